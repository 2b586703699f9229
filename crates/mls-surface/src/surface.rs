//! The MLS point-set surface of Adamson & Alexa (2004): evaluation and projection.

use glam::Vec3;
use pointset_core::spatial::{key_index, nearness_key};
use pointset_core::{BandAnswer, KdIndex, PointSet, Surface, SurfacePoint};
use rayon::prelude::*;

use crate::error::{MlsError, Result};
use crate::params::MlsParams;

/// Out of the kernel's reach, the nearest sample's plane alone signs a query that lies
/// within 45° of that sample's normal (`|offset · n| ≥ 0.7 |offset|`): it is clearly on one
/// side. Nearer the plane (past an edge, beside a thin part, under a tilted normal) the
/// planes of [`MlsParams::fallback_sign_samples`] nearest samples vote. Voting everywhere
/// gave the same shapes (a random cube 10 components against 9, the chameleon 25 against
/// 27, a thin box and a noisy-normal sphere closed either way) and made the MLS distance
/// grid of 100k points 57% slower at 64³ (0.221 s against 0.141 s with one plane); with
/// the gate it took 0.151 s (docs/performance.md).
pub const SINGLE_PLANE_COSINE: f32 = 0.7;

/// Relative margin taken off a nearest-sample distance before it becomes a clearance
/// ([`Surface::signed_distance_or_clearance`]), for the rounding of the distance.
const CLEARANCE_MARGIN: f32 = 1e-5;

/// Neighbours are gathered in a ball of this many support radii around an anchor, and
/// reused while the projection's iterate stays within the excess (half a support radius)
/// of it.
const GATHER_RADIUS: f32 = 1.5;

/// The local quantities of the surface definition at a point `x`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalFit {
    /// Weighted centre `a(x) = Σ θ p_i / Σ θ`.
    pub center: Vec3,
    /// Weighted normal direction `n(x) = Σ θ n_i / |Σ θ n_i|`.
    pub normal: Vec3,
    /// Implicit function `f(x) = n(x) · (x − a(x))`.
    pub value: f32,
    /// Number of points inside the kernel's support.
    pub neighbours: usize,
}

/// The result of projecting a point onto the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// The surface point `x*`.
    pub point: Vec3,
    /// The surface normal `n(x*)`.
    pub normal: Vec3,
    /// Signed distance of the query: `±|x − x*|`, positive on the normal's side.
    pub signed_distance: f32,
    /// Iterations used.
    pub iterations: usize,
    /// Whether `|f| < tolerance · h` was reached (otherwise the cap stopped it).
    pub converged: bool,
}

/// What one projection attempt from a query `x` found.
struct ProjectionAttempt {
    /// The fit at `x` itself; `None` where the surface is not defined at `x`.
    start: Option<LocalFit>,
    /// The projection; `None` also where the iteration leaves the surface.
    projection: Option<Projection>,
    /// The sample nearest to `x` among those gathered around it (every sample within 1.5
    /// support radii, nearest first, the lowest index among equally near ones); `None`
    /// when that ball is empty.
    nearest_gathered: Option<usize>,
}

/// An oriented point-set surface: Gaussian-weighted centres and normals of the input points
/// define `f(x) = n(x) · (x − a(x))`, whose zero set is the surface.
#[derive(Debug)]
pub struct MlsSurface {
    points: Vec<Vec3>,
    normals: Vec<Vec3>,
    index: KdIndex,
    h: f32,
    params: MlsParams,
}

impl MlsSurface {
    /// Builds the surface over an oriented point set.
    ///
    /// Errors: no normals, no points, a zero normal, invalid parameters, or an estimated
    /// kernel of zero (all points identical) without an explicit `kernel`.
    pub fn new(points: &PointSet, params: &MlsParams) -> Result<Self> {
        params.validate()?;
        let normals = points.normals().ok_or(MlsError::MissingNormals)?;
        if points.is_empty() {
            return Err(MlsError::EmptyInput { what: "point set" });
        }
        let mut unit = Vec::with_capacity(normals.len());
        for (index, n) in normals.iter().enumerate() {
            unit.push(
                n.try_normalize()
                    .ok_or(MlsError::DegenerateNormal { index })?,
            );
        }
        let index = KdIndex::new(points.positions())?;
        let h = params.kernel_for(&index)?;
        Ok(Self {
            points: points.positions().to_vec(),
            normals: unit,
            index,
            h,
            params: params.clone(),
        })
    }

    /// The kernel size `h`.
    pub fn kernel(&self) -> f32 {
        self.h
    }

    /// The truncation radius `support · h`.
    pub fn support_radius(&self) -> f32 {
        self.params.support * self.h
    }

    /// The parameters in use.
    pub fn params(&self) -> &MlsParams {
        &self.params
    }

    /// The input points (positions).
    pub fn points(&self) -> &[Vec3] {
        &self.points
    }

    /// The input normals, normalized.
    pub fn normals(&self) -> &[Vec3] {
        &self.normals
    }

    /// The spatial index over the input points.
    pub fn index(&self) -> &KdIndex {
        &self.index
    }

    /// Indices of input points within `radius` of `x` (empty for non-finite `x`).
    fn candidates(&self, x: Vec3, radius: f32) -> Vec<usize> {
        self.index
            .within(x, radius)
            .map(|n| n.into_iter().map(|n| n.index).collect())
            .unwrap_or_default()
    }

    /// The input points near the segment `from`–`to`: every point within the support of
    /// some point of it, and more (those within the support of the ball around the
    /// segment). [`Self::fit_among`] fits at points of the segment from them.
    pub(crate) fn gather_along(&self, from: Vec3, to: Vec3) -> Vec<usize> {
        let reach = 0.5 * from.distance(to) + self.support_radius();
        // A little slack for the rounding of points computed along the segment.
        self.candidates(0.5 * (from + to), reach * (1.0 + 1e-5) + 1e-6 * self.h)
    }

    /// [`Self::fit`] at `x` from `gathered` ([`Self::gather_along`] a segment through
    /// `x`) instead of the spatial index: the points within the support taken in the order
    /// the index returns them (nearest first, ties to the lower index), so the sums, and
    /// the fit, are the same. `order` is scratch space.
    pub(crate) fn fit_among(
        &self,
        x: Vec3,
        gathered: &[usize],
        order: &mut Vec<u64>,
    ) -> Option<LocalFit> {
        if !x.is_finite() {
            return None;
        }
        let radius = self.support_radius();
        let r2 = radius * radius;
        order.clear();
        order.extend(gathered.iter().filter_map(|&i| {
            let d2 = (self.points[i] - x).length_squared();
            // Lossless: a `KdIndex`, and so this surface, holds at most `u32::MAX` points.
            (d2 <= r2).then_some(nearness_key(d2, i as u32))
        }));
        order.sort_unstable();
        self.fit_with(x, order.iter().map(|&key| key_index(key) as usize))
    }

    /// Evaluates `a`, `n` and `f` at `x` from the candidate points inside the support.
    fn fit_with(&self, x: Vec3, candidates: impl IntoIterator<Item = usize>) -> Option<LocalFit> {
        let r2 = self.support_radius().powi(2);
        let inv_h2 = 1.0 / (self.h * self.h);
        // Offsets `p_i − x` are summed instead of positions: they are small, so `a(x) − x`
        // keeps full f32 precision far from the origin.
        let (mut sw, mut sd, mut sn, mut count) = (0.0f32, Vec3::ZERO, Vec3::ZERO, 0usize);
        for i in candidates {
            let d = self.points[i] - x;
            let d2 = d.length_squared();
            if d2 > r2 {
                continue;
            }
            let w = (-d2 * inv_h2).exp();
            sw += w;
            sd += w * d;
            sn += w * self.normals[i];
            count += 1;
        }
        if count < self.params.min_neighbours || sw <= f32::MIN_POSITIVE {
            return None;
        }
        let len = sn.length();
        // Opposing normals cancelling out: the orientation is undefined here.
        if len <= 1e-4 * sw {
            return None;
        }
        let to_center = sd / sw;
        let normal = sn / len;
        Some(LocalFit {
            center: x + to_center,
            normal,
            value: -normal.dot(to_center),
            neighbours: count,
        })
    }

    /// `a(x)`, `n(x)` and `f(x)`, or `None` where fewer than `min_neighbours` points lie
    /// inside the support or the weighted normals cancel.
    pub fn fit(&self, x: Vec3) -> Option<LocalFit> {
        if !x.is_finite() {
            return None;
        }
        self.fit_with(x, self.candidates(x, self.support_radius()))
    }

    /// The weighted normal direction `n(x)`.
    pub fn normal(&self, x: Vec3) -> Option<Vec3> {
        self.fit(x).map(|f| f.normal)
    }

    /// The implicit function `f(x)`.
    pub fn implicit(&self, x: Vec3) -> Option<f32> {
        self.fit(x).map(|f| f.value)
    }

    /// Quasi-orthogonal projection: repeats `x ← x − f(x) n(x)` until `|f| < tolerance · h`
    /// or the iteration cap. `None` where the surface is not defined (see [`Self::fit`]).
    pub fn project(&self, x: Vec3) -> Option<Projection> {
        self.attempt_projection(x).projection
    }

    /// [`Self::project`], also keeping the fit at `x` itself (its first iteration) and the
    /// nearest sample met on the way, so a caller that needs `f(x)`, the projection or,
    /// failing both, the nearest sample gathers the neighbours once.
    fn attempt_projection(&self, x: Vec3) -> ProjectionAttempt {
        let mut attempt = ProjectionAttempt {
            start: None,
            projection: None,
            nearest_gathered: None,
        };
        if !x.is_finite() {
            return attempt;
        }
        // Candidates are gathered in a ball of radius 1.5·support around an anchor and
        // reused while the iterate stays within 0.5·support of it.
        let candidates = self.candidates(x, GATHER_RADIUS * self.support_radius());
        attempt.nearest_gathered = candidates.first().copied();
        attempt.start = self.fit_with(x, candidates.iter().copied());
        if let Some(start) = attempt.start {
            attempt.projection = self.iterate_projection(x, start, candidates);
        }
        attempt
    }

    /// The iteration of [`Self::project`] from the fit `start` at `x`, with `candidates`
    /// gathered around `x`; `None` where the iteration leaves the surface.
    fn iterate_projection(
        &self,
        x: Vec3,
        start: LocalFit,
        mut candidates: Vec<usize>,
    ) -> Option<Projection> {
        let radius = self.support_radius();
        let slack = (GATHER_RADIUS - 1.0) * radius;
        let mut anchor = x;
        let tolerance = self.params.tolerance * self.h;
        let mut y = x;
        let mut fit = start;
        for iteration in 1..=self.params.max_iterations {
            if iteration > 1 {
                if y.distance(anchor) > slack {
                    anchor = y;
                    candidates = self.candidates(anchor, radius + slack);
                }
                fit = self.fit_with(y, candidates.iter().copied())?;
            }
            if fit.value.abs() < tolerance {
                return Some(self.finish(x, y, fit.normal, iteration, true));
            }
            y -= fit.value * fit.normal;
            if !y.is_finite() {
                return None;
            }
            if iteration == self.params.max_iterations {
                let normal = self
                    .fit_with(y, candidates.iter().copied())
                    .map_or(fit.normal, |f| f.normal);
                return Some(self.finish(x, y, normal, iteration, false));
            }
        }
        None
    }

    /// The input point nearest to `query`, with its normal: the surface's stand-in where
    /// the kernel does not reach. `gathered` is the nearest sample a projection attempt
    /// already found within its gathering ball; only beyond that ball is the index asked.
    fn nearest_sample(&self, query: Vec3, gathered: Option<usize>) -> Option<SurfacePoint> {
        let nearest = match gathered {
            Some(index) => index,
            None => self.index.nearest_one(query).ok()??.index,
        };
        Some(SurfacePoint {
            point: self.points[nearest],
            normal: self.normals[nearest],
        })
    }

    /// Whether `query` lies inside by the tangent planes of its
    /// [`MlsParams::fallback_sign_samples`](crate::MlsParams::fallback_sign_samples) nearest
    /// samples: the sum of its signed distances to them, each over its squared distance to
    /// the sample, is negative. `None` when the index cannot answer.
    fn inside_by_nearby_planes(&self, query: Vec3) -> Option<bool> {
        let nearest = self
            .index
            .nearest(query, self.params.fallback_sign_samples)
            .ok()?;
        let vote: f32 = nearest
            .iter()
            .map(|n| {
                let offset = query - self.points[n.index];
                offset.dot(self.normals[n.index]) / offset.length_squared().max(f32::MIN_POSITIVE)
            })
            .sum();
        Some(vote < 0.0)
    }

    /// The signed distance and closest point of `query`, or [`BandAnswer::Beyond`] when the
    /// distance exceeds `max_distance` (checked before the sign is worked out) or the
    /// surface has no answer. Out of the kernel's reach the answer is the nearest sample,
    /// and so it stays for every query whose nearest sample lies beyond the support radius:
    /// the clearance is how much farther than both that radius and `max_distance` the
    /// nearest sample is (the nearest-sample distance is 1-Lipschitz).
    fn signed_distance_up_to(&self, query: Vec3, max_distance: f32) -> BandAnswer {
        let nothing = BandAnswer::Beyond { clearance: 0.0 };
        let ProjectionAttempt {
            start,
            projection,
            nearest_gathered,
        } = self.attempt_projection(query);
        let (c, out_of_reach) = match projection {
            Some(p) => (
                SurfacePoint {
                    point: p.point,
                    normal: p.normal,
                },
                false,
            ),
            None => match self.nearest_sample(query, nearest_gathered) {
                Some(c) => (c, start.is_none()),
                None => return nothing,
            },
        };
        let offset = query - c.point;
        let d = offset.length();
        if d.is_nan() {
            return nothing;
        }
        if d > max_distance {
            let clearance = d * (1.0 - CLEARANCE_MARGIN) - self.support_radius().max(max_distance);
            return BandAnswer::Beyond {
                clearance: if out_of_reach {
                    clearance.max(0.0)
                } else {
                    0.0
                },
            };
        }
        let along_normal = offset.dot(c.normal);
        let inside = match start {
            Some(fit) => fit.value < 0.0,
            None if self.params.fallback_sign_samples > 1
                && along_normal.abs() < SINGLE_PLANE_COSINE * d =>
            {
                match self.inside_by_nearby_planes(query) {
                    Some(inside) => inside,
                    None => return nothing,
                }
            }
            None => along_normal < 0.0,
        };
        BandAnswer::Within {
            distance: if inside { -d } else { d },
            closest: c,
        }
    }

    fn finish(
        &self,
        query: Vec3,
        point: Vec3,
        normal: Vec3,
        iterations: usize,
        converged: bool,
    ) -> Projection {
        let offset = query - point;
        let sign = if offset.dot(normal) < 0.0 { -1.0 } else { 1.0 };
        Projection {
            point,
            normal,
            signed_distance: sign * offset.length(),
            iterations,
            converged,
        }
    }

    /// Signed distance of `x` to the surface (via projection).
    pub fn signed_distance(&self, x: Vec3) -> Option<f32> {
        self.project(x).map(|p| p.signed_distance)
    }

    /// Gradient of the signed distance at `x`: the surface normal at `x`'s projection (the
    /// exact gradient of a distance field is the normal at the closest point).
    pub fn gradient(&self, x: Vec3) -> Option<Vec3> {
        self.project(x).map(|p| p.normal)
    }

    /// Projects many points in parallel (deterministic: each result depends only on its
    /// query).
    pub fn project_all(&self, queries: &[Vec3]) -> Vec<Option<Projection>> {
        queries.par_iter().map(|&q| self.project(q)).collect()
    }
}

/// Where the kernel does not reach, [`Surface::closest_point`] falls back to the nearest
/// input point and its normal, so distance fields stay defined (with a coarser value) far
/// from the samples. [`MlsSurface::project`] itself returns `None` there.
impl Surface for MlsSurface {
    fn closest_point(&self, query: Vec3) -> Option<SurfacePoint> {
        let attempt = self.attempt_projection(query);
        if let Some(p) = attempt.projection {
            return Some(SurfacePoint {
                point: p.point,
                normal: p.normal,
            });
        }
        self.nearest_sample(query, attempt.nearest_gathered)
    }

    /// Magnitude from the projection; sign from `f(query)` where the kernel reaches the
    /// query (the surface *is* the zero set of `f`, so the grid's zero crossings match it),
    /// otherwise from the planes of the nearest samples
    /// ([`MlsParams::fallback_sign_samples`](crate::MlsParams::fallback_sign_samples)). The
    /// neighbours of the query are gathered once for the projection and `f`.
    fn signed_distance(&self, query: Vec3) -> Option<(f32, SurfacePoint)> {
        self.signed_distance_up_to(query, f32::INFINITY).within()
    }

    /// [`Surface::signed_distance`] filtered to `max_distance`; the sign is not worked out
    /// for an answer that is too far (out of the kernel's reach that costs a search for
    /// the nearest samples, and most nodes of a distance grid are out of reach).
    fn signed_distance_within(
        &self,
        query: Vec3,
        max_distance: f32,
    ) -> Option<(f32, SurfacePoint)> {
        self.signed_distance_up_to(query, max_distance).within()
    }

    /// Out of the kernel's reach the clearance is the nearest sample's distance less the
    /// larger of the support radius and `max_distance`: every query that near still has
    /// no sample in its support and its nearest sample beyond the bound. `likely` is
    /// ignored: the projection costs the same whatever the bound, and trying a smaller
    /// bound first would repeat it whenever the answer lies between the two.
    fn signed_distance_or_clearance(
        &self,
        query: Vec3,
        max_distance: f32,
        _likely: Option<f32>,
    ) -> BandAnswer {
        self.signed_distance_up_to(query, max_distance)
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use pointset_core::{PointSet, rng};
    use rand::RngExt;

    use super::MlsSurface;
    use crate::params::MlsParams;

    /// Fits from the points gathered along a segment are the index's fits, bit for bit:
    /// the same points in the same order (rays rely on it to gather once).
    #[test]
    fn fits_among_points_gathered_along_a_segment_are_the_index_fits() {
        let mut g = rng::rng_from_seed(4);
        // A bumpy sheet with noise, and coincident samples to make ties in the order.
        let mut positions: Vec<Vec3> = (0..1500)
            .map(|_| {
                let (x, y) = (g.random::<f32>(), g.random::<f32>());
                Vec3::new(x, y, 0.05 * (9.0 * x).sin() + 0.003 * g.random::<f32>())
            })
            .collect();
        positions.extend_from_within(0..100);
        let n = positions.len();
        let set = PointSet::new(positions)
            .unwrap()
            .with_normals(vec![Vec3::Z; n])
            .unwrap();
        let surface = MlsSurface::new(&set, &MlsParams::default()).unwrap();
        let mut order = Vec::new();
        let (mut compared, mut fitted) = (0, 0);
        for _ in 0..200 {
            let (x, y) = (g.random::<f32>(), g.random::<f32>());
            let from = Vec3::new(
                x,
                y,
                0.05 * (9.0 * x).sin() + 0.04 * (g.random::<f32>() - 0.5),
            );
            let to = from + 0.1 * (Vec3::new(g.random(), g.random(), g.random()) - 0.5);
            let gathered = surface.gather_along(from, to);
            for k in 0..=16 {
                let x = from.lerp(to, k as f32 / 16.0);
                let by_index = surface.fit(x);
                assert_eq!(surface.fit_among(x, &gathered, &mut order), by_index);
                compared += 1;
                fitted += usize::from(by_index.is_some());
            }
        }
        // Most of the points compared have a fit (the comparison is not of two `None`s).
        assert!(fitted > compared / 2, "{fitted} of {compared}");
    }
}
