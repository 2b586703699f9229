//! ENVI headers beside raw height fields: the layout GDAL (`gdal_translate -of ENVI -ot
//! Float32 dem.tif dem.f32le`) and other GIS tools write next to a raw file, read so that
//! a raw height field needs no `_WxH` in its name.
//!
//! Read: `samples` and `lines` (the size), `data type` (4, 32-bit float, is the one a
//! `.f32le` holds), `byte order` (0 little-endian, 1 big-endian; default 0), `header
//! offset` (bytes before the samples; default 0), `bands` (1) and `data ignore value` (a
//! no-data marker: samples equal to it are refused, since a height field has no holes).
//! Other keys (`map info`, `description`, …) are skipped. Values in braces may span lines.

use std::path::{Path, PathBuf};

use pointset_core::HeightField;

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
    big_endian: bool,
    offset: usize,
    no_data: Option<f32>,
}

/// Reads the height field `raw` as the ENVI header `header` lays it out. Errors: a header
/// that is not ENVI, lacks the size, has more than one band, a data type other than 4 or
/// an unknown byte order; a file whose length is not the header offset plus
/// `4 · samples · lines` bytes; samples equal to the no-data value, or not finite.
pub(super) fn read_with_header(raw: &Path, header: &Path) -> Result<HeightField> {
    let text = std::fs::read_to_string(header).map_err(super::io_error(header))?;
    let layout = parse_header(&text).map_err(|reason| super::format_error(header, reason))?;
    let bytes = std::fs::read(raw).map_err(super::io_error(raw))?;
    let samples = bytes.get(layout.offset..).unwrap_or_default();
    let field = if layout.big_endian {
        let swapped: Vec<u8> = samples
            .chunks(4)
            .flat_map(|c| c.iter().rev().copied())
            .collect();
        HeightField::from_f32le(&swapped, layout.width, layout.height)?
    } else {
        HeightField::from_f32le(samples, layout.width, layout.height)?
    };
    if let Some(no_data) = layout.no_data {
        super::refuse_no_data(raw, field.heights(), no_data)?;
    }
    Ok(field)
}

/// The layout `text`, an ENVI header, gives; the error says what is missing or unread.
fn parse_header(text: &str) -> std::result::Result<RawLayout, String> {
    if !text.trim_start().starts_with("ENVI") {
        return Err("an ENVI header starts with `ENVI`".into());
    }
    let fields = header_fields(text);
    let value = |key: &str| {
        fields
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(key))
            .map(|(_, v)| v.as_str())
    };
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
    if data_type != 4 {
        return Err(format!(
            "data type {data_type}; a .f32le height field is 32-bit float, ENVI data type 4 \
             (gdal_translate -ot Float32)"
        ));
    }
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
        big_endian,
        offset: number("header offset", Some(0))?,
        no_data,
    })
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
    fn headers_it_cannot_read_say_why() {
        for (from, to, reason) in [
            ("ENVI\n", "PLY\n", "starts with `ENVI`"),
            ("samples = 5\n", "", "no `samples`"),
            ("bands = 1", "bands = 3", "3 bands"),
            ("data type = 4", "data type = 2", "data type 2"),
            ("byte order = 0", "byte order = 7", "byte order 7"),
            ("lines = 3", "lines = three", "not a whole number"),
        ] {
            let broken = GDAL_HEADER.replacen(from, to, 1);
            let error = parse_header(&broken).unwrap_err();
            assert!(error.contains(reason), "{reason}: {error}");
        }
    }

    #[test]
    fn braces_may_span_lines_and_hold_equals_signs() {
        let fields = header_fields("ENVI\nnote = {a = b,\nc}\nsamples = 2\n");
        assert_eq!(fields[0], ("note".to_string(), "a = b,\nc".to_string()));
        assert_eq!(fields[1], ("samples".to_string(), "2".to_string()));
    }
}
