//! `--params FILE` with `--report FILE`: parameters read from JSON or from an earlier run's
//! report, flags given on the command line taking precedence, and bad files refused by name
//! before anything runs.

use std::path::Path;

use serde_json::Value;

use crate::{Scratch, arg, geosynth, ok};

fn read_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Asserts that two files hold the same bytes.
fn assert_same_bytes(a: &Path, b: &Path) {
    assert!(
        std::fs::read(a).unwrap() == std::fs::read(b).unwrap(),
        "{} and {} differ",
        a.display(),
        b.display()
    );
}

/// Runs `geosynth COMMAND INPUT -o never.ply --params FILE` with `content` in the file
/// (none: no file), and asserts that it fails, saying `said`, with nothing written.
fn assert_params_refused(
    dir: &Scratch,
    command: &str,
    input: &str,
    content: Option<&str>,
    said: &str,
) {
    let (out, file) = (dir.path("never.ply"), dir.path("refused.json"));
    match content {
        Some(text) => std::fs::write(&file, text).unwrap(),
        None => {
            let _ = std::fs::remove_file(&file);
        }
    }
    let run = geosynth(&[command, input, "-o", &arg(&out), "--params", &arg(&file)]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "{content:?}");
    assert!(err.contains(said), "{content:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out.exists(), "{content:?}");
}

/// Runs `geosynth quilt` on the bumpy fixture with `extra` arguments, writing `out` and a
/// report `report`, and returns the report.
fn quilt_bumpy(out: &Path, report: &Path, extra: &[&str]) -> Value {
    let exemplar = geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply");
    let (exemplar, out, report) = (arg(&exemplar), arg(out), arg(report));
    let mut args = vec![
        "quilt",
        &exemplar,
        "-o",
        &out,
        "--report",
        &report,
        "--no-quality",
        "-q",
    ];
    args.extend_from_slice(extra);
    ok(&args);
    read_json(Path::new(&report))
}

#[test]
fn a_quilt_report_runs_again_through_params_and_flags_override_it() {
    let dir = Scratch::new();
    let first = quilt_bumpy(
        &dir.path("a.ply"),
        &dir.path("a.json"),
        &[
            "--scale",
            "1.3",
            "--resolution",
            "24",
            "--seed",
            "3",
            "--epsilon",
            "0.2",
            "--cluster-points",
            "6",
        ],
    );
    let params = &first["params"];
    assert_eq!(params["seed"], 3);
    assert_eq!(params["clusters"]["max_points"], 6);
    // The pairing weights are written out (Table 1's height-field row by default).
    assert_eq!(params["pairing"]["w_v"], 30.0);
    assert!(params["pairing"]["max_distance"].is_null(), "{params}");

    // The report alone reproduces the run, point for point.
    let again = quilt_bumpy(
        &dir.path("b.ply"),
        &dir.path("b.json"),
        &["--params", &arg(&dir.path("a.json"))],
    );
    assert_eq!(again["params"], first["params"]);
    assert_same_bytes(&dir.path("a.ply"), &dir.path("b.ply"));

    // Flags given on the command line win; the rest comes from the file.
    let changed = quilt_bumpy(
        &dir.path("c.ply"),
        &dir.path("c.json"),
        &["--params", &arg(&dir.path("a.json")), "--seed", "4"],
    );
    assert_eq!(changed["params"]["seed"], 4);
    for key in ["field_resolution", "epsilon", "output", "clusters"] {
        assert_eq!(changed["params"][key], first["params"][key], "{key}");
    }
    assert_ne!(
        std::fs::read(dir.path("a.ply")).unwrap(),
        std::fs::read(dir.path("c.ply")).unwrap()
    );
}

#[test]
fn a_partial_params_file_keeps_the_commands_defaults_inside_nested_objects() {
    let dir = Scratch::new();
    let file = dir.path("p.json");
    std::fs::write(
        &file,
        r#"{ "clusters": { "max_points": 4 }, "output": { "absolute": [3.0, 2.5] },
             "field_resolution": 24, "method": "search_only" }"#,
    )
    .unwrap();
    let report = quilt_bumpy(
        &dir.path("p.ply"),
        &dir.path("p_report.json"),
        &["--params", &arg(&file)],
    );
    let params = &report["params"];
    assert_eq!(params["clusters"]["max_points"], 4);
    // The quilt's own default (0.1), not `ClusterParams::default()`'s 0.05.
    let variation = params["clusters"]["max_variation"].as_f64().unwrap();
    assert!((variation - 0.1).abs() < 1e-6, "{params}");
    assert_eq!(
        params["output"],
        serde_json::json!({ "absolute": [3.0, 2.5] })
    );
    assert_eq!(params["method"], "search_only");
    assert_eq!(params["pairing"]["w_n"], 3.0);
    assert_eq!(params["seed"], 0);
    let out = geosynth::core::io::read_geometry(dir.path("p.ply")).unwrap();
    let bounds = out.geometry.bounding_box().unwrap();
    assert!(bounds.extent().x <= 3.0 + 1e-4 && bounds.extent().y <= 2.5 + 1e-4);
}

#[test]
fn bad_params_files_are_refused_by_name_before_anything_is_written() {
    let dir = Scratch::new();
    let exemplar = arg(&geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply"));
    for (content, said) in [
        (Some("{ \"patch_sise\": 0.3 }"), "patch_sise"),
        (Some("{ \"clusters\": { \"max_pts\": 4 } }"), "max_pts"),
        (Some("{ \"method\": \"fast\" }"), "fast"),
        (Some("{ \"seed\": \"three\" }"), "three"),
        (Some("{ \"epsilon\": -1 }"), "epsilon"),
        (Some("[0.3]"), "object"),
        (Some("{ \"epsilon\": 0.3"), "not a JSON parameter file"),
        (None, "refused.json"),
    ] {
        assert_params_refused(&dir, "quilt", &exemplar, content, said);
    }
}

#[test]
fn a_voxel_report_runs_again_through_params() {
    let dir = Scratch::new();
    ok(&["fixtures", "--quiet", "--out", &arg(&dir.path(""))]);
    let exemplar = arg(&dir.path("voxel_grid.ply"));
    let run = |out: &str, report: &str, extra: &[&str]| {
        let (out, report) = (arg(&dir.path(out)), arg(&dir.path(report)));
        let mut args = vec!["voxel", &exemplar, "-o", &out, "--report", &report, "-q"];
        args.extend_from_slice(extra);
        ok(&args);
        read_json(Path::new(&report))
    };
    let first = run(
        "a.ply",
        "a.json",
        &[
            "--source-res",
            "16",
            "--target-dims",
            "16,24,16",
            "--levels",
            "1",
            "--block",
            "8",
            "--seed",
            "5",
            "--sign",
            "winding",
        ],
    );
    let stage = &first["stage"];
    assert_eq!(stage["source_resolution"], 16);
    assert_eq!(stage["mesh_sign"], "winding_number");
    assert_eq!(
        stage["params"]["target_dims"],
        serde_json::json!([16, 24, 16])
    );
    assert_eq!(stage["params"]["seed"], 5);
    let again = run("b.ply", "b.json", &["--params", &arg(&dir.path("a.json"))]);
    assert_eq!(again["stage"], first["stage"]);
    assert_same_bytes(&dir.path("a.ply"), &dir.path("b.ply"));
    // A range error from the file names the parameter.
    let bad = r#"{ "params": { "block": 6 } }"#;
    assert_params_refused(&dir, "voxel", &exemplar, Some(bad), "block");
}

#[test]
fn sdf_and_reconstruct_reports_run_again_through_params() {
    let dir = Scratch::new();
    ok(&["fixtures", "--quiet", "--out", &arg(&dir.path(""))]);
    let sphere = arg(&dir.path("sphere_points.ply"));
    let (field, report) = (dir.path("a.nrrd"), dir.path("a.json"));
    // A margin and band no flag sets, from a file; the resolution from a flag.
    std::fs::write(dir.path("p.json"), r#"{ "margin": 5, "band": 6 }"#).unwrap();
    ok(&[
        "sdf",
        &sphere,
        "-o",
        &arg(&field),
        "--params",
        &arg(&dir.path("p.json")),
        "--resolution",
        "24",
        "--sign",
        "winding",
        "--report",
        &arg(&report),
        "-q",
    ]);
    let first = read_json(&report);
    assert_eq!(first["params"]["margin"], 5.0);
    assert_eq!(first["params"]["band"], 6.0);
    assert_eq!(first["params"]["resolution"], 24);
    assert_eq!(first["params"]["point_sign"], "winding_number");
    assert_eq!(first["params"]["mesh_sign"], "winding_number");
    let dims: Vec<u64> = first["dims"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d.as_u64().unwrap())
        .collect();
    assert_eq!(dims.iter().max(), Some(&24));
    // The report repeats the field exactly.
    ok(&[
        "sdf",
        &sphere,
        "-o",
        &arg(&dir.path("b.nrrd")),
        "--params",
        &arg(&report),
        "-q",
    ]);
    assert_same_bytes(&field, &dir.path("b.nrrd"));

    // reconstruct: its report holds the mesh's counts, and repeats the mesh.
    let mesh = dir.path("r.ply");
    ok(&[
        "reconstruct",
        &sphere,
        "-o",
        &arg(&mesh),
        "--resolution",
        "20",
        "--report",
        &arg(&dir.path("r.json")),
        "-q",
    ]);
    let r = read_json(&dir.path("r.json"));
    assert_eq!(r["params"]["resolution"], 20);
    assert_eq!(r["closed_manifold"], true);
    assert!(r["faces"].as_u64().unwrap() > 100);
    ok(&[
        "reconstruct",
        &sphere,
        "-o",
        &arg(&dir.path("r2.ply")),
        "--params",
        &arg(&dir.path("r.json")),
        "-q",
    ]);
    assert_same_bytes(&mesh, &dir.path("r2.ply"));
    // A kernel from a file is checked like the flag.
    let bad = r#"{ "kernel": -1 }"#;
    assert_params_refused(&dir, "reconstruct", &sphere, Some(bad), "kernel");
}
