//! Analytic surfaces shared by the crate's unit tests.

use glam::Vec3;

/// The wavy height field `z = 0.05 sin(6x) cos(5y)` with its unit normal.
pub(crate) fn wave(x: f32, y: f32) -> (Vec3, Vec3) {
    let z = 0.05 * (6.0 * x).sin() * (5.0 * y).cos();
    let dzdx = 0.3 * (6.0 * x).cos() * (5.0 * y).cos();
    let dzdy = -0.25 * (6.0 * x).sin() * (5.0 * y).sin();
    (Vec3::new(x, y, z), Vec3::new(-dzdx, -dzdy, 1.0).normalize())
}
