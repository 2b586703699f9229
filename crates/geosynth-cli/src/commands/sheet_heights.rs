//! `geosynth quilt --heightfield-out`: a quilted height field written back as one, on the
//! input's grid spacing and in its units.

use std::path::Path;
use std::time::Instant;

use geosynth::imagery::write_heightfield;
use geosynth::quilt::{HeightFieldFrame, QuiltOutput, sample_heights};
use serde_json::{Value, json};

use crate::output::{spinner, status};
use crate::{CliResult, Globals};

/// Samples the top of `output`'s sheet on the grid of `frame` over the output box
/// ([`sample_heights`]), writes it to `path` ([`write_heightfield`]) and returns the
/// report's `heightfield_out` entry.
pub fn write_sheet_heights(
    path: &Path,
    output: &QuiltOutput,
    frame: HeightFieldFrame,
    globals: Globals,
) -> CliResult<Value> {
    let start = Instant::now();
    let bar = spinner(globals, "sampling heights");
    let sampled = sample_heights(&output.points, &output.bounds, frame)?;
    bar.finish_and_clear();
    let written = write_heightfield(path, &sampled.field)?;
    let seconds = start.elapsed().as_secs_f64();
    let (width, height) = (sampled.field.width(), sampled.field.height());
    let mut notes = Vec::new();
    if sampled.filled > 0 {
        notes.push(format!(
            "{} over holes filled from the heights around them",
            sampled.filled
        ));
    }
    if written.clamped > 0 {
        notes.push(format!(
            "{} outside 0..1 clamped (.f32le keeps them)",
            written.clamped
        ));
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
    Ok(json!({
        "path": written.path.display().to_string(),
        "width": width,
        "height": height,
        "by_ray": sampled.by_ray,
        "by_projection": sampled.by_projection,
        "filled": sampled.filled,
        "clamped": written.clamped,
        "seconds": seconds,
    }))
}
