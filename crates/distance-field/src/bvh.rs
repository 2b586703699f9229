//! A bounding-volume hierarchy over items given by their boxes and centroids (triangles of
//! a mesh, samples of a point cloud), built by median splits along the longest axis of the
//! centroids' box, with the far-field dipoles that winding numbers sum
//! ([`crate::winding`]).

use glam::Vec3;
use pointset_core::Aabb;

use crate::winding::Dipole;

/// A node of the hierarchy: a leaf holds a range of [`Bvh::order`], an inner node two
/// children (stored after it).
#[derive(Debug, Clone)]
pub(crate) enum Node {
    /// Items `order[start..end]`.
    Leaf {
        /// Box of the leaf's items.
        bounds: Aabb,
        /// First position in `order`.
        start: usize,
        /// One past the last position in `order`.
        end: usize,
    },
    /// Two children.
    Inner {
        /// Box of both children.
        bounds: Aabb,
        /// Index of the left child.
        left: usize,
        /// Index of the right child.
        right: usize,
    },
}

impl Node {
    /// The node's box.
    pub fn bounds(&self) -> &Aabb {
        match self {
            Node::Leaf { bounds, .. } | Node::Inner { bounds, .. } => bounds,
        }
    }
}

/// A range of `order` waiting to become a node, and its parent link (index, is-left).
struct PendingNode {
    start: usize,
    end: usize,
    parent: Option<(usize, bool)>,
}

/// The hierarchy: nodes (the root first, children after their parent) and the item order
/// its leaves index into.
#[derive(Debug, Clone)]
pub(crate) struct Bvh {
    /// The nodes; `nodes[0]` is the root.
    pub nodes: Vec<Node>,
    /// Item indices, grouped so that every leaf owns a contiguous range.
    pub order: Vec<usize>,
}

impl Bvh {
    /// Builds the hierarchy over items `0..count` (at least one) with at most `leaf_size`
    /// items per leaf. Ties between equal centroids are broken by item index, so the tree
    /// depends only on the items.
    pub fn build(
        count: usize,
        leaf_size: usize,
        item_bounds: impl Fn(usize) -> Aabb,
        centroid: impl Fn(usize) -> Vec3,
    ) -> Self {
        let mut order: Vec<usize> = (0..count).collect();
        let mut nodes = Vec::with_capacity(2 * count / leaf_size.max(1) + 1);
        let mut stack = vec![PendingNode {
            start: 0,
            end: count,
            parent: None,
        }];
        while let Some(PendingNode { start, end, parent }) = stack.pop() {
            let slice = &mut order[start..end];
            let bounds = slice
                .iter()
                .map(|&t| item_bounds(t))
                .reduce(Aabb::union)
                .unwrap_or(Aabb::new(Vec3::ZERO, Vec3::ZERO));
            let me = nodes.len();
            if let Some((p, is_left)) = parent
                && let Node::Inner { left, right, .. } = &mut nodes[p]
            {
                if is_left {
                    *left = me;
                } else {
                    *right = me;
                }
            }
            if slice.len() <= leaf_size.max(1) {
                nodes.push(Node::Leaf { bounds, start, end });
                continue;
            }
            let cb = slice
                .iter()
                .map(|&t| {
                    let c = centroid(t);
                    Aabb::new(c, c)
                })
                .reduce(Aabb::union)
                .unwrap_or(bounds);
            let e = cb.extent();
            let axis = if e.x >= e.y && e.x >= e.z {
                0
            } else if e.y >= e.z {
                1
            } else {
                2
            };
            let mid = slice.len() / 2;
            slice.select_nth_unstable_by(mid, |&a, &b| {
                centroid(a)[axis]
                    .total_cmp(&centroid(b)[axis])
                    .then(a.cmp(&b))
            });
            nodes.push(Node::Inner {
                bounds,
                left: usize::MAX,
                right: usize::MAX,
            });
            stack.push(PendingNode {
                start: start + mid,
                end,
                parent: Some((me, false)),
            });
            stack.push(PendingNode {
                start,
                end: start + mid,
                parent: Some((me, true)),
            });
        }
        Self { nodes, order }
    }

    /// The root's box.
    pub fn bounds(&self) -> Aabb {
        *self.nodes[0].bounds()
    }

    /// Every node's dipole, a leaf's from `leaf_dipole` of its items; children come after
    /// their parent, so a reverse pass sees both children of a node before the node.
    pub fn dipoles(&self, leaf_dipole: impl Fn(&[usize]) -> Dipole) -> Vec<Dipole> {
        let mut dipoles = vec![Dipole::default(); self.nodes.len()];
        for n in (0..self.nodes.len()).rev() {
            dipoles[n] = match &self.nodes[n] {
                Node::Leaf { start, end, .. } => leaf_dipole(&self.order[*start..*end]),
                Node::Inner { left, right, .. } => dipoles[*left].join(&dipoles[*right]),
            };
        }
        dipoles
    }

    /// The items' total solid angle at `q` over 4π (the winding number): a node's dipole
    /// where `q` is far enough from it ([`Dipole::far_solid_angle`]), else its children,
    /// and at the leaves `item_solid_angle` of each item. NaN for a non-finite `q`.
    pub fn winding_number(
        &self,
        dipoles: &[Dipole],
        q: Vec3,
        item_solid_angle: impl Fn(usize) -> f64,
    ) -> f32 {
        if !q.is_finite() {
            return f32::NAN;
        }
        let mut solid_angle = 0.0f64;
        let mut stack = NodeStack::new(0);
        while let Some(node) = stack.pop() {
            if let Some(far) = dipoles[node].far_solid_angle(q) {
                solid_angle += far;
                continue;
            }
            match &self.nodes[node] {
                Node::Leaf { start, end, .. } => {
                    solid_angle += self.order[*start..*end]
                        .iter()
                        .map(|&t| item_solid_angle(t))
                        .sum::<f64>();
                }
                Node::Inner { left, right, .. } => {
                    stack.push(*left);
                    stack.push(*right);
                }
            }
        }
        (solid_angle / (4.0 * std::f64::consts::PI)) as f32
    }
}

/// How many entries a [`NodeStack`] holds in place. A median split leaves at most half
/// (rounded up) of a node's items to each child, so a hierarchy over `n` items is at most
/// ⌈log₂ n⌉ + 1 levels deep, and a depth-first search that pushes both children of the
/// node it takes holds at most one entry a level more than that: 66 entries cover a
/// hierarchy over as many items as a `usize` counts.
const INLINE_ENTRIES: usize = 66;

/// The nodes a depth-first search of the hierarchy still has to visit (last in, first
/// out), held in place: a query allocates nothing. Both searches run once a grid node, on
/// every thread at once, and a stack on the heap made them contend for the allocator's
/// lock: `geosynth sdf` of a 9,000-triangle mesh at 384 nodes took 15 s with the progress
/// bar shown against 6 s without (docs/performance.md). Entries past
/// [`INLINE_ENTRIES`], which no median-split hierarchy reaches, go to the heap.
pub(crate) struct NodeStack<T> {
    inline: [T; INLINE_ENTRIES],
    len: usize,
    spilled: Vec<T>,
}

impl<T: Copy + Default> NodeStack<T> {
    /// A stack holding `first`.
    pub fn new(first: T) -> Self {
        let mut stack = Self {
            inline: [T::default(); INLINE_ENTRIES],
            len: 0,
            spilled: Vec::new(),
        };
        stack.push(first);
        stack
    }

    /// Puts `entry` on top.
    pub fn push(&mut self, entry: T) {
        match self.inline.get_mut(self.len) {
            Some(slot) if self.spilled.is_empty() => {
                *slot = entry;
                self.len += 1;
            }
            _ => self.spilled.push(entry),
        }
    }

    /// Takes the top entry.
    pub fn pop(&mut self) -> Option<T> {
        if let Some(entry) = self.spilled.pop() {
            return Some(entry);
        }
        self.len = self.len.checked_sub(1)?;
        self.inline.get(self.len).copied()
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        /// Pushes and pops in any order, past the entries held in place and back, give
        /// what a `Vec` used as a stack gives.
        #[test]
        fn node_stack_is_last_in_first_out(
            ops in proptest::collection::vec(0u8..3, 0..400),
        ) {
            let mut stack = NodeStack::new(0usize);
            let mut reference = vec![0usize];
            for (i, op) in ops.into_iter().enumerate() {
                // Two pushes to one pop: the stack grows past its inline entries.
                if op < 2 {
                    stack.push(i + 1);
                    reference.push(i + 1);
                } else {
                    prop_assert_eq!(stack.pop(), reference.pop());
                }
            }
            while let Some(top) = reference.pop() {
                prop_assert_eq!(stack.pop(), Some(top));
            }
            prop_assert_eq!(stack.pop(), None);
        }
    }

    /// A search over a million items never holds more entries than the stack keeps in
    /// place: the hierarchy is as shallow as the median splits promise.
    #[test]
    fn a_median_split_hierarchy_is_shallow() {
        let count = 1 << 20;
        let position = |i: usize| Vec3::new((i % 1000) as f32, (i / 1000) as f32, 0.0);
        let bvh = Bvh::build(count, 1, |i| Aabb::new(position(i), position(i)), position);
        let mut deepest = 0;
        let mut pending = vec![(0usize, 1usize)];
        while let Some((node, depth)) = pending.pop() {
            deepest = deepest.max(depth);
            if let Node::Inner { left, right, .. } = &bvh.nodes[node] {
                pending.extend([(*left, depth + 1), (*right, depth + 1)]);
            }
        }
        assert_eq!(deepest, 21, "⌈log₂ 2²⁰⌉ + 1 levels");
        assert!(deepest < INLINE_ENTRIES);
    }
}
