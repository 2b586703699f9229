//! Points drawn uniformly by area over a mesh: a triangle chosen with probability
//! proportional to its area (Walker's alias method, built by Vose's procedure: one
//! uniform number and one table entry a draw), then a point uniform over it.

use glam::Vec3;
use rand::RngExt;

use crate::rng::SeededRng;
use crate::{Error, Result, TriMesh};

/// A sample: its position, its triangle and the barycentric weights of that triangle's
/// corners.
#[derive(Debug, Clone, Copy)]
pub(super) struct Sample {
    pub(super) position: Vec3,
    pub(super) face: u32,
    pub(super) weights: [f32; 3],
}

/// One column of the alias table: its own triangle is chosen below `keep`, `alias`
/// above.
#[derive(Debug, Clone, Copy)]
struct Column {
    keep: f64,
    alias: u32,
}

/// The triangles of a mesh, chosen with probability proportional to their area.
pub(super) struct FaceChoice {
    columns: Vec<Column>,
    area: f64,
}

impl FaceChoice {
    /// The alias table of `mesh`'s triangle areas.
    ///
    /// Errors: a mesh without triangles, or whose triangles all have zero area.
    pub(super) fn new(mesh: &TriMesh) -> Result<Self> {
        if mesh.face_count() == 0 {
            return Err(Error::EmptyInput {
                what: "the mesh to sample (it has no triangles)".into(),
            });
        }
        let positions = mesh.positions();
        let areas: Vec<f64> = mesh
            .triangles()
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| positions[v as usize].as_dvec3());
                (b - a).cross(c - a).length() * 0.5
            })
            .collect();
        let area: f64 = areas.iter().sum();
        let Some(with_area) = areas.iter().position(|a| *a > 0.0) else {
            let which = match mesh.face_count() {
                1 => "its one triangle has".to_string(),
                n => format!("all {n} of its triangles have"),
            };
            return Err(Error::EmptyInput {
                what: format!("the surface to sample ({which} zero area)"),
            });
        };
        Ok(Self {
            columns: vose(&areas, area, with_area as u32),
            area,
        })
    }

    /// The mesh's area.
    pub(super) fn area(&self) -> f64 {
        self.area
    }

    /// The triangle for a number `u` uniform in `[0, 1)`.
    fn face(&self, u: f64) -> usize {
        let scaled = u * self.columns.len() as f64;
        let column = (scaled as usize).min(self.columns.len() - 1);
        let entry = self.columns[column];
        if scaled - (column as f64) < entry.keep {
            column
        } else {
            entry.alias as usize
        }
    }
}

/// Vose's construction of the alias table of `areas` (summing to `total`). Columns left
/// over when the lists run dry hold rounding residue: they keep their own triangle if it
/// has area, and give every draw to `with_area` (a triangle with area) if not, so a
/// triangle of zero area is never chosen.
fn vose(areas: &[f64], total: f64, with_area: u32) -> Vec<Column> {
    let n = areas.len() as f64;
    let mut share: Vec<f64> = areas.iter().map(|a| a * n / total).collect();
    let mut columns = vec![
        Column {
            keep: 1.0,
            alias: with_area,
        };
        areas.len()
    ];
    let (mut small, mut large): (Vec<u32>, Vec<u32>) =
        (0..areas.len() as u32).partition(|&i| share[i as usize] < 1.0);
    while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
        small.pop();
        columns[s as usize] = Column {
            keep: share[s as usize],
            alias: l,
        };
        share[l as usize] -= 1.0 - share[s as usize];
        if share[l as usize] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    for left in small.into_iter().chain(large) {
        let keep = if areas[left as usize] > 0.0 { 1.0 } else { 0.0 };
        columns[left as usize] = Column {
            keep,
            alias: with_area,
        };
    }
    columns
}

/// Samples drawn uniformly by area from one seeded generator.
pub(super) struct Draws<'m> {
    mesh: &'m TriMesh,
    choice: &'m FaceChoice,
    rng: SeededRng,
}

impl<'m> Draws<'m> {
    /// Draws over `mesh` by `choice` (built from it), from `rng`.
    pub(super) fn new(mesh: &'m TriMesh, choice: &'m FaceChoice, rng: SeededRng) -> Self {
        Self { mesh, choice, rng }
    }

    /// The next sample: a triangle by area, then barycentric weights
    /// `(1 − √r₁, √r₁(1 − r₂), √r₁ r₂)`.
    pub(super) fn next_sample(&mut self) -> Sample {
        let face = self.choice.face(self.rng.random::<f64>());
        let root = self.rng.random::<f64>().sqrt();
        let along = self.rng.random::<f64>();
        let weights = [1.0 - root, root * (1.0 - along), root * along];
        let [a, b, c] = self.mesh.triangles()[face].map(|v| self.mesh.positions()[v as usize]);
        let position = a.as_dvec3()
            + (b.as_dvec3() - a.as_dvec3()) * weights[1]
            + (c.as_dvec3() - a.as_dvec3()) * weights[2];
        Sample {
            position: position.as_vec3(),
            face: face as u32,
            weights: weights.map(|w| w as f32),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::rng_from_seed;

    /// Each triangle's probability as the table gives it: its own columns' `keep` and the
    /// rest of the columns aliased to it, over the number of columns.
    fn probabilities(columns: &[Column]) -> Vec<f64> {
        let mut p = vec![0.0; columns.len()];
        for (i, column) in columns.iter().enumerate() {
            p[i] += column.keep;
            p[column.alias as usize] += 1.0 - column.keep;
        }
        p.iter().map(|x| x / columns.len() as f64).collect()
    }

    #[test]
    fn the_alias_table_gives_each_triangle_its_share_of_the_area() {
        let mut g = rng_from_seed(4);
        for faces in [1usize, 2, 7, 100, 1000] {
            let areas: Vec<f64> = (0..faces)
                .map(|i| {
                    if i % 5 == 3 {
                        0.0
                    } else {
                        g.random::<f64>().powi(4) * 1e3
                    }
                })
                .collect();
            let total: f64 = areas.iter().sum();
            let Some(with_area) = areas.iter().position(|a| *a > 0.0) else {
                continue;
            };
            let columns = vose(&areas, total, with_area as u32);
            for (p, a) in probabilities(&columns).iter().zip(&areas) {
                assert!(
                    (p - a / total).abs() < 1e-12,
                    "{p} for a share {}",
                    a / total
                );
                if *a == 0.0 {
                    assert_eq!(*p, 0.0);
                }
            }
        }
    }
}
