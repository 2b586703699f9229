//! Mesh simplification by edge collapse under error quadrics (Garland and Heckbert,
//! "Surface simplification using quadric error metrics", SIGGRAPH 1997): fewer triangles
//! for a mesh that has too many — a reconstruction, an iso-surface, a scan — keeping its
//! shape, its boundaries and its topology.
//!
//! Each vertex carries a quadric, the sum of the squared distances to the planes of the
//! faces around it, each plane counted once as in the paper. Every edge gets a cost: its two
//! vertices' quadrics summed, at the point where that sum is least. The cheapest edge
//! collapses — one vertex merges into the other, which moves to that point and takes
//! the summed quadric — and the edges around it are costed anew; until the mesh has no
//! more than [`SimplifyParams::target_faces`] faces, or no edge may collapse.
//!
//! The choices this implementation makes where the paper leaves room:
//!
//! - **Pairs are edges only** (the paper's threshold `t = 0`): parts that do not share an
//!   edge are never joined, and no collapse changes the topology. A collapse is refused
//!   when it would (the link condition of Dey et al., with the boundary taken as a vertex
//!   of its own): the two vertices share a neighbour that is not across the edge, or an
//!   edge inside the surface joins two boundary vertices, or the collapse would make two
//!   faces of the same corners (a tetrahedron), or remove a component's last face. So a
//!   closed surface stays closed, with its genus, and every component stays.
//! - **Boundaries** get the paper's constraint planes: through each boundary edge,
//!   perpendicular to its face, counted [`SimplifyParams::boundary_weight`] times. A
//!   boundary then moves along itself, not inward.
//! - **Seams**: the topology is that of the vertices welded by position (`-0` as `0`),
//!   so a mesh split where its texture coordinates jump (Spot's OBJ: 13 pieces, one
//!   closed surface welded) simplifies as the one surface it is. Each face corner keeps
//!   its own input vertex (its *wedge*: normal, UV, colour); when an edge collapses, the
//!   wedges of the removed vertex merge into the kept vertex's wedges on the same faces,
//!   and a seam's two sides keep theirs apart. Seam edges (inside the welded surface,
//!   with different wedges on their two faces at an end) get constraint planes as
//!   boundaries do, so a seam moves along itself. Vertices on an edge of more than two
//!   faces, or where the surface is pinched to a point (faces that make more than one
//!   fan), take part in no collapse.
//! - **Where the merged vertex goes**: the sum's least point when its matrix is well
//!   conditioned and that point lies within an edge's length of the edge's midpoint; else
//!   the least point along the edge (a flat or a straight neighbourhood has a plane or a
//!   line of best points); never worse than either endpoint.
//! - **No folds**: a collapse is refused when any face around it would turn by more than
//!   [`SimplifyParams::max_face_turn`] degrees, or lose all its area, or end up more than
//!   a right angle from the way it faced in the input (turns add up over collapses: on a
//!   torus at a tenth of its faces, one face had come to face into the tube).
//! - **Error limit**: [`SimplifyParams::max_error`] refuses a collapse whose point lies
//!   further than that from its faces' planes (the root mean square distance over the
//!   planes merged into it, a boundary's constraints counted in the sum but not in the
//!   number), so a run can stop at a tolerance instead of a count.
//! - **Vertex data**: texture coordinates, colours and float attributes are interpolated
//!   along the edge to where the vertex went; integer attributes other than colours
//!   (labels, such as a quilt's `patch`) come from the nearer of the two vertices.
//! - **Normals** are interpolated along the edge too (renormalized) by default
//!   ([`SimplifiedNormals::Interpolate`]), which keeps the dense input's shading on the
//!   coarse output; or recomputed from the output's faces
//!   ([`SimplifiedNormals::Recompute`]), which shades the output as the faceted surface it
//!   is. Either way a normal never ends up facing against its faces: faces are taken in
//!   *smooth groups* — vertices at one position whose input normals agree (within a
//!   degree: the two sides of a texture seam) start in one group, those whose normals
//!   differ (the sides of a hard edge) in groups of their own, merged vertices join
//!   their groups — and an interpolated normal facing against the angle-weighted mean
//!   normal of its group's faces is replaced by that mean, as every recomputed normal
//!   is. So the input's creases stay creases and its smooth surfaces stay smooth across
//!   seams. (Measured on the demo's reconstructions at a tenth of their faces: the
//!   interpolated normals lie 2.6° from the input's nearest normal on average on the
//!   bunny and 12.3° on the chameleon, the recomputed ones 4.6° and 18.5°; one
//!   interpolated normal of the chameleon's faced against its faces before it was
//!   replaced.)
//! - **Order**: ties in cost go to the edge of lower vertex indices, so the result
//!   depends on the mesh and the parameters only. A refused edge is tried again once one
//!   of its own vertices has changed.
//!
//! Faces with a repeated corner, or two corners at one position (no area, no plane), are
//! left out first, and vertices no face uses are not written: the report counts both.
//!
//! ```
//! use pointset_core::simplify::{SimplifyParams, simplify_mesh};
//! use pointset_core::{PointSet, RunContext, TriMesh};
//! use glam::Vec3;
//!
//! // A flat 9 × 9 grid of 128 triangles simplifies to a handful, as flat as it was.
//! let positions = (0..81).map(|i| Vec3::new((i % 9) as f32, (i / 9) as f32, 0.0)).collect();
//! let mut faces = Vec::new();
//! for y in 0..8u32 {
//!     for x in 0..8u32 {
//!         let v = y * 9 + x;
//!         faces.push([v, v + 1, v + 10]);
//!         faces.push([v, v + 10, v + 9]);
//!     }
//! }
//! let grid = TriMesh::new(PointSet::new(positions)?, faces)?;
//! let simplified = simplify_mesh(&grid, &SimplifyParams::faces(8), &mut RunContext::new(0))?;
//! assert!(simplified.mesh.face_count() <= 8);
//! assert!(simplified.mesh.positions().iter().all(|p| p.z == 0.0));
//! assert_eq!(simplified.mesh.area(), 64.0); // the boundary kept: the same square
//! # Ok::<(), pointset_core::Error>(())
//! ```

mod quadric;
mod queue;
mod smooth_groups;
mod vertex_data;
mod working;

use crate::{Error, Result, RunContext, TriMesh};
use queue::{CollapseQueue, Queued};
use vertex_data::VertexData;
use working::{Refusal, Role, Working};

/// How far to simplify, and the limits a collapse must keep (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SimplifyParams {
    /// Stop once the mesh has no more faces than this (0: as far as the limits allow).
    pub target_faces: usize,
    /// No collapse whose vertex lands further than this from its planes, in the mesh's
    /// units (root mean square over the planes merged into it); `None`: no limit.
    #[cfg_attr(feature = "serde", serde(default))]
    pub max_error: Option<f64>,
    /// The most a face may turn in one collapse, in degrees, above 0 and at most 180
    /// (default [`DEFAULT_MAX_FACE_TURN`]).
    #[cfg_attr(feature = "serde", serde(default = "default_max_face_turn"))]
    pub max_face_turn: f64,
    /// How many times a boundary or seam edge's constraint plane counts against a face's
    /// plane, at least 0 (default [`DEFAULT_BOUNDARY_WEIGHT`]; 0 lets boundaries shrink).
    #[cfg_attr(feature = "serde", serde(default = "default_boundary_weight"))]
    pub boundary_weight: f64,
    /// Where the output's vertex normals come from, when the input has normals.
    #[cfg_attr(feature = "serde", serde(default))]
    pub normals: SimplifiedNormals,
}

/// Where a simplified mesh's vertex normals come from (module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum SimplifiedNormals {
    /// Interpolated along each collapsed edge, as texture coordinates are: the input's
    /// shading kept. One that ends up facing against its faces takes theirs.
    #[default]
    Interpolate,
    /// Recomputed from the output's faces, each vertex's from the faces of its smooth
    /// group, the input's creases kept: the output shaded as the surface it is.
    Recompute,
}

/// The default [`SimplifyParams::max_face_turn`], in degrees: a face may turn by up to a
/// right angle in one collapse, not fold over.
pub const DEFAULT_MAX_FACE_TURN: f64 = 90.0;

/// The default [`SimplifyParams::boundary_weight`]: a boundary edge's constraint plane
/// weighs as much as a hundred faces' planes, so a boundary barely moves off its line.
pub const DEFAULT_BOUNDARY_WEIGHT: f64 = 100.0;

#[cfg(feature = "serde")]
fn default_max_face_turn() -> f64 {
    DEFAULT_MAX_FACE_TURN
}

#[cfg(feature = "serde")]
fn default_boundary_weight() -> f64 {
    DEFAULT_BOUNDARY_WEIGHT
}

impl SimplifyParams {
    /// Down to at most `target_faces` faces, with the default limits.
    pub fn faces(target_faces: usize) -> Self {
        Self {
            target_faces,
            max_error: None,
            max_face_turn: DEFAULT_MAX_FACE_TURN,
            boundary_weight: DEFAULT_BOUNDARY_WEIGHT,
            normals: SimplifiedNormals::Interpolate,
        }
    }

    /// These parameters with [`Self::max_error`] set.
    pub fn max_error(mut self, max_error: f64) -> Self {
        self.max_error = Some(max_error);
        self
    }

    /// Errors name the first parameter out of range.
    pub fn validate(&self) -> Result<()> {
        let out_of_range = |name, value: f64, expected: &str| {
            Err(Error::InvalidParameter {
                name,
                value: value.to_string(),
                expected: expected.into(),
            })
        };
        if let Some(max_error) = self.max_error
            && !(max_error.is_finite() && max_error >= 0.0)
        {
            return out_of_range("max_error", max_error, "a finite distance, at least 0");
        }
        if !(self.max_face_turn > 0.0 && self.max_face_turn <= 180.0) {
            return out_of_range(
                "max_face_turn",
                self.max_face_turn,
                "an angle above 0 and at most 180 degrees",
            );
        }
        if !(self.boundary_weight.is_finite() && self.boundary_weight >= 0.0) {
            return out_of_range(
                "boundary_weight",
                self.boundary_weight,
                "a finite weight, at least 0",
            );
        }
        Ok(())
    }
}

/// What [`simplify_mesh`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct SimplifyReport {
    /// Faces of the input.
    pub faces_before: usize,
    /// Faces of the output.
    pub faces_after: usize,
    /// Vertices of the input.
    pub vertices_before: usize,
    /// Vertices of the output.
    pub vertices_after: usize,
    /// Edges collapsed.
    pub collapses: usize,
    /// Collapses refused because they would have changed the topology.
    pub refused_topology: usize,
    /// Collapses refused because a face would have turned too far or lost its area.
    pub refused_fold: usize,
    /// Collapses refused by [`SimplifyParams::max_error`].
    pub refused_error: usize,
    /// Vertices that took part in no collapse: on an edge of more than two faces, or
    /// where the surface is pinched to a point.
    pub frozen_vertices: usize,
    /// Edges inside the surface where the vertex data splits: the two faces use
    /// different vertices at an end (a texture seam), given constraint planes as
    /// boundaries are.
    pub seam_edges: usize,
    /// Input faces with a repeated corner, or corners at the same position, left out.
    pub faces_with_repeated_corners: usize,
    /// Input vertices no face used, not written.
    pub vertices_without_faces: usize,
    /// The largest error of a collapse made: the root mean square distance from the
    /// merged vertex to its planes, in the mesh's units (0 when none was made).
    pub max_collapse_error: f64,
}

/// A simplified mesh and what was done to it.
#[derive(Debug, Clone, PartialEq)]
pub struct Simplified {
    /// The mesh: the input's vertices that are left (each at its welded vertex's new
    /// position, with its data merged), in their input order.
    pub mesh: TriMesh,
    /// The counts.
    pub report: SimplifyReport,
}

/// Collapses between reports of progress and checks for cancellation.
const PROGRESS_EVERY: usize = 4096;

/// Simplifies `mesh` (module docs); reports progress as "simplify" (faces removed of those
/// to remove) and stops when cancelled.
///
/// Errors: parameters out of range ([`Error::InvalidParameter`]), a mesh without faces
/// ([`Error::EmptyInput`]), [`Error::Cancelled`].
pub fn simplify_mesh(
    mesh: &TriMesh,
    params: &SimplifyParams,
    ctx: &mut RunContext,
) -> Result<Simplified> {
    params.validate()?;
    let Some(bounds) = mesh.bounding_box().filter(|_| mesh.face_count() > 0) else {
        return Err(Error::EmptyInput {
            what: "the mesh's triangles".into(),
        });
    };
    // Positions about the box's centre, where double precision rounds least.
    let centre = (bounds.min.as_dvec3() + bounds.max.as_dvec3()) * 0.5;
    let corners: Vec<[u32; 3]> = mesh
        .triangles()
        .iter()
        .copied()
        .filter(|&[a, b, c]| a != b && b != c && c != a)
        .collect();
    let (mut working, welded_together) =
        Working::new(mesh.positions(), &corners, centre, params.boundary_weight);
    let mut data = VertexData::of(mesh, working.wedge_vertices(), params.normals);
    let mut report = SimplifyReport {
        faces_before: mesh.face_count(),
        vertices_before: mesh.vertex_count(),
        faces_with_repeated_corners: mesh.face_count() - corners.len() + welded_together,
        vertices_without_faces: mesh.unreferenced_vertices(),
        frozen_vertices: working.roles.iter().filter(|&&r| r == Role::Frozen).count(),
        seam_edges: working.seam_edges,
        ..SimplifyReport::default()
    };

    let mut queue = queue_every_edge(&mut working);
    collapse_until(
        &mut working,
        &mut data,
        &mut queue,
        params,
        &mut report,
        ctx,
    )?;

    // Every input vertex at its welded vertex, those no live face uses left out.
    let positions = (0..mesh.vertex_count() as u32)
        .map(|w| (working.wedge_position(w) + centre).as_vec3())
        .collect();
    let triangles = working.live_corners().copied().collect();
    let mesh = data
        .into_mesh(positions, triangles)?
        .into_without_unreferenced_vertices()?;
    report.faces_after = mesh.face_count();
    report.vertices_after = mesh.vertex_count();
    Ok(Simplified { mesh, report })
}

/// The planned collapse of every edge of `working`, queued (the edge list is handed over:
/// it is not needed again).
fn queue_every_edge(working: &mut Working) -> CollapseQueue {
    let edges = std::mem::take(&mut working.edges);
    let planned = edges
        .into_iter()
        .filter_map(|(a, b)| planned(working, a, b))
        .collect();
    CollapseQueue::from_entries(planned)
}

/// Collapses the cheapest edges that pass the checks until `working` has no more than
/// `params.target_faces` faces or the queue is empty, merging the wedges' `data` and
/// counting into `report`; progress as "simplify", cancellation every
/// [`PROGRESS_EVERY`] collapses.
fn collapse_until(
    working: &mut Working,
    data: &mut VertexData,
    queue: &mut CollapseQueue,
    params: &SimplifyParams,
    report: &mut SimplifyReport,
    ctx: &mut RunContext,
) -> Result<()> {
    let min_cos = params.max_face_turn.to_radians().cos();
    let start_faces = working.live_faces;
    let to_remove = start_faces.saturating_sub(params.target_faces) as u64;
    let mut merged = Vec::new();
    while working.live_faces > params.target_faces {
        let Some(queued) = queue.pop() else {
            break;
        };
        let (keep, gone) = (queued.keep as usize, queued.gone as usize);
        if queued.versions != [working.versions[keep], working.versions[gone]]
            || working.roles[keep] == Role::Gone
            || working.roles[gone] == Role::Gone
        {
            continue;
        }
        let Some(collapse) = working.plan(queued.keep, queued.gone) else {
            continue;
        };
        if params
            .max_error
            .is_some_and(|limit| collapse.distance > limit)
        {
            report.refused_error += 1;
            continue;
        }
        match working.check(&collapse, min_cos) {
            Ok(None) => continue,
            Err(Refusal::Topology) => report.refused_topology += 1,
            Err(Refusal::Fold) => report.refused_fold += 1,
            Ok(Some(shared)) => {
                working.apply(&collapse, &shared, &mut merged);
                for &(k, g) in &merged {
                    data.merge(k as usize, g as usize, collapse.t as f32);
                }
                report.collapses += 1;
                report.max_collapse_error = report.max_collapse_error.max(collapse.distance);
                for w in working.neighbours(collapse.keep) {
                    enqueue(working, queue, collapse.keep, w);
                }
                if report.collapses.is_multiple_of(PROGRESS_EVERY) {
                    ctx.check_cancelled()?;
                    let removed = (start_faces - working.live_faces) as u64;
                    ctx.report("simplify", removed, Some(to_remove));
                }
            }
        }
    }
    ctx.report("simplify", to_remove, Some(to_remove));
    Ok(())
}

/// Queues the collapse of the edge `a`–`b`, when one of its vertices may merge.
fn enqueue(working: &Working, queue: &mut CollapseQueue, a: u32, b: u32) {
    if let Some(entry) = planned(working, a, b) {
        queue.push(entry);
    }
}

/// The queue's entry for the collapse of the edge `a`–`b`; `None` when neither vertex
/// may merge.
fn planned(working: &Working, a: u32, b: u32) -> Option<Queued> {
    let collapse = working.plan(a, b)?;
    let versions = [
        working.versions[collapse.keep as usize],
        working.versions[collapse.gone as usize],
    ];
    Some(Queued {
        cost: collapse.cost,
        keep: collapse.keep,
        gone: collapse.gone,
        versions,
    })
}
