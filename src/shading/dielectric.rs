//! Dielectric interfaces: glass, water, clear plastic (glTF's `KHR_materials_transmission`,
//! with `KHR_materials_volume` for [`Dielectric`], without it for [`ThinDielectric`]).
//!
//! [`Dielectric`] is the boundary between the outside, the side the shading normal +z points
//! to, and a medium of relative index of refraction η = n_inside / n_outside below it, rough
//! (GGX) or, for α < [`Ggx::SMOOTH_ALPHA`], smooth. `wo` may be on either side: wo.z < 0 means
//! the path is inside the medium. With η_o and η_i the indices of the media `wo` and `wi` lie
//! in (the Walter et al. 2007 notation, "Microfacet Models for Refraction through Rough
//! Surfaces"):
//!
//! - Fresnel: the exact unpolarized reflectance of a dielectric, [`fresnel_dielectric`]
//!   (Walter eq. 22 in its cosine form), 1 past the critical angle (total internal
//!   reflection).
//! - The generalized half vector h = ±normalize(η_o wo + η_i wi), turned to +z (Walter eq. 16;
//!   for reflection, η_o = η_i and it is the ordinary half vector). Microfacets that either
//!   direction sees from behind scatter nothing.
//! - Reflection (Walter eq. 20): f_r = F(wo·h) D(h) G2(wo, wi) / (4 |n·wo| |n·wi|).
//! - Transmission (Walter eq. 21):
//!   f_t = (1 − F(wo·h)) tint |wo·h| |wi·h| η_o² D(h) G2(wo, wi) / (|n·wo| |n·wi| (η_o wo·h + η_i wi·h)²).
//! - D is GGX's ([`Ggx::d`]), G2 the height-correlated Smith masking-shadowing
//!   1 / (1 + Λ(wo) + Λ(wi)) (Heitz 2014, eq. 99, the form pbrt-v4 uses for both lobes, so that
//!   G2 / (4 |n·wo| |n·wi|) is [`Ggx::v`]).
//!
//! **Radiance convention.** strata's path tracer starts at the camera and carries radiance
//! toward it: `wo` points to the camera, `wi` to the light, and f must turn the radiance
//! arriving along wi into the radiance leaving along wo. Radiance crossing an interface is
//! scaled by (η_o / η_i)², the squeeze or spread of the solid angle of a beam that bends
//! (Veach 1997, §5.2): f_t above carries η_o² / (η_o wo·h + η_i wi·h)², which is pbrt-v4's
//! `TransportMode::Radiance` (its BTDF divided by η'² = (η_i / η_o)²). A camera ray entering
//! glass (wo outside, wi inside) so takes 1/η² of the radiance inside; one leaving it, η².
//! The BSDF is then not symmetric but obeys the generalized reciprocity
//! f(wo, wi) / η_o² = f(wi, wo) / η_i² (Veach eq. 5.14): every factor of f_t but η_o² is
//! symmetric in the two directions (the Fresnel reflectance of a pair of refracted directions
//! is the same from both sides). A light tracer (importance) would need f without the η_o² /
//! η_i² factor; none exists in strata today.
//!
//! **Sampling.** A microfacet normal h visible from wo (Heitz 2018, [`Ggx::sample_visible_normal`],
//! with wo turned to +z when it is inside), then reflection about h with probability
//! F(wo·h) and refraction through it otherwise (total internal reflection: always
//! reflection). The pdf of wi is the visible normals' D_wo(h) = G1(wo) |wo·h| D(h) / |n·wo|
//! (Heitz 2018, eq. 3) times the lobe's probability and the Jacobian of h → wi:
//! 1 / (4 |wo·h|) for reflection (Walter eq. 14), η_i² |wi·h| / (η_o wo·h + η_i wi·h)² for
//! refraction (Walter eq. 17). The estimator f·|cos θi| / pdf is then G2 / G1(wo) for
//! reflection and tint (η_o/η_i)² G2 / G1(wo) for transmission.
//!
//! The choice between the two lobes needs a third random number after h is drawn: the lobe
//! number `uc` of [`LocalBsdf::sample`] (pbrt-v4's `uc`), which the path tracer draws from a
//! sampler dimension of its own ([`LocalBsdf::reads_lobe_number`]). The smooth interface
//! chooses with it too.
//!
//! **Smooth.** A delta lobe: reflection (−wo.x, −wo.y, wo.z) with probability F(n·wo) and
//! weight F, refraction (Snell's law, [`refract`]) with probability 1 − F and weight
//! (1 − F) tint (η_o/η_i)², so that f_cos / pdf is 1 or tint (η_o/η_i)². η = 1 is treated as
//! an invisible interface (smooth at any α: F = 0 and light passes straight through; the rough
//! lobe would collapse to a delta that no half vector could find).
//!
//! [`ThinDielectric`] is the thin-walled surface of `KHR_materials_transmission` alone: see its
//! documentation.
//!
//! **Energy compensation.** Single scattering among the microfacets loses energy (a rough
//! glass sphere in a white furnace keeps 88% at roughness 0.5). With compensation (the
//! renderer's default, as for the glTF BRDF) both lobes are scaled by 1 / E(μo), E the power
//! the white interface returns from wo's side ([`DielectricAlbedoTable`], Turquin 2019's
//! scaling); the thin sheet's by the white GGX albedo's reciprocal. Shapes, and so sampling,
//! are unchanged.

use glam::{Vec2, Vec3};

use super::fresnel;
use super::gltf_brdf::DirectionLanes;
use super::lobe::{BsdfFlags, BsdfSample, LocalBsdf};
use super::microfacet::{ggx_d, ggx_g1, ggx_v, visible_normal, AlbedoRowLanes, AlbedoTable, Ggx};
use crate::lanes::{select_lazy, Bits, Mask, Real, Vec2L, Vec3L};

/// The lobes of a rough interface.
const GLOSSY: BsdfFlags = BsdfFlags::REFLECTION
    .union(BsdfFlags::TRANSMISSION)
    .union(BsdfFlags::GLOSSY);
/// The lobes of a smooth interface.
const SPECULAR: BsdfFlags = BsdfFlags::REFLECTION
    .union(BsdfFlags::TRANSMISSION)
    .union(BsdfFlags::SPECULAR);
const GLOSSY_TRANSMISSION: BsdfFlags = BsdfFlags::TRANSMISSION.union(BsdfFlags::GLOSSY);
const SPECULAR_TRANSMISSION: BsdfFlags = BsdfFlags::TRANSMISSION.union(BsdfFlags::SPECULAR);

/// The exact Fresnel reflectance of unpolarized light at a smooth dielectric interface for
/// light arriving with direction cosine `cos_i` (negative from below) and relative index `eta`
/// = n(below) / n(above): [`fresnel::dielectric`] at one lane. Total internal reflection
/// gives 1.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    fresnel::dielectric(cos_i, eta)
}

/// The direction `w` (pointing away from the interface) refracts into, through an interface
/// of unit normal `n` and relative index `eta` = n(below) / n(above), `n` pointing above;
/// `w` may be on either side. None on total internal reflection.
///
/// With η' and the normal n' taken on w's side (η and n, or 1/η and −n), Snell's law in
/// vector form: wt = −w / η' + (cos θi / η' − cos θt) n', cos θt = √(1 − (1 − cos²θi) / η'²).
#[inline]
pub fn refract(w: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let (t, refracts) = refract_lanes(w.into(), n.into(), eta);
    refracts.then(|| t.into())
}

/// [`refract`] at any width: the refracted direction, and the lanes where there is one
/// (false on total internal reflection, where the direction is not meaningful).
#[inline(always)]
pub fn refract_lanes<R: Real>(w: Vec3L<R>, n: Vec3L<R>, eta: R) -> (Vec3L<R>, R::Mask) {
    let cos_i = w.dot(n).clamp(-R::ONE, R::ONE);
    // From below: the normal and the ratio taken on w's side.
    let below = cos_i.lt(R::ZERO);
    let n = Vec3L::select(below, -n, n);
    let eta = R::select(below, eta.recip(), eta);
    let cos_i = R::select(below, -cos_i, cos_i);
    let sin2_t = (R::ONE - cos_i * cos_i) / (eta * eta);
    let cos_t = (R::ONE - sin2_t).safe_sqrt();
    let t = Vec3L::new(-w.x / eta, -w.y / eta, -w.z / eta) + n * (cos_i / eta - cos_t);
    (t, !sin2_t.ge(R::ONE))
}

/// A rough or smooth dielectric interface between the outside (+z) and a medium of relative
/// index `eta` below it (see the module documentation for its formulas, sampling and
/// radiance convention).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// n_inside / n_outside (glTF: `KHR_materials_ior`'s `ior`, the outside being air).
    pub eta: f32,
    /// The GGX roughness α (glTF: roughness²); below [`Ggx::SMOOTH_ALPHA`], smooth.
    pub alpha: f32,
    /// What transmitted light is multiplied by (glTF: the base colour).
    pub tint: Vec3,
    /// Compensate the energy single scattering among the microfacets loses
    /// ([`Dielectric::with_energy_compensation`]).
    pub compensated: bool,
    /// The compensation's factor 1 / E(μo) for the wo of [`LocalBsdf::at`] (1 before, or
    /// without compensation).
    scale: f32,
    /// `KHR_materials_dispersion`'s 20 / Abbe number (0: none): `eta` is then the index at
    /// 587.6 nm, until [`Dielectric::at_wavelength`] gives the one of a path's wavelength.
    pub dispersion: f32,
}

impl Dielectric {
    /// The interface of relative index `eta` (n_inside / n_outside), GGX roughness `alpha`
    /// (roughness², not the perceptual roughness) and transmission tint `tint`; single
    /// scattering.
    pub fn new(eta: f32, alpha: f32, tint: Vec3) -> Dielectric {
        Dielectric {
            eta,
            alpha,
            tint,
            compensated: false,
            scale: 1.0,
            dispersion: 0.0,
        }
    }

    /// The same interface with `KHR_materials_dispersion`'s `dispersion` (20 / Abbe number).
    pub fn with_dispersion(self, dispersion: f32) -> Dielectric {
        Dielectric {
            dispersion: dispersion.max(0.0),
            ..self
        }
    }

    /// The interface at wavelength `lambda` nm: the index n(λ) by Cauchy's law from the one
    /// at 587.6 nm ([`super::spectrum::dispersed_ior`]), on the side `eta` was given for (η
    /// below 1: leaving the medium). Itself without dispersion. Its terms of wo are to be
    /// made again ([`LocalBsdf::at`]).
    pub fn at_wavelength(self, lambda: f32) -> Dielectric {
        if self.dispersion <= 0.0 {
            return self;
        }
        let leaving = self.eta < 1.0;
        let n_d = if leaving { 1.0 / self.eta } else { self.eta };
        let n = super::spectrum::dispersed_ior(n_d, self.dispersion, lambda);
        Dielectric {
            eta: if leaving { 1.0 / n } else { n },
            dispersion: 0.0,
            scale: 1.0,
            ..self
        }
    }

    /// The same interface with the energy single scattering loses given back: reflection
    /// and transmission both scaled by 1 / E(μo), E the power the white interface returns
    /// from wo's side, R + η'² T ([`DielectricAlbedoTable`]; Turquin 2019's scaling, which
    /// keeps the lobes' shapes, so sampling is unchanged). A rough glass sphere then stays
    /// white in a white furnace. Not reciprocal (it reads μo alone), as Turquin notes.
    pub fn with_energy_compensation(self) -> Dielectric {
        Dielectric {
            compensated: true,
            scale: 1.0,
            ..self
        }
    }

    /// True when the interface is a delta lobe: smooth, or index-matched (η = 1).
    #[inline]
    pub fn is_specular(&self) -> bool {
        self.alpha < Ggx::SMOOTH_ALPHA || self.eta == 1.0
    }

    /// The interface as lanes of one (its dispersion already resolved by
    /// [`Dielectric::at_wavelength`]).
    #[inline(always)]
    pub fn lanes(&self) -> DielectricLanes<f32> {
        DielectricLanes {
            eta: self.eta,
            alpha: self.alpha,
            tint: self.tint.into(),
            compensated: self.compensated,
        }
    }
}

/// A rough or smooth dielectric interface per lane (see [`Dielectric`]): the one source of
/// its lobes, run at one lane by [`Dielectric`] and at eight by shading that keeps eight
/// paths together. Its compensation's scale of wo comes from [`DielectricLanes::scale`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DielectricLanes<R: Real> {
    /// n_inside / n_outside.
    pub eta: R,
    pub alpha: R,
    pub tint: Vec3L<R>,
    /// Compensate the energy single scattering loses: one choice for every lane.
    pub compensated: bool,
}

/// A direction drawn from an interface per lane, with its f·|cos θi|, pdf and lobe: `drawn`
/// where the numbers map to a direction, `valid` where it is also one to go on with (a
/// positive, finite pdf and a finite value).
#[derive(Clone, Copy, Debug)]
pub struct InterfaceSample<R: Real> {
    pub wi: Vec3L<R>,
    pub f_cos: Vec3L<R>,
    pub pdf: R,
    pub flags: R::Bits,
    pub drawn: R::Mask,
    pub valid: R::Mask,
}

impl<R: Real> DielectricLanes<R> {
    /// True per lane where the interface is a delta lobe: smooth, or index-matched (η = 1).
    #[inline(always)]
    pub fn specular(&self) -> R::Mask {
        self.alpha.lt(R::splat(Ggx::SMOOTH_ALPHA)) | self.eta.eq(R::ONE)
    }

    /// Which way up a query is: directions are turned (negated) so that wo lies above the
    /// surface, where the interface then has relative index η (η outside, 1/η inside).
    /// Negation keeps D, G and Fresnel (the isotropic microsurface seen from below is the same
    /// distribution of normals, pointing down), and swaps the media. Returns 1 where wo is
    /// outside, −1 inside; the relative index once turned; and the lanes where wo sees the
    /// interface (not in its plane, and finite).
    #[inline(always)]
    fn upright(&self, wo: Vec3L<R>) -> (R, R, R::Mask) {
        let above = wo.z.gt(R::ZERO);
        let sign = R::select(above, R::ONE, -R::ONE);
        let eta = R::select(above, self.eta, self.eta.recip());
        (sign, eta, above | wo.z.lt(R::ZERO))
    }

    /// The compensation's scale seen from `wo`: 1 / E(|μo|), E the power the white rough
    /// interface returns from wo's side ([`DielectricAlbedoTable`]); 1 without compensation,
    /// for a delta lobe or a wo in the plane.
    #[inline(always)]
    pub fn scale(&self, wo: Vec3L<R>) -> R {
        if !self.compensated {
            return R::ONE;
        }
        let (_, eta, seen) = self.upright(wo);
        let e = DielectricAlbedoTable::get().e_lanes(wo.z.abs(), self.alpha, eta);
        let rough = seen & !self.specular();
        R::select(rough, e.max(R::splat(1e-3)).recip(), R::ONE)
    }

    /// f·|cos θi| and the pdf of upright `wo` (wo.z > 0) and `wi` through microfacet normal
    /// `h` (h.z > 0, facing wo), `eta` the upright relative index: Walter's reflection where
    /// wi is above (eq. 20, the Jacobian 1 / (4 wo·h), eq. 14), his transmission below.
    #[inline(always)]
    fn lobe(&self, wo: Vec3L<R>, wi: Vec3L<R>, h: Vec3L<R>, eta: R) -> (Vec3L<R>, R) {
        let alpha = self.alpha;
        let (wo_h, wi_h) = (wo.dot(h), wi.dot(h));
        let d = ggx_d(alpha, h);
        let f = fresnel::dielectric(wo_h, eta);
        // The density of h among the normals visible from wo (Heitz 2018, eq. 3).
        let pdf_h = ggx_g1(alpha, wo) * wo_h * d / wo.z;
        let v = ggx_v(alpha, wo, wi);
        select_lazy!(
            wi.z.gt(R::ZERO),
            {
                let value = f * d * v * wi.z;
                (Vec3L::all(value), f * pdf_h / (wo_h * 4.0))
            },
            {
                // Walter eq. 21 divided through by η_o² (wo's medium is "above", index 1
                // here): η_o wo·h + η_i wi·h → wo·h + η wi·h; G2 / (|n·wo| |n·wi|) = 4 V.
                let t = R::ONE - f;
                let denominator = (wo_h + eta * wi_h) * (wo_h + eta * wi_h);
                let g2_over_cosines = v * 4.0;
                let value = t * d * g2_over_cosines * wo_h * wi_h.abs() * wi.z.abs() / denominator;
                // The Jacobian η_i² |wi·h| / (η_o wo·h + η_i wi·h)² (eq. 17).
                let pdf = t * pdf_h * eta * eta * wi_h.abs() / denominator;
                (self.tint * value, pdf)
            },
            |m, a: (Vec3L<R>, R), b: (Vec3L<R>, R)| (
                Vec3L::select(m, a.0, b.0),
                R::select(m, a.1, b.1)
            )
        )
    }

    /// f·|cos θi| and pdf, given the compensation's `scale` of wo: zero for a delta lobe, a
    /// wo in the plane, a wi in it or not finite, microfacets either direction sees from
    /// behind, or values f32 cannot hold.
    #[inline(always)]
    pub fn eval_pdf(&self, scale: R, wo: Vec3L<R>, wi: Vec3L<R>) -> (Vec3L<R>, R) {
        let (sign, eta, seen) = self.upright(wo);
        let (wo, wi) = (wo * sign, wi * sign);
        let inf = R::splat(f32::INFINITY);
        let finite = |x: R| x.abs().lt(inf);
        // The generalized half vector (Walter eq. 16), turned to +z.
        let eta_i = R::select(wi.z.gt(R::ZERO), R::ONE, eta);
        let h = wo + wi * eta_i;
        let length2 = h.length_squared();
        let h = h * (R::ONE.copysign(h.z) / length2.sqrt());
        let (value, pdf) = self.lobe(wo, wi, h, eta);
        let ok = seen
            & !self.specular()
            & wi.z.ne(R::ZERO)
            & finite(wi.x)
            & finite(wi.y)
            & finite(wi.z)
            & length2.gt(R::ZERO)
            & finite(length2)
            // Microfacets either direction sees from behind scatter nothing.
            & wo.dot(h).gt(R::ZERO)
            & (wi.dot(h) * wi.z).gt(R::ZERO)
            & finite(value.x)
            & finite(value.y)
            & finite(value.z)
            & finite(pdf);
        (
            Vec3L::select(ok, value * scale, Vec3L::all(R::ZERO)),
            R::select(ok, pdf, R::ZERO),
        )
    }

    /// A direction drawn with normal sample `u` and lobe choice `uc`, with its f·|cos θi|
    /// (scaled by `scale`) and pdf computed from the drawn microfacet normal (the value and
    /// pdf [`DielectricLanes::eval_pdf`] gives the direction up to rounding); for a delta
    /// lobe the mirror with probability F(n·wo), else the refraction, weighted as
    /// [`DielectricLanes::sample_delta`] weights them.
    #[inline(always)]
    pub fn sample(&self, scale: R, wo: Vec3L<R>, uc: R, u: Vec2L<R>) -> InterfaceSample<R> {
        let (sign, eta, seen) = self.upright(wo);
        let wo_up = wo * sign;
        let flag = |f: BsdfFlags| R::Bits::splat(f.bits());
        let inf = R::splat(f32::INFINITY);
        let finite = |x: R| x.abs().lt(inf);
        let drawn = select_lazy!(
            self.specular(),
            {
                let reflect = uc.lt(fresnel::dielectric(wo_up.z, eta));
                let z = Vec3L::new(R::ZERO, R::ZERO, R::ONE);
                let (t, refracts) = refract_lanes(wo_up, z, eta);
                let wi = Vec3L::select(reflect, Vec3L::new(-wo_up.x, -wo_up.y, wo_up.z), t);
                let flags = R::Bits::select(
                    reflect,
                    flag(BsdfFlags::SPECULAR_REFLECTION),
                    flag(SPECULAR_TRANSMISSION),
                );
                let drawn = reflect | (refracts & t.z.lt(R::ZERO));
                let (f_cos, pdf, valid) = self.sample_delta(wo, flags);
                InterfaceSample {
                    wi: wi * sign,
                    f_cos,
                    pdf,
                    flags,
                    drawn,
                    valid: valid & drawn,
                }
            },
            {
                let h = visible_normal(self.alpha, self.alpha, wo_up, u);
                let wo_h = wo_up.dot(h);
                let reflect = uc.lt(fresnel::dielectric(wo_h, eta));
                let mirror = h * (wo_h * 2.0) - wo_up;
                let (t, refracts) = refract_lanes(wo_up, h, eta);
                let wi = Vec3L::select(reflect, mirror, t);
                let drawn = wo_h.gt(R::ZERO)
                    & ((reflect & mirror.z.gt(R::ZERO)) | (!reflect & refracts & t.z.lt(R::ZERO)));
                let (f_cos, pdf) = self.lobe(wo_up, wi, h, eta);
                let f_cos = f_cos * scale;
                let flags = R::Bits::select(
                    wi.z.gt(R::ZERO),
                    flag(BsdfFlags::GLOSSY_REFLECTION),
                    flag(GLOSSY_TRANSMISSION),
                );
                let valid = drawn
                    & pdf.gt(R::ZERO)
                    & finite(pdf)
                    & finite(f_cos.x)
                    & finite(f_cos.y)
                    & finite(f_cos.z);
                InterfaceSample {
                    wi: wi * sign,
                    f_cos,
                    pdf,
                    flags,
                    drawn,
                    valid,
                }
            },
            InterfaceSample::select
        );
        InterfaceSample {
            drawn: drawn.drawn & seen,
            valid: drawn.valid & seen,
            ..drawn
        }
    }

    /// The smooth interface's weight and probability for lobe `flags` ([`BsdfFlags::bits`]):
    /// F(n·wo) for the mirror, (1 − F) tint (η_o/η_i)² and 1 − F for the refraction; valid
    /// where the probability is positive and wo sees the interface.
    #[inline(always)]
    pub fn sample_delta(&self, wo: Vec3L<R>, flags: R::Bits) -> (Vec3L<R>, R, R::Mask) {
        let (sign, eta, seen) = self.upright(wo);
        let f = fresnel::dielectric(wo.z * sign, eta);
        let transmission = R::Bits::splat(BsdfFlags::TRANSMISSION.bits());
        let through = (flags & transmission).eq(transmission);
        let kept = R::ONE - f;
        // Radiance: (η_o / η_i)² = 1 / η² with η upright (wi's medium below).
        let f_cos = Vec3L::select(through, self.tint * (kept / (eta * eta)), Vec3L::all(f));
        let pdf = R::select(through, kept, f);
        (f_cos, pdf, pdf.gt(R::ZERO) & seen)
    }

    /// The lobes each lane has ([`BsdfFlags::bits`]).
    #[inline(always)]
    pub fn flags(&self) -> R::Bits {
        R::Bits::select(
            self.specular(),
            R::Bits::splat(SPECULAR.bits()),
            R::Bits::splat(GLOSSY.bits()),
        )
    }
}

impl<R: Real> InterfaceSample<R> {
    /// `a` where `m` is true, `b` elsewhere.
    #[inline(always)]
    fn select(m: R::Mask, a: Self, b: Self) -> Self {
        InterfaceSample {
            wi: Vec3L::select(m, a.wi, b.wi),
            f_cos: Vec3L::select(m, a.f_cos, b.f_cos),
            pdf: R::select(m, a.pdf, b.pdf),
            flags: R::Bits::select(m, a.flags, b.flags),
            drawn: (m & a.drawn) | (!m & b.drawn),
            valid: (m & a.valid) | (!m & b.valid),
        }
    }
}

impl LocalBsdf for Dielectric {
    #[inline(always)]
    fn depends_on_cos_theta_only(&self) -> bool {
        false
    }

    #[inline]
    fn at(self, wo: Vec3) -> Dielectric {
        if !self.compensated || self.is_specular() || wo.z == 0.0 || wo.z.is_nan() {
            return self;
        }
        Dielectric {
            scale: self.lanes().scale(wo.into()),
            ..self
        }
    }

    #[inline]
    fn flags(&self) -> BsdfFlags {
        BsdfFlags::from_bits(self.lanes().flags())
    }

    #[inline]
    fn albedo(&self) -> Vec3 {
        self.tint
    }

    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.eval_pdf(wo, wi).0
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_pdf(wo, wi).1
    }

    #[inline]
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let (f, pdf) = self.lanes().eval_pdf(self.scale, wo.into(), wi.into());
        (f.into(), pdf)
    }

    #[inline(always)]
    fn reads_lobe_number(&self) -> bool {
        true
    }

    #[inline]
    fn sample_direction(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<(Vec3, BsdfFlags)> {
        let s = self.lanes().sample(self.scale, wo.into(), uc, u.into());
        s.drawn
            .then(|| (s.wi.into(), BsdfFlags::from_bits(s.flags)))
    }

    /// The smooth interface's sample in direction `wi` ([`DielectricLanes::sample_delta`]).
    #[inline]
    fn sample_delta(&self, wo: Vec3, wi: Vec3, flags: BsdfFlags) -> Option<BsdfSample> {
        let (f_cos, pdf, valid) = self.lanes().sample_delta(wo.into(), flags.bits());
        valid.then(|| BsdfSample {
            wi,
            f_cos: f_cos.into(),
            pdf,
            flags,
        })
    }

    /// A direction drawn with normal sample `u` and lobe choice `uc`, its f·|cos θi| and pdf
    /// computed from the drawn microfacet normal ([`DielectricLanes::sample`]).
    #[inline]
    fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let s = self.lanes().sample(self.scale, wo.into(), uc, u.into());
        s.valid.then(|| BsdfSample {
            wi: s.wi.into(),
            f_cos: s.f_cos.into(),
            pdf: s.pdf,
            flags: BsdfFlags::from_bits(s.flags),
        })
    }
}

/// The power a white rough interface returns from one side, E(μ, α, η) = R + η² T (η the
/// relative index seen from that side, undoing the radiance convention's 1/η²): 1 for a smooth
/// one, less for a rough one by what single scattering among its microfacets loses.
/// Tabulated once per process (the first scene with compensated rough glass) on a grid of μ
/// (32), √α (16) and n = max(η, 1/η) from 1 to 3 (17), for light arriving from the lower
/// index (η ≥ 1) and from the higher, each entry the mean over 16 × 16 stratified
/// visible-normal samples (the lobe number a Kronecker sequence) of the sample's power weight;
/// looked up by interpolation in all three.
pub struct DielectricAlbedoTable {
    /// [side][n][√α][μ].
    e: Vec<f32>,
}

impl DielectricAlbedoTable {
    const N_MU: usize = 32;
    const N_R: usize = 16;
    const N_ETA: usize = 17;
    const N_MAX: f32 = 3.0;
    const SAMPLES: usize = 16;

    /// The table, made on first use.
    pub fn get() -> &'static DielectricAlbedoTable {
        static TABLE: std::sync::OnceLock<DielectricAlbedoTable> = std::sync::OnceLock::new();
        TABLE.get_or_init(DielectricAlbedoTable::compute)
    }

    fn compute() -> DielectricAlbedoTable {
        use rayon::prelude::*;
        let (n_mu, n_r, n_eta) = (Self::N_MU, Self::N_R, Self::N_ETA);
        let blocks: Vec<Vec<f32>> = (0..2 * n_eta)
            .into_par_iter()
            .map(|b| {
                let (side, k) = (b / n_eta, b % n_eta);
                let n = 1.0 + (Self::N_MAX - 1.0) * k as f32 / (n_eta - 1) as f32;
                let eta = if side == 0 { n } else { 1.0 / n };
                let mut out = Vec::with_capacity(n_r * n_mu);
                for j in 0..n_r {
                    let r = j as f32 / (n_r - 1) as f32;
                    for i in 0..n_mu {
                        let mu = (i as f32 / (n_mu - 1) as f32).max(1e-3);
                        out.push(Self::power_albedo(eta, r * r, mu));
                    }
                }
                out
            })
            .collect();
        DielectricAlbedoTable { e: blocks.concat() }
    }

    /// R + η² T of the white single-scattering interface (η, α) seen from direction cosine
    /// `mu` above it, by stratified sampling.
    pub fn power_albedo(eta: f32, alpha: f32, mu: f32) -> f32 {
        let glass = Dielectric::new(eta, alpha, Vec3::ONE);
        if glass.is_specular() {
            return 1.0;
        }
        let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
        let k = Self::SAMPLES;
        let mut sum = 0.0f64;
        for a in 0..k {
            for b in 0..k {
                let u = Vec2::new((a as f32 + 0.5) / k as f32, (b as f32 + 0.5) / k as f32);
                // The lobe number from the golden-ratio sequence, apart from u's strata.
                let uc = ((a * k + b) as f32 * 0.618_034).fract();
                if let Some(s) = glass.sample(wo, uc, u) {
                    let w = s.f_cos.x / s.pdf;
                    sum += match s.wi.z < 0.0 {
                        true => (w * eta * eta) as f64,
                        false => w as f64,
                    };
                }
            }
        }
        (sum / (k * k) as f64) as f32
    }

    /// E at direction cosine `mu`, GGX α `alpha` and relative index `eta` seen from wo's side.
    pub fn e(&self, mu: f32, alpha: f32, eta: f32) -> f32 {
        self.e_lanes(mu, alpha, eta)
    }

    /// [`DielectricAlbedoTable::e`] at any width: trilinear in μ, √α and the index, the
    /// eight corners gathered per lane.
    #[inline(always)]
    pub fn e_lanes<R: Real>(&self, mu: R, alpha: R, eta: R) -> R {
        let (n_mu, n_r, n_eta) = (Self::N_MU as u32, Self::N_R as u32, Self::N_ETA as u32);
        let inside = eta.lt(R::ONE);
        let n = R::select(inside, eta.recip(), eta);
        let (i, fi) = grid(mu, n_mu);
        let (j, fj) = grid(alpha.max(R::ZERO).sqrt(), n_r);
        let (k, fk) = grid((n - 1.0) / (Self::N_MAX - 1.0), n_eta);
        let side = R::Bits::select(inside, R::Bits::splat(1), R::Bits::splat(0));
        let one = R::Bits::splat(1);
        // Entry ((side n_eta + k) n_r + j) n_mu + i, and the next along μ.
        let block = side.wrapping_mul(R::Bits::splat(n_eta)).wrapping_add(k);
        let (near, far) = (
            block.wrapping_mul(R::Bits::splat(n_r)).wrapping_add(j),
            block
                .wrapping_add(one)
                .wrapping_mul(R::Bits::splat(n_r))
                .wrapping_add(j),
        );
        let mus = R::Bits::splat(n_mu);
        let row = |r: R::Bits| r.wrapping_mul(mus).wrapping_add(i);
        let (a, b) = (row(near), row(near.wrapping_add(one)));
        let (c, d) = (row(far), row(far.wrapping_add(one)));
        let plane_near = along_mu(&self.e, a, fi) * (R::ONE - fj) + along_mu(&self.e, b, fi) * fj;
        let plane_far = along_mu(&self.e, c, fi) * (R::ONE - fj) + along_mu(&self.e, d, fi) * fj;
        plane_near * (R::ONE - fk) + plane_far * fk
    }
}

/// Table `e` between entry `start` and the next, by weight `f` of the next.
#[inline(always)]
fn along_mu<R: Real>(e: &[f32], start: R::Bits, f: R) -> R {
    let (a, b) = (
        R::gather_slice(e, start),
        R::gather_slice(e, start.wrapping_add(R::Bits::splat(1))),
    );
    a * (R::ONE - f) + b * f
}

/// Where `x` ∈ [0, 1] (clamped) falls on a grid of `cells` points: the point below (at most
/// the last but one) and the weight of the one above.
#[inline(always)]
fn grid<R: Real>(x: R, cells: u32) -> (R::Bits, R) {
    let x = x.clamp(R::ZERO, R::ONE) * (cells - 1) as f32;
    let lo = x.min(R::splat((cells - 2) as f32)).trunc_i32();
    (lo, x - R::from_i32(lo))
}

/// The thin-walled transmissive surface of `KHR_materials_transmission` without
/// `KHR_materials_volume`: two back-to-back interfaces of an infinitely thin sheet, so light
/// leaves on the far side with no average refraction.
///
/// The extension's "Transmission BTDF" section adds `specular_btdf(α) · baseColor` under the
/// Fresnel mix whose layer is the specular BRDF, and its implementation notes make the BTDF
/// the specular lobe evaluated with the transmission half vector
/// H_T = normalize(V − 2 (N·L) N + L): the reflection lobe mirrored through the surface plane
/// (wi.z → −wi.z). strata follows that:
///
/// - reflection f_r = F(wo·h) D(h) V(wo, wi), h = normalize(wo + wi);
/// - transmission f_t = (1 − F(wo·h)) tint D(h) V(wo, wi'), wi' = (wi.x, wi.y, −wi.z),
///   h = normalize(wo + wi'), so that f_r + f_t over both sides is the white GGX lobe;
/// - F the exact dielectric Fresnel of relative index `eta` seen from the outside whichever
///   side wo is on (the sheet is symmetric), where the core specification's `fresnel_mix`
///   uses Schlick's approximation of the same reflectance;
/// - V the height-correlated visibility of [`Ggx::v`] for both lobes (the extension's
///   non-normative notes write the BTDF with the separable G1·G1; the height-correlated form
///   keeps the mirrored lobe exactly the reflection lobe, as its normative text says);
/// - no η² factor: light returns to the medium it came from;
/// - smooth (α < [`Ggx::SMOOTH_ALPHA`]): the mirror with weight F(n·wo), and straight
///   through (wi = −wo) with weight (1 − F) tint.
///
/// The extension's remark that the sheet's two uncorrelated microsurfaces blur more as the
/// IOR grows is not modelled: the transmitted lobe has the roughness α of the reflected one,
/// as the BTDF formula has it.
///
/// Sampling draws a visible normal, reflects about it, and keeps the reflection with
/// probability F(wo·h) or mirrors it through the plane otherwise; the estimator is G2 / G1(wo)
/// or tint G2 / G1(wo).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectric {
    /// The sheet's index of refraction relative to the surrounding medium (glTF: `ior`).
    pub eta: f32,
    /// The GGX roughness α (glTF: roughness²); below [`Ggx::SMOOTH_ALPHA`], smooth.
    pub alpha: f32,
    /// What transmitted light is multiplied by (glTF: the base colour).
    pub tint: Vec3,
    /// Compensate the energy single scattering loses
    /// ([`ThinDielectric::with_energy_compensation`]).
    pub compensated: bool,
    /// 1 / E(μo) for the wo of [`LocalBsdf::at`] (1 before, or without compensation).
    scale: f32,
}

impl ThinDielectric {
    /// The sheet of relative index `eta`, GGX roughness `alpha` (roughness²) and
    /// transmission tint `tint`; single scattering.
    pub fn new(eta: f32, alpha: f32, tint: Vec3) -> ThinDielectric {
        ThinDielectric {
            eta,
            alpha,
            tint,
            compensated: false,
            scale: 1.0,
        }
    }

    /// The same sheet with reflection and transmission scaled by 1 / E(μo), E the white GGX
    /// lobe's single-scattering albedo ([`AlbedoTable`]), which is what the white sheet
    /// returns (R + T = E, F + (1 − F) = 1 at every microfacet): it then returns all of it.
    pub fn with_energy_compensation(self) -> ThinDielectric {
        ThinDielectric {
            compensated: true,
            scale: 1.0,
            ..self
        }
    }

    /// True when the sheet is smooth: a delta lobe.
    #[inline]
    pub fn is_specular(&self) -> bool {
        self.alpha < Ggx::SMOOTH_ALPHA
    }

    /// The sheet as lanes of one.
    #[inline(always)]
    pub fn lanes(&self) -> ThinDielectricLanes<f32> {
        ThinDielectricLanes {
            eta: self.eta,
            alpha: self.alpha,
            tint: self.tint.into(),
            compensated: self.compensated,
        }
    }
}

/// A thin dielectric sheet per lane (see [`ThinDielectric`]): the one source of its lobes,
/// run at one lane by [`ThinDielectric`] and at eight by shading that keeps eight paths
/// together. Its compensation's scale of wo is computed by [`ThinDielectricLanes::scale`]
/// and passed in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectricLanes<R: Real> {
    pub eta: R,
    pub alpha: R,
    pub tint: Vec3L<R>,
    /// Compensate the energy single scattering loses: one choice for every lane.
    pub compensated: bool,
}

impl<R: Real> ThinDielectricLanes<R> {
    /// True per lane where the sheet is smooth: a delta lobe.
    #[inline(always)]
    pub fn smooth(&self) -> R::Mask {
        self.alpha.lt(R::splat(Ggx::SMOOTH_ALPHA))
    }

    /// The compensation's scale seen from `wo`: 1 / E(|μo|), E the white GGX lobe's albedo;
    /// 1 without compensation, for a smooth sheet or a wo in the plane.
    #[inline(always)]
    pub fn scale(&self, wo: Vec3L<R>) -> R {
        if !self.compensated {
            return R::ONE;
        }
        let row = AlbedoRowLanes::new(self.alpha);
        let e = AlbedoTable::get().e_and_e_s_lanes(wo.z.abs(), row).0;
        let rough = !self.smooth() & wo.z.ne(R::ZERO);
        R::select(rough, e.max(R::splat(1e-3)).recip(), R::ONE)
    }

    /// 1 where wo is above the surface, −1 below (negation turns a query upright, see
    /// [`DielectricLanes`]), and the lanes where wo sees the sheet at all (not in its plane).
    #[inline(always)]
    fn upright(wo: Vec3L<R>) -> (R, R::Mask) {
        let above = wo.z.gt(R::ZERO);
        let sign = R::select(above, R::ONE, -R::ONE);
        (sign, above | wo.z.lt(R::ZERO))
    }

    /// f·|cos θi| and pdf, given the compensation's `scale` of wo: zero for a smooth sheet,
    /// a wo in the plane, a wi in it or not finite, or values f32 cannot hold.
    #[inline(always)]
    pub fn eval_pdf(&self, scale: R, wo: Vec3L<R>, wi: Vec3L<R>) -> (Vec3L<R>, R) {
        let (sign, seen) = Self::upright(wo);
        let (wo, wi) = (wo * sign, wi * sign);
        let inf = R::splat(f32::INFINITY);
        let finite = |x: R| x.abs().lt(inf);
        // The reflection lobe's direction: wi itself, or wi mirrored through the plane.
        let transmitted = wi.z.lt(R::ZERO);
        let wr = Vec3L::new(wi.x, wi.y, wi.z.abs());
        let h = (wo + wr).normalize();
        let wo_h = wo.dot(h);
        let d = ggx_d(self.alpha, h);
        let f = fresnel::dielectric(wo_h, self.eta);
        let lobe = d * ggx_v(self.alpha, wo, wr) * wr.z;
        let pdf = ggx_g1(self.alpha, wo) * d / (wo.z * 4.0);
        let kept = R::ONE - f;
        let value = Vec3L::select(transmitted, self.tint * (kept * lobe), Vec3L::all(f * lobe));
        let pdf = R::select(transmitted, kept * pdf, f * pdf);
        let ok = seen
            & !self.smooth()
            & wi.z.ne(R::ZERO)
            & finite(wi.x)
            & finite(wi.y)
            & finite(wi.z)
            & wo_h.gt(R::ZERO)
            & finite(value.x)
            & finite(value.y)
            & finite(value.z)
            & finite(pdf);
        (
            Vec3L::select(ok, value * scale, Vec3L::all(R::ZERO)),
            R::select(ok, pdf, R::ZERO),
        )
    }

    /// A direction and its lobe: the reflection about a visible normal drawn with `u` (the
    /// mirror of a smooth sheet), kept with probability F(wo·h) (`uc` below it) or mirrored
    /// through the plane. Not valid for a wo in the plane or a reflection below it.
    #[inline(always)]
    pub fn sample_direction(&self, wo: Vec3L<R>, uc: R, u: Vec2L<R>) -> DirectionLanes<R> {
        let (sign, seen) = Self::upright(wo);
        let wo = wo * sign;
        let flag = |f: BsdfFlags| R::Bits::splat(f.bits());
        let drawn = select_lazy!(
            self.smooth(),
            {
                let reflect = uc.lt(fresnel::dielectric(wo.z, self.eta));
                DirectionLanes {
                    wi: Vec3L::select(
                        reflect,
                        Vec3L::new(-wo.x, -wo.y, wo.z),
                        Vec3L::new(-wo.x, -wo.y, -wo.z),
                    ),
                    flags: R::Bits::select(
                        reflect,
                        flag(BsdfFlags::SPECULAR_REFLECTION),
                        flag(SPECULAR_TRANSMISSION),
                    ),
                    valid: R::Mask::splat(true),
                }
            },
            {
                let h = visible_normal(self.alpha, self.alpha, wo, u);
                let wo_h = wo.dot(h);
                let wi = h * (wo_h * 2.0) - wo;
                let reflect = uc.lt(fresnel::dielectric(wo_h, self.eta));
                DirectionLanes {
                    wi: Vec3L::select(reflect, wi, Vec3L::new(wi.x, wi.y, -wi.z)),
                    flags: R::Bits::select(
                        reflect,
                        flag(BsdfFlags::GLOSSY_REFLECTION),
                        flag(GLOSSY_TRANSMISSION),
                    ),
                    valid: wo_h.gt(R::ZERO) & wi.z.gt(R::ZERO),
                }
            },
            DirectionLanes::select
        );
        DirectionLanes {
            wi: drawn.wi * sign,
            flags: drawn.flags,
            valid: drawn.valid & seen,
        }
    }

    /// The smooth sheet's weight and probability in direction `wi` of lobe `flags`
    /// ([`BsdfFlags::bits`]): F(|n·wo|) for the mirror, (1 − F) tint and 1 − F straight
    /// through; valid where the probability is positive and wo is not in the plane.
    #[inline(always)]
    pub fn sample_delta(&self, wo: Vec3L<R>, flags: R::Bits) -> (Vec3L<R>, R, R::Mask) {
        let f = fresnel::dielectric(wo.z.abs(), self.eta);
        let transmission = R::Bits::splat(BsdfFlags::TRANSMISSION.bits());
        let through = (flags & transmission).eq(transmission);
        let kept = R::ONE - f;
        let f_cos = Vec3L::select(through, self.tint * kept, Vec3L::all(f));
        let pdf = R::select(through, kept, f);
        (f_cos, pdf, pdf.gt(R::ZERO) & wo.z.ne(R::ZERO))
    }

    /// The lobes each lane has ([`BsdfFlags::bits`]).
    #[inline(always)]
    pub fn flags(&self) -> R::Bits {
        R::Bits::select(
            self.smooth(),
            R::Bits::splat(SPECULAR.bits()),
            R::Bits::splat(GLOSSY.bits()),
        )
    }
}

impl LocalBsdf for ThinDielectric {
    #[inline(always)]
    fn depends_on_cos_theta_only(&self) -> bool {
        false
    }

    #[inline]
    fn at(self, wo: Vec3) -> ThinDielectric {
        if !self.compensated || self.is_specular() || wo.z == 0.0 {
            return self;
        }
        ThinDielectric {
            scale: self.lanes().scale(wo.into()),
            ..self
        }
    }

    #[inline]
    fn flags(&self) -> BsdfFlags {
        BsdfFlags::from_bits(self.lanes().flags())
    }

    #[inline]
    fn albedo(&self) -> Vec3 {
        self.tint
    }

    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.eval_pdf(wo, wi).0
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_pdf(wo, wi).1
    }

    #[inline]
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let (f, pdf) = self.lanes().eval_pdf(self.scale, wo.into(), wi.into());
        (f.into(), pdf)
    }

    #[inline(always)]
    fn reads_lobe_number(&self) -> bool {
        true
    }

    #[inline]
    fn sample_direction(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<(Vec3, BsdfFlags)> {
        let d = self.lanes().sample_direction(wo.into(), uc, u.into());
        d.valid
            .then(|| (d.wi.into(), BsdfFlags::from_bits(d.flags)))
    }

    /// The smooth sheet's sample in direction `wi` ([`ThinDielectricLanes::sample_delta`]).
    #[inline]
    fn sample_delta(&self, wo: Vec3, wi: Vec3, flags: BsdfFlags) -> Option<BsdfSample> {
        let (f_cos, pdf, valid) = self.lanes().sample_delta(wo.into(), flags.bits());
        valid.then(|| BsdfSample {
            wi,
            f_cos: f_cos.into(),
            pdf,
            flags,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit direction of (a, b) ∈ [0, 1)²: z = 2a − 1, azimuth 2πb (uniform over the
    /// sphere), at any width.
    #[inline(always)]
    fn sphere<R: Real>(a: R, b: R) -> Vec3L<R> {
        let z = a * 2.0 - 1.0;
        let r = (R::ONE - z * z).safe_sqrt();
        let (s, c) = crate::math::sin_cos(b * std::f32::consts::TAU);
        Vec3L::new(r * c, r * s, z)
    }

    /// The interface gives the same bits at one lane and eight, inside the AVX2 dispatch:
    /// smooth, rough and index-matched interfaces side by side, wo outside, inside and in
    /// the plane, indices above and below 1 (total internal reflection among them), both
    /// models (eight lanes in a row alike).
    #[test]
    fn the_interface_has_the_same_bits_at_every_width() {
        #[inline(always)]
        fn kernel<R: Real>(x: [R; 12]) -> [R; 16] {
            let glass = DielectricLanes {
                eta: x[0],
                alpha: x[1],
                tint: Vec3L::new(x[2], x[3], x[4]),
                compensated: x[11].lane(0) < 0.5,
            };
            let (wo, wi) = (sphere(x[5], x[6]), sphere(x[7], x[8]));
            let scale = glass.scale(wo);
            let (f, pdf) = glass.eval_pdf(scale, wo, wi);
            let s = glass.sample(scale, wo, x[9], Vec2L::new(x[10], x[6]));
            let (f_d, pdf_d, valid_d) = glass.sample_delta(wo, s.flags);
            let flag = |m: R::Mask| R::select(m, R::ONE, R::ZERO);
            let kept = |v: R| R::select(s.drawn, v, R::ZERO);
            [
                scale,
                f.x,
                f.z,
                pdf,
                kept(s.wi.x),
                kept(s.wi.z),
                R::select(s.valid, s.f_cos.y, R::ZERO),
                R::select(s.valid, s.pdf, R::ZERO),
                R::from_bits(R::Bits::select(s.drawn, s.flags, R::Bits::splat(0))),
                flag(s.drawn),
                flag(s.valid),
                f_d.x,
                pdf_d,
                flag(valid_d),
                R::from_bits(glass.flags()),
                flag(glass.specular()),
            ]
        }
        let mut next = crate::sampling::hash::uniform_sequence(4544);
        let inputs: Vec<[f32; 12]> = (0..4000)
            .map(|k| {
                let mut x = [0.0f32; 12];
                for v in x.iter_mut() {
                    *v = next();
                }
                x[0] = [1.5, 1.0 / 1.5, 1.0, 0.8 + 2.0 * x[0]][k % 4];
                x[1] = [0.0, x[1] * x[1], 0.5, x[1]][(k / 4) % 4];
                if k % 97 == 5 {
                    x[5] = 0.5;
                }
                x[11] = ((k / 8) % 2) as f32;
                x
            })
            .collect();
        crate::lanes::assert_same_bits_at_every_width!(
            kernel: [12] -> [16],
            inputs.clone(),
            dispatched only
        );
        // Every lobe is drawn.
        let lobes: std::collections::BTreeSet<u32> = inputs
            .into_iter()
            .map(kernel::<f32>)
            .filter(|o| o[10] > 0.0)
            .map(|o| o[8].to_bits())
            .collect();
        assert_eq!(lobes.len(), 4, "{lobes:?}");
    }

    /// The thin sheet gives the same bits at one lane and eight, in and out of the AVX2
    /// dispatch: smooth and rough sheets side by side, wo on both sides and in the plane,
    /// both lobes drawn, compensated or not (eight lanes in a row alike).
    #[test]
    fn the_thin_sheet_has_the_same_bits_at_every_width() {
        #[inline(always)]
        fn kernel<R: Real>(x: [R; 12]) -> [R; 13] {
            let sheet = ThinDielectricLanes {
                eta: x[0],
                alpha: x[1],
                tint: Vec3L::new(x[2], x[3], x[4]),
                compensated: x[11].lane(0) < 0.5,
            };
            let (wo, wi) = (sphere(x[5], x[6]), sphere(x[7], x[8]));
            let scale = sheet.scale(wo);
            let (f, pdf) = sheet.eval_pdf(scale, wo, wi);
            let s = sheet.sample_direction(wo, x[9], Vec2L::new(x[10], x[6]));
            let (f_d, pdf_d, valid_d) = sheet.sample_delta(wo, s.flags);
            let flag = |m: R::Mask| R::select(m, R::ONE, R::ZERO);
            [
                scale,
                f.x,
                f.z,
                pdf,
                R::select(s.valid, s.wi.x, R::ZERO),
                R::select(s.valid, s.wi.z, R::ZERO),
                R::from_bits(R::Bits::select(s.valid, s.flags, R::Bits::splat(0))),
                flag(s.valid),
                f_d.y,
                pdf_d,
                flag(valid_d),
                R::from_bits(sheet.flags()),
                flag(sheet.smooth()),
            ]
        }
        let mut next = crate::sampling::hash::uniform_sequence(4533);
        let inputs: Vec<[f32; 12]> = (0..4000)
            .map(|k| {
                let mut x = [0.0f32; 12];
                for v in x.iter_mut() {
                    *v = next();
                }
                x[0] += 1.0;
                x[1] = [0.0, x[1] * x[1], 0.5, x[1]][k % 4];
                // A wo in the plane now and then.
                if k % 97 == 5 {
                    x[5] = 0.5;
                }
                x[11] = ((k / 8) % 2) as f32;
                x
            })
            .collect();
        crate::lanes::assert_same_bits_at_every_width!(kernel: [12] -> [13], inputs.clone());
        // Both lobes of both kinds are drawn.
        let lobes: std::collections::BTreeSet<u32> = inputs
            .into_iter()
            .map(kernel::<f32>)
            .filter(|o| o[7] > 0.0)
            .map(|o| o[6].to_bits())
            .collect();
        assert_eq!(lobes.len(), 4, "{lobes:?}");
    }

    /// Refraction at eight lanes has the bits of one lane, and the same lanes refract,
    /// over directions from both sides, indices below and above 1 (total internal reflection
    /// among them) and tilted normals.
    #[test]
    fn refraction_has_the_same_bits_at_every_width() {
        #[inline(always)]
        fn kernel<R: Real>(x: [R; 7]) -> [R; 4] {
            let w = Vec3L::new(x[0], x[1], x[2]).normalize();
            let n = Vec3L::new(x[3], x[4], x[5]).normalize();
            let (t, refracts) = refract_lanes(w, n, x[6]);
            let zero = Vec3L::all(R::ZERO);
            let t = Vec3L::select(refracts, t, zero);
            [t.x, t.y, t.z, R::select(refracts, R::ONE, R::ZERO)]
        }
        let mut next = crate::sampling::hash::uniform_sequence(54);
        let inputs: Vec<[f32; 7]> = (0..20_000)
            .map(|k| {
                let mut x: [f32; 7] = std::array::from_fn(|_| next() * 2.0 - 1.0);
                x[5] = x[5].abs() + 0.5;
                x[6] = if k % 2 == 0 { 1.5 } else { 0.4 + next() * 2.0 };
                x
            })
            .collect();
        assert!(
            inputs.iter().any(|x| refract(
                Vec3::new(x[0], x[1], x[2]).normalize(),
                Vec3::new(x[3], x[4], x[5]).normalize(),
                x[6]
            )
            .is_none()),
            "some inputs are totally reflected"
        );
        crate::lanes::assert_same_bits_at_every_width!(kernel: [7] -> [4], inputs);
    }

    /// The largest f32 below 1.
    const BELOW_ONE: f32 = 1.0 - f32::EPSILON / 2.0;

    fn at(theta: f32, phi: f32) -> Vec3 {
        Vec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    }

    /// Fresnel's equations written out again in f64 from the angles (Born & Wolf §1.5.2:
    /// r⊥ = −sin(θi − θt) / sin(θi + θt), r∥ = tan(θi − θt) / tan(θi + θt)), for light from
    /// the medium of index `n1` into `n2`.
    fn fresnel_reference(theta_i: f64, n1: f64, n2: f64) -> f64 {
        let sin_t = n1 / n2 * theta_i.sin();
        if sin_t >= 1.0 {
            return 1.0;
        }
        if theta_i == 0.0 {
            return ((n1 - n2) / (n1 + n2)).powi(2);
        }
        let theta_t = sin_t.asin();
        let perpendicular = (theta_i - theta_t).sin() / (theta_i + theta_t).sin();
        let parallel = (theta_i - theta_t).tan() / (theta_i + theta_t).tan();
        0.5 * (perpendicular * perpendicular + parallel * parallel)
    }

    /// At normal incidence F = ((η − 1) / (η + 1))² from both sides; elsewhere F follows the
    /// angle form of Fresnel's equations from outside and inside.
    #[test]
    fn fresnel_follows_the_angle_form_of_fresnels_equations() {
        for eta in [1.33f32, 1.5, 2.4, 1.0 / 1.5] {
            let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!((fresnel_dielectric(1.0, eta) - f0).abs() < 1e-7, "η {eta}");
            assert!((fresnel_dielectric(-1.0, eta) - f0).abs() < 1e-7, "η {eta}");
            for k in 0..=90 {
                let theta = k as f64 / 90.0 * std::f64::consts::FRAC_PI_2 * 0.999;
                let c = theta.cos() as f32;
                let outside = fresnel_reference(theta, 1.0, eta as f64);
                let inside = fresnel_reference(theta, eta as f64, 1.0);
                let (got_out, got_in) = (fresnel_dielectric(c, eta), fresnel_dielectric(-c, eta));
                assert!(
                    (got_out as f64 - outside).abs() < 2e-6,
                    "η {eta} θ {theta}: {got_out} against {outside}"
                );
                assert!(
                    (got_in as f64 - inside).abs() < 2e-6,
                    "η {eta} θ {theta} inside: {got_in} against {inside}"
                );
            }
        }
        // At grazing incidence everything is reflected.
        assert_eq!(fresnel_dielectric(0.0, 1.5), 1.0);
    }

    /// From the dense side, past the critical angle asin(1/η), F = 1; F rises continuously
    /// (no jump) to 1 as the angle approaches it, and is monotone in the angle.
    #[test]
    fn fresnel_is_total_past_the_critical_angle_and_continuous_up_to_it() {
        let eta = 1.5f32;
        let critical = (1.0 / eta).asin();
        for k in 1..50 {
            let theta = critical + (std::f32::consts::FRAC_PI_2 - critical) * k as f32 / 50.0;
            assert_eq!(fresnel_dielectric(-theta.cos(), eta), 1.0, "θ {theta}");
            // η < 1 seen from outside is the same interface seen from inside.
            assert_eq!(fresnel_dielectric(theta.cos(), 1.0 / eta), 1.0, "θ {theta}");
        }
        let mut previous = fresnel_dielectric(-1.0, eta);
        let n = 20_000;
        for k in 0..=n {
            let theta = critical * k as f32 / n as f32;
            let f = fresnel_dielectric(-theta.cos(), eta);
            assert!(f >= previous - 1e-6, "θ {theta}: {f} after {previous}");
            previous = f;
        }
        // Continuity at θc: 1 − F(θc − δ) shrinks to 0 with δ (as √δ: the slope is infinite
        // there, but there is no jump).
        let gaps: Vec<f64> = [1e-2f64, 1e-3, 1e-4, 1e-5]
            .iter()
            .map(|delta| {
                let c = ((1.0 / eta as f64).asin() - delta).cos();
                1.0 - fresnel_dielectric(-c as f32, eta) as f64
            })
            .collect();
        for pair in gaps.windows(2) {
            let ratio = pair[1] / pair[0];
            assert!(ratio > 0.2 && ratio < 0.45, "gaps {gaps:?}: not like √δ");
        }
        assert!(gaps[3] < 0.03, "gaps {gaps:?}");
        // Either side of a refraction sees the same reflectance.
        for theta in [0.2f32, 0.6, 1.0, 1.4] {
            let wo = at(theta, 0.3);
            let wt = refract(wo, Vec3::Z, eta).unwrap();
            let (a, b) = (fresnel_dielectric(wo.z, eta), fresnel_dielectric(wt.z, eta));
            assert!((a - b).abs() < 1e-6, "θ {theta}: {a} outside, {b} inside");
        }
    }

    /// Snell's law: η_o sin θo = η_i sin θi, in the plane of incidence, on the far side; from
    /// either side; None past the critical angle; refracting back returns the direction.
    #[test]
    fn refraction_obeys_snells_law_both_ways() {
        let eta = 1.5f32;
        for theta in [0.0f32, 0.3, 0.9, 1.5] {
            let w = at(theta, 1.1);
            let t = refract(w, Vec3::Z, eta).unwrap();
            assert!((t.length() - 1.0).abs() < 1e-6);
            assert!(t.z < 0.0);
            let sin_t = t.truncate().length();
            assert!((theta.sin() - eta * sin_t).abs() < 1e-6, "θ {theta}");
            // The plane of incidence: t's tangent part opposes w's.
            assert!(w.truncate().dot(t.truncate()) <= 0.0);
            let back = refract(t, Vec3::Z, eta).unwrap();
            assert!((back - w).length() < 1e-5, "θ {theta}: {back} against {w}");
        }
        let inside = -at(1.0, 0.0);
        assert!(refract(inside, Vec3::Z, eta).is_none());
        // The same with the normal facing the other way.
        assert!(refract(inside, -Vec3::Z, 1.0 / eta).is_none());
    }

    /// A smooth interface: reflection with probability and weight F, refraction with
    /// probability 1 − F and weight (1 − F)/η'², η' = η_i/η_o, so that with a white tint the
    /// weights times the power factor η'² sum to 1 from both sides, and f_cos/pdf is 1 or
    /// (η_o/η_i)²; past the critical angle everything is reflected.
    #[test]
    fn a_smooth_interface_splits_by_fresnel_and_keeps_energy() {
        for (eta, sign) in [
            (1.5f32, 1.0f32),
            (1.5, -1.0),
            (1.0 / 1.33, 1.0),
            (1.33, -1.0),
        ] {
            let glass = Dielectric::new(eta, 0.0, Vec3::ONE);
            assert_eq!(glass.flags(), SPECULAR);
            for theta in [0.0f32, 0.4, 0.8, 1.2, 1.55] {
                let wo = sign * at(theta, 0.7);
                let f = fresnel_dielectric(wo.z, eta);
                let r = glass.sample(wo, f * 0.5, Vec2::new(0.5, 0.3)).unwrap();
                assert!(r.flags.contains(BsdfFlags::SPECULAR_REFLECTION));
                assert!((r.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
                assert_eq!((r.f_cos.x, r.pdf), (f, f));
                let what = format!("η {eta} side {sign} θ {theta}");
                // η' = η_i / η_o: η entering, 1/η leaving.
                let eta_p = if sign > 0.0 { eta } else { 1.0 / eta };
                if f < 1.0 {
                    let t = glass
                        .sample(wo, f + (1.0 - f) * 0.5, Vec2::new(0.5, 0.3))
                        .unwrap();
                    assert!(t.flags.contains(SPECULAR_TRANSMISSION), "{what}");
                    assert!(t.wi.z * wo.z < 0.0, "{what}");
                    assert!((t.pdf - (1.0 - f)).abs() < 1e-7, "{what}");
                    let weight = t.f_cos.x / t.pdf;
                    assert!(
                        (weight * eta_p * eta_p - 1.0).abs() < 1e-5,
                        "{what}: {weight}"
                    );
                    let total = r.f_cos.x + t.f_cos.x * eta_p * eta_p;
                    assert!((total - 1.0).abs() < 1e-6, "{what}: {total}");
                } else {
                    assert!(
                        glass
                            .sample(wo, BELOW_ONE, Vec2::new(0.5, 0.3))
                            .unwrap()
                            .flags
                            == BsdfFlags::SPECULAR_REFLECTION
                    );
                }
                // Delta lobes are invisible to eval and pdf.
                assert_eq!(glass.eval_pdf(wo, r.wi), (Vec3::ZERO, 0.0));
            }
        }
        // Past the critical angle from inside, the refraction is never chosen.
        let glass = Dielectric::new(1.5, 0.0, Vec3::ONE);
        let wo = -at(0.9, 0.0);
        for k in 0..100 {
            let s = glass
                .sample(wo, k as f32 / 100.0, Vec2::new(0.5, 0.5))
                .unwrap();
            assert_eq!(s.flags, BsdfFlags::SPECULAR_REFLECTION);
            assert_eq!((s.f_cos, s.pdf), (Vec3::ONE, 1.0));
        }
    }

    /// The tint colours transmitted light only.
    #[test]
    fn the_tint_colours_transmission_only() {
        let tint = Vec3::new(0.9, 0.5, 0.1);
        let wo = at(0.5, 0.0);
        for alpha in [0.0f32, 0.3] {
            let (glass, thin) = (
                Dielectric::new(1.5, alpha, tint),
                ThinDielectric::new(1.5, alpha, tint),
            );
            for k in 0..64 {
                let u = Vec2::new((k as f32 + 0.5) / 64.0, 0.37);
                for s in [glass.sample(wo, u.x, u), thin.sample(wo, u.x, u)]
                    .into_iter()
                    .flatten()
                {
                    let c = s.f_cos / s.f_cos.max_element();
                    match s.flags.contains(BsdfFlags::TRANSMISSION) {
                        true => assert!((c - tint / 0.9).abs().max_element() < 1e-5, "{c}"),
                        false => assert_eq!(c, Vec3::ONE),
                    }
                }
            }
            assert_eq!(glass.albedo(), tint);
            assert_eq!(thin.albedo(), tint);
        }
    }

    /// The generalized reciprocity of the radiance convention: f(wo, wi)/η_o² =
    /// f(wi, wo)/η_i², η_o and η_i the indices of the media wo and wi lie in (plain symmetry
    /// for reflection), for rough interfaces from both sides at pairs of directions the
    /// interface samples (so that f > 0), reflected and transmitted; plain symmetry for the
    /// thin sheet.
    #[test]
    fn the_interface_obeys_the_reciprocity_of_radiance() {
        let mut seen = [0usize; 2];
        for (eta, alpha) in [(1.5f32, 0.3f32), (1.33, 0.05), (1.0 / 1.5, 0.6)] {
            let glass = Dielectric::new(eta, alpha, Vec3::ONE);
            let thin = ThinDielectric::new(eta, alpha, Vec3::ONE);
            let index = |w: Vec3| if w.z > 0.0 { 1.0 } else { eta };
            for wo in [at(0.3, 0.0), at(1.2, 0.5), -at(0.2, 0.0), -at(1.0, 2.0)] {
                for k in 0..32 {
                    let u = Vec2::new((k % 8) as f32 / 8.0 + 0.06, (k / 8) as f32 / 4.0 + 0.1);
                    for (uc, kind) in [(0.0f32, 0), (BELOW_ONE, 1)] {
                        let Some(s) = glass.sample(wo, uc, u) else {
                            continue;
                        };
                        let wi = s.wi;
                        let what = format!("η {eta} α {alpha} wo {wo} wi {wi}");
                        let f = glass.eval(wo, wi).x / wi.z.abs();
                        let b = glass.eval(wi, wo).x / wo.z.abs();
                        assert!(f > 0.0, "{what}");
                        let (a, b) = (f / index(wo).powi(2), b / index(wi).powi(2));
                        assert!((a - b).abs() <= 2e-4 * a, "{what}: {a} against {b}");
                        seen[kind] += 1;
                        let Some(s) = thin.sample(wo, uc, u) else {
                            continue;
                        };
                        let wi = s.wi;
                        let f = thin.eval(wo, wi).x / wi.z.abs();
                        let b = thin.eval(wi, wo).x / wo.z.abs();
                        assert!((f - b).abs() <= 2e-4 * f, "thin {what}: {f} against {b}");
                    }
                }
            }
        }
        // Reflections (uc = 0) and transmissions (uc → 1, TIR aside) were both checked.
        assert!(seen[0] > 300 && seen[1] > 200, "{seen:?}");
    }

    /// The thin sheet's transmission is its reflection mirrored through the plane: at the
    /// mirrored direction, f_t / f_r = (1 − F)/F, pdf likewise, from either side.
    #[test]
    fn the_thin_sheets_transmission_is_its_reflection_mirrored() {
        let thin = ThinDielectric::new(1.5, 0.2, Vec3::ONE);
        for sign in [1.0f32, -1.0] {
            for (wo, wi) in [(at(0.4, 0.0), at(0.6, 2.5)), (at(1.3, 0.0), at(0.2, 0.3))] {
                let (wo, wi) = (sign * wo, sign * wi);
                let mirrored = Vec3::new(wi.x, wi.y, -wi.z);
                let (fr, pr) = thin.eval_pdf(wo, wi);
                let (ft, pt) = thin.eval_pdf(wo, mirrored);
                let h = (wo + wi).normalize();
                let f = fresnel_dielectric(wo.dot(h).abs(), 1.5);
                let what = format!("side {sign} wo {wo}");
                assert!(
                    (ft.x / fr.x - (1.0 - f) / f).abs() < 1e-4 * (1.0 - f) / f,
                    "{what}"
                );
                assert!(
                    (pt / pr - (1.0 - f) / f).abs() < 1e-4 * (1.0 - f) / f,
                    "{what}"
                );
                assert!(
                    ft.x > fr.x,
                    "{what}: glass transmits more than it reflects here"
                );
            }
        }
    }

    /// A smooth thin sheet does not bend light: wi = −wo exactly, weight (1 − F) tint with
    /// probability 1 − F; the mirror takes F; the weights sum to 1 (no η² factor).
    #[test]
    fn a_smooth_thin_sheet_passes_light_straight_through() {
        let thin = ThinDielectric::new(1.5, 0.0, Vec3::ONE);
        assert_eq!(thin.flags(), SPECULAR);
        for sign in [1.0f32, -1.0] {
            for theta in [0.0f32, 0.5, 1.0, 1.5] {
                let wo = sign * at(theta, 0.4);
                let f = fresnel_dielectric(theta.cos(), 1.5);
                let t = thin.sample(wo, BELOW_ONE, Vec2::new(0.5, 0.5)).unwrap();
                assert_eq!(t.wi, -wo);
                assert!(t.flags.contains(SPECULAR_TRANSMISSION));
                assert_eq!((t.f_cos.x, t.pdf), (1.0 - f, 1.0 - f));
                let r = thin.sample(wo, 0.0, Vec2::new(0.5, 0.5)).unwrap();
                assert_eq!(r.wi, Vec3::new(-wo.x, -wo.y, wo.z));
                assert_eq!((r.f_cos.x, r.pdf), (f, f));
                assert!((r.f_cos.x + t.f_cos.x - 1.0).abs() < 1e-7);
            }
        }
    }

    /// An index-matched interface (η = 1) is invisible at any roughness: nothing reflected,
    /// everything straight through with the tint.
    #[test]
    fn an_index_matched_interface_is_invisible() {
        let tint = Vec3::new(0.5, 0.6, 0.7);
        let glass = Dielectric::new(1.0, 0.4, tint);
        assert!(glass.flags().is_specular());
        for sign in [1.0f32, -1.0] {
            let wo = sign * at(0.7, 0.2);
            for k in 0..16 {
                let s = glass
                    .sample(wo, k as f32 / 16.0, Vec2::new(0.5, 0.5))
                    .unwrap();
                assert!((s.wi + wo).length() < 1e-6);
                assert_eq!((s.f_cos, s.pdf), (tint, 1.0));
            }
        }
    }

    /// Grazing and tangent wo (wo.z = 0, ±1e-7, −0), roughness at and around the smooth
    /// bound, wi in the plane: no NaN or infinity, no negative value or pdf, and the same
    /// answers twice (bit for bit).
    #[test]
    fn grazing_and_tangent_directions_give_finite_deterministic_answers() {
        let s = Ggx::SMOOTH_ALPHA;
        let alphas = [0.0, s * 0.999, s, s * 1.001, 0.05, 1.0];
        let zs = [0.0f32, -0.0, 1e-7, -1e-7, 1e-4, -1e-4, 1.0, -1.0];
        let mut checked = 0;
        for alpha in alphas {
            for eta in [1.5f32, 1.0 / 1.5] {
                let glass = Dielectric::new(eta, alpha, Vec3::ONE);
                let thin = ThinDielectric::new(eta, alpha, Vec3::ONE);
                for z in zs {
                    let wo = Vec3::new((1.0 - z * z).sqrt(), 0.0, z);
                    for k in 0..400 {
                        let u = Vec2::new((k % 20) as f32 / 20.0, (k / 20) as f32 / 20.0);
                        let u = u.min(Vec2::splat(BELOW_ONE));
                        let samples = [
                            glass.sample(wo, u.y, u),
                            thin.sample(wo, u.y, u),
                            glass.sample(wo, u.x, u),
                            thin.sample(wo, u.x, u),
                        ];
                        let again = [
                            glass.sample(wo, u.y, u),
                            thin.sample(wo, u.y, u),
                            glass.sample(wo, u.x, u),
                            thin.sample(wo, u.x, u),
                        ];
                        for (a, b) in samples.iter().zip(&again) {
                            let what = format!("α {alpha} η {eta} wo {wo:?} u {u}: {a:?}");
                            assert_eq!(format!("{a:?}"), format!("{b:?}"), "{what}");
                            if let Some(a) = a {
                                assert!(
                                    a.wi.is_finite() && (a.wi.length() - 1.0).abs() < 1e-3,
                                    "{what}"
                                );
                                assert!(
                                    a.f_cos.is_finite() && a.f_cos.min_element() >= 0.0,
                                    "{what}"
                                );
                                assert!(a.pdf.is_finite() && a.pdf > 0.0, "{what}");
                                checked += 1;
                            }
                        }
                    }
                    for wi in [
                        Vec3::X,
                        Vec3::new(0.0, 1.0, 1e-7),
                        Vec3::Z,
                        -Vec3::Z,
                        -wo,
                        wo,
                    ] {
                        for (f, p) in [glass.eval_pdf(wo, wi), thin.eval_pdf(wo, wi)] {
                            let what = format!("α {alpha} η {eta} wo {wo:?} wi {wi}: {f} {p}");
                            assert!(f.is_finite() && f.min_element() >= 0.0, "{what}");
                            assert!(p.is_finite() && p >= 0.0, "{what}");
                        }
                    }
                }
            }
        }
        assert!(checked > 10_000, "{checked}");
        // At the bound itself the interface is rough; just below, smooth.
        assert_eq!(Dielectric::new(1.5, s, Vec3::ONE).flags(), GLOSSY);
        assert_eq!(Dielectric::new(1.5, s * 0.999, Vec3::ONE).flags(), SPECULAR);
        assert_eq!(ThinDielectric::new(1.5, s, Vec3::ONE).flags(), GLOSSY);
    }
}
