//! XYZ point clouds: round trips of each column layout, files as other tools write them,
//! and every refusal with its line.

use glam::Vec3;
use pointset_core::io::{self, FileFormat, Geometry, WriteOptions, XyzColumns};
use pointset_core::{Attribute, Error, PointSet};

use super::{random_mesh, read};

/// Points with normals, colours and an attribute, at awkward coordinates.
pub(super) fn full_points() -> PointSet {
    let vertices = random_mesh(21, 30, 0).vertices().clone();
    let n = vertices.len();
    let normals = (0..n)
        .map(|i| Vec3::new(i as f32, 1.0, -0.3).normalize())
        .collect();
    let mut points = vertices.with_normals(normals).unwrap();
    let colours: Vec<[f32; 3]> = (0..n)
        .map(|i| [i as f32 / n as f32, 0.5, 1.0 / 3.0])
        .collect();
    points.set_colors(&colours).unwrap();
    points
        .set_attribute(Attribute::new("quality", vec![0.25; n]))
        .unwrap();
    points
}

#[test]
fn each_layout_round_trips_what_it_holds_exactly_and_names_what_it_drops() {
    let points = full_points();
    let geometry = Geometry::Points(points.clone());
    for (name, normals, colours) in [
        ("p.xyz", true, false),
        ("p.xyzn", true, false),
        ("p.xyzrgb", false, true),
    ] {
        let format = FileFormat::from_extension(&name[2..]).unwrap();
        let options = WriteOptions::default().comment("made by a test");
        let bytes = io::encode_geometry(&geometry, format, &options).unwrap();
        let back = read(name, &bytes).unwrap();
        assert_eq!(back.format, format);
        assert_eq!(back.comments, ["made by a test"]);
        let got = back.geometry.points();
        assert_eq!(format.stores_normals(), got.normals().is_some(), "{name}");
        // Positions, normals and colours are written in their shortest exact form.
        assert_eq!(got.positions(), points.positions(), "{name}");
        assert_eq!(
            got.normals(),
            normals.then(|| points.normals().unwrap()),
            "{name}"
        );
        assert_eq!(
            got.colors(),
            colours.then(|| points.colors().unwrap()),
            "{name}"
        );
        let mut lost = vec!["attribute `quality`".to_string()];
        if !normals {
            lost.insert(0, "vertex normals".into());
        }
        if !colours {
            lost.insert(lost.len() - 1, "colours".into());
        }
        assert_eq!(format.unstored(&geometry), lost, "{name}");
    }
    // Positions alone: three numbers a line.
    let bare = Geometry::Points(PointSet::new(points.positions().to_vec()).unwrap());
    let format = FileFormat::from_extension("xyz").unwrap();
    let bytes = io::encode_geometry(&bare, format, &WriteOptions::default()).unwrap();
    let text = String::from_utf8(bytes.clone()).unwrap();
    assert!(text.lines().all(|l| l.split(' ').count() == 3), "{text}");
    assert_eq!(read("p.xyz", &bytes).unwrap().geometry, bare);
}

#[test]
fn files_as_other_tools_write_them_are_read() {
    // CloudCompare: a `//` header of column names, commas; MeshLab: spaces, normals;
    // numpy's savetxt: exponents, tabs; Windows line ends; a blank line at the end.
    let cases: [(&str, &str, usize, bool); 4] = [
        (
            "cc.xyz",
            "//X,Y,Z,Nx,Ny,Nz\n1.5,2,3,0,0,1\n-1,0,0.25,1,0,0\n",
            2,
            true,
        ),
        (
            "ml.xyz",
            "0 0 0 0 1 0\n1 1 1 0 0 -1\n2 2 2 1 0 0\n",
            3,
            true,
        ),
        (
            "np.xyz",
            "# x y z\n1.000000000000000000e+00\t2.5e-01\t-3e2\n\n",
            1,
            false,
        ),
        ("win.xyzn", "1 2 3 0 0 1\r\n4 5 6 0 1 0\r\n", 2, true),
    ];
    for (name, text, count, normals) in cases {
        let loaded = read(name, text.as_bytes()).unwrap();
        let points = loaded.geometry.points();
        assert_eq!(points.len(), count, "{name}");
        assert_eq!(points.normals().is_some(), normals, "{name}");
    }
    let np = read("np.xyz", cases[2].1.as_bytes()).unwrap();
    assert_eq!(
        np.geometry.points().positions(),
        [Vec3::new(1.0, 0.25, -300.0)]
    );
    // Colours as integers 0..=255 (any value above 1) or floats 0..=1 (kept in 8 bits).
    for (text, red) in [("0 0 0 255 0 51\n", 1.0), ("0 0 0 0.5 0 0.2\n", 0.5)] {
        let colours = read("c.xyzrgb", text.as_bytes())
            .unwrap()
            .geometry
            .points()
            .colors()
            .unwrap();
        assert!(
            (colours[0][0] - red).abs() <= 1.0 / 255.0,
            "{text}: {colours:?}"
        );
    }
    // Only comments: no points, not an error.
    let empty = read("e.xyz", b"# nothing scanned\n").unwrap();
    assert_eq!(empty.geometry.points().len(), 0);
}

#[test]
fn bad_lines_are_refused_with_their_number() {
    let cases = [
        ("a.xyz", "0 0 0\n1 1\n", "line 2", "2 numbers"),
        (
            "b.xyz",
            "0 0 0 1\n",
            "line 1",
            "`x y z` or `x y z nx ny nz`",
        ),
        (
            "c.xyz",
            "0 0 0\n# fine\n1 1 1 0 0 1\n",
            "line 3",
            "where the first point's line has 3",
        ),
        ("d.xyzn", "0 0 0\n", "line 1", "`x y z nx ny nz`"),
        (
            "e.xyz",
            "0 0 0\n1 two 3\n",
            "line 2",
            "`two` is not a number",
        ),
        ("f.xyzrgb", "0 0 0 1 1 1 1\n", "line 1", "`x y z r g b`"),
        // CloudCompare's colours in a file named .xyz: not normals.
        (
            "g.xyz",
            "0 0 0 0 0 1\n1 1 1 255 0 51\n",
            "line 2",
            "name the file .xyzrgb",
        ),
    ];
    for (name, text, line, what) in cases {
        let err = read(name, text.as_bytes()).unwrap_err();
        let message = err.to_string();
        assert!(matches!(err, Error::Malformed { .. }), "{name}: {message}");
        assert!(
            message.contains(line) && message.contains(what),
            "{name}: {message}"
        );
    }
    // Non-finite numbers parse, and are refused as points.
    let err = read("n.xyz", b"0 0 0\nnan 0 0\n").unwrap_err();
    assert!(
        err.to_string().contains("position 1 is not finite"),
        "{err}"
    );
    let err = read("i.xyzn", b"0 0 0 inf 0 0\n").unwrap_err();
    assert!(err.to_string().contains("normal 0 is not finite"), "{err}");
    // Binary content is no XYZ text.
    let err = read("b.xyz", &[0x30, 0x20, 0xff, 0xfe, 0x0a]).unwrap_err();
    assert!(err.to_string().contains("not valid UTF-8"), "{err}");
}

#[test]
fn what_a_layout_cannot_hold_is_refused_before_writing() {
    let mesh = Geometry::Mesh(random_mesh(3, 8, 6));
    let xyz = FileFormat::Xyz(XyzColumns::Positions);
    assert!(xyz.check_can_store(true, glam::DVec3::ZERO).is_err());
    let err = io::encode_geometry(&mesh, xyz, &WriteOptions::default()).unwrap_err();
    assert!(err.to_string().contains("a mesh's faces"), "{err}");
    let bare = Geometry::Points(PointSet::new(vec![Vec3::ZERO]).unwrap());
    for (columns, what) in [
        (XyzColumns::Normals, "without normals"),
        (XyzColumns::Colours, "without colours"),
    ] {
        let err = io::encode_geometry(&bare, FileFormat::Xyz(columns), &WriteOptions::default())
            .unwrap_err();
        assert!(matches!(err, Error::FormatCannotStore { .. }), "{err}");
        assert!(err.to_string().contains(what), "{err}");
    }
}
