//! Quality of a synthesized field (GUIDE §5), measured the same way for every method so the
//! synthesis can be compared with the random-block baseline.
//!
//! - **Neighbourhood error**: windows of `window³` samples at random target positions, each
//!   scored by its exact nearest source window (Eq. 1, found by [`BruteForce`]), divided
//!   by the mean Eq. 1 distance between random pairs of source windows (the exemplar's own
//!   typical window variation). 0 = every window occurs in the source.
//! - **Seam error**: for every pair of neighbouring target samples written by different
//!   blocks, how far each sample lies from the value the *other* block's source would have
//!   there (the continuation of that block in the source), squared, divided by the mean
//!   squared difference of random pairs of source samples. 0 = the blocks continue each
//!   other seamlessly.
//! - **Distance-field fraction**: share of unsaturated samples whose central-difference
//!   gradient has length within 0.25 of 1 (is the target still a distance field?), beside
//!   the same share for the source.
//! - **Verbatim fraction**: share of neighbouring blocks of the last iteration copied from
//!   neighbouring source positions with the same offset (large intact copies).

use distance_field::Quantizer;
use pointset_core::rng::stream;
use rand::RngExt;
use rayon::prelude::*;

use crate::error::{Result, invalid};
use crate::field::{QuantizedField, block_ssd};
use crate::matcher::{BlockMatcher, BruteForce};
use crate::synth::Synthesis;

/// Parameters of [`evaluate`].
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
#[non_exhaustive]
pub struct QualityParams {
    /// Window size (a power of two ≥ 2 that fits in source and target); default 8.
    pub window: usize,
    /// Windows sampled from the target; default 64.
    pub windows: usize,
    /// Seed of the window positions and of the normalizing pairs; default 0.
    pub seed: u64,
}

impl Default for QualityParams {
    fn default() -> Self {
        Self {
            window: 8,
            windows: 64,
            seed: 0,
        }
    }
}

impl QualityParams {
    /// Sets the window size (default 8).
    pub fn window(mut self, window: usize) -> Self {
        self.window = window;
        self
    }

    /// Sets the number of windows sampled from the target (default 64).
    pub fn windows(mut self, windows: usize) -> Self {
        self.windows = windows;
        self
    }

    /// Sets the seed (default 0).
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Checks the ranges that do not depend on the fields: a window that is a power of two
    /// ≥ 2 and at least one of them. Whether the window fits is checked by [`evaluate`].
    pub fn validate(&self) -> Result<()> {
        if !self.window.is_power_of_two() || self.window < 2 {
            return Err(invalid("window", self.window, "a power of two ≥ 2"));
        }
        if self.windows == 0 {
            return Err(invalid("windows", 0, "at least one window"));
        }
        Ok(())
    }
}

/// The quality numbers of one synthesized field.
#[derive(Debug, Clone, PartialEq)]
pub struct VoxelQuality {
    /// Mean nearest-window distance over the source's typical window distance.
    pub neighbourhood_error: f64,
    /// Mean squared continuation mismatch across block boundaries over the source's typical
    /// squared sample difference.
    pub seam_error: f64,
    /// Neighbouring sample pairs across block boundaries that were scored.
    pub seam_pairs: usize,
    /// Share of the target's unsaturated samples with a unit-length gradient (±0.25).
    pub distance_field_fraction: f64,
    /// The same share for the source.
    pub source_distance_field_fraction: f64,
    /// Share of neighbouring last-iteration blocks that continue each other in the source.
    pub verbatim_fraction: f64,
    /// Window size used.
    pub window: usize,
    /// Windows scored.
    pub windows: usize,
}

/// Measures `synthesis` against its quantized `source` (see the module docs).
pub fn evaluate(
    source: &QuantizedField,
    quantizer: &Quantizer,
    synthesis: &Synthesis,
    params: &QualityParams,
) -> Result<VoxelQuality> {
    params.validate()?;
    let w = params.window;
    let target = &synthesis.field;
    let (src_pos, tgt_pos) = (source.fitting_positions(w)?, target.fitting_positions(w)?);
    // Any exact matcher gives these distances. The search tree takes far longer for
    // windows unlike every source window, as a random baseline's are (its best-first
    // search then visits most of the tree): on the balls at 64³, 5.2 s against 0.35 s.
    let matcher = BruteForce::new(source, w)?;
    let random_corner =
        |rng: &mut pointset_core::rng::SeededRng, p: [usize; 3]| p.map(|n| rng.random_range(0..n));

    // Neighbourhood error.
    let nearest: Vec<f64> = (0..params.windows)
        .into_par_iter()
        .map(|i| {
            let mut rng = stream(params.seed, i as u64);
            let query = target.block(random_corner(&mut rng, tgt_pos), w);
            matcher.best_match(&query).map(|m| f64::from(m.distance))
        })
        .collect::<Result<_>>()?;
    let mut rng = stream(params.seed, u64::MAX - 1);
    let pairs = 256;
    let typical_window = (0..pairs)
        .map(|_| {
            let a = source.block(random_corner(&mut rng, src_pos), w);
            let b = source.block(random_corner(&mut rng, src_pos), w);
            block_ssd(&a, &b) as f64 / a.len() as f64
        })
        .sum::<f64>()
        / f64::from(pairs);
    let neighbourhood_error =
        nearest.iter().sum::<f64>() / nearest.len() as f64 / typical_window.max(f64::EPSILON);

    // Seams: continuation mismatch across block boundaries.
    let sv = source.values();
    let typical_sample = (0..4096)
        .map(|_| {
            let (a, b) = (rng.random_range(0..sv.len()), rng.random_range(0..sv.len()));
            f64::from(sv[a].abs_diff(sv[b])).powi(2)
        })
        .sum::<f64>()
        / 4096.0;
    let (seam_sum, seam_pairs) = seam_mismatch(source, synthesis);
    let seam_error = seam_sum / seam_pairs.max(1) as f64 / typical_sample.max(f64::EPSILON);

    Ok(VoxelQuality {
        neighbourhood_error,
        seam_error,
        seam_pairs,
        distance_field_fraction: unit_gradient_fraction(target, quantizer, synthesis.spacing),
        source_distance_field_fraction: unit_gradient_fraction(
            source,
            quantizer,
            synthesis.spacing,
        ),
        verbatim_fraction: verbatim_fraction(synthesis),
        window: w,
        windows: params.windows,
    })
}

/// Sum of squared continuation mismatches and the number of scored boundary pairs.
fn seam_mismatch(source: &QuantizedField, synthesis: &Synthesis) -> (f64, usize) {
    let target = &synthesis.field;
    let dims = target.dims();
    let sdims = source.dims();
    let (tv, sv) = (target.values(), source.values());
    // The source value block `copy` would put at target sample `p`, if inside the source.
    let continued = |copy: usize, p: [usize; 3]| -> Option<u8> {
        let c = synthesis.copies.get(copy)?;
        let mut s = [0usize; 3];
        for a in 0..3 {
            let v = (c.source[a] + p[a]).checked_sub(c.target[a])?;
            if v >= sdims[a] {
                return None;
            }
            s[a] = v;
        }
        Some(sv[source.index(s[0], s[1], s[2])])
    };
    (0..dims[2])
        .into_par_iter()
        .map(|z| {
            let (mut sum, mut count) = (0.0f64, 0usize);
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let p = [x, y, z];
                    let i = target.index(x, y, z);
                    for axis in 0..3 {
                        let mut q = p;
                        q[axis] += 1;
                        if q[axis] >= dims[axis] {
                            continue;
                        }
                        let j = target.index(q[0], q[1], q[2]);
                        let (oa, ob) = (synthesis.owner[i] as usize, synthesis.owner[j] as usize);
                        if oa == ob {
                            continue;
                        }
                        for (here, value, other) in [(q, tv[j], oa), (p, tv[i], ob)] {
                            if let Some(expected) = continued(other, here) {
                                sum += f64::from(value.abs_diff(expected)).powi(2);
                                count += 1;
                            }
                        }
                    }
                }
            }
            (sum, count)
        })
        .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1))
}

/// Share of samples (all 6 neighbours present, none saturated) whose central-difference
/// gradient, in world units, has length within 0.25 of 1.
pub fn unit_gradient_fraction(field: &QuantizedField, quantizer: &Quantizer, spacing: f32) -> f64 {
    let d = field.dims();
    let v = field.values();
    let (mut unit, mut total) = (0usize, 0usize);
    for z in 1..d[2].saturating_sub(1) {
        for y in 1..d[1].saturating_sub(1) {
            for x in 1..d[0].saturating_sub(1) {
                let at = |x: usize, y: usize, z: usize| v[field.index(x, y, z)];
                let around = [
                    (at(x + 1, y, z), at(x - 1, y, z)),
                    (at(x, y + 1, z), at(x, y - 1, z)),
                    (at(x, y, z + 1), at(x, y, z - 1)),
                ];
                let centre = at(x, y, z);
                let saturated = |q: u8| q == 0 || q == 255;
                if saturated(centre) || around.iter().any(|&(a, b)| saturated(a) || saturated(b)) {
                    continue;
                }
                let g: f32 = around
                    .iter()
                    .map(|&(a, b)| {
                        ((quantizer.dequantize(a) - quantizer.dequantize(b)) / (2.0 * spacing))
                            .powi(2)
                    })
                    .sum::<f32>()
                    .sqrt();
                total += 1;
                unit += usize::from((g - 1.0).abs() <= 0.25);
            }
        }
    }
    unit as f64 / total.max(1) as f64
}

/// Share of face-neighbouring last-iteration blocks whose source corners differ by exactly
/// their target offset.
fn verbatim_fraction(synthesis: &Synthesis) -> f64 {
    use std::collections::HashMap;
    let by_target: HashMap<[usize; 3], [usize; 3]> = synthesis
        .copies
        .iter()
        .map(|c| (c.target, c.source))
        .collect();
    let step = synthesis
        .copies
        .iter()
        .flat_map(|c| c.target)
        .filter(|&t| t > 0)
        .min()
        .unwrap_or(1);
    let (mut same, mut pairs) = (0usize, 0usize);
    for c in &synthesis.copies {
        for axis in 0..3 {
            let mut t = c.target;
            t[axis] += step;
            if let Some(s) = by_target.get(&t) {
                pairs += 1;
                let mut expected = c.source;
                expected[axis] += step;
                same += usize::from(*s == expected);
            }
        }
    }
    same as f64 / pairs.max(1) as f64
}
