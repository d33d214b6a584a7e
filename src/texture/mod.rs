//! Decoded textures and their lookup: glTF UVs (origin at the image's top-left), the
//! `KHR_texture_transform` affine map, glTF wrap modes and bilinear filtering. Colour textures
//! (base colour, emission) are sRGB-encoded in glTF and decoded to linear once, at load; data
//! textures (metallic-roughness) are read as stored ([`Encoding`]).

pub mod ktx2;

use std::path::Path;

use glam::{Vec2, Vec4};

pub use crate::scene::extensions::texture_transform::apply as transform_uv;
use crate::scene::image_header::describe;
pub use crate::scene::image_header::{dimensions, BYTES_PER_TEXEL};
pub use crate::scene::Encoding;
use crate::scene::{ImageSource, Wrap};

// The scene's memory estimate counts this many bytes per texel.
const _: () = assert!(std::mem::size_of::<Vec4>() as u64 == BYTES_PER_TEXEL);

/// A decoded image in linear RGBA, row 0 at the top.
///
/// Or one channel of it: `Image<f32>`, e.g. the alpha that alpha coverage reads
/// ([`Image::alpha`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Image<T = Vec4> {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<T>,
}

/// What an [`Image`] may hold: values that bilinear filtering blends. A channel of a
/// [`Vec4`] image filters to the same bits as that channel of the whole texel (the same
/// products and sums, lane by lane).
pub trait Texel: Copy + std::ops::Mul<f32, Output = Self> + std::ops::Add<Output = Self> {}

impl Texel for Vec4 {}
impl Texel for f32 {}

/// sRGB transfer function, decoding (IEC 61966-2-1).
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Decodes encoded image bytes: KTX2 (Basis Universal, [`super::ktx2`]) by its identifier,
/// PNG, JPEG and WebP by the `image` crate's guess from the bytes.
fn decode_bytes(data: &[u8]) -> Result<image::DynamicImage, String> {
    if ktx2::is_ktx2(data) {
        return ktx2::decode(data).map(image::DynamicImage::ImageRgba8);
    }
    image::load_from_memory(data).map_err(|e| describe(&e))
}

/// Decodes an image file: a KTX2 file by its identifier, the others by the `image` crate.
fn decode_file(path: &Path) -> Result<image::DynamicImage, String> {
    use std::io::Read;
    let mut head = [0u8; 12];
    let is_ktx2 = std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| ktx2::is_ktx2(&head));
    if is_ktx2 {
        let data = std::fs::read(path).map_err(|e| e.to_string())?;
        return ktx2::decode(&data).map(image::DynamicImage::ImageRgba8);
    }
    image::open(path).map_err(|e| describe(&e))
}

impl Image {
    /// Decodes PNG, JPEG, WebP or KTX2 (Basis Universal) bytes; colour channels are sRGB-decoded, alpha kept linear.
    /// `index` is the image's index in the glTF file, for the error message.
    pub fn decode(source: &ImageSource, index: usize, scene_path: &Path) -> Result<Image, String> {
        Image::decode_as(source, index, scene_path, Encoding::Srgb)
    }

    /// Decodes PNG, JPEG, WebP or KTX2 bytes whose colour channels are encoded as `encoding` says (alpha
    /// is always linear); an error names the scene (`scene_path`) and the image (`index`).
    pub fn decode_as(
        source: &ImageSource,
        index: usize,
        scene_path: &Path,
        encoding: Encoding,
    ) -> Result<Image, String> {
        Image::decode_source(source, encoding).map_err(|e| {
            let scene = scene_path.display();
            match source {
                ImageSource::File(path) => format!(
                    "{scene}: cannot decode image {index} ('{}'): {e}",
                    path.display()
                ),
                ImageSource::Bytes { .. } => {
                    format!("{scene}: cannot decode embedded image {index}: {e}")
                }
                ImageSource::Unreadable(_) => format!("{scene}: image {index}: {e}"),
            }
        })
    }

    /// [`Image::decode_as`], with an error that says only why the image cannot be had (the
    /// caller names it).
    pub fn decode_source(source: &ImageSource, encoding: Encoding) -> Result<Image, String> {
        let decoded = match source {
            ImageSource::File(path) => decode_file(path)?,
            ImageSource::Bytes { data, .. } => decode_bytes(data)?,
            ImageSource::Unreadable(why) => return Err(why.clone()),
        };
        let rgba = decoded.to_rgba32f();
        let (width, height) = rgba.dimensions();
        if width == 0 || height == 0 {
            return Err("the image has no pixels".into());
        }
        let texels = rgba
            .pixels()
            .map(|p| match encoding {
                Encoding::Srgb => Vec4::new(
                    srgb_to_linear(p[0]),
                    srgb_to_linear(p[1]),
                    srgb_to_linear(p[2]),
                    p[3],
                ),
                Encoding::Linear => Vec4::new(p[0], p[1], p[2], p[3]),
            })
            .collect();
        Ok(Image {
            width,
            height,
            texels,
        })
    }

    /// The mean of all texels (for light power estimates), summed in f64: an f32 sum of
    /// millions of texels stops growing once the texels fall below its rounding step.
    pub fn average(&self) -> Vec4 {
        let sum = self
            .texels
            .iter()
            .fold(glam::DVec4::ZERO, |sum, t| sum + t.as_dvec4());
        (sum / self.texels.len() as f64).as_vec4()
    }

    /// The alpha channel alone (a quarter of the memory).
    pub fn alpha(&self) -> Image<f32> {
        Image {
            width: self.width,
            height: self.height,
            texels: self.texels.iter().map(|t| t.w).collect(),
        }
    }
}

impl<T: Texel> Image<T> {
    #[inline]
    fn texel(&self, x: i64, y: i64, wrap_s: Wrap, wrap_t: Wrap) -> T {
        let x = wrap_index(x, self.width as i64, wrap_s);
        let y = wrap_index(y, self.height as i64, wrap_t);
        self.texels[(y * self.width as i64 + x) as usize]
    }

    /// Bilinear lookup at texture coordinates `uv` (already transformed), with texel centres
    /// at half-integer positions.
    #[inline]
    pub fn bilinear(&self, uv: Vec2, wrap_s: Wrap, wrap_t: Wrap) -> T {
        // Coordinates a billion texels out have no sub-texel precision left in f32; clamping
        // them keeps the integer texel indices (and x0 + 1) far from overflow, and gives
        // clamp-to-edge its edge texel. The loader replaces non-finite coordinates; the check
        // stays for coordinates a texture transform overflows.
        const FAR: f32 = 1e9;
        let x = (uv.x * self.width as f32 - 0.5).clamp(-FAR, FAR);
        let y = (uv.y * self.height as f32 - 0.5).clamp(-FAR, FAR);
        if !(x.is_finite() && y.is_finite()) {
            return self.texels[0];
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let a = self.texel(x0, y0, wrap_s, wrap_t);
        let b = self.texel(x0 + 1, y0, wrap_s, wrap_t);
        let c = self.texel(x0, y0 + 1, wrap_s, wrap_t);
        let d = self.texel(x0 + 1, y0 + 1, wrap_s, wrap_t);
        (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy
    }
}

/// Maps a texel index into `[0, n)` by the glTF wrap mode.
#[inline]
fn wrap_index(i: i64, n: i64, wrap: Wrap) -> i64 {
    match wrap {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let period = 2 * n;
            let m = i.rem_euclid(period);
            if m < n {
                m
            } else {
                period - 1 - m
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image_2x2() -> Image {
        Image {
            width: 2,
            height: 2,
            texels: vec![
                Vec4::new(0.0, 0.0, 0.0, 1.0),
                Vec4::new(1.0, 0.0, 0.0, 1.0),
                Vec4::new(0.0, 1.0, 0.0, 1.0),
                Vec4::new(0.0, 0.0, 1.0, 1.0),
            ],
        }
    }

    #[test]
    fn texel_centres_return_texels_and_midpoints_average() {
        let img = image_2x2();
        // Texel (1, 0) is the top-right texel: u = 0.75, v = 0.25.
        let v = img.bilinear(Vec2::new(0.75, 0.25), Wrap::ClampToEdge, Wrap::ClampToEdge);
        assert!(
            (v - Vec4::new(1.0, 0.0, 0.0, 1.0)).abs().max_element() < 1e-6,
            "{v}"
        );
        let mid = img.bilinear(Vec2::new(0.5, 0.5), Wrap::ClampToEdge, Wrap::ClampToEdge);
        assert!(
            (mid - Vec4::new(0.25, 0.25, 0.25, 1.0)).abs().max_element() < 1e-6,
            "{mid}"
        );
    }

    /// The alpha image filters to the same bits as the alpha channel of the whole texels,
    /// at any coordinates and wrap mode: alpha coverage and shading read one alpha.
    #[test]
    fn the_alpha_image_filters_as_the_alpha_channel_does() {
        let mut next = crate::sampling::hash::uniform_sequence(5);
        let img = Image {
            width: 3,
            height: 5,
            texels: (0..15)
                .map(|_| Vec4::new(next(), next(), next(), next()))
                .collect(),
        };
        let alpha = img.alpha();
        for _ in 0..1000 {
            let uv = Vec2::new(next() * 6.0 - 3.0, next() * 6.0 - 3.0);
            for wrap in [Wrap::Repeat, Wrap::MirroredRepeat, Wrap::ClampToEdge] {
                let want = img.bilinear(uv, wrap, Wrap::Repeat).w;
                assert_eq!(
                    alpha.bilinear(uv, wrap, Wrap::Repeat).to_bits(),
                    want.to_bits()
                );
            }
        }
    }

    #[test]
    fn wrap_modes_follow_gltf() {
        assert_eq!(wrap_index(-1, 4, Wrap::Repeat), 3);
        assert_eq!(wrap_index(5, 4, Wrap::Repeat), 1);
        assert_eq!(wrap_index(-3, 4, Wrap::ClampToEdge), 0);
        assert_eq!(wrap_index(9, 4, Wrap::ClampToEdge), 3);
        // Mirrored: 0 1 2 3 | 3 2 1 0 | 0 1 ...
        let m: Vec<i64> = (-2..10)
            .map(|i| wrap_index(i, 4, Wrap::MirroredRepeat))
            .collect();
        assert_eq!(m, vec![1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0, 1]);
    }

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        // sRGB 0.5 is linear 0.214 (IEC 61966-2-1).
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-5);
    }
}
