//! The glTF 2.0 metallic-roughness BRDF, as Appendix B of the specification writes it
//! (single scattering):
//!
//! material = mix(dielectric_brdf, metal_brdf, metallic), the metal's specular lobe tinted by
//! Schlick's Fresnel of f0 = base colour, the dielectric's a Fresnel mix (F0 = 0.04, the
//! reflectance of IOR 1.5) of the specular layer over Lambertian base colour. Schlick's F is
//! affine in f0, so the two specular lobes mix into one:
//!
//! - f0 = mix(0.04, base colour, metallic), c_diff = (1 − metallic) base colour;
//! - F = f0 + (1 − f0)(1 − |wo·h|)⁵, and the dielectric's F_d the same with f0 = 0.04;
//! - f = (1 − F_d) c_diff / π + F D V, D and V those of GGX with α = roughness² ([`Ggx`]).
//!
//! (The specification's "suggested simplification" weights the diffuse lobe by 1 − F instead
//! of 1 − F_d: the same model at metallic 0 and 1 only; between, it darkens, a white half-metal
//! returning three quarters of the light. strata renders the normative mix.)
//!
//! The specification's model gains and loses energy: single scattering among the microfacets
//! loses it on rough surfaces (a white metal of roughness 1 returns 1 − ln 2 ≈ 31% of the
//! light at normal incidence, [`AlbedoTable`]), and the dielectric's diffuse weight 1 − F(wo·h), whose
//! h lies between wo and each wi, gives a white dielectric more than comes in at grazing
//! incidence (1.26 at 77° and roughness 0.1). With energy compensation, the default:
//!
//! - the specular lobe is scaled by 1 + f0 (1 − E(μo)) / E(μo), E the single-scattering albedo
//!   of GGX with F = 1 (Turquin 2019, "Practical multiple scattering compensation for
//!   microfacet models", eq. 8): a white metal then returns all the light, and the lobe keeps
//!   its shape, so sampling is unchanged (not reciprocal: it reads μo alone, as Turquin notes).
//!   The metal's lobe and the dielectric's are each compensated with their own f0 and then
//!   mixed by metallic: F·(1 + f0 k) is not affine in f0, and compensating the mixed f0 would
//!   leave a white half-metal of roughness 1 at 0.84;
//! - the diffuse lobe takes what the specular layer leaves, c_diff/π · (1 − A(μo))(1 − A(μi))
//!   / (1 − A_avg), A(μ) that layer's albedo (f0·E + (1 − f0)·E_s, compensated) and A_avg its
//!   cosine-weighted average (the energy-conserving layering of Kulla & Conty 2017, §5.3): a
//!   white dielectric then returns all of it, and the lobe stays reciprocal.
//!
//! `single_scattering()` gives the specification's model exactly.
//!
//! Below [`Ggx::SMOOTH_ALPHA`] the specular lobe is a perfect mirror: a delta lobe of weight
//! F(n·wo) that only sampling finds. Directions come from the specular lobe (the visible
//! normals, Heitz 2018) or the cosine, chosen with probability proportional to their
//! Fresnel-weighted luminance at wo; `pdf` is the mixture's density.

use glam::{Vec2, Vec3};

use super::bsdf::{BsdfFlags, BsdfSample};
use super::environment::luminance;
use super::microfacet::{AlbedoTable, Ggx};
use crate::sampling::warps::square_to_cosine_hemisphere;

/// The dielectric's reflectance at normal incidence: IOR 1.5, ((1.5 − 1) / (1.5 + 1))².
const DIELECTRIC_F0: f32 = 0.04;

/// The glTF metallic-roughness BRDF of one surface point, in the shading frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GltfBrdf {
    /// Linear base colour (factor × texture × vertex colour).
    pub base_color: Vec3,
    pub metallic: f32,
    /// The GGX roughness α = roughness².
    pub alpha: f32,
    /// Compensate the energy single scattering loses (see the module documentation).
    pub energy_compensation: bool,
}

impl GltfBrdf {
    /// The BRDF for a material's `roughness` (perceptual, as the file gives it).
    /// With energy compensation, the default.
    pub fn new(base_color: Vec3, metallic: f32, roughness: f32) -> GltfBrdf {
        GltfBrdf {
            base_color,
            metallic,
            alpha: roughness * roughness,
            energy_compensation: true,
        }
    }

    /// The same BRDF without energy compensation: the specification's model exactly.
    pub fn single_scattering(self) -> GltfBrdf {
        GltfBrdf {
            energy_compensation: false,
            ..self
        }
    }

    fn ggx(&self) -> Ggx {
        Ggx { alpha: self.alpha }
    }

    /// f0 and c_diff.
    #[inline]
    fn colors(&self) -> (Vec3, Vec3) {
        let f0 = Vec3::splat(DIELECTRIC_F0).lerp(self.base_color, self.metallic);
        (f0, self.base_color * (1.0 - self.metallic))
    }

    /// The probability of sampling the specular lobe seen from `wo`: its share of the
    /// Fresnel-weighted luminance, F(n·wo) against (1 − F_d(n·wo)) c_diff (1 where the diffuse
    /// lobe is black).
    #[inline]
    fn specular_probability(&self, wo: Vec3) -> f32 {
        let (f0, c_diff) = self.colors();
        let specular = luminance(schlick(f0, wo.z));
        let f_d = schlick(Vec3::splat(DIELECTRIC_F0), wo.z);
        let diffuse = luminance((Vec3::ONE - f_d) * c_diff);
        if diffuse <= 0.0 {
            1.0
        } else {
            specular / (specular + diffuse)
        }
    }

    pub fn flags(&self) -> BsdfFlags {
        let specular = match self.ggx().is_smooth() {
            true => BsdfFlags::SPECULAR_REFLECTION,
            false => BsdfFlags::GLOSSY_REFLECTION,
        };
        match self.metallic < 1.0 && self.base_color.max_element() > 0.0 {
            true => specular.union(BsdfFlags::DIFFUSE),
            false => specular,
        }
    }

    /// f(wo, wi)·cos θi, the delta lobe left out.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wo + wi).normalize();
        let (f0, c_diff) = self.colors();
        let wo_h = wo.dot(h).abs();
        let f = schlick(f0, wo_h);
        let diffuse = match self.energy_compensation {
            false => {
                let f_d = schlick(Vec3::splat(DIELECTRIC_F0), wo_h);
                (Vec3::ONE - f_d) * c_diff * std::f32::consts::FRAC_1_PI
            }
            true => self.layered_diffuse(c_diff, wo.z, wi.z),
        };
        let ggx = self.ggx();
        let specular = match ggx.is_smooth() {
            true => Vec3::ZERO,
            false => self.specular_weight(f, wo_h, wo.z) * (ggx.d(h) * ggx.v(wo, wi)),
        };
        (diffuse + specular) * wi.z
    }

    /// The specular lobe's Fresnel weight, `f` = F(`wo_h`) of the mixed f0, seen from direction
    /// cosine `mu`: without compensation `f` itself; with it, the metal's and the dielectric's
    /// weights F (1 + f0 (1 − E) / E) (Turquin), each with its own F and f0, mixed by metallic.
    #[inline]
    fn specular_weight(&self, f: Vec3, wo_h: f32, mu: f32) -> Vec3 {
        if !self.energy_compensation {
            return f;
        }
        let e = AlbedoTable::get().e(mu, self.alpha).max(1e-3);
        let k = (1.0 - e) / e;
        let dielectric = schlick(Vec3::splat(DIELECTRIC_F0), wo_h) * (1.0 + DIELECTRIC_F0 * k);
        let metal = schlick(self.base_color, wo_h) * (Vec3::ONE + self.base_color * k);
        dielectric.lerp(metal, self.metallic)
    }

    /// The specular layer's albedo A(μ) = (f0·E + (1 − f0)·E_s)(1 + f0 (1 − E) / E), seen from
    /// direction cosine `mu`, compensated.
    #[inline]
    fn specular_albedo(&self, f0: Vec3, mu: f32) -> Vec3 {
        let table = AlbedoTable::get();
        let e = table.e(mu, self.alpha).max(1e-3);
        let e_s = table.e_s(mu, self.alpha);
        (f0 * e + (Vec3::ONE - f0) * e_s) * (Vec3::ONE + f0 * ((1.0 - e) / e))
    }

    /// The cosine-weighted average of [`GltfBrdf::specular_albedo`] over μ: the table's
    /// averages of E, E_s and E_s (1 − E) / E combined as the expanded product
    /// f0·E + (1 − f0)·E_s + f0²(1 − E) + f0 (1 − f0)·E_s (1 − E) / E requires.
    #[inline]
    fn specular_albedo_average(&self, f0: Vec3) -> Vec3 {
        let [e, e_s, ratio] = AlbedoTable::get().averages(self.alpha);
        let g = Vec3::ONE - f0;
        f0 * e + g * e_s + f0 * f0 * (1.0 - e) + f0 * g * ratio
    }

    /// The diffuse lobe under the dielectric's compensated specular layer (see the module
    /// documentation).
    #[inline]
    fn layered_diffuse(&self, c_diff: Vec3, mu_o: f32, mu_i: f32) -> Vec3 {
        if c_diff == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let f0 = Vec3::splat(DIELECTRIC_F0);
        let leave = |mu| (Vec3::ONE - self.specular_albedo(f0, mu)).max(Vec3::ZERO);
        let rest = (Vec3::ONE - self.specular_albedo_average(f0)).max(Vec3::splat(1e-4));
        c_diff * std::f32::consts::FRAC_1_PI * leave(mu_o) * leave(mu_i) / rest
    }

    /// The mixture's density of `wi`, the delta lobe left out.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let p_specular = self.specular_probability(wo);
        let ggx = self.ggx();
        let specular = match ggx.is_smooth() {
            true => 0.0,
            false => p_specular * ggx.reflection_pdf(wo, wi),
        };
        specular + (1.0 - p_specular) * wi.z * std::f32::consts::FRAC_1_PI
    }

    /// A direction and the lobe it comes from: the lobe chosen with `u.x`, whose stretch
    /// that chose it is reused for the direction.
    pub fn sample_direction(&self, wo: Vec3, u: Vec2) -> Option<(Vec3, BsdfFlags)> {
        if wo.z <= 0.0 {
            return None;
        }
        const BELOW_ONE: f32 = 1.0 - f32::EPSILON / 2.0;
        let p_specular = self.specular_probability(wo);
        if u.x < p_specular {
            let u = Vec2::new((u.x / p_specular).min(BELOW_ONE), u.y);
            let ggx = self.ggx();
            if ggx.is_smooth() {
                let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
                return Some((mirror, BsdfFlags::SPECULAR_REFLECTION));
            }
            let h = ggx.sample_visible_normal(wo, u);
            let wi = 2.0 * wo.dot(h) * h - wo;
            (wi.z > 0.0).then_some((wi, BsdfFlags::GLOSSY_REFLECTION))
        } else {
            let v = ((u.x - p_specular) / (1.0 - p_specular)).min(BELOW_ONE);
            let wi = square_to_cosine_hemisphere(Vec2::new(v, u.y));
            Some((wi, BsdfFlags::DIFFUSE_REFLECTION))
        }
    }

    /// The mirror's sample in direction `wi`: weight F(n·wo) (a mirror's half vector is the
    /// normal) and the probability of having chosen the lobe.
    pub fn sample_delta(&self, wo: Vec3, wi: Vec3, flags: BsdfFlags) -> Option<BsdfSample> {
        let (f0, _) = self.colors();
        let pdf = self.specular_probability(wo);
        (pdf > 0.0).then_some(BsdfSample {
            wi,
            f_cos: schlick(f0, wo.z),
            pdf,
            flags,
        })
    }
}

/// Schlick's Fresnel approximation F = f0 + (1 − f0)(1 − cos)⁵.
#[inline]
fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    f0 + (Vec3::ONE - f0) * (m2 * m2 * m)
}
