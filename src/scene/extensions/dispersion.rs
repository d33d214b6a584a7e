//! `KHR_materials_dispersion`: a refracting volume's index varies with the wavelength by
//! Cauchy's law for the Abbe number V = 20 / dispersion ([`crate::shading::spectrum`]); a
//! path that meets it carries one wavelength from then on.
//!
//! | property     | type   | default | range  | read as                                  |
//! |--------------|--------|---------|--------|------------------------------------------|
//! | `dispersion` | number | 0       | [0, ∞) | 20 / V_d (0: the index does not vary)     |
//!
//! Only a refracting volume (`KHR_materials_transmission` with `KHR_materials_volume`) has
//! anything to disperse; elsewhere the extension warns and is not rendered.

use super::{number_at_least, Reader, Result};

pub const NAME: &str = "KHR_materials_dispersion";

/// Material `m`'s dispersion (0 without the extension); `refracts`: the material bounds a
/// refracting volume, without which a dispersion warns.
pub fn read(m: &gltf::Material, r: &mut dyn Reader, label: &str, refracts: bool) -> Result<f32> {
    let dispersion = match m.extension_value(NAME) {
        None => 0.0,
        Some(ext) => {
            let what = format!("{label} {NAME}");
            number_at_least(ext, "dispersion", 0.0, 0.0, &what)?
        }
    };
    if dispersion > 0.0 && !refracts {
        r.warn(format!(
            "{label}: {NAME} needs a refracting volume (KHR_materials_transmission with KHR_materials_volume); without one it has nothing to disperse and is not rendered"
        ));
    }
    Ok(dispersion)
}
