//! Wavefront OBJ, read and written in-house.
//!
//! Reading triangulates polygons ([`crate::triangulate_polygon`]: fans when convex, ear
//! clipping when not), unifies position/UV/normal indices into one vertex per distinct
//! combination within an object or group (so vertices on UV seams are duplicated, the way
//! every GPU-style mesh stores them), keeps per-vertex colours (`v x y z r g b`) as
//! `red/green/blue` channels, divides a position by its weight (`v x y z w`), merges all
//! objects and groups into one mesh, and ignores materials, `p` and `l` elements. A file
//! without faces (bare `v` lines, the usual point-cloud OBJ) becomes a point set; `vn`
//! lines are its normals when there is one per vertex.
//!
//! The file is read line by line as it streams in (`read`), never held whole: a
//! 24-million-triangle OBJ of 1.03 GB converts in 1.14 GB, where `tobj`, the reader
//! used before, took 4.96 GB (docs/performance.md). A malformed file is refused with the
//! line at fault ([`crate::Error::Malformed`]): numbers that do not parse, too few or too
//! many of them, a weight of 0, face corners that refer to elements not defined before
//! them or have more than three parts, faces of fewer than three corners, comments after
//! a face, and text that is not UTF-8. A line ending in `\` continues on the next.

mod read;

use std::io::{Read, Write};

use glam::{DVec3, Vec2};

use super::buffered::{buffered, comment_lines};
use super::stream::ByteStream;
use super::{Geometry, position_text, relative_positions};
use crate::{PointSet, Result, TriMesh, triangulate_polygon};
use read::{Forms, MISSING, ObjLines, malformed};

/// What a mesh read from a file of `forms` lost: UVs, normals or colours that only some
/// corners (or `v` lines) had, which a mesh must have at every vertex or not at all.
fn dropped_notes(forms: &Forms, mesh: &TriMesh) -> Vec<String> {
    let mut notes = Vec::new();
    let partial = |what: &str, some: usize, all: usize, of: &str| {
        format!(
            "{what} dropped: {some} of {all} {of} have them; a mesh carries them at every \
             vertex or not at all"
        )
    };
    if forms.corners_with_uv > 0 && mesh.uvs().is_none() {
        let (some, all) = (forms.corners_with_uv, forms.corners);
        notes.push(partial("texture coordinates", some, all, "face corners"));
    }
    if forms.corners_with_normal > 0 && mesh.vertices().normals().is_none() {
        let (some, all) = (forms.corners_with_normal, forms.corners);
        notes.push(partial("normals", some, all, "face corners"));
    }
    if forms.coloured_vertices > 0 && mesh.vertices().colors().is_none() {
        let (some, all) = (forms.coloured_vertices, forms.vertices);
        notes.push(partial("colours", some, all, "`v` lines"));
    }
    notes
}

/// Reads an OBJ file held in memory (see the module docs).
///
/// ```
/// use pointset_core::io::read_obj;
/// let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n";
/// let mesh = read_obj(obj.as_bytes())?;
/// let mesh = mesh.mesh().ok_or("faces make a mesh")?;
/// // The square is split into two triangles; its corners share the one normal.
/// assert_eq!(mesh.triangles().len(), 2);
/// assert!(mesh.vertices().normals().is_some());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_obj(bytes: &[u8]) -> Result<Geometry> {
    read_obj_from(bytes, bytes.len() as u64, false).map(|(geometry, _, _)| geometry)
}

/// [`read_obj`] of the `len` bytes of OBJ text `reader` gives, read as they stream in,
/// with positions stored relative to an origin when `recentre_far` is set and the data
/// lies far from the file's origin ([`super::ReadOptions::recentre_far`]); returns the
/// origin too, and notes on what the file had that the mesh could not keep
/// ([`super::LoadedGeometry::notes`]).
pub(crate) fn read_obj_from(
    reader: impl Read,
    len: u64,
    recentre_far: bool,
) -> Result<(Geometry, DVec3, Vec<String>)> {
    let mut lines = ObjLines::read(&mut ByteStream::new(reader, len))?;
    if lines.vertices.is_empty() {
        return point_cloud(lines, recentre_far)
            .map(|(points, origin, notes)| (Geometry::Points(points), origin, notes));
    }
    let (positions, origin) = relative_positions(&lines.take_vertex_positions(), recentre_far);
    let mut points = PointSet::new(positions)?;
    let every = |k: usize| lines.vertices.iter().all(|vertex| vertex[k] != MISSING);
    if every(2) {
        let normals = lines
            .vertices
            .iter()
            .map(|&[_, _, n]| lines.normals[n as usize].as_vec3());
        points = points.with_normals(normals.collect())?;
    }
    // Colours only when every `v` line has them: the mesh needs one per vertex.
    if lines.forms.coloured_vertices == lines.forms.vertices {
        let colours: Vec<[f32; 3]> = lines
            .vertices
            .iter()
            .map(|&[v, ..]| lines.colours[v as usize].map(|c| c as f32))
            .collect();
        points.set_colors(&colours)?;
    }
    let mut triangles =
        Vec::with_capacity(lines.corners.len().saturating_sub(2 * lines.arities.len()));
    let mut start = 0;
    for &arity in &lines.arities {
        let face = &lines.corners[start..start + arity as usize];
        triangulate_polygon(points.positions(), face, &mut triangles);
        start += arity as usize;
    }
    let mut mesh = TriMesh::new(points, triangles)?;
    if every(1) {
        let uvs = lines.vertices.iter().map(|&[_, t, _]| {
            let [u, v] = lines.uvs[t as usize];
            Vec2::new(u as f32, v as f32)
        });
        mesh = mesh.with_uvs(uvs.collect())?;
    }
    let notes = dropped_notes(&lines.forms, &mesh);
    Ok((Geometry::Mesh(mesh), origin, notes))
}

/// A face-less OBJ as points: each `v` line's `x y z` (any weight ignored), with the `vn`
/// lines as normals when there is one per `v` line and the colours when every `v` line
/// has one; notes say what was dropped.
fn point_cloud(lines: ObjLines, recentre_far: bool) -> Result<(PointSet, DVec3, Vec<String>)> {
    let count = lines.positions.len();
    if count == 0 {
        return Err(malformed(1, "no vertices (`v` lines) found"));
    }
    let mut notes = Vec::new();
    let (positions, origin) = relative_positions(&lines.positions, recentre_far);
    let mut points = PointSet::new(positions)?;
    if lines.normals.len() == count {
        points = points.with_normals(lines.normals.iter().map(|n| n.as_vec3()).collect())?;
    } else if !lines.normals.is_empty() {
        notes.push(format!(
            "normals dropped: {} `vn` lines for {count} points (one per point is needed)",
            lines.normals.len()
        ));
    }
    if lines.colours.len() == count {
        let colours: Vec<[f32; 3]> = lines.colours.iter().map(|c| c.map(|c| c as f32)).collect();
        points.set_colors(&colours)?;
    } else if !lines.colours.is_empty() {
        notes.push(format!(
            "colours dropped: {} of {count} `v` lines have them; a point set carries them at \
             every point or not at all",
            lines.colours.len()
        ));
    }
    Ok((points, origin, notes))
}

/// Writes OBJ: `v` lines (with `r g b` in `0..=1` when colours exist), `vt`, `vn`, then
/// `f` lines for a mesh; a point set is written as its vertices alone.
pub fn write_obj(geometry: &Geometry, comments: &[String], out: &mut impl Write) -> Result<()> {
    write_obj_at(geometry, comments, DVec3::ZERO, out)
}

/// [`write_obj`] with `origin` added to every position, in double precision.
pub(crate) fn write_obj_at(
    geometry: &Geometry,
    comments: &[String],
    origin: DVec3,
    out: &mut impl Write,
) -> Result<()> {
    let points = geometry.points();
    let colors = points.colors();
    let uvs = geometry.mesh().and_then(TriMesh::uvs);
    let normals = points.normals();
    let corner = |i: u32| Corner {
        index: u64::from(i) + 1,
        uv: uvs.is_some(),
        normal: normals.is_some(),
    };
    buffered(out, |out| {
        comment_lines(out, comments)?;
        for (i, p) in points.positions().iter().enumerate() {
            let p = position_text(*p, origin);
            match &colors {
                Some(c) => writeln!(out, "v {p} {} {} {}", c[i][0], c[i][1], c[i][2])?,
                None => writeln!(out, "v {p}")?,
            }
        }
        for uv in uvs.unwrap_or(&[]) {
            writeln!(out, "vt {} {}", uv.x, uv.y)?;
        }
        for n in normals.unwrap_or(&[]) {
            writeln!(out, "vn {} {} {}", n.x, n.y, n.z)?;
        }
        match geometry.mesh() {
            Some(mesh) => {
                for t in mesh.triangles() {
                    let [a, b, c] = t.map(corner);
                    writeln!(out, "f {a} {b} {c}")?;
                }
            }
            None => {
                for i in 0..points.len() as u32 {
                    writeln!(out, "p {}", corner(i))?;
                }
            }
        }
        Ok(())
    })
}

/// A face corner as OBJ writes it: `i`, `i/i`, `i//i` or `i/i/i` (1-based; the vertex, its
/// UV and its normal share an index).
struct Corner {
    index: u64,
    uv: bool,
    normal: bool,
}

impl std::fmt::Display for Corner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let i = self.index;
        match (self.uv, self.normal) {
            (true, true) => write!(f, "{i}/{i}/{i}"),
            (true, false) => write!(f, "{i}/{i}"),
            (false, true) => write!(f, "{i}//{i}"),
            (false, false) => write!(f, "{i}"),
        }
    }
}
