//! # tps-warp
//!
//! Thin-plate spline warps driven by automatic point pairing, as paper 000 (Duranleau &
//! Poulin, *Patch-based synthesis of geometry textures with point-set surfaces*, §5.2) uses
//! them to bend a chosen patch onto its neighbourhood.
//!
//! ## The spline (Wahba 1990), in 3D
//!
//! `W(x) = c + A x + Σᵢ wᵢ φ(|x − sᵢ|)` with the biharmonic kernel of three dimensions,
//! `φ(r) = r`, and the side conditions `Σ wᵢ = 0`, `Σ wᵢ sᵢᵀ = 0`. The `(n+4) × (n+4)`
//! system `[K + λI, P; Pᵀ, 0] [w; a] = [q; 0]` is solved in `f64` by LU with partial pivoting
//! for the three coordinates at once (nalgebra's below 512 unknowns, a blocked parallel one
//! from 512 up); `λ` is optional smoothing. The Jacobian is analytic,
//! `J(x) = A + Σ wᵢ (x − sᵢ)ᵀ / |x − sᵢ|` (the singular term is dropped at a control point),
//! and normals are transported as in the paper: `n' = (J u × J v) / |J u × J v|` for
//! orthonormal tangents `u, v` of `n`.
//!
//! Degenerate control sets: coincident sources with different targets are an error;
//! identical pairs are merged; sets that do not span 3D (coplanar — every flat patch —,
//! collinear, a single pair) either fail ([`AffineRegularization::Reject`]) or, by default,
//! resolve the undetermined affine directions toward the identity. Never a NaN warp: a
//! non-finite solution is [`TpsError::Singular`].
//!
//! ## The pairing (paper 000 Eq. 1–3)
//!
//! `c(s, q) = w_p |p_s − p_q| + (w_n/2)(1 − n_s·n_q) + w_v (v_s − v_q)²`, infinite when a raw
//! term exceeds its threshold; `g(s, q, Φ) = w_l | |p_s − p_q| − f_l | + (w_d/2)(1 − f_d·dir)`
//! with `f_l`, `f_d` the `θ`-weighted mean length and direction of neighbouring pairs
//! (distances measured in `Q`, Gaussian `θ`). [`pair_points`] runs the iterated greedy
//! algorithm (steps 1–6), uses no source twice, and removes pairs that cross neighbours.
//! [`anchors_in_regions`] picks the corner points mapped to themselves; [`pair_and_fit`]
//! does all of it and fits the spline.
//!
//! ```
//! use glam::Vec3;
//! use tps_warp::{ThinPlateSpline, TpsParams};
//!
//! // Bend a unit square's corners and centre; the warp interpolates them exactly.
//! let s = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.5, 0.5, 0.2)];
//! let q = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.5, 0.5, 0.5)];
//! let w = ThinPlateSpline::fit(&s, &q, &TpsParams::default())?;
//! assert!((w.eval(s[4]) - q[4]).length() < 1e-5);
//! let n = w.transform_normal(Vec3::new(0.2, 0.2, 0.0), Vec3::Z);
//! assert!((n.length() - 1.0).abs() < 1e-6);
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Parameters
//!
//! | [`TpsParams`] | default | meaning |
//! |---|---|---|
//! | `smoothing` | 0 | `λ` of the regularized spline (0 interpolates; units of length) |
//! | `affine_regularization` | toward identity | control sets that do not span 3D |
//! | `duplicate_tolerance` | 1e-9 | sources closer than this fraction of the box diagonal coincide |
//!
//! | [`PairingParams`] | default | meaning |
//! |---|---|---|
//! | `w_p, w_n, w_v, w_l, w_d` | 1, 3, 30, 9, 7 | Eq. 2–3 weights (Table 1, height field; [`Table1Preset`] has the other rows) |
//! | `max_distance` | unlimited | largest pair length |
//! | `max_normal_difference` | 0.5 | largest `(1 − n_s·n_q)/2` (normals at most 90° apart) |
//! | `max_variation_difference` | unlimited | largest `(v_s − v_q)²` |
//! | `coherence_radius` | twice the targets' median spacing | `σ` of `θ` in `g` |
//! | `rounds` | 3 | rounds of the greedy steps 3–5 |
//! | `remove_crossings` | true | drop pairs that cross their neighbours |
//!
//! ## Choices where the paper leaves room
//!
//! - Thresholds apply to the raw terms (distance, `(1 − n·n)/2`, squared variation
//!   difference); the default normal threshold excludes pairs more than 90° apart.
//! - `g` excludes `q`'s own previous pair from `f_l`, `f_d` ("its neighbours"); a zero-length
//!   pair or cancelling neighbour directions contribute no direction term.
//! - A crossing is a pair of neighbouring pairs (targets within `3σ`) that reverse their
//!   relative order, `(s_i − s_j)·(q_i − q_j) ≤ 0` — the configuration that folds the warp.
//! - Default weights are Table 1's height-field row; [`Table1Preset`] has the others.
//!
//! ## Complexity, determinism, errors
//!
//! Fitting is `O(n³)` (LU of `n + 4`; from 512 unknowns up in panels whose trailing update
//! is one matrix product run on all threads, 1,500 pairs in about 85 ms on 2 cores against
//! 740 ms for nalgebra's unblocked LU), evaluation `O(n)` per point. Many points at once
//! ([`ThinPlateSpline::eval_many`], [`ThinPlateSpline::jacobians`], [`ThinPlateSpline::warp`])
//! run in parallel and in blocks of lanes for the vector unit, with results equal bit for
//! bit to one point at a time.
//! Pairing is `O(n m)` per round without a distance threshold, less with one. Everything is
//! deterministic. Errors are [`TpsError`].
//!
//! ## Features
//!
//! - `serde`: `Serialize`/`Deserialize` for [`TpsParams`], [`AffineRegularization`],
//!   [`PairingParams`] and [`Table1Preset`], and for a fitted [`ThinPlateSpline`] (its
//!   terms, checked by [`ThinPlateSpline::from_terms`] when read); an unlimited pairing
//!   threshold is written as none (`null` in JSON, which has no infinity) and read back
//!   unlimited. Structs with a `Default` are read with missing fields taken from it,
//!   unknown fields refused by name, and
//!   enums spelt in `snake_case` (`"toward_identity"`). Read parameters are checked like
//!   built ones: call `validate()` (or let the fit do it).

#![deny(missing_docs)]

mod error;
mod pairing;
#[cfg(feature = "serde")]
mod serde_threshold;
mod spline;
#[cfg(feature = "serde")]
mod spline_serde;

pub use error::{Result, TpsError};
pub use pairing::{
    MAX_PAIRING_ROUNDS, Pair, PairedWarp, Pairing, PairingParams, PairingPoint, Table1Preset,
    anchors_in_regions, pair_and_fit, pair_points,
};
pub use spline::{AffineRegularization, MAX_CONTROL_POINTS, ThinPlateSpline, TpsParams};
