//! Step 5: progressive linear interpolation of the warped patch toward the neighbourhood
//! (paper 000 §5.3, Figure 3c).

use glam::{Vec2, Vec3};
use mls_surface::{MlsSurface, SnapMethod};
use rayon::prelude::*;

/// The overlap of one patch: which strips exist and where.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Overlap {
    /// Patch corner (x_k, y_k).
    pub origin: Vec2,
    /// Overlap width `W_O`.
    pub width: f32,
    /// Patch side `P` (the strips run along it).
    pub patch: f32,
    /// A strip along the left edge (already synthesized patch to the left).
    pub left: bool,
    /// A strip along the bottom edge (already synthesized row below).
    pub bottom: bool,
}

impl Overlap {
    /// Whether `(x, y)` lies in the overlap region `O_k` (the L-shaped strips).
    pub fn contains(&self, q: Vec2) -> bool {
        let d = q - self.origin;
        let inside = d.x >= 0.0 && d.y >= 0.0 && d.x <= self.patch && d.y <= self.patch;
        inside && ((self.left && d.x <= self.width) || (self.bottom && d.y <= self.width))
    }

    /// The strips as rectangles `(lo, hi)` in the reference plane.
    fn strips(&self) -> impl Iterator<Item = (Vec2, Vec2)> + '_ {
        let o = self.origin;
        let left = self
            .left
            .then(|| (o, o + Vec2::new(self.width, self.patch)));
        let bottom = self
            .bottom
            .then(|| (o, o + Vec2::new(self.patch, self.width)));
        left.into_iter().chain(bottom)
    }

    /// Whether the rectangle `[lo, hi]` shares area with the overlap region (touching a
    /// strip along an edge or at a corner does not count).
    pub fn overlaps_rect(&self, lo: Vec2, hi: Vec2) -> bool {
        self.strips().any(|(a, b)| {
            let (l, h) = (lo.max(a), hi.min(b));
            l.x < h.x && l.y < h.y
        })
    }

    /// The ramp of Figure 3c: 1 at the overlap's outer edge (fully the neighbourhood), falling
    /// linearly to 0 at its inner edge (fully the patch), 0 beyond; the larger of the two
    /// strips' values. A strip runs along the patch's side only (not into the extra region
    /// `E_k` beyond it, which the next row or column overwrites); points outside the patch on
    /// the overlap side get 1.
    pub fn ramp(&self, q: Vec2) -> f32 {
        let d = q - self.origin;
        let strip = |u: f32| (1.0 - u / self.width).clamp(0.0, 1.0);
        let left = if self.left && d.y <= self.patch {
            strip(d.x)
        } else {
            0.0
        };
        let bottom = if self.bottom && d.x <= self.patch {
            strip(d.y)
        } else {
            0.0
        };
        left.max(bottom)
    }
}

/// How one point's target was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    Ray,
    Projection,
    Unmatched,
    BeyondReach,
    FacingAway,
}

/// Counts of what blending did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BlendCounts {
    /// Points with a ramp value above 0 that can end up inside `B_k`. A point more than
    /// twice the blend reach outside `B_k` is skipped and not counted: step 6 discards it.
    pub blended: usize,
    /// Of those, targets found by the two-ray intersection.
    pub by_ray: usize,
    /// Of those, targets found by projection (no ray hit).
    pub by_projection: usize,
    /// Of those, no target (no neighbourhood surface nearby): left unchanged.
    pub unmatched: usize,
    /// Of those, a target farther than the reach: different geometry, not a gap; left
    /// unchanged.
    pub beyond_reach: usize,
    /// Of those, a target within reach on a surface facing another way (normals further
    /// apart than the normal agreement allows): a different sheet, not a gap; left
    /// unchanged.
    pub facing_away: usize,
}

impl std::iter::Sum for BlendCounts {
    /// Totals over several blends, e.g. all placements of a run.
    fn sum<I: Iterator<Item = Self>>(iter: I) -> Self {
        iter.fold(Self::default(), |a, b| Self {
            blended: a.blended + b.blended,
            by_ray: a.by_ray + b.by_ray,
            by_projection: a.by_projection + b.by_projection,
            unmatched: a.unmatched + b.unmatched,
            beyond_reach: a.beyond_reach + b.beyond_reach,
            facing_away: a.facing_away + b.facing_away,
        })
    }
}

/// Which gaps steps 4–5 close: the paper's gaps "should be small" (§5.3) and join two
/// versions of one surface. Shared by the blend and by surface-gap warp targets.
#[derive(Debug, Clone, Copy)]
pub(crate) struct GapLimits {
    /// Longest gap.
    pub distance: f32,
    /// Smallest cosine between the point's normal and the surface's where the gap ends.
    pub normal_agreement: f32,
}

/// Why a gap is not closed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum GapRefusal {
    /// Longer than [`GapLimits::distance`]: other geometry, not a gap.
    TooFar,
    /// The surface at its end faces another way: a different sheet, not a gap.
    FacingAway,
}

impl GapLimits {
    /// `None` when the gap `gap` from a point with normal `n` to a surface point with normal
    /// `target_normal` is one to close, else why not.
    pub fn refusal(&self, gap: Vec3, n: Vec3, target_normal: Vec3) -> Option<GapRefusal> {
        if gap.length() > self.distance {
            Some(GapRefusal::TooFar)
        } else if n.dot(target_normal) < self.normal_agreement {
            Some(GapRefusal::FacingAway)
        } else {
            None
        }
    }
}

/// The footprint of `B_k` (whose points step 6 keeps) with the slack a point of `F_k`
/// needs to land in it through the blend: twice the blend reach. The blend moves no point
/// farther than its reach, so a point beyond the slack stays outside whatever its target
/// (twice, not once, so that rounding cannot decide it). Such points are the margin by
/// which `F_k` is extended for the warp (§5.2); step 6 discards them, so neither the
/// blend nor the warp's normal transport spends work on them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct KeptFootprint {
    lo: Vec2,
    hi: Vec2,
    slack: f32,
}

impl KeptFootprint {
    /// The footprint `(lo, hi)` of `B_k` and the blend reach.
    pub fn new((lo, hi): (Vec2, Vec2), blend_reach: f32) -> Self {
        Self {
            lo,
            hi,
            slack: 2.0 * blend_reach,
        }
    }

    /// The footprint `(lo, hi)` of `B_k`.
    pub fn footprint(&self) -> (Vec2, Vec2) {
        (self.lo, self.hi)
    }

    /// Whether a point at `p` can still end up inside the footprint.
    pub fn may_land(&self, p: Vec3) -> bool {
        let q = p.truncate();
        let outside = (self.lo - q).max(q - self.hi).max(Vec2::ZERO);
        outside.length() <= self.slack
    }
}

/// Moves each point with ramp value `t > 0` to `p + t (g − p)` and its normal to
/// `normalize((1 − t) n + t n_g)`, where `g, n_g` is the point's target on the
/// neighbourhood's surface: the closer hit of rays along `±n` (cast as far as the surface's
/// support radius), else the projection. The paper blends the *gaps* the warp leaves, which
/// "should be small" (§5.3); a target farther than `limits.distance` (the reach) is another
/// part of the geometry (a ring or thread the neighbourhood has and the patch has not),
/// and pulling the point onto it would leave points in mid-air, so such a point is left as
/// it is. So is a point whose target's normal makes a cosine below
/// `limits.normal_agreement` with its own: the surface there faces another way (another
/// petal, a crossing thread's underside), and interpolating the two normals would describe
/// neither.
///
/// Only points that can end up inside `keep` ([`KeptFootprint::may_land`], built with
/// `limits.distance` as the reach) are blended; the rest are skipped and not counted. They
/// are the margin by which `F_k` is extended for the warp (§5.2), about half of the points
/// with a ramp value above 0.
pub(crate) fn blend(
    points: &mut [Vec3],
    normals: &mut [Vec3],
    overlap: &Overlap,
    keep: &KeptFootprint,
    neighbourhood: &MlsSurface,
    limits: GapLimits,
) -> BlendCounts {
    let results: Vec<Option<(Vec3, Vec3, Outcome)>> = points
        .par_iter()
        .zip(normals.par_iter())
        .map(|(&p, &n)| {
            if !keep.may_land(p) {
                return None;
            }
            let t = overlap.ramp(p.truncate());
            if t <= 0.0 {
                return None;
            }
            let Some(snap) = neighbourhood.snap(p, n) else {
                return Some((p, n, Outcome::Unmatched));
            };
            let (target, target_normal) = (snap.projection.point, snap.projection.normal);
            let outcome = match snap.method {
                SnapMethod::Ray => Outcome::Ray,
                SnapMethod::Projection => Outcome::Projection,
            };
            match limits.refusal(target - p, n, target_normal) {
                Some(GapRefusal::TooFar) => return Some((p, n, Outcome::BeyondReach)),
                Some(GapRefusal::FacingAway) => return Some((p, n, Outcome::FacingAway)),
                None => {}
            }
            let blended_normal = ((1.0 - t) * n + t * target_normal)
                .try_normalize()
                .unwrap_or(n);
            Some((p + t * (target - p), blended_normal, outcome))
        })
        .collect();
    let mut counts = BlendCounts::default();
    for (i, r) in results.into_iter().enumerate() {
        let Some((p, n, outcome)) = r else { continue };
        counts.blended += 1;
        match outcome {
            Outcome::Ray => counts.by_ray += 1,
            Outcome::Projection => counts.by_projection += 1,
            Outcome::Unmatched => counts.unmatched += 1,
            Outcome::BeyondReach => counts.beyond_reach += 1,
            Outcome::FacingAway => counts.facing_away += 1,
        }
        points[i] = p;
        normals[i] = n;
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;
    use mls_surface::MlsParams;
    use pointset_core::PointSet;

    fn limits(distance: f32, normal_agreement: f32) -> GapLimits {
        GapLimits {
            distance,
            normal_agreement,
        }
    }

    /// The plane z = 0 over [-1.5, 1.45]² as a neighbourhood surface.
    fn plane_surface() -> MlsSurface {
        let plane: Vec<Vec3> = (0..60 * 60)
            .map(|i| {
                Vec3::new(
                    (i % 60) as f32 * 0.05 - 1.5,
                    (i / 60) as f32 * 0.05 - 1.5,
                    0.0,
                )
            })
            .collect();
        let set = PointSet::new(plane)
            .unwrap()
            .with_normals(vec![Vec3::Z; 3600])
            .unwrap();
        MlsSurface::new(&set, &MlsParams::default()).unwrap()
    }

    /// A left overlap strip 0.5 wide on a patch of side 2 at the origin, and its footprint.
    const LEFT_STRIP: Overlap = Overlap {
        origin: Vec2::ZERO,
        width: 0.5,
        patch: 2.0,
        left: true,
        bottom: false,
    };
    const FOOTPRINT: (Vec2, Vec2) = (Vec2::ZERO, Vec2::splat(2.0));

    /// [`blend`] over [`FOOTPRINT`] with blend reach `reach` and normal agreement
    /// `agreement`, the footprint's slack following the same reach as in a run.
    fn blend_within(
        points: &mut [Vec3],
        normals: &mut [Vec3],
        overlap: &Overlap,
        surface: &MlsSurface,
        reach: f32,
        agreement: f32,
    ) -> BlendCounts {
        let keep = KeptFootprint::new(FOOTPRINT, reach);
        blend(
            points,
            normals,
            overlap,
            &keep,
            surface,
            limits(reach, agreement),
        )
    }

    #[test]
    fn blending_moves_points_toward_the_neighbourhood_monotonically_across_the_ramp() {
        // Neighbourhood: the plane z = 0. Patch points: z = 0.1 across the overlap.
        let surface = plane_surface();
        let o = LEFT_STRIP;
        let mut points: Vec<Vec3> = (0..=20)
            .map(|i| Vec3::new(i as f32 * 0.03, 1.0, 0.1))
            .collect();
        let mut normals = vec![Vec3::Z; points.len()];
        let before = points.clone();
        // A gap of 0.1 beyond a reach of 0.05 is not a gap: nothing moves.
        let (mut far, mut far_normals) = (points.clone(), normals.clone());
        let counts = blend_within(&mut far, &mut far_normals, &o, &surface, 0.05, -1.0);
        assert!(counts.blended > 0 && counts.beyond_reach == counts.blended);
        assert_eq!(far, before);
        // The same gap seen from points facing down: the plane faces away from them, a
        // different sheet rather than a gap, and nothing moves unless the test is off.
        let down = vec![-Vec3::Z; points.len()];
        let (mut away, mut away_normals) = (points.clone(), down.clone());
        let counts = blend_within(&mut away, &mut away_normals, &o, &surface, 0.2, 0.8);
        assert!(counts.blended > 0 && counts.facing_away == counts.blended);
        assert_eq!(away, before);
        let (mut any, mut any_normals) = (points.clone(), down);
        blend_within(&mut any, &mut any_normals, &o, &surface, 0.2, -1.0);
        assert_ne!(any, before);
        let counts = blend_within(&mut points, &mut normals, &o, &surface, 0.2, 0.8);
        assert!(counts.blended > 0 && counts.by_ray == counts.blended);
        let mut last = -1.0f32;
        for (p, q) in points.iter().zip(&before) {
            let t = o.ramp(q.truncate());
            // Moved toward the plane by exactly the ramp fraction of the gap.
            assert!((p.z - 0.1 * (1.0 - t)).abs() < 1e-3, "t {t}: z {}", p.z);
            assert!(p.z >= last - 1e-6, "heights must not decrease inward");
            last = p.z;
        }
    }

    #[test]
    fn points_that_cannot_reach_the_kept_footprint_are_not_blended() {
        // Left of the patch the ramp is 1, so every point there would be blended; with a
        // reach of 0.2, those more than 0.4 outside the footprint are skipped.
        let surface = plane_surface();
        let xs = [-0.9f32, -0.6, -0.41, -0.39, -0.2, -0.05];
        let mut points: Vec<Vec3> = xs.iter().map(|&x| Vec3::new(x, 1.0, 0.1)).collect();
        let mut normals = vec![Vec3::Z; points.len()];
        let before = points.clone();
        let counts = blend_within(&mut points, &mut normals, &LEFT_STRIP, &surface, 0.2, 0.8);
        assert_eq!(counts.blended, 3);
        assert_eq!(counts.by_ray, 3);
        for ((p, q), x) in points.iter().zip(&before).zip(xs) {
            if x < -0.4 {
                assert_eq!(
                    p, q,
                    "x = {x} lies beyond twice the reach and must not move"
                );
            } else {
                assert!(
                    p.z.abs() < 1e-3,
                    "x = {x} must land on the plane: z {}",
                    p.z
                );
            }
        }
    }

    #[test]
    fn rectangles_touching_a_strip_do_not_overlap_it() {
        let o = Overlap {
            origin: Vec2::ZERO,
            width: 0.2,
            patch: 1.0,
            left: true,
            bottom: true,
        };
        // The corners beyond the strips' ends touch them only along an edge.
        assert!(!o.overlaps_rect(Vec2::new(0.0, 1.0), Vec2::new(0.3, 1.3)));
        assert!(!o.overlaps_rect(Vec2::new(1.0, 0.0), Vec2::new(1.3, 0.3)));
        assert!(!o.overlaps_rect(Vec2::new(1.0, 1.0), Vec2::new(1.3, 1.3)));
        assert!(o.overlaps_rect(Vec2::new(0.1, 0.9), Vec2::new(0.4, 1.2)));
        assert!(o.overlaps_rect(Vec2::new(0.9, 0.1), Vec2::new(1.2, 0.4)));
        let left_only = Overlap { bottom: false, ..o };
        assert!(!left_only.overlaps_rect(Vec2::new(0.5, 0.0), Vec2::new(0.8, 0.15)));
        assert!(left_only.overlaps_rect(Vec2::new(-0.1, 0.5), Vec2::new(0.1, 0.6)));
    }

    #[test]
    fn ramp_is_one_outside_and_zero_inside() {
        let o = Overlap {
            origin: Vec2::ZERO,
            width: 1.0,
            patch: 4.0,
            left: true,
            bottom: false,
        };
        assert_eq!(o.ramp(Vec2::new(0.0, 2.0)), 1.0);
        assert_eq!(o.ramp(Vec2::new(0.5, 2.0)), 0.5);
        assert_eq!(o.ramp(Vec2::new(1.5, 2.0)), 0.0);
        assert!(o.contains(Vec2::new(0.5, 3.0)) && !o.contains(Vec2::new(2.0, 0.5)));
        let l = Overlap { bottom: true, ..o };
        assert_eq!(l.ramp(Vec2::new(3.0, 0.25)), 0.75);
        assert!(l.contains(Vec2::new(2.0, 0.5)));
        // The strips stop at the patch's sides: the extra region beyond is not overlap.
        assert_eq!(l.ramp(Vec2::new(0.2, 4.5)), 0.0);
        assert_eq!(l.ramp(Vec2::new(4.5, 0.2)), 0.0);
    }
}
