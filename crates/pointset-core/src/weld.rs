//! Welding positions into vertices: the rule of [`crate::TriMesh::welded`] and of the STL
//! reader.

use std::collections::HashMap;
use std::hash::{BuildHasher, Hash, Hasher};

use glam::Vec3;

use crate::{Error, Result};

/// Numbers positions into vertices, equal positions (exact bits, `-0` taken as `0`) into
/// one, in order of first appearance.
///
/// The map is only looked up, never iterated, so its hasher cannot change a result. It is
/// [`PositionHasher`] rather than the standard SipHash: welding a 2,000,000-facet STL makes
/// 6 million lookups, and SipHash was most of their cost.
#[derive(Debug, Default)]
pub(crate) struct PositionWelder {
    index: HashMap<WordTriple, u32, SeededPositionHash>,
    positions: Vec<Vec3>,
}

impl PositionWelder {
    /// A welder expecting about `vertices` distinct positions.
    pub(crate) fn with_capacity(vertices: usize) -> Self {
        Self {
            index: HashMap::with_capacity_and_hasher(vertices, SeededPositionHash::default()),
            positions: Vec::with_capacity(vertices),
        }
    }

    /// The vertex at `p`, new if no earlier position equals it; an error once there are
    /// more distinct positions than `u32` indices can number.
    pub(crate) fn vertex(&mut self, p: Vec3) -> Result<u32> {
        let key = WordTriple(position_bits(p));
        let next = u32::try_from(self.positions.len()).map_err(|_| Error::InvalidParameter {
            name: "vertex count",
            value: self.positions.len().to_string(),
            expected: "distinct positions that 32-bit vertex indices can number".into(),
        })?;
        let positions = &mut self.positions;
        Ok(*self.index.entry(key).or_insert_with(|| {
            positions.push(p);
            next
        }))
    }

    /// The distinct positions, in order of first appearance.
    pub(crate) fn into_positions(self) -> Vec<Vec3> {
        self.positions
    }
}

/// The words a position is welded by: its coordinates' bit patterns, `-0` taken as `0`.
pub(crate) fn position_bits(p: Vec3) -> [u32; 3] {
    p.to_array()
        .map(|c| if c == 0.0 { 0u32 } else { c.to_bits() })
}

/// Whether any two of `positions` would weld into one vertex ([`PositionWelder`]'s rule),
/// found by sorting their bit patterns: 12 bytes a position, against the welder's hash
/// table and copy.
pub(crate) fn any_coincident(positions: &[Vec3]) -> bool {
    let mut keys: Vec<[u32; 3]> = positions.iter().map(|&p| position_bits(p)).collect();
    keys.sort_unstable();
    keys.windows(2).any(|w| w[0] == w[1])
}

/// Three 32-bit words hashed as two: a position's coordinate bit patterns, or an OBJ
/// corner's position, texture coordinate and normal indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct WordTriple(pub(crate) [u32; 3]);

impl Hash for WordTriple {
    fn hash<H: Hasher>(&self, state: &mut H) {
        let [x, y, z] = self.0;
        state.write_u64((u64::from(x) << 32) | u64::from(y));
        state.write_u32(z);
    }
}

/// Builds [`PositionHasher`]s from a seed drawn once per map from the standard library's
/// random keys, so that no file can be crafted to collide on every run.
#[derive(Debug, Clone)]
pub(crate) struct SeededPositionHash(u64);

impl Default for SeededPositionHash {
    fn default() -> Self {
        Self(std::collections::hash_map::RandomState::new().hash_one(0u8))
    }
}

impl BuildHasher for SeededPositionHash {
    type Hasher = PositionHasher;

    fn build_hasher(&self) -> PositionHasher {
        PositionHasher(self.0)
    }
}

/// A multiply-mix hasher for [`WordTriple`]: each word is folded in by an xor and a
/// multiplication by an odd constant, and `finish` spreads the bits over the whole word
/// (the finalizer of MurmurHash3), since the table takes its bucket from the low bits and
/// its tag from the high ones.
pub(crate) struct PositionHasher(u64);

impl PositionHasher {
    const MULTIPLIER: u64 = 0x9E37_79B9_7F4A_7C15;

    fn fold(&mut self, word: u64) {
        self.0 = (self.0 ^ word)
            .wrapping_mul(Self::MULTIPLIER)
            .rotate_left(29);
    }
}

impl Hasher for PositionHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.fold(u64::from_le_bytes(word));
        }
    }

    fn write_u32(&mut self, i: u32) {
        self.fold(u64::from(i));
    }

    fn write_u64(&mut self, i: u64) {
        self.fold(i);
    }

    fn finish(&self) -> u64 {
        let mut h = self.0;
        h ^= h >> 33;
        h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        h ^= h >> 33;
        h = h.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
        h ^ (h >> 33)
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;
    use proptest::test_runner::TestCaseError;

    use super::*;

    /// Positions on a lattice, each given twice and `-0` beside `0`: one vertex each, in
    /// order of first appearance.
    #[test]
    fn equal_positions_weld_in_order_of_first_appearance() -> Result<()> {
        let lattice: Vec<Vec3> = (0..2000)
            .map(|i| {
                Vec3::new(
                    (i % 13) as f32,
                    (i / 13 % 11) as f32 * 0.5,
                    (i / 143) as f32,
                )
            })
            .collect();
        let mut welder = PositionWelder::with_capacity(16);
        let mut ids = Vec::new();
        for p in lattice.iter().chain(&lattice) {
            ids.push(welder.vertex(*p)?);
        }
        assert_eq!(welder.vertex(Vec3::new(-0.0, 0.0, -0.0))?, 0);
        assert_eq!(ids[..2000], ids[2000..]);
        assert_eq!(ids[..2000], (0..2000).collect::<Vec<u32>>()[..]);
        assert_eq!(welder.into_positions(), lattice);
        Ok(())
    }

    proptest! {
        /// The sorted check finds coincident positions exactly when the welder merges
        /// some: on small lattices where repeats and signed zeros are common.
        #[test]
        fn the_sorted_check_agrees_with_the_welder(
            cells in proptest::collection::vec((-2i8..3, -2i8..3, any::<bool>()), 0..40),
        ) {
            let positions: Vec<Vec3> = cells
                .iter()
                .map(|&(x, y, negative)| {
                    let zero = if negative { -0.0 } else { 0.0 };
                    Vec3::new(f32::from(x) * 0.5, f32::from(y), zero)
                })
                .collect();
            let mut welder = PositionWelder::default();
            for &p in &positions {
                welder
                    .vertex(p)
                    .map_err(|e| TestCaseError::fail(e.to_string()))?;
            }
            let merged = welder.into_positions().len() < positions.len();
            prop_assert_eq!(any_coincident(&positions), merged);
        }
    }
}
