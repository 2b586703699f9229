//! The far nodes of a grid in the order of the nearest-sign search's waves.
//!
//! [`FarSigns::Nearest`](crate::far_signs::FarSigns::Nearest) signs the far nodes in waves
//! of a breadth-first search from the answered nodes over 6-connected steps: wave `w`
//! holds the far nodes `w` steps from the nearest answered node. Every node of the grid
//! can be stepped through, and a box of nodes holds a path of `|Δi| + |Δj| + |Δk|` steps
//! between any two of its nodes, so a node's wave is its city-block distance to the nearest
//! answered node: a distance transform, two sweeps along each axis, which visit the grid in
//! memory order and run in parallel over its rows and layers. A counting sort then lists
//! the far nodes wave by wave, each wave in memory order, so that the votes of one wave
//! read their neighbours from nearby memory. The search visited the nodes in the order it
//! reached them, scattered over the grid, one node at a time.

use rayon::prelude::*;

/// The far nodes wave by wave ([`FarWaves::new`]).
pub(crate) struct FarWaves {
    /// The far nodes, by wave, then by index.
    order: Vec<u32>,
    /// Where each wave starts in `order` (wave 1 first), and one past the last.
    starts: Vec<usize>,
}

impl FarWaves {
    /// The waves of the nodes for which `far` holds, on a grid of `dims` nodes (x fastest)
    /// with at least one node that is not far. `None` when the grid is too large for the
    /// compact form: more than `u32::MAX` nodes, or sides adding up to a city-block
    /// distance over `u16::MAX − 1`.
    pub fn new(far: &[bool], dims: [usize; 3]) -> Option<Self> {
        let [nx, ny, nz] = dims;
        let fits = u32::try_from(far.len()).is_ok()
            && nx + ny + nz < usize::from(u16::MAX)
            && far.len() == nx * ny * nz
            && far.contains(&false);
        if !fits {
            return None;
        }
        let waves = wave_numbers(far, dims);
        let mut counts = vec![0usize; usize::from(waves.iter().copied().max()?) + 1];
        for &w in &waves {
            counts[usize::from(w)] += 1;
        }
        // Wave 0 holds the answered nodes, which are not listed.
        let mut starts = Vec::with_capacity(counts.len());
        let mut next = Vec::with_capacity(counts.len());
        let mut at = 0;
        for &count in &counts[1..] {
            starts.push(at);
            next.push(at);
            at += count;
        }
        starts.push(at);
        let mut order = vec![0u32; at];
        for (n, &w) in waves.iter().enumerate() {
            if let Some(slot) = usize::from(w).checked_sub(1).and_then(|i| next.get_mut(i)) {
                order[*slot] = n as u32;
                *slot += 1;
            }
        }
        Some(Self { order, starts })
    }

    /// The waves in order, each the far nodes it holds in increasing index order.
    pub fn waves(&self) -> impl Iterator<Item = &[u32]> {
        self.starts.windows(2).map(|w| &self.order[w[0]..w[1]])
    }
}

/// Each node's city-block distance, in nodes, to the nearest node for which `far` does
/// not hold (0 there): a forward and a backward sweep along x in every row, then along y
/// in every layer, then along z. After the sweeps along an axis every node holds the least
/// over the nodes of its line of their earlier value plus the steps between, which makes
/// the three axes together the least over all nodes of the three axes' steps. The sides
/// must add up to less than `u16::MAX` ([`FarWaves::new`]).
fn wave_numbers(far: &[bool], [nx, ny, _]: [usize; 3]) -> Vec<u16> {
    let mut waves: Vec<u16> = far
        .par_iter()
        .map(|&f| if f { u16::MAX } else { 0 })
        .collect();
    waves.par_chunks_mut(nx).for_each(|row| {
        for i in 1..row.len() {
            row[i] = row[i].min(row[i - 1].saturating_add(1));
        }
        for i in (1..row.len()).rev() {
            row[i - 1] = row[i - 1].min(row[i].saturating_add(1));
        }
    });
    waves
        .par_chunks_mut(nx * ny)
        .for_each(|layer| sweep(layer, nx, relax_line));
    sweep(&mut waves, nx * ny, relax_layer);
    waves
}

/// A forward and a backward sweep over the lines of `line` values that make up `slab`:
/// `relax` lowers each line by the one just swept.
fn sweep(slab: &mut [u16], line: usize, relax: impl Fn(&mut [u16], &[u16])) {
    let lines = slab.len() / line;
    for t in 1..lines {
        let (before, after) = slab.split_at_mut(t * line);
        relax(&mut after[..line], &before[(t - 1) * line..]);
    }
    for t in (1..lines).rev() {
        let (before, after) = slab.split_at_mut(t * line);
        relax(&mut before[(t - 1) * line..], &after[..line]);
    }
}

/// Lowers each of `line` to its neighbour in `from` plus one step, where that is less.
fn relax_line(line: &mut [u16], from: &[u16]) {
    for (w, &f) in line.iter_mut().zip(from) {
        *w = (*w).min(f.saturating_add(1));
    }
}

/// [`relax_line`] over a whole layer, in parallel.
fn relax_layer(layer: &mut [u16], from: &[u16]) {
    const CHUNK: usize = 1 << 14;
    layer
        .par_chunks_mut(CHUNK)
        .zip(from.par_chunks(CHUNK))
        .for_each(|(line, from)| relax_line(line, from));
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// Each far node's city-block distance to the nearest node that is not far, node by
    /// node over the whole grid.
    fn brute_force_waves(far: &[bool], [nx, ny, _]: [usize; 3]) -> Vec<u16> {
        let at = |n: usize| (n % nx, (n / nx) % ny, n / (nx * ny));
        (0..far.len())
            .map(|n| {
                let (i, j, k) = at(n);
                (0..far.len())
                    .filter(|&m| !far[m])
                    .map(|m| {
                        let (a, b, c) = at(m);
                        (a.abs_diff(i) + b.abs_diff(j) + c.abs_diff(k)) as u16
                    })
                    .min()
                    .unwrap_or(u16::MAX)
            })
            .collect()
    }

    proptest! {
        /// The sweeps give every node its distance to the nearest answered node, and the
        /// waves list every far node once, by that distance and then by index.
        #[test]
        fn waves_are_city_block_distances_listed_in_order(
            dims in [1usize..7, 1usize..7, 1usize..7],
            answered in proptest::collection::vec(0usize..343, 1..6),
        ) {
            let count = dims[0] * dims[1] * dims[2];
            let mut far = vec![true; count];
            for a in answered {
                far[a % count] = false;
            }
            let expected = brute_force_waves(&far, dims);
            prop_assert_eq!(&wave_numbers(&far, dims), &expected);
            let waves = FarWaves::new(&far, dims);
            prop_assert!(waves.is_some());
            let mut listed = Vec::new();
            for (w, wave) in waves.iter().flat_map(FarWaves::waves).enumerate() {
                prop_assert!(wave.windows(2).all(|p| p[0] < p[1]));
                for &n in wave {
                    prop_assert_eq!(usize::from(expected[n as usize]), w + 1);
                    listed.push(n as usize);
                }
            }
            listed.sort_unstable();
            let far_nodes: Vec<usize> = (0..count).filter(|&n| far[n]).collect();
            prop_assert_eq!(listed, far_nodes);
        }
    }

    #[test]
    fn a_grid_without_answered_nodes_or_too_long_has_no_compact_waves() {
        assert!(FarWaves::new(&[true; 8], [2, 2, 2]).is_none());
        let long = vec![false; 70_000];
        assert!(FarWaves::new(&long, [70_000, 1, 1]).is_none());
        assert!(FarWaves::new(&[false; 8], [2, 2, 2]).is_some());
    }
}
