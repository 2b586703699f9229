//! STL: round trips of random and real meshes through both encodings, format detection,
//! and edited files that must be read or refused, never panic.

use std::path::Path;

use glam::Vec3;
use pointset_core::TriMesh;
use pointset_core::io::{self, FileFormat, Geometry, WriteOptions, write_stl_ascii};
use proptest::prelude::*;

use super::{load, random_mesh, read};

/// Each triangle as its three corner positions: what an STL file holds.
fn corner_positions(mesh: &TriMesh) -> Vec<[Vec3; 3]> {
    let p = mesh.vertices().positions();
    mesh.triangles()
        .iter()
        .map(|t| t.map(|v| p[v as usize]))
        .collect()
}

fn both_encodings(mesh: &TriMesh) -> [Vec<u8>; 2] {
    let geometry = Geometry::Mesh(mesh.clone());
    let binary = io::encode_geometry(&geometry, FileFormat::Stl, &WriteOptions::default()).unwrap();
    let mut ascii = Vec::new();
    write_stl_ascii(&geometry, &mut ascii).unwrap();
    [binary, ascii]
}

proptest! {
    /// Both encodings give back every triangle's corners exactly, welded into as many
    /// vertices as there are distinct positions in use.
    #[test]
    fn meshes_round_trip_through_both_encodings(
        seed in any::<u64>(),
        vertices in 3usize..40,
        faces in 0usize..60,
    ) {
        let mesh = random_mesh(seed, vertices, faces);
        let welded = mesh.welded().unwrap().without_unreferenced_vertices().unwrap();
        for (bytes, name) in both_encodings(&mesh).iter().zip(["b.stl", "a.stl"]) {
            let back = read(name, bytes).unwrap().geometry;
            let back = back.mesh().unwrap();
            prop_assert_eq!(corner_positions(back), corner_positions(&mesh));
            prop_assert_eq!(back.vertex_count(), welded.vertex_count());
            prop_assert_eq!(back.topology(), welded.topology());
        }
    }

    /// Any edit of a valid file (bytes replaced, the file cut short) reads as a mesh whose
    /// indices are in range, or as an error; never a panic.
    #[test]
    fn stl_edits_are_read_or_refused(
        seed in any::<u64>(),
        edits in proptest::collection::vec((0usize..2000, any::<u8>()), 1..6),
        cut in 0usize..3000,
        ascii in any::<bool>(),
    ) {
        let mesh = random_mesh(seed, 6, 8);
        let mut bytes = both_encodings(&mesh)[usize::from(ascii)].clone();
        let len = bytes.len();
        for (at, byte) in edits {
            bytes[at % len] = byte;
        }
        bytes.truncate(bytes.len().saturating_sub(cut % bytes.len()));
        if let Ok(loaded) = read("e.stl", &bytes) {
            let mesh = loaded.geometry.mesh().unwrap();
            let n = mesh.vertex_count() as u32;
            prop_assert!(mesh.triangles().iter().flatten().all(|&v| v < n));
            prop_assert!(mesh.positions().iter().all(|p| p.is_finite()));
        }
    }
}

#[test]
fn real_meshes_round_trip_with_their_welded_topology() {
    for rel in [
        "meshes/stanford_bunny_res2.ply",
        "meshes/fertility.off",
        "meshes/spot_triangulated.obj",
    ] {
        let Some(loaded) = load("stl_real_meshes", rel) else {
            return;
        };
        let mesh = loaded.geometry.mesh().unwrap();
        let welded = mesh
            .welded()
            .unwrap()
            .without_unreferenced_vertices()
            .unwrap();
        for bytes in both_encodings(mesh) {
            let back = read("r.stl", &bytes).unwrap().geometry;
            let back = back.mesh().unwrap();
            assert_eq!(corner_positions(back), corner_positions(mesh), "{rel}");
            assert_eq!(back.topology(), welded.topology(), "{rel}");
        }
    }
}

#[test]
fn stl_is_found_by_extension_or_by_content() {
    let mesh = random_mesh(7, 10, 12);
    let [binary, ascii] = both_encodings(&mesh);
    for (bytes, encoding) in [(&binary, "binary_little_endian"), (&ascii, "ascii")] {
        for name in ["m.stl", "m.STL", "m"] {
            let loaded = read(name, bytes).unwrap();
            assert_eq!(
                (loaded.format, loaded.encoding.as_str()),
                (FileFormat::Stl, encoding)
            );
        }
        assert!(matches!(
            read("m.ply", bytes),
            Err(pointset_core::Error::FormatMismatch { .. })
        ));
    }
    // A point set has no triangles to write.
    let points = Geometry::Points(mesh.vertices().clone());
    let err = io::encode_geometry(&points, FileFormat::Stl, &WriteOptions::default()).unwrap_err();
    assert!(
        err.to_string().contains("STL cannot store a point set"),
        "{err}"
    );
    assert_eq!(
        FileFormat::Stl
            .check_can_store(false, glam::DVec3::ZERO)
            .unwrap_err()
            .to_string(),
        err.to_string()
    );
    // Written and read through paths, as the command-line tool does.
    let dir = std::env::temp_dir().join(format!("pointset_core_stl_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("mesh.stl");
    io::write_geometry(
        &path,
        &Geometry::Mesh(mesh.clone()),
        &WriteOptions::default(),
    )
    .unwrap();
    let back = io::read_geometry(&path).unwrap();
    assert_eq!(
        corner_positions(back.geometry.mesh().unwrap()),
        corner_positions(&mesh)
    );
    std::fs::remove_dir_all(Path::new(&dir)).unwrap();
}

/// `FileFormat::unstored` names exactly what a round trip through each format loses.
#[test]
fn unstored_names_what_each_format_drops() {
    use glam::Vec2;
    use pointset_core::Attribute;
    let mesh = random_mesh(11, 12, 10);
    let n = mesh.vertex_count();
    let mut points = mesh
        .vertices()
        .clone()
        .with_normals(vec![Vec3::Z; n])
        .unwrap();
    points.set_colors(&vec![[0.2, 0.4, 0.6]; n]).unwrap();
    points
        .set_attribute(Attribute::new("quality", vec![0.5; n]))
        .unwrap();
    points
        .set_attribute(Attribute::new("alpha", vec![255.0; n]))
        .unwrap();
    let full = TriMesh::new(points, mesh.triangles().to_vec())
        .unwrap()
        .with_uvs(vec![Vec2::new(0.25, 0.75); n])
        .unwrap();
    let geometry = Geometry::Mesh(full);
    for format in [
        FileFormat::Ply,
        FileFormat::Obj,
        FileFormat::Off,
        FileFormat::Stl,
    ] {
        let bytes = io::encode_geometry(&geometry, format, &WriteOptions::default()).unwrap();
        let back = read(&format!("m.{}", format.to_string().to_lowercase()), &bytes).unwrap();
        let back_points = back.geometry.points();
        let mut lost = Vec::new();
        if back_points.normals().is_none() {
            lost.push("vertex normals".to_string());
        }
        if back.geometry.mesh().and_then(TriMesh::uvs).is_none() {
            lost.push("UVs".to_string());
        }
        if back_points.colors().is_none() {
            lost.push("colours".to_string());
        }
        for name in ["quality", "alpha"] {
            if back_points.attribute(name).is_none() {
                lost.push(format!("attribute `{name}`"));
            }
        }
        assert_eq!(format.unstored(&geometry), lost, "{format}");
    }
    assert_eq!(FileFormat::Stl.unstored(&geometry).len(), 5);
    assert!(FileFormat::Ply.unstored(&geometry).is_empty());
}
