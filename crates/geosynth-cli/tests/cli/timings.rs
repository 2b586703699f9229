//! Every report's `timings` list the phases of the whole command, reading to writing, none
//! inside another: they add up to no more than its `wall_seconds`, which is no more than
//! the process took.

use std::time::Instant;

use crate::{Scratch, TINY_VOXEL, arg, ok, timed_stages};

/// Runs `geosynth` with `args` and its report at `report`; asserts that the report's
/// phases are `stages` and tile its wall time, which the process's own time bounds.
fn assert_phases(args: &[&str], report: &str, stages: &[&str]) {
    let started = Instant::now();
    ok(&[args, &["--quiet", "--report", report]].concat());
    let elapsed = started.elapsed().as_secs_f64();
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    assert_eq!(timed_stages(&r, "timings"), stages, "{args:?}");
    let seconds: Vec<f64> = r["timings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["seconds"].as_f64().unwrap())
        .collect();
    assert!(seconds.iter().all(|s| *s >= 0.0), "{args:?}: {seconds:?}");
    let wall = r["wall_seconds"].as_f64().unwrap();
    // A microsecond for the sum's rounding: the phases were measured apart.
    let sum: f64 = seconds.iter().sum();
    assert!(sum <= wall + 1e-6, "{args:?}: phases {sum} s in {wall} s");
    assert!(
        wall <= elapsed,
        "{args:?}: {wall} s reported, {elapsed} s taken"
    );
}

/// `quilt` of `exemplar` into `output`, small, with `more` arguments.
fn quilt_args<'a>(exemplar: &'a str, output: &'a str, more: &[&'a str]) -> Vec<&'a str> {
    let run = ["quilt", exemplar, "-o", output, "--scale", "1.2"];
    [&run[..], &["--resolution", "24"], more].concat()
}

#[test]
fn every_report_times_its_command_from_reading_to_writing() {
    let dir = Scratch::new();
    let fixture = |name: &str| arg(&geosynth::fixtures::bundled_dir().join(name));
    let out = |name: &str| arg(&dir.path(name));
    let report = out("r.json");
    let (points, mesh) = (fixture("sphere_points.ply"), fixture("icosphere_mesh.ply"));
    let input = ["reading", "preparing the input"];
    assert_phases(
        &["normals", &points, "-o", &out("n.ply")],
        &report,
        crate::NORMALS_PHASES,
    );
    assert_phases(
        &["sample", &mesh, "-o", &out("s.ply"), "--count", "2000"],
        &report,
        &["reading", "sampling", "writing"],
    );
    let grid = ["--resolution", "24"];
    let reconstruct = ["reconstruct: distance field", "reconstruct: iso-surface"];
    assert_phases(
        &[&["reconstruct", &points, "-o", &out("r.ply")][..], &grid].concat(),
        &report,
        &[&input[..], &reconstruct, &["writing"]].concat(),
    );
    let remesh = ["remesh: distance field", "remesh: iso-surface"];
    assert_phases(
        &[&["reconstruct", &mesh, "-o", &out("m.ply")][..], &grid].concat(),
        &report,
        &[&input[..], &remesh, &["writing"]].concat(),
    );
    let sdf = ["signed distance: surface", "signed distance: sampling"];
    assert_phases(
        &[&["sdf", &points, "-o", &out("f.nrrd")][..], &grid].concat(),
        &report,
        &[&input[..], &sdf, &["writing"]].concat(),
    );
    let pairs = out("pairs.txt");
    std::fs::write(
        &pairs,
        "0 0 0 0.1 0 0\n1 1 1 1 1 1.2\n0 1 0 0 1 0\n1 0 0 1 0 0\n",
    )
    .unwrap();
    assert_phases(
        &["warp", &points, "--pairs", &pairs, "-o", &out("w.ply")],
        &report,
        &[
            "reading",
            "fitting the spline",
            "warping and finding folds",
            "writing",
        ],
    );
    let quilted = out("q.ply");
    let bumpy = fixture("quilt_bumpy.ply");
    let outputs = [
        "--mesh",
        &out("qm.ply"),
        "--heightfield-out",
        &out("qh.png"),
    ];
    assert_phases(
        &quilt_args(&bumpy, &quilted, &[&["--baselines"][..], &outputs].concat()),
        &report,
        &[
            &input[..],
            &[
                "synthesis",
                "writing",
                "mesh",
                "height map",
                "preparing the measure",
                "measuring quality",
                "search only",
                "random placement",
                "full's layout, pasted",
            ],
        ]
        .concat(),
    );
    // Normals estimated on the way are phases of their own, after the reading.
    let bare = out("bare.xyz");
    ok(&["convert", &bumpy, "-o", &bare, "-q"]);
    assert_phases(
        &quilt_args(&bare, &quilted, &["--no-quality", "--estimate-normals"]),
        &report,
        &[
            "reading",
            "fitting normals",
            "orienting normals",
            "preparing the input",
            "synthesis",
            "writing",
        ],
    );
    let voxel = ["voxel", &mesh, "-o", &out("v.ply")];
    // The field is written between the synthesis and the meshes; the meshes' writing
    // adds to that phase.
    assert_phases(
        &[
            &voxel[..],
            TINY_VOXEL,
            &["--field", &out("v.nrrd"), "--baseline"],
        ]
        .concat(),
        &report,
        &[
            &input[..],
            &["source field", "analysis", "level 1", "writing"],
            &["checking the meshes fit", "isosurface", "copied triangles"],
            &["measuring quality", "random baseline"],
        ]
        .concat(),
    );
}
