//! A height file's samples as stored, voids included: what `geosynth info` describes of a
//! DEM before anything refuses its voids, and what [`super::read_heightfield`] turns into
//! a [`HeightField`] when it has none.

use std::path::Path;

use pointset_core::HeightField;

use crate::Result;

/// The samples of a height file as it stores them, voids included: samples on the file's
/// no-data value (GeoTIFF's `GDAL_NODATA` tag, an ENVI header's `data ignore value`) or
/// not finite (NaN, as float DEMs often mark voids, or infinite).
#[derive(Debug, Clone, PartialEq)]
pub struct HeightSamples {
    /// Samples per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// The samples, row-major with row 0 at the top, cast to `f32`.
    pub heights: Vec<f32>,
    /// The file's no-data value, if it names one.
    pub no_data: Option<f32>,
}

/// How many voids a file's samples hold, and where the first lies
/// ([`HeightSamples::voids`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Voids {
    /// Samples on the file's no-data value.
    pub on_no_data: usize,
    /// Samples that are not finite (and not the no-data value).
    pub not_finite: usize,
    /// The first void's column and row (row 0 at the top).
    pub first: (usize, usize),
}

impl Voids {
    /// Every void.
    pub fn count(&self) -> usize {
        self.on_no_data + self.not_finite
    }
}

impl HeightSamples {
    /// Whether `h` is a void: the no-data value, or not finite.
    pub fn is_void(&self, h: f32) -> bool {
        !h.is_finite() || self.is_no_data(h)
    }

    /// Whether `h` is the file's no-data value (NaN when that is NaN).
    fn is_no_data(&self, h: f32) -> bool {
        self.no_data
            .is_some_and(|v| h == v || (h.is_nan() && v.is_nan()))
    }

    /// The voids, or `None` when there is none.
    ///
    /// ```
    /// use geosynth::imagery::HeightSamples;
    ///
    /// let samples = HeightSamples {
    ///     width: 3,
    ///     height: 2,
    ///     heights: vec![1.0, 2.0, 3.0, -9999.0, f32::NAN, 5.0],
    ///     no_data: Some(-9999.0),
    /// };
    /// let voids = samples.voids().ok_or("no voids")?;
    /// assert_eq!((voids.on_no_data, voids.not_finite, voids.first), (1, 1, (0, 1)));
    /// assert_eq!(samples.range(), Some((1.0, 5.0)));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn voids(&self) -> Option<Voids> {
        let first = self.heights.iter().position(|&h| self.is_void(h))?;
        let on_no_data = self.heights.iter().filter(|&&h| self.is_no_data(h)).count();
        let voids = self.heights.iter().filter(|&&h| self.is_void(h)).count();
        let width = self.width.max(1);
        Some(Voids {
            on_no_data,
            not_finite: voids - on_no_data,
            first: (first % width, first / width),
        })
    }

    /// The lowest and highest height that is not a void (`None` when every sample is one).
    pub fn range(&self) -> Option<(f32, f32)> {
        self.heights
            .iter()
            .filter(|&&h| !self.is_void(h))
            .fold(None, |range, &h| match range {
                None => Some((h, h)),
                Some((lo, hi)) => Some((lo.min(h), hi.max(h))),
            })
    }

    /// The height field of samples read from `path`. Errors: voids, named by count, kind
    /// and the first one's place (a height field has no holes), and fewer than 2 × 2
    /// samples.
    pub fn into_field(self, path: &Path) -> Result<HeightField> {
        if let Some(voids) = self.voids() {
            return Err(super::format_error(path, self.voids_refused(voids)));
        }
        Ok(HeightField::new(self.width, self.height, self.heights)?)
    }

    /// The height field of the samples with their voids filled
    /// ([`super::fill_harmonic`]: each the mean of its grid neighbours, the other samples
    /// fixed), and how many were filled. Errors: every sample a void, fewer than 2 × 2
    /// samples.
    ///
    /// ```
    /// use geosynth::imagery::HeightSamples;
    ///
    /// let samples = HeightSamples {
    ///     width: 3,
    ///     height: 2,
    ///     heights: vec![1.0, -9999.0, 3.0, 1.0, f32::NAN, 3.0],
    ///     no_data: Some(-9999.0),
    /// };
    /// let (field, filled) = samples.filled()?;
    /// assert_eq!(filled, 2);
    /// assert!((field.get(1, 0).ok_or("no sample")? - 2.0).abs() < 1e-6);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn filled(self) -> Result<(HeightField, usize)> {
        let known: Vec<Option<f32>> = self
            .heights
            .iter()
            .map(|&h| (!self.is_void(h)).then_some(h))
            .collect();
        let voids = known.iter().filter(|h| h.is_none()).count();
        let heights =
            super::fill_harmonic(&known, self.width).ok_or_else(|| crate::Error::NoSurface {
                reason: format!("every one of its {} samples is a void", known.len()),
            })?;
        Ok((HeightField::new(self.width, self.height, heights)?, voids))
    }

    /// Why the samples, with `voids`, are not a height field.
    fn voids_refused(&self, voids: Voids) -> String {
        let total = self.heights.len();
        let one = voids.count() == 1;
        let what = match (self.no_data, voids.on_no_data, voids.not_finite) {
            (Some(v), _, 0) => format!(
                "{} the no-data value {v}",
                if one { "holds" } else { "hold" }
            ),
            (Some(v), on, off) if on > 0 => {
                format!("are voids ({on} on the no-data value {v}, {off} not finite)")
            }
            _ => format!(
                "{} not finite (NaN or infinite)",
                if one { "is" } else { "are" }
            ),
        };
        let (column, row) = voids.first;
        format!(
            "{} of its {total} samples {what}, the first at column {column}, row {row}: a \
             height field has no holes (`geosynth quilt --fill-voids` fills them, as does \
             gdal_fillnodata)",
            voids.count()
        )
    }
}
