//! `geosynth sample`: oriented points sampled on a mesh's surface, or a point set thinned
//! to fewer of its own points.

use std::path::PathBuf;
use std::time::Instant;

use clap::{Args, ValueEnum};
use geosynth::Stage;
use geosynth::core::io::{Geometry, WriteOptions};
use geosynth::core::surface_sampling::{SampleNormals, SurfaceSampling};
use geosynth::imagery::read_image;
use geosynth::sample::{SampleSurface, texture_colours};
use serde_json::json;

use crate::input_file::read_geometry;
use crate::json_report::{timings_json, write_json_report};
use crate::output::{
    check_geometry_output, check_output_paths, progress_context, report_not_kept, status,
    write_geometry_file,
};
use crate::phases::{READING, WRITING};
use crate::{CliResult, Globals};

mod thin;

/// Points `sample` aims for when given neither `--count` nor `--spacing`.
const DEFAULT_COUNT: usize = 100_000;

/// Where the samples' normals come from.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ValueEnum)]
pub enum NormalsArg {
    /// The normal of the triangle each point lies on.
    #[default]
    Faces,
    /// The mesh's vertex normals (its own, or averaged from its faces) interpolated
    /// across each triangle: smooth shading's normals.
    Interpolated,
}

/// Arguments of `geosynth sample`.
#[derive(Debug, Args)]
pub struct SampleArgs {
    /// Mesh to sample (.ply, .obj, .off, .stl, .glb, .gltf), or point set to thin (any
    /// point format).
    input: PathBuf,
    /// Output point set (.ply, .pcd, .glb, .gltf, .xyzn, .obj, .off; .xyz and .las keep no
    /// normals). A mesh's vertex colours and other vertex attributes are interpolated onto
    /// the points; a point set's kept points keep theirs.
    #[arg(short, long)]
    output: PathBuf,
    /// About this many points, spread as a Poisson disk (no two closer than the spacing
    /// that gives about this many; default 100000). With `--uniform`, exactly this many,
    /// drawn independently (from a point set: without replacement).
    #[arg(long, conflicts_with = "spacing")]
    count: Option<usize>,
    /// No two points closer than this, in the input's units (Poisson-disk sampling; a
    /// point set keeps a point within this of each of its points).
    #[arg(long, conflicts_with = "uniform")]
    spacing: Option<f32>,
    /// Draw the points independently, uniform by area (from a point set: any of its
    /// points alike), instead of as a Poisson disk: unbiased, and clumped like any random
    /// draw.
    #[arg(long)]
    uniform: bool,
    /// Colour the points from this image (PNG, JPEG, …) at their texture coordinates,
    /// which the mesh must have (OBJ's convention: (0, 0) is the image's lower-left
    /// corner; bilinear, repeating outside [0, 1]). The points also keep the coordinates
    /// as `s` and `t`. Replaces any vertex colours the mesh has (with a note).
    #[arg(long, value_name = "IMG")]
    texture: Option<PathBuf>,
    /// Where the points' normals come from, on a mesh (default: faces).
    #[arg(long, value_enum)]
    normals: Option<NormalsArg>,
    /// Seed of the random draws: the same mesh, options and seed give the same points.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Also write a JSON report: the mesh's area or the point set's count, the sampling,
    /// the points written, each stage's seconds and the peak memory.
    #[arg(long, value_name = "R.json")]
    report: Option<PathBuf>,
}

/// Runs `geosynth sample`.
pub fn run(args: &SampleArgs, globals: Globals) -> CliResult {
    check_output_paths([args.output.as_path()], args.report.as_deref())?;
    let started = Instant::now();
    let loaded = read_geometry(&args.input, globals)?;
    let read_time = started.elapsed();
    report_not_kept(globals, &args.input, &loaded.notes);
    check_geometry_output(&args.output, false, loaded.origin)?;
    let mesh = match loaded.geometry {
        Geometry::Mesh(mesh) => mesh,
        Geometry::Points(points) => {
            return thin::run(args, points, loaded.origin, read_time, globals);
        }
    };
    let texture = match &args.texture {
        None => None,
        Some(_) if mesh.uvs().is_none() => {
            return Err(format!(
                "{} has no texture coordinates for --texture to look the colours up at",
                args.input.display()
            )
            .into());
        }
        Some(path) => Some(read_image(path)?.to_rgb8()),
    };
    let area = mesh.area();
    if area <= 0.0 {
        return Err(format!(
            "{}: every triangle has zero area: there is no surface to sample",
            args.input.display()
        )
        .into());
    }
    let sampling = match (args.spacing, args.count) {
        (Some(spacing), _) => SurfaceSampling::PoissonDisk { spacing },
        (None, count) if args.uniform => SurfaceSampling::Uniform {
            count: count.unwrap_or(DEFAULT_COUNT),
        },
        (None, count) => {
            SurfaceSampling::poisson_disk_for_count(area, count.unwrap_or(DEFAULT_COUNT))
                .map_err(|e| format!("{}: {e}", args.input.display()))?
        }
    };
    let stage = SampleSurface {
        sampling,
        normals: match args.normals.unwrap_or_default() {
            NormalsArg::Faces => SampleNormals::Faces,
            NormalsArg::Interpolated => SampleNormals::Interpolated,
        },
    };
    let (mut ctx, bar) = progress_context(globals, args.seed, "sampling", false);
    ctx.record_timing(READING, read_time);
    let samples = ctx
        .timed("sampling", |ctx| stage.run(mesh, ctx))
        .map_err(|e| format!("{}: {e}", args.input.display()))?;
    bar.finish_and_clear();
    let mut points = samples.points;
    if let Some(texture) = &texture {
        if points.colors().is_some() {
            status(
                globals,
                "note: the mesh's vertex colours are replaced by the texture's; without \
                 --texture the points keep them, interpolated",
            );
        }
        points.set_colors(&texture_colours(&points, texture)?)?;
    }
    let count = points.len();
    let comment = match sampling {
        SurfaceSampling::Uniform { count } => format!(
            "{count} points sampled uniformly by area on {} by geosynth (seed {})",
            args.input.display(),
            args.seed
        ),
        SurfaceSampling::PoissonDisk { spacing } => format!(
            "points sampled on {} by geosynth as a Poisson disk of spacing {spacing} (seed {})",
            args.input.display(),
            args.seed
        ),
    };
    let options = WriteOptions::default()
        .comment(comment)
        .origin(loaded.origin);
    ctx.timed(WRITING, |_| {
        write_geometry_file(&args.output, &Geometry::Points(points), &options, globals)
    })?;
    let spacing = match sampling {
        SurfaceSampling::PoissonDisk { spacing } => Some(spacing),
        SurfaceSampling::Uniform { .. } => None,
    };
    if let Some(path) = &args.report {
        let report = json!({
            "input": args.input.display().to_string(),
            "output": args.output.display().to_string(),
            "area": area,
            "sampling": if spacing.is_some() { "poisson_disk" } else { "uniform" },
            "spacing": spacing,
            "normals": format!("{:?}", args.normals.unwrap_or_default()).to_lowercase(),
            "seed": args.seed,
            "texture": args.texture.as_ref().map(|p| p.display().to_string()),
            "points": count,
            "timings": timings_json(ctx.timings()),
        });
        write_json_report(path, "sample", &report)?;
    }
    let spread = match spacing {
        // One sample (as asked, or as all a surface far under one spacing² gets): no
        // pair to be apart.
        Some(spacing) if count == 1 => format!("alone at a spacing of {spacing}"),
        Some(spacing) => format!("none closer than {spacing}"),
        None => "uniform by area".into(),
    };
    let points = if count == 1 { "point" } else { "points" };
    status(
        globals,
        format!(
            "wrote {} ({count} {points}, {spread}; area {area:.4})",
            args.output.display()
        ),
    );
    Ok(())
}
