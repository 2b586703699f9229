//! The error type of `tps-warp`.

/// Everything that can go wrong fitting a spline or pairing points.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TpsError {
    /// From `pointset-core`.
    #[error(transparent)]
    Core(#[from] pointset_core::Error),
    /// No control points or no points to pair.
    #[error("{what} is empty")]
    EmptyInput {
        /// What was empty.
        what: &'static str,
    },
    /// Two sequences that must have equal length do not.
    #[error("{what}: {left} vs {right} entries")]
    LengthMismatch {
        /// What was compared.
        what: &'static str,
        /// First length.
        left: usize,
        /// Second length.
        right: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("{what} {index} is not finite")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Index of the bad entry.
        index: usize,
    },
    /// Two control points coincide but map to different targets: no function does that.
    #[error("control points {first} and {second} coincide but map to different targets")]
    DuplicateControlPoints {
        /// First index.
        first: usize,
        /// Second index.
        second: usize,
    },
    /// The control points span fewer than three dimensions (all coplanar, collinear or one
    /// point), so the affine part is undetermined; allow
    /// [`crate::AffineRegularization::TowardIdentity`] to resolve it.
    #[error(
        "control points are degenerate (they span {rank} of 3 dimensions); the affine part is undetermined"
    )]
    DegenerateControlPoints {
        /// Dimension of the affine hull of the control points.
        rank: usize,
    },
    /// The linear system could not be solved (or produced non-finite coefficients).
    #[error("the spline system is singular")]
    Singular,
    /// A parameter lies outside its valid range.
    #[error("parameter `{name}` = {value} is out of range: expected {expected}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// The value given.
        value: String,
        /// The accepted range, in words.
        expected: &'static str,
    },
}

/// Shorthand for results of this crate.
pub type Result<T, E = TpsError> = std::result::Result<T, E>;
