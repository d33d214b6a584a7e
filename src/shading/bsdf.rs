//! BSDFs: how a surface scatters light, in the local frame of its shading normal.
//!
//! [`Bsdf`] is a closed set dispatched by `match` (pbrt-v4's tagged `BxDF`, Mitsuba's BSDF
//! plugins): Lambertian reflection ([`Lambertian`], sampled by the cosine or, for comparisons,
//! uniformly) and the glTF 2.0 metallic-roughness model (Appendix B of the specification);
//! dielectrics and layers join it as variants. Both it and [`Lambertian`] alone implement
//! [`LocalBsdf`], so that an integrator can be compiled for a scene whose every surface is
//! Lambertian without the other lobes' code ([`super::material::ShadeAs`]).
//! Each answers three questions about directions in its local frame (z along the
//! shading normal, `wo` toward the viewer, `wi` toward the light, both pointing away from the
//! surface):
//!
//! | method     | returns                                                                  |
//! |------------|--------------------------------------------------------------------------|
//! | `eval`     | f(wo, wi)·\|cos θi\| (the cosine included, as Mitsuba's `eval` does)      |
//! | `pdf`      | the solid-angle density with which `sample` draws `wi`                   |
//! | `sample`   | a direction `wi` from a 2D point (and, for a BSDF that chooses between   |
//! |            | lobes after drawing a normal, a lobe number), with its `eval`, `pdf` and |
//! |            | lobe flags                                                               |
//!
//! A variant touches nothing else: [`SurfaceBsdf`] carries world directions into its frame
//! (and rejects those on the wrong side of the geometric surface), the material preparation
//! ([`super::material`]) chooses the variant, and the integrators see `SurfaceBsdf` only.

use glam::{Vec2, Vec3};

use super::dielectric::{Dielectric, ThinDielectric};
use super::gltf_brdf::GltfBrdf;
use super::interaction::SurfaceInteraction;
use super::layers::Layered;
pub use super::lobe::{BsdfFlags, BsdfSample, LocalBsdf};
use crate::lanes::{Real, Vec2L, Vec3L};
use crate::sampling::warps::{cosine_hemisphere, uniform_hemisphere};
use crate::sampling::Onb;
use std::f32::consts::FRAC_1_PI;

/// How Lambertian reflection draws its directions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum DiffuseSampling {
    /// Cosine-weighted: the pdf follows f·cos θ.
    #[default]
    Cosine,
    /// Uniform over the hemisphere: more variance for the same mean, kept for comparisons
    /// (`--hemisphere uniform`).
    Uniform,
}

/// Lambertian reflection f = ρ/π, its directions drawn as `sampling` says (cosine-weighted:
/// pdf cos θ/π, proportional to f·cos θ; uniform: pdf 1/2π).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambertian {
    pub albedo: Vec3,
    pub sampling: DiffuseSampling,
}

impl Lambertian {
    /// Reflectance `albedo`, cosine-sampled.
    pub fn new(albedo: Vec3) -> Lambertian {
        Lambertian {
            albedo,
            sampling: DiffuseSampling::Cosine,
        }
    }
}

// Lambertian reflection written once over [`Real`]: [`Lambertian`] is this at one lane.

/// f·cos θi = ρ cos θi / π of a Lambertian surface of reflectance `albedo`, 0 below it.
#[inline(always)]
pub fn lambertian_eval<R: Real>(albedo: Vec3L<R>, wi: Vec3L<R>) -> Vec3L<R> {
    let cos = wi.z;
    let f = albedo * (cos * FRAC_1_PI);
    Vec3L::select(cos.le(R::ZERO), Vec3L::all(R::ZERO), f)
}

/// The solid-angle density of [`lambertian_sample`]'s directions: cos θ / π, or 1 / (2π)
/// for uniform sampling; 0 below the surface.
#[inline(always)]
pub fn lambertian_pdf<R: Real>(sampling: DiffuseSampling, wi: Vec3L<R>) -> R {
    let cos = wi.z;
    let pdf = match sampling {
        DiffuseSampling::Cosine => cos * FRAC_1_PI,
        DiffuseSampling::Uniform => R::splat(0.5 * FRAC_1_PI),
    };
    R::select(cos.le(R::ZERO), R::ZERO, pdf)
}

/// A direction of the upper hemisphere drawn from `u` as `sampling` says.
#[inline(always)]
pub fn lambertian_sample<R: Real>(sampling: DiffuseSampling, u: Vec2L<R>) -> Vec3L<R> {
    match sampling {
        DiffuseSampling::Cosine => cosine_hemisphere(u),
        DiffuseSampling::Uniform => uniform_hemisphere(u),
    }
}

impl LocalBsdf for Lambertian {
    #[inline(always)]
    fn depends_on_cos_theta_only(&self) -> bool {
        true
    }

    #[inline(always)]
    fn at(self, _wo: Vec3) -> Lambertian {
        self
    }

    #[inline(always)]
    fn flags(&self) -> BsdfFlags {
        BsdfFlags::DIFFUSE_REFLECTION
    }

    #[inline]
    fn albedo(&self) -> Vec3 {
        self.albedo
    }

    #[inline]
    fn eval(&self, _wo: Vec3, wi: Vec3) -> Vec3 {
        lambertian_eval(self.albedo.into(), wi.into()).into()
    }

    #[inline]
    fn pdf(&self, _wo: Vec3, wi: Vec3) -> f32 {
        lambertian_pdf(self.sampling, wi.into())
    }

    #[inline(always)]
    fn sample_direction(&self, _wo: Vec3, _uc: f32, u: Vec2) -> Option<(Vec3, BsdfFlags)> {
        let wi = lambertian_sample(self.sampling, u.into()).into();
        Some((wi, BsdfFlags::DIFFUSE_REFLECTION))
    }

    #[inline(always)]
    fn sample_delta(&self, _wo: Vec3, _wi: Vec3, _flags: BsdfFlags) -> Option<BsdfSample> {
        None
    }
}

/// The BSDFs materials choose from, a closed set dispatched by `match`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    /// Lambertian reflection ([`Lambertian`]).
    Diffuse(Lambertian),
    /// The glTF 2.0 metallic-roughness BRDF ([`GltfBrdf`]).
    MetallicRoughness(GltfBrdf),
    /// A dielectric interface bounding a volume (`KHR_materials_transmission` with
    /// `KHR_materials_volume`): refracts.
    Glass(Dielectric),
    /// A thin transmissive wall (`KHR_materials_transmission` alone): no refraction.
    ThinGlass(ThinDielectric),
    /// The glTF BRDF under a sheen and/or a clear coat (`KHR_materials_sheen`,
    /// `KHR_materials_clearcoat`).
    Layered(Layered),
}

/// Dispatches `$call` on the BSDF variant `$b` names.
macro_rules! each_variant {
    ($self:expr, $b:ident => $call:expr) => {
        match $self {
            Bsdf::Diffuse($b) => $call,
            Bsdf::MetallicRoughness($b) => $call,
            Bsdf::Glass($b) => $call,
            Bsdf::ThinGlass($b) => $call,
            Bsdf::Layered($b) => $call,
        }
    };
}

impl LocalBsdf for Bsdf {
    #[inline(always)]
    fn depends_on_cos_theta_only(&self) -> bool {
        // Every variant named, here and below, so that a new one must say.
        match self {
            Bsdf::Diffuse(_) => true,
            Bsdf::MetallicRoughness(_) | Bsdf::Layered(_) | Bsdf::Glass(_) | Bsdf::ThinGlass(_) => {
                false
            }
        }
    }

    #[inline]
    fn at(self, wo: Vec3) -> Bsdf {
        match self {
            Bsdf::MetallicRoughness(brdf) => Bsdf::MetallicRoughness(brdf.at(wo)),
            Bsdf::Layered(b) => Bsdf::Layered(b.at(wo)),
            Bsdf::Glass(b) => Bsdf::Glass(b.at(wo)),
            Bsdf::ThinGlass(b) => Bsdf::ThinGlass(b.at(wo)),
            Bsdf::Diffuse(b) => Bsdf::Diffuse(b),
        }
    }

    #[inline]
    fn flags(&self) -> BsdfFlags {
        each_variant!(self, b => b.flags())
    }

    #[inline(always)]
    fn transmits(&self) -> bool {
        match self {
            Bsdf::Glass(_) | Bsdf::ThinGlass(_) => true,
            Bsdf::Diffuse(_) | Bsdf::MetallicRoughness(_) | Bsdf::Layered(_) => false,
        }
    }

    #[inline]
    fn albedo(&self) -> Vec3 {
        match self {
            Bsdf::Diffuse(b) => b.albedo,
            // A metal's specular colour is its base colour, a dielectric's diffuse one.
            Bsdf::MetallicRoughness(brdf) => brdf.base_color(),
            Bsdf::Glass(b) => b.albedo(),
            Bsdf::ThinGlass(b) => b.albedo(),
            Bsdf::Layered(b) => b.albedo(),
        }
    }

    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        each_variant!(self, b => b.eval(wo, wi))
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        each_variant!(self, b => b.pdf(wo, wi))
    }

    #[inline]
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        each_variant!(self, b => b.eval_pdf(wo, wi))
    }

    #[inline(always)]
    fn reads_lobe_number(&self) -> bool {
        match self {
            Bsdf::Diffuse(_) | Bsdf::MetallicRoughness(_) => false,
            Bsdf::Glass(b) => b.reads_lobe_number(),
            Bsdf::ThinGlass(b) => b.reads_lobe_number(),
            Bsdf::Layered(b) => b.reads_lobe_number(),
        }
    }

    #[inline(always)]
    fn sample_direction(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<(Vec3, BsdfFlags)> {
        match self {
            Bsdf::Diffuse(b) => b.sample_direction(wo, uc, u),
            // The glTF BRDF chooses its lobe by remapping u.x.
            Bsdf::MetallicRoughness(b) => b.sample_direction(wo, u),
            Bsdf::Glass(b) => b.sample_direction(wo, uc, u),
            Bsdf::ThinGlass(b) => b.sample_direction(wo, uc, u),
            Bsdf::Layered(b) => b.sample_direction(wo, uc, u),
        }
    }

    #[inline(always)]
    fn disperses(&self) -> bool {
        match self {
            Bsdf::Glass(g) => g.dispersion > 0.0,
            Bsdf::Diffuse(_)
            | Bsdf::MetallicRoughness(_)
            | Bsdf::Layered(_)
            | Bsdf::ThinGlass(_) => false,
        }
    }

    #[inline]
    fn at_wavelength(self, lambda: f32) -> Bsdf {
        match self {
            Bsdf::Glass(g) => Bsdf::Glass(g.at_wavelength(lambda)),
            b @ (Bsdf::Diffuse(_)
            | Bsdf::MetallicRoughness(_)
            | Bsdf::Layered(_)
            | Bsdf::ThinGlass(_)) => b,
        }
    }

    #[inline]
    fn sample_delta(&self, wo: Vec3, wi: Vec3, flags: BsdfFlags) -> Option<BsdfSample> {
        match self {
            Bsdf::MetallicRoughness(brdf) => brdf.sample_delta(wo, wi, flags),
            Bsdf::Glass(b) => b.sample_delta(wo, wi, flags),
            Bsdf::ThinGlass(b) => b.sample_delta(wo, wi, flags),
            Bsdf::Layered(b) => b.sample_delta(wo, wi, flags),
            Bsdf::Diffuse(_) => None,
        }
    }
}

/// A [`Bsdf`] placed at a surface point: world directions in, world directions out (pbrt-v4's
/// `BSDF`). It holds the shading frame (Duff et al.'s ONB around the shading normal), the
/// geometric normal on the side the ray came from, and `wo` in the local frame.
///
/// Reflection is taken only toward the side of the geometric surface the ray came from: a
/// direction below it, which an interpolated shading normal can allow, would leave through
/// the surface and is given zero. A BSDF that transmits scatters to both sides, but only
/// where the shading frame and the geometric surface agree on the side a direction lies on
/// ([`SurfaceBsdf::admits`]): light neither leaks through a reflecting lobe nor reflects
/// through a transmitting one.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceBsdf<B = Bsdf> {
    pub bsdf: B,
    frame: Onb,
    ng: Vec3,
    wo: Vec3,
}

impl<B: LocalBsdf> SurfaceBsdf<B> {
    #[inline]
    pub fn new(bsdf: B, si: &SurfaceInteraction) -> SurfaceBsdf<B> {
        let frame = Onb::from_normal(si.ns);
        let wo = match bsdf.depends_on_cos_theta_only() {
            true => Vec3::Z,
            false => frame.to_local(si.wo),
        };
        // Every query of a surface point's BSDF is from its one wo: the terms of wo once.
        let bsdf = bsdf.at(wo);
        SurfaceBsdf {
            bsdf,
            frame,
            ng: si.ng,
            wo,
        }
    }

    /// True when the BSDF depends on the wavelength ([`LocalBsdf::disperses`]).
    #[inline(always)]
    pub fn disperses(&self) -> bool {
        self.bsdf.disperses()
    }

    /// The BSDF at wavelength `lambda` nm, its terms of wo made again.
    #[inline]
    pub fn at_wavelength(self, lambda: f32) -> SurfaceBsdf<B> {
        SurfaceBsdf {
            bsdf: self.bsdf.at_wavelength(lambda).at(self.wo),
            ..self
        }
    }

    /// The lobes of the BSDF.
    #[inline]
    pub fn flags(&self) -> BsdfFlags {
        self.bsdf.flags()
    }

    /// World direction `w` in the shading frame; for a BSDF that reads cos θ alone, only its
    /// z (the one dot product of the Lambertian path, where three cost the path tracer 6%
    /// more instructions on the Cornell box).
    #[inline(always)]
    fn local(&self, w: Vec3) -> Vec3 {
        match self.bsdf.depends_on_cos_theta_only() {
            true => Vec3::new(0.0, 0.0, w.dot(self.frame.n)),
            false => self.frame.to_local(w),
        }
    }

    /// Whether the BSDF may scatter into world direction `wi` (`local` in its frame): above
    /// the geometric surface (the side the ray came from); or, for a BSDF that transmits, on
    /// either side where the shading frame puts it on the same one.
    #[inline(always)]
    fn admits(&self, wi: Vec3, local: Vec3) -> bool {
        let above = wi.dot(self.ng) > 0.0;
        match self.bsdf.transmits() {
            false => above,
            true => above == (local.z > 0.0),
        }
    }

    /// f(wo, wi)·|cos θi| for world direction `wi`.
    #[inline(always)]
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        let local = self.local(wi);
        if !self.admits(wi, local) {
            return Vec3::ZERO;
        }
        self.bsdf.eval(self.wo, local)
    }

    /// The solid-angle pdf of [`SurfaceBsdf::sample`] drawing world direction `wi`.
    #[inline(always)]
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let local = self.local(wi);
        if !self.admits(wi, local) {
            return 0.0;
        }
        self.bsdf.pdf(self.wo, local)
    }

    /// [`SurfaceBsdf::eval`] and [`SurfaceBsdf::pdf`] of world direction `wi` together.
    #[inline(always)]
    pub fn eval_pdf(&self, wi: Vec3) -> (Vec3, f32) {
        let local = self.local(wi);
        if !self.admits(wi, local) {
            return (Vec3::ZERO, 0.0);
        }
        self.bsdf.eval_pdf(self.wo, local)
    }

    /// True when [`SurfaceBsdf::sample`] reads its lobe number (see
    /// [`LocalBsdf::reads_lobe_number`]).
    #[inline(always)]
    pub fn reads_lobe_number(&self) -> bool {
        self.bsdf.reads_lobe_number()
    }

    /// A world direction drawn with lobe number `uc` and 2D point `u`; None where none can be
    /// drawn, or where it falls below the geometric surface.
    ///
    /// For a non-delta lobe, the value and pdf are those [`SurfaceBsdf::eval`] and
    /// [`SurfaceBsdf::pdf`] give the world direction as it will be traced (after its
    /// rotation out of the local frame has rounded it): an emitter that direction reaches is
    /// then weighted by MIS with exactly the pdf that sampled it.
    #[inline(always)]
    pub fn sample(&self, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let (local, flags) = self.bsdf.sample_direction(self.wo, uc, u)?;
        let wi = self.frame.to_world(local);
        if flags.is_specular() {
            let s = self.bsdf.sample_delta(self.wo, local, flags)?;
            return self.admits(wi, local).then_some(BsdfSample { wi, ..s });
        }
        let (f_cos, pdf) = self.eval_pdf(wi);
        (pdf > 0.0).then_some(BsdfSample {
            wi,
            f_cos,
            pdf,
            flags,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lambertian reflection's value, densities and samples: eight lanes give the bits of
    /// eight single lanes.
    #[test]
    fn lambertian_has_the_same_bits_at_every_width() {
        #[inline(always)]
        fn kernel<R: Real>(x: [R; 6]) -> [R; 11] {
            let albedo = Vec3L::new(x[0], x[1], x[2]);
            let u = Vec2L::new(x[3], x[4]);
            let cosine = lambertian_sample(DiffuseSampling::Cosine, u);
            let uniform = lambertian_sample(DiffuseSampling::Uniform, u);
            // A direction below the surface for some lanes.
            let below = Vec3L::new(uniform.x, uniform.y, x[5] - 0.5);
            let f = lambertian_eval(albedo, below);
            [
                f.x,
                f.y,
                f.z,
                lambertian_pdf(DiffuseSampling::Cosine, cosine),
                lambertian_pdf(DiffuseSampling::Uniform, below),
                cosine.x,
                cosine.y,
                cosine.z,
                uniform.x,
                uniform.y,
                uniform.z,
            ]
        }
        let mut next = crate::sampling::hash::uniform_sequence(46);
        let inputs = (0..20_000).map(|_| std::array::from_fn(|_| next()));
        crate::lanes::assert_same_bits_at_every_width!(kernel: [6] -> [11], inputs);
    }

    fn interaction(n: Vec3) -> SurfaceInteraction {
        SurfaceInteraction {
            p: Vec3::ZERO,
            p_error: Vec3::ZERO,
            ng: n,
            ns: n,
            wo: n,
            front_face: true,
            prim: 0,
            inst: crate::ray::NO_INSTANCE,
            u: 0.0,
            v: 0.0,
        }
    }

    /// Every variant: `sample`'s value and pdf are `eval`'s and `pdf`'s for the direction it
    /// returns, and the estimator f·cos/pdf averages to the albedo (the reflectance of a
    /// Lambertian surface, ρ = 0.6 here) over a stratified grid of points.
    #[test]
    fn every_variant_samples_what_it_evaluates_and_reflects_its_albedo() {
        let albedo = Vec3::new(0.6, 0.3, 0.1);
        let n = Vec3::new(0.36, 0.48, 0.8);
        let uniform = Lambertian {
            albedo,
            sampling: DiffuseSampling::Uniform,
        };
        for bsdf in [
            Bsdf::Diffuse(Lambertian::new(albedo)),
            Bsdf::Diffuse(uniform),
        ] {
            // (The glTF model's reflectance is checked against quadrature below.)
            let surface = SurfaceBsdf::new(bsdf, &interaction(n));
            let grid = 256;
            let mut sum = Vec3::ZERO;
            for i in 0..grid {
                for j in 0..grid {
                    let u = Vec2::new(
                        (i as f32 + 0.5) / grid as f32,
                        (j as f32 + 0.5) / grid as f32,
                    );
                    let Some(s) = surface.sample(0.0, u) else {
                        continue;
                    };
                    assert_eq!(s.pdf, surface.pdf(s.wi), "{bsdf:?} u {u}");
                    assert_eq!(s.f_cos, surface.eval(s.wi), "{bsdf:?} u {u}");
                    assert!(s.wi.dot(n) > 0.0);
                    sum += s.f_cos / s.pdf;
                }
            }
            let mean = sum / (grid * grid) as f32;
            assert!(
                (mean - albedo).abs().max_element() < 2e-3,
                "{bsdf:?}: mean f·cos/pdf {mean}, albedo {albedo}"
            );
            assert_eq!(bsdf.albedo(), albedo);
            assert!(bsdf.flags().contains(BsdfFlags::DIFFUSE_REFLECTION));
            assert!(bsdf.flags().has_non_specular() && !bsdf.flags().is_specular());
        }
    }

    /// Directions below the geometric surface scatter nothing, even where the shading
    /// normal leans over them.
    #[test]
    fn directions_below_the_geometric_surface_get_nothing() {
        let mut si = interaction(Vec3::Z);
        si.ns = Vec3::new(0.6, 0.0, 0.8);
        let surface = SurfaceBsdf::new(Bsdf::Diffuse(Lambertian::new(Vec3::ONE)), &si);
        // Above the shading normal's horizon, below the geometric one.
        let wi = Vec3::new(0.99, 0.0, -0.141).normalize();
        assert!(wi.dot(si.ns) > 0.0);
        assert_eq!(surface.eval(wi), Vec3::ZERO);
        assert_eq!(surface.pdf(wi), 0.0);
        // And a direction above both is reflected.
        assert!(surface.eval(Vec3::Z).max_element() > 0.0);
    }

    /// A BSDF that transmits scatters below the geometric surface where the shading frame
    /// agrees; a reflecting one never does, and neither scatters where the two disagree.
    #[test]
    fn only_transmitting_bsdfs_reach_below_the_surface() {
        use super::super::dielectric::Dielectric;
        let si = SurfaceInteraction {
            p: Vec3::ZERO,
            p_error: Vec3::ZERO,
            ng: Vec3::Z,
            // A shading normal tilted 20° off the geometric one.
            ns: Vec3::new(0.342, 0.0, 0.940),
            wo: Vec3::new(0.0, 0.6, 0.8),
            front_face: true,
            prim: 0,
            inst: crate::ray::NO_INSTANCE,
            u: 0.0,
            v: 0.0,
        };
        let glass = SurfaceBsdf::new(Bsdf::Glass(Dielectric::new(1.5, 0.3, Vec3::ONE)), &si);
        let matte = SurfaceBsdf::new(Bsdf::Diffuse(Lambertian::new(Vec3::ONE)), &si);
        // Below both: transmitted by glass only.
        let through = Vec3::new(0.1, -0.5, -0.86).normalize();
        assert!(glass.eval(through).max_element() > 0.0 && glass.pdf(through) > 0.0);
        assert_eq!(matte.eval(through), Vec3::ZERO);
        // Below the geometric surface, above the shading one: neither.
        let between = Vec3::new(0.95, 0.0, -0.05).normalize();
        assert!(between.dot(si.ns) > 0.0 && between.dot(si.ng) < 0.0);
        assert_eq!(glass.eval(between), Vec3::ZERO);
        assert_eq!(glass.pdf(between), 0.0);
        assert_eq!(matte.eval(between), Vec3::ZERO);
        // Above the geometric surface, below the shading one: glass does not transmit there.
        let other = Vec3::new(-0.99, 0.0, 0.05).normalize();
        assert!(other.dot(si.ns) < 0.0 && other.dot(si.ng) > 0.0);
        assert_eq!(glass.eval(other), Vec3::ZERO);
        // Sampled directions keep to the rule.
        for i in 0..256 {
            let u = Vec2::new((i % 16) as f32 / 16.0 + 0.03, (i / 16) as f32 / 16.0 + 0.01);
            // Both lobes: the lobe number runs through [0, 1) as a Kronecker sequence.
            let uc = (i as f32 * 0.618_034).fract();
            if let Some(s) = glass.sample(uc, u) {
                let (above_ng, above_ns) = (s.wi.dot(si.ng) > 0.0, s.wi.dot(si.ns) > 0.0);
                assert_eq!(above_ng, above_ns, "{}", s.wi);
            }
        }
    }

    /// The specification's model, single scattering.
    fn gltf(base: Vec3, metallic: f32, roughness: f32) -> Bsdf {
        Bsdf::MetallicRoughness(GltfBrdf::new(base, metallic, roughness).single_scattering())
    }

    /// KHR_materials_ior: the dielectric's reflectance at normal incidence is
    /// ((ior − 1) / (ior + 1))², so 1/9 for an IOR of 2 and none for an IOR of 1, where a
    /// white dielectric is Lambertian.
    #[test]
    fn the_index_of_refraction_sets_the_dielectric_reflectance() {
        use super::super::gltf_brdf::dielectric_f0;
        assert!((dielectric_f0(1.5) - 0.04).abs() < 1e-7);
        assert!((dielectric_f0(2.0) - 1.0 / 9.0).abs() < 1e-7);
        assert_eq!(dielectric_f0(1.0), 0.0);
        // A smooth black dielectric seen head-on: its mirror's weight is f0.
        for (ior, f0) in [(1.5f32, 0.04f32), (2.0, 1.0 / 9.0), (1.2, 1.0 / 121.0)] {
            let mirror = GltfBrdf::new(Vec3::ZERO, 0.0, 0.0).with_ior(ior);
            let s = Bsdf::MetallicRoughness(mirror.single_scattering())
                .sample(Vec3::Z, 0.0, Vec2::new(0.3, 0.7))
                .expect("the mirror's sample");
            assert!(s.flags.is_specular(), "ior {ior}");
            let weight = s.f_cos / s.pdf;
            assert!(
                (weight - Vec3::splat(f0)).abs().max_element() < 1e-6,
                "ior {ior}: {weight}"
            );
        }
        // IOR 1: f0 = 0, and only Schlick's grazing term (1 − cos)⁵ is left: away from
        // grazing half vectors, a white dielectric is Lambertian to 1e-4.
        let plain = GltfBrdf::new(Vec3::ONE, 0.0, 0.5)
            .with_ior(1.0)
            .single_scattering();
        let wo = Vec3::new(0.6, 0.0, 0.8);
        for wi in [Vec3::Z, Vec3::new(0.0, 0.6, 0.8), Vec3::new(0.8, 0.0, 0.6)] {
            let f = plain.eval(wo, wi);
            let lambert = wi.z * std::f32::consts::FRAC_1_PI;
            assert!(
                (f - Vec3::splat(lambert)).abs().max_element() < 1e-4,
                "{wi}: {f}"
            );
        }
        // A black rough dielectric (its specular layer alone) reflects about f0's ratio more
        // at IOR 2 than at 1.5: (1/9) / 0.04 = 2.8.
        let black = |ior: f32| {
            let brdf = GltfBrdf::new(Vec3::ZERO, 0.0, 0.3).single_scattering();
            Bsdf::MetallicRoughness(brdf.with_ior(ior))
        };
        let (high, low) = (
            sampled_albedo(&black(2.0), wo),
            sampled_albedo(&black(1.5), wo),
        );
        assert!(
            high.x > 2.0 * low.x && high.x < 3.0 * low.x,
            "{high} against {low}"
        );
    }

    /// The directional albedo ∫ f cos dωi of `bsdf` seen from `wo`, estimated by sampling
    /// over a 300 × 300 stratified grid.
    fn sampled_albedo(bsdf: &Bsdf, wo: Vec3) -> glam::DVec3 {
        let grid = 300;
        let mut estimate = glam::DVec3::ZERO;
        for i in 0..grid {
            for j in 0..grid {
                let u = Vec2::new(
                    (i as f32 + 0.5) / grid as f32,
                    (j as f32 + 0.5) / grid as f32,
                );
                let uc = ((i * grid + j) as f32 * 0.618_034).fract();
                if let Some(s) = bsdf.sample(wo, uc, u) {
                    estimate += (s.f_cos / s.pdf).as_dvec3();
                }
            }
        }
        estimate / (grid * grid) as f64
    }

    /// The white furnace: a white surface (base colour 1; metallic 1, 0.5 or 0) with energy
    /// compensation reflects all the light that reaches it, within 1% (the half-metal too:
    /// the specification mixes two white BRDFs), at every roughness and
    /// from normal to near-grazing incidence; without it, rough metals lose much of it (roughness
    /// 1 at normal incidence keeps 1 − ln 2 ≈ 0.31: D = 1/π, V = 1/(2(1 + μi))) and
    /// smooth dielectrics return more than comes in at grazing incidence.
    #[test]
    fn a_white_metal_with_energy_compensation_stays_white() {
        for (metallic, roughness) in [0.1f32, 0.3, 0.5, 0.7, 0.9, 1.0]
            .into_iter()
            .flat_map(|r| [(1.0, r), (0.5, r), (0.0, r)])
        {
            for theta in [0.0f32, 0.6, 1.1, 1.35] {
                let wo = at(theta, 0.0);
                let metal = GltfBrdf::new(Vec3::ONE, metallic, roughness);
                let e = sampled_albedo(&Bsdf::MetallicRoughness(metal), wo);
                let what = format!("metallic {metallic} roughness {roughness} θo {theta}");
                assert!(
                    (e - glam::DVec3::ONE).abs().max_element() < 0.01,
                    "{what}: {e}"
                );
                // A metal only loses energy to single scattering (the dielectric's diffuse
                // weight can gain it, below).
                if metallic == 1.0 {
                    let single =
                        sampled_albedo(&Bsdf::MetallicRoughness(metal.single_scattering()), wo);
                    assert!(
                        single.x <= e.x + 1e-3,
                        "{what}: single {single}, compensated {e}"
                    );
                }
            }
        }
        let rough = GltfBrdf::new(Vec3::ONE, 1.0, 1.0).single_scattering();
        let lost = sampled_albedo(&Bsdf::MetallicRoughness(rough), at(0.0, 0.0));
        assert!(lost.x < 0.9, "single scattering keeps {lost}");
        let smooth = GltfBrdf::new(Vec3::ONE, 0.0, 0.1).single_scattering();
        let gained = sampled_albedo(&Bsdf::MetallicRoughness(smooth), at(1.35, 0.0));
        assert!(
            gained.x > 1.1,
            "the specification's dielectric returns {gained}"
        );
    }

    fn at(theta: f32, phi: f32) -> Vec3 {
        Vec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    }

    /// The BRDF against the specification's formulas written out again here in f64 (glTF 2.0
    /// Appendix B: D, the height-correlated V, Schlick's F, the Fresnel mix of diffuse and
    /// specular).
    #[test]
    fn the_gltf_brdf_follows_appendix_b() {
        let reference = |base: [f64; 3], metallic: f64, roughness: f64, wo: Vec3, wi: Vec3| {
            let (wo, wi) = (wo.as_dvec3(), wi.as_dvec3());
            let h = (wo + wi).normalize();
            let a2 = (roughness * roughness).powi(2);
            let (nl, nv, nh, vh) = (wi.z, wo.z, h.z, wo.dot(h));
            let d = a2 / (std::f64::consts::PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
            let v = 0.5
                / (nl * (nv * nv * (1.0 - a2) + a2).sqrt()
                    + nv * (nl * nl * (1.0 - a2) + a2).sqrt());
            // material = mix(dielectric_brdf, metal_brdf, metallic), each written out.
            let schlick = |f0: f64| f0 + (1.0 - f0) * (1.0 - vh.abs()).powi(5);
            let specular = d * v;
            base.map(|b| {
                let metal = schlick(b) * specular;
                let fd = schlick(0.04);
                let dielectric = (1.0 - fd) * b / std::f64::consts::PI + fd * specular;
                ((1.0 - metallic) * dielectric + metallic * metal) * nl
            })
        };
        for (base, metallic, roughness) in [
            ([0.8, 0.5, 0.2], 0.0, 0.5),
            ([0.9, 0.9, 0.9], 1.0, 0.2),
            ([0.3, 0.6, 0.9], 0.4, 0.8),
            ([1.0, 1.0, 1.0], 0.0, 1.0),
        ] {
            let bsdf = gltf(
                Vec3::from_array(base.map(|b| b as f32)),
                metallic,
                roughness,
            );
            for (to, ti, dphi) in [
                (0.1, 0.2, 3.0),
                (0.7, 0.7, 2.9),
                (1.3, 0.4, 1.0),
                (0.5, 1.5, 0.2),
            ] {
                let (wo, wi) = (at(to, 0.0), at(ti, dphi));
                let want = reference(base, metallic as f64, roughness as f64, wo, wi);
                let got = bsdf.eval(wo, wi);
                for c in 0..3 {
                    let (g, w) = (got[c] as f64, want[c]);
                    assert!(
                        (g - w).abs() <= 1e-4 * w.abs() + 1e-7,
                        "{base:?} m {metallic} r {roughness} θo {to} θi {ti}: {g} against {w}"
                    );
                }
            }
        }
    }

    /// Asserts Helmholtz reciprocity of `bsdf` at three pairs of directions: f(wo, wi) =
    /// f(wi, wo), that is eval(wo, wi)/cos θi = eval(wi, wo)/cos θo.
    fn assert_reciprocal(bsdf: &Bsdf, what: &str) {
        for (to, ti, dphi) in [(0.2, 1.1, 2.0), (1.4, 0.3, 0.5), (0.9, 0.9, 3.1)] {
            let (wo, wi) = (at(to, 0.0), at(ti, dphi));
            let a = bsdf.eval(wo, wi) / wi.z;
            let b = bsdf.eval(wi, wo) / wo.z;
            assert!(
                (a - b).abs().max_element() <= 1e-5 * a.max_element(),
                "{what}: {a} against {b}"
            );
        }
    }

    /// The specification's model is reciprocal.
    #[test]
    fn the_gltf_brdf_is_reciprocal() {
        assert_reciprocal(
            &gltf(Vec3::new(0.7, 0.4, 0.2), 0.3, 0.4),
            "single scattering",
        );
    }

    /// With energy compensation, a metal stays reciprocal (Kulla & Conty's multiple-scattering
    /// lobe is symmetric in μo and μi), grey and coloured, rough and half-rough, half-metal
    /// excepted (the dielectric's Turquin scaling reads μo alone). (Turquin's scaling of the
    /// metal, strata's model before, was not.)
    #[test]
    fn a_compensated_metal_is_reciprocal() {
        for (base, roughness) in [(Vec3::splat(0.5), 1.0), (Vec3::new(0.9, 0.6, 0.3), 0.6)] {
            let bsdf = Bsdf::MetallicRoughness(GltfBrdf::new(base, 1.0, roughness));
            assert_reciprocal(&bsdf, &format!("{base} roughness {roughness}"));
        }
    }

    /// Sampling estimates the directional albedo ∫ f cos dωi that quadrature gives (a
    /// 600 × 600 midpoint rule over (cos θ, φ)), for metals and dielectrics from normal to
    /// grazing incidence; single scattering never reflects more than comes in, and a rough
    /// white metal loses some energy (the specification's model has no multiple-scattering
    /// term).
    #[test]
    fn sampling_the_gltf_brdf_estimates_its_albedo() {
        for (base, metallic, roughness) in [
            (Vec3::new(0.8, 0.5, 0.2), 0.0, 0.5),
            (Vec3::ONE, 1.0, 0.4),
            (Vec3::ONE, 1.0, 1.0),
            (Vec3::new(0.3, 0.6, 0.9), 0.5, 0.7),
        ] {
            let bsdf = gltf(base, metallic, roughness);
            for theta in [0.0f32, 0.8, 1.4] {
                let wo = at(theta, 0.0);
                let n = 600;
                let mut quadrature = Vec3::ZERO.as_dvec3();
                for i in 0..n {
                    for j in 0..n {
                        let mu = (i as f32 + 0.5) / n as f32;
                        let phi = (j as f32 + 0.5) / n as f32 * std::f32::consts::TAU;
                        let wi = at(mu.acos(), phi);
                        quadrature += (bsdf.eval(wo, wi) / wi.z.max(1e-6)).as_dvec3()
                            * (wi.z as f64 * std::f64::consts::TAU / (n * n) as f64);
                    }
                }
                let estimate = sampled_albedo(&bsdf, wo);
                let what = format!("{base} m {metallic} r {roughness} θo {theta}");
                assert!(
                    (estimate - quadrature).abs().max_element() < 0.01 * quadrature.max_element(),
                    "{what}: sampled {estimate}, quadrature {quadrature}"
                );
                assert!(
                    quadrature.max_element() <= 1.0 + 1e-3,
                    "{what}: albedo {quadrature}"
                );
                if metallic == 1.0 && roughness == 1.0 {
                    assert!(
                        quadrature.x < 0.95,
                        "{what}: no single-scattering loss? {quadrature}"
                    );
                }
            }
        }
    }

    /// Roughness 0 is a perfect mirror: a delta lobe that sampling alone finds, weighted by
    /// Schlick's F at the normal (a white metal reflects everything), and absent from eval.
    #[test]
    fn a_smooth_gltf_surface_is_a_mirror() {
        let wo = at(0.5, 0.0);
        let metal = gltf(Vec3::ONE, 1.0, 0.0);
        assert!(metal.flags().is_specular() && !metal.flags().has_non_specular());
        let s = metal
            .sample(wo, 0.0, Vec2::new(0.3, 0.7))
            .expect("a mirror sample");
        assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
        assert!(s.flags.is_specular());
        assert_eq!(s.f_cos / s.pdf, Vec3::ONE);
        assert_eq!(metal.eval(wo, s.wi), Vec3::ZERO);
        assert_eq!(metal.pdf(wo, s.wi), 0.0);
        // A smooth dielectric: the mirror takes F, the diffuse lobe the rest.
        let plastic = gltf(Vec3::new(0.5, 0.5, 0.5), 0.0, 0.0);
        assert!(plastic.flags().is_specular() && plastic.flags().has_non_specular());
        let mirror = plastic.sample(wo, 0.0, Vec2::new(0.0, 0.5)).unwrap();
        let f = 0.04 + 0.96 * (1.0 - wo.z).powi(5);
        assert!(
            (mirror.f_cos.x - f).abs() < 1e-6,
            "{} against {f}",
            mirror.f_cos.x
        );
        let diffuse = plastic.sample(wo, 0.0, Vec2::new(0.99, 0.5)).unwrap();
        assert!(!diffuse.flags.is_specular());
        assert_eq!(diffuse.pdf, plastic.pdf(wo, diffuse.wi));
    }
}
