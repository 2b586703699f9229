//! One module per subcommand.

pub mod demo;
pub mod fixtures;
pub mod info;
pub mod quilt;
pub mod reconstruct;
pub mod render;
pub mod voxel;
pub mod warp;
