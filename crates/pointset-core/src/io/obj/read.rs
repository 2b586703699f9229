//! Reading OBJ text line by line, as it streams in: the `v`, `vt`, `vn` and `f` lines
//! checked with their line numbers and gathered into arrays, and the face corners
//! numbered into vertices as they arrive.
//!
//! A vertex is one distinct combination of position, texture coordinate and normal index
//! within an object or group (`o`, `g`): a new object or group that follows faces starts
//! its vertices afresh, so one position used by two groups gives two vertices. This is
//! the numbering `tobj` gives with `single_index` (the reader used before, whose output
//! this one reproduces; the unit tests compare them on generated files).
//!
//! Where this reader differs from `tobj`: `l` lines are skipped (`tobj` read a polyline
//! of three or more points as a face), a comment may follow a `v` line's numbers, a line
//! ending in `\` continues on the next, colours on only some `v` lines are dropped rather
//! than shifted onto the wrong vertices, and every refusal names its line.

use std::collections::HashMap;
use std::io::Read;

use glam::DVec3;

use crate::io::FileFormat;
use crate::io::stream::ByteStream;
use crate::weld::{SeededPositionHash, WordTriple};
use crate::{Error, Location, Result};

/// The index a corner has for a part it leaves out (`1//3` has no texture coordinate).
pub(super) const MISSING: u32 = u32::MAX;

/// A malformed-file error at line `line`.
pub(super) fn malformed(line: usize, message: impl Into<String>) -> Error {
    Error::Malformed {
        format: FileFormat::Obj,
        location: Location::Line(line),
        message: message.into(),
    }
}

/// How many face corners and `v` lines the file has, and how many of them carry a texture
/// coordinate, a normal or a colour: what tells a mixed file, whose UVs, normals or colours
/// the reader must drop, from one that has none.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub(super) struct Forms {
    pub(super) corners: usize,
    pub(super) corners_with_uv: usize,
    pub(super) corners_with_normal: usize,
    pub(super) vertices: usize,
    pub(super) coloured_vertices: usize,
}

/// Everything an OBJ file's lines give.
#[derive(Debug, Default)]
pub(super) struct ObjLines {
    /// Each `v` line's `x y z`, as written.
    pub(super) positions: Vec<DVec3>,
    /// Each `v` line's weight `w` (1 where none is given), once any line has given one.
    weights: Option<Vec<f64>>,
    /// The `r g b` of the `v` lines that have them, in file order.
    pub(super) colours: Vec<[f64; 3]>,
    /// Each `vt` line's `u v`.
    pub(super) uvs: Vec<[f64; 2]>,
    /// Each `vn` line's normal.
    pub(super) normals: Vec<DVec3>,
    /// The forms counted.
    pub(super) forms: Forms,
    /// Each vertex's `v`, `vt` and `vn` index (0-based; [`MISSING`] where absent).
    pub(super) vertices: Vec<[u32; 3]>,
    /// Every face's vertices, one face after the other.
    pub(super) corners: Vec<u32>,
    /// How many corners each face has.
    pub(super) arities: Vec<u32>,
    /// The current object's vertices by their `v`, `vt` and `vn` indices.
    numbering: HashMap<WordTriple, u32, SeededPositionHash>,
    /// Whether the current object has faces.
    object_has_faces: bool,
    /// One face's corners, reused.
    face: Vec<[u32; 3]>,
}

impl ObjLines {
    /// The position `v` a vertex's index names: `x y z` divided by the weight `w`.
    pub(super) fn position(&self, v: u32) -> DVec3 {
        let p = self.positions[v as usize];
        match &self.weights {
            Some(weights) => p / weights[v as usize],
            None => p,
        }
    }

    /// Every vertex's position ([`ObjLines::position`] of its `v` index); the `v` lines'
    /// own arrays are freed, since nothing else needs them once faces made a mesh.
    pub(super) fn take_vertex_positions(&mut self) -> Vec<DVec3> {
        let positions = self
            .vertices
            .iter()
            .map(|&[v, ..]| self.position(v))
            .collect();
        self.positions = Vec::new();
        self.weights = None;
        positions
    }

    /// Reads an OBJ file's lines from `stream`. A line ending in `\` continues on the
    /// next: such lines are joined (errors name the first of them); the others are read
    /// where they lie.
    pub(super) fn read<R: Read>(stream: &mut ByteStream<R>) -> Result<Self> {
        let mut lines = ObjLines::default();
        let (mut raw, mut joined) = (Vec::new(), String::new());
        let (mut number, mut first) = (0, 1);
        loop {
            let not_text = |at| malformed(number + 1, format!("not UTF-8 text (at byte {at})"));
            let Some(line) = stream.read_text_line(&mut raw, not_text)? else {
                break;
            };
            number += 1;
            match line.trim_end().strip_suffix('\\') {
                Some(part) => {
                    joined.push_str(part);
                    joined.push(' ');
                }
                None if joined.is_empty() => {
                    lines.line(line, number)?;
                    first = number + 1;
                }
                None => {
                    joined.push_str(line);
                    lines.line(&joined, first)?;
                    joined.clear();
                    first = number + 1;
                }
            }
        }
        // A continuation on the last line ends with the file.
        if !joined.is_empty() {
            lines.line(&joined, first)?;
        }
        // The numbering is done: free its table (about 30 bytes a vertex).
        lines.numbering = HashMap::default();
        Ok(lines)
    }

    /// Reads one (logical) line, the `number`th of the file.
    fn line(&mut self, line: &str, number: usize) -> Result<()> {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => self.vertex_line(words, number),
            Some("vt") => {
                let [u, v, ..] = numbers(words, number, 2)?[..] else {
                    return Err(malformed(number, "expected at least 2 numbers"));
                };
                self.uvs.push([u, v]);
                Ok(())
            }
            Some("vn") => {
                let [x, y, z, ..] = numbers(words, number, 3)?[..] else {
                    return Err(malformed(number, "expected at least 3 numbers"));
                };
                self.normals.push(DVec3::new(x, y, z));
                Ok(())
            }
            Some("f") => self.face_line(words, number),
            Some("o" | "g") => {
                if self.object_has_faces {
                    self.numbering.clear();
                    self.object_has_faces = false;
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// A `v` line: `x y z`, `x y z w` or `x y z r g b`.
    fn vertex_line<'a>(&mut self, words: impl Iterator<Item = &'a str>, line: usize) -> Result<()> {
        let values = numbers(words, line, 3)?;
        let at = self.positions.len();
        self.positions
            .push(DVec3::new(values[0], values[1], values[2]));
        self.forms.vertices += 1;
        match values[3..] {
            [] => {
                if let Some(weights) = &mut self.weights {
                    weights.push(1.0);
                }
            }
            [w] => {
                if w == 0.0 {
                    return Err(malformed(line, "a vertex weight `w` of 0"));
                }
                let weights = self.weights.get_or_insert_with(|| vec![1.0; at]);
                weights.push(w);
            }
            [r, g, b] => {
                if let Some(weights) = &mut self.weights {
                    weights.push(1.0);
                }
                self.colours.push([r, g, b]);
                self.forms.coloured_vertices += 1;
            }
            _ => {
                return Err(malformed(
                    line,
                    format!(
                        "{} numbers: a `v` line holds x y z, x y z w or x y z r g b",
                        values.len()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// An `f` line: its corners checked, then numbered into the current object's vertices.
    fn face_line<'a>(&mut self, words: impl Iterator<Item = &'a str>, line: usize) -> Result<()> {
        let counts = [self.positions.len(), self.uvs.len(), self.normals.len()];
        let mut face = std::mem::take(&mut self.face);
        face_corners(words, line, counts, &mut self.forms, &mut face)?;
        for &corner in &face {
            let next = u32::try_from(self.vertices.len())
                .ok()
                .filter(|&n| n < MISSING)
                .ok_or_else(|| malformed(line, "more than 2^32 - 1 vertices"))?;
            let vertex = *self.numbering.entry(WordTriple(corner)).or_insert(next);
            if vertex == next {
                self.vertices.push(corner);
            }
            self.corners.push(vertex);
        }
        self.arities.push(face.len() as u32);
        self.object_has_faces = true;
        self.face = face;
        Ok(())
    }
}

/// The numbers after a `v`, `vn` or `vt` keyword on line `line` (up to a trailing `#`
/// comment); at least `least`.
pub(super) fn numbers<'a>(
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

/// One `f` line's corners (`v`, `v/vt`, `v//vn`, `v/vt/vn`, 1-based or negative relative
/// indices) into `face` as 0-based `v`, `vt`, `vn` indices ([`MISSING`] where absent),
/// checked against the `v`, `vt` and `vn` counts so far, with their forms counted.
fn face_corners<'a>(
    corners: impl Iterator<Item = &'a str>,
    line: usize,
    counts: [usize; 3],
    forms: &mut Forms,
    face: &mut Vec<[u32; 3]>,
) -> Result<()> {
    const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    face.clear();
    for corner in corners {
        if corner.starts_with('#') {
            return Err(malformed(
                line,
                "a comment after a face: OBJ comments must start their own line",
            ));
        }
        let not_a_corner = || malformed(line, format!("`{corner}` is not a face corner"));
        let mut indices = [MISSING; 3];
        for (k, part) in corner.split('/').enumerate() {
            if k > 2 {
                return Err(not_a_corner());
            }
            if part.is_empty() && k > 0 {
                continue;
            }
            match k {
                1 => forms.corners_with_uv += 1,
                2 => forms.corners_with_normal += 1,
                _ => forms.corners += 1,
            }
            let index: i64 = part.parse().map_err(|_| not_a_corner())?;
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
            let resolved = if index < 0 { count + index } else { index - 1 };
            indices[k] = u32::try_from(resolved)
                .ok()
                .filter(|&i| i < MISSING)
                .ok_or_else(|| {
                    malformed(line, format!("{} index {index} is too large", KINDS[k]))
                })?;
        }
        face.push(indices);
    }
    if face.len() < 3 {
        return Err(malformed(
            line,
            format!("a face needs three corners, this one has {}", face.len()),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use std::fmt::Write;

    use proptest::prelude::*;

    use super::*;

    /// What `tobj` makes of `text`, as one list of vertex positions, normals, texture
    /// coordinates and colours, and the faces' corners and arities.
    type Parts = (
        Vec<DVec3>,
        Vec<DVec3>,
        Vec<[f64; 2]>,
        Vec<[f64; 3]>,
        Vec<u32>,
        Vec<u32>,
    );

    fn by_tobj(text: &str) -> Parts {
        let options = tobj::LoadOptions {
            single_index: true,
            triangulate: false,
            ignore_points: true,
            ignore_lines: true,
        };
        let no_materials = |_: &std::path::Path| Ok((Vec::new(), Default::default()));
        let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &options, no_materials).unwrap();
        let mut parts = Parts::default();
        for model in models {
            let mesh = model.mesh;
            let base = parts.0.len() as u32;
            let triples = |v: &[f64]| -> Vec<[f64; 3]> {
                v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
            };
            parts
                .0
                .extend(triples(&mesh.positions).into_iter().map(DVec3::from));
            parts
                .1
                .extend(triples(&mesh.normals).into_iter().map(DVec3::from));
            parts
                .2
                .extend(mesh.texcoords.chunks_exact(2).map(|c| [c[0], c[1]]));
            parts.3.extend(triples(&mesh.vertex_color));
            parts.4.extend(mesh.indices.iter().map(|i| i + base));
            let arities = if mesh.face_arities.is_empty() {
                vec![3; mesh.indices.len() / 3]
            } else {
                mesh.face_arities
            };
            parts.5.extend(arities);
        }
        parts
    }

    /// The same parts from this reader.
    fn by_lines(text: &str) -> Parts {
        let lines = ObjLines::read(&mut ByteStream::of_bytes(text.as_bytes())).unwrap();
        let of = |k: usize| lines.vertices.iter().filter(move |v| v[k] != MISSING);
        let coloured = !lines.colours.is_empty();
        (
            lines
                .vertices
                .iter()
                .map(|&[v, ..]| lines.position(v))
                .collect(),
            of(2).map(|&[_, _, n]| lines.normals[n as usize]).collect(),
            of(1).map(|&[_, t, _]| lines.uvs[t as usize]).collect(),
            (lines.vertices.iter())
                .filter(|_| coloured)
                .map(|&[v, ..]| lines.colours[v as usize])
                .collect(),
            lines.corners.clone(),
            lines.arities.clone(),
        )
    }

    /// An OBJ text from the choices: `v` lines (with a weight or a colour on all of them
    /// or none), `vt` and `vn` lines, faces of 3 to 6 corners in every form with positive
    /// and negative indices, objects and groups, two-point `l` lines, comments and blank
    /// lines, in an order where every corner refers to what comes before it.
    fn obj_text(choices: &[(u8, u8, u8)], colours: bool, uvs: bool, normals: bool) -> String {
        let mut text = String::from("# generated\n");
        let (mut v, mut vt, mut vn) = (0i64, 0i64, 0i64);
        for (k, &(what, a, b)) in choices.iter().enumerate() {
            let x = f64::from(a) * 0.25 - 7.0;
            let y = f64::from(b) * 0.5;
            match what % 8 {
                0 | 1 => {
                    v += 1;
                    match (colours, a % 4) {
                        (true, _) => writeln!(text, "v {x} {y} {k} 0.{a} 0.{b} 1"),
                        (false, 0) => writeln!(text, "v {x} {y} {k} {}", 1 + b % 3),
                        (false, _) => writeln!(text, "v {x} {y} {k}"),
                    }
                }
                2 if uvs => {
                    vt += 1;
                    writeln!(text, "vt {} {}", f64::from(a) / 255.0, f64::from(b) / 255.0)
                }
                3 if normals => {
                    vn += 1;
                    writeln!(text, "vn {x} {y} 1")
                }
                4 | 5 if v > 0 && (!uvs || vt > 0) && (!normals || vn > 0) => {
                    let n = 3 + usize::from(a % 4);
                    let corners: Vec<String> = (0..n)
                        .map(|c| {
                            let pick = |count: i64, salt: usize| {
                                let i = (usize::from(b) * 7 + c * 13 + salt) as i64 % count;
                                if (c + salt).is_multiple_of(3) {
                                    -(i + 1)
                                } else {
                                    count - i
                                }
                            };
                            let p = pick(v, 0);
                            match (uvs, normals) {
                                (true, true) => format!("{p}/{}/{}", pick(vt, 1), pick(vn, 2)),
                                (true, false) => format!("{p}/{}", pick(vt, 1)),
                                (false, true) => format!("{p}//{}", pick(vn, 2)),
                                (false, false) => format!("{p}"),
                            }
                        })
                        .collect();
                    writeln!(text, "f {}", corners.join(" "))
                }
                6 => writeln!(text, "{} part{a}", if b % 2 == 0 { "o" } else { "g" }),
                7 if v > 1 => writeln!(text, "l 1 {v}"),
                _ => writeln!(text, "\n# {a}"),
            }
            .unwrap();
        }
        text
    }

    proptest! {
        /// The vertices, attributes and faces equal `tobj`'s with `single_index`.
        #[test]
        fn files_read_as_tobj_reads_them(
            choices in proptest::collection::vec((any::<u8>(), any::<u8>(), any::<u8>()), 1..60),
            colours in any::<bool>(),
            uvs in any::<bool>(),
            normals in any::<bool>(),
        ) {
            let text = obj_text(&choices, colours, uvs, normals);
            prop_assert_eq!(by_lines(&text), by_tobj(&text), "{}", text);
        }
    }

    #[test]
    fn the_generated_files_have_every_part() {
        let choices: Vec<(u8, u8, u8)> = (0..400u32)
            .map(|i| {
                (
                    (i * 5 % 8) as u8,
                    ((i * 37 + i / 3) % 256) as u8,
                    ((i * 91 + i / 8) % 256) as u8,
                )
            })
            .collect();
        let text = obj_text(&choices, false, true, true);
        for keyword in ["v ", "vt ", "vn ", "f ", "o ", "g ", "l ", "/-"] {
            assert!(text.contains(keyword), "{keyword}");
        }
        let parts = by_lines(&text);
        assert!(parts.5.iter().any(|&n| n > 4), "polygons");
        assert_eq!(parts, by_tobj(&text));
    }
}
