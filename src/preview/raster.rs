//! A z-buffered framebuffer with triangle and splat rasterization, one band of rows at a
//! time.

use glam::{Vec2, Vec3};

use super::camera::{Camera, Projected};
use super::splat_shape::SplatShape;

/// Colour and depth buffers of a band of an image's rows; depth is "closeness" (larger
/// wins). Drawing takes pixel coordinates in the whole image and keeps what falls in the
/// band, so a picture drawn band by band is the picture drawn whole.
pub(crate) struct FrameBuffer {
    width: usize,
    /// The band's first row in the image.
    top: usize,
    /// The band's number of rows.
    rows: usize,
    color: Vec<Vec3>,
    depth: Vec<f32>,
}

impl FrameBuffer {
    /// Rows `top..top + rows` of an image `width` pixels wide, filled with `background`.
    pub fn band(width: usize, top: usize, rows: usize, background: Vec3) -> Self {
        Self {
            width,
            top,
            rows,
            color: vec![background; width * rows],
            depth: vec![f32::NEG_INFINITY; width * rows],
        }
    }

    /// The buffers' index of image pixel `(x, y)`, which must lie in the band.
    fn index(&self, x: usize, y: usize) -> usize {
        (y - self.top) * self.width + x
    }

    fn test_and_set(&mut self, x: usize, y: usize, depth: f32, color: Vec3) {
        let i = self.index(x, y);
        if depth > self.depth[i] {
            self.depth[i] = depth;
            self.color[i] = color;
        }
    }

    /// Image pixel bounds of a screen-space box, clipped to the band; `None` when it
    /// misses the band.
    fn clip(&self, lo: Vec2, hi: Vec2) -> Option<(usize, usize, usize, usize)> {
        let (x0, x1) = pixel_span(lo.x, hi.x, 0, self.width)?;
        let (y0, y1) = pixel_span(lo.y, hi.y, self.top, self.top + self.rows)?;
        Some((x0, y0, x1, y1))
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

    /// Draws a point without a normal as a small sphere of pixel radius `radius`, shaded
    /// by the sphere's own normals so that it still reads as 3D. Its depth
    /// bulges toward the viewer like a sphere, which resolves overlaps.
    pub fn sphere_splat(&mut self, cam: &Camera, p: Projected, radius: f32, albedo: Vec3) {
        let r = sphere_radius(radius);
        let lo = Vec2::new(p.x - r, p.y - r);
        let hi = Vec2::new(p.x + r, p.y + r);
        let Some((x0, y0, x1, y1)) = self.clip(lo, hi) else {
            return;
        };
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = Vec2::new(x as f32 + 0.5 - p.x, y as f32 + 0.5 - p.y) / r;
                let d2 = d.length_squared();
                if d2 > 1.0 {
                    continue;
                }
                let bulge = (1.0 - d2).sqrt();
                let depth = p.depth + bulge * r / cam.scale();
                let n = cam.right * d.x - cam.up * d.y + cam.toward * bulge;
                self.test_and_set(x, y, depth, albedo * cam.shade(n));
            }
        }
    }

    /// Draws oriented points as surface splats, `footprints[k]` for each `k` of `drawn`
    /// in that order: discs or ellipses in each point's tangent plane. The nearest surface
    /// is found first; then the albedos and normals of every splat within half its radius
    /// of it are blended with Gaussian weights and shaded once per pixel. Before blending,
    /// each normal is turned to agree with the nearest splat's there, so normals of either
    /// sign and both sides of a sheet shade alike, and the splats just behind a closed
    /// surface's silhouette blend with those just in front instead of cancelling them.
    pub fn surface_splats(&mut self, cam: &Camera, footprints: &[Footprint], drawn: &[usize]) {
        let drawn = || drawn.iter().filter_map(|&k| footprints.get(k));
        let mut nearest_normal = vec![Vec3::ZERO; self.color.len()];
        for f in drawn() {
            self.cover(f, |fb, i, depth, _| {
                if depth > fb.depth[i] {
                    fb.depth[i] = depth;
                    nearest_normal[i] = f.normal;
                }
            });
        }
        let mut blend = vec![(Vec3::ZERO, Vec3::ZERO, 0.0f32); self.color.len()];
        for f in drawn() {
            // Within half its radius of the nearest surface, a splat belongs to that
            // surface.
            let tolerance = 0.5 * f.radius * f.world_per_px;
            self.cover(f, |fb, i, depth, rho2| {
                if depth >= fb.depth[i] - tolerance {
                    let w = (-2.0 * rho2).exp();
                    let b = &mut blend[i];
                    let agreeing = if f.normal.dot(nearest_normal[i]) < 0.0 {
                        -f.normal
                    } else {
                        f.normal
                    };
                    b.0 += w * agreeing;
                    b.1 += w * f.albedo;
                    b.2 += w;
                }
            });
        }
        for (color, (normal, albedo, weight)) in self.color.iter_mut().zip(blend) {
            if weight > 0.0 {
                *color = albedo / weight * cam.shade(normal.normalize_or_zero());
            }
        }
    }

    /// Calls `visit(self, pixel, depth, ρ²)` for each pixel the splat's ellipse covers,
    /// with the depth of its plane there and its squared distance from the centre in
    /// radii (1 on the ellipse's rim).
    fn cover(&mut self, f: &Footprint, mut visit: impl FnMut(&mut Self, usize, f32, f32)) {
        let c = Vec2::new(f.centre.x, f.centre.y);
        let Some((x0, y0, x1, y1)) =
            self.clip(c - Vec2::splat(f.radius), c + Vec2::splat(f.radius))
        else {
            return;
        };
        let inv_r2 = 1.0 / (f.radius * f.radius);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) - c;
                let along_view = -d.dot(f.slope);
                let across = d.dot(f.along_minor);
                let rho2 = (d.length_squared() + along_view * along_view) * inv_r2
                    + across * across * f.minor_excess;
                if rho2 <= 1.0 {
                    let depth = f.centre.depth + along_view * f.world_per_px;
                    visit(self, self.index(x, y), depth, rho2);
                }
            }
        }
    }

    /// Writes the band as 8-bit RGB bytes, row after row, into `out` (three bytes a pixel).
    pub fn write_rgb8(&self, out: &mut [u8]) {
        for (rgb, c) in out.chunks_exact_mut(3).zip(&self.color) {
            for (byte, v) in rgb.iter_mut().zip(c.to_array()) {
                *byte = (v.clamp(0.0, 1.0) * 255.0).round() as u8;
            }
        }
    }
}

/// The first and last of the pixels `first..end` (along one axis) that a span from `lo`
/// to `hi` in pixel coordinates touches; `None` when it touches none or is not finite.
pub(crate) fn pixel_span(lo: f32, hi: f32, first: usize, end: usize) -> Option<(usize, usize)> {
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let from = (lo.floor() as i64).max(first as i64);
    let to = (hi.ceil() as i64).min(end as i64 - 1);
    (to >= from).then_some((from as usize, to as usize))
}

/// An oriented point to draw as an ellipse in its tangent plane.
pub(crate) struct SurfaceSplat {
    /// The point, projected.
    pub centre: Projected,
    /// Its normal (either sign).
    pub normal: Vec3,
    /// Its colour.
    pub albedo: Vec3,
    /// The ellipse's radii in pixels and its minor axis.
    pub shape: SplatShape,
}

/// A surface splat's screen footprint: the ellipse it projects to.
pub(crate) struct Footprint {
    centre: Projected,
    /// The ellipse's larger radius in pixels.
    radius: f32,
    /// Maps a screen offset from the centre to the offset's component along the
    /// ellipse's minor axis, in pixels.
    along_minor: Vec2,
    /// `1 / minor² − 1 / radius²`: what the minor axis adds to the squared distance
    /// from the centre in radii per squared pixel along it (0 for a disc).
    minor_excess: f32,
    /// How far the disc's plane recedes from the viewer per pixel of screen offset
    /// (pixels along the view per pixel across it).
    slope: Vec2,
    /// World units per pixel.
    world_per_px: f32,
    /// The point's normal, as given.
    normal: Vec3,
    albedo: Vec3,
}

/// The smallest share of a splat's normal along the view used for its footprint: a disc
/// seen edge-on is drawn as an ellipse about this wide (in radii), not as a line that
/// pixels miss.
const MIN_FACING: f32 = 0.3;

impl Footprint {
    /// The footprint of `splat` seen by `cam`.
    pub fn new(cam: &Camera, splat: &SurfaceSplat) -> Self {
        // The plane's slope is the same for either sign of the normal; take the one
        // facing the viewer.
        let facing_normal = if splat.normal.dot(cam.toward) < 0.0 {
            -splat.normal
        } else {
            splat.normal
        };
        let facing = facing_normal.dot(cam.toward).max(MIN_FACING);
        // Screen y grows downward, opposite to the camera's up.
        let slope = Vec2::new(facing_normal.dot(cam.right), -facing_normal.dot(cam.up)) / facing;
        let radius = splat.shape.radius.max(0.5);
        let minor = splat.shape.minor_radius.clamp(0.5, radius);
        let axis = splat.shape.minor_axis;
        // A screen offset d lies at d.x·right − d.y·up − (d·slope)·toward on the plane.
        let along_minor = Vec2::new(
            cam.right.dot(axis) - slope.x * cam.toward.dot(axis),
            -cam.up.dot(axis) - slope.y * cam.toward.dot(axis),
        );
        Self {
            centre: splat.centre,
            radius,
            along_minor,
            minor_excess: 1.0 / (minor * minor) - 1.0 / (radius * radius),
            slope,
            world_per_px: 1.0 / cam.scale(),
            normal: splat.normal,
            albedo: splat.albedo,
        }
    }

    /// The rows the footprint may cover: its top and bottom in pixel coordinates.
    pub fn rows(&self) -> (f32, f32) {
        (self.centre.y - self.radius, self.centre.y + self.radius)
    }
}

/// The rows a sphere splat of `radius` pixels at `p` may cover
/// ([`FrameBuffer::sphere_splat`]): its top and bottom in pixel coordinates.
pub(crate) fn sphere_rows(p: Projected, radius: f32) -> (f32, f32) {
    let r = sphere_radius(radius);
    (p.y - r, p.y + r)
}

/// The rows a triangle may cover: its top and bottom in pixel coordinates.
pub(crate) fn triangle_rows(p: &[Projected; 3]) -> (f32, f32) {
    (
        p[0].y.min(p[1].y).min(p[2].y),
        p[0].y.max(p[1].y).max(p[2].y),
    )
}

/// The radius a sphere splat is drawn with: at least half a pixel.
fn sphere_radius(radius: f32) -> f32 {
    radius.max(0.5)
}
