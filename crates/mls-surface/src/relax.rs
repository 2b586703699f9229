//! Point relaxation on the MLS surface (paper 000 §6 post-process): points repel their
//! neighbours tangentially and are re-projected, evening out the sampling density.

use glam::Vec3;
use pointset_core::{KdIndex, Surface, rng::mix64};
use rayon::prelude::*;

use crate::error::{MlsError, Result};
use crate::surface::MlsSurface;

/// Parameters of [`relax`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct RelaxParams {
    /// Number of repel-and-project rounds; default 10.
    pub iterations: usize,
    /// Repulsion radius as a multiple of the median spacing; default 2.
    pub radius_factor: f32,
    /// Step length as a fraction of the median spacing per unit of force; default 0.25.
    /// Each move is capped at half the spacing.
    pub step: f32,
}

impl Default for RelaxParams {
    fn default() -> Self {
        Self {
            iterations: 10,
            radius_factor: 2.0,
            step: 0.25,
        }
    }
}

impl RelaxParams {
    /// Sets the number of rounds (default 10).
    pub fn iterations(mut self, n: usize) -> Self {
        self.iterations = n;
        self
    }

    /// Checks that the radius factor and the step are positive and finite.
    pub fn validate(&self) -> Result<()> {
        for (name, value) in [("radius_factor", self.radius_factor), ("step", self.step)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(MlsError::InvalidParameter {
                    name,
                    value: value.to_string(),
                    expected: "a positive finite number",
                });
            }
        }
        Ok(())
    }

    /// Sets the repulsion radius, a multiple of the median spacing (default 2).
    pub fn radius_factor(mut self, factor: f32) -> Self {
        self.radius_factor = factor;
        self
    }

    /// Sets the step length, a fraction of the median spacing per unit of force (default
    /// 0.25).
    pub fn step(mut self, step: f32) -> Self {
        self.step = step;
        self
    }
}

/// The outcome of [`relax`].
#[derive(Debug, Clone, PartialEq)]
pub struct Relaxed {
    /// Relaxed positions, on the surface.
    pub positions: Vec<Vec3>,
    /// Surface normals at the relaxed positions.
    pub normals: Vec<Vec3>,
    /// Coefficient of variation (std / mean) of nearest-neighbour distances before.
    pub spread_before: f32,
    /// The same after relaxation.
    pub spread_after: f32,
}

/// Coefficient of variation of nearest-neighbour distances (0 for fewer than 2 points).
pub fn nearest_neighbour_spread(points: &[Vec3]) -> Result<f32> {
    if points.len() < 2 {
        return Ok(0.0);
    }
    let index = KdIndex::new(points)?;
    let d: Vec<f64> = points
        .iter()
        .map(|&p| {
            Ok(index
                .nearest(p, 2)?
                .get(1)
                .map_or(0.0, |n| f64::from(n.distance_squared.sqrt())))
        })
        .collect::<Result<_>>()?;
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    if mean <= 0.0 {
        return Ok(0.0);
    }
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / d.len() as f64;
    Ok((var.sqrt() / mean) as f32)
}

/// A deterministic unit vector for separating exactly coincident points `i` and `j`.
fn separation(i: usize, j: usize) -> Vec3 {
    let h = mix64(((i as u64) << 32) ^ j as u64);
    let v = Vec3::new(
        (h & 0xffff) as f32 - 32767.5,
        ((h >> 16) & 0xffff) as f32 - 32767.5,
        ((h >> 32) & 0xffff) as f32 - 32767.5,
    );
    let sign = if i < j { 1.0 } else { -1.0 };
    sign * v.normalize_or_zero()
}

/// Relaxes `positions` on `surface`. Points are first projected onto the surface (those
/// that cannot be are kept where they are, with the normal of the nearest sample). Each round
/// moves every point (in parallel, from the previous round's positions) along the tangent
/// plane, away from neighbours within the repulsion radius with weight `(1 − d/r)²`, then
/// projects it back. Deterministic for any thread count.
pub fn relax(surface: &MlsSurface, positions: &[Vec3], params: &RelaxParams) -> Result<Relaxed> {
    params.validate()?;
    let spread_before = nearest_neighbour_spread(positions)?;
    let initial: Vec<(Vec3, Vec3)> = positions
        .par_iter()
        .map(|&p| match surface.project(p) {
            Some(q) => (q.point, q.normal),
            // Not projectable (too few samples within the support): kept in place with the
            // normal of the nearest sample, which is oriented like the surface there.
            None => (
                p,
                surface
                    .closest_point(p)
                    .map_or(Vec3::Z, |nearest| nearest.normal),
            ),
        })
        .collect();
    let (mut pts, mut nrm): (Vec<Vec3>, Vec<Vec3>) = initial.into_iter().unzip();
    let spacing = KdIndex::new(&pts)?.median_spacing()?;
    if spacing > 0.0 {
        let radius = params.radius_factor * spacing;
        for _ in 0..params.iterations {
            let index = KdIndex::new(&pts)?;
            let moved: Vec<(Vec3, Vec3)> = (0..pts.len())
                .into_par_iter()
                .map(|i| {
                    let p = pts[i];
                    let mut force = Vec3::ZERO;
                    for nb in index.within(p, radius).unwrap_or_default() {
                        if nb.index == i {
                            continue;
                        }
                        let d = nb.distance_squared.sqrt();
                        let dir = if d > 0.0 {
                            (p - pts[nb.index]) / d
                        } else {
                            separation(i, nb.index)
                        };
                        force += (1.0 - d / radius).powi(2) * dir;
                    }
                    let n = nrm[i];
                    let tangential = force - force.dot(n) * n;
                    let step = (params.step * spacing * tangential).clamp_length_max(0.5 * spacing);
                    match surface.project(p + step) {
                        Some(q) => (q.point, q.normal),
                        None => (p, n),
                    }
                })
                .collect();
            (pts, nrm) = moved.into_iter().unzip();
        }
    }
    let spread_after = nearest_neighbour_spread(&pts)?;
    Ok(Relaxed {
        positions: pts,
        normals: nrm,
        spread_before,
        spread_after,
    })
}
