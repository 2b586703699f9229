//! `--params FILE` with `--report FILE`: parameters read from JSON or from an earlier run's
//! report, flags given on the command line taking precedence, and bad files refused by name
//! before anything runs.

use std::path::Path;

use serde_json::Value;

use crate::{
    Scratch, TINY_VOXEL, arg, assert_peak_memory, geosynth, icosphere_with_turned_faces, ok,
    write_with_defaults,
};

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

/// Asserts that two files hold different bytes (so an equality test elsewhere can fail).
fn assert_bytes_differ(a: &Path, b: &Path) {
    assert!(
        std::fs::read(a).unwrap() != std::fs::read(b).unwrap(),
        "{} and {} are the same",
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
    assert_bytes_differ(&dir.path("a.ply"), &dir.path("c.ply"));
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
        (
            Some("{ \"epsilon\": -1 }"),
            "refused.json: parameter `epsilon`",
        ),
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

/// Runs `geosynth ARGS… -o OUT --report REPORT -q` in `dir` and returns the report.
fn run_with_report(dir: &Scratch, args: &[&str], out: &str, report: &str) -> Value {
    let (out, report) = (arg(&dir.path(out)), arg(&dir.path(report)));
    let mut all = args.to_vec();
    all.extend_from_slice(&["-o", &out, "--report", &report, "-q"]);
    ok(&all);
    let report = read_json(Path::new(&report));
    assert_peak_memory(&report);
    report
}

#[test]
fn reports_record_how_the_input_was_read_and_params_reads_it_back() {
    let dir = Scratch::new();
    ok(&["fixtures", "--quiet", "--out", &arg(&dir.path(""))]);
    let again = |args: &[&str], report: &str, out: &str| {
        let mut all = args.to_vec();
        let file = arg(&dir.path(report));
        all.extend_from_slice(&["--params", &file]);
        run_with_report(&dir, &all, out, "again.json")
    };

    // quilt: a height field's relief, which changes every height.
    let hf = dir.path("waves_40x40.f32le");
    let heights: Vec<u8> = (0..40 * 40)
        .flat_map(|i| (((i % 40) as f32 * 0.5).sin() * ((i / 40) as f32 * 0.4).cos()).to_le_bytes())
        .collect();
    std::fs::write(&hf, heights).unwrap();
    let hf = arg(&hf);
    let quilt = [
        "quilt",
        "--heightfield",
        &hf,
        "--resolution",
        "20",
        "--no-quality",
    ];
    let mut steep = quilt.to_vec();
    steep.extend_from_slice(&["--relief", "0.3"]);
    let first = run_with_report(&dir, &steep, "q1.ply", "q1.json");
    assert_eq!(first["command"], "quilt");
    assert_eq!(first["input_options"]["relief"].as_f64(), Some(0.3));
    assert!(
        first["input_options"]["up"].is_null(),
        "{}",
        first["input_options"]
    );
    let repeated = again(&quilt, "q1.json", "q2.ply");
    assert_eq!(repeated["input_options"], first["input_options"]);
    assert_same_bytes(&dir.path("q1.ply"), &dir.path("q2.ply"));
    // Without the report, the default relief gives other heights.
    run_with_report(&dir, &quilt, "q3.ply", "q3.json");
    assert_bytes_differ(&dir.path("q1.ply"), &dir.path("q3.ply"));

    // reconstruct: `--trim` cuts an open sheet back; the report's trim does it again.
    let sheet = arg(&dir.path("heightfield_points.ply"));
    let reconstruct = ["reconstruct", &sheet, "--resolution", "24"];
    let mut trimmed = reconstruct.to_vec();
    trimmed.extend_from_slice(&["--trim", "2.5"]);
    let first = run_with_report(&dir, &trimmed, "r1.ply", "r1.json");
    assert_eq!(first["input_options"]["trim"].as_f64(), Some(2.5));
    again(&reconstruct, "r1.json", "r2.ply");
    assert_same_bytes(&dir.path("r1.ply"), &dir.path("r2.ply"));
    let untrimmed = run_with_report(&dir, &reconstruct, "r3.ply", "r3.json");
    assert!(untrimmed["input_options"]["trim"].is_null());
    assert!(untrimmed["faces"].as_u64() > first["faces"].as_u64());

    // sdf: `--orient-faces` on a mesh with triangles turned over.
    let (_, scrambled) = icosphere_with_turned_faces();
    let messy = dir.path("messy.ply");
    write_with_defaults(&messy, &geosynth::core::io::Geometry::Mesh(scrambled));
    let messy = arg(&messy);
    let sdf = ["sdf", &messy, "--resolution", "20"];
    let mut oriented = sdf.to_vec();
    oriented.push("--orient-faces");
    let first = run_with_report(&dir, &oriented, "s1.nrrd", "s1.json");
    assert_eq!(first["input_options"]["orient_faces"], true);
    // The report alone turns the triangles again.
    again(&sdf, "s1.json", "s2.nrrd");
    assert_same_bytes(&dir.path("s1.nrrd"), &dir.path("s2.nrrd"));
    run_with_report(&dir, &sdf, "s3.nrrd", "s3.json");
    assert_bytes_differ(&dir.path("s1.nrrd"), &dir.path("s3.nrrd"));
}

#[test]
fn a_report_of_another_command_is_refused_as_such() {
    let dir = Scratch::new();
    ok(&["fixtures", "--quiet", "--out", &arg(&dir.path(""))]);
    let sphere = arg(&dir.path("sphere_points.ply"));
    let quilt = quilt_bumpy(&dir.path("q.ply"), &dir.path("q.json"), &["--scale", "1"]);
    let text = serde_json::to_string(&quilt).unwrap();
    assert_params_refused(
        &dir,
        "voxel",
        &sphere,
        Some(&text),
        "a report of `geosynth quilt`",
    );
    assert_params_refused(
        &dir,
        "sdf",
        &sphere,
        Some(&text),
        "give a report of `geosynth sdf` or",
    );
    // sdf and reconstruct share their parameters, so each reads the other's reports.
    let sdf = run_with_report(
        &dir,
        &["sdf", &sphere, "--resolution", "18"],
        "s.nrrd",
        "s.json",
    );
    assert_eq!(sdf["command"], "sdf");
    let mesh = run_with_report(
        &dir,
        &[
            "reconstruct",
            &sphere,
            "--params",
            &arg(&dir.path("s.json")),
        ],
        "m.ply",
        "m.json",
    );
    assert_eq!(mesh["params"], sdf["params"]);
    // A command that is not a name is refused too.
    let unnamed = r#"{ "command": 3, "params": {} }"#;
    assert_params_refused(
        &dir,
        "quilt",
        &sphere,
        Some(unnamed),
        "must name the command",
    );
    // Input options are checked like parameters, and their errors name the file.
    for (command, options, said) in [
        ("quilt", r#"{ "orient_normal": true }"#, "unknown field"),
        (
            "quilt",
            r#"{ "relief": 0 }"#,
            "relief must be a positive fraction",
        ),
        (
            "reconstruct",
            r#"{ "trim": -1 }"#,
            "trim must be a positive number",
        ),
    ] {
        let document = format!(r#"{{ "input_options": {options} }}"#);
        let said = format!("refused.json: input_options: {said}");
        assert_params_refused(&dir, command, &sphere, Some(&document), &said);
    }
}

#[cfg(unix)]
#[test]
fn reports_of_inputs_whose_names_are_not_utf8_are_written() {
    use std::os::unix::ffi::OsStrExt;
    let dir = Scratch::new();
    ok(&["fixtures", "--quiet", "--out", &arg(&dir.path(""))]);
    for (fixture, command) in [("quilt_bumpy.ply", "quilt"), ("voxel_grid.ply", "voxel")] {
        // Latin-1 bytes, as an old archive might name its files.
        let name = dir
            .path("")
            .join(std::ffi::OsStr::from_bytes(b"caf\xe9.ply"));
        std::fs::copy(dir.path(fixture), &name).unwrap();
        let report = dir.path(&format!("{command}.json"));
        let mut args: Vec<std::ffi::OsString> = vec![command.into(), name.into()];
        for a in [
            "-o",
            &arg(&dir.path("out.ply")),
            "--report",
            &arg(&report),
            "-q",
        ] {
            args.push(a.into());
        }
        let small: &[&str] = match command {
            "quilt" => &["--scale", "1", "--no-quality"],
            _ => TINY_VOXEL,
        };
        args.extend(small.iter().map(Into::into));
        let run = std::process::Command::new(env!("CARGO_BIN_EXE_geosynth"))
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(run.status.success(), "{command}: {err}");
        let exemplar = read_json(&report)["exemplar"].as_str().unwrap().to_string();
        assert!(exemplar.ends_with("caf\u{fffd}.ply"), "{exemplar}");
    }
}
