//! `geosynth simplify`: a mesh in fewer triangles.

use geosynth::core::io::read_geometry;
use geosynth::core::{NormalWeighting, TriMesh};

use super::*;

/// A bundled fixture's path.
fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(name)
}

#[test]
fn the_torus_halves_by_default_and_goes_to_a_count_or_a_tolerance() {
    let dir = Scratch::new();
    let torus = fixture("torus_mesh.ply");
    let faces = read_geometry(&torus)
        .unwrap()
        .geometry
        .mesh()
        .unwrap()
        .face_count();
    let (half, report) = (dir.path("half.glb"), dir.path("r.json"));
    let printed = ok(&[
        "simplify",
        &arg(&torus),
        "-o",
        &arg(&half),
        "--report",
        &arg(&report),
    ]);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["simplify"]["faces_before"], faces);
    assert_eq!(r["params"]["target_faces"], faces / 2);
    assert_eq!(
        timed_stages(&r, "timings"),
        ["reading", "simplifying", "writing"]
    );
    assert_peak_memory(&r);
    let after = r["simplify"]["faces_after"].as_u64().unwrap() as usize;
    assert!(after <= faces / 2 && after + 4 >= faces / 2, "{after}");
    assert!(
        printed.contains(&format!("{after} faces from {faces}")),
        "{printed}"
    );
    assert_closed(&half, 0, "the halved torus");

    let few = dir.path("few.ply");
    ok(&["simplify", &arg(&torus), "-o", &arg(&few), "--faces", "200"]);
    let mesh = read_geometry(&few)
        .unwrap()
        .geometry
        .mesh()
        .unwrap()
        .clone();
    assert!(mesh.face_count() <= 200);
    assert_closed(&few, 0, "the torus at 200 faces");
    // The torus's normals were interpolated (the default): not those of the coarse faces,
    // which `--normals recompute` gives.
    let faceted = dir.path("faceted.ply");
    let recompute = ["--faces", "200", "--normals", "recompute"];
    ok(&[
        &["simplify", &arg(&torus), "-o", &arg(&faceted)][..],
        &recompute,
    ]
    .concat());
    let largest_turn_from_faces = |mesh: &TriMesh| {
        let stored = mesh.vertices().normals().unwrap();
        let faces = mesh.vertex_normals(NormalWeighting::Angle);
        stored
            .iter()
            .zip(faces)
            .map(|(n, f)| n.angle_between(f).to_degrees())
            .fold(0.0, f32::max)
    };
    assert!(largest_turn_from_faces(&mesh) > 1.0);
    let faceted = read_geometry(&faceted).unwrap().geometry;
    assert!(largest_turn_from_faces(faceted.mesh().unwrap()) < 0.01);

    // A tolerance alone goes as far as it allows, no further.
    let (tolerant, report) = (dir.path("tol.obj"), dir.path("tol.json"));
    ok(&[
        "simplify",
        &arg(&torus),
        "-o",
        &arg(&tolerant),
        "--max-error",
        "0.001",
        "--report",
        &arg(&report),
    ]);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["params"]["target_faces"], 0);
    assert!(r["simplify"]["max_collapse_error"].as_f64().unwrap() <= 0.001);
    let kept = r["simplify"]["faces_after"].as_u64().unwrap() as usize;
    assert!(kept < faces && kept > 200, "{kept}");
}

#[test]
fn simplify_refuses_point_sets_bad_targets_and_limits() {
    let dir = Scratch::new();
    let torus = fixture("torus_mesh.ply");
    let out = arg(&dir.path("o.ply"));
    refused(
        &["simplify", &arg(&fixture("sphere_points.ply")), "-o", &out],
        "is a point set",
    );
    refused(
        &["simplify", &arg(&torus), "-o", &out, "--ratio", "0"],
        "--ratio 0 is out of range",
    );
    refused(
        &["simplify", &arg(&torus), "-o", &out, "--ratio", "1.5"],
        "out of range",
    );
    refused(
        &["simplify", &arg(&torus), "-o", &out, "--max-turn", "200"],
        "max_face_turn",
    );
    refused(
        &["simplify", &arg(&torus), "-o", &out, "--max-error=-1"],
        "max_error",
    );
    refused(
        &["simplify", &arg(&torus), "-o", &arg(&dir.path("o.xyz"))],
        "cannot write",
    );
    refused(
        &["simplify", &arg(&torus), "-o", &out, "--normals", "smooth"],
        "invalid value 'smooth'",
    );
    assert!(!dir.path("o.ply").exists());
}
