//! Closest point on a triangle, with the feature (vertex, edge, face) it lies on.

use glam::Vec3;

/// The part of a triangle a closest point lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Feature {
    /// Corner `k`.
    Vertex(usize),
    /// Edge from corner `k` to corner `(k + 1) % 3`.
    Edge(usize),
    /// The interior.
    Face,
}

/// Closest point to `p` on triangle `(a, b, c)` by Voronoi-region classification of `p`
/// against the triangle's vertices, edges and face.
pub(crate) fn closest_point(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> (Vec3, Feature) {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Feature::Vertex(0));
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return (a + t * ab, Feature::Edge(0));
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return (a + t * ac, Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + t * (c - b), Feature::Edge(1));
    }
    let denom = va + vb + vc;
    if denom.abs() <= f32::MIN_POSITIVE {
        // Degenerate (zero-area) triangle: fall back to the closest of its three edges.
        let candidates = [(a, b, 0usize), (b, c, 1), (c, a, 2)];
        let mut best = (a, Feature::Vertex(0), f32::INFINITY);
        for (s, e, k) in candidates {
            let d = e - s;
            let len2 = d.length_squared();
            let t = if len2 > 0.0 {
                ((p - s).dot(d) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let q = s + t * d;
            let dist = q.distance_squared(p);
            if dist < best.2 {
                best = (q, Feature::Edge(k), dist);
            }
        }
        return (best.0, best.1);
    }
    let v = vb / denom;
    let w = vc / denom;
    (a + ab * v + ac * w, Feature::Face)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regions_are_classified() {
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        let (q, f) = closest_point(Vec3::new(0.2, 0.2, 1.0), a, b, c);
        assert_eq!(f, Feature::Face);
        assert!((q - Vec3::new(0.2, 0.2, 0.0)).length() < 1e-6);
        assert_eq!(
            closest_point(Vec3::new(-1.0, -1.0, 0.0), a, b, c),
            (a, Feature::Vertex(0))
        );
        assert_eq!(
            closest_point(Vec3::new(2.0, -0.5, 0.0), a, b, c),
            (b, Feature::Vertex(1))
        );
        assert_eq!(
            closest_point(Vec3::new(0.5, -1.0, 0.0), a, b, c),
            (Vec3::new(0.5, 0.0, 0.0), Feature::Edge(0))
        );
        assert_eq!(
            closest_point(Vec3::new(-1.0, 0.5, 0.0), a, b, c),
            (Vec3::new(0.0, 0.5, 0.0), Feature::Edge(2))
        );
        let (q, f) = closest_point(Vec3::new(1.0, 1.0, 0.0), a, b, c);
        assert_eq!(f, Feature::Edge(1));
        assert!((q - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6);
        let (q, _) = closest_point(Vec3::new(0.5, 1.0, 0.0), a, Vec3::X, Vec3::X * 2.0);
        assert!((q - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-6);
    }
}
