//! PLY body decoding for the three encodings.

use super::header::ParsedHeader;
use super::{PlyColumn, PlyElement, PlyEncoding, PropertyKind};
use crate::io::FileFormat;
use crate::{Error, Location, Result, ScalarType};

/// A source of typed values, either ascii tokens or binary words.
trait ValueSource {
    /// Reads one value of type `ty`; `what` names it for error messages (called only when
    /// there is an error, so the hot path allocates nothing).
    fn scalar(&mut self, ty: ScalarType, what: &dyn Fn() -> String) -> Result<f64>;
    /// Where the next value starts.
    fn location(&self) -> Location;
    /// A cheap upper bound on how many more values of type `ty` could follow.
    fn max_remaining(&self, ty: ScalarType) -> u64;
}

/// Where the values of a body go, in file order.
pub(super) trait BodySink {
    /// Record `record`'s value of scalar property `property` of element `element`.
    fn scalar(&mut self, element: usize, property: usize, record: usize, value: f64);
    /// The next record's list of property `property` of element `element`.
    fn list(&mut self, element: usize, property: usize, items: &[f64]);
    /// Every record of element `element` has been read.
    fn element_done(&mut self, element: usize);
}

/// The body as [`PlyElement`]s: every value, as `f64`.
pub(super) fn read_body(header: &ParsedHeader, bytes: &[u8]) -> Result<Vec<PlyElement>> {
    let mut document = DocumentSink::new(header);
    read_body_into(header, bytes, &mut document)?;
    Ok(document.elements)
}

/// Reads the body, sending every value to `sink`.
pub(super) fn read_body_into(
    header: &ParsedHeader,
    bytes: &[u8],
    sink: &mut impl BodySink,
) -> Result<()> {
    let body = bytes.get(header.body_start..).unwrap_or(&[]);
    match header.encoding {
        PlyEncoding::Ascii => {
            let mut src = AsciiSource::new(body, header.header_lines);
            read_elements(header, &mut src, sink)
        }
        PlyEncoding::BinaryLittleEndian | PlyEncoding::BinaryBigEndian => {
            let mut src = BinarySource {
                data: body,
                pos: 0,
                base: header.body_start as u64,
                big_endian: header.encoding == PlyEncoding::BinaryBigEndian,
            };
            read_elements(header, &mut src, sink)
        }
    }
}

fn read_elements(
    header: &ParsedHeader,
    src: &mut impl ValueSource,
    sink: &mut impl BodySink,
) -> Result<()> {
    let mut items = Vec::new();
    for (element, decl) in header.elements.iter().enumerate() {
        for record in 0..decl.count {
            for (property, prop) in decl.properties.iter().enumerate() {
                let what = || format!("property `{}` of {} {record}", prop.name, decl.name);
                match prop.kind {
                    PropertyKind::Scalar(ty) => {
                        sink.scalar(element, property, record, src.scalar(ty, &what)?);
                    }
                    PropertyKind::List { count, item } => {
                        let at = src.location();
                        let n = src.scalar(count, &what)?;
                        let remaining = src.max_remaining(item);
                        if n < 0.0 || n > remaining as f64 {
                            return Err(Error::ListCountOverflow {
                                format: FileFormat::Ply,
                                location: at,
                                count: n as i128,
                                reason: if n < 0.0 {
                                    "a negative length".into()
                                } else {
                                    format!("but at most {remaining} items can follow in the file")
                                },
                            });
                        }
                        items.clear();
                        for _ in 0..n as u64 {
                            items.push(src.scalar(item, &what)?);
                        }
                        sink.list(element, property, &items);
                    }
                }
            }
        }
        sink.element_done(element);
    }
    Ok(())
}

/// Collects a body into [`PlyElement`]s.
struct DocumentSink {
    elements: Vec<PlyElement>,
}

impl DocumentSink {
    fn new(header: &ParsedHeader) -> Self {
        // The header size check bounds every `count` by the file size, so these
        // allocations are safe.
        let elements = header
            .elements
            .iter()
            .map(|decl| PlyElement {
                name: decl.name.clone(),
                count: decl.count,
                properties: decl.properties.clone(),
                columns: decl
                    .properties
                    .iter()
                    .map(|p| match p.kind {
                        PropertyKind::Scalar(_) => {
                            PlyColumn::Scalar(Vec::with_capacity(decl.count))
                        }
                        PropertyKind::List { .. } => {
                            let mut offsets = Vec::with_capacity(decl.count + 1);
                            offsets.push(0);
                            PlyColumn::List {
                                offsets,
                                items: Vec::new(),
                            }
                        }
                    })
                    .collect(),
            })
            .collect();
        DocumentSink { elements }
    }
}

impl BodySink for DocumentSink {
    fn scalar(&mut self, element: usize, property: usize, _record: usize, value: f64) {
        if let PlyColumn::Scalar(values) = &mut self.elements[element].columns[property] {
            values.push(value);
        }
    }

    fn list(&mut self, element: usize, property: usize, list: &[f64]) {
        if let PlyColumn::List { offsets, items } = &mut self.elements[element].columns[property] {
            items.extend_from_slice(list);
            offsets.push(items.len());
        }
    }

    fn element_done(&mut self, _element: usize) {}
}

struct BinarySource<'a> {
    data: &'a [u8],
    pos: usize,
    base: u64,
    big_endian: bool,
}

impl ValueSource for BinarySource<'_> {
    fn scalar(&mut self, ty: ScalarType, what: &dyn Fn() -> String) -> Result<f64> {
        let value = self
            .data
            .get(self.pos..)
            .and_then(|rest| ty.decode(rest, self.big_endian))
            .ok_or_else(|| Error::UnexpectedEof {
                format: FileFormat::Ply,
                location: self.location(),
                what: what(),
            })?;
        self.pos += ty.size();
        Ok(value)
    }

    fn location(&self) -> Location {
        Location::Byte(self.base + self.pos as u64)
    }

    fn max_remaining(&self, ty: ScalarType) -> u64 {
        (self.data.len().saturating_sub(self.pos) / ty.size()) as u64
    }
}

struct AsciiSource<'a> {
    data: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> AsciiSource<'a> {
    fn new(data: &'a [u8], header_lines: usize) -> Self {
        Self {
            data,
            pos: 0,
            line: header_lines + 1,
        }
    }

    fn next_token(&mut self, what: &dyn Fn() -> String) -> Result<&'a str> {
        while let Some(&b) = self.data.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while self
            .data
            .get(self.pos)
            .is_some_and(|b| !b.is_ascii_whitespace())
        {
            self.pos += 1;
        }
        if start == self.pos {
            return Err(Error::UnexpectedEof {
                format: FileFormat::Ply,
                location: Location::Line(self.line),
                what: what(),
            });
        }
        std::str::from_utf8(&self.data[start..self.pos]).map_err(|_| Error::Malformed {
            format: FileFormat::Ply,
            location: Location::Line(self.line),
            message: format!("non-text bytes in {}", what()),
        })
    }
}

impl ValueSource for AsciiSource<'_> {
    fn scalar(&mut self, ty: ScalarType, what: &dyn Fn() -> String) -> Result<f64> {
        let token = self.next_token(what)?;
        let bad = |reason: &str| Error::Malformed {
            format: FileFormat::Ply,
            location: Location::Line(self.line),
            message: format!("`{token}` in {} {reason}", what()),
        };
        let value: f64 = token.parse().map_err(|_| bad("is not a number"))?;
        if ty.is_integer() {
            let (lo, hi) = ty.range();
            if value.fract() != 0.0 || value < lo || value > hi {
                return Err(bad(&format!("is not a valid {ty}")));
            }
        }
        // A `float` token means the nearest single-precision value, as in a binary file.
        Ok(if ty == ScalarType::F32 {
            ty.quantize(value)
        } else {
            value
        })
    }

    fn location(&self) -> Location {
        Location::Line(self.line)
    }

    fn max_remaining(&self, _ty: ScalarType) -> u64 {
        // Each token needs at least one character and one separator.
        (self.data.len().saturating_sub(self.pos) as u64).div_ceil(2)
    }
}
