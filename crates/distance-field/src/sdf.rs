//! Signed distance + gradient grids sampled from any [`Surface`] (paper 000 §5.1 `D(S)`).

use glam::{Vec3, Vec4};
use pointset_core::{Aabb, Grid3, Surface};
use rayon::prelude::*;

use crate::error::{FieldError, Result, positive};

/// Where the nodes of a grid lie: `dims` nodes from `origin`, `spacing` apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSpec {
    /// Nodes along x, y, z.
    pub dims: [usize; 3],
    /// Position of node (0, 0, 0).
    pub origin: Vec3,
    /// Node spacing.
    pub spacing: f32,
}

impl GridSpec {
    /// A grid covering `bounds` grown by `margin` on every side, with `resolution` nodes
    /// along the longest side (at least 2).
    pub fn covering(bounds: Aabb, resolution: usize, margin: f32) -> Result<Self> {
        if resolution < 2 {
            return Err(FieldError::InvalidParameter {
                name: "resolution",
                value: resolution.to_string(),
                expected: "at least 2 nodes",
            });
        }
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(FieldError::InvalidParameter {
                name: "margin",
                value: margin.to_string(),
                expected: "a finite non-negative length",
            });
        }
        let b = bounds.inflated(margin);
        let longest = b.extent().max_element();
        positive("bounds extent", longest)?;
        let spacing = longest / (resolution - 1) as f32;
        let dims = (b.extent() / spacing)
            .to_array()
            .map(|e| (e.ceil() as usize + 1).max(2));
        Ok(Self {
            dims,
            origin: b.min,
            spacing,
        })
    }

    /// The sub-grid of nodes `lo..hi` (exclusive) of this grid.
    pub fn sub_box(&self, lo: [usize; 3], hi: [usize; 3]) -> Result<Self> {
        for a in 0..3 {
            if lo[a] >= hi[a] || hi[a] > self.dims[a] {
                return Err(FieldError::InvalidParameter {
                    name: "sub_box",
                    value: format!("{lo:?}..{hi:?}"),
                    expected: "a non-empty range of nodes inside the grid",
                });
            }
        }
        Ok(Self {
            dims: [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]],
            origin: self.origin
                + Vec3::new(lo[0] as f32, lo[1] as f32, lo[2] as f32) * self.spacing,
            spacing: self.spacing,
        })
    }

    /// World position of node `(i, j, k)`.
    pub fn node(&self, i: usize, j: usize, k: usize) -> Vec3 {
        self.origin + Vec3::new(i as f32, j as f32, k as f32) * self.spacing
    }
}

/// A grid of signed distances and their gradients: each node holds
/// `Vec4(distance, ∂x, ∂y, ∂z)`.
///
/// Distances are clamped to `[−band, band]`; gradients are kept unchanged beyond the band.
/// The gradient is the unit direction from the closest surface point to the node, oriented
/// toward increasing distance (the surface normal on the surface itself).
#[derive(Debug, Clone, PartialEq)]
pub struct SdfGrid {
    grid: Grid3<Vec4>,
    band: f32,
    undefined: usize,
}

impl SdfGrid {
    /// Samples `surface` at every node of `spec` (parallel over rows, deterministic).
    ///
    /// Nodes where the surface gives no answer get distance `+band` and a zero gradient and
    /// are counted in [`SdfGrid::undefined_nodes`]. Along each row, the previous node's
    /// distance plus the spacing bounds the next one's, which lets exact mesh searches prune.
    pub fn from_surface(
        surface: &(impl Surface + ?Sized),
        spec: &GridSpec,
        band: f32,
    ) -> Result<Self> {
        positive("band", band)?;
        positive("spacing", spec.spacing)?;
        let grid = Grid3::new(spec.dims, spec.origin, spec.spacing, Vec4::ZERO)?;
        let [nx, ny, _] = spec.dims;
        let mut data = grid.into_data();
        let undefined: usize = data
            .par_chunks_mut(nx)
            .enumerate()
            .map(|(row, out)| {
                let (j, k) = (row % ny, row / ny);
                let mut previous: Option<f32> = None;
                let mut missing = 0;
                for (i, slot) in out.iter_mut().enumerate() {
                    let q = spec.node(i, j, k);
                    let answer = match previous {
                        Some(d) => {
                            surface.signed_distance_bounded(q, d.abs() + spec.spacing * 1.001)
                        }
                        None => surface.signed_distance(q),
                    };
                    match answer {
                        Some((d, p)) => {
                            previous = Some(d);
                            *slot =
                                Vec4::new(d.clamp(-band, band), p.normal.x, p.normal.y, p.normal.z);
                        }
                        None => {
                            previous = None;
                            missing += 1;
                            *slot = Vec4::new(band, 0.0, 0.0, 0.0);
                        }
                    }
                }
                missing
            })
            .sum();
        Ok(Self {
            grid: Grid3::from_vec(spec.dims, spec.origin, spec.spacing, data)?,
            band,
            undefined,
        })
    }

    /// Wraps an existing grid of `(distance, gradient)` samples.
    pub fn from_grid(grid: Grid3<Vec4>, band: f32) -> Result<Self> {
        positive("band", band)?;
        Ok(Self {
            grid,
            band,
            undefined: 0,
        })
    }

    /// The underlying 4-channel grid.
    pub fn grid(&self) -> &Grid3<Vec4> {
        &self.grid
    }

    /// The clamping band.
    pub fn band(&self) -> f32 {
        self.band
    }

    /// Nodes where the surface gave no answer.
    pub fn undefined_nodes(&self) -> usize {
        self.undefined
    }

    /// Grid dimensions.
    pub fn dims(&self) -> [usize; 3] {
        self.grid.dims()
    }

    /// Distance at node `(i, j, k)`.
    pub fn distance(&self, i: usize, j: usize, k: usize) -> Option<f32> {
        self.grid.get(i, j, k).map(|v| v.x)
    }

    /// Gradient at node `(i, j, k)`.
    pub fn gradient(&self, i: usize, j: usize, k: usize) -> Option<Vec3> {
        self.grid.get(i, j, k).map(|v| Vec3::new(v.y, v.z, v.w))
    }

    /// Trilinearly interpolated distance and gradient at a world position.
    pub fn sample(&self, p: Vec3) -> Option<(f32, Vec3)> {
        self.grid
            .trilinear(p)
            .map(|v| (v.x, Vec3::new(v.y, v.z, v.w)))
    }

    /// The distance channel alone.
    pub fn distances(&self) -> Result<Grid3<f32>> {
        Ok(Grid3::from_vec(
            self.grid.dims(),
            self.grid.origin(),
            self.grid.spacing(),
            self.grid.data().iter().map(|v| v.x).collect(),
        )?)
    }
}
