//! Files that `read_geometry` reads through a buffer instead of whole (PLY, binary STL,
//! LAS, OBJ, OFF, XYZ) give what their bytes give read from memory: the same geometry, or
//! the same error.

use glam::Vec3;
use pointset_core::io::ply::PlyEncoding;
use pointset_core::io::{self, FileFormat, Geometry, WriteOptions};
use pointset_core::{CancelFlag, Error, PointSet, ProgressUpdate, RunContext, TriMesh};

use super::ply_codec::geometry_with_parts;

/// `bytes` read by `read_geometry_with` from a file called `name` (read through a buffer)
/// and by `read_geometry_bytes_with` from memory, with errors as text.
pub(crate) fn read_from_file_and_bytes(
    name: &str,
    bytes: &[u8],
    recentre: bool,
) -> (
    Result<io::LoadedGeometry, String>,
    Result<io::LoadedGeometry, String>,
) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    let options = io::ReadOptions::default().recentre_far(recentre);
    (
        io::read_geometry_with(&path, &options).map_err(|e| e.to_string()),
        io::read_geometry_bytes_with(&path, bytes, &options).map_err(|e| e.to_string()),
    )
}

/// Each file, with and without recentring, read both ways: the same geometry or error,
/// and readable or not as the list says.
fn check_files(files: Vec<(&str, Vec<u8>, bool)>) {
    for (name, bytes, readable) in files {
        for recentre in [false, true] {
            let (from_file, from_bytes) = read_from_file_and_bytes(name, &bytes, recentre);
            assert_eq!(from_file.is_ok(), readable, "{name}: {from_file:?}");
            assert_eq!(from_file, from_bytes, "{name}, recentre {recentre}");
        }
    }
}

#[test]
fn ply_files_read_from_disk_equal_their_bytes_read_from_memory() {
    let mesh = geometry_with_parts(&[0.5, -1.0, 2.0, 3.5, 4.0, -0.25, 7.0], true, true, 2, 5);
    let mut files = Vec::new();
    for encoding in PlyEncoding::ALL {
        let options = WriteOptions::default().ply_encoding(encoding);
        let ply = io::encode_geometry(&mesh, FileFormat::Ply, &options).unwrap();
        // Behind a byte-order mark; longer than the bytes sniffed first; named as
        // another format, or as none.
        files.push((
            "mark.ply",
            [b"\xEF\xBB\xBF".as_slice(), &ply].concat(),
            true,
        ));
        let mut long = ply.clone();
        long.splice(
            4..4,
            b"comment "
                .iter()
                .chain(&[b'x'; 5000])
                .chain(b"\n")
                .copied(),
        );
        files.push(("long.ply", long, true));
        files.push(("named.obj", ply.clone(), false));
        files.push(("unnamed", ply.clone(), true));
        files.push(("cut.ply", ply[..ply.len() - 3].to_vec(), false));
    }
    // A binary STL whose 80-byte header starts like a PLY file is an STL by its size, and
    // the same with a byte-order mark before its header text.
    let stl = io::encode_geometry(&mesh, FileFormat::Stl, &WriteOptions::default()).unwrap();
    let mut like_ply = stl.clone();
    like_ply[..4].copy_from_slice(b"ply\n");
    files.push(("like_ply.stl", like_ply.clone(), true));
    files.push(("like_ply.ply", like_ply.clone(), false));
    files.push(("like_ply", like_ply, true));
    let mut marked = stl;
    marked[..7].copy_from_slice(b"\xEF\xBB\xBFply\n");
    files.push(("marked.stl", marked.clone(), true));
    files.push(("marked.ply", marked, false));
    check_files(files);
}

#[test]
fn stl_and_las_files_read_from_disk_equal_their_bytes_read_from_memory() {
    // 1,600 facets and 1,681 points: more than the 4 KiB sniffed before the rest is read.
    let side = 41u32;
    let grid: Vec<Vec3> = (0..side * side)
        .map(|i| Vec3::new((i % side) as f32, (i / side) as f32, (i % 5) as f32 * 0.5))
        .collect();
    let triangles = (0..side - 1)
        .flat_map(|r| (0..side - 1).map(move |c| r * side + c))
        .map(|i| [i, i + 1, i + side])
        .collect();
    let points = PointSet::new(grid).unwrap();
    let mesh = Geometry::Mesh(TriMesh::new(points.clone(), triangles).unwrap());
    let options = WriteOptions::default();
    let stl = io::encode_geometry(&mesh, FileFormat::Stl, &options).unwrap();
    let las = io::encode_geometry(&Geometry::Points(points), FileFormat::Las, &options).unwrap();
    let far = WriteOptions::default().origin(glam::DVec3::new(4e5, 5e6, 30.0));
    let far_las = io::encode_geometry(
        &Geometry::Points(PointSet::new(vec![Vec3::ONE; 300]).unwrap()),
        FileFormat::Las,
        &far,
    )
    .unwrap();
    let mut attributed = stl.clone();
    attributed[84 + 50 * 7 + 48] = 5;
    let mut not_finite = stl.clone();
    not_finite[84 + 50 * 3 + 24..84 + 50 * 3 + 28].copy_from_slice(&f32::INFINITY.to_le_bytes());
    let mut short_records = las.clone();
    short_records.truncate(las.len() - 7);
    let mut offset_past_end = las[..300].to_vec();
    offset_past_end[96..100].copy_from_slice(&400u32.to_le_bytes());
    offset_past_end[107..111].copy_from_slice(&0u32.to_le_bytes());
    let files: Vec<(&str, Vec<u8>, bool)> = vec![
        ("m.stl", stl.clone(), true),
        ("unnamed", stl.clone(), true),
        ("m.ply", stl.clone(), false),
        ("attributed.stl", attributed, true),
        ("not_finite.stl", not_finite, false),
        ("cut.stl", stl[..stl.len() - 50].to_vec(), false),
        ("p.las", las.clone(), true),
        ("far.las", far_las, true),
        (
            "mark.las",
            [b"\xEF\xBB\xBF".as_slice(), &las].concat(),
            true,
        ),
        ("unnamed", las.clone(), true),
        ("p.xyz", las.clone(), false),
        ("short.las", short_records, false),
        ("past_end.las", offset_past_end, false),
    ];
    check_files(files);
}

#[test]
fn text_files_read_from_disk_equal_their_bytes_read_from_memory() {
    let mesh = geometry_with_parts(&[0.5, -1.0, 2.0, 3.5, 4.0, -0.25, 7.0], true, true, 0, 5);
    let options = WriteOptions::default();
    let obj = io::encode_geometry(&mesh, FileFormat::Obj, &options).unwrap();
    let points = Geometry::Points(mesh.points().clone());
    let xyz =
        io::encode_geometry(&points, FileFormat::Xyz(io::XyzColumns::Normals), &options).unwrap();
    let crlf = |text: &[u8]| {
        String::from_utf8_lossy(text)
            .replace('\n', "\r\n")
            .into_bytes()
    };
    // Comments longer than the bytes sniffed before the rest is read.
    let long = |text: &[u8]| [format!("# {}\n", "c".repeat(5000)).as_bytes(), text].concat();
    let bad_text = |text: &[u8]| [text, b"\xff\xfe\n"].concat();
    let mark = |text: &[u8]| [b"\xEF\xBB\xBF".as_slice(), text].concat();
    let stl_options = WriteOptions::default().stl_encoding(io::StlEncoding::Ascii);
    let stl = io::encode_geometry(&mesh, FileFormat::Stl, &stl_options).unwrap();
    let late = stl.len() - 20;
    let with_byte = |at: usize, byte: u8| {
        let mut text = stl.clone();
        text[at] = byte;
        text
    };
    let syntax_then = |byte: u8| {
        let mut text = with_byte(late, byte);
        let at = 40 + text[40..].iter().position(|&b| b == b'v').unwrap();
        text[at] = b'w';
        text
    };
    let blank = [vec![b' '; 5000], stl.clone()].concat();
    let off = io::encode_geometry(&mesh, FileFormat::Off, &options).unwrap();
    let off_comment = [off.as_slice(), b"# after the faces\n"].concat();
    let off_huge = b"OFF\n1000000000 0 0\n0 0 0\n".to_vec();
    let files: Vec<(&str, Vec<u8>, bool)> = vec![
        // ASCII STL: a NUL byte anywhere makes the file binary (of the wrong size), and
        // text that is not UTF-8 anywhere is refused before what the text says.
        ("a.stl", stl.clone(), true),
        ("mark.stl", mark(&stl), true),
        ("crlf.stl", crlf(&stl), true),
        ("nul.stl", with_byte(late, 0), false),
        ("syntax_nul.stl", syntax_then(0), false),
        ("syntax_not_text.stl", syntax_then(0xff), false),
        ("blank.stl", blank, true),
        ("cut.stl", stl[..stl.len() / 2].to_vec(), false),
        ("m.off", off.clone(), true),
        ("unnamed", off.clone(), true),
        ("crlf.off", crlf(&off), true),
        ("long.off", long(&off), true),
        ("mark.off", mark(&off), true),
        ("comment.off", off_comment, true),
        ("bad.off", bad_text(&off), false),
        ("cut.off", off[..off.len() - 9].to_vec(), false),
        ("huge.off", off_huge, false),
        ("m.obj", obj.clone(), true),
        ("unnamed", obj.clone(), true),
        ("m.ply", obj.clone(), false),
        ("crlf.obj", crlf(&obj), true),
        ("long.obj", long(&obj), true),
        ("mark.obj", mark(&obj), true),
        ("bad.obj", bad_text(&obj), false),
        // The last corner loses its texture coordinate and normal: read without them.
        ("cut.obj", obj[..obj.len() - 4].to_vec(), true),
        ("p.xyzn", xyz.clone(), true),
        ("p.xyz", xyz.clone(), true),
        // Normals named as colours are read as colours: the name decides.
        ("p.xyzrgb", xyz.clone(), true),
        ("crlf.xyzn", crlf(&xyz), true),
        ("long.xyzn", long(&xyz), true),
        ("mark.xyzn", mark(&xyz), true),
        ("bad.xyzn", bad_text(&xyz), false),
        ("unnamed", xyz.clone(), false),
    ];
    check_files(files);
}

#[test]
fn long_reads_report_their_progress_and_stop_when_cancelled() {
    // 5 MB of XYZ: the head sniffed first, then reads of a megabyte.
    let text: String = (0..400_000)
        .map(|i| format!("{i} {} 0.5\n", i % 7))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("long.xyz");
    std::fs::write(&path, &text).unwrap();
    let len = text.len() as u64;
    let (sender, reports) = std::sync::mpsc::channel();
    let mut ctx = RunContext::new(0).with_progress(move |u: &ProgressUpdate<'_>| {
        sender.send((u.stage.to_string(), u.done, u.total)).unwrap();
    });
    let loaded = io::read_geometry_in(&path, &io::ReadOptions::default(), &mut ctx).unwrap();
    assert_eq!(loaded.geometry.points().len(), 400_000);
    let reports: Vec<(String, u64, Option<u64>)> = reports.try_iter().collect();
    assert!(reports.len() >= 6, "{reports:?}");
    assert!(
        reports
            .iter()
            .all(|(stage, _, total)| stage == "reading" && *total == Some(len))
    );
    assert!(reports.windows(2).all(|w| w[0].1 <= w[1].1), "{reports:?}");
    assert_eq!(reports.last().map(|r| r.1), Some(len));
    // Cancelled once more than a megabyte is in: the read stops at the next megabyte.
    let cancel = CancelFlag::new();
    let trigger = cancel.clone();
    let (sender, reports) = std::sync::mpsc::channel();
    let mut ctx =
        RunContext::new(0)
            .with_cancel_flag(cancel)
            .with_progress(move |u: &ProgressUpdate<'_>| {
                if u.done > 1 << 20 {
                    trigger.cancel();
                }
                sender.send(u.done).unwrap();
            });
    let result = io::read_geometry_in(&path, &io::ReadOptions::default(), &mut ctx);
    assert!(matches!(result, Err(Error::Cancelled)), "{result:?}");
    let last = reports.try_iter().last().unwrap();
    assert!(last > 1 << 20 && last <= 2 << 20 && last < len, "{last}");
}
