//! PLY encoding.

use std::io::Write;

use super::view::{ColumnView, DocumentView};
use super::{PlyDocument, PlyEncoding, PropertyKind};
use super::{check_column_lengths, check_list_offsets};
use crate::{Error, Result, ScalarType};

fn io(source: std::io::Error) -> Error {
    Error::Write { source }
}

/// Writes `doc` in `doc.encoding`. Values are converted with [`ScalarType::quantize`]
/// (integers rounded and clamped); columns must hold `count` records each.
pub fn write_ply(doc: &PlyDocument, out: &mut impl Write) -> Result<()> {
    write_view(&DocumentView::of_document(doc), out)
}

/// Writes the viewed values as [`write_ply`] writes a document holding them.
pub(crate) fn write_view(doc: &DocumentView<'_>, out: &mut impl Write) -> Result<()> {
    for element in &doc.elements {
        let lengths = element.columns.iter().map(ColumnView::len);
        check_column_lengths(&element.name, element.count, &element.properties, lengths)?;
        for (property, column) in element.properties.iter().zip(&element.columns) {
            if let ColumnView::Stored(column) = column {
                check_list_offsets(&element.name, property, column)?;
            }
        }
    }
    write_header(doc, out).map_err(io)?;
    let ascii = doc.encoding == PlyEncoding::Ascii;
    let mut buf: Vec<u8> = Vec::with_capacity(1 << 16);
    for element in &doc.elements {
        for record in 0..element.count {
            for (i, (prop, column)) in element.properties.iter().zip(&element.columns).enumerate() {
                if ascii && i > 0 {
                    buf.push(b' ');
                }
                // Only the declared kind's value is looked up: this runs for every value.
                let written = match prop.kind {
                    PropertyKind::Scalar(ty) => column.scalar(record).map(|value| {
                        put(&mut buf, doc.encoding, ty, value);
                    }),
                    PropertyKind::List { count, item } => match column.list(record) {
                        None => None,
                        Some(list) => {
                            let (_, max) = count.range();
                            if list.len() as f64 > max {
                                return Err(Error::ListCountOverflow {
                                    format: crate::io::FileFormat::Ply,
                                    location: crate::Location::Byte(0),
                                    count: list.len() as i128,
                                    reason: format!("more than a `{count}` length can express"),
                                });
                            }
                            put(&mut buf, doc.encoding, count, list.len() as f64);
                            for v in list.items() {
                                if ascii {
                                    buf.push(b' ');
                                }
                                put(&mut buf, doc.encoding, item, v);
                            }
                            Some(())
                        }
                    },
                };
                if written.is_none() {
                    return Err(Error::IncompatibleLayout {
                        reason: format!(
                            "column of `{}` does not match its declared kind",
                            prop.name
                        ),
                    });
                }
            }
            if ascii {
                buf.push(b'\n');
            }
            if buf.len() >= 1 << 16 {
                out.write_all(&buf).map_err(io)?;
                buf.clear();
            }
        }
    }
    out.write_all(&buf).map_err(io)?;
    out.flush().map_err(io)
}

fn write_header(doc: &DocumentView<'_>, out: &mut impl Write) -> std::io::Result<()> {
    let mut h = String::from("ply\n");
    h.push_str(&format!("format {} 1.0\n", doc.encoding.keyword()));
    for c in doc.comments {
        h.push_str(&format!("comment {}\n", single_line(c)));
    }
    for c in doc.obj_info {
        h.push_str(&format!("obj_info {}\n", single_line(c)));
    }
    for e in &doc.elements {
        h.push_str(&format!("element {} {}\n", e.name, e.count));
        for p in &e.properties {
            match p.kind {
                PropertyKind::Scalar(t) => h.push_str(&format!("property {t} {}\n", p.name)),
                PropertyKind::List { count, item } => {
                    h.push_str(&format!("property list {count} {item} {}\n", p.name))
                }
            }
        }
    }
    h.push_str("end_header\n");
    out.write_all(h.as_bytes())
}

fn single_line(s: &str) -> String {
    s.replace(['\n', '\r'], " ")
}

fn put(buf: &mut Vec<u8>, encoding: PlyEncoding, ty: ScalarType, value: f64) {
    match encoding {
        PlyEncoding::Ascii => ty.encode_text(value, buf),
        PlyEncoding::BinaryLittleEndian => ty.encode(value, false, buf),
        PlyEncoding::BinaryBigEndian => ty.encode(value, true, buf),
    }
}
