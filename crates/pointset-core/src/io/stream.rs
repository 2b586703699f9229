//! The readers' input: bytes in memory or a file, read through a buffer, with the
//! position reached and the length the file had when it was opened (which bounds what a
//! binary header may promise, and the buffer's size).

use std::io::{ErrorKind, Read, Seek, SeekFrom};

use crate::{Error, Result};

/// The buffer a file is read through.
const BUFFER_BYTES: usize = 1 << 20;

/// A byte source read front to back through a buffer, counting what has been consumed.
pub(crate) struct ByteStream<R> {
    reader: R,
    buffer: Vec<u8>,
    /// The unconsumed bytes are `buffer[start..end]`.
    start: usize,
    end: usize,
    /// The offset of `buffer[start]`.
    position: u64,
    len: u64,
}

impl<'a> ByteStream<&'a [u8]> {
    /// The stream of bytes held in memory.
    pub(crate) fn of_bytes(bytes: &'a [u8]) -> Self {
        ByteStream::new(bytes, bytes.len() as u64)
    }
}

impl<R: Read> ByteStream<R> {
    /// A stream of `len` bytes read from `reader`. `len` bounds what the header may
    /// promise; if the reader ends earlier, reading stops there with a truncation error.
    pub(crate) fn new(reader: R, len: u64) -> Self {
        let capacity = usize::try_from(len).map_or(BUFFER_BYTES, |len| len.clamp(1, BUFFER_BYTES));
        ByteStream {
            reader,
            buffer: vec![0; capacity],
            start: 0,
            end: 0,
            position: 0,
            len,
        }
    }

    /// Bytes consumed so far: the offset of the next byte.
    pub(crate) fn position(&self) -> u64 {
        self.position
    }

    /// The stream's length.
    pub(crate) fn len(&self) -> u64 {
        self.len
    }

    /// How many bytes the stream's length leaves after the position.
    pub(crate) fn remaining(&self) -> u64 {
        self.len.saturating_sub(self.position)
    }

    /// The bytes buffered at the position, without reading (possibly empty).
    #[inline]
    pub(crate) fn buffered(&self) -> &[u8] {
        &self.buffer[self.start..self.end]
    }

    /// The bytes buffered at the position, read from the source if none are (empty at
    /// the end).
    pub(crate) fn buffer(&mut self) -> Result<&[u8]> {
        if self.start == self.end {
            self.start = 0;
            self.end = 0;
            loop {
                match self.reader.read(&mut self.buffer) {
                    Ok(n) => {
                        self.end = n;
                        break;
                    }
                    Err(error) if error.kind() == ErrorKind::Interrupted => {}
                    Err(source) => return Err(Error::Read { source }),
                }
            }
        }
        Ok(self.buffered())
    }

    /// Moves past `n` buffered bytes.
    #[inline]
    pub(crate) fn consume(&mut self, n: usize) {
        debug_assert!(n <= self.end - self.start);
        self.start += n;
        self.position += n as u64;
    }

    /// Whether the stream has no more bytes.
    pub(crate) fn at_end(&mut self) -> Result<bool> {
        Ok(self.buffer()?.is_empty())
    }

    /// Consumes the longest run of bytes for which `take` holds, handing each buffered
    /// piece of it to `piece`.
    pub(crate) fn consume_while(
        &mut self,
        take: impl Fn(u8) -> bool,
        mut piece: impl FnMut(&[u8]),
    ) -> Result<()> {
        loop {
            let buffer = self.buffer()?;
            let available = buffer.len();
            let n = buffer.iter().position(|&b| !take(b)).unwrap_or(available);
            piece(&buffer[..n]);
            self.consume(n);
            if n < available || available == 0 {
                return Ok(());
            }
        }
    }

    /// Reads the next line into `line` (emptied first), without its `\n`; `false` at the
    /// end of the stream, where no line is left.
    pub(crate) fn read_line(&mut self, line: &mut Vec<u8>) -> Result<bool> {
        line.clear();
        if self.at_end()? {
            return Ok(false);
        }
        self.consume_while(|b| b != b'\n', |piece| line.extend_from_slice(piece))?;
        if !self.at_end()? {
            self.consume(1);
        }
        Ok(true)
    }

    /// The next line as text, without its `\n` or a `\r` before it; `None` at the end of
    /// the stream. A line that is not UTF-8 is refused with `not_text` of the offset of
    /// its first bad byte.
    pub(crate) fn read_text_line<'l>(
        &mut self,
        line: &'l mut Vec<u8>,
        not_text: impl FnOnce(u64) -> Error,
    ) -> Result<Option<&'l str>> {
        let start = self.position;
        if !self.read_line(line)? {
            return Ok(None);
        }
        let text =
            std::str::from_utf8(line).map_err(|e| not_text(start + e.valid_up_to() as u64))?;
        Ok(Some(text.strip_suffix('\r').unwrap_or(text)))
    }

    /// Moves past the next `n` bytes; `false` if the stream ends first.
    pub(crate) fn skip(&mut self, mut n: u64) -> Result<bool> {
        while n > 0 {
            let available = self.buffer()?.len();
            if available == 0 {
                return Ok(false);
            }
            let step = usize::try_from(n).map_or(available, |n| n.min(available));
            self.consume(step);
            n -= step as u64;
        }
        Ok(true)
    }

    /// Fills `out` from the stream; `false` if the stream ends first.
    pub(crate) fn read_exact(&mut self, out: &mut [u8]) -> Result<bool> {
        let mut filled = 0;
        while filled < out.len() {
            let buffer = self.buffer()?;
            if buffer.is_empty() {
                return Ok(false);
            }
            let n = buffer.len().min(out.len() - filled);
            out[filled..filled + n].copy_from_slice(&buffer[..n]);
            self.consume(n);
            filled += n;
        }
        Ok(true)
    }
}

/// Runs `pass` over `reader` and puts the reader back where it stood: the first pass over
/// a file read twice (for the origin of its positions, before reading them relative to
/// it).
pub(crate) fn rewound<R: Read + Seek, T>(
    reader: &mut R,
    pass: impl FnOnce(&mut R) -> Result<T>,
) -> Result<T> {
    let read = |source| Error::Read { source };
    let start = reader.stream_position().map_err(read)?;
    let out = pass(reader)?;
    reader.seek(SeekFrom::Start(start)).map_err(read)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use std::io::{Cursor, Read, Seek, SeekFrom};
    use std::path::Path;

    use glam::{DVec3, Vec2, Vec3};
    use proptest::prelude::*;

    use crate::io::ply::{PlyEncoding, read_ply_geometry_from};
    use crate::io::{self, FileFormat, Geometry, WriteOptions};
    use crate::{Attribute, Error, PointSet, ScalarType, TriMesh};

    /// A point set or mesh with normals, UVs and an attribute of type `ty`, as chosen.
    fn geometry(values: &[f32], normals: bool, ty: Option<ScalarType>, faces: usize) -> Geometry {
        let n = values.len();
        let v = |i: usize, k: usize| values[(i + k) % n];
        let mut points = PointSet::new(
            (0..n)
                .map(|i| Vec3::new(v(i, 0), v(i, 1), v(i, 2)))
                .collect(),
        )
        .unwrap();
        if normals {
            let normals = (0..n).map(|i| Vec3::new(v(i, 3), 1.0, 0.5).normalize());
            points = points.with_normals(normals.collect()).unwrap();
        }
        if let Some(ty) = ty {
            let channel = (0..n).map(|i| ty.quantize(f64::from(v(i, 4))) as f32);
            let attribute = Attribute::new("a", channel.collect()).with_storage(ty);
            points = points.with_attribute(attribute).unwrap();
        }
        if faces == 0 {
            return Geometry::Points(points);
        }
        let triangles = (0..faces).map(|f| [f % n, (f * 5 + 1) % n, (f * 11 + 2) % n]);
        let triangles = triangles.map(|t| t.map(|i| i as u32)).collect();
        let uvs = (0..n).map(|i| Vec2::new(v(i, 5), v(i, 6))).collect();
        Geometry::Mesh(
            TriMesh::new(points, triangles)
                .unwrap()
                .with_uvs(uvs)
                .unwrap(),
        )
    }

    /// `bytes` with each `(at, byte)` edit made (at `at` modulo the length), then cut to
    /// `cut` bytes if given.
    fn edited(mut bytes: Vec<u8>, edits: &[(usize, u8)], cut: Option<usize>) -> Vec<u8> {
        for &(at, byte) in edits {
            let len = bytes.len();
            bytes[at % len] = byte;
        }
        if let Some(cut) = cut {
            bytes.truncate(cut);
        }
        bytes
    }

    proptest! {
        /// Read a few bytes at a time, so that tokens, words, lines and the header
        /// straddle refills, a file gives what it gives read from memory: the same
        /// geometry or the same error, edited or cut short, in every encoding.
        #[test]
        fn small_buffers_read_what_memory_reads(
            values in proptest::collection::vec(-1e3f32..1e3, 1..10),
            normals in any::<bool>(),
            ty in proptest::option::of(proptest::sample::select(ScalarType::ALL.to_vec())),
            faces in 0usize..6,
            edits in proptest::collection::vec((0usize..1000, any::<u8>()), 0..3),
            cut in proptest::option::of(0usize..1000),
            at_most in 1usize..12,

        ) {
            let geometry = geometry(&values, normals, ty, faces);
            for encoding in PlyEncoding::ALL {
                let options = WriteOptions::default().ply_encoding(encoding);
                let bytes = io::encode_geometry(&geometry, FileFormat::Ply, &options).unwrap();
                let bytes = edited(bytes, &edits, cut);
                let len = bytes.len() as u64;
                let reader = Trickle::new(&bytes, at_most);
                let streamed = read_ply_geometry_from(reader, len, true)
                    .map(|read| (read.geometry, read.origin, read.comments, read.notes))
                    .map_err(|e| e.to_string());
                let in_memory = read_ply_geometry_from(bytes.as_slice(), len, true)
                    .map(|read| (read.geometry, read.origin, read.comments, read.notes))
                    .map_err(|e| e.to_string());
                prop_assert_eq!(streamed, in_memory);
            }
        }
    }

    /// A reader that hands out at most `at_most` bytes a read, as pipes and sockets may.
    struct Trickle<'a> {
        bytes: Cursor<&'a [u8]>,
        at_most: usize,
    }

    impl<'a> Trickle<'a> {
        fn new(bytes: &'a [u8], at_most: usize) -> Self {
            Trickle {
                bytes: Cursor::new(bytes),
                at_most,
            }
        }
    }

    impl Read for Trickle<'_> {
        fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
            let n = out.len().min(self.at_most);
            self.bytes.read(&mut out[..n])
        }
    }

    impl Seek for Trickle<'_> {
        fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
            self.bytes.seek(to)
        }
    }

    /// `len` bytes of `format` read by the readers' shared dispatch from `reader` (`head`:
    /// their first bytes), errors as text.
    fn read_as(
        format: FileFormat,
        reader: impl Read + Seek,
        head: &[u8],
        len: u64,
        recentre: bool,
    ) -> std::result::Result<io::LoadedGeometry, String> {
        io::read_as(format, reader, (head, Path::new("")), len, recentre).map_err(|e| e.to_string())
    }

    proptest! {
        /// Binary STL and LAS files read a few bytes at a time (records straddling
        /// refills) give what they give read from memory, with and without recentring,
        /// whole or with a corner made infinite or the points cut short.
        #[test]
        fn small_reads_of_stl_and_las_files_read_what_memory_reads(
            side in 2u32..12,
            far in any::<bool>(),
            broken in any::<bool>(),
            recentre in any::<bool>(),
            at_most in 1usize..80,
        ) {
            let grid = (0..side * side).map(|i| {
                Vec3::new((i % side) as f32, (i / side) as f32, (i % 3) as f32 * 0.5)
            });
            let points = PointSet::new(grid.collect()).unwrap();
            let triangles = (0..side - 1)
                .flat_map(|r| (0..side - 1).map(move |c| r * side + c))
                .map(|i| [i, i + 1, i + side])
                .collect();
            let mesh = Geometry::Mesh(TriMesh::new(points.clone(), triangles).unwrap());
            let origin = if far { DVec3::new(3e5, 4e6, 20.0) } else { DVec3::ZERO };
            let mut stl = io::encode_geometry(&mesh, FileFormat::Stl, &WriteOptions::default())
                .unwrap();
            let options = WriteOptions::default().origin(origin);
            let mut las = io::encode_geometry(&Geometry::Points(points), FileFormat::Las, &options)
                .unwrap();
            if broken {
                // The first corner's x of the middle facet.
                let at = 84 + 50 * ((stl.len() - 84) / 100) + 12;
                stl[at..at + 4].copy_from_slice(&f32::INFINITY.to_le_bytes());
                las.truncate(las.len() - 3);
            }
            // The LAS head: its public header and no more.
            for (format, bytes, head) in [
                (FileFormat::Stl, &stl, stl.len()),
                (FileFormat::Las, &las, las.len().min(300)),
            ] {
                let len = bytes.len() as u64;
                let trickle = Trickle::new(bytes, at_most);
                let trickled = read_as(format, trickle, &bytes[..head], len, recentre);
                let whole = read_as(format, Cursor::new(bytes.as_slice()), bytes, len, recentre);
                prop_assert_eq!(&trickled, &whole);
                prop_assert_eq!(trickled.is_err(), broken);
            }
        }
    }

    proptest! {
        /// OBJ, OFF, XYZ and ASCII STL text read a few bytes at a time (lines straddling
        /// refills) gives what it gives read from memory, edited or cut short.
        #[test]
        fn small_reads_of_text_files_read_what_memory_reads(
            values in proptest::collection::vec(-1e3f32..1e3, 3..10),
            faces in 1usize..6,
            edits in proptest::collection::vec((0usize..1000, any::<u8>()), 0..3),
            cut in proptest::option::of(0usize..1000),
            at_most in 1usize..12,
        ) {
            let geometry = geometry(&values, true, None, faces);
            let columns = io::XyzColumns::Normals;
            let points = Geometry::Points(geometry.points().clone());
            let options = WriteOptions::default();
            let ascii_stl = WriteOptions::default().stl_encoding(io::StlEncoding::Ascii);
            for (bytes, format) in [
                (io::encode_geometry(&geometry, FileFormat::Obj, &options).unwrap(), FileFormat::Obj),
                (io::encode_geometry(&geometry, FileFormat::Off, &options).unwrap(), FileFormat::Off),
                (io::encode_geometry(&points, FileFormat::Xyz(columns), &options).unwrap(), FileFormat::Xyz(columns)),
                (io::encode_geometry(&geometry, FileFormat::Stl, &ascii_stl).unwrap(), FileFormat::Stl),
            ] {
                let bytes = edited(bytes, &edits, cut);
                let len = bytes.len() as u64;
                prop_assert_eq!(
                    read_as(format, Trickle::new(&bytes, at_most), &bytes, len, true),
                    read_as(format, Cursor::new(bytes.as_slice()), &bytes, len, true)
                );
            }
        }
    }

    /// A reader that fails after `good` bytes.
    struct FailingAfter<'a> {
        good: &'a [u8],
    }

    impl Read for FailingAfter<'_> {
        fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
            if self.good.is_empty() {
                return Err(std::io::Error::other("the disk is gone"));
            }
            self.good.read(out)
        }
    }

    #[test]
    fn a_failed_read_is_a_read_error_not_a_truncation() {
        let geometry = geometry(&[1.0, 2.0, 3.0, 4.0], true, None, 2);
        for encoding in PlyEncoding::ALL {
            let options = WriteOptions::default().ply_encoding(encoding);
            let bytes = io::encode_geometry(&geometry, FileFormat::Ply, &options).unwrap();
            for good in [10, bytes.len() - 5] {
                let reader = FailingAfter {
                    good: &bytes[..good],
                };
                let error = read_ply_geometry_from(reader, bytes.len() as u64, false).unwrap_err();
                assert!(
                    matches!(&error, Error::Read { source } if source.to_string() == "the disk is gone"),
                    "{encoding:?}, {good} bytes: {error:?}"
                );
            }
            // The same bytes, whole, are read.
            assert!(read_ply_geometry_from(bytes.as_slice(), bytes.len() as u64, false).is_ok());
        }
    }
}
