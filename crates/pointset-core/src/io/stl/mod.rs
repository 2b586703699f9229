//! STL (stereolithography) meshes, binary and ASCII.
//!
//! An STL file is a soup of triangles: each facet stores its own three corners and a
//! normal, and nothing says which corners are the same vertex. The reader welds corners
//! whose stored positions are equal (compared exactly in single precision, `-0` equal to
//! `0`: [`TriMesh::welded`]) into one vertex, numbered in order of first appearance, so
//! the mesh has the connectivity that signing by pseudo-normals and
//! [`TriMesh::consistently_oriented`] need. Two things follow: vertices a mesh kept apart
//! at one position (UV seams) come back as one, and a facet whose corners coincide comes
//! back as a degenerate triangle ([`TriMesh::degenerate_faces`]).
//!
//! Text files may use `\r\n` line ends (and, through [`super::read_geometry`], start with
//! a UTF-8 byte-order mark). Both encodings are read as they stream in: binary facets one
//! record at a time, welded as they come; ASCII facets word by word into corners, welded
//! once all are read.
//!
//! The facet normals are read past, not used: the corners' order (counter-clockwise seen
//! from outside) is what the rest of the library takes as orientation, as most tools do, and
//! many writers leave the stored normals zero. The two attribute bytes of a binary facet
//! (used by a few tools for colour, in encodings of their own) are skipped, and the notes
//! say so when any is not zero ([`super::LoadedGeometry::notes`]).
//!
//! Binary and ASCII are told apart by size, not by the first word: a binary file is exactly
//! 84 bytes plus 50 per declared facet, and binary files whose 80-byte header happens to
//! start with `solid` are common. A file that starts with `solid` and holds no NUL byte is
//! read as ASCII; anything else as binary, whose declared facet count must match the
//! file's size exactly (a short file is [`Error::HeaderExceedsFile`], a long one is refused
//! rather than partly read).
//!
//! The writer writes binary STL with each facet's unit normal from its corners (zero for a
//! degenerate facet). STL holds triangles and nothing else: point sets are refused with
//! [`Error::FormatCannotStore`], and a mesh's vertex normals, colours, attributes and UVs
//! are not written. Positions are single precision, so a nonzero write origin (data read
//! with [`super::ReadOptions::recentre_far`]) is refused too: write PLY to keep it.

mod ascii;
mod binary;
mod write;

use std::io::{Cursor, Read, Seek};

use glam::DVec3;

use super::stream::rewound;
use super::{Geometry, origin_for};
use crate::weld::PositionWelder;
use crate::{Error, PointSet, Result, TriMesh};
use ascii::ascii_corners;
use binary::{BinaryFacets, binary_size_error_of, header_text};
pub(crate) use binary::{binary_facet_count, binary_facet_count_of};
pub use write::{StlEncoding, write_stl, write_stl_ascii};
pub(crate) use write::{check_storable, write_stl_at};

/// An STL file as read: the welded mesh, its encoding and the text it carries (the ASCII
/// solids' names, or the binary header when it is printable text).
pub(crate) struct StlFile {
    /// The welded mesh.
    pub(crate) geometry: Geometry,
    /// `ascii` or `binary_little_endian`.
    pub(crate) encoding: &'static str,
    /// Solid names or header text.
    pub(crate) comments: Vec<String>,
    /// The origin positions are stored relative to.
    pub(crate) origin: DVec3,
    /// What was skipped (nonzero facet attribute bytes).
    pub(crate) notes: Vec<String>,
}

/// Whether `bytes` open like an ASCII STL: the word `solid` (any case) after optional
/// whitespace.
pub(crate) fn starts_like_ascii(bytes: &[u8]) -> bool {
    let start = bytes.iter().position(|b| !b.is_ascii_whitespace());
    start.is_some_and(|s| {
        bytes[s..]
            .get(..5)
            .is_some_and(|word| word.eq_ignore_ascii_case(b"solid"))
            && bytes.get(s + 5).is_none_or(|&b| b.is_ascii_whitespace())
    })
}

/// Reads an STL file held in memory (binary or ASCII, told apart as the module docs say).
///
/// ```
/// use pointset_core::io::read_stl;
/// let stl = "solid tet\n\
///   facet normal 0 0 -1\n outer loop\n  vertex 0 0 0\n  vertex 0 1 0\n  vertex 1 0 0\n endloop\n endfacet\n\
///   facet normal 0 -1 0\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex 0 0 1\n endloop\n endfacet\n\
/// endsolid tet\n";
/// let mesh = read_stl(stl.as_bytes())?;
/// let mesh = mesh.mesh().ok_or("an STL file is a mesh")?;
/// // Six corners, four distinct positions: shared corners become shared vertices.
/// assert_eq!(mesh.vertices().len(), 4);
/// assert_eq!(mesh.triangles(), &[[0, 1, 2], [0, 2, 3]]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_stl(bytes: &[u8]) -> Result<Geometry> {
    read_stl_at(bytes, false).map(|file| file.geometry)
}

/// [`read_stl`], with positions stored relative to an origin when `recentre_far` is set and
/// the data lies far from the file's origin ([`super::ReadOptions::recentre_far`]).
pub(crate) fn read_stl_at(bytes: &[u8], recentre_far: bool) -> Result<StlFile> {
    read_stl_from(Cursor::new(bytes), bytes, bytes.len() as u64, recentre_far)
}

/// [`read_stl_at`] of the `len` bytes `reader` gives, from their first; `head` holds the
/// first of them (all, or at least the first text line and 6 bytes past its start). Both
/// encodings are read as they stream in, except an ASCII file whose head is all blank,
/// which is read whole.
pub(crate) fn read_stl_from<R: Read + Seek>(
    mut reader: R,
    head: &[u8],
    len: u64,
    recentre_far: bool,
) -> Result<StlFile> {
    if let Some(count) = binary_facet_count_of(head, len) {
        return read_binary(reader, len, count, recentre_far);
    }
    let whole = head.len() as u64 == len;
    match head.iter().position(|b| !b.is_ascii_whitespace()) {
        Some(s) if whole || s + 6 <= head.len() => {}
        None if whole => {}
        _ => {
            let mut bytes = Vec::new();
            reader
                .read_to_end(&mut bytes)
                .map_err(|source| Error::Read { source })?;
            return read_stl_at(&bytes, recentre_far);
        }
    }
    if !starts_like_ascii(head) {
        return Err(binary_size_error_of(head, len));
    }
    let (corners, names) = ascii_corners(reader, head, len)?;
    let origin = origin_for(corners.iter().copied(), recentre_far);
    let facets = corners.chunks_exact(3).map(|c| [c[0], c[1], c[2]]);
    Ok(StlFile {
        geometry: Geometry::Mesh(weld(facets, corners.len() / 3, origin)?),
        encoding: "ascii",
        comments: names,
        origin,
        notes: Vec::new(),
    })
}

/// Reads a binary STL of `len` bytes and `count` facets (its size checked against them)
/// from `reader`, which starts at the file's first byte. Facets are decoded from the
/// stream as they are welded, so the file is never held whole; when recentring, the
/// file is read twice (the box for the origin, then the welding).
pub(crate) fn read_binary<R: Read + Seek>(
    mut reader: R,
    len: u64,
    count: usize,
    recentre_far: bool,
) -> Result<StlFile> {
    let origin = if recentre_far {
        rewound(&mut reader, |reader| {
            let (mut facets, _) = BinaryFacets::new(reader, len, count)?;
            let origin = origin_for(facets.by_ref().flatten(), true);
            facets.finish()?;
            Ok(origin)
        })?
    } else {
        DVec3::ZERO
    };
    let (mut facets, header) = BinaryFacets::new(&mut reader, len, count)?;
    let mesh = weld(facets.by_ref(), count, origin);
    let attributed = facets.finish()?;
    let notes = if attributed > 0 {
        vec![format!(
            "facet attribute bytes on {attributed} of {count} facets skipped (some tools keep \
             colours there, in no agreed encoding)"
        )]
    } else {
        Vec::new()
    };
    Ok(StlFile {
        geometry: Geometry::Mesh(mesh?),
        encoding: "binary_little_endian",
        comments: header_text(&header),
        origin,
        notes,
    })
}

/// The mesh of `facets` (about `count` of them), its corners stored relative to `origin`
/// in single precision and welded into vertices by stored position, numbered in order of
/// first appearance: [`TriMesh::welded`] of the triangle soup, without building the soup.
/// A corner that is not finite is refused, naming its facet.
fn weld(facets: impl Iterator<Item = [DVec3; 3]>, count: usize, origin: DVec3) -> Result<TriMesh> {
    // A closed mesh has about half as many vertices as facets.
    let mut welder = PositionWelder::with_capacity(count / 2);
    let mut triangles = Vec::with_capacity(count);
    for (facet, corners) in facets.enumerate() {
        let mut triangle = [0u32; 3];
        for (k, (slot, corner)) in triangle.iter_mut().zip(corners).enumerate() {
            check_corner(corner, facet, k)?;
            *slot = welder.vertex((corner - origin).as_vec3())?;
        }
        triangles.push(triangle);
    }
    TriMesh::new(PointSet::new(welder.into_positions())?, triangles)
}

/// Refuses a corner that is not finite, naming its facet.
fn check_corner(p: DVec3, facet: usize, corner: usize) -> Result<()> {
    if p.is_finite() {
        Ok(())
    } else {
        Err(Error::NonFinite {
            what: format!("corner {corner} of STL facet"),
            index: facet,
        })
    }
}
