//! A radix-2 complex FFT in 1D and 3D (f64), for the FFT block matcher.

use std::f64::consts::PI;

/// A complex number.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Complex {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl Complex {
    fn mul(self, o: Self) -> Self {
        Self {
            re: self.re * o.re - self.im * o.im,
            im: self.re * o.im + self.im * o.re,
        }
    }

    /// `self · conj(o)`.
    pub fn mul_conj(self, o: Self) -> Self {
        Self {
            re: self.re * o.re + self.im * o.im,
            im: self.im * o.re - self.re * o.im,
        }
    }
}

/// In-place iterative radix-2 FFT of a power-of-two-length slice; `inverse` computes the
/// unnormalized inverse transform.
pub fn fft_1d(data: &mut [Complex], inverse: bool) {
    let n = data.len();
    if n <= 1 {
        return;
    }
    // Bit-reversal permutation.
    let mut j = 0usize;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            data.swap(i, j);
        }
    }
    let sign = if inverse { 1.0 } else { -1.0 };
    let mut len = 2;
    while len <= n {
        let angle = sign * 2.0 * PI / len as f64;
        let step = Complex {
            re: angle.cos(),
            im: angle.sin(),
        };
        for start in (0..n).step_by(len) {
            let mut w = Complex { re: 1.0, im: 0.0 };
            for k in 0..len / 2 {
                let a = data[start + k];
                let b = data[start + k + len / 2].mul(w);
                data[start + k] = Complex {
                    re: a.re + b.re,
                    im: a.im + b.im,
                };
                data[start + k + len / 2] = Complex {
                    re: a.re - b.re,
                    im: a.im - b.im,
                };
                w = w.mul(step);
            }
        }
        len <<= 1;
    }
}

/// Transforms the strided lines `start + k·stride`, `k < len`, for every start.
fn transform_lines(
    data: &mut [Complex],
    starts: impl Iterator<Item = usize>,
    stride: usize,
    len: usize,
    inverse: bool,
) {
    let mut line = vec![Complex::default(); len];
    for start in starts {
        for (k, v) in line.iter_mut().enumerate() {
            *v = data[start + k * stride];
        }
        fft_1d(&mut line, inverse);
        for (k, v) in line.iter().enumerate() {
            data[start + k * stride] = *v;
        }
    }
}

/// In-place 3D FFT of an x-fastest `dims` array (each a power of two); the inverse is
/// normalized by `1 / (nx ny nz)`.
pub fn fft_3d(data: &mut [Complex], dims: [usize; 3], inverse: bool) {
    let [nx, ny, nz] = dims;
    for row in data.chunks_mut(nx) {
        fft_1d(row, inverse);
    }
    // Along y: lines start at x + nx·ny·z with stride nx; along z: at x + nx·y, stride nx·ny.
    transform_lines(
        data,
        (0..nz).flat_map(|z| (0..nx).map(move |x| x + nx * ny * z)),
        nx,
        ny,
        inverse,
    );
    transform_lines(
        data,
        (0..ny).flat_map(|y| (0..nx).map(move |x| x + nx * y)),
        nx * ny,
        nz,
        inverse,
    );
    if inverse {
        let scale = 1.0 / (nx * ny * nz) as f64;
        for v in data.iter_mut() {
            v.re *= scale;
            v.im *= scale;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_matches_a_direct_dft() {
        let n = 16;
        let input: Vec<Complex> = (0..n)
            .map(|i| Complex {
                re: (i as f64 * 0.7).sin(),
                im: (i as f64 * 0.3).cos(),
            })
            .collect();
        let mut f = input.clone();
        fft_1d(&mut f, false);
        for (k, v) in f.iter().enumerate() {
            let mut acc = Complex::default();
            for (t, x) in input.iter().enumerate() {
                let a = -2.0 * PI * (k * t) as f64 / n as f64;
                acc.re += x.re * a.cos() - x.im * a.sin();
                acc.im += x.re * a.sin() + x.im * a.cos();
            }
            assert!((acc.re - v.re).abs() < 1e-9 && (acc.im - v.im).abs() < 1e-9);
        }
        let dims = [4, 8, 2];
        let data: Vec<Complex> = (0..64)
            .map(|i| Complex {
                re: i as f64,
                im: -(i as f64) / 3.0,
            })
            .collect();
        let mut d = data.clone();
        fft_3d(&mut d, dims, false);
        fft_3d(&mut d, dims, true);
        for (a, b) in d.iter().zip(&data) {
            assert!((a.re - b.re).abs() < 1e-9 && (a.im - b.im).abs() < 1e-9);
        }
    }
}
