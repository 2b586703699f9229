//! Stray points: the few samples that lie far outside the rest of a point set (a scan's
//! outliers, a mistyped coordinate), which stretch everything sized by the points' box —
//! a texture's box, a distance grid — until the real surface is a speck in it.

use glam::Vec3;

use crate::PointSet;

/// The share of the points cut from each end of every axis to find where the rest lie.
const CENTRAL_TAIL: f64 = 0.005;

/// How far beyond the central range of an axis a point must lie to be stray, in widths of
/// that range.
const STRAY_REACH: f32 = 2.0;

/// The narrowest central range an axis is given, as a share of the widest axis's: on a
/// flat set the range across it is the noise, and a point barely off it is not stray.
const FLAT_FLOOR: f32 = 0.01;

/// The indices of the points of `positions` that are not stray, in order (all of them
/// when none is, none when there are no points).
///
/// The rule (a choice made here): on each axis, the points between the 0.5% and 99.5%
/// quantiles of their coordinate span the central range; a point is stray when on some
/// axis it lies beyond that range by more than twice its width, each range counted at
/// least a hundredth of the widest one. So no more than 1% of the points can be stray,
/// none of a set of 200 points or fewer (its quantiles are its extremes), and Gaussian
/// coordinates have none (the limit lies 12.9 standard deviations from their mean).
/// Deterministic; `O(n)` time.
///
/// ```
/// use glam::Vec3;
/// use pointset_core::strays::kept_indices;
///
/// // A 30 × 30 grid and one point 1,000 above it.
/// let mut p: Vec<Vec3> = (0..900).map(|i| Vec3::new((i % 30) as f32, (i / 30) as f32, 0.0)).collect();
/// p.insert(10, Vec3::new(5.0, 5.0, 1000.0));
/// let kept = kept_indices(&p);
/// assert_eq!(kept.len(), 900);
/// assert!(!kept.contains(&10));
/// ```
pub fn kept_indices(positions: &[Vec3]) -> Vec<usize> {
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

impl PointSet {
    /// How many of the points are stray by [`kept_indices`]' rule.
    ///
    /// ```
    /// use glam::Vec3;
    /// use pointset_core::PointSet;
    ///
    /// let mut p: Vec<Vec3> = (0..900).map(|i| Vec3::new((i % 30) as f32, (i / 30) as f32, 0.0)).collect();
    /// assert_eq!(PointSet::new(p.clone())?.stray_count(), 0);
    /// p.push(Vec3::new(-5_000.0, 3.0, 0.0));
    /// assert_eq!(PointSet::new(p)?.stray_count(), 1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn stray_count(&self) -> usize {
        self.len() - kept_indices(self.positions()).len()
    }

    /// The points that are not stray by [`kept_indices`]' rule, with their normals and
    /// attributes, and how many were left out (the points themselves, and 0, when none is
    /// stray).
    ///
    /// ```
    /// use glam::Vec3;
    /// use pointset_core::PointSet;
    ///
    /// let mut p: Vec<Vec3> = (0..900).map(|i| Vec3::new((i % 30) as f32, (i / 30) as f32, 0.0)).collect();
    /// p.push(Vec3::new(-5_000.0, 3.0, 0.0));
    /// let (kept, left_out) = PointSet::new(p)?.without_strays();
    /// assert_eq!((kept.len(), left_out), (900, 1));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn without_strays(self) -> (PointSet, usize) {
        let kept = kept_indices(self.positions());
        let left_out = self.len() - kept.len();
        if left_out == 0 {
            return (self, 0);
        }
        // The indices come from 0..len, so the subset cannot fail; should it, nothing is
        // left out.
        match self.subset(&kept) {
            Ok(subset) => (subset, left_out),
            Err(_) => (self, 0),
        }
    }
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

    fn strays(positions: &[Vec3]) -> usize {
        positions.len() - kept_indices(positions).len()
    }

    #[test]
    fn points_far_outside_are_stray_wherever_they_lie() {
        let clean = ripples();
        for stray in [
            vec![Vec3::new(2.0, 2.0, 30_000.0)],
            vec![Vec3::new(2.0, 2.0, -3.0), Vec3::new(-40.0, 1.0, 0.0)],
            vec![Vec3::new(3.0, 1e9, 0.05); 5],
        ] {
            let mut points = clean.clone();
            // Among the others, not only at the end.
            let at: Vec<usize> = (0..stray.len()).map(|k| 100 * k + 7).collect();
            for (&i, &s) in at.iter().zip(&stray) {
                points.insert(i, s);
            }
            let kept = kept_indices(&points);
            assert_eq!(kept.len(), clean.len());
            assert!(at.iter().all(|i| !kept.contains(i)));
            assert!(kept.windows(2).all(|w| w[0] < w[1]), "in order");
        }
    }

    #[test]
    fn points_within_twice_the_central_range_are_not_stray() {
        assert_eq!(strays(&ripples()), 0);
        // Heights within ±0.1: a point 0.4 up lies at most 0.3 beyond the central range
        // (twice its width, below 0.4, is allowed); at 0.6 it lies beyond.
        let mut points = ripples();
        points.push(Vec3::new(2.0, 2.0, 0.4));
        assert_eq!(strays(&points), 0);
        points.push(Vec3::new(2.0, 2.0, 0.6));
        assert_eq!(strays(&points), 1);
        // A flat sheet: the up axis's range counts as a hundredth of the width (5.9), so a
        // point may lie 0.118 above: 0.1 is not stray, 0.2 is.
        let mut flat: Vec<Vec3> = ripples().iter().map(|p| p.with_z(0.0)).collect();
        flat.push(Vec3::new(1.0, 1.0, 0.1));
        assert_eq!(strays(&flat), 0);
        flat.push(Vec3::new(1.0, 1.0, 0.2));
        assert_eq!(strays(&flat), 1);
        // Too few points to tell: the quantiles are the extremes.
        let few = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.5, 0.5, 1e6)];
        assert_eq!(strays(&few), 0);
        assert!(kept_indices(&[]).is_empty());
    }

    #[test]
    fn gaussian_heights_have_no_strays() {
        // Heights from the sum of twelve uniforms (nearly Gaussian, σ = 0.1) over a grid.
        let mut rng = crate::rng::rng_from_seed(7);
        let points: Vec<Vec3> = (0..40_000)
            .map(|i| {
                let h: f32 = (0..12).map(|_| rng.random_range(0.0..1.0f32)).sum::<f32>() - 6.0;
                Vec3::new((i % 200) as f32 * 0.02, (i / 200) as f32 * 0.02, 0.1 * h)
            })
            .collect();
        assert_eq!(strays(&points), 0);
    }

    #[test]
    fn without_strays_keeps_the_normals_and_attributes_of_the_rest() {
        let mut positions = ripples();
        positions.insert(3, Vec3::new(0.0, 0.0, 50.0));
        let normals: Vec<Vec3> = (0..positions.len())
            .map(|i| Vec3::new(0.0, (i as f32 * 0.01).sin(), 1.0).normalize())
            .collect();
        let ids: Vec<f32> = (0..positions.len()).map(|i| i as f32).collect();
        let points = PointSet::new(positions)
            .and_then(|p| p.with_normals(normals.clone()))
            .and_then(|p| p.with_attribute(crate::Attribute::new("id", ids)))
            .unwrap();
        assert_eq!(points.stray_count(), 1);
        let (kept, left_out) = points.clone().without_strays();
        assert_eq!(left_out, 1);
        let expected: Vec<usize> = (0..points.len()).filter(|&i| i != 3).collect();
        assert_eq!(kept, points.subset(&expected).unwrap());
    }
}
