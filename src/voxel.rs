//! Geometry synthesis by distance-field block matching (paper 001; the `voxel-dfsynth`
//! crate), with the facade's exemplar files and the [`VoxelSynth`] stage.
//!
//! An exemplar is a closed mesh whose comments may give the box to sample
//! (`texture_box X0 Y0 Z0 X1 Y1 Z1`, as `geosynth fixtures` writes them); without one, the
//! mesh's bounding box is used. Its signed distance field over that box, with
//! `source_resolution` samples along the longest side, is the synthesis source.
//!
//! ```
//! use geosynth::voxel::{VoxelExemplar, VoxelParams, VoxelSynth};
//! use geosynth::{fixtures, RunContext, Stage};
//!
//! let exemplar = VoxelExemplar::from(&fixtures::volumes::grid(1)?);
//! let stage = VoxelSynth {
//!     source_resolution: 16,
//!     params: VoxelParams { target_dims: [24; 3], levels: 2, block: 8, ..Default::default() },
//!     ..Default::default()
//! };
//! let out = stage.run(exemplar, &mut RunContext::new(0))?;
//! assert_eq!(out.synthesis.field.dims(), [24, 24, 24]);
//! assert!(out.isosurface.face_count() > 0 && out.copied.mesh.face_count() > 0);
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::path::Path;

use distance_field::{GridSpec, MeshSurface, SdfGrid};
use pointset_core::io;
use pointset_core::{Aabb, RunContext, Stage, TriMesh};
pub use voxel_dfsynth::{
    BlockCopy, BlockMatcher, BoxMeans, BruteForce, CopiedMesh, FftMatcher, LevelReport, Match,
    MatcherKind, QualityParams, QuantizedField, RelaxParams, SearchTree, SubsampledSource,
    Synthesis, TreeStats, VoxelError, VoxelParams, VoxelQuality, block_level, copied_mesh,
    evaluate, fft, isosurface_mesh, quantize_source, source_quantizer, synthesize,
    unit_gradient_fraction,
};

use crate::fixtures::volumes::VolumeExemplar;
use crate::{Error, Result};

/// A solid exemplar: a closed mesh and the box whose distance field is sampled.
#[derive(Debug, Clone)]
pub struct VoxelExemplar {
    /// The mesh.
    pub mesh: TriMesh,
    /// The sampled box.
    pub bounds: Aabb,
}

impl From<&VolumeExemplar> for VoxelExemplar {
    fn from(v: &VolumeExemplar) -> Self {
        Self {
            mesh: v.mesh.clone(),
            bounds: v.bounds,
        }
    }
}

/// Reads an exemplar mesh (see the module docs).
pub fn read_exemplar(path: &Path) -> Result<VoxelExemplar> {
    let loaded = io::read_geometry(path)?;
    let mesh = match loaded.geometry {
        io::Geometry::Mesh(m) => m,
        io::Geometry::Points(_) => {
            return Err(Error::TextureFile {
                path: path.to_path_buf(),
                message: "distance-field synthesis needs a mesh, not a point set".into(),
            });
        }
    };
    let described = crate::quilt::parse_texture_comments(&loaded.comments).map_err(|message| {
        Error::TextureFile {
            path: path.to_path_buf(),
            message,
        }
    })?;
    let bounds = match described {
        Some((b, _)) => b,
        None => mesh.bounding_box().ok_or_else(|| Error::TextureFile {
            path: path.to_path_buf(),
            message: "the mesh has no vertices".into(),
        })?,
    };
    Ok(VoxelExemplar { mesh, bounds })
}

/// The exemplar's signed distance field with `resolution` samples along the box's longest
/// side, exact everywhere (the band is the box's diagonal).
pub fn source_field(exemplar: &VoxelExemplar, resolution: usize) -> Result<SdfGrid> {
    if !(4..=512).contains(&resolution) {
        return Err(Error::InvalidParameter {
            name: "source resolution",
            value: resolution.to_string(),
            expected: "4 to 512 samples".into(),
        });
    }
    let spec = GridSpec::covering(exemplar.bounds, resolution, 0.0)?;
    let surface = MeshSurface::new(&exemplar.mesh)?;
    let diagonal = exemplar.bounds.extent().length().max(2.0 * spec.spacing);
    Ok(SdfGrid::from_surface(&surface, &spec, diagonal)?)
}

/// Samples along x, y, z of [`source_field`] at `resolution`.
pub fn source_dims(exemplar: &VoxelExemplar, resolution: usize) -> Result<[usize; 3]> {
    Ok(GridSpec::covering(exemplar.bounds, resolution, 0.0)?.dims)
}

/// Stage: exemplar → synthesized field and both reconstructions.
#[derive(Debug, Clone)]
pub struct VoxelSynth {
    /// Source samples along the exemplar box's longest side (paper: 64).
    pub source_resolution: usize,
    /// Synthesis parameters.
    pub params: VoxelParams,
    /// Seam relaxation of the copied-triangle reconstruction.
    pub relax: RelaxParams,
}

impl Default for VoxelSynth {
    fn default() -> Self {
        Self {
            source_resolution: 64,
            params: VoxelParams::default(),
            relax: RelaxParams::default(),
        }
    }
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

impl Stage for VoxelSynth {
    type Input = VoxelExemplar;
    type Output = VoxelOutput;
    type Error = Error;

    fn name(&self) -> &str {
        "voxel"
    }

    fn run(&self, input: VoxelExemplar, ctx: &mut RunContext) -> Result<VoxelOutput> {
        let source = ctx.timed("source field", |_| {
            source_field(&input, self.source_resolution)
        })?;
        let synthesis = synthesize(&source, &self.params, ctx)?;
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
