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
//! film's interference reflectance over that lobe's f0 ([`thin_film::reflectance`], Belcour & Barla 2017)
//! at the microfacet's angle, as the extension's notes mix them. Without compensation the
//! diffuse lobe below takes 1 − the dielectric's mixed F; with it, the compensation and the
//! diffuse layering keep reading the film-free tables (an approximation: the film moves
//! energy between colours more than it adds or removes).
//!
//! Below [`Ggx::SMOOTH_ALPHA`] the specular lobe is a perfect mirror: a delta lobe of weight
//! F(n·wo) that only sampling finds. Directions come from the specular lobe (the visible
//! normals, Heitz 2018) or the cosine, chosen with probability proportional to their
//! Fresnel-weighted luminance at wo; `pdf` is the mixture's density.

use std::f32::consts::{FRAC_1_PI, PI};

use glam::{Vec2, Vec3};

use super::fresnel::schlick3;
use super::lobe::{BsdfFlags, BsdfSample};
use super::microfacet::{
    anisotropic_d, anisotropic_g1, anisotropic_v, ggx_d, ggx_g1, ggx_v, visible_normal,
    AlbedoRowLanes, AlbedoTable, Ggx, SMOOTH_ALPHA,
};
use super::spectrum::luminance_lanes;
use super::thin_film;
use crate::lanes::{select_lazy, Bits, Mask, Real, Vec2L, Vec3L};
use crate::sampling::warps::cosine_hemisphere;

/// The dielectric's reflectance at normal incidence without `KHR_materials_ior`: IOR 1.5,
/// ((1.5 − 1) / (1.5 + 1))².
pub const DIELECTRIC_F0: f32 = 0.04;

/// The reflectance at normal incidence of a dielectric of index of refraction `ior` in air,
/// ((ior − 1) / (ior + 1))² (KHR_materials_ior, "dielectric_f0").
pub fn dielectric_f0(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    r * r
}

/// The largest float below 1: a remapped sample number stays in [0, 1).
const BELOW_ONE: f32 = 1.0 - f32::EPSILON / 2.0;

/// The glTF metallic-roughness BRDF of one surface point per lane, in the shading frame: the
/// one source of the model, run at one lane by [`GltfBrdf`] and at eight by shading that
/// keeps eight paths together. Every extension is a plain value, neutral where a material
/// lacks it, and the code that reads an extension runs only when some lane has it; a lane
/// without it takes, by a per-lane select, exactly the value the plain model gives, so its
/// bits do not depend on its neighbours.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GltfBrdfLanes<R: Real> {
    /// Linear base colour (factor × texture × vertex colour).
    pub base_color: Vec3L<R>,
    pub metallic: R,
    /// The GGX roughness α = roughness².
    pub alpha: R,
    /// The dielectric part's reflectance at normal incidence ([`dielectric_f0`] of the
    /// material's index of refraction; 0.04 by default), the largest channel of
    /// `specular_f0` under `KHR_materials_specular`.
    pub dielectric_f0: R,
    /// The dielectric specular layer's coloured f0_c and its weight w (KHR_materials_specular;
    /// without it, f0 in every channel and 1).
    pub specular_f0: Vec3L<R>,
    pub specular_weight: R,
    /// Where `KHR_materials_anisotropy` stretches the specular lobes: roughness `alpha_t`
    /// along `direction` (a unit vector of the shading frame's xy plane, (cos φ, sin φ)) and
    /// `alpha_b` across it. Unread elsewhere.
    pub anisotropic: R::Mask,
    pub alpha_t: R,
    pub alpha_b: R,
    pub direction: Vec2L<R>,
    /// `KHR_materials_iridescence`'s share of the specular lobes' Fresnel term (0: no film),
    /// and the film's index, its thickness in nm and the index of the medium above it.
    pub iridescence: R,
    pub film_ior: R,
    pub film_thickness: R,
    pub film_outside: R,
    /// Where the compensation's albedo tables are read: α's rows, or under anisotropy those
    /// of the isotropic α of the same mean square slope.
    pub row: AlbedoRowLanes<R>,
    /// Compensate the energy single scattering loses (see the module documentation): one
    /// choice for every lane, the render's.
    pub energy_compensation: bool,
}

/// The parts of the BRDF that read wo alone, per lane. (For wo below the surface, where the
/// BRDF is zero and draws nothing, they are computed but never read.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutgoingLanes<R: Real> {
    /// The probability of choosing the specular lobe.
    pub p_specular: R,
    /// The dielectric specular lobe's scale: w (1 + f0_c k), k = Turquin's (1 − E(μo)) /
    /// E(μo) (0 without compensation).
    pub specular_scale: Vec3L<R>,
    /// The metal's multiple-scattering lobe's factor of μo, weighted by metallic:
    /// metallic F_ms (1 − E(μo)) / (π (1 − E_avg)) (zero without compensation).
    pub multiple: Vec3L<R>,
    /// The layered diffuse lobe's factor of μo: c_diff / π · (1 − A(μo)) / (1 − A_avg), A the
    /// dielectric layer's compensated albedo (unused without compensation).
    pub diffuse: Vec3L<R>,
}

/// A direction drawn from the BRDF per lane, with the lobe it comes from
/// ([`BsdfFlags::bits`]) and whether the lane drew one at all.
#[derive(Clone, Copy, Debug)]
pub struct DirectionLanes<R: Real> {
    pub wi: Vec3L<R>,
    pub flags: R::Bits,
    pub valid: R::Mask,
}

impl<R: Real> GltfBrdfLanes<R> {
    /// Lane `i` of each parameter from `lane(i)`: eight surface points' BRDFs side by side.
    /// The energy compensation is lane 0's (the render's, the same for all).
    pub fn from_fn(mut lane: impl FnMut(usize) -> GltfBrdfLanes<f32>) -> Self {
        let one: [GltfBrdfLanes<f32>; 8] = std::array::from_fn(|i| match i < R::LANES {
            true => lane(i),
            false => lane(0),
        });
        let real = |f: &dyn Fn(&GltfBrdfLanes<f32>) -> f32| R::from_fn(|i| f(&one[i]));
        let vec3 =
            |f: &dyn Fn(&GltfBrdfLanes<f32>) -> Vec3L<f32>| Vec3L::from_fn(|i| f(&one[i]).into());
        debug_assert!(one
            .iter()
            .all(|b| b.energy_compensation == one[0].energy_compensation));
        GltfBrdfLanes {
            base_color: vec3(&|b| b.base_color),
            metallic: real(&|b| b.metallic),
            alpha: real(&|b| b.alpha),
            dielectric_f0: real(&|b| b.dielectric_f0),
            specular_f0: vec3(&|b| b.specular_f0),
            specular_weight: real(&|b| b.specular_weight),
            anisotropic: R::Mask::from_fn(|i| one[i].anisotropic),
            alpha_t: real(&|b| b.alpha_t),
            alpha_b: real(&|b| b.alpha_b),
            direction: Vec2L::from_fn(|i| one[i].direction.into()),
            iridescence: real(&|b| b.iridescence),
            film_ior: real(&|b| b.film_ior),
            film_thickness: real(&|b| b.film_thickness),
            film_outside: real(&|b| b.film_outside),
            row: AlbedoRowLanes::from_fn(|i| one[i].row),
            energy_compensation: one[0].energy_compensation,
        }
    }

    /// True per lane where the specular lobe is a perfect mirror (never once stretched:
    /// [`GltfBrdf::with_anisotropy`] keeps mirrors isotropic).
    #[inline(always)]
    pub fn smooth(&self) -> R::Mask {
        !self.anisotropic & self.alpha.lt(R::splat(SMOOTH_ALPHA))
    }

    /// c_diff, the diffuse lobe's colour.
    #[inline(always)]
    fn diffuse_color(&self) -> Vec3L<R> {
        self.base_color * (R::ONE - self.metallic)
    }

    /// `w` in the frame whose x axis is the stretch's direction, where a lane is anisotropic:
    /// turned about z by the direction's angle backwards.
    #[inline(always)]
    fn turn(&self, w: Vec3L<R>) -> Vec3L<R> {
        self.rotate(w, -self.direction.y)
    }

    /// The inverse of [`GltfBrdfLanes::turn`].
    #[inline(always)]
    fn turn_back(&self, w: Vec3L<R>) -> Vec3L<R> {
        self.rotate(w, self.direction.y)
    }

    /// `w` rotated about z by the angle of (direction.x, `sin`) on anisotropic lanes, left as
    /// it is on the others (and on every lane where none is anisotropic).
    #[inline(always)]
    fn rotate(&self, w: Vec3L<R>, sin: R) -> Vec3L<R> {
        if self.anisotropic.none() {
            return w;
        }
        let cos = self.direction.x;
        let turned = Vec3L::new(cos * w.x - sin * w.y, sin * w.x + cos * w.y, w.z);
        Vec3L::select(self.anisotropic, turned, w)
    }

    /// The distribution's roughnesses along the turned frame's axes: (α_t, α_b) where
    /// anisotropic, (α, α) elsewhere.
    #[inline(always)]
    fn roughnesses(&self) -> (R, R) {
        match self.anisotropic.none() {
            true => (self.alpha, self.alpha),
            false => (
                R::select(self.anisotropic, self.alpha_t, self.alpha),
                R::select(self.anisotropic, self.alpha_b, self.alpha),
            ),
        }
    }

    /// D(h), `h` in the turned frame.
    #[inline(always)]
    fn d(&self, h: Vec3L<R>) -> R {
        select_lazy!(
            !self.anisotropic,
            ggx_d(self.alpha, h),
            anisotropic_d(self.alpha_t, self.alpha_b, h),
            R::select
        )
    }

    /// The visibility term V(wo, wi), directions in the turned frame.
    #[inline(always)]
    fn v(&self, wo: Vec3L<R>, wi: Vec3L<R>) -> R {
        select_lazy!(
            !self.anisotropic,
            ggx_v(self.alpha, wo, wi),
            anisotropic_v(self.alpha_t, self.alpha_b, wo, wi),
            R::select
        )
    }

    /// Smith's G1(w), `w` in the turned frame.
    #[inline(always)]
    fn g1(&self, w: Vec3L<R>) -> R {
        select_lazy!(
            !self.anisotropic,
            ggx_g1(self.alpha, w),
            anisotropic_g1(self.alpha_t, self.alpha_b, w),
            R::select
        )
    }

    /// The film's reflectance over a base of normal-incidence reflectance `f0` at cosine
    /// `cos`, per lane ([`thin_film::reflectance`]).
    #[inline(always)]
    fn film(&self, f0: Vec3L<R>, cos: R) -> Vec3L<R> {
        thin_film::reflectance(
            self.film_ior,
            self.film_thickness,
            self.film_outside,
            f0,
            cos,
        )
    }

    /// The dielectric's and the metal's Fresnel terms at cosine `cos` between the view and
    /// the microfacet normal: Schlick's of f0_c and of the base colour, each mixed with the
    /// film's reflectance over it under iridescence.
    #[inline(always)]
    fn fresnel_pair(&self, cos: R) -> (Vec3L<R>, Vec3L<R>) {
        let f_d = schlick3(self.specular_f0, cos);
        let f_metal = schlick3(self.base_color, cos);
        let iridescent = self.iridescence.gt(R::ZERO);
        if iridescent.none() {
            return (f_d, f_metal);
        }
        let film_d = f_d.lerp(self.film(self.specular_f0, cos), self.iridescence);
        let f_d = Vec3L::select(iridescent, film_d, f_d);
        let metal = iridescent & self.metallic.gt(R::ZERO);
        let f_metal = match metal.none() {
            true => f_metal,
            false => {
                let film_metal = f_metal.lerp(self.film(self.base_color, cos), self.iridescence);
                Vec3L::select(metal, film_metal, f_metal)
            }
        };
        (f_d, f_metal)
    }

    /// The specular lobes' Fresnel weight at cosine `cos`: the dielectric's w F_c and the
    /// metal's Schlick F of its base colour, mixed by metallic. (Schlick's F is affine in f0:
    /// without KHR_materials_specular or a film this is F of the mixed f0, which costs one
    /// Schlick term instead of two.)
    #[inline(always)]
    pub fn specular_fresnel(&self, cos: R) -> Vec3L<R> {
        let plain = self.specular_weight.eq(R::ONE) & !self.iridescence.gt(R::ZERO);
        select_lazy!(
            plain,
            {
                let f0 = self.specular_f0.lerp(self.base_color, self.metallic);
                schlick3(f0, cos)
            },
            {
                let (f_d, f_metal) = self.fresnel_pair(cos);
                (f_d * self.specular_weight).lerp(f_metal, self.metallic)
            },
            Vec3L::select
        )
    }

    /// The dielectric's diffuse weight 1 − w max(F_c) at cosine `cos` (1 − F_d without
    /// KHR_materials_specular).
    #[inline(always)]
    fn diffuse_weight(&self, cos: R) -> Vec3L<R> {
        let f_c = schlick3(self.specular_f0, cos);
        Vec3L::all(R::ONE - self.specular_weight * f_c.max_element())
    }

    /// A rough estimate of the light the BRDF returns toward `wo`: the Fresnel-weighted
    /// luminances of its lobes that its own choice of lobe weighs, for a layer above it that
    /// chooses between itself and this BRDF ([`super::layers::Layered`]).
    #[inline(always)]
    pub fn sampling_albedo(&self, wo: Vec3L<R>) -> R {
        luminance_lanes(self.specular_fresnel(wo.z))
            + luminance_lanes(self.diffuse_weight(wo.z) * self.diffuse_color())
    }

    /// The terms of outgoing direction `wo` (see [`OutgoingLanes`]).
    #[inline(always)]
    pub fn outgoing(&self, wo: Vec3L<R>) -> OutgoingLanes<R> {
        let c_diff = self.diffuse_color();
        let specular = luminance_lanes(self.specular_fresnel(wo.z));
        let diffuse = luminance_lanes(self.diffuse_weight(wo.z) * c_diff);
        let zero = Vec3L::all(R::ZERO);
        if !self.energy_compensation {
            return OutgoingLanes {
                p_specular: share(specular, diffuse),
                specular_scale: Vec3L::all(self.specular_weight),
                multiple: zero,
                diffuse: zero,
            };
        }
        let table = AlbedoTable::get();
        let (a_o, k, e_o) = self.dielectric_albedo(table, wo.z);
        let averages = table.averages_in_lanes(self.row);
        let multiple = self.multiple_scattering(averages[0], e_o);
        // The multiple-scattering lobe is drawn with the cosine: its energy joins the
        // diffuse lobe's in the choice of lobe.
        let spread = diffuse + luminance_lanes(multiple) * PI * (R::ONE - averages[0]);
        let rest = (R::ONE - self.dielectric_albedo_average(averages)).max(R::splat(1e-4));
        let layered = c_diff * (R::splat(FRAC_1_PI) * (R::ONE - a_o).max(R::ZERO) / rest);
        let black = c_diff.x.eq(R::ZERO) & c_diff.y.eq(R::ZERO) & c_diff.z.eq(R::ZERO);
        OutgoingLanes {
            p_specular: share(specular, spread),
            specular_scale: (Vec3L::all(R::ONE) + self.specular_f0 * k) * self.specular_weight,
            multiple,
            diffuse: Vec3L::select(black, zero, layered),
        }
    }

    /// The metal's multiple-scattering lobe's factor of μo (Kulla & Conty 2017):
    /// metallic F_ms (1 − E(μo)) / (π (1 − E_avg)), per channel of f0 = base colour, with
    /// F_avg = f0 + (1 − f0)/21 and F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)); zero for a
    /// mirror (its delta lobe loses nothing) or a dielectric.
    #[inline(always)]
    fn multiple_scattering(&self, e_avg: R, e_o: R) -> Vec3L<R> {
        let one = Vec3L::all(R::ONE);
        let f_avg = self.base_color + (one - self.base_color) * R::splat(1.0 / 21.0);
        let f_ms = f_avg * f_avg * e_avg / (one - f_avg * (R::ONE - e_avg));
        let lobe = f_ms
            * (self.metallic * (R::ONE - e_o).max(R::ZERO) * FRAC_1_PI
                / (R::ONE - e_avg).max(R::splat(1e-4)));
        let none = self.metallic.le(R::ZERO) | self.smooth();
        Vec3L::select(none, Vec3L::all(R::ZERO), lobe)
    }

    /// The dielectric specular layer's albedo A(μ) = (f0 E + (1 − f0) E_s)(1 + f0 k) seen from
    /// direction cosine `mu`, compensated, Turquin's k = (1 − E(μ)) / E(μ), and E(μ).
    #[inline(always)]
    fn dielectric_albedo(&self, table: &AlbedoTable, mu: R) -> (R, R, R) {
        let (e, e_s) = table.e_and_e_s_lanes(mu, self.row);
        let e = e.max(R::splat(1e-3));
        let k = (R::ONE - e) / e;
        let f0 = self.dielectric_f0;
        let a = (f0 * e + (R::ONE - f0) * e_s) * (R::ONE + f0 * k);
        (self.specular_weight * a, k, e)
    }

    /// The cosine-weighted average of [`GltfBrdfLanes::dielectric_albedo`] over μ from the
    /// table's `averages` of E, E_s and E_s (1 − E) / E, combined as the expanded product
    /// f0·E + (1 − f0)·E_s + f0²(1 − E) + f0 (1 − f0)·E_s (1 − E) / E requires.
    #[inline(always)]
    fn dielectric_albedo_average(&self, [e, e_s, ratio]: [R; 3]) -> R {
        let (f0, g) = (self.dielectric_f0, R::ONE - self.dielectric_f0);
        self.specular_weight * (f0 * e + g * e_s + f0 * f0 * (R::ONE - e) + f0 * g * ratio)
    }

    /// f(wo, wi)·cos θi and the mixture's density of `wi`, the delta lobe left out, given
    /// wo's terms `o`: the half vector and D computed once for both. Zero where wo or wi is
    /// below the surface.
    #[inline(always)]
    pub fn eval_pdf(&self, o: &OutgoingLanes<R>, wo: Vec3L<R>, wi: Vec3L<R>) -> (Vec3L<R>, R) {
        let above = wo.z.gt(R::ZERO) & wi.z.gt(R::ZERO);
        let (f, pdf) = select_lazy!(
            above,
            {
                let (wo, wi) = (self.turn(wo), self.turn(wi));
                let h = (wo + wi).normalize();
                let d = self.d(h);
                (self.eval_at(o, wo, wi, h, d), self.pdf_at(o, wo, wi, d))
            },
            (Vec3L::all(R::ZERO), R::ZERO),
            select_pair
        );
        (f, pdf)
    }

    /// f(wo, wi)·cos θi alone (the same values as [`GltfBrdfLanes::eval_pdf`]'s).
    #[inline(always)]
    pub fn eval(&self, o: &OutgoingLanes<R>, wo: Vec3L<R>, wi: Vec3L<R>) -> Vec3L<R> {
        let above = wo.z.gt(R::ZERO) & wi.z.gt(R::ZERO);
        select_lazy!(
            above,
            {
                let (wo, wi) = (self.turn(wo), self.turn(wi));
                let h = (wo + wi).normalize();
                self.eval_at(o, wo, wi, h, self.d(h))
            },
            Vec3L::all(R::ZERO),
            Vec3L::select
        )
    }

    /// The density alone (the same values as [`GltfBrdfLanes::eval_pdf`]'s).
    #[inline(always)]
    pub fn pdf(&self, o: &OutgoingLanes<R>, wo: Vec3L<R>, wi: Vec3L<R>) -> R {
        let above = wo.z.gt(R::ZERO) & wi.z.gt(R::ZERO);
        select_lazy!(
            above,
            {
                let (wo, wi) = (self.turn(wo), self.turn(wi));
                let h = (wo + wi).normalize();
                self.pdf_at(o, wo, wi, self.d(h))
            },
            R::ZERO,
            R::select
        )
    }

    /// f·cos for wo and wi above the surface (in the turned frame), given wo's terms, the
    /// half vector and D(h).
    #[inline(always)]
    fn eval_at(
        &self,
        o: &OutgoingLanes<R>,
        wo: Vec3L<R>,
        wi: Vec3L<R>,
        h: Vec3L<R>,
        d: R,
    ) -> Vec3L<R> {
        let wo_h = wo.dot(h).abs();
        let (f_d, f_metal) = self.fresnel_pair(wo_h);
        let diffuse = match self.energy_compensation {
            false => {
                let weight = R::ONE - self.specular_weight * f_d.max_element();
                Vec3L::all(weight) * self.diffuse_color() * R::splat(FRAC_1_PI)
            }
            true => {
                let (a_i, _, e_i) = self.dielectric_albedo(AlbedoTable::get(), wi.z);
                o.diffuse * (R::ONE - a_i).max(R::ZERO) + o.multiple * (R::ONE - e_i).max(R::ZERO)
            }
        };
        // The dielectric's Fresnel weight w F_c scaled by Turquin's 1 + f0 (1 − E(μo)) /
        // E(μo) (k = 0 without compensation; `specular_scale`) and the metal's, mixed by
        // metallic. (The metal's compensation is its own lobe.) A mirror's is a delta lobe.
        let dielectric = f_d * o.specular_scale;
        let specular = dielectric.lerp(f_metal, self.metallic) * (d * self.v(wo, wi));
        let specular = Vec3L::select(self.smooth(), Vec3L::all(R::ZERO), specular);
        (diffuse + specular) * wi.z
    }

    /// The mixture's density for wo and wi above the surface (in the turned frame), given
    /// wo's terms and D(h): the visible-normal reflection's density, G1(wo) D(h) / (4 n·wo)
    /// (Heitz 2018, eq. 3, times the reflection's Jacobian), and the cosine's, mixed by the
    /// lobe probability.
    #[inline(always)]
    fn pdf_at(&self, o: &OutgoingLanes<R>, wo: Vec3L<R>, wi: Vec3L<R>, d: R) -> R {
        let p = o.p_specular;
        let reflection = self.g1(wo) * d / (wo.z * 4.0);
        let specular = R::select(self.smooth(), R::ZERO, p * reflection);
        specular + (R::ONE - p) * wi.z * FRAC_1_PI
    }

    /// A direction and the lobe it comes from, given wo's terms: the lobe chosen with `u.x`,
    /// whose stretch that chose it is reused for the direction (the visible normals, Heitz
    /// 2018, or the cosine). Not valid where wo is below the surface or a glossy reflection
    /// falls below it.
    #[inline(always)]
    pub fn sample_direction(
        &self,
        o: &OutgoingLanes<R>,
        wo: Vec3L<R>,
        u: Vec2L<R>,
    ) -> DirectionLanes<R> {
        let p = o.p_specular;
        let drawn = select_lazy!(
            u.x.lt(p),
            {
                let u = Vec2L::new((u.x / p).min(R::splat(BELOW_ONE)), u.y);
                self.sample_specular(wo, u)
            },
            {
                let v = ((u.x - p) / (R::ONE - p)).min(R::splat(BELOW_ONE));
                DirectionLanes {
                    wi: cosine_hemisphere(Vec2L::new(v, u.y)),
                    flags: R::Bits::splat(BsdfFlags::DIFFUSE_REFLECTION.bits()),
                    valid: R::Mask::splat(true),
                }
            },
            DirectionLanes::select
        );
        DirectionLanes {
            valid: drawn.valid & wo.z.gt(R::ZERO),
            ..drawn
        }
    }

    /// The specular lobe's direction from `u`: the mirror of a smooth lane, else `wo`
    /// reflected about a visible normal (in the turned frame, then turned back).
    #[inline(always)]
    fn sample_specular(&self, wo: Vec3L<R>, u: Vec2L<R>) -> DirectionLanes<R> {
        select_lazy!(
            self.smooth(),
            DirectionLanes {
                wi: Vec3L::new(-wo.x, -wo.y, wo.z),
                flags: R::Bits::splat(BsdfFlags::SPECULAR_REFLECTION.bits()),
                valid: R::Mask::splat(true),
            },
            {
                let (ax, ay) = self.roughnesses();
                let wo = self.turn(wo);
                let h = visible_normal(ax, ay, wo, u);
                let wi = self.turn_back(h * (wo.dot(h) * 2.0) - wo);
                DirectionLanes {
                    wi,
                    flags: R::Bits::splat(BsdfFlags::GLOSSY_REFLECTION.bits()),
                    valid: wi.z.gt(R::ZERO),
                }
            },
            DirectionLanes::select
        )
    }

    /// The lobes each lane has ([`BsdfFlags::bits`]).
    #[inline(always)]
    pub fn flags(&self) -> R::Bits {
        let specular = R::Bits::select(
            self.smooth(),
            R::Bits::splat(BsdfFlags::SPECULAR_REFLECTION.bits()),
            R::Bits::splat(BsdfFlags::GLOSSY_REFLECTION.bits()),
        );
        let diffuse = self.metallic.lt(R::ONE) & self.base_color.max_element().gt(R::ZERO);
        let diffuse = R::Bits::select(
            diffuse,
            R::Bits::splat(BsdfFlags::DIFFUSE.bits()),
            R::Bits::splat(0),
        );
        specular | diffuse
    }
}

/// `a` where `m` is true, `b` elsewhere, for a colour and a density.
#[inline(always)]
fn select_pair<R: Real>(m: R::Mask, a: (Vec3L<R>, R), b: (Vec3L<R>, R)) -> (Vec3L<R>, R) {
    (Vec3L::select(m, a.0, b.0), R::select(m, a.1, b.1))
}

/// The specular lobe's share `specular` / (`specular` + `rest`) of the Fresnel-weighted
/// luminance, 1 where the rest is black.
#[inline(always)]
fn share<R: Real>(specular: R, rest: R) -> R {
    R::select(rest.le(R::ZERO), R::ONE, specular / (specular + rest))
}

impl<R: Real> DirectionLanes<R> {
    /// `a` where `m` is true, `b` elsewhere.
    #[inline(always)]
    pub fn select(m: R::Mask, a: Self, b: Self) -> Self {
        DirectionLanes {
            wi: Vec3L::select(m, a.wi, b.wi),
            flags: R::Bits::select(m, a.flags, b.flags),
            valid: (m & a.valid) | (!m & b.valid),
        }
    }
}

/// The glTF metallic-roughness BRDF of one surface point, in the shading frame:
/// [`GltfBrdfLanes`] at one lane, with the glam-typed face [`super::lobe::LocalBsdf`] asks
/// for and the terms of the one wo a path evaluates it at kept.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GltfBrdf {
    lanes: GltfBrdfLanes<f32>,
    /// The terms that depend on the outgoing direction alone, for the one they were computed
    /// at ([`GltfBrdf::at`]): a path evaluates the BRDF at one wo many times.
    outgoing: Option<(Vec3, OutgoingLanes<f32>)>,
}

impl GltfBrdf {
    /// The BRDF for a material's `roughness` (perceptual, as the file gives it).
    /// With energy compensation, the default.
    pub fn new(base_color: Vec3, metallic: f32, roughness: f32) -> GltfBrdf {
        let alpha = roughness * roughness;
        GltfBrdf {
            lanes: GltfBrdfLanes {
                base_color: base_color.into(),
                metallic,
                alpha,
                dielectric_f0: DIELECTRIC_F0,
                specular_f0: Vec3L::all(DIELECTRIC_F0),
                specular_weight: 1.0,
                anisotropic: false,
                alpha_t: alpha,
                alpha_b: alpha,
                direction: Vec2L::new(1.0, 0.0),
                iridescence: 0.0,
                film_ior: 1.0,
                film_thickness: 0.0,
                film_outside: 1.0,
                row: AlbedoRowLanes::new(alpha),
                energy_compensation: true,
            },
            outgoing: None,
        }
    }

    /// The parameters, as lanes of one.
    #[inline(always)]
    pub fn lanes(&self) -> &GltfBrdfLanes<f32> {
        &self.lanes
    }

    /// The linear base colour.
    #[inline(always)]
    pub fn base_color(&self) -> Vec3 {
        self.lanes.base_color.into()
    }

    /// The BRDF with these parameters and no terms of wo computed.
    #[inline(always)]
    fn with(lanes: GltfBrdfLanes<f32>) -> GltfBrdf {
        GltfBrdf {
            lanes,
            outgoing: None,
        }
    }

    /// The same BRDF with the dielectric part's index of refraction `ior`
    /// (`KHR_materials_ior`).
    pub fn with_ior(self, ior: f32) -> GltfBrdf {
        let f0 = dielectric_f0(ior);
        GltfBrdf::with(GltfBrdfLanes {
            dielectric_f0: f0,
            specular_f0: Vec3L::all(f0),
            ..self.lanes
        })
    }

    /// The same BRDF with `KHR_materials_specular`'s weight `specular` (specularFactor × the
    /// texture's A) and `color` (specularColorFactor × the texture's RGB) on the dielectric's
    /// specular layer, over the index of refraction already set.
    pub fn with_specular(self, specular: f32, color: Vec3) -> GltfBrdf {
        let f0 = (Vec3::from(self.lanes.specular_f0) * color.max(Vec3::ZERO)).min(Vec3::ONE);
        GltfBrdf::with(GltfBrdfLanes {
            dielectric_f0: f0.max_element(),
            specular_f0: f0.into(),
            specular_weight: specular.clamp(0.0, 1.0),
            ..self.lanes
        })
    }

    /// The same BRDF with its specular lobes stretched as `KHR_materials_anisotropy` says:
    /// roughness α_t = mix(α, 1, `strength`²) along `direction` (a vector of the shading
    /// frame's tangent plane, its z ignored) and α across it. Unchanged where the strength is
    /// 0, the direction has no length in the plane, or both roughnesses stay a mirror's; a
    /// mirror across a rough direction is given the least rough GGX ([`Ggx::SMOOTH_ALPHA`]).
    pub fn with_anisotropy(self, strength: f32, direction: Vec3) -> GltfBrdf {
        let alpha = self.lanes.alpha;
        let s = strength.clamp(0.0, 1.0);
        let alpha_t = alpha + (1.0 - alpha) * s * s;
        let direction = Vec2::new(direction.x, direction.y).normalize_or_zero();
        if s == 0.0 || alpha_t < Ggx::SMOOTH_ALPHA || direction == Vec2::ZERO {
            return self;
        }
        let alpha_b = alpha.max(Ggx::SMOOTH_ALPHA);
        GltfBrdf::with(GltfBrdfLanes {
            anisotropic: true,
            alpha_t,
            alpha_b,
            direction: direction.into(),
            // The isotropic α of the same mean square slope (see the module documentation).
            row: AlbedoRowLanes::new(((alpha_t * alpha_t + alpha_b * alpha_b) / 2.0).sqrt()),
            ..self.lanes
        })
    }

    /// The same BRDF under `KHR_materials_iridescence`'s thin film: each specular lobe's
    /// Fresnel term F becomes mix(F, F_film, `factor`), F_film the film's reflectance over
    /// that lobe's f0 ([`thin_film::reflectance`]; index `ior`, `thickness` nm) seen from a
    /// medium of index `outside` at the microfacet's angle. Unchanged where the factor is 0.
    /// Energy compensation keeps reading the film-free lobes' tables: an approximation.
    pub fn with_iridescence(self, factor: f32, ior: f32, thickness: f32, outside: f32) -> GltfBrdf {
        let factor = factor.clamp(0.0, 1.0);
        if factor == 0.0 {
            return self;
        }
        GltfBrdf::with(GltfBrdfLanes {
            iridescence: factor,
            film_ior: ior,
            film_thickness: thickness.max(0.0),
            film_outside: outside,
            ..self.lanes
        })
    }

    /// The same BRDF without energy compensation: the specification's model exactly.
    pub fn single_scattering(self) -> GltfBrdf {
        GltfBrdf::with(GltfBrdfLanes {
            energy_compensation: false,
            ..self.lanes
        })
    }

    /// The same BRDF with the terms of outgoing direction `wo` computed ahead: evaluations at
    /// that `wo` then skip them (any other `wo` still gets its own).
    #[inline]
    pub fn at(self, wo: Vec3) -> GltfBrdf {
        GltfBrdf {
            outgoing: Some((wo, self.lanes.outgoing(wo.into()))),
            ..self
        }
    }

    #[inline]
    fn terms(&self, wo: Vec3) -> OutgoingLanes<f32> {
        match self.outgoing {
            Some((at, o)) if at == wo => o,
            _ => self.lanes.outgoing(wo.into()),
        }
    }

    /// A rough estimate of the light the BRDF returns toward `wo`
    /// ([`GltfBrdfLanes::sampling_albedo`]).
    pub fn sampling_albedo(&self, wo: Vec3) -> f32 {
        self.lanes.sampling_albedo(wo.into())
    }

    pub fn flags(&self) -> BsdfFlags {
        BsdfFlags::from_bits(self.lanes.flags())
    }

    /// f(wo, wi)·cos θi, the delta lobe left out.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        self.lanes
            .eval(&self.terms(wo), wo.into(), wi.into())
            .into()
    }

    /// [`GltfBrdf::eval`] and [`GltfBrdf::pdf`] together, the half vector and D computed
    /// once: what MIS asks of a light sample's direction, and BSDF sampling of its own.
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let (f, pdf) = self.lanes.eval_pdf(&self.terms(wo), wo.into(), wi.into());
        (f.into(), pdf)
    }

    /// The mixture's density of `wi`, the delta lobe left out.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        self.lanes.pdf(&self.terms(wo), wo.into(), wi.into())
    }

    /// A direction and the lobe it comes from: the lobe chosen with `u.x`, whose stretch
    /// that chose it is reused for the direction.
    pub fn sample_direction(&self, wo: Vec3, u: Vec2) -> Option<(Vec3, BsdfFlags)> {
        if wo.z <= 0.0 {
            return None;
        }
        let d = self
            .lanes
            .sample_direction(&self.terms(wo), wo.into(), u.into());
        d.valid
            .then(|| (d.wi.into(), BsdfFlags::from_bits(d.flags)))
    }

    /// The mirror's sample in direction `wi`: weight F(n·wo) (a mirror's half vector is the
    /// normal) and the probability of having chosen the lobe.
    pub fn sample_delta(&self, wo: Vec3, wi: Vec3, flags: BsdfFlags) -> Option<BsdfSample> {
        let pdf = self.terms(wo).p_specular;
        (pdf > 0.0).then(|| BsdfSample {
            wi,
            f_cos: self.lanes.specular_fresnel(wo.z).into(),
            pdf,
            flags,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lanes::assert_same_bits_at_every_width;

    /// Random materials and directions, lane by lane unlike one another: metals, dielectrics
    /// and blends, mirrors and rough surfaces, and the extensions on some lanes only
    /// (KHR_materials_ior, _specular, _anisotropy, _iridescence), with wo and wi on both sides
    /// of the surface. 25 numbers: base colour (3), metallic, roughness, ior, specular weight,
    /// specular colour (3), anisotropy strength and direction (3), iridescence factor, film
    /// index and thickness, wo (3), wi (3), u (2), and whether to compensate (for eight
    /// lanes in a row).
    fn inputs() -> Vec<[f32; 25]> {
        let mut next = crate::sampling::hash::uniform_sequence(4511);
        let direction = |a: f32, b: f32| {
            let z = a * 2.0 - 1.0;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let (s, c) = (b * std::f32::consts::TAU).sin_cos();
            [r * c, r * s, z]
        };
        (0..2000)
            .map(|k| {
                let mut x = [0.0f32; 25];
                for v in x.iter_mut() {
                    *v = next();
                }
                // Metallic 0 or 1 on some lanes; mirrors and the roughest on others.
                x[3] = [x[3], 0.0, 1.0, x[3]][k % 4];
                x[4] = [x[4], 0.0, 0.02, 1.0, x[4]][k % 5];
                // Each extension on a share of the lanes, off (its neutral value) elsewhere.
                x[5] = if k % 3 == 0 { 1.0 + x[5] } else { 1.5 };
                if k % 7 != 2 {
                    x[6] = 1.0;
                    x[7..10].copy_from_slice(&[1.0; 3]);
                }
                x[7] *= 2.0;
                if k % 5 != 3 {
                    x[10] = 0.0;
                }
                x[11] -= 0.5;
                x[12] -= 0.5;
                if k % 11 != 4 && k % 8 != 1 {
                    x[13] = 0.0;
                }
                x[14] += 1.2;
                x[15] *= 600.0;
                let wo = direction(x[16], x[17]);
                let wi = direction(x[18], x[19]);
                x[16..19].copy_from_slice(&wo);
                x[19..22].copy_from_slice(&wi);
                // Energy compensation for eight lanes in a row, then not.
                x[24] = ((k / 8) % 2) as f32;
                // The first view straight down the normal.
                if k == 0 {
                    x[16..19].copy_from_slice(&[0.0, 0.0, 1.0]);
                }
                x
            })
            .collect()
    }

    /// Lane `i`'s BRDF from the inputs, by the one-lane builders.
    fn material<R: Real>(x: &[R; 25], i: usize, compensated: bool) -> GltfBrdfLanes<f32> {
        let v = |k: usize| x[k].lane(i);
        let mut b = GltfBrdf::new(Vec3::new(v(0), v(1), v(2)), v(3), v(4))
            .with_ior(v(5))
            .with_specular(v(6), Vec3::new(v(7), v(8), v(9)))
            .with_anisotropy(v(10), Vec3::new(v(11), v(12), 0.0))
            .with_iridescence(v(13), v(14), v(15), 1.0);
        if !compensated {
            b = b.single_scattering();
        }
        *b.lanes()
    }

    /// Every value the BRDF gives for lane inputs `x`: the terms of wo, f·cos and pdf
    /// together and apart, the drawn direction with its lobe and validity, the mirror's
    /// weight, the sampling albedo and the lobes.
    #[inline(always)]
    fn values<R: Real>(x: [R; 25], compensated: bool) -> [R; 24] {
        let brdf = GltfBrdfLanes::<R>::from_fn(|i| material(&x, i, compensated));
        let wo = Vec3L::new(x[16], x[17], x[18]);
        let wi = Vec3L::new(x[19], x[20], x[21]);
        let o = brdf.outgoing(wo);
        let (f, pdf) = brdf.eval_pdf(&o, wo, wi);
        let f_alone = brdf.eval(&o, wo, wi);
        let pdf_alone = brdf.pdf(&o, wo, wi);
        let d = brdf.sample_direction(&o, wo, Vec2L::new(x[22], x[23]));
        let valid = R::select(d.valid, R::ONE, R::ZERO);
        // The drawn direction's value where it is valid (what a path goes on with).
        let (f_d, pdf_d) = brdf.eval_pdf(&o, wo, d.wi);
        let mirror = brdf.specular_fresnel(wo.z);
        [
            o.p_specular,
            o.specular_scale.x,
            o.multiple.y,
            o.diffuse.z,
            f.x,
            f.y,
            f.z,
            pdf,
            f_alone.x,
            f_alone.z,
            pdf_alone,
            R::select(d.valid, d.wi.x, R::ZERO),
            R::select(d.valid, d.wi.y, R::ZERO),
            R::select(d.valid, d.wi.z, R::ZERO),
            R::from_bits(R::Bits::select(d.valid, d.flags, R::Bits::splat(0))),
            valid,
            R::select(d.valid, f_d.x, R::ZERO),
            R::select(d.valid, pdf_d, R::ZERO),
            mirror.x,
            mirror.y,
            mirror.z,
            brdf.sampling_albedo(wo),
            R::from_bits(brdf.flags()),
            R::select(brdf.smooth(), R::ONE, R::ZERO),
        ]
    }

    /// [`values`] with energy compensation where input 24 (the same for eight lanes in a
    /// row) is below ½: one kernel for both models, which halves what the test compiles.
    #[inline(always)]
    fn kernel<R: Real>(x: [R; 25]) -> [R; 24] {
        values(x, x[24].lane(0) < 0.5)
    }

    /// The BRDF gives the same bits at one lane and eight, in and out of the AVX2 dispatch,
    /// with lanes of different materials and extensions side by side.
    #[test]
    fn the_brdf_has_the_same_bits_at_every_width() {
        assert_same_bits_at_every_width!(kernel: [25] -> [24], inputs(), dispatched only);
    }

    /// The inputs reach every branch: some lanes anisotropic, iridescent, mirror-smooth,
    /// below the surface; draws of every lobe; so that the width test compares lanes that
    /// take different sides of each select next to one another.
    #[test]
    fn the_width_test_inputs_reach_every_branch() {
        let (mut aniso, mut film, mut smooth, mut below) = (0, 0, 0, 0);
        let mut lobes = std::collections::BTreeSet::new();
        for x in inputs() {
            let b = material(&x, 0, true);
            aniso += b.anisotropic as usize;
            film += (b.iridescence > 0.0) as usize;
            smooth += b.smooth() as usize;
            below += (x[18] <= 0.0) as usize;
            let o = b.outgoing(Vec3L::new(x[16], x[17], x[18]));
            let d = b.sample_direction(
                &o,
                Vec3L::new(x[16], x[17], x[18]),
                Vec2L::new(x[22], x[23]),
            );
            if d.valid {
                lobes.insert(d.flags);
            }
        }
        println!("anisotropic {aniso}, iridescent {film}, smooth {smooth}, below {below}, lobes {lobes:?}");
        assert!(aniso > 100 && film > 100 && smooth > 100 && below > 500);
        assert_eq!(
            lobes.len(),
            3,
            "diffuse, glossy and specular reflection drawn"
        );
    }
}
