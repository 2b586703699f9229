//! Behaviour of the whole synthesis on height-field textures with known answers.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use glam::{Vec2, Vec3};
use patch_quilt::{
    GeometryTexture, Method, OutputSize, QualityMeasure, QuiltError, QuiltParams, UpAxis, evaluate,
    quilt,
};
use pointset_core::testdata::shared_data;
use pointset_core::{Aabb, HeightField, PointSet, RunContext};
use rand::RngExt;

fn texture(f: impl Fn(f32, f32) -> f32, n: usize, spacing: f32) -> GeometryTexture {
    let h: Vec<f32> = (0..n * n)
        .map(|i| f((i % n) as f32 * spacing, (i / n) as f32 * spacing))
        .collect();
    GeometryTexture::from_heightfield(&HeightField::new(n, n, h).unwrap(), spacing, 1.0, n / 6)
        .unwrap()
}

/// A 48 × 48 height field of skewed waves, 0.05 apart.
fn wavy_texture() -> GeometryTexture {
    texture(
        |x, y| 0.1 * (3.0 * x).sin() * (2.0 * y + 0.5 * x).cos(),
        48,
        0.05,
    )
}

fn small_params() -> QuiltParams {
    QuiltParams::default()
        .field_resolution(24)
        .output(OutputSize::Scale(1.6))
}

#[test]
fn output_is_identical_with_one_and_two_threads() {
    let t = wavy_texture();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| quilt(&t, &small_params().seed(5), &mut RunContext::new(5)).unwrap())
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(a.points, b.points);
    assert_eq!(a.placements, b.placements);
    let c = quilt(&t, &small_params().seed(6), &mut RunContext::new(6)).unwrap();
    assert_ne!(a.points, c.points, "another seed gives another texture");
}

#[test]
fn the_result_does_not_depend_on_the_unit_of_length() {
    // The same exemplar in other units: scaled by powers of two, which floating point
    // represents exactly, so every length of the run scales exactly too. The search and
    // the pairing mix lengths with unitless terms; measured in units of the box they keep
    // their balance, and the output is the same texture, scaled.
    let t = wavy_texture();
    let params = small_params().seed(5);
    let reference = quilt(&t, &params, &mut RunContext::new(5)).unwrap();
    for factor in [4.0f32, 0.5] {
        let set = t.canonical_points();
        let scaled = PointSet::new(set.positions().iter().map(|p| *p * factor).collect())
            .and_then(|s| s.with_normals(set.normals().unwrap().to_vec()))
            .unwrap();
        let b = t.canonical_bounds();
        let texture = GeometryTexture::new(
            &scaled,
            Aabb::new(b.min * factor, b.max * factor),
            UpAxis::Z,
        )
        .unwrap();
        let out = quilt(&texture, &params, &mut RunContext::new(5)).unwrap();
        assert_eq!(out.sources(), reference.sources(), "factor {factor}");
        assert_eq!(out.points.len(), reference.points.len(), "factor {factor}");
        let expected: Vec<Vec3> = reference
            .points
            .positions()
            .iter()
            .map(|p| *p * factor)
            .collect();
        assert_eq!(
            out.points.positions(),
            expected.as_slice(),
            "factor {factor}"
        );
        assert_eq!(out.points.normals(), reference.points.normals());
    }
}

#[test]
fn a_flat_plane_stays_flat_and_whole() {
    let t = texture(|_, _| 0.0, 48, 0.05);
    let out = quilt(&t, &small_params(), &mut RunContext::new(1)).unwrap();
    let normals = out.points.normals().unwrap();
    for (p, n) in out.points.positions().iter().zip(normals) {
        assert!(p.z.abs() < 1e-4, "off the plane: {p}");
        assert!(n.angle_between(Vec3::Z).to_degrees() < 1.0, "normal {n}");
    }
    let q = evaluate(&t, &out, &small_params(), 16).unwrap();
    // A plane has no relief: its window errors are noise over noise, and the report says so.
    assert!(q.featureless_exemplar, "{q:?}");
    assert!(
        q.largest_empty_disc <= 1.5 * q.exemplar_largest_empty_disc,
        "hole of radius {} (exemplar {})",
        q.largest_empty_disc,
        q.exemplar_largest_empty_disc
    );
}

/// `n` points of the plane z = 0 drawn at random over [-0.6, 2.6]², all with `normal`: a
/// sheet for a box [0, 2]² with padding.
fn random_sheet(seed: u64, n: usize, normal: Vec3) -> PointSet {
    let mut g = pointset_core::rng::rng_from_seed(seed);
    let positions: Vec<Vec3> = (0..n)
        .map(|_| Vec3::new(g.random_range(-0.6..2.6), g.random_range(-0.6..2.6), 0.0))
        .collect();
    PointSet::new(positions)
        .unwrap()
        .with_normals(vec![normal; n])
        .unwrap()
}

#[test]
fn relaxation_evens_the_spacing_inside_the_box_and_keeps_orientation() {
    // The underside of a sheet, sampled at random: some samples have too few neighbours for
    // the MLS projection. The relaxed output must keep every normal pointing down, as the
    // exemplar's do (an unprojectable point once fell back to +Z), and stay in the output
    // box (relaxed after trimming, the border's points were pushed out of it).
    let set = random_sheet(11, 2500, Vec3::NEG_Z);
    let bounds = Aabb::new(Vec3::new(0.0, 0.0, -0.1), Vec3::new(2.0, 2.0, 0.1));
    let t = GeometryTexture::new(&set, bounds, UpAxis::Z).unwrap();
    let params = small_params().relaxation_rounds(2);
    let out = quilt(&t, &params, &mut RunContext::new(2)).unwrap();
    let (before, after) = out.stats.relaxation_spread.unwrap();
    assert!(after < 0.8 * before, "spread {before} -> {after}");
    for (p, n) in out
        .points
        .positions()
        .iter()
        .zip(out.points.normals().unwrap())
    {
        assert!(n.z < -0.99, "normal {n} at {p}");
        assert!(out.bounds.contains(*p), "{p} outside {:?}", out.bounds);
    }
}

#[test]
fn the_quality_measure_refuses_a_field_it_cannot_hold() {
    // A sheet in a box 40 times taller than wide: `D(T_in)` has about a million nodes, which
    // the synthesis handles, but the measure's field 4 times finer would have 88 million.
    let set = random_sheet(4, 2000, Vec3::Z);
    let tall = Aabb::new(Vec3::new(0.0, 0.0, -40.0), Vec3::new(2.0, 2.0, 40.0));
    let t = GeometryTexture::new(&set, tall, UpAxis::Z).unwrap();
    let params = QuiltParams::default().field_resolution(32);
    let refused = QualityMeasure::new(&t, &params).err().unwrap();
    assert!(
        matches!(
            refused,
            QuiltError::InvalidParameter {
                name: "field_resolution",
                ..
            }
        ),
        "{refused}"
    );
    assert!(
        refused.to_string().contains("lower field_resolution"),
        "{refused}"
    );
}

/// Dominant period along x of a height field sampled from points (autocorrelation peak).
fn period_along_x(points: &[Vec3], lo: Vec2, hi: Vec2, cell: f32) -> f32 {
    let n = ((hi - lo) / cell).as_uvec2();
    let (nx, ny) = (n.x as usize, n.y as usize);
    let (mut sum, mut count) = (vec![0.0f32; nx * ny], vec![0u32; nx * ny]);
    for p in points {
        let c = ((p.truncate() - lo) / cell).as_ivec2();
        if c.x >= 0 && c.y >= 0 && (c.x as usize) < nx && (c.y as usize) < ny {
            sum[c.y as usize * nx + c.x as usize] += p.z;
            count[c.y as usize * nx + c.x as usize] += 1;
        }
    }
    let h: Vec<Option<f32>> = sum
        .iter()
        .zip(&count)
        .map(|(s, &c)| (c > 0).then(|| s / c as f32))
        .collect();
    // Autocorrelation over cells that both hold points.
    let corr = |lag: usize| -> f32 {
        let (mut acc, mut n) = (0.0, 0);
        for y in 0..ny {
            for x in 0..nx - lag {
                if let (Some(a), Some(b)) = (h[y * nx + x], h[y * nx + x + lag]) {
                    acc += a * b;
                    n += 1;
                }
            }
        }
        acc / n.max(1) as f32
    };
    // The first positive local maximum after the first negative correlation is the period.
    let values: Vec<f32> = (0..nx / 2).map(corr).collect();
    let negative = (1..values.len()).find(|&i| values[i] < 0.0).unwrap();
    let peak = (negative..values.len() - 1)
        .find(|&i| values[i] > 0.0 && values[i] >= values[i - 1] && values[i] >= values[i + 1])
        .unwrap();
    peak as f32 * cell
}

#[test]
fn a_lattice_of_bumps_keeps_its_spacing() {
    let lambda = 0.5f32;
    let f = move |x: f32, y: f32| {
        0.08 * (std::f32::consts::TAU * x / lambda).sin()
            * (std::f32::consts::TAU * y / lambda).sin()
    };
    let t = texture(f, 64, 0.04);
    let out = quilt(
        &t,
        &small_params().output(OutputSize::Scale(2.0)),
        &mut RunContext::new(2),
    )
    .unwrap();
    let lo = Vec2::new(out.bounds.min.x, out.bounds.min.y);
    let hi = Vec2::new(out.bounds.max.x, out.bounds.max.y);
    let measured = period_along_x(out.points.positions(), lo, hi, 0.05);
    assert!(
        (measured - lambda).abs() < 0.1 * lambda,
        "lattice spacing {measured}, expected {lambda}"
    );
}

#[test]
fn output_lies_in_the_requested_box_and_each_point_in_its_patch_box() {
    let t = texture(|x, y| 0.1 * (4.0 * x).sin() * (3.0 * y).cos(), 48, 0.05);
    let params = small_params().output(OutputSize::Absolute(2.3, 1.7));
    let out = quilt(&t, &params, &mut RunContext::new(3)).unwrap();
    let ext = out.bounds.extent();
    assert!((ext.x - 2.3).abs() < 1e-4 && (ext.y - 1.7).abs() < 1e-4);
    let patch = out.points.attribute("patch").unwrap().values();
    let g = out.stats.geometry;
    for (p, &k) in out.points.positions().iter().zip(patch) {
        assert!(out.bounds.contains(*p), "{p} outside {:?}", out.bounds);
        let placement = &out.placements[k as usize];
        let lo = placement.origin;
        let hi = lo + Vec2::splat(g.patch() + g.extra());
        assert!(
            p.x >= lo.x - 1e-4 && p.y >= lo.y - 1e-4 && p.x <= hi.x + 1e-4 && p.y <= hi.y + 1e-4,
            "point of patch {k} outside B_k"
        );
    }
    // Searched patches report candidate sets; the seed patch does not search.
    assert_eq!(out.placements[0].candidates, 1);
    assert!(
        out.placements
            .iter()
            .skip(1)
            .all(|p| p.candidates >= 1 && p.distance >= 0.0)
    );
}

#[test]
fn baselines_run_through_the_same_code() {
    let t = texture(|x, y| 0.1 * (4.0 * x).sin() * (3.0 * y).cos(), 40, 0.05);
    for method in [Method::SearchOnly, Method::RandomPlacement] {
        let out = quilt(&t, &small_params().method(method), &mut RunContext::new(4)).unwrap();
        assert!(
            out.placements
                .iter()
                .all(|p| p.warp.skipped && p.blend.blended == 0)
        );
        assert!(!out.points.is_empty());
        // Pasting without warp or blend copies every point verbatim.
        let q = evaluate(&t, &out, &small_params(), 8).unwrap();
        assert!(
            q.verbatim_fraction > 0.999,
            "{method:?}: {}",
            q.verbatim_fraction
        );
    }
    let full = quilt(&t, &small_params(), &mut RunContext::new(4)).unwrap();
    let q = evaluate(&t, &full, &small_params(), 8).unwrap();
    assert!(
        q.verbatim_fraction < 0.9,
        "warped and blended points are not verbatim: {}",
        q.verbatim_fraction
    );
}

#[test]
fn a_given_layout_is_followed_and_isolates_warp_and_blend() {
    let t = texture(|x, y| 0.1 * (4.0 * x).sin() * (3.0 * y).cos(), 40, 0.05);
    let run = |p: QuiltParams| quilt(&t, &p, &mut RunContext::new(3));
    let search = run(small_params().method(Method::SearchOnly).seed(3)).unwrap();
    let layout = search.sources();
    assert_eq!(layout.len(), search.placements.len());
    // Pasting search-only's own layout under another seed reproduces it point for point.
    let again = run(small_params()
        .method(Method::SearchOnly)
        .seed(9)
        .layout(layout.clone()))
    .unwrap();
    assert_eq!(again.points, search.points);
    // The full method on that layout places the same patches, then warps and blends them.
    let full = run(small_params().seed(9).layout(layout.clone())).unwrap();
    assert_eq!(full.sources(), layout);
    // Its control pastes those patches again: the search-only output, point for point.
    let control = run(small_params().seed(9).same_layout_control(&full)).unwrap();
    assert_eq!(control.points, search.points);
    assert!(full.placements.iter().any(|p| !p.warp.skipped));
    assert!(full.placements.iter().any(|p| p.blend.blended > 0));
    assert_ne!(full.points, search.points);
    // A layout of the wrong length or with a source outside the exemplar is refused.
    let short = layout[1..].to_vec();
    let mut outside = layout.clone();
    outside[2] = (10_000, 0);
    for bad in [short, outside, Vec::new()] {
        assert!(matches!(
            run(small_params().layout(bad)),
            Err(QuiltError::InvalidParameter { name: "layout", .. })
        ));
    }
}

#[test]
fn patches_under_three_field_spacings_are_refused_naming_the_smallest_that_works() {
    let t = wavy_texture();
    let run = |patch: f32| {
        quilt(
            &t,
            &small_params().patch_size(patch),
            &mut RunContext::new(0),
        )
    };
    // Two spacings: each placement advanced by one, and the output kept a seventh of its
    // points. Now refused, with the smallest patch_size of at least three.
    let refused = run(0.1).unwrap_err().to_string();
    assert!(refused.contains("at least 3 field spacings"), "{refused}");
    let smallest: f32 = refused
        .split("patch_size ≥ ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|number| number.parse().ok())
        .unwrap_or_else(|| panic!("no smallest patch_size in: {refused}"));
    let small = run(smallest + 1e-3).unwrap();
    assert!(small.placements[0].cell == (0, 0) && small.stats.patches > 50);
    // As dense as with the default patch: no placement leaves a thinned-out corner.
    let default = run(QuiltParams::default().patch_size).unwrap();
    let ratio = small.points.len() as f32 / default.points.len() as f32;
    assert!((0.85..1.15).contains(&ratio), "{ratio}");
}

#[test]
fn patches_too_narrow_in_a_long_box_are_refused_naming_remedies_in_range() {
    // A flat sheet sampled every 0.02 in boxes 4 long and `width` wide. The patch is a
    // fraction of the shorter side, the field's spacing a fraction of the longer one, so a
    // long box needs a finer field, a wider patch, or both; a remedy outside the accepted
    // ranges (a patch wider than the box, a field finer than 512 nodes) is never named.
    let (nx, ny) = (261, 66);
    let sheet: Vec<Vec3> = (0..nx * ny)
        .map(|i| {
            Vec3::new(
                -0.6 + 0.02 * (i % nx) as f32,
                -0.599 + 0.02 * (i / nx) as f32,
                0.0,
            )
        })
        .collect();
    let set = PointSet::new(sheet)
        .unwrap()
        .with_normals(vec![Vec3::Z; nx * ny])
        .unwrap();
    let in_box = |width: f32| {
        let bounds = Aabb::new(Vec3::new(0.0, 0.0, -0.1), Vec3::new(4.0, width, 0.1));
        GeometryTexture::new(&set, bounds, UpAxis::Z).unwrap()
    };
    let refusal =
        |t: &GeometryTexture, params: &QuiltParams| match quilt(t, params, &mut RunContext::new(0))
        {
            Err(
                e @ QuiltError::InvalidParameter {
                    name: "patch_size", ..
                },
            ) => e.to_string(),
            other => panic!("expected a refused patch_size, got {other:?}"),
        };
    let number_after = |text: &str, key: &str| -> f32 {
        text.split(key)
            .nth(1)
            .and_then(|rest| rest.split([' ', ',']).next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("no `{key}` in: {text}"))
    };
    let small = QuiltParams::default().output(OutputSize::Absolute(0.3, 0.3));

    // 40 : 1. Any patch_size would be over the box at 48 nodes; 251 nodes make 0.4 work.
    let long = in_box(0.1);
    let refused = refusal(&long, &small);
    assert!(!refused.contains("patch_size ≥"), "{refused}");
    let resolution = number_after(&refused, "field_resolution ≥ ") as usize;
    assert_eq!(resolution, 251, "{refused}");
    let done = quilt(
        &long,
        &small.clone().field_resolution(resolution),
        &mut RunContext::new(0),
    );
    assert!(done.is_ok(), "{refused}: {:?}", done.err());
    assert!(
        matches!(
            quilt(
                &long,
                &small.clone().field_resolution(resolution - 1),
                &mut RunContext::new(0)
            ),
            Err(QuiltError::InvalidParameter {
                name: "patch_size",
                ..
            })
        ),
        "one node fewer still refuses"
    );

    // 167 : 1. Neither alone is in range; a wider patch at the finest field is.
    let longer = in_box(0.024);
    let refused = refusal(&longer, &small);
    let patch = number_after(&refused, "patch_size ≥ ");
    assert!(refused.contains("with field_resolution 512"), "{refused}");
    assert!(patch < 1.0, "{refused}");
    refusal(
        &longer,
        &small.clone().field_resolution(512).patch_size(patch - 0.01),
    );

    // 1000 : 1. Nothing in range: a squarer box, with the shortest side that would do.
    let refused = refusal(&in_box(0.004), &small);
    for part in [
        "(this one is 1.9e-2)",
        "a squarer box: this one's shorter side is 1.0e-3 of its longer",
        "only from 4.9e-3 on",
    ] {
        assert!(refused.contains(part), "{refused}");
    }
}

#[test]
fn geometry_short_of_the_extra_region_is_refused_with_its_lengths_and_remedy() {
    let refusal = |t: &GeometryTexture, p: &QuiltParams| match quilt(t, p, &mut RunContext::new(0))
    {
        Err(QuiltError::InvalidTexture { reason }) => reason,
        other => panic!("{:?}", other.map(|o| o.points.len())),
    };
    // The wavy sheet spans 2.35 with 8 samples (0.4) of padding: 1.95 from the box's low
    // corner, where a patch of 0.9 of the box (1.55, snapped to 1.4 on the field's nodes)
    // and half as much again need 2.1 and more.
    let wavy = wavy_texture();
    let wide = small_params().patch_size(0.9).extra_width(0.5);
    let reason = refusal(&wavy, &wide);
    assert!(
        reason.contains("spans 2.0 along x and 2.0 along y")
            && reason.contains("(2.2: the patch 1.4 and w_E 0.7)")
            && reason.ends_with("a smaller patch_size or extra_width would fit"),
        "{reason}"
    );
    // A box a hundred times wider than the points: the box is the mistake.
    let points = wavy.canonical_points().clone();
    let bounds = Aabb::new(Vec3::new(0.0, 0.0, -1.0), Vec3::new(200.0, 200.0, 1.0));
    let boxed = GeometryTexture::new(&points, bounds, UpAxis::Z).unwrap();
    let reason = refusal(&boxed, &small_params());
    assert!(
        reason.contains("the box (200.0 × 200.0) reaches past the points (2.4 × 2.4)")
            && reason.ends_with("give a box inside them"),
        "{reason}"
    );
}

#[test]
fn invalid_input_is_an_error() {
    let t = texture(|_, _| 0.0, 40, 0.05);
    for bad in [
        QuiltParams::default().patch_size(0.0),
        QuiltParams::default().patch_size(1.5),
        QuiltParams::default().epsilon(-1.0),
        QuiltParams::default().field_resolution(3),
        QuiltParams::default().output(OutputSize::Scale(0.0)),
        QuiltParams::default().output(OutputSize::Absolute(-1.0, 2.0)),
        // Larger than 64 exemplar boxes per side (the box here is about 1.3 wide).
        QuiltParams::default().output(OutputSize::Absolute(1e30, 2.0)),
        QuiltParams::default().output(OutputSize::Absolute(2.0, 100.0)),
        // Between the samples: valid sizes, but no point falls inside (it used to be
        // called an invalid texture).
        QuiltParams::default().output(OutputSize::Absolute(0.001, 0.001)),
        QuiltParams::default().pair_distance(0.0),
        QuiltParams::default().blend_reach(f32::NAN),
        QuiltParams::default().blend_reach(0.0),
        QuiltParams::default().normal_agreement(1.5),
        QuiltParams::default().normal_agreement(f32::NAN),
        // Used to pass validation and then skip every warp silently.
        QuiltParams::default().cluster_points(0),
        QuiltParams::default().relaxation_rounds(patch_quilt::MAX_RELAXATION_ROUNDS + 1),
        QuiltParams::default().anchors_per_corner(patch_quilt::MAX_ANCHORS_PER_CORNER + 1),
        QuiltParams::default().anchors_per_corner(usize::MAX),
        {
            let mut p = QuiltParams::default();
            p.clusters = p.clusters.max_variation(f32::NAN);
            p
        },
    ] {
        assert!(
            matches!(
                quilt(&t, &bad, &mut RunContext::new(0)),
                Err(QuiltError::InvalidParameter { .. })
            ),
            "{bad:?}"
        );
    }
    let bare = PointSet::new((0..100).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect()).unwrap();
    let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
    assert!(matches!(
        GeometryTexture::new(&bare, b, UpAxis::Z),
        Err(QuiltError::InvalidTexture { .. })
    ));
    // Normals a tool left unset (zero) are refused, counted; so are ones too short to
    // have a direction.
    let sheet: Vec<Vec3> = (0..100)
        .map(|i| Vec3::new((i % 10) as f32 * 0.1, (i / 10) as f32 * 0.1, 0.0))
        .collect();
    let mut normals = vec![Vec3::Z; 100];
    normals[3] = Vec3::ZERO;
    normals[50] = Vec3::splat(1e-30);
    let unset = PointSet::new(sheet).unwrap().with_normals(normals).unwrap();
    let unset = GeometryTexture::new(&unset, b, UpAxis::Z).unwrap_err();
    assert!(
        unset.to_string().contains("2 of the 100 normals are zero"),
        "{unset}"
    );
    let heap = PointSet::new(vec![Vec3::splat(0.5); 100])
        .unwrap()
        .with_normals(vec![Vec3::Z; 100])
        .unwrap();
    let heap = GeometryTexture::new(&heap, b, UpAxis::Z).unwrap_err();
    assert!(
        heap.to_string().contains("all 100 points coincide"),
        "{heap}"
    );
    let flat_box = Aabb::new(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0));
    let oriented = bare.clone().with_normals(vec![Vec3::Z; 100]).unwrap();
    let flat = GeometryTexture::new(&oriented, flat_box, UpAxis::Z).unwrap_err();
    assert!(flat.to_string().contains("along the up axis"), "{flat}");
    let line_box = Aabb::new(Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0));
    let line = GeometryTexture::new(&oriented, line_box, UpAxis::Z).unwrap_err();
    assert!(
        line.to_string().contains("across the reference plane"),
        "{line}"
    );
    // A box far taller than wide would ask for an absurd grid (its layer count once
    // overflowed to 0).
    let tower = Aabb::new(Vec3::new(0.0, -1.0, -1e30), Vec3::new(99.0, 1.0, 1e30));
    let tower = GeometryTexture::new(&oriented, tower, UpAxis::Z).unwrap();
    let refused = quilt(&tower, &small_params(), &mut RunContext::new(0)).unwrap_err();
    assert!(
        refused.to_string().contains("field spacings tall"),
        "{refused}"
    );
    // Cancellation is honoured.
    let flag = pointset_core::CancelFlag::new();
    flag.cancel();
    let mut ctx = RunContext::new(0).with_cancel_flag(flag);
    assert!(matches!(
        quilt(&t, &small_params(), &mut ctx),
        Err(QuiltError::Core(pointset_core::Error::Cancelled))
    ));
}

/// A shared height field (`$GEOSYNTH_DATA/heightfields/…`) as a texture: every `step`-th
/// sample in each direction, heights normalized to a relief of 0.4 over a 4-unit width, the
/// outer sixth as padding. `None` (the test is skipped) without the shared data.
fn shared_heightfield_texture(test: &str, rel: &str, step: usize) -> Option<GeometryTexture> {
    let path = shared_data(test, rel)?;
    let full = HeightField::read_f32le(&path).unwrap();
    let (w, h) = (full.width() / step, full.height() / step);
    let (lo, hi) = full.range();
    let samples: Vec<f32> = (0..w * h)
        .map(|i| (full.get(step * (i % w), step * (i / w)).unwrap() - lo) / (hi - lo) * 0.4)
        .collect();
    let field = HeightField::new(w, h, samples).unwrap();
    Some(GeometryTexture::from_heightfield(&field, 4.0 / w as f32, 1.0, w.min(h) / 6).unwrap())
}

#[test]
fn the_shared_height_fields_quilt() {
    for rel in [
        "heightfields/StoneWall_200x200.f32le",
        "heightfields/SainteHelens_317x460.f32le",
    ] {
        // Every fourth sample keeps the test fast.
        let Some(t) = shared_heightfield_texture("shared_height_fields_quilt", rel, 4) else {
            return;
        };
        let params = small_params();
        let out = quilt(&t, &params, &mut RunContext::new(9)).unwrap();
        assert!(out.points.len() > t.canonical_points().len());
        // The output keeps the exemplar's density, so its size is known beforehand.
        let expected = t.expected_output_points(params.output);
        let ratio = out.points.len() as f64 / expected;
        assert!(
            (0.9..1.1).contains(&ratio),
            "{rel}: {} points, {expected:.0} expected",
            out.points.len()
        );
        let q = evaluate(&t, &out, &params, 12).unwrap();
        assert!(
            q.neighbourhood_error.is_finite()
                && q.largest_empty_disc < 3.0 * q.exemplar_largest_empty_disc + 1e-3,
            "{rel}: {q:?}"
        );
    }
}

#[test]
fn on_a_real_terrain_the_full_method_beats_pasting() {
    // Mount St. Helens (every second sample): not periodic, so pasted patches meet with
    // steps in height, and the warp and blend close them (docs/patch-quilt-studies.md,
    // "Real height fields"). One seed is noisy, so the means over seeds 1–8 are compared.
    // Measured (anchors through the height, twenty-ninth session): neighbourhood 0.044
    // against 0.058, seam 0.044 against 0.060. At every fourth sample search-only led
    // (fourteenth session: 0.037 against 0.050 and 0.039 against 0.048): too few samples
    // per feature.
    let Some(t) = shared_heightfield_texture(
        "real_terrain_full_beats_pasting",
        "heightfields/SainteHelens_317x460.f32le",
        2,
    ) else {
        return;
    };
    let params = QuiltParams::default().output(OutputSize::Scale(1.6));
    let measure = QualityMeasure::new(&t, &params).unwrap();
    // [neighbourhood, seam], means over the seeds.
    let [full, search] = [Method::Full, Method::SearchOnly].map(|m| {
        measure
            .mean_errors(&params.clone().method(m), 1..=8, 32)
            .unwrap()
    });
    assert!(
        full[0] < search[0] && full[1] < search[1],
        "means over 8 seeds, neighbourhood / seam: full {full:?}, search only {search:?}"
    );
}

#[test]
fn a_translated_verbatim_copy_scores_like_the_copy() {
    let t = texture(|x, y| 0.1 * (4.0 * x).sin() * (3.0 * y + x).cos(), 40, 0.05);
    let params = small_params().method(Method::SearchOnly);
    let out = quilt(&t, &params, &mut RunContext::new(3)).unwrap();
    let spacing = out.stats.geometry.spacing;
    let moved = {
        let mut o = out.clone();
        let shift = Vec3::new(0.3, 0.2, 0.15) * spacing;
        let p: Vec<Vec3> = o.points.positions().iter().map(|&p| p + shift).collect();
        let n = o.points.normals().unwrap().to_vec();
        let patch = o.points.attribute("patch").unwrap().clone();
        o.points = PointSet::new(p)
            .unwrap()
            .with_normals(n)
            .unwrap()
            .with_attribute(patch)
            .unwrap();
        o
    };
    let a = evaluate(&t, &out, &params, 16).unwrap();
    let b = evaluate(&t, &moved, &params, 16).unwrap();
    // Sub-node shifts are found again: the interior (verbatim) windows stay near 0. The
    // random-placement baseline on this texture scores 4 times higher.
    assert!(a.interior_error < 0.02, "{a:?}");
    assert!(b.interior_error < a.interior_error + 0.01, "{a:?}\n{b:?}");
    let random = quilt(
        &t,
        &small_params().method(Method::RandomPlacement),
        &mut RunContext::new(3),
    )
    .unwrap();
    let r = evaluate(&t, &random, &params, 16).unwrap();
    assert!(
        r.neighbourhood_error > 3.0 * b.neighbourhood_error,
        "{r:?}\n{b:?}"
    );
}

#[test]
fn quality_reports_the_windows_it_measured() {
    let t = texture(|x, y| 0.1 * (4.0 * x).sin() * (3.0 * y + x).cos(), 40, 0.05);
    let params = small_params().method(Method::SearchOnly);
    let out = quilt(&t, &params, &mut RunContext::new(4)).unwrap();
    let q = evaluate(&t, &out, &params, 12).unwrap();
    assert!(!q.featureless_exemplar, "{q:?}");
    assert_eq!(
        (q.windows, q.seam_windows, q.interior_windows),
        (12, 12, 12)
    );
    assert!(matches!(
        evaluate(&t, &out, &params, 0),
        Err(QuiltError::InvalidParameter {
            name: "windows",
            ..
        })
    ));
    // A single patch has no seams: no seam window, so its seam error of 0 means "not
    // measured", which the count says.
    let g = out.stats.geometry;
    let side = g.patch() - 2.0 * g.extra();
    let single = params.clone().output(OutputSize::Absolute(side, side));
    let one = quilt(&t, &single, &mut RunContext::new(4)).unwrap();
    assert_eq!(one.stats.patches, 1);
    let q = evaluate(&t, &one, &single, 12).unwrap();
    assert_eq!((q.seam_windows, q.seam_error), (0, 0.0));
    assert!(q.interior_windows > 0);
    // An output narrower than one window cannot be measured: an error, not a panic.
    let tiny = params.clone().output(OutputSize::Absolute(0.05, 1.0));
    let out = quilt(&t, &tiny, &mut RunContext::new(4)).unwrap();
    assert!(matches!(
        evaluate(&t, &out, &tiny, 12),
        Err(QuiltError::InvalidParameter { name: "output", .. })
    ));
}

#[test]
fn one_measure_reused_for_several_outputs_reports_what_evaluate_does() {
    let t = texture(
        |x, y| 0.1 * (4.0 * x).sin() * (3.0 * y + 0.3 * x).cos(),
        40,
        0.05,
    );
    let params = small_params().seed(9);
    let measure = QualityMeasure::new(&t, &params).unwrap();
    let mut errors = Vec::new();
    for method in [Method::Full, Method::SearchOnly, Method::RandomPlacement] {
        let p = params.clone().method(method);
        let out = quilt(&t, &p, &mut RunContext::new(9)).unwrap();
        let reused = measure.evaluate(&out, 8).unwrap();
        assert_eq!(reused, evaluate(&t, &out, &p, 8).unwrap(), "{method:?}");
        errors.push(reused.neighbourhood_error);
    }
    assert!(
        errors[2] > errors[1],
        "the measure still tells random placement from search: {errors:?}"
    );
    assert!(matches!(
        measure.evaluate(&quilt(&t, &params, &mut RunContext::new(9)).unwrap(), 0),
        Err(QuiltError::InvalidParameter { .. })
    ));
}

#[test]
fn warp_and_blend_repair_the_seams_of_randomly_placed_patches() {
    // Steps 4–5 on a layout the search did not choose: random placement leaves steps at
    // every seam, and warping and blending the same patches must close them. The gaps
    // here are far larger than the search leaves, so the pairs and the blend are given the
    // reach for them (the defaults are sized for the search's small gaps). The two runs
    // differ in nothing else.
    let t = texture(
        |x, y| 0.1 * (4.0 * x).sin() * (3.0 * y).cos() + 0.05 * (7.3 * x + 2.1 * y).sin(),
        40,
        0.05,
    );
    let params = small_params().pair_distance(4.0).blend_reach(10.0);
    let measure = QualityMeasure::new(&t, &params).unwrap();
    // Measured over seeds 1–8: the seam error fell to 0.12–0.65 of the pasted layout's and
    // the neighbourhood error to 0.08–0.94 of it.
    for seed in [1, 2, 3] {
        let run = |p: QuiltParams| quilt(&t, &p.seed(seed), &mut RunContext::new(seed)).unwrap();
        let random = run(params.clone().method(Method::RandomPlacement));
        let repaired = run(params.clone().layout(random.sources()));
        assert_eq!(repaired.sources(), random.sources());
        let (before, after) = (
            measure.evaluate(&random, 32).unwrap(),
            measure.evaluate(&repaired, 32).unwrap(),
        );
        assert!(
            after.neighbourhood_error < before.neighbourhood_error,
            "seed {seed}: neighbourhood error {} pasted, {} warped and blended",
            before.neighbourhood_error,
            after.neighbourhood_error
        );
        assert!(
            after.seam_error < 0.8 * before.seam_error,
            "seed {seed}: seam error {} pasted, {} warped and blended",
            before.seam_error,
            after.seam_error
        );
    }
}
