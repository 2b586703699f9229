//! Exemplar files whose reference plane is none of the coordinate planes (a scan of a
//! tilted wall, a terrain patch exported in a rotated frame): the plane is fitted to the
//! points, the texture is quilted in that plane's frame, and outputs go back to the file's.

use std::path::Path;

use glam::{DMat3, DVec3, Vec3};
use mls_surface::Covariance;
use pointset_core::io::{self, ReadOptions};
use pointset_core::{Aabb, PointSet, RunContext};

use super::files::{
    default_box, parse_texture_comments_at, single_precision_step, texture_comments_at,
    texture_file_error,
};
use super::samples::{ExemplarNormals, texture_samples};
use super::strays::{isolated_handled, strays_handled};
use super::{GeometryTexture, TextureFile, UpAxis};
use crate::Result;

/// The fitted plane must be flatter than this: its normal spread (smallest eigenvalue of
/// the points' covariance) at most this fraction of the narrower in-plane spread (the
/// middle eigenvalue), i.e. a standard deviation across the plane at most half of that
/// along its narrower side.
pub const MAX_PLANE_SPREAD: f64 = 0.25;

/// Reads a geometry texture file without texture comments whose reference plane is fitted
/// to its points: the plane through their centroid spanned by the two largest principal
/// directions of their covariance, its normal turned to agree with the sum of the points'
/// normals (so "up" is the side the surface faces). The texture is built in that plane's
/// frame (Z the normal; X and Y turned in the plane to give the points' projection its
/// smallest bounding rectangle, so that the default box, inset by a sixth, follows the
/// edges of a rectangular exemplar), and
/// [`TextureFile::frame`] and [`TextureFile::origin`] take results back to the file's
/// frame ([`TextureFile::to_file_frame`], [`TextureFile::comments`]).
///
/// A point set's points that lie far outside the rest ([`pointset_core::strays`]) would
/// tilt the plane and stretch its box: they are left out and counted in
/// [`TextureFile::stray_points`]. So are its isolated points, too far from the others for
/// the texture's surface to take them in ([`TextureFile::isolated_points`]), unless they
/// are most of the points.
///
/// Errors: texture comments in the file (they already give the box and the up axis), no
/// points or normals, and points with no dominant plane (spread across the best plane more
/// than half as wide as along its narrower side, see [`MAX_PLANE_SPREAD`]).
///
/// ```
/// use geosynth::quilt::read_texture_file_fitted;
/// // Ripples on a plane tilted by 30° about the x axis (no texture comments).
/// let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
/// let mut ply = String::from("ply\nformat ascii 1.0\nelement vertex 1600\n");
/// ply += "property float x\nproperty float y\nproperty float z\n";
/// ply += "property float nx\nproperty float ny\nproperty float nz\nend_header\n";
/// for k in 0..1600 {
///     let (u, v) = ((k % 40) as f64 * 0.1, (k / 40) as f64 * 0.1);
///     let h = 0.05 * (3.0 * u).sin();
///     let n = glam::DVec3::new(-0.15 * (3.0 * u).cos(), 0.0, 1.0).normalize();
///     // Rotate (u, v, h) and its normal about x.
///     let (y, z) = (v * c - h * s, v * s + h * c);
///     let (ny, nz) = (n.y * c - n.z * s, n.y * s + n.z * c);
///     ply += &format!("{u} {y} {z} {} {ny} {nz}\n", n.x);
/// }
/// let path = std::env::temp_dir().join("geosynth_doc_tilted.ply");
/// std::fs::write(&path, ply)?;
/// let file = read_texture_file_fitted(&path)?;
/// // The plane's normal, within a degree (the ripples tilt the least-squares plane a bit).
/// let normal = file.frame.z_axis;
/// assert!(normal.angle_between(glam::DVec3::new(0.0, -s, c)) < 1f64.to_radians(), "{normal}");
/// // In the texture's frame the ripples stand up along Z again.
/// let z_span = file.texture.canonical_bounds().extent().z;
/// assert!(z_span < 0.2, "{z_span}");
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_texture_file_fitted(path: &Path) -> Result<TextureFile> {
    read_texture_file_fitted_with(
        path,
        ExemplarNormals::AsStored,
        None,
        &mut RunContext::new(0),
    )
}

/// [`read_texture_file_fitted`] with the exemplar's normals taken as `normals` says. Normals
/// estimated for a bare point set ([`ExemplarNormals::Estimated`]) are turned toward the
/// side of the points' best plane that faces +Z of the file (+Y for a plane along Z, +X
/// for one along Y and Z), and that side becomes the texture's up. A mesh gives about
/// `mesh_samples` points sampled on its surface instead of its vertices, when given
/// ([`super::TextureReading::mesh_samples`]). Progress and cancellation as for
/// [`super::read_texture_file_with`].
pub fn read_texture_file_fitted_with(
    path: &Path,
    normals: ExemplarNormals,
    mesh_samples: Option<usize>,
    ctx: &mut RunContext,
) -> Result<TextureFile> {
    let file_error = texture_file_error(path);
    let loaded = io::read_geometry_with(path, &ReadOptions::default().recentre_far(true))?;
    if parse_texture_comments_at(&loaded.comments, loaded.origin)
        .map_err(&file_error)?
        .is_some()
    {
        return Err(file_error(
            "its texture comments give the box and up axis; a fitted plane is for files \
             without them"
                .into(),
        ));
    }
    // Stray points would tilt the plane and stretch its box, and no box can be given in
    // a fitted plane: they are always left out, and isolated points with them.
    let (geometry, stray_points) = strays_handled(loaded.geometry, false);
    let (geometry, isolated_points) = isolated_handled(geometry, false)?;
    let up = match normals {
        ExemplarNormals::AsStored => Vec3::Z,
        ExemplarNormals::Estimated { .. } => facing_up(geometry.points().positions()),
    };
    let samples = texture_samples(path, geometry, normals, mesh_samples, up, ctx)?;
    let points = samples.points;
    let normals = points.normals().ok_or_else(|| {
        // The samples come with normals (or were refused); kept as an error, not a panic.
        file_error("the exemplar has no normals".into())
    })?;
    let positions = points.positions();
    let fit = Covariance::of(positions, 0..positions.len())
        .ok_or_else(|| file_error("no points".into()))?;
    let [across, narrow, _] = fit.eigenvalues;
    if narrow <= 0.0 || across > MAX_PLANE_SPREAD * narrow {
        return Err(file_error(format!(
            "the points have no dominant plane (variance {across:.3e} across the best plane \
             against {narrow:.3e} along its narrower side); name the up axis instead"
        )));
    }
    let facing: DVec3 = normals.iter().map(|n| n.as_dvec3()).sum();
    let mut normal = fit.eigenvectors[0].as_dvec3().normalize();
    if facing.dot(normal) < 0.0 {
        normal = -normal;
    }
    let centre = fit.centroid.as_dvec3();
    let widest = fit.eigenvectors[2].as_dvec3();
    let x = tightest_x(positions, centre, normal, widest);
    let frame = DMat3::from_cols(x, normal.cross(x), normal);
    let into_plane = frame.transpose();
    let local = positions
        .iter()
        .map(|p| (into_plane * (p.as_dvec3() - centre)).as_vec3())
        .collect();
    let turned = normals
        .iter()
        .map(|n| (into_plane * n.as_dvec3()).as_vec3())
        .collect();
    let mut in_plane = PointSet::new(local)?.with_normals(turned)?;
    for a in points.attributes() {
        in_plane.set_attribute(a.clone())?;
    }
    let bounds = default_box(&in_plane, UpAxis::Z).map_err(&file_error)?;
    Ok(TextureFile {
        texture: GeometryTexture::new(&in_plane, bounds, UpAxis::Z)?,
        origin: loaded.origin + centre,
        frame,
        single_precision_step: single_precision_step(&points, loaded.origin),
        notes: loaded.notes,
        undefined_normals: samples.undefined_normals,
        stray_points,
        isolated_points,
        longest_edge_spacings: samples.longest_edge_spacings,
    })
}

/// The normal of the best plane through `positions` (their covariance's direction of
/// least spread), turned to face +Z, or +Y where it lies across Z, or +X where it lies
/// across both; +Z when there are no points.
fn facing_up(positions: &[Vec3]) -> Vec3 {
    let Some(fit) = Covariance::of(positions, 0..positions.len()) else {
        return Vec3::Z;
    };
    let normal = fit.eigenvectors[0];
    let facing = [normal.z, normal.y, normal.x]
        .into_iter()
        .find(|c| c.abs() > AXIS_TOLERANCE)
        .unwrap_or(1.0);
    if facing < 0.0 { -normal } else { normal }
}

/// How far from a coordinate plane a fitted plane's normal must reach along an axis for
/// [`facing_up`] to take its sign from that axis.
const AXIS_TOLERANCE: f32 = 1e-3;

/// Steps of the search for the in-plane axes, in degrees (over a quarter turn).
const AXIS_STEP_DEGREES: f64 = 0.5;

/// The in-plane X axis that gives the points' projection its smallest bounding rectangle,
/// searched in [`AXIS_STEP_DEGREES`] steps from `start` (made orthogonal to `normal`): the
/// default box then follows the edges of an exemplar cut as a rectangle, whatever its
/// principal directions (a square has none).
fn tightest_x(positions: &[glam::Vec3], centre: DVec3, normal: DVec3, start: DVec3) -> DVec3 {
    let u = (start - start.dot(normal) * normal).normalize();
    let v = normal.cross(u);
    let planar: Vec<(f64, f64)> = positions
        .iter()
        .map(|p| {
            let d = p.as_dvec3() - centre;
            (d.dot(u), d.dot(v))
        })
        .collect();
    let steps = (90.0 / AXIS_STEP_DEGREES) as usize;
    let area = |k: usize| {
        let (s, c) = (k as f64 * AXIS_STEP_DEGREES).to_radians().sin_cos();
        let (mut lo, mut hi) = ((f64::MAX, f64::MAX), (f64::MIN, f64::MIN));
        for &(a, b) in &planar {
            let (x, y) = (c * a + s * b, c * b - s * a);
            lo = (lo.0.min(x), lo.1.min(y));
            hi = (hi.0.max(x), hi.1.max(y));
        }
        (hi.0 - lo.0) * (hi.1 - lo.1)
    };
    let best = (0..steps)
        .map(|k| (area(k), k))
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .map_or(0, |(_, k)| k);
    let (s, c) = (best as f64 * AXIS_STEP_DEGREES).to_radians().sin_cos();
    c * u + s * v
}

impl TextureFile {
    /// `points` (in the texture's world frame, e.g. a quilt's output) turned into the
    /// file's frame, relative to [`Self::origin`] (write them with
    /// [`pointset_core::io::WriteOptions::origin`]). Normals turn with them; attributes
    /// are kept. A clone when the frame is the identity.
    pub fn to_file_frame(&self, points: &PointSet) -> Result<PointSet> {
        if self.frame == DMat3::IDENTITY {
            return Ok(points.clone());
        }
        let turn = |v: &glam::Vec3| (self.frame * v.as_dvec3()).as_vec3();
        let mut out = PointSet::new(points.positions().iter().map(turn).collect())?;
        if let Some(normals) = points.normals() {
            out = out.with_normals(normals.iter().map(turn).collect())?;
        }
        for a in points.attributes() {
            out.set_attribute(a.clone())?;
        }
        Ok(out)
    }

    /// Comment lines for an output of this texture whose box is `bounds` (texture frame):
    /// `texture_box` and `texture_up` in the file's coordinates when the frame is an axis
    /// frame; for a fitted plane, whose box is not aligned with the file's axes, a line
    /// naming the plane instead.
    pub fn comments(&self, bounds: &Aabb) -> Vec<String> {
        if self.frame == DMat3::IDENTITY {
            return texture_comments_at(bounds, self.texture.up(), self.origin);
        }
        let (n, o) = (self.frame.z_axis, self.origin);
        vec![format!(
            "fitted reference plane: normal {} {} {} through {} {} {}",
            n.x, n.y, n.z, o.x, o.y, o.z
        )]
    }
}

#[cfg(test)]
mod tests {
    use glam::{DMat3, DVec3, Vec3};
    use pointset_core::io::{self, Geometry, WriteOptions};
    use pointset_core::{Aabb, PointSet};

    use super::read_texture_file_fitted;
    use crate::fixtures;
    use crate::quilt::read_texture_file;

    /// The bumpy fixture turned by 35° about (1, 1, 0) and moved, written without comments;
    /// returns the path and the turn.
    fn tilted_bumpy(dir: &std::path::Path) -> (std::path::PathBuf, DMat3, PointSet) {
        let bumpy = io::read_geometry(fixtures::bundled_dir().join("quilt_bumpy.ply")).unwrap();
        let points = bumpy.geometry.points();
        let turn =
            DMat3::from_axis_angle(DVec3::new(1.0, 1.0, 0.0).normalize(), 35f64.to_radians());
        let shift = DVec3::new(10.0, -3.0, 7.0);
        let moved = |p: &Vec3| (turn * p.as_dvec3() + shift).as_vec3();
        let turned = |n: &Vec3| (turn * n.as_dvec3()).as_vec3();
        let tilted = PointSet::new(points.positions().iter().map(moved).collect())
            .unwrap()
            .with_normals(points.normals().unwrap().iter().map(turned).collect())
            .unwrap();
        let path = dir.join("tilted.ply");
        io::write_geometry(
            &path,
            &Geometry::Points(tilted.clone()),
            &WriteOptions::default(),
        )
        .unwrap();
        (path, turn, tilted)
    }

    #[test]
    fn a_tilted_exemplar_is_read_in_its_own_plane_and_goes_back() {
        let dir = tempfile::tempdir().unwrap();
        let (path, turn, tilted) = tilted_bumpy(dir.path());
        let file = read_texture_file_fitted(&path).unwrap();
        // The fitted normal is the turned +Z, within a degree.
        let angle = file
            .frame
            .z_axis
            .angle_between(turn * DVec3::Z)
            .to_degrees();
        assert!(angle < 1.0, "normal off by {angle}°");
        // The in-plane axes follow the square's edges: the default box is as wide as the
        // untilted fixture's (read without its comments, the points' box inset by a sixth).
        let side = |b: Aabb| b.extent().truncate();
        let fitted = side(file.texture.canonical_bounds());
        let plain = dir.path().join("plain.ply");
        let bumpy = io::read_geometry(fixtures::bundled_dir().join("quilt_bumpy.ply")).unwrap();
        io::write_geometry(&plain, &bumpy.geometry, &WriteOptions::default()).unwrap();
        let untilted = side(
            read_texture_file(&plain, None)
                .unwrap()
                .texture
                .canonical_bounds(),
        );
        let (a, b) = (fitted.max_element(), untilted.max_element());
        assert!((a - b).abs() < 0.02 * b, "box side {a} against {b}");
        // Back into the file's frame: the exemplar's own points come out where they were.
        let back = file.to_file_frame(file.texture.canonical_points()).unwrap();
        for (p, q) in back.positions().iter().zip(tilted.positions()) {
            let p = p.as_dvec3() + file.origin;
            assert!((p - q.as_dvec3()).length() < 1e-4, "{p} against {q}");
        }
        assert!(file.comments(&file.texture.canonical_bounds())[0].starts_with("fitted"));
    }

    #[test]
    fn files_with_comments_and_points_without_a_plane_are_refused() {
        let commented = fixtures::bundled_dir().join("quilt_bumpy.ply");
        let refused = read_texture_file_fitted(&commented)
            .unwrap_err()
            .to_string();
        assert!(refused.contains("texture comments"), "{refused}");
        let dir = tempfile::tempdir().unwrap();
        let sphere = io::read_geometry(fixtures::bundled_dir().join("sphere_points.ply")).unwrap();
        let blob = dir.path().join("blob.ply");
        io::write_geometry(&blob, &sphere.geometry, &WriteOptions::default()).unwrap();
        let refused = read_texture_file_fitted(&blob).unwrap_err().to_string();
        assert!(refused.contains("no dominant plane"), "{refused}");
    }
}
