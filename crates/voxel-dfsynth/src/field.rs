//! The quantized source field and its global subsampled pyramid (paper 001 §4.1).

use distance_field::Quantizer;
use pointset_core::Grid3;

use crate::error::{Result, VoxelError};

/// A scalar field quantized to 256 levels, x-fastest.
#[derive(Debug, Clone, PartialEq)]
pub struct QuantizedField {
    dims: [usize; 3],
    values: Vec<u8>,
}

impl QuantizedField {
    /// Quantizes a distance grid with `quantizer` (paper 001 §4.1: 256 levels).
    pub fn from_grid(grid: &Grid3<f32>, quantizer: &Quantizer) -> Self {
        Self {
            dims: grid.dims(),
            values: grid.data().iter().map(|&d| quantizer.quantize(d)).collect(),
        }
    }

    /// A field from raw levels (x-fastest).
    pub fn from_values(dims: [usize; 3], values: Vec<u8>) -> Result<Self> {
        if dims.contains(&0) || dims.iter().product::<usize>() != values.len() {
            return Err(VoxelError::InvalidParameter {
                name: "values",
                value: format!("{} values for {dims:?}", values.len()),
                expected: "one value per node of a non-empty grid".into(),
            });
        }
        Ok(Self { dims, values })
    }

    /// Nodes along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// All levels, x-fastest.
    pub fn values(&self) -> &[u8] {
        &self.values
    }

    /// Linear index of `(x, y, z)`.
    pub fn index(&self, x: usize, y: usize, z: usize) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// The `n³` block at `corner`, x-fastest.
    pub fn block(&self, corner: [usize; 3], n: usize) -> Vec<u8> {
        let mut out = Vec::with_capacity(n * n * n);
        for z in 0..n {
            for y in 0..n {
                let row = self.index(corner[0], corner[1] + y, corner[2] + z);
                out.extend_from_slice(&self.values[row..row + n]);
            }
        }
        out
    }

    /// Like [`QuantizedField::block_positions`], as a range error when `n` does not fit.
    pub fn fitting_positions(&self, n: usize) -> Result<[usize; 3]> {
        let [x, y, z] = self.dims;
        self.block_positions(n)
            .ok_or_else(|| VoxelError::InvalidParameter {
                name: "block size",
                value: format!("{n} (the field is {x} × {y} × {z} samples)"),
                expected: "a block that fits in the field along every axis (a thin solid needs \
                           a higher resolution or a smaller block)"
                    .into(),
            })
    }

    /// Block corners `0..=dims − n` along each axis (all blocks that fit), as counts.
    pub fn block_positions(&self, n: usize) -> Option<[usize; 3]> {
        let [x, y, z] = self.dims;
        (n >= 1 && n <= x && n <= y && n <= z).then(|| [x - n + 1, y - n + 1, z - n + 1])
    }
}

/// Sum of squared differences of two equally long blocks of levels (exact).
pub(crate) fn block_ssd(a: &[u8], b: &[u8]) -> u64 {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| u64::from(x.abs_diff(y)).pow(2))
        .sum()
}

/// Box means of a field over `c³` cells, for every cell corner (`G_c[p] = mean of f over
/// [p, p + c)³`), the global subsampled pyramid every block's levels are read from: level `l`
/// of the `n³` block at `p` is `G_{n/2^(l−1)}[p + c · (i, j, k)]`.
#[derive(Debug, Clone)]
pub struct BoxMeans {
    cell: usize,
    dims: [usize; 3],
    means: Vec<f32>,
}

impl BoxMeans {
    /// The box means of `field` over cells of side `cell` (defined where the cell fits).
    pub fn new(field: &QuantizedField, cell: usize) -> Self {
        let [nx, ny, nz] = field.dims();
        let dims = [nx + 1 - cell, ny + 1 - cell, nz + 1 - cell];
        // Separable running sums along x, then y, then z.
        let v = field.values();
        let mut sx = vec![0u32; dims[0] * ny * nz];
        for z in 0..nz {
            for y in 0..ny {
                let row = nx * (y + ny * z);
                let mut acc: u32 = v[row..row + cell].iter().map(|&b| u32::from(b)).sum();
                for x in 0..dims[0] {
                    if x > 0 {
                        acc = acc + u32::from(v[row + x + cell - 1]) - u32::from(v[row + x - 1]);
                    }
                    sx[x + dims[0] * (y + ny * z)] = acc;
                }
            }
        }
        let mut sy = vec![0u32; dims[0] * dims[1] * nz];
        for z in 0..nz {
            for x in 0..dims[0] {
                let at = |y: usize| sx[x + dims[0] * (y + ny * z)];
                let mut acc: u32 = (0..cell).map(at).sum();
                for y in 0..dims[1] {
                    if y > 0 {
                        acc = acc + at(y + cell - 1) - at(y - 1);
                    }
                    sy[x + dims[0] * (y + dims[1] * z)] = acc;
                }
            }
        }
        let volume = (cell * cell * cell) as f32;
        let mut means = vec![0f32; dims[0] * dims[1] * dims[2]];
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let at = |z: usize| sy[x + dims[0] * (y + dims[1] * z)];
                let mut acc: u32 = (0..cell).map(at).sum();
                for z in 0..dims[2] {
                    if z > 0 {
                        acc = acc + at(z + cell - 1) - at(z - 1);
                    }
                    means[x + dims[0] * (y + dims[1] * z)] = acc as f32 / volume;
                }
            }
        }
        Self { cell, dims, means }
    }

    /// Bytes held by the means.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.means.as_slice())
    }

    /// Cell side.
    pub fn cell(&self) -> usize {
        self.cell
    }

    /// Mean of the cell with corner `(x, y, z)`.
    pub fn mean(&self, x: usize, y: usize, z: usize) -> f32 {
        self.means[x + self.dims[0] * (y + self.dims[1] * z)]
    }
}

/// Level `l` (1-based; `r = 2^(l−1)` samples per side) of the `n³` block at `corner`, read
/// from the box means of cell `n / r`, x-fastest.
pub fn block_level(means: &BoxMeans, corner: [usize; 3], r: usize) -> Vec<f32> {
    let c = means.cell();
    let mut out = Vec::with_capacity(r * r * r);
    for k in 0..r {
        for j in 0..r {
            for i in 0..r {
                out.push(means.mean(corner[0] + i * c, corner[1] + j * c, corner[2] + k * c));
            }
        }
    }
    out
}

/// The source subsampled `drop` times at every offset (§5.2): `S[p]` is the source's mean over
/// the cell of side `c = 2^drop` at `p`, rounded to a level. The `m³` block at `p` of the
/// subsampled source is `S[p + c · (i, j, k)]` — the values the search tree with `drop` leaf
/// levels removed holds for the block at `p` ([`crate::SearchTree::subsampled_block`]).
#[derive(Debug, Clone)]
pub struct SubsampledSource {
    cell: usize,
    rounded: QuantizedField,
}

impl SubsampledSource {
    /// Subsamples `field` `drop` times (`drop = 0` keeps it as is). Errors when the cell does
    /// not fit in the field.
    pub fn new(field: &QuantizedField, drop: usize) -> Result<Self> {
        let cell = 1usize << drop.min(usize::BITS as usize - 1);
        field.fitting_positions(cell)?;
        if drop == 0 {
            return Ok(Self {
                cell,
                rounded: field.clone(),
            });
        }
        let means = BoxMeans::new(field, cell);
        let values = means.means.iter().map(|v| v.round() as u8).collect();
        Ok(Self {
            cell,
            rounded: QuantizedField::from_values(means.dims, values)?,
        })
    }

    /// Cell side `c = 2^drop`.
    pub fn cell(&self) -> usize {
        self.cell
    }

    /// Rounded cell means at every cell corner.
    pub fn rounded(&self) -> &QuantizedField {
        &self.rounded
    }

    /// The `m³` subsampled block at full-resolution corner `p` (x-fastest); `None` when it
    /// does not fit.
    pub fn block(&self, p: [usize; 3], m: usize) -> Option<Vec<u8>> {
        let c = self.cell;
        let dims = self.rounded.dims();
        if m == 0 || (0..3).any(|a| p[a] + c * (m - 1) >= dims[a]) {
            return None;
        }
        let v = self.rounded.values();
        let mut out = Vec::with_capacity(m * m * m);
        for k in 0..m {
            for j in 0..m {
                for i in 0..m {
                    out.push(v[self.rounded.index(p[0] + c * i, p[1] + c * j, p[2] + c * k)]);
                }
            }
        }
        Some(out)
    }

    /// The regular subsampled field of phase `phase` (each coordinate `< c`): samples
    /// `S[phase + c · i]`. Every subsampled block is a block of exactly one phase field.
    pub fn phase_field(&self, phase: [usize; 3]) -> Option<QuantizedField> {
        let c = self.cell;
        let dims = self.rounded.dims();
        if (0..3).any(|a| phase[a] >= c || phase[a] >= dims[a]) {
            return None;
        }
        let pd = [0, 1, 2].map(|a| (dims[a] - phase[a]).div_ceil(c));
        let v = self.rounded.values();
        let mut out = Vec::with_capacity(pd[0] * pd[1] * pd[2]);
        for k in 0..pd[2] {
            for j in 0..pd[1] {
                for i in 0..pd[0] {
                    out.push(
                        v[self
                            .rounded
                            .index(phase[0] + c * i, phase[1] + c * j, phase[2] + c * k)],
                    );
                }
            }
        }
        QuantizedField::from_values(pd, out).ok()
    }
}
