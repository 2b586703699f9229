//! Geometry synthesis by distance-field block matching (paper 001; the `voxel-dfsynth`
//! crate), with the facade's exemplar files and the [`VoxelSynth`] stage.
//!
//! An exemplar is a closed mesh whose comments may give the box to sample
//! (`texture_box X0 Y0 Z0 X1 Y1 Z1`, as `geosynth fixtures` writes them); without one, the
//! mesh's bounding box is used. An NRRD volume is read as the solid where it is negative
//! ([`read_exemplar`]). Its signed distance field over that box, with
//! `source_resolution` samples along the longest side, is the synthesis source.
//!
//! ```
//! use geosynth::voxel::{VoxelExemplar, VoxelParams, VoxelSynth};
//! use geosynth::{fixtures, RunContext, Stage};
//!
//! let exemplar = VoxelExemplar::from(&fixtures::volumes::grid(1)?);
//! let stage = VoxelSynth {
//!     source_resolution: 16,
//!     params: VoxelParams::default().target_dims([24; 3]).levels(2).block(8),
//!     ..Default::default()
//! };
//! let out = stage.run(exemplar, &mut RunContext::new(0))?;
//! assert_eq!(out.synthesis.field.dims(), [24, 24, 24]);
//! assert!(out.isosurface.face_count() > 0 && out.copied.mesh.face_count() > 0);
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The stage runs in two halves, [`VoxelSynth::synthesize_field`] and
//! [`VoxelSynth::reconstruct`]; between them the meshes' sizes can be counted, to check
//! that they fit in memory before they are built (as `geosynth voxel` does):
//!
//! ```
//! use geosynth::voxel::{VoxelExemplar, VoxelParams, VoxelSynth, copied_triangle_count,
//!     isosurface_cells};
//! use geosynth::{fixtures, RunContext};
//!
//! let exemplar = VoxelExemplar::from(&fixtures::volumes::grid(1)?);
//! let stage = VoxelSynth {
//!     source_resolution: 16,
//!     params: VoxelParams::default().target_dims([24; 3]).levels(2).block(8),
//!     ..Default::default()
//! };
//! let mut ctx = RunContext::new(0);
//! let field = stage.synthesize_field(&exemplar, &mut ctx)?;
//! let copied = copied_triangle_count(&exemplar.mesh, &field.synthesis);
//! let cells = isosurface_cells(&field.synthesis, true);
//! let out = stage.reconstruct(&exemplar, field, &mut ctx)?;
//! assert_eq!(out.copied.copied_triangles, copied);
//! assert!(cells <= out.isosurface.face_count() && out.isosurface.face_count() <= 12 * cells);
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::path::Path;

use distance_field::{FarSigns, GridSpec, MeshSign, MeshSurface, SdfGrid, closed_isosurface, nrrd};
use glam::DVec3;
use pointset_core::io::{self, ReadOptions};
use pointset_core::{Aabb, RunContext, Stage, TriMesh};
pub use voxel_dfsynth::{
    BlockCopy, BlockMatcher, BoxMeans, BruteForce, CopiedMesh, FftMatcher, LevelReport, Match,
    MatcherKind, QualityParams, QuantizedField, RelaxParams, SearchTree, SubsampledSource,
    Synthesis, TreeStats, VoxelError, VoxelParams, VoxelQuality, block_level, copied_mesh,
    copied_triangle_count, evaluate, fft, isosurface_cells, isosurface_mesh, quantize_source,
    source_quantizer, synthesize, unit_gradient_fraction,
};

use crate::fixtures::volumes::VolumeExemplar;
use crate::quilt::texture_file_error;
use crate::{Error, Result};

/// A solid exemplar: a closed mesh and the box whose distance field is sampled.
///
/// Built by [`VoxelExemplar::new`] from a mesh of one's own, by [`read_exemplar`] from a
/// file, or from a generated solid (`VoxelExemplar::from(&fixtures::volumes::grid(1)?)`).
/// Its fields are public to read and to change; it is `#[non_exhaustive]`, so fields may
/// be added without breaking code outside the crate.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct VoxelExemplar {
    /// The mesh, its positions relative to [`Self::origin`].
    pub mesh: TriMesh,
    /// The sampled box, relative to [`Self::origin`].
    pub bounds: Aabb,
    /// Where the mesh's coordinates are measured from, in the file's frame (zero but for
    /// georeferenced files, see [`read_exemplar`]). The synthesized solid starts at the
    /// box's corner, so its meshes are written back with this origin
    /// (`pointset_core::io::WriteOptions::origin`).
    pub origin: DVec3,
    /// When the file stored such coordinates in single precision, the step of the grid
    /// they sit on (as [`crate::quilt::TextureFile::single_precision_step`]): recentring
    /// cannot restore what the file lost.
    pub single_precision_step: Option<f64>,
    /// What the file had that the reader could not keep
    /// ([`pointset_core::io::LoadedGeometry::notes`]: a PLY's extra elements, colours or
    /// texture coordinates that only some vertices or corners have, …); empty for
    /// generated exemplars and NRRD volumes.
    pub notes: Vec<String>,
}

impl VoxelExemplar {
    /// An exemplar from a closed mesh and the box to sample, in the same coordinates
    /// ([`Self::origin`] zero, no notes). Errors when the mesh has no triangles or the box
    /// is not finite or is flat along an axis.
    ///
    /// ```
    /// use geosynth::core::Aabb;
    /// use geosynth::voxel::VoxelExemplar;
    /// use glam::Vec3;
    ///
    /// let mesh = geosynth::fixtures::icosphere_mesh(2)?;
    /// let cube = Aabb::new(Vec3::splat(-1.5), Vec3::splat(1.5));
    /// let exemplar = VoxelExemplar::new(mesh.clone(), cube)?;
    /// assert_eq!(exemplar.mesh.face_count(), mesh.face_count());
    /// let flat = Aabb::new(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0));
    /// assert!(VoxelExemplar::new(mesh, flat).is_err());
    /// Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn new(mesh: TriMesh, bounds: Aabb) -> Result<Self> {
        if mesh.face_count() == 0 {
            return Err(Error::InvalidParameter {
                name: "exemplar mesh",
                value: format!("{} vertices, no triangles", mesh.vertices().len()),
                expected: "a closed mesh with triangles".into(),
            });
        }
        let extent = bounds.extent();
        if !(bounds.min.is_finite() && bounds.max.is_finite() && extent.min_element() > 0.0) {
            return Err(Error::InvalidParameter {
                name: "exemplar box",
                value: format!("{} to {}", bounds.min, bounds.max),
                expected: "finite corners and a positive extent along every axis".into(),
            });
        }
        Ok(Self {
            mesh,
            bounds,
            origin: DVec3::ZERO,
            single_precision_step: None,
            notes: Vec::new(),
        })
    }
}

impl From<&VolumeExemplar> for VoxelExemplar {
    fn from(v: &VolumeExemplar) -> Self {
        Self {
            mesh: v.mesh.clone(),
            bounds: v.bounds,
            origin: DVec3::ZERO,
            single_precision_step: None,
            notes: Vec::new(),
        }
    }
}

/// Reads an exemplar mesh (see the module docs).
///
/// A mesh far from its file's origin (georeferenced coordinates in the millions, where an
/// `f32` steps by a quarter unit or more) is read relative to a double-precision origin
/// (`pointset_core::io::ReadOptions::recentre_far`), so its distance field is sampled at
/// full precision; [`VoxelExemplar::origin`] says where.
///
/// An NRRD volume (`.nrrd`, as `geosynth sdf` writes one) is read as the solid where its
/// first channel is negative (inside, for a signed distance): the exemplar mesh is that
/// zero set, capped where the solid meets the volume's edge, and the box is the volume's.
pub fn read_exemplar(path: &Path) -> Result<VoxelExemplar> {
    if nrrd::is_nrrd_path(path) {
        return read_volume_exemplar(path);
    }
    let file_error = texture_file_error(path);
    let loaded = io::read_geometry_with(path, &ReadOptions::default().recentre_far(true))?;
    let mesh = match loaded.geometry {
        io::Geometry::Mesh(m) => m,
        io::Geometry::Points(_) => {
            return Err(file_error(
                "distance-field synthesis needs a mesh, not a point set: sample the point \
                 set's distance field into a volume first (`geosynth sdf POINTS.ply -o \
                 FIELD.nrrd`, with `--estimate-normals` for points without normals) and \
                 synthesize from that"
                    .into(),
            ));
        }
    };
    let described = crate::quilt::parse_texture_comments_at(&loaded.comments, loaded.origin)
        .map_err(file_error)?;
    let bounds = match described {
        Some((b, _)) => b,
        None => mesh
            .bounding_box()
            .ok_or_else(|| file_error("the mesh has no vertices".into()))?,
    };
    Ok(VoxelExemplar {
        single_precision_step: crate::quilt::single_precision_step(mesh.vertices(), loaded.origin),
        mesh,
        bounds,
        origin: loaded.origin,
        notes: loaded.notes,
    })
}

/// [`read_exemplar`] of an NRRD volume.
fn read_volume_exemplar(path: &Path) -> Result<VoxelExemplar> {
    let file_error = texture_file_error(path);
    let volume = nrrd::read_file(path)?;
    // A georeferenced field is stored relative to an origin, as mesh files are.
    let origin = io::far_origin(volume.origin, volume.far_corner());
    let grid = volume.scalar_grid_at(origin)?;
    if let Some(i) = grid.data().iter().position(|v| !v.is_finite()) {
        return Err(file_error(format!(
            "value {i} is {}; a solid needs finite values",
            grid.data()[i]
        )));
    }
    let largest = grid.data().iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let mesh = closed_isosurface(&grid, 0.0, largest + grid.spacing())?;
    if mesh.face_count() == 0 {
        return Err(file_error(
            "the field is negative nowhere: it holds no solid".into(),
        ));
    }
    let bounds = Aabb::new(
        (volume.origin - origin).as_vec3(),
        (volume.far_corner() - origin).as_vec3(),
    );
    Ok(VoxelExemplar {
        mesh,
        bounds,
        origin,
        single_precision_step: None,
        notes: Vec::new(),
    })
}

/// The exemplar's signed distance field with `resolution` samples along the box's longest
/// side, exact everywhere (the band is the box's diagonal), signed by `sign`
/// ([`MeshSign::WindingNumber`] for solids built from intersecting or nearly closed
/// pieces).
pub fn source_field(
    exemplar: &VoxelExemplar,
    resolution: usize,
    sign: MeshSign,
) -> Result<SdfGrid> {
    source_field_in(exemplar, resolution, sign, &mut RunContext::new(0))
}

/// [`source_field`] within a run: its layers are reported as they are sampled
/// ([`distance_field::SAMPLING_STAGE`]), and a cancelled run stops within a few layers
/// ([`Error::is_cancelled`]).
pub fn source_field_in(
    exemplar: &VoxelExemplar,
    resolution: usize,
    sign: MeshSign,
    ctx: &mut RunContext,
) -> Result<SdfGrid> {
    let spec = source_spec(exemplar, resolution)?;
    let surface = MeshSurface::new(&exemplar.mesh)?.with_sign(sign);
    let diagonal = exemplar.bounds.extent().length().max(2.0 * spec.spacing);
    let far_signs = FarSigns::default();
    Ok(SdfGrid::from_surface_in(
        &surface, &spec, diagonal, far_signs, ctx,
    )?)
}

/// Samples along x, y, z of [`source_field`] at `resolution`; the same range errors.
pub fn source_dims(exemplar: &VoxelExemplar, resolution: usize) -> Result<[usize; 3]> {
    Ok(source_spec(exemplar, resolution)?.dims)
}

/// The grid of [`source_field`]: `resolution` (4 to 512) samples along the box's longest
/// side.
fn source_spec(exemplar: &VoxelExemplar, resolution: usize) -> Result<GridSpec> {
    if !(4..=512).contains(&resolution) {
        return Err(Error::InvalidParameter {
            name: "source resolution",
            value: resolution.to_string(),
            expected: "4 to 512 samples".into(),
        });
    }
    Ok(GridSpec::covering(exemplar.bounds, resolution, 0.0)?)
}

/// Stage: exemplar → synthesized field and both reconstructions.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct VoxelSynth {
    /// Source samples along the exemplar box's longest side (paper: 64).
    pub source_resolution: usize,
    /// How the exemplar mesh's distances are signed (default
    /// [`MeshSign::PseudoNormal`]; [`source_field`]).
    pub mesh_sign: MeshSign,
    /// Synthesis parameters.
    pub params: VoxelParams,
    /// Seam relaxation of the copied-triangle reconstruction.
    pub relax: RelaxParams,
}

impl Default for VoxelSynth {
    fn default() -> Self {
        Self {
            source_resolution: 64,
            mesh_sign: MeshSign::default(),
            params: VoxelParams::default(),
            relax: RelaxParams::default(),
        }
    }
}

/// The first half of [`VoxelSynth`]'s run ([`VoxelSynth::synthesize_field`]): the fields,
/// before any geometry is built from them.
#[derive(Debug, Clone)]
pub struct SynthesizedField {
    /// The source field.
    pub source: SdfGrid,
    /// The synthesized field and its block copies.
    pub synthesis: Synthesis,
}

/// Everything [`VoxelSynth`] produces.
#[derive(Debug, Clone)]
pub struct VoxelOutput {
    /// The source field.
    pub source: SdfGrid,
    /// The synthesized field and its block copies.
    pub synthesis: Synthesis,
    /// Reconstruction (a): the closed zero set of the target field.
    pub isosurface: TriMesh,
    /// Reconstruction (b): the source triangles copied block by block, welded and relaxed.
    pub copied: CopiedMesh,
}

impl VoxelSynth {
    /// The first half of [`Stage::run`]: the exemplar's source field and the synthesized
    /// field. Between the halves a caller can look at the field, write it, or check that
    /// the reconstructions fit in memory ([`copied_triangle_count`], [`isosurface_cells`]);
    /// [`VoxelSynth::reconstruct`] is the second half.
    pub fn synthesize_field(
        &self,
        input: &VoxelExemplar,
        ctx: &mut RunContext,
    ) -> Result<SynthesizedField> {
        let source = ctx.timed("source field", |ctx| {
            source_field_in(input, self.source_resolution, self.mesh_sign, ctx)
        })?;
        let synthesis = synthesize(&source, &self.params, ctx)?;
        Ok(SynthesizedField { source, synthesis })
    }

    /// The second half of [`Stage::run`]: both reconstructions of `field`, which
    /// [`VoxelSynth::synthesize_field`] made from `input` with these settings.
    pub fn reconstruct(
        &self,
        input: &VoxelExemplar,
        field: SynthesizedField,
        ctx: &mut RunContext,
    ) -> Result<VoxelOutput> {
        let SynthesizedField { source, synthesis } = field;
        let isosurface = ctx.timed("isosurface", |_| isosurface_mesh(&synthesis, true))?;
        let copied = ctx.timed("copied triangles", |_| {
            copied_mesh(&input.mesh, &synthesis, &self.relax)
        })?;
        Ok(VoxelOutput {
            source,
            synthesis,
            isosurface,
            copied,
        })
    }
}

impl Stage for VoxelSynth {
    type Input = VoxelExemplar;
    type Output = VoxelOutput;
    type Error = Error;

    fn name(&self) -> &str {
        "voxel"
    }

    fn run(&self, input: VoxelExemplar, ctx: &mut RunContext) -> Result<VoxelOutput> {
        let field = self.synthesize_field(&input, ctx)?;
        self.reconstruct(&input, field, ctx)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use crate::quilt::{UpAxis, texture_comments_at};
    use io::{Geometry, WriteOptions};

    /// The grid solid written with its box as georeferenced coordinates in double precision.
    fn write_far(path: &Path, exemplar: &VoxelExemplar, far: DVec3) {
        let mut options = WriteOptions::default().origin(far);
        for c in texture_comments_at(&exemplar.bounds, UpAxis::Z, far) {
            options = options.comment(c);
        }
        io::write_geometry(path, &Geometry::Mesh(exemplar.mesh.clone()), &options).unwrap();
    }

    #[test]
    fn a_signed_distance_volume_is_read_as_its_solid() {
        use crate::reconstruct::{FieldParams, signed_distance};
        use pointset_core::Surface;
        let grid = VoxelExemplar::from(&crate::fixtures::volumes::grid(1).unwrap());
        let field = signed_distance(
            &Geometry::Mesh(grid.mesh.clone()),
            &FieldParams::default().resolution(48),
        )
        .unwrap();
        let distances = field.distances().unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("grid.nrrd");
        nrrd::write_file(&path, |f| nrrd::write_scalar(f, &distances)).unwrap();

        let read = read_exemplar(&path).unwrap();
        // The volume's box, and a closed solid on the original surface (the field's margin
        // keeps the solid off the box's sides, so nothing is capped; marching cubes stays
        // within a grid spacing of it, measured 0.55 spacings at the junctions).
        let spacing = distances.spacing();
        let corner = distances.origin()
            + glam::Vec3::from(distances.dims().map(|d| (d - 1) as f32)) * spacing;
        assert!((read.bounds.min - distances.origin()).abs().max_element() < 1e-5);
        assert!((read.bounds.max - corner).abs().max_element() < 1e-4);
        assert!(read.mesh.topology().is_closed_manifold());
        let original = MeshSurface::new(&grid.mesh).unwrap();
        let worst = read
            .mesh
            .positions()
            .iter()
            .map(|&p| {
                original
                    .signed_distance(p)
                    .map_or(f32::MAX, |(d, _)| d.abs())
            })
            .fold(0.0f32, f32::max);
        assert!(worst < spacing, "{worst} against spacing {spacing}");

        // A field without an inside, or with a NaN, is no solid: errors.
        for (name, value) in [("outside.nrrd", 1.0f32), ("nan.nrrd", f32::NAN)] {
            let mut bad = distances.clone();
            bad.data_mut().fill(1.0);
            bad.data_mut()[0] = value;
            let path = dir.path().join(name);
            nrrd::write_file(&path, |f| nrrd::write_scalar(f, &bad)).unwrap();
            assert!(matches!(
                read_exemplar(&path),
                Err(Error::TextureFile { .. })
            ));
        }
    }

    #[test]
    fn source_resolutions_out_of_range_are_refused_before_the_grid_is_sized() {
        let exemplar = VoxelExemplar::from(&crate::fixtures::volumes::grid(1).unwrap());
        for resolution in [0, 1, 3, 513, 1 << 32, usize::MAX] {
            for refused in [
                source_dims(&exemplar, resolution).map(|_| ()),
                source_field(&exemplar, resolution, MeshSign::PseudoNormal).map(|_| ()),
            ] {
                let message = refused.unwrap_err().to_string();
                assert!(message.contains("source resolution"), "{message}");
            }
        }
        let dims = source_dims(&exemplar, 4).unwrap();
        assert_eq!(*dims.iter().max().unwrap(), 4, "{dims:?}");
    }

    #[test]
    fn an_exemplar_built_from_ones_own_mesh_is_checked_and_synthesizes() {
        let sphere = crate::fixtures::icosphere_mesh(2).unwrap();
        let cube = Aabb::new(glam::Vec3::splat(-1.2), glam::Vec3::splat(1.2));
        let no_triangles = TriMesh::new(sphere.vertices().clone(), Vec::new()).unwrap();
        let message = VoxelExemplar::new(no_triangles, cube)
            .unwrap_err()
            .to_string();
        assert!(message.contains("exemplar mesh"), "{message}");
        for (lo, hi) in [
            (glam::Vec3::ZERO, glam::Vec3::new(1.0, 1.0, 0.0)),
            (glam::Vec3::new(f32::NAN, 0.0, 0.0), glam::Vec3::ONE),
            (glam::Vec3::ZERO, glam::Vec3::new(f32::INFINITY, 1.0, 1.0)),
        ] {
            let message = VoxelExemplar::new(sphere.clone(), Aabb { min: lo, max: hi })
                .unwrap_err()
                .to_string();
            assert!(message.contains("exemplar box"), "{lo} {hi}: {message}");
        }
        let exemplar = VoxelExemplar::new(sphere, cube).unwrap();
        let stage = VoxelSynth {
            source_resolution: 12,
            params: VoxelParams::default()
                .target_dims([16; 3])
                .levels(1)
                .block(4),
            ..Default::default()
        };
        let out = stage.run(exemplar, &mut RunContext::new(0)).unwrap();
        assert_eq!(out.synthesis.field.dims(), [16; 3]);
        assert!(out.isosurface.face_count() > 0);
    }

    #[test]
    fn a_georeferenced_exemplar_is_sampled_at_full_precision() {
        let near = VoxelExemplar::from(&crate::fixtures::volumes::grid(1).unwrap());
        let far = DVec3::new(5e5, 4e6, 0.0);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("far_grid.ply");
        write_far(&path, &near, far);

        let read = read_exemplar(&path).unwrap();
        // The same mesh and box, once the origin is added back.
        let shift = (read.origin - far).as_vec3();
        let worst = near
            .mesh
            .positions()
            .iter()
            .zip(read.mesh.positions())
            .map(|(a, b)| (*b + shift - *a).abs().max_element())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-4, "positions off by {worst}");
        assert!(
            (read.bounds.min + shift - near.bounds.min)
                .abs()
                .max_element()
                < 1e-4
        );
        assert!(
            (read.bounds.max + shift - near.bounds.max)
                .abs()
                .max_element()
                < 1e-4
        );
        // So the synthesis source is the near exemplar's field.
        let (a, b) = (
            source_field(&near, 16, MeshSign::PseudoNormal).unwrap(),
            source_field(&read, 16, MeshSign::PseudoNormal).unwrap(),
        );
        let field_gap = a
            .grid()
            .data()
            .iter()
            .zip(b.grid().data())
            .map(|(x, y)| (x.x - y.x).abs())
            .fold(0.0f32, f32::max);
        assert!(field_gap < 1e-4, "fields differ by {field_gap}");

        // Read without recentring, the same file's coordinates fall on the f32 grid
        // (0.25 apart at 4e6), which is what the exemplar must not be sampled from.
        let plain = io::read_geometry(&path).unwrap();
        let plain = plain.geometry.mesh().unwrap();
        let plain_worst = near
            .mesh
            .positions()
            .iter()
            .zip(plain.positions())
            .map(|(a, b)| (*b - far.as_vec3() - *a).abs().max_element())
            .fold(0.0f32, f32::max);
        assert!(plain_worst > 1e-2, "plain read off by only {plain_worst}");
    }
}
