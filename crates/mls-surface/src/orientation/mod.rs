//! How consistently a point set's normals are oriented.
//!
//! The MLS surface averages neighbouring normals (`n(x) = Σ θ n_i / |Σ θ n_i|`), so normals
//! whose signs flip from point to point — as normals estimated by local PCA come, before
//! anything orients them — cancel out and leave no surface, or a wrong one, with no error
//! to say why. [`orientation_disagreement`] measures that, so tools can warn before a
//! long run, and [`orient_normals`] repairs it by propagation.

mod fitted;
mod frontier;
mod graph;

use glam::Vec3;
use pointset_core::spatial::z_order;
use pointset_core::{KdIndex, PointSet, RunContext};
use rayon::prelude::*;

use crate::error::{MlsError, Result};
use crate::index_match::check_index_of;
pub use fitted::fit_oriented_normals_with;
use frontier::{Entry, Frontier};
pub(crate) use graph::FoundNeighbours;
use graph::OrientationGraph;

/// Nearest neighbours each normal is compared with.
pub const ORIENTATION_NEIGHBOURS: usize = 6;

/// An [`orientation_disagreement`] above this suggests normals with random signs (they
/// score about a third); consistently oriented data scores up to a few hundredths, more
/// where thin sheets lie back to back (measured in the function's docs).
pub const LIKELY_UNORIENTED: f32 = 0.15;

/// Most points [`orientation_disagreement`] examines (an even stride through the set).
const SAMPLE: usize = 4096;

/// The fraction of points whose normal points away from (negative dot product with) the
/// normals of more than half of their [`ORIENTATION_NEIGHBOURS`] nearest neighbours.
///
/// Measured (all points): the bundled bumpy height field, torus, sphere and cylinder 0;
/// Stanford bunny scan 0.0001; chameleon 0.019; the chain mail and flowers fixtures 0.007
/// and 0.042 (neighbours across a thin tube or petal face the other way; the weave scored
/// 0.025 while its threads crossed through each other, 0.0003 since, and the chain mail
/// 0.021 while its rings did); a sheet with random normal signs 0.34. Examines at most
/// 4096 points, evenly strided, so the result is deterministic. Errors: no normals, a non-finite position.
///
/// ```
/// use glam::Vec3;
/// use mls_surface::{LIKELY_UNORIENTED, orientation_disagreement};
/// use pointset_core::PointSet;
///
/// let grid: Vec<Vec3> = (0..400).map(|i| Vec3::new((i % 20) as f32, (i / 20) as f32, 0.0)).collect();
/// let up = PointSet::new(grid.clone())?.with_normals(vec![Vec3::Z; 400])?;
/// assert_eq!(orientation_disagreement(&up)?, 0.0);
/// // Every third normal flipped, as unoriented estimates come.
/// let signs = (0..400).map(|i| if (i * 7919) % 3 == 0 { -Vec3::Z } else { Vec3::Z }).collect();
/// let mixed = PointSet::new(grid)?.with_normals(signs)?;
/// assert!(orientation_disagreement(&mixed)? > LIKELY_UNORIENTED);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn orientation_disagreement(points: &PointSet) -> Result<f32> {
    points.normals().ok_or(MlsError::MissingNormals)?;
    if points.len() <= ORIENTATION_NEIGHBOURS {
        return Ok(0.0);
    }
    orientation_disagreement_with(&KdIndex::new(points.positions())?, points)
}

/// [`orientation_disagreement`] with an `index` of `points`' positions that the caller
/// built (`KdIndex::new(points.positions())`): the function examines 4096 points at
/// most, and on millions of points building the index is nearly all of its time. The
/// same result. Errors: no normals, an index of other positions.
///
/// ```
/// use glam::Vec3;
/// use mls_surface::{fit_normals_with, orient_normals_with, orientation_disagreement_with};
/// use pointset_core::{KdIndex, PointSet, RunContext};
///
/// // One index for the fit, the orientation and its check.
/// let p: Vec<Vec3> = (0..900).map(|i| Vec3::new((i % 30) as f32, (i / 30) as f32, 0.0)).collect();
/// let points = PointSet::new(p)?;
/// let index = KdIndex::new(points.positions())?;
/// let mut ctx = RunContext::new(0);
/// let fit = fit_normals_with(&index, &points, 12, &mut ctx)?;
/// let oriented = orient_normals_with(&index, &fit.points, Vec3::Z, &mut ctx)?;
/// assert_eq!(orientation_disagreement_with(&index, &oriented)?, 0.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn orientation_disagreement_with(index: &KdIndex, points: &PointSet) -> Result<f32> {
    let normals = points.normals().ok_or(MlsError::MissingNormals)?;
    check_index_of(index, points)?;
    let positions = points.positions();
    if positions.len() <= ORIENTATION_NEIGHBOURS {
        return Ok(0.0);
    }
    let step = positions.len().div_ceil(SAMPLE);
    let (mut examined, mut opposed) = (0usize, 0usize);
    for i in (0..positions.len()).step_by(step) {
        let neighbours = index.nearest(positions[i], ORIENTATION_NEIGHBOURS + 1)?;
        let away = neighbours
            .iter()
            .filter(|n| n.index != i && normals[n.index].dot(normals[i]) < 0.0)
            .count();
        examined += 1;
        if 2 * away > ORIENTATION_NEIGHBOURS {
            opposed += 1;
        }
    }
    Ok(opposed as f32 / examined as f32)
}

/// Neighbours each point is joined to in [`orient_normals`]' graph.
pub const ORIENTATION_GRAPH_NEIGHBOURS: usize = 8;

/// The smallest `|cos|` between a root's normal and `up` in [`orient_normals`], where a
/// part of the graph has such a point.
const ROOT_MIN_COSINE: f32 = 0.5;

/// The normals' signs made consistent by propagation, after Hoppe et al. 1992 (*Surface
/// reconstruction from unorganized points*, §3.3): over the graph joining each point to
/// its [`ORIENTATION_GRAPH_NEIGHBOURS`] nearest neighbours, a minimum spanning tree carries
/// the orientation from a root, flipping each normal that faces away from its parent's.
/// The cost of an edge is Hoppe's `1 − |n_i · n_j|` plus the share of the edge that runs
/// along the normals. Edges that run mostly along the normals (two sheets facing each
/// other across a thin gap) are left out — with Hoppe's cost alone such facing pairs,
/// whose normals are antiparallel, are the cheapest edges of all — and so are edges whose
/// normals are within 15° of a right angle (a stem on a base), which cannot tell which
/// way either faces. Both are choices made here. Each connected part of the graph starts
/// from its point furthest along `up` among those whose normal is within 60° of `up` or
/// of its opposite, and that normal is turned to face `up` (the outside of a closed
/// surface there; the top of a texture); a part with no such point starts from its
/// highest point and is turned to face away from its own centroid there. Only signs
/// change; positions, attributes and the normals' directions are kept. Deterministic.
///
/// Measured against the true normals, starting from them and from every third flipped
/// (the same result but for the few points no usable edge reaches, which keep their sign:
/// 17 of the flowers' 15,796): the bumpy fixture, torus, sphere, cylinder and the bunny
/// scan all restored, and the weave since its threads no longer cross through each other
/// (forty-eighth session; 54% before); chameleon 97%; flowers 92% (97% at density 700);
/// the chain mail 90% at the fixtures' density (tubes about seven samples around) and
/// all of it at 1,200 and 3,000 points per unit area.
/// **Tubes that pass through one another are not restored**: on the chain mail fixture
/// before the sixtieth session, whose rings interpenetrated, about half the points came
/// out reversed in large consistent pieces at every sampling density measured (300 to
/// 3,000): where two surfaces cross, edges between them pass both filters, and the sign
/// each ring gets hangs on the crossing edge its tree takes (docs/mls-surface.md).
/// [`orientation_disagreement`] cannot see that, since each piece is consistent in
/// itself.
///
/// Errors: no normals, a non-finite position, an `up` that is zero or not finite.
///
/// ```
/// use glam::Vec3;
/// use mls_surface::{orient_normals, orientation_disagreement};
/// use pointset_core::PointSet;
///
/// // A sphere whose normals point in or out at random (as PCA estimates come).
/// let p: Vec<Vec3> = (0..800)
///     .map(|i| {
///         let (t, f) = (i as f32 * 2.399963, 1.0 - 2.0 * (i as f32 + 0.5) / 800.0);
///         Vec3::new((1.0 - f * f).sqrt() * t.cos(), (1.0 - f * f).sqrt() * t.sin(), f)
///     })
///     .collect();
/// let n = p.iter().enumerate().map(|(i, &v)| if i % 3 == 0 { -v } else { v }).collect();
/// let mixed = PointSet::new(p)?.with_normals(n)?;
/// let fixed = orient_normals(&mixed, Vec3::Z)?;
/// assert_eq!(orientation_disagreement(&fixed)?, 0.0);
/// // Outward everywhere: the root, the top of the sphere, faces +Z.
/// let outward = fixed.positions().iter().zip(fixed.normals().ok_or("no normals")?);
/// assert!(outward.into_iter().all(|(p, n)| p.dot(*n) > 0.0));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn orient_normals(points: &PointSet, up: Vec3) -> Result<PointSet> {
    orient_normals_in(points, up, &mut RunContext::new(0))
}

/// Points [`orient_normals_in`] orients between two progress reports and checks for
/// cancellation.
const ORIENT_REPORT_EVERY: u64 = 1 << 16;

/// The stage name [`orient_normals_in`] reports the propagation's progress under.
pub const ORIENTING_STAGE: &str = "orienting normals";

/// The stage name [`orient_normals_in`] reports the search for each point's neighbours
/// under, before the propagation.
pub const LINKING_STAGE: &str = "linking neighbours";

/// [`orient_normals`] within a run: the points whose neighbours were found, every 65,536
/// points, under [`LINKING_STAGE`]; then, from 0, the points reached by the propagation
/// every 65,536 points and at the end, out of all, under [`ORIENTING_STAGE`]. A
/// cancelled run stops at the next report with
/// `MlsError::Core(pointset_core::Error::Cancelled)`. The result is the same, bit for
/// bit.
///
/// ```
/// use glam::Vec3;
/// use mls_surface::{LINKING_STAGE, ORIENTING_STAGE, orient_normals_in};
/// use pointset_core::{PointSet, ProgressUpdate, RunContext};
///
/// let p: Vec<Vec3> = (0..400).map(|i| Vec3::new((i % 20) as f32, (i / 20) as f32, 0.0)).collect();
/// let signs = (0..400).map(|i| if i % 3 == 0 { -Vec3::Z } else { Vec3::Z }).collect();
/// let mixed = PointSet::new(p)?.with_normals(signs)?;
/// let mut ctx = RunContext::new(0).with_progress(move |u: &ProgressUpdate<'_>| {
///     assert!([LINKING_STAGE, ORIENTING_STAGE].contains(&u.stage) && u.total == Some(400));
/// });
/// let up = orient_normals_in(&mixed, Vec3::Z, &mut ctx)?;
/// assert!(up.normals().ok_or("no normals")?.iter().all(|n| n.z > 0.0));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn orient_normals_in(points: &PointSet, up: Vec3, ctx: &mut RunContext) -> Result<PointSet> {
    check_orient(points, up)?;
    ctx.check_cancelled()?;
    orient_normals_with(&KdIndex::new(points.positions())?, points, up, ctx)
}

/// [`orient_normals_in`] with an `index` of `points`' positions that the caller built
/// (`KdIndex::new(points.positions())`), so that the index the normals were fitted with
/// ([`crate::fit_normals_with`]) serves again: on 12 million points each index takes
/// seconds to build. The result is the same, bit for bit (the example at
/// [`orientation_disagreement_with`] runs all three on one index). Errors as
/// [`orient_normals`]'s, and an index of other positions.
pub fn orient_normals_with(
    index: &KdIndex,
    points: &PointSet,
    up: Vec3,
    ctx: &mut RunContext,
) -> Result<PointSet> {
    let normals = check_orient(points, up)?;
    check_index_of(index, points)?;
    let positions = points.positions();
    let unsearched = FoundNeighbours::unsearched(positions.len());
    let graph = OrientationGraph::build(
        positions,
        normals,
        index,
        z_order(positions),
        unsearched,
        ctx,
    )?;
    let by_point = propagate(positions, normals, graph, up, ctx)?;
    let mut out = points.clone();
    out.set_normals(Some(by_point))?;
    Ok(out)
}

/// The normals of the points at `positions` made consistent over `graph`, as
/// [`orient_normals`] describes, by point; reported under [`ORIENTING_STAGE`] as
/// [`orient_normals_in`] says. The graph is freed before the result is returned.
fn propagate(
    positions: &[Vec3],
    normals: &[Vec3],
    graph: OrientationGraph,
    up: Vec3,
    ctx: &mut RunContext,
) -> Result<Vec<Vec3>> {
    let total = positions.len() as u64;
    ctx.check_cancelled()?;
    ctx.report(ORIENTING_STAGE, 0, Some(total));
    let by_height = highest_first(positions, up);
    // The propagation works in the graph's numbering: `oriented[r]` is the normal of the
    // point at rank `r`.
    let mut oriented: Vec<Vec3> = graph.order.iter().map(|&i| normals[i as usize]).collect();
    let mut frontier = Frontier::new(positions.len());
    let mut reached = Reached { ctx, count: 0 };
    // A root must face clearly up or down (|n · up| ≥ ROOT_MIN_COSINE) for "face up" to
    // decide its sign: the tip of a petal is often highest and faces sideways. Parts
    // without such a point are rooted at their highest point afterwards.
    let steep = by_height
        .iter()
        .filter(|&&i| normals[i as usize].dot(up).abs() >= ROOT_MIN_COSINE * up.length());
    for &root in steep.chain(&by_height) {
        let root = root as usize;
        let root_rank = graph.rank_of[root];
        if frontier.reached(root_rank) {
            continue;
        }
        let mut tree = Tree {
            graph: &graph,
            oriented: &mut oriented,
            frontier: &mut frontier,
        };
        let part = tree.grow(root_rank, &mut reached)?;
        let root_normal = oriented[root_rank as usize];
        // Which way the part faces: its root's normal toward `up`, or, for a part with no
        // point facing up or down (a stem), outward from the part's centroid at the root.
        let facing = if normals[root].dot(up).abs() >= ROOT_MIN_COSINE * up.length() {
            root_normal.dot(up)
        } else {
            let at = |&rank: &u32| positions[graph.order[rank as usize] as usize];
            let centroid = part.iter().map(at).sum::<Vec3>() / part.len() as f32;
            root_normal.dot(positions[root] - centroid)
        };
        if facing < 0.0 {
            for &rank in &part {
                oriented[rank as usize] = -oriented[rank as usize];
            }
        }
    }
    let by_point: Vec<Vec3> = graph
        .rank_of
        .iter()
        .map(|&rank| oriented[rank as usize])
        .collect();
    // Freed before the caller copies the normals into the points: on millions of points
    // the graph is the largest thing the run holds.
    drop((graph, oriented, frontier, by_height));
    reached.ctx.report(ORIENTING_STAGE, total, Some(total));
    Ok(by_point)
}

/// The points' indices (fewer than `u32::MAX`) from the highest along `up` to the lowest
/// by `f32::total_cmp`, ties to the lower index: the order roots are tried in. Each point
/// is one 64-bit key, its height's order in the high half and its index in the low, so
/// that the sort compares integers instead of reading two points' positions each time
/// (on 12 million points 1.8 s became 0.36 s).
fn highest_first(positions: &[Vec3], up: Vec3) -> Vec<u32> {
    let mut keys: Vec<u64> = positions
        .par_iter()
        .enumerate()
        .map(|(i, p)| (u64::from(!total_order(p.dot(up))) << 32) | i as u64)
        .collect();
    keys.par_sort_unstable();
    keys.into_iter().map(|key| key as u32).collect()
}

/// `x`'s place in the order of `f32::total_cmp`, as an unsigned integer: negative values'
/// bits reversed below every positive value's, positive values' above.
fn total_order(x: f32) -> u32 {
    let bits = x.to_bits();
    if bits >> 31 == 1 {
        !bits
    } else {
        bits | (1 << 31)
    }
}

/// The input checks of [`orient_normals`]: normals, at most `u32::MAX` points, a
/// direction `up`. Returns the normals.
fn check_orient(points: &PointSet, up: Vec3) -> Result<&[Vec3]> {
    let normals = points.normals().ok_or(MlsError::MissingNormals)?;
    check_countable(points)?;
    check_up(up)?;
    Ok(normals)
}

/// That `up` is a direction: finite and not zero.
fn check_up(up: Vec3) -> Result<()> {
    if up.is_finite() && up.length_squared() > 0.0 {
        Ok(())
    } else {
        Err(MlsError::InvalidParameter {
            name: "up",
            value: format!("{up}"),
            expected: "a finite, non-zero direction",
        })
    }
}

/// That the graph can number `points`: at most `u32::MAX` of them.
fn check_countable(points: &PointSet) -> Result<()> {
    if u32::try_from(points.len()).is_err() {
        return Err(MlsError::InvalidParameter {
            name: "points",
            value: points.len().to_string(),
            expected: "at most 2^32 − 1 points to orient",
        });
    }
    Ok(())
}

/// How many points the propagation has reached, reported to a run every
/// [`ORIENT_REPORT_EVERY`].
struct Reached<'a> {
    ctx: &'a mut RunContext,
    count: u64,
}

impl Reached<'_> {
    /// Counts one more point; at every [`ORIENT_REPORT_EVERY`]-th, reports them all and
    /// stops a cancelled run.
    fn one_more(&mut self, total: usize) -> Result<()> {
        self.count += 1;
        if self.count.is_multiple_of(ORIENT_REPORT_EVERY) {
            self.ctx.check_cancelled()?;
            self.ctx
                .report(ORIENTING_STAGE, self.count, Some(total as u64));
        }
        Ok(())
    }
}

/// A minimum spanning tree of the part of the graph around a root, grown by Prim's
/// algorithm through the points the frontier has not reached (ties to the point with the
/// lower index in the point set, then to the parent with the lower index), each normal
/// reached turned to agree with its parent's. Everything else is numbered by the graph's
/// ranks.
struct Tree<'a> {
    graph: &'a OrientationGraph,
    oriented: &'a mut [Vec3],
    frontier: &'a mut Frontier,
}

impl Tree<'_> {
    /// Grows the tree from `root`; returns its points in the order reached.
    fn grow(&mut self, root: u32, reached: &mut Reached<'_>) -> Result<Vec<u32>> {
        let mut part = Vec::new();
        let index = self.graph.order[root as usize];
        self.frontier.offer(Entry {
            key: (0, index, index),
            point: root,
            parent: root,
        });
        while let Some(reached_by) = self.frontier.pop() {
            let (node, index) = (reached_by.point, reached_by.key.1);
            let (at, from) = (node as usize, reached_by.parent as usize);
            part.push(node);
            reached.one_more(self.oriented.len())?;
            if self.oriented[at].dot(self.oriented[from]) < 0.0 {
                self.oriented[at] = -self.oriented[at];
            }
            for &(next, cost) in self.graph.edges_of(node) {
                if !self.frontier.reached(next) {
                    self.frontier.offer(Entry {
                        key: (cost, self.graph.order[next as usize], index),
                        point: next,
                        parent: node,
                    });
                }
            }
        }
        Ok(part)
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        /// Heights of both signs, zeros of both signs and repeats: the keys give the
        /// order the comparison of heights and indices gives.
        #[test]
        fn highest_first_is_the_order_of_heights_then_indices(
            heights in prop::collection::vec(
                prop_oneof![
                    -1e3f32..1e3,
                    Just(0.0f32),
                    Just(-0.0f32),
                    Just(2.5f32),
                    Just(f32::MIN_POSITIVE),
                    Just(-f32::MAX),
                ],
                0..300,
            ),
            up in prop::sample::select(vec![Vec3::Z, -Vec3::Z, Vec3::new(0.0, 0.0, 3.0)]),
        ) {
            let positions: Vec<Vec3> =
                heights.iter().map(|&h| Vec3::new(1.0, -2.0, h)).collect();
            let mut compared: Vec<u32> = (0..positions.len() as u32).collect();
            compared.sort_by(|&a, &b| {
                positions[b as usize]
                    .dot(up)
                    .total_cmp(&positions[a as usize].dot(up))
                    .then(a.cmp(&b))
            });
            prop_assert_eq!(highest_first(&positions, up), compared);
        }
    }
}
