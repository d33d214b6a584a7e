//! The interface every lobe implements: [`LocalBsdf`], with the [`BsdfFlags`] of its lobes
//! and the [`BsdfSample`] it draws. It stands apart from the lobes and from the closed set of
//! them ([`super::bsdf::Bsdf`]), so that each lobe's file imports it and the enum imports the
//! lobes, and nothing imports in a circle (as pbrt-v4's `base/bxdf.h` stands apart from
//! `bxdfs.h`). The directions are in the local frame of the shading normal; see
//! [`super::bsdf`] for what each method answers.

use glam::{Vec2, Vec3};

/// The kinds of scattering a BSDF or one of its samples has (pbrt-v4's `BxDFFlags`):
/// reflection or transmission, and diffuse, glossy or specular (a delta lobe, which only
/// BSDF sampling can find: light sampling and MIS leave it alone).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct BsdfFlags(u8);

impl BsdfFlags {
    pub const NONE: BsdfFlags = BsdfFlags(0);
    pub const REFLECTION: BsdfFlags = BsdfFlags(1);
    pub const TRANSMISSION: BsdfFlags = BsdfFlags(2);
    pub const DIFFUSE: BsdfFlags = BsdfFlags(4);
    pub const GLOSSY: BsdfFlags = BsdfFlags(8);
    pub const SPECULAR: BsdfFlags = BsdfFlags(16);
    pub const DIFFUSE_REFLECTION: BsdfFlags = BsdfFlags(1 | 4);
    pub const GLOSSY_REFLECTION: BsdfFlags = BsdfFlags(1 | 8);
    pub const SPECULAR_REFLECTION: BsdfFlags = BsdfFlags(1 | 16);

    /// The flags as a lane's word ([`crate::lanes::Bits`]), for lobes drawn eight at a time.
    #[inline(always)]
    pub const fn bits(self) -> u32 {
        self.0 as u32
    }

    /// The flags of a lane's word made by [`BsdfFlags::bits`] (its low byte).
    #[inline(always)]
    pub const fn from_bits(bits: u32) -> BsdfFlags {
        BsdfFlags(bits as u8)
    }

    /// Both sets of flags.
    #[inline]
    pub const fn union(self, other: BsdfFlags) -> BsdfFlags {
        BsdfFlags(self.0 | other.0)
    }

    /// True when every flag of `other` is set.
    #[inline]
    pub const fn contains(self, other: BsdfFlags) -> bool {
        self.0 & other.0 == other.0
    }

    /// True when any flag of `other` is set.
    #[inline]
    pub const fn intersects(self, other: BsdfFlags) -> bool {
        self.0 & other.0 != 0
    }

    /// True when some lobe is not a delta: light sampling can find light through it.
    #[inline]
    pub const fn has_non_specular(self) -> bool {
        self.0 & (Self::DIFFUSE.0 | Self::GLOSSY.0) != 0
    }

    /// True for a delta lobe (or a sample of one).
    #[inline]
    pub const fn is_specular(self) -> bool {
        self.0 & Self::SPECULAR.0 != 0
    }
}

/// A direction drawn from a BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// The sampled direction (local or world, as the method that returned it says).
    pub wi: Vec3,
    /// f(wo, wi)·|cos θi|; for a delta lobe, the lobe's weight times the cosine, as if f held
    /// a Dirac delta divided out by `pdf`.
    pub f_cos: Vec3,
    /// Solid-angle density of `wi` (for a delta lobe, the probability of choosing the lobe).
    pub pdf: f32,
    /// The lobe the direction came from.
    pub flags: BsdfFlags,
}

/// What every BSDF in its local frame answers (see the module documentation); [`super::bsdf::SurfaceBsdf`]
/// places one at a surface point. Implemented by [`super::bsdf::Bsdf`], the closed set materials choose
/// from, and by [`super::bsdf::Lambertian`] alone, for callers compiled for a scene whose every surface is
/// Lambertian (the clay model): they see no other lobe's code.
pub trait LocalBsdf: Copy {
    /// True when `eval` and `pdf` read cos θ of `wi` alone and ignore `wo` (Lambertian
    /// reflection): the shading frame then needs no tangent or bitangent components.
    fn depends_on_cos_theta_only(&self) -> bool;

    /// The BSDF with the terms that depend on `wo` alone computed once (every query of a
    /// surface point's BSDF is from its one `wo`).
    fn at(self, wo: Vec3) -> Self;

    /// The lobes this BSDF has.
    fn flags(&self) -> BsdfFlags;

    /// True when some lobe transmits light to the other side of the surface.
    #[inline(always)]
    fn transmits(&self) -> bool {
        self.flags().intersects(BsdfFlags::TRANSMISSION)
    }

    /// The directional-hemispherical reflectance a denoiser's albedo pass takes.
    fn albedo(&self) -> Vec3;

    /// f(wo, wi)·|cos θi| for local directions.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3;

    /// The solid-angle pdf with which `sample` draws local direction `wi`.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;

    /// `eval` and `pdf` of `wi` together (the same values), for BSDFs that share work
    /// between them.
    #[inline]
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        (self.eval(wo, wi), self.pdf(wo, wi))
    }

    /// True when `sample` reads its lobe number `uc`: a BSDF that chooses its lobe after
    /// drawing a microfacet normal needs a third number (pbrt-v4's `uc`); the others choose
    /// by remapping `u` and ignore `uc`, so that a caller may leave that number undrawn.
    #[inline(always)]
    fn reads_lobe_number(&self) -> bool {
        false
    }

    /// The direction `sample` draws with lobe number `uc` and 2D point `u`, and the lobe it
    /// comes from, before its value and pdf are known to be non-zero.
    fn sample_direction(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<(Vec3, BsdfFlags)>;

    /// True when the BSDF depends on the wavelength (`KHR_materials_dispersion`): a path
    /// then carries one ([`LocalBsdf::at_wavelength`]).
    #[inline(always)]
    fn disperses(&self) -> bool {
        false
    }

    /// The BSDF at wavelength `lambda` nm, its terms of wo not yet made; itself for one that
    /// does not disperse.
    #[inline(always)]
    fn at_wavelength(self, _lambda: f32) -> Self {
        self
    }

    /// The sample of a delta lobe in direction `wi`, with its weight and the probability of
    /// having chosen the lobe.
    fn sample_delta(&self, wo: Vec3, wi: Vec3, flags: BsdfFlags) -> Option<BsdfSample>;

    /// A local direction drawn with lobe number `uc` (read only where
    /// [`LocalBsdf::reads_lobe_number`]) and 2D point `u`, with its value and pdf; None where
    /// the numbers map to no direction the BSDF scatters into (the hemisphere's rim).
    #[inline]
    fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let (wi, flags) = self.sample_direction(wo, uc, u)?;
        if flags.is_specular() {
            return self.sample_delta(wo, wi, flags);
        }
        let (f_cos, pdf) = self.eval_pdf(wo, wi);
        (pdf > 0.0).then_some(BsdfSample {
            wi,
            f_cos,
            pdf,
            flags,
        })
    }
}
