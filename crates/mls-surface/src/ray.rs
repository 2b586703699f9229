//! Ray–surface intersection in the spirit of Adamson & Alexa (2003), and the two-ray snap
//! of paper 000 §5.3.
//!
//! The ray is marched through the kernel's support in steps of `h / 4`, evaluating the
//! implicit function `f`; the first sign change between two points where `f` is defined
//! brackets a root, which is refined to `|f| < tolerance · h` (or 40 fits) by intersecting
//! the ray with the local fit's plane, as Adamson and Alexa do, safeguarded by bisection.
//! Sign changes where `|f|` at both ends exceeds the step length are rejected: they are
//! jumps of `f` between two sheets of the surface, not crossings.

use glam::Vec3;

use crate::surface::{LocalFit, MlsSurface, Projection};

/// Most fits [`MlsSurface::refine`] makes to find a root it has bracketed.
const REFINE_STEPS: usize = 40;

/// A ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Ray parameter of the hit (distance along the unit direction).
    pub t: f32,
    /// The hit point.
    pub point: Vec3,
    /// Surface normal `n` at the hit.
    pub normal: Vec3,
}

/// How [`MlsSurface::snap`] found its surface point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SnapMethod {
    /// The closer hit of the two rays along `±n`.
    Ray,
    /// Neither ray hit within the kernel support: the projection.
    Projection,
}

/// A point snapped onto the surface by [`MlsSurface::snap`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Snap {
    /// The surface point, its normal and the signed offset along `n` (0 iterations for a
    /// ray hit).
    pub projection: Projection,
    /// Whether a ray or the projection found it.
    pub method: SnapMethod,
}

/// The input points near one ray, gathered once for every fit along it (every point
/// within the support radius of some point of the ray that is marched), the ray, the fit
/// at its origin once made, and scratch space for ordering a fit's points.
struct NearRay<'a> {
    origin: Vec3,
    dir: Vec3,
    gathered: &'a [usize],
    /// The fit at `origin` (`Some(None)`: the surface is undefined there), kept when
    /// the ray turns around ([`Self::turn_around`]).
    at_origin: Option<Option<LocalFit>>,
    order: Vec<u64>,
}

impl<'a> NearRay<'a> {
    /// The ray from `origin` in the unit direction `dir`, and the points `gathered` near it.
    fn new(origin: Vec3, dir: Vec3, gathered: &'a [usize]) -> Self {
        Self {
            origin,
            dir,
            gathered,
            at_origin: None,
            order: Vec::new(),
        }
    }

    /// Turns the ray around: the same origin, the opposite direction, the same gathered
    /// points (which must include every point within the support radius of the turned
    /// ray's marched points too, as a gathering around both rays' segment does). The fit
    /// at the origin stays the same, so it is not made again.
    fn turn_around(&mut self) {
        self.dir = -self.dir;
    }

    /// The point `origin + t·dir` of the ray.
    fn point(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }

    /// The hit at `t`, where the surface's fit is `fit`.
    fn hit(&self, t: f32, fit: &LocalFit) -> RayHit {
        RayHit {
            t,
            point: self.point(t),
            normal: fit.normal,
        }
    }

    /// The surface's fit at [`Self::point`]`(t)` ([`MlsSurface::fit_among`] the points
    /// gathered).
    fn fit_at(&mut self, surface: &MlsSurface, t: f32) -> Option<LocalFit> {
        if t == 0.0
            && let Some(fit) = self.at_origin
        {
            return fit;
        }
        let fit = surface.fit_among(
            self.point(t),
            self.gathered.iter().copied(),
            &mut self.order,
        );
        if t == 0.0 {
            self.at_origin = Some(fit);
        }
        fit
    }
}

impl MlsSurface {
    /// The first intersection of the ray `origin + t·direction`, `0 ≤ t ≤ max_t`, with the
    /// surface. `direction` need not be unit length (it is normalized); `None` when there is
    /// no crossing within `max_t` or the input is degenerate.
    pub fn intersect_ray(&self, origin: Vec3, direction: Vec3, max_t: f32) -> Option<RayHit> {
        let dir = direction.try_normalize()?;
        if !(origin.is_finite() && max_t.is_finite() && max_t >= 0.0) {
            return None;
        }
        // Every fit lies on the ray up to `max_t`: the points near that segment, gathered
        // once, serve them all.
        let gathered = self.gather_along(origin, origin + max_t * dir);
        self.march(
            &mut NearRay::new(origin, dir, &gathered),
            max_t,
            f32::INFINITY,
        )
    }

    /// [`Self::intersect_ray`] of the ray from `origin` in the unit direction `dir`, with
    /// the fits made from `candidates` (indices of the points), which must include every
    /// point within the support radius of some point of the ray up to `max_t`.
    pub(crate) fn intersect_ray_among(
        &self,
        origin: Vec3,
        dir: Vec3,
        max_t: f32,
        candidates: &[usize],
    ) -> Option<RayHit> {
        if !(origin.is_finite() && dir.is_normalized() && max_t.is_finite() && max_t >= 0.0) {
            return None;
        }
        self.march(
            &mut NearRay::new(origin, dir, candidates),
            max_t,
            f32::INFINITY,
        )
    }

    /// The march's step along a ray: a quarter kernel.
    fn march_step(&self) -> f32 {
        0.25 * self.kernel()
    }

    /// The march along `ray` from its origin up to `max_t`, stopping before a step that
    /// starts at or beyond `stop` and answering `None` there: every hit it could still
    /// find would lie at `t ≥ stop`. Below `stop` it visits the same points, so any hit it
    /// returns is the one of the whole march.
    fn march(&self, ray: &mut NearRay, max_t: f32, stop: f32) -> Option<RayHit> {
        let step = self.march_step();
        let steps = (max_t / step).ceil() as usize;
        let mut prev = ray.fit_at(self, 0.0).map(|fit| (0.0, fit));
        for k in 1..=steps.max(1) {
            if ((k - 1) as f32 * step).min(max_t) >= stop {
                return None;
            }
            let t = (k as f32 * step).min(max_t);
            let current = ray.fit_at(self, t).map(|fit| (t, fit));
            if let (Some((t0, fit0)), Some((t1, fit1))) = (prev, current) {
                let (f0, f1) = (fit0.value, fit1.value);
                if f0 == 0.0 {
                    return Some(ray.hit(t0, &fit0));
                }
                let crossing = (f0 < 0.0) != (f1 < 0.0);
                if crossing && f0.abs().min(f1.abs()) <= step {
                    return self.refine(ray, (t0, fit0), (t1, fit1));
                }
            }
            prev = current;
        }
        None
    }

    /// The root of `f` along `ray` between `lo` and `hi` (ray parameters, `lo.0 < hi.0`,
    /// with fits of opposite signs): the hit where `|f| < tolerance · h`, or where the
    /// bracket has shrunk below `10⁻⁷ h`, after at most [`REFINE_STEPS`] fits.
    ///
    /// Each step intersects the ray with the plane of the last fit, as Adamson and Alexa
    /// trace rays: `f(x) = n · (x − a)` is the distance to that plane, so the ray meets it
    /// at `t − f / (n · d)`. Near the surface `f` is nearly linear along the ray and this
    /// converges in a few fits. The step is safeguarded: where it would leave the bracket,
    /// or where the previous one did not halve `|f|`, the bracket's middle is taken
    /// instead. (Bisection alone took about 11 fits a hit at the default tolerance.) The
    /// bracket keeps a sign change throughout, so the hit is never outside it.
    fn refine(
        &self,
        ray: &mut NearRay,
        mut lo: (f32, LocalFit),
        mut hi: (f32, LocalFit),
    ) -> Option<RayHit> {
        let tolerance = self.params().tolerance * self.kernel();
        let shortest = 1e-7 * self.kernel();
        let mut last = if lo.1.value.abs() <= hi.1.value.abs() {
            lo
        } else {
            hi
        };
        let mut newton = true;
        for _ in 0..REFINE_STEPS {
            let middle = 0.5 * (lo.0 + hi.0);
            let slope = last.1.normal.dot(ray.dir);
            let along_plane = last.0 - last.1.value / slope;
            let t = if newton && along_plane > lo.0 && along_plane < hi.0 {
                along_plane
            } else {
                middle
            };
            let fit = ray.fit_at(self, t)?;
            if fit.value.abs() < tolerance || (hi.0 - lo.0) < shortest {
                return Some(ray.hit(t, &fit));
            }
            newton = fit.value.abs() <= 0.5 * last.1.value.abs();
            if (fit.value < 0.0) == (lo.1.value < 0.0) {
                lo = (t, fit);
            } else {
                hi = (t, fit);
            }
            last = (t, fit);
        }
        let t = 0.5 * (lo.0 + hi.0);
        let fit = ray.fit_at(self, t)?;
        Some(ray.hit(t, &fit))
    }

    /// The hits of [`Self::snap`]'s two rays from `p`, along `n` and along `−n`, each up
    /// to the support radius: those of [`Self::intersect_ray`], except that the ray
    /// marched second stops where the first one's hit lies, so its hit is only found
    /// where it is as close or closer (the forward ray) or strictly closer (the backward
    /// one). Both rays fit from the points within the support radius of the segment they
    /// span (`p ± radius·n̂`), gathered once, and share the fit at `p`.
    ///
    /// The ray toward the surface as `f(p)` tells it goes first: where `f(p) > 0`, `p`
    /// lies on the side the normals point to, so the surface is most likely behind it,
    /// along `−n`. Marched first, the backward ray's hit then cuts the forward march short,
    /// which would otherwise run its whole length for nothing. The order does not change
    /// the snap: the closer hit wins either way, the forward one on a tie.
    fn snap_rays(&self, p: Vec3, n: Vec3) -> (Option<RayHit>, Option<RayHit>) {
        let max_t = self.support_radius();
        let Some(dir) = n.try_normalize() else {
            return (None, None);
        };
        if !(p.is_finite() && max_t.is_finite()) {
            return (None, None);
        }
        let near = self.gather_around(p - max_t * dir, p + max_t * dir);
        let mut ray = NearRay::new(p, dir, &near);
        let behind = ray.fit_at(self, 0.0).is_some_and(|fit| fit.value > 0.0);
        if behind {
            ray.turn_around();
        }
        let first = self.march(&mut ray, max_t, f32::INFINITY);
        // The second march stops where the first hit lies; a forward hit as far as the
        // backward one wins the tie, so a forward march going second also takes a step
        // that starts exactly there.
        let stop = match first {
            Some(hit) if behind => hit.t.next_up(),
            Some(hit) => hit.t,
            None => f32::INFINITY,
        };
        ray.turn_around();
        let second = self.march(&mut ray, max_t, stop);
        if behind {
            (second, first)
        } else {
            (first, second)
        }
    }

    /// Paper 000 §5.3: shoots rays from `p` along `+n` and `−n` (up to the kernel support),
    /// keeps the closer hit, and falls back to [`MlsSurface::project`] when neither ray hits.
    /// The returned signed distance is `p`'s offset from the hit along `n`.
    pub fn snap_along_normal(&self, p: Vec3, n: Vec3) -> Option<Projection> {
        self.snap(p, n).map(|snap| snap.projection)
    }

    /// [`MlsSurface::snap_along_normal`], also telling whether a ray or the projection
    /// found the point.
    ///
    /// ```
    /// use glam::Vec3;
    /// use mls_surface::{MlsParams, MlsSurface, SnapMethod};
    /// use pointset_core::PointSet;
    ///
    /// let plane: Vec<Vec3> = (0..400)
    ///     .map(|i| Vec3::new((i % 20) as f32 * 0.05, (i / 20) as f32 * 0.05, 0.0))
    ///     .collect();
    /// let set = PointSet::new(plane)?.with_normals(vec![Vec3::Z; 400])?;
    /// let surface = MlsSurface::new(&set, &MlsParams::default())?;
    /// let snap = surface
    ///     .snap(Vec3::new(0.5, 0.5, 0.02), Vec3::Z)
    ///     .ok_or("no surface near the point")?;
    /// assert_eq!(snap.method, SnapMethod::Ray);
    /// assert!(snap.projection.point.z.abs() < 1e-3);
    /// // Rays along the plane never cross it: the projection finds the point instead.
    /// let beside = surface
    ///     .snap(Vec3::new(0.5, 0.5, 0.02), Vec3::X)
    ///     .ok_or("no surface near the point")?;
    /// assert_eq!(beside.method, SnapMethod::Projection);
    /// assert!(beside.projection.point.z.abs() < 1e-3);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn snap(&self, p: Vec3, n: Vec3) -> Option<Snap> {
        let (forward, backward) = self.snap_rays(p, n);
        let best = match (forward, backward) {
            (Some(a), Some(b)) => Some(if a.t <= b.t { (a, -1.0) } else { (b, 1.0) }),
            (Some(a), None) => Some((a, -1.0)),
            (None, Some(b)) => Some((b, 1.0)),
            (None, None) => None,
        };
        match best {
            Some((hit, sign)) => Some(Snap {
                projection: Projection {
                    point: hit.point,
                    normal: hit.normal,
                    signed_distance: sign * hit.t,
                    iterations: 0,
                    converged: true,
                },
                method: SnapMethod::Ray,
            }),
            None => self.project(p).map(|projection| Snap {
                projection,
                method: SnapMethod::Projection,
            }),
        }
    }
}
