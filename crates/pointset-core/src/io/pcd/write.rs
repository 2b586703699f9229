//! PCD encoding (see the module docs of [`super`]).

use std::io::Write;

use glam::DVec3;

use super::header::FieldType;
use super::{NORMAL_NAMES, PcdEncoding, cannot_store_mesh, lzf};
use crate::io::buffered::buffered;
use crate::io::{FileFormat, Geometry};
use crate::{Attribute, COLOR_CHANNELS, Error, PointSet, Result, ScalarType};

/// Where a written field's values come from.
#[derive(Debug, Clone, Copy)]
enum Source<'a> {
    /// A coordinate of the position (0 to 2).
    Position(usize),
    /// A coordinate of the normal (0 to 2).
    Normal(usize),
    /// The colours, packed with the `alpha` attribute's values or 255.
    Colour(Option<&'a Attribute>),
    /// An attribute.
    Attribute(&'a Attribute),
}

/// A field to write.
struct OutField<'a> {
    name: &'a str,
    /// How its values are stored (PCD's `TYPE` and `SIZE`: [`FieldType::of`]).
    ty: ScalarType,
    source: Source<'a>,
}

/// The names the reader gives a meaning of their own: an attribute of such a name would
/// not come back as itself.
fn taken_name(name: &str) -> bool {
    name == "_"
        || name == "rgb"
        || name == "rgba"
        || NORMAL_NAMES.iter().flatten().any(|&n| n == name)
}

/// The fields `points` are written as (see the module docs).
fn fields<'a>(points: &'a PointSet, origin: DVec3) -> Result<Vec<OutField<'a>>> {
    let position_type = if origin == DVec3::ZERO {
        ScalarType::F32
    } else {
        ScalarType::F64
    };
    let mut fields: Vec<OutField<'a>> = ["x", "y", "z"]
        .iter()
        .enumerate()
        .map(|(k, name)| OutField {
            name,
            ty: position_type,
            source: Source::Position(k),
        })
        .collect();
    if points.normals().is_some() {
        fields.extend(
            NORMAL_NAMES[0]
                .iter()
                .enumerate()
                .map(|(k, name)| OutField {
                    name,
                    ty: ScalarType::F32,
                    source: Source::Normal(k),
                }),
        );
    }
    // As `PointSet::colors` decides, without building the colours.
    let has_colours = COLOR_CHANNELS.iter().all(|c| points.attribute(c).is_some());
    let alpha = points.attribute("alpha").filter(|_| has_colours);
    if has_colours {
        fields.push(OutField {
            name: if alpha.is_some() { "rgba" } else { "rgb" },
            ty: ScalarType::U32,
            source: Source::Colour(alpha),
        });
    }
    for attribute in points.attributes() {
        let name = attribute.name();
        let in_colour = has_colours && (COLOR_CHANNELS.contains(&name) || name == "alpha");
        if in_colour {
            continue;
        }
        if taken_name(name) {
            return Err(Error::FormatCannotStore {
                format: FileFormat::Pcd,
                what: format!(
                    "the attribute `{name}`: PCD readers take a field of that name for \
                     normals, colours or padding (rename it)"
                ),
            });
        }
        fields.push(OutField {
            name,
            ty: attribute.storage(),
            source: Source::Attribute(attribute),
        });
    }
    Ok(fields)
}

/// A colour's channel, `0..=255`, from its `0..=1` value.
fn channel(c: f32) -> u32 {
    (c.clamp(0.0, 1.0) * 255.0).round() as u32
}

/// The value of `field` for point `i` (`colours` are the points' own), in double
/// precision: a position plus `origin`, a colour's packed bits.
fn value(
    field: &OutField<'_>,
    points: &PointSet,
    colours: Option<&[[f32; 3]]>,
    origin: DVec3,
    i: usize,
) -> f64 {
    match field.source {
        Source::Position(k) => f64::from(points.positions()[i][k]) + origin[k],
        Source::Normal(k) => points.normals().map_or(0.0, |n| f64::from(n[i][k])),
        Source::Colour(alpha) => {
            let [r, g, b] = colours.map_or([0.0; 3], |c| c[i]);
            let a = alpha.map_or(255, |a| a.values()[i].round().clamp(0.0, 255.0) as u32);
            f64::from(a << 24 | channel(r) << 16 | channel(g) << 8 | channel(b))
        }
        Source::Attribute(a) => f64::from(a.values()[i]),
    }
}

/// Writes the point set `geometry` as PCD 0.7 in `encoding` (see the module docs), with
/// `comments` as `#` lines after the format's banner; a mesh is refused (its faces would
/// be lost).
///
/// ```
/// use pointset_core::io::{Geometry, PcdEncoding, read_pcd, write_pcd};
/// use pointset_core::{PointSet, glam::Vec3};
/// let points = PointSet::new(vec![Vec3::new(0.5, 1.0, -2.0), Vec3::ZERO])?
///     .with_normals(vec![Vec3::Z, Vec3::X])?;
/// let geometry = Geometry::Points(points);
/// let mut pcd = Vec::new();
/// write_pcd(&geometry, PcdEncoding::Ascii, &[], &mut pcd)?;
/// let text = String::from_utf8_lossy(&pcd);
/// assert!(text.contains("FIELDS x y z normal_x normal_y normal_z\n"));
/// assert!(text.ends_with("DATA ascii\n0.5 1 -2 0 0 1\n0 0 0 1 0 0\n"));
/// assert_eq!(read_pcd(&pcd)?, geometry);
/// # Ok::<(), pointset_core::Error>(())
/// ```
pub fn write_pcd(
    geometry: &Geometry,
    encoding: PcdEncoding,
    comments: &[String],
    out: &mut impl Write,
) -> Result<()> {
    write_pcd_at(geometry, encoding, comments, DVec3::ZERO, out)
}

/// [`write_pcd`] with `origin` added to every position, in double precision (the
/// positions are then written as `F 8`).
pub(crate) fn write_pcd_at(
    geometry: &Geometry,
    encoding: PcdEncoding,
    comments: &[String],
    origin: DVec3,
    out: &mut impl Write,
) -> Result<()> {
    let Geometry::Points(points) = geometry else {
        return Err(cannot_store_mesh());
    };
    let count = u32::try_from(points.len()).map_err(|_| Error::FormatCannotStore {
        format: FileFormat::Pcd,
        what: format!(
            "{} points (PCD's WIDTH counts up to 2^32 − 1)",
            points.len()
        ),
    })?;
    let fields = fields(points, origin)?;
    let colours = points.colors();
    let colours = colours.as_deref();
    let value = |field: &OutField<'_>, i| value(field, points, colours, origin, i);
    let record_bytes: usize = fields.iter().map(|f| f.ty.size()).sum();
    let compressed = if encoding == PcdEncoding::BinaryCompressed {
        let total = record_bytes * points.len();
        let total = u32::try_from(total).map_err(|_| Error::FormatCannotStore {
            format: FileFormat::Pcd,
            what: format!(
                "{total} bytes of points compressed (binary_compressed counts up to 2^32 − 1; \
                 write binary)"
            ),
        })?;
        let mut columns = Vec::with_capacity(total as usize);
        for field in &fields {
            for i in 0..points.len() {
                field.ty.encode(value(field, i), false, &mut columns);
            }
        }
        let packed = lzf::compress(&columns);
        let packed_len = u32::try_from(packed.len()).map_err(|_| Error::FormatCannotStore {
            format: FileFormat::Pcd,
            what: format!(
                "{} compressed bytes (binary_compressed counts up to 2^32 − 1; write binary)",
                packed.len()
            ),
        })?;
        Some((packed, packed_len, total))
    } else {
        None
    };
    buffered(out, |out| {
        writeln!(out, "# .PCD v0.7 - Point Cloud Data file format")?;
        crate::io::buffered::comment_lines(out, comments)?;
        let list = |each: &dyn Fn(&OutField<'_>) -> String| {
            fields.iter().map(each).collect::<Vec<_>>().join(" ")
        };
        writeln!(out, "VERSION 0.7")?;
        writeln!(out, "FIELDS {}", list(&|f| f.name.to_string()))?;
        writeln!(out, "SIZE {}", list(&|f| f.ty.size().to_string()))?;
        writeln!(
            out,
            "TYPE {}",
            list(&|f| FieldType::of(f.ty).letter().to_string())
        )?;
        writeln!(out, "COUNT {}", list(&|_| "1".to_string()))?;
        writeln!(out, "WIDTH {count}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0")?;
        writeln!(out, "POINTS {count}\nDATA {}", encoding.keyword())?;
        if let Some((data, packed_len, total)) = &compressed {
            out.write_all(&packed_len.to_le_bytes())?;
            out.write_all(&total.to_le_bytes())?;
            return out.write_all(data);
        }
        let mut line = Vec::with_capacity(record_bytes.max(64));
        for i in 0..points.len() {
            line.clear();
            for (k, field) in fields.iter().enumerate() {
                if encoding == PcdEncoding::Ascii {
                    if k > 0 {
                        line.push(b' ');
                    }
                    field.ty.encode_text(value(field, i), &mut line);
                } else {
                    field.ty.encode(value(field, i), false, &mut line);
                }
            }
            if encoding == PcdEncoding::Ascii {
                line.push(b'\n');
            }
            out.write_all(&line)?;
        }
        Ok(())
    })
}
