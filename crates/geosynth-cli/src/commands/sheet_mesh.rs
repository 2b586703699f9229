//! `geosynth quilt --mesh`: the quilted sheet as a mesh, the way `geosynth reconstruct
//! --trim` would make it, on a grid that follows the points' spacing.

use std::time::Instant;

use geosynth::core::{KdIndex, PointSet, RunContext, Stage, TriMesh};
use geosynth::reconstruct::{FieldParams, ReconstructOpen};

use crate::CliResult;

/// Fewest grid nodes along the sheet's longest side.
pub const MIN_SHEET_NODES: usize = 32;
/// Most grid nodes along the sheet's longest side (512 × 512 nodes across, times as many
/// as the relief and the margins take).
pub const MAX_SHEET_NODES: usize = 512;

/// Median sample spacings per grid spacing. The MLS kernel reaches 1.25 median spacings,
/// so a grid finer than about 2 resolves the small bubbles where the points undersample
/// the surface (docs/mls-surface.md, "Small pieces"): the quilted stone wall came out in 40
/// pieces at 2 spacings a node (132 nodes) and in 307 at 1 (263 nodes, five times the
/// faces); a quilted chain mail (8 units, spacing 0.027) in 18 pieces at 128 nodes, 83 at
/// 200, and 344 at 64, where its tubes break up.
pub const SPACINGS_PER_NODE: f32 = 2.0;

/// The grid resolution for a sheet of `points`: [`nodes_across`] its longest side.
pub fn sheet_resolution(points: &PointSet) -> CliResult<usize> {
    let spacing = KdIndex::new(points.positions())?.median_spacing()?;
    let longest = points
        .bounding_box()
        .map_or(0.0, |b| b.extent().max_element());
    Ok(nodes_across(longest, spacing))
}

/// Grid nodes across `length` at one node per [`SPACINGS_PER_NODE`] median sample
/// spacings (`spacing`), within [`MIN_SHEET_NODES`] and [`MAX_SHEET_NODES`]; the fewest
/// for samples that all coincide (no spacing).
pub fn nodes_across(length: f32, spacing: f32) -> usize {
    let nodes = if spacing > 0.0 {
        (length / (SPACINGS_PER_NODE * spacing)).ceil()
    } else {
        0.0
    };
    // A saturating cast: NaN and negatives give 0, huge values the maximum.
    (nodes as usize).clamp(MIN_SHEET_NODES, MAX_SHEET_NODES)
}

/// A mesh of the sheet sampled by `points` ([`ReconstructOpen`] with the default kernel and
/// trim, at [`sheet_resolution`]), the grid's resolution, and the seconds it took; `ctx`
/// gets the stage's progress.
pub fn sheet_mesh(points: PointSet, ctx: &mut RunContext) -> CliResult<(TriMesh, usize, f64)> {
    let start = Instant::now();
    let resolution = sheet_resolution(&points)?;
    let stage = ReconstructOpen {
        params: FieldParams::default().resolution(resolution),
        ..Default::default()
    };
    let mesh = stage.run(points, ctx)?;
    Ok((mesh, resolution, start.elapsed().as_secs_f64()))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use glam::Vec3;

    use super::*;

    #[test]
    fn the_grid_has_a_node_per_two_spacings_within_its_bounds() {
        assert_eq!(nodes_across(49.5, 0.5), 50);
        assert_eq!(nodes_across(50.0, 0.5), 50);
        assert_eq!(nodes_across(4.5, 0.5), MIN_SHEET_NODES);
        assert_eq!(nodes_across(1e9, 0.5), MAX_SHEET_NODES);
        assert_eq!(nodes_across(4.5, 0.0), MIN_SHEET_NODES);
        assert_eq!(nodes_across(f32::NAN, 0.5), MIN_SHEET_NODES);
        // 100 × 100 samples 0.5 apart: 49.5 wide.
        let positions = (0..100 * 100)
            .map(|i| Vec3::new((i % 100) as f32, (i / 100) as f32, 0.0) * 0.5)
            .collect();
        let grid = PointSet::new(positions).unwrap();
        assert_eq!(sheet_resolution(&grid).ok(), Some(50));
    }
}
