//! Images and height fields from files: textures (PNG, JPEG) and height fields (raw
//! `.f32le`, sized by a `_WxH` name or an ENVI header beside it, and other raw files an
//! ENVI header describes; one-band TIFF, as DEMs are shipped; or grey PNG, 8 or 16 bit),
//! and the files GIS tools read beside a height map.

use std::path::{Path, PathBuf};

use image::DynamicImage;
use pointset_core::io::write_whole;
use pointset_core::{HeightField, TriMesh};

use crate::{Error, Result};

mod envi;
mod fill;
mod georeference;
mod geotiff;
mod samples;
mod sidecars;

pub use fill::fill_harmonic;
pub use georeference::GeoReference;
pub use samples::{HeightSamples, Voids};
pub use sidecars::{MapDescription, PlanPlacement, write_map_sidecars};

/// Whether a path names an image the workspace reads (`.png`, `.jpg`, `.jpeg`).
pub fn is_image_path(path: &Path) -> bool {
    matches!(extension(path).as_str(), "png" | "jpg" | "jpeg")
}

/// Whether a path names a raw height field (`.f32le`).
pub fn is_raw_heightfield_path(path: &Path) -> bool {
    extension(path) == "f32le"
}

/// Whether a path names a raw file that an ENVI header beside it describes (`NAME.hdr` or
/// `NAME.EXT.hdr`), under a name GIS tools give such files: `.bil`, `.bsq`, `.bip`,
/// `.img`, `.dat`, `.raw` or `.bin` (as `gdal_translate -of ENVI dem.tif dem.bil` writes
/// one). A `.f32le` is a raw height field with or without a header
/// ([`is_raw_heightfield_path`]).
pub fn is_envi_raw_path(path: &Path) -> bool {
    matches!(
        extension(path).as_str(),
        "bil" | "bsq" | "bip" | "img" | "dat" | "raw" | "bin"
    ) && envi::header_beside(path).is_some()
}

/// Whether a path names a TIFF file (`.tif`, `.tiff`), read as a height field.
pub fn is_tiff_path(path: &Path) -> bool {
    matches!(extension(path).as_str(), "tif" | "tiff")
}

/// Whether a path names a file that only ever holds a height field: raw (`.f32le`) or
/// TIFF. A PNG may hold either a picture or a height field. (Other raw files with an
/// ENVI header beside them are height fields too, for reading: [`is_envi_raw_path`].)
pub fn is_heightfield_path(path: &Path) -> bool {
    is_raw_heightfield_path(path) || is_tiff_path(path)
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

/// Reads a height field: raw `.f32le` (heights as stored; the size from a `_WxH` name
/// suffix, or else from an ENVI header beside the file, `NAME.hdr` or `NAME.f32le.hdr`,
/// as `gdal_translate -of ENVI -ot Float32 dem.tif dem.f32le` writes one), any other raw
/// file an ENVI header describes ([`is_envi_raw_path`]: `dem.bil` beside `dem.hdr`, as
/// `gdal_translate -of ENVI dem.tif dem.bil` writes them; a header's data type may be
/// any of ENVI's integer or float types, in either byte order), a one-band
/// `.tif`/`.tiff` (a GeoTIFF DEM: integer or float samples as stored, in strips or
/// tiles, Deflate, LZW or PackBits; samples on GDAL's no-data value refused) or an
/// image, whose grey level in `0..=1` (16-bit precision kept) is the height.
///
/// ```
/// use geosynth::imagery::read_heightfield;
///
/// let dir = std::env::temp_dir();
/// let raw = dir.join("geosynth_doc_dem.f32le");
/// let big_endian: Vec<u8> = (0..6).flat_map(|i| (i as f32 * 0.5).to_be_bytes()).collect();
/// std::fs::write(&raw, big_endian)?;
/// let header = "ENVI\nsamples = 3\nlines = 2\nbands = 1\ndata type = 4\nbyte order = 1\n";
/// std::fs::write(dir.join("geosynth_doc_dem.hdr"), header)?;
/// let field = read_heightfield(&raw)?;
/// assert_eq!((field.width(), field.height()), (3, 2));
/// assert_eq!(field.get(2, 1), Some(2.5));
/// # std::fs::remove_file(&raw)?;
/// # std::fs::remove_file(dir.join("geosynth_doc_dem.hdr"))?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_heightfield(path: &Path) -> Result<HeightField> {
    read_height_samples(path)?.into_field(path)
}

/// Reads a height file's samples as [`read_heightfield`] does, voids included (samples on
/// the file's no-data value, or not finite): for describing a DEM that has them.
///
/// ```
/// use geosynth::imagery::read_height_samples;
///
/// let raw = std::env::temp_dir().join("geosynth_doc_voids_3x2.f32le");
/// let heights = [1.0f32, f32::NAN, 2.0, 3.0, 4.0, 5.0];
/// std::fs::write(&raw, heights.iter().flat_map(|h| h.to_le_bytes()).collect::<Vec<u8>>())?;
/// let samples = read_height_samples(&raw)?;
/// assert_eq!(samples.voids().map(|v| (v.count(), v.first)), Some((1, (1, 0))));
/// assert!(geosynth::imagery::read_heightfield(&raw).is_err());
/// # std::fs::remove_file(&raw)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_height_samples(path: &Path) -> Result<HeightSamples> {
    if is_envi_raw_path(path)
        && let Some(header) = envi::header_beside(path)
    {
        return envi::read_with_header(path, &header);
    }
    if is_raw_heightfield_path(path) {
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        if let Some((width, height)) = pointset_core::dims_from_name(stem) {
            let bytes = std::fs::read(path).map_err(io_error(path))?;
            let heights = HeightField::f32le_samples(&bytes, width, height)?;
            return Ok(HeightSamples {
                width,
                height,
                heights,
                no_data: None,
            });
        }
        let Some(header) = envi::header_beside(path) else {
            let reason = "a raw height field needs its size: a name like \
                          `name_WIDTHxHEIGHT.f32le`, or an ENVI header beside it (NAME.hdr \
                          or NAME.f32le.hdr)";
            return Err(format_error(path, reason.into()));
        };
        return envi::read_with_header(path, &header);
    }
    if is_tiff_path(path) {
        return geotiff::read(path);
    }
    let grey = read_image(path)?.into_luma16();
    let (w, h) = grey.dimensions();
    Ok(HeightSamples {
        width: w as usize,
        height: h as usize,
        heights: grey.pixels().map(|p| f32::from(p.0[0]) / 65535.0).collect(),
        no_data: None,
    })
}

/// A height field as a mesh for viewing: the longer side spans 1 unit and the height range
/// spans `relief` units (a flat field stays flat). Errors as [`relief_scale`].
pub fn heightfield_mesh(field: &HeightField, relief: f32) -> Result<TriMesh> {
    let spacing = 1.0 / (field.width().max(field.height()) - 1) as f32;
    Ok(field.to_mesh(spacing, relief_scale(field, relief)?)?)
}

/// [`heightfield_mesh`] of a height file's samples, voids included: the voids are filled to
/// place their vertices ([`HeightSamples::filled`]), and every triangle with a corner on
/// one is left out, so that they show as holes. Also returns how many voids there are.
/// Errors as [`HeightSamples::filled`] and [`relief_scale`].
///
/// ```
/// use geosynth::imagery::{HeightSamples, height_samples_mesh};
///
/// // A 3 × 3 grid with a void in the middle: 6 of its 8 triangles have a corner there
/// // (the quads' diagonals keep two corner triangles clear of it).
/// let mut heights = vec![0.0f32; 9];
/// heights[4] = f32::NAN;
/// let samples = HeightSamples { width: 3, height: 3, heights, no_data: None };
/// let (mesh, voids) = height_samples_mesh(samples, 0.2)?;
/// assert_eq!((mesh.triangles().len(), voids), (2, 1));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn height_samples_mesh(samples: HeightSamples, relief: f32) -> Result<(TriMesh, usize)> {
    let void: Vec<bool> = samples
        .heights
        .iter()
        .map(|&h| samples.is_void(h))
        .collect();
    let (field, voids) = samples.filled()?;
    let mesh = heightfield_mesh(&field, relief)?;
    if voids == 0 {
        return Ok((mesh, 0));
    }
    let kept: Vec<[u32; 3]> = mesh
        .triangles()
        .iter()
        .filter(|t| t.iter().all(|&v| !void[v as usize]))
        .copied()
        .collect();
    Ok((TriMesh::new(mesh.vertices().clone(), kept)?, voids))
}

/// The factor that makes `field`'s heights span `range` (1 for a flat field).
///
/// Errors ([`Error::InvalidParameter`] `heights`): heights whose range single precision
/// cannot scale to `range`, or whose scaled values it cannot hold. Heights from −3.4·10³⁸
/// to 3.4·10³⁸ have a range beyond `f32` (it was infinite, and the terrain came out
/// flat); a range of 10⁻⁴⁰ needs a scale beyond `f32` (and came out not finite).
///
/// ```
/// use geosynth::core::HeightField;
/// use geosynth::imagery::relief_scale;
///
/// let field = HeightField::new(2, 2, vec![1.0, 2.0, 3.0, 5.0])?;
/// assert_eq!(relief_scale(&field, 0.8)?, 0.2);
/// let extreme = HeightField::new(2, 2, vec![-3.4e38, 0.0, 0.0, 3.4e38])?;
/// assert!(relief_scale(&extreme, 0.8).is_err());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn relief_scale(field: &HeightField, range: f32) -> Result<f32> {
    let (lo, hi) = field.range();
    if hi <= lo {
        return Ok(1.0);
    }
    let scale = range / (hi - lo);
    if scale.is_normal() && (lo.abs().max(hi.abs()) * scale).is_finite() {
        return Ok(scale);
    }
    let needed = f64::from(range) / (f64::from(hi) - f64::from(lo));
    Error::invalid(
        "heights",
        format!("{lo:e} .. {hi:e}"),
        &format!(
            "heights whose range single precision can scale to {range} (the factor would \
             be {needed:e}): rescale the file's heights"
        ),
    )
}

/// A height field written by [`write_heightfield`].
#[derive(Debug, Clone, PartialEq)]
pub struct WrittenHeightField {
    /// The file written (a raw file's name carries its size).
    pub path: PathBuf,
    /// Heights outside `0..=1` stored as 0 or 1 in a PNG (none in a raw or TIFF file).
    pub clamped: usize,
}

/// Writes a height field the way [`read_heightfield`] reads it back: a `.png` as 16-bit
/// grey with the height as the grey level in `0..=1` (heights beyond are clamped and
/// counted), a `.f32le` as raw little-endian samples under a name that ends in the
/// field's `_WxH` ([`raw_heightfield_path`]), a `.tif`/`.tiff` as 32-bit floats, unplaced
/// ([`write_geotiff`] places one). Errors on any other extension and on I/O.
///
/// ```
/// use geosynth::core::HeightField;
/// use geosynth::imagery::{read_heightfield, write_heightfield};
///
/// let field = HeightField::new(3, 2, vec![0.0, 0.25, 0.5, 0.75, 1.0, 1.5])?;
/// let dir = std::env::temp_dir();
/// let png = write_heightfield(&dir.join("geosynth_doc_written.png"), &field)?;
/// assert_eq!(png.clamped, 1);
/// let back = read_heightfield(&png.path)?;
/// assert!((back.get(1, 0).ok_or("no sample")? - 0.25).abs() < 1e-4);
/// let raw = write_heightfield(&dir.join("geosynth_doc_written.f32le"), &field)?;
/// assert!(raw.path.ends_with("geosynth_doc_written_3x2.f32le"));
/// assert_eq!(read_heightfield(&raw.path)?, field);
/// let tiff = write_heightfield(&dir.join("geosynth_doc_written.tif"), &field)?;
/// assert_eq!(read_heightfield(&tiff.path)?, field);
/// # std::fs::remove_file(&png.path)?;
/// # std::fs::remove_file(&raw.path)?;
/// # std::fs::remove_file(&tiff.path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_heightfield(path: &Path, field: &HeightField) -> Result<WrittenHeightField> {
    let (width, height) = (field.width(), field.height());
    if is_raw_heightfield_path(path) {
        let path = raw_heightfield_path(path, width, height);
        let bytes: Vec<u8> = field
            .heights()
            .iter()
            .flat_map(|h| h.to_le_bytes())
            .collect();
        write_whole(&path, bytes).map_err(io_error(&path))?;
        return Ok(WrittenHeightField { path, clamped: 0 });
    }
    if is_tiff_path(path) {
        return write_geotiff(path, field, None);
    }
    if extension(path) != "png" {
        return Err(heightfield_format_error(path));
    }
    let clamped = field
        .heights()
        .iter()
        .filter(|h| !(0.0..=1.0).contains(*h))
        .count();
    let grey: Vec<u16> = field
        .heights()
        .iter()
        .map(|h| (h.clamp(0.0, 1.0) * 65535.0).round() as u16)
        .collect();
    let (w, h) = image_sides(field, "PNG")?;
    // The buffer holds exactly `w × h` samples, so this cannot fail.
    let image = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, grey)
        .ok_or_else(|| sides_error(field, "PNG"))?;
    crate::preview::save_png(&image, path)?;
    Ok(WrittenHeightField {
        path: path.to_path_buf(),
        clamped,
    })
}

/// The width and height of `field` as an image file's `u32` sides; `format` names the
/// file kind in the error for a longer side.
fn image_sides(field: &HeightField, format: &str) -> Result<(u32, u32)> {
    let side = |n: usize| u32::try_from(n).map_err(|_| sides_error(field, format));
    Ok((side(field.width())?, side(field.height())?))
}

fn sides_error(field: &HeightField, format: &str) -> Error {
    Error::InvalidParameter {
        name: "height field size",
        value: format!("{} × {}", field.width(), field.height()),
        expected: format!("a {format}'s at most 4294967295 samples a side"),
    }
}

/// Writes a height map as one file that GIS tools open and place: a one-band 32-bit float
/// TIFF (Deflate) holding every height, and with `reference` a GeoTIFF whose tags put the
/// samples where it says: a point set's plan placement (`GeoReference::from`, the
/// coordinate system left unnamed) or an input DEM's own ([`GeoReference::read`]).
/// Errors on I/O and for a side longer than 2³² − 1 samples.
///
/// ```
/// use geosynth::core::HeightField;
/// use geosynth::imagery::{GeoReference, PlanPlacement, read_heightfield, write_geotiff};
///
/// let field = HeightField::new(3, 2, vec![1000.0, 1000.5, 1001.0, 999.0, 999.5, 1002.25])?;
/// let placement = PlanPlacement { top_left: [500_000.0, 4_000_002.0], spacing: 2.0 };
/// let path = std::env::temp_dir().join("geosynth_doc_placed.tif");
/// let written = write_geotiff(&path, &field, Some(&GeoReference::from(placement)))?;
/// assert_eq!((written.path, written.clamped), (path.clone(), 0));
/// assert_eq!(read_heightfield(&path)?, field);
/// # std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_geotiff(
    path: &Path,
    field: &HeightField,
    reference: Option<&GeoReference>,
) -> Result<WrittenHeightField> {
    geotiff::write(path, field, reference)?;
    Ok(WrittenHeightField {
        path: path.to_path_buf(),
        clamped: 0,
    })
}

/// `field` mapped linearly from `lo..hi` onto `0..1` (a flat range onto 0), the way a PNG's
/// grey levels hold it: written with [`write_heightfield`], grey level `g` of 65535 is the
/// height `lo + g·(hi − lo)`. Computed in double precision. Errors if a mapped height is
/// not finite (a range that is).
///
/// ```
/// use geosynth::core::HeightField;
/// use geosynth::imagery::stretch_to_unit;
///
/// let field = HeightField::new(2, 2, vec![1000.5, 1002.5, 1001.0, 1000.5])?;
/// let unit = stretch_to_unit(&field, field.range())?;
/// assert_eq!(unit.heights(), &[0.0, 1.0, 0.25, 0.0]);
/// let flat = HeightField::new(2, 2, vec![7.0; 4])?;
/// assert_eq!(stretch_to_unit(&flat, flat.range())?.heights(), &[0.0; 4]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn stretch_to_unit(field: &HeightField, (lo, hi): (f32, f32)) -> Result<HeightField> {
    let (lo, span) = (f64::from(lo), f64::from(hi) - f64::from(lo));
    mapped_heights(field, |h| if span > 0.0 { (h - lo) / span } else { 0.0 })
}

/// `field` with every height `h` replaced by `map(h)`, computed in double precision.
pub(crate) fn mapped_heights(field: &HeightField, map: impl Fn(f64) -> f64) -> Result<HeightField> {
    let heights = field
        .heights()
        .iter()
        .map(|&h| map(f64::from(h)) as f32)
        .collect();
    Ok(HeightField::new(field.width(), field.height(), heights)?)
}

/// The error for the file `path`, whose content is not what its kind needs: `reason`.
fn format_error(path: &Path, reason: String) -> Error {
    Error::HeightFile {
        path: path.to_path_buf(),
        reason,
    }
}

/// The error for an I/O failure `source` on the file `path`, as a `map_err` argument.
pub(crate) fn io_error(path: &Path) -> impl Fn(std::io::Error) -> Error + use<> {
    let path = path.to_path_buf();
    move |source| {
        pointset_core::Error::Io {
            path: path.clone(),
            source,
        }
        .into()
    }
}

/// Whether [`write_heightfield`] can write `path` (`.png`, `.f32le`, `.tif` or `.tiff`);
/// the error says what it takes.
pub fn check_heightfield_output(path: &Path) -> Result<()> {
    if is_heightfield_path(path) || extension(path) == "png" {
        Ok(())
    } else {
        Err(heightfield_format_error(path))
    }
}

fn heightfield_format_error(path: &Path) -> Error {
    Error::InvalidParameter {
        name: "height field output",
        value: path.display().to_string(),
        expected: "a .png (16-bit grey, heights 0..1), .f32le (raw) or .tif (32-bit float) \
                   file"
            .into(),
    }
}

/// `path` itself when its name already ends in `_WxH` for this size, else the same name
/// with `_WxH` added before `.f32le` (the readers take a raw file's size from its name).
pub fn raw_heightfield_path(path: &Path, width: usize, height: usize) -> PathBuf {
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
    if pointset_core::dims_from_name(stem) == Some((width, height)) {
        return path.to_path_buf();
    }
    path.with_file_name(format!("{stem}_{width}x{height}.f32le"))
}
