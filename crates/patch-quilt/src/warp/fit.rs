//! Fitting step 4's spline: the pairs, the corner anchors, the corners' column ends, and
//! the second fit of a warp that stretches too far.

use glam::Vec3;
use pointset_core::Aabb;
use tps_warp::{ThinPlateSpline, TpsParams};

#[cfg(doc)]
use super::warp_patch;
use crate::blend::KeptFootprint;

/// A warp whose largest move of a point that may land in `B_k` exceeds this many times
/// its longest pair is fitted again with more of the free corners' columns pinned
/// ([`fit_restrained`]).
pub(super) const STRETCH_LIMIT: f32 = 3.0;

/// The spline's control points: the paired sources `from`, mapped to `to`, and the
/// corner `anchors`, mapped to themselves.
pub(super) struct Controls<'a> {
    /// The paired sources.
    pub from: &'a [Vec3],
    /// Where the spline maps each of `from`.
    pub to: &'a [Vec3],
    /// The corner anchors.
    pub anchors: &'a [Vec3],
}

/// Fits the warp of `points` with the column ends of [`ColumnEnds::beyond_the_controls`]
/// and, where it moves a point that may land farther than [`STRETCH_LIMIT`] times its
/// longest pair, again with those of [`ColumnEnds::beyond_the_pairs`], keeping
/// the fit whose landing points move less. Returns the fit and whether it is the second.
///
/// The first rule leaves the ends free where the controls span the patch's height, which
/// keeps the warp's freedom on terrain like Mount St. Helens; on a dense height map it
/// still let one patch stretch a pit by about 3.9 times its longest pair, with one corner's
/// samples as deep as the pit and every pair on the plateau above it
/// (docs/patch-quilt-studies.md, "Stretch limit"). `None` when the first fit fails.
pub(super) fn fit_restrained(
    points: &[Vec3],
    controls: &Controls<'_>,
    ends: &ColumnEnds,
    smoothing: f64,
    keep: &KeptFootprint,
) -> Option<(FittedWarp, bool)> {
    let fit = |extra: &[Vec3]| FittedWarp::new(points, controls, extra, smoothing, keep);
    let first = fit(&ends.beyond_the_controls)?;
    let longest_pair = controls
        .from
        .iter()
        .zip(controls.to)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f32::max);
    let more_ends = ends.beyond_the_pairs.len() > ends.beyond_the_controls.len();
    if first.landing_reach <= STRETCH_LIMIT * longest_pair || !more_ends {
        return Some((first, false));
    }
    match fit(&ends.beyond_the_pairs) {
        Some(second) if second.landing_reach < first.landing_reach => Some((second, true)),
        _ => Some((first, false)),
    }
}

/// A fitted spline and where it moves the patch's points.
pub(super) struct FittedWarp {
    /// The spline.
    pub spline: ThinPlateSpline,
    /// Control points mapped to themselves (corner anchors and column ends).
    pub anchors: usize,
    /// The patch's points, moved.
    pub moved: Vec<Vec3>,
    /// Indices of the moved points that may land in `B_k` ([`KeptFootprint::may_land`]).
    pub landing: Vec<usize>,
    /// Largest distance the spline moves a point of `landing`.
    pub landing_reach: f32,
}

impl FittedWarp {
    /// Fits the spline of `controls` with the column ends `ends` as further anchors, and
    /// moves `points` with it. `None` when the system is degenerate or a point moves to a
    /// non-finite position.
    fn new(
        points: &[Vec3],
        controls: &Controls<'_>,
        ends: &[Vec3],
        smoothing: f64,
        keep: &KeptFootprint,
    ) -> Option<Self> {
        let fixed: Vec<Vec3> = controls.anchors.iter().chain(ends).copied().collect();
        let sources: Vec<Vec3> = controls.from.iter().chain(&fixed).copied().collect();
        let targets: Vec<Vec3> = controls.to.iter().chain(&fixed).copied().collect();
        let spline = ThinPlateSpline::fit(
            &sources,
            &targets,
            &TpsParams::default().smoothing(smoothing),
        )
        .ok()?;
        let moved = spline.eval_many(points);
        if moved.iter().any(|p| !p.is_finite()) {
            return None;
        }
        let landing: Vec<usize> = (0..moved.len())
            .filter(|&i| keep.may_land(moved[i]))
            .collect();
        let landing_reach = landing
            .iter()
            .map(|&i| moved[i].distance(points[i]))
            .fold(0.0, f32::max);
        Some(Self {
            spline,
            anchors: fixed.len(),
            moved,
            landing,
            landing_reach,
        })
    }
}

/// The anchors at the ends of the free corners' columns ([`column_end_anchors`]) under
/// the two rules a warp may use.
///
/// The paper maps "corner regions of `F_k`" to themselves; in 3D a corner region is a
/// column through the patch's height. Where every pair and corner sample sits in a thin
/// slab (a plateau of a height map), the spline's stretch along z is fitted to the pairs'
/// noise alone and extrapolated over the patch's full height: on Spot's 1024² texture
/// one warp moved a pit's points by 11 times its longest pair (0.31 box units). Pinning
/// the column's far end bounds that extrapolation ([`warp_patch`]). Where the controls
/// already span the patch's height, the ends are left free at first: pinned there too,
/// they took most of the full method's lead on Mount St. Helens
/// (docs/patch-quilt-studies.md, "Column ends").
#[derive(Default)]
pub(super) struct ColumnEnds {
    /// Where the patch reaches beyond the spline's other control points (pairs and corner
    /// anchors) by more than both their height span and an eighth of the corner: the
    /// rule every warp uses.
    beyond_the_controls: Vec<Vec3>,
    /// Where the patch reaches beyond the pairs alone by more than an eighth of the
    /// corner, however deep the corners' samples reach: for a warp that stretches too far
    /// ([`STRETCH_LIMIT`]).
    beyond_the_pairs: Vec<Vec3>,
}

impl ColumnEnds {
    /// The column ends of the free corners `free` (each of side `corner`) for a patch
    /// bounded by `patch` whose pairs' sources are bounded by `paired` and whose spline's
    /// other control points (pairs and corner anchors) by `controls`.
    pub fn new(free: &[Aabb], patch: &Aabb, paired: &Aabb, controls: &Aabb, corner: f32) -> Self {
        let least = corner / 8.0;
        Self {
            beyond_the_controls: column_end_anchors(
                free,
                patch,
                controls,
                controls.extent().z.max(least),
            ),
            beyond_the_pairs: column_end_anchors(free, patch, paired, least),
        }
    }
}

/// Extra anchors at the bottom and top of each free corner's column: the corner's centre
/// at the lowest or highest z of `patch` (the patch's bounding box), where the patch
/// reaches more than `beyond` below or above `reference` (the bounding box of some of the
/// spline's control points; [`ColumnEnds`]).
fn column_end_anchors(free: &[Aabb], patch: &Aabb, reference: &Aabb, beyond: f32) -> Vec<Vec3> {
    let (low, high) = (patch.min.z, patch.max.z);
    let heights: Vec<f32> = [
        (reference.min.z - low > beyond).then_some(low),
        (high - reference.max.z > beyond).then_some(high),
    ]
    .into_iter()
    .flatten()
    .collect();
    free.iter()
        .flat_map(|region| {
            let centre = region.center().truncate();
            heights.iter().map(move |z| centre.extend(*z))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_surfaces::plateau_with_pit;
    use crate::warp::tests::{sampled_surface, wave_keep};
    use tps_warp::anchors_in_regions;

    #[test]
    fn column_ends_are_pinned_only_where_the_patch_reaches_far_beyond_the_controls() {
        let column = |x: f32| {
            Aabb::new(
                Vec3::new(x, 0.0, f32::MIN / 4.0),
                Vec3::new(x + 0.4, 0.4, f32::MAX / 4.0),
            )
        };
        let free = [column(0.0), column(2.0)];
        // Boxes spanning heights `low` to `high` (only z matters).
        let heights =
            |low: f32, high: f32| Aabb::new(Vec3::new(0.0, 0.0, low), Vec3::new(1.0, 1.0, high));
        // The ends under both rules, for pairs and controls spanning the given heights.
        let ends = |patch: (f32, f32), pairs: (f32, f32), controls: (f32, f32)| {
            let e = ColumnEnds::new(
                &free,
                &heights(patch.0, patch.1),
                &heights(pairs.0, pairs.1),
                &heights(controls.0, controls.1),
                0.4,
            );
            (e.beyond_the_controls, e.beyond_the_pairs)
        };
        let bottom = [Vec3::new(0.2, 0.2, -0.3), Vec3::new(2.2, 0.2, -0.3)];
        // Controls in a slab 0.01 thick at the top of a patch 0.8 high: the bottom ends.
        let (first, wider) = ends((-0.3, 0.5), (0.49, 0.5), (0.49, 0.5));
        assert_eq!(
            (first.as_slice(), wider.as_slice()),
            (&bottom[..], &bottom[..])
        );
        // In the middle of it: both ends of both columns.
        let (first, wider) = ends((-0.3, 0.5), (0.1, 0.11), (0.1, 0.11));
        assert_eq!((first.len(), wider.len()), (4, 4));
        // Beyond the controls by less than their span: none at first; beyond the pairs by
        // more than an eighth of the corner: both ends.
        let (first, wider) = ends((-0.3, 0.5), (-0.1, 0.3), (-0.1, 0.3));
        assert_eq!((first.len(), wider.len()), (0, 4));
        // Corner samples as deep as the patch, pairs in a slab at the top: the bottom ends
        // of the wider rule only.
        let (first, wider) = ends((-0.3, 0.5), (0.45, 0.5), (-0.3, 0.5));
        assert_eq!((first.len(), wider.as_slice()), (0, &bottom[..]));
        // Beyond both by less than an eighth of the corner, and a flat patch.
        assert_eq!(ends((0.0, 0.04), (0.0, 0.0), (0.0, 0.0)), (vec![], vec![]));
        assert_eq!(ends((0.1, 0.1), (0.1, 0.1), (0.1, 0.1)), (vec![], vec![]));
    }

    /// One warp's scene on the plateau of [`plateau_with_pit`].
    struct PlateauScene {
        points: Vec<Vec3>,
        /// 40 pairs' sources along the bottom strip.
        from: Vec<Vec3>,
        /// Their targets, each moved by at most 0.0073 (a pairing's noise).
        to: Vec<Vec3>,
        /// 4 anchors in each top corner, all on the plateau.
        anchors: Vec<Vec3>,
        /// The two top corners' columns.
        free: Vec<Aabb>,
    }

    impl PlateauScene {
        fn new() -> Self {
            let (points, _) = sampled_surface(plateau_with_pit, 2, 0.0);
            let from: Vec<Vec3> = points
                .iter()
                .filter(|p| p.x > 0.0 && p.x < 2.0 && p.y > 0.0 && p.y < 0.3)
                .step_by(5)
                .take(40)
                .copied()
                .collect();
            let to = from
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let t = i as f32;
                    *p + Vec3::new(0.006 * t.sin(), 0.006 * t.cos(), 0.004 * (3.0 * t).sin())
                })
                .collect();
            let column = |x: f32| {
                Aabb::new(
                    Vec3::new(x, 1.55, f32::MIN / 4.0),
                    Vec3::new(x + 0.45, 2.0, f32::MAX / 4.0),
                )
            };
            let free = vec![column(0.0), column(1.55)];
            let anchors = anchors_in_regions(&points, &free, 4);
            Self {
                points,
                from,
                to,
                anchors,
                free,
            }
        }
    }

    #[test]
    fn a_warp_that_stretches_too_far_is_fitted_again_with_the_columns_pinned() {
        let PlateauScene {
            points,
            from,
            to,
            anchors,
            free,
        } = PlateauScene::new();
        assert_eq!((from.len(), anchors.len()), (40, 8));
        let controls = Controls {
            from: &from,
            to: &to,
            anchors: &anchors,
        };
        let longest = from
            .iter()
            .zip(&to)
            .map(|(a, b)| a.distance(*b))
            .fold(0.0, f32::max);
        let bounds = |p: &[Vec3]| Aabb::from_points(p).unwrap();
        let whole = bounds(&[from.clone(), anchors.clone()].concat());
        let pinned = ColumnEnds::new(&free, &bounds(&points), &bounds(&from), &whole, 0.45);
        assert_eq!(pinned.beyond_the_pairs.len(), 2);
        let pit_moved = |warp: &FittedWarp| {
            points
                .iter()
                .zip(&warp.moved)
                .filter(|(b, _)| b.z < 0.2)
                .map(|(b, a)| a.distance(*b))
                .fold(0.0, f32::max)
        };
        // With no end pinned at first (as where the controls span the patch's height),
        // the spline stretches the pit far beyond its longest pair, and the second fit,
        // with the columns' bottom ends pinned, is kept.
        let loose = ColumnEnds {
            beyond_the_controls: Vec::new(),
            beyond_the_pairs: pinned.beyond_the_pairs.clone(),
        };
        let (restrained, second) =
            fit_restrained(&points, &controls, &loose, 0.0, &wave_keep()).unwrap();
        assert!(second);
        assert_eq!(restrained.anchors, 10);
        assert!(
            pit_moved(&restrained) < STRETCH_LIMIT * longest,
            "{}",
            pit_moved(&restrained)
        );
        // Without ends to pin, the first fit stands, stretched.
        let (free_fit, second) = fit_restrained(
            &points,
            &controls,
            &ColumnEnds::default(),
            0.0,
            &wave_keep(),
        )
        .unwrap();
        assert!(!second);
        assert!(free_fit.landing_reach > STRETCH_LIMIT * longest);
        assert!(pit_moved(&free_fit) > 3.0 * pit_moved(&restrained));
        // With the ends the first rule gives here (every control on the plateau), the
        // first fit stays within the limit and is kept.
        let (kept, second) =
            fit_restrained(&points, &controls, &pinned, 0.0, &wave_keep()).unwrap();
        assert!(!second);
        assert!(kept.landing_reach <= STRETCH_LIMIT * longest);
    }
}
