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
//! - the metal's lobe gains Kulla & Conty's multiple-scattering lobe (2017, "Revisiting
//!   Physically Based Shading at Imageworks", §2.2 and the Fresnel term of its slides):
//!   F_ms (1 − E(μo))(1 − E(μi)) / (π (1 − E_avg)), E the single-scattering albedo of GGX with
//!   F = 1 and E_avg its cosine-weighted average ([`AlbedoTable`]), which returns 1 − E(μo),
//!   the energy single scattering loses, and F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)) the
//!   Fresnel of a walk of two or more bounces, F_avg = f0 + (1 − f0)/21 Schlick's
//!   cosine-weighted average. A white metal (F_ms = 1) returns all the light, and the lobe is
//!   reciprocal; it is drawn with the cosine, its share of the sampling being its energy. On
//!   grey metals it follows a random walk on the microsurface (Heitz et al. 2016) where
//!   Turquin's scaling of the single-scattering lobe did not (tests/multiple_scattering.rs,
//!   docs/khronos.md): the extra light leaves more evenly than the single-scattering lobe, and
//!   the Fresnel factor of k bounces tends to F_avg^k, not f0;
//! - the dielectric's specular lobe (f0 = 0.04, where the multiple scattering is a fraction of
//!   a percent) is scaled by 1 + f0 (1 − E(μo)) / E(μo) (Turquin 2019, "Practical multiple
//!   scattering compensation for microfacet models", eq. 8): it keeps its shape, so sampling
//!   is unchanged (not reciprocal: it reads μo alone, as Turquin notes). The metal's lobe and
//!   the dielectric's are each compensated with their own f0 and then mixed by metallic:
//!   compensating the mixed f0 would leave a white half-metal of roughness 1 dark;
//! - the diffuse lobe takes what the specular layer leaves, c_diff/π · (1 − A(μo))(1 − A(μi))
//!   / (1 − A_avg), A(μ) that layer's albedo (f0·E + (1 − f0)·E_s, compensated) and A_avg its
//!   cosine-weighted average (the energy-conserving layering of Kulla & Conty 2017, §5.3): a
//!   white dielectric then returns all of it, and the lobe stays reciprocal.
//!
//! `single_scattering()` gives the specification's model exactly.
//!
//! `KHR_materials_ior` replaces the dielectric's 0.04 by ((ior − 1) / (ior + 1))² everywhere
//! above ([`GltfBrdf::with_ior`]); the metal's f0 stays the base colour.
//!
//! `KHR_materials_specular` ([`GltfBrdf::with_specular`]) colours and weights the dielectric's
//! specular layer through the extension's `fresnel_mix`: f0_c = min(f0 × specularColor, 1),
//! F_c = Schlick of f0_c, the layer w F_c D V with w = specular, and the diffuse lobe below it
//! weighted by 1 − w max(F_c) in place of 1 − F_d. Compensated, the layer is scaled per channel
//! by Turquin's factor with f0_c, and the diffuse layering reads w times the layer albedo of
//! max(f0_c) (the quantity its weight takes). At w = 1 and a grey specularColor that leaves
//! the plain model's values.
//!
//! `KHR_materials_anisotropy` ([`GltfBrdf::with_anisotropy`]) stretches both specular lobes
//! along a direction of the tangent plane: α_t = mix(α, 1, strength²) along it, α along the
//! direction across it (the extension's `BRDF_specularAnisotropicGGX`). D, V and the visible
//! normals are GGX's anisotropic forms ([`AnisotropicGgx`]) in a frame turned about the
//! normal so that its x axis is the direction; the Fresnel terms and the compensation read
//! cosines with the normal alone, which the turn keeps. The compensation's tables are read at
//! the isotropic α of the same mean square slope, √((α_t² + α²) / 2). Over 72 views and
//! stretches (numerical quadrature, 28 Nov) its single-scattering albedo errs by −0.003 on
//! average against the stretched lobe's (worst 0.31, grazing views of the strongest
//! stretches), the arithmetic mean's by +0.043, and the geometric mean √(α_t α) is 0.06–0.35
//! too bright on three cases (a dark furnace). The tables cannot follow the view's azimuth against the
//! stretch: white metals stay within 7% of white in the furnace (`tests/materials.rs`),
//! against 15–48% lost without compensation.
//!
//! `KHR_materials_iridescence` ([`GltfBrdf::with_iridescence`]) puts a thin film over the
//! specular lobes: each lobe's Fresnel term F becomes mix(F, F_film, iridescence), F_film the
//! film's interference reflectance over that lobe's f0 ([`ThinFilm`], Belcour & Barla 2017)
//! at the microfacet's angle, as the extension's notes mix them. Without compensation the
//! diffuse lobe below takes 1 − the dielectric's mixed F; with it, the compensation and the
//! diffuse layering keep reading the film-free tables (an approximation: the film moves
//! energy between colours more than it adds or removes).
//!
//! Below [`Ggx::SMOOTH_ALPHA`] the specular lobe is a perfect mirror: a delta lobe of weight
//! F(n·wo) that only sampling finds. Directions come from the specular lobe (the visible
//! normals, Heitz 2018) or the cosine, chosen with probability proportional to their
//! Fresnel-weighted luminance at wo; `pdf` is the mixture's density.

use glam::{Vec2, Vec3};

use super::fresnel;
use super::lobe::{BsdfFlags, BsdfSample};
use super::microfacet::{AlbedoRow, AlbedoTable, AnisotropicGgx, Ggx, Microfacet};
use super::spectrum::luminance;
use super::thin_film::ThinFilm;
use crate::sampling::warps::square_to_cosine_hemisphere;

/// The dielectric's reflectance at normal incidence without `KHR_materials_ior`: IOR 1.5,
/// ((1.5 − 1) / (1.5 + 1))².
pub const DIELECTRIC_F0: f32 = 0.04;

/// The reflectance at normal incidence of a dielectric of index of refraction `ior` in air,
/// ((ior − 1) / (ior + 1))² (KHR_materials_ior, "dielectric_f0").
pub fn dielectric_f0(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    r * r
}

/// The glTF metallic-roughness BRDF of one surface point, in the shading frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GltfBrdf {
    /// Linear base colour (factor × texture × vertex colour).
    pub base_color: Vec3,
    pub metallic: f32,
    /// The GGX roughness α = roughness².
    pub alpha: f32,
    /// The dielectric part's reflectance at normal incidence ([`dielectric_f0`] of the
    /// material's index of refraction; 0.04 by default), the largest channel of
    /// `specular_f0` under `KHR_materials_specular`.
    pub dielectric_f0: f32,
    /// The dielectric specular layer's coloured f0_c and its weight w (KHR_materials_specular;
    /// without it, f0 in every channel and 1).
    pub specular_f0: Vec3,
    pub specular_weight: f32,
    /// Compensate the energy single scattering loses (see the module documentation).
    pub energy_compensation: bool,
    /// `KHR_materials_anisotropy`'s stretch of the specular lobes (None: isotropic).
    anisotropy: Option<Anisotropy>,
    /// `KHR_materials_iridescence`'s thin film over the specular lobes (None: no film).
    iridescence: Option<Iridescence>,
    /// Where α falls in the albedo table's rows.
    row: AlbedoRow,
    /// The terms that depend on the outgoing direction alone, for the one they were computed
    /// at ([`GltfBrdf::at`]): a path evaluates the BRDF at one wo many times.
    outgoing: Option<Outgoing>,
}

/// The specular lobes' anisotropy at a surface point: GGX roughness `alpha_t` along
/// `direction` (a unit vector of the shading frame's xy plane, as (cos φ, sin φ)) and
/// `alpha_b` across it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Anisotropy {
    alpha_t: f32,
    alpha_b: f32,
    direction: Vec2,
}

impl Anisotropy {
    /// The stretched distribution, in the frame of [`Anisotropy::turn`].
    #[inline(always)]
    fn ggx(&self) -> AnisotropicGgx {
        AnisotropicGgx::new(self.alpha_t, self.alpha_b)
    }

    /// Local direction `w` in the frame whose x axis is the stretch's direction: turned
    /// about z by the direction's angle backwards.
    #[inline(always)]
    fn turn(&self, w: Vec3) -> Vec3 {
        let back = Vec2::new(self.direction.x, -self.direction.y);
        back.rotate(w.truncate()).extend(w.z)
    }

    /// The inverse of [`Anisotropy::turn`].
    #[inline(always)]
    fn turn_back(&self, w: Vec3) -> Vec3 {
        self.direction.rotate(w.truncate()).extend(w.z)
    }
}

/// A thin film over the specular lobes: its share of their Fresnel term, the film, and the
/// index of the medium above it (air, or a clear coat's 1.5).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Iridescence {
    factor: f32,
    film: ThinFilm,
    outside: f32,
}

/// The parts of the BRDF that read wo alone.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Outgoing {
    wo: Vec3,
    /// The probability of choosing the specular lobe.
    p_specular: f32,
    /// The dielectric specular lobe's scale: w (1 + f0_c k), k = Turquin's (1 − E(μo)) /
    /// E(μo) (0 without compensation).
    specular_scale: Vec3,
    /// The metal's multiple-scattering lobe's factor of μo, weighted by metallic:
    /// metallic F_ms (1 − E(μo)) / (π (1 − E_avg)) (zero without compensation).
    multiple: Vec3,
    /// The layered diffuse lobe's factor of μo: c_diff / π · (1 − A(μo)) / (1 − A_avg), A the
    /// dielectric layer's compensated albedo (unused without compensation).
    diffuse: Vec3,
}

impl GltfBrdf {
    /// The BRDF for a material's `roughness` (perceptual, as the file gives it).
    /// With energy compensation, the default.
    pub fn new(base_color: Vec3, metallic: f32, roughness: f32) -> GltfBrdf {
        let alpha = roughness * roughness;
        GltfBrdf {
            base_color,
            metallic,
            alpha,
            dielectric_f0: DIELECTRIC_F0,
            specular_f0: Vec3::splat(DIELECTRIC_F0),
            specular_weight: 1.0,
            energy_compensation: true,
            anisotropy: None,
            iridescence: None,
            row: AlbedoRow::new(alpha),
            outgoing: None,
        }
    }

    /// The same BRDF with the dielectric part's index of refraction `ior`
    /// (`KHR_materials_ior`).
    pub fn with_ior(self, ior: f32) -> GltfBrdf {
        let f0 = dielectric_f0(ior);
        GltfBrdf {
            dielectric_f0: f0,
            specular_f0: Vec3::splat(f0),
            outgoing: None,
            ..self
        }
    }

    /// The same BRDF with `KHR_materials_specular`'s weight `specular` (specularFactor × the
    /// texture's A) and `color` (specularColorFactor × the texture's RGB) on the dielectric's
    /// specular layer, over the index of refraction already set.
    pub fn with_specular(self, specular: f32, color: Vec3) -> GltfBrdf {
        let f0 = (self.specular_f0 * color.max(Vec3::ZERO)).min(Vec3::ONE);
        GltfBrdf {
            dielectric_f0: f0.max_element(),
            specular_f0: f0,
            specular_weight: specular.clamp(0.0, 1.0),
            outgoing: None,
            ..self
        }
    }

    /// The same BRDF with its specular lobes stretched as `KHR_materials_anisotropy` says:
    /// roughness α_t = mix(α, 1, `strength`²) along `direction` (a vector of the shading
    /// frame's tangent plane, its z ignored) and α across it. Unchanged where the strength is
    /// 0, the direction has no length in the plane, or both roughnesses stay a mirror's; a
    /// mirror across a rough direction is given the least rough GGX ([`Ggx::SMOOTH_ALPHA`]).
    pub fn with_anisotropy(self, strength: f32, direction: Vec3) -> GltfBrdf {
        let s = strength.clamp(0.0, 1.0);
        let alpha_t = self.alpha + (1.0 - self.alpha) * s * s;
        let direction = Vec2::new(direction.x, direction.y).normalize_or_zero();
        if s == 0.0 || alpha_t < Ggx::SMOOTH_ALPHA || direction == Vec2::ZERO {
            return self;
        }
        let alpha_b = self.alpha.max(Ggx::SMOOTH_ALPHA);
        GltfBrdf {
            anisotropy: Some(Anisotropy {
                alpha_t,
                alpha_b,
                direction,
            }),
            // The isotropic α of the same mean square slope (see the module documentation).
            row: AlbedoRow::new(((alpha_t * alpha_t + alpha_b * alpha_b) / 2.0).sqrt()),
            outgoing: None,
            ..self
        }
    }

    /// The same BRDF under `KHR_materials_iridescence`'s thin film: each specular lobe's
    /// Fresnel term F becomes mix(F, F_film, `factor`), F_film the film's reflectance over
    /// that lobe's f0 ([`ThinFilm::reflectance`]; index `ior`, `thickness` nm) seen from a
    /// medium of index `outside` at the microfacet's angle. Unchanged where the factor is 0.
    /// Energy compensation keeps reading the film-free lobes' tables: an approximation.
    pub fn with_iridescence(self, factor: f32, ior: f32, thickness: f32, outside: f32) -> GltfBrdf {
        let factor = factor.clamp(0.0, 1.0);
        if factor == 0.0 {
            return self;
        }
        GltfBrdf {
            iridescence: Some(Iridescence {
                factor,
                film: ThinFilm {
                    ior,
                    thickness: thickness.max(0.0),
                },
                outside,
            }),
            outgoing: None,
            ..self
        }
    }

    /// The dielectric's and the metal's Fresnel terms at cosine `cos` between the view and
    /// the microfacet normal: Schlick's of f0_c and of the base colour, each mixed with the
    /// film's reflectance over it under iridescence.
    #[inline(always)]
    fn fresnel_pair(&self, cos: f32) -> (Vec3, Vec3) {
        let (f_d, f_metal) = (
            schlick(self.specular_f0, cos),
            schlick(self.base_color, cos),
        );
        match &self.iridescence {
            None => (f_d, f_metal),
            Some(i) => {
                let film = |f0: Vec3| i.film.reflectance(i.outside, f0, cos);
                let f_metal = match self.metallic > 0.0 {
                    true => f_metal.lerp(film(self.base_color), i.factor),
                    false => f_metal,
                };
                (f_d.lerp(film(self.specular_f0), i.factor), f_metal)
            }
        }
    }

    /// The same BRDF without energy compensation: the specification's model exactly.
    pub fn single_scattering(self) -> GltfBrdf {
        GltfBrdf {
            energy_compensation: false,
            outgoing: None,
            ..self
        }
    }

    /// The same BRDF with the terms of outgoing direction `wo` computed ahead: evaluations at
    /// that `wo` then skip them (any other `wo` still gets its own).
    #[inline]
    pub fn at(self, wo: Vec3) -> GltfBrdf {
        GltfBrdf {
            outgoing: Some(self.outgoing_terms(wo)),
            ..self
        }
    }

    #[inline]
    fn terms(&self, wo: Vec3) -> Outgoing {
        match self.outgoing {
            Some(o) if o.wo == wo => o,
            _ => self.outgoing_terms(wo),
        }
    }

    fn outgoing_terms(&self, wo: Vec3) -> Outgoing {
        let c_diff = self.diffuse_color();
        let specular = luminance(self.specular_fresnel(wo.z));
        let diffuse = luminance(self.diffuse_weight(wo.z) * c_diff);
        let p_specular = {
            match diffuse <= 0.0 {
                true => 1.0,
                false => specular / (specular + diffuse),
            }
        };
        if !self.energy_compensation || wo.z <= 0.0 {
            return Outgoing {
                wo,
                p_specular,
                specular_scale: Vec3::splat(self.specular_weight),
                multiple: Vec3::ZERO,
                diffuse: Vec3::ZERO,
            };
        }
        let table = AlbedoTable::get();
        let (a_o, k, e_o) = self.dielectric_albedo(table, wo.z);
        let multiple = self.multiple_scattering(table, e_o);
        // The multiple-scattering lobe is drawn with the cosine: its energy joins the
        // diffuse lobe's in the choice of lobe.
        let p_specular = {
            let spread = diffuse
                + luminance(multiple)
                    * std::f32::consts::PI
                    * (1.0 - table.averages_in(self.row)[0]);
            match spread <= 0.0 {
                true => 1.0,
                false => specular / (specular + spread),
            }
        };
        let diffuse = match c_diff == Vec3::ZERO {
            true => Vec3::ZERO,
            false => {
                let rest = (1.0 - self.dielectric_albedo_average(table)).max(1e-4);
                c_diff * (std::f32::consts::FRAC_1_PI * (1.0 - a_o).max(0.0) / rest)
            }
        };
        Outgoing {
            wo,
            p_specular,
            specular_scale: self.specular_weight * (Vec3::ONE + self.specular_f0 * k),
            multiple,
            diffuse,
        }
    }

    /// The metal's multiple-scattering lobe's factor of μo (Kulla & Conty 2017):
    /// metallic F_ms (1 − E(μo)) / (π (1 − E_avg)), per channel of f0 = base colour, with
    /// F_avg = f0 + (1 − f0)/21 and F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)); zero for a
    /// mirror (its delta lobe loses nothing) or a dielectric.
    fn multiple_scattering(&self, table: &AlbedoTable, e_o: f32) -> Vec3 {
        if self.metallic <= 0.0 || self.smooth() {
            return Vec3::ZERO;
        }
        let e_avg = table.averages_in(self.row)[0];
        let f_avg = self.base_color + (Vec3::ONE - self.base_color) * (1.0 / 21.0);
        let f_ms = f_avg * f_avg * e_avg / (Vec3::ONE - f_avg * (1.0 - e_avg));
        f_ms * (self.metallic * (1.0 - e_o).max(0.0) * std::f32::consts::FRAC_1_PI
            / (1.0 - e_avg).max(1e-4))
    }

    /// The isotropic specular lobes' distribution (see [`Anisotropy::ggx`]).
    #[inline(always)]
    fn ggx(&self) -> Ggx {
        Ggx::new(self.alpha)
    }

    /// True when the specular lobe is a perfect mirror (never once stretched:
    /// [`GltfBrdf::with_anisotropy`] keeps mirrors isotropic).
    #[inline(always)]
    fn smooth(&self) -> bool {
        self.anisotropy.is_none() && self.ggx().is_smooth()
    }

    /// c_diff, the diffuse lobe's colour.
    #[inline]
    fn diffuse_color(&self) -> Vec3 {
        self.base_color * (1.0 - self.metallic)
    }

    /// The specular lobes' Fresnel weight at cosine `cos`: the dielectric's w F_c and the
    /// metal's Schlick F of its base colour, mixed by metallic. (Schlick's F is affine in f0:
    /// without KHR_materials_specular this is F of the mixed f0.)
    #[inline(always)]
    fn specular_fresnel(&self, cos: f32) -> Vec3 {
        if self.iridescence.is_some() {
            let (f_d, f_metal) = self.fresnel_pair(cos);
            return (self.specular_weight * f_d).lerp(f_metal, self.metallic);
        }
        let f0 = self.specular_f0.lerp(self.base_color, self.metallic);
        match self.specular_weight == 1.0 {
            true => schlick(f0, cos),
            false => (self.specular_weight * schlick(self.specular_f0, cos))
                .lerp(schlick(self.base_color, cos), self.metallic),
        }
    }

    /// The dielectric's diffuse weight 1 − w max(F_c) at cosine `cos` (1 − F_d without
    /// KHR_materials_specular).
    #[inline(always)]
    fn diffuse_weight(&self, cos: f32) -> Vec3 {
        let f_c = schlick(self.specular_f0, cos);
        Vec3::ONE - self.specular_weight * Vec3::splat(f_c.max_element())
    }

    /// A rough estimate of the light the BRDF returns toward `wo`: the Fresnel-weighted
    /// luminances of its lobes that its own choice of lobe weighs, for a layer above it that
    /// chooses between itself and this BRDF ([`super::layers::Layered`]).
    pub fn sampling_albedo(&self, wo: Vec3) -> f32 {
        luminance(self.specular_fresnel(wo.z))
            + luminance(self.diffuse_weight(wo.z) * self.diffuse_color())
    }

    /// The probability of sampling the specular lobe seen from `wo`: its share of the
    /// Fresnel-weighted luminance, F(n·wo) against (1 − F_d(n·wo)) c_diff (1 where the diffuse
    /// lobe is black).
    #[inline]
    fn specular_probability(&self, wo: Vec3) -> f32 {
        self.terms(wo).p_specular
    }

    pub fn flags(&self) -> BsdfFlags {
        let specular = match self.smooth() {
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
        let o = self.terms(wo);
        match &self.anisotropy {
            None => self.eval_in(&o, &self.ggx(), wo, wi),
            Some(a) => self.eval_in(&o, &a.ggx(), a.turn(wo), a.turn(wi)),
        }
    }

    /// [`GltfBrdf::eval`] with distribution `m`, wo and wi in its frame.
    #[inline(always)]
    fn eval_in<M: Microfacet>(&self, o: &Outgoing, m: &M, wo: Vec3, wi: Vec3) -> Vec3 {
        let h = (wo + wi).normalize();
        self.eval_at(o, m, wo, wi, h, m.d(h))
    }

    /// [`GltfBrdf::eval`] and [`GltfBrdf::pdf`] together, the half vector and D computed
    /// once: what MIS asks of a light sample's direction, and BSDF sampling of its own. The
    /// same operations as the two apart, so the same values.
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let o = self.terms(wo);
        match &self.anisotropy {
            None => self.eval_pdf_in(&o, &self.ggx(), wo, wi),
            Some(a) => self.eval_pdf_in(&o, &a.ggx(), a.turn(wo), a.turn(wi)),
        }
    }

    /// [`GltfBrdf::eval_pdf`] with distribution `m`, wo and wi in its frame.
    #[inline(always)]
    fn eval_pdf_in<M: Microfacet>(&self, o: &Outgoing, m: &M, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let h = (wo + wi).normalize();
        let d = m.d(h);
        (
            self.eval_at(o, m, wo, wi, h, d),
            self.pdf_at(o, m, wo, wi, d),
        )
    }

    /// [`GltfBrdf::eval`] for wo and wi above the surface (in the frame of distribution `m`),
    /// given wo's terms, the half vector and D(h).
    #[inline]
    fn eval_at<M: Microfacet>(
        &self,
        o: &Outgoing,
        m: &M,
        wo: Vec3,
        wi: Vec3,
        h: Vec3,
        d: f32,
    ) -> Vec3 {
        let wo_h = wo.dot(h).abs();
        let (f_d, f_metal) = self.fresnel_pair(wo_h);
        let w = self.specular_weight;
        let diffuse = match self.energy_compensation {
            false => {
                let c_diff = self.base_color * (1.0 - self.metallic);
                (Vec3::ONE - w * Vec3::splat(f_d.max_element()))
                    * c_diff
                    * std::f32::consts::FRAC_1_PI
            }
            true => {
                let (a_i, _, e_i) = self.dielectric_albedo(AlbedoTable::get(), wi.z);
                o.diffuse * (1.0 - a_i).max(0.0) + o.multiple * (1.0 - e_i).max(0.0)
            }
        };
        let specular = match m.is_smooth() {
            true => Vec3::ZERO,
            false => {
                // The dielectric's Fresnel weight w F_c scaled by Turquin's 1 + f0 (1 − E(μo)) /
                // E(μo) (k = 0 without compensation; `specular_scale`) and the metal's, mixed
                // by metallic: F of the mixed f0 when uncompensated and w = 1. (The metal's
                // compensation is its own lobe.)
                let dielectric = f_d * o.specular_scale;
                dielectric.lerp(f_metal, self.metallic) * (d * m.v(wo, wi))
            }
        };
        (diffuse + specular) * wi.z
    }

    /// The dielectric specular layer's albedo A(μ) = (f0 E + (1 − f0) E_s)(1 + f0 k) seen from
    /// direction cosine `mu`, compensated, Turquin's k = (1 − E(μ)) / E(μ), and E(μ).
    #[inline]
    fn dielectric_albedo(&self, table: &AlbedoTable, mu: f32) -> (f32, f32, f32) {
        let (e, e_s) = table.e_and_e_s(mu, self.row);
        let e = e.max(1e-3);
        let k = (1.0 - e) / e;
        let f0 = self.dielectric_f0;
        let a = (f0 * e + (1.0 - f0) * e_s) * (1.0 + f0 * k);
        (self.specular_weight * a, k, e)
    }

    /// The cosine-weighted average of [`GltfBrdf::dielectric_albedo`] over μ: the table's
    /// averages of E, E_s and E_s (1 − E) / E combined as the expanded product
    /// f0·E + (1 − f0)·E_s + f0²(1 − E) + f0 (1 − f0)·E_s (1 − E) / E requires.
    #[inline]
    fn dielectric_albedo_average(&self, table: &AlbedoTable) -> f32 {
        let [e, e_s, ratio] = table.averages_in(self.row);
        let (f0, g) = (self.dielectric_f0, 1.0 - self.dielectric_f0);
        self.specular_weight * (f0 * e + g * e_s + f0 * f0 * (1.0 - e) + f0 * g * ratio)
    }

    /// The mixture's density of `wi`, the delta lobe left out.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let o = self.terms(wo);
        match &self.anisotropy {
            None => self.pdf_in(&o, &self.ggx(), wo, wi),
            Some(a) => self.pdf_in(&o, &a.ggx(), a.turn(wo), a.turn(wi)),
        }
    }

    /// [`GltfBrdf::pdf`] with distribution `m`, wo and wi in its frame.
    #[inline(always)]
    fn pdf_in<M: Microfacet>(&self, o: &Outgoing, m: &M, wo: Vec3, wi: Vec3) -> f32 {
        let h = (wo + wi).normalize();
        self.pdf_at(o, m, wo, wi, m.d(h))
    }

    /// [`GltfBrdf::pdf`] for wo and wi above the surface (in the frame of distribution `m`),
    /// given wo's terms and D(h): the visible-normal reflection's density
    /// ([`Microfacet::reflection_pdf`]) and the cosine's, mixed by the lobe probability.
    #[inline]
    fn pdf_at<M: Microfacet>(&self, o: &Outgoing, m: &M, wo: Vec3, wi: Vec3, d: f32) -> f32 {
        let p_specular = o.p_specular;
        let specular = match m.is_smooth() {
            true => 0.0,
            false => p_specular * m.reflection_pdf(wo, d),
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
            let wi = match &self.anisotropy {
                None => {
                    let ggx = self.ggx();
                    if ggx.is_smooth() {
                        let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
                        return Some((mirror, BsdfFlags::SPECULAR_REFLECTION));
                    }
                    reflect_visible_normal(&ggx, wo, u)
                }
                Some(a) => a.turn_back(reflect_visible_normal(&a.ggx(), a.turn(wo), u)),
            };
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
        let pdf = self.specular_probability(wo);
        (pdf > 0.0).then_some(BsdfSample {
            wi,
            f_cos: self.specular_fresnel(wo.z),
            pdf,
            flags,
        })
    }
}

/// `wo` reflected about a normal of `m` visible from it, drawn from `u` (Heitz 2018).
#[inline(always)]
fn reflect_visible_normal<M: Microfacet>(m: &M, wo: Vec3, u: Vec2) -> Vec3 {
    let h = m.sample_visible_normal(wo, u);
    2.0 * wo.dot(h) * h - wo
}

/// Schlick's Fresnel approximation F = f0 + (1 − f0)(1 − cos)⁵ ([`fresnel::schlick3`] at
/// one lane).
#[inline]
fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    fresnel::schlick3(f0.into(), cos).into()
}
