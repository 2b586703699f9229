//! The queue of planned collapses, cheapest first: a four-ary min-heap of small entries.
//!
//! A binary heap's `pop` was most of a run (about 40% on 200,000 triangles, the cache
//! misses of its twenty levels); four children a node halve the levels, and the four sit
//! side by side. Entries of equal cost and edge come out in either order: such entries
//! differ only in the versions they were planned at, and all but the current one are
//! skipped, so any order gives the same collapses.

use std::cmp::Ordering;

/// A collapse waiting in the queue: its cost, its edge (`keep` the lower index) and the
/// versions its vertices had when it was planned. Kept small (the queue's moves were
/// most of the run with the whole plan in each entry); the plan is made again when the
/// entry comes out, the same while the versions hold.
#[derive(Debug, Clone, Copy)]
pub(super) struct Queued {
    pub(super) cost: f64,
    pub(super) keep: u32,
    pub(super) gone: u32,
    pub(super) versions: [u32; 2],
}

impl Queued {
    /// The order of the queue: cost, then the edge's vertices (the versions do not count).
    fn cmp_key(&self, other: &Self) -> Ordering {
        self.cost
            .total_cmp(&other.cost)
            .then(self.keep.cmp(&other.keep))
            .then(self.gone.cmp(&other.gone))
    }
}

/// Children a node of the heap has.
const ARITY: usize = 4;

/// Planned collapses, the least by [`Queued`]'s order first.
#[derive(Debug, Default)]
pub(super) struct CollapseQueue {
    heap: Vec<Queued>,
}

impl CollapseQueue {
    /// A queue of `entries`, arranged in one pass from the leaves up.
    pub(super) fn from_entries(entries: Vec<Queued>) -> Self {
        let mut queue = Self { heap: entries };
        for node in (0..queue.heap.len().div_ceil(ARITY)).rev() {
            queue.sift_down(node);
        }
        queue
    }

    /// Adds `entry`.
    pub(super) fn push(&mut self, entry: Queued) {
        self.heap.push(entry);
        self.sift_up(self.heap.len() - 1);
    }

    /// Takes out the least entry; `None` when empty.
    pub(super) fn pop(&mut self) -> Option<Queued> {
        let last = self.heap.pop()?;
        if self.heap.is_empty() {
            return Some(last);
        }
        let least = std::mem::replace(&mut self.heap[0], last);
        self.sift_down(0);
        Some(least)
    }

    /// Moves the entry at `node` up past every parent above it in the order.
    fn sift_up(&mut self, mut node: usize) {
        let entry = self.heap[node];
        while node > 0 {
            let parent = (node - 1) / ARITY;
            if entry.cmp_key(&self.heap[parent]) != Ordering::Less {
                break;
            }
            self.heap[node] = self.heap[parent];
            node = parent;
        }
        self.heap[node] = entry;
    }

    /// Moves the entry at `node` down past every child below it in the order.
    fn sift_down(&mut self, mut node: usize) {
        let entry = self.heap[node];
        loop {
            let first = node * ARITY + 1;
            let children = first..(first + ARITY).min(self.heap.len());
            let Some(least) = children.min_by(|&a, &b| self.heap[a].cmp_key(&self.heap[b])) else {
                break;
            };
            if self.heap[least].cmp_key(&entry) != Ordering::Less {
                break;
            }
            self.heap[node] = self.heap[least];
            node = least;
        }
        self.heap[node] = entry;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn entry(cost: f64, edge: u32) -> Queued {
        Queued {
            cost,
            keep: edge,
            gone: edge + 1,
            versions: [0, 0],
        }
    }

    proptest! {
        /// Interleaved pushes and pops come out as a sorted list would give them.
        #[test]
        fn the_least_comes_out_first(
            first in prop::collection::vec((0u8..20, 0u32..50), 0..200),
            steps in prop::collection::vec(prop::option::of((0u8..20, 0u32..50)), 0..400),
        ) {
            let mut queue = CollapseQueue::from_entries(
                first.iter().map(|&(c, e)| entry(f64::from(c), e)).collect(),
            );
            let mut reference: Vec<(u8, u32)> = first.clone();
            for step in steps {
                match step {
                    Some((c, e)) => {
                        queue.push(entry(f64::from(c), e));
                        reference.push((c, e));
                    }
                    None => {
                        reference.sort_unstable_by(|a, b| b.cmp(a));
                        let expected = reference.pop();
                        let popped = queue.pop().map(|q| (q.cost as u8, q.keep));
                        prop_assert_eq!(popped, expected);
                    }
                }
            }
            reference.sort_unstable_by(|a, b| b.cmp(a));
            while let Some(expected) = reference.pop() {
                prop_assert_eq!(queue.pop().map(|q| (q.cost as u8, q.keep)), Some(expected));
            }
            prop_assert!(queue.pop().is_none());
        }
    }
}
