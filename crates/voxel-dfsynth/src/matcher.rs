//! Interchangeable exact block matchers: the paper's search tree, brute force, and masked
//! SSD by FFT cross-correlation. All return a best block under Eq. 1.

use rayon::prelude::*;

use crate::error::{Result, VoxelError};
use crate::fft::{Complex, fft_3d};
use crate::field::{BoxMeans, QuantizedField};
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
            expected: "N³ values".into(),
        })
    }
}

/// Linear search over every block (parallel, exact; ties go to the lowest corner index).
#[derive(Debug, Clone)]
pub struct BruteForce {
    field: QuantizedField,
    n: usize,
    positions: [usize; 3],
    /// Box means for pyramid levels 2 and 3 (cells `n/2`, `n/4`) where they exist.
    filters: Vec<BoxMeans>,
}

impl BruteForce {
    /// A brute-force matcher over every `n³` block of `field`.
    pub fn new(field: &QuantizedField, n: usize) -> Result<Self> {
        let positions = field.fitting_positions(n)?;
        let filters = [2, 4]
            .into_iter()
            .filter(|&r| n >= 2 * r && n.is_multiple_of(r))
            .map(|r| BoxMeans::new(field, n / r))
            .collect();
        Ok(Self {
            field: field.clone(),
            n,
            positions,
            filters,
        })
    }

    /// Eq. 2 as a filter: `n³ · dist(level)` of the block at `corner` against the query's
    /// level means `q`, a lower bound of the block's sum of squared differences. It is shrunk
    /// by 10⁻⁴ and ½ against the rounding of the `f32` means (whose effect stays below both
    /// for blocks up to 32³); sums are integers, so a block is only skipped when its sum
    /// exceeds the best one.
    fn level_bound(means: &BoxMeans, corner: [usize; 3], q: &[f32], r: usize) -> f64 {
        // The filters' levels have 2 and 4 cells a side; each gets a copy compiled for it.
        let sum = match r {
            2 => level_sum(means, corner, q, 2),
            4 => level_sum(means, corner, q, 4),
            _ => level_sum(means, corner, q, r),
        };
        let c = means.cell();
        f64::from(sum) * (c * c * c) as f64 * (1.0 - 1e-4) - 0.5
    }
}

/// `Σ (mean − q)²` over the `r³` cells of a block's level ([`BruteForce::level_bound`]),
/// in four interleaved partial sums: with one running sum every addition waited for the
/// one before, and this loop's instructions held about 40% of a synthesis's profile
/// samples (`perf`). The order of the additions changes the `f32` rounding only (relative
/// error below 10⁻⁵ for 64 terms), which the bound's 10⁻⁴ margin covers.
#[inline(always)]
fn level_sum(means: &BoxMeans, corner: [usize; 3], q: &[f32], r: usize) -> f32 {
    let c = means.cell();
    let mut lanes = [0.0f32; 4];
    for k in 0..r {
        for j in 0..r {
            for i in 0..r {
                let b = means.mean(corner[0] + i * c, corner[1] + j * c, corner[2] + k * c);
                lanes[i % 4] += (b - q[i + r * (j + r * k)]).powi(2);
            }
        }
    }
    (lanes[0] + lanes[1]) + (lanes[2] + lanes[3])
}

impl BruteForce {
    /// The block with the smallest sum of squared differences to `query` among those whose
    /// sum is below `limit` (`None`: no limit), as `(ssd, position index)`; ties go to the
    /// lowest index. `None` when no block is below the limit (a caller holding a block at
    /// `limit` keeps it: ties go to what the caller already has).
    ///
    /// Partial distance search: each block's sum is accumulated row by row (z-slice after
    /// z-slice, so the already synthesized lower octants of a synthesis query come first) and
    /// abandoned as soon as it reaches the best sum known to its worker, which starts at
    /// `limit`. Exact: an abandoned block cannot be strictly better than one already found,
    /// and among equal sums the earlier (lower-index) block wins.
    ///
    /// `parallel` splits the positions over threads (slabs along z); without it the search
    /// runs on the calling thread, for callers that parallelize over many searches.
    pub fn best_within(
        &self,
        query: &[u8],
        limit: Option<u64>,
        parallel: bool,
    ) -> Result<Option<(u64, usize)>> {
        check_query(query, self.n)?;
        let n = self.n;
        let [px, py, pz] = self.positions;
        let values = self.field.values();
        let query_field = QuantizedField::from_values([n, n, n], query.to_vec())?;
        let query_means: Vec<Vec<f32>> = self
            .filters
            .iter()
            .map(|f| {
                let own = BoxMeans::new(&query_field, f.cell());
                crate::field::block_level(&own, [0, 0, 0], n / f.cell())
            })
            .collect();
        let strides = [self.field.index(0, 1, 0), self.field.index(0, 0, 1)];
        let slab = |z0: usize| {
            let mut best: Option<(u64, usize)> = None;
            let mut bound = limit.unwrap_or(u64::MAX);
            for y0 in 0..py {
                'block: for x0 in 0..px {
                    for (f, q) in self.filters.iter().zip(&query_means) {
                        if Self::level_bound(f, [x0, y0, z0], q, n / f.cell()) >= bound as f64 {
                            continue 'block;
                        }
                    }
                    let start = self.field.index(x0, y0, z0);
                    let Some(ssd) = ssd_below(&values[start..], strides, query, n, bound) else {
                        continue 'block;
                    };
                    // Reached only when `ssd < bound`: strictly better than the limit and
                    // than every earlier (lower-index) block of this slab.
                    best = Some((ssd, x0 + px * (y0 + py * z0)));
                    bound = ssd;
                }
            }
            best
        };
        let merge = |a: Option<(u64, usize)>, b: Option<(u64, usize)>| match (a, b) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, None) => a,
            (None, b) => b,
        };
        Ok(if parallel {
            (0..pz).into_par_iter().map(slab).reduce(|| None, merge)
        } else {
            (0..pz).map(slab).fold(None, merge)
        })
    }

    /// The paper's linear search, as Table 1 compares against: the full sum of squared
    /// differences of every block, no early exit, no filter (parallel; ties go to the lowest
    /// index). Same result as [`BlockMatcher::best_match`], which prunes.
    pub fn exhaustive(&self, query: &[u8]) -> Result<Match> {
        check_query(query, self.n)?;
        let n = self.n;
        let [px, py, pz] = self.positions;
        let values = self.field.values();
        let best = (0..px * py * pz)
            .into_par_iter()
            .map(|id| {
                let [x0, y0, z0] = self.corner(id);
                let mut ssd = 0u64;
                for z in 0..n {
                    for y in 0..n {
                        let row = self.field.index(x0, y0 + y, z0 + z);
                        let q = &query[n * (y + n * z)..n * (y + n * z) + n];
                        ssd += values[row..row + n]
                            .iter()
                            .zip(q)
                            .map(|(&a, &b)| u64::from(a.abs_diff(b)).pow(2))
                            .sum::<u64>();
                    }
                }
                (ssd, id)
            })
            .min();
        self.to_match(best)
    }

    /// The match for a `(sum, position index)` result; an error when there is none.
    fn to_match(&self, best: Option<(u64, usize)>) -> Result<Match> {
        let (ssd, id) = best.ok_or(VoxelError::InvalidParameter {
            name: "field",
            value: "no blocks".into(),
            expected: "at least one block".into(),
        })?;
        Ok(Match {
            corner: self.corner(id),
            distance: ssd as f32 / (self.n * self.n * self.n) as f32,
        })
    }

    /// Corner of position index `id`.
    pub fn corner(&self, id: usize) -> [usize; 3] {
        let [px, py, _] = self.positions;
        [id % px, (id / px) % py, id / (px * py)]
    }
}

/// The sum of squared differences between the `n³` block whose first sample starts
/// `values` (`strides`: from one row to the next along y, and along z) and `query`
/// (x-fastest), if it is below `bound`; `None` as soon as the partial sum reaches it.
/// Summed row by row in the order of `query`, so the rows of a synthesis query's already
/// synthesized lower octants come first.
///
/// The block sizes of a synthesis (powers of two up to 32) each get a copy of
/// [`ssd_below_any`] compiled for their row length: with the length known, a row's
/// differences are summed in a few vector instructions instead of a loop with a runtime
/// trip count (2–2.5× faster per sample at 4, 8 and 16, measured in a scratch benchmark;
/// `docs/performance.md`).
fn ssd_below(
    values: &[u8],
    strides: [usize; 2],
    query: &[u8],
    n: usize,
    bound: u64,
) -> Option<u64> {
    match n {
        2 => ssd_below_any(values, strides, query, 2, bound),
        4 => ssd_below_any(values, strides, query, 4, bound),
        8 => ssd_below_any(values, strides, query, 8, bound),
        16 => ssd_below_any(values, strides, query, 16, bound),
        32 => ssd_below_any(values, strides, query, 32, bound),
        _ => ssd_below_any(values, strides, query, n, bound),
    }
}

/// [`ssd_below`] for any row length `n`; inlined into each arm of its dispatch, where `n`
/// is a constant. Squares of differences of 8-bit levels fit in `u16` (255² = 65,025).
#[inline(always)]
fn ssd_below_any(
    values: &[u8],
    [along_y, along_z]: [usize; 2],
    query: &[u8],
    n: usize,
    bound: u64,
) -> Option<u64> {
    let mut ssd = 0u64;
    for (r, q) in query.chunks_exact(n).enumerate() {
        let row = (r % n) * along_y + (r / n) * along_z;
        let sum: u32 = values[row..row + n]
            .iter()
            .zip(q)
            .map(|(&a, &b)| {
                let d = u16::from(a.abs_diff(b));
                u32::from(d * d)
            })
            .sum();
        ssd += u64::from(sum);
        if ssd >= bound {
            return None;
        }
    }
    Some(ssd)
}

impl BlockMatcher for BruteForce {
    fn block_size(&self) -> usize {
        self.n
    }

    fn best_match(&self, query: &[u8]) -> Result<Match> {
        self.to_match(self.best_within(query, None, true)?)
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
                expected: "at least one block".into(),
            })?;
        Ok(Match {
            corner: [id % px, (id / px) % py, id / (px * py)],
            distance: *best as f32 / (n * n * n) as f32,
        })
    }
}
