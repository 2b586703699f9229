//! What the PLY writer writes, read where it is kept: a [`PlyDocument`]'s columns, or a
//! point set's or mesh's own arrays. Writing geometry through a view needs no copy of it
//! (a document holds every value as `f64`: about 32 bytes a triangle and 24–48 a vertex,
//! beside the geometry's 12 and 12–24), and building a document from geometry is the same
//! view materialized, so both give the same values.

use glam::{DVec3, Vec2, Vec3};

use super::{PlyColumn, PlyDocument, PlyElement, PlyEncoding, PlyProperty, PropertyKind};
use crate::io::Geometry;
use crate::{Error, Result, ScalarType, TriMesh};

/// The values of one property for every record, borrowed from where they are kept.
#[derive(Debug, Clone, Copy)]
pub(crate) enum ColumnView<'a> {
    /// A document's stored column.
    Stored(&'a PlyColumn),
    /// One component of 3-vectors, with an origin's coordinate added for positions.
    Component {
        /// The vectors.
        vectors: &'a [Vec3],
        /// 0, 1 or 2.
        axis: usize,
        /// Added to every value (positions, even when zero: −0 is then written as 0);
        /// `None` writes the values as they are (normals keep their −0).
        offset: Option<f64>,
    },
    /// One component of texture coordinates.
    UvComponent {
        /// The coordinates.
        uvs: &'a [Vec2],
        /// 0 (`s`) or 1 (`t`).
        axis: usize,
    },
    /// Scalars kept as `f32` (a named attribute's values).
    Floats(&'a [f32]),
    /// Triangles, each a list of its three vertex indices.
    Triangles(&'a [[u32; 3]]),
}

impl ColumnView<'_> {
    /// Number of records.
    pub(crate) fn len(&self) -> usize {
        match self {
            ColumnView::Stored(column) => column.len(),
            ColumnView::Component { vectors, .. } => vectors.len(),
            ColumnView::UvComponent { uvs, .. } => uvs.len(),
            ColumnView::Floats(values) => values.len(),
            ColumnView::Triangles(triangles) => triangles.len(),
        }
    }

    /// Record `record`'s value, or `None` for a list column. `record` must be below
    /// [`ColumnView::len`].
    pub(crate) fn scalar(&self, record: usize) -> Option<f64> {
        match self {
            ColumnView::Stored(PlyColumn::Scalar(values)) => Some(values[record]),
            ColumnView::Component {
                vectors,
                axis,
                offset,
            } => {
                let value = f64::from(vectors[record][*axis]);
                Some(offset.map_or(value, |offset| value + offset))
            }
            ColumnView::UvComponent { uvs, axis } => Some(f64::from(uvs[record][*axis])),
            ColumnView::Floats(values) => Some(f64::from(values[record])),
            ColumnView::Stored(PlyColumn::List { .. }) | ColumnView::Triangles(_) => None,
        }
    }

    /// Record `record`'s list, or `None` for a scalar column. `record` must be below
    /// [`ColumnView::len`].
    pub(crate) fn list(&self, record: usize) -> Option<ListView<'_>> {
        match self {
            ColumnView::Stored(PlyColumn::List { offsets, items }) => Some(ListView::Stored(
                &items[offsets[record]..offsets[record + 1]],
            )),
            ColumnView::Triangles(triangles) => Some(ListView::Triangle(&triangles[record])),
            _ => None,
        }
    }

    /// The values copied into a column of their own.
    fn to_column(self) -> PlyColumn {
        match self {
            ColumnView::Stored(column) => column.clone(),
            ColumnView::Triangles(triangles) => PlyColumn::List {
                offsets: (0..=triangles.len()).map(|i| 3 * i).collect(),
                items: triangles.iter().flat_map(|t| t.map(f64::from)).collect(),
            },
            scalars => PlyColumn::Scalar(
                (0..scalars.len())
                    .filter_map(|r| scalars.scalar(r))
                    .collect(),
            ),
        }
    }
}

/// One record's list.
#[derive(Debug, Clone, Copy)]
pub(crate) enum ListView<'a> {
    /// A document's stored items.
    Stored(&'a [f64]),
    /// A triangle's vertex indices.
    Triangle(&'a [u32; 3]),
}

impl ListView<'_> {
    /// Number of items.
    pub(crate) fn len(&self) -> usize {
        match self {
            ListView::Stored(items) => items.len(),
            ListView::Triangle(corners) => corners.len(),
        }
    }

    /// The items, in order.
    pub(crate) fn items(&self) -> impl Iterator<Item = f64> + '_ {
        let (stored, corners): (&[f64], &[u32]) = match self {
            ListView::Stored(items) => (items, &[]),
            ListView::Triangle(corners) => (&[], &corners[..]),
        };
        stored
            .iter()
            .copied()
            .chain(corners.iter().map(|&v| f64::from(v)))
    }
}

/// One element: its name, record count, and a view of each property's values.
#[derive(Debug, Clone)]
pub(crate) struct ElementView<'a> {
    /// Element name.
    pub(crate) name: String,
    /// Number of records.
    pub(crate) count: usize,
    /// Declared properties, in file order.
    pub(crate) properties: Vec<PlyProperty>,
    /// One view per property.
    pub(crate) columns: Vec<ColumnView<'a>>,
}

/// A whole file to write.
#[derive(Debug, Clone)]
pub(crate) struct DocumentView<'a> {
    /// Encoding of the body.
    pub(crate) encoding: PlyEncoding,
    /// `comment` lines.
    pub(crate) comments: &'a [String],
    /// `obj_info` lines.
    pub(crate) obj_info: &'a [String],
    /// Elements in file order.
    pub(crate) elements: Vec<ElementView<'a>>,
}

impl<'a> DocumentView<'a> {
    /// A view of a document's own columns.
    pub(crate) fn of_document(doc: &'a PlyDocument) -> Self {
        DocumentView {
            encoding: doc.encoding,
            comments: &doc.comments,
            obj_info: &doc.obj_info,
            elements: doc
                .elements
                .iter()
                .map(|e| ElementView {
                    name: e.name.clone(),
                    count: e.count,
                    properties: e.properties.clone(),
                    columns: e.columns.iter().map(ColumnView::Stored).collect(),
                })
                .collect(),
        }
    }

    /// A view of a point set or mesh as the `vertex` (and `face`) elements described in
    /// the `convert` module, with `origin` added to every position; the coordinates are
    /// `double` properties when it is not zero (a `float` could not hold them).
    pub(crate) fn of_geometry(
        geometry: &'a Geometry,
        encoding: PlyEncoding,
        comments: &'a [String],
        origin: DVec3,
    ) -> Result<Self> {
        let (points, mesh) = match geometry {
            Geometry::Points(p) => (p, None),
            Geometry::Mesh(m) => (m.vertices(), Some(m)),
        };
        let coordinate_type = if origin == DVec3::ZERO {
            ScalarType::F32
        } else {
            ScalarType::F64
        };
        let mut vertex = ElementView {
            name: "vertex".into(),
            count: points.len(),
            properties: Vec::new(),
            columns: Vec::new(),
        };
        for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
            vertex.push_scalar(
                name,
                coordinate_type,
                ColumnView::Component {
                    vectors: points.positions(),
                    axis,
                    offset: Some(origin[axis]),
                },
            );
        }
        if let Some(normals) = points.normals() {
            for (axis, name) in ["nx", "ny", "nz"].into_iter().enumerate() {
                vertex.push_scalar(
                    name,
                    ScalarType::F32,
                    ColumnView::Component {
                        vectors: normals,
                        axis,
                        offset: None,
                    },
                );
            }
        }
        if let Some(uvs) = mesh.and_then(TriMesh::uvs) {
            if points.attribute("s").is_some() || points.attribute("t").is_some() {
                return Err(Error::IncompatibleLayout {
                    reason: "attributes named `s`/`t` collide with the UV properties".into(),
                });
            }
            for (axis, name) in ["s", "t"].into_iter().enumerate() {
                vertex.push_scalar(name, ScalarType::F32, ColumnView::UvComponent { uvs, axis });
            }
        }
        for a in points.attributes() {
            vertex.push_scalar(a.name(), a.storage(), ColumnView::Floats(a.values()));
        }
        let mut elements = vec![vertex];
        if let Some(mesh) = mesh {
            let triangles = mesh.triangles();
            elements.push(ElementView {
                name: "face".into(),
                count: triangles.len(),
                properties: vec![PlyProperty {
                    name: "vertex_indices".into(),
                    kind: PropertyKind::List {
                        count: ScalarType::U8,
                        item: ScalarType::I32,
                    },
                }],
                columns: vec![ColumnView::Triangles(triangles)],
            });
        }
        Ok(DocumentView {
            encoding,
            comments,
            obj_info: &[],
            elements,
        })
    }

    /// The viewed values copied into a document of their own.
    pub(crate) fn to_document(&self) -> PlyDocument {
        PlyDocument {
            encoding: self.encoding,
            comments: self.comments.to_vec(),
            obj_info: self.obj_info.to_vec(),
            elements: self
                .elements
                .iter()
                .map(|e| PlyElement {
                    name: e.name.clone(),
                    count: e.count,
                    properties: e.properties.clone(),
                    columns: e.columns.iter().map(|c| c.to_column()).collect(),
                })
                .collect(),
        }
    }
}

impl<'a> ElementView<'a> {
    /// Appends a scalar property of type `ty` read from `values`.
    fn push_scalar(&mut self, name: &str, ty: ScalarType, values: ColumnView<'a>) {
        self.properties.push(PlyProperty {
            name: name.to_string(),
            kind: PropertyKind::Scalar(ty),
        });
        self.columns.push(values);
    }
}
