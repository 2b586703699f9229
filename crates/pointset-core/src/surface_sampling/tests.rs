#![allow(clippy::unwrap_used)]

use glam::{Vec2, Vec3};

use super::*;
use crate::{CancelFlag, ScalarType};

fn mesh(corners: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> TriMesh {
    TriMesh::new(PointSet::new(corners).unwrap(), triangles).unwrap()
}

fn sample(mesh: &TriMesh, sampling: SurfaceSampling, normals: SampleNormals) -> SurfaceSamples {
    sample_surface(mesh, &sampling, normals, &mut RunContext::new(3)).unwrap()
}

/// Each sample's position, normal and triangle.
fn each_sample(samples: &SurfaceSamples) -> impl Iterator<Item = (Vec3, Vec3, u32)> + '_ {
    let normals = samples.points.normals().unwrap_or(&[]);
    let positions = samples.points.positions();
    assert_eq!(normals.len(), positions.len(), "every sample has a normal");
    assert_eq!(
        samples.faces.len(),
        positions.len(),
        "every sample has a triangle"
    );
    (positions.iter().zip(normals).zip(&samples.faces)).map(|((p, n), f)| (*p, *n, *f))
}

/// A sheet over the unit square, `z = 0.3 sin(3x) cos(2y)`, as an `n × n` grid of
/// quads, each split in two.
fn wavy_sheet(n: u32) -> TriMesh {
    let side = n + 1;
    let corners = (0..side * side)
        .map(|i| {
            let (x, y) = ((i % side) as f32 / n as f32, (i / side) as f32 / n as f32);
            Vec3::new(x, y, 0.3 * (3.0 * x).sin() * (2.0 * y).cos())
        })
        .collect();
    let triangles = (0..n * n)
        .flat_map(|q| {
            let corner = q / n * side + q % n;
            [
                [corner, corner + 1, corner + side + 1],
                [corner, corner + side + 1, corner + side],
            ]
        })
        .collect();
    mesh(corners, triangles)
}

/// The barycentric weights of `p` in the triangle `[a, b, c]`, and its distance from the
/// triangle's plane.
fn barycentric(p: Vec3, [a, b, c]: [Vec3; 3]) -> ([f32; 3], f32) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let normal = ab.cross(ac);
    let off_plane = ap.dot(normal) / normal.length();
    let area = normal.length_squared();
    let wb = ap.cross(ac).dot(normal) / area;
    let wc = ab.cross(ap).dot(normal) / area;
    ([1.0 - wb - wc, wb, wc], off_plane)
}

#[test]
fn samples_lie_on_their_triangles_with_their_triangles_normals() {
    let sheet = wavy_sheet(12);
    for sampling in [
        SurfaceSampling::Uniform { count: 3000 },
        SurfaceSampling::PoissonDisk { spacing: 0.04 },
    ] {
        let samples = sample(&sheet, sampling, SampleNormals::Faces);
        let face_normals = sheet.face_normals();
        for (p, n, face) in each_sample(&samples) {
            let corners = sheet.triangles()[face as usize].map(|v| sheet.positions()[v as usize]);
            let (weights, off_plane) = barycentric(p, corners);
            assert!(
                off_plane.abs() < 1e-6,
                "{p} is {off_plane} off its triangle's plane"
            );
            assert!(
                weights.iter().all(|w| *w > -1e-5),
                "{p} is outside its triangle: {weights:?}"
            );
            assert_eq!(n, face_normals[face as usize]);
        }
    }
}

#[test]
fn uniform_samples_choose_triangles_by_area_and_never_a_flat_one() {
    // Four separate triangles of areas 0.5, 1, 1.5 and 2, and two of zero area.
    let mut corners = Vec::new();
    let mut triangles = Vec::new();
    for (i, height) in [1.0f32, 2.0, 0.0, 3.0, 4.0, 0.0].into_iter().enumerate() {
        let x = 10.0 * i as f32;
        let first = corners.len() as u32;
        corners.extend([
            Vec3::new(x, 0.0, 0.0),
            Vec3::new(x + 1.0, 0.0, 0.0),
            Vec3::new(x, height, 0.0),
        ]);
        triangles.push([first, first + 1, first + 2]);
    }
    let count = 200_000;
    let samples = sample(
        &mesh(corners, triangles),
        SurfaceSampling::Uniform { count },
        SampleNormals::Faces,
    );
    let mut per_face = [0usize; 6];
    for face in &samples.faces {
        per_face[*face as usize] += 1;
    }
    assert_eq!((per_face[2], per_face[5]), (0, 0));
    for (face, area) in [(0, 0.5), (1, 1.0), (3, 1.5), (4, 2.0)] {
        let share = area / 5.0;
        let expected = count as f64 * share;
        let deviation = (count as f64 * share * (1.0 - share)).sqrt();
        let found = per_face[face] as f64;
        assert!(
            (found - expected).abs() < 4.0 * deviation,
            "face {face}: {found} samples, expected {expected} ± {deviation}"
        );
    }
}

#[test]
fn uniform_samples_spread_evenly_over_a_triangle() {
    let corners = [
        Vec3::new(0.3, -0.2, 1.0),
        Vec3::new(2.0, 0.5, 0.0),
        Vec3::new(-0.5, 1.5, 0.5),
    ];
    let triangle = mesh(corners.to_vec(), vec![[0, 1, 2]]);
    let count = 100_000;
    let samples = sample(
        &triangle,
        SurfaceSampling::Uniform { count },
        SampleNormals::Faces,
    );
    let weights: Vec<[f32; 3]> = samples
        .points
        .positions()
        .iter()
        .map(|p| barycentric(*p, corners).0)
        .collect();
    // The midpoints split the triangle into four of equal area: a quarter near each
    // corner (its weight above 1/2) and a quarter in the middle.
    let quarter = count as f64 / 4.0;
    let deviation = (count as f64 * 0.25 * 0.75).sqrt();
    for corner in 0..3 {
        let near = weights.iter().filter(|w| w[corner] > 0.5).count() as f64;
        assert!(
            (near - quarter).abs() < 4.0 * deviation,
            "corner {corner}: {near}"
        );
    }
    let middle = weights
        .iter()
        .filter(|w| w.iter().all(|x| *x <= 0.5))
        .count() as f64;
    assert!(
        (middle - quarter).abs() < 4.0 * deviation,
        "middle: {middle}"
    );
    // The mean is the centroid, each weight's mean 1/3 (standard deviation 1/√18 per
    // sample).
    let tolerance = 4.0 / (18.0 * count as f64).sqrt();
    for corner in 0..3 {
        let mean = weights.iter().map(|w| f64::from(w[corner])).sum::<f64>() / count as f64;
        assert!(
            (mean - 1.0 / 3.0).abs() < tolerance,
            "corner {corner}: mean weight {mean}"
        );
    }
}

#[test]
fn poisson_disk_samples_keep_their_spacing_and_cover_the_surface() {
    let sheet = wavy_sheet(16);
    let spacing = 0.03;
    let samples = sample(
        &sheet,
        SurfaceSampling::PoissonDisk { spacing },
        SampleNormals::Faces,
    );
    let points = samples.points.positions();
    // Every pair, by brute force.
    let closest = points
        .iter()
        .enumerate()
        .flat_map(|(i, p)| points[i + 1..].iter().map(move |q| p.distance(*q)))
        .fold(f32::INFINITY, f32::min);
    assert!(closest >= spacing, "two samples {closest} apart");
    // Almost no point of the surface is farther than the spacing from a sample.
    let probes = sample_surface(
        &sheet,
        &SurfaceSampling::Uniform { count: 20_000 },
        SampleNormals::Faces,
        &mut RunContext::new(99),
    )
    .unwrap();
    let index = crate::KdIndex::new(points).unwrap();
    let mut gaps = Vec::new();
    for probe in probes.points.positions() {
        gaps.push(
            index
                .nearest_one(*probe)
                .unwrap()
                .unwrap()
                .distance_squared
                .sqrt(),
        );
    }
    let uncovered = gaps.iter().filter(|g| **g > spacing).count() as f64 / gaps.len() as f64;
    let widest = gaps.iter().copied().fold(0.0, f32::max);
    assert!(uncovered < 0.005, "{uncovered} of the surface uncovered");
    assert!(widest < 1.3 * spacing, "a gap of {widest}");
    // About 0.65 samples per spacing² of surface.
    let per_area = points.len() as f64 * f64::from(spacing * spacing) / sheet.area();
    assert!(
        (0.6..0.8).contains(&per_area),
        "{per_area} samples per spacing²"
    );
}

#[test]
fn a_spacing_chosen_for_a_count_gives_about_that_many_samples() {
    let sheet = wavy_sheet(16);
    for count in [300, 3000] {
        let sampling = SurfaceSampling::poisson_disk_for_count(sheet.area(), count).unwrap();
        let found = sample(&sheet, sampling, SampleNormals::Faces).points.len() as f64;
        assert!(
            (found / count as f64 - 1.0).abs() < 0.05,
            "{found} samples for {count}"
        );
    }
    assert!(SurfaceSampling::poisson_disk_for_count(1.0, 0).is_err());
    assert!(SurfaceSampling::poisson_disk_for_count(0.0, 10).is_err());
    assert!(SurfaceSampling::poisson_disk_for_count(f64::NAN, 10).is_err());
    // The most samples: a spacing whose candidates the sampling accepts (on any area);
    // one more is refused by its count (a count of 2^64 − 1 was refused by the spacing
    // it gave, naming a spacing nobody asked for).
    for area in [1e-6, 13.75, 1e9] {
        let Ok(SurfaceSampling::PoissonDisk { spacing }) =
            SurfaceSampling::poisson_disk_for_count(area, MAX_POISSON_SAMPLES)
        else {
            panic!("the most samples refused on area {area}");
        };
        let spacing = f64::from(spacing);
        let candidates = (POISSON_CANDIDATES_PER_AREA * area / (spacing * spacing)).ceil();
        assert!(candidates <= MAX_POISSON_CANDIDATES as f64, "{candidates}");
    }
    for count in [MAX_POISSON_SAMPLES + 1, usize::MAX] {
        let Err(Error::InvalidParameter { name, .. }) =
            SurfaceSampling::poisson_disk_for_count(13.75, count)
        else {
            panic!("{count} samples accepted");
        };
        assert_eq!(name, "count");
    }
}

#[test]
fn a_spacing_wider_than_the_surface_gives_one_sample_on_it() {
    // Expected candidates about 32 · area / spacing² ≪ 1: none is drawn, and the disk is
    // one sample, uniform by area (it was an empty point set).
    let sheet = wavy_sheet(4);
    for spacing in [1e3, 1e30] {
        let samples = sample(
            &sheet,
            SurfaceSampling::PoissonDisk { spacing },
            SampleNormals::Faces,
        );
        assert_eq!(samples.points.len(), 1, "spacing {spacing}");
        for (p, n, face) in each_sample(&samples) {
            let [a, b, c] = sheet.triangles()[face as usize].map(|v| sheet.positions()[v as usize]);
            let (weights, off) = barycentric(p, [a, b, c]);
            assert!(off.abs() < 1e-5, "{p} lies {off} off its triangle's plane");
            assert!(
                weights.iter().all(|w| (-1e-4..=1.0 + 1e-4).contains(w)),
                "{weights:?}"
            );
            assert!(n.is_finite());
        }
    }
}

#[test]
fn interpolated_normals_on_an_octahedron_with_radial_vertex_normals_point_along_the_position() {
    // On the face with corners X, Y, Z, a sample's weights are its coordinates, so the
    // radial normals X, Y, Z interpolate to its position, normalized.
    let corners = vec![Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
    let triangles = vec![
        [0, 1, 2],
        [1, 3, 2],
        [3, 4, 2],
        [4, 0, 2],
        [1, 0, 5],
        [3, 1, 5],
        [4, 3, 5],
        [0, 4, 5],
    ];
    let octahedron = TriMesh::new(
        PointSet::new(corners.clone())
            .unwrap()
            .with_normals(corners)
            .unwrap(),
        triangles,
    )
    .unwrap();
    let samples = sample(
        &octahedron,
        SurfaceSampling::Uniform { count: 2000 },
        SampleNormals::Interpolated,
    );
    let faces = octahedron.face_normals();
    let mut turned = 0.0;
    for (p, n, face) in each_sample(&samples) {
        assert!((n - p.normalize()).length() < 1e-5, "{p}: {n}");
        turned += n.angle_between(faces[face as usize]);
    }
    // And they differ from the faces' normals (by 0.2 rad on average, measured).
    assert!(turned / 2000.0 > 0.1);
}

#[test]
fn interpolated_normals_come_from_the_faces_when_the_mesh_has_none() {
    // A tent of two slopes: the ridge's computed vertex normals lean between them.
    let corners = vec![
        Vec3::ZERO,
        Vec3::Y,
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(2.0, 1.0, 0.0),
    ];
    let tent = mesh(corners, vec![[0, 2, 1], [1, 2, 3], [2, 4, 3], [3, 4, 5]]);
    let samples = sample(
        &tent,
        SurfaceSampling::Uniform { count: 500 },
        SampleNormals::Interpolated,
    );
    let normals = samples.points.normals().unwrap();
    for (p, n) in samples.points.positions().iter().zip(normals) {
        // The slopes' normals lean 45° from +Z, the ridge's (−1, 0, 3)/√10 and
        // (1, 0, 3)/√10; a normalized blend of them leans no more than the slopes'.
        assert!((n.length() - 1.0).abs() < 1e-5);
        assert!(n.z >= std::f32::consts::FRAC_1_SQRT_2 - 1e-5, "{p}: {n}");
        if (p.x - 1.0).abs() < 0.01 {
            assert!(n.z > 0.94, "{p}: {n}");
        }
    }
}

#[test]
fn vertex_attributes_are_interpolated_and_quantized_to_their_storage() {
    let corners = vec![
        Vec3::ZERO,
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let linear = |p: Vec3| 3.0 * p.x - 2.0 * p.y + 1.0;
    let mut vertices = PointSet::new(corners.clone()).unwrap();
    vertices
        .set_colors(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
        .unwrap();
    vertices
        .set_attribute(Attribute::new(
            "height",
            corners.iter().map(|p| linear(*p)).collect(),
        ))
        .unwrap();
    let uvs = vec![
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(0.0, 0.5),
    ];
    let triangle = TriMesh::new(vertices, vec![[0, 1, 2]])
        .unwrap()
        .with_uvs(uvs)
        .unwrap();
    let samples = sample(
        &triangle,
        SurfaceSampling::Uniform { count: 1000 },
        SampleNormals::Faces,
    );
    let height = samples.points.attribute("height").unwrap();
    let [s, t] = UV_CHANNELS.map(|n| samples.points.attribute(n).unwrap().values());
    assert_eq!(height.storage(), ScalarType::F32);
    let channels: Vec<&Attribute> = crate::COLOR_CHANNELS
        .iter()
        .map(|c| samples.points.attribute(c).unwrap())
        .collect();
    for (i, p) in samples.points.positions().iter().enumerate() {
        // A linear function is reproduced by barycentric interpolation: the height, and
        // the texture coordinates (u = x/2, v = y/2 here).
        assert!((height.values()[i] - linear(*p)).abs() < 1e-5);
        assert!((s[i] - p.x / 2.0).abs() < 1e-6 && (t[i] - p.y / 2.0).abs() < 1e-6);
        // The colour channels are the weights times 255, rounded.
        let (weights, _) = barycentric(*p, [corners[0], corners[1], corners[2]]);
        for (channel, weight) in channels.iter().zip(weights) {
            assert_eq!(channel.storage(), ScalarType::U8);
            let value = channel.values()[i];
            assert_eq!(value, value.round());
            assert!(
                (value - 255.0 * weight).abs() <= 0.5 + 1e-3,
                "{value} for weight {weight}"
            );
        }
    }
}

#[test]
fn the_samples_depend_on_the_seed_only() {
    let sheet = wavy_sheet(6);
    let run = |seed| {
        sample_surface(
            &sheet,
            &SurfaceSampling::PoissonDisk { spacing: 0.05 },
            SampleNormals::Faces,
            &mut RunContext::new(seed),
        )
        .unwrap()
    };
    assert_eq!(run(5), run(5));
    assert_ne!(run(5).points.positions(), run(6).points.positions());
}

#[test]
fn poisson_disk_samples_do_not_depend_on_the_threads() {
    // Tiles of 0.16: about 7 × 7 over the sheet, several in each phase.
    let sheet = wavy_sheet(8);
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            sample(
                &sheet,
                SurfaceSampling::PoissonDisk { spacing: 0.01 },
                SampleNormals::Faces,
            )
        })
    };
    let one = run(1);
    assert!(one.points.len() > 5000);
    // No two closer than the spacing, across the tiles' sides too (a k-d tree's answer).
    let points = one.points.positions();
    let index = crate::KdIndex::new(points).unwrap();
    for p in points {
        assert!(index.nearest(*p, 2).unwrap()[1].distance_squared.sqrt() >= 0.01);
    }
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
}

#[test]
fn bad_meshes_and_parameters_are_errors() {
    let run = |mesh: &TriMesh, sampling: SurfaceSampling| {
        sample_surface(
            mesh,
            &sampling,
            SampleNormals::Faces,
            &mut RunContext::new(0),
        )
    };
    let uniform = SurfaceSampling::Uniform { count: 10 };
    let no_faces = mesh(vec![Vec3::ZERO], Vec::new());
    assert!(matches!(
        run(&no_faces, uniform),
        Err(Error::EmptyInput { .. })
    ));
    let flat = mesh(
        vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
        vec![[0, 1, 2], [0, 0, 1]],
    );
    let Err(Error::EmptyInput { what }) = run(&flat, uniform) else {
        panic!("a mesh of zero area was sampled");
    };
    assert!(
        what.contains("all 2 of its triangles have zero area"),
        "{what}"
    );
    let sheet = wavy_sheet(2);
    for sampling in [
        SurfaceSampling::Uniform { count: 0 },
        SurfaceSampling::Uniform {
            count: MAX_SURFACE_SAMPLES + 1,
        },
        SurfaceSampling::PoissonDisk { spacing: 0.0 },
        SurfaceSampling::PoissonDisk { spacing: -1.0 },
        SurfaceSampling::PoissonDisk { spacing: f32::NAN },
        SurfaceSampling::PoissonDisk {
            spacing: f32::INFINITY,
        },
        SurfaceSampling::PoissonDisk { spacing: 1e-5 },
    ] {
        assert!(
            matches!(run(&sheet, sampling), Err(Error::InvalidParameter { .. })),
            "{sampling:?}"
        );
    }
    let cancel = CancelFlag::new();
    cancel.cancel();
    let mut ctx = RunContext::new(0).with_cancel_flag(cancel);
    let cancelled = sample_surface(&sheet, &uniform, SampleNormals::Faces, &mut ctx);
    assert!(matches!(cancelled, Err(Error::Cancelled)));
}
