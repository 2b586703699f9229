//! `geosynth quilt` of mesh exemplars: by their vertices, or sampled on their surfaces
//! (`--sample`).

use geosynth::core::io::{self, Geometry};

use super::{Scratch, arg, ok, refused, timed_stages, write_with_defaults};
use crate::quilt::report_of;

/// Writes the brick tile fixture (a mesh whose vertices undersample it) as `bricks.obj`.
fn brick_tile(dir: &Scratch) -> String {
    let path = dir.path("bricks.obj");
    let tile = geosynth::fixtures::brick_tile_mesh().unwrap();
    write_with_defaults(&path, &Geometry::Mesh(tile));
    arg(&path)
}

/// The points of the point set written to `path`.
fn positions(path: &str) -> Vec<glam::Vec3> {
    let loaded = io::read_geometry(std::path::Path::new(path)).unwrap();
    loaded.geometry.points().positions().to_vec()
}

/// How many points the point set written to `path` holds.
fn point_count(path: &str) -> usize {
    positions(path).len()
}

/// The share of the points written to `path` within 0.01 of height `z`.
fn share_at(path: &str, z: f32) -> f32 {
    let points = positions(path);
    let near = points.iter().filter(|p| (p.z - z).abs() < 0.01).count();
    near as f32 / points.len() as f32
}

#[test]
fn a_mesh_its_vertices_undersample_is_noted_and_quilted_sampled_with_sample() {
    let dir = Scratch::new();
    let tile = brick_tile(&dir);
    let (by_vertices, sampled) = (arg(&dir.path("v.ply")), arg(&dir.path("s.ply")));
    let (report, replayed) = (arg(&dir.path("s.json")), arg(&dir.path("again.ply")));
    let said = ok(&["quilt", &tile, "-o", &by_vertices, "--scale", "1.2"]);
    assert!(
        said.contains("quilted by its 904 vertices, and its longest edge is 6 times")
            && said.contains("--sample [N] quilts points sampled evenly"),
        "{said}"
    );
    let run = ["quilt", &tile, "-o", &sampled, "--scale", "1.2"];
    let said = ok(&[&run[..], &["--sample", "4000", "--report", &report]].concat());
    assert!(!said.contains("--sample [N]"), "{said}");
    let r = report_of(&report);
    assert_eq!(r["input_options"]["sample"], 4000);
    assert!(r["longest_edge_spacings"].is_null());
    assert_eq!(
        timed_stages(&r, "timings")[..3],
        [
            "reading",
            geosynth::quilt::MESH_SAMPLING_STAGE,
            "preparing the input"
        ]
    );
    // The vertices put nothing on the bricks' tops between their corners; the samples
    // cover the tops and the joints' floor, and the quilt keeps both.
    let counts = [&by_vertices, &sampled].map(|path| point_count(path));
    assert!(counts[1] > 3 * counts[0], "{counts:?}");
    let (tops, floor) = (share_at(&sampled, 0.15), share_at(&sampled, 0.0));
    assert!(tops > 0.4 && floor > 0.1, "tops {tops}, floor {floor}");
    // The report replays the sampling.
    ok(&["quilt", &tile, "-o", &replayed, "--params", &report]);
    assert_eq!(
        std::fs::read(&sampled).unwrap(),
        std::fs::read(&replayed).unwrap()
    );
}

#[test]
fn sample_is_refused_where_there_is_no_mesh_to_sample() {
    let dir = Scratch::new();
    let out = arg(&dir.path("out.ply"));
    let points = arg(&geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply"));
    refused(
        &["quilt", &points, "-o", &out, "--sample"],
        "it is a point set: only a mesh's surface is sampled",
    );
    let tile = brick_tile(&dir);
    refused(
        &["quilt", &tile, "-o", &out, "--sample", "0"],
        "`0` is not a positive whole number of points",
    );
    refused(
        &["quilt", &tile, "-o", &out, "--sample", "--estimate-normals"],
        "it is a mesh: its normals come from its faces",
    );
    crate::quilt::refused_with_a_height_field(&dir, &["--sample"]);
}
