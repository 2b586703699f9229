//! Signs of the nodes farther than the band from the surface.
//!
//! [`SdfGrid::from_surface_with`](crate::SdfGrid::from_surface_with) asks the surface for a
//! distance only within the band; every other node holds `±band`, and its sign has to come
//! from the nodes that got an answer. Two rules, [`FarSigns`]:
//!
//! - [`FarSigns::Nearest`] (the default): the sign of the answered nodes nearest to the node.
//!   A hole in the band (nodes near the surface that got no answer, as an MLS surface leaves
//!   over a sampling gap wider than its kernel) then stays a local matter: the inside and
//!   outside meet in it and close it. A region of far nodes that the band does not
//!   support (a few wrong nodes at its edge signed it) then takes the other sign
//!   (`far_regions`, private: every region's faces with the other sign against its faces
//!   with answered nodes of its own).
//! - [`FarSigns::RegionVote`]: one sign for each 6-connected region of far nodes, the
//!   majority of the answered nodes around it. A hole in the band joins the inside and the
//!   outside into one region and flips one of them whole (randomly sampled spheres of 500
//!   points at 48 nodes: a second shell joined to the first by tunnels, Euler
//!   characteristic −14 or −16 instead of 2). The geometry textures of paper 000 keep it:
//!   they are open sheets, with no inside to lose, and their quality numbers were measured
//!   with it.

use glam::Vec4;
use pointset_core::Surface;
use rayon::prelude::*;

use crate::far_regions::flip_unsupported_regions;
use crate::far_waves::FarWaves;
use crate::sdf::GridSpec;

/// A node whose distance is not known yet (farther than the band).
pub(crate) const UNKNOWN: f32 = f32::INFINITY;

/// How [`SdfGrid`](crate::SdfGrid) signs the nodes farther than the band from the surface
/// (module docs: [`crate::far_signs`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum FarSigns {
    /// Each far node takes the majority sign of its 26 neighbours that are nearer to the
    /// answered nodes (a breadth-first search from all answered nodes in waves of
    /// 6-connected steps; a tie counts as outside). Exact for closed surfaces whose band
    /// is whole, and local where the band has holes. Counting the 26 neighbours, not the 6,
    /// keeps a single wrong-signed node at the band's edge from signing a one-node-wide
    /// column of its own all the way to the grid's side. A few such nodes together still
    /// would, so a region of far nodes bordered by the other sign across more node faces
    /// than by answered nodes of its own sign then takes the other sign, the worst first,
    /// until none is left: the count of sign changes where no surface was found falls
    /// with each flip.
    #[default]
    Nearest,
    /// Each 6-connected region of far nodes takes the majority sign of its contacts with
    /// answered nodes (a tie counts as outside). Exact for closed surfaces whose band is
    /// whole; a few wrong-signed nodes at an open sheet's rim cannot sign anything on
    /// their own, but a hole in the band flips the inside or the outside whole.
    RegionVote,
}

/// Gives every node still marked [`UNKNOWN`] `±band` by `rule`. When no node is known, the
/// whole grid lies farther than `band` from the surface and shares one sign, asked of the
/// surface once at the first node. Returns the number of nodes whose sign no rule could
/// determine (held at `+band`).
pub(crate) fn fill_far_signs(
    data: &mut [Vec4],
    spec: &GridSpec,
    band: f32,
    surface: &(impl Surface + ?Sized),
    rule: FarSigns,
) -> usize {
    if data.iter().all(|v| v.x == UNKNOWN) {
        let sign = surface
            .signed_distance(spec.node(0, 0, 0))
            .map(|(d, _)| if d < 0.0 { -1.0 } else { 1.0 });
        data.fill(Vec4::new(sign.unwrap_or(1.0) * band, 0.0, 0.0, 0.0));
        return if sign.is_some() { 0 } else { data.len() };
    }
    match rule {
        FarSigns::Nearest => {
            let far: Vec<bool> = data.par_iter().map(|v| v.x == UNKNOWN).collect();
            sign_by_nearest(data, &far, spec.dims, band);
            flip_unsupported_regions(data, &far, spec.dims);
        }
        FarSigns::RegionVote => sign_by_region(data, spec.dims, band),
    }
    0
}

/// [`FarSigns::Nearest`]: the far nodes (`far`) in waves of a breadth-first search from
/// every known node. A node reached in a wave votes with its 26 neighbours signed in
/// earlier waves; the nodes of its own wave are still unknown when the votes are counted,
/// so the order in which a wave is visited does not matter. The waves come from
/// [`FarWaves`] (a distance transform), or for grids too large for it from the search
/// itself; both give the same signs.
fn sign_by_nearest(data: &mut [Vec4], far: &[bool], dims: [usize; 3], band: f32) {
    // The votes are counted on one byte a node, not on the 16-byte values: each node reads
    // 26 neighbours, and the grid is mostly far nodes.
    let mut votes: Vec<i8> = data.par_iter().map(|v| sign_vote(v.x) as i8).collect();
    match FarWaves::new(far, dims) {
        Some(waves) => {
            for wave in waves.waves() {
                vote_wave(&mut votes, wave, |n| n as usize, dims);
            }
        }
        None => vote_by_search(&mut votes, far, dims),
    }
    data.par_iter_mut()
        .zip(votes.par_iter().zip(far))
        .for_each(|(value, (&sign, &far))| {
            if far {
                *value = Vec4::new(f32::from(sign) * band, 0.0, 0.0, 0.0);
            }
        });
}

/// Gives the nodes of one wave (`wave`, read as node numbers by `node`) the sign of their
/// 26 neighbours' `votes` (a tie counts as outside), counted before any of them is signed.
fn vote_wave<T: Copy + Sync>(
    votes: &mut [i8],
    wave: &[T],
    node: impl Fn(T) -> usize + Sync,
    dims: [usize; 3],
) {
    let signs: Vec<i8> = wave
        .par_iter()
        .map(|&m| {
            if vote_around(votes, node(m), dims) < 0 {
                -1
            } else {
                1
            }
        })
        .collect();
    for (&m, sign) in wave.iter().zip(signs) {
        votes[node(m)] = sign;
    }
}

/// The waves found by the breadth-first search itself, one node at a time.
fn vote_by_search(votes: &mut [i8], far: &[bool], dims: [usize; 3]) {
    let mut reached: Vec<bool> = far.iter().map(|&f| !f).collect();
    let mut wave: Vec<usize> = (0..far.len()).filter(|&n| reached[n]).collect();
    while !wave.is_empty() {
        let mut next = Vec::new();
        for &n in &wave {
            for m in six_neighbours(n, dims).into_iter().flatten() {
                if !reached[m] {
                    reached[m] = true;
                    next.push(m);
                }
            }
        }
        vote_wave(votes, &next, |n| n, dims);
        wave = next;
    }
}

/// [`FarSigns::RegionVote`]: a flood fill per region of unknown nodes, counting each
/// contact between a region node and a known neighbour once.
fn sign_by_region(data: &mut [Vec4], dims: [usize; 3], band: f32) {
    let mut visited = vec![false; data.len()];
    let mut region = Vec::new();
    for seed in 0..data.len() {
        if visited[seed] || data[seed].x != UNKNOWN {
            continue;
        }
        region.clear();
        region.push(seed);
        visited[seed] = true;
        let mut vote = 0i64;
        let mut head = 0;
        while head < region.len() {
            let n = region[head];
            head += 1;
            for m in six_neighbours(n, dims).into_iter().flatten() {
                if data[m].x != UNKNOWN {
                    vote += i64::from(sign_vote(data[m].x));
                } else if !visited[m] {
                    visited[m] = true;
                    region.push(m);
                }
            }
        }
        let sign = if vote < 0 { -1.0 } else { 1.0 };
        for &n in &region {
            data[n] = Vec4::new(sign * band, 0.0, 0.0, 0.0);
        }
    }
}

/// A node's vote: −1 inside, +1 outside, 0 exactly on the surface or not known yet.
fn sign_vote(distance: f32) -> i32 {
    if distance == UNKNOWN || distance == 0.0 {
        0
    } else if distance < 0.0 {
        -1
    } else {
        1
    }
}

/// The 6-connected neighbours of node `n` of a grid of `dims` nodes (x fastest).
pub(crate) fn six_neighbours(n: usize, [nx, ny, nz]: [usize; 3]) -> [Option<usize>; 6] {
    let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
    [
        (i > 0).then(|| n - 1),
        (i + 1 < nx).then(|| n + 1),
        (j > 0).then(|| n - nx),
        (j + 1 < ny).then(|| n + nx),
        (k > 0).then(|| n - nx * ny),
        (k + 1 < nz).then(|| n + nx * ny),
    ]
}

/// The sum of `votes` over the up to 26 nodes around node `n` (the 3 × 3 × 3 block
/// without its centre) of a grid of `dims` nodes (x fastest): nine runs of up to three
/// consecutive nodes, summed from the slices.
fn vote_around(votes: &[i8], n: usize, [nx, ny, nz]: [usize; 3]) -> i32 {
    let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
    let span = |c: usize, len: usize| c.saturating_sub(1)..=(c + 1).min(len - 1);
    let (first, last) = (i.saturating_sub(1), (i + 1).min(nx - 1));
    let mut sum = 0;
    for c in span(k, nz) {
        for b in span(j, ny) {
            let row = nx * (b + ny * c);
            if let Some(run) = votes.get(row + first..=row + last) {
                sum += run.iter().map(|&v| i32::from(v)).sum::<i32>();
            }
        }
    }
    sum - votes.get(n).map_or(0, |&v| i32::from(v))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use glam::Vec3;

    use super::*;

    proptest::proptest! {
        /// The sliced sum agrees with the votes of the 26 neighbours counted one by one,
        /// on grids down to one node wide, at corners, edges and faces.
        #[test]
        fn votes_around_a_node_are_its_26_neighbours_votes(
            dims in [1usize..5, 1usize..5, 1usize..5],
            seed in 0u64..1000,
            node in 0usize..64,
        ) {
            let [nx, ny, nz] = dims;
            let count = nx * ny * nz;
            let votes: Vec<i8> = (0..count)
                .map(|n| ((n as u64 * 2654435761 + seed) % 3) as i8 - 1)
                .collect();
            let n = node % count;
            let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
            let mut expected = 0;
            for (a, b, c) in (0..nx).flat_map(|a| {
                (0..ny).flat_map(move |b| (0..nz).map(move |c| (a, b, c)))
            }) {
                let near = a.abs_diff(i) <= 1 && b.abs_diff(j) <= 1 && c.abs_diff(k) <= 1;
                if near && (a, b, c) != (i, j, k) {
                    expected += i32::from(votes[a + nx * (b + ny * c)]);
                }
            }
            proptest::prop_assert_eq!(vote_around(&votes, n, dims), expected);
        }

        /// The waves of the distance transform sign every far node as the breadth-first
        /// search does, whatever the answered nodes and their signs (zeros among them).
        #[test]
        fn the_transform_waves_sign_as_the_search_does(
            dims in [1usize..9, 1usize..9, 1usize..9],
            answered in proptest::collection::vec((0usize..512, -1i8..=1), 1..12),
        ) {
            let count = dims[0] * dims[1] * dims[2];
            let mut votes = vec![0i8; count];
            let mut far = vec![true; count];
            for (n, vote) in answered {
                votes[n % count] = vote;
                far[n % count] = false;
            }
            let mut searched = votes.clone();
            vote_by_search(&mut searched, &far, dims);
            let waves = FarWaves::new(&far, dims);
            proptest::prop_assert!(waves.is_some());
            for wave in waves.iter().flat_map(FarWaves::waves) {
                vote_wave(&mut votes, wave, |n| n as usize, dims);
            }
            proptest::prop_assert_eq!(votes, searched);
        }
    }

    /// A surface that answers nothing: the fill must rely on the known nodes.
    struct Silent;

    impl Surface for Silent {
        fn closest_point(&self, _: Vec3) -> Option<pointset_core::SurfacePoint> {
            None
        }
    }

    /// A `n × n × 1` slab of unknown nodes, spacing 1.
    fn unknown_slab(n: usize) -> (GridSpec, Vec<Vec4>) {
        let spec = GridSpec {
            dims: [n, n, 1],
            origin: Vec3::ZERO,
            spacing: 1.0,
        };
        (spec, vec![Vec4::new(UNKNOWN, 0.0, 0.0, 0.0); n * n])
    }

    fn known(d: f32) -> Vec4 {
        Vec4::new(d, 0.0, 0.0, 0.0)
    }

    #[test]
    fn a_far_node_takes_the_majority_sign_of_its_known_neighbours() {
        for rule in [FarSigns::Nearest, FarSigns::RegionVote] {
            // A 3 × 3 × 1 slab: the centre is unknown; the node left of it is inside.
            let (spec, _) = unknown_slab(3);
            let mut data = vec![known(0.5); 9];
            data[3] = known(-0.5);
            data[4] = known(UNKNOWN);
            assert_eq!(fill_far_signs(&mut data, &spec, 2.0, &Silent, rule), 0);
            assert_eq!(
                data[4].x, 2.0,
                "{rule:?}: the outside outvotes one inside node"
            );
            let mut data = vec![known(-0.5); 9];
            data[4] = known(UNKNOWN);
            fill_far_signs(&mut data, &spec, 2.0, &Silent, rule);
            assert_eq!(data[4].x, -2.0, "{rule:?}: all inside");
            // No known node and a silent surface: undefined, held at +band.
            let (spec, mut data) = unknown_slab(3);
            assert_eq!(fill_far_signs(&mut data, &spec, 2.0, &Silent, rule), 9);
            assert!(data.iter().all(|v| v.x == 2.0));
        }
    }

    /// A ring of known nodes, inside (−) at radii 4.5–6 and outside (+) at 6–7.5, on a
    /// 25 × 25 slab, with a gap on its right three nodes wide: the band with a hole.
    fn ring_with_a_gap() -> (GridSpec, Vec<Vec4>, impl Fn(usize) -> f32) {
        let n = 25;
        let (spec, mut data) = unknown_slab(n);
        let centre = (n / 2) as f32;
        let radius = move |node: usize| {
            let (i, j) = ((node % n) as f32, (node / n) as f32);
            (i - centre).hypot(j - centre)
        };
        for (node, value) in data.iter_mut().enumerate() {
            let (i, j) = (node % n, node / n);
            let in_gap = i > n / 2 && (j as f32 - centre).abs() <= 1.0;
            if !in_gap && (4.5..6.0).contains(&radius(node)) {
                *value = known(-0.5);
            } else if !in_gap && (6.0..7.5).contains(&radius(node)) {
                *value = known(0.5);
            }
        }
        (spec, data, radius)
    }

    #[test]
    fn a_hole_in_the_band_keeps_the_inside_inside_by_the_nearest_sign() {
        let (spec, mut data, radius) = ring_with_a_gap();
        assert_eq!(
            fill_far_signs(&mut data, &spec, 3.0, &Silent, FarSigns::Nearest),
            0
        );
        for (node, v) in data.iter().enumerate() {
            if radius(node) < 4.0 {
                assert_eq!(v.x, -3.0, "node {node} within the ring");
            } else if radius(node) > 8.0 {
                assert_eq!(v.x, 3.0, "node {node} outside the ring");
            }
        }
    }

    #[test]
    fn a_hole_in_the_band_flips_the_inside_by_region_vote() {
        // The documented weakness of the region vote: the disc within the ring and the
        // outside are one region, bordered by more outside nodes than inside ones.
        let (spec, mut data, radius) = ring_with_a_gap();
        fill_far_signs(&mut data, &spec, 3.0, &Silent, FarSigns::RegionVote);
        let centre = (0..data.len()).find(|&node| radius(node) == 0.0).unwrap();
        assert_eq!(data[centre].x, 3.0);
    }

    #[test]
    fn one_wrong_node_at_the_band_edge_signs_no_column_of_its_own() {
        // A row of outside nodes (the band's edge) with one inside node among them; every
        // node beyond the row is far. The 26-neighbour vote outvotes the odd node at once.
        let n = 9;
        let (spec, mut data) = unknown_slab(n);
        for node in data.iter_mut().take(n) {
            *node = known(0.5);
        }
        data[n / 2] = known(-0.5);
        fill_far_signs(&mut data, &spec, 2.0, &Silent, FarSigns::Nearest);
        assert!(data[n..].iter().all(|v| v.x == 2.0));
    }

    #[test]
    fn a_cluster_of_wrong_nodes_at_the_band_edge_signs_no_column_of_its_own() {
        // Three neighbouring inside nodes in the band's edge row outvote the outside
        // around them wave after wave, and the search alone grows them into a column out
        // to the grid's side; bordered by the other sign along its length and by its own
        // answered nodes at three faces, the column is flipped back.
        let n = 15;
        let (spec, mut data) = unknown_slab(n);
        for node in data.iter_mut().take(n) {
            *node = known(0.5);
        }
        for node in &mut data[n / 2 - 1..=n / 2 + 1] {
            *node = known(-0.5);
        }
        fill_far_signs(&mut data, &spec, 2.0, &Silent, FarSigns::Nearest);
        assert!(data[n..].iter().all(|v| v.x == 2.0));
        assert_eq!(data[n / 2].x, -0.5, "answered nodes keep their answers");
    }

    #[test]
    fn the_nearest_sign_does_not_depend_on_the_order_of_the_nodes() {
        // Mirroring the grid mirrors the result.
        let n = 9;
        let (spec, mut data) = unknown_slab(n);
        for (node, d) in [(10, -0.5), (16, 0.5), (40, -0.5), (58, 0.5), (70, 0.5)] {
            data[node] = known(d);
        }
        let mirror = |node: usize| (n - 1 - node % n) + n * (node / n);
        let mut mirrored = vec![known(UNKNOWN); n * n];
        for (node, v) in data.iter().enumerate() {
            mirrored[mirror(node)] = *v;
        }
        fill_far_signs(&mut data, &spec, 2.0, &Silent, FarSigns::Nearest);
        fill_far_signs(&mut mirrored, &spec, 2.0, &Silent, FarSigns::Nearest);
        for node in 0..n * n {
            assert_eq!(data[node], mirrored[mirror(node)], "node {node}");
        }
        assert!(data.iter().any(|v| v.x < 0.0) && data.iter().any(|v| v.x > 0.0));
    }
}
