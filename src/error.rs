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
    /// A warp sent the point at `index` beyond single precision: the spline's targets lie
    /// too far from their sources.
    #[error(
        "the spline sends point {index} beyond single precision; its targets lie too far \
         from their sources"
    )]
    WarpOverflow {
        /// The first such point, by its index in the point set or mesh.
        index: usize,
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
    /// Whether the run was cancelled through its [`RunContext`](crate::RunContext)'s
    /// cancel flag, whichever crate noticed it: what a caller that cancels runs tells
    /// apart from failures.
    ///
    /// ```
    /// use geosynth::reconstruct::{FieldParams, Reconstruct};
    /// use geosynth::{fixtures, RunContext, Stage};
    ///
    /// let points = fixtures::sphere_points(500)?;
    /// let mut ctx = RunContext::new(0);
    /// ctx.cancel_flag().cancel();
    /// let stopped = Reconstruct { params: FieldParams::default() }.run(points, &mut ctx);
    /// assert!(stopped.is_err_and(|e| e.is_cancelled()));
    /// # Ok::<(), geosynth::Error>(())
    /// ```
    pub fn is_cancelled(&self) -> bool {
        use distance_field::FieldError;
        use mls_surface::MlsError;
        use patch_quilt::QuiltError;
        use pointset_core::Error::Cancelled;
        use voxel_dfsynth::VoxelError;
        let field = |e: &FieldError| matches!(e, FieldError::Core(Cancelled));
        let mls = |e: &MlsError| matches!(e, MlsError::Core(Cancelled));
        match self {
            Error::Core(e) => matches!(e, Cancelled),
            Error::Mls(e) => mls(e),
            Error::Field(e) => field(e),
            Error::Tps(e) => matches!(e, tps_warp::TpsError::Core(Cancelled)),
            Error::Quilt(QuiltError::Core(Cancelled))
            | Error::Voxel(VoxelError::Core(Cancelled)) => true,
            Error::Quilt(QuiltError::Mls(e)) => mls(e),
            Error::Quilt(QuiltError::Field(e)) | Error::Voxel(VoxelError::Field(e)) => field(e),
            _ => false,
        }
    }

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

#[cfg(test)]
mod tests {
    use distance_field::FieldError;
    use mls_surface::MlsError;
    use patch_quilt::QuiltError;
    use pointset_core::Error::{Cancelled, EmptyInput};
    use voxel_dfsynth::VoxelError;

    use super::*;

    #[test]
    fn a_cancellation_is_found_through_every_crate_that_passes_it_on() {
        let field = || FieldError::Core(Cancelled);
        let mls = || MlsError::Core(Cancelled);
        let cancelled = [
            Error::Core(Cancelled),
            Error::Mls(mls()),
            Error::Field(field()),
            Error::Tps(tps_warp::TpsError::Core(Cancelled)),
            Error::Quilt(QuiltError::Core(Cancelled)),
            Error::Quilt(QuiltError::Mls(mls())),
            Error::Quilt(QuiltError::Field(field())),
            Error::Voxel(VoxelError::Core(Cancelled)),
            Error::Voxel(VoxelError::Field(field())),
        ];
        for error in cancelled {
            assert!(error.is_cancelled(), "{error:?}");
        }
        let empty = || EmptyInput {
            what: "the point set".into(),
        };
        let failed = [
            Error::Core(empty()),
            Error::Field(FieldError::Core(empty())),
            Error::Quilt(QuiltError::Mls(MlsError::Core(empty()))),
            Error::NoSurface {
                reason: "no crossing".into(),
            },
        ];
        for error in failed {
            assert!(!error.is_cancelled(), "{error:?}");
        }
    }
}
