//! The points of a [`KdIndex`] around one place, gathered once for many queries near it.

use glam::Vec3;

use super::kd_index::{KdIndex, Neighbour, key_index, nearness_key};
use crate::Result;

/// Relative slack on a ball's extent before a region counts it as covered: computed
/// distances carry a relative rounding error of a few units in the last place (about
/// 1e-7), so a ball that fits with this margin holds no point the region lacks.
const COVER_MARGIN: f32 = 1e-5;

/// The indexed points within `reach` of a centre, gathered with one query of a
/// [`KdIndex`]. It answers [`KdRegion::within`] and [`KdRegion::nearest_one`] exactly as
/// the index does — the same points, in the same order, the same point among equally near
/// ones — from its own points where the query's ball provably lies inside the region, and
/// by asking the index otherwise. Many queries close together (the nodes of a grid row,
/// the iterates of a projection) then cost one tree search and a scan of a short list
/// each, instead of a tree search each.
///
/// ```
/// use glam::Vec3;
/// use pointset_core::KdIndex;
///
/// let points: Vec<Vec3> = (0..1000)
///     .map(|i| Vec3::new((i % 10) as f32, ((i / 10) % 10) as f32, (i / 100) as f32) * 0.1)
///     .collect();
/// let index = KdIndex::new(&points)?;
/// let region = index.region(Vec3::splat(0.45), 0.3)?;
/// for q in [Vec3::splat(0.45), Vec3::new(0.4, 0.5, 0.42), Vec3::splat(2.0)] {
///     assert_eq!(region.within(q, 0.12)?, index.within(q, 0.12)?);
///     assert_eq!(region.nearest_one(q)?, index.nearest_one(q)?);
/// }
/// # Ok::<(), pointset_core::Error>(())
/// ```
pub struct KdRegion<'i> {
    index: &'i KdIndex,
    centre: Vec3,
    reach: f32,
    /// The members' coordinates, one array per axis, for scans [`LANES`] members at a
    /// time; padded to whole chunks with infinite coordinates, which are infinitely far
    /// from every query.
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
    /// The members' indices in the index, in the order of the coordinates (no padding).
    members: Vec<u32>,
}

/// Members scanned side by side.
const LANES: usize = 8;

/// `values`, padded with infinities to a whole number of [`LANES`].
fn padded(values: impl ExactSizeIterator<Item = f32>) -> Vec<f32> {
    let n = values.len();
    values
        .chain(std::iter::repeat_n(
            f32::INFINITY,
            n.next_multiple_of(LANES) - n,
        ))
        .collect()
}

/// Per lane of a scan for the nearest member: the least squared distance so far, the
/// first member at it, and whether a later member matched it.
struct Lanes {
    least: [f32; LANES],
    first: [usize; LANES],
    tied: [bool; LANES],
}

impl Default for Lanes {
    fn default() -> Self {
        Self {
            least: [f32::INFINITY; LANES],
            first: [usize::MAX; LANES],
            tied: [false; LANES],
        }
    }
}

impl Lanes {
    /// Member `m` at squared distance `d2`, in lane `l`.
    fn offer(&mut self, l: usize, d2: f32, m: usize) {
        let nearer = d2 < self.least[l];
        self.tied[l] = !nearer && (self.tied[l] || d2 == self.least[l]);
        self.first[l] = if nearer { m } else { self.first[l] };
        self.least[l] = if nearer { d2 } else { self.least[l] };
    }
}

/// [`KdRegion::nearest_one_up_to`]'s answer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NearestUpTo {
    /// What [`KdIndex::nearest_one`] gives: the nearest point, `None` for an empty index.
    Found(Option<Neighbour>),
    /// Every point lies at least `at_least` from the query, and that is over the bound.
    Farther {
        /// A distance no point comes nearer than.
        at_least: f32,
    },
}

/// The members' least distance to a query ([`KdRegion::unique_nearest_member`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct NearestMember {
    /// The least squared distance, infinite for no members.
    least_squared: f32,
    /// The member at that distance and its squared distance, `None` when there are no
    /// members or two or more share the least distance.
    unique: Option<(f32, u32)>,
}

impl std::fmt::Debug for KdRegion<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KdRegion")
            .field("centre", &self.centre)
            .field("reach", &self.reach)
            .field("members", &self.members.len())
            .finish()
    }
}

impl KdIndex {
    /// The points within `reach` of `centre`, gathered for queries near it
    /// ([`KdRegion`]). Errors: a non-finite centre, a negative or non-finite reach.
    pub fn region(&self, centre: Vec3, reach: f32) -> Result<KdRegion<'_>> {
        let members: Vec<u32> = self
            .within_unsorted(centre, reach)?
            .map(|(i, _)| i)
            .collect();
        let points = self.points();
        Ok(KdRegion {
            index: self,
            centre,
            reach,
            xs: padded(members.iter().map(|&i| points[i as usize].x)),
            ys: padded(members.iter().map(|&i| points[i as usize].y)),
            zs: padded(members.iter().map(|&i| points[i as usize].z)),
            members,
        })
    }
}

impl KdRegion<'_> {
    /// Number of gathered points.
    pub fn len(&self) -> usize {
        self.members.len()
    }

    /// Whether no indexed point lies within the reach.
    pub fn is_empty(&self) -> bool {
        self.members.is_empty()
    }

    /// Whether every point within `radius` of `q` is a member (with [`COVER_MARGIN`]).
    fn covers(&self, q: Vec3, radius: f32) -> bool {
        (q.distance(self.centre) + radius) * (1.0 + COVER_MARGIN) <= self.reach
    }

    /// [`KdIndex::within`]: every point within `radius` of `q` (inclusive), nearest first,
    /// ties to the lower index. Errors as the index's.
    pub fn within(&self, q: Vec3, radius: f32) -> Result<Vec<Neighbour>> {
        if !(q.is_finite() && radius.is_finite() && radius >= 0.0 && self.covers(q, radius)) {
            return self.index.within(q, radius);
        }
        let r2 = radius * radius;
        let mut keys = Vec::new();
        self.scan(q, |first, d2| {
            for (l, &d2) in d2.iter().enumerate() {
                // Padding is infinitely far, but so is a radius whose square overflows:
                // only members are read.
                if d2 <= r2
                    && let Some(&member) = self.members.get(first + l)
                {
                    keys.push(nearness_key(d2, member));
                }
            }
        });
        keys.sort_unstable();
        Ok(keys
            .into_iter()
            .map(|key| Neighbour {
                index: key_index(key) as usize,
                distance_squared: f32::from_bits((key >> 32) as u32),
            })
            .collect())
    }

    /// [`KdIndex::nearest_one`]: the nearest point to `q`. Answered from the members when
    /// the nearest of them is the only one at its distance and the ball through it lies
    /// inside the region; the index answers otherwise, so among equally near points it
    /// picks the one the index picks. Errors as the index's.
    pub fn nearest_one(&self, q: Vec3) -> Result<Option<Neighbour>> {
        match self.nearest_one_up_to(q, f32::INFINITY)? {
            NearestUpTo::Found(found) => Ok(found),
            // No distance exceeds an infinite bound.
            NearestUpTo::Farther { .. } => self.index.nearest_one(q),
        }
    }

    /// [`KdRegion::nearest_one`], unless the members show that every point lies farther
    /// than `bound` from `q`: then [`NearestUpTo::Farther`] with a distance over `bound`
    /// that no point comes nearer than, without asking the index. Errors as the index's.
    pub fn nearest_one_up_to(&self, q: Vec3, bound: f32) -> Result<NearestUpTo> {
        if !q.is_finite() {
            return self.index.nearest_one(q).map(NearestUpTo::Found);
        }
        let nearest = self.unique_nearest_member(q);
        if let Some((d2, i)) = nearest.unique
            && self.covers(q, d2.sqrt())
        {
            return Ok(NearestUpTo::Found(Some(Neighbour {
                index: i as usize,
                distance_squared: d2,
            })));
        }
        // Points outside the region lie beyond `reach` of the centre; the factors take
        // the rounding of computed distances (relative 1e-6 at most) off both terms.
        let outside =
            self.reach * (1.0 - COVER_MARGIN) - q.distance(self.centre) * (1.0 + COVER_MARGIN);
        let members = nearest.least_squared.sqrt() * (1.0 - COVER_MARGIN);
        let floor = outside.min(members);
        if floor > bound {
            return Ok(NearestUpTo::Farther { at_least: floor });
        }
        self.index.nearest_one(q).map(NearestUpTo::Found)
    }

    /// Calls `visit(first, d2)` for each chunk of [`LANES`] members from member `first` on,
    /// with their squared distances to `q` computed as `(p - q).length_squared()` and the
    /// index compute them (`dx² + dy² + dz²`, in that order), bit for bit.
    fn scan(&self, q: Vec3, mut visit: impl FnMut(usize, &[f32; LANES])) {
        let (xs, _) = self.xs.as_chunks::<LANES>();
        let (ys, _) = self.ys.as_chunks::<LANES>();
        let (zs, _) = self.zs.as_chunks::<LANES>();
        for (chunk, ((x, y), z)) in xs.iter().zip(ys).zip(zs).enumerate() {
            let d2: [f32; LANES] = std::array::from_fn(|l| {
                let (dx, dy, dz) = (x[l] - q.x, y[l] - q.y, z[l] - q.z);
                dx * dx + dy * dy + dz * dz
            });
            visit(chunk * LANES, &d2);
        }
    }

    /// The members' least squared distance to `q`, and the member at it if it is the
    /// only one there. The members are scanned [`LANES`] at a time, each lane keeping its
    /// least distance, the first member at it, and whether another one matched it.
    fn unique_nearest_member(&self, q: Vec3) -> NearestMember {
        let mut lanes = Lanes::default();
        self.scan(q, |first, d2| {
            for (l, &d2) in d2.iter().enumerate() {
                lanes.offer(l, d2, first + l);
            }
        });
        let least = lanes.least.into_iter().fold(f32::INFINITY, f32::min);
        let mut holders = (0..LANES).filter(|&l| lanes.least[l] == least);
        let unique = match (holders.next(), holders.next()) {
            (Some(l), None) if !lanes.tied[l] => Some((least, self.members[lanes.first[l]])),
            _ => None,
        };
        NearestMember {
            least_squared: least,
            unique,
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use rand::RngExt;

    use super::*;
    use crate::rng;

    /// Jittered points plus exact copies and grid-aligned points, so that ties in distance
    /// occur both among members and across the region's edge.
    fn points() -> Vec<Vec3> {
        let mut g = rng::rng_from_seed(11);
        let mut points: Vec<Vec3> = (0..3000)
            .map(|_| Vec3::new(g.random(), g.random(), 0.2 * g.random::<f32>()))
            .collect();
        points.extend_from_within(0..200);
        points.extend((0..400).map(|i| Vec3::new((i % 20) as f32, (i / 20) as f32, 0.0) * 0.05));
        points
    }

    #[test]
    fn answers_are_the_index_answers_bit_for_bit() {
        let points = points();
        let index = KdIndex::new(&points).unwrap();
        let mut g = rng::rng_from_seed(12);
        let (mut from_members, mut asked, mut farther) = (0, 0, 0);
        for _ in 0..300 {
            let centre = Vec3::new(g.random(), g.random(), 0.3 * g.random::<f32>());
            let reach = 0.3 * g.random::<f32>();
            let region = index.region(centre, reach).unwrap();
            for _ in 0..20 {
                // Queries inside and outside the region, some on the grid's nodes and
                // halfway between them (equidistant from several points).
                let q = match g.random_range(0..3) {
                    0 => centre + (Vec3::new(g.random(), g.random(), g.random()) - 0.5) * reach,
                    1 => (centre / 0.025).round() * 0.025,
                    _ => Vec3::new(g.random(), g.random(), g.random()),
                };
                let radius = 0.2 * g.random::<f32>();
                assert_eq!(
                    region.within(q, radius).unwrap(),
                    index.within(q, radius).unwrap()
                );
                let nearest = region.nearest_one(q).unwrap();
                assert_eq!(nearest, index.nearest_one(q).unwrap(), "{q} in {region:?}");
                // A bounded query finds the same, or a floor over the bound that the
                // nearest point (by brute force) does not come under.
                let bound = 0.3 * g.random::<f32>();
                match region.nearest_one_up_to(q, bound).unwrap() {
                    NearestUpTo::Found(found) => assert_eq!(found, nearest),
                    NearestUpTo::Farther { at_least } => {
                        let least = points
                            .iter()
                            .map(|p| p.distance(q))
                            .fold(f32::MAX, f32::min);
                        assert!(at_least > bound && least >= at_least, "{least} {at_least}");
                        farther += 1;
                    }
                }
                asked += 1;
                if region
                    .unique_nearest_member(q)
                    .unique
                    .is_some_and(|(d2, _)| region.covers(q, d2.sqrt()))
                {
                    from_members += 1;
                }
            }
        }
        // The members answered a good share of the nearest queries themselves.
        assert!(from_members > asked / 10, "{from_members} of {asked}");
        assert!(farther > asked / 100, "{farther} of {asked}");
    }

    /// Among equally near members the region does not choose: the index's traversal
    /// picks one, so the question goes to the index.
    #[test]
    fn equally_near_members_are_left_to_the_index() {
        let points = [Vec3::X, -Vec3::X, Vec3::X, Vec3::Y * 3.0];
        let index = KdIndex::new(&points).unwrap();
        let region = index.region(Vec3::ZERO, 10.0).unwrap();
        assert_eq!(region.len(), 4);
        // Equidistant from two points, and a point with a copy.
        assert_eq!(region.unique_nearest_member(Vec3::ZERO).unique, None);
        assert_eq!(
            region
                .unique_nearest_member(Vec3::new(0.9, 0.0, 0.0))
                .unique,
            None
        );
        let q = Vec3::new(0.0, 2.9, 0.0);
        assert_eq!(
            region.unique_nearest_member(q).unique,
            Some(((Vec3::Y * 3.0 - q).length_squared(), 3))
        );
        for q in [
            Vec3::ZERO,
            Vec3::new(0.9, 0.0, 0.0),
            Vec3::new(0.0, 2.9, 0.0),
        ] {
            assert_eq!(
                region.nearest_one(q).unwrap(),
                index.nearest_one(q).unwrap()
            );
        }
    }

    /// A radius whose square overflows `f32` (the CLI's `reconstruct --kernel 1e30` asked
    /// for one) is infinite to the comparison, as the padding's distances are: the scan
    /// once read past its members there and panicked.
    #[test]
    fn radii_whose_squares_overflow_give_every_point() {
        let mut points = points();
        points.truncate(points.len() - 3);
        let index = KdIndex::new(&points).unwrap();
        let region = index.region(Vec3::splat(0.5), 1e31).unwrap();
        assert_eq!(region.len(), points.len());
        assert_ne!(points.len() % LANES, 0, "the members end inside a chunk");
        for radius in [1e20, 1e30] {
            let within = region.within(Vec3::splat(0.4), radius).unwrap();
            assert_eq!(within, index.within(Vec3::splat(0.4), radius).unwrap());
            assert_eq!(within.len(), points.len());
        }
    }

    #[test]
    fn bad_queries_are_the_index_errors() {
        let points = points();
        let index = KdIndex::new(&points).unwrap();
        let region = index.region(Vec3::splat(0.5), 0.2).unwrap();
        assert!(region.within(Vec3::NAN, 0.1).is_err());
        assert!(region.within(Vec3::splat(0.5), -1.0).is_err());
        assert!(region.nearest_one(Vec3::INFINITY).is_err());
        assert!(index.region(Vec3::NAN, 0.1).is_err());
        assert!(index.region(Vec3::ZERO, f32::NAN).is_err());
        let empty = KdIndex::new(&[]).unwrap();
        let region = empty.region(Vec3::ZERO, 1.0).unwrap();
        assert!(region.is_empty());
        assert_eq!(region.nearest_one(Vec3::ZERO).unwrap(), None);
        assert!(region.within(Vec3::ZERO, 0.5).unwrap().is_empty());
    }
}
