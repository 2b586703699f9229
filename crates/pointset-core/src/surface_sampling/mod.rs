//! Points sampled on a mesh's surface: an oriented point set from a triangle mesh, for the
//! algorithms that work on point-set surfaces (MLS, quilting) and for meshes whose vertices
//! are too few or too uneven to stand for their surface; and a point set's own points,
//! thinned to a Poisson disk or at random ([`thin_points`], module `point_thinning`), for
//! scans far denser than those algorithms need.
//!
//! Two samplings of a mesh ([`SurfaceSampling`]):
//!
//! - **Uniform**: `count` independent samples, each on a triangle chosen with probability
//!   proportional to its area, at a point uniform over that triangle (barycentric
//!   coordinates `(1 − √r₁, √r₁(1 − r₂), √r₁ r₂)` for `r₁, r₂` uniform in `[0, 1)`). The
//!   samples are unbiased and clump like any random draw.
//! - **Poisson disk**: no two samples closer than `spacing` (straight-line distance), and
//!   almost no point of the surface farther than `spacing` from a sample. Candidates are
//!   drawn uniformly over the surface, [`POISSON_CANDIDATES_PER_AREA`] per `spacing²`,
//!   and each is kept when no sample kept before lies within `spacing` of it (dart
//!   throwing over a finite pool). They are drawn and tested tile by tile, in random
//!   order within a tile (cubes of 16 spacings: the kept samples a test reads are then in
//!   the cache), the tiles in eight phases of tiles a tile apart, each phase's tiles in
//!   parallel (module `tiles`); the result does not depend on the threads. A million
//!   samples took 42–49 s in one random order over the whole surface, 5.2–5.8 s tile by
//!   tile, and 3.1–3.4 s in phases on two threads (docs/performance.md). Measured on a
//!   square and on a wavy sheet (spacings 0.03 and 0.01, two seeds each, one random
//!   order): about `0.65 · area / spacing²` samples, 0.1% of the surface farther than
//!   `spacing` from every sample and none farther than 1.13 spacings; with 8 candidates
//!   per `spacing²` it was 0.59, 0.8% and 1.36 spacings. In phases of tiles, on the unit
//!   square at spacing 0.004 (three seeds): the same coverage and widest gap, 0.4% more
//!   samples, the same counts of neighbours at every distance up to 3 spacings (within
//!   1.5%), and 1.5% more samples within one spacing of a tile's side than elsewhere. The distance is taken through space, not along the
//!   surface, so two sheets closer than `spacing` (a thin wall) thin each other out.
//!
//! Normals ([`SampleNormals`]) are the sampled triangle's normal (right-hand rule), or the
//! mesh's vertex normals interpolated and normalized (the file's normals, or area-weighted
//! face normals when it has none). Every vertex attribute (colours, …) is interpolated by
//! the same barycentric weights and quantized to its storage type, and so are the mesh's
//! texture coordinates, into the attributes `s` and `t` ([`UV_CHANNELS`], unless the
//! vertices have attributes of those names). Triangles of zero area are never sampled.
//!
//! Deterministic: the samples depend on the mesh, the sampling and the run's seed only.
//!
//! ```
//! use glam::Vec3;
//! use pointset_core::{PointSet, RunContext, TriMesh};
//! use pointset_core::surface_sampling::{SampleNormals, SurfaceSampling, sample_surface};
//!
//! // A unit square of two triangles in the plane z = 0.
//! let corners = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
//! let square = TriMesh::new(PointSet::new(corners)?, vec![[0, 1, 2], [0, 2, 3]])?;
//! let sampling = SurfaceSampling::PoissonDisk { spacing: 0.05 };
//! let samples = sample_surface(&square, &sampling, SampleNormals::Faces, &mut RunContext::new(7))?;
//! let points = samples.points.positions();
//! assert!(points.len() > 200 && points.len() < 300); // about 0.65 / 0.05²
//! assert!(points.iter().all(|p| p.z == 0.0 && p.x >= 0.0 && p.y <= 1.0));
//! assert!(samples.points.normals().is_some_and(|n| n.iter().all(|n| *n == Vec3::Z)));
//! # Ok::<(), pointset_core::Error>(())
//! ```

use glam::Vec3;

mod disk_grid;
mod draws;
mod phased;
mod point_thinning;
mod tiles;

use crate::rng::rng_from_seed;
use crate::{Attribute, Error, NormalWeighting, PointSet, Result, RunContext, TriMesh};
use draws::{Draws, FaceChoice, Sample};
use phased::{Candidates, grid_low, keep_apart, spacing_too_small};
pub use point_thinning::{MAX_COUNT_PASSES, PointThinning, ThinnedPoints, thin_points};
use tiles::{TILE_SPACINGS, Tile, Tiles};

/// Most samples a [`SurfaceSampling::Uniform`] sampling may ask for (2²⁶, about 1.6 GB of
/// positions and normals).
pub const MAX_SURFACE_SAMPLES: usize = 1 << 26;

/// Candidates a [`SurfaceSampling::PoissonDisk`] sampling draws per `spacing²` of
/// surface: about fifty per sample kept, enough that under 0.5% of the surface is left
/// farther than `spacing` from every sample (tested; 0.1% measured, module docs).
pub const POISSON_CANDIDATES_PER_AREA: f64 = 32.0;

/// Most candidates a [`SurfaceSampling::PoissonDisk`] sampling may draw (2³⁰, for about
/// 20 million samples): a spacing that would need more is refused as too small for the
/// mesh.
pub const MAX_POISSON_CANDIDATES: u64 = 1 << 30;

/// Most samples [`SurfaceSampling::poisson_disk_for_count`] may aim for: the count
/// whose spacing draws [`MAX_POISSON_CANDIDATES`] candidates (about 21.8 million), less
/// a part in a million for the spacing's rounding.
pub const MAX_POISSON_SAMPLES: usize = (MAX_POISSON_CANDIDATES as f64 * POISSON_SAMPLES_PER_AREA
    / POISSON_CANDIDATES_PER_AREA
    * (1.0 - 1e-6)) as usize;

/// How many samples, and how they spread (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum SurfaceSampling {
    /// `count` independent samples, uniform by area (1 to [`MAX_SURFACE_SAMPLES`]).
    Uniform {
        /// How many samples.
        count: usize,
    },
    /// No two samples closer than `spacing` (positive, finite), the surface covered. A
    /// surface whose area draws no candidate (far below one `spacing²`) gets one sample,
    /// uniform by area.
    PoissonDisk {
        /// The least distance between two samples.
        spacing: f32,
    },
}

/// Poisson-disk samples per `spacing²` of surface, as measured (module docs): what
/// [`SurfaceSampling::poisson_disk_for_count`] aims by.
pub const POISSON_SAMPLES_PER_AREA: f64 = 0.65;

impl SurfaceSampling {
    /// A Poisson-disk sampling whose spacing gives about `count` samples on a surface of
    /// area `area` (within a few percent on smooth surfaces; a thin wall keeps fewer):
    /// `spacing = √(0.65 · area / count)`.
    ///
    /// Errors: a count of 0 or above [`MAX_POISSON_SAMPLES`], or an area that is not
    /// positive and finite.
    ///
    /// ```
    /// use pointset_core::surface_sampling::SurfaceSampling;
    /// let sampling = SurfaceSampling::poisson_disk_for_count(2.6, 10_000)?;
    /// assert_eq!(sampling, SurfaceSampling::PoissonDisk { spacing: 0.013 });
    /// # Ok::<(), pointset_core::Error>(())
    /// ```
    pub fn poisson_disk_for_count(area: f64, count: usize) -> Result<Self> {
        if count == 0 {
            return Err(Error::InvalidParameter {
                name: "count",
                value: "0".into(),
                expected: "at least 1 sample".into(),
            });
        }
        if count > MAX_POISSON_SAMPLES {
            return Err(Error::InvalidParameter {
                name: "count",
                value: count.to_string(),
                expected: format!(
                    "1 to {MAX_POISSON_SAMPLES} samples for a Poisson disk (about \
                     {:.0} candidates a sample, at most {MAX_POISSON_CANDIDATES})",
                    POISSON_CANDIDATES_PER_AREA / POISSON_SAMPLES_PER_AREA
                ),
            });
        }
        if !(area.is_finite() && area > 0.0) {
            return Err(Error::InvalidParameter {
                name: "area",
                value: area.to_string(),
                expected: "a positive finite area".into(),
            });
        }
        let spacing = (POISSON_SAMPLES_PER_AREA * area / count as f64).sqrt() as f32;
        Ok(SurfaceSampling::PoissonDisk { spacing })
    }
}

/// The attributes a mesh's texture coordinates are interpolated into (the names the PLY
/// writer gives a mesh's UVs; MeshLab reads them).
pub const UV_CHANNELS: [&str; 2] = ["s", "t"];

/// Where the samples' normals come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum SampleNormals {
    /// The normal of the triangle each sample lies on: the surface the mesh describes.
    #[default]
    Faces,
    /// The mesh's vertex normals (its own, or area-weighted face normals) interpolated
    /// across each triangle and normalized: smooth shading's normals. Where they cancel,
    /// the triangle's normal.
    Interpolated,
}

/// The samples of [`sample_surface`].
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceSamples {
    /// Positions, unit normals, the interpolated vertex attributes and texture coordinates.
    pub points: PointSet,
    /// The triangle each sample lies on.
    pub faces: Vec<u32>,
}

/// Samples the surface of `mesh` (module docs), seeded by `ctx`'s seed; reports progress
/// as "sample surface" and stops when cancelled.
///
/// Errors: a mesh without triangles or whose triangles all have zero area
/// ([`Error::EmptyInput`]); a count of 0 or above [`MAX_SURFACE_SAMPLES`], a spacing
/// that is not positive and finite, or one so small the mesh would need more than
/// [`MAX_POISSON_CANDIDATES`] candidates or more than 2²³ spacings along an axis
/// ([`Error::InvalidParameter`]); [`Error::Cancelled`].
pub fn sample_surface(
    mesh: &TriMesh,
    sampling: &SurfaceSampling,
    normals: SampleNormals,
    ctx: &mut RunContext,
) -> Result<SurfaceSamples> {
    let choice = FaceChoice::new(mesh)?;
    let chosen = match *sampling {
        SurfaceSampling::Uniform { count } => {
            let draws = Draws::new(mesh, &choice, rng_from_seed(ctx.seed()));
            uniform(draws, count, ctx)?
        }
        SurfaceSampling::PoissonDisk { spacing } => {
            let kept = poisson_disk(mesh, choice.area(), spacing, ctx)?;
            if kept.is_empty() {
                // No candidate was drawn: the surface's area is far below one spacing²
                // (`spacing` 1e30 on a torus gave an empty point set). One sample,
                // uniform by area, is the disk.
                vec![Draws::new(mesh, &choice, rng_from_seed(ctx.seed())).next_sample()]
            } else {
                kept
            }
        }
    };
    ctx.report(STAGE, chosen.len() as u64, Some(chosen.len() as u64));
    build_samples(mesh, &chosen, normals)
}

/// The progress stage's name.
const STAGE: &str = "sample surface";

/// Uniform samples drawn between progress reports and cancellation checks.
const REPORT_EVERY: u64 = 1 << 16;

/// `count` samples uniform by area.
fn uniform(mut draws: Draws<'_>, count: usize, ctx: &mut RunContext) -> Result<Vec<Sample>> {
    if !(1..=MAX_SURFACE_SAMPLES).contains(&count) {
        return Err(Error::InvalidParameter {
            name: "count",
            value: count.to_string(),
            expected: format!("1 to {MAX_SURFACE_SAMPLES} samples"),
        });
    }
    let mut chosen = Vec::with_capacity(count);
    for drawn in 0..count as u64 {
        if drawn % REPORT_EVERY == 0 {
            ctx.check_cancelled()?;
            ctx.report(STAGE, drawn, Some(count as u64));
        }
        chosen.push(draws.next_sample());
    }
    Ok(chosen)
}

/// A Poisson disk of `spacing` over `mesh` (of area `area`), by tiles.
fn poisson_disk(
    mesh: &TriMesh,
    area: f64,
    spacing: f32,
    ctx: &mut RunContext,
) -> Result<Vec<Sample>> {
    let invalid = |expected: String| Error::InvalidParameter {
        name: "spacing",
        value: spacing.to_string(),
        expected,
    };
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(invalid("a positive finite length".into()));
    }
    let too_small = || spacing_too_small(spacing, "the mesh's box");
    let spacing = f64::from(spacing);
    let candidates = (POISSON_CANDIDATES_PER_AREA * area / (spacing * spacing)).ceil();
    let least = (POISSON_CANDIDATES_PER_AREA * area / MAX_POISSON_CANDIDATES as f64).sqrt();
    if candidates > MAX_POISSON_CANDIDATES as f64 {
        return Err(invalid(format!(
            "at least {least:.3e} for a surface of area {area:.3e} (at most {MAX_POISSON_CANDIDATES} candidates)"
        )));
    }
    let low = grid_low(mesh.positions(), spacing);
    let tiles = Tiles::new(mesh, low, TILE_SPACINGS * spacing).ok_or_else(too_small)?;
    let candidates = MeshCandidates {
        mesh,
        tiles: &tiles,
        per_area: POISSON_CANDIDATES_PER_AREA / (spacing * spacing),
        seed: ctx.seed(),
    };
    keep_apart(&tiles, &candidates, low, spacing, STAGE, too_small, ctx)
}

/// Candidates drawn on a mesh's triangles, `per_area` per unit of area in each tile.
struct MeshCandidates<'a> {
    mesh: &'a TriMesh,
    tiles: &'a Tiles,
    per_area: f64,
    seed: u64,
}

impl Candidates for MeshCandidates<'_> {
    type Item = Sample;

    fn of_tile(&self, tile: &Tile<'_>) -> Vec<Sample> {
        self.tiles
            .candidates(self.mesh, tile, self.per_area, self.seed)
    }

    fn position(&self, item: &Sample) -> Vec3 {
        item.position
    }
}

/// A quantity given at `mesh`'s vertices, interpolated at each sample by its barycentric
/// weights.
fn interpolated<'a>(
    mesh: &'a TriMesh,
    chosen: &'a [Sample],
    at_vertex: impl Fn(usize) -> f64 + 'a,
) -> impl Iterator<Item = f64> + 'a {
    chosen.iter().map(move |s| {
        let corners = mesh.triangles()[s.face as usize];
        corners
            .iter()
            .zip(s.weights)
            .map(|(&v, w)| at_vertex(v as usize) * f64::from(w))
            .sum()
    })
}

/// The point set of the chosen samples: positions, normals and interpolated attributes.
fn build_samples(
    mesh: &TriMesh,
    chosen: &[Sample],
    normals: SampleNormals,
) -> Result<SurfaceSamples> {
    let triangles = mesh.triangles();
    let corners = |s: &Sample| triangles[s.face as usize].map(|v| v as usize);
    let vertices = mesh.positions();
    let positions = chosen.iter().map(|s| s.position).collect();
    let face_normal = |s: &Sample| {
        let [a, b, c] = corners(s).map(|v| vertices[v]);
        crate::triangle_normal(a, b, c)
    };
    let sample_normals = match normals {
        SampleNormals::Faces => chosen.iter().map(face_normal).collect(),
        SampleNormals::Interpolated => {
            let computed;
            let at_vertices = match mesh.vertices().normals() {
                Some(given) => given,
                None => {
                    computed = mesh.vertex_normals(NormalWeighting::Area);
                    &computed
                }
            };
            chosen
                .iter()
                .map(|s| {
                    let blended = corners(s)
                        .iter()
                        .zip(s.weights)
                        .map(|(&v, w)| at_vertices[v] * w)
                        .sum::<Vec3>();
                    let unit = crate::unit_vector(blended);
                    if unit == Vec3::ZERO {
                        face_normal(s)
                    } else {
                        unit
                    }
                })
                .collect()
        }
    };
    let mut points = PointSet::new(positions)?.with_normals(sample_normals)?;
    for attribute in mesh.vertices().attributes() {
        let (at_vertices, storage) = (attribute.values(), attribute.storage());
        let values = interpolated(mesh, chosen, |v| f64::from(at_vertices[v]))
            .map(|value| storage.quantize(value) as f32)
            .collect();
        points.set_attribute(Attribute::new(attribute.name(), values).with_storage(storage))?;
    }
    let uv_names_free = UV_CHANNELS.iter().all(|n| points.attribute(n).is_none());
    if let Some(uvs) = mesh.uvs().filter(|_| uv_names_free) {
        for (axis, name) in UV_CHANNELS.into_iter().enumerate() {
            let values = interpolated(mesh, chosen, |v| f64::from(uvs[v][axis]))
                .map(|value| value as f32)
                .collect();
            points.set_attribute(Attribute::new(name, values))?;
        }
    }
    Ok(SurfaceSamples {
        points,
        faces: chosen.iter().map(|s| s.face).collect(),
    })
}

#[cfg(test)]
mod tests;
