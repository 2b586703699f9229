//! Reading and writing point sets and meshes: PLY, OBJ and OFF.
//!
//! [`read_geometry`] picks the format from the file extension and checks it against the
//! content (a `.ply` that does not start with `ply` is an error, not a guess); files without
//! a known extension are identified by content alone. Every reader returns typed errors with
//! a line number or byte offset, and checks declared counts against the bytes present before
//! allocating.

mod obj;
mod off;
pub mod ply;

use std::fmt;
use std::path::Path;

pub use obj::{read_obj, write_obj};
pub use off::{read_off, write_off};

use crate::{Aabb, Error, PointSet, Result, TriMesh};
use ply::PlyEncoding;

/// The supported file formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FileFormat {
    /// Stanford PLY.
    Ply,
    /// Wavefront OBJ.
    Obj,
    /// Object File Format.
    Off,
}

impl fmt::Display for FileFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FileFormat::Ply => "PLY",
            FileFormat::Obj => "OBJ",
            FileFormat::Off => "OFF",
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
            _ => None,
        }
    }

    /// The format the first bytes of a file look like, if any.
    pub fn sniff(bytes: &[u8]) -> Option<Self> {
        let head = &bytes[..bytes.len().min(4096)];
        let text = String::from_utf8_lossy(head);
        let first = text
            .lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && !l.starts_with('#'))?;
        if text.starts_with("ply") && matches!(text.as_bytes().get(3), Some(b'\n' | b'\r')) {
            return Some(FileFormat::Ply);
        }
        let word = first.split_whitespace().next().unwrap_or("");
        if word.ends_with("OFF") && word.len() <= 6 {
            return Some(FileFormat::Off);
        }
        const OBJ_KEYWORDS: [&str; 12] = [
            "v", "vt", "vn", "f", "o", "g", "s", "p", "l", "mtllib", "usemtl", "vp",
        ];
        OBJ_KEYWORDS.contains(&word).then_some(FileFormat::Obj)
    }
}

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
}

/// Options for [`write_geometry`].
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub struct WriteOptions {
    /// PLY encoding (default binary little-endian); ignored by OBJ and OFF, which are text.
    pub ply_encoding: PlyEncoding,
    /// Comment lines to write (default none).
    pub comments: Vec<String>,
}

impl WriteOptions {
    /// Sets the PLY encoding (default [`PlyEncoding::BinaryLittleEndian`]).
    pub fn ply_encoding(mut self, encoding: PlyEncoding) -> Self {
        self.ply_encoding = encoding;
        self
    }

    /// Adds a comment line (default none).
    pub fn comment(mut self, comment: impl Into<String>) -> Self {
        self.comments.push(comment.into());
        self
    }
}

/// Determines a file's format from its extension, checked against its content.
pub fn detect_format(path: &Path, bytes: &[u8]) -> Result<FileFormat> {
    let sniffed = FileFormat::sniff(bytes);
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    match (FileFormat::from_extension(ext), sniffed) {
        (Some(by_ext), Some(by_content)) if by_ext != by_content => Err(Error::FormatMismatch {
            path: path.to_path_buf(),
            extension: ext.to_string(),
            sniffed: by_content,
        }),
        (Some(by_ext), _) => Ok(by_ext),
        (None, Some(by_content)) => Ok(by_content),
        (None, None) => Err(Error::UnknownFormat {
            path: path.to_path_buf(),
            reason: "no .ply/.obj/.off extension and the content matches none of them".into(),
        }),
    }
}

/// Reads a PLY, OBJ or OFF file.
pub fn read_geometry(path: impl AsRef<Path>) -> Result<LoadedGeometry> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    read_geometry_bytes(path, &bytes)
}

/// Reads geometry held in memory; `path` names it in errors and picks the format.
pub fn read_geometry_bytes(path: &Path, bytes: &[u8]) -> Result<LoadedGeometry> {
    if bytes.is_empty() {
        return Err(Error::EmptyFile {
            path: path.to_path_buf(),
        });
    }
    match detect_format(path, bytes)? {
        FileFormat::Ply => {
            let doc = ply::read_ply(bytes)?;
            Ok(LoadedGeometry {
                geometry: ply::geometry_from_document(&doc)?,
                format: FileFormat::Ply,
                encoding: doc.encoding.keyword().to_string(),
                comments: doc.comments,
            })
        }
        FileFormat::Obj => Ok(LoadedGeometry {
            geometry: read_obj(path, bytes)?,
            format: FileFormat::Obj,
            encoding: "ascii".into(),
            comments: Vec::new(),
        }),
        FileFormat::Off => {
            let (geometry, comments) = read_off(bytes)?;
            Ok(LoadedGeometry {
                geometry,
                format: FileFormat::Off,
                encoding: "ascii".into(),
                comments,
            })
        }
    }
}

/// Encodes geometry in `format` into a byte vector.
pub fn encode_geometry(
    geometry: &Geometry,
    format: FileFormat,
    options: &WriteOptions,
) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    match format {
        FileFormat::Ply => {
            let doc =
                ply::document_from_geometry(geometry, options.ply_encoding, &options.comments)?;
            ply::write_ply(&doc, &mut out)?;
        }
        FileFormat::Obj => write_obj(geometry, &options.comments, &mut out)?,
        FileFormat::Off => write_off(geometry, &options.comments, &mut out)?,
    }
    Ok(out)
}

/// Writes geometry to `path` in the format its extension names.
pub fn write_geometry(
    path: impl AsRef<Path>,
    geometry: &Geometry,
    options: &WriteOptions,
) -> Result<()> {
    let path = path.as_ref();
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    let format = FileFormat::from_extension(ext).ok_or_else(|| Error::UnknownFormat {
        path: path.to_path_buf(),
        reason: "the output extension must be .ply, .obj or .off".into(),
    })?;
    let bytes = encode_geometry(geometry, format, options)?;
    std::fs::write(path, bytes).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}
