//! Whether a `geosynth voxel` run fits in the memory this machine has available, checked
//! before each half of the run: before the synthesis from the sample counts, and before
//! the reconstructions from the counts the synthesized field fixes (copied triangles and
//! surface cells, counted without building anything). Without the checks, a large target
//! (up to 512³ samples are allowed) ran for minutes and was then killed while copying
//! triangles: balls from a 32³ source to a 128³ target already copy 7.2 million of them.
//!
//! The peak resident memory is modelled as the largest of three phases' needs (extracting
//! the iso-surface; copying the triangles and writing them; writing the iso-surface, with
//! `--isosurface`), each a sum of terms, fitted to `--report`'s peak over 66 runs (five
//! solids, the torus, the bunny, the teapot and fertility; sources 32 to 128, targets 64 to
//! 256; each with and without `--isosurface`; see `docs/performance.md`, "Memory of
//! `geosynth voxel`"), weighted by the square root of the peak, since the check decides
//! only large runs. Model / measured peak: 0.92 to 1.05 over the 13 runs above 500 MB, 0.67
//! to 1.69 over all (the misses are runs below 140 MB). A term the fit left at zero is
//! carried by another phase's term, not absent from the run.

use geosynth::voxel::{
    SynthesizedField, VoxelExemplar, VoxelSynth, copied_triangle_count, isosurface_cells,
    source_dims,
};

use crate::CliResult;
use crate::memory::{available_bytes, resident_bytes};

/// Fitted bytes that do not depend on the sizes.
const BASE_BYTES: f64 = 18.0e6;
/// Fitted bytes per source sample (the signed distance grid, its quantized copy and the
/// matcher's tables).
const BYTES_PER_SOURCE_SAMPLE: f64 = 257.5;

/// What one phase of the run holds beyond the fixed part, in fitted bytes per unit.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Phase {
    /// Bytes per target sample.
    per_target_sample: f64,
    /// Bytes per surface cell (about 6 iso-surface triangles each).
    per_surface_cell: f64,
    /// Bytes per copied triangle.
    per_copied_triangle: f64,
}

/// Extracting the iso-surface: the field and its owners, the distances, their padded copy.
const EXTRACTING_ISOSURFACE: Phase = Phase {
    per_target_sample: 0.0,
    per_surface_cell: 356.6,
    per_copied_triangle: 0.0,
};

/// Copying, welding and relaxing the triangles beside the finished iso-surface, and
/// writing the copied mesh (streamed from the mesh's own arrays).
const COPYING: Phase = Phase {
    per_target_sample: 21.6,
    per_surface_cell: 0.0,
    per_copied_triangle: 66.5,
};

/// Writing the iso-surface (`--isosurface`) beside the copied mesh.
const WRITING_ISOSURFACE: Phase = Phase {
    per_target_sample: 2.9,
    per_surface_cell: 303.2,
    per_copied_triangle: 11.3,
};

impl Phase {
    /// The phase's bytes for `sizes`.
    fn bytes(&self, sizes: &RunSizes) -> f64 {
        sizes.target_samples as f64 * self.per_target_sample
            + sizes.surface_cells as f64 * self.per_surface_cell
            + sizes.copied_triangles as f64 * self.per_copied_triangle
    }
}

/// The sizes the memory of a run depends on.
#[derive(Debug, Clone, Copy, PartialEq)]
struct RunSizes {
    /// Samples of the source field.
    source_samples: usize,
    /// Samples of the target field.
    target_samples: usize,
    /// Source triangles the copied-triangle mesh copies (0 before the synthesis).
    copied_triangles: usize,
    /// Cells of the target grid that cross the zero set (0 before the synthesis).
    surface_cells: usize,
    /// Whether the iso-surface is written too.
    isosurface_written: bool,
}

impl RunSizes {
    /// The modelled peak resident memory of the run, in bytes.
    fn peak_bytes(&self) -> f64 {
        self.fixed_bytes() + self.scaled_bytes()
    }

    /// The part of [`RunSizes::peak_bytes`] that does not depend on the target.
    fn fixed_bytes(&self) -> f64 {
        BASE_BYTES + self.source_samples as f64 * BYTES_PER_SOURCE_SAMPLE
    }

    /// The part of [`RunSizes::peak_bytes`] that grows with the target: the largest of
    /// the phases' needs.
    fn scaled_bytes(&self) -> f64 {
        let written = if self.isosurface_written {
            WRITING_ISOSURFACE.bytes(self)
        } else {
            0.0
        };
        EXTRACTING_ISOSURFACE
            .bytes(self)
            .max(COPYING.bytes(self))
            .max(written)
    }
}

/// The share of the exemplar's mean triangles per source sample that the upfront check
/// takes every target sample to copy. Measured shares (the model's 33 settings): 0.15 to
/// 2.3, 0.4 to 0.6 on the five solids; the smallest is the bunny, mostly empty space,
/// copied into a cube four times its height. A tenth stays below all of them, so the
/// check refuses only runs that would not fit even then.
const LEAST_COPY_SHARE: f64 = 0.1;

/// The share the upfront note takes instead: the low end of what the five solids copy
/// (0.4 to 0.6). A run that would not fit even at this share is most likely refused after
/// its synthesis, and the note says so before the synthesis starts.
const TYPICAL_COPY_SHARE: f64 = 0.4;

/// Refuses a run that would not fit even on its most favourable showing, before anything
/// runs: the fields, and a tenth ([`LEAST_COPY_SHARE`]) of the triangles a target of
/// source-like density would copy. It catches the hopeless runs (a 512³ source beside a
/// 512³ target: the source field alone needs 35 GB); the rest wait for the counted check
/// after the synthesis (balls from a 16³ source to a 512³ target pass this estimate, 20 GB,
/// and are refused after two to three minutes of synthesis at 4.2 billion copied
/// triangles; the note of [`TYPICAL_COPY_SHARE`] warns of it before the synthesis).
/// `isosurface_written`: whether `--isosurface` is written too.
///
/// A run that passes but would not fit at the share solids typically copy
/// ([`TYPICAL_COPY_SHARE`]) gets a note to show before the synthesis: it will most likely
/// be refused once its triangles are counted.
pub fn check_synthesis_fits(
    stage: &VoxelSynth,
    exemplar: &VoxelExemplar,
    isosurface_written: bool,
) -> CliResult<Option<String>> {
    let Some(memory) = machine_memory() else {
        return Ok(None);
    };
    let source = source_dims(exemplar, stage.source_resolution)?;
    let target = stage.params.target_dims;
    let at_least = upfront_sizes(
        exemplar,
        source,
        target,
        isosurface_written,
        LEAST_COPY_SHARE,
    );
    let what = format!(
        "synthesizing a target of {} samples from a source of {} (at least about {} copied \
         triangles)",
        dims_text(target),
        dims_text(source),
        at_least.copied_triangles
    );
    check_fits(&at_least, Copies::AtLeast, stage, memory, &what)?;
    let typical = upfront_sizes(
        exemplar,
        source,
        target,
        isosurface_written,
        TYPICAL_COPY_SHARE,
    );
    Ok(likely_refused(&typical, stage, memory))
}

/// The note for a run whose `typical` sizes would not fit: what it would then need, and
/// that the counted check after the synthesis will most likely refuse it.
fn likely_refused(typical: &RunSizes, stage: &VoxelSynth, memory: (u64, u64)) -> Option<String> {
    let (needed, advice) = shortfall(typical, Copies::AtLeast, stage, memory)?;
    Some(format!(
        "note: copying as solids typically do (about {} triangles), this run would need \
         about {:.1} GB, more than the {:.1} GB available: it will most likely be refused \
         once the synthesis has counted its triangles ({advice})",
        typical.copied_triangles,
        needed / 1e9,
        memory.0 as f64 / 1e9
    ))
}

/// The sizes [`check_synthesis_fits`] checks: the fields', and `share` of the copied
/// triangles at the exemplar's mean density (the triangles whose centroids lie in the
/// exemplar's box, over the source samples).
fn upfront_sizes(
    exemplar: &VoxelExemplar,
    source: [usize; 3],
    target: [usize; 3],
    isosurface_written: bool,
    share: f64,
) -> RunSizes {
    let [source_samples, target_samples] = [source, target].map(|d| d.iter().product::<usize>());
    let positions = exemplar.mesh.positions();
    let in_box = exemplar
        .mesh
        .triangles()
        .iter()
        .filter(|t| {
            let corners = t.map(|v| positions[v as usize]);
            exemplar
                .bounds
                .contains((corners[0] + corners[1] + corners[2]) / 3.0)
        })
        .count();
    let copied = share * in_box as f64 * target_samples as f64 / source_samples.max(1) as f64;
    RunSizes {
        source_samples,
        target_samples,
        copied_triangles: copied as usize,
        surface_cells: 0,
        isosurface_written,
    }
}

/// Refuses to build the meshes from `field` when they would not fit; `kept` says where
/// the synthesized field was written, if it was, for the message.
pub fn check_reconstruction_fits(
    stage: &VoxelSynth,
    exemplar: &VoxelExemplar,
    field: &SynthesizedField,
    isosurface_written: bool,
    kept: Option<&std::path::Path>,
) -> CliResult {
    let Some(memory) = machine_memory() else {
        return Ok(());
    };
    let synthesis = &field.synthesis;
    let copied_triangles = copied_triangle_count(&exemplar.mesh, synthesis);
    let surface_cells = isosurface_cells(synthesis, true);
    let sizes = RunSizes {
        source_samples: synthesis.source_dims.iter().product(),
        target_samples: synthesis.field.values().len(),
        copied_triangles,
        surface_cells,
        isosurface_written,
    };
    let what = format!(
        "building the meshes of a target of {} samples ({copied_triangles} copied triangles, \
         {surface_cells} surface cells)",
        dims_text(synthesis.field.dims())
    );
    check_fits(&sizes, Copies::Counted, stage, memory, &what).map_err(|e| match kept {
        Some(path) => format!("{e}; the synthesized field is in {}", path.display()).into(),
        None => e,
    })
}

/// What the machine offers this process: `(available, resident)` bytes, where `resident`
/// is what the process holds already (part of the modelled peak, and no longer in
/// `available`). `None` where the platform does not tell.
fn machine_memory() -> Option<(u64, u64)> {
    Some((available_bytes()?, resident_bytes()?))
}

/// Where the copied triangles of [`RunSizes`] come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Copies {
    /// Estimated before the run, on the low side ([`LEAST_COPY_SHARE`]): a smaller target
    /// can still be too large.
    AtLeast,
    /// Counted after the synthesis.
    Counted,
}

/// Refuses `sizes` when their modelled peak, less what the process already holds, exceeds
/// what is available, naming the target dimensions that would (or, before the run, at
/// most could) fit.
fn check_fits(
    sizes: &RunSizes,
    copies: Copies,
    stage: &VoxelSynth,
    memory: (u64, u64),
    what: &str,
) -> CliResult {
    match shortfall(sizes, copies, stage, memory) {
        None => Ok(()),
        Some((needed, advice)) => Err(format!(
            "{what} needs about {:.1} GB, more than the {:.1} GB this machine has available; \
             {advice}",
            needed / 1e9,
            memory.0 as f64 / 1e9
        )
        .into()),
    }
}

/// When `sizes` would not fit in `(available, resident)` bytes: the bytes they need beyond
/// what the process holds, and which target dimensions would (or could) fit.
fn shortfall(
    sizes: &RunSizes,
    copies: Copies,
    stage: &VoxelSynth,
    (available, resident): (u64, u64),
) -> Option<(f64, String)> {
    let needed = (sizes.peak_bytes() - resident as f64).max(0.0);
    if needed <= available as f64 {
        return None;
    }
    let advice = match fitting_target(sizes, stage, available as f64 + resident as f64) {
        Some([x, y, z]) if copies == Copies::Counted => format!("--target-dims {x},{y},{z} fits"),
        Some([x, y, z]) => format!("at most --target-dims {x},{y},{z} could fit"),
        None => "no target fits beside this source; a lower --source-res needs less".into(),
    };
    Some((needed, advice))
}

/// `x × y × z`.
fn dims_text([x, y, z]: [usize; 3]) -> String {
    format!("{x} × {y} × {z}")
}

/// The largest target, the asked one scaled alike along every axis in steps of half a
/// block, whose modelled peak fits in `budget` bytes with a twentieth spare. Everything
/// that grows with the target is taken to grow with its sample count (surface cells grow
/// more slowly, so this errs small). `None` when not even the smallest block fits.
fn fitting_target(sizes: &RunSizes, stage: &VoxelSynth, budget: f64) -> Option<[usize; 3]> {
    let share = (0.95 * budget - sizes.fixed_bytes()) / sizes.scaled_bytes();
    if share.is_nan() || share <= 0.0 {
        return None;
    }
    let block = stage.params.block;
    let step = (block / 2).max(1);
    let scale = share.cbrt();
    let dims = stage
        .params
        .target_dims
        .map(|d| (d as f64 * scale / step as f64).floor() as usize * step);
    dims.iter().all(|&d| d >= block).then_some(dims)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]

    use super::*;
    use geosynth::RunContext;
    use geosynth::voxel::VoxelParams;

    fn stage(dims: [usize; 3]) -> VoxelSynth {
        VoxelSynth {
            params: VoxelParams::default().target_dims(dims),
            ..VoxelSynth::default()
        }
    }

    /// Balls from a 32³ source to a 128³ target, with `--isosurface`: 7.2 M copied
    /// triangles, 0.96 M surface cells, 0.60 GB measured peak.
    const BALLS: RunSizes = RunSizes {
        source_samples: 32 * 32 * 32,
        target_samples: 128 * 128 * 128,
        copied_triangles: 7_176_153,
        surface_cells: 960_200,
        isosurface_written: true,
    };

    #[test]
    fn the_model_is_near_a_measured_peak() {
        let ratio = BALLS.peak_bytes() / 0.597e9;
        assert!((0.9..1.2).contains(&ratio), "{ratio}");
    }

    #[test]
    fn a_run_that_does_not_fit_is_refused_with_a_target_that_does() {
        let stage = stage([128; 3]);
        assert!(
            check_fits(
                &BALLS,
                Copies::Counted,
                &stage,
                (2_000_000_000, 0),
                "copying"
            )
            .is_ok()
        );
        // What the process already holds is part of the peak.
        assert!(
            check_fits(
                &BALLS,
                Copies::Counted,
                &stage,
                (500_000_000, 600_000_000),
                "copying"
            )
            .is_ok()
        );
        let message = check_fits(&BALLS, Copies::Counted, &stage, (400_000_000, 0), "copying")
            .unwrap_err()
            .to_string();
        assert!(
            message.starts_with("copying needs about 0.5 GB, more than the 0.4 GB"),
            "{message}"
        );
        let dims: Vec<usize> = message
            .rsplit_once("--target-dims ")
            .and_then(|(_, d)| d.strip_suffix(" fits"))
            .unwrap()
            .split(',')
            .map(|d| d.parse().unwrap())
            .collect();
        // Whole half blocks, and the run they describe fits.
        assert!(dims.iter().all(|d| d % 8 == 0 && *d < 128), "{dims:?}");
        // Everything that grows with the target scaled by its share of the samples.
        let scaled_to = |dims: [usize; 3]| {
            let share = dims.iter().product::<usize>() as f64 / BALLS.target_samples as f64;
            let grown = |n: usize| (n as f64 * share) as usize;
            RunSizes {
                target_samples: grown(BALLS.target_samples),
                copied_triangles: grown(BALLS.copied_triangles),
                surface_cells: grown(BALLS.surface_cells),
                ..BALLS
            }
            .peak_bytes()
        };
        let dims = [dims[0], dims[1], dims[2]];
        assert!(scaled_to(dims) <= 0.95 * 400_000_000.0, "{dims:?}");
        // A step of half a block more along every axis would not.
        assert!(
            scaled_to(dims.map(|d| d + 8)) > 0.95 * 400_000_000.0,
            "{dims:?}"
        );
        // Before the run, the copy is a lower estimate.
        let message = check_fits(&BALLS, Copies::AtLeast, &stage, (400_000_000, 0), "copying")
            .unwrap_err()
            .to_string();
        assert!(
            message.ends_with("at most --target-dims 112,112,112 could fit"),
            "{message}"
        );
        // Nothing fits beside a source that takes the memory by itself.
        let message = check_fits(&BALLS, Copies::Counted, &stage, (10_000_000, 0), "copying")
            .unwrap_err()
            .to_string();
        assert!(message.contains("no target fits"), "{message}");
    }

    #[test]
    fn a_run_likely_too_large_gets_a_note_before_its_synthesis() {
        let stage = stage([128; 3]);
        // The balls' count, taken as what a typical share predicts.
        assert_eq!(likely_refused(&BALLS, &stage, (2_000_000_000, 0)), None);
        let note = likely_refused(&BALLS, &stage, (400_000_000, 0)).unwrap();
        assert!(
            note.starts_with("note: copying as solids typically do (about 7176153 triangles)"),
            "{note}"
        );
        assert!(
            note.contains("about 0.5 GB, more than the 0.4 GB available"),
            "{note}"
        );
        assert!(
            note.ends_with("(at most --target-dims 112,112,112 could fit)"),
            "{note}"
        );
    }

    #[test]
    fn the_upfront_estimate_stays_below_what_runs_copy() {
        // A lower estimate, and not a vacuous one (here 7–9% of the count).
        for volume in geosynth::fixtures::volumes::all(3).unwrap() {
            let exemplar = VoxelExemplar::from(&volume);
            let stage = VoxelSynth {
                source_resolution: 24,
                params: VoxelParams::default()
                    .target_dims([32, 32, 16])
                    .levels(2)
                    .block(8),
                ..VoxelSynth::default()
            };
            let source = source_dims(&exemplar, 24).unwrap();
            let dims = stage.params.target_dims;
            let upfront = upfront_sizes(&exemplar, source, dims, true, LEAST_COPY_SHARE);
            let typical = upfront_sizes(&exemplar, source, dims, true, TYPICAL_COPY_SHARE);
            let field = stage
                .synthesize_field(&exemplar, &mut RunContext::new(0))
                .unwrap();
            let copied = copied_triangle_count(&exemplar.mesh, &field.synthesis);
            assert!(
                copied / 20 < upfront.copied_triangles && upfront.copied_triangles < copied,
                "{}: {} vs {copied}",
                volume.name,
                upfront.copied_triangles
            );
            // The note's share stays below what these runs copy too.
            assert!(
                typical.copied_triangles < copied,
                "{}: {} vs {copied}",
                volume.name,
                typical.copied_triangles
            );
        }
    }
}
