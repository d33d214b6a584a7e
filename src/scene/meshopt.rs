//! `EXT_meshopt_compression` and `KHR_meshopt_compression`: buffer views whose bytes are
//! stored compressed by meshoptimizer's codecs, decoded into the (usually URI-less,
//! "fallback") buffer each view describes, so that accessors then read them as any other view.
//!
//! A compressed view names, in its extension object, the buffer range holding the stream, the
//! element size (`byteStride`) and `count`, the `mode` (ATTRIBUTES: the vertex codec;
//! TRIANGLES: the triangle index codec; INDICES: the index sequence codec) and, for
//! ATTRIBUTES, a `filter` applied after decoding (OCTAHEDRAL unit vectors, QUATERNION
//! rotations, EXPONENTIAL floats; KHR_meshopt_compression adds COLOR, YCoCg colours, and
//! version 1 of the vertex codec). The validity rules of the extension's specification
//! (KhronosGroup/glTF, `extensions/2.0/Vendor/EXT_meshopt_compression`, "JSON schema
//! updates") are checked before a stream is decoded, and every stream is decoded by the
//! reference decoder, meshoptimizer's C++ (the `meshopt` crate), which is written for untrusted
//! input: a corrupt stream is an error naming the view, never a panic.
//!
//! A view is decoded even when its buffer has real (fallback) data: the decoded bytes are the
//! same by the specification, and checking the stream is worth the little time it takes.

use serde_json::Value;

/// The two names of the extension; KHR_ is the ratified successor of EXT_ (same bitstream,
/// plus the COLOR filter and version 1 of the vertex codec).
const EXTENSIONS: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];

type Result<T> = std::result::Result<T, String>;

/// The meshopt extension object of a buffer or buffer view, and its name.
fn extension(
    extensions: Option<&serde_json::Map<String, Value>>,
) -> Option<(&'static str, &Value)> {
    let map = extensions?;
    EXTENSIONS
        .iter()
        .find_map(|name| map.get(*name).map(|v| (*name, v)))
}

/// True when buffer `buffer` is a placeholder that compressed views decode into: it has no
/// URI, and either says so (`"fallback": true`) or some compressed view writes into it, and it
/// is not a binary glTF's chunk (buffer 0 of a `.glb`, `has_blob`). Such a buffer starts as
/// zeros; [`decode_views`] fills it.
pub(super) fn is_placeholder(doc: &gltf::Document, buffer: &gltf::Buffer, has_blob: bool) -> bool {
    let json = &doc.as_json().buffers[buffer.index()];
    if json.uri.is_some() || (buffer.index() == 0 && has_blob) {
        return false;
    }
    let flagged = extension(buffer.extensions())
        .is_some_and(|(_, ext)| ext.get("fallback").and_then(Value::as_bool) == Some(true));
    flagged
        || doc
            .views()
            .any(|v| v.buffer().index() == buffer.index() && extension(v.extensions()).is_some())
}

/// Zeros for a placeholder buffer of `len` bytes, or an error saying the memory is not there
/// (a hostile `byteLength` must not abort the process).
pub(super) fn placeholder(index: usize, len: usize) -> Result<Vec<u8>> {
    let mut data = Vec::new();
    data.try_reserve_exact(len).map_err(|_| {
        format!(
            "buffer {index}: cannot allocate its {} for the data compressed views decode into",
            super::format_bytes(len as u64)
        )
    })?;
    data.resize(len, 0);
    Ok(data)
}

/// How a compressed view is decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Attributes,
    Triangles,
    Indices,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Filter {
    None,
    Octahedral,
    Quaternion,
    Exponential,
    Color,
}

impl Mode {
    /// The specification's name.
    fn name(self) -> &'static str {
        match self {
            Mode::Attributes => "ATTRIBUTES",
            Mode::Triangles => "TRIANGLES",
            Mode::Indices => "INDICES",
        }
    }
}

impl Filter {
    /// The specification's name.
    fn name(self) -> &'static str {
        match self {
            Filter::None => "NONE",
            Filter::Octahedral => "OCTAHEDRAL",
            Filter::Quaternion => "QUATERNION",
            Filter::Exponential => "EXPONENTIAL",
            Filter::Color => "COLOR",
        }
    }
}

/// One compressed view, as its extension object describes it.
#[derive(Debug)]
struct Compressed {
    name: &'static str,
    buffer: usize,
    offset: usize,
    length: usize,
    stride: usize,
    count: usize,
    mode: Mode,
    filter: Filter,
}

/// Reads and checks the extension object `ext` (named `name`) of view `view`.
fn parse(name: &'static str, ext: &Value, view: &gltf::buffer::View) -> Result<Compressed> {
    let label = format!("bufferView {} {name}", view.index());
    let integer = |key: &str, default: Option<usize>| -> Result<usize> {
        match ext.get(key) {
            None => default.ok_or_else(|| format!("{label}: no {key}, which is required")),
            Some(v) => v
                .as_u64()
                .and_then(|n| usize::try_from(n).ok())
                .ok_or_else(|| format!("{label}: {key} {v} is not a non-negative integer")),
        }
    };
    let buffer = integer("buffer", None)?;
    let offset = integer("byteOffset", Some(0))?;
    let length = integer("byteLength", None)?;
    let stride = integer("byteStride", None)?;
    let count = integer("count", None)?;
    let text = |key: &str| {
        ext.get(key).map(|v| {
            v.as_str()
                .ok_or_else(|| format!("{label}: {key} {v} is not a string"))
        })
    };
    let mode = match text("mode").transpose()? {
        Some("ATTRIBUTES") => Mode::Attributes,
        Some("TRIANGLES") => Mode::Triangles,
        Some("INDICES") => Mode::Indices,
        Some(other) => {
            return Err(format!(
                "{label}: unknown mode \"{other}\" (ATTRIBUTES, TRIANGLES or INDICES)"
            ))
        }
        None => return Err(format!("{label}: no mode, which is required")),
    };
    let khr = name.starts_with("KHR_");
    let filter = match text("filter").transpose()? {
        None | Some("NONE") => Filter::None,
        Some("OCTAHEDRAL") => Filter::Octahedral,
        Some("QUATERNION") => Filter::Quaternion,
        Some("EXPONENTIAL") => Filter::Exponential,
        Some("COLOR") if khr => Filter::Color,
        Some(other) => {
            let known = match khr {
                true => "NONE, OCTAHEDRAL, QUATERNION, EXPONENTIAL or COLOR",
                false => "NONE, OCTAHEDRAL, QUATERNION or EXPONENTIAL",
            };
            return Err(format!("{label}: unknown filter \"{other}\" ({known})"));
        }
    };
    let c = Compressed {
        name,
        buffer,
        offset,
        length,
        stride,
        count,
        mode,
        filter,
    };
    // The specification's validity rules.
    let broken = |why: String| Err(format!("{label}: {why}"));
    if let Some(s) = view.stride().filter(|&s| s != stride) {
        return broken(format!(
            "the view's byteStride {s} differs from the extension's {stride}"
        ));
    }
    if stride.checked_mul(count) != Some(view.length()) {
        return broken(format!(
            "byteStride {stride} × count {count} is not the view's byteLength {}",
            view.length()
        ));
    }
    match mode {
        Mode::Attributes if stride == 0 || stride % 4 != 0 || stride > 256 => {
            return broken(format!(
                "ATTRIBUTES needs a byteStride divisible by 4 and at most 256, not {stride}"
            ))
        }
        Mode::Triangles | Mode::Indices if stride != 2 && stride != 4 => {
            return broken(format!(
                "{} needs a byteStride of 2 or 4, not {stride}",
                mode.name()
            ))
        }
        Mode::Triangles if count % 3 != 0 => {
            return broken(format!(
                "TRIANGLES needs a count divisible by 3, not {count}"
            ))
        }
        Mode::Triangles | Mode::Indices if filter != Filter::None => {
            return broken(format!(
                "{} allows no filter, not {}",
                mode.name(),
                filter.name()
            ))
        }
        _ => {}
    }
    let filter_strides: &[usize] = match filter {
        Filter::Octahedral | Filter::Color => &[4, 8],
        Filter::Quaternion => &[8],
        _ => &[],
    };
    if !filter_strides.is_empty() && !filter_strides.contains(&stride) {
        return broken(format!(
            "the {} filter needs a byteStride of {filter_strides:?}, not {stride}",
            filter.name()
        ));
    }
    Ok(c)
}

/// Decodes every compressed view of `doc` into its place in `buffers` (the document's
/// buffers, placeholders included). Returns how many views were decoded.
pub(super) fn decode_views(doc: &gltf::Document, buffers: &mut [Vec<u8>]) -> Result<usize> {
    let mut decoded = 0;
    for view in doc.views() {
        let Some((name, ext)) = extension(view.extensions()) else {
            continue;
        };
        let c = parse(name, ext, &view)?;
        let label = format!("bufferView {} {name}", view.index());
        let source = buffers
            .get(c.buffer)
            .ok_or_else(|| format!("{label}: buffer {} does not exist", c.buffer))?;
        let encoded = c
            .offset
            .checked_add(c.length)
            .and_then(|end| source.get(c.offset..end))
            .ok_or_else(|| {
                format!(
                    "{label}: the compressed data (offset {}, length {}) runs past the end of buffer {} ({} bytes)",
                    c.offset,
                    c.length,
                    c.buffer,
                    source.len()
                )
            })?;
        let bytes = decode(&c, encoded).map_err(|e| format!("{label}: {e}"))?;
        let target = &mut buffers[view.buffer().index()];
        let target_len = target.len();
        let place = view
            .offset()
            .checked_add(view.length())
            .and_then(|end| target.get_mut(view.offset()..end))
            .ok_or_else(|| {
                format!(
                    "{label}: the view (offset {}, length {}) runs past the end of buffer {} ({target_len} bytes), which its decoded data fills",
                    view.offset(),
                    view.length(),
                    view.buffer().index()
                )
            })?;
        place.copy_from_slice(&bytes);
        decoded += 1;
    }
    Ok(decoded)
}

/// Decodes one stream into `count × stride` bytes, filter applied.
fn decode(c: &Compressed, encoded: &[u8]) -> Result<Vec<u8>> {
    let corrupt = |e: meshopt::Error| {
        format!(
            "the compressed stream is corrupt ({} of {} elements of {} bytes from {} bytes: meshoptimizer says {e})",
            c.mode.name(), c.count, c.stride, encoded.len()
        )
    };
    match c.mode {
        Mode::Attributes => {
            // Version 0 (header 0xa0) is EXT_meshopt_compression's; KHR_ adds version 1.
            let version = meshopt::encoding::decode_vertex_version(encoded);
            let allowed = if c.name.starts_with("KHR_") { 1 } else { 0 };
            match version {
                Some(v) if v <= allowed => {}
                Some(v) => {
                    return Err(format!(
                        "the vertex stream has codec version {v}, which {} does not allow",
                        c.name
                    ))
                }
                None => {
                    return Err(format!(
                    "the compressed stream is corrupt (its header byte {} is not a vertex codec's)",
                    encoded
                        .first()
                        .map_or("(none: the stream is empty)".into(), |b| format!(
                            "{b:#04x}"
                        ))
                ))
                }
            }
            let mut bytes = decode_attributes(encoded, c.count, c.stride).map_err(corrupt)?;
            apply_filter(c.filter, c.stride, &mut bytes);
            Ok(bytes)
        }
        Mode::Triangles => match c.stride {
            2 => meshopt::encoding::decode_index_buffer::<u16>(encoded, c.count)
                .map(|v| v.iter().flat_map(|i| i.to_le_bytes()).collect()),
            _ => meshopt::encoding::decode_index_buffer::<u32>(encoded, c.count)
                .map(|v| v.iter().flat_map(|i| i.to_le_bytes()).collect()),
        }
        .map_err(corrupt),
        Mode::Indices => match c.stride {
            2 => meshopt::encoding::decode_index_sequence::<u16>(encoded, c.count)
                .map(|v| v.iter().flat_map(|i| i.to_le_bytes()).collect()),
            _ => meshopt::encoding::decode_index_sequence::<u32>(encoded, c.count)
                .map(|v| v.iter().flat_map(|i| i.to_le_bytes()).collect()),
        }
        .map_err(corrupt),
    }
}

/// An element of `N` bytes, for the vertex decoder (which takes the element size from its
/// type).
#[derive(Clone, Copy)]
struct Element<const N: usize>([u8; N]);

impl<const N: usize> Default for Element<N> {
    fn default() -> Self {
        Element([0; N])
    }
}

fn decode_elements<const N: usize>(encoded: &[u8], count: usize) -> meshopt::Result<Vec<u8>> {
    let elements: Vec<Element<N>> = meshopt::encoding::decode_vertex_buffer(encoded, count)?;
    Ok(elements.iter().flat_map(|e| e.0).collect())
}

/// The vertex codec's output for `count` elements of `stride` bytes (a multiple of 4 up to
/// 256, checked by [`parse`]).
fn decode_attributes(encoded: &[u8], count: usize, stride: usize) -> meshopt::Result<Vec<u8>> {
    macro_rules! by_stride {
        ($($n:literal)*) => {
            match stride {
                $($n => decode_elements::<$n>(encoded, count),)*
                _ => unreachable!("parse checks the stride"),
            }
        };
    }
    by_stride!(4 8 12 16 20 24 28 32 36 40 44 48 52 56 60 64 68 72 76 80 84 88 92 96 100 104
        108 112 116 120 124 128 132 136 140 144 148 152 156 160 164 168 172 176 180 184 188 192
        196 200 204 208 212 216 220 224 228 232 236 240 244 248 252 256)
}

/// Applies `filter` in place to decoded elements of `stride` bytes (checked by [`parse`]).
fn apply_filter(filter: Filter, stride: usize, bytes: &mut [u8]) {
    match (filter, stride) {
        (Filter::None, _) => {}
        (Filter::Octahedral | Filter::Color, 4) => {
            let mut v: Vec<[u8; 4]> = bytes
                .chunks_exact(4)
                .map(|c| c.try_into().expect("4 bytes"))
                .collect();
            match filter {
                Filter::Octahedral => {
                    let mut signed: Vec<[i8; 4]> = v.iter().map(|e| e.map(|b| b as i8)).collect();
                    meshopt::encoding::decode_filter_oct(&mut signed);
                    v = signed.iter().map(|e| e.map(|b| b as u8)).collect();
                }
                _ => meshopt::encoding::decode_filter_color(&mut v),
            }
            bytes.copy_from_slice(v.as_flattened());
        }
        (Filter::Octahedral | Filter::Color | Filter::Quaternion, 8) => {
            let mut v: Vec<[i16; 4]> = bytes
                .chunks_exact(8)
                .map(|c| std::array::from_fn(|k| i16::from_le_bytes([c[2 * k], c[2 * k + 1]])))
                .collect();
            match filter {
                Filter::Octahedral => meshopt::encoding::decode_filter_oct(&mut v),
                Filter::Quaternion => meshopt::encoding::decode_filter_quat(&mut v),
                _ => {
                    let mut u: Vec<[u16; 4]> = v.iter().map(|e| e.map(|c| c as u16)).collect();
                    meshopt::encoding::decode_filter_color(&mut u);
                    v = u.iter().map(|e| e.map(|c| c as i16)).collect();
                }
            }
            for (out, e) in bytes.chunks_exact_mut(8).zip(&v) {
                for k in 0..4 {
                    out[2 * k..2 * k + 2].copy_from_slice(&e[k].to_le_bytes());
                }
            }
        }
        (Filter::Exponential, _) => {
            // Each 32-bit value decodes on its own (2^e · m), whatever the stride.
            let mut v: Vec<[u32; 1]> = bytes
                .chunks_exact(4)
                .map(|c| [u32::from_le_bytes(c.try_into().expect("4 bytes"))])
                .collect();
            meshopt::encoding::decode_filter_exp(&mut v);
            for (out, e) in bytes.chunks_exact_mut(4).zip(&v) {
                out.copy_from_slice(&e[0].to_le_bytes());
            }
        }
        _ => unreachable!("parse checks the filters' strides"),
    }
}
