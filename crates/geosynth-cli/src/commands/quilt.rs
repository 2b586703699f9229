//! `geosynth quilt`: patch-based geometry texture synthesis (paper 000).

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, ValueEnum};
use geosynth::core::io::{FileFormat, Geometry, WriteOptions, XyzColumns};
use geosynth::core::{KdIndex, PointSet};
use geosynth::imagery::{GeoReference, check_heightfield_output, is_heightfield_path};
use geosynth::mls::Covariance;
use geosynth::preview::{self, Panel, RenderOptions, UpAxis as ViewUp};
use geosynth::quilt::{
    BlendCounts, DEFAULT_RELIEF, GeometryTexture, HeightFieldFrame, MAX_PLANE_SPREAD, Method,
    OutputSize, QualityMeasure, QualityReport, QuiltOutput, QuiltParams, TextureFile, UpAxis,
    WarpTargets, quilt, read_heightfield_texture_framed, read_texture_file,
    read_texture_file_fitted,
};
use geosynth::tps::{PairingParams, Table1Preset};
use glam::{DMat3, DVec3, Vec3};

use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use super::sheet_heights::{MapPlacement, write_sheet_heights};
use super::sheet_mesh::sheet_mesh;
use crate::input_file::named;
use crate::json_report::write_json_report;
use crate::output::{
    check_geometry_output, check_output_paths, progress_context, report_not_kept, spinner, status,
    write_geometry_file,
};
use crate::params_file::{
    GivenFlags, INPUT_OPTIONS_KEY, ParamsFile, QUILT_REPORTS, RecordedInput, check_positive,
};
use crate::{CliResult, Globals};

/// Which parts of the algorithm run.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum MethodArg {
    /// Search, warp, blend (the paper).
    Full,
    /// Best-matching patches pasted without warp or blend.
    Search,
    /// Random patches pasted (no search, warp or blend).
    Random,
}

impl From<MethodArg> for Method {
    fn from(m: MethodArg) -> Self {
        match m {
            MethodArg::Full => Method::Full,
            MethodArg::Search => Method::SearchOnly,
            MethodArg::Random => Method::RandomPlacement,
        }
    }
}

/// The up axis of an exemplar file, as a command-line value.
#[derive(Debug, Clone, Copy, ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TextureUpArg {
    /// +X is up: the reference plane is YZ.
    X,
    /// +Y is up: the reference plane is ZX (Blender's and most DCC tools' OBJ export).
    Y,
    /// +Z is up: the reference plane is XY (height fields, terrain).
    Z,
    /// The plane fitted to the points (a tilted scan): quilted in that plane's frame, the
    /// output turned back into the file's.
    Auto,
}

impl TextureUpArg {
    /// The axis, or `None` for a fitted plane.
    fn axis(self) -> Option<UpAxis> {
        match self {
            TextureUpArg::X => Some(UpAxis::X),
            TextureUpArg::Y => Some(UpAxis::Y),
            TextureUpArg::Z => Some(UpAxis::Z),
            TextureUpArg::Auto => None,
        }
    }
}

/// Where the warp sends paired points.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum WarpTargetsArg {
    /// Onto the paired neighbourhood point exactly (paper 000 §5.2; default).
    Exact,
    /// By the gap between the exemplar's and the neighbourhood's surfaces at the source
    /// (not in the paper): lower errors than exact targets on all four demo fixtures,
    /// most on thin tubes (docs/patch-quilt-studies.md).
    SurfaceGap,
}

impl From<WarpTargetsArg> for WarpTargets {
    fn from(t: WarpTargetsArg) -> Self {
        match t {
            WarpTargetsArg::Exact => WarpTargets::Exact,
            WarpTargetsArg::SurfaceGap => WarpTargets::SurfaceGap,
        }
    }
}

/// Table 1 weight presets.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum PresetArg {
    /// w_n 3, w_v 30, w_l 9, w_d 7.
    Heightfield,
    /// w_n 1, w_v 10, w_l 8, w_d 6.
    ChainMail,
    /// w_n 2, w_v 15, w_l 6, w_d 5.
    Weave,
    /// w_n 2, w_v 2, w_l 6, w_d 6.
    Flowers,
}

/// Arguments of `geosynth quilt`.
#[derive(Debug, Args)]
pub struct QuiltArgs {
    /// Geometry texture: an oriented point set whose comments give `texture_box` and
    /// `texture_up` (as `geosynth fixtures` writes them); otherwise the box is the points'
    /// box inset by a sixth on every side across the reference plane (one sample spacing
    /// thick for a flat file). A mesh gets normals from its faces; a point set without
    /// normals needs them first (`geosynth normals`).
    #[arg(required_unless_present = "heightfield")]
    exemplar: Option<PathBuf>,
    /// Use a height field instead (PNG 8/16-bit, raw `name_WxH.f32le`, a raw file with an
    /// ENVI header beside it, as GDAL writes them: `.f32le`, `.bil`, `.img`, … of any
    /// numeric type, or a one-band TIFF such as a GeoTIFF DEM): sampled as points spanning
    /// 4 units along its longer side, the outer sixth of the samples on every side as
    /// padding (so the box is about two thirds of that), heights scaled by `--relief`.
    #[arg(long, conflicts_with = "exemplar")]
    heightfield: Option<PathBuf>,
    /// With `--heightfield`: the height range as a fraction of the samples' longer extent
    /// (default 0.1, a relief of 0.4 over 4 units). A file's heights rarely share its
    /// spacing's unit, so this is the one shape parameter it does not carry.
    #[arg(long, conflicts_with = "exemplar")]
    relief: Option<f32>,
    /// The exemplar file's up axis when it has no `texture_up` comment (default z), or
    /// `auto` to fit the reference plane to the points; a file whose comments name another
    /// axis (or any, with `auto`) is refused.
    #[arg(long, value_enum, conflicts_with = "heightfield")]
    up: Option<TextureUpArg>,
    /// Output point set (.ply, .obj, .off).
    #[arg(short, long)]
    output: PathBuf,
    /// Read the parameters from JSON: any of the library's `QuiltParams` fields (as the
    /// report's `params` spells them: `{"epsilon": 0.3, "clusters": {"max_points": 4}}`),
    /// or a report written by `--report`, to run it again (its `input_options` read the
    /// exemplar the same way: `--up`, `--relief`, `--orient-normals`). Fields it leaves out
    /// keep their defaults; the flags given here override it.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Output width and depth in world units, `W,H`.
    #[arg(long, value_parser = parse_size, conflicts_with = "scale")]
    size: Option<(f32, f32)>,
    /// Output extent as a multiple of the exemplar's box (default 2).
    #[arg(long)]
    scale: Option<f32>,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Which parts of the algorithm run.
    #[arg(long, value_enum, default_value_t = MethodArg::Full)]
    method: MethodArg,
    /// Pairing weights of a Table 1 row (default: height field).
    #[arg(long, value_enum)]
    preset: Option<PresetArg>,
    /// Nodes of the exemplar's distance field along its longer side.
    #[arg(long, default_value_t = QuiltParams::default().field_resolution)]
    resolution: usize,
    /// Patch size as a fraction of the exemplar box's smaller side; at least 3 spacings of
    /// the distance field (`--resolution`).
    #[arg(long, default_value_t = QuiltParams::default().patch_size)]
    patch: f32,
    /// Relative tolerance `ε` of the search: every patch within `(1 + ε)` of the best match
    /// is a candidate (larger: more variety, looser seams).
    #[arg(long, default_value_t = QuiltParams::default().epsilon)]
    epsilon: f32,
    /// Largest pair length of the warp, in distance-field spacings (0.25 measured better on
    /// rough, noisy images read as height fields, such as bark or brick photographs, and
    /// worse on smooth terrain: docs/patch-quilt-studies.md).
    #[arg(long, default_value_t = QuiltParams::default().pair_distance)]
    pair_distance: f32,
    /// Where the warp sends paired points.
    #[arg(long, value_enum, default_value_t = WarpTargetsArg::Exact)]
    warp_targets: WarpTargetsArg,
    /// Smoothing λ of the warp's spline, relative to the patch size (0 = interpolate).
    #[arg(long, default_value_t = QuiltParams::default().smoothing)]
    smoothing: f32,
    /// Largest gap the blend closes, as a fraction of the MLS support radius; points facing
    /// farther geometry are left as they are.
    #[arg(long, default_value_t = QuiltParams::default().blend_reach)]
    blend_reach: f32,
    /// Smallest cosine between a point's normal and the surface's where its gap ends, for
    /// the blend (and surface-gap targets) to close it; -1 turns the test off.
    #[arg(
        long,
        default_value_t = QuiltParams::default().normal_agreement,
        allow_negative_numbers = true
    )]
    normal_agreement: f32,
    /// Most points per cluster of the warp's targets (fewer points: more targets, a warp
    /// that follows the seam's misfit more finely; 4 measured better on height fields).
    #[arg(long, default_value_t = QuiltParams::default().clusters.max_points)]
    cluster_points: usize,
    /// Relaxation rounds after synthesis (at most 100).
    #[arg(long, default_value_t = QuiltParams::default().relaxation_rounds)]
    relax: usize,
    /// Write a JSON report (timings, counts, quality).
    #[arg(long)]
    report: Option<PathBuf>,
    /// Also run and measure the random-placement and search-only baselines, and (for the
    /// full method) its own patches pasted without warp or blend. Their errors are
    /// summarised under the run's own line; `--report` also gets their counts and timings.
    /// Without `--report` they need the summary: refused with `--no-quality` or `--quiet`.
    #[arg(long)]
    baselines: bool,
    /// Render exemplar | output to a PNG.
    #[arg(long)]
    preview: Option<PathBuf>,
    /// Also write the output as a mesh (.ply, .obj, .off, .stl), as `geosynth reconstruct
    /// --trim` makes one: its MLS surface on a grid of one node per two median sample
    /// spacings (32 to 512 along the longest side), cut back to the points.
    #[arg(long, value_name = "MESH")]
    mesh: Option<PathBuf>,
    /// Also write the output as a height map (.png, .f32le or .tif): its top surface
    /// sampled straight down. A raw file keeps every height and gets `_WxH` in its name;
    /// a .tif keeps every height as 32-bit floats. With `--heightfield`, on the input's
    /// sample spacing and in its height units, a PNG's grey levels 0..1 as the input's
    /// were read (beyond that clamped). From a point set,
    /// on a grid as dense as its points (or `--map-spacing`), heights in the file's
    /// coordinates along the up axis, a PNG's grey levels spanning the map's own range;
    /// the report says where the grid lies in the file and what the grey levels mean.
    /// Beside it, for GDAL and QGIS: a raw map's ENVI header (MAP.f32le.hdr); a point
    /// set's PNG's grey scale (MAP.png.aux.xml); and where the grid runs along x and y
    /// with z up (`--up z`), its place in the file (the header's map info, MAP.pgw). A
    /// .tif is a GeoTIFF holding that place itself; from a GeoTIFF DEM, it lies on the
    /// DEM's grid and in its coordinate system, from the DEM's top-left corner on.
    #[arg(long, value_name = "MAP")]
    heightfield_out: Option<PathBuf>,
    /// The grid spacing of a point-set exemplar's `--heightfield-out` map, in the file's
    /// length units (default: one over the square root of its points per unit area, the
    /// spacing of a grid with as many samples).
    #[arg(long, value_name = "S")]
    map_spacing: Option<f32>,
    /// The heights a point-set exemplar's `--heightfield-out` PNG stores as grey 0 and
    /// 65535, in the file's length units (default: the map's own range). Fixed, several
    /// runs' PNGs share one scale; heights beyond are clamped and counted.
    #[arg(long, value_name = "LO,HI", value_parser = parse_height_range)]
    map_range: Option<(f32, f32)>,
    /// Skip the quality measure: it builds distance fields of the exemplar and of every
    /// output and can take longer than the synthesis (a 70k → 200k chain mail takes about
    /// 6 s with it, 3 s without). The report then says why its quality is missing.
    #[arg(long)]
    no_quality: bool,
    /// Make the exemplar's normal signs consistent by propagation from the side facing up
    /// before quilting (for normals estimated without orientation); unreliable on
    /// interlinked thin tubes (docs/mls-surface.md).
    #[arg(long)]
    orient_normals: bool,
}

fn parse_size(s: &str) -> Result<(f32, f32), String> {
    match super::comma_values(s, "W,H")? {
        [w, h] if w > 0.0 && h > 0.0 => Ok((w, h)),
        _ => Err(format!("`{s}` needs two positive numbers W,H")),
    }
}

fn parse_height_range(s: &str) -> Result<(f32, f32), String> {
    match super::comma_values(s, "LO,HI")? {
        [lo, hi] if f32::is_finite(lo) && f32::is_finite(hi) && lo < hi => Ok((lo, hi)),
        _ => Err(format!("`{s}` needs two finite heights LO,HI with LO < HI")),
    }
}

/// A hint when the exemplar looks stood on its side: its samples reach further along the
/// up axis than across the narrower side of the plane, which a texture rarely does and a
/// Y-up file read as Z-up always does.
fn orientation_note(texture: &GeometryTexture) -> Option<String> {
    let extent = texture
        .canonical_points()
        .bounding_box()
        .map(|b| b.extent())?;
    (extent.z > extent.x.min(extent.y)).then(|| {
        format!(
            "note: the exemplar is taller along its up axis ({:?}) than it is wide; if its \
             file was written with another up axis, pass --up x|y|z (or --up auto)",
            texture.up()
        )
    })
}

/// Tilts of the points' best plane against the reference plane above this (degrees) get a
/// note suggesting `--up auto`.
const TILT_NOTE_DEGREES: f64 = 15.0;

/// A hint when the exemplar's points lie in a plane tilted against its reference plane (a
/// scan of a sloping wall read with an axis): the angle between the plane fitted to them
/// and the up axis, when they have a dominant plane and it exceeds
/// [`TILT_NOTE_DEGREES`]. `None` for a fitted frame, which is the plane itself.
fn tilt_note(file: &TextureFile) -> Option<String> {
    if file.frame != DMat3::IDENTITY {
        return None;
    }
    let points = file.texture.canonical_points().positions();
    let fit = Covariance::of(points, 0..points.len())?;
    let [across, narrow, _] = fit.eigenvalues;
    let normal = fit.eigenvectors[0].as_dvec3();
    let tilt = normal.dot(DVec3::Z).abs().min(1.0).acos().to_degrees();
    (across <= MAX_PLANE_SPREAD * narrow && tilt > TILT_NOTE_DEGREES).then(|| {
        format!(
            "note: the exemplar's points lie in a plane tilted {tilt:.0}° from its reference \
             plane; --up auto quilts it in that plane"
        )
    })
}

/// A note when the exemplar file stored coordinates far from the origin in single
/// precision, on a grid coarser than a hundredth of its sample spacing (georeferenced data
/// written as `float`: at 4e6 the values are 0.25 apart). Reading in double precision
/// cannot restore that; `None` when it is fine or its spacing cannot be estimated.
fn precision_note(file: &TextureFile) -> Option<String> {
    let step = file.single_precision_step?;
    let points = file.texture.canonical_points().positions();
    let spacing = f64::from(KdIndex::new(points).ok()?.median_spacing().ok()?);
    super::single_precision_note(file.origin, step, spacing, "its sample spacing")
}

/// Expected output sizes above this many points get a note before the run starts.
const LARGE_OUTPUT_POINTS: f64 = 1.0e6;

/// A note when the output will be large (more than [`LARGE_OUTPUT_POINTS`] points at the
/// exemplar's density, [`GeometryTexture::expected_output_points`]): such runs take
/// minutes (the warp's spline systems grow with the exemplar's density, so the time grows
/// faster than the output), and on sparse exemplars the measure, which is on by default, can take longer
/// than the synthesis.
fn size_note(texture: &GeometryTexture, params: &QuiltParams) -> Option<String> {
    let expected = texture.expected_output_points(params.output);
    (expected > LARGE_OUTPUT_POINTS).then(|| {
        format!(
            "note: about {:.1} million output points expected; runs this large take minutes, \
             and the time grows faster than the output (on 2 cores, without the quality \
             measure: a 1024 × 1024 image read as a height field, 1.9 million points in \
             about 53 s; a 2048 × 2048 one, 7.4 million, in about 10 minutes and 1.8 GB of \
             memory). --scale or --size make the output smaller; --no-quality skips the \
             measure",
            expected / 1.0e6
        )
    })
}

/// How the exemplar is read: the options a report records under
/// [`INPUT_OPTIONS_KEY`], so that `--params REPORT` reads it as the reported run did.
#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct InputOptions {
    /// `--up` (unset: the file's `texture_up` comment, or z).
    up: Option<TextureUpArg>,
    /// `--relief`, for height fields (unset: [`DEFAULT_RELIEF`]).
    relief: Option<f32>,
    /// `--orient-normals`.
    orient_normals: bool,
}

impl RecordedInput for InputOptions {
    fn check(&self) -> Result<(), String> {
        check_positive("relief", self.relief, "fraction")
    }
}

impl InputOptions {
    /// The options given on the command line over those of `--params`' file; the relief
    /// written out for a height field and dropped otherwise, like the axis for one.
    fn of(args: &QuiltArgs, file: &ParamsFile) -> CliResult<Self> {
        let recorded: Self = file.input_options()?;
        let heightfield = args.heightfield.is_some();
        Ok(Self {
            up: args.up.or(recorded.up).filter(|_| !heightfield),
            relief: heightfield.then(|| args.relief.or(recorded.relief).unwrap_or(DEFAULT_RELIEF)),
            orient_normals: args.orient_normals || recorded.orient_normals,
        })
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

/// Loads the texture named by the arguments as `options` say (a height field is at the
/// origin), its normals oriented if asked, and for a height field where its samples were
/// placed.
fn load(
    args: &QuiltArgs,
    options: &InputOptions,
) -> CliResult<(TextureFile, Option<HeightFieldFrame>)> {
    let (mut file, frame) = read_texture(args, options)?;
    if options.orient_normals {
        file.texture = file.texture.with_oriented_normals()?;
    }
    Ok((file, frame))
}

/// Reads the texture named by the arguments with the axis or relief of `options`, and for
/// a height field where its samples were placed.
fn read_texture(
    args: &QuiltArgs,
    options: &InputOptions,
) -> CliResult<(TextureFile, Option<HeightFieldFrame>)> {
    if let Some(path) = &args.heightfield {
        let relief = options.relief.unwrap_or(DEFAULT_RELIEF);
        let (texture, frame) =
            read_heightfield_texture_framed(path, relief).map_err(named(path))?;
        return Ok((texture.into(), Some(frame)));
    }
    let path = args
        .exemplar
        .as_deref()
        .ok_or("an exemplar or --heightfield is needed")?;
    let file = match options.up {
        Some(TextureUpArg::Auto) => read_texture_file_fitted(path),
        up => read_texture_file(path, up.and_then(TextureUpArg::axis)),
    }
    .map_err(named(path))?;
    Ok((file, None))
}

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
    fn measured(mut self, measure: &Measure<'_>, globals: Globals, label: &str) -> Self {
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

/// Renders exemplar | result panels (Z-up textures are viewed with Z up).
pub fn texture_preview(
    texture: &GeometryTexture,
    outputs: &[&QuiltOutput],
    path: &Path,
    w: u32,
    h: u32,
) -> CliResult {
    let up = match texture.up() {
        UpAxis::X | UpAxis::Y => ViewUp::Y,
        UpAxis::Z => ViewUp::Z,
    };
    let exemplar = Geometry::Points(texture.canonical_points().clone());
    let results: Vec<Geometry> = outputs
        .iter()
        .map(|o| Geometry::Points(o.points.clone()))
        .collect();
    let mut panels = vec![Panel::Geometry(&exemplar, ViewUp::Z)];
    panels.extend(results.iter().map(|g| Panel::Geometry(g, up)));
    let image = preview::render_panels(
        &panels,
        &RenderOptions::default().size(w, h).view(30.0, 40.0),
    )?;
    preview::save_png(&image, path)?;
    Ok(())
}

/// Writes the quilted points `points` (in the file's frame) as a mesh to `path`, with the
/// output's `options` (origin and comments); returns the report's `mesh` entry.
fn write_sheet_mesh(
    path: &Path,
    points: PointSet,
    options: &WriteOptions,
    globals: Globals,
) -> CliResult<Value> {
    let bar = spinner(globals, "meshing");
    let (mesh, resolution, seconds) = sheet_mesh(points)?;
    bar.finish_and_clear();
    write_geometry_file(path, &Geometry::Mesh(mesh.clone()), options)?;
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
    let (file, heightfield_frame) = load(args, &input_options)?;
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
    if let Some(placement) = &map_placement {
        let extent = file.texture.output_extent(params.output);
        placement.frame.map_size(extent)?;
    }
    let texture = &file.texture;
    // The hints about a file's up axis and its normals' orientation are for point-set
    // files: a height field's up axis is its own, its relief the one asked for, and its
    // normals its surface's, all facing up (rough terrain whose neighbouring normals tilt
    // apart is no sign of unoriented data).
    let from_points = heightfield_frame.is_none();
    for note in [
        from_points.then(|| orientation_note(texture)).flatten(),
        tilt_note(&file),
        precision_note(&file),
        from_points
            .then(|| super::unoriented_normals_note(texture.canonical_points(), Some(Vec3::Z)))
            .flatten(),
        size_note(texture, &params),
    ]
    .into_iter()
    .flatten()
    {
        status(globals, note);
    }
    // The output (and its preview) are written before it is measured: on large exemplars
    // the measure can take longer than the synthesis, and an interrupted measure must not
    // cost the result.
    let main = unmeasured_run(texture, &params, globals, "quilt")?;
    let mut comments = vec![format!(
        "quilted by geosynth (seed {}, {:?})",
        params.seed, params.method
    )];
    comments.extend(file.comments(&main.output.bounds));
    let mut options = WriteOptions::default().origin(file.origin);
    for c in comments {
        options = options.comment(c);
    }
    let written = Geometry::Points(file.to_file_frame(&main.output.points)?);
    write_geometry_file(&args.output, &written, &options)?;
    if let Some(path) = &args.preview {
        texture_preview(texture, &[&main.output], path, 480, 360)?;
    }
    // The written points, taken back for the mesh (no copy of them is made).
    let mesh = match (&args.mesh, written) {
        (Some(path), Geometry::Points(points)) => {
            Some(write_sheet_mesh(path, points, &options, globals)?)
        }
        _ => None,
    };
    let heightfield_out = match (&args.heightfield_out, map_placement) {
        (Some(path), Some(placement)) => {
            Some(write_sheet_heights(path, &main.output, placement, globals)?)
        }
        _ => None,
    };
    let measure = if args.no_quality {
        Err("skipped (--no-quality)".to_string())
    } else {
        measure_for(texture, &params, globals)
    };
    let main = main.measured(&measure, globals, "quilt");
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
            let run = measured_run(texture, &run_params, &measure, globals, label)?;
            compared.push((key, label, run_json(&run), run.quality));
        }
    }
    if let Some(path) = &args.report {
        let mut report = json!({
            "exemplar": args.exemplar.as_ref().or(args.heightfield.as_ref())
                .map(|path| path.display().to_string()),
            INPUT_OPTIONS_KEY: input_options,
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

#[cfg(test)]
mod tests {
    use super::*;
    use geosynth::core::HeightField;

    /// A 40 × 40 height field 0.1 apart (about 107 samples per unit area in its box).
    fn small_texture() -> GeometryTexture {
        let heights = (0..1600).map(|i| (i % 7) as f32 * 0.01).collect();
        let field = HeightField::new(40, 40, heights).unwrap_or_else(|e| panic!("{e}"));
        GeometryTexture::from_heightfield(&field, 0.1, 1.0, 4).unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn large_outputs_get_a_note_before_the_run() {
        let texture = small_texture();
        let params = QuiltParams::default();
        assert_eq!(size_note(&texture, &params), None, "a 2 × 2 quilt is small");
        // 100 × 100 at about 107 samples per unit area: about 1.07 million points.
        let large = params.output(OutputSize::Absolute(100.0, 100.0));
        let note = size_note(&texture, &large).unwrap_or_default();
        assert!(note.contains("about 1.1 million output points"), "{note}");
        assert!(note.contains("--no-quality"), "{note}");
    }
}
