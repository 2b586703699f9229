//! Test data the geosynth crates share: the real-world files (`GEOSYNTH_DATA`), and the
//! seeded random inputs several crates' tests draw alike.
//!
//! Tests and benchmarks of the geosynth crates read public meshes, point sets and textures
//! from the folder named by the `GEOSYNTH_DATA` environment variable (CI sets it to the
//! absolute path of `../shared/data`). Without the variable a test prints that it skipped and
//! why; with it, a missing file is the test's failure, never a skip.

use std::path::PathBuf;

use glam::Vec3;
use rand::RngExt;

use crate::rng::SeededRng;

/// A random direction for tests, drawn from `g`: a point uniform in the cube `[-1, 1]³`,
/// normalized (+X for the origin). Not uniform over the sphere (denser toward the cube's
/// corners), which the tests that draw points on a sphere or queries around one do not
/// need.
///
/// ```
/// use pointset_core::{rng::rng_from_seed, testdata::random_direction};
///
/// let mut g = rng_from_seed(1);
/// let d = random_direction(&mut g);
/// assert!((d.length() - 1.0).abs() < 1e-6);
/// ```
pub fn random_direction(g: &mut SeededRng) -> Vec3 {
    Vec3::new(
        g.random_range(-1.0..1.0),
        g.random_range(-1.0..1.0),
        g.random_range(-1.0..1.0),
    )
    .normalize_or(Vec3::X)
}

/// The environment variable naming the data folder.
pub const DATA_ENV: &str = "GEOSYNTH_DATA";

/// The path of `relative` inside the data folder, or `None` (after printing a skip notice
/// naming `test`) when `GEOSYNTH_DATA` is not set. The file's existence is not checked: the
/// caller's read fails loudly if it is missing.
pub fn shared_data(test: &str, relative: &str) -> Option<PathBuf> {
    match std::env::var_os(DATA_ENV) {
        Some(dir) => Some(PathBuf::from(dir).join(relative)),
        None => {
            eprintln!("skipped {test}: {DATA_ENV} is not set, so {relative} cannot be located");
            None
        }
    }
}
