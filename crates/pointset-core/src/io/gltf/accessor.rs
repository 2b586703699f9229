//! Accessors: typed views of a buffer's bytes (component type, element kind, stride,
//! normalisation, sparse substitutions), decoded to `f64` values.

use std::borrow::Cow;

use super::document::{Document, Member};
use crate::{Error, Result, ScalarType};

/// An accessor's component type (glTF's `componentType` codes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Component {
    I8,
    U8,
    I16,
    U16,
    U32,
    F32,
}

impl Component {
    /// The type a `componentType` code names.
    pub(super) fn from_code(code: usize) -> Option<Self> {
        Some(match code {
            5120 => Component::I8,
            5121 => Component::U8,
            5122 => Component::I16,
            5123 => Component::U16,
            5125 => Component::U32,
            5126 => Component::F32,
            _ => return None,
        })
    }

    /// The `componentType` code.
    pub(super) fn code(self) -> u32 {
        match self {
            Component::I8 => 5120,
            Component::U8 => 5121,
            Component::I16 => 5122,
            Component::U16 => 5123,
            Component::U32 => 5125,
            Component::F32 => 5126,
        }
    }

    /// The scalar type of the same bytes.
    pub(super) fn scalar(self) -> ScalarType {
        match self {
            Component::I8 => ScalarType::I8,
            Component::U8 => ScalarType::U8,
            Component::I16 => ScalarType::I16,
            Component::U16 => ScalarType::U16,
            Component::U32 => ScalarType::U32,
            Component::F32 => ScalarType::F32,
        }
    }

    /// The value a normalised integer stands for (the format's rounding rule), or `None`
    /// for the types that cannot be normalised.
    fn normalised(self, raw: f64) -> Option<f64> {
        match self {
            Component::I8 => Some((raw / 127.0).max(-1.0)),
            Component::U8 => Some(raw / 255.0),
            Component::I16 => Some((raw / 32767.0).max(-1.0)),
            Component::U16 => Some(raw / 65535.0),
            Component::U32 | Component::F32 => None,
        }
    }
}

/// The components of an element kind (`type`), for the vector kinds read.
pub(super) fn components_of(kind: &str) -> Option<usize> {
    match kind {
        "SCALAR" => Some(1),
        "VEC2" => Some(2),
        "VEC3" => Some(3),
        "VEC4" => Some(4),
        _ => None,
    }
}

/// An accessor's elements, decoded.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Elements {
    /// Values a element.
    pub components: usize,
    /// The stored type.
    pub component: Component,
    /// Whether the integers stand for `0..=1` (or `-1..=1`).
    pub normalized: bool,
    /// `components` values an element, element after element (normalised when the
    /// accessor is).
    pub values: Vec<f64>,
}

impl Elements {
    /// How many elements.
    pub(super) fn count(&self) -> usize {
        self.values.len() / self.components.max(1)
    }

    /// Element `i`.
    pub(super) fn element(&self, i: usize) -> &[f64] {
        &self.values[i * self.components..(i + 1) * self.components]
    }
}

/// What an accessor's bytes are, as its JSON says.
#[derive(Debug, Clone, Copy)]
struct Layout {
    component: Component,
    components: usize,
    count: usize,
}

impl Layout {
    /// Bytes of one element, packed.
    fn element_bytes(&self) -> usize {
        self.component.scalar().size() * self.components
    }
}

/// The bytes `count` elements of `element_bytes` each occupy at `offset` in buffer view
/// `view_index` with the view's stride (or packed), checked against the view and its
/// buffer; and that stride.
fn view_bytes<'b>(
    document: &Document,
    buffers: &'b [Cow<'_, [u8]>],
    view_index: usize,
    from: &Member<'_>,
    offset: usize,
    count: usize,
    element_bytes: usize,
) -> Result<(&'b [u8], usize)> {
    let view = document.item("bufferViews", view_index, &from.path_of("bufferView"))?;
    let buffer_index = view.required_index("buffer")?;
    let buffer = buffers.get(buffer_index).ok_or_else(|| {
        view.invalid(
            "buffer",
            format!(
                "refers to buffers[{buffer_index}], but the file has {}",
                buffers.len()
            ),
        )
    })?;
    let view_offset = view.index("byteOffset")?.unwrap_or(0);
    let view_len = view.required_index("byteLength")?;
    if view_offset.saturating_add(view_len) > buffer.len() {
        return Err(view.invalid(
            "byteLength",
            format!(
                "bytes {view_offset}..{} of a buffer of {} bytes",
                view_offset.saturating_add(view_len),
                buffer.len()
            ),
        ));
    }
    let stride = view.index("byteStride")?.unwrap_or(element_bytes);
    if stride < element_bytes {
        return Err(view.invalid(
            "byteStride",
            format!("{stride}, less than the {element_bytes} bytes of an element"),
        ));
    }
    let needed = match count {
        0 => Some(offset),
        n => (n - 1)
            .checked_mul(stride)
            .and_then(|b| b.checked_add(element_bytes))
            .and_then(|b| b.checked_add(offset)),
    };
    match needed {
        Some(end) if end <= view_len => {
            Ok((&buffer[view_offset + offset..view_offset + end], stride))
        }
        _ => Err(from.invalid(
            "count",
            format!(
                "{count} elements of {element_bytes} bytes from byte {offset} with a stride \
                 of {stride} reach past the {view_len} bytes of bufferViews[{view_index}]"
            ),
        )),
    }
}

/// Decodes `count` elements of `layout` from `bytes` at `stride` into `out` (as raw
/// stored values).
fn decode_into(bytes: &[u8], stride: usize, layout: &Layout, out: &mut Vec<f64>) {
    let scalar = layout.component.scalar();
    let size = scalar.size();
    for i in 0..layout.count {
        let element = &bytes[i * stride..];
        for c in 0..layout.components {
            out.push(
                scalar
                    .decode(&element[c * size..], false)
                    .unwrap_or_default(),
            );
        }
    }
}

/// Reads accessor `index`, referenced from `from` (e.g. a primitive's attribute), whose
/// element kinds must be among `kinds`; `file_len` bounds an accessor without data.
pub(super) fn read_accessor(
    document: &Document,
    buffers: &[Cow<'_, [u8]>],
    index: usize,
    from: &str,
    kinds: &[&str],
    file_len: usize,
) -> Result<Elements> {
    let accessor = document.item("accessors", index, from)?;
    let code = accessor.required_index("componentType")?;
    let component = Component::from_code(code).ok_or_else(|| {
        accessor.invalid(
            "componentType",
            format!("{code} is not a glTF component type"),
        )
    })?;
    let kind = accessor.string("type")?.unwrap_or_default();
    let components = components_of(&kind)
        .filter(|_| kinds.contains(&kind.as_str()))
        .ok_or_else(|| {
            accessor.invalid(
                "type",
                format!("`{kind}` where {from} needs {}", kinds.join(" or ")),
            )
        })?;
    let normalized = accessor.flag("normalized")?;
    if normalized && component.normalised(0.0).is_none() {
        return Err(accessor.invalid(
            "normalized",
            "only 8- and 16-bit integers can be normalised",
        ));
    }
    let layout = Layout {
        component,
        components,
        count: accessor.required_index("count")?,
    };
    let len = layout.count.saturating_mul(components);
    let mut values = Vec::new();
    values
        .try_reserve_exact(len)
        .map_err(|_| Error::OutOfMemory {
            what: format!("the values of {}", accessor.path_of("")),
            bytes: len as u128 * 8,
        })?;
    match accessor.index("bufferView")? {
        Some(view) => {
            let offset = accessor.index("byteOffset")?.unwrap_or(0);
            let (bytes, stride) = view_bytes(
                document,
                buffers,
                view,
                &accessor,
                offset,
                layout.count,
                layout.element_bytes(),
            )?;
            decode_into(bytes, stride, &layout, &mut values);
        }
        None if layout.count <= file_len => values.resize(len, 0.0),
        None => {
            return Err(accessor.invalid(
                "count",
                format!(
                    "{} zero elements (no bufferView), more than the file's {file_len} bytes",
                    layout.count
                ),
            ));
        }
    }
    if let Some(sparse) = accessor.object("sparse")? {
        apply_sparse(document, buffers, &sparse, &layout, &mut values)?;
    }
    if normalized {
        for v in &mut values {
            *v = component.normalised(*v).unwrap_or(*v);
        }
    }
    Ok(Elements {
        components,
        component,
        normalized,
        values,
    })
}

/// Replaces the elements a sparse accessor's `sparse` member lists.
fn apply_sparse(
    document: &Document,
    buffers: &[Cow<'_, [u8]>],
    sparse: &Member<'_>,
    layout: &Layout,
    values: &mut [f64],
) -> Result<()> {
    let count = sparse.required_index("count")?;
    let indices = sparse
        .object("indices")?
        .ok_or_else(|| sparse.invalid("indices", "missing (required)"))?;
    let code = indices.required_index("componentType")?;
    let index_type = Component::from_code(code)
        .filter(|c| matches!(c, Component::U8 | Component::U16 | Component::U32))
        .ok_or_else(|| indices.invalid("componentType", format!("{code} is not an index type")))?;
    let index_layout = Layout {
        component: index_type,
        components: 1,
        count,
    };
    let targets = packed(document, buffers, &indices, &index_layout)?;
    let replacement = sparse
        .object("values")?
        .ok_or_else(|| sparse.invalid("values", "missing (required)"))?;
    let new_values = packed(
        document,
        buffers,
        &replacement,
        &Layout { count, ..*layout },
    )?;
    let n = layout.components;
    for (k, &target) in targets.iter().enumerate() {
        let target = target as usize;
        if target >= layout.count {
            return Err(indices.invalid(
                "",
                format!(
                    "sparse index {target} (entry {k}) past the accessor's {} elements",
                    layout.count
                ),
            ));
        }
        values[target * n..(target + 1) * n].copy_from_slice(&new_values[k * n..(k + 1) * n]);
    }
    Ok(())
}

/// The elements of `layout` a sparse accessor's `indices` or `values` member (`member`:
/// its `bufferView` and `byteOffset`) holds, tightly packed as the format asks.
fn packed(
    document: &Document,
    buffers: &[Cow<'_, [u8]>],
    member: &Member<'_>,
    layout: &Layout,
) -> Result<Vec<f64>> {
    let element_bytes = layout.element_bytes();
    let (bytes, _) = view_bytes(
        document,
        buffers,
        member.required_index("bufferView")?,
        member,
        member.index("byteOffset")?.unwrap_or(0),
        layout.count,
        element_bytes,
    )?;
    let mut values = Vec::with_capacity(layout.count * layout.components);
    decode_into(bytes, element_bytes, layout, &mut values);
    Ok(values)
}
