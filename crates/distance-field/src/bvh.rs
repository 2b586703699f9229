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
        let mut stack = vec![0usize];
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
                Node::Inner { left, right, .. } => stack.extend([*left, *right]),
            }
        }
        (solid_angle / (4.0 * std::f64::consts::PI)) as f32
    }
}
