//! PLY (Stanford polygon file format): an in-house codec for `ascii`,
//! `binary_little_endian` and `binary_big_endian`.
//!
//! [`PlyDocument`] is the faithful file model: every element (known or not), every scalar and
//! list property with its declared type, comments and `obj_info` lines. [`read_ply`] checks
//! the header's record counts against the bytes actually present before allocating anything,
//! and reports problems with a line number (header, ascii body) or byte offset (binary body).
//! Conversions to and from [`crate::PointSet`] / [`crate::TriMesh`] live in `convert`.
//! [`crate::io::read_geometry`] and [`crate::io::write_geometry`] go without a document:
//! bodies are read straight into the geometry's arrays and written from them (`to_geometry`,
//! `view`), by the same rules. `read_geometry` reads a PLY file through a 1 MiB buffer
//! (`io::stream`, shared with the other readers), not from a copy of the whole file, so a
//! 24-million-triangle mesh converts in 0.45 GB instead of 2.2 GB (docs/performance.md).

mod body;
mod convert;
mod header;
mod to_geometry;
mod view;
mod write;

pub use convert::{
    document_from_geometry, document_from_geometry_at, geometry_from_document,
    geometry_from_document_at, skipped_parts,
};
pub(crate) use view::DocumentView;
pub use write::write_ply;
pub(crate) use write::write_view;

use std::io::Read;

use glam::DVec3;

use super::stream::ByteStream;
use crate::io::Geometry;
use crate::{Result, ScalarType};

/// The three PLY encodings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum PlyEncoding {
    /// Human-readable text.
    Ascii,
    /// Binary, little-endian (the default: compact and what most tools write).
    #[default]
    BinaryLittleEndian,
    /// Binary, big-endian.
    BinaryBigEndian,
}

impl PlyEncoding {
    /// The header keyword (`ascii`, `binary_little_endian`, `binary_big_endian`).
    pub fn keyword(self) -> &'static str {
        match self {
            PlyEncoding::Ascii => "ascii",
            PlyEncoding::BinaryLittleEndian => "binary_little_endian",
            PlyEncoding::BinaryBigEndian => "binary_big_endian",
        }
    }

    /// All encodings.
    pub const ALL: [PlyEncoding; 3] = [
        PlyEncoding::Ascii,
        PlyEncoding::BinaryLittleEndian,
        PlyEncoding::BinaryBigEndian,
    ];
}

/// A property's declared type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PropertyKind {
    /// One scalar per record.
    Scalar(ScalarType),
    /// A variable-length list: the length's type and the items' type.
    List {
        /// Type of the length prefix.
        count: ScalarType,
        /// Type of each item.
        item: ScalarType,
    },
}

/// A declared property of an element.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlyProperty {
    /// Property name.
    pub name: String,
    /// Declared type.
    pub kind: PropertyKind,
}

/// The values of one property for every record of an element.
#[derive(Debug, Clone, PartialEq)]
pub enum PlyColumn {
    /// One value per record.
    Scalar(Vec<f64>),
    /// Lists: record `r` owns `items[offsets[r]..offsets[r + 1]]`.
    List {
        /// `count + 1` offsets into `items`.
        offsets: Vec<usize>,
        /// All list items, concatenated.
        items: Vec<f64>,
    },
}

impl PlyColumn {
    /// An empty column of the right shape for `kind`.
    pub fn empty(kind: PropertyKind) -> Self {
        match kind {
            PropertyKind::Scalar(_) => PlyColumn::Scalar(Vec::new()),
            PropertyKind::List { .. } => PlyColumn::List {
                offsets: vec![0],
                items: Vec::new(),
            },
        }
    }

    /// Number of records held.
    pub fn len(&self) -> usize {
        match self {
            PlyColumn::Scalar(v) => v.len(),
            PlyColumn::List { offsets, .. } => offsets.len().saturating_sub(1),
        }
    }

    /// Whether no records are held.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// One element (e.g. `vertex`, `face`) with its properties and data.
#[derive(Debug, Clone, PartialEq)]
pub struct PlyElement {
    /// Element name.
    pub name: String,
    /// Number of records.
    pub count: usize,
    /// Declared properties, in file order.
    pub properties: Vec<PlyProperty>,
    /// One column per property, each with `count` records.
    pub columns: Vec<PlyColumn>,
}

impl PlyElement {
    /// The column of a property by name, with its kind.
    pub fn column(&self, name: &str) -> Option<(&PlyProperty, &PlyColumn)> {
        let at = self.properties.iter().position(|p| p.name == name)?;
        Some((&self.properties[at], self.columns.get(at)?))
    }

    /// A scalar column's values by property name.
    pub fn scalar(&self, name: &str) -> Option<&[f64]> {
        match self.column(name)? {
            (_, PlyColumn::Scalar(v)) => Some(v),
            _ => None,
        }
    }
}

/// A whole PLY file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlyDocument {
    /// Encoding of the body.
    pub encoding: PlyEncoding,
    /// `comment` lines (without the keyword).
    pub comments: Vec<String>,
    /// `obj_info` lines (without the keyword).
    pub obj_info: Vec<String>,
    /// Elements in file order.
    pub elements: Vec<PlyElement>,
}

impl PlyDocument {
    /// An element by name.
    pub fn element(&self, name: &str) -> Option<&PlyElement> {
        self.elements.iter().find(|e| e.name == name)
    }
}

/// Parses a whole PLY file held in memory.
pub fn read_ply(bytes: &[u8]) -> Result<PlyDocument> {
    let mut stream = ByteStream::of_bytes(bytes);
    let parsed = header::parse_header(&mut stream)?;
    document_after_header(parsed, &mut stream)
}

/// The document of a header already read and the body that follows it in `stream`.
fn document_after_header<R: Read>(
    parsed: header::ParsedHeader,
    stream: &mut ByteStream<R>,
) -> Result<PlyDocument> {
    let elements = body::read_body(&parsed, stream)?;
    Ok(PlyDocument {
        encoding: parsed.encoding,
        comments: parsed.comments,
        obj_info: parsed.obj_info,
        elements,
    })
}

/// Checks that an element has a column per property (`lengths`: each column's number of
/// records) and that each holds `count` records.
fn check_column_lengths(
    element: &str,
    count: usize,
    properties: &[PlyProperty],
    lengths: impl ExactSizeIterator<Item = usize>,
) -> Result<()> {
    if lengths.len() != properties.len() {
        return Err(crate::Error::LengthMismatch {
            what: format!("PLY columns of `{element}`"),
            expected: properties.len(),
            found: lengths.len(),
        });
    }
    for (property, found) in properties.iter().zip(lengths) {
        if found != count {
            return Err(crate::Error::LengthMismatch {
                what: format!("PLY column `{}` of `{element}`", property.name),
                expected: count,
                found,
            });
        }
    }
    Ok(())
}

/// Checks that each record of a list column owns a range of its items: offsets that do
/// not decrease and stay within the items held.
fn check_list_offsets(element: &str, property: &PlyProperty, column: &PlyColumn) -> Result<()> {
    let PlyColumn::List { offsets, items } = column else {
        return Ok(());
    };
    let bad = offsets
        .windows(2)
        .position(|w| w[0] > w[1] || w[1] > items.len());
    match bad {
        None => Ok(()),
        Some(record) => Err(crate::Error::ListOutOfRange {
            element: element.to_string(),
            property: property.name.clone(),
            record,
            start: offsets[record],
            end: offsets[record + 1],
            items: items.len(),
        }),
    }
}

/// A PLY file read straight into geometry.
#[derive(Debug)]
pub(crate) struct PlyGeometry {
    /// The point set or mesh.
    pub(crate) geometry: Geometry,
    /// What its positions are relative to.
    pub(crate) origin: DVec3,
    /// The body's encoding.
    pub(crate) encoding: PlyEncoding,
    /// `comment` lines.
    pub(crate) comments: Vec<String>,
    /// What the geometry leaves out ([`skipped_parts`]).
    pub(crate) notes: Vec<String>,
}

/// Reads a PLY file of `len` bytes from `reader` into a point set or mesh, as [`read_ply`]
/// and [`geometry_from_document_at`] do together, without holding a document or the file:
/// the values go from the body into the geometry's arrays. A file whose `face` element
/// comes before its `vertex` element is read through a document. Failed reads are
/// [`crate::Error::Read`].
pub(crate) fn read_ply_geometry_from(
    reader: impl Read,
    len: u64,
    recentre_far: bool,
) -> Result<PlyGeometry> {
    let mut stream = ByteStream::new(reader, len);
    let parsed = header::parse_header(&mut stream)?;
    let position = |name: &str| parsed.elements.iter().position(|e| e.name == name);
    if let (Some(vertex), Some(face)) = (position("vertex"), position("face"))
        && face < vertex
    {
        let doc = document_after_header(parsed, &mut stream)?;
        let (geometry, origin) = geometry_from_document_at(&doc, recentre_far)?;
        return Ok(PlyGeometry {
            geometry,
            origin,
            encoding: doc.encoding,
            notes: skipped_parts(&doc),
            comments: doc.comments,
        });
    }
    let declared: Vec<to_geometry::Declared<'_>> = parsed
        .elements
        .iter()
        .map(|e| to_geometry::Declared {
            name: &e.name,
            count: e.count,
            properties: &e.properties,
        })
        .collect();
    let mut sink = to_geometry::GeometrySink::new(&declared, recentre_far);
    body::read_body_into(&parsed, &mut stream, &mut sink)?;
    let (geometry, origin) = sink.finish()?;
    Ok(PlyGeometry {
        geometry,
        origin,
        encoding: parsed.encoding,
        notes: convert::skipped_parts_of(&declared),
        comments: parsed.comments,
    })
}
