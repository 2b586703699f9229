//! Unit vectors and exact rescaling for geometry at any scale.
//!
//! Squares of `f32` values overflow beyond about 1.8e19 and lose all precision below about
//! 1e-19, so the textbook formulas fail for lengths far from 1 long before the coordinates
//! themselves do: the cross product of two edges 1e10 units long has a squared length of
//! 1e40, so `((b − a) × (c − a)).normalize()` gives zero. Multiplying by a power of two
//! is exact, so scaling the operands into `[1, 2)` first gives, wherever the textbook
//! formula does not overflow or underflow, the very same bits, and the right answer
//! where it does.

use glam::Vec3;

/// The power of two `2^−e` that brings `magnitude` into `[1, 2)` (`[2, 4)` for the
/// largest `f32` exponent), so that multiplying by it is exact. 1 for zero, subnormal or
/// non-finite magnitudes.
///
/// ```
/// use pointset_core::power_of_two_scale;
///
/// assert_eq!(power_of_two_scale(1e10) * 1e10, 1e10 / 8589934592.0);
/// assert_eq!(power_of_two_scale(0.75), 2.0);
/// assert_eq!(power_of_two_scale(0.0), 1.0);
/// ```
pub fn power_of_two_scale(magnitude: f32) -> f32 {
    if !magnitude.is_normal() {
        return 1.0;
    }
    let exponent = (((magnitude.abs().to_bits() >> 23) & 0xff) as i32 - 127).clamp(-126, 126);
    f32::from_bits(((127 - exponent) as u32) << 23)
}

/// `v` scaled to unit length, or zero when `v` is zero or not finite: `normalize_or_zero`
/// for vectors of any length (it gives zero once the squared length overflows or
/// vanishes). Bit for bit `v.normalize_or_zero()` wherever that one works.
///
/// ```
/// use glam::Vec3;
/// use pointset_core::unit_vector;
///
/// let long = Vec3::new(3e20, 4e20, 0.0);
/// assert_eq!(long.normalize_or_zero(), Vec3::ZERO); // |v|² overflows
/// assert!((unit_vector(long) - Vec3::new(0.6, 0.8, 0.0)).length() < 1e-6);
/// assert_eq!(unit_vector(Vec3::new(0.3, 0.4, 0.0)), Vec3::new(0.3, 0.4, 0.0).normalize());
/// ```
pub fn unit_vector(v: Vec3) -> Vec3 {
    (v * power_of_two_scale(v.abs().max_element())).normalize_or_zero()
}

/// The unit normal of triangle `(a, b, c)` by the right-hand rule, zero for a degenerate
/// one, at any scale: the edges are brought near unit length by a power of two before
/// their cross product ([`unit_vector`]). Bit for bit
/// `(b − a).cross(c − a).normalize_or_zero()` wherever that does not overflow.
pub fn triangle_normal(a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let (ab, ac) = (b - a, c - a);
    let scale = power_of_two_scale(ab.abs().max_element().max(ac.abs().max_element()));
    unit_vector((ab * scale).cross(ac * scale))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales_are_exact_powers_of_two_bringing_values_into_one_to_two() {
        for m in [
            1e-30f32,
            3.7e-5,
            0.5,
            1.0,
            1.5,
            2.0,
            123.0,
            6e12,
            1e30,
            f32::MAX,
        ] {
            let s = power_of_two_scale(m);
            assert_eq!(s.to_bits() & 0x007f_ffff, 0, "{s} is a power of two");
            let scaled = m * s;
            assert!((1.0..4.0).contains(&scaled), "{m} → {scaled}");
            assert_eq!(scaled / s, m, "exact round trip for {m}");
        }
        for m in [0.0, f32::MIN_POSITIVE / 4.0, f32::INFINITY, f32::NAN] {
            assert_eq!(power_of_two_scale(m), 1.0);
        }
    }

    #[test]
    fn unit_vectors_match_the_textbook_formula_where_it_works_and_fix_it_elsewhere() {
        let mut state = 7u32;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        for _ in 0..1000 {
            let v = Vec3::new(next(), next(), next());
            assert_eq!(unit_vector(v), v.normalize_or_zero());
            for scale in [1e-25f32, 1e25] {
                let u = unit_vector(v * scale);
                assert!((u - v.normalize()).length() < 1e-6, "{v} at {scale}");
            }
        }
        assert_eq!(unit_vector(Vec3::ZERO), Vec3::ZERO);
        assert_eq!(unit_vector(Vec3::new(f32::NAN, 0.0, 1.0)), Vec3::ZERO);
    }

    #[test]
    fn triangle_normals_hold_at_every_scale() {
        let (a, b, c) = (
            Vec3::new(0.1, 0.2, 0.3),
            Vec3::new(1.3, 0.4, 0.2),
            Vec3::new(0.2, 1.1, 0.9),
        );
        let textbook = (b - a).cross(c - a).normalize_or_zero();
        assert_eq!(triangle_normal(a, b, c), textbook);
        for scale in [1e-15f32, 1e12, 1e18] {
            let n = triangle_normal(a * scale, b * scale, c * scale);
            assert!((n - textbook).length() < 1e-5, "scale {scale}: {n}");
        }
        // The textbook formula loses the big one.
        let big = 1e12;
        assert_eq!(
            ((b - a) * big).cross((c - a) * big).normalize_or_zero(),
            Vec3::ZERO
        );
        assert_eq!(triangle_normal(a, a, c), Vec3::ZERO);
    }
}
