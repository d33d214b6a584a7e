//! `KHR_materials_emissive_strength`: a scale of the emissive factor beyond 1, so that a
//! material can emit more than the core's [0, 1] colour allows.
//!
//! | property           | type   | default | range  | read as                             |
//! |--------------------|--------|---------|--------|-------------------------------------|
//! | `emissiveStrength` | number | 1       | [0, ∞) | emitted radiance × the strength     |

pub const NAME: &str = "KHR_materials_emissive_strength";

/// The scale of material `m`'s emissive factor: its emissive strength, 1 without one.
pub fn read(m: &gltf::Material) -> f32 {
    m.emissive_strength().unwrap_or(1.0)
}
