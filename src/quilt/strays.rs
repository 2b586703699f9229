//! Stray points: the few samples of a file without texture comments that lie far outside
//! the rest and stretch its default box (a scan's outliers, a mistyped coordinate), found
//! so that a tool can say which box leaves them out.

use glam::{DVec3, Vec3};
use pointset_core::PointSet;

use super::UpAxis;
use super::files::default_box;

/// The share of the points cut from each end of every axis to find where the rest lie.
const CENTRAL_TAIL: f64 = 0.005;

/// How far beyond the central range of an axis a point must lie to be stray, in widths of
/// that range.
const STRAY_REACH: f32 = 2.0;

/// The narrowest central range an axis is given, as a share of the widest axis's: on a
/// flat exemplar the range along the up axis is the noise, and a point barely above it is
/// not stray.
const FLAT_FLOOR: f32 = 0.01;

/// The stray points of a texture file read with its default box
/// ([`super::TextureFile::stray_points`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrayPoints {
    /// How many points lie beyond the others.
    pub count: usize,
    /// For a file read along its axes, the default box of the points without them, by
    /// its lower and upper corners in the file's coordinates (double precision): what
    /// `TextureReading::bounds` (the command line's `--box`) takes to leave them out.
    /// `None` for a fitted reference plane, whose plane and box already leave them out.
    pub box_without: Option<[DVec3; 2]>,
}

/// The points of `points` (relative to `origin` in the file) that lie far outside the
/// others, and the default box without them; `None` when there are none.
///
/// The rule (a choice made here; paper 000 reads boxes from its own exemplars): on each
/// axis, the points between the 0.5% and 99.5% quantiles of their coordinate span the
/// central range; a point is stray when on some axis it lies beyond that range by more
/// than twice its width, each range counted at least a hundredth of the widest one. So no
/// more than 1% of the points can be stray, none of a set of 200 points or fewer (its
/// quantiles are its extremes), and Gaussian heights have none (the limit lies 12.9
/// standard deviations from their mean).
pub(super) fn stray_points(points: &PointSet, up: UpAxis, origin: DVec3) -> Option<StrayPoints> {
    let positions = points.positions();
    let kept = kept_points(positions);
    let count = positions.len() - kept.len();
    if count == 0 {
        return None;
    }
    let kept = kept.iter().map(|&i| positions[i]).collect();
    let bounds = default_box(&PointSet::new(kept).ok()?, up).ok()?;
    Some(StrayPoints {
        count,
        box_without: Some([
            origin + bounds.min.as_dvec3(),
            origin + bounds.max.as_dvec3(),
        ]),
    })
}

/// The indices of the points of `positions` that are not stray by [`stray_points`]' rule,
/// in order (all of them when none is).
pub(super) fn kept_points(positions: &[Vec3]) -> Vec<usize> {
    let Some(ranges) = central_ranges(positions) else {
        return Vec::new();
    };
    let widest = ranges
        .iter()
        .map(|&(lo, hi)| hi - lo)
        .fold(0.0f32, f32::max);
    let limits = ranges.map(|(lo, hi)| {
        let reach = STRAY_REACH * (hi - lo).max(FLAT_FLOOR * widest);
        lo - reach..=hi + reach
    });
    (0..positions.len())
        .filter(|&i| (0..3).all(|axis| limits[axis].contains(&positions[i][axis])))
        .collect()
}

/// Each axis's coordinates at the [`CENTRAL_TAIL`] and `1 − CENTRAL_TAIL` quantiles (by
/// rank: the `⌊t·(n − 1)⌋`-th smallest and largest); `None` without points.
fn central_ranges(positions: &[Vec3]) -> Option<[(f32, f32); 3]> {
    let last = positions.len().checked_sub(1)?;
    let cut = (CENTRAL_TAIL * last as f64) as usize;
    let mut values = vec![0.0f32; positions.len()];
    let mut ranges = [(0.0, 0.0); 3];
    for (axis, range) in ranges.iter_mut().enumerate() {
        for (v, p) in values.iter_mut().zip(positions) {
            *v = p[axis];
        }
        let (_, &mut high, _) = values.select_nth_unstable_by(last - cut, f32::total_cmp);
        let (_, &mut low, _) = values[..=last - cut].select_nth_unstable_by(cut, f32::total_cmp);
        *range = (low, high);
    }
    Some(ranges)
}

#[cfg(test)]
mod tests {
    use rand::RngExt;

    use super::*;

    /// A 60 × 60 grid of ripples 0.1 apart (heights within ±0.1).
    fn ripples() -> Vec<Vec3> {
        (0..3600)
            .map(|i| {
                let (x, y) = ((i % 60) as f32 * 0.1, (i / 60) as f32 * 0.1);
                Vec3::new(x, y, 0.1 * (2.0 * x).sin() * (1.5 * y).cos())
            })
            .collect()
    }

    fn strays_of(positions: Vec<Vec3>, origin: DVec3) -> Option<StrayPoints> {
        stray_points(&PointSet::new(positions).unwrap(), UpAxis::Z, origin)
    }

    #[test]
    fn points_far_outside_are_stray_and_the_box_is_the_default_without_them() {
        let clean = ripples();
        let default = default_box(&PointSet::new(clean.clone()).unwrap(), UpAxis::Z).unwrap();
        let origin = DVec3::new(512_000.0, 4_123_000.0, 10.0);
        for (strays, count) in [
            (vec![Vec3::new(2.0, 2.0, 30_000.0)], 1),
            (
                vec![Vec3::new(2.0, 2.0, -3.0), Vec3::new(-40.0, 1.0, 0.0)],
                2,
            ),
            (vec![Vec3::new(3.0, 1e9, 0.05); 5], 5),
        ] {
            let mut points = clean.clone();
            // Among the others, not only at the end.
            for (k, s) in strays.into_iter().enumerate() {
                points.insert(100 * k + 7, s);
            }
            let found = strays_of(points, origin).unwrap();
            assert_eq!(found.count, count);
            assert_eq!(
                found.box_without,
                Some([
                    origin + default.min.as_dvec3(),
                    origin + default.max.as_dvec3()
                ])
            );
        }
    }

    #[test]
    fn points_within_twice_the_central_range_are_not_stray() {
        assert_eq!(strays_of(ripples(), DVec3::ZERO), None);
        // Heights within ±0.1: a point 0.4 up lies at most 0.3 beyond the central range
        // (twice its width, below 0.4, is allowed); at 0.6 it lies beyond.
        let mut points = ripples();
        points.push(Vec3::new(2.0, 2.0, 0.4));
        assert_eq!(strays_of(points.clone(), DVec3::ZERO), None);
        points.push(Vec3::new(2.0, 2.0, 0.6));
        assert_eq!(strays_of(points, DVec3::ZERO).map(|s| s.count), Some(1));
        // A flat sheet: the up axis's range counts as a hundredth of the width (5.9), so a
        // point may lie 0.118 above: 0.1 is not stray, 0.2 is.
        let mut flat: Vec<Vec3> = ripples().iter().map(|p| p.with_z(0.0)).collect();
        flat.push(Vec3::new(1.0, 1.0, 0.1));
        assert_eq!(strays_of(flat.clone(), DVec3::ZERO), None);
        flat.push(Vec3::new(1.0, 1.0, 0.2));
        assert_eq!(strays_of(flat, DVec3::ZERO).map(|s| s.count), Some(1));
        // Too few points to tell: the quantiles are the extremes.
        let few = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.5, 0.5, 1e6)];
        assert_eq!(strays_of(few, DVec3::ZERO), None);
    }

    #[test]
    fn gaussian_heights_have_no_strays() {
        // Heights from the sum of twelve uniforms (nearly Gaussian, σ = 0.1) over a grid.
        let mut rng = pointset_core::rng::rng_from_seed(7);
        let points: Vec<Vec3> = (0..40_000)
            .map(|i| {
                let h: f32 = (0..12).map(|_| rng.random_range(0.0..1.0f32)).sum::<f32>() - 6.0;
                Vec3::new((i % 200) as f32 * 0.02, (i / 200) as f32 * 0.02, 0.1 * h)
            })
            .collect();
        assert_eq!(strays_of(points, DVec3::ZERO), None);
    }
}
