//! Holes in a grid of heights filled with the smooth (harmonic) surface the heights
//! around them bound, the way height maps are commonly inpainted: a quilt's height map over
//! gaps in its top sheet, and a DEM's voids (`geosynth quilt --heightfield --fill-voids`).
//!
//! Every missing value becomes the mean of its grid neighbours (4-neighbour, those on the
//! grid), the known values fixed: the discrete Laplace equation. Across a gap, that is the
//! ramp from one side's heights to the other's. The equations are solved by conjugate
//! gradients (Jacobi-preconditioned, in `f64`) from the nearest known values, to a
//! residual of a billionth of the known heights' range. Gauss–Seidel
//! sweeps, which the map's fill used before, settle a hole `n` samples across in about
//! `n²` sweeps, too slow for a DEM's voids hundreds of samples wide; conjugate gradients
//! need about `n` steps.

use std::collections::VecDeque;

/// Most conjugate-gradient steps: ample for holes thousands of samples across.
const MAX_STEPS: usize = 20_000;

/// The residual, relative to the known heights' range, at which the fill stops.
const SETTLED: f64 = 1e-9;

/// The grid `known` (row-major, `width` wide) with its missing values filled with the
/// harmonic interpolant of the known ones; `None` when no value is known.
///
/// ```
/// use geosynth::imagery::fill_harmonic;
///
/// // A 5 × 1 strip: the gap between 1 and 3 is filled with the ramp between them.
/// let filled = fill_harmonic(&[Some(1.0), None, None, None, Some(3.0)], 5).ok_or("empty")?;
/// assert!(filled.iter().zip([1.0, 1.5, 2.0, 2.5, 3.0]).all(|(a, b)| (a - b).abs() < 1e-6));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fill_harmonic(known: &[Option<f32>], width: usize) -> Option<Vec<f32>> {
    let start = fill_from_nearest(known, width)?;
    let rows = known.len() / width.max(1);
    let holes: Vec<usize> = (0..known.len()).filter(|&k| known[k].is_none()).collect();
    if holes.is_empty() {
        return Some(start);
    }
    // Each hole's unknown, and the equations `d·x_j − Σ x_(hole neighbours) = Σ known
    // neighbours` over them, `d` the number of its neighbours on the grid.
    let mut unknown = vec![usize::MAX; known.len()];
    for (j, &k) in holes.iter().enumerate() {
        unknown[k] = j;
    }
    let degree: Vec<f64> = holes
        .iter()
        .map(|&k| grid_neighbours(k, width, rows).count() as f64)
        .collect();
    let apply = |x: &[f64], out: &mut [f64]| {
        for (j, &k) in holes.iter().enumerate() {
            let coupled: f64 = grid_neighbours(k, width, rows)
                .filter_map(|m| x.get(unknown[m]))
                .sum();
            out[j] = degree[j] * x[j] - coupled;
        }
    };
    let b: Vec<f64> = holes
        .iter()
        .map(|&k| {
            grid_neighbours(k, width, rows)
                .filter_map(|m| known[m])
                .map(f64::from)
                .sum()
        })
        .collect();
    let (lo, hi) = known
        .iter()
        .flatten()
        .fold((f64::MAX, f64::MIN), |(lo, hi), &h| {
            (lo.min(f64::from(h)), hi.max(f64::from(h)))
        });
    let tolerance = SETTLED * (hi - lo).max(f64::MIN_POSITIVE);
    let mut x: Vec<f64> = holes.iter().map(|&k| f64::from(start[k])).collect();
    let mut ax = vec![0.0; holes.len()];
    apply(&x, &mut ax);
    let mut r: Vec<f64> = b.iter().zip(&ax).map(|(b, a)| b - a).collect();
    let mut z: Vec<f64> = r.iter().zip(&degree).map(|(r, d)| r / d).collect();
    let mut p = z.clone();
    let mut rz: f64 = r.iter().zip(&z).map(|(r, z)| r * z).sum();
    let mut ap = vec![0.0; holes.len()];
    for _ in 0..MAX_STEPS {
        if r.iter().all(|r| r.abs() <= tolerance) {
            break;
        }
        apply(&p, &mut ap);
        let pap: f64 = p.iter().zip(&ap).map(|(p, a)| p * a).sum();
        if pap <= 0.0 {
            break;
        }
        let alpha = rz / pap;
        for j in 0..holes.len() {
            x[j] += alpha * p[j];
            r[j] -= alpha * ap[j];
            z[j] = r[j] / degree[j];
        }
        let next: f64 = r.iter().zip(&z).map(|(r, z)| r * z).sum();
        let beta = next / rz;
        rz = next;
        for (p, z) in p.iter_mut().zip(&z) {
            *p = z + beta * *p;
        }
    }
    let mut filled = start;
    for (j, &k) in holes.iter().enumerate() {
        filled[k] = x[j] as f32;
    }
    Some(filled)
}

/// The grid `known` (row-major, `width` wide) with each missing value taken from the
/// nearest known one in grid steps (4-neighbour breadth-first order, ties to the one
/// reached first); `None` when no value is known.
fn fill_from_nearest(known: &[Option<f32>], width: usize) -> Option<Vec<f32>> {
    let mut queue: VecDeque<usize> = (0..known.len()).filter(|&k| known[k].is_some()).collect();
    if queue.is_empty() || width == 0 {
        return None;
    }
    let rows = known.len() / width;
    let mut heights = known.to_vec();
    while let Some(k) = queue.pop_front() {
        let value = heights[k];
        for m in grid_neighbours(k, width, rows) {
            if heights[m].is_none() {
                heights[m] = value;
                queue.push_back(m);
            }
        }
    }
    heights.into_iter().collect()
}

/// The 4 neighbours of sample `k` of a row-major `width × rows` grid that lie on it.
fn grid_neighbours(k: usize, width: usize, rows: usize) -> impl Iterator<Item = usize> {
    let (c, r) = (k % width, k / width);
    [
        (c > 0).then(|| k - 1),
        (c + 1 < width).then(|| k + 1),
        (r > 0).then(|| k - width),
        (r + 1 < rows).then(|| k + width),
    ]
    .into_iter()
    .flatten()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn missing_heights_start_from_the_nearest_known_sample() {
        let known = [Some(1.0), None, None, None, None, None, None, Some(5.0)];
        let nearest = fill_from_nearest(&known, 4).unwrap();
        assert_eq!(nearest, vec![1.0, 1.0, 1.0, 5.0, 1.0, 1.0, 5.0, 5.0]);
        assert!(fill_from_nearest(&[None; 6], 3).is_none());
        assert!(fill_harmonic(&[None; 6], 3).is_none());
    }

    #[test]
    fn a_hole_in_a_ramp_is_filled_with_the_ramp() {
        let ramp = |k: usize| 0.5 * (k % 30) as f32 - 0.2 * (k / 30) as f32;
        let in_hole = |k: usize| {
            let (c, r) = ((k % 30) as i32, (k / 30) as i32);
            (c - 12).abs() <= 4 && (r - 9).abs() <= 6
        };
        let known: Vec<Option<f32>> = (0..600).map(|k| (!in_hole(k)).then(|| ramp(k))).collect();
        let nearest = fill_from_nearest(&known, 30).unwrap();
        let filled = fill_harmonic(&known, 30).unwrap();
        let worst = |heights: &[f32]| {
            (0..600)
                .map(|k| (heights[k] - ramp(k)).abs())
                .fold(0.0, f32::max)
        };
        // A linear ramp is harmonic: the fill finds it; the nearest value is off by up to
        // half the hole's width times the slope.
        assert!(worst(&filled) < 1e-4, "{}", worst(&filled));
        assert!(worst(&nearest) > 1.0, "{}", worst(&nearest));
    }

    #[test]
    fn a_wide_void_settles_to_the_mean_of_its_neighbours() {
        // A 200 × 150 void in a 250 × 200 grid of the saddle x² − y² (harmonic, so the
        // exact fill): found across 200 samples, where 500 Gauss–Seidel sweeps from the
        // nearest values would have moved its middle by little; and every filled value is
        // the mean of its neighbours.
        let (w, h) = (250usize, 200usize);
        let saddle = |k: usize| {
            let (x, y) = ((k % w) as f64 / 50.0 - 2.5, (k / w) as f64 / 50.0 - 2.0);
            (x * x - y * y) as f32
        };
        let in_void = |k: usize| (25..225).contains(&(k % w)) && (25..175).contains(&(k / w));
        let known: Vec<Option<f32>> = (0..w * h)
            .map(|k| (!in_void(k)).then(|| saddle(k)))
            .collect();
        let filled = fill_harmonic(&known, w).unwrap();
        let worst = (0..w * h)
            .map(|k| (filled[k] - saddle(k)).abs())
            .fold(0.0, f32::max);
        assert!(worst < 1e-4, "{worst}");
        for k in (0..w * h).filter(|&k| in_void(k)) {
            let around: Vec<f32> = grid_neighbours(k, w, h).map(|m| filled[m]).collect();
            let mean = around.iter().sum::<f32>() / around.len() as f32;
            assert!(
                (filled[k] - mean).abs() < 1e-5,
                "{k}: {} vs {mean}",
                filled[k]
            );
        }
    }
}
