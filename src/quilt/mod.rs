//! Patch-based geometry texture synthesis (paper 000; the `patch-quilt` crate), with the
//! facade's stage and file conventions.
//!
//! A geometry texture file is an oriented point set (PLY, OBJ, OFF, XYZ; a mesh without
//! vertex normals gets them from its faces; a bare point set gets them estimated when
//! [`ExemplarNormals::Estimated`] asks) whose comments carry its box and up axis:
//! `texture_box X0 Y0 Z0 X1 Y1 Z1` and `texture_up x|y|z`. Without them the up axis is Z
//! (or the one given to [`read_texture_with_up`]) and the box is the points' bounding box
//! inset by a sixth of its extent across the reference plane on every side (so the outer
//! sixths are padding); points that lie in a plane get a box one sample spacing thick.
//! A point set's points far outside the rest would stretch that box: the reader leaves
//! them out and counts them ([`StrayPoints`]) unless [`TextureReading::keep_strays`].
//!
//! ```
//! use geosynth::quilt::{Quilt, QuiltParams, OutputSize, texture_from_exemplar};
//! use geosynth::{fixtures, RunContext, Stage};
//!
//! let exemplar = fixtures::textures::bumpy(60.0, 1, 1)?;
//! let texture = texture_from_exemplar(&exemplar)?;
//! let stage = Quilt { params: QuiltParams::default().output(OutputSize::Scale(1.25)).field_resolution(20) };
//! let out = stage.run(texture, &mut RunContext::new(3))?;
//! assert!(out.points.len() > 500);
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::path::Path;

pub use patch_quilt::search;
pub use patch_quilt::{
    BlendCounts, GeometryTexture, Method, OutputSize, Overlap, PatchGeometry, Placement,
    QualityMeasure, QualityReport, QuiltError, QuiltOutput, QuiltParams, QuiltStats, UpAxis,
    WarpCounts, WarpTargets, evaluate, quilt,
};
use pointset_core::io::Geometry;
use pointset_core::{HeightField, RunContext, Stage};

use crate::fixtures::textures::TextureExemplar;
use crate::{Error, Result};

mod files;
mod fitted;
mod heights;
mod map_grid;
mod samples;
mod strays;

pub use files::{
    TextureFile, TextureReading, parse_texture_comments, parse_texture_comments_at, read_texture,
    read_texture_file, read_texture_file_with, read_texture_with_up, texture_comments,
    texture_comments_at,
};
pub(crate) use files::{single_precision_step, texture_file_error};
pub use fitted::{MAX_PLANE_SPREAD, read_texture_file_fitted, read_texture_file_fitted_with};
pub use heights::{
    HeightFieldFrame, MAX_HEIGHT_SAMPLES, SampleHeights, SampledHeights, sample_heights,
};
pub use map_grid::MapGrid;
pub use samples::{ExemplarNormals, MESH_SAMPLING_STAGE};
pub use strays::StrayPoints;

/// The relief [`read_heightfield_texture`] gives a height field: its height range as a
/// fraction of the samples' longer extent.
pub const DEFAULT_RELIEF: f32 = 0.1;

/// Reads a height field file (PNG 8/16-bit or raw `name_WxH.f32le`, see
/// [`crate::imagery::read_heightfield`]) as a geometry texture with the command line's
/// conventions: the samples span 4 units along the longer side, the relief is scaled to
/// 0.4 ([`DEFAULT_RELIEF`] of the extent; a flat field stays flat), and the outer sixth of
/// the samples on every side is padding (paper §3), so the box is about two thirds of the
/// extent. [`read_heightfield_texture_with_relief`] sets the relief.
///
/// ```
/// // A 30 × 30 raw height field of ripples, written beside the other temporary files.
/// let path = std::env::temp_dir().join("geosynth_doc_ripples_30x30.f32le");
/// let heights: Vec<u8> = (0..30 * 30)
///     .flat_map(|i| ((i % 30) as f32 * 0.5).sin().to_le_bytes())
///     .collect();
/// std::fs::write(&path, heights)?;
/// let texture = geosynth::quilt::read_heightfield_texture(&path)?;
/// assert_eq!(texture.canonical_points().len(), 30 * 30);
/// // 4 units across, the outer 5 samples on every side outside the box.
/// let (lo, hi) = texture.footprint();
/// assert!((hi.x - lo.x - 4.0 * 19.0 / 29.0).abs() < 1e-4, "{lo} {hi}");
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_heightfield_texture(path: &Path) -> Result<GeometryTexture> {
    read_heightfield_texture_with_relief(path, DEFAULT_RELIEF)
}

/// [`read_heightfield_texture`] with the height range set to `relief` times the samples'
/// longer extent (a flat field stays flat). A file's heights rarely share its spacing's
/// unit, so the relief is the one shape parameter a height field does not carry.
/// Errors on a relief that is not positive and finite.
///
/// ```
/// let path = std::env::temp_dir().join("geosynth_doc_slope_20x20.f32le");
/// let heights: Vec<u8> = (0..20 * 20).flat_map(|i| ((i % 20) as f32).to_le_bytes()).collect();
/// std::fs::write(&path, heights)?;
/// let steep = geosynth::quilt::read_heightfield_texture_with_relief(&path, 0.5)?;
/// // The samples span 4 units; the heights span half of that.
/// let z: Vec<f32> = steep.canonical_points().positions().iter().map(|p| p.z).collect();
/// let range = z.iter().copied().fold(f32::MIN, f32::max) - z.iter().copied().fold(f32::MAX, f32::min);
/// assert!((range - 2.0).abs() < 1e-4, "{range}");
/// assert!(geosynth::quilt::read_heightfield_texture_with_relief(&path, 0.0).is_err());
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_heightfield_texture_with_relief(path: &Path, relief: f32) -> Result<GeometryTexture> {
    Ok(read_heightfield_texture_framed(path, relief)?.0)
}

/// [`read_heightfield_texture_with_relief`], with where the samples were placed: the frame
/// [`sample_heights`] needs to write a quilt of the texture back as a height field in the
/// file's units.
///
/// ```
/// let path = std::env::temp_dir().join("geosynth_doc_framed_20x10.f32le");
/// let heights: Vec<u8> = (0..20 * 10).flat_map(|i| ((i % 20) as f32 * 3.0).to_le_bytes()).collect();
/// std::fs::write(&path, heights)?;
/// let (texture, frame) = geosynth::quilt::read_heightfield_texture_framed(&path, 0.1)?;
/// // 20 samples span 4 units; heights 0..57 span 0.4.
/// assert!((frame.spacing - 4.0 / 19.0).abs() < 1e-6);
/// assert!((frame.scale - 0.4 / 57.0).abs() < 1e-6);
/// let p = texture.canonical_points().positions()[19];
/// assert!((p.z / frame.scale - 57.0).abs() < 1e-3);
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_heightfield_texture_framed(
    path: &Path,
    relief: f32,
) -> Result<(GeometryTexture, HeightFieldFrame)> {
    check_relief(relief)?;
    heightfield_texture(&crate::imagery::read_heightfield(path)?, relief)
}

/// [`read_heightfield_texture_framed`] of a file whose voids (samples on its no-data
/// value, or not finite, which that refuses) are filled first
/// ([`crate::imagery::HeightSamples::filled`]); also returns how many were filled.
///
/// ```
/// let path = std::env::temp_dir().join("geosynth_doc_voids_20x20.f32le");
/// let mut heights: Vec<f32> = (0..20 * 20).map(|i| (i % 20) as f32).collect();
/// heights[210] = f32::NAN;
/// std::fs::write(&path, heights.iter().flat_map(|h| h.to_le_bytes()).collect::<Vec<u8>>())?;
/// assert!(geosynth::quilt::read_heightfield_texture_framed(&path, 0.1).is_err());
/// let (_, _, filled) = geosynth::quilt::read_heightfield_texture_filling(&path, 0.1)?;
/// assert_eq!(filled, 1);
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_heightfield_texture_filling(
    path: &Path,
    relief: f32,
) -> Result<(GeometryTexture, HeightFieldFrame, usize)> {
    check_relief(relief)?;
    let (field, filled) = crate::imagery::read_height_samples(path)?.filled()?;
    let (texture, frame) = heightfield_texture(&field, relief)?;
    Ok((texture, frame, filled))
}

/// Errors on a relief that is not positive and finite.
fn check_relief(relief: f32) -> Result<()> {
    if relief.is_finite() && relief > 0.0 {
        return Ok(());
    }
    Error::invalid(
        "relief",
        relief,
        "a positive fraction of the height field's extent",
    )
}

/// The texture of `field` as [`read_heightfield_texture_framed`] samples it with a checked
/// `relief` ([`check_relief`]), and its frame.
fn heightfield_texture(
    field: &HeightField,
    relief: f32,
) -> Result<(GeometryTexture, HeightFieldFrame)> {
    let extent = 4.0;
    let spacing = extent / (field.width().max(field.height()) - 1) as f32;
    let scale = crate::imagery::relief_scale(field, relief * extent)?;
    let padding = field.width().min(field.height()) / 6;
    let texture = GeometryTexture::from_heightfield(field, spacing, scale, padding)?;
    let frame = HeightFieldFrame {
        spacing,
        scale,
        up: UpAxis::Z,
    };
    Ok((texture, frame))
}

/// The geometry texture of a procedural exemplar.
pub fn texture_from_exemplar(exemplar: &TextureExemplar) -> Result<GeometryTexture> {
    Ok(GeometryTexture::new(
        &exemplar.points,
        exemplar.bounds,
        UpAxis::Z,
    )?)
}

/// The exemplar as a file-ready geometry with its box comments.
pub fn exemplar_geometry(exemplar: &TextureExemplar) -> (Geometry, Vec<String>) {
    (
        Geometry::Points(exemplar.points.clone()),
        texture_comments(&exemplar.bounds, UpAxis::Z),
    )
}

/// Stage: geometry texture → synthesized texture ([`patch_quilt::quilt`]).
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct Quilt {
    /// The parameters used.
    pub params: QuiltParams,
}

impl Stage for Quilt {
    type Input = GeometryTexture;
    type Output = QuiltOutput;
    type Error = Error;

    fn name(&self) -> &str {
        "quilt"
    }

    fn run(&self, input: GeometryTexture, ctx: &mut RunContext) -> Result<QuiltOutput> {
        Ok(quilt(&input, &self.params, ctx)?)
    }
}
