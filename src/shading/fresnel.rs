//! Fresnel reflectance, written once over [`Real`]: Schlick's approximation, which the glTF
//! BRDF and the thin film read, and the exact reflectance of a smooth dielectric interface,
//! which glass reads. The glam-typed callers use these at one lane; eight paths' shading at
//! eight.

use crate::lanes::{Real, Vec3L};

/// Schlick's weight (1 − cos)⁵, with cos clamped to [0, 1] (Schlick 1994, "An Inexpensive
/// BRDF Model for Physically-based Rendering", eq. 15; glTF 2.0 Appendix B's
/// `fresnel_mix`).
#[inline(always)]
pub fn schlick_weight<R: Real>(cos: R) -> R {
    let m = (R::ONE - cos).clamp(R::ZERO, R::ONE);
    let m2 = m * m;
    m2 * m2 * m
}

/// Schlick's F = f0 + (1 − f0)(1 − cos)⁵ of one channel.
#[inline(always)]
pub fn schlick<R: Real>(f0: R, cos: R) -> R {
    f0 + (R::ONE - f0) * schlick_weight(cos)
}

/// Schlick's F of three channels, the weight computed once.
#[inline(always)]
pub fn schlick3<R: Real>(f0: Vec3L<R>, cos: R) -> Vec3L<R> {
    let w = schlick_weight(cos);
    let channel = |c: R| c + (R::ONE - c) * w;
    Vec3L::new(channel(f0.x), channel(f0.y), channel(f0.z))
}

/// The exact Fresnel reflectance of unpolarized light at a smooth dielectric interface, for
/// light arriving with direction cosine `cos_i` against the normal (negative: from the side
/// the normal points away from) and relative index `eta` = n(below) / n(above), the normal
/// pointing above. Total internal reflection gives 1.
///
/// With η' the index ratio across the interface as the light sees it (η, or 1/η from
/// below), sin²θt = (1 − cos²θi) / η'² (Snell), and
/// F = (r∥² + r⊥²) / 2, r∥ = (η' cos θi − cos θt) / (η' cos θi + cos θt),
/// r⊥ = (cos θi − η' cos θt) / (cos θi + η' cos θt) (Born & Wolf §1.5; Walter et al. 2007,
/// eq. 22).
#[inline(always)]
pub fn dielectric<R: Real>(cos_i: R, eta: R) -> R {
    let cos_i = cos_i.clamp(-R::ONE, R::ONE);
    // From below: the same formula with the media swapped.
    let below = cos_i.lt(R::ZERO);
    let eta = R::select(below, eta.recip(), eta);
    let cos_i = cos_i.abs();
    let sin2_t = (R::ONE - cos_i * cos_i) / (eta * eta);
    let cos_t = (R::ONE - sin2_t).safe_sqrt();
    let r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let f = (r_parallel * r_parallel + r_perpendicular * r_perpendicular) * 0.5;
    R::select(sin2_t.ge(R::ONE), R::ONE, f)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each form at eight lanes has the bits of one lane, over cosines of both sides,
    /// grazing and normal incidence, and indices below and above 1 (total internal
    /// reflection included).
    #[test]
    fn fresnel_has_the_same_bits_at_every_width() {
        #[inline(always)]
        fn kernel<R: Real>([cos, eta, f0, g0]: [R; 4]) -> [R; 5] {
            let f = schlick3(Vec3L::new(f0, g0, R::ONE - f0), cos);
            [dielectric(cos, eta), schlick(f0, cos), f.x, f.y, f.z]
        }
        let mut next = crate::sampling::hash::uniform_sequence(48);
        let mut inputs: Vec<[f32; 4]> = (0..20_000)
            .map(|_| [next() * 2.0 - 1.0, 0.5 + next() * 2.0, next(), next()])
            .collect();
        for cos in [-1.0, -0.0, 0.0, 1.0, 1e-30, 2.0] {
            inputs.push([cos, 1.5, 0.04, 1.0]);
            inputs.push([cos, 1.0 / 1.5, 0.5, 0.0]);
        }
        crate::lanes::assert_same_bits_at_every_width!(kernel: [4] -> [5], inputs);
    }

    /// The closed forms at a few points: normal incidence ((η − 1)/(η + 1))², Brewster's
    /// angle (the parallel part vanishes), total internal reflection, Schlick's end points.
    #[test]
    fn fresnel_meets_its_closed_forms() {
        let f0 = ((1.5f32 - 1.0) / (1.5 + 1.0)).powi(2);
        assert!((dielectric(1.0f32, 1.5) - f0).abs() < 1e-7);
        assert!(
            (dielectric(-1.0f32, 1.5) - f0).abs() < 1e-7,
            "from below, the same"
        );
        // At Brewster's angle tan θ = η, only r⊥ is left.
        let theta = 1.5f32.atan();
        let (c, s) = (theta.cos(), theta.sin());
        let ct = (1.0 - s * s / 2.25).sqrt();
        let r_perp = (c - 1.5 * ct) / (c + 1.5 * ct);
        assert!((dielectric(c, 1.5) - 0.5 * r_perp * r_perp).abs() < 1e-6);
        // Inside glass beyond the critical angle asin(1/1.5) ≈ 41.8°, all is reflected.
        assert_eq!(dielectric(-(50f32.to_radians().cos()), 1.5), 1.0);
        assert_eq!(schlick(0.04f32, 1.0), 0.04);
        assert_eq!(schlick(0.04f32, 0.0), 1.0);
        assert_eq!(schlick_weight(1.5f32), 0.0, "clamped");
    }
}
