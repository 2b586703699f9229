//! File codecs: PLY, PCD and glTF encode/decode in each encoding, on a 100k-point oriented
//! set with colours; STL encode/decode (with welding) of a 100k-triangle mesh.

// A benchmark whose setup fails has nothing to measure: aborting is the right outcome.
#![allow(clippy::expect_used)]

use std::hint::black_box;
use std::path::Path;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use geosynth::core::io::ply::PlyEncoding;
use geosynth::core::io::{self, FileFormat, Geometry, GltfContainer, PcdEncoding, WriteOptions};
use geosynth::fixtures;

/// A 100k-point oriented set with colours.
fn coloured_points() -> Geometry {
    let mut points = fixtures::torus_points(100_000, 1.0, 0.3, 7).expect("benchmark setup");
    let colors: Vec<[f32; 3]> = points
        .positions()
        .iter()
        .map(|p| [p.x.abs(), p.y.abs(), p.z.abs()])
        .collect();
    points.set_colors(&colors).expect("benchmark setup");
    Geometry::Points(points)
}

/// Writing and reading `geometry` as `format` with each named set of options, in the
/// group `group_name` (`file_name` names the format to the reader).
fn codec(
    c: &mut Criterion,
    group_name: &str,
    format: FileFormat,
    file_name: &str,
    cases: &[(&str, WriteOptions)],
) {
    let geometry = coloured_points();
    let mut group = c.benchmark_group(group_name);
    group.sample_size(20);
    group.throughput(Throughput::Elements(100_000));
    for (name, options) in cases {
        let bytes = io::encode_geometry(&geometry, format, options).expect("benchmark setup");
        group.bench_with_input(BenchmarkId::new("write", name), options, |b, o| {
            b.iter(|| io::encode_geometry(black_box(&geometry), format, o))
        });
        group.bench_with_input(BenchmarkId::new("read", name), &bytes, |b, data| {
            b.iter(|| io::read_geometry_bytes(Path::new(file_name), black_box(data)))
        });
    }
    group.finish();
}

fn ply(c: &mut Criterion) {
    let cases = PlyEncoding::ALL.map(|e| (e.keyword(), WriteOptions::default().ply_encoding(e)));
    codec(c, "ply_100k_points", FileFormat::Ply, "bench.ply", &cases);
}

fn pcd(c: &mut Criterion) {
    let cases = [
        PcdEncoding::Binary,
        PcdEncoding::Ascii,
        PcdEncoding::BinaryCompressed,
    ]
    .map(|e| (e.keyword(), WriteOptions::default().pcd_encoding(e)));
    codec(c, "pcd_100k_points", FileFormat::Pcd, "bench.pcd", &cases);
}

fn gltf(c: &mut Criterion) {
    for container in [GltfContainer::Binary, GltfContainer::Json] {
        let ext = container.extension();
        let cases = [("default", WriteOptions::default())];
        let format = FileFormat::Gltf(container);
        let group = format!("{ext}_100k_points");
        codec(c, &group, format, &format!("bench.{ext}"), &cases);
    }
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

criterion_group!(benches, ply, pcd, gltf, stl);
criterion_main!(benches);
