//! Spatial indices: a static k-d tree ([`KdIndex`]) and a dynamic hashed grid ([`BucketGrid`]),
//! the Z-order of points ([`z_order`]) to ask them in, and grids of cells named by packed
//! keys ([`PackedCells`], [`CellMap`]).

mod bucket_grid;
mod kd_index;
mod morton;
mod packed_cells;
mod region;

pub use bucket_grid::{BucketGrid, PointKey};
pub use kd_index::{KdIndex, Neighbour, key_index, nearness_key};
pub use morton::z_order;
pub use packed_cells::{CELL_BITS, CellHasher, CellMap, PackedCells};
pub use region::{KdRegion, NearestUpTo};
