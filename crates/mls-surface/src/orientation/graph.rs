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
/// [`ORIENTATION_GRAPH_NEIGHBOURS`] nearest neighbours, listed once from each end. The
/// points are numbered by their rank along the Z-order curve (`order`), so that points
/// near each other in space are near each other in every array the propagation walks: on
/// points stored in random order, their own numbering sends almost every step of it to
/// memory the processor has not cached.
///
/// A point's edges are the row of its own nearest neighbours (`near`) followed by the
/// edges from points that have it among theirs while it does not have them (`reverse`):
/// the table of neighbours is kept as half of the graph instead of being copied into it.
pub(super) struct OrientationGraph {
    /// The point at each rank.
    pub(super) order: Vec<u32>,
    /// The rank of each point.
    pub(super) rank_of: Vec<u32>,
    /// Each rank's usable edges to its own nearest neighbours.
    near: NearTable,
    /// Where each rank's edges in `reverse` start; one more entry, the end.
    reverse_starts: Vec<usize>,
    /// Every rank's edges from points whose rows list it while its row does not list
    /// them, one rank after another.
    reverse: Vec<Edge>,
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
                    // The point itself and its neighbours. At most `SLOTS` of them are
                    // usable: the point itself never is, and if it is not among those
                    // found, they all lie where it lies, and edges of no length are not.
                    let found = index.nearest(positions[i], NearTable::SLOTS + 1)?;
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
        // The edges a row lists whose other end's row does not list them back (the cost
        // is symmetric, so a listed edge back is the same edge).
        let one_way = || {
            (0..n as u32).flat_map(|r| {
                let near = &near;
                let row = near.row(r).iter();
                row.filter(move |&&(s, _)| !near.lists(s, r))
                    .map(move |&(s, cost)| (r, s, cost))
            })
        };
        // Counted per rank, summed into where each rank's edges end, and filled from
        // there backwards: each rank's entry ends where its edges start.
        let mut reverse_starts = vec![0usize; n + 1];
        for (_, s, _) in one_way() {
            reverse_starts[s as usize] += 1;
        }
        for r in 1..=n {
            reverse_starts[r] += reverse_starts[r - 1];
        }
        let mut reverse = vec![NO_EDGE; reverse_starts[n]];
        for (r, s, cost) in one_way() {
            let end = &mut reverse_starts[s as usize];
            *end -= 1;
            reverse[*end] = (r, cost);
        }
        Ok(Self {
            order,
            rank_of,
            near,
            reverse_starts,
            reverse,
        })
    }

    /// The edges of the point at `rank`, in no particular order.
    pub(super) fn edges_of(&self, rank: u32) -> impl Iterator<Item = &Edge> {
        let at = rank as usize;
        let reverse = &self.reverse[self.reverse_starts[at]..self.reverse_starts[at + 1]];
        self.near.row(rank).iter().chain(reverse)
    }
}

/// Each ranked point's usable edges to its nearest neighbours, a row of
/// [`NearTable::SLOTS`] per rank, [`NO_EDGE`] after the last.
struct NearTable(Vec<Edge>);

impl NearTable {
    /// The most usable edges a point has to its own nearest neighbours: one per
    /// neighbour of the graph.
    const SLOTS: usize = ORIENTATION_GRAPH_NEIGHBOURS;

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
            prop_assert_eq!(graph.reverse_starts.len(), positions.len() + 1);
            for (i, list) in lists.iter().enumerate() {
                prop_assert_eq!(graph.order[graph.rank_of[i] as usize] as usize, i);
                let mut by_point: Vec<Edge> = graph
                    .edges_of(graph.rank_of[i])
                    .map(|&(rank, cost)| (graph.order[rank as usize], cost))
                    .collect();
                by_point.sort_unstable();
                // Sorted and compared whole: no edge twice, none missing.
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
