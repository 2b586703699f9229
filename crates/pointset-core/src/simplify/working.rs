//! The mesh as it is being simplified: its vertices welded by position, the live faces
//! over them with each corner's wedge (the input vertex it came from, which carries the
//! corner's normal, texture coordinates and attributes), each vertex's faces and quadric,
//! and the checks that keep an edge collapse from changing the surface's topology or
//! folding it.

use std::collections::{HashMap, HashSet};

use glam::{DVec3, Vec3};

use super::quadric::Quadric;
use crate::DisjointSets;
use crate::weld::position_bits;

/// What a vertex may do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Role {
    /// Moves and merges freely.
    Free,
    /// Takes part in no collapse: on an edge of more than two faces, or where its faces
    /// make more than one fan (the surface pinched to a point).
    Frozen,
    /// Merged into a neighbour, or used by no face.
    Gone,
}

/// Why a collapse was not made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Refusal {
    /// It would change the topology: glue two parts of the surface together, close a hole
    /// of three edges, pinch a boundary, remove a whole component, or make two faces of
    /// the same corners.
    Topology,
    /// A face would turn by more than the limit, or shrink to no area.
    Fold,
}

/// An edge collapse as planned: `gone` merges into `keep`, which moves to `position`,
/// `t` of the way from where `keep` was toward `gone`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Collapse {
    pub(super) keep: u32,
    pub(super) gone: u32,
    pub(super) position: DVec3,
    pub(super) t: f64,
    /// `Q(position)` of the two vertices' summed quadrics.
    pub(super) cost: f64,
    /// The root mean square distance from `position` to the two vertices' planes.
    pub(super) distance: f64,
}

/// The mesh being simplified (module docs of `simplify`).
#[derive(Debug)]
pub(super) struct Working {
    /// Per welded vertex.
    pub(super) positions: Vec<DVec3>,
    /// Faces over welded vertices.
    faces: Vec<[u32; 3]>,
    /// Each face's corners as wedges (input vertices).
    corners: Vec<[u32; 3]>,
    /// Each wedge's welded vertex.
    wedge_vertex: Vec<u32>,
    face_alive: Vec<bool>,
    /// Each face's unit normal in the input (zero for a face of no area).
    first_normals: Vec<DVec3>,
    vertex_faces: Vec<Vec<u32>>,
    quadrics: Vec<Quadric>,
    pub(super) roles: Vec<Role>,
    /// Bumped each time a vertex moves or merges: queued collapses of its edges that were
    /// planned before are stale.
    pub(super) versions: Vec<u32>,
    pub(super) live_faces: usize,
    /// Edges inside the surface whose two faces have different wedges at an end.
    pub(super) seam_edges: usize,
    /// Every edge of the input (lower vertex first), sorted: the first collapses to plan
    /// (taken by the queue when it is filled).
    pub(super) edges: Vec<(u32, u32)>,
}

impl Working {
    /// The working mesh of `corners` (faces over the input's vertices, none with a
    /// repeated corner) at the input's `positions` less `centre` (where double precision
    /// rounds least), welded where positions are equal; faces whose corners weld together
    /// are left out (their count is returned beside). Each face's plane counts once, and
    /// each boundary or seam edge's constraint plane `boundary_weight` times.
    pub(super) fn new(
        positions: &[Vec3],
        corners: &[[u32; 3]],
        centre: DVec3,
        boundary_weight: f64,
    ) -> (Self, usize) {
        let (welded_positions, wedge_vertex) = weld(positions, centre);
        let (faces, kept_corners): (Vec<[u32; 3]>, Vec<[u32; 3]>) = corners
            .iter()
            .map(|c| (c.map(|w| wedge_vertex[w as usize]), *c))
            .filter(|([a, b, c], _)| a != b && b != c && c != a)
            .unzip();
        let n = welded_positions.len();
        let mut vertex_faces = vec![Vec::new(); n];
        for (f, face) in faces.iter().enumerate() {
            for &v in face {
                vertex_faces[v as usize].push(f as u32);
            }
        }
        let edges = EdgeTable::new(&faces, &kept_corners);
        let quadrics = initial_quadrics(&welded_positions, &faces, &edges, boundary_weight);
        let first_normals = faces
            .iter()
            .map(|face| {
                let [a, b, c] = face.map(|v| welded_positions[v as usize]);
                (b - a).cross(c - a).normalize_or_zero()
            })
            .collect();
        let mut working = Self {
            first_normals,
            roles: vec![Role::Free; n],
            versions: vec![0; n],
            live_faces: faces.len(),
            face_alive: vec![true; faces.len()],
            seam_edges: edges.seams.len(),
            edges: edges.sorted(),
            positions: welded_positions,
            faces,
            corners: kept_corners,
            wedge_vertex,
            vertex_faces,
            quadrics,
        };
        working.assign_roles(&edges);
        let left_out = corners.len() - working.faces.len();
        (working, left_out)
    }

    fn assign_roles(&mut self, edges: &EdgeTable) {
        for (&(a, b), _) in edges.faces.iter().filter(|(_, count)| **count > 2) {
            self.roles[a as usize] = Role::Frozen;
            self.roles[b as usize] = Role::Frozen;
        }
        for v in 0..self.positions.len() {
            if self.vertex_faces[v].is_empty() {
                self.roles[v] = Role::Gone;
            } else if self.roles[v] == Role::Free && !self.is_one_fan(v as u32) {
                self.roles[v] = Role::Frozen;
            }
        }
    }

    /// Whether `v`'s faces, joined where they share an edge through `v`, make one fan.
    fn is_one_fan(&self, v: u32) -> bool {
        let ring = self.neighbours(v);
        let mut fans = DisjointSets::new(ring.len());
        let index = |w: u32| ring.iter().position(|&r| r == w).map(|i| i as u32);
        let mut joined = 0;
        for &f in &self.vertex_faces[v as usize] {
            let [a, b] = others(&self.faces[f as usize], v);
            if let (Some(i), Some(j)) = (index(a), index(b))
                && fans.join(i, j)
            {
                joined += 1;
            }
        }
        // A ring of n neighbours is one fan when n − 1 joins linked them all.
        joined + 1 >= ring.len()
    }

    /// The vertices sharing a face with `v`, each once, in the order first met.
    pub(super) fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut ring = Vec::with_capacity(8);
        for &f in &self.vertex_faces[v as usize] {
            for w in others(&self.faces[f as usize], v) {
                if !ring.contains(&w) {
                    ring.push(w);
                }
            }
        }
        ring
    }

    /// The faces of the edge `a`–`b`.
    fn edge_faces(&self, a: u32, b: u32) -> Vec<u32> {
        self.vertex_faces[a as usize]
            .iter()
            .copied()
            .filter(|&f| self.faces[f as usize].contains(&b))
            .collect()
    }

    /// Whether `v` lies on an edge of one face.
    fn on_boundary(&self, v: u32) -> bool {
        self.neighbours(v)
            .into_iter()
            .any(|w| self.edge_faces(v, w).len() == 1)
    }

    /// The collapse of the edge `a`–`b`, planned: the lower index stays, and goes where
    /// the summed quadric is least; `None` when either vertex may not move.
    pub(super) fn plan(&self, a: u32, b: u32) -> Option<Collapse> {
        if self.roles[a as usize] != Role::Free || self.roles[b as usize] != Role::Free {
            return None;
        }
        let (keep, gone) = (a.min(b), a.max(b));
        let (pk, pg) = (self.positions[keep as usize], self.positions[gone as usize]);
        let quadric = self.quadrics[keep as usize].plus(&self.quadrics[gone as usize]);
        let position = quadric.best_point(pk, pg);
        let span = pk.distance_squared(pg);
        let t = if span > 0.0 {
            ((position - pk).dot(pg - pk) / span).clamp(0.0, 1.0)
        } else {
            0.0
        };
        Some(Collapse {
            keep,
            gone,
            position,
            t,
            cost: quadric.cost(position),
            distance: quadric.rms_distance(position),
        })
    }

    /// Whether `collapse` keeps the surface's topology and folds no face more than
    /// `min_cos` allows (the cosine of the largest turn): the edge's faces, for
    /// [`Self::apply`], or `Ok(None)` when the edge is no longer in the mesh.
    pub(super) fn check(
        &self,
        collapse: &Collapse,
        min_cos: f64,
    ) -> Result<Option<Vec<u32>>, Refusal> {
        let (keep, gone) = (collapse.keep, collapse.gone);
        let shared = self.edge_faces(keep, gone);
        if shared.is_empty() {
            return Ok(None);
        }
        if shared.len() > 2 {
            return Err(Refusal::Topology);
        }
        if shared.len() == 2 && self.on_boundary(keep) && self.on_boundary(gone) {
            return Err(Refusal::Topology);
        }
        // The link condition: the two vertices' common neighbours are exactly the corners
        // across the edge.
        let across: Vec<u32> = shared
            .iter()
            .map(|&f| third(&self.faces[f as usize], keep, gone))
            .collect();
        let ring_gone = self.neighbours(gone);
        let common = self
            .neighbours(keep)
            .into_iter()
            .filter(|w| ring_gone.contains(w))
            .count();
        if common != across.len() || across.iter().any(|w| !ring_gone.contains(w)) {
            return Err(Refusal::Topology);
        }
        let rest_keep: Vec<u32> = self.faces_without(keep, &shared);
        let rest_gone: Vec<u32> = self.faces_without(gone, &shared);
        if rest_keep.is_empty() && rest_gone.is_empty() {
            return Err(Refusal::Topology);
        }
        let kept_corners: Vec<[u32; 3]> = rest_keep
            .iter()
            .map(|&f| sorted(self.faces[f as usize]))
            .collect();
        for &f in &rest_gone {
            let moved = self.faces[f as usize].map(|v| if v == gone { keep } else { v });
            if kept_corners.contains(&sorted(moved)) {
                return Err(Refusal::Topology);
            }
        }
        for &f in rest_keep.iter().chain(&rest_gone) {
            let face = self.faces[f as usize];
            let before = self.normal(face.map(|v| self.positions[v as usize]));
            let after = self.normal(face.map(|v| {
                if v == keep || v == gone {
                    collapse.position
                } else {
                    self.positions[v as usize]
                }
            }));
            let (lb, la) = (before.length(), after.length());
            if lb > 0.0 && (la <= 1e-12 * lb || before.dot(after) < min_cos * lb * la) {
                return Err(Refusal::Fold);
            }
            // Turns add up over many collapses: never past a right angle from the face's
            // first orientation either.
            if self.first_normals[f as usize].dot(after) < 0.0 {
                return Err(Refusal::Fold);
            }
        }
        Ok(Some(shared))
    }

    fn normal(&self, [a, b, c]: [DVec3; 3]) -> DVec3 {
        (b - a).cross(c - a)
    }

    fn faces_without(&self, v: u32, shared: &[u32]) -> Vec<u32> {
        self.vertex_faces[v as usize]
            .iter()
            .copied()
            .filter(|f| !shared.contains(f))
            .collect()
    }

    /// Makes `collapse`, checked, whose edge has the faces `shared`: they leave the mesh, `gone`'s other faces
    /// take `keep` in its place, and `keep` moves and takes `gone`'s quadric. `gone`'s
    /// wedges on the edge's faces merge into `keep`'s wedges there (appended to `merged`
    /// as `(keep's wedge, gone's wedge)`, for their data); its other wedges (the far side
    /// of a seam that ends at `gone`) stay, at `keep`'s position.
    pub(super) fn apply(
        &mut self,
        collapse: &Collapse,
        shared: &[u32],
        merged: &mut Vec<(u32, u32)>,
    ) {
        let (keep, gone) = (collapse.keep as usize, collapse.gone as usize);
        merged.clear();
        for &f in shared {
            let (face, corner) = (self.faces[f as usize], self.corners[f as usize]);
            let wedge_of = |v: u32| face.iter().position(|&c| c == v).map(|i| corner[i]);
            if let (Some(k), Some(g)) = (wedge_of(collapse.keep), wedge_of(collapse.gone))
                && k != g
                && !merged.iter().any(|&(_, m)| m == g)
            {
                merged.push((k, g));
            }
            self.face_alive[f as usize] = false;
            let w = third(&face, collapse.keep, collapse.gone);
            self.vertex_faces[w as usize].retain(|&g| g != f);
        }
        self.live_faces -= shared.len();
        let moved = std::mem::take(&mut self.vertex_faces[gone]);
        self.vertex_faces[keep].retain(|f| !shared.contains(f));
        for f in moved.into_iter().filter(|f| !shared.contains(f)) {
            let (face, corner) = (&mut self.faces[f as usize], &mut self.corners[f as usize]);
            for (v, w) in face.iter_mut().zip(corner.iter_mut()) {
                if *v == collapse.gone {
                    *v = collapse.keep;
                    match merged.iter().find(|&&(_, g)| g == *w) {
                        Some(&(k, _)) => *w = k,
                        None => self.wedge_vertex[*w as usize] = collapse.keep,
                    }
                }
            }
            self.vertex_faces[keep].push(f);
        }
        self.positions[keep] = collapse.position;
        let absorbed = self.quadrics[gone];
        self.quadrics[keep].add(&absorbed);
        self.roles[gone] = Role::Gone;
        self.versions[keep] = self.versions[keep].wrapping_add(1);
        self.versions[gone] = self.versions[gone].wrapping_add(1);
    }

    /// The live faces' corners as wedges, in the faces' input order.
    pub(super) fn live_corners(&self) -> impl Iterator<Item = &[u32; 3]> {
        self.corners
            .iter()
            .zip(&self.face_alive)
            .filter(|(_, alive)| **alive)
            .map(|(corner, _)| corner)
    }

    /// Each wedge's welded vertex.
    pub(super) fn wedge_vertices(&self) -> &[u32] {
        &self.wedge_vertex
    }

    /// Where wedge `w` is now: at its welded vertex.
    pub(super) fn wedge_position(&self, w: u32) -> DVec3 {
        self.positions[self.wedge_vertex[w as usize] as usize]
    }
}

/// The input's positions less `centre`, one per distinct position (`-0` as `0`, as
/// [`crate::TriMesh::welded`] welds), and each input vertex's welded vertex.
fn weld(positions: &[Vec3], centre: DVec3) -> (Vec<DVec3>, Vec<u32>) {
    let mut welded: HashMap<[u32; 3], u32> = HashMap::new();
    let mut welded_positions = Vec::new();
    let wedge_vertex = positions
        .iter()
        .map(|p| {
            *welded.entry(position_bits(*p)).or_insert_with(|| {
                welded_positions.push(p.as_dvec3() - centre);
                welded_positions.len() as u32 - 1
            })
        })
        .collect();
    (welded_positions, wedge_vertex)
}

/// The welded mesh's edges (lower vertex first): how many faces each has, and which of
/// those with two faces are seams (the faces use different wedges at an end).
struct EdgeTable {
    faces: HashMap<(u32, u32), u32>,
    seams: HashSet<(u32, u32)>,
}

impl EdgeTable {
    fn new(faces: &[[u32; 3]], corners: &[[u32; 3]]) -> Self {
        let mut first_wedges: HashMap<(u32, u32), [u32; 2]> = HashMap::new();
        let mut counts: HashMap<(u32, u32), u32> = HashMap::new();
        let mut differing = HashSet::new();
        for (face, corner) in faces.iter().zip(corners) {
            for i in 0..3 {
                let (j, k) = if face[i] < face[(i + 1) % 3] {
                    (i, (i + 1) % 3)
                } else {
                    ((i + 1) % 3, i)
                };
                let key = (face[j], face[k]);
                *counts.entry(key).or_default() += 1;
                if *first_wedges.entry(key).or_insert([corner[j], corner[k]])
                    != [corner[j], corner[k]]
                {
                    differing.insert(key);
                }
            }
        }
        let seams = differing
            .into_iter()
            .filter(|key| counts[key] == 2)
            .collect();
        Self {
            faces: counts,
            seams,
        }
    }

    /// The edges, sorted.
    fn sorted(&self) -> Vec<(u32, u32)> {
        let mut edges: Vec<(u32, u32)> = self.faces.keys().copied().collect();
        edges.sort_unstable();
        edges
    }

    /// Whether the edge `a`–`b` gets constraint planes: a boundary or a seam.
    fn constrained(&self, a: u32, b: u32) -> bool {
        let key = (a.min(b), a.max(b));
        self.faces.get(&key) == Some(&1) || self.seams.contains(&key)
    }
}

/// Each welded vertex's quadric: the planes of its faces, each once, and the constraint
/// planes of its boundary and seam edges (through the edge, perpendicular to its face),
/// each `boundary_weight` times.
fn initial_quadrics(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    edges: &EdgeTable,
    boundary_weight: f64,
) -> Vec<Quadric> {
    let mut quadrics = vec![Quadric::default(); positions.len()];
    for face in faces {
        let [a, b, c] = face.map(|v| positions[v as usize]);
        let Some(normal) = (b - a).cross(c - a).try_normalize() else {
            continue;
        };
        let plane = Quadric::plane(a, normal, 1.0, 1.0);
        for &v in face {
            quadrics[v as usize].add(&plane);
        }
        for (u, v) in face_edges(face)
            .into_iter()
            .filter(|&(u, v)| edges.constrained(u, v))
        {
            let (pu, pv) = (positions[u as usize], positions[v as usize]);
            let Some(across) = (pv - pu).cross(normal).try_normalize() else {
                continue;
            };
            let constraint = Quadric::plane(pu, across, boundary_weight, 0.0);
            quadrics[u as usize].add(&constraint);
            quadrics[v as usize].add(&constraint);
        }
    }
    quadrics
}

/// A face's three edges, in its corners' order.
fn face_edges(&[a, b, c]: &[u32; 3]) -> [(u32, u32); 3] {
    [(a, b), (b, c), (c, a)]
}

/// The face's other two corners than `v`, in the face's order after `v`.
fn others(face: &[u32; 3], v: u32) -> [u32; 2] {
    match face.iter().position(|&c| c == v) {
        Some(i) => [face[(i + 1) % 3], face[(i + 2) % 3]],
        None => [face[1], face[2]],
    }
}

/// The face's corner that is neither `a` nor `b`.
fn third(face: &[u32; 3], a: u32, b: u32) -> u32 {
    face.iter()
        .copied()
        .find(|&c| c != a && c != b)
        .unwrap_or(face[0])
}

fn sorted(mut face: [u32; 3]) -> [u32; 3] {
    face.sort_unstable();
    face
}
