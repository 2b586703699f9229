//! Evaluation at many points at once.
//!
//! [`ThinPlateSpline::eval_many`] and [`ThinPlateSpline::jacobians`] do, for every point,
//! exactly the arithmetic of [`ThinPlateSpline::eval`] and [`ThinPlateSpline::jacobian`]:
//! the same operations on the same values in the same order, so their results are equal
//! bit for bit. What differs is the loop order. Points are taken 2 or 4 at a time, with
//! their coordinates in one array per axis. The loop over the centres runs outside, and
//! the inner loop over the lanes holds no dependence between lanes, so the compiler can
//! keep the lanes in vector registers (square roots and divisions included). Each lane
//! still adds its terms center by center in the order of [`ThinPlateSpline::centers`],
//! so nothing is reassociated.

use glam::{DMat3, DVec3, Vec3};
use rayon::prelude::*;

use super::ThinPlateSpline;

/// Points evaluated together in one pass over the centres by [`ThinPlateSpline::eval_many`]:
/// its 3 sums per lane fit in vector registers at 4 lanes.
const EVAL_LANES: usize = 4;

/// Points per pass of [`ThinPlateSpline::jacobians`]: its 9 sums per lane stay in vector
/// registers at 2 lanes and spill at 4 (the 100k-point bench took 59 ms at 2, 71 ms at 4).
const JACOBIAN_LANES: usize = 2;

/// Points per parallel task: enough to amortize scheduling, few enough to balance two
/// to a few dozen threads on a patch of some thousand points.
const POINTS_PER_TASK: usize = 256;

/// Up to `N` points in double precision, one array per axis. Lanes past the given points
/// repeat the last point; their results are computed and dropped.
struct LaneBlock<const N: usize> {
    x: [f64; N],
    y: [f64; N],
    z: [f64; N],
}

impl<const N: usize> LaneBlock<N> {
    /// The block of `points` (1 to `N` of them; an empty slice gives the origin).
    fn gather(points: &[Vec3]) -> Self {
        let last = points.last().copied().unwrap_or(Vec3::ZERO);
        let at = |l: usize| points.get(l).copied().unwrap_or(last).as_dvec3();
        Self {
            x: std::array::from_fn(|l| at(l).x),
            y: std::array::from_fn(|l| at(l).y),
            z: std::array::from_fn(|l| at(l).z),
        }
    }

    fn point(&self, lane: usize) -> DVec3 {
        DVec3::new(self.x[lane], self.y[lane], self.z[lane])
    }

    /// `x − c` per lane, one array per axis. Always inlined: called out of line (as the
    /// compiler chose), its result went through memory once per center and point block,
    /// a quarter of a dense warp's time in `perf`.
    #[inline(always)]
    fn offsets_from(&self, c: DVec3) -> [[f64; N]; 3] {
        [
            self.x.map(|x| x - c.x),
            self.y.map(|y| y - c.y),
            self.z.map(|z| z - c.z),
        ]
    }
}

/// `|d|` per lane, summed as `DVec3::length` does: `(x² + y²) + z²`, then the root.
#[inline(always)]
fn lengths<const N: usize>(d: &[[f64; N]; 3]) -> [f64; N] {
    std::array::from_fn(|l| (d[0][l] * d[0][l] + d[1][l] * d[1][l] + d[2][l] * d[2][l]).sqrt())
}

/// Applies `per_block` to `points` `N` at a time, in parallel, and writes the first
/// `block.len()` results of each block in order.
fn map_blocks<const N: usize, T, F>(points: &[Vec3], per_block: F) -> Vec<T>
where
    T: Copy + Default + Send,
    F: Fn(&LaneBlock<N>) -> [T; N] + Sync,
{
    let mut out = vec![T::default(); points.len()];
    out.par_chunks_mut(POINTS_PER_TASK)
        .zip(points.par_chunks(POINTS_PER_TASK))
        .for_each(|(out, points)| {
            for (out, block) in out.chunks_mut(N).zip(points.chunks(N)) {
                let values = per_block(&LaneBlock::gather(block));
                out.copy_from_slice(&values[..out.len()]);
            }
        });
    out
}

impl ThinPlateSpline {
    /// `W(x)` at every point, in parallel; equal bit for bit to [`Self::eval`] at each.
    ///
    /// ```
    /// use glam::Vec3;
    /// use tps_warp::{ThinPlateSpline, TpsParams};
    ///
    /// let s = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::splat(0.5)];
    /// let q = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::splat(0.6)];
    /// let w = ThinPlateSpline::fit(&s, &q, &TpsParams::default())?;
    /// let points = [Vec3::new(0.2, 0.3, 0.1), Vec3::splat(0.5), Vec3::ONE];
    /// let moved = w.eval_many(&points);
    /// for (p, m) in points.iter().zip(&moved) {
    ///     assert_eq!(w.eval(*p), *m);
    /// }
    /// Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn eval_many(&self, points: &[Vec3]) -> Vec<Vec3> {
        map_blocks::<EVAL_LANES, _, _>(points, |block| self.eval_block(block).map(DVec3::as_vec3))
    }

    /// The Jacobian at every point, in parallel; equal bit for bit to [`Self::jacobian`] at
    /// each.
    pub fn jacobians(&self, points: &[Vec3]) -> Vec<DMat3> {
        map_blocks::<JACOBIAN_LANES, _, _>(points, |block| self.jacobian_block(block))
    }

    /// The indices of the points where the warp folds space: its Jacobian's determinant is
    /// zero or negative there, so the neighbourhood is squashed flat or turned inside out
    /// (a mesh's triangles there flip, and two parts of a surface may cross). Pairs whose
    /// targets swap the order of their sources do that; smoothing (`λ > 0`) or fewer pairs
    /// undo it. In parallel, in order.
    ///
    /// ```
    /// use glam::Vec3;
    /// use tps_warp::{ThinPlateSpline, TpsParams};
    ///
    /// // Sources along x at 0, 1, 2, 3 (on a cube's corners, so the fit is 3D); the middle
    /// // two swap places: between them x runs backwards.
    /// let mut s = Vec::new();
    /// let mut q = Vec::new();
    /// for (x, to) in [(0.0, 0.0), (1.0, 2.0), (2.0, 1.0), (3.0, 3.0)] {
    ///     for (y, z) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
    ///         s.push(Vec3::new(x, y, z));
    ///         q.push(Vec3::new(to, y, z));
    ///     }
    /// }
    /// let w = ThinPlateSpline::fit(&s, &q, &TpsParams::default())?;
    /// let probes = [Vec3::new(1.5, 0.5, 0.5), Vec3::new(-1.0, 0.5, 0.5)];
    /// assert_eq!(w.folded_points(&probes), [0]);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn folded_points(&self, points: &[Vec3]) -> Vec<usize> {
        self.jacobians(points)
            .iter()
            .enumerate()
            .filter(|(_, j)| j.determinant() <= 0.0)
            .map(|(i, _)| i)
            .collect()
    }

    /// [`Self::eval_f64`] for each lane of `block`.
    fn eval_block<const N: usize>(&self, block: &LaneBlock<N>) -> [DVec3; N] {
        let affine: [DVec3; N] =
            std::array::from_fn(|l| self.translation + self.linear * block.point(l));
        let mut sums = [
            affine.map(|a| a.x),
            affine.map(|a| a.y),
            affine.map(|a| a.z),
        ];
        for (c, w) in self.centers.iter().zip(&self.weights) {
            let r = lengths(&block.offsets_from(*c));
            for (sum, wi) in sums.iter_mut().zip(w.to_array()) {
                for l in 0..N {
                    sum[l] += wi * r[l];
                }
            }
        }
        std::array::from_fn(|l| DVec3::new(sums[0][l], sums[1][l], sums[2][l]))
    }

    /// [`Self::jacobian`] for each lane of `block`. `j[k][i][l]` is row `i` of column `k`
    /// at lane `l`. Where a lane sits on a center (`r = 0`) that center's term is skipped,
    /// as in the scalar loop: the sum is left as it was rather than given a zero, so even
    /// the sign of a zero entry is the scalar loop's.
    fn jacobian_block<const N: usize>(&self, block: &LaneBlock<N>) -> [DMat3; N] {
        let column = |k: usize| self.linear.col(k).to_array().map(|v| [v; N]);
        let mut j = [column(0), column(1), column(2)];
        for (c, w) in self.centers.iter().zip(&self.weights) {
            let d = block.offsets_from(*c);
            let r = lengths(&d);
            // Every lane takes the term unless it sits on the center; the common case,
            // all lanes apart, is tested once per center so that the sums vectorize.
            let all_apart = r.iter().all(|&r| r > 0.0);
            for (col, dk) in j.iter_mut().zip(&d) {
                let g: [f64; N] = std::array::from_fn(|l| dk[l] / r[l]);
                for (entry, wi) in col.iter_mut().zip(w.to_array()) {
                    if all_apart {
                        for l in 0..N {
                            entry[l] += wi * g[l];
                        }
                    } else {
                        for l in (0..N).filter(|&l| r[l] > 0.0) {
                            entry[l] += wi * g[l];
                        }
                    }
                }
            }
        }
        std::array::from_fn(|l| {
            let col = |k: usize| DVec3::new(j[k][0][l], j[k][1][l], j[k][2][l]);
            DMat3::from_cols(col(0), col(1), col(2))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::TpsParams;
    use pointset_core::rng;
    use rand::RngExt;

    fn random_points(g: &mut rng::SeededRng, n: usize) -> Vec<Vec3> {
        (0..n)
            .map(|_| Vec3::new(g.random(), g.random(), g.random::<f32>() * 0.3))
            .collect()
    }

    /// Every count from 0 to past two tasks, points on the centres included (the `r = 0`
    /// case): the batched results must equal the scalar ones bit for bit.
    #[test]
    fn batched_evaluation_equals_the_scalar_one_bit_for_bit() {
        let mut g = rng::rng_from_seed(7);
        let sources = random_points(&mut g, 40);
        let targets: Vec<Vec3> = sources
            .iter()
            .map(|s| *s + Vec3::new(g.random(), g.random(), g.random()) * 0.05)
            .collect();
        let Ok(spline) = ThinPlateSpline::fit(&sources, &targets, &TpsParams::default()) else {
            panic!("the test's control points are in general position");
        };
        for n in (0..=9).chain([POINTS_PER_TASK + 3, 2 * POINTS_PER_TASK + 1]) {
            let mut points = random_points(&mut g, n);
            for (p, s) in points.iter_mut().step_by(3).zip(&sources) {
                *p = *s;
            }
            let moved = spline.eval_many(&points);
            let jacobians = spline.jacobians(&points);
            assert_eq!(moved.len(), n);
            assert_eq!(jacobians.len(), n);
            for ((p, m), j) in points.iter().zip(&moved).zip(&jacobians) {
                assert_eq!(
                    spline.eval(*p).to_array().map(f32::to_bits),
                    m.to_array().map(f32::to_bits)
                );
                let scalar = spline.jacobian(*p).to_cols_array().map(f64::to_bits);
                assert_eq!(scalar, j.to_cols_array().map(f64::to_bits), "at {p}");
            }
        }
    }
}
