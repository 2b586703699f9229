//! # geosynth
//!
//! Example-based geometry and texture synthesis in Rust: given a small example — a point
//! set, a mesh, a height field, a texture — produce more of it. This facade re-exports the
//! workspace's crates as modules and adds what ties them together: headless previews
//! ([`preview`]), procedural exemplars ([`fixtures`]) and an umbrella [`Error`].
//!
//! | module | crate | what |
//! |---|---|---|
//! | [`core`] | `pointset-core` | point sets, meshes, grids, spatial indices, PLY/OBJ/OFF/STL/XYZ/LAS/PCD/glTF I/O, mesh simplification, [`Stage`] |
//! | [`mls`] | `mls-surface` | point-set surfaces: projection, rays, surface variation, clustering, relaxation, normal estimation and orientation |
//! | [`sdf`] | `distance-field` | signed distance grids, block pyramids, iso-surfaces, NRRD |
//! | [`tps`] | `tps-warp` | thin-plate spline warps, normal transport, automatic point pairing |
//! | [`voxel`] | `voxel-dfsynth` | paper 001: distance-field block matching and synthesis, the `VoxelSynth` stage |
//! | [`quilt`] | `patch-quilt` | paper 000: patch-based geometry texture synthesis, the `Quilt` stage, and `SampleHeights` to write a quilted height field back as one |
//! | [`normals`] | (facade) | stage: bare points → points with oriented normals |
//! | [`strays`] | (facade) | stage: a scan → the same without its stray and isolated points |
//! | [`sample`] | (facade) | stage: a mesh → oriented points sampled on its surface (uniform or Poisson disk); stage: a point set → fewer of its own points |
//! | [`reconstruct`] | (facade) | stages: oriented points → mesh, geometry → distance grid; trimming open scans |
//! | [`simplify`] | (facade) | stage: a mesh → the same surface in fewer triangles (edge collapse under error quadrics) |
//! | [`warp`] | (facade) | stage: a point set or mesh moved by a thin-plate spline |
//! | [`preview`] | (facade) | CPU rendering of point sets and meshes to PNG |
//! | [`fixtures`] | (facade) | deterministic procedural exemplars |
//! | [`imagery`] | (facade) | textures and height fields from PNG/JPEG/raw `f32` files |
//!
//! The synthesis families are modules exposed as [`Stage`]s: [`quilt`] (paper 000) and
//! [`voxel`] (paper 001) today; `texmesh` and `structure` arrive with their issues.
//!
//! ## Cookbook: read, inspect, render
//!
//! ```
//! use geosynth::core::io::{self, Geometry, WriteOptions};
//! use geosynth::{fixtures, preview};
//!
//! let torus = Geometry::Mesh(fixtures::torus_mesh(32, 16, 1.0, 0.3)?);
//! let dir = tempfile::tempdir()?;
//! let path = dir.path().join("torus.ply");
//! io::write_geometry(&path, &torus, &WriteOptions::default())?;
//!
//! let loaded = io::read_geometry(&path)?;
//! assert_eq!(loaded.geometry.mesh().map(|m| m.face_count()), Some(32 * 16 * 2));
//!
//! let image = preview::render(&loaded.geometry, &preview::RenderOptions::default())?;
//! preview::save_png(&image, &dir.path().join("torus.png"))?;
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Cookbook: a bare scan to a mesh
//!
//! Positions alone (an XYZ scan) get normals by local PCA, oriented by propagation
//! ([`normals::EstimateNormals`]), and become a closed mesh; an open scan would be trimmed
//! with [`reconstruct::trim_to_samples`]. A scan with outliers goes through
//! [`strays::LeaveOutStrays`] first, as `geosynth reconstruct` does: points far outside the
//! rest would stretch the grid, and points alone would close into bubbles of their own.
//!
//! ```
//! use geosynth::core::PointSet;
//! use geosynth::mls::{NORMAL_NEIGHBOURS, estimate_normals, orient_normals};
//! use geosynth::reconstruct::{FieldParams, Reconstruct};
//! use geosynth::{RunContext, Stage};
//!
//! let scan = geosynth::fixtures::sphere_points(2000)?;
//! let bare = PointSet::new(scan.positions().to_vec())?;
//! // The two steps one by one; `EstimateNormals` does both in one stage.
//! let estimated = estimate_normals(&bare, NORMAL_NEIGHBOURS)?;
//! let oriented = orient_normals(&estimated, glam::Vec3::Z)?;
//! let stage = Reconstruct { params: FieldParams::default().resolution(32) };
//! let mesh = stage.run(oriented, &mut RunContext::new(0))?;
//! let topology = mesh.topology();
//! assert!(topology.is_closed_manifold() && topology.euler_characteristic == 2);
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Composing stages
//!
//! Every algorithm is a [`Stage`]; `then` chains them with typed inputs and outputs, and the
//! [`RunContext`] carries the seed, a progress sink, a cancel flag and per-stage timings.
//!
//! ```
//! use geosynth::core::{io::Geometry, PointSet};
//! use geosynth::{RunContext, Stage};
//!
//! /// Keeps the points above a height.
//! struct Above(f32);
//! impl Stage for Above {
//!     type Input = PointSet;
//!     type Output = PointSet;
//!     type Error = geosynth::Error;
//!     fn name(&self) -> &str { "above" }
//!     fn run(&self, p: PointSet, ctx: &mut RunContext) -> Result<PointSet, Self::Error> {
//!         ctx.check_cancelled()?;
//!         Ok(p.filter(|_, q| q.y > self.0))
//!     }
//! }
//!
//! let sphere = geosynth::fixtures::sphere_points(1000)?;
//! let cap = Above(0.0).then(Above(0.5)).run(sphere, &mut RunContext::new(7))?;
//! assert!(cap.positions().iter().all(|p| p.y > 0.5));
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Where one stage's output is not the next one's input, `map` adapts it. A geometry
//! texture quilted (paper 000) and turned into a mesh, in one pipeline:
//!
//! ```
//! use geosynth::quilt::{OutputSize, Quilt, QuiltParams, texture_from_exemplar};
//! use geosynth::reconstruct::{FieldParams, ReconstructOpen};
//! use geosynth::{fixtures, RunContext, Stage};
//!
//! let texture = texture_from_exemplar(&fixtures::textures::bumpy(60.0, 1, 1)?)?;
//! let quilt = Quilt {
//!     params: QuiltParams::default().output(OutputSize::Scale(1.25)).field_resolution(20),
//! };
//! // The sheet is open: its mesh is cut back to the quilted points.
//! let to_mesh = ReconstructOpen { params: FieldParams::default().resolution(40), ..Default::default() };
//! // The quilt's output holds its points, box and placements; the mesh needs the points.
//! let pipeline = quilt.map(|out| out.points).then(to_mesh);
//! let mut ctx = RunContext::new(3);
//! let sheet = pipeline.run(texture, &mut ctx)?;
//! let topology = sheet.topology();
//! assert!(sheet.face_count() > 1000 && topology.components == 1 && topology.boundary_edges > 0);
//! let stages: Vec<&str> = ctx.timings().iter().map(|(name, _)| name.as_str()).collect();
//! assert!(stages.contains(&"quilt") && stages.contains(&"trim"), "{stages:?}");
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Features
//!
//! - `serde`: `Serialize`/`Deserialize` for every crate's parameter types (it turns on each
//!   crate's own `serde` feature), [`reconstruct::FieldParams`], and the stages (the
//!   [`warp::Warp`] stage with its spline's terms). Structs with a `Default` are
//!   read with missing fields taken from it, unknown fields refused by name, and enums
//!   spelt in `snake_case` (`"search_only"`). Read parameters are checked like built ones:
//!   call `validate()` (or let the run do it).

#![deny(missing_docs)]

mod error;
pub mod fixtures;
pub mod imagery;
pub mod normals;
pub mod preview;
pub mod quilt;
pub mod reconstruct;
pub mod sample;
pub mod simplify;
pub mod strays;
pub mod voxel;
pub mod warp;

/// Shared types, I/O and spatial indices (the `pointset-core` crate).
pub use pointset_core as core;

/// Point-set surfaces after Adamson & Alexa (the `mls-surface` crate).
///
/// ```
/// use geosynth::mls::{MlsParams, MlsSurface};
///
/// let sphere = geosynth::fixtures::sphere_points(4000)?;
/// let surface = MlsSurface::new(&sphere, &MlsParams::default())?;
/// let p = surface.project(glam::Vec3::new(0.0, 1.05, 0.0)).ok_or("no surface")?;
/// assert!((p.point.length() - 1.0).abs() < 0.01);
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub use mls_surface as mls;

/// Signed distance fields (the `distance-field` crate).
///
/// ```
/// use geosynth::sdf::{GridSpec, MeshSurface, SdfGrid, sdf_isosurface};
///
/// let torus = geosynth::fixtures::torus_mesh(48, 24, 1.0, 0.35)?;
/// let surface = MeshSurface::new(&torus)?;
/// let spec = GridSpec::covering(torus.bounding_box().ok_or("empty")?, 40, 0.1)?;
/// let field = SdfGrid::from_surface(&surface, &spec, 0.3)?;
/// let remeshed = sdf_isosurface(&field)?;
/// assert!(remeshed.face_count() > 1000);
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub use distance_field as sdf;

pub use pointset_core::{CancelFlag, Progress, ProgressUpdate, RunContext, Stage};
/// Thin-plate spline warps and point pairing (the `tps-warp` crate).
///
/// ```
/// use geosynth::tps::{ThinPlateSpline, TpsParams};
/// use glam::Vec3;
///
/// // Push the middle of a flat patch up; anchors at the corners keep the rest in place.
/// let corners = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)];
/// let mut from = corners.to_vec();
/// let mut to = corners.to_vec();
/// from.push(Vec3::new(0.5, 0.5, 0.0));
/// to.push(Vec3::new(0.5, 0.5, 0.2));
/// let warp = ThinPlateSpline::fit(&from, &to, &TpsParams::default())?;
///
/// let sphere = geosynth::fixtures::sphere_points(500)?;
/// let (moved, normals) = warp.warp(sphere.positions(), sphere.normals());
/// assert_eq!(moved.len(), 500);
/// assert!(normals.ok_or("normals")?.iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
/// Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub use tps_warp as tps;

pub use error::{Error, Result};
