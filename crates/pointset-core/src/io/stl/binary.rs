//! Binary STL: an 80-byte header, a `u32` facet count, 50 bytes a facet.

use std::io::Read;

use glam::DVec3;

use crate::io::FileFormat;
use crate::io::stream::ByteStream;
use crate::{Error, Location, Result};

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

/// Why a file of `len` bytes that starts with `head` (at least its first 84 bytes, if it
/// has them) is not a binary STL of the size its header declares.
pub(super) fn binary_size_error_of(head: &[u8], len: u64) -> Error {
    let Some(count) = declared_facets(head) else {
        return Error::UnexpectedEof {
            format: FileFormat::Stl,
            location: Location::Byte(len),
            what: "the 84-byte binary header (80 bytes of text and the facet count)".into(),
        };
    };
    let needed = (count as u128) * BINARY_FACET_BYTES as u128;
    let available = u128::from(len) - BINARY_HEADER_BYTES as u128;
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

/// The facets of a binary STL read one record at a time from a stream just past its
/// 84-byte header: each facet's three corners (its stored normal is read past), with a
/// count of the facets whose attribute bytes are not zero. A stream that ends early (a
/// file cut short while it was read) or fails ends the iteration; [`BinaryFacets::finish`]
/// then returns the error.
pub(super) struct BinaryFacets<R> {
    stream: ByteStream<R>,
    /// The facets still to read.
    left: usize,
    /// The next facet's index.
    facet: usize,
    /// How many facets so far have nonzero attribute bytes.
    attributed: usize,
    error: Option<Error>,
}

impl<R: Read> BinaryFacets<R> {
    /// The `count` facets of the binary STL of `len` bytes that `reader` starts, with the
    /// file's 80-byte header.
    pub(super) fn new(reader: R, len: u64, count: usize) -> Result<(Self, [u8; 80])> {
        let mut stream = ByteStream::new(reader, len);
        let mut header = [0u8; BINARY_HEADER_BYTES];
        if !stream.read_exact(&mut header)? {
            return Err(Error::UnexpectedEof {
                format: FileFormat::Stl,
                location: Location::Byte(stream.position()),
                what: "the 84-byte binary header".into(),
            });
        }
        let mut text = [0u8; 80];
        text.copy_from_slice(&header[..80]);
        let facets = BinaryFacets {
            stream,
            left: count,
            facet: 0,
            attributed: 0,
            error: None,
        };
        Ok((facets, text))
    }

    /// After the iteration: how many facets had nonzero attribute bytes, or the error that
    /// ended it.
    pub(super) fn finish(self) -> Result<usize> {
        self.error.map_or(Ok(self.attributed), Err)
    }

    /// The next record, or `None` with the error kept.
    fn record(&mut self) -> Option<[u8; BINARY_FACET_BYTES]> {
        let mut record = [0u8; BINARY_FACET_BYTES];
        match self.stream.read_exact(&mut record) {
            Ok(true) => Some(record),
            Ok(false) => {
                self.error = Some(Error::UnexpectedEof {
                    format: FileFormat::Stl,
                    location: Location::Byte(self.stream.position()),
                    what: format!("facet {}", self.facet),
                });
                None
            }
            Err(error) => {
                self.error = Some(error);
                None
            }
        }
    }
}

impl<R: Read> Iterator for BinaryFacets<R> {
    type Item = [DVec3; 3];

    fn next(&mut self) -> Option<[DVec3; 3]> {
        if self.left == 0 || self.error.is_some() {
            return None;
        }
        let record = self.record()?;
        self.left -= 1;
        self.facet += 1;
        self.attributed += usize::from(record[48..50] != [0, 0]);
        // Bytes 0..12 are the stored normal, 12..48 the corners, 48..50 the attributes.
        let value = |at: usize| {
            let le: [u8; 4] = [record[at], record[at + 1], record[at + 2], record[at + 3]];
            f64::from(f32::from_le_bytes(le))
        };
        let corner = |k: usize| {
            let at = 12 + 12 * k;
            DVec3::new(value(at), value(at + 4), value(at + 8))
        };
        Some([corner(0), corner(1), corner(2)])
    }
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
