//! Preview rendering: point splats and shaded triangles at 640×480.

// A benchmark whose setup fails has nothing to measure: aborting is the right outcome.
#![allow(clippy::expect_used)]

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use geosynth::core::io::Geometry;
use geosynth::fixtures;
use geosynth::preview::{self, RenderOptions};

fn render(c: &mut Criterion) {
    let options = RenderOptions::default();
    let points =
        Geometry::Points(fixtures::torus_points(100_000, 1.0, 0.3, 9).expect("benchmark setup"));
    let mesh = Geometry::Mesh(fixtures::torus_mesh(256, 128, 1.0, 0.3).expect("benchmark setup"));
    let mut group = c.benchmark_group("render_640x480");
    group.sample_size(20);
    group.bench_function("splats_100k", |b| {
        b.iter(|| preview::render(black_box(&points), &options))
    });
    group.bench_function("mesh_65k_triangles", |b| {
        b.iter(|| preview::render(black_box(&mesh), &options))
    });
    group.finish();
}

criterion_group!(benches, render);
criterion_main!(benches);
