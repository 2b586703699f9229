//! `geosynth quilt`: patch-based geometry texture synthesis (paper 000).

mod args;
mod measured;
mod notes;
mod panels;

use std::path::{Path, PathBuf};
use std::time::Duration;

use geosynth::core::io::{FileFormat, Geometry, WriteOptions, XyzColumns};
use geosynth::core::{PointSet, RunContext};
use geosynth::imagery::{GeoReference, check_heightfield_output, is_heightfield_path};
use geosynth::mls::IsolatedFate;
use geosynth::quilt::{
    DEFAULT_RELIEF, ExemplarNormals, HeightFieldFrame, Method, OutputSize, QualityReport,
    QuiltParams, TextureFile, TextureReading, read_heightfield_texture_filling,
    read_heightfield_texture_framed, read_texture_file_fitted_with, read_texture_file_with,
};
use geosynth::tps::{PairingParams, Table1Preset};
use glam::{DVec3, Vec3};

use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use super::normals::undefined_note;
use super::point_prep::check_recorded_neighbours;
use super::sheet_heights::{MapPlacement, write_sheet_heights};
use super::sheet_mesh::sheet_mesh;
use crate::input_file::named;
use crate::json_report::{timings_json, write_json_report};
use crate::output::{
    check_geometry_output, check_output_paths, progress_context, report_not_kept, status,
    write_geometry_file,
};
use crate::params_file::{
    GivenFlags, INPUT_OPTIONS_KEY, ParamsFile, QUILT_REPORTS, RecordedInput, check_positive,
};
use crate::phases::{self, MEASURING, PREPARING, READING, Timings, WRITING};
use crate::{CliResult, Globals};
use args::{PresetArg, TextureUpArg, box_is_ordered};
use notes::{
    isolated_points_note, orientation_note, precision_note, size_note, stray_note, tilt_note,
    undersampled_mesh_note,
};
pub use panels::texture_preview;

pub use args::QuiltArgs;
use measured::{Measure, MeasuredRun};
pub use measured::{measure_for, measured_run, run_json, unmeasured_run};

/// The phase of the quilt itself (its own stages: the report's `run.timings`).
const SYNTHESIS: &str = "synthesis";
/// The phase of meshing the output and writing the mesh (`--mesh`).
const MESH: &str = "mesh";
/// The phase of sampling the output's heights and writing the map (`--heightfield-out`).
const HEIGHT_MAP: &str = "height map";
/// The phase of preparing the quality measure: the exemplar's fine distance field.
const MEASURE_SETUP: &str = "preparing the measure";

/// How the exemplar is read: the options a report records under
/// [`INPUT_OPTIONS_KEY`], so that `--params REPORT` reads it as the reported run did.
#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct InputOptions {
    /// `--up` (unset: the file's `texture_up` comment, or z).
    up: Option<TextureUpArg>,
    /// `--relief`, for height fields (unset: [`DEFAULT_RELIEF`]).
    relief: Option<f32>,
    /// `--fill-voids`, for height fields.
    fill_voids: bool,
    /// `--orient-normals`.
    orient_normals: bool,
    /// `--estimate-normals`, in neighbours (unset: the file's own normals).
    estimate_normals: Option<usize>,
    /// `--box`, corners in the file's coordinates (unset: the comments' box or the default).
    #[serde(rename = "box")]
    bounds: Option<[f64; 6]>,
    /// `--keep-strays`.
    keep_strays: bool,
    /// `--sample`, in points (unset: a mesh's vertices).
    sample: Option<usize>,
}

impl RecordedInput for InputOptions {
    fn check(&self) -> Result<(), String> {
        check_recorded_neighbours(self.estimate_normals)?;
        if self.sample == Some(0) {
            return Err("sample must be a positive number of points, not 0".into());
        }
        if let Some(b) = self.bounds
            && !box_is_ordered(&b)
        {
            return Err(format!(
                "box must be six finite numbers, each lower corner's below the upper one's, \
                 not {b:?}"
            ));
        }
        check_positive("relief", self.relief, "fraction")
    }
}

impl InputOptions {
    /// The options given on the command line over those of `--params`' file; the relief
    /// written out for a height field and dropped otherwise, like the axis and the
    /// normals' estimation for one. Estimated normals come oriented, so a recorded
    /// `--orient-normals` gives way to `--estimate-normals`.
    fn of(args: &QuiltArgs, file: &ParamsFile) -> CliResult<Self> {
        let recorded: Self = file.input_options()?;
        let heightfield = args.heightfield.is_some();
        let estimate_normals = args
            .estimate_normals
            .or(recorded.estimate_normals)
            .filter(|_| !heightfield);
        let up = args.up.or(recorded.up).filter(|_| !heightfield);
        let bounds = args.bounds.or(recorded.bounds).filter(|_| !heightfield);
        let keep_strays = (args.keep_strays || recorded.keep_strays) && !heightfield;
        let sample = args.sample.or(recorded.sample).filter(|_| !heightfield);
        let fitted = matches!(up, Some(TextureUpArg::Auto));
        if keep_strays && fitted {
            return Err(
                "--keep-strays keeps stray and isolated points; --up auto always leaves them \
                 out of its fitted plane"
                    .into(),
            );
        }
        if bounds.is_some() && fitted {
            return Err(
                "--box gives a box along the file's axes, and --up auto quilts in a \
                        plane fitted to the points, whose box is not; name the up axis \
                        (--up x|y|z) or leave out --box"
                    .into(),
            );
        }
        Ok(Self {
            up,
            bounds,
            relief: heightfield.then(|| args.relief.or(recorded.relief).unwrap_or(DEFAULT_RELIEF)),
            fill_voids: (args.fill_voids || recorded.fill_voids) && heightfield,
            orient_normals: (args.orient_normals || recorded.orient_normals)
                && estimate_normals.is_none(),
            estimate_normals,
            keep_strays,
            sample,
        })
    }

    /// How a point-set exemplar's file is read along its axes: its up axis, normals and
    /// box.
    fn reading(&self) -> TextureReading {
        TextureReading {
            up: self.up.and_then(TextureUpArg::axis),
            normals: match self.estimate_normals {
                Some(neighbours) => ExemplarNormals::Estimated { neighbours },
                None => ExemplarNormals::AsStored,
            },
            bounds: self
                .bounds
                .map(|b| [DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[4], b[5])]),
            keep_strays: self.keep_strays,
            mesh_samples: self.sample,
        }
    }
}

/// The run's parameters: `--params`' file over the defaults (with the pairing weights
/// written out, so the report shows them), then every flag given on the command line;
/// validated.
fn run_params(args: &QuiltArgs, file: &ParamsFile, given: GivenFlags) -> CliResult<QuiltParams> {
    let defaults = QuiltParams::default().pairing(PairingParams::default());
    let mut p = file.params(defaults, QuiltParams::validate)?;
    match (args.size, args.scale) {
        (Some((w, h)), _) => p.output = OutputSize::Absolute(w, h),
        (None, Some(s)) => p.output = OutputSize::Scale(s),
        (None, None) => {}
    }
    given.apply("seed", &mut p.seed, args.seed);
    given.apply("method", &mut p.method, args.method.into());
    given.apply("resolution", &mut p.field_resolution, args.resolution);
    given.apply("patch", &mut p.patch_size, args.patch);
    given.apply("epsilon", &mut p.epsilon, args.epsilon);
    given.apply("pair_distance", &mut p.pair_distance, args.pair_distance);
    given.apply(
        "warp_targets",
        &mut p.warp_targets,
        args.warp_targets.into(),
    );
    given.apply("smoothing", &mut p.smoothing, args.smoothing);
    given.apply("blend_reach", &mut p.blend_reach, args.blend_reach);
    given.apply(
        "normal_agreement",
        &mut p.normal_agreement,
        args.normal_agreement,
    );
    given.apply(
        "cluster_points",
        &mut p.clusters.max_points,
        args.cluster_points,
    );
    given.apply("relax", &mut p.relaxation_rounds, args.relax);
    if let Some(preset) = args.preset {
        p.pairing = Some(PairingParams::table1(match preset {
            PresetArg::Heightfield => Table1Preset::HeightField,
            PresetArg::ChainMail => Table1Preset::ChainMail,
            PresetArg::Weave => Table1Preset::Weave,
            PresetArg::Flowers => Table1Preset::Flowers,
        }));
    }
    p.validate()?;
    Ok(p)
}

/// The exemplar as read: its file, for a height field where its samples were placed, and
/// how many voids `--fill-voids` filled.
struct Loaded {
    file: TextureFile,
    heightfield: Option<HeightFieldFrame>,
    voids_filled: Option<usize>,
}

/// Loads the texture named by the arguments as `options` say (a height field is at the
/// origin), its normals estimated or oriented if asked (the estimation's stages timed in
/// `timings`), and for a height field where its samples were placed.
fn load(
    args: &QuiltArgs,
    options: &InputOptions,
    globals: Globals,
    timings: &mut Vec<(String, Duration)>,
) -> CliResult<Loaded> {
    let mut loaded = read_texture(args, options, globals, timings)?;
    let file = &mut loaded.file;
    let count = file.texture.canonical_points().len();
    if let Some(neighbours) = options.estimate_normals
        && let Some(note) = undefined_note(
            file.undefined_normals,
            count,
            neighbours.min(count),
            "--estimate-normals K",
        )
    {
        status(globals, note);
    }
    if options.orient_normals {
        let (mut ctx, bar) = progress_context(globals, 0, "orienting normals", false);
        file.texture = file.texture.with_oriented_normals_in(&mut ctx)?;
        bar.finish_and_clear();
        timings.extend_from_slice(ctx.timings());
    }
    Ok(loaded)
}

/// Reads the texture named by the arguments with the axis, relief and normals of
/// `options` (the estimation's stages timed in `timings`), and for a height field where
/// its samples were placed.
fn read_texture(
    args: &QuiltArgs,
    options: &InputOptions,
    globals: Globals,
    timings: &mut Vec<(String, Duration)>,
) -> CliResult<Loaded> {
    if let Some(path) = &args.heightfield {
        let relief = options.relief.unwrap_or(DEFAULT_RELIEF);
        let (texture, frame, voids_filled) = if options.fill_voids {
            let (texture, frame, filled) =
                read_heightfield_texture_filling(path, relief).map_err(named(path))?;
            let samples = texture.canonical_points().len();
            let message = match filled {
                0 => format!("{}: no voids to fill", path.display()),
                _ => format!(
                    "{}: filled {filled} void{} ({:.2}% of its samples) from the heights \
                     around them",
                    path.display(),
                    if filled == 1 { "" } else { "s" },
                    100.0 * filled as f64 / samples.max(1) as f64
                ),
            };
            status(globals, message);
            (texture, frame, Some(filled))
        } else {
            let (texture, frame) =
                read_heightfield_texture_framed(path, relief).map_err(named(path))?;
            (texture, frame, None)
        };
        return Ok(Loaded {
            file: texture.into(),
            heightfield: Some(frame),
            voids_filled,
        });
    }
    let path = args
        .exemplar
        .as_deref()
        .ok_or("an exemplar or --heightfield is needed")?;
    let reading = options.reading();
    let read = |ctx: &mut RunContext| match options.up {
        Some(TextureUpArg::Auto) => {
            read_texture_file_fitted_with(path, reading.normals, reading.mesh_samples, ctx)
        }
        _ => read_texture_file_with(path, &reading, ctx),
    };
    let file = if reading.normals == ExemplarNormals::AsStored && reading.mesh_samples.is_none() {
        read(&mut RunContext::new(0))
    } else {
        let task = match reading.mesh_samples {
            Some(_) => "sampling the mesh",
            None => "estimating normals",
        };
        let (mut ctx, bar) = progress_context(globals, 0, task, true);
        let file = read(&mut ctx);
        bar.finish_and_clear();
        timings.extend_from_slice(ctx.timings());
        file
    }
    .map_err(named(path))?;
    Ok(Loaded {
        file,
        heightfield: None,
        voids_filled: None,
    })
}

/// Writes the quilted points `points` (in the file's frame) as a mesh to `path`, with the
/// output's `options` (origin and comments); returns the report's `mesh` entry.
fn write_sheet_mesh(
    path: &Path,
    points: PointSet,
    options: &WriteOptions,
    globals: Globals,
) -> CliResult<Value> {
    let (mut ctx, bar) = progress_context(globals, 0, "meshing", false);
    let (mesh, resolution, seconds) = sheet_mesh(points, &mut ctx)?;
    bar.finish_and_clear();
    write_geometry_file(path, &Geometry::Mesh(mesh.clone()), options, globals)?;
    let topology = mesh.topology();
    status(
        globals,
        format!(
            "wrote {} ({} vertices, {} faces, {} component(s), grid {resolution}, {seconds:.2}s)",
            path.display(),
            mesh.vertex_count(),
            mesh.face_count(),
            topology.components,
        ),
    );
    Ok(json!({
        "path": path.display().to_string(),
        "resolution": resolution,
        "vertices": mesh.vertex_count(),
        "faces": mesh.face_count(),
        "components": topology.components,
        "boundary_edges": topology.boundary_edges,
        "seconds": seconds,
    }))
}

/// Runs `geosynth quilt`.
pub fn run(args: &QuiltArgs, given: GivenFlags, globals: Globals) -> CliResult {
    check_output_paths(
        std::iter::once(args.output.as_path()).chain(args.mesh.as_deref()),
        args.report
            .iter()
            .chain(&args.preview)
            .chain(&args.heightfield_out)
            .map(PathBuf::as_path),
    )?;
    check_geometry_output(&args.output, false, DVec3::ZERO)?;
    let ext = args
        .output
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("");
    if FileFormat::from_extension(ext) == Some(FileFormat::Xyz(XyzColumns::Colours)) {
        return Err(format!(
            "cannot write {}: a quilt's points carry normals and their patch, no colours \
             (write .xyz or .xyzn)",
            args.output.display()
        )
        .into());
    }
    if let Some(map) = &args.heightfield_out {
        check_heightfield_output(map)?;
    }
    // Checked here, not by clap's `requires` and `conflicts_with`: clap skips `requires`
    // when the required flag conflicts with one given (clap-rs/clap#4520).
    if let Some(spacing) = args.map_spacing
        && (args.heightfield_out.is_none() || args.heightfield.is_some())
    {
        return Err(format!(
            "--map-spacing {spacing} sets the grid of a point-set exemplar's \
             --heightfield-out map (a height field's map keeps the input's own grid)"
        )
        .into());
    }
    let png_map = args
        .heightfield_out
        .as_deref()
        .is_some_and(|map| !is_heightfield_path(map));
    if let Some((lo, hi)) = args.map_range
        && !(png_map && args.heightfield.is_none())
    {
        return Err(format!(
            "--map-range {lo},{hi} sets the grey scale of a point-set exemplar's \
             --heightfield-out PNG (a .f32le or .tif map keeps every height; a height \
             field's PNG keeps the input's grey levels)"
        )
        .into());
    }
    if let Some(mesh) = &args.mesh {
        check_geometry_output(mesh, true, DVec3::ZERO)?;
    }
    check_baselines_land(args, globals)?;
    let params_file = ParamsFile::read(args.params.as_deref(), QUILT_REPORTS)?;
    let params = run_params(args, &params_file, given)?;
    let input_options = InputOptions::of(args, &params_file)?;
    let mut timings = Timings::new();
    let Loaded {
        file,
        heightfield: heightfield_frame,
        voids_filled,
    } = phases::timed_rest(&mut timings, READING, |timings| {
        load(args, &input_options, globals, timings)
    })?;
    if let Some(mesh) = &args.mesh {
        // Georeferenced exemplars are written back in place: can the mesh's format say so?
        check_geometry_output(mesh, true, file.origin)?;
    }
    if let Some(path) = &args.exemplar {
        report_not_kept(globals, path, &file.notes);
    }
    // Before the run: a map that cannot be written must not cost the quilt. A height
    // field is read at the origin, so the output's points are in its frame.
    let map_placement = match (&args.heightfield_out, heightfield_frame) {
        (None, _) => None,
        (Some(_), Some(frame)) => Some(MapPlacement {
            frame,
            file: None,
            grey_range: None,
            input_reference: match &args.heightfield {
                Some(input) => GeoReference::of_heightfield(input).map_err(named(input))?,
                None => None,
            },
        }),
        (Some(_), None) => Some(MapPlacement::of_points(
            &file,
            args.map_spacing,
            args.map_range,
        )?),
    };
    // The output's size is checked before the notes size anything from it.
    let extent = file.texture.checked_output_extent(params.output)?;
    if let Some(placement) = &map_placement {
        placement.frame.map_size(extent)?;
    }
    let texture = &file.texture;
    // The hints about a file's up axis and its normals' orientation are for point-set
    // files: a height field's up axis is its own, its relief the one asked for, and its
    // normals its surface's, all facing up (rough terrain whose neighbouring normals tilt
    // apart is no sign of unoriented data).
    let from_points = heightfield_frame.is_none();
    let strays = stray_note(&file);
    let notes = phases::timed(&mut timings, PREPARING, || {
        [
            // A box given by hand says the axes and the extent are the user's choice;
            // stray points explain a tall box better than another up axis does.
            (from_points && input_options.bounds.is_none() && strays.is_none())
                .then(|| orientation_note(texture))
                .flatten(),
            strays,
            isolated_points_note(&file),
            undersampled_mesh_note(&file),
            tilt_note(&file),
            precision_note(&file),
            from_points
                .then(|| {
                    super::unoriented_normals_note(texture.canonical_points(), Some(Vec3::Z), None)
                })
                .flatten(),
            size_note(texture, &params),
        ]
    });
    for note in notes.into_iter().flatten() {
        status(globals, note);
    }
    // The output (and its preview) are written before it is measured: on large exemplars
    // the measure can take longer than the synthesis, and an interrupted measure must not
    // cost the result.
    let main = phases::timed(&mut timings, SYNTHESIS, || {
        unmeasured_run(texture, &params, globals, "quilt")
    })?;
    let mut comments = vec![format!(
        "quilted by geosynth (seed {}, {:?})",
        params.seed, params.method
    )];
    comments.extend(file.comments(&main.output.bounds));
    let mut options = WriteOptions::default().origin(file.origin);
    for c in comments {
        options = options.comment(c);
    }
    let written = phases::timed(&mut timings, WRITING, || -> CliResult<_> {
        let written = Geometry::Points(file.to_file_frame(&main.output.points)?);
        write_geometry_file(&args.output, &written, &options, globals)?;
        if let Some(path) = &args.preview {
            texture_preview(texture, &[&main.output], path, 480, 360)?;
        }
        Ok(written)
    })?;
    // The written points, taken back for the mesh (no copy of them is made).
    let mesh = match (&args.mesh, written) {
        (Some(path), Geometry::Points(points)) => Some(phases::timed(&mut timings, MESH, || {
            write_sheet_mesh(path, points, &options, globals)
        })?),
        _ => None,
    };
    let heightfield_out = match (&args.heightfield_out, map_placement) {
        (Some(path), Some(placement)) => Some(phases::timed(&mut timings, HEIGHT_MAP, || {
            write_sheet_heights(path, &main.output, placement, globals)
        })?),
        _ => None,
    };
    let measure = if args.no_quality {
        Err("skipped (--no-quality)".to_string())
    } else {
        phases::timed(&mut timings, MEASURE_SETUP, || {
            measure_for(texture, &params, globals)
        })
    };
    let main = timed_measure(main, &measure, globals, "quilt", &mut timings);
    // The baselines: their report entries, and their qualities for the summary lines
    // (their outputs are dropped run by run, so no two are held at once).
    let mut compared = Vec::new();
    if args.baselines {
        let mut runs = vec![
            (
                "search_only",
                "search only",
                params.clone().method(Method::SearchOnly),
            ),
            (
                "random_placement",
                "random placement",
                params.clone().method(Method::RandomPlacement),
            ),
        ];
        if params.method == Method::Full {
            // The control: the same patches pasted, so only the warp and blend differ.
            let pasted = params.same_layout_control(&main.output);
            runs.push(("same_layout_pasted", "full's layout, pasted", pasted));
        }
        for (key, label, run_params) in runs {
            let run = phases::timed(&mut timings, label, || {
                unmeasured_run(texture, &run_params, globals, label)
            })?;
            let run = timed_measure(run, &measure, globals, label, &mut timings);
            compared.push((key, label, run_json(&run), run.quality));
        }
    }
    if let Some(path) = &args.report {
        let mut report = json!({
            "exemplar": args.exemplar.as_ref().or(args.heightfield.as_ref())
                .map(|path| path.display().to_string()),
            INPUT_OPTIONS_KEY: input_options,
            "timings": timings_json(&timings),
            "undefined_normals": input_options.estimate_normals.map(|_| file.undefined_normals),
            "voids_filled": voids_filled,
            "longest_edge_spacings": file.longest_edge_spacings,
            "stray_points": file.stray_points.map(|s| json!({
                "count": s.count,
                "left_out": s.left_out,
            })),
            "isolated_points": file.isolated_points.map(|i| json!({
                "count": i.count,
                "reach": i.reach,
                "left_out": i.fate == IsolatedFate::LeftOut,
            })),
            "params": params,
            "run": run_json(&main),
            "mesh": mesh,
            "heightfield_out": heightfield_out,
        });
        for (key, _, entry, _) in &compared {
            report[*key] = entry.clone();
        }
        write_json_report(path, "quilt", &report)?;
    }
    status(
        globals,
        format!(
            "wrote {} ({} points, {} patches, {:.2}s; {})",
            args.output.display(),
            main.output.points.len(),
            main.output.stats.patches,
            main.seconds,
            quality_summary(&main.quality),
        ),
    );
    for (_, label, _, quality) in &compared {
        status(globals, format!("  {label}: {}", quality_summary(quality)));
    }
    Ok(())
}

/// `run` measured by `measure` ([`MeasuredRun::measured`]), timed in `timings` where
/// there is a measure.
fn timed_measure(
    run: MeasuredRun,
    measure: &Measure<'_>,
    globals: Globals,
    label: &str,
    timings: &mut Timings,
) -> MeasuredRun {
    match measure {
        Ok(_) => phases::timed(timings, MEASURING, || run.measured(measure, globals, label)),
        Err(_) => run.measured(measure, globals, label),
    }
}

/// Refuses `--baselines` where its results would land nowhere: without `--report` only
/// their errors are printed, which `--no-quality` skips and `--quiet` hides.
fn check_baselines_land(args: &QuiltArgs, globals: Globals) -> CliResult<()> {
    if !args.baselines || args.report.is_some() {
        return Ok(());
    }
    let fix = if args.no_quality {
        "--no-quality skips them: add --report R.json for their counts and timings, or drop \
         --no-quality"
    } else if globals.quiet {
        "--quiet hides them: add --report R.json"
    } else {
        return Ok(());
    };
    Err(format!(
        "without --report, --baselines only prints the baselines' neighbourhood and seam \
         errors, and {fix}"
    )
    .into())
}

/// The quality part of a run's summary line: its two errors, or why there are none.
fn quality_summary(quality: &Result<QualityReport, String>) -> String {
    match quality {
        Ok(q) if q.featureless_exemplar => "the exemplar has no relief, so its window \
            errors are not meaningful; see the report's coverage"
            .to_string(),
        Ok(q) => format!(
            "neighbourhood error {:.3}, seam error {:.3}",
            q.neighbourhood_error, q.seam_error
        ),
        Err(reason) => format!("quality not measured: {reason}"),
    }
}
