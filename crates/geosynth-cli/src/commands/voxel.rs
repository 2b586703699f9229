//! `geosynth voxel`: geometry synthesis by distance-field block matching (paper 001).

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, ValueEnum};
use geosynth::RunContext;
use geosynth::core::io::{Geometry, WriteOptions};
use geosynth::preview::{self, Panel, RenderOptions, UpAxis};
use geosynth::sdf::{GridSpec, nrrd};
use geosynth::voxel::{
    MatcherKind, QualityParams, SynthesizedField, VoxelExemplar, VoxelOutput, VoxelParams,
    VoxelQuality, VoxelSynth, evaluate, quantize_source, read_exemplar, source_quantizer,
    synthesize,
};
use serde_json::{Value, json};

use super::SignArgs;
use super::voxel_memory::{check_reconstruction_fits, check_synthesis_fits};
use crate::input_file::named;
use crate::json_report::{timings_json, write_json_report};
use crate::output::{
    check_geometry_output, check_output_paths, progress_context, report_not_kept, status,
    write_geometry_file,
};
use crate::params_file::{GivenFlags, INPUT_OPTIONS_KEY, ParamsFile, VOXEL_REPORTS};
use crate::phases::{self, MEASURING, PREPARING, READING, Timings, WRITING};
use crate::{CliResult, Globals};

/// Block search.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum MatcherArg {
    /// The paper's search tree.
    Tree,
    /// Linear search.
    Brute,
    /// Masked SSD by FFT.
    Fft,
    /// Random blocks (the baseline; no search).
    Random,
}

impl From<MatcherArg> for MatcherKind {
    fn from(m: MatcherArg) -> Self {
        match m {
            MatcherArg::Tree => MatcherKind::Tree,
            MatcherArg::Brute => MatcherKind::Brute,
            MatcherArg::Fft => MatcherKind::Fft,
            MatcherArg::Random => MatcherKind::Random,
        }
    }
}

/// Arguments of `geosynth voxel`.
#[derive(Debug, Args)]
pub struct VoxelArgs {
    /// Exemplar mesh (.ply, .obj, .off, .stl); a `texture_box` comment selects the sampled box
    /// (as `geosynth fixtures` writes it), otherwise the mesh's bounding box. Or an NRRD
    /// volume (as `geosynth sdf` writes one): the solid where it is negative, in its box.
    exemplar: PathBuf,
    /// Output mesh: the source triangles copied block by block, welded and relaxed (the
    /// paper's reconstruction).
    #[arg(short, long)]
    output: PathBuf,
    /// Also write the closed iso-surface of the synthesized field (.ply, .obj, .off, .stl).
    #[arg(long)]
    isosurface: Option<PathBuf>,
    #[command(flatten)]
    sign: SignArgs,
    /// Read the settings from JSON: any of the fields of the library's `VoxelSynth` stage
    /// (`source_resolution`, `mesh_sign`, `params` — `VoxelParams` — and `relax`, as the
    /// report's `stage` spells them: `{"params": {"levels": 2, "block": 8}}`), or a report
    /// written by `--report`, to run it again (with its `--orient-faces`). Fields it leaves
    /// out keep their defaults; the flags given here override it.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Source samples along the exemplar box's longest side.
    #[arg(long, default_value_t = VoxelSynth::default().source_resolution)]
    source_res: usize,
    /// Target samples along each axis at the last iteration. A run the machine's available
    /// memory cannot hold is refused before it starts, or, once the synthesized field shows
    /// how many triangles it copies, before the meshes are built (after `--field` is
    /// written); the error names a target that fits.
    #[arg(long, default_value_t = VoxelParams::default().target_dims[0])]
    target_res: usize,
    /// Target samples along x, y, z (`X,Y,Z`), instead of a cube of `--target-res`; e.g.
    /// keep a terrain's height with `128,128,64` from a 64³ source.
    #[arg(long, value_parser = parse_dims)]
    target_dims: Option<[usize; 3]>,
    /// Iterations (resolution levels).
    #[arg(long, default_value_t = VoxelParams::default().levels)]
    levels: usize,
    /// Block size of the last iteration (a power of two).
    #[arg(long, default_value_t = VoxelParams::default().block)]
    block: usize,
    /// Block search (tree, brute and fft are exact and give the same result; brute — a
    /// linear search with partial distances and pyramid filters — is the fastest here).
    #[arg(long, value_enum, default_value_t = MatcherArg::Brute)]
    matcher: MatcherArg,
    /// Seed of the random initialisation.
    #[arg(long, default_value_t = VoxelParams::default().seed)]
    seed: u64,
    /// Write the synthesized distance field as NRRD.
    #[arg(long)]
    field: Option<PathBuf>,
    /// Write a JSON report (timings, tree statistics, quality).
    #[arg(long)]
    report: Option<PathBuf>,
    /// Also synthesize with random blocks and measure that baseline for the report.
    #[arg(long)]
    baseline: bool,
    /// Render exemplar | output mesh | iso-surface to a PNG.
    #[arg(long)]
    preview: Option<PathBuf>,
}

fn parse_dims(s: &str) -> Result<[usize; 3], String> {
    super::comma_values(s, "X,Y,Z")
}

/// The phase of synthesizing the random-block baseline (`--baseline`).
const BASELINE: &str = "random baseline";

/// One measured run of the stage.
pub struct VoxelRun {
    /// What the stage produced.
    pub output: VoxelOutput,
    /// The run's phases: the stage's own, then measuring the quality and the baseline's.
    pub timings: Timings,
    /// Wall time.
    pub seconds: f64,
    /// Quality against the source.
    pub quality: VoxelQuality,
    /// Quality of the random-block baseline, when measured.
    pub baseline: Option<VoxelQuality>,
}

/// Runs the stage with a progress bar, measures it, and optionally the random baseline.
/// `after_synthesis` sees the synthesized field before the meshes are built from it (to
/// write it, or to check that they fit; timing what it does in the context it is given)
/// and can stop the run.
pub fn measured_run(
    exemplar: VoxelExemplar,
    stage: &VoxelSynth,
    baseline: bool,
    globals: Globals,
    after_synthesis: impl FnOnce(&SynthesizedField, &mut RunContext) -> CliResult,
) -> CliResult<VoxelRun> {
    let (mut ctx, bar) = progress_context(globals, stage.params.seed, "blocks", true);
    let start = Instant::now();
    let field = stage.synthesize_field(&exemplar, &mut ctx)?;
    let mut seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    after_synthesis(&field, &mut ctx)?;
    let start = Instant::now();
    let output = stage.reconstruct(&exemplar, field, &mut ctx)?;
    seconds += start.elapsed().as_secs_f64();
    let qp = QualityParams::default()
        .window(8.min(stage.params.block))
        .seed(stage.params.seed);
    let (quantizer, source, quality) = ctx.timed(MEASURING, |_| -> CliResult<_> {
        let quantizer = source_quantizer(&output.source, &stage.params)?;
        let source = quantize_source(&output.source, &quantizer)?;
        let quality = evaluate(&source, &quantizer, &output.synthesis, &qp)?;
        Ok((quantizer, source, quality))
    })?;
    let baseline = if baseline {
        let params = stage.params.clone().matcher(MatcherKind::Random);
        let (mut baseline_ctx, bar) = progress_context(globals, params.seed, "baseline", true);
        let random = ctx.timed(BASELINE, |_| {
            synthesize(&output.source, &params, &mut baseline_ctx)
        })?;
        bar.finish_and_clear();
        Some(ctx.timed(MEASURING, |_| evaluate(&source, &quantizer, &random, &qp))?)
    } else {
        None
    };
    let timings = ctx.timings().to_vec();
    Ok(VoxelRun {
        output,
        timings,
        seconds,
        quality,
        baseline,
    })
}

/// Quality numbers as JSON.
pub fn quality_json(q: &VoxelQuality) -> Value {
    json!({
        "neighbourhood_error": q.neighbourhood_error,
        "seam_error": q.seam_error,
        "seam_pairs": q.seam_pairs,
        "distance_field_fraction": q.distance_field_fraction,
        "source_distance_field_fraction": q.source_distance_field_fraction,
        "verbatim_fraction": q.verbatim_fraction,
        "window": q.window,
        "windows": q.windows,
    })
}

/// A run as JSON.
pub fn run_json(run: &VoxelRun, stage: &VoxelSynth) -> Value {
    let s = &run.output.synthesis;
    let c = &run.output.copied;
    json!({
        "seconds": run.seconds,
        "matcher": stage.params.matcher.name(),
        "exact_matches": stage.params.matcher != MatcherKind::Random,
        "source_dims": s.source_dims,
        "target_dims": s.field.dims(),
        "block": stage.params.block,
        "levels": s.levels.iter().map(|l| json!({
            "drop": l.drop, "dims": l.dims, "block": l.block, "blocks": l.blocks,
            "waves": l.waves, "mean_distance": l.mean_distance, "min_writes": l.min_writes,
            "max_writes": l.max_writes, "seconds": l.seconds,
        })).collect::<Vec<_>>(),
        "tree": s.tree.as_ref().map(|t| json!({
            "blocks": t.blocks, "nodes_per_level": t.nodes_per_level,
            "branching_factor": t.branching_factor, "memory_bytes": t.memory_bytes,
            "build_seconds": t.build_seconds,
        })),
        "timings": timings_json(&run.timings),
        "isosurface": { "vertices": run.output.isosurface.vertex_count(), "faces": run.output.isosurface.face_count() },
        "copied": {
            "triangles": c.copied_triangles, "boundary_edges_before": c.boundary_edges_before,
            "boundary_edges_after": c.boundary_edges_after, "welded_vertices": c.welded_vertices,
            "seam_distance_before": c.seam_distance_before, "seam_distance_after": c.seam_distance_after,
        },
        "quality": quality_json(&run.quality),
        "random_baseline": run.baseline.as_ref().map(quality_json),
    })
}

/// Renders exemplar | copied-triangle mesh | iso-surface, Z up, at one scale (the largest
/// at which each fits), so the exemplar's features and the synthesized solid's are drawn
/// the same size.
pub fn voxel_preview(
    exemplar: &VoxelExemplar,
    copied: &Geometry,
    isosurface: &Geometry,
    path: &Path,
    w: u32,
) -> CliResult {
    let exemplar = Geometry::Mesh(exemplar.mesh.clone());
    let panels: Vec<Panel<'_>> = [&exemplar, copied, isosurface]
        .into_iter()
        .map(|g| Panel::Geometry(g, UpAxis::Z))
        .collect();
    let image = preview::render_panels_at_one_scale(
        &panels,
        &RenderOptions::default().size(w, w * 3 / 4).view(30.0, 30.0),
    )?;
    preview::save_png(&image, path)?;
    Ok(())
}

/// A note when the exemplar file stored far coordinates in single precision on a grid
/// coarser than a hundredth of the source field's spacing.
fn precision_note(exemplar: &VoxelExemplar, source_res: usize) -> Option<String> {
    let step = exemplar.single_precision_step?;
    let spacing = GridSpec::covering(exemplar.bounds, source_res, 0.0)
        .ok()?
        .spacing;
    super::single_precision_note(
        exemplar.origin,
        step,
        f64::from(spacing),
        "the source distance field's spacing",
    )
}

/// Why the copied-triangle mesh came out empty, when it did: each source triangle travels
/// with the source sample nearest its centroid, so an exemplar of a few large triangles
/// has too few of them for the blocks to pick up.
fn empty_copy_note(
    exemplar: &VoxelExemplar,
    run: &VoxelRun,
    has_isosurface: bool,
) -> Option<String> {
    (run.output.copied.mesh.face_count() == 0).then(|| {
        let remedy = if has_isosurface {
            "the iso-surface file holds the synthesized solid"
        } else {
            "--isosurface writes the synthesized solid's surface"
        };
        format!(
            "note: no source triangle was copied: each travels with the source sample nearest \
             its centroid, and the exemplar's {} triangles are too few for the blocks to pick \
             up (a finer mesh of it would copy); {remedy}",
            exemplar.mesh.face_count()
        )
    })
}

/// The stage's settings: `--params`' file over the defaults, then every flag given on the
/// command line; validated.
fn run_stage(args: &VoxelArgs, file: &ParamsFile, given: GivenFlags) -> CliResult<VoxelSynth> {
    let mut stage = file.params(VoxelSynth::default(), |s: &VoxelSynth| {
        s.params.validate().and_then(|()| s.relax.validate())
    })?;
    given.apply("source_res", &mut stage.source_resolution, args.source_res);
    given.apply("sign", &mut stage.mesh_sign, args.sign.mesh_rule());
    let p = &mut stage.params;
    if let Some(dims) = args.target_dims {
        p.target_dims = dims;
    } else if given.has("target_res") {
        p.target_dims = [args.target_res; 3];
    }
    given.apply("levels", &mut p.levels, args.levels);
    given.apply("block", &mut p.block, args.block);
    given.apply("matcher", &mut p.matcher, args.matcher.into());
    given.apply("seed", &mut p.seed, args.seed);
    p.validate()?;
    stage.relax.validate()?;
    Ok(stage)
}

/// Runs `geosynth voxel`.
pub fn run(args: &VoxelArgs, given: GivenFlags, globals: Globals) -> CliResult {
    check_output_paths(
        std::iter::once(args.output.as_path()).chain(args.isosurface.as_deref()),
        [&args.field, &args.report, &args.preview]
            .into_iter()
            .flatten()
            .map(PathBuf::as_path),
    )?;
    let file = ParamsFile::read(args.params.as_deref(), VOXEL_REPORTS)?;
    let stage = run_stage(args, &file, given)?;
    let (sign, input_options) = args.sign.with_recorded(&file)?;
    let mut timings = Timings::new();
    let mut exemplar = phases::timed(&mut timings, READING, || read_exemplar(&args.exemplar))
        .map_err(named(&args.exemplar))?;
    report_not_kept(globals, &args.exemplar, &exemplar.notes);
    for path in std::iter::once(args.output.as_path()).chain(args.isosurface.as_deref()) {
        check_geometry_output(path, true, exemplar.origin)?;
    }
    phases::timed(&mut timings, PREPARING, || -> CliResult {
        if let Some(note) = precision_note(&exemplar, stage.source_resolution) {
            status(globals, note);
        }
        let (mesh, change) = sign.oriented(std::mem::take(&mut exemplar.mesh))?;
        exemplar.mesh = mesh;
        if let Some(line) = change {
            status(globals, line);
        }
        if let Some(note) = sign.note(&exemplar.mesh, stage.mesh_sign)? {
            status(globals, note);
        }
        if let Some(note) = check_synthesis_fits(&stage, &exemplar, args.isosurface.is_some())? {
            status(globals, note);
        }
        Ok(())
    })?;
    let run = measured_run(
        exemplar.clone(),
        &stage,
        args.baseline,
        globals,
        |field, ctx| {
            if let Some(path) = &args.field {
                ctx.timed(WRITING, |_| -> CliResult {
                    let grid = field.synthesis.distances()?;
                    nrrd::write_file(path, |f| nrrd::write_scalar_at(f, &grid, exemplar.origin))?;
                    Ok(())
                })?;
            }
            ctx.timed("checking the meshes fit", |_| {
                check_reconstruction_fits(
                    &stage,
                    &exemplar,
                    field,
                    args.isosurface.is_some(),
                    args.field.as_deref(),
                )
            })
        },
    )?;
    let options = WriteOptions::default()
        .comment(format!(
            "synthesized by geosynth voxel (seed {}, matcher {})",
            stage.params.seed,
            stage.params.matcher.name()
        ))
        .origin(exemplar.origin);
    // What needs the meshes is taken first, then they move into the written geometry
    // (copies of them would be the run's largest allocation).
    let report = run_json(&run, &stage);
    let note = empty_copy_note(&exemplar, &run, args.isosurface.is_some());
    let faces = run.output.copied.mesh.face_count();
    phases::extend(&mut timings, &run.timings);
    let copied = Geometry::Mesh(run.output.copied.mesh);
    let isosurface = Geometry::Mesh(run.output.isosurface);
    phases::timed(&mut timings, WRITING, || -> CliResult {
        write_geometry_file(&args.output, &copied, &options, globals)?;
        if let Some(path) = &args.isosurface {
            write_geometry_file(path, &isosurface, &options, globals)?;
        }
        if let Some(path) = &args.preview {
            voxel_preview(&exemplar, &copied, &isosurface, path, 400)?;
        }
        Ok(())
    })?;
    if let Some(path) = &args.report {
        let mut report = report;
        // The command's phases: the input's, the run's, the outputs'.
        report["timings"] = timings_json(&timings);
        report["exemplar"] = Value::from(args.exemplar.display().to_string());
        report[INPUT_OPTIONS_KEY] = serde_json::to_value(input_options)?;
        report["stage"] = serde_json::to_value(&stage)?;
        write_json_report(path, "voxel", &report)?;
    }
    if let Some(note) = note {
        status(globals, note);
    }
    let q = &run.quality;
    status(
        globals,
        format!(
            "wrote {} ({} faces, {:.1}s; neighbourhood error {:.3}, seam error {:.3}, distance-field fraction {:.2})",
            args.output.display(),
            faces,
            run.seconds,
            q.neighbourhood_error,
            q.seam_error,
            q.distance_field_fraction,
        ),
    );
    Ok(())
}
