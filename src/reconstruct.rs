//! Surfaces from oriented points and distance fields from any geometry, as stages.
//!
//! [`Reconstruct`] turns an oriented point set into a closed mesh: MLS point-set surface
//! ([`crate::mls`]) → signed distance grid over the points' box ([`crate::sdf`]) → zero
//! iso-surface. [`Remesh`] does the same for a mesh through its own exact distance: a
//! closed remesh at the grid's resolution (an open or holed mesh closed where its sign rule
//! closes it). [`SignedDistance`] samples a point set (through its MLS surface) or a mesh
//! (exactly) into an [`SdfGrid`].
//!
//! The zero sets are extracted with [`distance_field::sdf_isosurface_of`]: where a sign
//! rule other than the nearest surface's side (winding numbers, pseudo-normals where
//! pieces meet) changes the sign away from the surface, the crossing is looked for along
//! its grid edge instead of interpolated, so the surface follows the sign's boundary
//! instead of a staircase of the grid.

use distance_field::{
    FarSigns, GridSpec, MeshSign, MeshSurface, PointSign, PointWinding, SdfGrid, WindingSigned,
    sdf_isosurface_of,
};
use glam::Vec3;
use mls_surface::{MlsError, MlsParams, MlsSurface};
use pointset_core::io::Geometry;
use pointset_core::{Aabb, DisjointSets, KdIndex, PointSet, RunContext, Stage, Surface, TriMesh};
use rayon::prelude::*;

use crate::{Error, Result};

/// Parameters of [`Reconstruct`] and [`SignedDistance`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct FieldParams {
    /// Grid nodes along the longest side of the box; default 96.
    pub resolution: usize,
    /// MLS kernel size `h` for point sets; default estimated (see [`MlsParams`]).
    pub kernel: Option<f32>,
    /// Margin around the geometry's box, in grid spacings, at most half the resolution;
    /// default 3.
    pub margin: f32,
    /// Distances are clamped to this many grid spacings (more than 1); default 4.
    pub band: f32,
    /// How a mesh's distances are signed; default [`MeshSign::PseudoNormal`].
    pub mesh_sign: MeshSign,
    /// How a point set's distances (to its MLS surface) are signed; default
    /// [`PointSign::Implicit`]. [`PointSign::WindingNumber`] keeps closed objects with
    /// thin parts or stray normals whole (the chameleon of the shared data).
    pub point_sign: PointSign,
}

impl Default for FieldParams {
    fn default() -> Self {
        Self {
            resolution: 96,
            kernel: None,
            margin: 3.0,
            band: 4.0,
            mesh_sign: MeshSign::default(),
            point_sign: PointSign::default(),
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

    /// Sets the margin around the geometry's box, in grid spacings (default 3).
    pub fn margin(mut self, spacings: f32) -> Self {
        self.margin = spacings;
        self
    }

    /// Sets the clamp of the distances, in grid spacings (default 4).
    pub fn band(mut self, spacings: f32) -> Self {
        self.band = spacings;
        self
    }

    /// Sets how a mesh's distances are signed (default [`MeshSign::PseudoNormal`]).
    pub fn mesh_sign(mut self, sign: MeshSign) -> Self {
        self.mesh_sign = sign;
        self
    }

    /// Sets how a point set's distances are signed (default [`PointSign::Implicit`]).
    ///
    /// ```
    /// use geosynth::reconstruct::{FieldParams, Reconstruct};
    /// use geosynth::sdf::PointSign;
    /// use geosynth::{fixtures, RunContext, Stage};
    ///
    /// // A closed sphere whose every 25th normal faces inward, as scans and estimated
    /// // normals have them: the MLS surface's own sign breaks it into pieces.
    /// let sphere = fixtures::sphere_points(4000)?;
    /// let normals = sphere.normals().ok_or("normals")?.iter().enumerate()
    ///     .map(|(i, n)| if i % 25 == 0 { -*n } else { *n })
    ///     .collect();
    /// let points = sphere.with_normals(normals)?;
    /// let params = FieldParams::default().resolution(48);
    /// let pieces = |params: FieldParams| -> Result<usize, geosynth::Error> {
    ///     let mesh = Reconstruct { params }.run(points.clone(), &mut RunContext::new(0))?;
    ///     Ok(mesh.topology().components)
    /// };
    /// assert!(pieces(params.clone())? > 1);
    /// // The points' winding number outvotes the stray normals.
    /// assert_eq!(pieces(params.point_sign(PointSign::WindingNumber))?, 1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn point_sign(mut self, sign: PointSign) -> Self {
        self.point_sign = sign;
        self
    }

    /// Checks ranges: resolution 4..=1024, a non-negative margin up to half the resolution,
    /// a band over 1 spacing.
    pub fn validate(&self) -> Result<()> {
        let bad = Error::invalid::<()>;
        if !(4..=1024).contains(&self.resolution) {
            return bad("resolution", self.resolution.to_string(), "4 to 1024 nodes");
        }
        if let Some(h) = self.kernel
            && !(h.is_finite() && h > 0.0)
        {
            return bad("kernel", h.to_string(), "a positive length");
        }
        if !(self.margin.is_finite() && self.margin >= 0.0) {
            return bad(
                "margin",
                self.margin.to_string(),
                "a non-negative number of spacings",
            );
        }
        if self.margin > self.resolution as f32 / 2.0 {
            // The resolution that would hold this margin, where one is accepted.
            let fitting = (2.0 * self.margin).ceil();
            let or_resolution = if fitting <= 1024.0 {
                format!(" (or a resolution of at least {fitting} for this margin)")
            } else {
                String::new()
            };
            return bad(
                "margin",
                self.margin.to_string(),
                &format!(
                    "at most half the resolution, {} spacings{or_resolution}: a wider margin \
                     leaves the geometry less than half the grid (a margin of 1e30 spacings \
                     made it smaller than one spacing, and the field never crossed zero)",
                    self.resolution as f32 / 2.0,
                ),
            );
        }
        if !(self.band.is_finite() && self.band > 1.0) {
            return bad(
                "band",
                self.band.to_string(),
                "more than 1 spacing (far nodes take their sign from neighbours within one)",
            );
        }
        Ok(())
    }

    /// The grid [`signed_distance`] samples `geometry` on: [`FieldParams::resolution`]
    /// nodes along the longest side of its box, grown by [`FieldParams::margin`] spacings.
    /// Its node count tells what a run will hold before it starts. Errors: a geometry
    /// whose points all coincide, or the grid's own range errors.
    pub fn grid_for(&self, geometry: &Geometry) -> Result<GridSpec> {
        let bounds = geometry.bounding_box().ok_or(Error::InvalidParameter {
            name: "geometry",
            value: "no points".into(),
            expected: "a non-empty point set or mesh".into(),
        })?;
        if bounds.extent().max_element() <= 0.0 {
            return Error::invalid(
                "geometry",
                format!("{} positions, all at one point", geometry.points().len()),
                "positions spread over a box of some size (one point has no surface to sample)",
            );
        }
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
    signed_distance_in(geometry, params, &mut RunContext::new(0))
}

/// [`signed_distance`] within a run: the grid's layers are reported as they are sampled
/// (stage [`distance_field::SAMPLING_STAGE`]), and a cancelled run stops within a few
/// layers with an error for which [`Error::is_cancelled`] holds. The run's timings get
/// [`SURFACE_TIMING`] (the mesh's or the points' search structures) and
/// [`SAMPLING_TIMING`] (the grid).
pub fn signed_distance_in(
    geometry: &Geometry,
    params: &FieldParams,
    ctx: &mut RunContext,
) -> Result<SdfGrid> {
    let (surface, spec) = ctx.timed(SURFACE_TIMING, |_| surface_for(geometry, params))?;
    ctx.timed(SAMPLING_TIMING, |ctx| {
        field_of(surface.as_ref(), &spec, params, ctx)
    })
}

/// The timing [`signed_distance_in`] records for building the surface it samples: a
/// mesh's bounding-volume hierarchy, or the points' index and MLS surface (and their
/// winding-number hierarchy when they are signed by it).
pub const SURFACE_TIMING: &str = "signed distance: surface";

/// The timing [`signed_distance_in`] records for sampling the grid.
pub const SAMPLING_TIMING: &str = "signed distance: sampling";

/// The surface [`signed_distance`] samples for `geometry`: the mesh, or the points' MLS
/// surface, each signed as `params` say, and the grid it is sampled on. Errors as
/// [`signed_distance`]'s; the grid's own (no points, all at one point) come first.
fn surface_for<'a>(
    geometry: &'a Geometry,
    params: &FieldParams,
) -> Result<(Box<dyn Surface + 'a>, GridSpec)> {
    params.validate()?;
    let spec = params.grid_for(geometry)?;
    let surface: Box<dyn Surface + 'a> = match geometry {
        Geometry::Mesh(mesh) => Box::new(MeshSurface::new(mesh)?.with_sign(params.mesh_sign)),
        Geometry::Points(points) => {
            let mls = MlsParams::default().with_kernel(params.kernel);
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
            match params.point_sign {
                PointSign::Implicit => Box::new(surface),
                PointSign::WindingNumber => {
                    let winding = PointWinding::with_index(points, surface.index())?;
                    Box::new(WindingSigned::new(surface, winding))
                }
            }
        }
    };
    Ok((surface, spec))
}

/// `surface` sampled on `spec`, within `params`' band.
fn field_of(
    surface: &dyn Surface,
    spec: &GridSpec,
    params: &FieldParams,
    ctx: &mut RunContext,
) -> Result<SdfGrid> {
    let band = params.band * spec.spacing;
    Ok(SdfGrid::from_surface_in(
        surface,
        spec,
        band,
        FarSigns::default(),
        ctx,
    )?)
}

/// Stage: geometry → signed distance grid.
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
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
        signed_distance_in(&input, &self.params, ctx)
    }
}

/// Stage: oriented points → closed mesh (MLS surface → SDF grid → iso-surface).
///
/// Errors: those of [`signed_distance`], and [`Error::NoSurface`] when the field never
/// crosses zero (an empty mesh is not a reconstruction).
///
/// Progress: the field's layers as they are sampled ([`distance_field::SAMPLING_STAGE`]),
/// then [`ISO_SURFACE_STAGE`]. A cancelled run stops within a few layers
/// ([`Error::is_cancelled`]).
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
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
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
        zero_set("reconstruct", &Geometry::Points(input), &self.params, ctx)
    }
}

/// Stage: a mesh → a closed mesh: the zero set of the mesh's own signed distance (exact,
/// signed by [`FieldParams::mesh_sign`]) on a grid over its box, as [`Reconstruct`] does
/// for points. The result is closed at the grid's resolution: a watertight copy of a
/// closed mesh; an open or holed one closed where its sign rule closes it. With
/// [`MeshSign::PseudoNormal`] an open sheet keeps a side, and its zero set runs on past
/// the border to the grid's sides ([`trim_to_mesh`] cuts it back); with
/// [`MeshSign::WindingNumber`] a nearly closed solid (a scan with holes) comes out whole.
/// [`FieldParams::kernel`] and [`FieldParams::point_sign`] are for point sets and unused.
///
/// Errors: those of [`signed_distance`], and [`Error::NoSurface`] when the field never
/// crosses zero.
///
/// ```
/// use geosynth::reconstruct::{FieldParams, Remesh};
/// use geosynth::{fixtures, RunContext, Stage};
///
/// // An icosphere of 80 flat faces comes back closed, its vertices on the faces.
/// let coarse = fixtures::icosphere_mesh(1)?;
/// let stage = Remesh { params: FieldParams::default().resolution(40) };
/// let remeshed = stage.run(coarse, &mut RunContext::new(0))?;
/// assert!(remeshed.topology().is_closed_manifold());
/// assert!(remeshed.vertex_count() > 1000);
/// let r = |p: &glam::Vec3| p.length();
/// assert!(remeshed.positions().iter().all(|p| (0.78..1.01).contains(&r(p))));
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct Remesh {
    /// The parameters used.
    pub params: FieldParams,
}

impl Stage for Remesh {
    type Input = TriMesh;
    type Output = TriMesh;
    type Error = Error;

    fn name(&self) -> &str {
        "remesh"
    }

    fn run(&self, input: TriMesh, ctx: &mut RunContext) -> Result<TriMesh> {
        zero_set("remesh", &Geometry::Mesh(input), &self.params, ctx)
    }
}

/// The zero set of `geometry`'s signed distance on the grid `params` describe, timed as
/// `stage: distance field` and `stage: iso-surface`.
fn zero_set(
    stage: &str,
    geometry: &Geometry,
    params: &FieldParams,
    ctx: &mut RunContext,
) -> Result<TriMesh> {
    let (surface, sdf) = ctx.timed(&format!("{stage}: distance field"), |ctx| {
        let (surface, spec) = surface_for(geometry, params)?;
        let sdf = field_of(surface.as_ref(), &spec, params, ctx)?;
        Ok::<_, Error>((surface, sdf))
    })?;
    ctx.check_cancelled()?;
    let source = match geometry {
        Geometry::Mesh(_) => "the mesh",
        Geometry::Points(_) => "the MLS surface of the points",
    };
    ctx.report(ISO_SURFACE_STAGE, 0, Some(1));
    let mesh = ctx.timed(&format!("{stage}: iso-surface"), |_| {
        surface_of(&sdf, surface.as_ref(), source)
    })?;
    ctx.report(ISO_SURFACE_STAGE, 1, Some(1));
    Ok(mesh)
}

/// The stage name [`Reconstruct`] and [`Remesh`] report the extraction of the zero set
/// under (0 of 1, then 1 of 1), after the field's layers
/// ([`distance_field::SAMPLING_STAGE`]).
pub const ISO_SURFACE_STAGE: &str = "iso-surface";

/// Median sample spacings from every point beyond which [`ReconstructOpen`] cuts by
/// default (`geosynth reconstruct --trim` alone). Below about 2 the gaps of a random
/// sampling join up with the border and the sheet falls apart.
pub const DEFAULT_TRIM_SPACINGS: f32 = 2.0;

/// Stage: oriented points of an open surface — a scan, a terrain, a quilted sheet → a mesh
/// cut back to the samples. [`Reconstruct`], then [`trim_to_samples`] with a limit of
/// `trim` median sample spacings (nearest-neighbour distances); what
/// `geosynth reconstruct --trim` runs.
///
/// Errors: those of [`Reconstruct`]; `trim` not positive and finite.
///
/// ```
/// use geosynth::reconstruct::{FieldParams, Reconstruct, ReconstructOpen};
/// use geosynth::{fixtures, RunContext, Stage};
///
/// // A terrain over [0, 2]²: closed, its zero set runs on to the grid's sides; open, it
/// // ends where the samples do.
/// let terrain = fixtures::heightfield_points(40, 2.0, 7)?;
/// let params = FieldParams::default().resolution(40);
/// let closed = Reconstruct { params: params.clone() }.run(terrain.clone(), &mut RunContext::new(0))?;
/// let open = ReconstructOpen { params, ..Default::default() }.run(terrain, &mut RunContext::new(0))?;
/// let reach = |m: &geosynth::core::TriMesh| m.bounding_box().map(|b| b.extent().x);
/// assert!(reach(&open) < reach(&closed) && open.face_count() < closed.face_count());
/// assert_eq!(open.topology().components, 1);
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct ReconstructOpen {
    /// The parameters of the field.
    pub params: FieldParams,
    /// How far the mesh may run from every sample, in median sample spacings; default
    /// [`DEFAULT_TRIM_SPACINGS`].
    pub trim: f32,
}

impl Default for ReconstructOpen {
    fn default() -> Self {
        Self {
            params: FieldParams::default(),
            trim: DEFAULT_TRIM_SPACINGS,
        }
    }
}

impl Stage for ReconstructOpen {
    type Input = PointSet;
    type Output = TriMesh;
    type Error = Error;

    fn name(&self) -> &str {
        "reconstruct open"
    }

    fn run(&self, input: PointSet, ctx: &mut RunContext) -> Result<TriMesh> {
        if !(self.trim.is_finite() && self.trim > 0.0) {
            return Error::invalid("trim", self.trim, "a positive number of spacings");
        }
        // One index of the samples, for their spacing and for the trim.
        let samples = KdIndex::new(input.positions())?;
        let spacing = samples.median_spacing()?;
        let mesh = Reconstruct {
            params: self.params.clone(),
        }
        .run(input, ctx)?;
        ctx.timed("trim", |_| {
            trim_to_indexed_samples(&mesh, &samples, self.trim * spacing)
        })
        .map_err(|e| as_trim_error(e, self.trim, spacing))
    }
}

/// A trim distance refused for leaving no face ([`trim_to_samples`], [`trim_to_mesh`]),
/// told as the `trim` in `spacing`s that gave it; other errors pass through.
fn as_trim_error(error: Error, trim: f32, spacing: f32) -> Error {
    match error {
        Error::InvalidParameter {
            name: "max_distance",
            ..
        } => Error::InvalidParameter {
            name: "trim",
            value: trim.to_string(),
            expected: format!(
                "spacings that keep part of the surface (no corner of any face lies within \
                 {} of the samples; the default is {DEFAULT_TRIM_SPACINGS})",
                trim * spacing
            ),
        },
        other => other,
    }
}

/// [`trim_to_mesh`] with the distance in `trim` median vertex spacings of `source`, as
/// [`ReconstructOpen`] trims in sample spacings: `geosynth reconstruct MESH --trim`.
///
/// Errors: those of [`trim_to_mesh`], a trim that leaves no face as `trim`.
pub fn trim_to_mesh_spacings(mesh: &TriMesh, source: &TriMesh, trim: f32) -> Result<TriMesh> {
    let spacing = KdIndex::new(source.positions())?.median_spacing()?;
    trim_to_mesh(mesh, source, trim * spacing).map_err(|e| as_trim_error(e, trim, spacing))
}

/// The zero set of `sdf`, sampled from `surface` ([`sdf_isosurface_of`]), or
/// [`Error::NoSurface`] when the field never crosses zero (an empty mesh is not a
/// reconstruction); `source` names what was sampled.
fn surface_of(sdf: &SdfGrid, surface: &dyn Surface, source: &str) -> Result<TriMesh> {
    let mesh = sdf_isosurface_of(sdf, surface)?;
    if mesh.face_count() == 0 {
        let (lo, hi) = sdf.distances()?.value_range();
        let [x, y, z] = sdf.grid().dims();
        return Err(Error::NoSurface {
            reason: format!(
                "the signed distance on the {x}x{y}x{z} grid never crosses zero (values \
                 {lo} to {hi}); {source} could not be sampled there"
            ),
        });
    }
    Ok(mesh)
}

/// `mesh` without the parts that run away from the samples it was reconstructed from. The
/// zero set of an open scan's distance field does not end where the scan does: the MLS
/// surface carries on past the scan's border to the edge of the grid and folds back there.
///
/// A face is *far* when all its corners lie farther than `max_distance` from every
/// sample. Far faces that share corners form regions; a region that leaves the samples'
/// bounding box (grown by `max_distance`) runs on past the scan, and is cut. Far regions
/// inside it — gaps in the sampling the reconstruction bridged — stay, so a randomly
/// sampled sheet is not left full of pinholes, and a scan's holes stay closed.
/// The vertices no kept face uses are dropped; normals and UVs are kept (UVs were dropped
/// before the twenty-eighth session). A closed surface sampled all over loses nothing.
///
/// Errors: no samples, a non-finite sample, `max_distance` not positive, or so small
/// that no face is left.
///
/// ```
/// use geosynth::reconstruct::{FieldParams, Reconstruct, trim_to_samples};
/// use geosynth::{fixtures, RunContext, Stage};
///
/// let points = fixtures::sphere_points(3000)?;
/// let stage = Reconstruct { params: FieldParams::default().resolution(32) };
/// let mesh = stage.run(points.clone(), &mut RunContext::new(0))?;
/// let spacing = geosynth::core::KdIndex::new(points.positions())?.median_spacing()?;
/// let trimmed = trim_to_samples(&mesh, points.positions(), 2.0 * spacing)?;
/// assert_eq!(trimmed.face_count(), mesh.face_count());
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn trim_to_samples(mesh: &TriMesh, samples: &[Vec3], max_distance: f32) -> Result<TriMesh> {
    trim_to_indexed_samples(mesh, &KdIndex::new(samples)?, max_distance)
}

/// [`trim_to_samples`] with the samples already indexed.
fn trim_to_indexed_samples(mesh: &TriMesh, index: &KdIndex, max_distance: f32) -> Result<TriMesh> {
    check_trim_distance(max_distance)?;
    let Some(samples_box) = Aabb::from_points(index.points()) else {
        return Error::invalid("samples", "none", "at least one sample");
    };
    let limit = max_distance * max_distance;
    let near = mesh
        .positions()
        .par_iter()
        .map(|&p| {
            Ok(index
                .nearest_one(p)?
                .is_some_and(|n| n.distance_squared <= limit))
        })
        .collect::<Result<Vec<bool>>>()?;
    cut_runaway_regions(
        mesh,
        &near,
        samples_box.inflated(max_distance),
        max_distance,
    )
}

/// `mesh` (a [`Remesh`] of `source`) without the parts that run away from `source`: what
/// [`trim_to_samples`] does for samples, with the distance to `source`'s surface in place
/// of the distance to the nearest sample. A face is far when all its corners lie farther
/// than `max_distance` from `source`; far regions that leave `source`'s box (grown by
/// `max_distance`) are cut, and those inside it (holes the remesh closed) stay.
///
/// Errors: `source` without faces, `max_distance` not positive, or so small that no face
/// is left.
///
/// ```
/// use geosynth::reconstruct::{trim_to_mesh, FieldParams, Remesh};
/// use geosynth::core::{PointSet, TriMesh};
/// use geosynth::{RunContext, Stage};
/// use glam::Vec3;
///
/// // A unit square of two triangles: its zero set runs on to the sides of a grid with
/// // a margin of 8 spacings, about 0.42; the trim cuts it back to the faces with a corner
/// // within 0.1 of the square (the grid's spacing is about 0.05).
/// let corners = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
/// let square = TriMesh::new(PointSet::new(corners)?, vec![[0, 1, 2], [0, 2, 3]])?;
/// let params = FieldParams::default().resolution(20).margin(8.0);
/// let remeshed = Remesh { params }.run(square.clone(), &mut RunContext::new(0))?;
/// let trimmed = trim_to_mesh(&remeshed, &square, 0.1)?;
/// let width = |m: &TriMesh| m.bounding_box().map(|b| b.extent().x).unwrap_or(0.0);
/// assert!(width(&remeshed) > 1.7, "{}", width(&remeshed));
/// assert!((1.0..1.4).contains(&width(&trimmed)), "{}", width(&trimmed));
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn trim_to_mesh(mesh: &TriMesh, source: &TriMesh, max_distance: f32) -> Result<TriMesh> {
    check_trim_distance(max_distance)?;
    let surface = MeshSurface::new(source)?;
    let Some(source_box) = source.bounding_box() else {
        return Error::invalid("source", "no vertices", "a mesh with faces");
    };
    let near: Vec<bool> = mesh
        .positions()
        .par_iter()
        .map(|&p| {
            surface
                .closest_point(p)
                .is_some_and(|c| c.point.distance(p) <= max_distance)
        })
        .collect();
    cut_runaway_regions(mesh, &near, source_box.inflated(max_distance), max_distance)
}

/// Refuses a trim distance that is not a positive length.
fn check_trim_distance(max_distance: f32) -> Result<()> {
    if max_distance.is_finite() && max_distance > 0.0 {
        Ok(())
    } else {
        Error::invalid(
            "max_distance",
            max_distance.to_string(),
            "a positive length",
        )
    }
}

/// `mesh` without its far regions that leave `reach`. A face is far when none of its
/// corners is `near`; far faces that share corners form a region. A region with a corner
/// outside `reach` (the source's box, grown by the trim distance) runs on past the source;
/// one that stays inside fills a gap in it and is kept. An error when nothing is left of a
/// mesh with faces.
fn cut_runaway_regions(
    mesh: &TriMesh,
    near: &[bool],
    reach: Aabb,
    max_distance: f32,
) -> Result<TriMesh> {
    let triangles = mesh.triangles();
    let is_far = |t: &[u32; 3]| t.iter().all(|&v| !near[v as usize]);
    // Regions of far faces: their corners joined face by face.
    let mut regions = DisjointSets::new(mesh.vertex_count());
    for t in triangles.iter().filter(|t| is_far(t)) {
        regions.join(t[0], t[1]);
        regions.join(t[1], t[2]);
    }
    let mut runaway = vec![false; mesh.vertex_count()];
    for t in triangles.iter().filter(|t| is_far(t)) {
        if t.iter()
            .any(|&v| !reach.contains(mesh.positions()[v as usize]))
        {
            let root = regions.root(t[0]);
            runaway[root as usize] = true;
        }
    }
    let kept =
        mesh.with_triangles_kept(|_, t| !(is_far(t) && runaway[regions.root(t[0]) as usize]))?;
    if kept.face_count() == 0 && mesh.face_count() > 0 {
        // No corner of any face was near: nothing of the surface is left to return.
        return Error::invalid(
            "max_distance",
            max_distance,
            "a distance that keeps part of the surface (no corner of any face lies that near)",
        );
    }
    Ok(kept)
}

/// What [`drop_small_pieces`] leaves.
#[derive(Debug, Clone)]
pub struct PiecesKept {
    /// The mesh without the small pieces (their vertices dropped too).
    pub mesh: TriMesh,
    /// How many pieces went.
    pub dropped: usize,
}

/// The mesh without its small pieces: the connected pieces (faces joined by shared
/// corners) whose bounding box's diagonal is shorter than `min_diagonal`.
///
/// Where a surface is undersampled — the steep sides of a height field's features, parts
/// of a scan thinner than the kernel — its MLS surface can close into small bubbles beside
/// the real one, and the distance field's zero set with it (docs/mls-surface.md, "Small
/// pieces").
/// This removes such pieces, as MeshLab's "remove isolated pieces (wrt diameter)" does. It
/// removes real parts that small as well, so it is a choice, never a default; `0` keeps
/// every piece. Normals and UVs are kept.
///
/// Errors: `min_diagonal` negative or not finite.
///
/// ```
/// use geosynth::fixtures::torus_mesh;
/// use geosynth::reconstruct::drop_small_pieces;
/// use geosynth::core::{PointSet, TriMesh};
///
/// // A torus 2.6 wide and a small one 0.26 wide beside it, as one mesh.
/// let (big, small) = (torus_mesh(32, 16, 1.0, 0.3)?, torus_mesh(16, 8, 0.1, 0.03)?);
/// let offset = big.vertex_count() as u32;
/// let mut positions = big.positions().to_vec();
/// positions.extend(small.positions().iter().map(|p| *p + glam::Vec3::X * 3.0));
/// let mut faces = big.triangles().to_vec();
/// faces.extend(small.triangles().iter().map(|t| t.map(|v| v + offset)));
/// let both = TriMesh::new(PointSet::new(positions)?, faces)?;
///
/// let kept = drop_small_pieces(&both, 1.0)?;
/// assert_eq!((kept.dropped, kept.mesh.face_count()), (1, big.face_count()));
/// assert_eq!(drop_small_pieces(&both, 0.0)?.mesh.face_count(), both.face_count());
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn drop_small_pieces(mesh: &TriMesh, min_diagonal: f32) -> Result<PiecesKept> {
    if !(min_diagonal.is_finite() && min_diagonal >= 0.0) {
        return Error::invalid("min_diagonal", min_diagonal, "a length ≥ 0");
    }
    let triangles = mesh.triangles();
    let mut pieces = DisjointSets::new(mesh.vertex_count());
    for t in triangles {
        pieces.join(t[0], t[1]);
        pieces.join(t[0], t[2]);
    }
    // Each piece's box, kept at its root vertex.
    let mut boxes: Vec<Option<Aabb>> = vec![None; mesh.vertex_count()];
    let roots: Vec<u32> = triangles.iter().map(|t| pieces.root(t[0])).collect();
    for (t, &root) in triangles.iter().zip(&roots) {
        let slot = &mut boxes[root as usize];
        for &v in t {
            let p = mesh.positions()[v as usize];
            *slot = Some(slot.map_or(Aabb::new(p, p), |b| b.including(p)));
        }
    }
    let diagonals: Vec<f32> = boxes
        .iter()
        .map(|b| b.map_or(f32::NAN, |b| b.diagonal()))
        .collect();
    // Vertices that root no piece hold NaN, which is never small.
    let small = |d: f32| d < min_diagonal;
    let dropped = diagonals.iter().filter(|&&d| small(d)).count();
    Ok(PiecesKept {
        mesh: mesh.with_triangles_kept(|i, _| !small(diagonals[roots[i] as usize]))?,
        dropped,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec3, Vec4};
    use pointset_core::Grid3;

    #[test]
    fn an_open_reconstruction_refuses_a_trim_that_is_no_length() {
        let terrain = crate::fixtures::heightfield_points(12, 1.0, 3).unwrap();
        for trim in [0.0, -2.0, f32::NAN, f32::INFINITY] {
            let stage = ReconstructOpen {
                trim,
                ..Default::default()
            };
            let err = stage
                .run(terrain.clone(), &mut RunContext::new(0))
                .unwrap_err();
            assert!(
                matches!(err, Error::InvalidParameter { name: "trim", .. }),
                "{err}"
            );
        }
        // A trim so short that no face keeps a corner near a sample cuts the whole sheet
        // away: refused as a trim, not returned as an empty mesh.
        let stage = ReconstructOpen {
            trim: 1e-30,
            ..Default::default()
        };
        let err = stage
            .run(terrain.clone(), &mut RunContext::new(0))
            .unwrap_err();
        let message = err.to_string();
        assert!(
            matches!(err, Error::InvalidParameter { name: "trim", .. })
                && message.contains("keep part of the surface"),
            "{message}"
        );
    }

    #[test]
    fn a_closed_remesh_loses_nothing_to_the_trim_and_a_trim_needs_a_length() {
        let sphere = crate::fixtures::icosphere_mesh(2).unwrap();
        let stage = Remesh {
            params: FieldParams::default().resolution(24),
        };
        let closed = stage.run(sphere.clone(), &mut RunContext::new(0)).unwrap();
        let spacing = KdIndex::new(sphere.positions())
            .unwrap()
            .median_spacing()
            .unwrap();
        let trimmed = trim_to_mesh(&closed, &sphere, 0.5 * spacing).unwrap();
        assert_eq!(trimmed.triangles(), closed.triangles());
        for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            let err = trim_to_mesh(&closed, &sphere, bad).unwrap_err();
            assert!(err.to_string().contains("max_distance"), "{err}");
        }
    }

    #[test]
    fn a_mesh_trim_in_spacings_that_leaves_nothing_is_refused_as_a_trim() {
        // A unit square remeshed runs out to the grid's sides; trimmed at a tenth of a
        // vertex spacing it keeps its middle. Against the square lifted by 0.5 no face
        // is near at 1e-30 spacings, which is refused by name.
        let corners = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let square =
            TriMesh::new(PointSet::new(corners).unwrap(), vec![[0, 1, 2], [0, 2, 3]]).unwrap();
        let params = FieldParams::default().resolution(20).margin(8.0);
        let remeshed = Remesh { params }
            .run(square.clone(), &mut RunContext::new(0))
            .unwrap();
        let kept = trim_to_mesh_spacings(&remeshed, &square, 0.1).unwrap();
        assert!(kept.face_count() > 0 && kept.face_count() < remeshed.face_count());
        let lifted = TriMesh::new(
            PointSet::new(
                square
                    .positions()
                    .iter()
                    .map(|p| *p + Vec3::Z * 0.5)
                    .collect(),
            )
            .unwrap(),
            square.triangles().to_vec(),
        )
        .unwrap();
        let err = trim_to_mesh_spacings(&remeshed, &lifted, 1e-30).unwrap_err();
        assert!(
            matches!(err, Error::InvalidParameter { name: "trim", .. }),
            "{err}"
        );
    }

    #[test]
    fn pieces_shorter_than_the_diagonal_go_with_their_vertices() {
        // A unit right triangle (diagonal √2), one ten times larger, an unused vertex.
        let positions = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::new(5.0, 0.0, 0.0),
            Vec3::new(15.0, 0.0, 0.0),
            Vec3::new(5.0, 10.0, 0.0),
            Vec3::splat(100.0),
        ];
        let normals = (0..7)
            .map(|i| Vec3::new(i as f32, 0.0, 1.0).normalize())
            .collect();
        let uvs: Vec<glam::Vec2> = (0..7).map(|i| glam::Vec2::splat(i as f32)).collect();
        let points = PointSet::new(positions)
            .unwrap()
            .with_normals(normals)
            .unwrap();
        let mesh = TriMesh::new(points, vec![[0, 1, 2], [3, 4, 5]])
            .unwrap()
            .with_uvs(uvs)
            .unwrap();
        // A piece exactly as long as the limit stays.
        let all = drop_small_pieces(&mesh, 2f32.sqrt()).unwrap();
        assert_eq!((all.dropped, all.mesh.face_count()), (0, 2));
        assert_eq!(all.mesh.vertex_count(), 6);
        let big = drop_small_pieces(&mesh, 1.5).unwrap();
        assert_eq!(big.dropped, 1);
        assert_eq!(big.mesh.triangles(), &[[0, 1, 2]]);
        assert_eq!(big.mesh.positions(), &mesh.positions()[3..6]);
        assert_eq!(big.mesh.uvs().unwrap(), &mesh.uvs().unwrap()[3..6]);
        assert_eq!(
            big.mesh.vertices().normals().unwrap(),
            &mesh.vertices().normals().unwrap()[3..6]
        );
        assert_eq!(drop_small_pieces(&mesh, 15.0).unwrap().mesh.face_count(), 0);
        for bad in [f32::NAN, -1.0, f32::INFINITY] {
            let err = drop_small_pieces(&mesh, bad).unwrap_err();
            assert!(err.to_string().contains("min_diagonal"), "{err}");
        }
    }

    #[test]
    fn a_field_without_a_zero_crossing_is_no_surface_not_an_empty_mesh() {
        // The reconstruction once came out as an empty mesh that the CLI wrote as a
        // success (found with coordinates of 1e30, which are now refused first).
        let field = |value: f32| {
            let mut grid =
                Grid3::new([4, 4, 4], Vec3::ZERO, 1.0, Vec4::new(1.0, 0.0, 0.0, 1.0)).unwrap();
            // Node (1, 1, 1).
            grid.data_mut()[21].x = value;
            SdfGrid::from_grid(grid, 2.0).unwrap()
        };
        // A triangle far off: on one side of it everywhere near the grid, so it moves no
        // crossing.
        let corners = vec![
            Vec3::splat(100.0),
            Vec3::new(101.0, 100.0, 100.0),
            Vec3::Y + 100.0,
        ];
        let far = TriMesh::new(PointSet::new(corners).unwrap(), vec![[0, 1, 2]]).unwrap();
        let far = MeshSurface::new(&far).unwrap();
        let err = surface_of(&field(0.5), &far, "the field").unwrap_err();
        assert!(matches!(err, Error::NoSurface { .. }), "{err}");
        assert!(err.to_string().contains("never crosses zero"), "{err}");
        // One node inside: a small closed surface around it.
        assert!(
            surface_of(&field(-0.5), &far, "the field")
                .unwrap()
                .face_count()
                > 0
        );
    }
}
