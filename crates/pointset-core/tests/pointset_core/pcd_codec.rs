//! PCD point clouds: round trips through each encoding, files as PCL, Open3D and older
//! writers make them, what the reader says it could not keep, and every refusal.

use glam::{DVec3, Vec3};
use pointset_core::io::{self, FileFormat, Geometry, PcdEncoding, WriteOptions};
use pointset_core::{Attribute, Error, Location, PointSet, ScalarType};
use proptest::prelude::*;

use super::streamed_files::read_from_file_and_bytes;
use super::xyz_codec::full_points;
use super::{point_set_strategy, read};

const ENCODINGS: [PcdEncoding; 3] = [
    PcdEncoding::Binary,
    PcdEncoding::Ascii,
    PcdEncoding::BinaryCompressed,
];

/// `points` as a PCD file in `encoding`.
fn encoded(points: &PointSet, encoding: PcdEncoding) -> Vec<u8> {
    let options = WriteOptions::default()
        .pcd_encoding(encoding)
        .comment("a test");
    io::encode_geometry(&Geometry::Points(points.clone()), FileFormat::Pcd, &options).unwrap()
}

/// The attributes of `points` by name: colours come back first, the others after them.
pub(super) fn by_name(points: &PointSet) -> Vec<(String, ScalarType, Vec<f32>)> {
    let mut all: Vec<_> = points
        .attributes()
        .iter()
        .map(|a| (a.name().to_string(), a.storage(), a.values().to_vec()))
        .collect();
    all.sort_by(|a, b| a.0.cmp(&b.0));
    all
}

proptest! {
    #[test]
    fn point_sets_round_trip_through_every_encoding(points in point_set_strategy()) {
        for encoding in ENCODINGS {
            let back = read("p.pcd", &encoded(&points, encoding)).unwrap();
            prop_assert_eq!(back.format, FileFormat::Pcd);
            prop_assert_eq!(&back.encoding, encoding.keyword());
            prop_assert_eq!(&back.comments, &["a test".to_string()]);
            prop_assert!(back.notes.is_empty(), "{:?}", back.notes);
            let got = back.geometry.points();
            prop_assert_eq!(got.positions(), points.positions());
            prop_assert_eq!(got.normals(), points.normals());
            prop_assert_eq!(by_name(got), by_name(&points));
        }
    }
}

#[test]
fn every_attribute_type_and_an_alpha_come_back_as_stored() {
    let n = 50;
    let mut points =
        PointSet::new((0..n).map(|i| Vec3::new(i as f32, 0.5, -1.0)).collect()).unwrap();
    let storages = [
        (ScalarType::I8, -100.0),
        (ScalarType::U8, 200.0),
        (ScalarType::I16, -30000.0),
        (ScalarType::U16, 60000.0),
        (ScalarType::I32, -2e9),
        (ScalarType::U32, 4e9),
        (ScalarType::F32, 0.1),
        (ScalarType::F64, 1e-30),
    ];
    for (storage, value) in storages {
        let name = format!("a_{storage}");
        let values = (0..n).map(|i| value as f32 * (i % 2) as f32).collect();
        points
            .set_attribute(Attribute::new(name, values).with_storage(storage))
            .unwrap();
    }
    let colours: Vec<[f32; 3]> = (0..n).map(|i| [i as f32 / 49.0, 0.0, 1.0]).collect();
    points.set_colors(&colours).unwrap();
    let alpha = (0..n).map(|i| (i * 5) as f32).collect();
    points
        .set_attribute(Attribute::new("alpha", alpha).with_storage(ScalarType::U8))
        .unwrap();
    for encoding in ENCODINGS {
        let bytes = encoded(&points, encoding);
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains(" rgba "), "{text:.400}");
        let back = read("p.pcd", &bytes).unwrap();
        assert_eq!(
            by_name(back.geometry.points()),
            by_name(&points),
            "{encoding:?}"
        );
    }
}

#[test]
fn files_as_pcl_and_open3d_write_them_are_read() {
    // PCL's PointXYZRGBNormal in ASCII: rgb a float field written as its packed integer
    // (alpha 255), curvature, padding; Open3D writes the float itself (alpha 0: a
    // denormal), which must give the same colour.
    let packed: u32 = 0xFF_10_80_F0;
    let as_float = f32::from_bits(0x00_10_80_F0);
    let file = |colour: String| {
        format!(
            "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n\
             FIELDS x y z _ rgb normal_x normal_y normal_z curvature\n\
             SIZE 4 4 4 1 4 4 4 4 4\nTYPE F F F U F F F F F\nCOUNT 1 1 1 4 1 1 1 1 1\n\
             WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n\
             1 2 3 0 0 0 0 {colour} 0 0 1 0.25\n-1 0.5 4 0 0 0 0 0 1 0 0 0\n"
        )
    };
    for colour in [packed.to_string(), format!("{as_float:e}")] {
        let back = read("pcl.pcd", file(colour.clone()).as_bytes()).unwrap();
        let points = back.geometry.points();
        assert!(back.notes.is_empty(), "{:?}", back.notes);
        assert!(back.comments.is_empty(), "the banner is no comment");
        assert_eq!(points.positions()[1], Vec3::new(-1.0, 0.5, 4.0));
        assert_eq!(points.normals().map(|n| n[0]), Some(Vec3::Z));
        let [r, g, b] = ["red", "green", "blue"].map(|c| points.attribute(c).unwrap().values()[0]);
        assert_eq!([r, g, b], [16.0, 128.0, 240.0], "{colour}");
        assert_eq!(points.attribute("curvature").unwrap().values(), [0.25, 0.0]);
        assert_eq!(points.attributes().len(), 4, "padding is not an attribute");
    }
}

#[test]
fn an_organised_scan_keeps_its_valid_points_and_says_what_it_dropped() {
    // A 3 × 2 organised cloud, binary, as a depth camera gives it: one point invalid (NaN),
    // one normal and one curvature NaN, a 33-value descriptor, a 64-bit timestamp, and
    // the sensor placed off the origin.
    let header = "VERSION .7\nFIELDS x y z normal_x normal_y normal_z curvature fpfh t\n\
                  SIZE 4 4 4 4 4 4 4 4 8\nTYPE F F F F F F F F U\nCOUNT 1 1 1 1 1 1 1 33 1\n\
                  WIDTH 3\nHEIGHT 2\nVIEWPOINT 0.5 0 1.5 1 0 0 0\nPOINTS 6\nDATA binary\n";
    let mut bytes = header.as_bytes().to_vec();
    for i in 0..6u64 {
        let x = if i == 2 { f32::NAN } else { i as f32 };
        let normal_z = if i == 4 { f32::NAN } else { 1.0 };
        let curvature = if i == 5 { f32::NAN } else { 0.5 };
        for v in [x, 0.0, 2.0, 0.0, 0.0, normal_z, curvature] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        bytes.extend(std::iter::repeat_n(0u8, 33 * 4));
        bytes.extend_from_slice(&(1_700_000_000_000 + i).to_le_bytes());
    }
    let back = read("scan.pcd", &bytes).unwrap();
    let points = back.geometry.points();
    let xs: Vec<f32> = points.positions().iter().map(|p| p.x).collect();
    assert_eq!(xs, [0.0, 1.0, 3.0, 4.0, 5.0]);
    assert_eq!(points.normals().map(|n| n[3]), Some(Vec3::ZERO));
    assert_eq!(points.attribute("curvature").unwrap().values()[4], 0.0);
    let t = points.attribute("t").unwrap();
    assert_eq!(t.storage(), ScalarType::F64);
    let notes = back.notes.join("\n");
    for said in [
        "`fpfh` (33 values a point) skipped",
        "3 × 2 points kept as a list",
        "1 PCD point with NaN",
        "1 PCD normal not finite",
        "`curvature`: 1 value not finite",
        "VIEWPOINT (position 0.5 0 1.5",
    ] {
        assert!(notes.contains(said), "{said}\n{notes}");
    }
    // Normals under both names: the first full set is read, the other named as skipped.
    let both = "FIELDS x y z normal_x normal_y normal_z nx ny nz\nSIZE 4 4 4 4 4 4 4 4 4\n\
                TYPE F F F F F F F F F\nWIDTH 1\nDATA ascii\n0 0 0 0 0 1 1 0 0\n";
    let back = read("both.pcd", both.as_bytes()).unwrap();
    assert_eq!(back.geometry.points().normals(), Some(&[Vec3::Z][..]));
    assert_eq!(back.notes.len(), 3, "{:?}", back.notes);
    // Bytes after the last record: a note.
    let mut longer = bytes.clone();
    longer.extend_from_slice(&[7; 5]);
    let back = read("scan.pcd", &longer).unwrap();
    assert!(
        back.notes
            .iter()
            .any(|n| n.contains("5 bytes after the last"))
    );
}

#[test]
fn far_coordinates_are_written_in_double_precision() {
    let origin = DVec3::new(512_345.0, 4_123_456.0, 80.0);
    let points = PointSet::new(vec![Vec3::new(0.125, -0.5, 1.0), Vec3::ZERO]).unwrap();
    let options = WriteOptions::default().origin(origin);
    let geometry = Geometry::Points(points.clone());
    for encoding in ENCODINGS {
        let bytes = io::encode_geometry(
            &geometry,
            FileFormat::Pcd,
            &options.clone().pcd_encoding(encoding),
        )
        .unwrap();
        assert!(String::from_utf8_lossy(&bytes).contains("SIZE 8 8 8\nTYPE F F F\n"));
        let recentre = io::ReadOptions::default().recentre_far(true);
        let back = io::read_geometry_bytes_with(std::path::Path::new("far.pcd"), &bytes, &recentre)
            .unwrap();
        let got: Vec<DVec3> = back
            .geometry
            .points()
            .positions()
            .iter()
            .map(|p| p.as_dvec3() + back.origin)
            .collect();
        let want: Vec<DVec3> = points
            .positions()
            .iter()
            .map(|p| p.as_dvec3() + origin)
            .collect();
        assert_eq!(got, want, "{encoding:?}");
    }
}

#[test]
fn pcd_is_told_by_its_content_and_read_as_it_streams_in() {
    let points = full_points();
    for encoding in ENCODINGS {
        let bytes = encoded(&points, encoding);
        for name in ["p.pcd", "unnamed"] {
            let (from_file, from_bytes) = read_from_file_and_bytes(name, &bytes, false);
            assert!(from_file.is_ok(), "{name}: {from_file:?}");
            assert_eq!(from_file, from_bytes, "{name}");
        }
        // A text line cut short may still be a line of numbers; records may not.
        let cut = &bytes[..bytes.len() - 3];
        let (from_file, from_bytes) = read_from_file_and_bytes("cut.pcd", cut, false);
        assert!(encoding == PcdEncoding::Ascii || from_file.is_err());
        assert_eq!(from_file, from_bytes);
    }
    let ply = io::encode_geometry(
        &Geometry::Points(points),
        FileFormat::Ply,
        &WriteOptions::default(),
    )
    .unwrap();
    assert!(matches!(
        read("ply.pcd", &ply),
        Err(Error::FormatMismatch { .. })
    ));
}

/// The error of `text` read as PCD, with its location.
fn refusal(bytes: &[u8]) -> (Error, String) {
    let error = read("bad.pcd", bytes).err().unwrap();
    let text = error.to_string();
    (error, text)
}

#[test]
fn damaged_files_are_refused_with_where_and_why() {
    let head = |fields: &str, size: &str, ty: &str, n: usize, data: &str| {
        format!(
            "VERSION 0.7\nFIELDS {fields}\nSIZE {size}\nTYPE {ty}\nCOUNT {}\nWIDTH {n}\n\
             HEIGHT 1\nPOINTS {n}\nDATA {data}\n",
            vec!["1"; fields.split(' ').count()].join(" ")
        )
        .into_bytes()
    };
    // No positions.
    let (_, text) = refusal(&head("x y intensity", "4 4 4", "F F F", 1, "ascii"));
    assert!(text.contains("no `z` field"), "{text}");
    // A binary header promising a million points over 12 bytes.
    let mut bytes = head("x y z", "4 4 4", "F F F", 1_000_000, "binary");
    bytes.extend_from_slice(&[0; 12]);
    assert!(matches!(
        refusal(&bytes).0,
        Error::HeaderExceedsFile {
            declared: 1_000_000,
            needed_bytes: 12_000_000,
            available_bytes: 12,
            ..
        }
    ));
    // ASCII: a line with a value short, a word that is no number, a line short.
    let mut bytes = head("x y z", "4 4 4", "F F F", 3, "ascii");
    let start = bytes.len() as u64;
    bytes.extend_from_slice(b"0 0 0\n1 1\n2.0 2 2\n");
    match refusal(&bytes).0 {
        Error::Malformed {
            location: Location::Byte(at),
            message,
            ..
        } => {
            assert_eq!(at, start + 6);
            assert!(message.contains("point 1: 2 values where the fields hold 3"));
        }
        other => panic!("{other:?}"),
    }
    let mut bytes = head("x y z", "4 4 4", "F F F", 1, "ascii");
    bytes.extend_from_slice(b"0 zero 0\n");
    assert!(
        refusal(&bytes)
            .1
            .contains("field `y`: `zero` is not a number")
    );
    let mut bytes = head("x y z", "4 4 4", "F F F", 2, "ascii");
    bytes.extend_from_slice(b"0.000000 0.000000 0.000000\n");
    assert!(matches!(refusal(&bytes).0, Error::UnexpectedEof { .. }));
    bytes.truncate(bytes.len() - 17);
    assert!(matches!(refusal(&bytes).0, Error::HeaderExceedsFile { .. }));
    // Compressed: sizes that do not fit the points, more than the file holds, more than
    // the compressed bytes expand to, and damaged data.
    let compressed = |sizes: (u32, u32), data: &[u8]| {
        let mut bytes = head("x y z", "4 4 4", "F F F", 2, "binary_compressed");
        bytes.extend_from_slice(&sizes.0.to_le_bytes());
        bytes.extend_from_slice(&sizes.1.to_le_bytes());
        bytes.extend_from_slice(data);
        bytes
    };
    assert!(refusal(&compressed((4, 20), &[0; 4])).1.contains("24"));
    assert!(matches!(
        refusal(&compressed((400, 24), &[0; 4])).0,
        Error::HeaderExceedsFile { .. }
    ));
    let mut bytes = head("x y z", "4 4 4", "F F F", 100, "binary_compressed");
    bytes.extend_from_slice(&1u32.to_le_bytes());
    bytes.extend_from_slice(&1200u32.to_le_bytes());
    bytes.push(0);
    assert!(
        refusal(&bytes).1.contains("cannot expand"),
        "{}",
        refusal(&bytes).1
    );
    let (error, text) = refusal(&compressed((4, 24), &[0, 1, 0x20, 9]));
    assert!(
        matches!(error, Error::Malformed { .. }) && text.contains("back"),
        "{text}"
    );
}

#[test]
fn what_pcd_cannot_hold_is_refused_before_writing() {
    let mesh = super::random_mesh(3, 6, 4);
    assert!(FileFormat::Pcd.check_can_store(true, DVec3::ZERO).is_err());
    assert!(matches!(
        io::encode_geometry(
            &Geometry::Mesh(mesh),
            FileFormat::Pcd,
            &WriteOptions::default()
        ),
        Err(Error::FormatCannotStore { .. })
    ));
    let named_rgb = PointSet::new(vec![Vec3::ZERO])
        .unwrap()
        .with_attribute(Attribute::new("rgb", vec![1.0]))
        .unwrap();
    let error = io::encode_geometry(
        &Geometry::Points(named_rgb),
        FileFormat::Pcd,
        &WriteOptions::default(),
    )
    .err()
    .unwrap();
    assert!(error.to_string().contains("attribute `rgb`"), "{error}");
    assert!(
        FileFormat::Pcd
            .unstored(&Geometry::Points(full_points()))
            .is_empty()
    );
}
