//! Odd sheets, boxes and frames through `sample_heights`: each is either refused with a
//! typed error or sampled into a map that keeps its contracts (the size `map_size` gives,
//! finite heights, every sample counted once). Never a panic.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use geosynth::core::rng::rng_from_seed;
use geosynth::core::{Aabb, PointSet};
use geosynth::quilt::{HeightFieldFrame, UpAxis, sample_heights};
use glam::Vec3;
use proptest::prelude::*;
use rand::RngExt;

/// How the samples lie (canonical frame, up = +Z, in a unit square).
#[derive(Debug, Clone, Copy)]
enum Layout {
    /// A wavy sheet on a jittered grid.
    Sheet,
    /// The same sheet with a square hole in its middle.
    Holed,
    /// Two sheets, one above the other.
    Stacked,
    /// Uniformly at random in the unit cube.
    Uniform,
    /// Every sample at one point.
    Coincident,
    /// On one line.
    Line,
}

#[derive(Debug, Clone, Copy)]
struct Case {
    layout: Layout,
    samples: usize,
    /// Side of the square the samples span.
    size: f32,
    /// Added to every coordinate.
    offset: f32,
    /// Normals with random signs instead of up.
    unoriented: bool,
    up: UpAxis,
    /// Map spacing over the sample spacing (a power of ten), or an odd value.
    spacing: Spacing,
    /// Height scale.
    scale: f32,
    /// The box: the points' own, or one ten times as wide.
    wide_box: bool,
    seed: u64,
}

#[derive(Debug, Clone, Copy)]
enum Spacing {
    Relative(f32),
    Odd(f32),
}

fn case() -> impl Strategy<Value = Case> {
    let layout = prop_oneof![
        3 => Just(Layout::Sheet),
        2 => Just(Layout::Holed),
        1 => Just(Layout::Stacked),
        1 => Just(Layout::Uniform),
        1 => Just(Layout::Coincident),
        1 => Just(Layout::Line),
    ];
    let up = prop_oneof![Just(UpAxis::X), Just(UpAxis::Y), Just(UpAxis::Z)];
    let power_of_ten = |e: f32| 10f32.powf(e);
    let spacing = prop_oneof![
        6 => (-1.0f32..1.5).prop_map(move |e| Spacing::Relative(power_of_ten(e))),
        1 => prop_oneof![
            Just(0.0f32),
            Just(-0.1),
            Just(f32::NAN),
            Just(f32::INFINITY),
            Just(1e-9),
        ]
        .prop_map(Spacing::Odd),
    ];
    let scale = prop_oneof![
        4 => Just(1.0f32),
        2 => (-2.0f32..2.0).prop_map(power_of_ten),
        1 => prop_oneof![Just(-2.0f32), Just(0.0), Just(f32::NAN)],
    ];
    let size = (-2.0f32..2.0).prop_map(power_of_ten);
    let offset = prop_oneof![Just(0.0f32), (-1.0f32..4.0).prop_map(power_of_ten)];
    (
        (layout, 1usize..600, size, offset, any::<bool>()),
        (up, spacing, scale, any::<bool>(), any::<u64>()),
    )
        .prop_map(
            |(
                (layout, samples, size, offset, unoriented),
                (up, spacing, scale, wide_box, seed),
            )| {
                Case {
                    layout,
                    samples,
                    size,
                    offset,
                    unoriented,
                    up,
                    spacing,
                    scale,
                    wide_box,
                    seed,
                }
            },
        )
}

/// The case's points in the world frame of a texture whose up axis is `case.up`, and their
/// box there.
fn sheet(case: &Case) -> (PointSet, Aabb) {
    let mut g = rng_from_seed(case.seed);
    let side = (case.samples as f32).sqrt().ceil().max(2.0);
    let wave = |x: f32, y: f32| 0.1 * (6.0 * x).sin() * (5.0 * y).cos();
    let mut canonical = Vec::new();
    for i in 0..case.samples {
        let (x, y) = (
            ((i as f32 % side) + g.random_range(-0.3f32..0.3)) / side,
            ((i as f32 / side).floor() + g.random_range(-0.3f32..0.3)) / side,
        );
        let p = match case.layout {
            Layout::Sheet => Vec3::new(x, y, wave(x, y)),
            Layout::Holed if (x - 0.5).abs().max((y - 0.5).abs()) < 0.2 => continue,
            Layout::Holed => Vec3::new(x, y, wave(x, y)),
            Layout::Stacked => Vec3::new(x, y, wave(x, y) + if i % 2 == 0 { 0.3 } else { 0.0 }),
            Layout::Uniform => Vec3::new(
                g.random_range(0.0f32..1.0),
                g.random_range(0.0f32..1.0),
                g.random_range(0.0f32..1.0),
            ),
            Layout::Coincident => Vec3::splat(0.5),
            Layout::Line => Vec3::new(x, 0.5, 0.0),
        };
        canonical.push(p * case.size + Vec3::splat(case.offset));
    }
    if canonical.is_empty() {
        canonical.push(Vec3::splat(case.offset));
    }
    let normals: Vec<Vec3> = (0..canonical.len())
        .map(|i| {
            if case.unoriented && i % 3 == 0 {
                -Vec3::Z
            } else {
                Vec3::Z
            }
        })
        .collect();
    let own = Aabb::from_points(&canonical).unwrap();
    let bounds = if case.wide_box {
        let centre = own.center();
        let half = 5.0 * own.extent().max(Vec3::splat(case.size));
        Aabb::new(centre - half, centre + half)
    } else {
        own
    };
    let world = |v: &Vec3| case.up.to_world(*v);
    let points = PointSet::new(canonical.iter().map(world).collect())
        .unwrap()
        .with_normals(normals.iter().map(world).collect())
        .unwrap();
    (points, Aabb::new(world(&bounds.min), world(&bounds.max)))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn odd_sheets_are_refused_or_mapped_within_their_contracts(case in case()) {
        let (points, bounds) = sheet(&case);
        let spacing = match case.spacing {
            Spacing::Relative(r) => r * case.size / (case.samples as f32).sqrt(),
            Spacing::Odd(s) => s,
        };
        let frame = HeightFieldFrame { spacing, scale: case.scale, up: case.up };
        let extent = case.up.canonical_box(&bounds).extent().truncate();
        let size = frame.map_size(extent);
        // Large maps keep their contracts too, but take seconds each in a debug build.
        prop_assume!(size.as_ref().map_or(true, |(w, h)| w * h <= 1 << 16));
        match sample_heights(&points, &bounds, frame) {
            Ok(sampled) => {
                let field = &sampled.field;
                prop_assert_eq!(size.ok(), Some((field.width(), field.height())));
                prop_assert!(field.heights().iter().all(|h| h.is_finite()));
                prop_assert_eq!(
                    sampled.by_ray + sampled.by_projection + sampled.filled,
                    field.width() * field.height()
                );
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
    }
}
