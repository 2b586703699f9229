//! Geometry from a synthesized field (paper 001 §5.3), both ways the issue asks for:
//!
//! - [`isosurface_mesh`]: the zero set of the target field (marching tetrahedra). With
//!   `closed`, the field is padded by one sample of "outside" so the surface is closed where
//!   it meets the target's box. [`isosurface_cells`] counts the cells it triangulates.
//! - [`copied_mesh`](crate::copied_mesh): the paper's way, in the `copied` module.

use pointset_core::TriMesh;
use rayon::prelude::*;

use crate::error::Result;
use crate::synth::Synthesis;

/// The zero set of the synthesized field as a mesh (reconstruction (a)).
pub fn isosurface_mesh(synthesis: &Synthesis, closed: bool) -> Result<TriMesh> {
    let grid = synthesis.distances()?;
    Ok(if closed {
        distance_field::closed_isosurface(&grid, 0.0, synthesis.quantizer.range())?
    } else {
        distance_field::isosurface(&grid, 0.0)?
    })
}

/// How many cells of the grid that [`isosurface_mesh`] with `closed` triangulates cross the
/// zero set (corners on both sides), counted without triangulating: each such cell gives 1
/// to 12 triangles (6 tetrahedra, at most 2 each), so the memory the iso-surface needs
/// grows with this number. `O(target samples)`.
pub fn isosurface_cells(synthesis: &Synthesis, closed: bool) -> usize {
    let [nx, ny, nz] = synthesis.field.dims();
    let inside: Vec<bool> = synthesis
        .field
        .values()
        .iter()
        .map(|&q| synthesis.quantizer.dequantize(q) < 0.0)
        .collect();
    // Closed: one layer of outside around the field, so corner coordinates run over 0..n+2
    // with the field's samples at 1..=n.
    let pad = usize::from(closed);
    let inside_at = |x: usize, y: usize, z: usize| {
        let [x, y, z] = [
            x.wrapping_sub(pad),
            y.wrapping_sub(pad),
            z.wrapping_sub(pad),
        ];
        x < nx && y < ny && z < nz && inside[x + nx * (y + ny * z)]
    };
    let cells = |n: usize| (n + 2 * pad).saturating_sub(1);
    (0..cells(nz))
        .into_par_iter()
        .map(|k| {
            let mut crossing = 0;
            for j in 0..cells(ny) {
                for i in 0..cells(nx) {
                    let negative = (0..8)
                        .filter(|&c| inside_at(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)))
                        .count();
                    if negative != 0 && negative != 8 {
                        crossing += 1;
                    }
                }
            }
            crossing
        })
        .sum()
}
