//! Exact closest points and signed distances to triangle meshes: a bounding-volume
//! hierarchy over the triangles and angle-weighted pseudo-normals for the sign
//! (Bærentzen & Aanæs 2005).
//!
//! **Sign rule.** The sign of `q`'s distance is the sign of `(q − c) · N`, where `c` is the
//! closest point and `N` the pseudo-normal of the feature `c` lies on: the face normal inside
//! a face, the sum of the incident face normals on an edge, the angle-weighted sum of incident
//! face normals at a vertex. On closed, consistently oriented meshes this is exactly
//! inside/outside. On open meshes it tells which side of the *nearest* surface piece `q` is
//! on (boundary edges use their single face's normal), which is the useful answer for
//! terrain-like or partial geometry. Solids built from intersecting or nearly closed
//! pieces are signed right by generalized winding numbers instead ([`MeshSign`],
//! [`crate::winding`]).

use glam::Vec3;
use pointset_core::{Aabb, BandAnswer, Surface, SurfacePoint, TriMesh};
use rayon::prelude::*;

use crate::bvh::{Bvh, Node, NodeStack};
use crate::error::{FieldError, Result};
use crate::triangle::{Feature, closest_point};
use crate::winding::{Dipole, triangle_solid_angle};

/// Triangles per BVH leaf.
const LEAF_SIZE: usize = 4;

/// The closest point on a mesh to a query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshHit {
    /// Closest point.
    pub point: Vec3,
    /// Triangle it lies on.
    pub triangle: usize,
    /// Squared distance to the query.
    pub distance_squared: f32,
    /// Pseudo-normal of the closest feature (unit).
    pub pseudo_normal: Vec3,
}

/// Which rule signs a mesh's distances.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum MeshSign {
    /// The side of the closest feature's pseudo-normal (the module docs): exact on closed,
    /// consistently oriented meshes, and on open sheets the side of the nearest piece.
    #[default]
    PseudoNormal,
    /// Inside where the generalized winding number exceeds ½ ([`crate::winding`]): right
    /// on solids built from intersecting or overlapping pieces and on nearly closed meshes
    /// with small gaps; an open sheet has no inside by it (everything is outside).
    WindingNumber,
}

/// Edge pseudo-normals: for each triangle's edges `(v0, v1)`, `(v1, v2)`, `(v2, v0)`, the
/// sum of the normals of every triangle using that edge, normalized (the triangle's own
/// normal where the sum vanishes). Edge uses are sorted by edge and then by triangle, so
/// each sum runs in triangle order whatever the threads; sorting takes a fraction of the
/// time a hash map of edges took on large meshes (2 million triangles: docs/performance.md).
fn edge_pseudo_normals(tris: &[[u32; 3]], face_normals: &[Vec3]) -> Vec<[Vec3; 3]> {
    let mut uses: Vec<(u64, usize)> = tris
        .par_iter()
        .enumerate()
        .flat_map_iter(|(t, tri)| {
            (0..3).map(move |k| {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                ((u64::from(a.min(b)) << 32) | u64::from(a.max(b)), 3 * t + k)
            })
        })
        .collect();
    uses.par_sort_unstable();
    let mut normals = vec![[Vec3::ZERO; 3]; tris.len()];
    for edge in uses.chunk_by(|x, y| x.0 == y.0) {
        let sum = edge
            .iter()
            .fold(Vec3::ZERO, |sum, &(_, u)| sum + face_normals[u / 3]);
        for &(_, u) in edge {
            normals[u / 3][u % 3] = sum.try_normalize().unwrap_or(face_normals[u / 3]);
        }
    }
    normals
}

/// A triangle mesh prepared for closest-point and signed-distance queries.
#[derive(Debug, Clone)]
pub struct MeshSurface {
    corners: Vec<[Vec3; 3]>,
    face_normals: Vec<Vec3>,
    edge_normals: Vec<[Vec3; 3]>,
    vertex_normals: Vec<[Vec3; 3]>,
    bvh: Bvh,
    /// Far-field summaries of the hierarchy's nodes, for winding numbers.
    dipoles: Vec<Dipole>,
    sign: MeshSign,
    /// The power of two the mesh is stored multiplied by (corners, hierarchy, dipoles),
    /// bringing its extent into `[1, 2)`: closest-point arithmetic multiplies four
    /// lengths together, which overflows `f32` for triangles a few billion units long
    /// and vanishes for tiny ones. The scaling is exact, so at ordinary sizes every answer
    /// is bit for bit the unscaled one. Queries are scaled on the way in, answers back.
    scale: f32,
}

impl MeshSurface {
    /// Prepares `mesh` (degenerate triangles are skipped). Errors when no triangle remains,
    /// and when the vertices span more than [`pointset_core::MAX_SPAN`].
    pub fn new(mesh: &TriMesh) -> Result<Self> {
        let span = pointset_core::check_span(mesh.positions(), "mesh vertices")?;
        let degenerate: std::collections::HashSet<usize> =
            mesh.degenerate_faces().into_iter().collect();
        let tris: Vec<[u32; 3]> = mesh
            .triangles()
            .iter()
            .enumerate()
            .filter(|(i, _)| !degenerate.contains(i))
            .map(|(_, t)| *t)
            .collect();
        if tris.is_empty() {
            return Err(FieldError::EmptyMesh);
        }
        let pos = mesh.positions();
        let scale = pointset_core::power_of_two_scale(span);
        let corners: Vec<[Vec3; 3]> = tris
            .iter()
            .map(|t| t.map(|v| pos[v as usize] * scale))
            .collect();
        let face_normals: Vec<Vec3> = corners
            .iter()
            .map(|&[a, b, c]| pointset_core::triangle_normal(a, b, c))
            .collect();
        // Vertex pseudo-normals: incident face normals weighted by the incident angle.
        let vertex_acc = mesh.vertex_normals(pointset_core::NormalWeighting::Angle);
        let edge_normals = edge_pseudo_normals(&tris, &face_normals);
        let vertex_normals = tris
            .iter()
            .zip(&face_normals)
            .map(|(t, n)| t.map(|v| vertex_acc[v as usize].try_normalize().unwrap_or(*n)))
            .collect();
        let bvh = Bvh::build(
            corners.len(),
            LEAF_SIZE,
            |t| {
                let [a, b, c] = corners[t];
                Aabb::new(a, b).including(c)
            },
            |t| {
                let [a, b, c] = corners[t];
                (a + b + c) / 3.0
            },
        );
        let dipoles = bvh.dipoles(|items| Dipole::of_triangles(items.iter().map(|&t| &corners[t])));
        Ok(Self {
            corners,
            face_normals,
            edge_normals,
            vertex_normals,
            bvh,
            dipoles,
            sign: MeshSign::default(),
            scale,
        })
    }

    /// This surface with distances signed by `sign` (default [`MeshSign::PseudoNormal`]).
    pub fn with_sign(mut self, sign: MeshSign) -> Self {
        self.sign = sign;
        self
    }

    /// The rule signing this surface's distances.
    pub fn sign_rule(&self) -> MeshSign {
        self.sign
    }

    /// The generalized winding number of the mesh at `q` ([`crate::winding`]): 1 inside
    /// a closed outward-oriented mesh, 0 outside, fractional near gaps; NaN for a
    /// non-finite `q`.
    pub fn winding_number(&self, q: Vec3) -> f32 {
        self.winding_number_scaled(q * self.scale)
    }

    /// [`Self::winding_number`] at `q` in the stored (scaled) coordinates.
    fn winding_number_scaled(&self, q: Vec3) -> f32 {
        self.bvh.winding_number(&self.dipoles, q, |t| {
            triangle_solid_angle(q, self.corners[t])
        })
    }

    /// How many (non-degenerate) triangles lie inside another part of the mesh. From each
    /// triangle's centroid two probes step off along its normal and against it, by a
    /// thousandth of its longest edge. Probes whose closest triangle is their own have
    /// crossed nothing else, and crossing an outward-facing triangle raises the winding
    /// number by 1; so where it does (the triangle faces the way its part does, which a
    /// sliver's rounded normal may not), the outer probe lies just outside its own part,
    /// where a closed, embedded part contributes 0, and a winding number over ½ there
    /// means another part encloses the triangle. Closed parts that intersect or overlap
    /// have such triangles; separate parts and cavities (inner shells facing inward) have
    /// none. Triangles whose probes are nearer another triangle (narrow gaps) are not
    /// counted.
    ///
    /// At most `max_probed` triangles are probed, evenly spread over the mesh (every
    /// `k`-th); returns how many of those lie inside and how many were probed. Each probe
    /// costs two closest-point searches and two winding numbers (about 20 µs on a
    /// 200k-triangle mesh), so a small intersection can go unseen on a large mesh.
    pub fn triangles_inside_other_parts(&self, max_probed: usize) -> (usize, usize) {
        let every = self.corners.len().div_ceil(max_probed.max(1));
        let probed: Vec<usize> = (0..self.corners.len()).step_by(every).collect();
        let inside = probed
            .par_iter()
            .filter(|&&t| {
                let [a, b, c] = self.corners[t];
                let step = 1e-3 * (b - a).length().max((c - b).length()).max((a - c).length());
                let centroid = (a + b + c) / 3.0;
                let probes = [1.0, -1.0].map(|side| centroid + side * step * self.face_normals[t]);
                let own = |probe: Vec3| {
                    self.closest_or_gap(probe, 2.0 * step).is_ok_and(|hit| {
                        hit.triangle == t && hit.distance_squared >= (0.5 * step).powi(2)
                    })
                };
                if !probes.iter().all(|&p| own(p)) {
                    return false;
                }
                let [outer, inner] = probes.map(|p| self.winding_number_scaled(p));
                inner - outer > 0.5 && outer > 0.5
            })
            .count();
        (inside, probed.len())
    }

    /// Number of (non-degenerate) triangles.
    pub fn triangle_count(&self) -> usize {
        self.corners.len()
    }

    /// Bounding box of the mesh.
    pub fn bounds(&self) -> Aabb {
        let stored = self.bvh.bounds();
        Aabb::new(stored.min / self.scale, stored.max / self.scale)
    }

    /// The closest point on the mesh, searching only within distance `bound` (use infinity
    /// for an unbounded search). `None` for a non-finite query or nothing within `bound`.
    pub fn closest(&self, q: Vec3, bound: f32) -> Option<MeshHit> {
        self.closest_or_gap(q * self.scale, bound * self.scale)
            .ok()
            .map(|hit| MeshHit {
                point: hit.point / self.scale,
                distance_squared: hit.distance_squared / self.scale / self.scale,
                ..hit
            })
    }

    /// [`Self::closest`] in the stored (scaled) coordinates, and when nothing lies within
    /// `bound`, a lower bound on the distance to the mesh: the nearest box the search
    /// pruned or triangle it passed over (0 for a non-finite query).
    fn closest_or_gap(&self, q: Vec3, bound: f32) -> std::result::Result<MeshHit, f32> {
        if !q.is_finite() {
            return Err(0.0);
        }
        let mut pruned_d2 = f32::INFINITY;
        let mut best_d2 = if bound.is_finite() {
            bound * bound
        } else {
            f32::INFINITY
        };
        let mut best: Option<(usize, Vec3, Feature)> = None;
        let mut stack = NodeStack::new((0, self.bvh.nodes[0].bounds().distance_squared(q)));
        while let Some((node, d2)) = stack.pop() {
            if d2 > best_d2 {
                pruned_d2 = pruned_d2.min(d2);
                continue;
            }
            match &self.bvh.nodes[node] {
                Node::Leaf { start, end, .. } => {
                    for &t in &self.bvh.order[*start..*end] {
                        let [a, b, c] = self.corners[t];
                        let (p, feature) = closest_point(q, a, b, c);
                        let dist = p.distance_squared(q);
                        if dist < best_d2
                            || (dist == best_d2 && best.is_some_and(|(bt, _, _)| t < bt))
                        {
                            best_d2 = dist;
                            best = Some((t, p, feature));
                        } else {
                            pruned_d2 = pruned_d2.min(dist);
                        }
                    }
                }
                Node::Inner { left, right, .. } => {
                    let dl = self.bvh.nodes[*left].bounds().distance_squared(q);
                    let dr = self.bvh.nodes[*right].bounds().distance_squared(q);
                    // Push the farther child first so the nearer one is explored first.
                    if dl <= dr {
                        stack.push((*right, dr));
                        stack.push((*left, dl));
                    } else {
                        stack.push((*left, dl));
                        stack.push((*right, dr));
                    }
                }
            }
        }
        let Some((t, point, feature)) = best else {
            return Err(pruned_d2.sqrt());
        };
        let pseudo_normal = match feature {
            Feature::Face => self.face_normals[t],
            Feature::Edge(k) => self.edge_normals[t][k],
            Feature::Vertex(k) => self.vertex_normals[t][k],
        };
        Ok(MeshHit {
            point,
            triangle: t,
            distance_squared: best_d2,
            pseudo_normal,
        })
    }

    /// Signed distance to the mesh, signed by [`Self::sign_rule`].
    pub fn signed_distance_to(&self, q: Vec3) -> Option<f32> {
        self.signed_distance_bounded_search(q, f32::INFINITY)
            .ok()
            .map(|(d, _)| d)
    }

    /// The signed distance and closest point within `bound`, or a lower bound on the
    /// distance ([`Self::closest_or_gap`]).
    fn signed_distance_bounded_search(
        &self,
        world: Vec3,
        bound: f32,
    ) -> std::result::Result<(f32, SurfacePoint), f32> {
        let q = world * self.scale;
        let hit = self
            .closest_or_gap(q, bound * self.scale)
            .map_err(|gap| gap / self.scale)?;
        let d = hit.distance_squared.sqrt() / self.scale;
        let inside = match self.sign {
            MeshSign::PseudoNormal => (q - hit.point).dot(hit.pseudo_normal) < 0.0,
            MeshSign::WindingNumber => self.winding_number_scaled(q) > 0.5,
        };
        let sign = if inside { -1.0 } else { 1.0 };
        // The normal reported is the outward direction of the field: the unit offset from
        // the closest point (oriented by the sign), or the face normal on the surface itself.
        let normal = ((q - hit.point) * sign)
            .try_normalize()
            .unwrap_or(self.face_normals[hit.triangle]);
        Ok((
            sign * d,
            SurfacePoint {
                point: hit.point / self.scale,
                normal,
            },
        ))
    }
}

impl Surface for MeshSurface {
    fn closest_point(&self, query: Vec3) -> Option<SurfacePoint> {
        self.signed_distance_bounded_search(query, f32::INFINITY)
            .ok()
            .map(|(_, p)| p)
    }

    fn signed_distance(&self, query: Vec3) -> Option<(f32, SurfacePoint)> {
        self.signed_distance_bounded_search(query, f32::INFINITY)
            .ok()
    }

    fn signed_distance_within(
        &self,
        query: Vec3,
        max_distance: f32,
    ) -> Option<(f32, SurfacePoint)> {
        self.signed_distance_bounded_search(query, max_distance)
            .ok()
    }

    /// The bounded closest-point search alone: no pseudo-normal, no winding number.
    fn distance_within(&self, query: Vec3, max_distance: f32) -> Option<f32> {
        let hit = self
            .closest_or_gap(query * self.scale, max_distance * self.scale)
            .ok()?;
        Some(hit.distance_squared.sqrt() / self.scale)
    }

    /// The `likely` bound first, then `max_distance`; with nothing within it, the
    /// clearance is how much farther the nearest pruned box or passed-over triangle is
    /// ([`BandAnswer::from_bounded_search`]).
    fn signed_distance_or_clearance(
        &self,
        query: Vec3,
        max_distance: f32,
        likely: Option<f32>,
    ) -> BandAnswer {
        BandAnswer::from_bounded_search(max_distance, likely, |bound| {
            self.signed_distance_bounded_search(query, bound)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sum, in triangle order, of the normals of every triangle with the edge `{a, b}`.
    fn brute_force_sum(tris: &[[u32; 3]], normals: &[Vec3], a: u32, b: u32) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for (tri, n) in tris.iter().zip(normals) {
            let has_edge = (0..3).any(|k| {
                let (x, y) = (tri[k], tri[(k + 1) % 3]);
                (x, y) == (a, b) || (x, y) == (b, a)
            });
            if has_edge {
                sum += *n;
            }
        }
        sum
    }

    #[test]
    fn edge_pseudo_normals_sum_every_triangle_on_the_edge() {
        // An octahedron, a fin on one of its edges (three triangles there), a flap with
        // an open edge, and a triangle with its reverse (their normals cancel).
        let p = [
            Vec3::X,
            Vec3::Y,
            Vec3::NEG_X,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
            Vec3::new(2.0, 2.0, 0.3),
            Vec3::new(3.0, 0.0, 1.0),
            Vec3::new(5.0, 5.0, 5.0),
        ];
        let mut tris = vec![
            [0, 1, 4],
            [1, 2, 4],
            [2, 3, 4],
            [3, 0, 4],
            [1, 0, 5],
            [2, 1, 5],
            [3, 2, 5],
            [0, 3, 5],
            [0, 1, 6],
            [0, 6, 7],
        ];
        tris.extend([[6, 7, 8], [6, 8, 7]]);
        let normals: Vec<Vec3> = tris
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| p[v as usize]);
                (b - a).cross(c - a).normalize()
            })
            .collect();
        let edges = edge_pseudo_normals(&tris, &normals);
        for (t, tri) in tris.iter().enumerate() {
            for k in 0..3 {
                let sum = brute_force_sum(&tris, &normals, tri[k], tri[(k + 1) % 3]);
                let expected = sum.try_normalize().unwrap_or(normals[t]);
                assert_eq!(edges[t][k], expected, "triangle {t}, edge {k}");
            }
        }
        // The cancelling pair keeps its own normals on the edge they share alone.
        assert_eq!(edges[10][1], normals[10]);
        assert_eq!(edges[11][1], normals[11]);
    }
}
