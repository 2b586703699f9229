//! Tests of the thin-plate spline and the pairing against exact properties.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use glam::{DMat3, DVec3, Mat3, Vec2, Vec3};
use pointset_core::{Aabb, rng};
use proptest::prelude::*;
use rand::RngExt;
use tps_warp::{
    AffineRegularization, MAX_PAIRING_ROUNDS, PairingParams, PairingPoint, ThinPlateSpline,
    TpsError, TpsParams, anchors_in_regions, pair_and_fit, pair_points,
};

/// `points` moved up by `dz`.
fn lifted(points: &[PairingPoint], dz: f32) -> Vec<PairingPoint> {
    points
        .iter()
        .map(|p| PairingPoint {
            position: p.position + Vec3::Z * dz,
            ..*p
        })
        .collect()
}

fn random_points(g: &mut rng::SeededRng, n: usize, scale: f32) -> Vec<Vec3> {
    (0..n)
        .map(|_| {
            Vec3::new(
                g.random_range(-1.0..1.0),
                g.random_range(-1.0..1.0),
                g.random_range(-1.0..1.0),
            ) * scale
        })
        .collect()
}

/// `points` each moved by a random offset in `[0, reach)³`.
fn nudged(g: &mut rng::SeededRng, points: &[Vec3], reach: f32) -> Vec<Vec3> {
    points
        .iter()
        .map(|p| *p + Vec3::new(g.random(), g.random(), g.random()) * reach)
        .collect()
}

/// The Jacobian of `w` at `x` by central differences of step 1e-5, in double precision.
fn central_differences(w: &ThinPlateSpline, x: Vec3) -> DMat3 {
    let (h, x) = (1e-5, x.as_dvec3());
    let column = |k: usize| {
        let mut e = DVec3::ZERO;
        e[k] = h;
        (w.eval_f64(x + e) - w.eval_f64(x - e)) / (2.0 * h)
    };
    DMat3::from_cols(column(0), column(1), column(2))
}

fn strict() -> TpsParams {
    TpsParams::default().affine_regularization(AffineRegularization::Reject)
}

proptest! {
    #[test]
    fn the_spline_interpolates_its_control_points(seed in any::<u64>(), n in 5usize..40) {
        let mut g = rng::rng_from_seed(seed);
        let s = random_points(&mut g, n, 2.0);
        let q: Vec<Vec3> = s.iter().map(|p| *p + Vec3::new(g.random(), g.random(), g.random()) * 0.3).collect();
        let w = ThinPlateSpline::fit(&s, &q, &strict()).unwrap();
        for (a, b) in s.iter().zip(&q) {
            let err = w.eval_f64(a.as_dvec3()).distance(b.as_dvec3());
            prop_assert!(err <= 1e-9 * (1.0 + b.as_dvec3().length()), "residual {err}");
        }
    }

    #[test]
    fn affine_maps_are_reproduced_with_zero_kernel_weights(seed in any::<u64>(), n in 5usize..30) {
        let mut g = rng::rng_from_seed(seed);
        let s = random_points(&mut g, n, 1.0);
        let m = Mat3::from_cols_array(&[1.2, 0.1, -0.2, 0.05, 0.9, 0.1, 0.3, -0.1, 1.1]);
        let t = Vec3::new(0.5, -0.25, 2.0);
        let q: Vec<Vec3> = s.iter().map(|p| m * *p + t).collect();
        let w = ThinPlateSpline::fit(&s, &q, &strict()).unwrap();
        // Zero but for the f32 rounding of the targets: the fit is linear in them, so the
        // kernel weights are those of the spline through the rounding residuals alone
        // (which, among close points, can reach 1e-5).
        let exact = |p: &Vec3| m.as_dmat3() * p.as_dvec3() + t.as_dvec3();
        let residuals: Vec<Vec3> =
            s.iter().zip(&q).map(|(p, qi)| (qi.as_dvec3() - exact(p)).as_vec3()).collect();
        let rounding = ThinPlateSpline::fit(&s, &residuals, &strict()).unwrap();
        for (wi, ri) in w.weights().iter().zip(rounding.weights()) {
            prop_assert!((*wi - *ri).length() < 1e-8 + 1e-6 * ri.length(), "kernel weight {wi}, rounding's {ri}");
        }
        for x in random_points(&mut g, 20, 3.0) {
            prop_assert!((w.eval(x) - (m * x + t)).length() < 1e-4);
        }
    }

    #[test]
    fn bending_energy_is_minimal_among_interpolants(seed in any::<u64>(), n in 5usize..20, extra in 1usize..6) {
        let mut g = rng::rng_from_seed(seed);
        let s = random_points(&mut g, n, 1.0);
        let q: Vec<Vec3> = s.iter().map(|p| *p + Vec3::new(g.random(), g.random(), g.random()) * 0.2).collect();
        let minimal = ThinPlateSpline::fit(&s, &q, &strict()).unwrap();
        // Another interpolant of the same data: also pass through extra points with
        // arbitrary targets.
        let mut s2 = s.clone();
        let mut q2 = q.clone();
        for p in random_points(&mut g, extra, 1.0) {
            s2.push(p);
            q2.push(p + Vec3::new(g.random(), g.random(), g.random()) * 0.5);
        }
        let other = ThinPlateSpline::fit(&s2, &q2, &strict()).unwrap();
        let (e0, e1) = (minimal.bending_energy(), other.bending_energy());
        prop_assert!(e0 >= -1e-9, "energy {e0} must be non-negative");
        prop_assert!(e0 <= e1 + 1e-9 * e1.abs().max(1.0), "{e0} > {e1}");
    }
}

/// `Σ |W(sᵢ) − qᵢ|²` of a fitted spline.
fn squared_residual(w: &ThinPlateSpline, s: &[Vec3], q: &[Vec3]) -> f64 {
    s.iter()
        .zip(q)
        .map(|(a, b)| w.eval_f64(a.as_dvec3()).distance_squared(b.as_dvec3()))
        .sum()
}

proptest! {
    #[test]
    fn smoothing_minimizes_residual_plus_lambda_times_bending(seed in any::<u64>(), n in 6usize..30) {
        let mut g = rng::rng_from_seed(seed);
        let s = random_points(&mut g, n, 1.0);
        let q: Vec<Vec3> = s.iter().map(|p| *p + Vec3::new(g.random(), g.random(), g.random()) * 0.2).collect();
        let fit = |lambda: f64| ThinPlateSpline::fit(&s, &q, &strict().smoothing(lambda)).unwrap();
        let lambdas = [0.0, 0.01, 0.1, 1.0, 10.0];
        let fits: Vec<ThinPlateSpline> = lambdas.iter().map(|&l| fit(l)).collect();
        let objective = |w: &ThinPlateSpline, lambda: f64| squared_residual(w, &s, &q) + lambda * w.bending_energy();
        for (i, &lambda) in lambdas.iter().enumerate() {
            let own = objective(&fits[i], lambda);
            prop_assert!(fits[i].bending_energy() >= -1e-9);
            // Every other spline of the same centres (the other λ's fits) does no better.
            for other in &fits {
                let theirs = objective(other, lambda);
                prop_assert!(own <= theirs + 1e-9 * theirs.max(1.0), "λ {lambda}: {own} > {theirs}");
            }
            if i > 0 {
                let (prev, cur) = (&fits[i - 1], &fits[i]);
                prop_assert!(squared_residual(cur, &s, &q) >= squared_residual(prev, &s, &q) - 1e-9);
                prop_assert!(cur.bending_energy() <= prev.bending_energy() + 1e-9);
            }
        }
    }
}

/// From 512 unknowns up the system goes to the blocked LU: its splines must interpolate, keep
/// the side conditions `Σ wᵢ = 0`, `Σ wᵢ sᵢᵀ = 0`, and reproduce affine maps, like the small
/// ones above. A flat control set (every height field's patch) takes the regularized affine
/// rows through the same solver.
#[test]
fn large_systems_interpolate_and_keep_the_side_conditions() {
    let mut g = rng::rng_from_seed(5);
    let solid = random_points(&mut g, 700, 2.0);
    let flat: Vec<Vec3> = random_points(&mut g, 600, 2.0)
        .into_iter()
        .map(|p| p * Vec3::new(1.0, 1.0, 0.0))
        .collect();
    for (s, params) in [(&solid, strict()), (&flat, TpsParams::default())] {
        let q: Vec<Vec3> = s
            .iter()
            .map(|p| *p + Vec3::new(g.random(), g.random(), g.random()) * 0.3)
            .collect();
        let w = ThinPlateSpline::fit(s, &q, &params).unwrap();
        for (a, b) in s.iter().zip(&q) {
            let err = w.eval_f64(a.as_dvec3()).distance(b.as_dvec3());
            assert!(err <= 1e-8, "{} points: residual {err}", s.len());
        }
        let total: DVec3 = w.weights().iter().sum();
        let moment = w
            .weights()
            .iter()
            .zip(w.centers())
            .fold(DMat3::ZERO, |m, (wi, si)| {
                m + DMat3::from_cols(*wi * si.x, *wi * si.y, *wi * si.z)
            });
        let scale: f64 = w.weights().iter().map(|wi| wi.length()).sum();
        assert!(total.length() <= 1e-9 * scale, "Σ w = {total}");
        assert!(
            moment
                .abs()
                .to_cols_array()
                .iter()
                .all(|v| *v <= 1e-9 * scale)
        );
    }
    let m = Mat3::from_cols_array(&[1.2, 0.1, -0.2, 0.05, 0.9, 0.1, 0.3, -0.1, 1.1]);
    let t = Vec3::new(0.5, -0.25, 2.0);
    let q: Vec<Vec3> = solid.iter().map(|p| m * *p + t).collect();
    let w = ThinPlateSpline::fit(&solid, &q, &strict()).unwrap();
    assert!(w.weights().iter().all(|wi| wi.length() < 1e-5));
}

#[test]
fn heavy_smoothing_tends_to_the_least_squares_affine_map() {
    let mut g = rng::rng_from_seed(11);
    let s = random_points(&mut g, 30, 1.0);
    let q: Vec<Vec3> = s
        .iter()
        .map(|p| {
            Mat3::from_cols_array(&[1.1, 0.1, 0.0, -0.2, 0.9, 0.1, 0.0, 0.3, 1.2]) * *p
                + Vec3::new(g.random(), g.random(), g.random()) * 0.2
        })
        .collect();
    // Independent reference: normal equations of the 4-parameter affine fit per coordinate.
    let rows: Vec<[f64; 4]> = s
        .iter()
        .map(|p| [1.0, f64::from(p.x), f64::from(p.y), f64::from(p.z)])
        .collect();
    let ata = nalgebra::Matrix4::from_fn(|i, j| rows.iter().map(|r| r[i] * r[j]).sum::<f64>());
    let inverse = ata.try_inverse().unwrap();
    let coefficients: Vec<nalgebra::Vector4<f64>> = (0..3)
        .map(|c| {
            let atb = nalgebra::Vector4::from_fn(|i, _| {
                rows.iter()
                    .zip(&q)
                    .map(|(r, t)| r[i] * f64::from(t[c]))
                    .sum::<f64>()
            });
            inverse * atb
        })
        .collect();
    let w = ThinPlateSpline::fit(&s, &q, &strict().smoothing(1e7)).unwrap();
    for x in random_points(&mut g, 20, 1.5) {
        let r = [1.0, f64::from(x.x), f64::from(x.y), f64::from(x.z)];
        let reference = DVec3::from_array(std::array::from_fn(|c| {
            (0..4).map(|i| coefficients[c][i] * r[i]).sum::<f64>()
        }));
        let err = w.eval_f64(x.as_dvec3()).distance(reference);
        assert!(err < 1e-4, "{err}");
    }
}

#[test]
fn jacobian_matches_central_differences() {
    let mut g = rng::rng_from_seed(3);
    let s = random_points(&mut g, 25, 1.0);
    let q = nudged(&mut g, &s, 0.3);
    let w = ThinPlateSpline::fit(&s, &q, &strict()).unwrap();
    for x in random_points(&mut g, 50, 1.2) {
        let diff = (w.jacobian(x) - central_differences(&w, x))
            .to_cols_array()
            .iter()
            .map(|v| v.abs())
            .fold(0.0, f64::max);
        assert!(
            diff < 1e-6,
            "Jacobian differs from finite differences by {diff}"
        );
    }
    // At a control point the singular term is dropped: the result is finite.
    assert!(
        w.jacobian(s[0])
            .to_cols_array()
            .iter()
            .all(|v| v.is_finite())
    );
}

#[test]
fn folded_points_are_where_finite_differences_turn_space_inside_out() {
    let mut g = rng::rng_from_seed(11);
    // Targets far from their sources (up to 1.5 on a cube of side 2) fold space here and
    // there; the probes are classified by the determinant of central differences.
    let s = random_points(&mut g, 20, 1.0);
    let w = ThinPlateSpline::fit(&s, &nudged(&mut g, &s, 1.5), &strict()).unwrap();
    let probes = random_points(&mut g, 2000, 1.2);
    let folded = w.folded_points(&probes);
    let (mut inside_out, mut compared) = (0, 0);
    for (i, x) in probes.iter().enumerate() {
        let det = central_differences(&w, *x).determinant();
        // Near a zero of the determinant the two may disagree by rounding.
        if det.abs() > 1e-3 {
            compared += 1;
            assert_eq!(folded.contains(&i), det < 0.0, "probe {x}: det {det}");
            inside_out += usize::from(det < 0.0);
        }
    }
    assert!(compared > 1900, "{compared}");
    assert!(
        inside_out > 20 && inside_out < 1900,
        "{inside_out} folded probes"
    );
    // A gentle warp (targets within 0.05) folds nothing.
    let w = ThinPlateSpline::fit(&s, &nudged(&mut g, &s, 0.05), &strict()).unwrap();
    assert!(w.folded_points(&probes).is_empty());
}

#[test]
fn normals_rotate_exactly_under_a_rotation() {
    let mut g = rng::rng_from_seed(4);
    let s = random_points(&mut g, 20, 1.0);
    let r = Mat3::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.7);
    let q: Vec<Vec3> = s.iter().map(|p| r * *p).collect();
    let w = ThinPlateSpline::fit(&s, &q, &strict()).unwrap();
    for x in random_points(&mut g, 30, 1.0) {
        let n = random_points(&mut g, 1, 1.0)[0].normalize();
        let turned = w.transform_normal(x, n);
        assert!((turned - r * n).length() < 1e-5, "{turned} vs {}", r * n);
    }
    let (moved, normals) = w.warp(&s, Some(&vec![Vec3::Z; s.len()]));
    assert!(moved.iter().zip(&q).all(|(a, b)| a.distance(*b) < 1e-5));
    assert!(
        normals
            .unwrap()
            .iter()
            .all(|n| (*n - r * Vec3::Z).length() < 1e-5)
    );
}

#[test]
fn a_spline_built_from_its_terms_is_the_fitted_one_and_bad_terms_are_errors() {
    let mut g = rng::rng_from_seed(11);
    let sources: Vec<Vec3> = (0..40)
        .map(|_| Vec3::new(g.random(), g.random(), g.random()))
        .collect();
    let targets: Vec<Vec3> = (sources.iter())
        .map(|p| *p + 0.1 * Vec3::new(p.y, p.z, p.x).sin())
        .collect();
    let fitted = ThinPlateSpline::fit(&sources, &targets, &TpsParams::default()).unwrap();
    let (c, a) = fitted.affine();
    let (centers, weights) = (fitted.centers().to_vec(), fitted.weights().to_vec());
    let built = |centers: Vec<DVec3>, weights: Vec<DVec3>, c: DVec3, a: DMat3| {
        ThinPlateSpline::from_terms(centers, weights, c, a)
    };
    let again = built(centers.clone(), weights.clone(), c, a).unwrap();
    for p in &sources {
        assert_eq!(again.eval(*p), fitted.eval(*p));
        assert_eq!(again.jacobian(*p), fitted.jacobian(*p));
    }
    let uneven = built(centers.clone(), weights[1..].to_vec(), c, a);
    assert!(matches!(
        uneven,
        Err(TpsError::LengthMismatch {
            left: 40,
            right: 39,
            ..
        })
    ));
    let mut bad = weights.clone();
    bad[7].y = f64::NAN;
    let nan = built(centers.clone(), bad, c, a);
    assert!(matches!(
        nan,
        Err(TpsError::NonFinite {
            what: "weight",
            index: 7
        })
    ));
    let infinite = built(centers.clone(), weights.clone(), c, a * f64::INFINITY);
    assert!(matches!(infinite, Err(TpsError::NonFinite { .. })));
    let many = vec![DVec3::ZERO; tps_warp::MAX_CONTROL_POINTS + 1];
    let too_many = built(many.clone(), many, c, a);
    assert!(matches!(too_many, Err(TpsError::InvalidParameter { .. })));
}

#[test]
fn degenerate_control_points_are_errors_or_documented_regularization() {
    let square = [
        Vec3::ZERO,
        Vec3::X,
        Vec3::Y,
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.5, 0.5, 0.0),
    ];
    let bumped = [
        Vec3::ZERO,
        Vec3::X,
        Vec3::Y,
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.5, 0.5, 0.1),
    ];
    assert!(matches!(
        ThinPlateSpline::fit(&square, &bumped, &strict()),
        Err(TpsError::DegenerateControlPoints { rank: 2 })
    ));
    // Default: coplanar controls resolve toward the identity along the normal.
    let w = ThinPlateSpline::fit(&square, &bumped, &TpsParams::default()).unwrap();
    for (a, b) in square.iter().zip(&bumped) {
        assert!(w.eval(*a).distance(*b) < 1e-4);
    }
    // The undetermined affine direction (the plane's normal) is the identity's.
    let (_, a) = w.affine();
    assert!(
        (a * DVec3::Z - DVec3::Z).length() < 1e-6,
        "A·n = {}",
        a * DVec3::Z
    );
    let above = w.eval(Vec3::new(0.0, 0.0, 1.0));
    assert!(
        above.is_finite() && (above.z - 1.0).abs() < 1e-2,
        "off-plane offsets survive: {above}"
    );
    assert!(
        (w.transform_normal(Vec3::new(0.1, 0.1, 0.0), Vec3::Z)
            .length()
            - 1.0)
            .abs()
            < 1e-6
    );

    // One pair: a translation by default, an error when strict.
    assert!(matches!(
        ThinPlateSpline::fit(&[Vec3::ZERO], &[Vec3::X], &strict()),
        Err(TpsError::DegenerateControlPoints { rank: 0 })
    ));
    let t = ThinPlateSpline::fit(&[Vec3::ZERO], &[Vec3::X], &TpsParams::default()).unwrap();
    assert!((t.eval(Vec3::new(3.0, 2.0, 1.0)) - Vec3::new(4.0, 2.0, 1.0)).length() < 1e-4);

    // Coincident sources with different targets; identical pairs are merged.
    let dup_s = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::X];
    let dup_q = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE];
    assert!(matches!(
        ThinPlateSpline::fit(&dup_s, &dup_q, &strict()),
        Err(TpsError::DuplicateControlPoints {
            first: 1,
            second: 4
        })
    ));
    let same_q = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::X];
    assert_eq!(
        ThinPlateSpline::fit(&dup_s, &same_q, &strict())
            .unwrap()
            .centers()
            .len(),
        4
    );

    // NaN, empty, mismatched.
    assert!(matches!(
        ThinPlateSpline::fit(&[Vec3::NAN], &[Vec3::X], &strict()),
        Err(TpsError::NonFinite { .. })
    ));
    assert!(matches!(
        ThinPlateSpline::fit(&[], &[], &strict()),
        Err(TpsError::EmptyInput { .. })
    ));
    assert!(matches!(
        ThinPlateSpline::fit(&[Vec3::X], &[], &strict()),
        Err(TpsError::LengthMismatch { .. })
    ));
    assert!(ThinPlateSpline::fit(&square, &bumped, &TpsParams::default().smoothing(-1.0)).is_err());
    // More pairs than the dense solve is meant for.
    let many: Vec<Vec3> = (0..=tps_warp::MAX_CONTROL_POINTS)
        .map(|i| Vec3::new(i as f32, (i % 7) as f32, (i % 5) as f32))
        .collect();
    assert!(matches!(
        ThinPlateSpline::fit(&many, &many, &strict()),
        Err(TpsError::InvalidParameter {
            name: "control points",
            ..
        })
    ));
}

// ------------------------------------------------------------ pairing

/// A bumpy sheet: `z = 0.1 sin(3x) cos(2y)`, normals from the gradient, variation from |z|.
fn sheet(g: &mut rng::SeededRng, n: usize) -> Vec<PairingPoint> {
    (0..n)
        .map(|_| {
            let (x, y) = (g.random_range(-1.0..1.0f32), g.random_range(-1.0..1.0f32));
            let z = 0.1 * (3.0 * x).sin() * (2.0 * y).cos();
            let dzdx = 0.3 * (3.0 * x).cos() * (2.0 * y).cos();
            let dzdy = -0.2 * (3.0 * x).sin() * (2.0 * y).sin();
            PairingPoint {
                position: Vec3::new(x, y, z),
                normal: Vec3::new(-dzdx, -dzdy, 1.0).normalize(),
                variation: 0.02 * z.abs() / 0.1,
            }
        })
        .collect()
}

#[test]
fn a_shifted_noisy_copy_is_paired_back_to_its_originals() {
    let mut g = rng::rng_from_seed(7);
    let q = sheet(&mut g, 200);
    let shift = Vec3::new(0.01, -0.008, 0.003);
    // S: the shifted noisy copy of Q (indices 0..200) plus 1800 distractors.
    let mut s: Vec<PairingPoint> = q
        .iter()
        .map(|p| PairingPoint {
            position: p.position + shift + Vec3::new(g.random(), g.random(), g.random()) * 0.002,
            ..*p
        })
        .collect();
    s.extend(sheet(&mut g, 1800).into_iter().map(|p| PairingPoint {
        position: p.position + Vec3::Z * 0.05,
        ..p
    }));
    let pairing = pair_points(&s, &q, &PairingParams::default().max_distance(0.2)).unwrap();
    let correct = pairing
        .pairs
        .iter()
        .filter(|p| p.source == p.target)
        .count();
    assert!(
        correct as f32 >= 0.95 * q.len() as f32,
        "{correct} of {} paired back",
        q.len()
    );
    // No source used twice.
    let mut used: Vec<usize> = pairing.pairs.iter().map(|p| p.source).collect();
    used.sort_unstable();
    used.dedup();
    assert_eq!(used.len(), pairing.pairs.len());
    assert!(pairing.cost.is_finite() && pairing.cost > 0.0);
}

/// Eq. 1 for the pairing's final pairs, from scratch: `c` of Eq. 2 plus `g` of Eq. 3 with
/// the neighbours (other targets within `3σ`, weights `θ`) found by brute force.
fn eq1_cost(
    sources: &[PairingPoint],
    targets: &[PairingPoint],
    params: &PairingParams,
    sigma: f32,
    pairs: &[(usize, usize)],
) -> f64 {
    let source_of = |q: usize| pairs.iter().find(|p| p.1 == q).map(|p| p.0);
    let mut total = 0.0f64;
    for &(s, q) in pairs {
        let (ps, pq) = (&sources[s], &targets[q]);
        let v = ps.position - pq.position;
        let c = params.w_p * v.length()
            + params.w_n * 0.5 * (1.0 - ps.normal.dot(pq.normal))
            + params.w_v * (ps.variation - pq.variation).powi(2);
        let (mut sum_w, mut sum_len, mut sum_dir) = (0.0f64, 0.0f64, DVec3::ZERO);
        for (r, t) in targets.iter().enumerate() {
            let d = t.position.distance(pq.position);
            let Some(u) = source_of(r).filter(|_| r != q && d <= 3.0 * sigma) else {
                continue;
            };
            let w = f64::from((-(d * d) / (sigma * sigma)).exp());
            let pair = (sources[u].position - t.position).as_dvec3();
            sum_w += w;
            sum_len += w * pair.length();
            sum_dir += w * pair;
        }
        let mut g = 0.0;
        if sum_w > 0.0 {
            g += f64::from(params.w_l) * (f64::from(v.length()) - sum_len / sum_w).abs();
            if let (Some(dir), Some(mean)) = (v.as_dvec3().try_normalize(), sum_dir.try_normalize())
            {
                g += 0.5 * f64::from(params.w_d) * (1.0 - mean.dot(dir));
            }
        }
        total += f64::from(c) + g;
    }
    total
}

/// The reported cost is Eq. 1 of the returned pairs, recomputed independently.
#[test]
fn the_reported_cost_is_eq1_of_the_pairs() {
    let mut g = rng::rng_from_seed(11);
    let q = sheet(&mut g, 150);
    let s: Vec<PairingPoint> = sheet(&mut g, 600)
        .into_iter()
        .map(|p| PairingPoint {
            position: p.position + Vec3::new(0.01, 0.0, 0.02),
            ..p
        })
        .collect();
    let sigma = 0.15;
    for max_distance in [f32::INFINITY, 0.2] {
        let params = PairingParams::default()
            .coherence_radius(sigma)
            .max_distance(max_distance);
        let pairing = pair_points(&s, &q, &params).unwrap();
        assert!(pairing.pairs.len() > 100, "{} pairs", pairing.pairs.len());
        let pairs: Vec<(usize, usize)> =
            pairing.pairs.iter().map(|p| (p.source, p.target)).collect();
        let want = eq1_cost(&s, &q, &params, sigma, &pairs);
        assert!(
            (pairing.cost - want).abs() <= 1e-4 * want,
            "reported {} against {want}",
            pairing.cost
        );
    }
}

#[test]
fn thresholds_and_opposite_normals_are_honoured() {
    let mut g = rng::rng_from_seed(8);
    let q = sheet(&mut g, 100);
    // Sources: exact copies with flipped normals, plus properly oriented points farther away.
    let mut s: Vec<PairingPoint> = q
        .iter()
        .map(|p| PairingPoint {
            normal: -p.normal,
            ..*p
        })
        .collect();
    s.extend(q.iter().map(|p| PairingPoint {
        position: p.position + Vec3::Z * 0.05,
        ..*p
    }));
    let params = PairingParams::default().max_distance(0.04);
    let pairing = pair_points(&s, &q, &params).unwrap();
    // Flipped copies are never paired; the correct ones are beyond max_distance.
    assert!(pairing.pairs.is_empty(), "{:?}", pairing.pairs);
    assert_eq!(pairing.unmatched_targets.len(), q.len());
    let params = PairingParams::default().max_distance(0.06);
    let pairing = pair_points(&s, &q, &params).unwrap();
    for p in &pairing.pairs {
        assert!(p.source >= q.len(), "a flipped normal was paired");
        assert!(s[p.source].position.distance(q[p.target].position) <= 0.06);
        assert!(s[p.source].normal.dot(q[p.target].normal) >= 0.0);
    }
    assert!(!pairing.pairs.is_empty());
}

#[test]
fn crossing_pairs_are_removed() {
    // Targets on a line; sources the same line lifted a little.
    let mut q: Vec<PairingPoint> = (0..10)
        .map(|i| PairingPoint {
            position: Vec3::new(i as f32 * 0.1, 0.0, 0.0),
            normal: Vec3::Z,
            variation: 0.0,
        })
        .collect();
    let mut s: Vec<PairingPoint> = q
        .iter()
        .map(|p| PairingPoint {
            position: p.position + Vec3::Y * 0.02,
            ..*p
        })
        .collect();
    // Target 4 (x = 0.4) has a distinctive variation that only a source at x = 0.47 shares,
    // and the source near target 5 sits at x = 0.43: the cheapest pairs reverse the order.
    q[4].variation = 0.5;
    s[4].position = Vec3::new(0.47, 0.02, 0.0);
    s[4].variation = 0.5;
    s[5].position = Vec3::new(0.43, 0.02, 0.0);
    let mut params = PairingParams::default().coherence_radius(0.15).rounds(0);
    params.remove_crossings = false;
    let raw = pair_points(&s, &q, &params).unwrap();
    let source_of = |pairing: &tps_warp::Pairing, t: usize| {
        pairing
            .pairs
            .iter()
            .find(|p| p.target == t)
            .map(|p| p.source)
    };
    assert_eq!(
        (source_of(&raw, 4), source_of(&raw, 5)),
        (Some(4), Some(5)),
        "setup: 0.4 → 0.47 and 0.5 → 0.43 cross"
    );
    params.remove_crossings = true;
    let clean = pair_points(&s, &q, &params).unwrap();
    assert_eq!(clean.removed_crossings, 1);
    for a in &clean.pairs {
        for b in &clean.pairs {
            if a.target != b.target && q[a.target].position.distance(q[b.target].position) < 0.45 {
                let ds = s[a.source].position - s[b.source].position;
                let dq = q[a.target].position - q[b.target].position;
                assert!(ds.dot(dq) > 0.0, "pairs {a:?} and {b:?} still cross");
            }
        }
    }
}

#[test]
fn pairing_is_deterministic_and_validates_input() {
    let mut g = rng::rng_from_seed(9);
    let q = sheet(&mut g, 80);
    let s = sheet(&mut g, 400);
    let a = pair_points(&s, &q, &PairingParams::default()).unwrap();
    let b = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| pair_points(&s, &q, &PairingParams::default()).unwrap());
    assert_eq!(a, b);
    assert!(pair_points(&[], &q, &PairingParams::default()).is_err());
    let mut bad = q.clone();
    bad[3].normal = Vec3::NAN;
    assert!(matches!(
        pair_points(&s, &bad, &PairingParams::default()),
        Err(TpsError::NonFinite { index: 3, .. })
    ));
    let mut params = PairingParams::default();
    params.w_v = -1.0;
    assert!(pair_points(&s, &q, &params).is_err());
    // A round is a function of the previous pairing alone: once one changes nothing, any
    // number of further rounds (which stop there) gives the same pairing. Sources just
    // above their targets settle at once. (On `s` and `q` above, rounds still change
    // pairs after 100 of them, so there every round runs.)
    let lifted = lifted(&q, 0.01);
    let rounds = |r: usize| pair_points(&lifted, &q, &PairingParams::default().rounds(r)).unwrap();
    let settled = rounds(1);
    assert_eq!(settled.pairs.len(), q.len());
    assert_eq!(settled, rounds(2));
    assert_eq!(settled, rounds(MAX_PAIRING_ROUNDS));
    assert!(matches!(
        pair_points(
            &s,
            &q,
            &PairingParams::default().rounds(MAX_PAIRING_ROUNDS + 1)
        ),
        Err(TpsError::InvalidParameter { name: "rounds", .. })
    ));
}

/// A column over the unit square of the xy plane, unbounded along z (paper 000's corners).
fn unit_column() -> Aabb {
    Aabb::new(Vec3::new(0.0, 0.0, f32::MIN), Vec3::new(1.0, 1.0, f32::MAX))
}

proptest! {
    #[test]
    fn anchors_reach_both_ends_of_the_height(seed in any::<u64>(), n in 0usize..200, per_region in 0usize..9, height in 0.0f32..2.0) {
        let mut g = rng::rng_from_seed(seed);
        // Points over a larger square, so some fall outside the column.
        let points: Vec<Vec3> = (0..n)
            .map(|_| Vec3::new(g.random_range(-0.5..1.5), g.random_range(-0.5..1.5), g.random_range(0.0..=height)))
            .collect();
        let column = unit_column();
        let inside: Vec<Vec3> = points.iter().copied().filter(|p| column.contains(*p)).collect();
        let anchors = anchors_in_regions(&points, &[column], per_region);
        prop_assert_eq!(anchors.len(), per_region.min(inside.len()));
        for a in &anchors {
            prop_assert!(inside.contains(a));
            prop_assert_eq!(anchors.iter().filter(|b| *b == a).count(), 1, "no anchor twice");
        }
        if anchors.is_empty() {
            return Ok(());
        }
        // The point nearest the centre in the plane is always one.
        let centre = Vec2::splat(0.5);
        let xy = |p: &Vec3| p.truncate().distance(centre);
        let nearest = inside.iter().copied().min_by(|a, b| xy(a).total_cmp(&xy(b)));
        prop_assert!(nearest.is_some_and(|p| anchors.iter().any(|a| xy(a) == xy(&p))));
        // With two or more, the lowest and the highest layer each give one.
        let low = inside.iter().map(|p| p.z).fold(f32::INFINITY, f32::min);
        let high = inside.iter().map(|p| p.z).fold(f32::NEG_INFINITY, f32::max);
        let layer = (high - low) / per_region as f32;
        if per_region >= 2 && layer > 0.0 {
            prop_assert!(anchors.iter().any(|a| a.z < low + layer), "{anchors:?}");
            prop_assert!(anchors.iter().any(|a| a.z >= high - layer), "{anchors:?}");
        }
    }
}

#[test]
fn asking_for_more_anchors_than_points_gives_every_point_inside() {
    let points: Vec<Vec3> = (0..30)
        .map(|i| Vec3::new(0.03 * i as f32, 0.5, 0.01 * (i % 7) as f32))
        .collect();
    let column = Aabb::new(Vec3::new(0.0, 0.0, f32::MIN), Vec3::new(0.5, 1.0, f32::MAX));
    let inside: Vec<Vec3> = points
        .iter()
        .copied()
        .filter(|p| column.contains(*p))
        .collect();
    for per_region in [inside.len(), inside.len() + 1, 1 << 40, usize::MAX] {
        let mut anchors = anchors_in_regions(&points, &[column], per_region);
        anchors.sort_by(|a, b| a.x.total_cmp(&b.x));
        assert_eq!(anchors, inside, "{per_region}");
    }
}

#[test]
fn anchors_of_a_flat_region_are_the_nearest_its_centre() {
    let mut g = rng::rng_from_seed(4);
    let points: Vec<Vec3> = (0..300)
        .map(|_| Vec3::new(g.random(), g.random(), 0.25))
        .collect();
    let anchors = anchors_in_regions(&points, &[unit_column()], 5);
    // Brute force: the five nearest the centre.
    let mut by_distance = points.clone();
    by_distance.sort_by(|a, b| {
        let d = |p: &Vec3| p.truncate().distance(Vec2::splat(0.5));
        d(a).total_cmp(&d(b))
    });
    let mut got = anchors.clone();
    got.sort_by(|a, b| a.x.total_cmp(&b.x));
    let mut expected = by_distance[..5].to_vec();
    expected.sort_by(|a, b| a.x.total_cmp(&b.x));
    assert_eq!(got, expected);
}

#[test]
fn anchors_through_the_height_hold_a_rough_corner_in_place() {
    // A rough height field over [0, 1]²: heights up to 0.3, at random, on a 40 × 40 grid.
    let mut g = rng::rng_from_seed(21);
    let field: Vec<Vec3> = (0..1600)
        .map(|i| {
            let (x, y) = ((i % 40) as f32 / 39.0, (i / 40) as f32 / 39.0);
            Vec3::new(x, y, g.random_range(0.0..0.3))
        })
        .collect();
    // Pairs along the left side among the valleys, each pulled up or down a little.
    let from: Vec<Vec3> = field
        .iter()
        .copied()
        .filter(|p| p.x < 0.15 && p.z < 0.05)
        .collect();
    let to: Vec<Vec3> = from
        .iter()
        .map(|p| *p + Vec3::Z * g.random_range(-0.02..0.02))
        .collect();
    let corners: Vec<Aabb> = [(0.7, 0.0), (0.7, 0.7)]
        .iter()
        .map(|&(x, y)| {
            Aabb::new(
                Vec3::new(x, y, f32::MIN),
                Vec3::new(x + 0.3, y + 0.3, f32::MAX),
            )
        })
        .collect();
    // How far the warp moves the corners' points with the given anchors.
    let corner_shift = |anchors: &[Vec3]| {
        let sources: Vec<Vec3> = from.iter().chain(anchors).copied().collect();
        let targets: Vec<Vec3> = to.iter().chain(anchors).copied().collect();
        let w = ThinPlateSpline::fit(&sources, &targets, &TpsParams::default()).unwrap();
        field
            .iter()
            .filter(|p| corners.iter().any(|c| c.contains(**p)))
            .map(|p| w.eval(*p).distance(*p))
            .fold(0.0f32, f32::max)
    };
    let spread = anchors_in_regions(&field, &corners, 4);
    // The same number of anchors per corner, all in its valleys (measured: the corners move
    // 0.005 against 0.024; the largest pull of a pair is 0.02).
    let valleys: Vec<Vec3> = corners
        .iter()
        .flat_map(|c| {
            let mut inside: Vec<Vec3> = field.iter().copied().filter(|p| c.contains(*p)).collect();
            inside.sort_by(|a, b| a.z.total_cmp(&b.z));
            inside.truncate(4);
            inside
        })
        .collect();
    let (spread_shift, valley_shift) = (corner_shift(&spread), corner_shift(&valleys));
    assert!(
        spread_shift < 0.5 * valley_shift && spread_shift < 0.01,
        "anchors through the height move the corners by {spread_shift}, in the valleys by {valley_shift}"
    );
}

#[test]
fn anchored_warp_stays_local() {
    let mut g = rng::rng_from_seed(10);
    let q = sheet(&mut g, 150);
    let s = lifted(&q, 0.02);
    // Anchor the four corners of a larger box, far from the pairs.
    let grid: Vec<Vec3> = (0..400)
        .map(|i| {
            Vec3::new(
                (i % 20) as f32 * 0.3 - 3.0,
                (i / 20) as f32 * 0.3 - 3.0,
                0.0,
            )
        })
        .collect();
    let corners: Vec<Aabb> = [(-3.0, -3.0), (2.4, -3.0), (-3.0, 2.4), (2.4, 2.4)]
        .iter()
        .map(|&(x, y)| Aabb::new(Vec3::new(x, y, -0.1), Vec3::new(x + 0.6, y + 0.6, 0.1)))
        .collect();
    let anchors = anchors_in_regions(&grid, &corners, 3);
    assert_eq!(anchors.len(), 12);
    let warp = pair_and_fit(
        &s,
        &q,
        &anchors,
        &PairingParams::default().max_distance(0.1),
        &TpsParams::default(),
    )
    .unwrap();
    for a in &anchors {
        assert!(warp.spline.eval(*a).distance(*a) < 1e-4, "anchors stay put");
    }
    for p in &warp.pairing.pairs {
        assert!(
            warp.spline
                .eval(s[p.source].position)
                .distance(q[p.target].position)
                < 1e-4
        );
    }
}
