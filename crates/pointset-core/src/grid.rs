//! Regular 3D grids of samples.

use std::ops::{Add, Mul};

use glam::Vec3;

use crate::{Aabb, Error, Result};

/// A dense regular grid of samples of type `T`, stored x-fastest (`index = i + nx·(j + ny·k)`).
///
/// Node `(i, j, k)` sits at world position `origin + spacing·(i, j, k)`; the grid covers the
/// box from `origin` to `origin + spacing·(dims − 1)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid3<T> {
    dims: [usize; 3],
    origin: Vec3,
    spacing: f32,
    data: Vec<T>,
}

impl<T: Clone> Grid3<T> {
    /// A grid of `dims` nodes filled with `fill`.
    ///
    /// Errors when a dimension is zero, the node count overflows, or `spacing` is not a
    /// positive finite number, or `origin` is not finite; [`Error::OutOfMemory`] when the
    /// samples cannot be allocated (instead of aborting the process).
    pub fn new(dims: [usize; 3], origin: Vec3, spacing: f32, fill: T) -> Result<Self> {
        let count = Self::validate(dims, origin, spacing)?;
        let mut data = Vec::new();
        data.try_reserve_exact(count)
            .map_err(|_| Error::OutOfMemory {
                what: format!("a grid of {} × {} × {} samples", dims[0], dims[1], dims[2]),
                bytes: count as u128 * std::mem::size_of::<T>() as u128,
            })?;
        data.resize(count, fill);
        Ok(Self {
            dims,
            origin,
            spacing,
            data,
        })
    }
}

impl<T> Grid3<T> {
    fn validate(dims: [usize; 3], origin: Vec3, spacing: f32) -> Result<usize> {
        if dims.contains(&0) {
            return Err(Error::InvalidParameter {
                name: "dims",
                value: format!("{dims:?}"),
                expected: "every dimension at least 1".into(),
            });
        }
        if !(spacing.is_finite() && spacing > 0.0) {
            return Err(Error::InvalidParameter {
                name: "spacing",
                value: spacing.to_string(),
                expected: "a positive finite number".into(),
            });
        }
        if !origin.is_finite() {
            return Err(Error::NonFinite {
                what: "grid origin".into(),
                index: 0,
            });
        }
        dims.iter()
            .try_fold(1usize, |acc, &d| acc.checked_mul(d))
            .ok_or_else(|| Error::InvalidParameter {
                name: "dims",
                value: format!("{dims:?}"),
                expected: "a node count that fits in memory".into(),
            })
    }

    /// A grid from existing samples (x-fastest order).
    pub fn from_vec(dims: [usize; 3], origin: Vec3, spacing: f32, data: Vec<T>) -> Result<Self> {
        let count = Self::validate(dims, origin, spacing)?;
        if data.len() != count {
            return Err(Error::LengthMismatch {
                what: "grid samples".into(),
                expected: count,
                found: data.len(),
            });
        }
        Ok(Self {
            dims,
            origin,
            spacing,
            data,
        })
    }

    /// Number of nodes along x, y and z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// World position of node (0, 0, 0).
    pub fn origin(&self) -> Vec3 {
        self.origin
    }

    /// Distance between neighbouring nodes.
    pub fn spacing(&self) -> f32 {
        self.spacing
    }

    /// The box spanned by the nodes.
    pub fn bounds(&self) -> Aabb {
        let far = Vec3::new(
            (self.dims[0] - 1) as f32,
            (self.dims[1] - 1) as f32,
            (self.dims[2] - 1) as f32,
        );
        Aabb::new(self.origin, self.origin + far * self.spacing)
    }

    /// All samples, x-fastest.
    pub fn data(&self) -> &[T] {
        &self.data
    }

    /// All samples, mutable, x-fastest.
    pub fn data_mut(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// Consumes the grid and returns its samples.
    pub fn into_data(self) -> Vec<T> {
        self.data
    }

    /// Linear index of node `(i, j, k)`, or `None` outside the grid.
    pub fn index(&self, i: usize, j: usize, k: usize) -> Option<usize> {
        let [nx, ny, nz] = self.dims;
        (i < nx && j < ny && k < nz).then(|| i + nx * (j + ny * k))
    }

    /// Node coordinates of linear index `index`, or `None` outside the grid.
    pub fn coords(&self, index: usize) -> Option<[usize; 3]> {
        let [nx, ny, _] = self.dims;
        (index < self.data.len()).then(|| [index % nx, (index / nx) % ny, index / (nx * ny)])
    }

    /// World position of node `(i, j, k)` (defined for any indices, also outside the grid).
    pub fn world(&self, i: usize, j: usize, k: usize) -> Vec3 {
        self.origin + Vec3::new(i as f32, j as f32, k as f32) * self.spacing
    }

    /// Continuous grid coordinates of a world position (node `(i,j,k)` maps to `(i,j,k)`).
    pub fn to_grid(&self, p: Vec3) -> Vec3 {
        (p - self.origin) / self.spacing
    }

    /// Sample at node `(i, j, k)`.
    pub fn get(&self, i: usize, j: usize, k: usize) -> Option<&T> {
        self.index(i, j, k).map(|n| &self.data[n])
    }

    /// Mutable sample at node `(i, j, k)`.
    pub fn get_mut(&mut self, i: usize, j: usize, k: usize) -> Option<&mut T> {
        self.index(i, j, k).map(move |n| &mut self.data[n])
    }
}

impl Grid3<f32> {
    /// The smallest and largest sample, NaN ignored (`(∞, −∞)` when no sample is a number):
    /// what a field that never crosses a level ranges over, for the error that says so.
    ///
    /// ```
    /// use glam::Vec3;
    /// use pointset_core::Grid3;
    /// let g = Grid3::from_vec([3, 1, 1], Vec3::ZERO, 1.0, vec![0.5, f32::NAN, -2.0])?;
    /// assert_eq!(g.value_range(), (-2.0, 0.5));
    /// # Ok::<(), pointset_core::Error>(())
    /// ```
    pub fn value_range(&self) -> (f32, f32) {
        self.data
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            })
    }
}

impl<T> Grid3<T>
where
    T: Copy + Add<Output = T> + Mul<f32, Output = T>,
{
    /// Trilinear interpolation at world position `p`; `None` outside the grid's box or for a
    /// non-finite `p`. Works for `f32`, `Vec3`, `Vec4` and any type with the same arithmetic.
    pub fn trilinear(&self, p: Vec3) -> Option<T> {
        let g = self.to_grid(p);
        if !g.is_finite() || g.min_element() < 0.0 {
            return None;
        }
        let mut base = [0usize; 3];
        let mut frac = [0f32; 3];
        for axis in 0..3 {
            let last = (self.dims[axis] - 1) as f32;
            if g[axis] > last {
                return None;
            }
            // Clamp the cell so that the far boundary interpolates inside the last cell.
            let cell = g[axis].floor().min((last - 1.0).max(0.0));
            base[axis] = cell as usize;
            frac[axis] = g[axis] - cell;
        }
        let step = |axis: usize| usize::from(self.dims[axis] > 1);
        let mut acc: Option<T> = None;
        for corner in 0..8usize {
            let offs = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            let mut weight = 1.0;
            let mut idx = [0usize; 3];
            for axis in 0..3 {
                let o = offs[axis] * step(axis);
                idx[axis] = base[axis] + o;
                weight *= if offs[axis] == 1 {
                    frac[axis]
                } else {
                    1.0 - frac[axis]
                };
            }
            let v = *self.get(idx[0], idx[1], idx[2])? * weight;
            acc = Some(match acc {
                Some(a) => a + v,
                None => v,
            });
        }
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_round_trip() {
        let g = Grid3::new([3, 4, 5], Vec3::ZERO, 1.0, 0u8).unwrap();
        for n in 0..60 {
            let [i, j, k] = g.coords(n).unwrap();
            assert_eq!(g.index(i, j, k), Some(n));
        }
        assert!(g.index(3, 0, 0).is_none());
        assert!(g.coords(60).is_none());
    }

    #[test]
    fn a_grid_too_large_to_allocate_is_an_error_not_an_abort() {
        // 2^50 samples of 4 bytes: 4 PiB, more than any machine has.
        let err = Grid3::new([1 << 20, 1 << 20, 1 << 10], Vec3::ZERO, 1.0, 0f32).unwrap_err();
        let text = err.to_string();
        assert!(
            matches!(err, Error::OutOfMemory { bytes, .. } if bytes == 1 << 52),
            "{text}"
        );
        assert!(text.contains("1048576 × 1048576 × 1024"), "{text}");
    }

    #[test]
    fn trilinear_reproduces_linear_functions() {
        let f = |p: Vec3| 2.0 * p.x - 3.0 * p.y + 0.5 * p.z + 1.0;
        let origin = Vec3::new(-1.0, 0.5, 2.0);
        let mut g = Grid3::new([5, 6, 7], origin, 0.25, 0.0f32).unwrap();
        for k in 0..7 {
            for j in 0..6 {
                for i in 0..5 {
                    let p = g.world(i, j, k);
                    *g.get_mut(i, j, k).unwrap() = f(p);
                }
            }
        }
        for t in 0..50 {
            let s = t as f32 / 49.0;
            let p = origin + Vec3::new(s * 1.0, (1.0 - s) * 1.25, (s * 7.0).fract() * 1.5);
            let v = g.trilinear(p).unwrap();
            assert!((v - f(p)).abs() < 1e-4, "{v} vs {}", f(p));
        }
        assert!(g.trilinear(origin - Vec3::X).is_none());
        assert!(g.trilinear(Vec3::NAN).is_none());
    }

    #[test]
    fn invalid_grids_are_errors() {
        assert!(Grid3::new([0, 1, 1], Vec3::ZERO, 1.0, 0.0f32).is_err());
        assert!(Grid3::new([1, 1, 1], Vec3::ZERO, -1.0, 0.0f32).is_err());
        assert!(Grid3::new([usize::MAX, 2, 2], Vec3::ZERO, 1.0, 0.0f32).is_err());
        assert!(Grid3::from_vec([2, 2, 2], Vec3::ZERO, 1.0, vec![0.0f32; 7]).is_err());
    }
}
