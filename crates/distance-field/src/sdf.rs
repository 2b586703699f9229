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
/// Nodes within `band` of the surface hold the exact signed distance and its gradient — the
/// unit direction from the closest surface point to the node, oriented toward increasing
/// distance (the surface normal on the surface itself). Nodes farther away hold `±band` and
/// a zero gradient: the values of the clamped field.
#[derive(Debug, Clone, PartialEq)]
pub struct SdfGrid {
    grid: Grid3<Vec4>,
    band: f32,
    far: usize,
    undefined: usize,
}

/// A node whose distance is not known yet (farther than the band).
const UNKNOWN: f32 = f32::INFINITY;

impl SdfGrid {
    /// Samples `surface` at every node of `spec` (parallel over rows, deterministic).
    ///
    /// 1. Every node asks for the surface within `band` only. Along a row the previous
    ///    node's distance plus the spacing bounds the next one's, so exact mesh searches
    ///    prune to a small ball.
    /// 2. Nodes with no surface within `band` take the sign of their 6-connected region of
    ///    such nodes, read from a neighbouring node that has a distance. This is exact when
    ///    `band` exceeds the spacing: two neighbouring nodes on opposite sides of the surface
    ///    would both lie within one spacing of it. A region with no such neighbour (no
    ///    surface near the grid at all) asks the surface once, without a limit.
    ///
    /// Errors when `band` is not larger than the spacing.
    pub fn from_surface(
        surface: &(impl Surface + ?Sized),
        spec: &GridSpec,
        band: f32,
    ) -> Result<Self> {
        positive("band", band)?;
        positive("spacing", spec.spacing)?;
        if band <= spec.spacing {
            return Err(FieldError::InvalidParameter {
                name: "band",
                value: format!("{band} (spacing {})", spec.spacing),
                expected: "a band wider than the grid spacing",
            });
        }
        let grid = Grid3::new(spec.dims, spec.origin, spec.spacing, Vec4::ZERO)?;
        let [nx, ny, _] = spec.dims;
        let mut data = grid.into_data();
        data.par_chunks_mut(nx).enumerate().for_each(|(row, out)| {
            let (j, k) = (row % ny, row / ny);
            let mut previous: Option<f32> = None;
            for (i, slot) in out.iter_mut().enumerate() {
                let q = spec.node(i, j, k);
                let hinted = previous
                    .map(|d| d.abs() + spec.spacing * 1.001)
                    .filter(|&bound| bound < band)
                    .and_then(|bound| surface.signed_distance_within(q, bound));
                let answer = hinted.or_else(|| surface.signed_distance_within(q, band));
                previous = answer.map(|(d, _)| d);
                *slot = match answer {
                    Some((d, p)) => Vec4::new(d, p.normal.x, p.normal.y, p.normal.z),
                    None => Vec4::new(UNKNOWN, 0.0, 0.0, 0.0),
                };
            }
        });
        let far = data.iter().filter(|v| v.x == UNKNOWN).count();
        let undefined = fill_far_signs(&mut data, spec, band, surface);
        Ok(Self {
            grid: Grid3::from_vec(spec.dims, spec.origin, spec.spacing, data)?,
            band,
            far,
            undefined,
        })
    }

    /// Wraps an existing grid of `(distance, gradient)` samples.
    pub fn from_grid(grid: Grid3<Vec4>, band: f32) -> Result<Self> {
        positive("band", band)?;
        Ok(Self {
            grid,
            band,
            far: 0,
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

    /// Nodes farther than the band from the surface (sign from their region).
    pub fn far_nodes(&self) -> usize {
        self.far
    }

    /// Nodes whose sign could not be determined (the surface gave no answer anywhere in
    /// their region); they hold `+band`.
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

/// Gives every node still marked unknown `±band`, with the sign of its 6-connected region of
/// unknown nodes: the majority sign of the known nodes bordering the region (each contact
/// between a region node and a known neighbour counts once; a tie counts as outside), or
/// one unlimited surface query when the region borders no known node. Returns the number of
/// nodes left undefined.
///
/// Majority, not the first neighbour met: for a closed, consistently oriented surface every
/// border node has the region's sign and the two agree. For open sheets (petals, a ground
/// plane's rim) a few border nodes can carry the other side's sign. Taking the first one met
/// then flipped the whole air above a quilted flower field to `−band` (search-only output,
/// flowers fixture, seed 11: window errors above 1 for a verbatim copy).
fn fill_far_signs(
    data: &mut [Vec4],
    spec: &GridSpec,
    band: f32,
    surface: &(impl Surface + ?Sized),
) -> usize {
    let [nx, ny, nz] = spec.dims;
    let mut visited = vec![false; data.len()];
    let mut region = Vec::new();
    let mut undefined = 0;
    for seed in 0..data.len() {
        if visited[seed] || data[seed].x != UNKNOWN {
            continue;
        }
        region.clear();
        region.push(seed);
        visited[seed] = true;
        let (mut outside, mut inside) = (0usize, 0usize);
        let mut head = 0;
        while head < region.len() {
            let n = region[head];
            head += 1;
            let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
            let neighbours = [
                (i > 0).then(|| n - 1),
                (i + 1 < nx).then(|| n + 1),
                (j > 0).then(|| n - nx),
                (j + 1 < ny).then(|| n + nx),
                (k > 0).then(|| n - nx * ny),
                (k + 1 < nz).then(|| n + nx * ny),
            ];
            for m in neighbours.into_iter().flatten() {
                let d = data[m].x;
                if d != UNKNOWN {
                    if d > 0.0 {
                        outside += 1;
                    } else if d < 0.0 {
                        inside += 1;
                    }
                } else if !visited[m] {
                    visited[m] = true;
                    region.push(m);
                }
            }
        }
        let majority = (outside + inside > 0).then_some(if inside > outside { -1.0 } else { 1.0 });
        let sign = majority.or_else(|| {
            let (i, j, k) = (seed % nx, (seed / nx) % ny, seed / (nx * ny));
            surface
                .signed_distance(spec.node(i, j, k))
                .map(|(d, _)| if d < 0.0 { -1.0 } else { 1.0 })
        });
        if sign.is_none() {
            undefined += region.len();
        }
        for &n in &region {
            data[n] = Vec4::new(sign.unwrap_or(1.0) * band, 0.0, 0.0, 0.0);
        }
    }
    undefined
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    /// A surface that answers nothing: the fill must rely on the known border nodes.
    struct Silent;

    impl Surface for Silent {
        fn closest_point(&self, _: Vec3) -> Option<pointset_core::SurfacePoint> {
            None
        }
    }

    #[test]
    fn a_far_region_takes_the_majority_sign_of_its_border() {
        // A 3 × 3 × 1 slab: the centre is unknown, its four 6-connected neighbours are known,
        // and only the first the walk meets (the left one) is inside.
        let spec = GridSpec {
            dims: [3, 3, 1],
            origin: Vec3::ZERO,
            spacing: 1.0,
        };
        let mut data = vec![Vec4::new(0.5, 0.0, 0.0, 1.0); 9];
        data[3] = Vec4::new(-0.5, 0.0, 0.0, -1.0); // left of the centre: met first
        data[4] = Vec4::new(UNKNOWN, 0.0, 0.0, 0.0);
        let undefined = fill_far_signs(&mut data, &spec, 2.0, &Silent);
        assert_eq!(undefined, 0);
        assert_eq!(data[4].x, 2.0, "three outside contacts outvote one inside");
        // All contacts inside: the region is inside.
        let mut data = vec![Vec4::new(-0.5, 0.0, 0.0, -1.0); 9];
        data[4] = Vec4::new(UNKNOWN, 0.0, 0.0, 0.0);
        fill_far_signs(&mut data, &spec, 2.0, &Silent);
        assert_eq!(data[4].x, -2.0);
        // No known node and a silent surface: undefined, held at +band.
        let mut data = vec![Vec4::new(UNKNOWN, 0.0, 0.0, 0.0); 9];
        assert_eq!(fill_far_signs(&mut data, &spec, 2.0, &Silent), 9);
        assert!(data.iter().all(|v| v.x == 2.0));
    }
}
