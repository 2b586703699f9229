//! Stage: bare points → points with oriented normals, the step before [`crate::reconstruct`]
//! for scans that come without normals (or with normals of random sign).

use glam::Vec3;
use mls_surface::{NORMAL_NEIGHBOURS, NormalFit, fit_oriented_normals_with};
use pointset_core::{KdIndex, PointSet, RunContext, Stage};

use crate::error::{Error, Result};

/// Stage: points → the same points with unit normals fitted by local PCA to each point's
/// `neighbours` nearest (itself included) and oriented by propagation, those facing most
/// clearly along `up` turned toward it ([`mls_surface::fit_oriented_normals_with`]; the
/// orientation's rules and their limits are [`mls_surface::orient_normals`]'). Any
/// normals the points had are replaced; positions and attributes are kept.
///
/// The output is the [`NormalFit`]: the points, and which of them have neighbourhoods
/// that define no normal (scan lines sampled far more densely along than across: more
/// `neighbours` fixes them). `map(|fit| fit.points)` hands the points on.
///
/// Progress: [`mls_surface::FITTING_STAGE`], [`mls_surface::LINKING_STAGE`] and
/// [`mls_surface::ORIENTING_STAGE`], each timed under its name; a cancelled run stops at
/// the next report ([`Error::is_cancelled`]). Errors: `neighbours` below 3, `up` zero or
/// not finite, fewer than 3 points, a non-finite position.
///
/// ```
/// use geosynth::core::PointSet;
/// use geosynth::normals::EstimateNormals;
/// use geosynth::reconstruct::{FieldParams, Reconstruct};
/// use geosynth::{RunContext, Stage};
///
/// // A scan of a sphere with its positions alone, to a closed mesh.
/// let scan = geosynth::fixtures::sphere_points(2000)?;
/// let bare = PointSet::new(scan.positions().to_vec())?;
/// let to_mesh = EstimateNormals::default()
///     .map(|fit| fit.points)
///     .then(Reconstruct { params: FieldParams::default().resolution(32) });
/// let mesh = to_mesh.run(bare, &mut RunContext::new(0))?;
/// let topology = mesh.topology();
/// assert!(topology.is_closed_manifold() && topology.euler_characteristic == 2);
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct EstimateNormals {
    /// The nearest points each tangent plane is fitted to, the point itself included: at
    /// least 3. [`NORMAL_NEIGHBOURS`] (12) by default.
    pub neighbours: usize,
    /// The direction the orientation turns normals toward where a part of the points
    /// faces clearly up or down: the outside of a closed object at its top, the top of a
    /// terrain. `+Z` by default.
    pub up: Vec3,
}

impl Default for EstimateNormals {
    fn default() -> Self {
        Self {
            neighbours: NORMAL_NEIGHBOURS,
            up: Vec3::Z,
        }
    }
}

impl Stage for EstimateNormals {
    type Input = PointSet;
    type Output = NormalFit;
    type Error = Error;

    fn name(&self) -> &str {
        "estimate normals"
    }

    fn run(&self, input: PointSet, ctx: &mut RunContext) -> Result<NormalFit> {
        let index = KdIndex::new(input.positions())?;
        Ok(fit_oriented_normals_with(
            &index,
            input,
            self.neighbours,
            self.up,
            ctx,
        )?)
    }
}
