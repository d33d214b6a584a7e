//! Compressed glTF, resolved into plain glTF before the loader reads it: geometry in
//! `EXT_meshopt_compression` / `KHR_meshopt_compression` buffer views is decoded into the
//! buffers they describe ([`super::meshopt`]) by [`decode_geometry`]. After it, every accessor
//! reads plain (possibly `KHR_mesh_quantization`-quantized) data.

type Result<T> = std::result::Result<T, String>;

/// Decodes the document's compressed geometry into `buffers` (its buffers, meshopt
/// placeholders included). Returns the document.
pub(super) fn decode_geometry(
    document: gltf::Document,
    buffers: &mut [Vec<u8>],
) -> Result<gltf::Document> {
    super::meshopt::decode_views(&document, buffers)?;
    Ok(document)
}
