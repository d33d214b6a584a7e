//! `KHR_texture_transform`: an affine map of a texture's coordinates, on any textureInfo
//! (the core material's and the extensions').
//!
//! | property   | type      | default | read as                                              |
//! |------------|-----------|---------|------------------------------------------------------|
//! | `offset`   | number[2] | [0, 0]  | T                                                    |
//! | `rotation` | number    | 0       | R, radians counter-clockwise in UV space             |
//! | `scale`    | number[2] | [1, 1]  | S                                                    |
//! | `texCoord` | integer   | —       | replaces the textureInfo's `texCoord`                |
//!
//! uv' = T · R · S · uv with R = [[cos, sin], [−sin, cos]] (the extension's matrices), kept as
//! a 3×2 affine map (columns) in [`TextureRef::transform`].

use glam::Vec2;

use crate::scene::TextureRef;

pub const NAME: &str = "KHR_texture_transform";

/// No transform.
pub const IDENTITY: [Vec2; 3] = [Vec2::X, Vec2::Y, Vec2::ZERO];

/// The affine map (columns) of `rotation`, `scale` and `offset`.
pub fn matrix(rotation: f32, [sx, sy]: [f32; 2], offset: [f32; 2]) -> [Vec2; 3] {
    let (s, c) = rotation.sin_cos();
    [
        Vec2::new(c * sx, -s * sx),
        Vec2::new(s * sy, c * sy),
        Vec2::from_array(offset),
    ]
}

/// A textureInfo's transform as the glTF crate reads it, and its `texCoord` override.
pub fn read(info: &gltf::texture::Info) -> ([Vec2; 3], Option<u32>) {
    match info.texture_transform() {
        None => (IDENTITY, None),
        Some(t) => (matrix(t.rotation(), t.scale(), t.offset()), t.tex_coord()),
    }
}

/// The transform in a textureInfo's JSON `info` (an extension's texture, which the glTF crate
/// does not parse), and its `texCoord` override; values that are not numbers take their
/// defaults.
pub fn read_json(info: &gltf::json::Value) -> ([Vec2; 3], Option<u32>) {
    let Some(t) = (info.get("extensions")).and_then(|e| e.get(NAME)) else {
        return (IDENTITY, None);
    };
    let pair = |k: &str, default: [f32; 2]| -> [f32; 2] {
        match t.get(k).and_then(|v| v.as_array()) {
            Some(a) if a.len() == 2 => [
                a[0].as_f64().unwrap_or(default[0] as f64) as f32,
                a[1].as_f64().unwrap_or(default[1] as f64) as f32,
            ],
            _ => default,
        }
    };
    let rotation = t.get("rotation").and_then(|r| r.as_f64()).unwrap_or(0.0) as f32;
    let transform = matrix(
        rotation,
        pair("scale", [1.0, 1.0]),
        pair("offset", [0.0, 0.0]),
    );
    let tex_coord = t.get("texCoord").and_then(|t| t.as_u64()).map(|t| t as u32);
    (transform, tex_coord)
}

/// Applies a texture binding's transform to `uv`.
#[inline]
pub fn apply(t: &TextureRef, uv: Vec2) -> Vec2 {
    t.transform[0] * uv.x + t.transform[1] * uv.y + t.transform[2]
}
