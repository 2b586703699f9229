//! Normals fitted and oriented in one pass over the points' neighbours.

use std::time::Instant;

use glam::Vec3;
use pointset_core::spatial::z_order;
use pointset_core::{KdIndex, PointSet, RunContext};

use super::{
    FoundNeighbours, ORIENTING_STAGE, OrientationGraph, check_countable, check_up, propagate,
};
use crate::error::{MlsError, Result};
use crate::index_match::check_index_of;
use crate::pca::{FITTING_STAGE, NormalFit, check_fit, fit_along};

/// [`crate::fit_normals_with`] followed by [`crate::orient_normals_with`] on its points,
/// with the same result bit for bit, but faster: the orientation's graph takes each
/// point's neighbours from the fit's search instead of searching again, wherever the
/// fit's `k` nearest settle them (a `k` of 9 or more, unless the 9th and 10th nearest are
/// equally far, as on lattices). It takes the points and returns them with their normals,
/// where the two functions copy them twice: on 12 million points that saves seconds and
/// copies. (On an error the points are dropped; clone them first to keep them.)
///
/// The fit reports under [`FITTING_STAGE`] and the orientation under
/// [`crate::LINKING_STAGE`] and [`ORIENTING_STAGE`], as the two functions do; the time of
/// each half is recorded in `ctx`'s timings under those two stage names. A cancelled run
/// stops at the next report. Errors as the two functions': `k` below 3, fewer than 3
/// points, a non-finite position, an index of other positions, more than `u32::MAX`
/// points, an `up` that is zero or not finite.
///
/// ```
/// use glam::Vec3;
/// use mls_surface::{fit_normals_with, fit_oriented_normals_with, orient_normals_with};
/// use pointset_core::{KdIndex, PointSet, RunContext};
///
/// // A wavy sheet, without normals.
/// let p: Vec<Vec3> = (0..900)
///     .map(|i| {
///         let (x, y) = ((i % 30) as f32 * 0.1, (i / 30) as f32 * 0.1);
///         Vec3::new(x, y, 0.2 * (2.0 * x).sin())
///     })
///     .collect();
/// let points = PointSet::new(p)?;
/// let index = KdIndex::new(points.positions())?;
/// let mut ctx = RunContext::new(0);
/// let both = fit_oriented_normals_with(&index, points.clone(), 12, Vec3::Z, &mut ctx)?;
/// assert!(both.points.normals().ok_or("no normals")?.iter().all(|n| n.z > 0.5));
/// // The same as the two steps one after the other.
/// let fit = fit_normals_with(&index, &points, 12, &mut ctx)?;
/// assert_eq!(both.points, orient_normals_with(&index, &fit.points, Vec3::Z, &mut ctx)?);
/// assert_eq!(both.undefined, fit.undefined);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_oriented_normals_with(
    index: &KdIndex,
    points: PointSet,
    k: usize,
    up: Vec3,
    ctx: &mut RunContext,
) -> Result<NormalFit> {
    check_fit(&points, k)?;
    check_countable(&points)?;
    check_up(up)?;
    check_index_of(index, &points)?;
    let order = z_order(points.positions());
    let mut found = FoundNeighbours::unsearched(points.len());
    let mut fit = ctx.timed(FITTING_STAGE, |ctx| {
        fit_along(index, points, k, &order, Some(&mut found), ctx)
    })?;
    let started = Instant::now();
    let positions = fit.points.positions();
    let normals = fit.points.normals().ok_or(MlsError::MissingNormals)?;
    let graph = OrientationGraph::build(positions, normals, index, order, found, ctx)?;
    let oriented = propagate(positions, normals, graph, up, ctx)?;
    fit.points.set_normals(Some(oriented))?;
    ctx.record_timing(ORIENTING_STAGE, started.elapsed());
    Ok(fit)
}
