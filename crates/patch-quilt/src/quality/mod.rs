//! Objective quality of a quilt (GUIDE §5): neighbourhood error, seams, coverage.
//!
//! Windows are `w × w × n_z` blocks of distance-field nodes (`w` = half a patch, full
//! height) with the spacing of `D(T_in)`. The output's field is computed from the output's
//! own MLS surface over the output box. A window's error is the mean squared difference of
//! the signed distance to its nearest exemplar window — at any position, not only at the
//! nodes of `D(T_in)` ([`windows`]); errors are divided by the exemplar's typical window
//! variation — the mean difference between random non-overlapping exemplar windows — so 0
//! means "exactly like some part of the exemplar" and 1 means "as different as two unrelated
//! parts of it".

pub mod windows;

use distance_field::GridSpec;
use glam::{Vec2, Vec3};
use mls_surface::MlsSurface;
use pointset_core::rng::{self, SeededRng};
use pointset_core::{KdIndex, RunContext};
use rand::RngExt;
use rayon::prelude::*;

use crate::error::{Result, invalid};
use crate::exemplar::{ExemplarFrame, texture_field, texture_mls_params};
use crate::params::QuiltParams;
use crate::quilt::{Placement, QuiltOutput};
use crate::texture::GeometryTexture;
use windows::{ExemplarWindows, Field};

/// At or below this mean squared difference between its windows, in squared field
/// spacings (an rms difference of a thousandth of a spacing), an exemplar counts as
/// featureless: [`QualityReport::featureless_exemplar`].
pub const FEATURELESS_VARIATION: f32 = 1e-6;

/// The measured quality of one output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QualityReport {
    /// Mean normalized nearest-window error over random output windows.
    pub neighbourhood_error: f32,
    /// The same over windows centred on seams (within half an overlap of a patch boundary).
    pub seam_error: f32,
    /// The same over windows centred well inside patches (a quarter patch from any seam).
    pub interior_error: f32,
    /// `seam_error / interior_error`: how much the error concentrates at patch boundaries
    /// (GUIDE §5's "error concentrated at patch boundaries versus interiors"); 1 = none.
    pub seam_concentration: f32,
    /// Fraction of output points that are exact translated copies of exemplar points (within
    /// 1e-5 of an exemplar point after undoing their patch's translation) — GUIDE §5's
    /// verbatim copying: a tiled copy scores 1, and a low error with a high fraction means
    /// the output was copied rather than synthesized.
    pub verbatim_fraction: f32,
    /// Fraction of seams between neighbouring patches (left–right and below–above) whose
    /// sources continue each other in the exemplar: the second patch is the exemplar region
    /// right next to the first, so the two copy one larger intact region and their seam is
    /// invisible (GUIDE §5, "large intact exemplar regions"). On near-periodic exemplars the
    /// search finds such continuations often, which is why pasting scores so well there.
    pub continued_seams: f32,
    /// The exemplar's typical window difference used for normalization.
    pub exemplar_window_variation: f32,
    /// The exemplar has no relief: its windows are all alike (`exemplar_window_variation`
    /// at most [`FEATURELESS_VARIATION`] squared field spacings, as for a plane sampled on
    /// a grid). The three errors are then rounding noise divided by rounding noise and say
    /// nothing; the coverage fields still hold.
    pub featureless_exemplar: bool,
    /// Radius of the largest disc inside the output box free of the output's points
    /// (projected on the reference plane).
    pub largest_empty_disc: f32,
    /// The same for the exemplar's points and box.
    pub exemplar_largest_empty_disc: f32,
    /// Random windows measured for `neighbourhood_error` (the number asked for).
    pub windows: usize,
    /// Seam windows found for `seam_error`: up to `windows`, fewer when the output has few
    /// seams, none for a single patch (whose `seam_error` is then 0).
    pub seam_windows: usize,
    /// Interior windows found for `interior_error`: up to `windows`, fewer when the patches
    /// leave little room a quarter patch away from every seam.
    pub interior_windows: usize,
}

/// Radius of the largest disc inside `[lo, hi]` that contains none of the points' (x, y),
/// its centre sampled on a lattice of step `step`. Requiring the disc to lie inside the box
/// measures an exemplar (whose padding continues beyond its box) and a trimmed output alike:
/// where a box edge cuts the sampling, the disc is bounded by the edge, not by points beyond.
fn largest_empty_disc(points: &[Vec3], lo: Vec2, hi: Vec2, step: f32) -> Result<f32> {
    let flat: Vec<Vec3> = points.iter().map(|p| p.truncate().extend(0.0)).collect();
    let index = KdIndex::new(&flat)?;
    let n = ((hi - lo) / step).ceil().as_uvec2();
    let cells: Vec<Vec3> = (0..n.y)
        .flat_map(|j| {
            (0..n.x)
                .map(move |i| (lo + Vec2::new(i as f32 + 0.5, j as f32 + 0.5) * step).extend(0.0))
        })
        .collect();
    let radius = cells
        .par_iter()
        .map(|q| {
            let to_edge = (q.truncate() - lo).min(hi - q.truncate()).min_element();
            index
                .nearest_one(*q)
                .ok()
                .flatten()
                .map_or(0.0, |n| n.distance_squared.sqrt().min(to_edge))
        })
        .reduce(|| 0.0f32, f32::max);
    Ok(radius)
}

/// Fraction of neighbouring patch pairs whose sources (node offsets in `D(T_in)`) differ by
/// exactly the layout step (`step_nodes` along the pair's axis, 0 across it).
fn continued_seams(placements: &[Placement], step_nodes: usize) -> f32 {
    let source_at: std::collections::HashMap<(usize, usize), (usize, usize)> =
        placements.iter().map(|p| (p.cell, p.source)).collect();
    let (mut pairs, mut continued) = (0usize, 0usize);
    for p in placements {
        let (col, row) = p.cell;
        let (i, j) = p.source;
        let neighbours = [
            ((col + 1, row), (i + step_nodes, j)),
            ((col, row + 1), (i, j + step_nodes)),
        ];
        for (cell, continuation) in neighbours {
            if let Some(&source) = source_at.get(&cell) {
                pairs += 1;
                continued += usize::from(source == continuation);
            }
        }
    }
    continued as f32 / pairs.max(1) as f32
}

/// Measures `output` against `texture` (the parameters must be those of the run) with
/// `windows` random windows per class. Errors: `windows` = 0, an output smaller than one
/// window (half a patch) along either side, and whatever rebuilding the exemplar or the
/// output's surface fails on. For an exemplar without relief the errors say nothing
/// ([`QualityReport::featureless_exemplar`]).
///
/// This rebuilds the exemplar's side of the measure on every call; to measure several
/// outputs of one exemplar (methods, baselines, parameter sweeps), build a
/// [`QualityMeasure`] once instead.
pub fn evaluate(
    texture: &GeometryTexture,
    output: &QuiltOutput,
    params: &QuiltParams,
    windows: usize,
) -> Result<QualityReport> {
    QualityMeasure::new(texture, params)?.evaluate(output, windows)
}

/// The exemplar's side of the quality measure — its MLS surface, `D(T_in)` and the finely
/// sampled signed distance the nearest windows are searched in — built once and reused for
/// every output measured against it. Measuring with it gives exactly what [`evaluate`]
/// gives.
///
/// ```
/// use patch_quilt::{GeometryTexture, Method, QualityMeasure, QuiltParams, quilt};
/// use pointset_core::{HeightField, RunContext};
///
/// let n = 24;
/// let heights: Vec<f32> = (0..n * n)
///     .map(|i| 0.1 * ((i % n) as f32 * 0.7).sin() * ((i / n) as f32 * 0.5).cos())
///     .collect();
/// let texture = GeometryTexture::from_heightfield(&HeightField::new(n, n, heights)?, 0.05, 1.0, 4)?;
/// let params = QuiltParams::default().field_resolution(16).seed(3);
/// let measure = QualityMeasure::new(&texture, &params)?;
/// for method in [Method::Full, Method::SearchOnly] {
///     let p = params.clone().method(method);
///     let output = quilt(&texture, &p, &mut RunContext::new(3))?;
///     let report = measure.evaluate(&output, 8)?;
///     assert!(report.neighbourhood_error.is_finite());
/// }
/// // Means over seeds 1–2; no seeds at all is an error.
/// let [neighbourhood, seam] = measure.mean_errors(&params, 1..=2, 8)?;
/// assert!(neighbourhood.is_finite() && seam.is_finite());
/// assert!(measure.mean_errors(&params, 2..=1, 8).is_err());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct QualityMeasure<'t> {
    texture: &'t GeometryTexture,
    params: QuiltParams,
    ex: ExemplarFrame,
    exemplar_windows: ExemplarWindows,
    /// The exemplar's points, for the verbatim-copy test.
    exemplar_index: KdIndex,
    /// The exemplar's largest empty disc inside its footprint.
    exemplar_largest_empty_disc: f32,
}

impl<'t> QualityMeasure<'t> {
    /// Prepares the measure for outputs of `texture` quilted with `params` (any
    /// [`Method`](crate::Method): only the parameters shaping the exemplar's field, the
    /// patch and the windows, and the seed that draws the windows, are used). Errors: a
    /// texture without normals, a finely sampled exemplar field over
    /// [`MAX_MEASURE_NODES`](crate::MAX_MEASURE_NODES) nodes, and whatever building its
    /// surface or fields fails on.
    pub fn new(texture: &'t GeometryTexture, params: &QuiltParams) -> Result<Self> {
        let ex = ExemplarFrame::new(texture, params)?;
        let w = (ex.geometry.patch_nodes / 2).max(3);
        let s = ex.geometry.spacing;
        let exemplar_windows = ExemplarWindows::new(&ex, params.band * s, w)?;
        let (ex_lo, ex_hi) = texture.footprint();
        Ok(Self {
            texture,
            params: params.clone(),
            exemplar_windows,
            exemplar_index: KdIndex::new(&ex.points)?,
            exemplar_largest_empty_disc: largest_empty_disc(&ex.points, ex_lo, ex_hi, 0.5 * s)?,
            ex,
        })
    }

    /// Mean neighbourhood and seam errors of quilting this measure's texture with `params`
    /// at each of `seeds` (the seed set in `params` is replaced), each output measured with
    /// `windows` windows per class: one seed is too noisy to compare methods on. Errors:
    /// no seeds, and whatever [`quilt`](crate::quilt()) or [`Self::evaluate`] fails on.
    pub fn mean_errors(
        &self,
        params: &QuiltParams,
        seeds: std::ops::RangeInclusive<u64>,
        windows: usize,
    ) -> Result<[f32; 2]> {
        let mut sums = [0.0f32; 2];
        let mut count = 0usize;
        for seed in seeds {
            let p = params.clone().seed(seed);
            let output = crate::quilt(self.texture, &p, &mut RunContext::new(seed))?;
            let q = self.evaluate(&output, windows)?;
            sums[0] += q.neighbourhood_error;
            sums[1] += q.seam_error;
            count += 1;
        }
        if count == 0 {
            return Err(invalid("seeds", "none", "at least one seed"));
        }
        Ok(sums.map(|s| s / count as f32))
    }

    /// Measures `output` with `windows` random windows per class. Errors: `windows` = 0,
    /// an output smaller than one window (half a patch) along either side, and whatever
    /// building the output's surface fails on.
    pub fn evaluate(&self, output: &QuiltOutput, windows: usize) -> Result<QualityReport> {
        if windows == 0 {
            return Err(invalid("windows", 0, "at least 1 window per class"));
        }
        let g = self.ex.geometry;
        let out = self.output_field(output)?;
        // One stream draws the exemplar's window pairs, then the output's windows.
        let mut r = rng::stream(self.params.seed ^ 0x9a11, 0);
        let typical = self.typical_variation(&mut r, windows);
        let drawn = self.draw_windows(&mut r, output, &out, windows);
        let mean_error = |set: &[(usize, usize)]| -> Result<f32> {
            if set.is_empty() {
                return Ok(0.0);
            }
            let errors = set
                .par_iter()
                .map(|&at| {
                    self.exemplar_windows
                        .nearest(&self.ex.surface, &out.field, at)
                })
                .collect::<Result<Vec<f32>>>()?;
            Ok(errors.iter().sum::<f32>() / set.len() as f32 / typical)
        };
        let (seam_error, interior_error) = (mean_error(&drawn.seam)?, mean_error(&drawn.interior)?);
        Ok(QualityReport {
            neighbourhood_error: mean_error(&drawn.any)?,
            seam_error,
            interior_error,
            seam_concentration: seam_error / interior_error.max(f32::MIN_POSITIVE),
            verbatim_fraction: self.verbatim_fraction(output, &out.points),
            continued_seams: continued_seams(&output.placements, g.patch_nodes - g.overlap_nodes),
            exemplar_window_variation: typical,
            featureless_exemplar: typical <= FEATURELESS_VARIATION * g.spacing * g.spacing,
            largest_empty_disc: largest_empty_disc(&out.points, out.lo, out.hi, 0.5 * g.spacing)?,
            exemplar_largest_empty_disc: self.exemplar_largest_empty_disc,
            windows,
            seam_windows: drawn.seam.len(),
            interior_windows: drawn.interior.len(),
        })
    }

    /// The output's points in the canonical frame and the signed distance of its own MLS
    /// surface over its box, at the spacing and height of `D(T_in)`. Errors: an output
    /// smaller than one window, and whatever building its surface fails on.
    fn output_field(&self, output: &QuiltOutput) -> Result<OutputField> {
        let (ex, w) = (&self.ex, self.exemplar_windows.width());
        let up = self.texture.up();
        let (set, bounds) = (
            up.canonical_points(&output.points)?,
            up.canonical_box(&output.bounds),
        );
        let surface = MlsSurface::new(&set, &texture_mls_params().kernel(ex.surface.kernel()))?;
        let (a, b) = (bounds.min.truncate(), bounds.max.truncate());
        let (lo, hi) = (a.min(b), a.max(b));
        let s = ex.geometry.spacing;
        let dims = [
            ((hi.x - lo.x) / s).floor() as usize + 1,
            ((hi.y - lo.y) / s).floor() as usize + 1,
            ex.spec.dims[2],
        ];
        let spec = GridSpec {
            dims,
            origin: lo.extend(ex.spec.origin.z),
            spacing: s,
        };
        let field = Field::distances(&texture_field(&surface, &spec, self.params.band * s)?);
        if dims[0] < w || dims[1] < w {
            return Err(invalid(
                "output",
                format!("{} x {}", hi.x - lo.x, hi.y - lo.y),
                format!(
                    "room for one quality window ({w} × {w} field nodes, {:.3} wide) to measure",
                    (w - 1) as f32 * s
                ),
            ));
        }
        Ok(OutputField {
            points: set.positions().to_vec(),
            field,
            dims,
            lo,
            hi,
        })
    }

    /// The exemplar's typical window variation: the mean error between random pairs of
    /// non-overlapping exemplar windows (`8 · windows` draws).
    fn typical_variation(&self, r: &mut SeededRng, windows: usize) -> f32 {
        let (exemplar, w) = (&self.exemplar_windows, self.exemplar_windows.width());
        let positions = exemplar.positions();
        let mut pair_errors = Vec::new();
        for _ in 0..(8 * windows) {
            let a = positions[r.random_range(0..positions.len())];
            let b = positions[r.random_range(0..positions.len())];
            if a.0.abs_diff(b.0) >= w || a.1.abs_diff(b.1) >= w {
                pair_errors.push(exemplar.aligned_error(a, b));
            }
        }
        (pair_errors.iter().sum::<f32>() / pair_errors.len().max(1) as f32).max(f32::MIN_POSITIVE)
    }

    /// Random output windows (start nodes): up to `windows` anywhere, up to `windows`
    /// centred within half an overlap of a seam line (the middle of an overlap strip), and
    /// up to `windows` centred at least a quarter patch from every seam line.
    fn draw_windows(
        &self,
        r: &mut SeededRng,
        output: &QuiltOutput,
        out: &OutputField,
        windows: usize,
    ) -> DrawnWindows {
        let (g, w) = (self.ex.geometry, self.exemplar_windows.width());
        let seam_lines = |axis: usize| -> Vec<f32> {
            output
                .placements
                .iter()
                .filter(|p| [p.cell.0, p.cell.1][axis] > 0)
                .map(|p| p.origin[axis] + 0.5 * g.overlap())
                .collect()
        };
        let (seams_x, seams_y) = (seam_lines(0), seam_lines(1));
        let seam_distance = |c: Vec2| {
            let dx = seams_x
                .iter()
                .map(|x| (c.x - x).abs())
                .fold(f32::MAX, f32::min);
            let dy = seams_y
                .iter()
                .map(|y| (c.y - y).abs())
                .fold(f32::MAX, f32::min);
            dx.min(dy)
        };
        let mut drawn = DrawnWindows::default();
        let max_i = out.dims[0].saturating_sub(w);
        let max_j = out.dims[1].saturating_sub(w);
        let mut tries = 0;
        while (drawn.any.len() < windows
            || drawn.seam.len() < windows
            || drawn.interior.len() < windows)
            && tries < 200 * windows
        {
            tries += 1;
            let at = (r.random_range(0..=max_i), r.random_range(0..=max_j));
            let centre = out.lo
                + Vec2::new(
                    at.0 as f32 + 0.5 * (w - 1) as f32,
                    at.1 as f32 + 0.5 * (w - 1) as f32,
                ) * g.spacing;
            let d = seam_distance(centre);
            if drawn.any.len() < windows {
                drawn.any.push(at);
            }
            if d <= 0.5 * g.overlap() && drawn.seam.len() < windows {
                drawn.seam.push(at);
            } else if d >= 0.25 * g.patch() && drawn.interior.len() < windows {
                drawn.interior.push(at);
            }
        }
        drawn
    }

    /// Fraction of `points` (the output's, canonical frame) that are exemplar points
    /// translated by their patch's placement (GUIDE §5's verbatim copying).
    fn verbatim_fraction(&self, output: &QuiltOutput, points: &[Vec3]) -> f32 {
        let patch_of = output
            .points
            .attribute("patch")
            .map(|a| a.values().to_vec())
            .unwrap_or_default();
        let verbatim = points
            .par_iter()
            .zip(patch_of.par_iter())
            .filter(|(p, k)| {
                output
                    .placements
                    .get(**k as usize)
                    .is_some_and(|placement| {
                        let shift = placement.origin
                            - self.ex.patch_origin(placement.source.0, placement.source.1);
                        let source = **p - shift.extend(0.0);
                        self.exemplar_index
                            .nearest_one(source)
                            .ok()
                            .flatten()
                            .is_some_and(|n| n.distance_squared <= 1e-10)
                    })
            })
            .count();
        verbatim as f32 / points.len().max(1) as f32
    }
}

/// The output side of one measurement.
struct OutputField {
    /// The output's points in the canonical frame.
    points: Vec<Vec3>,
    /// Signed distance of the output's MLS surface over its box.
    field: Field,
    /// The field's node counts.
    dims: [usize; 3],
    /// The output box's lower corner on the reference plane.
    lo: Vec2,
    /// Its upper corner.
    hi: Vec2,
}

/// Start nodes of the windows drawn from one output, per class.
#[derive(Default)]
struct DrawnWindows {
    /// Anywhere in the output.
    any: Vec<(usize, usize)>,
    /// Centred on a seam.
    seam: Vec<(usize, usize)>,
    /// Centred well inside a patch.
    interior: Vec<(usize, usize)>,
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    fn lattice(step: f32, n: i32, skip: Option<(i32, i32)>) -> Vec<Vec3> {
        (0..n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .filter(|&c| Some(c) != skip)
            .map(|(i, j)| Vec3::new(i as f32 * step, j as f32 * step, 0.0))
            .collect()
    }

    #[test]
    fn continued_seams_count_sources_that_sit_side_by_side_in_the_exemplar() {
        let at = |cell: (usize, usize), source: (usize, usize)| Placement {
            index: 0,
            cell,
            origin: Vec2::ZERO,
            source,
            candidates: 1,
            distance: 0.0,
            warp: crate::warp::WarpCounts::default(),
            blend: crate::blend::BlendCounts::default(),
        };
        // 2 × 2 layout, step 5: (0,0) → (1,0) continues along x; (0,0) → (0,1) is off by
        // one node; the other two seams are unrelated.
        let layout = [
            at((0, 0), (3, 4)),
            at((1, 0), (8, 4)),
            at((0, 1), (3, 10)),
            at((1, 1), (0, 0)),
        ];
        assert_eq!(continued_seams(&layout, 5), 0.25);
        assert_eq!(continued_seams(&layout[..1], 5), 0.0);
    }

    #[test]
    fn the_largest_empty_disc_stays_inside_the_box() {
        let full = lattice(0.1, 21, None);
        let (lo, hi) = (Vec2::splat(0.5), Vec2::splat(1.5));
        let r = largest_empty_disc(&full, lo, hi, 0.005).unwrap();
        // A square lattice: half the cell diagonal.
        assert!((r - 0.1 / 2f32.sqrt()).abs() < 0.005, "{r}");
        // A missing point inside the box opens a disc about one step wide.
        let holed = lattice(0.1, 21, Some((10, 10)));
        let r = largest_empty_disc(&holed, lo, hi, 0.005).unwrap();
        assert!(r > 0.095 && r < 0.105, "{r}");
        // Points trimmed at a box that cuts the lattice between samples: the edge bounds the
        // disc, so the trimmed set measures like the untrimmed one.
        let (lo, hi) = (Vec2::splat(0.53), Vec2::splat(1.47));
        let trimmed: Vec<Vec3> = full
            .iter()
            .copied()
            .filter(|p| p.truncate().cmpge(lo).all() && p.truncate().cmple(hi).all())
            .collect();
        let a = largest_empty_disc(&trimmed, lo, hi, 0.005).unwrap();
        let b = largest_empty_disc(&full, lo, hi, 0.005).unwrap();
        assert!((a - b).abs() < 0.005 && a < 0.075, "{a} vs {b}");
    }
}
