//! `geosynth warp`: apply a thin-plate spline given by explicit pairs.

use std::path::{Path, PathBuf};

use clap::Args;
use geosynth::core::io::WriteOptions;
use geosynth::tps::{ThinPlateSpline, TpsError, TpsParams};
use geosynth::warp::warp_geometry;
use glam::{DVec3, Vec3};
use serde_json::json;

use crate::input_file::read_geometry;
use crate::json_report::{timings_json, write_json_report};
use crate::output::{
    check_geometry_output, check_output_paths, report_not_kept, status, write_geometry_file,
};
use crate::phases::{self, READING, Timings, WRITING};
use crate::{CliError, CliResult, Globals};

/// Arguments of `geosynth warp`.
#[derive(Debug, Args)]
pub struct WarpArgs {
    /// Point set or mesh to warp (.ply, .obj, .off, .stl, .glb, .gltf, .xyz, .las, .pcd);
    /// meshes keep their faces.
    input: PathBuf,
    /// Pairs file: one pair per line, `sx sy sz qx qy qz` (source → target); `#` starts a
    /// comment.
    #[arg(long)]
    pairs: PathBuf,
    /// Output file (.ply, .obj, .off, .glb, .gltf; .stl for a mesh; .xyz, .xyzn, .xyzrgb,
    /// .las, .pcd for a point set): warped positions, transported normals when the input
    /// has normals, other attributes unchanged.
    #[arg(short, long)]
    output: PathBuf,
    /// Smoothing λ of the spline (0 = interpolate the pairs exactly).
    #[arg(long, default_value_t = 0.0)]
    smoothing: f64,
    /// Write a JSON report: the pairs, the spline's bending energy, how far it misses its
    /// targets and moves the points, how many points it folds, the timings.
    #[arg(long, value_name = "FILE")]
    report: Option<PathBuf>,
}

/// The pairs of a pairs file, with the line each came from.
#[derive(Debug)]
pub struct Pairs {
    /// Where each pair starts (the spline's control points), relative to the origin.
    pub from: Vec<Vec3>,
    /// Where each pair ends, relative to the origin.
    pub to: Vec<Vec3>,
    /// The 1-based line of each pair in the file.
    pub lines: Vec<usize>,
}

/// Parses a pairs file into sources and targets, naming the line of any error. The
/// coordinates are read in double precision and stored relative to `origin` (that of the
/// point set they warp, see [`geosynth::core::io::ReadOptions::recentre_far`]); a
/// coordinate that is not finite there, or that single precision cannot hold, is refused.
pub fn parse_pairs(text: &str, path: &Path, origin: DVec3) -> CliResult<Pairs> {
    let mut pairs = Pairs {
        from: Vec::new(),
        to: Vec::new(),
        lines: Vec::new(),
    };
    for (i, line) in text.lines().enumerate() {
        let at = format!("{}:{}", path.display(), i + 1);
        let content = line.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let values: Vec<f64> = content
            .split_whitespace()
            .map(|w| w.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("{at}: `{content}` is not six numbers"))?;
        let [sx, sy, sz, qx, qy, qz] = values[..] else {
            return Err(format!("{at}: expected 6 numbers, found {}", values.len()).into());
        };
        let from = (DVec3::new(sx, sy, sz) - origin).as_vec3();
        let to = (DVec3::new(qx, qy, qz) - origin).as_vec3();
        if !(from.is_finite() && to.is_finite()) {
            return Err(format!(
                "{at}: `{content}` has a coordinate that is not a finite single-precision \
                 number"
            )
            .into());
        }
        pairs.from.push(from);
        pairs.to.push(to);
        pairs.lines.push(i + 1);
    }
    if pairs.from.is_empty() {
        return Err(format!("{}: no pairs", path.display()).into());
    }
    Ok(pairs)
}

/// Fits the spline through `pairs`, naming the file, and the lines of the pairs a fit
/// refuses.
fn fit_spline(pairs: &Pairs, path: &Path, smoothing: f64) -> CliResult<ThinPlateSpline> {
    let params = TpsParams::default().smoothing(smoothing);
    ThinPlateSpline::fit(&pairs.from, &pairs.to, &params).map_err(|e| match e {
        TpsError::DuplicateControlPoints { first, second } => format!(
            "{}:{} and {}: both pairs start at one point but end at different points; no \
             warp can do that (remove one, or give them one target)",
            path.display(),
            pairs.lines.get(first).copied().unwrap_or(first + 1),
            pairs.lines.get(second).copied().unwrap_or(second + 1),
        )
        .into(),
        TpsError::InvalidParameter { .. } => e.to_string().into(),
        other => format!("{}: {other}", path.display()).into(),
    })
}

/// Runs `geosynth warp`.
pub fn run(args: &WarpArgs, globals: Globals) -> CliResult {
    check_output_paths([args.output.as_path()], args.report.as_deref())?;
    let mut timings = Timings::new();
    let (text, loaded) = phases::timed(&mut timings, READING, || -> CliResult<_> {
        let text = std::fs::read_to_string(&args.pairs)
            .map_err(|e| format!("cannot read {}: {e}", args.pairs.display()))?;
        // Georeferenced inputs are warped relative to an origin and written back there.
        Ok((text, read_geometry(&args.input, globals)?))
    })?;
    report_not_kept(globals, &args.input, &loaded.notes);
    check_geometry_output(
        &args.output,
        loaded.geometry.mesh().is_some(),
        loaded.origin,
    )?;
    let pairs = phases::timed(&mut timings, READING, || {
        parse_pairs(&text, &args.pairs, loaded.origin)
    })?;
    let spline = phases::timed(&mut timings, "fitting the spline", || {
        fit_spline(&pairs, &args.pairs, args.smoothing)
    })?;
    let (folded, before, out) = phases::timed(
        &mut timings,
        "warping and finding folds",
        || -> CliResult<_> {
            let folded = spline.folded_points(loaded.geometry.points().positions());
            let before = loaded.geometry.points().positions().to_vec();
            let out = warp_geometry(&spline, loaded.geometry).map_err(|e| -> CliError {
                match e {
                    geosynth::Error::WarpOverflow { index } => format!(
                        "the spline through {} sends point {index} of {} beyond single \
                         precision; its targets lie too far from their sources",
                        args.pairs.display(),
                        args.input.display()
                    )
                    .into(),
                    other => other.into(),
                }
            })?;
            Ok((folded, before, out))
        },
    )?;
    let options = WriteOptions::default()
        .comment(format!(
            "warped by {} pairs from {}",
            pairs.from.len(),
            args.pairs.display()
        ))
        .origin(loaded.origin);
    phases::timed(&mut timings, WRITING, || {
        write_geometry_file(&args.output, &out, &options, globals)
    })?;
    // In double precision: distances between single-precision points near f32::MAX
    // overflow f32 (the report would say null).
    let missed = pairs
        .from
        .iter()
        .zip(&pairs.to)
        .map(|(&s, &q)| spline.eval(s).as_dvec3().distance(q.as_dvec3()))
        .fold(0.0f64, f64::max);
    let moved = before
        .iter()
        .zip(out.points().positions())
        .map(|(a, b)| a.as_dvec3().distance(b.as_dvec3()))
        .fold(0.0f64, f64::max);
    if let Some(path) = &args.report {
        let report = json!({
            "input": args.input.display().to_string(),
            "pairs_file": args.pairs.display().to_string(),
            "pairs": pairs.from.len(),
            "smoothing": args.smoothing,
            "output": args.output.display().to_string(),
            "points": before.len(),
            "bending_energy": spline.bending_energy(),
            "largest_target_miss": missed,
            "largest_displacement": moved,
            "folded_points": folded.len(),
            "timings": timings_json(&timings),
        });
        write_json_report(path, "warp", &report)?;
    }
    if !folded.is_empty() {
        status(
            globals,
            format!(
                "note: the spline folds space at {} of the {} points (its Jacobian's \
                 determinant is zero or negative there): their surroundings are squashed \
                 flat or turned inside out, a mesh's triangles there flip, and parts of the \
                 surface may cross. Pairs whose targets swap the order of their sources do \
                 that; --smoothing λ > 0 or fewer pairs undo it",
                folded.len(),
                before.len()
            ),
        );
    }
    status(
        globals,
        format!(
            "wrote {} ({} {} warped by a spline through {} pairs, bending energy {:.4e})",
            args.output.display(),
            out.points().len(),
            if out.mesh().is_some() {
                "vertices"
            } else {
                "points"
            },
            spline.centers().len(),
            spline.bending_energy()
        ),
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{DVec3, fit_spline, parse_pairs};
    use std::path::Path;

    #[test]
    fn pairs_files_parse_with_line_numbers_in_errors() {
        let p = Path::new("p.txt");
        let pairs = parse_pairs(
            "# header\n0 0 0 1 1 1\n\n1 2 3 4 5 6 # note\n",
            p,
            DVec3::ZERO,
        )
        .unwrap();
        assert_eq!((pairs.from.len(), pairs.to.len()), (2, 2));
        assert_eq!(pairs.lines, [2, 4]);
        let err = parse_pairs("0 0 0 1 1 1\n0 0 0 1 1\n", p, DVec3::ZERO)
            .unwrap_err()
            .to_string();
        assert!(err.contains("p.txt:2"), "{err}");
        assert!(parse_pairs("0 0 x 1 1 1\n", p, DVec3::ZERO).is_err());
        assert!(parse_pairs("# nothing\n", p, DVec3::ZERO).is_err());
        // Georeferenced pairs keep their digits relative to the point set's origin (an f32
        // at 4e6 steps by 0.25).
        let origin = DVec3::new(500_000.0, 4_000_000.0, 0.0);
        let pairs = parse_pairs("500000.1 4000000.1 0 500000.2 4000000.3 1\n", p, origin).unwrap();
        let (a, b) = (pairs.from, pairs.to);
        assert!(
            (a[0] - glam::Vec3::new(0.1, 0.1, 0.0)).length() < 1e-6,
            "{}",
            a[0]
        );
        assert!(
            (b[0] - glam::Vec3::new(0.2, 0.3, 1.0)).length() < 1e-6,
            "{}",
            b[0]
        );
    }

    #[test]
    fn coordinates_single_precision_cannot_hold_are_refused_with_their_line() {
        let p = Path::new("p.txt");
        for bad in ["nan", "inf", "-inf", "1e39"] {
            let text = format!("0 0 0 1 1 1\n# two\n0 0 1 0 0 {bad}\n");
            let err = parse_pairs(&text, p, DVec3::ZERO).unwrap_err().to_string();
            assert!(err.contains("p.txt:3") && err.contains("finite"), "{err}");
        }
        // Finite in double precision far from the origin, but not once recentred to f32.
        let far = DVec3::new(0.0, 0.0, -3.0e38);
        assert!(parse_pairs("0 0 3e38 0 0 3e38\n", p, far).is_err());
        assert!(parse_pairs("0 0 1e38 0 0 1e38\n", p, DVec3::ZERO).is_ok());
    }

    #[test]
    fn pairs_that_start_together_and_part_are_named_by_their_lines() {
        let p = Path::new("p.txt");
        let text = "1 0 0 1 0 0\n\n0 0 0 0 0 1\n# comment\n0 1 0 0 1 0\n0 0 0 0 0 2\n";
        let pairs = parse_pairs(text, p, DVec3::ZERO).unwrap();
        let err = fit_spline(&pairs, p, 0.0).unwrap_err().to_string();
        assert!(err.contains("p.txt:3 and 6"), "{err}");
        // Negative smoothing is the parameter's fault, not the file's.
        let fine = parse_pairs("1 0 0 1 0 0\n0 1 0 0 1 0\n", p, DVec3::ZERO).unwrap();
        let err = fit_spline(&fine, p, -1.0).unwrap_err().to_string();
        assert!(!err.contains("p.txt") && err.contains("smoothing"), "{err}");
    }
}
