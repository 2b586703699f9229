//! `geosynth fixtures`.

use std::path::PathBuf;

use clap::Args;
use geosynth::fixtures;

use crate::output::status;
use crate::{CliResult, Globals};

/// Arguments of `geosynth fixtures` (shapes, geometry textures and the distance-field
/// synthesis solids).
#[derive(Debug, Args)]
pub struct FixturesArgs {
    /// Folder to write into (created if missing).
    #[arg(long, default_value = "fixtures")]
    out: PathBuf,
    /// Seed of the random fixtures; the default reproduces the committed files.
    #[arg(long, default_value_t = fixtures::FIXTURE_SEED)]
    seed: u64,
    /// Write only the four geometry textures, at this many points per unit area (the
    /// committed ones use 300; 450 gives a 70k-point chain mail, the size of the paper's).
    #[arg(long)]
    texture_density: Option<f32>,
    /// With `--texture-density`: seed of the sample positions (default: `--seed`, as
    /// committed). Another value samples the same surfaces anew, a control for measures
    /// that should not depend on where the samples fall.
    #[arg(long, requires = "texture_density")]
    sampling_seed: Option<u64>,
}

/// Runs `geosynth fixtures`.
pub fn run(args: &FixturesArgs, globals: Globals) -> CliResult {
    if let Some(density) = args.texture_density {
        if !(density.is_finite() && density > 0.0 && density <= 1e5) {
            return Err(format!("--texture-density must be in (0, 100000], not {density}").into());
        }
        let sampling_seed = args.sampling_seed.unwrap_or(args.seed);
        for path in fixtures::write_textures(&args.out, args.seed, sampling_seed, density)? {
            status(globals, format!("wrote {}", path.display()));
        }
        return Ok(());
    }
    let mut written = fixtures::write_all(&args.out, args.seed)?;
    written.extend(fixtures::write_volumes(&args.out, args.seed)?);
    for path in written {
        status(globals, format!("wrote {}", path.display()));
    }
    Ok(())
}
