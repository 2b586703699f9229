//! Edited or cut-short PLY (binary and ASCII), OBJ, OFF, XYZ, LAS, PCD (binary, ASCII
//! and compressed) and glTF (`.glb` and `.gltf`) files, of meshes and of point sets with normals and colours (XYZ, LAS
//! and PCD: point sets only): each is read as valid
//! geometry or refused with an error, never a panic. (STL and NRRD files have tests of
//! their own like this one.)

use glam::Vec3;
use pointset_core::io::ply::PlyEncoding;
use pointset_core::io::{
    self, FileFormat, Geometry, GltfContainer, PcdEncoding, WriteOptions, XyzColumns,
};
use proptest::prelude::*;

use super::{random_mesh, read};

/// The formats edited: the format, the PLY and PCD encodings (ignored by the others), a
/// file name that says the format.
const FORMATS: [(FileFormat, PlyEncoding, PcdEncoding, &str); 13] = [
    (
        FileFormat::Ply,
        PlyEncoding::BinaryLittleEndian,
        PcdEncoding::Binary,
        "e.ply",
    ),
    (
        FileFormat::Ply,
        PlyEncoding::BinaryBigEndian,
        PcdEncoding::Binary,
        "e.ply",
    ),
    (
        FileFormat::Ply,
        PlyEncoding::Ascii,
        PcdEncoding::Binary,
        "e.ply",
    ),
    (
        FileFormat::Obj,
        PlyEncoding::Ascii,
        PcdEncoding::Binary,
        "e.obj",
    ),
    (
        FileFormat::Off,
        PlyEncoding::Ascii,
        PcdEncoding::Binary,
        "e.off",
    ),
    (
        FileFormat::Xyz(XyzColumns::Positions),
        PlyEncoding::Ascii,
        PcdEncoding::Binary,
        "e.xyz",
    ),
    (
        FileFormat::Xyz(XyzColumns::Colours),
        PlyEncoding::Ascii,
        PcdEncoding::Binary,
        "e.xyzrgb",
    ),
    (
        FileFormat::Las,
        PlyEncoding::Ascii,
        PcdEncoding::Binary,
        "e.las",
    ),
    (
        FileFormat::Pcd,
        PlyEncoding::Ascii,
        PcdEncoding::Binary,
        "e.pcd",
    ),
    (
        FileFormat::Pcd,
        PlyEncoding::Ascii,
        PcdEncoding::Ascii,
        "e.pcd",
    ),
    (
        FileFormat::Pcd,
        PlyEncoding::Ascii,
        PcdEncoding::BinaryCompressed,
        "e.pcd",
    ),
    (
        FileFormat::Gltf(GltfContainer::Binary),
        PlyEncoding::Ascii,
        PcdEncoding::Binary,
        "e.glb",
    ),
    (
        FileFormat::Gltf(GltfContainer::Json),
        PlyEncoding::Ascii,
        PcdEncoding::Binary,
        "e.gltf",
    ),
];

/// A random mesh, or its vertices as points with normals and colours.
fn geometry(seed: u64, mesh: bool) -> Geometry {
    let mesh_geometry = random_mesh(seed, 8, 10);
    if mesh {
        return Geometry::Mesh(mesh_geometry);
    }
    let vertices = mesh_geometry.vertices();
    let mut points = vertices
        .clone()
        .with_normals(vec![Vec3::Z; vertices.len()])
        .unwrap();
    points
        .set_colors(&vec![[0.8, 0.4, 0.2]; vertices.len()])
        .unwrap();
    Geometry::Points(points)
}

proptest! {
    #[test]
    fn edited_files_are_read_or_refused(
        seed in any::<u64>(),
        mesh in any::<bool>(),
        format in 0usize..FORMATS.len(),
        edits in proptest::collection::vec((0usize..4000, any::<u8>()), 1..6),
        cut in proptest::option::of(0usize..4000),
    ) {
        let (format, encoding, pcd_encoding, name) = FORMATS[format];
        let options = WriteOptions::default().ply_encoding(encoding).pcd_encoding(pcd_encoding);
        let mesh = mesh && !matches!(format, FileFormat::Xyz(_) | FileFormat::Las | FileFormat::Pcd);
        let mut bytes = io::encode_geometry(&geometry(seed, mesh), format, &options).unwrap();
        let len = bytes.len();
        for (at, byte) in edits {
            bytes[at % len] = byte;
        }
        // Some files are only edited: a cut of `cut % len` would almost always shorten them.
        if let Some(cut) = cut {
            bytes.truncate(len - cut % len);
        }
        if let Ok(loaded) = read(name, &bytes) {
            let points = loaded.geometry.points();
            prop_assert!(points.positions().iter().all(|p| p.is_finite()));
            if let Some(normals) = points.normals() {
                prop_assert_eq!(normals.len(), points.len());
            }
            if let Some(mesh) = loaded.geometry.mesh() {
                let n = mesh.vertex_count() as u32;
                prop_assert!(mesh.triangles().iter().flatten().all(|&v| v < n));
            }
        }
    }
}
