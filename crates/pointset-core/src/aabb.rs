//! Axis-aligned bounding boxes.

use glam::Vec3;

use crate::{Error, Result};

/// The widest extent, along any axis, of positions that the workspace's `f32` distance
/// arithmetic handles: squared distances overflow `f32` once two points lie about 1.8e19
/// apart, and sums of squares over three axes and kernel weights need a margin below that.
/// Surfaces, indices and textures refuse wider inputs with [`Error::SpanTooLarge`]
/// ([`check_span`]) instead of computing infinities and NaNs. Positions far from the
/// origin but close together are fine (and `io` reading can recentre them).
pub const MAX_SPAN: f32 = 1e18;

/// The widest extent of `positions` along an axis (0 for none), or
/// [`Error::SpanTooLarge`] when it exceeds [`MAX_SPAN`] (an infinite span, from
/// coordinates near `f32::MAX` of both signs, included). `what` names the positions in the
/// message.
///
/// ```
/// use glam::Vec3;
/// use pointset_core::check_span;
///
/// assert_eq!(check_span(&[Vec3::ZERO, Vec3::new(1e6, 2.0, 0.0)], "points")?, 1e6);
/// let err = check_span(&[Vec3::ZERO, Vec3::new(1e25, 0.0, 0.0)], "points").unwrap_err();
/// assert!(err.to_string().contains("rescale"));
/// # Ok::<(), pointset_core::Error>(())
/// ```
pub fn check_span(positions: &[Vec3], what: &str) -> Result<f32> {
    let Some(bounds) = Aabb::from_points(positions) else {
        return Ok(0.0);
    };
    let span = (bounds.max - bounds.min).max_element();
    if span <= MAX_SPAN {
        return Ok(span);
    }
    Err(Error::SpanTooLarge {
        what: what.to_string(),
        span,
    })
}

/// An axis-aligned box `[min, max]` (closed on both sides).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Aabb {
    /// A box from two corners, in any order.
    pub fn new(a: Vec3, b: Vec3) -> Self {
        Self {
            min: a.min(b),
            max: a.max(b),
        }
    }

    /// The smallest box containing every point, or `None` for an empty slice.
    pub fn from_points(points: &[Vec3]) -> Option<Self> {
        let first = *points.first()?;
        Some(
            points
                .iter()
                .fold(Self::new(first, first), |b, &p| b.including(p)),
        )
    }

    /// This box grown to include `p`.
    pub fn including(self, p: Vec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The smallest box containing both boxes.
    pub fn union(self, other: Self) -> Self {
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// The box grown by `margin` on every side (shrunk for negative margins, never inverted).
    pub fn inflated(self, margin: f32) -> Self {
        let min = self.min - Vec3::splat(margin);
        let max = self.max + Vec3::splat(margin);
        let center = self.center();
        Self {
            min: min.min(center),
            max: max.max(center),
        }
    }

    /// Edge lengths.
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Length of the diagonal.
    pub fn diagonal(&self) -> f32 {
        self.extent().length()
    }

    /// Whether `p` lies inside or on the boundary.
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Whether the two boxes share at least one point.
    pub fn intersects(&self, other: &Self) -> bool {
        self.min.cmple(other.max).all() && other.min.cmple(self.max).all()
    }

    /// Squared distance from `p` to the box (zero inside).
    pub fn distance_squared(&self, p: Vec3) -> f32 {
        let d = (self.min - p).max(p - self.max).max(Vec3::ZERO);
        d.length_squared()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn from_points_bounds_every_point() {
        let pts = [Vec3::new(1.0, -2.0, 3.0), Vec3::new(-1.0, 5.0, 0.0)];
        let b = Aabb::from_points(&pts).unwrap();
        assert_eq!(b.min, Vec3::new(-1.0, -2.0, 0.0));
        assert_eq!(b.max, Vec3::new(1.0, 5.0, 3.0));
        assert!(pts.iter().all(|&p| b.contains(p)));
        assert!(Aabb::from_points(&[]).is_none());
    }

    #[test]
    fn spans_up_to_the_limit_pass_and_wider_ones_are_refused() {
        let at = |x: f32| [Vec3::ZERO, Vec3::new(0.0, x, 0.0)];
        assert!(check_span(&at(MAX_SPAN), "points").is_ok());
        assert!(check_span(&[], "points").is_ok());
        // Far from the origin but close together: fine; far apart: refused.
        let far = Vec3::splat(1e12);
        assert!(check_span(&[far, far + Vec3::X * 1e6], "points").is_ok());
        assert!(check_span(&[far, -far], "points").is_ok());
        assert!(check_span(&[far * 1e7, -far * 1e7], "points").is_err());
        for wide in [2.0 * MAX_SPAN, 1e25, f32::MAX] {
            match check_span(&at(wide), "points") {
                Err(Error::SpanTooLarge { span, .. }) => assert_eq!(span, wide),
                other => panic!("span {wide}: {other:?}"),
            }
        }
        // Both signs near f32::MAX: the extent itself overflows to infinity.
        let both = [Vec3::splat(-f32::MAX), Vec3::splat(f32::MAX)];
        assert!(matches!(
            check_span(&both, "points"),
            Err(Error::SpanTooLarge { span, .. }) if span == f32::INFINITY
        ));
    }

    #[test]
    fn distance_and_intersection() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(b.distance_squared(Vec3::splat(0.5)), 0.0);
        assert!((b.distance_squared(Vec3::new(3.0, 0.5, 0.5)) - 4.0).abs() < 1e-6);
        assert!(b.intersects(&Aabb::new(Vec3::splat(1.0), Vec3::splat(2.0))));
        assert!(!b.intersects(&Aabb::new(Vec3::splat(1.1), Vec3::splat(2.0))));
        let shrunk = b.inflated(-10.0);
        assert!(shrunk.min.cmple(shrunk.max).all());
    }
}
