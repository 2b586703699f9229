//! Generalized winding numbers of triangle meshes (Jacobson, Kavan & Sorkine-Hornung 2013),
//! evaluated fast through the mesh's bounding-volume hierarchy (Barill et al. 2018, order 0).
//!
//! The winding number of a query `q` is the signed solid angle the mesh subtends at `q`,
//! over 4π: 1 inside a closed, outward-oriented mesh, 0 outside, and for a mesh with gaps,
//! overlapping parts or several intersecting components, a number that still reads as
//! inside (about 1, or 2 where two parts overlap) or outside (about 0) away from the gaps.
//! That makes it the sign to use on solids modelled as intersecting pieces, like the Utah
//! teapot, where the nearest piece's pseudo-normal is wrong inside the other pieces.
//!
//! **Evaluation.** Each triangle's solid angle is exact (Van Oosterom & Strackee 1983,
//! summed in double precision). A node of the hierarchy whose triangles all lie within
//! `radius` of their area-weighted centre `c` counts as one dipole `A · (c − q) / |c − q|³`
//! (`A` the sum of the triangles' area vectors) when `|c − q| > BETA · radius`; nearer
//! nodes are opened. The error of a dipole falls with the cube of `radius / |c − q|`.

use glam::{DVec3, Vec3};

/// A node is summarized by its dipole beyond this many of its radii (Barill et al. use 2).
pub const BETA: f32 = 2.0;

/// The far-field summary of a hierarchy node's triangles.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Dipole {
    /// Area-weighted centre of the triangles.
    pub centre: Vec3,
    /// Sum of the triangles' area vectors (`½ (b − a) × (c − a)`).
    pub area: Vec3,
    /// Every corner of the node's triangles lies within this distance of `centre`.
    pub radius: f32,
}

impl Dipole {
    /// The dipole of one set of triangles.
    pub fn of_triangles<'a>(triangles: impl Iterator<Item = &'a [Vec3; 3]> + Clone) -> Self {
        let (mut area, mut weighted, mut total) = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
        for [a, b, c] in triangles.clone() {
            let vector = 0.5 * (*b - *a).cross(*c - *a);
            let size = vector.length();
            area += vector;
            weighted += size * (*a + *b + *c) / 3.0;
            total += size;
        }
        let centre = if total > 0.0 {
            weighted / total
        } else {
            let (count, sum) = triangles.clone().fold((0.0f32, Vec3::ZERO), |(n, s), t| {
                (n + 3.0, s + t[0] + t[1] + t[2])
            });
            sum / count.max(1.0)
        };
        let radius = triangles
            .flat_map(|t| t.iter())
            .map(|p| p.distance(centre))
            .fold(0.0f32, f32::max);
        Self {
            centre,
            area,
            radius,
        }
    }

    /// The dipole of oriented samples given as `(position, area vector)` pairs: centre
    /// weighted by area, the area vectors summed.
    pub fn of_points(samples: impl Iterator<Item = (Vec3, Vec3)> + Clone) -> Self {
        let (mut area, mut weighted, mut total, mut count, mut sum) =
            (Vec3::ZERO, Vec3::ZERO, 0.0f32, 0.0f32, Vec3::ZERO);
        for (p, a) in samples.clone() {
            let size = a.length();
            area += a;
            weighted += size * p;
            total += size;
            count += 1.0;
            sum += p;
        }
        let centre = if total > 0.0 {
            weighted / total
        } else {
            sum / count.max(1.0)
        };
        let radius = samples
            .map(|(p, _)| p.distance(centre))
            .fold(0.0f32, f32::max);
        Self {
            centre,
            area,
            radius,
        }
    }

    /// The dipole of two nodes together (the radius bounds both children's corners).
    pub fn join(&self, other: &Self) -> Self {
        let (wa, wb) = (self.area.length(), other.area.length());
        let centre = if wa + wb > 0.0 {
            (wa * self.centre + wb * other.centre) / (wa + wb)
        } else {
            0.5 * (self.centre + other.centre)
        };
        let radius = (self.centre.distance(centre) + self.radius)
            .max(other.centre.distance(centre) + other.radius);
        Self {
            centre,
            area: self.area + other.area,
            radius,
        }
    }

    /// The dipole's solid angle at `q` when `q` is far enough for it, else `None`.
    pub fn far_solid_angle(&self, q: Vec3) -> Option<f64> {
        let offset = (self.centre - q).as_dvec3();
        let distance = offset.length();
        (distance > f64::from(BETA * self.radius) && distance > 0.0)
            .then(|| self.area.as_dvec3().dot(offset) / distance.powi(3))
    }
}

/// The signed solid angle of triangle `abc` seen from `q`: positive on the side its normal
/// `(b − a) × (c − a)` points away from (inside, for an outward-oriented mesh); in
/// `(−2π, 2π]`, 0 in the triangle's plane.
pub fn triangle_solid_angle(q: Vec3, [a, b, c]: [Vec3; 3]) -> f64 {
    let (a, b, c): (DVec3, DVec3, DVec3) =
        ((a - q).as_dvec3(), (b - q).as_dvec3(), (c - q).as_dvec3());
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let numerator = a.dot(b.cross(c));
    let denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * numerator.atan2(denominator)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_subtends_the_analytic_solid_angle_signed_by_its_side() {
        // An octant of the sphere: the triangle (1,0,0), (0,1,0), (0,0,1) seen from the
        // origin subtends 4π/8, and its normal (1,1,1) points away from the origin.
        let t = [Vec3::X, Vec3::Y, Vec3::Z];
        let omega = triangle_solid_angle(Vec3::ZERO, t);
        assert!((omega - std::f64::consts::PI / 2.0).abs() < 1e-6, "{omega}");
        // Reversed, the sign flips; from the far side, too.
        assert!((triangle_solid_angle(Vec3::ZERO, [t[0], t[2], t[1]]) + omega).abs() < 1e-6);
        assert!(
            (triangle_solid_angle(Vec3::splat(1.0), t)
                + triangle_solid_angle(Vec3::splat(1.0), [t[0], t[2], t[1]]))
            .abs()
                < 1e-9
        );
        // In its plane, nothing.
        assert_eq!(
            triangle_solid_angle(Vec3::new(2.0, -1.0, 0.0), [Vec3::ZERO, Vec3::X, Vec3::Y]),
            0.0
        );
    }

    #[test]
    fn a_far_dipole_matches_the_exact_solid_angles() {
        let triangles = [
            [Vec3::ZERO, Vec3::X, Vec3::Y],
            [Vec3::X, Vec3::new(1.0, 1.0, 0.2), Vec3::Y],
        ];
        let dipole = Dipole::of_triangles(triangles.iter());
        assert!(
            dipole.radius > 0.7 && dipole.radius < 1.0,
            "{}",
            dipole.radius
        );
        for q in [Vec3::new(0.5, 0.5, -20.0), Vec3::new(30.0, -4.0, 9.0)] {
            let exact: f64 = triangles.iter().map(|t| triangle_solid_angle(q, *t)).sum();
            let far = dipole.far_solid_angle(q).unwrap_or(f64::NAN);
            assert!(
                (far - exact).abs() < 1e-2 * exact.abs().max(1e-6),
                "{far} vs {exact}"
            );
        }
        // Near, the dipole declines.
        assert_eq!(dipole.far_solid_angle(Vec3::new(0.5, 0.5, 1.0)), None);
        // Joined halves give the whole.
        let halves = Dipole::of_triangles(triangles[..1].iter())
            .join(&Dipole::of_triangles(triangles[1..].iter()));
        assert!((halves.centre - dipole.centre).length() < 1e-6);
        assert!((halves.area - dipole.area).length() < 1e-6);
        assert!(halves.radius >= dipole.radius - 1e-6);
    }
}
