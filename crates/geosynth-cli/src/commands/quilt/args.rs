//! The command line of `geosynth quilt`: its flags and the values they take.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use geosynth::quilt::{Method, QuiltParams, UpAxis, WarpTargets};
use serde::{Deserialize, Serialize};

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
    pub(super) fn axis(self) -> Option<UpAxis> {
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
    /// normals needs `--estimate-normals` (or `geosynth normals` first).
    #[arg(required_unless_present = "heightfield")]
    pub(super) exemplar: Option<PathBuf>,
    /// Use a height field instead (PNG 8/16-bit, raw `name_WxH.f32le`, a raw file with an
    /// ENVI header beside it, as GDAL writes them: `.f32le`, `.bil`, `.img`, … of any
    /// numeric type, or a one-band TIFF such as a GeoTIFF DEM): sampled as points spanning
    /// 4 units along its longer side, the outer sixth of the samples on every side as
    /// padding (so the box is about two thirds of that), heights scaled by `--relief`.
    #[arg(long, conflicts_with = "exemplar")]
    pub(super) heightfield: Option<PathBuf>,
    /// With `--heightfield`: the height range as a fraction of the samples' longer extent
    /// (default 0.1, a relief of 0.4 over 4 units). A file's heights rarely share its
    /// spacing's unit, so this is the one shape parameter it does not carry.
    #[arg(long, conflicts_with = "exemplar")]
    pub(super) relief: Option<f32>,
    /// With `--heightfield`: fill the file's voids (samples on its no-data value, or NaN,
    /// which are refused otherwise) with the smooth surface the heights around them bound,
    /// each the mean of its neighbours, before quilting; `geosynth info` counts them
    #[arg(long, conflicts_with = "exemplar")]
    pub(super) fill_voids: bool,
    /// The exemplar file's up axis when it has no `texture_up` comment (default z), or
    /// `auto` to fit the reference plane to the points; a file whose comments name another
    /// axis (or any, with `auto`) is refused.
    #[arg(long, value_enum, conflicts_with = "heightfield")]
    pub(super) up: Option<TextureUpArg>,
    /// The exemplar's box `B_Tin` (paper §3), its corners in the file's coordinates:
    /// the part of the points that is the texture, the rest across the reference plane
    /// being padding. Replaces a `texture_box` comment and the default box (useful for
    /// files that carry no comments, such as XYZ and LAS scans). Not with `--up auto` (the
    /// fitted plane's box is not aligned with the file's axes) or a height field.
    #[arg(
        long = "box",
        value_name = "X0,Y0,Z0,X1,Y1,Z1",
        value_parser = parse_box,
        conflicts_with = "heightfield"
    )]
    pub(super) bounds: Option<[f64; 6]>,
    /// Keep a point-set exemplar's stray and isolated points. By default the points far
    /// outside the rest (beyond twice the span of the middle 99% of the points' coordinates
    /// on some axis, such as a scan's outliers) are left out of the default box, which
    /// would span them, and points with fewer than 3 others within twice the MLS kernel's
    /// reach (floating specks, which the exemplar's surface would close into bubbles) are
    /// left out under any box, with a note. A `texture_box` comment or `--box` does not
    /// stretch to far points, so none is left out as stray there (a lone one is still
    /// isolated); a fitted plane (`--up auto`) always leaves both out.
    #[arg(long, conflicts_with = "heightfield")]
    pub(super) keep_strays: bool,
    /// Output point set (.ply, .obj, .off, .pcd, .glb, .gltf, .xyz or .xyzn).
    #[arg(short, long)]
    pub(super) output: PathBuf,
    /// Read the parameters from JSON: any of the library's `QuiltParams` fields (as the
    /// report's `params` spells them: `{"epsilon": 0.3, "clusters": {"max_points": 4}}`),
    /// or a report written by `--report`, to run it again (its `input_options` read the
    /// exemplar the same way: `--up`, `--relief`, `--orient-normals`). Fields it leaves out
    /// keep their defaults; the flags given here override it.
    #[arg(long, value_name = "FILE")]
    pub(super) params: Option<PathBuf>,
    /// Output width and depth in world units, `W,H`.
    #[arg(long, value_parser = parse_size, conflicts_with = "scale")]
    pub(super) size: Option<(f32, f32)>,
    /// Output extent as a multiple of the exemplar's box (default 2).
    #[arg(long)]
    pub(super) scale: Option<f32>,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 0)]
    pub(super) seed: u64,
    /// Which parts of the algorithm run.
    #[arg(long, value_enum, default_value_t = MethodArg::Full)]
    pub(super) method: MethodArg,
    /// Pairing weights of a Table 1 row (default: height field).
    #[arg(long, value_enum)]
    pub(super) preset: Option<PresetArg>,
    /// Nodes of the exemplar's distance field along its longer side.
    #[arg(long, default_value_t = QuiltParams::default().field_resolution)]
    pub(super) resolution: usize,
    /// Patch size as a fraction of the exemplar box's smaller side; at least 3 spacings of
    /// the distance field (`--resolution`).
    #[arg(long, default_value_t = QuiltParams::default().patch_size)]
    pub(super) patch: f32,
    /// Relative tolerance `ε` of the search: every patch within `(1 + ε)` of the best match
    /// is a candidate (larger: more variety, looser seams).
    #[arg(long, default_value_t = QuiltParams::default().epsilon)]
    pub(super) epsilon: f32,
    /// Largest pair length of the warp, in distance-field spacings (0.25 measured better on
    /// rough, noisy images read as height fields, such as bark or brick photographs, and
    /// worse on smooth terrain: docs/patch-quilt-studies.md).
    #[arg(long, default_value_t = QuiltParams::default().pair_distance)]
    pub(super) pair_distance: f32,
    /// Where the warp sends paired points.
    #[arg(long, value_enum, default_value_t = WarpTargetsArg::Exact)]
    pub(super) warp_targets: WarpTargetsArg,
    /// Smoothing λ of the warp's spline, relative to the patch size (0 = interpolate).
    #[arg(long, default_value_t = QuiltParams::default().smoothing)]
    pub(super) smoothing: f32,
    /// Largest gap the blend closes, as a fraction of the MLS support radius; points facing
    /// farther geometry are left as they are.
    #[arg(long, default_value_t = QuiltParams::default().blend_reach)]
    pub(super) blend_reach: f32,
    /// Smallest cosine between a point's normal and the surface's where its gap ends, for
    /// the blend (and surface-gap targets) to close it; -1 turns the test off.
    #[arg(
        long,
        default_value_t = QuiltParams::default().normal_agreement,
        allow_negative_numbers = true
    )]
    pub(super) normal_agreement: f32,
    /// Most points per cluster of the warp's targets (fewer points: more targets, a warp
    /// that follows the seam's misfit more finely; 4 measured better on height fields).
    #[arg(long, default_value_t = QuiltParams::default().clusters.max_points)]
    pub(super) cluster_points: usize,
    /// Relaxation rounds after synthesis (at most 100).
    #[arg(long, default_value_t = QuiltParams::default().relaxation_rounds)]
    pub(super) relax: usize,
    /// Write a JSON report (timings, counts, quality).
    #[arg(long)]
    pub(super) report: Option<PathBuf>,
    /// Also run and measure the random-placement and search-only baselines, and (for the
    /// full method) its own patches pasted without warp or blend. Their errors are
    /// summarised under the run's own line; `--report` also gets their counts and timings.
    /// Without `--report` they need the summary: refused with `--no-quality` or `--quiet`.
    #[arg(long)]
    pub(super) baselines: bool,
    /// Render exemplar | output to a PNG, both at one scale (the larger fills its panel),
    /// so their features are drawn the same size.
    #[arg(long)]
    pub(super) preview: Option<PathBuf>,
    /// Also write the output as a mesh (.ply, .obj, .off, .stl), as `geosynth reconstruct
    /// --trim` makes one: its MLS surface on a grid of one node per two median sample
    /// spacings (32 to 512 along the longest side), cut back to the points.
    #[arg(long, value_name = "MESH")]
    pub(super) mesh: Option<PathBuf>,
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
    pub(super) heightfield_out: Option<PathBuf>,
    /// The grid spacing of a point-set exemplar's `--heightfield-out` map, in the file's
    /// length units (default: one over the square root of its points per unit area, the
    /// spacing of a grid with as many samples).
    #[arg(long, value_name = "S")]
    pub(super) map_spacing: Option<f32>,
    /// The heights a point-set exemplar's `--heightfield-out` PNG stores as grey 0 and
    /// 65535, in the file's length units (default: the map's own range). Fixed, several
    /// runs' PNGs share one scale; heights beyond are clamped and counted.
    #[arg(long, value_name = "LO,HI", value_parser = parse_height_range)]
    pub(super) map_range: Option<(f32, f32)>,
    /// Skip the quality measure: it builds distance fields of the exemplar and of every
    /// output and can take longer than the synthesis (a 70k → 200k chain mail takes about
    /// 5 s with it, 2.4 s without). The report then says why its quality is missing.
    #[arg(long)]
    pub(super) no_quality: bool,
    /// Make the exemplar's normal signs consistent by propagation from the side facing up
    /// before quilting (for normals estimated without orientation); unreliable on
    /// interlinked thin tubes (docs/mls-surface.md).
    #[arg(long, conflicts_with = "estimate_normals")]
    pub(super) orient_normals: bool,
    /// Estimate the exemplar's normals first, as `geosynth normals` does: fitted to each
    /// point's K nearest neighbours (`--estimate-normals` alone: 12) and oriented by
    /// propagation toward the texture's up side (with `--up auto`, the side of the fitted
    /// plane facing +Z); for bare scans (XYZ files of positions), replacing any normals
    /// the points have. Reliable on sheets such as terrain, not on interlinked thin tubes
    /// (docs/mls-surface.md). Not for meshes or height fields, whose normals come from
    /// their surfaces.
    #[arg(
        long,
        value_name = "K",
        num_args = 0..=1,
        default_missing_value = "12",
        value_parser = crate::commands::normals::parse_neighbours,
        conflicts_with = "heightfield"
    )]
    pub(super) estimate_normals: Option<usize>,
    /// Quilt points sampled on a mesh exemplar's surface instead of its vertices: about N,
    /// as a Poisson disk, with the faces' normals, seed 0 whatever --seed (`--sample`
    /// alone: 20,000, about the bundled fixtures' size). For meshes whose triangles are
    /// large for the spacing of their vertices (boxes on a plane, a low-poly tile), which
    /// the vertices undersample. Not for point sets or height fields.
    #[arg(
        long,
        value_name = "N",
        num_args = 0..=1,
        default_missing_value = "20000",
        value_parser = parse_sample_count,
        conflicts_with = "heightfield"
    )]
    pub(super) sample: Option<usize>,
}

/// Parses `--sample N`: a positive count.
fn parse_sample_count(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(format!("`{s}` is not a positive whole number of points")),
    }
}

/// Parses `--size W,H`: two positive numbers.
fn parse_size(s: &str) -> Result<(f32, f32), String> {
    match crate::commands::comma_values(s, "W,H")? {
        [w, h] if w > 0.0 && h > 0.0 => Ok((w, h)),
        _ => Err(format!("`{s}` needs two positive numbers W,H")),
    }
}

/// Parses `--box X0,Y0,Z0,X1,Y1,Z1`: six finite numbers, each lower corner's below the
/// upper one's.
fn parse_box(s: &str) -> Result<[f64; 6], String> {
    let v: [f64; 6] = crate::commands::comma_values(s, "X0,Y0,Z0,X1,Y1,Z1")?;
    if box_is_ordered(&v) {
        Ok(v)
    } else {
        Err(format!(
            "`{s}` needs six finite numbers X0,Y0,Z0,X1,Y1,Z1 with each of X0, Y0, Z0 below \
             X1, Y1, Z1"
        ))
    }
}

/// Whether the corners `X0,Y0,Z0,X1,Y1,Z1` are finite, each lower one below the upper.
pub(super) fn box_is_ordered(corners: &[f64; 6]) -> bool {
    corners.iter().all(|x| x.is_finite()) && (0..3).all(|i| corners[i] < corners[i + 3])
}

/// Parses `--map-range LO,HI`: two finite heights, LO below HI.
fn parse_height_range(s: &str) -> Result<(f32, f32), String> {
    match crate::commands::comma_values(s, "LO,HI")? {
        [lo, hi] if f32::is_finite(lo) && f32::is_finite(hi) && lo < hi => Ok((lo, hi)),
        _ => Err(format!("`{s}` needs two finite heights LO,HI with LO < HI")),
    }
}
