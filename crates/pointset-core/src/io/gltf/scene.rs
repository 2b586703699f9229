//! The scene's node tree, the meshes its nodes place, and their primitives merged into one
//! geometry (see the module docs of [`super`]).

use std::borrow::Cow;
use std::collections::hash_map::Entry;
use std::collections::{BTreeSet, HashMap};
use std::rc::Rc;

use glam::{DMat3, DMat4, DQuat, DVec3, Vec2, Vec3};

use super::MAX_GLTF_VERTICES;
use super::accessor::{Component, Elements, read_accessor};
use super::colour::linear_to_srgb;
use super::document::{Document, Member};
use crate::io::{Geometry, finite_or_zero, relative_positions};
use crate::{Attribute, COLOR_CHANNELS, PointSet, RESERVED_NAMES, Result, ScalarType, TriMesh};

/// A mesh placed in the scene by a node.
struct Instance {
    mesh: usize,
    /// The node's transform and its ancestors'.
    world: DMat4,
}

/// The transform a node's `matrix`, or its `translation`, `rotation` and `scale`, give.
fn local_transform(node: &Member<'_>) -> Result<DMat4> {
    if let Some(m) = node.numbers::<16>("matrix")? {
        return Ok(DMat4::from_cols_array(&m));
    }
    let t = node.numbers::<3>("translation")?.unwrap_or([0.0; 3]);
    let r = node
        .numbers::<4>("rotation")?
        .unwrap_or([0.0, 0.0, 0.0, 1.0]);
    let s = node.numbers::<3>("scale")?.unwrap_or([1.0; 3]);
    let q = DQuat::from_array(r);
    if q.length() == 0.0 {
        return Err(node.invalid("rotation", "a zero quaternion is no rotation"));
    }
    Ok(DMat4::from_scale_rotation_translation(
        DVec3::from(s),
        q.normalize(),
        DVec3::from(t),
    ))
}

/// The meshes the scene places (see the module docs of [`super`] for which scene).
fn instances(document: &Document, notes: &mut Vec<String>) -> Result<Vec<Instance>> {
    let nodes = document.items("nodes")?;
    let node_index = |item: &Member<'_>| -> Result<usize> {
        let i = item.as_index()?;
        if i < nodes.len() {
            Ok(i)
        } else {
            Err(item.invalid(
                "",
                format!("refers to nodes[{i}], but the file has {}", nodes.len()),
            ))
        }
    };
    let mut children = vec![Vec::new(); nodes.len()];
    let mut has_parent = vec![false; nodes.len()];
    for (i, node) in nodes.iter().enumerate() {
        for child in node.array("children")? {
            let c = node_index(&child)?;
            if c == i || has_parent[c] {
                return Err(child.invalid(
                    "",
                    format!("nodes[{c}] would have two parents, or be its own child"),
                ));
            }
            has_parent[c] = true;
            children[i].push(c);
        }
    }
    let scenes = document.items("scenes")?;
    let roots: Vec<usize> = if scenes.is_empty() {
        (0..nodes.len()).filter(|&i| !has_parent[i]).collect()
    } else {
        let chosen = document.root().index("scene")?.unwrap_or(0);
        let scene = document.item("scenes", chosen, "scene")?;
        if scenes.len() > 1 {
            let others = counted(scenes.len() - 1, "other scene", "other scenes");
            notes.push(format!("glTF scene {chosen} read; the file's {others} not"));
        }
        scene
            .array("nodes")?
            .iter()
            .map(node_index)
            .collect::<Result<_>>()?
    };
    let mut visited = vec![false; nodes.len()];
    let mut stack: Vec<(usize, DMat4)> =
        roots.iter().rev().map(|&r| (r, DMat4::IDENTITY)).collect();
    let mut placed = Vec::new();
    let mut skinned = 0;
    while let Some((i, parent)) = stack.pop() {
        let node = &nodes[i];
        if visited[i] {
            return Err(node.invalid(
                "",
                "reached twice from the scene's roots (a root listed twice, or the child of \
                 another root, or a cycle)",
            ));
        }
        visited[i] = true;
        let world = parent * local_transform(node)?;
        if let Some(mesh) = node.index("mesh")? {
            document.item("meshes", mesh, &node.path_of("mesh"))?;
            skinned += usize::from(node.has("skin"));
            placed.push(Instance { mesh, world });
        }
        stack.extend(children[i].iter().rev().map(|&c| (c, world)));
    }
    if skinned > 0 {
        let meshes = counted(skinned, "skinned glTF mesh", "skinned glTF meshes");
        notes.push(format!(
            "{meshes} read in the rest pose (skins not applied)"
        ));
    }
    Ok(placed)
}

/// What a primitive draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Draws {
    Points,
    Lines,
    Triangles,
}

/// One primitive's vertices and faces, in its mesh's coordinates.
struct Part {
    positions: Vec<DVec3>,
    normals: Option<Vec<Vec3>>,
    colours: Option<Colours>,
    uvs: Option<Vec<Vec2>>,
    attributes: Vec<(String, ScalarType, Vec<f32>)>,
    /// `None` for points.
    triangles: Option<Vec<[u32; 3]>>,
}

/// A primitive's colours as every other format keeps them.
#[derive(Clone)]
struct Colours {
    /// sRGB red, green, blue in `0..=255`.
    rgb: Vec<[f32; 3]>,
    /// Alpha in `0..=255`, when the colours have it.
    alpha: Option<Vec<f32>>,
}

/// What reading primitives notes, each said once.
#[derive(Default)]
struct Skipped {
    attributes: BTreeSet<String>,
    line_primitives: usize,
    morphed: usize,
    /// Normals that were not finite, kept as zero.
    unknown_normals: usize,
}

/// The vertex stream of attribute `semantic` (accessor `index`), which must have `count`
/// elements of one of `kinds`.
fn stream(
    read: &mut impl FnMut(usize, &str, &[&str]) -> Result<Rc<Elements>>,
    attributes: &Member<'_>,
    semantic: &str,
    index: usize,
    count: usize,
    kinds: &[&str],
) -> Result<Rc<Elements>> {
    let elements = read(index, &attributes.path_of(semantic), kinds)?;
    if elements.count() != count {
        return Err(attributes.invalid(
            semantic,
            format!("{} elements, but POSITION has {count}", elements.count()),
        ));
    }
    Ok(elements)
}

/// The storage of an application attribute's values.
fn storage_of(elements: &Elements) -> ScalarType {
    if elements.normalized {
        ScalarType::F32
    } else {
        elements.component.scalar()
    }
}

/// The element kinds the vertex attribute `semantic` may have; `None` for one not read.
fn kinds_of(semantic: &str) -> Option<&'static [&'static str]> {
    match semantic {
        "POSITION" | "NORMAL" => Some(&["VEC3"]),
        "COLOR_0" => Some(&["VEC3", "VEC4"]),
        "TEXCOORD_0" => Some(&["VEC2"]),
        // Application attributes: any kind is read, one value a point kept.
        name if name.len() > 1 && name.starts_with('_') => {
            Some(&["SCALAR", "VEC2", "VEC3", "VEC4"])
        }
        _ => None,
    }
}

/// Reads primitive `primitive` (`None` when it draws lines).
fn read_part(
    primitive: &Member<'_>,
    read: &mut impl FnMut(usize, &str, &[&str]) -> Result<Rc<Elements>>,
    skipped: &mut Skipped,
) -> Result<Option<Part>> {
    let mode = primitive.index("mode")?.unwrap_or(4);
    let draws = match mode {
        0 => Draws::Points,
        1..=3 => Draws::Lines,
        4..=6 => Draws::Triangles,
        _ => return Err(primitive.invalid("mode", format!("{mode} is not a glTF mode"))),
    };
    if draws == Draws::Lines {
        skipped.line_primitives += 1;
        return Ok(None);
    }
    if primitive.has("targets") {
        skipped.morphed += 1;
    }
    let attributes = primitive
        .object("attributes")?
        .ok_or_else(|| primitive.invalid("attributes", "missing (required)"))?;
    let position = attributes.required_index("POSITION")?;
    let positions = read(position, &attributes.path_of("POSITION"), &["VEC3"])?;
    let count = positions.count();
    let mut part = Part {
        positions: (0..count)
            .map(|i| DVec3::from_slice(positions.element(i)))
            .collect(),
        normals: None,
        colours: None,
        uvs: None,
        attributes: Vec::new(),
        triangles: None,
    };
    for (semantic, value) in primitive.entries("attributes")? {
        let Some(kinds) = kinds_of(&semantic) else {
            skipped.attributes.insert(semantic);
            continue;
        };
        let elements = stream(
            read,
            &attributes,
            &semantic,
            value.as_index()?,
            count,
            kinds,
        )?;
        part.take(&semantic, &elements, skipped);
    }
    let order = read_indices(primitive, read, count)?;
    match (draws, order) {
        (Draws::Triangles, order) => {
            let order = order.unwrap_or_else(|| (0..count as u32).collect());
            part.triangles = Some(triangles(&order, mode));
        }
        (_, Some(order)) => part = part.picked(&order),
        (_, None) => {}
    }
    Ok(Some(part))
}

/// The vertex order a primitive's `indices` give (`None` without them), each checked to
/// be one of its `count` vertices.
fn read_indices(
    primitive: &Member<'_>,
    read: &mut impl FnMut(usize, &str, &[&str]) -> Result<Rc<Elements>>,
    count: usize,
) -> Result<Option<Vec<u32>>> {
    let Some(index) = primitive.index("indices")? else {
        return Ok(None);
    };
    let elements = read(index, &primitive.path_of("indices"), &["SCALAR"])?;
    let integers = matches!(
        elements.component,
        Component::U8 | Component::U16 | Component::U32
    );
    if !integers || elements.normalized {
        return Err(primitive.invalid(
            "indices",
            "indices must be unsigned 8-, 16- or 32-bit integers",
        ));
    }
    if let Some(bad) = elements.values.iter().find(|&&v| v as usize >= count) {
        return Err(primitive.invalid("indices", format!("index {bad} past the {count} vertices")));
    }
    Ok(Some(elements.values.iter().map(|&v| v as u32).collect()))
}

/// The triangles a `TRIANGLES` (4), `TRIANGLE_STRIP` (5) or `TRIANGLE_FAN` (6) list of
/// vertices draws, in the format's corner order.
fn triangles(v: &[u32], mode: usize) -> Vec<[u32; 3]> {
    match mode {
        5 => (0..v.len().saturating_sub(2))
            .map(|i| {
                let odd = i % 2;
                [v[i], v[i + 1 + odd], v[i + 2 - odd]]
            })
            .collect(),
        6 => (0..v.len().saturating_sub(2))
            .map(|i| [v[i + 1], v[i + 2], v[0]])
            .collect(),
        _ => v.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
    }
}

impl Part {
    /// Keeps the vertex stream `semantic` (its `elements`, one a vertex) as geosynth
    /// holds it: normals (not finite: zero), colours from linear to sRGB bytes, UVs with
    /// `v` flipped, application attributes of one value a point.
    fn take(&mut self, semantic: &str, elements: &Elements, skipped: &mut Skipped) {
        let count = elements.count();
        match semantic {
            "NORMAL" => {
                let normal = |i| {
                    let v = DVec3::from_slice(elements.element(i)).as_vec3();
                    if v.is_finite() {
                        v
                    } else {
                        skipped.unknown_normals += 1;
                        Vec3::ZERO
                    }
                };
                self.normals = Some((0..count).map(normal).collect());
            }
            "COLOR_0" => {
                let byte = |v: f64| (v.clamp(0.0, 1.0) * 255.0).round() as f32;
                let rgb = (0..count)
                    .map(|i| {
                        let e = elements.element(i);
                        [0, 1, 2].map(|k| byte(linear_to_srgb(e[k])))
                    })
                    .collect();
                let alpha = (elements.components == 4)
                    .then(|| (0..count).map(|i| byte(elements.element(i)[3])).collect());
                self.colours = Some(Colours { rgb, alpha });
            }
            "TEXCOORD_0" => {
                let uv = |i| {
                    let e = elements.element(i);
                    Vec2::new(e[0] as f32, (1.0 - e[1]) as f32)
                };
                self.uvs = Some((0..count).map(uv).collect());
            }
            name if name.starts_with('_') && elements.components == 1 => {
                let values = elements.values.iter().map(|&v| v as f32).collect();
                let storage = storage_of(elements);
                self.attributes
                    .push((name[1..].to_string(), storage, values));
            }
            "POSITION" => {}
            _ => {
                skipped.attributes.insert(semantic.to_string());
            }
        }
    }

    /// The points drawn in `order` (an indexed `POINTS` primitive).
    fn picked(self, order: &[u32]) -> Part {
        let pick = |values: &Vec<f32>| order.iter().map(|&i| values[i as usize]).collect();
        Part {
            positions: order.iter().map(|&i| self.positions[i as usize]).collect(),
            normals: self
                .normals
                .map(|n| order.iter().map(|&i| n[i as usize]).collect()),
            colours: self.colours.map(|c| Colours {
                rgb: order.iter().map(|&i| c.rgb[i as usize]).collect(),
                alpha: c.alpha.as_ref().map(pick),
            }),
            uvs: None,
            attributes: self
                .attributes
                .iter()
                .map(|(name, storage, values)| (name.clone(), *storage, pick(values)))
                .collect(),
            triangles: None,
        }
    }

    /// The part placed by `world`.
    fn placed(&self, world: &DMat4) -> Part {
        let linear = DMat3::from_mat4(*world);
        let det = linear.determinant();
        // The cofactor matrix is the inverse transpose times the determinant, and exists
        // for singular transforms too; the determinant's sign keeps normals outward.
        let cofactor = DMat3::from_cols(
            linear.y_axis.cross(linear.z_axis),
            linear.z_axis.cross(linear.x_axis),
            linear.x_axis.cross(linear.y_axis),
        ) * if det < 0.0 { -1.0 } else { 1.0 };
        let mirrored = det < 0.0;
        Part {
            positions: self
                .positions
                .iter()
                .map(|&p| world.transform_point3(p))
                .collect(),
            normals: self.normals.as_ref().map(|normals| {
                if linear == DMat3::IDENTITY {
                    return normals.clone();
                }
                normals
                    .iter()
                    .map(|n| {
                        let n = n.as_dvec3();
                        ((cofactor * n).normalize_or_zero() * n.length()).as_vec3()
                    })
                    .collect()
            }),
            colours: self.colours.clone(),
            uvs: self.uvs.clone(),
            attributes: self.attributes.clone(),
            triangles: self.triangles.as_ref().map(|t| {
                t.iter()
                    .map(|&[a, b, c]| if mirrored { [a, c, b] } else { [a, b, c] })
                    .collect()
            }),
        }
    }
}

/// Every primitive of the scene, placed, with what was skipped noted.
fn placed_parts(
    document: &Document,
    buffers: &[Cow<'_, [u8]>],
    file_len: usize,
    notes: &mut Vec<String>,
) -> Result<Vec<Part>> {
    let placed = instances(document, notes)?;
    // The vertices every instance will hold, from the accessors' counts, before reading.
    let mut total = 0usize;
    for instance in &placed {
        let mesh = document.item("meshes", instance.mesh, "nodes")?;
        for primitive in mesh.array("primitives")? {
            if let Some(attributes) = primitive.object("attributes")?
                && let Some(position) = attributes.index("POSITION")?
            {
                let accessor =
                    document.item("accessors", position, &attributes.path_of("POSITION"))?;
                total = total.saturating_add(accessor.required_index("count")?);
            }
        }
    }
    if total > MAX_GLTF_VERTICES {
        return Err(super::document::invalid(
            document.container(),
            "nodes",
            format!("the scene places {total} vertices, more than the {MAX_GLTF_VERTICES} read"),
        ));
    }
    // Accessors shared by primitives are decoded once for each use's kinds.
    let mut cache: HashMap<(usize, String), Rc<Elements>> = HashMap::new();
    let mut read = |index: usize, from: &str, kinds: &[&str]| -> Result<Rc<Elements>> {
        let key = (index, kinds.join(","));
        if let Some(elements) = cache.get(&key) {
            return Ok(Rc::clone(elements));
        }
        let elements = read_accessor(document, buffers, index, from, kinds, file_len)?;
        let elements = Rc::new(elements);
        cache.insert(key, Rc::clone(&elements));
        Ok(elements)
    };
    let mut skipped = Skipped::default();
    let mut meshes: HashMap<usize, Vec<Part>> = HashMap::new();
    let mut parts = Vec::new();
    for instance in &placed {
        let local = match meshes.entry(instance.mesh) {
            Entry::Occupied(read_before) => read_before.into_mut(),
            Entry::Vacant(slot) => {
                let mesh = document.item("meshes", instance.mesh, "nodes")?;
                let mut local = Vec::new();
                for primitive in mesh.array("primitives")? {
                    local.extend(read_part(&primitive, &mut read, &mut skipped)?);
                }
                slot.insert(local)
            }
        };
        parts.extend(local.iter().map(|p| p.placed(&instance.world)));
    }
    if skipped.line_primitives > 0 {
        let lines = counted(
            skipped.line_primitives,
            "glTF line primitive",
            "glTF line primitives",
        );
        notes.push(format!("{lines} skipped"));
    }
    if skipped.morphed > 0 {
        let morphed = counted(skipped.morphed, "glTF primitive", "glTF primitives");
        notes.push(format!(
            "morph targets of {morphed} not applied (base shape read)"
        ));
    }
    if skipped.unknown_normals > 0 {
        let normals = counted(skipped.unknown_normals, "glTF normal", "glTF normals");
        notes.push(format!(
            "{normals} not finite, kept as zero (no known direction)"
        ));
    }
    if !skipped.attributes.is_empty() {
        let names: Vec<&str> = skipped.attributes.iter().map(String::as_str).collect();
        notes.push(format!(
            "glTF vertex attributes skipped: {}",
            names.join(", ")
        ));
    }
    Ok(parts)
}

/// The scene's meshes (or points) merged into one geometry, with the origin its positions
/// are relative to (see [`crate::io::ReadOptions::recentre_far`]).
pub(super) fn merged_geometry(
    document: &Document,
    buffers: &[Cow<'_, [u8]>],
    file_len: usize,
    recentre_far: bool,
    notes: &mut Vec<String>,
) -> Result<(Geometry, DVec3)> {
    let mut parts = placed_parts(document, buffers, file_len, notes)?;
    let is_mesh = parts.iter().any(|p| p.triangles.is_some());
    if is_mesh {
        let points = parts.iter().filter(|p| p.triangles.is_none()).count();
        if points > 0 {
            let points = counted(points, "glTF point primitive", "glTF point primitives");
            notes.push(format!("{points} skipped beside the triangles"));
        }
        parts.retain(|p| p.triangles.is_some());
    }
    if parts.is_empty() {
        notes.push("the glTF scene places no triangles or points".to_string());
        return Ok((Geometry::Points(PointSet::default()), DVec3::ZERO));
    }
    let raw: Vec<DVec3> = parts
        .iter()
        .flat_map(|p| p.positions.iter().copied())
        .collect();
    let (relative, origin) = relative_positions(&raw, recentre_far);
    let mut points = PointSet::new(relative)?;
    let all = |has: &dyn Fn(&Part) -> bool| parts.iter().all(has);
    let some = |has: &dyn Fn(&Part) -> bool| parts.iter().any(has);
    let mut partial = Vec::new();
    if all(&|p| p.normals.is_some()) {
        let normals = parts
            .iter()
            .flat_map(|p| p.normals.iter().flatten().copied());
        points.set_normals(Some(normals.collect()))?;
    } else if some(&|p| p.normals.is_some()) {
        partial.push("NORMAL".to_string());
    }
    let has_colours = all(&|p| p.colours.is_some());
    if has_colours {
        let rgb: Vec<[f32; 3]> = parts
            .iter()
            .flat_map(|p| p.colours.iter().flat_map(|c| c.rgb.iter().copied()))
            .collect();
        for (k, name) in COLOR_CHANNELS.iter().enumerate() {
            let values = rgb.iter().map(|c| c[k]).collect();
            points.set_attribute(Attribute::new(*name, values).with_storage(ScalarType::U8))?;
        }
        if all(&|p| p.colours.as_ref().is_some_and(|c| c.alpha.is_some())) {
            let alpha = parts.iter().flat_map(|p| {
                p.colours
                    .iter()
                    .flat_map(|c| c.alpha.iter().flatten().copied())
            });
            points.set_attribute(
                Attribute::new("alpha", alpha.collect()).with_storage(ScalarType::U8),
            )?;
        }
    } else if some(&|p| p.colours.is_some()) {
        partial.push("COLOR_0".to_string());
    }
    merge_attributes(&parts, has_colours, &mut points, &mut partial, notes)?;
    let uvs = (is_mesh && all(&|p| p.uvs.is_some())).then(|| {
        let uvs = parts.iter().flat_map(|p| p.uvs.iter().flatten().copied());
        uvs.collect::<Vec<_>>()
    });
    if uvs.is_none() && some(&|p| p.uvs.is_some()) {
        // Points keep no UVs; a mesh keeps them only when every vertex has them.
        partial.push("TEXCOORD_0".to_string());
    }
    if !partial.is_empty() {
        notes.push(format!(
            "glTF vertex attributes not on every primitive, or whose names are taken, \
             skipped: {}",
            partial.join(", ")
        ));
    }
    if !is_mesh {
        return Ok((Geometry::Points(points), origin));
    }
    let mut offset = 0u32;
    let mut triangles = Vec::new();
    for part in &parts {
        let shift = |t: &[u32; 3]| t.map(|v| v + offset);
        triangles.extend(part.triangles.iter().flatten().map(shift));
        offset += part.positions.len() as u32;
    }
    let mut mesh = TriMesh::new(points, triangles)?;
    if let Some(uvs) = uvs {
        mesh = mesh.with_uvs(uvs)?;
    }
    Ok((Geometry::Mesh(mesh), origin))
}

/// Adds the application attributes every part has to `points`, each in the parts' common
/// storage (`f32` when they differ); names some parts lack, or that are taken (by
/// positions, normals or the colours) or invalid (with whitespace), go to `partial`.
/// Values that are not finite are kept as 0, with a note.
fn merge_attributes(
    parts: &[Part],
    has_colours: bool,
    points: &mut PointSet,
    partial: &mut Vec<String>,
    notes: &mut Vec<String>,
) -> Result<()> {
    let names: BTreeSet<&str> = parts
        .iter()
        .flat_map(|p| p.attributes.iter().map(|a| a.0.as_str()))
        .collect();
    for name in names {
        let columns: Vec<&(String, ScalarType, Vec<f32>)> = parts
            .iter()
            .filter_map(|p| p.attributes.iter().find(|a| a.0 == name))
            .collect();
        let taken = RESERVED_NAMES.contains(&name)
            || (has_colours && (COLOR_CHANNELS.contains(&name) || name == "alpha"));
        if columns.len() < parts.len() || taken || name.chars().any(char::is_whitespace) {
            partial.push(format!("_{name}"));
            continue;
        }
        let storage = columns[0].1;
        let storage = if columns.iter().all(|c| c.1 == storage) {
            storage
        } else {
            ScalarType::F32
        };
        let (values, not_finite) = finite_or_zero(columns.iter().flat_map(|c| c.2.iter().copied()));
        if not_finite > 0 {
            let values = counted(not_finite, "value", "values");
            notes.push(format!(
                "glTF attribute `_{name}`: {values} not finite, kept as 0"
            ));
        }
        points.set_attribute(Attribute::new(name, values).with_storage(storage))?;
    }
    Ok(())
}

/// `count` and the noun, `one` or `many` as the count asks: a note's subject.
fn counted(count: usize, one: &str, many: &str) -> String {
    format!("{count} {}", if count == 1 { one } else { many })
}
