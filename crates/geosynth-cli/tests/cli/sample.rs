//! `geosynth sample`: points on a mesh's surface, or fewer of a point set's own.

use geosynth::core::io::{Geometry, read_geometry};
use geosynth::core::{KdIndex, PointSet};

use super::*;

fn read_points(path: &Path) -> PointSet {
    match read_geometry(path).unwrap().geometry {
        Geometry::Points(points) => points,
        Geometry::Mesh(_) => panic!("{} holds a mesh", path.display()),
    }
}

/// Runs `geosynth sample MESH -o OUT` with `extra` arguments; returns what it printed.
fn sample(mesh: &Path, out: &Path, extra: &[&str]) -> String {
    let mut args = vec!["sample".to_string(), arg(mesh), "-o".into(), arg(out)];
    args.extend(extra.iter().map(|a| a.to_string()));
    ok(&args.iter().map(String::as_str).collect::<Vec<_>>())
}

/// A bundled fixture's path.
fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures")
        .join(name)
}

/// Reconstructs `points` into `mesh` at resolution 48, with `extra` arguments.
fn reconstruct_48(points: &Path, mesh: &Path, extra: &[&str]) {
    let mut args = vec![
        "reconstruct".to_string(),
        arg(points),
        "-o".into(),
        arg(mesh),
    ];
    args.extend(
        ["--resolution", "48"]
            .iter()
            .chain(extra)
            .map(|a| a.to_string()),
    );
    ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
}

/// The least distance between two of `points`, through their k-d tree.
fn closest_pair(points: &[glam::Vec3]) -> f32 {
    let index = KdIndex::new(points).unwrap();
    points
        .iter()
        .map(|p| index.nearest(*p, 2).unwrap()[1].distance_squared.sqrt())
        .fold(f32::INFINITY, f32::min)
}

#[test]
fn a_torus_sampled_as_a_poisson_disk_keeps_its_spacing_lies_on_the_mesh_and_reconstructs() {
    let dir = Scratch::new();
    let torus = fixture("torus_mesh.ply");
    let (out, report, mesh) = (dir.path("t.ply"), dir.path("r.json"), dir.path("m.ply"));
    let printed = sample(
        &torus,
        &out,
        &["--count", "6000", "--report", &arg(&report)],
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let spacing = r["spacing"].as_f64().unwrap() as f32;
    let points = read_points(&out);
    assert_eq!(r["points"], points.len());
    assert_eq!(
        timed_stages(&r, "timings"),
        ["reading", "sampling", "writing"]
    );
    assert_peak_memory(&r);
    assert!(
        printed.contains(&format!("{} points", points.len())),
        "{printed}"
    );
    // About the count asked for, no two closer than the spacing.
    assert!((5500..6500).contains(&points.len()), "{}", points.len());
    assert!(closest_pair(points.positions()) >= spacing);
    // On the torus (about +Y, major radius 1, minor 0.35; flat facets sag inward by
    // under 0.006), with
    // the facets' outward normals.
    let normals = points.normals().unwrap();
    for (p, n) in points.positions().iter().zip(normals) {
        let ring = glam::Vec3::new(p.x, 0.0, p.z).normalize();
        let tube = *p - ring;
        assert!((tube.length() - 0.35).abs() < 0.01, "{p}");
        assert!(n.dot(tube.normalize()) > 0.95, "{p}: {n}");
    }
    reconstruct_48(&out, &mesh, &[]);
    assert_closed(&mesh, 0, "the sampled torus reconstructed");
}

#[test]
fn uniform_samples_are_as_many_as_asked_and_a_seed_decides_them() {
    let dir = Scratch::new();
    let sphere = fixture("icosphere_mesh.ply");
    let run = |seed: &str, name: &str| {
        let out = dir.path(name);
        sample(
            &sphere,
            &out,
            &[
                "--uniform",
                "--count",
                "777",
                "--seed",
                seed,
                "--normals",
                "interpolated",
            ],
        );
        std::fs::read(out).unwrap()
    };
    let (a, again, other) = (run("4", "a.ply"), run("4", "b.ply"), run("5", "c.ply"));
    assert_eq!(a, again);
    assert_ne!(a, other);
    let points = read_points(&dir.path("a.ply"));
    assert_eq!(points.len(), 777);
    // Interpolated normals on a sphere point along the radius.
    for (p, n) in points.positions().iter().zip(points.normals().unwrap()) {
        assert!(n.angle_between(p.normalize()) < 0.05, "{p}: {n}");
    }
}

#[test]
fn vertex_colours_are_carried_onto_the_points() {
    let dir = Scratch::new();
    let (mesh_path, out) = (dir.path("coloured.ply"), dir.path("p.ply"));
    let mut sphere = geosynth::fixtures::icosphere_mesh(2).unwrap();
    let colours: Vec<[f32; 3]> = sphere
        .positions()
        .iter()
        .map(|p| [(p.x + 1.0) / 2.0, 0.5, 0.0])
        .collect();
    let (mut vertices, triangles, _) = sphere.clone().into_parts();
    vertices.set_colors(&colours).unwrap();
    sphere = geosynth::core::TriMesh::new(vertices, triangles).unwrap();
    write_with_defaults(&mesh_path, &Geometry::Mesh(sphere));
    sample(&mesh_path, &out, &["--count", "500"]);
    let points = read_points(&out);
    let read = points.colors().unwrap();
    // Red follows x, as at the vertices (to within the 1/255 steps and the facets' sag).
    for (p, c) in points.positions().iter().zip(&read) {
        assert!((c[0] - (p.x + 1.0) / 2.0).abs() < 0.02, "{p}: {c:?}");
        assert!((c[1] - 0.5).abs() < 0.003 && c[2] == 0.0, "{c:?}");
    }
}

#[test]
fn a_point_set_is_thinned_to_its_own_points() {
    let dir = Scratch::new();
    let sphere = fixture("sphere_points.ply");
    let all = read_points(&sphere);
    let kept_from_input = |points: &PointSet| {
        let index = KdIndex::new(all.positions()).unwrap();
        points
            .positions()
            .iter()
            .zip(points.normals().unwrap())
            .all(|(p, n)| {
                let nearest = index.nearest(*p, 1).unwrap()[0];
                nearest.distance_squared == 0.0 && all.normals().unwrap()[nearest.index] == *n
            })
    };
    // By spacing: a Poisson disk of the sphere's own points, every one of them near one.
    let spaced = dir.path("spaced.ply");
    let printed = sample(&sphere, &spaced, &["--spacing", "0.2"]);
    let points = read_points(&spaced);
    assert!(
        printed.contains(&format!(
            "{} of {} points, none closer than 0.2)",
            points.len(),
            all.len()
        )),
        "{printed}"
    );
    assert!(closest_pair(points.positions()) >= 0.2);
    assert!(kept_from_input(&points));
    let index = KdIndex::new(points.positions()).unwrap();
    for p in all.positions() {
        assert!(index.nearest(*p, 1).unwrap()[0].distance_squared < 0.04);
    }
    // By count, with a report: the spacing found and the passes it took.
    let (counted, report) = (dir.path("counted.pcd"), dir.path("r.json"));
    let printed = sample(
        &sphere,
        &counted,
        &["--count", "300", "--report", &arg(&report)],
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let kept = r["points"].as_u64().unwrap();
    assert!(kept.abs_diff(300) <= 3, "{kept}");
    assert_eq!(r["points_before"], all.len());
    assert_eq!(r["thinning"]["poisson_disk_count"]["count"], 300);
    assert!(r["passes"].as_u64().unwrap() >= 1);
    assert_eq!(
        timed_stages(&r, "timings"),
        ["reading", "thinning", "writing"]
    );
    let spacing = r["spacing"].as_f64().unwrap() as f32;
    assert!(printed.contains("found in"), "{printed}");
    let points = read_points(&counted);
    assert_eq!(points.len() as u64, kept);
    assert!(closest_pair(points.positions()) >= spacing);
    // At random: exactly as many, decided by the seed.
    let (a, b) = (dir.path("a.ply"), dir.path("b.ply"));
    sample(&sphere, &a, &["--uniform", "--count", "40", "--seed", "3"]);
    sample(&sphere, &b, &["--uniform", "--count", "40", "--seed", "4"]);
    let (a, b) = (read_points(&a), read_points(&b));
    assert_eq!((a.len(), b.len()), (40, 40));
    assert!(kept_from_input(&a) && kept_from_input(&b));
    assert_ne!(a.positions(), b.positions());
}

#[test]
fn points_formats_and_options_that_cannot_work_are_refused() {
    let dir = Scratch::new();
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures");
    let (sphere, points) = (
        arg(&fixtures.join("icosphere_mesh.ply")),
        arg(&fixtures.join("sphere_points.ply")),
    );
    let out = arg(&dir.path("o.ply"));
    refused(
        &["sample", &points, "-o", &out, "--normals", "faces"],
        "is a point set: --normals is for sampling a mesh",
    );
    refused(
        &["sample", &points, "-o", &out, "--texture", &sphere],
        "is a point set: --texture",
    );
    refused(
        &["sample", &points, "-o", &out, "--spacing", "0"],
        "spacing",
    );
    refused(&["sample", &points, "-o", &out, "--count", "0"], "count");
    refused(&["sample", &sphere, "-o", &arg(&dir.path("o.stl"))], "STL");
    refused(
        &["sample", &sphere, "-o", &out, "--spacing", "0"],
        "spacing",
    );
    refused(
        &["sample", &sphere, "-o", &out, "--spacing", "1e-7"],
        "at least",
    );
    refused(&["sample", &sphere, "-o", &out, "--count", "0"], "count");
    // A count too large is refused as a count (it was refused by the spacing it gave).
    refused(
        &[
            "sample",
            &sphere,
            "-o",
            &out,
            "--count",
            "18446744073709551615",
        ],
        "parameter `count` = 18446744073709551615",
    );
    refused(
        &["sample", &sphere, "-o", &out, "--uniform", "--count", "0"],
        "count",
    );
    refused(
        &[
            "sample",
            &sphere,
            "-o",
            &out,
            "--spacing",
            "0.1",
            "--count",
            "5",
        ],
        "cannot be used with",
    );
    refused(
        &[
            "sample",
            &sphere,
            "-o",
            &out,
            "--spacing",
            "0.1",
            "--uniform",
        ],
        "cannot be used with",
    );
    let flat = dir.path("flat.obj");
    std::fs::write(&flat, "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").unwrap();
    refused(
        &["sample", &arg(&flat), "-o", &out],
        "every triangle has zero area",
    );
    std::fs::remove_file(&flat).unwrap();
    assert!(dir.names().is_empty(), "{:?}", dir.names());
    // A spacing wider than the sphere draws no candidate: one point, so said.
    let said = ok(&["sample", &sphere, "-o", &out, "--spacing", "1e30"]);
    assert!(
        said.contains("(1 point, alone at a spacing of 1000000000000000000000000000000"),
        "{said}"
    );
    assert_eq!(read_points(&dir.path("o.ply")).len(), 1);
    std::fs::remove_file(dir.path("o.ply")).unwrap();
    // A format without normals keeps the positions, with a note.
    let las = dir.path("o.las");
    let printed = ok(&["sample", &sphere, "-o", &arg(&las), "--count", "50"]);
    assert!(
        printed.contains("cannot store the vertex normals"),
        "{printed}"
    );
}

#[test]
fn the_shared_bunny_sampled_reconstructs_as_one_closed_piece() {
    let Some(bunny) =
        geosynth::core::testdata::shared_data("sampled bunny", "meshes/bunny_watertight.obj")
    else {
        return;
    };
    let dir = Scratch::new();
    let (points, mesh) = (dir.path("b.ply"), dir.path("m.ply"));
    sample(&bunny, &points, &["--count", "20000"]);
    let sampled = read_points(&points);
    assert!(
        (19_000..21_000).contains(&sampled.len()),
        "{}",
        sampled.len()
    );
    // Signed by the winding number, as the notes advise for a closed object: with the
    // local sign, this sampling (seed 0) leaves one bubble 4 units wide near the base (z
    // 43–47 of 33–186; seeds 1–5 leave none).
    reconstruct_48(&points, &mesh, &["--sign", "winding"]);
    assert_closed(&mesh, 2, "the sampled bunny reconstructed");
}

#[test]
fn a_texture_colours_the_points_at_their_texture_coordinates() {
    // The unit square with UVs equal to its x and y, and a 64 × 64 texture whose red
    // grows to the right and green upward (rows counted from the top).
    let dir = Scratch::new();
    let (mesh_path, image_path, out) = (dir.path("q.ply"), dir.path("t.png"), dir.path("p.ply"));
    let corners = vec![
        glam::Vec3::ZERO,
        glam::Vec3::X,
        glam::Vec3::new(1.0, 1.0, 0.0),
        glam::Vec3::Y,
    ];
    let uvs: Vec<glam::Vec2> = corners.iter().map(|p| glam::Vec2::new(p.x, p.y)).collect();
    let square =
        geosynth::core::TriMesh::new(PointSet::new(corners).unwrap(), vec![[0, 1, 2], [0, 2, 3]])
            .unwrap()
            .with_uvs(uvs.clone())
            .unwrap();
    write_with_defaults(&mesh_path, &Geometry::Mesh(square.clone()));
    let texture = image::RgbImage::from_fn(64, 64, |x, y| {
        image::Rgb([(x * 4) as u8, ((63 - y) * 4) as u8, 7])
    });
    texture.save(&image_path).unwrap();
    let with_texture = ["--count", "2000", "--texture", &arg(&image_path)];
    let said = sample(&mesh_path, &out, &with_texture);
    assert!(!said.contains("vertex colours are replaced"), "{said}");
    let points = read_points(&out);
    let colours = points.colors().unwrap();
    let [s, t] = ["s", "t"].map(|n| points.attribute(n).unwrap().values().to_vec());
    let mut inside = 0;
    for (i, (p, c)) in points.positions().iter().zip(&colours).enumerate() {
        assert!((s[i] - p.x).abs() < 1e-6 && (t[i] - p.y).abs() < 1e-6);
        // Half a texel from the border the lookup wraps around; inside, it is linear.
        let texel = |w: f32| (w * 64.0 - 0.5) * 4.0 / 255.0;
        if (1.0 / 64.0..63.0 / 64.0).contains(&p.x) && (1.0 / 64.0..63.0 / 64.0).contains(&p.y) {
            inside += 1;
            assert!((c[0] - texel(p.x)).abs() <= 0.6 / 255.0, "{p}: {c:?}");
            assert!((c[1] - texel(p.y)).abs() <= 0.6 / 255.0, "{p}: {c:?}");
        }
        assert!((c[2] - 7.0 / 255.0).abs() < 1e-6);
    }
    assert!(inside > 1500, "{inside}");
    // A mesh with vertex colours has them replaced, and is told so.
    let coloured_path = dir.path("coloured.ply");
    let (mut vertices, triangles, _) = square.clone().into_parts();
    vertices.set_colors(&[[1.0, 0.0, 0.0]; 4]).unwrap();
    let coloured = geosynth::core::TriMesh::new(vertices, triangles).unwrap();
    write_with_defaults(
        &coloured_path,
        &Geometry::Mesh(coloured.with_uvs(uvs).unwrap()),
    );
    let said = sample(&coloured_path, &dir.path("c.ply"), &with_texture);
    assert!(said.contains("vertex colours are replaced"), "{said}");
    assert_eq!(read_points(&dir.path("c.ply")).colors(), Some(colours));
    // A mesh without UVs is refused before the work.
    let bare = dir.path("bare.ply");
    let (vertices, triangles, _) = square.into_parts();
    write_with_defaults(
        &bare,
        &Geometry::Mesh(geosynth::core::TriMesh::new(vertices, triangles).unwrap()),
    );
    refused(
        &[
            "sample",
            &arg(&bare),
            "-o",
            &arg(&dir.path("x.ply")),
            "--texture",
            &arg(&image_path),
        ],
        "no texture coordinates",
    );
}

#[test]
fn spot_sampled_with_its_texture_has_its_colours() {
    let (Some(spot), Some(texture)) = (
        geosynth::core::testdata::shared_data("textured spot", "meshes/spot_triangulated.obj"),
        geosynth::core::testdata::shared_data("textured spot", "meshes/spot_texture.png"),
    ) else {
        return;
    };
    let dir = Scratch::new();
    let out = dir.path("spot.ply");
    sample(
        &spot,
        &out,
        &["--count", "20000", "--texture", &arg(&texture)],
    );
    let colours = read_points(&out).colors().unwrap();
    // The texture's flat colours, as measured on this sampling: the cream body 63% (of
    // points within 12 of it in every channel), the muzzle's pink 11%, the dark patches
    // 8%.
    let near =
        |c: &[f32; 3], rgb: [f32; 3]| c.iter().zip(rgb).all(|(a, b)| (a * 255.0 - b).abs() < 12.0);
    let share = |rgb| colours.iter().filter(|c| near(c, rgb)).count() as f64 / colours.len() as f64;
    let shares = [
        [255.0, 238.0, 230.0],
        [255.0, 198.0, 167.0],
        [64.0, 64.0, 64.0],
    ]
    .map(share);
    assert!((0.55..0.7).contains(&shares[0]), "{shares:?}");
    assert!((0.07..0.15).contains(&shares[1]), "{shares:?}");
    assert!((0.05..0.12).contains(&shares[2]), "{shares:?}");
}
