//! What the scene knows of an image before decoding it: its size from its header (a KTX2
//! file's own, the others' through the `image` crate), for the memory estimate and for
//! finding images that cannot be read at load; the decoding itself is [`crate::texture`]'s.

use super::ImageSource;

/// The 12-byte identifier every KTX 2.0 file starts with.
pub const KTX2_IDENTIFIER: [u8; 12] = [
    0xAB, b'K', b'T', b'X', b' ', b'2', b'0', 0xBB, b'\r', b'\n', 0x1A, b'\n',
];

/// The bytes of a KTX 2.0 file's header up to and including its level count: the
/// identifier, then nine little-endian u32 (vkFormat, typeSize, pixelWidth, pixelHeight,
/// pixelDepth, layerCount, faceCount, levelCount, supercompressionScheme), of which
/// [`ktx2_dimensions`] reads the width and height.
pub const KTX2_HEADER_BYTES: usize = 12 + 9 * 4;

/// The base level's width and height from a KTX2 file's header (`bytes` holds at least its
/// first [`KTX2_HEADER_BYTES`]), without transcoding anything.
pub fn ktx2_dimensions(bytes: &[u8]) -> Result<(u32, u32), String> {
    let word = |offset: usize| {
        bytes
            .get(offset..offset + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    match (word(20), word(24)) {
        (Some(width), Some(height)) => Ok((width, height)),
        _ => Err("the KTX2 file ends inside its header (truncated?)".into()),
    }
}

/// True when `bytes` start as a KTX 2.0 file.
pub fn is_ktx2(bytes: &[u8]) -> bool {
    bytes.starts_with(&KTX2_IDENTIFIER)
}

/// The bytes each texel of a decoded texture takes: strata keeps textures as linear RGBA in
/// f32 (`texture::Image` of `Vec4`, which the texture module asserts), one level (no mip
/// maps), decoded once per colour encoding the image is bound with.
pub const BYTES_PER_TEXEL: u64 = 16;

/// The width and height of the image at `source`, read from its header without decoding it:
/// a KTX2 file's own header, the others' as the `image` crate reads them. An error says why
/// the image cannot be had (it does not name the image).
pub fn dimensions(source: &ImageSource) -> Result<(u32, u32), String> {
    use std::io::{BufReader, Cursor, Read};
    let (width, height) = match source {
        ImageSource::Unreadable(why) => return Err(why.clone()),
        ImageSource::Bytes { data, .. } if is_ktx2(data) => ktx2_dimensions(data)?,
        ImageSource::Bytes { data, .. } => image::ImageReader::new(Cursor::new(&data[..]))
            .with_guessed_format()
            .map_err(|e| e.to_string())?
            .into_dimensions()
            .map_err(|e| describe(&e))?,
        ImageSource::File(path) => {
            let cannot = |e: std::io::Error| format!("cannot read '{}': {e}", path.display());
            let file = std::fs::File::open(path).map_err(cannot)?;
            let mut head = Vec::with_capacity(KTX2_HEADER_BYTES);
            (&file)
                .take(KTX2_HEADER_BYTES as u64)
                .read_to_end(&mut head)
                .map_err(cannot)?;
            if is_ktx2(&head) {
                ktx2_dimensions(&head)?
            } else {
                let mut reader = BufReader::new(file);
                std::io::Seek::rewind(&mut reader).map_err(cannot)?;
                image::ImageReader::new(reader)
                    .with_guessed_format()
                    .map_err(cannot)?
                    .into_dimensions()
                    .map_err(|e| describe(&e))?
            }
        }
    };
    if width == 0 || height == 0 {
        return Err("the image has no pixels".into());
    }
    Ok((width, height))
}

/// The `image` crate's error in a message's words: its "format could not be determined"
/// names no format, so say which ones strata reads; a short read is a file cut short.
pub fn describe(e: &image::ImageError) -> String {
    match e {
        image::ImageError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            format!("the image ends before its data does (truncated?): {io}")
        }
        image::ImageError::Unsupported(_) => {
            format!("{e} (strata reads PNG, JPEG, WebP and KTX2 Basis Universal images)")
        }
        e => e.to_string(),
    }
}
