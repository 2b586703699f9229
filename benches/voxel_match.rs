//! Paper 001 Table 1: matching time of the search tree vs the plain linear search, the
//! pruned linear search (partial distances + Eq. 2 filters) and the FFT matcher on a real
//! distance field (the watertight bunny; a pile of random balls without
//! `GEOSYNTH_DATA`).

// A benchmark whose setup fails has nothing to measure: aborting is the right outcome.
#![allow(clippy::expect_used)]

mod common;

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use geosynth::core::rng;
use geosynth::sdf::{GridSpec, MeshSurface, Quantizer, SdfGrid};
use geosynth::voxel::{BlockMatcher, BruteForce, FftMatcher, QuantizedField, SearchTree};
use rand::RngExt;

/// The source field: the bunny's signed distance at `res³`, quantized over ±4 spacings.
fn source(res: usize) -> QuantizedField {
    let bunny = common::watertight_bunny()
        .expect("set GEOSYNTH_DATA to the shared data folder for this benchmark");
    let mesh = &bunny;
    let surface = MeshSurface::new(mesh).expect("benchmark setup");
    let bounds = mesh.bounding_box().expect("bounds");
    let spec = GridSpec::covering(bounds, res, 0.0).expect("grid");
    let band = 4.0 * spec.spacing;
    let sdf = SdfGrid::from_surface(&surface, &spec, band).expect("field");
    QuantizedField::from_grid(
        &sdf.distances().expect("distances"),
        &Quantizer::new(band).expect("quantizer"),
    )
}

/// Queries like synthesis produces: source blocks from random places with small noise.
fn queries(field: &QuantizedField, n: usize, count: usize) -> Vec<Vec<u8>> {
    let mut g = rng::rng_from_seed(7);
    let [x, y, z] = field.dims();
    (0..count)
        .map(|_| {
            let corner = [
                g.random_range(0..=x - n),
                g.random_range(0..=y - n),
                g.random_range(0..=z - n),
            ];
            field
                .block(corner, n)
                .into_iter()
                .map(|v| v.saturating_add(g.random_range(0..3)))
                .collect()
        })
        .collect()
}

fn table1(c: &mut Criterion) {
    let mut group = c.benchmark_group("voxel_table1");
    group.sample_size(10);
    for (res, n) in [(64usize, 8usize), (128, 16)] {
        let field = source(res);
        let start = std::time::Instant::now();
        let tree = SearchTree::build(&field, n).expect("tree");
        eprintln!(
            "{res}^3/{n}: tree built in {:.2}s, {:?}",
            start.elapsed().as_secs_f64(),
            tree.stats()
        );
        let qs = queries(&field, n, 8);
        let brute = BruteForce::new(&field, n).expect("brute force");
        let fft = FftMatcher::new(&field, n).expect("fft");
        let label = format!("{res}^3_block{n}");
        group.bench_with_input(BenchmarkId::new("tree", &label), &qs, |b, qs| {
            b.iter(|| {
                qs.iter()
                    .map(|q| {
                        tree.best_match(black_box(q))
                            .map_or(f32::NAN, |m| m.distance)
                    })
                    .sum::<f32>()
            })
        });
        group.bench_with_input(BenchmarkId::new("brute_force", &label), &qs, |b, qs| {
            b.iter(|| {
                qs.iter()
                    .map(|q| {
                        brute
                            .best_match(black_box(q))
                            .map_or(f32::NAN, |m| m.distance)
                    })
                    .sum::<f32>()
            })
        });
        group.bench_with_input(BenchmarkId::new("linear_plain", &label), &qs, |b, qs| {
            b.iter(|| {
                qs.iter()
                    .map(|q| {
                        brute
                            .exhaustive(black_box(q))
                            .map_or(f32::NAN, |m| m.distance)
                    })
                    .sum::<f32>()
            })
        });
        group.bench_with_input(BenchmarkId::new("fft", &label), &qs, |b, qs| {
            b.iter(|| {
                qs.iter()
                    .map(|q| {
                        fft.best_match(black_box(q))
                            .map_or(f32::NAN, |m| m.distance)
                    })
                    .sum::<f32>()
            })
        });
    }
    group.finish();
    if std::env::var_os("GEOSYNTH_TABLE1_256").is_some() {
        table1_256();
    }
}

/// The 256³ / 32 row, timed once per matcher (a criterion loop would take hours): set
/// `GEOSYNTH_TABLE1_256=1`. The FFT matcher is left out (its 512³ complex spectra need
/// about 8 GB).
fn table1_256() {
    let (res, n) = (256usize, 32usize);
    let field = source(res);
    let start = std::time::Instant::now();
    let tree = SearchTree::build(&field, n).expect("tree");
    eprintln!(
        "{res}^3/{n}: tree built in {:.1}s, {:?}",
        start.elapsed().as_secs_f64(),
        tree.stats()
    );
    let brute = BruteForce::new(&field, n).expect("brute force");
    let qs = queries(&field, n, 2);
    let time = |name: &str, f: &dyn Fn(&[u8]) -> f32| {
        let start = std::time::Instant::now();
        let d: Vec<f32> = qs.iter().map(|q| f(q)).collect();
        eprintln!(
            "{res}^3/{n} {name}: {:.3}s per query (distances {d:?})",
            start.elapsed().as_secs_f64() / qs.len() as f64
        );
    };
    time("tree", &|q| {
        tree.best_match(q).map_or(f32::NAN, |m| m.distance)
    });
    time("brute_force", &|q| {
        brute.best_match(q).map_or(f32::NAN, |m| m.distance)
    });
    time("linear_plain", &|q| {
        brute.exhaustive(q).map_or(f32::NAN, |m| m.distance)
    });
}

criterion_group!(benches, table1);
criterion_main!(benches);
