//! `KHR_draco_mesh_compression`: primitives whose attributes and indices are stored as one
//! Draco stream (KhronosGroup/glTF, `extensions/2.0/Khronos/KHR_draco_mesh_compression`).
//!
//! Each such primitive's stream (the extension's `bufferView`) is decoded by Google's Draco
//! library (the reference decoder, through `ffi`), and the decoded data replaces what its
//! accessors would otherwise read: the extension's `attributes` map each attribute name to a
//! Draco attribute id, the decoded faces become the indices. The accessors' declared counts,
//! types and `normalized` flags are respected: the decoded values are written in the
//! accessor's component type into a buffer appended to the document, and the accessor is
//! pointed at them (a copy of it, when another stream already filled it). A count or
//! component count that does not match the decoded data is an error, as is a value the
//! accessor's type cannot hold. Attributes the extension does not name are read as usual.
//! The decoded faces form a triangle list, so the primitive's mode becomes TRIANGLES (the
//! extension allows TRIANGLES and TRIANGLE_STRIP).

mod ffi;

use std::collections::HashSet;

use gltf::json::accessor::{ComponentType, GenericComponentType, Type};
use gltf::json::validation::{Checked, USize64};
use gltf::json::{self, Index};
use serde_json::Value;

pub use ffi::{Attribute, DataType, Mesh};

const EXTENSION: &str = "KHR_draco_mesh_compression";

type Result<T> = std::result::Result<T, String>;

/// Decodes every Draco-compressed primitive of `root` (whose buffers' bytes are `buffers`):
/// the decoded data goes into one new buffer appended to both, and the primitives' accessors
/// are pointed at it. Returns how many primitives were decoded.
pub(super) fn decode_primitives(
    root: &mut json::Root,
    buffers: &mut Vec<Vec<u8>>,
) -> Result<usize> {
    let mut out = Vec::new();
    let new_buffer = buffers.len();
    // Accessors already filled by a stream: another primitive naming one gets a copy.
    let mut filled: HashSet<usize> = HashSet::new();
    let mut decoded = 0;
    for m in 0..root.meshes.len() {
        for p in 0..root.meshes[m].primitives.len() {
            let Some(ext) = root.meshes[m].primitives[p]
                .extensions
                .as_ref()
                .and_then(|e| e.others.get(EXTENSION))
                .cloned()
            else {
                continue;
            };
            let label = format!("mesh {m} primitive {p} {EXTENSION}");
            let stream = stream(root, buffers, &ext).map_err(|e| format!("{label}: {e}"))?;
            let mesh = Mesh::decode(stream)
                .map_err(|e| format!("{label}: the Draco stream does not decode: {e}"))?;
            let primitive = &root.meshes[m].primitives[p];
            match primitive.mode {
                Checked::Valid(json::mesh::Mode::Triangles)
                | Checked::Valid(json::mesh::Mode::TriangleStrip) => {}
                _ => {
                    return Err(format!(
                        "{label}: the primitive's mode must be TRIANGLES or TRIANGLE_STRIP"
                    ))
                }
            }
            // The attributes the stream holds, each with its accessor.
            let names = ext
                .get("attributes")
                .and_then(Value::as_object)
                .ok_or_else(|| format!("{label}: no attributes object"))?;
            let mut fills: Vec<(Option<String>, usize, Vec<u8>)> = Vec::new();
            for (name, id) in names {
                let id = id
                    .as_u64()
                    .and_then(|i| u32::try_from(i).ok())
                    .ok_or_else(|| {
                        format!("{label}: attribute {name}'s id {id} is not an integer")
                    })?;
                let accessor = primitive
                    .attributes
                    .iter()
                    .find(|(s, _)| matches!(s, Checked::Valid(s) if s.to_string() == *name))
                    .map(|(_, a)| a.value())
                    .ok_or_else(|| {
                        format!("{label}: {name} is compressed, but the primitive has no {name} attribute")
                    })?;
                let attribute = mesh.attribute(id).ok_or_else(|| {
                    format!("{label}: {name}'s Draco attribute id {id} is not in the stream")
                })?;
                let values = mesh
                    .attribute_values(id, &attribute)
                    .map_err(|e| format!("{label}: {name}: {e}"))?;
                let bytes = convert(
                    &root.accessors[accessor],
                    mesh.num_points(),
                    &attribute,
                    &values,
                )
                .map_err(|e| format!("{label}: {name} (accessor {accessor}): {e}"))?;
                fills.push((Some(name.clone()), accessor, bytes));
            }
            // The faces, as the primitive's indices.
            let faces = mesh.faces();
            let indices = match primitive.indices {
                Some(i) => {
                    let i = i.value();
                    let bytes = indices(&root.accessors[i], mesh.num_points(), &faces)
                        .map_err(|e| format!("{label}: indices (accessor {i}): {e}"))?;
                    (i, bytes)
                }
                None => {
                    // A stream always holds faces: give the primitive an index accessor.
                    let accessor = index_accessor(faces.len());
                    let bytes = indices(&accessor, mesh.num_points(), &faces)
                        .map_err(|e| format!("{label}: indices: {e}"))?;
                    let i = root.push(accessor).value();
                    root.meshes[m].primitives[p].indices = Some(Index::new(i as u32));
                    (i, bytes)
                }
            };
            fills.push((None, indices.0, indices.1));
            for (name, accessor, bytes) in fills {
                let accessor = match filled.insert(accessor) {
                    true => accessor,
                    false => {
                        let copy = root.accessors[accessor].clone();
                        let i = root.push(copy);
                        let primitive = &mut root.meshes[m].primitives[p];
                        match &name {
                            Some(name) => {
                                for (s, a) in primitive.attributes.iter_mut() {
                                    if matches!(s, Checked::Valid(s) if s.to_string() == *name) {
                                        *a = i;
                                    }
                                }
                            }
                            None => primitive.indices = Some(i),
                        }
                        i.value()
                    }
                };
                while out.len() % 4 != 0 {
                    out.push(0);
                }
                let view = root.push(json::buffer::View {
                    buffer: Index::new(new_buffer as u32),
                    byte_length: USize64::from(bytes.len()),
                    byte_offset: Some(USize64::from(out.len())),
                    byte_stride: None,
                    name: None,
                    target: None,
                    extensions: None,
                    extras: Default::default(),
                });
                out.extend_from_slice(&bytes);
                let a = &mut root.accessors[accessor];
                a.buffer_view = Some(view);
                a.byte_offset = None;
                a.sparse = None;
            }
            root.meshes[m].primitives[p].mode = Checked::Valid(json::mesh::Mode::Triangles);
            decoded += 1;
        }
    }
    if decoded > 0 {
        root.push(json::Buffer {
            byte_length: USize64::from(out.len()),
            name: None,
            uri: None,
            extensions: None,
            extras: Default::default(),
        });
        buffers.push(out);
    }
    Ok(decoded)
}

/// The bytes of the stream the extension object `ext` names.
fn stream<'b>(root: &json::Root, buffers: &'b [Vec<u8>], ext: &Value) -> Result<&'b [u8]> {
    let v = ext
        .get("bufferView")
        .and_then(Value::as_u64)
        .ok_or("no bufferView (an index), which is required")?;
    let view = usize::try_from(v)
        .ok()
        .and_then(|v| root.buffer_views.get(v))
        .ok_or_else(|| format!("bufferView {v} does not exist"))?;
    let buffer = view.buffer.value();
    let data = buffers
        .get(buffer)
        .ok_or_else(|| format!("bufferView {v}'s buffer {buffer} does not exist"))?;
    let offset = view.byte_offset.map_or(0, |o| o.0);
    let end = offset.checked_add(view.byte_length.0);
    end.and_then(|end| data.get(usize::try_from(offset).ok()?..usize::try_from(end).ok()?))
        .ok_or_else(|| {
            format!(
                "bufferView {v} (offset {offset}, length {}) runs past the end of buffer {buffer} ({} bytes)",
                view.byte_length.0,
                data.len()
            )
        })
}

/// An index accessor for `count` indices, for a primitive that declares none.
fn index_accessor(count: usize) -> json::Accessor {
    json::Accessor {
        buffer_view: None,
        byte_offset: None,
        count: USize64::from(count),
        component_type: Checked::Valid(GenericComponentType(ComponentType::U32)),
        extensions: None,
        extras: Default::default(),
        type_: Checked::Valid(Type::Scalar),
        min: None,
        max: None,
        name: None,
        normalized: false,
        sparse: None,
    }
}

/// The accessor's component type and number of components.
fn layout(accessor: &json::Accessor) -> Result<(ComponentType, usize)> {
    match (&accessor.component_type, &accessor.type_) {
        (Checked::Valid(GenericComponentType(c)), Checked::Valid(t)) => Ok((*c, t.multiplicity())),
        _ => Err("the accessor's componentType or type is not valid".into()),
    }
}

/// The largest value of an integer component type (the divisor of normalized values).
fn max_of(c: ComponentType) -> f64 {
    match c {
        ComponentType::I8 => 127.0,
        ComponentType::U8 => 255.0,
        ComponentType::I16 => 32767.0,
        ComponentType::U16 => 65535.0,
        ComponentType::U32 => 4_294_967_295.0,
        ComponentType::F32 => 1.0,
    }
}

/// The faces as index bytes of `accessor`'s component type (which must hold every index), after
/// checking the count and that every index names a decoded point.
fn indices(accessor: &json::Accessor, points: usize, faces: &[u32]) -> Result<Vec<u8>> {
    let (c, n) = layout(accessor)?;
    if n != 1 {
        return Err("an index accessor must be SCALAR".into());
    }
    if accessor.count.0 != faces.len() as u64 {
        return Err(format!(
            "the accessor's count {} is not the {} indices ({} triangles) the stream decodes to",
            accessor.count.0,
            faces.len(),
            faces.len() / 3
        ));
    }
    if let Some(bad) = faces.iter().find(|&&i| i as usize >= points) {
        return Err(format!(
            "the stream's index {bad} is out of range ({points} points)"
        ));
    }
    let max = faces.iter().copied().max().unwrap_or(0);
    let (size, limit) = match c {
        ComponentType::U8 => (1, u8::MAX as u32),
        ComponentType::U16 => (2, u16::MAX as u32),
        ComponentType::U32 => (4, u32::MAX),
        other => return Err(format!("indices must be unsigned integers, not {other:?}")),
    };
    if max > limit {
        return Err(format!(
            "the stream has index {max}, more than the accessor's {c:?} can hold"
        ));
    }
    Ok(faces
        .iter()
        .flat_map(|&i| i.to_le_bytes().into_iter().take(size))
        .collect())
}

/// A decoded value: a float, or an integer as Draco stores it.
#[derive(Clone, Copy)]
enum Number {
    Float(f64),
    Int(i128),
}

/// Draco's raw little-endian values of `data_type`, one by one.
fn numbers(data_type: DataType, raw: &[u8]) -> Vec<Number> {
    let size = data_type.size();
    raw.chunks_exact(size)
        .map(|b| {
            let mut word = [0u8; 8];
            word[..size].copy_from_slice(b);
            let u = u64::from_le_bytes(word);
            match data_type {
                DataType::I8 => Number::Int(b[0] as i8 as i128),
                DataType::U8 | DataType::Bool => Number::Int(b[0] as i128),
                DataType::I16 => Number::Int(u as u16 as i16 as i128),
                DataType::U16 => Number::Int(u as u16 as i128),
                DataType::I32 => Number::Int(u as u32 as i32 as i128),
                DataType::U32 => Number::Int(u as u32 as i128),
                DataType::I64 => Number::Int(u as i64 as i128),
                DataType::U64 => Number::Int(u as i128),
                DataType::F32 => Number::Float(f32::from_bits(u as u32) as f64),
                DataType::F64 => Number::Float(f64::from_bits(u)),
            }
        })
        .collect()
}

/// The largest value of a Draco integer type (for its normalized values).
fn draco_max(data_type: DataType) -> f64 {
    match data_type {
        DataType::I8 => 127.0,
        DataType::U8 | DataType::Bool => 255.0,
        DataType::I16 => 32767.0,
        DataType::U16 => 65535.0,
        DataType::I32 => i32::MAX as f64,
        DataType::U32 => u32::MAX as f64,
        DataType::I64 => i64::MAX as f64,
        DataType::U64 => u64::MAX as f64,
        DataType::F32 | DataType::F64 => 1.0,
    }
}

/// The decoded attribute (`attribute`, raw `values` for `points` points) as the bytes of
/// `accessor`'s elements: its count and component count must be the stream's; its component
/// type and `normalized` flag say how each value is stored (glTF 2.0 §3.11's normalized
/// integers: signed c ↔ max(c / (2ᵇ⁻¹ − 1), −1), unsigned c ↔ c / (2ᵇ − 1)).
fn convert(
    accessor: &json::Accessor,
    points: usize,
    attribute: &Attribute,
    values: &[u8],
) -> Result<Vec<u8>> {
    let (c, n) = layout(accessor)?;
    if accessor.count.0 != points as u64 {
        return Err(format!(
            "the accessor's count {} is not the {points} points the stream decodes to",
            accessor.count.0
        ));
    }
    if n != attribute.components {
        return Err(format!(
            "the accessor has {n} components per element, the stream's attribute {}",
            attribute.components
        ));
    }
    let normalized_draco = attribute.normalized;
    let d_max = draco_max(attribute.data_type);
    // A Draco value as the float it stands for.
    let as_float = |v: Number| match v {
        Number::Float(f) => f,
        Number::Int(i) if normalized_draco => (i as f64 / d_max).max(-1.0),
        Number::Int(i) => i as f64,
    };
    let mut out = Vec::with_capacity(values.len() / attribute.data_type.size() * 4);
    for v in numbers(attribute.data_type, values) {
        if c == ComponentType::F32 {
            let f = as_float(v) as f32;
            if !f.is_finite() {
                return Err(format!("the stream holds a value ({f}) that is not finite"));
            }
            out.extend_from_slice(&f.to_le_bytes());
            continue;
        }
        let a_max = max_of(c);
        let signed = matches!(c, ComponentType::I8 | ComponentType::I16);
        let lowest = if signed { -a_max - 1.0 } else { 0.0 };
        // The integer to store.
        let stored: f64 = match (v, accessor.normalized) {
            (Number::Int(i), false) if !normalized_draco => i as f64,
            (v, true) => {
                let f = as_float(v);
                let clamp_low = if signed { -1.0 } else { 0.0 };
                (f.clamp(clamp_low, 1.0) * a_max).round()
            }
            (v, false) => {
                let f = as_float(v);
                if (f - f.round()).abs() > 1e-3 {
                    return Err(format!(
                        "the stream holds {f}, which the accessor's {c:?} (not normalized) cannot hold"
                    ));
                }
                f.round()
            }
        };
        if !(lowest..=a_max).contains(&stored) {
            return Err(format!(
                "the stream holds {stored}, outside the range of the accessor's {c:?}"
            ));
        }
        match c {
            ComponentType::I8 => out.push(stored as i8 as u8),
            ComponentType::U8 => out.push(stored as u8),
            ComponentType::I16 => out.extend_from_slice(&(stored as i16).to_le_bytes()),
            ComponentType::U16 => out.extend_from_slice(&(stored as u16).to_le_bytes()),
            ComponentType::U32 => out.extend_from_slice(&(stored as u32).to_le_bytes()),
            ComponentType::F32 => unreachable!("handled above"),
        }
    }
    // Elements are tightly packed (the new view has no byteStride), which the readers read
    // as glTF's default stride; the GPU's 4-byte alignment of vertex elements does not apply.
    Ok(out)
}
