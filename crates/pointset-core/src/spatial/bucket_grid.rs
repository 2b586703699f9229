//! A hashed regular grid of point buckets supporting insertion and removal.

use std::collections::HashMap;
use std::collections::hash_map::DefaultHasher;
use std::hash::BuildHasherDefault;

use glam::{IVec3, Vec3};

use crate::{Aabb, Error, Result};

/// Handle to a point stored in a [`BucketGrid`]; stays valid until the point is removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct PointKey(u32);

impl PointKey {
    /// The key as a plain number (slot index).
    pub fn get(self) -> u32 {
        self.0
    }
}

type CellMap = HashMap<IVec3, Vec<u32>, BuildHasherDefault<DefaultHasher>>;

/// A dynamic spatial index: points with payloads of type `T` hashed into cubic cells.
///
/// Insert, remove, remove-inside-box and radius/box queries cost time proportional to the
/// number of cells touched plus points found. Query results are sorted by key, and keys are
/// reused slots in a fixed order, so identical operation sequences give identical results.
#[derive(Debug, Clone)]
pub struct BucketGrid<T> {
    cell_size: f32,
    cells: CellMap,
    slots: Vec<Option<(Vec3, T)>>,
    free: Vec<u32>,
    len: usize,
}

impl<T> BucketGrid<T> {
    /// An empty grid with cubic cells of edge `cell_size` (positive and finite).
    pub fn new(cell_size: f32) -> Result<Self> {
        if !(cell_size.is_finite() && cell_size > 0.0) {
            return Err(Error::InvalidParameter {
                name: "cell_size",
                value: cell_size.to_string(),
                expected: "a positive finite length".into(),
            });
        }
        Ok(Self {
            cell_size,
            cells: CellMap::default(),
            slots: Vec::new(),
            free: Vec::new(),
            len: 0,
        })
    }

    /// Cell edge length.
    pub fn cell_size(&self) -> f32 {
        self.cell_size
    }

    /// Number of stored points.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no points are stored.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn cell_of(&self, p: Vec3) -> IVec3 {
        // Saturating float→int casts keep far-away points in the outermost cells.
        (p / self.cell_size).floor().as_ivec3()
    }

    /// Stores `value` at `position`; errors on a non-finite position.
    pub fn insert(&mut self, position: Vec3, value: T) -> Result<PointKey> {
        if !position.is_finite() {
            return Err(Error::NonFinite {
                what: "inserted point".into(),
                index: self.len,
            });
        }
        let slot = match self.free.pop() {
            Some(slot) => {
                self.slots[slot as usize] = Some((position, value));
                slot
            }
            None => {
                let slot =
                    u32::try_from(self.slots.len()).map_err(|_| Error::InvalidParameter {
                        name: "len",
                        value: self.slots.len().to_string(),
                        expected: "at most 2^32 points".into(),
                    })?;
                self.slots.push(Some((position, value)));
                slot
            }
        };
        let cell = self.cell_of(position);
        self.cells.entry(cell).or_default().push(slot);
        self.len += 1;
        Ok(PointKey(slot))
    }

    /// The point and payload under `key`, if still present.
    pub fn get(&self, key: PointKey) -> Option<(Vec3, &T)> {
        self.slots
            .get(key.0 as usize)?
            .as_ref()
            .map(|(p, v)| (*p, v))
    }

    /// Removes the point under `key` and returns it.
    pub fn remove(&mut self, key: PointKey) -> Option<(Vec3, T)> {
        let (position, value) = self.slots.get_mut(key.0 as usize)?.take()?;
        let cell = self.cell_of(position);
        if let Some(bucket) = self.cells.get_mut(&cell) {
            bucket.retain(|&s| s != key.0);
            if bucket.is_empty() {
                self.cells.remove(&cell);
            }
        }
        self.free.push(key.0);
        self.len -= 1;
        Some((position, value))
    }

    /// Calls `visit` for each stored point in cells overlapping `region` (unfiltered).
    fn candidates(&self, region: &Aabb, mut visit: impl FnMut(u32, Vec3)) {
        let lo = self.cell_of(region.min);
        let hi = self.cell_of(region.max);
        // In 64 bits: boxes reaching the saturated outermost cells would overflow i32.
        let span = hi.as_i64vec3() - lo.as_i64vec3() + glam::I64Vec3::ONE;
        let cells_in_box = span.x.saturating_mul(span.y).saturating_mul(span.z);
        if cells_in_box > self.cells.len() as i64 {
            // Sparse grid or huge box: scan occupied cells instead of the box's cells.
            for (cell, bucket) in &self.cells {
                if cell.cmpge(lo).all() && cell.cmple(hi).all() {
                    self.visit_bucket(bucket, &mut visit);
                }
            }
        } else {
            for z in lo.z..=hi.z {
                for y in lo.y..=hi.y {
                    for x in lo.x..=hi.x {
                        if let Some(bucket) = self.cells.get(&IVec3::new(x, y, z)) {
                            self.visit_bucket(bucket, &mut visit);
                        }
                    }
                }
            }
        }
    }

    fn visit_bucket(&self, bucket: &[u32], visit: &mut impl FnMut(u32, Vec3)) {
        for &slot in bucket {
            if let Some(Some((p, _))) = self.slots.get(slot as usize) {
                visit(slot, *p);
            }
        }
    }

    /// Keys of all points inside `region` (boundary included), sorted.
    pub fn query_box(&self, region: &Aabb) -> Vec<PointKey> {
        let mut out = Vec::new();
        self.candidates(region, |slot, p| {
            if region.contains(p) {
                out.push(PointKey(slot));
            }
        });
        out.sort_unstable();
        out
    }

    /// Keys of all points within distance `radius` of `center` (inclusive), sorted.
    pub fn query_radius(&self, center: Vec3, radius: f32) -> Vec<PointKey> {
        if !(center.is_finite() && radius.is_finite() && radius >= 0.0) {
            return Vec::new();
        }
        let region = Aabb::new(center - Vec3::splat(radius), center + Vec3::splat(radius));
        let r2 = radius * radius;
        let mut out = Vec::new();
        self.candidates(&region, |slot, p| {
            if p.distance_squared(center) <= r2 {
                out.push(PointKey(slot));
            }
        });
        out.sort_unstable();
        out
    }

    /// Removes every point inside `region` and returns them in key order.
    pub fn remove_inside_box(&mut self, region: &Aabb) -> Vec<(Vec3, T)> {
        self.query_box(region)
            .into_iter()
            .filter_map(|key| self.remove(key))
            .collect()
    }

    /// All stored points in key order.
    pub fn iter(&self) -> impl Iterator<Item = (PointKey, Vec3, &T)> {
        self.slots
            .iter()
            .enumerate()
            .filter_map(|(i, s)| s.as_ref().map(|(p, v)| (PointKey(i as u32), *p, v)))
    }
}
