//! NRRD files (attached header, raw encoding) for scalar and 4-channel grids, readable by
//! ParaView, 3D Slicer and teem.
//!
//! Written: `NRRD0004`, `type: float`, `encoding: raw`, `endian: little`, `space dimension:
//! 3`, `space directions` and `space origin`; 4-channel grids add a leading axis of size 4
//! with `kinds: vector domain domain domain` (and `none` as its space direction). Read: the
//! same, plus `spacings`/`axis mins` instead of space fields; `double` and 8-, 16-, 32- and
//! 64-bit integer data (converted to `f32` as they are: no value scaling is applied;
//! 64-bit integers are numpy's default, so pynrrd's for integer arrays); big-endian data;
//! and `gzip` (pynrrd's default) and `ascii` encodings; and, through [`read_file`], detached
//! headers (`.nhdr`) whose `data file` names one file beside them. `bzip2`, data split over
//! several files (`LIST` or a `%` pattern) and byte or line skips are not supported and are
//! reported as such.

use std::io::Write;
use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3, Vec4};
use pointset_core::io::{FileReplacement, replace_file};
use pointset_core::{Grid3, ScalarType};

use crate::error::{FieldError, Result};

/// A volume read from an NRRD file: `channels` values per node (1 or 4), x-fastest.
#[derive(Debug, Clone, PartialEq)]
pub struct NrrdVolume {
    /// Nodes along x, y, z.
    pub dims: [usize; 3],
    /// World position of node (0, 0, 0), in double precision as the file gives it (a
    /// georeferenced field's origin can lie where an `f32` steps by 0.25 or more).
    pub origin: DVec3,
    /// Node spacing (the files we read must have cubic cells).
    pub spacing: f32,
    /// Values per node: 1 (scalar) or 4 (distance + gradient).
    pub channels: usize,
    /// `channels × nodes` values, channel-fastest.
    pub data: Vec<f32>,
}

impl NrrdVolume {
    /// World position of the last node, in double precision.
    pub fn far_corner(&self) -> DVec3 {
        let span = DVec3::from(self.dims.map(|d| d.saturating_sub(1) as f64));
        self.origin + span * f64::from(self.spacing)
    }

    /// The volume as a scalar grid (the first channel of multi-channel volumes).
    pub fn scalar_grid(&self) -> Result<Grid3<f32>> {
        self.scalar_grid_at(DVec3::ZERO)
    }

    /// [`Self::scalar_grid`] with its origin stored relative to `offset` (the inverse of
    /// [`write_scalar_at`]): a georeferenced field keeps its node positions' precision.
    pub fn scalar_grid_at(&self, offset: DVec3) -> Result<Grid3<f32>> {
        let values = self.data.iter().step_by(self.channels).copied().collect();
        Ok(Grid3::from_vec(
            self.dims,
            (self.origin - offset).as_vec3(),
            self.spacing,
            values,
        )?)
    }

    /// A 4-channel volume as a grid of `Vec4`.
    pub fn vec4_grid(&self) -> Result<Grid3<Vec4>> {
        self.vec4_grid_at(DVec3::ZERO)
    }

    /// [`Self::vec4_grid`] with its origin stored relative to `offset` (the inverse of
    /// [`write_vec4_at`]).
    pub fn vec4_grid_at(&self, offset: DVec3) -> Result<Grid3<Vec4>> {
        if self.channels != 4 {
            return Err(nrrd_error(
                "header",
                format!("{} channels, 4 needed", self.channels),
            ));
        }
        let values = self.data.chunks_exact(4).map(Vec4::from_slice).collect();
        Ok(Grid3::from_vec(
            self.dims,
            (self.origin - offset).as_vec3(),
            self.spacing,
            values,
        )?)
    }
}

fn nrrd_error(location: impl Into<String>, message: impl Into<String>) -> FieldError {
    FieldError::Nrrd {
        location: location.into(),
        message: message.into(),
    }
}

fn header(dims: [usize; 3], origin: Vec3, offset: DVec3, spacing: f32, channels: usize) -> String {
    let s = spacing;
    let dirs = format!("({s},0,0) (0,{s},0) (0,0,{s})");
    let mut h = String::from("NRRD0004\n# written by geosynth (distance-field)\ntype: float\n");
    if channels == 1 {
        h.push_str(&format!(
            "dimension: 3\nsizes: {} {} {}\n",
            dims[0], dims[1], dims[2]
        ));
        h.push_str(&format!(
            "space dimension: 3\nspace directions: {dirs}\nkinds: domain domain domain\n"
        ));
    } else {
        h.push_str(&format!(
            "dimension: 4\nsizes: {channels} {} {} {}\n",
            dims[0], dims[1], dims[2]
        ));
        h.push_str(&format!("space dimension: 3\nspace directions: none {dirs}\nkinds: vector domain domain domain\n"));
    }
    let origin = if offset == DVec3::ZERO {
        format!("{},{},{}", origin.x, origin.y, origin.z)
    } else {
        let o = origin.as_dvec3() + offset;
        format!("{},{},{}", o.x, o.y, o.z)
    };
    h.push_str(&format!(
        "space origin: ({origin})\nencoding: raw\nendian: little\n\n"
    ));
    h
}

fn write_raw(
    out: &mut impl Write,
    head: &str,
    values: impl Iterator<Item = f32>,
) -> std::io::Result<()> {
    let mut buf = head.as_bytes().to_vec();
    for v in values {
        buf.extend_from_slice(&v.to_le_bytes());
    }
    out.write_all(&buf)
}

/// Writes a scalar grid.
pub fn write_scalar(out: &mut impl Write, grid: &Grid3<f32>) -> std::io::Result<()> {
    write_scalar_at(out, grid, DVec3::ZERO)
}

/// [`write_scalar`] for a grid stored relative to `offset` (georeferenced data read with
/// `pointset_core::io::ReadOptions::recentre_far`): the header's `space origin` is the sum,
/// in double precision.
pub fn write_scalar_at(
    out: &mut impl Write,
    grid: &Grid3<f32>,
    offset: DVec3,
) -> std::io::Result<()> {
    let head = header(grid.dims(), grid.origin(), offset, grid.spacing(), 1);
    write_raw(out, &head, grid.data().iter().copied())
}

/// Writes a 4-channel grid (distance + gradient).
pub fn write_vec4(out: &mut impl Write, grid: &Grid3<Vec4>) -> std::io::Result<()> {
    write_vec4_at(out, grid, DVec3::ZERO)
}

/// [`write_vec4`] for a grid stored relative to `offset` (see [`write_scalar_at`]).
pub fn write_vec4_at(
    out: &mut impl Write,
    grid: &Grid3<Vec4>,
    offset: DVec3,
) -> std::io::Result<()> {
    let head = header(grid.dims(), grid.origin(), offset, grid.spacing(), 4);
    write_raw(out, &head, grid.data().iter().flat_map(|v| v.to_array()))
}

/// Writes a file whole or not at all ([`FileReplacement`]: after any error it keeps what it
/// held), naming it in errors.
pub fn write_file(
    path: &Path,
    write: impl FnOnce(&mut FileReplacement) -> std::io::Result<()>,
) -> Result<()> {
    let io = |source| FieldError::Io {
        path: path.to_path_buf(),
        source,
    };
    replace_file(path, |out| write(out).map_err(io), io)
}

fn parse_vector(s: &str) -> Option<Vec<f64>> {
    let inner = s.trim().strip_prefix('(')?.strip_suffix(')')?;
    inner.split(',').map(|x| x.trim().parse().ok()).collect()
}

/// The last three numbers of a per-axis field (`spacings`, `axis mins`): the spatial
/// axes, after a channel axis whose entry may be `nan`. Anything that is not a number is
/// an error, not a silent default.
fn spatial_numbers(line: usize, text: &str, what: &str) -> Result<[f64; 3]> {
    let values: Vec<f64> = text
        .split_whitespace()
        .map(|t| {
            t.parse().map_err(|_| {
                nrrd_error(
                    format!("line {line}"),
                    format!("`{t}` in {what} is not a number"),
                )
            })
        })
        .collect::<Result<_>>()?;
    match values[..] {
        [.., x, y, z] => Ok([x, y, z]),
        _ => Err(nrrd_error(
            format!("line {line}"),
            format!("{what} needs a value for each of the three spatial axes"),
        )),
    }
}

/// Parses an NRRD file held in memory. A detached header (`data file: …`) is refused here,
/// since there is no folder to find its data in: [`read_file`] reads those.
pub fn read(bytes: &[u8]) -> Result<NrrdVolume> {
    read_with_data_folder(bytes, None)
}

/// [`read`], with `folder` the one a detached header's data file is named relative to.
fn read_with_data_folder(bytes: &[u8], folder: Option<&Path>) -> Result<NrrdVolume> {
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut fields: Vec<(usize, String, String)> = Vec::new();
    loop {
        // A detached header may end with the file instead of a blank line.
        if pos == bytes.len() && line_no > 0 {
            break;
        }
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map(|n| pos + n)
            .ok_or_else(|| {
                nrrd_error(
                    format!("line {}", line_no + 1),
                    "header does not end with a blank line",
                )
            })?;
        line_no += 1;
        let line = std::str::from_utf8(&bytes[pos..end])
            .map_err(|_| nrrd_error(format!("line {line_no}"), "header is not text"))?
            .trim_end_matches('\r');
        pos = end + 1;
        if line_no == 1 {
            if !line.starts_with("NRRD000") {
                return Err(nrrd_error("line 1", "missing the NRRD000x magic"));
            }
            continue;
        }
        if line.is_empty() {
            break;
        }
        if line.starts_with('#') {
            continue;
        }
        let (key, value) = line
            .split_once(": ")
            .or_else(|| line.split_once(":="))
            .ok_or_else(|| {
                nrrd_error(format!("line {line_no}"), format!("cannot parse `{line}`"))
            })?;
        fields.push((line_no, key.trim().to_string(), value.trim().to_string()));
    }
    let get = |k: &str| {
        fields
            .iter()
            .find(|(_, key, _)| key == k)
            .map(|(l, _, v)| (*l, v.as_str()))
    };
    let require = |k: &'static str| {
        get(k).ok_or_else(|| nrrd_error("header", format!("missing `{k}` field")))
    };

    let (line, ty) = require("type")?;
    let scalar = data_type(ty).ok_or_else(|| {
        nrrd_error(
            format!("line {line}"),
            format!(
                "unsupported type `{ty}` (8-, 16-, 32- and 64-bit integers, float and double \
                 are read)"
            ),
        )
    })?;
    let (line, enc) = require("encoding")?;
    let encoding = match enc {
        "raw" => Encoding::Raw,
        "gzip" | "gz" => Encoding::Gzip,
        "ascii" | "text" | "txt" => Encoding::Ascii,
        other => {
            return Err(nrrd_error(
                format!("line {line}"),
                format!("unsupported encoding `{other}` (raw, gzip and ascii are read)"),
            ));
        }
    };
    for key in ["byte skip", "byteskip", "line skip", "lineskip"] {
        if let Some((line, skip)) = get(key).filter(|(_, v)| *v != "0") {
            return Err(nrrd_error(
                format!("line {line}"),
                format!("`{key}: {skip}` is not supported (data must follow the header)"),
            ));
        }
    }
    let big_endian = get("endian").is_some_and(|(_, e)| e == "big");
    let (line, sizes) = require("sizes")?;
    let sizes: Vec<usize> = sizes
        .split_whitespace()
        .map(|s| {
            s.parse().map_err(|_| {
                nrrd_error(format!("line {line}"), format!("size `{s}` is not a count"))
            })
        })
        .collect::<Result<_>>()?;
    let (channels, dims) = match sizes[..] {
        [x, y, z] => (1, [x, y, z]),
        [c @ (1 | 4), x, y, z] => (c, [x, y, z]),
        _ => {
            return Err(nrrd_error(
                format!("line {line}"),
                "expected 3 sizes, or 4 with 1 or 4 channels first",
            ));
        }
    };
    let (spacing, origin) = if let Some((line, dirs)) = get("space directions") {
        let vectors: Vec<Vec<f64>> = dirs
            .split_whitespace()
            .filter(|d| *d != "none")
            .filter_map(parse_vector)
            .collect();
        if vectors.len() != 3 || vectors.iter().any(|v| v.len() != 3) {
            return Err(nrrd_error(
                format!("line {line}"),
                "expected three space direction vectors",
            ));
        }
        let s = vectors[0][0];
        let axis_aligned = (0..3).all(|a| {
            (0..3).all(|b| {
                if a == b {
                    (vectors[a][b] - s).abs() <= 1e-6 * s.abs()
                } else {
                    vectors[a][b] == 0.0
                }
            })
        });
        if !axis_aligned {
            return Err(nrrd_error(
                format!("line {line}"),
                "only axis-aligned cubic cells are supported",
            ));
        }
        let origin = match get("space origin") {
            Some((line, o)) => parse_vector(o).filter(|v| v.len() == 3).ok_or_else(|| {
                nrrd_error(
                    format!("line {line}"),
                    format!("space origin `{o}` is not three numbers (x,y,z)"),
                )
            })?,
            None => vec![0.0; 3],
        };
        (s, origin)
    } else {
        let (line, sp) = require("spacings")?;
        let sp = spatial_numbers(line, sp, "spacings")?;
        let s = sp[0];
        if sp.iter().any(|&v| (v - s).abs() > 1e-6 * s.abs()) {
            return Err(nrrd_error(
                format!("line {line}"),
                format!(
                    "spacings {} {} {}: only cubic cells are supported",
                    sp[0], sp[1], sp[2]
                ),
            ));
        }
        let origin = match get("axis mins") {
            Some((line, m)) => spatial_numbers(line, m, "axis mins")?.to_vec(),
            None => vec![0.0; 3],
        };
        (s, origin)
    };
    let spacing = spacing as f32;
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(nrrd_error(
            "header",
            format!("the node spacing {spacing} is not a positive length"),
        ));
    }
    if origin.iter().any(|v| !v.is_finite()) {
        return Err(nrrd_error(
            "header",
            format!("the origin {origin:?} is not finite"),
        ));
    }
    let count = dims
        .iter()
        .try_fold(channels, |acc, &d| acc.checked_mul(d))
        .ok_or_else(|| nrrd_error("header", "sizes overflow"))?;
    let detached = match get("data file").or_else(|| get("datafile")) {
        Some((line, name)) => Some(data_file_path(line, name, folder)?),
        None => None,
    };
    let data_bytes;
    let (body, pos) = match &detached {
        Some(path) => {
            data_bytes = std::fs::read(path).map_err(|source| FieldError::Io {
                path: path.clone(),
                source,
            })?;
            (&data_bytes[..], 0)
        }
        None => (&bytes[pos..], pos),
    };
    let data = decode_data(body, pos, encoding, scalar, big_endian, count).map_err(|e| {
        match (&detached, e) {
            (Some(path), FieldError::Nrrd { location, message }) => FieldError::Nrrd {
                location: format!("{location} of data file {}", path.display()),
                message,
            },
            (_, e) => e,
        }
    })?;
    Ok(NrrdVolume {
        dims,
        origin: DVec3::new(origin[0], origin[1], origin[2]),
        spacing,
        channels,
        data,
    })
}

/// The file a detached header's `data file: name` (on header line `line`) points to,
/// relative to `folder` unless absolute. Data split over several files is refused.
fn data_file_path(line: usize, name: &str, folder: Option<&Path>) -> Result<PathBuf> {
    if name == "LIST" || name.contains('%') {
        return Err(nrrd_error(
            format!("line {line}"),
            format!("`data file: {name}`: data split over several files is not supported"),
        ));
    }
    let path = Path::new(name);
    if path.is_absolute() {
        return Ok(path.to_path_buf());
    }
    let folder = folder.ok_or_else(|| {
        nrrd_error(
            format!("line {line}"),
            format!(
                "the data is in the file `{name}` beside the header: read the header as a \
                 file (nrrd::read_file), not from memory"
            ),
        )
    })?;
    Ok(folder.join(path))
}

/// The `count` values of the data `body` (which starts at byte `pos` of its file).
fn decode_data(
    body: &[u8],
    pos: usize,
    encoding: Encoding,
    scalar: DataType,
    big_endian: bool,
    count: usize,
) -> Result<Vec<f32>> {
    Ok(match encoding {
        Encoding::Ascii => ascii_values(body, pos, count)?,
        Encoding::Raw | Encoding::Gzip => {
            let needed = count
                .checked_mul(scalar.size())
                .ok_or_else(|| nrrd_error("header", "sizes overflow"))?;
            let inflated;
            let raw = if encoding == Encoding::Gzip {
                inflated = gunzip(body, pos, needed)?;
                &inflated[..]
            } else {
                body
            };
            if needed > raw.len() {
                let what = if encoding == Encoding::Gzip {
                    "decompressed data bytes"
                } else {
                    "data bytes follow"
                };
                return Err(nrrd_error(
                    format!("byte {pos}"),
                    format!(
                        "the header promises {needed} data bytes but only {} {what}",
                        raw.len()
                    ),
                ));
            }
            raw[..needed]
                .chunks_exact(scalar.size())
                .map(|word| scalar.decode(word, big_endian).map(|v| v as f32))
                .collect::<Option<Vec<f32>>>()
                .ok_or_else(|| nrrd_error(format!("byte {pos}"), "a value is cut short"))?
        }
    })
}

/// How the data after the header is encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    /// Binary values, `endian` byte order.
    Raw,
    /// The same, gzip-compressed (pynrrd's default).
    Gzip,
    /// Whitespace- (or comma-) separated numbers.
    Ascii,
}

/// The storage type of NRRD data: the PLY scalar types, or a 64-bit integer (which PLY
/// has not).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DataType {
    /// One of the PLY scalar types.
    Scalar(ScalarType),
    /// Signed 64-bit integer.
    I64,
    /// Unsigned 64-bit integer.
    U64,
}

impl DataType {
    /// Bytes per value.
    fn size(self) -> usize {
        match self {
            DataType::Scalar(scalar) => scalar.size(),
            DataType::I64 | DataType::U64 => 8,
        }
    }

    /// The value in `word` (exactly [`Self::size`] bytes), `None` when it is cut short.
    fn decode(self, word: &[u8], big_endian: bool) -> Option<f64> {
        let bits = |word: &[u8]| {
            let bytes: [u8; 8] = word.try_into().ok()?;
            Some(if big_endian {
                u64::from_be_bytes(bytes)
            } else {
                u64::from_le_bytes(bytes)
            })
        };
        match self {
            DataType::Scalar(scalar) => scalar.decode(word, big_endian),
            DataType::I64 => bits(word).map(|b| b as i64 as f64),
            DataType::U64 => bits(word).map(|b| b as f64),
        }
    }
}

/// The storage type named by an NRRD `type` field, in any of the spellings the format
/// allows (`uchar`, `unsigned char`, `uint8`, `uint8_t`, `long long`, …). `block` is not
/// read.
fn data_type(name: &str) -> Option<DataType> {
    let scalar = match name {
        "longlong"
        | "long long"
        | "long long int"
        | "signed long long"
        | "signed long long int"
        | "int64"
        | "int64_t" => return Some(DataType::I64),
        "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => {
            return Some(DataType::U64);
        }
        other => other,
    };
    Some(DataType::Scalar(match scalar {
        "signed char" | "int8" | "int8_t" => ScalarType::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => ScalarType::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            ScalarType::I16
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => {
            ScalarType::U16
        }
        "int" | "signed int" | "int32" | "int32_t" => ScalarType::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => ScalarType::U32,
        "float" | "float32" => ScalarType::F32,
        "double" | "float64" => ScalarType::F64,
        _ => return None,
    }))
}

/// The gzip stream `body` (which starts at byte `offset` of the file) inflated, reading at
/// most one byte more than the `needed` ones, so that a stream that would inflate to far
/// more than the header promises (a decompression bomb) stops there.
fn gunzip(body: &[u8], offset: usize, needed: usize) -> Result<Vec<u8>> {
    use std::io::Read;
    let mut out = Vec::new();
    flate2::read::MultiGzDecoder::new(body)
        .take(needed as u64 + 1)
        .read_to_end(&mut out)
        .map_err(|e| nrrd_error(format!("byte {offset}"), format!("gzip data: {e}")))?;
    Ok(out)
}

/// The first `count` numbers of an ASCII-encoded body (which starts at byte `offset`).
fn ascii_values(body: &[u8], offset: usize, count: usize) -> Result<Vec<f32>> {
    let text = std::str::from_utf8(body)
        .map_err(|_| nrrd_error(format!("byte {offset}"), "ascii data is not text"))?;
    let values = text
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|t| !t.is_empty())
        .take(count)
        .map(|t| {
            t.parse::<f64>().map(|v| v as f32).map_err(|_| {
                nrrd_error(
                    format!("byte {offset}"),
                    format!("`{t}` in the data is not a number"),
                )
            })
        })
        .collect::<Result<Vec<f32>>>()?;
    if values.len() < count {
        return Err(nrrd_error(
            format!("byte {offset}"),
            format!(
                "the header promises {count} values but only {} follow",
                values.len()
            ),
        ));
    }
    Ok(values)
}

/// Whether a path names an NRRD file: `.nrrd`, or `.nhdr` for a detached header (any case).
pub fn is_nrrd_path(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("nrrd") || e.eq_ignore_ascii_case("nhdr"))
}

/// Reads an NRRD file (`.nrrd`), or a detached header (`.nhdr`) and the data file it names
/// (relative to the header's folder unless absolute).
pub fn read_file(path: &Path) -> Result<NrrdVolume> {
    let bytes = std::fs::read(path).map_err(|source| FieldError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    read_with_data_folder(&bytes, Some(path.parent().unwrap_or(Path::new(""))))
}
