//! Precomputation on `T_in`: its distance field `D(T_in)`, surface variation, point bins.

use distance_field::{FarSigns, GridSpec, SdfGrid};
use glam::{Vec2, Vec3, Vec4};
use mls_surface::{MlsParams, MlsSurface, surface_variation};
use pointset_core::{Aabb, BucketGrid, Surface};

use crate::error::{QuiltError, Result};
use crate::params::{FIELD_RESOLUTIONS, Method, QuiltParams, WarpTargets};
use crate::texture::GeometryTexture;
use crate::warp::foot_offsets;

/// Patch geometry in field nodes: patch `np`, overlap `no`, extra region `ne`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PatchGeometry {
    /// Field spacing `s`.
    pub spacing: f32,
    /// Patch side in nodes (the patch spans `np · s`).
    pub patch_nodes: usize,
    /// Overlap width in nodes.
    pub overlap_nodes: usize,
    /// Extra region width in nodes.
    pub extra_nodes: usize,
}

impl PatchGeometry {
    /// Patch side `P`.
    pub fn patch(&self) -> f32 {
        self.patch_nodes as f32 * self.spacing
    }
    /// Overlap width `W_O`.
    pub fn overlap(&self) -> f32 {
        self.overlap_nodes as f32 * self.spacing
    }
    /// Extra width `w_E`.
    pub fn extra(&self) -> f32 {
        self.extra_nodes as f32 * self.spacing
    }
}

/// The exemplar box side (the longer in-plane one) that the search metric and the pairing
/// weights are calibrated for: the side of the demo fixtures on which the defaults and
/// the paper's Table 1 weights were measured (the paper's examples all have "about the
/// same base dimensions", §6).
///
/// The search's `d` and Eq. 2–3 add lengths to unitless terms (gradients, normals,
/// surface variation, directions), so without a fixed base their balance would depend on
/// the units of the file: the same exemplar in millimetres and in metres would quilt
/// differently. Lengths in those three formulas are therefore measured in units of the
/// longer box side / `BASE_SIDE`; every other length of a run is already a fraction of
/// the box, the field spacing or the MLS kernel.
pub const BASE_SIDE: f32 = 4.0;

/// MLS parameters of every surface over a geometry texture's points: the defaults, with a
/// query out of the kernel's reach signed by its nearest sample's plane alone
/// (`fallback_sign_samples` 1), the rule every quality number in
/// docs/patch-quilt-studies.md was measured with. Like [`texture_field`]'s far signs, the
/// textures keep it.
pub(crate) fn texture_mls_params() -> MlsParams {
    MlsParams::default().fallback_sign_samples(1)
}

/// The distance field of a geometry texture's surface over `spec` (the exemplar's `D(T_in)`,
/// the on-the-fly `D(O^N_k)`, the quality measure's fields): far nodes signed by
/// [`FarSigns::RegionVote`]. Geometry textures are open sheets, with no inside that a hole
/// in the band could flip, and a few wrong-signed nodes at a petal's rim cannot sign
/// anything with the region vote. It was the only rule until the nineteenth session, and
/// every quality number in docs/patch-quilt-studies.md was measured with it.
pub(crate) fn texture_field(
    surface: &(impl Surface + ?Sized),
    spec: &GridSpec,
    band: f32,
) -> distance_field::Result<SdfGrid> {
    SdfGrid::from_surface_with(surface, spec, band, FarSigns::RegionVote)
}

/// Divides the distance channel of `values` (distance, gradient) by `unit`, in place: a
/// field as the search compares it.
pub(crate) fn to_base_units(values: &mut [Vec4], unit: f32) {
    for v in values {
        v.x /= unit;
    }
}

/// The exemplar's samples, surface and field lattice: what a run and the quality measure
/// both need.
pub(crate) struct ExemplarFrame {
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    bins: BucketGrid<u32>,
    /// Longer in-plane box side / [`BASE_SIDE`]: the unit of length of the search metric
    /// and of Eq. 2–3.
    pub length_unit: f32,
    /// The lattice of `D(T_in)`.
    pub spec: GridSpec,
    /// The exemplar's MLS surface (its kernel is used for every other surface of the run).
    pub surface: MlsSurface,
    pub bounds: Aabb,
    pub geometry: PatchGeometry,
    /// Valid patch offsets (in nodes): `0..=max_i`, `0..=max_j`.
    pub max_i: usize,
    pub max_j: usize,
}

/// Everything a run precomputes on the exemplar: its frame, plus the surface variation,
/// `D(T_in)` and (for surface-gap warps) foot offsets that the search and the warp read.
pub(crate) struct Exemplar {
    pub frame: ExemplarFrame,
    pub variation: Vec<f32>,
    /// Signed offset along each sample's normal from the sample to its foot point on
    /// the frame's surface (0 where it cannot be projected): the warp's
    /// [`WarpTargets::SurfaceGap`] measures gaps from the foot points. `Some` only for a
    /// full run with that warp, the one reader.
    pub foot_offset: Option<Vec<f32>>,
    /// `D(T_in)` as the search compares it: distance (in [`ExemplarFrame::length_unit`]s)
    /// and gradient at the nodes of [`ExemplarFrame::spec`].
    pub search_field: Vec<Vec4>,
}

impl Exemplar {
    /// Everything a run with `params` needs, foot offsets included when its warp reads them.
    pub fn new(texture: &GeometryTexture, params: &QuiltParams) -> Result<Self> {
        let frame = ExemplarFrame::new(texture, params)?;
        let variation = surface_variation(frame.surface.index(), 12)?;
        let feet = params.method == Method::Full && params.warp_targets == WarpTargets::SurfaceGap;
        let foot_offset = feet.then(|| foot_offsets(&frame.surface, &frame.points, &frame.normals));
        let field = texture_field(
            &frame.surface,
            &frame.spec,
            params.band * frame.geometry.spacing,
        )?;
        let mut search_field = field.grid().data().to_vec();
        to_base_units(&mut search_field, frame.length_unit);
        Ok(Self {
            frame,
            variation,
            foot_offset,
            search_field,
        })
    }

    /// Memory held by `D(T_in)` in bytes.
    pub fn field_bytes(&self) -> usize {
        std::mem::size_of_val(self.search_field.as_slice())
    }
}

/// Fewest field spacings a patch may span. The overlap is at most half a patch, so from 3
/// on every placement advances by at least 2 spacings. At 2 the advance is 1 spacing,
/// equal to the overlap: each patch keeps only the corner of its box that no later patch
/// covers, one spacing square, and the output thins out (measured on the bumpy fixture:
/// 3,015 points instead of about 21,600, holes 34 times the exemplar's largest).
pub const MIN_PATCH_SPACINGS: usize = 3;

/// Most nodes `D(T_in)` may have (2 GiB of distance + gradient samples): a bound on boxes
/// far taller than wide, which would otherwise ask for absurd grids.
pub const MAX_FIELD_NODES: usize = 1 << 27;

/// The error for a patch under [`MIN_PATCH_SPACINGS`] field spacings (`spacings`), with
/// the remedies that reach the minimum: the smallest `patch_size` at this resolution, the
/// smallest `field_resolution` for this patch, each named only where it is in range (a box
/// far longer than wide may need a patch wider than the box at 48 nodes); failing both, the
/// smallest `patch_size` at the finest field, and failing that a squarer box. `aspect` is
/// the box's shorter side over its longer.
fn too_narrow_patch(params: &QuiltParams, aspect: f32, spacings: f32) -> QuiltError {
    // Patches round to whole spacings: the minimum is reached from `MIN − ½` on.
    let needed = MIN_PATCH_SPACINGS as f32 - 0.5;
    let resolution = params.field_resolution;
    let mut remedies = Vec::new();
    let smallest_patch = needed / (aspect * (resolution - 1) as f32);
    if smallest_patch <= 1.0 {
        remedies.push(format!(
            "patch_size ≥ {smallest_patch:.3} at field_resolution {resolution}"
        ));
    }
    let smallest_resolution = (needed / (params.patch_size * aspect)).ceil() + 1.0;
    if smallest_resolution <= *FIELD_RESOLUTIONS.end() as f32 {
        remedies.push(format!(
            "field_resolution ≥ {smallest_resolution} for this patch_size"
        ));
    }
    if remedies.is_empty() {
        let finest = *FIELD_RESOLUTIONS.end();
        let at_finest = needed / (aspect * (finest - 1) as f32);
        remedies.push(if at_finest <= 1.0 {
            format!("patch_size ≥ {at_finest:.3} with field_resolution {finest}")
        } else {
            format!(
                "a squarer box: this one's shorter side is {} of its longer, and a patch as \
                 wide as the box spans {MIN_PATCH_SPACINGS} spacings even at field_resolution \
                 {finest} only from {} on",
                significant(aspect),
                significant(needed / (finest - 1) as f32)
            )
        });
    }
    QuiltError::InvalidParameter {
        name: "patch_size",
        value: params.patch_size.to_string(),
        expected: format!(
            "a patch at least {MIN_PATCH_SPACINGS} field spacings wide (this one is {}): {}",
            significant(spacings),
            remedies.join(", or ")
        ),
    }
}

/// `x` to a tenth, or with two significant digits below a tenth (`1.9e-3`, not `0.0`)
/// and from a million up (`4.0e29`, not thirty digits).
fn significant(x: f32) -> String {
    if x == 0.0 || (0.1..1e6).contains(&x.abs()) {
        format!("{x:.1}")
    } else {
        format!("{x:.1e}")
    }
}

/// The error for geometry (its box `all`) that spans less than a patch and its extra
/// region `E` from the low corner of the exemplar box `bounds` (canonical frame), with the
/// lengths, and the remedy: a box inside the points where it reaches past them, else a
/// smaller patch or extra region.
fn short_of_extra_region(geometry: &PatchGeometry, bounds: Aabb, all: Aabb) -> QuiltError {
    let need = geometry.patch() + geometry.extra();
    let span = all.max.truncate() - bounds.min.truncate();
    let remedy = if bounds.max.x > all.max.x || bounds.max.y > all.max.y {
        let (box_extent, points_extent) = (bounds.extent(), all.extent());
        format!(
            "the box ({} × {}) reaches past the points ({} × {}): give a box inside them",
            significant(box_extent.x),
            significant(box_extent.y),
            significant(points_extent.x),
            significant(points_extent.y)
        )
    } else {
        "a smaller patch_size or extra_width would fit".to_string()
    };
    QuiltError::InvalidTexture {
        reason: format!(
            "the geometry spans {} along x and {} along y (the reference plane's axes) from \
             the box's low corner, less than a patch with its extra region needs ({}: the \
             patch {} and w_E {}); {remedy}",
            significant(span.x),
            significant(span.y),
            significant(need),
            significant(geometry.patch()),
            significant(geometry.extra())
        ),
    }
}

impl ExemplarFrame {
    /// The frame of `texture` for `params` (its field resolution and patch proportions).
    /// Errors: no normals, a surface that cannot be built, a patch larger than the box, or
    /// padding too narrow for the extra region.
    pub fn new(texture: &GeometryTexture, params: &QuiltParams) -> Result<Self> {
        let set = texture.canonical_points();
        let points = set.positions().to_vec();
        let normals =
            set.normals()
                .map(<[Vec3]>::to_vec)
                .ok_or_else(|| QuiltError::InvalidTexture {
                    reason: "no normals".into(),
                })?;
        let bounds = texture.canonical_bounds();
        let surface = MlsSurface::new(set, &texture_mls_params())?;
        let ext = bounds.extent();
        let spacing = ext.x.max(ext.y) / (params.field_resolution - 1) as f32;
        let layers = (ext.z / spacing).ceil();
        let plane = ((ext.x / spacing).floor() + 1.0) * ((ext.y / spacing).floor() + 1.0);
        let nodes = plane * (layers + 1.0);
        if nodes.is_nan() || nodes > MAX_FIELD_NODES as f32 {
            return Err(QuiltError::InvalidTexture {
                reason: format!(
                    "the box is {layers} field spacings tall: its distance field would need \
                     more than {MAX_FIELD_NODES} nodes (check the box's height against its \
                     width, or lower field_resolution)"
                ),
            });
        }
        let dims = [
            (ext.x / spacing).floor() as usize + 1,
            (ext.y / spacing).floor() as usize + 1,
            layers as usize + 1,
        ];
        let spec = GridSpec {
            dims,
            origin: bounds.min,
            spacing,
        };
        let length_unit = ext.x.max(ext.y) / BASE_SIDE;
        let patch_spacings = params.patch_size * ext.x.min(ext.y) / spacing;
        let patch_nodes = patch_spacings.round() as usize;
        if patch_nodes < MIN_PATCH_SPACINGS {
            return Err(too_narrow_patch(
                params,
                ext.x.min(ext.y) / ext.x.max(ext.y),
                patch_spacings,
            ));
        }
        let overlap_nodes =
            ((params.overlap * patch_nodes as f32).round() as usize).clamp(1, patch_nodes / 2);
        let extra_nodes = ((params.extra_width * patch_nodes as f32).round() as usize).max(1);
        let geometry = PatchGeometry {
            spacing,
            patch_nodes,
            overlap_nodes,
            extra_nodes,
        };
        // P ∪ E must lie inside the geometry: the patch inside the field, E inside the padding.
        let all = Aabb::from_points(&points).unwrap_or(bounds);
        let limit = |origin: f32, nodes: usize, far: f32| -> usize {
            (0..nodes)
                .take_while(|&i| {
                    origin + (i + patch_nodes + extra_nodes) as f32 * spacing
                        <= far + 1e-6 * spacing
                })
                .last()
                .unwrap_or(0)
        };
        if patch_nodes + 1 > dims[0].min(dims[1]) {
            return Err(QuiltError::InvalidParameter {
                name: "patch_size",
                value: params.patch_size.to_string(),
                expected: format!(
                    "a patch smaller than the exemplar box: the patch spans {} field nodes, the \
                     box's shorter side {} (raise field_resolution, or use a squarer box)",
                    patch_nodes + 1,
                    dims[0].min(dims[1])
                ),
            });
        }
        let max_i = limit(spec.origin.x, dims[0] - patch_nodes, all.max.x);
        let max_j = limit(spec.origin.y, dims[1] - patch_nodes, all.max.y);
        let fits = |origin: f32, far: f32| {
            origin + (patch_nodes + extra_nodes) as f32 * spacing <= far + 1e-6 * spacing
        };
        if !fits(spec.origin.x, all.max.x) || !fits(spec.origin.y, all.max.y) {
            return Err(short_of_extra_region(&geometry, bounds, all));
        }
        let cell = (2.0 * spacing).max(f32::MIN_POSITIVE);
        let mut bins = BucketGrid::new(cell)?;
        for (i, p) in points.iter().enumerate() {
            bins.insert(*p, i as u32)?;
        }
        Ok(Self {
            points,
            normals,
            bins,
            length_unit,
            spec,
            surface,
            bounds,
            geometry,
            max_i,
            max_j,
        })
    }

    /// Indices of points whose (x, y) lies in `[lo, hi]`, ascending.
    pub fn points_in(&self, lo: Vec2, hi: Vec2) -> Vec<usize> {
        let region = Aabb::new(lo.extend(f32::MIN / 4.0), hi.extend(f32::MAX / 4.0));
        let mut out: Vec<usize> = self
            .bins
            .query_box(&region)
            .into_iter()
            .filter_map(|k| self.bins.get(k).map(|(_, &i)| i as usize))
            .collect();
        out.sort_unstable();
        out
    }

    /// World (canonical) position of the patch offset `(i, j)`'s lower-left corner.
    pub fn patch_origin(&self, i: usize, j: usize) -> Vec2 {
        self.spec.origin.truncate() + Vec2::new(i as f32, j as f32) * self.geometry.spacing
    }
}
