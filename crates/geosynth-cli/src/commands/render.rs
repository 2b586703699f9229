//! `geosynth render`.

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use geosynth::core::TriMesh;
use geosynth::core::io::Geometry;
use geosynth::imagery;
use geosynth::preview::{self, Panel, RenderOptions, UpAxis};
use geosynth::sdf::{isosurface, nrrd};

use crate::input_file::{named, read_geometry};
use crate::output::{check_output_paths, report_not_kept, status};
use crate::{CliResult, Globals};

/// The up axis, as a command-line value.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Up {
    /// +Y is up (scanned models).
    Y,
    /// +Z is up (height fields, terrain).
    Z,
}

impl From<Up> for UpAxis {
    fn from(up: Up) -> Self {
        match up {
            Up::Y => UpAxis::Y,
            Up::Z => UpAxis::Z,
        }
    }
}

/// View settings shared by every command that writes previews.
#[derive(Debug, Clone, Args)]
pub struct ViewArgs {
    /// Panel width in pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Panel height in pixels.
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    /// Camera azimuth around the up axis, degrees.
    #[arg(long, default_value_t = 30.0, allow_negative_numbers = true)]
    pub azimuth: f32,
    /// Camera elevation, degrees.
    #[arg(long, default_value_t = 25.0, allow_negative_numbers = true)]
    pub elevation: f32,
    /// Which axis points up.
    #[arg(long, value_enum, default_value_t = Up::Y)]
    pub up: Up,
    /// Surface colour for geometry without colours: `R,G,B` in 0..1 or `#rrggbb`.
    #[arg(long, value_parser = parse_color)]
    pub color: Option<[f32; 3]>,
}

impl ViewArgs {
    /// The render options these arguments describe.
    pub fn options(&self) -> RenderOptions {
        let mut o = RenderOptions::default()
            .size(self.width, self.height)
            .view(self.azimuth, self.elevation)
            .up(self.up.into());
        if let Some(c) = self.color {
            o = o.color(c);
        }
        o
    }
}

/// Parses `R,G,B` (floats in 0..1) or `#rrggbb`.
fn parse_color(s: &str) -> Result<[f32; 3], String> {
    if let Some(hex) = s.strip_prefix('#') {
        let v = u32::from_str_radix(hex, 16).map_err(|_| format!("`{s}` is not #rrggbb"))?;
        if hex.len() != 6 {
            return Err(format!("`{s}` is not #rrggbb"));
        }
        return Ok([16, 8, 0].map(|shift| ((v >> shift) & 0xff) as f32 / 255.0));
    }
    let rgb: [f32; 3] = super::comma_values(s, "R,G,B")?;
    if rgb.iter().all(|c| (0.0..=1.0).contains(c)) {
        Ok(rgb)
    } else {
        Err(format!("`{s}` needs three components in 0..1"))
    }
}

/// Arguments of `geosynth render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// Files to render, each a panel, left to right: point sets and meshes (.ply, .obj,
    /// .off, .stl, .glb, .gltf, .xyz, .las, .pcd), pictures (.png, .jpg), raw height fields
    /// (`name_WxH.f32le`, or raw files with an ENVI header: `.f32le`, `.bil`, `.img`, …)
    /// and one-band TIFFs (GeoTIFF DEMs), drawn as shaded terrain, and NRRD volumes (.nrrd
    /// or .nhdr, drawn as the zero level set of their first channel: the surface of a
    /// signed distance field).
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Output PNG.
    #[arg(short, long)]
    output: PathBuf,
    /// Draw pictures as height fields (grey level = height) instead of as pictures.
    #[arg(long)]
    heightfield: bool,
    /// Height range of drawn height fields, relative to their longer side (at most
    /// 100).
    #[arg(long, default_value_t = 0.2)]
    relief: f32,
    /// Draw every geometry panel at one scale (the largest at which each fits), so a
    /// quilt and its exemplar, or two outputs, show their features the same size; by
    /// default each panel is fitted to its own geometry.
    #[arg(long)]
    same_scale: bool,
    #[command(flatten)]
    view: ViewArgs,
}

/// A loaded input, ready to become a panel.
enum Input {
    Geometry(Geometry, UpAxis),
    Picture(preview::RgbImage),
}

fn load(path: &Path, args: &RenderArgs, globals: Globals) -> CliResult<Input> {
    let as_heightfield = imagery::is_heightfield_path(path)
        || imagery::is_envi_raw_path(path)
        || (args.heightfield && imagery::is_image_path(path));
    if as_heightfield {
        let samples = imagery::read_height_samples(path)?;
        let (mesh, voids) = imagery::height_samples_mesh(samples, args.relief)?;
        if voids > 0 {
            status(
                globals,
                format!("{}: {voids} voids drawn as holes", path.display()),
            );
        }
        return Ok(Input::Geometry(Geometry::Mesh(mesh), UpAxis::Z));
    }
    if imagery::is_image_path(path) {
        return Ok(Input::Picture(imagery::read_image(path)?.into_rgb8()));
    }
    if nrrd::is_nrrd_path(path) {
        return Ok(Input::Geometry(
            Geometry::Mesh(zero_surface(path)?),
            args.view.up.into(),
        ));
    }
    // A picture does not depend on where the data lies, so georeferenced files are read
    // relative to an origin, at full precision.
    let loaded = read_geometry(path, globals)?;
    report_not_kept(globals, path, &loaded.notes);
    if loaded.geometry.points().is_empty() {
        status(
            globals,
            format!(
                "note: {} holds no points; its panel is empty",
                path.display()
            ),
        );
    }
    Ok(Input::Geometry(loaded.geometry, args.view.up.into()))
}

/// The zero level set of an NRRD volume's first channel (the surface of a signed distance
/// field), placed relative to the volume's origin (a picture does not depend on where the
/// data lies).
fn zero_surface(path: &Path) -> CliResult<TriMesh> {
    let volume = nrrd::read_file(path)?;
    if let Some(i) = volume.data.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "{}: value {i} is {}; a field with non-finite values has no surface to draw",
            path.display(),
            volume.data[i]
        )
        .into());
    }
    let grid = volume.scalar_grid_at(volume.origin)?;
    let mesh = isosurface(&grid, 0.0)?;
    if mesh.face_count() == 0 {
        let (lo, hi) = grid.value_range();
        return Err(format!(
            "{}: the field never crosses zero (values {lo} .. {hi}); no surface to draw",
            path.display()
        )
        .into());
    }
    Ok(mesh)
}

/// The tallest `--relief`: heights spanning 100 times the terrain's longer side.
const MAX_RELIEF: f32 = 100.0;

/// Runs `geosynth render`.
pub fn run(args: &RenderArgs, globals: Globals) -> CliResult {
    check_output_paths([], [args.output.as_path()])?;
    // Taller, a terrain framed whole is a needle under a pixel wide (from about 1000 the
    // picture came out blank).
    if !(args.relief.is_finite() && args.relief > 0.0 && args.relief <= MAX_RELIEF) {
        return Err(format!(
            "--relief must be a positive number up to {MAX_RELIEF}, not {}",
            args.relief
        )
        .into());
    }
    if args.heightfield && !args.files.iter().any(|p| imagery::is_image_path(p)) {
        status(
            globals,
            "note: --heightfield draws pictures (.png, .jpg) as height fields, and none of \
             the files is one (height field files are drawn as terrain without it)",
        );
    }
    let inputs = args
        .files
        .iter()
        .map(|p| load(p, args, globals).map_err(named(p)))
        .collect::<CliResult<Vec<_>>>()?;
    for (path, input) in args.files.iter().zip(&inputs) {
        if let Input::Geometry(Geometry::Points(points), _) = input {
            let strays = points.stray_count();
            let lie = if strays == 1 { "lies" } else { "lie" };
            if strays > 0 {
                status(
                    globals,
                    format!(
                        "note: {}: {strays} of its points {lie} far outside the rest; its \
                         panel frames the others",
                        path.display()
                    ),
                );
            }
        }
    }
    let panels: Vec<Panel<'_>> = inputs
        .iter()
        .map(|i| match i {
            Input::Geometry(g, up) => Panel::Geometry(g, *up),
            Input::Picture(img) => Panel::Image(img),
        })
        .collect();
    let image = if args.same_scale {
        preview::render_panels_at_one_scale(&panels, &args.view.options())?
    } else {
        preview::render_panels(&panels, &args.view.options())?
    };
    preview::save_png(&image, &args.output)?;
    status(
        globals,
        format!(
            "wrote {} ({}x{})",
            args.output.display(),
            image.width(),
            image.height()
        ),
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::parse_color;

    #[test]
    fn colours_parse_in_both_spellings() {
        assert_eq!(parse_color("#ff0000"), Ok([1.0, 0.0, 0.0]));
        assert_eq!(parse_color("0.5, 0.25,1"), Ok([0.5, 0.25, 1.0]));
        assert!(parse_color("#ff00").is_err());
        assert!(parse_color("2,0,0").is_err());
        assert!(parse_color("red").is_err());
    }
}
