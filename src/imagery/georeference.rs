//! Where a GeoTIFF's samples lie, as its tags say: the pixel scale, the model coordinates
//! of raster point (0, 0), and the coordinate system's keys, carried from an input DEM
//! to a map written from it, or made for a point set's map from its plan placement.

use std::io::{Seek, Write};
use std::path::Path;

use ::tiff::encoder::{DirectoryEncoder, TiffKind};
use ::tiff::tags::Tag;

use super::PlanPlacement;
use crate::Result;

/// GeoTIFF's key directory for a map placed in a plane with no named coordinate system:
/// version 1.1.0, two keys; the model type user-defined (32767) and the raster type
/// pixel-is-area (1: raster point (0, 0) is the top-left sample's outer corner).
const PLAN_KEYS: [u16; 12] = [1, 1, 0, 2, 1024, 0, 1, 32767, 1025, 0, 1, 1];

/// Numbers before the first key of a GeoKeyDirectory: version, revision, minor revision
/// and the number of keys.
const KEY_DIRECTORY_HEADER: usize = 4;

/// A GeoTIFF's placement of its samples without rotation: column `c`, row `r` (raster
/// point `(c, r)`) lies at model `origin + (c·scale[0], −r·scale[1], 0)`, and the key
/// directory with its parameters names the coordinate system and whether a raster point
/// is a sample's corner or its centre. A map written on the same grid spacing with the
/// same reference lies on the same grid, in the same coordinate system.
#[derive(Debug, Clone, PartialEq)]
pub struct GeoReference {
    /// Model units per sample along x and y (and z, usually 0).
    pub scale: [f64; 3],
    /// Model coordinates of raster point (0, 0).
    pub origin: [f64; 3],
    /// The GeoKeyDirectory (tag 34735), as stored; empty when the file has none (it is
    /// then placed in an unnamed coordinate system, as GDAL reads it, and a map written
    /// with this reference has no key directory either).
    pub keys: Vec<u16>,
    /// The GeoDoubleParams the keys point into (tag 34736), as stored.
    pub doubles: Option<Vec<f64>>,
    /// The GeoAsciiParams the keys point into (tag 34737), as stored.
    pub ascii: Option<String>,
}

impl From<PlanPlacement> for GeoReference {
    /// The reference of a map placed in a plane whose coordinate system is unknown (a
    /// point set's file names none): pixel-is-area, so raster point (0, 0) lies half a
    /// spacing up and left of the top-left sample's centre.
    fn from(PlanPlacement { top_left, spacing }: PlanPlacement) -> Self {
        let [x, y] = top_left;
        Self {
            scale: [spacing, spacing, 0.0],
            origin: [x - spacing / 2.0, y + spacing / 2.0, 0.0],
            keys: PLAN_KEYS.to_vec(),
            doubles: None,
            ascii: None,
        }
    }
}

/// A coordinate system named by its EPSG code: projected (key 3072) or geographic (key
/// 2048).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum NamedSystem {
    /// A projected system's code.
    Projected(u16),
    /// A geographic system's code.
    Geographic(u16),
}

impl GeoReference {
    /// The reference of the height field file `path`, if its format places it: a TIFF's
    /// GeoTIFF tags ([`Self::read`]) or the `map info` of an ENVI header beside a raw
    /// file (`None` for other files, and for headers without one). The ENVI placement's
    /// reference pixel is taken as ENVI defines it (pixel (1, 1) is the top-left corner of
    /// the top-left sample); its coordinate system is named by the EPSG code of the
    /// header's `coordinate system string` (as GDAL writes one) or, for `UTM` on
    /// `WGS-84`, by its zone and hemisphere, and left unnamed otherwise.
    ///
    /// ```
    /// use geosynth::imagery::GeoReference;
    ///
    /// let dir = std::env::temp_dir();
    /// let raw = dir.join("geosynth_doc_placed_dem.bil");
    /// std::fs::write(&raw, [0u8; 8])?;
    /// let header = "ENVI\nsamples = 2\nlines = 2\nbands = 1\ndata type = 2\n\
    ///               map info = {UTM, 1, 1, 562000, 5125000, 30, 30, 10, North, WGS-84}\n";
    /// std::fs::write(dir.join("geosynth_doc_placed_dem.hdr"), header)?;
    /// let reference = GeoReference::of_heightfield(&raw)?.ok_or("not placed")?;
    /// assert_eq!(reference.origin, [562000.0, 5125000.0, 0.0]);
    /// assert_eq!((reference.scale, reference.epsg()), ([30.0, 30.0, 0.0], Some(32610)));
    /// # std::fs::remove_file(&raw)?;
    /// # std::fs::remove_file(dir.join("geosynth_doc_placed_dem.hdr"))?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn of_heightfield(path: &Path) -> Result<Option<Self>> {
        if super::is_tiff_path(path) {
            return Self::read(path);
        }
        if super::is_envi_raw_path(path) || super::is_raw_heightfield_path(path) {
            return super::envi::reference_beside(path);
        }
        Ok(None)
    }

    /// A reference with `scale` and raster point (0, 0) at `origin` whose key directory
    /// names `system` (pixel-is-area), or has no keys when it is `None`.
    pub(super) fn naming(scale: [f64; 3], origin: [f64; 3], system: Option<NamedSystem>) -> Self {
        let keys = match system {
            // Version 1.1.0 and three keys: the model type, pixel-is-area, the system.
            Some(NamedSystem::Projected(code)) => {
                vec![1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, code]
            }
            Some(NamedSystem::Geographic(code)) => {
                vec![1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, code]
            }
            None => Vec::new(),
        };
        Self {
            scale,
            origin,
            keys,
            doubles: None,
            ascii: None,
        }
    }

    /// The reference of the TIFF file `path`, if it has one this type can hold: a pixel
    /// scale and a tie point, with the key directory if there is one (`None` for a plain
    /// TIFF, and for a rotated or sheared one, which GeoTIFF places with a
    /// transformation matrix).
    /// Errors: a file TIFF cannot open, tags of the wrong type or length.
    ///
    /// ```
    /// use geosynth::core::HeightField;
    /// use geosynth::imagery::{GeoReference, PlanPlacement, write_geotiff};
    ///
    /// let field = HeightField::new(2, 2, vec![1.0, 2.0, 3.0, 4.0])?;
    /// let placed = PlanPlacement { top_left: [100.0, 200.0], spacing: 10.0 };
    /// let path = std::env::temp_dir().join("geosynth_doc_reference.tif");
    /// write_geotiff(&path, &field, Some(&GeoReference::from(placed)))?;
    /// let reference = GeoReference::read(&path)?.ok_or("not placed")?;
    /// assert_eq!(reference.origin, [95.0, 205.0, 0.0]);
    /// assert_eq!(reference.scale, [10.0, 10.0, 0.0]);
    /// # std::fs::remove_file(&path)?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn read(path: &Path) -> Result<Option<Self>> {
        let failed = super::geotiff::decoding_error(path);
        let mut decoder = super::geotiff::open(path)?;
        let mut numbers = |tag| -> Result<Option<Vec<f64>>> {
            match decoder.find_tag(tag).map_err(&failed)? {
                Some(value) => Ok(Some(value.into_f64_vec().map_err(&failed)?)),
                None => Ok(None),
            }
        };
        let (scale, tie) = (
            numbers(Tag::ModelPixelScaleTag)?,
            numbers(Tag::ModelTiepointTag)?,
        );
        let doubles = numbers(Tag::GeoDoubleParamsTag)?;
        let keys = decoder
            .find_tag_unsigned_vec::<u16>(Tag::GeoKeyDirectoryTag)
            .map_err(&failed)?;
        let ascii = match decoder.find_tag(Tag::GeoAsciiParamsTag).map_err(&failed)? {
            Some(value) => Some(value.into_string().map_err(&failed)?),
            None => None,
        };
        let (Some(scale), Some(tie)) = (scale, tie) else {
            return Ok(None);
        };
        let (Ok(scale), Some(tie)) = (<[f64; 3]>::try_from(scale), tie.get(..6)) else {
            let reason = "a GeoTIFF pixel scale has 3 numbers and a tie point 6";
            return Err(super::format_error(path, reason.into()));
        };
        let keys = keys.unwrap_or_default();
        if !keys.is_empty() && keys.len() < KEY_DIRECTORY_HEADER + 4 * usize::from(keys[3]) {
            let reason = "a GeoTIFF key directory holds a 4-number header and 4 numbers per key";
            return Err(super::format_error(path, reason.into()));
        }
        // The tie point pins raster point (i, j) to model (x, y, z); (0, 0) follows.
        let [i, j, _, x, y, z] = [tie[0], tie[1], tie[2], tie[3], tie[4], tie[5]];
        Ok(Some(Self {
            scale,
            origin: [x - i * scale[0], y + j * scale[1], z],
            keys,
            doubles,
            ascii,
        }))
    }

    /// The EPSG code of the coordinate system the keys name, if they name one by code:
    /// the projected system's (key 3072) or else the geographic one's (key 2048); `None`
    /// for user-defined systems (32767) and for keys that give none.
    ///
    /// ```
    /// use geosynth::imagery::{GeoReference, PlanPlacement};
    ///
    /// let mut reference = GeoReference::from(PlanPlacement { top_left: [0.0, 0.0], spacing: 1.0 });
    /// assert_eq!(reference.epsg(), None);
    /// reference.keys = vec![1, 1, 0, 2, 1024, 0, 1, 1, 3072, 0, 1, 32610];
    /// assert_eq!(reference.epsg(), Some(32610));
    /// ```
    pub fn epsg(&self) -> Option<u16> {
        // After the 4-number header, each key is (id, location, count, value); location 0
        // holds the value itself.
        let inline = |id: u16| {
            self.keys
                .get(KEY_DIRECTORY_HEADER..)?
                .chunks_exact(4)
                .find(|key| key[0] == id && key[1] == 0)
                .map(|key| key[3])
                .filter(|&code| code != 0 && code != 32767)
        };
        inline(3072).or_else(|| inline(2048))
    }

    /// Writes the reference's tags into the TIFF directory being encoded.
    pub(super) fn write_tags<W: Write + Seek, K: TiffKind>(
        &self,
        tags: &mut DirectoryEncoder<'_, W, K>,
    ) -> ::tiff::TiffResult<()> {
        tags.write_tag(Tag::ModelPixelScaleTag, &self.scale[..])?;
        let [x, y, z] = self.origin;
        tags.write_tag(Tag::ModelTiepointTag, &[0.0, 0.0, 0.0, x, y, z][..])?;
        if !self.keys.is_empty() {
            tags.write_tag(Tag::GeoKeyDirectoryTag, &self.keys[..])?;
        }
        if let Some(doubles) = &self.doubles {
            tags.write_tag(Tag::GeoDoubleParamsTag, &doubles[..])?;
        }
        if let Some(ascii) = &self.ascii {
            tags.write_tag(Tag::GeoAsciiParamsTag, ascii.as_str())?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use ::tiff::encoder::{TiffEncoder, colortype};

    use super::*;

    fn temp(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("geosynth_georef_{}_{name}", std::process::id()))
    }

    /// A 4 × 3 float TIFF at `path` with the GeoTIFF tags of a UTM DEM whose tie point
    /// pins raster point (2, 1) (or, with `short_tie`, a tie point of 4 numbers), its
    /// key directory and parameters unless `bare`.
    fn write_dem(path: &Path, short_tie: bool, bare: bool) {
        let file = std::fs::File::create(path).unwrap();
        let mut encoder = TiffEncoder::new(file).unwrap();
        let mut image = encoder.new_image::<colortype::Gray32Float>(4, 3).unwrap();
        let tags = image.encoder();
        tags.write_tag(Tag::ModelPixelScaleTag, &[30.0, 20.0, 0.0][..])
            .unwrap();
        let tie = [2.0, 1.0, 0.0, 562_060.0, 5_124_980.0, 0.0];
        let tie = if short_tie { &tie[..4] } else { &tie[..] };
        tags.write_tag(Tag::ModelTiepointTag, tie).unwrap();
        if bare {
            image.write_data(&[0.0; 12]).unwrap();
            return;
        }
        let keys: [u16; 16] = [1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32610];
        tags.write_tag(Tag::GeoKeyDirectoryTag, &keys[..]).unwrap();
        tags.write_tag(Tag::GeoDoubleParamsTag, &[6378137.0][..])
            .unwrap();
        tags.write_tag(Tag::GeoAsciiParamsTag, "WGS 84 / UTM zone 10N|")
            .unwrap();
        image.write_data(&[0.0; 12]).unwrap();
    }

    #[test]
    fn a_key_directory_shorter_than_its_count_is_refused() {
        let path = temp("short_keys.tif");
        let file = std::fs::File::create(&path).unwrap();
        let mut encoder = TiffEncoder::new(file).unwrap();
        let mut image = encoder.new_image::<colortype::Gray32Float>(2, 2).unwrap();
        let tags = image.encoder();
        tags.write_tag(Tag::ModelPixelScaleTag, &[1.0, 1.0, 0.0][..])
            .unwrap();
        tags.write_tag(Tag::ModelTiepointTag, &[0.0; 6][..])
            .unwrap();
        // The header counts 3 keys; one follows.
        let keys: [u16; 8] = [1, 1, 0, 3, 1024, 0, 1, 1];
        tags.write_tag(Tag::GeoKeyDirectoryTag, &keys[..]).unwrap();
        image.write_data(&[0.0; 4]).unwrap();
        let error = GeoReference::read(&path).unwrap_err().to_string();
        assert!(error.contains("4 numbers per key"), "{error}");
        std::fs::remove_file(path).unwrap();
    }

    #[test]
    fn the_origin_is_raster_point_zero_whichever_point_the_tie_pins() {
        let path = temp("dem.tif");
        write_dem(&path, false, false);
        let reference = GeoReference::read(&path).unwrap().unwrap();
        // Raster (2, 1) at (562060, 5124980): (0, 0) two columns west, one row north.
        assert_eq!(reference.origin, [562_000.0, 5_125_000.0, 0.0]);
        assert_eq!(reference.scale, [30.0, 20.0, 0.0]);
        assert_eq!(reference.keys[15], 32610);
        assert_eq!(reference.doubles, Some(vec![6378137.0]));
        assert_eq!(reference.ascii.as_deref(), Some("WGS 84 / UTM zone 10N|"));
        // Written into another file and read back, it is the same reference.
        let copy = temp("copy.tif");
        let field = pointset_core::HeightField::new(2, 2, vec![0.0; 4]).unwrap();
        super::super::write_geotiff(&copy, &field, Some(&reference)).unwrap();
        assert_eq!(
            GeoReference::read(&copy).unwrap().as_ref(),
            Some(&reference)
        );
        // Without a tie point of 6 numbers it is refused; a plain TIFF has none.
        write_dem(&path, true, false);
        let error = GeoReference::read(&path).unwrap_err().to_string();
        assert!(error.contains("a tie point 6"), "{error}");
        super::super::write_geotiff(&copy, &field, None).unwrap();
        assert_eq!(GeoReference::read(&copy).unwrap(), None);
        // A tie point and scale without keys place the samples in an unnamed system (as
        // GDAL reads them); a map written with that reference has no keys either.
        write_dem(&path, false, true);
        let bare = GeoReference::read(&path).unwrap().unwrap();
        assert_eq!(
            (bare.origin, bare.keys.len(), bare.epsg()),
            (reference.origin, 0, None)
        );
        super::super::write_geotiff(&copy, &field, Some(&bare)).unwrap();
        assert_eq!(GeoReference::read(&copy).unwrap(), Some(bare));
        std::fs::remove_file(path).unwrap();
        std::fs::remove_file(copy).unwrap();
    }
}
