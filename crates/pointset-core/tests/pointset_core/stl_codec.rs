//! STL: round trips of random and real meshes through both encodings, format detection,
//! welding, the writer, and edited or broken files that must be read or refused by name,
//! never panic.

use std::path::Path;

use glam::{DVec3, Vec3};
use pointset_core::io::{
    self, FileFormat, Geometry, ReadOptions, WriteOptions, read_stl, write_stl, write_stl_ascii,
};
use pointset_core::{Error, Location, PointSet, TriMesh};
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
        cut in proptest::option::of(0usize..3000),
        ascii in any::<bool>(),
    ) {
        let mesh = random_mesh(seed, 6, 8);
        let mut bytes = both_encodings(&mesh)[usize::from(ascii)].clone();
        let len = bytes.len();
        for (at, byte) in edits {
            bytes[at % len] = byte;
        }
        // Some files are only edited: a cut of `cut % len` would almost always shorten them.
        if let Some(cut) = cut {
            bytes.truncate(len - cut % len);
        }
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
        assert_eq!(format.stores_normals(), back_points.normals().is_some());
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

// The codec's own cases, moved from a unit-test file in `src/` (public API only):
// detection, welding, broken files, the writer.

/// Reads STL bytes as `geosynth` reads a `.stl` file, recentring far data when asked.
fn read_at(bytes: &[u8], recentre: bool) -> Result<io::LoadedGeometry, Error> {
    io::read_geometry_bytes_with(
        Path::new("part.stl"),
        bytes,
        &ReadOptions::default().recentre_far(recentre),
    )
}

fn cube() -> TriMesh {
    let corners: Vec<Vec3> = (0..8)
        .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
        .collect();
    let faces = vec![
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ];
    TriMesh::new(PointSet::new(corners).unwrap(), faces).unwrap()
}

fn binary(mesh: &TriMesh) -> Vec<u8> {
    let mut bytes = Vec::new();
    write_stl(&Geometry::Mesh(mesh.clone()), &mut bytes).unwrap();
    bytes
}

fn ascii(mesh: &TriMesh) -> String {
    let mut bytes = Vec::new();
    write_stl_ascii(&Geometry::Mesh(mesh.clone()), &mut bytes).unwrap();
    String::from_utf8(bytes).unwrap()
}

/// The cube's vertices are numbered in the order its triangles first use them, which
/// is the order welding gives back.
fn cube_in_welding_order() -> TriMesh {
    let mesh = cube();
    let p = mesh.vertices().positions();
    let mut order: Vec<u32> = Vec::new();
    for v in mesh.triangles().iter().flatten() {
        if !order.contains(v) {
            order.push(*v);
        }
    }
    let positions = order.iter().map(|&v| p[v as usize]).collect();
    let renumber = |v: u32| order.iter().position(|&w| w == v).unwrap() as u32;
    let triangles = mesh.triangles().iter().map(|t| t.map(renumber)).collect();
    TriMesh::new(PointSet::new(positions).unwrap(), triangles).unwrap()
}

#[test]
fn binary_and_ascii_give_back_the_welded_mesh() {
    let mesh = cube_in_welding_order();
    assert_eq!(mesh.vertices().len(), 8);
    let from_binary = read_at(&binary(&mesh), false).unwrap();
    assert_eq!(from_binary.encoding, "binary_little_endian");
    assert_eq!(from_binary.comments, ["binary STL written by geosynth"]);
    assert_eq!(from_binary.geometry, Geometry::Mesh(mesh.clone()));
    let from_ascii = read_at(ascii(&mesh).as_bytes(), false).unwrap();
    assert_eq!(from_ascii.encoding, "ascii");
    assert_eq!(from_ascii.comments, ["geosynth"]);
    assert_eq!(from_ascii.geometry, Geometry::Mesh(mesh));
}

#[test]
fn windows_line_ends_are_read() {
    let mesh = cube_in_welding_order();
    let text = ascii(&mesh).replace('\n', "\r\n");
    let file = read_at(text.as_bytes(), false).unwrap();
    assert_eq!(file.encoding, "ascii");
    assert_eq!(file.geometry, Geometry::Mesh(mesh));
}

#[test]
fn binary_files_whose_header_says_solid_are_read_as_binary() {
    let mut bytes = binary(&cube());
    bytes[..12].copy_from_slice(b"solid part 1");
    let file = read_at(&bytes, false).unwrap();
    assert_eq!(file.encoding, "binary_little_endian");
    assert_eq!(file.geometry.mesh().unwrap().triangles().len(), 12);
}

#[test]
fn facet_normals_and_attribute_bytes_do_not_change_the_mesh() {
    let plain = binary(&cube());
    let mut noisy = plain.clone();
    for facet in noisy[84..].chunks_exact_mut(50) {
        facet[..12].copy_from_slice(&[0xff; 12]); // NaN normals
        facet[48..].copy_from_slice(&[0x12, 0x80]);
    }
    assert_eq!(
        read_stl(&noisy).unwrap(),
        read_stl(&plain).unwrap(),
        "stored normals and attributes must be read past"
    );
    // Skipped attribute bytes are said; a plain file says nothing.
    assert!(read_at(&plain, false).unwrap().notes.is_empty());
    assert_eq!(
        read_at(&noisy, false).unwrap().notes,
        [
            "facet attribute bytes on 12 of 12 facets skipped (some tools keep colours there, \
          in no agreed encoding)"
        ]
    );
}

#[test]
fn several_solids_mixed_case_and_negative_zero_weld_together() {
    let text = "SOLID a b\nFacet Normal 0 0 1\nOuter Loop\nVertex 0 0 0\nvertex 1 0 0\n\
                vertex 0 1 0\nEndLoop\nEndFacet\nendsolid a b\n\
                solid\nfacet normal 0 0 1 outer loop vertex -0 1 0 vertex 1 0 0 \
                vertex 1 1 -0.0 endloop endfacet endsolid\n";
    let file = read_at(text.as_bytes(), false).unwrap();
    assert_eq!(file.comments, ["a b"]);
    let mesh = file.geometry.mesh().unwrap().clone();
    assert_eq!(mesh.vertices().len(), 4);
    assert_eq!(mesh.triangles(), &[[0, 1, 2], [2, 1, 3]]);
}

#[test]
fn coinciding_corners_give_a_degenerate_triangle() {
    let text = "solid\nfacet normal 0 0 0\nouter loop\nvertex 1 2 3\nvertex 1 2 3\n\
                vertex 0 0 0\nendloop\nendfacet\nendsolid\n";
    let mesh = read_stl(text.as_bytes()).unwrap().mesh().unwrap().clone();
    assert_eq!(mesh.triangles(), &[[0, 0, 1]]);
    assert_eq!(mesh.degenerate_faces(), vec![0]);
}

#[test]
fn an_empty_solid_is_an_empty_mesh() {
    let mesh = read_stl(b"solid nothing\nendsolid nothing\n").unwrap();
    assert_eq!(mesh.mesh().map(|m| m.triangles().len()), Some(0));
    let mut bytes = vec![b' '; 80];
    bytes.extend_from_slice(&0u32.to_le_bytes());
    assert_eq!(read_stl(&bytes).unwrap(), mesh);
}

#[test]
fn short_and_long_binary_files_are_refused_by_name() {
    let bytes = binary(&cube());
    let short = read_stl(&bytes[..bytes.len() - 1]).unwrap_err();
    assert!(
        matches!(
            short,
            Error::HeaderExceedsFile {
                declared: 12,
                needed_bytes: 600,
                available_bytes: 599,
                ..
            }
        ),
        "{short}"
    );
    let mut long = bytes.clone();
    long.extend_from_slice(&[0; 7]);
    let err = read_stl(&long).unwrap_err();
    assert!(
        err.to_string().contains("7 bytes follow the 12 facets"),
        "{err}"
    );
    let header_only = read_stl(&bytes[..50]).unwrap_err();
    assert!(
        matches!(header_only, Error::UnexpectedEof { .. }),
        "{header_only}"
    );
    // A huge declared count is refused before anything is allocated.
    let mut huge = bytes[..84].to_vec();
    huge[80..84].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(
        read_stl(&huge).unwrap_err(),
        Error::HeaderExceedsFile { .. }
    ));
}

#[test]
fn broken_ascii_files_name_the_line() {
    let good = ascii(&cube());
    let cases = [
        (
            good.replacen("endloop", "vertex 0 0 0\nendloop", 1),
            "an STL facet is a triangle",
            7,
        ),
        (
            good.replacen("vertex 0 0 0", "vertex 0 zero 0", 1),
            "`zero` in a vertex",
            4,
        ),
        (
            good.replacen("vertex 0 0 0", "vertex 0 nan 0", 1),
            "corner 0 of facet 0",
            4,
        ),
        (
            good.replacen("facet normal", "facet", 1),
            "expected `normal`",
            2,
        ),
        (
            good.replacen("outer loop", "outer", 1),
            "expected `loop`",
            4,
        ),
        (
            format!("{good}junk\n"),
            "expected `solid`, found `junk`",
            87,
        ),
    ];
    for (text, needle, line) in cases {
        let err = read_stl(text.as_bytes()).unwrap_err();
        assert!(err.to_string().contains(needle), "{err}");
        assert!(
            matches!(err, Error::Malformed { location: Location::Line(l), .. } if l == line),
            "{err}"
        );
    }
    let cut: Vec<&str> = good.lines().take(40).collect();
    let err = read_stl(cut.join("\n").as_bytes()).unwrap_err();
    assert!(matches!(err, Error::UnexpectedEof { .. }), "{err}");
}

#[test]
fn non_finite_binary_corners_are_refused() {
    let mut bytes = binary(&cube());
    let at = 84 + 5 * 50 + 12 + 12 + 4; // facet 5, corner 1, y
    bytes[at..at + 4].copy_from_slice(&f32::INFINITY.to_le_bytes());
    let err = read_stl(&bytes).unwrap_err();
    assert_eq!(err.to_string(), "corner 1 of STL facet 5 is not finite");
}

#[test]
fn the_writer_refuses_what_stl_cannot_hold() {
    let points = Geometry::Points(PointSet::new(vec![Vec3::ZERO]).unwrap());
    let err = write_stl(&points, &mut Vec::new()).unwrap_err();
    assert!(matches!(err, Error::FormatCannotStore { .. }), "{err}");
    let mesh = Geometry::Mesh(cube());
    let far = WriteOptions::default().origin(DVec3::new(5e5, 4e6, 0.0));
    let err = io::encode_geometry(&mesh, FileFormat::Stl, &far).unwrap_err();
    assert!(err.to_string().contains("write .ply"), "{err}");
}

#[test]
fn written_normals_follow_the_right_hand_rule() {
    let bytes = binary(&cube());
    let mesh = cube();
    for (facet, t) in bytes[84..].chunks_exact(50).zip(mesh.triangles()) {
        let n: Vec<f32> = facet[..12]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        let p = t.map(|v| mesh.vertices().positions()[v as usize]);
        let centre = (p[0] + p[1] + p[2]) / 3.0 - Vec3::splat(0.5);
        // The cube's triangles face outward, so the normal points away from its centre.
        assert!(Vec3::from_slice(&n).dot(centre) > 0.0, "{n:?} at {centre}");
        assert!((Vec3::from_slice(&n).length() - 1.0).abs() < 1e-6);
    }
}

/// Welding while reading gives what welding the whole triangle soup would: the same
/// vertices in the same order, near the origin and recentred far from it (the soup is read
/// from a PLY file with the same recentring).
#[test]
fn welding_while_reading_equals_welding_the_soup() {
    for offset in [Vec3::ZERO, Vec3::new(5e5, 4e6, -3.0)] {
        let mut mesh = cube();
        let moved: Vec<Vec3> = mesh.positions().iter().map(|&p| p + offset).collect();
        mesh = TriMesh::new(PointSet::new(moved).unwrap(), mesh.triangles().to_vec()).unwrap();
        let corners: Vec<Vec3> = mesh
            .triangles()
            .iter()
            .flat_map(|t| t.map(|v| mesh.positions()[v as usize]))
            .collect();
        let soup_faces = (0..12).map(|f| [3 * f, 3 * f + 1, 3 * f + 2]).collect();
        let soup = TriMesh::new(PointSet::new(corners).unwrap(), soup_faces).unwrap();
        let soup_ply = io::encode_geometry(
            &Geometry::Mesh(soup),
            FileFormat::Ply,
            &WriteOptions::default(),
        )
        .unwrap();
        for (bytes, recentre) in [
            (binary(&mesh), false),
            (binary(&mesh), true),
            (ascii(&mesh).into_bytes(), true),
        ] {
            let options = ReadOptions::default().recentre_far(recentre);
            let from_soup =
                io::read_geometry_bytes_with(Path::new("soup.ply"), &soup_ply, &options).unwrap();
            let expected = from_soup.geometry.mesh().unwrap().welded().unwrap();
            let file = read_at(&bytes, recentre).unwrap();
            assert_eq!(file.origin, from_soup.origin);
            assert_eq!(
                file.geometry,
                Geometry::Mesh(expected),
                "{offset} {recentre}"
            );
            assert_eq!(file.geometry.mesh().unwrap().vertex_count(), 8);
        }
    }
}
