//! Geometry textures (paper 000 §3): oriented points, a box, a reference plane.

use glam::{Vec2, Vec3};
use pointset_core::{Aabb, HeightField, PointSet, RunContext};

use crate::error::{QuiltError, Result};
use crate::params::{MAX_OUTPUT_SCALE, OutputSize};

/// Fewest points [`GeometryTexture::new`] takes for a texture.
pub const MIN_TEXTURE_POINTS: usize = 16;

/// The axis normal to the reference plane (the texture's "up").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UpAxis {
    /// The reference plane is YZ.
    X,
    /// The reference plane is ZX.
    Y,
    /// The reference plane is XY (height fields); the default.
    #[default]
    Z,
}

impl UpAxis {
    /// World → canonical frame (up becomes +Z; a cyclic permutation, so orientation is kept).
    pub fn to_canonical(self, v: Vec3) -> Vec3 {
        match self {
            UpAxis::X => Vec3::new(v.y, v.z, v.x),
            UpAxis::Y => Vec3::new(v.z, v.x, v.y),
            UpAxis::Z => v,
        }
    }

    /// Canonical frame → world.
    pub fn to_world(self, v: Vec3) -> Vec3 {
        match self {
            UpAxis::X => Vec3::new(v.z, v.x, v.y),
            UpAxis::Y => Vec3::new(v.y, v.z, v.x),
            UpAxis::Z => v,
        }
    }

    /// `points` (world coordinates, e.g. a quilt's output) in the canonical frame of a
    /// texture with this up axis: up becomes +Z, the plane's axes follow cyclically (for
    /// Y up, world z and x become x and y). Normals turn with the points; attributes are
    /// kept.
    ///
    /// ```
    /// use glam::Vec3;
    /// use patch_quilt::UpAxis;
    /// use pointset_core::{Aabb, PointSet};
    ///
    /// let points = PointSet::new(vec![Vec3::new(1.0, 2.0, 3.0)])?.with_normals(vec![Vec3::Y])?;
    /// let canonical = UpAxis::Y.canonical_points(&points)?;
    /// assert_eq!(canonical.positions()[0], Vec3::new(3.0, 1.0, 2.0));
    /// assert_eq!(canonical.normals().ok_or("no normals")?[0], Vec3::Z);
    /// let bounds = Aabb::new(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0));
    /// assert_eq!(UpAxis::X.canonical_box(&bounds).max, Vec3::new(2.0, 3.0, 1.0));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn canonical_points(self, points: &PointSet) -> Result<PointSet> {
        let turn = |v: &[Vec3]| v.iter().map(|&v| self.to_canonical(v)).collect::<Vec<_>>();
        let mut canonical = PointSet::new(turn(points.positions()))?;
        if let Some(normals) = points.normals() {
            canonical = canonical.with_normals(turn(normals))?;
        }
        for a in points.attributes() {
            canonical.set_attribute(a.clone())?;
        }
        Ok(canonical)
    }

    /// `bounds` (world coordinates) in the canonical frame ([`Self::canonical_points`]).
    pub fn canonical_box(self, bounds: &Aabb) -> Aabb {
        Aabb::new(self.to_canonical(bounds.min), self.to_canonical(bounds.max))
    }
}

/// An input geometry texture `T_in`: an oriented point set, its box `B_Tin` and the
/// reference plane. The geometry must extend beyond the box in the plane's directions
/// (padding): the distance fields near the box's sides and the extra region `E_k` of each
/// patch come from it.
///
/// Internally everything is stored in a canonical frame where the up axis is +Z.
#[derive(Debug, Clone)]
pub struct GeometryTexture {
    points: PointSet,
    bounds: Aabb,
    up: UpAxis,
    padding: f32,
}

impl GeometryTexture {
    /// A texture from oriented points (in world coordinates), the box and the up axis.
    ///
    /// Errors: no normals, a zero normal, fewer than 16 points, points spanning more than
    /// [`pointset_core::MAX_SPAN`], points that all coincide, a box with zero extent, no
    /// points inside it.
    pub fn new(points: &PointSet, bounds: Aabb, up: UpAxis) -> Result<Self> {
        if points.normals().is_none() {
            return Err(QuiltError::InvalidTexture {
                reason: "the exemplar has no normals; patch quilting needs oriented points (`geosynth normals`, or mls_surface::estimate_normals then orient_normals, estimates them)".into(),
            });
        }
        let directionless = points.directionless_normals();
        if directionless > 0 {
            return Err(QuiltError::InvalidTexture {
                reason: format!(
                    "{directionless} of the {} normals are zero (unset by the tool that wrote \
                     them), and patch quilting needs a direction at every point (`geosynth \
                     normals` estimates them all anew)",
                    points.len()
                ),
            });
        }
        if points.len() < MIN_TEXTURE_POINTS {
            return Err(QuiltError::InvalidTexture {
                reason: format!(
                    "{} {} too few for a texture (at least {MIN_TEXTURE_POINTS})",
                    points.len(),
                    if points.len() == 1 {
                        "point is"
                    } else {
                        "points are"
                    }
                ),
            });
        }
        pointset_core::check_span(points.positions(), "exemplar points")?;
        let first = points.positions()[0];
        if points.positions().iter().all(|&p| p == first) {
            return Err(QuiltError::InvalidTexture {
                reason: format!(
                    "all {} points coincide at ({}, {}, {}): they sample no surface",
                    points.len(),
                    first.x,
                    first.y,
                    first.z
                ),
            });
        }
        let canonical_bounds = up.canonical_box(&bounds);
        let extent = canonical_bounds.extent();
        if !extent.is_finite() || extent.min_element() <= 0.0 {
            let (a, b) = (bounds.min, bounds.max);
            let thin = if extent.x > 0.0 && extent.y > 0.0 {
                " along the up axis (give a flat exemplar's box some thickness)"
            } else {
                " across the reference plane"
            };
            return Err(QuiltError::InvalidTexture {
                reason: format!(
                    "the box from ({}, {}, {}) to ({}, {}, {}) has no volume{thin}",
                    a.x, a.y, a.z, b.x, b.y, b.z
                ),
            });
        }
        let canonical = up.canonical_points(points)?;
        let p = canonical.positions();
        if !p.iter().any(|q| canonical_bounds.contains(*q)) {
            return Err(QuiltError::InvalidTexture {
                reason: "no point lies inside the box".into(),
            });
        }
        let all = Aabb::from_points(p).unwrap_or(canonical_bounds);
        let padding = [
            canonical_bounds.min.x - all.min.x,
            canonical_bounds.min.y - all.min.y,
            all.max.x - canonical_bounds.max.x,
            all.max.y - canonical_bounds.max.y,
        ]
        .into_iter()
        .fold(f32::MAX, f32::min)
        .max(0.0);
        Ok(Self {
            points: canonical,
            bounds: canonical_bounds,
            up,
            padding,
        })
    }

    /// Samples a height field `z = scale · h(x, y)` as oriented points (one per sample, at
    /// `spacing` apart, Z up). The outer `padding` samples on every side are padding: the box
    /// covers the inner samples and the full height range.
    pub fn from_heightfield(
        field: &HeightField,
        spacing: f32,
        scale: f32,
        padding: usize,
    ) -> Result<Self> {
        if !(spacing.is_finite() && spacing > 0.0 && scale.is_finite()) {
            return Err(crate::error::invalid(
                "spacing/scale",
                format!("{spacing}/{scale}"),
                "a positive spacing and a finite scale",
            ));
        }
        if 2 * padding + 2 > field.width().min(field.height()) {
            return Err(crate::error::invalid(
                "padding",
                padding,
                format!(
                    "fewer than half of the {}x{} samples",
                    field.width(),
                    field.height()
                ),
            ));
        }
        let points = field.to_points(spacing, scale)?;
        let (lo, hi) = field.range();
        let (zlo, zhi) = if scale >= 0.0 {
            (lo * scale, hi * scale)
        } else {
            (hi * scale, lo * scale)
        };
        let margin = 0.05 * (zhi - zlo).max(spacing);
        let pad = padding as f32 * spacing;
        let max_x = (field.width() - 1) as f32 * spacing - pad;
        let max_y = (field.height() - 1) as f32 * spacing - pad;
        let bounds = Aabb::new(
            Vec3::new(pad, pad, zlo - margin),
            Vec3::new(max_x, max_y, zhi + margin),
        );
        Self::new(&points, bounds, UpAxis::Z)
    }

    /// The texture with its normals' signs made consistent by propagation from the side
    /// facing up ([`mls_surface::orient_normals`]), for exemplars whose normals came
    /// unoriented (local PCA estimates). Box, up axis and positions are kept.
    ///
    /// ```
    /// use glam::Vec3;
    /// use patch_quilt::{GeometryTexture, UpAxis};
    /// use pointset_core::{Aabb, PointSet};
    ///
    /// let grid: Vec<Vec3> = (0..900).map(|i| Vec3::new((i % 30) as f32, (i / 30) as f32, 0.0) * 0.1).collect();
    /// let signs = (0..900).map(|i| if i % 3 == 0 { Vec3::NEG_Z } else { Vec3::Z }).collect();
    /// let points = PointSet::new(grid)?.with_normals(signs)?;
    /// let bounds = Aabb::new(Vec3::new(0.5, 0.5, -0.1), Vec3::new(2.4, 2.4, 0.1));
    /// let texture = GeometryTexture::new(&points, bounds, UpAxis::Z)?.with_oriented_normals()?;
    /// let normals = texture.canonical_points().normals().ok_or("no normals")?;
    /// assert!(normals.iter().all(|n| *n == Vec3::Z));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn with_oriented_normals(&self) -> Result<Self> {
        self.with_oriented_normals_in(&mut RunContext::new(0))
    }

    /// [`GeometryTexture::with_oriented_normals`] within a run: progress and cancellation
    /// as [`mls_surface::orient_normals_in`] reports and checks them.
    pub fn with_oriented_normals_in(&self, ctx: &mut RunContext) -> Result<Self> {
        Ok(Self {
            points: mls_surface::orient_normals_in(&self.points, Vec3::Z, ctx)?,
            ..self.clone()
        })
    }

    /// The points in the canonical frame (up = +Z).
    pub fn canonical_points(&self) -> &PointSet {
        &self.points
    }

    /// The box in the canonical frame.
    pub fn canonical_bounds(&self) -> Aabb {
        self.bounds
    }

    /// The up axis.
    pub fn up(&self) -> UpAxis {
        self.up
    }

    /// Smallest extent of the geometry beyond the box, over the four in-plane sides.
    pub fn padding(&self) -> f32 {
        self.padding
    }

    /// Footprint of the box on the reference plane (canonical x, y).
    pub fn footprint(&self) -> (Vec2, Vec2) {
        (self.bounds.min.truncate(), self.bounds.max.truncate())
    }

    /// About how many points a quilt of this texture at `size` holds: the footprint's
    /// sample density times the output's area. Patches are copies of the exemplar, so the
    /// output keeps its density; the count is known before the run, for sizing it (the
    /// fixtures' outputs at `Scale(2.0)` come within 7% of it, seed 1). Sizes that
    /// [`QuiltParams::validate`](crate::QuiltParams::validate) refuses (not positive, not
    /// finite) give 0.
    ///
    /// ```
    /// use patch_quilt::{GeometryTexture, OutputSize};
    /// use pointset_core::HeightField;
    ///
    /// // 40 × 40 samples 0.1 apart, 4 of them padding on each side: about 32 × 32 inside
    /// // a box 3.1 wide, so twice as wide a quilt holds about 4 × 1024 points.
    /// let field = HeightField::new(40, 40, vec![0.0; 1600])?;
    /// let texture = GeometryTexture::from_heightfield(&field, 0.1, 1.0, 4)?;
    /// let expected = texture.expected_output_points(OutputSize::Scale(2.0));
    /// assert!((expected / 4096.0 - 1.0).abs() < 0.1);
    /// let half = texture.expected_output_points(OutputSize::Absolute(6.2, 3.1));
    /// assert!((half / expected - 0.5).abs() < 1e-3);
    /// assert_eq!(texture.expected_output_points(OutputSize::Scale(f32::NAN)), 0.0);
    /// assert_eq!(texture.expected_output_points(OutputSize::Scale(-2.0)), 0.0);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn expected_output_points(&self, size: OutputSize) -> f64 {
        let extent = self.output_extent(size);
        let (w, h) = (f64::from(extent.x), f64::from(extent.y));
        if !(w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0) {
            return 0.0;
        }
        self.sample_density() * w * h
    }

    /// The footprint of a quilt of this texture at `size` on the reference plane (canonical
    /// x and y): the box's footprint scaled, or the absolute size. The output box spans
    /// it from the footprint's lower corner. Not checked: sizes that
    /// [`QuiltParams::validate`](crate::QuiltParams::validate) refuses pass through.
    ///
    /// ```
    /// use glam::Vec2;
    /// use patch_quilt::{GeometryTexture, OutputSize};
    /// use pointset_core::HeightField;
    ///
    /// let field = HeightField::new(40, 20, vec![0.0; 800])?;
    /// let texture = GeometryTexture::from_heightfield(&field, 0.1, 1.0, 4)?;
    /// // 31 × 11 spacings inside the padding.
    /// let scaled = texture.output_extent(OutputSize::Scale(2.0));
    /// assert!((scaled - Vec2::new(6.2, 2.2)).abs().max_element() < 1e-5);
    /// assert_eq!(texture.output_extent(OutputSize::Absolute(5.0, 1.0)), Vec2::new(5.0, 1.0));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn output_extent(&self, size: OutputSize) -> Vec2 {
        let (lo, hi) = self.footprint();
        match size {
            OutputSize::Absolute(w, h) => Vec2::new(w, h),
            OutputSize::Scale(s) => (hi - lo) * s,
        }
    }

    /// [`Self::output_extent`], refused as [`quilt`](crate::quilt()) refuses it when a side
    /// exceeds [`MAX_OUTPUT_SCALE`] times the footprint's: for checking a size before
    /// anything is sized from it (a `1e30 × 1` quilt was first estimated at 5.8·10²⁶
    /// million points).
    ///
    /// ```
    /// use patch_quilt::{GeometryTexture, OutputSize};
    /// use pointset_core::HeightField;
    ///
    /// let field = HeightField::new(40, 20, vec![0.0; 800])?;
    /// let texture = GeometryTexture::from_heightfield(&field, 0.1, 1.0, 4)?;
    /// assert!(texture.checked_output_extent(OutputSize::Absolute(5.0, 1.0)).is_ok());
    /// assert!(texture.checked_output_extent(OutputSize::Absolute(1e30, 1.0)).is_err());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn checked_output_extent(&self, size: OutputSize) -> Result<Vec2> {
        let extent = self.output_extent(size);
        let (lo, hi) = self.footprint();
        let box_side = hi - lo;
        if (extent / box_side).max_element() > MAX_OUTPUT_SCALE {
            return Err(crate::error::invalid(
                "output",
                format!("{} x {}", extent.x, extent.y),
                format!(
                    "at most {MAX_OUTPUT_SCALE} times the exemplar's box ({} x {}) per side",
                    box_side.x, box_side.y
                ),
            ));
        }
        Ok(extent)
    }

    /// Samples per unit area of the reference plane: the points whose projection lies in
    /// the box's footprint, over its area. `1 / √density` is the spacing of a grid with
    /// as many samples.
    ///
    /// ```
    /// use patch_quilt::GeometryTexture;
    /// use pointset_core::HeightField;
    ///
    /// // Samples 0.1 apart: 100 per unit area.
    /// let field = HeightField::new(40, 40, vec![0.0; 1600])?;
    /// let texture = GeometryTexture::from_heightfield(&field, 0.1, 1.0, 4)?;
    /// assert!((texture.sample_density() / 100.0 - 1.0).abs() < 0.1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn sample_density(&self) -> f64 {
        let (lo, hi) = self.footprint();
        // The box has a positive extent (`new` refuses any other), so the area is too.
        let area = f64::from(hi.x - lo.x) * f64::from(hi.y - lo.y);
        let inside = self
            .points
            .positions()
            .iter()
            .filter(|p| {
                let q = p.truncate();
                q.cmpge(lo).all() && q.cmple(hi).all()
            })
            .count();
        inside as f64 / area
    }
}
