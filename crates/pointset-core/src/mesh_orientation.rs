//! Making a mesh's triangles agree on which side is out.
//!
//! Meshes exported by some tools, or stitched from pieces, have triangles whose vertex order
//! disagrees with their neighbours'. Every side test built on the triangles' orientation
//! then goes wrong near them: pseudo-normals, winding numbers, face normals for shading.
//! [`TriMesh::consistently_oriented`] repairs that.

use std::collections::VecDeque;

use crate::{Error, PointSet, Result, TriMesh};

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

/// The triangles on every undirected edge, found by sorting: 60 bytes a triangle (1.4 GB
/// for a mesh of 24 million), where a hash map of lists held about 210 (the process's
/// peak fell from 6.4 to 2.7 GB).
struct EdgeFaces {
    /// Per use of an edge by a triangle: the edge's key (its lower vertex in the high
    /// bits), and the triangle's index shifted left three times above the edge's place in
    /// the triangle (two bits) and whether the triangle runs from the lower vertex to the
    /// higher (the low bit). Sorted: an edge's triangles in face order.
    uses: Vec<(u64, u64)>,
    /// Per triangle and edge place, where the use lies in `uses` (`u32::MAX`: an edge of a
    /// repeated vertex, not used).
    position: Vec<[u32; 3]>,
}

impl EdgeFaces {
    /// Every edge of `triangles` with the triangles on it. Refused above `u32::MAX` edge
    /// uses (1.4 billion triangles).
    fn new(triangles: &[[u32; 3]]) -> Result<Self> {
        let mut uses: Vec<(u64, u64)> = triangles
            .iter()
            .enumerate()
            .flat_map(|(face, &t)| {
                face_edges(t).map(move |(place, key, forward)| {
                    let packed = ((face as u64) << 3) | ((place as u64) << 1) | u64::from(forward);
                    (edge_key(key), packed)
                })
            })
            .collect();
        if u32::try_from(uses.len()).is_err() {
            return Err(Error::InvalidParameter {
                name: "triangles",
                value: triangles.len().to_string(),
                expected: "at most 1,431,655,765 to orient (their edges are counted in 32 bits)"
                    .into(),
            });
        }
        uses.sort_unstable();
        let mut position = vec![[u32::MAX; 3]; triangles.len()];
        for (at, &(_, packed)) in uses.iter().enumerate() {
            // At most `u32::MAX` uses, checked above.
            position[(packed >> 3) as usize][((packed >> 1) & 3) as usize] = at as u32;
        }
        Ok(EdgeFaces { uses, position })
    }

    /// The triangles on the edge in place `place` of triangle `face` (itself among
    /// them), in face order, each with whether it runs from the lower vertex to the
    /// higher.
    fn on(&self, face: usize, place: usize) -> impl ExactSizeIterator<Item = (usize, bool)> + '_ {
        let at = self.position[face][place] as usize;
        let key = self.uses[at].0;
        let start = at
            - self.uses[..at]
                .iter()
                .rev()
                .take_while(|u| u.0 == key)
                .count();
        let end = at + self.uses[at..].iter().take_while(|u| u.0 == key).count();
        self.uses[start..end]
            .iter()
            .map(|&(_, packed)| ((packed >> 3) as usize, packed & 1 == 1))
    }
}

/// An undirected edge `(low, high)` as one word.
fn edge_key((low, high): (u32, u32)) -> u64 {
    (u64::from(low) << 32) | u64::from(high)
}

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
        let welded = self.welded_where_needed()?;
        let triangles = welded.triangles();
        let edges = EdgeFaces::new(triangles)?;
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
                for (place, _, forward) in face_edges(triangles[face]) {
                    let faces = edges.on(face, place);
                    if faces.len() != 2 {
                        closed = false;
                        continue;
                    }
                    for (other, other_forward) in faces.filter(|(f, _)| *f != face) {
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

/// The three edges of `t`, each with its place in `t` (0 to 2), its undirected key and
/// whether `t` runs from its lower to its higher vertex. Edges of a repeated vertex are
/// left out.
fn face_edges(t: [u32; 3]) -> impl Iterator<Item = (usize, (u32, u32), bool)> {
    (0..3).filter_map(move |k| {
        let (a, b) = (t[k], t[(k + 1) % 3]);
        (a != b).then_some((k, (a.min(b), a.max(b)), a < b))
    })
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

    proptest::proptest! {
        /// The triangles on each edge, found by sorting, are those a scan of every
        /// triangle finds, in face order and with their directions.
        #[test]
        fn edge_faces_agree_with_a_scan(
            triangles in proptest::collection::vec(proptest::array::uniform3(0u32..7), 0..40),
        ) {
            let edges = EdgeFaces::new(&triangles).unwrap();
            for (face, &t) in triangles.iter().enumerate() {
                for (place, key, _) in face_edges(t) {
                    let scanned: Vec<(usize, bool)> = triangles
                        .iter()
                        .enumerate()
                        .flat_map(|(f, &u)| {
                            face_edges(u).filter(|e| e.1 == key).map(move |e| (f, e.2))
                        })
                        .collect();
                    proptest::prop_assert_eq!(edges.on(face, place).collect::<Vec<_>>(), scanned);
                }
            }
        }
    }

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
    fn triangles_meet_by_position_where_the_file_split_their_vertices() {
        // A square's two triangles, the second turned, with and without their own copies
        // of the shared diagonal (as files split vertices along UV seams).
        let shared = TriMesh::new(
            PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::ONE, Vec3::Y]).unwrap(),
            vec![[0, 1, 2], [0, 3, 2]],
        )
        .unwrap();
        let split = TriMesh::new(
            PointSet::new(vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::ONE,
                Vec3::ZERO,
                Vec3::ONE,
                Vec3::Y,
            ])
            .unwrap(),
            vec![[0, 1, 2], [3, 5, 4]],
        )
        .unwrap();
        assert!(split.has_coincident_vertices() && !shared.has_coincident_vertices());
        for (mesh, turned) in [(&shared, [0, 2, 3]), (&split, [3, 4, 5])] {
            let (fixed, change) = mesh.consistently_oriented().unwrap();
            // They agree once the second is turned (a tie: the first one's way is kept).
            assert_eq!(fixed.triangles()[1], turned);
            assert_eq!((change.flipped_faces, change.parts), (1, 1));
            // The vertices are the file's, split or not.
            assert_eq!(fixed.vertices(), mesh.vertices());
        }
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
