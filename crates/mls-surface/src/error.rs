//! The error type of `mls-surface`.

/// Everything that can go wrong building or using a point-set surface.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MlsError {
    /// From `pointset-core` (spatial index, validation).
    #[error(transparent)]
    Core(#[from] pointset_core::Error),
    /// The surface definition needs oriented points.
    #[error(
        "the point set has no normals; the MLS surface needs oriented points (`geosynth normals`, or mls_surface::estimate_normals then orient_normals, estimates them)"
    )]
    MissingNormals,
    /// No points at all.
    #[error("{what} is empty")]
    EmptyInput {
        /// What was empty.
        what: &'static str,
    },
    /// A normal of (near) zero length cannot be oriented.
    #[error("normal {index} has zero length, so it gives the surface no direction there")]
    DegenerateNormal {
        /// Index of the point.
        index: usize,
    },
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
pub type Result<T, E = MlsError> = std::result::Result<T, E>;

/// Checks `value` is finite and strictly positive.
pub(crate) fn positive(name: &'static str, value: f32) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(MlsError::InvalidParameter {
            name,
            value: value.to_string(),
            expected: "a positive finite number",
        })
    }
}
