//! Outputs where the user may write the file but not its folder (no temporary file can be
//! made beside it: written in place), and another user's file in a folder the user may
//! write (refused before the run). Root ignores permissions, so as root the runs drop to
//! the user `nobody` through `setpriv`; where that cannot be done the test says so and
//! checks what it can.

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use super::{Scratch, arg};

/// The user and group ids of `nobody`.
const NOBODY: &str = "65534";

/// Whether this process is root (`id -u` says 0).
fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

/// A command running `geosynth` as a user permissions apply to: this one, or, as root,
/// `nobody` through `setpriv`. `None` as root where `setpriv` cannot run it.
fn unprivileged_geosynth() -> Option<Command> {
    let binary = env!("CARGO_BIN_EXE_geosynth");
    if !is_root() {
        return Some(Command::new(binary));
    }
    let as_nobody = || {
        let mut command = Command::new("setpriv");
        command.args([
            "--reuid",
            NOBODY,
            "--regid",
            NOBODY,
            "--clear-groups",
            binary,
        ]);
        command
    };
    let probe = as_nobody().arg("--version").output();
    if probe.as_ref().is_ok_and(|o| o.status.success()) {
        Some(as_nobody())
    } else {
        eprintln!("skipped: as root, and `setpriv` cannot run geosynth as nobody: {probe:?}");
        None
    }
}

/// Sets `path`'s permission bits.
fn set_mode(path: &Path, mode: u32) {
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
}

/// A scratch folder of mode `mode` holding a fixture point set everyone may read.
fn folder_with_input(mode: u32) -> (Scratch, PathBuf) {
    let dir = Scratch::new();
    set_mode(dir.0.path(), mode);
    let input = dir.path("in.ply");
    let fixture = geosynth::fixtures::bundled_dir().join("sphere_points.ply");
    std::fs::copy(fixture, &input).unwrap();
    set_mode(&input, 0o644);
    (dir, input)
}

/// Runs `command` with `args`.
fn run(mut command: Command, args: &[&str]) -> Output {
    command.args(args).output().unwrap()
}

#[test]
fn a_folder_the_user_may_not_write_gets_its_output_in_place() {
    let Some(geosynth) = unprivileged_geosynth() else {
        return;
    };
    let (dir, input) = folder_with_input(0o755);
    let locked = dir.path("locked");
    std::fs::create_dir(&locked).unwrap();
    let out = locked.join("out.xyz");
    std::fs::write(&out, "earlier run").unwrap();
    set_mode(&out, 0o666);
    set_mode(&locked, 0o555);

    let ran = run(geosynth, &["-q", "convert", &arg(&input), "-o", &arg(&out)]);
    let stderr = String::from_utf8_lossy(&ran.stderr);
    assert!(ran.status.success(), "{stderr}");
    let written = std::fs::read_to_string(&out).unwrap();
    let rows = written
        .lines()
        .filter(|line| !line.starts_with('#'))
        .count();
    assert_eq!(
        rows, 2000,
        "the fixture's points, written over the old file"
    );
    let names: Vec<_> = std::fs::read_dir(&locked)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["out.xyz"], "no temporary file was made");
    // The file is the same one, written through: its mode is as it was.
    assert_eq!(
        std::fs::metadata(&out).unwrap().permissions().mode() & 0o777,
        0o666
    );
    set_mode(&locked, 0o755);
}

#[test]
fn another_users_file_is_refused_before_the_run() {
    if !is_root() {
        eprintln!("skipped: needs a file of another user, which only root can make");
        return;
    }
    let Some(geosynth) = unprivileged_geosynth() else {
        return;
    };
    // A folder anyone may write, holding root's file that only root may write.
    let (dir, input) = folder_with_input(0o777);
    let out = dir.path("roots.xyz");
    std::fs::write(&out, "root's").unwrap();
    set_mode(&out, 0o644);

    let ran = run(geosynth, &["-q", "convert", &arg(&input), "-o", &arg(&out)]);
    let stderr = String::from_utf8_lossy(&ran.stderr);
    assert!(!ran.status.success(), "{stderr}");
    assert!(
        stderr.contains(&format!("cannot write {}", arg(&out))),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "root's");
    assert_eq!(dir.names(), ["in.ply", "roots.xyz"]);
}
