//! Conversions between [`PlyDocument`] and the geometry types.
//!
//! Reading: the `vertex` element must have `x y z`; `nx ny nz` become normals; in files
//! with faces, `s t` (or `u v`, `texture_u texture_v`, `texture_s texture_t`) become UVs;
//! every other scalar vertex property becomes a named [`Attribute`] that remembers its
//! declared type. The `face` element's `vertex_indices` (or `vertex_index`) lists become
//! triangles, polygons split by [`crate::triangulate_polygon`] (fans when convex, ear
//! clipping when not). Other elements, list properties on vertices and other face
//! properties are skipped. Writing produces `float` positions/normals/UVs, attributes in
//! their storage type, and `list uchar int vertex_indices` faces — the layout MeshLab,
//! Blender and Open3D read.

use glam::{DVec3, Vec2, Vec3};

use super::view::DocumentView;
use super::{PlyColumn, PlyDocument, PlyElement, PlyEncoding, PropertyKind};
use crate::io::{FileFormat, Geometry, relative_positions};
use crate::{Attribute, Error, Location, PointSet, Result, TriMesh, triangulate_polygon};

const UV_NAMES: [(&str, &str); 4] = [
    ("s", "t"),
    ("u", "v"),
    ("texture_u", "texture_v"),
    ("texture_s", "texture_t"),
];

fn missing(message: &str) -> Error {
    Error::Malformed {
        format: FileFormat::Ply,
        location: Location::Line(1),
        message: message.to_string(),
    }
}

fn vec3s(e: &PlyElement, names: [&str; 3]) -> Option<Vec<Vec3>> {
    let [x, y, z] = names.map(|n| e.scalar(n));
    let (x, y, z) = (x?, y?, z?);
    Some(
        (0..e.count)
            .map(|i| Vec3::new(x[i] as f32, y[i] as f32, z[i] as f32))
            .collect(),
    )
}

/// What [`geometry_from_document`] leaves out of the geometry, in words: elements other
/// than `vertex` and `face` that hold records, list properties on vertices, and face
/// properties besides the index list (a mesh keeps values per vertex, not per face).
///
/// ```
/// use pointset_core::io::ply::{read_ply, skipped_parts};
/// let ply = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
///            property float z\nelement camera 1\nproperty float f\nend_header\n0 0 0\n35\n";
/// let doc = read_ply(ply.as_bytes())?;
/// assert_eq!(skipped_parts(&doc), ["element `camera` (1 record) skipped"]);
/// # Ok::<(), pointset_core::Error>(())
/// ```
pub fn skipped_parts(doc: &PlyDocument) -> Vec<String> {
    let mut notes = Vec::new();
    for element in doc.elements.iter().filter(|e| e.count > 0) {
        match element.name.as_str() {
            "vertex" => notes.extend(
                element
                    .properties
                    .iter()
                    .filter(|p| matches!(p.kind, PropertyKind::List { .. }))
                    .map(|p| format!("vertex list property `{}` skipped", p.name)),
            ),
            "face" => {
                let indices = if element.column("vertex_indices").is_some() {
                    "vertex_indices"
                } else {
                    "vertex_index"
                };
                notes.extend(
                    element
                        .properties
                        .iter()
                        .filter(|p| p.name != indices)
                        .map(|p| {
                            format!(
                                "face property `{}` skipped (a mesh keeps values per vertex, \
                                 not per face)",
                                p.name
                            )
                        }),
                );
            }
            name => notes.push(format!(
                "element `{name}` ({} record{}) skipped",
                element.count,
                if element.count == 1 { "" } else { "s" }
            )),
        }
    }
    notes
}

/// Turns a parsed document into a point set (no faces) or a mesh.
pub fn geometry_from_document(doc: &PlyDocument) -> Result<Geometry> {
    geometry_from_document_at(doc, false).map(|(geometry, _)| geometry)
}

/// [`geometry_from_document`], with positions stored relative to an origin when
/// `recentre_far` is set and the data lies far from the file's origin (see
/// [`crate::io::ReadOptions::recentre_far`]); returns the origin too.
pub fn geometry_from_document_at(
    doc: &PlyDocument,
    recentre_far: bool,
) -> Result<(Geometry, DVec3)> {
    let vertex = doc
        .element("vertex")
        .ok_or_else(|| missing("no `vertex` element"))?;
    let [x, y, z] = ["x", "y", "z"].map(|n| vertex.scalar(n));
    let (Some(x), Some(y), Some(z)) = (x, y, z) else {
        return Err(missing("vertex element lacks x, y or z"));
    };
    let raw: Vec<DVec3> = (0..vertex.count)
        .map(|i| DVec3::new(x[i], y[i], z[i]))
        .collect();
    let (positions, origin) = relative_positions(&raw, recentre_far);
    let faces = doc.element("face");
    let has_faces = faces.is_some_and(|f| f.count > 0);
    let uv_names = UV_NAMES
        .iter()
        .find(|(u, v)| vertex.scalar(u).is_some() && vertex.scalar(v).is_some())
        .filter(|_| has_faces);
    let mut consumed: Vec<&str> = vec!["x", "y", "z"];
    let mut points = PointSet::new(positions)?;
    if let Some(normals) = vec3s(vertex, ["nx", "ny", "nz"]) {
        points = points.with_normals(normals)?;
        consumed.extend(["nx", "ny", "nz"]);
    }
    if let Some((u, v)) = uv_names {
        consumed.extend([*u, *v]);
    }
    for (prop, column) in vertex.properties.iter().zip(&vertex.columns) {
        if let (PropertyKind::Scalar(ty), PlyColumn::Scalar(values)) = (prop.kind, column) {
            if consumed.contains(&prop.name.as_str()) {
                continue;
            }
            let values = values.iter().map(|&v| v as f32).collect();
            points.set_attribute(Attribute::new(prop.name.clone(), values).with_storage(ty))?;
        }
    }
    let Some(faces) = faces.filter(|_| has_faces) else {
        return Ok((Geometry::Points(points), origin));
    };
    let (_, column) = faces
        .column("vertex_indices")
        .or_else(|| faces.column("vertex_index"))
        .ok_or_else(|| missing("face element has no `vertex_indices` list"))?;
    let PlyColumn::List { offsets, items } = column else {
        return Err(missing("face `vertex_indices` is not a list"));
    };
    let vertex_count = points.len();
    let mut triangles = Vec::with_capacity(faces.count);
    for face in 0..faces.count {
        let list = &items[offsets[face]..offsets[face + 1]];
        if list.len() < 3 {
            return Err(Error::InvalidFace {
                face,
                reason: format!("{} vertex indices (at least 3 needed)", list.len()),
            });
        }
        let mut idx = Vec::with_capacity(list.len());
        for &v in list {
            if v.fract() != 0.0 {
                return Err(Error::InvalidFace {
                    face,
                    reason: format!("vertex index {v} is not a whole number"),
                });
            }
            if v < 0.0 || v >= vertex_count as f64 {
                return Err(Error::IndexOutOfRange {
                    face,
                    vertex: v as i64,
                    vertex_count,
                });
            }
            idx.push(v as u32);
        }
        triangulate_polygon(points.positions(), &idx, &mut triangles);
    }
    let mut mesh = TriMesh::new(points, triangles)?;
    if let Some((u, v)) = uv_names {
        let (u, v) = (vertex.scalar(u), vertex.scalar(v));
        if let (Some(u), Some(v)) = (u, v) {
            let uvs = u
                .iter()
                .zip(v)
                .map(|(&a, &b)| Vec2::new(a as f32, b as f32))
                .collect();
            mesh = mesh.with_uvs(uvs)?;
        }
    }
    Ok((Geometry::Mesh(mesh), origin))
}

/// Builds a document for a point set or mesh, with the given encoding and comments.
pub fn document_from_geometry(
    geometry: &Geometry,
    encoding: PlyEncoding,
    comments: &[String],
) -> Result<PlyDocument> {
    document_from_geometry_at(geometry, encoding, comments, DVec3::ZERO)
}

/// [`document_from_geometry`] with `origin` added to every position; the coordinates are
/// `double` properties when it is not zero (a `float` could not hold them).
pub fn document_from_geometry_at(
    geometry: &Geometry,
    encoding: PlyEncoding,
    comments: &[String],
    origin: DVec3,
) -> Result<PlyDocument> {
    Ok(DocumentView::of_geometry(geometry, encoding, comments, origin)?.to_document())
}
