//! Accessors read and checked: each accessor range-checked against its buffer view before it
//! is read (so a malformed file is an error, not a panic), the formats glTF allows for each
//! attribute (`KHR_mesh_quantization`'s integers among them), and triangles assembled from
//! lists, strips and fans.

use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

/// A loader's error message.
type Result<T> = std::result::Result<T, String>;

/// Turns an index list of the given mode into triangles (glTF 2.0 §3.7.2.1: strips use
/// {v_i, v_{i+1+i%2}, v_{i+2−i%2}}, fans {v_{i+1}, v_{i+2}, v_0}, keeping one winding).
pub(super) fn assemble_triangles(mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .map(|i| [idx[i], idx[i + 1 + i % 2], idx[i + 2 - i % 2]])
            .collect(),
        Mode::TriangleFan => (0..idx.len().saturating_sub(2))
            .map(|i| [idx[i + 1], idx[i + 2], idx[0]])
            .collect(),
        _ => Vec::new(),
    }
}

/// The component types a POSITION or TEXCOORD accessor may have: float, or with
/// KHR_mesh_quantization (normalized or not) signed and unsigned bytes and shorts.
pub(super) const QUANTIZED: &[DataType] = &[
    DataType::F32,
    DataType::I8,
    DataType::U8,
    DataType::I16,
    DataType::U16,
];

/// The component types of NORMAL and TANGENT: float, or with KHR_mesh_quantization normalized
/// signed bytes and shorts.
pub(super) const QUANTIZED_UNIT: &[DataType] = &[DataType::F32, DataType::I8, DataType::I16];

/// An accessor's elements as floats, whatever its component type: integers are mapped as
/// glTF 2.0 §3.11 ("Animations", the normalized-integer table) and KHR_mesh_quantization
/// say: normalized signed c ↦ max(c / (2ᵇ⁻¹ − 1), −1), unsigned c ↦ c / (2ᵇ − 1); not
/// normalized, c itself. Sparse accessors and byte strides are the `gltf` crate's. None
/// where the accessor's data cannot be read.
pub(super) fn read_floats<const N: usize>(
    acc: &gltf::Accessor,
    buffers: &[Vec<u8>],
) -> Option<Vec<[f32; N]>>
where
    [f32; N]: gltf::accessor::Item,
    [i8; N]: gltf::accessor::Item,
    [u8; N]: gltf::accessor::Item,
    [i16; N]: gltf::accessor::Item,
    [u16; N]: gltf::accessor::Item,
{
    use gltf::accessor::Iter;
    let data = |b: gltf::Buffer| buffers.get(b.index()).map(Vec::as_slice);
    // Integers of one type: `max` is the type's largest value (signed ones reach −max − 1,
    // which normalizes to below −1 and is clamped).
    fn ints<'s, T, const N: usize>(
        acc: &gltf::Accessor,
        data: impl Clone + Fn(gltf::Buffer) -> Option<&'s [u8]>,
        max: f32,
    ) -> Option<Vec<[f32; N]>>
    where
        T: Copy + Into<f32>,
        [T; N]: gltf::accessor::Item,
    {
        let normalized = acc.normalized();
        let map = move |c: T| match normalized {
            true => (c.into() / max).max(-1.0),
            false => c.into(),
        };
        Some(
            Iter::<[T; N]>::new(acc.clone(), data)?
                .map(|v| v.map(map))
                .collect(),
        )
    }
    match acc.data_type() {
        DataType::F32 => Some(Iter::<[f32; N]>::new(acc.clone(), data)?.collect()),
        DataType::I8 => ints::<i8, N>(acc, data, 127.0),
        DataType::U8 => ints::<u8, N>(acc, data, 255.0),
        DataType::I16 => ints::<i16, N>(acc, data, 32767.0),
        DataType::U16 => ints::<u16, N>(acc, data, 65535.0),
        DataType::U32 => None,
    }
}

pub(super) fn expect_format(
    acc: &gltf::Accessor,
    dims: Dimensions,
    types: &[DataType],
    label: &str,
    what: &str,
) -> Result<()> {
    if acc.dimensions() != dims || !types.contains(&acc.data_type()) {
        return Err(format!(
            "{label}: {what} accessor {} is {:?} {:?}; expected {dims:?} of {types:?}",
            acc.index(),
            acc.dimensions(),
            acc.data_type()
        ));
    }
    Ok(())
}

/// The bytes of a buffer view, range-checked.
pub(super) fn view_bytes<'b>(
    buffers: &'b [Vec<u8>],
    view: &gltf::buffer::View,
) -> Result<&'b [u8]> {
    let data = &buffers[view.buffer().index()];
    let end = view
        .offset()
        .checked_add(view.length())
        .filter(|&e| e <= data.len())
        .ok_or_else(|| {
            format!(
                "bufferView {} (offset {}, length {}) runs past the end of buffer {} ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index(),
                data.len()
            )
        })?;
    Ok(&data[view.offset()..end])
}

/// Checks that an accessor's elements (and sparse parts) lie inside their buffer views and
/// buffers, with overflow-checked arithmetic, before anything is read.
pub(super) fn check_accessor(buffers: &[Vec<u8>], acc: &gltf::Accessor) -> Result<()> {
    let count = acc.count();
    if count == 0 {
        return Err(format!("accessor {} has count 0", acc.index()));
    }
    let elem = acc.size();
    if let Some(view) = acc.view() {
        let bytes = view_bytes(buffers, &view)?;
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(format!(
                "accessor {}: byteStride {stride} is smaller than its element size {elem}",
                acc.index()
            ));
        }
        let needed = stride
            .checked_mul(count - 1)
            .and_then(|x| x.checked_add(elem))
            .and_then(|x| x.checked_add(acc.offset()));
        if needed.is_none_or(|n| n > bytes.len()) {
            return Err(format!(
                "accessor {} ({count} elements of {elem} bytes at offset {}) runs past the end of bufferView {} ({} bytes)",
                acc.index(),
                acc.offset(),
                view.index(),
                bytes.len()
            ));
        }
    }
    if let Some(sparse) = acc.sparse() {
        let sc = sparse.count();
        if sc == 0 {
            // glTF requires at least one; the gltf crate computes `count - 1` (found by
            // fuzzing: an overflow panic in builds with overflow checks).
            return Err(format!("accessor {}: sparse count is 0", acc.index()));
        }
        let idx = sparse.indices();
        let idx_size = match idx.index_type() {
            gltf::accessor::sparse::IndexType::U8 => 1,
            gltf::accessor::sparse::IndexType::U16 => 2,
            gltf::accessor::sparse::IndexType::U32 => 4,
        };
        let val = sparse.values();
        // The extent the gltf crate's reader will slice: offset + stride·(count − 1) + size.
        let fits = |view: gltf::buffer::View, offset: usize, size: usize| -> Result<bool> {
            let bytes = view_bytes(buffers, &view)?;
            let stride = view.stride().unwrap_or(size).max(size);
            let end = stride
                .checked_mul(sc - 1)
                .and_then(|x| x.checked_add(size))
                .and_then(|x| x.checked_add(offset));
            Ok(end.is_some_and(|e| e <= bytes.len()))
        };
        if !fits(idx.view(), idx.offset(), idx_size)? || !fits(val.view(), val.offset(), elem)? {
            return Err(format!(
                "accessor {}: sparse data runs past its bufferView",
                acc.index()
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn strips_and_fans_keep_one_winding() {
        // A strip over a regular quad row: every triangle must face the same way.
        let p = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
        ];
        let idx: Vec<u32> = (0..6).collect();
        let strip = assemble_triangles(Mode::TriangleStrip, &idx);
        assert_eq!(strip.len(), 4);
        let normal = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|i| p[i as usize]);
            (b - a).cross(c - a).z.signum()
        };
        let first = normal(&strip[0]);
        assert!(strip.iter().all(|t| normal(t) == first), "{strip:?}");

        // A fan around vertex 0 of a convex polygon.
        let fan_pts = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let fan = assemble_triangles(Mode::TriangleFan, &[0, 1, 2, 3]);
        assert_eq!(fan, vec![[1, 2, 0], [2, 3, 0]]);
        for t in &fan {
            let [a, b, c] = t.map(|i| fan_pts[i as usize]);
            assert!((b - a).cross(c - a).z > 0.0);
        }
    }
}
