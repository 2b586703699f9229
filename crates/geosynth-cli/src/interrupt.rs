//! What Ctrl-C (`SIGINT`), `SIGTERM` and `SIGHUP` do to a run. Every output is written to
//! a temporary file beside it and renamed into place when whole
//! ([`io::FileReplacement`]); a signal's default action would leave that hidden
//! `.NAME.geosynth-PID-N.tmp` behind. Here a thread waits for the signals, removes the
//! unfinished files ([`io::abandon_replacements`]), says which outputs were not written,
//! and then ends the process as the signal's default action would, so that shells and
//! scripts see it killed by that signal (exit status 128 + its number). `SIGKILL` cannot
//! be caught, and still leaves the temporary file.
//!
//! Outputs already written stay; an output being written keeps what it held before the
//! run (or stays absent). Where no handler can be installed, or on platforms without these
//! signals, a run ends as it did before.

use std::sync::atomic::{AtomicBool, Ordering};

use geosynth::core::io;

/// Set once a signal's handler has begun: the run's own ending must then wait for it.
static STOPPING: AtomicBool = AtomicBool::new(false);

/// Starts the thread that handles the signals. Failing to start it changes nothing but
/// what a signal leaves behind, so a failure is not reported.
#[cfg(unix)]
pub(crate) fn install() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    let _ = std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                stop(signal);
            }
        });
}

/// Nothing to install where there are no such signals.
#[cfg(not(unix))]
pub(crate) fn install() {}

/// Called as the run ends, before its result is reported: if a signal came, the run's
/// outputs may have been refused because of it, so this waits for the signal's handler
/// to end the process rather than report those refusals (or success) in its place.
pub(crate) fn wait_if_stopping() {
    while STOPPING.load(Ordering::SeqCst) {
        std::thread::park();
    }
}

/// Removes the unfinished outputs, says so, and ends the process by `signal`.
#[cfg(unix)]
fn stop(signal: std::ffi::c_int) {
    use std::io::Write;
    STOPPING.store(true, Ordering::SeqCst);
    let abandoned = io::abandon_replacements();
    let name = signal_hook::low_level::signal_name(signal).unwrap_or("a signal");
    let mut stderr = std::io::stderr().lock();
    if !abandoned.is_empty() {
        // After the progress bar's line, and the terminal's `^C`.
        let _ = writeln!(stderr);
    }
    for output in abandoned {
        // The terminal may be gone (SIGHUP): nothing to do about a failed message.
        let _ = writeln!(
            stderr,
            "stopped by {name}: {} was not written (a file already there is unchanged)",
            output.display()
        );
    }
    drop(stderr);
    let _ = signal_hook::low_level::emulate_default_handler(signal);
    // Reached only if the default action could not be run.
    std::process::exit(128 + signal);
}
