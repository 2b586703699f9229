//! The graph the orientation propagates over, numbered along the Z-order curve.

use glam::Vec3;
use pointset_core::{KdIndex, Neighbour, RunContext};
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

/// The first slot of a row of [`FoundNeighbours`] whose neighbours the fit could not tell.
const UNSEARCHED: Edge = (u32::MAX, 0);

/// Each ranked point's neighbours in the graph, as a fit of normals found them
/// ([`crate::pca::fit_along`]), so that [`OrientationGraph::build`] need not search again:
/// a row of [`NearTable::SLOTS`] per rank holding the neighbours' indices in the point
/// set (the second half of each slot unused), [`NO_EDGE`] after the last; a row starting
/// with [`UNSEARCHED`] is searched by the graph. The graph turns the rows into its own in
/// place, so keeping them costs no memory the graph does not take anyway.
pub(crate) struct FoundNeighbours(Vec<Edge>);

impl FoundNeighbours {
    /// The nearest points the graph asks for around each point: the point itself and a
    /// neighbour for each slot.
    const ASKED: usize = NearTable::SLOTS + 1;

    /// Rows for `n` points, none searched yet.
    pub(crate) fn unsearched(n: usize) -> Self {
        Self(vec![UNSEARCHED; n * NearTable::SLOTS])
    }

    /// The row of the point `point` from `nearest`, the answer of
    /// `index.nearest(positions[point], asked)`: the points the graph's own question
    /// (the [`Self::ASKED`] nearest) would get, without the point itself, when the answer
    /// settles them, or an [`UNSEARCHED`] row.
    ///
    /// It settles them when it is the same question, when it holds every point of the
    /// set (fewer than asked) and the graph's question would too, or when it holds more
    /// and its [`Self::ASKED`]-th nearest is strictly nearer than the next: the nearest
    /// are then one set whatever order the index finds equidistant points in, and the
    /// graph depends only on the set. Ties there (lattices) leave the row to the graph's
    /// own search.
    pub(crate) fn row_from(
        nearest: &[Neighbour],
        point: usize,
        asked: usize,
    ) -> [Edge; NearTable::SLOTS] {
        let every_point = nearest.len() < asked && nearest.len() <= Self::ASKED;
        let settled = asked == Self::ASKED
            || every_point
            || (nearest.len() > Self::ASKED
                && nearest[Self::ASKED - 1].distance_squared
                    < nearest[Self::ASKED].distance_squared);
        let mut row = [NO_EDGE; NearTable::SLOTS];
        if !settled {
            row[0] = UNSEARCHED;
            return row;
        }
        // When the point itself is not among them, they all lie where it lies and none is
        // usable, so dropping the last changes nothing.
        let others = nearest
            .iter()
            .take(Self::ASKED)
            .filter(|n| n.index != point);
        for (slot, n) in row.iter_mut().zip(others) {
            *slot = (n.index as u32, 0);
        }
        row
    }

    /// Sets the row of the point at `rank`.
    pub(crate) fn set_row(&mut self, rank: usize, row: [Edge; NearTable::SLOTS]) {
        let first = rank * NearTable::SLOTS;
        self.0[first..first + NearTable::SLOTS].copy_from_slice(&row);
    }
}

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
    /// `index`, its points ranked by `order` (`z_order(positions)`). Each rank's
    /// neighbours are those `found` holds for it, or, where it holds none, found here in
    /// parallel; the graph does not depend on which, nor on the threads.
    ///
    /// The points linked are reported to `ctx` under [`LINKING_STAGE`] every
    /// [`ORIENT_REPORT_EVERY`] points, and a cancelled run stops there.
    pub(super) fn build(
        positions: &[Vec3],
        normals: &[Vec3],
        index: &KdIndex,
        order: Vec<usize>,
        found: FoundNeighbours,
        ctx: &mut RunContext,
    ) -> Result<Self> {
        const CHUNK: usize = ORIENT_REPORT_EVERY as usize;
        let n = positions.len();
        // The caller checked that the points fit in `u32`.
        let order: Vec<u32> = order.into_iter().map(|i| i as u32).collect();
        let mut rank_of = vec![0u32; n];
        for (rank, &point) in order.iter().enumerate() {
            rank_of[point as usize] = rank as u32;
        }
        // Each row of neighbours' indices becomes, in place, the row of usable edges.
        let mut near = NearTable(found.0);
        let rows = near.0.chunks_mut(NearTable::SLOTS * CHUNK);
        for (chunk, (table, points)) in rows.zip(order.chunks(CHUNK)).enumerate() {
            ctx.check_cancelled()?;
            table
                .par_chunks_mut(NearTable::SLOTS)
                .zip(points.par_iter())
                .try_for_each(|(slots, &i)| -> Result<()> {
                    let i = i as usize;
                    let (neighbours, count) = neighbours_of(slots, i, positions, index)?;
                    let usable = neighbours[..count].iter().filter_map(|&j| {
                        let j = j as usize;
                        let cost = edge_cost(positions, normals, i, j)?;
                        Some((rank_of[j], cost))
                    });
                    slots.fill(NO_EDGE);
                    for (slot, edge) in slots.iter_mut().zip(usable) {
                        *slot = edge;
                    }
                    Ok(())
                })?;
            let done = (chunk * CHUNK + points.len()) as u64;
            ctx.report(LINKING_STAGE, done, Some(n as u64));
        }
        // The edges a row lists whose other end's row does not list them back (the cost
        // is symmetric, so a listed edge back is the same edge): found in parallel, a bit
        // per slot (a row has at most 8), then read in rank order.
        const _: () = assert!(NearTable::SLOTS <= 8);
        let unlisted: Vec<u8> = (0..n as u32)
            .into_par_iter()
            .map(|r| {
                let row = near.row(r).iter().enumerate();
                row.filter(|&(_, &(s, _))| !near.lists(s, r))
                    .fold(0u8, |bits, (slot, _)| bits | (1 << slot))
            })
            .collect();
        let one_way = || {
            unlisted.iter().zip(0u32..).flat_map(|(&bits, r)| {
                let row = near.row(r).iter().enumerate();
                row.filter(move |&(slot, _)| bits & (1 << slot) != 0)
                    .map(move |(_, &(s, cost))| (r, s, cost))
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

/// The indices of the neighbours the point `i` is linked to from its row `slots` of
/// [`FoundNeighbours`], and how many there are: those the row holds, or, for an
/// [`UNSEARCHED`] row, the [`FoundNeighbours::ASKED`] nearest (the point itself among
/// them, unless they all lie where it lies: edges of no length are not usable, and the
/// point's own never is).
fn neighbours_of(
    slots: &[Edge],
    i: usize,
    positions: &[Vec3],
    index: &KdIndex,
) -> Result<([u32; FoundNeighbours::ASKED], usize)> {
    Ok(if slots[0] == UNSEARCHED {
        let nearest = index.nearest(positions[i], FoundNeighbours::ASKED)?;
        held(nearest.iter().map(|n| n.index as u32))
    } else {
        held(
            slots
                .iter()
                .take_while(|&&slot| slot != NO_EDGE)
                .map(|&(j, _)| j),
        )
    })
}

/// The first [`FoundNeighbours::ASKED`] of `indices` in an array, and how many there are.
fn held(indices: impl Iterator<Item = u32>) -> ([u32; FoundNeighbours::ASKED], usize) {
    let mut neighbours = [u32::MAX; FoundNeighbours::ASKED];
    let mut count = 0;
    for (slot, j) in neighbours.iter_mut().zip(indices) {
        *slot = j;
        count += 1;
    }
    (neighbours, count)
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

    use pointset_core::spatial::z_order;
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

    /// Every point's edges, by the points' own indices, sorted.
    fn edges_by_point(graph: &OrientationGraph) -> Vec<Vec<Edge>> {
        let by_point = |i: usize| {
            let mut edges: Vec<Edge> = graph
                .edges_of(graph.rank_of[i])
                .map(|&(rank, cost)| (graph.order[rank as usize], cost))
                .collect();
            edges.sort_unstable();
            edges
        };
        (0..graph.rank_of.len()).map(by_point).collect()
    }

    /// A point, its 6 neighbours at distance 1 along the axes and 5 of the 12 at √2:
    /// the 9 nearest (the point itself among them) end among the ones at √2.
    fn tied_at_the_ninth() -> Vec<Vec3> {
        let mut p = vec![
            Vec3::ZERO,
            Vec3::X,
            -Vec3::X,
            Vec3::Y,
            -Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
        ];
        p.extend(
            [
                (1., 1., 0.),
                (1., -1., 0.),
                (-1., 1., 0.),
                (0., 1., 1.),
                (0., -1., -1.),
            ]
            .map(Vec3::from),
        );
        p
    }

    #[test]
    fn a_fit_settles_the_rows_it_can_and_leaves_the_rest_unsearched() {
        let tied = tied_at_the_ninth();
        let index = KdIndex::new(&tied).unwrap();
        let row = |asked: usize| {
            FoundNeighbours::row_from(&index.nearest(Vec3::ZERO, asked).unwrap(), 0, asked)
        };
        // The same question as the graph's: the 8 others it finds, whichever they are.
        let same = row(FoundNeighbours::ASKED);
        assert!(same.iter().all(|&(j, _)| j != 0 && j != u32::MAX));
        // More asked, all 12 found (fewer than asked), but the 9th and 10th are equally
        // far: the graph must choose for itself.
        assert_eq!(row(15)[0], UNSEARCHED);
        assert_eq!(row(11)[0], UNSEARCHED);
        // Fewer asked than the graph asks: unsettled.
        assert_eq!(row(6)[0], UNSEARCHED);
        // Without the tie (the last point moved out to distance 3): settled, the 8
        // nearest others.
        let mut apart = tied;
        apart[11] = Vec3::new(0.0, 0.0, 3.0);
        apart[10] = Vec3::new(0.0, 2.0, 2.0);
        apart[9] = Vec3::new(0.0, 2.0, 0.0);
        let index = KdIndex::new(&apart).unwrap();
        let nearest = index.nearest(Vec3::ZERO, 15).unwrap();
        let mut held: Vec<u32> = FoundNeighbours::row_from(&nearest, 0, 15)
            .iter()
            .map(|&(j, _)| j)
            .collect();
        held.sort_unstable();
        assert_eq!(held, [1, 2, 3, 4, 5, 6, 7, 8]);
        // Every point of a small set found, as the graph's own question would find them.
        let few = &apart[..5];
        let index = KdIndex::new(few).unwrap();
        let nearest = index.nearest(Vec3::ZERO, 12).unwrap();
        let few_row = FoundNeighbours::row_from(&nearest, 0, 12);
        assert_eq!(
            few_row[..4].iter().map(|&(j, _)| j).collect::<Vec<_>>(),
            [1, 2, 3, 4]
        );
        assert_eq!(few_row[4], NO_EDGE);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Points on a coarse lattice, many of them repeated, so that the 9th and 10th
        /// nearest are often equally far and a fit's neighbours do not settle the graph's:
        /// the graph built from a fit's rows of any `k` is the graph built by searching.
        #[test]
        fn rows_from_a_fit_give_the_graph_a_search_gives(
            cells in prop::collection::vec((0u8..6, 0u8..6, 0u8..2, -1.0f32..1.0), 3..200),
            k in 3usize..16,
        ) {
            let positions: Vec<Vec3> = cells
                .iter()
                .map(|&(x, y, z, _)| Vec3::new(f32::from(x), f32::from(y), 0.25 * f32::from(z)))
                .collect();
            let normals: Vec<Vec3> = cells
                .iter()
                .map(|&(_, _, _, tilt)| Vec3::new(tilt, 0.2, 1.0).normalize())
                .collect();
            let index = KdIndex::new(&positions).unwrap();
            let order = z_order(&positions);
            let mut found = FoundNeighbours::unsearched(positions.len());
            for (rank, &i) in order.iter().enumerate() {
                let nearest = index.nearest(positions[i], k).unwrap();
                found.set_row(rank, FoundNeighbours::row_from(&nearest, i, k));
            }
            let mut ctx = RunContext::new(0);
            let from_fit =
                OrientationGraph::build(&positions, &normals, &index, order.clone(), found, &mut ctx)
                    .unwrap();
            let unsearched = FoundNeighbours::unsearched(positions.len());
            let searched =
                OrientationGraph::build(&positions, &normals, &index, order, unsearched, &mut ctx)
                    .unwrap();
            prop_assert_eq!(edges_by_point(&from_fit), edges_by_point(&searched));
        }

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
            let unsearched = FoundNeighbours::unsearched(positions.len());
            let order = z_order(&positions);
            let graph =
                OrientationGraph::build(&positions, &normals, &index, order, unsearched, &mut ctx)
                    .unwrap();
            let lists = listed_graph(&positions, &normals);
            prop_assert_eq!(graph.reverse_starts.len(), positions.len() + 1);
            for (i, list) in lists.iter().enumerate() {
                prop_assert_eq!(graph.order[graph.rank_of[i] as usize] as usize, i);
                // Sorted and compared whole: no edge twice, none missing.
                prop_assert_eq!(&edges_by_point(&graph)[i], list, "point {}", i);
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
