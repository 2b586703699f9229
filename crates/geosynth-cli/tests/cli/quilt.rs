//! `geosynth quilt` (paper 000): outputs, reports, baselines, previews and exemplars
//! written with another up axis.

use std::path::Path;

use crate::{Scratch, arg, geosynth, ok, refused};

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
    // An output wider than 64 exemplar boxes is refused before any note sizes it (it was
    // first announced as 5.8e26 million points), and nothing is written.
    let vast = dir.path().join("vast.ply");
    let vast_arg = vast.to_str().unwrap();
    let args = [
        "quilt",
        exemplar.to_str().unwrap(),
        "-o",
        vast_arg,
        "--size",
        "1e30,1",
    ];
    refused(&args, "at most 64 times the exemplar's box");
    let said = String::from_utf8_lossy(&geosynth(&args).stderr).into_owned();
    assert!(!said.contains("output points expected"), "{said}");
    assert!(!vast.exists());
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
fn orient_normals_repairs_an_exemplar_whose_normals_came_unoriented() {
    use geosynth::core::PointSet;
    use geosynth::core::io::{Geometry, WriteOptions, read_geometry, write_geometry};
    let dir = Scratch::new();
    let bumpy = read_geometry(geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply"))
        .unwrap()
        .geometry;
    // The bumpy fixture without its comments, every third normal turned when `turn`.
    let write = |name: &str, turn: bool| {
        let points = bumpy.points();
        let normals = points.normals().unwrap().iter().enumerate();
        let signed = normals.map(|(i, &n)| if turn && i % 3 == 0 { -n } else { n });
        let exemplar = PointSet::new(points.positions().to_vec())
            .unwrap()
            .with_normals(signed.collect())
            .unwrap();
        let path = dir.path(name);
        let geometry = Geometry::Points(exemplar);
        write_geometry(&path, &geometry, &WriteOptions::default()).unwrap();
        arg(&path)
    };
    let (kept, turned) = (write("kept.ply", false), write("turned.ply", true));
    let quilt = |input: &str, out: &str, more: &[&str]| {
        let out = arg(&dir.path(out));
        let run = [
            "quilt",
            input,
            "-o",
            &out,
            "--scale",
            "1.2",
            "--resolution",
            "24",
        ];
        ok(&[&run[..], &["--no-quality"], more].concat())
    };
    let note = "the normals look unoriented";
    assert!(quilt(&turned, "as_read.ply", &[]).contains(note));
    assert!(!quilt(&kept, "kept_out.ply", &[]).contains(note));
    let said = quilt(&turned, "oriented_out.ply", &["--orient-normals"]);
    assert!(!said.contains(note), "{said}");
    // Orienting turns every sign back: the quilt is the one of the fixture's own normals.
    let bytes = |name: &str| std::fs::read(dir.path(name)).unwrap();
    assert!(bytes("oriented_out.ply") == bytes("kept_out.ply"));
    assert!(bytes("as_read.ply") != bytes("kept_out.ply"));
}

#[test]
fn estimate_normals_quilts_a_bare_scan_as_the_estimated_file_would_be() {
    use geosynth::core::PointSet;
    use geosynth::core::io::{Geometry, read_geometry};
    use geosynth::normals::EstimateNormals;
    use geosynth::{RunContext, Stage};
    let dir = Scratch::new();
    let bumpy = read_geometry(geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply"))
        .unwrap()
        .geometry;
    // The bumpy fixture's positions alone, and with the normals the library estimates.
    let bare_points = PointSet::new(bumpy.points().positions().to_vec()).unwrap();
    let fit = EstimateNormals::default()
        .run(bare_points.clone(), &mut RunContext::new(0))
        .unwrap();
    let (bare, estimated) = (dir.path("bare.ply"), dir.path("estimated.ply"));
    crate::write_with_defaults(&bare, &Geometry::Points(bare_points));
    crate::write_with_defaults(&estimated, &Geometry::Points(fit.points));
    let (bare, estimated, report) = (arg(&bare), arg(&estimated), arg(&dir.path("r.json")));
    let quilt = |input: &str, out: &str, more: &[&str]| {
        let out = arg(&dir.path(out));
        let run = ["quilt", input, "-o", &out, "--scale", "1.2"];
        ok(&[&run[..], &["--resolution", "24", "--no-quality"], more].concat())
    };
    quilt(
        &bare,
        "from_bare.ply",
        &["--estimate-normals", "--report", &report],
    );
    quilt(&estimated, "from_estimated.ply", &[]);
    let bytes = |name: &str| std::fs::read(dir.path(name)).unwrap();
    assert!(bytes("from_bare.ply") == bytes("from_estimated.ply"));
    // The report records the estimation and times it; `--params` replays it.
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["input_options"]["estimate_normals"], 12);
    assert_eq!(r["undefined_normals"], 0);
    let stages = crate::timed_stages(&r, "timings");
    assert_eq!(
        stages[..4],
        [
            "reading",
            "fitting normals",
            "orienting normals",
            "preparing the input"
        ]
    );
    quilt(&bare, "replayed.ply", &["--params", &report]);
    assert!(bytes("replayed.ply") == bytes("from_bare.ply"));
    // A fixture read as stored is only read and prepared.
    quilt(&estimated, "plain.ply", &["--report", &report]);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let stages = crate::timed_stages(&r, "timings");
    assert_eq!(stages[..3], ["reading", "preparing the input", "synthesis"]);
    assert_eq!(r["undefined_normals"], serde_json::Value::Null);
}

#[test]
fn estimate_normals_is_refused_where_normals_come_otherwise() {
    let dir = Scratch::new();
    let out = arg(&dir.path("out.ply"));
    let bare = dir.path("bare.xyz");
    let grid: String = (0..400)
        .map(|k| format!("{} {} 0\n", (k % 20) as f32 * 0.1, (k / 20) as f32 * 0.1))
        .collect();
    std::fs::write(&bare, grid).unwrap();
    let bare = arg(&bare);
    refused(
        &["quilt", &bare, "-o", &out],
        "bare.xyz: the points have no normals, and patch quilting needs oriented points \
         (`geosynth quilt --estimate-normals`",
    );
    refused(
        &["quilt", &bare, "-o", &out, "--estimate-normals", "2"],
        "`2` is not a whole number of at least 3",
    );
    refused(
        &[
            "quilt",
            &bare,
            "-o",
            &out,
            "--estimate-normals",
            "--orient-normals",
        ],
        "cannot be used with",
    );
    let mesh = arg(&geosynth::fixtures::bundled_dir().join("torus_mesh.ply"));
    refused(
        &["quilt", &mesh, "-o", &out, "--estimate-normals"],
        "it is a mesh: its normals come from its faces",
    );
    refused_with_a_height_field(&dir, &["--estimate-normals"]);
}

#[test]
fn outputs_in_formats_without_normals_are_noted_or_refused() {
    let dir = Scratch::new();
    let exemplar = arg(&geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply"));
    // A quilt to LAS keeps its points (terrain tools read them) and says what it lost.
    let las = dir.path("q.las");
    let run = ["quilt", &exemplar, "-o", &arg(&las), "--scale", "1.2"];
    let said = ok(&[&run[..], &["--resolution", "24", "--no-quality"]].concat());
    assert!(
        said.contains("q.las: LAS cannot store the vertex normals, attribute `patch`; write .ply"),
        "{said}"
    );
    let written = geosynth::core::io::read_geometry(&las).unwrap().geometry;
    assert!(written.points().len() > 1000 && written.points().normals().is_none());
    // Normals to a format without them would write nothing of what was asked: refused
    // before the work.
    for name in ["n.las", "n.xyzrgb"] {
        refused(
            &["normals", &exemplar, "-o", &arg(&dir.path(name))],
            "stores no normals, and they are what `normals` writes",
        );
        assert!(!dir.path(name).exists());
    }
}

#[test]
fn box_sets_the_exemplar_box_in_file_coordinates() {
    let dir = Scratch::new();
    let fixture = arg(&geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply"));
    let quilt = |input: &str, out: &str, more: &[&str]| {
        let out = arg(&dir.path(out));
        let run = ["quilt", input, "-o", &out, "--scale", "1.2"];
        ok(&[&run[..], &["--resolution", "24", "--no-quality"], more].concat())
    };
    let bytes = |name: &str| std::fs::read(dir.path(name)).unwrap();
    // The fixture's own `texture_box`, given by hand, quilts as the comment does; another
    // box quilts otherwise.
    let own = "0,0,-0.024641763,4,4,0.517577";
    quilt(&fixture, "commented.ply", &[]);
    quilt(&fixture, "given.ply", &["--box", own]);
    assert!(bytes("given.ply") == bytes("commented.ply"));
    quilt(
        &fixture,
        "smaller.ply",
        &["--box", "0.5,0.5,-0.1,3.5,3.5,0.6"],
    );
    assert!(bytes("smaller.ply") != bytes("commented.ply"));
    // Bare positions with one stray point far above: left out, with a note, so the
    // quilt is the clean positions' byte for byte; kept, the default box reaches up to it
    // and is refused; --box does not reach it, and the report records the box for
    // --params.
    let bumpy = geosynth::core::io::read_geometry(Path::new(&fixture)).unwrap();
    let mut xyz = String::new();
    for p in bumpy.geometry.points().positions() {
        xyz += &format!("{} {} {}\n", p.x, p.y, p.z);
    }
    let clean = dir.path("clean.xyz");
    std::fs::write(&clean, &xyz).unwrap();
    xyz += "2 2 30000\n";
    let stray = dir.path("stray.xyz");
    std::fs::write(&stray, &xyz).unwrap();
    let (clean, stray) = (arg(&clean), arg(&stray));
    let report = arg(&dir.path("r.json"));
    quilt(&clean, "clean.ply", &["--estimate-normals"]);
    let said = quilt(
        &stray,
        "stray.ply",
        &["--estimate-normals", "--report", &report],
    );
    assert!(
        said.contains("note: 1 point of the exemplar lies far outside the rest")
            && said.contains("left out, since the default box would span it; --keep-strays"),
        "{said}"
    );
    assert!(!said.contains("taller along its up axis"), "{said}");
    assert!(bytes("stray.ply") == bytes("clean.ply"));
    let recorded = &report_of(&report)["stray_points"];
    assert_eq!(*recorded, serde_json::json!({"count": 1, "left_out": true}));
    let kept = geosynth(&[
        "quilt",
        &stray,
        "-o",
        &arg(&dir.path("x.ply")),
        "--estimate-normals",
        "--keep-strays",
    ]);
    let (said, error) = (
        String::from_utf8_lossy(&kept.stdout),
        String::from_utf8_lossy(&kept.stderr),
    );
    assert!(
        !kept.status.success() && error.contains("field spacings tall"),
        "{error}"
    );
    assert!(said.contains("kept (--keep-strays)"), "{said}");
    let said = quilt(
        &stray,
        "boxed.ply",
        &["--estimate-normals", "--box", own, "--report", &report],
    );
    assert!(!said.contains("taller along its up axis"), "{said}");
    assert!(!said.contains("far outside the rest"), "{said}");
    assert!(report_of(&report)["stray_points"].is_null());
    // Not stray under a given box, but isolated (fewer than 3 others near it).
    assert!(
        said.contains("1 point of the exemplar has fewer than 3 others"),
        "{said}"
    );
    assert_eq!(
        report_of(&report)["input_options"]["box"],
        serde_json::json!([0.0, 0.0, -0.024641763, 4.0, 4.0, 0.517577])
    );
    quilt(&stray, "replayed.ply", &["--params", &report]);
    assert!(bytes("replayed.ply") == bytes("boxed.ply"));
    // A fitted plane leaves the stray point out too.
    let said = quilt(
        &stray,
        "fitted.ply",
        &["--estimate-normals", "--up", "auto"],
    );
    assert!(
        said.contains("left out of the fitted plane and its box"),
        "{said}"
    );
    let out = arg(&dir.path("x.ply"));
    refused(
        &["quilt", &stray, "-o", &out, "--keep-strays", "--up", "auto"],
        "--keep-strays keeps stray and isolated points; --up auto always leaves them out",
    );
    // Refused: corners out of order, a fitted plane, a height field.
    refused(
        &["quilt", &fixture, "-o", &out, "--box", "4,0,0,0,4,1"],
        "needs six finite numbers",
    );
    refused(
        &["quilt", &stray, "-o", &out, "--box", own, "--up", "auto"],
        "--box gives a box along the file's axes, and --up auto",
    );
    refused_with_a_height_field(&dir, &["--box", own]);
}

#[test]
fn isolated_points_are_left_out_of_an_exemplar_under_its_box_unless_kept() {
    let dir = Scratch::new();
    let fixture = geosynth::fixtures::bundled_dir().join("quilt_bumpy.ply");
    let bumpy = geosynth::core::io::read_geometry(&fixture).unwrap();
    // The fixture as XYZN with its texture comments, and with five specks floating 0.45
    // above its base (away from its bumps), among its points.
    let specks = [(0.7, 0.9), (1.6, 2.9), (2.5, 1.3), (3.3, 3.4), (1.1, 2.2)];
    let mut clean: String = bumpy.comments.iter().map(|c| format!("# {c}\n")).collect();
    let mut specked = clean.clone();
    let points = bumpy.geometry.points();
    let normals = points.normals().unwrap();
    for (k, (p, n)) in points.positions().iter().zip(normals).enumerate() {
        let line = format!("{} {} {} {} {} {}\n", p.x, p.y, p.z, n.x, n.y, n.z);
        clean += &line;
        specked += &line;
        if let Some((x, y)) = specks.get(k / 2000).filter(|_| k % 2000 == 999) {
            specked += &format!("{x} {y} 0.45 0 0 1\n");
        }
    }
    let (clean_path, specked_path) = (dir.path("clean.xyzn"), dir.path("specked.xyzn"));
    std::fs::write(&clean_path, clean).unwrap();
    std::fs::write(&specked_path, specked).unwrap();
    let report = arg(&dir.path("r.json"));
    let quilt = |input: &Path, out: &str, more: &[&str]| {
        let out = arg(&dir.path(out));
        let run = ["quilt", &arg(input), "-o", &out, "--scale", "1.2"];
        ok(&[&run[..], &["--resolution", "24", "--report", &report], more].concat())
    };
    let bytes = |name: &str| std::fs::read(dir.path(name)).unwrap();
    quilt(&clean_path, "clean.ply", &[]);
    assert!(report_of(&report)["isolated_points"].is_null());
    let quality = |report: &serde_json::Value| report["run"]["quality"].clone();
    let clean_quality = quality(&report_of(&report));
    // Left out under the comments' box: the clean exemplar's quilt, byte for byte.
    let said = quilt(&specked_path, "specked.ply", &[]);
    assert!(
        said.contains("note: 5 points of the exemplar have fewer than 3 others within ")
            && said.contains("bubble of their own: left out; --keep-strays keeps them"),
        "{said}"
    );
    assert!(bytes("specked.ply") == bytes("clean.ply"));
    let recorded = report_of(&report);
    assert_eq!(recorded["isolated_points"]["count"], 5);
    assert_eq!(recorded["isolated_points"]["left_out"], true);
    assert_eq!(quality(&recorded), clean_quality);
    // Kept, with a box given too: the quilt copies them and its errors grow.
    let own = "0,0,-0.024641763,4,4,0.517577";
    let said = quilt(&specked_path, "kept.ply", &["--keep-strays", "--box", own]);
    assert!(
        said.contains("bubble of their own; kept (--keep-strays)"),
        "{said}"
    );
    let kept = report_of(&report);
    assert_eq!(kept["isolated_points"]["left_out"], false);
    let error = |q: &serde_json::Value, key: &str| q[key].as_f64().unwrap();
    for key in ["neighbourhood_error", "seam_error"] {
        assert!(
            error(&quality(&kept), key) > error(&clean_quality, key),
            "{key}: {} against {}",
            quality(&kept),
            clean_quality
        );
    }
}

/// The JSON report at `path`.
pub(crate) fn report_of(path: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// `quilt` of a flat height field with `flags` is refused: they are for point sets.
pub(crate) fn refused_with_a_height_field(dir: &Scratch, flags: &[&str]) {
    let map = dir.path("flat_8x8.f32le");
    std::fs::write(&map, vec![0u8; 8 * 8 * 4]).unwrap();
    let (map, out) = (arg(&map), arg(&dir.path("from_map.ply")));
    let run = ["quilt", "--heightfield", &map, "-o", &out];
    refused(&[&run[..], flags].concat(), "cannot be used with");
}
