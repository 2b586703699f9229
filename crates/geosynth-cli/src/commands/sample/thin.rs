//! `geosynth sample` given a point set: fewer of its own points, as a Poisson disk or at
//! random.

use std::time::Duration;

use geosynth::Stage;
use geosynth::core::PointSet;
use geosynth::core::io::{Geometry, WriteOptions};
use geosynth::core::surface_sampling::PointThinning;
use geosynth::sample::ThinPoints;
use glam::DVec3;
use serde_json::json;

use super::{DEFAULT_COUNT, SampleArgs};
use crate::json_report::{timings_json, write_json_report};
use crate::output::{progress_context, status, write_geometry_file};
use crate::phases::{READING, WRITING};
use crate::{CliResult, Globals};

/// Thins `points` (read in `read_time`, their file's coordinates less `origin`) as `args`
/// say, writes them and the report.
pub(super) fn run(
    args: &SampleArgs,
    points: PointSet,
    origin: DVec3,
    read_time: Duration,
    globals: Globals,
) -> CliResult {
    let input = args.input.display();
    let for_meshes = [
        (args.texture.is_some(), "--texture"),
        (args.normals.is_some(), "--normals"),
    ];
    if let Some((_, flag)) = for_meshes.iter().find(|(given, _)| *given) {
        return Err(format!(
            "{input} is a point set: {flag} is for sampling a mesh (its points are thinned, \
             each kept as it is)"
        )
        .into());
    }
    let asked = args.count.unwrap_or(DEFAULT_COUNT);
    let thinning = match args.spacing {
        Some(spacing) => PointThinning::PoissonDisk { spacing },
        None if args.uniform => PointThinning::Random { count: asked },
        None => PointThinning::PoissonDiskCount { count: asked },
    };
    let before = points.len();
    let (mut ctx, bar) = progress_context(globals, args.seed, "thinning", false);
    ctx.record_timing(READING, read_time);
    let thinned = ctx
        .timed("thinning", |ctx| ThinPoints { thinning }.run(points, ctx))
        .map_err(|e| format!("{input}: {e}"))?;
    bar.finish_and_clear();
    let (count, spacing, passes) = (thinned.points.len(), thinned.spacing, thinned.passes);
    let how = match spacing {
        Some(spacing) => format!("as a Poisson disk of spacing {spacing}"),
        None if count == before => "all kept".into(),
        None => "at random".into(),
    };
    let comment = format!(
        "{count} of the {before} points of {input} kept by geosynth {how} (seed {})",
        args.seed
    );
    let options = WriteOptions::default().comment(comment).origin(origin);
    ctx.timed(WRITING, |_| {
        write_geometry_file(
            &args.output,
            &Geometry::Points(thinned.points),
            &options,
            globals,
        )
    })?;
    if let Some(path) = &args.report {
        let report = json!({
            "input": input.to_string(),
            "output": args.output.display().to_string(),
            "points_before": before,
            "thinning": thinning,
            "spacing": spacing,
            "passes": passes,
            "seed": args.seed,
            "points": count,
            "timings": timings_json(ctx.timings()),
        });
        write_json_report(path, "sample", &report)?;
    }
    let spread = match (spacing, count) {
        (Some(spacing), 1) => format!("alone at a spacing of {spacing}"),
        (Some(spacing), _) if args.spacing.is_none() => {
            let passes = match passes {
                1 => "1 pass".to_string(),
                n => format!("{n} passes"),
            };
            format!("none closer than {spacing}, a spacing found in {passes}")
        }
        (Some(spacing), _) => format!("none closer than {spacing}"),
        (None, _) if count == before => format!("all of them: {asked} asked for"),
        (None, _) => "drawn at random".into(),
    };
    status(
        globals,
        format!(
            "wrote {} ({count} of {before} points, {spread})",
            args.output.display()
        ),
    );
    Ok(())
}
