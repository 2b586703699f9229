//! Locating the shared real-world test data (`GEOSYNTH_DATA`).
//!
//! Tests and benchmarks of the geosynth crates read public meshes, point sets and textures
//! from the folder named by the `GEOSYNTH_DATA` environment variable (CI sets it to the
//! absolute path of `../shared/data`). Without the variable a test prints that it skipped and
//! why; with it, a missing file is the test's failure, never a skip.

use std::path::PathBuf;

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
