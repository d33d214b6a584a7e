//! `KHR_materials_ior`: the index of refraction of the material's dielectric part, which
//! sets its specular reflectance at normal incidence, f0 = ((ior − 1) / (ior + 1))², and
//! its glass's refraction.
//!
//! | property | type   | default | range | read as                                          |
//! |----------|--------|---------|-------|--------------------------------------------------|
//! | `ior`    | number | 1.5     | ≥ 1   | the index (a value below 1 warns and takes 1.5)  |

use super::Reader;
use crate::scene::DEFAULT_IOR;

pub const NAME: &str = "KHR_materials_ior";

/// Material `m`'s index of refraction: glTF's 1.5 without the extension, or where the file's
/// is not a number of at least 1 (with a warning).
pub fn read(m: &gltf::Material, r: &mut dyn Reader, label: &str) -> f32 {
    match m.ior() {
        None => DEFAULT_IOR,
        Some(ior) if ior.is_finite() && ior >= 1.0 => ior,
        Some(ior) => {
            r.warn(format!(
                "{label}: {NAME} ior {ior} is not a number of at least 1; 1.5 is used"
            ));
            DEFAULT_IOR
        }
    }
}
