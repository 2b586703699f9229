//! An orthographic camera fitted to the geometry.

use glam::Vec3;

/// Which world axis points up in the preview.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UpAxis {
    /// +Y up (scanned models such as the Stanford bunny).
    #[default]
    Y,
    /// +Z up (height fields, terrain, geometry textures on the XY plane).
    Z,
}

/// Orthographic view: screen axes `right`/`up`, `toward` the viewer, and a pixel scale.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Camera {
    pub right: Vec3,
    pub up: Vec3,
    pub toward: Vec3,
    pub light: Vec3,
    center: Vec3,
    scale: f32,
    width: f32,
    height: f32,
}

/// A projected point: pixel coordinates and depth (larger is closer to the viewer).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Projected {
    pub x: f32,
    pub y: f32,
    pub depth: f32,
}

impl Camera {
    /// A camera looking from `azimuth`/`elevation` (degrees) that fits `points` into
    /// 90% of a `width × height` image.
    pub fn fitted(
        points: &[Vec3],
        up_axis: UpAxis,
        azimuth: f32,
        elevation: f32,
        width: u32,
        height: u32,
    ) -> Self {
        let (az, el) = (azimuth.to_radians(), elevation.to_radians());
        // View direction in a Y-up frame, then rotated for Z-up scenes.
        let toward_y = Vec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos());
        let (world_up, toward) = match up_axis {
            UpAxis::Y => (Vec3::Y, toward_y),
            UpAxis::Z => (Vec3::Z, Vec3::new(toward_y.x, -toward_y.z, toward_y.y)),
        };
        let mut right = world_up.cross(toward).normalize_or_zero();
        if right == Vec3::ZERO {
            // Looking straight down the up axis: pick any perpendicular.
            right = toward.any_orthonormal_vector();
        }
        let up = toward.cross(right).normalize();
        let light = (toward + 0.45 * up - 0.3 * right).normalize();
        let mut cam = Self {
            right,
            up,
            toward,
            light,
            center: Vec3::ZERO,
            scale: 1.0,
            width: width as f32,
            height: height as f32,
        };
        let (mut lo, mut hi) = (glam::Vec2::splat(f32::MAX), glam::Vec2::splat(f32::MIN));
        for &p in points {
            let s = glam::Vec2::new(p.dot(right), p.dot(up));
            lo = lo.min(s);
            hi = hi.max(s);
        }
        if points.is_empty() {
            lo = glam::Vec2::ZERO;
            hi = glam::Vec2::ONE;
        }
        let mid = (lo + hi) * 0.5;
        let span = (hi - lo).max(glam::Vec2::splat(1e-6));
        cam.center = right * mid.x + up * mid.y;
        cam.scale = (0.9 * cam.width / span.x).min(0.9 * cam.height / span.y);
        cam
    }

    /// Pixels per world unit.
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// The same view at `scale` pixels per world unit, still centred where it was.
    pub fn with_scale(self, scale: f32) -> Self {
        Self { scale, ..self }
    }

    /// Projects a world point to pixel coordinates.
    pub fn project(&self, p: Vec3) -> Projected {
        let rel = p - self.center;
        Projected {
            x: 0.5 * self.width + rel.dot(self.right) * self.scale,
            y: 0.5 * self.height - rel.dot(self.up) * self.scale,
            depth: rel.dot(self.toward),
        }
    }

    /// Lambert shade for a normal, lit two-sided from a light near the viewer.
    pub fn shade(&self, normal: Vec3) -> f32 {
        const AMBIENT: f32 = 0.12;
        AMBIENT + (1.0 - AMBIENT) * normal.dot(self.light).abs()
    }
}
