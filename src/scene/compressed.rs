//! Compressed glTF, resolved into plain glTF before the loader reads it:
//! `EXT_meshopt_compression` / `KHR_meshopt_compression` buffer views are decoded into the
//! buffers they describe ([`super::meshopt`]), then `KHR_draco_mesh_compression` primitives
//! into a new buffer their accessors point at ([`super::draco`]) ([`decode_geometry`]).
//! After both, every accessor reads plain (possibly `KHR_mesh_quantization`-quantized) data.

use gltf::json;

type Result<T> = std::result::Result<T, String>;

/// Decodes the document's compressed geometry into `buffers` (its buffers, meshopt
/// placeholders included): meshopt views in place, Draco primitives into one more buffer.
/// Returns the document, changed where Draco primitives were.
pub(super) fn decode_geometry(
    document: gltf::Document,
    buffers: &mut Vec<Vec<u8>>,
) -> Result<gltf::Document> {
    super::meshopt::decode_views(&document, buffers)?;
    let has_draco = document.meshes().any(|m| {
        m.primitives()
            .any(|p| p.extension_value("KHR_draco_mesh_compression").is_some())
    });
    if !has_draco {
        return Ok(document);
    }
    let mut root = document.into_json();
    super::draco::decode_primitives(&mut root, buffers)?;
    Ok(gltf::Document::from_json_without_validation(root))
}

/// The paths (`accessors[i].bufferView`) of the accessors that `KHR_draco_mesh_compression`
/// streams fill: the attributes each stream names and its primitive's indices. They have no
/// bufferView, which the `gltf` crate's validation (not glTF's) refuses.
pub(super) fn draco_accessors(root: &json::Root) -> std::collections::HashSet<String> {
    let mut paths = std::collections::HashSet::new();
    for primitive in root.meshes.iter().flat_map(|m| &m.primitives) {
        let Some(ext) = (primitive.extensions.as_ref())
            .and_then(|e| e.others.get("KHR_draco_mesh_compression"))
        else {
            continue;
        };
        let names = ext.get("attributes").and_then(serde_json::Value::as_object);
        for (semantic, accessor) in &primitive.attributes {
            let json::validation::Checked::Valid(semantic) = semantic else {
                continue;
            };
            if names.is_some_and(|n| n.contains_key(&semantic.to_string())) {
                paths.insert(format!("accessors[{}].bufferView", accessor.value()));
            }
        }
        if let Some(indices) = primitive.indices {
            paths.insert(format!("accessors[{}].bufferView", indices.value()));
        }
    }
    paths
}
