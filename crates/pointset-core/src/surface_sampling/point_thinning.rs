//! A point set thinned to fewer of its own points: a scan far denser than an algorithm
//! needs (Mount St. Helens's 13,000 points per unit of area against the 300 of the quilt's
//! fixtures), brought down without moving a point.
//!
//! Two thinnings ([`PointThinning`]):
//!
//! - **Poisson disk**: the kept points are no two closer than `spacing`, and every point
//!   of the input lies closer than `spacing` to a kept one (the subset is maximal: a point
//!   left out was crowded by one kept before it). The points are tested in a random order,
//!   tile by tile in eight phases as the mesh's Poisson disk is (the module `tiles` of
//!   [`super`]), so the result depends on the points, the spacing and the seed only, not
//!   on the threads. Points at one position are one point. With a count instead of a
//!   spacing, the spacing is searched for: each pass scales it by `(kept / count)^(1/d)`
//!   (a disk holds about `c / spacing^d` points: `d` = 2 on a surface at first, then as
//!   measured from the last two passes, between 1 for a line and 3 for a volume), kept
//!   inside the bracket the passes so far have found, until the count is met within 1%
//!   (or one point) or after [`MAX_COUNT_PASSES`] passes; the pass nearest the count is
//!   kept.
//! - **Random**: `count` points drawn without replacement, each subset as likely as any.
//!
//! The kept points keep their positions, normals and attributes exactly, in their input
//! order; [`ThinnedPoints::kept`] says which they were. Distances are compared in double
//! precision, against the spacing as given. Attributes that describe the sampling itself,
//! such as a scan's splat `radius`, keep their input values too: after thinning they
//! understate the spacing (the spacing is in [`ThinnedPoints::spacing`]).
//!
//! ```
//! use glam::Vec3;
//! use pointset_core::surface_sampling::{PointThinning, thin_points};
//! use pointset_core::{PointSet, RunContext};
//!
//! // A 100 × 100 grid of spacing 0.01, thinned so that no two points are closer than 0.05.
//! let grid = (0..10_000).map(|i| Vec3::new((i % 100) as f32, (i / 100) as f32, 0.0) * 0.01);
//! let points = PointSet::new(grid.collect())?;
//! let thinning = PointThinning::PoissonDisk { spacing: 0.05 };
//! let thinned = thin_points(&points, &thinning, &mut RunContext::new(3))?;
//! let kept = thinned.points.positions();
//! assert!(kept.len() > 230 && kept.len() < 330); // about 0.65 a spacing² (276)
//! for (i, a) in kept.iter().enumerate() {
//!     assert!(kept[i + 1..].iter().all(|b| a.distance(*b) >= 0.05 - 1e-6));
//! }
//! // Every grid point has a kept point within the spacing (many lie exactly a spacing
//! // apart on this grid: the test is made in double precision, hence the rounding).
//! let near = |p: &Vec3| kept.iter().any(|k| k.distance(*p) < 0.05 + 1e-6);
//! assert!(points.positions().iter().all(near));
//! # Ok::<(), pointset_core::Error>(())
//! ```

use glam::Vec3;
use rand::RngExt;
use rand::seq::SliceRandom;

use super::phased::{Candidates, grid_low, keep_apart, spacing_too_small};
use super::tiles::{TILE_SPACINGS, Tile, Tiles};
use crate::rng::{rng_from_seed, stream};
use crate::{Error, PointSet, Result, RunContext};

/// Most passes [`PointThinning::PoissonDiskCount`] makes in search of its spacing.
pub const MAX_COUNT_PASSES: usize = 12;

/// How a point set is thinned (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum PointThinning {
    /// The points no two closer than `spacing` (positive, finite), every input point
    /// within `spacing` of a kept one.
    PoissonDisk {
        /// The least distance between two kept points.
        spacing: f32,
    },
    /// A Poisson disk of about `count` points (at least 1): its spacing searched for. A
    /// count at or above the input's keeps every point.
    PoissonDiskCount {
        /// How many points to keep, about.
        count: usize,
    },
    /// `count` points (at least 1) drawn at random without replacement; a count at or
    /// above the input's keeps every point.
    Random {
        /// How many points to keep.
        count: usize,
    },
}

/// The points [`thin_points`] kept.
#[derive(Debug, Clone, PartialEq)]
pub struct ThinnedPoints {
    /// The kept points, with their normals and attributes, in their input order.
    pub points: PointSet,
    /// Each kept point's index in the input, increasing.
    pub kept: Vec<u32>,
    /// The Poisson disk's spacing (the one found, for a count); `None` when every point
    /// was kept for a count at or above the input's, or for a random thinning.
    pub spacing: Option<f32>,
    /// How many Poisson-disk passes were made (0 for a random thinning or every point
    /// kept).
    pub passes: usize,
}

/// The progress stage's name.
const STAGE: &str = "thin points";

/// Thins `points` (module docs), seeded by `ctx`'s seed; reports progress as "thin
/// points" (tiles done, each pass anew) and stops when cancelled.
///
/// Errors: an empty point set ([`Error::EmptyInput`]); a count of 0, a spacing that is not
/// positive and finite, or one so small that the points' box spans more than 2²³ spacings
/// along an axis ([`Error::InvalidParameter`]; a count's search stays above that);
/// [`Error::Cancelled`].
pub fn thin_points(
    points: &PointSet,
    thinning: &PointThinning,
    ctx: &mut RunContext,
) -> Result<ThinnedPoints> {
    if points.is_empty() {
        return Err(Error::EmptyInput {
            what: "the point set to thin".into(),
        });
    }
    let every_point = |count: usize| count >= points.len();
    let (kept, spacing, passes) = match *thinning {
        PointThinning::PoissonDisk { spacing } => (
            poisson_disk(points.positions(), spacing, ctx)?,
            Some(spacing),
            1,
        ),
        PointThinning::PoissonDiskCount { count } => {
            check_count(count)?;
            if every_point(count) {
                ((0..points.len() as u32).collect(), None, 0)
            } else {
                let (kept, spacing, passes) = poisson_disk_for_count(points, count, ctx)?;
                (kept, Some(spacing), passes)
            }
        }
        PointThinning::Random { count } => {
            check_count(count)?;
            (random(points.len(), count, ctx.seed()), None, 0)
        }
    };
    ctx.report(STAGE, kept.len() as u64, Some(kept.len() as u64));
    let indices: Vec<usize> = kept.iter().map(|&i| i as usize).collect();
    Ok(ThinnedPoints {
        points: points.subset(&indices)?,
        kept,
        spacing,
        passes,
    })
}

/// A count of at least one point.
fn check_count(count: usize) -> Result<()> {
    if count == 0 {
        return Err(Error::InvalidParameter {
            name: "count",
            value: "0".into(),
            expected: "at least 1 point".into(),
        });
    }
    Ok(())
}

/// The points of `positions` kept as a Poisson disk of `spacing`, by index, increasing.
fn poisson_disk(positions: &[Vec3], spacing: f32, ctx: &mut RunContext) -> Result<Vec<u32>> {
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(Error::InvalidParameter {
            name: "spacing",
            value: spacing.to_string(),
            expected: "a positive finite length".into(),
        });
    }
    let too_small = || spacing_too_small(spacing, "the points' box");
    let spacing = f64::from(spacing);
    let low = grid_low(positions, spacing);
    let tiles = Tiles::of_points(positions, low, TILE_SPACINGS * spacing).ok_or_else(too_small)?;
    let candidates = PointCandidates {
        positions,
        seed: ctx.seed(),
    };
    let mut kept = keep_apart(&tiles, &candidates, low, spacing, STAGE, too_small, ctx)?;
    kept.sort_unstable();
    Ok(kept)
}

/// A point set's own points as the candidates, each tile's shuffled by the stream of the
/// seed and the tile's key.
struct PointCandidates<'a> {
    positions: &'a [Vec3],
    seed: u64,
}

impl Candidates for PointCandidates<'_> {
    type Item = u32;

    fn of_tile(&self, tile: &Tile<'_>) -> Vec<u32> {
        let mut points: Vec<u32> = tile.items().collect();
        points.shuffle(&mut stream(self.seed, tile.key()));
        points
    }

    fn position(&self, item: &u32) -> Vec3 {
        self.positions[*item as usize]
    }
}

/// A Poisson disk of about `count` points of `points` (fewer than it has): the kept
/// indices, the spacing and the passes made (module docs).
fn poisson_disk_for_count(
    points: &PointSet,
    count: usize,
    ctx: &mut RunContext,
) -> Result<(Vec<u32>, f32, usize)> {
    let positions = points.positions();
    let diagonal = points
        .bounding_box()
        .map_or(0.0, |b| f64::from(b.diagonal()));
    let target = count as f64;
    // Spacings known to keep too many points (the largest such) and too few (the least).
    let (mut too_many, mut too_few) = (0.0f64, f64::INFINITY);
    if diagonal == 0.0 {
        // Every point at one position: any spacing keeps one.
        return Ok((poisson_disk(positions, 1.0, ctx)?, 1.0, 1));
    }
    // The least spacing the grid takes across the points' box (2²³ cells), halved.
    let least = diagonal / f64::from(1u32 << 22);
    let mut spacing = diagonal / target.sqrt();
    let mut best: Option<(Vec<u32>, f32)> = None;
    let mut passes = 0;
    // The spacing and the count kept of the last pass.
    let mut previous: Option<(f64, f64)> = None;
    while passes < MAX_COUNT_PASSES {
        passes += 1;
        let this = spacing as f32;
        let kept = poisson_disk(positions, this, ctx)?;
        let found = kept.len() as f64;
        if found > target {
            too_many = too_many.max(spacing);
        } else {
            too_few = too_few.min(spacing);
        }
        let off = (found - target).abs();
        if best
            .as_ref()
            .is_none_or(|(b, _)| off < (b.len() as f64 - target).abs())
        {
            best = Some((kept, this));
        }
        if off <= (0.01 * target).max(1.0) {
            break;
        }
        // A disk keeps about c / spacing^d points: d is 2 on a surface, 1 along a line
        // and 3 through a volume, measured from the last two passes once there are two
        // (and kept within 1..3); outside the bracket, or where that has stalled, the
        // bracket's middle (or a step out of it).
        let dimension = match previous {
            Some((s, f)) if f != found && found > 0.0 && f > 0.0 => {
                ((f / found).ln() / (spacing / s).ln()).clamp(1.0, 3.0)
            }
            _ => 2.0,
        };
        previous = Some((spacing, found));
        let scaled = spacing * (found / target).powf(dimension.recip());
        spacing = if scaled > too_many && scaled < too_few {
            scaled
        } else if too_few.is_infinite() {
            too_many * 2.0
        } else if too_many == 0.0 {
            too_few / 2.0
        } else {
            (too_many * too_few).sqrt()
        }
        .max(least);
        if (spacing as f32) == this {
            break;
        }
    }
    let (kept, spacing) = best.ok_or(Error::EmptyInput {
        what: "the point set to thin".into(),
    })?;
    Ok((kept, spacing, passes))
}

/// `count` of the indices `0..len`, each subset as likely as any, increasing (every index
/// when `count` is `len` or more).
fn random(len: usize, count: usize, seed: u64) -> Vec<u32> {
    let mut indices: Vec<u32> = (0..len as u32).collect();
    if count < len {
        let mut rng = rng_from_seed(seed);
        // The first `count` places of a partial Fisher–Yates shuffle.
        for i in 0..count {
            let j = rng.random_range(i..len);
            indices.swap(i, j);
        }
        indices.truncate(count);
        indices.sort_unstable();
    }
    indices
}
