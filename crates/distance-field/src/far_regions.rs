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

/// Labels the 6-connected regions of far nodes of one sign and counts their faces with
/// answered nodes and with one another: a union-find over the nodes, joining each far node
/// to its lower neighbours along x, y and z of the same sign, then one pass over the node
/// faces. Regions are numbered in the order of their first node. `None` when the grid has
/// too many nodes to number.
fn label_regions(
    data: &[Vec4],
    far: &[bool],
    [nx, ny, nz]: [usize; 3],
) -> Option<(Vec<u32>, Vec<Region>)> {
    if data.len() >= NO_REGION as usize {
        return None;
    }
    let inside = |n: usize| data[n].x < 0.0;
    let joined = |n: usize, m: usize| far[m] && inside(m) == inside(n);
    // Fewer nodes than `NO_REGION`, so every index fits.
    let mut parent: Vec<u32> = (0..data.len() as u32).collect();
    let (row, slice) = (nx, nx * ny);
    for (n, [i, j, k]) in nodes([nx, ny, nz]) {
        if !far[n] {
            continue;
        }
        for (has, step) in [(i > 0, 1), (j > 0, row), (k > 0, slice)] {
            if has && joined(n, n - step) {
                union(&mut parent, n, n - step);
            }
        }
    }
    // Number the roots in order and label every far node with its root's number, in
    // place: a parent lies before its child (a union keeps the lower root, a halving
    // points to a grandparent), so it is already relabelled when the child comes.
    let mut labels = parent;
    let mut regions: Vec<Region> = Vec::new();
    for n in 0..data.len() {
        labels[n] = if !far[n] {
            NO_REGION
        } else if labels[n] as usize == n {
            let id = regions.len() as u32;
            regions.push(Region {
                inside: inside(n),
                support: 0,
                answered_conflict: 0,
                contacts: BTreeMap::new(),
                merged_into: id,
            });
            id
        } else {
            labels[labels[n] as usize]
        };
    }
    let mut between = Vec::new();
    for (n, [i, j, k]) in nodes([nx, ny, nz]) {
        for (has, step) in [(i + 1 < nx, 1), (j + 1 < ny, row), (k + 1 < nz, slice)] {
            let m = n + step;
            if !has || !(far[n] || far[m]) {
                continue;
            }
            let same_sign = inside(n) == inside(m);
            match (far[n], far[m]) {
                (true, true) if !same_sign => {
                    between.push((labels[n].min(labels[m]), labels[n].max(labels[m])));
                }
                (true, true) => {}
                (true, false) | (false, true) => {
                    let region = &mut regions[labels[if far[n] { n } else { m }] as usize];
                    if same_sign {
                        region.support += 1;
                    } else {
                        region.answered_conflict += 1;
                    }
                }
                (false, false) => {}
            }
        }
    }
    between.sort_unstable();
    for pair in between.chunk_by(|a, b| a == b) {
        let (a, b) = pair[0];
        let count = pair.len() as u64;
        regions[a as usize].contacts.insert(b, count);
        regions[b as usize].contacts.insert(a, count);
    }
    Some((labels, regions))
}

/// Every node of a grid of `dims` nodes with its index and coordinates, x fastest.
fn nodes([nx, ny, nz]: [usize; 3]) -> impl Iterator<Item = (usize, [usize; 3])> {
    (0..nz)
        .flat_map(move |k| (0..ny).flat_map(move |j| (0..nx).map(move |i| [i, j, k])))
        .enumerate()
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
