//! `geosynth normals`: estimate and orient the normals of a point set.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use geosynth::core::io::{Geometry, WriteOptions};
use geosynth::mls::{
    NORMAL_NEIGHBOURS, estimate_normals, orient_normals, orientation_disagreement,
};
use glam::{DVec3, Vec3};

use crate::input_file::read_geometry;
use crate::output::{
    check_geometry_output, check_output_paths, report_not_kept, spinner, status,
    write_geometry_file,
};
use crate::{CliResult, Globals};

/// The direction estimated normals are turned toward where nothing else decides.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum UpArg {
    /// +X.
    X,
    /// +Y (scanned models, most DCC tools' exports).
    Y,
    /// +Z (height fields, terrain).
    Z,
}

impl UpArg {
    fn vector(self) -> Vec3 {
        match self {
            UpArg::X => Vec3::X,
            UpArg::Y => Vec3::Y,
            UpArg::Z => Vec3::Z,
        }
    }
}

/// Arguments of `geosynth normals`.
#[derive(Debug, Args)]
pub struct NormalsArgs {
    /// Point set (.ply, .obj, .off); normals it has are replaced.
    input: PathBuf,
    /// Output point set with normals (.ply, .obj or .off).
    #[arg(short, long)]
    output: PathBuf,
    /// Nearest neighbours (the point included) each tangent plane is fitted to.
    #[arg(long, default_value_t = NORMAL_NEIGHBOURS)]
    neighbours: usize,
    /// Each connected part's highest point along this axis gets the normal facing it;
    /// the signs spread from there (for a closed scan: outward).
    #[arg(long, value_enum, default_value_t = UpArg::Z)]
    up: UpArg,
}

/// Runs `geosynth normals`.
pub fn run(args: &NormalsArgs, globals: Globals) -> CliResult {
    check_output_paths([args.output.as_path()], [])?;
    check_geometry_output(&args.output, false, DVec3::ZERO)?;
    let loaded = read_geometry(&args.input)?;
    report_not_kept(globals, &args.input, &loaded.notes);
    let points = match &loaded.geometry {
        Geometry::Points(points) => points,
        Geometry::Mesh(_) => {
            return Err(format!(
                "{} is a mesh: its normals come from its faces, which every command that \
                 needs them uses; `normals` estimates them for point sets",
                args.input.display()
            )
            .into());
        }
    };
    let bar = spinner(globals, "estimating normals");
    let estimated = estimate_normals(points, args.neighbours)?;
    let oriented = orient_normals(&estimated, args.up.vector())?;
    bar.finish_and_clear();
    let options = WriteOptions::default()
        .comment(format!(
            "normals estimated by geosynth from {} nearest neighbours and oriented toward +{:?}",
            args.neighbours, args.up
        ))
        .origin(loaded.origin);
    write_geometry_file(&args.output, &Geometry::Points(oriented.clone()), &options)?;
    let disagreement = orientation_disagreement(&oriented)?;
    status(
        globals,
        format!(
            "wrote {} ({} points; {:.1}% face away from most neighbours)",
            args.output.display(),
            oriented.len(),
            100.0 * disagreement
        ),
    );
    Ok(())
}
