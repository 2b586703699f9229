//! Spatial index kernels: k-d tree build and queries, regions of it gathered for blocks of
//! queries, bucket grid churn and queries; the stray-point check every point-set input of
//! `reconstruct`, `sdf` and `quilt` goes through; points sampled on a mesh's surface.

// A benchmark whose setup fails has nothing to measure: aborting is the right outcome.
#![allow(clippy::expect_used)]

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use geosynth::core::rng;
use geosynth::core::{Aabb, BucketGrid, KdIndex, KdRegion};
use glam::Vec3;
use rand::RngExt;

fn random_points(n: usize, seed: u64) -> Vec<Vec3> {
    let mut r = rng::rng_from_seed(seed);
    (0..n)
        .map(|_| Vec3::new(r.random(), r.random(), r.random()))
        .collect()
}

fn kd_index(c: &mut Criterion) {
    let mut group = c.benchmark_group("kd_index");
    for n in [10_000usize, 100_000] {
        let points = random_points(n, 1);
        group.bench_with_input(BenchmarkId::new("build", n), &points, |b, p| {
            b.iter(|| KdIndex::new(black_box(p)))
        });
        let index = KdIndex::new(&points).expect("benchmark setup");
        let queries = random_points(1000, 2);
        group.bench_with_input(BenchmarkId::new("knn16_x1000", n), &queries, |b, q| {
            b.iter(|| {
                for &p in q {
                    black_box(index.nearest(p, 16).ok());
                }
            })
        });
        // About 16 neighbours a query, and about 128 (an MLS gathering ball on a dense
        // scan, as the quilt's blend asks for).
        for (name, expected) in [("radius_x1000", 16.0), ("radius_128_x1000", 128.0)] {
            let radius = (expected / (n as f32 * 4.19)).cbrt();
            group.bench_with_input(BenchmarkId::new(name, n), &queries, |b, q| {
                b.iter(|| {
                    for &p in q {
                        black_box(index.within(p, radius).ok());
                    }
                })
            });
        }
    }
    group.finish();
}

fn bucket_grid(c: &mut Criterion) {
    let mut group = c.benchmark_group("bucket_grid");
    let points = random_points(100_000, 3);
    group.bench_function("insert_100k", |b| {
        b.iter(|| {
            let mut g = BucketGrid::new(0.02).expect("benchmark setup");
            for (i, &p) in points.iter().enumerate() {
                black_box(g.insert(p, i).ok());
            }
            g
        })
    });
    let mut grid = BucketGrid::new(0.02).expect("benchmark setup");
    for (i, &p) in points.iter().enumerate() {
        grid.insert(p, i).expect("benchmark setup");
    }
    let queries = random_points(1000, 4);
    group.bench_function("radius_0.03_x1000", |b| {
        b.iter(|| {
            for &q in &queries {
                black_box(grid.query_radius(q, 0.03));
            }
        })
    });
    // The quilting pattern: clear a box, refill it.
    group.bench_function("remove_box_and_refill", |b| {
        let region = Aabb::new(Vec3::splat(0.4), Vec3::new(0.5, 0.5, 1.0));
        b.iter(|| {
            let removed = grid.remove_inside_box(&region);
            for (p, v) in removed {
                black_box(grid.insert(p, v).ok());
            }
        })
    });
    group.finish();
}

/// `n` points on a bumpy sheet over the unit square (a scanned surface, as an MLS surface
/// is built on).
fn sheet_points(n: usize, seed: u64) -> Vec<Vec3> {
    let mut r = rng::rng_from_seed(seed);
    (0..n)
        .map(|_| {
            let (x, y) = (r.random::<f32>(), r.random::<f32>());
            Vec3::new(x, y, 0.02 * (20.0 * x).sin() * (15.0 * y).cos())
        })
        .collect()
}

/// 48 blocks of 8 × 8 grid nodes spaced `spacing` apart, level with the sheet or up to
/// `height` above it: each block's centre, reach, and nodes.
fn node_blocks(spacing: f32, height: f32) -> Vec<Block> {
    let mut r = rng::rng_from_seed(3);
    (0..48)
        .map(|_| {
            let corner = Vec3::new(
                0.8 * r.random::<f32>(),
                0.8 * r.random::<f32>(),
                height * r.random::<f32>(),
            );
            let nodes: Vec<Vec3> = (0..64)
                .map(|n| corner + Vec3::new((n % 8) as f32, (n / 8) as f32, 0.0) * spacing)
                .collect();
            let (a, b) = (nodes[0], nodes[63]);
            (0.5 * (a + b), 0.5 * a.distance(b), nodes)
        })
        .collect()
}

/// A block of nodes: its centre, its reach (half its diagonal) and its nodes.
type Block = (Vec3, f32, Vec<Vec3>);

/// Calls `ask(q)` for every node of every block.
fn each_node(blocks: &[Block], mut ask: impl FnMut(Vec3)) {
    for (_, _, nodes) in blocks {
        nodes.iter().for_each(|&q| ask(q));
    }
}

/// Gathers the points within `beyond` of each block's reach into a region, then calls
/// `ask(region, q)` for the block's nodes.
fn each_node_by_region(
    index: &KdIndex,
    blocks: &[Block],
    beyond: f32,
    mut ask: impl FnMut(&KdRegion, Vec3),
) {
    for (centre, reach, nodes) in blocks {
        let region = index
            .region(*centre, (reach + beyond) * 1.0001)
            .expect("benchmark setup");
        nodes.iter().for_each(|&q| ask(&region, q));
    }
}

/// The nodes of blocks above a sampled sheet asked of the index one by one, and of a
/// region gathered once per block — what a distance grid does through a prepared MLS
/// surface: neighbours in a gathering ball, and the nearest sample within a band.
fn kd_region(c: &mut Criterion) {
    let mut group = c.benchmark_group("kd_region_sheet_100k");
    let index = KdIndex::new(&sheet_points(100_000, 1)).expect("benchmark setup");
    // A sample spacing of about 0.003: a gathering ball of 1.5 MLS supports (2.5 kernels of
    // 1.25 spacings) holds about 60 samples; nodes a quarter support apart, a band of 4
    // supports.
    let support = 2.5 * 1.25 * 0.0032;
    let (gather, band) = (1.5 * support, 4.0 * support);
    let blocks = node_blocks(0.25 * support, band);
    group.bench_function("within_3072_nodes_by_index", |b| {
        b.iter(|| {
            each_node(&blocks, |q| {
                black_box(index.within(q, gather).ok());
            })
        })
    });
    group.bench_function("within_3072_nodes_by_region", |b| {
        b.iter(|| {
            each_node_by_region(&index, &blocks, gather, |region, q| {
                black_box(region.within(q, gather).ok());
            })
        })
    });
    group.bench_function("nearest_one_3072_nodes_by_index", |b| {
        b.iter(|| {
            each_node(&blocks, |q| {
                black_box(index.nearest_one(q).ok());
            })
        })
    });
    group.bench_function("nearest_up_to_band_3072_nodes_by_region", |b| {
        b.iter(|| {
            each_node_by_region(&index, &blocks, band, |region, q| {
                black_box(region.nearest_one_up_to(q, band).ok());
            })
        })
    });
    group.finish();
}

/// `strays::kept_indices` on a unit cube of random points with one far outlier.
fn stray_points(c: &mut Criterion) {
    let mut group = c.benchmark_group("strays");
    for n in [100_000usize, 1_000_000] {
        let mut points = random_points(n, 5);
        points[n / 2] = Vec3::new(0.5, 0.5, 1_000.0);
        group.bench_with_input(BenchmarkId::new("kept_indices", n), &points, |b, p| {
            b.iter(|| geosynth::core::strays::kept_indices(black_box(p)))
        });
    }
    group.finish();
}

/// `mls::isolated_samples` (default parameters) on random points of the unit sphere with
/// one point at its centre, the index built beforehand.
fn isolated_points(c: &mut Criterion) {
    let mut group = c.benchmark_group("isolated");
    for n in [100_000usize, 1_000_000] {
        let mut points: Vec<Vec3> = random_points(n, 6)
            .into_iter()
            .map(|p| (p - Vec3::splat(0.5)).normalize_or(Vec3::X))
            .collect();
        points[n / 2] = Vec3::ZERO;
        let Ok(index) = KdIndex::new(&points) else {
            return;
        };
        let params = geosynth::mls::MlsParams::default();
        group.bench_with_input(
            BenchmarkId::new("isolated_samples", n),
            &index,
            |b, index| b.iter(|| geosynth::mls::isolated_samples(black_box(index), &params)),
        );
    }
    group.finish();
}

/// `core::surface_sampling::sample_surface` on an icosphere of 20,480 triangles: 100,000
/// points uniform by area, and a Poisson disk of about 100,000 (32 candidates per
/// spacing², the default pool).
fn surface_sampling(c: &mut Criterion) {
    use geosynth::core::RunContext;
    use geosynth::core::surface_sampling::{SampleNormals, SurfaceSampling, sample_surface};
    let mut group = c.benchmark_group("surface_sampling");
    group.sample_size(10);
    let sphere = geosynth::fixtures::icosphere_mesh(5).expect("benchmark setup");
    let poisson =
        SurfaceSampling::poisson_disk_for_count(sphere.area(), 100_000).expect("benchmark setup");
    for (name, sampling) in [
        ("uniform_100k", SurfaceSampling::Uniform { count: 100_000 }),
        ("poisson_disk_100k", poisson),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| {
                let mut ctx = RunContext::new(1);
                sample_surface(
                    black_box(&sphere),
                    &sampling,
                    SampleNormals::Faces,
                    &mut ctx,
                )
            })
        });
    }
    group.finish();
}

/// `core::surface_sampling::thin_points` on 1,000,000 points of a torus: a Poisson disk of
/// spacing 0.01 (about 80,000 kept), and about 100,000 kept by count (the spacing searched
/// for, a pass each try).
fn point_thinning(c: &mut Criterion) {
    use geosynth::core::RunContext;
    use geosynth::core::surface_sampling::{PointThinning, thin_points};
    let mut group = c.benchmark_group("thin_points_1m");
    group.sample_size(10);
    let torus = geosynth::fixtures::torus_points(1_000_000, 1.0, 0.35, 2).expect("benchmark setup");
    for (name, thinning) in [
        ("spacing_0.01", PointThinning::PoissonDisk { spacing: 0.01 }),
        (
            "count_100k",
            PointThinning::PoissonDiskCount { count: 100_000 },
        ),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| thin_points(black_box(&torus), &thinning, &mut RunContext::new(1)))
        });
    }
    group.finish();
}

criterion_group!(
    benches,
    kd_index,
    kd_region,
    bucket_grid,
    stray_points,
    isolated_points,
    surface_sampling,
    point_thinning
);
criterion_main!(benches);
