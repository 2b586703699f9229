//! A PCD file's text header: the fields, how each is stored, how many points follow and
//! how.

use super::{PcdEncoding, ends_early, malformed_at_line};
use crate::io::stream::ByteStream;
use crate::{Error, Result, ScalarType};
use std::io::Read;

/// How a field's values are stored: `TYPE` (`I`, `U` or `F`) and `SIZE` in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FieldType {
    /// A signed integer of 1, 2, 4 or 8 bytes.
    Signed(usize),
    /// An unsigned integer of 1, 2, 4 or 8 bytes.
    Unsigned(usize),
    /// A float of 4 or 8 bytes.
    Float(usize),
}

impl FieldType {
    /// The type a `TYPE` letter and a `SIZE` name, if PCD has it.
    fn parse(letter: &str, size: usize) -> Option<Self> {
        match (letter, size) {
            ("I", 1 | 2 | 4 | 8) => Some(FieldType::Signed(size)),
            ("U", 1 | 2 | 4 | 8) => Some(FieldType::Unsigned(size)),
            ("F", 4 | 8) => Some(FieldType::Float(size)),
            _ => None,
        }
    }

    /// The type of `storage`, as written.
    pub(crate) fn of(storage: ScalarType) -> Self {
        match storage {
            ScalarType::I8 => FieldType::Signed(1),
            ScalarType::U8 => FieldType::Unsigned(1),
            ScalarType::I16 => FieldType::Signed(2),
            ScalarType::U16 => FieldType::Unsigned(2),
            ScalarType::I32 => FieldType::Signed(4),
            ScalarType::U32 => FieldType::Unsigned(4),
            ScalarType::F32 => FieldType::Float(4),
            ScalarType::F64 => FieldType::Float(8),
        }
    }

    /// Bytes a value takes.
    pub(crate) fn size(self) -> usize {
        match self {
            FieldType::Signed(size) | FieldType::Unsigned(size) | FieldType::Float(size) => size,
        }
    }

    /// The `TYPE` letter.
    pub(crate) fn letter(self) -> char {
        match self {
            FieldType::Signed(_) => 'I',
            FieldType::Unsigned(_) => 'U',
            FieldType::Float(_) => 'F',
        }
    }

    /// The attribute storage that holds the type's values: itself, or `double` for
    /// 64-bit integers, which no attribute type holds exactly.
    pub(crate) fn storage(self) -> ScalarType {
        match self {
            FieldType::Signed(1) => ScalarType::I8,
            FieldType::Unsigned(1) => ScalarType::U8,
            FieldType::Signed(2) => ScalarType::I16,
            FieldType::Unsigned(2) => ScalarType::U16,
            FieldType::Signed(4) => ScalarType::I32,
            FieldType::Unsigned(4) => ScalarType::U32,
            FieldType::Float(4) => ScalarType::F32,
            _ => ScalarType::F64,
        }
    }

    /// A value decoded from its little-endian bytes (`bytes` holds exactly
    /// [`Self::size`]): through [`ScalarType::decode`], but for 64-bit integers, which it
    /// has no type for.
    pub(crate) fn decode(self, bytes: &[u8]) -> f64 {
        let mut word = [0u8; 8];
        let n = bytes.len().min(8);
        word[..n].copy_from_slice(&bytes[..n]);
        match self {
            FieldType::Signed(8) => i64::from_le_bytes(word) as f64,
            FieldType::Unsigned(8) => u64::from_le_bytes(word) as f64,
            _ => self.storage().decode(&word, false).unwrap_or(0.0),
        }
    }
}

/// One `FIELDS` entry.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Field {
    /// Its name (`_` marks padding).
    pub name: String,
    /// How each value is stored.
    pub ty: FieldType,
    /// Values a point (`COUNT`).
    pub count: usize,
}

impl Field {
    /// Bytes the field takes in a point's record.
    pub(crate) fn bytes(&self) -> usize {
        self.ty.size() * self.count
    }
}

/// A parsed header.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Header {
    /// The `VERSION`, as written (`0.7`, `.7`), if given.
    pub version: Option<String>,
    /// The fields, in record order.
    pub fields: Vec<Field>,
    /// `WIDTH` and `HEIGHT`: an organised cloud's columns and rows (height 1 for a list).
    pub width: u64,
    /// See `width`.
    pub height: u64,
    /// `VIEWPOINT`: the sensor's position and orientation (`tx ty tz qw qx qy qz`).
    pub viewpoint: [f64; 7],
    /// `POINTS`.
    pub points: u64,
    /// `DATA`.
    pub encoding: PcdEncoding,
    /// The comment lines, without their `#`.
    pub comments: Vec<String>,
}

impl Header {
    /// Bytes a point's record takes in a binary file.
    pub(crate) fn record_bytes(&self) -> usize {
        self.fields.iter().map(Field::bytes).sum()
    }

    /// Values a point's line holds in an ASCII file.
    pub(crate) fn values_per_point(&self) -> usize {
        self.fields.iter().map(|f| f.count).sum()
    }
}

/// The identity viewpoint: at the origin, not turned.
pub(crate) const IDENTITY_VIEWPOINT: [f64; 7] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];

/// The header keywords, in the order PCD 0.7 writes them.
const KEYWORDS: [&str; 10] = [
    "VERSION",
    "FIELDS",
    "SIZE",
    "TYPE",
    "COUNT",
    "WIDTH",
    "HEIGHT",
    "VIEWPOINT",
    "POINTS",
    "DATA",
];

/// The header's lines, read up to and including `DATA`, as (line number, keyword,
/// values); comments go to `comments`.
fn header_lines<R: Read>(
    stream: &mut ByteStream<R>,
    comments: &mut Vec<String>,
) -> Result<Vec<(usize, String, Vec<String>)>> {
    let not_text = |at| Error::Malformed {
        format: crate::io::FileFormat::Pcd,
        location: crate::Location::Byte(at),
        message: "the header is not text".into(),
    };
    let mut raw = Vec::new();
    let mut lines = Vec::new();
    let mut number = 0;
    loop {
        let Some(line) = stream.read_text_line(&mut raw, not_text)? else {
            return Err(ends_early(stream.position(), "the header's `DATA` line"));
        };
        number += 1;
        let line = line.trim();
        if let Some(comment) = line.strip_prefix('#') {
            // The format's own banner (`# .PCD v0.7 - Point Cloud Data file format`) is
            // not the file's comment: writers put it in every file.
            let comment = comment.trim();
            if !comment.starts_with(".PCD v") {
                comments.push(comment.to_string());
            }
            continue;
        }
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        let keyword = keyword.to_ascii_uppercase();
        if !KEYWORDS.contains(&keyword.as_str()) && keyword != "COLUMNS" {
            return Err(malformed_at_line(
                number,
                format!("`{keyword}` is not a PCD header keyword"),
            ));
        }
        let values = words.map(str::to_string).collect();
        let done = keyword == "DATA";
        lines.push((number, keyword, values));
        if done {
            return Ok(lines);
        }
    }
}

/// A header value parsed as `T`, or an error naming the keyword and line.
fn number<T: std::str::FromStr>(line: usize, keyword: &str, word: &str) -> Result<T> {
    word.parse().map_err(|_| {
        malformed_at_line(
            line,
            format!("`{word}` in `{keyword}` is not a number of the kind it needs"),
        )
    })
}

/// Reads the header from the start of `stream`, leaving it at the first byte of data.
pub(crate) fn read_header<R: Read>(stream: &mut ByteStream<R>) -> Result<Header> {
    let mut comments = Vec::new();
    let lines = header_lines(stream, &mut comments)?;
    let data_line = lines.last().map_or(0, |(n, _, _)| *n);
    let find = |keyword: &str| {
        lines
            .iter()
            .find(|(_, k, _)| k == keyword || (keyword == "FIELDS" && k == "COLUMNS"))
    };
    let single = |keyword: &str| -> Result<Option<u64>> {
        match find(keyword) {
            None => Ok(None),
            Some((n, _, values)) => match values.as_slice() {
                [one] => number(*n, keyword, one).map(Some),
                _ => Err(malformed_at_line(
                    *n,
                    format!("`{keyword}` takes one number"),
                )),
            },
        }
    };
    let Some((fields_line, _, names)) = find("FIELDS") else {
        return Err(malformed_at_line(
            data_line,
            "no `FIELDS` line before `DATA`",
        ));
    };
    let per_field = |keyword: &str| -> Result<Option<(usize, &Vec<String>)>> {
        match find(keyword) {
            None => Ok(None),
            Some((n, _, values)) if values.len() == names.len() => Ok(Some((*n, values))),
            Some((n, _, values)) => Err(malformed_at_line(
                *n,
                format!(
                    "`{keyword}` gives {} values for {} fields",
                    values.len(),
                    names.len()
                ),
            )),
        }
    };
    let (Some((size_line, sizes)), Some((type_line, types))) =
        (per_field("SIZE")?, per_field("TYPE")?)
    else {
        return Err(malformed_at_line(
            data_line,
            "`SIZE` and `TYPE` must both be given before `DATA`",
        ));
    };
    let counts = per_field("COUNT")?;
    let mut fields = Vec::with_capacity(names.len());
    for (k, name) in names.iter().enumerate() {
        if name != "_" && names[..k].contains(name) {
            return Err(malformed_at_line(
                *fields_line,
                format!("the field `{name}` is named twice"),
            ));
        }
        let size: usize = number(size_line, "SIZE", &sizes[k])?;
        let letter = types[k].to_ascii_uppercase();
        let ty = FieldType::parse(&letter, size).ok_or_else(|| {
            malformed_at_line(
                type_line,
                format!(
                    "field `{name}`: TYPE {letter} with SIZE {size} (I and U take 1, 2, 4 or 8 \
                     bytes, F 4 or 8)"
                ),
            )
        })?;
        let count = match counts {
            Some((n, values)) => number(n, "COUNT", &values[k])?,
            None => 1,
        };
        if count == 0 {
            let n = counts.map_or(data_line, |(n, _)| n);
            return Err(malformed_at_line(n, format!("field `{name}` has COUNT 0")));
        }
        fields.push(Field {
            name: name.clone(),
            ty,
            count,
        });
    }
    for axis in ["x", "y", "z"] {
        if !fields.iter().any(|f| f.name == axis && f.count == 1) {
            return Err(malformed_at_line(
                *fields_line,
                format!(
                    "no `{axis}` field of one value: a PCD file without x, y and z holds no positions"
                ),
            ));
        }
    }
    let width = single("WIDTH")?;
    let height = single("HEIGHT")?.unwrap_or(1);
    let points = single("POINTS")?;
    let (width, points) = match (width, points) {
        (Some(w), Some(p)) => (w, p),
        (Some(w), None) => (w, w.saturating_mul(height)),
        (None, Some(p)) if height == 1 => (p, p),
        _ => {
            return Err(malformed_at_line(
                data_line,
                "neither `WIDTH` nor `POINTS` says how many points follow",
            ));
        }
    };
    if u128::from(width) * u128::from(height) != u128::from(points) {
        return Err(malformed_at_line(
            data_line,
            format!("WIDTH {width} × HEIGHT {height} is not POINTS {points}"),
        ));
    }
    let viewpoint = match find("VIEWPOINT") {
        None => IDENTITY_VIEWPOINT,
        Some((n, _, values)) if values.len() == 7 => {
            let mut viewpoint = [0.0; 7];
            for (v, word) in viewpoint.iter_mut().zip(values) {
                *v = number(*n, "VIEWPOINT", word)?;
            }
            viewpoint
        }
        Some((n, _, _)) => {
            return Err(malformed_at_line(
                *n,
                "`VIEWPOINT` takes seven numbers: tx ty tz qw qx qy qz",
            ));
        }
    };
    let encoding = match lines.last().map(|(_, _, v)| v.as_slice()) {
        Some([word]) => PcdEncoding::from_keyword(word).ok_or_else(|| {
            malformed_at_line(
                data_line,
                format!("DATA `{word}` (ascii, binary or binary_compressed are read)"),
            )
        })?,
        _ => {
            return Err(malformed_at_line(
                data_line,
                "`DATA` takes one word: ascii, binary or binary_compressed",
            ));
        }
    };
    Ok(Header {
        version: find("VERSION").and_then(|(_, _, v)| v.first().cloned()),
        fields,
        width,
        height,
        viewpoint,
        points,
        encoding,
        comments,
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    fn parse(text: &str) -> Result<Header> {
        read_header(&mut ByteStream::of_bytes(text.as_bytes()))
    }

    #[test]
    fn a_full_header_is_read_with_defaults_where_lines_are_missing() {
        let header = parse(
            "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\n\
             SIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 3\nHEIGHT 2\n\
             VIEWPOINT 1 2 3 1 0 0 0\nPOINTS 6\nDATA binary\n",
        )
        .unwrap();
        assert_eq!(header.fields.len(), 4);
        assert_eq!(header.fields[3].ty, FieldType::Unsigned(4));
        assert_eq!((header.width, header.height, header.points), (3, 2, 6));
        assert_eq!(header.viewpoint[..3], [1.0, 2.0, 3.0]);
        assert_eq!(header.encoding, PcdEncoding::Binary);
        assert!(header.comments.is_empty(), "the banner is no comment");
        assert_eq!(header.record_bytes(), 16);
        // Older files: no COUNT, VIEWPOINT or POINTS.
        let old = parse("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 5\nDATA ascii\n").unwrap();
        assert_eq!((old.points, old.viewpoint), (5, IDENTITY_VIEWPOINT));
        assert!(old.fields.iter().all(|f| f.count == 1));
    }

    #[test]
    fn inconsistent_headers_are_refused_at_their_line() {
        let cases = [
            (
                "FIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n",
                2,
            ),
            (
                "FIELDS x y z\nSIZE 4 4 4\nTYPE F F Q\nWIDTH 1\nDATA ascii\n",
                3,
            ),
            (
                "FIELDS x y z\nSIZE 4 4 3\nTYPE F F F\nWIDTH 1\nDATA ascii\n",
                3,
            ),
            (
                "FIELDS x y x\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n",
                1,
            ),
            (
                "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nPOINTS 3\nDATA ascii\n",
                6,
            ),
            (
                "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA xml\n",
                5,
            ),
            (
                "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH -1\nDATA ascii\n",
                4,
            ),
            (
                "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOLOUR 1\nDATA ascii\n",
                4,
            ),
            (
                "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 0 1\nWIDTH 1\nDATA ascii\n",
                4,
            ),
            ("FIELDS x y z\nTYPE F F F\nWIDTH 1\nDATA ascii\n", 4),
        ];
        for (text, line) in cases {
            match parse(text) {
                Err(Error::Malformed {
                    location: crate::Location::Line(at),
                    ..
                }) => assert_eq!(at, line, "{text}"),
                other => panic!("{text}: {other:?}"),
            }
        }
        assert!(matches!(
            parse("FIELDS x y z\nSIZE 4 4 4\n"),
            Err(Error::UnexpectedEof { .. })
        ));
    }

    #[test]
    fn values_decode_from_every_stored_type() {
        let cases: [(FieldType, &[u8], f64); 7] = [
            (FieldType::Signed(1), &[0xfe], -2.0),
            (FieldType::Unsigned(1), &[0xfe], 254.0),
            (FieldType::Signed(2), &[0x00, 0x80], -32768.0),
            (FieldType::Unsigned(4), &[1, 0, 0, 0x80], 2147483649.0),
            (FieldType::Signed(8), &[0xff; 8], -1.0),
            (FieldType::Float(4), &1.5f32.to_le_bytes(), 1.5),
            (FieldType::Float(8), &(-0.1f64).to_le_bytes(), -0.1),
        ];
        for (ty, bytes, value) in cases {
            assert_eq!(ty.decode(bytes), value, "{ty:?}");
        }
        for storage in ScalarType::ALL {
            assert_eq!(FieldType::of(storage).storage(), storage);
        }
    }
}
