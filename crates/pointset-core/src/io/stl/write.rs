//! Writing STL, binary and ASCII.

use std::io::Write;

use glam::{DVec3, Vec3};

use crate::io::buffered::buffered;
use crate::io::{FileFormat, Geometry};
use crate::{Error, Result, TriMesh, triangle_normal};

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
    write_stl_at(geometry, StlEncoding::Binary, DVec3::ZERO, out)
}

/// The two STL encodings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum StlEncoding {
    /// 50 bytes a facet ([`write_stl`]); the default.
    #[default]
    Binary,
    /// Text ([`write_stl_ascii`]).
    Ascii,
}

/// [`write_stl`] or [`write_stl_ascii`] by `encoding`, refusing a nonzero `origin` (STL
/// cannot store it at full precision).
pub(crate) fn write_stl_at(
    geometry: &Geometry,
    encoding: StlEncoding,
    origin: DVec3,
    out: &mut impl Write,
) -> Result<()> {
    let mesh = storable_mesh(geometry, origin)?;
    match encoding {
        StlEncoding::Binary => write_binary(mesh, out),
        StlEncoding::Ascii => write_ascii(mesh, out),
    }
}

/// A mesh as binary STL.
fn write_binary(mesh: &TriMesh, out: &mut impl Write) -> Result<()> {
    let facets = u32::try_from(mesh.triangles().len()).map_err(|_| Error::FormatCannotStore {
        format: FileFormat::Stl,
        what: format!(
            "{} triangles (a binary STL counts at most {})",
            mesh.triangles().len(),
            u32::MAX
        ),
    })?;
    let mut header = [b' '; 80];
    let title = b"binary STL written by geosynth";
    header[..title.len()].copy_from_slice(title);
    buffered(out, |out| {
        out.write_all(&header)?;
        out.write_all(&facets.to_le_bytes())?;
        for facet in facets_with_normals(mesh) {
            for x in facet.iter().flat_map(|v| v.to_array()) {
                out.write_all(&x.to_le_bytes())?;
            }
            out.write_all(&[0, 0])?;
        }
        Ok(())
    })
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
    write_stl_at(geometry, StlEncoding::Ascii, DVec3::ZERO, out)
}

/// A mesh as ASCII STL.
fn write_ascii(mesh: &TriMesh, out: &mut impl Write) -> Result<()> {
    buffered(out, |out| {
        writeln!(out, "solid geosynth")?;
        for [n, a, b, c] in facets_with_normals(mesh) {
            writeln!(
                out,
                "  facet normal {} {} {}\n    outer loop",
                n.x, n.y, n.z
            )?;
            for p in [a, b, c] {
                writeln!(out, "      vertex {} {} {}", p.x, p.y, p.z)?;
            }
            writeln!(out, "    endloop\n  endfacet")?;
        }
        writeln!(out, "endsolid geosynth")
    })
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
