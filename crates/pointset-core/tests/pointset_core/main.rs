//! Integration tests of pointset-core: real files, round trips, malformed input, spatial
//! indices against brute force, seeded streams.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod edited_files;
#[path = "../shared/file_names.rs"]
mod file_names;
mod gltf_codec;
mod kd_construction;
mod las_codec;
mod pcd_codec;
mod ply_codec;
mod point_thinning;
mod polygons;
mod replaced_files;
mod simplify;
mod stl_codec;
mod streamed_files;
mod xyz_codec;

use std::path::Path;

use glam::{DVec3, Vec2, Vec3};
use pointset_core::io::ply::PlyEncoding;
use pointset_core::io::{self, FileFormat, Geometry, ReadOptions, WriteOptions, XyzColumns};
use pointset_core::spatial::{key_index, nearness_key};
use pointset_core::testdata::shared_data;
use pointset_core::{
    Attribute, BucketGrid, Error, KdIndex, Location, PointSet, ScalarType, TriMesh, rng,
};
use proptest::prelude::*;
use rand::RngExt;

// ---------------------------------------------------------------- real public data

fn load(test: &str, rel: &str) -> Option<io::LoadedGeometry> {
    let path = shared_data(test, rel)?;
    Some(io::read_geometry(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
}

#[test]
fn reads_every_shared_mesh_with_the_right_counts() {
    let expected: [(&str, usize, usize); 6] = [
        ("meshes/bunny_watertight.obj", 34834, 69664),
        ("meshes/stanford_bunny_res2.ply", 8171, 16301),
        ("meshes/fertility.off", 4494, 9000),
        ("meshes/icosphere_642.ply", 642, 1280),
        ("meshes/utah_teapot.obj", 3644, 6320),
        ("meshes/spot_triangulated.obj", 0, 5856),
    ];
    for (rel, vertices, faces) in expected {
        let Some(loaded) = load("reads_every_shared_mesh", rel) else {
            return;
        };
        let mesh = loaded
            .geometry
            .mesh()
            .unwrap_or_else(|| panic!("{rel} is a mesh"));
        if vertices > 0 {
            assert_eq!(mesh.vertex_count(), vertices, "{rel}");
        }
        assert_eq!(mesh.face_count(), faces, "{rel}");
    }
}

#[test]
fn scan_attributes_survive_a_round_trip() {
    let Some(loaded) = load("scan_attributes", "meshes/stanford_bunny_res2.ply") else {
        return;
    };
    assert_eq!(loaded.encoding, "ascii");
    assert_eq!(loaded.comments, vec!["zipper output".to_string()]);
    let points = loaded.geometry.points();
    for name in ["confidence", "intensity"] {
        assert_eq!(
            points.attribute(name).map(|a| a.storage()),
            Some(ScalarType::F32),
            "{name}"
        );
    }
    for encoding in PlyEncoding::ALL {
        let bytes = io::encode_geometry(
            &loaded.geometry,
            FileFormat::Ply,
            &WriteOptions::default().ply_encoding(encoding),
        )
        .unwrap();
        let back = io::read_geometry_bytes(Path::new("b.ply"), &bytes).unwrap();
        assert_eq!(back.geometry, loaded.geometry, "{encoding:?}");
    }
}

#[test]
fn oriented_point_sets_keep_normals_radius_and_colours() {
    for (rel, count) in [
        ("pointsets/chameleon4k_normals.ply", 4594),
        ("pointsets/bunny16k_normals.ply", 16130),
    ] {
        let Some(loaded) = load("oriented_point_sets", rel) else {
            return;
        };
        let Geometry::Points(points) = &loaded.geometry else {
            panic!("{rel} has no faces");
        };
        assert_eq!(points.len(), count);
        assert!(points.normals().is_some());
        assert!(points.attribute("radius").is_some());
        for c in ["red", "green", "blue", "alpha"] {
            assert_eq!(
                points.attribute(c).map(Attribute::storage),
                Some(ScalarType::U8)
            );
        }
        assert_eq!(points.colors().map(|c| c.len()), Some(count));
    }
}

// ---------------------------------------------------------------- round trips

fn point_set_strategy() -> impl Strategy<Value = PointSet> {
    (1usize..60).prop_flat_map(|n| {
        (
            proptest::collection::vec(prop::array::uniform3(-100.0f32..100.0), n),
            proptest::collection::vec(prop::array::uniform3(-1.0f32..1.0), n),
            proptest::collection::vec(0u8..=255, n),
            proptest::collection::vec(-1e3f32..1e3, n),
        )
            .prop_map(|(p, nrm, c, conf)| {
                PointSet::new(p.into_iter().map(Vec3::from).collect())
                    .unwrap()
                    .with_normals(nrm.into_iter().map(Vec3::from).collect())
                    .unwrap()
                    .with_attribute(
                        Attribute::new("red", c.iter().map(|&x| f32::from(x)).collect())
                            .with_storage(ScalarType::U8),
                    )
                    .unwrap()
                    .with_attribute(Attribute::new("confidence", conf))
                    .unwrap()
                    .with_attribute(
                        Attribute::new("green", c.iter().map(|&x| f32::from(255 - x)).collect())
                            .with_storage(ScalarType::U8),
                    )
                    .unwrap()
                    .with_attribute(
                        Attribute::new("blue", c.iter().map(|&x| f32::from(x / 2)).collect())
                            .with_storage(ScalarType::U8),
                    )
                    .unwrap()
            })
    })
}

proptest! {
    #[test]
    fn point_sets_round_trip_through_every_ply_encoding(points in point_set_strategy()) {
        let geometry = Geometry::Points(points);
        for encoding in PlyEncoding::ALL {
            let opts = WriteOptions::default().ply_encoding(encoding).comment("round trip");
            let bytes = io::encode_geometry(&geometry, FileFormat::Ply, &opts).unwrap();
            let back = io::read_geometry_bytes(Path::new("x.ply"), &bytes).unwrap();
            prop_assert_eq!(&back.geometry, &geometry);
            prop_assert_eq!(back.comments, vec!["round trip".to_string()]);
        }
    }

    #[test]
    fn meshes_round_trip_through_ply_obj_and_off(
        points in point_set_strategy(),
        seed in any::<u64>(),
    ) {
        let n = points.len() as u32;
        let mut r = rng::rng_from_seed(seed);
        let tris: Vec<[u32; 3]> = (0..n).map(|_| {
            [r.random_range(0..n), r.random_range(0..n), r.random_range(0..n)]
        }).collect();
        let uvs: Vec<Vec2> = (0..n).map(|i| Vec2::new(i as f32 * 0.25, 1.0 - i as f32 * 0.5)).collect();
        let mesh = TriMesh::new(points.clone(), tris.clone()).unwrap().with_uvs(uvs).unwrap();
        let geometry = Geometry::Mesh(mesh);
        let bytes = io::encode_geometry(&geometry, FileFormat::Ply, &WriteOptions::default()).unwrap();
        prop_assert_eq!(&io::read_geometry_bytes(Path::new("m.ply"), &bytes).unwrap().geometry, &geometry);

        // OFF keeps positions, normals, colours (as 0..255) and faces.
        let bytes = io::encode_geometry(&geometry, FileFormat::Off, &WriteOptions::default()).unwrap();
        let back = io::read_geometry_bytes(Path::new("m.off"), &bytes).unwrap().geometry;
        let m = back.mesh().unwrap();
        prop_assert_eq!(m.positions(), points.positions());
        prop_assert_eq!(m.vertices().normals(), points.normals());
        prop_assert_eq!(m.triangles(), &tris[..]);
        prop_assert_eq!(m.vertices().colors(), points.colors());
    }
}

proptest! {
    /// Georeferenced data: positions near a far origin, written with that origin (double
    /// coordinates) and read back recentred, keep single precision relative to the data;
    /// read without recentring they are quantized to the `f32` step at the coordinates.
    #[test]
    fn far_data_keeps_its_precision_through_every_format(
        local in proptest::collection::vec(prop::array::uniform3(-50.0f32..50.0), 8..40),
        east in 100_000i32..900_000,
        north in 1_000_000i32..9_000_000,
    ) {
        let origin = DVec3::new(f64::from(east), f64::from(north), 37.0);
        let points = PointSet::new(local.iter().map(|&p| Vec3::from(p)).collect()).unwrap();
        let geometry = Geometry::Points(points.clone());
        let recentre = ReadOptions::default().recentre_far(true);
        for (format, name) in [
            (FileFormat::Ply, "far.ply"),
            (FileFormat::Obj, "far.obj"),
            (FileFormat::Off, "far.off"),
            (FileFormat::Xyz(XyzColumns::Positions), "far.xyz"),
            (FileFormat::Las, "far.las"),
            (FileFormat::Pcd, "far.pcd"),
        ] {
            let options = WriteOptions::default()
                .ply_encoding(PlyEncoding::BinaryBigEndian)
                .origin(origin);
            let bytes = io::encode_geometry(&geometry, format, &options).unwrap();
            let back = io::read_geometry_bytes_with(Path::new(name), &bytes, &recentre).unwrap();
            prop_assert!(back.origin != DVec3::ZERO, "{name}: not recentred");
            let plain = io::read_geometry_bytes(Path::new(name), &bytes).unwrap();
            prop_assert_eq!(plain.origin, DVec3::ZERO);
            let (mut kept, mut plain_error) = (0.0f64, 0.0f64);
            for ((p, q), r) in points
                .positions()
                .iter()
                .zip(back.geometry.points().positions())
                .zip(plain.geometry.points().positions())
            {
                let truth = p.as_dvec3() + origin;
                kept = kept.max((q.as_dvec3() + back.origin - truth).abs().max_element());
                plain_error = plain_error.max((r.as_dvec3() - truth).abs().max_element());
            }
            // The f32 step at 100 units is 7.6e-6; at 1e6 it is 0.0625.
            prop_assert!(kept < 1e-5, "{name}: recentred error {kept}");
            prop_assert!(north < 2_097_152 || plain_error > 1e-3, "{name}: {plain_error}");
        }
    }
}

#[test]
fn data_near_the_origin_is_not_moved() {
    // Within its own extent of the origin: stored as the file has it, origin zero.
    let points = PointSet::new(vec![Vec3::new(10.0, 0.0, 0.0), Vec3::new(30.0, 5.0, 1.0)]).unwrap();
    let bytes = io::encode_geometry(
        &Geometry::Points(points.clone()),
        FileFormat::Ply,
        &WriteOptions::default(),
    )
    .unwrap();
    assert!(!String::from_utf8_lossy(&bytes).contains("double"));
    let back = io::read_geometry_bytes_with(
        Path::new("near.ply"),
        &bytes,
        &ReadOptions::default().recentre_far(true),
    )
    .unwrap();
    assert_eq!(back.origin, DVec3::ZERO);
    assert_eq!(back.geometry.points(), &points);
}

#[test]
fn obj_round_trip_keeps_faces_normals_and_uvs() {
    let points = PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE])
        .unwrap()
        .with_normals(vec![Vec3::Z; 4])
        .unwrap();
    let uvs = vec![Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE];
    let mesh = TriMesh::new(points, vec![[0, 1, 2], [1, 3, 2]])
        .unwrap()
        .with_uvs(uvs)
        .unwrap();
    let geometry = Geometry::Mesh(mesh);
    let bytes = io::encode_geometry(&geometry, FileFormat::Obj, &WriteOptions::default()).unwrap();
    let back = io::read_geometry_bytes(Path::new("q.obj"), &bytes)
        .unwrap()
        .geometry;
    assert_eq!(back, geometry);
    // Point sets are written as bare `v` lines (what MeshLab and Open3D read as a point
    // cloud) and read back as points.
    let pts = Geometry::Points(geometry.points().clone());
    let bytes = io::encode_geometry(&pts, FileFormat::Obj, &WriteOptions::default()).unwrap();
    let back = io::read_geometry_bytes(Path::new("p.obj"), &bytes)
        .unwrap()
        .geometry;
    assert_eq!(back.points().positions(), pts.points().positions());
    assert_eq!(back.points().normals(), pts.points().normals());
    assert!(back.mesh().is_none());
}

#[test]
fn files_hold_the_encoded_bytes_and_unwritable_paths_are_named() {
    // PLY is streamed to its file, the other formats written whole: either way the file
    // holds exactly what `encode_geometry` gives.
    let points = PointSet::new(
        (0..50)
            .map(|i| Vec3::new(i as f32, (i * i) as f32, 0.5))
            .collect(),
    )
    .unwrap()
    .with_normals(vec![Vec3::Z; 50])
    .unwrap();
    let mesh = TriMesh::new(points, (0..48).map(|i| [i, i + 1, i + 2]).collect()).unwrap();
    let geometry = Geometry::Mesh(mesh);
    let dir = tempfile::tempdir().unwrap();
    for (name, encoding) in [
        ("m.ply", PlyEncoding::BinaryLittleEndian),
        ("a.ply", PlyEncoding::Ascii),
        ("m.obj", PlyEncoding::Ascii),
        ("m.off", PlyEncoding::Ascii),
    ] {
        let path = dir.path().join(name);
        let options = WriteOptions::default()
            .comment("streamed or not")
            .origin(DVec3::new(1e6, 0.0, 0.0))
            .ply_encoding(encoding);
        io::write_geometry(&path, &geometry, &options).unwrap();
        let format = FileFormat::from_extension(name.rsplit('.').next().unwrap()).unwrap();
        let expected = io::encode_geometry(&geometry, format, &options).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), expected, "{name}");
        // A folder that does not exist: the error names the file.
        let missing = dir.path().join("no such folder").join(name);
        match io::write_geometry(&missing, &geometry, &options) {
            Err(Error::Io { path, .. }) => assert_eq!(path, missing),
            other => panic!("{name}: {other:?}"),
        }
    }
}

// ---------------------------------------------------------------- malformed input

fn read(name: &str, bytes: &[u8]) -> Result<io::LoadedGeometry, Error> {
    io::read_geometry_bytes(Path::new(name), bytes)
}

#[test]
fn text_files_may_start_with_a_byte_order_mark() {
    let mesh = Geometry::Mesh(random_mesh(5, 8, 6));
    let ascii_ply = WriteOptions::default().ply_encoding(PlyEncoding::Ascii);
    let mut stl = Vec::new();
    io::write_stl_ascii(&mesh, &mut stl).unwrap();
    let files = [
        (
            "m.ply",
            io::encode_geometry(&mesh, FileFormat::Ply, &ascii_ply).unwrap(),
        ),
        (
            "m.obj",
            io::encode_geometry(&mesh, FileFormat::Obj, &WriteOptions::default()).unwrap(),
        ),
        (
            "m.off",
            io::encode_geometry(&mesh, FileFormat::Off, &WriteOptions::default()).unwrap(),
        ),
        ("m.stl", stl),
    ];
    for (name, bytes) in files {
        let plain = read(name, &bytes).unwrap();
        let marked = [&b"\xEF\xBB\xBF"[..], &bytes].concat();
        assert_eq!(read(name, &marked).unwrap(), plain, "{name}");
        // Without the extension, the content still says what the file is.
        assert_eq!(read("m", &marked).unwrap().format, plain.format, "{name}");
    }
    // A binary STL whose header happens to start with those bytes stays binary.
    let mut binary = io::encode_geometry(&mesh, FileFormat::Stl, &WriteOptions::default()).unwrap();
    binary[..3].copy_from_slice(b"\xEF\xBB\xBF");
    let loaded = read("b.stl", &binary).unwrap();
    assert_eq!(
        (
            loaded.encoding.as_str(),
            loaded.geometry.mesh().unwrap().face_count()
        ),
        ("binary_little_endian", 6)
    );
}

#[test]
fn readers_say_what_they_could_not_keep() {
    let obj = |faces: &str| {
        format!(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0 0.5 0.5 0.5\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\n{faces}"
        )
    };
    let notes = |name: &str, text: &str| read(name, text.as_bytes()).unwrap().notes;
    // Every corner alike: nothing lost, UVs and normals kept.
    let whole = read(
        "a.obj",
        obj("f 1/1/1 2/2/1 3/3/1\nf 2/2/1 4/1/1 3/3/1\n").as_bytes(),
    )
    .unwrap();
    let mesh = whole.geometry.mesh().unwrap();
    assert!(mesh.uvs().is_some() && mesh.vertices().normals().is_some());
    assert_eq!(
        whole.notes,
        [
            "colours dropped: 1 of 4 `v` lines have them; a mesh carries them at every vertex or not at all"
        ]
    );
    // Corners without UVs or normals, in one object or in another object.
    for faces in [
        "f 1/1/1 2/2/1 3/3/1\nf 2 4 3\n",
        "o a\nf 1/1/1 2/2/1 3/3/1\no b\nf 2//1 4//1 3//1\n",
    ] {
        let said = notes("m.obj", &obj(faces)).join("\n");
        assert!(
            said.contains("texture coordinates dropped: 3 of 6 face corners"),
            "{said}"
        );
        assert_eq!(
            said.contains("normals dropped"),
            faces.contains("f 2 4 3"),
            "{said}"
        );
    }
    // A face-less OBJ is a point cloud: normals need one `vn` per `v`.
    let cloud = "v 0 0 0 1 0 0\nv 1 0 0\nvn 0 0 1\n";
    assert_eq!(
        notes("c.obj", cloud),
        [
            "normals dropped: 1 `vn` lines for 2 points (one per point is needed)",
            "colours dropped: 1 of 2 `v` lines have them; a point set carries them at every \
             point or not at all",
        ]
    );
    // PLY: other elements, vertex lists and per-face values are skipped, and said so.
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nproperty list uchar float weights\nelement face 1\n\
               property list uchar int vertex_indices\nproperty uchar red\nelement camera 2\n\
               property float f\nelement empty 0\nproperty float g\nend_header\n\
               0 0 0 1 0.5\n1 0 0 0\n0 1 0 0\n3 0 1 2 255\n35\n50\n";
    assert_eq!(
        notes("p.ply", ply),
        [
            "vertex list property `weights` skipped",
            "face property `red` skipped (a mesh keeps values per vertex, not per face)",
            "element `camera` (2 records) skipped",
        ]
    );
    // OFF: per-face colours are skipped, and said so.
    let off =
        "COFF\n3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n3 0 1 2 9 9 9\n";
    let loaded = read("f.off", off.as_bytes()).unwrap();
    assert!(loaded.geometry.points().colors().is_some());
    assert_eq!(
        loaded.notes,
        [
            "per-face values (colours) on 1 of 1 faces skipped (a mesh keeps values per vertex, \
          not per face)"
        ]
    );
    // Formats that keep what they read say nothing.
    let clean = io::encode_geometry(
        &Geometry::Mesh(random_mesh(3, 5, 4)),
        FileFormat::Ply,
        &WriteOptions::default(),
    )
    .unwrap();
    assert!(read("c.ply", &clean).unwrap().notes.is_empty());
}

#[test]
fn malformed_files_give_specific_errors() {
    assert!(matches!(read("e.ply", b""), Err(Error::EmptyFile { .. })));
    let nan = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 nan 0\n";
    assert!(matches!(
        read("n.ply", nan),
        Err(Error::NonFinite { index: 1, .. })
    ));
    let bad_index = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n";
    assert!(matches!(
        read("f.ply", bad_index),
        Err(Error::IndexOutOfRange {
            face: 0,
            vertex: 7,
            vertex_count: 3
        })
    ));
    let no_xyz = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float a\nend_header\n1\n";
    assert!(matches!(
        read("a.ply", no_xyz),
        Err(Error::Malformed { .. })
    ));
    assert!(matches!(
        read("off.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n"),
        Err(Error::IndexOutOfRange { vertex: 9, .. })
    ));
    assert!(matches!(
        read("off.off", b"OFF\n1000000000000 0 0\n0 0 0\n"),
        Err(Error::HeaderExceedsFile { .. })
    ));
    assert!(matches!(
        read("off.off", b"OFF\n2 0 0\n0 0 0\n"),
        Err(Error::UnexpectedEof { .. })
    ));
    assert!(matches!(
        read("off.off", b"OFF\n1 0 0\ninf 0 0\n"),
        Err(Error::NonFinite { .. })
    ));
    // OBJ errors name their line; a face of two corners is refused, not dropped.
    for (text, line) in [
        (&b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 5\n"[..], 4),
        (b"v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", 2),
        (b"v 0 0 0\nv 1 0 x\nv 0 1 0\nf 1 2 3\n", 2),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", 4),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", 4),
        (
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//2 3//1\n",
            5,
        ),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\n# c\nf 1/1 2/1 3/1\n", 5),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 0\n", 4),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 a\n", 4),
        // Refused by `tobj` before, without a line: a weight of 0, five numbers, four
        // parts to a corner, text that is not UTF-8.
        (b"v 0 0 0\nv 1 0 0 0\nv 0 1 0\nf 1 2 3\n", 2),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0 1 1\nf 1 2 3\n", 3),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/1/1/1\n", 4),
        (b"v 0 0 0\nv 1 0 0\nv 0 \xff 0\nf 1 2 3\n", 3),
    ] {
        let err = read("t.obj", text);
        assert!(
            matches!(err, Err(Error::Malformed { location: Location::Line(l), .. }) if l == line),
            "{:?}: {err:?}",
            String::from_utf8_lossy(text)
        );
    }
    // What the in-house reader reads where `tobj` did otherwise: a comment after a `v`
    // line's numbers, a line continued with `\`, a weight dividing the position, and a
    // polyline of three points skipped (not read as a face).
    let text = b"v 0 0 0 # origin\nv 2 0 0 2\nv 0 1 \\\n 0\nl 1 2 3\nf 1 2 3\n";
    let loaded = read("w.obj", text).unwrap();
    let mesh = loaded.geometry.mesh().unwrap();
    assert_eq!(mesh.triangles(), &[[0, 1, 2]]);
    assert_eq!(mesh.vertices().positions()[1], Vec3::X);
    assert_eq!(mesh.vertices().positions()[2], Vec3::Y);
    // Relative indices and every corner form read.
    let corners = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf -3/1/1 2/1/1 3//1\n";
    assert_eq!(
        read("c.obj", corners)
            .unwrap()
            .geometry
            .mesh()
            .unwrap()
            .face_count(),
        1
    );
    assert!(matches!(
        read("v.obj", b"v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        read("x.ply", b"OFF\n0 0 0\n"),
        Err(Error::FormatMismatch { .. })
    ));
    assert!(matches!(
        read("x.dat", b"\x00\x01binary"),
        Err(Error::UnknownFormat { .. })
    ));
    // Without an extension the content decides.
    assert!(read("noext", b"OFF\n1 0 0\n0 0 0\n").is_ok());
}

/// `mesh` with the triangles whose index `turned` picks turned over.
fn with_turned(mesh: &TriMesh, turned: impl Fn(usize) -> bool) -> TriMesh {
    let triangles = mesh
        .triangles()
        .iter()
        .enumerate()
        .map(|(i, &[a, b, c])| if turned(i) { [a, c, b] } else { [a, b, c] })
        .collect();
    TriMesh::new(mesh.vertices().clone(), triangles).unwrap()
}

#[test]
fn real_meshes_with_faces_turned_over_are_oriented_back() {
    // The shared watertight bunny, fertility and Spot (whose OBJ splits vertices along UV
    // seams), every 7th triangle turned over, and each inside out: consistent orientation
    // gives back the file's triangles exactly, outward.
    for rel in [
        "meshes/bunny_watertight.obj",
        "meshes/fertility.off",
        "meshes/spot_triangulated.obj",
    ] {
        let Some(loaded) = load("real_meshes_oriented_back", rel) else {
            return;
        };
        let io::Geometry::Mesh(mesh) = loaded.geometry else {
            panic!("{rel} is a mesh");
        };
        assert!(
            mesh.welded().unwrap().topology().is_closed_manifold(),
            "{rel}"
        );
        for turned in [|i: usize| i.is_multiple_of(7), |_: usize| true] {
            let (fixed, change) = with_turned(&mesh, turned).consistently_oriented().unwrap();
            assert_eq!(fixed.triangles(), mesh.triangles(), "{rel}");
            assert_eq!((change.parts, change.conflicting_edges), (1, 0), "{rel}");
            let expected = (0..mesh.face_count()).filter(|&i| turned(i)).count();
            assert_eq!(change.flipped_faces, expected, "{rel}");
        }
    }
}

#[test]
fn real_meshes_whose_triangles_agree_come_back_unchanged() {
    // Open scans, intersecting pieces and non-manifold edges included: orienting a mesh
    // whose triangles already agree changes nothing. With every 7th triangle turned, the
    // teapot (4 parts), the icosphere and the Stanford scan come back exactly, but for
    // the scan's twins: 81 sets of triangles on the same three corners, most facing
    // opposite ways in the file itself (fins of no volume), which no orientation can make
    // all agree. 35 of them stay turned (measured); every other triangle is right.
    for (rel, twins_left_turned) in [
        ("meshes/utah_teapot.obj", 0),
        ("meshes/stanford_bunny_res2.ply", 35),
        ("meshes/icosphere_642.ply", 0),
    ] {
        let Some(loaded) = load("real_meshes_unchanged", rel) else {
            return;
        };
        let io::Geometry::Mesh(mesh) = loaded.geometry else {
            panic!("{rel} is a mesh");
        };
        let (fixed, change) = mesh.consistently_oriented().unwrap();
        assert_eq!(fixed.triangles(), mesh.triangles(), "{rel}");
        assert_eq!(
            (change.flipped_faces, change.conflicting_edges),
            (0, 0),
            "{rel}"
        );
        let (fixed, change) = with_turned(&mesh, |i| i.is_multiple_of(7))
            .consistently_oriented()
            .unwrap();
        let corners = |t: &[u32; 3]| {
            let mut c = *t;
            c.sort_unstable();
            c
        };
        let duplicates = mesh.duplicate_faces();
        // The scan: 87 triangles repeat another's corners, 83 of them facing the other way.
        let (expected, reversed) = if twins_left_turned > 0 {
            (87, 83)
        } else {
            (0, 0)
        };
        assert_eq!(duplicates.len(), expected, "{rel}");
        let facing_back = duplicates.iter().filter(|d| d.reversed).count();
        assert_eq!(facing_back, reversed, "{rel}");
        let twinned: std::collections::HashSet<[u32; 3]> = duplicates
            .iter()
            .map(|d| corners(&mesh.triangles()[d.face]))
            .collect();
        let (mut twins, mut others) = (0, 0);
        for (a, b) in fixed.triangles().iter().zip(mesh.triangles()) {
            if a != b {
                if twinned.contains(&corners(b)) {
                    twins += 1;
                } else {
                    others += 1;
                }
            }
        }
        assert_eq!((others, twins), (0, twins_left_turned), "{rel}: {change:?}");
    }
}

#[test]
fn truncated_real_file_is_an_error_not_a_panic() {
    let Some(path) = shared_data("truncated_real_file", "pointsets/chameleon4k_normals.ply") else {
        return;
    };
    let bytes = std::fs::read(&path).unwrap();
    for cut in [10, 200, bytes.len() / 2, bytes.len() - 1] {
        assert!(read("c.ply", &bytes[..cut]).is_err(), "cut at {cut}");
    }
}

// ---------------------------------------------------------------- spatial indices

fn brute_force_knn(points: &[Vec3], q: Vec3, k: usize) -> Vec<f32> {
    let mut d: Vec<f32> = points.iter().map(|p| p.distance_squared(q)).collect();
    d.sort_by(f32::total_cmp);
    d.truncate(k);
    d
}

fn points_strategy() -> impl Strategy<Value = Vec<Vec3>> {
    // Mix of random, grid-aligned and duplicated coordinates.
    (
        proptest::collection::vec(prop::array::uniform3(-10.0f32..10.0), 0..150),
        proptest::collection::vec(prop::array::uniform3(0i32..4), 0..150),
        0usize..40,
    )
        .prop_map(|(random, grid, dups)| {
            let mut pts: Vec<Vec3> = random.into_iter().map(Vec3::from).collect();
            pts.extend(
                grid.into_iter()
                    .map(|g| Vec3::new(g[0] as f32, g[1] as f32, g[2] as f32)),
            );
            let first = pts.first().copied().unwrap_or(Vec3::ONE);
            pts.extend(std::iter::repeat_n(first, dups));
            pts
        })
}

proptest! {
    #[test]
    fn kd_index_agrees_with_brute_force(
        points in points_strategy(),
        q in prop::array::uniform3(-12.0f32..12.0),
        k in 0usize..20,
        r in 0.0f32..6.0,
    ) {
        let q = Vec3::from(q);
        let index = KdIndex::new(&points).unwrap();
        let got: Vec<f32> = index.nearest(q, k).unwrap().iter().map(|n| n.distance_squared).collect();
        let want = brute_force_knn(&points, q, k);
        prop_assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(&want) {
            prop_assert!((g - w).abs() <= 1e-4 * w.max(1.0));
        }
        let one = index.nearest_one(q).unwrap().map(|n| n.distance_squared);
        prop_assert_eq!(one.is_some(), !points.is_empty());
        if let (Some(g), Some(w)) = (one, brute_force_knn(&points, q, 1).first()) {
            prop_assert!((g - w).abs() <= 1e-4 * w.max(1.0));
        }
        let distinct = index.nearest_distinct(q).unwrap().map(|n| n.distance_squared);
        let want_distinct = points.iter().map(|p| p.distance_squared(q)).filter(|&d| d > 0.0).min_by(f32::total_cmp);
        prop_assert_eq!(distinct.is_some(), want_distinct.is_some());
        if let (Some(g), Some(w)) = (distinct, want_distinct) {
            prop_assert!((g - w).abs() <= 1e-4 * w.max(1.0));
        }
        let bounded: Vec<f32> = index.nearest_within(q, k, r).unwrap().iter().map(|n| n.distance_squared).collect();
        let want: Vec<f32> = want.into_iter().filter(|&w| w <= r * r).collect();
        prop_assert_eq!(bounded.len(), want.len());
        for (g, w) in bounded.iter().zip(&want) {
            prop_assert!((g - w).abs() <= 1e-4 * w.max(1.0));
        }
        let found = index.within(q, r).unwrap();
        // Nearest first, ties to the lower index.
        prop_assert!(found.windows(2).all(|p| (p[0].distance_squared, p[0].index) < (p[1].distance_squared, p[1].index)));
        let mut within: Vec<usize> = found.iter().map(|n| n.index).collect();
        within.sort_unstable();
        let expected: Vec<usize> = (0..points.len()).filter(|&i| points[i].distance_squared(q) <= r * r).collect();
        prop_assert_eq!(within, expected);
    }

    #[test]
    fn nearness_keys_order_as_distance_then_index(
        a in (0.0f32..=f32::MAX, any::<u32>()),
        b in (0.0f32..=f32::MAX, any::<u32>()),
        tie in any::<bool>(),
    ) {
        // Half the cases share a distance, so that the index decides.
        let b = if tie { (a.0, b.1) } else { b };
        let (ka, kb) = (nearness_key(a.0, a.1), nearness_key(b.0, b.1));
        let by_value = a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        prop_assert_eq!(ka.cmp(&kb), by_value);
        prop_assert_eq!(key_index(ka), a.1);
        prop_assert_eq!(key_index(kb), b.1);
    }

    #[test]
    fn bucket_grid_agrees_with_brute_force(
        points in points_strategy(),
        cell in 0.3f32..5.0,
        q in prop::array::uniform3(-12.0f32..12.0),
        r in 0.0f32..8.0,
        remove_every in 2usize..5,
    ) {
        let q = Vec3::from(q);
        let mut grid = BucketGrid::new(cell).unwrap();
        let keys: Vec<_> = points.iter().enumerate().map(|(i, &p)| grid.insert(p, i).unwrap()).collect();
        let mut alive = vec![true; points.len()];
        for (i, key) in keys.iter().enumerate().step_by(remove_every) {
            prop_assert_eq!(grid.remove(*key).map(|(_, v)| v), Some(i));
            alive[i] = false;
        }
        prop_assert_eq!(grid.len(), alive.iter().filter(|&&a| a).count());
        let mut got: Vec<usize> = grid.query_radius(q, r).iter().map(|&k| *grid.get(k).unwrap().1).collect();
        got.sort_unstable();
        let want: Vec<usize> = (0..points.len()).filter(|&i| alive[i] && points[i].distance_squared(q) <= r * r).collect();
        prop_assert_eq!(got, want);

        let region = pointset_core::Aabb::new(q, q + Vec3::splat(r));
        let mut removed: Vec<usize> = grid.remove_inside_box(&region).into_iter().map(|(_, v)| v).collect();
        removed.sort_unstable();
        let want: Vec<usize> = (0..points.len()).filter(|&i| alive[i] && region.contains(points[i])).collect();
        prop_assert_eq!(&removed, &want);
        prop_assert!(grid.query_box(&region).is_empty());
        for &i in &removed { alive[i] = false; }
        prop_assert_eq!(grid.iter().count(), alive.iter().filter(|&&a| a).count());
    }
}

#[test]
fn bucket_grid_accepts_unbounded_query_boxes() {
    let mut grid = BucketGrid::new(0.5).unwrap();
    for i in 0..10 {
        grid.insert(Vec3::new(i as f32, 0.0, -1e6), i).unwrap();
    }
    let slab = pointset_core::Aabb::new(
        Vec3::new(2.0, -1.0, f32::MIN),
        Vec3::new(5.0, 1.0, f32::MAX),
    );
    assert_eq!(grid.query_box(&slab).len(), 4);
    assert_eq!(grid.remove_inside_box(&slab).len(), 4);
    assert_eq!(grid.len(), 6);
}

#[test]
fn median_spacing_looks_past_any_number_of_copies() {
    // 50 points on a line, 0.25 apart, each written 100 times, in interleaved order.
    let line: Vec<Vec3> = (0..5000)
        .map(|i| Vec3::new((i % 50) as f32 * 0.25, 1.0, -2.0))
        .collect();
    let index = KdIndex::new(&line).unwrap();
    assert_eq!(index.median_spacing().unwrap(), 0.25);
    let far_end = index.nearest_distinct(line[49]).unwrap().unwrap();
    assert_eq!(line[far_end.index], line[48]);
    // One position, copied: nothing distinct.
    let same = KdIndex::new(&vec![Vec3::ONE; 300]).unwrap();
    assert_eq!(same.nearest_distinct(Vec3::ONE).unwrap(), None);
    assert_eq!(same.median_spacing().unwrap(), 0.0);
    assert_eq!(KdIndex::new(&[]).unwrap().median_spacing().unwrap(), 0.0);
}

#[test]
fn kd_index_handles_voxel_centres_and_rejects_nan() {
    // 32³ grid-aligned voxel centres plus 500 exact duplicates of one point.
    let mut pts = Vec::new();
    for k in 0..32 {
        for j in 0..32 {
            for i in 0..32 {
                pts.push(Vec3::new(i as f32, j as f32, k as f32) + 0.5);
            }
        }
    }
    pts.extend(std::iter::repeat_n(Vec3::splat(0.5), 500));
    let index = KdIndex::new(&pts).unwrap();
    let n = index.nearest(Vec3::splat(0.5), 510).unwrap();
    assert_eq!(n.len(), 510);
    assert_eq!(n.iter().filter(|x| x.distance_squared == 0.0).count(), 501);
    assert_eq!(
        index
            .within(Vec3::new(10.5, 10.5, 10.5), 1.0)
            .unwrap()
            .len(),
        7
    );
    // The 501 coincident points come first, in index order, then the corner's three
    // neighbours at distance 1.
    let found = index.within(Vec3::splat(0.5), 1.0).unwrap();
    let first: Vec<usize> = found.iter().take(501).map(|n| n.index).collect();
    let mut coincident: Vec<usize> = (32 * 32 * 32..pts.len()).collect();
    coincident.insert(0, 0);
    assert_eq!(first, coincident);
    assert_eq!(found.len(), 504);
    assert!(matches!(
        KdIndex::new(&[Vec3::NAN]),
        Err(Error::NonFinite { .. })
    ));
    assert!(index.nearest(Vec3::new(f32::NAN, 0.0, 0.0), 1).is_err());
    assert!(index.within(Vec3::ZERO, f32::NAN).is_err());
    assert!(index.nearest_within(Vec3::ZERO, 1, -1.0).is_err());
    let empty = KdIndex::new(&[]).unwrap();
    assert!(empty.nearest(Vec3::ZERO, 3).unwrap().is_empty());
    assert!(empty.nearest_one(Vec3::ZERO).unwrap().is_none());
    assert!(empty.nearest_within(Vec3::ZERO, 3, 1.0).unwrap().is_empty());
}

#[test]
fn seeded_streams_are_deterministic_across_threads() {
    let draw = |i: u64| {
        let mut r = rng::stream(42, i);
        (0..4).map(|_| r.random::<u32>()).collect::<Vec<_>>()
    };
    let sequential: Vec<_> = (0..64).map(draw).collect();
    let threaded: Vec<_> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..64).map(|i| s.spawn(move || draw(i))).collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(sequential, threaded);
}

/// `faces` triangles over `vertices` random points in the unit cube, corners drawn at
/// random (degenerate triangles included).
fn random_mesh(seed: u64, vertices: usize, faces: usize) -> TriMesh {
    let mut g = rng::rng_from_seed(seed);
    let positions: Vec<Vec3> = (0..vertices)
        .map(|_| Vec3::new(g.random(), g.random(), g.random()))
        .collect();
    let triangles: Vec<[u32; 3]> = (0..faces)
        .map(|_| std::array::from_fn(|_| g.random_range(0..vertices as u32)))
        .collect();
    TriMesh::new(PointSet::new(positions).unwrap(), triangles).unwrap()
}

proptest! {
    /// A mesh exploded into one vertex per triangle corner (every edge a border) welds
    /// back to the mesh's own topology.
    #[test]
    fn an_exploded_mesh_welds_back_to_its_topology(
        seed in any::<u64>(),
        vertices in 3usize..40,
        faces in 1usize..60,
    ) {
        let mesh = random_mesh(seed, vertices, faces);
        let (positions, triangles) = (mesh.positions(), mesh.triangles());
        let corners: Vec<Vec3> = triangles.iter().flat_map(|t| t.map(|v| positions[v as usize])).collect();
        let soup = (0..faces as u32).map(|f| [3 * f, 3 * f + 1, 3 * f + 2]).collect();
        let exploded = TriMesh::new(PointSet::new(corners).unwrap(), soup).unwrap();
        let welded = exploded.welded().unwrap();
        prop_assert_eq!(welded.topology(), mesh.topology());
        prop_assert_eq!(welded.face_count(), faces);
        // Welding twice changes nothing.
        prop_assert_eq!(welded.welded().unwrap(), welded);
    }
}

#[test]
fn spot_is_closed_once_its_uv_seams_are_welded() {
    // The OBJ reader splits Spot's vertices along its UV seams (13 open pieces); by
    // position the cow is one closed genus-0 surface.
    let Some(loaded) = load("spot_welded", "meshes/spot_triangulated.obj") else {
        return;
    };
    let mesh = loaded.geometry.mesh().unwrap();
    let split = mesh.topology();
    assert!(
        !split.is_closed_manifold() && split.components > 1,
        "{split:?}"
    );
    let welded = mesh.welded().unwrap().topology();
    assert!(welded.is_closed_manifold(), "{welded:?}");
    assert_eq!((welded.components, welded.euler_characteristic), (1, 2));
}

proptest! {
    #[test]
    fn unreferenced_vertices_go_alike_whether_the_mesh_is_consumed_or_not(
        ts in prop::collection::vec([0u32..15, 0u32..15, 0u32..15], 0..40),
    ) {
        let ts: Vec<[u32; 3]> =
            ts.into_iter().filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]).collect();
        let positions: Vec<Vec3> = (0..15).map(|i| Vec3::new(i as f32, (i * i) as f32, 1.0)).collect();
        let normals: Vec<Vec3> = (0..15).map(|i| Vec3::new(1.0, i as f32, 0.0).normalize()).collect();
        let uvs: Vec<Vec2> = (0..15).map(|i| Vec2::new(i as f32 / 15.0, 0.5)).collect();
        let points = PointSet::new(positions).unwrap().with_normals(normals).unwrap();
        let mesh = TriMesh::new(points, ts).unwrap().with_uvs(uvs).unwrap();
        let borrowed = mesh.without_unreferenced_vertices().unwrap();
        prop_assert_eq!(borrowed.unreferenced_vertices(), 0);
        prop_assert_eq!(mesh.into_without_unreferenced_vertices().unwrap(), borrowed);
    }
}
