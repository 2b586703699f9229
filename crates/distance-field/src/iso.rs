//! Iso-surface extraction by marching tetrahedra.
//!
//! Every grid cell is split into the six tetrahedra of its Kuhn triangulation (one per path
//! from corner 0 to corner 7 along the axes), which all neighbouring cells split their
//! shared faces the same way. Inside a tetrahedron the field is linear, so the surface piece
//! is one triangle or one quad and there are no ambiguous cases: the result is a closed,
//! consistently oriented 2-manifold wherever the surface does not leave the grid.
//! Vertices sit on grid edges (including cell diagonals) at the linearly interpolated zero
//! crossing and are shared through an edge-keyed map, so the mesh is welded. Triangles face
//! the positive side (outside, for signed distances). Samples exactly equal to the iso
//! value count as outside; a crossing on or near a node is kept a thousandth of its edge
//! off it, so that no two vertices share a position.

use std::collections::HashMap;

use glam::{IVec3, Vec3, Vec4};
use pointset_core::{Grid3, NormalWeighting, PointSet, Surface, TriMesh};
use rayon::prelude::*;

use crate::error::{FieldError, Result};
use crate::sdf::SdfGrid;

/// The six tetrahedra of the Kuhn split; corners numbered `x + 2y + 4z`.
const TETRAHEDRA: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 2, 3, 7],
    [0, 2, 6, 7],
    [0, 4, 6, 7],
    [0, 4, 5, 7],
    [0, 1, 5, 7],
];

/// How far along its edge, as a fraction of it, every vertex is kept off the edge's nodes
/// (see [`Builder::vertex`]): a thousandth of the spacing, far below the interpolation's
/// own error and far above an `f32` step at any coordinates the grids are sampled at
/// (georeferenced ones are read relative to an origin).
const NODE_CLEARANCE: f32 = 1.0 / 1024.0;

/// How far from the surface, as a fraction of its edge, an interpolated crossing may lie
/// before [`sdf_isosurface_of`] looks for the sign's change along the edge instead. Chosen
/// on the Utah teapot remeshed with winding numbers at 96 nodes (by halvings alone, while
/// choosing): 0.2 / 0.05 / 0.01 moved 427 / 1,751 / 7,082 of 43,174 vertices; the collar
/// round its lid was still saw-toothed at 0.2 and 0.05, nearly smooth at 0.01.
pub const CROSSING_MISS: f32 = 0.01;

/// Halvings of an edge when its crossing is looked for ([`sign_change`]): the last
/// interval is a 4096th of the edge, below [`NODE_CLEARANCE`].
const CROSSING_BISECTIONS: usize = 12;

/// A crossing looked for is taken where the surface's distance is under this share of
/// [`CROSSING_MISS`] (a 400th of the edge).
const CROSSING_SETTLED: f32 = 0.25;

/// Least cosine between a moved vertex's normal from the stored gradients and the mesh's
/// own normal there ([`sdf_isosurface_of`]), about 26°. Where the sign jumps, the nodes'
/// gradients point at the surface, not across the sign's boundary, and fail it; where a
/// vertex moved onto the surface, they pass. With the mesh's normals at every moved vertex
/// the bunny scan's reconstruction came out speckled; with the gradients at every one (any
/// facing the same side), the teapot's collar was shaded as the staircase it no longer was.
pub const MOVED_NORMAL_AGREEMENT: f32 = 0.9;

/// Builds the welded mesh while cells are visited.
struct Builder<'a> {
    values: &'a [f32],
    grid_origin: Vec3,
    spacing: f32,
    dims: [usize; 3],
    vertex_of_edge: HashMap<(u32, u32), u32>,
    positions: Vec<Vec3>,
    /// Per vertex, its edge's nodes and its place along the edge from the first (for
    /// normals from the stored gradients).
    crossings: Vec<(u32, u32, f32)>,
    triangles: Vec<[u32; 3]>,
}

impl Builder<'_> {
    fn position(&self, node: usize) -> Vec3 {
        let [nx, ny, _] = self.dims;
        let (i, j, k) = (node % nx, (node / nx) % ny, node / (nx * ny));
        self.grid_origin + Vec3::new(i as f32, j as f32, k as f32) * self.spacing
    }

    fn vertex(&mut self, a: usize, b: usize) -> u32 {
        let key = (a.min(b) as u32, a.max(b) as u32);
        if let Some(&v) = self.vertex_of_edge.get(&key) {
            return v;
        }
        let (va, vb) = (self.values[a], self.values[b]);
        let (pa, pb) = (self.position(a), self.position(b));
        // A crossing on or very near a node (a sample equal to the iso value, or within a
        // few ulps of it) would put the vertices of the edges through that node at one
        // position once rounded to `f32`: distinct vertices at one point, which readers that
        // weld by position see as a pinch. Each is kept `NODE_CLEARANCE` of its edge off
        // the nodes, along its own edge.
        let t = (va / (va - vb)).clamp(NODE_CLEARANCE, 1.0 - NODE_CLEARANCE);
        let p = pa.lerp(pb, t);
        let id = self.positions.len() as u32;
        self.positions.push(p);
        self.crossings.push((a as u32, b as u32, t));
        self.vertex_of_edge.insert(key, id);
        id
    }

    /// Moves every vertex whose interpolated position lies more than [`CROSSING_MISS`] of
    /// its edge from `surface` to where `surface`'s sign changes along the edge
    /// ([`sdf_isosurface_of`]); returns the moved vertices, ascending.
    fn locate_missed_crossings(&mut self, surface: &dyn Surface) -> Vec<usize> {
        let this = &*self;
        let found: Vec<(usize, f32)> = (0..this.crossings.len())
            .into_par_iter()
            .filter_map(|v| this.missed_crossing(surface, v).map(|t| (v, t)))
            .collect();
        let mut moved = Vec::with_capacity(found.len());
        for (v, t) in found {
            let (a, b, _) = self.crossings[v];
            let t = t.clamp(NODE_CLEARANCE, 1.0 - NODE_CLEARANCE);
            self.positions[v] = self.position(a as usize).lerp(self.position(b as usize), t);
            self.crossings[v].2 = t;
            moved.push(v);
        }
        moved
    }

    /// Where along its edge `surface`'s sign changes, for vertex `v` when its interpolated
    /// position lies more than [`CROSSING_MISS`] of the edge from `surface`.
    fn missed_crossing(&self, surface: &dyn Surface, v: usize) -> Option<f32> {
        let (a, b, _) = self.crossings[v];
        let (a, b) = (a as usize, b as usize);
        let (pa, pb) = (self.position(a), self.position(b));
        let miss = CROSSING_MISS * pa.distance(pb);
        if surface.distance_within(self.positions[v], miss).is_some() {
            return None;
        }
        sign_change(
            surface,
            pa,
            pb,
            self.values[a] < 0.0,
            CROSSING_SETTLED * miss,
        )
    }

    /// Integer grid coordinates of a node.
    fn coords(&self, node: usize) -> IVec3 {
        let [nx, ny, _] = self.dims;
        IVec3::new(
            (node % nx) as i32,
            ((node / nx) % ny) as i32,
            (node / (nx * ny)) as i32,
        )
    }

    /// Orientation of the ordered tetrahedron `(a, b, c, d)`: the sign of
    /// `det(b − a, c − a, d − a)` on integer grid coordinates (exact, never zero for the
    /// Kuhn tetrahedra).
    fn orientation(&self, [a, b, c, d]: [usize; 4]) -> bool {
        let pa = self.coords(a);
        let (u, v, w) = (
            self.coords(b) - pa,
            self.coords(c) - pa,
            self.coords(d) - pa,
        );
        u.dot(v.cross(w)) > 0
    }

    fn push(&mut self, [a, b, c]: [u32; 3], flip: bool) {
        self.triangles
            .push(if flip { [a, c, b] } else { [a, b, c] });
    }

    /// Emits the surface piece of one tetrahedron. Orientation is decided combinatorially:
    /// for a lone vertex `a` and the others `b, c, d`, the triangle `(ab, ac, ad)` faces away
    /// from `a` exactly when `(a, b, c, d)` is positively oriented; for inside pair `a, b` and
    /// outside pair `c, d`, the quad `(ac, ad, bd, bc)` faces `c, d` under the same
    /// condition. Geometric normals are never consulted, so near-degenerate triangles (a
    /// crossing right at a grid node) cannot flip.
    fn tetrahedron(&mut self, nodes: [usize; 4]) {
        let inside: Vec<usize> = nodes
            .iter()
            .copied()
            .filter(|&n| self.values[n] < 0.0)
            .collect();
        let outside: Vec<usize> = nodes
            .iter()
            .copied()
            .filter(|&n| self.values[n] >= 0.0)
            .collect();
        match (inside.as_slice(), outside.as_slice()) {
            (&[a], &[b, c, d]) => {
                let tri = [self.vertex(a, b), self.vertex(a, c), self.vertex(a, d)];
                let flip = !self.orientation([a, b, c, d]);
                self.push(tri, flip);
            }
            (&[b, c, d], &[a]) => {
                // The lone vertex is outside: the triangle must face it.
                let tri = [self.vertex(a, b), self.vertex(a, c), self.vertex(a, d)];
                let flip = self.orientation([a, b, c, d]);
                self.push(tri, flip);
            }
            (&[a, b], &[c, d]) => {
                let (ac, ad, bd, bc) = (
                    self.vertex(a, c),
                    self.vertex(a, d),
                    self.vertex(b, d),
                    self.vertex(b, c),
                );
                let flip = !self.orientation([a, b, c, d]);
                self.push([ac, ad, bd], flip);
                self.push([ac, bd, bc], flip);
            }
            _ => {}
        }
    }
}

/// Extracts the surface `value = iso` of a scalar grid as a welded, outward-oriented mesh
/// with normals from the mesh (angle-weighted).
pub fn isosurface(grid: &Grid3<f32>, iso: f32) -> Result<TriMesh> {
    extract(grid, iso, None, None)
}

/// [`isosurface`] of the grid padded by one layer of `outside` on every side: a solid that
/// reaches the grid's edge is capped there, so the surface is closed (a 2-manifold without
/// border) wherever the values inside the grid are finite. `outside` must exceed `iso`.
pub fn closed_isosurface(grid: &Grid3<f32>, iso: f32, outside: f32) -> Result<TriMesh> {
    if !(outside.is_finite() && iso.is_finite() && outside > iso) {
        return Err(FieldError::InvalidParameter {
            name: "outside",
            value: format!("{outside} (iso {iso})"),
            expected: "a finite value above the iso value",
        });
    }
    let d = grid.dims();
    let padded = [d[0] + 2, d[1] + 2, d[2] + 2];
    let mut data = vec![outside; padded.iter().product()];
    for z in 0..d[2] {
        for y in 0..d[1] {
            for x in 0..d[0] {
                if let Some(&v) = grid.get(x, y, z) {
                    data[x + 1 + padded[0] * (y + 1 + padded[1] * (z + 1))] = v;
                }
            }
        }
    }
    let padded = Grid3::from_vec(
        padded,
        grid.origin() - Vec3::splat(grid.spacing()),
        grid.spacing(),
        data,
    )?;
    extract(&padded, iso, None, None)
}

/// Extracts the zero set of a signed distance grid; vertex normals interpolate the stored
/// gradients. Where that faces against the mesh's own (angle-weighted) normal, or vanishes,
/// the gradient of the edge's nearer or farther node is used if it faces with the mesh,
/// else the mesh's own normal.
pub fn sdf_isosurface(sdf: &SdfGrid) -> Result<TriMesh> {
    let distances = sdf.distances()?;
    extract(&distances, 0.0, Some(sdf.grid().data()), None)
}

/// [`sdf_isosurface`] of a field sampled from `surface` (with [`SdfGrid::from_surface`]
/// and its relatives), with every crossing that the interpolation misses looked for along
/// its edge with `surface`'s own sign.
///
/// Where a field's sign comes from a rule other than which side of the nearest surface a
/// node lies on (a winding number closing the gaps of an open mesh; a pseudo-normal
/// switching from one piece to another where pieces meet), it can change between two
/// nodes away from where the surface passes, or where none passes at all. Their values
/// are distances to the surface, not to where the sign changes, so the linear
/// interpolation of [`sdf_isosurface`] puts the crossing wherever the two distances
/// balance: the zero set comes out as a staircase of the grid there (the Utah teapot
/// remeshed with winding numbers showed a saw-toothed collar round its lid and where its
/// spout meets the body).
///
/// Here each vertex's interpolated position is checked against `surface`: where it lies
/// more than [`CROSSING_MISS`] of its edge from the surface (or the surface gives no
/// distance there), the change of `surface.signed_distance`'s sign along the edge is
/// looked for by false position and halving in turn (down to a 4096th of the edge),
/// provided that sign agrees with both nodes' (otherwise, as between two far nodes signed
/// by their neighbours, the interpolation stays). Where the surface does cross the edge,
/// that finds the crossing more closely than the interpolation did; where only the sign
/// changes, it finds where it does. Moved vertices take their normal from the stored
/// gradients only where it lies within about 26° of the mesh's own
/// ([`MOVED_NORMAL_AGREEMENT`]), the mesh's own otherwise: across a jump of the sign the
/// gradients point at the surface, not across the sign's boundary. Every other vertex is
/// as [`sdf_isosurface`] places it.
///
/// Cost: one bounded distance per vertex ([`Surface::distance_within`]); per checked
/// edge, signed distances at its two ends and a step or two along it where the surface
/// crosses it, up to 24 where only the sign jumps; in parallel.
pub fn sdf_isosurface_of(sdf: &SdfGrid, surface: &dyn Surface) -> Result<TriMesh> {
    let distances = sdf.distances()?;
    extract(&distances, 0.0, Some(sdf.grid().data()), Some(surface))
}

/// Where along `pa → pb` the side of `surface` changes, as a fraction of the segment,
/// when `pa` lies on the side `inside_a` says and `pb` on the other; `None` when the
/// surface says otherwise at either end or gives no distance somewhere.
///
/// The bracket shrinks by false position and halving in turn: where the surface crosses
/// the segment its signed distance is smooth, and a false-position step lands within
/// `tolerance` of it in a step or two; where only the sign changes, the distance jumps
/// there, and the halvings close in on the jump ([`CROSSING_BISECTIONS`] of them, to a
/// 4096th of the segment).
fn sign_change(
    surface: &dyn Surface,
    pa: Vec3,
    pb: Vec3,
    inside_a: bool,
    tolerance: f32,
) -> Option<f32> {
    let distance = |t: f32| surface.signed_distance(pa.lerp(pb, t)).map(|(d, _)| d);
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    let (mut at_lo, mut at_hi) = (distance(lo)?, distance(hi)?);
    if (at_lo < 0.0) != inside_a || (at_hi < 0.0) == inside_a {
        return None;
    }
    let mut halvings = 0;
    let mut halve = false;
    while halvings < CROSSING_BISECTIONS {
        let t = if halve {
            halvings += 1;
            0.5 * (lo + hi)
        } else {
            // Strictly inside the bracket: the two distances have opposite signs.
            (lo + (hi - lo) * at_lo / (at_lo - at_hi)).clamp(lo, hi)
        };
        halve = !halve;
        let d = distance(t)?;
        if d.abs() <= tolerance {
            return Some(t);
        }
        if (d < 0.0) == inside_a {
            (lo, at_lo) = (t, d);
        } else {
            (hi, at_hi) = (t, d);
        }
    }
    Some(0.5 * (lo + hi))
}

/// The normal of the vertex at `t` along the edge from node `a` to node `b`: the stored
/// gradients interpolated there, else the nearer node's, else the farther node's,
/// whichever first faces the same side as `own`, the mesh's angle-weighted normal there
/// (its cosine with `own` over `agreement`); `own` if none does.
///
/// A stored gradient can face against the surface it is stored on: where a field's sign
/// was decided by another rule than its distances (a point cloud's winding number
/// overriding its MLS surface right beside it, `WindingSigned`), a node a hair outside the
/// surface is signed inside, the zero set bulges around it by less than a hair, and the
/// node's gradient still points to the surface it measured, into the bulge. Renderers
/// shade such a vertex black (the reconstructed chameleon's crest showed a dark hexagon
/// around every such node); a neighbouring node's gradient shades a bulge that small as
/// the surface around it.
fn gradient_normal(
    gradients: &[Vec4],
    (a, b, t): (u32, u32, f32),
    own: Vec3,
    agreement: f32,
) -> Vec3 {
    let at = |node: u32| {
        let g = gradients[node as usize];
        Vec3::new(g.y, g.z, g.w)
    };
    let (ga, gb) = (at(a), at(b));
    let (near, far) = if t <= 0.5 { (ga, gb) } else { (gb, ga) };
    [ga.lerp(gb, t), near, far]
        .map(Vec3::normalize_or_zero)
        .into_iter()
        .find(|n| *n != Vec3::ZERO && n.dot(own) > agreement)
        .unwrap_or(own)
}

fn extract(
    grid: &Grid3<f32>,
    iso: f32,
    gradients: Option<&[Vec4]>,
    surface: Option<&dyn Surface>,
) -> Result<TriMesh> {
    let values: Vec<f32> = grid
        .data()
        .iter()
        .map(|v| if v.is_nan() { f32::MAX } else { v - iso })
        .collect();
    let dims = grid.dims();
    let [nx, ny, nz] = dims;
    let mut b = Builder {
        values: &values,
        grid_origin: grid.origin(),
        spacing: grid.spacing(),
        dims,
        vertex_of_edge: HashMap::new(),
        positions: Vec::new(),
        crossings: Vec::new(),
        triangles: Vec::new(),
    };
    for k in 0..nz.saturating_sub(1) {
        for j in 0..ny.saturating_sub(1) {
            for i in 0..nx.saturating_sub(1) {
                let corners: [usize; 8] = std::array::from_fn(|c| {
                    (i + (c & 1)) + nx * ((j + ((c >> 1) & 1)) + ny * (k + ((c >> 2) & 1)))
                });
                let negative = corners.iter().filter(|&&n| values[n] < 0.0).count();
                if negative == 0 || negative == 8 {
                    continue;
                }
                for tet in TETRAHEDRA {
                    b.tetrahedron(tet.map(|c| corners[c]));
                }
            }
        }
    }
    let located = match surface {
        Some(surface) => b.locate_missed_crossings(surface),
        None => Vec::new(),
    };
    let Builder {
        positions,
        crossings,
        triangles,
        ..
    } = b;
    let points = PointSet::new(positions)?;
    let mut mesh = TriMesh::new(points, triangles)?;
    let own = mesh.vertex_normals(NormalWeighting::Angle);
    let normals = match gradients {
        Some(g) => crossings
            .iter()
            .zip(own)
            .enumerate()
            .map(|(v, (&crossing, own))| {
                let agreement = if located.binary_search(&v).is_ok() {
                    MOVED_NORMAL_AGREEMENT
                } else {
                    0.0
                };
                gradient_normal(g, crossing, own, agreement)
            })
            .collect(),
        None => own,
    };
    let (vertices, tris, _) = mesh.into_parts();
    mesh = TriMesh::new(vertices.with_normals(normals)?, tris)?;
    Ok(mesh)
}
