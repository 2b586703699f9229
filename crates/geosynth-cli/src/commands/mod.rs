//! One module per subcommand.

pub mod demo;
pub mod fixtures;
pub mod info;
pub mod quilt;
pub mod reconstruct;
pub mod render;
pub mod voxel;
pub mod warp;

use geosynth::core::PointSet;
use geosynth::mls::{LIKELY_UNORIENTED, ORIENTATION_NEIGHBOURS, orientation_disagreement};

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
