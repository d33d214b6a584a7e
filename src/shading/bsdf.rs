//! BSDFs: how a surface scatters light, in the local frame of its shading normal.
//!
//! [`Bsdf`] is a closed set dispatched by `match` (pbrt-v4's tagged `BxDF`, Mitsuba's BSDF
//! plugins): today Lambertian reflection, sampled by the cosine or, for comparisons,
//! uniformly; the glTF metallic-roughness model, dielectrics and layers join it as variants.
//! Each variant answers three questions about directions in its local frame (z along the
//! shading normal, `wo` toward the viewer, `wi` toward the light, both pointing away from the
//! surface):
//!
//! | method     | returns                                                                  |
//! |------------|--------------------------------------------------------------------------|
//! | `eval`     | f(wo, wi)·\|cos θi\| (the cosine included, as Mitsuba's `eval` does)      |
//! | `pdf`      | the solid-angle density with which `sample` draws `wi`                   |
//! | `sample`   | a direction `wi` from a 2D point, with its `eval`, `pdf` and lobe flags  |
//!
//! A variant touches nothing else: [`SurfaceBsdf`] carries world directions into its frame
//! (and rejects those on the wrong side of the geometric surface), the material preparation
//! ([`super::material`]) chooses the variant, and the integrators see `SurfaceBsdf` only.

use glam::{Vec2, Vec3};

use super::interaction::SurfaceInteraction;
use crate::sampling::warps::{square_to_cosine_hemisphere, square_to_uniform_hemisphere};
use crate::sampling::Onb;

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

/// A BSDF in its local frame (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    /// Lambertian reflection f = ρ/π, directions cosine-weighted (pdf cos θ/π, proportional
    /// to f·cos θ).
    Diffuse { albedo: Vec3 },
    /// The same reflection with directions uniform over the hemisphere (pdf 1/2π): more
    /// variance for the same mean, kept for comparisons (`--hemisphere uniform`).
    DiffuseUniform { albedo: Vec3 },
}

impl Bsdf {
    /// The lobes this BSDF has.
    #[inline]
    pub fn flags(&self) -> BsdfFlags {
        match self {
            Bsdf::Diffuse { .. } | Bsdf::DiffuseUniform { .. } => BsdfFlags::DIFFUSE_REFLECTION,
        }
    }

    /// The directional-hemispherical reflectance a denoiser's albedo pass takes: ρ for
    /// Lambertian reflection.
    #[inline]
    pub fn albedo(&self) -> Vec3 {
        match *self {
            Bsdf::Diffuse { albedo } | Bsdf::DiffuseUniform { albedo } => albedo,
        }
    }

    /// f(wo, wi)·|cos θi| for local directions.
    #[inline]
    pub fn eval(&self, _wo: Vec3, wi: Vec3) -> Vec3 {
        match *self {
            Bsdf::Diffuse { albedo } | Bsdf::DiffuseUniform { albedo } => {
                let cos = wi.z;
                if cos <= 0.0 {
                    return Vec3::ZERO;
                }
                albedo * (cos * std::f32::consts::FRAC_1_PI)
            }
        }
    }

    /// The solid-angle pdf with which [`Bsdf::sample`] draws local direction `wi`.
    #[inline]
    pub fn pdf(&self, _wo: Vec3, wi: Vec3) -> f32 {
        let cos = wi.z;
        if cos <= 0.0 {
            return 0.0;
        }
        match self {
            Bsdf::Diffuse { .. } => cos * std::f32::consts::FRAC_1_PI,
            Bsdf::DiffuseUniform { .. } => 0.5 * std::f32::consts::FRAC_1_PI,
        }
    }

    /// A local direction drawn with 2D point `u`, with its value and pdf; None where the
    /// point maps to no direction the BSDF scatters into (the hemisphere's rim).
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        let (wi, flags) = self.sample_direction(wo, u)?;
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0).then(|| BsdfSample {
            wi,
            f_cos: self.eval(wo, wi),
            pdf,
            flags,
        })
    }

    /// The direction [`Bsdf::sample`] draws with `u` and the lobe it comes from, before its
    /// value and pdf are known to be non-zero.
    #[inline(always)]
    fn sample_direction(&self, _wo: Vec3, u: Vec2) -> Option<(Vec3, BsdfFlags)> {
        match self {
            Bsdf::Diffuse { .. } => Some((square_to_cosine_hemisphere(u), self.flags())),
            Bsdf::DiffuseUniform { .. } => Some((square_to_uniform_hemisphere(u), self.flags())),
        }
    }
}

/// A [`Bsdf`] placed at a surface point: world directions in, world directions out (pbrt-v4's
/// `BSDF`). It holds the shading frame (Duff et al.'s ONB around the shading normal), the
/// geometric normal on the side the ray came from, and `wo` in the local frame.
///
/// Reflection is taken only toward the side of the geometric surface the ray came from: a
/// direction below it, which an interpolated shading normal can allow, would leave through
/// the surface and is given zero.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceBsdf {
    pub bsdf: Bsdf,
    frame: Onb,
    ng: Vec3,
    wo: Vec3,
}

impl SurfaceBsdf {
    #[inline]
    pub fn new(bsdf: Bsdf, si: &SurfaceInteraction) -> SurfaceBsdf {
        let frame = Onb::from_normal(si.ns);
        SurfaceBsdf {
            bsdf,
            frame,
            ng: si.ng,
            wo: frame.to_local(si.wo),
        }
    }

    /// The lobes of the BSDF.
    #[inline]
    pub fn flags(&self) -> BsdfFlags {
        self.bsdf.flags()
    }

    /// f(wo, wi)·|cos θi| for world direction `wi`.
    #[inline]
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        let local = self.frame.to_local(wi);
        if wi.dot(self.ng) <= 0.0 {
            return Vec3::ZERO;
        }
        self.bsdf.eval(self.wo, local)
    }

    /// The solid-angle pdf of [`SurfaceBsdf::sample`] drawing world direction `wi`.
    #[inline]
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let local = self.frame.to_local(wi);
        if wi.dot(self.ng) <= 0.0 {
            return 0.0;
        }
        self.bsdf.pdf(self.wo, local)
    }

    /// A world direction drawn with 2D point `u`; None where none can be drawn, or where it
    /// falls below the geometric surface.
    ///
    /// For a non-delta lobe, the value and pdf are those [`SurfaceBsdf::eval`] and
    /// [`SurfaceBsdf::pdf`] give the world direction as it will be traced (after its
    /// rotation out of the local frame has rounded it): an emitter that direction reaches is
    /// then weighted by MIS with exactly the pdf that sampled it.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<BsdfSample> {
        let (local, flags) = self.bsdf.sample_direction(self.wo, u)?;
        let wi = self.frame.to_world(local);
        if flags.is_specular() {
            let s = self.bsdf.sample(self.wo, u)?;
            return (wi.dot(self.ng) > 0.0).then_some(BsdfSample { wi, ..s });
        }
        let pdf = self.pdf(wi);
        (pdf > 0.0).then(|| BsdfSample {
            wi,
            f_cos: self.eval(wi),
            pdf,
            flags,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn interaction(n: Vec3) -> SurfaceInteraction {
        SurfaceInteraction {
            p: Vec3::ZERO,
            p_error: Vec3::ZERO,
            ng: n,
            ns: n,
            wo: n,
            front_face: true,
            prim: 0,
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
        for bsdf in [Bsdf::Diffuse { albedo }, Bsdf::DiffuseUniform { albedo }] {
            let surface = SurfaceBsdf::new(bsdf, &interaction(n));
            let grid = 256;
            let mut sum = Vec3::ZERO;
            for i in 0..grid {
                for j in 0..grid {
                    let u = Vec2::new(
                        (i as f32 + 0.5) / grid as f32,
                        (j as f32 + 0.5) / grid as f32,
                    );
                    let Some(s) = surface.sample(u) else { continue };
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
        let surface = SurfaceBsdf::new(Bsdf::Diffuse { albedo: Vec3::ONE }, &si);
        // Above the shading normal's horizon, below the geometric one.
        let wi = Vec3::new(0.99, 0.0, -0.141).normalize();
        assert!(wi.dot(si.ns) > 0.0);
        assert_eq!(surface.eval(wi), Vec3::ZERO);
        assert_eq!(surface.pdf(wi), 0.0);
        // And a direction above both is reflected.
        assert!(surface.eval(Vec3::Z).max_element() > 0.0);
    }
}
