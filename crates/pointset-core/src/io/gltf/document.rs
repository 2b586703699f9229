//! The glTF JSON document: parsed once, then read member by member, each read naming its
//! path in the document when the member is missing or of the wrong kind.

use serde_json::Value;

use super::GltfContainer;
use crate::io::FileFormat;
use crate::{Error, Location, Result};

/// The extensions that may be required: what they change is read anyway.
const UNDERSTOOD_EXTENSIONS: [&str; 1] = ["KHR_mesh_quantization"];

/// A parsed glTF document.
pub(super) struct Document {
    root: Value,
    container: GltfContainer,
}

/// The error of member `at` of a document in `container`.
pub(super) fn invalid(container: GltfContainer, at: &str, message: impl Into<String>) -> Error {
    Error::InvalidDocument {
        format: FileFormat::Gltf(container),
        at: at.to_string(),
        message: message.into(),
    }
}

impl Document {
    /// Parses `json` and checks what the whole document promises: a glTF 2 asset, and no
    /// required extension that is not understood.
    pub(super) fn parse(json: &[u8], container: GltfContainer) -> Result<Self> {
        let root: Value = serde_json::from_slice(json).map_err(|e| Error::Malformed {
            format: FileFormat::Gltf(container),
            location: Location::Line(e.line()),
            message: format!("JSON, column {}: {e}", e.column()),
        })?;
        if !root.is_object() {
            return Err(invalid(container, "", "the document is not a JSON object"));
        }
        let document = Document { root, container };
        let asset = document
            .root()
            .object("asset")?
            .ok_or_else(|| invalid(container, "asset", "missing (every glTF file has an asset)"))?;
        let version = asset.string("version")?.unwrap_or_default();
        if version.split('.').next() != Some("2") {
            return Err(invalid(
                container,
                "asset.version",
                format!("`{version}`: glTF 2.x is read (convert glTF 1.0 files first)"),
            ));
        }
        for (k, name) in document
            .root()
            .strings("extensionsRequired")?
            .iter()
            .enumerate()
        {
            if !UNDERSTOOD_EXTENSIONS.contains(&name.as_str()) {
                return Err(invalid(
                    container,
                    &format!("extensionsRequired[{k}]"),
                    format!(
                        "the file requires `{name}`, which is not read (Draco or meshopt \
                         compression must be undone first, e.g. with `gltf-transform copy`)"
                    ),
                ));
            }
        }
        Ok(document)
    }

    /// The document's container.
    pub(super) fn container(&self) -> GltfContainer {
        self.container
    }

    /// The root object.
    pub(super) fn root(&self) -> Member<'_> {
        Member {
            value: &self.root,
            path: String::new(),
            container: self.container,
        }
    }

    /// The items of the top-level array `key` (none when it is absent).
    pub(super) fn items(&self, key: &str) -> Result<Vec<Member<'_>>> {
        self.root().array(key)
    }

    /// Item `index` of the top-level array `key`, referenced from `from` (found without
    /// visiting the other items: files hold thousands of accessors).
    pub(super) fn item(&self, key: &str, index: usize, from: &str) -> Result<Member<'_>> {
        let items = match self.root.get(key) {
            None | Some(Value::Null) => &[][..],
            Some(Value::Array(items)) => items.as_slice(),
            Some(_) => return Err(self.root().invalid(key, "is not an array")),
        };
        let value = items.get(index).ok_or_else(|| {
            invalid(
                self.container,
                from,
                format!("refers to {key}[{index}], but the file has {}", items.len()),
            )
        })?;
        Ok(Member {
            value,
            path: format!("{key}[{index}]"),
            container: self.container,
        })
    }

    /// The comment lines in `asset.extras.comments`, as the writer puts them there.
    pub(super) fn comments(&self) -> Vec<String> {
        self.root
            .pointer("/asset/extras/comments")
            .and_then(Value::as_array)
            .map(|lines| {
                lines
                    .iter()
                    .filter_map(|l| l.as_str().map(str::to_string))
                    .collect()
            })
            .unwrap_or_default()
    }
}

/// A JSON value at a known path of the document.
#[derive(Clone)]
pub(super) struct Member<'a> {
    value: &'a Value,
    path: String,
    container: GltfContainer,
}

impl<'a> Member<'a> {
    /// The path of its member `key`.
    pub(super) fn path_of(&self, key: &str) -> String {
        if self.path.is_empty() {
            key.to_string()
        } else {
            format!("{}.{key}", self.path)
        }
    }

    /// The error of its member `key` (of itself when `key` is empty).
    pub(super) fn invalid(&self, key: &str, message: impl Into<String>) -> Error {
        let at = if key.is_empty() {
            self.path.clone()
        } else {
            self.path_of(key)
        };
        invalid(self.container, &at, message)
    }

    /// Its member `key`, if present (`null` counts as absent).
    fn get(&self, key: &str) -> Option<&'a Value> {
        self.value.get(key).filter(|v| !v.is_null())
    }

    /// Whether it has the member `key`.
    pub(super) fn has(&self, key: &str) -> bool {
        self.get(key).is_some()
    }

    /// The member `key` as a value at its path.
    fn member(&self, key: &str, value: &'a Value) -> Member<'a> {
        Member {
            value,
            path: self.path_of(key),
            container: self.container,
        }
    }

    /// The object `key`, if present.
    pub(super) fn object(&self, key: &str) -> Result<Option<Member<'a>>> {
        match self.get(key) {
            None => Ok(None),
            Some(v) if v.is_object() => Ok(Some(self.member(key, v))),
            Some(_) => Err(self.invalid(key, "is not an object")),
        }
    }

    /// The members of the object `key` in the document's order (none when absent).
    pub(super) fn entries(&self, key: &str) -> Result<Vec<(String, Member<'a>)>> {
        let Some(object) = self.object(key)? else {
            return Ok(Vec::new());
        };
        let map = object.value.as_object().into_iter().flatten();
        Ok(map
            .map(|(name, value)| (name.clone(), object.member(name, value)))
            .collect())
    }

    /// The items of the array `key` (none when absent).
    pub(super) fn array(&self, key: &str) -> Result<Vec<Member<'a>>> {
        match self.get(key) {
            None => Ok(Vec::new()),
            Some(Value::Array(items)) => {
                let base = self.path_of(key);
                Ok(items
                    .iter()
                    .enumerate()
                    .map(|(k, value)| Member {
                        value,
                        path: format!("{base}[{k}]"),
                        container: self.container,
                    })
                    .collect())
            }
            Some(_) => Err(self.invalid(key, "is not an array")),
        }
    }

    /// The count or index `key`, if present: a whole number of at least 0.
    pub(super) fn index(&self, key: &str) -> Result<Option<usize>> {
        match self.get(key) {
            None => Ok(None),
            Some(v) => v
                .as_u64()
                .and_then(|n| usize::try_from(n).ok())
                .map(Some)
                .ok_or_else(|| self.invalid(key, format!("`{v}` is not a whole number ≥ 0"))),
        }
    }

    /// The count or index `key`, which must be present.
    pub(super) fn required_index(&self, key: &str) -> Result<usize> {
        self.index(key)?
            .ok_or_else(|| self.invalid(key, "missing (required)"))
    }

    /// Itself as an index (an item of an array of indices).
    pub(super) fn as_index(&self) -> Result<usize> {
        self.value
            .as_u64()
            .and_then(|n| usize::try_from(n).ok())
            .ok_or_else(|| self.invalid("", format!("`{}` is not an index", self.value)))
    }

    /// The string `key`, if present.
    pub(super) fn string(&self, key: &str) -> Result<Option<String>> {
        match self.get(key) {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(s.clone())),
            Some(_) => Err(self.invalid(key, "is not a string")),
        }
    }

    /// The strings of the array `key` (none when absent).
    pub(super) fn strings(&self, key: &str) -> Result<Vec<String>> {
        self.array(key)?
            .iter()
            .map(|item| {
                item.value
                    .as_str()
                    .map(str::to_string)
                    .ok_or_else(|| item.invalid("", "is not a string"))
            })
            .collect()
    }

    /// The boolean `key`, `false` when absent.
    pub(super) fn flag(&self, key: &str) -> Result<bool> {
        match self.get(key) {
            None => Ok(false),
            Some(Value::Bool(b)) => Ok(*b),
            Some(_) => Err(self.invalid(key, "is not true or false")),
        }
    }

    /// The `N` finite numbers of the array `key`, if present.
    pub(super) fn numbers<const N: usize>(&self, key: &str) -> Result<Option<[f64; N]>> {
        let Some(v) = self.get(key) else {
            return Ok(None);
        };
        let numbers: Option<Vec<f64>> = v
            .as_array()
            .map(|items| items.iter().map(Value::as_f64).collect())
            .and_then(|n: Option<Vec<f64>>| n);
        match numbers {
            Some(n) if n.len() == N && n.iter().all(|x| x.is_finite()) => {
                let mut out = [0.0; N];
                out.copy_from_slice(&n);
                Ok(Some(out))
            }
            _ => Err(self.invalid(key, format!("is not an array of {N} finite numbers"))),
        }
    }
}
