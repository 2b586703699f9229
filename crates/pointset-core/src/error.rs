//! The error type of `pointset-core`.

use std::fmt;
use std::path::PathBuf;

use crate::io::FileFormat;

/// Where in a file a problem was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// A 1-based line number in a text file or text header.
    Line(usize),
    /// A 0-based byte offset from the start of the file.
    Byte(u64),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(n) => write!(f, "line {n}"),
            Location::Byte(n) => write!(f, "byte {n}"),
        }
    }
}

/// Everything that can go wrong in `pointset-core`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The operating system failed to read or write a file.
    #[error("cannot access {path}: {source}")]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// Writing to an in-memory or user-supplied writer failed.
    #[error("write failed: {source}")]
    Write {
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// Reading from a file or user-supplied reader failed.
    #[error("read failed: {source}")]
    Read {
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file has no bytes at all.
    #[error("{path} is empty")]
    EmptyFile {
        /// The file involved.
        path: PathBuf,
    },
    /// The file's extension names no supported format and its content matches none either.
    #[error("cannot tell the format of {path}: {reason}")]
    UnknownFormat {
        /// The file involved.
        path: PathBuf,
        /// Why detection failed.
        reason: String,
    },
    /// The extension says one format but the content is clearly another.
    #[error("{path} has a .{extension} extension but its content looks like {sniffed}")]
    FormatMismatch {
        /// The file involved.
        path: PathBuf,
        /// The extension found.
        extension: String,
        /// The format the content looks like.
        sniffed: FileFormat,
    },
    /// Text or binary content that does not follow the format.
    #[error("{format} syntax error at {location}: {message}")]
    Malformed {
        /// The format being read.
        format: FileFormat,
        /// Where the problem is.
        location: Location,
        /// What is wrong.
        message: String,
    },
    /// A structured document (a glTF file's JSON) whose content breaks the format's
    /// rules, found at the member `at` (e.g. `accessors[3].count`).
    #[error("{format} file invalid at `{at}`: {message}")]
    InvalidDocument {
        /// The format being read.
        format: FileFormat,
        /// The member at fault, as a path from the document's root.
        at: String,
        /// What is wrong.
        message: String,
    },
    /// A property type name that the PLY specification does not define.
    #[error("PLY header line {line}: unknown property type `{type_name}`")]
    UnknownPropertyType {
        /// Header line (1-based).
        line: usize,
        /// The type name found.
        type_name: String,
    },
    /// The header declares more data than the file contains (checked before allocating).
    #[error(
        "{format} header declares {declared} `{element}` records needing at least {needed_bytes} bytes, \
         but only {available_bytes} bytes follow the header"
    )]
    HeaderExceedsFile {
        /// The format being read.
        format: FileFormat,
        /// The element whose count is too large.
        element: String,
        /// The declared record count.
        declared: u64,
        /// Minimum number of bytes those records need.
        needed_bytes: u128,
        /// Bytes actually present after the header.
        available_bytes: u64,
    },
    /// The data ends before all declared records were read.
    #[error("{format} data ends early at {location} while reading {what}")]
    UnexpectedEof {
        /// The format being read.
        format: FileFormat,
        /// Where the data ran out.
        location: Location,
        /// What was being read.
        what: String,
    },
    /// A list property's length is negative, absurd, or longer than the remaining data.
    #[error("{format} list at {location} claims {count} items, {reason}")]
    ListCountOverflow {
        /// The format being read.
        format: FileFormat,
        /// Where the list starts.
        location: Location,
        /// The declared list length.
        count: i128,
        /// Why it is rejected.
        reason: String,
    },
    /// A coordinate, normal or attribute value is NaN or infinite.
    #[error("{what} {index} is not finite")]
    NonFinite {
        /// What kind of value (e.g. "position", "normal", "attribute `radius` value").
        what: String,
        /// Index of the offending record.
        index: usize,
    },
    /// Height samples that are NaN or infinite (a DEM's voids): a height field has no
    /// holes.
    #[error(
        "{count} of the {total} height samples are not finite (NaN or infinite), the first \
         at column {column}, row {row}: a height field has no holes (fill them first, e.g. \
         with gdal_fillnodata)"
    )]
    NonFiniteHeights {
        /// How many samples are not finite.
        count: usize,
        /// How many samples the field has.
        total: usize,
        /// The first one's column (from the left).
        column: usize,
        /// The first one's row (from the top).
        row: usize,
    },
    /// A face references a vertex that does not exist.
    #[error("face {face} references vertex {vertex}, but there are only {vertex_count} vertices")]
    IndexOutOfRange {
        /// Face index.
        face: usize,
        /// The referenced vertex index.
        vertex: i64,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// A face that cannot be turned into triangles.
    #[error("face {face} is invalid: {reason}")]
    InvalidFace {
        /// Face index.
        face: usize,
        /// What is wrong.
        reason: String,
    },
    /// A raw height field whose byte count does not match the size its name gives.
    #[error(
        "a {width}x{height} raw f32 height field needs {} bytes (4 per sample), \
         but the data has {found_bytes}",
        expected_bytes.map_or_else(|| format!("more than {}", usize::MAX), |n| n.to_string())
    )]
    RawSizeMismatch {
        /// Samples per row.
        width: usize,
        /// Rows.
        height: usize,
        /// `width · height · 4`; `None` when that exceeds `usize::MAX` (no file holds it).
        expected_bytes: Option<usize>,
        /// Bytes present.
        found_bytes: usize,
    },
    /// Two arrays that must have equal length do not.
    #[error("{what}: expected {expected} entries, found {found}")]
    LengthMismatch {
        /// What was being matched.
        what: String,
        /// Expected length.
        expected: usize,
        /// Actual length.
        found: usize,
    },
    /// A PLY list column built by hand whose offsets do not mark out a range of its items
    /// for every record (they must not decrease, nor exceed the number of items).
    #[error(
        "PLY list `{property}` of `{element}`: record {record} spans items {start}..{end} \
         of the {items} held"
    )]
    ListOutOfRange {
        /// The element.
        element: String,
        /// The list property.
        property: String,
        /// The first record at fault.
        record: usize,
        /// Its first offset.
        start: usize,
        /// Its end offset.
        end: usize,
        /// How many items the column holds.
        items: usize,
    },
    /// Two point sets (or meshes) with different attribute layouts were combined.
    #[error("incompatible layouts: {reason}")]
    IncompatibleLayout {
        /// What differs.
        reason: String,
    },
    /// An attribute name is reserved, empty or used twice.
    #[error("invalid attribute name `{name}`: {reason}")]
    InvalidAttributeName {
        /// The name given.
        name: String,
        /// Why it is rejected.
        reason: String,
    },
    /// An operation needs at least one element.
    #[error("{what} is empty")]
    EmptyInput {
        /// What was empty.
        what: String,
    },
    /// Positions spread wider than [`crate::MAX_SPAN`]: squared distances between
    /// them would overflow `f32`.
    #[error(
        "{what} span {span:e} units along one axis; distances between f32 coordinates overflow beyond about 1.8e19 and the library accepts spans up to 1e18: rescale the file's units"
    )]
    SpanTooLarge {
        /// What the positions are (e.g. "points of the MLS surface").
        what: String,
        /// The widest extent along an axis.
        span: f32,
    },
    /// A parameter lies outside its valid range.
    #[error("parameter `{name}` = {value} is out of range: expected {expected}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// The value given, formatted.
        value: String,
        /// The accepted range, in words.
        expected: String,
    },
    /// The chosen file format cannot hold what was to be written (a point set as STL).
    #[error("{format} cannot store {what}")]
    FormatCannotStore {
        /// The format asked for.
        format: FileFormat,
        /// What it cannot store, and what to write instead.
        what: String,
    },
    /// Memory for `what` could not be allocated (a process limit such as `ulimit -v`, or
    /// an address space too small for the request).
    #[error("cannot allocate {bytes} bytes for {what}")]
    OutOfMemory {
        /// What the memory was for.
        what: String,
        /// How many bytes were asked for.
        bytes: u128,
    },
    /// The run was cancelled through its [`crate::CancelFlag`].
    #[error("cancelled")]
    Cancelled,
}

/// Shorthand for results of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Checks that every vector in `values` is finite, naming the first offender.
pub(crate) fn check_finite_vec3(values: &[glam::Vec3], what: &str) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(Error::NonFinite {
            what: what.to_string(),
            index,
        }),
        None => Ok(()),
    }
}
