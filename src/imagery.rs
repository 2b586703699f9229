//! Images and height fields from files: textures (PNG, JPEG) and height fields (raw
//! `*_WxH.f32le` or grey PNG, 8 or 16 bit).

use std::path::Path;

use image::DynamicImage;
use pointset_core::{HeightField, TriMesh};

use crate::{Error, Result};

/// Whether a path names an image the workspace reads (`.png`, `.jpg`, `.jpeg`).
pub fn is_image_path(path: &Path) -> bool {
    matches!(extension(path).as_str(), "png" | "jpg" | "jpeg")
}

/// Whether a path names a raw height field (`.f32le`).
pub fn is_raw_heightfield_path(path: &Path) -> bool {
    extension(path) == "f32le"
}

fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// Decodes a PNG or JPEG file.
pub fn read_image(path: &Path) -> Result<DynamicImage> {
    image::open(path).map_err(|source| Error::ImageRead {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a height field: raw `f32le` (size from the `_WxH` name suffix, heights as stored) or
/// an image, whose grey level in `0..=1` (16-bit precision kept) is the height.
pub fn read_heightfield(path: &Path) -> Result<HeightField> {
    if is_raw_heightfield_path(path) {
        return Ok(HeightField::read_f32le(path)?);
    }
    let grey = read_image(path)?.into_luma16();
    let (w, h) = grey.dimensions();
    let heights = grey.pixels().map(|p| f32::from(p.0[0]) / 65535.0).collect();
    Ok(HeightField::new(w as usize, h as usize, heights)?)
}

/// A height field as a mesh for viewing: the longer side spans 1 unit and the height range
/// spans `relief` units (a flat field stays flat).
pub fn heightfield_mesh(field: &HeightField, relief: f32) -> Result<TriMesh> {
    let spacing = 1.0 / (field.width().max(field.height()) - 1) as f32;
    let (lo, hi) = field.range();
    let scale = if hi > lo { relief / (hi - lo) } else { 1.0 };
    Ok(field.to_mesh(spacing, scale)?)
}
