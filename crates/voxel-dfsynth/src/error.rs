//! The error type of `voxel-dfsynth`.

/// Everything that can go wrong in `voxel-dfsynth`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum VoxelError {
    /// From `pointset-core`.
    #[error(transparent)]
    Core(#[from] pointset_core::Error),
    /// From `distance-field`.
    #[error(transparent)]
    Field(#[from] distance_field::FieldError),
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

/// An [`VoxelError::InvalidParameter`] naming the parameter, its value and the range.
pub(crate) fn invalid(
    name: &'static str,
    value: impl ToString,
    expected: impl Into<String>,
) -> VoxelError {
    VoxelError::InvalidParameter {
        name,
        value: value.to_string(),
        expected: expected.into(),
    }
}

/// Shorthand for results of this crate.
pub type Result<T, E = VoxelError> = std::result::Result<T, E>;
