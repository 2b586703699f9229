//! XYZ point clouds: one point a line, its numbers separated by spaces, tabs, commas or
//! semicolons, as scanners, CloudCompare, MeshLab and Open3D write them. Which numbers a
//! line holds is told by the extension, as Open3D names them:
//!
//! - `.xyz`: `x y z`, or `x y z nx ny nz` (positions and normals, as MeshLab writes them);
//!   every line has as many numbers as the first, and three numbers after a position must
//!   look like a normal (length 1/2 to 3/2, or zero): colours are refused, not taken for
//!   normals;
//! - `.xyzn`: `x y z nx ny nz`;
//! - `.xyzrgb`: `x y z r g b`, colours in `0..=1`, or in `0..=255` when any value exceeds 1
//!   (decided per file, as for OFF).
//!
//! Lines starting with `#` or `//` are comments (CloudCompare writes its column names as
//! `//X,Y,Z`); blank lines are skipped. XYZ holds points only: a mesh is refused, since its
//! faces would be lost.

use std::io::{Read, Write};

use glam::{DVec3, Vec3};

use super::buffered::{buffered, comment_lines};
use super::stream::ByteStream;
use super::{FileFormat, Geometry, position_text, relative_positions, unit_colours};
use crate::{Error, Location, PointSet, Result};

/// Which numbers each line of an XYZ file holds (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum XyzColumns {
    /// `.xyz`: positions, optionally followed by normals.
    Positions,
    /// `.xyzn`: positions and normals.
    Normals,
    /// `.xyzrgb`: positions and colours.
    Colours,
}

impl XyzColumns {
    /// The extension that names these columns.
    pub fn extension(self) -> &'static str {
        match self {
            XyzColumns::Positions => "xyz",
            XyzColumns::Normals => "xyzn",
            XyzColumns::Colours => "xyzrgb",
        }
    }

    /// How many numbers a line may hold.
    fn allowed(self) -> &'static [usize] {
        match self {
            XyzColumns::Positions => &[3, 6],
            XyzColumns::Normals | XyzColumns::Colours => &[6],
        }
    }

    /// What a line holds, in words, for errors.
    fn layout(self) -> &'static str {
        match self {
            XyzColumns::Positions => "`x y z` or `x y z nx ny nz`",
            XyzColumns::Normals => "`x y z nx ny nz`",
            XyzColumns::Colours => "`x y z r g b`",
        }
    }
}

fn malformed(columns: XyzColumns, line: usize, message: impl Into<String>) -> Error {
    Error::Malformed {
        format: FileFormat::Xyz(columns),
        location: Location::Line(line),
        message: message.into(),
    }
}

/// An XYZ file as read.
pub(crate) struct XyzFile {
    /// The points.
    pub(crate) geometry: Geometry,
    /// The file's comment lines, without their `#` or `//`.
    pub(crate) comments: Vec<String>,
    /// The origin positions are stored relative to.
    pub(crate) origin: DVec3,
}

/// Whether three numbers after a position in an `.xyz` file can be a normal: of length
/// 1/2 to 3/2 (unit, as written with a few digits), or zero (none known). Colours (`r g b`
/// in `0..=255`, as CloudCompare writes them, or dim ones in `0..=1`) mostly are not, so a
/// colour file named `.xyz` is refused rather than read as normals.
fn looks_like_a_normal(n: [f64; 3]) -> bool {
    let length = DVec3::from(n).length();
    length == 0.0 || (0.5..=1.5).contains(&length) || !length.is_finite()
}

/// The comment a line holds, if it is one.
fn comment(line: &str) -> Option<&str> {
    let line = line.trim_start();
    line.strip_prefix("//").or_else(|| line.strip_prefix('#'))
}

/// Reads an XYZ file held in memory as `columns` says; returns the points and the file's
/// comments.
///
/// ```
/// use pointset_core::io::{read_xyz, XyzColumns};
/// let text = b"//X,Y,Z,Nx,Ny,Nz\n0,0,1,0,0,1\n1 0 0 1 0 0\n";
/// let (points, comments) = read_xyz(text, XyzColumns::Positions)?;
/// assert_eq!(points.len(), 2);
/// assert_eq!(points.normals().map(|n| n[1].x), Some(1.0));
/// assert_eq!(comments, ["X,Y,Z,Nx,Ny,Nz"]);
/// # Ok::<(), pointset_core::Error>(())
/// ```
pub fn read_xyz(bytes: &[u8], columns: XyzColumns) -> Result<(PointSet, Vec<String>)> {
    let file = read_xyz_at(bytes, columns, false)?;
    Ok((file.geometry.points().clone(), file.comments))
}

/// [`read_xyz`], with positions stored relative to an origin when `recentre_far` is set
/// and the data lies far from the file's origin ([`super::ReadOptions::recentre_far`]).
pub(crate) fn read_xyz_at(
    bytes: &[u8],
    columns: XyzColumns,
    recentre_far: bool,
) -> Result<XyzFile> {
    read_xyz_from(bytes, bytes.len() as u64, columns, recentre_far)
}

/// [`read_xyz_at`] of the `len` bytes of text `reader` gives, read line by line as they
/// stream in.
pub(crate) fn read_xyz_from(
    reader: impl Read,
    len: u64,
    columns: XyzColumns,
    recentre_far: bool,
) -> Result<XyzFile> {
    let not_text = |at| Error::Malformed {
        format: FileFormat::Xyz(columns),
        location: Location::Byte(at),
        message: "not valid UTF-8 text (an XYZ file is text)".into(),
    };
    let mut stream = ByteStream::new(reader, len);
    let mut raw = Vec::new();
    let mut comments = Vec::new();
    let mut width = None;
    let (mut positions, mut rest) = (Vec::new(), Vec::new());
    let mut number = 0;
    while let Some(line) = stream.read_text_line(&mut raw, not_text)? {
        number += 1;
        if let Some(c) = comment(line) {
            comments.push(c.trim().to_string());
            continue;
        }
        let words: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || c == ',' || c == ';')
            .filter(|w| !w.is_empty())
            .collect();
        if words.is_empty() {
            continue;
        }
        let expected = *width.get_or_insert(words.len());
        if !columns.allowed().contains(&words.len()) {
            return Err(malformed(
                columns,
                number,
                format!(
                    "{} numbers; a .{} file holds {} on every line",
                    words.len(),
                    columns.extension(),
                    columns.layout()
                ),
            ));
        }
        if words.len() != expected {
            return Err(malformed(
                columns,
                number,
                format!(
                    "{} numbers where the first point's line has {expected}",
                    words.len()
                ),
            ));
        }
        let mut values = [0.0f64; 6];
        for (value, word) in values.iter_mut().zip(&words) {
            *value = word
                .parse()
                .map_err(|_| malformed(columns, number, format!("`{word}` is not a number")))?;
        }
        positions.push(DVec3::new(values[0], values[1], values[2]));
        if expected == 6 {
            let after = [values[3], values[4], values[5]];
            if columns == XyzColumns::Positions && !looks_like_a_normal(after) {
                return Err(malformed(
                    columns,
                    number,
                    format!(
                        "({}, {}, {}) after the position is no normal (its length is {:.3}); \
                         for colours, name the file .xyzrgb",
                        after[0],
                        after[1],
                        after[2],
                        DVec3::from(after).length()
                    ),
                ));
            }
            rest.push(after);
        }
    }
    let (relative, origin) = relative_positions(&positions, recentre_far);
    let mut points = PointSet::new(relative)?;
    if !rest.is_empty() {
        match columns {
            XyzColumns::Colours => points.set_colors(&unit_colours(&rest))?,
            XyzColumns::Positions | XyzColumns::Normals => {
                let normals = rest
                    .iter()
                    .map(|n| Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32))
                    .collect();
                points = points.with_normals(normals)?;
            }
        }
    }
    Ok(XyzFile {
        geometry: Geometry::Points(points),
        comments,
        origin,
    })
}

/// The refusal of a mesh: its faces would be lost.
pub(crate) fn cannot_store_mesh(columns: XyzColumns) -> Error {
    Error::FormatCannotStore {
        format: FileFormat::Xyz(columns),
        what: format!(
            "a mesh's faces (.{} holds points only; write .ply, .obj or .off)",
            columns.extension()
        ),
    }
}

/// Refuses what an XYZ file with `columns` cannot hold: a mesh (its faces would be lost),
/// and for `.xyzn` and `.xyzrgb` points without normals or colours.
pub(crate) fn check_storable(columns: XyzColumns, geometry: &Geometry) -> Result<()> {
    let cannot = |what: &str| {
        Err(Error::FormatCannotStore {
            format: FileFormat::Xyz(columns),
            what: what.into(),
        })
    };
    let points = geometry.points();
    match (geometry.mesh(), columns) {
        (Some(_), _) => Err(cannot_store_mesh(columns)),
        (None, XyzColumns::Normals) if points.normals().is_none() => {
            cannot("points without normals as .xyzn (write .xyz)")
        }
        (None, XyzColumns::Colours) if points.colors().is_none() => {
            cannot("points without colours as .xyzrgb (write .xyz)")
        }
        _ => Ok(()),
    }
}

/// Writes `points` as XYZ text with `columns` (`.xyz` adds normals when the points have
/// them), `#` comment lines first, colours as floats in `0..=1`.
///
/// ```
/// use pointset_core::io::{write_xyz, XyzColumns};
/// use pointset_core::{PointSet, glam::Vec3};
/// let points = PointSet::new(vec![Vec3::new(0.5, 1.0, -2.0)])?.with_normals(vec![Vec3::Z])?;
/// let mut text = Vec::new();
/// write_xyz(&points, XyzColumns::Positions, &["scan".into()], &mut text)?;
/// assert_eq!(String::from_utf8_lossy(&text), "# scan\n0.5 1 -2 0 0 1\n");
/// # Ok::<(), pointset_core::Error>(())
/// ```
pub fn write_xyz(
    points: &PointSet,
    columns: XyzColumns,
    comments: &[String],
    out: &mut impl Write,
) -> Result<()> {
    write_xyz_at(
        &Geometry::Points(points.clone()),
        columns,
        comments,
        DVec3::ZERO,
        out,
    )
}

/// [`write_xyz`] of `geometry` (refused when a mesh) with `origin` added to every
/// position, in double precision.
pub(crate) fn write_xyz_at(
    geometry: &Geometry,
    columns: XyzColumns,
    comments: &[String],
    origin: DVec3,
    out: &mut impl Write,
) -> Result<()> {
    check_storable(columns, geometry)?;
    let points = geometry.points();
    let normals = match columns {
        XyzColumns::Colours => None,
        XyzColumns::Positions | XyzColumns::Normals => points.normals(),
    };
    let colours = match columns {
        XyzColumns::Colours => points.colors(),
        XyzColumns::Positions | XyzColumns::Normals => None,
    };
    buffered(out, |out| {
        comment_lines(out, comments)?;
        for (i, p) in points.positions().iter().enumerate() {
            write!(out, "{}", position_text(*p, origin))?;
            if let Some(n) = normals {
                write!(out, " {} {} {}", n[i].x, n[i].y, n[i].z)?;
            }
            if let Some(c) = &colours {
                write!(out, " {} {} {}", c[i][0], c[i][1], c[i][2])?;
            }
            writeln!(out)?;
        }
        Ok(())
    })
}
