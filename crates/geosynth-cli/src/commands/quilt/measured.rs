//! One quilt run with its progress bar, timings and quality, and its report entry: shared
//! by `geosynth quilt` and the demo.

use std::time::Instant;

use geosynth::quilt::{
    BlendCounts, GeometryTexture, QualityMeasure, QualityReport, QuiltOutput, QuiltParams, quilt,
};
use serde_json::{Value, json};

use crate::output::{progress_context, spinner};
use crate::{CliResult, Globals};

/// One measured run: the output, its timings and its quality.
pub struct MeasuredRun {
    /// The synthesis result.
    pub output: QuiltOutput,
    /// `(stage, seconds)` in first-use order.
    pub timings: Vec<(String, f64)>,
    /// Wall time of the synthesis.
    pub seconds: f64,
    /// Quality against the exemplar, or why it could not be measured (an output smaller
    /// than one quality window); the output is kept either way.
    pub quality: Result<QualityReport, String>,
}

/// The quality measure of one exemplar, shared by every run measured against it, or why it
/// could not be built (the runs then go on unmeasured).
pub type Measure<'t> = Result<QualityMeasure<'t>, String>;

/// The [`Measure`] of `texture` for runs with `params`' seed and geometry, behind a spinner
/// (building the exemplar's windows takes seconds on large exemplars).
pub fn measure_for<'t>(
    texture: &'t GeometryTexture,
    params: &QuiltParams,
    globals: Globals,
) -> Measure<'t> {
    let bar = spinner(globals, "preparing the quality measure");
    let measure = QualityMeasure::new(texture, params).map_err(|e| e.to_string());
    bar.finish_and_clear();
    measure
}

/// Runs `quilt` with a progress bar, then measures it with `measure`.
pub fn measured_run(
    texture: &GeometryTexture,
    params: &QuiltParams,
    measure: &Measure<'_>,
    globals: Globals,
    label: &str,
) -> CliResult<MeasuredRun> {
    Ok(unmeasured_run(texture, params, globals, label)?.measured(measure, globals, label))
}

/// Runs `quilt` with a progress bar; its quality is left to [`MeasuredRun::measured`].
pub fn unmeasured_run(
    texture: &GeometryTexture,
    params: &QuiltParams,
    globals: Globals,
    label: &str,
) -> CliResult<MeasuredRun> {
    let (mut ctx, bar) = progress_context(globals, params.seed, label, false);
    let start = Instant::now();
    let output = quilt(texture, params, &mut ctx)?;
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let timings = ctx
        .timings()
        .iter()
        .map(|(n, d)| (n.clone(), d.as_secs_f64()))
        .collect();
    Ok(MeasuredRun {
        output,
        timings,
        seconds,
        quality: Err("not measured".into()),
    })
}

impl MeasuredRun {
    /// The run with its quality measured by `measure` (or the reason it has none).
    pub(super) fn measured(mut self, measure: &Measure<'_>, globals: Globals, label: &str) -> Self {
        self.quality = match measure {
            Ok(m) => {
                let bar = spinner(globals, format!("{label}: measuring quality"));
                let quality = m.evaluate(&self.output, 48).map_err(|e| e.to_string());
                bar.finish_and_clear();
                quality
            }
            Err(reason) => Err(reason.clone()),
        };
        self
    }
}

fn mean(values: impl Iterator<Item = f32>) -> f32 {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 { 0.0 } else { sum / n as f32 }
}

/// What the blends of a run did, totalled over its placements (step 5).
fn blend_json(b: BlendCounts) -> Value {
    json!({
        "blended_points": b.blended,
        "by_ray": b.by_ray,
        "by_projection": b.by_projection,
        "unmatched": b.unmatched,
        "beyond_reach": b.beyond_reach,
        "facing_away": b.facing_away,
    })
}

/// A run as JSON.
pub fn run_json(run: &MeasuredRun) -> Value {
    let s = &run.output.stats;
    let quality = match &run.quality {
        Ok(q) => json!({
            "neighbourhood_error": q.neighbourhood_error,
            "seam_error": q.seam_error,
            "interior_error": q.interior_error,
            "seam_concentration": q.seam_concentration,
            "verbatim_fraction": q.verbatim_fraction,
            "continued_seams": q.continued_seams,
            "largest_empty_disc": q.largest_empty_disc,
            "exemplar_largest_empty_disc": q.exemplar_largest_empty_disc,
            "exemplar_window_variation": q.exemplar_window_variation,
            "featureless_exemplar": q.featureless_exemplar,
            "windows_per_class": q.windows,
            "seam_windows": q.seam_windows,
            "interior_windows": q.interior_windows,
        }),
        Err(reason) => json!({ "not_measured": reason }),
    };
    json!({
        "seconds": run.seconds,
        "timings": run.timings.iter().map(|(n, t)| json!({"stage": n, "seconds": t})).collect::<Vec<_>>(),
        "patches": s.patches,
        "mean_candidates": s.mean_candidates,
        "mean_pairs": s.mean_pairs,
        "warps_skipped": s.warps_skipped,
        "warps_coarsened": s.warps_coarsened,
        "warps_restrained": s.warps_restrained,
        "dropped_pairs": run.output.placements.iter().map(|p| p.warp.dropped_pairs).sum::<usize>(),
        "warp_displacement": {
            "mean": mean(run.output.placements.iter().filter(|p| !p.warp.skipped).map(|p| p.warp.mean_displacement)),
            "max": run.output.placements.iter().map(|p| p.warp.max_displacement).fold(0.0f32, f32::max),
            "max_landing": run.output.placements.iter().map(|p| p.warp.max_landing_displacement).fold(0.0f32, f32::max),
            "mean_pair_length": mean(run.output.placements.iter().filter(|p| !p.warp.skipped).map(|p| p.warp.mean_pair_length)),
        },
        "blend": blend_json(run.output.placements.iter().map(|p| p.blend).sum()),
        "input_points": s.input_points,
        "output_points": s.output_points,
        "field_dims": s.field_dims,
        "field_bytes": s.field_bytes,
        "relaxation_spread": s.relaxation_spread,
        "quality": quality,
    })
}
