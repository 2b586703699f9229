//! STL (stereolithography) meshes, binary and ASCII.
//!
//! An STL file is a soup of triangles: each facet stores its own three corners and a
//! normal, and nothing says which corners are the same vertex. The reader welds corners
//! whose stored positions are equal (compared exactly in single precision, `-0` equal to
//! `0`: [`TriMesh::welded`]) into one vertex, numbered in order of first appearance, so the mesh has the connectivity that
//! signing by pseudo-normals and [`TriMesh::consistently_oriented`] need. Two things follow:
//! vertices a mesh kept apart at one position (UV seams) come back as one, and a facet whose
//! corners coincide comes back as a degenerate triangle ([`TriMesh::degenerate_faces`]).
//!
//! The facet normals are read past, not used: the corners' order (counter-clockwise seen
//! from outside) is what the rest of the library takes as orientation, as most tools do, and
//! many writers leave the stored normals zero. The two attribute bytes of a binary facet
//! (used by a few tools for colour) are skipped.
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

use std::io::Write;

use glam::{DVec3, Vec3};

use super::{FileFormat, Geometry, relative_positions};
use crate::{Error, Location, PointSet, Result, TriMesh, triangle_normal};

/// Bytes before the first binary facet: an 80-byte header and the `u32` facet count.
const BINARY_HEADER_BYTES: usize = 84;
/// Bytes per binary facet: normal and three corners as `f32`, two attribute bytes.
const BINARY_FACET_BYTES: usize = 50;

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
}

/// The facet count a binary STL declares, when `bytes` is exactly as long as a binary file
/// with that many facets.
pub(crate) fn binary_facet_count(bytes: &[u8]) -> Option<usize> {
    let count = declared_facets(bytes)?;
    let expected = (count as u128) * BINARY_FACET_BYTES as u128 + BINARY_HEADER_BYTES as u128;
    (expected == bytes.len() as u128).then_some(count)
}

fn declared_facets(bytes: &[u8]) -> Option<usize> {
    let count: [u8; 4] = bytes.get(80..84)?.try_into().ok()?;
    usize::try_from(u32::from_le_bytes(count)).ok()
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
/// let mesh = mesh.mesh().expect("an STL file is a mesh");
/// // Six corners, four distinct positions: shared corners become shared vertices.
/// assert_eq!(mesh.vertices().len(), 4);
/// assert_eq!(mesh.triangles(), &[[0, 1, 2], [0, 2, 3]]);
/// # Ok::<(), pointset_core::Error>(())
/// ```
pub fn read_stl(bytes: &[u8]) -> Result<Geometry> {
    read_stl_at(bytes, false).map(|file| file.geometry)
}

/// [`read_stl`], with positions stored relative to an origin when `recentre_far` is set and
/// the data lies far from the file's origin ([`super::ReadOptions::recentre_far`]).
pub(crate) fn read_stl_at(bytes: &[u8], recentre_far: bool) -> Result<StlFile> {
    let (corners, encoding, comments) = if let Some(count) = binary_facet_count(bytes) {
        let (corners, header) = binary_corners(bytes, count)?;
        (corners, "binary_little_endian", header)
    } else if starts_like_ascii(bytes) && !bytes.contains(&0) {
        let (corners, names) = ascii_corners(bytes)?;
        (corners, "ascii", names)
    } else {
        return Err(binary_size_error(bytes));
    };
    let (corners, origin) = relative_positions(&corners, recentre_far);
    let facets = (corners.len() / 3) as u32;
    let soup = (0..facets).map(|f| [3 * f, 3 * f + 1, 3 * f + 2]).collect();
    let mesh = TriMesh::new(PointSet::new(corners)?, soup)?.welded()?;
    Ok(StlFile {
        geometry: Geometry::Mesh(mesh),
        encoding,
        comments,
        origin,
    })
}

/// Why `bytes` are not a binary STL of the size its header declares.
fn binary_size_error(bytes: &[u8]) -> Error {
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

/// The corners of a binary STL's `count` facets (its size already checked), three per
/// facet, and the header when it is printable text.
fn binary_corners(bytes: &[u8], count: usize) -> Result<(Vec<DVec3>, Vec<String>)> {
    let mut corners = Vec::with_capacity(3 * count);
    let facets = bytes[BINARY_HEADER_BYTES..].chunks_exact(BINARY_FACET_BYTES);
    for (facet, record) in facets.enumerate() {
        // Bytes 0..12 are the stored normal, 12..48 the corners, 48..50 the attributes.
        for (corner, xyz) in record[12..48].chunks_exact(12).enumerate() {
            let value = |k: usize| {
                let le: [u8; 4] = [xyz[4 * k], xyz[4 * k + 1], xyz[4 * k + 2], xyz[4 * k + 3]];
                f64::from(f32::from_le_bytes(le))
            };
            let p = DVec3::new(value(0), value(1), value(2));
            check_corner(p, facet, corner)?;
            corners.push(p);
        }
    }
    Ok((corners, header_text(&bytes[..80])))
}

/// The header as a comment when it is printable text (NULs and spaces trimmed).
fn header_text(header: &[u8]) -> Vec<String> {
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

/// The words of a text with the 1-based line each stands on.
struct Words<'a> {
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    line: usize,
    rest: std::str::SplitWhitespace<'a>,
}

impl<'a> Words<'a> {
    fn new(text: &'a str) -> Self {
        Self {
            lines: text.lines().enumerate(),
            line: 0,
            rest: "".split_whitespace(),
        }
    }

    /// The next word and its line, or `None` at the end of the text.
    fn next_word(&mut self) -> Option<(usize, &'a str)> {
        loop {
            if let Some(word) = self.rest.next() {
                return Some((self.line, word));
            }
            let (index, line) = self.lines.next()?;
            self.line = index + 1;
            self.rest = line.split_whitespace();
        }
    }

    /// The rest of the current line, joined by single spaces (a solid's name).
    fn rest_of_line(&mut self) -> String {
        self.rest.by_ref().collect::<Vec<_>>().join(" ")
    }

    /// The next word, which must be `keyword` (ASCII case ignored).
    fn expect(&mut self, keyword: &str, inside: &str) -> Result<usize> {
        match self.next_word() {
            Some((line, word)) if word.eq_ignore_ascii_case(keyword) => Ok(line),
            Some((line, word)) => Err(ascii_error(
                line,
                format!("expected `{keyword}` {inside}, found `{word}`"),
            )),
            None => Err(self.ended(&format!("`{keyword}` {inside}"))),
        }
    }

    /// The next three words as numbers.
    fn vector(&mut self, what: &str) -> Result<DVec3> {
        let mut xyz = [0.0; 3];
        for x in &mut xyz {
            let (line, word) = self.next_word().ok_or_else(|| self.ended(what))?;
            *x = word
                .parse()
                .map_err(|_| ascii_error(line, format!("`{word}` in {what} is not a number")))?;
        }
        Ok(DVec3::from_array(xyz))
    }

    fn ended(&self, what: &str) -> Error {
        Error::UnexpectedEof {
            format: FileFormat::Stl,
            location: Location::Line(self.line.max(1)),
            what: what.to_string(),
        }
    }
}

fn ascii_error(line: usize, message: String) -> Error {
    Error::Malformed {
        format: FileFormat::Stl,
        location: Location::Line(line),
        message,
    }
}

/// The corners of an ASCII STL's facets, three per facet, and the names of its solids.
/// Several solids may follow each other; keywords are matched ignoring ASCII case.
fn ascii_corners(bytes: &[u8]) -> Result<(Vec<DVec3>, Vec<String>)> {
    let text = std::str::from_utf8(bytes).map_err(|e| Error::Malformed {
        format: FileFormat::Stl,
        location: Location::Byte(e.valid_up_to() as u64),
        message: "an ASCII STL must be text (valid UTF-8)".into(),
    })?;
    let mut words = Words::new(text);
    let mut corners = Vec::new();
    let mut names = Vec::new();
    while let Some((line, word)) = words.next_word() {
        if !word.eq_ignore_ascii_case("solid") {
            return Err(ascii_error(
                line,
                format!("expected `solid`, found `{word}`"),
            ));
        }
        let name = words.rest_of_line();
        if !name.is_empty() {
            names.push(name);
        }
        read_solid_facets(&mut words, &mut corners)?;
    }
    Ok((corners, names))
}

/// Reads facets up to and including the `endsolid` line.
fn read_solid_facets(words: &mut Words<'_>, corners: &mut Vec<DVec3>) -> Result<()> {
    loop {
        let (line, word) = words
            .next_word()
            .ok_or_else(|| words.ended("`facet` or `endsolid`"))?;
        if word.eq_ignore_ascii_case("endsolid") {
            words.rest_of_line();
            return Ok(());
        }
        if !word.eq_ignore_ascii_case("facet") {
            return Err(ascii_error(
                line,
                format!("expected `facet` or `endsolid`, found `{word}`"),
            ));
        }
        let facet = corners.len() / 3;
        words.expect("normal", "after `facet`")?;
        words.vector("the facet normal")?;
        words.expect("outer", "before the facet's corners")?;
        words.expect("loop", "after `outer`")?;
        for corner in 0..3 {
            let line = words.expect("vertex", "(an STL facet has three corners)")?;
            let p = words.vector("a vertex")?;
            check_corner(p, facet, corner).map_err(|_| {
                ascii_error(
                    line,
                    format!("corner {corner} of facet {facet} is not finite"),
                )
            })?;
            corners.push(p);
        }
        words.expect(
            "endloop",
            "after three corners (an STL facet is a triangle)",
        )?;
        words.expect("endfacet", "after `endloop`")?;
    }
}

/// Writes a mesh as binary STL (see the module docs for what STL cannot hold).
///
/// ```
/// use pointset_core::io::{Geometry, read_stl, write_stl};
/// use pointset_core::{PointSet, TriMesh, glam::Vec3};
/// // Corners numbered in the order the faces first use them, which is the order the
/// // reader's welding numbers them in.
/// let corners = vec![Vec3::ZERO, Vec3::Y, Vec3::X, Vec3::Z];
/// let faces = vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [2, 1, 3]];
/// let tetrahedron = Geometry::Mesh(TriMesh::new(PointSet::new(corners)?, faces)?);
/// let mut bytes = Vec::new();
/// write_stl(&tetrahedron, &mut bytes)?;
/// assert_eq!(bytes.len(), 84 + 4 * 50);
/// assert_eq!(read_stl(&bytes)?, tetrahedron);
/// # Ok::<(), pointset_core::Error>(())
/// ```
pub fn write_stl(geometry: &Geometry, out: &mut impl Write) -> Result<()> {
    write_stl_at(geometry, DVec3::ZERO, out)
}

/// [`write_stl`], refusing a nonzero `origin` (STL cannot store it at full precision).
pub(crate) fn write_stl_at(geometry: &Geometry, origin: DVec3, out: &mut impl Write) -> Result<()> {
    let mesh = storable_mesh(geometry, origin)?;
    let facets = u32::try_from(mesh.triangles().len()).map_err(|_| Error::FormatCannotStore {
        format: FileFormat::Stl,
        what: format!(
            "{} triangles (a binary STL counts at most {})",
            mesh.triangles().len(),
            u32::MAX
        ),
    })?;
    let mut bytes =
        Vec::with_capacity(BINARY_HEADER_BYTES + BINARY_FACET_BYTES * mesh.triangles().len());
    let mut header = [b' '; 80];
    let title = b"binary STL written by geosynth";
    header[..title.len()].copy_from_slice(title);
    bytes.extend_from_slice(&header);
    bytes.extend_from_slice(&facets.to_le_bytes());
    for facet in facets_with_normals(mesh) {
        for x in facet.iter().flat_map(|v| v.to_array()) {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
        bytes.extend_from_slice(&[0, 0]);
    }
    out.write_all(&bytes)
        .map_err(|source| Error::Write { source })
}

/// Writes a mesh as ASCII STL, one solid named `geosynth`, numbers in the shortest form
/// that reads back to the same `f32` (so a round trip is exact). Four to five times the
/// size of [`write_stl`]'s binary file; for people and tools that want text.
///
/// ```
/// use pointset_core::io::{Geometry, read_stl, write_stl_ascii};
/// use pointset_core::{PointSet, TriMesh, glam::Vec3};
/// let corners = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
/// let triangle = Geometry::Mesh(TriMesh::new(PointSet::new(corners)?, vec![[0, 1, 2]])?);
/// let mut bytes = Vec::new();
/// write_stl_ascii(&triangle, &mut bytes)?;
/// assert!(String::from_utf8_lossy(&bytes).contains("facet normal 0 0 1"));
/// assert_eq!(read_stl(&bytes)?, triangle);
/// # Ok::<(), pointset_core::Error>(())
/// ```
pub fn write_stl_ascii(geometry: &Geometry, out: &mut impl Write) -> Result<()> {
    let mesh = storable_mesh(geometry, DVec3::ZERO)?;
    let mut text = String::from("solid geosynth\n");
    for [n, a, b, c] in facets_with_normals(mesh) {
        text.push_str(&format!(
            "  facet normal {} {} {}\n    outer loop\n",
            n.x, n.y, n.z
        ));
        for p in [a, b, c] {
            text.push_str(&format!("      vertex {} {} {}\n", p.x, p.y, p.z));
        }
        text.push_str("    endloop\n  endfacet\n");
    }
    text.push_str("endsolid geosynth\n");
    out.write_all(text.as_bytes())
        .map_err(|source| Error::Write { source })
}

/// The mesh in `geometry`, unless STL cannot store it ([`check_storable`]).
fn storable_mesh(geometry: &Geometry, origin: DVec3) -> Result<&TriMesh> {
    check_storable(matches!(geometry, Geometry::Mesh(_)), origin)?;
    match geometry {
        Geometry::Mesh(mesh) => Ok(mesh),
        Geometry::Points(_) => Err(cannot_store_points()),
    }
}

/// Refuses what STL cannot store: a point set (`mesh` false), or positions offset by a
/// nonzero `origin`, which single precision would round away.
pub(crate) fn check_storable(mesh: bool, origin: DVec3) -> Result<()> {
    if !mesh {
        return Err(cannot_store_points());
    }
    if origin != DVec3::ZERO {
        return Err(Error::FormatCannotStore {
            format: FileFormat::Stl,
            what: format!(
                "coordinates offset by ({}, {}, {}) at full precision (STL is single \
                 precision; write .ply to keep them)",
                origin.x, origin.y, origin.z
            ),
        });
    }
    Ok(())
}

fn cannot_store_points() -> Error {
    Error::FormatCannotStore {
        format: FileFormat::Stl,
        what: "a point set (STL holds triangles only; write .ply, .obj or .off)".into(),
    }
}

/// Each triangle's unit normal by the right-hand rule (zero when degenerate) and corners.
fn facets_with_normals(mesh: &TriMesh) -> impl Iterator<Item = [Vec3; 4]> + '_ {
    let p = mesh.vertices().positions();
    mesh.triangles().iter().map(move |t| {
        let [a, b, c] = t.map(|v| p[v as usize]);
        [triangle_normal(a, b, c), a, b, c]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> TriMesh {
        let corners: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
            .collect();
        let faces = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        TriMesh::new(PointSet::new(corners).unwrap(), faces).unwrap()
    }

    fn binary(mesh: &TriMesh) -> Vec<u8> {
        let mut bytes = Vec::new();
        write_stl(&Geometry::Mesh(mesh.clone()), &mut bytes).unwrap();
        bytes
    }

    fn ascii(mesh: &TriMesh) -> String {
        let mut bytes = Vec::new();
        write_stl_ascii(&Geometry::Mesh(mesh.clone()), &mut bytes).unwrap();
        String::from_utf8(bytes).unwrap()
    }

    /// The cube's vertices are numbered in the order its triangles first use them, which
    /// is the order welding gives back.
    fn cube_in_welding_order() -> TriMesh {
        let mesh = cube();
        let p = mesh.vertices().positions();
        let mut order: Vec<u32> = Vec::new();
        for v in mesh.triangles().iter().flatten() {
            if !order.contains(v) {
                order.push(*v);
            }
        }
        let positions = order.iter().map(|&v| p[v as usize]).collect();
        let renumber = |v: u32| order.iter().position(|&w| w == v).unwrap() as u32;
        let triangles = mesh.triangles().iter().map(|t| t.map(renumber)).collect();
        TriMesh::new(PointSet::new(positions).unwrap(), triangles).unwrap()
    }

    #[test]
    fn binary_and_ascii_give_back_the_welded_mesh() {
        let mesh = cube_in_welding_order();
        assert_eq!(mesh.vertices().len(), 8);
        let from_binary = read_stl_at(&binary(&mesh), false).unwrap();
        assert_eq!(from_binary.encoding, "binary_little_endian");
        assert_eq!(from_binary.comments, ["binary STL written by geosynth"]);
        assert_eq!(from_binary.geometry, Geometry::Mesh(mesh.clone()));
        let from_ascii = read_stl_at(ascii(&mesh).as_bytes(), false).unwrap();
        assert_eq!(from_ascii.encoding, "ascii");
        assert_eq!(from_ascii.comments, ["geosynth"]);
        assert_eq!(from_ascii.geometry, Geometry::Mesh(mesh));
    }

    #[test]
    fn binary_files_whose_header_says_solid_are_read_as_binary() {
        let mut bytes = binary(&cube());
        bytes[..12].copy_from_slice(b"solid part 1");
        let file = read_stl_at(&bytes, false).unwrap();
        assert_eq!(file.encoding, "binary_little_endian");
        assert_eq!(file.geometry.mesh().unwrap().triangles().len(), 12);
    }

    #[test]
    fn facet_normals_and_attribute_bytes_do_not_change_the_mesh() {
        let plain = binary(&cube());
        let mut noisy = plain.clone();
        for facet in noisy[84..].chunks_exact_mut(50) {
            facet[..12].copy_from_slice(&[0xff; 12]); // NaN normals
            facet[48..].copy_from_slice(&[0x12, 0x80]);
        }
        assert_eq!(
            read_stl(&noisy).unwrap(),
            read_stl(&plain).unwrap(),
            "stored normals and attributes must be read past"
        );
    }

    #[test]
    fn several_solids_mixed_case_and_negative_zero_weld_together() {
        let text = "SOLID a b\nFacet Normal 0 0 1\nOuter Loop\nVertex 0 0 0\nvertex 1 0 0\n\
                    vertex 0 1 0\nEndLoop\nEndFacet\nendsolid a b\n\
                    solid\nfacet normal 0 0 1 outer loop vertex -0 1 0 vertex 1 0 0 \
                    vertex 1 1 -0.0 endloop endfacet endsolid\n";
        let file = read_stl_at(text.as_bytes(), false).unwrap();
        assert_eq!(file.comments, ["a b"]);
        let mesh = file.geometry.mesh().unwrap().clone();
        assert_eq!(mesh.vertices().len(), 4);
        assert_eq!(mesh.triangles(), &[[0, 1, 2], [2, 1, 3]]);
    }

    #[test]
    fn coinciding_corners_give_a_degenerate_triangle() {
        let text = "solid\nfacet normal 0 0 0\nouter loop\nvertex 1 2 3\nvertex 1 2 3\n\
                    vertex 0 0 0\nendloop\nendfacet\nendsolid\n";
        let mesh = read_stl(text.as_bytes()).unwrap().mesh().unwrap().clone();
        assert_eq!(mesh.triangles(), &[[0, 0, 1]]);
        assert_eq!(mesh.degenerate_faces(), vec![0]);
    }

    #[test]
    fn an_empty_solid_is_an_empty_mesh() {
        let mesh = read_stl(b"solid nothing\nendsolid nothing\n").unwrap();
        assert_eq!(mesh.mesh().map(|m| m.triangles().len()), Some(0));
        let mut bytes = vec![b' '; 80];
        bytes.extend_from_slice(&0u32.to_le_bytes());
        assert_eq!(read_stl(&bytes).unwrap(), mesh);
    }

    #[test]
    fn short_and_long_binary_files_are_refused_by_name() {
        let bytes = binary(&cube());
        let short = read_stl(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(
            matches!(
                short,
                Error::HeaderExceedsFile {
                    declared: 12,
                    needed_bytes: 600,
                    available_bytes: 599,
                    ..
                }
            ),
            "{short}"
        );
        let mut long = bytes.clone();
        long.extend_from_slice(&[0; 7]);
        let err = read_stl(&long).unwrap_err();
        assert!(
            err.to_string().contains("7 bytes follow the 12 facets"),
            "{err}"
        );
        let header_only = read_stl(&bytes[..50]).unwrap_err();
        assert!(
            matches!(header_only, Error::UnexpectedEof { .. }),
            "{header_only}"
        );
        // A huge declared count is refused before anything is allocated.
        let mut huge = bytes[..84].to_vec();
        huge[80..84].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(
            read_stl(&huge).unwrap_err(),
            Error::HeaderExceedsFile { .. }
        ));
    }

    #[test]
    fn broken_ascii_files_name_the_line() {
        let good = ascii(&cube());
        let cases = [
            (
                good.replacen("endloop", "vertex 0 0 0\nendloop", 1),
                "an STL facet is a triangle",
                7,
            ),
            (
                good.replacen("vertex 0 0 0", "vertex 0 zero 0", 1),
                "`zero` in a vertex",
                4,
            ),
            (
                good.replacen("vertex 0 0 0", "vertex 0 nan 0", 1),
                "corner 0 of facet 0",
                4,
            ),
            (
                good.replacen("facet normal", "facet", 1),
                "expected `normal`",
                2,
            ),
            (
                good.replacen("outer loop", "outer", 1),
                "expected `loop`",
                4,
            ),
            (
                format!("{good}junk\n"),
                "expected `solid`, found `junk`",
                87,
            ),
        ];
        for (text, needle, line) in cases {
            let err = read_stl(text.as_bytes()).unwrap_err();
            assert!(err.to_string().contains(needle), "{err}");
            assert!(
                matches!(err, Error::Malformed { location: Location::Line(l), .. } if l == line),
                "{err}"
            );
        }
        let cut: Vec<&str> = good.lines().take(40).collect();
        let err = read_stl(cut.join("\n").as_bytes()).unwrap_err();
        assert!(matches!(err, Error::UnexpectedEof { .. }), "{err}");
    }

    #[test]
    fn non_finite_binary_corners_are_refused() {
        let mut bytes = binary(&cube());
        let at = 84 + 5 * 50 + 12 + 12 + 4; // facet 5, corner 1, y
        bytes[at..at + 4].copy_from_slice(&f32::INFINITY.to_le_bytes());
        let err = read_stl(&bytes).unwrap_err();
        assert_eq!(err.to_string(), "corner 1 of STL facet 5 is not finite");
    }

    #[test]
    fn the_writer_refuses_what_stl_cannot_hold() {
        let points = Geometry::Points(PointSet::new(vec![Vec3::ZERO]).unwrap());
        let err = write_stl(&points, &mut Vec::new()).unwrap_err();
        assert!(matches!(err, Error::FormatCannotStore { .. }), "{err}");
        let mesh = Geometry::Mesh(cube());
        let err = write_stl_at(&mesh, DVec3::new(5e5, 4e6, 0.0), &mut Vec::new()).unwrap_err();
        assert!(err.to_string().contains("write .ply"), "{err}");
    }

    #[test]
    fn written_normals_follow_the_right_hand_rule() {
        let bytes = binary(&cube());
        let mesh = cube();
        for (facet, t) in bytes[84..].chunks_exact(50).zip(mesh.triangles()) {
            let n: Vec<f32> = facet[..12]
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect();
            let p = t.map(|v| mesh.vertices().positions()[v as usize]);
            let centre = (p[0] + p[1] + p[2]) / 3.0 - Vec3::splat(0.5);
            // The cube's triangles face outward, so the normal points away from its centre.
            assert!(Vec3::from_slice(&n).dot(centre) > 0.0, "{n:?} at {centre}");
            assert!((Vec3::from_slice(&n).length() - 1.0).abs() < 1e-6);
        }
    }
}
