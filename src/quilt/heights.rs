//! A quilted sheet written as a height map: a quilted height field on the input's grid
//! spacing with heights in the input file's units, a quilted point set on a grid of its
//! own spacing with heights in its length units.

use std::borrow::Cow;

use glam::Vec2;
use mls_surface::{HeightMethod, MlsParams, MlsSurface};
use patch_quilt::{GeometryTexture, QuiltOutput, UpAxis};
use pointset_core::{Aabb, HeightField, PointSet, RunContext, Stage};

use crate::imagery::fill_harmonic;
use crate::{Error, Result};

/// Most samples [`sample_heights`] writes: an 8192 × 8192 map (a 2048² height field
/// quilted at the default scale gives about 2730 × 2730). Sampling holds about 32 bytes
/// a sample.
pub const MAX_HEIGHT_SAMPLES: usize = 1 << 26;

/// Where a height map's samples lie in a texture's frame: sample `(c, r)` of a height
/// field read as a texture ([`super::read_heightfield_texture_framed`]) at
/// `x = c·spacing`, `y = (rows − 1 − r)·spacing`, `z = scale·h`; for a point-set texture
/// ([`Self::of_points`]), on a grid of its own spacing with heights in its length units.
/// `x`, `y` and `z` are the canonical axes of a texture whose up axis is `up`
/// ([`UpAxis::canonical_points`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeightFieldFrame {
    /// Distance between neighbouring samples.
    pub spacing: f32,
    /// World height per unit of the map's heights.
    pub scale: f32,
    /// The axis the heights run along ([`UpAxis::Z`] for a height field).
    pub up: UpAxis,
}

impl HeightFieldFrame {
    /// The frame of a height map of a point-set texture (or of its quilt): samples
    /// `spacing` apart, or without one as many as the texture has points
    /// (`1 / √`[`GeometryTexture::sample_density`]), with heights in the texture's length
    /// units along its up axis (scale 1). On a grid of points that is their own spacing;
    /// points scattered at random lie closer to their nearest neighbours (about half as
    /// far), and a map that fine would show their MLS surface's holes at every sample.
    ///
    /// Errors: a given spacing that is not positive and finite.
    ///
    /// ```
    /// use geosynth::quilt::{HeightFieldFrame, UpAxis, texture_from_exemplar};
    ///
    /// let exemplar = geosynth::fixtures::textures::bumpy(60.0, 1, 1)?;
    /// let texture = texture_from_exemplar(&exemplar)?;
    /// let frame = HeightFieldFrame::of_points(&texture, None)?;
    /// // 60 points per unit area: a grid of as many is 1/√60 apart.
    /// assert!((frame.spacing * 60f32.sqrt() - 1.0).abs() < 0.1, "{}", frame.spacing);
    /// assert_eq!((frame.scale, frame.up), (1.0, UpAxis::Z));
    /// assert_eq!(HeightFieldFrame::of_points(&texture, Some(0.5))?.spacing, 0.5);
    /// assert!(HeightFieldFrame::of_points(&texture, Some(-0.5)).is_err());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn of_points(texture: &GeometryTexture, spacing: Option<f32>) -> Result<Self> {
        let spacing = match spacing {
            Some(s) if s.is_finite() && s > 0.0 => s,
            Some(s) => return Error::invalid("map spacing", s, "a positive length"),
            // A texture holds points inside its box's positive area (`GeometryTexture::new`
            // refuses any other), so the density is positive and finite.
            None => (1.0 / texture.sample_density().sqrt()) as f32,
        };
        Ok(Self {
            spacing,
            scale: 1.0,
            up: texture.up(),
        })
    }

    /// Samples along x and y of a map on this frame's grid over a footprint `extent`
    /// wide (canonical x and y): one per `spacing` from the lower corner, the far side
    /// included where it falls on the grid (to within a thousandth of a step). Run before
    /// a quilt on [`GeometryTexture::output_extent`], it refuses a map
    /// [`sample_heights`] would refuse after it.
    ///
    /// Errors: a spacing that is not positive, a scale that is zero or not finite, fewer
    /// than 2 × 2 samples or more than [`MAX_HEIGHT_SAMPLES`].
    ///
    /// ```
    /// use geosynth::quilt::{HeightFieldFrame, UpAxis};
    /// use glam::Vec2;
    ///
    /// let frame = HeightFieldFrame { spacing: 0.1, scale: 1.0, up: UpAxis::Z };
    /// assert_eq!(frame.map_size(Vec2::new(2.0, 1.05))?, (21, 11));
    /// assert!(frame.map_size(Vec2::new(1e6, 1e6)).is_err());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn map_size(&self, extent: Vec2) -> Result<(usize, usize)> {
        let HeightFieldFrame { spacing, scale, .. } = *self;
        if !(spacing.is_finite() && spacing > 0.0 && scale.is_finite() && scale != 0.0) {
            return Err(Error::InvalidParameter {
                name: "height field frame",
                value: format!("spacing {spacing}, scale {scale}"),
                expected: "a positive spacing and a non-zero finite scale".into(),
            });
        }
        let steps = (extent / spacing + 1e-3).floor();
        let too_many = |s: f32| !(s.is_finite() && s < MAX_HEIGHT_SAMPLES as f32);
        if too_many(steps.x) || too_many(steps.y) {
            return Err(too_large(steps));
        }
        let (cols, rows) = (steps.x as usize + 1, steps.y as usize + 1);
        if cols < 2 || rows < 2 {
            return Err(Error::InvalidParameter {
                name: "height field size",
                value: format!("{cols} × {rows}"),
                expected: "a footprint of at least 2 × 2 samples".into(),
            });
        }
        match cols.checked_mul(rows) {
            Some(n) if n <= MAX_HEIGHT_SAMPLES => Ok((cols, rows)),
            _ => Err(too_large(steps)),
        }
    }
}

/// A height field sampled from a sheet by [`sample_heights`], with how each sample was
/// found.
#[derive(Debug, Clone, PartialEq)]
pub struct SampledHeights {
    /// The heights, in the file's units, row 0 at the top (largest y), as the readers
    /// place them.
    pub field: HeightField,
    /// Samples where a ray cast down met the surface.
    pub by_ray: usize,
    /// Samples where it did not and the nearest sample's height was projected
    /// ([`MlsSurface::top_heights`]).
    pub by_projection: usize,
    /// Samples with no surface within the kernel's reach (holes), filled from the samples
    /// around them ([`sample_heights`]).
    pub filled: usize,
}

/// Stage: a quilted sheet → its height map ([`sample_heights`] over the output box, on
/// the grid of `frame`). Follows [`super::Quilt`] on a texture read by
/// [`super::read_heightfield_texture_framed`], which gives the frame, or on a point-set
/// texture, whose frame [`HeightFieldFrame::of_points`] gives.
///
/// ```
/// use geosynth::quilt::{OutputSize, Quilt, QuiltParams, SampleHeights};
/// use geosynth::{RunContext, Stage};
///
/// // A 48 × 48 raw height field of bumps, quilted to 1.5 times its box and written back
/// // as a height map in the file's units.
/// let path = std::env::temp_dir().join("geosynth_doc_stage_bumps_48x48.f32le");
/// let heights: Vec<u8> = (0..48 * 48)
///     .flat_map(|i| (((i % 48) as f32 * 0.5).sin() * ((i / 48) as f32 * 0.4).cos()).to_le_bytes())
///     .collect();
/// std::fs::write(&path, heights)?;
/// let (texture, frame) = geosynth::quilt::read_heightfield_texture_framed(&path, 0.1)?;
/// let params = QuiltParams::default().output(OutputSize::Scale(1.5)).field_resolution(20);
/// let pipeline = Quilt { params }.then(SampleHeights { frame });
/// let mut ctx = RunContext::new(1);
/// let map = pipeline.run(texture, &mut ctx)?;
/// assert!(ctx.timings().iter().any(|(stage, _)| stage == "sample heights"));
/// // The box spans 31 of the 48 samples' spacings; the output 1.5 times that.
/// assert_eq!(map.field.width(), 47);
/// let (lo, hi) = map.field.range();
/// assert!(lo > -1.1 && hi < 1.1 && hi - lo > 1.0, "{lo}..{hi}");
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleHeights {
    /// Where the quilted height field's samples were placed.
    pub frame: HeightFieldFrame,
}

impl Stage for SampleHeights {
    type Input = QuiltOutput;
    type Output = SampledHeights;
    type Error = Error;

    fn name(&self) -> &str {
        "sample heights"
    }

    fn run(&self, input: QuiltOutput, ctx: &mut RunContext) -> Result<SampledHeights> {
        ctx.timed("sample heights", |_| {
            sample_heights(&input.points, &input.bounds, self.frame)
        })
    }
}

/// The top of the sheet sampled by `points` (oriented, in the world frame of a texture
/// whose up axis is `frame.up`, as a quilt outputs them) as a height field over the
/// footprint of `bounds`, on the grid of `frame` starting at `bounds`' lower corner in the
/// canonical frame, with heights divided by `frame.scale` ([`MlsSurface::top_heights`] on
/// the points' MLS surface with the default parameters). Samples over holes are filled
/// from those around them: the smooth (harmonic) surface their heights bound, the way
/// height maps are commonly inpainted. Across a gap that a warp opened at a cliff, that is
/// a ramp from the cliff's foot to its top.
///
/// Errors: a frame whose spacing is not positive or whose scale is zero or not finite, a
/// footprint with fewer than 2 × 2 samples or more than [`MAX_HEIGHT_SAMPLES`], points
/// without normals, and a sheet with no surface over any sample.
///
/// ```
/// use geosynth::core::{Aabb, PointSet};
/// use geosynth::quilt::{HeightFieldFrame, UpAxis, sample_heights};
/// use glam::Vec3;
///
/// // The ramp z = 0.1 x on a 40 × 40 grid 0.1 apart, read back at its own spacing with
/// // heights in units of 0.1.
/// let p: Vec<Vec3> = (0..1600)
///     .map(|i| {
///         let x = (i % 40) as f32 * 0.1;
///         Vec3::new(x, (i / 40) as f32 * 0.1, 0.1 * x)
///     })
///     .collect();
/// let n = Vec3::new(-0.1, 0.0, 1.0).normalize();
/// let points = PointSet::new(p)?.with_normals(vec![n; 1600])?;
/// let bounds = Aabb::new(Vec3::new(1.0, 1.0, 0.0), Vec3::new(3.0, 2.0, 0.4));
/// let frame = HeightFieldFrame { spacing: 0.1, scale: 0.1, up: UpAxis::Z };
/// let sampled = sample_heights(&points, &bounds, frame)?;
/// assert_eq!((sampled.field.width(), sampled.field.height()), (21, 11));
/// // Column c lies at x = 1 + 0.1 c, where the ramp is 1 + 0.1 c units high.
/// let h = sampled.field.get(5, 0).ok_or("no sample")?;
/// assert!((h - 1.5).abs() < 1e-3, "{h}");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn sample_heights(
    points: &PointSet,
    bounds: &Aabb,
    frame: HeightFieldFrame,
) -> Result<SampledHeights> {
    let (points, bounds) = match frame.up {
        UpAxis::Z => (Cow::Borrowed(points), *bounds),
        up => (
            Cow::Owned(up.canonical_points(points)?),
            up.canonical_box(bounds),
        ),
    };
    let (cols, rows) = frame.map_size(bounds.extent().truncate())?;
    let lo = bounds.min.truncate();
    let columns: Vec<Vec2> = (0..rows)
        .flat_map(|r| {
            (0..cols).map(move |c| lo + Vec2::new(c as f32, (rows - 1 - r) as f32) * frame.spacing)
        })
        .collect();
    let surface = MlsSurface::new(&points, &MlsParams::default())?;
    let found = surface.top_heights(&columns)?;
    let by_ray = found
        .iter()
        .flatten()
        .filter(|h| h.method == HeightMethod::Ray)
        .count();
    let by_projection = found.iter().flatten().count() - by_ray;
    let known: Vec<Option<f32>> = found
        .into_iter()
        .map(|h| h.map(|h| h.z / frame.scale))
        .collect();
    let filled = known.iter().filter(|h| h.is_none()).count();
    let heights = fill_harmonic(&known, cols).ok_or_else(|| Error::NoSurface {
        reason: format!(
            "the {} points have no surface over any of the {cols} × {rows} samples",
            points.len()
        ),
    })?;
    Ok(SampledHeights {
        field: HeightField::new(cols, rows, heights)?,
        by_ray,
        by_projection,
        filled,
    })
}

/// The error for a grid of `steps + 1` samples along x and y, past [`MAX_HEIGHT_SAMPLES`].
fn too_large(steps: Vec2) -> Error {
    Error::InvalidParameter {
        name: "height field size",
        value: format!("{} × {} samples", steps.x + 1.0, steps.y + 1.0),
        expected: format!("at most {MAX_HEIGHT_SAMPLES} samples"),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use glam::Vec3;

    use super::*;

    #[test]
    fn the_grid_covers_the_footprint_at_the_frames_spacing() {
        let frame = HeightFieldFrame {
            spacing: 0.1,
            scale: 2.0,
            up: UpAxis::Z,
        };
        assert_eq!(frame.map_size(Vec2::new(2.0, 1.0)).unwrap(), (21, 11));
        assert_eq!(frame.map_size(Vec2::new(2.05, 1.0)).unwrap(), (21, 11));
        assert!(frame.map_size(Vec2::new(0.05, 1.0)).is_err());
        assert!(frame.map_size(Vec2::new(1e9, 1e9)).is_err());
        for (spacing, scale) in [(0.0, 1.0), (-0.1, 1.0), (f32::NAN, 1.0), (0.1, 0.0)] {
            let frame = HeightFieldFrame {
                spacing,
                scale,
                up: UpAxis::Z,
            };
            assert!(frame.map_size(Vec2::new(2.0, 1.0)).is_err());
        }
    }

    #[test]
    fn a_sheet_with_a_hole_is_sampled_everywhere_and_the_hole_counted() {
        // z = 0.5 everywhere but a square hole of side 1 in the middle of a 4 × 4 sheet.
        let p: Vec<Vec3> = (0..81 * 81)
            .map(|i| Vec3::new((i % 81) as f32, (i / 81) as f32, 25.0) * 0.05)
            .filter(|p| (p.x - 2.0).abs().max((p.y - 2.0).abs()) > 0.5)
            .collect();
        let count = p.len();
        let points = PointSet::new(p)
            .unwrap()
            .with_normals(vec![Vec3::Z; count])
            .unwrap();
        let bounds = Aabb::new(Vec3::ZERO, Vec3::new(4.0, 4.0, 2.0));
        let frame = HeightFieldFrame {
            spacing: 0.05,
            scale: 0.5,
            up: UpAxis::Z,
        };
        let sampled = sample_heights(&points, &bounds, frame).unwrap();
        assert_eq!(sampled.field.width(), 81);
        assert!(
            sampled
                .field
                .heights()
                .iter()
                .all(|h| (h - 2.5).abs() < 1e-4)
        );
        assert!(sampled.filled > 0 && sampled.filled < 21 * 21);
        assert_eq!(
            sampled.by_ray + sampled.by_projection + sampled.filled,
            81 * 81
        );
        // The same sheet stood up as an X-up texture holds it in world coordinates
        // (canonical x, y, z are world y, z, x): the same map.
        let stood = |v: &Vec3| Vec3::new(v.z, v.x, v.y);
        let standing = PointSet::new(points.positions().iter().map(stood).collect())
            .unwrap()
            .with_normals(vec![Vec3::X; count])
            .unwrap();
        let standing_box = Aabb::new(stood(&bounds.min), stood(&bounds.max));
        let up_x = HeightFieldFrame {
            up: UpAxis::X,
            ..frame
        };
        assert_eq!(
            sample_heights(&standing, &standing_box, up_x).unwrap(),
            sampled
        );
        // Read with the wrong up axis it is a wall, not a map of this sheet.
        let wrong = sample_heights(&standing, &standing_box, frame);
        assert!(wrong.map_or(true, |w| w != sampled));
    }

    /// The texture read from the height field file at `path` sampled back over its own
    /// box: the worst and the root-mean-square difference from the file's samples there,
    /// as fractions of the file's height range.
    fn read_back_errors(path: &std::path::Path) -> (f32, f32) {
        let field = crate::imagery::read_heightfield(path).unwrap();
        let (texture, frame) = super::super::read_heightfield_texture_framed(path, 0.1).unwrap();
        let bounds = texture.canonical_bounds();
        let sampled = sample_heights(texture.canonical_points(), &bounds, frame).unwrap();
        let padding = field.width().min(field.height()) / 6;
        let back = &sampled.field;
        assert_eq!(back.width(), field.width() - 2 * padding);
        assert_eq!(back.height(), field.height() - 2 * padding);
        let (lo, hi) = field.range();
        let (mut worst, mut squares) = (0.0f32, 0.0f64);
        for r in 0..back.height() {
            for c in 0..back.width() {
                let d = back.get(c, r).unwrap() - field.get(c + padding, r + padding).unwrap();
                worst = worst.max(d.abs());
                squares += f64::from(d * d);
            }
        }
        let rms = (squares / back.heights().len() as f64).sqrt() as f32;
        (worst / (hi - lo), rms / (hi - lo))
    }

    #[test]
    fn a_smooth_height_field_is_read_back_from_its_own_samples() {
        let path = std::env::temp_dir().join("geosynth_heights_read_back_90x60.f32le");
        let bytes: Vec<u8> = (0..90 * 60)
            .flat_map(|i| {
                let (c, r) = ((i % 90) as f32, (i / 90) as f32);
                (3.0 * (0.2 * c).sin() + 2.0 * (0.15 * r).cos() + 40.0).to_le_bytes()
            })
            .collect();
        std::fs::write(&path, bytes).unwrap();
        let (worst, rms) = read_back_errors(&path);
        std::fs::remove_file(&path).unwrap();
        assert!(worst < 0.01 && rms < 0.005, "worst {worst}, rms {rms}");
    }

    #[test]
    fn mount_st_helens_is_read_back_from_its_own_samples() {
        let test = "mount_st_helens_is_read_back_from_its_own_samples";
        let relative = "heightfields/SainteHelens_317x460.f32le";
        let Some(path) = pointset_core::testdata::shared_data(test, relative) else {
            return;
        };
        let (worst, rms) = read_back_errors(&path);
        eprintln!("St. Helens read back: worst {worst}, rms {rms} of the height range");
        assert!(worst < 0.05 && rms < 0.005, "worst {worst}, rms {rms}");
    }
}
