//! What a scene will take in memory, estimated from the file before its meshes are read (and
//! its textures from their images' headers before they are decoded), so that a file too large
//! for `--max-memory` is refused before it is loaded.

use gltf::mesh::Mode;

use super::instancing::{instance_count, instanced_mesh};
use super::MAX_NODE_DEPTH;

/// A loader's error message.
type Result<T> = std::result::Result<T, String>;

/// What loading a scene will allocate, estimated from the file's accessor counts and buffer
/// lengths before anything is read, and the decoded textures from their images' headers
/// ([`texture_memory`]). A mesh placed once, or flattened, counts once per placement; an
/// instanced one once, and each of its instances [`Self::BYTES_PER_INSTANCE`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryEstimate {
    /// Vertices stored (POSITION counts of triangle primitives).
    pub vertices: u64,
    /// Triangles stored (index counts / 3, or − 2 for strips and fans).
    pub triangles: u64,
    /// Instances of meshes stored once.
    pub instances: u64,
    /// The file itself and the buffers it declares, held while loading.
    pub input_bytes: u64,
    /// Decoded textures: how many, and their bytes ([`texture_memory`]).
    pub textures: u64,
    pub texture_bytes: u64,
}

impl MemoryEstimate {
    /// Per vertex: the scene's position, normal and UV (32 bytes) and the loader's decoded
    /// copies of them while a primitive is converted (32 bytes).
    pub const BYTES_PER_VERTEX: u64 = 64;
    /// Per triangle: the scene's indices and material (16 bytes), the loader's index list and
    /// assembled triangles (16 bytes), and the BVH: Embree keeps about 85 bytes per triangle
    /// (BVH and its geometry buffers, BENCHMARKS.md "Decisions measured earlier"), obvhs about 64;
    /// 90 covers either.
    pub const BYTES_PER_TRIANGLE: u64 = 32 + 90;
    /// Per instance: the scene's record (128 bytes), the loader's placement (128), and the
    /// BVH's: Embree's instance geometry and its share of the top-level BVH, or obvhs's
    /// inverse placement and node; measured in BENCHMARKS.md ("Instances").
    pub const BYTES_PER_INSTANCE: u64 = 640;

    /// The estimate in bytes (saturating: absurd counts give `u64::MAX`, never wrap).
    pub fn bytes(&self) -> u64 {
        self.vertices
            .saturating_mul(Self::BYTES_PER_VERTEX)
            .saturating_add(self.triangles.saturating_mul(Self::BYTES_PER_TRIANGLE))
            .saturating_add(self.instances.saturating_mul(Self::BYTES_PER_INSTANCE))
            .saturating_add(self.input_bytes)
            .saturating_add(self.texture_bytes)
    }
}

/// The decoded textures of `materials` (the scene's), whose images are `sizes` in pixels
/// (None for an image that cannot be read, which is never decoded): how many images are
/// decoded, and their bytes. An image is decoded once per colour encoding its textures read
/// it with, at [`super::image_header::BYTES_PER_TEXEL`]; the base colour image of a MASK or BLEND
/// material also once more as the alpha channel alpha coverage tests (4 bytes per texel).
/// Every material counts, used or not, and every texture, whether the integrator reads it
/// or not: an estimate from above.
pub(super) fn texture_memory(
    materials: &[super::Material],
    sizes: &[Option<(u32, u32)>],
) -> (u64, u64) {
    use std::collections::HashSet;
    let texels = |image: usize| match sizes.get(image) {
        Some(Some((w, h))) => Some(*w as u64 * *h as u64),
        _ => None,
    };
    let mut decoded = HashSet::new();
    let mut alpha = HashSet::new();
    for m in materials {
        decoded.extend(m.texture_images());
        if let (Some(t), true) = (
            &m.base_color_texture,
            m.alpha_mode != super::AlphaMode::Opaque,
        ) {
            alpha.insert(t.image);
        }
    }
    let mut count = 0u64;
    let mut bytes = 0u64;
    for &(image, _) in &decoded {
        if let Some(n) = texels(image) {
            count += 1;
            bytes = bytes.saturating_add(n.saturating_mul(super::image_header::BYTES_PER_TEXEL));
        }
    }
    for &image in &alpha {
        if let Some(n) = texels(image) {
            bytes = bytes.saturating_add(n.saturating_mul(4));
        }
    }
    (count, bytes)
}

/// Walks the node graph of `scene` once: refuses cycles, nodes with more than one parent (glTF
/// requires disjoint trees; shared subtrees would be flattened once per path, exponentially
/// often) and hierarchies deeper than [`MAX_NODE_DEPTH`], and counts how often each mesh is
/// placed (nodes × `EXT_mesh_gpu_instancing` instances). Then sums the vertex and triangle
/// counts the scene will store from the accessors' declared counts: a mesh that will be
/// instanced ([`instanced_mesh`]) once, any other once per placement. Returns the estimate and
/// the placements per mesh.
pub(super) fn estimate_memory(
    doc: &gltf::Document,
    scene: &gltf::Scene,
    flatten_instances: bool,
) -> Result<(MemoryEstimate, Vec<u64>)> {
    fn walk(
        doc: &gltf::Document,
        node: &gltf::Node,
        path: &mut Vec<usize>,
        seen: &mut std::collections::HashSet<usize>,
        uses: &mut [u64],
    ) -> Result<()> {
        let index = node.index();
        if path.contains(&index) {
            return Err(format!(
                "node {index} is its own ancestor (the node graph has a cycle)"
            ));
        }
        if !seen.insert(index) {
            return Err(format!(
                "node {index} has more than one parent or appears twice in the scene (glTF requires the node hierarchy to be disjoint trees)"
            ));
        }
        if path.len() >= MAX_NODE_DEPTH {
            return Err(format!(
                "the node hierarchy is deeper than {MAX_NODE_DEPTH} levels"
            ));
        }
        if let Some(mesh) = node.mesh() {
            let copies = instance_count(doc, node).unwrap_or(1) as u64;
            let n = &mut uses[mesh.index()];
            *n = n.saturating_add(copies);
        }
        path.push(index);
        for child in node.children() {
            walk(doc, &child, path, seen, uses)?;
        }
        path.pop();
        Ok(())
    }
    let mut uses = vec![0u64; doc.meshes().len()];
    let mut seen = std::collections::HashSet::new();
    for node in scene.nodes() {
        walk(doc, &node, &mut Vec::new(), &mut seen, &mut uses)?;
    }
    let mut est = MemoryEstimate::default();
    for mesh in doc.meshes() {
        let placements = uses[mesh.index()];
        let copies = match instanced_mesh(placements, flatten_instances) {
            true => {
                est.instances = est.instances.saturating_add(placements);
                1
            }
            false => placements,
        };
        for primitive in mesh.primitives() {
            let Some(positions) = primitive.get(&gltf::Semantic::Positions) else {
                continue;
            };
            let vertices = positions.count() as u64;
            let indices = primitive.indices().map_or(vertices, |a| a.count() as u64);
            let triangles = match primitive.mode() {
                Mode::Triangles => indices / 3,
                Mode::TriangleStrip | Mode::TriangleFan => indices.saturating_sub(2),
                _ => continue,
            };
            est.vertices = est.vertices.saturating_add(vertices.saturating_mul(copies));
            est.triangles = est
                .triangles
                .saturating_add(triangles.saturating_mul(copies));
        }
    }
    Ok((est, uses))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::format_bytes;

    #[test]
    fn memory_estimates_saturate_and_format() {
        let huge = MemoryEstimate {
            vertices: u64::MAX / 2,
            triangles: u64::MAX / 2,
            instances: u64::MAX,
            input_bytes: u64::MAX,
            textures: 1,
            texture_bytes: u64::MAX,
        };
        assert_eq!(huge.bytes(), u64::MAX);
        let small = MemoryEstimate {
            vertices: 8,
            triangles: 4,
            instances: 3,
            input_bytes: 1000,
            textures: 2,
            texture_bytes: 5000,
        };
        assert_eq!(small.bytes(), 8 * 64 + 4 * 122 + 3 * 640 + 1000 + 5000);
        assert_eq!(format_bytes(100), "100 bytes");
        assert_eq!(format_bytes(64 << 10), "64.0 KiB");
        assert_eq!(format_bytes(3 << 29), "1.5 GiB");
        assert_eq!(format_bytes(u64::MAX), "16.0 EiB");
    }
}
