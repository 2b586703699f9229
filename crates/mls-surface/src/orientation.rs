//! How consistently a point set's normals are oriented.
//!
//! The MLS surface averages neighbouring normals (`n(x) = Σ θ n_i / |Σ θ n_i|`), so normals
//! whose signs flip from point to point — as normals estimated by local PCA come, before
//! anything orients them — cancel out and leave no surface, or a wrong one, with no error
//! to say why. [`orientation_disagreement`] measures that, so tools can warn before a
//! long run, and [`orient_normals`] repairs it by propagation.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::Vec3;
use pointset_core::spatial::z_order;
use pointset_core::{KdIndex, PointSet, RunContext};
use rayon::prelude::*;

use crate::error::{MlsError, Result};

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
/// Stanford bunny scan 0.0001; chameleon 0.019; the chain mail, weave and flowers
/// fixtures 0.021, 0.025 and 0.042 (neighbours across a thin tube or petal face the other
/// way); a sheet with random normal signs 0.34. Examines at most 4096 points, evenly
/// strided, so the result is deterministic. Errors: no normals, a non-finite position.
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
    let normals = points.normals().ok_or(MlsError::MissingNormals)?;
    let positions = points.positions();
    if positions.len() <= ORIENTATION_NEIGHBOURS {
        return Ok(0.0);
    }
    let index = KdIndex::new(positions)?;
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

/// The largest share of a graph edge's length that may run along either end's normal in
/// [`orient_normals`]: neighbours on one sheet lie nearly in each other's tangent plane,
/// while two sheets facing each other across a thin gap lie along the normal.
const MAX_EDGE_ACROSS: f32 = 0.5;

/// The smallest `|n_i · n_j|` of an edge of [`orient_normals`]' graph: normals nearly at
/// right angles (a stem standing on a base) say nothing about which way either faces.
const MIN_EDGE_COSINE: f32 = 0.25;

/// The smallest `|cos|` between a root's normal and `up` in [`orient_normals`], where a
/// part of the graph has such a point.
const ROOT_MIN_COSINE: f32 = 0.5;

/// An edge of [`orient_normals`]' graph: the other end and the cost of crossing.
type Edge = (u32, u32);

/// A slot of [`OrientationGraph::build`]'s table of nearest neighbours with no usable edge.
const NO_EDGE: Edge = (u32::MAX, u32::MAX);

/// [`orient_normals`]' graph: every usable edge between a point and one of its
/// [`ORIENTATION_GRAPH_NEIGHBOURS`] nearest neighbours, listed from both ends, each
/// point's list sorted and without repeats, all in one array.
struct OrientationGraph {
    /// Where each point's edges start in `edges`; one more entry, the end.
    starts: Vec<usize>,
    /// Every point's edges, one point after another.
    edges: Vec<Edge>,
}

impl OrientationGraph {
    /// The graph of `positions` (at most `u32::MAX` of them) with `normals`, indexed by
    /// `index`. The neighbours are found in parallel; the graph does not depend on the
    /// threads.
    ///
    /// The points' neighbours are reported to `ctx` under [`LINKING_STAGE`] every
    /// [`ORIENT_REPORT_EVERY`] points, and a cancelled run stops there.
    fn build(
        positions: &[Vec3],
        normals: &[Vec3],
        index: &KdIndex,
        ctx: &mut RunContext,
    ) -> Result<Self> {
        const SLOTS: usize = ORIENTATION_GRAPH_NEIGHBOURS + 1;
        const CHUNK: usize = ORIENT_REPORT_EVERY as usize;
        let n = positions.len();
        // The table lists the points along the Z-order curve, so that consecutive queries
        // share the index's caches; the lists below are sorted, so the graph is the same.
        let order = z_order(positions);
        let mut near = vec![NO_EDGE; n * SLOTS];
        let chunks = near.chunks_mut(SLOTS * CHUNK).zip(order.chunks(CHUNK));
        for (chunk, (table, points)) in chunks.enumerate() {
            ctx.check_cancelled()?;
            table
                .par_chunks_mut(SLOTS)
                .zip(points.par_iter())
                .try_for_each(|(slots, &i)| -> Result<()> {
                    let found = index.nearest(positions[i], SLOTS)?;
                    let usable = found.iter().filter_map(|neighbour| {
                        let cost = edge_cost(positions, normals, i, neighbour.index)?;
                        Some((neighbour.index as u32, cost))
                    });
                    for (slot, edge) in slots.iter_mut().zip(usable) {
                        *slot = edge;
                    }
                    Ok(())
                })?;
            let done = (chunk * CHUNK + points.len()) as u64;
            ctx.report(LINKING_STAGE, done, Some(n as u64));
        }
        let listed = || {
            near.chunks(SLOTS).zip(&order).flat_map(|(slots, &i)| {
                let usable = slots.iter().take_while(|&&edge| edge != NO_EDGE);
                usable.map(move |&(j, cost)| (i, j as usize, cost))
            })
        };
        let mut starts = vec![0usize; n + 1];
        for (i, j, _) in listed() {
            starts[i + 1] += 1;
            starts[j + 1] += 1;
        }
        for i in 0..n {
            starts[i + 1] += starts[i];
        }
        let mut edges = vec![NO_EDGE; starts[n]];
        let mut filled = starts[..n].to_vec();
        for (i, j, cost) in listed() {
            edges[filled[i]] = (j as u32, cost);
            filled[i] += 1;
            edges[filled[j]] = (i as u32, cost);
            filled[j] += 1;
        }
        drop(near);
        // Each list sorted, its repeats (both ends among each other's neighbours) dropped,
        // and the lists moved together.
        let mut kept = 0;
        for i in 0..n {
            let (first, end) = (starts[i], starts[i + 1]);
            edges[first..end].sort_unstable();
            starts[i] = kept;
            for read in first..end {
                if kept == starts[i] || edges[kept - 1] != edges[read] {
                    edges[kept] = edges[read];
                    kept += 1;
                }
            }
        }
        starts[n] = kept;
        edges.truncate(kept);
        Ok(Self { starts, edges })
    }

    /// The edges of point `i`.
    fn edges_of(&self, i: usize) -> &[Edge] {
        &self.edges[self.starts[i]..self.starts[i + 1]]
    }
}

/// The cost of carrying the orientation from `i` to `j`: `1 − |n_i · n_j|` (Hoppe et al.)
/// plus the share of the edge that runs along the normals, so that links within one sheet
/// are taken before links that jump between sheets; `None` for edges that run mostly along
/// the normals. Scaled to integers for the heap.
fn edge_cost(positions: &[Vec3], normals: &[Vec3], i: usize, j: usize) -> Option<u32> {
    let offset = positions[j] - positions[i];
    let length = offset.length();
    if i == j || length <= 0.0 {
        return None;
    }
    let across = offset
        .dot(normals[i])
        .abs()
        .max(offset.dot(normals[j]).abs())
        / length;
    let agreement = normals[i].dot(normals[j]).abs();
    let bend = (1.0 - agreement).max(0.0);
    (across <= MAX_EDGE_ACROSS && agreement >= MIN_EDGE_COSINE)
        .then_some(((bend + across) * 1e6) as u32)
}

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
/// scan all restored; chameleon 97%; flowers 92% (97% at density 700).
/// **Interlinked thin tubes are not restored**: on the chain mail and the weave about half the points come out
/// reversed, in large consistent pieces (likely whole rings: linked rings touch, and the
/// propagation crosses between them; not isolated). [`orientation_disagreement`] cannot
/// see that, since each piece is consistent in itself.
///
/// Errors: no normals, a non-finite position.
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
    let normals = points.normals().ok_or(MlsError::MissingNormals)?;
    let positions = points.positions();
    if u32::try_from(positions.len()).is_err() {
        return Err(MlsError::InvalidParameter {
            name: "points",
            value: positions.len().to_string(),
            expected: "at most 2^32 − 1 points to orient",
        });
    }
    let total = positions.len() as u64;
    ctx.check_cancelled()?;
    let index = KdIndex::new(positions)?;
    let graph = OrientationGraph::build(positions, normals, &index, ctx)?;
    drop(index);
    ctx.check_cancelled()?;
    ctx.report(ORIENTING_STAGE, 0, Some(total));
    // Roots in order of height along `up` (index breaks ties: the order is total, so an
    // unstable sort gives the one order there is).
    let mut by_height: Vec<usize> = (0..positions.len()).collect();
    by_height.par_sort_unstable_by(|&a, &b| {
        positions[b]
            .dot(up)
            .total_cmp(&positions[a].dot(up))
            .then(a.cmp(&b))
    });
    let mut oriented: Vec<Vec3> = normals.to_vec();
    let mut done = vec![false; positions.len()];
    let mut reached = Reached { ctx, count: 0 };
    // A root must face clearly up or down (|n · up| ≥ ROOT_MIN_COSINE) for "face up" to
    // decide its sign: the tip of a petal is often highest and faces sideways. Parts
    // without such a point are rooted at their highest point afterwards.
    let steep = by_height
        .iter()
        .filter(|&&i| normals[i].dot(up).abs() >= ROOT_MIN_COSINE * up.length());
    for &root in steep.chain(&by_height) {
        if done[root] {
            continue;
        }
        let part = propagate(root, &graph, &mut oriented, &mut done, &mut reached)?;
        // Which way the part faces: its root's normal toward `up`, or, for a part with no
        // point facing up or down (a stem), outward from the part's centroid at the root.
        let facing = if normals[root].dot(up).abs() >= ROOT_MIN_COSINE * up.length() {
            oriented[root].dot(up)
        } else {
            let centroid = part.iter().map(|&i| positions[i]).sum::<Vec3>() / part.len() as f32;
            oriented[root].dot(positions[root] - centroid)
        };
        if facing < 0.0 {
            for &i in &part {
                oriented[i] = -oriented[i];
            }
        }
    }
    reached.ctx.report(ORIENTING_STAGE, total, Some(total));
    let mut out = points.clone();
    out.set_normals(Some(oriented))?;
    Ok(out)
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

/// Prim's algorithm over (cost, node, parent) from `root` through the parts of the graph
/// not yet `done`: each normal reached is turned to agree with its parent's. Returns the
/// part's points in the order reached.
fn propagate(
    root: usize,
    graph: &OrientationGraph,
    oriented: &mut [Vec3],
    done: &mut [bool],
    reached: &mut Reached<'_>,
) -> Result<Vec<usize>> {
    let mut part = Vec::new();
    // Points fit in `u32` (checked by the caller): the heap's entries are 12 bytes.
    let mut frontier = BinaryHeap::from([Reverse((0u32, root as u32, root as u32))]);
    while let Some(Reverse((_, node, parent))) = frontier.pop() {
        let (node, parent) = (node as usize, parent as usize);
        if done[node] {
            continue;
        }
        done[node] = true;
        part.push(node);
        reached.one_more(done.len())?;
        if oriented[node].dot(oriented[parent]) < 0.0 {
            oriented[node] = -oriented[node];
        }
        for &(next, cost) in graph.edges_of(node) {
            if !done[next as usize] {
                frontier.push(Reverse((cost, next, node as u32)));
            }
        }
    }
    Ok(part)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use proptest::prelude::*;

    use super::*;

    /// The graph as the first version built it: a list per point, both ends of every
    /// usable edge pushed, each list sorted and its repeats dropped.
    fn listed_graph(positions: &[Vec3], normals: &[Vec3]) -> Vec<Vec<Edge>> {
        let index = KdIndex::new(positions).unwrap();
        let mut lists: Vec<Vec<Edge>> = vec![Vec::new(); positions.len()];
        for (i, &p) in positions.iter().enumerate() {
            for n in index.nearest(p, ORIENTATION_GRAPH_NEIGHBOURS + 1).unwrap() {
                if let Some(cost) = edge_cost(positions, normals, i, n.index) {
                    lists[i].push((n.index as u32, cost));
                    lists[n.index].push((i as u32, cost));
                }
            }
        }
        for list in &mut lists {
            list.sort_unstable();
            list.dedup();
        }
        lists
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Points near a wavy sheet (many usable edges, some left out for running along
        /// the normals or bending too far), some coincident.
        #[test]
        fn the_graph_lists_every_usable_edge_from_both_ends_once(
            samples in prop::collection::vec(
                (0.0f32..4.0, 0.0f32..4.0, -0.3f32..0.3, -1.0f32..1.0, any::<bool>()),
                2..300,
            ),
        ) {
            let positions: Vec<Vec3> = samples
                .iter()
                .map(|&(x, y, z, _, _)| Vec3::new(x, y, (2.0 * x).sin() + z * (y % 1.0)))
                .collect();
            let normals: Vec<Vec3> = samples
                .iter()
                .map(|&(_, _, _, tilt, flip)| {
                    let n = Vec3::new(tilt, 0.3 * tilt, 1.0).normalize();
                    if flip { -n } else { n }
                })
                .collect();
            let index = KdIndex::new(&positions).unwrap();
            let mut ctx = RunContext::new(0);
            let graph = OrientationGraph::build(&positions, &normals, &index, &mut ctx).unwrap();
            let lists = listed_graph(&positions, &normals);
            prop_assert_eq!(graph.starts.len(), positions.len() + 1);
            prop_assert_eq!(graph.edges.len(), lists.iter().map(Vec::len).sum::<usize>());
            for (i, list) in lists.iter().enumerate() {
                prop_assert_eq!(graph.edges_of(i), list.as_slice(), "point {}", i);
            }
        }
    }
}
