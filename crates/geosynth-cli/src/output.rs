//! Console output helpers: progress bars and status lines that respect `--quiet`.

use std::io::Write;
use std::path::{Path, PathBuf};

use geosynth::core::io::{self, FileFormat, GEOMETRY_EXTENSIONS, Geometry, WriteOptions};
use geosynth::{ProgressUpdate, RunContext};
use glam::DVec3;
use indicatif::{ProgressBar, ProgressStyle};

use crate::{CliError, CliResult, Globals};

/// Refuses to start work whose results could not be saved: the directory of every output
/// path must exist, no path may be given for two outputs (the second would overwrite the
/// first), an existing output must be replaceable (not read-only, not a folder:
/// [`io::check_replaceable`]), and geometry outputs need an extension the writers know
/// ([`GEOMETRY_EXTENSIONS`]). Checked before a run, so a typo does not cost the run; what
/// the format can hold is checked by [`check_geometry_output`] once the input is read.
pub(crate) fn check_output_paths<'a>(
    geometry: impl IntoIterator<Item = &'a Path>,
    other: impl IntoIterator<Item = &'a Path>,
) -> CliResult {
    let geometry: Vec<&Path> = geometry.into_iter().collect();
    for path in &geometry {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if FileFormat::from_extension(ext).is_none() {
            return Err(format!(
                "cannot write {}: geometry files must end in {GEOMETRY_EXTENSIONS}",
                path.display()
            )
            .into());
        }
    }
    let mut files: Vec<PathBuf> = Vec::new();
    for path in geometry.into_iter().chain(other) {
        let dir = match path.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir,
            _ => Path::new("."),
        };
        // The directory exists, so it has a canonical form: `a.ply`, `./a.ply` and
        // `d/../a.ply` are one file.
        let Some(name) = path.file_name() else {
            return Err(format!("cannot write {}: it names no file", path.display()).into());
        };
        let file = match dir.canonicalize() {
            Ok(dir) if dir.is_dir() => dir.join(name),
            _ => {
                return Err(format!(
                    "cannot write {}: the directory {} does not exist",
                    path.display(),
                    dir.display()
                )
                .into());
            }
        };
        if files.contains(&file) {
            return Err(format!(
                "cannot write {} twice: it is given for two of the outputs",
                path.display()
            )
            .into());
        }
        // An existing output the run could not replace (read-only, a folder) is named
        // now, not after the run.
        io::check_replaceable(path).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        files.push(file);
    }
    Ok(())
}

/// Writes `geometry` to `path` as [`io::write_geometry`] does; an error that does not name
/// the file (what its format cannot store, an encoder's failure) is told as `cannot write
/// FILE: …`, as [`check_geometry_output`] tells it before a run. What the format could not
/// store of it ([`FileFormat::unstored`]: normals in a LAS file, a quilt's patch labels in
/// an OBJ) is noted once it is written.
pub(crate) fn write_geometry_file(
    path: &Path,
    geometry: &Geometry,
    options: &WriteOptions,
    globals: Globals,
) -> CliResult {
    io::write_geometry(path, geometry, options).map_err(|error| {
        let message = error.to_string();
        if message.contains(&path.display().to_string()) {
            CliError::from(error)
        } else {
            format!("cannot write {}: {message}", path.display()).into()
        }
    })?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if let Some(format) = FileFormat::from_extension(ext) {
        let lost = format.unstored(geometry);
        if !lost.is_empty() {
            status(
                globals,
                format!(
                    "note: {}: {format} cannot store the {}; write .ply to keep them",
                    path.display(),
                    lost.join(", ")
                ),
            );
        }
    }
    Ok(())
}

/// Refuses, before the work, a geometry output whose format cannot hold what the command
/// will write there: a point set (`mesh` false), or data stored relative to a nonzero
/// `origin` (georeferenced input), as STL; a mesh as XYZ.
pub(crate) fn check_geometry_output(path: &Path, mesh: bool, origin: DVec3) -> CliResult {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    match FileFormat::from_extension(ext) {
        Some(format) => format
            .check_can_store(mesh, origin)
            .map_err(|e| format!("cannot write {}: {e}", path.display()).into()),
        None => Ok(()),
    }
}

/// Prints what the reader could not keep of `path`
/// ([`LoadedGeometry::notes`](geosynth::core::io::LoadedGeometry::notes)), one note a line.
pub(crate) fn report_not_kept(globals: Globals, path: &Path, notes: &[String]) {
    for note in notes {
        status(globals, format!("note: {}: {note}", path.display()));
    }
}

/// A progress bar over `total` steps, hidden with `--quiet` or when stderr is not a terminal.
pub(crate) fn progress_bar(globals: Globals, total: u64, label: &str) -> ProgressBar {
    let bar = styled_bar(globals, total, label, "{pos}/{len}");
    // The clock keeps running between updates: a long first step (a large exemplar's
    // preparation) would otherwise show a frozen 00:00:00.
    if !bar.is_hidden() {
        bar.enable_steady_tick(std::time::Duration::from_millis(500));
    }
    bar
}

/// A progress bar over `total` bytes, hidden with `--quiet` or when stderr is not a
/// terminal.
pub(crate) fn bytes_bar(globals: Globals, label: &str, total: u64) -> ProgressBar {
    styled_bar(globals, total, label, "{bytes}/{total_bytes}")
}

/// A bar labelled `label` over `total`, showing `counts` (an indicatif template part).
fn styled_bar(globals: Globals, total: u64, label: &str, counts: &str) -> ProgressBar {
    if globals.quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(total);
    let template = format!("{{msg:>12}} [{{bar:30}}] {counts} {{elapsed_precise}}");
    if let Ok(style) = ProgressStyle::with_template(&template) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(label.to_string());
    bar
}

/// Writes `line` to stdout. A reader that has gone away (`geosynth info x.ply | head -3`)
/// only wants no more output, so a broken pipe is not an error; other write errors are.
pub(crate) fn print_line(line: &str) -> std::io::Result<()> {
    match writeln!(std::io::stdout().lock(), "{line}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}

/// Prints a status line unless `--quiet`. Status lines are informational: failing to print
/// one does not stop the work.
pub(crate) fn status(globals: Globals, line: impl AsRef<str>) {
    if !globals.quiet {
        let _ = print_line(line.as_ref());
    }
}

/// A spinner for work without a known length, hidden with `--quiet`.
pub(crate) fn spinner(globals: Globals, label: impl Into<String>) -> ProgressBar {
    if globals.quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new_spinner();
    bar.set_message(label.into());
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}

/// A run context for `seed` whose progress reports drive a bar labelled `label` (hidden with
/// `--quiet`); with `show_stage`, the bar's label follows the reporting stage's name.
pub(crate) fn progress_context(
    globals: Globals,
    seed: u64,
    label: &str,
    show_stage: bool,
) -> (RunContext, ProgressBar) {
    let bar = progress_bar(globals, 1, label);
    let sink = bar.clone();
    let ctx = RunContext::new(seed).with_progress(move |u: &ProgressUpdate<'_>| {
        if let Some(total) = u.total {
            sink.set_length(total);
        }
        if show_stage {
            sink.set_message(u.stage.to_string());
        }
        sink.set_position(u.done);
    });
    (ctx, bar)
}
