//! `geosynth quilt --heightfield-out`: a quilted sheet written as a height map. A quilted
//! height field goes back on the input's grid spacing and in its height units; a quilted
//! point set on a grid of its own spacing (or `--map-spacing`), with heights in the file's
//! length units and the map's place in the file's coordinates in the report. Files for
//! GIS tools go beside the map ([`super::map_sidecars`]).

use std::path::Path;
use std::time::Instant;

use geosynth::core::HeightField;
use geosynth::imagery::{is_raw_heightfield_path, write_heightfield};
use geosynth::quilt::{HeightFieldFrame, QuiltOutput, TextureFile, sample_heights};
use glam::{DMat3, DVec3, Vec3};
use serde_json::{Value, json};

use super::map_sidecars::{MapDescription, PlanPlacement, write_map_sidecars};
use crate::output::{spinner, status};
use crate::{CliResult, Globals};

/// The share of filled samples above which a map gets a note that it shows little of
/// the surface: the bundled chain mail and weave fill 39% and 37% of theirs (gaps between
/// rings and threads), bumpy and the flowers 11%, Spot's texture 0.4%.
const MANY_FILLED: f64 = 0.2;

/// Where a quilt's height map lies: the grid and height axis of the texture's frame, and
/// for a point-set exemplar where that frame lies in the file.
#[derive(Debug, Clone, Copy)]
pub struct MapPlacement {
    /// The map's grid and height axis in the texture's frame.
    pub frame: HeightFieldFrame,
    /// For a point-set exemplar, the texture's origin and axes in the file
    /// ([`TextureFile::origin`], [`TextureFile::frame`]): its heights are then offset to
    /// the file's coordinates and a PNG spans the map's own range. `None` for a height
    /// field, whose map keeps the input's units.
    pub file: Option<(DVec3, DMat3)>,
}

impl MapPlacement {
    /// The placement of a height map of a quilt of the point-set exemplar `file`, on a
    /// grid `spacing` apart (without one, a grid with as many samples as the exemplar
    /// has points: [`HeightFieldFrame::of_points`]).
    pub fn of_points(file: &TextureFile, spacing: Option<f32>) -> CliResult<Self> {
        Ok(Self {
            frame: HeightFieldFrame::of_points(&file.texture, spacing)?,
            file: Some((file.origin, file.frame)),
        })
    }
}

/// Where a point-set quilt's map lies in the file: sample `(c, r)` with height `h` is at
/// `lower_corner + spacing·(c·columns_axis + (rows − 1 − r)·rows_axis) + h·up_axis`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FileGrid {
    /// File coordinates of the bottom row's first sample at height 0.
    lower_corner: DVec3,
    /// Along the columns (file directions, unit length).
    columns_axis: DVec3,
    /// Along the rows, bottom to top.
    rows_axis: DVec3,
    /// The direction heights grow in.
    up_axis: DVec3,
    /// Added to every height: the origin's coordinate along `up_axis`.
    offset: f64,
}

impl FileGrid {
    /// The grid of a map over `output`'s box in the texture frame `frame`, whose origin
    /// and axes in the file are `origin` and `axes`.
    fn new(output: &QuiltOutput, frame: HeightFieldFrame, origin: DVec3, axes: DMat3) -> Self {
        let texture_up = frame.up;
        let lo = texture_up.canonical_box(&output.bounds).min;
        let in_file = |v: Vec3| axes * texture_up.to_world(v).as_dvec3();
        let up_axis = in_file(Vec3::Z);
        let offset = origin.dot(up_axis);
        Self {
            lower_corner: origin - offset * up_axis + in_file(Vec3::new(lo.x, lo.y, 0.0)),
            columns_axis: in_file(Vec3::X),
            rows_axis: in_file(Vec3::Y),
            up_axis,
            offset,
        }
    }
}

/// Samples the top of `output`'s sheet on the grid of `placement` over the output box
/// ([`sample_heights`]), writes it to `path` ([`write_heightfield`]) and returns the
/// report's `heightfield_out` entry.
pub fn write_sheet_heights(
    path: &Path,
    output: &QuiltOutput,
    placement: MapPlacement,
    globals: Globals,
) -> CliResult<Value> {
    let start = Instant::now();
    let bar = spinner(globals, "sampling heights");
    let frame = placement.frame;
    let sampled = sample_heights(&output.points, &output.bounds, frame)?;
    bar.finish_and_clear();
    let grid = placement
        .file
        .map(|(origin, axes)| FileGrid::new(output, frame, origin, axes));
    let field = match grid {
        Some(grid) => offset_heights(sampled.field, grid.offset)?,
        None => sampled.field,
    };
    let raw = is_raw_heightfield_path(path);
    let png_range = (grid.is_some() && !raw).then(|| field.range());
    let written = match png_range {
        Some(range) => write_heightfield(path, &stretched(&field, range)?)?,
        None => write_heightfield(path, &field)?,
    };
    let (width, height) = (field.width(), field.height());
    let description = MapDescription {
        width,
        height,
        placement: grid.and_then(|g| {
            let axes = [g.columns_axis, g.rows_axis, g.up_axis];
            PlanPlacement::of_grid(g.lower_corner, axes, f64::from(frame.spacing), height)
        }),
        grey_range: png_range,
    };
    let sidecars = write_map_sidecars(&written.path, raw, &description)?;
    let seconds = start.elapsed().as_secs_f64();
    let mut notes = Vec::new();
    let filled_share = sampled.filled as f64 / (width * height) as f64;
    if sampled.filled > 0 {
        notes.push(format!(
            "{} ({:.1}%) over holes filled from the heights around them",
            sampled.filled,
            100.0 * filled_share
        ));
    }
    if written.clamped > 0 {
        notes.push(format!(
            "{} outside 0..1 clamped (.f32le keeps them)",
            written.clamped
        ));
    }
    if let Some((lo, hi)) = png_range {
        notes.push(format!("grey 0..65535 is height {lo}..{hi}"));
    }
    if !sidecars.is_empty() {
        let names: Vec<_> = sidecars
            .iter()
            .filter_map(|p| p.file_name())
            .map(|n| n.to_string_lossy())
            .collect();
        notes.push(format!("GIS sidecars {}", names.join(", ")));
    }
    let notes = if notes.is_empty() {
        String::new()
    } else {
        format!("; {}", notes.join(", "))
    };
    status(
        globals,
        format!(
            "wrote {} ({width} × {height} heights, {seconds:.2}s{notes})",
            written.path.display()
        ),
    );
    if filled_share > MANY_FILLED {
        status(
            globals,
            format!(
                "note: {:.0}% of the map lies over gaps in the output's top surface (such as \
                 between rings or threads) and holds heights filled in from around them; a \
                 height map keeps one height a sample, and --mesh writes the whole surface",
                100.0 * filled_share
            ),
        );
    }
    let vector = |v: DVec3| [v.x, v.y, v.z];
    Ok(json!({
        "path": written.path.display().to_string(),
        "width": width,
        "height": height,
        "by_ray": sampled.by_ray,
        "by_projection": sampled.by_projection,
        "filled": sampled.filled,
        "clamped": written.clamped,
        "seconds": seconds,
        "spacing": grid.map(|_| frame.spacing),
        "lower_corner": grid.map(|g| vector(g.lower_corner)),
        "columns_axis": grid.map(|g| vector(g.columns_axis)),
        "rows_axis": grid.map(|g| vector(g.rows_axis)),
        "up_axis": grid.map(|g| vector(g.up_axis)),
        "png_range": png_range.map(|(lo, hi)| [lo, hi]),
        "georeferenced": description.placement.is_some(),
        "sidecars": sidecars.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
    }))
}

/// `field` with `offset` added to every height (in double precision, so a georeferenced
/// height keeps what `f32` can hold of it).
fn offset_heights(field: HeightField, offset: f64) -> CliResult<HeightField> {
    if offset == 0.0 {
        return Ok(field);
    }
    mapped_heights(&field, |h| h + offset)
}

/// `field` mapped linearly from `lo..hi` onto `0..1` (a flat field onto 0), the way a
/// PNG's grey levels hold it.
fn stretched(field: &HeightField, (lo, hi): (f32, f32)) -> CliResult<HeightField> {
    let (lo, span) = (f64::from(lo), f64::from(hi) - f64::from(lo));
    mapped_heights(field, |h| if span > 0.0 { (h - lo) / span } else { 0.0 })
}

/// `field` with every height `h` replaced by `map(h)`, computed in double precision.
fn mapped_heights(field: &HeightField, map: impl Fn(f64) -> f64) -> CliResult<HeightField> {
    let heights = field
        .heights()
        .iter()
        .map(|&h| map(f64::from(h)) as f32)
        .collect();
    Ok(HeightField::new(field.width(), field.height(), heights)?)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn a_stretched_map_spans_zero_to_one_and_a_flat_one_is_zero() {
        let field = HeightField::new(2, 2, vec![1000.5, 1002.5, 1001.0, 1000.5]).unwrap();
        let unit = stretched(&field, field.range()).unwrap();
        assert_eq!(unit.heights(), &[0.0, 1.0, 0.25, 0.0]);
        let flat = HeightField::new(2, 2, vec![7.0; 4]).unwrap();
        assert_eq!(stretched(&flat, flat.range()).unwrap().heights(), &[0.0; 4]);
    }

    #[test]
    fn offsets_are_added_in_double_precision() {
        let field = HeightField::new(2, 2, vec![0.25, -1.5, 0.0, 1.0]).unwrap();
        let moved = offset_heights(field.clone(), 4096.0).unwrap();
        assert_eq!(moved.heights(), &[4096.25, 4094.5, 4096.0, 4097.0]);
        // 2²⁴ + 1 has no single-precision value: rounded first, then added, 1 more would
        // give 2²⁴ (a tie, to even); added first, 2²⁴ + 2.
        let far = offset_heights(field.clone(), 16_777_217.0).unwrap();
        assert_eq!(far.heights()[3], 16_777_218.0);
        assert_eq!(offset_heights(field.clone(), 0.0).unwrap(), field);
    }
}
