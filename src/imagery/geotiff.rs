//! Height fields in TIFF files, the format DEMs are shipped in (GeoTIFF), read and
//! written.
//!
//! Read: one band of
//! signed or unsigned integers of 8 to 64 bits or floats of 16, 32 or 64 bits, in strips
//! or tiles, uncompressed or compressed with Deflate, LZW or PackBits (with or without a
//! predictor), as GDAL writes them. The heights are the samples as stored (an `Int16`
//! DEM's metres stay metres), cast to `f32`; the first image of the file is read, which is
//! the full-resolution one where overviews follow it.
//!
//! GDAL's no-data tag (`GDAL_NODATA`, 42113) is read: samples equal to it (or NaN) are
//! voids, which [`super::read_heightfield`] refuses, since a height field has no holes.
//! The GeoTIFF placement tags are read apart ([`super::GeoReference::read`]).
//!
//! Written: one band of 32-bit floats, Deflate-compressed, placed by GeoTIFF's tie point
//! and pixel scale when the map has a place in its file's x–y plane.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use ::tiff::ColorType;
use ::tiff::decoder::{Decoder, DecodingResult};
use ::tiff::encoder::compression::DeflateLevel;
use ::tiff::encoder::{Compression, TiffEncoder, colortype};
use ::tiff::tags::Tag;
use pointset_core::HeightField;
use pointset_core::io::{FileReplacement, replace_file};

use super::HeightSamples;
use crate::{Error, Result};

/// Reads the samples of the first image of the TIFF file `path`, voids included. Errors:
/// a file TIFF cannot decode (truncated, an unsupported compression), more than one
/// sample per pixel, a no-data tag that is not a number.
pub(super) fn read(path: &Path) -> Result<HeightSamples> {
    let decoding = decoding_error(path);
    let mut decoder = open(path)?;
    let colour = decoder.colortype().map_err(&decoding)?;
    if !matches!(colour, ColorType::Gray(_)) {
        return Err(super::format_error(
            path,
            format!("its pixels are {colour:?}; a height field has one grey sample per pixel"),
        ));
    }
    let (width, height) = decoder.dimensions().map_err(&decoding)?;
    let no_data = match decoder.find_tag(Tag::GdalNodata).map_err(&decoding)? {
        Some(value) => Some(no_data_value(path, value)?),
        None => None,
    };
    Ok(HeightSamples {
        width: width as usize,
        height: height as usize,
        heights: as_f32(decoder.read_image().map_err(&decoding)?),
        no_data,
    })
}

/// A decoder of the TIFF file `path`, its first directory read. Errors: I/O, and a file
/// that is not TIFF.
pub(super) fn open(path: &Path) -> Result<Decoder<BufReader<File>>> {
    let file = File::open(path).map_err(super::io_error(path))?;
    Decoder::new(BufReader::new(file)).map_err(decoding_error(path))
}

/// The error for a decoding failure on the TIFF file `path`, as a `map_err` argument.
pub(super) fn decoding_error(path: &Path) -> impl Fn(::tiff::TiffError) -> Error {
    move |source| Error::TiffRead {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes `field` to `path` as a one-band 32-bit float TIFF, Deflate-compressed, every
/// height kept; with `reference`, a GeoTIFF placed by its tags. Errors: a side longer
/// than 2³² − 1 samples, I/O and encoding failures.
pub(super) fn write(
    path: &Path,
    field: &HeightField,
    reference: Option<&super::GeoReference>,
) -> Result<()> {
    let (width, height) = super::image_sides(field, "TIFF")?;
    let encoding = |source| Error::TiffWrite {
        path: path.to_path_buf(),
        source,
    };
    let write = |out: &mut FileReplacement| {
        let mut encoder = TiffEncoder::new(out)
            .map_err(encoding)?
            .with_compression(Compression::Deflate(DeflateLevel::Balanced));
        let mut image = encoder
            .new_image::<colortype::Gray32Float>(width, height)
            .map_err(encoding)?;
        if let Some(reference) = reference {
            reference.write_tags(image.encoder()).map_err(encoding)?;
        }
        image.write_data(field.heights()).map_err(encoding)
    };
    replace_file(path, write, super::io_error(path))
}

/// The no-data value GDAL's tag holds: an ASCII number, `nan` included.
fn no_data_value(path: &Path, value: ::tiff::decoder::ifd::Value) -> Result<f32> {
    let text = value.into_string().unwrap_or_default();
    let text = text.trim_matches(|c: char| c == '\0' || c.is_whitespace());
    text.parse::<f32>().map_err(|_| {
        super::format_error(
            path,
            format!("its GDAL_NODATA tag `{text}` is not a number"),
        )
    })
}

/// The samples as `f32`: integers and wider floats cast to the nearest value.
fn as_f32(samples: DecodingResult) -> Vec<f32> {
    fn cast<T: Copy>(values: Vec<T>, to: impl Fn(T) -> f32) -> Vec<f32> {
        values.into_iter().map(to).collect()
    }
    match samples {
        DecodingResult::U8(v) => cast(v, f32::from),
        DecodingResult::I8(v) => cast(v, f32::from),
        DecodingResult::U16(v) => cast(v, f32::from),
        DecodingResult::I16(v) => cast(v, f32::from),
        DecodingResult::U32(v) => cast(v, |s| s as f32),
        DecodingResult::I32(v) => cast(v, |s| s as f32),
        DecodingResult::U64(v) => cast(v, |s| s as f32),
        DecodingResult::I64(v) => cast(v, |s| s as f32),
        DecodingResult::F16(v) => cast(v, f32::from),
        DecodingResult::F32(v) => v,
        DecodingResult::F64(v) => cast(v, |s| s as f32),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    fn temp(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("geosynth_geotiff_{}_{name}", std::process::id()))
    }

    /// Writes a 3 × 2 grey TIFF of samples `values`, with `no_data` in GDAL's tag.
    fn write<C: colortype::ColorType>(
        name: &str,
        values: &[C::Inner],
        no_data: Option<&str>,
    ) -> std::path::PathBuf
    where
        [C::Inner]: ::tiff::encoder::TiffValue,
    {
        let path = temp(name);
        let file = std::fs::File::create(&path).unwrap();
        let mut encoder = TiffEncoder::new(file).unwrap();
        let mut image = encoder.new_image::<C>(3, 2).unwrap();
        if let Some(text) = no_data {
            image.encoder().write_tag(Tag::GdalNodata, text).unwrap();
        }
        image.write_data(values).unwrap();
        path
    }

    /// The height field of the TIFF file `path` (its samples, voids refused).
    fn read(path: &Path) -> Result<HeightField> {
        super::read(path)?.into_field(path)
    }

    #[test]
    fn every_sample_type_reads_as_stored() {
        let expected = [-2.0, 0.0, 1.0, 3.0, 250.0, -125.0];
        let cases = [
            write::<colortype::GrayI16>("i16.tif", &[-2, 0, 1, 3, 250, -125], None),
            write::<colortype::GrayI32>("i32.tif", &[-2, 0, 1, 3, 250, -125], None),
            write::<colortype::Gray32Float>("f32.tif", &expected, None),
            write::<colortype::Gray64Float>("f64.tif", &expected.map(f64::from), None),
        ];
        for path in cases {
            let field = read(&path).unwrap();
            assert_eq!((field.width(), field.height()), (3, 2));
            assert_eq!(field.heights(), &expected, "{}", path.display());
            std::fs::remove_file(path).unwrap();
        }
        let path = write::<colortype::Gray16>("u16.tif", &[0, 1, 2, 3, 4, 65535], None);
        assert_eq!(read(&path).unwrap().get(2, 1), Some(65535.0));
        std::fs::remove_file(path).unwrap();
    }

    /// GeoTIFF's pixel scale, tie point and key directory, where a file has them.
    type GeoTags = (Option<Vec<f64>>, Option<Vec<f64>>, Option<Vec<u16>>);

    /// The GeoTIFF tags of the TIFF file `path`.
    fn geotags(path: &Path) -> GeoTags {
        let mut decoder = open(path).unwrap();
        let mut numbers = |tag| {
            let value = decoder.find_tag(tag).unwrap()?;
            Some(value.into_f64_vec().unwrap())
        };
        let (scale, tie) = (
            numbers(Tag::ModelPixelScaleTag),
            numbers(Tag::ModelTiepointTag),
        );
        let keys = decoder
            .find_tag_unsigned_vec(Tag::GeoKeyDirectoryTag)
            .unwrap();
        (scale, tie, keys)
    }

    #[test]
    fn a_placed_map_ties_its_top_left_corner_half_a_spacing_from_the_first_centre() {
        let field = HeightField::new(3, 2, vec![1000.0, 1000.5, 1001.0, 999.0, -2.5, 1e6]).unwrap();
        let path = temp("placed.tif");
        let placement = super::super::PlanPlacement {
            top_left: [500_000.25, 4_000_002.0],
            spacing: 0.5,
        };
        let reference = super::super::GeoReference::from(placement);
        super::write(&path, &field, Some(&reference)).unwrap();
        assert_eq!(read(&path).unwrap(), field);
        let (scale, tie, keys) = geotags(&path);
        assert_eq!(scale, Some(vec![0.5, 0.5, 0.0]));
        let corner = vec![0.0, 0.0, 0.0, 500_000.0, 4_000_002.25, 0.0];
        assert_eq!(tie, Some(corner));
        // Model type user-defined, raster type pixel-is-area.
        let plan_keys = vec![1, 1, 0, 2, 1024, 0, 1, 32767, 1025, 0, 1, 1];
        assert_eq!(keys, Some(plan_keys));
        super::write(&path, &field, None).unwrap();
        assert_eq!(read(&path).unwrap(), field);
        assert_eq!(geotags(&path), (None, None, None));
        std::fs::remove_file(path).unwrap();
    }

    /// Asserts that reading `path` fails saying `reason`.
    fn assert_refused(path: &Path, reason: &str) {
        let error = read(path).unwrap_err().to_string();
        assert!(error.contains(reason), "{reason}: {error}");
    }

    #[test]
    fn no_data_samples_are_refused_and_other_values_pass() {
        let values = [7, -32768, 8, 9, 10, 11];
        let path = write::<colortype::GrayI16>("void.tif", &values, Some("-32768"));
        assert_refused(
            &path,
            "1 of its 6 samples holds the no-data value -32768, the first at column 1, row 0",
        );
        let path = write::<colortype::GrayI16>("void.tif", &values, Some("-9999"));
        assert_eq!(read(&path).unwrap().get(1, 0), Some(-32768.0));
        let nan = [1.0, f32::NAN, 2.0, 3.0, 4.0, f32::NAN];
        let path = write::<colortype::Gray32Float>("void.tif", &nan, Some("nan"));
        assert_refused(&path, "2 of its 6 samples hold the no-data value NaN");
        std::fs::remove_file(path).unwrap();
    }

    #[test]
    fn files_that_are_not_height_fields_say_why() {
        let path = write::<colortype::RGB8>("bad.tif", &[0; 18], None);
        assert_refused(&path, "one grey sample per pixel");
        let path = write::<colortype::GrayI16>("bad.tif", &[0; 6], Some("none"));
        assert_refused(&path, "GDAL_NODATA tag `none` is not a number");
        let whole = std::fs::read(&path).unwrap();
        std::fs::write(&path, &whole[..whole.len() / 2]).unwrap();
        assert!(matches!(read(&path), Err(Error::TiffRead { .. })));
        std::fs::write(&path, b"II*\0").unwrap();
        assert!(matches!(read(&path), Err(Error::TiffRead { .. })));
        std::fs::remove_file(&path).unwrap();
        let missing = temp("missing.tif");
        assert!(matches!(read(&missing), Err(Error::Core(_))));
    }
}
