//! Ctrl-C, `SIGTERM` and `SIGHUP` while an output is being written: the output keeps what
//! it held, no temporary file stays behind, and the process ends by the signal.

use std::os::unix::process::ExitStatusExt;
use std::process::{Command, Stdio};
use std::time::Duration;

use geosynth::core::PointSet;
use geosynth::core::io::Geometry;

use super::{Scratch, arg, write_with_defaults};

/// Points in the input: writing them as text keeps the temporary file open for about
/// 0.3 s in the test's build, a hundred times as long as sending the signal takes.
const POINTS: usize = 2_000_000;

#[test]
fn a_signal_while_writing_keeps_the_old_output_and_leaves_no_temporary_file() {
    let dir = Scratch::new();
    let input = dir.path("in.ply");
    let positions = (0..POINTS)
        .map(|i| glam::Vec3::new(i as f32, (i % 977) as f32, (i % 13) as f32))
        .collect();
    write_with_defaults(&input, &Geometry::Points(PointSet::new(positions).unwrap()));
    let out = dir.path("out.xyz");
    std::fs::write(&out, "earlier run").unwrap();

    for (signal, number) in [("INT", 2), ("TERM", 15), ("HUP", 1)] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_geosynth"))
            .args(["-q", "convert", &arg(&input), "-o", &arg(&out)])
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Wait for the temporary file beside the output, then signal.
        while !dir
            .names()
            .iter()
            .any(|n| n.starts_with(".out.xyz.geosynth-"))
        {
            let finished = child.try_wait().unwrap();
            assert!(
                finished.is_none(),
                "SIG{signal}: ended before writing: {finished:?}"
            );
            std::thread::sleep(Duration::from_millis(1));
        }
        let sent = Command::new("kill")
            .args(["-s", signal, &child.id().to_string()])
            .status()
            .unwrap();
        assert!(sent.success());
        let ended = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&ended.stderr);
        assert_eq!(ended.status.signal(), Some(number), "SIG{signal}: {stderr}");
        assert!(
            stderr.contains(&format!(
                "stopped by SIG{signal}: {} was not written",
                arg(&out)
            )),
            "{stderr}"
        );
        assert_eq!(dir.names(), ["in.ply", "out.xyz"], "SIG{signal}");
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "earlier run");
    }
    // Undisturbed, the same run replaces the output.
    super::ok(&["-q", "convert", &arg(&input), "-o", &arg(&out)]);
    let written = std::fs::read_to_string(&out).unwrap();
    let rows = written
        .lines()
        .filter(|line| !line.starts_with('#'))
        .count();
    assert_eq!(rows, POINTS);
}
