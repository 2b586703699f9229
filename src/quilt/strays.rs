//! Stray and isolated points of texture files. Stray points are the few samples that lie
//! far outside the rest ([`pointset_core::strays::kept_indices`] says the rule: a scan's
//! outliers, a mistyped coordinate) and would stretch the default box until its distance
//! field is refused. Isolated points ([`mls_surface::isolated_samples`]) lie inside the
//! box but too far from the others for the texture's MLS surface to take them in: each
//! would be a bubble of its own in `D(T_in)`, and the quilt would copy it into the output.

use mls_surface::{IsolatedPoints, MlsParams, without_isolated};
use pointset_core::io::Geometry;

use crate::Result;

/// What a texture file's reader did with its stray points ([`super::TextureFile::stray_points`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StrayPoints {
    /// How many points lie far outside the others.
    pub count: usize,
    /// Whether they were left out of the texture (the default); when kept
    /// ([`super::TextureReading::keep_strays`]) the default box spans them.
    pub left_out: bool,
}

/// `geometry` without its stray points when it is a point set read with the default box
/// and `keep` is false, and what was done with them (`None` when there are none, and for
/// meshes, whose far vertices belong to faces).
pub(super) fn strays_handled(geometry: Geometry, keep: bool) -> (Geometry, Option<StrayPoints>) {
    let Geometry::Points(points) = geometry else {
        return (geometry, None);
    };
    let (points, count, left_out) = if keep {
        let count = points.stray_count();
        (points, count, false)
    } else {
        let (kept, count) = points.without_strays();
        (kept, count, true)
    };
    let strays = (count > 0).then_some(StrayPoints { count, left_out });
    (Geometry::Points(points), strays)
}

/// `geometry` without its isolated points ([`mls_surface::without_isolated`] for the MLS
/// surface every quilt builds over a texture's points: the default parameters, its kernel
/// from their spacing) when it is a point set and `keep` is false, and what was done with
/// them (`None` when there are none, and for meshes, whose vertices belong to faces).
pub(super) fn isolated_handled(
    geometry: Geometry,
    keep: bool,
) -> Result<(Geometry, Option<IsolatedPoints>)> {
    let Geometry::Points(points) = geometry else {
        return Ok((geometry, None));
    };
    let (points, isolated) = without_isolated(points, &MlsParams::default(), keep)?;
    Ok((Geometry::Points(points), isolated))
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use pointset_core::{PointSet, io};

    use super::*;

    #[test]
    fn stray_points_are_left_out_of_point_sets_unless_kept() {
        let bumpy = io::read_geometry(crate::fixtures::bundled_dir().join("quilt_bumpy.ply"));
        let positions = bumpy.unwrap().geometry.points().positions().to_vec();
        let clean = PointSet::new(positions).unwrap();
        let mut positions = clean.positions().to_vec();
        positions.insert(7, Vec3::new(2.0, 2.0, 30_000.0));
        positions.insert(300, Vec3::new(-40.0, 1.0, 0.0));
        let with_strays = Geometry::Points(PointSet::new(positions).unwrap());
        let (left, strays) = strays_handled(with_strays.clone(), false);
        assert_eq!(left, Geometry::Points(clean.clone()));
        assert_eq!(
            strays,
            Some(StrayPoints {
                count: 2,
                left_out: true
            })
        );
        let (kept, strays) = strays_handled(with_strays.clone(), true);
        assert_eq!(kept, with_strays);
        assert_eq!(
            strays,
            Some(StrayPoints {
                count: 2,
                left_out: false
            })
        );
        let (same, none) = strays_handled(Geometry::Points(clean.clone()), false);
        assert_eq!((same, none), (Geometry::Points(clean), None));
    }
}
