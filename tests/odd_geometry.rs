//! Odd point sets and meshes (each signed either way) and parameters through the distance-field
//! stages: each either refuses them with a typed error or returns a field and a mesh that
//! keep their contracts (finite, clamped to the band, inside the grid's box). Never a
//! panic. The same point sets are also drawn as previews.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use geosynth::core::io::Geometry;
use geosynth::core::rng::rng_from_seed;
use geosynth::core::{PointSet, TriMesh};
use geosynth::preview::{self, RenderOptions};
use geosynth::reconstruct::{FieldParams, Reconstruct, signed_distance};
use geosynth::sdf::{MeshSign, PointSign};
use geosynth::{RunContext, Stage};
use glam::Vec3;
use proptest::prelude::*;
use rand::RngExt;

/// How the samples are laid out in a cube of side `scale` around `offset`.
#[derive(Debug, Clone, Copy)]
enum Layout {
    /// On a sphere, at random.
    Sphere,
    /// Uniformly at random in the cube.
    Uniform,
    /// Every sample at one point.
    Coincident,
    /// On one line.
    Line,
    /// A regular grid on one plane.
    Plane,
    /// Two tight clusters at opposite corners.
    Clusters,
}

/// Which normals the samples get.
#[derive(Debug, Clone, Copy)]
enum Normals {
    /// Away from the layout's centre (up where a sample sits at the centre).
    Outward,
    /// All the same.
    Up,
    /// Outward with random signs.
    Unoriented,
}

#[derive(Debug, Clone, Copy)]
struct Cloud {
    layout: Layout,
    normals: Normals,
    samples: usize,
    scale: f32,
    offset: f32,
    seed: u64,
}

fn cloud() -> impl Strategy<Value = Cloud> {
    let layout = prop_oneof![
        4 => Just(Layout::Sphere),
        2 => Just(Layout::Uniform),
        1 => Just(Layout::Coincident),
        1 => Just(Layout::Line),
        1 => Just(Layout::Plane),
        1 => Just(Layout::Clusters),
    ];
    let normals = prop_oneof![
        3 => Just(Normals::Outward),
        1 => Just(Normals::Up),
        1 => Just(Normals::Unoriented),
    ];
    (
        layout,
        normals,
        1usize..400,
        -4.0f32..4.0,
        prop_oneof![Just(0.0f32), -1.0f32..6.0],
        any::<u64>(),
    )
        .prop_map(|(layout, normals, samples, scale, offset, seed)| Cloud {
            layout,
            normals,
            samples,
            scale: 10f32.powf(scale),
            offset: if offset == 0.0 {
                0.0
            } else {
                10f32.powf(offset)
            },
            seed,
        })
}

fn points(c: &Cloud) -> PointSet {
    let mut g = rng_from_seed(c.seed);
    let mut unit = || {
        Vec3::new(
            g.random_range(-1.0f32..1.0),
            g.random_range(-1.0f32..1.0),
            g.random_range(-1.0f32..1.0),
        )
    };
    let side = (c.samples as f32).sqrt().ceil() as usize;
    let local: Vec<Vec3> = (0..c.samples)
        .map(|i| match c.layout {
            Layout::Sphere => unit().normalize_or(Vec3::Z),
            Layout::Uniform => unit(),
            Layout::Coincident => Vec3::splat(0.25),
            Layout::Line => Vec3::new(unit().x, 0.0, 0.0),
            Layout::Plane => Vec3::new(
                (i % side) as f32 / side as f32,
                (i / side) as f32 / side as f32,
                0.0,
            ),
            Layout::Clusters => {
                let corner = if i % 2 == 0 { Vec3::ONE } else { -Vec3::ONE };
                corner + 1e-3 * unit()
            }
        })
        .collect();
    let normals: Vec<Vec3> = local
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let outward = p.normalize_or(Vec3::Z);
            match c.normals {
                Normals::Outward => outward,
                Normals::Up => Vec3::Z,
                Normals::Unoriented if i % 3 == 0 => -outward,
                Normals::Unoriented => outward,
            }
        })
        .collect();
    let positions = local
        .iter()
        .map(|p| *p * c.scale + Vec3::splat(c.offset))
        .collect();
    PointSet::new(positions)
        .unwrap()
        .with_normals(normals)
        .unwrap()
}

fn params() -> impl Strategy<Value = (FieldParams, Option<f32>)> {
    (
        4usize..40,
        prop_oneof![Just(None), (-3.0f32..1.0).prop_map(Some)],
        0.0f32..4.0,
        0.5f32..8.0,
    )
        .prop_map(|(resolution, kernel, margin, band)| {
            let mut p = FieldParams::default().resolution(resolution);
            p.margin = margin;
            p.band = band;
            // The kernel is relative to the cloud's scale: set once the cloud is known.
            (p, kernel.map(|k| 10f32.powf(k)))
        })
}

/// The field's contracts: finite distances within the band, and a mesh made of it (when
/// there is one) with finite vertices inside the grid's box.
fn check_field_and_mesh(geometry: &Geometry, params: &FieldParams) {
    let field = match signed_distance(geometry, params) {
        Ok(field) => field,
        Err(e) => {
            assert!(!e.to_string().is_empty());
            return;
        }
    };
    let band = field.band();
    let distances = field.distances().unwrap();
    for &d in distances.data() {
        assert!(
            d.is_finite() && d.abs() <= band * (1.0 + 1e-5),
            "distance {d}, band {band}"
        );
    }
    let Geometry::Points(points) = geometry else {
        return;
    };
    let stage = Reconstruct {
        params: params.clone(),
    };
    let grid = field.grid();
    let extent = grid.dims().map(|n| (n - 1) as f32);
    let (lo, hi) = (
        grid.origin(),
        grid.origin() + Vec3::from(extent) * grid.spacing(),
    );
    let slack = Vec3::splat(1e-3 * grid.spacing() + 1e-6 * lo.abs().max(hi.abs()).max_element());
    match stage.run(points.clone(), &mut RunContext::new(0)) {
        Ok(mesh) => check_mesh(&mesh, lo - slack, hi + slack),
        Err(e) => assert!(!e.to_string().is_empty()),
    }
}

fn check_mesh(mesh: &TriMesh, lo: Vec3, hi: Vec3) {
    assert!(mesh.face_count() > 0);
    for p in mesh.positions() {
        assert!(
            p.is_finite() && p.cmpge(lo).all() && p.cmple(hi).all(),
            "{p} outside {lo}..{hi}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(100))]

    #[test]
    fn odd_point_sets_give_a_field_and_mesh_or_an_error(
        c in cloud(),
        (p, kernel) in params(),
        winding in any::<bool>(),
    ) {
        let points = points(&c);
        let sign = if winding { PointSign::WindingNumber } else { PointSign::Implicit };
        let p = p.kernel(kernel.map(|k| k * c.scale)).point_sign(sign);
        check_field_and_mesh(&Geometry::Points(points), &p);
    }

    #[test]
    fn odd_meshes_give_a_field_or_an_error(
        c in cloud(),
        (p, _) in params(),
        faces in proptest::collection::vec((0usize..400, 0usize..400, 0usize..400), 1..60),
        winding in any::<bool>(),
    ) {
        // Triangles over the cloud's samples: degenerate, repeated and crossing ones too.
        let points = points(&c);
        let n = points.len();
        let faces: Vec<[u32; 3]> = faces
            .iter()
            .map(|&(a, b, c)| [a % n, b % n, c % n].map(|i| i as u32))
            .collect();
        match TriMesh::new(PointSet::new(points.positions().to_vec()).unwrap(), faces) {
            Ok(mesh) => {
                let sign = if winding { MeshSign::WindingNumber } else { MeshSign::PseudoNormal };
                check_field_and_mesh(&Geometry::Mesh(mesh), &p.mesh_sign(sign));
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
    }

    #[test]
    fn odd_point_sets_render_or_are_refused(
        c in cloud(),
        with_normals in any::<bool>(),
        (width, height) in (1u32..48, 1u32..48),
        (azimuth, elevation) in (-360.0f32..360.0, -90.0f32..90.0),
        splat_scale in -1.0f32..1.0,
        pixels_per_unit in proptest::option::of(-3.0f32..7.0),
    ) {
        // Surface splats (with normals) and small spheres (without), fitted or at a fixed
        // scale from far too small to far too large: a picture of the size asked for, or
        // a typed error.
        let oriented = points(&c);
        let points = if with_normals {
            oriented
        } else {
            PointSet::new(oriented.positions().to_vec()).unwrap()
        };
        let mut options = RenderOptions::default()
            .size(width, height)
            .view(azimuth, elevation);
        options.splat_scale = 10f32.powf(splat_scale);
        if let Some(exponent) = pixels_per_unit {
            options = options.pixels_per_unit(10f32.powf(exponent) / c.scale);
        }
        match preview::render(&Geometry::Points(points), &options) {
            Ok(image) => prop_assert_eq!(image.dimensions(), (width, height)),
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
    }
}

/// `geometry` with every position multiplied by `scale` (normals and faces kept).
fn scaled(geometry: &Geometry, scale: f32) -> Geometry {
    let points = geometry.points();
    let positions = points.positions().iter().map(|&p| p * scale).collect();
    let mut moved = PointSet::new(positions).unwrap();
    moved
        .set_normals(points.normals().map(<[Vec3]>::to_vec))
        .unwrap();
    match geometry {
        Geometry::Points(_) => Geometry::Points(moved),
        Geometry::Mesh(mesh) => {
            Geometry::Mesh(TriMesh::new(moved, mesh.triangles().to_vec()).unwrap())
        }
    }
}

/// How many nodes of `geometry`'s field (24 nodes along the longest side) lie inside.
fn inside_nodes(geometry: &Geometry, params: &FieldParams) -> usize {
    let field = signed_distance(geometry, params).unwrap();
    let values: Vec<f32> = field.grid().data().iter().map(|v| v.x).collect();
    assert!(values.iter().all(|v| v.is_finite()));
    values.iter().filter(|&&v| v < 0.0).count()
}

#[test]
fn fields_do_not_depend_on_the_unit_of_length_up_to_the_widest_span() {
    // A unit sphere's samples and a torus mesh, in units from 1e-15 to 1e17 of the
    // original: the same nodes inside by either sign rule (measured: equal counts, but
    // for 2 of 3135 with the sphere's winding numbers). Before the mesh was stored
    // rescaled, its closest-point arithmetic (products of four lengths) overflowed for
    // triangles longer than about 4e9 units, and the torus at 1e12 came out with no node
    // inside. At 1e20 squared distances overflow f32 itself, and every entry point says
    // so instead of computing NaNs (before: a NaN box, "no surface", "no non-degenerate
    // triangles", or a field written without complaint).
    let sphere = Geometry::Points(geosynth::fixtures::sphere_points(1500).unwrap());
    let torus = Geometry::Mesh(geosynth::fixtures::torus_mesh(24, 12, 1.0, 0.3).unwrap());
    let params = FieldParams::default().resolution(24);
    let winding = params
        .clone()
        .point_sign(PointSign::WindingNumber)
        .mesh_sign(MeshSign::WindingNumber);
    for geometry in [&sphere, &torus] {
        for rule in [&params, &winding] {
            let inside = inside_nodes(geometry, rule);
            assert!(inside > 300, "{inside} nodes inside");
            for scale in [1e-15f32, 1e-5, 1e12, 1e17] {
                // Rounding of the grid's nodes may move a node or two across.
                let at_scale = inside_nodes(&scaled(geometry, scale), rule);
                assert!(
                    at_scale.abs_diff(inside) <= inside / 200,
                    "scale {scale}: {at_scale} nodes inside against {inside}"
                );
            }
        }
        let err = signed_distance(&scaled(geometry, 1e20), &params).unwrap_err();
        assert!(
            err.to_string().contains("rescale the file's units"),
            "{err}"
        );
    }
    let texture = geosynth::fixtures::sphere_points(1500).unwrap();
    let huge = scaled(&Geometry::Points(texture), 1e20).points().clone();
    let bounds = geosynth::core::Aabb::from_points(huge.positions()).unwrap();
    let err = geosynth::quilt::GeometryTexture::new(&huge, bounds, geosynth::quilt::UpAxis::Z)
        .unwrap_err();
    assert!(
        matches!(
            err,
            geosynth::quilt::QuiltError::Core(geosynth::core::Error::SpanTooLarge { .. })
        ),
        "{err}"
    );
}
