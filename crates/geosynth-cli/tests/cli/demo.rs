//! `geosynth demo` and `geosynth fixtures`.

use std::path::Path;

use geosynth::core::testdata::shared_data;

use crate::{arg, assert_peak_memory, ok, refused};

#[test]
fn demo_refuses_a_data_folder_that_is_a_file_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("data.ply");
    std::fs::write(&file, "ply\n").unwrap();
    let out = dir.path().join("demo");
    refused(
        &[
            "demo",
            "--quick",
            "--out",
            &arg(&out),
            "--data",
            &arg(&file),
        ],
        "not a folder",
    );
    assert!(!out.exists());
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
    // Reconstructed scans (when the shared data is found) come as PLY and as glTF, the
    // same mesh in both.
    for r in report["reconstructions"].as_array().into_iter().flatten() {
        let ply = out.join(r["geometry"].as_str().unwrap());
        let read = |path: &Path| geosynth::core::io::read_geometry(path).unwrap().geometry;
        let (ply_mesh, glb_mesh) = (read(&ply), read(&ply.with_extension("glb")));
        assert_eq!(glb_mesh, ply_mesh, "{}", ply.display());
        assert_eq!(r["faces"], glb_mesh.mesh().unwrap().face_count());
        // Its copy at a tenth of the faces, closed and of the same genus when it is.
        let simplified = &r["simplified"];
        let fewer = read(&out.join(simplified["geometry"].as_str().unwrap()));
        let fewer = fewer.mesh().unwrap();
        assert_eq!(simplified["faces"], fewer.face_count());
        assert!(fewer.face_count() <= ply_mesh.mesh().unwrap().face_count() / 10);
        if r["closed_manifold"] == true {
            let topology = fewer.topology();
            assert!(topology.is_closed_manifold(), "{}", ply.display());
            assert_eq!(r["euler_characteristic"], topology.euler_characteristic);
        }
    }
    // Patch quilting: every texture fixture, its files, and the parameters that made it.
    let quilts = report["quilts"].as_array().unwrap();
    assert_eq!(quilts.len(), 4);
    for q in quilts {
        for key in ["preview", "geometry"] {
            assert!(out.join(q[key].as_str().unwrap()).is_file(), "{key}");
        }
        assert_eq!(q["params"]["method"], "full", "{q}");
        assert!(q["params"]["pairing"]["w_d"].as_f64().unwrap() > 0.0, "{q}");
        // The full method beats random placement on both errors, in the quick run too
        // (at half the default field resolution it had not on the flowers).
        let error = |run: &str, key: &str| q[run]["quality"][key].as_f64().unwrap();
        for key in ["neighbourhood_error", "seam_error"] {
            assert!(error("full", key) >= 0.0, "{q}");
            assert!(
                error("full", key) < error("random_placement", key),
                "{}: {key}",
                q["exemplar"]
            );
        }
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
