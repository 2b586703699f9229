//! Stray points: the few samples of a file without texture comments that lie far outside
//! the rest and stretch its default box (a scan's outliers, a mistyped coordinate), found
//! so that a tool can say which box leaves them out.

use glam::DVec3;
use pointset_core::PointSet;

use super::UpAxis;
use super::files::default_box;

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
/// others ([`pointset_core::strays::kept_indices`] says the rule), and the default box
/// without them; `None` when there are none.
pub(super) fn stray_points(points: &PointSet, up: UpAxis, origin: DVec3) -> Option<StrayPoints> {
    let (kept, count) = points.without_strays()?;
    let bounds = default_box(&kept, up).ok()?;
    Some(StrayPoints {
        count,
        box_without: Some([
            origin + bounds.min.as_dvec3(),
            origin + bounds.max.as_dvec3(),
        ]),
    })
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use pointset_core::io;

    use super::*;

    #[test]
    fn points_far_outside_are_stray_and_the_box_is_the_default_without_them() {
        let bumpy = io::read_geometry(crate::fixtures::bundled_dir().join("quilt_bumpy.ply"));
        let clean = bumpy.unwrap().geometry.points().positions().to_vec();
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
            let found = stray_points(&PointSet::new(points).unwrap(), UpAxis::Z, origin).unwrap();
            assert_eq!(found.count, count);
            let shifted = [
                origin + default.min.as_dvec3(),
                origin + default.max.as_dvec3(),
            ];
            assert_eq!(found.box_without, Some(shifted));
        }
        let none = stray_points(&PointSet::new(clean).unwrap(), UpAxis::Z, origin);
        assert_eq!(none, None);
    }
}
