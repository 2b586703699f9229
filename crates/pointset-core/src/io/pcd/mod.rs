//! PCD point clouds, the Point Cloud Library's format (also read and written by Open3D
//! and ROS tools): version 0.7 files, and older ones without `COUNT`, `VIEWPOINT` or
//! `POINTS`, with their data `ascii`, `binary` or `binary_compressed` (LZF, as PCL
//! writes it); binary values are little-endian.
//!
//! Fields are read by their PCL names:
//! - `x`, `y`, `z`: the positions (required), in double precision when stored as `F 8`;
//! - `normal_x`, `normal_y`, `normal_z` (or `nx`, `ny`, `nz`): the normals, when all
//!   three are there;
//! - `rgb` or `rgba`: colours packed in 4 bytes as `0xAARRGGBB` (stored as a float, as
//!   PCL's `PointXYZRGB` does, or as an unsigned integer), kept as `red`, `green`,
//!   `blue` (and `alpha` for `rgba`). In ASCII files a float colour may be written as
//!   the float (Open3D) or as the packed integer (PCL, since a colour with alpha 255 is a
//!   NaN as a float): a run of digits is read as the integer;
//! - every other field of one value a point (`intensity`, `label`, `curvature`, …): an
//!   attribute of that name, stored as its type (64-bit integers as `double`).
//!
//! What the point set cannot keep is said in [`super::LoadedGeometry::notes`]: fields of
//! several values a point (descriptors such as FPFH histograms), and a second or partial
//! set of normal fields, are skipped; an organised cloud (`HEIGHT` above 1) is kept as a
//! list of points; the points an organised cloud marks invalid (a NaN or infinite
//! coordinate) are left out; normals that are not finite (PCL gives them to points with
//! too few neighbours) become zero (no known direction) and other values that are not
//! finite become 0; a `VIEWPOINT` other than the identity is not applied (positions are
//! as stored, as PCL and Open3D read them). Padding fields (`_`) are skipped without a
//! note.
//!
//! Refused with a typed error: a header whose `SIZE`, `TYPE` or `COUNT` lists do not match
//! its fields, unknown types or sizes, a field named twice, `WIDTH × HEIGHT` other than
//! `POINTS`, a file without `x`, `y` and `z`, a point count the file's bytes cannot hold
//! (checked before anything is allocated; for compressed data, the declared size against
//! what the compressed bytes can expand to), damaged compressed data, and ASCII lines
//! with the wrong number of values.
//!
//! Writing ([`write_pcd`]): `x y z` as `F 4` (as `F 8`, the file's coordinates, when
//! written with a nonzero [`super::WriteOptions::origin`]), `normal_x normal_y normal_z`
//! when the points have normals, `rgb` as `U 4` (alpha 255) when they have colours, then
//! every other attribute in its storage type, as a list (`HEIGHT 1`) with the identity
//! viewpoint, in the encoding asked for ([`PcdEncoding`], binary by default). A mesh is
//! refused (its faces would be lost).

mod body;
mod header;
mod lzf;
mod write;

use std::io::Read;

use glam::{DVec3, Vec3};

use super::stream::ByteStream;
use super::{FileFormat, Geometry, finite_or_zero, relative_positions};
use crate::{Attribute, Error, Location, PointSet, RESERVED_NAMES, Result, ScalarType};
use header::{Field, FieldType, Header, IDENTITY_VIEWPOINT};

pub use write::write_pcd;
pub(crate) use write::write_pcd_at;

/// How a PCD file's points are stored (its `DATA` line).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[non_exhaustive]
pub enum PcdEncoding {
    /// Records of little-endian values, a point after another (the default).
    #[default]
    Binary,
    /// A line of text a point.
    Ascii,
    /// Each field's values for every point, one field after another, compressed with LZF.
    BinaryCompressed,
}

impl PcdEncoding {
    /// The `DATA` keyword.
    pub fn keyword(self) -> &'static str {
        match self {
            PcdEncoding::Binary => "binary",
            PcdEncoding::Ascii => "ascii",
            PcdEncoding::BinaryCompressed => "binary_compressed",
        }
    }

    /// The encoding a `DATA` keyword names (case-insensitive).
    pub fn from_keyword(word: &str) -> Option<Self> {
        match word.to_ascii_lowercase().as_str() {
            "binary" => Some(PcdEncoding::Binary),
            "ascii" => Some(PcdEncoding::Ascii),
            "binary_compressed" => Some(PcdEncoding::BinaryCompressed),
            _ => None,
        }
    }
}

/// A malformed-header error at `line`.
fn malformed_at_line(line: usize, message: impl Into<String>) -> Error {
    Error::Malformed {
        format: FileFormat::Pcd,
        location: Location::Line(line),
        message: message.into(),
    }
}

/// A malformed-data error at byte `at`.
fn malformed_at_byte(at: u64, message: impl Into<String>) -> Error {
    Error::Malformed {
        format: FileFormat::Pcd,
        location: Location::Byte(at),
        message: message.into(),
    }
}

/// The error of a file that ends at byte `at`, before `what`.
fn ends_early(at: u64, what: impl Into<String>) -> Error {
    Error::UnexpectedEof {
        format: FileFormat::Pcd,
        location: Location::Byte(at),
        what: what.into(),
    }
}

/// A PCD file read into a point set.
pub(crate) struct PcdFile {
    /// The points.
    pub geometry: Geometry,
    /// The origin the positions are relative to.
    pub origin: DVec3,
    /// The `DATA` keyword, for `info`.
    pub encoding: String,
    /// The header's comment lines.
    pub comments: Vec<String>,
    /// What the file had that the point set does not keep.
    pub notes: Vec<String>,
}

/// Where a field's values go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Slot {
    /// A coordinate of the position (0 to 2).
    Position(usize),
    /// A coordinate of the normal (0 to 2).
    Normal(usize),
    /// Packed colours; `alpha` keeps the top byte.
    Colour { alpha: bool },
    /// The attribute of this index in [`Columns::attributes`].
    Attribute(usize),
    /// Not kept.
    Skipped,
}

/// The values read, a column a kind, before they become a point set.
struct Columns {
    slots: Vec<Slot>,
    /// Each field's stored type.
    types: Vec<FieldType>,
    positions: Vec<DVec3>,
    normals: Option<Vec<Vec3>>,
    /// `0xAARRGGBB` a point.
    colours: Option<Vec<u32>>,
    keeps_alpha: bool,
    /// Name, storage and values of each attribute field.
    attributes: Vec<(String, ScalarType, Vec<f64>)>,
    notes: Vec<String>,
}

/// The field names that hold normals, in the two spellings read.
const NORMAL_NAMES: [[&str; 3]; 2] = [["normal_x", "normal_y", "normal_z"], ["nx", "ny", "nz"]];

impl Columns {
    /// Columns for `points` points of `header`'s fields.
    fn new(header: &Header, points: usize) -> Self {
        let named = |name: &str| {
            header
                .fields
                .iter()
                .position(|f| f.name == name && f.count == 1)
        };
        let normal_names = NORMAL_NAMES
            .iter()
            .find(|names| names.iter().all(|n| named(n).is_some()));
        let mut slots = Vec::with_capacity(header.fields.len());
        let mut attributes = Vec::new();
        let mut notes = Vec::new();
        let mut colour_field = None;
        for field in &header.fields {
            let Field { name, ty, count } = field;
            let axis = |names: [&str; 3]| names.iter().position(|n| n == name);
            let slot = if name == "_" {
                Slot::Skipped
            } else if *count > 1 {
                notes.push(format!(
                    "PCD field `{name}` ({count} values a point) skipped"
                ));
                Slot::Skipped
            } else if let Some(k) = axis(["x", "y", "z"]) {
                Slot::Position(k)
            } else if let Some(k) = normal_names.and_then(|names| axis(*names)) {
                Slot::Normal(k)
            } else if (name == "rgb" || name == "rgba") && ty.size() == 4 && colour_field.is_none()
            {
                colour_field = Some(name.as_str());
                Slot::Colour {
                    alpha: name == "rgba",
                }
            } else if RESERVED_NAMES.contains(&name.as_str()) {
                // `nx ny nz` beside `normal_x normal_y normal_z`, or one of them alone.
                notes.push(format!(
                    "PCD field `{name}` skipped (not a full set of normals beside the ones read)"
                ));
                Slot::Skipped
            } else {
                attributes.push((name.clone(), ty.storage(), vec![0.0; points]));
                Slot::Attribute(attributes.len() - 1)
            };
            slots.push(slot);
        }
        Columns {
            slots,
            types: header.fields.iter().map(|f| f.ty).collect(),
            positions: vec![DVec3::ZERO; points],
            normals: normal_names.map(|_| vec![Vec3::ZERO; points]),
            colours: colour_field.map(|_| vec![0; points]),
            keeps_alpha: colour_field == Some("rgba"),
            attributes,
            notes,
        }
    }

    /// Stores the value of field `field` for point `point` from its stored bytes.
    fn put_bytes(&mut self, field: usize, point: usize, bytes: &[u8]) {
        let value = match self.slots[field] {
            Slot::Skipped => return,
            Slot::Colour { .. } => {
                let mut word = [0u8; 4];
                word.copy_from_slice(&bytes[..4]);
                Value::Bits(u32::from_le_bytes(word))
            }
            _ => Value::Number(self.types[field].decode(bytes)),
        };
        self.put(field, point, value);
    }

    /// Stores the value of field `field` for point `point` from its text; what is wrong
    /// with the text otherwise.
    fn put_text(
        &mut self,
        field: usize,
        point: usize,
        word: &str,
    ) -> std::result::Result<(), String> {
        let not = |what: &str| format!("`{word}` is not {what}");
        let value = match (self.slots[field], self.types[field]) {
            (Slot::Skipped, _) => return Ok(()),
            // A colour stored as a float holds the packed bits of its integer. PCL writes
            // that integer (a float with alpha 255 is a NaN); Open3D and older writers
            // the float, which is never a run of digits but for 0 (bits 0 either way).
            (Slot::Colour { .. }, FieldType::Float(_))
                if !word.bytes().all(|b| b.is_ascii_digit()) =>
            {
                Value::Bits(word.parse::<f32>().map_err(|_| not("a number"))?.to_bits())
            }
            (Slot::Colour { .. }, _) => Value::Bits(
                word.parse::<u32>()
                    .map_err(|_| not("a packed colour (0 to 4294967295)"))?,
            ),
            _ => Value::Number(word.parse().map_err(|_| not("a number"))?),
        };
        self.put(field, point, value);
        Ok(())
    }

    /// Stores `value` (of field `field`, point `point`), given as a number or, for
    /// colours, as its packed bits.
    fn put(&mut self, field: usize, point: usize, value: Value) {
        let number = match value {
            Value::Number(v) => v,
            Value::Bits(bits) => f64::from(bits),
        };
        match self.slots[field] {
            Slot::Position(k) => self.positions[point][k] = number,
            Slot::Normal(k) => {
                if let Some(normals) = &mut self.normals {
                    normals[point][k] = number as f32;
                }
            }
            Slot::Colour { .. } => {
                if let (Some(colours), Value::Bits(bits)) = (&mut self.colours, value) {
                    colours[point] = bits;
                }
            }
            Slot::Attribute(a) => self.attributes[a].2[point] = number,
            Slot::Skipped => {}
        }
    }

    /// The point set the columns hold, with `header`'s notes added to `self.notes`.
    fn into_points(
        mut self,
        header: &Header,
        recentre_far: bool,
    ) -> Result<(PointSet, DVec3, Vec<String>)> {
        if header.height > 1 {
            self.notes.push(format!(
                "PCD organised cloud of {} × {} points kept as a list",
                header.width, header.height
            ));
        }
        if header.viewpoint != IDENTITY_VIEWPOINT {
            let v = header.viewpoint;
            self.notes.push(format!(
                "PCD VIEWPOINT (position {} {} {}, orientation {} {} {} {}) not applied: the \
                 positions are as stored",
                v[0], v[1], v[2], v[3], v[4], v[5], v[6]
            ));
        }
        let valid: Vec<usize> = (0..self.positions.len())
            .filter(|&i| self.positions[i].is_finite())
            .collect();
        let invalid = self.positions.len() - valid.len();
        if invalid > 0 {
            self.notes.push(format!(
                "{invalid} PCD point{} with NaN or infinite coordinates (invalid points) left out",
                if invalid == 1 { "" } else { "s" }
            ));
        }
        let kept: Vec<DVec3> = valid.iter().map(|&i| self.positions[i]).collect();
        let (relative, origin) = relative_positions(&kept, recentre_far);
        let mut points = PointSet::new(relative)?;
        if let Some(normals) = &self.normals {
            let mut unknown = 0;
            let kept: Vec<Vec3> = valid
                .iter()
                .map(|&i| {
                    let n = normals[i];
                    if n.is_finite() {
                        n
                    } else {
                        unknown += 1;
                        Vec3::ZERO
                    }
                })
                .collect();
            if unknown > 0 {
                self.notes.push(format!(
                    "{unknown} PCD normal{} not finite, kept as zero (no known direction)",
                    if unknown == 1 { "" } else { "s" }
                ));
            }
            points.set_normals(Some(kept))?;
        }
        if let Some(colours) = &self.colours {
            let channel = |shift: u32| -> Vec<f32> {
                valid
                    .iter()
                    .map(|&i| ((colours[i] >> shift) & 0xFF) as f32)
                    .collect()
            };
            let names = [("red", 16), ("green", 8), ("blue", 0), ("alpha", 24)];
            let count = if self.keeps_alpha { 4 } else { 3 };
            for (name, shift) in &names[..count] {
                points.set_attribute(
                    Attribute::new(*name, channel(*shift)).with_storage(ScalarType::U8),
                )?;
            }
        }
        for (name, storage, values) in &self.attributes {
            let (kept, not_finite) = finite_or_zero(valid.iter().map(|&i| values[i] as f32));
            if not_finite > 0 {
                self.notes.push(format!(
                    "PCD field `{name}`: {not_finite} value{} not finite, kept as 0",
                    if not_finite == 1 { "" } else { "s" }
                ));
            }
            points.set_attribute(Attribute::new(name.clone(), kept).with_storage(*storage))?;
        }
        Ok((points, origin, self.notes))
    }
}

/// A value as a reader gives it to [`Columns::put`].
#[derive(Debug, Clone, Copy, PartialEq)]
enum Value {
    /// A number.
    Number(f64),
    /// A packed colour's bits.
    Bits(u32),
}

/// Reads a PCD file held in memory (see the module docs).
///
/// ```
/// use pointset_core::io::read_pcd;
/// let pcd = b"VERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 2\nTYPE F F F U\n\
///             WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n0 0 1 7\n1 0.5 0 300\n";
/// let points = read_pcd(pcd)?;
/// let points = points.points();
/// assert_eq!(points.positions()[1].y, 0.5);
/// assert_eq!(points.attribute("intensity").map(|a| a.values()[1]), Some(300.0));
/// # Ok::<(), pointset_core::Error>(())
/// ```
pub fn read_pcd(bytes: &[u8]) -> Result<Geometry> {
    read_pcd_from(bytes, bytes.len() as u64, false).map(|file| file.geometry)
}

/// Reads a PCD file of `len` bytes from `reader`, which starts at its first byte, as it
/// streams in (compressed data is read whole, since it is one block); positions are
/// stored relative to an origin when `recentre_far` is set and the data lies far from the
/// file's origin.
pub(crate) fn read_pcd_from(reader: impl Read, len: u64, recentre_far: bool) -> Result<PcdFile> {
    let mut stream = ByteStream::new(reader, len);
    let header = header::read_header(&mut stream)?;
    let columns = body::read_columns(&header, &mut stream)?;
    let (points, origin, notes) = columns.into_points(&header, recentre_far)?;
    Ok(PcdFile {
        geometry: Geometry::Points(points),
        origin,
        encoding: header.encoding.keyword().to_string(),
        comments: header.comments,
        notes,
    })
}

/// Whether a file whose first line that is not a comment starts with `word` looks like
/// PCD.
pub(crate) fn starts_like_pcd(word: &str) -> bool {
    word == "VERSION" || word == "FIELDS"
}

/// The error for a mesh written as PCD: its faces would be lost.
pub(crate) fn cannot_store_mesh() -> Error {
    Error::FormatCannotStore {
        format: FileFormat::Pcd,
        what: "a mesh's faces (.pcd holds points only; write .ply, .obj or .off)".into(),
    }
}
