//! The search tree of paper 001 §4.1/§4.4 and its best-first search (§4.3, Figure 4).
//!
//! Every block pyramid is a path of *chunks*: level 1 (one sample), then each finer level's
//! eight octants in turn (§4.4's partially identical parents: blocks sharing the first
//! octants of a level share a node). Blocks whose chunks agree are merged into one node per
//! prefix (§4.1's identical nodes). A prefix reached by a single block is stored as one
//! compressed node that refers to the block (nodes reference the global pyramid, not copies).
//!
//! Keys of levels below the block itself are the block's level means rounded to 256 levels,
//! so at most 256 nodes exist at level 1. Rounding makes the stored means differ from the true
//! means by at most ½ level, which can break Eq. 2 by a hair; the search therefore scores a node
//! with the lower bound `max(0, |q − b| − ½)²` per sample, which Eq. 2 keeps below the leaf
//! distance. The best-first search is thus exact: the first block to reach the front of the
//! queue is a best match under Eq. 1.

use std::collections::HashMap;

use rayon::prelude::*;

use crate::error::{Result, VoxelError};
use crate::field::{BoxMeans, QuantizedField};
use crate::radix_heap::RadixHeap;

#[derive(Debug, Clone)]
struct Node {
    /// Chunks fixed so far (0 = root).
    depth: u16,
    /// A block position sharing this prefix (to recompute chunk values from the pyramid).
    rep: u32,
    children: Vec<u32>,
    /// For a full path: every block position with identical levels. For a compressed node:
    /// the single block below it.
    blocks: Vec<u32>,
    compressed: bool,
}

/// Statistics of a built tree.
#[derive(Debug, Clone, PartialEq)]
pub struct TreeStats {
    /// Block size `N`.
    pub block: usize,
    /// Block positions indexed.
    pub blocks: usize,
    /// Nodes per pyramid level (index 0 = level 1); compressed nodes count at their level.
    pub nodes_per_level: Vec<usize>,
    /// Mean number of children of nodes that have children.
    pub branching_factor: f64,
    /// Bytes held by the tree (nodes and the pyramid's box means).
    pub memory_bytes: usize,
    /// Wall time of the build in seconds.
    pub build_seconds: f64,
}

/// The search tree over every `N³` block of a quantized field.
#[derive(Debug, Clone)]
pub struct SearchTree {
    n: usize,
    levels: usize,
    positions: [usize; 3],
    field: QuantizedField,
    /// Box means for levels 1..L−1 (index l−1 → cell N / 2^(l−1)).
    means: Vec<BoxMeans>,
    nodes: Vec<Node>,
    stats: TreeStats,
}

/// Where chunk `d` lies: its level (1-based) and octant (`None` for level 1).
fn chunk_location(d: usize) -> (usize, Option<usize>) {
    if d == 0 {
        (1, None)
    } else {
        (2 + (d - 1) / 8, Some((d - 1) % 8))
    }
}

/// Sample coordinates (within the level, `r` per side) of chunk `octant` of a level.
fn chunk_samples(r: usize, octant: Option<usize>) -> impl Iterator<Item = [usize; 3]> {
    let (lo, h) = match octant {
        None => ([0, 0, 0], 1),
        Some(o) => {
            let h = r / 2;
            ([(o & 1) * h, ((o >> 1) & 1) * h, ((o >> 2) & 1) * h], h)
        }
    };
    (0..h * h * h).map(move |s| [lo[0] + s % h, lo[1] + (s / h) % h, lo[2] + s / (h * h)])
}

/// A query prepared for scoring: its exact level means and its raw block.
struct Query {
    /// Level means per chunk (levels below the block), in chunk sample order.
    chunks: Vec<Vec<f32>>,
    block: Vec<u8>,
}

#[derive(Debug, Clone, Copy)]
struct Entry {
    /// Lower bound of the distance of every block below (exact once the path is complete).
    bound: f32,
    node: u32,
    /// Chunks scored on this path. Equals the node's depth, except on a compressed node,
    /// whose single block's chunks are scored one at a time as the entry returns to the front.
    depth: u16,
    /// Mean of the last complete level (a lower bound by Eq. 2).
    floor: f64,
    /// Sum of the scored chunks of the current level (`f64`: sums of squared levels exceed
    /// the integers `f32` holds exactly).
    partial: f64,
}

/// Eq. 3 queue pruning (§4.3, §5.2) for [`SearchTree::best_match_pruned`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eq3Pruning {
    /// Largest change of the field between neighbouring samples, in quantization levels
    /// (a distance field changes by at most one spacing per spacing: `255 · spacing /
    /// (2 · range)`).
    pub slope: f32,
    /// Squared levels added to every upper bound before pruning (0: prune as soon as Eq. 3
    /// allows).
    pub tolerance: f32,
}

/// What one tree search did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SearchStats {
    /// Entries taken from the queue.
    pub expanded: usize,
    /// Largest number of entries queued at once.
    pub max_queue: usize,
    /// Entries not queued because their lower bound exceeded the limit (the incumbent or
    /// the Eq. 3 bound).
    pub pruned: usize,
}

/// A best match: the block corner and its Eq. 1 distance (in squared quantization levels).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// Corner of the best block in the source field.
    pub corner: [usize; 3],
    /// `dist(B, B')` of Eq. 1.
    pub distance: f32,
}

impl SearchTree {
    /// Builds the tree over every `n³` block of `field` (`n` a power of two ≥ 2).
    pub fn build(field: &QuantizedField, n: usize) -> Result<Self> {
        let start = std::time::Instant::now();
        if !n.is_power_of_two() || n < 2 {
            return Err(VoxelError::InvalidParameter {
                name: "block size",
                value: n.to_string(),
                expected: "a power of two ≥ 2".into(),
            });
        }
        let positions = field.fitting_positions(n)?;
        let count = positions.iter().product::<usize>();
        if count > u32::MAX as usize - 1 {
            return Err(VoxelError::InvalidParameter {
                name: "field",
                value: format!("{count} blocks"),
                expected: "fewer than 2^32 blocks".into(),
            });
        }
        let levels = n.trailing_zeros() as usize + 1;
        let means = (1..levels)
            .map(|l| BoxMeans::new(field, n >> (l - 1)))
            .collect();
        let mut tree = Self {
            n,
            levels,
            positions,
            field: field.clone(),
            means,
            nodes: Vec::new(),
            stats: TreeStats {
                block: n,
                blocks: count,
                nodes_per_level: vec![0; levels],
                branching_factor: 0.0,
                memory_bytes: 0,
                build_seconds: 0.0,
            },
        };
        let all: Vec<u32> = (0..count as u32).collect();
        tree.nodes.push(Node {
            depth: 0,
            rep: 0,
            children: Vec::new(),
            blocks: Vec::new(),
            compressed: false,
        });
        tree.grow_root(all);
        tree.finish_stats(start.elapsed().as_secs_f64());
        Ok(tree)
    }

    /// Number of chunks on a full path.
    fn total_chunks(&self) -> usize {
        1 + 8 * (self.levels - 1)
    }

    fn corner(&self, id: u32) -> [usize; 3] {
        let [px, py, _] = self.positions;
        let id = id as usize;
        [id % px, (id / px) % py, id / (px * py)]
    }

    /// The stored key of chunk `d` of block `id`: rounded level means, or raw values at the
    /// block's own level.
    fn chunk_key(&self, d: usize, id: u32) -> Vec<u8> {
        let corner = self.corner(id);
        let (level, octant) = chunk_location(d);
        let r = 1usize << (level - 1);
        if level == self.levels {
            chunk_samples(r, octant)
                .map(|s| {
                    self.field.values()[self.field.index(
                        corner[0] + s[0],
                        corner[1] + s[1],
                        corner[2] + s[2],
                    )]
                })
                .collect()
        } else {
            let m = &self.means[level - 1];
            let c = m.cell();
            chunk_samples(r, octant)
                .map(|s| {
                    m.mean(
                        corner[0] + s[0] * c,
                        corner[1] + s[1] * c,
                        corner[2] + s[2] * c,
                    )
                    .round() as u8
                })
                .collect()
        }
    }

    /// Groups `blocks` by their key for chunk `depth`, in key order (deterministic).
    fn groups(&self, depth: usize, blocks: Vec<u32>) -> Vec<Vec<u32>> {
        let mut groups: HashMap<Vec<u8>, Vec<u32>> = HashMap::new();
        for b in blocks {
            groups.entry(self.chunk_key(depth, b)).or_default().push(b);
        }
        let mut groups: Vec<(Vec<u8>, Vec<u32>)> = groups.into_iter().collect();
        groups.sort_by(|a, b| a.0.cmp(&b.0));
        groups.into_iter().map(|(_, members)| members).collect()
    }

    /// Builds the subtree for the prefix of length `depth` shared by `blocks` into a local
    /// arena whose node 0 is the subtree's root (child ids are local).
    fn subtree(&self, depth: usize, blocks: Vec<u32>) -> Vec<Node> {
        let total = self.total_chunks();
        let compressed = blocks.len() == 1 && depth < total;
        let mut arena = vec![Node {
            depth: depth as u16,
            rep: blocks[0],
            children: Vec::new(),
            blocks: if compressed || depth == total {
                blocks.clone()
            } else {
                Vec::new()
            },
            compressed,
        }];
        if compressed || depth == total {
            return arena;
        }
        for members in self.groups(depth, blocks) {
            let child = self.subtree(depth + 1, members);
            let offset = arena.len() as u32;
            arena[0].children.push(offset);
            arena.extend(child.into_iter().map(|mut n| {
                n.children.iter_mut().for_each(|c| *c += offset);
                n
            }));
        }
        arena
    }

    /// Attaches the root's children: one subtree per level-1 key, built in parallel and
    /// appended in key order.
    fn grow_root(&mut self, blocks: Vec<u32>) {
        let groups = self.groups(0, blocks);
        let subtrees: Vec<Vec<Node>> = groups
            .into_par_iter()
            .map(|members| self.subtree(1, members))
            .collect();
        for sub in subtrees {
            let offset = self.nodes.len() as u32;
            self.nodes[0].children.push(offset);
            self.nodes.extend(sub.into_iter().map(|mut n| {
                n.children.iter_mut().for_each(|c| *c += offset);
                n
            }));
        }
    }

    fn finish_stats(&mut self, seconds: f64) {
        let mut per_level = vec![0usize; self.levels];
        let (mut parents, mut edges) = (0usize, 0usize);
        for n in &self.nodes[1..] {
            let (level, _) = chunk_location(n.depth as usize - 1);
            per_level[level - 1] += 1;
        }
        for n in &self.nodes {
            if !n.children.is_empty() {
                parents += 1;
                edges += n.children.len();
            }
        }
        let node_bytes: usize = self
            .nodes
            .iter()
            .map(|n| std::mem::size_of::<Node>() + 4 * (n.children.len() + n.blocks.len()))
            .sum();
        let mean_bytes: usize =
            self.means.iter().map(BoxMeans::bytes).sum::<usize>() + self.field.values().len();
        self.stats.nodes_per_level = per_level;
        self.stats.branching_factor = if parents == 0 {
            0.0
        } else {
            edges as f64 / parents as f64
        };
        self.stats.memory_bytes = node_bytes + mean_bytes;
        self.stats.build_seconds = seconds;
    }

    /// Checks the tree's invariants (for tests; `O(blocks × depth)`): children of a node
    /// have pairwise different keys for their chunk, and every block below a node has that
    /// node's key for every chunk on the path — merging never joins different quantized
    /// nodes. Returns the number of blocks reached, which must equal the number indexed.
    pub fn verify(&self) -> std::result::Result<usize, String> {
        let mut reached = 0usize;
        // (node, keys of the path so far)
        let mut stack: Vec<(u32, Vec<Vec<u8>>)> = vec![(0, Vec::new())];
        while let Some((id, path)) = stack.pop() {
            let node = &self.nodes[id as usize];
            let below: Vec<u32> = if node.compressed || node.depth as usize == self.total_chunks() {
                node.blocks.clone()
            } else {
                Vec::new()
            };
            for &b in &below {
                for (d, key) in path.iter().enumerate() {
                    if self.chunk_key(d, b) != *key {
                        return Err(format!("block {b} under node {id} differs at chunk {d}"));
                    }
                }
            }
            reached += below.len();
            let mut keys: Vec<Vec<u8>> = Vec::new();
            for &c in &node.children {
                let key = self.chunk_key(node.depth as usize, self.nodes[c as usize].rep);
                if keys.contains(&key) {
                    return Err(format!("node {id} has two children with the same key"));
                }
                keys.push(key.clone());
                let mut p = path.clone();
                p.push(key);
                stack.push((c, p));
            }
        }
        Ok(reached)
    }

    /// Build statistics.
    pub fn stats(&self) -> &TreeStats {
        &self.stats
    }

    /// Block size `N`.
    pub fn block_size(&self) -> usize {
        self.n
    }

    /// Number of chunks on a path to the leaves of the tree with `drop` levels removed.
    fn final_depth(&self, drop: usize) -> usize {
        1 + 8 * (self.levels - 1 - drop)
    }

    fn prepare(&self, query: &[u8], drop: usize) -> Result<Query> {
        let m = self.n >> drop;
        let qf = QuantizedField::from_values([m, m, m], query.to_vec())?;
        let mut chunks = Vec::with_capacity(self.final_depth(drop));
        for d in 0..self.final_depth(drop) {
            let (level, octant) = chunk_location(d);
            if level == self.levels - drop {
                chunks.push(Vec::new());
                continue;
            }
            let r = 1usize << (level - 1);
            let means = BoxMeans::new(&qf, m / r);
            let c = means.cell();
            chunks.push(
                chunk_samples(r, octant)
                    .map(|s| means.mean(s[0] * c, s[1] * c, s[2] * c))
                    .collect(),
            );
        }
        Ok(Query {
            chunks,
            block: query.to_vec(),
        })
    }

    /// Sum over chunk `d` of block `rep`'s lower-bound terms against the query, for the
    /// tree with `drop` levels removed: exact squared differences at its leaf level, and
    /// `max(0, |q − b| − slack)²` below it, where `slack` bounds how far a stored key can lie
    /// from the true level mean of the (subsampled) block: ½ for the rounding of the key,
    /// plus ½ more when the leaf values are themselves rounded means (`drop > 0`).
    fn chunk_score(&self, d: usize, rep: u32, q: &Query, drop: usize) -> f64 {
        let corner = self.corner(rep);
        let (level, octant) = chunk_location(d);
        let r = 1usize << (level - 1);
        if level == self.levels {
            // Raw samples of the block against the raw query.
            let v = self.field.values();
            return chunk_samples(r, octant)
                .map(|s| {
                    let b = f32::from(q.block[s[0] + r * (s[1] + r * s[2])]);
                    let k =
                        v[self
                            .field
                            .index(corner[0] + s[0], corner[1] + s[1], corner[2] + s[2])];
                    f64::from((f32::from(k) - b).powi(2))
                })
                .sum();
        }
        let m = &self.means[level - 1];
        let c = m.cell();
        let key = |s: [usize; 3]| {
            m.mean(
                corner[0] + s[0] * c,
                corner[1] + s[1] * c,
                corner[2] + s[2] * c,
            )
            .round()
        };
        if level == self.levels - drop {
            chunk_samples(r, octant)
                .map(|s| {
                    f64::from((key(s) - f32::from(q.block[s[0] + r * (s[1] + r * s[2])])).powi(2))
                })
                .sum()
        } else {
            let slack = if drop == 0 { 0.5 } else { 1.0 };
            chunk_samples(r, octant)
                .zip(&q.chunks[d])
                .map(|(s, &b)| f64::from(((key(s) - b).abs() - slack).max(0.0).powi(2)))
                .sum()
        }
    }

    /// The entry for `node` after scoring chunk `d` (of block `rep`) on top of `parent`.
    fn advance(&self, parent: &Entry, node: u32, d: usize, q: &Query, drop: usize) -> Entry {
        let rep = self.nodes[node as usize].rep;
        let (level, octant) = chunk_location(d);
        let samples = (1usize << (level - 1)).pow(3) as f64;
        let score = self.chunk_score(d, rep, q, drop);
        let (floor, partial) = if octant.is_none_or(|o| o == 0) {
            // The previous level is complete: its mean is a floor for everything below.
            let previous = if d == 0 {
                0.0
            } else {
                parent.partial / ((1usize << (level - 2)).pow(3) as f64)
            };
            (parent.floor.max(previous), score)
        } else {
            (parent.floor, parent.partial + score)
        };
        Entry {
            bound: floor.max(partial / samples) as f32,
            node,
            depth: (d + 1) as u16,
            floor,
            partial,
        }
    }

    /// Block corners along each axis (every `N³` block that fits in the field).
    pub fn positions(&self) -> [usize; 3] {
        self.positions
    }

    /// Levels `L = log2 N + 1` of every block pyramid.
    pub fn levels(&self) -> usize {
        self.levels
    }

    /// The block at `corner` as seen by the tree with `drop` leaf levels removed (§5.2): its
    /// pyramid level `L − drop`, `(N / 2^drop)³` values, each the source's mean over a cell of
    /// side `2^drop` rounded to a quantization level (`drop = 0`: the raw block). These values
    /// form the subsampled source of the coarser synthesis iterations.
    ///
    /// `corner` must be a block position and `drop < L`; other values are clamped.
    pub fn subsampled_block(&self, corner: [usize; 3], drop: usize) -> Vec<u8> {
        let drop = drop.min(self.levels - 1);
        let corner = [0, 1, 2].map(|a| corner[a].min(self.positions[a] - 1));
        if drop == 0 {
            return self.field.block(corner, self.n);
        }
        let means = &self.means[self.levels - 1 - drop];
        crate::field::block_level(means, corner, self.n >> drop)
            .into_iter()
            .map(|v| v.round() as u8)
            .collect()
    }

    /// The best-matching block for `query` (`N³` levels, x-fastest) by the best-first
    /// search of Figure 4. Exact; ties go to the lowest block index reached first.
    pub fn best_match(&self, query: &[u8]) -> Result<Match> {
        self.best_match_subsampled(query, 0)
    }

    /// The best match for a query of `(N / 2^drop)³` levels in the tree with its `drop`
    /// finest levels removed — the tree of the source subsampled `drop` times (§5.2) — among
    /// the subsampled blocks of every block position ([`SearchTree::subsampled_block`]).
    /// Exact under Eq. 1 on those values; `drop = 0` is [`SearchTree::best_match`].
    pub fn best_match_subsampled(&self, query: &[u8], drop: usize) -> Result<Match> {
        self.best_match_below(query, drop, None)
    }

    /// [`SearchTree::best_match_subsampled`] given a block already known to be at distance
    /// `incumbent.distance` (e.g. the block that continues a synthesized neighbour): entries
    /// whose lower bound exceeds it are never queued (branch and bound), and the incumbent
    /// is returned when nothing in the tree is closer. Still exact; only ties may resolve
    /// differently.
    pub fn best_match_below(
        &self,
        query: &[u8],
        drop: usize,
        incumbent: Option<Match>,
    ) -> Result<Match> {
        Ok(self.search(query, drop, incumbent, None)?.0)
    }

    /// The best-first search with the Eq. 3 queue pruning of §4.3: an entry that completes
    /// level `l` with mean distance `d_l` bounds every leaf below it by
    /// `U = d_l + Σ ε_k` over the remaining level steps, and entries whose lower bound
    /// exceeds the smallest such `U` plus `pruning.tolerance` are not queued. Exact when the
    /// query is a valid distance field and the source's slope bound holds; otherwise (e.g.
    /// synthesis queries with unsynthesized samples, §5.2) the result may be a near-best
    /// match, within the tolerance in the worst case the paper accepts; should the bound be
    /// so wrong that every path is pruned, the search is repeated without pruning. Returns
    /// the search statistics beside the match.
    pub fn best_match_pruned(
        &self,
        query: &[u8],
        drop: usize,
        pruning: &Eq3Pruning,
    ) -> Result<(Match, SearchStats)> {
        self.search(query, drop, None, Some(pruning))
    }

    /// ε of Eq. 3 for the step from level `l` to `l + 1` (squared levels): twice the largest
    /// difference between a child cell's mean and its parent's — cells `√3 · c` apart at
    /// most, `c` the child's side in samples, at `slope` levels per sample, plus 1½ levels
    /// for the rounding of keys and values.
    fn eq3_epsilon(&self, l: usize, slope: f32) -> f64 {
        let child = (self.n >> l).max(1) as f64;
        let delta = 3f64.sqrt() * child * f64::from(slope) + 1.5;
        (2.0 * delta).powi(2)
    }

    fn search(
        &self,
        query: &[u8],
        drop: usize,
        incumbent: Option<Match>,
        pruning: Option<&Eq3Pruning>,
    ) -> Result<(Match, SearchStats)> {
        if drop >= self.levels {
            return Err(VoxelError::InvalidParameter {
                name: "drop",
                value: drop.to_string(),
                expected: "fewer levels than the block pyramid has".into(),
            });
        }
        let m = self.n >> drop;
        if query.len() != m * m * m {
            return Err(VoxelError::InvalidParameter {
                name: "query",
                value: format!("{} values", query.len()),
                expected: "(N / 2^drop)³ values".into(),
            });
        }
        let q = self.prepare(query, drop)?;
        let final_depth = self.final_depth(drop);
        let mut limit = incumbent.map_or(f32::INFINITY, |m| m.distance);
        let leaf_level = self.levels - drop;
        // Σ ε from level l to the leaf level, for every complete level l.
        let remaining: Vec<f64> = (0..=leaf_level)
            .map(|l| match pruning {
                Some(p) => (l.max(1)..leaf_level)
                    .map(|k| self.eq3_epsilon(k, p.slope))
                    .sum(),
                None => 0.0,
            })
            .collect();
        let mut stats = SearchStats::default();
        let mut heap = RadixHeap::new();
        heap.push(
            0.0,
            Entry {
                bound: 0.0,
                node: 0,
                depth: 0,
                floor: 0.0,
                partial: 0.0,
            },
        );
        let push =
            |heap: &mut RadixHeap<Entry>, next: Entry, limit: &mut f32, stats: &mut SearchStats| {
                if next.bound > *limit {
                    stats.pruned += 1;
                    return;
                }
                if let Some(p) = pruning {
                    let d = next.depth as usize;
                    // An entry that completes level l (its last chunk is the level's last).
                    if d >= 1 && (d - 1).is_multiple_of(8) {
                        let l = 1 + (d - 1) / 8;
                        let samples = (1usize << (l - 1)).pow(3) as f64;
                        let upper = next.partial / samples + remaining[l.min(leaf_level)];
                        *limit = limit.min((upper + f64::from(p.tolerance)) as f32);
                    }
                }
                heap.push(next.bound, next);
                stats.max_queue = stats.max_queue.max(heap.len());
            };
        while let Some((_, e)) = heap.pop() {
            stats.expanded += 1;
            let node = &self.nodes[e.node as usize];
            let d = e.depth as usize;
            if d == final_depth {
                // A complete path: its bound is its exact distance, and no entry in the
                // queue (nor anything below one) can be closer.
                let block = node.blocks.first().copied().unwrap_or(node.rep);
                let found = Match {
                    corner: self.corner(block),
                    distance: (e.partial / (m * m * m) as f64) as f32,
                };
                return Ok((found, stats));
            }
            if node.compressed {
                let next = self.advance(&e, e.node, d, &q, drop);
                push(&mut heap, next, &mut limit, &mut stats);
                continue;
            }
            for &child in &node.children {
                push(
                    &mut heap,
                    self.advance(&e, child, d, &q, drop),
                    &mut limit,
                    &mut stats,
                );
            }
        }
        if let Some(m) = incumbent {
            return Ok((m, stats));
        }
        if pruning.is_some() {
            // Eq. 3 did not hold for this query and pruned every path: search again without.
            let (found, again) = self.search(query, drop, None, None)?;
            let total = SearchStats {
                expanded: stats.expanded + again.expanded,
                max_queue: stats.max_queue.max(again.max_queue),
                pruned: stats.pruned + again.pruned,
            };
            return Ok((found, total));
        }
        Err(VoxelError::InvalidParameter {
            name: "tree",
            value: "empty".into(),
            expected: "at least one block".into(),
        })
    }
}
