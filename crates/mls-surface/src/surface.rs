//! The MLS point-set surface of Adamson & Alexa (2004): evaluation and projection.

use glam::Vec3;
use pointset_core::spatial::{key_index, nearness_key};
use std::sync::OnceLock;

use pointset_core::spatial::NearestUpTo;
use pointset_core::{BandAnswer, KdIndex, KdRegion, Neighbour, PointSet, Surface, SurfacePoint};
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

/// A surface prepared for queries near one place ([`Surface::prepared_near`]) looks for
/// the nearest sample of a query out of the kernel's reach among the samples within the
/// query's bound (a grid's band) of the queries' reach, and at least this many support
/// radii.
const NEAREST_REACH: f32 = 2.5;

/// Most samples a prepared surface expects to gather for nearest samples (estimated from
/// its neighbours); beyond it, the index answers. Measured on the Mount St. Helens quilt
/// (146k samples on a sheet): gathering without a limit cost 3% more than asking the index
/// alone, and a limit of 256 saved 4% against it; the chain mail fixture, whose regions
/// stay under it, gains the same either way (docs/performance.md).
const NEAREST_MAX_MEMBERS: f32 = 256.0;

/// Relative margin added to the radius a prepared surface gathers in, so that rounding
/// does not leave the queries at the very end of its reach uncovered.
const REGION_SLACK: f32 = 1e-4;

/// Largest reach, in support radii, that a surface is prepared for: the gathered samples
/// then lie within 3.5 support radii of the centre, about five times the area of one
/// query's gathering ball on a sheet. At 2 the quality measure's fine field (nodes a
/// quarter support apart) is prepared in whole 8 × 8 × 8 blocks; the value was not tuned
/// beyond that (1, with runs of 8 nodes along a row, gained less: docs/performance.md).
const PREPARED_MAX_REACH: f32 = 2.0;

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
        Neighbours::within(&self.index, x, radius)
    }

    /// The input points near the segment `from`–`to`: every point within the support of
    /// some point of it, and more (those within the support of the ball around the
    /// segment). [`Self::fit_among`] fits at points of the segment from them.
    pub(crate) fn gather_along(&self, from: Vec3, to: Vec3) -> Vec<usize> {
        let reach = 0.5 * from.distance(to) + self.support_radius();
        // A little slack for the rounding of points computed along the segment.
        self.candidates(0.5 * (from + to), reach * (1.0 + 1e-5) + 1e-6 * self.h)
    }

    /// The input points within the support radius of some point of the segment
    /// `from`–`to` (a capsule around it), and a little beyond, for the rounding of points
    /// computed along the segment far from the origin. [`Self::fit_among`] fits at points
    /// of the segment from them, as from [`Self::gather_along`]'s ball around it, which
    /// holds more: a sheet across a segment one support radius long meets that ball in a
    /// disc of 1.5 support radii, and the capsule in a disc of one.
    pub(crate) fn gather_around(&self, from: Vec3, to: Vec3) -> Vec<usize> {
        let size = from.abs().max_element().max(to.abs().max_element());
        let reach =
            self.support_radius() * (1.0 + 1e-5) + 1e-6 * self.h + 8.0 * f32::EPSILON * size;
        let axis = to - from;
        let length2 = axis.length_squared();
        let half = 0.5 * length2.sqrt();
        let ball = self.candidates(0.5 * (from + to), half + reach);
        ball.into_iter()
            .filter(|&i| {
                let offset = self.points[i] - from;
                let along = if length2 > 0.0 {
                    (offset.dot(axis) / length2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (offset - along * axis).length_squared() <= reach * reach
            })
            .collect()
    }

    /// [`Self::fit`] at `x` from `gathered` (indices of points that include every one
    /// within the support of `x`, such as [`Self::gather_along`] a segment through `x`)
    /// instead of the spatial index: the points within the support taken in the order the
    /// index returns them (nearest first, ties to the lower index), so the sums, and the
    /// fit, are the same. `order` is scratch space.
    pub(crate) fn fit_among(
        &self,
        x: Vec3,
        gathered: impl IntoIterator<Item = usize>,
        order: &mut Vec<u64>,
    ) -> Option<LocalFit> {
        if !x.is_finite() {
            return None;
        }
        let radius = self.support_radius();
        let r2 = radius * radius;
        order.clear();
        order.extend(gathered.into_iter().filter_map(|i| {
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
        self.attempt_projection(x, &self.index).projection
    }

    /// [`Self::project`], also keeping the fit at `x` itself (its first iteration) and the
    /// nearest sample met on the way, so a caller that needs `f(x)`, the projection or,
    /// failing both, the nearest sample gathers the neighbours once.
    fn attempt_projection(&self, x: Vec3, lookup: &dyn Neighbours) -> ProjectionAttempt {
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
        let candidates = lookup.within(x, GATHER_RADIUS * self.support_radius());
        attempt.nearest_gathered = candidates.first().copied();
        attempt.start = self.fit_with(x, candidates.iter().copied());
        if let Some(start) = attempt.start {
            attempt.projection = self.iterate_projection(x, start, candidates, lookup);
        }
        attempt
    }

    /// The iteration of [`Self::project`] from the fit `start` at `x`, with `candidates`
    /// gathered around `x` and more looked up by `lookup`; `None` where the iteration
    /// leaves the surface.
    fn iterate_projection(
        &self,
        x: Vec3,
        start: LocalFit,
        mut candidates: Vec<usize>,
        lookup: &dyn Neighbours,
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
                    candidates = lookup.within(anchor, radius + slack);
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
    /// already found within its gathering ball; only beyond that ball is `lookup` asked.
    fn nearest_sample(
        &self,
        query: Vec3,
        gathered: Option<usize>,
        lookup: &dyn Neighbours,
    ) -> Option<SurfacePoint> {
        let nearest = match gathered {
            Some(index) => index,
            None => lookup.nearest_one(query)?,
        };
        Some(self.sample(nearest))
    }

    /// Input point `index` with its normal.
    fn sample(&self, index: usize) -> SurfacePoint {
        SurfacePoint {
            point: self.points[index],
            normal: self.normals[index],
        }
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
    fn signed_distance_up_to(
        &self,
        query: Vec3,
        max_distance: f32,
        lookup: &dyn Neighbours,
    ) -> BandAnswer {
        let nothing = BandAnswer::Beyond { clearance: 0.0 };
        let ProjectionAttempt {
            start,
            projection,
            nearest_gathered,
        } = self.attempt_projection(query, lookup);
        let out_of_reach = projection.is_none() && start.is_none();
        // Beyond `max_distance`, the nearest sample at least `d` away.
        let beyond = |d: f32| BandAnswer::Beyond {
            clearance: if out_of_reach {
                (d * (1.0 - CLEARANCE_MARGIN) - self.support_radius().max(max_distance)).max(0.0)
            } else {
                0.0
            },
        };
        let c = match projection {
            Some(p) => SurfacePoint {
                point: p.point,
                normal: p.normal,
            },
            None => {
                let nearest = match nearest_gathered {
                    Some(index) => index,
                    None => match lookup.nearest_up_to(query, max_distance) {
                        NearestUpTo::Found(Some(n)) => n.index,
                        NearestUpTo::Found(None) => return nothing,
                        NearestUpTo::Farther { at_least } => return beyond(at_least),
                    },
                };
                self.sample(nearest)
            }
        };
        let offset = query - c.point;
        let d = offset.length();
        if d.is_nan() {
            return nothing;
        }
        if d > max_distance {
            return beyond(d);
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

    /// [`Surface::closest_point`] with neighbours from `lookup`.
    fn closest_point_with(&self, query: Vec3, lookup: &dyn Neighbours) -> Option<SurfacePoint> {
        let attempt = self.attempt_projection(query, lookup);
        if let Some(p) = attempt.projection {
            return Some(SurfacePoint {
                point: p.point,
                normal: p.normal,
            });
        }
        self.nearest_sample(query, attempt.nearest_gathered, lookup)
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
        self.closest_point_with(query, &self.index)
    }

    /// Magnitude from the projection; sign from `f(query)` where the kernel reaches the
    /// query (the surface *is* the zero set of `f`, so the grid's zero crossings match it),
    /// otherwise from the planes of the nearest samples
    /// ([`MlsParams::fallback_sign_samples`](crate::MlsParams::fallback_sign_samples)). The
    /// neighbours of the query are gathered once for the projection and `f`.
    fn signed_distance(&self, query: Vec3) -> Option<(f32, SurfacePoint)> {
        self.signed_distance_up_to(query, f32::INFINITY, &self.index)
            .within()
    }

    /// [`Surface::signed_distance`] filtered to `max_distance`; the sign is not worked out
    /// for an answer that is too far (out of the kernel's reach that costs a search for
    /// the nearest samples, and most nodes of a distance grid are out of reach).
    fn signed_distance_within(
        &self,
        query: Vec3,
        max_distance: f32,
    ) -> Option<(f32, SurfacePoint)> {
        self.signed_distance_up_to(query, max_distance, &self.index)
            .within()
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
        self.signed_distance_up_to(query, max_distance, &self.index)
    }

    /// Two support radii: the gathered samples then number a few times a query's own
    /// neighbours (docs/mls-surface.md, "Prepared surfaces").
    fn preparation_reach(&self) -> Option<f32> {
        Some(PREPARED_MAX_REACH * self.support_radius())
    }

    /// The samples near the queries' reach gathered once (a `KdRegion`): every query's
    /// neighbours and nearest sample come from them where they provably hold all of them,
    /// from the index otherwise, so the answers are the surface's own. `None` for a reach
    /// over [`Surface::preparation_reach`].
    fn prepared_near(&self, centre: Vec3, reach: f32) -> Option<Box<dyn Surface + '_>> {
        let within_limit = reach <= PREPARED_MAX_REACH * self.support_radius();
        // A NaN reach is refused too.
        if !within_limit {
            return None;
        }
        let prepared = PreparedMls {
            surface: self,
            centre,
            reach,
            neighbours: OnceLock::new(),
            nearest: OnceLock::new(),
        };
        prepared.neighbours_region()?;
        Some(Box::new(prepared))
    }
}

/// An [`MlsSurface`] prepared for queries within `reach` of `centre`
/// ([`Surface::prepared_near`]): the samples within [`GATHER_RADIUS`] support radii of the
/// reach, which hold the neighbours of every query within it, and — gathered on the first
/// query out of the kernel's reach, unless there would be too many — those within that
/// query's bound (at least [`NEAREST_REACH`] support radii), which hold the nearest sample
/// of every query within the bound or show that it lies beyond.
struct PreparedMls<'s> {
    surface: &'s MlsSurface,
    centre: Vec3,
    reach: f32,
    neighbours: OnceLock<Option<KdRegion<'s>>>,
    nearest: OnceLock<Option<KdRegion<'s>>>,
}

impl<'s> PreparedMls<'s> {
    /// The region for neighbours, gathered on first use: the samples within a gathering
    /// ball of the reach. `None` where the index cannot gather.
    fn neighbours_region(&self) -> Option<&KdRegion<'s>> {
        self.neighbours
            .get_or_init(|| self.gathered(self.gathering()))
            .as_ref()
    }

    /// The samples within `beyond` of the reach, and a little more ([`REGION_SLACK`]), so
    /// that rounding does not leave the queries at the reach's very end uncovered.
    fn gathered(&self, beyond: f32) -> Option<KdRegion<'s>> {
        let radius = (self.reach + beyond) * (1.0 + REGION_SLACK);
        self.surface.index.region(self.centre, radius).ok()
    }

    /// The region for nearest samples within `bound` ([`Self::nearest_gathering`]), unless
    /// it would hold more than [`NEAREST_MAX_MEMBERS`] samples by the neighbours' count,
    /// scaled by area (samples lie on a surface): scanning that many costs more than the
    /// index's search. `None` then, or where the index cannot gather.
    fn nearest_region(&self, bound: f32) -> Option<&KdRegion<'s>> {
        self.nearest
            .get_or_init(|| {
                let beyond = self.nearest_gathering(bound);
                let neighbours = self.neighbours_region()?;
                let scale = (self.reach + beyond) / (self.reach + self.gathering());
                if neighbours.len() as f32 * scale * scale > NEAREST_MAX_MEMBERS {
                    return None;
                }
                self.gathered(beyond)
            })
            .as_ref()
    }

    /// How far beyond the reach the neighbours are gathered: a projection's gathering
    /// ball.
    fn gathering(&self) -> f32 {
        GATHER_RADIUS * self.surface.support_radius()
    }

    /// How far beyond the reach the nearest samples are gathered for queries bounded by
    /// `bound`: at least the bound, so that every such query gets its nearest sample or
    /// its farther-than-the-bound answer from the region; at least [`NEAREST_REACH`]
    /// support radii, for the unbounded queries. The first query decides.
    fn nearest_gathering(&self, bound: f32) -> f32 {
        let least = NEAREST_REACH * self.surface.support_radius();
        if bound.is_finite() {
            bound.max(least)
        } else {
            least
        }
    }
}

/// The surface's answers, with neighbours looked up in the gathered regions. The default
/// [`Surface::signed_distance_within`] (the unbounded answer, filtered) gives the
/// surface's own: within the bound the two are the same.
impl Surface for PreparedMls<'_> {
    fn closest_point(&self, query: Vec3) -> Option<SurfacePoint> {
        self.surface.closest_point_with(query, self)
    }

    fn signed_distance(&self, query: Vec3) -> Option<(f32, SurfacePoint)> {
        self.signed_distance_or_clearance(query, f32::INFINITY, None)
            .within()
    }

    fn signed_distance_or_clearance(
        &self,
        query: Vec3,
        max_distance: f32,
        _likely: Option<f32>,
    ) -> BandAnswer {
        self.surface
            .signed_distance_up_to(query, max_distance, self)
    }
}

/// Where a query's neighbours are looked up: the surface's index, or regions of it
/// gathered for queries near one place, which answer exactly as the index does.
trait Neighbours {
    /// Indices of the samples within `radius` of `x`, nearest first, ties to the lower
    /// index (empty for non-finite `x`).
    fn within(&self, x: Vec3, radius: f32) -> Vec<usize>;

    /// The index of the sample nearest to `x` (the one the index picks among equally
    /// near ones); `None` for no samples or a non-finite `x`.
    fn nearest_one(&self, x: Vec3) -> Option<usize>;

    /// [`Self::nearest_one`] as [`KdRegion::nearest_one_up_to`] gives it: the sample, or a
    /// distance over `bound` that no sample comes nearer than.
    fn nearest_up_to(&self, x: Vec3, bound: f32) -> NearestUpTo;
}

/// Indices of the neighbours found, or none for a query the index refuses.
fn indices(found: pointset_core::Result<Vec<Neighbour>>) -> Vec<usize> {
    found
        .map(|n| n.into_iter().map(|n| n.index).collect())
        .unwrap_or_default()
}

impl Neighbours for KdIndex {
    fn within(&self, x: Vec3, radius: f32) -> Vec<usize> {
        indices(KdIndex::within(self, x, radius))
    }

    fn nearest_one(&self, x: Vec3) -> Option<usize> {
        Some(KdIndex::nearest_one(self, x).ok()??.index)
    }

    /// Always the sample: the index has no cheaper answer.
    fn nearest_up_to(&self, x: Vec3, _bound: f32) -> NearestUpTo {
        NearestUpTo::Found(KdIndex::nearest_one(self, x).ok().flatten())
    }
}

impl Neighbours for PreparedMls<'_> {
    fn within(&self, x: Vec3, radius: f32) -> Vec<usize> {
        match self.neighbours_region() {
            Some(region) => indices(region.within(x, radius)),
            None => Neighbours::within(&self.surface.index, x, radius),
        }
    }

    fn nearest_one(&self, x: Vec3) -> Option<usize> {
        match self.nearest_region(f32::INFINITY) {
            Some(region) => Some(region.nearest_one(x).ok()??.index),
            None => Neighbours::nearest_one(&self.surface.index, x),
        }
    }

    fn nearest_up_to(&self, x: Vec3, bound: f32) -> NearestUpTo {
        match self.nearest_region(bound) {
            Some(region) => region
                .nearest_one_up_to(x, bound)
                .unwrap_or(NearestUpTo::Found(None)),
            None => self.surface.index.nearest_up_to(x, bound),
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use pointset_core::{PointSet, rng};
    use rand::RngExt;

    use pointset_core::{BandAnswer, Surface};

    use super::{MlsSurface, PREPARED_MAX_REACH};
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
                assert_eq!(
                    surface.fit_among(x, gathered.iter().copied(), &mut order),
                    by_index
                );
                compared += 1;
                fitted += usize::from(by_index.is_some());
            }
        }
        // Most of the points compared have a fit (the comparison is not of two `None`s).
        assert!(fitted > compared / 2, "{fitted} of {compared}");
    }

    /// A surface prepared near a place answers every query as the surface does, bit for
    /// bit — near the place and away from it, in and out of the kernel's reach, with and
    /// without a bound — except that it may promise a smaller clearance.
    #[test]
    fn a_prepared_surface_answers_as_the_surface() {
        let mut g = rng::rng_from_seed(5);
        // Two bumpy sheets facing each other (nodes between them are out of reach or
        // see opposing normals), with coincident samples.
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        for (z, up) in [(0.0, 1.0), (0.3, -1.0)] {
            for _ in 0..1500 {
                let (x, y) = (g.random::<f32>(), g.random::<f32>());
                positions.push(Vec3::new(
                    x,
                    y,
                    z + 0.04 * (9.0 * x).sin() * (7.0 * y).cos(),
                ));
                normals.push(Vec3::new(0.1 * g.random::<f32>(), 0.0, up));
            }
        }
        positions.extend_from_within(0..100);
        normals.extend_from_within(0..100);
        let set = PointSet::new(positions)
            .unwrap()
            .with_normals(normals)
            .unwrap();
        let (mut within, mut beyond, mut smaller) = (0, 0, 0);
        for params in [
            MlsParams::default(),
            MlsParams::default().fallback_sign_samples(1),
        ] {
            let surface = MlsSurface::new(&set, &params).unwrap();
            let support = surface.support_radius();
            for _ in 0..60 {
                let centre = Vec3::new(g.random(), g.random(), 0.5 * g.random::<f32>() - 0.1);
                let reach = 2.0 * support * g.random::<f32>();
                let Some(prepared) = surface.prepared_near(centre, reach) else {
                    panic!("not prepared for a reach of {reach}");
                };
                for _ in 0..30 {
                    let offset = Vec3::new(g.random(), g.random(), g.random()) - 0.5;
                    let q = if g.random_bool(0.8) {
                        centre + offset * reach
                    } else {
                        centre + offset
                    };
                    assert_eq!(prepared.closest_point(q), surface.closest_point(q));
                    assert_eq!(
                        prepared.signed_distance(q),
                        Surface::signed_distance(&surface, q)
                    );
                    for bound in [0.02, 0.1, f32::INFINITY] {
                        let (a, b) = (
                            prepared.signed_distance_or_clearance(q, bound, None),
                            surface.signed_distance_or_clearance(q, bound, None),
                        );
                        match (a, b) {
                            (
                                BandAnswer::Beyond { clearance: mine },
                                BandAnswer::Beyond { clearance: theirs },
                            ) => {
                                assert!(mine <= theirs, "{q}: {mine} > {theirs}");
                                beyond += 1;
                                smaller += usize::from(mine < theirs);
                            }
                            _ => {
                                assert_eq!(a, b, "{q}, bound {bound}");
                                within += 1;
                            }
                        }
                        assert_eq!(
                            prepared.signed_distance_within(q, bound),
                            surface.signed_distance_within(q, bound)
                        );
                    }
                }
            }
        }
        assert!(
            within > 1000 && beyond > 1000,
            "{within} within, {beyond} beyond"
        );
        assert!(smaller > 0 && smaller < beyond / 2, "{smaller} of {beyond}");
    }

    /// Only regions up to [`PREPARED_MAX_REACH`] support radii across are prepared.
    #[test]
    fn wide_regions_are_not_prepared() {
        let set = PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE])
            .unwrap()
            .with_normals(vec![Vec3::Z; 4])
            .unwrap();
        let surface = MlsSurface::new(&set, &MlsParams::default().kernel(0.1)).unwrap();
        let limit = PREPARED_MAX_REACH * surface.support_radius();
        assert!(surface.prepared_near(Vec3::ZERO, limit).is_some());
        assert!(surface.prepared_near(Vec3::ZERO, 1.01 * limit).is_none());
        assert!(surface.prepared_near(Vec3::ZERO, f32::NAN).is_none());
        assert!(surface.prepared_near(Vec3::NAN, limit).is_none());
    }
}
