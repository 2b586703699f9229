//! The error type of `distance-field`.

/// Everything that can go wrong in `distance-field`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FieldError {
    /// From `pointset-core` (grids, meshes, I/O).
    #[error(transparent)]
    Core(#[from] pointset_core::Error),
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
    /// A mesh without triangles has no distance field.
    #[error("the mesh has no non-degenerate triangles")]
    EmptyMesh,
    /// Winding numbers of a point cloud need its samples' normals.
    #[error(
        "the point set has no normals: its winding numbers need oriented samples \
         (`geosynth normals` estimates them)"
    )]
    MissingNormals,
    /// An NRRD file that this crate cannot read.
    #[error("NRRD {location}: {message}")]
    Nrrd {
        /// Line number (header) or byte offset (data), in words.
        location: String,
        /// What is wrong.
        message: String,
    },
    /// Reading or writing a file failed.
    #[error("cannot access {path}: {source}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// Shorthand for results of this crate.
pub type Result<T, E = FieldError> = std::result::Result<T, E>;

/// Checks `value` is finite and strictly positive.
pub(crate) fn positive(name: &'static str, value: f32) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(FieldError::InvalidParameter {
            name,
            value: value.to_string(),
            expected: "a positive finite number",
        })
    }
}
