//! Spatial index kernels: k-d tree build and queries, bucket grid churn and queries.

// A benchmark whose setup fails has nothing to measure: aborting is the right outcome.
#![allow(clippy::expect_used)]

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use geosynth::core::rng;
use geosynth::core::{Aabb, BucketGrid, KdIndex};
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

criterion_group!(benches, kd_index, bucket_grid);
criterion_main!(benches);
