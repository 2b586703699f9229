//! Spatial indices: a static k-d tree ([`KdIndex`]) and a dynamic hashed grid ([`BucketGrid`]).

mod bucket_grid;
mod kd_index;

pub use bucket_grid::{BucketGrid, PointKey};
pub use kd_index::{KdIndex, Neighbour, key_index, nearness_key};
