//! A regular grid whose cells are named by one packed `u64` key, for hash maps of cells
//! that cost 8 bytes a key and one SplitMix64 finalizer a lookup.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use glam::{DVec3, Vec3};

use crate::rng::mix64;

/// Bits of a cell number along one axis in a packed key: 2²¹ cells per axis.
pub const CELL_BITS: u32 = 21;

/// Cubic cells of one side laid from a low corner, each named by a packed key: the cell
/// numbers along x, y and z in bits 0–20, 21–41 and 42–62.
///
/// ```
/// use glam::{DVec3, Vec3};
/// use pointset_core::spatial::PackedCells;
///
/// let cells = PackedCells::new(DVec3::ZERO, 0.5);
/// let key = cells.key(Vec3::new(1.2, 0.1, 0.7)).ok_or("outside")?;
/// assert_eq!(key, 2 | 1 << 42);
/// assert_eq!(cells.moved(key, [-1, 0, 0]), cells.key(Vec3::new(0.7, 0.1, 0.7)));
/// assert_eq!(cells.moved(key, [0, -1, 0]), None); // below the low corner
/// assert_eq!(cells.key(Vec3::new(-1.0, 0.0, 0.0)), None);
/// # Ok::<(), &str>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PackedCells {
    low: DVec3,
    side: f64,
}

impl PackedCells {
    /// Cells of side `side` (positive) from the corner `low`.
    pub fn new(low: DVec3, side: f64) -> Self {
        Self { low, side }
    }

    /// The low corner of the cell with key 0.
    pub fn low(&self) -> DVec3 {
        self.low
    }

    /// The cell side.
    pub fn side(&self) -> f64 {
        self.side
    }

    /// The key of the cell holding `p`; `None` below the low corner or more than 2²¹
    /// cells above it along an axis.
    #[inline]
    pub fn key(&self, p: Vec3) -> Option<u64> {
        let q = ((p.as_dvec3() - self.low) / self.side).floor();
        let limit = f64::from(1u32 << CELL_BITS);
        (q.min_element() >= 0.0 && q.max_element() < limit)
            .then_some(q.x as u64 | (q.y as u64) << CELL_BITS | (q.z as u64) << (2 * CELL_BITS))
    }

    /// The key of the cell `step` cells from `key` along x, y and z; `None` where that
    /// leaves the grid.
    #[inline]
    pub fn moved(&self, key: u64, step: [i64; 3]) -> Option<u64> {
        let top = (1u64 << CELL_BITS) - 1;
        let mut moved = key;
        for (axis, offset) in step.into_iter().enumerate() {
            if offset == 0 {
                continue;
            }
            let shift = axis as u32 * CELL_BITS;
            let number = ((key >> shift) & top).checked_add_signed(offset)?;
            if number > top {
                return None;
            }
            moved = (moved & !(top << shift)) | number << shift;
        }
        Some(moved)
    }

    /// The keys of the up to six cells sharing a face with cell `key`, in the order x−, x+,
    /// y−, y+, z−, z+ (`None` off the grid): [`PackedCells::moved`] by one cell along each
    /// axis, without its general step (a neighbour count asks this for every sample).
    #[inline]
    pub fn face_neighbours(&self, key: u64) -> [Option<u64>; 6] {
        let top = (1u64 << CELL_BITS) - 1;
        let mut around = [None; 6];
        for axis in 0..3 {
            let shift = axis as u32 * CELL_BITS;
            let number = (key >> shift) & top;
            let others = key & !(top << shift);
            around[2 * axis] = (number > 0).then(|| others | (number - 1) << shift);
            around[2 * axis + 1] = (number < top).then(|| others | (number + 1) << shift);
        }
        around
    }
}

/// A hash map keyed by packed cell keys ([`PackedCells::key`]), hashed by [`CellHasher`].
pub type CellMap<V> = HashMap<u64, V, BuildHasherDefault<CellHasher>>;

/// A hasher for packed cell keys: SplitMix64's finalizer ([`mix64`]), which spreads every
/// bit of the key over the low bits the table's buckets are chosen by.
#[derive(Debug, Default)]
pub struct CellHasher(u64);

// Inlined across crates: a map of cells is built and looked up in the crate that uses it,
// and a call per hash cost `mls_surface::isolated_samples` a quarter of its time.
impl Hasher for CellHasher {
    #[inline]
    fn finish(&self) -> u64 {
        mix64(self.0)
    }

    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = self.0.rotate_left(8) ^ u64::from(b);
        }
    }

    #[inline]
    fn write_u64(&mut self, n: u64) {
        self.0 = n;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moving_a_key_matches_the_key_of_the_moved_point() {
        let cells = PackedCells::new(DVec3::new(-3.0, 1.0, 0.5), 0.25);
        let p = Vec3::new(-1.1, 2.3, 4.05);
        let Some(key) = cells.key(p) else {
            panic!("the point is inside the grid");
        };
        for dx in -1i64..=1 {
            for dy in -1i64..=1 {
                for dz in -1i64..=1 {
                    let shifted = p + Vec3::new(dx as f32, dy as f32, dz as f32) * 0.25;
                    assert_eq!(cells.moved(key, [dx, dy, dz]), cells.key(shifted));
                }
            }
        }
        let top = (1u64 << CELL_BITS) - 1;
        let corner = top | top << CELL_BITS | top << (2 * CELL_BITS);
        let steps = [
            [-1, 0, 0],
            [1, 0, 0],
            [0, -1, 0],
            [0, 1, 0],
            [0, 0, -1],
            [0, 0, 1],
        ];
        for k in [key, 0, top, corner] {
            assert_eq!(
                cells.face_neighbours(k),
                steps.map(|s| cells.moved(k, s)),
                "{k}"
            );
        }
        assert_eq!(cells.moved(top, [1, 0, 0]), None);
        assert_eq!(cells.moved(top, [-1, 0, 0]), Some(top - 1));
        let far = Vec3::new(-3.0 + 0.25 * (1u32 << CELL_BITS) as f32 + 1.0, 1.0, 0.5);
        assert_eq!(cells.key(far), None);
    }
}
