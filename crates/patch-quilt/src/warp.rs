//! Step 4: warping the translated patch onto its neighbourhood with a thin-plate spline
//! driven by the automatic pairing (paper 000 §5.2).

use glam::{Vec2, Vec3};
use mls_surface::{ClusterParams, Covariance, MlsSurface, adaptive_clusters};
use pointset_core::Aabb;
use tps_warp::{
    MAX_CONTROL_POINTS, PairingParams, PairingPoint, ThinPlateSpline, anchors_in_regions,
    pair_points,
};

use crate::blend::{GapLimits, KeptFootprint, Overlap};
#[cfg(doc)]
use crate::params::WarpTargets;

mod fit;

use fit::{ColumnEnds, Controls, fit_restrained};

/// The neighbourhood `N_k` as oriented points and their MLS surface (whose spatial index
/// gives the surface variation of the few points that become targets).
pub(crate) struct Neighbourhood<'a> {
    pub points: &'a [Vec3],
    pub normals: &'a [Vec3],
    pub surface: &'a MlsSurface,
}

/// Per-point attributes of the source set `S` (the extended, translated `F_k`), carried
/// over from the exemplar.
pub(crate) struct SourceAttributes<'a> {
    /// Surface variation.
    pub variation: &'a [f32],
    /// Where a paired source goes, with the per-point data that needs.
    pub targets: PairTargets<'a>,
}

/// Where the spline maps a paired source `s`: the run's [`WarpTargets`] with the per-point
/// data it needs.
#[derive(Debug, Clone, Copy)]
pub(crate) enum PairTargets<'a> {
    /// Onto its partner `q` (the paper).
    Exact,
    /// By the gap from its foot point to the neighbourhood's surface.
    SurfaceGap {
        /// Per source: signed offset along the normal to its foot on the exemplar's MLS
        /// surface.
        foot_offset: &'a [f32],
        /// Smallest cosine between the source's normal and the neighbourhood surface's
        /// where the gap ends ([`QuiltParams::normal_agreement`](crate::QuiltParams)).
        normal_agreement: f32,
    },
}

/// Neighbours used for surface variation (as for the exemplar's points).
const VARIATION_NEIGHBOURS: usize = 12;

impl Neighbourhood<'_> {
    /// Surface variation of point `i` over its 12 nearest neighbours in `N_k`.
    fn variation(&self, i: usize) -> f32 {
        self.surface
            .index()
            .nearest(self.points[i], VARIATION_NEIGHBOURS)
            .ok()
            .and_then(|nn| Covariance::of(self.points, nn.iter().map(|n| n.index)))
            .map_or(0.0, |c| c.variation())
    }
}

/// What one warp did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WarpCounts {
    /// Pairs used (anchors not included).
    pub pairs: usize,
    /// Pairs of the pairing dropped because `N_k` has no surface within the pair distance
    /// limit along the source's normal, or only one facing another way
    /// ([`WarpTargets::SurfaceGap`] only).
    pub dropped_pairs: usize,
    /// Anchor points mapped to themselves (column ends included).
    pub anchors: usize,
    /// Targets `|Q|`.
    pub targets: usize,
    /// Times the clustering's limits (`n_max` and `σ_max`) were both doubled to keep the
    /// pairs within the spline's size limit: 0 unless the configured clustering gives
    /// more pairs than [`MAX_CONTROL_POINTS`] less the anchors.
    pub coarsenings: usize,
    /// `C(Φ)` of the pairing, its lengths in units of the exemplar box
    /// ([`BASE_SIDE`](crate::BASE_SIDE)).
    pub cost: f64,
    /// True when the patch was left unwarped (fewer than 4 pairs or a degenerate system).
    pub skipped: bool,
    /// Mean distance the warp moved the points.
    pub mean_displacement: f32,
    /// Largest distance the warp moved a point.
    pub max_displacement: f32,
    /// Largest distance the warp moved a point that can still land in `B_k` (one within
    /// twice the blend reach of its footprint); step 6 discards the others.
    pub max_landing_displacement: f32,
    /// True when the first fit stretched too far and the warp kept is the second fit, with
    /// the free corners' columns pinned wherever the patch reaches beyond the pairs.
    pub restrained: bool,
    /// Mean length of the spline's pair displacements (after [`WarpTargets`]).
    pub mean_pair_length: f32,
}

/// Warps `points`/`normals` (the extended, translated `F_k` = `S`) in place.
///
/// `Q` = representatives of adaptive clusters of the neighbourhood's points inside the
/// overlap region; anchors = up to `anchors_per_corner` points of `S` in each `w_E × w_E`
/// corner of `B_k`'s footprint that shares no area with the overlap (three for an interior
/// patch: the strips run along the patch's sides only), and those corners' column ends
/// where the patch reaches far beyond the controls along z ([`ColumnEnds`]). The
/// spline maps each paired source to its target ([`WarpTargets`]); a warp that moves a
/// point too far for its pairs is fitted again with more column ends ([`fit_restrained`]).
/// A patch with fewer than four pairs, or whose spline cannot be fitted, is left unwarped
/// (reported, not an error). Normals are turned
/// through the Jacobian only for points that can still land in `keep`
/// ([`KeptFootprint::may_land`]); the others keep their normals, and step 6 discards them.
#[allow(clippy::too_many_arguments)]
pub(crate) fn warp_patch(
    points: &mut [Vec3],
    normals: &mut [Vec3],
    source: &SourceAttributes<'_>,
    neighbourhood: &Neighbourhood<'_>,
    overlap: &Overlap,
    keep: &KeptFootprint,
    corner: f32,
    clusters: &ClusterParams,
    pairing: &PairingParams,
    anchors_per_corner: usize,
    smoothing: f64,
) -> WarpCounts {
    let in_overlap: Vec<usize> = (0..neighbourhood.points.len())
        .filter(|&i| overlap.contains(neighbourhood.points[i].truncate()))
        .collect();
    let positions: Vec<Vec3> = in_overlap
        .iter()
        .map(|&i| neighbourhood.points[i])
        .collect();
    let s: Vec<PairingPoint> = (0..points.len())
        .map(|i| PairingPoint {
            position: points[i],
            normal: normals[i],
            variation: source.variation[i],
        })
        .collect();
    let (lo, hi) = keep.footprint();
    let corners = [
        Vec2::new(lo.x, lo.y),
        Vec2::new(hi.x - corner, lo.y),
        Vec2::new(lo.x, hi.y - corner),
        Vec2::new(hi.x - corner, hi.y - corner),
    ];
    let free: Vec<Aabb> = corners
        .iter()
        .filter(|c| !overlap.overlaps_rect(**c, **c + Vec2::splat(corner)))
        .map(|c| {
            Aabb::new(
                c.extend(f32::MIN / 4.0),
                (*c + Vec2::splat(corner)).extend(f32::MAX / 4.0),
            )
        })
        .collect();
    let anchors = anchors_in_regions(points, &free, anchors_per_corner);
    let column_ends_at_most = if anchors_per_corner > 0 {
        2 * free.len()
    } else {
        0
    };
    let target_side = TargetSide {
        in_overlap: &in_overlap,
        positions: &positions,
        neighbourhood,
    };
    let (found, coarsenings) = coarsened_until(
        clusters,
        positions.len(),
        MAX_CONTROL_POINTS.saturating_sub(anchors.len() + column_ends_at_most),
        |params| {
            let found = target_side.spline_pairs(params, &s, source.targets, pairing);
            let size = found.from.len();
            (found, size)
        },
    );
    let mut counts = WarpCounts {
        targets: found.targets,
        coarsenings,
        skipped: true,
        cost: found.cost,
        dropped_pairs: found.dropped,
        ..WarpCounts::default()
    };
    let (from, to) = (found.from, found.to);
    counts.pairs = from.len();
    if counts.pairs < 4 {
        return counts;
    }
    counts.mean_pair_length = from
        .iter()
        .zip(&to)
        .map(|(a, b)| a.distance(*b))
        .sum::<f32>()
        / counts.pairs as f32;
    let ends = match (
        anchors_per_corner > 0,
        Aabb::from_points(points),
        Aabb::from_points(&from),
    ) {
        (true, Some(patch), Some(paired)) => {
            let controls = anchors.iter().fold(paired, |b, a| b.including(*a));
            ColumnEnds::new(&free, &patch, &paired, &controls, corner)
        }
        _ => ColumnEnds::default(),
    };
    let controls = Controls {
        from: &from,
        to: &to,
        anchors: &anchors,
    };
    let Some((warp, restrained)) = fit_restrained(points, &controls, &ends, smoothing, keep) else {
        return counts;
    };
    counts.anchors = warp.anchors;
    counts.max_landing_displacement = warp.landing_reach;
    counts.restrained = restrained;
    let landing_points: Vec<Vec3> = warp.landing.iter().map(|&i| points[i]).collect();
    let jacobians = warp.spline.jacobians(&landing_points);
    let shifts: Vec<f32> = warp
        .moved
        .iter()
        .zip(points.iter())
        .map(|(a, b)| a.distance(*b))
        .collect();
    counts.mean_displacement = shifts.iter().sum::<f32>() / shifts.len().max(1) as f32;
    counts.max_displacement = shifts.iter().copied().fold(0.0, f32::max);
    points.copy_from_slice(&warp.moved);
    for (i, j) in warp.landing.into_iter().zip(jacobians) {
        normals[i] = ThinPlateSpline::normal_through(j, normals[i]);
    }
    counts.skipped = false;
    counts
}

/// The target side of the pairing: the overlap's points of `N_k` (`positions`, at
/// `in_overlap` in the neighbourhood), from which `Q` is clustered.
struct TargetSide<'a> {
    in_overlap: &'a [usize],
    positions: &'a [Vec3],
    neighbourhood: &'a Neighbourhood<'a>,
}

/// What the pairing gives the spline for one clustering of `Q`.
#[derive(Default)]
struct SplinePairs {
    /// `|Q|` (0 when the clustering failed).
    targets: usize,
    /// `C(Φ)` of the pairing (0 when there was none).
    cost: f64,
    /// Paired sources.
    from: Vec<Vec3>,
    /// Where the spline maps each of `from`.
    to: Vec<Vec3>,
    /// Pairs dropped for want of a target ([`PairTargets::SurfaceGap`]).
    dropped: usize,
}

impl TargetSide<'_> {
    /// Clusters the overlap with `params` into `Q`, pairs `s` with it and maps each pair
    /// to its target. Fewer than 4 targets, or a failed clustering or pairing, give no
    /// pairs.
    fn spline_pairs(
        &self,
        params: &ClusterParams,
        s: &[PairingPoint],
        kind: PairTargets<'_>,
        pairing: &PairingParams,
    ) -> SplinePairs {
        let Ok(groups) = adaptive_clusters(self.positions, params) else {
            return SplinePairs::default();
        };
        let q: Vec<PairingPoint> = groups
            .iter()
            .map(|c| {
                let i = self.in_overlap[c.representative];
                PairingPoint {
                    position: self.neighbourhood.points[i],
                    normal: self.neighbourhood.normals[i],
                    variation: self.neighbourhood.variation(i),
                }
            })
            .collect();
        let mut found = SplinePairs {
            targets: q.len(),
            ..SplinePairs::default()
        };
        if q.len() < 4 {
            return found;
        }
        let Ok(pairs) = pair_points(s, &q, pairing) else {
            return found;
        };
        found.cost = pairs.cost;
        for pair in &pairs.pairs {
            let (s_k, q_k) = (&s[pair.source], &q[pair.target]);
            let target = match kind {
                PairTargets::Exact => Some(q_k.position),
                PairTargets::SurfaceGap {
                    foot_offset,
                    normal_agreement,
                } => surface_gap(
                    self.neighbourhood.surface,
                    s_k.position,
                    s_k.normal,
                    foot_offset[pair.source],
                    GapLimits {
                        distance: pairing.max_distance,
                        normal_agreement,
                    },
                )
                .map(|gap| s_k.position + gap),
            };
            match target {
                Some(t) => {
                    found.from.push(s_k.position);
                    found.to.push(t);
                }
                None => found.dropped += 1,
            }
        }
        found
    }
}

/// Runs `attempt` with the clustering limits `params` and, while the size it reports
/// exceeds `limit`, again with `n_max` and `σ_max` both doubled (a `σ_max` of 0 becomes
/// 1/1024). Returns the last attempt's result and the number of doublings.
///
/// Clusters hold at most `n_max` points, so on dense exemplars `|Q|`, and the pairs with
/// it, grow with the overlap's point count: a 2048 × 2048 height field gave about 4,900
/// pairs a warp, and a patch with more than the spline takes ([`MAX_CONTROL_POINTS`]) was
/// pasted unwarped (4 of that run's 49 warps were skipped; with this, none). Coarser
/// clusters give such patches the warp of a coarser `Q` instead; patches within the limit
/// keep the configured clustering. Stops over the limit once `n_max` reaches `points` (the overlap's point
/// count) and `σ_max` every possible variation (1/3): the overlap is then one cluster.
fn coarsened_until<T>(
    params: &ClusterParams,
    points: usize,
    limit: usize,
    mut attempt: impl FnMut(&ClusterParams) -> (T, usize),
) -> (T, usize) {
    let mut params = params.clone();
    let mut coarsenings = 0;
    loop {
        let (result, size) = attempt(&params);
        let one_cluster = params.max_points >= points && params.max_variation >= LARGEST_VARIATION;
        if size <= limit || one_cluster {
            return (result, coarsenings);
        }
        params = coarser(&params);
        coarsenings += 1;
    }
}

/// Surface variation `λ₀ / (λ₀ + λ₁ + λ₂)` never exceeds this.
const LARGEST_VARIATION: f32 = 1.0 / 3.0;

/// A `σ_max` of 0 doubles to this, so that it reaches [`LARGEST_VARIATION`] in a few rounds.
const SMALLEST_RELAXED_VARIATION: f32 = 1.0 / 1024.0;

/// One step of [`coarsened_until`]: `n_max` and `σ_max` doubled, `σ_max` kept within
/// [`SMALLEST_RELAXED_VARIATION`] and [`LARGEST_VARIATION`].
fn coarser(params: &ClusterParams) -> ClusterParams {
    params
        .clone()
        .max_points(params.max_points.saturating_mul(2))
        .max_variation(
            (params.max_variation * 2.0).clamp(SMALLEST_RELAXED_VARIATION, LARGEST_VARIATION),
        )
}

/// Signed offset along each point's normal from the point to its foot on `surface` (0 where
/// it cannot be projected): the foot points [`WarpTargets::SurfaceGap`] measures gaps from.
pub(crate) fn foot_offsets(surface: &MlsSurface, points: &[Vec3], normals: &[Vec3]) -> Vec<f32> {
    surface
        .project_all(points)
        .iter()
        .zip(points.iter().zip(normals))
        .map(|(f, (p, n))| f.map_or(0.0, |f| (f.point - *p).dot(*n)))
        .collect()
}

/// The gap [`WarpTargets::SurfaceGap`] closes at source point `s` (normal `n`, foot point
/// `s + foot_offset · n` on the exemplar's MLS surface): from the foot point to the closer
/// hit of the two rays along `±n` on the neighbourhood's surface, else to its projection.
/// `None` when there is no such point, when it lies farther than the limit, or when the
/// surface there faces another way than `n` (a different sheet, not the far side of a gap).
fn surface_gap(
    neighbourhood: &MlsSurface,
    s: Vec3,
    n: Vec3,
    foot_offset: f32,
    limits: GapLimits,
) -> Option<Vec3> {
    let foot = s + foot_offset * n;
    let hit = neighbourhood.snap_along_normal(foot, n)?;
    let gap = hit.point - foot;
    limits.refusal(gap, n, hit.normal).is_none().then_some(gap)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::WarpTargets;
    use crate::test_surfaces::{plateau_with_pit, wave};
    use mls_surface::{MlsParams, surface_variation};
    use pointset_core::{PointSet, rng};
    use rand::RngExt;

    /// An analytic height field and its unit normal at `(x, y)`.
    pub(super) type Surface = fn(f32, f32) -> (Vec3, Vec3);

    /// 6000 samples of the wave over `[-0.5, 2.5]²`, uniformly at random, lifted by `lift`.
    fn sampled(seed: u64, lift: f32) -> (Vec<Vec3>, Vec<Vec3>) {
        sampled_surface(wave, seed, lift)
    }

    /// 6000 samples of `surface` over `[-0.5, 2.5]²`, uniformly at random, lifted by `lift`.
    pub(super) fn sampled_surface(
        surface: Surface,
        seed: u64,
        lift: f32,
    ) -> (Vec<Vec3>, Vec<Vec3>) {
        let mut r = rng::rng_from_seed(seed);
        (0..6000)
            .map(|_| {
                let (p, n) = surface(r.random_range(-0.5..2.5), r.random_range(-0.5..2.5));
                (p + Vec3::Z * lift, n)
            })
            .unzip()
    }

    /// `params` after `times` steps of [`coarser`].
    fn doubled(params: &ClusterParams, times: usize) -> ClusterParams {
        (0..times).fold(params.clone(), |p, _| coarser(&p))
    }

    /// [`coarsened_until`] with the clustering itself as the attempt: its clusters and
    /// their count.
    fn clusters_within(
        points: &[Vec3],
        params: &ClusterParams,
        limit: usize,
    ) -> (Vec<mls_surface::Cluster>, usize) {
        coarsened_until(params, points.len(), limit, |p| {
            let groups = adaptive_clusters(points, p).unwrap_or_default();
            let size = groups.len();
            (groups, size)
        })
    }

    #[test]
    fn clusters_are_coarsened_only_past_the_limit_and_no_further_than_needed() {
        let (points, _) = sampled(3, 0.0);
        let params = ClusterParams::default().max_points(4).max_variation(0.1);
        let fine = adaptive_clusters(&points, &params).unwrap_or_default();
        assert!(fine.len() > 1000, "{} clusters", fine.len());
        // Within the limit: the paper's clustering, untouched.
        assert_eq!(
            clusters_within(&points, &params, fine.len()),
            (fine.clone(), 0)
        );
        // Past it: the first doubling that fits, every point in exactly one cluster.
        let limit = fine.len() / 5;
        let (coarse, coarsenings) = clusters_within(&points, &params, limit);
        assert!(
            coarsenings >= 2 && coarse.len() <= limit,
            "{coarsenings}, {}",
            coarse.len()
        );
        let at = |times| adaptive_clusters(&points, &doubled(&params, times)).unwrap_or_default();
        assert_eq!(at(coarsenings), coarse);
        assert!(at(coarsenings - 1).len() > limit);
        let mut members: Vec<usize> = coarse.iter().flat_map(|c| c.members.clone()).collect();
        members.sort_unstable();
        assert_eq!(members, (0..points.len()).collect::<Vec<_>>());
        // A limit of one, from σ_max 0: the limits reach one cluster and stop; a limit of
        // zero cannot be met, and the loop still stops there.
        let strict = ClusterParams::default().max_points(1).max_variation(0.0);
        for limit in [1, 0] {
            let (single, coarsenings) = clusters_within(&points, &strict, limit);
            assert_eq!(single.len(), 1);
            assert!(coarsenings <= 20, "{coarsenings} rounds");
        }
    }

    /// The footprint the wave tests keep, with a blend reach of 0.05.
    pub(super) fn wave_keep() -> KeptFootprint {
        KeptFootprint::new((Vec2::ZERO, Vec2::splat(2.0)), 0.05)
    }

    /// [`warp_wave_with_normals`] without the normals.
    fn warp_wave(seed: u64, lift: f32, targets: WarpTargets) -> (Vec<Vec3>, Vec<Vec3>, WarpCounts) {
        let (before, after, _, counts) = warp_wave_with_normals(seed, lift, targets);
        (before, after, counts)
    }

    /// [`warp_surface`] on the wave, with an overlap on the left and at the bottom.
    fn warp_wave_with_normals(
        seed: u64,
        lift: f32,
        targets: WarpTargets,
    ) -> (Vec<Vec3>, Vec<Vec3>, [Vec<Vec3>; 2], WarpCounts) {
        warp_surface(wave, seed, lift, targets, true)
    }

    /// Warps a patch of `surface` sampled with `seed` and lifted by `lift` onto the
    /// neighbourhood sampled with seed 1, over an overlap at the bottom and, when `left`,
    /// on the left; returns the points before and after, the normals before and after, and
    /// the counts.
    fn warp_surface(
        surface: Surface,
        seed: u64,
        lift: f32,
        targets: WarpTargets,
        left: bool,
    ) -> (Vec<Vec3>, Vec<Vec3>, [Vec<Vec3>; 2], WarpCounts) {
        let mls = MlsParams::default();
        let (n_points, n_normals) = sampled_surface(surface, 1, 0.0);
        let n_set = PointSet::new(n_points.clone())
            .and_then(|s| s.with_normals(n_normals.clone()))
            .unwrap();
        let n_surface = MlsSurface::new(&n_set, &mls).unwrap();
        let (before, normals_before) = sampled_surface(surface, seed, lift);
        let mut normals = normals_before.clone();
        let f_set = PointSet::new(before.clone())
            .and_then(|s| s.with_normals(normals.clone()))
            .unwrap();
        let f_surface = MlsSurface::new(&f_set, &mls).unwrap();
        let variation = surface_variation(f_surface.index(), 12).unwrap();
        let foot_offset = foot_offsets(&f_surface, &before, &normals);
        let overlap = Overlap {
            origin: Vec2::ZERO,
            width: 0.3,
            patch: 1.5,
            left,
            bottom: true,
        };
        let mut points = before.clone();
        let counts = warp_patch(
            &mut points,
            &mut normals,
            &SourceAttributes {
                variation: &variation,
                targets: match targets {
                    WarpTargets::Exact => PairTargets::Exact,
                    WarpTargets::SurfaceGap => PairTargets::SurfaceGap {
                        foot_offset: &foot_offset,
                        normal_agreement: 0.8,
                    },
                },
            },
            &Neighbourhood {
                points: &n_points,
                normals: &n_normals,
                surface: &n_surface,
            },
            &overlap,
            &wave_keep(),
            0.45,
            &ClusterParams::default().max_points(12).max_variation(0.1),
            &PairingParams::default().max_distance(0.06),
            4,
            0.0,
        );
        (before, points, [normals_before, normals], counts)
    }

    fn mean_shift_in_overlap(before: &[Vec3], after: &[Vec3]) -> Vec3 {
        let inside: Vec<Vec3> = before
            .iter()
            .zip(after)
            .filter(|(b, _)| {
                let q = b.truncate();
                q.min_element() >= 0.0 && q.max_element() <= 1.5 && q.min_element() <= 0.3
            })
            .map(|(b, a)| *a - *b)
            .collect();
        inside.iter().sum::<Vec3>() / inside.len() as f32
    }

    fn mean_distance(before: &[Vec3], after: &[Vec3]) -> f32 {
        before
            .iter()
            .zip(after)
            .map(|(b, a)| a.distance(*b))
            .sum::<f32>()
            / before.len() as f32
    }

    #[test]
    fn surface_gap_targets_leave_a_resampled_copy_of_the_neighbourhood_nearly_in_place() {
        // The patch is the neighbourhood's surface sampled anew: nothing to correct. Exact
        // targets drag every paired sample onto another random sample; surface gaps do not.
        let (before, exact, counts) = warp_wave(2, 0.0, WarpTargets::Exact);
        assert!(!counts.skipped && counts.pairs >= 20, "{counts:?}");
        let (_, gap, counts) = warp_wave(2, 0.0, WarpTargets::SurfaceGap);
        assert!(!counts.skipped && counts.pairs >= 20, "{counts:?}");
        let (moved_exact, moved_gap) =
            (mean_distance(&before, &exact), mean_distance(&before, &gap));
        assert!(
            moved_gap < 0.25 * moved_exact,
            "surface gap moved {moved_gap}, exact {moved_exact}"
        );
        assert!(counts.mean_pair_length < 0.003, "{counts:?}");
    }

    #[test]
    fn surface_gap_targets_close_a_lifted_patch_onto_the_neighbourhood() {
        let lift = 0.02;
        let (before, after, counts) = warp_wave(2, lift, WarpTargets::SurfaceGap);
        assert!(!counts.skipped && counts.pairs >= 20, "{counts:?}");
        assert!(
            (counts.mean_pair_length - lift).abs() < 0.2 * lift,
            "{counts:?}"
        );
        let shift = mean_shift_in_overlap(&before, &after);
        assert!(
            (shift.z + lift).abs() < 0.3 * lift && shift.truncate().length() < 0.2 * lift,
            "mean shift in the overlap {shift}"
        );
    }

    #[test]
    fn normals_are_turned_only_where_step_6_can_keep_the_point() {
        let (_, after, [n_before, n_after], counts) =
            warp_wave_with_normals(2, 0.02, WarpTargets::Exact);
        assert!(!counts.skipped, "{counts:?}");
        let keep = wave_keep();
        let (mut kept, mut turned) = (0, 0);
        for ((p, a), b) in after.iter().zip(&n_after).zip(&n_before) {
            if keep.may_land(*p) {
                kept += 1;
                turned += usize::from(a != b);
                assert!((a.length() - 1.0).abs() < 1e-4, "{a}");
            } else {
                assert_eq!(
                    a, b,
                    "a point at {p} cannot be kept; its normal is not turned"
                );
            }
        }
        assert!(
            kept > 1000 && kept < after.len() - 1000,
            "{kept} of {}",
            after.len()
        );
        assert!(turned > kept / 2, "{turned} of {kept} normals turned");
    }

    #[test]
    fn a_warp_on_a_plateau_does_not_stretch_into_a_pit() {
        // Every pair and every corner sample sits on the plateau, within ±0.003 of one
        // height; the pit reaches 0.27 below it. The column ends pin the stretch along z.
        let (before, after, _, counts) =
            warp_surface(plateau_with_pit, 2, 0.0, WarpTargets::Exact, false);
        assert!(!counts.skipped && counts.pairs >= 20, "{counts:?}");
        let pit_moved = before
            .iter()
            .zip(&after)
            .filter(|(b, _)| b.z < 0.2)
            .map(|(b, a)| a.distance(*b))
            .fold(0.0, f32::max);
        assert!(pit_moved < 0.06, "pit moved by {pit_moved}: {counts:?}");
    }

    /// Gap limits: `distance`, and normals at most about 37° apart.
    fn within(distance: f32) -> GapLimits {
        GapLimits {
            distance,
            normal_agreement: 0.8,
        }
    }

    #[test]
    fn a_surface_gap_runs_from_the_foot_point_and_respects_the_limits() {
        let (points, normals) = sampled(1, 0.0);
        let set = PointSet::new(points)
            .and_then(|s| s.with_normals(normals))
            .unwrap();
        let surface = MlsSurface::new(&set, &MlsParams::default()).unwrap();
        let (on, n) = wave(1.0, 1.0);
        // 0.03 above the surface, foot point on it: the gap is the way back down.
        let gap = surface_gap(&surface, on + 0.03 * n, n, -0.03, within(0.1)).unwrap();
        assert!(gap.length() < 2e-3, "{gap}");
        // Foot point taken as the sample itself: the gap is the whole 0.03.
        let gap = surface_gap(&surface, on + 0.03 * n, n, 0.0, within(0.1)).unwrap();
        assert!((gap + 0.03 * n).length() < 3e-3, "{gap}");
        assert!(surface_gap(&surface, on + 0.03 * n, n, 0.0, within(0.02)).is_none());
        // The same gap seen from a source facing the other way ends on a surface that faces
        // away from it: another sheet, not a gap — unless the test is off.
        assert!(surface_gap(&surface, on + 0.03 * n, -n, 0.0, within(0.1)).is_none());
        let any_facing = GapLimits {
            distance: 0.1,
            normal_agreement: -1.0,
        };
        assert!(surface_gap(&surface, on + 0.03 * n, -n, 0.0, any_facing).is_some());
        // Nothing of the surface near: no gap.
        assert!(
            surface_gap(
                &surface,
                Vec3::new(9.0, 9.0, 0.0),
                Vec3::Z,
                0.0,
                within(1.0)
            )
            .is_none()
        );
    }
}
