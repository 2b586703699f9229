//! Binary STL: an 80-byte header, a `u32` facet count, 50 bytes a facet.

use glam::DVec3;

use crate::io::FileFormat;
use crate::{Error, Location};

/// Bytes before the first binary facet: an 80-byte header and the `u32` facet count.
pub(super) const BINARY_HEADER_BYTES: usize = 84;
/// Bytes per binary facet: normal and three corners as `f32`, two attribute bytes.
pub(super) const BINARY_FACET_BYTES: usize = 50;

/// The facet count a binary STL declares, when `bytes` is exactly as long as a binary file
/// with that many facets.
pub(crate) fn binary_facet_count(bytes: &[u8]) -> Option<usize> {
    binary_facet_count_of(bytes, bytes.len() as u64)
}

/// [`binary_facet_count`] of a file of `len` bytes that starts with `head` (at least its
/// first 84 bytes, if it has them).
pub(crate) fn binary_facet_count_of(head: &[u8], len: u64) -> Option<usize> {
    let count = declared_facets(head)?;
    let expected = (count as u128) * BINARY_FACET_BYTES as u128 + BINARY_HEADER_BYTES as u128;
    (expected == u128::from(len)).then_some(count)
}

fn declared_facets(bytes: &[u8]) -> Option<usize> {
    let count: [u8; 4] = bytes.get(80..84)?.try_into().ok()?;
    usize::try_from(u32::from_le_bytes(count)).ok()
}

/// Why `bytes` are not a binary STL of the size its header declares.
pub(super) fn binary_size_error(bytes: &[u8]) -> Error {
    let Some(count) = declared_facets(bytes) else {
        return Error::UnexpectedEof {
            format: FileFormat::Stl,
            location: Location::Byte(bytes.len() as u64),
            what: "the 84-byte binary header (80 bytes of text and the facet count)".into(),
        };
    };
    let needed = (count as u128) * BINARY_FACET_BYTES as u128;
    let available = (bytes.len() - BINARY_HEADER_BYTES) as u128;
    if needed > available {
        Error::HeaderExceedsFile {
            format: FileFormat::Stl,
            element: "facet".into(),
            declared: count as u64,
            needed_bytes: needed,
            available_bytes: available as u64,
        }
    } else {
        Error::Malformed {
            format: FileFormat::Stl,
            location: Location::Byte((BINARY_HEADER_BYTES as u128 + needed) as u64),
            message: format!(
                "{} bytes follow the {count} facets the header declares; refusing to guess \
                 whether the count or the data is wrong",
                available - needed
            ),
        }
    }
}

/// The three corners of each facet of a binary STL whose size is already checked
/// ([`binary_facet_count`]), decoded where they lie in `bytes` (a file read twice this way
/// costs no copy of its corners).
pub(super) fn binary_facets(bytes: &[u8]) -> impl Iterator<Item = [DVec3; 3]> + '_ {
    let records = bytes.get(BINARY_HEADER_BYTES..).unwrap_or(&[]);
    records.chunks_exact(BINARY_FACET_BYTES).map(|record| {
        // Bytes 0..12 are the stored normal, 12..48 the corners, 48..50 the attributes.
        let value = |at: usize| {
            let le: [u8; 4] = [record[at], record[at + 1], record[at + 2], record[at + 3]];
            f64::from(f32::from_le_bytes(le))
        };
        let corner = |k: usize| {
            let at = 12 + 12 * k;
            DVec3::new(value(at), value(at + 4), value(at + 8))
        };
        [corner(0), corner(1), corner(2)]
    })
}

/// How many facets of a binary STL (its size already checked) have nonzero attribute
/// bytes, which some tools use for colours in encodings of their own.
pub(super) fn facets_with_attributes(bytes: &[u8]) -> usize {
    let records = bytes.get(BINARY_HEADER_BYTES..).unwrap_or(&[]);
    records
        .chunks_exact(BINARY_FACET_BYTES)
        .filter(|record| record[48..50] != [0, 0])
        .count()
}

/// The header as a comment when it is printable text (NULs and spaces trimmed).
pub(super) fn header_text(header: &[u8]) -> Vec<String> {
    let end = header.iter().position(|&b| b == 0).unwrap_or(header.len());
    let text = &header[..end];
    if text.iter().all(|b| b.is_ascii_graphic() || *b == b' ') {
        let trimmed = String::from_utf8_lossy(text).trim().to_string();
        (!trimmed.is_empty())
            .then_some(trimmed)
            .into_iter()
            .collect()
    } else {
        Vec::new()
    }
}
