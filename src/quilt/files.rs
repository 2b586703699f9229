//! Geometry texture files: the box and up-axis comments, reading exemplars (meshes
//! without normals, flat files, georeferenced files), and writing the comments back.

use std::path::Path;

use glam::{DMat3, DVec3, Vec3};
use mls_surface::IsolatedPoints;
use pointset_core::io::{self, ReadOptions};
use pointset_core::{Aabb, KdIndex, PointSet, RunContext};

use super::samples::{ExemplarNormals, texture_samples};
use super::strays::{StrayPoints, isolated_handled, strays_handled};
use super::{GeometryTexture, UpAxis};
use crate::{Error, Result};

/// Comment lines describing a texture's box and up axis.
pub fn texture_comments(bounds: &Aabb, up: UpAxis) -> Vec<String> {
    texture_comments_at(bounds, up, DVec3::ZERO)
}

/// [`texture_comments`] for a box stored relative to `origin` (see [`TextureFile`]): the
/// corners are written as the sums, in double precision, when the origin is not zero.
pub fn texture_comments_at(bounds: &Aabb, up: UpAxis, origin: DVec3) -> Vec<String> {
    let axis = match up {
        UpAxis::X => "x",
        UpAxis::Y => "y",
        UpAxis::Z => "z",
    };
    let corner = |c: Vec3| io::position_text(c, origin);
    vec![
        format!("texture_box {} {}", corner(bounds.min), corner(bounds.max)),
        format!("texture_up {axis}"),
    ]
}

/// Parses the box and up axis from comment lines (see the module docs); `None` when absent.
pub fn parse_texture_comments(
    comments: &[String],
) -> std::result::Result<Option<(Aabb, UpAxis)>, String> {
    parse_texture_comments_at(comments, DVec3::ZERO)
}

/// [`parse_texture_comments`] for a file whose points were read relative to `origin`: the
/// box is moved by it in double precision before it is stored in single precision.
pub fn parse_texture_comments_at(
    comments: &[String],
    origin: DVec3,
) -> std::result::Result<Option<(Aabb, UpAxis)>, String> {
    let mut bounds = None;
    let mut up = UpAxis::Z;
    for c in comments {
        if let Some(rest) = c.trim().strip_prefix("texture_box") {
            let v: Vec<f64> = rest
                .split_whitespace()
                .map(str::parse)
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| format!("`{c}`: texture_box needs six numbers"))?;
            let [x0, y0, z0, x1, y1, z1] = v[..] else {
                return Err(format!("`{c}`: texture_box needs six numbers"));
            };
            let (lo, hi) = (DVec3::new(x0, y0, z0), DVec3::new(x1, y1, z1));
            let (lo, hi) = ((lo - origin).as_vec3(), (hi - origin).as_vec3());
            if !(lo.is_finite() && hi.is_finite()) {
                return Err(format!("`{c}`: texture_box needs finite numbers"));
            }
            bounds = Some(Aabb::new(lo, hi));
        } else if let Some(rest) = c.trim().strip_prefix("texture_up") {
            up = match rest.trim() {
                "x" | "X" => UpAxis::X,
                "y" | "Y" => UpAxis::Y,
                "z" | "Z" => UpAxis::Z,
                other => return Err(format!("texture_up must be x, y or z, not `{other}`")),
            };
        }
    }
    Ok(bounds.map(|b| (b, up)))
}

/// The error of a texture file `path` that the reader refuses, with `message` saying why.
pub(crate) fn texture_file_error(path: &Path) -> impl Fn(String) -> Error + Copy + '_ {
    |message| Error::TextureFile {
        path: path.to_path_buf(),
        message,
    }
}

/// A box given by its corners in a file's coordinates, relative to the `origin` its points
/// were read from. Errors (as messages) on corners that are not finite or not below one
/// another on every axis.
fn given_box([lo, hi]: [DVec3; 2], origin: DVec3) -> std::result::Result<Aabb, String> {
    let (a, b) = ((lo - origin).as_vec3(), (hi - origin).as_vec3());
    if !(a.is_finite() && b.is_finite() && a.cmplt(b).all()) {
        return Err(format!(
            "the box from ({:?}, {:?}, {:?}) to ({:?}, {:?}, {:?}) needs finite corners, the \
             first below the second on every axis",
            lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
        ));
    }
    Ok(Aabb::new(a, b))
}

/// The box of a file without texture comments: the points' bounding box inset by a sixth
/// across the plane perpendicular to `up`, one sample spacing thick where they are flat.
/// Errors (as messages) on no points.
pub(super) fn default_box(points: &PointSet, up: UpAxis) -> std::result::Result<Aabb, String> {
    let b = points.bounding_box().ok_or("no points")?;
    let across = match up {
        UpAxis::X => Vec3::new(0.0, 1.0, 1.0),
        UpAxis::Y => Vec3::new(1.0, 0.0, 1.0),
        UpAxis::Z => Vec3::new(1.0, 1.0, 0.0),
    };
    let inset = b.extent() / 6.0 * across;
    let thickness = flat_thickness(points, b, across).map_err(|e| e.to_string())?;
    Ok(Aabb::new(
        b.min + inset - thickness,
        b.max - inset + thickness,
    ))
}

/// How far the default box reaches beyond the points along the up axis (`across` is 0
/// there): nothing, unless the points lie within one sample spacing of a plane. Then the
/// box is widened to one median sample spacing in total, so that a flat exemplar (a
/// scanned floor, a plane written by another tool) has a box with volume.
fn flat_thickness(points: &PointSet, b: Aabb, across: Vec3) -> Result<Vec3> {
    let up = Vec3::ONE - across;
    let height = b.extent().dot(up);
    let spacing = KdIndex::new(points.positions())?.median_spacing()?;
    Ok(up * (0.5 * (spacing - height)).max(0.0))
}

/// Reads a geometry texture file (see the module docs). A mesh without vertex normals
/// gets them from its faces.
pub fn read_texture(path: &Path) -> Result<GeometryTexture> {
    read_texture_with_up(path, None)
}

/// [`read_texture`] for a file that may have been written with another up axis: a file
/// without texture comments is taken to have `up` as its up axis (Z when `None`), and its
/// box is inset by a sixth across the plane perpendicular to it. A file whose
/// `texture_up` comment names another axis than `up` is an error, not a guess.
///
/// ```
/// use geosynth::quilt::{UpAxis, read_texture_with_up};
/// // Ripples of y = 0.1 sin(3x) over the XZ plane, as a Y-up tool writes them (no comments).
/// let mut ply = String::from("ply\nformat ascii 1.0\nelement vertex 1600\n");
/// ply += "property float x\nproperty float y\nproperty float z\n";
/// ply += "property float nx\nproperty float ny\nproperty float nz\nend_header\n";
/// for k in 0..1600 {
///     let (x, z) = ((k % 40) as f32 * 0.1, (k / 40) as f32 * 0.1);
///     let n = glam::Vec3::new(-0.3 * (3.0 * x).cos(), 1.0, 0.0).normalize();
///     ply += &format!("{x} {} {z} {} {} {}\n", 0.1 * (3.0 * x).sin(), n.x, n.y, n.z);
/// }
/// let path = std::env::temp_dir().join("geosynth_doc_y_up.ply");
/// std::fs::write(&path, ply)?;
/// let texture = read_texture_with_up(&path, Some(UpAxis::Y))?;
/// assert_eq!(texture.up(), UpAxis::Y);
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_texture_with_up(path: &Path, up: Option<UpAxis>) -> Result<GeometryTexture> {
    let reading = TextureReading {
        up,
        ..TextureReading::default()
    };
    read_texture_from(
        path,
        &ReadOptions::default(),
        &reading,
        &mut RunContext::new(0),
    )
    .map(|file| file.texture)
}

/// A geometry texture read from a file that may lie far from the origin (georeferenced
/// data): the texture's points and box are relative to `origin`, which is kept in double
/// precision so that outputs can be written back where the exemplar was
/// ([`pointset_core::io::WriteOptions::origin`], [`texture_comments_at`]).
#[derive(Debug, Clone)]
pub struct TextureFile {
    /// The texture, relative to `origin`.
    pub texture: GeometryTexture,
    /// Where the file's coordinates start from: zero unless the data lies further from the
    /// file's origin than its own extent ([`pointset_core::io::ReadOptions::recentre_far`]),
    /// or the points' centroid for a fitted reference plane.
    pub origin: DVec3,
    /// The texture's axes in the file's frame (columns): file coordinates = `origin +
    /// frame · texture coordinates`. The identity, except for a reference plane fitted to
    /// the points ([`super::read_texture_file_fitted`]), whose normal is the third column.
    pub frame: DMat3,
    /// When the file itself stored coordinates that far out in single precision, they sit
    /// on a grid: the coarsest step of that grid over the axes whose coordinates all lie on
    /// it (none when the file keeps finer coordinates than a single-precision grid would).
    /// Recentring cannot restore what the file lost.
    pub single_precision_step: Option<f64>,
    /// What the file had that the reader could not keep
    /// ([`pointset_core::io::LoadedGeometry::notes`]); empty for generated textures.
    pub notes: Vec<String>,
    /// With [`ExemplarNormals::Estimated`]: how many points' neighbourhoods defined no
    /// normal (on a line, coincident or isotropic; [`mls_surface::NormalFit::undefined`]),
    /// so that their normals are arbitrary across the line (more neighbours fix them).
    /// 0 otherwise.
    pub undefined_normals: usize,
    /// For a point set read with the default box (no texture comments, no given box) or
    /// in a fitted plane: how many of its points lie far outside the rest
    /// ([`pointset_core::strays::kept_indices`]), and whether they were left out of the
    /// texture (the default, since they would stretch the box) or kept
    /// ([`TextureReading::keep_strays`]). `None` when there are none, for meshes and for
    /// files whose box is given.
    pub stray_points: Option<StrayPoints>,
    /// For a point set: how many of its points lie too far from the others for the
    /// texture's MLS surface to take them in ([`mls_surface::without_isolated`]; each
    /// would be a bubble of its own in the exemplar's distance field, copied into the
    /// output), and what was done with them: left out under any box (and in a fitted
    /// plane), kept with [`TextureReading::keep_strays`] or when they are most of the
    /// points.
    /// `None` when there are none, and for meshes.
    pub isolated_points: Option<IsolatedPoints>,
    /// For a mesh read by its vertices: its longest edge over the median distance from a
    /// vertex to the nearest other one. Far above 1 (say 4), some triangles are large for
    /// the vertices' spacing and the vertices undersample the surface there;
    /// [`TextureReading::mesh_samples`] samples it evenly instead. `None` for point sets,
    /// sampled meshes, and meshes without an edge or a spacing (coincident vertices).
    pub longest_edge_spacings: Option<f32>,
}

/// A texture that lies where its coordinates say (a height field, a generated exemplar):
/// origin zero, axis frame, nothing lost to single precision.
impl From<GeometryTexture> for TextureFile {
    fn from(texture: GeometryTexture) -> Self {
        Self {
            texture,
            origin: DVec3::ZERO,
            frame: DMat3::IDENTITY,
            single_precision_step: None,
            notes: Vec::new(),
            undefined_normals: 0,
            stray_points: None,
            isolated_points: None,
            longest_edge_spacings: None,
        }
    }
}

/// [`read_texture_with_up`] for files that may lie far from the origin: positions are read
/// relative to an origin kept in double precision when the data lies further from the
/// file's origin than its own extent, so that georeferenced exemplars (coordinates in the
/// millions) keep their precision.
///
/// ```
/// use geosynth::quilt::read_texture_file;
/// // Ripples 4,000 km north, in double precision: an f32 would step by 0.25 there.
/// let mut ply = String::from("ply\nformat ascii 1.0\nelement vertex 1600\n");
/// ply += "property double x\nproperty double y\nproperty double z\n";
/// ply += "property float nx\nproperty float ny\nproperty float nz\nend_header\n";
/// for k in 0..1600 {
///     let (x, y) = ((k % 40) as f64 * 0.1, (k / 40) as f64 * 0.1);
///     let z = 0.1 * (3.0 * x).sin();
///     ply += &format!("{} {} {z} 0 0 1\n", 500_000.0 + x, 4_000_000.0 + y);
/// }
/// let path = std::env::temp_dir().join("geosynth_doc_far_texture.ply");
/// std::fs::write(&path, ply)?;
/// let file = read_texture_file(&path, None)?;
/// assert_eq!(file.origin, glam::DVec3::new(500_002.0, 4_000_002.0, 0.0));
/// assert_eq!(file.single_precision_step, None);
/// // Samples 0.1 apart stay 0.1 apart (as f32 near the origin).
/// let p = file.texture.canonical_points().positions();
/// assert!((p[1].x - p[0].x - 0.1).abs() < 1e-6);
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_texture_file(path: &Path, up: Option<UpAxis>) -> Result<TextureFile> {
    let reading = TextureReading {
        up,
        ..TextureReading::default()
    };
    read_texture_file_with(path, &reading, &mut RunContext::new(0))
}

/// How [`read_texture_file_with`] reads a texture file beyond its coordinates: its up
/// axis, where its normals come from, and its box.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TextureReading {
    /// The up axis of a file without texture comments (Z when `None`); a file whose
    /// `texture_up` comment names another axis is refused.
    pub up: Option<UpAxis>,
    /// Where the exemplar's normals come from (the file's own by default).
    pub normals: ExemplarNormals,
    /// The box `B_Tin` (paper §3) as its lower and upper corners in the file's coordinates
    /// (double precision, so that georeferenced files can be given theirs), in place of a
    /// `texture_box` comment's or the default box (the points' box inset by a sixth across
    /// the reference plane). Points outside it across the plane are padding. `None` by
    /// default.
    pub bounds: Option<[DVec3; 2]>,
    /// Keep a point set's stray points ([`pointset_core::strays::kept_indices`]: far
    /// outside the rest) under the default box, which then spans them, and its isolated
    /// points ([`TextureFile::isolated_points`]) under any box. By default both are left
    /// out, as if the file did not hold them ([`TextureFile::stray_points`] and
    /// [`TextureFile::isolated_points`] count them). A box given or read from the
    /// comments does not stretch to far points, so none is left out as stray there; a
    /// lone far point is still isolated, and left out as such.
    pub keep_strays: bool,
    /// For a mesh exemplar: quilt about this many points sampled on its surface as a
    /// Poisson disk, with its faces' normals and the reading's seed (`ctx`'s; `geosynth
    /// quilt` reads with seed 0, whatever the quilt's), instead of its vertices (which
    /// undersample a mesh whose triangles are large for its detail, such as boxes on a
    /// plane; [`TextureFile::longest_edge_spacings`]). A point set given a count is
    /// refused. `None` (the default) reads a mesh by its vertices.
    pub mesh_samples: Option<usize>,
}

/// [`read_texture_file`] read as `reading` says: the up axis, the normals (for a bare point
/// set, [`ExemplarNormals::Estimated`] fits them and turns them toward the texture's up
/// axis, the `texture_up` comment's or `reading.up`'s) and the box. Estimating reports
/// progress through `ctx` ([`mls_surface::FITTING_STAGE`] and the orientation's stages,
/// each timed) and stops with [`Error::is_cancelled`] when it is cancelled.
///
/// Errors, besides [`read_texture_file`]'s: a box whose lower corner is not below its
/// upper one on every axis, or not finite.
///
/// ```
/// use geosynth::RunContext;
/// use geosynth::quilt::{ExemplarNormals, TextureReading, read_texture_file_with};
/// // Ripples z = 0.1 sin(3x) as bare positions (an XYZ file: no normals, no comments).
/// let xyz: String = (0..1600)
///     .map(|k| {
///         let (x, y) = ((k % 40) as f32 * 0.1, (k / 40) as f32 * 0.1);
///         format!("{x} {y} {}\n", 0.1 * (3.0 * x).sin())
///     })
///     .collect();
/// let path = std::env::temp_dir().join("geosynth_doc_bare_ripples.xyz");
/// std::fs::write(&path, xyz)?;
/// let reading = TextureReading {
///     normals: ExemplarNormals::Estimated { neighbours: 12 },
///     // The middle of the ripples as the box; the rest is padding.
///     bounds: Some([glam::DVec3::new(1.0, 1.0, -0.2), glam::DVec3::new(3.0, 3.0, 0.2)]),
///     ..TextureReading::default()
/// };
/// let file = read_texture_file_with(&path, &reading, &mut RunContext::new(0))?;
/// assert_eq!(file.texture.footprint(), (glam::Vec2::ONE, glam::Vec2::splat(3.0)));
/// // Every normal faces up; away from the border (where the neighbourhoods are one-sided)
/// // within 5° of the ripples' own.
/// let points = file.texture.canonical_points();
/// let normals = points.normals().ok_or("no normals")?;
/// for (p, n) in points.positions().iter().zip(normals) {
///     assert!(n.z > 0.9, "{p} {n}");
///     let truth = glam::Vec3::new(-0.3 * (3.0 * p.x).cos(), 0.0, 1.0).normalize();
///     let inside = p.x.min(p.y) > 0.15 && p.x.max(p.y) < 3.75;
///     assert!(!inside || n.angle_between(truth) < 5f32.to_radians(), "{p} {n}");
/// }
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_texture_file_with(
    path: &Path,
    reading: &TextureReading,
    ctx: &mut RunContext,
) -> Result<TextureFile> {
    read_texture_from(
        path,
        &ReadOptions::default().recentre_far(true),
        reading,
        ctx,
    )
}

/// The step of the single-precision grid the file's coordinates sit on, if they all do on
/// some axis where that grid is coarser than `f32` near the origin (see
/// [`TextureFile::single_precision_step`]).
pub(crate) fn single_precision_step(points: &PointSet, origin: DVec3) -> Option<f64> {
    let positions = points.positions();
    (0..3)
        .filter(|&axis| origin[axis] != 0.0)
        .filter_map(|axis| {
            let reach = positions
                .iter()
                .map(|p| f64::from(p[axis]).abs())
                .fold(0.0, f64::max);
            let farthest = (origin[axis].abs() + reach) as f32;
            let step = f64::from(f32::from_bits(farthest.to_bits() + 1) - farthest);
            let on_grid = positions.iter().all(|p| {
                let file_value = f64::from(p[axis]) + origin[axis];
                (file_value / step).fract() == 0.0
            });
            on_grid.then_some(step)
        })
        .reduce(f64::max)
}

fn read_texture_from(
    path: &Path,
    options: &ReadOptions,
    reading: &TextureReading,
    ctx: &mut RunContext,
) -> Result<TextureFile> {
    let up = reading.up;
    let file_error = texture_file_error(path);
    let loaded = io::read_geometry_with(path, options)?;
    let origin = loaded.origin;
    let described = parse_texture_comments_at(&loaded.comments, origin).map_err(file_error)?;
    let file_up = described.map_or(up.unwrap_or_default(), |(_, file_up)| file_up);
    if let Some(wanted) = up
        && wanted != file_up
    {
        return Err(file_error(format!(
            "its texture comments give up axis {file_up:?}, not the {wanted:?} asked for"
        )));
    }
    let given = reading
        .bounds
        .map(|corners| given_box(corners, origin))
        .transpose()
        .map_err(file_error)?;
    // Stray points would stretch only the default box; left out before any normal is
    // fitted to them.
    let (geometry, stray_points) = match (given, described) {
        (None, None) => strays_handled(loaded.geometry, reading.keep_strays),
        _ => (loaded.geometry, None),
    };
    // Isolated points would be bubbles under any box.
    let (geometry, isolated_points) = isolated_handled(geometry, reading.keep_strays)?;
    let samples = texture_samples(
        path,
        geometry,
        reading.normals,
        reading.mesh_samples,
        file_up.to_world(Vec3::Z),
        ctx,
    )?;
    let points = samples.points;
    let bounds = match (given, described) {
        (Some(bounds), _) | (None, Some((bounds, _))) => bounds,
        (None, None) => default_box(&points, file_up).map_err(file_error)?,
    };
    Ok(TextureFile {
        texture: GeometryTexture::new(&points, bounds, file_up)?,
        origin,
        frame: DMat3::IDENTITY,
        single_precision_step: single_precision_step(&points, origin),
        notes: loaded.notes,
        undefined_normals: samples.undefined_normals,
        stray_points,
        isolated_points,
        longest_edge_spacings: samples.longest_edge_spacings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quilt::{OutputSize, QuiltParams, quilt, read_texture_file_fitted};
    use mls_surface::IsolatedFate;
    use pointset_core::RunContext;

    fn parse(lines: &[&str]) -> std::result::Result<Option<(Aabb, UpAxis)>, String> {
        parse_texture_comments(&lines.iter().map(|l| l.to_string()).collect::<Vec<_>>())
    }

    #[test]
    fn texture_comments_give_box_and_up_axis_or_say_what_is_wrong() {
        let box_and_up = parse(&["texture_box 0 0 -1 4 4 1", "texture_up y"]);
        assert_eq!(
            box_and_up,
            Ok(Some((
                Aabb::new(Vec3::new(0.0, 0.0, -1.0), Vec3::new(4.0, 4.0, 1.0)),
                UpAxis::Y
            )))
        );
        assert_eq!(parse(&["made by hand"]), Ok(None));
        // A box kept relative to a far origin is written as the sums and read back.
        let origin = DVec3::new(512_345.0, 4_123_456.0, -7.0);
        let local = Aabb::new(Vec3::new(-1.5, -2.0, 0.125), Vec3::new(2.5, 2.0, 0.75));
        let lines = texture_comments_at(&local, UpAxis::X, origin);
        assert_eq!(
            lines[0],
            "texture_box 512343.5 4123454 -6.875 512347.5 4123458 -6.25"
        );
        assert_eq!(
            parse_texture_comments_at(&lines, origin),
            Ok(Some((local, UpAxis::X)))
        );
        for bad in [
            "texture_box 0 0 -1 4 4",
            "texture_box 0 0 -1 4 4 one",
            "texture_box nan 0 -1 4 4 1",
            "texture_box 0 0 -1 inf 4 1",
            "texture_up w",
        ] {
            assert!(parse(&[bad]).is_err(), "{bad}");
        }
    }

    #[test]
    fn a_mesh_without_normals_is_read_with_normals_from_its_faces() {
        // A 30 × 30 grid of z = 0.1 sin(2x), triangulated counter-clockwise seen from +z,
        // plus one vertex no face uses, as OFF (which stores no normals).
        let n = 30;
        let h = |x: f32| 0.1 * (2.0 * x).sin();
        let mut off = format!("OFF\n{} {} 0\n", n * n + 1, 2 * (n - 1) * (n - 1));
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (i as f32 * 0.1, j as f32 * 0.1);
                off.push_str(&format!("{x} {y} {}\n", h(x)));
            }
        }
        off.push_str("9 9 9\n");
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let v = j * n + i;
                off.push_str(&format!("3 {} {} {}\n", v, v + 1, v + n + 1));
                off.push_str(&format!("3 {} {} {}\n", v, v + n + 1, v + n));
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("wave.off");
        std::fs::write(&path, off).unwrap();
        let texture = read_texture(&path).unwrap();
        let points = texture.canonical_points();
        assert_eq!(points.len(), n * n, "the unused vertex is left out");
        // Interior vertices: the face-averaged normal is the wave's, within 2°.
        for (p, normal) in points.positions().iter().zip(points.normals().unwrap()) {
            let interior = p.x > 0.05 && p.x < 2.85 && p.y > 0.05 && p.y < 2.85;
            let exact = Vec3::new(-0.2 * (2.0 * p.x).cos(), 0.0, 1.0).normalize();
            assert!(
                !interior || normal.dot(exact) > 2f32.to_radians().cos(),
                "{p}: {normal} against {exact}"
            );
        }
        let params = QuiltParams::default()
            .output(OutputSize::Scale(1.25))
            .field_resolution(20);
        let out = quilt(&texture, &params, &mut RunContext::new(1)).unwrap();
        assert!(out.points.len() > points.len() / 2);
    }

    #[test]
    fn a_mesh_of_degenerate_faces_is_refused_naming_why() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sliver.obj");
        // Two faces whose corners lie on one line: no face has area, so no normal.
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 3 2 1\n").unwrap();
        let refused = read_texture_file(&path, None).err().map(|e| e.to_string());
        let message = refused.unwrap_or_default();
        assert!(
            message.starts_with(&path.display().to_string()),
            "{message}"
        );
        assert!(
            message.contains("none of the mesh's 3 vertices"),
            "{message}"
        );
        assert!(
            read_texture_file_fitted(&path).is_err_and(|e| e.to_string() == message),
            "the fitted reader refuses it alike"
        );
    }
    #[test]
    fn what_the_reader_could_not_keep_travels_with_the_texture() {
        let dir = tempfile::tempdir().unwrap();
        let plain = grid_ply(dir.path(), "grid.ply", |_| 0.0);
        let text = std::fs::read_to_string(&plain).unwrap();
        let with_camera = text.replace(
            "end_header\n",
            "element camera 1\nproperty float f\nend_header\n",
        ) + "35\n";
        let path = dir.path().join("camera.ply");
        std::fs::write(&path, with_camera).unwrap();
        let expected = ["element `camera` (1 record) skipped"];
        assert_eq!(read_texture_file(&path, None).unwrap().notes, expected);
        assert_eq!(
            super::super::read_texture_file_fitted(&path).unwrap().notes,
            expected
        );
        assert!(read_texture_file(&plain, None).unwrap().notes.is_empty());
    }

    #[test]
    fn stray_points_are_left_out_under_the_default_box_unless_kept() {
        let dir = tempfile::tempdir().unwrap();
        let wave = grid_ply(dir.path(), "wave.ply", |x| 0.1 * (2.0 * x).sin());
        let clean = read_texture_file(&wave, None).unwrap();
        assert_eq!(clean.stray_points, None);
        // One point 50 above the others.
        let stray = with_point(&wave, "1.5 1.5 50", "stray.ply");
        let read = |reading: TextureReading| {
            read_texture_file_with(&stray, &reading, &mut RunContext::new(0)).unwrap()
        };
        // Left out: the clean file's texture.
        let file = read(TextureReading::default());
        let left_out = StrayPoints {
            count: 1,
            left_out: true,
        };
        assert_eq!(file.stray_points, Some(left_out));
        assert_same_texture(&file, &clean);
        // Kept: the default box reaches up to it.
        let kept = read(TextureReading {
            keep_strays: true,
            ..TextureReading::default()
        });
        assert_eq!(
            kept.stray_points,
            Some(StrayPoints {
                count: 1,
                left_out: false
            })
        );
        assert_eq!(kept.texture.canonical_bounds().max.z, 50.0);
        // A given box does not stretch to it, as comments do not: not stray there, but
        // isolated, and left out as such.
        let own = clean.texture.canonical_bounds();
        let boxed = read(TextureReading {
            bounds: Some([own.min.as_dvec3(), own.max.as_dvec3()]),
            ..TextureReading::default()
        });
        assert_eq!(boxed.stray_points, None);
        assert_eq!(boxed.isolated_points.map(|i| i.count), Some(1));
        assert_same_texture(&boxed, &clean);
        let bumpy = crate::fixtures::bundled_dir().join("quilt_bumpy.ply");
        assert_eq!(read_texture_file(&bumpy, None).unwrap().stray_points, None);
        // A fitted plane leaves it out: the clean file's plane, points and box.
        let fitted = super::super::read_texture_file_fitted(&stray).unwrap();
        let fitted_clean = super::super::read_texture_file_fitted(&wave).unwrap();
        assert_eq!(fitted.stray_points, Some(left_out));
        assert_eq!(
            (fitted.frame, fitted.origin),
            (fitted_clean.frame, fitted_clean.origin)
        );
        assert_same_texture(&fitted, &fitted_clean);
        assert_eq!(fitted_clean.stray_points, None);
    }

    #[test]
    fn isolated_points_are_left_out_under_any_box_unless_kept() {
        let dir = tempfile::tempdir().unwrap();
        let wave = grid_ply(dir.path(), "wave.ply", |x| 0.3 * (2.0 * x).sin());
        let clean = read_texture_file(&wave, None).unwrap();
        assert_eq!(clean.isolated_points, None);
        // A speck 0.9 above the crest at x = 0.8 (beyond the reach, 6.25 spacings, yet
        // within the points' z range widened twice, so not stray).
        let speck = with_point(&wave, "0.8 1.5 1.2", "speck.ply");
        let read = |path: &Path, reading: TextureReading| {
            read_texture_file_with(path, &reading, &mut RunContext::new(0)).unwrap()
        };
        let file = read(&speck, TextureReading::default());
        let isolated = file.isolated_points.unwrap();
        assert_eq!(
            (isolated.count, isolated.of, isolated.fate),
            (1, 901, IsolatedFate::LeftOut)
        );
        assert_eq!(file.stray_points, None);
        assert_same_texture(&file, &clean);
        // Under a given box too (as under a comment's).
        let own = clean.texture.canonical_bounds();
        let boxed = TextureReading {
            bounds: Some([own.min.as_dvec3(), own.max.as_dvec3()]),
            ..TextureReading::default()
        };
        let file = read(&speck, boxed);
        assert_eq!(
            file.isolated_points.map(|i| i.fate),
            Some(IsolatedFate::LeftOut)
        );
        assert_same_texture(&file, &read(&wave, boxed));
        // Kept: the default box reaches up to it.
        let kept = read(
            &speck,
            TextureReading {
                keep_strays: true,
                ..TextureReading::default()
            },
        );
        assert_eq!(
            kept.isolated_points.map(|i| i.fate),
            Some(IsolatedFate::Kept)
        );
        assert_eq!(kept.texture.canonical_points().len(), 901);
        assert_eq!(kept.texture.canonical_bounds().max.z, 1.2);
        // A fitted plane leaves it out.
        let fitted = super::super::read_texture_file_fitted(&speck).unwrap();
        assert_eq!(fitted.isolated_points.map(|i| i.count), Some(1));
        let fitted_clean = super::super::read_texture_file_fitted(&wave).unwrap();
        assert_eq!(fitted.frame, fitted_clean.frame);
        assert_same_texture(&fitted, &fitted_clean);
    }

    /// Asserts that two files read to the same texture points and box.
    fn assert_same_texture(a: &TextureFile, b: &TextureFile) {
        assert_eq!(a.texture.canonical_points(), b.texture.canonical_points());
        assert_eq!(a.texture.canonical_bounds(), b.texture.canonical_bounds());
    }

    /// A copy, named `name` beside it, of a [`grid_ply`] file at `grid` with one more
    /// point first, at `position` ("x y z") with a +Z normal.
    fn with_point(grid: &Path, position: &str, name: &str) -> std::path::PathBuf {
        let text = std::fs::read_to_string(grid).unwrap();
        let with_point = text
            .replace("element vertex 900", "element vertex 901")
            .replace("end_header\n", &format!("end_header\n{position} 0 0 1\n"));
        let path = grid.with_file_name(name);
        std::fs::write(&path, with_point).unwrap();
        path
    }

    /// An ASCII PLY of a 30 × 30 grid at spacing 0.1 with heights `z(x)` and +Z normals,
    /// without texture comments.
    fn grid_ply(dir: &Path, name: &str, z: impl Fn(f32) -> f32) -> std::path::PathBuf {
        let n = 30;
        let mut ply = format!("ply\nformat ascii 1.0\nelement vertex {}\n", n * n);
        ply += "property float x\nproperty float y\nproperty float z\n";
        ply += "property float nx\nproperty float ny\nproperty float nz\nend_header\n";
        for k in 0..n * n {
            let (x, y) = ((k % n) as f32 * 0.1, (k / n) as f32 * 0.1);
            ply += &format!("{x} {y} {} 0 0 1\n", z(x));
        }
        let path = dir.join(name);
        std::fs::write(&path, ply).unwrap();
        path
    }

    #[test]
    fn a_given_box_replaces_the_comments_and_the_default_in_file_coordinates() {
        let dir = tempfile::tempdir().unwrap();
        let read = |path: &Path, up: Option<UpAxis>, bounds: Option<[DVec3; 2]>| {
            let reading = TextureReading {
                up,
                bounds,
                ..TextureReading::default()
            };
            read_texture_file_with(path, &reading, &mut RunContext::new(0))
        };
        // Over the bumpy fixture's own `texture_box` comment.
        let bumpy = crate::fixtures::bundled_dir().join("quilt_bumpy.ply");
        let corners = [DVec3::new(1.0, 0.5, -0.5), DVec3::new(3.0, 3.5, 1.0)];
        let file = read(&bumpy, None, Some(corners)).unwrap();
        let expected = Aabb::new(Vec3::new(1.0, 0.5, -0.5), Vec3::new(3.0, 3.5, 1.0));
        assert_eq!(file.texture.canonical_bounds(), expected);
        // Y up: the corners are the file's, the texture's box their canonical turn.
        let wave = grid_ply(dir.path(), "wave.ply", |x| 0.1 * (2.0 * x).sin());
        let y_box = [DVec3::new(0.5, 0.0, -0.2), DVec3::new(2.5, 3.0, 0.2)];
        let turned = read(&wave, Some(UpAxis::Y), Some(y_box)).unwrap();
        let world = Aabb::new(y_box[0].as_vec3(), y_box[1].as_vec3());
        assert_eq!(
            turned.texture.canonical_bounds(),
            UpAxis::Y.canonical_box(&world)
        );
        // Far from the origin: the corners are taken in double precision, relative to the
        // origin the points were read from.
        let far = dir.path().join("far.ply");
        let text = std::fs::read_to_string(&wave).unwrap();
        let mut shifted = String::new();
        for line in text.lines() {
            let v: Vec<f64> = line.split(' ').filter_map(|t| t.parse().ok()).collect();
            if v.len() == 6 {
                let (x, y) = (v[0] + 600_000.0, v[1] + 5_000_000.0);
                shifted += &format!("{x} {y} {} {} {} {}\n", v[2], v[3], v[4], v[5]);
            } else {
                shifted += &format!(
                    "{}\n",
                    line.replace("property float x", "property double x")
                        .replace("property float y", "property double y")
                );
            }
        }
        std::fs::write(&far, shifted).unwrap();
        let offset = DVec3::new(600_000.0, 5_000_000.0, 0.0);
        let far_box = [
            DVec3::new(0.5, 0.5, -0.5) + offset,
            DVec3::new(2.5, 2.0, 0.5) + offset,
        ];
        let file = read(&far, None, Some(far_box)).unwrap();
        let local = Aabb::new(
            (far_box[0] - file.origin).as_vec3(),
            (far_box[1] - file.origin).as_vec3(),
        );
        assert_eq!(file.texture.canonical_bounds(), local);
        assert!(file.origin.x > 500_000.0, "{}", file.origin);
        // Corners out of order or not finite are refused, naming the file.
        for bad in [
            [DVec3::new(2.0, 0.0, -1.0), DVec3::new(1.0, 3.0, 1.0)],
            [DVec3::new(0.0, 0.0, 1.0), DVec3::new(3.0, 3.0, 1.0)],
            [DVec3::new(f64::NAN, 0.0, -1.0), DVec3::new(3.0, 3.0, 1.0)],
        ] {
            let refused = read(&wave, None, Some(bad)).unwrap_err().to_string();
            assert!(
                refused.contains("wave.ply") && refused.contains("first below the second"),
                "{refused}"
            );
        }
    }

    #[test]
    fn a_flat_file_gets_a_box_one_spacing_thick_and_quilts_flat() {
        let dir = tempfile::tempdir().unwrap();
        let flat = read_texture(&grid_ply(dir.path(), "flat.ply", |_| 0.0)).unwrap();
        let b = flat.canonical_bounds();
        assert!(
            (b.min.z + 0.05).abs() < 1e-6 && (b.max.z - 0.05).abs() < 1e-6,
            "{b:?}"
        );
        let params = QuiltParams::default()
            .output(OutputSize::Scale(1.25))
            .field_resolution(20);
        let out = quilt(&flat, &params, &mut RunContext::new(1)).unwrap();
        let normals = out.points.normals().unwrap();
        for (p, n) in out.points.positions().iter().zip(normals) {
            assert!(p.z == 0.0 && *n == Vec3::Z, "{p} {n}");
        }
        // Relief of at least a spacing keeps the points' own height range.
        let wave = |x: f32| 0.1 * (2.0 * x).sin();
        let waved = read_texture(&grid_ply(dir.path(), "wave.ply", wave)).unwrap();
        let (lo, hi) = (
            waved.canonical_bounds().min.z,
            waved.canonical_bounds().max.z,
        );
        let range = waved.canonical_points().bounding_box().unwrap();
        assert_eq!((lo, hi), (range.min.z, range.max.z));
    }
}
