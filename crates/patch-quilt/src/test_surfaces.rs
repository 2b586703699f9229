//! Analytic surfaces shared by the crate's unit tests.

use glam::Vec3;

/// The wavy height field `z = 0.05 sin(6x) cos(5y)` with its unit normal.
pub(crate) fn wave(x: f32, y: f32) -> (Vec3, Vec3) {
    let z = 0.05 * (6.0 * x).sin() * (5.0 * y).cos();
    let dzdx = 0.3 * (6.0 * x).cos() * (5.0 * y).cos();
    let dzdy = -0.25 * (6.0 * x).sin() * (5.0 * y).sin();
    (Vec3::new(x, y, z), Vec3::new(-dzdx, -dzdy, 1.0).normalize())
}

/// A plateau at `z ≈ 0.37` (rippled by ±0.003) with a pit 0.27 deep centred on
/// `(1, 1.1)`, with its unit normal: the shape of a height map's flat top around a spot.
pub(crate) fn plateau_with_pit(x: f32, y: f32) -> (Vec3, Vec3) {
    let (dx, dy) = (x - 1.0, y - 1.1);
    let pit = -0.27 * (-(dx * dx + dy * dy) / 0.05).exp();
    let z = 0.37 + 0.003 * (40.0 * x).sin() * (40.0 * y).sin() + pit;
    let dzdx = 0.12 * (40.0 * x).cos() * (40.0 * y).sin() - pit * 2.0 * dx / 0.05;
    let dzdy = 0.12 * (40.0 * x).sin() * (40.0 * y).cos() - pit * 2.0 * dy / 0.05;
    (Vec3::new(x, y, z), Vec3::new(-dzdx, -dzdy, 1.0).normalize())
}
