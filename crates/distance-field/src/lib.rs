//! # distance-field
//!
//! Signed distance fields as paper 000 (Duranleau & Poulin, §5.1) and paper 001 (Lagae,
//! Dumont & Dutré, *Geometry Synthesis*, §3–§4.1) use them: grids of signed distance plus
//! gradient sampled from any [`pointset_core::Surface`] (an MLS point-set surface or a
//! triangle mesh), block pyramids by averaging with 8-bit quantization, iso-surface
//! extraction, and NRRD files.
//!
//! ## Quick start
//!
//! ```
//! use distance_field::{GridSpec, MeshSurface, SdfGrid, sdf_isosurface};
//! use glam::Vec3;
//! use pointset_core::{Aabb, PointSet, TriMesh};
//!
//! // A tetrahedron; its distance field; and the zero set back as a mesh.
//! let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
//! let tet = TriMesh::new(PointSet::new(p)?, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])?;
//! let surface = MeshSurface::new(&tet)?;
//! assert!(surface.signed_distance_to(Vec3::splat(0.1)).ok_or("no distance")? < 0.0);
//!
//! let spec = GridSpec::covering(Aabb::new(Vec3::ZERO, Vec3::ONE), 24, 0.2)?;
//! let sdf = SdfGrid::from_surface(&surface, &spec, 0.5)?;
//! let mesh = sdf_isosurface(&sdf)?;
//! assert!(mesh.face_count() > 100);
//! Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Parts
//!
//! | item | what |
//! |---|---|
//! | [`MeshSurface`] | BVH closest point on a triangle mesh; sign from angle-weighted pseudo-normals (rule for open meshes in its docs) or, by [`MeshSign`], from generalized winding numbers |
//! | [`winding`] | solid angles of triangles and the hierarchy's fast winding number (intersecting or nearly closed pieces) |
//! | [`point_winding`] | winding numbers of oriented point clouds ([`PointWinding`], per-sample areas) and [`WindingSigned`], which signs any surface sampled by a cloud by them ([`PointSign`]: thin parts, stray normals) |
//! | [`GridSpec`], [`SdfGrid`] | node layout; 4-channel `(distance, gradient)` grid, clamped to a band, parallel and deterministic |
//! | [`BlockPyramid`], [`Quantizer`] | paper 001 §4.1 pyramids by 2×2×2 averaging; 256 levels over `[−range, range]` |
//! | [`isosurface`], [`sdf_isosurface`] | marching tetrahedra (Kuhn split): closed, welded, outward-oriented meshes |
//! | [`nrrd`] | read/write NRRD (raw f32, attached header) |
//!
//! ## Choices where the sources leave room
//!
//! - Gradients are the unit offset from the closest surface point to the node, oriented
//!   toward increasing distance — the exact gradient of a distance field — or the surface
//!   normal for nodes on the surface.
//! - Distances are clamped to `[−band, band]` (the caller picks the band; paper 001's
//!   quantization range is the natural choice). Gradients are not clamped.
//! - Iso-surfaces use marching tetrahedra rather than marching cubes: both interpolate
//!   linearly along edges, and tetrahedra have no ambiguous configurations, which makes the
//!   output watertight by construction.
//!
//! ## Complexity and determinism
//!
//! A mesh query is `O(log n)` expected with the BVH; grid filling walks rows in parallel,
//! bounds each node's search by the previous node's distance plus the spacing, and skips
//! the nodes inside a clearance the surface gives (meshes, and MLS surfaces out of reach,
//! say how far beyond the band a node is). Extraction
//! is linear in the number of cells. All results are independent of the thread count.
//!
//! ## Errors
//!
//! [`FieldError`]: invalid parameters, meshes without triangles, unreadable NRRD headers
//! (with the line) or data shorter than the header promises (checked before allocating).
//!
//! ## Features
//!
//! - `serde`: `Serialize`/`Deserialize` for [`GridSpec`], [`MeshSign`], [`PointSign`] and
//!   [`FarSigns`]. Unknown fields are refused by name and enums are spelt in `snake_case`
//!   (`"winding_number"`); read values are checked where they are used, like built ones.

#![deny(missing_docs)]

mod bvh;
mod error;
mod far_regions;
pub mod far_signs;
mod far_waves;
mod iso;
mod mesh_surface;
pub mod nrrd;
pub mod point_winding;
mod pyramid;
mod sdf;
mod triangle;
pub mod winding;

pub use error::{FieldError, Result};
pub use far_signs::FarSigns;
pub use iso::{
    CROSSING_MISS, MOVED_NORMAL_AGREEMENT, closed_isosurface, isosurface, sdf_isosurface,
    sdf_isosurface_of,
};
pub use mesh_surface::{MeshHit, MeshSign, MeshSurface};
pub use point_winding::{PointSign, PointWinding, WindingSigned};
pub use pyramid::{BlockPyramid, Quantizer, mean_squared_difference};
pub use sdf::{GridSpec, SAMPLING_STAGE, SdfGrid};
