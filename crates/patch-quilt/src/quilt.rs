//! The synthesis loop (paper 000 §4, steps 1–8).

use std::time::Instant;

use distance_field::{GridSpec, SdfGrid};
use glam::{Vec2, Vec3};
use mls_surface::{MlsSurface, RelaxParams, nearest_neighbour_spread, relax};
use pointset_core::{Aabb, Attribute, BucketGrid, KdIndex, PointSet, RunContext, ScalarType, rng};
use rand::RngExt;

use crate::blend::{BlendCounts, GapLimits, KeptFootprint, Overlap, blend};
use crate::error::{QuiltError, Result, invalid};
use crate::exemplar::{
    Exemplar, ExemplarFrame, PatchGeometry, texture_field, texture_mls_params, to_base_units,
};
use crate::params::{Method, QuiltParams};
use crate::search::{OverlapNode, candidates, distances};
use crate::texture::GeometryTexture;
use crate::warp::{Neighbourhood, PairTargets, SourceAttributes, WarpCounts, warp_patch};

/// Where one patch went and how it was chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    /// Patch index `k`.
    pub index: usize,
    /// Column and row in the scan-line layout.
    pub cell: (usize, usize),
    /// Lower-left corner `(x_k, y_k)` of the patch in the output (canonical frame).
    pub origin: Vec2,
    /// Chosen patch: node offsets `(i, j)` in `D(T_in)`.
    pub source: (usize, usize),
    /// `|Ψ_k|`.
    pub candidates: usize,
    /// `d` of the chosen patch (0 for the seed patch and random placement), its
    /// distances in units of the exemplar box ([`BASE_SIDE`](crate::BASE_SIDE)).
    pub distance: f32,
    /// What the warp did.
    pub warp: WarpCounts,
    /// What blending did.
    pub blend: BlendCounts,
}

/// Run statistics (Table 1 style timings are in the [`RunContext`]: `search`, `warp`,
/// `blend`, `other`).
#[derive(Debug, Clone, PartialEq)]
pub struct QuiltStats {
    /// Patches placed.
    pub patches: usize,
    /// Mean `|Ψ_k|` over searched patches.
    pub mean_candidates: f64,
    /// Mean pairs per warp over warped patches.
    pub mean_pairs: f64,
    /// Patches left unwarped.
    pub warps_skipped: usize,
    /// Patches whose targets `Q` were clustered more coarsely than
    /// [`QuiltParams::clusters`] asks, to keep the spline within its size limit (dense
    /// exemplars only; [`WarpCounts::coarsenings`](crate::WarpCounts::coarsenings)).
    pub warps_coarsened: usize,
    /// Patches whose first warp stretched too far and that were warped with a second fit,
    /// more of the free corners' columns pinned
    /// ([`WarpCounts::restrained`](crate::WarpCounts::restrained)).
    pub warps_restrained: usize,
    /// `D(T_in)` dimensions.
    pub field_dims: [usize; 3],
    /// Bytes held by `D(T_in)` (the patches' fields are read from it, not unpacked).
    pub field_bytes: usize,
    /// Patch geometry in field nodes.
    pub geometry: PatchGeometry,
    /// Input points.
    pub input_points: usize,
    /// Output points.
    pub output_points: usize,
    /// Spread of nearest-neighbour distances before/after relaxation (when it ran).
    pub relaxation_spread: Option<(f32, f32)>,
}

/// The result of [`quilt`].
#[derive(Debug, Clone)]
pub struct QuiltOutput {
    /// The synthesized texture, in world coordinates, with normals and a `patch` attribute
    /// (index of the patch each point came from).
    pub points: PointSet,
    /// The output box (world coordinates).
    pub bounds: Aabb,
    /// Every placement, in synthesis order.
    pub placements: Vec<Placement>,
    /// Counts and sizes.
    pub stats: QuiltStats,
}

impl QuiltOutput {
    /// Every patch's source (node offsets in `D(T_in)`), in synthesis order: the layout
    /// [`QuiltParams::layout`] takes to repeat this run's choices under another method.
    pub fn sources(&self) -> Vec<(usize, usize)> {
        self.placements.iter().map(|p| p.source).collect()
    }
}

/// A point of `T_out`: normal and the patch it came from.
type OutPoint = (Vec3, u32);

struct Layout {
    start: Vec2,
    step: f32,
    cols: usize,
    rows: usize,
    out_lo: Vec2,
    out_hi: Vec2,
}

impl Layout {
    /// The scan-line layout covering an output of `size` (from
    /// [`GeometryTexture::checked_output_extent`]).
    fn new(frame: &ExemplarFrame, size: Vec2) -> Self {
        let g = frame.geometry;
        let lo = frame.bounds.min.truncate();
        let start = lo - Vec2::splat(g.extra());
        let step = g.patch() - g.overlap();
        let count =
            |span: f32| ((span + g.extra() - g.patch()) / step).ceil().max(0.0) as usize + 1;
        // Cover [start, lo + size + w_E]: the trim removes w_E on every side.
        Self {
            start,
            step,
            cols: count(size.x + g.extra()),
            rows: count(size.y + g.extra()),
            out_lo: lo,
            out_hi: lo + size,
        }
    }

    fn origin(&self, col: usize, row: usize) -> Vec2 {
        self.start + Vec2::new(col as f32, row as f32) * self.step
    }
}

fn vec4_field(sdf: &SdfGrid) -> &[glam::Vec4] {
    sdf.grid().data()
}

/// `D(O^{N_k})`: the neighbourhood surface's distance and gradient at the nodes of the
/// overlap strips only (paper 000 §5.1: "the fields are computed only inside the
/// overlapping regions"). One field per strip, both written into a patch-sized array
/// (`(patch_nodes + 1)² × nz` nodes from `corner`, x fastest) that the search reads at the
/// overlap nodes; where the strips meet, the bottom strip's values are kept. The other
/// nodes stay zero and are never read. Distances are in `length_unit`s, as in
/// [`Exemplar::search_field`].
fn overlap_field(
    surface: &MlsSurface,
    overlap: &Overlap,
    g: &PatchGeometry,
    corner: Vec3,
    nz: usize,
    band: f32,
    length_unit: f32,
) -> Result<Vec<glam::Vec4>> {
    let side = g.patch_nodes + 1;
    let strip = g.overlap_nodes + 1;
    let mut field = vec![glam::Vec4::ZERO; side * side * nz];
    let strips = [
        (overlap.left, [strip, side, nz]),
        (overlap.bottom, [side, strip, nz]),
    ];
    for (_, dims) in strips.into_iter().filter(|(present, _)| *present) {
        let spec = GridSpec {
            dims,
            origin: corner,
            spacing: g.spacing,
        };
        let sdf = texture_field(surface, &spec, band)?;
        let data = vec4_field(&sdf);
        for c in 0..nz {
            for b in 0..dims[1] {
                let row = dims[0] * (b + dims[1] * c);
                let at = side * (b + side * c);
                field[at..at + dims[0]].copy_from_slice(&data[row..row + dims[0]]);
            }
        }
    }
    to_base_units(&mut field, length_unit);
    Ok(field)
}

/// Checks a given layout: one source per patch, each inside `[0, max_i] × [0, max_j]`.
fn check_layout(
    sources: &[(usize, usize)],
    patches: usize,
    (max_i, max_j): (usize, usize),
) -> Result<()> {
    if sources.len() != patches {
        return Err(invalid(
            "layout",
            format!("{} sources", sources.len()),
            format!("one source per patch of this run: {patches}"),
        ));
    }
    match sources
        .iter()
        .enumerate()
        .find(|(_, s)| s.0 > max_i || s.1 > max_j)
    {
        Some((k, s)) => Err(invalid(
            "layout",
            format!("({}, {}) for patch {k}", s.0, s.1),
            format!("node offsets up to ({max_i}, {max_j})"),
        )),
        None => Ok(()),
    }
}

/// The entries of `values` whose flag in `inside` is set, in order.
fn kept<T>(values: Vec<T>, inside: &[bool]) -> Vec<T> {
    values
        .into_iter()
        .zip(inside)
        .filter_map(|(v, &i)| i.then_some(v))
        .collect()
}

/// Runs the synthesis.
pub fn quilt(
    texture: &GeometryTexture,
    params: &QuiltParams,
    ctx: &mut RunContext,
) -> Result<QuiltOutput> {
    params.validate()?;
    let t0 = Instant::now();
    let ex = Exemplar::new(texture, params)?;
    let frame = &ex.frame;
    let g = frame.geometry;
    let layout = Layout::new(frame, texture.checked_output_extent(params.output)?);
    let mut pairing = params.pairing.clone().unwrap_or_default();
    if !pairing.max_distance.is_finite() {
        pairing.max_distance = params.pair_distance * g.spacing;
    }
    // Eq. 2's position term and Eq. 3's length term in base units (see `BASE_SIDE`).
    pairing.w_p /= frame.length_unit;
    pairing.w_l /= frame.length_unit;
    let mls = texture_mls_params().kernel(frame.surface.kernel());
    let [nx, _, nz] = frame.spec.dims;
    let total = layout.cols * layout.rows;
    if let Some(sources) = &params.layout {
        check_layout(sources, total, (frame.max_i, frame.max_j))?;
    }
    let mut out: BucketGrid<OutPoint> = BucketGrid::new(2.0 * g.spacing)?;
    let mut placements = Vec::with_capacity(total);
    ctx.record_timing("other", t0.elapsed());

    for row in 0..layout.rows {
        for col in 0..layout.cols {
            ctx.check_cancelled()?;
            let k = row * layout.cols + col;
            let mut rng = rng::stream(params.seed, k as u64);
            let origin = layout.origin(col, row);
            let overlap = Overlap {
                origin,
                width: g.overlap(),
                patch: g.patch(),
                left: col > 0,
                bottom: row > 0,
            };
            let far = origin + Vec2::splat(g.patch() + g.extra());
            let t = Instant::now();
            // N_k: T_out around B_k (B_k grown by w_E).
            let gather_lo = origin - Vec2::splat(g.extra());
            let gather_hi = far + Vec2::splat(g.extra());
            let gather = Aabb::new(
                gather_lo.extend(f32::MIN / 4.0),
                gather_hi.extend(f32::MAX / 4.0),
            );
            let keys = out.query_box(&gather);
            let mut n_points = Vec::with_capacity(keys.len());
            let mut n_normals = Vec::with_capacity(keys.len());
            for key in keys {
                if let Some((p, (n, _))) = out.get(key) {
                    n_points.push(p);
                    n_normals.push(*n);
                }
            }
            let first = k == 0 || n_points.len() < 8;
            let given = params.layout.as_ref().and_then(|l| l.get(k).copied());
            let needs_surface = !first
                && match params.method {
                    Method::Full => true,
                    Method::SearchOnly => given.is_none(),
                    Method::RandomPlacement => false,
                };
            let n_surface = if needs_surface {
                let set = PointSet::new(n_points.clone())?.with_normals(n_normals.clone())?;
                Some(MlsSurface::new(&set, &mls)?)
            } else {
                None
            };
            ctx.record_timing("other", t.elapsed());

            // Steps 2–3: choose the patch.
            let t = Instant::now();
            let (source, count, distance) = match (given, &n_surface, params.seed_patch) {
                (Some(source), _, _) => (source, 1, 0.0),
                (None, None, Some(seed)) if k == 0 => {
                    ((seed.0.min(frame.max_i), seed.1.min(frame.max_j)), 1, 0.0)
                }
                (None, None, _) => (
                    (
                        rng.random_range(0..=frame.max_i),
                        rng.random_range(0..=frame.max_j),
                    ),
                    1,
                    0.0,
                ),
                (None, Some(surface), _) => {
                    let local_field = overlap_field(
                        surface,
                        &overlap,
                        &g,
                        origin.extend(frame.spec.origin.z),
                        nz,
                        params.band * g.spacing,
                        frame.length_unit,
                    )?;
                    let side = g.patch_nodes + 1;
                    let mut nodes = Vec::new();
                    for c in 0..nz {
                        for b in 0..side {
                            for a in 0..side {
                                let in_left = overlap.left && a <= g.overlap_nodes;
                                let in_bottom = overlap.bottom && b <= g.overlap_nodes;
                                if in_left || in_bottom {
                                    nodes.push(OverlapNode {
                                        exemplar_offset: a + nx * (b + frame.spec.dims[1] * c),
                                        neighbourhood_index: a + side * (b + side * c),
                                    });
                                }
                            }
                        }
                    }
                    let d = distances(
                        &ex.search_field,
                        nx,
                        frame.max_i,
                        frame.max_j,
                        &nodes,
                        &local_field,
                    )?;
                    let psi = candidates(&d, params.epsilon);
                    if psi.is_empty() {
                        return Err(QuiltError::InvalidTexture {
                            reason: format!(
                                "no patch position has a finite distance to patch {k}'s \
                                 neighbourhood"
                            ),
                        });
                    }
                    let pick = psi[rng.random_range(0..psi.len())];
                    let width = frame.max_i + 1;
                    ((pick % width, pick / width), psi.len(), d[pick])
                }
            };
            ctx.record_timing("search", t.elapsed());

            // Step 3: F_k = tr(P ∪ E), extended by w_E / 2 for the warp.
            let t = Instant::now();
            let src_origin = frame.patch_origin(source.0, source.1);
            let margin = if n_surface.is_some() && params.method == Method::Full {
                0.5 * g.extra()
            } else {
                0.0
            };
            let span = g.patch() + g.extra();
            let idx = frame.points_in(
                src_origin - Vec2::splat(margin),
                src_origin + Vec2::splat(span + margin),
            );
            let shift = (origin - src_origin).extend(0.0);
            let mut f_points: Vec<Vec3> = idx.iter().map(|&i| frame.points[i] + shift).collect();
            let mut f_normals: Vec<Vec3> = idx.iter().map(|&i| frame.normals[i]).collect();
            let f_variation: Vec<f32> = idx.iter().map(|&i| ex.variation[i]).collect();
            let f_foot: Option<Vec<f32>> = ex
                .foot_offset
                .as_ref()
                .map(|feet| idx.iter().map(|&i| feet[i]).collect());
            ctx.record_timing("other", t.elapsed());

            // Steps 4–5.
            let mut warp = WarpCounts {
                skipped: true,
                ..WarpCounts::default()
            };
            let mut blended = BlendCounts::default();
            if let (Some(surface), Method::Full) = (&n_surface, params.method) {
                let t = Instant::now();
                let reach = params.blend_reach * surface.support_radius();
                let keep = KeptFootprint::new((origin, far), reach);
                let neighbourhood = Neighbourhood {
                    points: &n_points,
                    normals: &n_normals,
                    surface,
                };
                warp = warp_patch(
                    &mut f_points,
                    &mut f_normals,
                    &SourceAttributes {
                        variation: &f_variation,
                        targets: match &f_foot {
                            Some(foot_offset) => PairTargets::SurfaceGap {
                                foot_offset,
                                normal_agreement: params.normal_agreement,
                            },
                            None => PairTargets::Exact,
                        },
                    },
                    &neighbourhood,
                    &overlap,
                    &keep,
                    g.extra(),
                    &params.clusters,
                    &pairing,
                    params.anchors_per_corner,
                    f64::from(params.smoothing * g.patch()),
                );
                ctx.record_timing("warp", t.elapsed());
                let t = Instant::now();
                blended = blend(
                    &mut f_points,
                    &mut f_normals,
                    &overlap,
                    &keep,
                    surface,
                    GapLimits {
                        distance: reach,
                        normal_agreement: params.normal_agreement,
                    },
                );
                ctx.record_timing("blend", t.elapsed());
            }

            // Step 6: replace T_out inside B_k.
            let t = Instant::now();
            let b_k = Aabb::new(origin.extend(f32::MIN / 4.0), far.extend(f32::MAX / 4.0));
            out.remove_inside_box(&b_k);
            for (p, n) in f_points.iter().zip(&f_normals) {
                if b_k.contains(*p) {
                    out.insert(*p, (*n, k as u32))?;
                }
            }
            ctx.record_timing("other", t.elapsed());
            placements.push(Placement {
                index: k,
                cell: (col, row),
                origin,
                source,
                candidates: count,
                distance,
                warp,
                blend: blended,
            });
            ctx.report("quilt", (k + 1) as u64, Some(total as u64));
        }
    }

    // Step 8: relax (the paper's optional post-process), then trim w_E along the border to
    // the requested output box. The box's height is the exemplar's, widened by the overlap
    // width: warps may move geometry that far; anything beyond is trimmed too. Relaxing
    // before the trim gives the border's points neighbours on every side; relaxed after
    // it, they were pushed out of the box by neighbours on one side only.
    let t = Instant::now();
    let zlo = frame.bounds.min.z - g.overlap();
    let zhi = frame.bounds.max.z + g.overlap();
    let in_height = |p: Vec3| p.z >= zlo && p.z <= zhi;
    let in_box = |p: Vec3| {
        let q = p.truncate();
        in_height(p) && q.cmpge(layout.out_lo).all() && q.cmple(layout.out_hi).all()
    };
    let (mut pts, mut nrm, mut patch) = (Vec::new(), Vec::new(), Vec::new());
    for (_, p, (n, id)) in out.iter() {
        if in_height(p) {
            pts.push(p);
            nrm.push(*n);
            patch.push(*id as f32);
        }
    }
    let mut relaxation_spread = None;
    if params.relaxation_rounds > 0 && !pts.is_empty() {
        let set = PointSet::new(pts.clone())?.with_normals(nrm.clone())?;
        let surface = MlsSurface::new(&set, &mls)?;
        let relaxed = relax(
            &surface,
            &pts,
            &RelaxParams::default().iterations(params.relaxation_rounds),
        )?;
        // The spreads are the output's: measured inside the box, before and after.
        let in_output =
            |v: &[Vec3]| -> Vec<Vec3> { v.iter().copied().filter(|&p| in_box(p)).collect() };
        let before = nearest_neighbour_spread(&in_output(&pts))?;
        let after = nearest_neighbour_spread(&in_output(&relaxed.positions))?;
        relaxation_spread = Some((before, after));
        pts = relaxed.positions;
        nrm = relaxed.normals;
    }
    let inside: Vec<bool> = pts.iter().map(|&p| in_box(p)).collect();
    let (pts, nrm, patch) = (kept(pts, &inside), kept(nrm, &inside), kept(patch, &inside));
    if pts.is_empty() {
        // The texture holds points inside its box (checked when it was made), and every
        // placement copies a patch of it: an empty output is a box between the samples.
        let size = layout.out_hi - layout.out_lo;
        let spacing = KdIndex::new(texture.canonical_points().positions())?.median_spacing()?;
        return Err(invalid(
            "output",
            format!("{} x {}", size.x, size.y),
            format!(
                "a box that holds samples: this one caught none (the exemplar's samples are \
                 about {spacing} apart)"
            ),
        ));
    }
    let up = texture.up();
    let world_p: Vec<Vec3> = pts.iter().map(|&p| up.to_world(p)).collect();
    let world_n: Vec<Vec3> = nrm.iter().map(|&n| up.to_world(n)).collect();
    let points = PointSet::new(world_p)?
        .with_normals(world_n)?
        .with_attribute(Attribute::new("patch", patch).with_storage(ScalarType::I32))?;
    let lo = layout.out_lo.extend(zlo);
    let hi = layout.out_hi.extend(zhi);
    let bounds = Aabb::new(up.to_world(lo), up.to_world(hi));
    ctx.record_timing("other", t.elapsed());

    let searched: Vec<&Placement> = placements
        .iter()
        .filter(|p| p.distance > 0.0 || p.candidates > 1)
        .collect();
    let warped: Vec<&Placement> = placements.iter().filter(|p| !p.warp.skipped).collect();
    let mean = |v: &[f64]| {
        if v.is_empty() {
            0.0
        } else {
            v.iter().sum::<f64>() / v.len() as f64
        }
    };
    let stats = QuiltStats {
        patches: placements.len(),
        mean_candidates: mean(
            &searched
                .iter()
                .map(|p| p.candidates as f64)
                .collect::<Vec<_>>(),
        ),
        mean_pairs: mean(
            &warped
                .iter()
                .map(|p| p.warp.pairs as f64)
                .collect::<Vec<_>>(),
        ),
        warps_skipped: placements
            .iter()
            .filter(|p| p.index > 0 && p.warp.skipped)
            .count(),
        warps_coarsened: placements.iter().filter(|p| p.warp.coarsenings > 0).count(),
        warps_restrained: placements.iter().filter(|p| p.warp.restrained).count(),
        field_dims: frame.spec.dims,
        field_bytes: ex.field_bytes(),
        geometry: g,
        input_points: frame.points.len(),
        output_points: points.len(),
        relaxation_spread,
    };
    Ok(QuiltOutput {
        points,
        bounds,
        placements,
        stats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_surfaces::wave;

    /// The strips' fields agree with the whole patch grid's at every overlap node.
    #[test]
    fn the_overlap_field_matches_the_whole_patch_grid_at_the_overlap_nodes() {
        let (points, normals): (Vec<Vec3>, Vec<Vec3>) = (0..80 * 80)
            .map(|i| wave((i % 80) as f32 * 0.025, (i / 80) as f32 * 0.025))
            .unzip();
        let set = PointSet::new(points)
            .and_then(|s| s.with_normals(normals))
            .unwrap();
        let surface = MlsSurface::new(&set, &texture_mls_params()).unwrap();
        let g = PatchGeometry {
            spacing: 0.1,
            patch_nodes: 12,
            overlap_nodes: 3,
            extra_nodes: 4,
        };
        let (corner, nz, band) = (Vec3::new(0.3, 0.2, -0.3), 7, 0.25);
        let side = g.patch_nodes + 1;
        let whole = texture_field(
            &surface,
            &GridSpec {
                dims: [side, side, nz],
                origin: corner,
                spacing: g.spacing,
            },
            band,
        )
        .unwrap();
        for (left, bottom) in [(true, false), (false, true), (true, true)] {
            let overlap = Overlap {
                origin: corner.truncate(),
                width: g.overlap(),
                patch: g.patch(),
                left,
                bottom,
            };
            let field = overlap_field(&surface, &overlap, &g, corner, nz, band, 1.0).unwrap();
            let mut compared = 0;
            for c in 0..nz {
                for b in 0..side {
                    for a in 0..side {
                        let in_left = left && a <= g.overlap_nodes;
                        let in_bottom = bottom && b <= g.overlap_nodes;
                        let i = a + side * (b + side * c);
                        if in_left || in_bottom {
                            assert_eq!(field[i], vec4_field(&whole)[i], "node ({a}, {b}, {c})");
                            compared += 1;
                        } else {
                            assert_eq!(field[i], glam::Vec4::ZERO, "node ({a}, {b}, {c})");
                        }
                    }
                }
            }
            assert!(compared >= 4 * side * nz, "{compared} overlap nodes");
        }
    }
}
