//! Outputs are written whole or not at all (`FileReplacement`, `replace_file`,
//! `write_geometry`).

use std::io::Write;

use glam::Vec3;
use pointset_core::io::{self, FileReplacement, Geometry, WriteOptions, replace_file};
use pointset_core::{Attribute, Error, PointSet};

use crate::file_names::names;

/// A writer that fails after `bytes` bytes, as a full disk would.
fn failing_after(bytes: usize) -> impl FnOnce(&mut FileReplacement) -> std::io::Result<()> {
    move |out| {
        out.write_all(&vec![b'x'; bytes])?;
        out.flush()?;
        Err(std::io::Error::other("disk full"))
    }
}

#[test]
fn a_failed_write_keeps_the_old_file_and_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let old = dir.path().join("old.ply");
    std::fs::write(&old, "earlier run").unwrap();
    // Past the writer's buffer, so bytes have reached the temporary file.
    let result = replace_file(&old, failing_after(1 << 20), |e| e);
    assert_eq!(result.unwrap_err().to_string(), "disk full");
    assert_eq!(std::fs::read_to_string(&old).unwrap(), "earlier run");
    let new = dir.path().join("new.ply");
    assert!(replace_file(&new, failing_after(10), |e| e).is_err());
    assert!(!new.exists());
    assert_eq!(names(dir.path()), ["old.ply"]);
    // A writer dropped without committing removes its temporary file too.
    let mut out = FileReplacement::create(&new).unwrap();
    out.write_all(b"half").unwrap();
    assert_eq!(names(dir.path()).len(), 2);
    drop(out);
    assert_eq!(names(dir.path()), ["old.ply"]);
    // A successful write replaces the file.
    io::write_whole(&old, "this run").unwrap();
    assert_eq!(std::fs::read_to_string(&old).unwrap(), "this run");
    assert_eq!(names(dir.path()), ["old.ply"]);
}

#[test]
fn geometry_that_cannot_be_written_keeps_the_old_file() {
    // An attribute named like the UV properties is found while the PLY is laid out, after
    // the output was opened: the earlier file must survive.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mesh.ply");
    std::fs::write(&path, "earlier run").unwrap();
    let points = PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y])
        .unwrap()
        .with_attribute(Attribute::new("s", vec![0.0; 3]))
        .unwrap();
    let uvs = vec![glam::Vec2::ZERO; 3];
    let mesh = pointset_core::TriMesh::new(points, vec![[0, 1, 2]])
        .unwrap()
        .with_uvs(uvs)
        .unwrap();
    let result = io::write_geometry(&path, &Geometry::Mesh(mesh), &WriteOptions::default());
    assert!(
        matches!(result, Err(Error::IncompatibleLayout { .. })),
        "{result:?}"
    );
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "earlier run");
    assert_eq!(names(dir.path()), ["mesh.ply"]);
}

#[test]
fn a_folder_in_the_way_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("taken.ply");
    std::fs::create_dir(&folder).unwrap();
    let error = FileReplacement::create(&folder).unwrap_err();
    assert_eq!(error.kind(), std::io::ErrorKind::IsADirectory);
    // The same answer before a run, without touching anything; a new file passes.
    let error = io::check_replaceable(&folder).unwrap_err();
    assert_eq!(error.kind(), std::io::ErrorKind::IsADirectory);
    assert!(io::check_replaceable(&dir.path().join("new.ply")).is_ok());
    assert!(folder.is_dir());
}

#[cfg(unix)]
#[test]
fn permissions_and_links_are_kept_and_read_only_files_refused() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("shared.ply");
    std::fs::write(&path, "old").unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o640)).unwrap();
    replace_file(&path, |out| out.write_all(b"new"), |e| e).unwrap();
    let mode = std::fs::metadata(&path).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o640);
    // Through a link: the file it names is replaced, and the link stays a link.
    let link = dir.path().join("link.ply");
    std::os::unix::fs::symlink(&path, &link).unwrap();
    replace_file(&link, |out| out.write_all(b"through the link"), |e| e).unwrap();
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "through the link");
    // A read-only file is refused, even where the folder would allow the rename.
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o444)).unwrap();
    let error = FileReplacement::create(&path).unwrap_err();
    assert_eq!(error.kind(), std::io::ErrorKind::PermissionDenied);
    assert!(io::check_replaceable(&link).is_err());
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "through the link");
    assert_eq!(names(dir.path()), ["link.ply", "shared.ply"]);
}

/// A writer that takes `room` bytes, fails the next write as a full disk does, and then
/// takes everything again: a writer that wrote on after an error would leave a gap.
struct FailsOnceAt {
    taken: Vec<u8>,
    room: usize,
    failed: bool,
}

impl FailsOnceAt {
    fn new(room: usize) -> Self {
        FailsOnceAt {
            taken: Vec::new(),
            room,
            failed: false,
        }
    }
}

impl Write for FailsOnceAt {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        let n = if self.failed {
            bytes.len()
        } else {
            bytes.len().min(self.room - self.taken.len())
        };
        if n == 0 && !bytes.is_empty() {
            self.failed = true;
            return Err(std::io::Error::other("disk full"));
        }
        self.taken.extend_from_slice(&bytes[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// A writer of one format into any `Write`.
type Writer<'a> = Box<dyn Fn(&mut dyn Write) -> Result<(), Error> + 'a>;

#[test]
fn every_writer_reports_a_full_disk_and_writes_only_a_prefix() {
    // 8,100 vertices and 15,842 triangles: every encoding is longer than the writers'
    // 64 KiB buffer.
    let side = 90u32;
    let grid = (0..side * side)
        .map(|i| Vec3::new((i % side) as f32, (i / side) as f32, (i % 7) as f32 * 0.25))
        .collect();
    let points = PointSet::new(grid)
        .unwrap()
        .with_normals(vec![Vec3::Z; (side * side) as usize])
        .unwrap();
    let triangles = (0..side - 1)
        .flat_map(|r| (0..side - 1).map(move |c| r * side + c))
        .flat_map(|i| [[i, i + 1, i + side], [i + 1, i + side + 1, i + side]])
        .collect();
    let mesh = Geometry::Mesh(pointset_core::TriMesh::new(points.clone(), triangles).unwrap());
    let cloud = Geometry::Points(points.clone());
    let ply = io::ply::document_from_geometry(&mesh, io::ply::PlyEncoding::Ascii, &[]).unwrap();
    let writers: [(&str, Writer); 7] = [
        (
            "PLY",
            Box::new(|mut out| io::ply::write_ply(&ply, &mut out)),
        ),
        (
            "OBJ",
            Box::new(|mut out| io::write_obj(&mesh, &[], &mut out)),
        ),
        (
            "OFF",
            Box::new(|mut out| io::write_off(&mesh, &[], &mut out)),
        ),
        ("STL", Box::new(|mut out| io::write_stl(&mesh, &mut out))),
        (
            "ASCII STL",
            Box::new(|mut out| io::write_stl_ascii(&mesh, &mut out)),
        ),
        (
            "XYZ",
            Box::new(|mut out| io::write_xyz(&points, io::XyzColumns::Normals, &[], &mut out)),
        ),
        ("LAS", Box::new(|mut out| io::write_las(&cloud, &mut out))),
    ];
    for (format, write) in &writers {
        let mut whole = Vec::new();
        write(&mut whole).unwrap();
        assert!(whole.len() > 1 << 16, "{format}: {} bytes", whole.len());
        for room in [0, 100, whole.len() / 2, whole.len() - 1] {
            let mut out = FailsOnceAt::new(room);
            let error = write(&mut out).unwrap_err();
            assert!(
                matches!(&error, Error::Write { source } if source.to_string() == "disk full"),
                "{format}, room {room}: {error:?}"
            );
            assert_eq!(out.taken, whole[..room], "{format}, room {room}");
        }
        let mut out = FailsOnceAt::new(whole.len());
        write(&mut out).unwrap();
        assert_eq!(out.taken, whole, "{format}");
    }
}
