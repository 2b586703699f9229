//! What the geometry writers share: a buffer in front of the caller's writer, so that files
//! are streamed value by value and never encoded whole in memory first, and `#` comments.

use std::io::{BufWriter, Write};

use crate::{Error, Result};

/// The buffer's size.
const BUFFER_BYTES: usize = 1 << 16;

/// Runs `write` on `out` through a buffer and flushes it; errors become [`Error::Write`].
/// After an error, what is still buffered is dropped, not written.
pub(crate) fn buffered<W: Write>(
    out: &mut W,
    write: impl FnOnce(&mut BufWriter<&mut W>) -> std::io::Result<()>,
) -> Result<()> {
    let mut buffered = BufWriter::with_capacity(BUFFER_BYTES, out);
    match write(&mut buffered).and_then(|()| buffered.flush()) {
        Ok(()) => Ok(()),
        Err(source) => {
            // Drop the buffer without the flush that dropping a `BufWriter` would do.
            let _ = buffered.into_parts();
            Err(Error::Write { source })
        }
    }
}

/// Writes each comment as a `# ` line, its line breaks turned into spaces.
pub(crate) fn comment_lines(out: &mut impl Write, comments: &[String]) -> std::io::Result<()> {
    for comment in comments {
        writeln!(out, "# {}", comment.replace(['\n', '\r'], " "))?;
    }
    Ok(())
}
