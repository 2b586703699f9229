//! The surface abstraction shared by point-set surfaces and meshes.

use glam::Vec3;

/// A point on a surface with its unit outward normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Position on the surface.
    pub point: Vec3,
    /// Unit normal at `point`, oriented outward.
    pub normal: Vec3,
}

/// Anything that can answer "which surface point is closest to `q`, and which way is out?".
///
/// Implemented by the MLS point-set surface (`mls-surface`) and by triangle meshes
/// (`distance-field`), so distance fields can be computed from either without the crates
/// depending on each other.
pub trait Surface: Send + Sync {
    /// The closest surface point to `query` with its outward normal, or `None` where the
    /// surface is not defined near `query`.
    fn closest_point(&self, query: Vec3) -> Option<SurfacePoint>;

    /// Signed distance from `query` to the surface (positive on the normal's side) and the
    /// closest point. The default derives both from [`Surface::closest_point`]; the sign comes
    /// from the normal at the closest point.
    fn signed_distance(&self, query: Vec3) -> Option<(f32, SurfacePoint)> {
        let c = self.closest_point(query)?;
        let offset = query - c.point;
        let distance = offset.length();
        let sign = if offset.dot(c.normal) < 0.0 {
            -1.0
        } else {
            1.0
        };
        Some((sign * distance, c))
    }

    /// Like [`Surface::signed_distance`], but only answers when the surface is within
    /// `max_distance` of `query` (`None` otherwise), which lets exact searches prune
    /// everything farther away. The default computes the full answer and filters it.
    fn signed_distance_within(
        &self,
        query: Vec3,
        max_distance: f32,
    ) -> Option<(f32, SurfacePoint)> {
        self.signed_distance(query)
            .filter(|(d, _)| d.abs() <= max_distance)
    }

    /// The distance from `query` to the surface when it is at most `max_distance`
    /// (`None` otherwise, or where the surface is not defined near `query`), unsigned.
    /// The default takes [`Surface::signed_distance_within`]'s magnitude; surfaces whose
    /// sign costs more than their distance (a winding number) answer without it.
    fn distance_within(&self, query: Vec3, max_distance: f32) -> Option<f32> {
        self.signed_distance_within(query, max_distance)
            .map(|(d, _)| d.abs())
    }

    /// [`Surface::signed_distance_within`], and when it has no answer, how far around
    /// `query` that stays so ([`BandAnswer::Beyond`]): grids sampling the surface skip the
    /// nodes inside that clearance without asking. `likely` is a smaller bound the answer
    /// probably lies within (a grid passes its previous node's distance plus a spacing);
    /// surfaces whose search prunes by distance try it first. The default tries `likely`,
    /// then `max_distance`, and promises no clearance.
    fn signed_distance_or_clearance(
        &self,
        query: Vec3,
        max_distance: f32,
        likely: Option<f32>,
    ) -> BandAnswer {
        BandAnswer::from_bounded_search(max_distance, likely, |bound| {
            self.signed_distance_within(query, bound).ok_or(0.0)
        })
    }

    /// This surface prepared for many queries within `reach` of `centre` (a block of grid
    /// nodes): it answers every query exactly as this surface does, bit for bit, and
    /// those near `centre` faster, by gathering once what they share. The one liberty
    /// it may take is a smaller [`BandAnswer::Beyond`] clearance (still a true one),
    /// where it can tell that a query is beyond the bound without working out how far.
    /// `None` (the default) when the surface has nothing to gather or the region is too
    /// large to gain from it; ask the surface itself then.
    fn prepared_near(&self, _centre: Vec3, _reach: f32) -> Option<Box<dyn Surface + '_>> {
        None
    }

    /// The largest reach [`Surface::prepared_near`] prepares for, and gains at: grids
    /// group their nodes into blocks about this far from their centres. `None` (the
    /// default) when preparing gains nothing.
    fn preparation_reach(&self) -> Option<f32> {
        None
    }
}

/// A surface's answer to a query with a distance bound:
/// [`Surface::signed_distance_or_clearance`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BandAnswer {
    /// The surface lies within the bound: the signed distance and the closest point, as
    /// [`Surface::signed_distance_within`] gives them.
    Within {
        /// Signed distance (positive on the normal's side).
        distance: f32,
        /// The closest surface point.
        closest: SurfacePoint,
    },
    /// No answer within the bound, and none for any query closer than `clearance` to this
    /// one (0: no promise beyond this query).
    Beyond {
        /// Radius around the query with no answer within the bound.
        clearance: f32,
    },
}

impl BandAnswer {
    /// The answer of a search that takes a distance bound: `search(bound)` gives the signed
    /// distance and closest point within `bound`, or else a lower bound on the distance (0
    /// when it knows none). `likely` is tried first when it is below `max_distance`, then
    /// `max_distance`; the clearance is how far the lower bound exceeds `max_distance`,
    /// less a relative 1e-5 for rounding.
    pub fn from_bounded_search(
        max_distance: f32,
        likely: Option<f32>,
        search: impl Fn(f32) -> Result<(f32, SurfacePoint), f32>,
    ) -> Self {
        let hinted = likely
            .filter(|&bound| bound < max_distance)
            .and_then(|bound| search(bound).ok());
        match hinted.map_or_else(|| search(max_distance), Ok) {
            Ok((distance, closest)) => Self::Within { distance, closest },
            Err(gap) => Self::Beyond {
                clearance: (gap * (1.0 - 1e-5) - max_distance).max(0.0),
            },
        }
    }

    /// The signed distance and closest point, if within the bound.
    pub fn within(self) -> Option<(f32, SurfacePoint)> {
        match self {
            Self::Within { distance, closest } => Some((distance, closest)),
            Self::Beyond { .. } => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct UnitSphere;
    impl Surface for UnitSphere {
        fn closest_point(&self, q: Vec3) -> Option<SurfacePoint> {
            let n = q.try_normalize()?;
            Some(SurfacePoint {
                point: n,
                normal: n,
            })
        }
    }

    #[test]
    fn default_signed_distance_uses_the_normal_side() {
        let (d, _) = UnitSphere
            .signed_distance(Vec3::new(0.0, 0.0, 3.0))
            .unwrap();
        assert!((d - 2.0).abs() < 1e-6);
        let (d, _) = UnitSphere
            .signed_distance(Vec3::new(0.0, 0.25, 0.0))
            .unwrap();
        assert!((d + 0.75).abs() < 1e-6);
        assert!(UnitSphere.signed_distance(Vec3::ZERO).is_none());
        assert!(
            UnitSphere
                .signed_distance_within(Vec3::new(0.0, 0.0, 3.0), 1.5)
                .is_none()
        );
        assert!(
            UnitSphere
                .signed_distance_within(Vec3::new(0.0, 0.0, 3.0), 2.5)
                .is_some()
        );
    }

    #[test]
    fn the_default_band_answer_tries_the_likely_bound_then_the_band_and_promises_nothing() {
        let q = Vec3::new(0.0, 0.0, 3.0);
        let exact = UnitSphere.signed_distance(q).unwrap();
        // A likely bound too small, one large enough, none, one beyond the band: the same
        // answer within the band.
        for likely in [Some(1.0), Some(2.5), None, Some(9.0)] {
            let answer = UnitSphere.signed_distance_or_clearance(q, 3.0, likely);
            assert_eq!(answer.within(), Some(exact), "{likely:?}");
        }
        assert_eq!(
            UnitSphere.signed_distance_or_clearance(q, 1.5, Some(1.0)),
            BandAnswer::Beyond { clearance: 0.0 }
        );
    }
}
