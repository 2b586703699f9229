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

use crate::CliResult;

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

/// Reads a geometry file (PLY, OBJ, OFF, STL, XYZ) as every command does: georeferenced
/// coordinates relative to an origin, at full precision (see
/// [`ReadOptions::recentre_far`]); errors name the file.
pub(crate) fn read_geometry(path: &Path) -> CliResult<LoadedGeometry> {
    io::read_geometry_with(path, &ReadOptions::default().recentre_far(true)).map_err(named(path))
}

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
