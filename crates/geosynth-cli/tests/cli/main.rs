//! Runs the `geosynth` binary as a user would.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use geosynth::core::testdata::shared_data;

mod height_files;
mod params;
mod remesh;

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

/// Every data file under `GEOSYNTH_DATA` (geometry, pictures, height fields), skipping the
/// folder's own text documentation.
fn shared_data_files() -> Option<Vec<PathBuf>> {
    let root = shared_data("info_and_render_on_shared_data", "")?;
    let mut files = Vec::new();
    let mut dirs = vec![root];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else if !matches!(
                path.extension().and_then(|e| e.to_str()),
                Some("md" | "json" | "txt")
            ) {
                files.push(path);
            }
        }
    }
    files.sort();
    assert!(
        files.len() >= 30,
        "expected the shared data set, found {files:?}"
    );
    Some(files)
}

#[test]
fn info_and_render_work_on_every_shared_file() {
    let Some(files) = shared_data_files() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    for file in &files {
        let f = file.to_str().unwrap();
        let json = info_json(file);
        match json["kind"].as_str().unwrap() {
            "points" | "mesh" => {
                assert!(json["vertices"].as_u64().unwrap() > 0, "{f}");
                assert!(json["bbox_min"].is_array(), "{f}");
            }
            "image" | "heightfield" => assert!(json["width"].as_u64().unwrap() >= 64, "{f}"),
            other => panic!("{f}: unexpected kind {other}"),
        }
        let text = ok(&["info", f]);
        assert!(text.contains("kind:"), "{f}");
        if f.ends_with("spot_triangulated.obj") {
            // Split along its UV seams into open pieces; closed once welded by position.
            assert_eq!(json["topology"]["closed_manifold"], false);
            assert_eq!(json["welded_topology"]["closed_manifold"], true, "{json}");
            assert_eq!(json["welded_topology"]["components"], 1);
            assert!(text.contains("welded:"), "{text}");
        }
        let png = dir.path().join(format!(
            "{}.png",
            file.file_stem().unwrap().to_str().unwrap()
        ));
        ok(&[
            "render",
            f,
            "-o",
            png.to_str().unwrap(),
            "--width",
            "160",
            "--height",
            "120",
        ]);
        let img = image::open(&png).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (160, 120));
        let drawn = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        assert!(drawn > 500, "{f}: only {drawn} pixels drawn");
    }
    // A 16-bit PNG height field can be drawn as terrain too.
    let hf = files
        .iter()
        .find(|p| p.to_str().unwrap().ends_with("_u16.png"))
        .unwrap();
    let terrain = dir.path().join("terrain.png");
    let said = ok(&[
        "render",
        "--heightfield",
        hf.to_str().unwrap(),
        "-o",
        terrain.to_str().unwrap(),
    ]);
    assert!(!said.contains("note"), "{said}");
    // Without a picture among the files, --heightfield has nothing to do, and says so.
    let points = arg(&geosynth::fixtures::bundled_dir().join("sphere_points.ply"));
    let said = ok(&["render", "--heightfield", &points, "-o", &arg(&terrain)]);
    assert!(said.contains("none of the files is one"), "{said}");
    // Several inputs become panels.
    let all: Vec<&str> = files.iter().take(3).map(|p| p.to_str().unwrap()).collect();
    let out = dir.path().join("panels.png");
    let mut args = vec!["render"];
    args.extend(&all);
    args.extend([
        "-o",
        out.to_str().unwrap(),
        "--width",
        "100",
        "--height",
        "80",
        "--quiet",
    ]);
    ok(&args);
    assert_eq!(image::open(&out).unwrap().width(), 3 * 100 + 2 * 4);
}

#[test]
fn output_into_a_closed_pipe_is_not_a_panic() {
    // `geosynth info x.ply | head -1`: the reader leaves before the output is written.
    let fixture = geosynth::fixtures::bundled_dir().join("torus_mesh.ply");
    for json in [false, true] {
        let mut args = vec!["info", fixture.to_str().unwrap()];
        if json {
            args.push("--json");
        }
        let mut child = Command::new(env!("CARGO_BIN_EXE_geosynth"))
            .args(&args)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(out.status.success(), "{args:?}: {err}");
    }
}

#[test]
fn info_reports_kept_attributes() {
    let Some(path) = shared_data(
        "info_reports_kept_attributes",
        "meshes/stanford_bunny_res2.ply",
    ) else {
        return;
    };
    let json = info_json(&path);
    assert_eq!(json["vertices"], 8171);
    assert_eq!(json["faces"], 16301);
    let names: Vec<&str> = json["attributes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["confidence", "intensity"]);
}

#[test]
fn bad_input_fails_with_a_message_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.ply");
    std::fs::write(&bad, b"ply\nformat binary_little_endian 1.0\nelement vertex 99999999\nproperty float x\nend_header\n").unwrap();
    for args in [
        vec!["info", bad.to_str().unwrap()],
        vec!["info", "/nonexistent/file.ply"],
        vec!["render", bad.to_str().unwrap(), "-o", "x.png"],
        vec![
            "render",
            "--width",
            "0",
            "-o",
            "x.png",
            bad.to_str().unwrap(),
        ],
    ] {
        let out = geosynth(&args);
        assert!(!out.status.success(), "{args:?} should fail");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("error"), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    // Outputs that could not be written are refused before the run, not after it.
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/quilt_bumpy.ply");
    let fixture = fixture.to_str().unwrap();
    let missing = dir.path().join("missing/out.ply");
    let missing = missing.to_str().unwrap();
    let report_in_missing = dir.path().join("missing/report.json");
    let unknown = dir.path().join("out.xyzw");
    for (args, message) in [
        (vec!["quilt", fixture, "-o", missing], "does not exist"),
        (
            vec![
                "quilt",
                fixture,
                "-o",
                dir.path().join("q.ply").to_str().unwrap(),
                "--report",
                report_in_missing.to_str().unwrap(),
            ],
            "does not exist",
        ),
        (
            vec!["quilt", fixture, "-o", unknown.to_str().unwrap()],
            ".ply, .obj, .off, .stl, .xyz, .xyzn or .xyzrgb",
        ),
        (
            vec!["reconstruct", fixture, "-o", missing],
            "does not exist",
        ),
    ] {
        refused(&args, message);
    }
    // The quilt whose report had nowhere to go never ran: its output was not written either.
    assert!(!dir.path().join("q.ply").exists());
    // Thread counts out of range are refused before anything starts (100,000 threads had
    // not started after a minute).
    for threads in ["0", "100000"] {
        let args = ["--threads", threads, "fixtures", "--out", &arg(dir.path())];
        refused(&args, "--threads must be 1 to");
    }
}

#[test]
fn a_bad_input_file_is_named_in_its_error_once() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.ply");
    write_with_defaults(
        &good,
        &geosynth::core::io::Geometry::Points(geosynth::fixtures::sphere_points(50).unwrap()),
    );
    let nan = dir.path().join("nan.ply");
    let header = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
                  property float z\nend_header\n";
    std::fs::write(&nan, format!("{header}0 0 0\n1 nan 0\n")).unwrap();
    let short_raw = dir.path().join("short_4x4.f32le");
    std::fs::write(&short_raw, [0u8; 40]).unwrap();
    let volume = dir.path().join("volume.nrrd");
    std::fs::write(
        &volume,
        "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nendian: little\n\n",
    )
    .unwrap();
    let png = dir.path().join("out.png");
    let ply_out = dir.path().join("out.ply");
    let (nan, short_raw, volume) = (arg(&nan), arg(&short_raw), arg(&volume));
    let (png, ply_out, good) = (arg(&png), arg(&ply_out), arg(&good));
    for (args, file, what) in [
        // Of two panels, the second cannot be read: the message says which.
        (
            vec!["render", &good, &nan, "-o", &png],
            &nan,
            "position 1 is not finite",
        ),
        (vec!["info", &short_raw], &short_raw, "needs 64 bytes"),
        (vec!["info", &volume], &volume, "spacings"),
        (vec!["voxel", &volume, "-o", &ply_out], &volume, "spacings"),
        (vec!["quilt", &nan, "-o", &ply_out], &nan, "not finite"),
        (
            vec!["quilt", "--heightfield", &short_raw, "-o", &ply_out],
            &short_raw,
            "64 bytes",
        ),
        (vec!["convert", &nan, "-o", &ply_out], &nan, "not finite"),
        (vec!["normals", &nan, "-o", &ply_out], &nan, "not finite"),
        (
            vec!["reconstruct", &nan, "-o", &ply_out],
            &nan,
            "not finite",
        ),
    ] {
        let out = geosynth(&args);
        assert!(!out.status.success(), "{args:?} should fail");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.starts_with(&format!("error: {file}: ")),
            "{args:?}: {err}"
        );
        assert!(err.contains(what), "{args:?}: {err}");
        // The cause is the message itself: it is not printed a second time.
        assert_eq!(err.matches(what).count(), 1, "{args:?}: {err}");
    }
    // A message that names the file already is left as it is.
    let missing = dir.path().join("missing.ply");
    let out = geosynth(&["info", &arg(&missing)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.matches("missing.ply").count(), 1, "{err}");
}

#[test]
fn an_empty_mesh_is_described_and_drawn_as_empty() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.stl");
    std::fs::write(&empty, "solid nothing\nendsolid nothing\n").unwrap();
    let text = ok(&["info", &arg(&empty)]);
    assert!(
        text.contains("topology:    no faces, 0 component(s)"),
        "{text}"
    );
    assert_eq!(info_json(&empty)["topology"]["closed_manifold"], false);
    let png = dir.path().join("empty.png");
    let out = geosynth(&["render", &arg(&empty), "-o", &arg(&png)]);
    assert!(out.status.success() && png.exists());
    let said = String::from_utf8_lossy(&out.stdout) + String::from_utf8_lossy(&out.stderr);
    assert!(
        said.contains("empty.stl holds no points; its panel is empty"),
        "{said}"
    );
}

#[test]
fn demo_quick_writes_report_geometry_and_previews() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    ok(&["demo", "--quick", "--quiet", "--out", out.to_str().unwrap()]);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_peak_memory(&report);
    let markdown = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(markdown.contains("· peak memory "), "{markdown}");
    let fixtures = report["fixtures"].as_array().unwrap();
    assert!(fixtures.len() >= 6);
    for f in fixtures {
        for key in ["preview", "geometry"] {
            let p = out.join(f[key].as_str().unwrap());
            assert!(p.is_file(), "{}", p.display());
        }
        let img = image::open(out.join(f["preview"].as_str().unwrap())).unwrap();
        assert_eq!(img.width(), 320);
    }
    assert!(
        report["fixtures_source"]
            .as_str()
            .unwrap()
            .ends_with("fixtures")
    );
    assert!(
        std::fs::read_to_string(out.join("report.md"))
            .unwrap()
            .contains("| stage | seconds |")
    );
    assert!(Path::new(&out.join("fixtures.png")).is_file());
    // Patch quilting: every texture fixture, its files, and the parameters that made it.
    let quilts = report["quilts"].as_array().unwrap();
    assert_eq!(quilts.len(), 4);
    for q in quilts {
        for key in ["preview", "geometry"] {
            assert!(out.join(q[key].as_str().unwrap()).is_file(), "{key}");
        }
        assert_eq!(q["params"]["method"], "full", "{q}");
        assert!(q["params"]["pairing"]["w_d"].as_f64().unwrap() > 0.0, "{q}");
        assert!(
            q["full"]["quality"]["neighbourhood_error"]
                .as_f64()
                .unwrap()
                >= 0.0
        );
    }
    // A real terrain quilted and written back as a height map, with the shared data (the
    // demo also looks beside the source tree when `GEOSYNTH_DATA` is not set).
    let terrain = report["terrain"].as_array().unwrap();
    let test = "demo_quick_writes_report_geometry_and_previews";
    match terrain.first() {
        Some(t) => {
            assert_eq!(terrain.len(), 1);
            assert!(out.join(t["preview"].as_str().unwrap()).is_file());
            let map_path = out.join(t["height_map"].as_str().unwrap());
            let map = geosynth::imagery::read_heightfield(&map_path).unwrap();
            assert_eq!(map.width() as u64, t["width"].as_u64().unwrap());
            assert_eq!(map.height() as u64, t["height"].as_u64().unwrap());
        }
        None => {
            let data = shared_data(test, "heightfields/SainteHelens_317x460_u16.png");
            assert!(data.is_none(), "{}", report["skipped"]);
            assert!(report["skipped"].to_string().contains("terrain height map"));
        }
    }
    // Distance-field synthesis: every Figure 6 solid, search beating random blocks.
    let volumes = report["volumes"].as_array().unwrap();
    assert_eq!(volumes.len(), 5);
    for v in volumes {
        assert!(v["beats_baseline"].as_bool().unwrap(), "{v}");
        for key in ["preview", "geometry", "isosurface", "exemplar_geometry"] {
            assert!(out.join(v[key].as_str().unwrap()).is_file(), "{key}");
        }
    }
}

#[test]
fn voxel_synthesizes_a_fixture_and_rejects_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    ok(&["fixtures", "--quiet", "--out", dir.path().to_str().unwrap()]);
    let exemplar = dir.path().join("voxel_grid.ply");
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    ok(&[
        "voxel",
        exemplar.to_str().unwrap(),
        "-o",
        &path("v.ply"),
        "--isosurface",
        &path("v_iso.obj"),
        "--source-res",
        "20",
        "--target-res",
        "24",
        "--levels",
        "2",
        "--block",
        "8",
        "--field",
        &path("v.nrrd"),
        "--report",
        &path("v.json"),
        "--baseline",
        "--preview",
        &path("v.png"),
        "-q",
    ]);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path("v.json")).unwrap()).unwrap();
    assert_eq!(r["target_dims"], serde_json::json!([24, 24, 24]));
    assert_eq!(r["levels"].as_array().unwrap().len(), 2);
    for level in r["levels"].as_array().unwrap() {
        assert_eq!(level["min_writes"], 1);
        assert_eq!(level["max_writes"], 1);
    }
    let q = |k: &str, run: &str| r[run][k].as_f64().unwrap();
    assert!(q("neighbourhood_error", "quality") < q("neighbourhood_error", "random_baseline"));
    let iso = geosynth::core::io::read_geometry(path("v_iso.obj")).unwrap();
    assert!(iso.geometry.mesh().unwrap().topology().is_closed_manifold());
    let field = geosynth::sdf::nrrd::read_file(Path::new(&path("v.nrrd"))).unwrap();
    assert_eq!(field.scalar_grid().unwrap().dims(), [24, 24, 24]);
    assert!(image::open(path("v.png")).is_ok());
    // A point set is not a solid: the error says how to make one, and that works.
    let points = path("sphere_points.ply");
    refused(&["voxel", &points, "-o", &path("x.ply")], "geosynth sdf");
    let volume = path("sphere.nrrd");
    ok(&["sdf", &points, "-o", &volume, "--resolution", "20", "-q"]);
    tiny_voxel(Path::new(&volume), &dir.path().join("x.ply"), &["-q"]);
    // A block that is not a power of two is a range error.
    refused(
        &[
            "voxel",
            exemplar.to_str().unwrap(),
            "-o",
            &path("x.ply"),
            "--block",
            "6",
        ],
        "block",
    );
}

#[test]
fn voxel_says_why_a_few_large_triangles_copy_to_nothing() {
    // A unit cube of 12 triangles, faces outward: its solid synthesizes, but no triangle's
    // nearest source sample is picked up by a block, so the copied mesh is empty.
    let dir = tempfile::tempdir().unwrap();
    let cube = dir.path().join("cube.obj");
    let mut obj = String::new();
    for i in 0..8 {
        obj += &format!("v {} {} {}\n", i >> 2 & 1, i >> 1 & 1, i & 1);
    }
    for f in [
        [1, 2, 4],
        [1, 4, 3],
        [5, 7, 8],
        [5, 8, 6],
        [1, 5, 6],
        [1, 6, 2],
        [3, 4, 8],
        [3, 8, 7],
        [1, 3, 7],
        [1, 7, 5],
        [2, 6, 8],
        [2, 8, 4],
    ] {
        obj += &format!("f {} {} {}\n", f[0], f[1], f[2]);
    }
    std::fs::write(&cube, obj).unwrap();
    assert_closed(&cube, 2, "the cube");
    let out = dir.path().join("v.ply");
    let said = ok(&[
        "voxel",
        cube.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--source-res",
        "16",
        "--target-res",
        "20",
        "--levels",
        "1",
        "--block",
        "4",
    ]);
    assert!(said.contains("no source triangle was copied"), "{said}");
    assert!(said.contains("--isosurface writes"), "{said}");
    assert_eq!(info_json(&out)["faces"], 0);
}

#[test]
fn voxel_keeps_georeferenced_exemplars_in_place() {
    use geosynth::core::io::{Geometry, WriteOptions, read_geometry, write_geometry};
    let dir = tempfile::tempdir().unwrap();
    let grid = geosynth::fixtures::volumes::grid(1).unwrap();
    let origin = glam::DVec3::new(5e5, 4e6, 0.0);
    let run = |file: &Path, out: &Path| {
        let run = geosynth(&[
            "voxel",
            file.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--source-res",
            "16",
            "--target-res",
            "24",
            "--levels",
            "2",
            "--block",
            "8",
        ]);
        assert!(run.status.success(), "{run:?}");
        String::from_utf8_lossy(&run.stdout).into_owned()
    };
    // In double precision: synthesized at full precision and written back in place.
    let precise = dir.path().join("precise.ply");
    let out = dir.path().join("out.ply");
    let mesh = Geometry::Mesh(grid.mesh.clone());
    write_geometry(&precise, &mesh, &WriteOptions::default().origin(origin)).unwrap();
    let said = run(&precise, &out);
    assert!(!said.contains("single precision"), "{said}");
    let header = std::fs::read(&out).unwrap();
    assert!(String::from_utf8_lossy(&header[..400]).contains("property double x"));
    let b = read_geometry(&out)
        .unwrap()
        .geometry
        .bounding_box()
        .unwrap();
    assert!(b.min.x > 499_990.0 && b.min.y > 3_999_990.0, "{b:?}");
    assert!(b.max.x < 500_010.0 && b.max.y < 4_000_010.0, "{b:?}");
    // Its signed distance volume (NRRD, origin written at full precision) is an exemplar
    // too: the solid where it is negative, synthesized in place.
    let field = dir.path().join("precise.nrrd");
    ok(&[
        "sdf",
        precise.to_str().unwrap(),
        "-o",
        field.to_str().unwrap(),
        "--resolution",
        "24",
        "-q",
    ]);
    run(&field, &out);
    let b = read_geometry(&out)
        .unwrap()
        .geometry
        .bounding_box()
        .unwrap();
    assert!(b.min.x > 499_990.0 && b.max.y < 4_000_010.0, "{b:?}");
    // In single precision the file has lost its detail (0.25 apart at 4e6); the run says so.
    let shifted: Vec<glam::Vec3> = grid
        .mesh
        .positions()
        .iter()
        .map(|p| *p + origin.as_vec3())
        .collect();
    let coarse = dir.path().join("coarse.ply");
    let coarse_mesh = geosynth::core::TriMesh::new(
        geosynth::core::PointSet::new(shifted).unwrap(),
        grid.mesh.triangles().to_vec(),
    )
    .unwrap();
    write_geometry(
        &coarse,
        &Geometry::Mesh(coarse_mesh),
        &WriteOptions::default(),
    )
    .unwrap();
    let said = run(&coarse, &out);
    assert!(said.contains("single precision, 0.25 apart"), "{said}");
}

#[test]
fn bare_and_open_scans_get_normals_and_trimmed_meshes() {
    use geosynth::core::io::{Geometry, WriteOptions, read_geometry, write_geometry};
    let dir = tempfile::tempdir().unwrap();
    let fixture = geosynth::fixtures::bundled_dir().join("sphere_points.ply");
    let truth = read_geometry(&fixture).unwrap().geometry.points().clone();
    let bare = dir.path().join("bare.ply");
    let positions = geosynth::core::PointSet::new(truth.positions().to_vec()).unwrap();
    write_geometry(
        &bare,
        &Geometry::Points(positions),
        &WriteOptions::default(),
    )
    .unwrap();
    assert!(ok(&["info", bare.to_str().unwrap()]).contains("no (geosynth normals"));
    let with_normals = dir.path().join("with_normals.ply");
    let said = ok(&[
        "normals",
        bare.to_str().unwrap(),
        "-o",
        with_normals.to_str().unwrap(),
    ]);
    assert!(said.contains("0.0% face away"), "{said}");
    let got = read_geometry(&with_normals).unwrap().geometry;
    let got = got.points().normals().unwrap();
    let worst = got
        .iter()
        .zip(truth.normals().unwrap())
        .map(|(a, b)| a.dot(*b))
        .fold(1.0f32, f32::min);
    assert!(worst > 0.95, "least agreement {worst}");
    // Without normals reconstruct refuses and names the remedy; with them it closes.
    let mesh = dir.path().join("mesh.ply");
    refused(
        &["reconstruct", &arg(&bare), "-o", "x.ply"],
        "geosynth normals",
    );
    let said = ok(&[
        "reconstruct",
        with_normals.to_str().unwrap(),
        "-o",
        mesh.to_str().unwrap(),
        "--resolution",
        "32",
    ]);
    assert_closed(&mesh, 2, "a sphere");
    assert!(said.contains("1 component(s), closed"), "{said}");
    assert!(!said.contains("sides of the grid"), "{said}");
    // An open sheet (the bumpy fixture) trimmed: the surface ends near its samples
    // instead of running on to the grid's edge. Untrimmed, the run says why its mesh is
    // open and what to do about it.
    let bumpy = geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply");
    let samples = read_geometry(&bumpy)
        .unwrap()
        .geometry
        .bounding_box()
        .unwrap();
    let reach = |trim: &[&str]| {
        let mut args = vec!["reconstruct", bumpy.to_str().unwrap(), "-o"];
        args.extend([mesh.to_str().unwrap(), "--resolution", "40"]);
        args.extend(trim);
        let said = ok(&args);
        let noted = said.contains("runs out to the sides of the grid") && said.contains("--trim");
        assert_eq!(noted, trim.is_empty(), "{said}");
        let b = read_geometry(&mesh)
            .unwrap()
            .geometry
            .bounding_box()
            .unwrap();
        (samples.min - b.min)
            .max_element()
            .max((b.max - samples.max).max_element())
    };
    let (untrimmed, trimmed) = (reach(&[]), reach(&["--trim"]));
    assert!(untrimmed > 0.4 && trimmed < 0.15, "{untrimmed} / {trimmed}");
    // A mesh is not estimated: its faces give its normals.
    refused(&["normals", &arg(&mesh), "-o", "x.ply"], "is a mesh");
}

#[test]
fn fixtures_command_reproduces_the_committed_files() {
    let dir = tempfile::tempdir().unwrap();
    ok(&["fixtures", "--quiet", "--out", dir.path().to_str().unwrap()]);
    let committed = geosynth::fixtures::bundled_dir();
    for f in geosynth::fixtures::all().unwrap() {
        let a = std::fs::read(dir.path().join(f.file_name())).unwrap();
        let b = std::fs::read(committed.join(f.file_name())).unwrap();
        assert!(a == b, "{} differs", f.file_name());
    }
}

#[test]
fn reconstruct_and_sdf_commands_write_usable_files() {
    let dir = tempfile::tempdir().unwrap();
    let points = geosynth::fixtures::bundled_dir().join("torus_points.ply");
    let mesh = dir.path().join("torus.ply");
    ok(&[
        "reconstruct",
        points.to_str().unwrap(),
        "-o",
        mesh.to_str().unwrap(),
        "--resolution",
        "40",
        "-q",
    ]);
    assert_closed(&mesh, 0, "a torus");
    // The same points with every third normal flipped, as unoriented estimates come: the
    // run warns, the oriented one does not.
    let torus = geosynth::core::io::read_geometry(&points).unwrap().geometry;
    let signs: Vec<glam::Vec3> = torus
        .points()
        .normals()
        .unwrap()
        .iter()
        .enumerate()
        .map(|(i, &n)| if i % 3 == 0 { -n } else { n })
        .collect();
    let mixed = dir.path().join("mixed.ply");
    let unoriented = torus.points().clone().with_normals(signs).unwrap();
    write_with_defaults(&mixed, &geosynth::core::io::Geometry::Points(unoriented));
    let share = |path: &Path| {
        let json = info_json(path);
        json["normal_disagreement"].as_f64().unwrap()
    };
    assert!(share(&points) < 0.05 && share(&mixed) > 0.15);
    let probe = dir.path().join("probe.ply");
    for (input, warned) in [(&points, false), (&mixed, true)] {
        let said = ok(&[
            "reconstruct",
            input.to_str().unwrap(),
            "-o",
            probe.to_str().unwrap(),
            "--resolution",
            "24",
        ]);
        assert_eq!(said.contains("look unoriented"), warned, "{said}");
    }
    // `--orient-normals` repairs them: no note, and the surface is the torus again.
    let said = ok(&[
        "reconstruct",
        mixed.to_str().unwrap(),
        "-o",
        probe.to_str().unwrap(),
        "--resolution",
        "40",
        "--orient-normals",
    ]);
    assert!(!said.contains("look unoriented"), "{said}");
    assert_closed(&probe, 0, "a torus");

    let field = dir.path().join("torus.nrrd");
    ok(&[
        "sdf",
        mesh.to_str().unwrap(),
        "-o",
        field.to_str().unwrap(),
        "--resolution",
        "24",
        "--gradient",
        "-q",
    ]);
    let volume = geosynth::sdf::nrrd::read_file(&field).unwrap();
    assert_eq!(volume.channels, 4);
    assert!(
        volume.data.iter().step_by(4).any(|d| *d < 0.0)
            && volume.data.iter().step_by(4).any(|d| *d > 0.0)
    );
    // info describes the field; render draws its zero level set, a torus like the mesh.
    let json = info_json(&field);
    assert_eq!(json["channels"], 4);
    assert_eq!(json["dims"], serde_json::json!(volume.dims));
    let inside = json["inside_share"].as_f64().unwrap();
    assert!(inside > 0.0 && inside < 0.5, "{json}");
    assert_eq!(json["non_finite"], 0);
    let picture = dir.path().join("field.png");
    ok(&[
        "render",
        field.to_str().unwrap(),
        "-o",
        picture.to_str().unwrap(),
        "--width",
        "160",
        "--height",
        "120",
    ]);
    let drawn = image::open(&picture).unwrap().into_rgb8();
    let covered = drawn.pixels().filter(|p| p.0 != [255, 255, 255]).count();
    assert!(covered > 500, "{covered} pixels drawn");
    // A field that never crosses zero, or holds NaN, has no surface: an error, not a blank.
    let header =
        b"NRRD0004\ntype: float\nsizes: 2 2 2\nencoding: raw\nspacings: 1 1 1\n\n".to_vec();
    for (name, last) in [("positive.nrrd", 1.0f32), ("nan.nrrd", f32::NAN)] {
        let path = dir.path().join(name);
        let mut bytes = header.clone();
        for k in 0..8 {
            let v = if k == 7 { last } else { 1.0 };
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        std::fs::write(&path, &bytes).unwrap();
        let out = geosynth(&[
            "render",
            path.to_str().unwrap(),
            "-o",
            picture.to_str().unwrap(),
        ]);
        assert!(!out.status.success(), "{name}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("no surface to draw") && !err.contains("panicked"),
            "{err}"
        );
    }

    let bad = geosynth(&[
        "reconstruct",
        points.to_str().unwrap(),
        "-o",
        "x.ply",
        "--resolution",
        "2",
    ]);
    assert!(!bad.status.success());
    let bare = dir.path().join("bare.ply");
    std::fs::write(&bare, b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n").unwrap();
    let out = geosynth(&["reconstruct", bare.to_str().unwrap(), "-o", "x.ply"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("normals"));
}

#[test]
fn warp_moves_points_through_the_pairs_and_turns_normals() {
    let dir = tempfile::tempdir().unwrap();
    let pairs = dir.path().join("pairs.txt");
    // A rotation by 90° about +z given by five pairs (not coplanar).
    std::fs::write(
        &pairs,
        "# rotation about z\n1 0 0  0 1 0\n0 1 0  -1 0 0\n-1 0 0  0 -1 0\n0 0 1  0 0 1\n0 0 -1  0 0 -1\n",
    )
    .unwrap();
    let input = geosynth::fixtures::bundled_dir().join("sphere_points.ply");
    let out = dir.path().join("warped.ply");
    ok(&[
        "warp",
        input.to_str().unwrap(),
        "--pairs",
        pairs.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "-q",
    ]);
    let before = geosynth::core::io::read_geometry(&input).unwrap().geometry;
    let after = geosynth::core::io::read_geometry(&out).unwrap().geometry;
    let (p0, p1) = (before.points(), after.points());
    for i in (0..p0.len()).step_by(37) {
        let (a, b) = (p0.positions()[i], p1.positions()[i]);
        assert!((b - glam::Vec3::new(-a.y, a.x, a.z)).length() < 1e-4);
        let (n0, n1) = (p0.normals().unwrap()[i], p1.normals().unwrap()[i]);
        assert!((n1 - glam::Vec3::new(-n0.y, n0.x, n0.z)).length() < 1e-4);
    }
    // Meshes keep their faces.
    let mesh_in = geosynth::fixtures::bundled_dir().join("torus_mesh.ply");
    let mesh_out = dir.path().join("torus_warped.obj");
    ok(&[
        "warp",
        mesh_in.to_str().unwrap(),
        "--pairs",
        pairs.to_str().unwrap(),
        "-o",
        mesh_out.to_str().unwrap(),
        "-q",
    ]);
    let json = info_json(&mesh_out);
    assert_eq!(json["faces"], 48 * 24 * 2);
    // Bad pairs files fail with the line.
    std::fs::write(&pairs, "1 0 0 0 1 0\n1 2 3\n").unwrap();
    let args = [
        "warp",
        &arg(&input),
        "--pairs",
        &arg(&pairs),
        "-o",
        &arg(&out),
    ];
    refused(&args, "pairs.txt:2");
    // So do pairs that leave one point for two places, naming both lines.
    std::fs::write(&pairs, "1 0 0 0 1 0\n# moved\n1 0 0 0 2 0\n").unwrap();
    refused(&args, "pairs.txt:1 and 3: both pairs start at one point");
    // Targets so far that the warped points leave single precision are refused, and
    // nothing is written.
    std::fs::write(&pairs, "0 0 0 0 0 3e38\n1 0 0 1 0 0\n0 1 0 0 1 0\n").unwrap();
    let fresh = dir.path().join("never.ply");
    let args = [
        "warp",
        &arg(&input),
        "--pairs",
        &arg(&pairs),
        "-o",
        &arg(&fresh),
    ];
    refused(&args, "beyond single precision");
    assert!(!fresh.exists());
}

#[test]
fn quilt_also_writes_the_sheet_as_a_mesh() {
    let dir = Scratch::new();
    let exemplar = arg(&geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply"));
    let (out, mesh, report) = (
        arg(&dir.path("q.ply")),
        arg(&dir.path("q_mesh.obj")),
        arg(&dir.path("q.json")),
    );
    let quilt = |mesh: &str| {
        geosynth(&[
            "quilt",
            &exemplar,
            "-o",
            &out,
            "--scale",
            "1.3",
            "--resolution",
            "24",
            "--no-quality",
            "--mesh",
            mesh,
            "--report",
            &report,
        ])
    };
    let said = quilt(&mesh);
    assert!(
        said.status.success(),
        "{}",
        String::from_utf8_lossy(&said.stderr)
    );
    let points = geosynth::core::io::read_geometry(Path::new(&out))
        .unwrap()
        .geometry;
    let sheet = match geosynth::core::io::read_geometry(Path::new(&mesh))
        .unwrap()
        .geometry
    {
        geosynth::core::io::Geometry::Mesh(m) => m,
        geosynth::core::io::Geometry::Points(_) => panic!("a mesh was written"),
    };
    // An open sheet cut back to the points: open edges, nothing far beyond the points.
    let topology = sheet.topology();
    assert!(
        sheet.face_count() > 1000 && topology.boundary_edges > 0,
        "{topology:?}"
    );
    let (inner, outer) = (
        points.points().bounding_box().unwrap(),
        sheet.bounding_box().unwrap(),
    );
    assert!(inner.inflated(0.2).contains(outer.min) && inner.inflated(0.2).contains(outer.max));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["mesh"]["faces"].as_u64(), Some(sheet.face_count() as u64));
    assert!(
        r["mesh"]["resolution"].as_u64().unwrap() >= 32,
        "{}",
        r["mesh"]
    );
    // The mesh may not overwrite the points, and must go to a format that stores faces.
    for (bad, why) in [
        (out.as_str(), "twice"),
        (&arg(&dir.path("q_mesh.txt")), "must end in"),
        (&arg(&dir.path("q_mesh.xyz")), "holds points only"),
    ] {
        let refused = quilt(bad);
        let err = String::from_utf8_lossy(&refused.stderr);
        assert!(
            !refused.status.success() && err.contains(why),
            "{bad}: {err}"
        );
    }
    // No command writes two of its outputs to one path.
    let torus = arg(&geosynth::fixtures::bundled_dir().join("torus_mesh.ply"));
    let same = arg(&dir.path(".").join("q_mesh.obj"));
    refused(
        &["voxel", &torus, "-o", &mesh, "--isosurface", &same],
        "twice",
    );
}

#[test]
fn quilt_writes_output_report_with_baselines_and_preview() {
    let dir = tempfile::tempdir().unwrap();
    let exemplar = geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply");
    let (out, report, preview) = (
        dir.path().join("q.ply"),
        dir.path().join("q.json"),
        dir.path().join("q.png"),
    );
    let args = [
        "quilt",
        exemplar.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--scale",
        "1.3",
        "--resolution",
        "24",
        "--baselines",
        "--preview",
        preview.to_str().unwrap(),
        "--seed",
        "3",
        "--epsilon",
        "0.2",
    ];
    let summary = ok(&[&args[..], &["--report", report.to_str().unwrap()]].concat());
    // Without a report the baselines still run, and the summary is the same but for the
    // run's time ("…, 0.10s; neighbourhood error …").
    let untimed = |said: &str| -> Vec<String> {
        said.lines()
            .map(|l| l.split_once("s; ").map_or(l, |(_, rest)| rest).to_string())
            .collect()
    };
    let without_report = ok(&args);
    assert_eq!(
        untimed(&without_report),
        untimed(&summary),
        "{without_report}"
    );
    assert_eq!(summary.lines().count(), 4, "{summary}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    // The summary gives every run's errors, as the report has them, one line each.
    for (key, label) in [
        ("run", "wrote "),
        ("search_only", "  search only: "),
        ("random_placement", "  random placement: "),
        ("same_layout_pasted", "  full's layout, pasted: "),
    ] {
        let quality = &r[key]["quality"];
        let expected = format!(
            "neighbourhood error {:.3}, seam error {:.3}",
            quality["neighbourhood_error"].as_f64().unwrap(),
            quality["seam_error"].as_f64().unwrap()
        );
        let line = summary.lines().find(|l| l.starts_with(label));
        assert!(
            line.is_some_and(|l| l.ends_with(&format!("{expected})")) || l.ends_with(&expected)),
            "{key}: {expected} in {summary}"
        );
    }
    // The report records the parameters the run used, the given ones and the defaults.
    let params = &r["params"];
    assert_eq!(params["seed"], 3);
    assert_eq!(params["field_resolution"], 24);
    assert!(
        (params["epsilon"].as_f64().unwrap() - 0.2).abs() < 1e-6,
        "{params}"
    );
    assert!((params["output"]["scale"].as_f64().unwrap() - 1.3).abs() < 1e-6);
    assert_eq!(params["method"], "full");
    assert_eq!(params["pairing"]["w_p"], 1.0);
    assert!(params["pairing"]["w_v"].as_f64().unwrap() > 0.0);
    for run in [
        "run",
        "search_only",
        "random_placement",
        "same_layout_pasted",
    ] {
        assert!(
            r[run]["quality"]["neighbourhood_error"].as_f64().unwrap() >= 0.0,
            "{run}"
        );
        assert!(r[run]["patches"].as_u64().unwrap() > 1);
    }
    let stages: Vec<&str> = r["run"]["timings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["stage"].as_str().unwrap())
        .collect();
    for s in ["search", "warp", "blend", "other"] {
        assert!(stages.contains(&s), "{s} in {stages:?}");
    }
    // The warp's largest move of a point that can still land is one of its moves, and
    // the patches fitted twice for stretch are some of the patches.
    let moved = &r["run"]["warp_displacement"];
    let largest = |k: &str| moved[k].as_f64().unwrap();
    assert!(largest("max_landing") > 0.0, "{moved}");
    assert!(largest("max_landing") <= largest("max"), "{moved}");
    assert!(
        r["run"]["warps_restrained"].as_u64().unwrap() <= r["run"]["patches"].as_u64().unwrap()
    );
    // Step 5's counts: the full run blends, the baselines do not; every blended point is
    // accounted for by exactly one outcome.
    let blend = &r["run"]["blend"];
    let count = |k: &str| blend[k].as_u64().unwrap();
    assert!(count("blended_points") > 0, "{blend}");
    assert_eq!(
        count("blended_points"),
        [
            "by_ray",
            "by_projection",
            "unmatched",
            "beyond_reach",
            "facing_away"
        ]
        .iter()
        .map(|k| count(k))
        .sum::<u64>(),
        "{blend}"
    );
    assert_eq!(r["search_only"]["blend"]["blended_points"], 0);
    assert!(image::open(&preview).is_ok());
    // The output keeps its box in the comments and can be quilted again, here with the
    // surface-gap warp targets.
    let again = dir.path().join("q2.ply");
    let again_report = dir.path().join("q2.json");
    ok(&[
        "quilt",
        out.to_str().unwrap(),
        "-o",
        again.to_str().unwrap(),
        "--scale",
        "1.1",
        "--resolution",
        "20",
        "--warp-targets",
        "surface-gap",
        "--report",
        again_report.to_str().unwrap(),
        "-q",
    ]);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&again_report).unwrap()).unwrap();
    assert!(r["run"]["dropped_pairs"].is_u64(), "{}", r["run"]);
    assert!(
        r["run"]["warps_skipped"].as_u64().unwrap() + 1 < r["run"]["patches"].as_u64().unwrap(),
        "{}",
        r["run"]
    );
    // An output too narrow for a quality window is still written; the report says why it
    // has no quality figures.
    let narrow = dir.path().join("narrow.ply");
    ok(&[
        "quilt",
        exemplar.to_str().unwrap(),
        "-o",
        narrow.to_str().unwrap(),
        "--size",
        "0.1,2",
        "--report",
        report.to_str().unwrap(),
        "-q",
    ]);
    assert!(narrow.exists());
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let reason = r["run"]["quality"]["not_measured"].as_str().unwrap();
    assert!(reason.contains("quality window"), "{reason}");
    // Height fields work directly; `--no-quality` skips the measure and the report says so.
    let hf = dir.path().join("bumps_64x64.f32le");
    let heights: Vec<u8> = (0..64 * 64)
        .flat_map(|i| (((i % 64) as f32 * 0.4).sin() * ((i / 64) as f32 * 0.3).cos()).to_le_bytes())
        .collect();
    std::fs::write(&hf, heights).unwrap();
    ok(&[
        "quilt",
        "--heightfield",
        hf.to_str().unwrap(),
        "-o",
        again.to_str().unwrap(),
        "--resolution",
        "20",
        "--no-quality",
        "--report",
        report.to_str().unwrap(),
        "-q",
    ]);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let reason = r["run"]["quality"]["not_measured"].as_str().unwrap();
    assert!(reason.contains("--no-quality"), "{reason}");
    assert!(r["run"]["patches"].as_u64().unwrap() > 1, "{}", r["run"]);
    // `--relief` sets the height range: three times the default's relief, three times
    // the exemplar's height range (the box's height widens by the same factor).
    let steep = dir.path().join("steep.ply");
    ok(&[
        "quilt",
        "--heightfield",
        hf.to_str().unwrap(),
        "-o",
        steep.to_str().unwrap(),
        "--resolution",
        "20",
        "--relief",
        "0.3",
        "--no-quality",
        "-q",
    ]);
    let z_range = |path: &Path| {
        let points = geosynth::core::io::read_geometry(path).unwrap().geometry;
        let z: Vec<f32> = points.points().positions().iter().map(|p| p.z).collect();
        z.iter().copied().fold(f32::MIN, f32::max) - z.iter().copied().fold(f32::MAX, f32::min)
    };
    let ratio = z_range(&steep) / z_range(&again);
    assert!(
        (2.5..3.5).contains(&ratio),
        "relief 0.3 against 0.1: ratio {ratio}"
    );
    // A constant height field quilts, and its report says the errors mean nothing there.
    let level = dir.path().join("level_40x40.f32le");
    std::fs::write(&level, vec![0u8; 40 * 40 * 4]).unwrap();
    let said = ok(&[
        "quilt",
        "--heightfield",
        level.to_str().unwrap(),
        "-o",
        again.to_str().unwrap(),
        "--resolution",
        "20",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(said.contains("no relief"), "{said}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(
        r["run"]["quality"]["featureless_exemplar"], true,
        "{}",
        r["run"]
    );
    // Bad parameters, and baselines whose results would land nowhere: without a report
    // only their errors are printed, which --no-quality skips and --quiet hides (an
    // error, not minutes of work thrown away).
    for (extra, message) in [
        (&["--patch", "2"][..], "patch_size"),
        (&["--epsilon=-0.5"][..], "epsilon"),
        (&["--cluster-points", "0"][..], "max_points"),
        (
            &["--baselines", "--no-quality"][..],
            "--no-quality skips them",
        ),
        (&["--baselines", "-q"][..], "--quiet hides them"),
        (&["--relief", "0.3"][..], "--relief"),
    ] {
        let mut args = vec![
            "quilt",
            exemplar.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        refused(&args, message);
    }
}

#[test]
fn quilt_writes_a_height_field_back_as_one() {
    let dir = Scratch::new();
    // Ridges 40..46 units high: a raw file keeps those units, a PNG stores 0..1.
    let hf = dir.path("ridges_60x48.f32le");
    let heights: Vec<u8> = (0..60 * 48)
        .flat_map(|i| (43.0 + 3.0 * ((i % 60) as f32 * 0.35).sin()).to_le_bytes())
        .collect();
    std::fs::write(&hf, heights).unwrap();
    let (out, report) = (dir.path("out.ply"), dir.path("r.json"));
    let quilt_into = |map: &Path| quilt_height_field_into(&hf, map, &out, &report);
    let said = quilt_into(&dir.path("map.f32le"));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let entry = &r["heightfield_out"];
    let (w, h) = (
        entry["width"].as_u64().unwrap(),
        entry["height"].as_u64().unwrap(),
    );
    // The box spans the samples but 8 of padding on each side (43 × 31 spacings); the
    // output twice that at the default scale, sampled at the input's spacing.
    assert_eq!((w, h), (87, 63), "{entry}");
    let written = dir.path(&format!("map_{w}x{h}.f32le"));
    assert_eq!(entry["path"].as_str().unwrap(), arg(&written));
    assert!(said.contains(&arg(&written)), "{said}");
    let sampled = ["by_ray", "by_projection", "filled"]
        .map(|k| entry[k].as_u64().unwrap())
        .iter()
        .sum::<u64>();
    assert_eq!(sampled, w * h, "{entry}");
    assert!(
        entry["by_ray"].as_u64().unwrap() > w * h * 9 / 10,
        "{entry}"
    );
    let map = geosynth::imagery::read_heightfield(&written).unwrap();
    let (lo, hi) = map.range();
    assert!(lo > 39.9 && hi < 46.1 && hi - lo > 5.0, "{lo}..{hi}");
    // The same run into a PNG: heights beyond 0..1 are clamped, and it says so.
    let png = dir.path("map.png");
    let said = quilt_into(&png);
    assert!(said.contains("clamped"), "{said}");
    let map = geosynth::imagery::read_heightfield(&png).unwrap();
    assert_eq!((map.width() as u64, map.height() as u64), (w, h));
    // A grid spacing or a grey scale for a height field's map, and a format it cannot
    // write: errors, and nothing written.
    let point_set = dir.path("sheet.ply");
    let (hf, point_set_arg, png) = (arg(&hf), arg(&point_set), arg(&png));
    let jpeg = arg(&dir.path("map.jpg"));
    for (extra, message) in [
        (
            [&png, "--map-spacing", "0.1"].as_slice(),
            "input's own grid",
        ),
        (
            &[&png, "--map-range", "0,2"],
            "keeps the input's grey levels",
        ),
        (&[&jpeg], ".f32le"),
    ] {
        let mut args = vec!["quilt", "--heightfield", &hf, "-o", &point_set_arg];
        args.push("--heightfield-out");
        args.extend_from_slice(extra);
        refused(&args, message);
        assert!(!point_set.exists());
    }
}

/// A report's `[x, y, z]`.
fn json_vector(v: &serde_json::Value) -> glam::DVec3 {
    glam::DVec3::new(
        v[0].as_f64().unwrap(),
        v[1].as_f64().unwrap(),
        v[2].as_f64().unwrap(),
    )
}

/// How far the samples of the height map a quilt report's `entry` describes lie from the
/// points of the quilt written to `output`, placed by the entry's grid (every 7th sample:
/// median, 90th percentile); as a control, with the map's rows read upside down.
fn map_misses(entry: &serde_json::Value, output: &Path, upside_down: bool) -> (f64, f64) {
    use geosynth::core::KdIndex;
    use geosynth::core::io::{ReadOptions, read_geometry_with};
    let map =
        geosynth::imagery::read_heightfield(Path::new(entry["path"].as_str().unwrap())).unwrap();
    let (w, h) = (map.width(), map.height());
    let written = read_geometry_with(output, &ReadOptions::default().recentre_far(true)).unwrap();
    let index = KdIndex::new(written.geometry.points().positions()).unwrap();
    let corner = json_vector(&entry["lower_corner"]);
    let [columns, rows, up] =
        ["columns_axis", "rows_axis", "up_axis"].map(|k| json_vector(&entry[k]));
    let spacing = entry["spacing"].as_f64().unwrap();
    let mut misses: Vec<f64> = (0..w * h)
        .step_by(7)
        .map(|k| {
            let (c, r) = (k % w, k / w);
            let up_row = if upside_down { r } else { h - 1 - r };
            let height = f64::from(map.get(c, r).unwrap());
            let file = corner + spacing * (c as f64 * columns + up_row as f64 * rows) + height * up;
            let nearest = index
                .nearest_one((file - written.origin).as_vec3())
                .unwrap()
                .unwrap();
            f64::from(nearest.distance_squared).sqrt()
        })
        .collect();
    misses.sort_by(f64::total_cmp);
    (misses[misses.len() / 2], misses[misses.len() * 9 / 10])
}

/// The text of the `index`th sidecar file a report's height map `entry` lists, after
/// checking that its name is the map's with `suffix` in place of the extension.
fn sidecar_text(entry: &serde_json::Value, index: usize, suffix: &str) -> String {
    let map = Path::new(entry["path"].as_str().unwrap());
    let path = entry["sidecars"][index].as_str().unwrap();
    assert_eq!(
        Path::new(path),
        map.with_extension("").with_extension(&suffix[1..])
    );
    std::fs::read_to_string(path).unwrap()
}

/// The numbers in `text`, split at `separator`.
fn numbers(text: &str, separator: char) -> Vec<f64> {
    text.split(separator)
        .filter(|t| !t.trim().is_empty())
        .map(|t| t.trim().parse().unwrap())
        .collect()
}

/// Asserts that `got` equals `expected` to within `tolerance` (the report writes
/// single-precision numbers as their shortest decimals, the sidecars their exact values).
fn assert_close(got: &[f64], expected: &[f64], tolerance: f64) {
    assert!(
        got.len() == expected.len()
            && got
                .iter()
                .zip(expected)
                .all(|(g, e)| (g - e).abs() <= tolerance),
        "{got:?} against {expected:?}"
    );
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

#[test]
fn quilt_writes_a_point_sets_height_map_where_its_points_are() {
    use geosynth::core::PointSet;
    use geosynth::core::io::{Geometry, WriteOptions};
    use glam::{DVec3, Vec3};
    let dir = Scratch::new();
    let bumpy = geosynth::core::io::read_geometry(
        geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply"),
    )
    .unwrap()
    .geometry;
    // The bumpy fixture without its comments, its positions and normals mapped by `map`,
    // written relative to `origin` in double precision.
    let write_mapped = |name: &str, map: &dyn Fn(Vec3) -> Vec3, origin: DVec3| {
        let points = bumpy.points();
        let mapped = PointSet::new(points.positions().iter().map(|&p| map(p)).collect())
            .unwrap()
            .with_normals(points.normals().unwrap().iter().map(|&n| map(n)).collect())
            .unwrap();
        let path = dir.path(name);
        let options = WriteOptions::default().origin(origin);
        geosynth::core::io::write_geometry(&path, &Geometry::Points(mapped), &options).unwrap();
        path
    };
    let out = dir.path("out.ply");
    let report = dir.path("r.json");
    // A small quilt of `exemplar` with its map written to `map`; the map's entry.
    let quilt = |exemplar: &Path, map: &Path, extra: &[&str]| {
        let mut args = vec![
            "quilt".to_string(),
            arg(exemplar),
            "-o".into(),
            arg(&out),
            "--scale".into(),
            "1.2".into(),
            "--resolution".into(),
            "24".into(),
            "--no-quality".into(),
            "--heightfield-out".into(),
            arg(map),
            "--report".into(),
            arg(&report),
        ];
        args.extend(extra.iter().map(|a| a.to_string()));
        ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
        height_map_entry(&report)
    };
    // Georeferenced, 1000 units up: the map's heights are the file's z, and every sample
    // of it lies on the written output's sheet where the report's grid puts it.
    let origin = DVec3::new(5e5, 4e6, 1000.0);
    let far = write_mapped("far.ply", &|v| v, origin);
    let entry = quilt(&far, &dir.path("far.f32le"), &[]);
    let (w, h) = (
        entry["width"].as_u64().unwrap() as usize,
        entry["height"].as_u64().unwrap() as usize,
    );
    let map =
        geosynth::imagery::read_heightfield(Path::new(entry["path"].as_str().unwrap())).unwrap();
    assert_eq!((map.width(), map.height()), (w, h));
    let (lo, hi) = map.range();
    assert!(lo > 999.9 && hi < 1000.6 && hi - lo > 0.3, "{lo}..{hi}");
    let axes = ["columns_axis", "rows_axis", "up_axis"].map(|k| json_vector(&entry[k]));
    assert_eq!(axes, [DVec3::X, DVec3::Y, DVec3::Z]);
    let spacing = entry["spacing"].as_f64().unwrap();
    // The fixture holds about 300 samples per unit area.
    assert!((spacing * 300f64.sqrt() - 1.0).abs() < 0.1, "{spacing}");
    // Samples scattered at random: a point of their sheet is about half a grid spacing
    // from the nearest. Measured: 0.52 and 0.97 spacings; upside down, the tail is 2.7.
    let (median, tail) = map_misses(&entry, &out, false);
    assert!(
        median < 0.75 * spacing && tail < 1.5 * spacing,
        "{median}, {tail}"
    );
    let (_, flipped_tail) = map_misses(&entry, &out, true);
    assert!(flipped_tail > 2.0 * spacing, "{flipped_tail}");
    // Its ENVI header gives GIS tools the raw file's layout and, ENVI's pixel (1.5, 1.5)
    // being the top-left sample's centre, the report's grid.
    let corner = json_vector(&entry["lower_corner"]);
    let top_left = [corner.x, corner.y + spacing * (h - 1) as f64];
    let header = sidecar_text(&entry, 0, ".f32le.hdr");
    for line in [format!("samples = {w}"), format!("lines = {h}")] {
        assert!(header.lines().any(|l| l == line), "{line} in {header}");
    }
    let map_info = header
        .lines()
        .find_map(|l| l.strip_prefix("map info = {Arbitrary, 1.5, 1.5, "))
        .unwrap();
    let placed = numbers(map_info.trim_end_matches('}'), ',');
    let expected = [top_left[0], top_left[1], spacing, spacing];
    assert_close(&placed, &expected, 1e-6);
    // The same run into a GeoTIFF: every height of the raw map, its place inside the file
    // (CI's interop check has GDAL read it), nothing beside it.
    let entry = quilt(&far, &dir.path("far.tif"), &[]);
    let tiff = geosynth::imagery::read_heightfield(&dir.path("far.tif")).unwrap();
    assert_eq!(tiff, map);
    assert_eq!(entry["georeferenced"], true);
    assert_eq!(entry["sidecars"], serde_json::json!([]));
    // Tilted by 35° about (1, 1, 0) and moved: quilted in its fitted plane (`--up auto`),
    // mapped along that plane's normal, and placed back where its points are.
    let turn = glam::Quat::from_axis_angle(Vec3::new(1.0, 1.0, 0.0).normalize(), 0.61);
    let tilted = write_mapped("tilted.ply", &|v| turn * v, DVec3::new(10.0, -3.0, 7.0));
    let entry = quilt(&tilted, &dir.path("tilted.f32le"), &["--up", "auto"]);
    let up = json_vector(&entry["up_axis"]);
    let angle = up.angle_between((turn * Vec3::Z).as_dvec3()).to_degrees();
    assert!(
        angle < 2.0,
        "the map's heights run {angle}° off the sheet's normal"
    );
    let (median, tail) = map_misses(&entry, &out, false);
    assert!(
        median < 0.75 * spacing && tail < 1.5 * spacing,
        "{median}, {tail}"
    );
    // A tilted grid has no place in the file's x–y plane: its header says only the layout.
    assert_eq!(entry["georeferenced"], false);
    assert!(!sidecar_text(&entry, 0, ".f32le.hdr").contains("map info"));
    // The same run into a PNG: grey levels span the map's range, which the report gives.
    let entry = quilt(&far, &dir.path("far.png"), &[]);
    let range = &entry["png_range"];
    let (a, b) = (range[0].as_f64().unwrap(), range[1].as_f64().unwrap());
    assert!((a - f64::from(lo)).abs() < 1e-3 && (b - f64::from(hi)).abs() < 1e-3);
    let grey = geosynth::imagery::read_heightfield(&dir.path("far.png")).unwrap();
    let worst = grey
        .heights()
        .iter()
        .zip(map.heights())
        .map(|(&g, &m)| (a + f64::from(g) * (b - a) - f64::from(m)).abs())
        .fold(0.0, f64::max);
    assert!(worst < (b - a) / 65535.0 + 1e-3, "{worst}");
    assert_eq!(entry["clamped"], 0);
    // Beside it, a world file with the same grid, and GDAL's scale and offset from grey
    // levels to the report's range.
    let world = numbers(&sidecar_text(&entry, 0, ".pgw"), '\n');
    let expected = [spacing, 0.0, 0.0, -spacing, top_left[0], top_left[1]];
    assert_close(&world, &expected, 1e-6);
    let aux = sidecar_text(&entry, 1, ".png.aux.xml");
    let tag = |name: &str| -> f64 {
        let (_, rest) = aux.split_once(&format!("<{name}>")).unwrap();
        rest.split_once('<').unwrap().0.parse().unwrap()
    };
    // At 1000 units up, single precision's step is 6e-5.
    let ends = [tag("Offset"), tag("Offset") + 65535.0 * tag("Scale")];
    assert_close(&ends, &[a, b], 1e-4);
    // A grey scale of one's own, which several runs' PNGs can share: the heights beyond
    // it are clamped and counted, and the report and the aux.xml give it.
    let (lo_given, hi_given) = (999.95f32, 1000.3f32);
    let entry = quilt(
        &far,
        &dir.path("fixed.png"),
        &["--map-range", "999.95,1000.3"],
    );
    assert_eq!(entry["png_range"], serde_json::json!([999.95, 1000.3]));
    let beyond = map
        .heights()
        .iter()
        .filter(|h| !(lo_given..=hi_given).contains(*h))
        .count();
    assert!(
        beyond > 0 && entry["clamped"] == beyond,
        "{beyond}: {entry}"
    );
    let aux = sidecar_text(&entry, 1, ".png.aux.xml");
    assert!(aux.contains("<Offset>999.95</Offset>"), "{aux}");
    // Stood up as a Y-up tool writes it (up is y, the plane's axes z and x): the same
    // quilt, so the same map, and the report's axes say where it lies.
    let z_up = write_mapped("z_up.ply", &|v| v, DVec3::ZERO);
    let y_up = write_mapped("y_up.ply", &|v| Vec3::new(v.y, v.z, v.x), DVec3::ZERO);
    let entry = quilt(&z_up, &dir.path("z_up.f32le"), &[]);
    let z_map = std::fs::read(entry["path"].as_str().unwrap()).unwrap();
    let entry = quilt(&y_up, &dir.path("y_up.f32le"), &["--up", "y"]);
    let y_map = std::fs::read(entry["path"].as_str().unwrap()).unwrap();
    assert!(z_map == y_map, "a Y-up exemplar gives another map");
    let axes = ["columns_axis", "rows_axis", "up_axis"].map(|k| json_vector(&entry[k]));
    assert_eq!(axes, [DVec3::Z, DVec3::X, DVec3::Y]);
    // A grid spacing of one's own choosing.
    let entry = quilt(&z_up, &dir.path("coarse.f32le"), &["--map-spacing", "0.25"]);
    assert_eq!(entry["spacing"], 0.25);
    assert!((w as f64 * spacing / 0.25 - entry["width"].as_f64().unwrap()).abs() < 2.0);
    // A spacing that is no length, one that gives a map too large or too small to write,
    // or one without a map to set: errors before the quilt.
    let unwritten = dir.path("unwritten.ply");
    for (extra, message) in [
        (
            &["--heightfield-out", "m.f32le", "--map-spacing=-1"][..],
            "map spacing",
        ),
        (
            &["--heightfield-out", "m.f32le", "--map-spacing", "1e-4"][..],
            "at most 67108864 samples",
        ),
        (
            &["--heightfield-out", "m.f32le", "--map-spacing", "100"][..],
            "at least 2 × 2 samples",
        ),
        (&["--map-spacing", "0.25"][..], "--heightfield-out"),
        (
            &["--heightfield-out", "m.f32le", "--map-range", "0,1"][..],
            "a .f32le or .tif map keeps every height",
        ),
        (
            &["--heightfield-out", "m.tif", "--map-range", "0,1"][..],
            "a .f32le or .tif map keeps every height",
        ),
        (
            &["--heightfield-out", "m.png", "--map-range", "1,0"][..],
            "LO < HI",
        ),
    ] {
        let mut args = vec![
            "quilt",
            z_up.to_str().unwrap(),
            "-o",
            unwritten.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        refused(&args, message);
        assert!(!unwritten.exists());
    }
}

#[test]
fn a_map_mostly_over_gaps_says_so() {
    let dir = Scratch::new();
    let (out, map, report) = (dir.path("out.ply"), dir.path("m.f32le"), dir.path("r.json"));
    let note = "of the map lies over gaps";
    for (fixture, gaps) in [("quilt_chain_mail.ply", true), ("quilt_bumpy.ply", false)] {
        let exemplar = geosynth::fixtures::bundled_dir().join(fixture);
        let printed = ok(&[
            "quilt",
            &arg(&exemplar),
            "-o",
            &arg(&out),
            "--resolution",
            "24",
            "--no-quality",
            "--heightfield-out",
            &arg(&map),
            "--report",
            &arg(&report),
        ]);
        let entry = height_map_entry(&report);
        let samples = entry["width"].as_f64().unwrap() * entry["height"].as_f64().unwrap();
        let share = entry["filled"].as_f64().unwrap() / samples;
        // Measured at the default scale and seed: 39% of the chain mail's, 11% of bumpy's.
        assert_eq!(share > 0.2, gaps, "{fixture}: {share}");
        assert_eq!(printed.contains(note), gaps, "{fixture}: {printed}");
    }
}

#[test]
fn a_height_fields_points_quilt_to_its_own_map_in_world_units() {
    use geosynth::core::io::{Geometry, WriteOptions, write_geometry};
    use geosynth::quilt::{read_heightfield_texture_framed, texture_comments};
    let dir = Scratch::new();
    // Bumps 12..20 units high, and the same samples as a point set whose comments give
    // the texture's box: one texture, read two ways.
    let hf = dir.path("bumps_56x44.f32le");
    let heights: Vec<u8> = (0..56 * 44)
        .flat_map(|i| {
            let (c, r) = ((i % 56) as f32, (i / 56) as f32);
            (16.0 + 4.0 * (0.45 * c).sin() * (0.3 * r).cos()).to_le_bytes()
        })
        .collect();
    std::fs::write(&hf, heights).unwrap();
    let (texture, frame) = read_heightfield_texture_framed(&hf, 0.1).unwrap();
    let ply = dir.path("bumps.ply");
    let mut options = WriteOptions::default();
    for line in texture_comments(&texture.canonical_bounds(), texture.up()) {
        options = options.comment(line);
    }
    let points = Geometry::Points(texture.canonical_points().clone());
    write_geometry(&ply, &points, &options).unwrap();
    let out = dir.path("out.ply");
    let quilt = |input: &[&str], map: &Path| {
        let mut args = input.to_vec();
        let (out, map) = (arg(&out), arg(map));
        args.extend(["-o", &out, "--resolution", "20", "--no-quality"]);
        args.extend(["--heightfield-out", &map]);
        ok(&args);
        std::fs::read(&out).unwrap()
    };
    let from_field = quilt(
        &["quilt", "--heightfield", &arg(&hf)],
        &dir.path("field.f32le"),
    );
    let spacing = frame.spacing.to_string();
    let point_args = ["quilt", &arg(&ply), "--map-spacing", &spacing];
    let from_points = quilt(&point_args, &dir.path("points.f32le"));
    assert!(from_field == from_points, "the two readings quilt alike");
    // The same output sampled on the same grid: the field's map in file units, the
    // points' in world units, `scale` times as large.
    let maps = ["field", "points"].map(|name| {
        let found = std::fs::read_dir(dir.0.path())
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| {
                let file = p.file_name().unwrap().to_str().unwrap();
                file.starts_with(name) && file.ends_with(".f32le")
            })
            .unwrap();
        geosynth::imagery::read_heightfield(&found).unwrap()
    });
    let [field, points] = &maps;
    assert_eq!(
        (field.width(), field.height()),
        (points.width(), points.height())
    );
    let worst = field
        .heights()
        .iter()
        .zip(points.heights())
        .map(|(f, p)| (f * frame.scale - p).abs())
        .fold(0.0, f32::max);
    let (lo, hi) = points.range();
    assert!(worst <= 1e-5 * (hi - lo), "{worst} of {lo}..{hi}");
}

#[test]
fn quilt_reads_a_y_up_exemplar_when_told_and_hints_at_trouble() {
    use geosynth::core::PointSet;
    use geosynth::core::io::{Geometry, WriteOptions, read_geometry, write_geometry};
    let dir = tempfile::tempdir().unwrap();
    let bumpy = read_geometry(geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply"))
        .unwrap()
        .geometry;
    // The bumpy fixture with positions (and normals, when `turn`) mapped, no comments.
    let write_mapped = |name: &str, map: &dyn Fn(glam::Vec3) -> glam::Vec3, turn: bool| {
        let points = bumpy.points();
        let normals = points.normals().unwrap().iter();
        let mapped = PointSet::new(points.positions().iter().map(|&p| map(p)).collect())
            .unwrap()
            .with_normals(normals.map(|&n| if turn { map(n) } else { n }).collect())
            .unwrap();
        let path = dir.path().join(name);
        let geometry = Geometry::Points(mapped);
        write_geometry(&path, &geometry, &WriteOptions::default()).unwrap();
        path
    };
    // As a Y-up tool writes it: (x, y, z) → (x, z, −y).
    let exemplar = write_mapped("y_up.ply", &|v| glam::Vec3::new(v.x, v.z, -v.y), true);
    let out = dir.path().join("out.ply");
    // A small quilt of `path`, read with up axis `up`.
    let run = |path: &Path, up: &str| {
        geosynth(&[
            "quilt",
            path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--up",
            up,
            "--scale",
            "1.2",
            "--resolution",
            "24",
            "--no-quality",
        ])
    };
    let read_as_z_up = run(&exemplar, "z");
    assert!(
        String::from_utf8_lossy(&read_as_z_up.stdout).contains("pass --up"),
        "a sheet stood on its side gets a hint"
    );
    let read_as_y_up = run(&exemplar, "y");
    assert!(read_as_y_up.status.success());
    assert!(!String::from_utf8_lossy(&read_as_y_up.stdout).contains("pass --up"));
    // The output is a sheet across X and Z whose relief stays along Y.
    let quilted = read_geometry(&out).unwrap().geometry;
    let extent = quilted.points().bounding_box().unwrap().extent();
    assert!(extent.y < 0.25 * extent.x.min(extent.z), "extent {extent}");
    // A file whose comments give its up axis is not re-read with another one.
    let committed = geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply");
    let args = ["quilt", &arg(&committed), "-o", &arg(&out), "--up", "y"];
    refused(&args, "texture comments give up axis Z");
    // A sheet tilted by 35° about (1, 1, 0): `--up auto` quilts it in its fitted plane and
    // writes the output tilted the same way.
    let turn = glam::Quat::from_axis_angle(glam::Vec3::new(1.0, 1.0, 0.0).normalize(), 0.61);
    let tilted = write_mapped("tilted.ply", &|v| turn * v, true);
    let read_as_z_up = run(&tilted, "z");
    let said = String::from_utf8_lossy(&read_as_z_up.stdout);
    assert!(
        said.contains("° from its reference plane; --up auto"),
        "{said}"
    );
    assert!(!String::from_utf8_lossy(&read_as_y_up.stdout).contains("tilted"));
    assert!(run(&tilted, "auto").status.success());
    let quilted = read_geometry(&out).unwrap();
    assert!(
        quilted
            .comments
            .iter()
            .any(|c| c.starts_with("fitted reference plane"))
    );
    let facing: glam::Vec3 = quilted.geometry.points().normals().unwrap().iter().sum();
    let angle = facing.angle_between(turn * glam::Vec3::Z).to_degrees();
    assert!(
        angle < 3.0,
        "the output faces {angle}° away from the sheet's normal"
    );
    // Georeferenced coordinates written in single precision: at 4e6 they step by 0.25,
    // coarser than the samples, and no reader can undo that; the run says so (and the
    // Y-up run above did not).
    let far = write_mapped("far.ply", &|v| v + glam::Vec3::new(5e5, 4e6, 0.0), false);
    let far_run = run(&far, "z");
    assert!(far_run.status.success());
    let far_run = String::from_utf8_lossy(&far_run.stdout);
    assert!(
        far_run.contains("single precision, 0.25 apart"),
        "{far_run}"
    );
    assert!(!String::from_utf8_lossy(&read_as_y_up.stdout).contains("single precision"));
    // The same place in double precision: read relative to an origin, quilted at full
    // precision, and written back there in double precision.
    let origin = glam::DVec3::new(5e5, 4e6, 0.0);
    let precise = dir.path().join("precise.ply");
    let options = WriteOptions::default().origin(origin);
    write_geometry(&precise, &bumpy, &options).unwrap();
    let described = ok(&["info", precise.to_str().unwrap()]);
    // The fixture's padding starts about a unit before its box; info reads the far file
    // at full precision (a single-precision read would print 499999.000000).
    assert!(
        described.contains("bbox min:    499999.000265 3999999.000647"),
        "{described}"
    );
    let precise_run = run(&precise, "z");
    assert!(precise_run.status.success());
    let said = String::from_utf8_lossy(&precise_run.stdout);
    assert!(!said.contains("single precision"), "{said}");
    let header = std::fs::read(&out).unwrap();
    assert!(String::from_utf8_lossy(&header[..400]).contains("property double x"));
    let quilted = read_geometry(&out).unwrap();
    let b = quilted.geometry.bounding_box().unwrap();
    assert!(
        b.min.x >= 5e5 && b.min.y >= 4e6 && b.max.y <= 4e6 + 8.0,
        "{b:?}"
    );
    let described = quilted
        .comments
        .iter()
        .find(|c| c.starts_with("texture_box"))
        .unwrap();
    assert!(described.starts_with("texture_box 500000"), "{described}");
    // Recentred, its x coordinates take thousands of values (in single precision at 5e5
    // they could take about 160 across the 5 units).
    let recentred = geosynth::core::io::read_geometry_with(
        &out,
        &geosynth::core::io::ReadOptions::default().recentre_far(true),
    )
    .unwrap();
    let mut xs: Vec<u32> = recentred
        .geometry
        .points()
        .positions()
        .iter()
        .map(|p| p.x.to_bits())
        .collect();
    xs.sort_unstable();
    xs.dedup();
    assert!(xs.len() > 1000, "{} distinct x values", xs.len());
}

#[test]
fn sdf_signs_intersecting_pieces_by_winding_numbers_when_asked() {
    // Two unit icospheres whose centres are 1.2 apart, as one mesh of two intersecting
    // closed components: inside one, next to the other's surface, the nearest piece's
    // pseudo-normal says outside. The run says so, and `--sign winding` fixes it.
    let dir = tempfile::tempdir().unwrap();
    let sphere = geosynth::fixtures::icosphere_mesh(3).unwrap();
    let shift = glam::Vec3::new(1.2, 0.0, 0.0);
    let n = sphere.vertex_count() as u32;
    let positions = sphere
        .positions()
        .iter()
        .copied()
        .chain(sphere.positions().iter().map(|p| *p + shift))
        .collect();
    let triangles = sphere
        .triangles()
        .iter()
        .copied()
        .chain(sphere.triangles().iter().map(|t| t.map(|v| v + n)))
        .collect();
    let pair =
        geosynth::core::TriMesh::new(geosynth::core::PointSet::new(positions).unwrap(), triangles)
            .unwrap();
    let mesh = dir.path().join("pair.ply");
    write_with_defaults(&mesh, &geosynth::core::io::Geometry::Mesh(pair));
    let wrong_signs = |sign: &str| {
        let field = dir.path().join(format!("{sign}.nrrd"));
        let said = ok(&[
            "sdf",
            mesh.to_str().unwrap(),
            "-o",
            field.to_str().unwrap(),
            "--resolution",
            "32",
            "--sign",
            sign,
        ]);
        let volume = geosynth::sdf::nrrd::read_file(&field).unwrap();
        let [nx, ny, _] = volume.dims;
        let wrong = volume
            .data
            .iter()
            .enumerate()
            .filter(|&(i, d)| {
                let node = glam::Vec3::new(
                    (i % nx) as f32,
                    ((i / nx) % ny) as f32,
                    (i / (nx * ny)) as f32,
                );
                let p = volume.origin.as_vec3() + node * volume.spacing;
                let union = (p.length() - 1.0).min((p - shift).length() - 1.0);
                // The icosphere lies within 0.01 of the unit sphere.
                union.abs() > 0.02 && (*d < 0.0) != (union < 0.0)
            })
            .count();
        (said, wrong)
    };
    let (said, wrong) = wrong_signs("pseudo-normal");
    assert!(
        said.contains("triangles probed lie inside other parts"),
        "{said}"
    );
    assert!(wrong > 10, "{wrong}");
    let (said, wrong) = wrong_signs("winding");
    assert!(!said.contains("note"), "{said}");
    assert_eq!(wrong, 0);
    // `voxel` takes the same flag for its exemplar mesh, and says the same.
    for (sign, noted) in [("pseudo-normal", true), ("winding", false)] {
        let said = tiny_voxel(&mesh, &dir.path().join("voxel.ply"), &["--sign", sign]);
        assert_eq!(said.contains("lie inside other parts"), noted, "{said}");
    }
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

#[test]
fn sdf_and_voxel_turn_disagreeing_triangles_around_when_asked() {
    // An icosphere with every 9th triangle turned over: either sign rule goes wrong near
    // those triangles, the run says so, and `--orient-faces` gives the clean sphere's field.
    let dir = tempfile::tempdir().unwrap();
    let (sphere, scrambled) = icosphere_with_turned_faces();
    let (clean, messy) = (dir.path().join("clean.ply"), dir.path().join("messy.ply"));
    write_with_defaults(&clean, &geosynth::core::io::Geometry::Mesh(sphere.clone()));
    write_with_defaults(&messy, &geosynth::core::io::Geometry::Mesh(scrambled));
    let field = |input: &Path, name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "sdf",
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--resolution",
            "24",
        ];
        args.extend_from_slice(extra);
        let said = ok(&args);
        (said, geosynth::sdf::nrrd::read_file(&out).unwrap().data)
    };
    // `info` points to the flag.
    assert!(ok(&["info", messy.to_str().unwrap()]).contains("--orient-faces"));
    assert!(!ok(&["info", clean.to_str().unwrap()]).contains("orientation:"));
    let (_, reference) = field(&clean, "clean.nrrd", &[]);
    for sign in ["pseudo-normal", "winding"] {
        let (said, wrong) = field(&messy, "messy.nrrd", &["--sign", sign]);
        assert!(said.contains("disagree on which side is out"), "{said}");
        let differing = |data: &[f32]| {
            data.iter()
                .zip(&reference)
                .filter(|(a, b)| (**a < 0.0) != (**b < 0.0))
                .count()
        };
        assert!(differing(&wrong) > 0, "{sign}");
        let (said, fixed) = field(&messy, "fixed.nrrd", &["--sign", sign, "--orient-faces"]);
        let turned = sphere.face_count().div_ceil(9);
        assert!(
            said.contains(&format!(
                "oriented faces: {turned} of {}",
                sphere.face_count()
            )),
            "{said}"
        );
        assert!(!said.contains("note"), "{said}");
        assert_eq!(differing(&fixed), 0, "{sign}");
    }
    let said = tiny_voxel(&messy, &dir.path().join("voxel.ply"), &["--orient-faces"]);
    assert!(
        said.contains("oriented faces:") && !said.contains("note"),
        "{said}"
    );
}

#[test]
fn reconstruct_drops_small_pieces_when_asked_and_says_so_when_not() {
    // A sphere of radius 1 (3000 samples) and one of radius 0.1 beside it (300): the small
    // one comes out as its own closed piece about 4 median spacings across.
    let dir = Scratch::new();
    let big = geosynth::fixtures::sphere_points(3000).unwrap();
    let small = geosynth::fixtures::sphere_points(300).unwrap();
    let shifted: Vec<glam::Vec3> = small
        .positions()
        .iter()
        .map(|p| *p * 0.1 + glam::Vec3::new(1.6, 0.0, 0.0))
        .collect();
    let positions = [big.positions(), &shifted].concat();
    let normals = [big.normals().unwrap(), small.normals().unwrap()].concat();
    let points = dir.path("two.ply");
    write_with_defaults(
        &points,
        &geosynth::core::io::Geometry::Points(
            geosynth::core::PointSet::new(positions)
                .unwrap()
                .with_normals(normals)
                .unwrap(),
        ),
    );
    let (mesh, report) = (dir.path("mesh.ply"), dir.path("report.json"));
    let reconstruct = |extra: &[&str]| {
        let (points, mesh, report) = (arg(&points), arg(&mesh), arg(&report));
        let mut args = vec![
            "reconstruct",
            &points,
            "-o",
            &mesh,
            "--resolution",
            "64",
            "--report",
            &report,
        ];
        args.extend_from_slice(extra);
        let said = ok(&args);
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        (said, json)
    };
    let (said, json) = reconstruct(&[]);
    assert_eq!(json["components"], 2, "{said}");
    assert!(json["pieces_dropped"].is_null(), "{json}");
    assert!(
        said.contains("1 of the 2 pieces are under 12 sample spacings")
            && said.contains("--drop-pieces"),
        "{said}"
    );
    // `--drop-pieces` alone is 12 spacings, and the report records it for `--params`.
    let (said, json) = reconstruct(&["--drop-pieces"]);
    assert_eq!(
        (json["components"].as_u64(), json["pieces_dropped"].as_u64()),
        (Some(1), Some(1)),
        "{said}"
    );
    assert_eq!(json["input_options"]["drop_pieces"].as_f64(), Some(12.0));
    assert!(
        said.contains("after dropping 1 small") && !said.contains("note"),
        "{said}"
    );
    let mesh = geosynth::core::io::read_geometry(&mesh).unwrap().geometry;
    assert!(mesh.points().positions().iter().all(|p| p.x < 1.2));
    // A limit below the small sphere's width keeps it; a bad one is refused by name.
    let (_, json) = reconstruct(&["--drop-pieces", "1"]);
    assert_eq!(json["pieces_dropped"].as_u64(), Some(0));
    refused(
        &[
            "reconstruct",
            &arg(&points),
            "-o",
            &arg(&dir.path("bad.ply")),
            "--drop-pieces=-1",
        ],
        "--drop-pieces",
    );
}

#[test]
fn reconstruct_keeps_a_closed_cloud_with_stray_normals_whole_with_sign_winding() {
    // 4000 points on a sphere, every 25th normal turned inward: each such sample turns the
    // MLS surface's implicit function around near it, and the surface comes out in
    // pieces (224 at this resolution); the points' winding number outvotes them.
    let dir = tempfile::tempdir().unwrap();
    let sphere = geosynth::fixtures::sphere_points(4000).unwrap();
    let normals = sphere
        .normals()
        .unwrap()
        .iter()
        .enumerate()
        .map(|(i, n)| if i % 25 == 0 { -*n } else { *n })
        .collect();
    let points = dir.path().join("stray.ply");
    write_with_defaults(
        &points,
        &geosynth::core::io::Geometry::Points(sphere.with_normals(normals).unwrap()),
    );
    let mesh = dir.path().join("mesh.ply");
    let reconstruct = |sign: &str| {
        let said = ok(&[
            "reconstruct",
            points.to_str().unwrap(),
            "-o",
            mesh.to_str().unwrap(),
            "--resolution",
            "48",
            "--sign",
            sign,
        ]);
        let topology = match geosynth::core::io::read_geometry(&mesh).unwrap().geometry {
            geosynth::core::io::Geometry::Mesh(m) => m.topology(),
            geosynth::core::io::Geometry::Points(_) => panic!("a mesh was written"),
        };
        (said, topology)
    };
    let (said, topology) = reconstruct("local");
    assert!(topology.components > 1, "{said}");
    assert!(said.contains("--sign winding"), "{said}");
    let (said, topology) = reconstruct("winding");
    assert!(
        topology.is_closed_manifold() && topology.components == 1,
        "{said}"
    );
    assert!(!said.contains("pieces"), "{said}");
    // Two stacked flat patches (an open scan) come out in pieces too, but their normals do
    // not cancel: no such note.
    let patches: Vec<glam::Vec3> = (0..2)
        .flat_map(|patch| {
            (0..400).map(move |i| {
                glam::Vec3::new(
                    (i % 20) as f32 * 0.05,
                    (i / 20) as f32 * 0.05,
                    2.0 * patch as f32,
                )
            })
        })
        .collect();
    let sheets = dir.path().join("sheets.ply");
    write_with_defaults(
        &sheets,
        &geosynth::core::io::Geometry::Points(
            geosynth::core::PointSet::new(patches.clone())
                .unwrap()
                .with_normals(vec![glam::Vec3::Z; patches.len()])
                .unwrap(),
        ),
    );
    let said = ok(&[
        "reconstruct",
        sheets.to_str().unwrap(),
        "-o",
        mesh.to_str().unwrap(),
        "--resolution",
        "32",
    ]);
    assert!(!said.contains(" 1 component(s)"), "{said}");
    assert!(!said.contains("--sign winding"), "{said}");
    // Trimming says that winding numbers are for closed objects.
    let said = ok(&[
        "reconstruct",
        points.to_str().unwrap(),
        "-o",
        mesh.to_str().unwrap(),
        "--resolution",
        "24",
        "--sign",
        "winding",
        "--trim",
    ]);
    assert!(said.contains("open scan has no inside"), "{said}");
    // `sdf` takes the flag for point sets too.
    ok(&[
        "sdf",
        points.to_str().unwrap(),
        "-o",
        dir.path().join("stray.nrrd").to_str().unwrap(),
        "--resolution",
        "24",
        "--sign",
        "winding",
    ]);
}

#[test]
fn stl_meshes_work_where_meshes_do_and_point_sets_are_refused_early() {
    use geosynth::core::io::{Geometry, WriteOptions, write_geometry};
    let scratch = Scratch::new();
    let sphere = geosynth::fixtures::icosphere_mesh(3).unwrap();
    write_with_defaults(&scratch.path("sphere.ply"), &Geometry::Mesh(sphere.clone()));
    write_with_defaults(&scratch.path("sphere.stl"), &Geometry::Mesh(sphere.clone()));

    // `info` sees the same closed sphere: STL corners welded back into shared vertices.
    let json = info_json(&scratch.path("sphere.stl"));
    assert_eq!(
        (json["format"].as_str(), json["encoding"].as_str()),
        (Some("STL"), Some("binary_little_endian"))
    );
    assert_eq!(
        (json["vertices"].as_u64(), json["faces"].as_u64()),
        (Some(642), Some(1280))
    );
    assert_closed(&scratch.path("sphere.stl"), 2, "STL sphere");

    // `sdf` gives the same field from either file.
    let field = |input: &Path, name: &str| {
        ok(&[
            "sdf",
            &arg(input),
            "-o",
            &arg(&scratch.path(name)),
            "--resolution",
            "24",
        ]);
        geosynth::sdf::nrrd::read_file(&scratch.path(name))
            .unwrap()
            .data
    };
    assert_eq!(
        field(&scratch.path("sphere.stl"), "a.nrrd"),
        field(&scratch.path("sphere.ply"), "b.nrrd")
    );

    // `voxel` takes an STL exemplar and writes STL meshes: the same run as with PLY.
    for ext in ["ply", "stl"] {
        let iso = arg(&scratch.path(&format!("iso.{ext}")));
        tiny_voxel(
            &scratch.path(&format!("sphere.{ext}")),
            &scratch.path(&format!("voxel.{ext}")),
            &["--isosurface", &iso],
        );
    }
    let [iso_ply, iso_stl] = ["iso.ply", "iso.stl"].map(|n| info_json(&scratch.path(n)));
    assert_eq!(iso_stl["topology"]["closed_manifold"], true);
    assert_eq!(iso_stl["topology"], iso_ply["topology"]);
    assert_eq!(iso_stl["faces"], iso_ply["faces"]);
    let [copied_ply, copied_stl] = ["voxel.ply", "voxel.stl"].map(|n| info_json(&scratch.path(n)));
    assert!(copied_stl["faces"].as_u64() > Some(0));
    assert_eq!(copied_stl["faces"], copied_ply["faces"]);

    // Point sets cannot be STL: refused before any work, naming what to write instead.
    let fixture =
        arg(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/quilt_bumpy.ply"));
    let refused = geosynth(&["quilt", &fixture, "-o", &arg(&scratch.path("quilt.stl"))]);
    let said = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && said.contains("STL cannot store a point set"),
        "{said}"
    );
    assert!(!scratch.path("quilt.stl").exists());

    // Georeferenced input would lose its precision as STL: refused once the input is read.
    let points = sphere
        .vertices()
        .clone()
        .with_normals(sphere.vertex_normals(geosynth::core::NormalWeighting::Angle))
        .unwrap();
    let far = scratch.path("far.ply");
    write_geometry(
        &far,
        &Geometry::Points(points),
        &WriteOptions::default().origin(glam::DVec3::new(5e5, 4e6, 0.0)),
    )
    .unwrap();
    let refused = geosynth(&[
        "reconstruct",
        &arg(&far),
        "-o",
        &arg(&scratch.path("far.stl")),
    ]);
    let said = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && said.contains("write .ply to keep them"),
        "{said}"
    );
    ok(&[
        "reconstruct",
        &arg(&far),
        "-o",
        &arg(&scratch.path("far_ok.ply")),
        "--resolution",
        "24",
    ]);
}

#[test]
fn convert_moves_geometry_between_formats_and_says_what_is_lost() {
    use geosynth::core::io::{Geometry, WriteOptions, read_geometry, write_geometry};
    let scratch = Scratch::new();
    // A sphere with normals (which STL cannot keep), its triangles partly turned over.
    let sphere = geosynth::fixtures::icosphere_mesh(2).unwrap();
    let turned: Vec<[u32; 3]> = sphere
        .triangles()
        .iter()
        .enumerate()
        .map(|(i, &[a, b, c])| if i % 5 == 0 { [a, c, b] } else { [a, b, c] })
        .collect();
    let normals = sphere.vertex_normals(geosynth::core::NormalWeighting::Angle);
    let vertices = sphere.vertices().clone().with_normals(normals).unwrap();
    let messy = geosynth::core::TriMesh::new(vertices, turned).unwrap();
    write_with_defaults(&scratch.path("messy.ply"), &Geometry::Mesh(messy));

    let said = ok(&[
        "convert",
        &arg(&scratch.path("messy.ply")),
        "-o",
        &arg(&scratch.path("s.stl")),
        "--orient-faces",
    ]);
    assert!(said.contains("oriented faces: 64 of 320"), "{said}");
    assert!(
        said.contains("STL cannot store the input's vertex normals"),
        "{said}"
    );
    // A point set has no triangles to turn: written as it is, with a note saying so.
    let points = geosynth::fixtures::bundled_dir().join("sphere_points.ply");
    let copy = scratch.path("points.ply");
    let said = ok(&[
        "convert",
        &arg(&points),
        "-o",
        &arg(&copy),
        "--orient-faces",
    ]);
    assert!(said.contains("is a point set: --orient-faces"), "{said}");
    assert_eq!(info_json(&copy)["vertices"], 2000);
    let said = ok(&[
        "convert",
        &arg(&scratch.path("s.stl")),
        "-o",
        &arg(&scratch.path("s.obj")),
    ]);
    assert!(!said.contains("note"), "{said}");
    assert_closed(&scratch.path("s.obj"), 2, "sphere through STL and OBJ");
    // The clean sphere's triangles, each as its corners from the lowest one on.
    let corners = |mesh: &geosynth::core::TriMesh| -> Vec<[[f32; 3]; 3]> {
        let p = mesh.positions();
        mesh.triangles()
            .iter()
            .map(|t| {
                let c = t.map(|v| p[v as usize].to_array());
                let first = (0..3)
                    .min_by(|&i, &j| c[i].partial_cmp(&c[j]).unwrap())
                    .unwrap();
                std::array::from_fn(|k| c[(first + k) % 3])
            })
            .collect()
    };
    let back = read_geometry(scratch.path("s.obj")).unwrap();
    assert_eq!(corners(back.geometry.mesh().unwrap()), corners(&sphere));

    // ASCII on request, for PLY and STL.
    ok(&[
        "convert",
        &arg(&scratch.path("s.obj")),
        "-o",
        &arg(&scratch.path("a.stl")),
        "--ascii",
    ]);
    ok(&[
        "convert",
        &arg(&scratch.path("a.stl")),
        "-o",
        &arg(&scratch.path("a.ply")),
        "--ascii",
    ]);
    assert!(
        std::fs::read_to_string(scratch.path("a.stl"))
            .unwrap()
            .starts_with("solid")
    );
    assert_eq!(info_json(&scratch.path("a.ply"))["encoding"], "ascii");
    assert_eq!(info_json(&scratch.path("a.ply"))["faces"], 320);
    let said = ok(&[
        "convert",
        &arg(&scratch.path("a.stl")),
        "-o",
        &arg(&scratch.path("a.off")),
        "--ascii",
    ]);
    assert!(said.contains("OFF is always text"), "{said}");

    // Georeferenced points stay in place through OFF; STL refuses them, and point sets.
    let points = sphere.vertices().clone();
    let origin = glam::DVec3::new(5e5, 4e6, 10.0);
    write_geometry(
        scratch.path("far.ply"),
        &Geometry::Points(points.clone()),
        &WriteOptions::default().origin(origin),
    )
    .unwrap();
    ok(&[
        "convert",
        &arg(&scratch.path("far.ply")),
        "-o",
        &arg(&scratch.path("far.off")),
    ]);
    let recentred = geosynth::core::io::ReadOptions::default().recentre_far(true);
    let far = geosynth::core::io::read_geometry_with(scratch.path("far.off"), &recentred).unwrap();
    let first = far.geometry.points().positions()[0].as_dvec3() + far.origin;
    assert!((first - (points.positions()[0].as_dvec3() + origin)).length() < 1e-6);
    let refused = geosynth(&[
        "convert",
        &arg(&scratch.path("far.ply")),
        "-o",
        &arg(&scratch.path("far.stl")),
    ]);
    let said = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && said.contains("STL cannot store a point set"),
        "{said}"
    );
    assert!(!scratch.path("far.stl").exists());

    // `info` counts triangles that repeat another's corners (here, one facing the other way).
    let twin = scratch.path("twin.off");
    std::fs::write(
        &twin,
        "OFF\n4 3 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 2 1\n3 0 1 3\n",
    )
    .unwrap();
    let said = ok(&["info", &arg(&twin)]);
    assert!(
        said.contains(
            "duplicates:  1 triangles on the same corners as another, 1 of them facing the \
             other way"
        ),
        "{said}"
    );
    assert_eq!(info_json(&twin)["duplicate_faces"], 1);
    assert_eq!(info_json(&twin)["reversed_duplicates"], 1);

    // What the reader could not keep is said by `info` and by the commands that read it.
    let mixed = scratch.path("mixed.obj");
    std::fs::write(
        &mixed,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n\
         o textured\nf 1/1 2/2 3/3\no plain\nf 2 4 3\n",
    )
    .unwrap();
    let dropped = "texture coordinates dropped: 3 of 6 face corners have them";
    assert!(ok(&["info", &arg(&mixed)]).contains(&format!("not kept:    {dropped}")));
    let note = format!("note: {}: {dropped}", mixed.display());
    for (command, out) in [("convert", "mixed.ply"), ("render", "mixed.png")] {
        let said = ok(&[command, &arg(&mixed), "-o", &arg(&scratch.path(out))]);
        assert!(said.contains(&note), "{command}: {said}");
    }
}

#[test]
fn point_clouds_go_through_xyz_files_and_meshes_do_not() {
    let dir = Scratch::new();
    let points = geosynth::fixtures::bundled_dir().join("sphere_points.ply");
    let xyz = dir.path("sphere.xyz");
    let said = ok(&["convert", &arg(&points), "-o", &arg(&xyz)]);
    assert!(said.contains("(XYZ): 2000 points"), "{said}");
    let json = info_json(&xyz);
    assert_eq!(
        (json["format"].as_str(), json["vertices"].as_u64()),
        (Some("XYZ"), Some(2000))
    );
    assert_eq!(json["normals"], true);
    // Back to PLY: the same positions and normals.
    let back = dir.path("back.ply");
    ok(&["convert", &arg(&xyz), "-o", &arg(&back), "-q"]);
    let read = |path: &Path| geosynth::core::io::read_geometry(path).unwrap().geometry;
    assert_eq!(
        read(&back).points().positions(),
        read(&points).points().positions()
    );
    assert_eq!(
        read(&back).points().normals(),
        read(&points).points().normals()
    );
    // A mesh output as XYZ is refused before the run: its faces would be lost.
    refused(
        &["reconstruct", &arg(&xyz), "-o", &arg(&dir.path("m.xyz"))],
        "holds points only",
    );
    refused(
        &["convert", &arg(&xyz), "-o", &arg(&dir.path("m.txt"))],
        ".xyz, .xyzn or .xyzrgb",
    );
    // A quilt has no colours for .xyzrgb: refused before the run. As .xyz it reads back
    // with its box.
    let exemplar = arg(&geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply"));
    let quilt = [
        "quilt",
        &exemplar,
        "--no-quality",
        "--scale",
        "1.2",
        "-q",
        "-o",
    ];
    refused(
        &[&quilt[..], &[&arg(&dir.path("q.xyzrgb"))]].concat(),
        "no colours",
    );
    let quilted = dir.path("q.xyz");
    ok(&[&quilt[..], &[&arg(&quilted)]].concat());
    // Found only when writing (points without colours): the error names the file.
    let rgb = dir.path("n.xyzrgb");
    refused(
        &["normals", &arg(&points), "-o", &arg(&rgb)],
        &format!(
            "cannot write {}: XYZRGB cannot store points without colours",
            rgb.display()
        ),
    );
    let comments = info_json(&quilted)["comments"].to_string();
    assert!(comments.contains("texture_box"), "{comments}");
}
