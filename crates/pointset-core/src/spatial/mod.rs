//! Spatial indices: a static k-d tree ([`KdIndex`]) and a dynamic hashed grid ([`BucketGrid`]),
//! and the Z-order of points ([`z_order`]) to ask them in.

mod bucket_grid;
mod kd_index;
mod morton;
mod region;

pub use bucket_grid::{BucketGrid, PointKey};
pub use kd_index::{KdIndex, Neighbour, key_index, nearness_key};
pub use morton::z_order;
pub use region::{KdRegion, NearestUpTo};
