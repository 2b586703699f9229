//! PLY body decoding for the three encodings.

use std::io::Read;

use super::header::ParsedHeader;
use super::{PlyColumn, PlyElement, PlyEncoding, PropertyKind};
use crate::io::FileFormat;
use crate::io::stream::ByteStream;
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
pub(super) fn read_body<R: Read>(
    header: &ParsedHeader,
    stream: &mut ByteStream<R>,
) -> Result<Vec<PlyElement>> {
    let mut document = DocumentSink::new(header);
    read_body_into(header, stream, &mut document)?;
    Ok(document.elements)
}

/// Reads the body from `stream` (just past the header), sending every value to `sink`.
pub(super) fn read_body_into<R: Read>(
    header: &ParsedHeader,
    stream: &mut ByteStream<R>,
    sink: &mut impl BodySink,
) -> Result<()> {
    match header.encoding {
        PlyEncoding::Ascii => {
            let mut src = AsciiSource {
                stream,
                line: header.header_lines + 1,
                token: Vec::new(),
            };
            read_elements(header, &mut src, sink)
        }
        PlyEncoding::BinaryLittleEndian | PlyEncoding::BinaryBigEndian => {
            let mut src = BinarySource {
                stream,
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

struct BinarySource<'s, R> {
    stream: &'s mut ByteStream<R>,
    big_endian: bool,
}

impl<R: Read> ValueSource for BinarySource<'_, R> {
    fn scalar(&mut self, ty: ScalarType, what: &dyn Fn() -> String) -> Result<f64> {
        let at = self.location();
        let size = ty.size();
        let buffered = self.stream.buffered();
        let value = if buffered.len() >= size {
            let value = ty.decode(buffered, self.big_endian);
            self.stream.consume(size);
            value
        } else {
            // The value straddles the end of the buffer (or of the file), or nothing is
            // buffered yet.
            let mut word = [0u8; 8];
            let word = &mut word[..size];
            if self.stream.read_exact(word)? {
                ty.decode(word, self.big_endian)
            } else {
                None
            }
        };
        value.ok_or_else(|| Error::UnexpectedEof {
            format: FileFormat::Ply,
            location: at,
            what: what(),
        })
    }

    fn location(&self) -> Location {
        Location::Byte(self.stream.position())
    }

    fn max_remaining(&self, ty: ScalarType) -> u64 {
        self.stream.remaining() / ty.size() as u64
    }
}

struct AsciiSource<'s, R> {
    stream: &'s mut ByteStream<R>,
    /// The line the next byte is on.
    line: usize,
    /// A token that straddled the end of the buffer, gathered.
    token: Vec<u8>,
}

impl<R: Read> AsciiSource<'_, R> {
    /// Moves past whitespace, counting lines.
    fn skip_whitespace(&mut self) -> Result<()> {
        let newline_count = |bytes: &[u8]| bytes.iter().filter(|&&b| b == b'\n').count();
        let buffered = self.stream.buffered();
        if let Some(end) = buffered.iter().position(|b| !b.is_ascii_whitespace()) {
            self.line += newline_count(&buffered[..end]);
            self.stream.consume(end);
            return Ok(());
        }
        let mut newlines = 0;
        self.stream.consume_while(
            |b| b.is_ascii_whitespace(),
            |piece| newlines += newline_count(piece),
        )?;
        self.line += newlines;
        Ok(())
    }
}

/// The value of `token`, read as a `ty` on line `line`.
#[inline]
fn token_value(
    token: &[u8],
    ty: ScalarType,
    line: usize,
    what: &dyn Fn() -> String,
) -> Result<f64> {
    let location = Location::Line(line);
    if token.is_empty() {
        return Err(Error::UnexpectedEof {
            format: FileFormat::Ply,
            location,
            what: what(),
        });
    }
    let token = std::str::from_utf8(token).map_err(|_| Error::Malformed {
        format: FileFormat::Ply,
        location,
        message: format!("non-text bytes in {}", what()),
    })?;
    let bad = |reason: &str| Error::Malformed {
        format: FileFormat::Ply,
        location,
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

impl<R: Read> ValueSource for AsciiSource<'_, R> {
    fn scalar(&mut self, ty: ScalarType, what: &dyn Fn() -> String) -> Result<f64> {
        self.skip_whitespace()?;
        let line = self.line;
        // Most tokens end inside the buffer and are read where they lie.
        let buffered = self.stream.buffered();
        if let Some(end) = buffered.iter().position(u8::is_ascii_whitespace) {
            let value = token_value(&buffered[..end], ty, line, what);
            self.stream.consume(end);
            return value;
        }
        self.token.clear();
        let token = &mut self.token;
        self.stream.consume_while(
            |b| !b.is_ascii_whitespace(),
            |piece| token.extend_from_slice(piece),
        )?;
        token_value(&self.token, ty, line, what)
    }

    fn location(&self) -> Location {
        Location::Line(self.line)
    }

    fn max_remaining(&self, _ty: ScalarType) -> u64 {
        // Each token needs at least one character and one separator.
        self.stream.remaining().div_ceil(2)
    }
}
