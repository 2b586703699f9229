//! Regions of far nodes that the nearest-sign search signed against the band.
//!
//! [`FarSigns::Nearest`](crate::far_signs::FarSigns::Nearest) gives each far node the sign
//! of the answered nodes nearest to it. A few wrong answered nodes at the band's edge
//! (beside a part thinner than the kernel, past a sheet's rim) then sign the whole of the
//! free space beyond them, since nothing else is nearer there: a cone or slab of the wrong
//! sign that reaches the grid's side, bounded by the far nodes' bisector planes, which the
//! iso-surface shows as large flat sheets (the chameleon scan at 160–192 nodes).
//!
//! Between two nodes with different signs the iso-surface puts a piece of surface. Where
//! both nodes are far, or one is far and the other answered, no surface was found there,
//! so every such node face is a *conflict*. [`flip_unsupported_regions`] lowers their
//! number: a 6-connected region of far nodes of one sign whose conflicts outnumber its
//! faces with answered nodes of its own sign (its *support*) takes the other sign and
//! joins the regions around it. Each flip lowers the count of conflicts by the region's
//! excess, so the merging ends; the region with the largest excess goes first, the lowest
//! numbered on a tie. A region that truly lies inside or outside is bordered by answered
//! nodes of its sign nearly everywhere (a hole in the band joins it to the other side only
//! across the hole), and keeps its sign.

use std::collections::BTreeMap;

use glam::Vec4;
use rayon::prelude::*;

/// Marks a node that belongs to no region (an answered node).
const NO_REGION: u32 = u32::MAX;

/// A region of far nodes of one sign, or a union of such regions merged by a flip.
struct Region {
    /// Whether its nodes are inside.
    inside: bool,
    /// Node faces between its nodes and answered nodes of its sign.
    support: u64,
    /// Node faces between its nodes and answered nodes of the other sign.
    answered_conflict: u64,
    /// Node faces between its nodes and those of each other region (all of the other sign),
    /// keyed by that region's number. Empty for a region merged into another.
    contacts: BTreeMap<u32, u64>,
    /// The region it was merged into; itself while it stands.
    merged_into: u32,
}

impl Region {
    /// How many more conflicts than supports it has.
    fn excess(&self) -> i128 {
        let conflict = self.answered_conflict + self.contacts.values().sum::<u64>();
        i128::from(conflict) - i128::from(self.support)
    }
}

/// Flips the far nodes' regions that the band does not support (module docs). `far` marks
/// the nodes that had no answer; their values are `±band` with the search's signs, and
/// keep their magnitudes. Grids of more than `u32::MAX − 1` nodes are left as they are.
pub(crate) fn flip_unsupported_regions(data: &mut [Vec4], far: &[bool], dims: [usize; 3]) {
    let Some((labels, mut regions)) = label_regions(data, far, dims) else {
        return;
    };
    while let Some(worst) = (0..regions.len())
        .filter(|&r| regions[r].merged_into as usize == r && regions[r].excess() > 0)
        .max_by_key(|&r| (regions[r].excess(), std::cmp::Reverse(r)))
    {
        flip_and_merge(&mut regions, worst);
    }
    // Each region's final sign once (a merge chain can be as long as the flips were many).
    let inside: Vec<bool> = (0..regions.len() as u32)
        .map(|r| regions[standing(&regions, r) as usize].inside)
        .collect();
    for (value, &label) in data.iter_mut().zip(&labels) {
        if label != NO_REGION {
            value.x = if inside[label as usize] {
                -value.x.abs()
            } else {
                value.x.abs()
            };
        }
    }
}

/// The region that `region` now belongs to, following merges.
fn standing(regions: &[Region], mut region: u32) -> u32 {
    while regions[region as usize].merged_into != region {
        region = regions[region as usize].merged_into;
    }
    region
}

/// Flips region `r` and merges it with every region it touches (all of which then share
/// its new sign) into `r`.
fn flip_and_merge(regions: &mut [Region], r: usize) {
    let flipped = &mut regions[r];
    flipped.inside = !flipped.inside;
    std::mem::swap(&mut flipped.support, &mut flipped.answered_conflict);
    let absorbed: Vec<u32> = std::mem::take(&mut flipped.contacts).into_keys().collect();
    let id = r as u32;
    let mut contacts = BTreeMap::new();
    for &q in &absorbed {
        let region = &mut regions[q as usize];
        region.merged_into = id;
        let (support, conflict) = (region.support, region.answered_conflict);
        for (other, count) in std::mem::take(&mut region.contacts) {
            if other != id && !absorbed.contains(&other) {
                *contacts.entry(other).or_insert(0) += count;
            }
        }
        regions[r].support += support;
        regions[r].answered_conflict += conflict;
    }
    // The regions beyond now touch `r` in place of the ones it absorbed.
    for (&other, &count) in &contacts {
        let beyond = &mut regions[other as usize].contacts;
        beyond.retain(|q, _| !absorbed.contains(q) && *q != id);
        beyond.insert(id, count);
    }
    regions[r].contacts = contacts;
}

/// A node's class for the labelling: answered or far, inside or outside.
#[derive(Clone, Copy, PartialEq, Eq)]
struct Class {
    far: bool,
    inside: bool,
}

/// A run of far nodes of one class along x: nodes `start..end` of a row (x indices).
#[derive(Clone, Copy)]
struct Run {
    start: usize,
    end: usize,
    class: Class,
}

/// Labels the 6-connected regions of far nodes of one sign and counts their faces with
/// answered nodes and with one another. Each row's far nodes are taken as runs of one
/// class; a union-find over the runs joins every run to the overlapping runs of its class
/// in the row before it (along y) and in the layer before it (along z). Then one pass over
/// the node faces, a layer at a time in parallel. Regions are numbered in the order of
/// their first node (a union keeps the lower run, and runs are in node order). `None` when
/// the grid has too many nodes to number.
fn label_regions(
    data: &[Vec4],
    far: &[bool],
    [nx, ny, nz]: [usize; 3],
) -> Option<(Vec<u32>, Vec<Region>)> {
    if data.len() >= NO_REGION as usize || data.len() != nx * ny * nz {
        return None;
    }
    let class: Vec<Class> = data
        .par_iter()
        .zip(far)
        .map(|(value, &far)| Class {
            far,
            inside: value.x < 0.0,
        })
        .collect();
    let rows: Vec<Vec<Run>> = class.par_chunks(nx).map(runs_of_row).collect();
    // `first[r]..first[r + 1]` are row r's runs in `runs`; fewer runs than nodes.
    let mut first = Vec::with_capacity(rows.len() + 1);
    first.push(0);
    for row in &rows {
        first.push(first.last().copied().unwrap_or(0) + row.len());
    }
    let runs: Vec<Run> = rows.into_iter().flatten().collect();
    let mut parent: Vec<u32> = (0..runs.len() as u32).collect();
    let row_runs = |r: usize| first[r]..first[r + 1];
    for r in 0..ny * nz {
        let (j, k) = (r % ny, r / ny);
        for (has, before) in [(j > 0, r.wrapping_sub(1)), (k > 0, r.wrapping_sub(ny))] {
            if has {
                join_overlapping(&mut parent, &runs, row_runs(r), row_runs(before));
            }
        }
    }
    // Number the roots in order and label every run with its root's number, in place: a
    // parent lies before its child (a union keeps the lower root, a halving points to a
    // grandparent), so it is already relabelled when the child comes.
    let mut run_labels = parent;
    let mut regions: Vec<Region> = Vec::new();
    for (id, run) in runs.iter().enumerate() {
        run_labels[id] = if run_labels[id] as usize == id {
            let number = regions.len() as u32;
            regions.push(Region {
                inside: run.class.inside,
                support: 0,
                answered_conflict: 0,
                contacts: BTreeMap::new(),
                merged_into: number,
            });
            number
        } else {
            run_labels[run_labels[id] as usize]
        };
    }
    let mut labels = vec![NO_REGION; data.len()];
    labels.par_chunks_mut(nx).enumerate().for_each(|(r, row)| {
        for id in row_runs(r) {
            row[runs[id].start..runs[id].end].fill(run_labels[id]);
        }
    });
    let faces = (0..nz)
        .into_par_iter()
        .map(|k| layer_faces(&class, &labels, [nx, ny, nz], k))
        .reduce(LayerFaces::default, LayerFaces::join);
    for (label, same_sign) in faces.with_answered {
        let region = &mut regions[label as usize];
        if same_sign {
            region.support += 1;
        } else {
            region.answered_conflict += 1;
        }
    }
    let mut between = faces.between;
    between.sort_unstable();
    for pair in between.chunk_by(|a, b| a == b) {
        let (a, b) = pair[0];
        let count = pair.len() as u64;
        regions[a as usize].contacts.insert(b, count);
        regions[b as usize].contacts.insert(a, count);
    }
    Some((labels, regions))
}

/// The runs of far nodes of one class in a row of node classes.
fn runs_of_row(row: &[Class]) -> Vec<Run> {
    let mut runs = Vec::new();
    let mut start = 0;
    for piece in row.chunk_by(|a, b| a == b) {
        let end = start + piece.len();
        if piece[0].far {
            runs.push(Run {
                start,
                end,
                class: piece[0],
            });
        }
        start = end;
    }
    runs
}

/// Joins each run of `here` to the runs of `before` (another row's, in `runs`) that
/// overlap it in x and have its class.
fn join_overlapping(
    parent: &mut [u32],
    runs: &[Run],
    here: std::ops::Range<usize>,
    before: std::ops::Range<usize>,
) {
    let (mut a, mut b) = (here.start, before.start);
    while a < here.end && b < before.end {
        let (x, y) = (runs[a], runs[b]);
        if x.class == y.class && x.start < y.end && y.start < x.end {
            union(parent, a, b);
        }
        if x.end <= y.end {
            a += 1;
        } else {
            b += 1;
        }
    }
}

/// The node faces of one layer's nodes with their neighbours after them along x, y and z
/// that involve a far node: faces with answered nodes (the far node's region, and whether
/// the signs agree), and faces between far nodes of different signs (the two regions,
/// lower first).
#[derive(Default)]
struct LayerFaces {
    with_answered: Vec<(u32, bool)>,
    between: Vec<(u32, u32)>,
}

impl LayerFaces {
    /// Both layers' faces.
    fn join(mut self, mut other: Self) -> Self {
        self.with_answered.append(&mut other.with_answered);
        self.between.append(&mut other.between);
        self
    }
}

/// [`LayerFaces`] of layer `k`.
fn layer_faces(class: &[Class], labels: &[u32], [nx, ny, nz]: [usize; 3], k: usize) -> LayerFaces {
    let mut faces = LayerFaces::default();
    let (row, slice) = (nx, nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let n = i + row * j + slice * k;
            for (has, step) in [(i + 1 < nx, 1), (j + 1 < ny, row), (k + 1 < nz, slice)] {
                let m = n + step;
                if !has || !(class[n].far || class[m].far) {
                    continue;
                }
                let same_sign = class[n].inside == class[m].inside;
                match (class[n].far, class[m].far) {
                    (true, true) if !same_sign => {
                        let (x, y) = (labels[n], labels[m]);
                        faces.between.push((x.min(y), x.max(y)));
                    }
                    (true, false) => faces.with_answered.push((labels[n], same_sign)),
                    (false, true) => faces.with_answered.push((labels[m], same_sign)),
                    _ => {}
                }
            }
        }
    }
    faces
}

/// The root of node `n`'s set, halving the path on the way.
fn find(parent: &mut [u32], mut n: usize) -> usize {
    while parent[n] as usize != n {
        let grandparent = parent[parent[n] as usize];
        parent[n] = grandparent;
        n = grandparent as usize;
    }
    n
}

/// Joins the sets of nodes `a` and `b` under the lower-numbered root.
fn union(parent: &mut [u32], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        // Both are node indices, which fit (`label_regions`).
        parent[ra.max(rb)] = ra.min(rb) as u32;
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use proptest::prelude::*;

    use super::*;
    use crate::far_signs::six_neighbours;

    /// Node faces across which the sign changes with a far node on either side.
    fn conflicts(data: &[Vec4], far: &[bool], dims: [usize; 3]) -> usize {
        (0..data.len())
            .flat_map(|n| {
                six_neighbours(n, dims)
                    .into_iter()
                    .flatten()
                    .map(move |m| (n, m))
            })
            .filter(|&(n, m)| n < m && (far[n] || far[m]))
            .filter(|&(n, m)| (data[n].x < 0.0) != (data[m].x < 0.0))
            .count()
    }

    /// A grid of `dims` whose nodes are answered (`±0.5`) or far (`±2`), from `cells`:
    /// 0 answered inside, 1 answered outside, 2 far inside, 3 far outside.
    fn grid(cells: &[u8]) -> (Vec<Vec4>, Vec<bool>) {
        let value = |c: u8| match c {
            0 => -0.5,
            1 => 0.5,
            2 => -2.0,
            _ => 2.0,
        };
        let data = cells
            .iter()
            .map(|&c| Vec4::new(value(c), 0.0, 0.0, 0.0))
            .collect();
        (data, cells.iter().map(|&c| c >= 2).collect())
    }

    proptest! {
        #[test]
        fn flips_leave_no_region_with_more_conflicts_than_support(
            (dims, cells) in (1usize..7, 1usize..7, 1usize..5).prop_flat_map(|(x, y, z)| {
                (Just([x, y, z]), proptest::collection::vec(0u8..4, x * y * z))
            })
        ) {
            let (mut data, far) = grid(&cells);
            let before = data.clone();
            let conflicts_before = conflicts(&data, &far, dims);
            flip_unsupported_regions(&mut data, &far, dims);
            for n in 0..data.len() {
                prop_assert_eq!(data[n].x.abs(), before[n].x.abs());
                if !far[n] {
                    prop_assert_eq!(data[n], before[n], "answered node {} changed", n);
                }
            }
            prop_assert!(conflicts(&data, &far, dims) <= conflicts_before);
            let (_, regions) = label_regions(&data, &far, dims).unwrap();
            for (r, region) in regions.iter().enumerate() {
                prop_assert!(region.excess() <= 0, "region {} keeps an excess of {}", r, region.excess());
            }
        }
    }

    /// The regions of `data` found one node at a time: a flood fill from each far node
    /// not yet labelled, in node order, then every node face counted.
    fn regions_by_flood_fill(
        data: &[Vec4],
        far: &[bool],
        dims: [usize; 3],
    ) -> (Vec<u32>, Vec<Region>) {
        let inside = |n: usize| data[n].x < 0.0;
        let mut labels = vec![NO_REGION; data.len()];
        let mut regions = Vec::new();
        for seed in 0..data.len() {
            if !far[seed] || labels[seed] != NO_REGION {
                continue;
            }
            let id = regions.len() as u32;
            regions.push(Region {
                inside: inside(seed),
                support: 0,
                answered_conflict: 0,
                contacts: BTreeMap::new(),
                merged_into: id,
            });
            labels[seed] = id;
            let mut pending = vec![seed];
            while let Some(n) = pending.pop() {
                for m in six_neighbours(n, dims).into_iter().flatten() {
                    if far[m] && labels[m] == NO_REGION && inside(m) == inside(n) {
                        labels[m] = id;
                        pending.push(m);
                    }
                }
            }
        }
        for n in 0..data.len() {
            for m in six_neighbours(n, dims).into_iter().flatten() {
                if !far[n] {
                    continue;
                }
                let region = &mut regions[labels[n] as usize];
                match (far[m], inside(m) == inside(n)) {
                    (false, true) => region.support += 1,
                    (false, false) => region.answered_conflict += 1,
                    (true, false) => *region.contacts.entry(labels[m]).or_insert(0) += 1,
                    (true, true) => {}
                }
            }
        }
        (labels, regions)
    }

    proptest! {
        /// The runs' union-find and the layers' face counts give the labels, signs and
        /// counts of a flood fill node by node.
        #[test]
        fn regions_by_runs_are_those_of_a_flood_fill(
            (dims, cells) in (1usize..8, 1usize..8, 1usize..6).prop_flat_map(|(x, y, z)| {
                (Just([x, y, z]), proptest::collection::vec(0u8..4, x * y * z))
            })
        ) {
            let (data, far) = grid(&cells);
            let (labels, regions) = label_regions(&data, &far, dims).unwrap();
            let (expected_labels, expected) = regions_by_flood_fill(&data, &far, dims);
            prop_assert_eq!(labels, expected_labels);
            prop_assert_eq!(regions.len(), expected.len());
            for (region, expected) in regions.iter().zip(expected) {
                prop_assert_eq!(region.inside, expected.inside);
                prop_assert_eq!(region.support, expected.support);
                prop_assert_eq!(region.answered_conflict, expected.answered_conflict);
                prop_assert_eq!(&region.contacts, &expected.contacts);
                prop_assert_eq!(region.merged_into, expected.merged_into);
            }
        }
    }

    #[test]
    fn a_region_between_two_others_flips_first_and_joins_them() {
        // One row: answered outside, far outside, far inside × 5, far outside, answered
        // outside. The inside run touches no answered node; each outside run has one face
        // with an answered outside node and one with the inside run. The inside run goes
        // (excess 2), and the three runs become one outside region.
        let cells = [1, 3, 2, 2, 2, 2, 2, 3, 1];
        let (mut data, far) = grid(&cells);
        flip_unsupported_regions(&mut data, &far, [cells.len(), 1, 1]);
        assert!(data.iter().all(|v| v.x > 0.0));
        assert_eq!(data[4].x, 2.0);
    }
}
