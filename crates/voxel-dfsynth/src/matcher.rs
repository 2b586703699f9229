//! Interchangeable exact block matchers: the paper's search tree, brute force, and masked
//! SSD by FFT cross-correlation. All return a best block under Eq. 1.

use rayon::prelude::*;

use crate::error::{Result, VoxelError};
use crate::fft::{Complex, fft_3d};
use crate::field::QuantizedField;
use crate::tree::{Match, SearchTree};

/// Finds the source block closest to a query block under paper 001 Eq. 1.
pub trait BlockMatcher: Send + Sync {
    /// Block size `N`.
    fn block_size(&self) -> usize;
    /// The best match for `query` (`N³` levels, x-fastest).
    fn best_match(&self, query: &[u8]) -> Result<Match>;
}

impl BlockMatcher for SearchTree {
    fn block_size(&self) -> usize {
        SearchTree::block_size(self)
    }

    fn best_match(&self, query: &[u8]) -> Result<Match> {
        SearchTree::best_match(self, query)
    }
}

fn check_query(query: &[u8], n: usize) -> Result<()> {
    if query.len() == n * n * n {
        Ok(())
    } else {
        Err(VoxelError::InvalidParameter {
            name: "query",
            value: format!("{} values", query.len()),
            expected: "N³ values",
        })
    }
}

/// Linear search over every block (parallel, exact; ties go to the lowest corner index).
#[derive(Debug, Clone)]
pub struct BruteForce {
    field: QuantizedField,
    n: usize,
    positions: [usize; 3],
}

impl BruteForce {
    /// A brute-force matcher over every `n³` block of `field`.
    pub fn new(field: &QuantizedField, n: usize) -> Result<Self> {
        let positions = field.fitting_positions(n)?;
        Ok(Self {
            field: field.clone(),
            n,
            positions,
        })
    }
}

impl BlockMatcher for BruteForce {
    fn block_size(&self) -> usize {
        self.n
    }

    fn best_match(&self, query: &[u8]) -> Result<Match> {
        check_query(query, self.n)?;
        let n = self.n;
        let [px, py, pz] = self.positions;
        let best = (0..px * py * pz)
            .into_par_iter()
            .map(|id| {
                let corner = [id % px, (id / px) % py, id / (px * py)];
                let mut ssd = 0u64;
                for z in 0..n {
                    for y in 0..n {
                        let row = self.field.index(corner[0], corner[1] + y, corner[2] + z);
                        let q = &query[n * (y + n * z)..n * (y + n * z) + n];
                        ssd += self.field.values()[row..row + n]
                            .iter()
                            .zip(q)
                            .map(|(&a, &b)| u64::from(a.abs_diff(b)).pow(2))
                            .sum::<u64>();
                    }
                }
                (ssd, id)
            })
            .min()
            .ok_or(VoxelError::InvalidParameter {
                name: "field",
                value: "no blocks".into(),
                expected: "at least one block",
            })?;
        let id = best.1;
        Ok(Match {
            corner: [id % px, (id / px) % py, id / (px * py)],
            distance: best.0 as f32 / (n * n * n) as f32,
        })
    }
}

/// Exact masked SSD for every block position at once:
/// `Σ M (S − Q)² = corr(S², M) − 2 corr(S, M·Q) + Σ M Q²`, the correlations by FFT with the
/// source spectra precomputed (the source zero-padded to powers of two; block corners that fit
/// never wrap). Sums are integers, recovered exactly by rounding.
#[derive(Debug, Clone)]
pub struct FftMatcher {
    n: usize,
    dims: [usize; 3],
    padded: [usize; 3],
    source: Vec<Complex>,
    source_squared: Vec<Complex>,
}

impl FftMatcher {
    /// Precomputes the spectra of `field` and of its squares for blocks of size `n`.
    pub fn new(field: &QuantizedField, n: usize) -> Result<Self> {
        field.fitting_positions(n)?;
        let dims = field.dims();
        let padded = dims.map(usize::next_power_of_two);
        let size = padded.iter().product::<usize>();
        let mut source = vec![Complex::default(); size];
        let mut source_squared = vec![Complex::default(); size];
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let v = f64::from(field.values()[field.index(x, y, z)]);
                    let i = x + padded[0] * (y + padded[1] * z);
                    source[i].re = v;
                    source_squared[i].re = v * v;
                }
            }
        }
        fft_3d(&mut source, padded, false);
        fft_3d(&mut source_squared, padded, false);
        Ok(Self {
            n,
            dims,
            padded,
            source,
            source_squared,
        })
    }

    /// Masked SSD for every block corner (x-fastest over the corners that fit); `mask` has
    /// one entry per query sample (true = compare).
    pub fn masked_ssd(&self, query: &[u8], mask: &[bool]) -> Result<Vec<u64>> {
        check_query(query, self.n)?;
        check_query(&vec![0u8; mask.len()], self.n)?;
        let n = self.n;
        let p = self.padded;
        let size = p.iter().product::<usize>();
        let (mut m, mut mq) = (
            vec![Complex::default(); size],
            vec![Complex::default(); size],
        );
        let mut energy = 0u64;
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let s = x + n * (y + n * z);
                    if mask[s] {
                        let i = x + p[0] * (y + p[1] * z);
                        m[i].re = 1.0;
                        mq[i].re = f64::from(query[s]);
                        energy += u64::from(query[s]).pow(2);
                    }
                }
            }
        }
        fft_3d(&mut m, p, false);
        fft_3d(&mut mq, p, false);
        // corr(A, B)(t) = Σ_b B(b) A(t + b) = IFFT(FFT(A) · conj(FFT(B))).
        let mut first: Vec<Complex> = self
            .source_squared
            .iter()
            .zip(&m)
            .map(|(a, b)| a.mul_conj(*b))
            .collect();
        let mut second: Vec<Complex> = self
            .source
            .iter()
            .zip(&mq)
            .map(|(a, b)| a.mul_conj(*b))
            .collect();
        fft_3d(&mut first, p, true);
        fft_3d(&mut second, p, true);
        let [px, py, pz] = [
            self.dims[0] - n + 1,
            self.dims[1] - n + 1,
            self.dims[2] - n + 1,
        ];
        let mut out = Vec::with_capacity(px * py * pz);
        for z in 0..pz {
            for y in 0..py {
                for x in 0..px {
                    let i = x + p[0] * (y + p[1] * z);
                    let v = first[i].re.round() - 2.0 * second[i].re.round() + energy as f64;
                    out.push(v.max(0.0) as u64);
                }
            }
        }
        Ok(out)
    }
}

impl BlockMatcher for FftMatcher {
    fn block_size(&self) -> usize {
        self.n
    }

    fn best_match(&self, query: &[u8]) -> Result<Match> {
        let n = self.n;
        let ssd = self.masked_ssd(query, &vec![true; n * n * n])?;
        let (px, py) = (self.dims[0] - n + 1, self.dims[1] - n + 1);
        let (id, best) = ssd
            .iter()
            .enumerate()
            .min_by_key(|(i, v)| (**v, *i))
            .ok_or(VoxelError::InvalidParameter {
                name: "field",
                value: "no blocks".into(),
                expected: "at least one block",
            })?;
        Ok(Match {
            corner: [id % px, (id / px) % py, id / (px * py)],
            distance: *best as f32 / (n * n * n) as f32,
        })
    }
}
