//! Shared benchmark setup.

use geosynth::core::TriMesh;
use geosynth::core::io;

/// `bunny_watertight.obj` from `GEOSYNTH_DATA`, or `None` when the variable is not set.
pub fn watertight_bunny() -> Option<TriMesh> {
    let dir = std::env::var_os("GEOSYNTH_DATA")?;
    let path = std::path::Path::new(&dir).join("meshes/bunny_watertight.obj");
    let geometry = io::read_geometry(&path)
        .expect("bunny_watertight.obj")
        .geometry;
    Some(geometry.mesh().expect("a mesh").clone())
}
