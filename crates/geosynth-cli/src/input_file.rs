//! Errors met reading an input file, named by that file.
//!
//! The libraries' read errors say what is wrong ("position 1 is not finite", "NRRD
//! header: missing `spacings` field") but not always in which file: the caller knows the
//! path. A command given several files (`render a.ply b.ply`) or an exemplar and a pairs
//! file must say which one it could not read, so every input is read through [`named`].

use std::error::Error;
use std::fmt;
use std::path::{Path, PathBuf};

use geosynth::core::io::{self, LoadedGeometry, ReadOptions};
use geosynth::core::{ProgressUpdate, RunContext};
use indicatif::ProgressBar;

use crate::output::bytes_bar;
use crate::{CliResult, Globals};

/// The boxed error every command returns.
type BoxedError = Box<dyn Error + Send + Sync>;

/// An error met reading one input file, shown as `FILE: what went wrong`.
#[derive(Debug)]
pub(crate) struct InputFileError {
    /// The file being read.
    path: PathBuf,
    /// What went wrong.
    source: BoxedError,
}

impl fmt::Display for InputFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.source)
    }
}

impl Error for InputFileError {
    fn source(&self) -> Option<&(dyn Error + 'static)> {
        Some(&*self.source)
    }
}

/// Names `path` in the error of reading it, unless the message already names it (an I/O
/// error or an undecodable picture does).
pub(crate) fn named<E: Into<BoxedError>>(path: &Path) -> impl FnOnce(E) -> BoxedError + '_ {
    move |error| {
        let source = error.into();
        if source.to_string().contains(&path.display().to_string()) {
            source
        } else {
            Box::new(InputFileError {
                path: path.to_path_buf(),
                source,
            })
        }
    }
}

/// Reads a geometry file (PLY, OBJ, OFF, STL, XYZ, LAS, PCD) as every command does:
/// georeferenced coordinates relative to an origin, at full precision (see
/// [`ReadOptions::recentre_far`]); errors name the file. A file of [`SHOWN_READ_BYTES`] or
/// more shows a progress bar in bytes while it is read (none with `--quiet`).
pub(crate) fn read_geometry(path: &Path, globals: Globals) -> CliResult<LoadedGeometry> {
    let size = std::fs::metadata(path).map_or(0, |m| m.len());
    let bar = if size >= SHOWN_READ_BYTES {
        bytes_bar(globals, "reading", size)
    } else {
        ProgressBar::hidden()
    };
    let sink = bar.clone();
    let mut ctx = RunContext::new(0).with_progress(move |u: &ProgressUpdate<'_>| {
        if let Some(total) = u.total {
            sink.set_length(total);
        }
        sink.set_position(u.done);
    });
    let options = ReadOptions::default().recentre_far(true);
    let loaded = io::read_geometry_in(path, &options, &mut ctx).map_err(named(path));
    bar.finish_and_clear();
    loaded
}

/// The size from which reading a file shows its progress: 64 MiB, about half a second.
const SHOWN_READ_BYTES: u64 = 64 << 20;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_is_prefixed_with_its_file_once() {
        let path = Path::new("scans/b.ply");
        let named_error = named(path)("position 1 is not finite");
        assert_eq!(
            named_error.to_string(),
            "scans/b.ply: position 1 is not finite"
        );
        let cause = named_error.source().map(ToString::to_string);
        assert_eq!(cause.as_deref(), Some("position 1 is not finite"));

        let already = named(path)("cannot read scans/b.ply: no such file");
        assert_eq!(already.to_string(), "cannot read scans/b.ply: no such file");
        assert!(already.source().is_none());
    }
}
