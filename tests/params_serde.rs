//! The `serde` feature: every parameter type (and a fitted warp) survives a trip through
//! JSON unchanged, a
//! partial document fills the rest from `Default`, misspelt fields and unknown enum values
//! are refused by name, and unlimited thresholds (which JSON cannot write as numbers) come
//! back unlimited.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use geosynth::core::simplify::{SimplifiedNormals, SimplifyParams};
use geosynth::core::surface_sampling::{PointThinning, SampleNormals, SurfaceSampling};
use geosynth::mls::{ClusterParams, MlsParams, RelaxParams as MlsRelaxParams};
use geosynth::normals::EstimateNormals;
use geosynth::quilt::{Method, OutputSize, QuiltParams, WarpTargets};
use geosynth::reconstruct::FieldParams;
use geosynth::sample::{SampleSurface, ThinPoints};
use geosynth::sdf::{FarSigns, GridSpec, MeshSign, PointSign};
use geosynth::simplify::Simplify;
use geosynth::strays::LeaveOutStrays;
use geosynth::tps::{
    AffineRegularization, PairingParams, Table1Preset, ThinPlateSpline, TpsParams,
};
use geosynth::voxel::{MatcherKind, QualityParams, RelaxParams as VoxelRelaxParams, VoxelParams};
use geosynth::warp::Warp;
use glam::Vec3;
use proptest::prelude::*;
use serde::Serialize;
use serde::de::DeserializeOwned;

/// Writes `value` as JSON and reads it back.
fn round_trip<T: Serialize + DeserializeOwned>(value: &T) -> T {
    let text = serde_json::to_string(value).unwrap();
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e} reading back {text}"))
}

/// A finite number in a range wide enough to include invalid values: serde keeps what it
/// is given, and validation is a separate step.
fn number() -> impl Strategy<Value = f32> {
    -1e6f32..1e6
}

/// A pairing threshold: a number or unlimited.
fn threshold() -> impl Strategy<Value = f32> {
    prop_oneof![Just(f32::INFINITY), 0f32..10.0]
}

fn pairing() -> impl Strategy<Value = PairingParams> {
    (
        prop::array::uniform5(number()),
        prop::array::uniform3(threshold()),
        prop::option::of(number()),
        0usize..10,
        any::<bool>(),
    )
        .prop_map(|(w, t, coherence, rounds, crossings)| {
            let mut p = PairingParams::default()
                .weights(w)
                .max_distance(t[0])
                .max_normal_difference(t[1])
                .max_variation_difference(t[2])
                .rounds(rounds)
                .remove_crossings(crossings);
            p.coherence_radius = coherence;
            p
        })
}

fn output_size() -> impl Strategy<Value = OutputSize> {
    prop_oneof![
        (number(), number()).prop_map(|(w, h)| OutputSize::Absolute(w, h)),
        number().prop_map(OutputSize::Scale),
    ]
}

fn quilt_params() -> impl Strategy<Value = QuiltParams> {
    let lengths = prop::array::uniform8(number());
    let choices = (
        prop::sample::select(vec![
            Method::Full,
            Method::SearchOnly,
            Method::RandomPlacement,
        ]),
        prop::sample::select(vec![WarpTargets::Exact, WarpTargets::SurfaceGap]),
        prop::option::of(pairing()),
        output_size(),
    );
    let counts = (
        prop::array::uniform4(0usize..1000),
        any::<u64>(),
        prop::option::of((0usize..100, 0usize..100)),
        prop::option::of(prop::collection::vec((0usize..100, 0usize..100), 0..6)),
    );
    (lengths, choices, counts).prop_map(
        |(
            l,
            (method, targets, pairing, output),
            ([res, cluster, anchors, relax], seed, seed_patch, layout),
        )| {
            let mut p = QuiltParams::default()
                .patch_size(l[0])
                .extra_width(l[1])
                .overlap(l[2])
                .epsilon(l[3])
                .band(l[4])
                .pair_distance(l[5])
                .smoothing(l[6])
                .blend_reach(l[7])
                .anchors_per_corner(anchors);
            p.normal_agreement = l[0] / 1e6;
            p.clusters.max_variation = l[1].abs();
            (p.method, p.warp_targets, p.pairing, p.output) = (method, targets, pairing, output);
            (p.field_resolution, p.clusters.max_points) = (res, cluster);
            p.relaxation_rounds = relax;
            (p.seed, p.seed_patch, p.layout) = (seed, seed_patch, layout);
            p
        },
    )
}

proptest! {
    #[test]
    fn quilt_params_survive_json(p in quilt_params()) {
        prop_assert_eq!(round_trip(&p), p);
    }

    #[test]
    fn pairing_params_survive_json(p in pairing()) {
        prop_assert_eq!(round_trip(&p), p);
    }

    #[test]
    fn voxel_params_survive_json(
        dims in prop::array::uniform3(0usize..4096),
        levels in 0usize..8,
        block in 0usize..64,
        matcher in prop::sample::select(vec![
            MatcherKind::Tree, MatcherKind::Brute, MatcherKind::Fft, MatcherKind::Random,
        ]),
        range in prop::option::of(number()),
        seed in any::<u64>(),
    ) {
        let mut p = VoxelParams::default()
            .target_dims(dims)
            .levels(levels)
            .block(block)
            .matcher(matcher)
            .seed(seed);
        p.range = range;
        prop_assert_eq!(round_trip(&p), p);
    }

    #[test]
    fn field_and_mls_params_survive_json(
        resolution in 0usize..1000,
        kernel in prop::option::of(number()),
        lengths in prop::array::uniform4(number()),
        counts in prop::array::uniform3(0usize..100),
        mesh_sign in prop::sample::select(vec![MeshSign::PseudoNormal, MeshSign::WindingNumber]),
        point_sign in prop::sample::select(vec![PointSign::Implicit, PointSign::WindingNumber]),
    ) {
        let field = FieldParams::default()
            .resolution(resolution)
            .kernel(kernel)
            .mesh_sign(mesh_sign)
            .point_sign(point_sign)
            .margin(lengths[0])
            .band(lengths[1]);
        prop_assert_eq!(round_trip(&field), field);

        let mut mls = MlsParams::default()
            .kernel_spacing_factor(lengths[2])
            .support(lengths[3]);
        mls.kernel = kernel;
        [mls.min_neighbours, mls.max_iterations, mls.fallback_sign_samples] = counts;
        prop_assert_eq!(round_trip(&mls), mls);
    }
}

#[test]
fn every_parameter_type_reads_an_empty_document_as_its_default() {
    fn empty_is_default<T: DeserializeOwned + Default + PartialEq + std::fmt::Debug>() {
        assert_eq!(serde_json::from_str::<T>("{}").unwrap(), T::default());
    }
    empty_is_default::<QuiltParams>();
    empty_is_default::<PairingParams>();
    empty_is_default::<TpsParams>();
    empty_is_default::<MlsParams>();
    empty_is_default::<ClusterParams>();
    empty_is_default::<MlsRelaxParams>();
    empty_is_default::<FieldParams>();
    empty_is_default::<VoxelParams>();
    empty_is_default::<QualityParams>();
    empty_is_default::<VoxelRelaxParams>();
    empty_is_default::<EstimateNormals>();
    empty_is_default::<LeaveOutStrays>();
}

#[test]
fn the_remaining_types_survive_json() {
    let tps = TpsParams::default()
        .smoothing(0.25)
        .affine_regularization(AffineRegularization::TowardIdentity)
        .duplicate_tolerance(1e-6);
    assert_eq!(round_trip(&tps), tps);
    let clusters = ClusterParams::default().max_points(4).max_variation(0.2);
    assert_eq!(round_trip(&clusters), clusters);
    let relax = MlsRelaxParams::default()
        .iterations(3)
        .radius_factor(1.5)
        .step(0.125);
    assert_eq!(round_trip(&relax), relax);
    let quality = QualityParams::default().window(4).windows(9).seed(2);
    assert_eq!(round_trip(&quality), quality);
    let voxel_relax = VoxelRelaxParams::default()
        .weld_radius(0.5)
        .rings(1)
        .step(0.3);
    assert_eq!(round_trip(&voxel_relax), voxel_relax);
    let normals = EstimateNormals {
        neighbours: 20,
        up: Vec3::new(0.0, -1.0, 0.5),
    };
    assert_eq!(round_trip(&normals), normals);
    let partial: EstimateNormals = serde_json::from_str(r#"{ "up": [1.0, 0.0, 0.0] }"#).unwrap();
    assert_eq!(
        partial,
        EstimateNormals {
            up: Vec3::X,
            ..Default::default()
        }
    );
    // A fitted warp: the same spline back, moving points the same.
    let corner = |i: u32| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32);
    let sources: Vec<Vec3> = (0..8).map(corner).collect();
    let targets: Vec<Vec3> = (sources.iter().enumerate())
        .map(|(i, p)| *p + 0.1 * Vec3::new(i as f32, 1.0, -(i as f32) * 0.5).sin())
        .collect();
    let spline = ThinPlateSpline::fit(&sources, &targets, &TpsParams::default()).unwrap();
    let warp = Warp { spline };
    let back = round_trip(&warp);
    // serde_json reads a double back to within its last bit (exactly only with its
    // `float_roundtrip` feature).
    assert_eq!(back.spline.centers(), warp.spline.centers());
    for (p, q) in back.spline.weights().iter().zip(warp.spline.weights()) {
        assert!((*p - *q).abs().max_element() <= 1e-15 * q.abs().max_element().max(1.0));
    }
    for probe in [Vec3::new(0.3, 0.7, 0.2), Vec3::new(-2.0, 5.0, 1.5)] {
        let (a, b) = (
            back.spline.eval_f64(probe.as_dvec3()),
            warp.spline.eval_f64(probe.as_dvec3()),
        );
        assert!(a.distance(b) < 1e-13, "{a} against {b}");
    }
    let leave_out = LeaveOutStrays {
        kernel: Some(0.25),
        keep: true,
    };
    assert_eq!(round_trip(&leave_out), leave_out);
    for sampling in [
        SurfaceSampling::Uniform { count: 1000 },
        SurfaceSampling::PoissonDisk { spacing: 0.015 },
    ] {
        let stage = SampleSurface {
            sampling,
            normals: SampleNormals::Interpolated,
        };
        assert_eq!(round_trip(&stage), stage);
    }
    let written: SampleSurface =
        serde_json::from_str(r#"{ "sampling": { "poisson_disk": { "spacing": 0.5 } } }"#).unwrap();
    assert_eq!(
        written,
        SampleSurface {
            sampling: SurfaceSampling::PoissonDisk { spacing: 0.5 },
            normals: SampleNormals::Faces,
        }
    );
    for thinning in [
        PointThinning::PoissonDisk { spacing: 0.02 },
        PointThinning::PoissonDiskCount { count: 5000 },
        PointThinning::Random { count: 10 },
    ] {
        let stage = ThinPoints { thinning };
        assert_eq!(round_trip(&stage), stage);
    }
    let written: ThinPoints =
        serde_json::from_str(r#"{ "thinning": { "random": { "count": 7 } } }"#).unwrap();
    assert_eq!(written.thinning, PointThinning::Random { count: 7 });
    let simplify = Simplify {
        params: SimplifyParams {
            normals: SimplifiedNormals::Recompute,
            ..SimplifyParams::faces(500).max_error(0.25)
        },
    };
    assert_eq!(round_trip(&simplify), simplify);
    let written: SimplifiedNormals = serde_json::from_str(r#""recompute""#).unwrap();
    assert_eq!(written, SimplifiedNormals::Recompute);
    // Only the target is needed; the limits take their defaults.
    let written: SimplifyParams = serde_json::from_str(r#"{ "target_faces": 80 }"#).unwrap();
    assert_eq!(written, SimplifyParams::faces(80));
    let spec = GridSpec {
        dims: [3, 4, 5],
        origin: Vec3::new(-1.0, 0.5, 2.0),
        spacing: 0.125,
    };
    assert_eq!(round_trip(&spec), spec);
    for rule in [FarSigns::Nearest, FarSigns::RegionVote] {
        assert_eq!(round_trip(&rule), rule);
    }
    for preset in [
        Table1Preset::HeightField,
        Table1Preset::ChainMail,
        Table1Preset::Weave,
        Table1Preset::Flowers,
    ] {
        assert_eq!(round_trip(&preset), preset);
        let weights = PairingParams::table1(preset);
        assert_eq!(round_trip(&weights), weights);
    }
}

#[test]
fn a_partial_document_keeps_the_defaults_of_the_fields_it_omits() {
    let p: QuiltParams = serde_json::from_str(
        r#"{ "seed": 9, "method": "search_only", "warp_targets": "surface_gap",
             "output": { "absolute": [6.0, 3.5] } }"#,
    )
    .unwrap();
    let expected = QuiltParams::default()
        .seed(9)
        .method(Method::SearchOnly)
        .warp_targets(WarpTargets::SurfaceGap)
        .output(OutputSize::Absolute(6.0, 3.5));
    assert_eq!(p, expected);
    // A nested object fills from its own type's defaults (serde's rule), which for the
    // quilt's clusters are not the quilt's: the CLI merges documents into its defaults
    // instead (`geosynth quilt --params`).
    let p: QuiltParams = serde_json::from_str(r#"{ "clusters": { "max_points": 4 } }"#).unwrap();
    assert_eq!(p.clusters, ClusterParams::default().max_points(4));
    let v: VoxelParams =
        serde_json::from_str(r#"{ "matcher": "fft", "target_dims": [32, 32, 16] }"#).unwrap();
    assert_eq!(
        v,
        VoxelParams::default()
            .matcher(MatcherKind::Fft)
            .target_dims([32, 32, 16])
    );
}

#[test]
fn misspelt_fields_and_unknown_values_are_refused_by_name() {
    let e = serde_json::from_str::<QuiltParams>(r#"{ "patch_sise": 0.3 }"#).unwrap_err();
    assert!(e.to_string().contains("patch_sise"), "{e}");
    let e = serde_json::from_str::<QuiltParams>(r#"{ "method": "fast" }"#).unwrap_err();
    assert!(e.to_string().contains("fast"), "{e}");
    let e = serde_json::from_str::<VoxelParams>(r#"{ "levels": -1 }"#).unwrap_err();
    assert!(e.to_string().contains("-1"), "{e}");
    let e = serde_json::from_str::<PairingParams>(r#"{ "w_x": 1 }"#).unwrap_err();
    assert!(e.to_string().contains("w_x"), "{e}");
    let e = serde_json::from_str::<FieldParams>(r#"{ "mesh_sign": "winding" }"#).unwrap_err();
    assert!(e.to_string().contains("winding"), "{e}");
    // A warp's spline is checked as `ThinPlateSpline::from_terms` checks it.
    let affine = r#""translation": [0, 0, 0], "linear": [1, 0, 0, 0, 1, 0, 0, 0, 1]"#;
    let spline = |terms: &str| format!(r#"{{ "spline": {{ {terms}, {affine} }} }}"#);
    let shift = spline(r#""centers": [], "weights": []"#).replace("[0, 0, 0]", "[1, 0, 0]");
    let moved = serde_json::from_str::<Warp>(&shift).unwrap();
    assert_eq!(moved.spline.eval(Vec3::ZERO), Vec3::X);
    let uneven = spline(r#""centers": [[0, 0, 0], [1, 0, 0]], "weights": [[0, 0, 0]]"#);
    let e = serde_json::from_str::<Warp>(&uneven).unwrap_err();
    assert!(e.to_string().contains("centers and weights: 2 vs 1"), "{e}");
    let extra = spline(r#""centers": [], "weights": [], "degree": 3"#);
    let e = serde_json::from_str::<Warp>(&extra).unwrap_err();
    assert!(e.to_string().contains("degree"), "{e}");
}

#[test]
fn unlimited_thresholds_are_written_as_null_and_read_back_unlimited() {
    let p = PairingParams::default();
    assert!(p.max_distance.is_infinite() && p.max_variation_difference.is_infinite());
    let json = serde_json::to_value(&p).unwrap();
    assert!(json["max_distance"].is_null(), "{json}");
    assert!(json["max_variation_difference"].is_null(), "{json}");
    assert_eq!(json["max_normal_difference"], 0.5);
    let back: PairingParams = serde_json::from_value(json).unwrap();
    assert_eq!(back, p);
    // Omitted is the default (unlimited) too; a number is a number.
    let q: PairingParams = serde_json::from_str(r#"{ "max_distance": 0.25 }"#).unwrap();
    assert_eq!(q.max_distance, 0.25);
    assert!(q.max_variation_difference.is_infinite());
}

#[test]
fn read_parameters_are_validated_like_built_ones() {
    /// Reads `$json` as `$type` (which must succeed: serde checks kinds, not ranges) and
    /// asserts that its `validate()` refuses it.
    macro_rules! refused {
        ($type:ty, $json:expr) => {
            let read: $type = serde_json::from_str($json).unwrap();
            assert!(read.validate().is_err(), "{}", $json);
        };
    }
    refused!(QuiltParams, r#"{ "epsilon": -1 }"#);
    refused!(VoxelParams, r#"{ "block": 12 }"#);
    refused!(QualityParams, r#"{ "window": 6 }"#);
    refused!(VoxelRelaxParams, r#"{ "step": 2 }"#);
    refused!(TpsParams, r#"{ "duplicate_tolerance": -1 }"#);
    refused!(MlsRelaxParams, r#"{ "step": 0 }"#);
    refused!(ClusterParams, r#"{ "max_points": 0 }"#);
    refused!(FieldParams, r#"{ "kernel": 0 }"#);
    let good: QuiltParams =
        serde_json::from_str(r#"{ "epsilon": 0.3, "pairing": { "w_n": 1 } }"#).unwrap();
    assert!(good.validate().is_ok());
}
