//! Triangle meshes.

use std::borrow::Cow;

use glam::{Vec2, Vec3};

use crate::weld::PositionWelder;
use crate::{Aabb, DisjointSets, Error, PointSet, Result};

/// How face normals are weighted when averaged into vertex normals.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NormalWeighting {
    /// Weight by triangle area (the cross product's length).
    Area,
    /// Weight by the triangle's interior angle at the vertex (Thürmer & Wüthrich); the
    /// default, as it does not depend on how a flat region is triangulated.
    #[default]
    Angle,
}

/// What a triangle with `corners` adds to each corner's vertex normal, weighted as
/// `weighting` says (zero for a triangle of no area).
pub(crate) fn corner_normal_shares(corners: [Vec3; 3], weighting: NormalWeighting) -> [Vec3; 3] {
    let face = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
    let unit = crate::triangle_normal(corners[0], corners[1], corners[2]);
    std::array::from_fn(|k| match weighting {
        NormalWeighting::Area => face,
        NormalWeighting::Angle => {
            let e1 = crate::unit_vector(corners[(k + 1) % 3] - corners[k]);
            let e2 = crate::unit_vector(corners[(k + 2) % 3] - corners[k]);
            unit * e1.dot(e2).clamp(-1.0, 1.0).acos()
        }
    })
}

/// Edge-based topology of a mesh (see [`TriMesh::topology`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MeshTopology {
    /// Distinct undirected edges.
    pub edges: usize,
    /// Edges used by exactly one face (holes, open borders).
    pub boundary_edges: usize,
    /// Edges used by more than two faces.
    pub non_manifold_edges: usize,
    /// Edges shared by two faces that traverse them in the same direction (inconsistent
    /// orientation).
    pub misoriented_edges: usize,
    /// Connected components (of vertices used by faces).
    pub components: usize,
    /// `V − E + F` over the vertices used by faces (2 per closed sphere-like component).
    pub euler_characteristic: i64,
}

impl MeshTopology {
    /// Whether the mesh is a closed, consistently oriented 2-manifold (every edge in exactly
    /// two faces, traversed once in each direction). A mesh without faces is not: it
    /// bounds nothing.
    pub fn is_closed_manifold(&self) -> bool {
        self.edges > 0
            && self.boundary_edges == 0
            && self.non_manifold_edges == 0
            && self.misoriented_edges == 0
    }
}

/// A triangle on the same three vertices as an earlier one ([`TriMesh::duplicate_faces`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DuplicateFace {
    /// The repeating triangle's index.
    pub face: usize,
    /// The first triangle on the same vertices.
    pub first: usize,
    /// Whether it faces the other way from the first (its corners in the opposite order).
    pub reversed: bool,
}

/// An indexed triangle mesh. Vertices are a [`PointSet`], so they carry optional normals and
/// any named attributes (vertex colours are the `red`, `green`, `blue` channels).
///
/// Invariant: every triangle index is below the vertex count; UVs, when present, are one per
/// vertex and finite. Degenerate triangles are allowed and reported by
/// [`TriMesh::degenerate_faces`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TriMesh {
    vertices: PointSet,
    triangles: Vec<[u32; 3]>,
    uvs: Option<Vec<Vec2>>,
}

impl TriMesh {
    /// A mesh from vertices and triangles; errors on an out-of-range index.
    pub fn new(vertices: PointSet, triangles: Vec<[u32; 3]>) -> Result<Self> {
        let vertex_count = vertices.len();
        for (face, tri) in triangles.iter().enumerate() {
            if let Some(&v) = tri.iter().find(|&&v| v as usize >= vertex_count) {
                return Err(Error::IndexOutOfRange {
                    face,
                    vertex: i64::from(v),
                    vertex_count,
                });
            }
        }
        Ok(Self {
            vertices,
            triangles,
            uvs: None,
        })
    }

    /// Adds per-vertex texture coordinates.
    pub fn with_uvs(mut self, uvs: Vec<Vec2>) -> Result<Self> {
        if uvs.len() != self.vertices.len() {
            return Err(Error::LengthMismatch {
                what: "uvs".into(),
                expected: self.vertices.len(),
                found: uvs.len(),
            });
        }
        if let Some(index) = uvs.iter().position(|uv| !uv.is_finite()) {
            return Err(Error::NonFinite {
                what: "uv".into(),
                index,
            });
        }
        self.uvs = Some(uvs);
        Ok(self)
    }

    /// The vertices (positions, normals, attributes).
    pub fn vertices(&self) -> &PointSet {
        &self.vertices
    }

    /// Vertex positions.
    pub fn positions(&self) -> &[Vec3] {
        self.vertices.positions()
    }

    /// Triangles as vertex index triples.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Per-vertex texture coordinates, if present.
    pub fn uvs(&self) -> Option<&[Vec2]> {
        self.uvs.as_deref()
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.vertices.len()
    }

    /// Number of triangles.
    pub fn face_count(&self) -> usize {
        self.triangles.len()
    }

    /// Bounding box of the vertices, `None` without vertices.
    pub fn bounding_box(&self) -> Option<Aabb> {
        self.vertices.bounding_box()
    }

    /// Corner positions of triangle `face` (which must exist).
    fn corners(&self, tri: &[u32; 3]) -> [Vec3; 3] {
        let p = self.vertices.positions();
        tri.map(|v| p[v as usize])
    }

    /// Indices of triangles with a repeated vertex or (near-)zero area: area below
    /// `1e-12 ·` the squared bounding-box diagonal. Both sides are compared after an exact
    /// rescaling by a power of two ([`crate::power_of_two_scale`]), so the test does not
    /// overflow for large meshes or vanish for tiny ones.
    pub fn degenerate_faces(&self) -> Vec<usize> {
        let diagonal = self.bounding_box().map_or(0.0, |b| b.diagonal());
        let unit = crate::power_of_two_scale(diagonal);
        let scale = diagonal * unit;
        let threshold = 1e-12 * scale * scale;
        self.triangles
            .iter()
            .enumerate()
            .filter(|(_, t)| {
                let [a, b, c] = self.corners(t).map(|p| p * unit);
                t[0] == t[1]
                    || t[1] == t[2]
                    || t[0] == t[2]
                    || (b - a).cross(c - a).length() * 0.5 <= threshold
            })
            .map(|(i, _)| i)
            .collect()
    }

    /// Unit face normals (right-hand rule); zero for degenerate faces.
    pub fn face_normals(&self) -> Vec<Vec3> {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = self.corners(t);
                crate::triangle_normal(a, b, c)
            })
            .collect()
    }

    /// Total surface area.
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = self.corners(t).map(|p| p.as_dvec3());
                (b - a).cross(c - a).length() * 0.5
            })
            .sum()
    }

    /// Unit vertex normals averaged from incident faces. Isolated vertices (or those with
    /// only degenerate faces) get a zero normal.
    pub fn vertex_normals(&self, weighting: NormalWeighting) -> Vec<Vec3> {
        let mut acc = vec![Vec3::ZERO; self.vertex_count()];
        for t in &self.triangles {
            for (&v, share) in t
                .iter()
                .zip(corner_normal_shares(self.corners(t), weighting))
            {
                acc[v as usize] += share;
            }
        }
        acc.into_iter().map(crate::unit_vector).collect()
    }

    /// How many stored vertex normals face against the faces around their vertex: a
    /// negative dot product with the angle-weighted average of those faces' normals
    /// ([`Self::vertex_normals`]). Renderers shade such a vertex as if lit from behind
    /// (dark), whatever the light. Vertices without a stored normal direction or without
    /// faces of any area are not counted; 0 without normals.
    ///
    /// ```
    /// use glam::Vec3;
    /// use pointset_core::{PointSet, TriMesh};
    /// let p = PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y])?
    ///     .with_normals(vec![Vec3::Z, -Vec3::Z, Vec3::X])?;
    /// let mesh = TriMesh::new(p, vec![[0, 1, 2]])?; // faces +z
    /// assert_eq!(mesh.normals_against_faces(), 1); // the second vertex's
    /// # Ok::<(), pointset_core::Error>(())
    /// ```
    pub fn normals_against_faces(&self) -> usize {
        let Some(stored) = self.vertices.normals() else {
            return 0;
        };
        stored
            .iter()
            .zip(self.vertex_normals(NormalWeighting::Angle))
            .filter(|(n, faces)| n.dot(*faces) < 0.0)
            .count()
    }

    /// Stores freshly computed vertex normals in the mesh.
    pub fn compute_normals(&mut self, weighting: NormalWeighting) -> Result<()> {
        let normals = self.vertex_normals(weighting);
        self.vertices.set_normals(Some(normals))
    }

    /// Whether some vertices share a position: whether [`Self::welded`] would merge any.
    /// It sorts a copy of the positions' bits (12 bytes a vertex) instead of building the
    /// welded mesh.
    ///
    /// ```
    /// use glam::Vec3;
    /// use pointset_core::{PointSet, TriMesh};
    /// let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(-0.0, 0.0, 0.0)];
    /// let mesh = TriMesh::new(PointSet::new(p)?, vec![[0, 1, 2], [3, 2, 1]])?;
    /// assert!(mesh.has_coincident_vertices()); // -0 and 0 are one position
    /// # Ok::<(), pointset_core::Error>(())
    /// ```
    pub fn has_coincident_vertices(&self) -> bool {
        crate::weld::any_coincident(self.positions())
    }

    /// The mesh with the vertices that share a position merged into the first of them.
    /// Files that split vertices along UV or normal seams (OBJ readers do, and this one
    /// too) describe the same surface with more vertices, and their [`Self::topology`]
    /// shows the seams as open borders; the welded mesh's shows the surface's. Triangles
    /// keep their order and orientation; normals, UVs and attributes are dropped (they no
    /// longer have one value per vertex).
    ///
    /// ```
    /// use glam::Vec3;
    /// use pointset_core::{PointSet, TriMesh};
    /// // Two triangles of a square, each with its own copy of the shared diagonal.
    /// let p = vec![Vec3::ZERO, Vec3::X, Vec3::ONE, Vec3::ZERO, Vec3::ONE, Vec3::Y];
    /// let split = TriMesh::new(PointSet::new(p)?, vec![[0, 1, 2], [3, 4, 5]])?;
    /// assert_eq!(split.topology().components, 2);
    /// let welded = split.welded()?;
    /// assert_eq!((welded.vertex_count(), welded.triangles()), (4, &[[0, 1, 2], [0, 2, 3]][..]));
    /// assert_eq!(welded.topology().components, 1);
    /// # Ok::<(), pointset_core::Error>(())
    /// ```
    pub fn welded(&self) -> Result<TriMesh> {
        let mut welder = PositionWelder::default();
        let remap: Vec<u32> = self
            .positions()
            .iter()
            .map(|&p| welder.vertex(p))
            .collect::<Result<_>>()?;
        let triangles = self
            .triangles
            .iter()
            .map(|t| t.map(|v| remap[v as usize]))
            .collect();
        TriMesh::new(PointSet::new(welder.into_positions())?, triangles)
    }

    /// [`Self::welded`] where it would merge some vertices; otherwise the mesh itself,
    /// borrowed (welding would give the same positions in the same order and the same
    /// triangles, so a copy would only double what a caller holds). The borrowed mesh
    /// keeps its normals, UVs and attributes; a welded one has none.
    ///
    /// ```
    /// use std::borrow::Cow;
    /// use glam::Vec3;
    /// use pointset_core::{PointSet, TriMesh};
    /// let p = vec![Vec3::ZERO, Vec3::X, Vec3::ONE, Vec3::Y];
    /// let shared = TriMesh::new(PointSet::new(p)?, vec![[0, 1, 2], [0, 2, 3]])?;
    /// assert!(matches!(shared.welded_where_needed()?, Cow::Borrowed(_)));
    /// let p = vec![Vec3::ZERO, Vec3::X, Vec3::ONE, Vec3::ZERO, Vec3::ONE, Vec3::Y];
    /// let split = TriMesh::new(PointSet::new(p)?, vec![[0, 1, 2], [3, 4, 5]])?;
    /// let welded = split.welded_where_needed()?;
    /// assert_eq!(welded.triangles(), shared.triangles());
    /// # Ok::<(), pointset_core::Error>(())
    /// ```
    pub fn welded_where_needed(&self) -> Result<Cow<'_, TriMesh>> {
        if self.has_coincident_vertices() {
            self.welded().map(Cow::Owned)
        } else {
            Ok(Cow::Borrowed(self))
        }
    }

    /// Edge and component counts: what `geosynth info` reports and what tests check for
    /// "closed 2-manifold".
    pub fn topology(&self) -> MeshTopology {
        // Every directed edge `a → b` as one word, `a` in the high bits, sorted by its
        // undirected key (the lower vertex in the high bits): equal keys are the uses of
        // one edge (a sort instead of hash maps: three times faster on millions; 8 bytes a
        // use, 24 a triangle).
        let directed = |a: u32, b: u32| (u64::from(a) << 32) | u64::from(b);
        let undirected = |d: u64| {
            let (a, b) = ((d >> 32) as u32, d as u32);
            directed(a.min(b), a.max(b))
        };
        let runs_forward = |d: &u64| ((d >> 32) as u32) < (*d as u32);
        let mut uses: Vec<u64> = self
            .triangles
            .iter()
            .flat_map(|t| (0..3).map(move |k| directed(t[k], t[(k + 1) % 3])))
            .collect();
        uses.sort_unstable_by_key(|&d| undirected(d));
        let (mut edges, mut boundary, mut non_manifold, mut misoriented) = (0, 0, 0, 0);
        for run in uses.chunk_by(|x, y| undirected(*x) == undirected(*y)) {
            edges += 1;
            let forward = run.iter().filter(|d| runs_forward(d)).count();
            match run.len() {
                1 => boundary += 1,
                2 if forward != 1 => misoriented += 1,
                2 => {}
                _ => non_manifold += 1,
            }
        }
        // Connected components of the vertices used by faces.
        let mut sets = DisjointSets::new(self.vertex_count());
        for t in &self.triangles {
            sets.join(t[0], t[1]);
            sets.join(t[0], t[2]);
        }
        let used = referenced(&self.triangles, self.vertex_count());
        let used_count = used.iter().filter(|&&u| u).count();
        let components = (0..self.vertex_count() as u32)
            .filter(|&v| used[v as usize] && sets.root(v) == v)
            .count();
        MeshTopology {
            edges,
            boundary_edges: boundary,
            non_manifold_edges: non_manifold,
            misoriented_edges: misoriented,
            components,
            euler_characteristic: used_count as i64 - edges as i64 + self.triangles.len() as i64,
        }
    }

    /// Triangles on the same three vertices as an earlier triangle, in face order, each
    /// with the first triangle on those vertices and whether it faces the other way: scans
    /// and mesh repairs leave such twins, often facing opposite ways (a fin of no volume),
    /// which make their edges non-manifold and give their corners no single outside.
    /// Compare by position after [`Self::welded`] when the mesh splits vertices along UV
    /// seams.
    ///
    /// ```
    /// use glam::Vec3;
    /// use pointset_core::{DuplicateFace, PointSet, TriMesh};
    /// let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    /// let faces = vec![[0, 1, 2], [0, 1, 3], [2, 1, 0], [1, 2, 0]];
    /// let mesh = TriMesh::new(PointSet::new(p)?, faces)?;
    /// let twin = |face, reversed| DuplicateFace { face, first: 0, reversed };
    /// assert_eq!(mesh.duplicate_faces(), vec![twin(2, true), twin(3, false)]);
    /// # Ok::<(), pointset_core::Error>(())
    /// ```
    pub fn duplicate_faces(&self) -> Vec<DuplicateFace> {
        // Each triangle's corners in order with its index, sorted: a run of equal corners
        // holds a first triangle and its twins (a sort instead of a hash map, 24 bytes a
        // triangle).
        let mut keyed: Vec<([u32; 3], usize)> = self
            .triangles
            .iter()
            .enumerate()
            .map(|(face, t)| {
                let mut corners = *t;
                corners.sort_unstable();
                (corners, face)
            })
            .collect();
        keyed.sort_unstable();
        let mut duplicates = Vec::new();
        for run in keyed.chunk_by(|x, y| x.0 == y.0) {
            let first = run[0].1;
            let original = self.triangles[first];
            for &(_, face) in &run[1..] {
                let t = self.triangles[face];
                let same_way = (0..3).any(|k| [t[k], t[(k + 1) % 3], t[(k + 2) % 3]] == original);
                duplicates.push(DuplicateFace {
                    face,
                    first,
                    reversed: !same_way,
                });
            }
        }
        duplicates.sort_unstable_by_key(|d| d.face);
        duplicates
    }

    /// How many vertices no triangle uses. Some tools warn about them (MeshLab) or drop
    /// them on load and report a different vertex count; bounding boxes that count them
    /// disagree with those that do not.
    pub fn unreferenced_vertices(&self) -> usize {
        self.vertex_count()
            - referenced(&self.triangles, self.vertex_count())
                .iter()
                .filter(|&&u| u)
                .count()
    }

    /// The mesh with only the triangles `keep` accepts (given each triangle's index and
    /// corners), in order, and only the vertices they use
    /// ([`Self::without_unreferenced_vertices`]: normals, attributes and UVs follow their
    /// vertices).
    ///
    /// ```
    /// use glam::Vec3;
    /// use pointset_core::{PointSet, TriMesh};
    /// let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    /// let mesh = TriMesh::new(PointSet::new(p)?, vec![[0, 1, 2], [0, 1, 3]])?;
    /// let kept = mesh.with_triangles_kept(|i, _| i == 1)?;
    /// assert_eq!(kept.triangles(), &[[0, 1, 2]]);
    /// assert_eq!(kept.positions(), &[Vec3::ZERO, Vec3::X, Vec3::Z]);
    /// # Ok::<(), pointset_core::Error>(())
    /// ```
    pub fn with_triangles_kept(
        &self,
        mut keep: impl FnMut(usize, &[u32; 3]) -> bool,
    ) -> Result<TriMesh> {
        let triangles = self
            .triangles
            .iter()
            .enumerate()
            .filter(|(i, t)| keep(*i, t))
            .map(|(_, t)| *t)
            .collect();
        let mesh = TriMesh::new(self.vertices.clone(), triangles)?;
        let mesh = match &self.uvs {
            Some(uvs) => mesh.with_uvs(uvs.clone())?,
            None => mesh,
        };
        mesh.without_unreferenced_vertices()
    }

    /// The mesh without the vertices no triangle uses, the others kept in order with their
    /// normals, attributes and UVs, and the triangles renumbered.
    ///
    /// ```
    /// use glam::Vec3;
    /// use pointset_core::{PointSet, TriMesh};
    /// // Vertex 1 is used by no triangle.
    /// let p = vec![Vec3::ZERO, Vec3::splat(9.0), Vec3::X, Vec3::Y];
    /// let mesh = TriMesh::new(PointSet::new(p)?, vec![[0, 2, 3]])?;
    /// assert_eq!(mesh.unreferenced_vertices(), 1);
    /// let compact = mesh.without_unreferenced_vertices()?;
    /// assert_eq!(compact.triangles(), &[[0, 1, 2]]);
    /// assert_eq!(compact.positions(), &[Vec3::ZERO, Vec3::X, Vec3::Y]);
    /// # Ok::<(), pointset_core::Error>(())
    /// ```
    pub fn without_unreferenced_vertices(&self) -> Result<TriMesh> {
        self.compacted(self.triangles.clone())
    }

    /// [`TriMesh::without_unreferenced_vertices`], consuming the mesh: its triangles are
    /// renumbered in place rather than copied (for meshes of millions of triangles).
    pub fn into_without_unreferenced_vertices(mut self) -> Result<TriMesh> {
        let triangles = std::mem::take(&mut self.triangles);
        self.compacted(triangles)
    }

    /// The mesh of `triangles` (this mesh's, moved out or copied) over the vertices they
    /// use, with their positions, normals, attributes and UVs; the triangles renumbered in
    /// place.
    fn compacted(&self, mut triangles: Vec<[u32; 3]>) -> Result<TriMesh> {
        let used = referenced(&triangles, self.vertex_count());
        let kept: Vec<usize> = (0..self.vertex_count()).filter(|&v| used[v]).collect();
        let mut renumbered = vec![0u32; self.vertex_count()];
        for (new, &old) in kept.iter().enumerate() {
            renumbered[old] = new as u32;
        }
        for t in &mut triangles {
            *t = t.map(|v| renumbered[v as usize]);
        }
        let mesh = TriMesh::new(self.vertices.subset(&kept)?, triangles)?;
        match &self.uvs {
            Some(uvs) => mesh.with_uvs(kept.iter().map(|&v| uvs[v]).collect()),
            None => Ok(mesh),
        }
    }

    /// Consumes the mesh and returns its parts.
    pub fn into_parts(self) -> (PointSet, Vec<[u32; 3]>, Option<Vec<Vec2>>) {
        (self.vertices, self.triangles, self.uvs)
    }
}

/// For each of `vertex_count` vertices, whether one of `triangles` uses it.
fn referenced(triangles: &[[u32; 3]], vertex_count: usize) -> Vec<bool> {
    let mut used = vec![false; vertex_count];
    for t in triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    used
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn a_mesh_without_faces_is_not_a_closed_manifold() {
        let corners = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let points = PointSet::new(corners).unwrap();
        let empty = TriMesh::new(points.clone(), Vec::new()).unwrap().topology();
        assert_eq!((empty.edges, empty.components), (0, 0));
        assert!(!empty.is_closed_manifold());
        let faces = vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
        let tetrahedron = TriMesh::new(points, faces).unwrap().topology();
        assert!(tetrahedron.is_closed_manifold());
        assert_eq!(tetrahedron.euler_characteristic, 2);
    }

    #[test]
    fn dropping_unreferenced_vertices_keeps_the_rest_with_their_data() {
        let p: Vec<Vec3> = (0..6)
            .map(|i| Vec3::new(i as f32, (i * i) as f32, 1.0))
            .collect();
        let normals: Vec<Vec3> = (0..6)
            .map(|i| Vec3::new(0.0, 0.0, i as f32 + 1.0))
            .collect();
        let uvs: Vec<Vec2> = (0..6).map(|i| Vec2::new(i as f32, 0.5)).collect();
        let vertices = PointSet::new(p.clone())
            .unwrap()
            .with_normals(normals)
            .unwrap()
            .with_attribute(crate::Attribute::new(
                "id",
                (0..6).map(|i| i as f32).collect(),
            ))
            .unwrap();
        // Vertices 0 and 3 are used by no triangle.
        let mesh = TriMesh::new(vertices, vec![[1, 2, 4], [4, 2, 5]])
            .unwrap()
            .with_uvs(uvs)
            .unwrap();
        assert_eq!(mesh.unreferenced_vertices(), 2);
        let compact = mesh.without_unreferenced_vertices().unwrap();
        assert_eq!(compact.unreferenced_vertices(), 0);
        assert_eq!(compact.triangles(), &[[0, 1, 2], [2, 1, 3]]);
        let kept = [1usize, 2, 4, 5];
        for (new, &old) in kept.iter().enumerate() {
            assert_eq!(compact.positions()[new], p[old]);
            assert_eq!(
                compact.vertices().normals().unwrap()[new].z,
                old as f32 + 1.0
            );
            assert_eq!(
                compact.vertices().attribute("id").unwrap().values()[new],
                old as f32
            );
            assert_eq!(compact.uvs().unwrap()[new].x, old as f32);
        }
        // The faces are the same triangles in space.
        for (a, b) in mesh.triangles().iter().zip(compact.triangles()) {
            assert_eq!(
                a.map(|v| p[v as usize]),
                b.map(|v| compact.positions()[v as usize])
            );
        }
        // Nothing to drop: the same mesh.
        assert_eq!(compact.without_unreferenced_vertices().unwrap(), compact);
    }

    /// A unit cube with outward-facing triangles.
    pub(crate) fn cube() -> TriMesh {
        let p: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let tris = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        TriMesh::new(PointSet::new(p).unwrap(), tris).unwrap()
    }

    #[test]
    fn cube_area_and_normals_point_outward() {
        let m = cube();
        assert!((m.area() - 6.0).abs() < 1e-9);
        let center = Vec3::splat(0.5);
        for weighting in [NormalWeighting::Area, NormalWeighting::Angle] {
            for (p, n) in m.positions().iter().zip(m.vertex_normals(weighting)) {
                assert!((n.length() - 1.0).abs() < 1e-5);
                assert!(n.dot(*p - center) > 0.0);
            }
        }
        // Angle weighting is triangulation independent: corners get the exact diagonal.
        let n = m.vertex_normals(NormalWeighting::Angle)[7];
        assert!((n - Vec3::ONE.normalize()).length() < 1e-5);
        assert!(m.degenerate_faces().is_empty());
        let t = m.topology();
        assert!(t.is_closed_manifold());
        assert_eq!((t.edges, t.components, t.euler_characteristic), (18, 1, 2));
    }

    #[test]
    fn topology_finds_borders_flips_and_fans() {
        let v = PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE]).unwrap();
        let open = TriMesh::new(v.clone(), vec![[0, 1, 2], [1, 3, 2]])
            .unwrap()
            .topology();
        assert_eq!((open.boundary_edges, open.misoriented_edges), (4, 0));
        let flipped = TriMesh::new(v.clone(), vec![[0, 1, 2], [1, 2, 3]])
            .unwrap()
            .topology();
        assert_eq!(flipped.misoriented_edges, 1);
        let fan = TriMesh::new(v, vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]])
            .unwrap()
            .topology();
        assert_eq!(fan.non_manifold_edges, 1);
        assert!(!fan.is_closed_manifold());
    }

    /// `triangles` on `n` vertices spaced along x: meshes whose connectivity is all that
    /// counts.
    fn mesh_on_a_line(n: u32, triangles: &[[u32; 3]]) -> TriMesh {
        let positions = (0..n).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
        TriMesh::new(PointSet::new(positions).unwrap(), triangles.to_vec()).unwrap()
    }

    proptest::proptest! {
        /// The edge counts agree with a count by hash map over random triangle soups
        /// (borders, flips, fans, repeated and degenerate triangles).
        #[test]
        fn topology_counts_edges_as_a_hash_map_does(
            triangles in proptest::collection::vec(proptest::array::uniform3(0u32..9), 0..40),
        ) {
            let t = mesh_on_a_line(9, &triangles).topology();
            let mut uses: std::collections::HashMap<(u32, u32), (usize, usize)> =
                std::collections::HashMap::new();
            for tri in &triangles {
                for k in 0..3 {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    let entry = uses.entry((a.min(b), a.max(b))).or_default();
                    entry.0 += 1;
                    entry.1 += usize::from(a < b);
                }
            }
            let count = |f: &dyn Fn(&(usize, usize)) -> bool| uses.values().filter(|u| f(u)).count();
            proptest::prop_assert_eq!(t.edges, uses.len());
            proptest::prop_assert_eq!(t.boundary_edges, count(&|u| u.0 == 1));
            proptest::prop_assert_eq!(t.misoriented_edges, count(&|u| u.0 == 2 && u.1 != 1));
            proptest::prop_assert_eq!(t.non_manifold_edges, count(&|u| u.0 > 2));
        }
    }

    proptest::proptest! {
        /// Twins are found as a quadratic scan finds them: each later triangle on the same
        /// corners as an earlier one, with the earliest, in face order.
        #[test]
        fn duplicate_faces_agree_with_a_scan_of_every_pair(
            triangles in proptest::collection::vec(proptest::array::uniform3(0u32..5), 0..30),
        ) {
            let mesh = mesh_on_a_line(5, &triangles);
            let sorted = |t: [u32; 3]| {
                let mut c = t;
                c.sort_unstable();
                c
            };
            let mut expected = Vec::new();
            for (face, &t) in triangles.iter().enumerate() {
                if let Some(first) = (0..face).find(|&f| sorted(triangles[f]) == sorted(t)) {
                    let o = triangles[first];
                    let rotations = [o, [o[1], o[2], o[0]], [o[2], o[0], o[1]]];
                    expected.push(DuplicateFace { face, first, reversed: !rotations.contains(&t) });
                }
            }
            proptest::prop_assert_eq!(mesh.duplicate_faces(), expected);
        }
    }

    #[test]
    fn bad_indices_and_degenerate_faces() {
        let v = PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y]).unwrap();
        assert!(matches!(
            TriMesh::new(v.clone(), vec![[0, 1, 3]]),
            Err(Error::IndexOutOfRange {
                face: 0,
                vertex: 3,
                ..
            })
        ));
        let m = TriMesh::new(v, vec![[0, 1, 2], [0, 0, 1], [0, 1, 1]]).unwrap();
        assert_eq!(m.degenerate_faces(), vec![1, 2]);
        assert!(m.clone().with_uvs(vec![Vec2::ZERO; 2]).is_err());
        assert!(m.with_uvs(vec![Vec2::NAN; 3]).is_err());
    }
}
