//! Tests of distance-field against independent references: brute-force point–triangle
//! distances, winding numbers, analytic spheres and tori, paper 001 Eq. 2, file round trips.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::collections::HashMap;

use distance_field::{
    BlockPyramid, CROSSING_MISS, FieldError, GridSpec, MeshSign, MeshSurface, SdfGrid, isosurface,
    nrrd, sdf_isosurface, sdf_isosurface_of,
};
use glam::{Vec3, Vec4};
use mls_surface::{MlsParams, MlsSurface};
use pointset_core::testdata::{random_direction, shared_data};
use pointset_core::{Aabb, BandAnswer, Grid3, PointSet, Surface, SurfacePoint, TriMesh, io, rng};
use proptest::prelude::*;
use rand::RngExt;

// ------------------------------------------------------------ independent references

/// Distance from `p` to segment `ab`.
fn segment_distance(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let d = b - a;
    let t = if d.length_squared() > 0.0 {
        ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + t * d)
}

/// Point–triangle distance by plane projection + barycentric test, else the nearest edge.
fn brute_triangle_distance(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let n = (b - a).cross(c - a);
    if n.length_squared() > 1e-20 {
        let n = n.normalize();
        let q = p - n * n.dot(p - a);
        let inside = [(a, b), (b, c), (c, a)]
            .iter()
            .all(|&(s, e)| (e - s).cross(q - s).dot(n) >= 0.0);
        if inside {
            return p.distance(q);
        }
    }
    segment_distance(p, a, b)
        .min(segment_distance(p, b, c))
        .min(segment_distance(p, c, a))
}

/// Generalized winding number of a closed mesh around `p` (van Oosterom–Strackee).
fn winding_number(mesh: &TriMesh, p: Vec3) -> f64 {
    let pos = mesh.positions();
    let mut total = 0.0f64;
    for t in mesh.triangles() {
        let [a, b, c] = t.map(|v| (pos[v as usize] - p).as_dvec3());
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c));
        let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
        total += 2.0 * num.atan2(den);
    }
    total / (4.0 * std::f64::consts::PI)
}

fn random_mesh(seed: u64, n: usize) -> TriMesh {
    let mut g = rng::rng_from_seed(seed);
    let p: Vec<Vec3> = (0..3 * n)
        .map(|_| Vec3::new(g.random(), g.random(), g.random()))
        .collect();
    let tris = (0..n as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    TriMesh::new(PointSet::new(p).unwrap(), tris).unwrap()
}

proptest! {
    #[test]
    fn mesh_distance_matches_brute_force(
        seed in any::<u64>(),
        n in 1usize..80,
        q in prop::array::uniform3(-1.0f32..2.0),
    ) {
        let mesh = random_mesh(seed, n);
        let surface = MeshSurface::new(&mesh).unwrap();
        let q = Vec3::from(q);
        let pos = mesh.positions();
        let expected = mesh
            .triangles()
            .iter()
            .map(|t| brute_triangle_distance(q, pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]))
            .fold(f32::INFINITY, f32::min);
        let hit = surface.closest(q, f32::INFINITY).unwrap();
        prop_assert!((hit.distance_squared.sqrt() - expected).abs() <= 1e-4 * expected.max(1.0));
        // A correct bound changes nothing.
        let bounded = surface.closest(q, expected * 1.01 + 1e-6).unwrap();
        prop_assert!((bounded.distance_squared - hit.distance_squared).abs() <= 1e-6);
    }
}

/// The mesh at `relative` in the shared data (`None`, after a skip notice, without it).
fn shared_mesh(test: &str, relative: &str) -> Option<TriMesh> {
    let path = shared_data(test, relative)?;
    Some(
        io::read_geometry(&path)
            .unwrap()
            .geometry
            .mesh()
            .unwrap()
            .clone(),
    )
}

/// `bunny_watertight.obj` from the shared data (`None`, after a skip notice, without it).
fn watertight_bunny(test: &str) -> Option<TriMesh> {
    shared_mesh(test, "meshes/bunny_watertight.obj")
}

#[test]
fn bunny_sign_agrees_with_winding_numbers() {
    let Some(mesh) = watertight_bunny("bunny_sign") else {
        return;
    };
    let surface = MeshSurface::new(&mesh).unwrap();
    let bounds = mesh.bounding_box().unwrap();
    let mut g = rng::rng_from_seed(11);
    let (mut inside, mut outside) = (0, 0);
    for _ in 0..150 {
        let t = Vec3::new(g.random(), g.random(), g.random());
        let q = bounds.min + t * bounds.extent();
        let w = winding_number(&mesh, q);
        let d = surface.signed_distance_to(q).unwrap();
        // Skip the rare query so close to the surface that either answer is legitimate.
        if d.abs() < 1e-5 * bounds.diagonal() {
            continue;
        }
        assert_eq!(d < 0.0, w > 0.5, "q = {q}, distance {d}, winding {w}");
        if d < 0.0 { inside += 1 } else { outside += 1 }
    }
    assert!(
        inside > 10 && outside > 10,
        "{inside} inside, {outside} outside"
    );
    // Just off the surface along the normals: the sign follows the side.
    let eps = 1e-4 * bounds.diagonal();
    let normals = mesh.vertex_normals(pointset_core::NormalWeighting::Angle);
    for (v, n) in mesh.positions().iter().zip(&normals).step_by(97) {
        assert!(surface.signed_distance_to(*v + *n * eps).unwrap() > 0.0);
        assert!(surface.signed_distance_to(*v - *n * eps).unwrap() < 0.0);
    }
}

// ------------------------------------------------------------ grids of spheres

struct AnalyticSphere(f32);
impl Surface for AnalyticSphere {
    fn closest_point(&self, q: Vec3) -> Option<SurfacePoint> {
        let n = q.try_normalize()?;
        Some(SurfacePoint {
            point: n * self.0,
            normal: n,
        })
    }
}

fn fibonacci_sphere(n: usize, r: f32) -> PointSet {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let dirs: Vec<Vec3> = (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let s = (1.0 - y * y).sqrt();
            Vec3::new(
                s * (golden * i as f32).cos(),
                y,
                s * (golden * i as f32).sin(),
            )
        })
        .collect();
    PointSet::new(dirs.iter().map(|d| *d * r).collect())
        .unwrap()
        .with_normals(dirs)
        .unwrap()
}

#[test]
fn sdf_of_an_analytic_sphere_is_exact_and_clamped() {
    let spec =
        GridSpec::covering(Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0)), 33, 0.25).unwrap();
    let sdf = SdfGrid::from_surface(&AnalyticSphere(1.0), &spec, 0.3).unwrap();
    // The centre has no closest point, but its region (the inside beyond the band) has a sign.
    assert_eq!(sdf.undefined_nodes(), 0);
    let [nx, ny, nz] = sdf.dims();
    let mut far = 0;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = spec.node(i, j, k);
                let exact = p.length() - 1.0;
                let d = sdf.distance(i, j, k).unwrap();
                assert!(
                    (d - exact.clamp(-0.3, 0.3)).abs() < 1e-5,
                    "at {p}: {d} vs {exact}"
                );
                let g = sdf.gradient(i, j, k).unwrap();
                if exact.abs() <= 0.3 - 1e-4 {
                    assert!((g - p.normalize()).length() < 1e-4);
                } else if exact.abs() > 0.3 + 1e-4 {
                    assert_eq!(
                        g,
                        Vec3::ZERO,
                        "clamped nodes carry the clamped field's gradient"
                    );
                    far += 1;
                }
            }
        }
    }
    assert!(far > 0 && far <= sdf.far_nodes());
    // A band no wider than the spacing cannot propagate signs safely.
    assert!(SdfGrid::from_surface(&AnalyticSphere(1.0), &spec, spec.spacing).is_err());
}

#[test]
fn sdf_from_a_point_set_surface_matches_the_sphere_near_the_surface() {
    let points = fibonacci_sphere(20_000, 1.0);
    let mls = MlsSurface::new(&points, &MlsParams::default()).unwrap();
    let spec = GridSpec::covering(Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0)), 24, 0.2).unwrap();
    let sdf = SdfGrid::from_surface(&mls, &spec, 0.5).unwrap();
    assert_eq!(sdf.undefined_nodes(), 0);
    let [nx, ny, nz] = sdf.dims();
    let mut checked = 0;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = spec.node(i, j, k);
                let exact = p.length() - 1.0;
                if exact.abs() > 0.1 {
                    continue;
                }
                checked += 1;
                assert!(
                    (sdf.distance(i, j, k).unwrap() - exact).abs() < 3e-3,
                    "at {p}"
                );
                let g = sdf.gradient(i, j, k).unwrap();
                assert!((g.length() - 1.0).abs() < 1e-3);
                assert!(g.dot(p.normalize()) > 0.999);
            }
        }
    }
    assert!(checked > 500);
}

#[test]
fn sampling_reports_its_layers_and_stops_when_cancelled() {
    use std::sync::{Arc, Mutex};

    use distance_field::{FarSigns, SAMPLING_STAGE};
    use pointset_core::{ProgressUpdate, RunContext};

    let spec =
        GridSpec::covering(Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0)), 30, 0.25).unwrap();
    let nz = spec.dims[2] as u64;
    let sampled = |ctx: &mut RunContext| {
        SdfGrid::from_surface_in(&AnalyticSphere(1.0), &spec, 0.3, FarSigns::default(), ctx)
    };
    // The reports climb from 0 to every layer; the grid is the one sampled without a run.
    let reports = Arc::new(Mutex::new(Vec::new()));
    let sink = Arc::clone(&reports);
    let mut ctx = RunContext::new(0).with_progress(move |u: &ProgressUpdate<'_>| {
        assert_eq!((u.stage, u.total), (SAMPLING_STAGE, Some(nz)));
        sink.lock().unwrap().push(u.done);
    });
    let sdf = sampled(&mut ctx).unwrap();
    assert_eq!(
        sdf,
        SdfGrid::from_surface(&AnalyticSphere(1.0), &spec, 0.3).unwrap()
    );
    let done = reports.lock().unwrap().clone();
    assert_eq!((done.first(), done.last()), (Some(&0), Some(&nz)));
    assert!(done.windows(2).all(|w| w[0] < w[1]), "{done:?}");
    assert!(done.len() > 3, "{done:?}");

    // Cancelled after the first layers are reported, it samples no more of them.
    let flag = pointset_core::CancelFlag::new();
    let cancel = flag.clone();
    let reports = Arc::new(Mutex::new(Vec::new()));
    let sink = Arc::clone(&reports);
    let mut ctx =
        RunContext::new(0)
            .with_cancel_flag(flag)
            .with_progress(move |u: &ProgressUpdate<'_>| {
                sink.lock().unwrap().push(u.done);
                if u.done > 0 {
                    cancel.cancel();
                }
            });
    let stopped = sampled(&mut ctx);
    assert!(
        matches!(
            stopped,
            Err(FieldError::Core(pointset_core::Error::Cancelled))
        ),
        "{stopped:?}"
    );
    assert_eq!(
        reports.lock().unwrap().len(),
        2,
        "one group of layers, then the stop"
    );
}

#[test]
fn grid_filling_does_not_depend_on_thread_count() {
    let mesh = random_mesh(5, 60);
    let surface = MeshSurface::new(&mesh).unwrap();
    let spec = GridSpec::covering(mesh.bounding_box().unwrap(), 20, 0.1).unwrap();
    let run = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| SdfGrid::from_surface(&surface, &spec, 1.0).unwrap())
    };
    assert_eq!(run(1), run(2));
}

/// A surface that counts the queries it answers, asked the trait's default way (the likely
/// bound first, then the band, no clearance).
struct Counted<'s> {
    surface: &'s dyn Surface,
    queries: std::sync::atomic::AtomicUsize,
}

impl Counted<'_> {
    fn count(&self) {
        self.queries
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }
}

impl Surface for Counted<'_> {
    fn closest_point(&self, query: Vec3) -> Option<SurfacePoint> {
        self.surface.closest_point(query)
    }

    fn signed_distance_within(&self, query: Vec3, max: f32) -> Option<(f32, SurfacePoint)> {
        self.count();
        self.surface.signed_distance_within(query, max)
    }
}

/// [`Counted`], asked the surface's own way (with its clearances).
struct Clearing<'s>(Counted<'s>);

impl Surface for Clearing<'_> {
    fn closest_point(&self, query: Vec3) -> Option<SurfacePoint> {
        self.0.closest_point(query)
    }

    fn signed_distance_or_clearance(
        &self,
        query: Vec3,
        max: f32,
        likely: Option<f32>,
    ) -> BandAnswer {
        self.0.count();
        self.0
            .surface
            .signed_distance_or_clearance(query, max, likely)
    }
}

#[test]
fn clearances_skip_queries_without_changing_the_grid() {
    // 300 random points on a unit sphere in a box three times its size: most nodes lie far
    // beyond the band, where the MLS surface answers with a clearance.
    let mut g = rng::rng_from_seed(4);
    let dirs: Vec<Vec3> = (0..300).map(|_| random_direction(&mut g)).collect();
    let points = PointSet::new(dirs.clone())
        .unwrap()
        .with_normals(dirs)
        .unwrap();
    let mls = MlsSurface::new(&points, &MlsParams::default()).unwrap();
    let spec = GridSpec::covering(Aabb::new(Vec3::splat(-3.0), Vec3::splat(3.0)), 40, 0.0).unwrap();
    let (asked, asked_without) = queries_with_and_without_clearances(&mls, &spec);
    assert!(asked < asked_without / 2, "{asked} of {asked_without}");
}

/// A surface that forwards the grid's queries, and its preparations when `prepare` is
/// set (counting them); otherwise it is asked node by node.
struct Preparing<'s> {
    surface: &'s dyn Surface,
    prepare: bool,
    prepared: std::sync::atomic::AtomicUsize,
}

impl Surface for Preparing<'_> {
    fn closest_point(&self, query: Vec3) -> Option<SurfacePoint> {
        self.surface.closest_point(query)
    }

    fn signed_distance_or_clearance(
        &self,
        query: Vec3,
        max: f32,
        likely: Option<f32>,
    ) -> BandAnswer {
        self.surface
            .signed_distance_or_clearance(query, max, likely)
    }

    fn prepared_near(&self, centre: Vec3, reach: f32) -> Option<Box<dyn Surface + '_>> {
        if !self.prepare {
            return None;
        }
        self.prepared
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.surface.prepared_near(centre, reach)
    }

    fn preparation_reach(&self) -> Option<f32> {
        self.surface.preparation_reach().filter(|_| self.prepare)
    }
}

#[test]
fn grids_asked_through_prepared_blocks_are_the_grids_asked_node_by_node() {
    // Two bumpy sheets facing each other, with coincident samples: nodes in reach, out of
    // reach within the band, and beyond it.
    let mut g = rng::rng_from_seed(8);
    let (mut positions, mut normals) = (Vec::new(), Vec::new());
    for (z, up) in [(0.0f32, 1.0f32), (0.6, -1.0)] {
        for _ in 0..2000 {
            let (x, y) = (g.random::<f32>(), g.random::<f32>());
            positions.push(Vec3::new(
                x,
                y,
                z + 0.05 * (8.0 * x).sin() * (6.0 * y).cos(),
            ));
            normals.push(Vec3::new(0.0, 0.1 * g.random::<f32>(), up));
        }
    }
    positions.extend_from_within(0..50);
    normals.extend_from_within(0..50);
    let points = PointSet::new(positions)
        .unwrap()
        .with_normals(normals)
        .unwrap();
    let bounds = Aabb::new(Vec3::new(0.3, 0.3, -0.3), Vec3::new(0.6, 0.55, 0.9));
    for params in [
        MlsParams::default(),
        MlsParams::default().fallback_sign_samples(1),
    ] {
        let mls = MlsSurface::new(&points, &params).unwrap();
        let reach = mls.preparation_reach().unwrap();
        // Cubes of 8 and 4 nodes a side, squares of 3 (a cube would be 2), and none (too
        // coarse to prepare).
        for spacing in [0.1 * reach, 0.35 * reach, 0.7 * reach, 2.0 * reach] {
            let spec = GridSpec {
                dims: ((bounds.max - bounds.min) / spacing)
                    .as_uvec3()
                    .to_array()
                    .map(|n| n as usize + 1),
                origin: bounds.min,
                spacing,
            };
            let band = 4.0 * spacing;
            let preparing = |prepare| Preparing {
                surface: &mls,
                prepare,
                prepared: Default::default(),
            };
            let (blocks, nodes) = (preparing(true), preparing(false));
            let by_blocks = SdfGrid::from_surface(&blocks, &spec, band).unwrap();
            let by_nodes = SdfGrid::from_surface(&nodes, &spec, band).unwrap();
            assert_eq!(by_blocks, by_nodes, "spacing {spacing}");
            assert_eq!(by_blocks, SdfGrid::from_surface(&mls, &spec, band).unwrap());
            // Prepared where a block of 3 nodes a side (2 spacings, its half-diagonal
            // √2 spacings) fits the reach.
            let prepared = blocks.prepared.into_inner();
            let fits = spacing * std::f32::consts::SQRT_2 <= reach;
            assert_eq!(prepared > 0, fits, "spacing {spacing}: {prepared}");
        }
    }
}

#[test]
fn mesh_clearances_skip_queries_without_changing_the_grid() {
    // Two intersecting spheres in a box about three times their size; both sign rules.
    let (mesh, _) = overlapping_spheres();
    let spec = GridSpec::covering(Aabb::new(Vec3::splat(-2.2), Vec3::splat(2.8)), 40, 0.0).unwrap();
    for sign in [MeshSign::PseudoNormal, MeshSign::WindingNumber] {
        let surface = MeshSurface::new(&mesh).unwrap().with_sign(sign);
        let (asked, asked_without) = queries_with_and_without_clearances(&surface, &spec);
        assert!(
            asked < asked_without / 2,
            "{sign:?}: {asked} of {asked_without}"
        );
    }
}

/// Fills `spec` with `surface` twice, band 3 spacings: asked with its clearances and the
/// trait's default way. The grids are equal (and equal to the plain fill); returns the
/// queries each way. Most nodes must be far, and the default asks every node.
fn queries_with_and_without_clearances(surface: &dyn Surface, spec: &GridSpec) -> (usize, usize) {
    let band = 3.0 * spec.spacing;
    let counted = || Counted {
        surface,
        queries: Default::default(),
    };
    let (clearing, plain) = (Clearing(counted()), counted());
    let with = SdfGrid::from_surface(&clearing, spec, band).unwrap();
    let without = SdfGrid::from_surface(&plain, spec, band).unwrap();
    assert_eq!(with, without);
    assert_eq!(with, SdfGrid::from_surface(surface, spec, band).unwrap());
    let nodes = spec.dims.iter().product::<usize>();
    assert!(with.far_nodes() > nodes / 2);
    let asked_without = plain.queries.into_inner();
    assert!(asked_without >= nodes);
    (clearing.0.queries.into_inner(), asked_without)
}

// ------------------------------------------------------------ pyramids (paper 001 Eq. 2)

proptest! {
    #[test]
    fn pyramid_distances_never_decrease_with_level(
        a in proptest::collection::vec(-1.0f32..1.0, 512),
        b in proptest::collection::vec(-1.0f32..1.0, 512),
    ) {
        let pa = BlockPyramid::new(&a, 8).unwrap();
        let pb = BlockPyramid::new(&b, 8).unwrap();
        for l in 1..pa.level_count() {
            let coarse = pa.level_distance(&pb, l).unwrap();
            let fine = pa.level_distance(&pb, l + 1).unwrap();
            prop_assert!(coarse <= fine + 1e-6, "level {l}: {coarse} > {fine}");
        }
    }
}

#[test]
fn block_distances_of_unequal_sizes_are_refused() {
    use distance_field::mean_squared_difference;
    assert_eq!(mean_squared_difference(&[1.0, 2.0], &[1.0, 0.0]), Some(2.0));
    assert_eq!(mean_squared_difference(&[], &[]), Some(0.0));
    assert_eq!(mean_squared_difference(&[1.0, 2.0], &[1.0]), None);
    let small = BlockPyramid::new(&[0.5; 8], 2).unwrap();
    let large = BlockPyramid::new(&[0.5; 64], 4).unwrap();
    // Level 2 has 2³ samples in both; level 3 exists in the larger pyramid only.
    assert_eq!(small.level_distance(&large, 2), Some(0.0));
    assert_eq!(small.level_distance(&large, 3), None);
    assert!(BlockPyramid::new(&[0.5; 7], 2).is_err());
}

// ------------------------------------------------------------ iso-surfaces

fn analytic_grid(n: usize, half: f32, f: impl Fn(Vec3) -> f32) -> Grid3<f32> {
    let spacing = 2.0 * half / (n - 1) as f32;
    let origin = Vec3::splat(-half);
    let mut data = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                data.push(f(origin + Vec3::new(i as f32, j as f32, k as f32) * spacing));
            }
        }
    }
    Grid3::from_vec([n; 3], origin, spacing, data).unwrap()
}

/// Checks every edge is used by exactly two faces, once per direction; returns V − E + F.
fn euler_characteristic_of_closed_manifold(mesh: &TriMesh) -> i64 {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for t in mesh.triangles() {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(
            n, 1,
            "edge {a}-{b} used twice in one direction (orientation flip or non-manifold)"
        );
        assert_eq!(directed.get(&(b, a)), Some(&1), "edge {a}-{b} is a border");
    }
    let edges = directed.len() as i64 / 2;
    mesh.vertex_count() as i64 - edges + mesh.face_count() as i64
}

fn volume(mesh: &TriMesh) -> f64 {
    let p = mesh.positions();
    mesh.triangles()
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| p[v as usize].as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

#[test]
fn sphere_isosurface_is_a_closed_sphere_with_the_right_area_and_volume() {
    let r = 0.8f32;
    let grid = analytic_grid(64, 1.0, |p| p.length() - r);
    let mesh = isosurface(&grid, 0.0).unwrap();
    assert_eq!(euler_characteristic_of_closed_manifold(&mesh), 2);
    let area = mesh.area();
    let exact_area = 4.0 * std::f64::consts::PI * f64::from(r).powi(2);
    assert!(
        (area - exact_area).abs() < 0.01 * exact_area,
        "area {area} vs {exact_area}"
    );
    let vol = volume(&mesh);
    let exact_vol = 4.0 / 3.0 * std::f64::consts::PI * f64::from(r).powi(3);
    assert!(
        (vol - exact_vol).abs() < 0.01 * exact_vol,
        "volume {vol} vs {exact_vol}"
    );
    // Positive volume means the faces point outward.
    assert!(vol > 0.0);
}

#[test]
fn torus_isosurface_has_euler_characteristic_zero() {
    let (big, small) = (0.6f32, 0.25f32);
    let grid = analytic_grid(64, 1.0, |p| {
        let q = glam::Vec2::new(glam::Vec2::new(p.x, p.z).length() - big, p.y);
        q.length() - small
    });
    let mesh = isosurface(&grid, 0.0).unwrap();
    assert_eq!(euler_characteristic_of_closed_manifold(&mesh), 0);
    assert!(mesh.degenerate_faces().len() < mesh.face_count() / 100);
}

#[test]
fn crossings_on_grid_nodes_give_no_two_vertices_one_position() {
    // Spacing 0.125 from −1: the sphere of radius 0.5 passes exactly through six nodes
    // (±0.5 on each axis) and the plane z = x through a whole diagonal sheet of them. Every
    // edge into such a node crosses zero on it; those vertices once all sat on the node, so
    // welding by position pinched the sphere there (found remeshing fertility.off).
    // How far a vertex may sit off the surface: the sphere's linear interpolation across a
    // cell (up to 3h² / 8r = 0.012 along a cell diagonal), the plane's a thousandth of an edge.
    for (name, field, tolerance) in [
        (
            "sphere",
            (|p: Vec3| p.length() - 0.5) as fn(Vec3) -> f32,
            0.012,
        ),
        ("plane", |p: Vec3| p.z - p.x, 5e-4),
    ] {
        let mesh = isosurface(&analytic_grid(17, 1.0, field), 0.0).unwrap();
        let welded = mesh.welded().unwrap();
        assert_eq!(welded.vertex_count(), mesh.vertex_count(), "{name}");
        let topology = welded.topology();
        assert_eq!(topology.non_manifold_edges, 0, "{name}");
        if name.ends_with("sphere") {
            assert_eq!(euler_characteristic_of_closed_manifold(&welded), 2);
        }
        // Kept off the nodes by a thousandth of an edge, so still on the surface.
        for p in mesh.positions() {
            assert!(
                field(*p).abs() < tolerance,
                "{name}: {p} off by {}",
                field(*p)
            );
        }
    }
}

#[test]
fn crossings_within_an_f32_step_of_a_node_give_no_two_vertices_one_position() {
    // Far from the origin (x about 60, as in fertility.off, where this was found) an offset
    // of a few millionths from a node rounds away on some axes and not on others, so two
    // edges through one node could put their vertices at one position without either being
    // on the node. Nodes whose values are within 1e-6 of zero, of either sign, make such
    // crossings everywhere.
    let n = 14;
    let (origin, spacing) = (Vec3::new(-62.0, 30.5, 8.0), 0.2);
    let centre = origin + Vec3::splat(1.3);
    let mut g = rng::rng_from_seed(4);
    let data = (0..n * n * n)
        .map(|i| {
            let p = origin
                + Vec3::new((i % n) as f32, ((i / n) % n) as f32, (i / n / n) as f32) * spacing;
            let value = (p - centre).length() - 0.9;
            if g.random_bool(0.3) {
                value * 1e-6
            } else {
                value
            }
        })
        .collect();
    let grid = Grid3::from_vec([n; 3], origin, spacing, data).unwrap();
    let mesh = isosurface(&grid, 0.0).unwrap();
    assert!(mesh.face_count() > 500);
    let welded = mesh.welded().unwrap();
    assert_eq!(welded.vertex_count(), mesh.vertex_count());
}

#[test]
fn sdf_isosurface_uses_stored_gradients_for_normals() {
    let spec = GridSpec::covering(Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0)), 40, 0.2).unwrap();
    let sdf = SdfGrid::from_surface(&AnalyticSphere(1.0), &spec, 0.5).unwrap();
    let mesh = sdf_isosurface(&sdf).unwrap();
    assert_eq!(euler_characteristic_of_closed_manifold(&mesh), 2);
    for (p, n) in mesh
        .positions()
        .iter()
        .zip(mesh.vertices().normals().unwrap())
    {
        assert!((p.length() - 1.0).abs() < 2e-3);
        assert!(n.dot(p.normalize()) > 0.999);
    }
    // Empty and constant fields give empty meshes, not errors.
    let flat = analytic_grid(4, 1.0, |_| 1.0);
    assert_eq!(isosurface(&flat, 0.0).unwrap().face_count(), 0);
}

#[test]
fn stored_gradients_facing_against_the_surface_give_way_to_their_neighbours() {
    // A sphere's field with one node a hair outside the surface signed inside, its
    // gradient still pointing to the surface it measured (inward), as a winding number
    // overriding an MLS surface's sign leaves it: the zero set bulges around the node.
    let spec = GridSpec::covering(Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0)), 24, 0.2).unwrap();
    let sdf = SdfGrid::from_surface(&AnalyticSphere(1.0), &spec, 0.5).unwrap();
    let grid = sdf.grid();
    let [nx, ny, nz] = grid.dims();
    let mut data = grid.data().to_vec();
    let mut flipped = 0;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let v = &mut data[i + nx * (j + ny * k)];
                if v.x > 0.0 && v.x < 0.1 * grid.spacing() {
                    let inward = -Vec3::new(v.y, v.z, v.w);
                    *v = Vec4::new(-v.x, inward.x, inward.y, inward.z);
                    flipped += 1;
                }
            }
        }
    }
    assert!(flipped > 0, "no node close enough to the sphere to flip");
    let bulged = SdfGrid::from_grid(
        Grid3::from_vec(grid.dims(), grid.origin(), grid.spacing(), data).unwrap(),
        sdf.band(),
    )
    .unwrap();
    let mesh = sdf_isosurface(&bulged).unwrap();
    assert_eq!(euler_characteristic_of_closed_manifold(&mesh), 2);
    assert_eq!(mesh.normals_against_faces(), 0);
    let least = mesh
        .positions()
        .iter()
        .zip(mesh.vertices().normals().unwrap())
        .map(|(p, n)| n.dot(p.normalize()))
        .fold(1.0f32, f32::min);
    // The bulges are shaded as the sphere around them: every normal within 18° of the
    // sphere's (measured: 9°), taken from a neighbouring node's gradient.
    println!("least cosine to the radial direction {least}");
    assert!(least > 0.95, "{least}");
}

// ------------------------------------------------------------ NRRD

#[test]
fn nrrd_round_trips_and_rejects_short_data() {
    let grid = analytic_grid(9, 1.0, |p| p.x - 2.0 * p.y + p.z * p.z);
    let mut bytes = Vec::new();
    nrrd::write_scalar(&mut bytes, &grid).unwrap();
    let back = nrrd::read(&bytes).unwrap();
    assert_eq!(back.channels, 1);
    assert_eq!(back.scalar_grid().unwrap(), grid);

    let spec = GridSpec::covering(Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0)), 8, 0.1).unwrap();
    let sdf = SdfGrid::from_surface(&AnalyticSphere(0.7), &spec, 0.5).unwrap();
    let mut bytes4 = Vec::new();
    nrrd::write_vec4(&mut bytes4, sdf.grid()).unwrap();
    let back4 = nrrd::read(&bytes4).unwrap();
    assert_eq!(back4.channels, 4);
    assert_eq!(&back4.vec4_grid().unwrap(), sdf.grid());

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.nrrd");
    nrrd::write_file(&path, |f| nrrd::write_vec4(f, sdf.grid())).unwrap();
    assert_eq!(nrrd::read_file(&path).unwrap(), back4);

    // A grid kept relative to a far origin: the header's origin is the sum, at full
    // precision (at 4e6 an f32 steps by 0.25).
    let mut far = Vec::new();
    let offset = glam::DVec3::new(512_000.0, 4_100_000.0, 10.0);
    nrrd::write_scalar_at(&mut far, &grid, offset).unwrap();
    let head = String::from_utf8_lossy(&far[..far.len().min(600)]).into_owned();
    let o = grid.origin().as_dvec3() + offset;
    assert!(
        head.contains(&format!("space origin: ({},{},{})", o.x, o.y, o.z)),
        "{head}"
    );
    // Read back in double precision and relative to the same offset, it is the grid again
    // (in single precision its origin would be off by up to 0.25).
    let back_far = nrrd::read(&far).unwrap();
    assert_eq!(back_far.origin, o);
    assert_eq!(back_far.scalar_grid_at(offset).unwrap(), grid);

    // Per-axis spacings and minima, with `nan` for a leading channel axis (as teem writes).
    let mut axis_fields =
        b"NRRD0004\ntype: float\nsizes: 1 2 1 1\nencoding: raw\nspacings: nan 0.5 0.5 0.5\n"
            .to_vec();
    axis_fields.extend_from_slice(b"axis mins: nan 1 2 3\n\n");
    axis_fields.extend_from_slice(&[0u8; 8]);
    let read = nrrd::read(&axis_fields).unwrap();
    assert_eq!((read.dims, read.channels), ([2, 1, 1], 1));
    assert_eq!(
        (read.origin, read.spacing),
        (glam::DVec3::new(1.0, 2.0, 3.0), 0.5)
    );

    // Truncated data and lying headers are errors, not allocations or panics.
    assert!(matches!(
        nrrd::read(&bytes[..bytes.len() - 3]),
        Err(FieldError::Nrrd { .. })
    ));
    let liar = b"NRRD0004\ntype: float\ndimension: 3\nsizes: 100000 100000 100000\nencoding: raw\nspacings: 1 1 1\n\n1234";
    assert!(matches!(nrrd::read(liar), Err(FieldError::Nrrd { .. })));
    for bad in [
        &b"NRRD0004\ntype: block\nsizes: 1 1 1\nencoding: raw\nspacings: 1 1 1\n\n00000000"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: bzip2\nspacings: 1 1 1\n\n0000"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: raw\nbyte skip: 4\nspacings: 1 1 1\n\n00000000"[..],
        // Data short of what the header promises, in each encoding.
        &b"NRRD0004\ntype: short\nsizes: 1 1 1\nencoding: raw\nspacings: 1 1 1\n\n0"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: gzip\nspacings: 1 1 1\n\n"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 2\nencoding: ascii\nspacings: 1 1 1\n\n1.5"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: ascii\nspacings: 1 1 1\n\nabc"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: gzip\nspacings: 1 1 1\n\nnot gzip"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1\nencoding: raw\nspacings: 1 1\n\n"[..],
        &b"not nrrd\n\n"[..],
        &b"NRRD0004\ntype: float"[..],
        // Per-axis fields that do not say what they should are errors, not defaults.
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: raw\nspacings: 1 2 1\n\n0000"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: raw\nspacings: 1 x 1\n\n0000"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: raw\nspacings: 0 0 0\n\n0000"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: raw\nspacings: 1 1\n\n0000"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: raw\nspacings: 1 1 1\naxis mins: 0 y 0\n\n0000"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: raw\nspacings: 1 1 1\naxis mins: 0 nan 0\n\n0000"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: raw\nspace directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: (1,2)\n\n0000"[..],
        &b"NRRD0004\ntype: float\nsizes: 1 1 1\nencoding: raw\nspace directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: 1 2 3\n\n0000"[..],
    ] {
        assert!(
            matches!(nrrd::read(bad), Err(FieldError::Nrrd { .. })),
            "{:?}",
            String::from_utf8_lossy(bad)
        );
    }
}

#[test]
fn nrrd_reads_every_scalar_type_in_every_encoding() {
    use flate2::{Compression, write::GzEncoder};
    use std::io::Write;
    // Values every type holds exactly: -3..4 (0..7 for unsigned types), 2 x 2 x 2 nodes.
    // Each type: an NRRD spelling, whether it is signed, and its little-endian encoding.
    type Encode = fn(f64) -> Vec<u8>;
    let types: [(&str, bool, Encode); 10] = [
        ("signed char", true, |v| (v as i8).to_le_bytes().to_vec()),
        ("uint8_t", false, |v| (v as u8).to_le_bytes().to_vec()),
        ("short", true, |v| (v as i16).to_le_bytes().to_vec()),
        ("unsigned short", false, |v| {
            (v as u16).to_le_bytes().to_vec()
        }),
        ("int32", true, |v| (v as i32).to_le_bytes().to_vec()),
        ("uint", false, |v| (v as u32).to_le_bytes().to_vec()),
        ("int64", true, |v| (v as i64).to_le_bytes().to_vec()),
        ("unsigned long long", false, |v| {
            (v as u64).to_le_bytes().to_vec()
        }),
        ("float", true, |v| (v as f32).to_le_bytes().to_vec()),
        ("double", true, |v| v.to_le_bytes().to_vec()),
    ];
    for (name, signed, encode) in types {
        let values: Vec<f64> = (0..8)
            .map(|i| f64::from(i) - if signed { 3.0 } else { 0.0 })
            .collect();
        let binary = |big: bool| -> Vec<u8> {
            let mut out = Vec::new();
            for &v in &values {
                let mut le = encode(v);
                if big {
                    le.reverse();
                }
                out.extend(le);
            }
            out
        };
        let text: String = values.iter().map(|v| format!("{v}\n")).collect();
        let bodies = [
            ("raw", "little", binary(false)),
            ("raw", "big", binary(true)),
            ("gzip", "big", gzipped(&binary(true))),
            ("gz", "little", gzipped(&binary(false))),
            ("ascii", "little", text.into_bytes()),
        ];
        for (encoding, endian, body) in bodies {
            let mut file = format!(
                "NRRD0005\ntype: {name}\ndimension: 3\nsizes: 2 2 2\nendian: {endian}\n\
                 encoding: {encoding}\nspacings: 0.5 0.5 0.5\n\n"
            )
            .into_bytes();
            file.extend_from_slice(&body);
            let volume =
                nrrd::read(&file).unwrap_or_else(|e| panic!("{name}, {encoding}, {endian}: {e}"));
            let expected: Vec<f32> = values.iter().map(|&v| v as f32).collect();
            assert_eq!(volume.data, expected, "{name}, {encoding}, {endian}");
            assert_eq!((volume.dims, volume.spacing), ([2, 2, 2], 0.5));
        }
    }
    // A gzip stream that inflates to far more than the header promises is read only as
    // far as needed (64 MB of zeros behind a 2 x 2 x 2 float header).
    let mut encoder = GzEncoder::new(Vec::new(), Compression::best());
    for _ in 0..64 {
        encoder.write_all(&vec![0u8; 1 << 20]).unwrap();
    }
    let mut bomb =
        b"NRRD0004\ntype: float\nsizes: 2 2 2\nencoding: gzip\nspacings: 1 1 1\n\n".to_vec();
    bomb.extend(encoder.finish().unwrap());
    assert_eq!(nrrd::read(&bomb).unwrap().data, vec![0.0; 8]);
}

#[test]
fn invalid_parameters_are_errors() {
    let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
    assert!(GridSpec::covering(b, 1, 0.0).is_err());
    assert!(GridSpec::covering(b, 10, -1.0).is_err());
    assert!(GridSpec::covering(Aabb::new(Vec3::ZERO, Vec3::ZERO), 10, 0.0).is_err());
    let spec = GridSpec::covering(b, 10, 0.0).unwrap();
    assert!(spec.sub_box([0, 0, 0], [11, 2, 2]).is_err());
    let sub = spec.sub_box([2, 3, 4], [5, 6, 8]).unwrap();
    assert_eq!(sub.dims, [3, 3, 4]);
    assert!((sub.origin - spec.node(2, 3, 4)).length() < 1e-6);
    assert!(SdfGrid::from_surface(&AnalyticSphere(1.0), &spec, 0.0).is_err());
    let flat = TriMesh::new(
        PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0]).unwrap(),
        vec![[0, 1, 2]],
    )
    .unwrap();
    assert!(matches!(
        MeshSurface::new(&flat),
        Err(FieldError::EmptyMesh)
    ));
}

#[test]
fn band_limited_bunny_grid_agrees_with_unlimited_queries() {
    let Some(mesh) = watertight_bunny("band_limited_bunny_grid") else {
        return;
    };
    let surface = MeshSurface::new(&mesh).unwrap();
    let spec = GridSpec::covering(mesh.bounding_box().unwrap(), 40, 0.0).unwrap();
    let band = 3.0 * spec.spacing;
    let sdf = SdfGrid::from_surface(&surface, &spec, band).unwrap();
    assert_eq!(sdf.undefined_nodes(), 0);
    assert!(sdf.far_nodes() > 0);
    let [nx, ny, nz] = sdf.dims();
    for n in (0..nx * ny * nz).step_by(13) {
        let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
        let exact = surface.signed_distance_to(spec.node(i, j, k)).unwrap();
        let d = sdf.distance(i, j, k).unwrap();
        assert!(
            (d - exact.clamp(-band, band)).abs() <= 1e-4 * band,
            "node {n}: {d} vs {exact}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    /// Any edit of a valid file (bytes replaced, the file cut short) reads as a volume
    /// whose data fills its dims, or as an error; never a panic.
    #[test]
    fn nrrd_edits_are_read_or_refused(
        edits in proptest::collection::vec((0usize..400, any::<u8>()), 1..6),
        cut in proptest::option::of(0usize..600),
        vec4 in any::<bool>(),
        encoding in 0usize..3,
    ) {
        let grid = analytic_grid(4, 1.0, |p| p.x + p.y * p.z);
        let mut bytes = Vec::new();
        if vec4 {
            let spec = GridSpec::covering(Aabb::new(Vec3::splat(-1.0), Vec3::ONE), 4, 0.0).unwrap();
            let sdf = SdfGrid::from_surface(&AnalyticSphere(0.5), &spec, 1.0).unwrap();
            nrrd::write_vec4(&mut bytes, sdf.grid()).unwrap();
        } else {
            nrrd::write_scalar(&mut bytes, &grid).unwrap();
        }
        if encoding > 0 {
            bytes = reencoded(&bytes, encoding == 1);
        }
        for (at, byte) in edits {
            if let Some(b) = bytes.get_mut(at) {
                *b = byte;
            }
        }
        // Some files are only edited: a cut of `cut % len` would almost always shorten them.
        if let Some(cut) = cut {
            bytes.truncate(bytes.len().saturating_sub(cut % bytes.len().max(1)));
        }
        if let Ok(volume) = nrrd::read(&bytes) {
            let nodes: usize = volume.dims.iter().product();
            prop_assert_eq!(volume.data.len(), nodes * volume.channels);
            prop_assert!(volume.spacing > 0.0 && volume.origin.is_finite());
            let _ = volume.scalar_grid();
        }
    }
}

/// `data` gzip-compressed.
fn gzipped(data: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    encoder.write_all(data).unwrap();
    encoder.finish().unwrap()
}

/// A raw little-endian float NRRD file as we write it, re-encoded as `gzip` or, when
/// `gzip` is false, as `ascii` numbers.
fn reencoded(raw: &[u8], gzip: bool) -> Vec<u8> {
    let split = raw.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
    let header = String::from_utf8(raw[..split].to_vec()).unwrap();
    let values: Vec<f32> = raw[split..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let (name, body) = if gzip {
        ("gzip", gzipped(&raw[split..]))
    } else {
        let text: String = values.iter().map(|v| format!("{v} ")).collect();
        ("ascii", text.into_bytes())
    };
    let mut out = header
        .replace("encoding: raw", &format!("encoding: {name}"))
        .into_bytes();
    out.extend(body);
    assert_eq!(nrrd::read(&out).unwrap().data, values);
    out
}

#[test]
fn detached_headers_read_the_data_file_beside_them() {
    let grid = analytic_grid(5, 1.0, |p| p.x - 0.5 * p.y + p.z * p.z);
    let mut attached = Vec::new();
    nrrd::write_scalar(&mut attached, &grid).unwrap();
    let expected = nrrd::read(&attached).unwrap();
    let split = attached.windows(2).position(|w| w == b"\n\n").unwrap() + 1;
    let header = String::from_utf8(attached[..split].to_vec()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let gzip_data = gzipped(&attached[split + 1..]);
    // Raw and gzip data, named relative to the header and by an absolute path; the header
    // ends with the file, not a blank line.
    let raw_path = dir.path().join("field.raw");
    std::fs::write(&raw_path, &attached[split + 1..]).unwrap();
    std::fs::write(dir.path().join("field.raw.gz"), &gzip_data).unwrap();
    let cases = [
        ("relative.nhdr", "raw", "field.raw".to_string()),
        ("gzip.nhdr", "gzip", "field.raw.gz".to_string()),
        ("absolute.NHDR", "raw", raw_path.display().to_string()),
    ];
    for (name, encoding, data_file) in cases {
        let text = header.replace("encoding: raw", &format!("encoding: {encoding}"))
            + &format!("data file: {data_file}\n");
        let path = dir.path().join(name);
        std::fs::write(&path, &text).unwrap();
        assert!(nrrd::is_nrrd_path(&path));
        assert_eq!(nrrd::read_file(&path).unwrap(), expected, "{name}");
        // From memory there is no folder to look in: a relative name is refused, naming the
        // way that works; an absolute one needs no folder.
        let from_memory = nrrd::read(text.as_bytes());
        if data_file.starts_with("field") {
            let err = from_memory.unwrap_err().to_string();
            assert!(err.contains("nrrd::read_file"), "{err}");
        } else {
            assert_eq!(from_memory.unwrap(), expected);
        }
    }
    // A missing or short data file, and data split over several files, are errors.
    let with_data = |data_file: &str| header.clone() + &format!("data file: {data_file}\n");
    let path = dir.path().join("bad.nhdr");
    std::fs::write(&path, with_data("missing.raw")).unwrap();
    assert!(matches!(nrrd::read_file(&path), Err(FieldError::Io { .. })));
    std::fs::write(dir.path().join("short.raw"), [0u8; 10]).unwrap();
    std::fs::write(&path, with_data("short.raw")).unwrap();
    let err = nrrd::read_file(&path).unwrap_err().to_string();
    assert!(
        err.contains("of data file") && err.contains("short.raw"),
        "{err}"
    );
    for split_data in ["LIST", "slice%03d.raw 0 4 1"] {
        std::fs::write(&path, with_data(split_data)).unwrap();
        let err = nrrd::read_file(&path).unwrap_err().to_string();
        assert!(err.contains("several files"), "{err}");
    }
}

// ------------------------------------------------------------ winding numbers

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// The hierarchy's fast winding number agrees with the brute-force sum over every
    /// triangle, for triangle soups and queries anywhere (near triangles too).
    #[test]
    fn fast_winding_numbers_match_brute_force(seed in 0u64..1000, n in 1usize..80) {
        let mesh = random_mesh(seed, n);
        let surface = MeshSurface::new(&mesh).unwrap();
        let mut g = rng::rng_from_seed(seed ^ 7);
        for _ in 0..40 {
            let q = Vec3::new(
                g.random_range(-1.0..2.0),
                g.random_range(-1.0..2.0),
                g.random_range(-1.0..2.0),
            );
            let (fast, exact) = (surface.winding_number(q), winding_number(&mesh, q));
            // Order-0 dipoles at BETA = 2 (the largest error seen over 8000 such queries
            // was 0.012).
            prop_assert!((f64::from(fast) - exact).abs() < 0.025, "{fast} vs {exact} at {q}");
        }
    }
}

/// Two closed spheres of radius 0.5, centres 0.6 apart, as one mesh of two intersecting
/// components, and the signed distance to their union.
fn overlapping_spheres() -> (TriMesh, impl Fn(Vec3) -> f32) {
    let grid = analytic_grid(40, 1.0, |p| p.length() - 0.5);
    let sphere = isosurface(&grid, 0.0).unwrap();
    let shift = Vec3::new(0.6, 0.0, 0.0);
    let n = sphere.vertex_count() as u32;
    let positions: Vec<Vec3> = sphere
        .positions()
        .iter()
        .copied()
        .chain(sphere.positions().iter().map(|p| *p + shift))
        .collect();
    let triangles: Vec<[u32; 3]> = sphere
        .triangles()
        .iter()
        .copied()
        .chain(sphere.triangles().iter().map(|t| t.map(|v| v + n)))
        .collect();
    let mesh = TriMesh::new(PointSet::new(positions).unwrap(), triangles).unwrap();
    let union = move |p: Vec3| (p.length() - 0.5).min((p - shift).length() - 0.5);
    (mesh, union)
}

#[test]
fn winding_numbers_sign_a_union_of_intersecting_pieces_where_pseudo_normals_fail() {
    let (mesh, union) = overlapping_spheres();
    let winding = MeshSurface::new(&mesh)
        .unwrap()
        .with_sign(MeshSign::WindingNumber);
    let pseudo = MeshSurface::new(&mesh).unwrap();
    assert_eq!(winding.sign_rule(), MeshSign::WindingNumber);
    let mut g = rng::rng_from_seed(3);
    let (mut checked, mut pseudo_wrong) = (0, 0);
    for _ in 0..3000 {
        let q = Vec3::new(
            g.random_range(-0.8..1.4),
            g.random_range(-0.8..0.8),
            g.random_range(-0.8..0.8),
        );
        let exact = union(q);
        // The mesh approximates the spheres within a fraction of its grid's spacing.
        if exact.abs() < 0.03 {
            continue;
        }
        checked += 1;
        let w = winding.signed_distance_to(q).unwrap();
        assert_eq!(w < 0.0, exact < 0.0, "at {q}: {w} vs {exact}");
        // The magnitude is the distance to the nearest piece, inner parts included.
        assert_eq!(w.abs(), pseudo.signed_distance_to(q).unwrap().abs());
        pseudo_wrong += usize::from((pseudo.signed_distance_to(q).unwrap() < 0.0) != (exact < 0.0));
    }
    assert!(checked > 2500, "{checked}");
    // Inside one sphere, next to the other's surface (inside the first), the nearest
    // piece's pseudo-normal says outside.
    assert!(pseudo_wrong > 50, "{pseudo_wrong}");
}

#[test]
fn a_grid_signed_by_winding_numbers_makes_the_union_one_closed_surface() {
    let (mesh, union) = overlapping_spheres();
    let spec = GridSpec::covering(mesh.bounding_box().unwrap(), 40, 0.1).unwrap();
    let band = 3.0 * spec.spacing;
    let surface = MeshSurface::new(&mesh)
        .unwrap()
        .with_sign(MeshSign::WindingNumber);
    let sdf = SdfGrid::from_surface(&surface, &spec, band).unwrap();
    let [nx, ny, nz] = sdf.dims();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let exact = union(spec.node(i, j, k));
                if exact.abs() > 0.03 {
                    let d = sdf.distance(i, j, k).unwrap();
                    assert_eq!(d < 0.0, exact < 0.0, "node ({i}, {j}, {k})");
                }
            }
        }
    }
    // The zero set is the union's outer surface: one closed sphere-like component.
    let iso = sdf_isosurface(&sdf).unwrap();
    assert_eq!(euler_characteristic_of_closed_manifold(&iso), 2);
    assert_eq!(iso.topology().components, 1);
}

#[test]
fn the_teapot_signed_by_winding_numbers_agrees_with_brute_force() {
    // The Utah teapot: body, lid, spout and handle as four open, intersecting pieces
    // (1036 border edges). Inside the body next to the spout's end, the nearest piece is
    // the spout, and its pseudo-normal says outside.
    let Some(mesh) = shared_mesh("teapot_winding", "meshes/utah_teapot.obj") else {
        return;
    };
    let spec = GridSpec::covering(mesh.bounding_box().unwrap(), 48, 0.2).unwrap();
    let band = 3.0 * spec.spacing;
    let grid = |sign| {
        let surface = MeshSurface::new(&mesh).unwrap().with_sign(sign);
        SdfGrid::from_surface(&surface, &spec, band).unwrap()
    };
    let (winding, pseudo) = (grid(MeshSign::WindingNumber), grid(MeshSign::PseudoNormal));
    let [nx, ny, nz] = winding.dims();
    let (mut checked, mut pseudo_wrong) = (0, 0);
    for n in (0..nx * ny * nz).step_by(7) {
        let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
        let d = winding.distance(i, j, k).unwrap();
        if d.abs() >= band {
            continue;
        }
        let inside = winding_number(&mesh, spec.node(i, j, k)) > 0.5;
        assert_eq!(d < 0.0, inside, "node ({i}, {j}, {k})");
        checked += 1;
        pseudo_wrong += usize::from((pseudo.distance(i, j, k).unwrap() < 0.0) != inside);
    }
    assert!(checked > 1000, "{checked}");
    assert!(pseudo_wrong > 10, "{pseudo_wrong} of {checked}");
}

#[test]
fn triangles_inside_other_parts_find_intersecting_pieces_only() {
    let (pair, _) = overlapping_spheres();
    let count = |mesh: &TriMesh| {
        let (inside, probed) = MeshSurface::new(mesh)
            .unwrap()
            .triangles_inside_other_parts(usize::MAX);
        assert_eq!(probed, mesh.face_count());
        inside
    };
    // Each sphere's cap inside the other: radius 0.5, centres 0.6 apart, so a cap of
    // height 0.2 of each, about a fifth of its area.
    let inside = count(&pair);
    let share = inside as f32 / pair.face_count() as f32;
    assert!(
        share > 0.15 && share < 0.25,
        "{inside} of {}",
        pair.face_count()
    );
    // One sphere; two apart; a shell with an inward-facing cavity: none.
    let grid = analytic_grid(40, 1.0, |p| p.length() - 0.5);
    let sphere = isosurface(&grid, 0.0).unwrap();
    assert_eq!(count(&sphere), 0);
    let n = sphere.vertex_count() as u32;
    let combined = |scale: f32, shift: Vec3, flip: bool| {
        let positions = sphere
            .positions()
            .iter()
            .copied()
            .chain(sphere.positions().iter().map(|p| *p * scale + shift))
            .collect();
        let triangles = sphere
            .triangles()
            .iter()
            .copied()
            .chain(sphere.triangles().iter().map(|t| {
                let t = t.map(|v| v + n);
                if flip { [t[0], t[2], t[1]] } else { t }
            }))
            .collect();
        TriMesh::new(PointSet::new(positions).unwrap(), triangles).unwrap()
    };
    assert_eq!(count(&combined(1.0, Vec3::new(1.5, 0.0, 0.0), false)), 0);
    assert_eq!(count(&combined(0.5, Vec3::ZERO, true)), 0);
    // A sample of the pair's triangles, every 10th: about the same share.
    let at_most = pair.face_count() / 10;
    let (inside, probed) = MeshSurface::new(&pair)
        .unwrap()
        .triangles_inside_other_parts(at_most);
    assert!(probed <= at_most && probed > at_most / 2, "{probed}");
    let sampled = inside as f32 / probed as f32;
    assert!((sampled - share).abs() < 0.03, "{sampled} vs {share}");
}

/// The vertices of `mesh`, an iso-surface of a field sampled from `surface` at `spacing`,
/// that neither lie on `surface` (within [`CROSSING_MISS`] of the longest edge, a cell's
/// diagonal) nor beside a change of its sign: `surface`'s signs a 200th of a spacing
/// either side of the vertex, along each direction of the grid's edges (axes and cell
/// diagonals), all agree.
fn vertices_off_surface_and_sign_change(
    mesh: &TriMesh,
    surface: &dyn Surface,
    spacing: f32,
) -> usize {
    let directions: Vec<Vec3> = (1..8)
        .map(|c| Vec3::new((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32))
        .map(Vec3::normalize)
        .collect();
    let inside = |p: Vec3| surface.signed_distance(p).map(|(d, _)| d < 0.0);
    let delta = spacing / 200.0;
    mesh.positions()
        .iter()
        .filter(|&&p| {
            let on_surface = surface
                .distance_within(p, CROSSING_MISS * 3.0f32.sqrt() * spacing)
                .is_some();
            let at_change = directions
                .iter()
                .any(|&u| inside(p - delta * u) != inside(p + delta * u));
            !on_surface && !at_change
        })
        .count()
}

/// An open box: the unit cube without its top face, facing out.
fn open_box() -> TriMesh {
    let corners: Vec<Vec3> = (0..8)
        .map(|c| Vec3::new((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32))
        .collect();
    let quads = [
        [0, 2, 3, 1], // bottom, facing -z
        [0, 1, 5, 4], // y = 0
        [2, 6, 7, 3], // y = 1
        [0, 4, 6, 2], // x = 0
        [1, 3, 7, 5], // x = 1
    ];
    let triangles = quads
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    TriMesh::new(PointSet::new(corners).unwrap(), triangles).unwrap()
}

#[test]
fn crossings_sit_on_the_surface_or_where_its_sign_changes() {
    // The open box signed by winding numbers: they close its opening with a cap of
    // w = ½ that is no part of the mesh, where the sign jumps between nodes far from it.
    let mesh = open_box();
    let surface = MeshSurface::new(&mesh)
        .unwrap()
        .with_sign(MeshSign::WindingNumber);
    let spec = GridSpec::covering(mesh.bounding_box().unwrap(), 24, 0.3).unwrap();
    let sdf = SdfGrid::from_surface(&surface, &spec, 4.0 * spec.spacing).unwrap();
    let plain = sdf_isosurface(&sdf).unwrap();
    let located = sdf_isosurface_of(&sdf, &surface).unwrap();
    // The unsigned, bounded distance the search asks for first is the signed one's size.
    for i in 0..1000 {
        let q = Vec3::new((i % 10) as f32, ((i / 10) % 10) as f32, (i / 100) as f32) * 0.15
            - Vec3::splat(0.1);
        let d = surface.signed_distance(q).unwrap().0.abs();
        for bound in [0.5 * d, 1.01 * d + 1e-6] {
            let expected = (d <= bound).then_some(d);
            let got = surface.distance_within(q, bound);
            assert_eq!(got.is_some(), expected.is_some(), "{q} within {bound}");
            assert!(
                got.zip(expected).is_none_or(|(g, e)| (g - e).abs() <= 1e-6),
                "{q}"
            );
        }
    }
    // Vertices move along their own edges only: the same faces, the same topology.
    assert_eq!(plain.triangles(), located.triangles());
    assert!(located.topology().is_closed_manifold());
    let misplaced = |m: &TriMesh| vertices_off_surface_and_sign_change(m, &surface, spec.spacing);
    // Measured: 846 of 4538 before.
    let (before, after) = (misplaced(&plain), misplaced(&located));
    assert!(before > 400, "{before} of {}", plain.vertex_count());
    assert_eq!(after, 0, "{after} of {}", located.vertex_count());
    // From the middle of the opening the box's five faces subtend exactly a half
    // sphere: the cap passes through it, w = ½ at (0.5, 0.5, 1).
    let middle = located
        .positions()
        .iter()
        .filter(|p| (p.x - 0.5).abs() < 0.1 && (p.y - 0.5).abs() < 0.1 && p.z > 0.5)
        .map(|p| (p.z - 1.0).abs())
        .fold(f32::MAX, f32::min);
    assert!(middle < 0.1 * spec.spacing, "{middle}");
    // There the cap faces straight up, as its vertex's normal does: the stored gradients
    // point at the box's walls, not across the cap.
    let normals = located.vertices().normals().unwrap();
    let (_, up) = located
        .positions()
        .iter()
        .zip(normals)
        .map(|(p, n)| (p.distance(Vec3::new(0.5, 0.5, 1.0)), *n))
        .fold((f32::MAX, Vec3::ZERO), |a, b| if b.0 < a.0 { b } else { a });
    assert!(up.z > 0.95, "{up}");

    // A closed, consistent mesh signed by pseudo-normals: the sign changes only at the
    // surface, so the vertices that move get nearer to it, none farther.
    let sphere = isosurface(&analytic_grid(24, 1.0, |p| p.length() - 0.7), 0.0).unwrap();
    let surface = MeshSurface::new(&sphere).unwrap();
    let spec = GridSpec::covering(sphere.bounding_box().unwrap(), 20, 0.3).unwrap();
    let sdf = SdfGrid::from_surface(&surface, &spec, 3.0 * spec.spacing).unwrap();
    let (plain, located) = (
        sdf_isosurface(&sdf).unwrap(),
        sdf_isosurface_of(&sdf, &surface).unwrap(),
    );
    let off = |p: &Vec3| surface.signed_distance(*p).unwrap().0.abs();
    let mut moved = 0;
    for (p, q) in plain.positions().iter().zip(located.positions()) {
        assert!(
            off(q) <= off(p) + 1e-6,
            "{p} -> {q}: {} -> {}",
            off(p),
            off(q)
        );
        moved += usize::from(p != q);
    }
    assert!(moved > 0);
}

/// The teapot's four open, intersecting pieces signed by winding numbers at 48 nodes:
/// every vertex of the remesh on the mesh or at a change of the sign (2,348 of 10,526
/// neither without the search).
#[test]
fn the_teapots_remesh_follows_its_winding_sign() {
    let Some(mesh) = shared_mesh("teapot_crossings", "meshes/utah_teapot.obj") else {
        return;
    };
    let surface = MeshSurface::new(&mesh)
        .unwrap()
        .with_sign(MeshSign::WindingNumber);
    let spec = GridSpec::covering(mesh.bounding_box().unwrap(), 48, 0.2).unwrap();
    let sdf = SdfGrid::from_surface(&surface, &spec, 4.0 * spec.spacing).unwrap();
    let misplaced = |m: &TriMesh| vertices_off_surface_and_sign_change(m, &surface, spec.spacing);
    let before = misplaced(&sdf_isosurface(&sdf).unwrap());
    let after = misplaced(&sdf_isosurface_of(&sdf, &surface).unwrap());
    assert!(before > 1000, "{before}");
    assert_eq!(after, 0);
}

/// Vertices moved onto a smooth surface keep the stored gradients' normals, which the
/// mesh's own facets would only approximate: on 2000 sphere samples' MLS surface at 40
/// nodes, 307 of 14,714 vertices move, their normals within 0.12° of the sphere's where
/// the mesh's own reach 1.6°.
#[test]
fn vertices_moved_onto_a_smooth_surface_keep_smooth_normals() {
    let points = fibonacci_sphere(2000, 1.0);
    let mls = MlsSurface::new(&points, &MlsParams::default()).unwrap();
    let spec = GridSpec::covering(Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0)), 40, 0.2).unwrap();
    let sdf = SdfGrid::from_surface(&mls, &spec, 4.0 * spec.spacing).unwrap();
    let plain = sdf_isosurface(&sdf).unwrap();
    let located = sdf_isosurface_of(&sdf, &mls).unwrap();
    let given = located.vertices().normals().unwrap();
    let own = located.vertex_normals(pointset_core::NormalWeighting::Angle);
    let (mut moved, mut worst_given, mut worst_own) = (0, 1.0f32, 1.0f32);
    for (v, (p, q)) in plain
        .positions()
        .iter()
        .zip(located.positions())
        .enumerate()
    {
        if p != q {
            moved += 1;
            worst_given = worst_given.min(given[v].dot(q.normalize()));
            worst_own = worst_own.min(own[v].dot(q.normalize()));
        }
    }
    assert!(moved > 100, "{moved}");
    // Cosines of 0.5° and 1°.
    assert!(worst_given > 0.99996, "{worst_given}");
    assert!(worst_own < 0.99985, "{worst_own}");
}
