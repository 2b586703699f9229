//! Dense LU factorization with partial pivoting, blocked for large thin-plate systems.
//!
//! nalgebra's LU updates the trailing matrix with one rank-1 product per column: it reads
//! the whole trailing matrix once per column, on one thread. On the large systems of dense
//! exemplars (a 1024² height field gives about 1,450 pairs a warp) that solve was a third of
//! the run's CPU time, all of it single-threaded (docs/performance.md).
//!
//! Here the columns are factored in panels of [`PANEL_WIDTH`]. Each panel is factored
//! column by column (partial pivoting, rows swapped across the whole matrix, as LAPACK's
//! `getrf` does). The rest of the matrix is then brought up to date in one pass: the
//! panel's rows of the trailing columns are solved against the panel's unit lower triangle
//! (`U₁₂ = L₁₁⁻¹ A₁₂`), and the rows below take one matrix product,
//! `A₂₂ ← A₂₂ − L₂₁ U₁₂`, through nalgebra's `gemm` (matrixmultiply's cache-blocked kernel).
//! That pass runs over fixed chunks of [`CHUNK_COLUMNS`] columns in parallel. Each column's
//! arithmetic does not depend on the chunk it falls in or on which thread runs it, so the
//! result is the same with any number of threads.
//!
//! The result is not bit-identical to nalgebra's LU: the trailing sums are accumulated in a
//! different order. [`super::ThinPlateSpline::fit`] therefore uses this solver only from
//! [`BLOCKED_LU_MIN_SIZE`] unknowns up, where it is several times faster; smaller systems,
//! which every fixture's warps are, keep nalgebra's LU and their recorded outputs.

use nalgebra::{DMatrix, DMatrixViewMut};
use rayon::prelude::*;

/// Systems with at least this many unknowns are solved by [`solve`]; smaller ones by
/// nalgebra's LU.
pub(crate) const BLOCKED_LU_MIN_SIZE: usize = 512;

/// Columns factored together: the inner dimension of each trailing matrix product.
const PANEL_WIDTH: usize = 64;

/// Trailing columns updated by one parallel task. Fixed, so the split does not depend on the
/// thread count.
const CHUNK_COLUMNS: usize = 64;

/// Solves `m x = rhs` for a square `m`, by LU with partial pivoting. `None` when a pivot is
/// exactly zero (the matrix is singular to working precision in the same sense as
/// nalgebra's `LU::solve`). The caller checks the solution for non-finite values.
pub(crate) fn solve(mut m: DMatrix<f64>, mut rhs: DMatrix<f64>) -> Option<DMatrix<f64>> {
    let pivots = factor(&mut m)?;
    for (row, &pivot) in pivots.iter().enumerate() {
        if pivot != row {
            rhs.swap_rows(row, pivot);
        }
    }
    // Every pivot is non-zero, so neither triangular solve can refuse.
    (m.solve_lower_triangular_with_diag_mut(&mut rhs, 1.0)
        && m.solve_upper_triangular_mut(&mut rhs))
    .then_some(rhs)
}

/// Factors `m` in place into `P m = L U` (`L` unit lower, below the diagonal; `U` on and
/// above it). Returns the row swapped with row `j` at step `j`, or `None` on a zero pivot.
fn factor(m: &mut DMatrix<f64>) -> Option<Vec<usize>> {
    let n = m.nrows();
    let mut pivots = Vec::with_capacity(n);
    let mut start = 0;
    while start < n {
        let width = PANEL_WIDTH.min(n - start);
        factor_panel(m, start, width, &mut pivots)?;
        update_trailing(m, start, width);
        start += width;
    }
    Some(pivots)
}

/// Unblocked LU of columns `start..start + width`, rows `start..n`, with partial pivoting.
/// Row swaps are applied to every column, so the columns left of the panel (already `L`)
/// and right of it (still to be updated) stay consistent.
fn factor_panel(
    m: &mut DMatrix<f64>,
    start: usize,
    width: usize,
    pivots: &mut Vec<usize>,
) -> Option<()> {
    let n = m.nrows();
    let end = start + width;
    for j in start..end {
        let column = m.column(j);
        let mut pivot = j;
        let mut largest = column[j].abs();
        for i in j + 1..n {
            if column[i].abs() > largest {
                largest = column[i].abs();
                pivot = i;
            }
        }
        if largest == 0.0 {
            return None;
        }
        pivots.push(pivot);
        if pivot != j {
            m.swap_rows(j, pivot);
        }
        let data = m.as_mut_slice();
        let diagonal = data[j * n + j];
        for value in &mut data[j * n + j + 1..(j + 1) * n] {
            *value /= diagonal;
        }
        // Rank-1 update of the panel's remaining columns.
        let (left, right) = data.split_at_mut((j + 1) * n);
        let multipliers = &left[j * n + j + 1..(j + 1) * n];
        for column in right.chunks_exact_mut(n).take(end - j - 1) {
            let u = column[j];
            if u != 0.0 {
                for (value, l) in column[j + 1..].iter_mut().zip(multipliers) {
                    *value -= l * u;
                }
            }
        }
    }
    Some(())
}

/// Brings the columns right of the panel `start..start + width` up to date: their panel
/// rows become `U₁₂ = L₁₁⁻¹ A₁₂`, their rows below take `A₂₂ − L₂₁ U₁₂`.
fn update_trailing(m: &mut DMatrix<f64>, start: usize, width: usize) {
    let n = m.nrows();
    let end = start + width;
    if end >= n {
        return;
    }
    let l11 = m.view((start, start), (width, width)).clone_owned();
    let l21 = m.view((end, start), (n - end, width)).clone_owned();
    let trailing = &mut m.as_mut_slice()[end * n..];
    trailing
        .par_chunks_mut(CHUNK_COLUMNS * n)
        .for_each(|chunk| {
            let columns = chunk.len() / n;
            let mut u12 = DMatrix::from_fn(width, columns, |r, c| chunk[c * n + start + r]);
            // `L₁₁` has a unit diagonal, so the solve cannot refuse.
            l11.solve_lower_triangular_with_diag_mut(&mut u12, 1.0);
            for (column, solved) in chunk.chunks_exact_mut(n).zip(u12.column_iter()) {
                column[start..end].copy_from_slice(solved.as_slice());
            }
            let mut a22 = DMatrixViewMut::from_slice_with_strides_mut(
                &mut chunk[end..],
                n - end,
                columns,
                1,
                n,
            );
            a22.gemm(-1.0, &l21, &u12, 1.0);
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use pointset_core::rng;
    use rand::RngExt;

    fn random_system(n: usize, seed: u64) -> (DMatrix<f64>, DMatrix<f64>) {
        let mut g = rng::rng_from_seed(seed);
        let m = DMatrix::from_fn(n, n, |_, _| g.random::<f64>() - 0.5);
        let rhs = DMatrix::from_fn(n, 3, |_, _| g.random::<f64>() - 0.5);
        (m, rhs)
    }

    /// Residual `‖m x − rhs‖∞ / (‖m‖∞ ‖x‖∞)`: backward-stable solvers keep it near the
    /// machine epsilon times a modest factor of `n`.
    fn relative_residual(m: &DMatrix<f64>, x: &DMatrix<f64>, rhs: &DMatrix<f64>) -> f64 {
        let r = m * x - rhs;
        r.amax() / (m.amax() * m.nrows() as f64 * x.amax())
    }

    #[test]
    fn agrees_with_nalgebra_across_panel_boundaries() {
        for n in [1, 2, 7, 63, 64, 65, 128, 129, 200, 300] {
            let (m, rhs) = random_system(n, n as u64);
            let ours = solve(m.clone(), rhs.clone());
            let reference = m.clone().lu().solve(&rhs);
            let (Some(ours), Some(reference)) = (ours, reference) else {
                unreachable!("random matrices of size {n} are regular");
            };
            assert!(relative_residual(&m, &ours, &rhs) < 1e-14, "n = {n}");
            let difference = (&ours - &reference).amax() / reference.amax();
            assert!(
                difference < 1e-8,
                "n = {n}: solutions differ by {difference}"
            );
        }
    }

    #[test]
    fn pivots_past_a_zero_diagonal() {
        // Zeros on the whole diagonal: no step can go without a row swap.
        let n = 150;
        let (mut m, rhs) = random_system(n, 7);
        m.fill_diagonal(0.0);
        let Some(x) = solve(m.clone(), rhs.clone()) else {
            unreachable!("a random matrix with a zero diagonal is still regular");
        };
        assert!(relative_residual(&m, &x, &rhs) < 1e-14);
    }

    #[test]
    fn singular_matrix_is_refused() {
        // A zero column stays zero through every update before its own step, where the
        // pivot search then finds nothing: in the first panel and in a later one.
        for column in [40, 100] {
            let (mut m, rhs) = random_system(130, 3);
            m.column_mut(column).fill(0.0);
            assert!(solve(m, rhs).is_none(), "zero column {column}");
        }
        assert!(solve(DMatrix::zeros(1, 1), DMatrix::zeros(1, 3)).is_none());
    }

    #[test]
    fn same_result_with_one_and_two_threads() {
        let (m, rhs) = random_system(331, 11);
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map(|pool| pool.install(|| solve(m.clone(), rhs.clone())))
        };
        let (Ok(Some(one)), Ok(Some(two))) = (run(1), run(2)) else {
            unreachable!("thread pools build and the system is regular");
        };
        assert_eq!(one.as_slice(), two.as_slice());
    }
}
