//! `geosynth fixtures`.

use std::path::PathBuf;

use clap::Args;
use geosynth::fixtures;

use crate::output::status;
use crate::{CliResult, Globals};

/// Arguments of `geosynth fixtures`.
#[derive(Debug, Args)]
pub struct FixturesArgs {
    /// Folder to write into (created if missing).
    #[arg(long, default_value = "fixtures")]
    out: PathBuf,
    /// Seed of the random fixtures; the default reproduces the committed files.
    #[arg(long, default_value_t = fixtures::FIXTURE_SEED)]
    seed: u64,
}

/// Runs `geosynth fixtures`.
pub fn run(args: &FixturesArgs, globals: Globals) -> CliResult {
    for path in fixtures::write_all(&args.out, args.seed)? {
        status(globals, format!("wrote {}", path.display()));
    }
    Ok(())
}
