//! Reading a scene's files: the `.gltf` or `.glb` bytes (with the GLB header's checks), and
//! the buffers its URIs, data URIs and GLB chunk hold.

use std::path::{Path, PathBuf};

use base64::Engine;

/// A loader's error message.
type Result<T> = std::result::Result<T, String>;

pub(super) fn read_scene_file(path: &Path) -> Result<Vec<u8>> {
    let file = std::fs::File::open(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".to_string(),
        _ => format!("cannot read the file: {e}"),
    })?;
    // A FIFO or a device (/dev/zero) would block or never end.
    match file.metadata() {
        Ok(m) if m.is_file() => {}
        Ok(m) if m.is_dir() => return Err("is a directory, not a glTF file".into()),
        Ok(_) => return Err("not a regular file".into()),
        Err(e) => return Err(format!("cannot read the file: {e}")),
    }
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut &file, &mut bytes)
        .map_err(|e| format!("cannot read the file: {e}"))?;
    Ok(bytes)
}

/// The 12-byte header of a binary glTF: version 2, and a total length the file really has
/// (so a truncated file says so, rather than failing somewhere in a chunk).
pub(super) fn check_glb_header(bytes: &[u8]) -> Result<()> {
    if bytes.len() < 12 {
        return Err(format!(
            "truncated: {} bytes, shorter than the 12-byte header",
            bytes.len()
        ));
    }
    let word = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    let (version, length) = (word(4), word(8) as usize);
    if version != 2 {
        return Err(format!(
            "version {version} (strata reads binary glTF version 2)"
        ));
    }
    if length > bytes.len() {
        return Err(format!(
            "truncated: the header declares {length} bytes, the file has {}",
            bytes.len()
        ));
    }
    // The chunks (JSON, then optionally BIN) must lie inside the declared length.
    let mut offset = 12;
    let mut index = 0;
    while offset < length {
        if offset + 8 > length {
            return Err(format!(
                "truncated: chunk {index} at byte {offset} has no room for its 8-byte header (file length {length})"
            ));
        }
        let chunk = word(offset) as usize;
        let kind = String::from_utf8_lossy(&bytes[offset + 4..offset + 8]).into_owned();
        if index == 0 && kind != "JSON" {
            return Err(format!("the first chunk is {kind:?}, not \"JSON\""));
        }
        if chunk > length - offset - 8 {
            return Err(format!(
                "truncated: chunk {index} ({kind:?}) declares {chunk} bytes at byte {}, past the end of the file ({length} bytes)",
                offset + 8
            ));
        }
        offset += 8 + chunk;
        index += 1;
    }
    if index == 0 {
        return Err("no JSON chunk".into());
    }
    Ok(())
}

/// The document's buffers; the external files read are added to `files`.
pub(super) fn load_buffers(
    doc: &gltf::Document,
    blob: Option<&[u8]>,
    base_dir: &Path,
    files: &mut Vec<PathBuf>,
) -> Result<Vec<Vec<u8>>> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let i = buffer.index();
        // EXT_meshopt_compression's URI-less placeholder, which compressed views fill.
        if super::meshopt::is_placeholder(doc, &buffer, blob.is_some()) {
            out.push(super::meshopt::placeholder(i, buffer.length())?);
            continue;
        }
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .ok_or_else(|| {
                    format!("buffer {i} refers to the binary chunk, but the file has none")
                })?
                .to_vec(),
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                read_uri(uri, base_dir).map_err(|e| format!("buffer {i}: {e}"))?
            }
            gltf::buffer::Source::Uri(uri) => {
                let file = resolve_uri(uri, base_dir).map_err(|e| format!("buffer {i}: {e}"))?;
                let data = read_buffer_file(&file, buffer.length())
                    .map_err(|e| format!("buffer {i}: {e}"))?;
                files.push(file);
                data
            }
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "buffer {i} holds {} bytes but declares byteLength {}",
                data.len(),
                buffer.length()
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// Reads a data URI or a file relative to the scene.
pub(super) fn read_uri(uri: &str, base_dir: &Path) -> Result<Vec<u8>> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest
            .split_once(";base64,")
            .ok_or("data URI is not base64-encoded (expected ';base64,')")?;
        return base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map_err(|e| format!("data URI is not valid base64: {e}"));
    }
    let file = resolve_uri(uri, base_dir)?;
    std::fs::read(&file).map_err(|e| format!("cannot read '{}': {e}", file.display()))
}

/// Reads the first `len` bytes of a buffer file: only a regular file (a FIFO or a device such
/// as /dev/zero would block or never end), and no more than the buffer declares.
pub(super) fn read_buffer_file(file: &Path, len: usize) -> Result<Vec<u8>> {
    use std::io::Read;
    let cannot = |e: std::io::Error| format!("cannot read '{}': {e}", file.display());
    let f = std::fs::File::open(file).map_err(cannot)?;
    let meta = f.metadata().map_err(cannot)?;
    if !meta.is_file() {
        return Err(format!("'{}' is not a regular file", file.display()));
    }
    if meta.len() < len as u64 {
        return Err(format!(
            "'{}' holds {} bytes but the buffer declares byteLength {len}",
            file.display(),
            meta.len()
        ));
    }
    let mut data = Vec::with_capacity(len);
    f.take(len as u64).read_to_end(&mut data).map_err(cannot)?;
    Ok(data)
}

pub(super) fn resolve_uri(uri: &str, base_dir: &Path) -> Result<PathBuf> {
    if uri.contains("://") {
        return Err(format!(
            "'{uri}': only relative file URIs and data URIs are supported"
        ));
    }
    Ok(base_dir.join(percent_decode(uri)?))
}

/// Decodes %XX escapes of a URI reference (RFC 3986 §2.1).
pub fn percent_decode(uri: &str) -> Result<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("'{uri}': bad percent escape"))?;
            out.push(hex);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("'{uri}': not UTF-8 after percent-decoding"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin").unwrap(), "a b.bin");
        assert!(percent_decode("bad%2").is_err());
        assert!(percent_decode("bad%zz").is_err());
    }
}
