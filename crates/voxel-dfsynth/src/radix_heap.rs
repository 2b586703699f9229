//! A monotone priority queue on non-negative `f32` keys (a radix heap).
//!
//! The best-first search only ever inserts keys at least as large as the last key removed
//! (a child's lower bound never falls below its parent's, Eq. 2), which is exactly the
//! contract of a radix heap: items sit in buckets by the highest bit in which their key
//! differs from the last removed key, and removal only redistributes one bucket. It replaces
//! a binary heap whose sift-downs dominated the search time.

/// Buckets: index 0 holds keys equal to the last removed one; index `i > 0` keys whose
/// highest bit differing from it is bit `i − 1`.
const BUCKETS: usize = 33;

/// A min-queue of `(key, value)` with monotone keys. Among equal keys the most recently
/// inserted item comes out first (deterministic).
#[derive(Debug)]
pub(crate) struct RadixHeap<T> {
    last: u32,
    len: usize,
    buckets: Vec<Vec<(u32, T)>>,
}

fn bucket(key: u32, last: u32) -> usize {
    if key == last {
        0
    } else {
        (u32::BITS - (key ^ last).leading_zeros()) as usize
    }
}

impl<T> RadixHeap<T> {
    /// An empty queue.
    pub(crate) fn new() -> Self {
        Self {
            last: 0,
            len: 0,
            buckets: (0..BUCKETS).map(|_| Vec::new()).collect(),
        }
    }

    /// Inserts `value` with `key` (non-negative, finite). Keys below the last removed key
    /// are treated as equal to it, which keeps the queue consistent.
    pub(crate) fn push(&mut self, key: f32, value: T) {
        let k = key.max(0.0).to_bits().max(self.last);
        self.buckets[bucket(k, self.last)].push((k, value));
        self.len += 1;
    }

    /// Items queued.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Removes an item with the smallest key.
    pub(crate) fn pop(&mut self) -> Option<(f32, T)> {
        if self.len == 0 {
            return None;
        }
        if self.buckets[0].is_empty() {
            let i = (1..BUCKETS).find(|&i| !self.buckets[i].is_empty())?;
            let items = std::mem::take(&mut self.buckets[i]);
            self.last = items.iter().map(|&(k, _)| k).min()?;
            for (k, v) in items {
                self.buckets[bucket(k, self.last)].push((k, v));
            }
        }
        let (k, v) = self.buckets[0].pop()?;
        self.len -= 1;
        Some((f32::from_bits(k), v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pops_in_key_order_with_monotone_inserts() {
        let mut h = RadixHeap::new();
        let mut x = 12345u64;
        let mut next = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 40) as f32 / 1000.0
        };
        for i in 0..200 {
            h.push(next(), i);
        }
        let mut last = 0.0f32;
        let mut popped = 0;
        while let Some((k, _)) = h.pop() {
            assert!(k >= last, "{k} after {last}");
            last = k;
            popped += 1;
            // Insert children no smaller than the popped key, as the search does.
            if popped < 500 {
                h.push(k + next(), popped);
                h.push(k, popped);
            }
        }
        assert_eq!(popped, 200 + 2 * 499);
    }
}
