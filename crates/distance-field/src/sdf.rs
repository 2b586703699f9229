//! Signed distance + gradient grids sampled from any [`Surface`] (paper 000 §5.1 `D(S)`).

use glam::{Vec3, Vec4};
use pointset_core::{Aabb, BandAnswer, Grid3, RunContext, Surface};
use rayon::prelude::*;

use crate::error::{FieldError, Result, positive};
use crate::far_signs::{FarSigns, UNKNOWN, fill_far_signs};

/// Most nodes per side of the cubic blocks whose queries are asked through one
/// [`Surface::prepared_near`] preparation.
const MAX_BLOCK: usize = 8;

/// Blocks of fewer nodes per side than this are not prepared: too few queries share it.
const MIN_BLOCK: usize = 3;

/// Layers (nodes of one `k`) [`SdfGrid::from_surface_in`] samples at least between two
/// progress reports and checks for cancellation (rounded up to whole blocks): their block
/// rows keep every worker busy, and the workers wait for each other only once per group.
const LAYERS_PER_REPORT: usize = 4;

/// The stage name [`SdfGrid::from_surface_in`] reports progress under.
pub const SAMPLING_STAGE: &str = "distance field";

/// How the grid is cut into blocks sharing one preparation of `surface` on a grid of
/// `spacing`: cubes of as many nodes a side as its [`Surface::preparation_reach`] (half a
/// block's diagonal) spans, at most [`MAX_BLOCK`]; squares of one layer where a cube
/// would have fewer than [`MIN_BLOCK`] a side (a square's diagonal is shorter, so it can
/// be wider) and a square has enough; `None` when neither has, or the surface gains
/// nothing from preparing. Cubes where they fit: a preparation gathers the samples in a
/// ball reaching a few support radii past the block, and a layer's square shared that
/// ball with no other layer, so each sample was gathered again for every layer within
/// the ball's reach.
fn prepared_blocks(surface: &(impl Surface + ?Sized), spacing: f32) -> Option<Blocks> {
    let reach = surface.preparation_reach()?;
    // Nodes along a side of a block whose diagonal spans `diagonal` spacings a side; a
    // NaN or negative ratio gives 1, an infinite one the most (`as` saturates).
    let side = |diagonal: f32| {
        let intervals = (2.0 * reach / (spacing * diagonal)).floor() as usize;
        intervals.saturating_add(1).min(MAX_BLOCK)
    };
    let (cube, square) = (side(3.0f32.sqrt()), side(2.0f32.sqrt()));
    if cube >= MIN_BLOCK {
        Some(Blocks {
            side: cube,
            depth: cube,
            prepare: true,
        })
    } else {
        (square >= MIN_BLOCK).then_some(Blocks {
            side: square,
            depth: 1,
            prepare: true,
        })
    }
}

/// What [`Surface::prepared_near`] gave for each block of a row of blocks, `None` for a
/// block not asked yet.
type Prepared<'s> = Vec<Option<Option<Box<dyn Surface + 's>>>>;

/// How the grid is cut into blocks: `side` nodes a side in x and y, `depth` layers,
/// `prepare` whether each block's queries share a preparation of the surface.
#[derive(Clone, Copy)]
struct Blocks {
    side: usize,
    depth: usize,
    prepare: bool,
}

/// Samples the rows `block_row · side ..` (up to `side` of them) of the layers from `k0`
/// (`layers`, up to `depth` of them, each the rows of one layer), each block of
/// `side` × `side` × `depth` nodes through one preparation of the surface, made when the
/// block's first node is asked.
fn sample_block_row<'s, S: Surface + ?Sized>(
    surface: &'s S,
    spec: &GridSpec,
    band: f32,
    blocks: Blocks,
    (block_row, k0): (usize, usize),
    layers: Vec<&mut [Vec4]>,
) {
    let [nx, ny, nz] = spec.dims;
    let side = blocks.side;
    let mut prepared: Prepared<'s> = (0..nx.div_ceil(side)).map(|_| None).collect();
    let preparation = |block: usize| {
        if !blocks.prepare {
            return None;
        }
        let lo = [block * side, block_row * side, k0];
        let hi = [
            (lo[0] + side).min(nx) - 1,
            (lo[1] + side).min(ny) - 1,
            (k0 + blocks.depth).min(nz) - 1,
        ];
        let (a, b) = (
            spec.node(lo[0], lo[1], lo[2]),
            spec.node(hi[0], hi[1], hi[2]),
        );
        surface.prepared_near(0.5 * (a + b), 0.5 * a.distance(b))
    };
    for (dk, rows) in layers.into_iter().enumerate() {
        for (dj, out) in rows.chunks_mut(nx).enumerate() {
            let at = (block_row * side + dj, k0 + dk);
            sample_row(
                surface,
                spec,
                band,
                at,
                out,
                (side, &mut prepared),
                &preparation,
            );
        }
    }
}

/// Samples row `(j, k)` of `spec` into `out`: each node's signed distance and gradient
/// within `band`, [`UNKNOWN`] beyond it. The surface prepared for a node's block
/// (`prepared`, filled in by `prepare`) answers where there is one, `surface`
/// otherwise. The last node that answered with a clearance, and that clearance, are
/// kept: the nodes within it are beyond the band without asking.
fn sample_row<'s, S: Surface + ?Sized>(
    surface: &'s S,
    spec: &GridSpec,
    band: f32,
    (j, k): (usize, usize),
    out: &mut [Vec4],
    (side, prepared): (usize, &mut Prepared<'s>),
    prepare: &dyn Fn(usize) -> Option<Box<dyn Surface + 's>>,
) {
    let mut previous: Option<f32> = None;
    let mut clear: Option<(Vec3, f32)> = None;
    for (i, slot) in out.iter_mut().enumerate() {
        let q = spec.node(i, j, k);
        let cleared = clear.is_some_and(|(at, radius)| at.distance(q) * (1.0 + 1e-5) < radius);
        let likely = previous.map(|d| d.abs() + spec.spacing * 1.001);
        let answer = if cleared {
            None
        } else {
            let block = &mut prepared[i / side];
            let band_answer = match block.get_or_insert_with(|| prepare(i / side)) {
                Some(prepared) => prepared.signed_distance_or_clearance(q, band, likely),
                None => surface.signed_distance_or_clearance(q, band, likely),
            };
            match band_answer {
                BandAnswer::Within { distance, closest } => Some((distance, closest)),
                BandAnswer::Beyond { clearance } => {
                    if clearance > 0.0 {
                        clear = Some((q, clearance));
                    }
                    None
                }
            }
        };
        previous = answer.map(|(d, _)| d);
        *slot = match answer {
            Some((d, p)) => Vec4::new(d, p.normal.x, p.normal.y, p.normal.z),
            None => Vec4::new(UNKNOWN, 0.0, 0.0, 0.0),
        };
    }
}

/// Where the nodes of a grid lie: `dims` nodes from `origin`, `spacing` apart.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
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
    /// along the longest side (at least 2). Errors: fewer than 2 nodes, a negative or
    /// non-finite margin, and a grown box of no (or non-finite) extent.
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
        if !(longest.is_finite() && longest > 0.0) {
            return Err(FieldError::InvalidParameter {
                name: "bounds",
                value: format!("the box {} to {} grown by {margin}", bounds.min, bounds.max),
                expected: "a box with a positive, finite longest side (all the geometry \
                           sits at one point: give it a margin, or more than one position)",
            });
        }
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

impl SdfGrid {
    /// Samples `surface` at every node of `spec` (parallel over rows, deterministic).
    ///
    /// 1. Every node asks for the surface within `band` only
    ///    ([`Surface::signed_distance_or_clearance`]). Along a row the previous node's
    ///    distance plus the spacing is passed as the likely bound, so exact mesh searches
    ///    prune to a small ball; a node answered with a clearance lets the row skip the
    ///    nodes within it (the same grid, fewer queries).
    /// 2. Nodes with no surface within `band` hold `±band`, signed from the nodes that have
    ///    a distance by [`FarSigns::Nearest`]. This is exact when `band` exceeds the spacing
    ///    and the surface answered every node within `band` of it: two neighbouring nodes
    ///    on opposite sides of the surface would both lie within one spacing of it. A grid
    ///    with no node within `band` (no surface near it at all) asks the surface once,
    ///    without a limit.
    ///
    /// Errors when `band` is not larger than the spacing.
    pub fn from_surface(
        surface: &(impl Surface + ?Sized),
        spec: &GridSpec,
        band: f32,
    ) -> Result<Self> {
        Self::from_surface_with(surface, spec, band, FarSigns::default())
    }

    /// [`SdfGrid::from_surface`] with the far nodes signed by `far_signs`.
    pub fn from_surface_with(
        surface: &(impl Surface + ?Sized),
        spec: &GridSpec,
        band: f32,
        far_signs: FarSigns,
    ) -> Result<Self> {
        Self::from_surface_in(surface, spec, band, far_signs, &mut RunContext::new(0))
    }

    /// [`SdfGrid::from_surface_with`] within a run: reports the layers sampled (nodes of
    /// one `k`, out of `spec.dims[2]`) under [`SAMPLING_STAGE`] every few layers, and
    /// stops with `pointset_core::Error::Cancelled` at the next report once the run is
    /// cancelled. The grid is the same as without a run, whatever the threads.
    ///
    /// ```
    /// use distance_field::{FarSigns, FieldError, GridSpec, MeshSurface, SdfGrid};
    /// use glam::Vec3;
    /// use pointset_core::{Aabb, PointSet, ProgressUpdate, RunContext, TriMesh};
    ///
    /// let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    /// let tet = TriMesh::new(PointSet::new(p)?, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])?;
    /// let surface = MeshSurface::new(&tet)?;
    /// let spec = GridSpec::covering(Aabb::new(Vec3::ZERO, Vec3::ONE), 24, 0.2)?;
    ///
    /// // A bar would follow the layers: 0, 4, 8, … out of 24.
    /// let mut ctx = RunContext::new(0).with_progress(|u: &ProgressUpdate<'_>| {
    ///     assert!(u.done <= 24 && u.total == Some(24));
    /// });
    /// let sdf = SdfGrid::from_surface_in(&surface, &spec, 0.5, FarSigns::default(), &mut ctx)?;
    /// assert_eq!(sdf, SdfGrid::from_surface(&surface, &spec, 0.5)?);
    ///
    /// // A cancelled run stops before the next layers.
    /// ctx.cancel_flag().cancel();
    /// let stopped = SdfGrid::from_surface_in(&surface, &spec, 0.5, FarSigns::default(), &mut ctx);
    /// assert!(matches!(stopped, Err(FieldError::Core(pointset_core::Error::Cancelled))));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn from_surface_in(
        surface: &(impl Surface + ?Sized),
        spec: &GridSpec,
        band: f32,
        far_signs: FarSigns,
        ctx: &mut RunContext,
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
        let [nx, ny, nz] = spec.dims;
        let mut data = grid.into_data();
        // Blocks of nodes share one preparation of the surface (when it gains from one),
        // and are sampled in parallel, a few layers at a time.
        let blocks = prepared_blocks(surface, spec.spacing).unwrap_or(Blocks {
            side: MAX_BLOCK,
            depth: 1,
            prepare: false,
        });
        let group_layers = LAYERS_PER_REPORT.div_ceil(blocks.depth) * blocks.depth;
        ctx.report(SAMPLING_STAGE, 0, Some(nz as u64));
        for (group, layers) in data.chunks_mut(nx * ny * group_layers).enumerate() {
            ctx.check_cancelled()?;
            let first = group * group_layers;
            // Each task: one row of blocks through the layers of one block depth.
            let mut tasks = Vec::new();
            for (slab, slab_layers) in layers.chunks_mut(nx * ny * blocks.depth).enumerate() {
                let mut block_rows: Vec<Vec<&mut [Vec4]>> = (0..ny.div_ceil(blocks.side))
                    .map(|_| Vec::with_capacity(blocks.depth))
                    .collect();
                for layer in slab_layers.chunks_mut(nx * ny) {
                    for (rows, task) in layer.chunks_mut(nx * blocks.side).zip(&mut block_rows) {
                        task.push(rows);
                    }
                }
                let k0 = first + slab * blocks.depth;
                tasks.extend(
                    block_rows
                        .into_iter()
                        .enumerate()
                        .map(|(block_row, rows)| ((block_row, k0), rows)),
                );
            }
            tasks.into_par_iter().for_each(|(at, rows)| {
                sample_block_row(surface, spec, band, blocks, at, rows);
            });
            let done = (first + group_layers).min(nz);
            ctx.report(SAMPLING_STAGE, done as u64, Some(nz as u64));
        }
        let far = data.iter().filter(|v| v.x == UNKNOWN).count();
        let undefined = fill_far_signs(&mut data, spec, band, surface, far_signs);
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

    /// Nodes farther than the band from the surface (signed by a [`FarSigns`] rule).
    pub fn far_nodes(&self) -> usize {
        self.far
    }

    /// Nodes whose sign could not be determined (no node lies within the band and the
    /// surface gave no answer); they hold `+band`.
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
