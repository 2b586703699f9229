//! `geosynth quilt --heightfield-out`: a quilted sheet written as a height map. A quilted
//! height field goes back on the input's grid spacing and in its height units; a quilted
//! point set on a grid of its own spacing (or `--map-spacing`), with heights in the file's
//! length units and the map's place in the file's coordinates in the report. A GeoTIFF
//! map holds its place itself ([`geosynth::imagery::write_geotiff`]); files for GIS tools
//! go beside the others ([`geosynth::imagery::write_map_sidecars`]).

use std::path::Path;
use std::time::Instant;

use geosynth::imagery::{
    GeoReference, MapDescription, is_heightfield_path, is_raw_heightfield_path, is_tiff_path,
    stretch_to_unit, write_geotiff, write_heightfield, write_map_sidecars,
};
use geosynth::quilt::{HeightFieldFrame, MapGrid, QuiltOutput, TextureFile, sample_heights};
use glam::{DMat3, DVec3};
use serde_json::{Value, json};

use crate::output::{spinner, status};
use crate::{CliResult, Globals};

/// The share of filled samples above which a map gets a note that it shows little of
/// the surface: the bundled chain mail and weave fill 27% and 37% of theirs (gaps between
/// rings and threads), bumpy and the flowers 11%, Spot's texture 0.4%.
const MANY_FILLED: f64 = 0.2;

/// Where a quilt's height map lies: the grid and height axis of the texture's frame, and
/// for a point-set exemplar where that frame lies in the file.
#[derive(Debug, Clone)]
pub struct MapPlacement {
    /// The map's grid and height axis in the texture's frame.
    pub frame: HeightFieldFrame,
    /// For a point-set exemplar, the texture's origin and axes in the file
    /// ([`TextureFile::origin`], [`TextureFile::frame`]): its heights are then offset to
    /// the file's coordinates and a PNG spans the map's own range. `None` for a height
    /// field, whose map keeps the input's units.
    pub file: Option<(DVec3, DMat3)>,
    /// For a point-set exemplar's PNG, the heights of grey 0 and 65535 (`None`: the
    /// map's own range).
    pub grey_range: Option<(f32, f32)>,
    /// For a height field read from a GeoTIFF, its reference: a `.tif` map, on the
    /// input's grid spacing, gets it, so that its top-left sample lies where the input's
    /// does, in the input's coordinate system.
    pub input_reference: Option<GeoReference>,
}

impl MapPlacement {
    /// The placement of a height map of a quilt of the point-set exemplar `file`, on a
    /// grid `spacing` apart (without one, a grid with as many samples as the exemplar
    /// has points: [`HeightFieldFrame::of_points`]), a PNG's grey levels spanning
    /// `grey_range` (or the map's own range).
    pub fn of_points(
        file: &TextureFile,
        spacing: Option<f32>,
        grey_range: Option<(f32, f32)>,
    ) -> CliResult<Self> {
        Ok(Self {
            frame: HeightFieldFrame::of_points(&file.texture, spacing)?,
            file: Some((file.origin, file.frame)),
            grey_range,
            input_reference: None,
        })
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
        .map(|(origin, axes)| MapGrid::new(&output.bounds, frame, origin, axes));
    let field = match grid {
        Some(grid) => grid.file_heights(sampled.field)?,
        None => sampled.field,
    };
    // A raw or TIFF map keeps every height; a point set's PNG spans a range of them.
    let png_range = (grid.is_some() && !is_heightfield_path(path))
        .then(|| placement.grey_range.unwrap_or_else(|| field.range()));
    let (width, height) = (field.width(), field.height());
    let description = MapDescription {
        width,
        height,
        placement: grid.and_then(|g| g.plan_placement(height)),
        grey_range: png_range,
    };
    // A GeoTIFF holds its placement; the other maps get files beside them.
    let tiff = is_tiff_path(path);
    let reference = placement
        .input_reference
        .or_else(|| description.placement.map(GeoReference::from))
        .filter(|_| tiff);
    let (written, sidecars) = if tiff {
        (write_geotiff(path, &field, reference.as_ref())?, Vec::new())
    } else {
        let written = match png_range {
            Some(range) => write_heightfield(path, &stretch_to_unit(&field, range)?)?,
            None => write_heightfield(path, &field)?,
        };
        let raw = is_raw_heightfield_path(path);
        let sidecars = write_map_sidecars(&written.path, raw, &description)?;
        (written, sidecars)
    };
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
        let (lo, hi) = png_range.unwrap_or((0.0, 1.0));
        notes.push(format!(
            "{} outside {lo}..{hi} clamped (.f32le and .tif keep them)",
            written.clamped
        ));
    }
    if let Some((lo, hi)) = png_range {
        notes.push(format!("grey 0..65535 is height {lo}..{hi}"));
    }
    if reference.is_some() {
        notes.push(
            if description.placement.is_some() {
                "placed in the file's x–y plane (GeoTIFF)"
            } else {
                "placed at the input DEM's top-left corner, in its coordinate system (GeoTIFF)"
            }
            .to_string(),
        );
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
        "spacing": grid.map(|g| g.spacing),
        "lower_corner": grid.map(|g| vector(g.lower_corner)),
        "columns_axis": grid.map(|g| vector(g.columns_axis)),
        "rows_axis": grid.map(|g| vector(g.rows_axis)),
        "up_axis": grid.map(|g| vector(g.up_axis)),
        "png_range": png_range.map(|(lo, hi)| [lo, hi]),
        "georeferenced": description.placement.is_some() || reference.is_some(),
        "sidecars": sidecars.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
    }))
}
