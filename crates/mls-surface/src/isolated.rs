//! Samples whose MLS surface would be their own: isolated samples.
//!
//! A query sees the samples within the kernel's support radius `r = support · h`. Two
//! samples more than `2r` apart are never seen by the same query, so a sample with no
//! other within `2r` has a surface of its own: where the kernel reaches only it (fewer
//! than [`MlsParams::min_neighbours`] samples) a distance field falls back to that sample
//! and its plane, and the sign changes across the plane around it, so the field's zero set
//! closes into a bubble about a kernel wide. A stray point inside a hollow scan does that:
//! two points inside the shared bunny scan (8.7 and 13.0 from its nearest samples, whose
//! median spacing is 0.92 and support radius 2.9) gave two bubbles inside its surface.
//!
//! [`isolated_samples`] lists the samples with fewer than `min_neighbours` samples
//! (themselves included) within `2r`: such samples, and clumps of up to
//! `min_neighbours − 1` of them, far from the rest. With the defaults `2r` is 6.25 median
//! spacings; on a surface sampled at random (Poisson), fewer than 4 samples within that
//! happens with probability about 10⁻⁹, and the largest nearest-neighbour distance in the
//! shared bunny scan is 3.05 median spacings. The eight bundled point-set fixtures and the
//! shared bunny and chameleon scans have no isolated sample (the facade's tests).

use glam::{DVec3, Vec3};
use pointset_core::KdIndex;
use pointset_core::spatial::PackedCells;
use rayon::prelude::*;

use crate::error::Result;
use crate::params::MlsParams;

/// How far from every other sample an isolated sample lies, in support radii (module
/// docs): beyond that, no query's kernel sees it together with another.
pub const ISOLATION_REACH: f32 = 2.0;

/// The indices (ascending) of the samples of `index` with fewer than
/// `params.min_neighbours` samples, themselves included, within [`ISOLATION_REACH`]
/// support radii (`params.support` × the kernel [`MlsParams::kernel_for`] gives over
/// `index`): samples whose MLS surface would be a bubble of their own (module docs). Fewer
/// samples than `params.min_neighbours` in all are all isolated, whatever the kernel.
/// Parallel over the samples; the result does not depend on the thread count.
///
/// Errors: those of [`MlsParams::validate`] and [`MlsParams::kernel_for`] (an estimated
/// kernel of 0, when the samples all coincide).
///
/// ```
/// use glam::Vec3;
/// use mls_surface::{MlsParams, isolated_samples};
/// use pointset_core::KdIndex;
///
/// // A 30 × 30 grid of the plane z = 0, spacing 0.1, and one point 1.0 above it.
/// let mut p: Vec<Vec3> = (0..900).map(|i| Vec3::new((i % 30) as f32, (i / 30) as f32, 0.0) * 0.1).collect();
/// p.push(Vec3::new(1.5, 1.5, 1.0));
/// let isolated = isolated_samples(&KdIndex::new(&p)?, &MlsParams::default())?;
/// assert_eq!(isolated, vec![900]);
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn isolated_samples(index: &KdIndex, params: &MlsParams) -> Result<Vec<usize>> {
    params.validate()?;
    let wanted = params.min_neighbours;
    if index.len() < wanted {
        return Ok((0..index.len()).collect());
    }
    let reach = ISOLATION_REACH * params.support * params.kernel_for(index)?;
    let points = index.points();
    let settled = settled_by_cells(points, f64::from(reach), wanted);
    let flags = points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            if settled.as_ref().is_some_and(|s| s[i]) {
                return Ok(false);
            }
            Ok(index.nearest_within(*p, wanted, reach)?.len() < wanted)
        })
        .collect::<Result<Vec<bool>>>()?;
    Ok(flags
        .iter()
        .enumerate()
        .filter_map(|(i, &alone)| alone.then_some(i))
        .collect())
}

/// For each of `points`, whether a grid proves it has `wanted` samples (itself included)
/// within `reach`: a cell of side `reach/√6` and a cell sharing a face with it fit in a
/// box whose diagonal is `reach`, so the samples of a point's cell and of its six
/// face neighbours all lie within `reach` of it. On a surface sampled at random the seven
/// cells hold about ten samples, so nearly every sample is settled by its cells instead of
/// a search of the index. The cells are a millionth smaller than that, so that rounding
/// cannot put two samples farther apart than `reach` in neighbouring cells. `None` when
/// the points span more cells than a packed key holds, or are more than `u32` numbers
/// (then every sample is searched).
///
/// The samples are sorted by cell key, which gives each occupied cell's count as a run,
/// and the counts of a cell's neighbours (the key one step along an axis) are found by
/// walking the sorted cells beside a cursor per direction: sequential reads, where a hash
/// map of the cells made a random memory access per lookup (16 million samples: 3.7 s
/// with the map, 1.4 s sorted; the same flags).
fn settled_by_cells(points: &[Vec3], reach: f64, wanted: usize) -> Option<Vec<bool>> {
    let low = points
        .iter()
        .fold(DVec3::splat(f64::INFINITY), |m, p| m.min(p.as_dvec3()));
    let cells = PackedCells::new(low, (1.0 - 1e-6) * reach / 6f64.sqrt());
    // Each sample's cell key beside its number (16 bytes a sample), sorted by cell.
    let mut by_cell = points
        .par_iter()
        .enumerate()
        .map(|(i, p)| Some((cells.key(*p)?, u32::try_from(i).ok()?)))
        .collect::<Option<Vec<(u64, u32)>>>()?;
    by_cell.par_sort_unstable();
    let (keys, counts) = occupied_cells(&by_cell);
    let starts: Vec<usize> = (0..keys.len()).step_by(CELL_CHUNK).collect();
    let settled: Vec<bool> = starts
        .into_par_iter()
        .flat_map_iter(|start| {
            let end = (start + CELL_CHUNK).min(keys.len());
            settled_cells(&cells, &keys, &counts, start..end, wanted)
        })
        .collect();
    let mut flags = vec![false; points.len()];
    let mut runs = by_cell.iter();
    for (&count, &cell_settled) in counts.iter().zip(&settled) {
        for &(_, i) in runs.by_ref().take(count as usize) {
            flags[i as usize] = cell_settled;
        }
    }
    Some(flags)
}

/// Cells the sorted walk of [`settled_by_cells`] takes at a time on one thread.
const CELL_CHUNK: usize = 1 << 14;

/// Whether each of the occupied cells `range` (of `keys`, sorted, holding `counts`
/// samples) and its six face neighbours hold `wanted` samples: the neighbours one step
/// along an axis come in key order, as the cells do, so a cursor per direction walks
/// forward from where the range's first neighbour would be.
fn settled_cells(
    cells: &PackedCells,
    keys: &[u64],
    counts: &[u32],
    range: std::ops::Range<usize>,
    wanted: usize,
) -> Vec<bool> {
    let mut cursors: [Option<usize>; 6] = [None; 6];
    range
        .map(|c| {
            let around = cells.face_neighbours(keys[c]).into_iter().zip(&mut cursors);
            let total = around.fold(counts[c] as usize, |total, (neighbour, cursor)| {
                let Some(neighbour) = neighbour else {
                    return total;
                };
                let at = cursor.get_or_insert_with(|| keys.partition_point(|&k| k < neighbour));
                while keys.get(*at).is_some_and(|&k| k < neighbour) {
                    *at += 1;
                }
                let held = keys.get(*at).zip(counts.get(*at));
                let held = held.filter(|&(&k, _)| k == neighbour);
                total + held.map_or(0, |(_, &n)| n as usize)
            });
            total >= wanted
        })
        .collect()
}

/// The distinct keys of `by_cell` (sorted by key) and how many samples each holds.
fn occupied_cells(by_cell: &[(u64, u32)]) -> (Vec<u64>, Vec<u32>) {
    let (mut keys, mut counts) = (Vec::<u64>::new(), Vec::<u32>::new());
    for &(key, _) in by_cell {
        match (keys.last(), counts.last_mut()) {
            (Some(&last), Some(count)) if last == key => *count += 1,
            _ => {
                keys.push(key);
                counts.push(1);
            }
        }
    }
    (keys, counts)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use glam::Vec3;
    use pointset_core::rng::rng_from_seed;
    use pointset_core::testdata::random_direction;
    use rand::RngExt;

    /// `n` random directions (points on the unit sphere).
    fn sphere(n: usize, seed: u64) -> Vec<Vec3> {
        let mut g = rng_from_seed(seed);
        (0..n).map(|_| random_direction(&mut g)).collect()
    }

    #[test]
    fn points_inside_a_sphere_are_isolated_and_the_sphere_is_not() {
        for seed in 0..8 {
            let mut points = sphere(3000, seed);
            assert!(
                isolated_samples(&KdIndex::new(&points).unwrap(), &MlsParams::default())
                    .unwrap()
                    .is_empty()
            );
            // One point at the centre, and a clump of three.
            points.push(Vec3::ZERO);
            points.extend([0.0, 0.01, 0.02].map(|d| Vec3::new(0.3 + d, -0.2, 0.1)));
            let index = KdIndex::new(&points).unwrap();
            assert_eq!(
                isolated_samples(&index, &MlsParams::default()).unwrap(),
                vec![3000, 3001, 3002, 3003]
            );
            // A point so far away that the grid would need too many cells: every sample is
            // searched, with the same answer.
            let mut far = points.clone();
            far.push(Vec3::new(1.0e7, 0.0, 0.0));
            let far_index = KdIndex::new(&far).unwrap();
            let reach =
                ISOLATION_REACH * 2.5 * MlsParams::default().kernel_for(&far_index).unwrap();
            assert!(settled_by_cells(&far, f64::from(reach), 4).is_none());
            assert_eq!(
                isolated_samples(&far_index, &MlsParams::default()).unwrap(),
                vec![3000, 3001, 3002, 3003, 3004]
            );
            // A kernel that reaches from them to the sphere takes them in.
            let wide = MlsParams::default().kernel(0.3);
            assert!(isolated_samples(&index, &wide).unwrap().is_empty());
        }
    }

    #[test]
    fn too_few_samples_are_all_isolated_and_bad_parameters_are_errors() {
        let points = sphere(10, 1);
        let empty = KdIndex::new(&[]).unwrap();
        assert!(
            isolated_samples(&empty, &MlsParams::default())
                .unwrap()
                .is_empty()
        );
        let three = KdIndex::new(&points[..3]).unwrap();
        assert_eq!(
            isolated_samples(&three, &MlsParams::default()).unwrap(),
            vec![0, 1, 2]
        );
        let bad = MlsParams {
            min_neighbours: 0,
            ..MlsParams::default()
        };
        assert!(isolated_samples(&KdIndex::new(&points).unwrap(), &bad).is_err());
        // Four copies of one point have no spacing to estimate a kernel from.
        let same = KdIndex::new(&[Vec3::ONE; 4]).unwrap();
        assert!(isolated_samples(&same, &MlsParams::default()).is_err());
    }

    /// What [`settled_by_cells`] proves, counted naively: the samples whose own cell and
    /// six face neighbours hold `wanted` samples, each cell's count in a map.
    fn settled_by_counting(points: &[Vec3], reach: f64, wanted: usize) -> Vec<bool> {
        let low = points
            .iter()
            .fold(DVec3::splat(f64::INFINITY), |m, p| m.min(p.as_dvec3()));
        let cells = PackedCells::new(low, (1.0 - 1e-6) * reach / 6f64.sqrt());
        let keys: Vec<u64> = points.iter().map(|p| cells.key(*p).unwrap()).collect();
        let mut counts = std::collections::HashMap::<u64, usize>::new();
        for &k in &keys {
            *counts.entry(k).or_default() += 1;
        }
        let count = |k: u64| counts.get(&k).copied().unwrap_or(0);
        keys.iter()
            .map(|&k| {
                let around: usize = cells
                    .face_neighbours(k)
                    .into_iter()
                    .flatten()
                    .map(count)
                    .sum();
                count(k) + around >= wanted
            })
            .collect()
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// The sorted walk finds what counting every cell finds, and every sample it
        /// settles has `wanted` samples within the reach.
        #[test]
        fn cells_settle_what_counting_them_settles(seed in 0u64..1000, n in 1usize..3000, wanted in 1usize..12, spread in 0.5f32..20.0) {
            let mut g = rng_from_seed(seed);
            // Clumps and loners in a box `spread` wide: cells full, sparse and empty, and
            // neighbours along every axis.
            let points: Vec<Vec3> = (0..n)
                .map(|_| {
                    let p = Vec3::new(g.random(), g.random(), g.random()) * spread;
                    if g.random_bool(0.3) { p.round() } else { p }
                })
                .collect();
            let reach = 1.0;
            let settled = settled_by_cells(&points, reach, wanted).unwrap();
            proptest::prop_assert_eq!(&settled, &settled_by_counting(&points, reach, wanted));
            for (p, _) in points.iter().zip(&settled).filter(|(_, s)| **s) {
                let within = points.iter().filter(|q| f64::from(q.distance(*p)) <= reach).count();
                proptest::prop_assert!(within >= wanted);
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(32))]
        /// The indexed search agrees with counting every sample within the reach.
        #[test]
        fn agrees_with_counting_every_sample(seed in 0u64..1000, n in 4usize..400, clumps in 0usize..20) {
            let mut g = rng_from_seed(seed);
            let mut points = sphere(n, seed);
            // Clumps of one to five points scattered inside and around the sphere.
            for _ in 0..clumps {
                let centre = Vec3::new(
                    g.random_range(-2.0..2.0),
                    g.random_range(-2.0..2.0),
                    g.random_range(-2.0..2.0),
                );
                for _ in 0..g.random_range(1..6) {
                    points.push(centre + 0.01 * Vec3::new(g.random(), g.random(), g.random()));
                }
            }
            let index = KdIndex::new(&points).unwrap();
            let params = MlsParams::default();
            let reach = ISOLATION_REACH * params.support * params.kernel_for(&index).unwrap();
            let expected: Vec<usize> = (0..points.len())
                .filter(|&i| {
                    let within = points
                        .iter()
                        .filter(|q| q.distance_squared(points[i]) <= reach * reach)
                        .count();
                    within < params.min_neighbours
                })
                .collect();
            proptest::prop_assert_eq!(isolated_samples(&index, &params).unwrap(), expected);
        }
    }
}
