//! `geosynth warp`: apply a thin-plate spline given by explicit pairs.

use std::path::{Path, PathBuf};

use clap::Args;
use geosynth::core::io::{Geometry, WriteOptions};
use geosynth::core::{PointSet, TriMesh};
use geosynth::tps::{ThinPlateSpline, TpsParams};
use glam::{DVec3, Vec3};

use crate::input_file::read_geometry;
use crate::output::{
    check_geometry_output, check_output_paths, report_not_kept, status, write_geometry_file,
};
use crate::{CliResult, Globals};

/// Arguments of `geosynth warp`.
#[derive(Debug, Args)]
pub struct WarpArgs {
    /// Point set or mesh to warp (.ply, .obj, .off, .stl, .xyz); meshes keep their faces.
    input: PathBuf,
    /// Pairs file: one pair per line, `sx sy sz qx qy qz` (source → target); `#` starts a
    /// comment.
    #[arg(long)]
    pairs: PathBuf,
    /// Output file (.ply, .obj, .off; .stl for a mesh): warped positions, transported normals when the input
    /// has normals, other attributes unchanged.
    #[arg(short, long)]
    output: PathBuf,
    /// Smoothing λ of the spline (0 = interpolate the pairs exactly).
    #[arg(long, default_value_t = 0.0)]
    smoothing: f64,
}

/// Parses a pairs file into sources and targets, naming the line of any error. The
/// coordinates are read in double precision and stored relative to `origin` (that of the
/// point set they warp, see [`geosynth::core::io::ReadOptions::recentre_far`]).
pub fn parse_pairs(text: &str, path: &Path, origin: DVec3) -> CliResult<(Vec<Vec3>, Vec<Vec3>)> {
    let (mut from, mut to) = (Vec::new(), Vec::new());
    for (i, line) in text.lines().enumerate() {
        let content = line.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let values: Vec<f64> = content
            .split_whitespace()
            .map(|w| w.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| {
                format!(
                    "{}:{}: `{content}` is not six numbers",
                    path.display(),
                    i + 1
                )
            })?;
        let [sx, sy, sz, qx, qy, qz] = values[..] else {
            return Err(format!(
                "{}:{}: expected 6 numbers, found {}",
                path.display(),
                i + 1,
                values.len()
            )
            .into());
        };
        from.push((DVec3::new(sx, sy, sz) - origin).as_vec3());
        to.push((DVec3::new(qx, qy, qz) - origin).as_vec3());
    }
    if from.is_empty() {
        return Err(format!("{}: no pairs", path.display()).into());
    }
    Ok((from, to))
}

/// A copy of `points` with new positions and normals (attributes kept).
fn rebuild(
    points: &PointSet,
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
) -> CliResult<PointSet> {
    let mut out = PointSet::new(positions)?;
    if let Some(n) = normals {
        out = out.with_normals(n)?;
    }
    for a in points.attributes() {
        out.set_attribute(a.clone())?;
    }
    Ok(out)
}

/// Runs `geosynth warp`.
pub fn run(args: &WarpArgs, globals: Globals) -> CliResult {
    check_output_paths([args.output.as_path()], [])?;
    let text = std::fs::read_to_string(&args.pairs)
        .map_err(|e| format!("cannot read {}: {e}", args.pairs.display()))?;
    // Georeferenced inputs are warped relative to an origin and written back there.
    let loaded = read_geometry(&args.input)?;
    report_not_kept(globals, &args.input, &loaded.notes);
    check_geometry_output(
        &args.output,
        loaded.geometry.mesh().is_some(),
        loaded.origin,
    )?;
    let (from, to) = parse_pairs(&text, &args.pairs, loaded.origin)?;
    let spline = ThinPlateSpline::fit(&from, &to, &TpsParams::default().smoothing(args.smoothing))?;
    let geometry = loaded.geometry;
    let points = geometry.points();
    let (moved, normals) = spline.warp(points.positions(), points.normals());
    let warped = rebuild(points, moved, normals)?;
    let out = match &geometry {
        Geometry::Points(_) => Geometry::Points(warped),
        Geometry::Mesh(m) => {
            let mut mesh = TriMesh::new(warped, m.triangles().to_vec())?;
            if let Some(uvs) = m.uvs() {
                mesh = mesh.with_uvs(uvs.to_vec())?;
            }
            Geometry::Mesh(mesh)
        }
    };
    let options = WriteOptions::default()
        .comment(format!(
            "warped by {} pairs from {}",
            from.len(),
            args.pairs.display()
        ))
        .origin(loaded.origin);
    write_geometry_file(&args.output, &out, &options)?;
    status(
        globals,
        format!(
            "wrote {} ({} points warped by a spline through {} pairs, bending energy {:.4e})",
            args.output.display(),
            out.points().len(),
            spline.centers().len(),
            spline.bending_energy()
        ),
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{DVec3, parse_pairs};
    use std::path::Path;

    #[test]
    fn pairs_files_parse_with_line_numbers_in_errors() {
        let p = Path::new("p.txt");
        let (a, b) = parse_pairs(
            "# header\n0 0 0 1 1 1\n\n1 2 3 4 5 6 # note\n",
            p,
            DVec3::ZERO,
        )
        .unwrap();
        assert_eq!((a.len(), b.len()), (2, 2));
        let err = parse_pairs("0 0 0 1 1 1\n0 0 0 1 1\n", p, DVec3::ZERO)
            .unwrap_err()
            .to_string();
        assert!(err.contains("p.txt:2"), "{err}");
        assert!(parse_pairs("0 0 x 1 1 1\n", p, DVec3::ZERO).is_err());
        assert!(parse_pairs("# nothing\n", p, DVec3::ZERO).is_err());
        // Georeferenced pairs keep their digits relative to the point set's origin (an f32
        // at 4e6 steps by 0.25).
        let origin = DVec3::new(500_000.0, 4_000_000.0, 0.0);
        let (a, b) = parse_pairs("500000.1 4000000.1 0 500000.2 4000000.3 1\n", p, origin).unwrap();
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
}
