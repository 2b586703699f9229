//! The graph the orientation propagates over, numbered along the Z-order curve.

use glam::Vec3;
use pointset_core::spatial::z_order;
use pointset_core::{KdIndex, RunContext};
use rayon::prelude::*;

use super::{LINKING_STAGE, ORIENT_REPORT_EVERY, ORIENTATION_GRAPH_NEIGHBOURS};
use crate::error::Result;

/// The largest share of a graph edge's length that may run along either end's normal in
/// [`super::orient_normals`]: neighbours on one sheet lie nearly in each other's tangent
/// plane, while two sheets facing each other across a thin gap lie along the normal.
const MAX_EDGE_ACROSS: f32 = 0.5;

/// The smallest `|n_i · n_j|` of an edge of [`super::orient_normals`]' graph: normals
/// nearly at right angles (a stem standing on a base) say nothing about which way either
/// faces.
const MIN_EDGE_COSINE: f32 = 0.25;

/// An edge of the graph: the other end's rank and the cost of crossing.
pub(super) type Edge = (u32, u32);

/// A slot of [`OrientationGraph::build`]'s table of nearest neighbours with no usable edge.
const NO_EDGE: Edge = (u32::MAX, u32::MAX);

/// [`super::orient_normals`]' graph: every usable edge between a point and one of its
/// [`ORIENTATION_GRAPH_NEIGHBOURS`] nearest neighbours, listed once from each end, all in
/// one array. The points are numbered by their rank along the Z-order curve (`order`),
/// so that points near each other in space are near each other in every array the
/// propagation walks: on points stored in random order, their own numbering sends
/// almost every step of it to memory the processor has not cached.
pub(super) struct OrientationGraph {
    /// The point at each rank.
    pub(super) order: Vec<u32>,
    /// The rank of each point.
    pub(super) rank_of: Vec<u32>,
    /// Where each rank's edges start in `edges`; one more entry, the end.
    starts: Vec<usize>,
    /// Every rank's edges, one rank after another.
    edges: Vec<Edge>,
}

impl OrientationGraph {
    /// The graph of `positions` (at most `u32::MAX` of them) with `normals`, indexed by
    /// `index`. The neighbours are found in parallel; the graph does not depend on the
    /// threads.
    ///
    /// The points' neighbours are reported to `ctx` under [`LINKING_STAGE`] every
    /// [`ORIENT_REPORT_EVERY`] points, and a cancelled run stops there.
    pub(super) fn build(
        positions: &[Vec3],
        normals: &[Vec3],
        index: &KdIndex,
        ctx: &mut RunContext,
    ) -> Result<Self> {
        const CHUNK: usize = ORIENT_REPORT_EVERY as usize;
        let n = positions.len();
        // The caller checked that the points fit in `u32`.
        let order: Vec<u32> = z_order(positions).into_iter().map(|i| i as u32).collect();
        let mut rank_of = vec![0u32; n];
        for (rank, &point) in order.iter().enumerate() {
            rank_of[point as usize] = rank as u32;
        }
        let mut near = NearTable(vec![NO_EDGE; n * NearTable::SLOTS]);
        let rows = near.0.chunks_mut(NearTable::SLOTS * CHUNK);
        for (chunk, (table, points)) in rows.zip(order.chunks(CHUNK)).enumerate() {
            ctx.check_cancelled()?;
            table
                .par_chunks_mut(NearTable::SLOTS)
                .zip(points.par_iter())
                .try_for_each(|(slots, &i)| -> Result<()> {
                    let i = i as usize;
                    let found = index.nearest(positions[i], NearTable::SLOTS)?;
                    let usable = found.iter().filter_map(|neighbour| {
                        let cost = edge_cost(positions, normals, i, neighbour.index)?;
                        Some((rank_of[neighbour.index], cost))
                    });
                    for (slot, edge) in slots.iter_mut().zip(usable) {
                        *slot = edge;
                    }
                    Ok(())
                })?;
            let done = (chunk * CHUNK + points.len()) as u64;
            ctx.report(LINKING_STAGE, done, Some(n as u64));
        }
        // Each row's edges go into its own list, and into the other end's list unless the
        // other end's row has the same edge (the cost is symmetric) to put there itself.
        let listed = || {
            (0..n as u32).flat_map(|r| {
                let near = &near;
                near.row(r)
                    .iter()
                    .map(move |&(s, cost)| (r, s, cost, !near.lists(s, r)))
            })
        };
        let mut starts = vec![0usize; n + 1];
        for (r, s, _, both) in listed() {
            starts[r as usize + 1] += 1;
            if both {
                starts[s as usize + 1] += 1;
            }
        }
        for r in 0..n {
            starts[r + 1] += starts[r];
        }
        let mut edges = vec![NO_EDGE; starts[n]];
        let mut filled = starts[..n].to_vec();
        for (r, s, cost, both) in listed() {
            let (r, s) = (r as usize, s as usize);
            edges[filled[r]] = (s as u32, cost);
            filled[r] += 1;
            if both {
                edges[filled[s]] = (r as u32, cost);
                filled[s] += 1;
            }
        }
        Ok(Self {
            order,
            rank_of,
            starts,
            edges,
        })
    }

    /// The edges of the point at `rank`, in no particular order.
    pub(super) fn edges_of(&self, rank: u32) -> &[Edge] {
        let rank = rank as usize;
        &self.edges[self.starts[rank]..self.starts[rank + 1]]
    }
}

/// Each ranked point's usable edges to its nearest neighbours (itself among them, never
/// usable), a row of [`NearTable::SLOTS`] per rank, [`NO_EDGE`] after the last.
struct NearTable(Vec<Edge>);

impl NearTable {
    /// Neighbours asked per point: the graph's, and the point itself.
    const SLOTS: usize = ORIENTATION_GRAPH_NEIGHBOURS + 1;

    /// The usable edges of the point at `rank`.
    fn row(&self, rank: u32) -> &[Edge] {
        let first = rank as usize * Self::SLOTS;
        let slots = &self.0[first..first + Self::SLOTS];
        let used = slots.iter().take_while(|&&edge| edge != NO_EDGE).count();
        &slots[..used]
    }

    /// Whether the row of `rank` has an edge to `other`.
    fn lists(&self, rank: u32, other: u32) -> bool {
        self.row(rank).iter().any(|&(end, _)| end == other)
    }
}

/// The cost of carrying the orientation from `i` to `j`: `1 − |n_i · n_j|` (Hoppe et al.)
/// plus the share of the edge that runs along the normals, so that links within one sheet
/// are taken before links that jump between sheets; `None` for edges that run mostly along
/// the normals. Scaled to integers for the heap. The same both ways, bit for bit (the
/// offset's sign is lost to `abs`, and the rest does not depend on the order).
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
                prop_assert_eq!(graph.order[graph.rank_of[i] as usize] as usize, i);
                let mut by_point: Vec<Edge> = graph
                    .edges_of(graph.rank_of[i])
                    .iter()
                    .map(|&(rank, cost)| (graph.order[rank as usize], cost))
                    .collect();
                by_point.sort_unstable();
                prop_assert_eq!(by_point, list.clone(), "point {}", i);
            }
        }

        /// The cost does not depend on which end it is asked from.
        #[test]
        fn the_cost_is_the_same_both_ways(
            a in prop::array::uniform3(-10.0f32..10.0),
            b in prop::array::uniform3(-10.0f32..10.0),
            na in prop::array::uniform3(-1.0f32..1.0),
            nb in prop::array::uniform3(-1.0f32..1.0),
        ) {
            let positions = [Vec3::from(a), Vec3::from(b)];
            let normals = [Vec3::from(na).normalize_or(Vec3::Z), Vec3::from(nb).normalize_or(Vec3::X)];
            prop_assert_eq!(
                edge_cost(&positions, &normals, 0, 1),
                edge_cost(&positions, &normals, 1, 0)
            );
        }
    }
}
