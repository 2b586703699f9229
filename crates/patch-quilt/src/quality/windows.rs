//! Nearest exemplar windows at continuous offsets.
//!
//! The exemplar is a continuous surface, so its windows exist at every position, not only at
//! the nodes of `D(T_in)`. Restricting the nearest window to node positions scores a
//! verbatim copy of the exemplar translated by a fraction of a node as if it were different
//! (measured on the weave fixture, search-only output, all four channels: interior error
//! 0.008 as produced, 0.046 shifted by 0.1 spacing, 0.105 by 0.25 spacing), which penalizes
//! every method that moves geometry off the lattice — the warp does exactly that.
//!
//! Two choices make the measure continuous in the offset:
//! - **Signed distance only.** The gradient channels jump across medial axes and at the
//!   edge of the distance band (unit vector ↔ zero), so a node near either flips under an
//!   arbitrarily small shift; with gradients, even exact windows at continuous offsets left
//!   the 0.1-spacing shift at 0.019 against 0.008. The clamped signed distance is
//!   1-Lipschitz: windows of a shifted copy differ by at most the shift. (The search of
//!   step 2 still compares all four channels, as the paper does.)
//! - **Three passes**, on the exemplar's signed distance sampled [`SUBSTEPS`] times finer
//!   than `D(T_in)` (one spacing of margin on every side, where the padding geometry is):
//!   1. exhaustively over the node positions of `D(T_in)`;
//!   2. every fine offset within one spacing (x, y and z) of the [`REFINED`] best;
//!   3. a descent at continuous offsets from the best of those, trilinearly interpolated:
//!      the 26 neighbours at half a fine step, then half again, [`CONTINUOUS_LEVELS`] times;
//!      the window it ends on is then evaluated exactly (MLS distance at its nodes) and kept
//!      if better than the best of pass 2. Interpolation only steers: every error reported
//!      is that of an exactly evaluated exemplar window.
//!
//! Measured on the same output: shifted by 0.1 spacing the interior error moves from 0.004
//! to 0.005 (was 0.046 with nodes only and four channels), and it is never above the
//! node-only search's.

use distance_field::{GridSpec, SdfGrid};
use glam::Vec3;
use mls_surface::MlsSurface;

use crate::error::{Result, invalid};
use crate::exemplar::{ExemplarFrame, texture_field};

/// Finer samples per field spacing in the second pass.
pub const SUBSTEPS: usize = 4;
/// Node-aligned exemplar windows whose surroundings are searched in the second pass.
pub const REFINED: usize = 8;
/// Most nodes the measure's fine exemplar field may have (about 1.3 GB while it is built,
/// and minutes of MLS projections). Sampled 4 times finer, it has 64 times the nodes of
/// `D(T_in)`, so field resolutions that the synthesis handles in seconds can ask the
/// measure for more memory than the machine has. Measured on the bumpy fixture (2 cores):
/// 9 M fine nodes (`field_resolution` 96) take 10 s to build, 40 M (160) take 48 s.
pub const MAX_MEASURE_NODES: usize = 1 << 26;
/// Relative slack on the error limit below which the first pass keeps summing a window:
/// a window whose full error is within the limit is then never cut short by the rounding
/// of its partial sums (relative 1e-7), and one that is cut short is certainly over it.
const LIMIT_SLACK: f32 = 1e-5;
/// Halvings of the step in the continuous pass (the last step is
/// `1 / (SUBSTEPS · 2^CONTINUOUS_LEVELS)` spacing).
pub const CONTINUOUS_LEVELS: usize = 3;

/// The signed distance of an [`SdfGrid`] and its dimensions.
pub(super) struct Field {
    data: Vec<f32>,
    dims: [usize; 3],
}

/// Where a window starts in a field — a node plus a fraction of a node per axis, read by
/// trilinear interpolation — and how many of that field's nodes one window step spans.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct WindowAt {
    pub node: [usize; 3],
    pub frac: Vec3,
    pub step: usize,
}

impl WindowAt {
    /// A window starting exactly at `node`.
    pub fn at_node(node: [usize; 3], step: usize) -> Self {
        Self {
            node,
            frac: Vec3::ZERO,
            step,
        }
    }
}

impl Field {
    /// The distance channel of `field`.
    pub fn distances(field: &SdfGrid) -> Self {
        Self {
            data: field.grid().data().iter().map(|v| v.x).collect(),
            dims: field.grid().dims(),
        }
    }

    fn at(&self, [i, j, k]: [usize; 3]) -> f32 {
        self.data[i + self.dims[0] * (j + self.dims[1] * k)]
    }

    /// Trilinear interpolation at `node + frac`, with `frac`'s corner weights from
    /// [`corner_weights`] (`None`: exactly at the node; corners of weight 0 are not read).
    fn sample(&self, [i, j, k]: [usize; 3], weights: Option<&[f32; 8]>) -> f32 {
        let Some(weights) = weights else {
            return self.at([i, j, k]);
        };
        let mut value = 0.0;
        for (corner, &weight) in weights.iter().enumerate() {
            if weight > 0.0 {
                let d = [corner & 1, (corner >> 1) & 1, corner >> 2];
                value += weight * self.at([i + d[0], j + d[1], k + d[2]]);
            }
        }
        value
    }

    /// Mean squared difference of the `w × w × nz` windows `at` (here) and `other_at`; stops
    /// early, returning something above `limit`, once the partial sum exceeds it (checked
    /// after every row of the window).
    pub fn window_error(
        &self,
        at: WindowAt,
        other: &Field,
        other_at: WindowAt,
        [w, nz]: [usize; 2],
        limit: f32,
    ) -> f32 {
        let count = (w * w * nz) as f32;
        let bound = limit * count;
        let node = |start: WindowAt, [a, b, c]: [usize; 3]| {
            let [i, j, k] = start.node;
            [i + a * start.step, j + b * start.step, k + c * start.step]
        };
        let (mine_weights, their_weights) =
            (corner_weights(at.frac), corner_weights(other_at.frac));
        let mut sum = 0.0f32;
        for c in 0..nz {
            for b in 0..w {
                if mine_weights.is_none() && their_weights.is_none() {
                    // Both windows on nodes: read the two rows directly (same order of
                    // summation as the general path below).
                    let mine = self.row(node(at, [0, b, c]), at.step, w);
                    let theirs = other.row(node(other_at, [0, b, c]), other_at.step, w);
                    for (x, y) in mine.zip(theirs) {
                        sum += (x - y).powi(2);
                    }
                } else {
                    for a in 0..w {
                        let mine = self.sample(node(at, [a, b, c]), mine_weights.as_ref());
                        let theirs =
                            other.sample(node(other_at, [a, b, c]), their_weights.as_ref());
                        sum += (mine - theirs).powi(2);
                    }
                }
                if sum > bound {
                    return sum / count;
                }
            }
        }
        sum / count
    }

    /// `len` values along x from node `start`, every `step`-th node.
    fn row(&self, start: [usize; 3], step: usize, len: usize) -> impl Iterator<Item = f32> + '_ {
        let [i, j, k] = start;
        let first = i + self.dims[0] * (j + self.dims[1] * k);
        debug_assert!(len == 0 || first + step * (len - 1) < self.data.len());
        self.data[first..].iter().step_by(step).take(len).copied()
    }
}

/// The eight trilinear corner weights of a fraction of a node (corner `n` is offset by bit 0,
/// 1 and 2 of `n` along x, y and z), or `None` for a zero fraction. A window's nodes all share
/// its fraction, so these are computed once per window, not once per node.
fn corner_weights(frac: Vec3) -> Option<[f32; 8]> {
    (frac != Vec3::ZERO).then(|| {
        std::array::from_fn(|corner| {
            let d = [corner & 1, (corner >> 1) & 1, corner >> 2];
            (0..3)
                .map(|a| if d[a] == 1 { frac[a] } else { 1.0 - frac[a] })
                .product()
        })
    })
}

/// The exemplar's windows: `w × w` nodes of `D(T_in)`'s spacing, full height.
pub(super) struct ExemplarWindows {
    /// The fine field's grid (origin and spacing) and the distance band.
    spec: GridSpec,
    band: f32,
    /// The exemplar's signed distance [`SUBSTEPS`] times finer, one spacing beyond `D(T_in)`.
    fine: Field,
    /// `[w, nz]`.
    shape: [usize; 2],
    /// Node positions `(i, j)` of `D(T_in)` where a window fits.
    positions: Vec<(usize, usize)>,
}

impl ExemplarWindows {
    /// Samples the fine field of the exemplar's MLS surface around its box.
    pub fn new(ex: &ExemplarFrame, band: f32, w: usize) -> Result<Self> {
        let surface = &ex.surface;
        let coarse = ex.spec.dims;
        let spacing = ex.spec.spacing;
        let spec = GridSpec {
            dims: coarse.map(|n| (n + 1) * SUBSTEPS + 1),
            origin: ex.spec.origin - Vec3::splat(spacing),
            spacing: spacing / SUBSTEPS as f32,
        };
        let nodes = spec
            .dims
            .iter()
            .try_fold(1usize, |n, &d| n.checked_mul(d))
            .unwrap_or(usize::MAX);
        if nodes > MAX_MEASURE_NODES {
            let [x, y, z] = coarse;
            return Err(invalid(
                "field_resolution",
                format!("{x} x {y} x {z} nodes of D(T_in)"),
                format!(
                    "a quality measure within {MAX_MEASURE_NODES} nodes: its exemplar field, \
                     {SUBSTEPS} times finer, would have {nodes} (about {:.1} GB); lower \
                     field_resolution, or leave the output unmeasured",
                    nodes as f64 * 20.0 / 1e9
                ),
            ));
        }
        let positions = (0..=coarse[1].saturating_sub(w))
            .flat_map(|j| (0..=coarse[0].saturating_sub(w)).map(move |i| (i, j)))
            .collect();
        Ok(Self {
            fine: Field::distances(&texture_field(surface, &spec, band)?),
            spec,
            band,
            shape: [w, coarse[2]],
            positions,
        })
    }

    /// A window's width `w` in nodes of `D(T_in)`.
    pub fn width(&self) -> usize {
        self.shape[0]
    }

    /// Node positions of `D(T_in)` where a window fits.
    pub fn positions(&self) -> &[(usize, usize)] {
        &self.positions
    }

    /// The window at node `(i, j)` of `D(T_in)` (full height), in the fine field.
    fn aligned(&self, (i, j): (usize, usize)) -> WindowAt {
        WindowAt::at_node([(i + 1) * SUBSTEPS, (j + 1) * SUBSTEPS, SUBSTEPS], SUBSTEPS)
    }

    /// Error between the exemplar windows at node positions `a` and `b`.
    pub fn aligned_error(&self, a: (usize, usize), b: (usize, usize)) -> f32 {
        let (f, shape) = (&self.fine, self.shape);
        f.window_error(self.aligned(a), f, self.aligned(b), shape, f32::MAX)
    }

    /// Last fine node a window may start at along `axis`, keeping `reserve` nodes after its
    /// end for interpolation.
    fn last_start(&self, axis: usize, reserve: usize) -> usize {
        let span = if axis == 2 {
            self.shape[1]
        } else {
            self.shape[0]
        };
        (self.fine.dims[axis] - 1).saturating_sub((span - 1) * SUBSTEPS + reserve)
    }

    /// Every fine window within one spacing (x, y, z) of `centre` that fits.
    fn around(&self, centre: WindowAt) -> impl Iterator<Item = WindowAt> + '_ {
        let range = move |axis: usize| {
            let lo = centre.node[axis].saturating_sub(SUBSTEPS);
            let hi = (centre.node[axis] + SUBSTEPS).min(self.last_start(axis, 0));
            lo..=hi
        };
        range(2).flat_map(move |k| {
            range(1)
                .flat_map(move |j| range(0).map(move |i| WindowAt::at_node([i, j, k], SUBSTEPS)))
        })
    }

    /// The window starting at the continuous fine-node position `p`, if it fits.
    fn at_position(&self, p: Vec3) -> Option<WindowAt> {
        let base = p.floor();
        let frac = p - base;
        let mut node = [0; 3];
        for axis in 0..3 {
            let reserve = usize::from(frac[axis] > 0.0);
            if base[axis] < 0.0 || base[axis] as usize > self.last_start(axis, reserve) {
                return None;
            }
            node[axis] = base[axis] as usize;
        }
        Some(WindowAt {
            node,
            frac,
            step: SUBSTEPS,
        })
    }

    /// The exemplar's window starting at the continuous fine-node position `p`, evaluated
    /// exactly on the exemplar's surface `surface` (the one the windows were sampled from).
    fn exact(&self, surface: &MlsSurface, p: Vec3) -> Result<Field> {
        let [w, nz] = self.shape;
        let spec = GridSpec {
            dims: [w, w, nz],
            origin: self.spec.origin + p * self.spec.spacing,
            spacing: self.spec.spacing * SUBSTEPS as f32,
        };
        Ok(Field::distances(&texture_field(surface, &spec, self.band)?))
    }

    /// The [`REFINED`] node-aligned exemplar windows with the least `error(window, limit)`
    /// as `(error, position number)`, least first, ties to the lower number: the head of
    /// every position sorted by its error. Once [`REFINED`] are held, a window is summed
    /// only until it certainly falls behind the last of them (`limit`, with
    /// [`LIMIT_SLACK`] for the rounding of the sums).
    fn nearest_aligned(&self, error: impl Fn(WindowAt, f32) -> f32) -> Vec<(f32, usize)> {
        let mut best: Vec<(f32, usize)> = Vec::with_capacity(REFINED + 1);
        for (n, &p) in self.positions.iter().enumerate() {
            let limit = match best.get(REFINED - 1) {
                Some(&(last, _)) => last * (1.0 + LIMIT_SLACK),
                None => f32::MAX,
            };
            let e = error(self.aligned(p), limit);
            let at = best.partition_point(|&(b, m)| b.total_cmp(&e).then(m.cmp(&n)).is_lt());
            if at < REFINED {
                best.insert(at, (e, n));
                best.truncate(REFINED);
            }
        }
        best
    }

    /// Mean squared difference between the window of `out` starting at node `at` and the
    /// nearest exemplar window (three passes, see the module docs); `surface` is the
    /// exemplar's surface the windows were sampled from, for the exact last window.
    pub fn nearest(&self, surface: &MlsSurface, out: &Field, at: (usize, usize)) -> Result<f32> {
        let here = WindowAt::at_node([at.0, at.1, 0], 1);
        let error = |there: WindowAt, limit: f32| {
            out.window_error(here, &self.fine, there, self.shape, limit)
        };
        let ranked = self.nearest_aligned(error);
        let Some(&(first, n)) = ranked.first() else {
            return Ok(f32::INFINITY);
        };
        let (mut best, mut best_at) = (first, self.aligned(self.positions[n]));
        for &(_, n) in &ranked {
            for there in self.around(self.aligned(self.positions[n])) {
                let e = error(there, best);
                if e < best {
                    (best, best_at) = (e, there);
                }
            }
        }
        let start = Vec3::from(best_at.node.map(|n| n as f32));
        let (mut steered, mut position) = (best, start);
        let mut step = 0.5;
        for _ in 0..CONTINUOUS_LEVELS {
            let centre = position;
            for offset in neighbour_offsets() {
                let candidate = centre + offset * step;
                if let Some(there) = self.at_position(candidate) {
                    let e = error(there, steered);
                    if e < steered {
                        (steered, position) = (e, candidate);
                    }
                }
            }
            step *= 0.5;
        }
        if position != start {
            let window = self.exact(surface, position)?;
            let own = WindowAt::at_node([0; 3], 1);
            best = best.min(out.window_error(here, &window, own, self.shape, best));
        }
        Ok(best)
    }
}

/// The 26 offsets `{-1, 0, 1}³ \ {0}`.
fn neighbour_offsets() -> impl Iterator<Item = Vec3> {
    (0..27).filter(|&n| n != 13).map(|n| {
        Vec3::new(
            (n % 3) as f32 - 1.0,
            ((n / 3) % 3) as f32 - 1.0,
            (n / 9) as f32 - 1.0,
        )
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use pointset_core::HeightField;

    use super::*;
    use crate::params::QuiltParams;
    use crate::texture::GeometryTexture;

    /// Runs `check` on the windows (and `w`) of a bumpy height-field texture.
    fn with_windows(check: impl FnOnce(&ExemplarWindows, &MlsSurface, usize)) {
        let texture = bumps();
        let ex =
            ExemplarFrame::new(&texture, &QuiltParams::default().field_resolution(20)).unwrap();
        let w = ex.geometry.patch_nodes / 2;
        check(&ExemplarWindows::new(&ex, 0.4, w).unwrap(), &ex.surface, w);
    }

    fn bumps() -> GeometryTexture {
        let n = 40;
        let h: Vec<f32> = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32 * 0.05, (i / n) as f32 * 0.05);
                0.15 * (5.0 * x).sin() * (4.0 * y + x).cos()
            })
            .collect();
        GeometryTexture::from_heightfield(&HeightField::new(n, n, h).unwrap(), 0.05, 1.0, 7)
            .unwrap()
    }

    #[test]
    fn exact_windows_at_fine_nodes_are_the_fine_field() {
        with_windows(|windows, surface, _| {
            for node in [[4, 4, 4], [9, 17, 3], [21, 6, 5]] {
                let exact = windows
                    .exact(surface, Vec3::from(node.map(|n| n as f32)))
                    .unwrap();
                let error = exact.window_error(
                    WindowAt::at_node([0; 3], 1),
                    &windows.fine,
                    WindowAt::at_node(node, SUBSTEPS),
                    windows.shape,
                    f32::MAX,
                );
                assert!(error < 1e-10, "{node:?}: {error}");
            }
        });
    }

    /// The first pass keeps the head of the full ranking, cut-short sums and all.
    #[test]
    fn the_nearest_aligned_windows_are_the_head_of_the_full_ranking() {
        with_windows(|windows, surface, _| {
            let here = WindowAt::at_node([0; 3], 1);
            for (start, shift) in [
                ((2usize, 3usize), Vec3::new(1.37, -2.6, 0.9)),
                ((7, 1), Vec3::ZERO),
            ] {
                let node = Vec3::from(windows.aligned(start).node.map(|n| n as f32));
                let cut = windows.exact(surface, node + shift).unwrap();
                let error = |there: WindowAt, limit: f32| {
                    cut.window_error(here, &windows.fine, there, windows.shape, limit)
                };
                let mut ranked: Vec<(f32, usize)> = windows
                    .positions()
                    .iter()
                    .enumerate()
                    .map(|(n, &p)| (error(windows.aligned(p), f32::MAX), n))
                    .collect();
                ranked.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                ranked.truncate(REFINED);
                assert_eq!(windows.nearest_aligned(error), ranked);
            }
        });
    }

    #[test]
    fn a_window_at_a_continuous_offset_is_found() {
        with_windows(|windows, surface, w| {
            let typical = windows.aligned_error((0, 0), (w, w));
            for start in [(2usize, 3usize), (5, 1)] {
                let node = windows.aligned(start).node.map(|n| n as f32);
                let position = Vec3::from(node) + Vec3::new(1.37, -2.6, 0.9);
                let cut = windows.exact(surface, position).unwrap();
                let found = windows.nearest(surface, &cut, (0, 0)).unwrap();
                let on_nodes = windows
                    .positions()
                    .iter()
                    .map(|&p| {
                        cut.window_error(
                            WindowAt::at_node([0; 3], 1),
                            &windows.fine,
                            windows.aligned(p),
                            windows.shape,
                            f32::MAX,
                        )
                    })
                    .fold(f32::INFINITY, f32::min);
                assert!(
                    found < 2e-3 * typical,
                    "{start:?}: {found} vs typical {typical}"
                );
                assert!(
                    on_nodes > 20.0 * found,
                    "{start:?}: nodes only {on_nodes}, found {found}"
                );
            }
        });
    }
}
