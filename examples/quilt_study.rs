//! Mean quality of patch quilting over several seeds: the full method, both baselines and the
//! same-layout control (the full run's patches pasted without warp or blend). This is the
//! driver behind the multi-seed tables in `docs/patch-quilt-studies.md`; one seed is too
//! noisy to compare methods on.
//!
//! ```text
//! cargo run --release --example quilt_study -- [--seeds N] [--windows W] [--resampled DIR]
//!     [--surface-gap] [--normal-agreement C] [--smoothing L] [--epsilon E]
//!     [--patch-size F] [--overlap F] [--extra-width F] [--pair-distance D] [--blend-reach R]
//!     [--repair-random]
//!     [--cluster-points N] [--cluster-variation S] [--anchors A]
//!     [--max-normal-difference M] FIXTURE.ply...
//! ```
//!
//! `--surface-gap` runs the full method (and so its same-layout control) with
//! [`WarpTargets::SurfaceGap`] instead of the paper's exact targets. `--normal-agreement C`
//! sets the blend's normal test ([`QuiltParams::normal_agreement`], default 0.8);
//! `--smoothing L` the warp's spline smoothing ([`QuiltParams::smoothing`], default 0);
//! `--epsilon E` the search's tolerance `ε` ([`QuiltParams::epsilon`], default 0.1);
//! `--patch-size F` the patch side as a fraction of the exemplar box's smaller side
//! ([`QuiltParams::patch_size`], default 0.4; the measure's windows, half a patch, follow it);
//! `--overlap F` and `--extra-width F` the overlap width and `w_E` as fractions of the patch
//! ([`QuiltParams::overlap`], 1/6, and [`QuiltParams::extra_width`], 0.3);
//! `--pair-distance D` the warp's largest pair length ([`QuiltParams::pair_distance`]) and
//! `--blend-reach R` the blend's largest gap ([`QuiltParams::blend_reach`]);
//! `--cluster-points N` and `--cluster-variation S` the limits of the clustering that picks
//! the warp's targets `Q` ([`QuiltParams::clusters`], `n_max` 12 and `σ_max` 0.1);
//! `--anchors A` the anchors per free corner ([`QuiltParams::anchors_per_corner`], 4);
//! `--max-normal-difference M` the pairing's normal threshold on `(1 − n_s·n_q)/2`
//! (`PairingParams::max_normal_difference`, 0.5 in every Table 1 row).
//!
//! With `--repair-random`, another row runs the full method on random placement's own
//! layout: steps 4–5 applied to seams that the search did not choose, compared with random
//! placement itself (what the warp and blend repair when there is something to repair).
//!
//! With `--resampled DIR` (a folder of the same fixtures sampled anew, e.g. from
//! `geosynth fixtures --texture-density 300 --sampling-seed 7 --out DIR`), another row pastes
//! search-only's own layout from the resampled exemplar: the same surfaces with other
//! samples, measured against the original. It shows how much of the measure depends on the
//! sampling rather than on the geometry.
//!
//! A fixture is a texture file, or a height field image or raw `.f32le` file (as
//! `geosynth quilt --heightfield` reads it). Each fixture gets the pairing weights of its
//! Table 1 row, chosen from the file name (`chain_mail`, `weave`, `flowers`; anything else:
//! the height-field row), and otherwise the default parameters (output twice the exemplar). Seeds run from 1 to N (default 8) with `W`
//! windows per class (default 128). Prints neighbourhood / seam / interior error per method
//! and the fraction of seams whose two patches continue each other in the exemplar
//! ([`QualityReport::continued_seams`]: how much of the output is larger intact copies;
//! means over the seeds), then the full method's paired difference from each other run,
//! seed by seed (and, with `--repair-random`, that row's difference from random placement),
//! as mean ± standard error of the mean (neighbourhood / seam): the methods
//! differ by less than the spread between seeds, so only a difference several standard
//! errors from 0 ranks them.

use std::error::Error;
use std::path::{Path, PathBuf};

use geosynth::core::RunContext;
use geosynth::quilt::{
    GeometryTexture, Method, QualityMeasure, QualityReport, QuiltParams, WarpTargets, quilt,
    read_heightfield_texture, read_texture,
};
use geosynth::tps::{PairingParams, Table1Preset};

/// The runs compared for every seed.
const FULL: &str = "full";
const SEARCH_ONLY: &str = "search only";
const RANDOM: &str = "random placement";
const CONTROL: &str = "full's layout, pasted";
/// Only with `--resampled`.
const RESAMPLED: &str = "search only's layout, resampled exemplar";
/// Only with `--repair-random`.
const RANDOM_REPAIRED: &str = "random placement's layout, warped and blended";

/// Command-line settings.
struct Study {
    seeds: u64,
    windows: usize,
    resampled: Option<PathBuf>,
    /// The parameters every run starts from; each seed sets its seed and the fixture's
    /// Table 1 row on a copy.
    params: QuiltParams,
    repair_random: bool,
    /// Overrides the Table 1 row's `max_normal_difference` when given.
    max_normal_difference: Option<f32>,
    fixtures: Vec<PathBuf>,
}

/// The value after `flag`, parsed.
fn value<T>(args: &mut impl Iterator<Item = String>, flag: &str) -> Result<T, Box<dyn Error>>
where
    T: std::str::FromStr,
    T::Err: Error + 'static,
{
    let text = args.next().ok_or(format!("{flag} needs a value"))?;
    Ok(text.parse()?)
}

fn parse() -> Result<Study, Box<dyn Error>> {
    let mut study = Study {
        seeds: 8,
        windows: 128,
        resampled: None,
        params: QuiltParams::default(),
        repair_random: false,
        max_normal_difference: None,
        fixtures: Vec::new(),
    };
    let p = &mut study.params;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let a = &mut args;
        match arg.as_str() {
            "--seeds" => study.seeds = value(a, &arg)?,
            "--windows" => study.windows = value(a, &arg)?,
            "--resampled" => study.resampled = Some(value(a, &arg)?),
            "--surface-gap" => p.warp_targets = WarpTargets::SurfaceGap,
            "--repair-random" => study.repair_random = true,
            "--normal-agreement" => p.normal_agreement = value(a, &arg)?,
            "--smoothing" => p.smoothing = value(a, &arg)?,
            "--epsilon" => p.epsilon = value(a, &arg)?,
            "--patch-size" => p.patch_size = value(a, &arg)?,
            "--overlap" => p.overlap = value(a, &arg)?,
            "--extra-width" => p.extra_width = value(a, &arg)?,
            "--pair-distance" => p.pair_distance = value(a, &arg)?,
            "--blend-reach" => p.blend_reach = value(a, &arg)?,
            "--cluster-points" => p.clusters.max_points = value(a, &arg)?,
            "--cluster-variation" => p.clusters.max_variation = value(a, &arg)?,
            "--anchors" => p.anchors_per_corner = value(a, &arg)?,
            "--max-normal-difference" => study.max_normal_difference = Some(value(a, &arg)?),
            "--help" | "-h" => return Err(USAGE.into()),
            flag if flag.starts_with('-') => {
                return Err(format!("unknown flag {flag}; {USAGE}").into());
            }
            _ => study.fixtures.push(PathBuf::from(arg)),
        }
    }
    if study.fixtures.is_empty() || study.seeds == 0 || study.windows == 0 {
        return Err(USAGE.into());
    }
    Ok(study)
}

/// What the command line takes (the flags are described in the module docs).
const USAGE: &str = "usage: quilt_study [--seeds N ≥ 1] [--windows W ≥ 1] [--resampled DIR] \
     [--surface-gap] [--normal-agreement C] [--smoothing L] [--epsilon E] \
     [--patch-size F] [--overlap F] [--extra-width F] [--pair-distance D] \
     [--blend-reach R] [--repair-random] \
     [--cluster-points N] [--cluster-variation S] [--anchors A] \
     [--max-normal-difference M] FIXTURE.ply...";

/// A texture file (PLY, OBJ, OFF, XYZ), or a height field (`.png`, `.f32le`) read with the
/// command line's conventions.
fn load(path: &Path) -> Result<GeometryTexture, Box<dyn Error>> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    Ok(match extension.as_str() {
        "png" | "f32le" => read_heightfield_texture(path)?,
        _ => read_texture(path)?,
    })
}

/// The Table 1 row for a fixture, from its file name.
fn preset_for(path: &Path) -> Table1Preset {
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    if name.contains("chain") {
        Table1Preset::ChainMail
    } else if name.contains("weave") {
        Table1Preset::Weave
    } else if name.contains("flower") {
        Table1Preset::Flowers
    } else {
        Table1Preset::HeightField
    }
}

/// The named reports of one seed: full, search only, random placement and the control,
/// then the optional rows `study` asks for.
fn one_seed(
    study: &Study,
    texture: &GeometryTexture,
    resampled: Option<&GeometryTexture>,
    params: &QuiltParams,
) -> Result<Vec<(&'static str, QualityReport)>, Box<dyn Error>> {
    // Quilts `source` and measures the result against `texture`.
    let measure = QualityMeasure::new(texture, params)?;
    let run = |source: &GeometryTexture, p: &QuiltParams| -> Result<_, Box<dyn Error>> {
        let out = quilt(source, p, &mut RunContext::new(p.seed))?;
        let report = measure.evaluate(&out, study.windows)?;
        Ok((out, report))
    };
    let (full, full_report) = run(texture, params)?;
    let (search, search_report) = run(texture, &params.clone().method(Method::SearchOnly))?;
    let (random, random_report) = run(texture, &params.clone().method(Method::RandomPlacement))?;
    let (_, control) = run(texture, &params.same_layout_control(&full))?;
    let mut reports = vec![
        (FULL, full_report),
        (SEARCH_ONLY, search_report),
        (RANDOM, random_report),
        (CONTROL, control),
    ];
    if let Some(other) = resampled {
        let (_, anew) = run(other, &params.same_layout_control(&search))?;
        reports.push((RESAMPLED, anew));
    }
    if study.repair_random {
        let (_, repaired) = run(texture, &params.clone().layout(random.sources()))?;
        reports.push((RANDOM_REPAIRED, repaired));
    }
    Ok(reports)
}

/// Mean of `values` and its standard error (sample standard deviation / √n; 0 for fewer
/// than two values).
fn mean_and_error(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n.max(1.0);
    if values.len() < 2 {
        return (mean, 0.0);
    }
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (variance / n).sqrt())
}

fn main() -> Result<(), Box<dyn Error>> {
    let study = parse()?;
    println!(
        "seeds 1..={}, {} windows per class, warp targets {:?}, normal agreement {}, \
         smoothing {}, epsilon {}, patch size {}, pair distance {}, blend reach {}; \
         neighbourhood / seam / interior error (mean over seeds)",
        study.seeds,
        study.windows,
        study.params.warp_targets,
        study.params.normal_agreement,
        study.params.smoothing,
        study.params.epsilon,
        study.params.patch_size,
        study.params.pair_distance,
        study.params.blend_reach
    );
    for path in &study.fixtures {
        let texture = load(path)?;
        let resampled = match (&study.resampled, path.file_name()) {
            (Some(dir), Some(name)) => Some(read_texture(&dir.join(name))?),
            _ => None,
        };
        // rows[i] = (name, [neighbourhood, seam, interior error, continued seams] with one
        // value per seed), in the order of `one_seed`.
        let mut rows: Vec<(&str, [Vec<f64>; 4])> = Vec::new();
        for seed in 1..=study.seeds {
            let mut pairing = PairingParams::table1(preset_for(path));
            if let Some(limit) = study.max_normal_difference {
                pairing.max_normal_difference = limit;
            }
            let params = study.params.clone().seed(seed).pairing(pairing);
            for (i, (name, q)) in one_seed(&study, &texture, resampled.as_ref(), &params)?
                .into_iter()
                .enumerate()
            {
                if rows.len() <= i {
                    rows.push((name, Default::default()));
                }
                let values = &mut rows[i].1;
                values[0].push(f64::from(q.neighbourhood_error));
                values[1].push(f64::from(q.seam_error));
                values[2].push(f64::from(q.interior_error));
                values[3].push(f64::from(q.continued_seams));
            }
        }
        for (name, values) in &rows {
            let [n, s, i, c] = [0, 1, 2, 3].map(|class| mean_and_error(&values[class]).0);
            println!(
                "{} | {name} | {n:.4} / {s:.4} / {i:.4} | continued seams {c:.2}",
                path.display()
            );
        }
        let row = |wanted: &str| rows.iter().find(|(name, _)| *name == wanted);
        let mut comparisons: Vec<(&str, &str)> =
            rows[1..].iter().map(|(n, _)| (FULL, *n)).collect();
        comparisons.push((RANDOM_REPAIRED, RANDOM));
        for (a, b) in comparisons {
            let (Some((_, a_values)), Some((_, b_values))) = (row(a), row(b)) else {
                continue;
            };
            let [n, s] = [0, 1].map(|class| {
                let differences: Vec<f64> = a_values[class]
                    .iter()
                    .zip(&b_values[class])
                    .map(|(x, y)| x - y)
                    .collect();
                mean_and_error(&differences)
            });
            println!(
                "{} | {a} − {b} | {:+.4} ± {:.4} / {:+.4} ± {:.4}",
                path.display(),
                n.0,
                n.1,
                s.0,
                s.1
            );
        }
    }
    Ok(())
}
