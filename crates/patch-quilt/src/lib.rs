//! # patch-quilt
//!
//! Patch-based synthesis of geometry textures with point-set surfaces — Duranleau &
//! Poulin, paper 000. An exemplar *geometry texture* (oriented points, a box, a reference
//! plane, geometry extending beyond the box) is grown into a larger one by pasting patches
//! of it in scan-line order: each patch is chosen by comparing signed distance + gradient
//! fields over the overlap with what is already there, warped onto it with a thin-plate
//! spline through automatically paired points, and blended into it.
//!
//! ## Quick start
//!
//! ```
//! use patch_quilt::{GeometryTexture, OutputSize, QuiltParams, quilt};
//! use pointset_core::{HeightField, RunContext};
//!
//! // Bumps on a lattice, 40 × 40 samples with 6 samples of padding on every side.
//! let h: Vec<f32> = (0..40 * 40)
//!     .map(|i| ((i % 40) as f32 * 0.8).sin() * ((i / 40) as f32 * 0.8).sin())
//!     .collect();
//! let field = HeightField::new(40, 40, h)?;
//! let texture = GeometryTexture::from_heightfield(&field, 0.05, 0.1, 6)?;
//! let params = QuiltParams::default().output(OutputSize::Scale(1.5)).field_resolution(24);
//! let out = quilt(&texture, &params, &mut RunContext::new(7))?;
//! assert!(out.points.len() > 1000);
//! assert!(out.points.positions().iter().all(|p| out.bounds.contains(*p)));
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Parameters ([`QuiltParams`])
//!
//! | field | default | source |
//! |---|---|---|
//! | `patch_size` | 0.4 × the box's smaller side | "a texture element plus neighbourhood" |
//! | `extra_width` (`w_E`) | 0.3 × patch | paper: 1/4–1/3 |
//! | `overlap` | 1/6 × patch | |
//! | `field_resolution` (`D(T_in)`) | 48 nodes along the longer side | paper: 51–84 |
//! | `epsilon` (`ε`) | 0.1 | |
//! | `band` | 4 field spacings | |
//! | `pairing` | Table 1's height-field row ([`tps_warp::Table1Preset`] for the others) | Table 1 |
//! | `pair_distance` | 0.5 field spacings | "user-defined threshold"; measured |
//! | `warp_targets` | [`WarpTargets::Exact`] (the paper's) | [`WarpTargets::SurfaceGap`] is ours |
//! | `smoothing` | 0 (interpolation) | |
//! | `blend_reach` | 0.25 × the MLS support | §5.3 "gaps should be small"; measured |
//! | `normal_agreement` | cosine 0.8 | ours; measured |
//! | `clusters` | `n_max` 12, `σ_max` 0.1 | paper silent |
//! | `anchors_per_corner` | 4 (at most 1024) | "a few extra pairs … in corner regions" |
//! | `output` | twice the exemplar | |
//! | `relaxation_rounds` | 0 | §6 post-process |
//! | `seed`, `method`, `seed_patch`, `layout` | 0, full, random, searched | |
//!
//! The measurements behind the choices are in `docs/patch-quilt-studies.md`.
//!
//! ## The algorithm (paper 000 §4 steps 1–8, §5), as implemented
//!
//! Work happens in a canonical frame where the reference plane is XY. `D(T_in)` is the
//! signed distance + gradient grid of the exemplar's MLS surface over its box (resolution
//! [`QuiltParams::field_resolution`]); its spacing discretizes patch positions, and patch,
//! overlap and extra widths are snapped to whole nodes.
//!
//! 1. A random (or given) seed patch `P_0 ∪ E_0` is pasted at the lower-left corner of the
//!    output region, which starts `w_E` before the requested box.
//! 2. For each later patch `k` in scan-line order, `N_k` is the output's points around `B_k`
//!    (grown by `w_E`); `D(O^{N_k})` is computed on the fly by MLS projection on `N_k` at
//!    the overlap nodes only (left strip, bottom strip, or both); `d` is compared exhaustively
//!    (in parallel) with `D(O^P)` read from `D(T_in)` for every patch position, and
//!    `Ψ_k = {P | d ≤ (1 + ε) min d}`.
//! 3. A random member of `Ψ_k` is chosen; `F_k = tr(P_k ∪ E_k)` (E extends right and up),
//!    extended by `w_E/2` on every side as the warp's source set `S`.
//! 4. `Q` = representatives of adaptive clusters of `N_k` inside the overlap; the pairing of
//!    Eq. 1–3 (tps-warp) with anchors in the free corners of `B_k`; positions warped by the
//!    spline, normals through its Jacobian.
//! 5. Points in the overlap move toward their target on `N_k` — the closer hit of rays along
//!    `±n`, else the projection — by the ramp of Figure 3c (1 at the overlap's outer edge, 0
//!    at its inner edge).
//! 6. Points of `T_out` (a hashed bucket grid) inside `B_k` are removed and the points of
//!    `F''_k` inside `B_k` inserted.
//! 7. Until the layout is covered; 8. optional relaxation on the texture's own MLS surface
//!    (the paper's post-process, run while the `w_E` band still surrounds the box so the
//!    border's points have neighbours on every side), then everything outside the requested
//!    box (that band) is trimmed.
//!
//! Timings are recorded in the [`pointset_core::RunContext`] as `search`, `warp`, `blend`
//! and `other` (Table 1's split); [`QuiltStats`] has the counts.
//!
//! ## Choices where the paper leaves room
//!
//! - `d` sums squared differences of all four channels (distance and gradient) unweighted,
//!   reading the paper's "single high-dimensional vectors" literally.
//! - **Units.** `d` and the pairing's Eq. 2–3 add lengths to unitless terms (gradients,
//!   normals, surface variation, directions), so their balance depends on the unit of
//!   length. The paper gives one set of weights for exemplars of "about the same base
//!   dimensions" (§6). Here the lengths in those three formulas are measured in units of
//!   the exemplar's longer box side / [`BASE_SIDE`] (4, the side of the demo fixtures the
//!   defaults were measured on). Every other length of a run is already relative (to the
//!   box, the field spacing or the MLS kernel), so the same exemplar in millimetres and in
//!   metres gives the same texture, scaled: exactly for power-of-two factors (tested);
//!   other factors change the last bits of the samples, which can tip a near tie of the
//!   search the way another seed would.
//! - `N_k`'s MLS surface uses the exemplar's kernel, so both fields see the same surface
//!   definition.
//! - A patch with fewer than 4 pairs, or a degenerate spline, is pasted unwarped and counted
//!   ([`QuiltStats::warps_skipped`]). A patch whose pairs would exceed what the spline
//!   takes ([`tps_warp::MAX_CONTROL_POINTS`], reached by 2K height maps) is warped with a
//!   coarser clustering instead, its limits doubled until the pairs fit, and counted
//!   ([`QuiltStats::warps_coarsened`]).
//! - Anchors: up to 4 points in each `w_E × w_E` corner of `B_k` that shares no area with the
//!   overlap — three corners for an interior patch (the strips run along the patch's sides
//!   only, so the corners beyond their ends are free). The paper does not say which points;
//!   they are spread through the corner's height, one from each of 4 layers, nearest the
//!   corner's centre ([`tps_warp::anchors_in_regions`]). Anchors at one height left the
//!   spline's stretch along the normal free, and rough height fields' far corners were
//!   squashed (docs/patch-quilt-studies.md, "Anchors through the height"). A corner region
//!   is read as a column through the patch's height: where the patch reaches farther below
//!   (above) the spline's control points than both their own height span and an eighth of
//!   the corner's side, each free corner's centre at the patch's lowest (highest) z is an
//!   anchor too. Without them, a patch whose pairs and corners all lay on one plateau was
//!   stretched along z by the pairs' noise: on a 1024² height map one warp moved a pit's
//!   points by 11 times its longest pair. Pinned always, the ends took most of the full
//!   method's lead on Mount St. Helens (docs/patch-quilt-studies.md, "Column ends"). A warp
//!   that still moves a point that may land in `B_k` by more than 3 times its longest pair
//!   is fitted again with each free corner's column pinned wherever the patch reaches
//!   beyond the pairs alone by more than an eighth of the corner, and the fit whose landing
//!   points move less is kept ([`QuiltStats::warps_restrained`];
//!   docs/patch-quilt-studies.md, "Stretch limit").
//! - The first patch of each later row overlaps only the row below; the first row only its
//!   left neighbour.
//! - Each paired source goes onto its target `q` ([`WarpTargets::Exact`], the default). The
//!   option [`WarpTargets::SurfaceGap`] (not in the paper) moves it instead by the gap
//!   between the exemplar's and `N_k`'s MLS surfaces along its normal, which ignores the
//!   tangential sampling offset between the two samples of a pair. After the 2026-12-01
//!   distance-field fix it scores lower than exact targets on all four demo fixtures (means
//!   over 8–16 seeds in `docs/patch-quilt-studies.md`); the default stays the paper's.
//! - Step 5 closes *gaps*, which "should be small" (§5.3): a point whose target lies
//!   farther than [`QuiltParams::blend_reach`], or on a surface whose normal is further
//!   from the point's than [`QuiltParams::normal_agreement`] allows (another petal, a
//!   crossing thread's underside), faces different geometry and is left as it is
//!   ([`BlendCounts`]). Surface-gap targets apply the same normal test to each pair.
//!
//! ## Baselines and the same-layout control
//!
//! [`Method::SearchOnly`] and [`Method::RandomPlacement`] run the same loop without steps
//! 4–5 (and, for random placement, without the search). [`QuiltParams::layout`] replays
//! the sources of an earlier run ([`QuiltOutput::sources`]): pasting the full run's own
//! layout gives the one comparison in which only the warp and the blend differ, since the
//! two baselines also choose different patches.
//!
//! ## Determinism
//!
//! Patch `k` draws from the stream `(seed, k)`; searches reduce in a fixed order; the output
//! bucket grid is read in key order. The output is bit-identical for any thread count.
//!
//! ## Errors
//!
//! [`QuiltError`]: invalid parameters, exemplars without normals, boxes without volume
//! (the message says whether across the plane or along the up axis), boxes so much taller
//! than wide that `D(T_in)` would exceed [`MAX_FIELD_NODES`], patches narrower than
//! [`MIN_PATCH_SPACINGS`] field spacings (the message gives the smallest `patch_size` that
//! works), padding too narrow for the extra region, and errors of the building blocks.
//! The quality measure refuses exemplar fields whose fine sampling would exceed
//! [`MAX_MEASURE_NODES`]. An exemplar without
//! relief quilts, but its window errors mean nothing
//! ([`QualityReport::featureless_exemplar`]).
//!
//! ## Features
//!
//! - `serde`: `Serialize`/`Deserialize` for [`QuiltParams`], [`Method`], [`WarpTargets`]
//!   and [`OutputSize`] (and, through the building blocks' own `serde` features, the
//!   parameters they hold). Structs read with missing fields taken from their `Default`,
//!   unknown fields refused by name, and enums spelt in `snake_case` (`"search_only"`).
//!   Read parameters are checked like built ones: call `validate()` (or let the run do it).

#![deny(missing_docs)]

mod blend;
mod error;
mod exemplar;
mod params;
mod quality;
mod quilt;
pub mod search;
#[cfg(test)]
mod test_surfaces;
mod texture;
mod warp;

pub use blend::{BlendCounts, Overlap};
pub use error::{QuiltError, Result};
pub use exemplar::{BASE_SIDE, MAX_FIELD_NODES, MIN_PATCH_SPACINGS, PatchGeometry};
pub use params::{
    FIELD_RESOLUTIONS, MAX_ANCHORS_PER_CORNER, MAX_OUTPUT_SCALE, MAX_RELAXATION_ROUNDS, Method,
    OutputSize, QuiltParams, WarpTargets,
};
pub use quality::windows::MAX_MEASURE_NODES;
pub use quality::{FEATURELESS_VARIATION, QualityMeasure, QualityReport, evaluate};
pub use quilt::{Placement, QuiltOutput, QuiltStats, quilt};
pub use texture::{GeometryTexture, MIN_TEXTURE_POINTS, UpAxis};
pub use warp::WarpCounts;
