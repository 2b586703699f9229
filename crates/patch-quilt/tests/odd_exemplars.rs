//! Odd exemplars and parameters: the synthesis either refuses them with a typed error or
//! produces a texture that keeps its contracts. Never a panic.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use glam::Vec3;
use patch_quilt::{
    GeometryTexture, Method, OutputSize, QuiltParams, UpAxis, WarpTargets, evaluate, quilt,
};
use pointset_core::{Aabb, PointSet, RunContext, rng::rng_from_seed};
use proptest::prelude::*;
use rand::RngExt;

/// How the exemplar's samples are laid out in (and around) a `w × h × 2t` box.
#[derive(Debug, Clone, Copy)]
enum Layout {
    /// Uniformly at random over the box grown by `pad` of its sides.
    Uniform,
    /// Every sample at the box's centre.
    Coincident,
    /// Three tight clusters.
    Clusters,
    /// One line across the box.
    Line,
    /// A regular grid over the box (no padding).
    Grid,
    /// Only in the box's lower-left tenth.
    Corner,
}

/// The exemplar's shape: layout, sample count, width, aspect (`h / w`), half-thickness,
/// padding fraction and which normals the samples get. Boxes far taller than wide have
/// their own tests: their fields are large, and the measure's are refused.
#[derive(Debug, Clone, Copy)]
struct Shape {
    layout: Layout,
    samples: usize,
    width: f32,
    aspect: f32,
    half_thickness: f32,
    pad: f32,
    normals: Vec3,
}

fn shape() -> impl Strategy<Value = Shape> {
    // Mostly exemplars that can be quilted, so that the output's contracts get checked.
    let layout = prop_oneof![
        5 => Just(Layout::Uniform),
        1 => Just(Layout::Coincident),
        1 => Just(Layout::Clusters),
        1 => Just(Layout::Line),
        1 => Just(Layout::Grid),
        1 => Just(Layout::Corner),
    ];
    let normals = prop_oneof![
        Just(Vec3::Z),
        Just(Vec3::NEG_Z),
        Just(Vec3::X),
        Just(Vec3::new(0.6, 0.0, 0.8)),
    ];
    (
        layout,
        16usize..300,
        -2.0f32..1.0,
        -0.5f32..0.5,
        -3.0f32..-0.3,
        0.05f32..0.5,
        normals,
    )
        .prop_map(|(layout, samples, w, a, t, pad, normals)| Shape {
            layout,
            samples,
            width: 10f32.powf(w),
            aspect: 10f32.powf(a),
            half_thickness: 10f32.powf(w + t),
            pad,
            normals,
        })
}

fn positions(s: &Shape, seed: u64) -> Vec<Vec3> {
    let mut g = rng_from_seed(seed);
    let (w, h, t, pad) = (s.width, s.width * s.aspect, s.half_thickness, s.pad);
    let centres = [
        Vec3::new(0.2 * w, 0.3 * h, 0.0),
        Vec3::new(0.7 * w, 0.5 * h, 0.0),
        Vec3::new(0.4 * w, 0.9 * h, 0.0),
    ];
    let side = (s.samples as f32).sqrt().ceil() as usize;
    (0..s.samples)
        .map(|i| match s.layout {
            Layout::Uniform => Vec3::new(
                g.random_range(-pad * w..w * (1.0 + pad)),
                g.random_range(-pad * h..h * (1.0 + pad)),
                g.random_range(-t..t),
            ),
            Layout::Coincident => Vec3::new(0.5 * w, 0.5 * h, 0.0),
            Layout::Clusters => {
                centres[i % 3]
                    + Vec3::new(
                        g.random_range(-0.01..0.01),
                        g.random_range(-0.01..0.01),
                        0.0,
                    )
            }
            Layout::Line => Vec3::new(g.random_range(-pad * w..w * (1.0 + pad)), 0.5 * h, 0.0),
            Layout::Grid => Vec3::new(
                (i % side) as f32 / side as f32 * w,
                (i / side) as f32 / side as f32 * h,
                0.0,
            ),
            Layout::Corner => Vec3::new(
                g.random_range(0.0..0.1 * w),
                g.random_range(0.0..0.1 * h),
                0.0,
            ),
        })
        .collect()
}

fn params() -> impl Strategy<Value = QuiltParams> {
    let method = prop_oneof![
        Just(Method::Full),
        Just(Method::SearchOnly),
        Just(Method::RandomPlacement)
    ];
    let targets = prop_oneof![Just(WarpTargets::Exact), Just(WarpTargets::SurfaceGap)];
    let output = prop_oneof![
        (0.1f32..2.0).prop_map(OutputSize::Scale),
        (0.05f32..2.0, 0.05f32..2.0).prop_map(|(a, b)| OutputSize::Absolute(a, b)),
    ];
    (
        (0.25f32..1.0, 0.01f32..1.0, 0.01f32..0.4, 8usize..24),
        (0.0f32..2.0, method, targets, 0usize..3),
        (1usize..20, 0usize..8, -1.0f32..1.0, output, any::<u64>()),
    )
        .prop_map(
            |(
                (patch, extra, overlap, nodes),
                (epsilon, method, targets, relax),
                (cluster, anchors, agreement, output, seed),
            )| {
                let mut p = QuiltParams::default()
                    .patch_size(patch)
                    .field_resolution(nodes)
                    .epsilon(epsilon)
                    .method(method)
                    .warp_targets(targets)
                    .relaxation_rounds(relax)
                    .cluster_points(cluster)
                    .normal_agreement(agreement)
                    .output(output)
                    .seed(seed);
                p.extra_width = extra;
                p.overlap = overlap;
                p.anchors_per_corner = anchors;
                p
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]
    #[test]
    fn odd_exemplars_are_refused_or_quilted_within_their_contracts(
        s in shape(),
        mut p in params(),
        seed in any::<u64>(),
    ) {
        // Absolute output sizes are drawn as multiples of the exemplar's width.
        if let OutputSize::Absolute(a, b) = p.output {
            p = p.output(OutputSize::Absolute(a * s.width, b * s.width * s.aspect));
        }
        let points = PointSet::new(positions(&s, seed))
            .unwrap()
            .with_normals(vec![s.normals; s.samples])
            .unwrap();
        let (w, h, t) = (s.width, s.width * s.aspect, s.half_thickness);
        let bounds = Aabb::new(Vec3::new(0.0, 0.0, -t), Vec3::new(w, h, t));
        let texture = match GeometryTexture::new(&points, bounds, UpAxis::Z) {
            Ok(texture) => texture,
            Err(e) => {
                prop_assert!(!e.to_string().is_empty());
                return Ok(());
            }
        };
        match quilt(&texture, &p, &mut RunContext::new(seed)) {
            Ok(out) => {
                let normals = out.points.normals().unwrap();
                let patch = out.points.attribute("patch").unwrap().values();
                for ((q, n), &k) in out.points.positions().iter().zip(normals).zip(patch) {
                    prop_assert!(q.is_finite() && out.bounds.contains(*q), "{q} outside {:?}", out.bounds);
                    prop_assert!((n.length() - 1.0).abs() < 1e-3, "normal {n} at {q}");
                    prop_assert!((k as usize) < out.placements.len());
                }
                prop_assert_eq!(out.stats.output_points, out.points.len());
                if let Err(e) = evaluate(&texture, &out, &p, 4) {
                    prop_assert!(!e.to_string().is_empty());
                }
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
    }
}
