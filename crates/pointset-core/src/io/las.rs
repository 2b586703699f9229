//! ASPRS LAS point clouds, the LiDAR exchange format: versions 1.0 to 1.4 and point data
//! record formats 0 to 10 are read; LAS 1.2 with format 0 (or 2, with colours) is written.
//!
//! A point's coordinates are 32-bit integers scaled and offset by the header, in double
//! precision; they are stored relative to an origin under
//! [`super::ReadOptions::recentre_far`], as for every other format. The intensity becomes
//! the attribute `intensity` (`ushort`) and the class the attribute `classification`
//! (`uchar`: the low 5 bits of the legacy formats 0–5, the whole byte of formats 6–10);
//! the colours of formats 2, 3, 5, 7, 8 and 10 become colours (16-bit values divided by
//! 65535, or by 255 when no value in the file exceeds 255, as writers that store 8-bit
//! colours do). Everything else a record holds (return numbers, scan angle, GPS time,
//! wave packets, extra bytes) and the variable-length records (the coordinate system
//! among them) are skipped, and [`super::LoadedGeometry::notes`] says so.
//!
//! Refused with a typed error: a file shorter than its header, a signature other than
//! `LASF`, a version other than 1.0–1.4, compressed points (LAZ: the format id's bit 7),
//! point formats above 10, records shorter than their format, a zero or non-finite scale,
//! and a point count the file's bytes cannot hold (checked before anything is allocated).
//!
//! Writing ([`write_las`]): each coordinate is an integer times a decimal scale around the
//! data's centre, each axis's scale the finest power of ten that keeps its integers within
//! ±2·10⁹ (10⁻⁹ for a box 4 wide; 10⁻⁵ for 10 km of terrain), far finer than the
//! positions' own single precision. One scale for all three axes, as first written, lost
//! a flat axis of a cloud spread wide along another (1e30 wide: heights 0 to 5 all came
//! back as 3), and tiny clouds below a floor of 10⁻¹² (points 10⁻³⁰ apart came back
//! equal). What int32 steps cannot hold stays lost: an axis spanning 10³⁰ is stored in
//! steps of 10²¹. `intensity` and `classification` attributes are written
//! when their values are whole numbers that fit (0–65535; classes 0–31, the legacy
//! record's 5 bits), colours as 16-bit values; each record says return 1 of 1. Normals,
//! other attributes and faces are not stored ([`super::FileFormat::unstored`]; a mesh is
//! refused before writing).

use std::io::{Cursor, Read, Seek, Write};

use glam::DVec3;

use super::stream::{ByteStream, rewound};
use super::{FileFormat, Geometry, origin_for};
use crate::{Attribute, Error, Location, PointSet, Result, ScalarType};

/// The smallest public header: LAS 1.0 to 1.2.
const HEADER_BYTES: usize = 227;

/// The shortest record of each point data record format, 0 to 10.
const RECORD_BYTES: [usize; 11] = [20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67];

/// The byte offset of the red value in each format's record, for formats with colours.
fn colour_offset(format: u8) -> Option<usize> {
    match format {
        2 => Some(20),
        3 | 5 => Some(28),
        7 | 8 | 10 => Some(30),
        _ => None,
    }
}

/// A LAS file read into a point set.
pub(crate) struct LasFile {
    /// The points.
    pub geometry: Geometry,
    /// The origin the positions are relative to.
    pub origin: DVec3,
    /// `LAS 1.4, point format 6`, for `info`.
    pub encoding: String,
    /// The header's system identifier and generating software, where given.
    pub comments: Vec<String>,
    /// What the file had that the point set does not keep.
    pub notes: Vec<String>,
}

/// The header fields the reader uses.
struct Header {
    version: (u8, u8),
    header_size: usize,
    point_offset: usize,
    vlr_count: u32,
    format: u8,
    record_bytes: usize,
    count: u64,
    scale: DVec3,
    offset: DVec3,
    system: String,
    software: String,
}

/// A malformed-file error at byte `at`.
fn malformed(at: usize, message: impl Into<String>) -> Error {
    Error::Malformed {
        format: FileFormat::Las,
        location: Location::Byte(at as u64),
        message: message.into(),
    }
}

/// Little-endian readers at fixed offsets of a slice known to be long enough.
fn le_u16(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}

fn le_u32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn le_i32(b: &[u8], at: usize) -> i32 {
    le_u32(b, at) as i32
}

fn le_u64(b: &[u8], at: usize) -> u64 {
    u64::from(le_u32(b, at)) | (u64::from(le_u32(b, at + 4)) << 32)
}

fn le_f64(b: &[u8], at: usize) -> f64 {
    f64::from_bits(le_u64(b, at))
}

/// A fixed-width text field, cut at its first NUL and trimmed.
fn text_field(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(&b[..end]).trim().to_string()
}

/// Parses and checks the public header.
fn header(bytes: &[u8]) -> Result<Header> {
    if bytes.len() < HEADER_BYTES {
        return Err(Error::UnexpectedEof {
            format: FileFormat::Las,
            location: Location::Byte(bytes.len() as u64),
            what: format!("the {HEADER_BYTES}-byte public header"),
        });
    }
    if &bytes[..4] != b"LASF" {
        return Err(malformed(
            0,
            "the file does not start with the signature `LASF`",
        ));
    }
    let version = (bytes[24], bytes[25]);
    if version.0 != 1 || version.1 > 4 {
        return Err(malformed(
            24,
            format!("version {}.{} (1.0 to 1.4 are read)", version.0, version.1),
        ));
    }
    let header_size = usize::from(le_u16(bytes, 94));
    let id = bytes[104];
    if id & 0x80 != 0 {
        return Err(malformed(
            104,
            "the points are compressed (LAZ); decompress the file to .las first (laszip \
             or PDAL: `pdal translate in.laz out.las`)",
        ));
    }
    if id > 10 {
        return Err(malformed(
            104,
            format!("point data record format {id} (0 to 10 are read)"),
        ));
    }
    let record_bytes = usize::from(le_u16(bytes, 105));
    let shortest = RECORD_BYTES[usize::from(id)];
    if record_bytes < shortest {
        return Err(malformed(
            105,
            format!("records of {record_bytes} bytes, shorter than format {id}'s {shortest}"),
        ));
    }
    let legacy_count = u64::from(le_u32(bytes, 107));
    // LAS 1.4 moved the count to 64 bits at byte 247, and may leave the legacy one zero.
    let count = if version.1 >= 4 && header_size >= 255 && bytes.len() >= 255 {
        match le_u64(bytes, 247) {
            0 => legacy_count,
            wide => wide,
        }
    } else {
        legacy_count
    };
    let triple = |at: usize| {
        DVec3::new(
            le_f64(bytes, at),
            le_f64(bytes, at + 8),
            le_f64(bytes, at + 16),
        )
    };
    let (scale, offset) = (triple(131), triple(155));
    if !(scale.is_finite() && offset.is_finite()) || scale.cmpeq(DVec3::ZERO).any() {
        return Err(malformed(
            131,
            format!(
                "scale ({}, {}, {}) and offset ({}, {}, {}) must be finite, the scale nonzero",
                scale.x, scale.y, scale.z, offset.x, offset.y, offset.z
            ),
        ));
    }
    Ok(Header {
        version,
        header_size,
        point_offset: le_u32(bytes, 96) as usize,
        vlr_count: le_u32(bytes, 100),
        format: id,
        record_bytes,
        count,
        scale,
        offset,
        system: text_field(&bytes[26..58]),
        software: text_field(&bytes[58..90]),
    })
}

/// Reads a LAS file held in memory (see the module docs).
pub fn read_las(bytes: &[u8]) -> Result<Geometry> {
    read_las_at(bytes, false).map(|file| file.geometry)
}

/// [`read_las`], with positions relative to an origin when `recentre_far` is set and the
/// data lies far from the file's origin.
pub(crate) fn read_las_at(bytes: &[u8], recentre_far: bool) -> Result<LasFile> {
    read_las_from(Cursor::new(bytes), bytes, bytes.len() as u64, recentre_far)
}

/// Reads a LAS file of `len` bytes from `reader`, which starts at its first byte; `head`
/// holds the file's first bytes (the whole file, or at least its first 4 KiB, which hold
/// any public header). The points are decoded as they are read: the file is never held
/// whole. With `recentre_far` the records are read twice, the first time for the origin,
/// so that no position is held in double precision.
pub(crate) fn read_las_from<R: Read + Seek>(
    mut reader: R,
    head: &[u8],
    len: u64,
    recentre_far: bool,
) -> Result<LasFile> {
    let h = header(head)?;
    let point_offset = h.point_offset as u64;
    let available = len.saturating_sub(point_offset);
    let needed = u128::from(h.count) * h.record_bytes as u128;
    if h.point_offset < h.header_size.max(HEADER_BYTES) {
        return Err(malformed(
            96,
            format!(
                "the points start at byte {}, inside the {}-byte header",
                h.point_offset,
                h.header_size.max(HEADER_BYTES)
            ),
        ));
    }
    if point_offset > len {
        return Err(ends_early(
            len,
            format!("the points, which the header places at byte {point_offset}"),
        ));
    }
    if needed > u128::from(available) {
        return Err(Error::HeaderExceedsFile {
            format: FileFormat::Las,
            element: "point".into(),
            declared: h.count,
            needed_bytes: needed,
            available_bytes: available,
        });
    }
    let count = h.count as usize;
    let position = |r: &[u8]| {
        let raw = [0, 4, 8].map(|at| f64::from(le_i32(r, at)));
        DVec3::from_array(raw) * h.scale + h.offset
    };
    let mut record = vec![0u8; h.record_bytes];
    // The origin needs every position first: a first pass over the records finds it,
    // instead of holding each position in double precision (24 bytes a point).
    let origin = if recentre_far {
        rewound(&mut reader, |reader| {
            let mut records = PointRecords::new(reader, len, point_offset, count)?;
            let positions = std::iter::from_fn(|| records.next(&mut record).map(position));
            let origin = origin_for(positions, true);
            records.finish()?;
            Ok(origin)
        })?
    } else {
        DVec3::ZERO
    };
    let mut positions = Vec::with_capacity(count);
    let mut intensity = Vec::with_capacity(count);
    let mut class = Vec::with_capacity(count);
    let colours_at = colour_offset(h.format);
    let mut colours = Vec::with_capacity(if colours_at.is_some() { count } else { 0 });
    let class_at = if h.format >= 6 { 16 } else { 15 };
    let class_mask = if h.format >= 6 { 0xFF } else { 0x1F };
    let mut records = PointRecords::new(&mut reader, len, point_offset, count)?;
    while let Some(r) = records.next(&mut record) {
        positions.push((position(r) - origin).as_vec3());
        intensity.push(f32::from(le_u16(r, 12)));
        class.push(f32::from(r[class_at] & class_mask));
        if let Some(at) = colours_at {
            colours.push([le_u16(r, at), le_u16(r, at + 2), le_u16(r, at + 4)]);
        }
    }
    records.finish()?;
    let mut points = PointSet::new(positions)?;
    points.set_attribute(Attribute::new("intensity", intensity).with_storage(ScalarType::U16))?;
    points.set_attribute(Attribute::new("classification", class).with_storage(ScalarType::U8))?;
    if !colours.is_empty() {
        let full = if colours.iter().flatten().any(|&c| c > 255) {
            65535.0
        } else {
            255.0
        };
        let unit: Vec<[f32; 3]> = colours
            .iter()
            .map(|c| c.map(|v| f32::from(v) / full))
            .collect();
        points.set_colors(&unit)?;
    }
    let comments = [("system", &h.system), ("generated by", &h.software)]
        .iter()
        .filter(|(_, value)| !value.is_empty())
        .map(|(what, value)| format!("LAS {what}: {value}"))
        .collect();
    Ok(LasFile {
        geometry: Geometry::Points(points),
        origin,
        encoding: format!(
            "LAS {}.{}, point format {}",
            h.version.0, h.version.1, h.format
        ),
        comments,
        notes: skipped(&h),
    })
}

/// A LAS file's point records read one at a time from a stream, after skipping to the
/// first; a stream that ends early or fails ends them, and [`PointRecords::finish`] then
/// returns the error.
struct PointRecords<R> {
    stream: ByteStream<R>,
    /// The records still to read.
    left: usize,
    /// The next record's index.
    point: usize,
    error: Option<Error>,
}

impl<R: Read> PointRecords<R> {
    /// The `count` records of the LAS file of `len` bytes that `reader` starts, from byte
    /// `point_offset`.
    fn new(reader: R, len: u64, point_offset: u64, count: usize) -> Result<Self> {
        let mut stream = ByteStream::new(reader, len);
        if !stream.skip(point_offset)? {
            return Err(ends_early(
                stream.position(),
                "the header and its records".into(),
            ));
        }
        Ok(PointRecords {
            stream,
            left: count,
            point: 0,
            error: None,
        })
    }

    /// The next record, read into `record`; `None` at the end or with the error kept.
    fn next<'r>(&mut self, record: &'r mut [u8]) -> Option<&'r [u8]> {
        if self.left == 0 || self.error.is_some() {
            return None;
        }
        match self.stream.read_exact(record) {
            Ok(true) => {
                self.left -= 1;
                self.point += 1;
                Some(record)
            }
            Ok(false) => {
                let at = self.stream.position();
                self.error = Some(ends_early(at, format!("point {}", self.point)));
                None
            }
            Err(error) => {
                self.error = Some(error);
                None
            }
        }
    }

    /// After the records: the error that ended them early, if one did.
    fn finish(self) -> Result<()> {
        self.error.map_or(Ok(()), Err)
    }
}

/// The error of a file that ends at byte `at`, before `what`.
fn ends_early(at: u64, what: String) -> Error {
    Error::UnexpectedEof {
        format: FileFormat::Las,
        location: Location::Byte(at),
        what,
    }
}

/// What the point set does not keep of a file with header `h`.
fn skipped(h: &Header) -> Vec<String> {
    let mut fields = vec![
        "return numbers",
        "scan angles",
        "user data",
        "point source ids",
    ];
    if !matches!(h.format, 0 | 2) {
        fields.push("GPS times");
    }
    if h.format == 8 || h.format == 10 {
        fields.push("near-infrared");
    }
    if matches!(h.format, 4 | 5 | 9 | 10) {
        fields.push("wave packets");
    }
    let mut notes = vec![format!("LAS point fields skipped: {}", fields.join(", "))];
    let extra = h.record_bytes - RECORD_BYTES[usize::from(h.format)];
    if extra > 0 {
        notes.push(format!("{extra} extra bytes per point skipped"));
    }
    if h.vlr_count > 0 {
        notes.push(format!(
            "{} variable-length record{} skipped (a coordinate system among them is not \
             kept: the coordinates are the file's)",
            h.vlr_count,
            if h.vlr_count == 1 { "" } else { "s" }
        ));
    }
    notes
}

/// Whether `bytes` start like a LAS file.
pub(crate) fn looks_like_las(bytes: &[u8]) -> bool {
    bytes.starts_with(b"LASF")
}

/// The error for a mesh written as LAS: its faces would be lost.
pub(crate) fn cannot_store_mesh() -> Error {
    Error::FormatCannotStore {
        format: FileFormat::Las,
        what: "a mesh's faces (.las holds points only; write .ply, .obj or .off)".into(),
    }
}

/// The largest value each written attribute may hold: `intensity` a 16-bit count, the
/// legacy record's class 5 bits.
fn attribute_limit(name: &str) -> Option<f32> {
    match name {
        "intensity" => Some(65535.0),
        "classification" => Some(31.0),
        _ => None,
    }
}

/// Whether LAS records can hold `attribute`: `intensity` or `classification`, with values
/// that are whole numbers from 0 to their limit.
pub(crate) fn stores(attribute: &Attribute) -> bool {
    attribute_limit(attribute.name()).is_some_and(|limit| {
        attribute
            .values()
            .iter()
            .all(|&v| v.fract() == 0.0 && (0.0..=limit).contains(&v))
    })
}

/// Writes the point set `geometry` as LAS 1.2 to `out` (see the module docs); a mesh is
/// refused (its faces would be lost).
pub fn write_las(geometry: &Geometry, out: &mut impl Write) -> Result<()> {
    write_las_at(geometry, DVec3::ZERO, out)
}

/// The scales and offset that hold `lo..hi` in 32-bit integers, each axis on its own
/// (see the module docs).
fn scale_and_offset(lo: DVec3, hi: DVec3) -> (DVec3, DVec3) {
    let offset = (0.5 * (lo + hi)).round();
    let reach = (hi - offset).max(offset - lo);
    let scale = reach.to_array().map(|r| {
        // An axis where every point has the offset's value keeps the finest scale the
        // others would get at a reach of 1 (10⁻⁹), a normal number for every reader.
        let r = if r > 0.0 { r } else { 1.0 };
        10f64.powf((r / 2e9).log10().ceil()).max(MIN_SCALE)
    });
    (DVec3::from_array(scale), offset)
}

/// The finest scale [`write_las`] writes: 10⁻³⁰⁰, where `f64` is still a normal number.
/// Reaches under about 10⁻²⁹⁰ get it (positions that small are zero in `f32`).
const MIN_SCALE: f64 = 1e-300;

/// [`write_las`] with the stored positions relative to `origin`: the file's coordinates
/// are their sums, in double precision.
pub(crate) fn write_las_at(geometry: &Geometry, origin: DVec3, out: &mut impl Write) -> Result<()> {
    let Geometry::Points(points) = geometry else {
        return Err(cannot_store_mesh());
    };
    let count = u32::try_from(points.len()).map_err(|_| Error::FormatCannotStore {
        format: FileFormat::Las,
        what: format!("{} points (LAS 1.2 counts up to 2^32 − 1)", points.len()),
    })?;
    let absolute: Vec<DVec3> = points
        .positions()
        .iter()
        .map(|p| p.as_dvec3() + origin)
        .collect();
    let (lo, hi) = absolute
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let (lo, hi) = if count == 0 {
        (DVec3::ZERO, DVec3::ZERO)
    } else {
        (lo, hi)
    };
    let (scale, offset) = scale_and_offset(lo, hi);
    let colours = points.colors();
    let format: u8 = if colours.is_some() { 2 } else { 0 };
    let record = RECORD_BYTES[usize::from(format)];
    let values = |name: &str| {
        points
            .attribute(name)
            .filter(|a| stores(a))
            .map(Attribute::values)
    };
    let (intensity, class) = (values("intensity"), values("classification"));

    let mut header = vec![0u8; HEADER_BYTES];
    header[..4].copy_from_slice(b"LASF");
    header[24] = 1;
    header[25] = 2;
    put_text(&mut header[26..58], "geosynth");
    put_text(
        &mut header[58..90],
        concat!("geosynth ", env!("CARGO_PKG_VERSION")),
    );
    header[94..96].copy_from_slice(&(HEADER_BYTES as u16).to_le_bytes());
    header[96..100].copy_from_slice(&(HEADER_BYTES as u32).to_le_bytes());
    header[104] = format;
    header[105..107].copy_from_slice(&(record as u16).to_le_bytes());
    header[107..111].copy_from_slice(&count.to_le_bytes());
    // Every point is return 1 of 1.
    header[111..115].copy_from_slice(&count.to_le_bytes());
    for (k, v) in [
        scale.x, scale.y, scale.z, offset.x, offset.y, offset.z, hi.x, lo.x, hi.y, lo.y, hi.z, lo.z,
    ]
    .iter()
    .enumerate()
    {
        header[131 + 8 * k..139 + 8 * k].copy_from_slice(&v.to_le_bytes());
    }
    let io = |source| Error::Write { source };
    out.write_all(&header).map_err(io)?;
    let mut buffer = Vec::with_capacity(record * points.len().min(1 << 16));
    for (i, p) in absolute.iter().enumerate() {
        let steps = ((*p - offset) / scale).round();
        for c in steps.to_array() {
            buffer.extend_from_slice(
                &(c.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32).to_le_bytes(),
            );
        }
        let intensity = intensity.map_or(0, |v| v[i] as u16);
        buffer.extend_from_slice(&intensity.to_le_bytes());
        // Return 1 of 1 (bits 0–2 and 3–5), then the class.
        buffer.push(1 | (1 << 3));
        buffer.push(class.map_or(0, |v| v[i] as u8));
        // Scan angle rank, user data, point source id.
        buffer.extend_from_slice(&[0, 0, 0, 0]);
        if let Some(colours) = &colours {
            for c in colours[i] {
                buffer.extend_from_slice(
                    &((c.clamp(0.0, 1.0) * 65535.0).round() as u16).to_le_bytes(),
                );
            }
        }
        if buffer.len() >= record << 16 {
            out.write_all(&buffer).map_err(io)?;
            buffer.clear();
        }
    }
    out.write_all(&buffer).map_err(io)
}

/// `text` into a fixed-width field, cut to fit (the rest stays NUL).
fn put_text(field: &mut [u8], text: &str) {
    let n = text.len().min(field.len());
    field[..n].copy_from_slice(&text.as_bytes()[..n]);
}
