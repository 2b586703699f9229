//! Surfaces from points and meshes: `normals`, `reconstruct`, `sdf` and `warp`.

use std::path::Path;

use crate::{
    Scratch, arg, assert_closed, assert_peak_memory, every_third_flipped, geosynth, info_json, ok,
    refused, timed_stages, tiny_voxel, write_with_defaults,
};

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
        "--estimate-normals estimates and orients them",
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
fn keep_directions_orients_the_normals_a_file_has_without_refitting_them() {
    use geosynth::core::io::{Geometry, read_geometry};
    let dir = Scratch::new();
    // The torus fixture's true normals with every third flipped, as unoriented estimates
    // come; directions exact, so a refit would change them.
    let fixture = geosynth::fixtures::bundled_dir().join("torus_points.ply");
    let truth = read_geometry(&fixture).unwrap().geometry.points().clone();
    let true_normals = truth.normals().unwrap().to_vec();
    let mixed = every_third_flipped(&truth);
    let input = dir.path("mixed.ply");
    write_with_defaults(&input, &Geometry::Points(mixed.clone()));
    let (out, report) = (dir.path("kept.ply"), dir.path("kept.json"));
    let args = [
        "normals",
        &arg(&input),
        "-o",
        &arg(&out),
        "--keep-directions",
        "--report",
        &arg(&report),
    ];
    let said = ok(&args);
    assert!(said.contains("0.0% face away"), "{said}");
    let kept = read_geometry(&out).unwrap().geometry.points().clone();
    // Every normal is the file's own, turned or not, and all face out again.
    let pairs = kept.normals().unwrap().iter().zip(&true_normals);
    assert!(pairs.clone().all(|(k, t)| *k == *t), "every sign restored");
    assert_eq!(kept.positions(), truth.positions());
    // The library's orientation of the same points, bit for bit.
    let library = geosynth::mls::orient_normals(&mixed, glam::Vec3::Z).unwrap();
    assert_eq!(kept.normals(), library.normals());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(json["directions"], "kept");
    assert!(json["neighbours"].is_null() && json["undefined_normals"].is_null());
    // Nothing to keep, or --neighbours beside it: refused.
    let bare = dir.path("bare.ply");
    let positions = geosynth::core::PointSet::new(truth.positions().to_vec()).unwrap();
    write_with_defaults(&bare, &Geometry::Points(positions));
    refused(
        &[
            "normals",
            &arg(&bare),
            "-o",
            &arg(&out),
            "--keep-directions",
        ],
        "points have no normal direction to keep",
    );
    refused(
        &[&args[..5], &["--neighbours", "8"]].concat(),
        "cannot be used with",
    );
}

/// An XYZ scan of the plane z = 0.1 x in 10 lines 0.5 apart, sampled every 0.01 along
/// them (2000 points): 12 neighbours lie on one line, which fixes no normal.
fn write_scan_lines(path: &Path) {
    let lines: String = (0..2000)
        .map(|i| {
            let (x, y) = ((i % 200) as f32 * 0.01, (i / 200) as f32 * 0.5);
            format!("{x} {y} {}\n", 0.1 * x)
        })
        .collect();
    std::fs::write(path, lines).unwrap();
}

#[test]
fn neighbours_taking_in_every_point_are_told_to_shrink_not_grow() {
    // A sphere's 2,000 points, each fitted to all of them: spread alike every way, no
    // plane. The note says the count takes in every point and names the default, not
    // that a larger count would reach further.
    let dir = Scratch::new();
    let sphere = geosynth::fixtures::bundled_dir().join("sphere_points.ply");
    let out = dir.path("sphere.ply");
    let said = ok(&[
        "normals",
        &arg(&sphere),
        "-o",
        &arg(&out),
        "--neighbours",
        "100000",
    ]);
    assert!(said.contains("2000 of 2000 points"), "{said}");
    assert!(said.contains("takes in all 2000 points"), "{said}");
    assert!(said.contains("the default is 12"), "{said}");
    assert!(!said.contains("large enough to reach"), "{said}");
}

#[test]
fn scan_lines_too_far_apart_for_the_neighbours_or_the_kernel_get_notes() {
    let dir = Scratch::new();
    let scan = dir.path("scan.xyz");
    write_scan_lines(&scan);
    let (out, report) = (dir.path("scan.xyzn"), dir.path("normals.json"));
    let normals = |neighbours: &str| {
        let said = ok(&[
            "normals",
            &arg(&scan),
            "-o",
            &arg(&out),
            "--neighbours",
            neighbours,
            "--report",
            &arg(&report),
        ]);
        let read = geosynth::core::io::read_geometry(&out).unwrap().geometry;
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        (said, read.points().normals().unwrap().to_vec(), json)
    };
    // The plane's unit normal, facing up.
    let up = glam::Vec3::new(-0.1, 0.0, 1.0).normalize();
    let (said, estimated, json) = normals("12");
    assert!(said.contains("2000 of 2000 points (100.0%)"), "{said}");
    assert!(said.contains("--neighbours"), "{said}");
    // The report counts what the note says, names each stage and the peak memory.
    assert_eq!(json["command"], "normals");
    assert_eq!(json["points"], 2000);
    assert_eq!(json["neighbours"], 12);
    assert_eq!(json["up"], "+Z");
    assert_eq!(json["undefined_normals"], 2000);
    assert_eq!(json["output"], arg(&out));
    let stages: Vec<&str> = json["timings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            assert!(t["seconds"].as_f64().unwrap() >= 0.0, "{t}");
            t["stage"].as_str().unwrap()
        })
        .collect();
    assert_eq!(stages, crate::NORMALS_PHASES);
    assert_peak_memory(&json);
    let off = estimated.iter().filter(|n| n.dot(up) < 0.9).count();
    assert!(
        off > 200,
        "{off} of the arbitrary normals are off the plane's"
    );
    // Neighbourhoods that reach the next lines find the plane, and nothing is noted.
    let (said, estimated, json) = normals("160");
    assert!(!said.contains("note"), "{said}");
    assert!(estimated.iter().all(|n| n.dot(up) > 0.999));
    assert_eq!(json["undefined_normals"], 0);
    assert_eq!(json["facing_away_share"], 0.0);
    // The report may not overwrite the output.
    refused(
        &[
            "normals",
            &arg(&scan),
            "-o",
            &arg(&out),
            "--report",
            &arg(&out),
        ],
        "given for two of the outputs",
    );
    refused(
        &[
            "normals",
            &arg(&scan),
            "-o",
            &arg(&out),
            "--neighbours",
            "2",
        ],
        "at least 3",
    );

    // Reconstructed with the kernel of the step along the lines, the trim cuts the sheet
    // into strips; the note says so and gives a kernel and a trim that keep it whole.
    let mesh = dir.path("scan.ply");
    let reconstruct = |extra: &[&str]| {
        let args = [
            "reconstruct",
            &arg(&out),
            "-o",
            &arg(&mesh),
            "--resolution",
            "64",
        ];
        let said = ok(&[&args[..], extra].concat());
        (
            said,
            info_json(&mesh)["topology"]["components"].as_u64().unwrap(),
        )
    };
    let (said, strips) = reconstruct(&["--trim"]);
    assert!(said.contains("the points lie in lines"), "{said}");
    assert!(strips > 5, "{strips} pieces");
    // The advice: "--kernel K spans the gaps, and --trim T keeps …".
    let value_after = |flag: &str| {
        let at = said.find(flag).unwrap() + flag.len();
        said[at..]
            .split_whitespace()
            .next()
            .unwrap()
            .trim_end_matches(',')
            .to_string()
    };
    let (kernel, trim) = (value_after("--kernel "), value_after("--trim "));
    let kernel_value: f32 = kernel.parse().unwrap();
    assert!((0.2..0.3).contains(&kernel_value), "{kernel}");
    let (said, pieces) = reconstruct(&["--kernel", &kernel, "--trim", &trim]);
    assert!(!said.contains("the points lie in lines"), "{said}");
    assert_eq!(pieces, 1, "{said}");
    // The sheet is the plane's, trimmed back to within the trim (0.31) of the scan (x 0–2,
    // y 0–4.5).
    let sheet = geosynth::core::io::read_geometry(&mesh).unwrap().geometry;
    for p in sheet.points().positions() {
        assert!((p.z - 0.1 * p.x).abs() < 0.01, "{p}");
        assert!(
            p.x > -0.35 && p.x < 2.35 && p.y > -0.35 && p.y < 4.85,
            "{p}"
        );
    }
    // sdf notes it too; a well-sampled surface gets no such note.
    let field = dir.path("scan.nrrd");
    let said = ok(&["sdf", &arg(&out), "-o", &arg(&field), "--resolution", "16"]);
    assert!(said.contains("the points lie in lines"), "{said}");
    let sphere = geosynth::fixtures::bundled_dir().join("sphere_points.ply");
    let said = ok(&[
        "sdf",
        &arg(&sphere),
        "-o",
        &arg(&field),
        "--resolution",
        "16",
    ]);
    assert!(!said.contains("note"), "{said}");
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
    let mixed = dir.path().join("mixed.ply");
    let unoriented = every_third_flipped(torus.points());
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
    // `--orient-normals` repairs them: no note, and the surface is the torus again; the
    // summary times the orientation before the reconstruction.
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
    let (orienting, field) = (
        said.find(", orienting normals "),
        said.find(", reconstruct: distance field "),
    );
    assert!(orienting.is_some() && orienting < field, "{said}");
    assert_closed(&probe, 0, "a torus");
    // The positions alone: `--estimate-normals` fits and orients them first, and the
    // surface is the torus again; the report records the neighbours, and `--params`
    // reading it estimates them again. Fewer than 3 neighbours are refused.
    let bare = dir.path().join("bare.xyz");
    let positions = geosynth::core::PointSet::new(torus.points().positions().to_vec()).unwrap();
    write_with_defaults(&bare, &geosynth::core::io::Geometry::Points(positions));
    let report = dir.path().join("estimated.json");
    let estimate = |extra: &[&str]| {
        let args = [
            &[
                "reconstruct",
                bare.to_str().unwrap(),
                "-o",
                probe.to_str().unwrap(),
            ][..],
            extra,
        ]
        .concat();
        ok(&args)
    };
    estimate(&[
        "--resolution",
        "40",
        "--estimate-normals",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert_closed(&probe, 0, "a torus from its positions alone");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(json["input_options"]["estimate_normals"], 12);
    assert_eq!(json["input_options"]["up"], "z");
    // The estimation's stages are timed in the report, before the reconstruction's.
    let stages = timed_stages(&json, "timings");
    assert_eq!(
        stages[..4],
        [
            "reading",
            "preparing the input",
            "fitting normals",
            "orienting normals"
        ],
        "{stages:?}"
    );
    let replayed = estimate(&["--params", report.to_str().unwrap()]);
    assert!(!replayed.contains("no normals"), "{replayed}");
    assert_closed(&probe, 0, "the torus again, from the report");
    let too_few = [
        "reconstruct",
        bare.to_str().unwrap(),
        "-o",
        probe.to_str().unwrap(),
        "--estimate-normals",
        "2",
    ];
    refused(&too_few, "at least 3");
    // `--up` turns what is oriented; alone it would do nothing, and is refused.
    let sideways = dir.path().join("sideways.json");
    estimate(&[
        "--resolution",
        "24",
        "--estimate-normals",
        "--up",
        "y",
        "--report",
        sideways.to_str().unwrap(),
    ]);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&sideways).unwrap()).unwrap();
    assert_eq!(json["input_options"]["up"], "y");
    let args = [
        "reconstruct",
        points.to_str().unwrap(),
        "-o",
        probe.to_str().unwrap(),
        "--up",
        "y",
    ];
    refused(
        &args,
        "--up turns normals that --orient-normals or --estimate-normals orients",
    );

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
    // `geosynth warp INPUT --pairs PAIRS -o OUTPUT`.
    let warp = |input: &Path, output: &Path| {
        [
            "warp",
            &arg(input),
            "--pairs",
            &arg(&pairs),
            "-o",
            &arg(output),
        ]
        .map(String::from)
    };
    let input = geosynth::fixtures::bundled_dir().join("sphere_points.ply");
    let out = dir.path().join("warped.ply");
    let report = dir.path().join("r.json");
    let read_report = || -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap()
    };
    let (base, report_arg) = (warp(&input, &out), arg(&report));
    let with_report = [
        &base.each_ref().map(String::as_str)[..],
        &["--report", &report_arg],
    ]
    .concat();
    let said = ok(&with_report);
    assert!(!said.contains("folds space"), "{said}");
    // The report: a rotation meets its targets, moves the unit sphere's equator by √2 and
    // folds nothing.
    let r = read_report();
    assert_eq!(
        (r["command"].as_str(), r["pairs"].as_u64()),
        (Some("warp"), Some(5))
    );
    assert!(r["largest_target_miss"].as_f64().unwrap() < 1e-5, "{r}");
    let moved = r["largest_displacement"].as_f64().unwrap();
    assert!((moved - 2f64.sqrt()).abs() < 0.01, "{moved}");
    assert_eq!(r["folded_points"], 0);
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
    ok(&warp(&mesh_in, &mesh_out).each_ref().map(String::as_str));
    let json = info_json(&mesh_out);
    assert_eq!(json["faces"], 48 * 24 * 2);
    // Pairs whose targets swap the order of their sources fold space where they cross:
    // a note and the count, which smoothing takes away.
    let swap: String = [(-1.5, -1.5), (-0.5, 0.5), (0.5, -0.5), (1.5, 1.5)]
        .iter()
        .flat_map(|&(x, to)| {
            [(-1, -1), (1, -1), (-1, 1), (1, 1)].map(|(y, z)| format!("{x} {y} {z} {to} {y} {z}\n"))
        })
        .collect();
    std::fs::write(&pairs, swap).unwrap();
    let said = ok(&with_report);
    assert!(said.contains("the spline folds space at"), "{said}");
    let folded = read_report()["folded_points"].as_u64().unwrap();
    assert!(folded > 100 && folded < 2000, "{folded}");
    let said = ok(&[&with_report[..], &["--smoothing", "1"]].concat());
    assert!(!said.contains("folds space"), "{said}");
    let r = read_report();
    assert_eq!(r["folded_points"], 0);
    assert!(r["largest_target_miss"].as_f64().unwrap() > 0.1, "{r}");
    // x ↦ (x + 1)·1e30 stays within single precision; the report still measures how far
    // the sphere's point at x = 1 moves, 2e30 (its square overflows f32: the report said
    // null).
    let far: String = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
        .iter()
        .map(|(x, y, z)| format!("{x} {y} {z} {}e30 {y} {z}\n", x + 1))
        .collect();
    std::fs::write(&pairs, far).unwrap();
    ok(&with_report);
    let moved = read_report()["largest_displacement"].as_f64();
    assert!(
        moved.is_some_and(|d| (d / 2e30 - 1.0).abs() < 1e-3),
        "{moved:?}"
    );
    // Bad pairs files fail with the line.
    std::fs::write(&pairs, "1 0 0 0 1 0\n1 2 3\n").unwrap();
    let args = warp(&input, &out);
    let args = args.each_ref().map(String::as_str);
    refused(&args, "pairs.txt:2");
    // So do pairs that leave one point for two places, naming both lines.
    std::fs::write(&pairs, "1 0 0 0 1 0\n# moved\n1 0 0 0 2 0\n").unwrap();
    refused(&args, "pairs.txt:1 and 3: both pairs start at one point");
    // Targets so far that the warped points leave single precision are refused, and
    // nothing is written.
    std::fs::write(&pairs, "0 0 0 0 0 3e38\n1 0 0 1 0 0\n0 1 0 0 1 0\n").unwrap();
    let fresh = dir.path().join("never.ply");
    refused(
        &warp(&input, &fresh).each_ref().map(String::as_str),
        "beyond single precision",
    );
    assert!(!fresh.exists());
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
    // A limit above every piece would leave nothing: refused, nothing written (an empty
    // mesh was written).
    let empty = dir.path("empty.ply");
    refused(
        &[
            "reconstruct",
            &arg(&points),
            "-o",
            &arg(&empty),
            "--drop-pieces=1e30",
        ],
        "drops every piece (2 of them)",
    );
    assert!(!empty.exists());
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
fn sdf_estimates_or_orients_a_point_sets_normals_as_reconstruct_does() {
    use geosynth::core::PointSet;
    use geosynth::core::io::Geometry;
    use geosynth::normals::EstimateNormals;
    use geosynth::{RunContext, Stage};
    let dir = tempfile::tempdir().unwrap();
    let torus = geosynth::core::io::read_geometry(
        geosynth::fixtures::bundled_dir().join("torus_points.ply"),
    )
    .unwrap()
    .geometry;
    // The torus's positions alone, and with the normals the library estimates for them.
    let bare_points = PointSet::new(torus.points().positions().to_vec()).unwrap();
    let fit = EstimateNormals::default()
        .run(bare_points.clone(), &mut RunContext::new(0))
        .unwrap();
    let (bare, estimated) = (dir.path().join("bare.ply"), dir.path().join("est.ply"));
    write_with_defaults(&bare, &Geometry::Points(bare_points));
    write_with_defaults(&estimated, &Geometry::Points(fit.points.clone()));
    // The estimated normals with every third one flipped, as unoriented estimates come.
    let mixed = dir.path().join("mixed.ply");
    write_with_defaults(&mixed, &Geometry::Points(every_third_flipped(&fit.points)));
    let report = dir.path().join("r.json");
    let sdf = |input: &Path, out: &str, extra: &[&str]| {
        let out = dir.path().join(out);
        let run = ["sdf", input.to_str().unwrap(), "-o", out.to_str().unwrap()];
        let said = ok(&[&run[..], &["--resolution", "24"], extra].concat());
        (std::fs::read(out).unwrap(), said)
    };
    let (from_estimated, _) = sdf(&estimated, "est.nrrd", &[]);
    let report_arg = report.to_str().unwrap();
    let (from_bare, _) = sdf(
        &bare,
        "bare.nrrd",
        &["--estimate-normals", "--report", report_arg],
    );
    assert!(from_bare == from_estimated);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(json["input_options"]["estimate_normals"], 12);
    let stages = timed_stages(&json, "timings");
    assert_eq!(
        stages,
        [
            "reading",
            "preparing the input",
            "fitting normals",
            "orienting normals",
            "signed distance: surface",
            "signed distance: sampling",
            "writing"
        ],
        "{stages:?}"
    );
    // `--params` reads the bare points as the report's run did.
    let (replayed, _) = sdf(&bare, "replayed.nrrd", &["--params", report_arg]);
    assert!(replayed == from_bare);
    // Flipped signs: a note, and `--orient-normals` turns them back.
    let (as_read, said) = sdf(&mixed, "mixed.nrrd", &[]);
    assert!(
        said.contains("look unoriented") && as_read != from_estimated,
        "{said}"
    );
    let (oriented, said) = sdf(&mixed, "oriented.nrrd", &["--orient-normals"]);
    assert!(!said.contains("look unoriented"), "{said}");
    assert!(oriented == from_estimated);
    let up_alone = ["sdf", bare.to_str().unwrap(), "-o", "x.nrrd", "--up", "y"];
    refused(
        &up_alone,
        "--up turns normals that --orient-normals or --estimate-normals",
    );
}

#[test]
fn kernels_over_a_tenth_of_the_points_extent_are_called_large_not_small() {
    let dir = Scratch::new();
    let fixtures = geosynth::fixtures::bundled_dir();
    let (sheet, sphere) = (
        arg(&fixtures.join("quilt_bumpy.ply")),
        arg(&fixtures.join("sphere_points.ply")),
    );
    let mesh = arg(&dir.path("mesh.ply"));
    fn args<'a>(input: &'a str, mesh: &'a str, kernel: &[&'a str]) -> Vec<&'a str> {
        let mut args = vec!["reconstruct", input, "-o", mesh, "--resolution", "24"];
        args.extend(kernel);
        args
    }
    let reconstruct = |input, kernel| args(input, &mesh, kernel);
    // The bumpy sheet (diagonal 8.5) runs out to the grid's sides at its default kernel,
    // called small, and at h = 1, called large: more of it would not help.
    let said = ok(&reconstruct(&sheet, &[]));
    assert!(said.contains("probably too small"), "{said}");
    assert!(!said.contains("smooths away"), "{said}");
    let said = ok(&reconstruct(&sheet, &["--kernel", "1"]));
    assert!(!said.contains("too small"), "{said}");
    for part in [
        "h = 1 spans more than a tenth of the points' extent (diagonal 8.5)",
        "an open sheet flattens toward one plane",
        "the default for these points is 0.0336",
    ] {
        assert!(said.contains(part), "{said}");
    }
    // The unit sphere's samples (diagonal 3.46): closed at h = 0.3, no surface at all at
    // h = 1, and the refusal says why.
    let said = ok(&reconstruct(&sphere, &["--kernel", "0.3"]));
    assert!(said.contains("1 component(s), closed"), "{said}");
    refused(
        &reconstruct(&sphere, &["--kernel", "1"]),
        "never crosses zero (values 0.09437914 to 0.43837994); the MLS surface of the points \
         could not be sampled there; the MLS kernel h = 1 spans more than a tenth",
    );
    // Kernels whose squares overflow are refused before anything runs: at 1e30 a scan of
    // the gathered samples once read past them and panicked.
    refused(&reconstruct(&sphere, &["--kernel", "1e30"]), "at most 1e18");
    refused(&reconstruct(&sphere, &["--kernel", "1e19"]), "at most 1e18");
}
