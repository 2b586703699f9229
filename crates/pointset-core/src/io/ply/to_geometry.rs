//! PLY values turned into a point set or mesh as they are read (the rules are in the
//! `convert` module's docs). The byte reader sends the body here directly, so a file is
//! read without a [`PlyDocument`](super::PlyDocument) holding every value as `f64` (32
//! bytes a triangle, 24–48 a vertex, beside the geometry's 12 and 12–24);
//! [`geometry_from_document_at`](super::geometry_from_document_at) sends a document's
//! columns through the same rules.
//!
//! Faces are triangulated as they arrive, once the `vertex` element is complete; the byte
//! reader therefore takes files whose `face` element comes first through a document. The
//! errors of the conversion (a missing coordinate, a bad face) are kept and reported in a
//! document's order: after the whole body has been read (a file that is also truncated is
//! reported as truncated), the vertex layout's, then the point set's own checks, then the
//! faces'.

use glam::{DVec3, Vec2, Vec3};

use super::body::BodySink;
use super::{PlyProperty, PropertyKind};
use crate::io::{FileFormat, Geometry, relative_positions};
use crate::{
    Attribute, Error, Location, PointSet, Result, ScalarType, TriMesh, triangulate_polygon,
};

/// Pairs of vertex properties read as texture coordinates, in order of preference.
const UV_NAMES: [(&str, &str); 4] = [
    ("s", "t"),
    ("u", "v"),
    ("texture_u", "texture_v"),
    ("texture_s", "texture_t"),
];

/// The names of the face element's vertex index list, in order of preference.
const INDEX_NAMES: [&str; 2] = ["vertex_indices", "vertex_index"];

fn missing(message: &str) -> Error {
    Error::Malformed {
        format: FileFormat::Ply,
        location: Location::Line(1),
        message: message.to_string(),
    }
}

/// What one property's values become.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    /// Not kept.
    Skipped,
    /// A coordinate of the position (0, 1, 2).
    Position(usize),
    /// A coordinate of the normal.
    Normal(usize),
    /// A texture coordinate (0: u, 1: v).
    Uv(usize),
    /// The values of the attribute with this index.
    Attribute(usize),
    /// The face's vertex indices.
    Corners,
}

/// One element as the header declares it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Declared<'a> {
    /// Element name.
    pub(super) name: &'a str,
    /// Number of records.
    pub(super) count: usize,
    /// Declared properties.
    pub(super) properties: &'a [PlyProperty],
}

/// Builds a point set or mesh from the values of a PLY body, sent element by element.
#[derive(Debug)]
pub(super) struct GeometrySink {
    /// Per element, per property: what its values become.
    roles: Vec<Vec<Role>>,
    /// Index of the `vertex` element, if any.
    vertex: Option<usize>,
    /// Number of vertices declared.
    vertex_count: usize,
    recentre_far: bool,
    /// Positions as read, until the vertex element is complete.
    raw: Vec<DVec3>,
    /// Positions relative to `origin`, once the vertex element is complete.
    positions: Vec<Vec3>,
    origin: DVec3,
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    /// Attribute names, storage types and values.
    attributes: Vec<(String, ScalarType, Vec<f32>)>,
    /// Whether the file has faces (a `face` element with records).
    has_faces: bool,
    triangles: Vec<[u32; 3]>,
    /// The face being read, and the corners of its polygon.
    face: usize,
    corners: Vec<u32>,
    /// The first error found in the vertex element's layout, reported after the body.
    vertex_error: Option<Error>,
    /// The first error found in the faces, reported after the body and the point set's
    /// own checks.
    face_error: Option<Error>,
}

impl GeometrySink {
    /// A sink for a body with these elements (in file order).
    pub(super) fn new(elements: &[Declared<'_>], recentre_far: bool) -> Self {
        let vertex = elements.iter().position(|e| e.name == "vertex");
        let face = elements.iter().position(|e| e.name == "face");
        let has_faces = face.is_some_and(|f| elements[f].count > 0);
        let vertex_count = vertex.map_or(0, |v| elements[v].count);
        let mut sink = GeometrySink {
            roles: elements
                .iter()
                .map(|e| vec![Role::Skipped; e.properties.len()])
                .collect(),
            vertex,
            vertex_count,
            recentre_far,
            raw: Vec::new(),
            positions: Vec::new(),
            origin: DVec3::ZERO,
            normals: None,
            uvs: None,
            attributes: Vec::new(),
            has_faces,
            triangles: Vec::new(),
            face: 0,
            corners: Vec::new(),
            vertex_error: None,
            face_error: None,
        };
        match vertex {
            Some(v) => sink.assign_vertex_roles(v, elements[v].properties),
            None => sink.vertex_error = Some(missing("no `vertex` element")),
        }
        if let Some(f) = face.filter(|_| has_faces) {
            sink.assign_face_roles(f, elements[f]);
        }
        sink
    }

    /// Positions, normals (all three or none), texture coordinates (with faces only) and
    /// every other scalar property as an attribute; the first property of a name wins.
    fn assign_vertex_roles(&mut self, element: usize, properties: &[PlyProperty]) {
        let scalar_at = |name: &str| {
            properties
                .iter()
                .position(|p| p.name == name)
                .filter(|&i| matches!(properties[i].kind, PropertyKind::Scalar(_)))
        };
        let count = self.vertex_count;
        let mut consumed: Vec<&str> = Vec::new();
        let roles = &mut self.roles[element];
        let [x, y, z] = ["x", "y", "z"].map(scalar_at);
        if let (Some(x), Some(y), Some(z)) = (x, y, z) {
            for (axis, at) in [x, y, z].into_iter().enumerate() {
                roles[at] = Role::Position(axis);
            }
            self.raw = vec![DVec3::ZERO; count];
        } else {
            self.vertex_error = Some(missing("vertex element lacks x, y or z"));
        }
        consumed.extend(["x", "y", "z"]);
        if let [Some(x), Some(y), Some(z)] = ["nx", "ny", "nz"].map(scalar_at) {
            for (axis, at) in [x, y, z].into_iter().enumerate() {
                roles[at] = Role::Normal(axis);
            }
            self.normals = Some(vec![Vec3::ZERO; count]);
            consumed.extend(["nx", "ny", "nz"]);
        }
        let uv = UV_NAMES
            .iter()
            .find_map(|&(u, v)| Some((u, v, scalar_at(u)?, scalar_at(v)?)))
            .filter(|_| self.has_faces);
        if let Some((u, v, u_at, v_at)) = uv {
            roles[u_at] = Role::Uv(0);
            roles[v_at] = Role::Uv(1);
            self.uvs = Some(vec![Vec2::ZERO; count]);
            consumed.extend([u, v]);
        }
        for (at, property) in properties.iter().enumerate() {
            if let PropertyKind::Scalar(ty) = property.kind
                && !consumed.contains(&property.name.as_str())
            {
                roles[at] = Role::Attribute(self.attributes.len());
                let values = Vec::with_capacity(count);
                self.attributes.push((property.name.clone(), ty, values));
            }
        }
    }

    /// The face element's index list (`vertex_indices`, else `vertex_index`).
    fn assign_face_roles(&mut self, element: usize, declared: Declared<'_>) {
        let properties = declared.properties;
        let Some(at) = INDEX_NAMES
            .iter()
            .find_map(|&name| properties.iter().position(|p| p.name == name))
        else {
            self.keep_error(missing("face element has no `vertex_indices` list"));
            return;
        };
        if !matches!(properties[at].kind, PropertyKind::List { .. }) {
            self.keep_error(missing("face `vertex_indices` is not a list"));
            return;
        }
        self.roles[element][at] = Role::Corners;
        self.triangles.reserve(declared.count);
    }

    /// Keeps the face error `error` unless an earlier one is kept.
    fn keep_error(&mut self, error: Error) {
        self.face_error.get_or_insert(error);
    }

    /// Checks one face's vertex indices and adds its triangles.
    fn add_face(&mut self, items: &[f64]) {
        let face = self.face;
        self.face += 1;
        if self.face_error.is_some() || self.vertex_error.is_some() {
            return;
        }
        if items.len() < 3 {
            self.keep_error(Error::InvalidFace {
                face,
                reason: format!("{} vertex indices (at least 3 needed)", items.len()),
            });
            return;
        }
        self.corners.clear();
        for &v in items {
            if v.fract() != 0.0 {
                self.keep_error(Error::InvalidFace {
                    face,
                    reason: format!("vertex index {v} is not a whole number"),
                });
                return;
            }
            if v < 0.0 || v >= self.vertex_count as f64 {
                self.keep_error(Error::IndexOutOfRange {
                    face,
                    vertex: v as i64,
                    vertex_count: self.vertex_count,
                });
                return;
            }
            self.corners.push(v as u32);
        }
        triangulate_polygon(&self.positions, &self.corners, &mut self.triangles);
    }

    /// The point set or mesh, and the origin its positions are relative to.
    pub(super) fn finish(mut self) -> Result<(Geometry, DVec3)> {
        if let Some(error) = self.vertex_error.take() {
            return Err(error);
        }
        let mut points = PointSet::new(std::mem::take(&mut self.positions))?;
        if let Some(normals) = self.normals.take() {
            points = points.with_normals(normals)?;
        }
        for (name, ty, values) in std::mem::take(&mut self.attributes) {
            points.set_attribute(Attribute::new(name, values).with_storage(ty))?;
        }
        if !self.has_faces {
            return Ok((Geometry::Points(points), self.origin));
        }
        if let Some(error) = self.face_error.take() {
            return Err(error);
        }
        let mut mesh = TriMesh::new(points, std::mem::take(&mut self.triangles))?;
        if let Some(uvs) = self.uvs.take() {
            mesh = mesh.with_uvs(uvs)?;
        }
        Ok((Geometry::Mesh(mesh), self.origin))
    }
}

impl BodySink for GeometrySink {
    fn scalar(&mut self, element: usize, property: usize, record: usize, value: f64) {
        match self.roles[element][property] {
            Role::Position(axis) => self.raw[record][axis] = value,
            Role::Normal(axis) => {
                if let Some(normals) = &mut self.normals {
                    normals[record][axis] = value as f32;
                }
            }
            Role::Uv(axis) => {
                if let Some(uvs) = &mut self.uvs {
                    uvs[record][axis] = value as f32;
                }
            }
            Role::Attribute(index) => self.attributes[index].2.push(value as f32),
            Role::Skipped | Role::Corners => {}
        }
    }

    fn list(&mut self, element: usize, property: usize, items: &[f64]) {
        if self.roles[element][property] == Role::Corners {
            self.add_face(items);
        }
    }

    fn element_done(&mut self, element: usize) {
        if Some(element) == self.vertex {
            let raw = std::mem::take(&mut self.raw);
            (self.positions, self.origin) = relative_positions(&raw, self.recentre_far);
        }
    }
}
