//! Object File Format (OFF, with the `N` normal and `C` colour prefixes: `NOFF`, `COFF`,
//! `CNOFF`). Polygons are split into triangles (fans when convex, ear clipping when not:
//! [`crate::triangulate_polygon`]); per-face colours are skipped, and the reader's notes
//! say so ([`super::LoadedGeometry::notes`]). Vertex colours may be integers in `0..=255`
//! or floats in `0..=1` (decided per file: any value above 1 means the integer range).

use std::io::{Read, Write};

use glam::{DVec3, Vec3};

use super::buffered::{buffered, comment_lines};
use super::stream::ByteStream;
use super::{FileFormat, Geometry, position_text, relative_positions, unit_colours};
use crate::{Error, Location, PointSet, Result, TriMesh, triangulate_polygon};

fn malformed(line: usize, message: impl Into<String>) -> Error {
    Error::Malformed {
        format: FileFormat::Off,
        location: Location::Line(line),
        message: message.into(),
    }
}

/// An OFF file's lines as they stream in: the non-empty ones with comments cut off, with
/// their 1-based numbers, and the file's `#` comment lines gathered on the way.
struct Lines<R> {
    stream: ByteStream<R>,
    line: Vec<u8>,
    /// Lines read so far.
    number: usize,
    comments: Vec<String>,
}

impl<R: Read> Lines<R> {
    fn new(reader: R, len: u64) -> Self {
        Lines {
            stream: ByteStream::new(reader, len),
            line: Vec::new(),
            number: 0,
            comments: Vec::new(),
        }
    }

    /// The next line with words before any `#`, and its number; `None` at the end.
    fn next(&mut self) -> Result<Option<(usize, Vec<&str>)>> {
        let not_text = |at| Error::Malformed {
            format: FileFormat::Off,
            location: Location::Byte(at),
            message: "not valid UTF-8 text (binary OFF is not supported)".into(),
        };
        loop {
            let Some(line) = self.stream.read_text_line(&mut self.line, not_text)? else {
                return Ok(None);
            };
            self.number += 1;
            if let Some(comment) = line.trim_start().strip_prefix('#') {
                self.comments.push(comment.trim().to_string());
            }
            if words_before_comment(line).next().is_some() {
                break;
            }
        }
        // The line was checked as text above.
        let line = std::str::from_utf8(&self.line).unwrap_or("");
        Ok(Some((self.number, words_before_comment(line).collect())))
    }

    /// The end of a file that stops early: where it ends, and what it lacked.
    fn ended(&self, what: String) -> Error {
        Error::UnexpectedEof {
            format: FileFormat::Off,
            location: Location::Line(self.number + 1),
            what,
        }
    }

    /// The comments of the whole file, the lines after the data read for theirs.
    fn comments(mut self) -> Result<Vec<String>> {
        while self.next()?.is_some() {}
        Ok(self.comments)
    }
}

/// The words of `line` before any `#`.
fn words_before_comment(line: &str) -> std::str::SplitWhitespace<'_> {
    line.split('#').next().unwrap_or("").split_whitespace()
}

fn numbers(line: usize, words: &[&str]) -> Result<Vec<f64>> {
    words
        .iter()
        .map(|w| {
            w.parse::<f64>()
                .map_err(|_| malformed(line, format!("`{w}` is not a number")))
        })
        .collect()
}

/// Reads an OFF file held in memory; returns the geometry and the file's `#` comments.
pub fn read_off(bytes: &[u8]) -> Result<(Geometry, Vec<String>)> {
    read_off_at(bytes, false).map(|file| (file.geometry, file.comments))
}

/// An OFF file as read.
pub(crate) struct OffFile {
    /// The points or mesh.
    pub(crate) geometry: Geometry,
    /// The file's `#` comments.
    pub(crate) comments: Vec<String>,
    /// The origin positions are stored relative to.
    pub(crate) origin: DVec3,
    /// What was skipped (per-face values).
    pub(crate) notes: Vec<String>,
}

/// [`read_off`], with positions stored relative to an origin when `recentre_far` is set
/// and the data lies far from the file's origin ([`super::ReadOptions::recentre_far`]);
/// returns the origin too, and notes on what was skipped.
pub(crate) fn read_off_at(bytes: &[u8], recentre_far: bool) -> Result<OffFile> {
    read_off_from(bytes, bytes.len() as u64, recentre_far)
}

/// [`read_off_at`] of the `len` bytes of text `reader` gives, read line by line as they
/// stream in.
pub(crate) fn read_off_from(reader: impl Read, len: u64, recentre_far: bool) -> Result<OffFile> {
    let mut lines = Lines::new(reader, len);
    let Some((first_line, first)) = lines.next()? else {
        return Err(malformed(1, "no OFF keyword"));
    };
    let first: Vec<String> = first.iter().map(|w| w.to_string()).collect();
    let keyword = first[0].as_str();
    let (has_normals, has_colors) = match keyword {
        "OFF" => (false, false),
        "NOFF" => (true, false),
        "COFF" => (false, true),
        "CNOFF" | "NCOFF" => (true, true),
        other => {
            return Err(malformed(
                first_line,
                format!("unsupported OFF variant `{other}`"),
            ));
        }
    };
    // Counts may follow the keyword on the same line.
    let (count_line, count_words) = if first.len() > 1 {
        (first_line, first[1..].to_vec())
    } else {
        match lines.next()? {
            Some((line, words)) => (line, words.iter().map(|w| w.to_string()).collect()),
            None => return Err(malformed(first_line + 1, "missing vertex/face counts")),
        }
    };
    let counts: Vec<u64> = count_words
        .iter()
        .take(2)
        .map(|w| w.parse::<u64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| malformed(count_line, "counts must be non-negative integers"))?;
    let [nv, nf] = counts[..] else {
        return Err(malformed(count_line, "expected `VERTICES FACES [EDGES]`"));
    };
    // A vertex line needs at least 6 bytes ("0 0 0\n"), a face line at least 8 ("3 0 1 2\n").
    let needed = u128::from(nv) * 6 + u128::from(nf) * 8;
    let available = len;
    if needed > u128::from(available) {
        return Err(Error::HeaderExceedsFile {
            format: FileFormat::Off,
            element: if u128::from(nv) * 6 > u128::from(available) {
                "vertex"
            } else {
                "face"
            }
            .into(),
            declared: if u128::from(nv) * 6 > u128::from(available) {
                nv
            } else {
                nf
            },
            needed_bytes: needed,
            available_bytes: available,
        });
    }
    let (nv, nf) = (nv as usize, nf as usize);
    let stride = 3 + if has_normals { 3 } else { 0 };
    let mut positions = Vec::with_capacity(nv);
    let mut normals = Vec::with_capacity(if has_normals { nv } else { 0 });
    let mut raw_colors = Vec::new();
    for v in 0..nv {
        let Some((line, words)) = lines.next()? else {
            return Err(lines.ended(format!("vertex {v} of {nv}")));
        };
        let need = stride + if has_colors { 3 } else { 0 };
        if words.len() < need {
            return Err(malformed(line, format!("vertex line needs {need} numbers")));
        }
        let x = numbers(line, &words[..need])?;
        positions.push(DVec3::new(x[0], x[1], x[2]));
        if has_normals {
            normals.push(Vec3::new(x[3] as f32, x[4] as f32, x[5] as f32));
        }
        if has_colors {
            raw_colors.push([x[stride], x[stride + 1], x[stride + 2]]);
        }
    }
    let (positions, origin) = relative_positions(&positions, recentre_far);
    let mut points = PointSet::new(positions)?;
    if has_normals {
        points = points.with_normals(normals)?;
    }
    if has_colors {
        points.set_colors(&unit_colours(&raw_colors))?;
    }
    let mut triangles = Vec::with_capacity(nf);
    let mut faces_with_values = 0;
    for face in 0..nf {
        let Some((line, words)) = lines.next()? else {
            return Err(lines.ended(format!("face {face} of {nf}")));
        };
        let n: usize = words[0]
            .parse()
            .map_err(|_| malformed(line, "face must start with its vertex count"))?;
        if n < 3 {
            return Err(Error::InvalidFace {
                face,
                reason: format!("{n} vertex indices (at least 3 needed)"),
            });
        }
        if words.len() < n + 1 {
            return Err(Error::ListCountOverflow {
                format: FileFormat::Off,
                location: Location::Line(line),
                count: n as i128,
                reason: format!("but the line has only {} indices", words.len() - 1),
            });
        }
        let mut idx = Vec::with_capacity(n);
        for w in &words[1..=n] {
            let i: i64 = w
                .parse()
                .map_err(|_| malformed(line, format!("`{w}` is not a vertex index")))?;
            if i < 0 || i as usize >= nv {
                return Err(Error::IndexOutOfRange {
                    face,
                    vertex: i,
                    vertex_count: nv,
                });
            }
            idx.push(i as u32);
        }
        triangulate_polygon(points.positions(), &idx, &mut triangles);
        faces_with_values += usize::from(words.len() > n + 1);
    }
    let notes = if faces_with_values > 0 {
        vec![format!(
            "per-face values (colours) on {faces_with_values} of {nf} faces skipped (a mesh \
             keeps values per vertex, not per face)"
        )]
    } else {
        Vec::new()
    };
    let geometry = if nf == 0 {
        Geometry::Points(points)
    } else {
        Geometry::Mesh(TriMesh::new(points, triangles)?)
    };
    Ok(OffFile {
        geometry,
        comments: lines.comments()?,
        origin,
        notes,
    })
}

/// Writes ASCII OFF (`NOFF`/`COFF`/`CNOFF` when normals or colours exist; colours as
/// integers in `0..=255` with alpha 255). Point sets are written with zero faces.
pub fn write_off(geometry: &Geometry, comments: &[String], out: &mut impl Write) -> Result<()> {
    write_off_at(geometry, comments, DVec3::ZERO, out)
}

/// [`write_off`] with `origin` added to every position, in double precision.
pub(crate) fn write_off_at(
    geometry: &Geometry,
    comments: &[String],
    origin: DVec3,
    out: &mut impl Write,
) -> Result<()> {
    let points = geometry.points();
    let normals = points.normals();
    let colors = points.colors();
    let keyword = format!(
        "{}{}OFF",
        if colors.is_some() { "C" } else { "" },
        if normals.is_some() { "N" } else { "" }
    );
    let tris = geometry.mesh().map_or(&[][..], TriMesh::triangles);
    buffered(out, |out| {
        writeln!(out, "{keyword}")?;
        comment_lines(out, comments)?;
        writeln!(out, "{} {} 0", points.len(), tris.len())?;
        for (i, p) in points.positions().iter().enumerate() {
            write!(out, "{}", position_text(*p, origin))?;
            if let Some(n) = normals {
                write!(out, " {} {} {}", n[i].x, n[i].y, n[i].z)?;
            }
            if let Some(c) = &colors {
                let [r, g, b] = c[i].map(|x| (x * 255.0).round() as u8);
                write!(out, " {r} {g} {b} 255")?;
            }
            writeln!(out)?;
        }
        for t in tris {
            writeln!(out, "3 {} {} {}", t[0], t[1], t[2])?;
        }
        Ok(())
    })
}
