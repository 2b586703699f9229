//! Tests of the MLS surface against analytic shapes, degenerate input, and the contracts of
//! rays, surface variation, clustering and relaxation.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use glam::Vec3;
use mls_surface::{
    ClusterParams, Covariance, MAX_SUPPORT, MlsError, MlsParams, MlsSurface, NORMAL_NEIGHBOURS,
    RelaxParams, SINGLE_PLANE_COSINE, adaptive_clusters, estimate_normals, fit_normals,
    nearest_neighbour_spread, orient_normals, plane_radius, relax, surface_variation,
};
use pointset_core::{BandAnswer, KdIndex, MAX_SPAN, PointSet, Surface, rng};
use proptest::prelude::*;
use rand::RngExt;

/// `n` Fibonacci-spiral points on a sphere of radius `r`, normals outward.
fn sphere(n: usize, r: f32) -> PointSet {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let dirs: Vec<Vec3> = (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let s = (1.0 - y * y).sqrt();
            let phi = golden * i as f32;
            Vec3::new(s * phi.cos(), y, s * phi.sin())
        })
        .collect();
    PointSet::new(dirs.iter().map(|d| *d * r).collect())
        .unwrap()
        .with_normals(dirs)
        .unwrap()
}

fn random_unit(r: &mut rng::SeededRng) -> Vec3 {
    loop {
        let v = Vec3::new(
            r.random_range(-1.0..1.0),
            r.random_range(-1.0..1.0),
            r.random_range(-1.0..1.0),
        );
        if let Some(u) = v.try_normalize()
            && v.length() <= 1.0
        {
            return u;
        }
    }
}

#[test]
fn sphere_projection_lands_on_the_sphere_with_correct_normals() {
    // The Adamson–Alexa surface of a sphere lies inside it by about h²/r (the weighted centre
    // of a curved neighbourhood is inside the curve); 50k samples make h small enough for
    // the 1e-3·r bound.
    let r = 2.0;
    let points = sphere(50_000, r);
    let surface = MlsSurface::new(&points, &MlsParams::default()).unwrap();
    let mut g = rng::rng_from_seed(1);
    for _ in 0..500 {
        let dir = random_unit(&mut g);
        // Within 1.5 kernels of the surface, where the kernel reaches.
        let offset = g.random_range(-1.5..1.5) * surface.kernel();
        let q = dir * (r + offset);
        let p = surface
            .project(q)
            .expect("near the sphere the surface is defined");
        assert!(p.converged);
        assert!(
            (p.point.length() - r).abs() < 1e-3 * r,
            "off the sphere by {}",
            p.point.length() - r
        );
        let angle = p
            .normal
            .dot(p.point.normalize())
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees();
        assert!(angle < 1.0, "normal off by {angle}°");
        assert!((p.signed_distance - (q.length() - p.point.length())).abs() < 2e-3 * r);
        // Idempotent: projecting the projection does not move it.
        let again = surface.project(p.point).unwrap();
        assert!(again.point.distance(p.point) < 1e-4 * r);
    }
}

#[test]
fn plane_projection_is_orthogonal_projection() {
    let normal = Vec3::new(0.3, -0.2, 1.0).normalize();
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    let origin = Vec3::new(0.5, -1.0, 2.0);
    let p: Vec<Vec3> = (0..40 * 40)
        .map(|i| origin + u * ((i % 40) as f32 * 0.05) + v * ((i / 40) as f32 * 0.05))
        .collect();
    let points = PointSet::new(p)
        .unwrap()
        .with_normals(vec![normal; 1600])
        .unwrap();
    let surface = MlsSurface::new(&points, &MlsParams::default()).unwrap();
    let mut g = rng::rng_from_seed(2);
    for _ in 0..200 {
        let q = origin
            + u * g.random_range(0.5..1.5)
            + v * g.random_range(0.5..1.5)
            + normal * g.random_range(-0.1..0.1);
        let expected = q - normal * normal.dot(q - origin);
        let p = surface.project(q).unwrap();
        assert!(
            p.point.distance(expected) < 1e-4,
            "{} vs {}",
            p.point,
            expected
        );
        assert!((p.normal - normal).length() < 1e-5);
        assert!((p.signed_distance - normal.dot(q - origin)).abs() < 1e-4);
    }
}

#[test]
fn noisy_samples_still_converge_with_bounded_error() {
    let r = 1.0;
    let clean = sphere(10_000, r);
    let mut g = rng::rng_from_seed(3);
    let spacing = (4.0 * std::f32::consts::PI / 10_000.0).sqrt();
    let noisy_p: Vec<Vec3> = clean
        .positions()
        .iter()
        .map(|p| *p + random_unit(&mut g) * 0.2 * spacing)
        .collect();
    let noisy_n: Vec<Vec3> = clean
        .normals()
        .unwrap()
        .iter()
        .map(|n| (*n + random_unit(&mut g) * 0.1).normalize())
        .collect();
    let points = PointSet::new(noisy_p)
        .unwrap()
        .with_normals(noisy_n)
        .unwrap();
    let surface = MlsSurface::new(&points, &MlsParams::default()).unwrap();
    for _ in 0..300 {
        let q = random_unit(&mut g) * (r + g.random_range(-1.5..1.5) * surface.kernel());
        let p = surface.project(q).unwrap();
        assert!(p.converged);
        assert!((p.point.length() - r).abs() < 0.01 * r);
    }
}

#[test]
fn degenerate_input_gives_values_not_panics() {
    let points = sphere(2000, 1.0);
    let surface = MlsSurface::new(&points, &MlsParams::default()).unwrap();
    // Far away: no neighbours in the kernel.
    assert!(surface.project(Vec3::splat(100.0)).is_none());
    assert!(surface.normal(Vec3::splat(100.0)).is_none());
    assert!(
        surface
            .signed_distance(Vec3::new(f32::NAN, 0.0, 0.0))
            .is_none()
    );
    // The Surface trait falls back to the nearest sample instead.
    let far = surface.closest_point(Vec3::new(0.0, 100.0, 0.0)).unwrap();
    assert!(far.point.y > 0.99);
    // The sphere's centre: opposite normals cancel or no neighbours — either way None.
    assert!(surface.project(Vec3::ZERO).is_none());

    // Duplicated points: every sample twice.
    let mut doubled = points.clone();
    doubled.append(&points).unwrap();
    let s2 = MlsSurface::new(&doubled, &MlsParams::default()).unwrap();
    assert!(
        (s2.kernel() - surface.kernel()).abs() < 1e-6,
        "duplicates must not shrink the kernel estimate"
    );
    // Duplicates scale every weight equally, so the surface is unchanged.
    let q = Vec3::new(0.1, 1.02, 0.0);
    assert!(
        s2.project(q)
            .unwrap()
            .point
            .distance(surface.project(q).unwrap().point)
            < 1e-5
    );
    // Every sample 20 times (scanners that write each return per pass): the same kernel.
    let mut many = points.clone();
    for _ in 1..20 {
        many.append(&points).unwrap();
    }
    let s20 = MlsSurface::new(&many, &MlsParams::default()).unwrap();
    assert!((s20.kernel() - surface.kernel()).abs() < 1e-6);

    // Too few points for the kernel.
    let lonely = PointSet::new(vec![Vec3::ZERO])
        .unwrap()
        .with_normals(vec![Vec3::Z])
        .unwrap();
    assert!(matches!(
        MlsSurface::new(&lonely, &MlsParams::default()),
        Err(MlsError::InvalidParameter { .. })
    ));
    let s3 = MlsSurface::new(&lonely, &MlsParams::default().kernel(1.0)).unwrap();
    assert!(s3.project(Vec3::new(0.1, 0.0, 0.2)).is_none());
    let s4 = MlsSurface::new(&lonely, &MlsParams::default().kernel(1.0).min_neighbours(1)).unwrap();
    assert!(s4.project(Vec3::new(0.1, 0.0, 0.2)).unwrap().point.z.abs() < 1e-5);

    // Construction errors.
    let bare = PointSet::new(vec![Vec3::ZERO, Vec3::X]).unwrap();
    assert!(matches!(
        MlsSurface::new(&bare, &MlsParams::default()),
        Err(MlsError::MissingNormals)
    ));
    let zero_n = bare
        .clone()
        .with_normals(vec![Vec3::Z, Vec3::ZERO])
        .unwrap();
    assert!(matches!(
        MlsSurface::new(&zero_n, &MlsParams::default()),
        Err(MlsError::DegenerateNormal { index: 1 })
    ));
    let empty = PointSet::new(vec![]).unwrap().with_normals(vec![]).unwrap();
    assert!(matches!(
        MlsSurface::new(&empty, &MlsParams::default()),
        Err(MlsError::EmptyInput { .. })
    ));
    assert!(MlsSurface::new(&points, &MlsParams::default().support(-1.0)).is_err());
    // Kernels up to the widest span the library accepts, supports up to where the weights
    // vanish in f32; past either, an error (a kernel of 1e30 once reached a panic).
    for (params, fine) in [
        (MlsParams::default().kernel(MAX_SPAN), true),
        (MlsParams::default().kernel(2.0 * MAX_SPAN), false),
        (MlsParams::default().kernel(f32::MAX), false),
        (MlsParams::default().support(MAX_SUPPORT), true),
        (MlsParams::default().support(1.01 * MAX_SUPPORT), false),
    ] {
        assert_eq!(params.validate().is_ok(), fine, "{params:?}");
    }
    let huge_spacing = MlsParams::default().kernel_spacing_factor(1e38);
    let index = KdIndex::new(points.positions()).unwrap();
    assert!(huge_spacing.validate().is_ok() && huge_spacing.kernel_for(&index).is_err());
    assert!(MlsSurface::new(&points, &MlsParams::default().max_iterations(0)).is_err());
}

#[test]
fn rays_hit_the_sphere_where_geometry_says() {
    let points = sphere(20_000, 1.0);
    let surface = MlsSurface::new(&points, &MlsParams::default()).unwrap();
    let mut g = rng::rng_from_seed(4);
    for _ in 0..100 {
        let dir = random_unit(&mut g);
        let start = dir * 1.06;
        let hit = surface
            .intersect_ray(start, -dir, 0.2)
            .expect("inward ray crosses the sphere");
        assert!((hit.t - 0.06).abs() < 3e-3, "t = {}", hit.t);
        // The hit lies on the MLS surface: projecting it does not move it.
        let on_surface = surface.project(hit.point).unwrap();
        assert!(on_surface.point.distance(hit.point) < 1e-4);
        // Pointing away: nothing within reach.
        assert!(surface.intersect_ray(start, dir, 0.2).is_none());
        // Snapping along ±normal from either side finds the same surface point.
        let inside = dir * 0.97;
        let snapped = surface.snap_along_normal(inside, dir).unwrap();
        assert!((snapped.point.length() - 1.0).abs() < 3e-3);
        assert!(snapped.signed_distance < 0.0);
    }
    assert!(surface.intersect_ray(Vec3::ZERO, Vec3::ZERO, 1.0).is_none());
}

#[test]
fn a_ray_hits_the_first_crossing_of_a_wavy_sheet_converged() {
    // Waves sampled on a grid, normals from the slope. Rays come down from above at
    // angles down to grazing, so that many cross the sheet more than once: the hit must
    // be the first crossing a fine scan of `f` along the ray finds, and `f` must have
    // converged there. The root search steps along the fits' planes, safeguarded by
    // bisection; a search that strayed to a later root, or stopped early, fails this.
    let wave = |x: f32, y: f32| 0.1 * (x * 9.0).sin() * (y * 7.0).cos();
    let slope = |x: f32, y: f32| {
        Vec3::new(
            0.9 * (x * 9.0).cos() * (y * 7.0).cos(),
            -0.7 * (x * 9.0).sin() * (y * 7.0).sin(),
            0.0,
        )
    };
    let (mut positions, mut normals) = (Vec::new(), Vec::new());
    for i in 0..100 {
        for j in 0..100 {
            let (x, y) = (i as f32 * 0.02, j as f32 * 0.02);
            positions.push(Vec3::new(x, y, wave(x, y)));
            let g = slope(x, y);
            normals.push(Vec3::new(-g.x, -g.y, 1.0).normalize());
        }
    }
    let set = PointSet::new(positions)
        .unwrap()
        .with_normals(normals)
        .unwrap();
    let surface = MlsSurface::new(&set, &MlsParams::default()).unwrap();
    let h = surface.kernel();
    let tolerance = surface.params().tolerance * h;
    let mut g = rng::rng_from_seed(21);
    let (mut hits, mut crossed_again) = (0, 0);
    for _ in 0..200 {
        let origin = Vec3::new(g.random_range(0.5..1.5), g.random_range(0.5..1.5), 0.11);
        let down = g.random_range(0.03..0.35f32);
        let heading = g.random_range(0.0..std::f32::consts::TAU);
        let dir = Vec3::new(
            heading.cos(),
            heading.sin(),
            -down / (1.0 - down * down).sqrt(),
        )
        .normalize();
        let max_t = 0.9;
        // The first sign change of `f` at steps of h / 200, both ends defined.
        let fine = h / 200.0;
        let values: Vec<(f32, Option<f32>)> = (0..=(max_t / fine) as usize)
            .map(|k| {
                let t = k as f32 * fine;
                (t, surface.implicit(origin + t * dir))
            })
            .collect();
        let crossings: Vec<(f32, f32)> = values
            .windows(2)
            .filter_map(|w| match (w[0], w[1]) {
                ((t0, Some(f0)), (t1, Some(f1))) if (f0 < 0.0) != (f1 < 0.0) => Some((t0, t1)),
                _ => None,
            })
            .collect();
        let hit = surface.intersect_ray(origin, dir, max_t);
        let Some(&(lo, hi)) = crossings.first() else {
            assert!(hit.is_none(), "a hit where no sign changes: {hit:?}");
            continue;
        };
        let hit = hit.unwrap_or_else(|| panic!("no hit from {origin} along {dir}"));
        hits += 1;
        crossed_again += usize::from(crossings.len() > 1);
        // Converged means `|f| < tolerance`, which leaves the hit off the root by about
        // `|f|` over the slope of `f` along the ray (small for grazing rays).
        let slack = 1e-3 * h + 2.0 * tolerance / hit.normal.dot(dir).abs();
        assert!(
            hit.t >= lo - slack && hit.t <= hi + slack,
            "hit at {} outside the first crossing [{lo}, {hi}] from {origin} along {dir}",
            hit.t
        );
        let f = surface.implicit(hit.point).unwrap();
        assert!(f.abs() < tolerance, "|f| = {} at the hit", f.abs());
    }
    assert!(
        hits > 120 && crossed_again > 40,
        "{hits} hits, {crossed_again} crossing again"
    );
}

#[test]
fn the_signed_distance_is_its_definition_near_and_far() {
    // `Surface::signed_distance` shares one neighbour search between the projection and
    // `f(query)`. Rebuilt here from the public parts: magnitude from `closest_point`, sign
    // from `f(query)` where the kernel reaches, else from the closest sample's own plane
    // when the query lies within 45° of its normal (or `fallback_sign_samples` is 1), else
    // from the tangent planes of the `fallback_sign_samples` nearest samples.
    let mut points = sphere(3000, 1.0);
    let mut g = rng::rng_from_seed(6);
    let jitter: Vec<Vec3> = points
        .positions()
        .iter()
        .map(|p| *p * (1.0 + g.random_range(-0.01..0.01)))
        .collect();
    points = PointSet::new(jitter)
        .unwrap()
        .with_normals(points.normals().unwrap().to_vec())
        .unwrap();
    for planes in [1, 8] {
        let params = MlsParams::default().fallback_sign_samples(planes);
        let surface = MlsSurface::new(&points, &params).unwrap();
        let (mut near, mut far) = (0, 0);
        for _ in 0..2000 {
            let q = random_unit(&mut g) * g.random_range(0.0..1.6);
            let (d, c) = Surface::signed_distance(&surface, q).unwrap();
            let closest = surface.closest_point(q).unwrap();
            let offset = q - closest.point;
            let inside = match surface.fit(q) {
                Some(fit) => {
                    near += 1;
                    fit.value < 0.0
                }
                None if planes == 1
                    || offset.dot(closest.normal).abs()
                        >= SINGLE_PLANE_COSINE * offset.length() =>
                {
                    far += 1;
                    offset.dot(closest.normal) < 0.0
                }
                None => {
                    far += 1;
                    let vote: f32 = surface
                        .index()
                        .nearest(q, planes)
                        .unwrap()
                        .iter()
                        .map(|n| {
                            let o = q - surface.points()[n.index];
                            o.dot(surface.normals()[n.index]) / o.length_squared()
                        })
                        .sum();
                    vote < 0.0
                }
            };
            assert_eq!(c, closest, "query {q}");
            let sign = if inside { -1.0 } else { 1.0 };
            assert_eq!(d, sign * offset.length(), "query {q}, {planes} planes");
            // Bounded, the same answer or none (it skips the sign of too distant ones).
            for bound in [0.01, 0.1, 0.5] {
                let within = Surface::signed_distance_within(&surface, q, bound);
                assert_eq!(within, (d.abs() <= bound).then_some((d, c)), "query {q}");
            }
        }
        assert!(near > 100 && far > 100, "near {near}, far {far}");
    }
}

#[test]
fn a_clearance_keeps_its_promise_and_is_the_nearest_sample_gap() {
    // A sparse random sphere (kernel reach leaves holes) inside a larger box of queries.
    // Every query answered `Beyond { clearance }` promises that queries nearer than the
    // clearance have no answer within the bound either; the clearance is the nearest
    // sample's distance less the larger of the support radius and the bound.
    let mut g = rng::rng_from_seed(11);
    let dirs: Vec<Vec3> = (0..400).map(|_| random_unit(&mut g)).collect();
    let points = PointSet::new(dirs.clone())
        .unwrap()
        .with_normals(dirs)
        .unwrap();
    let surface = MlsSurface::new(&points, &MlsParams::default()).unwrap();
    let index = KdIndex::new(points.positions()).unwrap();
    let (mut cleared, mut kept) = (0, 0);
    for _ in 0..400 {
        let q = random_unit(&mut g) * g.random_range(0.0..3.0);
        let bound = g.random_range(0.02..0.4);
        let answer = surface.signed_distance_or_clearance(q, bound, None);
        assert_eq!(answer.within(), surface.signed_distance_within(q, bound));
        let BandAnswer::Beyond { clearance } = answer else {
            continue;
        };
        let nearest = index
            .nearest_one(q)
            .unwrap()
            .unwrap()
            .distance_squared
            .sqrt();
        let expected = nearest - surface.support_radius().max(bound);
        if surface.fit(q).is_none() && expected > 1e-4 {
            assert!(
                (clearance - expected).abs() < 1e-4,
                "{clearance} vs {expected}"
            );
            cleared += 1;
        } else {
            assert_eq!(clearance, 0.0, "query {q}");
        }
        for _ in 0..10 {
            // Up to just inside the clearance, where the promise is tightest.
            let r = clearance * g.random_range(0.5f32..1.0).sqrt().min(0.9999);
            let other = q + random_unit(&mut g) * r;
            assert_eq!(
                surface.signed_distance_within(other, bound),
                None,
                "{other}"
            );
            kept += 1;
        }
    }
    assert!(
        cleared > 100 && kept > 1000,
        "{cleared} cleared, {kept} checked"
    );
}

#[test]
fn out_of_reach_the_closest_point_is_the_brute_force_nearest_sample() {
    // Out of the kernel's reach the surface stands in the nearest sample. Within 1.5
    // support radii it is taken from the neighbours the projection gathered, beyond from
    // the index; both must be the exact nearest sample (ties: equal distance suffices).
    let mut g = rng::rng_from_seed(5);
    let dirs: Vec<Vec3> = (0..300).map(|_| random_unit(&mut g)).collect();
    let points = PointSet::new(dirs.clone())
        .unwrap()
        .with_normals(dirs.clone())
        .unwrap();
    let surface = MlsSurface::new(&points, &MlsParams::default()).unwrap();
    let r = surface.support_radius();
    let (mut gathered, mut beyond) = (0, 0);
    for _ in 0..2000 {
        let q = random_unit(&mut g) * g.random_range(0.0..2.5);
        if surface.project(q).is_some() {
            continue;
        }
        let nearest = dirs
            .iter()
            .map(|p| p.distance(q))
            .fold(f32::INFINITY, f32::min);
        let c = surface.closest_point(q).unwrap();
        assert_eq!(c.point.distance(q), nearest, "query {q}");
        let (d, _) = Surface::signed_distance(&surface, q).unwrap();
        assert_eq!(d.abs(), nearest, "query {q}");
        if nearest <= 1.5 * r {
            gathered += 1;
        } else {
            beyond += 1;
        }
    }
    assert!(
        gathered > 50 && beyond > 50,
        "{gathered} within 1.5 support radii, {beyond} beyond"
    );
}

#[test]
fn out_of_reach_queries_are_signed_by_the_nearby_planes_not_the_nearest_alone() {
    // The edge of a box: a bottom face z = 0 (normal −z, y from 0.1) and a front face
    // y = 0 (normal −y, z from 0.02), samples 0.1 apart, a kernel far too small to reach
    // the query. The query lies below the bottom face, just behind the front face's plane:
    // outside. Its nearest sample is on the front face, whose plane alone says inside; the
    // bottom face's planes, nearer in the sense that counts, say outside.
    let (mut points, mut normals) = (Vec::new(), Vec::new());
    for i in 0..11 {
        for j in 1..11 {
            points.push(Vec3::new(i as f32 * 0.1, j as f32 * 0.1, 0.0));
            normals.push(Vec3::NEG_Z);
            points.push(Vec3::new(i as f32 * 0.1, 0.0, 0.02 + (j - 1) as f32 * 0.1));
            normals.push(Vec3::NEG_Y);
        }
    }
    let set = PointSet::new(points)
        .unwrap()
        .with_normals(normals)
        .unwrap();
    let query = Vec3::new(0.5, 0.01, -0.05);
    let distance = |planes: usize| {
        let params = MlsParams::default()
            .kernel(0.01)
            .fallback_sign_samples(planes);
        let surface = MlsSurface::new(&set, &params).unwrap();
        assert!(surface.fit(query).is_none(), "the kernel must not reach");
        Surface::signed_distance(&surface, query).unwrap().0
    };
    assert!(
        distance(1) < 0.0,
        "the nearest sample's plane alone: inside"
    );
    assert!(distance(8) > 0.0, "eight nearby planes: outside");
    assert!(
        distance(8) == -distance(1),
        "the magnitude stays the nearest sample's"
    );
    assert!(matches!(
        MlsSurface::new(&set, &MlsParams::default().fallback_sign_samples(0)),
        Err(MlsError::InvalidParameter {
            name: "fallback_sign_samples",
            ..
        })
    ));
}

#[test]
fn the_snap_is_the_closer_of_two_full_rays() {
    // `snap` stops the backward march where the forward hit lies. Rebuilt here from two
    // full rays: the closer hit, the forward one on a tie, else the projection. Half the
    // rays run along a short chord just inside the sphere, so both hit at nearly the same
    // distance, often within one march step of each other. Far from the origin, where
    // points along the rays round to a coarse grid, as well as around it.
    for centre in [Vec3::ZERO, Vec3::new(3.0e3, -2.0e3, 1.0e3)] {
        snaps_are_the_closer_of_two_full_rays(centre);
    }
}

/// [`the_snap_is_the_closer_of_two_full_rays`] on a unit sphere around `centre`.
fn snaps_are_the_closer_of_two_full_rays(centre: Vec3) {
    let unit = sphere(1000, 1.0);
    let moved: Vec<Vec3> = unit.positions().iter().map(|p| *p + centre).collect();
    let normals = unit.normals().unwrap().to_vec();
    let set = PointSet::new(moved).unwrap().with_normals(normals).unwrap();
    let surface = MlsSurface::new(&set, &MlsParams::default()).unwrap();
    let reach = surface.support_radius();
    let mut g = rng::rng_from_seed(8);
    let (mut forward_won, mut backward_won, mut close_calls, mut projected) = (0, 0, 0, 0);
    for i in 0..4000 {
        let (p, n) = if i % 2 == 0 {
            (
                random_unit(&mut g) * g.random_range(0.9..1.1),
                random_unit(&mut g),
            )
        } else {
            let u = random_unit(&mut g);
            let along = u.any_orthonormal_vector();
            let r = (1.0 - (0.5 * reach).powi(2)).sqrt();
            (u * r + along * g.random_range(-0.02..0.02), along)
        };
        let p = p + centre;
        let snap = surface.snap(p, n);
        let forward = surface.intersect_ray(p, n, reach);
        let backward = surface.intersect_ray(p, -n, reach);
        let expected = match (forward, backward) {
            (Some(a), Some(b)) if b.t < a.t => {
                backward_won += 1;
                close_calls += usize::from(a.t - b.t < 0.25 * surface.kernel());
                Some(b.point)
            }
            (Some(a), _) => {
                forward_won += 1;
                Some(a.point)
            }
            (None, Some(b)) => {
                backward_won += 1;
                Some(b.point)
            }
            (None, None) => None,
        };
        match expected {
            Some(point) => assert_eq!(snap.map(|s| s.projection.point), Some(point), "p {p}"),
            None => {
                projected += 1;
                assert_eq!(
                    snap.map(|s| s.projection),
                    surface.project(p),
                    "p {p}, n {n}"
                );
            }
        }
    }
    assert!(
        forward_won > 100 && backward_won > 100 && close_calls > 100 && projected > 100,
        "around {centre}: forward {forward_won}, backward {backward_won} ({close_calls} \
         within a step of the forward hit), projection {projected}"
    );
}

#[test]
fn surface_variation_is_zero_on_planes_and_positive_on_curved_or_random_sets() {
    let plane: Vec<Vec3> = (0..900)
        .map(|i| Vec3::new((i % 30) as f32, (i / 30) as f32, 0.0))
        .collect();
    let v = surface_variation(&KdIndex::new(&plane).unwrap(), 16).unwrap();
    assert!(v.iter().all(|&s| s < 1e-6));
    let mut g = rng::rng_from_seed(5);
    let cloud: Vec<Vec3> = (0..2000)
        .map(|_| Vec3::new(g.random(), g.random(), g.random()))
        .collect();
    let v = surface_variation(&KdIndex::new(&cloud).unwrap(), 16).unwrap();
    let mean = v.iter().sum::<f32>() / v.len() as f32;
    assert!(
        mean > 0.15 && v.iter().all(|&s| s <= 1.0 / 3.0 + 1e-6),
        "mean {mean}"
    );
    assert!(surface_variation(&KdIndex::new(&plane).unwrap(), 2).is_err());
    // The covariance of a few plane points is flat; an index past the points is refused.
    let c = Covariance::of(&plane, [0, 1, 30, 31]).unwrap();
    assert!(c.variation() < 1e-6);
    assert!(Covariance::of(&plane, [0, 1, 900]).is_none());
    assert!(Covariance::of(&plane, []).is_none());
}

proptest! {
    #[test]
    fn clusters_partition_the_points_and_respect_limits(
        seed in any::<u64>(),
        n in 1usize..600,
        max_points in 1usize..40,
        max_variation in 0.0f32..0.2,
    ) {
        let mut g = rng::rng_from_seed(seed);
        // A mix of a sphere cap and duplicates.
        let mut pts: Vec<Vec3> = (0..n).map(|_| random_unit(&mut g)).collect();
        pts.extend(std::iter::repeat_n(pts[0], n / 10));
        let clusters = adaptive_clusters(&pts, &ClusterParams::default().max_points(max_points).max_variation(max_variation)).unwrap();
        let mut seen = vec![0u32; pts.len()];
        for c in &clusters {
            prop_assert!(c.members.contains(&c.representative));
            for &m in &c.members { seen[m] += 1; }
            let unsplittable = c.members.iter().all(|&m| pts[m] == pts[c.members[0]]);
            if !unsplittable {
                prop_assert!(c.members.len() <= max_points);
                prop_assert!(c.variation <= max_variation + 1e-6);
            }
        }
        prop_assert!(seen.iter().all(|&s| s == 1), "every point in exactly one cluster");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Sheets of lattice points (many equidistant neighbours, some repeated) or random
    /// points, any `k` and `up`: fitting and orienting in one pass gives what the two
    /// steps give, bit for bit.
    #[test]
    fn fitting_and_orienting_at_once_is_the_two_steps(
        seed in any::<u64>(),
        n in 3usize..400,
        lattice in any::<bool>(),
        k in 3usize..20,
        up in prop::sample::select(vec![Vec3::Z, Vec3::Y, -Vec3::X, Vec3::new(0.3, -0.2, 0.9)]),
    ) {
        use mls_surface::{fit_normals_with, fit_oriented_normals_with, orient_normals_with};
        let mut g = rng::rng_from_seed(seed);
        let positions: Vec<Vec3> = (0..n)
            .map(|_| {
                let (x, y): (f32, f32) = (g.random_range(0.0..8.0), g.random_range(0.0..8.0));
                let (x, y) = if lattice { (x.floor(), y.floor()) } else { (x, y) };
                Vec3::new(x, y, 0.3 * x.sin() * y.cos())
            })
            .collect();
        let points = PointSet::new(positions).unwrap();
        let index = KdIndex::new(points.positions()).unwrap();
        let mut ctx = pointset_core::RunContext::new(0);
        let fit = fit_normals_with(&index, &points, k, &mut ctx).unwrap();
        let two_steps = orient_normals_with(&index, &fit.points, up, &mut ctx).unwrap();
        let at_once = fit_oriented_normals_with(&index, points, k, up, &mut ctx).unwrap();
        prop_assert_eq!(at_once.points, two_steps);
        prop_assert_eq!(at_once.undefined, fit.undefined);
    }
}

#[test]
fn relaxation_evens_out_a_clumpy_sampling() {
    let reference = sphere(8000, 1.0);
    let surface = MlsSurface::new(&reference, &MlsParams::default()).unwrap();
    let mut g = rng::rng_from_seed(6);
    // Uniform random points (clumpy compared with a blue-noise sampling).
    let clumpy: Vec<Vec3> = (0..1500).map(|_| random_unit(&mut g)).collect();
    let relaxed = relax(&surface, &clumpy, &RelaxParams::default()).unwrap();
    assert!((relaxed.spread_before - nearest_neighbour_spread(&clumpy).unwrap()).abs() < 1e-6);
    assert!(
        relaxed.spread_after < 0.6 * relaxed.spread_before,
        "spread {} -> {}",
        relaxed.spread_before,
        relaxed.spread_after
    );
    for (p, n) in relaxed.positions.iter().zip(&relaxed.normals) {
        // On the MLS surface (which lies slightly inside the sphere, see above).
        assert!(surface.project(*p).unwrap().point.distance(*p) < 1e-4);
        assert!((p.length() - 1.0).abs() < 1e-2);
        assert!(n.dot(p.normalize()) > 0.999);
    }
}

#[test]
fn relaxation_keeps_the_orientation_where_the_surface_has_gaps() {
    // A sparse random sphere and a strict neighbour count: some points have too few samples
    // within the support to be projected. They must keep an outward normal (the nearest
    // sample's), not a fixed direction that points inward on half the sphere.
    let mut g = rng::rng_from_seed(8);
    let dirs: Vec<Vec3> = (0..400).map(|_| random_unit(&mut g)).collect();
    let points = PointSet::new(dirs.clone())
        .unwrap()
        .with_normals(dirs)
        .unwrap();
    let params = MlsParams::default().min_neighbours(8);
    let surface = MlsSurface::new(&points, &params).unwrap();
    let positions = points.positions();
    let unprojectable = positions
        .iter()
        .filter(|p| surface.project(**p).is_none())
        .count();
    assert!(
        unprojectable > 10,
        "{unprojectable} points without projection"
    );
    let relaxed = relax(&surface, positions, &RelaxParams::default().iterations(2)).unwrap();
    for (p, n) in relaxed.positions.iter().zip(&relaxed.normals) {
        assert!(n.dot(p.normalize()) > 0.5, "normal {n} at {p}");
    }
}

#[test]
fn parallel_results_do_not_depend_on_thread_count() {
    let points = sphere(5000, 1.0);
    let surface = MlsSurface::new(&points, &MlsParams::default()).unwrap();
    let mut g = rng::rng_from_seed(7);
    let queries: Vec<Vec3> = (0..2000)
        .map(|_| random_unit(&mut g) * g.random_range(0.9..1.1))
        .collect();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let proj = surface.project_all(&queries);
            let relaxed = relax(
                &surface,
                &queries[..500],
                &RelaxParams::default().iterations(3),
            )
            .unwrap();
            (proj, relaxed)
        })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn estimated_normals_are_the_analytic_ones_up_to_sign_and_orientation_fixes_the_sign() {
    // A sphere of 2000 points: the tangent plane of 12 neighbours is the sphere's to within
    // about a degree (its curvature tilts nothing on average; the spiral's unevenness a
    // little).
    let truth = sphere(2000, 1.5);
    let bare = PointSet::new(truth.positions().to_vec()).unwrap();
    let estimated = estimate_normals(&bare, NORMAL_NEIGHBOURS).unwrap();
    let pairs = || {
        estimated
            .normals()
            .unwrap()
            .iter()
            .zip(truth.normals().unwrap())
    };
    let worst = pairs()
        .map(|(e, t)| e.dot(*t).abs().min(1.0).acos().to_degrees())
        .fold(0.0f32, f32::max);
    assert!(worst < 2.0, "worst {worst}°");
    assert!(pairs().all(|(e, _)| (e.length() - 1.0).abs() < 1e-5));
    // Signs as the decomposition left them are mixed; propagation from the top makes
    // every one face out.
    assert!(pairs().any(|(e, t)| e.dot(*t) < 0.0));
    let oriented = orient_normals(&estimated, Vec3::Y).unwrap();
    let outward = oriented
        .normals()
        .unwrap()
        .iter()
        .zip(truth.normals().unwrap())
        .all(|(e, t)| e.dot(*t) > 0.99);
    assert!(outward);
    // On a plane, exactly the plane's normal.
    let grid: Vec<Vec3> = (0..400)
        .map(|i| Vec3::new((i % 20) as f32 * 0.3, 0.5, (i / 20) as f32 * 0.2))
        .collect();
    let flat = estimate_normals(&PointSet::new(grid).unwrap(), 8).unwrap();
    assert!(flat.normals().unwrap().iter().all(|n| n.y.abs() > 0.99999));
    // Errors, not panics.
    assert!(matches!(
        estimate_normals(&bare, 2),
        Err(MlsError::InvalidParameter { .. })
    ));
    assert!(matches!(
        estimate_normals(&PointSet::new(Vec::new()).unwrap(), 12),
        Err(MlsError::EmptyInput { .. })
    ));
    let two = PointSet::new(vec![Vec3::ZERO, Vec3::X]).unwrap();
    assert!(matches!(
        estimate_normals(&two, 12),
        Err(MlsError::InvalidParameter { .. })
    ));
}

/// Runs `work` in a context that records every report as (stage, done, total) and, once
/// a report's count reaches `cancel_at`, cancels the run; returns its result and the
/// reports.
fn recorded<T>(
    cancel_at: Option<u64>,
    work: impl FnOnce(&mut pointset_core::RunContext) -> T,
) -> (T, Vec<(String, u64, Option<u64>)>) {
    use std::sync::{Arc, Mutex};
    let reports = Arc::new(Mutex::new(Vec::new()));
    let sink = Arc::clone(&reports);
    let flag = pointset_core::CancelFlag::new();
    let cancel = flag.clone();
    let mut ctx = pointset_core::RunContext::new(0)
        .with_cancel_flag(flag)
        .with_progress(move |u: &pointset_core::ProgressUpdate<'_>| {
            sink.lock()
                .unwrap()
                .push((u.stage.to_string(), u.done, u.total));
            if cancel_at.is_some_and(|at| u.done >= at) {
                cancel.cancel();
            }
        });
    let result = work(&mut ctx);
    let reports = reports.lock().unwrap().clone();
    (result, reports)
}

#[test]
fn normals_report_their_progress_and_stop_when_cancelled() {
    use mls_surface::{
        FITTING_STAGE, LINKING_STAGE, ORIENTING_STAGE, fit_normals_in, fit_oriented_normals_with,
        orient_normals_in,
    };
    // 300 × 300 points on a rolling sheet: more than two reports' worth of each stage.
    let n = 90_000u64;
    let grid: Vec<Vec3> = (0..n as usize)
        .map(|i| {
            let (x, y) = ((i % 300) as f32 * 0.02, (i / 300) as f32 * 0.02);
            Vec3::new(x, y, 0.2 * (3.0 * x).sin())
        })
        .collect();
    let bare = PointSet::new(grid).unwrap();
    let counts = |reports: &[(String, u64, Option<u64>)], stage: &str| -> Vec<u64> {
        reports
            .iter()
            .filter(|(s, _, total)| s == stage && *total == Some(n))
            .map(|r| r.1)
            .collect()
    };

    let (fit, reports) = recorded(None, |ctx| fit_normals_in(&bare, 12, ctx));
    let fit = fit.unwrap();
    assert_eq!(fit.points, fit_normals(&bare, 12).unwrap().points);
    assert_eq!(counts(&reports, FITTING_STAGE), [65_536, n]);
    let (oriented, reports) = recorded(None, |ctx| orient_normals_in(&fit.points, Vec3::Z, ctx));
    assert_eq!(
        oriented.unwrap(),
        orient_normals(&fit.points, Vec3::Z).unwrap()
    );
    assert_eq!(counts(&reports, LINKING_STAGE), [65_536, n]);
    assert_eq!(counts(&reports, ORIENTING_STAGE), [0, 65_536, n]);
    // Both at once: the three stages reported in turn, each half timed.
    let index = KdIndex::new(bare.positions()).unwrap();
    let (both, reports) = recorded(None, |ctx| {
        let both = fit_oriented_normals_with(&index, bare.clone(), 12, Vec3::Z, ctx);
        let timed: Vec<&str> = ctx
            .timings()
            .iter()
            .map(|(name, _)| name.as_str())
            .collect();
        assert_eq!(timed, [FITTING_STAGE, ORIENTING_STAGE]);
        both
    });
    assert_eq!(
        both.unwrap().points,
        orient_normals(&fit.points, Vec3::Z).unwrap()
    );
    let stages: Vec<&str> = reports.iter().map(|r| r.0.as_str()).collect();
    let mut in_turn = stages.clone();
    in_turn.dedup();
    assert_eq!(in_turn, [FITTING_STAGE, LINKING_STAGE, ORIENTING_STAGE]);
    assert_eq!(counts(&reports, LINKING_STAGE), [65_536, n]);

    // Cancelled at the first report, each stops at the next check.
    let cancelled = |e: &MlsError| matches!(e, MlsError::Core(pointset_core::Error::Cancelled));
    let (stopped, reports) = recorded(Some(1), |ctx| fit_normals_in(&bare, 12, ctx));
    assert!(stopped.is_err_and(|e| cancelled(&e)));
    assert_eq!(reports.len(), 1);
    let (stopped, reports) = recorded(Some(0), |ctx| orient_normals_in(&fit.points, Vec3::Z, ctx));
    assert!(stopped.is_err_and(|e| cancelled(&e)));
    assert_eq!(
        reports.len(),
        1,
        "the graph's report, then the stop: {reports:?}"
    );
    let (stopped, reports) = recorded(Some(n), |ctx| {
        fit_oriented_normals_with(&index, bare.clone(), 12, Vec3::Z, ctx)
    });
    assert!(stopped.is_err_and(|e| cancelled(&e)));
    assert_eq!(reports.last().map(|r| r.0.as_str()), Some(FITTING_STAGE));
}

#[test]
fn neighbourhoods_on_one_line_or_one_point_are_said_to_define_no_normal() {
    let cov = |points: &[Vec3]| Covariance::of(points, 0..points.len()).unwrap();
    // A square patch of a plane defines its normal; a line, a point and the corners of a
    // cube (spread alike in every direction) do not.
    let square: Vec<Vec3> = (0..25)
        .map(|i| Vec3::new((i % 5) as f32, (i / 5) as f32, 0.0))
        .collect();
    assert!(cov(&square).defines_normal());
    let line: Vec<Vec3> = (0..10)
        .map(|i| Vec3::new(i as f32, 2.0 * i as f32, 1.0))
        .collect();
    assert!(!cov(&line).defines_normal());
    assert!(!cov(&[Vec3::ONE; 6]).defines_normal());
    let cube: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32))
        .collect();
    assert!(!cov(&cube).defines_normal());
    // Two rows 19 long: 0.001 apart they are a line, 0.1 apart still one (their spreads'
    // ratio is 8e-5), 1 apart a plane.
    for (width, defined) in [(1e-3, false), (0.1, false), (1.0, true)] {
        let strip: Vec<Vec3> = (0..40)
            .map(|i| Vec3::new((i / 2) as f32, width * (i % 2) as f32, 0.0))
            .collect();
        assert_eq!(cov(&strip).defines_normal(), defined, "width {width}");
    }

    // Scan lines 1 apart sampled every 0.02, with a little noise across them: 12
    // neighbours lie along one line, so no point's normal is defined and the estimate
    // points anywhere across the line; neighbourhoods reaching the next lines find the
    // plane z = 0.
    let mut rng = rng::rng_from_seed(21);
    let scan: Vec<Vec3> = (0..3000)
        .map(|i| {
            let jitter = 1e-5 * (rng.random::<f32>() - 0.5);
            Vec3::new((i % 300) as f32 * 0.02, (i / 300) as f32 + jitter, jitter)
        })
        .collect();
    let scan = PointSet::new(scan).unwrap();
    let narrow = fit_normals(&scan, 12).unwrap();
    assert_eq!(narrow.undefined.len(), 3000);
    let tilted = narrow
        .points
        .normals()
        .unwrap()
        .iter()
        .filter(|n| n.z.abs() < 0.9);
    assert!(
        tilted.count() > 300,
        "the estimates across the lines are arbitrary"
    );
    let wide = fit_normals(&scan, 160).unwrap();
    assert!(
        wide.undefined.is_empty(),
        "{:?}",
        &wide.undefined[..5.min(wide.undefined.len())]
    );
    assert!(
        wide.points
            .normals()
            .unwrap()
            .iter()
            .all(|n| n.z.abs() > 0.999)
    );
    // The normals are those of estimate_normals, and a sampled surface has no undefined
    // ones.
    assert_eq!(
        estimate_normals(&scan, 160).unwrap().normals(),
        wide.points.normals()
    );
    let sphere_fit = fit_normals(
        &PointSet::new(sphere(2000, 1.5).positions().to_vec()).unwrap(),
        12,
    );
    assert!(sphere_fit.unwrap().undefined.is_empty());
}

#[test]
fn plane_radius_is_the_spacing_on_a_surface_and_the_gap_between_scan_lines() {
    let radius = |p: Vec<Vec3>| plane_radius(&KdIndex::new(&p).unwrap()).unwrap();
    // A square grid 0.1 apart: the 4 nearest (the point and three of its neighbours) span
    // a plane at one spacing, or √2 of it for the diagonal.
    let grid: Vec<Vec3> = (0..900)
        .map(|i| Vec3::new((i % 30) as f32 * 0.1, (i / 30) as f32 * 0.1, 0.0))
        .collect();
    let r = radius(grid).unwrap();
    assert!((0.099..0.142).contains(&r), "{r}");
    // Scan lines: the distance to the next line, whatever the step along them.
    for (gap, step) in [(0.5, 0.01), (0.2, 0.005), (1.0, 0.05)] {
        let lines: Vec<Vec3> = (0..3000)
            .map(|i| Vec3::new((i % 300) as f32 * step, (i / 300) as f32 * gap, 0.0))
            .collect();
        let r = radius(lines).unwrap();
        assert!(r >= gap && r < 1.2 * gap, "gap {gap}, step {step}: {r}");
    }
    // Points on one line, or fewer than three, span no plane.
    assert_eq!(radius((0..50).map(|i| Vec3::X * i as f32).collect()), None);
    assert_eq!(radius(vec![Vec3::ZERO, Vec3::Y]), None);
    // On the sphere fixture it is about the spacing.
    let sphere_points = sphere(2000, 1.5);
    let index = KdIndex::new(sphere_points.positions()).unwrap();
    let r = plane_radius(&index).unwrap().unwrap();
    let spacing = index.median_spacing().unwrap();
    assert!(r > 0.5 * spacing && r < 2.0 * spacing, "{r} vs {spacing}");
}

#[test]
fn orienting_toward_no_direction_is_refused_by_name() {
    use mls_surface::fit_oriented_normals_with;
    let sheet = sphere(300, 1.0);
    let index = KdIndex::new(sheet.positions()).unwrap();
    for up in [
        Vec3::ZERO,
        Vec3::new(0.0, f32::NAN, 1.0),
        Vec3::splat(f32::NEG_INFINITY),
    ] {
        let is_up = |e: MlsError| matches!(e, MlsError::InvalidParameter { name: "up", .. });
        assert!(is_up(orient_normals(&sheet, up).unwrap_err()));
        let mut ctx = pointset_core::RunContext::new(0);
        let both = fit_oriented_normals_with(&index, sheet.clone(), 12, up, &mut ctx);
        assert!(is_up(both.unwrap_err()));
    }
    // Any other length is a direction.
    assert_eq!(
        orient_normals(&sheet, 40.0 * Vec3::Z).unwrap(),
        orient_normals(&sheet, Vec3::Z).unwrap()
    );
}
