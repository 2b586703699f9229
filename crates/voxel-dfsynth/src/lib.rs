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
//!   copied block by block, welded and relaxed), with their sizes counted before building
//!   ([`isosurface_cells`], [`copied_triangle_count`]) so a caller can check memory first;
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
//! ## Quick start
//!
//! Synthesize a larger field from a source distance field, measure it, and extract its
//! surface (the facade's `geosynth::voxel::VoxelSynth` stage does all of this from a mesh):
//!
//! ```
//! use distance_field::{GridSpec, SdfGrid};
//! use pointset_core::{Grid3, RunContext};
//! use voxel_dfsynth::{MatcherKind, QualityParams, VoxelParams, evaluate, isosurface_mesh,
//!     quantize_source, source_quantizer, synthesize};
//!
//! // Slabs two samples thick, every eight samples along x: a 24³ source.
//! let spec = GridSpec { dims: [24; 3], origin: glam::Vec3::ZERO, spacing: 1.0 };
//! let slabs = (0..24 * 24 * 24).map(|i| {
//!     let d = (((i % 24) as f32 % 8.0) - 4.0).abs() - 2.0;
//!     glam::Vec4::new(d, 0.0, 0.0, 0.0)
//! });
//! let source = SdfGrid::from_grid(Grid3::from_vec(spec.dims, spec.origin, 1.0, slabs.collect())?, 4.0)?;
//!
//! let params = VoxelParams::default().target_dims([32, 32, 16]).levels(2).block(8).seed(3);
//! let synthesis = synthesize(&source, &params, &mut RunContext::new(3))?;
//! assert_eq!(synthesis.field.dims(), [32, 32, 16]);
//!
//! let quantizer = source_quantizer(&source, &params)?;
//! let quantized = quantize_source(&source, &quantizer)?;
//! let found = evaluate(&quantized, &quantizer, &synthesis, &QualityParams::default())?;
//! let random = synthesize(&source, &params.clone().matcher(MatcherKind::Random), &mut RunContext::new(3))?;
//! let baseline = evaluate(&quantized, &quantizer, &random, &QualityParams::default())?;
//! assert!(found.neighbourhood_error < baseline.neighbourhood_error);
//!
//! let surface = isosurface_mesh(&synthesis, true)?;
//! assert!(surface.face_count() > 0);
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Parameters ([`VoxelParams`])
//!
//! | field | default | meaning |
//! |---|---|---|
//! | `target_dims` | 128³ (the paper's) | target samples along x, y, z at the finest iteration; each ≥ `block` and a multiple of `block / 2`; at most 512³ in all |
//! | `levels` | 3 (the paper's) | iterations (resolution levels), with `block / 2^(levels − 1) ≥ 2` |
//! | `block` | 16 (the paper's) | block size of the last iteration, a power of two from 2 to 512 |
//! | `matcher` | [`MatcherKind::Brute`] | the block search: `Tree` (the paper's), `Brute` (linear, pruned), `Fft` (masked SSD) — all exact and equal — or `Random` (the baseline) |
//! | `range` | the source's largest \|distance\| | half-range of the 256-level quantization |
//! | `seed` | 0 | the random seeding of the first iteration (and the baseline's picks) |
//!
//! [`QualityParams`] (window 8, 64 windows, seed 0) sets the measure and [`RelaxParams`]
//! (weld radius 1 spacing, at most [`MAX_WELD_RADIUS`]; 8 rounds, at most
//! [`MAX_RELAX_ITERATIONS`]; 2 rings; step ½) the seam relaxation of [`copied_mesh`].
//!
//! ## Complexity
//!
//! An iteration with `B` target blocks of `b³` samples makes `B` best-match queries against
//! the `P` block positions of the (subsampled) source: the linear search is `O(P · b³)` per
//! query at worst, cut short by partial distances and the Eq. 2 filters; the tree search is
//! best-first over at most as many nodes as the tree has (built once, `O(P · b³)`; 717 MB
//! for the bunny at 256³ with blocks of 32); the FFT matcher is `O(S log S)` per query for
//! a source of `S` samples. Measured numbers (the paper's Table 1 and its synthesis
//! setting) are in `docs/performance.md`.
//!
//! ## Determinism
//!
//! Randomness comes from `pointset_core::rng::stream(seed, index)`. Blocks that do not
//! overlap are searched in parallel waves and applied in scan-line order ([`synthesize`]),
//! so a seed gives the same field, copies and meshes for any number of threads (tested
//! with 1 and 2).
//!
//! ## Errors
//!
//! [`VoxelError`]: parameters out of range ([`VoxelParams::validate`], blocks or windows
//! that do not fit the source), and the building blocks' errors (`pointset-core`,
//! `distance-field`). Nothing panics on user input.
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
//!   (`"brute"`). Read parameters are checked like built ones: call `validate()` (or let
//!   the run do it).

#![deny(missing_docs)]

mod copied;
mod error;
pub mod fft;
mod field;
mod matcher;
mod quality;
mod radix_heap;
mod reconstruct;
mod synth;
mod tree;

pub use copied::{
    CopiedMesh, MAX_RELAX_ITERATIONS, MAX_WELD_RADIUS, RelaxParams, copied_mesh,
    copied_triangle_count,
};
pub use error::{Result, VoxelError};
pub use field::{BoxMeans, QuantizedField, SubsampledSource, block_level};
pub use matcher::{BlockMatcher, BruteForce, FftMatcher};
pub use quality::{QualityParams, VoxelQuality, evaluate, unit_gradient_fraction};
pub use reconstruct::{isosurface_cells, isosurface_mesh};
pub use synth::{
    BlockCopy, LevelReport, MAX_TARGET_SAMPLES, MatcherKind, Synthesis, VoxelParams,
    quantize_source, source_quantizer, synthesize,
};
pub use tree::{Eq3Pruning, Match, SearchStats, SearchTree, TreeStats};
