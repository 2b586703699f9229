//! What a reader does with a point set's isolated samples ([`super::isolated_samples`]):
//! leaves them out, unless the caller keeps them or they are most of the points.
//!
//! Whatever their share below that, leaving them out gives the better surface: each
//! would otherwise close into a bubble of its own, whether it is an outlier of a scan or
//! a sample of a part sampled more sparsely than the kernel reaches (a far wall, a thin
//! feature at the scanner's range), and a larger kernel reaches the latter. Scattered
//! outliers can be more than a few: 2% of the shared bunny scan's count, spread at random
//! through its box, leaves 217 isolated (the CLI's `reconstruct` gave 173 pieces while
//! they were kept above 1% of the points, as until the fiftieth session).
//!
//! Isolated samples that are more than [`SPARSE_SAMPLING_SHARE`] of the points are not
//! outliers, which are a minority by definition: the kernel is too small for the
//! sampling as a whole (an explicit kernel, or one estimated from points stored twice a
//! hair apart, whose median spacing is the hair). Leaving them out would leave too little
//! to describe the surface, so they are kept.

use pointset_core::{KdIndex, PointSet};

use crate::error::Result;
use crate::isolated::{ISOLATION_REACH, isolated_samples};
use crate::params::MlsParams;

/// Isolated samples that are more than this share of a point set are kept: the kernel is
/// too small for its sampling as a whole (module docs).
pub const SPARSE_SAMPLING_SHARE: f64 = 0.5;

/// What [`without_isolated`] did with a point set's isolated samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IsolatedFate {
    /// Left out of the points.
    LeftOut,
    /// Kept, because the caller asked for them.
    Kept,
    /// Kept, because they are more than [`SPARSE_SAMPLING_SHARE`] of the points: the
    /// kernel is too small for the sampling.
    SparseSampling,
}

/// A point set's isolated samples: how many, how far they lie from the rest, and what
/// was done with them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IsolatedPoints {
    /// How many samples are isolated.
    pub count: usize,
    /// Out of how many points.
    pub of: usize,
    /// The distance within which each has fewer than `min_neighbours − 1` other samples:
    /// [`ISOLATION_REACH`] support radii of the kernel the parameters give.
    pub reach: f32,
    /// What was done with them.
    pub fate: IsolatedFate,
}

/// The isolated samples of `index` for an MLS surface of `params` ([`isolated_samples`],
/// ascending) and what [`without_isolated`] does with them: kept when `keep` is true or
/// they are more than [`SPARSE_SAMPLING_SHARE`] of the samples, else left out. `None` when
/// there are none, and for fewer samples than `params.min_neighbours`, which no surface
/// can use whatever is left out (its own checks say so).
///
/// Errors: those of [`isolated_samples`].
pub fn isolated_points(
    index: &KdIndex,
    params: &MlsParams,
    keep: bool,
) -> Result<Option<(Vec<usize>, IsolatedPoints)>> {
    params.validate()?;
    if index.len() < params.min_neighbours {
        return Ok(None);
    }
    // The kernel estimated once, for the search and the reach reported.
    let params = params.clone().kernel(params.kernel_for(index)?);
    let isolated = isolated_samples(index, &params)?;
    if isolated.is_empty() {
        return Ok(None);
    }
    let fate = if keep {
        IsolatedFate::Kept
    } else if isolated.len() as f64 > SPARSE_SAMPLING_SHARE * index.len() as f64 {
        IsolatedFate::SparseSampling
    } else {
        IsolatedFate::LeftOut
    };
    let found = IsolatedPoints {
        count: isolated.len(),
        of: index.len(),
        reach: ISOLATION_REACH * params.support * params.kernel_for(index)?,
        fate,
    };
    Ok(Some((isolated, found)))
}

/// `points` without their isolated samples for an MLS surface of `params`
/// ([`isolated_points`] says which and when), and what was done with them (`None` when
/// there are none, and for fewer points than `params.min_neighbours`). Normals and the
/// order of the remaining points are kept.
///
/// Errors: those of [`isolated_samples`].
///
/// ```
/// use glam::Vec3;
/// use mls_surface::{IsolatedFate, MlsParams, without_isolated};
/// use pointset_core::PointSet;
///
/// // A 30 × 30 grid of the plane z = 0, spacing 0.1, and one point 1.0 above it.
/// let mut p: Vec<Vec3> = (0..900).map(|i| Vec3::new((i % 30) as f32, (i / 30) as f32, 0.0) * 0.1).collect();
/// p.push(Vec3::new(1.5, 1.5, 1.0));
/// let (plane, isolated) = without_isolated(PointSet::new(p)?, &MlsParams::default(), false)?;
/// assert_eq!(plane.len(), 900);
/// let isolated = isolated.ok_or("one is isolated")?;
/// assert_eq!((isolated.count, isolated.fate), (1, IsolatedFate::LeftOut));
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn without_isolated(
    points: PointSet,
    params: &MlsParams,
    keep: bool,
) -> Result<(PointSet, Option<IsolatedPoints>)> {
    without_isolated_indexed(points, params, keep).map(|(points, found, _)| (points, found))
}

/// [`without_isolated`], with an index of the positions of the points it returns: the one
/// the check searched, or one built anew where it left points out. Steps after the check
/// that search the points (estimating or orienting normals) need not build it again; on
/// millions of points that takes most of a second.
///
/// Errors: those of [`without_isolated`].
pub fn without_isolated_indexed(
    points: PointSet,
    params: &MlsParams,
    keep: bool,
) -> Result<(PointSet, Option<IsolatedPoints>, KdIndex)> {
    let index = KdIndex::new(points.positions())?;
    let Some((isolated, found)) = isolated_points(&index, params, keep)? else {
        return Ok((points, None, index));
    };
    if found.fate != IsolatedFate::LeftOut {
        return Ok((points, Some(found), index));
    }
    drop(index);
    let mut alone = isolated.iter().peekable();
    let others: Vec<usize> = (0..points.len())
        .filter(|i| alone.next_if_eq(&i).is_none())
        .collect();
    let kept = points.subset(&others)?;
    let index = KdIndex::new(kept.positions())?;
    Ok((kept, Some(found), index))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use glam::Vec3;

    /// A 40 × 40 grid of the plane z = 0 at spacing 0.1, with +Z normals.
    fn plane() -> Vec<Vec3> {
        (0..1600)
            .map(|i| Vec3::new((i % 40) as f32, (i / 40) as f32, 0.0) * 0.1)
            .collect()
    }

    fn with_normals(positions: Vec<Vec3>) -> PointSet {
        let n = positions.len();
        PointSet::new(positions)
            .unwrap()
            .with_normals(vec![Vec3::Z; n])
            .unwrap()
    }

    #[test]
    fn isolated_points_are_left_out_unless_kept_or_most_of_the_points() {
        let clean = with_normals(plane());
        let params = MlsParams::default();
        let (same, none) = without_isolated(clean.clone(), &params, false).unwrap();
        assert_eq!((same, none), (clean.clone(), None));
        // Three lone points above the plane, among its points in the file's order.
        let mut positions = plane();
        for (at, x) in [(5, 0.5), (700, 2.0), (1600, 3.5)] {
            positions.insert(at, Vec3::new(x, 2.0, 1.5));
        }
        let with_lone = with_normals(positions);
        let (left, isolated) = without_isolated(with_lone.clone(), &params, false).unwrap();
        assert_eq!(left, clean, "the plane's points, normals and order");
        let reach = ISOLATION_REACH * params.support * params.kernel_spacing_factor * 0.1;
        let isolated = isolated.unwrap();
        assert_eq!(
            (isolated.count, isolated.of, isolated.fate),
            (3, 1603, IsolatedFate::LeftOut)
        );
        assert!((isolated.reach - reach).abs() < 1e-5, "{}", isolated.reach);
        let (kept, isolated) = without_isolated(with_lone, &params, true).unwrap();
        assert_eq!(kept.len(), 1603);
        assert_eq!(isolated.map(|i| i.fate), Some(IsolatedFate::Kept));
        // Lone points are left out up to half of all the points; more are kept (with the
        // plane's kernel given: as many lone points as the plane's would set the median
        // spacing to theirs).
        let params = MlsParams::default().kernel(0.125);
        for (lone, fate) in [
            (160, IsolatedFate::LeftOut),
            (1600, IsolatedFate::LeftOut),
            (1601, IsolatedFate::SparseSampling),
        ] {
            let mut positions = plane();
            positions.extend((0..lone).map(|k| Vec3::new((k % 40) as f32, (k / 40) as f32, 5.0)));
            let (points, isolated) =
                without_isolated(with_normals(positions), &params, false).unwrap();
            assert_eq!(isolated.map(|i| (i.count, i.fate)), Some((lone, fate)));
            let expected = if fate == IsolatedFate::LeftOut {
                1600
            } else {
                1600 + lone
            };
            assert_eq!(points.len(), expected);
        }
    }

    #[test]
    fn too_few_points_are_returned_whole_and_bad_parameters_are_errors() {
        let three = with_normals(plane()[..3].to_vec());
        let (same, none) = without_isolated(three.clone(), &MlsParams::default(), false).unwrap();
        assert_eq!((same, none), (three.clone(), None));
        let bad = MlsParams {
            support: -1.0,
            ..MlsParams::default()
        };
        assert!(without_isolated(three, &bad, false).is_err());
        assert!(without_isolated(with_normals(plane()), &bad, false).is_err());
    }

    #[test]
    fn the_index_handed_on_indexes_the_points_handed_on() {
        let mut positions = plane();
        positions.insert(700, Vec3::new(2.0, 2.0, 1.5));
        let with_lone = with_normals(positions);
        let params = MlsParams::default();
        // Nothing left out (kept, or none isolated), and the lone point left out.
        for (input, keep) in [
            (with_lone.clone(), true),
            (with_normals(plane()), false),
            (with_lone, false),
        ] {
            let (points, isolated, index) =
                without_isolated_indexed(input.clone(), &params, keep).unwrap();
            assert_eq!(
                (points.clone(), isolated),
                without_isolated(input, &params, keep).unwrap()
            );
            assert_eq!(index.points(), points.positions());
            // It answers for the points handed on: each is its own nearest.
            for (i, p) in points.positions().iter().enumerate().step_by(97) {
                assert_eq!(index.nearest(*p, 1).unwrap()[0].index, i);
            }
        }
    }
}
