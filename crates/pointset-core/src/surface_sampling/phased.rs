//! The Poisson-disk test run tile by tile in eight phases ([`Tiles::phases`]), for
//! candidates of any kind: samples drawn on a mesh's triangles, or a point set's own points.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::disk_grid::DiskGrid;
use super::tiles::{Tile, Tiles};
use crate::spatial::CellMap;
use crate::{Error, Result, RunContext};

/// Tiles tested between progress reports and cancellation checks: enough for both threads
/// of a small machine to stay busy.
const TILES_PER_BATCH: usize = 256;

/// What [`keep_apart`] keeps: candidates of each tile, and where each lies.
pub(super) trait Candidates: Sync {
    /// One candidate.
    type Item: Send + Sync;
    /// `tile`'s candidates, in the order they are tested.
    fn of_tile(&self, tile: &Tile<'_>) -> Vec<Self::Item>;
    /// Where `item` lies.
    fn position(&self, item: &Self::Item) -> Vec3;
}

/// Keeps each candidate of `candidates` that lies no closer than `spacing` to one kept
/// before it, tile by tile over `tiles` in phases (a grid of cells of side `spacing` from
/// `low`); the kept ones in the order of their tiles' phases and keys, then their order
/// within the tile. Progress as `stage` (tiles done); `too_small` is the error for a
/// candidate outside the grid.
pub(super) fn keep_apart<C: Candidates>(
    tiles: &Tiles,
    candidates: &C,
    low: DVec3,
    spacing: f64,
    stage: &str,
    too_small: impl Fn() -> Error + Sync,
    ctx: &mut RunContext,
) -> Result<Vec<C::Item>> {
    let cancel = ctx.cancel_flag().clone();
    let (total_tiles, mut done) = (tiles.count() as u64, 0);
    // The candidates kept in each tile, by the tile's key, and the keys in the order done.
    let mut kept_by_tile: CellMap<Vec<C::Item>> = CellMap::default();
    let mut order = Vec::new();
    // A phase's tiles go in batches, with progress and a cancellation check between
    // them: tiles of one phase are not neighbours, so the batches keep the same points.
    for batch in tiles
        .phases()
        .iter()
        .flat_map(|phase| phase.chunks(TILES_PER_BATCH))
    {
        ctx.check_cancelled()?;
        ctx.report(stage, done, Some(total_tiles));
        let by_tile = batch
            .par_iter()
            .map(|tile| {
                if cancel.is_cancelled() {
                    return Err(Error::Cancelled);
                }
                // The tile's own grid, first holding what its neighbours kept in earlier
                // phases within two spacings of it, so that every test reads one small
                // grid.
                let [tile_low, tile_high] = tiles.bounds(tile);
                let near = |p: Vec3| {
                    let p = p.as_dvec3();
                    p.cmpge(tile_low - 2.0 * spacing).all()
                        && p.cmple(tile_high + 2.0 * spacing).all()
                };
                let mut grid = DiskGrid::new(low, spacing);
                let around = tiles
                    .neighbours(tile)
                    .filter_map(|key| kept_by_tile.get(&key));
                for p in around.flatten().map(|item| candidates.position(item)) {
                    if let Some(cell) = grid.cell(p).filter(|_| near(p)) {
                        grid.keep(p, cell);
                    }
                }
                let mut tile_kept = Vec::new();
                for item in candidates.of_tile(tile) {
                    let p = candidates.position(&item);
                    let cell = grid.cell(p).ok_or_else(&too_small)?;
                    if !grid.crowded(p, cell) {
                        grid.keep(p, cell);
                        tile_kept.push(item);
                    }
                }
                Ok((tile.key(), tile_kept))
            })
            .collect::<Result<Vec<_>>>()?;
        for (key, tile_kept) in by_tile {
            order.push(key);
            kept_by_tile.insert(key, tile_kept);
        }
        done += batch.len() as u64;
    }
    Ok(order
        .iter()
        .filter_map(|key| kept_by_tile.remove(key))
        .flatten()
        .collect())
}

/// The low corner for a grid of cells of side `spacing` over `positions`: a cell below
/// their box, so that no rounding puts one of them below the grid.
pub(super) fn grid_low(positions: &[Vec3], spacing: f64) -> DVec3 {
    positions
        .iter()
        .fold(DVec3::splat(f64::INFINITY), |m, p| m.min(p.as_dvec3()))
        - spacing
}

/// The error for a `spacing` too small for the grid over `what` ("the mesh's box").
pub(super) fn spacing_too_small(spacing: f32, what: &str) -> Error {
    Error::InvalidParameter {
        name: "spacing",
        value: spacing.to_string(),
        expected: format!(
            "a length that spans {what} in at most 2^{} cells",
            crate::spatial::CELL_BITS + 2
        ),
    }
}
