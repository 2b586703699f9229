//! # voxel-dfsynth
//!
//! Geometry synthesis by distance-field block matching — Lagae, Dumont & Dutré, *Geometry
//! Synthesis* (paper 001). **This crate currently implements the geometry-matching half
//! (§4):** the quantized source field, the global subsampled pyramid, the search tree with
//! merged identical and partially identical nodes, the exact best-first search of Figure 4,
//! and two other exact matchers behind one [`BlockMatcher`] trait (brute force; masked SSD by
//! FFT). Synthesis (§5) and geometry reconstruction (§5.3) are not implemented yet.
//!
//! ```
//! use voxel_dfsynth::{BlockMatcher, BruteForce, FftMatcher, QuantizedField, SearchTree};
//!
//! // A 20³ field of a smooth pattern; match one of its own 4³ blocks.
//! let dims = [20, 20, 20];
//! let values: Vec<u8> = (0..8000).map(|i| (((i % 20) * 7 + (i / 20 % 20) * 3 + i / 400) % 256) as u8).collect();
//! let field = QuantizedField::from_values(dims, values)?;
//! let query = field.block([5, 6, 7], 4);
//! let tree = SearchTree::build(&field, 4)?;
//! let (a, b, c) = (tree.best_match(&query)?, BruteForce::new(&field, 4)?.best_match(&query)?, FftMatcher::new(&field, 4)?.best_match(&query)?);
//! assert_eq!((a.distance, b.distance, c.distance), (0.0, 0.0, 0.0));
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Choices where the paper leaves room
//!
//! - Quantization: distances map to 256 levels over `[−range, range]`
//!   (`distance_field::Quantizer`); tree keys below the block level are level means rounded to
//!   those levels (so level 1 has at most 256 nodes) and nodes are scored with the lower bound
//!   `max(0, |q − b| − ½)²` per sample, keeping the search exact despite rounding.
//! - Partial identity (§4.4): each level's eight octants are successive tree levels.
//! - A prefix shared by one block is a single compressed node scored exactly when reached.
//! - The Eq. 3 queue pruning is not implemented yet.

#![deny(missing_docs)]

mod error;
pub mod fft;
mod field;
mod matcher;
mod quality;
mod radix_heap;
mod reconstruct;
mod synth;
mod tree;

pub use error::{Result, VoxelError};
pub use field::{BoxMeans, QuantizedField, SubsampledSource, block_level};
pub use matcher::{BlockMatcher, BruteForce, FftMatcher};
pub use quality::{QualityParams, VoxelQuality, evaluate, unit_gradient_fraction};
pub use reconstruct::{CopiedMesh, RelaxParams, copied_mesh, isosurface_mesh};
pub use synth::{
    BlockCopy, LevelReport, MatcherKind, Synthesis, VoxelParams, quantize_source, source_quantizer,
    synthesize,
};
pub use tree::{Match, SearchTree, TreeStats};
