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

use glam::DVec3;

use super::body::BodySink;
use super::to_geometry::{Declared, GeometrySink};
use super::view::DocumentView;
use super::{PlyColumn, PlyDocument, PlyEncoding, PropertyKind};
use super::{check_column_lengths, check_list_offsets};
use crate::Result;
use crate::io::Geometry;

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
    skipped_parts_of(&declared(doc))
}

/// [`skipped_parts`] of a file with these elements.
pub(super) fn skipped_parts_of(elements: &[Declared<'_>]) -> Vec<String> {
    let mut notes = Vec::new();
    for element in elements.iter().filter(|e| e.count > 0) {
        match element.name {
            "vertex" => notes.extend(
                element
                    .properties
                    .iter()
                    .filter(|p| matches!(p.kind, PropertyKind::List { .. }))
                    .map(|p| format!("vertex list property `{}` skipped", p.name)),
            ),
            "face" => {
                let indices = if element
                    .properties
                    .iter()
                    .any(|p| p.name == "vertex_indices")
                {
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

/// The elements of `doc` as a header declares them.
fn declared(doc: &PlyDocument) -> Vec<Declared<'_>> {
    doc.elements
        .iter()
        .map(|e| Declared {
            name: &e.name,
            count: e.count,
            properties: &e.properties,
        })
        .collect()
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
    for element in &doc.elements {
        let lengths = element.columns.iter().map(PlyColumn::len);
        check_column_lengths(&element.name, element.count, &element.properties, lengths)?;
        for (property, column) in element.properties.iter().zip(&element.columns) {
            check_list_offsets(&element.name, property, column)?;
        }
    }
    let elements = declared(doc);
    let mut sink = GeometrySink::new(&elements, recentre_far);
    // The vertex element first: faces are triangulated on its positions.
    let vertex = doc.elements.iter().position(|e| e.name == "vertex");
    let order = vertex
        .into_iter()
        .chain((0..doc.elements.len()).filter(|&e| Some(e) != vertex));
    for index in order {
        let element = &doc.elements[index];
        for record in 0..element.count {
            for (property, column) in element.columns.iter().enumerate() {
                match column {
                    PlyColumn::Scalar(values) => {
                        sink.scalar(index, property, record, values[record]);
                    }
                    PlyColumn::List { offsets, items } => {
                        sink.list(
                            index,
                            property,
                            &items[offsets[record]..offsets[record + 1]],
                        );
                    }
                }
            }
        }
        sink.element_done(index);
    }
    sink.finish()
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
