//! A z-buffered framebuffer with triangle and splat rasterization.

use glam::{Vec2, Vec3};

use super::camera::{Camera, Projected};

/// Colour and depth buffers; depth is "closeness" (larger wins).
pub(crate) struct FrameBuffer {
    pub width: usize,
    pub height: usize,
    pub color: Vec<Vec3>,
    depth: Vec<f32>,
}

impl FrameBuffer {
    pub fn new(width: u32, height: u32, background: Vec3) -> Self {
        let (width, height) = (width as usize, height as usize);
        Self {
            width,
            height,
            color: vec![background; width * height],
            depth: vec![f32::NEG_INFINITY; width * height],
        }
    }

    fn test_and_set(&mut self, x: usize, y: usize, depth: f32, color: Vec3) {
        let i = y * self.width + x;
        if depth > self.depth[i] {
            self.depth[i] = depth;
            self.color[i] = color;
        }
    }

    /// Pixel bounds of a screen-space box, clipped to the image; `None` when off screen.
    fn clip(&self, lo: Vec2, hi: Vec2) -> Option<(usize, usize, usize, usize)> {
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        let x0 = lo.x.floor().max(0.0) as usize;
        let y0 = lo.y.floor().max(0.0) as usize;
        let x1 = (hi.x.ceil() as i64).min(self.width as i64 - 1);
        let y1 = (hi.y.ceil() as i64).min(self.height as i64 - 1);
        (x1 >= x0 as i64 && y1 >= y0 as i64).then_some((x0, y0, x1 as usize, y1 as usize))
    }

    /// Fills a triangle, interpolating depth, normal and colour, shading per pixel.
    pub fn triangle(&mut self, cam: &Camera, p: [Projected; 3], n: [Vec3; 3], c: [Vec3; 3]) {
        let s = p.map(|q| Vec2::new(q.x, q.y));
        let area = (s[1] - s[0]).perp_dot(s[2] - s[0]);
        if area.abs() < 1e-12 {
            return;
        }
        let lo = s[0].min(s[1]).min(s[2]);
        let hi = s[0].max(s[1]).max(s[2]);
        let Some((x0, y0, x1, y1)) = self.clip(lo, hi) else {
            return;
        };
        for y in y0..=y1 {
            for x in x0..=x1 {
                let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let w0 = (s[2] - s[1]).perp_dot(q - s[1]) / area;
                let w1 = (s[0] - s[2]).perp_dot(q - s[2]) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let depth = w0 * p[0].depth + w1 * p[1].depth + w2 * p[2].depth;
                let normal = (n[0] * w0 + n[1] * w1 + n[2] * w2).normalize_or_zero();
                let albedo = c[0] * w0 + c[1] * w1 + c[2] * w2;
                self.test_and_set(x, y, depth, albedo * cam.shade(normal));
            }
        }
    }

    /// Draws a round splat of pixel radius `radius`. With a normal it is shaded flat by that
    /// normal; without one it is shaded as a small sphere, so unoriented points still read
    /// as 3D. Splat depth bulges toward the viewer like a sphere, which resolves overlaps.
    pub fn splat(
        &mut self,
        cam: &Camera,
        p: Projected,
        radius: f32,
        normal: Option<Vec3>,
        albedo: Vec3,
    ) {
        let r = radius.max(0.5);
        let lo = Vec2::new(p.x - r, p.y - r);
        let hi = Vec2::new(p.x + r, p.y + r);
        let Some((x0, y0, x1, y1)) = self.clip(lo, hi) else {
            return;
        };
        let flat = normal.map(|n| albedo * cam.shade(n));
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = Vec2::new(x as f32 + 0.5 - p.x, y as f32 + 0.5 - p.y) / r;
                let d2 = d.length_squared();
                if d2 > 1.0 {
                    continue;
                }
                let bulge = (1.0 - d2).sqrt();
                let depth = p.depth + bulge * r / cam.scale();
                let color = flat.unwrap_or_else(|| {
                    let n = cam.right * d.x - cam.up * d.y + cam.toward * bulge;
                    albedo * cam.shade(n)
                });
                self.test_and_set(x, y, depth, color);
            }
        }
    }

    /// Converts to 8-bit RGB bytes.
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.color
            .iter()
            .flat_map(|c| {
                c.to_array()
                    .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
            })
            .collect()
    }
}
