//! Surfaces from oriented points and distance fields from any geometry, as stages.
//!
//! [`Reconstruct`] turns an oriented point set into a closed mesh: MLS point-set surface
//! ([`crate::mls`]) → signed distance grid over the points' box ([`crate::sdf`]) → zero
//! iso-surface. [`SignedDistance`] samples a point set (through its MLS surface) or a mesh
//! (exactly) into an [`SdfGrid`].

use distance_field::{GridSpec, MeshSurface, SdfGrid, sdf_isosurface};
use mls_surface::{MlsError, MlsParams, MlsSurface};
use pointset_core::io::Geometry;
use pointset_core::{PointSet, RunContext, Stage, Surface, TriMesh};

use crate::{Error, Result};

/// Parameters of [`Reconstruct`] and [`SignedDistance`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct FieldParams {
    /// Grid nodes along the longest side of the box; default 96.
    pub resolution: usize,
    /// MLS kernel size `h` for point sets; default estimated (see [`MlsParams`]).
    pub kernel: Option<f32>,
    /// Margin around the geometry's box, in grid spacings; default 3.
    pub margin: f32,
    /// Distances are clamped to this many grid spacings; default 4.
    pub band: f32,
}

impl Default for FieldParams {
    fn default() -> Self {
        Self {
            resolution: 96,
            kernel: None,
            margin: 3.0,
            band: 4.0,
        }
    }
}

impl FieldParams {
    /// Sets the resolution (default 96).
    pub fn resolution(mut self, n: usize) -> Self {
        self.resolution = n;
        self
    }

    /// Sets the MLS kernel (default estimated).
    pub fn kernel(mut self, h: Option<f32>) -> Self {
        self.kernel = h;
        self
    }

    /// Checks ranges: resolution 4..=1024, positive margin and band.
    pub fn validate(&self) -> Result<()> {
        let bad = Error::invalid::<()>;
        if !(4..=1024).contains(&self.resolution) {
            return bad("resolution", self.resolution.to_string(), "4 to 1024 nodes");
        }
        if !(self.margin.is_finite() && self.margin >= 0.0) {
            return bad(
                "margin",
                self.margin.to_string(),
                "a non-negative number of spacings",
            );
        }
        if !(self.band.is_finite() && self.band > 0.0) {
            return bad(
                "band",
                self.band.to_string(),
                "a positive number of spacings",
            );
        }
        Ok(())
    }

    fn grid_for(&self, geometry: &Geometry) -> Result<GridSpec> {
        let bounds = geometry.bounding_box().ok_or(Error::InvalidParameter {
            name: "geometry",
            value: "no points".into(),
            expected: "a non-empty point set or mesh".into(),
        })?;
        let rough = GridSpec::covering(bounds, self.resolution, 0.0)?;
        Ok(GridSpec::covering(
            bounds,
            self.resolution,
            self.margin * rough.spacing,
        )?)
    }
}

/// Samples the signed distance of `geometry`: meshes exactly, point sets through their MLS
/// surface (which needs normals).
///
/// An explicit kernel whose support radius is below the points' median spacing is refused
/// (`MlsError::InvalidParameter`): almost no point would have a neighbour in reach, the
/// surface would be undefined nearly everywhere, and the grid would fall back to distances
/// to single samples.
pub fn signed_distance(geometry: &Geometry, params: &FieldParams) -> Result<SdfGrid> {
    params.validate()?;
    let spec = params.grid_for(geometry)?;
    let band = params.band * spec.spacing;
    let surface: Box<dyn Surface> = match geometry {
        Geometry::Mesh(mesh) => Box::new(MeshSurface::new(mesh)?),
        Geometry::Points(points) => {
            let mut mls = MlsParams::default();
            if let Some(h) = params.kernel {
                mls = mls.kernel(h);
            }
            let surface = MlsSurface::new(points, &mls)?;
            if params.kernel.is_some() {
                let spacing = surface.index().median_spacing()?;
                if surface.support_radius() < spacing {
                    return Err(MlsError::InvalidParameter {
                        name: "kernel",
                        value: format!(
                            "{} (support radius {}, the points' median spacing {spacing})",
                            surface.kernel(),
                            surface.support_radius()
                        ),
                        expected: "a support radius at least the points' median spacing",
                    }
                    .into());
                }
            }
            Box::new(surface)
        }
    };
    Ok(SdfGrid::from_surface(surface.as_ref(), &spec, band)?)
}

/// Stage: geometry → signed distance grid.
#[derive(Debug, Clone, Default)]
pub struct SignedDistance {
    /// The parameters used.
    pub params: FieldParams,
}

impl Stage for SignedDistance {
    type Input = Geometry;
    type Output = SdfGrid;
    type Error = Error;

    fn name(&self) -> &str {
        "signed distance"
    }

    fn run(&self, input: Geometry, ctx: &mut RunContext) -> Result<SdfGrid> {
        ctx.check_cancelled()?;
        ctx.report(self.name(), 0, Some(1));
        let sdf = signed_distance(&input, &self.params)?;
        ctx.report(self.name(), 1, Some(1));
        Ok(sdf)
    }
}

/// Stage: oriented points → closed mesh (MLS surface → SDF grid → iso-surface).
///
/// ```
/// use geosynth::reconstruct::{FieldParams, Reconstruct};
/// use geosynth::{fixtures, RunContext, Stage};
///
/// let points = fixtures::sphere_points(3000)?;
/// let stage = Reconstruct { params: FieldParams::default().resolution(32) };
/// let mesh = stage.run(points, &mut RunContext::new(0))?;
/// let r: f32 = mesh.positions().iter().map(|p| p.length()).sum::<f32>() / mesh.vertex_count() as f32;
/// assert!((r - 1.0).abs() < 0.02);
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Default)]
pub struct Reconstruct {
    /// The parameters used.
    pub params: FieldParams,
}

impl Stage for Reconstruct {
    type Input = PointSet;
    type Output = TriMesh;
    type Error = Error;

    fn name(&self) -> &str {
        "reconstruct"
    }

    fn run(&self, input: PointSet, ctx: &mut RunContext) -> Result<TriMesh> {
        ctx.check_cancelled()?;
        let sdf = ctx.timed("reconstruct: distance field", |_| {
            signed_distance(&Geometry::Points(input), &self.params)
        })?;
        ctx.check_cancelled()?;
        ctx.timed("reconstruct: iso-surface", |_| Ok(sdf_isosurface(&sdf)?))
    }
}
