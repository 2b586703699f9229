//! The `.glb` container's chunks, and the buffers a document's data lives in.

use std::borrow::Cow;
use std::fs::File;
use std::io::Read;
use std::path::Path;

use super::document::Document;
use super::{GltfContainer, base64, malformed_at_byte};
use crate::io::FileFormat;
use crate::{Error, Location, Result};

/// The first four bytes of a `.glb`.
pub(super) const GLB_MAGIC: &[u8; 4] = b"glTF";
/// The type of the JSON chunk (`JSON` in ASCII, little-endian).
pub(super) const JSON_CHUNK: u32 = 0x4E4F_534A;
/// The type of the binary chunk (`BIN\0`).
pub(super) const BIN_CHUNK: u32 = 0x004E_4942;
/// The bytes of the file header (magic, version, length).
pub(super) const GLB_HEADER_BYTES: usize = 12;

/// An asset's parts: its JSON and, in a `.glb`, its binary chunk.
pub(super) struct Asset<'a> {
    pub container: GltfContainer,
    pub json: &'a [u8],
    pub binary: Option<&'a [u8]>,
    /// What the container held that is not read.
    pub notes: Vec<String>,
}

/// The container `bytes` are in, by their magic bytes.
pub(super) fn container_of(bytes: &[u8]) -> GltfContainer {
    if bytes.starts_with(GLB_MAGIC) {
        GltfContainer::Binary
    } else {
        GltfContainer::Json
    }
}

/// The little-endian word at byte `at` of `bytes` (the caller checked the length).
fn word_at(bytes: &[u8], at: usize) -> u32 {
    let mut word = [0u8; 4];
    word.copy_from_slice(&bytes[at..at + 4]);
    u32::from_le_bytes(word)
}

/// Splits a file into its JSON and binary chunk (see the module docs of [`super`]).
pub(super) fn open(bytes: &[u8]) -> Result<Asset<'_>> {
    let container = container_of(bytes);
    if container == GltfContainer::Json {
        return Ok(Asset {
            container,
            json: bytes,
            binary: None,
            notes: Vec::new(),
        });
    }
    let ends_early = |at: usize, what: &str| Error::UnexpectedEof {
        format: FileFormat::Gltf(container),
        location: Location::Byte(at as u64),
        what: what.to_string(),
    };
    if bytes.len() < GLB_HEADER_BYTES {
        return Err(ends_early(bytes.len(), "the 12-byte GLB header"));
    }
    let version = word_at(bytes, 4);
    if version != 2 {
        return Err(malformed_at_byte(
            container,
            4,
            format!("GLB version {version} (version 2 is read)"),
        ));
    }
    let declared = word_at(bytes, 8) as usize;
    if declared > bytes.len() {
        return Err(Error::HeaderExceedsFile {
            format: FileFormat::Gltf(container),
            element: "GLB file byte".into(),
            declared: declared as u64,
            needed_bytes: declared as u128,
            available_bytes: bytes.len() as u64,
        });
    }
    let mut notes = Vec::new();
    if declared < bytes.len() {
        notes.push(format!(
            "{} bytes after the GLB's declared length of {declared} ignored",
            bytes.len() - declared
        ));
    }
    let file = &bytes[..declared];
    let mut at = GLB_HEADER_BYTES;
    let mut json = None;
    let mut binary = None;
    while at < file.len() {
        if file.len() - at < 8 {
            return Err(ends_early(file.len(), "a GLB chunk header"));
        }
        let (len, kind) = (word_at(file, at) as usize, word_at(file, at + 4));
        let start = at + 8;
        if len > file.len() - start {
            return Err(ends_early(
                file.len(),
                &format!("a GLB chunk of {len} bytes starting at byte {start}"),
            ));
        }
        let data = &file[start..start + len];
        match kind {
            JSON_CHUNK if json.is_none() && at == GLB_HEADER_BYTES => json = Some(data),
            BIN_CHUNK if json.is_some() && binary.is_none() => binary = Some(data),
            JSON_CHUNK | BIN_CHUNK => {
                return Err(malformed_at_byte(
                    container,
                    at as u64 + 4,
                    "a JSON chunk that is not the first, or a second binary chunk",
                ));
            }
            _ => notes.push(format!(
                "GLB chunk of unknown type {kind:#010x} at byte {at} skipped"
            )),
        }
        // Chunks are padded to 4 bytes; a chunk that is not ends the same way.
        at = start + len.next_multiple_of(4).min(file.len() - start);
    }
    let json = json.ok_or_else(|| {
        malformed_at_byte(container, GLB_HEADER_BYTES as u64, "no JSON chunk first")
    })?;
    Ok(Asset {
        container,
        json,
        binary,
        notes,
    })
}

/// The bytes of every buffer of `document`: the `.glb`'s binary chunk, `data:` URIs, or
/// files in `base_dir`. Each is checked to hold its declared `byteLength`.
pub(super) fn load_buffers<'a>(
    document: &Document,
    binary: Option<&'a [u8]>,
    base_dir: Option<&Path>,
) -> Result<Vec<Cow<'a, [u8]>>> {
    let mut buffers = Vec::new();
    for (k, buffer) in document.items("buffers")?.into_iter().enumerate() {
        let declared = buffer.required_index("byteLength")?;
        let bytes: Cow<'a, [u8]> = match buffer.string("uri")? {
            None => match binary {
                Some(chunk) if k == 0 => Cow::Borrowed(chunk),
                _ => {
                    return Err(buffer.invalid(
                        "uri",
                        "missing: only the first buffer of a .glb may use its binary chunk",
                    ));
                }
            },
            Some(uri) if uri.starts_with("data:") => {
                let Some((_, data)) = uri.split_once(";base64,") else {
                    return Err(buffer.invalid("uri", "a data URI that is not base64"));
                };
                let decoded = base64::decode(data).map_err(|at| {
                    buffer.invalid(
                        "uri",
                        format!("character {at} of the base64 data is not base64"),
                    )
                })?;
                Cow::Owned(decoded)
            }
            Some(uri) => Cow::Owned(external(&buffer, &uri, declared, base_dir)?),
        };
        if bytes.len() < declared {
            return Err(buffer.invalid(
                "byteLength",
                format!("{declared}, but the buffer holds {} bytes", bytes.len()),
            ));
        }
        buffers.push(match bytes {
            Cow::Borrowed(b) => Cow::Borrowed(&b[..declared]),
            Cow::Owned(mut b) => {
                b.truncate(declared);
                Cow::Owned(b)
            }
        });
    }
    Ok(buffers)
}

/// The first `declared` bytes of the file `uri` names, relative to `base_dir`.
fn external(
    buffer: &super::document::Member<'_>,
    uri: &str,
    declared: usize,
    base_dir: Option<&Path>,
) -> Result<Vec<u8>> {
    if let Some((scheme, _)) = uri.split_once(':')
        && scheme.len() > 1
        && scheme
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
    {
        return Err(buffer.invalid(
            "uri",
            format!("`{uri}`: only data URIs and files beside the glTF file are read"),
        ));
    }
    let Some(dir) = base_dir else {
        return Err(buffer.invalid(
            "uri",
            format!("`{uri}` is a file beside the glTF file: read the glTF file by its path"),
        ));
    };
    let path = dir.join(percent_decoded(uri));
    let at_path = |source| Error::Io {
        path: path.clone(),
        source,
    };
    let file = File::open(&path).map_err(at_path)?;
    let mut bytes = Vec::new();
    file.take(declared as u64)
        .read_to_end(&mut bytes)
        .map_err(at_path)?;
    Ok(bytes)
}

/// A URI's path with `%XX` escapes decoded (others kept as written).
fn percent_decoded(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = bytes
            .get(i + 1..i + 3)
            .and_then(|h| std::str::from_utf8(h).ok())
            .and_then(|h| u8::from_str_radix(h, 16).ok());
        match (bytes[i], hex) {
            (b'%', Some(byte)) => {
                out.push(byte);
                i += 3;
            }
            (b, _) => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::percent_decoded;

    #[test]
    fn escapes_are_decoded() {
        assert_eq!(percent_decoded("my%20mesh.bin"), "my mesh.bin");
        assert_eq!(percent_decoded("a%2"), "a%2");
        assert_eq!(percent_decoded("%zz.bin"), "%zz.bin");
    }
}
