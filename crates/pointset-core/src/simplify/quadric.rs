//! Garland and Heckbert's error quadrics: the sum of squared distances to a set of weighted
//! planes, as a symmetric 4 × 4 form kept in ten numbers, and the point that minimises it.

use glam::{DMat3, DVec3};

/// `Q(p) = pᵀAp + 2b·p + c`: the weighted sum of squared distances from `p` to the planes
/// added to it, with the number of faces' planes among them (`faces`) beside it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Quadric {
    /// `A`'s upper triangle: xx, xy, xz, yy, yz, zz.
    a: [f64; 6],
    b: DVec3,
    c: f64,
    /// How many faces' planes were added, which turns `Q` into a mean squared distance;
    /// the boundary's constraint planes add to `Q` but not to this.
    faces: f64,
}

impl Quadric {
    /// The quadric of the plane through `point` with unit normal `normal`, weighted by
    /// `weight`; `faces` is 1 for a face's plane, 0 for a constraint plane.
    pub(super) fn plane(point: DVec3, normal: DVec3, weight: f64, faces: f64) -> Self {
        let d = -normal.dot(point);
        let n = normal;
        Self {
            a: [
                n.x * n.x,
                n.x * n.y,
                n.x * n.z,
                n.y * n.y,
                n.y * n.z,
                n.z * n.z,
            ]
            .map(|v| v * weight),
            b: n * (d * weight),
            c: d * d * weight,
            faces,
        }
    }

    /// Both quadrics' planes in one.
    pub(super) fn add(&mut self, other: &Quadric) {
        for (a, o) in self.a.iter_mut().zip(other.a) {
            *a += o;
        }
        self.b += other.b;
        self.c += other.c;
        self.faces += other.faces;
    }

    /// The sum of the two.
    pub(super) fn plus(mut self, other: &Quadric) -> Self {
        self.add(other);
        self
    }

    fn matrix(&self) -> DMat3 {
        let [xx, xy, xz, yy, yz, zz] = self.a;
        DMat3::from_cols(
            DVec3::new(xx, xy, xz),
            DVec3::new(xy, yy, yz),
            DVec3::new(xz, yz, zz),
        )
    }

    /// `Q(p)`, never below 0 (rounding can take it a little under).
    pub(super) fn cost(&self, p: DVec3) -> f64 {
        (p.dot(self.matrix() * p) + 2.0 * self.b.dot(p) + self.c).max(0.0)
    }

    /// The root mean square distance from `p` to the faces' planes: `Q(p)` over their
    /// number (0 for a quadric of no face).
    pub(super) fn rms_distance(&self, p: DVec3) -> f64 {
        if self.faces > 0.0 {
            (self.cost(p) / self.faces).sqrt()
        } else {
            0.0
        }
    }

    /// Where `Q` is least, given the edge `a`–`b` it is for: the solution of `Ap = −b`
    /// when `A` is well conditioned and the solution lies within an edge's length of the
    /// edge, else (a flat or a straight neighbourhood, where a line or a plane of points
    /// minimise `Q`) the least of `Q` along the edge. The endpoints are candidates too,
    /// so the choice is never worse than keeping either vertex where it is.
    pub(super) fn best_point(&self, a: DVec3, b: DVec3) -> DVec3 {
        let mut best = (self.cost(a), a);
        let mut consider = |p: DVec3| {
            let cost = self.cost(p);
            if p.is_finite() && cost < best.0 {
                best = (cost, p);
            }
        };
        consider(b);
        consider(self.least_along(a, b));
        if let Some(p) = self.solved() {
            let reach = a.distance(b);
            if p.distance(0.5 * (a + b)) <= reach {
                consider(p);
            }
        }
        best.1
    }

    /// The point of the segment `a`–`b` where `Q` is least.
    fn least_along(&self, a: DVec3, b: DVec3) -> DVec3 {
        let d = b - a;
        let m = self.matrix();
        let curvature = d.dot(m * d);
        if curvature <= 0.0 {
            return 0.5 * (a + b);
        }
        let slope = d.dot(m * a) + self.b.dot(d);
        let t = (-slope / curvature).clamp(0.0, 1.0);
        a + d * t
    }

    /// The solution of `Ap = −b` when `A`'s smallest eigenvalue is at least
    /// [`CONDITION`] times its largest (estimated by the determinant against the trace).
    fn solved(&self) -> Option<DVec3> {
        let m = self.matrix();
        let trace = m.x_axis.x + m.y_axis.y + m.z_axis.z;
        if trace <= 0.0 {
            return None;
        }
        let det = m.determinant();
        // For a positive semi-definite A, det = λ₁λ₂λ₃ ≤ λ_min · (trace)².
        if det <= CONDITION * trace * trace * trace {
            return None;
        }
        let p = m.inverse() * -self.b;
        p.is_finite().then_some(p)
    }
}

/// How well conditioned `A` must be for [`Quadric::best_point`] to solve for the point:
/// its determinant at least this times its trace cubed (so its smallest eigenvalue at
/// least this times the largest). Below it the planes are near a line or a pencil, and
/// the solution runs far along the free direction.
const CONDITION: f64 = 1e-9;

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(v: DVec3) -> DVec3 {
        v.normalize()
    }

    #[test]
    fn a_plane_s_quadric_is_the_squared_distance_times_its_weight() {
        let n = unit(DVec3::new(1.0, 2.0, -2.0));
        let q = Quadric::plane(DVec3::new(0.5, -1.0, 3.0), n, 2.5, 2.5);
        for p in [
            DVec3::ZERO,
            DVec3::new(4.0, 1.0, -7.0),
            DVec3::new(0.5, -1.0, 3.0),
        ] {
            let distance = n.dot(p - DVec3::new(0.5, -1.0, 3.0));
            assert!((q.cost(p) - 2.5 * distance * distance).abs() < 1e-9);
            assert!((q.rms_distance(p) - distance.abs()).abs() < 1e-6);
        }
    }

    #[test]
    fn three_planes_meet_at_the_best_point() {
        let corner = DVec3::new(1.0, -2.0, 0.5);
        let q = Quadric::plane(corner, DVec3::X, 1.0, 1.0)
            .plus(&Quadric::plane(corner, DVec3::Y, 1.0, 1.0))
            .plus(&Quadric::plane(
                corner,
                unit(DVec3::new(0.0, 1.0, 1.0)),
                1.0,
                1.0,
            ));
        let best = q.best_point(corner + DVec3::X * 0.3, corner - DVec3::Y * 0.2);
        assert!(best.distance(corner) < 1e-9, "{best}");
        assert!(q.cost(best) < 1e-12);
    }

    #[test]
    fn on_a_flat_the_best_point_stays_on_the_edge() {
        // One plane: A is singular, every point of the plane is best.
        let q = Quadric::plane(DVec3::ZERO, DVec3::Z, 1.0, 1.0);
        let (a, b) = (DVec3::new(0.0, 0.0, 0.1), DVec3::new(1.0, 0.0, -0.3));
        let best = q.best_point(a, b);
        // The edge crosses the plane a quarter of the way along.
        assert!(best.distance(DVec3::new(0.25, 0.0, 0.0)) < 1e-12, "{best}");
    }

    #[test]
    fn the_best_point_is_never_worse_than_an_endpoint() {
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for _ in 0..500 {
            let mut q = Quadric::default();
            for _ in 0..4 {
                let point = DVec3::new(next(), next(), next());
                let normal = DVec3::new(next(), next(), next()).normalize_or(DVec3::X);
                q.add(&Quadric::plane(point, normal, next() + 0.6, 1.0));
            }
            let (a, b) = (
                DVec3::new(next(), next(), next()),
                DVec3::new(next(), next(), next()),
            );
            let best = q.best_point(a, b);
            assert!(q.cost(best) <= q.cost(a).min(q.cost(b)) + 1e-12);
        }
    }
}
