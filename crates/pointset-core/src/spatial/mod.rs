//! Spatial indices: a static k-d tree ([`KdIndex`]) and a dynamic hashed grid ([`BucketGrid`]).

mod bucket_grid;
mod kd_index;
mod region;

pub use bucket_grid::{BucketGrid, PointKey};
pub use kd_index::{KdIndex, Neighbour, key_index, nearness_key};
pub use region::{KdRegion, NearestUpTo};
