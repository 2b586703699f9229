//! One module per subcommand.

pub mod demo;
pub mod fixtures;
pub mod info;
pub mod normals;
pub mod quilt;
pub mod reconstruct;
pub mod render;
pub mod voxel;
pub mod warp;

use geosynth::core::PointSet;
use geosynth::mls::{LIKELY_UNORIENTED, ORIENTATION_NEIGHBOURS, orientation_disagreement};
use glam::DVec3;

/// A note when a point set's normals look unoriented (signs flipping from point to point,
/// as local PCA estimates come): the MLS surface averages them, so they cancel and leave
/// holes or a wrong surface without an error. `None` when they look consistent or there
/// are none.
pub fn unoriented_normals_note(points: &PointSet) -> Option<String> {
    let share = orientation_disagreement(points).ok()?;
    (share > LIKELY_UNORIENTED).then(|| {
        format!(
            "note: the normals look unoriented: {:.0}% of the points face away from most of \
             their {ORIENTATION_NEIGHBOURS} nearest neighbours (consistently oriented data \
             scores a few percent); the MLS surface needs consistently oriented normals \
             (--orient-normals orients them by propagation)",
            100.0 * share
        )
    })
}

/// A note when an input file stored coordinates far from its origin in single precision
/// (`step` apart there, around `origin`), coarser than a hundredth of `scale` (the length
/// `scale_name` describes): reading in double precision cannot restore that.
pub fn single_precision_note(
    origin: DVec3,
    step: f64,
    scale: f64,
    scale_name: &str,
) -> Option<String> {
    (scale > 0.0 && step > 0.01 * scale).then(|| {
        format!(
            "note: the exemplar file stores its coordinates (around {:.0}, {:.0}, {:.0}) in \
             single precision, {step} apart there, {:.2} times {scale_name}; write it in \
             double precision (or nearer the origin) for full precision",
            origin.x,
            origin.y,
            origin.z,
            step / scale
        )
    })
}
