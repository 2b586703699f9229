//! `geosynth quilt --heightfield-out`: quilts written back as height maps, placed where
//! their points are, with their GIS sidecars.

use std::path::Path;

use crate::{Scratch, arg, height_map_entry, ok, quilt_height_field_into, refused};

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
        // Measured at the default scale and seed: 27% of the chain mail's, 11% of bumpy's.
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
