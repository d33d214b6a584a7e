//! `KHR_materials_iridescence`: a thin film over the specular lobes, whose interference
//! tints their Fresnel term ([`crate::shading::thin_film`]).
//!
//! | property                      | type        | default | range  | read as                  |
//! |-------------------------------|-------------|---------|--------|--------------------------|
//! | `iridescenceFactor`           | number      | 0       | [0, 1] | strength                 |
//! | `iridescenceTexture`          | textureInfo | —       | linear | strength × R             |
//! | `iridescenceIor`              | number      | 1.3     | ≥ 1    | the film's index         |
//! | `iridescenceThicknessMinimum` | number      | 100     | ≥ 0 nm | thickness at texel G = 0 |
//! | `iridescenceThicknessMaximum` | number      | 400     | ≥ 0 nm | thickness without texture, or at G = 1 |
//! | `iridescenceThicknessTexture` | textureInfo | —       | linear | thickness: mix(min, max, G) |
//!
//! A factor of 0 is no film (None).

use glam::Vec4;

use super::{bind_texture, number_at_least, unit_number, Encoding, Reader, Result};
use crate::scene::TextureRef;

pub const NAME: &str = "KHR_materials_iridescence";

/// A thin film: its strength, iridescenceFactor × the texture's R; its index of refraction;
/// its thickness in nm, `thickness_max`, or mix(`thickness_min`, `thickness_max`, the
/// thickness texture's G).
#[derive(Clone, Debug, PartialEq)]
pub struct IridescenceLayer<T = TextureRef> {
    pub factor: f32,
    pub texture: Option<T>,
    pub ior: f32,
    pub thickness_min: f32,
    pub thickness_max: f32,
    pub thickness_texture: Option<T>,
}

/// Material `m`'s thin film, None without the extension or where its factor is 0.
pub fn read(
    m: &gltf::Material,
    r: &mut dyn Reader,
    label: &str,
) -> Result<Option<IridescenceLayer>> {
    let Some(ext) = m.extension_value(NAME) else {
        return Ok(None);
    };
    let what = format!("{label} {NAME}");
    let factor = unit_number(ext, "iridescenceFactor", 0.0, &what)?;
    let ior = number_at_least(ext, "iridescenceIor", 1.3, 1.0, &what)?;
    let thickness_min = number_at_least(ext, "iridescenceThicknessMinimum", 100.0, 0.0, &what)?;
    let thickness_max = number_at_least(ext, "iridescenceThicknessMaximum", 400.0, 0.0, &what)?;
    let texture = r.texture(ext, "iridescenceTexture", &what)?;
    let thickness_texture = r.texture(ext, "iridescenceThicknessTexture", &what)?;
    if factor == 0.0 {
        return Ok(None);
    }
    Ok(Some(IridescenceLayer {
        factor,
        texture,
        ior,
        thickness_min,
        thickness_max,
        thickness_texture,
    }))
}

impl<T> IridescenceLayer<T> {
    /// The layer with its textures bound by `bind`.
    pub fn bind<U, E>(
        &self,
        bind: &mut impl FnMut(&T, Encoding) -> std::result::Result<Option<U>, E>,
    ) -> std::result::Result<IridescenceLayer<U>, E> {
        Ok(IridescenceLayer {
            factor: self.factor,
            texture: bind_texture(&self.texture, Encoding::Linear, bind)?,
            ior: self.ior,
            thickness_min: self.thickness_min,
            thickness_max: self.thickness_max,
            thickness_texture: bind_texture(&self.thickness_texture, Encoding::Linear, bind)?,
        })
    }

    /// False: it reads no tangent frame.
    pub fn needs_tangents(&self) -> bool {
        false
    }

    /// True when it reads a texture.
    pub fn textured(&self) -> bool {
        self.texture.is_some() || self.thickness_texture.is_some()
    }

    /// The film's strength and thickness (nm) at a point whose texels `lookup` reads.
    #[inline]
    pub fn at(&self, lookup: impl Fn(&T) -> Vec4) -> (f32, f32) {
        let mut factor = self.factor;
        if let Some(t) = &self.texture {
            factor *= lookup(t).x;
        }
        let thickness = match &self.thickness_texture {
            None => self.thickness_max,
            Some(t) => {
                let g = lookup(t).y;
                self.thickness_min + (self.thickness_max - self.thickness_min) * g
            }
        };
        (factor, thickness)
    }
}
