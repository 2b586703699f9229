//! Height fields: regular 2D grids of heights, as raw `f32` files or sampled surfaces.

use std::path::Path;

use glam::{DVec3, Vec3};

use crate::{Error, PointSet, Result, TriMesh};

/// A `width × height` grid of heights, row-major with row 0 at the top (image order).
///
/// World placement used by [`HeightField::position`]: column `c`, row `r` sits at
/// `x = c·spacing`, `y = (height − 1 − r)·spacing`, `z = scale·h`, so +Z is up and the image
/// reads the right way round when seen from above.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightField {
    width: usize,
    height: usize,
    heights: Vec<f32>,
}

impl HeightField {
    /// A field from row-major samples; needs at least 2 × 2 finite samples.
    pub fn new(width: usize, height: usize, heights: Vec<f32>) -> Result<Self> {
        if width < 2 || height < 2 {
            return Err(Error::InvalidParameter {
                name: "width/height",
                value: format!("{width}x{height}"),
                expected: "at least 2x2 samples".into(),
            });
        }
        let expected = width
            .checked_mul(height)
            .ok_or_else(|| Error::InvalidParameter {
                name: "width/height",
                value: format!("{width}x{height}"),
                expected: "a sample count that fits in memory".into(),
            })?;
        if heights.len() != expected {
            return Err(Error::LengthMismatch {
                what: "height samples".into(),
                expected,
                found: heights.len(),
            });
        }
        if let Some(first) = heights.iter().position(|h| !h.is_finite()) {
            return Err(Error::NonFiniteHeights {
                count: heights.iter().filter(|h| !h.is_finite()).count(),
                total: heights.len(),
                column: first % width,
                row: first / width,
            });
        }
        Ok(Self {
            width,
            height,
            heights,
        })
    }

    /// Decodes raw little-endian `f32` samples (e.g. `*_317x460.f32le` files).
    pub fn from_f32le(bytes: &[u8], width: usize, height: usize) -> Result<Self> {
        Self::new(width, height, Self::f32le_samples(bytes, width, height)?)
    }

    /// The `width × height` raw little-endian `f32` samples in `bytes`, as stored (NaN
    /// included). Errors: a length other than 4 bytes a sample.
    pub fn f32le_samples(bytes: &[u8], width: usize, height: usize) -> Result<Vec<f32>> {
        let needed = width.checked_mul(height).and_then(|n| n.checked_mul(4));
        if needed != Some(bytes.len()) {
            return Err(Error::RawSizeMismatch {
                width,
                height,
                expected_bytes: needed,
                found_bytes: bytes.len(),
            });
        }
        Ok(bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect())
    }

    /// Reads a raw `f32le` file whose name carries its size as `_WxH` (as in
    /// `StoneWall_200x200.f32le`).
    pub fn read_f32le(path: &Path) -> Result<Self> {
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        let (width, height) = dims_from_name(name).ok_or_else(|| Error::UnknownFormat {
            path: path.to_path_buf(),
            reason: "raw height fields must be named like `name_WIDTHxHEIGHT.f32le`".into(),
        })?;
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_f32le(&bytes, width, height)
    }

    /// Samples per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// All samples, row-major.
    pub fn heights(&self) -> &[f32] {
        &self.heights
    }

    /// The sample at column `col`, row `row`.
    pub fn get(&self, col: usize, row: usize) -> Option<f32> {
        (col < self.width && row < self.height).then(|| self.heights[row * self.width + col])
    }

    /// Smallest and largest height.
    pub fn range(&self) -> (f32, f32) {
        self.heights
            .iter()
            .fold((f32::MAX, f32::MIN), |(lo, hi), &h| (lo.min(h), hi.max(h)))
    }

    /// World position of a sample (see the type docs for the placement).
    pub fn position(&self, col: usize, row: usize, spacing: f32, scale: f32) -> Vec3 {
        let h = self.heights[row.min(self.height - 1) * self.width + col.min(self.width - 1)];
        Vec3::new(
            col as f32 * spacing,
            (self.height - 1 - row.min(self.height - 1)) as f32 * spacing,
            h * scale,
        )
    }

    /// Unit surface normal at a sample from central differences (one-sided at borders);
    /// indices past the border read the border's samples, as [`HeightField::position`]
    /// does for its height. Slopes too steep for single precision (their squares
    /// overflow: a relief of 10³⁰ made every normal zero) are worked out in double.
    pub fn normal(&self, col: usize, row: usize, spacing: f32, scale: f32) -> Vec3 {
        let (col, row) = (col.min(self.width - 1), row.min(self.height - 1));
        let (c0, c1) = (col.saturating_sub(1), (col + 1).min(self.width - 1));
        let (r0, r1) = (row.saturating_sub(1), (row + 1).min(self.height - 1));
        let height = |c: usize, r: usize| self.heights[r * self.width + c];
        let at = |c: usize, r: usize| height(c, r) * scale;
        let dzdx = (at(c1, row) - at(c0, row)) / ((c1 - c0) as f32 * spacing);
        // Rows grow downward, y grows upward.
        let dzdy = (at(col, r0) - at(col, r1)) / ((r1 - r0) as f32 * spacing);
        Vec3::new(-dzdx, -dzdy, 1.0)
            .try_normalize()
            .unwrap_or_else(|| {
                let at = |c: usize, r: usize| f64::from(height(c, r)) * f64::from(scale);
                let spacing = f64::from(spacing);
                let dzdx = (at(c1, row) - at(c0, row)) / ((c1 - c0) as f64 * spacing);
                let dzdy = (at(col, r0) - at(col, r1)) / ((r1 - r0) as f64 * spacing);
                DVec3::new(-dzdx, -dzdy, 1.0)
                    .normalize_or(DVec3::Z)
                    .as_vec3()
            })
    }

    /// Every sample as an oriented point.
    pub fn to_points(&self, spacing: f32, scale: f32) -> Result<PointSet> {
        let (mut p, mut n) = (
            Vec::with_capacity(self.heights.len()),
            Vec::with_capacity(self.heights.len()),
        );
        for row in 0..self.height {
            for col in 0..self.width {
                p.push(self.position(col, row, spacing, scale));
                n.push(self.normal(col, row, spacing, scale));
            }
        }
        PointSet::new(p)?.with_normals(n)
    }

    /// The grid as a triangle mesh (two triangles per cell, facing +Z), with normals.
    pub fn to_mesh(&self, spacing: f32, scale: f32) -> Result<TriMesh> {
        let points = self.to_points(spacing, scale)?;
        let w = self.width as u32;
        let mut tris = Vec::with_capacity(2 * (self.width - 1) * (self.height - 1));
        for row in 0..self.height as u32 - 1 {
            for col in 0..w - 1 {
                let (a, b) = (row * w + col, row * w + col + 1);
                let (c, d) = (a + w, b + w);
                // Row r+1 lies below row r (smaller y): keep counter-clockwise seen from +Z.
                tris.push([a, c, b]);
                tris.push([b, c, d]);
            }
        }
        TriMesh::new(points, tris)
    }
}

/// Parses `_WIDTHxHEIGHT` at the end of a file stem.
pub fn dims_from_name(stem: &str) -> Option<(usize, usize)> {
    let tail = stem.rsplit('_').next()?;
    let (w, h) = tail.split_once('x')?;
    Some((w.parse().ok()?, h.parse().ok()?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_has_up_normals_and_right_orientation() {
        let hf = HeightField::new(3, 2, vec![0.0, 1.0, 2.0, 0.0, 1.0, 2.0]).unwrap();
        // z = x: normal is (-1, 0, 1)/√2 everywhere.
        for row in 0..2 {
            for col in 0..3 {
                let n = hf.normal(col, row, 1.0, 1.0);
                assert!((n - Vec3::new(-1.0, 0.0, 1.0).normalize()).length() < 1e-6);
            }
        }
        assert_eq!(hf.position(0, 0, 1.0, 1.0), Vec3::new(0.0, 1.0, 0.0));
        // Past the border: the border's samples are read, as for positions' heights.
        assert_eq!(hf.normal(5, 7, 1.0, 1.0), hf.normal(2, 1, 1.0, 1.0));
        assert_eq!(hf.position(5, 7, 1.0, 1.0).z, hf.position(2, 1, 1.0, 1.0).z);
        let mesh = hf.to_mesh(1.0, 1.0).unwrap();
        assert_eq!(mesh.face_count(), 4);
        for n in mesh.face_normals() {
            assert!(n.z > 0.0);
        }
    }

    #[test]
    fn slopes_too_steep_for_single_precision_keep_their_normals() {
        // z = 10³⁰·x: dz/dx squared overflows f32 (every normal came out zero), and the
        // normal is −x to within 10⁻³⁰ of a radian.
        let hf = HeightField::new(3, 2, vec![0.0, 1.0, 2.0, 0.0, 1.0, 2.0]).unwrap();
        for scale in [1e19, 1e30, -1e30] {
            let n = hf.normal(1, 0, 1.0, scale);
            let expected = Vec3::new(-scale.signum(), 0.0, 0.0);
            assert!((n - expected).length() < 1e-6, "{n} for scale {scale}");
        }
        let points = hf.to_points(1.0, 1e30).unwrap();
        assert_eq!(points.directionless_normals(), 0);
    }

    #[test]
    fn bad_fields_are_errors() {
        assert!(HeightField::new(1, 5, vec![0.0; 5]).is_err());
        assert!(HeightField::new(2, 2, vec![0.0; 3]).is_err());
        let voids = HeightField::new(3, 2, vec![0.0, 1.0, 2.0, f32::NAN, 0.0, f32::INFINITY]);
        assert!(matches!(
            voids,
            Err(Error::NonFiniteHeights {
                count: 2,
                total: 6,
                column: 0,
                row: 1
            })
        ));
        let short = HeightField::from_f32le(&[0u8; 15], 2, 2).unwrap_err();
        assert!(
            matches!(
                short,
                Error::RawSizeMismatch {
                    expected_bytes: Some(16),
                    found_bytes: 15,
                    ..
                }
            ),
            "{short}"
        );
        assert!(short.to_string().contains("16 bytes"), "{short}");
        let huge = HeightField::from_f32le(&[0u8; 16], usize::MAX / 2, 3).unwrap_err();
        assert!(
            matches!(
                huge,
                Error::RawSizeMismatch {
                    expected_bytes: None,
                    ..
                }
            ),
            "{huge}"
        );
        assert!(
            huge.to_string()
                .contains(&format!("needs more than {} bytes", usize::MAX)),
            "{huge}"
        );
        assert_eq!(dims_from_name("SainteHelens_317x460"), Some((317, 460)));
        assert_eq!(dims_from_name("nodims"), None);
    }
}
