//! Step 2: the candidate set `Ψ_k` by exhaustive comparison of distance fields over the
//! overlap region (paper 000 §5.1). Public as the hot kernel, for benchmarks and custom
//! drivers.

use glam::Vec4;
use rayon::prelude::*;

use crate::error::{Result, invalid};

/// One overlap node: its linear offset in `D(T_in)` relative to a patch's corner node, and
/// its index in the neighbourhood's field.
#[derive(Debug, Clone, Copy)]
pub struct OverlapNode {
    /// Linear offset in `D(T_in)` from the patch's corner node.
    pub exemplar_offset: usize,
    /// Index of the same node in the neighbourhood's field.
    pub neighbourhood_index: usize,
}

/// The distances `d(O^N, O^P) = ‖D(O^N) − D(O^P)‖²` (distance and gradient channels) for
/// every patch offset `(i, j)`, `0 ≤ i ≤ max_i`, `0 ≤ j ≤ max_j`, row-major in `j`. The
/// exemplar field is `nx` nodes wide.
///
/// Errors with [`QuiltError::InvalidParameter`](crate::QuiltError) when `max_i ≥ nx` or an
/// overlap node would read outside either field for some offset.
pub fn distances(
    exemplar: &[Vec4],
    nx: usize,
    max_i: usize,
    max_j: usize,
    overlap: &[OverlapNode],
    neighbourhood: &[Vec4],
) -> Result<Vec<f32>> {
    let last_corner = nx.checked_mul(max_j).and_then(|r| r.checked_add(max_i));
    let inside = |o: &OverlapNode| {
        o.neighbourhood_index < neighbourhood.len()
            && last_corner
                .and_then(|c| c.checked_add(o.exemplar_offset))
                .is_some_and(|last| last < exemplar.len())
    };
    if max_i >= nx || !overlap.iter().all(inside) {
        return Err(invalid(
            "overlap",
            format!(
                "{} nodes over offsets up to ({max_i}, {max_j}) in a field {nx} wide",
                overlap.len()
            ),
            format!(
                "nodes inside both fields ({} exemplar, {} neighbourhood values)",
                exemplar.len(),
                neighbourhood.len()
            ),
        ));
    }
    let width = max_i + 1;
    Ok((0..width * (max_j + 1))
        .into_par_iter()
        .map(|c| {
            let base = c % width + nx * (c / width);
            overlap
                .iter()
                .map(|o| {
                    (exemplar[base + o.exemplar_offset] - neighbourhood[o.neighbourhood_index])
                        .length_squared()
                })
                .sum()
        })
        .collect())
}

/// `Ψ = {P | d(P) ≤ (1 + ε) min d}` as indices into `d`, ascending; NaN distances are never
/// candidates (so `Ψ` is empty only when `d` is empty or all NaN).
pub fn candidates(d: &[f32], epsilon: f32) -> Vec<usize> {
    let best = d.iter().copied().fold(f32::INFINITY, f32::min);
    let limit = best * (1.0 + epsilon);
    (0..d.len()).filter(|&c| d[c] <= limit).collect()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn candidate_set_respects_epsilon() {
        let d = [5.0, 1.0, 1.05, 1.2, 0.99 * 1.1, 3.0];
        assert_eq!(candidates(&d, 0.1), vec![1, 2, 4]);
        assert_eq!(candidates(&d, 0.0), vec![1]);
        assert_eq!(candidates(&[0.0, 0.0, 1.0], 0.5), vec![0, 1]);
        assert_eq!(candidates(&[f32::NAN, 2.0, f32::NAN], 0.1), vec![1]);
        assert!(candidates(&[f32::NAN, f32::NAN], 0.1).is_empty());
    }

    #[test]
    fn distances_compare_the_overlap_only() {
        // A 4×1×1 exemplar field; the neighbourhood matches offset 2 exactly.
        let ex = [
            Vec4::splat(0.0),
            Vec4::splat(1.0),
            Vec4::splat(2.0),
            Vec4::splat(3.0),
        ];
        let overlap = [
            OverlapNode {
                exemplar_offset: 0,
                neighbourhood_index: 0,
            },
            OverlapNode {
                exemplar_offset: 1,
                neighbourhood_index: 1,
            },
        ];
        let nb = [Vec4::splat(2.0), Vec4::splat(3.0)];
        let d = distances(&ex, 4, 2, 0, &overlap, &nb).unwrap();
        assert_eq!(d, vec![32.0, 8.0, 0.0]);
        // Offsets that would read past either field are refused, not a panic.
        assert!(distances(&ex, 4, 3, 0, &overlap, &nb).is_err());
        assert!(distances(&ex, 4, 4, 0, &overlap, &nb).is_err());
        assert!(distances(&ex, 4, 2, 0, &overlap, &nb[..1]).is_err());
        assert!(distances(&ex, usize::MAX, 2, usize::MAX, &overlap, &nb).is_err());
    }
}
