//! Reconstruction (b) of paper 001 §5.3, the paper's way: [`copied_mesh`]. Every target
//! sample is owned by the block that wrote it; a source triangle belongs to the source
//! sample nearest its centroid, and the block that copied that sample copies the triangle,
//! moved by the block's offset. Pieces from different blocks do not meet exactly, so the
//! mesh is then relaxed to close the seams:
//! 1. *weld* — every open-boundary vertex joins the nearest boundary vertex of another piece
//!    within `weld_radius` spacings (clusters move to their mean);
//! 2. *relax* — vertices within `rings` edges of a weld are smoothed (umbrella operator,
//!    step `step`) and pulled back onto the target field's zero set (one Newton step along
//!    its gradient), `iterations` times.
//!
//! The paper only says "mesh relaxation"; welding first is our reading of "close seams", as
//! smoothing alone cannot join pieces that share no vertices.
//!
//! Memory: the copy adds about 45 bytes per copied triangle at its peak (balls, 32³ source
//! to 128³ target, 7.2 million triangles: 322 MB over what the process held before; 160
//! bytes a triangle when it hashed its edges, clusters and triangles, see
//! [`copied_mesh`]); [`copied_triangle_count`] gives the count before anything is copied.

use std::collections::HashMap;

use glam::Vec3;
use pointset_core::{DisjointSets, KdIndex, PointSet, TriMesh};
use rayon::prelude::*;

use crate::error::{Result, invalid};
use crate::synth::{BlockCopy, Synthesis};

/// Parameters of the seam relaxation in [`copied_mesh`].
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
#[non_exhaustive]
pub struct RelaxParams {
    /// Largest distance, in sample spacings, between boundary vertices that are welded;
    /// default 1, at most [`MAX_WELD_RADIUS`].
    pub weld_radius: f32,
    /// Smoothing + projection rounds; default 8, at most [`MAX_RELAX_ITERATIONS`].
    pub iterations: usize,
    /// Vertices within this many edges of a weld are relaxed; default 2. Any count
    /// beyond the mesh's reach relaxes every vertex connected to a weld.
    pub rings: usize,
    /// Umbrella step in `(0, 1]`; default 0.5.
    pub step: f32,
}

/// Most relaxation rounds [`RelaxParams::validate`] accepts (the default is 8): the bound
/// catches a mistyped count (`1000000000` from `geosynth voxel --params` was still running
/// after a minute).
pub const MAX_RELAX_ITERATIONS: usize = 100;

/// Largest weld radius [`RelaxParams::validate`] accepts, in sample spacings (the default
/// is 1). Copied pieces meet within about a spacing; farther apart, welding joins pieces
/// that are not seams and folds triangles over. Measured on the torus fixture
/// (`geosynth voxel fixtures/torus_mesh.ply`, 128³): non-manifold edges 143 at radius 1,
/// 1,643 at 4, 1,758 at 50; a radius of 50 was accepted before the bound.
pub const MAX_WELD_RADIUS: f32 = 4.0;

impl Default for RelaxParams {
    fn default() -> Self {
        Self {
            weld_radius: 1.0,
            iterations: 8,
            rings: 2,
            step: 0.5,
        }
    }
}

impl RelaxParams {
    /// Sets the weld radius in sample spacings (default 1, at most [`MAX_WELD_RADIUS`]).
    pub fn weld_radius(mut self, spacings: f32) -> Self {
        self.weld_radius = spacings;
        self
    }

    /// Sets the smoothing + projection rounds (default 8, at most
    /// [`MAX_RELAX_ITERATIONS`]).
    pub fn iterations(mut self, n: usize) -> Self {
        self.iterations = n;
        self
    }

    /// Sets how many edges around a weld are relaxed (default 2).
    pub fn rings(mut self, rings: usize) -> Self {
        self.rings = rings;
        self
    }

    /// Sets the umbrella step (default 0.5).
    pub fn step(mut self, step: f32) -> Self {
        self.step = step;
        self
    }

    /// Checks the weld radius (in `[0, MAX_WELD_RADIUS]`), the step (in `(0, 1]`) and the
    /// rounds (at most [`MAX_RELAX_ITERATIONS`]).
    pub fn validate(&self) -> Result<()> {
        if self.iterations > MAX_RELAX_ITERATIONS {
            return Err(invalid(
                "iterations",
                self.iterations,
                "at most 100 rounds (MAX_RELAX_ITERATIONS)",
            ));
        }
        if !(0.0..=MAX_WELD_RADIUS).contains(&self.weld_radius) {
            return Err(invalid(
                "weld_radius",
                self.weld_radius,
                "0 to 4 sample spacings (MAX_WELD_RADIUS)",
            ));
        }
        if !(self.step > 0.0 && self.step <= 1.0) {
            return Err(invalid("step", self.step, "a step in (0, 1]"));
        }
        Ok(())
    }
}

/// The copied-triangle reconstruction and what its relaxation achieved.
#[derive(Debug, Clone)]
pub struct CopiedMesh {
    /// The welded, relaxed mesh.
    pub mesh: TriMesh,
    /// Source triangles copied (a triangle copied by two blocks counts twice).
    pub copied_triangles: usize,
    /// Open boundary edges right after copying.
    pub boundary_edges_before: usize,
    /// Open boundary edges after welding and relaxation.
    pub boundary_edges_after: usize,
    /// Vertices merged away by welding.
    pub welded_vertices: usize,
    /// Mean |target distance| at the relaxed vertices before relaxation (world units).
    pub seam_distance_before: f64,
    /// The same after relaxation.
    pub seam_distance_after: f64,
}

/// For each triangle of `source_mesh` (in the world frame of the source field), the index
/// of the source sample nearest its centroid, the sample it travels with; `None` outside
/// the source field.
fn triangle_samples<'a>(
    source_mesh: &'a TriMesh,
    synthesis: &'a Synthesis,
) -> impl Iterator<Item = Option<usize>> + 'a {
    let positions = source_mesh.positions();
    let sdims = synthesis.source_dims;
    source_mesh.triangles().iter().map(move |t| {
        let c =
            (positions[t[0] as usize] + positions[t[1] as usize] + positions[t[2] as usize]) / 3.0;
        let u = ((c - synthesis.origin) / synthesis.spacing).round();
        if !u.is_finite() || u.min_element() < 0.0 {
            return None;
        }
        let s = [u.x as usize, u.y as usize, u.z as usize];
        (0..3)
            .all(|a| s[a] < sdims[a])
            .then(|| s[0] + sdims[0] * (s[1] + sdims[1] * s[2]))
    })
}

/// The source samples (as indices into the source field) behind the target samples that
/// `copy`, block `j` of the last iteration, owns, in scan-line order within the block.
fn owned_source_samples<'a>(
    synthesis: &'a Synthesis,
    j: usize,
    copy: &'a BlockCopy,
) -> impl Iterator<Item = usize> + 'a {
    let sdims = synthesis.source_dims;
    let tdims = synthesis.field.dims();
    let m = synthesis.levels.last().map_or(0, |l| l.block);
    (0..m * m * m).filter_map(move |x| {
        let o = [x % m, (x / m) % m, x / (m * m)];
        let t = [0, 1, 2].map(|a| copy.target[a] + o[a]);
        let s = [0, 1, 2].map(|a| copy.source[a] + o[a]);
        let owned = (0..3).all(|a| t[a] < tdims[a] && s[a] < sdims[a])
            && synthesis.owner[synthesis.field.index(t[0], t[1], t[2])] == j as u32;
        owned.then(|| s[0] + sdims[0] * (s[1] + sdims[1] * s[2]))
    })
}

/// How many source triangles [`copied_mesh`] copies for `synthesis` (its
/// [`CopiedMesh::copied_triangles`]), counted without copying any: the memory the copy
/// needs grows with this number, so a caller can check it first. `O(target samples)`.
pub fn copied_triangle_count(source_mesh: &TriMesh, synthesis: &Synthesis) -> usize {
    let sdims = synthesis.source_dims;
    let mut per_sample = vec![0usize; sdims.iter().product()];
    for s in triangle_samples(source_mesh, synthesis).flatten() {
        per_sample[s] += 1;
    }
    synthesis
        .copies
        .par_iter()
        .enumerate()
        .map(|(j, copy)| {
            owned_source_samples(synthesis, j, copy)
                .map(|s| per_sample[s])
                .sum::<usize>()
        })
        .sum()
}

/// Copies the triangles of `source_mesh` (in the world frame of the source field) block by
/// block to the target, then welds and relaxes the seams (see the module docs).
///
/// Each step keeps only what the next needs: pieces are copied with one vertex map per
/// block; edges are counted by sorting (not hashing) them; welded vertices are gathered in
/// arrays indexed by their cluster; and the relaxation builds neighbour lists for the
/// vertices it moves only.
pub fn copied_mesh(
    source_mesh: &TriMesh,
    synthesis: &Synthesis,
    relax: &RelaxParams,
) -> Result<CopiedMesh> {
    relax.validate()?;
    let pieces = copy_pieces(source_mesh, synthesis);
    let copied_triangles = pieces.triangles.len();
    let boundary = boundary_edges(&pieces.triangles);
    let boundary_edges_before = boundary.len();
    let welded = weld(pieces, &boundary, relax.weld_radius * synthesis.spacing)?;
    drop(boundary);
    let Welded {
        mut positions,
        welded: is_welded,
        triangles,
        merged: welded_vertices,
    } = welded;

    // Relax the neighbourhood of the welds toward the target surface.
    let grid = synthesis.distances()?;
    let active = relaxed_vertices(&triangles, &is_welded, relax.rings);
    let neighbours = Neighbours::of(&active, &triangles, positions.len());
    drop(is_welded);
    let distance_at = |p: Vec3| grid.trilinear(p);
    let mean_abs = |pts: &[Vec3]| {
        let d: Vec<f64> = active
            .iter()
            .filter_map(|&v| distance_at(pts[v as usize]).map(|d| f64::from(d.abs())))
            .collect();
        d.iter().sum::<f64>() / d.len().max(1) as f64
    };
    let seam_distance_before = mean_abs(&positions);
    let spacing = synthesis.spacing;
    let h = 0.5 * spacing;
    let mut previous = positions.clone();
    for _ in 0..relax.iterations {
        previous.copy_from_slice(&positions);
        for (slot, &v) in active.iter().enumerate() {
            let n = neighbours.of_slot(slot);
            if n.is_empty() {
                continue;
            }
            let v = v as usize;
            let centre = n.iter().map(|&u| previous[u as usize]).sum::<Vec3>() / n.len() as f32;
            let mut p = previous[v] + (centre - previous[v]) * relax.step;
            if let Some(d) = distance_at(p) {
                let g = Vec3::new(
                    distance_at(p + Vec3::X * h).unwrap_or(d)
                        - distance_at(p - Vec3::X * h).unwrap_or(d),
                    distance_at(p + Vec3::Y * h).unwrap_or(d)
                        - distance_at(p - Vec3::Y * h).unwrap_or(d),
                    distance_at(p + Vec3::Z * h).unwrap_or(d)
                        - distance_at(p - Vec3::Z * h).unwrap_or(d),
                ) / (2.0 * h);
                let g2 = g.length_squared();
                if g2 > 1e-6 {
                    // Newton step onto the zero set, at most one spacing.
                    p -= (g * (d / g2)).clamp_length_max(spacing);
                }
            }
            positions[v] = p;
        }
    }
    drop(previous);
    drop(neighbours);
    let seam_distance_after = mean_abs(&positions);
    let boundary_edges_after = boundary_edges(&triangles).len();
    // Welding collapses some copied triangles onto an edge; their vertices go too.
    let mesh =
        TriMesh::new(PointSet::new(positions)?, triangles)?.into_without_unreferenced_vertices()?;
    Ok(CopiedMesh {
        mesh,
        copied_triangles,
        boundary_edges_before,
        boundary_edges_after,
        welded_vertices,
        seam_distance_before,
        seam_distance_after,
    })
}

/// The copied pieces before welding: every block's triangles with vertices of their own.
struct Pieces {
    /// Vertex positions, moved by their block's offset.
    positions: Vec<Vec3>,
    /// For each vertex, the block (index in the synthesis' copies) that copied it.
    piece: Vec<u32>,
    /// The copied triangles.
    triangles: Vec<[u32; 3]>,
}

/// Copies, block by block, the source triangles of the samples each block owns.
fn copy_pieces(source_mesh: &TriMesh, synthesis: &Synthesis) -> Pieces {
    let source_positions = source_mesh.positions();
    let mut by_sample: HashMap<usize, Vec<u32>> = HashMap::new();
    for (i, sample) in triangle_samples(source_mesh, synthesis).enumerate() {
        if let Some(s) = sample {
            by_sample.entry(s).or_default().push(i as u32);
        }
    }
    let mut pieces = Pieces {
        positions: Vec::new(),
        piece: Vec::new(),
        triangles: Vec::new(),
    };
    let mut local: HashMap<u32, u32> = HashMap::new();
    for (j, copy) in synthesis.copies.iter().enumerate() {
        let shift = Vec3::new(
            copy.target[0] as f32 - copy.source[0] as f32,
            copy.target[1] as f32 - copy.source[1] as f32,
            copy.target[2] as f32 - copy.source[2] as f32,
        ) * synthesis.spacing;
        local.clear();
        for s in owned_source_samples(synthesis, j, copy) {
            let Some(list) = by_sample.get(&s) else {
                continue;
            };
            for &ti in list {
                let tri = source_mesh.triangles()[ti as usize];
                pieces.triangles.push(tri.map(|v| {
                    *local.entry(v).or_insert_with(|| {
                        pieces.positions.push(source_positions[v as usize] + shift);
                        pieces.piece.push(j as u32);
                        (pieces.positions.len() - 1) as u32
                    })
                }));
            }
        }
    }
    pieces
}

/// The edges of exactly one triangle, as `(smaller, larger)` vertex pairs in increasing
/// order. Counted by sorting the edges packed in 64 bits (8 bytes an edge where a hash map
/// took about 48 bytes a triangle).
fn boundary_edges(triangles: &[[u32; 3]]) -> Vec<(u32, u32)> {
    let mut edges: Vec<u64> = triangles
        .iter()
        .flat_map(|t| {
            (0..3).map(move |e| {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
            })
        })
        .collect();
    edges.par_sort_unstable();
    edges
        .chunk_by(|a, b| a == b)
        .filter(|run| run.len() == 1)
        .map(|run| ((run[0] >> 32) as u32, run[0] as u32))
        .collect()
}

/// The mesh after welding.
struct Welded {
    /// One position per cluster of welded vertices (their mean), in order of first use.
    positions: Vec<Vec3>,
    /// For each vertex, whether it merged two or more copied vertices.
    welded: Vec<bool>,
    /// The triangles on the new vertices, without those that collapsed onto an edge and
    /// without repeats (the first of equal triangles kept).
    triangles: Vec<[u32; 3]>,
    /// Copied vertices merged away.
    merged: usize,
}

/// Welds every open-boundary vertex to the nearest boundary vertex of another piece within
/// `radius` (world units), and replaces each cluster by its mean.
fn weld(pieces: Pieces, boundary: &[(u32, u32)], radius: f32) -> Result<Welded> {
    let Pieces {
        positions,
        piece,
        triangles,
    } = pieces;
    let mut open: Vec<u32> = boundary.iter().flat_map(|&(a, b)| [a, b]).collect();
    open.sort_unstable();
    open.dedup();
    let mut sets = DisjointSets::new(positions.len());
    if !open.is_empty() && radius > 0.0 {
        let points: Vec<Vec3> = open.iter().map(|&v| positions[v as usize]).collect();
        let index = KdIndex::new(&points)?;
        for (bi, &v) in open.iter().enumerate() {
            let near = index.nearest_within(points[bi], 8, radius)?;
            if let Some(n) = near
                .iter()
                .find(|n| piece[open[n.index] as usize] != piece[v as usize])
            {
                sets.join(v, open[n.index]);
            }
        }
    }
    drop(piece);
    let roots: Vec<u32> = (0..positions.len() as u32).map(|v| sets.root(v)).collect();
    drop(sets);
    // Sums and counts by cluster root, added in vertex order.
    let mut total = vec![(Vec3::ZERO, 0u32); positions.len()];
    for (v, &r) in roots.iter().enumerate() {
        let t = &mut total[r as usize];
        t.0 += positions[v];
        t.1 += 1;
    }
    let clusters = total.iter().filter(|t| t.1 > 0).count();
    let mut new_index = vec![u32::MAX; positions.len()];
    let mut out: Vec<Vec3> = Vec::with_capacity(clusters);
    let mut welded: Vec<bool> = Vec::with_capacity(clusters);
    for &r in &roots {
        if new_index[r as usize] == u32::MAX {
            let (p, n) = total[r as usize];
            out.push(p / n as f32);
            welded.push(n > 1);
            new_index[r as usize] = (out.len() - 1) as u32;
        }
    }
    let merged = positions.len() - clusters;
    drop(total);
    drop(positions);
    let renumbered: Vec<[u32; 3]> = triangles
        .into_iter()
        .map(|t| t.map(|v| new_index[roots[v as usize] as usize]))
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .collect();
    Ok(Welded {
        positions: out,
        welded,
        triangles: first_of_equal(renumbered),
        merged,
    })
}

/// `triangles` without repeats (the same three vertices in any order), the first of each
/// kept, in order. Found by sorting (16 bytes a triangle where a hash set took about 30).
fn first_of_equal(triangles: Vec<[u32; 3]>) -> Vec<[u32; 3]> {
    let mut keyed: Vec<([u32; 3], u32)> = triangles
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let mut key = *t;
            key.sort_unstable();
            (key, i as u32)
        })
        .collect();
    keyed.par_sort_unstable();
    let mut repeat = vec![false; triangles.len()];
    for run in keyed.chunk_by(|a, b| a.0 == b.0) {
        for &(_, i) in &run[1..] {
            repeat[i as usize] = true;
        }
    }
    drop(keyed);
    triangles
        .into_iter()
        .zip(repeat)
        .filter_map(|(t, r)| (!r).then_some(t))
        .collect()
}

/// The vertices within `rings` edges of a welded vertex (the welded ones included), in
/// increasing order: breadth-first from the welded vertices, one pass over the triangles
/// per ring (every two vertices of a triangle share an edge).
fn relaxed_vertices(triangles: &[[u32; 3]], welded: &[bool], rings: usize) -> Vec<u32> {
    let mut reached: Vec<bool> = welded.to_vec();
    let mut frontier: Vec<bool> = welded.to_vec();
    for _ in 0..rings {
        let mut next = vec![false; reached.len()];
        let mut grew = false;
        for t in triangles {
            if t.iter().any(|&v| frontier[v as usize]) {
                for &v in t {
                    if !reached[v as usize] {
                        reached[v as usize] = true;
                        next[v as usize] = true;
                        grew = true;
                    }
                }
            }
        }
        if !grew {
            // Every vertex connected to a weld is reached: more rings add nothing (a
            // count of 2^64 − 1 ran one pass each).
            break;
        }
        frontier = next;
    }
    (0..reached.len() as u32)
        .filter(|&v| reached[v as usize])
        .collect()
}

/// Neighbour lists of some vertices (each sorted, without repeats), stored one after
/// another.
struct Neighbours {
    /// Where each listed vertex's neighbours start in `flat` (one more entry than vertices).
    start: Vec<usize>,
    /// The lists, one after another.
    flat: Vec<u32>,
}

impl Neighbours {
    /// The neighbours of the vertices in `listed` (increasing) among `vertex_count`
    /// vertices, over the edges of `triangles`.
    fn of(listed: &[u32], triangles: &[[u32; 3]], vertex_count: usize) -> Self {
        let mut slot = vec![u32::MAX; vertex_count];
        for (i, &v) in listed.iter().enumerate() {
            slot[v as usize] = i as u32;
        }
        let edges = || {
            triangles.iter().flat_map(|t| {
                (0..3).flat_map(move |e| {
                    let (a, b) = (t[e], t[(e + 1) % 3]);
                    [(a, b), (b, a)]
                })
            })
        };
        let mut start = vec![0usize; listed.len() + 1];
        for (a, _) in edges() {
            let s = slot[a as usize];
            if s != u32::MAX {
                start[s as usize + 1] += 1;
            }
        }
        for i in 0..listed.len() {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut flat = vec![0u32; start[listed.len()]];
        for (a, b) in edges() {
            let s = slot[a as usize];
            if s != u32::MAX {
                flat[fill[s as usize]] = b;
                fill[s as usize] += 1;
            }
        }
        // Sort and deduplicate each list, packing the lists together again.
        let mut packed = 0;
        for i in 0..listed.len() {
            let list = &mut flat[start[i]..start[i + 1]];
            list.sort_unstable();
            let mut kept = 0;
            for k in 0..list.len() {
                if k == 0 || list[k] != list[k - 1] {
                    list[kept] = list[k];
                    kept += 1;
                }
            }
            flat.copy_within(start[i]..start[i] + kept, packed);
            start[i] = packed;
            packed += kept;
        }
        start[listed.len()] = packed;
        flat.truncate(packed);
        Self { start, flat }
    }

    /// The neighbours of the `slot`-th listed vertex.
    fn of_slot(&self, slot: usize) -> &[u32] {
        &self.flat[self.start[slot]..self.start[slot + 1]]
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use std::collections::{HashSet, VecDeque};

    use proptest::prelude::*;

    use super::*;

    /// Triangles on up to `n` vertices, repeats and every winding included, none degenerate.
    fn soup(n: u32) -> impl Strategy<Value = Vec<[u32; 3]>> {
        prop::collection::vec([0..n, 0..n, 0..n], 0..60).prop_map(|ts| {
            ts.into_iter()
                .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
                .collect()
        })
    }

    proptest! {
        #[test]
        fn boundary_edges_are_the_edges_of_one_triangle(ts in soup(12)) {
            let mut count: HashMap<(u32, u32), u32> = HashMap::new();
            for t in &ts {
                for e in 0..3 {
                    let (a, b) = (t[e], t[(e + 1) % 3]);
                    *count.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
            let mut once: Vec<(u32, u32)> =
                count.into_iter().filter(|&(_, c)| c == 1).map(|(e, _)| e).collect();
            once.sort_unstable();
            prop_assert_eq!(boundary_edges(&ts), once);
        }

        #[test]
        fn the_first_of_equal_triangles_is_kept_in_order(ts in soup(6)) {
            let mut seen: HashSet<[u32; 3]> = HashSet::new();
            let kept: Vec<[u32; 3]> = ts
                .iter()
                .copied()
                .filter(|t| {
                    let mut key = *t;
                    key.sort_unstable();
                    seen.insert(key)
                })
                .collect();
            prop_assert_eq!(first_of_equal(ts), kept);
        }

        #[test]
        fn relaxed_vertices_and_their_neighbours_match_a_breadth_first_search(
            ts in soup(20),
            welded in prop::collection::vec(any::<bool>(), 20),
            // usize::MAX: every vertex connected to a weld (the search stops when no ring
            // grows).
            rings in prop_oneof![0usize..4, Just(usize::MAX)],
        ) {
            let mut lists: Vec<Vec<u32>> = vec![Vec::new(); 20];
            for t in &ts {
                for e in 0..3 {
                    let (a, b) = (t[e], t[(e + 1) % 3]);
                    lists[a as usize].push(b);
                    lists[b as usize].push(a);
                }
            }
            for l in &mut lists {
                l.sort_unstable();
                l.dedup();
            }
            let mut ring = [usize::MAX; 20];
            let mut queue: VecDeque<usize> = VecDeque::new();
            for v in (0..20).filter(|&v| welded[v]) {
                ring[v] = 0;
                queue.push_back(v);
            }
            while let Some(v) = queue.pop_front() {
                if ring[v] >= rings {
                    continue;
                }
                for &n in &lists[v] {
                    if ring[n as usize] == usize::MAX {
                        ring[n as usize] = ring[v] + 1;
                        queue.push_back(n as usize);
                    }
                }
            }
            let expected: Vec<u32> = (0..20).filter(|&v| ring[v as usize] != usize::MAX).collect();
            let active = relaxed_vertices(&ts, &welded, rings);
            prop_assert_eq!(&active, &expected);
            let neighbours = Neighbours::of(&active, &ts, 20);
            for (slot, &v) in active.iter().enumerate() {
                prop_assert_eq!(neighbours.of_slot(slot), lists[v as usize].as_slice());
            }
        }
    }
}
