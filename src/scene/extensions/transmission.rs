//! `KHR_materials_transmission` and `KHR_materials_volume`: the share of the dielectric
//! part's light that passes through the surface, as glass ([`crate::shading::dielectric`]),
//! and the medium the surface bounds.
//!
//! | extension, property                   | type        | default   | range  | read as      |
//! |---------------------------------------|-------------|-----------|--------|--------------|
//! | transmission `transmissionFactor`     | number      | 0         | [0, 1] | share        |
//! | transmission `transmissionTexture`    | textureInfo | —         | linear | share × R    |
//! | volume `thicknessFactor`              | number      | 0         | [0, ∞) | > 0: a volume|
//! | volume `attenuationColor`             | number[3]   | [1, 1, 1] | [0, 1] | Beer–Lambert |
//! | volume `attenuationDistance`          | number      | +∞        | > 0    | Beer–Lambert |
//!
//! The surface point's glass takes w = share × (1 − metallic) of the material; it refracts
//! where the material bounds a volume (a thickness above 0), else it is a thin wall. The
//! thickness texture is not read: a path tracer measures the distance inside.

use glam::Vec3;

use super::{bind_texture, Encoding, Reader, Result};
use crate::scene::TextureRef;

pub const NAME: &str = "KHR_materials_transmission";
pub const VOLUME: &str = "KHR_materials_volume";

/// A material's transmission: its factor (0 without the extension), its texture (R), and
/// the volume the surface bounds, if it bounds one.
#[derive(Clone, Debug, PartialEq)]
pub struct Transmission<T = TextureRef> {
    pub factor: f32,
    pub texture: Option<T>,
    pub volume: Option<Volume>,
}

/// The medium inside a transmissive material's closed surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Volume {
    /// Light travelling `attenuation_distance` inside keeps `attenuation_color` of itself
    /// (Beer–Lambert); infinite: the medium absorbs nothing.
    pub attenuation_color: Vec3,
    pub attenuation_distance: f32,
}

impl Volume {
    /// The absorption coefficient σ_a = −ln(attenuation colour) / attenuation distance, per
    /// channel (KHR_materials_volume): transmittance over a distance d is exp(−σ_a d).
    pub fn absorption(&self) -> Vec3 {
        if !self.attenuation_distance.is_finite() {
            return Vec3::ZERO;
        }
        let c = self.attenuation_color.max(Vec3::splat(f32::MIN_POSITIVE));
        -Vec3::new(c.x.ln(), c.y.ln(), c.z.ln()) / self.attenuation_distance
    }
}

/// Material `m`'s transmission and volume.
pub fn read(m: &gltf::Material, r: &mut dyn Reader, label: &str) -> Result<Transmission> {
    let transmission = m.transmission();
    let factor = transmission
        .as_ref()
        .map_or(0.0, |t| t.transmission_factor());
    if !(0.0..=1.0).contains(&factor) {
        return Err(format!(
            "{label}: {NAME} transmissionFactor {factor} is not between 0 and 1"
        ));
    }
    let texture = (transmission.as_ref())
        .and_then(|t| t.transmission_texture())
        .map(|info| r.texture_info(&info, &format!("{label} transmission texture")));
    let volume = match m.volume() {
        Some(v) if transmission.is_some() && v.thickness_factor() > 0.0 => {
            let color = Vec3::from_array(v.attenuation_color());
            let distance = v.attenuation_distance();
            if !(color.is_finite() && color.min_element() >= 0.0 && distance > 0.0) {
                return Err(format!(
                    "{label}: {VOLUME} needs an attenuationColor of finite values of at least 0 and a positive attenuationDistance (got {color}, {distance})"
                ));
            }
            Some(Volume {
                attenuation_color: color,
                attenuation_distance: distance,
            })
        }
        _ => None,
    };
    Ok(Transmission {
        factor,
        texture,
        volume,
    })
}

impl<T> Default for Transmission<T> {
    /// No transmission: an opaque material.
    fn default() -> Self {
        Transmission {
            factor: 0.0,
            texture: None,
            volume: None,
        }
    }
}

impl<T> Transmission<T> {
    /// The transmission with its texture bound by `bind`.
    pub fn bind<U, E>(
        &self,
        bind: &mut impl FnMut(&T, Encoding) -> std::result::Result<Option<U>, E>,
    ) -> std::result::Result<Transmission<U>, E> {
        Ok(Transmission {
            factor: self.factor,
            texture: bind_texture(&self.texture, Encoding::Linear, bind)?,
            volume: self.volume,
        })
    }
}
