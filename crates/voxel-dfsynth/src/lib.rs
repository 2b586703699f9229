//! # voxel-dfsynth
//!
//! Geometry synthesis by distance-field block matching — Lagae, Dumont & Dutré, *Geometry
//! Synthesis* (paper 001), complete:
//!
//! - **analysis and matching (§4)**: the quantized source field, the global subsampled
//!   pyramid, the search tree with merged identical and partially identical nodes and its
//!   exact best-first search (Figure 4), and two other exact matchers behind one
//!   [`BlockMatcher`] trait (linear search, pruned by partial distances and Eq. 2 filters;
//!   masked SSD by FFT);
//! - **synthesis (§5.1–5.2)**: [`synthesize`] — multiresolution, the coarser trees obtained
//!   by dropping leaf levels, blocks in scan-line order with 7 of 8 octants known, random
//!   seeding, exact best match at every step, deterministic and parallel;
//! - **reconstruction (§5.3)**: [`isosurface_mesh`] and [`copied_mesh`] (source triangles
//!   copied block by block, welded and relaxed);
//! - **quality**: [`evaluate`], against the same numbers for random blocks.
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
//! - Quantization: distances map to 256 levels over `[−range, range]`, by default the
//!   source's largest |distance| (`distance_field::Quantizer`); tree keys below the block
//!   level are level means rounded to those levels (so level 1 has at most 256 nodes) and
//!   nodes are scored with the lower bound `max(0, |q − b| − ½)²` per sample, keeping the
//!   search exact despite rounding.
//! - Partial identity (§4.4): each level's eight octants are successive tree levels.
//! - A prefix shared by one block is a single compressed node, scored chunk by chunk.
//! - Coarser iterations search the same tree with leaf levels dropped, over the rounded cell
//!   means at every offset ([`SubsampledSource`]); blocks keep their extent across
//!   iterations; the previous result is upsampled trilinearly.
//! - Eq. 3 queue pruning ([`SearchTree::best_match_pruned`]): the paper's ε, "the squared
//!   maximum distance between neighbouring samples", is taken per level step as
//!   `(2 · (√3 · c · slope + 1½))²` for child cells of side `c` (mean differences across a
//!   cell plus rounding), with an optional tolerance (§5.2).
//!
//! More in `docs/voxel-dfsynth.md`.
//!
//! ## Features
//!
//! - `serde`: `Serialize`/`Deserialize` for [`VoxelParams`], [`MatcherKind`],
//!   [`QualityParams`] and [`RelaxParams`]. Structs read with missing fields taken from
//!   their `Default`, unknown fields refused by name, and enums spelt in `snake_case`
//!   (`"search_only"`). Read parameters are checked like built ones: call `validate()` (or
//!   let the run do it).

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
    BlockCopy, LevelReport, MAX_TARGET_SAMPLES, MatcherKind, Synthesis, VoxelParams,
    quantize_source, source_quantizer, synthesize,
};
pub use tree::{Eq3Pruning, Match, SearchStats, SearchTree, TreeStats};
