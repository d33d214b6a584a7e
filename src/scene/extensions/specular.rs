//! `KHR_materials_specular`: the strength and colour of the dielectric's specular layer
//! (its f0 and the Fresnel it weighs, [`crate::shading::gltf_brdf`]).
//!
//! | property                    | type        | default   | range          | read as        |
//! |-----------------------------|-------------|-----------|----------------|----------------|
//! | `specularFactor`            | number      | 1         | [0, 1]         | weight         |
//! | `specularTexture`           | textureInfo | —         | linear         | weight × A     |
//! | `specularColorFactor`       | number[3]   | [1, 1, 1] | [0, ∞)         | colour         |
//! | `specularColorTexture`      | textureInfo | —         | sRGB           | colour × RGB   |

use glam::{Vec3, Vec4};

use super::{bind_texture, Encoding, Reader, Result};
use crate::scene::TextureRef;

pub const NAME: &str = "KHR_materials_specular";

/// The dielectric specular layer's strength and colour: specular = specularFactor × the
/// texture's A, specular colour = specularColorFactor × the colour texture's RGB (sRGB).
#[derive(Clone, Debug, PartialEq)]
pub struct SpecularLayer<T = TextureRef> {
    pub factor: f32,
    pub texture: Option<T>,
    pub color: Vec3,
    pub color_texture: Option<T>,
}

/// Material `m`'s specular layer, None without the extension.
pub fn read(m: &gltf::Material, r: &mut dyn Reader, label: &str) -> Result<Option<SpecularLayer>> {
    let Some(sp) = m.specular() else {
        return Ok(None);
    };
    let (factor, color) = (
        sp.specular_factor(),
        Vec3::from_array(sp.specular_color_factor()),
    );
    if !(factor.is_finite() && (0.0..=1.0).contains(&factor)) {
        return Err(format!(
            "{label}: {NAME} specularFactor {factor} is not a number between 0 and 1"
        ));
    }
    if !(color.is_finite() && color.min_element() >= 0.0) {
        return Err(format!(
            "{label}: {NAME} specularColorFactor {color} is not three numbers of at least 0"
        ));
    }
    let what = format!("{label} specular texture");
    let texture = sp
        .specular_texture()
        .map(|info| r.texture_info(&info, &what));
    let what = format!("{label} specular colour texture");
    let color_texture = (sp.specular_color_texture()).map(|info| r.texture_info(&info, &what));
    Ok(Some(SpecularLayer {
        factor,
        texture,
        color,
        color_texture,
    }))
}

impl<T> SpecularLayer<T> {
    /// The layer with its textures bound by `bind`.
    pub fn bind<U, E>(
        &self,
        bind: &mut impl FnMut(&T, Encoding) -> std::result::Result<Option<U>, E>,
    ) -> std::result::Result<SpecularLayer<U>, E> {
        Ok(SpecularLayer {
            factor: self.factor,
            texture: bind_texture(&self.texture, Encoding::Linear, bind)?,
            color: self.color,
            color_texture: bind_texture(&self.color_texture, Encoding::Srgb, bind)?,
        })
    }

    /// False: it reads no tangent frame.
    pub fn needs_tangents(&self) -> bool {
        false
    }

    /// True when it reads a texture.
    pub fn textured(&self) -> bool {
        self.texture.is_some() || self.color_texture.is_some()
    }

    /// The layer's weight and colour at a point whose texels `lookup` reads.
    #[inline]
    pub fn at(&self, lookup: impl Fn(&T) -> Vec4) -> (f32, Vec3) {
        let (mut weight, mut color) = (self.factor, self.color);
        if let Some(t) = &self.texture {
            weight *= lookup(t).w;
        }
        if let Some(t) = &self.color_texture {
            color *= lookup(t).truncate();
        }
        (weight, color)
    }
}
