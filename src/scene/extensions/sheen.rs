//! `KHR_materials_sheen`: a sheen of fibres over the material, Conty Estevez & Kulla's
//! "Charlie" lobe, the layer below scaled by the extension's albedo scaling
//! ([`crate::shading::layers`]).
//!
//! | property                | type        | default   | range     | read as                |
//! |-------------------------|-------------|-----------|-----------|------------------------|
//! | `sheenColorFactor`      | number[3]   | [0, 0, 0] | [0, 1]    | colour                 |
//! | `sheenColorTexture`     | textureInfo | —         | sRGB      | colour × RGB           |
//! | `sheenRoughnessFactor`  | number      | 0         | [0, 1]    | roughness              |
//! | `sheenRoughnessTexture` | textureInfo | —         | linear    | roughness × A          |
//!
//! A black colour factor is no sheen (None).

use glam::{Vec3, Vec4};

use super::{bind_texture, unit_number, Encoding, Reader, Result};
use crate::scene::TextureRef;

pub const NAME: &str = "KHR_materials_sheen";

/// A sheen: its colour, sheenColorFactor × the colour texture's RGB (sRGB), and roughness,
/// sheenRoughnessFactor × the roughness texture's A.
#[derive(Clone, Debug, PartialEq)]
pub struct SheenLayer<T = TextureRef> {
    pub color: Vec3,
    pub color_texture: Option<T>,
    pub roughness: f32,
    pub roughness_texture: Option<T>,
}

/// Material `m`'s sheen, None without the extension or where its colour is black.
pub fn read(m: &gltf::Material, r: &mut dyn Reader, label: &str) -> Result<Option<SheenLayer>> {
    let Some(ext) = m.extension_value(NAME) else {
        return Ok(None);
    };
    let what = format!("{label} {NAME}");
    let color = match ext.get("sheenColorFactor") {
        None => Vec3::ZERO,
        Some(v) => {
            let c: Option<Vec<f32>> = (v.as_array()).map(|a| {
                a.iter()
                    .filter_map(|x| x.as_f64().map(|x| x as f32))
                    .collect()
            });
            match c {
                Some(c) if c.len() == 3 && c.iter().all(|x| (0.0..=1.0).contains(x)) => {
                    Vec3::new(c[0], c[1], c[2])
                }
                _ => {
                    return Err(format!(
                        "{what}: sheenColorFactor {v} is not three numbers between 0 and 1"
                    ))
                }
            }
        }
    };
    let roughness = unit_number(ext, "sheenRoughnessFactor", 0.0, &what)?;
    let color_texture = r.texture(ext, "sheenColorTexture", &what)?;
    let roughness_texture = r.texture(ext, "sheenRoughnessTexture", &what)?;
    if color == Vec3::ZERO {
        return Ok(None);
    }
    Ok(Some(SheenLayer {
        color,
        color_texture,
        roughness,
        roughness_texture,
    }))
}

impl<T> SheenLayer<T> {
    /// The layer with its textures bound by `bind`.
    pub fn bind<U, E>(
        &self,
        bind: &mut impl FnMut(&T, Encoding) -> std::result::Result<Option<U>, E>,
    ) -> std::result::Result<SheenLayer<U>, E> {
        Ok(SheenLayer {
            color: self.color,
            color_texture: bind_texture(&self.color_texture, Encoding::Srgb, bind)?,
            roughness: self.roughness,
            roughness_texture: bind_texture(&self.roughness_texture, Encoding::Linear, bind)?,
        })
    }

    /// False: it reads no tangent frame.
    pub fn needs_tangents(&self) -> bool {
        false
    }

    /// True when it reads a texture.
    pub fn textured(&self) -> bool {
        self.color_texture.is_some() || self.roughness_texture.is_some()
    }

    /// The sheen's colour and roughness at a point whose texels `lookup` reads.
    #[inline]
    pub fn at(&self, lookup: impl Fn(&T) -> Vec4) -> (Vec3, f32) {
        let (mut color, mut roughness) = (self.color, self.roughness);
        if let Some(t) = &self.color_texture {
            color *= lookup(t).truncate();
        }
        if let Some(t) = &self.roughness_texture {
            roughness *= lookup(t).w;
        }
        (color, roughness)
    }
}
