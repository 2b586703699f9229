//! The kept samples of a Poisson-disk sampling, by cell, for the test "is a kept sample
//! within `spacing` of this candidate?".
//!
//! Cells have side `spacing`, so the kept samples within `spacing` of a point lie in its
//! cell or the 26 around it. Cells are grouped in blocks of 4 × 4 × 4 that hold, per cell,
//! the latest sample kept in it (the others chained through `earlier`): the 27 cells fall
//! in 1 to 8 blocks (3.4 on average), each found by one hash lookup, where one lookup per
//! cell cost twice the time (100,000 samples of a sphere: 2.5 s against 1.1 s).

use glam::{DVec3, Vec3};

use crate::spatial::{CELL_BITS, CellMap};

/// Cells along each side of a block.
const BLOCK_SIDE: u64 = 4;

/// Cells in a block.
const BLOCK_CELLS: usize = (BLOCK_SIDE * BLOCK_SIDE * BLOCK_SIDE) as usize;

/// Cells along each axis of the grid: blocks' packed coordinates hold 2²¹ blocks.
const CELLS_PER_AXIS: u64 = BLOCK_SIDE << CELL_BITS;

/// No sample (an empty cell, or the first sample kept in its cell).
const NONE: u32 = u32::MAX;

/// The 27 steps from a cell to itself and its neighbours, nearest first (the cell, its 6
/// face neighbours, 12 edge neighbours, 8 corners): most candidates are turned down, and
/// the nearer cells turn them down sooner.
pub(super) const NEIGHBOUR_STEPS: [[i64; 3]; 27] = {
    let mut steps = [[0i64; 3]; 27];
    let mut filled = 0;
    let mut moved_axes = 0;
    while moved_axes <= 3 {
        let mut i = 0;
        while i < 27 {
            let step = [
                (i % 3) as i64 - 1,
                (i / 3 % 3) as i64 - 1,
                (i / 9) as i64 - 1,
            ];
            let moved = (step[0] != 0) as i64 + (step[1] != 0) as i64 + (step[2] != 0) as i64;
            if moved == moved_axes {
                steps[filled] = step;
                filled += 1;
            }
            i += 1;
        }
        moved_axes += 1;
    }
    steps
};

/// A cell's coordinates in cells from the grid's low corner.
pub(super) type Cell = [u64; 3];

/// Kept samples by cell (module docs).
pub(super) struct DiskGrid {
    low: DVec3,
    spacing: f64,
    /// Block number by packed block coordinates.
    blocks: CellMap<u32>,
    /// Per block, per cell, the latest sample kept there.
    latest: Vec<[u32; BLOCK_CELLS]>,
    /// Per kept sample, the one kept in its cell before it.
    earlier: Vec<u32>,
    positions: Vec<Vec3>,
}

impl DiskGrid {
    /// An empty grid of cells of side `spacing` from the corner `low`.
    pub(super) fn new(low: DVec3, spacing: f64) -> Self {
        Self {
            low,
            spacing,
            blocks: CellMap::default(),
            latest: Vec::new(),
            earlier: Vec::new(),
            positions: Vec::new(),
        }
    }

    /// The cell of `p`; `None` below the low corner or more than 2²³ cells above it.
    pub(super) fn cell(&self, p: Vec3) -> Option<Cell> {
        let q = ((p.as_dvec3() - self.low) / self.spacing).floor();
        let limit = CELLS_PER_AXIS as f64;
        (q.min_element() >= 0.0 && q.max_element() < limit)
            .then_some([q.x as u64, q.y as u64, q.z as u64])
    }

    /// Whether a kept sample lies closer than the spacing to `p`, in `cell`.
    pub(super) fn crowded(&self, p: Vec3, cell: Cell) -> bool {
        let spacing_squared = self.spacing * self.spacing;
        let own_block = cell.map(|c| c / BLOCK_SIDE);
        // The (up to 8) blocks the neighbours fall in, looked up once each: index bit
        // `axis` set where the neighbour's block is past the own block along that axis.
        let mut found: [Option<Option<u32>>; 8] = [None; 8];
        NEIGHBOUR_STEPS.iter().any(|step| {
            let mut neighbour = [0u64; 3];
            for axis in 0..3 {
                match cell[axis].checked_add_signed(step[axis]) {
                    Some(c) if c < CELLS_PER_AXIS => neighbour[axis] = c,
                    _ => return false,
                }
            }
            let block = neighbour.map(|c| c / BLOCK_SIDE);
            let which = (0..3)
                .filter(|&axis| block[axis] != own_block[axis])
                .map(|axis| 1 << axis)
                .sum::<usize>();
            let number = *found[which].get_or_insert_with(|| self.block_number(block));
            let Some(number) = number else {
                return false;
            };
            let head = self.latest[number as usize][slot(neighbour)];
            self.chain(head).any(|kept| {
                let other = self.positions[kept as usize].as_dvec3();
                other.distance_squared(p.as_dvec3()) < spacing_squared
            })
        })
    }

    /// Keeps a sample at `p`, in `cell`.
    pub(super) fn keep(&mut self, p: Vec3, cell: Cell) {
        let block = cell.map(|c| c / BLOCK_SIDE);
        let next_block = self.latest.len() as u32;
        let number = *self.blocks.entry(pack(block)).or_insert(next_block);
        if number == next_block {
            self.latest.push([NONE; BLOCK_CELLS]);
        }
        let index = self.positions.len() as u32;
        let head = &mut self.latest[number as usize][slot(cell)];
        self.earlier.push(*head);
        *head = index;
        self.positions.push(p);
    }

    fn block_number(&self, block: Cell) -> Option<u32> {
        self.blocks.get(&pack(block)).copied()
    }

    /// The samples kept in one cell, latest first, from its latest `head`.
    fn chain(&self, head: u32) -> impl Iterator<Item = u32> + '_ {
        std::iter::successors(Some(head).filter(|&h| h != NONE), |&i| {
            Some(self.earlier[i as usize]).filter(|&e| e != NONE)
        })
    }
}

/// Packed block coordinates (each below 2²¹, as [`DiskGrid::cell`] ensures).
fn pack(block: Cell) -> u64 {
    block[0] | block[1] << CELL_BITS | block[2] << (2 * CELL_BITS)
}

/// A cell's place in its block.
fn slot(cell: Cell) -> usize {
    let [x, y, z] = cell.map(|c| (c % BLOCK_SIDE) as usize);
    x + 4 * y + 16 * z
}
