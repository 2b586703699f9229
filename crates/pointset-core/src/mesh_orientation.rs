//! Making a mesh's triangles agree on which side is out.
//!
//! Meshes exported by some tools, or stitched from pieces, have triangles whose vertex order
//! disagrees with their neighbours'. Every side test built on the triangles' orientation
//! then goes wrong near them: pseudo-normals, winding numbers, face normals for shading.
//! [`TriMesh::consistently_oriented`] repairs that.

use std::collections::{HashMap, VecDeque};

use crate::{PointSet, Result, TriMesh};

/// What [`TriMesh::consistently_oriented`] changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Reorientation {
    /// Triangles whose vertex order was reversed.
    pub flipped_faces: usize,
    /// Edge-connected parts (through edges of exactly two triangles).
    pub parts: usize,
    /// Edges between two triangles that could not be made to agree: the part is not
    /// orientable (a Möbius strip) or its edges are shared by more than two triangles in
    /// a way that loops back. 0 for an orientable manifold mesh.
    pub conflicting_edges: usize,
}

/// An undirected edge `(low, high)` and, for each triangle on it, the triangle and whether
/// it runs from `low` to `high`.
type EdgeFaces = HashMap<(u32, u32), Vec<(usize, bool)>>;

impl TriMesh {
    /// The mesh with every edge-connected part's triangles made to agree with their
    /// neighbours (two triangles sharing an edge run along it in opposite directions),
    /// each closed part facing outward (positive signed volume), and each open part
    /// facing the way most of its triangles faced before. Only the vertex order of
    /// triangles changes (`[a, b, c]` becomes `[a, c, b]`); vertices, normals,
    /// attributes and UVs are kept. Triangles are neighbours where they share an edge by
    /// position, so vertices a file splits along UV seams do not cut the mesh into
    /// parts. Edges of more than two triangles do not carry the
    /// orientation across (which of them continue the surface is not known), and a
    /// part that cannot be oriented keeps the orientation first reached, its
    /// disagreeing edges counted in [`Reorientation::conflicting_edges`].
    ///
    /// ```
    /// use glam::Vec3;
    /// use pointset_core::{PointSet, TriMesh};
    ///
    /// // A tetrahedron with one face turned inward.
    /// let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    /// let mesh = TriMesh::new(PointSet::new(p)?, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 3, 2]])?;
    /// assert_eq!(mesh.topology().misoriented_edges, 3);
    /// let (fixed, change) = mesh.consistently_oriented()?;
    /// assert_eq!(fixed.triangles()[3], [1, 2, 3]);
    /// assert_eq!((change.flipped_faces, change.parts), (1, 1));
    /// assert!(fixed.topology().is_closed_manifold());
    /// # Ok::<(), pointset_core::Error>(())
    /// ```
    pub fn consistently_oriented(&self) -> Result<(TriMesh, Reorientation)> {
        // Adjacency by position: vertices a file split along UV seams are one here.
        let welded = self.welded()?;
        let triangles = welded.triangles();
        let edges = edge_faces(triangles);
        let mut flip: Vec<Option<bool>> = vec![None; triangles.len()];
        let mut change = Reorientation::default();
        let mut conflicts = 0usize;
        for seed in 0..triangles.len() {
            if flip[seed].is_some() {
                continue;
            }
            change.parts += 1;
            flip[seed] = Some(false);
            let mut part = vec![seed];
            let mut queue = VecDeque::from([seed]);
            let mut closed = true;
            while let Some(face) = queue.pop_front() {
                let flipped = flip[face] == Some(true);
                for (key, forward) in face_edges(triangles[face]) {
                    let Some(faces) = edges.get(&key) else {
                        continue;
                    };
                    if faces.len() != 2 {
                        closed = false;
                        continue;
                    }
                    for &(other, other_forward) in faces.iter().filter(|(f, _)| *f != face) {
                        // Opposite directions once both flips apply.
                        let wanted = (forward != flipped) == other_forward;
                        match flip[other] {
                            None => {
                                flip[other] = Some(wanted);
                                part.push(other);
                                queue.push_back(other);
                            }
                            Some(actual) if actual != wanted => conflicts += 1,
                            Some(_) => {}
                        }
                    }
                }
            }
            let flipped_here = part.iter().filter(|&&f| flip[f] == Some(true)).count();
            let turn_over = if closed {
                let volume: f64 = part
                    .iter()
                    .map(|&f| signed_volume(welded.vertices(), triangles[f], flip[f] == Some(true)))
                    .sum();
                volume < 0.0
            } else {
                2 * flipped_here > part.len()
            };
            if turn_over {
                for &f in &part {
                    flip[f] = flip[f].map(|x| !x);
                }
            }
        }
        // Each disagreeing edge is met from both of its triangles.
        change.conflicting_edges = conflicts / 2;
        let oriented: Vec<[u32; 3]> = self
            .triangles()
            .iter()
            .zip(&flip)
            .map(|(&[a, b, c], f)| {
                if *f == Some(true) {
                    [a, c, b]
                } else {
                    [a, b, c]
                }
            })
            .collect();
        change.flipped_faces = flip.iter().filter(|f| **f == Some(true)).count();
        let mesh = TriMesh::new(self.vertices().clone(), oriented)?;
        let mesh = match self.uvs() {
            Some(uvs) => mesh.with_uvs(uvs.to_vec())?,
            None => mesh,
        };
        Ok((mesh, change))
    }
}

/// The three edges of `t` as undirected keys, each with whether `t` runs from its lower
/// to its higher vertex. Edges of a repeated vertex are left out.
fn face_edges(t: [u32; 3]) -> impl Iterator<Item = ((u32, u32), bool)> {
    (0..3).filter_map(move |k| {
        let (a, b) = (t[k], t[(k + 1) % 3]);
        (a != b).then_some(((a.min(b), a.max(b)), a < b))
    })
}

/// Every undirected edge with the triangles on it.
fn edge_faces(triangles: &[[u32; 3]]) -> EdgeFaces {
    let mut edges: EdgeFaces = HashMap::new();
    for (face, &t) in triangles.iter().enumerate() {
        for (key, forward) in face_edges(t) {
            edges.entry(key).or_default().push((face, forward));
        }
    }
    edges
}

/// Six times the signed volume of the tetrahedron from the origin to triangle `t`
/// (reversed when `flipped`), in double precision: summed over a closed surface, positive
/// when it faces outward.
fn signed_volume(vertices: &PointSet, t: [u32; 3], flipped: bool) -> f64 {
    let p = vertices.positions();
    let [a, b, c] = t.map(|v| p[v as usize].as_dvec3());
    let volume = a.dot(b.cross(c));
    let volume = if flipped { -volume } else { volume };
    if volume.is_finite() { volume } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use glam::{Vec2, Vec3};

    use super::*;
    use crate::mesh::tests::cube;

    /// `mesh` with the triangles at `which` turned over.
    fn with_flipped(mesh: &TriMesh, which: impl Fn(usize) -> bool) -> TriMesh {
        let triangles = mesh
            .triangles()
            .iter()
            .enumerate()
            .map(|(i, &[a, b, c])| if which(i) { [a, c, b] } else { [a, b, c] })
            .collect();
        let turned = TriMesh::new(mesh.vertices().clone(), triangles).unwrap();
        match mesh.uvs() {
            Some(uvs) => turned.with_uvs(uvs.to_vec()).unwrap(),
            None => turned,
        }
    }

    #[test]
    fn a_closed_mesh_with_faces_turned_any_way_comes_back_facing_out() {
        let cube = cube();
        for pattern in [
            0b0000_0000_0001u32,
            0b1010_1010_1010,
            0b1111_1111_1111,
            0b0110_0001_1100,
        ] {
            let scrambled = with_flipped(&cube, |i| pattern & (1 << i) != 0);
            let (fixed, change) = scrambled.consistently_oriented().unwrap();
            assert_eq!(fixed.triangles(), cube.triangles(), "pattern {pattern:b}");
            assert_eq!(change.flipped_faces, pattern.count_ones() as usize);
            assert_eq!((change.parts, change.conflicting_edges), (1, 0));
        }
        // Two cubes, one inside out: each part is turned on its own.
        let (p, t) = (cube.positions().to_vec(), cube.triangles().to_vec());
        let shifted: Vec<Vec3> = p.iter().map(|&v| v + Vec3::splat(3.0)).collect();
        let both = TriMesh::new(
            PointSet::new([p, shifted].concat()).unwrap(),
            t.iter()
                .copied()
                .chain(t.iter().map(|&[a, b, c]| [a + 8, c + 8, b + 8]))
                .collect(),
        )
        .unwrap();
        let (fixed, change) = both.consistently_oriented().unwrap();
        assert_eq!((change.parts, change.flipped_faces), (2, 12));
        assert!(fixed.topology().is_closed_manifold());
        assert_eq!(
            &fixed.triangles()[12..],
            &t.iter().map(|v| v.map(|i| i + 8)).collect::<Vec<_>>()[..]
        );
    }

    #[test]
    fn an_open_sheet_keeps_the_orientation_most_of_its_triangles_had() {
        // A 4 x 4 grid of quads, two triangles each, all facing +z; then a third turned.
        let p: Vec<Vec3> = (0..25)
            .map(|i| Vec3::new((i % 5) as f32, (i / 5) as f32, 0.0))
            .collect();
        let mut t = Vec::new();
        for j in 0..4u32 {
            for i in 0..4u32 {
                let v = j * 5 + i;
                t.push([v, v + 1, v + 6]);
                t.push([v, v + 6, v + 5]);
            }
        }
        let uvs: Vec<Vec2> = p.iter().map(|v| v.truncate()).collect();
        let sheet = TriMesh::new(PointSet::new(p).unwrap(), t)
            .unwrap()
            .with_uvs(uvs.clone())
            .unwrap();
        let scrambled = with_flipped(&sheet, |i| i % 3 == 0);
        let (fixed, change) = scrambled.consistently_oriented().unwrap();
        assert_eq!(fixed.triangles(), sheet.triangles());
        assert_eq!(fixed.uvs(), Some(&uvs[..]));
        assert_eq!((change.flipped_faces, change.parts), (11, 1));
        assert_eq!(fixed.topology().misoriented_edges, 0);
        // Mostly turned over: the majority's way wins, so the sheet faces -z.
        let (fixed, change) = with_flipped(&sheet, |i| i % 3 != 0)
            .consistently_oriented()
            .unwrap();
        assert_eq!(change.flipped_faces, 11);
        assert!(fixed.face_normals().iter().all(|n| n.z < -0.99));
    }

    #[test]
    fn a_moebius_strip_is_reported_not_looped_over() {
        // A strip of 8 quads whose ends are joined with a half twist.
        let n = 8u32;
        let p: Vec<Vec3> = (0..2 * n)
            .map(|i| {
                let (k, side) = ((i / 2) as f32, if i % 2 == 0 { -0.2 } else { 0.2 });
                let angle = std::f32::consts::TAU * k / n as f32;
                let twist = 0.5 * angle;
                let radial = Vec3::new(angle.cos(), angle.sin(), 0.0);
                radial * (1.0 + side * twist.cos()) + Vec3::Z * side * twist.sin()
            })
            .collect();
        let mut t = Vec::new();
        for k in 0..n {
            let (a, b) = (2 * k, 2 * k + 1);
            let (c, d) = if k + 1 < n {
                (2 * k + 2, 2 * k + 3)
            } else {
                (1, 0)
            };
            t.push([a, c, b]);
            t.push([b, c, d]);
        }
        let strip = TriMesh::new(PointSet::new(p).unwrap(), t).unwrap();
        let (fixed, change) = strip.consistently_oriented().unwrap();
        assert_eq!(change.parts, 1);
        assert_eq!(change.conflicting_edges, 1);
        assert_eq!(fixed.face_count(), strip.face_count());
    }
}
