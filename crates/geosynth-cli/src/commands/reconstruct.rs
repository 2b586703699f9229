//! `geosynth reconstruct` and `geosynth sdf`.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use clap::Args;
use geosynth::core::KdIndex;
use geosynth::core::io::{self, Geometry, WriteOptions};
use geosynth::core::{PointSet, TriMesh};
use geosynth::mls::{MlsParams, PLANE_RADIUS_MAX_NEIGHBOURS, plane_radius};
use geosynth::reconstruct::{
    FieldParams, Reconstruct, ReconstructOpen, Remesh, drop_small_pieces, signed_distance_in,
    trim_to_mesh_spacings,
};
use geosynth::sdf::{MeshSign, PointSign, PointWinding, nrrd};
use geosynth::{RunContext, Stage};
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use super::normals::UpArg;
use super::point_prep::{LeftOut, PointPrep, PointPrepArgs, check_recorded_neighbours};
use super::{SignArgs, no_faces_to_orient, three_digits};
use crate::input_file::read_geometry;
use crate::json_report::{timings_json, write_json_report};
use crate::memory::available_bytes;
use crate::output::{
    check_geometry_output, check_output_paths, progress_context, report_not_kept, status,
    write_geometry_file,
};
use crate::params_file::{
    GivenFlags, INPUT_OPTIONS_KEY, ParamsFile, RECONSTRUCT_REPORTS, RecordedInput, ReportKind,
    SDF_REPORTS, check_positive,
};
use crate::phases::{self, PREPARING, READING, Timings, WRITING};
use crate::{CliResult, Globals};

/// Grid settings, the parameter file and the report, shared by both commands.
#[derive(Debug, Args)]
pub struct GridArgs {
    /// Grid nodes along the longest side of the input's box.
    #[arg(long, default_value_t = FieldParams::default().resolution)]
    resolution: usize,
    /// MLS kernel size h for point sets (default: 1.25 × the median point spacing).
    #[arg(long)]
    kernel: Option<f32>,
    /// Read the grid's settings from JSON: any of the library's `FieldParams` fields
    /// (`resolution`, `kernel`, `margin`, `band`, `mesh_sign`, `point_sign`, as the
    /// report's `params` spells them: `{"margin": 6, "band": 8}`), or a report written by
    /// `--report` (`sdf`'s or `reconstruct`'s; one of the same command also reads the input
    /// as that run did: its `--orient-faces`, `--orient-normals`, `--estimate-normals`,
    /// `--up` and `--keep-strays`, and for `reconstruct` its `--trim` and `--drop-pieces`). Fields it leaves
    /// out keep their defaults; the flags given here override it.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Write a JSON report: the parameters, what was read and written, the timings.
    #[arg(long, value_name = "FILE")]
    report: Option<PathBuf>,
}

impl GridArgs {
    /// The run's parameters: `--params`' file over the defaults, then the flags given on
    /// the command line (`--sign` sets both sign rules); validated.
    fn params(
        &self,
        file: &ParamsFile,
        sign: &SignArgs,
        given: GivenFlags,
    ) -> CliResult<FieldParams> {
        let mut params = file.params(FieldParams::default(), FieldParams::validate)?;
        given.apply("resolution", &mut params.resolution, self.resolution);
        if self.kernel.is_some() {
            params.kernel = self.kernel;
        }
        if given.has("sign") {
            params = sign.apply(params);
        }
        params.validate()?;
        Ok(params)
    }

    /// The paths this command writes besides its main output.
    fn other_outputs(&self) -> impl Iterator<Item = &Path> {
        self.report.iter().map(PathBuf::as_path)
    }

    /// The document of `--params`, if given, read as `kind` says.
    fn params_file(&self, kind: ReportKind) -> CliResult<ParamsFile> {
        ParamsFile::read(self.params.as_deref(), kind)
    }
}

/// Writes the report of `geosynth COMMAND`, `report` with the run's parameters under
/// `params` and how its input was read under [`INPUT_OPTIONS_KEY`], where `--report` asks.
fn write_report(
    grid: &GridArgs,
    command: &str,
    params: &FieldParams,
    input_options: impl Serialize,
    mut report: Value,
) -> CliResult {
    let Some(path) = &grid.report else {
        return Ok(());
    };
    report["params"] = serde_json::to_value(params)?;
    report[INPUT_OPTIONS_KEY] = serde_json::to_value(input_options)?;
    write_json_report(path, command, &report)
}

/// Arguments of `geosynth reconstruct`.
#[derive(Debug, Args)]
pub struct ReconstructArgs {
    /// An oriented point set (PLY, OBJ, OFF or XYZ with normals), or a mesh: remeshed closed
    /// through its own exact distance field (`--sign` and `--orient-faces` apply; `--kernel`
    /// does not).
    input: PathBuf,
    /// Output mesh (.ply, .obj, .off or .stl).
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    grid: GridArgs,
    #[command(flatten)]
    normals: PointPrepArgs,
    /// For open scans (a façade, a terrain, a quilted sheet): cut the surface where it runs
    /// on past the scan's border, beyond this many median sample spacings from every point
    /// (`--trim` alone: 2, `DEFAULT_TRIM_SPACINGS`). Gaps inside the scan stay bridged.
    /// Below about 2 the gaps of a random sampling join up with the border and the sheet
    /// falls apart. For a mesh: this many median spacings of its vertices from its faces.
    #[arg(long, value_name = "SPACINGS", num_args = 0..=1, default_missing_value = "2")]
    trim: Option<f32>,
    /// Drop the pieces of the surface whose bounding box is less than this many median
    /// sample spacings across (`--drop-pieces` alone: 12): the small closed bubbles that
    /// undersampled parts (the steep sides of a height field's features) leave beside the
    /// surface. Real parts that small go too.
    #[arg(long, value_name = "SPACINGS", num_args = 0..=1, default_missing_value = "12")]
    drop_pieces: Option<f32>,
    #[command(flatten)]
    sign: SignArgs,
}

/// `--drop-pieces` alone, in median sample spacings. On the shared stone wall height field,
/// quilted and reconstructed at 160 and 200 nodes, it leaves the sheet alone and drops
/// every other piece (69 of 70, 119 of 120), where 4 spacings leave 22 and 15 of them
/// (docs/mls-surface.md, "Small pieces").
const DROP_PIECES_SPACINGS: f32 = 12.0;

/// How `reconstruct` reads its points: the options its report records under
/// [`INPUT_OPTIONS_KEY`], so that `--params REPORT` reads them as the reported run did.
#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct ReconstructInputOptions {
    /// `--orient-normals`.
    orient_normals: bool,
    /// `--estimate-normals`, in neighbours (unset: the points' own normals).
    estimate_normals: Option<usize>,
    /// `--up`: where orienting or estimated normals are turned.
    up: UpArg,
    /// `--keep-strays`.
    keep_strays: bool,
    /// `--trim`, in median sample spacings (unset: no trim).
    trim: Option<f32>,
    /// `--drop-pieces`, in median sample spacings (unset: every piece kept).
    drop_pieces: Option<f32>,
    /// `--orient-faces` (meshes).
    orient_faces: bool,
}

impl RecordedInput for ReconstructInputOptions {
    fn check(&self) -> Result<(), String> {
        check_recorded_neighbours(self.estimate_normals)?;
        check_positive("trim", self.trim, "number of spacings")?;
        check_positive("drop_pieces", self.drop_pieces, "number of spacings")
    }
}

impl ReconstructInputOptions {
    /// The options given on the command line over those of `--params`' file.
    fn of(args: &ReconstructArgs, file: &ParamsFile) -> CliResult<Self> {
        let recorded: Self = file.input_options()?;
        check_positive("--trim", args.trim, "number of spacings")?;
        check_positive("--drop-pieces", args.drop_pieces, "number of spacings")?;
        let prep = args.normals.over(recorded.normals())?;
        Ok(Self {
            up: prep.up,
            orient_normals: prep.orient,
            estimate_normals: prep.estimate,
            keep_strays: prep.keep_strays,
            trim: args.trim.or(recorded.trim),
            drop_pieces: args.drop_pieces.or(recorded.drop_pieces),
            orient_faces: args.sign.orient_faces || recorded.orient_faces,
        })
    }

    /// What is done to a point set's normals.
    fn normals(&self) -> PointPrep {
        PointPrep {
            orient: self.orient_normals,
            estimate: self.estimate_normals,
            up: self.up,
            keep_strays: self.keep_strays,
        }
    }
}

/// Reads `reconstruct`'s input and prepares it as `options` ask: a point set's stray and
/// isolated points left out and its normals estimated or oriented (each stage's time added to
/// `timings`), a mesh's faces turned to agree; prints the notes about it. Returns it and
/// what was left out of a point set.
fn prepared_input(
    args: &ReconstructArgs,
    geometry: Geometry,
    options: &ReconstructInputOptions,
    params: &FieldParams,
    globals: Globals,
    timings: &mut Vec<(String, Duration)>,
) -> CliResult<(Geometry, LeftOut)> {
    match geometry {
        Geometry::Mesh(mesh) => {
            options.normals().refuse_for_mesh(&args.input)?;
            let sign = SignArgs {
                orient_faces: options.orient_faces,
                ..args.sign
            };
            if let Some(h) = params.kernel {
                status(
                    globals,
                    format!(
                        "note: --kernel {h} sets a point set's MLS kernel; a mesh's distance is \
                         exact and takes none"
                    ),
                );
            }
            let (mesh, change) = sign.oriented(mesh)?;
            if let Some(line) = change {
                status(globals, line);
            }
            // With --trim the mesh is taken as the open sheet the note would suggest.
            if options.trim.is_none()
                && let Some(note) = sign.note(&mesh, params.mesh_sign)?
            {
                status(globals, note);
            }
            Ok((Geometry::Mesh(mesh), LeftOut::default()))
        }
        Geometry::Points(points) => {
            let prepared =
                options
                    .normals()
                    .prepared(points, params.kernel, &args.input, globals, timings)?;
            if options.orient_faces {
                status(globals, no_faces_to_orient(&args.input));
            }
            let trimmed = options.trim.is_some();
            if let Some(note) = line_gap_note(&prepared.index, params.kernel, trimmed)? {
                status(globals, note);
            }
            Ok((Geometry::Points(prepared.points), prepared.left_out))
        }
    }
}

/// The closed (or, with `trim` in median sample spacings, trimmed) surface of `input`.
fn reconstructed(
    input: &Geometry,
    params: &FieldParams,
    trim: Option<f32>,
    ctx: &mut RunContext,
) -> CliResult<TriMesh> {
    let kernel = params.kernel;
    let params = params.clone();
    let of_points = |surface, points| with_kernel_hint(surface, points, kernel);
    Ok(match (input, trim) {
        (Geometry::Points(points), Some(trim)) => of_points(
            ReconstructOpen { params, trim }.run(points.clone(), ctx),
            points,
        )?,
        (Geometry::Points(points), None) => {
            of_points(Reconstruct { params }.run(points.clone(), ctx), points)?
        }
        (Geometry::Mesh(mesh), trim) => {
            let closed = Remesh { params }.run(mesh.clone(), ctx)?;
            match trim {
                Some(trim) => ctx.timed("trim", |_| trim_to_mesh_spacings(&closed, mesh, trim))?,
                None => closed,
            }
        }
    })
}

/// `surface`, or its error; a point set's [`geosynth::Error::NoSurface`] says what a large
/// `kernel` does ([`large_kernel`]) where it is one: a unit sphere's samples at `--kernel` 1
/// or more give a field positive everywhere.
fn with_kernel_hint(
    surface: geosynth::Result<TriMesh>,
    points: &PointSet,
    kernel: Option<f32>,
) -> CliResult<TriMesh> {
    match surface {
        Err(e @ geosynth::Error::NoSurface { .. }) => {
            let index = KdIndex::new(points.positions())?;
            let h = MlsParams::default()
                .with_kernel(kernel)
                .kernel_for(&index)?;
            Err(match large_kernel(points, &index, h)? {
                Some(large) => format!("{e}; {large}").into(),
                None => e.into(),
            })
        }
        other => Ok(other?),
    }
}

/// Runs `geosynth reconstruct`.
pub fn run_reconstruct(args: &ReconstructArgs, given: GivenFlags, globals: Globals) -> CliResult {
    check_output_paths([args.output.as_path()], args.grid.other_outputs())?;
    let file = args.grid.params_file(RECONSTRUCT_REPORTS)?;
    let params = args.grid.params(&file, &args.sign, given)?;
    let options = ReconstructInputOptions::of(args, &file)?;
    // Georeferenced points are reconstructed relative to an origin and written back there.
    let mut preparing = Timings::new();
    let loaded = phases::timed(&mut preparing, READING, || {
        read_geometry(&args.input, globals)
    })?;
    report_not_kept(globals, &args.input, &loaded.notes);
    check_geometry_output(&args.output, true, loaded.origin)?;
    let (input, left_out) = phases::timed_rest(&mut preparing, PREPARING, |preparing| {
        prepared_input(args, loaded.geometry, &options, &params, globals, preparing)
    })?;
    let from_points = matches!(input, Geometry::Points(_));
    let winding = if from_points {
        params.point_sign == PointSign::WindingNumber
    } else {
        params.mesh_sign == MeshSign::WindingNumber
    };
    if options.trim.is_some() && winding {
        status(
            globals,
            "note: --trim is for open scans, and an open scan has no inside for --sign \
             winding: below the sheet the winding number hovers near ½ and the surface comes \
             out speckled; the default --sign local follows the sheet",
        );
    }
    check_grid_fits(&params, &input)?;
    // The bar follows the stages: the field's layers, then the iso-surface.
    let (mut ctx, bar) = progress_context(globals, 0, "reconstructing", true);
    for (stage, time) in preparing {
        ctx.record_timing(&stage, time);
    }
    let mut mesh = reconstructed(&input, &params, options.trim, &mut ctx)?;
    let points = input.points();
    // Measured only when a piece's size is asked about (`--drop-pieces`, the note).
    let spacing = || -> CliResult<f32> { Ok(KdIndex::new(points.positions())?.median_spacing()?) };
    let mut pieces_dropped = None;
    if let Some(spacings) = options.drop_pieces {
        let limit = spacings * spacing()?;
        let kept = ctx.timed("drop pieces", |_| drop_small_pieces(&mesh, limit))?;
        if kept.mesh.face_count() == 0 {
            // Nothing written: an empty mesh is not a reconstruction.
            return Err(format!(
                "--drop-pieces {spacings} drops every piece ({} of them): none spans \
                 {spacings} median sample spacings ({limit}); a smaller value keeps the \
                 larger ones",
                kept.dropped
            )
            .into());
        }
        (mesh, pieces_dropped) = (kept.mesh, Some(kept.dropped));
    }
    bar.finish_and_clear();
    let write_options = WriteOptions::default()
        .comment(format!(
            "reconstructed from {} by geosynth",
            args.input.display()
        ))
        .origin(loaded.origin);
    ctx.timed(WRITING, |_| {
        write_geometry_file(
            &args.output,
            &Geometry::Mesh(mesh.clone()),
            &write_options,
            globals,
        )
    })?;
    let timings: Vec<String> = ctx
        .timings()
        .iter()
        .map(|(n, d)| format!("{n} {:.2}s", d.as_secs_f64()))
        .collect();
    let topology = mesh.topology();
    let shape = match (topology.is_closed_manifold(), topology.boundary_edges) {
        (true, _) => "closed".to_string(),
        (false, 0) => "no open edges but not an oriented manifold".to_string(),
        (false, open) => format!("{open} open edges"),
    };
    status(
        globals,
        format!(
            "wrote {} ({} vertices, {} faces, {} component(s){}, {shape}; {})",
            args.output.display(),
            mesh.vertex_count(),
            mesh.face_count(),
            topology.components,
            pieces_dropped.map_or(String::new(), |n| format!(" after dropping {n} small")),
            timings.join(", ")
        ),
    );
    write_report(
        &args.grid,
        "reconstruct",
        &params,
        &options,
        json!({
            "input": args.input.display().to_string(),
            "input_kind": if from_points { "points" } else { "mesh" },
            "points": points.len(),
            "strays_left_out": left_out.strays,
            "isolated_left_out": left_out.isolated,
            "output": args.output.display().to_string(),
            "vertices": mesh.vertex_count(),
            "faces": mesh.face_count(),
            "components": topology.components,
            "pieces_dropped": pieces_dropped,
            "boundary_edges": topology.boundary_edges,
            "closed_manifold": topology.is_closed_manifold(),
            "timings": timings_json(ctx.timings()),
        }),
    )?;
    if !from_points {
        if options.trim.is_none() && topology.boundary_edges > 0 {
            status(globals, mesh_grid_side_note(topology.boundary_edges));
        }
        return Ok(());
    }
    if options.drop_pieces.is_none() && topology.components > 1 {
        let small = drop_small_pieces(&mesh, DROP_PIECES_SPACINGS * spacing()?)?.dropped;
        if small > 0 {
            status(
                globals,
                format!(
                    "note: {small} of the {} pieces are under {DROP_PIECES_SPACINGS} sample \
                     spacings across: where the points undersample the surface (steep \
                     slopes, parts thinner than the kernel) its MLS surface closes into small \
                     bubbles; --drop-pieces removes them",
                    topology.components
                ),
            );
        }
    }
    if options.trim.is_none() && topology.boundary_edges > 0 {
        let note = grid_side_note(topology.boundary_edges, points, params.kernel)?;
        status(globals, note);
    }
    if options.trim.is_none() && !winding && topology.components > 1 {
        let open_flux = PointWinding::new(points)?.open_flux();
        if open_flux < CLOSED_FLUX {
            status(
                globals,
                format!(
                    "note: the surface came out in {} pieces, and the points' area-weighted \
                     normals cancel as on a closed surface (open flux {open_flux:.3}). If they \
                     sample one closed object, parts thinner than the kernel or normals facing \
                     the wrong way have broken it apart; --sign winding signs the field by the \
                     points' winding number, which keeps such objects whole",
                    topology.components
                ),
            );
        }
    }
    Ok(())
}

/// Below this [`PointWinding::open_flux`] a cloud may be closed, and a reconstruction in
/// pieces gets the `--sign winding` note. Measured: the chameleon 0.002, the bunny 0.003,
/// sphere, cube and chain-mail samples at most 0.004, an open tube 0.014 (a false alarm
/// the note's "if" covers); open sheets (the bumpy and height-field fixtures) 0.84–0.90.
const CLOSED_FLUX: f32 = 0.1;

/// The largest kernel, as a share of the points' bounding-box diagonal, that
/// [`grid_side_note`] calls small. Measured on the shared chameleon (diagonal 113, 32
/// nodes): `--kernel` 10 (0.09 of it) left 3 pieces with the animal's body; 30 (0.27) a
/// closed blob of 14 vertices; 300 and more a sheet through the grid, the MLS surface about
/// one plane; the 2000 unit-sphere samples of the fixtures (diagonal 3.46) at `--kernel` 1
/// (0.29) and more, a field positive everywhere: no surface at all. Doubling a kernel past
/// this share smooths the object away.
const LARGEST_SMALL_KERNEL: f32 = 0.1;

/// The note for an untrimmed reconstruction with `open` open edges. The iso-surface of a
/// grid is closed except where it meets the grid's sides, so open edges say the zero set
/// ran out to them: an open scan's continuation past its border, or, on a closed object, a
/// kernel too small for the sampling (fins past sharp edges, wrong signs at thin parts:
/// docs/mls-surface.md, "Known limits") or so large that the MLS surface flattens the
/// object toward one plane ([`LARGEST_SMALL_KERNEL`]). `kernel` is the one asked for, if
/// any.
fn grid_side_note(open: usize, points: &PointSet, kernel: Option<f32>) -> CliResult<String> {
    let scan = format!(
        "note: the surface runs out to the sides of the grid ({open} open edges). An open \
         scan does that past its border (--trim cuts it back)"
    );
    let index = KdIndex::new(points.positions())?;
    let h = MlsParams::default()
        .with_kernel(kernel)
        .kernel_for(&index)?;
    if let Some(large) = large_kernel(points, &index, h)? {
        return Ok(format!("{scan}; {large}"));
    }
    let largest_small = LARGEST_SMALL_KERNEL * diagonal(points);
    Ok(format!(
        "{scan}; on a closed object the MLS kernel (h = {}) is probably too small for the \
         sampling, leaving fins past sharp edges or wrong signs at thin parts (try a larger \
         --kernel, such as {})",
        three_digits(h),
        three_digits((2.0 * h).min(largest_small))
    ))
}

/// What the kernel `h` does when it is over [`LARGEST_SMALL_KERNEL`] of the points'
/// extent, said with the default to come back to; `None` for a smaller one. `index` holds
/// `points`.
fn large_kernel(points: &PointSet, index: &KdIndex, h: f32) -> CliResult<Option<String>> {
    let diagonal = diagonal(points);
    if h <= LARGEST_SMALL_KERNEL * diagonal {
        return Ok(None);
    }
    let default = MlsParams::default().kernel_for(index)?;
    Ok(Some(format!(
        "the MLS kernel h = {} spans more than a tenth of the points' extent (diagonal {}) \
         and smooths away everything smaller: an open sheet flattens toward one plane, a \
         closed object's opposite sides cancel (try a smaller --kernel; the default for these \
         points is {})",
        three_digits(h),
        three_digits(diagonal),
        three_digits(default)
    )))
}

/// The diagonal of `points`' bounding box (0 for none).
fn diagonal(points: &PointSet) -> f32 {
    points.bounding_box().map_or(0.0, |b| b.diagonal())
}

/// What `sdf` and `reconstruct` hold per grid node, in bytes: their peak memory over
/// the grid's nodes on the torus points at 400 nodes (`--report`'s `peak_memory_bytes`,
/// 2026-12-05) was 25 for `sdf` and 32 for `reconstruct`; 47 and more at 100 nodes,
/// where the input and the program weigh more than the grid.
const GRID_BYTES_PER_NODE: u64 = 32;

/// Refuses a grid that would not fit in the memory this machine has available
/// ([`available_bytes`]) at [`GRID_BYTES_PER_NODE`], saying which resolution would. The
/// allowed resolutions reach 1024 nodes along the longest side, and a cube at 1024 holds
/// 10⁹ nodes, about 34 GB: without the check the run would be killed (or the allocation
/// abort) after the input was read. Nothing is checked where the machine does not tell.
fn check_grid_fits(params: &FieldParams, geometry: &Geometry) -> CliResult {
    match available_bytes() {
        Some(available) => check_grid_fits_in(params, geometry, available),
        None => Ok(()),
    }
}

/// [`check_grid_fits`] with `available` bytes.
fn check_grid_fits_in(params: &FieldParams, geometry: &Geometry, available: u64) -> CliResult {
    let spec = params.grid_for(geometry)?;
    let nodes = spec
        .dims
        .iter()
        .fold(1u64, |n, &d| n.saturating_mul(d as u64));
    let needed = nodes.saturating_mul(GRID_BYTES_PER_NODE);
    if needed <= available {
        return Ok(());
    }
    // The node count goes with the cube of the resolution; a twentieth is left spare.
    let scale = (available as f64 / needed as f64).cbrt();
    let fits = (0.95 * scale * params.resolution as f64).floor();
    let [x, y, z] = spec.dims;
    Err(format!(
        "a grid of {x} × {y} × {z} nodes (resolution {}) needs about {:.1} GB, more than the \
         {:.1} GB this machine has available; --resolution {fits} fits",
        params.resolution,
        needed as f64 / 1e9,
        available as f64 / 1e9
    )
    .into())
}

/// The trim [`line_gap_note`] suggests, as a fraction of the distance between the lines:
/// a face midway between two lines lies half that distance from both, so a trim a fifth
/// longer keeps it, while the sheet runs on that far past the scan's border.
const LINE_GAP_TRIM: f32 = 0.6;

/// The note for points in lines (or clumps) farther apart than their MLS kernel reaches
/// (`kernel`: the one asked for, if any): the median point's nearest neighbours span a
/// plane ([`plane_radius`]) only beyond the kernel's truncation (`support · h`). Scan
/// lines sampled far more densely along than across do that: the kernel, estimated from
/// the step along them, leaves the surface between the lines to the far nodes' signs,
/// with ridges along the lines, and a trim in those steps cuts it into strips. Measured
/// `plane_radius / h`: 0.8–1.7 on the shared point sets, meshes and every fixture; 40 on
/// lines 0.5 apart sampled every 0.01. Suggests a kernel of half that radius (clean at
/// 0.2 and 0.3 on those lines, ridged edges at 0.1) and, with `trimmed`, a trim of
/// [`LINE_GAP_TRIM`] times the radius, in spacings. `index` indexes the points.
fn line_gap_note(index: &KdIndex, kernel: Option<f32>, trimmed: bool) -> CliResult<Option<String>> {
    let mls = MlsParams::default().with_kernel(kernel);
    let h = mls.kernel_for(index)?;
    let reach = mls.support * h;
    let radius = plane_radius(index)?;
    if radius.is_some_and(|r| r <= reach) {
        return Ok(None);
    }
    let (found, advice) = match radius {
        Some(r) => {
            let trim = if trimmed {
                let spacings = (LINE_GAP_TRIM * r / index.median_spacing()?).ceil();
                format!(", and --trim {spacings} keeps the trim from cutting between them")
            } else {
                String::new()
            };
            (
                format!("only {} away", three_digits(r)),
                format!("--kernel {} spans the gaps{trim}", three_digits(r / 2.0)),
            )
        }
        None => (
            format!("not among its {PLANE_RADIUS_MAX_NEIGHBOURS} nearest"),
            "a --kernel of half the distance between the lines spans the gaps".to_string(),
        ),
    };
    Ok(Some(format!(
        "note: the points lie in lines (or clumps) farther apart than the MLS kernel reaches \
         (h = {}, cut off at {}): the median point finds neighbours that span a plane {found}. \
         Between the lines the surface is guessed, with ridges along them; {advice}",
        three_digits(h),
        three_digits(reach)
    )))
}

/// The note for an untrimmed remesh with `open` open edges: the zero set ran out to the
/// grid's sides, past the border of an open mesh signed by its nearest piece.
fn mesh_grid_side_note(open: usize) -> String {
    format!(
        "note: the surface runs out to the sides of the grid ({open} open edges): the mesh \
         is open, and its distance keeps a side past its border. --trim cuts the surface \
         back to the mesh; --sign winding closes it where the mesh nearly encloses a solid"
    )
}

/// Arguments of `geosynth sdf`.
#[derive(Debug, Args)]
pub struct SdfArgs {
    /// A mesh (exact distances) or a point set (distances to its MLS surface): oriented, or
    /// bare with `--estimate-normals`.
    input: PathBuf,
    /// Output NRRD file.
    #[arg(short, long)]
    output: PathBuf,
    /// Also store the gradient (4 channels: distance, dx, dy, dz).
    #[arg(long)]
    gradient: bool,
    #[command(flatten)]
    grid: GridArgs,
    #[command(flatten)]
    normals: PointPrepArgs,
    #[command(flatten)]
    sign: SignArgs,
}

/// How `sdf` reads its input: the options its report records under [`INPUT_OPTIONS_KEY`],
/// so that `--params REPORT` reads it as the reported run did.
#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct SdfInputOptions {
    /// `--orient-faces` (meshes).
    orient_faces: bool,
    /// `--orient-normals`.
    orient_normals: bool,
    /// `--estimate-normals`, in neighbours (unset: the points' own normals).
    estimate_normals: Option<usize>,
    /// `--up`: where orienting or estimated normals are turned.
    up: UpArg,
    /// `--keep-strays`.
    keep_strays: bool,
}

impl RecordedInput for SdfInputOptions {
    fn check(&self) -> Result<(), String> {
        check_recorded_neighbours(self.estimate_normals)
    }
}

impl SdfInputOptions {
    /// The options given on the command line over those of `--params`' file.
    fn of(args: &SdfArgs, file: &ParamsFile) -> CliResult<Self> {
        let recorded: Self = file.input_options()?;
        let prep = args.normals.over(recorded.normals())?;
        Ok(Self {
            orient_faces: args.sign.orient_faces || recorded.orient_faces,
            orient_normals: prep.orient,
            estimate_normals: prep.estimate,
            up: prep.up,
            keep_strays: prep.keep_strays,
        })
    }

    /// What is done to a point set's normals.
    fn normals(&self) -> PointPrep {
        PointPrep {
            orient: self.orient_normals,
            estimate: self.estimate_normals,
            up: self.up,
            keep_strays: self.keep_strays,
        }
    }
}

/// Runs `geosynth sdf`.
pub fn run_sdf(args: &SdfArgs, given: GivenFlags, globals: Globals) -> CliResult {
    check_output_paths(
        [],
        std::iter::once(args.output.as_path()).chain(args.grid.other_outputs()),
    )?;
    let file = args.grid.params_file(SDF_REPORTS)?;
    let params = args.grid.params(&file, &args.sign, given)?;
    let options = SdfInputOptions::of(args, &file)?;
    let sign = SignArgs {
        orient_faces: options.orient_faces,
        ..args.sign
    };
    // Georeferenced inputs are sampled relative to an origin; the header's origin adds it.
    let mut preparing = Timings::new();
    let mut loaded = phases::timed(&mut preparing, READING, || {
        read_geometry(&args.input, globals)
    })?;
    report_not_kept(globals, &args.input, &loaded.notes);
    let mut left_out = LeftOut::default();
    loaded.geometry = phases::timed_rest(&mut preparing, PREPARING, |preparing| {
        CliResult::Ok(match loaded.geometry {
            io::Geometry::Points(read) => {
                let prepared = options.normals().prepared(
                    read,
                    params.kernel,
                    &args.input,
                    globals,
                    preparing,
                )?;
                if sign.orient_faces {
                    status(globals, no_faces_to_orient(&args.input));
                }
                if let Some(note) = line_gap_note(&prepared.index, params.kernel, false)? {
                    status(globals, note);
                }
                left_out = prepared.left_out;
                io::Geometry::Points(prepared.points)
            }
            io::Geometry::Mesh(mesh) => {
                options.normals().refuse_for_mesh(&args.input)?;
                let (mesh, change) = sign.oriented(mesh)?;
                if let Some(line) = change {
                    status(globals, line);
                }
                if let Some(note) = sign.note(&mesh, params.mesh_sign)? {
                    status(globals, note);
                }
                io::Geometry::Mesh(mesh)
            }
        })
    })?;
    check_grid_fits(&params, &loaded.geometry)?;
    let (mut ctx, bar) = progress_context(globals, 0, "sampling distances", false);
    for (stage, time) in preparing {
        ctx.record_timing(&stage, time);
    }
    let start = Instant::now();
    let sdf = signed_distance_in(&loaded.geometry, &params, &mut ctx)?;
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let offset = loaded.origin;
    ctx.timed(WRITING, |_| -> CliResult {
        if args.gradient {
            nrrd::write_file(&args.output, |f| nrrd::write_vec4_at(f, sdf.grid(), offset))?;
        } else {
            let distances = sdf.distances()?;
            nrrd::write_file(&args.output, |f| {
                nrrd::write_scalar_at(f, &distances, offset)
            })?;
        }
        Ok(())
    })?;
    let [x, y, z] = sdf.dims();
    write_report(
        &args.grid,
        "sdf",
        &params,
        options,
        json!({
            "input": args.input.display().to_string(),
            "output": args.output.display().to_string(),
            "gradient": args.gradient,
            "strays_left_out": left_out.strays,
            "isolated_left_out": left_out.isolated,
            "dims": sdf.dims(),
            "spacing": sdf.grid().spacing(),
            "band": sdf.band(),
            "seconds": seconds,
            "timings": timings_json(ctx.timings()),
        }),
    )?;
    status(
        globals,
        format!(
            "wrote {} ({x}x{y}x{z}, band {})",
            args.output.display(),
            sdf.band()
        ),
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{FieldParams, GRID_BYTES_PER_NODE, Geometry, check_grid_fits_in};

    #[test]
    fn a_grid_larger_than_the_memory_is_refused_with_a_resolution_that_fits() {
        let sphere = geosynth::fixtures::sphere_points(500).unwrap_or_else(|e| panic!("{e}"));
        let sphere = Geometry::Points(sphere);
        let params = FieldParams::default().resolution(512);
        let nodes = |p: &FieldParams| {
            let spec = p.grid_for(&sphere).unwrap_or_else(|e| panic!("{e}"));
            spec.dims.iter().map(|&d| d as u64).product::<u64>()
        };
        let needed = nodes(&params) * GRID_BYTES_PER_NODE;
        assert!(check_grid_fits_in(&params, &sphere, needed).is_ok());
        let available = needed / 10;
        let err = check_grid_fits_in(&params, &sphere, available)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            err.contains("resolution 512") && err.contains("GB"),
            "{err}"
        );
        // The resolution it names fits, and is not far below the largest that does.
        let fits: usize = err
            .rsplit("--resolution ")
            .next()
            .and_then(|w| w.split_whitespace().next())
            .and_then(|w| w.parse().ok())
            .unwrap_or(0);
        let at = |r: usize| nodes(&FieldParams::default().resolution(r)) * GRID_BYTES_PER_NODE;
        assert!(at(fits) <= available, "{fits}: {} > {available}", at(fits));
        assert!(at(fits * 11 / 10) > available, "{fits} is too cautious");
    }
}
