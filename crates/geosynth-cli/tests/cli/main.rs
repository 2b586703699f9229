//! Runs the `geosynth` binary as a user would.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod demo;
mod files;
mod height_files;
#[cfg(unix)]
mod locked_folders;
mod params;
mod quilt;
mod quilt_maps;
mod quilt_meshes;
mod remesh;
mod sample;
#[cfg(unix)]
mod signals;
mod simplify;
mod strays;
mod surfaces;
mod timings;
mod voxel;

fn geosynth(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_geosynth"))
        .args(args)
        .output()
        .expect("the geosynth binary runs")
}

fn ok(args: &[&str]) -> String {
    let out = geosynth(args);
    assert!(
        out.status.success(),
        "geosynth {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs `geosynth` with `args`, which it must refuse with `message` in its error.
fn refused(args: &[&str], message: &str) {
    let bad = geosynth(args);
    assert!(!bad.status.success(), "{args:?}");
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(stderr.contains(message), "{args:?}: {stderr}");
}

/// Writes `geometry` to `path` with the default options (the format from the extension).
fn write_with_defaults(path: &Path, geometry: &geosynth::core::io::Geometry) {
    geosynth::core::io::write_geometry(
        path,
        geometry,
        &geosynth::core::io::WriteOptions::default(),
    )
    .unwrap();
}

/// A scratch folder for a test's files, removed when dropped.
struct Scratch(tempfile::TempDir);

impl Scratch {
    fn new() -> Self {
        Self(tempfile::tempdir().unwrap())
    }

    /// The path of `name` in the folder.
    fn path(&self, name: &str) -> PathBuf {
        self.0.path().join(name)
    }

    /// The names in the folder, sorted.
    fn names(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(self.0.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

/// A path as a command-line argument.
fn arg(path: &Path) -> String {
    path.to_str().unwrap().to_string()
}

/// Asserts that a report records the peak memory of its run: a plausible number of bytes
/// on Linux (more than the 1 MiB any run holds, less than 64 GiB), `null` elsewhere.
fn assert_peak_memory(report: &serde_json::Value) {
    let peak = &report["peak_memory_bytes"];
    if cfg!(target_os = "linux") {
        let bytes = peak.as_u64().unwrap_or(0);
        assert!((1 << 20..1 << 36).contains(&bytes), "{peak}");
    } else {
        assert!(peak.is_null(), "{peak}");
    }
}

/// `points` with every third normal flipped (the first, fourth, …), as unoriented
/// estimates come.
fn every_third_flipped(points: &geosynth::core::PointSet) -> geosynth::core::PointSet {
    let normals = points.normals().unwrap().iter().enumerate();
    let signs = normals.map(|(i, &n)| if i % 3 == 0 { -n } else { n });
    points.clone().with_normals(signs.collect()).unwrap()
}

/// The stages a report lists under `key` (`{"stage": NAME, "seconds": S}` entries), in
/// order.
fn timed_stages(report: &serde_json::Value, key: &str) -> Vec<String> {
    report[key]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["stage"].as_str().unwrap().to_string())
        .collect()
}

/// `geosynth info --json` of a file.
fn info_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&ok(&["info", "--json", path.to_str().unwrap()])).unwrap()
}

/// Asserts that `info` finds `path` a closed manifold of Euler characteristic `euler`.
fn assert_closed(path: &Path, euler: i64, what: &str) {
    let json = info_json(path);
    assert_eq!(json["topology"]["closed_manifold"], true, "{what}");
    assert_eq!(json["topology"]["euler_characteristic"], euler, "{what}");
}

/// Quilts the height field `input` (resolution 20, no quality measure) into `out`, its
/// map into `map` and its report into `report`; returns what the command printed.
fn quilt_height_field_into(input: &Path, map: &Path, out: &Path, report: &Path) -> String {
    ok(&[
        "quilt",
        "--heightfield",
        &arg(input),
        "-o",
        &arg(out),
        "--resolution",
        "20",
        "--no-quality",
        "--heightfield-out",
        &arg(map),
        "--report",
        &arg(report),
    ])
}

/// The report's `heightfield_out` entry of a quilt run.
fn height_map_entry(report: &Path) -> serde_json::Value {
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    r["heightfield_out"].clone()
}

/// Runs `geosynth voxel` on `mesh` at 16³ in one level of 8³ blocks, with `extra`
/// arguments, and returns what it printed.
fn tiny_voxel(mesh: &Path, out: &Path, extra: &[&str]) -> String {
    let mut args = vec!["voxel", mesh.to_str().unwrap(), "-o", out.to_str().unwrap()];
    args.extend_from_slice(TINY_VOXEL);
    args.extend_from_slice(extra);
    ok(&args)
}

/// `voxel` settings small enough for a test: a 16³ source and target, one level, 8³ blocks.
const TINY_VOXEL: &[&str] = &[
    "--source-res",
    "16",
    "--target-res",
    "16",
    "--levels",
    "1",
    "--block",
    "8",
];

/// The phases a `normals` report times, in order.
const NORMALS_PHASES: &[&str] = &[
    "reading",
    "indexing",
    "fitting normals",
    "orienting normals",
    "checking the orientation",
    "writing",
];

/// An icosphere, and the same with every 9th triangle turned over.
fn icosphere_with_turned_faces() -> (geosynth::core::TriMesh, geosynth::core::TriMesh) {
    let sphere = geosynth::fixtures::icosphere_mesh(3).unwrap();
    let triangles = sphere
        .triangles()
        .iter()
        .enumerate()
        .map(|(i, &[a, b, c])| {
            if i.is_multiple_of(9) {
                [a, c, b]
            } else {
                [a, b, c]
            }
        })
        .collect();
    let scrambled = geosynth::core::TriMesh::new(sphere.vertices().clone(), triangles).unwrap();
    (sphere, scrambled)
}
