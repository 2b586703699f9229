//! Stage: a mesh → oriented points on its surface, for the algorithms that work on
//! point-set surfaces (MLS, [`crate::quilt`]) when the mesh's vertices are too few or too
//! uneven to stand for it (what `geosynth sample` runs).

use pointset_core::surface_sampling::{
    SampleNormals, SurfaceSamples, SurfaceSampling, sample_surface,
};
use pointset_core::{RunContext, Stage, TriMesh};

use crate::error::{Error, Result};

/// Stage: mesh → points sampled on its surface
/// ([`pointset_core::surface_sampling::sample_surface`]), seeded by the run's seed: with
/// the normals asked for and the vertex attributes interpolated, and the triangle each
/// sample lies on. `map(|samples| samples.points)` hands the points on.
///
/// Errors: a mesh without area, a count or spacing out of range, or cancellation.
///
/// ```
/// use geosynth::reconstruct::{FieldParams, Reconstruct};
/// use geosynth::sample::SampleSurface;
/// use geosynth::{RunContext, Stage};
///
/// // A coarse torus (288 vertices) sampled at 4000 points and reconstructed.
/// let torus = geosynth::fixtures::torus_mesh(24, 12, 1.0, 0.35)?;
/// let to_mesh = SampleSurface::about(&torus, 4000)?
///     .map(|samples| samples.points)
///     .then(Reconstruct { params: FieldParams::default().resolution(40) });
/// let mesh = to_mesh.run(torus, &mut RunContext::new(1))?;
/// let topology = mesh.topology();
/// assert!(topology.is_closed_manifold() && topology.components == 1);
/// assert_eq!(topology.euler_characteristic, 0); // a torus
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SampleSurface {
    /// How many samples, and how they spread.
    pub sampling: SurfaceSampling,
    /// Where the samples' normals come from.
    #[cfg_attr(feature = "serde", serde(default))]
    pub normals: SampleNormals,
}

impl SampleSurface {
    /// Poisson-disk samples, about `count` of them on `mesh`'s surface
    /// ([`SurfaceSampling::poisson_disk_for_count`]), with the triangles' normals.
    ///
    /// Errors: a count of 0, or a mesh without area.
    pub fn about(mesh: &TriMesh, count: usize) -> Result<Self> {
        Ok(Self {
            sampling: SurfaceSampling::poisson_disk_for_count(mesh.area(), count)?,
            normals: SampleNormals::Faces,
        })
    }
}

impl Stage for SampleSurface {
    type Input = TriMesh;
    type Output = SurfaceSamples;
    type Error = Error;

    fn name(&self) -> &str {
        "sample surface"
    }

    fn run(&self, input: TriMesh, ctx: &mut RunContext) -> Result<SurfaceSamples> {
        Ok(sample_surface(&input, &self.sampling, self.normals, ctx)?)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn samples_of_a_sphere_lie_on_it_and_a_flat_mesh_is_an_error() {
        let sphere = crate::fixtures::icosphere_mesh(3).unwrap();
        let stage = SampleSurface {
            sampling: SurfaceSampling::Uniform { count: 5000 },
            normals: SampleNormals::Interpolated,
        };
        let samples = stage.run(sphere.clone(), &mut RunContext::new(2)).unwrap();
        let points = samples.points.positions();
        let normals = samples.points.normals().unwrap();
        assert_eq!(points.len(), 5000);
        for (p, n) in points.iter().zip(normals) {
            // Flat triangles sag inside the sphere by at most 1 − cos(half an edge's
            // angle); the interpolated normals point out, near the radial direction.
            assert!(p.length() <= 1.0 + 1e-6 && p.length() > 0.98, "{p}");
            assert!(n.angle_between(p.normalize()) < 0.05, "{p}: {n}");
        }
        let flat = TriMesh::new(
            pointset_core::PointSet::new(vec![
                glam::Vec3::ZERO,
                glam::Vec3::X,
                glam::Vec3::X * 3.0,
            ])
            .unwrap(),
            vec![[0, 1, 2]],
        )
        .unwrap();
        assert!(SampleSurface::about(&flat, 100).is_err());
        assert!(stage.run(flat, &mut RunContext::new(2)).is_err());
    }
}
