//! Disjoint sets of indices (union–find), for connected components of meshes and graphs.

/// Disjoint sets over the indices `0..n`, joined pairwise (union–find with path halving).
/// The root of every set is its smallest index, so roots never depend on the order in
/// which pairs were joined.
///
/// ```
/// use pointset_core::DisjointSets;
///
/// let mut sets = DisjointSets::new(5);
/// assert!(sets.join(3, 1));
/// assert!(sets.join(4, 3));
/// assert!(!sets.join(1, 4)); // already together
/// assert_eq!((sets.root(4), sets.root(0), sets.root(2)), (1, 0, 2));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DisjointSets {
    parent: Vec<u32>,
}

impl DisjointSets {
    /// `n` sets of one index each (indices must fit in `u32`, as mesh indices do).
    pub fn new(n: usize) -> Self {
        Self {
            parent: (0..n as u32).collect(),
        }
    }

    /// The smallest index of `v`'s set. Panics if `v` is not below `n` (a caller's
    /// indexing bug, like slice indexing).
    pub fn root(&mut self, mut v: u32) -> u32 {
        while self.parent[v as usize] != v {
            let grand = self.parent[self.parent[v as usize] as usize];
            self.parent[v as usize] = grand;
            v = grand;
        }
        v
    }

    /// Joins the sets of `a` and `b`; true when they were apart.
    pub fn join(&mut self, a: u32, b: u32) -> bool {
        let (a, b) = (self.root(a), self.root(b));
        if a == b {
            return false;
        }
        self.parent[a.max(b) as usize] = a.min(b);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::DisjointSets;

    #[test]
    fn roots_are_the_smallest_members_whatever_the_join_order() {
        // A chain 9-8-...-0 joined from the top, and the same joined from the bottom.
        let mut down = DisjointSets::new(10);
        let mut up = DisjointSets::new(10);
        for v in (1..10).rev() {
            down.join(v, v - 1);
        }
        for v in 1..10 {
            up.join(v - 1, v);
        }
        for v in 0..10 {
            assert_eq!((down.root(v), up.root(v)), (0, 0));
        }
        // Two sets stay two.
        let mut two = DisjointSets::new(6);
        two.join(5, 3);
        two.join(4, 2);
        two.join(3, 1);
        let roots: Vec<u32> = (0..6).map(|v| two.root(v)).collect();
        assert_eq!(roots, [0, 1, 2, 1, 2, 1]);
    }
}
