//! Band-by-band drawing gives the picture drawn whole.

use glam::Vec3;
use pointset_core::PointSet;
use pointset_core::io::Geometry;

use super::{RenderOptions, render_in_bands};
use crate::fixtures;

/// The three ways a preview draws: surface splats, sphere splats and triangles.
fn geometries() -> Vec<Geometry> {
    let oriented = fixtures::torus_points(3000, 1.0, 0.3, 7).unwrap();
    let unoriented = PointSet::new(oriented.positions().to_vec()).unwrap();
    let mesh = fixtures::torus_mesh(40, 20, 1.0, 0.3).unwrap();
    vec![
        Geometry::Points(oriented),
        Geometry::Points(unoriented),
        Geometry::Mesh(mesh),
    ]
}

#[test]
fn bands_of_any_height_draw_the_same_picture() {
    // An odd size, so the last band is short, and a tilted view, so primitives cross
    // bands at every row.
    let options = RenderOptions::default().size(157, 101).view(40.0, 60.0);
    for geometry in geometries() {
        let whole = render_in_bands(&geometry, &options, 101).unwrap();
        let drawn = whole.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        assert!(drawn > 2000, "{drawn} pixels drawn");
        for band_rows in [1, 2, 7, 64, 1000] {
            let banded = render_in_bands(&geometry, &options, band_rows).unwrap();
            assert!(banded == whole, "bands of {band_rows} rows differ");
        }
    }
}

#[test]
fn the_picture_does_not_depend_on_the_number_of_threads() {
    let options = RenderOptions::default()
        .size(120, 90)
        .color(Vec3::splat(0.6).into());
    let in_pool = |threads: usize, geometry: &Geometry| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| render_in_bands(geometry, &options, 4).unwrap())
    };
    for geometry in geometries() {
        assert!(in_pool(1, &geometry) == in_pool(3, &geometry));
    }
}
