//! Reading, describing, converting and drawing files: every format, every shared data
//! file, and bad input refused with a message instead of a panic.

use std::path::{Path, PathBuf};
use std::process::Command;

use geosynth::core::io::Geometry;
use geosynth::core::testdata::shared_data;

use crate::{
    Scratch, arg, assert_closed, geosynth, info_json, ok, refused, tiny_voxel, write_with_defaults,
};

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
    // Reliefs above 100 times the longer side are refused (from about 1000 the picture
    // came out blank); 100 is drawn.
    let terrain_arg = arg(&terrain);
    let with_relief = |relief: &str| {
        [
            "render",
            "--heightfield",
            hf.to_str().unwrap(),
            "-o",
            &terrain_arg,
            "--relief",
            relief,
        ]
        .map(String::from)
    };
    refused(
        &with_relief("1e30").each_ref().map(String::as_str),
        "up to 100",
    );
    ok(&with_relief("100").each_ref().map(String::as_str));
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
fn same_scale_draws_a_square_twice_as_wide_as_one_half_its_side() {
    let dir = Scratch::new();
    let square = |side: u32| {
        let path = dir.path(&format!("square{side}.obj"));
        let s = side.to_string();
        let obj = format!("v 0 0 0\nv {s} 0 0\nv {s} {s} 0\nv 0 {s} 0\nf 1 2 3\nf 1 3 4\n");
        std::fs::write(&path, obj).unwrap();
        arg(&path)
    };
    let (small, large) = (square(1), square(2));
    let picture = arg(&dir.path("squares.png"));
    // Panels 160 × 120, seen straight along z; the widths drawn in each.
    let widths = |same_scale: bool| {
        let mut args = vec!["render", &small, &large, "-o", &picture];
        args.extend(["--width", "160", "--height", "120", "--azimuth", "0"]);
        args.extend(["--elevation", "0"]);
        if same_scale {
            args.push("--same-scale");
        }
        ok(&args);
        let img = image::open(&picture).unwrap().into_rgb8();
        [0u32, 164].map(|x0| {
            let drawn: Vec<u32> = (x0..x0 + 160)
                .filter(|&x| (0..120).any(|y| img.get_pixel(x, y).0 != [255, 255, 255]))
                .collect();
            drawn.last().map_or(0, |last| last - drawn[0] + 1)
        })
    };
    let [fitted_small, fitted_large] = widths(false);
    assert!(
        fitted_small.abs_diff(fitted_large) <= 1,
        "{fitted_small} {fitted_large}"
    );
    let [small_width, large_width] = widths(true);
    assert!(
        large_width.abs_diff(fitted_large) <= 1,
        "{large_width} {fitted_large}"
    );
    assert!(
        small_width.abs_diff(large_width / 2) <= 1,
        "{small_width} {large_width}"
    );
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
fn info_counts_mesh_normals_that_face_against_their_faces() {
    let scratch = Scratch::new();
    // A square of two triangles facing +z; the third vertex's normal faces -z.
    let path = scratch.path("square.ply");
    std::fs::write(
        &path,
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
         element face 2\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 -1\n0 1 0 0 0 1\n3 0 1 2\n3 0 2 3\n",
    )
    .unwrap();
    assert_eq!(info_json(&path)["normals_against_faces"], 1);
    let said = ok(&["info", &arg(&path)]);
    assert!(
        said.contains("1 vertex normals face against their faces"),
        "{said}"
    );
    // Point sets have no faces to face against.
    let points = geosynth::fixtures::bundled_dir().join("sphere_points.ply");
    assert!(info_json(&points)["normals_against_faces"].is_null());
    let said = ok(&["info", &arg(&points)]);
    assert!(!said.contains("against their faces"), "{said}");
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
    // An earlier output made read-only, and a folder where the report would go.
    let kept = dir.path().join("kept.ply");
    std::fs::write(&kept, "an earlier run").unwrap();
    let mut permissions = std::fs::metadata(&kept).unwrap().permissions();
    permissions.set_readonly(true);
    std::fs::set_permissions(&kept, permissions).unwrap();
    let folder = dir.path().join("folder.json");
    std::fs::create_dir(&folder).unwrap();
    // A quilt to `q.ply` with its report at `report`.
    let quilted = dir.path().join("q.ply");
    let quilted = quilted.to_str().unwrap();
    let with_report = |report| vec!["quilt", fixture, "-o", quilted, "--report", report];
    for (args, message) in [
        (
            vec!["quilt", fixture, "-o", kept.to_str().unwrap()],
            "read-only",
        ),
        (
            with_report(folder.to_str().unwrap()),
            "a folder has that name",
        ),
        (vec!["quilt", fixture, "-o", missing], "does not exist"),
        (
            with_report(report_in_missing.to_str().unwrap()),
            "does not exist",
        ),
        (
            vec!["quilt", fixture, "-o", unknown.to_str().unwrap()],
            ".ply, .obj, .off, .stl, .xyz, .xyzn, .xyzrgb, .las, .pcd, .glb or .gltf",
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
    assert_eq!(std::fs::read_to_string(&kept).unwrap(), "an earlier run");
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
    // Points whose normals a tool left unset (0 0 0) for every fifth point.
    let unset = dir.path().join("unset.xyzn");
    let lines: String = (0..200)
        .map(|i| {
            let (x, y) = ((i % 20) as f32 * 0.1, (i / 20) as f32 * 0.1);
            let nz = if i % 5 == 0 { 0 } else { 1 };
            format!("{x} {y} 0 0 0 {nz}\n")
        })
        .collect();
    std::fs::write(&unset, lines).unwrap();
    let info = info_json(&unset);
    assert_eq!(info["zero_normals"], 40);
    assert_eq!(info_json(Path::new(&good))["zero_normals"], 0);
    let unset = arg(&unset);
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
        (
            vec!["reconstruct", &unset, "-o", &ply_out],
            &unset,
            "40 of the 200 normals are zero",
        ),
        (
            vec!["sdf", &unset, "-o", &ply_out.replace(".ply", ".nrrd")],
            &unset,
            "40 of the 200 normals are zero",
        ),
        (
            vec!["quilt", &unset, "-o", &ply_out],
            &unset,
            "40 of the 200 normals are zero",
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
        said.contains("s.stl: STL cannot store the vertex normals; write .ply"),
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
        ".xyz, .xyzn, .xyzrgb, .las, .pcd, .glb or .gltf",
    );
    // A quilt has no colours for .xyzrgb: refused before the run. As .xyz it reads back
    // with its box.
    let exemplar = bumpy_exemplar();
    let quilt = small_quilt(&exemplar);
    refused(
        &[&quilt[..], &[&arg(&dir.path("q.xyzrgb"))]].concat(),
        "no colours",
    );
    let quilted = dir.path("q.xyz");
    ok(&[&quilt[..], &[&arg(&quilted)]].concat());
    // Found only when writing (points without colours): the error names the file.
    let rgb = dir.path("c.xyzrgb");
    refused(
        &["convert", &arg(&points), "-o", &arg(&rgb)],
        &format!(
            "cannot write {}: XYZRGB cannot store points without colours",
            rgb.display()
        ),
    );
    // `normals` refuses it before the work: the format keeps no normals.
    let rgb = dir.path("n.xyzrgb");
    refused(
        &["normals", &arg(&points), "-o", &arg(&rgb)],
        &format!("cannot write {}: XYZRGB stores no normals", rgb.display()),
    );
    let comments = info_json(&quilted)["comments"].to_string();
    assert!(comments.contains("texture_box"), "{comments}");
}

#[test]
fn lidar_points_go_through_las_files_and_meshes_do_not() {
    use geosynth::core::io::{Geometry, WriteOptions, write_geometry};
    use geosynth::core::{Attribute, PointSet};
    let dir = Scratch::new();
    // A terrain strip at UTM coordinates, with intensities and classes.
    let local: Vec<glam::Vec3> = (0..400)
        .map(|i| {
            glam::Vec3::new(
                (i % 20) as f32 * 0.5,
                (i / 20) as f32 * 0.5,
                (i % 7) as f32 * 0.1,
            )
        })
        .collect();
    let mut points = PointSet::new(local.clone()).unwrap();
    points
        .set_attribute(Attribute::new(
            "intensity",
            (0..400).map(|i| (i * 100) as f32).collect(),
        ))
        .unwrap();
    points
        .set_attribute(Attribute::new(
            "classification",
            (0..400).map(|i| (i % 3) as f32).collect(),
        ))
        .unwrap();
    let origin = glam::DVec3::new(512_000.0, 5_430_000.0, 300.0);
    let las = dir.path("strip.las");
    write_geometry(
        &las,
        &Geometry::Points(points),
        &WriteOptions::default().origin(origin),
    )
    .unwrap();
    let json = info_json(&las);
    assert_eq!(json["format"], "LAS");
    assert_eq!(json["encoding"], "LAS 1.2, point format 0");
    assert_eq!(json["vertices"], 400);
    assert!((json["bbox_min"][0].as_f64().unwrap() - 512_000.0).abs() < 1e-6);
    // To PLY: the coordinates in place (double) and both attributes.
    let ply = dir.path("strip.ply");
    let said = ok(&["convert", &arg(&las), "-o", &arg(&ply)]);
    assert!(said.contains("(PLY): 400 vertices"), "{said}");
    let json = info_json(&ply);
    let attributes = json["attributes"].to_string();
    assert!(attributes.contains("intensity") && attributes.contains("classification"));
    assert!((json["bbox_max"][1].as_f64().unwrap() - 5_430_009.5).abs() < 1e-4);
    // Normals for the bare LiDAR points.
    let with_normals = dir.path("strip_n.ply");
    ok(&["normals", &arg(&las), "-o", &arg(&with_normals), "-q"]);
    assert_eq!(info_json(&with_normals)["normals"], true);
    // Meshes are refused before anything is written; .laz is not written.
    let mesh = geosynth::fixtures::bundled_dir().join("torus_mesh.ply");
    let out = dir.path("mesh.las");
    refused(&["convert", &arg(&mesh), "-o", &arg(&out)], "faces");
    assert!(!out.exists());
    refused(
        &["convert", &arg(&las), "-o", &arg(&dir.path("x.laz"))],
        ".las",
    );
    // A compressed file (the format id's bit 7) is refused with what to do.
    let mut bytes = std::fs::read(&las).unwrap();
    bytes[104] |= 0x80;
    let laz = dir.path("strip.laz");
    std::fs::write(&laz, bytes).unwrap();
    refused(&["info", &arg(&laz)], "decompress");
}

#[test]
fn point_clouds_go_through_pcd_files_in_each_encoding() {
    let dir = Scratch::new();
    // A quilt: normals and its patch labels, which PCD keeps as a field.
    let exemplar = bumpy_exemplar();
    let quilted = dir.path("q.ply");
    ok(&[&small_quilt(&exemplar)[..], &[&arg(&quilted)]].concat());
    let read = |path: &Path| geosynth::core::io::read_geometry(path).unwrap().geometry;
    let original = read(&quilted);
    for (flag, encoding) in [
        (None, "binary"),
        (Some("--ascii"), "ascii"),
        (Some("--compressed"), "binary_compressed"),
    ] {
        let pcd = dir.path(&format!("q_{encoding}.pcd"));
        let quilted_arg = arg(&quilted);
        let pcd_arg = arg(&pcd);
        let mut args = vec!["convert", &quilted_arg, "-o"];
        args.push(&pcd_arg);
        args.extend(flag);
        let said = ok(&args);
        assert!(said.contains("(PCD):"), "{said}");
        let json = info_json(&pcd);
        assert_eq!(json["format"], "PCD");
        assert_eq!(json["encoding"], encoding);
        assert!(json["attributes"].to_string().contains("patch"));
        // Back to PLY: the same points, normals and labels.
        let back = dir.path(&format!("back_{encoding}.ply"));
        ok(&["convert", &pcd_arg, "-o", &arg(&back), "-q"]);
        let back = read(&back);
        assert_eq!(back.points().positions(), original.points().positions());
        assert_eq!(back.points().normals(), original.points().normals());
        assert_eq!(
            back.points()
                .attribute("patch")
                .map(|a| a.values().to_vec()),
            original
                .points()
                .attribute("patch")
                .map(|a| a.values().to_vec())
        );
    }
    // Compression is for PCD only, refused before the input is read; meshes are refused.
    refused(
        &[
            "convert",
            &arg(&dir.path("missing.ply")),
            "-o",
            &arg(&dir.path("x.ply")),
            "--compressed",
        ],
        "--compressed is for .pcd",
    );
    let mesh = geosynth::fixtures::bundled_dir().join("torus_mesh.ply");
    let out = dir.path("mesh.pcd");
    refused(&["convert", &arg(&mesh), "-o", &arg(&out)], "faces");
    assert!(!out.exists());
}

#[test]
fn meshes_and_quilts_go_through_gltf_files() {
    let dir = Scratch::new();
    let read = |path: &Path| geosynth::core::io::read_geometry(path).unwrap().geometry;
    let mesh = geosynth::fixtures::bundled_dir().join("torus_mesh.ply");
    let exemplar = bumpy_exemplar();
    let quilted = dir.path("q.ply");
    ok(&[&small_quilt(&exemplar)[..], &[&arg(&quilted)]].concat());
    for (input, kind) in [(mesh, "mesh"), (quilted, "quilt")] {
        let original = read(&input);
        for (ext, format, encoding) in [("glb", "GLB", "binary"), ("gltf", "glTF", "JSON")] {
            let gltf = dir.path(&format!("{kind}.{ext}"));
            let said = ok(&["convert", &arg(&input), "-o", &arg(&gltf)]);
            assert!(said.contains(&format!("({format}):")), "{said}");
            let json = info_json(&gltf);
            assert_eq!(json["format"], format);
            assert_eq!(json["encoding"], encoding);
            // Back to PLY: the same vertices, normals, faces and attributes.
            let back = dir.path(&format!("{kind}_{ext}.ply"));
            ok(&["convert", &arg(&gltf), "-o", &arg(&back), "-q"]);
            let back = read(&back);
            assert_eq!(back.points().positions(), original.points().positions());
            assert_eq!(back.points().normals(), original.points().normals());
            assert_eq!(
                back.mesh().map(|m| m.triangles().to_vec()),
                original.mesh().map(|m| m.triangles().to_vec())
            );
            let patch = |g: &Geometry| g.points().attribute("patch").map(|a| a.values().to_vec());
            assert_eq!(patch(&back), patch(&original));
            let png = dir.path(&format!("{kind}_{ext}.png"));
            ok(&[
                "render",
                &arg(&gltf),
                "-o",
                &arg(&png),
                "--width",
                "160",
                "--height",
                "120",
            ]);
            assert!(png.exists());
        }
    }
    let said = ok(&[
        "convert",
        &arg(&dir.path("mesh.glb")),
        "-o",
        &arg(&dir.path("again.glb")),
        "--ascii",
    ]);
    assert!(said.contains("GLB is always binary"), "{said}");
}

/// The bundled bumpy exemplar, as an argument.
fn bumpy_exemplar() -> String {
    arg(&geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply"))
}

/// A quick quilt of `exemplar` (no quality measure, 1.2 times its box), up to `-o`.
fn small_quilt(exemplar: &str) -> [&str; 7] {
    [
        "quilt",
        exemplar,
        "--no-quality",
        "--scale",
        "1.2",
        "-q",
        "-o",
    ]
}
