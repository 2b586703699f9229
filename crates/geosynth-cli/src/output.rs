//! Console output helpers: progress bars and status lines that respect `--quiet`.

use indicatif::{ProgressBar, ProgressStyle};

use crate::Globals;

/// A progress bar over `total` steps, hidden with `--quiet` or when stderr is not a terminal.
pub(crate) fn progress_bar(globals: Globals, total: u64, label: &str) -> ProgressBar {
    if globals.quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(total);
    if let Ok(style) =
        ProgressStyle::with_template("{msg:>12} [{bar:30}] {pos}/{len} {elapsed_precise}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(label.to_string());
    bar
}

/// Prints a status line unless `--quiet`.
pub(crate) fn status(globals: Globals, line: impl AsRef<str>) {
    if !globals.quiet {
        println!("{}", line.as_ref());
    }
}

/// A spinner for work without a known length, hidden with `--quiet`.
pub(crate) fn spinner(globals: Globals, label: &str) -> ProgressBar {
    if globals.quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new_spinner();
    bar.set_message(label.to_string());
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}
