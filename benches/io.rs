//! File codecs: PLY encode/decode in each encoding, on a 100k-point oriented set with colours;
//! STL encode/decode (with welding) of a 100k-triangle mesh.

// A benchmark whose setup fails has nothing to measure: aborting is the right outcome.
#![allow(clippy::expect_used)]

use std::hint::black_box;
use std::path::Path;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use geosynth::core::io::ply::PlyEncoding;
use geosynth::core::io::{self, FileFormat, Geometry, WriteOptions};
use geosynth::fixtures;

fn ply(c: &mut Criterion) {
    let mut points = fixtures::torus_points(100_000, 1.0, 0.3, 7).expect("benchmark setup");
    let colors: Vec<[f32; 3]> = points
        .positions()
        .iter()
        .map(|p| [p.x.abs(), p.y.abs(), p.z.abs()])
        .collect();
    points.set_colors(&colors).expect("benchmark setup");
    let geometry = Geometry::Points(points);
    let mut group = c.benchmark_group("ply_100k_points");
    group.sample_size(20);
    group.throughput(Throughput::Elements(100_000));
    for encoding in PlyEncoding::ALL {
        let options = WriteOptions::default().ply_encoding(encoding);
        let bytes =
            io::encode_geometry(&geometry, FileFormat::Ply, &options).expect("benchmark setup");
        group.bench_with_input(
            BenchmarkId::new("write", encoding.keyword()),
            &options,
            |b, o| b.iter(|| io::encode_geometry(black_box(&geometry), FileFormat::Ply, o)),
        );
        group.bench_with_input(
            BenchmarkId::new("read", encoding.keyword()),
            &bytes,
            |b, data| b.iter(|| io::read_geometry_bytes(Path::new("bench.ply"), black_box(data))),
        );
    }
    group.finish();
}

fn stl(c: &mut Criterion) {
    // A torus of 224 × 224 quads: 100,352 triangles over 50,176 shared vertices.
    let mesh = fixtures::torus_mesh(224, 224, 1.0, 0.3).expect("benchmark setup");
    let geometry = Geometry::Mesh(mesh);
    let mut group = c.benchmark_group("stl_100k_triangles");
    group.sample_size(20);
    group.throughput(Throughput::Elements(100_352));
    let binary =
        io::encode_geometry(&geometry, FileFormat::Stl, &WriteOptions::default()).expect("setup");
    let mut ascii = Vec::new();
    io::write_stl_ascii(&geometry, &mut ascii).expect("benchmark setup");
    group.bench_function("write/binary", |b| {
        b.iter(|| {
            io::encode_geometry(
                black_box(&geometry),
                FileFormat::Stl,
                &WriteOptions::default(),
            )
        })
    });
    for (name, bytes) in [("binary", &binary), ("ascii", &ascii)] {
        group.bench_with_input(BenchmarkId::new("read", name), bytes, |b, data| {
            b.iter(|| io::read_geometry_bytes(Path::new("bench.stl"), black_box(data)))
        });
    }
    group.finish();
}

criterion_group!(benches, ply, stl);
criterion_main!(benches);
