//! Patch quilting: the search kernel at a realistic size, a full small synthesis, and the
//! quality measure (building its exemplar side, and measuring one output with it).

// A benchmark whose setup fails has nothing to measure: aborting is the right outcome.
#![allow(clippy::expect_used)]

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use geosynth::core::{RunContext, rng};
use geosynth::fixtures::textures;
use geosynth::quilt::search::{OverlapNode, candidates, distances};
use geosynth::quilt::{OutputSize, QualityMeasure, QuiltParams, quilt, texture_from_exemplar};
use glam::Vec4;
use rand::RngExt;

fn search_kernel(c: &mut Criterion) {
    // D(T_in) of 48 × 48 × 10 nodes; an L-shaped overlap of a 19-node patch (3 nodes wide).
    let (nx, ny, nz, np, no) = (48usize, 48usize, 10usize, 19usize, 3usize);
    let mut g = rng::rng_from_seed(1);
    let field: Vec<Vec4> = (0..nx * ny * nz)
        .map(|_| Vec4::new(g.random(), g.random(), g.random(), g.random()))
        .collect();
    let side = np + 1;
    let mut overlap = Vec::new();
    for k in 0..nz {
        for b in 0..side {
            for a in 0..side {
                if a <= no || b <= no {
                    overlap.push(OverlapNode {
                        exemplar_offset: a + nx * (b + ny * k),
                        neighbourhood_index: a + side * (b + side * k),
                    });
                }
            }
        }
    }
    let neighbourhood: Vec<Vec4> = (0..side * side * nz)
        .map(|_| Vec4::new(g.random(), g.random(), g.random(), g.random()))
        .collect();
    let (max_i, max_j) = (nx - np - 1, ny - np - 1);
    let mut group = c.benchmark_group("quilt_search");
    group.bench_function("exhaustive_28x28_positions_1440_nodes", |b| {
        b.iter(|| {
            let d = distances(
                black_box(&field),
                nx,
                max_i,
                max_j,
                &overlap,
                &neighbourhood,
            )
            .expect("the overlap lies inside both fields");
            candidates(&d, 0.1)
        })
    });
    group.finish();
}

fn synthesis(c: &mut Criterion) {
    let exemplar = textures::bumpy(textures::TEXTURE_DENSITY, 1, 1).expect("benchmark setup");
    let texture = texture_from_exemplar(&exemplar).expect("benchmark setup");
    let params = QuiltParams::default().output(OutputSize::Scale(1.5));
    let mut group = c.benchmark_group("quilt_full");
    group.sample_size(10);
    group.bench_function("bumpy_12k_points_scale_1.5", |b| {
        b.iter(|| quilt(black_box(&texture), &params, &mut RunContext::new(1)))
    });
    group.finish();
}

fn quality(c: &mut Criterion) {
    let exemplar = textures::bumpy(textures::TEXTURE_DENSITY, 1, 1).expect("benchmark setup");
    let texture = texture_from_exemplar(&exemplar).expect("benchmark setup");
    let params = QuiltParams::default().output(OutputSize::Scale(1.5));
    let output = quilt(&texture, &params, &mut RunContext::new(1)).expect("benchmark setup");
    let measure = QualityMeasure::new(&texture, &params).expect("benchmark setup");
    let mut group = c.benchmark_group("quilt_quality");
    group.sample_size(10);
    group.bench_function("measure_setup_bumpy_12k_points", |b| {
        b.iter(|| QualityMeasure::new(black_box(&texture), &params))
    });
    group.bench_function("evaluate_bumpy_scale_1.5_32_windows", |b| {
        b.iter(|| measure.evaluate(black_box(&output), 32))
    });
    group.finish();
}

criterion_group!(benches, search_kernel, synthesis, quality);
criterion_main!(benches);
