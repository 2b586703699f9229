//! glTF 2.0: round trips through both containers, files laid out as other writers lay them
//! out (interleaved views, normalised integers, strips and fans, sparse accessors, node
//! trees), what the reader says it could not keep, and every refusal.

use glam::{DMat3, DQuat, DVec3, Vec2, Vec3};
use pointset_core::io::{
    self, FileFormat, Geometry, GltfContainer, ReadOptions, WriteOptions, read_gltf,
};
use pointset_core::{Attribute, Error, PointSet, ScalarType, TriMesh};
use proptest::prelude::*;
use serde_json::{Value, json};

use super::pcd_codec::by_name;
use super::streamed_files::read_from_file_and_bytes;
use super::{point_set_strategy, read};

const CONTAINERS: [(GltfContainer, &str); 2] = [
    (GltfContainer::Binary, "g.glb"),
    (GltfContainer::Json, "g.gltf"),
];

/// `geometry` encoded in `container`.
fn encoded(geometry: &Geometry, container: GltfContainer, options: &WriteOptions) -> Vec<u8> {
    io::encode_geometry(geometry, FileFormat::Gltf(container), options).unwrap()
}

/// A `.glb` of `document` with `bin` as its binary chunk, as another writer would make it.
fn glb(document: &Value, bin: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(document).unwrap();
    text.resize(text.len().next_multiple_of(4), b' ');
    let mut bin = bin.to_vec();
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = b"glTF".to_vec();
    for word in [2, total, text.len(), 0x4E4F_534A] {
        out.extend_from_slice(&(word as u32).to_le_bytes());
    }
    out.extend_from_slice(&text);
    for word in [bin.len(), 0x004E_4942] {
        out.extend_from_slice(&(word as u32).to_le_bytes());
    }
    out.extend_from_slice(&bin);
    out
}

/// Little-endian bytes of `values`.
fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// A unit quad in the x–y plane as four positions (12 floats).
const QUAD: [f32; 12] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];

/// A document drawing `QUAD`'s four vertices (accessor 0, view 0 of `len` bytes) with
/// `primitive`'s other members, placed by `nodes` (their first is the scene's root).
fn quad_document(primitive: Value, nodes: Value, extra_accessors: Value, views: Value) -> Value {
    let mut accessors = vec![json!({
        "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
        "min": [0, 0, 0], "max": [1, 1, 0]
    })];
    accessors.extend(extra_accessors.as_array().cloned().unwrap_or_default());
    let mut all_views = vec![json!({"buffer": 0, "byteLength": 48})];
    all_views.extend(views.as_array().cloned().unwrap_or_default());
    let mut primitive = primitive;
    primitive["attributes"]["POSITION"] = json!(0);
    json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": 4096}],
        "bufferViews": all_views,
        "accessors": accessors,
        "meshes": [{"primitives": [primitive]}],
        "nodes": nodes,
        "scenes": [{"nodes": [0]}],
    })
}

/// The binary chunk of a [`quad_document`]: the quad's positions, then `rest` from byte
/// 48, padded to the buffer's 4096 bytes.
fn quad_bin(rest: &[u8]) -> Vec<u8> {
    let mut bin = f32_bytes(&QUAD);
    bin.extend_from_slice(rest);
    bin.resize(4096, 0);
    bin
}

proptest! {
    #[test]
    fn point_sets_round_trip_through_both_containers(points in point_set_strategy()) {
        let geometry = Geometry::Points(points.clone());
        let options = WriteOptions::default().comment("a test");
        for (container, name) in CONTAINERS {
            let back = read(name, &encoded(&geometry, container, &options)).unwrap();
            prop_assert_eq!(back.format, FileFormat::Gltf(container));
            prop_assert_eq!(&back.comments, &["a test".to_string()]);
            prop_assert!(back.notes.is_empty(), "{:?}", back.notes);
            let got = back.geometry.points();
            prop_assert!(back.geometry.mesh().is_none());
            prop_assert_eq!(got.positions(), points.positions());
            prop_assert_eq!(got.normals(), points.normals());
            prop_assert_eq!(by_name(got), by_name(&points));
        }
    }

    #[test]
    fn meshes_round_trip_with_uvs(points in point_set_strategy(), seed in any::<u64>()) {
        let n = points.len() as u32;
        let triangles: Vec<[u32; 3]> = (0..n)
            .map(|i| [i, (i * 7 + 1 + (seed % 5) as u32) % n, (i * 3 + 2) % n])
            .collect();
        let uvs: Vec<Vec2> = (0..n).map(|i| Vec2::new(i as f32 * 0.25, 0.5 - i as f32 * 0.125)).collect();
        let mesh = TriMesh::new(points.clone(), triangles.clone()).unwrap().with_uvs(uvs.clone()).unwrap();
        let geometry = Geometry::Mesh(mesh);
        for (container, name) in CONTAINERS {
            let back = read(name, &encoded(&geometry, container, &WriteOptions::default())).unwrap();
            let mesh = back.geometry.mesh().unwrap();
            prop_assert_eq!(mesh.triangles(), &triangles[..]);
            prop_assert_eq!(mesh.positions(), points.positions());
            prop_assert_eq!(by_name(mesh.vertices()), by_name(&points));
            // `v` is flipped on the way out and back: exact up to one rounding.
            for (got, want) in mesh.uvs().unwrap().iter().zip(&uvs) {
                prop_assert_eq!(got.x, want.x);
                prop_assert!((got.y - want.y).abs() <= 1e-6 * want.y.abs().max(1.0));
            }
        }
    }
}

#[test]
fn every_attribute_type_an_alpha_and_every_8_bit_colour_come_back() {
    let n = 256;
    let mut points =
        PointSet::new((0..n).map(|i| Vec3::new(i as f32, 0.5, -1.0)).collect()).unwrap();
    let channel = |f: fn(usize) -> usize| (0..n).map(|i| f(i) as f32).collect::<Vec<_>>();
    for (name, values) in [
        ("red", channel(|i| i)),
        ("green", channel(|i| 255 - i)),
        ("blue", channel(|i| (i * 7) % 256)),
        ("alpha", channel(|i| (i * 3) % 256)),
    ] {
        let attribute = Attribute::new(name, values).with_storage(ScalarType::U8);
        points.set_attribute(attribute).unwrap();
    }
    for (name, storage, value) in [
        ("a_i8", ScalarType::I8, -100.0),
        ("a_u8", ScalarType::U8, 200.0),
        ("a_i16", ScalarType::I16, -30000.0),
        ("a_u16", ScalarType::U16, 60000.0),
        ("a_f32", ScalarType::F32, 0.125),
    ] {
        let attribute = Attribute::new(name, vec![value; n]).with_storage(storage);
        points.set_attribute(attribute).unwrap();
    }
    let geometry = Geometry::Points(points.clone());
    for (container, name) in CONTAINERS {
        let back = read(
            name,
            &encoded(&geometry, container, &WriteOptions::default()),
        )
        .unwrap();
        assert_eq!(by_name(back.geometry.points()), by_name(&points), "{name}");
    }
    // 32-bit integers and doubles are written as floats (glTF has no such attribute type).
    let wide = PointSet::new(vec![Vec3::ZERO; 2])
        .unwrap()
        .with_attribute(Attribute::new("id", vec![7.0, 70000.0]).with_storage(ScalarType::U32))
        .unwrap();
    let bytes = encoded(
        &Geometry::Points(wide),
        GltfContainer::Binary,
        &WriteOptions::default(),
    );
    let id = read("w.glb", &bytes).unwrap();
    let id = id.geometry.points().attribute("id").cloned().unwrap();
    assert_eq!(
        (id.values(), id.storage()),
        (&[7.0, 70000.0][..], ScalarType::F32)
    );
}

#[test]
fn written_colours_are_linear_as_the_format_says() {
    // sRGB 128 is 21.6% linear: stored as 0.2158 × 65535 = 14,146 in the COLOR_0 accessor.
    let mut points = PointSet::new(vec![Vec3::ZERO]).unwrap();
    points.set_colors(&[[128.0 / 255.0, 1.0, 0.0]]).unwrap();
    let bytes = encoded(
        &Geometry::Points(points),
        GltfContainer::Json,
        &WriteOptions::default(),
    );
    let document: Value = serde_json::from_slice(&bytes).unwrap();
    let accessor = &document["accessors"]
        [document["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"]
            .as_u64()
            .unwrap() as usize];
    assert_eq!(accessor["componentType"], 5123);
    assert_eq!(accessor["normalized"], true);
    let uri = document["buffers"][0]["uri"].as_str().unwrap();
    assert!(uri.starts_with("data:application/octet-stream;base64,"));
    let view = &document["bufferViews"][accessor["bufferView"].as_u64().unwrap() as usize];
    // Six bytes of colour padded to a stride of eight, as vertex streams must be.
    assert_eq!(view["byteStride"], 8);
    let red_linear = ((128.0f64 / 255.0 + 0.055) / 1.055).powf(2.4);
    assert_eq!((red_linear * 65535.0).round(), 14146.0);
}

#[test]
fn the_far_origin_becomes_the_nodes_translation() {
    let origin = DVec3::new(512_345.0, 4_123_456.0, 80.0);
    let local = vec![Vec3::new(0.25, -0.5, 1.0), Vec3::new(-3.0, 2.0, 0.0)];
    let geometry = Geometry::Points(PointSet::new(local.clone()).unwrap());
    let options = WriteOptions::default().origin(origin);
    for (container, name) in CONTAINERS {
        let bytes = encoded(&geometry, container, &options);
        let recentre = ReadOptions::default().recentre_far(true);
        let back =
            io::read_geometry_bytes_with(std::path::Path::new(name), &bytes, &recentre).unwrap();
        for (p, q) in local.iter().zip(back.geometry.points().positions()) {
            let error = (q.as_dvec3() + back.origin - (p.as_dvec3() + origin)).abs();
            assert!(error.max_element() < 1e-6, "{name}: {error}");
        }
    }
}

#[test]
fn files_read_from_disk_equal_the_same_bytes_read_from_memory() {
    let points = PointSet::new(vec![Vec3::X, Vec3::Y]).unwrap();
    for (container, name) in CONTAINERS {
        let bytes = encoded(
            &Geometry::Points(points.clone()),
            container,
            &WriteOptions::default(),
        );
        let (from_file, from_bytes) = read_from_file_and_bytes(name, &bytes, false);
        assert_eq!(from_file.unwrap(), from_bytes.unwrap(), "{name}");
    }
}

#[test]
fn interleaved_normalised_and_sparse_data_are_read() {
    // View 1 interleaves a normal (3 floats) and an RGBA colour (4 normalised bytes), 16
    // bytes a vertex; accessor 3's sparse part moves vertex 2 to z = 5.
    let mut interleaved = Vec::new();
    for i in 0..4u8 {
        interleaved.extend(f32_bytes(&[0.0, 0.0, 1.0]));
        interleaved.extend([255, 0, 188, 64 * i]);
    }
    let mut rest = interleaved.clone();
    rest.extend([2u8, 0, 0, 0]); // sparse index (u8), padded
    rest.extend(f32_bytes(&[1.0, 1.0, 5.0])); // sparse value
    let document = quad_document(
        json!({"attributes": {"NORMAL": 1, "COLOR_0": 2}, "indices": 4, "mode": 4}),
        json!([{"mesh": 0}]),
        json!([
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 1, "byteOffset": 12, "componentType": 5121, "normalized": true,
             "count": 4, "type": "VEC4"},
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "sparse": {"count": 1, "indices": {"bufferView": 2, "componentType": 5121},
                        "values": {"bufferView": 3}}},
            {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ]),
        json!([
            {"buffer": 0, "byteOffset": 48, "byteLength": 64, "byteStride": 16},
            {"buffer": 0, "byteOffset": 112, "byteLength": 1},
            {"buffer": 0, "byteOffset": 116, "byteLength": 12},
            {"buffer": 0, "byteOffset": 128, "byteLength": 12}
        ]),
    );
    let mut rest_with_indices = rest;
    for i in [0u16, 1, 2, 0, 2, 3] {
        rest_with_indices.extend(i.to_le_bytes());
    }
    // The sparse accessor replaces POSITION.
    let mut document = document;
    document["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(3);
    let geometry = read_gltf(&glb(&document, &quad_bin(&rest_with_indices))).unwrap();
    let mesh = geometry.mesh().unwrap();
    assert_eq!(mesh.triangles(), [[0, 1, 2], [0, 2, 3]]);
    assert_eq!(mesh.positions()[2], Vec3::new(1.0, 1.0, 5.0));
    assert_eq!(mesh.positions()[3], Vec3::new(0.0, 1.0, 0.0));
    assert_eq!(mesh.vertices().normals().unwrap()[1], Vec3::Z);
    let points = mesh.vertices();
    let channel = |name: &str| points.attribute(name).unwrap().values().to_vec();
    // Linear 188/255 is sRGB 222.9; alpha is linear already.
    assert_eq!(channel("red"), [255.0; 4]);
    assert_eq!(channel("green"), [0.0; 4]);
    assert_eq!(channel("blue"), [223.0; 4]);
    assert_eq!(channel("alpha"), [0.0, 64.0, 128.0, 192.0]);
}

#[test]
fn strips_fans_and_points_draw_what_the_format_says() {
    for (mode, expected) in [
        (5, vec![[0, 1, 2], [1, 3, 2]]),
        (6, vec![[1, 2, 0], [2, 3, 0]]),
    ] {
        let document = quad_document(
            json!({"mode": mode}),
            json!([{"mesh": 0}]),
            json!([]),
            json!([]),
        );
        let geometry = read_gltf(&glb(&document, &quad_bin(&[]))).unwrap();
        assert_eq!(
            geometry.mesh().unwrap().triangles(),
            expected,
            "mode {mode}"
        );
    }
    // An indexed point primitive draws the vertices it lists, in its order.
    let document = quad_document(
        json!({"mode": 0, "indices": 1}),
        json!([{"mesh": 0}]),
        json!([{"bufferView": 1, "componentType": 5121, "count": 2, "type": "SCALAR"}]),
        json!([{"buffer": 0, "byteOffset": 48, "byteLength": 2}]),
    );
    let geometry = read_gltf(&glb(&document, &quad_bin(&[3, 1]))).unwrap();
    assert!(geometry.mesh().is_none());
    assert_eq!(
        geometry.points().positions(),
        [Vec3::new(0.0, 1.0, 0.0), Vec3::X]
    );
}

#[test]
fn node_transforms_compose_and_mirrors_reverse_the_corners() {
    // Root: translate by (10, 0, 0); child: rotate 90° about z, scale x by -2 (a mirror),
    // given as TRS; grandchild: a matrix moving by (0, 0, 3). Each places the quad.
    let rotation = DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2);
    let document = quad_document(
        json!({"attributes": {"NORMAL": 1}, "mode": 4, "indices": 2}),
        json!([
            {"mesh": 0, "translation": [10, 0, 0], "children": [1]},
            {"mesh": 0, "rotation": rotation.to_array(), "scale": [-2, 1, 1], "children": [2]},
            {"mesh": 0, "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,3,1]}
        ]),
        json!([
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5121, "count": 3, "type": "SCALAR"}
        ]),
        json!([
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 3}
        ]),
    );
    let mut rest = f32_bytes(&[[0.0, 0.6, 0.8].repeat(3), vec![f32::NAN; 3]].concat());
    rest.extend([0u8, 1, 2, 0]);
    let loaded = read("t.glb", &glb(&document, &quad_bin(&rest))).unwrap();
    let mesh = loaded.geometry.mesh().unwrap();
    assert_eq!(mesh.vertex_count(), 12);
    assert_eq!(mesh.triangles(), [[0, 1, 2], [4, 6, 5], [8, 10, 9]]);
    // The fourth vertex's normal is NaN: kept as zero, once for the mesh's three instances.
    assert_eq!(mesh.vertices().normals().unwrap()[3], Vec3::ZERO);
    assert_eq!(
        loaded.notes,
        ["1 glTF normal not finite, kept as zero (no known direction)"]
    );
    // The child's world transform: translate (10,0,0) · R · S.
    let linear = DMat3::from_quat(rotation) * DMat3::from_diagonal(DVec3::new(-2.0, 1.0, 1.0));
    let p = |i: usize| mesh.positions()[i].as_dvec3();
    let expected = DVec3::new(10.0, 0.0, 0.0) + linear * DVec3::new(1.0, 1.0, 0.0);
    assert!((p(6) - expected).length() < 1e-6, "{} vs {expected}", p(6));
    assert!((p(10) - (expected + DVec3::new(0.0, 0.0, 3.0))).length() < 1e-6);
    // Normals through the inverse transpose, renormalised: a finite difference of the
    // transformed surface agrees (the normal stays perpendicular to transformed tangents).
    let normals = mesh.vertices().normals().unwrap();
    let n = normals[4].as_dvec3();
    assert!((n.length() - 1.0).abs() < 1e-6);
    for tangent in [DVec3::X, DVec3::new(0.0, 0.8, -0.6)] {
        // Both perpendicular to the stored normal (0, 0.6, 0.8).
        assert!(n.dot(linear * tangent).abs() < 1e-6, "{n}");
    }
}

#[test]
fn what_cannot_be_kept_is_said() {
    let document = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": 4096}],
        "bufferViews": [{"buffer": 0, "byteLength": 48}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"}],
        "meshes": [
            {"primitives": [
                {"attributes": {"POSITION": 0, "NORMAL": 0, "TANGENT": 0, "_DIR": 0},
                 "targets": [{}]},
                {"attributes": {"POSITION": 0}, "mode": 1},
                {"attributes": {"POSITION": 0}, "mode": 0}
            ]},
            {"primitives": [{"attributes": {"POSITION": 0}}]}
        ],
        "nodes": [{"mesh": 0}, {"mesh": 1, "skin": 0}],
        "scenes": [{"nodes": [0, 1]}, {"nodes": [0]}],
        "scene": 0,
    });
    let loaded = read("n.glb", &glb(&document, &quad_bin(&[]))).unwrap();
    let mesh = loaded.geometry.mesh().unwrap();
    assert_eq!((mesh.vertex_count(), mesh.face_count()), (8, 2));
    assert!(mesh.vertices().normals().is_none());
    let notes = loaded.notes.join("\n");
    for said in [
        "scene 0 read; the file's 1 other scene not",
        "1 skinned glTF mesh read in the rest pose",
        "1 glTF line primitive skipped",
        "morph targets of 1 glTF primitive not applied",
        "glTF vertex attributes skipped: TANGENT, _DIR",
        "1 glTF point primitive skipped beside the triangles",
        "not on every primitive, or whose names are taken, skipped: NORMAL",
    ] {
        assert!(notes.contains(said), "missing {said:?} in\n{notes}");
    }
}

#[test]
fn external_buffers_are_read_beside_the_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("quad data.bin"), f32_bytes(&QUAD)).unwrap();
    let mut document = quad_document(
        json!({"mode": 0}),
        json!([{"mesh": 0}]),
        json!([]),
        json!([]),
    );
    document["buffers"] = json!([{"byteLength": 48, "uri": "quad%20data.bin"}]);
    let path = dir.path().join("quad.gltf");
    std::fs::write(&path, serde_json::to_vec(&document).unwrap()).unwrap();
    let loaded = io::read_geometry(&path).unwrap();
    assert_eq!(
        loaded.geometry.points().positions()[2],
        Vec3::new(1.0, 1.0, 0.0)
    );
    // From bytes alone the file cannot be found; a missing file is named.
    let text = serde_json::to_vec(&document).unwrap();
    let error = read_gltf(&text).unwrap_err().to_string();
    assert!(error.contains("read the glTF file by its path"), "{error}");
    std::fs::remove_file(dir.path().join("quad data.bin")).unwrap();
    let error = io::read_geometry(&path).unwrap_err();
    assert!(
        matches!(error, Error::Io { ref path, .. } if path.ends_with("quad data.bin")),
        "{error}"
    );
}

/// The error reading `document` (with the quad's binary chunk) gives, as text.
fn refusal(document: &Value) -> String {
    read_gltf(&glb(document, &quad_bin(&[])))
        .unwrap_err()
        .to_string()
}

#[test]
fn broken_documents_are_refused_at_the_member_at_fault() {
    let good = quad_document(
        json!({"mode": 4}),
        json!([{"mesh": 0}]),
        json!([]),
        json!([]),
    );
    assert!(read_gltf(&glb(&good, &quad_bin(&[]))).is_ok());
    let edits: [(&str, Value, &str); 10] = [
        ("/asset/version", json!("1.0"), "asset.version"),
        ("/accessors/0/count", json!(400), "accessors[0].count"),
        (
            "/accessors/0/componentType",
            json!(5124),
            "accessors[0].componentType",
        ),
        ("/accessors/0/type", json!("MAT4"), "accessors[0].type"),
        (
            "/bufferViews/0/byteLength",
            json!(8000),
            "bufferViews[0].byteLength",
        ),
        (
            "/bufferViews/0/byteStride",
            json!(4),
            "bufferViews[0].byteStride",
        ),
        (
            "/meshes/0/primitives/0/mode",
            json!(9),
            "meshes[0].primitives[0].mode",
        ),
        ("/nodes/0/mesh", json!(3), "nodes[0].mesh"),
        ("/nodes/0/rotation", json!([0, 0, 0]), "nodes[0].rotation"),
        ("/scenes/0/nodes/0", json!(5), "scenes[0].nodes[0]"),
    ];
    for (pointer, value, at) in edits {
        let mut document = good.clone();
        let (parent, key) = pointer.rsplit_once('/').unwrap();
        match document.pointer_mut(parent).unwrap() {
            Value::Array(items) => items[key.parse::<usize>().unwrap()] = value,
            object => object[key] = value,
        }
        let error = refusal(&document);
        assert!(error.contains(&format!("at `{at}`")), "{pointer}: {error}");
    }
    let mut required = good.clone();
    required["extensionsRequired"] = json!(["KHR_mesh_quantization", "KHR_draco_mesh_compression"]);
    assert!(refusal(&required).contains("requires `KHR_draco_mesh_compression`"));
    let mut cycle = good.clone();
    cycle["nodes"] = json!([{"mesh": 0, "children": [1]}, {"children": [0]}]);
    assert!(
        refusal(&cycle).contains("reached twice"),
        "{}",
        refusal(&cycle)
    );
    let mut two_parents = good.clone();
    two_parents["nodes"] = json!([{"children": [2]}, {"children": [2]}, {"mesh": 0}]);
    assert!(refusal(&two_parents).contains("two parents"));
    let indices = quad_document(
        json!({"mode": 4, "indices": 1}),
        json!([{"mesh": 0}]),
        json!([{"bufferView": 1, "componentType": 5121, "count": 3, "type": "SCALAR"}]),
        json!([{"buffer": 0, "byteOffset": 48, "byteLength": 3}]),
    );
    let mut bin = quad_bin(&[0, 1, 9]);
    let error = read_gltf(&glb(&indices, &bin)).unwrap_err().to_string();
    assert!(error.contains("index 9 past the 4 vertices"), "{error}");
    bin.truncate(40);
    let error = read_gltf(&glb(&good, &bin)).unwrap_err().to_string();
    assert!(
        error.contains("buffers[0].byteLength") && error.contains("holds 40 bytes"),
        "{error}"
    );
    let mut zeros = good.clone();
    zeros["accessors"][0] = json!({"componentType": 5126, "count": 100_000_000, "type": "VEC3"});
    assert!(refusal(&zeros).contains("more than the file's"));
    let mut many = good.clone();
    many["nodes"] = json!([{"children": (1..=70).collect::<Vec<_>>()}]);
    for _ in 0..70 {
        many["nodes"]
            .as_array_mut()
            .unwrap()
            .push(json!({"mesh": 0}));
    }
    many["accessors"][0]["count"] = json!(4_000_000);
    assert!(
        refusal(&many).contains("vertices, more than"),
        "{}",
        refusal(&many)
    );
}

#[test]
fn broken_containers_are_refused_with_their_byte() {
    let good = quad_document(
        json!({"mode": 4}),
        json!([{"mesh": 0}]),
        json!([]),
        json!([]),
    );
    let bytes = glb(&good, &quad_bin(&[]));
    let mut version = bytes.clone();
    version[4] = 1;
    let error = read_gltf(&version).unwrap_err();
    assert!(
        error.to_string().contains("byte 4: GLB version 1"),
        "{error}"
    );
    let error = read_gltf(&bytes[..bytes.len() - 10]).unwrap_err();
    assert!(matches!(error, Error::HeaderExceedsFile { .. }), "{error}");
    let error = read_gltf(&bytes[..8]).unwrap_err();
    assert!(matches!(error, Error::UnexpectedEof { .. }), "{error}");
    let mut chunk = bytes.clone();
    chunk[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    let error = read_gltf(&chunk).unwrap_err().to_string();
    assert!(error.contains("a GLB chunk of 4294967295 bytes"), "{error}");
    let error = read_gltf(b"{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [").unwrap_err();
    assert!(matches!(error, Error::Malformed { .. }), "{error}");
    let error = read_gltf(b"{\"asset\": {\"version\": \"2.0\"}, \"buffers\": [{\"byteLength\": 4, \"uri\": \"data:;base64,A!==\"}]}")
        .unwrap_err()
        .to_string();
    assert!(error.contains("character 1 of the base64 data"), "{error}");
    let error = read_gltf(b"{\"asset\": {\"version\": \"2.0\"}, \"buffers\": [{\"byteLength\": 4, \"uri\": \"https://example.com/a.bin\"}]}")
        .unwrap_err()
        .to_string();
    assert!(error.contains("only data URIs and files beside"), "{error}");
}

#[test]
fn an_empty_point_set_and_a_mesh_without_faces_are_written() {
    let empty = Geometry::Points(PointSet::new(Vec::new()).unwrap());
    for (container, name) in CONTAINERS {
        let back = read(name, &encoded(&empty, container, &WriteOptions::default())).unwrap();
        assert_eq!(back.geometry, empty);
        assert_eq!(back.notes, ["the glTF scene places no triangles or points"]);
    }
    let bare = TriMesh::new(PointSet::new(vec![Vec3::X]).unwrap(), Vec::new()).unwrap();
    let bytes = encoded(
        &Geometry::Mesh(bare),
        GltfContainer::Binary,
        &WriteOptions::default(),
    );
    let back = read("b.glb", &bytes).unwrap();
    assert_eq!(back.geometry.points().positions(), [Vec3::X]);
}

#[test]
fn shared_meshes_round_trip_as_glb() {
    let Some(path) =
        pointset_core::testdata::shared_data("gltf_shared", "meshes/spot_triangulated.obj")
    else {
        return;
    };
    let loaded = io::read_geometry(&path).unwrap();
    let bytes = encoded(
        &loaded.geometry,
        GltfContainer::Binary,
        &WriteOptions::default(),
    );
    let back = read("spot.glb", &bytes).unwrap();
    let (a, b) = (
        loaded.geometry.mesh().unwrap(),
        back.geometry.mesh().unwrap(),
    );
    assert_eq!(a.positions(), b.positions());
    assert_eq!(a.triangles(), b.triangles());
    for (p, q) in a.uvs().unwrap().iter().zip(b.uvs().unwrap()) {
        assert!((*p - *q).abs().max_element() < 1e-6);
    }
}

/// Every JSON pointer into `value` (objects' members and arrays' items, nested).
fn pointers(value: &Value, at: String, out: &mut Vec<String>) {
    match value {
        Value::Object(members) => {
            for (key, member) in members {
                let path = format!("{at}/{key}");
                out.push(path.clone());
                pointers(member, path, out);
            }
        }
        Value::Array(items) => {
            for (k, item) in items.iter().enumerate() {
                let path = format!("{at}/{k}");
                out.push(path.clone());
                pointers(item, path, out);
            }
        }
        _ => {}
    }
}

/// Values a broken or hostile writer might put anywhere.
fn odd_value(pick: usize) -> Value {
    let values = [
        json!(-1),
        json!(0),
        json!(1),
        json!(2),
        json!(3),
        json!(5),
        json!(6),
        json!(7),
        json!(4_294_967_295u64),
        json!(1e300),
        json!(1.5),
        json!(-0.0),
        json!("x"),
        json!(null),
        json!([]),
        json!({}),
        json!(true),
        json!([0, 0, 0, 0]),
        json!([1e300, 0, 0]),
        json!(5126),
        json!(5121),
        json!("VEC2"),
        json!("SCALAR"),
    ];
    values[pick % values.len()].clone()
}

proptest! {
    /// A document whose members are replaced by odd values, anywhere, is read or refused
    /// with an error, never a panic; so is one whose members are removed.
    #[test]
    fn edited_documents_are_read_or_refused(
        picks in proptest::collection::vec((any::<usize>(), any::<usize>(), any::<bool>()), 1..5),
        binary in any::<bool>(),
    ) {
        let vertices = PointSet::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z])
            .unwrap()
            .with_normals(vec![Vec3::Z; 4])
            .unwrap()
            .with_attribute(Attribute::new("label", vec![1.0, 2.0, 3.0, 4.0]).with_storage(ScalarType::U8))
            .unwrap();
        let mut vertices = vertices;
        vertices.set_colors(&[[0.5, 0.25, 1.0]; 4]).unwrap();
        let mesh = TriMesh::new(vertices, vec![[0, 1, 2], [0, 2, 3]])
            .unwrap()
            .with_uvs(vec![Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE])
            .unwrap();
        let options = WriteOptions::default().origin(DVec3::new(1e6, 0.0, 0.0));
        let geometry = Geometry::Mesh(mesh);
        // The document and binary chunk of the .glb, or the .gltf's document.
        let (mut document, bin): (Value, Vec<u8>) = if binary {
            let file = encoded(&geometry, GltfContainer::Binary, &options);
            let word = |at: usize| u32::from_le_bytes(file[at..at + 4].try_into().unwrap()) as usize;
            let json_end = 20 + word(12);
            let document = serde_json::from_slice(&file[20..json_end]).unwrap();
            (document, file[json_end + 8..].to_vec())
        } else {
            let file = encoded(&geometry, GltfContainer::Json, &options);
            (serde_json::from_slice(&file).unwrap(), Vec::new())
        };
        for (path_pick, value_pick, remove) in picks {
            let mut all = Vec::new();
            pointers(&document, String::new(), &mut all);
            if all.is_empty() {
                break;
            }
            let target = &all[path_pick % all.len()];
            let (parent, key) = target.rsplit_once('/').unwrap();
            match document.pointer_mut(parent) {
                Some(Value::Object(members)) if remove => {
                    members.remove(key);
                }
                Some(Value::Object(members)) => {
                    members.insert(key.to_string(), odd_value(value_pick));
                }
                Some(Value::Array(items)) => {
                    let k: usize = key.parse().unwrap();
                    if remove {
                        items.remove(k);
                    } else {
                        items[k] = odd_value(value_pick);
                    }
                }
                _ => {}
            }
        }
        let bytes = if binary {
            glb(&document, &bin)
        } else {
            serde_json::to_vec(&document).unwrap()
        };
        let name = if binary { "e.glb" } else { "e.gltf" };
        if let Ok(loaded) = read(name, &bytes) {
            let points = loaded.geometry.points();
            prop_assert!(points.positions().iter().all(|p| p.is_finite()));
            if let Some(mesh) = loaded.geometry.mesh() {
                let n = mesh.vertex_count() as u32;
                prop_assert!(mesh.triangles().iter().flatten().all(|&v| v < n));
            }
        }
    }
}

#[test]
fn odd_application_attributes_are_kept_or_said() {
    // `_w` holds a NaN, `_my value` has a name no attribute may have, `_dir` three values
    // a point; all read from the quad's positions or the floats after them.
    let document = quad_document(
        json!({"mode": 0, "attributes": {"_w": 1, "_my value": 1, "_dir": 0}}),
        json!([{"mesh": 0}]),
        json!([{"bufferView": 1, "componentType": 5126, "count": 4, "type": "SCALAR"}]),
        json!([{"buffer": 0, "byteOffset": 48, "byteLength": 16}]),
    );
    let bin = quad_bin(&f32_bytes(&[1.0, f32::NAN, 3.0, 4.0]));
    let loaded = read("a.glb", &glb(&document, &bin)).unwrap();
    let w = loaded.geometry.points().attribute("w").unwrap();
    assert_eq!(w.values(), [1.0, 0.0, 3.0, 4.0]);
    assert_eq!(w.storage(), ScalarType::F32);
    assert_eq!(loaded.geometry.points().attributes().len(), 1);
    let notes = loaded.notes.join("\n");
    for said in [
        "glTF attribute `_w`: 1 value not finite, kept as 0",
        "glTF vertex attributes skipped: _dir",
        "skipped: _my value",
    ] {
        assert!(notes.contains(said), "missing {said:?} in\n{notes}");
    }
}
