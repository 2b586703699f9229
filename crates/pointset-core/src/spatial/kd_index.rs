//! A panic-free wrapper over `kiddo`'s immutable k-d tree.

use std::num::NonZeroUsize;

use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};

use crate::{Error, Result};

/// One query result: the index of a point in the indexed slice and its squared distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neighbour {
    /// Index into the slice the index was built from.
    pub index: usize,
    /// Squared Euclidean distance to the query.
    pub distance_squared: f32,
}

/// A key that sorts neighbours in the order every query of a [`KdIndex`] returns them:
/// nearest first, ties to the lower index. The squared distance's bits fill the high half
/// (squared distances are never negative, so their bits order as their values do, as
/// `f32::total_cmp` orders them) and the index the low half; an integer key sorts faster
/// than comparing floats. A `KdIndex` holds at most `u32::MAX` points, so its indices fit.
/// [`key_index`] reads the index back. The order holds for distances `≥ 0`, as squared
/// distances are; a negative one would sort after every positive one.
pub fn nearness_key(distance_squared: f32, index: u32) -> u64 {
    (u64::from(distance_squared.to_bits()) << 32) | u64::from(index)
}

/// The index a [`nearness_key`] was made with.
pub fn key_index(key: u64) -> u32 {
    (key & u64::from(u32::MAX)) as u32
}

/// A static k-d tree for k-nearest-neighbour and radius queries over 3D points.
///
/// Built once from a slice; the point at slice position `i` is reported as index `i`.
/// Unlike the raw tree it never panics: non-finite points or queries are errors, an empty
/// index answers every query with no neighbours, and data with many identical coordinates
/// (grid-aligned or voxel-centre points, exact duplicates) is supported — the immutable tree
/// splits by median and keeps equal values in one leaf, which the tests check.
///
/// Results are sorted by `(distance, index)`, so ties come back in a deterministic order.
pub struct KdIndex {
    tree: Option<ImmutableKdTree<f32, 3>>,
    points: Vec<Vec3>,
}

impl std::fmt::Debug for KdIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KdIndex")
            .field("len", &self.points.len())
            .finish()
    }
}

fn check_query(q: Vec3) -> Result<[f32; 3]> {
    if q.is_finite() {
        Ok(q.to_array())
    } else {
        Err(Error::NonFinite {
            what: "query point".into(),
            index: 0,
        })
    }
}

fn check_radius(radius: f32) -> Result<()> {
    if radius.is_finite() && radius >= 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name: "radius",
            value: radius.to_string(),
            expected: "a finite non-negative distance".into(),
        })
    }
}

impl KdIndex {
    /// Builds the index; errors if any point is NaN or infinite, the points span more
    /// than [`crate::MAX_SPAN`] (their squared distances would overflow), or there are more
    /// than `u32::MAX` points.
    ///
    /// From 262,144 points the tree is built on the current `rayon` pool (`kiddo`'s
    /// parallel construction): the same tree as on one thread, so the same answers, ties
    /// included (tested on a lattice of repeated points). 12 million points: 3.8 s on one
    /// thread, 2.7 s on two.
    pub fn new(points: &[Vec3]) -> Result<Self> {
        crate::error::check_finite_vec3(points, "indexed point")?;
        crate::check_span(points, "indexed points")?;
        if points.len() > u32::MAX as usize {
            return Err(Error::InvalidParameter {
                name: "points",
                value: points.len().to_string(),
                expected: "at most 2^32 - 1 points".into(),
            });
        }
        let tree = if points.is_empty() {
            None
        } else {
            let raw: Vec<[f32; 3]> = points.iter().map(|p| p.to_array()).collect();
            let tree =
                ImmutableKdTree::new_from_slice(&raw).map_err(|e| Error::InvalidParameter {
                    name: "points",
                    value: format!("{} points", points.len()),
                    expected: format!("a set the k-d tree accepts ({e})"),
                })?;
            Some(tree)
        };
        Ok(Self {
            tree,
            points: points.to_vec(),
        })
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the index holds no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The indexed points.
    pub fn points(&self) -> &[Vec3] {
        &self.points
    }

    /// The `k` nearest points to `q` (fewer if the index is smaller), nearest first.
    pub fn nearest(&self, q: Vec3, k: usize) -> Result<Vec<Neighbour>> {
        let query = check_query(q)?;
        let (Some(tree), Some(k)) = (&self.tree, NonZeroUsize::new(k)) else {
            return Ok(Vec::new());
        };
        let found = tree
            .query(&query)
            .nearest_n::<SquaredEuclidean<f32>>(k)
            .execute();
        Ok(Self::sorted(
            found.into_iter().map(|r| (r.item, r.distance)),
        ))
    }

    /// The nearest point to `q`, `None` for an empty index. Among points at exactly the
    /// same distance it returns one chosen by the tree's fixed traversal order (the same
    /// one every time), not necessarily the lowest index.
    pub fn nearest_one(&self, q: Vec3) -> Result<Option<Neighbour>> {
        let query = check_query(q)?;
        let Some(tree) = &self.tree else {
            return Ok(None);
        };
        let found = tree
            .query(&query)
            .nearest_one::<SquaredEuclidean<f32>>()
            .execute();
        Ok(Some(Neighbour {
            index: found.item as usize,
            distance_squared: found.distance,
        }))
    }

    /// Every point within distance `radius` of `q` (inclusive), nearest first.
    pub fn within(&self, q: Vec3, radius: f32) -> Result<Vec<Neighbour>> {
        Ok(Self::sorted(self.within_unsorted(q, radius)?))
    }

    /// Every point within distance `radius` of `q` (inclusive) as `(index, squared
    /// distance)`, in no particular order.
    pub(super) fn within_unsorted(
        &self,
        q: Vec3,
        radius: f32,
    ) -> Result<impl Iterator<Item = (u32, f32)>> {
        let query = check_query(q)?;
        check_radius(radius)?;
        let found = match &self.tree {
            Some(tree) => tree
                .query(&query)
                .within::<SquaredEuclidean<f32>>(radius * radius)
                .unsorted()
                .execute(),
            None => Vec::new(),
        };
        Ok(found.into_iter().map(|r| (r.item, r.distance)))
    }

    /// At most `k` nearest points within `radius` of `q`, nearest first.
    ///
    /// The search is bounded by `radius`, so a query far from every point is cheap.
    pub fn nearest_within(&self, q: Vec3, k: usize, radius: f32) -> Result<Vec<Neighbour>> {
        let query = check_query(q)?;
        check_radius(radius)?;
        let (Some(tree), Some(k)) = (&self.tree, NonZeroUsize::new(k)) else {
            return Ok(Vec::new());
        };
        let found = tree
            .query(&query)
            .nearest_n::<SquaredEuclidean<f32>>(k)
            .within(radius * radius)
            .execute();
        Ok(Self::sorted(
            found.into_iter().map(|r| (r.item, r.distance)),
        ))
    }

    /// The nearest point to `q` at a non-zero distance, looking past any number of exact
    /// copies of `q`; `None` when every indexed point coincides with `q`.
    ///
    /// Asks for 8 neighbours, then doubles the count while all of them sit exactly on `q`,
    /// so a point with `c` copies costs a k-nearest query with `k` about `2c`.
    pub fn nearest_distinct(&self, q: Vec3) -> Result<Option<Neighbour>> {
        let mut k = 8;
        loop {
            let found = self.nearest(q, k)?;
            if let Some(n) = found.iter().find(|n| n.distance_squared > 0.0) {
                return Ok(Some(*n));
            }
            if found.len() < k {
                return Ok(None);
            }
            k *= 2;
        }
    }

    /// The median distance from the points to their nearest distinct point (exact duplicates
    /// are looked past), over every point of indices up to 4,096 points and an even sample of
    /// about 4,096 of larger ones; 0 when no point has a distinct neighbour (fewer than two
    /// different positions).
    ///
    /// ```
    /// use glam::Vec3;
    /// use pointset_core::KdIndex;
    /// // A 10 × 10 grid of spacing 0.5, every point written three times.
    /// let grid: Vec<Vec3> = (0..300)
    ///     .map(|i| Vec3::new((i % 10) as f32, ((i / 10) % 10) as f32, 0.0) * 0.5)
    ///     .collect();
    /// let index = KdIndex::new(&grid)?;
    /// assert_eq!(index.median_spacing()?, 0.5);
    /// # Ok::<(), pointset_core::Error>(())
    /// ```
    pub fn median_spacing(&self) -> Result<f32> {
        let step = (self.points.len() / 4096).max(1);
        let mut d = Vec::with_capacity(self.points.len() / step + 1);
        for p in self.points.iter().step_by(step) {
            if let Some(n) = self.nearest_distinct(*p)? {
                d.push(n.distance_squared.sqrt());
            }
        }
        d.sort_by(f32::total_cmp);
        Ok(d.get(d.len() / 2).copied().unwrap_or(0.0))
    }

    fn sorted(found: impl Iterator<Item = (u32, f32)>) -> Vec<Neighbour> {
        // Every key is distinct (indices are), so an unstable sort gives the one order
        // there is.
        let mut keys: Vec<u64> = found.map(|(i, d2)| nearness_key(d2, i)).collect();
        keys.sort_unstable();
        keys.into_iter()
            .map(|key| Neighbour {
                index: key_index(key) as usize,
                distance_squared: f32::from_bits((key >> 32) as u32),
            })
            .collect()
    }
}
