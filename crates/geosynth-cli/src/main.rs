//! `geosynth`: run geosynth's synthesis algorithms on real files and look at the results.

mod commands;
mod input_file;
mod interrupt;
mod json_report;
mod memory;
mod output;
mod params_file;
mod phases;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

use params_file::GivenFlags;

/// Most worker threads `--threads` starts: more than almost any machine has cores, fewer
/// than would take a minute to start (100,000 had not started after one).
const MAX_THREADS: usize = 1024;

/// Example-based geometry and texture synthesis.
#[derive(Debug, Parser)]
#[command(name = "geosynth", version, about, long_about = None)]
struct Cli {
    /// Print nothing but errors (no progress bars, no summaries).
    #[arg(long, short, global = true)]
    quiet: bool,
    /// Worker threads for parallel stages (default: all cores). Results do not depend on it.
    #[arg(long, global = true, value_name = "N")]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Describe a geometry file (PLY, OBJ, OFF, STL, XYZ, LAS, PCD), a picture, a height field
    /// or an NRRD volume: format, counts, attributes, bounding box, topology.
    Info(commands::info::InfoArgs),
    /// Convert a point set or mesh between PLY, OBJ, OFF, STL, XYZ, LAS and PCD, saying what
    /// the target format cannot store.
    Convert(commands::convert::ConvertArgs),
    /// Render point sets and meshes to a PNG, one panel per input file.
    Render(commands::render::RenderArgs),
    /// Estimate a point set's normals by local PCA and orient them by propagation.
    Normals(commands::normals::NormalsArgs),
    /// Sample oriented points on a mesh's surface, as a Poisson disk or uniformly by area
    /// (for the commands that take point sets, from a mesh whose vertices are too few); or
    /// thin a point set to fewer of its own points, as a Poisson disk or at random.
    Sample(commands::sample::SampleArgs),
    /// Simplify a mesh to fewer triangles by edge collapse under error quadrics (Garland
    /// and Heckbert), keeping its topology, boundaries and seams.
    Simplify(commands::simplify::SimplifyArgs),
    /// Turn an oriented point set into a closed mesh (MLS surface → distance field →
    /// iso-surface), or remesh a mesh closed through its own distance field.
    Reconstruct(commands::reconstruct::ReconstructArgs),
    /// Sample the signed distance field of a mesh or oriented point set into an NRRD file.
    Sdf(commands::reconstruct::SdfArgs),
    /// Warp a point set or mesh with a thin-plate spline through given pairs (normals are
    /// transported through the spline's Jacobian).
    Warp(commands::warp::WarpArgs),
    /// Grow a geometry texture by patch-based synthesis (paper 000).
    Quilt(commands::quilt::QuiltArgs),
    /// Synthesize a solid by distance-field block matching (paper 001).
    Voxel(commands::voxel::VoxelArgs),
    /// Write the procedural exemplars used by the tests and the demo.
    Fixtures(commands::fixtures::FixturesArgs),
    /// Run every available synthesis family on the bundled fixtures; write results,
    /// previews and a report.
    Demo(commands::demo::DemoArgs),
}

/// Global settings every command sees.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Globals {
    quiet: bool,
}

fn main() -> ExitCode {
    phases::start_clock();
    interrupt::install();
    let matches = Cli::command().get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    if let Some(n) = cli.threads {
        if !(1..=MAX_THREADS).contains(&n) {
            let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
            eprintln!(
                "error: --threads must be 1 to {MAX_THREADS}, not {n} (this machine has {cores} \
                 cores; leave it out to use them all)"
            );
            return ExitCode::from(2);
        }
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
        {
            eprintln!("error: cannot start {n} worker threads: {e}");
            return ExitCode::FAILURE;
        }
    }
    let globals = Globals { quiet: cli.quiet };
    let result = match cli.command {
        Command::Info(args) => commands::info::run(&args, globals),
        Command::Convert(args) => commands::convert::run(&args, globals),
        Command::Render(args) => commands::render::run(&args, globals),
        Command::Normals(args) => commands::normals::run(&args, globals),
        Command::Sample(args) => commands::sample::run(&args, globals),
        Command::Simplify(args) => commands::simplify::run(&args, globals),
        Command::Reconstruct(args) => commands::reconstruct::run_reconstruct(
            &args,
            GivenFlags::of(&matches, "reconstruct"),
            globals,
        ),
        Command::Sdf(args) => {
            commands::reconstruct::run_sdf(&args, GivenFlags::of(&matches, "sdf"), globals)
        }
        Command::Warp(args) => commands::warp::run(&args, globals),
        Command::Quilt(args) => {
            commands::quilt::run(&args, GivenFlags::of(&matches, "quilt"), globals)
        }
        Command::Voxel(args) => {
            commands::voxel::run(&args, GivenFlags::of(&matches, "voxel"), globals)
        }
        Command::Fixtures(args) => commands::fixtures::run(&args, globals),
        Command::Demo(args) => commands::demo::run(&args, globals),
    };
    interrupt::wait_if_stopping();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let mut said = e.to_string();
            eprintln!("error: {said}");
            // Causes whose text the message before them already holds add nothing.
            let mut source = std::error::Error::source(&*e);
            while let Some(s) = source {
                let cause = s.to_string();
                if !said.contains(&cause) {
                    eprintln!("  caused by: {cause}");
                }
                said = cause;
                source = s.source();
            }
            ExitCode::FAILURE
        }
    }
}

/// Errors of CLI commands: any library error, with context.
pub(crate) type CliResult<T = ()> = Result<T, CliError>;

/// The error of every command: anything that can say what went wrong.
pub(crate) type CliError = Box<dyn std::error::Error + Send + Sync>;

/// Creates a directory and its parents, naming it in the error.
pub(crate) fn create_dir(dir: &PathBuf) -> CliResult {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()).into())
}
