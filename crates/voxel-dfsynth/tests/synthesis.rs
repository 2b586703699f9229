//! Synthesis (paper 001 §5): coverage, determinism, matcher agreement, periodicity.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use distance_field::SdfGrid;
use glam::{Vec3, Vec4};
use pointset_core::{Grid3, RunContext, rng};
use rand::RngExt;
use voxel_dfsynth::{MatcherKind, VoxelParams, synthesize};

/// An SDF grid (unit spacing) from an analytic distance function.
fn analytic(dims: [usize; 3], f: impl Fn(Vec3) -> f32) -> SdfGrid {
    let data = (0..dims.iter().product::<usize>())
        .map(|i| {
            let p = Vec3::new(
                (i % dims[0]) as f32,
                ((i / dims[0]) % dims[1]) as f32,
                (i / (dims[0] * dims[1])) as f32,
            );
            Vec4::new(f(p), 0.0, 0.0, 0.0)
        })
        .collect();
    SdfGrid::from_grid(Grid3::from_vec(dims, Vec3::ZERO, 1.0, data).unwrap(), 8.0).unwrap()
}

/// Balls of radius 2.5 on a cubic lattice of period 8 samples.
fn lattice(dims: [usize; 3]) -> SdfGrid {
    analytic(dims, |p| {
        let q = (p + 4.0).rem_euclid(Vec3::splat(8.0)) - 4.0;
        q.length() - 2.5
    })
}

/// Random balls (no symmetry, so ties between different blocks are unlikely).
fn random_balls(dims: [usize; 3], seed: u64) -> SdfGrid {
    let mut g = rng::rng_from_seed(seed);
    let extent = Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
    let balls: Vec<(Vec3, f32)> = (0..40)
        .map(|_| {
            let c = Vec3::new(g.random(), g.random(), g.random()) * extent;
            (c, g.random_range(1.5..4.0))
        })
        .collect();
    analytic(dims, |p| {
        balls
            .iter()
            .map(|&(c, r)| p.distance(c) - r)
            .fold(f32::INFINITY, f32::min)
    })
}

fn params(target: usize, levels: usize, block: usize, matcher: MatcherKind) -> VoxelParams {
    VoxelParams::default()
        .target_dims([target; 3])
        .levels(levels)
        .block(block)
        .matcher(matcher)
        .range(4.0)
        .seed(7)
}

#[test]
fn every_target_sample_is_written_exactly_once_per_level() {
    let source = random_balls([24, 24, 24], 3);
    for p in [
        params(32, 3, 8, MatcherKind::Tree),
        params(24, 1, 8, MatcherKind::Tree),
        params(0, 2, 8, MatcherKind::Random).target_dims([16, 24, 32]),
    ] {
        let out = synthesize(&source, &p, &mut RunContext::new(0)).unwrap();
        assert_eq!(out.levels.len(), p.levels);
        for level in &out.levels {
            assert_eq!((level.min_writes, level.max_writes), (1, 1), "{level:?}");
        }
        assert!(out.owner.iter().all(|&o| (o as usize) < out.copies.len()));
        assert_eq!(out.field.dims(), p.target_dims);
        // The last iteration's blocks step by half a block (7 octants known, §5.1).
        let h = p.block / 2;
        assert!(
            out.copies
                .iter()
                .all(|c| c.target.iter().all(|t| t % h == 0))
        );
    }
}

#[test]
fn synthesis_is_deterministic_for_a_seed_with_one_or_two_threads() {
    let source = random_balls([24, 24, 24], 5);
    let p = params(32, 2, 8, MatcherKind::Tree);
    let run = |threads: usize, p: &VoxelParams| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| synthesize(&source, p, &mut RunContext::new(0)).unwrap())
    };
    let (a, b) = (run(1, &p), run(2, &p));
    assert_eq!(a.field, b.field);
    assert_eq!(a.copies, b.copies);
    // The default matcher splits each search over threads too (and over phases at the
    // coarser iteration): still the same result.
    let brute = p.clone().matcher(MatcherKind::Brute);
    let (x, y) = (run(1, &brute), run(2, &brute));
    assert_eq!(x.field, y.field);
    assert_eq!(x.copies, y.copies);
    let c = synthesize(&source, &p.seed(8), &mut RunContext::new(0)).unwrap();
    assert_ne!(a.field, c.field, "another seed gives another target");
}

#[test]
fn tree_brute_force_and_fft_synthesize_the_same_target() {
    let source = random_balls([20, 20, 20], 11);
    let run = |m| synthesize(&source, &params(16, 2, 8, m), &mut RunContext::new(0)).unwrap();
    let (tree, brute, fft) = (
        run(MatcherKind::Tree),
        run(MatcherKind::Brute),
        run(MatcherKind::Fft),
    );
    let distances = |s: &voxel_dfsynth::Synthesis| -> Vec<f32> {
        s.copies.iter().map(|c| c.distance).collect()
    };
    assert_eq!(distances(&tree), distances(&brute));
    assert_eq!(distances(&tree), distances(&fft));
    assert_eq!(tree.field, brute.field);
}

#[test]
fn search_beats_random_blocks_on_the_matching_distance() {
    let source = random_balls([24, 24, 24], 13);
    let run = |m| synthesize(&source, &params(32, 2, 8, m), &mut RunContext::new(0)).unwrap();
    let (tree, random) = (run(MatcherKind::Tree), run(MatcherKind::Random));
    for (t, r) in tree.levels.iter().zip(&random.levels) {
        assert!(
            t.mean_distance < 0.5 * r.mean_distance,
            "{} vs {}",
            t.mean_distance,
            r.mean_distance
        );
    }
}

/// Lag in `lags` with the highest normalized autocorrelation of `f` along `axis`.
fn dominant_lag(f: &Grid3<f32>, axis: usize, lags: std::ops::Range<usize>) -> usize {
    let dims = f.dims();
    let mean = f.data().iter().sum::<f32>() / f.data().len() as f32;
    let mut best = (f32::NEG_INFINITY, 0);
    for lag in lags {
        let (mut num, mut count) = (0.0f32, 0usize);
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let mut q = [x, y, z];
                    q[axis] += lag;
                    if q[axis] >= dims[axis] {
                        continue;
                    }
                    let a = f.get(x, y, z).unwrap() - mean;
                    let b = f.get(q[0], q[1], q[2]).unwrap() - mean;
                    num += a * b;
                    count += 1;
                }
            }
        }
        let c = num / count as f32;
        if c > best.0 {
            best = (c, lag);
        }
    }
    best.1
}

/// Fraction of samples equal to the sample 8 further along each axis.
fn period_8_fraction(field: &Grid3<f32>) -> f64 {
    let dims = field.dims();
    let (mut same, mut total) = (0usize, 0usize);
    for z in 0..dims[2] - 8 {
        for y in 0..dims[1] - 8 {
            for x in 0..dims[0] - 8 {
                let v = field.get(x, y, z).unwrap();
                for q in [[x + 8, y, z], [x, y + 8, z], [x, y, z + 8]] {
                    same += usize::from(field.get(q[0], q[1], q[2]).unwrap() == v);
                    total += 1;
                }
            }
        }
    }
    same as f64 / total as f64
}

#[test]
fn synthesis_of_a_periodic_field_reproduces_the_period() {
    let source = lattice([32, 32, 32]);
    let run = |m| {
        synthesize(&source, &params(48, 2, 8, m), &mut RunContext::new(0))
            .unwrap()
            .distances()
            .unwrap()
    };
    let (field, baseline) = (run(MatcherKind::Tree), run(MatcherKind::Random));
    for axis in 0..3 {
        assert_eq!(dominant_lag(&field, axis, 4..14), 8, "axis {axis}");
    }
    // Not only the dominant lag: most of the output equals itself shifted by one period,
    // which random blocks of the same lattice do not achieve.
    let (tree, random) = (period_8_fraction(&field), period_8_fraction(&baseline));
    assert!(tree > 0.6 && tree > random + 0.3, "{tree} vs {random}");
}

#[test]
fn invalid_parameters_are_range_errors() {
    let source = lattice([16, 16, 16]);
    let bad = [
        params(32, 2, 6, MatcherKind::Tree),
        params(32, 0, 8, MatcherKind::Tree),
        params(32, 4, 8, MatcherKind::Tree),
        params(30, 2, 8, MatcherKind::Tree),
        params(4, 1, 8, MatcherKind::Tree),
        params(32, 2, 8, MatcherKind::Tree).range(f32::NAN),
        // Block larger than the source.
        params(64, 1, 32, MatcherKind::Tree),
        // Too many samples to allocate (2048³), and a product that overflows usize.
        params(2048, 2, 8, MatcherKind::Tree),
        params(32, 2, 8, MatcherKind::Tree).target_dims([16, 16, usize::MAX / 8 * 4]),
    ];
    for p in bad {
        assert!(
            synthesize(&source, &p, &mut RunContext::new(0)).is_err(),
            "{p:?}"
        );
    }
    assert!("kd".parse::<MatcherKind>().is_err());
    assert_eq!("fft".parse::<MatcherKind>().unwrap(), MatcherKind::Fft);
    // Target sizes that do not fit the block are refused with the block's numbers and a
    // size that fits, which validates.
    let message = |p: &VoxelParams| {
        p.validate()
            .map_err(|e| e.to_string())
            .err()
            .unwrap_or_default()
    };
    for (dims, fitting) in [
        ([16, 16, 4], [16, 16, 16]),
        ([30, 17, 0], [32, 24, 16]),
        ([1, 40, 20], [16, 40, 24]),
    ] {
        let p = params(32, 2, 16, MatcherKind::Brute).target_dims(dims);
        let message = message(&p);
        assert!(
            message.contains("at least the block (16) and a multiple of half of it (8)"),
            "{message}"
        );
        assert!(
            message.contains(&format!("such as {fitting:?}")),
            "{message}"
        );
        assert!(p.target_dims(fitting).validate().is_ok(), "{fitting:?}");
    }
    // No size is suggested that would be too many samples in turn.
    let huge = message(&params(32, 2, 16, MatcherKind::Brute).target_dims([512, 512, 513]));
    assert!(
        huge.contains("multiple of half of it (8)") && !huge.contains("such as"),
        "{huge}"
    );
    // Levels name their range for the block; a block above 512 is refused as a block
    // (a suggested target of 1024³ would have been refused next).
    let levels = message(&params(64, 5, 16, MatcherKind::Brute));
    assert!(levels.contains("1 to 4 for a block of 16"), "{levels}");
    assert!(params(64, 4, 16, MatcherKind::Brute).validate().is_ok());
    let block = message(&params(1024, 1, 1024, MatcherKind::Brute));
    assert!(
        block.contains("`block` = 1024") && block.contains("2 to 512"),
        "{block}"
    );
}

#[test]
fn synthesis_beats_random_blocks_on_every_quality_measure() {
    let source = random_balls([32, 32, 32], 17);
    let p = params(32, 2, 8, MatcherKind::Tree);
    let quantizer = voxel_dfsynth::source_quantizer(&source, &p).unwrap();
    let q_source = voxel_dfsynth::quantize_source(&source, &quantizer).unwrap();
    let qp = voxel_dfsynth::QualityParams::default()
        .window(8)
        .windows(24)
        .seed(3);
    let measure = |m| {
        let out = synthesize(&source, &p.clone().matcher(m), &mut RunContext::new(0)).unwrap();
        voxel_dfsynth::evaluate(&q_source, &quantizer, &out, &qp).unwrap()
    };
    let (tree, random) = (measure(MatcherKind::Tree), measure(MatcherKind::Random));
    assert!(
        tree.neighbourhood_error < random.neighbourhood_error,
        "{tree:?}\n{random:?}"
    );
    assert!(tree.seam_error < random.seam_error, "{tree:?}\n{random:?}");
    assert!(
        tree.distance_field_fraction > random.distance_field_fraction,
        "{tree:?}\n{random:?}"
    );
    assert!(tree.seam_pairs > 0 && random.seam_pairs > 0);
    // The source itself is (nearly) a distance field.
    assert!(tree.source_distance_field_fraction > 0.8, "{tree:?}");
}

#[test]
fn isosurface_reconstruction_of_closed_inputs_is_a_closed_manifold() {
    let source = random_balls([24, 24, 24], 19);
    let out = synthesize(
        &source,
        &params(32, 2, 8, MatcherKind::Tree),
        &mut RunContext::new(0),
    )
    .unwrap();
    let mesh = voxel_dfsynth::isosurface_mesh(&out, true).unwrap();
    let topo = mesh.topology();
    assert!(mesh.face_count() > 100);
    assert!(topo.is_closed_manifold(), "{topo:?}");
    // Without closing, the surface is open where it leaves the target box.
    let open = voxel_dfsynth::isosurface_mesh(&out, false).unwrap();
    assert!(open.topology().boundary_edges > 0);
}

#[test]
fn copied_triangles_are_welded_and_relaxed_onto_the_target() {
    let source = random_balls([24, 24, 24], 23);
    let source_mesh = distance_field::isosurface(&source.distances().unwrap(), 0.0).unwrap();
    let out = synthesize(
        &source,
        &params(32, 2, 8, MatcherKind::Tree),
        &mut RunContext::new(0),
    )
    .unwrap();
    let copied =
        voxel_dfsynth::copied_mesh(&source_mesh, &out, &voxel_dfsynth::RelaxParams::default())
            .unwrap();
    assert!(copied.copied_triangles > 100, "{}", copied.copied_triangles);
    assert!(copied.welded_vertices > 0);
    assert!(
        copied.boundary_edges_after < copied.boundary_edges_before,
        "{} -> {}",
        copied.boundary_edges_before,
        copied.boundary_edges_after
    );
    assert!(
        copied.seam_distance_after < copied.seam_distance_before,
        "{} -> {}",
        copied.seam_distance_before,
        copied.seam_distance_after
    );
    // Welding collapses some triangles; no vertex is left without a face (other tools
    // drop or flag such vertices, and boxes that count them disagree).
    assert_eq!(copied.mesh.unreferenced_vertices(), 0);
    // Every vertex lies inside the target box (grown by a spacing for the relaxation).
    let extent = Vec3::splat(32.0);
    for p in copied.mesh.positions() {
        assert!(
            p.min_element() >= -1.5 && (*p - extent).max_element() <= 1.5,
            "{p}"
        );
    }
    let too_many = voxel_dfsynth::MAX_RELAX_ITERATIONS + 1;
    for (bad, name) in [
        (voxel_dfsynth::RelaxParams::default().step(0.0), "step"),
        (
            voxel_dfsynth::RelaxParams::default().iterations(too_many),
            "iterations",
        ),
        (
            voxel_dfsynth::RelaxParams::default()
                .weld_radius(voxel_dfsynth::MAX_WELD_RADIUS * 1.01),
            "weld_radius",
        ),
        (
            voxel_dfsynth::RelaxParams::default().weld_radius(f32::NAN),
            "weld_radius",
        ),
    ] {
        assert!(matches!(
            voxel_dfsynth::copied_mesh(&source_mesh, &out, &bad),
            Err(voxel_dfsynth::VoxelError::InvalidParameter { name: n, .. }) if n == name
        ));
    }
    let widest = voxel_dfsynth::RelaxParams::default().weld_radius(voxel_dfsynth::MAX_WELD_RADIUS);
    assert!(widest.validate().is_ok());
}

#[test]
fn reconstruction_sizes_are_counted_before_building() {
    let source = random_balls([24, 24, 24], 29);
    let source_mesh = distance_field::isosurface(&source.distances().unwrap(), 0.0).unwrap();
    for (dims, seed) in [([32, 32, 32], 1), ([40, 24, 32], 2), ([24, 32, 16], 3)] {
        let out = synthesize(
            &source,
            &params(32, 2, 8, MatcherKind::Brute)
                .target_dims(dims)
                .seed(seed),
            &mut RunContext::new(0),
        )
        .unwrap();
        let copied =
            voxel_dfsynth::copied_mesh(&source_mesh, &out, &voxel_dfsynth::RelaxParams::default())
                .unwrap();
        assert!(copied.copied_triangles > 100);
        assert_eq!(
            voxel_dfsynth::copied_triangle_count(&source_mesh, &out),
            copied.copied_triangles,
            "{dims:?}"
        );
        // Cells crossing the zero set, counted on the dequantized grid by hand.
        let grid = out.distances().unwrap();
        let d = grid.dims();
        let mut by_hand = 0;
        for (k, j, i) in grid_cells(d) {
            let negative = (0..8)
                .filter(|&c| {
                    let at = grid.get(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
                    at.is_some_and(|&v| v < 0.0)
                })
                .count();
            by_hand += usize::from(negative != 0 && negative != 8);
        }
        assert_eq!(voxel_dfsynth::isosurface_cells(&out, false), by_hand);
        // Each crossing cell gives 1 to 12 triangles.
        for closed in [false, true] {
            let cells = voxel_dfsynth::isosurface_cells(&out, closed);
            let faces = voxel_dfsynth::isosurface_mesh(&out, closed)
                .unwrap()
                .face_count();
            assert!(
                cells > 0 && cells <= faces && faces <= 12 * cells,
                "{cells} {faces}"
            );
        }
    }
    // A solid filling the box crosses nowhere inside; closed, every cell touching the
    // outside layer crosses.
    let full = synthesize(
        &analytic([16, 16, 16], |_| -1.0),
        &params(24, 2, 8, MatcherKind::Brute),
        &mut RunContext::new(0),
    )
    .unwrap();
    assert_eq!(voxel_dfsynth::isosurface_cells(&full, false), 0);
    assert_eq!(
        voxel_dfsynth::isosurface_cells(&full, true),
        25 * 25 * 25 - 23 * 23 * 23
    );
}

/// The cells `(k, j, i)` of a grid of `d` samples.
fn grid_cells(d: [usize; 3]) -> impl Iterator<Item = (usize, usize, usize)> {
    (0..d[2] - 1)
        .flat_map(move |k| (0..d[1] - 1).flat_map(move |j| (0..d[0] - 1).map(move |i| (k, j, i))))
}
