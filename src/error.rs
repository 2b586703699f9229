//! The facade's umbrella error.

use std::path::PathBuf;

/// Any error from a geosynth crate or the facade itself.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// From `pointset-core` (types, I/O, spatial indices, stages).
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
    /// From `patch-quilt`.
    #[error(transparent)]
    Quilt(#[from] patch_quilt::QuiltError),
    /// From `voxel-dfsynth`.
    #[error(transparent)]
    Voxel(#[from] voxel_dfsynth::VoxelError),
    /// A geometry texture file whose box comment cannot be parsed.
    #[error("{path}: {message}")]
    TextureFile {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Encoding or writing an image failed.
    #[error("cannot write image {path}: {source}")]
    Image {
        /// The image file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: image::ImageError,
    },
    /// Reading or decoding an image failed.
    #[error("cannot read image {path}: {source}")]
    ImageRead {
        /// The image file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: image::ImageError,
    },
    /// A height field file whose content its reader refuses: a raw file of the wrong
    /// size, an ENVI header it cannot read, samples on the no-data value, GeoTIFF tags
    /// of the wrong length.
    #[error("{path}: {reason}")]
    HeightFile {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// Decoding a TIFF height field failed (not a TIFF, truncated, an unsupported
    /// compression or sample layout).
    #[error("cannot read TIFF {path}: {source}")]
    TiffRead {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: tiff::TiffError,
    },
    /// Encoding a TIFF height map failed.
    #[error("cannot write TIFF {path}: {source}")]
    TiffWrite {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: tiff::TiffError,
    },
    /// A stage found no surface to produce (its distance field never crosses zero).
    #[error("no surface: {reason}")]
    NoSurface {
        /// What was found instead.
        reason: String,
    },
    /// A rendering or pipeline parameter is out of range.
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

impl Error {
    /// A range error for parameter `name`.
    pub(crate) fn invalid<T>(
        name: &'static str,
        value: impl ToString,
        expected: &str,
    ) -> Result<T> {
        Err(Error::InvalidParameter {
            name,
            value: value.to_string(),
            expected: expected.into(),
        })
    }
}

/// Shorthand for results of the facade.
pub type Result<T, E = Error> = std::result::Result<T, E>;
