//! Surface kernels: MLS projection throughput, the MLS surface read as a height field,
//! signed distance grids from a mesh and from a point set (signed either way), winding
//! numbers of meshes and point clouds, iso-surface extraction, normals of unoriented
//! points (fitted by PCA, oriented by propagation), mesh simplification.

// A benchmark whose setup fails has nothing to measure: aborting is the right outcome.
#![allow(clippy::expect_used)]

mod common;

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use geosynth::core::simplify::{SimplifyParams, simplify_mesh};
use geosynth::core::{KdIndex, RunContext, rng};
use geosynth::fixtures;
use geosynth::mls::{
    MlsParams, MlsSurface, NORMAL_NEIGHBOURS, fit_normals, fit_normals_with,
    fit_oriented_normals_with, orient_normals, orient_normals_with,
};
use geosynth::sdf::{
    GridSpec, MeshSign, MeshSurface, PointWinding, SdfGrid, WindingSigned, sdf_isosurface,
    sdf_isosurface_of,
};
use glam::{Vec2, Vec3};
use rand::RngExt;

fn mls_projection(c: &mut Criterion) {
    let points = fixtures::torus_points(100_000, 1.0, 0.35, 1).expect("benchmark setup");
    let surface = MlsSurface::new(&points, &MlsParams::default()).expect("benchmark setup");
    let mut g = rng::rng_from_seed(2);
    // Queries within one kernel of the surface, as in distance-field sampling near it.
    let (queries, normals): (Vec<Vec3>, Vec<Vec3>) = points
        .positions()
        .iter()
        .zip(points.normals().expect("normals"))
        .step_by(10)
        .map(|(p, n)| (*p + *n * g.random_range(-1.0..1.0) * surface.kernel(), *n))
        .unzip();
    let mut group = c.benchmark_group("mls_projection_100k_points");
    group.sample_size(10);
    group.throughput(Throughput::Elements(queries.len() as u64));
    group.bench_function("project_all_10k_queries", |b| {
        b.iter(|| surface.project_all(black_box(&queries)))
    });
    // Paper 000's two-ray snap along each query's normal, as the quilt's blend runs it.
    group.bench_function("snap_10k_queries", |b| {
        b.iter(|| {
            for (&q, &n) in queries.iter().zip(&normals) {
                black_box(surface.snap(q, n));
            }
        })
    });
    group.finish();
}

/// The surface read as a height field (`geosynth quilt --heightfield-out`): a rolling
/// 200 × 200 height field's samples, read back between them.
fn mls_top_heights(c: &mut Criterion) {
    let heights = (0..200 * 200)
        .map(|i| {
            let (x, y) = ((i % 200) as f32 * 0.05, (i / 200) as f32 * 0.05);
            (2.0 * x).sin() * (1.5 * y).cos() + 0.3 * (5.0 * x + 3.0 * y).sin()
        })
        .collect();
    let field = geosynth::core::HeightField::new(200, 200, heights).expect("benchmark setup");
    let points = field.to_points(0.02, 0.2).expect("benchmark setup");
    let surface = MlsSurface::new(&points, &MlsParams::default()).expect("benchmark setup");
    let columns: Vec<Vec2> = (0..200 * 200)
        .map(|i| Vec2::new((i % 200) as f32 + 0.37, (i / 200) as f32 + 0.61) * 0.02)
        .collect();
    let mut group = c.benchmark_group("mls_top_heights_40k_points");
    group.sample_size(10);
    group.throughput(Throughput::Elements(columns.len() as u64));
    group.bench_function("40k_columns", |b| {
        b.iter(|| surface.top_heights(black_box(&columns)))
    });
    group.finish();
}

fn sdf_grids(c: &mut Criterion) {
    let mut group = c.benchmark_group("sdf_grid");
    group.sample_size(10);
    match common::watertight_bunny() {
        Some(bunny) => {
            let mesh = &bunny;
            let surface = MeshSurface::new(mesh).expect("benchmark setup");
            let bounds = mesh.bounding_box().expect("bounds");
            for n in [64usize, 128] {
                let spec = GridSpec::covering(bounds, n, 0.05 * bounds.diagonal()).expect("grid");
                // The default band of the CLI and the facade: 4 grid spacings.
                group.bench_with_input(
                    BenchmarkId::new("bunny_mesh_70k_triangles_band4", n),
                    &spec,
                    |b, spec| b.iter(|| SdfGrid::from_surface(&surface, spec, 4.0 * spec.spacing)),
                );
                // No clamping at all: every node gets its exact distance.
                group.bench_with_input(
                    BenchmarkId::new("bunny_mesh_70k_triangles_unclamped", n),
                    &spec,
                    |b, spec| {
                        b.iter(|| SdfGrid::from_surface(&surface, spec, 2.0 * bounds.diagonal()))
                    },
                );
            }
        }
        None => eprintln!("skipped sdf_grid/bunny_mesh: GEOSYNTH_DATA is not set"),
    }
    let points = fixtures::torus_points(100_000, 1.0, 0.35, 3).expect("benchmark setup");
    let mls = MlsSurface::new(&points, &MlsParams::default()).expect("benchmark setup");
    let bounds = points.bounding_box().expect("bounds");
    for n in [64usize, 128] {
        let spec = GridSpec::covering(bounds, n, 0.1).expect("grid");
        group.bench_with_input(BenchmarkId::new("mls_100k_points", n), &spec, |b, spec| {
            b.iter(|| SdfGrid::from_surface(&mls, spec, 4.0 * spec.spacing))
        });
    }
    // The same grid signed by the points' winding number.
    let signed = WindingSigned::new(
        MlsSurface::new(&points, &MlsParams::default()).expect("benchmark setup"),
        PointWinding::new(&points).expect("benchmark setup"),
    );
    let spec = GridSpec::covering(bounds, 64, 0.1).expect("grid");
    group.bench_with_input(
        BenchmarkId::new("mls_100k_points_winding_signs", 64),
        &spec,
        |b, spec| b.iter(|| SdfGrid::from_surface(&signed, spec, 4.0 * spec.spacing)),
    );
    let spec = GridSpec::covering(bounds, 128, 0.1).expect("grid");
    let field = SdfGrid::from_surface(&mls, &spec, 4.0 * spec.spacing).expect("field");
    group.bench_function("isosurface_128", |b| {
        b.iter(|| sdf_isosurface(black_box(&field)))
    });
    // The same zero set with its crossings checked against the surface, and those the
    // interpolation misses looked for along their edges.
    group.bench_function("isosurface_of_surface_128", |b| {
        b.iter(|| sdf_isosurface_of(black_box(&field), &mls))
    });
    group.finish();
}

/// 10k queries spread over the box around `bounds`, as a distance grid asks near and far.
fn box_queries(bounds: geosynth::core::Aabb, seed: u64) -> Vec<Vec3> {
    let mut g = rng::rng_from_seed(seed);
    let (lo, extent) = (bounds.min, bounds.extent());
    (0..10_000)
        .map(|_| lo + extent * Vec3::new(g.random(), g.random(), g.random()))
        .collect()
}

/// Benchmarks `winding` summed over `queries`.
fn bench_queries(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    queries: &[Vec3],
    winding: impl Fn(Vec3) -> f32,
) {
    group.bench_function(name, |b| {
        b.iter(|| black_box(queries).iter().map(|&q| winding(q)).sum::<f32>())
    });
}

fn winding_numbers(c: &mut Criterion) {
    let mut group = c.benchmark_group("winding_numbers");
    group.sample_size(10);
    let points = fixtures::torus_points(100_000, 1.0, 0.35, 4).expect("benchmark setup");
    group.bench_function("point_cloud_100k_build", |b| {
        b.iter(|| PointWinding::new(black_box(&points)))
    });
    let winding = PointWinding::new(&points).expect("benchmark setup");
    let queries = box_queries(points.bounding_box().expect("bounds"), 5);
    group.throughput(Throughput::Elements(queries.len() as u64));
    bench_queries(&mut group, "point_cloud_100k_10k_queries", &queries, |q| {
        winding.winding_number(q)
    });
    match common::watertight_bunny() {
        Some(bunny) => {
            let surface = MeshSurface::new(&bunny)
                .expect("benchmark setup")
                .with_sign(MeshSign::WindingNumber);
            let queries = box_queries(bunny.bounding_box().expect("bounds"), 6);
            bench_queries(
                &mut group,
                "bunny_mesh_70k_triangles_10k_queries",
                &queries,
                |q| surface.winding_number(q),
            );
        }
        None => eprintln!("skipped winding_numbers/bunny_mesh: GEOSYNTH_DATA is not set"),
    }
    group.finish();
}

/// Preparing a mesh for distance queries: normals, pseudo-normals, the bounding-volume
/// hierarchy and its winding-number dipoles, on a torus of 500,000 triangles.
fn mesh_surface_build(c: &mut Criterion) {
    let torus = fixtures::torus_mesh(500, 500, 1.0, 0.35).expect("benchmark setup");
    let mut group = c.benchmark_group("mesh_surface");
    group.sample_size(10);
    group.bench_function("build_torus_500k_triangles", |b| {
        b.iter(|| MeshSurface::new(black_box(&torus)))
    });
    group.finish();
}

/// `geosynth simplify`: a bumpy torus of 200,000 triangles (bumps so that no two
/// vertices share their planes) down to a tenth and to a hundredth.
fn mesh_simplification(c: &mut Criterion) {
    let torus = fixtures::torus_mesh(400, 250, 1.0, 0.35).expect("benchmark setup");
    let mut g = rng::rng_from_seed(5);
    let mut vertices = torus.vertices().clone();
    let bumpy: Vec<Vec3> = vertices
        .positions()
        .iter()
        .map(|&p| p * (1.0 + g.random_range(-0.002..0.002)))
        .collect();
    vertices = geosynth::core::PointSet::new(bumpy).expect("benchmark setup");
    let torus = geosynth::core::TriMesh::new(vertices, torus.triangles().to_vec())
        .expect("benchmark setup");
    let mut group = c.benchmark_group("simplify_200k_triangles");
    group.sample_size(10);
    group.throughput(Throughput::Elements(torus.face_count() as u64));
    for target in [20_000, 2_000] {
        let params = SimplifyParams::faces(target);
        group.bench_with_input(BenchmarkId::new("to", target), &params, |b, params| {
            b.iter(|| simplify_mesh(black_box(&torus), params, &mut RunContext::new(0)))
        });
    }
    group.finish();
}

/// `geosynth normals` on 200,000 points of a torus: the PCA fit of every point's
/// neighbourhood, and the orientation of normals whose signs are random (as fits come).
fn point_normals(c: &mut Criterion) {
    let points = fixtures::torus_points(200_000, 1.0, 0.35, 3).expect("benchmark setup");
    let unoriented =
        geosynth::core::PointSet::new(points.positions().to_vec()).expect("benchmark setup");
    let mut g = rng::rng_from_seed(4);
    let signs = points
        .normals()
        .expect("normals")
        .iter()
        .map(|&n| if g.random_bool(0.5) { n } else { -n })
        .collect();
    let mixed = unoriented
        .clone()
        .with_normals(signs)
        .expect("benchmark setup");
    let mut group = c.benchmark_group("normals_200k_points");
    group.sample_size(10);
    group.throughput(Throughput::Elements(200_000));
    group.bench_function("fit", |b| {
        b.iter(|| fit_normals(black_box(&unoriented), NORMAL_NEIGHBOURS))
    });
    group.bench_function("orient", |b| {
        b.iter(|| orient_normals(black_box(&mixed), Vec3::Z))
    });
    // `geosynth normals`: one index, the fit and the orientation one after the other, or
    // in one pass that hands the fit's neighbours to the orientation's graph.
    let index = KdIndex::new(unoriented.positions()).expect("benchmark setup");
    let mut ctx = RunContext::new(0);
    group.bench_function("fit_then_orient", |b| {
        b.iter(|| {
            let fit =
                fit_normals_with(&index, black_box(&unoriented), NORMAL_NEIGHBOURS, &mut ctx)?;
            orient_normals_with(&index, &fit.points, Vec3::Z, &mut ctx)
        })
    });
    group.bench_function("fit_and_orient", |b| {
        b.iter(|| {
            let points = black_box(&unoriented).clone();
            fit_oriented_normals_with(&index, points, NORMAL_NEIGHBOURS, Vec3::Z, &mut ctx)
        })
    });
    group.finish();
}

criterion_group!(
    benches,
    point_normals,
    mls_projection,
    mls_top_heights,
    sdf_grids,
    winding_numbers,
    mesh_surface_build,
    mesh_simplification
);
criterion_main!(benches);
