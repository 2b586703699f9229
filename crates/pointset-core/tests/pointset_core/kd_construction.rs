//! `KdIndex` builds large trees on several threads (kiddo's `multi-threaded` feature,
//! from 262,144 points): the tree must be the one a single thread builds, since ties
//! (`nearest_one`, the last of `k` neighbours) are settled by the tree's shape.

use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use pointset_core::KdIndex;

/// Points on a coarse lattice, each position taken by several points (ties everywhere),
/// in a scrambled order, past the parallel threshold.
fn lattice_with_repeats() -> Vec<Vec3> {
    (0u32..300_000)
        .map(|i| {
            let j = i.wrapping_mul(2_654_435_761) % 300_000;
            Vec3::new(
                (j % 50) as f32,
                ((j / 50) % 40) as f32,
                (j / 2000 % 30) as f32,
            )
        })
        .collect()
}

#[test]
fn a_tree_built_on_several_threads_answers_as_one_built_on_one() {
    let points = lattice_with_repeats();
    let index = KdIndex::new(&points).unwrap();
    let raw: Vec<[f32; 3]> = points.iter().map(|p| p.to_array()).collect();
    let serial: ImmutableKdTree<f32, 3> = ImmutableKdTree::builder()
        .with_serial_construction()
        .build_from_slice(&raw)
        .unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let parallel = pool.install(|| KdIndex::new(&points).unwrap());
    // Queries on the lattice, between lattice points and at cell centres: equidistant
    // points all around.
    for q in 0..3000u32 {
        let query = Vec3::new(
            (q % 53) as f32 * 0.5 - 1.0,
            (q / 53 % 43) as f32 * 0.5 - 1.0,
            (q % 31) as f32 * 0.5,
        );
        let one = serial
            .query(&query.to_array())
            .nearest_one::<SquaredEuclidean<f32>>()
            .execute();
        for index in [&index, &parallel] {
            let got = index.nearest_one(query).unwrap().unwrap();
            assert_eq!(got.index, one.item as usize, "nearest to {query}");
            let mut expected: Vec<(u32, f32)> = serial
                .query(&query.to_array())
                .nearest_n::<SquaredEuclidean<f32>>(std::num::NonZeroUsize::new(8).unwrap())
                .execute()
                .into_iter()
                .map(|r| (r.item, r.distance))
                .collect();
            expected.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            let found: Vec<(u32, f32)> = index
                .nearest(query, 8)
                .unwrap()
                .into_iter()
                .map(|n| (n.index as u32, n.distance_squared))
                .collect();
            assert_eq!(found, expected, "8 nearest to {query}");
        }
    }
}
