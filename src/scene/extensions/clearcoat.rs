//! `KHR_materials_clearcoat`: a clear coat over the material, a GGX lobe of IOR 1.5 mixed
//! with the layer below by its weight times Fresnel ([`crate::shading::layers`]).
//!
//! | property                    | type                | default | range  | read as             |
//! |-----------------------------|---------------------|---------|--------|---------------------|
//! | `clearcoatFactor`           | number              | 0       | [0, 1] | weight              |
//! | `clearcoatTexture`          | textureInfo         | —       |        | weight × R          |
//! | `clearcoatRoughnessFactor`  | number              | 0       | [0, 1] | roughness           |
//! | `clearcoatRoughnessTexture` | textureInfo         | —       |        | roughness × G       |
//! | `clearcoatNormalTexture`    | normalTextureInfo   | —       |        | the coat's normal   |
//!
//! A factor of 0 is no coat (None). Without its own normal map the coat follows the vertex
//! normals, not the base's map.

use glam::Vec4;

use super::{bind_texture, unit_number, Encoding, Reader, Result};
use crate::scene::TextureRef;

pub const NAME: &str = "KHR_materials_clearcoat";

/// A clear coat: its weight, clearcoatFactor × the texture's R; its roughness,
/// clearcoatRoughnessFactor × the roughness texture's G; and its own normal map.
#[derive(Clone, Debug, PartialEq)]
pub struct ClearcoatLayer<T = TextureRef> {
    pub factor: f32,
    pub texture: Option<T>,
    pub roughness: f32,
    pub roughness_texture: Option<T>,
    pub normal_texture: Option<T>,
    pub normal_scale: f32,
}

/// Material `m`'s clear coat, None without the extension or where its factor is 0.
pub fn read(m: &gltf::Material, r: &mut dyn Reader, label: &str) -> Result<Option<ClearcoatLayer>> {
    let Some(ext) = m.extension_value(NAME) else {
        return Ok(None);
    };
    let what = format!("{label} {NAME}");
    let factor = unit_number(ext, "clearcoatFactor", 0.0, &what)?;
    let roughness = unit_number(ext, "clearcoatRoughnessFactor", 0.0, &what)?;
    let texture = r.texture(ext, "clearcoatTexture", &what)?;
    let roughness_texture = r.texture(ext, "clearcoatRoughnessTexture", &what)?;
    let normal_texture = r.texture(ext, "clearcoatNormalTexture", &what)?;
    let normal_scale =
        match ext
            .get("clearcoatNormalTexture")
            .and_then(|t| t.get("scale"))
        {
            None => 1.0,
            Some(s) => s.as_f64().filter(|s| s.is_finite()).ok_or_else(|| {
                format!("{what}: clearcoatNormalTexture scale {s} is not a number")
            })? as f32,
        };
    if factor == 0.0 {
        return Ok(None);
    }
    Ok(Some(ClearcoatLayer {
        factor,
        texture,
        roughness,
        roughness_texture,
        normal_texture,
        normal_scale,
    }))
}

impl<T> ClearcoatLayer<T> {
    /// The layer with its textures bound by `bind`.
    pub fn bind<U, E>(
        &self,
        bind: &mut impl FnMut(&T, Encoding) -> std::result::Result<Option<U>, E>,
    ) -> std::result::Result<ClearcoatLayer<U>, E> {
        Ok(ClearcoatLayer {
            factor: self.factor,
            texture: bind_texture(&self.texture, Encoding::Linear, bind)?,
            roughness: self.roughness,
            roughness_texture: bind_texture(&self.roughness_texture, Encoding::Linear, bind)?,
            normal_texture: bind_texture(&self.normal_texture, Encoding::Linear, bind)?,
            normal_scale: self.normal_scale,
        })
    }

    /// True with its own normal map, which reads the tangent frame.
    pub fn needs_tangents(&self) -> bool {
        self.normal_texture.is_some()
    }

    /// True when it reads a texture.
    pub fn textured(&self) -> bool {
        self.texture.is_some() || self.roughness_texture.is_some() || self.normal_texture.is_some()
    }

    /// The coat's weight and roughness at a point whose texels `lookup` reads.
    #[inline]
    pub fn at(&self, lookup: impl Fn(&T) -> Vec4) -> (f32, f32) {
        let (mut weight, mut roughness) = (self.factor, self.roughness);
        if let Some(t) = &self.texture {
            weight *= lookup(t).x;
        }
        if let Some(t) = &self.roughness_texture {
            roughness *= lookup(t).y;
        }
        (weight, roughness)
    }
}
