//! The frontier of the orientation's propagation (Prim's algorithm): for each point not
//! yet reached, the least edge known into it, in a 4-ary heap that lowers a point's entry
//! in place.
//!
//! A binary heap of every edge offered, whose reached points' entries are skipped as they
//! come up, pops the same points in the same order from the same parents — each point
//! first comes up with its least entry, and the least of those is the least entry of all —
//! but holds an entry per edge: on 2 million points of a torus it grew to 3.9 million
//! entries and popped 9.2 million. This one holds at most one entry per point and pops
//! each point once.

/// A frontier entry: an edge from a reached point to one not yet reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(super) struct Entry {
    /// What orders the entries (the fields below only follow it): the edge's cost, then
    /// the index in the point set of the point it reaches, then of the point it comes
    /// from. The order is total, and ties go where they went when the graph was numbered
    /// by the points' indices, so the numbering does not change the tree.
    pub(super) key: (u32, u32, u32),
    /// The point the edge reaches, by its rank in the graph's numbering.
    pub(super) point: u32,
    /// The reached point it comes from, by rank.
    pub(super) parent: u32,
}

/// [`Frontier::slot`] of a point with no entry.
const ABSENT: u32 = u32::MAX;

/// [`Frontier::slot`] of a point popped: reached by the propagation. (Entries sit below
/// it: the heap never holds every point, and there are at most `u32::MAX` of them.)
const REACHED: u32 = u32::MAX - 1;

/// Children per node of the heap.
const ARITY: usize = 4;

/// The least known entry into each point not yet reached; see the module docs.
pub(super) struct Frontier {
    /// A 4-ary min-heap of entries, at most one per point.
    heap: Vec<Entry>,
    /// Where each point's entry sits in `heap`; [`ABSENT`] for none yet, [`REACHED`] once
    /// popped. One array for both, so that an offer reads one place.
    slot: Vec<u32>,
}

impl Frontier {
    /// An empty frontier over points `0..points` (fewer than `u32::MAX` of them, as the
    /// orientation's caller checks).
    pub(super) fn new(points: usize) -> Self {
        Self {
            heap: Vec::new(),
            slot: vec![ABSENT; points],
        }
    }

    /// Whether `point` has been popped.
    pub(super) fn reached(&self, point: u32) -> bool {
        self.slot[point as usize] == REACHED
    }

    /// Keeps `entry` if its point has not been popped and has no entry yet or a greater
    /// one.
    pub(super) fn offer(&mut self, entry: Entry) {
        let point = entry.point as usize;
        match self.slot[point] {
            REACHED => {}
            ABSENT => {
                self.heap.push(entry);
                self.rise(self.heap.len() - 1);
            }
            at => {
                let at = at as usize;
                if entry < self.heap[at] {
                    self.heap[at] = entry;
                    self.rise(at);
                }
            }
        }
    }

    /// Takes out the least entry; its point is reached afterwards.
    pub(super) fn pop(&mut self) -> Option<Entry> {
        let last = self.heap.pop()?;
        let least = match self.heap.first_mut() {
            Some(top) => {
                let least = std::mem::replace(top, last);
                self.sink(0);
                least
            }
            None => last,
        };
        self.slot[least.point as usize] = REACHED;
        Some(least)
    }

    /// Moves the entry at `at` up past every greater parent.
    fn rise(&mut self, mut at: usize) {
        let entry = self.heap[at];
        while at > 0 {
            let parent = (at - 1) / ARITY;
            if self.heap[parent] <= entry {
                break;
            }
            self.place(at, self.heap[parent]);
            at = parent;
        }
        self.place(at, entry);
    }

    /// Moves the entry at `at` down past every lesser child.
    fn sink(&mut self, mut at: usize) {
        let entry = self.heap[at];
        loop {
            let first = ARITY * at + 1;
            let children = first..(first + ARITY).min(self.heap.len());
            let least = children.min_by_key(|&child| self.heap[child]);
            match least {
                Some(child) if self.heap[child] < entry => {
                    self.place(at, self.heap[child]);
                    at = child;
                }
                _ => break,
            }
        }
        self.place(at, entry);
    }

    /// Puts `entry` at `at` and notes where its point's entry is.
    fn place(&mut self, at: usize, entry: Entry) {
        self.heap[at] = entry;
        self.slot[entry.point as usize] = at as u32;
    }
}

#[cfg(test)]
mod tests {
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;

    use proptest::prelude::*;

    use super::*;

    /// Points' indices in the tests' point set: a permutation of their ranks.
    fn index_of(rank: u32) -> u32 {
        (rank * 7) % 40
    }

    fn entry(cost: u32, point: u32, parent: u32) -> Entry {
        Entry {
            key: (cost, index_of(point), index_of(parent)),
            point,
            parent,
        }
    }

    /// What the propagation asks of a frontier: offers, and pops.
    #[derive(Debug, Clone)]
    enum Step {
        Offer { cost: u32, point: u32, parent: u32 },
        Pop,
    }

    fn steps() -> impl Strategy<Value = Vec<Step>> {
        let offer = (0u32..6, 0u32..40, 0u32..40).prop_map(|(cost, point, parent)| Step::Offer {
            cost,
            point,
            parent,
        });
        prop::collection::vec(prop_oneof![3 => offer, 2 => Just(Step::Pop)], 0..400)
    }

    proptest! {
        /// The frontier pops what a binary heap of every offer pops when it skips entries
        /// of points already popped (the propagation's first version), offer for offer.
        #[test]
        fn pops_what_a_heap_of_every_offer_pops_first_per_point(steps in steps()) {
            let mut frontier = Frontier::new(40);
            let mut every_offer = BinaryHeap::new();
            let mut popped = [false; 40];
            for step in steps {
                match step {
                    // Offers into popped points too: the frontier ignores them, as the
                    // reference skips them when they come up.
                    Step::Offer { cost, point, parent } => {
                        frontier.offer(entry(cost, point, parent));
                        every_offer.push(Reverse(entry(cost, point, parent)));
                    }
                    Step::Pop => {
                        let first_per_point = std::iter::from_fn(|| every_offer.pop())
                            .map(|Reverse(entry)| entry)
                            .find(|entry| !popped[entry.point as usize]);
                        let got = frontier.pop();
                        prop_assert_eq!(got, first_per_point);
                        if let Some(entry) = got {
                            popped[entry.point as usize] = true;
                        }
                    }
                }
                prop_assert!(frontier.heap.len() <= 40);
                for (point, &done) in (0u32..).zip(&popped) {
                    prop_assert_eq!(frontier.reached(point), done);
                }
                for (at, entry) in frontier.heap.iter().enumerate() {
                    prop_assert_eq!(frontier.slot[entry.point as usize] as usize, at);
                }
            }
        }
    }

    #[test]
    fn an_entry_is_lowered_in_place_and_never_raised() {
        let mut frontier = Frontier::new(3);
        frontier.offer(entry(5, 1, 0));
        frontier.offer(entry(7, 2, 0));
        frontier.offer(entry(9, 1, 2));
        frontier.offer(entry(3, 2, 1));
        assert_eq!(frontier.heap.len(), 2);
        assert_eq!(frontier.pop(), Some(entry(3, 2, 1)));
        assert_eq!(frontier.pop(), Some(entry(5, 1, 0)));
        assert_eq!(frontier.pop(), None);
    }
}
