//! Files written whole or not at all: the bytes go to a temporary file beside the output,
//! which takes the output's place only once everything is written and flushed. A run that
//! fails while writing (a full disk, an error found halfway) leaves the output as it was:
//! an earlier file of that name keeps its bytes, and no truncated file appears. Writers
//! can then stream to the file without first checking or encoding everything in memory.
//!
//! The replacement keeps an existing output's permissions, refuses one that could not be
//! opened for writing (and a read-only one, even where the user could), and writes
//! through a symbolic link to the file it names. Where no temporary file can be made
//! beside the output (a folder the user may not write, but a file they may), and where
//! the output is not a regular file (a device such as `/dev/null`, a pipe), it is written
//! in place, as before. A process killed while writing leaves its temporary file
//! (`.NAME.geosynth-PID-N.tmp`) behind, and the output untouched, unless something
//! calls [`abandon_replacements`] before the process ends (the `geosynth` tool does on
//! Ctrl-C, `SIGTERM` and `SIGHUP`; nothing can on `SIGKILL`).
//!
//! Unlike writing in place, a replaced file is a new file: other hard links to the old
//! one keep the old bytes, its owner is the writing user, extended attributes are not
//! carried over, and the disk holds the old and the new file until the rename. The new
//! file is flushed, not synced to the disk, before the rename: a failed run cannot lose
//! the old file, but a power cut soon after may still lose both.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, ErrorKind, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// Numbers the temporary files this process makes, so threads never share one.
static NEXT_TEMPORARY: AtomicU64 = AtomicU64::new(0);

/// The replacements of this process that are neither committed nor dropped yet, and
/// whether [`abandon_replacements`] has been called.
static UNFINISHED: Mutex<Unfinished> = Mutex::new(Unfinished {
    replacements: Vec::new(),
    abandoned: false,
});

/// What [`UNFINISHED`] holds.
struct Unfinished {
    /// Each unfinished replacement's temporary file and target.
    replacements: Vec<(PathBuf, PathBuf)>,
    abandoned: bool,
}

impl Unfinished {
    /// The registry, locked. A thread that panicked holding it left it consistent (every
    /// change is one push, removal or assignment), so a poisoned lock is taken as it is.
    fn lock() -> MutexGuard<'static, Unfinished> {
        UNFINISHED.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// An error ([`ABANDONED`]) once the replacements were abandoned. Not
    /// `ErrorKind::Interrupted`, which callers may retry.
    fn check_open(&self) -> std::io::Result<()> {
        if self.abandoned {
            return Err(std::io::Error::other(ABANDONED));
        }
        Ok(())
    }

    /// Forgets `temporary` (made by this process), if it is listed.
    fn forget(&mut self, temporary: &Path) {
        self.replacements.retain(|(listed, _)| listed != temporary);
    }
}

/// What [`FileReplacement::create`] and [`FileReplacement::commit`] fail with (as an
/// [`ErrorKind::Other`] error) after [`abandon_replacements`].
pub const ABANDONED: &str = "the process is stopping: its unfinished files were removed";

/// Removes the temporary file of every [`FileReplacement`] of this process that is not
/// yet committed or dropped, and makes every later replacement through a temporary file
/// fail ([`FileReplacement::create`] and [`FileReplacement::commit`] return an
/// [`ErrorKind::Other`] error saying [`ABANDONED`]), so that no output is replaced
/// afterwards. Returns the outputs whose temporary files it removed: they keep what they
/// held, or stay absent.
///
/// Meant for the handler of a signal that ends the process (Ctrl-C), so that no
/// temporary file stays behind; there is no undoing it. A commit that has begun renaming
/// finishes first, and its output is whole. Files written in place (devices, pipes, an
/// output in a folder the user may not write) have no temporary file and are left as
/// they are.
///
/// ```no_run
/// // In a handler of Ctrl-C, just before the process ends:
/// for output in pointset_core::io::abandon_replacements() {
///     eprintln!("stopped: {} was not written", output.display());
/// }
/// std::process::exit(130);
/// ```
pub fn abandon_replacements() -> Vec<PathBuf> {
    let mut unfinished = Unfinished::lock();
    unfinished.abandoned = true;
    std::mem::take(&mut unfinished.replacements)
        .into_iter()
        .filter(|(temporary, _)| std::fs::remove_file(temporary).is_ok())
        .map(|(_, target)| target)
        .collect()
}

/// A file being written to replace `target` as a whole; see the module docs. Dropped
/// without [`FileReplacement::commit`], it removes its temporary file and leaves the
/// target alone.
#[derive(Debug)]
pub struct FileReplacement {
    file: BufWriter<File>,
    /// The temporary file, or `None` when writing the target in place.
    temporary: Option<PathBuf>,
    /// The file replaced (a symbolic link's target).
    target: PathBuf,
}

impl FileReplacement {
    /// Starts writing a replacement for `path`. Fails as creating `path` would: a missing
    /// folder, a read-only file, a folder in its place.
    ///
    /// ```
    /// use std::io::Write;
    /// use pointset_core::io::FileReplacement;
    ///
    /// let dir = tempfile::tempdir()?;
    /// let path = dir.path().join("out.txt");
    /// std::fs::write(&path, "old")?;
    /// let mut out = FileReplacement::create(&path)?;
    /// out.write_all(b"new")?;
    /// drop(out); // not committed: the old file stays
    /// assert_eq!(std::fs::read_to_string(&path)?, "old");
    /// let mut out = FileReplacement::create(&path)?;
    /// out.write_all(b"new")?;
    /// out.commit()?;
    /// assert_eq!(std::fs::read_to_string(&path)?, "new");
    /// # Ok::<(), std::io::Error>(())
    /// ```
    pub fn create(path: &Path) -> std::io::Result<Self> {
        let target = followed_link(path);
        let existing = existing_output(&target)?;
        if !replaced(existing.as_ref()) {
            return Self::in_place(target);
        }
        let temporary = temporary_path(&target);
        // Made and listed under one lock, so that abandoning never misses a file.
        let mut unfinished = Unfinished::lock();
        unfinished.check_open()?;
        match OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temporary)
        {
            Ok(file) => {
                let listed = (temporary.clone(), target.clone());
                unfinished.replacements.push(listed);
                drop(unfinished);
                let replacement = FileReplacement {
                    file: BufWriter::new(file),
                    temporary: Some(temporary),
                    target,
                };
                if let Some(metadata) = existing {
                    // On failure the replacement is dropped, which removes the file.
                    replacement
                        .file
                        .get_ref()
                        .set_permissions(metadata.permissions())?;
                }
                Ok(replacement)
            }
            Err(e) if e.kind() == ErrorKind::PermissionDenied && existing.is_some() => {
                drop(unfinished);
                Self::in_place(target)
            }
            Err(e) => Err(e),
        }
    }

    /// Writes `target` itself, truncated first.
    fn in_place(target: PathBuf) -> std::io::Result<Self> {
        Ok(FileReplacement {
            file: BufWriter::new(File::create(&target)?),
            temporary: None,
            target,
        })
    }

    /// Flushes the written bytes and puts them in the target's place.
    /// Fails ([`ABANDONED`]), leaving the target as it was, once [`abandon_replacements`]
    /// has been called.
    pub fn commit(mut self) -> std::io::Result<()> {
        self.file.flush()?;
        let Some(temporary) = self.temporary.take() else {
            return Ok(());
        };
        // Renamed under the lock, so that abandoning waits for a rename begun.
        let mut unfinished = Unfinished::lock();
        unfinished.forget(&temporary);
        let renamed = unfinished
            .check_open()
            .and_then(|()| std::fs::rename(&temporary, &self.target));
        if renamed.is_err() {
            // Not renamed: the temporary file must not stay behind.
            let _ = std::fs::remove_file(&temporary);
        }
        renamed
    }
}

impl Write for FileReplacement {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.write(buf)
    }

    fn write_all(&mut self, buf: &[u8]) -> std::io::Result<()> {
        self.file.write_all(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

impl Seek for FileReplacement {
    fn seek(&mut self, position: SeekFrom) -> std::io::Result<u64> {
        self.file.seek(position)
    }
}

impl Drop for FileReplacement {
    fn drop(&mut self) {
        if let Some(temporary) = self.temporary.take() {
            Unfinished::lock().forget(&temporary);
            // Nothing to report to: the write already failed, and the target is untouched.
            let _ = std::fs::remove_file(&temporary);
        }
    }
}

/// Checks, without changing anything, that [`FileReplacement::create`] would accept
/// `path` as it stands now: an error for a folder in its place, a read-only file, or a
/// file this process may not open for writing. A missing file passes (its folder is
/// checked when it is written). Long runs call it before they start, so that their
/// results are not lost to an output that cannot be written.
pub fn check_replaceable(path: &Path) -> std::io::Result<()> {
    existing_output(&followed_link(path)).map(|_| ())
}

/// The metadata of the existing file `target`, or `None`; an error where it may not be
/// replaced.
fn existing_output(target: &Path) -> std::io::Result<Option<std::fs::Metadata>> {
    let metadata = match std::fs::metadata(target) {
        Ok(metadata) => metadata,
        Err(e) if e.kind() == ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e),
    };
    if metadata.is_dir() {
        return Err(std::io::Error::new(
            ErrorKind::IsADirectory,
            "a folder has that name",
        ));
    }
    if metadata.permissions().readonly() {
        return Err(std::io::Error::new(
            ErrorKind::PermissionDenied,
            "the file is read-only",
        ));
    }
    // Refused where writing it in place would be (another user's file in a folder this
    // one may write): opened, not truncated, and closed again.
    OpenOptions::new().write(true).open(target)?;
    Ok(Some(metadata))
}

/// Writes `path` as a whole through `write` (see [`FileReplacement`]): on any error,
/// `write`'s or the disk's, `path` keeps what it held. `io_error` turns the file's own
/// errors into the caller's.
pub fn replace_file<E>(
    path: &Path,
    write: impl FnOnce(&mut FileReplacement) -> Result<(), E>,
    io_error: impl Fn(std::io::Error) -> E,
) -> Result<(), E> {
    let mut out = FileReplacement::create(path).map_err(&io_error)?;
    write(&mut out)?;
    out.commit().map_err(io_error)
}

/// `std::fs::write`, whole or not at all: `contents` replace `path`'s only once they are
/// all written ([`FileReplacement`]).
pub fn write_whole(path: &Path, contents: impl AsRef<[u8]>) -> std::io::Result<()> {
    replace_file(path, |out| out.write_all(contents.as_ref()), |e| e)
}

/// Whether an output with this metadata (`None`: none yet) is replaced through a
/// temporary file: a regular file or a new one is; a device or a pipe (`/dev/null`,
/// `/dev/stdout`) is written in place, never replaced.
fn replaced(existing: Option<&std::fs::Metadata>) -> bool {
    existing.is_none_or(std::fs::Metadata::is_file)
}

/// The file a symbolic link at `path` names (followed to the end), or `path` itself.
fn followed_link(path: &Path) -> PathBuf {
    let is_link = std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink());
    if is_link && let Ok(resolved) = std::fs::canonicalize(path) {
        return resolved;
    }
    path.to_path_buf()
}

/// A fresh hidden name beside `target`.
fn temporary_path(target: &Path) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let number = NEXT_TEMPORARY.fetch_add(1, Ordering::Relaxed);
    target.with_file_name(format!(
        ".{name}.geosynth-{}-{number}.tmp",
        std::process::id()
    ))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn only_regular_files_are_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("f");
        std::fs::write(&file, "x").unwrap();
        assert!(replaced(None));
        assert!(replaced(Some(&std::fs::metadata(&file).unwrap())));
        // Read, never written: a device must not be renamed over.
        if let Ok(device) = std::fs::metadata("/dev/null") {
            assert!(!replaced(Some(&device)));
        }
    }
}
