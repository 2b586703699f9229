//! Covariance analysis of neighbourhoods: eigen-decomposition and surface variation
//! (Pauly, Gross & Kobbelt 2002).

use glam::Vec3;
use nalgebra::{Matrix3, SymmetricEigen};
use pointset_core::spatial::z_order;
use pointset_core::{KdIndex, PointSet, RunContext};
use rayon::prelude::*;

use crate::error::{MlsError, Result};
use crate::index_match::check_index_of;
use crate::orientation::FoundNeighbours;

/// Eigen-decomposition of a 3×3 covariance: eigenvalues ascending and matching unit vectors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Covariance {
    /// Centroid of the points.
    pub centroid: Vec3,
    /// Eigenvalues `λ0 ≤ λ1 ≤ λ2`.
    pub eigenvalues: [f64; 3],
    /// Unit eigenvectors, matching `eigenvalues`.
    pub eigenvectors: [Vec3; 3],
}

impl Covariance {
    /// Covariance of the points at `indices` (computed in `f64`); `None` when empty or when
    /// an index lies outside `points`.
    pub fn of(points: &[Vec3], indices: impl IntoIterator<Item = usize> + Clone) -> Option<Self> {
        let mut n = 0usize;
        let mut sum = [0f64; 3];
        for i in indices.clone() {
            let p = *points.get(i)?;
            sum[0] += f64::from(p.x);
            sum[1] += f64::from(p.y);
            sum[2] += f64::from(p.z);
            n += 1;
        }
        if n == 0 {
            return None;
        }
        let c = sum.map(|s| s / n as f64);
        let mut m = Matrix3::<f64>::zeros();
        for i in indices {
            let p = *points.get(i)?;
            let d = [
                f64::from(p.x) - c[0],
                f64::from(p.y) - c[1],
                f64::from(p.z) - c[2],
            ];
            for r in 0..3 {
                for s in 0..3 {
                    m[(r, s)] += d[r] * d[s];
                }
            }
        }
        m /= n as f64;
        let eig = SymmetricEigen::new(m);
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        let vector = |k: usize| {
            let v = eig.eigenvectors.column(k);
            Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32).normalize_or_zero()
        };
        Some(Self {
            centroid: Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32),
            eigenvalues: order.map(|k| eig.eigenvalues[k].max(0.0)),
            eigenvectors: order.map(vector),
        })
    }

    /// Surface variation `σ = λ0 / (λ0 + λ1 + λ2)`: 0 on a plane, at most 1/3 (isotropic).
    /// Zero for a neighbourhood of identical points.
    pub fn variation(&self) -> f32 {
        let total: f64 = self.eigenvalues.iter().sum();
        if total <= 0.0 {
            0.0
        } else {
            (self.eigenvalues[0] / total) as f32
        }
    }

    /// Whether the neighbourhood has one direction of least spread: `λ1 − λ0` above
    /// [`MIN_NORMAL_DEFINITENESS`] times `λ2`. False for points on one line (`λ0 ≈ λ1 ≈
    /// 0`), for points that all coincide, and for a neighbourhood spread alike in all
    /// directions.
    pub fn defines_normal(&self) -> bool {
        let [l0, l1, l2] = self.eigenvalues;
        l2 > 0.0 && l1 - l0 > MIN_NORMAL_DEFINITENESS * l2
    }
}

/// Surface variation of each point over its `k` nearest neighbours (itself included).
pub fn surface_variation(index: &KdIndex, k: usize) -> Result<Vec<f32>> {
    if k < 3 {
        return Err(MlsError::InvalidParameter {
            name: "k",
            value: k.to_string(),
            expected: "at least 3 neighbours",
        });
    }
    let points = index.points();
    points
        .par_iter()
        .map(|&p| {
            let nn = index.nearest(p, k)?;
            Ok(Covariance::of(points, nn.iter().map(|n| n.index)).map_or(0.0, |c| c.variation()))
        })
        .collect()
}

/// Neighbours (the point included) [`estimate_normals`] fits each tangent plane to, unless
/// told otherwise.
pub const NORMAL_NEIGHBOURS: usize = 12;

/// How much the two smallest spreads of a neighbourhood must differ, as a fraction of the
/// largest, for its direction of least spread to count as a normal
/// ([`Covariance::defines_normal`]). Points along one line fall below, and so do points
/// whose spread across a line (standard deviation) is under about a hundredth of their
/// spread along it: their least spread is any direction across the line.
pub const MIN_NORMAL_DEFINITENESS: f64 = 1e-4;

/// Normals estimated by [`fit_normals`], with the points whose neighbourhoods define none.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct NormalFit {
    /// The points with their estimated (unoriented) unit normals.
    pub points: PointSet,
    /// Indices of the points whose neighbourhoods have no single direction of least spread
    /// ([`Covariance::defines_normal`]): on one line (a scan line sampled far more densely
    /// than the lines lie apart), coincident, or isotropic. Their normals are the
    /// decomposition's unit vector, perpendicular to the line but otherwise arbitrary.
    /// Ascending.
    pub undefined: Vec<usize>,
}

/// Unit normals estimated by local PCA (Hoppe et al. 1992): each point's normal is the
/// direction of least spread of its `k` nearest neighbours, itself included. The signs are
/// whatever the eigen-decomposition gives, so they flip from point to point:
/// [`orient_normals`](crate::orient_normals) makes them consistent. Any normals `points`
/// had are replaced. A neighbourhood with no direction of least spread (all its points on
/// one line, or equal) still gets the decomposition's unit vector, which is then only
/// perpendicular to the line; [`fit_normals`] says which points those are. Errors: `k`
/// below 3, fewer than 3 points, a non-finite position.
///
/// ```
/// use glam::Vec3;
/// use mls_surface::{NORMAL_NEIGHBOURS, estimate_normals, orient_normals};
/// use pointset_core::PointSet;
///
/// // A gently curved sheet z = 0.1 sin(x), without normals.
/// let p: Vec<Vec3> = (0..900)
///     .map(|i| {
///         let (x, y) = ((i % 30) as f32 * 0.1, (i / 30) as f32 * 0.1);
///         Vec3::new(x, y, 0.1 * x.sin())
///     })
///     .collect();
/// let estimated = estimate_normals(&PointSet::new(p)?, NORMAL_NEIGHBOURS)?;
/// let up = orient_normals(&estimated, Vec3::Z)?;
/// let normals = up.normals().ok_or("no normals")?;
/// assert!(normals.iter().all(|n| n.z > 0.99 && (n.length() - 1.0).abs() < 1e-5));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn estimate_normals(points: &PointSet, k: usize) -> Result<PointSet> {
    fit_normals(points, k).map(|fit| fit.points)
}

/// [`estimate_normals`], also saying which points' neighbourhoods define no normal (see
/// [`NormalFit::undefined`]), so that a caller can warn about them or ask for more
/// neighbours. The normals are the same as [`estimate_normals`]'s, bit for bit.
///
/// ```
/// use glam::Vec3;
/// use mls_surface::fit_normals;
/// use pointset_core::PointSet;
///
/// // Scan lines 0.5 apart, sampled every 0.01 along them: 12 neighbours lie on one line.
/// let p: Vec<Vec3> = (0..2000)
///     .map(|i| Vec3::new((i % 200) as f32 * 0.01, (i / 200) as f32 * 0.5, 0.0))
///     .collect();
/// let points = PointSet::new(p)?;
/// assert_eq!(fit_normals(&points, 12)?.undefined.len(), 2000);
/// // Neighbourhoods wide enough to reach the next line define the plane's normal.
/// let wide = fit_normals(&points, 160)?;
/// assert!(wide.undefined.is_empty());
/// let normals = wide.points.normals().ok_or("no normals")?;
/// assert!(normals.iter().all(|n| n.z.abs() > 0.999));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_normals(points: &PointSet, k: usize) -> Result<NormalFit> {
    fit_normals_in(points, k, &mut RunContext::new(0))
}

/// Points [`fit_normals_in`] fits between two progress reports and checks for
/// cancellation: a few milliseconds of work.
const FIT_CHUNK: usize = 1 << 16;

/// The stage name [`fit_normals_in`] reports progress under.
pub const FITTING_STAGE: &str = "fitting normals";

/// [`fit_normals`] within a run: the points fitted are reported under [`FITTING_STAGE`]
/// every 65,536 points, and a cancelled run stops there with
/// `MlsError::Core(pointset_core::Error::Cancelled)`. The fit is the same, bit for bit.
///
/// ```
/// use glam::Vec3;
/// use mls_surface::{FITTING_STAGE, fit_normals, fit_normals_in};
/// use pointset_core::{PointSet, ProgressUpdate, RunContext};
///
/// let p: Vec<Vec3> = (0..900).map(|i| Vec3::new((i % 30) as f32, (i / 30) as f32, 0.0)).collect();
/// let points = PointSet::new(p)?;
/// let mut ctx = RunContext::new(0).with_progress(|u: &ProgressUpdate<'_>| {
///     assert_eq!((u.stage, u.total), (FITTING_STAGE, Some(900)));
/// });
/// let fit = fit_normals_in(&points, 12, &mut ctx)?;
/// assert_eq!(fit.points, fit_normals(&points, 12)?.points);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_normals_in(points: &PointSet, k: usize, ctx: &mut RunContext) -> Result<NormalFit> {
    check_fit(points, k)?;
    let index = KdIndex::new(points.positions())?;
    fit_normals_with(&index, points, k, ctx)
}

/// [`fit_normals_in`] with an `index` of `points`' positions that the caller built
/// (`KdIndex::new(points.positions())`), so that one index serves the fit, the
/// orientation ([`crate::orient_normals_with`]) and its check
/// ([`crate::orientation_disagreement_with`]): on 12 million points each index takes
/// seconds to build. The fit is the same, bit for bit. Errors as [`fit_normals`]'s, and
/// an index of other positions.
///
/// ```
/// use glam::Vec3;
/// use mls_surface::{fit_normals, fit_normals_with};
/// use pointset_core::{KdIndex, PointSet, RunContext};
///
/// let p: Vec<Vec3> = (0..900).map(|i| Vec3::new((i % 30) as f32, (i / 30) as f32, 0.0)).collect();
/// let points = PointSet::new(p)?;
/// let index = KdIndex::new(points.positions())?;
/// let fit = fit_normals_with(&index, &points, 12, &mut RunContext::new(0))?;
/// assert_eq!(fit.points, fit_normals(&points, 12)?.points);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_normals_with(
    index: &KdIndex,
    points: &PointSet,
    k: usize,
    ctx: &mut RunContext,
) -> Result<NormalFit> {
    check_fit(points, k)?;
    check_index_of(index, points)?;
    // Asked along the Z-order curve, so that consecutive queries share the index's caches.
    let order = z_order(points.positions());
    fit_along(index, points.clone(), k, &order, None, ctx)
}

/// The fit of [`fit_normals_with`], after its checks, into `points` (which `index` was
/// built from): each point's `k` nearest neighbours asked in `order` (every point once),
/// reported and cancelled as [`fit_normals_in`] says. With `found`, the neighbours the
/// orientation's graph needs are kept for it, row by row in `order`
/// ([`FoundNeighbours::row_from`]).
pub(crate) fn fit_along(
    index: &KdIndex,
    points: PointSet,
    k: usize,
    order: &[usize],
    mut found: Option<&mut FoundNeighbours>,
    ctx: &mut RunContext,
) -> Result<NormalFit> {
    let positions = points.positions();
    let total = Some(positions.len() as u64);
    let keep = found.is_some();
    let mut fits: Vec<(Vec3, bool)> = vec![(Vec3::ZERO, false); positions.len()];
    for (chunk, part) in order.chunks(FIT_CHUNK).enumerate() {
        ctx.check_cancelled()?;
        let fitted = part
            .par_iter()
            .map(|&i| {
                let nn = index.nearest(positions[i], k)?;
                let fit = Covariance::of(positions, nn.iter().map(|n| n.index))
                    .map(|c| (c.eigenvectors[0], c.defines_normal()))
                    .filter(|(n, _)| n.is_normalized())
                    .ok_or(MlsError::DegenerateNormal { index: i })?;
                Ok((fit, keep.then(|| FoundNeighbours::row_from(&nn, i, k))))
            })
            .collect::<Result<Vec<_>>>()?;
        let first_rank = chunk * FIT_CHUNK;
        for (at, (&i, (fit, row))) in part.iter().zip(fitted).enumerate() {
            fits[i] = fit;
            if let (Some(found), Some(row)) = (found.as_deref_mut(), row) {
                found.set_row(first_rank + at, row);
            }
        }
        let done = (first_rank + part.len()) as u64;
        ctx.report(FITTING_STAGE, done, total);
    }
    let undefined = fits
        .iter()
        .enumerate()
        .filter(|(_, (_, defined))| !defined)
        .map(|(i, _)| i)
        .collect();
    let normals = fits.into_iter().map(|(n, _)| n).collect();
    Ok(NormalFit {
        points: points.with_normals(normals)?,
        undefined,
    })
}

/// The input checks of [`fit_normals`]: `k` of at least 3, at least 3 points.
pub(crate) fn check_fit(points: &PointSet, k: usize) -> Result<()> {
    if k < 3 {
        return Err(MlsError::InvalidParameter {
            name: "k",
            value: k.to_string(),
            expected: "at least 3 neighbours",
        });
    }
    if points.is_empty() {
        return Err(MlsError::EmptyInput {
            what: "the point set",
        });
    }
    if points.len() < 3 {
        return Err(MlsError::InvalidParameter {
            name: "points",
            value: points.len().to_string(),
            expected: "at least 3 points to fit a tangent plane to",
        });
    }
    Ok(())
}

/// The most neighbours [`plane_radius`] gathers around a point looking for a plane.
pub const PLANE_RADIUS_MAX_NEIGHBOURS: usize = 512;

/// How many points [`plane_radius`] asks at most (every `n / 2000`-th, rounded up).
const PLANE_RADIUS_SAMPLES: usize = 2000;

/// The neighbourhood sizes [`plane_radius`] tries, nearest first.
const PLANE_RADIUS_LADDER: [usize; 15] =
    [4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512];

/// How far a typical point must look to find neighbours that span a plane: over up to
/// 2000 points spread through the set, the median distance to the farthest of the fewest
/// nearest neighbours (itself included; 4, 6, 8, 12, … up to
/// [`PLANE_RADIUS_MAX_NEIGHBOURS`]) that [`Covariance::defines_normal`]. On an even
/// sampling of a surface that is about the spacing; on scan lines sampled far more
/// densely along than across, it is the distance between the lines, where the spacing
/// (nearest neighbours, [`KdIndex::median_spacing`]) is the step along them. `None` when
/// the median point finds no plane among its nearest [`PLANE_RADIUS_MAX_NEIGHBOURS`]
/// (points on one line, or fewer than 3 points).
///
/// ```
/// use glam::Vec3;
/// use mls_surface::plane_radius;
/// use pointset_core::KdIndex;
///
/// // Lines 0.5 apart, sampled every 0.01 along them.
/// let p: Vec<Vec3> = (0..2000)
///     .map(|i| Vec3::new((i % 200) as f32 * 0.01, (i / 200) as f32 * 0.5, 0.0))
///     .collect();
/// let index = KdIndex::new(&p)?;
/// let radius = plane_radius(&index)?.ok_or("no plane")?;
/// assert!((0.5..0.6).contains(&radius), "{radius}");
/// assert!(index.median_spacing()? < 0.011);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn plane_radius(index: &KdIndex) -> Result<Option<f32>> {
    let points = index.points();
    if points.len() < 3 {
        return Ok(None);
    }
    let step = points.len().div_ceil(PLANE_RADIUS_SAMPLES);
    let asked: Vec<usize> = (0..points.len()).step_by(step).collect();
    let mut radii = asked
        .par_iter()
        .map(|&i| {
            let nn = index.nearest(points[i], PLANE_RADIUS_MAX_NEIGHBOURS)?;
            let found = PLANE_RADIUS_LADDER
                .iter()
                .map(|&k| k.min(nn.len()))
                .find(|&k| {
                    Covariance::of(points, nn[..k].iter().map(|n| n.index))
                        .is_some_and(|c| c.defines_normal())
                });
            Ok(found.map(|k| nn[k - 1].distance_squared.sqrt()))
        })
        .collect::<Result<Vec<Option<f32>>>>()?;
    // No plane sorts last, as farther than any.
    radii.sort_by(|a, b| match (a, b) {
        (Some(a), Some(b)) => a.total_cmp(b),
        (a, b) => b.is_some().cmp(&a.is_some()),
    });
    Ok(radii[radii.len() / 2])
}
