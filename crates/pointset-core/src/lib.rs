//! # pointset-core
//!
//! Shared foundations of the geosynth workspace: geometry types ([`PointSet`], [`TriMesh`],
//! [`Aabb`], [`Grid3`]), spatial indices ([`KdIndex`], [`BucketGrid`]), file I/O ([`io`]:
//! PLY ascii/binary, OBJ, OFF, STL, XYZ, LAS, PCD, glTF; polygon faces split by
//! [`triangulate_polygon`]), seeded randomness ([`rng`]), stray points far outside the
//! rest ([`strays`]), oriented points sampled on a mesh's surface and point sets thinned
//! to their own points ([`surface_sampling`]),
//! meshes simplified by edge collapse under error quadrics ([`simplify`]), and the
//! [`Stage`] /
//! [`RunContext`] / [`Progress`] machinery every algorithm is exposed through, and the
//! [`Surface`] trait (closest point + normal) shared by point-set surfaces and meshes. It
//! contains no algorithm from any paper.
//!
//! ## Quick start
//!
//! ```
//! use glam::Vec3;
//! use pointset_core::{io, Attribute, KdIndex, PointSet};
//!
//! let points = PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, 2.0, 0.0)])?
//!     .with_normals(vec![Vec3::Z; 3])?
//!     .with_attribute(Attribute::new("confidence", vec![0.9, 0.5, 1.0]))?;
//!
//! let index = KdIndex::new(points.positions())?;
//! let nearest = index.nearest(Vec3::new(0.9, 0.1, 0.0), 1)?;
//! assert_eq!(nearest[0].index, 1);
//!
//! let dir = tempfile::tempdir()?;
//! let path = dir.path().join("points.ply");
//! let geometry = io::Geometry::Points(points);
//! io::write_geometry(&path, &geometry, &io::WriteOptions::default())?;
//! let loaded = io::read_geometry(&path)?;
//! assert_eq!(loaded.geometry, geometry);
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Conventions
//!
//! - Geometry is `glam` (`Vec3`, `f32`); every stored value is finite (constructors check).
//! - Colours are the `red`, `green`, `blue` attribute channels in `0..=255` (the PLY
//!   convention); [`PointSet::colors`] returns them in `0..=1`.
//! - Randomness: [`rng::stream`]`(seed, index)` gives independent reproducible streams.
//! - Errors: one [`Error`] enum; readers report a line number or byte offset.
//!
//! ## Determinism
//!
//! Spatial queries return results sorted by distance then index ([`KdIndex`]) or by key
//! ([`BucketGrid`]); nothing here depends on thread scheduling or hash seeds.
//!
//! ## Features
//!
//! - `serde`: `Serialize`/`Deserialize` for [`Aabb`], [`ScalarType`] and the parameters of
//!   [`surface_sampling`] and [`simplify`].

#![deny(missing_docs)]

mod aabb;
mod disjoint;
mod error;
mod grid;
mod heightfield;
pub mod io;
mod mesh;
mod mesh_orientation;
mod pointset;
mod polygon;
pub mod rng;
mod scalar;
mod scaled;
pub mod simplify;
pub mod spatial;
mod stage;
pub mod strays;
mod surface;
pub mod surface_sampling;
pub mod testdata;
mod weld;

pub use aabb::{Aabb, MAX_SPAN, check_span};
pub use disjoint::DisjointSets;
pub use error::{Error, Location, Result};
pub use grid::Grid3;
pub use heightfield::{HeightField, dims_from_name};
pub use mesh::{DuplicateFace, MeshTopology, NormalWeighting, TriMesh};
pub use mesh_orientation::Reorientation;
pub use pointset::{Attribute, COLOR_CHANNELS, PointSet, RESERVED_NAMES};
pub use polygon::{MAX_EAR_CLIPPED_CORNERS, triangulate_polygon};
pub use scalar::ScalarType;
pub use scaled::{power_of_two_scale, triangle_normal, unit_vector};
pub use spatial::{BucketGrid, KdIndex, KdRegion, Neighbour, PointKey};
pub use stage::{CancelFlag, Map, NoProgress, Progress, ProgressUpdate, RunContext, Stage, Then};
pub use surface::{BandAnswer, Surface, SurfacePoint};

/// Re-export of the `glam` version used for all geometry.
pub use glam;
