//! Thin-plate spline kernels: fitting, warping with normal transport, pairing.

// A benchmark whose setup fails has nothing to measure: aborting is the right outcome.
#![allow(clippy::expect_used)]

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use geosynth::core::rng;
use geosynth::fixtures;
use geosynth::tps::{PairingParams, PairingPoint, ThinPlateSpline, TpsParams, pair_points};
use glam::Vec3;
use rand::RngExt;

fn controls(n: usize, seed: u64) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut g = rng::rng_from_seed(seed);
    let s: Vec<Vec3> = (0..n)
        .map(|_| Vec3::new(g.random(), g.random(), g.random::<f32>() * 0.2))
        .collect();
    let q = s
        .iter()
        .map(|p| *p + Vec3::new(g.random(), g.random(), g.random()) * 0.02)
        .collect();
    (s, q)
}

fn fit(c: &mut Criterion) {
    let mut group = c.benchmark_group("tps_fit");
    group.sample_size(10);
    for n in [50usize, 200, 500, 1500] {
        let (s, q) = controls(n, 1);
        group.bench_with_input(BenchmarkId::from_parameter(n), &(s, q), |b, (s, q)| {
            b.iter(|| ThinPlateSpline::fit(black_box(s), black_box(q), &TpsParams::default()))
        });
    }
    group.finish();
}

fn warp(c: &mut Criterion) {
    let (s, q) = controls(200, 2);
    let spline = ThinPlateSpline::fit(&s, &q, &TpsParams::default()).expect("benchmark setup");
    let points = fixtures::heightfield_points(317, 1.0, 3).expect("benchmark setup");
    let mut group = c.benchmark_group("tps_warp_200_pairs");
    group.sample_size(10);
    group.throughput(Throughput::Elements(points.len() as u64));
    group.bench_function("positions_jacobians_normals_100k", |b| {
        b.iter(|| spline.warp(black_box(points.positions()), points.normals()))
    });
    group.bench_function("positions_100k", |b| {
        b.iter(|| spline.eval_many(black_box(points.positions())))
    });
    group.bench_function("jacobians_100k", |b| {
        b.iter(|| spline.jacobians(black_box(points.positions())))
    });
    group.finish();
}

fn pairing(c: &mut Criterion) {
    let points = fixtures::heightfield_points(60, 1.0, 4).expect("benchmark setup");
    let as_pairing = |i: usize| PairingPoint {
        position: points.positions()[i],
        normal: points.normals().map_or(Vec3::Z, |n| n[i]),
        variation: 0.0,
    };
    let sources: Vec<PairingPoint> = (0..2000).map(as_pairing).collect();
    let targets: Vec<PairingPoint> = (0..200)
        .map(|i| {
            let mut p = as_pairing(i * 10);
            p.position += Vec3::new(0.003, -0.002, 0.001);
            p
        })
        .collect();
    let mut group = c.benchmark_group("tps_pairing");
    group.sample_size(10);
    group.bench_function("200_targets_2000_sources_3_rounds", |b| {
        b.iter(|| {
            pair_points(
                black_box(&sources),
                black_box(&targets),
                &PairingParams::default(),
            )
        })
    });
    group.bench_function("200_targets_2000_sources_3_rounds_max_distance", |b| {
        b.iter(|| {
            pair_points(
                black_box(&sources),
                black_box(&targets),
                &PairingParams::default().max_distance(0.05),
            )
        })
    });
    group.finish();
}

criterion_group!(benches, fit, warp, pairing);
criterion_main!(benches);
