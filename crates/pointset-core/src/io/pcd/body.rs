//! A PCD file's points after its header: ASCII lines, binary records, or LZF-compressed
//! columns. Each is checked against the bytes present before its columns are allocated.

use std::io::Read;

use super::header::Header;
use super::{Columns, PcdEncoding, ends_early, lzf, malformed_at_byte};
use crate::io::FileFormat;
use crate::io::stream::ByteStream;
use crate::{Error, Location, Result};

/// The points `header` declares, read from `stream` (at the first byte after the header)
/// into columns.
pub(super) fn read_columns<R: Read>(
    header: &Header,
    stream: &mut ByteStream<R>,
) -> Result<Columns> {
    let too_many = || Error::HeaderExceedsFile {
        format: FileFormat::Pcd,
        element: "point".into(),
        declared: header.points,
        needed_bytes: u128::MAX,
        available_bytes: stream.remaining(),
    };
    let points = usize::try_from(header.points).map_err(|_| too_many())?;
    match header.encoding {
        PcdEncoding::Binary => read_records(header, points, stream),
        PcdEncoding::Ascii => read_lines(header, points, stream),
        PcdEncoding::BinaryCompressed => read_compressed(header, points, stream),
    }
}

/// The error of `declared` records of `element` needing `needed` bytes where `stream`
/// has fewer, if it has.
fn check_room<R: Read>(
    (declared, element): (u64, &str),
    needed: u128,
    stream: &ByteStream<R>,
) -> Result<()> {
    let available = stream.remaining();
    if needed > u128::from(available) {
        return Err(Error::HeaderExceedsFile {
            format: FileFormat::Pcd,
            element: element.into(),
            declared,
            needed_bytes: needed,
            available_bytes: available,
        });
    }
    Ok(())
}

/// Each field's offset in a point's binary record.
fn record_offsets(header: &Header) -> Vec<usize> {
    header
        .fields
        .iter()
        .scan(0, |at, field| {
            let offset = *at;
            *at += field.bytes();
            Some(offset)
        })
        .collect()
}

/// A note on what follows the last point, if anything does: `count` of `unit`.
fn note_trailing(columns: &mut Columns, count: u64, unit: &str) {
    if count > 0 {
        columns
            .notes
            .push(format!("{count} {unit} after the last PCD point skipped"));
    }
}

/// `DATA binary`: a record a point.
fn read_records<R: Read>(
    header: &Header,
    points: usize,
    stream: &mut ByteStream<R>,
) -> Result<Columns> {
    let record_bytes = header.record_bytes();
    let needed = points as u128 * record_bytes as u128;
    check_room((header.points, "point"), needed, stream)?;
    let offsets = record_offsets(header);
    let mut columns = Columns::new(header, points);
    let mut record = vec![0u8; record_bytes];
    for point in 0..points {
        if !stream.read_exact(&mut record)? {
            return Err(ends_early(stream.position(), format!("point {point}")));
        }
        for (f, (field, &at)) in header.fields.iter().zip(&offsets).enumerate() {
            if field.count == 1 {
                columns.put_bytes(f, point, &record[at..at + field.ty.size()]);
            }
        }
    }
    note_trailing(&mut columns, stream.remaining(), "bytes");
    Ok(columns)
}

/// `DATA ascii`: a line a point, its values separated by white space.
fn read_lines<R: Read>(
    header: &Header,
    points: usize,
    stream: &mut ByteStream<R>,
) -> Result<Columns> {
    let values = header.values_per_point();
    // A value takes at least a character and a separator (the last line's end may be
    // missing).
    let least = (points as u128 * values as u128 * 2).saturating_sub(1);
    check_room((header.points, "point"), least, stream)?;
    let not_text = |at| malformed_at_byte(at, "a point's line is not text");
    let mut raw = Vec::new();
    let mut columns = Columns::new(header, points);
    let mut point = 0;
    let mut trailing = 0;
    loop {
        let line_start = stream.position();
        let Some(line) = stream.read_text_line(&mut raw, not_text)? else {
            break;
        };
        let words: Vec<&str> = line.split_whitespace().collect();
        if words.is_empty() {
            continue;
        }
        if point == points {
            trailing += 1;
            continue;
        }
        let malformed = |message: String| Error::Malformed {
            format: FileFormat::Pcd,
            location: Location::Byte(line_start),
            message: format!("point {point}: {message}"),
        };
        if words.len() != values {
            return Err(malformed(format!(
                "{} values where the fields hold {values}",
                words.len()
            )));
        }
        let mut word = 0;
        for (f, field) in header.fields.iter().enumerate() {
            if field.count == 1 {
                columns
                    .put_text(f, point, words[word])
                    .map_err(|message| malformed(format!("field `{}`: {message}", field.name)))?;
            }
            word += field.count;
        }
        point += 1;
    }
    if point < points {
        return Err(ends_early(stream.position(), format!("point {point}")));
    }
    note_trailing(&mut columns, trailing, "lines");
    Ok(columns)
}

/// `DATA binary_compressed`: the compressed and uncompressed sizes (4 bytes each), then
/// the LZF data, which holds each field's values for every point, field after field.
fn read_compressed<R: Read>(
    header: &Header,
    points: usize,
    stream: &mut ByteStream<R>,
) -> Result<Columns> {
    let sizes_at = stream.position();
    let mut sizes = [0u8; 8];
    if !stream.read_exact(&mut sizes)? {
        return Err(ends_early(stream.position(), "the compressed data's sizes"));
    }
    let [c0, c1, c2, c3, u0, u1, u2, u3] = sizes;
    let compressed = u32::from_le_bytes([c0, c1, c2, c3]);
    let uncompressed = u32::from_le_bytes([u0, u1, u2, u3]);
    let record_bytes = header.record_bytes();
    let expected = points as u128 * record_bytes as u128;
    if u128::from(uncompressed) != expected {
        return Err(malformed_at_byte(
            sizes_at + 4,
            format!(
                "the data declares {uncompressed} bytes uncompressed, but {points} points of \
                 {record_bytes} bytes take {expected}"
            ),
        ));
    }
    let declared = (u64::from(compressed), "compressed byte");
    check_room(declared, u128::from(compressed), stream)?;
    if u64::from(uncompressed) > u64::from(compressed) * lzf::MAX_EXPANSION {
        return Err(malformed_at_byte(
            sizes_at,
            format!(
                "{compressed} compressed bytes cannot expand to the {uncompressed} declared \
                 (LZF expands {}-fold at most)",
                lzf::MAX_EXPANSION
            ),
        ));
    }
    let data_at = stream.position();
    let mut data = vec![0u8; compressed as usize];
    if !stream.read_exact(&mut data)? {
        return Err(ends_early(stream.position(), "the compressed data"));
    }
    let data = lzf::decompress(&data, uncompressed as usize)
        .map_err(|message| malformed_at_byte(data_at, message))?;
    let mut columns = Columns::new(header, points);
    let mut start = 0;
    for (f, field) in header.fields.iter().enumerate() {
        let (bytes, size) = (field.bytes(), field.ty.size());
        if field.count == 1 {
            for point in 0..points {
                let at = start + point * bytes;
                columns.put_bytes(f, point, &data[at..at + size]);
            }
        }
        start += points * bytes;
    }
    note_trailing(&mut columns, stream.remaining(), "bytes");
    Ok(columns)
}
