//! KTX2 textures with Basis Universal payloads (`KHR_texture_basisu`): ETC1S (BasisLZ
//! supercompression) and UASTC LDR 4×4, with or without Zstandard supercompression, transcoded
//! to 8-bit RGBA by the reference Basis Universal transcoder (the `basisu_c_sys` crate, which
//! also carries its Zstandard decoder). Only the base mip level of a 2D texture is used, as
//! strata filters textures bilinearly at that level.
//!
//! The texels are the stored bytes: whether they are sRGB or linear is the glTF texture slot's
//! business ([`super::Encoding`]), not the container's transfer function.

use basisu_c_sys::extra::{
    basisu_transcoder_init, BasisuTranscoder, ChannelType, SupportedTextureCompression,
};
use basisu_c_sys::{BasisTextureFormat, TranscodeTargetFormat};

// The header's fields, which the scene reads to size a texture before it is decoded.
pub use crate::scene::image_header::{
    is_ktx2, ktx2_dimensions as dimensions, KTX2_HEADER_BYTES as HEADER_BYTES,
    KTX2_IDENTIFIER as IDENTIFIER,
};

/// The most bytes of RGBA8 a transcoded texture may take (the `image` crate's default limit
/// for the other formats).
const MAX_BYTES: u64 = 512 << 20;

/// The base level of a KTX2 Basis Universal texture as 8-bit RGBA, or why it cannot be had.
pub fn decode(bytes: &[u8]) -> Result<image::RgbaImage, String> {
    basisu_transcoder_init();
    let transcoder = BasisuTranscoder::new(
        bytes,
        SupportedTextureCompression::empty(),
        ChannelType::Auto,
    )
    .map_err(|e| {
        format!("not a readable KTX2 Basis Universal texture (the transcoder says: {e})")
    })?;
    let info = transcoder.get_info();
    match info.basis_format {
        BasisTextureFormat::Etc1s | BasisTextureFormat::UastcLdr4x4 => {}
        other => {
            return Err(format!(
                "a KTX2 texture in Basis format {other:?}; KHR_texture_basisu allows ETC1S and UASTC LDR 4x4"
            ))
        }
    }
    if info.faces != 1 || info.layers > 1 {
        return Err(format!(
            "a KTX2 texture of {} faces and {} layers; a glTF texture is one 2D image",
            info.faces, info.layers
        ));
    }
    let (width, height) = (info.width, info.height);
    if width == 0 || height == 0 {
        return Err("a KTX2 texture with no pixels".into());
    }
    if width as u64 * height as u64 * 4 > MAX_BYTES {
        return Err(format!(
            "a {width} × {height} KTX2 texture, larger than strata decodes ({} MiB of RGBA8)",
            MAX_BYTES >> 20
        ));
    }
    let image = transcoder
        .transcode(Some(TranscodeTargetFormat::RGBA32), Some(false))
        .map_err(|e| format!("the KTX2 texture does not transcode: {e}"))?;
    // Levels are stored one after another, the base level first.
    let base = width as usize * height as usize * 4;
    let texels = image
        .data
        .get(..base)
        .ok_or("the transcoder returned less than the base level")?
        .to_vec();
    image::RgbaImage::from_raw(width, height, texels)
        .ok_or_else(|| "the transcoder returned a base level of the wrong size".into())
}
