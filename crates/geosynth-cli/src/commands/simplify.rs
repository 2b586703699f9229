//! `geosynth simplify`: a mesh in fewer triangles, by edge collapse under error quadrics.

use std::path::PathBuf;
use std::time::Instant;

use clap::{Args, ValueEnum};
use geosynth::Stage;
use geosynth::core::io::{Geometry, WriteOptions};
use geosynth::core::simplify::{
    DEFAULT_BOUNDARY_WEIGHT, DEFAULT_MAX_FACE_TURN, SimplifiedNormals, SimplifyParams,
};
use geosynth::simplify::Simplify;
use serde_json::json;

use crate::input_file::read_geometry;
use crate::json_report::{timings_json, write_json_report};
use crate::output::{
    check_geometry_output, check_output_paths, progress_context, report_not_kept, status,
    write_geometry_file,
};
use crate::phases::{READING, WRITING};
use crate::{CliResult, Globals};

/// The share of its faces a mesh keeps when `simplify` is given no target (as MeshLab's
/// quadric simplification does by default).
const DEFAULT_RATIO: f64 = 0.5;

/// Arguments of `geosynth simplify`.
#[derive(Debug, Args)]
pub struct SimplifyArgs {
    /// Mesh to simplify (.ply, .obj, .off, .stl, .glb, .gltf).
    input: PathBuf,
    /// Output mesh (.ply, .obj, .off, .stl, .glb, .gltf). Vertex normals, colours, UVs
    /// and other attributes follow their vertices.
    #[arg(short, long)]
    output: PathBuf,
    /// Stop at this many faces (or fewer).
    #[arg(long, conflicts_with = "ratio")]
    faces: Option<usize>,
    /// Stop at this share of the input's faces, above 0 and at most 1 (default 0.5, unless
    /// --max-error alone is given: then as far as the error allows).
    #[arg(long)]
    ratio: Option<f64>,
    /// Make no collapse that puts a vertex further than this from the planes of its
    /// original faces (root mean square, in the mesh's units).
    #[arg(long, value_name = "E")]
    max_error: Option<f64>,
    /// The most a face may turn in one collapse, in degrees.
    #[arg(long, value_name = "DEG", default_value_t = DEFAULT_MAX_FACE_TURN)]
    max_turn: f64,
    /// How strongly boundaries keep their line (0 lets them shrink).
    #[arg(long, value_name = "W", default_value_t = DEFAULT_BOUNDARY_WEIGHT)]
    boundary_weight: f64,
    /// Where the output's vertex normals come from, when the input has normals.
    #[arg(long, value_enum, default_value_t = NormalsArg::Interpolate)]
    normals: NormalsArg,
    /// Also write a JSON report: the parameters, the counts before and after, the
    /// collapses made and refused, each phase's seconds and the peak memory.
    #[arg(long, value_name = "R.json")]
    report: Option<PathBuf>,
}

/// Where a simplified mesh's vertex normals come from.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum NormalsArg {
    /// Interpolated along each collapsed edge, as texture coordinates are (the input's
    /// shading kept); one facing against its faces takes theirs.
    Interpolate,
    /// From the output's faces, smooth where the input's normals were and creased where
    /// they were not.
    Recompute,
}

impl From<NormalsArg> for SimplifiedNormals {
    fn from(normals: NormalsArg) -> Self {
        match normals {
            NormalsArg::Interpolate => Self::Interpolate,
            NormalsArg::Recompute => Self::Recompute,
        }
    }
}

impl SimplifyArgs {
    /// The target face count for a mesh of `faces` faces.
    fn target(&self, faces: usize) -> Result<usize, String> {
        if let Some(count) = self.faces {
            return Ok(count);
        }
        let ratio = match (self.ratio, self.max_error) {
            (Some(ratio), _) => ratio,
            (None, Some(_)) => return Ok(0),
            (None, None) => DEFAULT_RATIO,
        };
        if !(ratio > 0.0 && ratio <= 1.0) {
            return Err(format!(
                "--ratio {ratio} is out of range: expected above 0 and at most 1"
            ));
        }
        Ok((faces as f64 * ratio).round() as usize)
    }
}

/// Runs `geosynth simplify`.
pub fn run(args: &SimplifyArgs, globals: Globals) -> CliResult {
    check_output_paths([args.output.as_path()], args.report.as_deref())?;
    let started = Instant::now();
    let loaded = read_geometry(&args.input, globals)?;
    let read_time = started.elapsed();
    report_not_kept(globals, &args.input, &loaded.notes);
    let mesh = match loaded.geometry {
        Geometry::Mesh(mesh) => mesh,
        Geometry::Points(_) => {
            return Err(format!(
                "{} is a point set: `simplify` collapses a mesh's edges (`reconstruct` makes \
                 a mesh of oriented points)",
                args.input.display()
            )
            .into());
        }
    };
    check_geometry_output(&args.output, true, loaded.origin)?;
    let mut params = SimplifyParams::faces(args.target(mesh.face_count())?);
    params.max_error = args.max_error;
    params.max_face_turn = args.max_turn;
    params.boundary_weight = args.boundary_weight;
    params.normals = args.normals.into();
    params.validate()?;
    let (mut ctx, bar) = progress_context(globals, 0, "simplifying", false);
    ctx.record_timing(READING, read_time);
    let simplified = ctx
        .timed("simplifying", |ctx| Simplify { params }.run(mesh, ctx))
        .map_err(|e| format!("{}: {e}", args.input.display()))?;
    bar.finish_and_clear();
    let report = simplified.report;
    let comment = format!(
        "{} simplified by geosynth from {} to {} faces (edge collapse under error quadrics)",
        args.input.display(),
        report.faces_before,
        report.faces_after
    );
    let options = WriteOptions::default()
        .comment(comment)
        .origin(loaded.origin);
    ctx.timed(WRITING, |_| {
        write_geometry_file(
            &args.output,
            &Geometry::Mesh(simplified.mesh),
            &options,
            globals,
        )
    })?;
    if let Some(path) = &args.report {
        let json = json!({
            "input": args.input.display().to_string(),
            "output": args.output.display().to_string(),
            "params": params,
            "simplify": report,
            "timings": timings_json(ctx.timings()),
        });
        write_json_report(path, "simplify", &json)?;
    }
    if report.faces_after > params.target_faces {
        status(
            globals,
            format!(
                "note: stopped at {} faces, above the target of {}: every remaining collapse \
                 would change the topology ({} refused), fold a face ({}) or exceed \
                 --max-error ({})",
                report.faces_after,
                params.target_faces,
                report.refused_topology,
                report.refused_fold,
                report.refused_error
            ),
        );
    }
    status(
        globals,
        format!(
            "wrote {} ({} faces from {}, {} vertices; largest collapse error {:.3e})",
            args.output.display(),
            report.faces_after,
            report.faces_before,
            report.vertices_after,
            report.max_collapse_error
        ),
    );
    Ok(())
}
