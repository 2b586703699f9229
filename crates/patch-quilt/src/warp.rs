//! Step 4: warping the translated patch onto its neighbourhood with a thin-plate spline
//! driven by the automatic pairing (paper 000 §5.2).

use glam::{Vec2, Vec3};
use mls_surface::{ClusterParams, Covariance, adaptive_clusters};
use pointset_core::{Aabb, KdIndex};
use tps_warp::{
    PairingParams, PairingPoint, ThinPlateSpline, TpsParams, anchors_in_regions, pair_points,
};

use crate::blend::Overlap;
use crate::params::WarpTargets;

/// The neighbourhood `N_k` as oriented points, with a spatial index for the surface
/// variation of the few points that become targets.
pub(crate) struct Neighbourhood<'a> {
    pub points: &'a [Vec3],
    pub normals: &'a [Vec3],
    pub index: &'a KdIndex,
}

/// Neighbours used for surface variation (as for the exemplar's points).
const VARIATION_NEIGHBOURS: usize = 12;

impl Neighbourhood<'_> {
    /// Surface variation of point `i` over its 12 nearest neighbours in `N_k`.
    fn variation(&self, i: usize) -> f32 {
        self.index
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
    /// Anchor points mapped to themselves.
    pub anchors: usize,
    /// Targets `|Q|`.
    pub targets: usize,
    /// `C(Φ)` of the pairing.
    pub cost: f64,
    /// True when the patch was left unwarped (fewer than 4 pairs or a degenerate system).
    pub skipped: bool,
    /// Mean distance the warp moved the points.
    pub mean_displacement: f32,
    /// Largest distance the warp moved a point.
    pub max_displacement: f32,
    /// Mean length of the spline's pair displacements (after [`WarpTargets`]).
    pub mean_pair_length: f32,
}

/// Warps `points`/`normals` (the extended, translated `F_k` = `S`) in place.
///
/// `Q` = representatives of adaptive clusters of the neighbourhood's points inside the
/// overlap region; anchors = up to `anchors_per_corner` points of `S` in each `w_E × w_E`
/// corner of `B_k`'s footprint that shares no area with the overlap (three for an interior
/// patch: the strips run along the patch's sides only). The spline maps each paired
/// source to its target ([`WarpTargets`]). A patch with fewer than four pairs, or whose
/// spline cannot be fitted, is left unwarped (reported, not an error).
#[allow(clippy::too_many_arguments)]
pub(crate) fn warp_patch(
    points: &mut [Vec3],
    normals: &mut [Vec3],
    variation: &[f32],
    neighbourhood: &Neighbourhood<'_>,
    overlap: &Overlap,
    footprint: (Vec2, Vec2),
    corner: f32,
    clusters: &ClusterParams,
    pairing: &PairingParams,
    anchors_per_corner: usize,
    targets: WarpTargets,
    smoothing: f64,
) -> WarpCounts {
    let in_overlap: Vec<usize> = (0..neighbourhood.points.len())
        .filter(|&i| overlap.contains(neighbourhood.points[i].truncate()))
        .collect();
    let positions: Vec<Vec3> = in_overlap
        .iter()
        .map(|&i| neighbourhood.points[i])
        .collect();
    let Ok(groups) = adaptive_clusters(&positions, clusters) else {
        return WarpCounts {
            skipped: true,
            ..WarpCounts::default()
        };
    };
    let q: Vec<PairingPoint> = groups
        .iter()
        .map(|c| {
            let i = in_overlap[c.representative];
            PairingPoint {
                position: neighbourhood.points[i],
                normal: neighbourhood.normals[i],
                variation: neighbourhood.variation(i),
            }
        })
        .collect();
    let s: Vec<PairingPoint> = (0..points.len())
        .map(|i| PairingPoint {
            position: points[i],
            normal: normals[i],
            variation: variation[i],
        })
        .collect();
    let (lo, hi) = footprint;
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
    let mut counts = WarpCounts {
        targets: q.len(),
        anchors: anchors.len(),
        skipped: true,
        ..WarpCounts::default()
    };
    if q.len() < 4 {
        return counts;
    }
    let Ok(pairing) = pair_points(&s, &q, pairing) else {
        return counts;
    };
    counts.pairs = pairing.pairs.len();
    counts.cost = pairing.cost;
    if counts.pairs < 4 {
        return counts;
    }
    let mut from: Vec<Vec3> = pairing.pairs.iter().map(|p| s[p.source].position).collect();
    let mut to: Vec<Vec3> = pairing
        .pairs
        .iter()
        .map(|p| {
            let (source, target) = (s[p.source].position, q[p.target]);
            match targets {
                WarpTargets::Exact => target.position,
                WarpTargets::NormalOffset => {
                    source + (target.position - source).dot(target.normal) * target.normal
                }
            }
        })
        .collect();
    counts.mean_pair_length = from
        .iter()
        .zip(&to)
        .map(|(a, b)| a.distance(*b))
        .sum::<f32>()
        / counts.pairs as f32;
    from.extend_from_slice(&anchors);
    to.extend_from_slice(&anchors);
    let Ok(spline) = ThinPlateSpline::fit(&from, &to, &TpsParams::default().smoothing(smoothing))
    else {
        return counts;
    };
    let fitted = spline;
    let (moved, turned) = fitted.warp(points, Some(normals));
    if moved.iter().any(|p| !p.is_finite()) {
        return counts;
    }
    let shifts: Vec<f32> = moved
        .iter()
        .zip(points.iter())
        .map(|(a, b)| a.distance(*b))
        .collect();
    counts.mean_displacement = shifts.iter().sum::<f32>() / shifts.len().max(1) as f32;
    counts.max_displacement = shifts.iter().copied().fold(0.0, f32::max);
    points.copy_from_slice(&moved);
    if let Some(n) = turned {
        normals.copy_from_slice(&n);
    }
    counts.skipped = false;
    counts
}
