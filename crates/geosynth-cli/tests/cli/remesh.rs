//! `reconstruct` given a mesh: remeshed closed through the mesh's own exact distance, with
//! `--sign`, `--orient-faces` and `--trim` applying to it; and `--orient-faces` given a
//! point set, which has no triangles to turn.

use geosynth::core::io::{Geometry, read_geometry};
use geosynth::core::{PointSet, TriMesh};
use glam::Vec3;

use crate::{Scratch, arg, icosphere_with_turned_faces, ok, refused, write_with_defaults};

/// The mesh in `path`.
fn mesh_in(path: &std::path::Path) -> TriMesh {
    match read_geometry(path).unwrap().geometry {
        Geometry::Mesh(mesh) => mesh,
        Geometry::Points(_) => panic!("{} holds no faces", path.display()),
    }
}

#[test]
fn a_mesh_is_remeshed_closed_on_its_own_surface() {
    let dir = Scratch::new();
    // The bundled torus: R = 1, r = 0.35 about the y axis, 48 × 24 quads whose facets lie
    // within about 0.006 of the analytic torus.
    let torus = geosynth::fixtures::bundled_dir().join("torus_mesh.ply");
    let (out, report) = (dir.path("remeshed.ply"), dir.path("r.json"));
    let args = ["reconstruct", &arg(&torus), "-o", &arg(&out)];
    let said = ok(&[
        &args[..],
        &["--resolution", "48", "--report", &arg(&report)],
    ]
    .concat());
    assert!(said.contains("closed") && !said.contains("note"), "{said}");
    let remeshed = mesh_in(&out);
    let topology = remeshed.topology();
    assert!(topology.is_closed_manifold(), "{topology:?}");
    assert_eq!((topology.components, topology.euler_characteristic), (1, 0));
    // Its vertices lie on the torus, to the facets' and the grid's error (spacing 0.06).
    let off_torus = |p: &Vec3| {
        let around = (p.x * p.x + p.z * p.z).sqrt() - 1.0;
        ((around * around + p.y * p.y).sqrt() - 0.35).abs()
    };
    let worst = remeshed
        .positions()
        .iter()
        .map(off_torus)
        .fold(0.0, f32::max);
    assert!(worst < 0.015, "a vertex {worst} off the torus");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["input_kind"], "mesh");
    assert_eq!(r["points"], 48 * 24);
    // A kernel is for point sets: noted, and the remesh is the same.
    let kernel_out = dir.path("kernel.ply");
    let said = ok(&[
        "reconstruct",
        &arg(&torus),
        "-o",
        &arg(&kernel_out),
        "--resolution",
        "48",
        "--kernel",
        "0.2",
    ]);
    assert!(said.contains("a mesh's distance is exact"), "{said}");
    assert_eq!(mesh_in(&kernel_out), remeshed);
    // A mesh has no normals to orient; a point set without normals is named in its refusal.
    refused(
        &[&args[..], &["--orient-normals"]].concat(),
        "is a mesh: --orient-normals orients a point set's normals, and a mesh's sides",
    );
    refused(
        &[&args[..], &["--estimate-normals"]].concat(),
        "is a mesh: --estimate-normals estimates a point set's normals, and a mesh's sides",
    );
    let bare = dir.path("bare.ply");
    write_with_defaults(
        &bare,
        &Geometry::Points(PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y]).unwrap()),
    );
    refused(
        &["reconstruct", &arg(&bare), "-o", &arg(&out)],
        &format!("{}: the points have no normals", bare.display()),
    );
    // Both commands name their flag that estimates them.
    refused(
        &["reconstruct", &arg(&bare), "-o", &arg(&out)],
        "(--estimate-normals estimates and orients them)",
    );
    let field = dir.path("bare.nrrd");
    refused(
        &["sdf", &arg(&bare), "-o", &arg(&field)],
        "(--estimate-normals estimates and orients them)",
    );
    let mesh = arg(&geosynth::fixtures::bundled_dir().join("torus_mesh.ply"));
    for flag in ["--estimate-normals", "--orient-normals"] {
        refused(&["sdf", &mesh, "-o", &arg(&field), flag], "is a mesh: --");
    }
}

#[test]
fn a_mesh_whose_triangles_disagree_is_remeshed_whole_once_they_are_turned() {
    let dir = Scratch::new();
    let (_, scrambled) = icosphere_with_turned_faces();
    let messy = dir.path("messy.ply");
    write_with_defaults(&messy, &Geometry::Mesh(scrambled.clone()));
    let out = dir.path("sphere.ply");
    let args = [
        "reconstruct",
        &arg(&messy),
        "-o",
        &arg(&out),
        "--resolution",
        "32",
    ];
    // As it is: a note, and the turned triangles' surroundings signed wrong.
    let said = ok(&args);
    assert!(said.contains("disagree on which side is out"), "{said}");
    let radii = |mesh: &TriMesh| {
        let r: Vec<f32> = mesh.positions().iter().map(|p| p.length()).collect();
        (
            r.iter().copied().fold(f32::MAX, f32::min),
            r.iter().copied().fold(0.0, f32::max),
        )
    };
    let (_, wrong_hi) = radii(&mesh_in(&out));
    // Turned to agree first: one closed sphere on the icosphere's facets (inscribed
    // radius about 0.98 at this subdivision).
    let said = ok(&[&args[..], &["--orient-faces"]].concat());
    let turned = scrambled.face_count().div_ceil(9);
    assert!(
        said.contains(&format!("oriented faces: {turned} of")),
        "{said}"
    );
    assert!(!said.contains("note"), "{said}");
    let sphere = mesh_in(&out);
    assert!(sphere.topology().is_closed_manifold());
    assert_eq!(sphere.topology().components, 1);
    let (lo, hi) = radii(&sphere);
    assert!(lo > 0.97 && hi < 1.001, "radii {lo}..{hi}");
    assert!(
        wrong_hi > 1.01,
        "the turned triangles changed nothing: {wrong_hi}"
    );
}

#[test]
fn an_open_mesh_is_cut_back_to_its_faces_by_trim() {
    let dir = Scratch::new();
    // A wavy 1 × 1 sheet of 11 × 11 vertices, 0.1 apart.
    let n = 11u32;
    let positions = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32 * 0.1, (i / n) as f32 * 0.1);
            Vec3::new(x, y, 0.05 * (6.0 * x).sin())
        })
        .collect();
    let faces = (0..n - 1)
        .flat_map(|j| (0..n - 1).map(move |i| (i, j)))
        .flat_map(|(i, j)| {
            let v = j * n + i;
            [[v, v + 1, v + n + 1], [v, v + n + 1, v + n]]
        })
        .collect();
    let sheet = TriMesh::new(PointSet::new(positions).unwrap(), faces).unwrap();
    let input = dir.path("sheet.obj");
    write_with_defaults(&input, &Geometry::Mesh(sheet));
    let (out, params) = (dir.path("sheet_remeshed.ply"), dir.path("margin.json"));
    // A grid 0.025 apart with a margin of 12 spacings (0.3) around the sheet's box.
    std::fs::write(&params, r#"{"margin": 12}"#).unwrap();
    let args = [
        "reconstruct",
        &arg(&input),
        "-o",
        &arg(&out),
        "--resolution",
        "40",
        "--params",
        &arg(&params),
    ];
    let width = |mesh: &TriMesh| mesh.bounding_box().map_or(0.0, |b| b.extent().x);
    // Untrimmed, the zero set runs on to the grid's sides.
    let said = ok(&args);
    assert!(said.contains("runs out to the sides of the grid"), "{said}");
    let untrimmed = width(&mesh_in(&out));
    assert!(untrimmed > 1.55, "{untrimmed}");
    // Trimmed at 1 vertex spacing (0.1): the faces with a corner that near the sheet stay,
    // so the surface reaches at most 0.1 and a grid cell past each side.
    let said = ok(&[&args[..], &["--trim", "1"]].concat());
    assert!(!said.contains("note"), "{said}");
    let trimmed = mesh_in(&out);
    assert!((1.0..1.3).contains(&width(&trimmed)), "{}", width(&trimmed));
    assert_eq!(trimmed.topology().components, 1);
}

#[test]
fn orient_faces_leaves_a_point_set_as_it_is_and_says_so() {
    let dir = Scratch::new();
    let points = arg(&geosynth::fixtures::bundled_dir().join("torus_points.ply"));
    let note = "is a point set: --orient-faces turns a mesh's triangles";
    let (plain, flagged) = (dir.path("plain.nrrd"), dir.path("flagged.nrrd"));
    let sdf = ["sdf", &points, "--resolution", "16", "-o"];
    assert!(!ok(&[&sdf[..], &[&arg(&plain)]].concat()).contains("note"));
    let said = ok(&[&sdf[..], &[&arg(&flagged), "--orient-faces"]].concat());
    assert!(said.contains(note), "{said}");
    let bytes = |path| std::fs::read(path).unwrap();
    assert_eq!(bytes(&plain), bytes(&flagged));
    let out = arg(&dir.path("torus.ply"));
    let reconstruct = ["reconstruct", &points, "-o", &out, "--resolution", "24"];
    let said = ok(&[&reconstruct[..], &["--orient-faces"]].concat());
    assert!(said.contains(note) && said.contains("closed"), "{said}");
}
