//! The error type of `patch-quilt`.

/// Everything that can go wrong preparing or running a quilt.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum QuiltError {
    /// From `pointset-core`.
    #[error(transparent)]
    Core(#[from] pointset_core::Error),
    /// From `mls-surface`.
    #[error(transparent)]
    Mls(#[from] mls_surface::MlsError),
    /// From `distance-field`.
    #[error(transparent)]
    Field(#[from] distance_field::FieldError),
    /// From `tps-warp`.
    #[error(transparent)]
    Tps(#[from] tps_warp::TpsError),
    /// The exemplar cannot be used as a geometry texture.
    #[error("invalid geometry texture: {reason}")]
    InvalidTexture {
        /// What is wrong.
        reason: String,
    },
    /// A parameter lies outside its valid range.
    #[error("parameter `{name}` = {value} is out of range: expected {expected}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// The value given.
        value: String,
        /// The accepted range, in words.
        expected: String,
    },
}

/// Shorthand for results of this crate.
pub type Result<T, E = QuiltError> = std::result::Result<T, E>;

pub(crate) fn invalid(
    name: &'static str,
    value: impl ToString,
    expected: impl Into<String>,
) -> QuiltError {
    QuiltError::InvalidParameter {
        name,
        value: value.to_string(),
        expected: expected.into(),
    }
}
