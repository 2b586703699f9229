//! Automatic point pairing for the warp (paper 000 §5.2, Eq. 1–3) by the paper's iterated
//! greedy algorithm, with crossing removal and anchor pairs.

use glam::Vec3;
use pointset_core::{Aabb, KdIndex};

use crate::error::{Result, TpsError};
use crate::spline::{ThinPlateSpline, TpsParams};

/// A point taking part in a pairing: position, unit normal, surface variation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairingPoint {
    /// Position.
    pub position: Vec3,
    /// Unit normal.
    pub normal: Vec3,
    /// Surface variation `σ = λ0 / (λ0 + λ1 + λ2)` (any per-point scalar of local shape).
    pub variation: f32,
}

/// The paper's Table 1 weight sets (all with `w_p = 1`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Table1Preset {
    /// Height field: `w_n 3, w_v 30, w_l 9, w_d 7`.
    HeightField,
    /// Chain mail: `w_n 1, w_v 10, w_l 8, w_d 6`.
    ChainMail,
    /// Weave: `w_n 2, w_v 15, w_l 6, w_d 5`.
    Weave,
    /// Flowers: `w_n 2, w_v 2, w_l 6, w_d 6`.
    Flowers,
}

/// Parameters of [`pair_points`].
///
/// Thresholds apply to the raw quantities of Eq. 2 (distance, `(1 − n_s·n_q)/2`,
/// `(v_s − v_q)²`), so they keep their meaning whatever the weights; a term above its
/// threshold makes `c(s, q) = ∞`.
///
/// `w_p` and `w_l` multiply lengths in the points' own units, while the other terms are
/// unitless, so the weights' balance depends on the unit of length: Table 1's values
/// assume the paper's "about the same base dimensions" for every exemplar. Dividing `w_p`
/// and `w_l` by a length unit of the data keeps the balance whatever the file's unit
/// (`patch-quilt` uses its exemplar box's longer side / 4).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct PairingParams {
    /// Position weight `w_p`; default 1.
    pub w_p: f32,
    /// Normal weight `w_n`; default 3 (Table 1, height field).
    pub w_n: f32,
    /// Surface-variation weight `w_v`; default 30.
    pub w_v: f32,
    /// Length-coherence weight `w_l`; default 9.
    pub w_l: f32,
    /// Direction-coherence weight `w_d`; default 7.
    pub w_d: f32,
    /// Largest pair length; default unlimited.
    #[cfg_attr(feature = "serde", serde(with = "crate::serde_threshold"))]
    pub max_distance: f32,
    /// Largest `(1 − n_s·n_q)/2`; default 0.5 (normals at most 90° apart, so opposite
    /// normals never pair).
    #[cfg_attr(feature = "serde", serde(with = "crate::serde_threshold"))]
    pub max_normal_difference: f32,
    /// Largest `(v_s − v_q)²`; default unlimited.
    #[cfg_attr(feature = "serde", serde(with = "crate::serde_threshold"))]
    pub max_variation_difference: f32,
    /// Width `σ` of the Gaussian `θ(d) = exp(−d²/σ²)` weighting neighbouring pairs in `g`;
    /// default: twice the median distance from a target to its nearest distinct target.
    pub coherence_radius: Option<f32>,
    /// Rounds of steps 3–5; default 3, at most [`MAX_PAIRING_ROUNDS`]. A round that
    /// changes no pair ends them: every later round would repeat it.
    pub rounds: usize,
    /// Remove pairs that cross their neighbours; default true.
    pub remove_crossings: bool,
}

impl Default for PairingParams {
    fn default() -> Self {
        Self::table1(Table1Preset::HeightField)
    }
}

impl PairingParams {
    /// The weights of one row of the paper's Table 1 and the default thresholds.
    pub fn table1(preset: Table1Preset) -> Self {
        let (w_n, w_v, w_l, w_d) = match preset {
            Table1Preset::HeightField => (3.0, 30.0, 9.0, 7.0),
            Table1Preset::ChainMail => (1.0, 10.0, 8.0, 6.0),
            Table1Preset::Weave => (2.0, 15.0, 6.0, 5.0),
            Table1Preset::Flowers => (2.0, 2.0, 6.0, 6.0),
        };
        Self {
            w_p: 1.0,
            w_n,
            w_v,
            w_l,
            w_d,
            max_distance: f32::INFINITY,
            max_normal_difference: 0.5,
            max_variation_difference: f32::INFINITY,
            coherence_radius: None,
            rounds: 3,
            remove_crossings: true,
        }
    }

    /// Sets the largest pair length (default unlimited).
    pub fn max_distance(mut self, d: f32) -> Self {
        self.max_distance = d;
        self
    }

    /// Sets the number of greedy rounds (default 3, at most [`MAX_PAIRING_ROUNDS`]).
    pub fn rounds(mut self, rounds: usize) -> Self {
        self.rounds = rounds;
        self
    }

    /// Sets the coherence radius (default twice the targets' median spacing).
    pub fn coherence_radius(mut self, sigma: f32) -> Self {
        self.coherence_radius = Some(sigma);
        self
    }

    /// Sets the weights `w_p, w_n, w_v, w_l, w_d` of Eq. 2–3 (default Table 1's
    /// height-field row, `1, 3, 30, 9, 7`).
    pub fn weights(mut self, [w_p, w_n, w_v, w_l, w_d]: [f32; 5]) -> Self {
        (self.w_p, self.w_n, self.w_v, self.w_l, self.w_d) = (w_p, w_n, w_v, w_l, w_d);
        self
    }

    /// Sets the largest `(1 − n_s·n_q)/2` (default 0.5).
    pub fn max_normal_difference(mut self, difference: f32) -> Self {
        self.max_normal_difference = difference;
        self
    }

    /// Sets the largest `(v_s − v_q)²` (default unlimited).
    pub fn max_variation_difference(mut self, difference: f32) -> Self {
        self.max_variation_difference = difference;
        self
    }

    /// Sets whether pairs crossing their neighbours are removed (default true).
    pub fn remove_crossings(mut self, remove: bool) -> Self {
        self.remove_crossings = remove;
        self
    }

    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        let fields = [
            ("w_p", self.w_p),
            ("w_n", self.w_n),
            ("w_v", self.w_v),
            ("w_l", self.w_l),
            ("w_d", self.w_d),
        ];
        for (name, v) in fields {
            if !(v.is_finite() && v >= 0.0) {
                return Err(TpsError::InvalidParameter {
                    name,
                    value: v.to_string(),
                    expected: "a finite weight ≥ 0",
                });
            }
        }
        let thresholds = [
            ("max_distance", self.max_distance),
            ("max_normal_difference", self.max_normal_difference),
            ("max_variation_difference", self.max_variation_difference),
        ];
        for (name, v) in thresholds {
            if v.is_nan() || v < 0.0 {
                return Err(TpsError::InvalidParameter {
                    name,
                    value: v.to_string(),
                    expected: "a threshold ≥ 0 (infinity allowed)",
                });
            }
        }
        if let Some(s) = self.coherence_radius
            && !(s.is_finite() && s > 0.0)
        {
            return Err(TpsError::InvalidParameter {
                name: "coherence_radius",
                value: s.to_string(),
                expected: "a positive length",
            });
        }
        if self.rounds > MAX_PAIRING_ROUNDS {
            return Err(TpsError::InvalidParameter {
                name: "rounds",
                value: self.rounds.to_string(),
                expected: "at most 100 rounds",
            });
        }
        Ok(())
    }
}

/// Most rounds of steps 3–5 [`PairingParams::validate`] accepts. The paper runs "a few",
/// and the rounds stop early once one changes no pair (every later round would repeat
/// it); but rounds can keep changing pairs past 100 rounds (on this crate's test sheets),
/// so a mistyped count (`1000000000` was still running after a minute) needs this bound.
pub const MAX_PAIRING_ROUNDS: usize = 100;

/// One pair: indices into the source and target slices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pair {
    /// Index into the sources (`S`).
    pub source: usize,
    /// Index into the targets (`Q`).
    pub target: usize,
}

/// The result of [`pair_points`].
#[derive(Debug, Clone, PartialEq)]
pub struct Pairing {
    /// The pairs, in target order.
    pub pairs: Vec<Pair>,
    /// `C(Φ)` of Eq. 1 for the final pairs.
    pub cost: f64,
    /// Targets with no admissible source (every `c(s, q) = ∞` or all used).
    pub unmatched_targets: Vec<usize>,
    /// Pairs removed because they crossed neighbours.
    pub removed_crossings: usize,
}

/// The pairing problem: points, parameters and precomputed neighbourhoods in `Q`.
struct Problem<'a> {
    sources: &'a [PairingPoint],
    targets: &'a [PairingPoint],
    params: &'a PairingParams,
    /// Per target: admissible sources and `c(s, q)`.
    candidates: Vec<Vec<(usize, f32)>>,
    /// Per target: other targets with their weights `θ(|p_q − p_r|)`.
    neighbours: Vec<Vec<(usize, f32)>>,
}

impl Problem<'_> {
    /// Eq. 2 with thresholds; `None` stands for `∞`.
    fn pair_cost(&self, s: &PairingPoint, q: &PairingPoint) -> Option<f32> {
        let p = self.params;
        let distance = s.position.distance(q.position);
        let normal = 0.5 * (1.0 - s.normal.dot(q.normal));
        let variation = (s.variation - q.variation).powi(2);
        if distance > p.max_distance
            || normal > p.max_normal_difference
            || variation > p.max_variation_difference
        {
            return None;
        }
        Some(p.w_p * distance + p.w_n * normal + p.w_v * variation)
    }

    /// `f_l` and `f_d` of Eq. 3 at target `q`: the `θ`-weighted mean length of the pairs
    /// of `q`'s neighbours in `pairing` and the direction of their `θ`-weighted sum (its own pair excluded, as
    /// `neighbours` holds only other targets). `None` when no neighbour is paired. They do
    /// not depend on the source, so a round computes them once per target.
    fn neighbour_pairs(&self, q: usize, pairing: &[Option<usize>]) -> Option<NeighbourPairs> {
        let (mut sum_w, mut sum_len, mut sum_dir) = (0.0f32, 0.0f32, Vec3::ZERO);
        for &(r, w) in &self.neighbours[q] {
            if let Some(t) = pairing[r] {
                let v = self.sources[t].position - self.targets[r].position;
                sum_w += w;
                sum_len += w * v.length();
                sum_dir += w * v;
            }
        }
        (sum_w > 0.0).then(|| NeighbourPairs {
            mean_length: sum_len / sum_w,
            mean_direction: sum_dir.try_normalize(),
        })
    }

    /// `g(s, q, Φ)`: coherence of the pair `s → q` with `around`, the pairs of `q`'s
    /// neighbours in `Φ` ([`Self::neighbour_pairs`]). 0 without paired neighbours; the
    /// direction term is 0 where a direction is undefined (a zero-length pair, or
    /// neighbour directions that cancel).
    fn coherence(&self, s: usize, q: usize, around: Option<&NeighbourPairs>) -> f32 {
        let Some(around) = around else {
            return 0.0;
        };
        let v = self.sources[s].position - self.targets[q].position;
        let length_term = self.params.w_l * (v.length() - around.mean_length).abs();
        let direction_term = match (v.try_normalize(), around.mean_direction) {
            (Some(dir), Some(mean)) => 0.5 * self.params.w_d * (1.0 - mean.dot(dir)),
            _ => 0.0,
        };
        length_term + direction_term
    }
}

/// The pairs around one target that `g` compares a candidate pair with.
struct NeighbourPairs {
    /// `f_l`: the `θ`-weighted mean length.
    mean_length: f32,
    /// `f_d`: the unit `θ`-weighted mean direction; `None` where the directions cancel.
    mean_direction: Option<Vec3>,
}

fn check(points: &[PairingPoint], what: &'static str) -> Result<()> {
    match points
        .iter()
        .position(|p| !(p.position.is_finite() && p.normal.is_finite() && p.variation.is_finite()))
    {
        Some(index) => Err(TpsError::NonFinite { what, index }),
        None => Ok(()),
    }
}

/// Pairs targets `Q` with distinct sources `S` (paper 000 §5.2).
///
/// 1–2. Greedy: each target in order takes the unused source of least `c(s, q)`.
/// 3–6. `rounds` times: with the previous pairing `Φ` fixed, each pair's target in order
///      takes the unused source of least `c(s, q) + g(s, q, Φ)`. A round is a function of
///      `Φ` alone, so once one returns `Φ` unchanged the rest would too, and they are
///      skipped.
///
/// Then, if enabled, pairs that cross a neighbour — targets within `3σ` whose relative order
/// the pairs reverse, `(s_i − s_j)·(q_i − q_j) ≤ 0`, which folds the warp — are removed, the
/// pair with most crossings first (ties: the costlier one). Deterministic.
pub fn pair_points(
    sources: &[PairingPoint],
    targets: &[PairingPoint],
    params: &PairingParams,
) -> Result<Pairing> {
    params.validate()?;
    if sources.is_empty() || targets.is_empty() {
        return Err(TpsError::EmptyInput {
            what: "source or target set",
        });
    }
    check(sources, "source point")?;
    check(targets, "target point")?;
    let target_positions: Vec<Vec3> = targets.iter().map(|t| t.position).collect();
    let target_index = KdIndex::new(&target_positions)?;
    let sigma = match params.coherence_radius {
        Some(s) => s,
        None => (2.0 * target_index.median_spacing()?).max(f32::MIN_POSITIVE),
    };
    let neighbours = targets
        .iter()
        .enumerate()
        .map(|(q, t)| {
            Ok(target_index
                .within(t.position, 3.0 * sigma)?
                .into_iter()
                .filter(|n| n.index != q)
                .map(|n| (n.index, (-n.distance_squared / (sigma * sigma)).exp()))
                .collect())
        })
        .collect::<Result<Vec<Vec<_>>>>()?;
    let mut problem = Problem {
        sources,
        targets,
        params,
        candidates: Vec::new(),
        neighbours,
    };
    let source_positions: Vec<Vec3> = sources.iter().map(|s| s.position).collect();
    let source_index = KdIndex::new(&source_positions)?;
    problem.candidates = targets
        .iter()
        .map(|q| {
            let near: Vec<usize> = if params.max_distance.is_finite() {
                source_index
                    .within(q.position, params.max_distance)?
                    .into_iter()
                    .map(|n| n.index)
                    .collect()
            } else {
                (0..sources.len()).collect()
            };
            Ok(near
                .into_iter()
                .filter_map(|s| problem.pair_cost(&sources[s], q).map(|c| (s, c)))
                .collect())
        })
        .collect::<Result<Vec<Vec<_>>>>()?;

    // Steps 1–2.
    let mut used = vec![false; sources.len()];
    let mut source_of: Vec<Option<usize>> = vec![None; targets.len()];
    for (slot, candidates) in source_of.iter_mut().zip(&problem.candidates) {
        let best = candidates
            .iter()
            .filter(|(s, _)| !used[*s])
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        if let Some(&(s, _)) = best {
            used[s] = true;
            *slot = Some(s);
        }
    }
    // Steps 3–6.
    for _ in 0..params.rounds {
        let previous = source_of.clone();
        let mut used = vec![false; sources.len()];
        let mut next: Vec<Option<usize>> = vec![None; targets.len()];
        for q in (0..targets.len()).filter(|&q| previous[q].is_some()) {
            let around = problem.neighbour_pairs(q, &previous);
            let best = problem.candidates[q]
                .iter()
                .filter(|(s, _)| !used[*s])
                .map(|&(s, c)| (s, c + problem.coherence(s, q, around.as_ref())))
                .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            if let Some((s, _)) = best {
                used[s] = true;
                next[q] = Some(s);
            }
        }
        if next == previous {
            break;
        }
        source_of = next;
    }
    let removed_crossings = if params.remove_crossings {
        remove_crossings(&problem, &mut source_of)
    } else {
        0
    };
    let total = |q: usize, s: usize| {
        let c = problem.candidates[q]
            .iter()
            .find(|(t, _)| *t == s)
            .map_or(0.0, |(_, c)| *c);
        let around = problem.neighbour_pairs(q, &source_of);
        f64::from(c + problem.coherence(s, q, around.as_ref()))
    };
    let pairs: Vec<Pair> = source_of
        .iter()
        .enumerate()
        .filter_map(|(target, s)| s.map(|source| Pair { source, target }))
        .collect();
    let cost = pairs.iter().map(|p| total(p.target, p.source)).sum();
    let unmatched_targets = (0..targets.len())
        .filter(|&q| source_of[q].is_none())
        .collect();
    Ok(Pairing {
        pairs,
        cost,
        unmatched_targets,
        removed_crossings,
    })
}

/// Whether pairs `qi → si` and `qj → sj` reverse the targets' relative order.
fn crosses(problem: &Problem<'_>, qi: usize, si: usize, qj: usize, sj: usize) -> bool {
    let ds = problem.sources[si].position - problem.sources[sj].position;
    let dq = problem.targets[qi].position - problem.targets[qj].position;
    ds.dot(dq) <= 0.0
}

fn remove_crossings(problem: &Problem<'_>, source_of: &mut [Option<usize>]) -> usize {
    let mut removed = 0;
    loop {
        let mut worst: Option<(usize, usize, f32)> = None;
        for q in 0..source_of.len() {
            let Some(s) = source_of[q] else { continue };
            let count = problem.neighbours[q]
                .iter()
                .filter(|(r, _)| source_of[*r].is_some_and(|t| crosses(problem, q, s, *r, t)))
                .count();
            if count == 0 {
                continue;
            }
            let cost = problem.candidates[q]
                .iter()
                .find(|(t, _)| *t == s)
                .map_or(0.0, |(_, c)| *c);
            let better = match worst {
                None => true,
                Some((_, n, c)) => count > n || (count == n && cost > c),
            };
            if better {
                worst = Some((q, count, cost));
            }
        }
        match worst {
            Some((q, _, _)) => {
                source_of[q] = None;
                removed += 1;
            }
            None => return removed,
        }
    }
}

/// Up to `per_region` points inside each region, spread through its height: the anchor
/// points paper 000 maps to themselves in the corners of `F_k` so the warp stays local.
///
/// A region's points are cut into `per_region` layers of equal thickness along z, from
/// its lowest point to its highest, and each layer gives its point nearest the region's
/// centre in the xy plane; the slots of empty layers go to the remaining points nearest the
/// centre in xy. Regions may be unbounded along z (paper 000's corners are columns over the
/// reference plane). Anchors at one height leave the spline free to stretch and shear the
/// patch along z: taken nearest the centre in 3D, they all sat in the valleys of rough
/// height fields, and the warp squashed far corners' peaks by up to 40% (patch-quilt's
/// docs, "Anchors through the height").
///
/// ```
/// use glam::Vec3;
/// use pointset_core::Aabb;
/// use tps_warp::anchors_in_regions;
///
/// // A column of points 0 to 1 high at the centre of a corner, and lower ones off-centre.
/// let points: Vec<Vec3> = (0..=10)
///     .map(|i| Vec3::new(0.5, 0.5, i as f32 / 10.0))
///     .chain((0..5).map(|i| Vec3::new(0.1 * i as f32, 0.9, 0.0)))
///     .collect();
/// let corner = Aabb::new(Vec3::new(0.0, 0.0, f32::MIN), Vec3::new(1.0, 1.0, f32::MAX));
/// let anchors = anchors_in_regions(&points, &[corner], 2);
/// let heights: Vec<f32> = anchors.iter().map(|a| a.z).collect();
/// assert_eq!(heights, [0.0, 0.5]); // one from each half of the height, nearest the centre
/// ```
pub fn anchors_in_regions(points: &[Vec3], regions: &[Aabb], per_region: usize) -> Vec<Vec3> {
    let mut out = Vec::new();
    for region in regions {
        let mut inside: Vec<Vec3> = points
            .iter()
            .copied()
            .filter(|p| region.contains(*p))
            .collect();
        let centre = region.center().truncate();
        inside.sort_by(|a, b| {
            (a.truncate() - centre)
                .length_squared()
                .total_cmp(&(b.truncate() - centre).length_squared())
        });
        out.extend(spread_through_height(&inside, per_region));
    }
    out
}

/// Up to `count` of `by_preference` (sorted, most preferred first): the most preferred of
/// each of `count` equal layers between their lowest and highest z, then the most preferred
/// of the rest for the layers left empty.
fn spread_through_height(by_preference: &[Vec3], count: usize) -> Vec<Vec3> {
    // More layers than points choose every point either way (each layer's most preferred,
    // then the rest for the empty layers), so the layers are capped at the points.
    let count = count.min(by_preference.len());
    if count == 0 {
        return Vec::new();
    }
    let (low, high) = by_preference
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.z), hi.max(p.z))
        });
    let thickness = (high - low) / count as f32;
    let layer = |z: f32| {
        if thickness > 0.0 {
            (((z - low) / thickness) as usize).min(count - 1)
        } else {
            0
        }
    };
    let mut layer_taken = vec![false; count];
    let mut chosen = vec![false; by_preference.len()];
    for (i, p) in by_preference.iter().enumerate() {
        let l = layer(p.z);
        if !layer_taken[l] {
            layer_taken[l] = true;
            chosen[i] = true;
        }
    }
    let empty_layers = layer_taken.iter().filter(|t| !**t).count();
    let rest: Vec<usize> = (0..by_preference.len())
        .filter(|&i| !chosen[i])
        .take(empty_layers)
        .collect();
    for i in rest {
        chosen[i] = true;
    }
    by_preference
        .iter()
        .zip(&chosen)
        .filter(|(_, c)| **c)
        .map(|(p, _)| *p)
        .collect()
}

/// A fitted warp with the pairing behind it.
#[derive(Debug, Clone, PartialEq)]
pub struct PairedWarp {
    /// The pairing (without anchors).
    pub pairing: Pairing,
    /// The spline through the pairs and the anchors.
    pub spline: ThinPlateSpline,
}

/// Pairs `targets` with `sources`, adds `anchors` (mapped to themselves) and fits the spline.
pub fn pair_and_fit(
    sources: &[PairingPoint],
    targets: &[PairingPoint],
    anchors: &[Vec3],
    pairing: &PairingParams,
    tps: &TpsParams,
) -> Result<PairedWarp> {
    let pairing = pair_points(sources, targets, pairing)?;
    let mut from: Vec<Vec3> = pairing
        .pairs
        .iter()
        .map(|p| sources[p.source].position)
        .collect();
    let mut to: Vec<Vec3> = pairing
        .pairs
        .iter()
        .map(|p| targets[p.target].position)
        .collect();
    from.extend_from_slice(anchors);
    to.extend_from_slice(anchors);
    let spline = ThinPlateSpline::fit(&from, &to, tps)?;
    Ok(PairedWarp { pairing, spline })
}
