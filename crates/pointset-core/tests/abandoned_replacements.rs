//! `abandon_replacements`: what a signal handler calls before the process ends. It cannot
//! be undone, so it has a test binary of its own (one test: `cargo test` runs the tests of
//! one binary in one process).

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::io::{ErrorKind, Write};

use pointset_core::io::{ABANDONED, FileReplacement, abandon_replacements, write_whole};

#[path = "shared/file_names.rs"]
mod file_names;

use file_names::names;

#[test]
fn abandoning_removes_unfinished_files_and_stops_every_later_replacement() {
    let dir = tempfile::tempdir().unwrap();
    let kept = dir.path().join("kept.ply");
    std::fs::write(&kept, "earlier run").unwrap();
    let done = dir.path().join("done.ply");
    let fresh = dir.path().join("fresh.ply");

    write_whole(&done, "committed before").unwrap();
    let mut replacing = FileReplacement::create(&kept).unwrap();
    // Past the writer's buffer, so bytes have reached the temporary file.
    replacing.write_all(&vec![b'x'; 1 << 20]).unwrap();
    let mut creating = FileReplacement::create(&fresh).unwrap();
    creating.write_all(b"new").unwrap();
    assert_eq!(
        names(dir.path()).len(),
        4,
        "two outputs and two temporary files"
    );

    let mut abandoned = abandon_replacements();
    abandoned.sort();
    assert_eq!(abandoned, [fresh.clone(), kept.clone()]);
    assert_eq!(names(dir.path()), ["done.ply", "kept.ply"]);

    // Nothing is replaced afterwards: the unfinished writers fail to commit, new ones
    // fail to start, and the outputs keep what they held.
    let refusals = [
        replacing.commit().unwrap_err(),
        creating.commit().unwrap_err(),
        FileReplacement::create(&fresh).unwrap_err(),
        write_whole(&done, "after").unwrap_err(),
    ];
    for refusal in refusals {
        assert_eq!(refusal.kind(), ErrorKind::Other);
        assert_eq!(refusal.to_string(), ABANDONED);
    }
    assert_eq!(std::fs::read_to_string(&kept).unwrap(), "earlier run");
    assert_eq!(std::fs::read_to_string(&done).unwrap(), "committed before");
    assert_eq!(names(dir.path()), ["done.ply", "kept.ply"]);
    // A second call finds nothing left.
    assert!(abandon_replacements().is_empty());
}
