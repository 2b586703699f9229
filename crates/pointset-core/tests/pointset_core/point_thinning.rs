//! Point sets thinned to a Poisson disk of their own points, or at random: the disk's two
//! properties against brute force, the kept points exact, threads, counts, the shared scans,
//! bad parameters.

use glam::Vec3;
use pointset_core::surface_sampling::{PointThinning, ThinnedPoints, thin_points};
use pointset_core::{Attribute, CancelFlag, Error, PointSet, RunContext, ScalarType, rng};
use proptest::prelude::*;
use rand::RngExt;

use super::load;

fn thinned(points: &PointSet, thinning: PointThinning, seed: u64) -> ThinnedPoints {
    thin_points(points, &thinning, &mut RunContext::new(seed)).unwrap()
}

/// The least distance between two of `positions` (brute force; infinite for fewer than
/// two).
fn least_distance(positions: &[Vec3]) -> f32 {
    let mut least = f32::INFINITY;
    for (i, a) in positions.iter().enumerate() {
        for b in &positions[i + 1..] {
            least = least.min(a.distance(*b));
        }
    }
    least
}

/// The largest distance from a point of `points` to its nearest of `kept` (brute force).
fn widest_gap(points: &[Vec3], kept: &[Vec3]) -> f32 {
    points
        .iter()
        .map(|p| {
            kept.iter()
                .map(|k| k.distance(*p))
                .fold(f32::INFINITY, f32::min)
        })
        .fold(0.0, f32::max)
}

/// `n` points in a few clusters of random size and spread, some repeated, with normals
/// and a label each.
fn clustered(n: usize, seed: u64) -> PointSet {
    let mut g = rng::stream(seed, 0);
    let centres: Vec<Vec3> = (0..4)
        .map(|_| Vec3::new(g.random(), g.random(), g.random()) * 4.0)
        .collect();
    let mut positions = Vec::with_capacity(n);
    while positions.len() < n {
        if !positions.is_empty() && g.random::<f32>() < 0.05 {
            positions.push(positions[g.random_range(0..positions.len())]);
            continue;
        }
        let centre = centres[g.random_range(0..centres.len())];
        let spread = g.random_range(0.05..1.0f32);
        let offset = Vec3::new(g.random(), g.random(), g.random()) - 0.5;
        positions.push(centre + offset * spread);
    }
    let normals = positions.iter().map(|p| p.normalize_or(Vec3::Z)).collect();
    let labels = (0..n).map(|i| (i % 7) as f32).collect();
    PointSet::new(positions)
        .unwrap()
        .with_normals(normals)
        .unwrap()
        .with_attribute(Attribute::new("label", labels).with_storage(ScalarType::I32))
        .unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// No two kept points closer than the spacing; every input point closer than the
    /// spacing to a kept one; the kept points are the input's, exactly, in order; the
    /// same with one thread as with two.
    #[test]
    fn a_thinned_point_set_is_a_maximal_poisson_disk(
        n in 1usize..1500,
        spacing in 0.01f32..2.0,
        seed in any::<u64>(),
    ) {
        let points = clustered(n, seed);
        let thinning = PointThinning::PoissonDisk { spacing };
        let out = thinned(&points, thinning, seed);
        let kept = out.points.positions();
        prop_assert!(least_distance(kept) >= spacing);
        prop_assert!(widest_gap(points.positions(), kept) < spacing);
        prop_assert!(out.kept.windows(2).all(|w| w[0] < w[1]));
        prop_assert_eq!(&out.points, &points.subset(&out.kept.iter().map(|&i| i as usize).collect::<Vec<_>>()).unwrap());
        prop_assert_eq!((out.spacing, out.passes), (Some(spacing), 1));
        let one_thread = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        prop_assert_eq!(one_thread.install(|| thinned(&points, thinning, seed)), out);
    }
}

#[test]
fn the_seed_chooses_among_disks() {
    let points = clustered(3000, 1);
    let thinning = PointThinning::PoissonDisk { spacing: 0.2 };
    let (a, b) = (thinned(&points, thinning, 1), thinned(&points, thinning, 2));
    assert_eq!(a, thinned(&points, thinning, 1));
    assert_ne!(a.kept, b.kept);
    // Disks of one spacing keep about as many points whatever the order.
    let (na, nb) = (a.kept.len() as f64, b.kept.len() as f64);
    assert!((na - nb).abs() < 0.1 * na, "{na} {nb}");
}

#[test]
fn points_at_one_position_are_one_point() {
    let points = PointSet::new(vec![Vec3::new(1.0, 2.0, 3.0); 50]).unwrap();
    for thinning in [
        PointThinning::PoissonDisk { spacing: 1e-3 },
        PointThinning::PoissonDiskCount { count: 10 },
    ] {
        assert_eq!(thinned(&points, thinning, 0).kept.len(), 1, "{thinning:?}");
    }
}

#[test]
fn a_count_finds_its_spacing_on_the_shared_scans() {
    for (rel, count) in [
        ("pointsets/bunny16k_normals.ply", 2000),
        ("pointsets/chameleon4k_normals.ply", 1000),
    ] {
        let Some(loaded) = load("thin_shared_scans", rel) else {
            return;
        };
        let points = loaded.geometry.points().clone();
        let out = thinned(&points, PointThinning::PoissonDiskCount { count }, 5);
        let found = out.kept.len();
        assert!(
            found.abs_diff(count) <= count / 50,
            "{rel}: {found} of {count}"
        );
        assert!(out.passes <= 6, "{rel}: {} passes", out.passes);
        // The disk of the spacing found, and the same as asking for that spacing.
        let spacing = out.spacing.unwrap();
        assert!(least_distance(out.points.positions()) >= spacing, "{rel}");
        let again = thinned(&points, PointThinning::PoissonDisk { spacing }, 5);
        assert_eq!(again.kept, out.kept, "{rel}");
        // Every attribute (the chameleon's colours, the scans' radii) came along.
        for attribute in points.attributes() {
            let kept = out.points.attribute(attribute.name()).unwrap();
            for (k, &i) in out.kept.iter().enumerate() {
                assert_eq!(kept.values()[k], attribute.values()[i as usize]);
            }
        }
    }
}

#[test]
fn a_count_is_found_along_lines_and_through_volumes_too() {
    // A disk keeps about c / spacing^d points, d = 1 on a line and 3 in a volume: the
    // search measures d from its passes instead of taking a surface's 2.
    let mut g = rng::stream(9, 0);
    let line: Vec<Vec3> = (0..20_000)
        .map(|_| Vec3::X * g.random_range(0.0..10.0f32))
        .collect();
    let volume: Vec<Vec3> = (0..50_000)
        .map(|_| Vec3::new(g.random(), g.random(), g.random()))
        .collect();
    for (name, positions) in [("line", line), ("volume", volume)] {
        let points = PointSet::new(positions).unwrap();
        for count in [1000, 100] {
            let out = thinned(&points, PointThinning::PoissonDiskCount { count }, 1);
            let found = out.kept.len();
            assert!(
                found.abs_diff(count) <= count / 100,
                "{name}: {found} of {count}"
            );
            assert!(out.passes <= 7, "{name}, {count}: {} passes", out.passes);
        }
    }
}

#[test]
fn a_count_at_or_above_the_points_keeps_them_all() {
    let points = clustered(100, 3);
    for thinning in [
        PointThinning::PoissonDiskCount { count: 100 },
        PointThinning::Random { count: 500 },
    ] {
        let out = thinned(&points, thinning, 0);
        assert_eq!(out.points, points);
        assert_eq!((out.spacing, out.passes), (None, 0));
    }
}

#[test]
fn random_thinning_draws_every_subset_alike() {
    // Three of ten points, 3000 times: each point drawn about 900 times.
    let points = PointSet::new((0..10).map(|i| Vec3::X * i as f32).collect()).unwrap();
    let mut drawn = [0usize; 10];
    for seed in 0..3000 {
        let out = thinned(&points, PointThinning::Random { count: 3 }, seed);
        assert_eq!(out.kept.len(), 3);
        assert!(out.kept.windows(2).all(|w| w[0] < w[1]));
        for i in out.kept {
            drawn[i as usize] += 1;
        }
    }
    // Binomial(3000, 0.3): standard deviation 25; five of them either way.
    assert!(drawn.iter().all(|&d| d.abs_diff(900) < 125), "{drawn:?}");
}

#[test]
fn bad_thinnings_are_refused_by_name() {
    let points = clustered(100, 4);
    let refused = |thinning: PointThinning, name: &str| match thin_points(
        &points,
        &thinning,
        &mut RunContext::new(0),
    ) {
        Err(Error::InvalidParameter { name: n, .. }) => assert_eq!(n, name, "{thinning:?}"),
        other => panic!("{thinning:?}: {other:?}"),
    };
    for spacing in [0.0, -1.0, f32::NAN, f32::INFINITY, 1e-12] {
        refused(PointThinning::PoissonDisk { spacing }, "spacing");
    }
    refused(PointThinning::PoissonDiskCount { count: 0 }, "count");
    refused(PointThinning::Random { count: 0 }, "count");
    let empty = PointSet::new(Vec::new()).unwrap();
    let thinning = PointThinning::PoissonDisk { spacing: 1.0 };
    assert!(matches!(
        thin_points(&empty, &thinning, &mut RunContext::new(0)),
        Err(Error::EmptyInput { .. })
    ));
    let cancel = CancelFlag::new();
    cancel.cancel();
    let mut ctx = RunContext::new(0).with_cancel_flag(cancel);
    assert!(matches!(
        thin_points(&points, &thinning, &mut ctx),
        Err(Error::Cancelled)
    ));
}
