//! Block pyramids by averaging (paper 001 §4.1) and 8-bit quantization.
//!
//! A block of size `N³` (`N` a power of two) has `log2 N + 1` levels; level 1 is `1³` and
//! the last level is the block itself. Each coarser sample is the mean of the 2×2×2 finer
//! samples it covers, so for two blocks `B`, `B'` the per-level distance of paper 001 Eq. 1,
//! `dist(B{l}, B'{l}) = mean over samples of (B − B')²`, never decreases with the level
//! (Eq. 2): the mean of squared differences of averages is at most the average of squared
//! differences (Jensen).

use crate::error::{FieldError, Result};

/// The levels of one block's pyramid, coarsest first; level `l` (1-based) has
/// `(2^(l−1))³` samples in x-fastest order.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockPyramid {
    levels: Vec<Vec<f32>>,
}

impl BlockPyramid {
    /// Builds the pyramid of an `n³` block given x-fastest; `n` must be a power of two.
    pub fn new(block: &[f32], n: usize) -> Result<Self> {
        if !n.is_power_of_two() {
            return Err(FieldError::InvalidParameter {
                name: "block size",
                value: n.to_string(),
                expected: "a power of two",
            });
        }
        if block.len() != n * n * n {
            return Err(FieldError::InvalidParameter {
                name: "block",
                value: format!("{} samples", block.len()),
                expected: "exactly n³ samples",
            });
        }
        let mut levels = vec![block.to_vec()];
        let mut size = n;
        while size > 1 {
            let finer = levels.last().map_or(&[][..], Vec::as_slice);
            levels.push(downsample(finer, size));
            size /= 2;
        }
        levels.reverse();
        Ok(Self { levels })
    }

    /// Number of levels (`log2 n + 1`).
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Level `l` (1-based, 1 = coarsest).
    pub fn level(&self, l: usize) -> Option<&[f32]> {
        self.levels.get(l.checked_sub(1)?).map(Vec::as_slice)
    }

    /// `dist(B{l}, B'{l})` of paper 001 Eq. 1 at level `l` (mean squared difference).
    pub fn level_distance(&self, other: &Self, l: usize) -> Option<f32> {
        let (a, b) = (self.level(l)?, other.level(l)?);
        mean_squared_difference(a, b)
    }
}

/// Mean of `(a_i − b_i)²` (paper 001 Eq. 1 for equal-size blocks); 0 for empty slices,
/// `None` when the lengths differ.
pub fn mean_squared_difference(a: &[f32], b: &[f32]) -> Option<f32> {
    if a.len() != b.len() {
        return None;
    }
    if a.is_empty() {
        return Some(0.0);
    }
    let sum: f64 = a.iter().zip(b).map(|(x, y)| f64::from(x - y).powi(2)).sum();
    Some((sum / a.len() as f64) as f32)
}

/// Averages 2×2×2 cells of an `n³` block into an `(n/2)³` block (x-fastest); the caller
/// guarantees `block.len() == n³`.
fn downsample(block: &[f32], n: usize) -> Vec<f32> {
    let h = n / 2;
    let mut out = Vec::with_capacity(h * h * h);
    for k in 0..h {
        for j in 0..h {
            for i in 0..h {
                let mut sum = 0.0;
                for (dx, dy, dz) in [
                    (0, 0, 0),
                    (1, 0, 0),
                    (0, 1, 0),
                    (1, 1, 0),
                    (0, 0, 1),
                    (1, 0, 1),
                    (0, 1, 1),
                    (1, 1, 1),
                ] {
                    sum += block[(2 * i + dx) + n * ((2 * j + dy) + n * (2 * k + dz))];
                }
                out.push(sum / 8.0);
            }
        }
    }
    out
}

/// Maps distances in `[−range, range]` to 256 levels: `q = round((d + range) / (2 range) · 255)`;
/// values outside the range saturate. Dequantization returns the level's centre, so the
/// round-trip error is at most `range / 255`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quantizer {
    range: f32,
}

impl Quantizer {
    /// A quantizer for `[−range, range]` (positive, finite).
    pub fn new(range: f32) -> Result<Self> {
        crate::error::positive("range", range)?;
        Ok(Self { range })
    }

    /// The covered half-range.
    pub fn range(&self) -> f32 {
        self.range
    }

    /// Quantizes one distance (NaN maps to the middle level).
    pub fn quantize(&self, d: f32) -> u8 {
        let t =
            ((d.clamp(-self.range, self.range) + self.range) / (2.0 * self.range) * 255.0).round();
        if t.is_nan() { 128 } else { t as u8 }
    }

    /// The distance a level stands for.
    pub fn dequantize(&self, q: u8) -> f32 {
        f32::from(q) / 255.0 * 2.0 * self.range - self.range
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pyramid_levels_and_means() {
        let block: Vec<f32> = (0..64).map(|i| i as f32).collect();
        let p = BlockPyramid::new(&block, 4).unwrap();
        assert_eq!(p.level_count(), 3);
        assert_eq!(p.level(1).unwrap(), &[31.5]);
        assert_eq!(p.level(2).unwrap().len(), 8);
        assert_eq!(p.level(3).unwrap(), &block[..]);
        assert!(p.level(0).is_none());
        assert!(BlockPyramid::new(&block[..27], 3).is_err());
        assert!(BlockPyramid::new(&block[..8], 4).is_err());
    }

    #[test]
    fn quantizer_round_trip_error_is_bounded() {
        let q = Quantizer::new(2.0).unwrap();
        for i in 0..=400 {
            let d = -2.0 + i as f32 * 0.01;
            assert!((q.dequantize(q.quantize(d)) - d).abs() <= 2.0 / 255.0 + 1e-6);
        }
        assert_eq!(q.quantize(-10.0), 0);
        assert_eq!(q.quantize(10.0), 255);
        assert!(Quantizer::new(0.0).is_err());
    }
}
