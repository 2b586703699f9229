//! Points a surface should not be built through: stray points far outside the rest,
//! isolated points and scattered outliers, as `reconstruct`, `sdf`, `render` and `info`
//! treat them.

use std::path::Path;

use crate::{Scratch, arg, info_json, ok, write_with_defaults};

#[test]
fn stray_points_are_left_out_of_surfaces_and_framed_out_of_pictures() {
    use geosynth::core::TriMesh;
    use geosynth::core::io::Geometry;
    use glam::Vec3;
    let dir = Scratch::new();
    let points = bundled_points("torus_points.ply");
    // One point 40 units off, among the others.
    let with_stray = with_points(&points, &[(5, Vec3::new(40.0, 0.0, 0.0), Vec3::X)]);
    let (clean, stray) = (dir.path("clean.ply"), dir.path("stray.ply"));
    write_with_defaults(&clean, &Geometry::Points(points.clone()));
    write_with_defaults(&stray, &Geometry::Points(with_stray));
    let run = |command: &str, input: &Path, out: &str, extra: &[&str]| {
        let out = dir.path(out);
        let base = [command, &arg(input), "-o", &arg(&out), "--resolution", "24"];
        let said = ok(&[&base[..], extra].concat());
        (std::fs::read(out).unwrap(), said)
    };
    // Left out: the field is the clean cloud's, byte for byte, and the report counts it.
    let report = arg(&dir.path("r.json"));
    let (clean_field, _) = run("sdf", &clean, "clean.nrrd", &[]);
    let (field, said) = run("sdf", &stray, "stray.nrrd", &["--report", &report]);
    assert!(
        said.contains("1 point of") && said.contains("left out, since the grid would span it"),
        "{said}"
    );
    assert!(field == clean_field);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(json["strays_left_out"], 1);
    assert_eq!(json["input_options"]["keep_strays"], false);
    // Kept: the grid spans the stray point, and `--params` keeps it again.
    let (kept, said) = run(
        "sdf",
        &stray,
        "kept.nrrd",
        &["--keep-strays", "--report", &report],
    );
    assert!(said.contains("kept (--keep-strays)"), "{said}");
    assert!(kept != clean_field);
    let (replayed, _) = run("sdf", &stray, "replayed.nrrd", &["--params", &report]);
    assert!(replayed == kept);
    // `reconstruct` leaves it out too: the clean cloud's mesh.
    let mesh = |name: &str| -> TriMesh {
        match geosynth::core::io::read_geometry(dir.path(name))
            .unwrap()
            .geometry
        {
            Geometry::Mesh(mesh) => mesh,
            Geometry::Points(_) => panic!("{name} holds no faces"),
        }
    };
    run("reconstruct", &clean, "clean_mesh.ply", &[]);
    let (_, said) = run("reconstruct", &stray, "stray_mesh.ply", &[]);
    assert!(said.contains("left out"), "{said}");
    assert_eq!(mesh("stray_mesh.ply"), mesh("clean_mesh.ply"));
    let clean_said = run("reconstruct", &clean, "again.ply", &[]).1;
    assert!(!clean_said.contains("far outside the rest"), "{clean_said}");
    // `render` frames the others: the same picture as the clean cloud's.
    let picture = |input: &Path, name: &str| {
        let out = dir.path(name);
        let said = ok(&["render", &arg(input), "-o", &arg(&out)]);
        (std::fs::read(out).unwrap(), said)
    };
    let (clean_picture, said) = picture(&clean, "clean.png");
    assert!(!said.contains("far outside"), "{said}");
    let (stray_picture, said) = picture(&stray, "stray.png");
    assert!(
        said.contains("1 of its points lies far outside the rest"),
        "{said}"
    );
    assert!(stray_picture == clean_picture);
    // `info` counts them: for point sets only.
    let said = ok(&["info", &arg(&stray)]);
    assert!(
        said.contains("strays:      1 point lies far outside"),
        "{said}"
    );
    assert_eq!(info_json(&stray)["stray_points"], 1);
    assert_eq!(info_json(&clean)["stray_points"], 0);
    assert!(info_json(&dir.path("clean_mesh.ply"))["stray_points"].is_null());
}

#[test]
fn isolated_points_are_left_out_of_surfaces_unless_they_are_most_of_them() {
    use geosynth::core::io::Geometry;
    use glam::Vec3;
    let dir = Scratch::new();
    let points = bundled_points("sphere_points.ply");
    // Inside the unit sphere (sample spacing about 0.075): one point at the centre and a
    // clump of two, each far from the sphere's samples and from one another.
    let with = |extra: &[Vec3]| {
        let placed: Vec<_> = (extra.iter().enumerate())
            .map(|(i, p)| (7 * i, *p, Vec3::Z))
            .collect();
        Geometry::Points(with_points(&points, &placed))
    };
    let inside = [
        Vec3::ZERO,
        Vec3::new(0.3, 0.3, 0.0),
        Vec3::new(0.31, 0.3, 0.0),
    ];
    let (clean, hollow) = (dir.path("clean.ply"), dir.path("hollow.ply"));
    write_with_defaults(&clean, &Geometry::Points(points.clone()));
    write_with_defaults(&hollow, &with(&inside));
    let reconstruct = |input: &Path, name: &str, extra: &[&str]| {
        let (out, report) = (dir.path(name), dir.path(&format!("{name}.json")));
        let base = ["reconstruct", &arg(input), "-o", &arg(&out)];
        let said = ok(&[
            &base[..],
            &["--resolution", "32", "--report", &arg(&report)],
            extra,
        ]
        .concat());
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        (std::fs::read(out).unwrap(), json, said)
    };
    let (clean_mesh, clean_json, said) = reconstruct(&clean, "clean_mesh.ply", &[]);
    assert!(!said.contains("bubble"), "{said}");
    assert_eq!(clean_json["isolated_left_out"], 0);
    assert_eq!(clean_json["components"], 1);
    // Left out: the clean sphere's mesh (the header names another input).
    let body = |bytes: &[u8]| {
        let end = bytes.windows(10).position(|w| w == b"end_header").unwrap();
        bytes[end..].to_vec()
    };
    let (mesh, json, said) = reconstruct(&hollow, "hollow_mesh.ply", &[]);
    assert!(
        said.contains("3 points of") && said.contains("bubble of their own: left out"),
        "{said}"
    );
    assert_eq!(json["isolated_left_out"], 3);
    assert_eq!(body(&mesh), body(&clean_mesh));
    // Kept, they close into bubbles of their own (at this resolution the grid catches one
    // or both of them).
    let (_, json, said) = reconstruct(&hollow, "kept_mesh.ply", &["--keep-strays"]);
    assert!(said.contains("kept (--keep-strays)"), "{said}");
    assert_eq!(json["isolated_left_out"], 0);
    assert!(json["components"].as_u64().unwrap() > 1, "{said}");
    // `sdf` counts them too.
    let report = dir.path("sdf.json");
    let said = ok(&[
        "sdf",
        &arg(&hollow),
        "-o",
        &arg(&dir.path("f.nrrd")),
        "--resolution",
        "16",
        "--report",
        &arg(&report),
    ]);
    assert!(said.contains("bubble of their own: left out"), "{said}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(json["isolated_left_out"], 3);
    // More than 1% of the points alone are still left out, with their share: 24 points on
    // a circle of radius 1.6 about the sphere, 0.42 apart (1.2%).
    let ring: Vec<Vec3> = (0..24)
        .map(|i| {
            let a = i as f32 * std::f32::consts::TAU / 24.0;
            Vec3::new(1.6 * a.cos(), 1.6 * a.sin(), 0.0)
        })
        .collect();
    let sparse = dir.path("sparse.ply");
    write_with_defaults(&sparse, &with(&ring));
    let (mesh, json, said) = reconstruct(&sparse, "sparse_mesh.ply", &[]);
    assert!(
        said.contains("24 points of")
            && said.contains("left out (1.2% of the points; if they sample a part more sparsely"),
        "{said}"
    );
    assert_eq!(json["isolated_left_out"], 24);
    assert_eq!(body(&mesh), body(&clean_mesh));
    // `info` counts them and says what those commands do: for point sets only.
    let said = ok(&["info", &arg(&hollow)]);
    assert!(
        said.contains("isolated:    3 points have fewer than 3 others within ")
            && said.contains("reconstruct, sdf and quilt leave them out; --keep-strays"),
        "{said}"
    );
    let listed = |path: &Path| {
        let json = info_json(path);
        let (count, sparse) = (&json["isolated_points"], &json["isolated_sparse_sampling"]);
        (count.as_u64(), sparse.as_bool().unwrap())
    };
    assert_eq!(listed(&hollow), (Some(3), false));
    assert_eq!(listed(&clean), (Some(0), false));
    assert_eq!(listed(&sparse), (Some(24), false));
    assert_eq!(listed(&dir.path("clean_mesh.ply")), (None, false));
    // Most of the points alone: each sphere point twice, 0.001 apart, so that the kernel
    // estimated from the median spacing is too small for the sampling. They are kept.
    let doubled: Vec<_> = (points.positions().iter())
        .enumerate()
        .map(|(i, p)| (2 * i + 1, *p + Vec3::splat(0.001), Vec3::Z))
        .collect();
    let twice = dir.path("twice.ply");
    write_with_defaults(&twice, &Geometry::Points(with_points(&points, &doubled)));
    let field = arg(&dir.path("g.nrrd"));
    let said = ok(&["sdf", &arg(&twice), "-o", &field, "--resolution", "8"]);
    assert!(
        said.contains("4000 points of")
            && said.contains("kept, since they are 100.0% of the points: the kernel is too small")
            && said.contains("(a larger --kernel widens it)"),
        "{said}"
    );
    assert_eq!(listed(&twice), (Some(4000), true));
}

#[test]
fn a_scan_with_outliers_scattered_through_its_box_reconstructs_whole() {
    // The shared bunny scan with 2% of its count (322 points) spread through its box, with
    // random normals, as a scanner's outliers: the isolated ones (more than 1% of the
    // points) are left out, and the winding sign and the small pieces' removal deal with
    // those near the surface. Kept, they close into bubbles and sheets around the bunny.
    use geosynth::core::io::Geometry;
    use geosynth::core::rng::mix64;
    use glam::Vec3;
    let Some(bunny) = geosynth::core::testdata::shared_data(
        "scattered outliers",
        "pointsets/bunny16k_normals.ply",
    ) else {
        return;
    };
    let dir = Scratch::new();
    let points = geosynth::core::io::read_geometry(&bunny).unwrap().geometry;
    let (points, bounds) = (points.points(), points.bounding_box().unwrap());
    let unit = |k: u64| (mix64(k) >> 40) as f32 / (1u64 << 24) as f32;
    let outliers: Vec<_> = (0..322u64)
        .map(|i| {
            let r = Vec3::new(unit(6 * i), unit(6 * i + 1), unit(6 * i + 2));
            let n = Vec3::new(unit(6 * i + 3), unit(6 * i + 4), unit(6 * i + 5)) - 0.5;
            let at = bounds.min + r * bounds.extent();
            (50 * i as usize, at, n.normalize_or(Vec3::Z))
        })
        .collect();
    let noisy = dir.path("noisy.ply");
    write_with_defaults(&noisy, &Geometry::Points(with_points(points, &outliers)));
    let reconstruct = |input: &Path, name: &str, extra: &[&str]| {
        let report = dir.path(&format!("{name}.json"));
        let run = ["reconstruct", &arg(input), "-o", &arg(&dir.path(name))];
        let flags = ["--resolution", "48", "--sign", "winding", "--drop-pieces"];
        let said = ok(&[&run[..], &flags, &["--report", &arg(&report)], extra].concat());
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        (json, said)
    };
    let (json, said) = reconstruct(&noisy, "whole.ply", &[]);
    let left_out = json["isolated_left_out"].as_u64().unwrap();
    assert!(left_out > 200 && left_out <= 322, "{said}");
    assert!(
        said.contains("% of the points; if they sample a part"),
        "{said}"
    );
    // The clean scan's surface: one closed piece of the same topology (at this resolution
    // the ears' thin tips make handles), with nearly as many vertices.
    let (clean, _) = reconstruct(&bunny, "clean.ply", &[]);
    let (noisy_info, clean_info) = (
        info_json(&dir.path("whole.ply")),
        info_json(&dir.path("clean.ply")),
    );
    assert_eq!(json["components"], 1, "{said}");
    assert_eq!(noisy_info["topology"], clean_info["topology"]);
    let vertices = |j: &serde_json::Value| j["vertices"].as_f64().unwrap();
    let ratio = vertices(&json) / vertices(&clean);
    assert!((ratio - 1.0).abs() < 0.02, "{ratio}: {said}");
    let (json, said) = reconstruct(&noisy, "kept.ply", &["--keep-strays"]);
    assert!(json["components"].as_u64().unwrap() > 1, "{said}");
}

/// The bundled point set `name` (`geosynth fixtures`' files).
fn bundled_points(name: &str) -> geosynth::core::PointSet {
    let read = geosynth::core::io::read_geometry(geosynth::fixtures::bundled_dir().join(name));
    read.unwrap().geometry.points().clone()
}

/// `points` with each `(index, position, normal)` of `extra` put in at its index, in turn.
fn with_points(
    points: &geosynth::core::PointSet,
    extra: &[(usize, glam::Vec3, glam::Vec3)],
) -> geosynth::core::PointSet {
    let mut positions = points.positions().to_vec();
    let mut normals = points.normals().unwrap().to_vec();
    for &(index, position, normal) in extra {
        positions.insert(index, position);
        normals.insert(index, normal);
    }
    geosynth::core::PointSet::new(positions)
        .and_then(|p| p.with_normals(normals))
        .unwrap()
}
