//! Codec-level tests: every encoding × every scalar type, and malformed input.

use glam::{DVec3, Vec2, Vec3};
use pointset_core::io::ply::*;
use pointset_core::io::{self, FileFormat, Geometry, WriteOptions};
use pointset_core::{Attribute, Error, Location, PointSet, ScalarType, TriMesh};
use proptest::prelude::*;

use super::streamed_files::read_from_file_and_bytes;

fn doc_with_all_types(encoding: PlyEncoding, values: &[f64]) -> PlyDocument {
    let n = values.len();
    let mut properties = Vec::new();
    let mut columns = Vec::new();
    for ty in ScalarType::ALL {
        properties.push(PlyProperty {
            name: format!("p_{ty}"),
            kind: PropertyKind::Scalar(ty),
        });
        columns.push(PlyColumn::Scalar(
            values.iter().map(|&v| ty.quantize(v)).collect(),
        ));
    }
    // A list of every item type with a varying length.
    for ty in ScalarType::ALL {
        properties.push(PlyProperty {
            name: format!("l_{ty}"),
            kind: PropertyKind::List {
                count: ScalarType::U8,
                item: ty,
            },
        });
        let mut offsets = vec![0];
        let mut items = Vec::new();
        for (r, &v) in values.iter().enumerate() {
            for k in 0..(r % 4) {
                items.push(ty.quantize(v + k as f64));
            }
            offsets.push(items.len());
        }
        columns.push(PlyColumn::List { offsets, items });
    }
    PlyDocument {
        encoding,
        comments: vec!["made by a test".into(), String::new()],
        obj_info: vec!["info line".into()],
        elements: vec![
            PlyElement {
                name: "thing".into(),
                count: n,
                properties,
                columns,
            },
            PlyElement {
                name: "empty".into(),
                count: 0,
                properties: vec![PlyProperty {
                    name: "a".into(),
                    kind: PropertyKind::Scalar(ScalarType::F32),
                }],
                columns: vec![PlyColumn::Scalar(Vec::new())],
            },
        ],
    }
}

fn encode(doc: &PlyDocument) -> Vec<u8> {
    let mut out = Vec::new();
    write_ply(doc, &mut out).unwrap();
    out
}

proptest! {
    #[test]
    fn every_encoding_and_scalar_type_round_trips(
        values in proptest::collection::vec(-1e6f64..1e6, 0..40)
    ) {
        for encoding in PlyEncoding::ALL {
            let doc = doc_with_all_types(encoding, &values);
            let back = read_ply(&encode(&doc)).unwrap();
            prop_assert_eq!(&back, &doc);
        }
    }
}

/// A point set or mesh with any mix of normals, UVs and attributes of every storage type.
pub(crate) fn geometry_with_parts(
    values: &[f32],
    normals: bool,
    uvs: bool,
    attributes: usize,
    faces: usize,
) -> Geometry {
    let n = values.len();
    let v = |i: usize, k: usize| values[(i + k) % n];
    let mut points = PointSet::new(
        (0..n)
            .map(|i| Vec3::new(v(i, 0), v(i, 1), v(i, 2)))
            .collect(),
    )
    .unwrap();
    if normals {
        let normals = (0..n)
            .map(|i| Vec3::new(v(i, 3), v(i, 4), 1.0).normalize())
            .collect();
        points = points.with_normals(normals).unwrap();
    }
    for (a, ty) in ScalarType::ALL.iter().cycle().take(attributes).enumerate() {
        let channel = (0..n)
            .map(|i| ty.quantize(f64::from(v(i, a))) as f32)
            .collect();
        let attribute = Attribute::new(format!("c{a}"), channel).with_storage(*ty);
        points = points.with_attribute(attribute).unwrap();
    }
    if faces == 0 {
        return Geometry::Points(points);
    }
    let triangles = (0..faces)
        .map(|f| [f % n, (f * 7 + 1) % n, (f * 13 + 2) % n].map(|i| i as u32))
        .collect();
    let mut mesh = TriMesh::new(points, triangles).unwrap();
    if uvs {
        mesh = mesh
            .with_uvs((0..n).map(|i| Vec2::new(v(i, 5), v(i, 6))).collect())
            .unwrap();
    }
    Geometry::Mesh(mesh)
}

proptest! {
    /// Geometry is written from its own arrays (`encode_geometry`, `write_geometry`): the
    /// bytes equal the document `document_from_geometry_at` builds, written by `write_ply`,
    /// in every encoding, with and without an origin; and the document reads back as it
    /// was written.
    #[test]
    fn geometry_written_from_its_arrays_equals_its_document(
        values in proptest::collection::vec(-1e4f32..1e4, 1..30),
        normals in any::<bool>(),
        uvs in any::<bool>(),
        attributes in 0usize..10,
        faces in 0usize..20,
        far in any::<bool>(),
    ) {
        let geometry = geometry_with_parts(&values, normals, uvs, attributes, faces);
        let origin = if far { DVec3::new(5e5, -3e6, 12.5) } else { DVec3::ZERO };
        for encoding in PlyEncoding::ALL {
            let options = WriteOptions::default()
                .comment("viewed")
                .origin(origin)
                .ply_encoding(encoding);
            let written = io::encode_geometry(&geometry, FileFormat::Ply, &options).unwrap();
            let doc = document_from_geometry_at(&geometry, encoding, &options.comments, origin)
                .unwrap();
            prop_assert_eq!(&written, &encode(&doc));
            prop_assert_eq!(&read_ply(&written).unwrap(), &doc);
        }
    }
}

fn minimal(body_format: &str, header_tail: &str, body: &[u8]) -> Vec<u8> {
    let mut v = format!("ply\nformat {body_format} 1.0\n{header_tail}end_header\n").into_bytes();
    v.extend_from_slice(body);
    v
}

#[test]
fn header_claiming_more_than_the_file_is_rejected_before_allocating() {
    let bytes = minimal(
        "binary_little_endian",
        "element vertex 1000000000000\nproperty float x\n",
        &[0u8; 1000],
    );
    match read_ply(&bytes) {
        Err(Error::HeaderExceedsFile {
            declared,
            available_bytes,
            ..
        }) => {
            assert_eq!(declared, 1_000_000_000_000);
            assert_eq!(available_bytes, 1000);
        }
        other => panic!("expected HeaderExceedsFile, got {other:?}"),
    }
    let ascii = minimal("ascii", "element vertex 100\nproperty float x\n", b"1\n2\n");
    assert!(matches!(
        read_ply(&ascii),
        Err(Error::HeaderExceedsFile { .. })
    ));
}

#[test]
fn truncated_binary_body_reports_the_byte_offset() {
    let header = "element vertex 2\nproperty float x\nproperty list uchar int idx\n";
    // Record 0: x + list of 0; record 1: x + list claiming 1 item (needs 4 more bytes).
    let mut body = vec![0u8; 4];
    body.push(0);
    body.extend_from_slice(&[0u8; 4]);
    body.push(1);
    body.extend_from_slice(&[0u8; 2]);
    let bytes = minimal("binary_little_endian", header, &body);
    match read_ply(&bytes) {
        Err(Error::ListCountOverflow { location, .. }) => {
            assert!(matches!(location, Location::Byte(_)));
        }
        other => panic!("expected ListCountOverflow, got {other:?}"),
    }
    // Lists make the minimum size smaller than the real one, so the size check passes and
    // the reader itself finds the end: record 1 has its list length but not its `x`.
    let header = "element vertex 2\nproperty list uchar uchar idx\nproperty float x\n";
    let mut body = vec![4u8, 1, 2, 3, 4];
    body.extend_from_slice(&1.5f32.to_le_bytes());
    body.extend_from_slice(&[0u8, 7]);
    let bytes = minimal("binary_little_endian", header, &body);
    let header_len = bytes.len() - body.len();
    match read_ply(&bytes) {
        Err(Error::UnexpectedEof {
            location: Location::Byte(off),
            ..
        }) => assert_eq!(off, header_len as u64 + 10),
        other => panic!("expected UnexpectedEof, got {other:?}"),
    }
}

#[test]
fn unknown_property_type_names_its_line() {
    let bytes = minimal("ascii", "element vertex 1\nproperty quad x\n", b"1\n");
    assert!(matches!(
        read_ply(&bytes),
        Err(Error::UnknownPropertyType { line: 4, ref type_name }) if type_name == "quad"
    ));
}

#[test]
fn list_count_overflow_and_negative_counts() {
    let header = "element face 1\nproperty list int int vertex_indices\n";
    let mut body = (-3i32).to_le_bytes().to_vec();
    body.extend_from_slice(&[0u8; 12]);
    let bytes = minimal("binary_little_endian", header, &body);
    assert!(matches!(
        read_ply(&bytes),
        Err(Error::ListCountOverflow { count: -3, .. })
    ));
    let mut body = 2_000_000_000i32.to_le_bytes().to_vec();
    body.extend_from_slice(&[0u8; 12]);
    let bytes = minimal("binary_little_endian", header, &body);
    assert!(matches!(
        read_ply(&bytes),
        Err(Error::ListCountOverflow {
            count: 2_000_000_000,
            ..
        })
    ));
    let ascii = minimal("ascii", header, b"400 1 2 3\n");
    assert!(matches!(
        read_ply(&ascii),
        Err(Error::ListCountOverflow { .. })
    ));
}

#[test]
fn malformed_headers_and_values() {
    let cases: Vec<Vec<u8>> = vec![
        b"plx\nformat ascii 1.0\nend_header\n".to_vec(),
        b"ply\nformat ascii 2.0\nend_header\n".to_vec(),
        b"ply\nformat ascii 1.0\nproperty float x\nend_header\n".to_vec(),
        b"ply\nformat ascii 1.0\nelement vertex -1\nend_header\n".to_vec(),
        b"ply\nelement vertex 0\nend_header\n".to_vec(),
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float x\nend_header\n1 2\n".to_vec(),
        minimal("ascii", "element v 1\nproperty uchar x\n", b"300\n"),
        minimal("ascii", "element v 1\nproperty int x\n", b"1.5\n"),
        minimal("ascii", "element v 1\nproperty float x\n", b"abc\n"),
        minimal("ascii", "element v 1\nproperty list float int x\n", b"1 2\n"),
    ];
    for (i, bytes) in cases.iter().enumerate() {
        assert!(
            matches!(read_ply(bytes), Err(Error::Malformed { .. })),
            "case {i}: {:?}",
            read_ply(bytes)
        );
    }
    assert!(matches!(
        read_ply(b"ply\nformat ascii 1.0\nelement vertex 1\n"),
        Err(Error::UnexpectedEof { .. })
    ));
}

#[test]
fn ascii_line_numbers_count_from_the_file_start() {
    let bytes = minimal("ascii", "element v 3\nproperty float x\n", b"1\n2\nzz\n");
    match read_ply(&bytes) {
        Err(Error::Malformed {
            location: Location::Line(n),
            ..
        }) => assert_eq!(n, 8),
        other => panic!("expected a line number, got {other:?}"),
    }
}

#[test]
fn normals_keep_their_negative_zeros() {
    // Written from the geometry's arrays, a normal's −0 stays −0 (the bundled fixtures'
    // bytes depend on it); positions are written with the origin added, as ever.
    let points = PointSet::new(vec![Vec3::new(-0.0, 1.0, 2.0)])
        .unwrap()
        .with_normals(vec![Vec3::new(-0.0, 0.0, 1.0)])
        .unwrap();
    let options = WriteOptions::default();
    let bytes = io::encode_geometry(&Geometry::Points(points), FileFormat::Ply, &options).unwrap();
    let doc = read_ply(&bytes).unwrap();
    let vertex = doc.element("vertex").unwrap();
    assert!(vertex.scalar("nx").unwrap()[0].is_sign_negative());
    assert!(vertex.scalar("ny").unwrap()[0].is_sign_positive());
    assert!(vertex.scalar("x").unwrap()[0].is_sign_positive());
}

/// Reads `bytes` through a document, as `read_geometry` did before it read PLY bodies
/// straight into geometry.
fn through_document(bytes: &[u8], recentre: bool) -> Result<(Geometry, DVec3), Error> {
    geometry_from_document_at(&read_ply(bytes)?, recentre)
}

/// Reads `bytes` as `read_geometry` does.
fn directly(bytes: &[u8], recentre: bool) -> Result<(Geometry, DVec3), Error> {
    let options = io::ReadOptions::default().recentre_far(recentre);
    let loaded = io::read_geometry_bytes_with(std::path::Path::new("x.ply"), bytes, &options)?;
    Ok((loaded.geometry, loaded.origin))
}

proptest! {
    /// PLY bodies read straight into geometry give what a document gives: the same
    /// geometry and origin, or the same error, on files with every kind of part, edited
    /// or cut short, in every encoding.
    #[test]
    fn files_read_directly_equal_files_read_through_a_document(
        values in proptest::collection::vec(-1e4f32..1e4, 1..12),
        normals in any::<bool>(),
        uvs in any::<bool>(),
        attributes in 0usize..4,
        faces in 0usize..8,
        far in any::<bool>(),
        edits in proptest::collection::vec((0usize..2000, any::<u8>()), 0..4),
        cut in proptest::option::of(0usize..2000),
    ) {
        let geometry = geometry_with_parts(&values, normals, uvs, attributes, faces);
        let origin = if far { DVec3::new(5e5, -3e6, 12.5) } else { DVec3::ZERO };
        for encoding in PlyEncoding::ALL {
            let options = WriteOptions::default().origin(origin).ply_encoding(encoding);
            let mut bytes = io::encode_geometry(&geometry, FileFormat::Ply, &options).unwrap();
            // Past the magic `ply` line, which `read_geometry` checks before either reader.
            for &(at, byte) in &edits {
                let len = bytes.len();
                bytes[4 + at % (len - 4)] = byte;
            }
            if let Some(cut) = cut {
                bytes.truncate(cut.max(8));
            }
            for recentre in [false, true] {
                let a = directly(&bytes, recentre).map_err(|e| e.to_string());
                let b = through_document(&bytes, recentre).map_err(|e| e.to_string());
                prop_assert_eq!(&a, &b);
            }
            for recentre in [false, true] {
                let (from_file, from_bytes) = read_from_file_and_bytes("x.ply", &bytes, recentre);
                prop_assert_eq!(from_file, from_bytes);
            }
        }
    }
}

#[test]
fn a_bad_face_in_a_truncated_file_is_reported_as_truncation() {
    // Both are wrong: face 0 names vertex 7 of 3, and the file stops before face 2. The
    // whole body is read before the faces are judged, however the file is read.
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 3\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n3 0 1 2\n";
    for error in [
        directly(ply.as_bytes(), false).unwrap_err(),
        through_document(ply.as_bytes(), false).unwrap_err(),
    ] {
        assert!(matches!(error, Error::UnexpectedEof { .. }), "{error:?}");
    }
    // Complete, the file is refused for its face.
    let whole = format!("{ply}3 2 1 0\n");
    let error = directly(whole.as_bytes(), false).unwrap_err();
    assert!(
        matches!(
            error,
            Error::IndexOutOfRange {
                face: 0,
                vertex: 7,
                ..
            }
        ),
        "{error:?}"
    );
}

#[test]
fn faces_before_vertices_are_read_too() {
    let ply = "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n\
               element vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
               end_header\n4 0 1 2 3\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
    let (geometry, _) = directly(ply.as_bytes(), false).unwrap();
    assert_eq!(geometry.mesh().unwrap().triangles().len(), 2);
    assert_eq!(
        directly(ply.as_bytes(), false).unwrap(),
        through_document(ply.as_bytes(), false).unwrap()
    );
}

#[test]
fn documents_built_by_hand_with_missing_values_are_refused() {
    let points = Geometry::Points(PointSet::new(vec![Vec3::ZERO, Vec3::X]).unwrap());
    let good = document_from_geometry(&points, PlyEncoding::Ascii, &[]).unwrap();
    // A column one value short, and a column too many.
    let mut short = good.clone();
    if let PlyColumn::Scalar(values) = &mut short.elements[0].columns[1] {
        values.pop();
    }
    let mut extra = good.clone();
    extra.elements[0]
        .columns
        .push(PlyColumn::Scalar(vec![0.0; 2]));
    for doc in [short, extra] {
        let error = geometry_from_document(&doc).unwrap_err();
        assert!(matches!(error, Error::LengthMismatch { .. }), "{error:?}");
        assert!(write_ply(&doc, &mut Vec::new()).is_err());
    }
    assert_eq!(geometry_from_document(&good).unwrap(), points);
    // A scalar property holding lists cannot be written.
    let mut mixed = good.clone();
    mixed.elements[0].columns[0] = PlyColumn::List {
        offsets: vec![0, 1, 2],
        items: vec![0.0, 1.0],
    };
    let error = write_ply(&mixed, &mut Vec::new()).unwrap_err();
    assert!(
        matches!(error, Error::IncompatibleLayout { .. }),
        "{error:?}"
    );
}

#[test]
fn list_offsets_outside_their_items_are_refused() {
    let square = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
                  property float z\nelement face 2\nproperty list uchar int vertex_indices\n\
                  end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";
    let good = read_ply(square.as_bytes()).unwrap();
    assert!(geometry_from_document(&good).is_ok());
    // Offsets that run past the items, and offsets that fall back.
    for (offsets, record, start, end) in [
        (vec![0, 3, 7], 1, 3, 7),
        (vec![0, 4, 3], 1, 4, 3),
        (vec![5, 3, 6], 0, 5, 3),
    ] {
        let mut doc = good.clone();
        let face = &mut doc.elements[1].columns[0];
        if let PlyColumn::List { offsets: o, .. } = face {
            *o = offsets;
        }
        let errors = [
            geometry_from_document(&doc).unwrap_err(),
            write_ply(&doc, &mut Vec::new()).unwrap_err(),
        ];
        for error in errors {
            let expected = Error::ListOutOfRange {
                element: "face".into(),
                property: "vertex_indices".into(),
                record,
                start,
                end,
                items: 6,
            };
            assert_eq!(error.to_string(), expected.to_string());
        }
    }
}
