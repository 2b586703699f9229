//! ASCII STL: `solid` blocks of `facet normal … outer loop vertex ×3 endloop endfacet`.

use glam::DVec3;

use super::check_corner;
use crate::io::FileFormat;
use crate::{Error, Location, Result};

/// The words of a text with the 1-based line each stands on.
struct Words<'a> {
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    line: usize,
    rest: std::str::SplitWhitespace<'a>,
}

impl<'a> Words<'a> {
    fn new(text: &'a str) -> Self {
        Self {
            lines: text.lines().enumerate(),
            line: 0,
            rest: "".split_whitespace(),
        }
    }

    /// The next word and its line, or `None` at the end of the text.
    fn next_word(&mut self) -> Option<(usize, &'a str)> {
        loop {
            if let Some(word) = self.rest.next() {
                return Some((self.line, word));
            }
            let (index, line) = self.lines.next()?;
            self.line = index + 1;
            self.rest = line.split_whitespace();
        }
    }

    /// The rest of the current line, joined by single spaces (a solid's name).
    fn rest_of_line(&mut self) -> String {
        self.rest.by_ref().collect::<Vec<_>>().join(" ")
    }

    /// The next word, which must be `keyword` (ASCII case ignored).
    fn require(&mut self, keyword: &str, inside: &str) -> Result<usize> {
        match self.next_word() {
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
            let (line, word) = self.next_word().ok_or_else(|| self.ended(what))?;
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

fn ascii_error(line: usize, message: String) -> Error {
    Error::Malformed {
        format: FileFormat::Stl,
        location: Location::Line(line),
        message,
    }
}

/// The corners of an ASCII STL's facets, three per facet, and the names of its solids.
/// Several solids may follow each other; keywords are matched ignoring ASCII case.
pub(super) fn ascii_corners(bytes: &[u8]) -> Result<(Vec<DVec3>, Vec<String>)> {
    let text = std::str::from_utf8(bytes).map_err(|e| Error::Malformed {
        format: FileFormat::Stl,
        location: Location::Byte(e.valid_up_to() as u64),
        message: "an ASCII STL must be text (valid UTF-8)".into(),
    })?;
    let mut words = Words::new(text);
    let mut corners = Vec::new();
    let mut names = Vec::new();
    while let Some((line, word)) = words.next_word() {
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
        read_solid_facets(&mut words, &mut corners)?;
    }
    Ok((corners, names))
}

/// Reads facets up to and including the `endsolid` line.
fn read_solid_facets(words: &mut Words<'_>, corners: &mut Vec<DVec3>) -> Result<()> {
    loop {
        let (line, word) = words
            .next_word()
            .ok_or_else(|| words.ended("`facet` or `endsolid`"))?;
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
