//! PLY header parsing and the size check done before any allocation.

use std::io::Read;

use super::{PlyEncoding, PlyProperty, PropertyKind};
use crate::io::FileFormat;
use crate::io::stream::ByteStream;
use crate::{Error, Location, Result, ScalarType};

/// A declared element before its data is read.
#[derive(Debug, Clone)]
pub(super) struct ElementDecl {
    pub name: String,
    pub count: usize,
    pub properties: Vec<PlyProperty>,
}

/// Everything the header says, plus where the body starts.
#[derive(Debug, Clone)]
pub(super) struct ParsedHeader {
    pub encoding: PlyEncoding,
    pub comments: Vec<String>,
    pub obj_info: Vec<String>,
    pub elements: Vec<ElementDecl>,
    /// Byte offset of the first body byte.
    pub body_start: u64,
    /// Number of header lines (the ascii body's line numbers continue from here).
    pub header_lines: usize,
}

fn malformed(line: usize, message: impl Into<String>) -> Error {
    Error::Malformed {
        format: FileFormat::Ply,
        location: Location::Line(line),
        message: message.into(),
    }
}

fn scalar_type(line: usize, name: &str) -> Result<ScalarType> {
    ScalarType::from_ply_name(name).ok_or_else(|| Error::UnknownPropertyType {
        line,
        type_name: name.to_string(),
    })
}

/// Headers longer than this are rejected (real headers are a few hundred bytes).
const MAX_HEADER_BYTES: u64 = 1 << 20;

/// Reads the header from the start of `stream`, leaving it at the first body byte, and
/// checks the record counts against the stream's length.
pub(super) fn parse_header<R: Read>(stream: &mut ByteStream<R>) -> Result<ParsedHeader> {
    let mut line_no = 0usize;
    let mut encoding = None;
    let mut comments = Vec::new();
    let mut obj_info = Vec::new();
    let mut elements: Vec<ElementDecl> = Vec::new();
    let mut raw = Vec::new();
    loop {
        if stream.at_end()? {
            return Err(Error::UnexpectedEof {
                format: FileFormat::Ply,
                location: Location::Line(line_no + 1),
                what: "the header (no `end_header` line)".into(),
            });
        }
        if stream.position() > MAX_HEADER_BYTES {
            return Err(malformed(
                line_no,
                "header longer than 1 MiB without `end_header`",
            ));
        }
        stream.read_line(&mut raw)?;
        line_no += 1;
        let line = std::str::from_utf8(&raw)
            .map_err(|_| malformed(line_no, "header line is not valid text"))?
            .trim_end_matches('\r');
        if line_no == 1 {
            if line.trim() != "ply" {
                return Err(malformed(1, "file does not start with `ply`"));
            }
            continue;
        }
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword {
            "format" => {
                let enc = match words.next() {
                    Some("ascii") => PlyEncoding::Ascii,
                    Some("binary_little_endian") => PlyEncoding::BinaryLittleEndian,
                    Some("binary_big_endian") => PlyEncoding::BinaryBigEndian,
                    other => {
                        return Err(malformed(
                            line_no,
                            format!("unknown format `{}`", other.unwrap_or("")),
                        ));
                    }
                };
                if words.next() != Some("1.0") {
                    return Err(malformed(line_no, "only PLY version 1.0 is supported"));
                }
                encoding = Some(enc);
            }
            "comment" => comments.push(rest_of(line, "comment")),
            "obj_info" => obj_info.push(rest_of(line, "obj_info")),
            "element" => {
                let (Some(name), Some(count), None) = (words.next(), words.next(), words.next())
                else {
                    return Err(malformed(line_no, "expected `element NAME COUNT`"));
                };
                let count: u64 = count.parse().map_err(|_| {
                    malformed(
                        line_no,
                        format!("element count `{count}` is not a non-negative integer"),
                    )
                })?;
                let count = usize::try_from(count).map_err(|_| {
                    malformed(
                        line_no,
                        format!("element count {count} exceeds this platform"),
                    )
                })?;
                elements.push(ElementDecl {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(malformed(line_no, "property before any element"));
                };
                let parts: Vec<&str> = words.collect();
                let (kind, name) = match parts.as_slice() {
                    ["list", count, item, name] => (
                        PropertyKind::List {
                            count: scalar_type(line_no, count)?,
                            item: scalar_type(line_no, item)?,
                        },
                        *name,
                    ),
                    [ty, name] if *ty != "list" => {
                        (PropertyKind::Scalar(scalar_type(line_no, ty)?), *name)
                    }
                    _ => {
                        return Err(malformed(
                            line_no,
                            "expected `property TYPE NAME` or `property list COUNT_TYPE ITEM_TYPE NAME`",
                        ));
                    }
                };
                if let PropertyKind::List { count, .. } = kind
                    && !count.is_integer()
                {
                    return Err(malformed(
                        line_no,
                        "list count type must be an integer type",
                    ));
                }
                if element.properties.iter().any(|p| p.name == name) {
                    return Err(malformed(line_no, format!("duplicate property `{name}`")));
                }
                element.properties.push(PlyProperty {
                    name: name.to_string(),
                    kind,
                });
            }
            "end_header" => break,
            other => {
                return Err(malformed(
                    line_no,
                    format!("unknown header keyword `{other}`"),
                ));
            }
        }
    }
    let encoding = encoding.ok_or_else(|| malformed(line_no, "header has no `format` line"))?;
    let header = ParsedHeader {
        encoding,
        comments,
        obj_info,
        elements,
        body_start: stream.position(),
        header_lines: line_no,
    };
    check_counts_against_size(&header, stream.len())?;
    Ok(header)
}

fn rest_of(line: &str, keyword: &str) -> String {
    line.trim_start()
        .strip_prefix(keyword)
        .map(|s| s.strip_prefix(' ').unwrap_or(s))
        .unwrap_or("")
        .to_string()
}

/// Minimum number of body bytes one record of `element` occupies.
fn min_record_bytes(element: &ElementDecl, encoding: PlyEncoding) -> u128 {
    match encoding {
        // Every property is at least one token of one character plus one separator.
        PlyEncoding::Ascii => 2 * element.properties.len() as u128,
        _ => element
            .properties
            .iter()
            .map(|p| match p.kind {
                PropertyKind::Scalar(t) => t.size() as u128,
                PropertyKind::List { count, .. } => count.size() as u128,
            })
            .sum(),
    }
}

/// Rejects headers whose record counts cannot fit in the bytes after the header.
fn check_counts_against_size(header: &ParsedHeader, file_len: u64) -> Result<()> {
    let available = file_len.saturating_sub(header.body_start);
    // The last ascii record may lack its trailing separator.
    let slack = u128::from(header.encoding == PlyEncoding::Ascii);
    let mut needed: u128 = 0;
    for element in &header.elements {
        let record = min_record_bytes(element, header.encoding);
        needed = needed.saturating_add(record.saturating_mul(element.count as u128));
        if needed > u128::from(available) + slack {
            return Err(Error::HeaderExceedsFile {
                format: FileFormat::Ply,
                element: element.name.clone(),
                declared: element.count as u64,
                needed_bytes: needed,
                available_bytes: available,
            });
        }
        if record == 0 && element.count > 0 && element.count as u64 > file_len.max(1 << 20) {
            // Elements without properties occupy no bytes; cap them so a header cannot make
            // us allocate a huge number of empty records.
            return Err(Error::HeaderExceedsFile {
                format: FileFormat::Ply,
                element: element.name.clone(),
                declared: element.count as u64,
                needed_bytes: 0,
                available_bytes: available,
            });
        }
    }
    Ok(())
}
