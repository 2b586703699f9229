//! Single- and multiresolution synthesis of a target distance field (paper 001 §5.1–5.2).
//!
//! Iteration `k` of `levels` works on the source subsampled `drop = levels − 1 − k` times and
//! a target of `target_dims / 2^drop` samples with blocks of `block / 2^drop` samples: the tree
//! is built once for the finest block size and searched with its `drop` finest levels removed
//! (§5.2, "by removing all leaf nodes … the tree for a subsampled distance field is obtained").
//! A block therefore covers the same region of the source at every iteration; coarse
//! iterations see it at a lower resolution. (§5.2 also says the block size decreases with
//! each iteration; under the tree reuse the paper prescribes, the block's size in samples
//! grows while its extent stays fixed — we follow the tree reuse.)
//!
//! Within an iteration, blocks step by half a block along each axis in scan-line order, so a
//! block that is not on the target's lower faces has 7 of its 8 octants synthesized (§5.1).
//! Only unsynthesized samples are written. The first iteration's target is seeded with
//! random source samples; later ones with the previous result upsampled by trilinear
//! interpolation (the paper does not say how; interpolation predicts a smooth distance field
//! far better than replicating samples, so the coarse result guides the finer search).
//!
//! Blocks whose regions do not overlap never influence each other, so blocks are searched in
//! *waves* (`wave = i + 2j + 4k` for block indices `(i, j, k)`; blocks of one wave are
//! disjoint, and each depends only on earlier waves): searches of a wave run in parallel and
//! their copies are applied in scan-line order. The result is identical to the sequential
//! scan for any number of threads.

use std::str::FromStr;

use distance_field::{Quantizer, SdfGrid};
use pointset_core::rng::stream;
use pointset_core::{Grid3, RunContext};
use rand::RngExt;
use rayon::prelude::*;

use crate::error::{Result, VoxelError, invalid};
use crate::field::{QuantizedField, SubsampledSource, block_ssd};
use crate::matcher::{BlockMatcher, BruteForce, FftMatcher};
use crate::tree::{Match, SearchTree, TreeStats};

/// How each block's source block is chosen. The three searches return equally good (exact)
/// matches; for synthesis queries the pruned linear search is the fastest (see the crate
/// docs), so it is the default.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum MatcherKind {
    /// The paper's search tree (exact best match).
    Tree,
    /// Linear search over every block with partial distances and Eq. 2 filters (exact best
    /// match).
    #[default]
    Brute,
    /// Masked SSD by FFT cross-correlation (exact best match).
    Fft,
    /// The baseline: a uniformly random source block, no search.
    Random,
}

impl MatcherKind {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Tree => "tree",
            Self::Brute => "brute",
            Self::Fft => "fft",
            Self::Random => "random",
        }
    }
}

impl FromStr for MatcherKind {
    type Err = VoxelError;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "tree" => Ok(Self::Tree),
            "brute" => Ok(Self::Brute),
            "fft" => Ok(Self::Fft),
            "random" => Ok(Self::Random),
            other => Err(VoxelError::InvalidParameter {
                name: "matcher",
                value: other.to_string(),
                expected: "tree, brute, fft or random".into(),
            }),
        }
    }
}

/// Parameters of [`synthesize`]; defaults are the paper's setting (§6: 3 iterations, target
/// 128³, final block 16), with the fastest exact matcher.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
#[non_exhaustive]
pub struct VoxelParams {
    /// Target samples along x, y, z at the finest iteration. Each must be at least `block`
    /// and a multiple of `block / 2`; default 128³ (the paper's).
    pub target_dims: [usize; 3],
    /// Iterations (resolution levels), ≥ 1, with `block / 2^(levels − 1) ≥ 2`; default 3 (the paper's).
    pub levels: usize,
    /// Block size of the last iteration (a power of two from 2 to 512); default 16 (the paper's).
    pub block: usize,
    /// Block search; default [`MatcherKind::Brute`] (exact, the fastest here).
    pub matcher: MatcherKind,
    /// Half-range of the 256-level quantization in world units; `None` uses the source's
    /// largest |distance| (distances beyond the range saturate); default `None`.
    pub range: Option<f32>,
    /// Seed of the random target initialisation (and of the random baseline's picks); default 0.
    pub seed: u64,
}

impl Default for VoxelParams {
    fn default() -> Self {
        Self {
            target_dims: [128; 3],
            levels: 3,
            block: 16,
            matcher: MatcherKind::Brute,
            range: None,
            seed: 0,
        }
    }
}

/// Largest target, in samples (512³): each target grid of `f32` then takes 512 MiB, and a run
/// holds a few of them. The paper's targets were 128³.
pub const MAX_TARGET_SAMPLES: usize = 1 << 27;

impl VoxelParams {
    /// Sets the target samples along x, y, z at the finest iteration (default 128³).
    pub fn target_dims(mut self, dims: [usize; 3]) -> Self {
        self.target_dims = dims;
        self
    }

    /// Sets the iterations (resolution levels; default 3).
    pub fn levels(mut self, levels: usize) -> Self {
        self.levels = levels;
        self
    }

    /// Sets the block size of the last iteration (default 16).
    pub fn block(mut self, block: usize) -> Self {
        self.block = block;
        self
    }

    /// Sets the block search (default [`MatcherKind::Brute`]).
    pub fn matcher(mut self, matcher: MatcherKind) -> Self {
        self.matcher = matcher;
        self
    }

    /// Sets the quantization half-range in world units (default: the source's largest
    /// |distance|).
    pub fn range(mut self, range: f32) -> Self {
        self.range = Some(range);
        self
    }

    /// Sets the seed (default 0).
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<()> {
        // A block holds block³ samples of the target, which holds at most 512³.
        if !self.block.is_power_of_two() || !(2..=512).contains(&self.block) {
            return Err(invalid("block", self.block, "a power of two from 2 to 512"));
        }
        // The first level's block, block / 2^(levels − 1), is at least 2.
        let most_levels = self.block.ilog2() as usize;
        if !(1..=most_levels).contains(&self.levels) {
            return Err(invalid(
                "levels",
                self.levels,
                format!(
                    "1 to {most_levels} for a block of {} (the first level's block, block / \
                     2^(levels − 1), is at least 2)",
                    self.block
                ),
            ));
        }
        let half = self.block / 2;
        if self
            .target_dims
            .iter()
            .any(|&t| t < self.block || t % half != 0)
        {
            // The nearest sizes that fit, so the message names numbers, not rules (where
            // they are not too many samples in turn).
            let fitting = self
                .target_dims
                .map(|t| t.div_ceil(half).saturating_mul(half).max(self.block));
            let such_as = fitting
                .iter()
                .try_fold(1usize, |n, &t| n.checked_mul(t))
                .filter(|&n| n <= MAX_TARGET_SAMPLES)
                .map_or(String::new(), |_| format!(", such as {fitting:?}"));
            return Err(invalid(
                "target dims",
                format!("{:?}", self.target_dims),
                format!(
                    "each at least the block ({}) and a multiple of half of it \
                     ({half}){such_as}",
                    self.block
                ),
            ));
        }
        let samples = self
            .target_dims
            .iter()
            .try_fold(1usize, |n, &t| n.checked_mul(t));
        if samples.is_none_or(|n| n > MAX_TARGET_SAMPLES) {
            return Err(invalid(
                "target dims",
                format!("{:?}", self.target_dims),
                "at most 512³ = 134,217,728 samples in all (MAX_TARGET_SAMPLES)",
            ));
        }
        if let Some(r) = self.range
            && !(r.is_finite() && r > 0.0)
        {
            return Err(invalid("range", r, "a positive finite length"));
        }
        Ok(())
    }
}

/// One block copied from the source to the target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlockCopy {
    /// Corner of the block in the target (samples of its iteration).
    pub target: [usize; 3],
    /// Corner of the source block (full-resolution source samples).
    pub source: [usize; 3],
    /// Eq. 1 distance between the query and the copied block (squared levels).
    pub distance: f32,
}

/// What one iteration did.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelReport {
    /// Times the source was subsampled for this iteration.
    pub drop: usize,
    /// Target samples along x, y, z.
    pub dims: [usize; 3],
    /// Block size in samples.
    pub block: usize,
    /// Blocks matched and copied.
    pub blocks: usize,
    /// Waves of independent blocks.
    pub waves: usize,
    /// Mean Eq. 1 distance of the chosen blocks to their queries.
    pub mean_distance: f64,
    /// Fewest writes any target sample received (1 when every sample is synthesized).
    pub min_writes: u32,
    /// Most writes any target sample received (1: nothing is overwritten).
    pub max_writes: u32,
    /// Wall time in seconds.
    pub seconds: f64,
}

/// The result of [`synthesize`].
#[derive(Debug, Clone)]
pub struct Synthesis {
    /// The final target field, quantized like the source.
    pub field: QuantizedField,
    /// The quantization shared by source and target.
    pub quantizer: Quantizer,
    /// Sample spacing of the source (and of the final target) in world units.
    pub spacing: f32,
    /// World position of target sample `(0, 0, 0)`: the source's origin, so that a block
    /// copied from source corner `s` to target corner `t` moves by `(t − s) · spacing`.
    pub origin: glam::Vec3,
    /// Samples of the source field along x, y, z.
    pub source_dims: [usize; 3],
    /// The blocks of the last iteration, in scan-line order.
    pub copies: Vec<BlockCopy>,
    /// For every final target sample, the index in `copies` of the block that wrote it.
    pub owner: Vec<u32>,
    /// One report per iteration, coarsest first.
    pub levels: Vec<LevelReport>,
    /// Statistics of the search tree (tree matcher only).
    pub tree: Option<TreeStats>,
    /// Seconds spent quantizing the source and building the matcher.
    pub analysis_seconds: f64,
}

impl Synthesis {
    /// The final target as distances in world units, at [`Synthesis::origin`].
    pub fn distances(&self) -> Result<Grid3<f32>> {
        let data = self
            .field
            .values()
            .iter()
            .map(|&q| self.quantizer.dequantize(q))
            .collect();
        Ok(Grid3::from_vec(
            self.field.dims(),
            self.origin,
            self.spacing,
            data,
        )?)
    }
}

/// Quantizes the distances of `source` with `quantizer` (paper 001 §4.1).
pub fn quantize_source(source: &SdfGrid, quantizer: &Quantizer) -> Result<QuantizedField> {
    Ok(QuantizedField::from_grid(&source.distances()?, quantizer))
}

/// The quantizer [`synthesize`] uses for `source` under `params`: `params.range`, or by
/// default the largest |distance| in the source (all of the field's range in 256 levels, as
/// §4.1 reads; a smaller range saturates the far field, which then carries no information
/// about where the surface is).
pub fn source_quantizer(source: &SdfGrid, params: &VoxelParams) -> Result<Quantizer> {
    let range = match params.range {
        Some(r) => r,
        None => {
            let largest = source
                .distances()?
                .data()
                .iter()
                .filter(|d| d.is_finite())
                .fold(0.0f32, |m, d| m.max(d.abs()));
            largest.max(source.grid().spacing())
        }
    };
    Ok(Quantizer::new(range)?)
}

/// How blocks are chosen at one iteration.
enum LevelSearch<'a> {
    Tree {
        tree: &'a SearchTree,
        drop: usize,
    },
    /// Brute force over the regular fields of each phase of the subsampled source.
    Brute {
        cell: usize,
        phases: Vec<([usize; 3], BruteForce)>,
    },
    /// FFT over the regular fields of each phase of the subsampled source.
    Fft {
        cell: usize,
        phases: Vec<([usize; 3], FftMatcher)>,
    },
    Random {
        positions: [usize; 3],
        seed: u64,
    },
}

impl LevelSearch<'_> {
    /// The block for `query` (`m³` levels), block `block_index` of its iteration.
    fn find(
        &self,
        query: &[u8],
        m: usize,
        block_index: usize,
        sub: &SubsampledSource,
        incumbent: Option<Match>,
    ) -> Result<Match> {
        match self {
            Self::Tree { tree, drop } => tree.best_match_below(query, *drop, incumbent),
            Self::Brute { cell, phases } => {
                let volume = query.len() as f32;
                // The incumbent's exact integer sum (its `f32` distance may be rounded).
                let limit = incumbent
                    .and_then(|known| sub.block(known.corner, m))
                    .map(|b| block_ssd(&b, query));
                // One phase: parallel inside the search. Several (coarser iterations):
                // parallel over phases, each searched on one thread.
                let single = phases.len() == 1;
                let found = phases
                    .par_iter()
                    .map(|(phase, matcher)| {
                        Ok(matcher.best_within(query, limit, single)?.map(|(s, id)| {
                            let q = matcher.corner(id);
                            (s, [0, 1, 2].map(|a| phase[a] + cell * q[a]))
                        }))
                    })
                    .collect::<Result<Vec<_>>>()?;
                let mut best = incumbent.zip(limit);
                for (s, corner) in found.into_iter().flatten() {
                    if best.is_none_or(|(_, b)| s < b) {
                        let distance = s as f32 / volume;
                        best = Some((Match { corner, distance }, s));
                    }
                }
                let best = best.map(|(m, _)| m);
                best.ok_or_else(|| invalid("source", "no phase", "a source larger than a block"))
            }
            Self::Fft { cell, phases } => {
                let mut best: Option<Match> = None;
                for (phase, matcher) in phases {
                    let m = matcher.best_match(query)?;
                    if best.is_none_or(|b| m.distance < b.distance) {
                        best = Some(Match {
                            corner: [0, 1, 2].map(|a| phase[a] + cell * m.corner[a]),
                            distance: m.distance,
                        });
                    }
                }
                best.ok_or_else(|| invalid("source", "no phase", "a source larger than a block"))
            }
            Self::Random { positions, seed } => {
                let mut rng = stream(*seed, block_index as u64);
                let corner = positions.map(|p| rng.random_range(0..p));
                let block = sub.block(corner, m).ok_or_else(|| {
                    invalid("source", "too small", "a source larger than a block")
                })?;
                Ok(Match {
                    corner,
                    distance: block_ssd(&block, query) as f32 / query.len() as f32,
                })
            }
        }
    }
}

/// One matcher per phase field of `sub` that holds an `m³` block.
fn phased<M: Send>(
    sub: &SubsampledSource,
    m: usize,
    build: impl Fn(&QuantizedField, usize) -> Result<M> + Sync,
) -> Result<Vec<([usize; 3], M)>> {
    let c = sub.cell();
    let all: Vec<[usize; 3]> = (0..c * c * c)
        .map(|i| [i % c, (i / c) % c, i / (c * c)])
        .collect();
    all.into_par_iter()
        .filter_map(|phase| {
            let field = sub.phase_field(phase)?;
            field.block_positions(m)?;
            Some(build(&field, m).map(|matcher| (phase, matcher)))
        })
        .collect()
}

/// Synthesizes a target distance field from `source` (paper 001 §5.1–5.2).
///
/// ```
/// use distance_field::{GridSpec, MeshSurface, SdfGrid};
/// use pointset_core::RunContext;
/// use voxel_dfsynth::{VoxelParams, synthesize};
///
/// // A field of parallel slabs (period 8 samples along x).
/// let spec = GridSpec { dims: [24, 24, 24], origin: glam::Vec3::ZERO, spacing: 1.0 };
/// let grid = pointset_core::Grid3::from_vec(spec.dims, spec.origin, 1.0,
///     (0..24 * 24 * 24).map(|i| {
///         let x = (i % 24) as f32;
///         let d = ((x % 8.0) - 4.0).abs() - 2.0;
///         glam::Vec4::new(d, 0.0, 0.0, 0.0)
///     }).collect())?;
/// let source = SdfGrid::from_grid(grid, 4.0)?;
/// let params = VoxelParams::default().target_dims([32; 3]).levels(2).block(8);
/// let out = synthesize(&source, &params, &mut RunContext::new(1))?;
/// assert_eq!(out.field.dims(), [32, 32, 32]);
/// assert!(out.levels.iter().all(|l| l.min_writes == 1 && l.max_writes == 1));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn synthesize(
    source: &SdfGrid,
    params: &VoxelParams,
    ctx: &mut RunContext,
) -> Result<Synthesis> {
    params.validate()?;
    let start = std::time::Instant::now();
    let quantizer = source_quantizer(source, params)?;
    let field = quantize_source(source, &quantizer)?;
    let positions = field.fitting_positions(params.block)?;
    let tree = match params.matcher {
        MatcherKind::Tree => Some(SearchTree::build(&field, params.block)?),
        _ => None,
    };
    let analysis_seconds = start.elapsed().as_secs_f64();
    ctx.record_timing("analysis", start.elapsed());

    let mut levels = Vec::with_capacity(params.levels);
    let mut target: Vec<u8> = Vec::new();
    let mut last: Option<(Vec<BlockCopy>, Vec<u32>)> = None;
    for k in 0..params.levels {
        let level_start = std::time::Instant::now();
        let drop = params.levels - 1 - k;
        let c = 1usize << drop;
        let m = params.block >> drop;
        let dims = params.target_dims.map(|t| t / c);
        let sub = SubsampledSource::new(&field, drop)?;
        let search = match (params.matcher, &tree) {
            (MatcherKind::Tree, Some(tree)) => LevelSearch::Tree { tree, drop },
            (MatcherKind::Fft, _) => LevelSearch::Fft {
                cell: c,
                phases: phased(&sub, m, FftMatcher::new)?,
            },
            (MatcherKind::Random, _) => LevelSearch::Random {
                positions,
                seed: pointset_core::rng::mix64(params.seed ^ (k as u64 + 1)),
            },
            _ => LevelSearch::Brute {
                cell: c,
                phases: phased(&sub, m, BruteForce::new)?,
            },
        };
        target = if k == 0 {
            random_seed(&sub, dims, params.seed)
        } else {
            upsample(&target, params.target_dims.map(|t| t / (2 * c)))
        };
        let (copies, owner, mut report) =
            synthesize_level(&mut target, dims, m, &search, &sub, k, params.levels, ctx)?;
        report.drop = drop;
        report.seconds = level_start.elapsed().as_secs_f64();
        ctx.record_timing(&format!("level {}", k + 1), level_start.elapsed());
        levels.push(report);
        last = Some((copies, owner));
    }
    let (copies, owner) = last.unwrap_or_default();
    Ok(Synthesis {
        field: QuantizedField::from_values(params.target_dims, target)?,
        quantizer,
        spacing: source.grid().spacing(),
        origin: source.grid().origin(),
        source_dims: field.dims(),
        copies,
        owner,
        levels,
        tree: tree.map(|t| t.stats().clone()),
        analysis_seconds,
    })
}

/// A target of `dims` whose every sample is a uniformly random sample of `sub`.
fn random_seed(sub: &SubsampledSource, dims: [usize; 3], seed: u64) -> Vec<u8> {
    let values = sub.rounded().values();
    let mut rng = stream(seed, u64::MAX);
    (0..dims.iter().product::<usize>())
        .map(|_| values[rng.random_range(0..values.len())])
        .collect()
}

/// Doubles a field of `dims` along every axis by trilinear interpolation. Coarse sample `i`
/// is the mean of fine samples `2i` and `2i + 1`, so it stands at fine coordinate `2i + ½`;
/// fine sample `x` reads the coarse field at `(x − ½) / 2`, clamped to the coarse grid.
fn upsample(coarse: &[u8], dims: [usize; 3]) -> Vec<u8> {
    let fine = dims.map(|d| 2 * d);
    // Per axis and fine index: the two coarse neighbours and the weight of the upper one.
    let taps = |a: usize| -> Vec<(usize, usize, f32)> {
        (0..fine[a])
            .map(|x| {
                let u = ((x as f32 - 0.5) / 2.0).clamp(0.0, (dims[a] - 1) as f32);
                let lo = (u.floor() as usize).min(dims[a] - 1);
                let hi = (lo + 1).min(dims[a] - 1);
                (lo, hi, u - lo as f32)
            })
            .collect()
    };
    let (tx, ty, tz) = (taps(0), taps(1), taps(2));
    let at = |x: usize, y: usize, z: usize| f32::from(coarse[x + dims[0] * (y + dims[1] * z)]);
    let mut out = Vec::with_capacity(fine.iter().product());
    for &(z0, z1, wz) in &tz {
        for &(y0, y1, wy) in &ty {
            for &(x0, x1, wx) in &tx {
                let lerp = |a: f32, b: f32, w: f32| a + (b - a) * w;
                let plane = |z: usize| {
                    lerp(
                        lerp(at(x0, y0, z), at(x1, y0, z), wx),
                        lerp(at(x0, y1, z), at(x1, y1, z), wx),
                        wy,
                    )
                };
                out.push(lerp(plane(z0), plane(z1), wz).round().clamp(0.0, 255.0) as u8);
            }
        }
    }
    out
}

/// The best of the blocks that continue an already copied neighbour of block `b` in the
/// source (the neighbour's source corner shifted by the blocks' offset in the target), scored
/// exactly against `query`: a starting bound for the search.
fn continuation(
    query: &[u8],
    b: usize,
    nb: [usize; 3],
    copies: &[Option<BlockCopy>],
    h: usize,
    m: usize,
    sub: &SubsampledSource,
) -> Option<Match> {
    let c = sub.cell() as i64;
    let at = [b % nb[0], (b / nb[0]) % nb[1], b / (nb[0] * nb[1])];
    let mut best: Option<Match> = None;
    for o in 0..27 {
        let delta = [o % 3, (o / 3) % 3, o / 9].map(|d| d as i64 - 1);
        let n: Option<Vec<usize>> = (0..3)
            .map(|a| {
                let v = at[a] as i64 + delta[a];
                (v >= 0 && v < nb[a] as i64).then_some(v as usize)
            })
            .collect();
        let Some(n) = n else { continue };
        let Some(copy) = copies[n[0] + nb[0] * (n[1] + nb[1] * n[2])] else {
            continue;
        };
        let corner: Option<Vec<usize>> = (0..3)
            .map(|a| {
                let s = copy.source[a] as i64 - delta[a] * h as i64 * c;
                usize::try_from(s).ok()
            })
            .collect();
        let Some(corner) = corner else { continue };
        let corner = [corner[0], corner[1], corner[2]];
        let Some(block) = sub.block(corner, m) else {
            continue;
        };
        let distance = block_ssd(&block, query) as f32 / query.len() as f32;
        if best.is_none_or(|x| distance < x.distance) {
            best = Some(Match { corner, distance });
        }
    }
    best
}

fn read_block(target: &[u8], dims: [usize; 3], corner: [usize; 3], m: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(m * m * m);
    for z in 0..m {
        for y in 0..m {
            let row = corner[0] + dims[0] * (corner[1] + y + dims[1] * (corner[2] + z));
            out.extend_from_slice(&target[row..row + m]);
        }
    }
    out
}

/// One iteration of §5.1 on `target` (already seeded): returns the copies, the owner of every
/// sample and the report (timing filled by the caller).
#[allow(clippy::too_many_arguments)]
fn synthesize_level(
    target: &mut [u8],
    dims: [usize; 3],
    m: usize,
    search: &LevelSearch<'_>,
    sub: &SubsampledSource,
    k: usize,
    level_count: usize,
    ctx: &mut RunContext,
) -> Result<(Vec<BlockCopy>, Vec<u32>, LevelReport)> {
    let h = m / 2;
    let nb = dims.map(|d| (d - m) / h + 1);
    let count = nb.iter().product::<usize>();
    let waves = (nb[0] - 1) + 2 * (nb[1] - 1) + 4 * (nb[2] - 1) + 1;
    let mut by_wave: Vec<Vec<usize>> = vec![Vec::new(); waves];
    for b in 0..count {
        let (i, j, kk) = (b % nb[0], (b / nb[0]) % nb[1], b / (nb[0] * nb[1]));
        by_wave[i + 2 * j + 4 * kk].push(b);
    }
    let corner_of = |b: usize| {
        [
            (b % nb[0]) * h,
            ((b / nb[0]) % nb[1]) * h,
            (b / (nb[0] * nb[1])) * h,
        ]
    };
    let mut writes = vec![0u32; target.len()];
    let mut owner = vec![u32::MAX; target.len()];
    let mut copies: Vec<Option<BlockCopy>> = vec![None; count];
    let mut done = 0u64;
    let stage = format!("voxel level {}/{level_count}", k + 1);
    for wave in &by_wave {
        ctx.check_cancelled()?;
        let shared: &[u8] = target;
        let found = wave
            .par_iter()
            .map(|&b| {
                let query = read_block(shared, dims, corner_of(b), m);
                let incumbent = continuation(&query, b, nb, &copies, h, m, sub);
                search.find(&query, m, b, sub, incumbent)
            })
            .collect::<Result<Vec<Match>>>()?;
        for (&b, found) in wave.iter().zip(found) {
            let corner = corner_of(b);
            let values = sub.block(found.corner, m).ok_or_else(|| {
                invalid(
                    "match",
                    format!("{:?}", found.corner),
                    "a block inside the source",
                )
            })?;
            for z in 0..m {
                for y in 0..m {
                    for x in 0..m {
                        let t =
                            corner[0] + x + dims[0] * (corner[1] + y + dims[1] * (corner[2] + z));
                        // Only unsynthesized samples are overwritten (§5.1).
                        if writes[t] == 0 {
                            target[t] = values[x + m * (y + m * z)];
                            owner[t] = b as u32;
                            writes[t] += 1;
                        }
                    }
                }
            }
            copies[b] = Some(BlockCopy {
                target: corner,
                source: found.corner,
                distance: found.distance,
            });
        }
        done += wave.len() as u64;
        ctx.report(&stage, done, Some(count as u64));
    }
    let copies: Vec<BlockCopy> = copies.into_iter().flatten().collect();
    let mean_distance =
        copies.iter().map(|c| f64::from(c.distance)).sum::<f64>() / copies.len().max(1) as f64;
    let report = LevelReport {
        drop: 0,
        dims,
        block: m,
        blocks: copies.len(),
        waves,
        mean_distance,
        min_writes: writes.iter().copied().min().unwrap_or(0),
        max_writes: writes.iter().copied().max().unwrap_or(0),
        seconds: 0.0,
    };
    Ok((copies, owner, report))
}
