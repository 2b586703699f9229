//! A file reader that reports how far it has read to a [`RunContext`] and stops when the
//! run is cancelled: what lets a long read show progress and be interrupted.

use std::io::{Read, Seek, SeekFrom};

use crate::{Error, RunContext};

/// The stage name read progress is reported under.
const READING: &str = "reading";

/// Reads from `inner`, reporting the position reached (out of `len` bytes, when known)
/// after every read, and failing the read once `ctx` is cancelled.
pub(crate) struct ReportingReader<'c, R> {
    inner: R,
    position: u64,
    len: Option<u64>,
    ctx: &'c mut RunContext,
}

/// What a cancelled read fails with, told apart from the disk's own errors by
/// [`cancelled_read`].
#[derive(Debug)]
struct ReadCancelled;

impl std::fmt::Display for ReadCancelled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("cancelled")
    }
}

impl std::error::Error for ReadCancelled {}

impl<'c, R> ReportingReader<'c, R> {
    /// A reader of `len` bytes (when known) from `inner`, which stands at its start.
    pub(crate) fn new(inner: R, len: Option<u64>, ctx: &'c mut RunContext) -> Self {
        ReportingReader {
            inner,
            position: 0,
            len,
            ctx,
        }
    }
}

impl<R: Read> Read for ReportingReader<'_, R> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        if self.ctx.check_cancelled().is_err() {
            return Err(std::io::Error::other(ReadCancelled));
        }
        let n = self.inner.read(out)?;
        self.position += n as u64;
        self.ctx.report(READING, self.position, self.len);
        Ok(n)
    }
}

impl<R: Seek> Seek for ReportingReader<'_, R> {
    fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
        self.position = self.inner.seek(to)?;
        Ok(self.position)
    }
}

/// `error`, or [`Error::Cancelled`] where it is a read that [`ReportingReader`] failed
/// because the run was cancelled.
pub(crate) fn cancelled_read(error: Error) -> Error {
    match error {
        Error::Read { source }
            if source
                .get_ref()
                .is_some_and(|inner| inner.is::<ReadCancelled>()) =>
        {
            Error::Cancelled
        }
        other => other,
    }
}
