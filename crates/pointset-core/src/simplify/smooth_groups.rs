//! The normals of a simplified mesh's faces around each vertex, taken together where the
//! input was smooth and apart where it was creased.
//!
//! A *smooth group* is a set of input vertices whose corners are shaded as one surface.
//! At first, vertices at one position whose normals lie within [`SAME_NORMAL_DEGREES`] of
//! each other form a group (the two sides of a texture seam, say), and vertices at one
//! position with different normals (the sides of a hard edge) form groups of their own.
//! When a collapse merges one vertex into another, their groups join. In the end each
//! vertex's *mean face normal* is the angle-weighted mean normal of the faces whose
//! corners lie in its group.

use glam::Vec3;

use crate::mesh::corner_normal_shares;
use crate::{DisjointSets, NormalWeighting};

/// Normals of vertices at one position that differ by less than this, in degrees, are the
/// same normal written twice (rounded differently, or computed per piece): their corners
/// are shaded as one smooth surface.
pub(super) const SAME_NORMAL_DEGREES: f32 = 1.0;

/// The input's vertices in smooth groups (module docs).
#[derive(Debug)]
pub(super) struct SmoothGroups {
    sets: DisjointSets,
}

impl SmoothGroups {
    /// The first groups of the vertices with `normals`, welded as `welded` says (each
    /// vertex's welded vertex, as the simplification welds them): those welded together
    /// whose normals agree.
    pub(super) fn of(welded: &[u32], normals: &[Vec3]) -> Self {
        let mut sets = DisjointSets::new(welded.len());
        let mut order: Vec<u32> = (0..welded.len() as u32).collect();
        order.sort_unstable_by_key(|&v| welded[v as usize]);
        let min_cos = SAME_NORMAL_DEGREES.to_radians().cos();
        for run in order.chunk_by(|&a, &b| welded[a as usize] == welded[b as usize]) {
            for (i, &a) in run.iter().enumerate() {
                for &b in &run[i + 1..] {
                    if normals[a as usize].dot(normals[b as usize]) >= min_cos {
                        sets.join(a, b);
                    }
                }
            }
        }
        Self { sets }
    }

    /// Vertex `gone` has merged into `keep`: one group from now on.
    pub(super) fn merge(&mut self, keep: usize, gone: usize) {
        self.sets.join(keep as u32, gone as u32);
    }

    /// Each vertex's mean face normal: the angle-weighted mean normal of the `triangles`
    /// (over vertices at `positions`) whose corners lie in its group; zero where those
    /// triangles have no area, or there are none.
    pub(super) fn mean_face_normals(
        mut self,
        positions: &[Vec3],
        triangles: &[[u32; 3]],
    ) -> Vec<Vec3> {
        let mut sums = vec![Vec3::ZERO; positions.len()];
        for triangle in triangles {
            let corners = triangle.map(|v| positions[v as usize]);
            for (&v, share) in triangle
                .iter()
                .zip(corner_normal_shares(corners, NormalWeighting::Angle))
            {
                sums[self.sets.root(v) as usize] += share;
            }
        }
        (0..positions.len() as u32)
            .map(|v| sums[self.sets.root(v) as usize].normalize_or_zero())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_join_equal_normals_of_one_welded_vertex_only() {
        let welded = [0, 0, 0, 0, 1];
        let tilted = Vec3::new(0.0, (0.5f32).to_radians().sin(), 1.0).normalize();
        let normals = [Vec3::Z, tilted, Vec3::Z, Vec3::X, Vec3::Z];
        let mut groups = SmoothGroups::of(&welded, &normals);
        let roots: Vec<u32> = (0..5).map(|v| groups.sets.root(v)).collect();
        // Half a degree apart: one group; a right angle apart, or elsewhere: not.
        assert_eq!(roots, [0, 0, 0, 3, 4]);
    }

    #[test]
    fn a_group_takes_the_mean_of_its_faces_and_a_crease_stays() {
        // Two faces meeting at a right angle along the edge x = 0..1, y = z = 0: the
        // vertices on the edge written twice, once per face, with that face's normal.
        let positions = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ZERO, Vec3::X, Vec3::Z];
        let welded = [0, 1, 2, 0, 1, 3];
        let triangles = [[0, 1, 2], [3, 5, 4]];
        let normals = [Vec3::Z, Vec3::Z, Vec3::Z, Vec3::Y, Vec3::Y, Vec3::Y];
        let creased = SmoothGroups::of(&welded, &normals);
        assert_eq!(creased.mean_face_normals(&positions, &triangles), normals);
        // Merged (as a collapse would), the edge's vertices are shaded across the crease.
        let mut joined = SmoothGroups::of(&welded, &normals);
        joined.merge(0, 3);
        joined.merge(1, 4);
        let mean = joined.mean_face_normals(&positions, &triangles);
        let halfway = Vec3::new(0.0, 1.0, 1.0).normalize();
        for v in [0, 1, 3, 4] {
            assert!(mean[v].abs_diff_eq(halfway, 1e-6), "{v}: {}", mean[v]);
        }
        assert_eq!((mean[2], mean[5]), (Vec3::Z, Vec3::Y));
        // A vertex without faces has no mean.
        let lone = SmoothGroups::of(&welded, &normals);
        assert_eq!(
            lone.mean_face_normals(&positions, &triangles[..1])[3],
            Vec3::ZERO
        );
    }
}
