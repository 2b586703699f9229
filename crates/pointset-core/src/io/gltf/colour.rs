//! glTF's vertex colours are linear; every other format here stores sRGB bytes. The
//! sRGB transfer function (IEC 61966-2-1) both ways.

/// The linear value of an sRGB-encoded value in `0..=1`.
pub(super) fn srgb_to_linear(c: f64) -> f64 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The sRGB-encoded value of a linear value in `0..=1`.
pub(super) fn linear_to_srgb(l: f64) -> f64 {
    let l = l.clamp(0.0, 1.0);
    if l <= 0.003_130_8 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::{linear_to_srgb, srgb_to_linear};

    #[test]
    fn the_curve_matches_its_published_points() {
        // Mid grey: sRGB 0.5 is about 21.4% linear; the ends are fixed.
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-6);
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-12);
        assert!((srgb_to_linear(0.04045) - 0.04045 / 12.92).abs() < 1e-12);
    }

    #[test]
    fn every_8_bit_value_survives_16_bit_linear_storage() {
        for byte in 0..=255u16 {
            let linear = srgb_to_linear(f64::from(byte) / 255.0);
            let stored = (linear * 65535.0).round() / 65535.0;
            let back = (linear_to_srgb(stored) * 255.0).round();
            assert_eq!(back, f64::from(byte));
        }
    }
}
