//! `geosynth voxel` (paper 001): synthesis from a solid, its notes and refusals, and
//! georeferenced exemplars.

use std::path::Path;

use crate::{
    assert_closed, geosynth, icosphere_with_turned_faces, info_json, ok, refused, tiny_voxel,
    write_with_defaults,
};

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
    refused(
        &["voxel", &points, "-o", &path("x.ply")],
        "(`geosynth sdf POINTS.ply -o FIELD.nrrd`, with `--estimate-normals` for points without",
    );
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
    // A colour on one vertex only, which a mesh cannot keep: the reader's note reaches the
    // user.
    obj = obj.replacen("v 0 0 0", "v 0 0 0 1 0 0", 1);
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
    assert!(
        said.contains("cube.obj: colours dropped: 1 of 8 `v` lines"),
        "{said}"
    );
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

/// The machine's available memory and free swap in bytes, as `/proc/meminfo` gives them
/// (0 where it does not).
fn available_memory() -> u64 {
    let meminfo = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
    let kib = |key: &str| -> u64 {
        meminfo
            .lines()
            .find_map(|l| l.strip_prefix(key))
            .and_then(|l| l.split_whitespace().next()?.parse().ok())
            .unwrap_or(0)
    };
    (kib("MemAvailable:") + kib("SwapFree:")) * 1024
}

#[test]
fn voxel_refuses_a_run_larger_than_memory_before_it_starts() {
    // A 512³ source beside a 512³ target: about 40 GB by the model. Machines with more
    // than 30 GB to spare may run it instead, which this test does not wait for.
    if available_memory() > 30_000_000_000 {
        eprintln!("skipped: this machine has more than 30 GB available");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exemplar = dir.path().join("grid.ply");
    let grid = geosynth::fixtures::volumes::grid(1).unwrap();
    write_with_defaults(
        &exemplar,
        &geosynth::core::io::Geometry::Mesh(grid.mesh.clone()),
    );
    let output = dir.path().join("out.ply");
    let run = geosynth(&[
        "voxel",
        exemplar.to_str().unwrap(),
        "-o",
        output.to_str().unwrap(),
        "--source-res",
        "512",
        "--target-res",
        "512",
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "{stderr}");
    assert!(
        stderr.contains("synthesizing a target of 512 × 512 × 512 samples from a source of")
            && stderr.contains("GB this machine has available"),
        "{stderr}"
    );
    // The upfront check's words (the later one speaks of building the meshes); nothing
    // written.
    assert!(!output.exists());
}
