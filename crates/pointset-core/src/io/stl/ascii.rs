//! ASCII STL: `solid` blocks of `facet normal … outer loop vertex ×3 endloop endfacet`.

use std::io::Read;

use glam::DVec3;

use super::binary::{BINARY_HEADER_BYTES, binary_size_error_of};
use super::check_corner;
use crate::io::FileFormat;
use crate::io::stream::ByteStream;
use crate::{Error, Location, Result};

/// The words of an ASCII STL as it streams in, with the 1-based line each stands on.
///
/// A NUL byte anywhere makes the file binary (and so the wrong size for one); text that is
/// not UTF-8 is refused before anything the text says. Lines are read until either is
/// found, and once the parse stops, [`Words::settle`] reads the rest to see which error the
/// whole file gives.
struct Words<R> {
    stream: ByteStream<R>,
    raw: Vec<u8>,
    /// The current line.
    text: String,
    /// Where the rest of the current line starts.
    at: usize,
    /// The current line's number.
    line: usize,
    /// The file's first (up to 84) bytes: a binary header, if it were binary.
    header: Vec<u8>,
    /// The first line that is not UTF-8, as its error.
    not_text: Option<Error>,
    /// Whether a NUL byte was read.
    nul: bool,
}

impl<R: Read> Words<R> {
    fn new(reader: R, len: u64, head: &[u8]) -> Self {
        Words {
            stream: ByteStream::new(reader, len),
            raw: Vec::new(),
            text: String::new(),
            at: 0,
            line: 0,
            header: head[..head.len().min(BINARY_HEADER_BYTES)].to_vec(),
            not_text: None,
            nul: false,
        }
    }

    /// Reads the next line into `text`; `false` at the end.
    fn next_line(&mut self) -> Result<bool> {
        let start = self.stream.position();
        if !self.stream.read_line(&mut self.raw)? {
            return Ok(false);
        }
        self.line += 1;
        self.text.clear();
        self.at = 0;
        if self.raw.contains(&0) {
            self.nul = true;
            return Err(self.refusal());
        }
        match std::str::from_utf8(&self.raw) {
            Ok(text) => self.text.push_str(text),
            Err(e) => {
                let error = not_utf8(start + e.valid_up_to() as u64);
                self.not_text = Some(not_utf8(start + e.valid_up_to() as u64));
                return Err(error);
            }
        }
        Ok(true)
    }

    /// What the whole file gives once the parse has stopped with `error`: the refusal of a
    /// binary file if any byte is NUL, else the first line that is not UTF-8, else `error`.
    fn settle(mut self, error: Error) -> Error {
        while !self.nul {
            let start = self.stream.position();
            match self.stream.read_line(&mut self.raw) {
                Ok(true) if self.raw.contains(&0) => self.nul = true,
                Ok(true) => {
                    if self.not_text.is_none()
                        && let Err(e) = std::str::from_utf8(&self.raw)
                    {
                        self.not_text = Some(not_utf8(start + e.valid_up_to() as u64));
                    }
                }
                Ok(false) => break,
                Err(read) => return read,
            }
        }
        if self.nul {
            self.refusal()
        } else {
            self.not_text.unwrap_or(error)
        }
    }

    /// The refusal of a binary file of this size and header.
    fn refusal(&self) -> Error {
        binary_size_error_of(&self.header, self.stream.len())
    }

    /// The next word and its line, or `None` at the end of the text.
    fn next_word(&mut self) -> Result<Option<(usize, &str)>> {
        let (start, end) = loop {
            let rest = &self.text[self.at..];
            if let Some(first) = rest.find(|c: char| !c.is_whitespace()) {
                let start = self.at + first;
                let end = self.text[start..]
                    .find(char::is_whitespace)
                    .map_or(self.text.len(), |n| start + n);
                break (start, end);
            }
            if !self.next_line()? {
                return Ok(None);
            }
        };
        self.at = end;
        Ok(Some((self.line, &self.text[start..end])))
    }

    /// The rest of the current line, joined by single spaces (a solid's name).
    fn rest_of_line(&mut self) -> String {
        let rest = self.text[self.at..]
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        self.at = self.text.len();
        rest
    }

    /// The next word, which must be `keyword` (ASCII case ignored).
    fn require(&mut self, keyword: &str, inside: &str) -> Result<usize> {
        match self.next_word()? {
            Some((line, word)) if word.eq_ignore_ascii_case(keyword) => Ok(line),
            Some((line, word)) => Err(ascii_error(
                line,
                format!("expected `{keyword}` {inside}, found `{word}`"),
            )),
            None => Err(self.ended(&format!("`{keyword}` {inside}"))),
        }
    }

    /// The next three words as numbers.
    fn vector(&mut self, what: &str) -> Result<DVec3> {
        let mut xyz = [0.0; 3];
        for x in &mut xyz {
            let Some((line, word)) = self.next_word()? else {
                return Err(self.ended(what));
            };
            *x = word
                .parse()
                .map_err(|_| ascii_error(line, format!("`{word}` in {what} is not a number")))?;
        }
        Ok(DVec3::from_array(xyz))
    }

    fn ended(&self, what: &str) -> Error {
        Error::UnexpectedEof {
            format: FileFormat::Stl,
            location: Location::Line(self.line.max(1)),
            what: what.to_string(),
        }
    }
}

/// The refusal of text that is not UTF-8 at byte `at`.
fn not_utf8(at: u64) -> Error {
    Error::Malformed {
        format: FileFormat::Stl,
        location: Location::Byte(at),
        message: "an ASCII STL must be text (valid UTF-8)".into(),
    }
}

fn ascii_error(line: usize, message: String) -> Error {
    Error::Malformed {
        format: FileFormat::Stl,
        location: Location::Line(line),
        message,
    }
}

/// The corners of an ASCII STL's facets, three per facet, and the names of its solids,
/// read from the `len` bytes `reader` gives, which start with `head`. A NUL byte anywhere
/// makes the file a binary one of the wrong size, refused as such. Several solids may
/// follow each other; keywords are matched ignoring ASCII case.
pub(super) fn ascii_corners<R: Read>(
    reader: R,
    head: &[u8],
    len: u64,
) -> Result<(Vec<DVec3>, Vec<String>)> {
    let mut words = Words::new(reader, len, head);
    let mut corners = Vec::new();
    let mut names = Vec::new();
    match read_solids(&mut words, &mut corners, &mut names) {
        Ok(()) => Ok((corners, names)),
        Err(error) => Err(words.settle(error)),
    }
}

/// Reads `solid` blocks to the end of the text.
fn read_solids<R: Read>(
    words: &mut Words<R>,
    corners: &mut Vec<DVec3>,
    names: &mut Vec<String>,
) -> Result<()> {
    while let Some((line, word)) = words.next_word()? {
        if !word.eq_ignore_ascii_case("solid") {
            return Err(ascii_error(
                line,
                format!("expected `solid`, found `{word}`"),
            ));
        }
        let name = words.rest_of_line();
        if !name.is_empty() {
            names.push(name);
        }
        read_solid_facets(words, corners)?;
    }
    Ok(())
}

/// Reads facets up to and including the `endsolid` line.
fn read_solid_facets<R: Read>(words: &mut Words<R>, corners: &mut Vec<DVec3>) -> Result<()> {
    loop {
        let Some((line, word)) = words.next_word()? else {
            return Err(words.ended("`facet` or `endsolid`"));
        };
        if word.eq_ignore_ascii_case("endsolid") {
            words.rest_of_line();
            return Ok(());
        }
        if !word.eq_ignore_ascii_case("facet") {
            return Err(ascii_error(
                line,
                format!("expected `facet` or `endsolid`, found `{word}`"),
            ));
        }
        let facet = corners.len() / 3;
        words.require("normal", "after `facet`")?;
        words.vector("the facet normal")?;
        words.require("outer", "before the facet's corners")?;
        words.require("loop", "after `outer`")?;
        for corner in 0..3 {
            let line = words.require("vertex", "(an STL facet has three corners)")?;
            let p = words.vector("a vertex")?;
            check_corner(p, facet, corner).map_err(|_| {
                ascii_error(
                    line,
                    format!("corner {corner} of facet {facet} is not finite"),
                )
            })?;
            corners.push(p);
        }
        words.require(
            "endloop",
            "after three corners (an STL facet is a triangle)",
        )?;
        words.require("endfacet", "after `endloop`")?;
    }
}
