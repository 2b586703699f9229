//! `geosynth normals`: estimate and orient the normals of a point set.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, ValueEnum};
use geosynth::core::KdIndex;
use geosynth::core::PointSet;
use geosynth::core::io::{FileFormat, Geometry, WriteOptions};
use geosynth::mls::{
    NORMAL_NEIGHBOURS, fit_oriented_normals_with, orient_normals_with,
    orientation_disagreement_with,
};
use glam::{DVec3, Vec3};
use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::input_file::read_geometry;
use crate::json_report::{timings_json, write_json_report};
use crate::output::{
    check_geometry_output, check_output_paths, progress_context, report_not_kept, status,
    write_geometry_file,
};
use crate::phases::{READING, WRITING};
use crate::{CliResult, Globals};

/// The direction estimated normals are turned toward where nothing else decides.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum UpArg {
    /// +X.
    X,
    /// +Y (scanned models, most DCC tools' exports).
    Y,
    /// +Z (height fields, terrain).
    #[default]
    Z,
}

impl UpArg {
    /// The unit vector along the axis.
    pub(super) fn vector(self) -> Vec3 {
        match self {
            UpArg::X => Vec3::X,
            UpArg::Y => Vec3::Y,
            UpArg::Z => Vec3::Z,
        }
    }
}

/// Arguments of `geosynth normals`.
#[derive(Debug, Args)]
pub struct NormalsArgs {
    /// Point set (.ply, .obj, .off, .glb, .gltf, .xyz, .las, .pcd); normals it has are
    /// replaced (or, with `--keep-directions`, kept and oriented).
    input: PathBuf,
    /// Output point set with normals (.ply, .obj, .off, .pcd, .glb, .gltf, .xyz or .xyzn).
    #[arg(short, long)]
    output: PathBuf,
    /// Nearest neighbours (the point included) each tangent plane is fitted to, at least
    /// 3. Scans sampled far more densely along their lines than across them need enough
    /// to reach the next line.
    #[arg(long, default_value_t = NORMAL_NEIGHBOURS, value_parser = parse_neighbours)]
    neighbours: usize,
    /// Each connected part's highest point along this axis gets the normal facing it;
    /// the signs spread from there (for a closed scan: outward).
    #[arg(long, value_enum, default_value_t = UpArg::Z)]
    up: UpArg,
    /// Keep the directions of the normals the file has and only make their signs
    /// consistent (for normals another tool estimated without orienting them, or a
    /// scanner's): `--neighbours` is then unused.
    #[arg(long, conflicts_with = "neighbours")]
    keep_directions: bool,
    /// Also write a JSON report: the counts, the share of points facing away from most
    /// neighbours, each stage's seconds (reading, indexing, fitting, orienting, checking,
    /// writing) and the peak memory.
    #[arg(long, value_name = "R.json")]
    report: Option<PathBuf>,
}

/// Parses `--neighbours`: a whole number of at least 3, the fewest points a plane is
/// fitted to.
pub(super) fn parse_neighbours(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(k) if k >= 3 => Ok(k),
        _ => Err(format!("`{s}` is not a whole number of at least 3")),
    }
}

/// A note when some points' neighbourhoods define no normal
/// ([`geosynth::mls::NormalFit::undefined`]): their normals, and the orientation spread
/// through them, are arbitrary. `neighbours` is the count used (at most `points`); `flag`
/// is the option that sets it.
pub(super) fn undefined_note(
    undefined: usize,
    points: usize,
    neighbours: usize,
    flag: &str,
) -> Option<String> {
    // Every point among every point's neighbours: a larger count cannot help, a smaller
    // one fits local planes (a sphere's whole set is spread alike every way).
    let remedy = if neighbours >= points {
        format!(
            "{flag} takes in all {points} points here, so each plane is fitted to the whole \
             set instead of its surroundings; a smaller {flag} (the default is \
             {NORMAL_NEIGHBOURS}) fits local planes"
        )
    } else {
        format!(
            "Scan lines sampled far more densely along than across do that; {flag} large \
             enough to reach the next line fixes it"
        )
    };
    (undefined > 0).then(|| {
        format!(
            "note: {undefined} of {points} points ({:.1}%) have {neighbours} nearest \
             neighbours that fix no normal (along one line, at one place, or spread alike \
             every way): theirs are arbitrary. {remedy}",
            100.0 * undefined as f64 / points as f64
        )
    })
}

/// Refuses an output whose format stores no normals (LAS, `.xyzrgb`): they are what the
/// command writes.
fn check_keeps_normals(output: &Path) -> CliResult {
    let ext = output.extension().and_then(|e| e.to_str()).unwrap_or("");
    match FileFormat::from_extension(ext) {
        Some(format) if !format.stores_normals() => Err(format!(
            "cannot write {}: {format} stores no normals, and they are what `normals` writes \
             (write .ply, .xyzn, .obj or .off)",
            output.display()
        )
        .into()),
        _ => Ok(()),
    }
}

/// Refuses, for `--keep-directions`, a point set read from `path` without a direction at
/// every point.
fn check_directions(points: &PointSet, path: &Path) -> CliResult {
    let zero = match points.normals() {
        None => points.len(),
        Some(_) => points.directionless_normals(),
    };
    if zero == 0 {
        return Ok(());
    }
    Err(format!(
        "{}: {zero} of the {} points have no normal direction to keep (none in the file, \
         or zero); without --keep-directions `normals` fits them all",
        path.display(),
        points.len()
    )
    .into())
}

/// Runs `geosynth normals`.
pub fn run(args: &NormalsArgs, globals: Globals) -> CliResult {
    check_output_paths([args.output.as_path()], args.report.as_deref())?;
    check_geometry_output(&args.output, false, DVec3::ZERO)?;
    check_keeps_normals(&args.output)?;
    let started = Instant::now();
    let loaded = read_geometry(&args.input, globals)?;
    let read_time = started.elapsed();
    report_not_kept(globals, &args.input, &loaded.notes);
    let points = match loaded.geometry {
        Geometry::Points(points) => points,
        Geometry::Mesh(_) => {
            return Err(format!(
                "{} is a mesh: its normals come from its faces, which every command that \
                 needs them uses; `normals` estimates them for point sets",
                args.input.display()
            )
            .into());
        }
    };
    // The bar follows the stages: the fit, then the orientation.
    let (mut ctx, bar) = progress_context(globals, 0, "estimating normals", true);
    ctx.record_timing(READING, read_time);
    // One index of the positions serves the fit, the orientation and its check.
    let index = ctx.timed("indexing", |_| KdIndex::new(points.positions()))?;
    let count = points.len();
    let up = args.up.vector();
    // With the neighbours fitted to and how many define no normal, unless kept.
    let (oriented, fitted) = if args.keep_directions {
        check_directions(&points, &args.input)?;
        let oriented = ctx.timed("orienting normals", |ctx| {
            orient_normals_with(&index, &points, up, ctx)
        })?;
        (oriented, None)
    } else {
        // Recorded under "fitting normals" and "orienting normals".
        let fit = fit_oriented_normals_with(&index, points, args.neighbours, up, &mut ctx)?;
        let neighbours = args.neighbours.min(count);
        (fit.points, Some((neighbours, fit.undefined.len())))
    };
    bar.finish_and_clear();
    let disagreement = ctx.timed("checking the orientation", |_| {
        orientation_disagreement_with(&index, &oriented)
    })?;
    drop(index);
    let comment = match fitted {
        Some((neighbours, undefined)) => {
            if let Some(note) = undefined_note(undefined, count, neighbours, "--neighbours") {
                status(globals, note);
            }
            format!(
                "normals estimated by geosynth from {neighbours} nearest neighbours and \
                 oriented toward +{:?}",
                args.up
            )
        }
        None => format!(
            "normals as read, their signs made consistent by geosynth toward +{:?}",
            args.up
        ),
    };
    let options = WriteOptions::default()
        .comment(comment)
        .origin(loaded.origin);
    ctx.timed(WRITING, |_| {
        write_geometry_file(&args.output, &Geometry::Points(oriented), &options, globals)
    })?;
    if let Some(path) = &args.report {
        let report = json!({
            "input": args.input.display().to_string(),
            "output": args.output.display().to_string(),
            "points": count,
            "directions": if fitted.is_some() { "fitted" } else { "kept" },
            "neighbours": fitted.map(|(neighbours, _)| neighbours),
            "up": format!("+{:?}", args.up),
            "undefined_normals": fitted.map(|(_, undefined)| undefined),
            "facing_away_share": disagreement,
            "timings": timings_json(ctx.timings()),
        });
        write_json_report(path, "normals", &report)?;
    }
    status(
        globals,
        format!(
            "wrote {} ({} points; {:.1}% face away from most neighbours)",
            args.output.display(),
            count,
            100.0 * disagreement
        ),
    );
    Ok(())
}
