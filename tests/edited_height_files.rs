//! Edited or cut-short height-field files: raw `.f32le` with an ENVI header (the data or
//! the header edited), TIFF (Deflate-compressed and placed as `write_geotiff` writes it,
//! or uncompressed 16-bit integers in strips) and 16-bit PNG. Each is read as a valid
//! height field or refused with an error, never a panic; so are the TIFFs' GeoTIFF tags.

// Test helpers fail the test by panicking; that is their job.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::path::{Path, PathBuf};

use geosynth::core::HeightField;
use geosynth::imagery::{
    GeoReference, PlanPlacement, read_heightfield, write_geotiff, write_heightfield,
};
use proptest::prelude::*;

/// The files edited.
#[derive(Debug, Clone, Copy)]
enum Kind {
    /// Raw samples, the data edited.
    RawData,
    /// Raw samples, the ENVI header beside them edited.
    RawHeader,
    /// A placed, Deflate-compressed GeoTIFF.
    GeoTiff,
    /// Uncompressed signed 16-bit samples, two rows per strip.
    Int16Tiff,
    /// 16-bit grey PNG.
    Png,
}

const KINDS: [Kind; 5] = [
    Kind::RawData,
    Kind::RawHeader,
    Kind::GeoTiff,
    Kind::Int16Tiff,
    Kind::Png,
];

/// A 7 × 5 field of varied heights between 0 and 1 (so that the PNG holds them too).
fn field(seed: u64) -> HeightField {
    let heights = (0..35u64)
        .map(|i| ((i * 2654435761 + seed) % 1000) as f32 / 1000.0)
        .collect();
    HeightField::new(7, 5, heights).unwrap()
}

/// Writes `field` as `kind` into `dir`; returns the file to read and the file to edit.
fn write(kind: Kind, field: &HeightField, dir: &Path) -> (PathBuf, PathBuf) {
    match kind {
        Kind::RawData | Kind::RawHeader => {
            let raw = dir.join("dem.f32le");
            let bytes: Vec<u8> = field
                .heights()
                .iter()
                .flat_map(|h| h.to_le_bytes())
                .collect();
            std::fs::write(&raw, bytes).unwrap();
            let header = dir.join("dem.hdr");
            let text = "ENVI\nsamples = 7\nlines = 5\nbands = 1\nheader offset = 0\n\
                        data type = 4\nbyte order = 0\ndata ignore value = -9999\n";
            std::fs::write(&header, text).unwrap();
            let edited = if matches!(kind, Kind::RawData) {
                raw.clone()
            } else {
                header
            };
            (raw, edited)
        }
        Kind::GeoTiff => {
            let path = dir.join("dem.tif");
            let placement = PlanPlacement {
                top_left: [500_000.0, 4_000_000.0],
                spacing: 30.0,
            };
            write_geotiff(&path, field, Some(&GeoReference::from(placement))).unwrap();
            (path.clone(), path)
        }
        Kind::Int16Tiff => {
            let path = dir.join("dem.tiff");
            let file = std::fs::File::create(&path).unwrap();
            let mut encoder = tiff::encoder::TiffEncoder::new(file).unwrap();
            let mut image = encoder
                .new_image::<tiff::encoder::colortype::GrayI16>(7, 5)
                .unwrap();
            image.rows_per_strip(2).unwrap();
            let samples: Vec<i16> = field.heights().iter().map(|h| (h * 3e4) as i16).collect();
            image.write_data(&samples).unwrap();
            (path.clone(), path)
        }
        Kind::Png => {
            let path = write_heightfield(&dir.join("dem.png"), field).unwrap().path;
            (path.clone(), path)
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn edited_height_files_are_read_or_refused(
        seed in any::<u64>(),
        kind in 0usize..KINDS.len(),
        edits in proptest::collection::vec((0usize..4000, any::<u8>()), 1..6),
        cut in proptest::option::of(0usize..4000),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let (read_path, edited) = write(KINDS[kind], &field(seed), dir.path());
        let mut bytes = std::fs::read(&edited).unwrap();
        let len = bytes.len();
        for (at, byte) in edits {
            bytes[at % len] = byte;
        }
        // Some files are only edited: a cut of `cut % len` would almost always shorten them.
        if let Some(cut) = cut {
            bytes.truncate(len - cut % len);
        }
        std::fs::write(&edited, bytes).unwrap();
        if let Ok(Some(reference)) = GeoReference::read(&read_path) {
            // No key directory, or its header and as many keys as the header counts.
            let keys = &reference.keys;
            prop_assert!(keys.is_empty() || keys.len() >= 4 + 4 * usize::from(keys[3]));
        }
        if let Ok(field) = read_heightfield(&read_path) {
            prop_assert_eq!(field.heights().len(), field.width() * field.height());
            prop_assert!(field.width() >= 2 && field.height() >= 2);
            prop_assert!(field.heights().iter().all(|h| h.is_finite()));
        }
    }
}
