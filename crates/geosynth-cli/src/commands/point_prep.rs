//! How `reconstruct` and `sdf` prepare a point set before its MLS surface is built: stray
//! and isolated points left out (unless `--keep-strays`), and the normals as read,
//! oriented (`--orient-normals`) or estimated (`--estimate-normals`), turned toward `--up`.

use std::path::Path;
use std::time::Duration;

use clap::Args;
use geosynth::core::{KdIndex, PointSet};
use geosynth::mls::{
    IsolatedFate, IsolatedPoints, MlsParams, ORIENTING_STAGE, fit_oriented_normals_with,
    orient_normals_with,
};
use geosynth::strays::{LeaveOutStrays, StraysFound};

use super::normals::{UpArg, parse_neighbours, undefined_note};
use super::three_digits;
use super::unoriented_normals_note;
use crate::output::{progress_context, spinner, status};
use crate::{CliResult, Globals};

/// A point set prepared for its MLS surface ([`PointPrep::prepared`]).
pub struct PreparedPoints {
    /// The points kept, with their normals as prepared.
    pub points: PointSet,
    /// What was left out of the points read.
    pub left_out: LeftOut,
    /// An index of the kept points' positions.
    pub index: KdIndex,
}

/// The flags that prepare a point set.
#[derive(Debug, Args)]
pub struct PointPrepArgs {
    /// Make the normal signs consistent by propagation from the side facing `--up` first
    /// (for normals estimated without orientation); unreliable on interlinked thin tubes
    /// (docs/mls-surface.md).
    #[arg(long, conflicts_with = "estimate_normals")]
    orient_normals: bool,
    /// Estimate the points' normals first, as `geosynth normals` does: fitted to each
    /// point's K nearest neighbours (`--estimate-normals` alone: 12) and oriented by
    /// propagation toward `--up`; for bare scans (XYZ files of positions), and replacing
    /// any normals the points have.
    #[arg(
        long,
        value_name = "K",
        num_args = 0..=1,
        default_missing_value = "12",
        value_parser = parse_neighbours
    )]
    estimate_normals: Option<usize>,
    /// With `--orient-normals` or `--estimate-normals`: each connected part's highest
    /// point along this axis gets the normal facing it, and the signs spread from there
    /// (a closed object comes out facing outward whichever; an open scan faces this way).
    #[arg(long, value_enum)]
    up: Option<UpArg>,
    /// Keep the points that lie far outside the rest, or alone (by default left out, with
    /// a note: a point beyond twice the span of the middle 99% of the points' coordinates
    /// on some axis, such as a scan's outlier, stretches the grid until the surface is a
    /// speck in it; a point with fewer than 3 others within twice the MLS kernel's reach,
    /// such as a stray point inside a hollow scan, closes into a bubble of its own).
    #[arg(long)]
    keep_strays: bool,
}

/// What is done to a point set before use: the flags over a recorded run's.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PointPrep {
    /// Orient the normals the points have.
    pub orient: bool,
    /// Estimate them anew, fitted to this many nearest neighbours (and oriented).
    pub estimate: Option<usize>,
    /// Where orienting turns them.
    pub up: UpArg,
    /// Keep the stray points ([`geosynth::core::strays::kept_indices`]).
    pub keep_strays: bool,
}

impl PointPrepArgs {
    /// The flags given over `recorded` (a `--params` report's): an estimate given or
    /// recorded wins over orienting (estimated normals come oriented). `--up` alone, with
    /// nothing to turn, is refused.
    pub fn over(&self, recorded: PointPrep) -> CliResult<PointPrep> {
        let estimate = self.estimate_normals.or(recorded.estimate);
        let orient = (self.orient_normals || recorded.orient) && estimate.is_none();
        if self.up.is_some() && !orient && estimate.is_none() {
            let unused = "--up turns normals that --orient-normals or --estimate-normals \
                          orients; without either the points' own normals are used as read";
            return Err(unused.into());
        }
        Ok(PointPrep {
            orient,
            estimate,
            up: self.up.unwrap_or(recorded.up),
            keep_strays: self.keep_strays || recorded.keep_strays,
        })
    }
}

/// Refuses a recorded neighbour count below 3 (as a message naming the option).
pub fn check_recorded_neighbours(estimate_normals: Option<usize>) -> Result<(), String> {
    match estimate_normals {
        Some(k) => parse_neighbours(&k.to_string())
            .map(|_| ())
            .map_err(|e| format!("estimate_normals: {e}")),
        None => Ok(()),
    }
}

impl PointPrep {
    /// Refuses to orient or estimate the normals of the mesh read from `path`: a mesh's
    /// sides come from its faces.
    pub fn refuse_for_mesh(&self, path: &Path) -> CliResult {
        let flag = if self.estimate.is_some() {
            "--estimate-normals estimates"
        } else if self.orient {
            "--orient-normals orients"
        } else {
            return Ok(());
        };
        Err(format!(
            "{} is a mesh: {flag} a point set's normals, and a mesh's sides come from its \
             faces (--orient-faces turns them to agree)",
            path.display()
        )
        .into())
    }

    /// `points` (read from `path`) without their stray and isolated points unless kept
    /// (isolated for an MLS surface of the `kernel` given, or estimated), with their
    /// normals estimated or oriented as asked, each stage's time added to `timings`, and
    /// refused when their MLS surface could still not use them; prints the notes about
    /// them. Returns the points, what was left out and an index of the points' positions.
    pub fn prepared(
        &self,
        points: PointSet,
        kernel: Option<f32>,
        path: &Path,
        globals: Globals,
        timings: &mut Vec<(String, Duration)>,
    ) -> CliResult<PreparedPoints> {
        let leave_out = LeaveOutStrays {
            kernel,
            keep: self.keep_strays,
        };
        // Seconds on millions of points, before any stage shows a bar.
        let bar = spinner(globals, "looking for stray and isolated points");
        // The index the isolated points were looked for with serves the estimation or
        // orientation of the normals, the check of their orientation and the caller's
        // notes: only the normals change.
        let found = leave_out.run_indexed(points);
        bar.finish_and_clear();
        let (found, index) = found?;
        let left_out = self.noted(&found, path, globals);
        let mut points = found.points;
        if let Some(neighbours) = self.estimate {
            points = estimated(&index, points, neighbours, self.up, globals, timings)?;
        }
        check_usable(&points, path)?;
        if self.orient {
            let (mut ctx, bar) = progress_context(globals, 0, "orienting normals", false);
            let up = self.up.vector();
            points = ctx.timed(ORIENTING_STAGE, |ctx| {
                orient_normals_with(&index, &points, up, ctx)
            })?;
            bar.finish_and_clear();
            timings.extend_from_slice(ctx.timings());
        }
        // Normals estimated here come oriented; the note would suggest --orient-normals.
        if self.estimate.is_none()
            && let Some(note) = unoriented_normals_note(&points, None, Some(&index))
        {
            status(globals, note);
        }
        Ok(PreparedPoints {
            points,
            left_out,
            index,
        })
    }

    /// Notes what [`LeaveOutStrays`] found in the points read from `path`, and returns what
    /// it left out.
    fn noted(&self, found: &StraysFound, path: &Path, globals: Globals) -> LeftOut {
        let what = path.display().to_string();
        if found.strays > 0 {
            status(globals, self.stray_note(found.strays, &what));
        }
        if let Some(isolated) = &found.isolated {
            let min_neighbours = MlsParams::default().min_neighbours;
            let note = isolated_note(isolated, &what, min_neighbours, Some("--kernel"));
            status(globals, note);
        }
        LeftOut {
            strays: if self.keep_strays { 0 } else { found.strays },
            isolated: found
                .isolated
                .filter(|i| i.fate == IsolatedFate::LeftOut)
                .map_or(0, |i| i.count),
        }
    }

    /// The note on `strays` stray points of `what` (a file's name), left out or kept.
    fn stray_note(&self, strays: usize, what: &str) -> String {
        let (count, one) = counted(strays);
        let (verb, pronoun) = if one { ("lies", "it") } else { ("lie", "them") };
        let found = format!(
            "note: {count} of {what} {verb} far outside the rest (beyond twice the span of the \
             middle 99% of the points' coordinates)"
        );
        let done = if self.keep_strays {
            format!("; kept (--keep-strays), the grid spans {pronoun}")
        } else {
            format!(
                ": left out, since the grid would span {pronoun}; --keep-strays keeps {pronoun}"
            )
        };
        format!("{found}{done}")
    }
}

/// What was done with the `isolated` points of `what` (a file's name) for an MLS surface
/// whose kernel needs `min_neighbours` samples, as a note; `kernel_flag` names the option
/// that widens the kernel, if the command has one.
pub(crate) fn isolated_note(
    isolated: &IsolatedPoints,
    what: &str,
    min_neighbours: usize,
    kernel_flag: Option<&str>,
) -> String {
    let (count, one) = counted(isolated.count);
    let (verb, pronoun) = if one { ("has", "it") } else { ("have", "them") };
    let found = format!(
        "note: {count} of {what} {verb} fewer than {} others within {} (twice the MLS kernel's \
         reach), so the surface about {pronoun} would be a bubble of {} own",
        min_neighbours - 1,
        three_digits(isolated.reach),
        if one { "its" } else { "their" }
    );
    let share = 100.0 * isolated.count as f64 / isolated.of as f64;
    let wider = kernel_flag.map_or(String::new(), |flag| {
        format!(" (a larger {flag} widens it)")
    });
    let done = match isolated.fate {
        IsolatedFate::Kept => "; kept (--keep-strays)".to_string(),
        IsolatedFate::SparseSampling => format!(
            "; kept, since they are {share:.1}% of the points: the kernel is too small for \
             their sampling{wider}"
        ),
        IsolatedFate::LeftOut if share > 1.0 => {
            let sparse = kernel_flag.map_or(String::new(), |flag| {
                format!(
                    "; if they sample a part more sparsely than the rest rather than \
                     outliers, a larger {flag} reaches them"
                )
            });
            format!(": left out ({share:.1}% of the points{sparse}); --keep-strays keeps {pronoun}")
        }
        IsolatedFate::LeftOut => format!(": left out; --keep-strays keeps {pronoun}"),
    };
    format!("{found}{done}")
}

/// `count` points as a note says them ("1 point", "3 points"), and whether there is one.
fn counted(count: usize) -> (String, bool) {
    match count {
        1 => ("1 point".to_string(), true),
        n => (format!("{n} points"), false),
    }
}

/// What [`PointPrep::prepared`] left out of a point set.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LeftOut {
    /// Stray points ([`geosynth::core::strays::kept_indices`]).
    pub strays: usize,
    /// Isolated points ([`geosynth::mls::isolated_samples`]).
    pub isolated: usize,
}

/// `points` with normals fitted to `neighbours` nearest and oriented toward `up`, as
/// `geosynth normals` estimates them (the stages' times added to `timings`); notes the
/// points whose neighbourhoods define none.
fn estimated(
    index: &KdIndex,
    points: PointSet,
    neighbours: usize,
    up: UpArg,
    globals: Globals,
    timings: &mut Vec<(String, Duration)>,
) -> CliResult<PointSet> {
    let (mut ctx, bar) = progress_context(globals, 0, "estimating normals", true);
    let count = points.len();
    // As the `EstimateNormals` stage does, with the index already built.
    let fit = fit_oriented_normals_with(index, points, neighbours, up.vector(), &mut ctx)?;
    bar.finish_and_clear();
    timings.extend_from_slice(ctx.timings());
    if let Some(note) = undefined_note(
        fit.undefined.len(),
        count,
        neighbours.min(count),
        "--estimate-normals K",
    ) {
        status(globals, note);
    }
    Ok(fit.points)
}

/// Refuses a point set read from `path` whose normals its MLS surface cannot use: none at
/// all, or some without a direction ([`PointSet::directionless_normals`]: zero normals a
/// tool wrote where it computed none), naming `--estimate-normals` as the remedy.
fn check_usable(points: &PointSet, path: &Path) -> CliResult {
    if points.normals().is_none() {
        return Err(format!(
            "{}: the points have no normals, and their MLS surface needs oriented points \
             (--estimate-normals estimates and orients them)",
            path.display()
        )
        .into());
    }
    match points.directionless_normals() {
        0 => Ok(()),
        zero => Err(format!(
            "{}: {zero} of the {} normals are zero (unset by the tool that wrote them), and \
             the MLS surface needs a direction at every point (--estimate-normals estimates \
             them all anew)",
            path.display(),
            points.len()
        )
        .into()),
    }
}
