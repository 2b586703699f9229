//! Headless previews: point sets as shaded, depth-tested splats and meshes as shaded,
//! z-buffered triangles, rendered on the CPU into PNG images.
//!
//! The camera is orthographic, looks at the geometry from `azimuth`/`elevation`, and is
//! fitted so the geometry fills 90% of the image. Lighting is Lambertian, two-sided, from a
//! light slightly above and left of the viewer, so surfaces darken toward silhouettes.
//! Stored colours (`red/green/blue` channels) are used when present; otherwise
//! [`RenderOptions::color`]. Rendering is deterministic.
//!
//! Points with normals are drawn as surface splats: a disc in each point's tangent plane,
//! as wide as the distance to its eighth nearest point (between one and four median
//! spacings, [`KdIndex::median_spacing`](crate::core::KdIndex::median_spacing), which looks
//! past duplicated samples). Where the surface curves so much that the disc's rim would
//! leave it by more than a quarter of a spacing (a tube about as thin as its sampling),
//! the disc is narrowed to an ellipse along the surface's principal directions, fitted
//! from the same neighbours, but not below a spacing. The nearest surface is found
//! first; then the colours and normals of the splats within half a radius of it are
//! blended with Gaussian weights (each normal turned to agree with the nearest splat's,
//! so normals of either sign shade alike) and shaded once per pixel, so a sampled
//! surface shades as smoothly as a mesh: a unit sphere of 20,000 random points comes
//! within about one grey level of its analytic shading. A gap in the sampling wider than
//! the discs shows as a speck. A point set
//! without normals gets them from local PCA over 12 neighbours
//! ([`mls_surface::fit_normals`]; the splats do not need them oriented), and is drawn the
//! same way; points whose neighbours fit no plane (on a line, coincident) are drawn as
//! small shaded spheres of 1.1 median spacings.
//!
//! Images are drawn in bands of rows, in parallel, each band with buffers for its own
//! rows only; the picture does not depend on the bands or the number of threads.
//!
//! ```
//! use geosynth::core::io::Geometry;
//! use geosynth::preview::{render, RenderOptions};
//! use geosynth::fixtures;
//!
//! let sphere = Geometry::Points(fixtures::sphere_points(2000)?);
//! let image = render(&sphere, &RenderOptions::default().size(160, 120))?;
//! assert_eq!(image.dimensions(), (160, 120));
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod bands;
mod camera;
mod raster;
mod splat_shape;
#[cfg(test)]
mod tests;

use std::borrow::Cow;
use std::path::Path;

use glam::Vec3;
use mls_surface::{NORMAL_NEIGHBOURS, fit_normals};
use pointset_core::io::{Geometry, replace_file};
use pointset_core::strays::kept_indices;
use pointset_core::{KdIndex, NormalWeighting, PointSet};

use crate::imagery::io_error;
use crate::{Error, Result};
use bands::{BAND_ROWS, draw_in_bands};
use camera::Camera;
pub use camera::UpAxis;
/// The image type previews are returned as (from the `image` crate).
pub use image::RgbImage;
use raster::{Footprint, SurfaceSplat, sphere_rows, triangle_rows};
use splat_shape::splat_shapes;

/// How to render a preview.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct RenderOptions {
    /// Image (or panel) width in pixels; default 640.
    pub width: u32,
    /// Image (or panel) height in pixels; default 480.
    pub height: u32,
    /// Camera azimuth around the up axis in degrees; default 30.
    pub azimuth: f32,
    /// Camera elevation above the horizontal plane in degrees; default 25.
    pub elevation: f32,
    /// Which world axis is up; default +Y.
    pub up: UpAxis,
    /// Surface colour (RGB in `0..=1`) when the geometry has none; default light grey-blue.
    pub color: [f32; 3],
    /// Background colour; default white.
    pub background: [f32; 3],
    /// Multiplies the automatic splat radius; default 1.
    pub splat_scale: f32,
    /// Pixels per world unit; default `None`: fitted so the geometry fills 90% of the
    /// image ([`fitted_pixels_per_unit`]). Set it to draw several geometries at one scale
    /// (an exemplar beside a larger output); the view stays centred on each geometry.
    pub pixels_per_unit: Option<f32>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            width: 640,
            height: 480,
            azimuth: 30.0,
            elevation: 25.0,
            up: UpAxis::Y,
            color: [0.78, 0.8, 0.88],
            background: [1.0, 1.0, 1.0],
            splat_scale: 1.0,
            pixels_per_unit: None,
        }
    }
}

impl RenderOptions {
    /// Sets the image size (default 640 × 480).
    pub fn size(mut self, width: u32, height: u32) -> Self {
        self.width = width;
        self.height = height;
        self
    }

    /// Sets the view direction in degrees (default azimuth 30, elevation 25).
    pub fn view(mut self, azimuth: f32, elevation: f32) -> Self {
        self.azimuth = azimuth;
        self.elevation = elevation;
        self
    }

    /// Sets the up axis (default +Y).
    pub fn up(mut self, up: UpAxis) -> Self {
        self.up = up;
        self
    }

    /// Sets the surface colour used when the geometry has none (default light grey-blue).
    pub fn color(mut self, color: [f32; 3]) -> Self {
        self.color = color;
        self
    }

    /// Sets the pixels per world unit instead of fitting the view to the geometry
    /// ([`RenderOptions::pixels_per_unit`]).
    pub fn pixels_per_unit(mut self, pixels_per_unit: f32) -> Self {
        self.pixels_per_unit = Some(pixels_per_unit);
        self
    }

    /// Checks sizes (1..=8192 pixels), finite angles, colours in `0..=1`, positive splat
    /// scale and pixels per unit.
    pub fn validate(&self) -> Result<()> {
        let bad = Error::invalid::<()>;
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if !(1..=8192).contains(&v) {
                return bad(name, v.to_string(), "1 to 8192 pixels");
            }
        }
        if !(self.azimuth.is_finite() && self.elevation.is_finite()) {
            return bad(
                "azimuth/elevation",
                format!("{}/{}", self.azimuth, self.elevation),
                "finite angles",
            );
        }
        for (name, c) in [("color", self.color), ("background", self.background)] {
            if c.iter().any(|v| !(0.0..=1.0).contains(v)) {
                return bad(name, format!("{c:?}"), "RGB components in 0..=1");
            }
        }
        if !(self.splat_scale.is_finite() && self.splat_scale > 0.0) {
            return bad(
                "splat_scale",
                self.splat_scale.to_string(),
                "a positive number",
            );
        }
        if let Some(s) = self.pixels_per_unit
            && !(s.is_finite() && s > 0.0)
        {
            return bad("pixels_per_unit", s.to_string(), "a positive number");
        }
        Ok(())
    }
}

/// Renders one geometry into an image of `options.width × options.height`. A point set's
/// view frames the points that are not stray ([`pointset_core::strays::kept_indices`]):
/// one outlier would shrink the rest to a speck; the stray points are drawn where they
/// fall in that frame.
pub fn render(geometry: &Geometry, options: &RenderOptions) -> Result<RgbImage> {
    render_in_bands(geometry, options, BAND_ROWS)
}

/// [`render`], drawing bands of `band_rows` rows (the picture does not depend on it).
fn render_in_bands(
    geometry: &Geometry,
    options: &RenderOptions,
    band_rows: usize,
) -> Result<RgbImage> {
    options.validate()?;
    let points = geometry.points();
    let framed = framed_positions(geometry);
    let cam = camera(&framed, options);
    let size = (options.width as usize, options.height as usize);
    let background = Vec3::from(options.background);
    let fallback = Vec3::from(options.color);
    let colors: Vec<Vec3> = match points.colors() {
        Some(c) => c.into_iter().map(Vec3::from).collect(),
        None => vec![fallback; points.len()],
    };
    let rgb = match geometry.mesh() {
        Some(mesh) => {
            let computed;
            let normals = match mesh.vertices().normals() {
                Some(n) => n,
                None => {
                    computed = mesh.vertex_normals(NormalWeighting::Angle);
                    &computed
                }
            };
            let projected: Vec<_> = mesh.positions().iter().map(|&p| cam.project(p)).collect();
            let corners = |t: [u32; 3]| t.map(|v| v as usize);
            let triangles = mesh.triangles();
            let rows = triangles
                .iter()
                .map(|&t| triangle_rows(&corners(t).map(|v| projected[v])));
            draw_in_bands(size, band_rows, background, rows, |band, drawn| {
                for &t in drawn {
                    let [a, b, c] = corners(triangles[t]);
                    band.triangle(
                        &cam,
                        [projected[a], projected[b], projected[c]],
                        [normals[a], normals[b], normals[c]],
                        [colors[a], colors[b], colors[c]],
                    );
                }
            })
        }
        None => draw_points(
            points,
            &framed,
            &colors,
            &cam,
            options,
            (size, band_rows, background),
        )?,
    };
    RgbImage::from_raw(options.width, options.height, rgb).ok_or(Error::InvalidParameter {
        name: "width/height",
        value: format!("{}x{}", options.width, options.height),
        expected: "a size whose pixel buffer fits in memory".into(),
    })
}

/// A point set's picture, drawn in bands (`(size, band_rows, background)` as for
/// [`draw_in_bands`]): points with normals as surface splats, the normals given or, when
/// the set has none, estimated by local PCA ([`fit_normals`]; their signs do not matter to
/// the splats); points whose neighbourhoods define no normal (on a line, coincident, too
/// few) as small shaded spheres of 1.1 median spacings.
fn draw_points(
    points: &PointSet,
    framed: &[Vec3],
    colors: &[Vec3],
    cam: &Camera,
    options: &RenderOptions,
    (size, band_rows, background): ((usize, usize), usize, Vec3),
) -> Result<Vec<u8>> {
    let index = KdIndex::new(framed)?;
    let spacing = index.median_spacing()?;
    let positions = points.positions();
    let estimated;
    let (normals, undefined) = match points.normals() {
        Some(normals) => (normals, Vec::new()),
        None if points.len() >= 3 => {
            let fit = fit_normals(points, NORMAL_NEIGHBOURS)?;
            estimated = fit.points;
            match estimated.normals() {
                Some(normals) => (normals, fit.undefined),
                None => (&[][..], (0..points.len()).collect()),
            }
        }
        None => (&[][..], (0..points.len()).collect()),
    };
    let mut is_sphere = vec![false; points.len()];
    for &i in &undefined {
        is_sphere[i] = true;
    }
    let oriented: Vec<usize> = (0..points.len()).filter(|&i| !is_sphere[i]).collect();
    let px = cam.scale() * options.splat_scale;
    let shapes = splat_shapes(&index, framed, (positions, normals, &oriented), spacing, px)?;
    let footprints: Vec<Footprint> = oriented
        .iter()
        .zip(shapes)
        .map(|(&i, shape)| {
            let splat = SurfaceSplat {
                centre: cam.project(positions[i]),
                normal: normals[i],
                albedo: colors[i],
                shape,
            };
            Footprint::new(cam, &splat)
        })
        .collect();
    let radius = (1.1 * spacing * px).clamp(1.0, 64.0);
    let spheres: Vec<_> = undefined
        .iter()
        .map(|&i| (cam.project(positions[i]), colors[i]))
        .collect();
    // The footprints are listed first, then the spheres.
    let rows = footprints
        .iter()
        .map(Footprint::rows)
        .chain(spheres.iter().map(|&(p, _)| sphere_rows(p, radius)));
    Ok(draw_in_bands(
        size,
        band_rows,
        background,
        rows,
        |band, drawn| {
            let splats = drawn.partition_point(|&k| k < footprints.len());
            for &k in &drawn[splats..] {
                if let Some(&(centre, albedo)) = spheres.get(k - footprints.len()) {
                    band.sphere_splat(cam, centre, radius, albedo);
                }
            }
            band.surface_splats(cam, &footprints, &drawn[..splats]);
        },
    ))
}

/// The pixels per world unit at which `geometry` fills 90% of an image of `options`
/// (its width, height, view and up axis): what [`render`] uses unless
/// [`RenderOptions::pixels_per_unit`] is set. The smallest of several geometries' values
/// draws them all at one scale, each within its panel.
pub fn fitted_pixels_per_unit(geometry: &Geometry, options: &RenderOptions) -> Result<f32> {
    options.validate()?;
    let fitted = RenderOptions {
        pixels_per_unit: None,
        ..options.clone()
    };
    Ok(camera(&framed_positions(geometry), &fitted).scale())
}

/// The largest pixels per world unit at which every geometry panel of `panels` fits its
/// panel (each seen with its own up axis), or `None` when none is geometry: set it as
/// [`RenderOptions::pixels_per_unit`] to draw the panels at one scale.
pub fn common_pixels_per_unit(
    panels: &[Panel<'_>],
    options: &RenderOptions,
) -> Result<Option<f32>> {
    let mut common: Option<f32> = None;
    for panel in panels {
        if let Panel::Geometry(geometry, up) = panel {
            let scale = fitted_pixels_per_unit(geometry, &options.clone().up(*up))?;
            common = Some(common.map_or(scale, |c| c.min(scale)));
        }
    }
    Ok(common)
}

/// The positions the view is fitted to: a mesh's vertices, or a point set's points that
/// are not stray ([`pointset_core::strays::kept_indices`]).
fn framed_positions(geometry: &Geometry) -> Cow<'_, [Vec3]> {
    let positions = geometry.points().positions();
    match geometry {
        Geometry::Points(_) => Cow::Owned(
            kept_indices(positions)
                .into_iter()
                .map(|i| positions[i])
                .collect(),
        ),
        Geometry::Mesh(_) => Cow::Borrowed(positions),
    }
}

/// The camera of `options` centred on `framed`, fitted to it unless the options fix the
/// pixels per unit.
fn camera(framed: &[Vec3], options: &RenderOptions) -> Camera {
    let cam = Camera::fitted(
        framed,
        options.up,
        options.azimuth,
        options.elevation,
        options.width,
        options.height,
    );
    match options.pixels_per_unit {
        Some(scale) => cam.with_scale(scale),
        None => cam,
    }
}

/// Width of the grey separator between panels, in pixels.
const PANEL_GAP: u32 = 4;

/// One panel of a side-by-side preview.
#[derive(Debug, Clone, Copy)]
pub enum Panel<'a> {
    /// Geometry rendered with the shared options, seen with the given up axis.
    Geometry(&'a Geometry, UpAxis),
    /// A picture (a texture exemplar or output) scaled to fit the panel.
    Image(&'a RgbImage),
}

/// Renders each panel at `options.width × options.height` and places them side by side,
/// separated by grey gaps.
pub fn render_panels(panels: &[Panel<'_>], options: &RenderOptions) -> Result<RgbImage> {
    options.validate()?;
    let n = panels.len().max(1) as u32;
    let total_width = n * options.width + (n - 1) * PANEL_GAP;
    let mut out = RgbImage::from_pixel(total_width, options.height, image::Rgb([160, 160, 160]));
    for (k, panel) in panels.iter().enumerate() {
        let rendered = match panel {
            Panel::Geometry(g, up) => render(g, &options.clone().up(*up))?,
            Panel::Image(img) => fit_image(img, options),
        };
        let x0 = k as u32 * (options.width + PANEL_GAP);
        image::imageops::replace(&mut out, &rendered, i64::from(x0), 0);
    }
    Ok(out)
}

/// [`render_panels`] with every geometry panel drawn at one scale,
/// [`common_pixels_per_unit`]: the largest at which each fits its panel. An exemplar beside
/// a larger output then shows its features the same size.
pub fn render_panels_at_one_scale(
    panels: &[Panel<'_>],
    options: &RenderOptions,
) -> Result<RgbImage> {
    match common_pixels_per_unit(panels, options)? {
        Some(scale) => render_panels(panels, &options.clone().pixels_per_unit(scale)),
        None => render_panels(panels, options),
    }
}

/// Scales a picture to fit the panel (keeping its aspect ratio) on the background colour.
fn fit_image(img: &RgbImage, options: &RenderOptions) -> RgbImage {
    let bg = options.background.map(|c| (c * 255.0).round() as u8);
    let mut panel = RgbImage::from_pixel(options.width, options.height, image::Rgb(bg));
    let (w, h) = img.dimensions();
    if w == 0 || h == 0 {
        return panel;
    }
    let s = (options.width as f32 / w as f32).min(options.height as f32 / h as f32);
    let (sw, sh) = (
        ((w as f32 * s) as u32).max(1),
        ((h as f32 * s) as u32).max(1),
    );
    // Nearest-neighbour keeps texels crisp, which is what one wants to inspect exemplars.
    let scaled = image::imageops::resize(img, sw, sh, image::imageops::FilterType::Nearest);
    let (x0, y0) = ((options.width - sw) / 2, (options.height - sh) / 2);
    image::imageops::replace(&mut panel, &scaled, i64::from(x0), i64::from(y0));
    panel
}

/// Saves an image as PNG (the format is fixed regardless of the extension), whole or not
/// at all ([`pointset_core::io::FileReplacement`]).
pub fn save_png<P, C>(image: &image::ImageBuffer<P, C>, path: &Path) -> Result<()>
where
    P: image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
    C: std::ops::Deref<Target = [P::Subpixel]>,
{
    let image_error = |source| Error::Image {
        path: path.to_path_buf(),
        source,
    };
    replace_file(
        path,
        |out| {
            image
                .write_to(out, image::ImageFormat::Png)
                .map_err(image_error)
        },
        io_error(path),
    )
}
