//! Points in an order that keeps neighbours together: the Z-order (Morton) curve over a
//! grid laid on their box. Nearest-neighbour queries asked in this order walk the same
//! parts of a [`KdIndex`](super::KdIndex) one after another, so the index stays in the
//! processor's caches: `geosynth normals` on 12 million points stored in random order
//! took half the processor time (docs/performance.md). Answers do not depend on the order
//! in which they are asked; only the time does.

use glam::Vec3;

/// Bits per axis of the grid the curve runs over (3 × 21 = 63 bits of code).
const BITS: u32 = 21;

/// The indices of `points`, ordered along the Z-order curve through the cells of a grid of
/// 2^21 cells a side over their box (cells compared by their interleaved coordinates;
/// points in one cell by index, so the order is one and the same every time). Non-finite
/// coordinates are put in the first cell of their axis.
///
/// ```
/// use glam::Vec3;
/// use pointset_core::spatial::z_order;
///
/// // Two clusters, stored alternately: the order visits one, then the other.
/// let points: Vec<Vec3> = (0..8)
///     .map(|i| Vec3::splat(if i % 2 == 0 { 0.0 } else { 10.0 }) + Vec3::X * (i as f32 * 0.01))
///     .collect();
/// assert_eq!(z_order(&points), [0, 2, 4, 6, 1, 3, 5, 7]);
/// ```
pub fn z_order(points: &[Vec3]) -> Vec<usize> {
    let finite = points.iter().filter(|p| p.is_finite());
    let lo = finite.clone().fold(Vec3::INFINITY, |m, &p| m.min(p));
    let hi = finite.fold(Vec3::NEG_INFINITY, |m, &p| m.max(p));
    let extent = (hi - lo).max_element();
    let cells = ((1u32 << BITS) - 1) as f32;
    let scale = if extent > 0.0 && extent.is_finite() {
        cells / extent
    } else {
        0.0
    };
    // `as` saturates: NaN gives 0, and rounding past the last cell stays in it.
    let cell = |v: f32, lo: f32| (((v - lo) * scale) as u32).min(cells as u32);
    let mut keyed: Vec<(u64, usize)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let code = spread(cell(p.x, lo.x))
                | (spread(cell(p.y, lo.y)) << 1)
                | (spread(cell(p.z, lo.z)) << 2);
            (code, i)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// The low [`BITS`] bits of `v` spread out to every third bit.
fn spread(v: u32) -> u64 {
    let mut x = u64::from(v) & ((1 << BITS) - 1);
    x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// Bit `b` of every coordinate, interleaved one bit at a time.
    fn spread_bit_by_bit(v: u32) -> u64 {
        (0..BITS).fold(0, |code, b| code | (u64::from((v >> b) & 1) << (3 * b)))
    }

    proptest! {
        #[test]
        fn spreading_puts_each_bit_three_places_apart(v in 0u32..(1 << BITS)) {
            prop_assert_eq!(spread(v), spread_bit_by_bit(v));
        }

        #[test]
        fn the_order_is_a_permutation_that_sorts_the_codes(
            points in prop::collection::vec(
                (-5.0f32..5.0, -5.0f32..5.0, -5.0f32..5.0).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
                0..200,
            ),
        ) {
            let order = z_order(&points);
            let mut seen = order.clone();
            seen.sort_unstable();
            prop_assert_eq!(seen, (0..points.len()).collect::<Vec<_>>());
            // Each point shares the cell-halves of the box with the points around it in
            // the order at least as often as with a point far along it: consecutive
            // points lie closer than a random pair, on average.
            if points.len() > 20 {
                let gap = |a: usize, b: usize| points[order[a]].distance(points[order[b]]);
                let near: f32 = (1..order.len()).map(|k| gap(k - 1, k)).sum();
                let far: f32 = (1..order.len()).map(|k| gap(k - 1, (k + order.len() / 2) % order.len())).sum();
                prop_assert!(near <= far, "{} {}", near, far);
            }
        }
    }

    #[test]
    fn coincident_and_non_finite_points_come_by_index() {
        let points = [Vec3::ONE, Vec3::ONE, Vec3::NAN, Vec3::ONE];
        assert_eq!(z_order(&points), [0, 1, 2, 3]);
        assert!(z_order(&[]).is_empty());
    }
}
