//! The surface read as a height field: the height of its top sheet above points of the XY
//! plane, for writing a sampled sheet (a quilted terrain) back as a height map.

use glam::{Vec2, Vec3};
use pointset_core::{KdIndex, Neighbour};
use rayon::prelude::*;

use crate::Result;
use crate::surface::MlsSurface;

/// Relative slack on the radius within which a column's samples are gathered for its
/// ray: a sample within the support radius of a point of the ray is within it in
/// projection, up to the rounding of the two squared distances.
const COLUMN_SLACK: f32 = 1e-5;

/// How [`MlsSurface::top_heights`] found a column's height.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HeightMethod {
    /// A ray cast straight down met the surface.
    Ray,
    /// The ray met nothing (the column passes through a gap between the samples' kernels):
    /// the projection of the nearest sample's height onto the surface.
    Projection,
}

/// The surface's height above one point of the XY plane ([`MlsSurface::top_heights`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TopHeight {
    /// The height (z).
    pub z: f32,
    /// How it was found.
    pub method: HeightMethod,
}

impl MlsSurface {
    /// The height of the surface's top sheet above each point of `columns` (in the XY
    /// plane; +Z is up), in parallel and in order.
    ///
    /// For each column the samples within the support radius of it in projection bound the
    /// search. Every surface point on the column lies within a support radius of its
    /// weighted centre, a mean of such samples, so a ray cast straight down from a support
    /// radius above the highest of them to a support radius below the lowest meets every
    /// one; its first hit ([`MlsSurface::intersect_ray`]) is the top sheet, even on a
    /// steep wall or where a fold puts two sheets above one point. Where the ray meets
    /// nothing, the nearest sample's height is projected onto the surface. `None` for a
    /// column with no sample within the support radius (a hole) or where neither finds
    /// the surface.
    ///
    /// ```
    /// use glam::{Vec2, Vec3};
    /// use mls_surface::{HeightMethod, MlsParams, MlsSurface};
    /// use pointset_core::PointSet;
    ///
    /// // The plane z = 0.2 x sampled on a 30 × 30 grid, normals up.
    /// let p: Vec<Vec3> = (0..900)
    ///     .map(|i| {
    ///         let (x, y) = ((i % 30) as f32 * 0.1, (i / 30) as f32 * 0.1);
    ///         Vec3::new(x, y, 0.2 * x)
    ///     })
    ///     .collect();
    /// let n = Vec3::new(-0.2, 0.0, 1.0).normalize();
    /// let points = PointSet::new(p)?.with_normals(vec![n; 900])?;
    /// let surface = MlsSurface::new(&points, &MlsParams::default())?;
    ///
    /// let heights = surface.top_heights(&[Vec2::new(1.23, 1.5), Vec2::new(9.0, 9.0)])?;
    /// let top = heights[0].ok_or("no surface")?;
    /// assert!((top.z - 0.246).abs() < 1e-4 && top.method == HeightMethod::Ray);
    /// assert!(heights[1].is_none(), "nothing is sampled near (9, 9)");
    /// Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn top_heights(&self, columns: &[Vec2]) -> Result<Vec<Option<TopHeight>>> {
        let flat: Vec<Vec3> = self.points().iter().map(|p| p.with_z(0.0)).collect();
        let index = KdIndex::new(&flat)?;
        let reach = self.support_radius();
        // The ray's fits read the samples within the support radius of the column in
        // projection, and a little beyond, for the rounding of distances in 3D.
        let gather = reach * (1.0 + COLUMN_SLACK);
        columns
            .par_iter()
            .map(|column| {
                let gathered = index.within(column.extend(0.0), gather)?;
                Ok(self.top_height_among(*column, &gathered))
            })
            .collect()
    }

    /// [`Self::top_heights`] at one column, from the samples `gathered` within a little
    /// more than the support radius of it in projection (nearest first).
    fn top_height_among(&self, column: Vec2, gathered: &[Neighbour]) -> Option<TopHeight> {
        let reach = self.support_radius();
        let within = reach * reach;
        let mut heights = gathered
            .iter()
            .take_while(|n| n.distance_squared <= within)
            .map(|n| self.points()[n.index].z);
        let nearest = heights.next()?;
        let (low, high) = heights.fold((nearest, nearest), |(lo, hi), z| (lo.min(z), hi.max(z)));
        let origin = column.extend(high + reach);
        let length = high - low + 2.0 * reach;
        let candidates: Vec<usize> = gathered.iter().map(|n| n.index).collect();
        if let Some(hit) = self.intersect_ray_among(origin, Vec3::NEG_Z, length, &candidates) {
            return Some(TopHeight {
                z: hit.point.z,
                method: HeightMethod::Ray,
            });
        }
        self.project(column.extend(nearest))
            .filter(|p| p.point.z.is_finite())
            .map(|p| TopHeight {
                z: p.point.z,
                method: HeightMethod::Projection,
            })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use pointset_core::{PointSet, rng};
    use rand::RngExt;

    use super::*;
    use crate::MlsParams;

    /// `height` sampled on a jittered grid of `n × n` points `step` apart, with its normals.
    fn sampled(n: usize, step: f32, height: impl Fn(f32, f32) -> (f32, Vec2)) -> MlsSurface {
        let mut g = rng::rng_from_seed(7);
        let mut jitter = || g.random_range(-0.2..0.2) * step;
        let (mut p, mut normals) = (Vec::new(), Vec::new());
        for k in 0..n * n {
            let x = (k % n) as f32 * step + jitter();
            let y = (k / n) as f32 * step + jitter();
            let (z, gradient) = height(x, y);
            p.push(Vec3::new(x, y, z));
            normals.push((-gradient).extend(1.0).normalize());
        }
        let points = PointSet::new(p).unwrap().with_normals(normals).unwrap();
        MlsSurface::new(&points, &MlsParams::default()).unwrap()
    }

    fn interior_columns(n: usize, step: f32) -> Vec<Vec2> {
        (0..400)
            .map(|k| {
                let t = Vec2::new((k % 20) as f32, (k / 20) as f32) / 19.0;
                (Vec2::splat(0.2) + 0.6 * t) * (n - 1) as f32 * step + 0.013
            })
            .collect()
    }

    #[test]
    fn a_tilted_plane_is_read_back_exactly() {
        let plane = |x: f32, y: f32| (0.3 * x - 0.2 * y + 1.0, Vec2::new(0.3, -0.2));
        let surface = sampled(40, 0.1, plane);
        let columns = interior_columns(40, 0.1);
        for (c, h) in columns.iter().zip(surface.top_heights(&columns).unwrap()) {
            let h = h.unwrap();
            assert_eq!(h.method, HeightMethod::Ray);
            assert!((h.z - plane(c.x, c.y).0).abs() < 1e-4, "{c}: {}", h.z);
        }
    }

    #[test]
    fn waves_are_read_back_within_the_kernels_smoothing() {
        let waves = |x: f32, y: f32| {
            let z = 0.2 * (2.0 * x).sin() * (1.5 * y).cos();
            let dx = 0.4 * (2.0 * x).cos() * (1.5 * y).cos();
            let dy = -0.3 * (2.0 * x).sin() * (1.5 * y).sin();
            (z, Vec2::new(dx, dy))
        };
        let surface = sampled(60, 0.05, waves);
        let columns = interior_columns(60, 0.05);
        let worst = columns
            .iter()
            .zip(surface.top_heights(&columns).unwrap())
            .map(|(c, h)| (h.unwrap().z - waves(c.x, c.y).0).abs())
            .fold(0.0, f32::max);
        // Relief 0.4; the Gaussian kernel flattens the crests by about h²·|∇²z|/4.
        assert!(worst < 2e-3, "worst error {worst}");
    }

    #[test]
    fn the_top_sheet_is_read_where_two_sheets_overlap() {
        let low = sampled(30, 0.1, |_, _| (0.0, Vec2::ZERO));
        let high = sampled(30, 0.1, |_, _| (0.7, Vec2::ZERO));
        let both: Vec<Vec3> = low.points().iter().chain(high.points()).copied().collect();
        let points = PointSet::new(both)
            .unwrap()
            .with_normals(vec![Vec3::Z; 1800])
            .unwrap();
        let surface = MlsSurface::new(&points, &MlsParams::default()).unwrap();
        let columns = interior_columns(30, 0.1);
        for h in surface.top_heights(&columns).unwrap() {
            assert!((h.unwrap().z - 0.7).abs() < 1e-4);
        }
    }

    #[test]
    fn a_columns_hit_is_the_hit_of_the_ray_searching_the_whole_surface() {
        // Steep walls (slopes up to 2.6) far from the origin: the fits along each column's
        // ray read only the samples within reach of the column in projection; the public
        // ray gathers its own from the whole index. Their hits agree bit for bit.
        let offset = Vec2::new(2.0e3, -1.5e3);
        let cliffs = |x: f32, y: f32| {
            let (u, v) = (x - offset.x, y - offset.y);
            let z = 300.0 + 0.3 * (8.0 * u).sin() * (3.0 * v).cos();
            let dz = Vec2::new(
                2.4 * (8.0 * u).cos() * (3.0 * v).cos(),
                -0.9 * (8.0 * u).sin() * (3.0 * v).sin(),
            );
            (z, dz)
        };
        let shifted = |x: f32, y: f32| cliffs(x + offset.x, y + offset.y);
        let local = sampled(50, 0.04, shifted);
        let moved: Vec<Vec3> = local
            .points()
            .iter()
            .map(|p| *p + offset.extend(0.0))
            .collect();
        let points = PointSet::new(moved)
            .unwrap()
            .with_normals(local.normals().to_vec())
            .unwrap();
        let surface = MlsSurface::new(&points, &MlsParams::default()).unwrap();
        let columns: Vec<Vec2> = interior_columns(50, 0.04)
            .iter()
            .map(|c| *c + offset)
            .collect();
        let reach = surface.support_radius();
        let (mut by_ray, mut compared) = (0, 0);
        for (c, h) in columns.iter().zip(surface.top_heights(&columns).unwrap()) {
            let near: Vec<f32> = surface
                .points()
                .iter()
                .filter(|p| p.truncate().distance(*c) <= reach)
                .map(|p| p.z)
                .collect();
            let high = near.iter().copied().fold(f32::MIN, f32::max);
            let low = near.iter().copied().fold(f32::MAX, f32::min);
            let ray = surface.intersect_ray(
                c.extend(high + reach),
                Vec3::NEG_Z,
                high - low + 2.0 * reach,
            );
            if let Some(hit) = ray {
                assert_eq!(
                    h,
                    Some(TopHeight {
                        z: hit.point.z,
                        method: HeightMethod::Ray
                    }),
                    "{c}"
                );
                by_ray += 1;
            } else {
                assert_ne!(h.map(|h| h.method), Some(HeightMethod::Ray), "{c}");
            }
            compared += 1;
        }
        assert!(by_ray > compared * 9 / 10, "{by_ray} of {compared}");
    }

    #[test]
    fn columns_far_from_every_sample_have_no_height() {
        let surface = sampled(20, 0.1, |_, _| (0.0, Vec2::ZERO));
        let reach = surface.support_radius();
        let columns = [Vec2::new(1.0, 1.0), Vec2::new(1.9 + 1.5 * reach, 1.0)];
        let heights = surface.top_heights(&columns).unwrap();
        assert!(heights[0].is_some());
        assert!(heights[1].is_none());
    }
}
