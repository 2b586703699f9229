//! ENVI headers beside raw height fields: the layout GDAL (`gdal_translate -of ENVI
//! dem.tif dem.bil`) and other GIS tools write next to a raw file, read so that a raw
//! height field needs no `_WxH` in its name and may hold any of ENVI's numeric types.
//!
//! Read: `samples` and `lines` (the size), `data type` (1 unsigned bytes, 2 and 3 signed
//! 16- and 32-bit integers, 4 and 5 32- and 64-bit floats, 12 and 13 unsigned 16- and
//! 32-bit integers, 14 and 15 signed and unsigned 64-bit integers: heights as stored, cast
//! to `f32` as the TIFF reader casts them), `byte order` (0 little-endian, 1 big-endian;
//! default 0), `header offset` (bytes before the samples; default 0), `bands` (1) and `data
//! ignore value` (a no-data marker: samples equal to it are voids, which
//! [`super::read_heightfield`] refuses, since a height field has no holes). Other keys
//! (`map info`, `interleave`, which one band does not need, `description`, …) are
//! skipped. Values in braces may span lines.

use std::path::{Path, PathBuf};

use super::georeference::NamedSystem;
use super::{GeoReference, HeightSamples};
use crate::Result;

/// The header of the raw file `raw`, if one lies beside it: `NAME.hdr` (the name GDAL
/// gives it) or `NAME.f32le.hdr` (the one [`super::write_map_sidecars`] writes).
pub(super) fn header_beside(raw: &Path) -> Option<PathBuf> {
    [
        raw.with_extension("hdr"),
        super::sidecars::appended(raw, "hdr"),
    ]
    .into_iter()
    .find(|p| p.is_file())
}

/// The layout an ENVI header gives a single-band raw file.
#[derive(Debug, Clone, PartialEq)]
struct RawLayout {
    width: usize,
    height: usize,
    sample: SampleType,
    big_endian: bool,
    offset: usize,
    no_data: Option<f32>,
}

/// The numeric types of ENVI's `data type` (its complex types hold no heights).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SampleType {
    U8,
    I16,
    I32,
    F32,
    F64,
    U16,
    U32,
    I64,
    U64,
}

impl SampleType {
    /// The type of ENVI's `data type` code, if it is a real number.
    fn of_code(code: usize) -> Option<Self> {
        Some(match code {
            1 => Self::U8,
            2 => Self::I16,
            3 => Self::I32,
            4 => Self::F32,
            5 => Self::F64,
            12 => Self::U16,
            13 => Self::U32,
            14 => Self::I64,
            15 => Self::U64,
            _ => return None,
        })
    }

    /// Bytes per sample.
    fn size(self) -> usize {
        match self {
            Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 | Self::I64 | Self::U64 => 8,
        }
    }

    /// What the samples are, for messages.
    fn name(self) -> &'static str {
        match self {
            Self::U8 => "bytes",
            Self::I16 => "16-bit integers",
            Self::U16 => "unsigned 16-bit integers",
            Self::I32 => "32-bit integers",
            Self::U32 => "unsigned 32-bit integers",
            Self::F32 => "32-bit floats",
            Self::F64 => "64-bit floats",
            Self::I64 => "64-bit integers",
            Self::U64 => "unsigned 64-bit integers",
        }
    }

    /// The sample stored in `bytes` (exactly [`Self::size`] of them) in the given byte
    /// order, cast to `f32`.
    fn decode(self, bytes: &[u8], big_endian: bool) -> f32 {
        // The bytes in little-endian order, widened to 64 bits and cut back per type.
        let mut little = [0u8; 8];
        for (k, &byte) in bytes.iter().enumerate() {
            little[if big_endian { bytes.len() - 1 - k } else { k }] = byte;
        }
        let bits = u64::from_le_bytes(little);
        match self {
            Self::U8 => f32::from(bits as u8),
            Self::I16 => f32::from(bits as u16 as i16),
            Self::U16 => f32::from(bits as u16),
            Self::I32 => bits as u32 as i32 as f32,
            Self::U32 => bits as u32 as f32,
            Self::F32 => f32::from_bits(bits as u32),
            Self::F64 => f64::from_bits(bits) as f32,
            Self::I64 => bits as i64 as f32,
            Self::U64 => bits as f32,
        }
    }
}

/// Reads the samples of the height field `raw` as the ENVI header `header` lays it out,
/// voids included. Errors: a header that is not ENVI, lacks the size, has more than one
/// band, a data type that is not a real number or an unknown byte order; a file whose
/// length is not the header offset plus `samples · lines` samples of the data type.
pub(super) fn read_with_header(raw: &Path, header: &Path) -> Result<HeightSamples> {
    let text = std::fs::read_to_string(header).map_err(super::io_error(header))?;
    let layout = parse_header(&text).map_err(|reason| super::format_error(header, reason))?;
    let bytes = std::fs::read(raw).map_err(super::io_error(raw))?;
    let samples = bytes.get(layout.offset..).unwrap_or_default();
    let size = layout.sample.size();
    let needed = layout
        .width
        .checked_mul(layout.height)
        .and_then(|n| n.checked_mul(size));
    if needed != Some(samples.len()) {
        let needed = needed.map_or("more than any file holds".into(), |n| format!("{n}"));
        let reason = format!(
            "a {}x{} height field of {} needs {needed} bytes after the header offset of {}, \
             but the data has {}",
            layout.width,
            layout.height,
            layout.sample.name(),
            layout.offset,
            samples.len()
        );
        return Err(super::format_error(raw, reason));
    }
    let heights: Vec<f32> = samples
        .chunks_exact(size)
        .map(|c| layout.sample.decode(c, layout.big_endian))
        .collect();
    Ok(HeightSamples {
        width: layout.width,
        height: layout.height,
        heights,
        no_data: layout.no_data,
    })
}

/// The layout `text`, an ENVI header, gives; the error says what is missing or unread.
fn parse_header(text: &str) -> std::result::Result<RawLayout, String> {
    if !text.trim_start().starts_with("ENVI") {
        return Err("an ENVI header starts with `ENVI`".into());
    }
    let fields = header_fields(text);
    let value = |key: &str| field(&fields, key);
    let number = |key: &str, default: Option<usize>| -> std::result::Result<usize, String> {
        match value(key) {
            Some(v) => v
                .parse()
                .map_err(|_| format!("`{key} = {v}` is not a whole number")),
            None => default.ok_or_else(|| format!("the header gives no `{key}`")),
        }
    };
    let (width, height) = (number("samples", None)?, number("lines", None)?);
    let bands = number("bands", Some(1))?;
    if bands != 1 {
        return Err(format!("{bands} bands; a height field has 1"));
    }
    let data_type = number("data type", None)?;
    let sample = SampleType::of_code(data_type).ok_or_else(|| {
        format!(
            "data type {data_type}; a height field holds real numbers, ENVI data type 1 to 5 \
             or 12 to 15"
        )
    })?;
    let big_endian = match number("byte order", Some(0))? {
        0 => false,
        1 => true,
        other => return Err(format!("byte order {other}; ENVI knows 0 and 1")),
    };
    let no_data = value("data ignore value")
        .map(|v| {
            v.parse::<f32>()
                .map_err(|_| format!("`data ignore value = {v}` is not a number"))
        })
        .transpose()?;
    Ok(RawLayout {
        width,
        height,
        sample,
        big_endian,
        offset: number("header offset", Some(0))?,
        no_data,
    })
}

/// The placement the ENVI header beside `raw` gives its samples, if there is a header
/// with a `map info` ([`GeoReference::of_heightfield`]). Errors: an unreadable header, a
/// `map info` without its six numbers or with a pixel size that is not positive.
pub(super) fn reference_beside(raw: &Path) -> Result<Option<GeoReference>> {
    let Some(header) = header_beside(raw) else {
        return Ok(None);
    };
    let text = std::fs::read_to_string(&header).map_err(super::io_error(&header))?;
    parse_placement(&text).map_err(|reason| super::format_error(&header, reason))
}

/// The placement `text`, an ENVI header, gives: from `map info = {projection, reference
/// pixel x, y (1-based; (1, 1) is the top-left sample's outer corner), its easting and
/// northing, pixel size x, y, [UTM zone, hemisphere], datum, …}`. `None` without a `map
/// info`, and for a rotated one (`rotation=` other than 0), which a scale and origin
/// cannot hold.
fn parse_placement(text: &str) -> std::result::Result<Option<GeoReference>, String> {
    let fields = header_fields(text);
    let value = |key: &str| field(&fields, key);
    let Some(map_info) = value("map info") else {
        return Ok(None);
    };
    let parts: Vec<&str> = map_info.split(',').map(str::trim).collect();
    let rotated = parts.iter().any(|p| {
        p.to_ascii_lowercase()
            .strip_prefix("rotation=")
            .is_some_and(|angle| angle.trim().parse::<f64>() != Ok(0.0))
    });
    if rotated {
        return Ok(None);
    }
    let numbers: Option<Vec<f64>> = parts
        .get(1..7)
        .and_then(|p| p.iter().map(|v| v.parse::<f64>().ok()).collect());
    let Some([ref_x, ref_y, easting, northing, dx, dy]) =
        numbers.and_then(|v| <[f64; 6]>::try_from(v).ok())
    else {
        return Err(format!(
            "`map info = {{{map_info}}}` needs a projection and six numbers: the reference \
             pixel, its easting and northing, and the pixel size"
        ));
    };
    let finite = [ref_x, ref_y, easting, northing]
        .iter()
        .all(|v| v.is_finite());
    if !(finite && dx.is_finite() && dy.is_finite() && dx > 0.0 && dy > 0.0) {
        return Err(format!(
            "`map info = {{{map_info}}}` gives no usable pixel size"
        ));
    }
    let origin = [
        easting - (ref_x - 1.0) * dx,
        northing + (ref_y - 1.0) * dy,
        0.0,
    ];
    let system = value("coordinate system string")
        .and_then(epsg_of_wkt)
        .or_else(|| system_of_map_info(&parts));
    Ok(Some(GeoReference::naming([dx, dy, 0.0], origin, system)))
}

/// The coordinate system a WKT string names by its own (outermost, so last) EPSG
/// authority, if it has one that fits a GeoTIFF key (ESRI's WKT, which GDAL's ENVI
/// driver writes, has none).
fn epsg_of_wkt(wkt: &str) -> Option<NamedSystem> {
    let authority = wkt
        .rsplit("AUTHORITY[")
        .next()
        .filter(|_| wkt.contains("AUTHORITY["))?;
    let quoted: Vec<&str> = authority.split('"').collect();
    let code = match quoted.as_slice() {
        [_, "EPSG", _, code, ..] => code.parse::<u16>().ok().filter(|&c| c < 32767)?,
        _ => return None,
    };
    if wkt.trim_start().starts_with("PROJCS") {
        Some(NamedSystem::Projected(code))
    } else if wkt.trim_start().starts_with("GEOGCS") {
        Some(NamedSystem::Geographic(code))
    } else {
        None
    }
}

/// The coordinate system of a `map info` that names it in ENVI's own terms: UTM on
/// WGS-84 by zone and hemisphere (EPSG 326zz north, 327zz south), and WGS-84 latitude
/// and longitude (EPSG 4326).
fn system_of_map_info(parts: &[&str]) -> Option<NamedSystem> {
    let wgs84 = |p: &&str| p.eq_ignore_ascii_case("WGS-84");
    match parts.first().map(|p| p.to_ascii_lowercase()).as_deref() {
        Some("utm") if parts.get(9).is_some_and(wgs84) => {
            let zone = parts
                .get(7)?
                .parse::<u16>()
                .ok()
                .filter(|z| (1..=60).contains(z))?;
            let hemisphere = parts.get(8)?.to_ascii_lowercase();
            let base = match hemisphere.as_str() {
                "north" => 32600,
                "south" => 32700,
                _ => return None,
            };
            Some(NamedSystem::Projected(base + zone))
        }
        Some("geographic lat/lon") if parts.get(7).is_some_and(wgs84) => {
            Some(NamedSystem::Geographic(4326))
        }
        _ => None,
    }
}

/// The value of `key` (any case) among an ENVI header's `fields`.
fn field<'a>(fields: &'a [(String, String)], key: &str) -> Option<&'a str> {
    fields
        .iter()
        .find(|(k, _)| k.eq_ignore_ascii_case(key))
        .map(|(_, v)| v.as_str())
}

/// The `key = value` pairs of an ENVI header after its first line, keys trimmed and
/// values trimmed of spaces and braces; a value that opens a brace runs to the line
/// that closes it.
fn header_fields(text: &str) -> Vec<(String, String)> {
    let mut fields = Vec::new();
    let mut lines = text.lines().skip(1);
    while let Some(line) = lines.next() {
        let Some((key, value)) = line.split_once('=') else {
            continue;
        };
        let mut value = value.to_string();
        if value.contains('{') {
            while !value.contains('}') {
                match lines.next() {
                    Some(more) => {
                        value.push('\n');
                        value.push_str(more);
                    }
                    None => break,
                }
            }
        }
        let value = value.trim().trim_start_matches('{').trim_end_matches('}');
        fields.push((key.trim().to_string(), value.trim().to_string()));
    }
    fields
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    /// A header as GDAL 3.10 writes one for `gdal_translate -of ENVI -ot Float32`.
    const GDAL_HEADER: &str = "ENVI\ndescription = {\ndem.f32le}\nsamples = 5\nlines = 3\n\
        bands = 1\nheader offset = 0\nfile type = ENVI Standard\ndata type = 4\n\
        interleave = bsq\nbyte order = 0\nmap info = {UTM, 1, 1, 500000, 4000003, 1, 1, \
        10, North,WGS-84}\nband names = {\nBand 1}\n";

    #[test]
    fn a_gdal_header_gives_the_layout() {
        let layout = parse_header(GDAL_HEADER).unwrap();
        let expected = RawLayout {
            width: 5,
            height: 3,
            sample: SampleType::F32,
            big_endian: false,
            offset: 0,
            no_data: None,
        };
        assert_eq!(layout, expected);
        let swapped = GDAL_HEADER.replace("byte order = 0", "byte order = 1");
        assert!(parse_header(&swapped).unwrap().big_endian);
        let marked = format!("{GDAL_HEADER}data ignore value = -9999\n");
        assert_eq!(parse_header(&marked).unwrap().no_data, Some(-9999.0));
    }

    #[test]
    fn every_real_data_type_is_read_as_stored_in_either_byte_order() {
        let cases: [(usize, Vec<u8>, f32); 9] = [
            (1, vec![200], 200.0),
            (2, (-1234i16).to_le_bytes().to_vec(), -1234.0),
            (3, (-70_000i32).to_le_bytes().to_vec(), -70_000.0),
            (4, (-12.5f32).to_le_bytes().to_vec(), -12.5),
            (5, 1000.25f64.to_le_bytes().to_vec(), 1000.25),
            (12, 65_535u16.to_le_bytes().to_vec(), 65_535.0),
            (13, 4_000_000_000u32.to_le_bytes().to_vec(), 4.0e9),
            (14, (-5_000_000_000i64).to_le_bytes().to_vec(), -5.0e9),
            (15, 1_000_000_000_000u64.to_le_bytes().to_vec(), 1.0e12),
        ];
        for (code, little, expected) in cases {
            let sample = SampleType::of_code(code).unwrap();
            assert_eq!(sample.size(), little.len(), "data type {code}");
            assert_eq!(sample.decode(&little, false), expected, "data type {code}");
            let big: Vec<u8> = little.iter().rev().copied().collect();
            assert_eq!(
                sample.decode(&big, true),
                expected,
                "data type {code}, big-endian"
            );
        }
        for complex_or_unknown in [0, 6, 9, 16] {
            assert_eq!(SampleType::of_code(complex_or_unknown), None);
        }
    }

    #[test]
    fn headers_it_cannot_read_say_why() {
        for (from, to, reason) in [
            ("ENVI\n", "PLY\n", "starts with `ENVI`"),
            ("samples = 5\n", "", "no `samples`"),
            ("bands = 1", "bands = 3", "3 bands"),
            ("data type = 4", "data type = 6", "data type 6"),
            ("byte order = 0", "byte order = 7", "byte order 7"),
            ("lines = 3", "lines = three", "not a whole number"),
        ] {
            let broken = GDAL_HEADER.replacen(from, to, 1);
            let error = parse_header(&broken).unwrap_err();
            assert!(error.contains(reason), "{reason}: {error}");
        }
    }

    #[test]
    fn map_info_places_the_samples_and_names_what_it_can() {
        // The UTM header GDAL 3.10 writes, with its ESRI WKT (no EPSG authority).
        let wkt = "PROJCS[\"WGS_1984_UTM_Zone_10N\",GEOGCS[\"GCS_WGS_1984\"],\
                   UNIT[\"Meter\",1.0]]";
        let utm = format!(
            "ENVI\nmap info = {{UTM, 1, 1, 562000, 5125000, 30, 20, 10, North,WGS-84}}\n\
             coordinate system string = {{{wkt}}}\n"
        );
        let placed = parse_placement(&utm).unwrap().unwrap();
        assert_eq!(
            (placed.scale, placed.origin),
            ([30.0, 20.0, 0.0], [562000.0, 5125000.0, 0.0])
        );
        assert_eq!(placed.epsg(), Some(32610));
        // A reference pixel inside the grid: (3, 2) is two columns east, one row south.
        let inside = utm.replace("1, 1, 562000", "3, 2, 562060");
        let placed = parse_placement(&inside).unwrap().unwrap();
        assert_eq!(placed.origin, [562000.0, 5125020.0, 0.0]);
        let south = utm.replace("10, North", "33, South");
        assert_eq!(
            parse_placement(&south).unwrap().unwrap().epsg(),
            Some(32733)
        );
        let geographic =
            "ENVI\nmap info = {Geographic Lat/Lon, 1, 1, -122.5, 46.5, 0.01, 0.01,WGS-84}\n";
        let placed = parse_placement(geographic).unwrap().unwrap();
        assert_eq!((placed.epsg(), placed.keys[7]), (Some(4326), 2));
        // A WKT with an EPSG authority names its own system, whatever map info says.
        let authority = "ENVI\nmap info = {Mercator_1SP, 1, 1, 0, 0, 5, 5}\ncoordinate system \
                         string = {PROJCS[\"x\",GEOGCS[\"y\",AUTHORITY[\"EPSG\",\"4326\"]],\
                         AUTHORITY[\"EPSG\",\"3857\"]]}\n";
        assert_eq!(
            parse_placement(authority).unwrap().unwrap().epsg(),
            Some(3857)
        );
        // Other systems are placed but not named; rotated ones and headers without map
        // info are not placed; a map info without its numbers is refused.
        let mercator = "ENVI\nmap info = {Mercator_1SP, 1, 1, 0, 0, 5, 5}\n";
        let placed = parse_placement(mercator).unwrap().unwrap();
        assert!(placed.keys.is_empty() && placed.epsg().is_none());
        let rotated = utm.replace("WGS-84}", "WGS-84, rotation=12}");
        assert_eq!(parse_placement(&rotated).unwrap(), None);
        assert_eq!(
            parse_placement(GDAL_HEADER.split("map info").next().unwrap()).unwrap(),
            None
        );
        for broken in ["{UTM, 1, 1, 562000}", "{UTM, 1, 1, 562000, 5125000, 0, 30}"] {
            let text = format!("ENVI\nmap info = {broken}\n");
            assert!(parse_placement(&text).is_err(), "{broken}");
        }
    }

    #[test]
    fn braces_may_span_lines_and_hold_equals_signs() {
        let fields = header_fields("ENVI\nnote = {a = b,\nc}\nsamples = 2\n");
        assert_eq!(fields[0], ("note".to_string(), "a = b,\nc".to_string()));
        assert_eq!(fields[1], ("samples".to_string(), "2".to_string()));
    }
}
