//! `KHR_materials_anisotropy`: the specular lobes' GGX roughness raised along one direction
//! of the tangent plane to mix(α, 1, strength²) ([`crate::shading::microfacet`]).
//!
//! | property             | type        | default | range   | read as                        |
//! |----------------------|-------------|---------|---------|--------------------------------|
//! | `anisotropyStrength` | number      | 0       | [0, 1]  | strength                       |
//! | `anisotropyRotation` | number      | 0       | radians | the direction's turn           |
//! | `anisotropyTexture`  | textureInfo | —       | linear  | RG: direction, B: strength ×   |
//!
//! The direction is the tangent turned by the rotation toward the bitangent, or the texture's
//! RG (mapped to [−1, 1]², in tangent and bitangent) turned by it. A strength of 0 is no
//! anisotropy (None).

use glam::{Vec2, Vec4};

use super::{bind_texture, unit_number, Encoding, Reader, Result};
use crate::scene::TextureRef;

pub const NAME: &str = "KHR_materials_anisotropy";

/// The specular lobes' anisotropy: `strength` (× the texture's B), `rotation` in radians
/// (and `turn`, its (cos, sin)), and the texture whose RG replace the tangent before that
/// rotation.
#[derive(Clone, Debug, PartialEq)]
pub struct AnisotropyLayer<T = TextureRef> {
    pub strength: f32,
    pub rotation: f32,
    pub turn: Vec2,
    pub texture: Option<T>,
}

/// Material `m`'s anisotropy, None without the extension or where its strength is 0.
pub fn read(
    m: &gltf::Material,
    r: &mut dyn Reader,
    label: &str,
) -> Result<Option<AnisotropyLayer>> {
    let Some(ext) = m.extension_value(NAME) else {
        return Ok(None);
    };
    let what = format!("{label} {NAME}");
    let strength = unit_number(ext, "anisotropyStrength", 0.0, &what)?;
    let rotation = match ext.get("anisotropyRotation") {
        None => 0.0,
        Some(v) => (v.as_f64())
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("{what}: anisotropyRotation {v} is not a number"))?
            as f32,
    };
    let texture = r.texture(ext, "anisotropyTexture", &what)?;
    if strength == 0.0 {
        return Ok(None);
    }
    Ok(Some(AnisotropyLayer {
        strength,
        rotation,
        turn: Vec2::new(rotation.cos(), rotation.sin()),
        texture,
    }))
}

impl<T> AnisotropyLayer<T> {
    /// The layer with its texture bound by `bind`.
    pub fn bind<U, E>(
        &self,
        bind: &mut impl FnMut(&T, Encoding) -> std::result::Result<Option<U>, E>,
    ) -> std::result::Result<AnisotropyLayer<U>, E> {
        Ok(AnisotropyLayer {
            strength: self.strength,
            rotation: self.rotation,
            turn: self.turn,
            texture: bind_texture(&self.texture, Encoding::Linear, bind)?,
        })
    }

    /// True: the direction is in the tangent frame.
    pub fn needs_tangents(&self) -> bool {
        true
    }

    /// True when it reads a texture.
    pub fn textured(&self) -> bool {
        self.texture.is_some()
    }

    /// The strength and the direction in the tangent frame ((tangent, bitangent)
    /// components) at a point whose texels `lookup` reads.
    #[inline]
    pub fn at(&self, lookup: impl Fn(&T) -> Vec4) -> (f32, Vec2) {
        let (mut strength, mut direction) = (self.strength, Vec2::X);
        if let Some(t) = &self.texture {
            let texel = lookup(t);
            direction = (Vec2::new(texel.x, texel.y) * 2.0 - Vec2::ONE).normalize_or_zero();
            strength *= texel.z;
        }
        // Turned counter-clockwise from the tangent toward the bitangent.
        (strength, self.turn.rotate(direction))
    }
}
