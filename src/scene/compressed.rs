//! Compressed and modern-format glTF, resolved into plain glTF before the loader reads it:
//!
//! - textures: `EXT_texture_webp` and `KHR_texture_basisu` name their image in the texture's
//!   extension, with the core `source` an optional fallback (PNG or JPEG). strata decodes
//!   WebP and KTX2 (Basis Universal) images, so a texture's image is its extension's:
//!   `EXT_texture_webp` first, then `KHR_texture_basisu`, then the core `source`
//!   ([`prefer_texture_extensions`]). Images are decoded when a render needs them
//!   (`texture`, `texture::ktx2`).
//! - geometry: `EXT_meshopt_compression` / `KHR_meshopt_compression` buffer views are decoded
//!   into the buffers they describe ([`super::meshopt`]), then `KHR_draco_mesh_compression`
//!   primitives into a new buffer their accessors point at ([`super::draco`])
//!   ([`decode_geometry`]). After both, every accessor reads plain (possibly
//!   `KHR_mesh_quantization`-quantized) data.

use gltf::json;

type Result<T> = std::result::Result<T, String>;

/// Texture extensions whose image strata decodes, in order of preference.
const TEXTURE_EXTENSIONS: [&str; 2] = ["EXT_texture_webp", "KHR_texture_basisu"];

/// The document with each texture's `source` set to the image its first extension of
/// [`TEXTURE_EXTENSIONS`] names (a texture without them keeps its own). Run before
/// validation: a texture that only has an extension's image has no core `source`.
pub(super) fn prefer_texture_extensions(document: gltf::Document) -> Result<gltf::Document> {
    let names_extension = |t: &json::Texture| {
        t.extensions
            .as_ref()
            .is_some_and(|e| TEXTURE_EXTENSIONS.iter().any(|n| e.others.contains_key(*n)))
    };
    if !document.as_json().textures.iter().any(names_extension) {
        return Ok(document);
    }
    let mut root = document.into_json();
    let images = root.images.len();
    for (i, texture) in root.textures.iter_mut().enumerate() {
        let Some(others) = texture.extensions.as_ref().map(|e| &e.others) else {
            continue;
        };
        let Some((name, ext)) = TEXTURE_EXTENSIONS
            .iter()
            .find_map(|n| others.get(*n).map(|v| (*n, v)))
        else {
            continue;
        };
        let source = ext
            .get("source")
            .and_then(serde_json::Value::as_u64)
            .ok_or_else(|| format!("texture {i}: {name} has no source (an image index)"))?;
        if source >= images as u64 {
            return Err(format!(
                "texture {i}: {name} names image {source}, but the file has {images} image(s)"
            ));
        }
        texture.source = json::Index::new(source as u32);
    }
    Ok(gltf::Document::from_json_without_validation(root))
}

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
