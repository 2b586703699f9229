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

pub(super) fn read_body(header: &ParsedHeader, bytes: &[u8]) -> Result<Vec<PlyElement>> {
    let body = bytes.get(header.body_start..).unwrap_or(&[]);
    match header.encoding {
        PlyEncoding::Ascii => {
            let mut src = AsciiSource::new(body, header.header_lines);
            read_elements(header, &mut src)
        }
        PlyEncoding::BinaryLittleEndian | PlyEncoding::BinaryBigEndian => {
            let mut src = BinarySource {
                data: body,
                pos: 0,
                base: header.body_start as u64,
                big_endian: header.encoding == PlyEncoding::BinaryBigEndian,
            };
            read_elements(header, &mut src)
        }
    }
}

fn read_elements(header: &ParsedHeader, src: &mut impl ValueSource) -> Result<Vec<PlyElement>> {
    let mut elements = Vec::with_capacity(header.elements.len());
    for decl in &header.elements {
        // The header size check bounds `count` by the file size, so this allocation is safe.
        let mut columns: Vec<PlyColumn> = decl
            .properties
            .iter()
            .map(|p| match p.kind {
                PropertyKind::Scalar(_) => PlyColumn::Scalar(Vec::with_capacity(decl.count)),
                PropertyKind::List { .. } => {
                    let mut offsets = Vec::with_capacity(decl.count + 1);
                    offsets.push(0);
                    PlyColumn::List {
                        offsets,
                        items: Vec::new(),
                    }
                }
            })
            .collect();
        for record in 0..decl.count {
            for (prop, column) in decl.properties.iter().zip(columns.iter_mut()) {
                let what = || format!("property `{}` of {} {record}", prop.name, decl.name);
                match (prop.kind, column) {
                    (PropertyKind::Scalar(ty), PlyColumn::Scalar(values)) => {
                        values.push(src.scalar(ty, &what)?);
                    }
                    (PropertyKind::List { count, item }, PlyColumn::List { offsets, items }) => {
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
                        for _ in 0..n as u64 {
                            items.push(src.scalar(item, &what)?);
                        }
                        offsets.push(items.len());
                    }
                    // Columns are built from the same declarations, so shapes always match.
                    _ => {}
                }
            }
        }
        elements.push(PlyElement {
            name: decl.name.clone(),
            count: decl.count,
            properties: decl.properties.clone(),
            columns,
        });
    }
    Ok(elements)
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
