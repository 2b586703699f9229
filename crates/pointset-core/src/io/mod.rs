//! Reading and writing point sets and meshes: PLY, OBJ, OFF, STL (meshes only), XYZ
//! (points only: `.xyz`, `.xyzn`, `.xyzrgb`), LAS (LiDAR points: `.las`; see
//! [`read_las`]), PCD (the Point Cloud Library's points: `.pcd`; see [`read_pcd`]) and
//! glTF 2.0 (scenes: `.glb`, `.gltf`; see [`read_gltf`]).
//!
//! [`read_geometry`] picks the format from the file extension and checks it against the
//! content (a `.ply` that does not start with `ply` is an error, not a guess); files without
//! a known extension are identified by content alone. Every reader returns typed errors with
//! a line number or byte offset, and checks declared counts against the bytes present before
//! allocating.
//!
//! Positions are stored in single precision. Georeferenced data (coordinates in the
//! millions, as in UTM) would arrive quantized — at 4e6 an `f32` steps by 0.25 — so
//! [`read_geometry_with`] can store positions relative to an origin kept in double
//! precision ([`ReadOptions::recentre_far`], [`LoadedGeometry::origin`]), and
//! [`write_geometry`] adds such an origin back ([`WriteOptions::origin`]; PLY then stores
//! `double` coordinates). Plain [`read_geometry`] never moves the data.

mod buffered;
pub mod gltf;
mod las;
mod obj;
mod off;
mod pcd;
pub mod ply;
mod replace;
mod reporting;
mod stl;
mod stream;
mod xyz;

use std::fmt;
use std::fs::File;
use std::io::{Cursor, Read, Seek, SeekFrom};
use std::path::Path;

use gltf::write_gltf_at;
pub use gltf::{GltfContainer, MAX_GLTF_VERTICES, read_gltf, write_gltf};
use las::write_las_at;
pub use las::{read_las, write_las};
pub use obj::{read_obj, write_obj};
use obj::{read_obj_from, write_obj_at};
use off::write_off_at;
pub use off::{read_off, write_off};
use pcd::write_pcd_at;
pub use pcd::{PcdEncoding, read_pcd, write_pcd};
pub use replace::{
    ABANDONED, FileReplacement, abandon_replacements, check_replaceable, replace_file, write_whole,
};
use stl::write_stl_at;
pub use stl::{StlEncoding, read_stl, write_stl, write_stl_ascii};
use xyz::write_xyz_at;
pub use xyz::{XyzColumns, read_xyz, write_xyz};

use glam::{DVec3, Vec3};

use crate::{Aabb, Attribute, COLOR_CHANNELS, Error, PointSet, Result, RunContext, TriMesh};
use ply::PlyEncoding;
use reporting::{ReportingReader, cancelled_read};

/// The supported file formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FileFormat {
    /// Stanford PLY.
    Ply,
    /// Wavefront OBJ.
    Obj,
    /// Object File Format.
    Off,
    /// Stereolithography triangles, binary or ASCII (meshes only: see [`read_stl`]).
    Stl,
    /// A point a line, text (points only: see [`read_xyz`]); the columns are named by the
    /// extension.
    Xyz(XyzColumns),
    /// ASPRS LAS, LiDAR points (see [`read_las`], [`write_las`]). A `.laz` file is read
    /// as LAS, so that its compression is refused with its own message; it is not written.
    Las,
    /// The Point Cloud Library's point clouds, ASCII, binary or compressed (see
    /// [`read_pcd`], [`write_pcd`]).
    Pcd,
    /// glTF 2.0 scenes, in either container (see [`read_gltf`], [`write_gltf`]).
    Gltf(GltfContainer),
}

/// The extensions the writers know, for messages.
pub const GEOMETRY_EXTENSIONS: &str =
    ".ply, .obj, .off, .stl, .xyz, .xyzn, .xyzrgb, .las, .pcd, .glb or .gltf";

impl fmt::Display for FileFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FileFormat::Ply => "PLY",
            FileFormat::Obj => "OBJ",
            FileFormat::Off => "OFF",
            FileFormat::Stl => "STL",
            FileFormat::Xyz(XyzColumns::Positions) => "XYZ",
            FileFormat::Xyz(XyzColumns::Normals) => "XYZN",
            FileFormat::Xyz(XyzColumns::Colours) => "XYZRGB",
            FileFormat::Las => "LAS",
            FileFormat::Pcd => "PCD",
            FileFormat::Gltf(GltfContainer::Binary) => "GLB",
            FileFormat::Gltf(GltfContainer::Json) => "glTF",
        })
    }
}

impl FileFormat {
    /// The format an extension names (case-insensitive), if any.
    pub fn from_extension(ext: &str) -> Option<Self> {
        match ext.to_ascii_lowercase().as_str() {
            "ply" => Some(FileFormat::Ply),
            "obj" => Some(FileFormat::Obj),
            "off" => Some(FileFormat::Off),
            "stl" => Some(FileFormat::Stl),
            "xyz" => Some(FileFormat::Xyz(XyzColumns::Positions)),
            "xyzn" => Some(FileFormat::Xyz(XyzColumns::Normals)),
            "xyzrgb" => Some(FileFormat::Xyz(XyzColumns::Colours)),
            "las" => Some(FileFormat::Las),
            "pcd" => Some(FileFormat::Pcd),
            "glb" => Some(FileFormat::Gltf(GltfContainer::Binary)),
            "gltf" => Some(FileFormat::Gltf(GltfContainer::Json)),
            _ => None,
        }
    }

    /// Refuses, before any work is done, what writing in this format would fail on or
    /// lose: a point set (`mesh` false) or a nonzero write origin
    /// ([`WriteOptions::origin`]) as STL, a mesh as XYZ, LAS or PCD (its faces). PLY, OBJ,
    /// OFF and glTF store all of them.
    ///
    /// ```
    /// use glam::DVec3;
    /// use pointset_core::io::FileFormat;
    /// assert!(FileFormat::Stl.check_can_store(true, DVec3::ZERO).is_ok());
    /// assert!(FileFormat::Stl.check_can_store(false, DVec3::ZERO).is_err());
    /// assert!(FileFormat::Stl.check_can_store(true, DVec3::new(5e5, 0.0, 0.0)).is_err());
    /// assert!(FileFormat::Off.check_can_store(false, DVec3::new(5e5, 0.0, 0.0)).is_ok());
    /// let xyz = FileFormat::Xyz(pointset_core::io::XyzColumns::Positions);
    /// assert_eq!(FileFormat::from_extension("xyz"), Some(xyz));
    /// assert!(xyz.check_can_store(false, DVec3::ZERO).is_ok());
    /// assert!(xyz.check_can_store(true, DVec3::ZERO).is_err());
    /// ```
    pub fn check_can_store(self, mesh: bool, origin: DVec3) -> Result<()> {
        match self {
            FileFormat::Stl => stl::check_storable(mesh, origin),
            FileFormat::Xyz(columns) if mesh => Err(xyz::cannot_store_mesh(columns)),
            FileFormat::Las if mesh => Err(las::cannot_store_mesh()),
            FileFormat::Pcd if mesh => Err(pcd::cannot_store_mesh()),
            FileFormat::Ply
            | FileFormat::Obj
            | FileFormat::Off
            | FileFormat::Xyz(_)
            | FileFormat::Las
            | FileFormat::Pcd
            | FileFormat::Gltf(_) => Ok(()),
        }
    }

    /// What writing `geometry` in this format would not store, in words (empty when the
    /// format keeps everything). PLY keeps everything; OBJ drops attributes other than
    /// colours; OFF drops those and UVs; STL keeps only positions and triangles; `.xyz` and
    /// `.xyzn` keep positions and normals, `.xyzrgb` positions and colours, LAS positions,
    /// colours and the `intensity` and `classification` attributes when their values fit
    /// its records, PCD everything a point set holds, glTF everything (attributes stored as
    /// 32-bit integers or doubles are written as floats of the same values). No format of
    /// points keeps a mesh's faces, which [`Self::check_can_store`] refuses. Colours are
    /// the `red`, `green`, `blue` channels when all three exist.
    ///
    /// ```
    /// use pointset_core::io::{FileFormat, Geometry};
    /// use pointset_core::{Attribute, PointSet, glam::Vec3};
    /// let mut points = PointSet::new(vec![Vec3::ZERO])?.with_normals(vec![Vec3::Z])?;
    /// points.set_attribute(Attribute::new("quality", vec![0.5]))?;
    /// let geometry = Geometry::Points(points);
    /// assert!(FileFormat::Ply.unstored(&geometry).is_empty());
    /// assert_eq!(FileFormat::Off.unstored(&geometry), ["attribute `quality`"]);
    /// # Ok::<(), pointset_core::Error>(())
    /// ```
    pub fn unstored(self, geometry: &Geometry) -> Vec<String> {
        // (UVs, colours, other attributes) kept.
        let (uvs, colours, others) = match self {
            FileFormat::Ply | FileFormat::Pcd | FileFormat::Gltf(_) => (true, true, true),
            FileFormat::Obj => (true, true, false),
            FileFormat::Off => (false, true, false),
            FileFormat::Stl => (false, false, false),
            FileFormat::Xyz(XyzColumns::Colours) | FileFormat::Las => (false, true, false),
            FileFormat::Xyz(_) => (false, false, false),
        };
        let normals = self.stores_normals();
        let points = geometry.points();
        let has_colours = points.colors().is_some();
        let mut lost = Vec::new();
        if !normals && points.normals().is_some() {
            lost.push("vertex normals".to_string());
        }
        if !uvs && geometry.mesh().and_then(TriMesh::uvs).is_some() {
            lost.push("UVs".to_string());
        }
        if !colours && has_colours {
            lost.push("colours".to_string());
        }
        let is_colour = |name: &str| has_colours && COLOR_CHANNELS.contains(&name);
        // LAS records hold an intensity and a class, when the values fit.
        let in_las_record = |a: &Attribute| self == FileFormat::Las && las::stores(a);
        if !others {
            lost.extend(
                points
                    .attributes()
                    .iter()
                    .filter(|a| !is_colour(a.name()) && !in_las_record(a))
                    .map(|a| format!("attribute `{}`", a.name())),
            );
        }
        lost
    }

    /// Whether the format stores per-point (vertex) normals: PLY, OBJ, OFF, PCD, `.xyz`
    /// and `.xyzn` do; STL (a normal per facet only), `.xyzrgb` and LAS do not.
    ///
    /// ```
    /// use pointset_core::io::FileFormat;
    /// assert!(FileFormat::from_extension("xyzn").is_some_and(FileFormat::stores_normals));
    /// assert!(!FileFormat::from_extension("las").is_some_and(FileFormat::stores_normals));
    /// ```
    pub fn stores_normals(self) -> bool {
        match self {
            FileFormat::Ply
            | FileFormat::Obj
            | FileFormat::Off
            | FileFormat::Pcd
            | FileFormat::Gltf(_) => true,
            FileFormat::Stl | FileFormat::Las | FileFormat::Xyz(XyzColumns::Colours) => false,
            FileFormat::Xyz(_) => true,
        }
    }

    /// The format a file's content looks like, if any (a `.glb` by its magic bytes, a
    /// `.gltf` by a JSON object naming glTF members). A binary STL is recognised by its
    /// size (84 bytes plus 50 per facet its header declares), so pass the whole file.
    pub fn sniff(bytes: &[u8]) -> Option<Self> {
        Self::sniff_start(bytes, bytes.len() as u64)
    }

    /// [`FileFormat::sniff`] of a file of `len` bytes that starts with `head`: the same
    /// answer when `head` holds the whole file or at least its first [`SNIFFED_TEXT`]
    /// bytes, since the checks look no further (the first text line within 4096 bytes,
    /// and the 6 bytes from its first character for `solid`).
    fn sniff_start(head: &[u8], len: u64) -> Option<Self> {
        if las::looks_like_las(head) {
            return Some(FileFormat::Las);
        }
        if stl::binary_facet_count_of(head, len).is_some() {
            return Some(FileFormat::Stl);
        }
        if let Some(container) = gltf::sniff(head) {
            return Some(FileFormat::Gltf(container));
        }
        if head.starts_with(b"ply") && matches!(head.get(3), Some(b'\n' | b'\r')) {
            return Some(FileFormat::Ply);
        }
        let text = String::from_utf8_lossy(&head[..head.len().min(4096)]);
        let first = text
            .lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && !l.starts_with('#'))?;
        let word = first.split_whitespace().next().unwrap_or("");
        if pcd::starts_like_pcd(word) {
            return Some(FileFormat::Pcd);
        }
        if word.ends_with("OFF") && word.len() <= 6 {
            return Some(FileFormat::Off);
        }
        const OBJ_KEYWORDS: [&str; 12] = [
            "v", "vt", "vn", "f", "o", "g", "s", "p", "l", "mtllib", "usemtl", "vp",
        ];
        if OBJ_KEYWORDS.contains(&word) {
            Some(FileFormat::Obj)
        } else {
            stl::starts_like_ascii(head).then_some(FileFormat::Stl)
        }
    }
}

/// How many bytes from a file's start [`FileFormat::sniff_start`] needs: a text line found
/// in the first 4096 bytes, and the word `solid` after it.
const SNIFFED_TEXT: usize = 4096 + 6;

/// A point set or a triangle mesh, as read from a file.
#[derive(Debug, Clone, PartialEq)]
pub enum Geometry {
    /// Points without faces.
    Points(PointSet),
    /// A triangle mesh.
    Mesh(TriMesh),
}

impl Geometry {
    /// The points (mesh vertices for a mesh).
    pub fn points(&self) -> &PointSet {
        match self {
            Geometry::Points(p) => p,
            Geometry::Mesh(m) => m.vertices(),
        }
    }

    /// The mesh, if this is one.
    pub fn mesh(&self) -> Option<&TriMesh> {
        match self {
            Geometry::Points(_) => None,
            Geometry::Mesh(m) => Some(m),
        }
    }

    /// Bounding box of the points.
    pub fn bounding_box(&self) -> Option<Aabb> {
        self.points().bounding_box()
    }
}

/// A file's geometry plus what the file said about itself.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedGeometry {
    /// The geometry.
    pub geometry: Geometry,
    /// The format read.
    pub format: FileFormat,
    /// Encoding, e.g. `ascii` or `binary_little_endian`.
    pub encoding: String,
    /// Comment lines found in the file.
    pub comments: Vec<String>,
    /// The file's coordinates are the stored positions plus this (zero unless read with
    /// [`ReadOptions::recentre_far`] from a file far from the origin).
    pub origin: DVec3,
    /// What the file had that the geometry could not keep, in words (empty when nothing
    /// was lost): a PLY file's other elements, vertex lists and face properties
    /// ([`ply::skipped_parts`]); an OFF file's per-face colours; a binary STL's nonzero
    /// facet attribute bytes; an OBJ file's texture coordinates or normals when its faces
    /// give them at some corners and not at others, or colours on some `v` lines only, since
    /// a mesh carries each at every vertex or not at all.
    pub notes: Vec<String>,
}

/// A position as text, `x y z`, as the text formats write it: the `f32` values as they
/// are (shortest form that reads back exactly) at a zero origin, else the sums with the
/// origin in double precision.
///
/// ```
/// use glam::{DVec3, Vec3};
/// use pointset_core::io::position_text;
/// assert_eq!(position_text(Vec3::new(0.1, 2.0, -3.5), DVec3::ZERO), "0.1 2 -3.5");
/// let far = DVec3::new(500_000.0, 4_000_000.0, 0.0);
/// assert_eq!(position_text(Vec3::new(0.25, -0.5, 1.0), far), "500000.25 3999999.5 1");
/// ```
pub fn position_text(p: Vec3, origin: DVec3) -> String {
    if origin == DVec3::ZERO {
        format!("{} {} {}", p.x, p.y, p.z)
    } else {
        let q = p.as_dvec3() + origin;
        format!("{} {} {}", q.x, q.y, q.z)
    }
}

/// Options for [`read_geometry_with`].
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub struct ReadOptions {
    /// Store positions relative to an origin when the data lies far from the file's
    /// origin: further than its own extent (largest side). The origin is the centre of
    /// the data's bounding box, rounded to whole units and computed in double precision
    /// from the file's values, so the stored `f32` positions keep the precision the file
    /// has. Default off: positions are the file's coordinates.
    pub recentre_far: bool,
}

impl ReadOptions {
    /// Sets [`Self::recentre_far`].
    pub fn recentre_far(mut self, recentre: bool) -> Self {
        self.recentre_far = recentre;
        self
    }
}

/// The origin data spanning the box `lo..hi` is stored relative to under
/// [`ReadOptions::recentre_far`]: the box's centre rounded to whole units when the box lies
/// further from the file's origin than its own extent (georeferenced data), else zero.
///
/// ```
/// use glam::DVec3;
/// use pointset_core::io::far_origin;
/// let near = far_origin(DVec3::ZERO, DVec3::splat(4.0));
/// let far = far_origin(DVec3::new(5e5, 4e6, 0.0), DVec3::new(5e5 + 8.0, 4e6 + 8.0, 2.0));
/// assert_eq!((near, far), (DVec3::ZERO, DVec3::new(500_004.0, 4_000_004.0, 1.0)));
/// ```
pub fn far_origin(lo: DVec3, hi: DVec3) -> DVec3 {
    let centre = 0.5 * (lo + hi);
    let far = centre.abs().max_element() > (hi - lo).max_element();
    if far && centre.is_finite() {
        centre.round()
    } else {
        DVec3::ZERO
    }
}

/// The origin the positions `raw` are stored relative to under
/// [`ReadOptions::recentre_far`] (zero when `recentre_far` is off or there are none).
pub(crate) fn origin_for(raw: impl Iterator<Item = DVec3>, recentre_far: bool) -> DVec3 {
    if !recentre_far {
        return DVec3::ZERO;
    }
    let (lo, hi) = raw.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
        (lo.min(p), hi.max(p))
    });
    if lo.cmple(hi).all() {
        far_origin(lo, hi)
    } else {
        DVec3::ZERO
    }
}

/// The origin positions are stored relative to (see [`ReadOptions::recentre_far`]), and
/// the positions relative to it in single precision.
pub(crate) fn relative_positions(raw: &[DVec3], recentre_far: bool) -> (Vec<Vec3>, DVec3) {
    let origin = origin_for(raw.iter().copied(), recentre_far);
    let relative = raw.iter().map(|&p| (p - origin).as_vec3()).collect();
    (relative, origin)
}

/// `values` with those that are not finite (NaN or infinite) replaced by 0, and how many
/// were replaced: what the readers keep of a file's odd values (and say in a note).
pub(crate) fn finite_or_zero(values: impl IntoIterator<Item = f32>) -> (Vec<f32>, usize) {
    let mut replaced = 0;
    let kept = values
        .into_iter()
        .map(|v| {
            if v.is_finite() {
                v
            } else {
                replaced += 1;
                0.0
            }
        })
        .collect();
    (kept, replaced)
}

/// Colours as a text file gives them, in `0..=1`: integers in `0..=255` when any value
/// exceeds 1, floats in `0..=1` otherwise (decided per file, as OFF and XYZ readers do).
pub(crate) fn unit_colours(raw: &[[f64; 3]]) -> Vec<[f32; 3]> {
    let scale = if raw.iter().flatten().any(|&c| c > 1.0) {
        255.0
    } else {
        1.0
    };
    raw.iter().map(|c| c.map(|x| (x / scale) as f32)).collect()
}

/// Options for [`write_geometry`].
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub struct WriteOptions {
    /// PLY encoding (default binary little-endian); ignored by the other formats.
    pub ply_encoding: PlyEncoding,
    /// STL encoding (default binary); ignored by the other formats (OBJ and OFF are text).
    pub stl_encoding: StlEncoding,
    /// PCD encoding (default binary); ignored by the other formats.
    pub pcd_encoding: PcdEncoding,
    /// Comment lines to write (default none; STL has no place for them).
    pub comments: Vec<String>,
    /// Added to every position as it is written, in double precision (default zero): the
    /// [`LoadedGeometry::origin`] of data read with [`ReadOptions::recentre_far`]. PLY
    /// coordinates are written as `double` when it is not zero.
    pub origin: DVec3,
}

impl WriteOptions {
    /// Sets the PLY encoding (default [`PlyEncoding::BinaryLittleEndian`]).
    pub fn ply_encoding(mut self, encoding: PlyEncoding) -> Self {
        self.ply_encoding = encoding;
        self
    }

    /// Sets the STL encoding (default [`StlEncoding::Binary`]).
    pub fn stl_encoding(mut self, encoding: StlEncoding) -> Self {
        self.stl_encoding = encoding;
        self
    }

    /// Sets the PCD encoding (default [`PcdEncoding::Binary`]).
    pub fn pcd_encoding(mut self, encoding: PcdEncoding) -> Self {
        self.pcd_encoding = encoding;
        self
    }

    /// Adds a comment line (default none).
    pub fn comment(mut self, comment: impl Into<String>) -> Self {
        self.comments.push(comment.into());
        self
    }

    /// Sets [`Self::origin`] (default zero).
    pub fn origin(mut self, origin: DVec3) -> Self {
        self.origin = origin;
        self
    }
}

/// Determines a file's format from its extension, checked against its content.
pub fn detect_format(path: &Path, bytes: &[u8]) -> Result<FileFormat> {
    format_of(path, FileFormat::sniff(bytes))
}

/// The format of `path`, from its extension checked against what its content was sniffed
/// as.
fn format_of(path: &Path, sniffed: Option<FileFormat>) -> Result<FileFormat> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    // A `.laz` is a LAS whose points are compressed: read as LAS, it is refused as such.
    let named = FileFormat::from_extension(ext)
        .or_else(|| ext.eq_ignore_ascii_case("laz").then_some(FileFormat::Las));
    match (named, sniffed) {
        (Some(by_ext), Some(by_content)) if by_ext != by_content => Err(Error::FormatMismatch {
            path: path.to_path_buf(),
            extension: ext.to_string(),
            sniffed: by_content,
        }),
        (Some(by_ext), _) => Ok(by_ext),
        (None, Some(by_content)) => Ok(by_content),
        (None, None) => Err(Error::UnknownFormat {
            path: path.to_path_buf(),
            reason: format!(
                "no {GEOMETRY_EXTENSIONS} extension, and the content looks like none of PLY, OBJ, \
                 OFF, STL, LAS, PCD and glTF (XYZ is told by its extension only)"
            ),
        }),
    }
}

/// Reads a PLY, OBJ, OFF, STL, XYZ, LAS or PCD file.
pub fn read_geometry(path: impl AsRef<Path>) -> Result<LoadedGeometry> {
    read_geometry_with(path, &ReadOptions::default())
}

/// [`read_geometry`] with options (e.g. recentring georeferenced data).
///
/// Files are read through a buffer into the geometry's arrays (pipes and other files that
/// are not regular are read whole into memory first). Either way the result is what
/// [`read_geometry_bytes_with`] gives for the file's bytes.
///
/// ```
/// use pointset_core::io::{self, ReadOptions};
/// // Two points a metre apart, 4,000 km north: an f32 steps by 0.25 there.
/// let ply = "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\n\
///            property double y\nproperty double z\nend_header\n\
///            500000.125 4000000.125 0\n500001.125 4000000.125 0\n";
/// let path = std::env::temp_dir().join("pointset_core_doc_far.ply");
/// std::fs::write(&path, ply)?;
/// let loaded = io::read_geometry_with(&path, &ReadOptions::default().recentre_far(true))?;
/// assert_eq!(loaded.origin, glam::DVec3::new(500001.0, 4000000.0, 0.0));
/// let p = loaded.geometry.points().positions();
/// assert_eq!((p[0].x, p[0].y, p[1].x), (-0.875, 0.125, 0.125));
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_geometry_with(path: impl AsRef<Path>, options: &ReadOptions) -> Result<LoadedGeometry> {
    read_geometry_in(path, options, &mut RunContext::default())
}

/// [`read_geometry_with`] within a run: progress goes to `ctx` as bytes read out of the
/// file's length (stage `"reading"`), and a cancelled run stops the read with
/// [`Error::Cancelled`] (checked every megabyte or so).
///
/// ```
/// use pointset_core::io::{self, ReadOptions};
/// use pointset_core::{CancelFlag, Error, ProgressUpdate, RunContext};
/// let path = std::env::temp_dir().join("pointset_core_doc_progress.xyz");
/// std::fs::write(&path, "0 0 0\n1 0 0\n0 1 0\n")?;
/// let (sender, reports) = std::sync::mpsc::channel();
/// let mut ctx = RunContext::new(0)
///     .with_progress(move |u: &ProgressUpdate<'_>| drop(sender.send((u.done, u.total))));
/// let loaded = io::read_geometry_in(&path, &ReadOptions::default(), &mut ctx)?;
/// assert_eq!(loaded.geometry.points().len(), 3);
/// assert_eq!(reports.try_iter().last(), Some((18, Some(18))));
/// // A cancelled run reads nothing.
/// let cancel = CancelFlag::new();
/// cancel.cancel();
/// let mut ctx = RunContext::new(0).with_cancel_flag(cancel);
/// let result = io::read_geometry_in(&path, &ReadOptions::default(), &mut ctx);
/// assert!(matches!(result, Err(Error::Cancelled)));
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_geometry_in(
    path: impl AsRef<Path>,
    options: &ReadOptions,
    ctx: &mut RunContext,
) -> Result<LoadedGeometry> {
    let path = path.as_ref();
    let at_path = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = File::open(path).map_err(at_path)?;
    let metadata = file.metadata().map_err(at_path)?;
    let (len, regular) = (metadata.len(), metadata.is_file());
    // A pipe's length is not known ahead.
    let mut file = ReportingReader::new(file, regular.then_some(len), ctx);
    let mut bytes = Vec::new();
    (&mut file)
        .take(SNIFFED_BYTES)
        .read_to_end(&mut bytes)
        .map_err(|source| cancelled_read(Error::Read { source }))
        .map_err(|error| read_error_at(error, path))?;
    let result = if regular && let Some((format, start)) = format_of_file(path, &bytes, len)? {
        file.seek(SeekFrom::Start(start)).map_err(at_path)?;
        let head = bytes.get(start as usize..).unwrap_or(&[]);
        read_as(
            format,
            file,
            (head, path),
            len - start,
            options.recentre_far,
        )
    } else {
        match file.read_to_end(&mut bytes) {
            Ok(_) => read_geometry_bytes_with(path, &bytes, options),
            Err(source) => Err(Error::Read { source }),
        }
    };
    result.map_err(|error| read_error_at(cancelled_read(error), path))
}

/// A read error as [`Error::Io`] naming `path`; other errors as they are.
fn read_error_at(error: Error, path: &Path) -> Error {
    match error {
        Error::Read { source } => Error::Io {
            path: path.to_path_buf(),
            source,
        },
        other => other,
    }
}

/// Bytes read from the start of a file to tell its format before reading the rest: what
/// sniffing needs, after a byte-order mark.
const SNIFFED_BYTES: u64 = (BYTE_ORDER_MARK.len() + SNIFFED_TEXT) as u64;

/// The format of a regular file of `len` bytes starting with `head`, and where its content
/// begins (after a byte-order mark, if any), as [`read_geometry_bytes_with`] would find
/// them from the whole file; `None` for an empty file, or one whose length is not that of
/// its bytes (as in `/proc`), which are read whole. A name and content that disagree are
/// refused as the whole file would be.
fn format_of_file(path: &Path, head: &[u8], len: u64) -> Result<Option<(FileFormat, u64)>> {
    if len == 0 || len < head.len() as u64 {
        return Ok(None);
    }
    let skip =
        if head.starts_with(BYTE_ORDER_MARK) && stl::binary_facet_count_of(head, len).is_none() {
            BYTE_ORDER_MARK.len()
        } else {
            0
        };
    let format = format_of(
        path,
        FileFormat::sniff_start(&head[skip..], len - skip as u64),
    )?;
    Ok(Some((format, skip as u64)))
}

/// Reads `len` bytes of `format` from `reader`, which starts at their first byte; `head`
/// holds their first bytes (all of them, or at least [`SNIFFED_TEXT`]). Every format but
/// glTF is read as it streams in; glTF's external buffers are looked for beside `path`.
fn read_as<R: Read + Seek>(
    format: FileFormat,
    reader: R,
    (head, path): (&[u8], &Path),
    len: u64,
    recentre: bool,
) -> Result<LoadedGeometry> {
    match format {
        FileFormat::Ply => ply::read_ply_geometry_from(reader, len, recentre).map(loaded_ply),
        FileFormat::Obj => read_obj_from(reader, len, recentre).map(loaded_obj),
        FileFormat::Off => off::read_off_from(reader, len, recentre).map(loaded_off),
        FileFormat::Xyz(columns) => {
            xyz::read_xyz_from(reader, len, columns, recentre).map(|file| loaded_xyz(file, columns))
        }
        FileFormat::Las => las::read_las_from(reader, head, len, recentre).map(loaded_las),
        FileFormat::Pcd => pcd::read_pcd_from(reader, len, recentre).map(loaded_pcd),
        FileFormat::Gltf(_) => {
            gltf::read_gltf_from(reader, len, recentre, path.parent()).map(loaded_gltf)
        }
        FileFormat::Stl => stl::read_stl_from(reader, head, len, recentre).map(loaded_stl),
    }
}

/// Reads geometry held in memory; `path` names it in errors and picks the format.
pub fn read_geometry_bytes(path: &Path, bytes: &[u8]) -> Result<LoadedGeometry> {
    read_geometry_bytes_with(path, bytes, &ReadOptions::default())
}

/// [`read_geometry_bytes`] with options.
pub fn read_geometry_bytes_with(
    path: &Path,
    bytes: &[u8],
    options: &ReadOptions,
) -> Result<LoadedGeometry> {
    if bytes.is_empty() {
        return Err(Error::EmptyFile {
            path: path.to_path_buf(),
        });
    }
    let bytes = without_byte_order_mark(bytes);
    let format = detect_format(path, bytes)?;
    let len = bytes.len() as u64;
    read_as(
        format,
        Cursor::new(bytes),
        (bytes, path),
        len,
        options.recentre_far,
    )
}

/// A PLY file's geometry as [`LoadedGeometry`].
fn loaded_ply(read: ply::PlyGeometry) -> LoadedGeometry {
    LoadedGeometry {
        geometry: read.geometry,
        format: FileFormat::Ply,
        encoding: read.encoding.keyword().to_string(),
        notes: read.notes,
        comments: read.comments,
        origin: read.origin,
    }
}

/// An STL file's mesh as [`LoadedGeometry`].
fn loaded_stl(file: stl::StlFile) -> LoadedGeometry {
    LoadedGeometry {
        geometry: file.geometry,
        format: FileFormat::Stl,
        encoding: file.encoding.into(),
        comments: file.comments,
        origin: file.origin,
        notes: file.notes,
    }
}

/// An OBJ file's geometry, origin and notes as [`LoadedGeometry`].
fn loaded_obj((geometry, origin, notes): (Geometry, DVec3, Vec<String>)) -> LoadedGeometry {
    LoadedGeometry {
        geometry,
        format: FileFormat::Obj,
        encoding: "ascii".into(),
        comments: Vec::new(),
        origin,
        notes,
    }
}

/// An OFF file's geometry as [`LoadedGeometry`].
fn loaded_off(file: off::OffFile) -> LoadedGeometry {
    LoadedGeometry {
        geometry: file.geometry,
        format: FileFormat::Off,
        encoding: "ascii".into(),
        comments: file.comments,
        origin: file.origin,
        notes: file.notes,
    }
}

/// An XYZ file's points as [`LoadedGeometry`].
fn loaded_xyz(file: xyz::XyzFile, columns: XyzColumns) -> LoadedGeometry {
    LoadedGeometry {
        geometry: file.geometry,
        format: FileFormat::Xyz(columns),
        encoding: "ascii".into(),
        comments: file.comments,
        origin: file.origin,
        notes: Vec::new(),
    }
}

/// A LAS file's points as [`LoadedGeometry`].
fn loaded_las(file: las::LasFile) -> LoadedGeometry {
    LoadedGeometry {
        geometry: file.geometry,
        format: FileFormat::Las,
        encoding: file.encoding,
        comments: file.comments,
        origin: file.origin,
        notes: file.notes,
    }
}

/// A PCD file's points as [`LoadedGeometry`].
fn loaded_pcd(file: pcd::PcdFile) -> LoadedGeometry {
    LoadedGeometry {
        geometry: file.geometry,
        format: FileFormat::Pcd,
        encoding: file.encoding,
        comments: file.comments,
        origin: file.origin,
        notes: file.notes,
    }
}

/// A glTF file's geometry as [`LoadedGeometry`].
fn loaded_gltf(file: gltf::GltfFile) -> LoadedGeometry {
    LoadedGeometry {
        geometry: file.geometry,
        format: FileFormat::Gltf(file.container),
        encoding: match file.container {
            GltfContainer::Binary => "binary",
            GltfContainer::Json => "JSON",
        }
        .into(),
        comments: file.comments,
        origin: file.origin,
        notes: file.notes,
    }
}

/// UTF-8's byte-order mark, which some Windows tools put before text.
const BYTE_ORDER_MARK: &[u8] = b"\xEF\xBB\xBF";

/// `bytes` without a leading UTF-8 byte-order mark, unless they are a binary STL of the
/// right size (whose 80-byte header may hold anything). Byte offsets in errors then count
/// from after the mark; line numbers are unchanged.
fn without_byte_order_mark(bytes: &[u8]) -> &[u8] {
    match bytes.strip_prefix(BYTE_ORDER_MARK) {
        Some(text) if stl::binary_facet_count(bytes).is_none() => text,
        _ => bytes,
    }
}

/// The PLY file `options` ask for, viewed in the geometry's own arrays.
fn ply_view<'a>(
    geometry: &'a Geometry,
    options: &'a WriteOptions,
) -> Result<ply::DocumentView<'a>> {
    ply::DocumentView::of_geometry(
        geometry,
        options.ply_encoding,
        &options.comments,
        options.origin,
    )
}

/// Encodes geometry in `format` into a byte vector.
pub fn encode_geometry(
    geometry: &Geometry,
    format: FileFormat,
    options: &WriteOptions,
) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    write_encoded(geometry, format, options, &mut out)?;
    Ok(out)
}

/// Writes geometry in `format` to `out`. PLY is written straight from the geometry's
/// arrays: no document of the values is built (in `f64`, it would hold 32 bytes a
/// triangle and 24–48 a vertex).
fn write_encoded(
    geometry: &Geometry,
    format: FileFormat,
    options: &WriteOptions,
    out: &mut impl std::io::Write,
) -> Result<()> {
    match format {
        FileFormat::Ply => ply::write_view(&ply_view(geometry, options)?, out),
        FileFormat::Obj => write_obj_at(geometry, &options.comments, options.origin, out),
        FileFormat::Off => write_off_at(geometry, &options.comments, options.origin, out),
        FileFormat::Stl => write_stl_at(geometry, options.stl_encoding, options.origin, out),
        FileFormat::Xyz(columns) => {
            write_xyz_at(geometry, columns, &options.comments, options.origin, out)
        }
        FileFormat::Las => write_las_at(geometry, options.origin, out),
        FileFormat::Pcd => write_pcd_at(
            geometry,
            options.pcd_encoding,
            &options.comments,
            options.origin,
            out,
        ),
        FileFormat::Gltf(container) => {
            write_gltf_at(geometry, container, &options.comments, options.origin, out)
        }
    }
}

/// Writes geometry to `path` in the format its extension names. The file holds exactly
/// what [`encode_geometry`] gives, streamed to it without holding the encoded file (136 MB
/// for a PLY mesh of 7.2 million triangles). It is written whole or not at all
/// ([`FileReplacement`]): after any error, `path` keeps what it held.
pub fn write_geometry(
    path: impl AsRef<Path>,
    geometry: &Geometry,
    options: &WriteOptions,
) -> Result<()> {
    let path = path.as_ref();
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    let format = FileFormat::from_extension(ext).ok_or_else(|| Error::UnknownFormat {
        path: path.to_path_buf(),
        reason: format!("the output extension must be {GEOMETRY_EXTENSIONS}"),
    })?;
    let at_path = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    replace_file(
        path,
        |out| {
            write_encoded(geometry, format, options, out).map_err(|error| match error {
                Error::Write { source } => at_path(source),
                other => other,
            })
        },
        at_path,
    )
}
