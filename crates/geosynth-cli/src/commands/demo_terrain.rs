//! `geosynth demo`'s terrain: Mount St. Helens from the shared data quilted and written back
//! as a height map (`geosynth quilt --heightfield-out`), with a preview of both maps.

use std::path::Path;

use geosynth::core::HeightField;
use geosynth::core::io::Geometry;
use geosynth::imagery::{read_heightfield, write_heightfield};
use geosynth::preview::{self, Panel, RenderOptions, UpAxis};
use geosynth::quilt::{
    DEFAULT_RELIEF, OutputSize, QuiltParams, read_heightfield_texture_framed, sample_heights,
};
use geosynth::tps::{PairingParams, Table1Preset};
use serde::Serialize;

use super::quilt::unmeasured_run;
use crate::{CliResult, Globals};

/// The shared data's height field the demo quilts, relative to the data folder.
pub const TERRAIN: &str = "heightfields/SainteHelens_317x460_u16.png";

/// A height field quilted and written back as one.
#[derive(Debug, Serialize)]
pub struct TerrainEntry {
    /// The input height field's file name.
    pub exemplar: String,
    /// The output box as a multiple of the exemplar's.
    pub scale: f32,
    /// The height map written (16-bit PNG, the input's grey levels).
    pub height_map: String,
    /// Input and output maps drawn as terrain at one scale.
    pub preview: String,
    /// Columns of the map (samples along x).
    pub width: usize,
    /// Rows of the map.
    pub height: usize,
    /// Samples over holes in the output, filled from around them.
    pub filled: usize,
    /// Heights outside the PNG's 0..1, clamped.
    pub clamped: usize,
    /// Seconds to quilt.
    pub seconds_quilt: f64,
    /// Seconds to sample the map.
    pub seconds_heights: f64,
}

/// Quilts the height field at `path` (the demo's scale, the Table 1 height-field weights,
/// `seed`) and writes its height map to `geometry/NAME_heights.png` and a preview of the
/// input and output maps to `previews/NAME_heights.png` under `out`.
pub fn quilt_terrain(
    path: &Path,
    out: &Path,
    quick: bool,
    seed: u64,
    globals: Globals,
) -> CliResult<TerrainEntry> {
    let scale = if quick { 1.25 } else { 2.0 };
    let (texture, frame) = read_heightfield_texture_framed(path, DEFAULT_RELIEF)?;
    let params = QuiltParams::default()
        .output(OutputSize::Scale(scale))
        .pairing(PairingParams::table1(Table1Preset::HeightField))
        .seed(seed);
    let run = unmeasured_run(&texture, &params, globals, "terrain")?;
    let start = std::time::Instant::now();
    let sampled = sample_heights(&run.output.points, &run.output.bounds, frame)?;
    let seconds_heights = start.elapsed().as_secs_f64();
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("terrain");
    let map_path = out.join("geometry").join(format!("{stem}_heights.png"));
    let written = write_heightfield(&map_path, &sampled.field)?;
    let preview_path = out.join("previews").join(format!("{stem}_heights.png"));
    let input = read_heightfield(path)?;
    let (w, h) = if quick { (320, 240) } else { (560, 420) };
    terrain_preview(&input, &sampled.field, &preview_path, w, h)?;
    Ok(TerrainEntry {
        exemplar: path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
        scale,
        height_map: super::demo::relative(&written.path, out),
        preview: super::demo::relative(&preview_path, out),
        width: sampled.field.width(),
        height: sampled.field.height(),
        filled: sampled.filled,
        clamped: written.clamped,
        seconds_quilt: run.seconds,
        seconds_heights,
    })
}

/// Draws `input` | `output` as shaded terrain with one spacing and one height scale (the
/// input's longer side 1 unit, its height range [`DEFAULT_RELIEF`] of that), so that both
/// show the input's relief.
fn terrain_preview(
    input: &HeightField,
    output: &HeightField,
    path: &Path,
    width: u32,
    height: u32,
) -> CliResult {
    let spacing = 1.0 / (input.width().max(input.height()) - 1) as f32;
    let scale = geosynth::imagery::relief_scale(input, DEFAULT_RELIEF)?;
    let meshes = [
        Geometry::Mesh(input.to_mesh(spacing, scale)?),
        Geometry::Mesh(output.to_mesh(spacing, scale)?),
    ];
    let panels: Vec<Panel<'_>> = meshes
        .iter()
        .map(|m| Panel::Geometry(m, UpAxis::Z))
        .collect();
    let image = preview::render_panels(&panels, &RenderOptions::default().size(width, height))?;
    preview::save_png(&image, path)?;
    Ok(())
}
