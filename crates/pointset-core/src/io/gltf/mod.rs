//! glTF 2.0, the Khronos Group's transmission format for scenes (Blender, three.js,
//! game engines and most content pipelines read it): `.glb` (the binary container, one
//! file) and `.gltf` (the JSON document; its buffers embedded as base64 `data:` URIs or
//! in files beside it).
//!
//! # Reading
//!
//! The scene's meshes are merged into one geometry, each placed by its node's transform
//! (the product of its ancestors' `matrix` or translation, rotation and scale, in double
//! precision): the default `scene` (the first when none is named; when the file has no
//! scenes, every node that is nobody's child). Triangles (`TRIANGLES`, `TRIANGLE_STRIP`,
//! `TRIANGLE_FAN`, indexed or not) make a mesh; a file of `POINTS` primitives only makes
//! a point set. Vertex attributes:
//! - `POSITION` (required); `NORMAL`, turned by the inverse transpose of the node's
//!   transform, keeping its stored length (unit normals stay unit, zero ones zero);
//!   under a transform that mirrors (negative determinant) the triangles' corner order
//!   is reversed, as the format asks;
//! - `COLOR_0` (RGB or RGBA): glTF's colours are linear, so they are converted to sRGB and
//!   kept as the `red`, `green`, `blue` (and `alpha`) channels in `0..=255`, the
//!   convention every other format here uses;
//! - `TEXCOORD_0`: the mesh's UVs, with `v` flipped (glTF's texture origin is the top
//!   left corner, OBJ's and PLY's the bottom left);
//! - application attributes (`_NAME`, one value a vertex): the attribute `NAME`, in its
//!   stored type (normalised integers as floats).
//!
//! Every component type is read, normalised or not (so files written with
//! `KHR_mesh_quantization` read as any other), from interleaved or packed buffer views, and
//! sparse accessors are applied.
//!
//! What the geometry cannot keep is said in [`super::LoadedGeometry::notes`]: line
//! primitives, point primitives in a file with triangles, other attributes (`TANGENT`,
//! `TEXCOORD_1`, `COLOR_1`, `JOINTS_0`, `WEIGHTS_0`, …), an attribute some primitives have
//! and others lack (a vertex channel is all or nothing), morph targets and skins (the
//! meshes are read in their rest pose), scenes other than the one read, and normals that
//! are not finite (kept as zero, no known direction, as the PCD reader keeps them). Materials,
//! textures, cameras, lights and animations are not geometry and are left without a note.
//!
//! Refused with a typed error naming the member at fault ([`crate::Error::InvalidDocument`],
//! e.g. `accessors[3].count`): an extension the file requires (`extensionsRequired`) other
//! than `KHR_mesh_quantization` (Draco and meshopt compression must be undone first), a
//! version other than 2, references to members that do not exist, accessors reaching past
//! their buffer views and views past their buffers (checked before reading), indices past
//! the vertices, a node that is its own ancestor or the child of two parents, and more
//! vertices than [`MAX_GLTF_VERTICES`] once every instance is placed. Broken containers
//! and JSON are [`crate::Error::Malformed`] with a byte or line.
//!
//! External buffers (`uri` naming a file) are read from the glTF file's directory when it
//! is read by path ([`super::read_geometry`]); [`read_gltf`] reads bytes alone, so it
//! refuses them. URIs with a scheme (`http:`) are refused.
//!
//! # Writing
//!
//! One mesh of one primitive (`TRIANGLES` with 32-bit indices, or `POINTS` for a point
//! set) under one node: `POSITION` (with the `min` and `max` the format requires), `NORMAL`
//! as stored (the format expects unit normals; a zero normal, geosynth's "no direction
//! known", is written as zero), `COLOR_0` as normalised 16-bit linear values (8-bit sRGB
//! colours come back exactly), `TEXCOORD_0`, and every other attribute as `_NAME` in its
//! storage type (8- and 16-bit integers as themselves, other types as floats). Each vertex
//! stream is aligned to 4 bytes as the format asks. A nonzero write origin
//! ([`super::WriteOptions::origin`]) becomes the node's translation, in double precision,
//! so viewers place georeferenced data where it is while the positions stay small
//! `f32`s. Comments go to `asset.extras.comments` (and are read back from there). A `.glb`
//! holds the JSON and one binary chunk; a `.gltf` is one self-contained file with its
//! buffer as a base64 `data:` URI (a third larger). The binary buffer is built in memory
//! before anything is written (the JSON, which comes first, states its length); a
//! `.gltf`'s base64 is then streamed into the file a chunk at a time.
//!
//! Coordinates are written and read as they are. glTF's viewers take +Y as up, so a
//! Z-up height field or quilt opens lying on its back in them, as an OBJ does in
//! Blender's importer with its default axes; rotate it there, or before writing.

mod accessor;
mod base64;
mod colour;
mod container;
mod document;
mod scene;
mod write;

use std::io::Read;
use std::path::Path;

use glam::DVec3;

use super::{FileFormat, Geometry};
use crate::{Error, Location, Result};

pub use write::write_gltf;
pub(crate) use write::write_gltf_at;

/// The most vertices a glTF file may expand to once every instance of its meshes is
/// placed (2²⁸, about 3 GB of positions in single precision): a small file can place one
/// large mesh under many nodes.
pub const MAX_GLTF_VERTICES: usize = 1 << 28;

/// The two ways a glTF asset is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GltfContainer {
    /// `.glb`: a binary container of the JSON document and one binary chunk.
    Binary,
    /// `.gltf`: the JSON document, buffers as `data:` URIs or files beside it.
    Json,
}

impl GltfContainer {
    /// The file extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            GltfContainer::Binary => "glb",
            GltfContainer::Json => "gltf",
        }
    }
}

/// A glTF file read into a geometry.
pub(crate) struct GltfFile {
    /// The merged meshes (or points).
    pub geometry: Geometry,
    /// The origin the positions are relative to.
    pub origin: DVec3,
    /// The container, for `info`.
    pub container: GltfContainer,
    /// The comments in `asset.extras.comments`.
    pub comments: Vec<String>,
    /// What the file had that the geometry does not keep.
    pub notes: Vec<String>,
}

/// A malformed-container error at byte `at`.
fn malformed_at_byte(container: GltfContainer, at: u64, message: impl Into<String>) -> Error {
    Error::Malformed {
        format: FileFormat::Gltf(container),
        location: Location::Byte(at),
        message: message.into(),
    }
}

/// Reads a glTF asset held in memory: a `.glb` container or a `.gltf` JSON document,
/// told apart by the container's magic bytes (see the module docs). Buffers in files
/// beside a `.gltf` cannot be found from bytes alone: read such a file by its path with
/// [`super::read_geometry`].
///
/// ```
/// use pointset_core::io::read_gltf;
/// // A triangle, its three positions embedded as base64.
/// let gltf = r#"{
///   "asset": {"version": "2.0"},
///   "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
///   "bufferViews": [{"buffer": 0, "byteLength": 36}],
///   "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
///                  "min": [0, 0, 0], "max": [1, 1, 0]}],
///   "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
///   "nodes": [{"mesh": 0, "translation": [0, 0, 2]}],
///   "scenes": [{"nodes": [0]}]
/// }"#;
/// let geometry = read_gltf(gltf.as_bytes())?;
/// let mesh = geometry.mesh().ok_or("a triangle makes a mesh")?;
/// assert_eq!(mesh.triangles(), [[0, 1, 2]]);
/// assert_eq!(mesh.positions()[1].to_array(), [1.0, 0.0, 2.0]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_gltf(bytes: &[u8]) -> Result<Geometry> {
    read_gltf_bytes(bytes, None, false).map(|file| file.geometry)
}

/// Reads a glTF file of `len` bytes from `reader` (read whole: the JSON says where the
/// data is); external buffers are looked for in `base_dir`. Positions are stored relative
/// to an origin when `recentre_far` is set and the data lies far from the file's origin.
pub(crate) fn read_gltf_from(
    reader: impl Read,
    len: u64,
    recentre_far: bool,
    base_dir: Option<&Path>,
) -> Result<GltfFile> {
    let capacity = usize::try_from(len).map_err(|_| Error::OutOfMemory {
        what: "a glTF file".into(),
        bytes: u128::from(len),
    })?;
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(capacity)
        .map_err(|_| Error::OutOfMemory {
            what: "a glTF file".into(),
            bytes: u128::from(len),
        })?;
    reader
        .take(len)
        .read_to_end(&mut bytes)
        .map_err(|source| Error::Read { source })?;
    if (bytes.len() as u64) < len {
        return Err(Error::UnexpectedEof {
            format: FileFormat::Gltf(container::container_of(&bytes)),
            location: Location::Byte(bytes.len() as u64),
            what: format!("the file's {len} bytes"),
        });
    }
    read_gltf_bytes(&bytes, base_dir, recentre_far)
}

/// Reads a glTF asset from its bytes (see [`read_gltf_from`]).
fn read_gltf_bytes(bytes: &[u8], base_dir: Option<&Path>, recentre_far: bool) -> Result<GltfFile> {
    let asset = container::open(bytes)?;
    let document = document::Document::parse(asset.json, asset.container)?;
    let buffers = container::load_buffers(&document, asset.binary, base_dir)?;
    let mut notes = asset.notes;
    let (geometry, origin) =
        scene::merged_geometry(&document, &buffers, bytes.len(), recentre_far, &mut notes)?;
    Ok(GltfFile {
        geometry,
        origin,
        container: asset.container,
        comments: document.comments(),
        notes,
    })
}

/// Whether a file starting with `head` looks like glTF, and in which container: a `.glb`
/// by its magic bytes, a `.gltf` by a JSON object opening with the `asset` or another
/// top-level glTF member within its first bytes.
pub(crate) fn sniff(head: &[u8]) -> Option<GltfContainer> {
    if head.starts_with(container::GLB_MAGIC) {
        return Some(GltfContainer::Binary);
    }
    let text = String::from_utf8_lossy(&head[..head.len().min(4096)]);
    let body = text.trim_start();
    let members = [
        "\"asset\"",
        "\"scene\"",
        "\"buffers\"",
        "\"accessors\"",
        "\"meshes\"",
    ];
    (body.starts_with('{') && members.iter().any(|m| body.contains(m)))
        .then_some(GltfContainer::Json)
}
