//! Stage: a mesh → the same surface in fewer triangles, by edge collapse under error
//! quadrics ([`pointset_core::simplify`], what `geosynth simplify` runs): for the dense
//! meshes reconstruction and iso-surfaces make, before they go to a modeller or an engine.

use pointset_core::simplify::{Simplified, SimplifyParams, simplify_mesh};
use pointset_core::{RunContext, Stage, TriMesh};

use crate::error::{Error, Result};

/// Stage: mesh → the mesh simplified to at most `params.target_faces` faces, with its
/// topology kept (module docs of [`pointset_core::simplify`]), and the report of what was
/// done. `map(|simplified| simplified.mesh)` hands the mesh on.
///
/// Errors: parameters out of range, a mesh without faces, or cancellation.
///
/// ```
/// use geosynth::reconstruct::{FieldParams, Reconstruct};
/// use geosynth::simplify::Simplify;
/// use geosynth::core::simplify::SimplifyParams;
/// use geosynth::{RunContext, Stage};
///
/// // A sphere's points reconstructed, then brought down to 500 triangles.
/// let points = geosynth::fixtures::sphere_points(3000)?;
/// let to_mesh = Reconstruct { params: FieldParams::default().resolution(40) }
///     .then(Simplify { params: SimplifyParams::faces(500) })
///     .map(|simplified| simplified.mesh);
/// let mesh = to_mesh.run(points, &mut RunContext::new(1))?;
/// assert!(mesh.face_count() <= 500);
/// let topology = mesh.topology();
/// assert!(topology.is_closed_manifold() && topology.euler_characteristic == 2);
/// // Still the unit sphere: every vertex within 1% of it.
/// assert!(mesh.positions().iter().all(|p| (p.length() - 1.0).abs() < 0.01));
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Simplify {
    /// How far to simplify, and the limits a collapse must keep.
    pub params: SimplifyParams,
}

impl Stage for Simplify {
    type Input = TriMesh;
    type Output = Simplified;
    type Error = Error;

    fn name(&self) -> &str {
        "simplify"
    }

    fn run(&self, input: TriMesh, ctx: &mut RunContext) -> Result<Simplified> {
        Ok(simplify_mesh(&input, &self.params, ctx)?)
    }
}
