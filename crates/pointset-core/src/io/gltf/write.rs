//! glTF encoding (see the module docs of [`super`]).

use std::io::Write;

use glam::DVec3;
use serde_json::{Map, Value, json};

use super::accessor::Component;
use super::colour::srgb_to_linear;
use super::container::{BIN_CHUNK, GLB_HEADER_BYTES, GLB_MAGIC, JSON_CHUNK};
use super::{GltfContainer, base64};
use crate::io::buffered::buffered;
use crate::io::{FileFormat, Geometry};
use crate::{Attribute, COLOR_CHANNELS, Error, Result, ScalarType};

/// The start of a buffer's `data:` URI; its base64 follows.
const DATA_URI: &str = "data:application/octet-stream;base64,";

/// `bufferView.target` of vertex streams.
const ARRAY_BUFFER: u32 = 34962;
/// `bufferView.target` of indices.
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// The binary buffer being filled, and the views and accessors describing it.
#[derive(Default)]
struct Buffer {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

/// How one accessor's elements are stored.
struct Stream<'a> {
    component: Component,
    kind: &'a str,
    /// Values an element.
    components: usize,
    normalized: bool,
    target: u32,
}

impl Buffer {
    /// Appends `count` elements of `stream`, each written by `element` (which appends
    /// its components' bytes), in a view of its own; vertex streams are padded to 4 bytes
    /// an element as the format asks. Returns the accessor's index.
    fn push(
        &mut self,
        stream: &Stream<'_>,
        count: usize,
        mut element: impl FnMut(usize, &mut Vec<u8>),
        bounds: Option<(Vec<f64>, Vec<f64>)>,
    ) -> usize {
        let element_bytes = stream.component.scalar().size() * stream.components;
        let vertex = stream.target == ARRAY_BUFFER;
        let stride = if vertex {
            element_bytes.next_multiple_of(4)
        } else {
            element_bytes
        };
        self.bytes.resize(self.bytes.len().next_multiple_of(4), 0);
        let start = self.bytes.len();
        for i in 0..count {
            let before = self.bytes.len();
            element(i, &mut self.bytes);
            self.bytes.resize(before + stride, 0);
        }
        let mut view = json!({
            "buffer": 0,
            "byteOffset": start,
            "byteLength": self.bytes.len() - start,
            "target": stream.target,
        });
        if vertex && stride != element_bytes {
            view["byteStride"] = json!(stride);
        }
        self.views.push(view);
        let mut accessor = json!({
            "bufferView": self.views.len() - 1,
            "componentType": stream.component.code(),
            "count": count,
            "type": stream.kind,
        });
        if stream.normalized {
            accessor["normalized"] = json!(true);
        }
        if let Some((min, max)) = bounds {
            accessor["min"] = json!(min);
            accessor["max"] = json!(max);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }
}

/// The glTF component an attribute of `storage` is written as: 8- and 16-bit integers as
/// themselves, every other type as a float (application attributes may not be 32-bit
/// unsigned integers).
fn component_of(storage: ScalarType) -> Component {
    match storage {
        ScalarType::I8 => Component::I8,
        ScalarType::U8 => Component::U8,
        ScalarType::I16 => Component::I16,
        ScalarType::U16 => Component::U16,
        _ => Component::F32,
    }
}

/// Writes `geometry` as glTF 2.0 in `container` (see the [module docs](crate::io::gltf)), with
/// `comments` in `asset.extras.comments`.
///
/// ```
/// use pointset_core::io::{Geometry, GltfContainer, read_gltf, write_gltf};
/// use pointset_core::{PointSet, TriMesh, glam::Vec3};
/// let vertices = PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y])?
///     .with_normals(vec![Vec3::Z; 3])?;
/// let geometry = Geometry::Mesh(TriMesh::new(vertices, vec![[0, 1, 2]])?);
/// let mut glb = Vec::new();
/// write_gltf(&geometry, GltfContainer::Binary, &[], &mut glb)?;
/// assert_eq!(&glb[..4], b"glTF");
/// assert_eq!(read_gltf(&glb)?, geometry);
/// # Ok::<(), pointset_core::Error>(())
/// ```
pub fn write_gltf(
    geometry: &Geometry,
    container: GltfContainer,
    comments: &[String],
    out: &mut impl Write,
) -> Result<()> {
    write_gltf_at(geometry, container, comments, DVec3::ZERO, out)
}

/// [`write_gltf`] with `origin` as the node's translation.
pub(crate) fn write_gltf_at(
    geometry: &Geometry,
    container: GltfContainer,
    comments: &[String],
    origin: DVec3,
    out: &mut impl Write,
) -> Result<()> {
    let mut buffer = Buffer::default();
    let document = document(geometry, container, comments, origin, &mut buffer);
    let text = serde_json::to_vec(&document).map_err(|e| Error::FormatCannotStore {
        format: FileFormat::Gltf(container),
        what: format!("its JSON document ({e})"),
    })?;
    match container {
        GltfContainer::Json => write_embedded(&text, &buffer.bytes, out),
        GltfContainer::Binary => write_glb(text, buffer.bytes, out),
    }
}

/// The document describing `geometry`, its data appended to `buffer`: one node placing
/// one mesh (none for no points) of one primitive.
fn document(
    geometry: &Geometry,
    container: GltfContainer,
    comments: &[String],
    origin: DVec3,
    buffer: &mut Buffer,
) -> Value {
    let mut asset = json!({
        "version": "2.0",
        "generator": concat!("geosynth ", env!("CARGO_PKG_VERSION")),
    });
    if !comments.is_empty() {
        asset["extras"] = json!({ "comments": comments });
    }
    let mut node = json!({});
    if origin != DVec3::ZERO {
        node["translation"] = json!(origin.to_array());
    }
    let mut document = json!({ "asset": asset, "scene": 0, "scenes": [{ "nodes": [0] }] });
    if !geometry.points().is_empty() {
        node["mesh"] = json!(0);
        let mut primitive = json!({ "attributes": vertex_streams(geometry, buffer), "mode": 0 });
        if let Some(mesh) = geometry.mesh()
            && mesh.face_count() > 0
        {
            let indices = Stream {
                component: Component::U32,
                kind: "SCALAR",
                components: 1,
                normalized: false,
                target: ELEMENT_ARRAY_BUFFER,
            };
            let triangles = mesh.triangles();
            let at = buffer.push(
                &indices,
                3 * triangles.len(),
                |i, b| b.extend_from_slice(&triangles[i / 3][i % 3].to_le_bytes()),
                None,
            );
            primitive["indices"] = json!(at);
            primitive["mode"] = json!(4);
        }
        document["meshes"] = json!([{ "primitives": [primitive] }]);
        document["accessors"] = json!(buffer.accessors);
        document["bufferViews"] = json!(buffer.views);
        let mut described = json!({ "byteLength": buffer.bytes.len() });
        if container == GltfContainer::Json {
            // The data goes in as the text is written ([`write_embedded`]).
            described["uri"] = json!(DATA_URI);
        }
        document["buffers"] = json!([described]);
    }
    document["nodes"] = json!([node]);
    document
}

/// The `f32` values as little-endian bytes.
fn push_f32s(values: &[f32], bytes: &mut Vec<u8>) {
    for v in values {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
}

/// A vertex stream of `components` floats.
fn floats(kind: &str, components: usize) -> Stream<'_> {
    Stream {
        component: Component::F32,
        kind,
        components,
        normalized: false,
        target: ARRAY_BUFFER,
    }
}

/// The primitive's `attributes`: each vertex stream of the (non-empty) geometry appended
/// to `buffer`.
fn vertex_streams(geometry: &Geometry, buffer: &mut Buffer) -> Map<String, Value> {
    let points = geometry.points();
    let n = points.len();
    let mut attributes = Map::new();
    let positions = points.positions();
    let (lo, hi) = positions.iter().fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(lo, hi), p| {
            let p = p.to_array().map(f64::from);
            (
                [0, 1, 2].map(|k| lo[k].min(p[k])),
                [0, 1, 2].map(|k| hi[k].max(p[k])),
            )
        },
    );
    let at = buffer.push(
        &floats("VEC3", 3),
        n,
        |i, b| push_f32s(&positions[i].to_array(), b),
        Some((lo.to_vec(), hi.to_vec())),
    );
    attributes.insert("POSITION".into(), json!(at));
    if let Some(normals) = points.normals() {
        let push = |i: usize, b: &mut Vec<u8>| push_f32s(&normals[i].to_array(), b);
        let at = buffer.push(&floats("VEC3", 3), n, push, None);
        attributes.insert("NORMAL".into(), json!(at));
    }
    if let Some(uvs) = geometry.mesh().and_then(|m| m.uvs()) {
        let push = |i: usize, b: &mut Vec<u8>| push_f32s(&[uvs[i].x, 1.0 - uvs[i].y], b);
        let at = buffer.push(&floats("VEC2", 2), n, push, None);
        attributes.insert("TEXCOORD_0".into(), json!(at));
    }
    let colours = points.colors();
    if let Some(colours) = &colours {
        let alpha = points.attribute("alpha");
        attributes.insert(
            "COLOR_0".into(),
            json!(push_colours(colours, alpha, buffer)),
        );
    }
    let in_colour =
        |name: &str| colours.is_some() && (COLOR_CHANNELS.contains(&name) || name == "alpha");
    for attribute in points.attributes() {
        if in_colour(attribute.name()) {
            continue;
        }
        let component = component_of(attribute.storage());
        let storage = component.scalar();
        let values = attribute.values();
        let stream = Stream {
            component,
            kind: "SCALAR",
            components: 1,
            normalized: false,
            target: ARRAY_BUFFER,
        };
        let push = |i: usize, b: &mut Vec<u8>| storage.encode(f64::from(values[i]), false, b);
        let at = buffer.push(&stream, n, push, None);
        attributes.insert(format!("_{}", attribute.name()), json!(at));
    }
    attributes
}

/// Appends `COLOR_0`: the sRGB `colours` (and `alpha`, in `0..=255`) as normalised 16-bit
/// linear values. Returns the accessor's index.
fn push_colours(colours: &[[f32; 3]], alpha: Option<&Attribute>, buffer: &mut Buffer) -> usize {
    let stream = Stream {
        component: Component::U16,
        kind: if alpha.is_some() { "VEC4" } else { "VEC3" },
        components: if alpha.is_some() { 4 } else { 3 },
        normalized: true,
        target: ARRAY_BUFFER,
    };
    let unit = |v: f64| (v.clamp(0.0, 1.0) * 65535.0).round() as u16;
    let push = |i: usize, b: &mut Vec<u8>| {
        for c in colours[i] {
            b.extend_from_slice(&unit(srgb_to_linear(f64::from(c))).to_le_bytes());
        }
        if let Some(a) = alpha {
            let a = f64::from(a.values()[i]) / 255.0;
            b.extend_from_slice(&unit(a).to_le_bytes());
        }
    };
    buffer.push(&stream, colours.len(), push, None)
}

/// Writes a `.gltf`: the document's `text` with the buffer's `data` in base64 streamed
/// into its URI a chunk at a time (built whole it would be a third larger than the buffer,
/// and copied into the document). The URI is found by its member's unescaped quotes,
/// which no string value can hold.
fn write_embedded(text: &[u8], data: &[u8], out: &mut impl Write) -> Result<()> {
    let marker = format!("\"uri\":\"{DATA_URI}");
    let split = text
        .windows(marker.len())
        .rposition(|w| w == marker.as_bytes())
        .map_or(text.len(), |at| at + marker.len());
    let (head, tail) = text.split_at(split);
    buffered(out, |out| {
        out.write_all(head)?;
        for chunk in data.chunks(3 << 14) {
            out.write_all(base64::encode(chunk).as_bytes())?;
        }
        out.write_all(tail)
    })
}

/// Writes a `.glb`: the header, the JSON chunk (`text` padded with spaces) and, when
/// there is data, the binary chunk (padded with zeros).
fn write_glb(mut text: Vec<u8>, mut bin: Vec<u8>, out: &mut impl Write) -> Result<()> {
    text.resize(text.len().next_multiple_of(4), b' ');
    bin.resize(bin.len().next_multiple_of(4), 0);
    let binary = !bin.is_empty();
    let total = GLB_HEADER_BYTES + 8 + text.len() + if binary { 8 + bin.len() } else { 0 };
    let word = |v: usize| {
        u32::try_from(v)
            .map(u32::to_le_bytes)
            .map_err(|_| Error::FormatCannotStore {
                format: FileFormat::Gltf(GltfContainer::Binary),
                what: format!("{total} bytes (a .glb counts up to 2^32 − 1; write .gltf)"),
            })
    };
    let words = [word(total)?, word(text.len())?, word(bin.len())?];
    buffered(out, |out| {
        out.write_all(GLB_MAGIC)?;
        out.write_all(&2u32.to_le_bytes())?;
        out.write_all(&words[0])?;
        out.write_all(&words[1])?;
        out.write_all(&JSON_CHUNK.to_le_bytes())?;
        out.write_all(&text)?;
        if binary {
            out.write_all(&words[2])?;
            out.write_all(&BIN_CHUNK.to_le_bytes())?;
            out.write_all(&bin)?;
        }
        Ok(())
    })
}
