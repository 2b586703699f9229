//! The three matchers agree; the tree's structure is what paper 001 §4 describes.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use distance_field::{GridSpec, Quantizer, SdfGrid};
use pointset_core::{Aabb, Surface, SurfacePoint, rng};
use proptest::prelude::*;
use rand::RngExt;
use voxel_dfsynth::{
    BlockMatcher, BruteForce, FftMatcher, QuantizedField, SearchTree, SubsampledSource,
};

/// A quantized distance field of random balls (a "pile of balls", paper 001 Figure 6).
fn balls_field(seed: u64, size: usize) -> QuantizedField {
    struct Balls(Vec<(glam::Vec3, f32)>);
    impl Surface for Balls {
        fn closest_point(&self, q: glam::Vec3) -> Option<SurfacePoint> {
            self.0
                .iter()
                .map(|&(c, r)| {
                    let n = (q - c).try_normalize().unwrap_or(glam::Vec3::Z);
                    (
                        q.distance(c) - r,
                        SurfacePoint {
                            point: c + n * r,
                            normal: n,
                        },
                    )
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(_, p)| p)
        }
    }
    let mut g = rng::rng_from_seed(seed);
    let balls = Balls(
        (0..12)
            .map(|_| {
                (
                    glam::Vec3::new(g.random(), g.random(), g.random()),
                    g.random_range(0.1..0.25),
                )
            })
            .collect(),
    );
    let spec = GridSpec::covering(Aabb::new(glam::Vec3::ZERO, glam::Vec3::ONE), size, 0.0).unwrap();
    let sdf = SdfGrid::from_surface(&balls, &spec, 0.3).unwrap();
    QuantizedField::from_grid(&sdf.distances().unwrap(), &Quantizer::new(0.3).unwrap())
}

fn noise_field(seed: u64, dims: [usize; 3]) -> QuantizedField {
    let mut g = rng::rng_from_seed(seed);
    QuantizedField::from_values(
        dims,
        (0..dims.iter().product::<usize>())
            .map(|_| g.random_range(0..4u8) * 60)
            .collect(),
    )
    .unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn tree_brute_force_and_fft_agree_on_the_best_distance(seed in any::<u64>(), kind in 0u8..5, n_log in 1u32..4) {
        let n = 1usize << n_log;
        let field = if seed % 2 == 0 { balls_field(seed, 16) } else { noise_field(seed, [12, 10, 9]) };
        let tree = SearchTree::build(&field, n).unwrap();
        let brute = BruteForce::new(&field, n).unwrap();
        let fft = FftMatcher::new(&field, n).unwrap();
        let mut g = rng::rng_from_seed(seed ^ 0x5eed);
        let [x, y, z] = field.dims();
        let corner = [g.random_range(0..=x - n), g.random_range(0..=y - n), g.random_range(0..=z - n)];
        let query: Vec<u8> = match kind {
            // An exact block of the source (distance 0, possibly tied).
            0 => field.block(corner, n),
            // A perturbed source block.
            1 => field.block(corner, n).into_iter().map(|v| v.saturating_add(g.random_range(0..20))).collect(),
            // A constant block (many ties).
            2 => vec![g.random(); n * n * n],
            // Random values.
            3 => (0..n * n * n).map(|_| g.random()).collect(),
            // Half source, half random (as in synthesis with random seeding).
            _ => field.block(corner, n).into_iter().enumerate().map(|(i, v)| if i % 2 == 0 { v } else { g.random() }).collect(),
        };
        let (a, b, c) = (tree.best_match(&query).unwrap(), brute.best_match(&query).unwrap(), fft.best_match(&query).unwrap());
        prop_assert_eq!(a.distance, b.distance);
        prop_assert_eq!(b.distance, c.distance);
        // Each reported corner really has the reported distance.
        for m in [a, b, c] {
            let block = field.block(m.corner, n);
            let d: u64 = block.iter().zip(&query).map(|(&p, &q)| u64::from(p.abs_diff(q)).pow(2)).sum();
            prop_assert_eq!(d as f32 / (n * n * n) as f32, m.distance);
        }
        if kind == 0 {
            prop_assert_eq!(a.distance, 0.0);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    /// The pruned search agrees with the paper's plain linear search (same distance, same
    /// lowest-index corner) for block sizes with a row loop of their own (16) and for those
    /// without (3, 5, 6), with and without the pyramid filters (which need `n ≥ 4`).
    #[test]
    fn pruned_search_agrees_with_the_plain_linear_search_for_any_block_size(seed in any::<u64>(), n_choice in 0usize..4, perturbed in any::<bool>()) {
        let n = [3usize, 5, 6, 16][n_choice];
        let field = if seed % 2 == 0 { balls_field(seed, 20) } else { noise_field(seed, [19, 18, 17]) };
        let brute = BruteForce::new(&field, n).unwrap();
        let mut g = rng::rng_from_seed(seed ^ 0xb10c);
        let [x, y, z] = field.dims();
        let corner = [g.random_range(0..=x - n), g.random_range(0..=y - n), g.random_range(0..=z - n)];
        let query: Vec<u8> = if perturbed {
            field.block(corner, n).into_iter().map(|v| v.saturating_add(g.random_range(0..20))).collect()
        } else {
            (0..n * n * n).map(|_| g.random()).collect()
        };
        let (pruned, plain) = (brute.best_match(&query).unwrap(), brute.exhaustive(&query).unwrap());
        prop_assert_eq!(pruned.corner, plain.corner);
        prop_assert_eq!(pruned.distance, plain.distance);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    /// §5.2: the tree with its finest levels dropped is an exact matcher over the subsampled
    /// blocks of every position (checked by linear search over `SubsampledSource`).
    #[test]
    fn the_tree_without_its_leaves_matches_the_subsampled_source_exactly(seed in any::<u64>(), kind in 0u8..4, drop in 1usize..3) {
        let n = 8usize;
        let field = if seed % 2 == 0 { balls_field(seed, 20) } else { noise_field(seed, [14, 12, 11]) };
        let tree = SearchTree::build(&field, n).unwrap();
        let sub = SubsampledSource::new(&field, drop).unwrap();
        let m = n >> drop;
        let mut g = rng::rng_from_seed(seed ^ 0xc0a5e);
        let [px, py, pz] = tree.positions();
        let corner = [g.random_range(0..px), g.random_range(0..py), g.random_range(0..pz)];
        let exact = sub.block(corner, m).unwrap();
        prop_assert_eq!(&exact, &tree.subsampled_block(corner, drop));
        let query: Vec<u8> = match kind {
            0 => exact,
            1 => exact.into_iter().map(|v| v.saturating_add(g.random_range(0..30))).collect(),
            2 => vec![g.random(); m * m * m],
            _ => (0..m * m * m).map(|_| g.random()).collect(),
        };
        let found = tree.best_match_subsampled(&query, drop).unwrap();
        let dist = |b: &[u8]| b.iter().zip(&query).map(|(&p, &q)| u64::from(p.abs_diff(q)).pow(2)).sum::<u64>() as f32 / query.len() as f32;
        let mut best = f32::INFINITY;
        for z in 0..pz {
            for y in 0..py {
                for x in 0..px {
                    best = best.min(dist(&sub.block([x, y, z], m).unwrap()));
                }
            }
        }
        prop_assert_eq!(found.distance, best);
        prop_assert_eq!(dist(&sub.block(found.corner, m).unwrap()), best);
    }
}

#[test]
fn merging_never_joins_different_nodes_and_level_one_has_at_most_256() {
    for (field, n) in [
        (balls_field(3, 20), 4),
        (noise_field(4, [14, 12, 11]), 4),
        (balls_field(5, 18), 8),
    ] {
        let tree = SearchTree::build(&field, n).unwrap();
        let stats = tree.stats().clone();
        assert_eq!(tree.verify().unwrap(), stats.blocks);
        assert!(stats.nodes_per_level[0] <= 256);
        assert!(stats.nodes_per_level.iter().sum::<usize>() > 0);
        assert!(stats.branching_factor >= 1.0);
    }
}

#[test]
fn masked_ssd_counts_only_the_mask() {
    let field = noise_field(9, [10, 9, 8]);
    let fft = FftMatcher::new(&field, 4).unwrap();
    let query = field.block([2, 3, 1], 4);
    // Compare only the first octant: that block and any block equal there score 0.
    let mask: Vec<bool> = (0..64)
        .map(|i| i % 4 < 2 && (i / 4) % 4 < 2 && i / 16 < 2)
        .collect();
    let ssd = fft.masked_ssd(&query, &mask).unwrap();
    // Corner (2, 3, 1) among 7 × 6 × 5 corners.
    let (corner_x, corner_y, corner_z) = (2, 3, 1);
    let index = corner_x + 7 * (corner_y + 6 * corner_z);
    assert_eq!(ssd[index], 0);
    // Brute-force check of every position.
    for (id, &v) in ssd.iter().enumerate() {
        let corner = [id % 7, (id / 7) % 6, id / 42];
        let block = field.block(corner, 4);
        let expected: u64 = (0..64)
            .filter(|&i| mask[i])
            .map(|i| u64::from(block[i].abs_diff(query[i])).pow(2))
            .sum();
        assert_eq!(v, expected, "corner {corner:?}");
    }
}

#[test]
fn invalid_input_is_an_error() {
    let field = noise_field(1, [8, 8, 8]);
    assert!(SearchTree::build(&field, 3).is_err());
    assert!(SearchTree::build(&field, 16).is_err());
    let too_big = BruteForce::new(&field, 16).unwrap_err().to_string();
    assert!(
        too_big.contains("the field is 8 × 8 × 8 samples"),
        "{too_big}"
    );
    assert!(FftMatcher::new(&field, 16).is_err());
    let tree = SearchTree::build(&field, 4).unwrap();
    assert!(tree.best_match(&[0u8; 10]).is_err());
    assert!(QuantizedField::from_values([2, 2, 2], vec![0; 7]).is_err());
}

#[test]
fn tree_and_matches_do_not_depend_on_thread_count() {
    let field = balls_field(11, 20);
    let queries: Vec<Vec<u8>> = (0..5)
        .map(|i| {
            field
                .block([i, 2 * i, 3], 4)
                .into_iter()
                .map(|v| v.wrapping_add(i as u8))
                .collect()
        })
        .collect();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let tree = SearchTree::build(&field, 4).unwrap();
                let stats = tree.stats().clone();
                let matches: Vec<_> = queries
                    .iter()
                    .map(|q| tree.best_match(q).unwrap())
                    .collect();
                (stats.nodes_per_level, stats.branching_factor, matches)
            })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn eq3_pruning_keeps_exact_answers_for_distance_field_queries() {
    let field = balls_field(5, 20);
    let tree = SearchTree::build(&field, 8).unwrap();
    // The balls field: range 0.3 over 255 levels, spacing 1/19.
    let slope = 255.0 * (1.0 / 19.0) / 0.6;
    let pruning = voxel_dfsynth::Eq3Pruning {
        slope,
        tolerance: 0.0,
    };
    let mut g = rng::rng_from_seed(9);
    let [px, py, pz] = tree.positions();
    for _ in 0..20 {
        let corner = [
            g.random_range(0..px),
            g.random_range(0..py),
            g.random_range(0..pz),
        ];
        let shift: u8 = g.random_range(0..3);
        // A source block raised by a constant is still a distance field (of a shifted level set).
        let query: Vec<u8> = field
            .block(corner, 8)
            .into_iter()
            .map(|v| v.saturating_add(shift))
            .collect();
        let exact = tree.best_match(&query).unwrap();
        let (pruned, stats) = tree.best_match_pruned(&query, 0, &pruning).unwrap();
        assert_eq!(pruned.distance, exact.distance);
        assert!(stats.expanded > 0 && stats.max_queue > 0);
    }
    // A bound that is far too tight (slope 0) prunes entries: the mechanism acts.
    let tight = voxel_dfsynth::Eq3Pruning {
        slope: 0.0,
        tolerance: 0.0,
    };
    let query: Vec<u8> = (0..512).map(|i| (i * 7 % 256) as u8).collect();
    let (_, stats) = tree.best_match_pruned(&query, 0, &tight).unwrap();
    assert!(stats.pruned > 0, "{stats:?}");
}
