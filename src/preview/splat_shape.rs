//! How wide each surface splat is drawn: as wide as its neighbourhood's gaps need, and no
//! wider across a curved surface than the surface stays within a sag tolerance of the
//! splat's plane.
//!
//! A flat disc in a point's tangent plane leaves a curved surface: at distance `r` from
//! the point, a surface of curvature `κ` lies `κ r² / 2` from the plane (the sag). On a
//! tube sampled about as sparsely as it is thin, discs as wide as the sampling's gaps
//! stick out of the tube by about its radius, and the tube is drawn 1.6 times as wide as
//! it is. So each splat is an ellipse: along each principal direction of the surface
//! (fitted from its neighbours) its radius is the neighbourhood's, capped where the sag
//! reaches [`SAG_SPACINGS`] of the sampling's median spacing, and never below
//! [`MIN_SPACINGS`] of it so that the sampling stays covered.

use glam::{Mat3, Vec2, Vec3};
use pointset_core::{KdIndex, Neighbour};
use rayon::prelude::*;

use crate::Result;

/// How many of a point's nearest framed points (itself included) its surface splat
/// reaches: enough discs to cover the gaps of an irregular sampling.
const SPLAT_NEIGHBOURS: usize = 8;

/// The largest surface splat, in median point spacings: a sparse point's disc does not
/// swell over its surroundings.
const MAX_SPLAT_SPACINGS: f32 = 4.0;

/// The largest sag of a splat's rim off the surface, in median point spacings.
const SAG_SPACINGS: f32 = 0.25;

/// The smallest radius the sag cap leaves a splat, in median point spacings.
const MIN_SPACINGS: f32 = 1.0;

/// A surface splat's extent in pixels: an ellipse in the point's tangent plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SplatShape {
    /// The radius along every direction but `minor_axis`.
    pub radius: f32,
    /// The radius along `minor_axis` (at most `radius`).
    pub minor_radius: f32,
    /// The tangent direction of the surface's strongest curvature (a unit vector), or
    /// zero when the splat is a disc.
    pub minor_axis: Vec3,
}

/// The splat shape in pixels of each point `i` of `drawn`, at `positions[i]` with normal
/// `normals[i]` (`px` to a world unit; `spacing` is the framed points' median spacing,
/// `index` is built over `framed`). The radius is the
/// distance to the [`SPLAT_NEIGHBOURS`]th nearest framed point, between one and
/// [`MAX_SPLAT_SPACINGS`] spacings (a point among copies of itself gets one); the sag
/// cap may narrow it along the surface's two principal directions. Every radius is at
/// least a pixel. When even the largest disc would be a pixel, the neighbours are not
/// searched.
pub(crate) fn splat_shapes(
    index: &KdIndex,
    framed: &[Vec3],
    (positions, normals, drawn): (&[Vec3], &[Vec3], &[usize]),
    spacing: f32,
    px: f32,
) -> Result<Vec<SplatShape>> {
    let largest = MAX_SPLAT_SPACINGS * spacing;
    if largest * px <= 1.0 {
        let pixel = SplatShape {
            radius: 1.0,
            minor_radius: 1.0,
            minor_axis: Vec3::ZERO,
        };
        return Ok(vec![pixel; drawn.len()]);
    }
    let in_px = |r: f32| (r * px).clamp(1.0, 64.0);
    drawn
        .par_iter()
        .map(|&i| {
            let (p, n) = (positions[i], normals[i]);
            let found = index.nearest_within(p, SPLAT_NEIGHBOURS, largest)?;
            let radius = found
                .get(SPLAT_NEIGHBOURS - 1)
                .map_or(largest, |f| f.distance_squared.sqrt().max(spacing));
            let capped = |curvature: f32| {
                let cap = (2.0 * SAG_SPACINGS * spacing / curvature.abs()).sqrt();
                radius.min(cap.max(MIN_SPACINGS * spacing))
            };
            let shape = match principal_curvatures(p, n, &found, framed) {
                Some(c) if capped(c.strongest) < radius => SplatShape {
                    radius: in_px(capped(c.weakest)),
                    minor_radius: in_px(capped(c.strongest)),
                    minor_axis: c.strongest_direction,
                },
                _ => SplatShape {
                    radius: in_px(radius),
                    minor_radius: in_px(radius),
                    minor_axis: Vec3::ZERO,
                },
            };
            Ok(shape)
        })
        .collect()
}

/// A surface's principal curvatures at a point: the larger and smaller in magnitude.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Curvatures {
    strongest: f32,
    weakest: f32,
    /// The tangent direction of `strongest` (a unit vector).
    strongest_direction: Vec3,
}

/// The principal curvatures at `p` (normal `n`, either sign) of the height function
/// `h(x, y) = a x² + b x y + c y²` fitted by least squares to the neighbours `found`
/// (indices into `framed`) in `p`'s tangent frame; `None` when they are too few or lie on
/// a line, or the normal is not a direction.
fn principal_curvatures(
    p: Vec3,
    n: Vec3,
    found: &[Neighbour],
    framed: &[Vec3],
) -> Option<Curvatures> {
    let n = n.try_normalize()?;
    let (e1, e2) = n.any_orthonormal_pair();
    let mut normal_matrix = Mat3::ZERO;
    let mut rhs = Vec3::ZERO;
    let mut used = 0;
    for f in found {
        let w = *framed.get(f.index)? - p;
        let (x, y, h) = (w.dot(e1), w.dot(e2), w.dot(n));
        let row = Vec3::new(x * x, x * y, y * y);
        if row == Vec3::ZERO {
            continue;
        }
        normal_matrix += outer(row);
        rhs += row * h;
        used += 1;
    }
    // Three unknowns; fewer than twice as many neighbours fit noise. Neighbours along
    // one line leave the matrix singular, up to rounding of its scale (its trace).
    let scale = normal_matrix.x_axis.x + normal_matrix.y_axis.y + normal_matrix.z_axis.z;
    if used < 6 || normal_matrix.determinant() <= 1e-6 * scale.powi(3) {
        return None;
    }
    let [a, b, c] = (normal_matrix.inverse() * rhs).to_array();
    // The Hessian [[2a, b], [b, 2c]]: its eigenvalues are the principal curvatures.
    let mean = a + c;
    let half_gap = Vec2::new(a - c, b).length();
    let (larger, smaller) = (mean + half_gap, mean - half_gap);
    // The eigenvector of the algebraically larger eigenvalue is at half the angle of
    // (2a − 2c, 2b); the other is perpendicular to it.
    let angle = 0.5 * b.atan2(a - c);
    let along_larger = angle.cos() * e1 + angle.sin() * e2;
    let (strongest, weakest, strongest_direction) = if larger.abs() >= smaller.abs() {
        (larger, smaller, along_larger)
    } else {
        (smaller, larger, n.cross(along_larger))
    };
    (strongest.is_finite() && weakest.is_finite()).then_some(Curvatures {
        strongest,
        weakest,
        strongest_direction,
    })
}

/// `v vᵀ`.
fn outer(v: Vec3) -> Mat3 {
    Mat3::from_cols(v * v.x, v * v.y, v * v.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The principal curvatures at the origin (normal +Z) of the surface `z = f(x, y)`
    /// sampled at 16 points on two rings around it, the outer of radius `reach`.
    fn fitted(reach: f32, f: impl Fn(f32, f32) -> f32) -> Curvatures {
        let mut framed = vec![Vec3::ZERO];
        for k in 0..16 {
            let angle = k as f32 * 0.7;
            let r = if k % 2 == 0 { 0.5 * reach } else { reach };
            let (x, y) = (r * angle.cos(), r * angle.sin());
            framed.push(Vec3::new(x, y, f(x, y)));
        }
        let index = KdIndex::new(&framed).unwrap();
        let found = index.nearest_within(Vec3::ZERO, 17, 1.0).unwrap();
        principal_curvatures(Vec3::ZERO, Vec3::Z, &found, &framed).unwrap()
    }

    #[test]
    fn curvatures_of_quadrics_are_their_second_derivatives() {
        // A cylinder of radius 0.06 along y, its lowest line at the origin.
        let r = 0.06f32;
        let cylinder = fitted(0.5 * r, |x, _| r - (r * r - x * x).sqrt());
        assert!((cylinder.strongest * r - 1.0).abs() < 0.15, "{cylinder:?}");
        assert!(cylinder.weakest.abs() < 0.5, "{cylinder:?}");
        assert!(cylinder.strongest_direction.x.abs() > 0.99, "{cylinder:?}");
        // A saddle z = (3x² − y²)/2 turned by 30°: curvatures 3 and −1.
        let (c, s) = (30f32.to_radians().cos(), 30f32.to_radians().sin());
        let saddle = fitted(0.1, |x, y| {
            let (u, v) = (c * x + s * y, -s * x + c * y);
            0.5 * (3.0 * u * u - v * v)
        });
        assert!((saddle.strongest - 3.0).abs() < 1e-3, "{saddle:?}");
        assert!((saddle.weakest + 1.0).abs() < 1e-3, "{saddle:?}");
        assert!(saddle.strongest_direction.dot(Vec3::new(c, s, 0.0)).abs() > 0.999);
        // A plane: none.
        let plane = fitted(0.1, |_, _| 0.0);
        assert!(plane.strongest == 0.0 && plane.weakest == 0.0, "{plane:?}");
    }

    #[test]
    fn neighbours_on_a_line_fit_nothing() {
        let framed: Vec<Vec3> = (0..10).map(|i| Vec3::X * i as f32 * 0.1).collect();
        let index = KdIndex::new(&framed).unwrap();
        let found = index.nearest_within(Vec3::ZERO, 10, 2.0).unwrap();
        assert_eq!(
            principal_curvatures(Vec3::ZERO, Vec3::Z, &found, &framed),
            None
        );
    }

    #[test]
    fn a_thin_tube_gets_ellipses_narrow_around_it_and_a_flat_sheet_gets_discs() {
        let tube = crate::fixtures::cylinder_points(400, 0.06, 2.0, 5).unwrap();
        let sheet: Vec<Vec3> = (0..400)
            .map(|i| Vec3::new((i % 20) as f32 * 0.05, (i / 20) as f32 * 0.05, 0.0))
            .collect();
        let up = vec![Vec3::Z; sheet.len()];
        for (positions, normals, narrowed) in [
            (tube.positions(), tube.normals().unwrap(), true),
            (&sheet[..], &up[..], false),
        ] {
            let index = KdIndex::new(positions).unwrap();
            let spacing = index.median_spacing().unwrap();
            let all: Vec<usize> = (0..positions.len()).collect();
            let shapes = splat_shapes(
                &index,
                positions,
                (positions, normals, &all),
                spacing,
                1000.0,
            )
            .unwrap();
            let ellipses = shapes.iter().filter(|s| s.minor_radius < s.radius).count();
            if narrowed {
                assert!(ellipses * 10 >= shapes.len() * 9, "{ellipses} ellipses");
                // Their minor axes run around the tube: perpendicular to its axis (y).
                let across = shapes
                    .iter()
                    .filter(|s| s.minor_radius < s.radius)
                    .filter(|s| s.minor_axis.y.abs() < 0.5)
                    .count();
                assert!(across * 10 >= ellipses * 9, "{across} of {ellipses}");
            } else {
                assert_eq!(ellipses, 0);
            }
        }
    }
}
