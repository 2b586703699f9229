//! # mls-surface
//!
//! The point-set surface of Adamson & Alexa (2004, *Approximating and intersecting surfaces
//! from points*), as paper 000 (Duranleau & Poulin, *Patch-based synthesis of geometry
//! textures with point-set surfaces*) uses it, with the tools that paper needs around it.
//!
//! Given oriented points `p_i, n_i` and Gaussian weights `θ(d) = exp(−d²/h²)` truncated at
//! `support · h`:
//!
//! - weighted centre `a(x) = Σ θ(|x − p_i|) p_i / Σ θ(|x − p_i|)`,
//! - weighted normal `n(x) = Σ θ n_i / |Σ θ n_i|`,
//! - implicit function `f(x) = n(x) · (x − a(x))`, whose zero set is the surface,
//! - quasi-orthogonal projection: `x ← x − f(x) n(x)` until `|f| < tolerance · h`.
//!
//! Around it: [`MlsSurface::intersect_ray`] and the two-ray [`MlsSurface::snap_along_normal`]
//! of paper 000 §5.3; [`surface_variation`] `σ = λ0/(λ0+λ1+λ2)` (Pauly et al. 2002, used by
//! paper 000 Eq. 2); [`adaptive_clusters`] (Pauly et al. 2002, paper 000 §5.2's target set
//! Q); [`relax`](relax()) (paper 000 §6). [`MlsSurface`] implements [`pointset_core::Surface`], so
//! `distance-field` can sample it.
//!
//! ## Quick start
//!
//! ```
//! use glam::Vec3;
//! use mls_surface::{MlsParams, MlsSurface};
//! use pointset_core::PointSet;
//!
//! // A 30 × 30 patch of the plane z = 0 with normals +z.
//! let p: Vec<Vec3> = (0..900).map(|i| Vec3::new((i % 30) as f32, (i / 30) as f32, 0.0) * 0.1).collect();
//! let points = PointSet::new(p)?.with_normals(vec![Vec3::Z; 900])?;
//! let surface = MlsSurface::new(&points, &MlsParams::default())?;
//!
//! let q = surface.project(Vec3::new(1.52, 1.37, 0.05)).ok_or("no surface")?;
//! assert!(q.point.z.abs() < 1e-4);
//! assert!((q.signed_distance - 0.05).abs() < 1e-4);
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Parameters ([`MlsParams`])
//!
//! | parameter | default | meaning |
//! |---|---|---|
//! | `kernel` | estimated | `h`; estimate = `kernel_spacing_factor` × median nearest-neighbour spacing; at most [`pointset_core::MAX_SPAN`] |
//! | `kernel_spacing_factor` | 1.25 | keep `support · h` below the thinnest feature's thickness |
//! | `support` | 2.5 | truncation radius in units of `h` (`θ = 0.002` there), at most [`MAX_SUPPORT`] |
//! | `min_neighbours` | 4 | fewer points in the support → no surface (`None`) |
//! | `tolerance` | 1e-4 | stop when `|f| < tolerance · h` |
//! | `max_iterations` | 50 | projection cap (result flagged `converged: false`) |
//!
//! ## Choices where the sources leave room
//!
//! - The gradient of the signed distance at `x` is the normal `n(x*)` at its projection.
//! - Where the kernel does not reach, `project` returns `None`; the [`pointset_core::Surface`]
//!   implementation falls back to the nearest sample and its normal, so distance fields
//!   remain defined far from the points. Its signed distance takes the magnitude from the
//!   projection and the sign from `f` at the query (the surface is `f`'s zero set); out of
//!   the kernel's reach, the magnitude from the nearest sample and the sign from its plane
//!   when the query lies within 45° of its normal, else from the tangent planes of the
//!   nearest few samples ([`MlsParams::fallback_sign_samples`], [`SINGLE_PLANE_COSINE`]:
//!   one plane is wrong too often near sharp edges, thin parts and tilted normals).
//! - A sample with fewer than `min_neighbours` samples (itself included) within twice the
//!   support radius has a surface of its own (a bubble, where a distance field falls back
//!   to it); [`isolated_samples`] lists such samples, and [`without_isolated`] leaves them
//!   out unless they are most of the points (a kernel too small for the sampling).
//! - Clusters are represented by the member nearest the centroid (a real oriented sample).
//! - Relaxation moves all points simultaneously (Jacobi style), which makes it independent
//!   of thread scheduling.
//!
//! ## Complexity
//!
//! One projection costs a radius query plus `O(k)` per iteration for `k` points in the
//! support; candidates are cached across iterations. Surface variation and clustering are
//! `O(n k log n)` and `O(n log n)`.
//!
//! ## Determinism and errors
//!
//! Every function is deterministic and parallel work (rayon) is per point. Errors are
//! [`MlsError`]: missing normals, empty input, zero normals, out-of-range parameters.
//! Queries where the surface is undefined return `None`, never panic.
//!
//! ## Features
//!
//! - `serde`: `Serialize`/`Deserialize` for [`MlsParams`], [`ClusterParams`] and
//!   [`RelaxParams`]. Structs read with missing fields taken from their `Default` and
//!   unknown fields refused by name. Read parameters are checked like built ones: call
//!   `validate()` (or let the function that takes them do it).

#![deny(missing_docs)]

mod cluster;
mod error;
mod heights;
mod index_match;
mod isolated;
mod isolated_points;
mod orientation;
mod params;
mod pca;
mod ray;
mod relax;
mod surface;

pub use cluster::{Cluster, ClusterParams, adaptive_clusters};
pub use error::{MlsError, Result};
pub use heights::{HeightMethod, TopHeight};
pub use isolated::{ISOLATION_REACH, isolated_samples};
pub use isolated_points::{
    IsolatedFate, IsolatedPoints, SPARSE_SAMPLING_SHARE, isolated_points, without_isolated,
    without_isolated_indexed,
};
pub use orientation::{
    LIKELY_UNORIENTED, LINKING_STAGE, ORIENTATION_GRAPH_NEIGHBOURS, ORIENTATION_NEIGHBOURS,
    ORIENTING_STAGE, fit_oriented_normals_with, orient_normals, orient_normals_in,
    orient_normals_with, orientation_disagreement, orientation_disagreement_with,
};
pub use params::{MAX_SUPPORT, MlsParams};
pub use pca::{
    Covariance, FITTING_STAGE, MIN_NORMAL_DEFINITENESS, NORMAL_NEIGHBOURS, NormalFit,
    PLANE_RADIUS_MAX_NEIGHBOURS, estimate_normals, fit_normals, fit_normals_in, fit_normals_with,
    plane_radius, surface_variation,
};
pub use ray::{RayHit, Snap, SnapMethod};
pub use relax::{RelaxParams, Relaxed, nearest_neighbour_spread, relax};
pub use surface::{LocalFit, MlsSurface, Projection, SINGLE_PLANE_COSINE};
