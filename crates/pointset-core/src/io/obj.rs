//! Wavefront OBJ: reading through `tobj`, writing in-house.
//!
//! Reading triangulates polygons ([`crate::triangulate_polygon`]: fans when convex, ear
//! clipping when not), unifies position/UV/normal indices into one vertex per distinct
//! combination (so vertices on UV seams are duplicated, the way every GPU-style mesh stores
//! them), keeps per-vertex colours (`v x y z r g b`) as `red/green/blue` channels, merges
//! all objects and groups into one mesh, and ignores materials and line elements. A file
//! without faces (bare `v` lines, the usual point-cloud OBJ) becomes a point set; `vn`
//! lines are its normals when there is one per vertex.
//!
//! Before `tobj` reads the file, its `v`, `vt`, `vn` and `f` lines are checked, so that a
//! malformed file is refused with the line at fault ([`crate::Error::Malformed`]): numbers
//! that do not parse, too few of them, face corners that refer to elements not defined
//! before them, faces of fewer than three corners (which `tobj` would drop silently), and
//! comments after a face.

use std::io::Write;
use std::path::Path;

use glam::{DVec3, Vec2};

use super::buffered::{buffered, comment_lines};
use super::{Geometry, position_text, relative_positions};
use crate::{Error, PointSet, Result, TriMesh, triangulate_polygon};

fn obj_error(path: &Path, message: impl Into<String>) -> Error {
    Error::Obj {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Triples of `tobj`'s values (double precision: positions keep the file's digits).
fn triples(values: &[f64]) -> impl Iterator<Item = DVec3> + '_ {
    values.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2]))
}

fn malformed(line: usize, message: impl Into<String>) -> Error {
    Error::Malformed {
        format: super::FileFormat::Obj,
        location: crate::Location::Line(line),
        message: message.into(),
    }
}

/// The file as text (OBJ is a text format).
fn obj_text(bytes: &[u8]) -> Result<&str> {
    std::str::from_utf8(bytes)
        .map_err(|e| malformed(1, format!("not UTF-8 text (at byte {})", e.valid_up_to())))
}

/// The numbers after a `v`, `vn` or `vt` keyword on line `line` (up to a trailing `#`
/// comment); at least `least`.
fn numbers<'a>(
    words: impl Iterator<Item = &'a str>,
    line: usize,
    least: usize,
) -> Result<Vec<f64>> {
    let values = words
        .take_while(|w| !w.starts_with('#'))
        .map(|w| {
            w.parse::<f64>()
                .map_err(|_| malformed(line, format!("`{w}` is not a number")))
        })
        .collect::<Result<Vec<f64>>>()?;
    if values.len() < least {
        return Err(malformed(
            line,
            format!("expected at least {least} numbers"),
        ));
    }
    Ok(values)
}

/// How many face corners and `v` lines the file has, and how many of them carry a texture
/// coordinate, a normal or a colour: what tells a mixed file, whose UVs, normals or colours
/// the reader must drop, from one that has none.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
struct Forms {
    corners: usize,
    corners_with_uv: usize,
    corners_with_normal: usize,
    vertices: usize,
    coloured_vertices: usize,
}

/// Checks one `f` line's corners (`v`, `v/vt`, `v//vn`, `v/vt/vn`, 1-based or negative
/// relative indices) against the `v`, `vt` and `vn` counts so far, and counts their forms.
fn check_face<'a>(
    corners: impl Iterator<Item = &'a str>,
    line: usize,
    counts: [usize; 3],
    forms: &mut Forms,
) -> Result<()> {
    const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let mut n = 0;
    for corner in corners {
        if corner.starts_with('#') {
            return Err(malformed(
                line,
                "a comment after a face: OBJ comments must start their own line",
            ));
        }
        n += 1;
        for (k, part) in corner.split('/').enumerate().take(3) {
            if part.is_empty() && k > 0 {
                continue;
            }
            match k {
                1 => forms.corners_with_uv += 1,
                2 => forms.corners_with_normal += 1,
                _ => forms.corners += 1,
            }
            let index: i64 = part
                .parse()
                .map_err(|_| malformed(line, format!("`{corner}` is not a face corner")))?;
            let count = counts[k] as i64;
            if index == 0 || index > count || index < -count {
                return Err(malformed(
                    line,
                    format!(
                        "face corner `{corner}` refers to {} {index}, but the file defines \
                         {count} before it",
                        KINDS[k]
                    ),
                ));
            }
        }
    }
    if n < 3 {
        return Err(malformed(
            line,
            format!("a face needs three corners, this one has {n}"),
        ));
    }
    Ok(())
}

/// Checks the lines `tobj` reads (`v`, `vn`, `vt`, `f`), so that a malformed file is refused
/// with its line number, and a face with fewer than three corners is refused instead of
/// dropped; returns the forms counted. From the first `\` line continuation on, the lines
/// are left to `tobj` and nothing is counted (`None`).
fn check_lines(text: &str) -> Result<Option<Forms>> {
    let mut counts = [0usize; 3];
    let mut forms = Forms::default();
    for (i, line) in text.lines().enumerate() {
        if line.trim_end().ends_with('\\') {
            return Ok(None);
        }
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let values = numbers(words, i + 1, 3)?;
                counts[0] += 1;
                forms.vertices += 1;
                forms.coloured_vertices += usize::from(values.len() >= 6);
            }
            Some("vt") => {
                numbers(words, i + 1, 2)?;
                counts[1] += 1;
            }
            Some("vn") => {
                numbers(words, i + 1, 3)?;
                counts[2] += 1;
            }
            Some("f") => check_face(words, i + 1, counts, &mut forms)?,
            _ => {}
        }
    }
    Ok(Some(forms))
}

/// `text` with every `v` line cut to its keyword and position (line numbers kept).
fn without_vertex_colours(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut words = line.split_whitespace();
        if words.next() == Some("v") {
            out.push('v');
            for word in words.take(3) {
                out.push(' ');
                out.push_str(word);
            }
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    out
}

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

/// Reads an OBJ file held in memory; `path` is used in error messages only.
pub fn read_obj(path: &Path, bytes: &[u8]) -> Result<Geometry> {
    read_obj_at(path, bytes, false).map(|(geometry, _, _)| geometry)
}

/// [`read_obj`], with positions stored relative to an origin when `recentre_far` is set
/// and the data lies far from the file's origin ([`super::ReadOptions::recentre_far`]);
/// returns the origin too, and notes on what the file had that the mesh could not keep
/// ([`super::LoadedGeometry::notes`]).
pub(crate) fn read_obj_at(
    path: &Path,
    bytes: &[u8],
    recentre_far: bool,
) -> Result<(Geometry, DVec3, Vec<String>)> {
    let options = tobj::LoadOptions {
        single_index: true,
        // Polygons are split here (`triangulate_polygon`): tobj's fans fold concave ones.
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let text = obj_text(bytes)?;
    let forms = check_lines(text)?;
    // Colours on some `v` lines only would shift `tobj`'s colour indices (wrong colours or
    // an error): such a file is read without colours, and the notes say so.
    let uncoloured;
    let source = match forms {
        Some(f) if f.coloured_vertices > 0 && f.coloured_vertices < f.vertices => {
            uncoloured = without_vertex_colours(text);
            uncoloured.as_bytes()
        }
        _ => bytes,
    };
    let mut reader = std::io::BufReader::new(source);
    let (models, _materials) = tobj::load_obj_buf(&mut reader, &options, |_| {
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| obj_error(path, e.to_string()))?;

    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut colors = Vec::new();
    // Every face's corners (indices into `positions`), one after the other, and how many
    // each face has.
    let (mut corners, mut arities) = (Vec::new(), Vec::new());
    let (mut all_normals, mut all_uvs, mut all_colors) = (true, true, true);
    for model in &models {
        let mesh = &model.mesh;
        let base = u32::try_from(positions.len())
            .map_err(|_| obj_error(path, "more than 2^32 vertices"))?;
        let count = mesh.positions.len() / 3;
        positions.extend(triples(&mesh.positions));
        all_normals &= mesh.normals.len() == 3 * count;
        normals.extend(triples(&mesh.normals).map(DVec3::as_vec3));
        all_uvs &= mesh.texcoords.len() == 2 * count;
        uvs.extend(
            mesh.texcoords
                .chunks_exact(2)
                .map(|c| Vec2::new(c[0] as f32, c[1] as f32)),
        );
        all_colors &= mesh.vertex_color.len() == 3 * count;
        colors.extend(triples(&mesh.vertex_color).map(|c| c.as_vec3().to_array()));
        // tobj leaves the arities empty when every face is a triangle.
        let face_arities = if mesh.face_arities.is_empty() {
            vec![3; mesh.indices.len() / 3]
        } else {
            mesh.face_arities.clone()
        };
        let mut start = 0;
        for arity in face_arities {
            let face = mesh
                .indices
                .get(start..start + arity as usize)
                .ok_or_else(|| obj_error(path, "face indices end early"))?;
            if let Some(&bad) = face.iter().find(|&&i| i as usize >= count) {
                return Err(Error::IndexOutOfRange {
                    face: arities.len(),
                    vertex: i64::from(bad),
                    vertex_count: count,
                });
            }
            corners.extend(face.iter().map(|&i| i + base));
            arities.push(arity as usize);
            start += arity as usize;
        }
    }
    if positions.is_empty() {
        return read_point_cloud(text, recentre_far)
            .map(|(points, origin, notes)| (Geometry::Points(points), origin, notes));
    }
    let (positions, origin) = relative_positions(&positions, recentre_far);
    let mut points = PointSet::new(positions)?;
    if all_normals && !normals.is_empty() {
        points = points.with_normals(normals)?;
    }
    if all_colors && !colors.is_empty() {
        points.set_colors(&colors)?;
    }
    let mut triangles = Vec::with_capacity(corners.len().saturating_sub(2 * arities.len()));
    let mut start = 0;
    for arity in arities {
        let face = &corners[start..start + arity];
        triangulate_polygon(points.positions(), face, &mut triangles);
        start += arity;
    }
    let mut mesh = TriMesh::new(points, triangles)?;
    if all_uvs && !uvs.is_empty() {
        mesh = mesh.with_uvs(uvs)?;
    }
    let notes = forms.map_or_else(Vec::new, |forms| dropped_notes(&forms, &mesh));
    Ok((Geometry::Mesh(mesh), origin, notes))
}

/// Reads a face-less OBJ: `v x y z [r g b]` lines and optional `vn` lines (the normals when
/// there is one per `v` line); notes say what was dropped.
fn read_point_cloud(text: &str, recentre_far: bool) -> Result<(PointSet, DVec3, Vec<String>)> {
    let (mut positions, mut normals, mut colors) = (Vec::new(), Vec::new(), Vec::new());
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let keyword = words.next();
        if !matches!(keyword, Some("v" | "vn")) {
            continue;
        }
        let values = numbers(words, i + 1, 3)?;
        let v = DVec3::new(values[0], values[1], values[2]);
        if keyword == Some("vn") {
            normals.push(v.as_vec3());
        } else {
            positions.push(v);
            if let [_, _, _, r, g, b, ..] = values[..] {
                colors.push([r as f32, g as f32, b as f32]);
            }
        }
    }
    if positions.is_empty() {
        return Err(malformed(1, "no vertices (`v` lines) found"));
    }
    let count = positions.len();
    let mut notes = Vec::new();
    let (positions, origin) = relative_positions(&positions, recentre_far);
    let mut points = PointSet::new(positions)?;
    if normals.len() == count {
        points = points.with_normals(normals)?;
    } else if !normals.is_empty() {
        notes.push(format!(
            "normals dropped: {} `vn` lines for {count} points (one per point is needed)",
            normals.len()
        ));
    }
    if colors.len() == count {
        points.set_colors(&colors)?;
    } else if !colors.is_empty() {
        notes.push(format!(
            "colours dropped: {} of {count} `v` lines have them; a point set carries them at \
             every point or not at all",
            colors.len()
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
