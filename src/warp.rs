//! Stage: geometry → the same geometry moved by a thin-plate spline (the `tps-warp`
//! crate's spline applied to a whole point set or mesh).

use pointset_core::io::Geometry;
use pointset_core::{PointSet, RunContext, Stage, TriMesh};
use tps_warp::ThinPlateSpline;

use crate::error::{Error, Result};

/// `geometry` moved by `spline`: every position through the spline and every normal
/// through its Jacobian ([`ThinPlateSpline::warp`]), in parallel; attributes kept as they
/// are, and a mesh's triangles and UVs too.
///
/// Errors: [`Error::WarpOverflow`] when the spline sends a point beyond single precision
/// (targets far from their sources, or sources so close together that the spline
/// explodes between them).
///
/// ```
/// use geosynth::core::io::Geometry;
/// use geosynth::tps::{ThinPlateSpline, TpsParams};
/// use geosynth::warp::warp_geometry;
/// use glam::Vec3;
///
/// // Pairs that stretch x twice over: the spline through them is that stretch.
/// let corner = |i: u32| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32);
/// let sources: Vec<Vec3> = (0..8).map(corner).collect();
/// let targets: Vec<Vec3> = sources.iter().map(|p| Vec3::new(2.0 * p.x, p.y, p.z)).collect();
/// let spline = ThinPlateSpline::fit(&sources, &targets, &TpsParams::default())?;
/// let sphere = Geometry::Points(geosynth::fixtures::sphere_points(500)?);
/// let warped = warp_geometry(&spline, sphere.clone())?;
/// for (p, q) in sphere.points().positions().iter().zip(warped.points().positions()) {
///     assert!((*q - Vec3::new(2.0 * p.x, p.y, p.z)).length() < 1e-4);
/// }
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn warp_geometry(spline: &ThinPlateSpline, geometry: Geometry) -> Result<Geometry> {
    match geometry {
        Geometry::Points(points) => Ok(Geometry::Points(warp_points(spline, points)?)),
        Geometry::Mesh(mesh) => {
            let (vertices, triangles, uvs) = mesh.into_parts();
            let mut warped = TriMesh::new(warp_points(spline, vertices)?, triangles)?;
            if let Some(uvs) = uvs {
                warped = warped.with_uvs(uvs)?;
            }
            Ok(Geometry::Mesh(warped))
        }
    }
}

/// `points` moved by `spline`, as [`warp_geometry`] says.
fn warp_points(spline: &ThinPlateSpline, points: PointSet) -> Result<PointSet> {
    let (moved, normals) = spline.warp(points.positions(), points.normals());
    if let Some(index) = moved.iter().position(|p| !p.is_finite()) {
        return Err(Error::WarpOverflow { index });
    }
    let (_, _, attributes) = points.into_parts();
    let mut warped = PointSet::new(moved)?;
    if let Some(normals) = normals {
        warped = warped.with_normals(normals)?;
    }
    for attribute in attributes {
        warped.set_attribute(attribute)?;
    }
    Ok(warped)
}

/// Stage: a point set or mesh → the same moved by a thin-plate spline
/// ([`warp_geometry`]); fit the spline through pairs with [`ThinPlateSpline::fit`], or
/// find the pairs with [`crate::tps::pair_and_fit`].
///
/// ```
/// use geosynth::core::io::Geometry;
/// use geosynth::tps::{ThinPlateSpline, TpsParams};
/// use geosynth::warp::Warp;
/// use geosynth::{fixtures, RunContext, Stage};
/// use glam::Vec3;
///
/// // The top of an icosphere pulled up into a bulge; the faces stay as they were.
/// let sources = [Vec3::Y, -Vec3::Y, Vec3::X, -Vec3::X, Vec3::Z, -Vec3::Z];
/// let mut targets = sources;
/// targets[0] = 1.5 * Vec3::Y;
/// let spline = ThinPlateSpline::fit(&sources, &targets, &TpsParams::default())?;
/// let sphere = fixtures::icosphere_mesh(3)?;
/// let bulged = Warp { spline }.run(Geometry::Mesh(sphere.clone()), &mut RunContext::new(0))?;
/// let mesh = bulged.mesh().ok_or("not a mesh")?;
/// assert_eq!(mesh.triangles(), sphere.triangles());
/// let top = mesh.positions().iter().map(|p| p.y).fold(f32::MIN, f32::max);
/// assert!(top > 1.4, "{top}");
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// With the `serde` feature the stage is stored with its spline's terms
/// ([`ThinPlateSpline::from_terms`] checks them when read): a warp fitted once can be kept
/// in a pipeline's configuration and applied again.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Warp {
    /// The spline every position goes through.
    pub spline: ThinPlateSpline,
}

impl Stage for Warp {
    type Input = Geometry;
    type Output = Geometry;
    type Error = Error;

    fn name(&self) -> &str {
        "warp"
    }

    fn run(&self, input: Geometry, ctx: &mut RunContext) -> Result<Geometry> {
        ctx.check_cancelled()?;
        warp_geometry(&self.spline, input)
    }
}
