//! The Trowbridge-Reitz (GGX) microfacet distribution in the shading frame (z along the
//! normal): the normal distribution D, Smith's masking and height-correlated
//! masking-shadowing, and sampling of the normals visible from a direction; isotropic
//! ([`Ggx`]) or stretched along the frame's x and y axes ([`AnisotropicGgx`]), both behind
//! [`Microfacet`] so that a BSDF is written once for either.
//!
//! - D(h) = α² / (π ((h·n)²(α² − 1) + 1)²) (Walter et al. 2007, eq. 33; glTF 2.0 Appendix B);
//!   anisotropic, 1 / (π αx αy (hx²/αx² + hy²/αy² + hz²)²) (Heitz 2014, "Understanding the
//!   Masking-Shadowing Function", eq. 85).
//! - Λ(w) = (√(1 + α² tan²θ) − 1) / 2, G1(w) = 1 / (1 + Λ(w)) (Heitz 2014, eq. 86); anisotropic,
//!   with α² tan²θ = (αx² wx² + αy² wy²) / wz², the roughness of w's azimuth.
//! - V(wo, wi) = G2 / (4 |n·wo| |n·wi|) with the height-correlated G2 = 1 / (1 + Λo + Λi), in
//!   the form glTF 2.0 Appendix B writes it:
//!   0.5 / (n·wi √((n·wo)²(1 − α²) + α²) + n·wo √((n·wi)²(1 − α²) + α²)), and
//!   KHR_materials_anisotropy's with √(αx² wx² + αy² wy² + wz²) for each square root.
//! - Visible normals D_wo(h) = G1(wo) max(0, wo·h) D(h) / (n·wo), sampled as Heitz 2018
//!   ("Sampling the GGX Distribution of Visible Normals", JCGT 7(4)) describes; reflected
//!   about h, the direction wi = 2(wo·h)h − wo has the density D_wo(h) / (4 wo·h)
//!   = G1(wo) D(h) / (4 n·wo).

use crate::lanes::{Bits, Real, Vec2L, Vec3L};
use crate::math;
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// Below this α, a distribution is treated as a perfect mirror (a delta lobe): f32 can no
/// longer evaluate D near its peak (pbrt-v4 uses the same bound).
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// What a microfacet BSDF asks of its distribution of normals.
pub trait Microfacet: Copy {
    /// D(h) for a unit microfacet normal `h` (0 below the surface).
    fn d(&self, h: Vec3) -> f32;
    /// Smith's masking G1(w).
    fn g1(&self, w: Vec3) -> f32;
    /// The visibility term V = G2 / (4 |n·wo| |n·wi|), height-correlated.
    fn v(&self, wo: Vec3, wi: Vec3) -> f32;
    /// A microfacet normal visible from `wo` (n·wo > 0), drawn with density D_wo(h) from `u`.
    fn sample_visible_normal(&self, wo: Vec3, u: Vec2) -> Vec3;
    /// True when the surface is a perfect mirror for rendering purposes.
    fn is_smooth(&self) -> bool;

    /// The density of reflection directions drawn by `sample_visible_normal` given D of the
    /// half vector: G1(wo) D(h) / (4 n·wo), the density of visible normals (Heitz 2018,
    /// eq. 3) times the reflection's Jacobian 1 / (4 wo·h).
    #[inline]
    fn reflection_pdf(&self, wo: Vec3, d_h: f32) -> f32 {
        self.g1(wo) * d_h / (4.0 * wo.z)
    }
}

/// An isotropic Trowbridge-Reitz (GGX) distribution of roughness α (glTF: α = roughness²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    pub alpha: f32,
}

impl Ggx {
    /// Below this α, the distribution is treated as a perfect mirror ([`SMOOTH_ALPHA`]).
    pub const SMOOTH_ALPHA: f32 = SMOOTH_ALPHA;

    /// The distribution of roughness α.
    #[inline]
    pub fn new(alpha: f32) -> Ggx {
        Ggx { alpha }
    }

    /// True when the surface is a perfect mirror for rendering purposes.
    #[inline]
    pub fn is_smooth(&self) -> bool {
        self.alpha < SMOOTH_ALPHA
    }

    /// D(h) for a unit microfacet normal `h` (0 below the surface).
    #[inline]
    pub fn d(&self, h: Vec3) -> f32 {
        ggx_d(self.alpha, h.into())
    }

    /// Smith's masking G1(w) = 2 (n·w) / (n·w + √(α² (1 − (n·w)²) + (n·w)²)).
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        ggx_g1(self.alpha, w.into())
    }

    /// The visibility term V = G2 / (4 |n·wo| |n·wi|), height-correlated (glTF 2.0 Appendix B).
    #[inline]
    pub fn v(&self, wo: Vec3, wi: Vec3) -> f32 {
        ggx_v(self.alpha, wo.into(), wi.into())
    }

    /// A microfacet normal visible from `wo` (n·wo > 0), drawn with density D_wo(h) from
    /// `u` (Heitz 2018, listing 1).
    #[inline]
    pub fn sample_visible_normal(&self, wo: Vec3, u: Vec2) -> Vec3 {
        visible_normal(self.alpha, self.alpha, wo.into(), u.into()).into()
    }

    /// [`Microfacet::reflection_pdf`].
    #[inline]
    pub fn reflection_pdf(&self, wo: Vec3, d_h: f32) -> f32 {
        self.g1(wo) * d_h / (4.0 * wo.z)
    }
}

impl Microfacet for Ggx {
    #[inline(always)]
    fn d(&self, h: Vec3) -> f32 {
        Ggx::d(self, h)
    }
    #[inline(always)]
    fn g1(&self, w: Vec3) -> f32 {
        Ggx::g1(self, w)
    }
    #[inline(always)]
    fn v(&self, wo: Vec3, wi: Vec3) -> f32 {
        Ggx::v(self, wo, wi)
    }
    #[inline(always)]
    fn sample_visible_normal(&self, wo: Vec3, u: Vec2) -> Vec3 {
        Ggx::sample_visible_normal(self, wo, u)
    }
    #[inline(always)]
    fn is_smooth(&self) -> bool {
        Ggx::is_smooth(self)
    }
}

/// A Trowbridge-Reitz (GGX) distribution of roughness `alpha_x` along the shading frame's x
/// axis and `alpha_y` along its y axis (KHR_materials_anisotropy).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnisotropicGgx {
    pub alpha_x: f32,
    pub alpha_y: f32,
}

impl AnisotropicGgx {
    #[inline]
    pub fn new(alpha_x: f32, alpha_y: f32) -> AnisotropicGgx {
        AnisotropicGgx { alpha_x, alpha_y }
    }
}

impl Microfacet for AnisotropicGgx {
    #[inline]
    fn d(&self, h: Vec3) -> f32 {
        anisotropic_d(self.alpha_x, self.alpha_y, h.into())
    }

    #[inline]
    fn g1(&self, w: Vec3) -> f32 {
        anisotropic_g1(self.alpha_x, self.alpha_y, w.into())
    }

    #[inline]
    fn v(&self, wo: Vec3, wi: Vec3) -> f32 {
        anisotropic_v(self.alpha_x, self.alpha_y, wo.into(), wi.into())
    }

    #[inline]
    fn sample_visible_normal(&self, wo: Vec3, u: Vec2) -> Vec3 {
        visible_normal(self.alpha_x, self.alpha_y, wo.into(), u.into()).into()
    }

    #[inline]
    fn is_smooth(&self) -> bool {
        self.alpha_x.max(self.alpha_y) < SMOOTH_ALPHA
    }
}

// The distributions' terms, written once over [`Real`]: [`Ggx`] and [`AnisotropicGgx`] are
// these at one lane, and eight paths' shading calls them at eight.

/// Isotropic D(h) = α² / (π ((h·n)²(α² − 1) + 1)²), 0 where h is below the surface.
#[inline(always)]
pub fn ggx_d<R: Real>(alpha: R, h: Vec3L<R>) -> R {
    let a2 = alpha * alpha;
    let t = h.z * h.z * (a2 - 1.0) + 1.0;
    R::select(h.z.le(R::ZERO), R::ZERO, a2 / (t * t * PI))
}

/// Isotropic G1(w) = 2 (n·w) / (n·w + √(α² (1 − (n·w)²) + (n·w)²)), 0 at grazing.
#[inline(always)]
pub fn ggx_g1<R: Real>(alpha: R, w: Vec3L<R>) -> R {
    let c = w.z.abs();
    let a2 = alpha * alpha;
    let g = c * 2.0 / (c + (a2 * (R::ONE - c * c) + c * c).safe_sqrt());
    R::select(c.eq(R::ZERO), R::ZERO, g)
}

/// Isotropic height-correlated V = 0.5 / (n·wi √((n·wo)²(1 − α²) + α²) + n·wo √((n·wi)²(1 − α²)
/// + α²)) (glTF 2.0 Appendix B), 0 where both cosines vanish.
#[inline(always)]
pub fn ggx_v<R: Real>(alpha: R, wo: Vec3L<R>, wi: Vec3L<R>) -> R {
    let (no, ni) = (wo.z.abs(), wi.z.abs());
    let a2 = alpha * alpha;
    let one_minus = R::ONE - a2;
    let denominator =
        ni * (no * no * one_minus + a2).sqrt() + no * (ni * ni * one_minus + a2).sqrt();
    R::select(
        denominator.gt(R::ZERO),
        R::splat(0.5) / denominator,
        R::ZERO,
    )
}

/// αx² wx² + αy² wy²: α(φ)² tan²θ times wz².
#[inline(always)]
fn stretched_sin2<R: Real>(ax: R, ay: R, w: Vec3L<R>) -> R {
    let (x, y) = (ax * w.x, ay * w.y);
    x * x + y * y
}

/// Anisotropic D(h) = 1 / (π αx αy (hx²/αx² + hy²/αy² + hz²)²) (Heitz 2014, eq. 85), 0 below
/// the surface.
#[inline(always)]
pub fn anisotropic_d<R: Real>(ax: R, ay: R, h: Vec3L<R>) -> R {
    let (x, y) = (h.x / ax, h.y / ay);
    let t = x * x + y * y + h.z * h.z;
    R::select(h.z.le(R::ZERO), R::ZERO, (ax * ay * t * t * PI).recip())
}

/// Anisotropic G1(w) = 2 (n·w) / (n·w + √(αx² wx² + αy² wy² + (n·w)²)), 0 at grazing.
#[inline(always)]
pub fn anisotropic_g1<R: Real>(ax: R, ay: R, w: Vec3L<R>) -> R {
    let c = w.z.abs();
    let g = c * 2.0 / (c + (stretched_sin2(ax, ay, w) + c * c).sqrt());
    R::select(c.eq(R::ZERO), R::ZERO, g)
}

/// Anisotropic height-correlated V (KHR_materials_anisotropy): glTF's form with
/// √(αx² wx² + αy² wy² + wz²) for each square root.
#[inline(always)]
pub fn anisotropic_v<R: Real>(ax: R, ay: R, wo: Vec3L<R>, wi: Vec3L<R>) -> R {
    let (no, ni) = (wo.z.abs(), wi.z.abs());
    let denominator = ni * (stretched_sin2(ax, ay, wo) + no * no).sqrt()
        + no * (stretched_sin2(ax, ay, wi) + ni * ni).sqrt();
    R::select(
        denominator.gt(R::ZERO),
        R::splat(0.5) / denominator,
        R::ZERO,
    )
}

/// A normal of the GGX distribution of roughnesses (`ax`, `ay`) visible from `wo`, drawn from
/// `u` (Heitz 2018, listing 1): the view stretched to the hemisphere configuration, a point of
/// the projected visible hemisphere, unstretched.
#[inline(always)]
pub fn visible_normal<R: Real>(ax: R, ay: R, wo: Vec3L<R>, u: Vec2L<R>) -> Vec3L<R> {
    // The view direction in the hemisphere configuration (α stretched to 1).
    let vh = Vec3L::new(ax * wo.x, ay * wo.y, wo.z).normalize();
    // An orthonormal basis around it (T1 = z × vh, or x when vh is the pole).
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let len = lensq.sqrt();
    let pole = lensq.le(R::ZERO);
    let t1 = Vec3L::new(
        R::select(pole, R::ONE, -vh.y / len),
        R::select(pole, R::ZERO, vh.x / len),
        R::ZERO,
    );
    let t2 = vh.cross(t1);
    // A point of the unit disk, its lower half compressed toward the projected hemisphere's
    // outline.
    let r = u.x.sqrt();
    let (sin_phi, cos_phi) = math::sin_cos(u.y * TAU);
    let p1 = r * cos_phi;
    let s = (R::ONE + vh.z) * 0.5;
    let p2 = (R::ONE - s) * (R::ONE - p1 * p1).safe_sqrt() + s * (r * sin_phi);
    // Back onto the hemisphere, then unstretched.
    let nh = t1 * p1 + t2 * p2 + vh * (R::ONE - p1 * p1 - p2 * p2).safe_sqrt();
    Vec3L::new(ax * nh.x, ay * nh.y, nh.z.max(R::ZERO)).normalize()
}

/// The directional albedo E(μ, α) of GGX reflection with F = 1, single scattering:
/// ∫ D V (n·wi) dωi, the energy a microfacet surface of roughness α returns from direction
/// cosine μ after one bounce among its facets; and E_s(μ, α) = ∫ (1 − |wo·h|)⁵ D V (n·wi) dωi,
/// Schlick's Fresnel weight integrated the same way, so that a lobe with Schlick's F of
/// reflectance f0 returns f0·E + (1 − f0)·E_s. Tabulated once per process on a 32 × 32 grid of
/// μ and √α (the perceptual roughness), each entry the mean over 32 × 32 stratified
/// visible-normal samples of G2(wo, wi) / G1(wo) (the estimator whose pdf cancels D), looked
/// up bilinearly; with, per roughness, the cosine-weighted averages over μ (2 ∫ · μ dμ) of
/// E, E_s and E_s (1 − E) / E that energy compensation needs.
pub struct AlbedoTable {
    /// Row-major, roughness rows of `N` cosines: fixed sizes, which lanes gather from
    /// without bounds checks.
    e: Box<[f32; 1024]>,
    e_s: Box<[f32; 1024]>,
    /// Per roughness row, the averages of E, E_s and E_s (1 − E) / E (entry 3·row + which).
    averages: [f32; 96],
}

impl AlbedoTable {
    const N: usize = 32;
    const SAMPLES: usize = 32;

    /// The process's table, computed on first use (about 0.05 s on one core;
    /// `Materials::prepare` asks for it before a render that needs it).
    pub fn get() -> &'static AlbedoTable {
        static TABLE: std::sync::OnceLock<AlbedoTable> = std::sync::OnceLock::new();
        TABLE.get_or_init(AlbedoTable::compute)
    }

    fn compute() -> AlbedoTable {
        let n = Self::N;
        // Sequential: the table may first be asked for inside a render's worker, where a
        // parallel loop could run a tile that asks for it again while it is being made.
        let rows: Vec<(Vec<f32>, Vec<f32>)> = (0..n).map(Self::row).collect();
        let e: Vec<f32> = rows.iter().flat_map(|r| r.0.iter().copied()).collect();
        let e_s: Vec<f32> = rows.iter().flat_map(|r| r.1.iter().copied()).collect();
        Self::with_averages(e, e_s)
    }

    /// Row `i` (roughness √α = i / (N − 1)) of E and E_s.
    fn row(i: usize) -> (Vec<f32>, Vec<f32>) {
        let n = Self::N;
        let (mut e, mut e_s) = (Vec::with_capacity(n), Vec::with_capacity(n));
        {
            // Roughness √α on [0, 1], from a little above 0 (the smooth end is 1 anyway).
            let r = (i as f32 / (n - 1) as f32).max(0.02);
            let ggx = Ggx::new(r * r);
            for j in 0..n {
                let mu = (j as f32 / (n - 1) as f32).max(1e-3);
                let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                let (mut sum, mut sum_s) = (0.0f64, 0.0f64);
                let k = Self::SAMPLES;
                for a in 0..k {
                    for b in 0..k {
                        let u = Vec2::new((a as f32 + 0.5) / k as f32, (b as f32 + 0.5) / k as f32);
                        let h = ggx.sample_visible_normal(wo, u);
                        let wi = 2.0 * wo.dot(h) * h - wo;
                        if wi.z > 0.0 {
                            let g1 = ggx.g1(wo);
                            let g2 = ggx.v(wo, wi) * 4.0 * wo.z * wi.z;
                            let weight = (g2 / g1) as f64;
                            sum += weight;
                            sum_s +=
                                weight * ((1.0 - wo.dot(h).abs()).clamp(0.0, 1.0) as f64).powi(5);
                        }
                    }
                }
                e.push((sum / (k * k) as f64) as f32);
                e_s.push((sum_s / (k * k) as f64) as f32);
            }
        }
        (e, e_s)
    }

    /// The table of E and E_s, with their cosine-weighted averages.
    fn with_averages(e: Vec<f32>, e_s: Vec<f32>) -> AlbedoTable {
        let n = Self::N;
        // Cosine-weighted averages over μ: 2 ∫ g(μ) μ dμ by the trapezoid rule on the grid,
        // which integrates the bilinear lookup's piecewise-linear g exactly but for the μ².
        let averages = (0..n)
            .map(|i| {
                let row = |j: usize| {
                    let (ee, es) = (e[i * n + j].max(1e-3) as f64, e_s[i * n + j] as f64);
                    [ee, es, es * (1.0 - ee) / ee]
                };
                let mut avg = [0.0f64; 3];
                for j in 0..n - 1 {
                    let (m0, m1) = (j as f64 / (n - 1) as f64, (j + 1) as f64 / (n - 1) as f64);
                    let (g0, g1) = (row(j), row(j + 1));
                    for c in 0..3 {
                        avg[c] += (g0[c] * m0 + g1[c] * m1) * (m1 - m0);
                    }
                }
                avg.map(|a| a as f32)
            })
            .collect::<Vec<[f32; 3]>>();
        let averages: Vec<f32> = averages.as_flattened().to_vec();
        let table = |v: Vec<f32>| -> Box<[f32; 1024]> {
            v.into_boxed_slice().try_into().expect("a 32 × 32 table")
        };
        AlbedoTable {
            e: table(e),
            e_s: table(e_s),
            averages: averages.try_into().expect("32 rows of three averages"),
        }
    }

    /// E at direction cosine `mu` and GGX α `alpha` (bilinear in μ and √α).
    pub fn e(&self, mu: f32, alpha: f32) -> f32 {
        self.e_and_e_s(mu, AlbedoRowLanes::new(alpha)).0
    }

    /// E_s at direction cosine `mu` and GGX α `alpha`.
    pub fn e_s(&self, mu: f32, alpha: f32) -> f32 {
        self.e_and_e_s(mu, AlbedoRowLanes::new(alpha)).1
    }

    /// E and E_s at direction cosine `mu` in roughness row `row`, with one set of bilinear
    /// weights.
    #[inline]
    pub fn e_and_e_s(&self, mu: f32, row: AlbedoRowLanes<f32>) -> (f32, f32) {
        self.e_and_e_s_lanes(mu, row)
    }

    /// [`AlbedoTable::e_and_e_s`] at any width: the four corners gathered per lane.
    #[inline(always)]
    pub fn e_and_e_s_lanes<R: Real>(&self, mu: R, row: AlbedoRowLanes<R>) -> (R, R) {
        let n = R::Bits::splat(Self::N as u32);
        let last = (Self::N - 1) as f32;
        let x = (mu.clamp(R::ZERO, R::ONE) * last).min(R::splat(last));
        let x0 = x.trunc_i32();
        let x1 = R::Bits::select(
            x0.lt(R::Bits::splat(Self::N as u32 - 1)),
            x0.wrapping_add(R::Bits::splat(1)),
            x0,
        );
        let fx = x - R::from_i32(x0);
        let (lo, hi) = (row.lo.wrapping_mul(n), row.hi.wrapping_mul(n));
        let corners = [
            lo.wrapping_add(x0),
            lo.wrapping_add(x1),
            hi.wrapping_add(x0),
            hi.wrapping_add(x1),
        ];
        (
            bilinear(&self.e, corners, fx, row.t),
            bilinear(&self.e_s, corners, fx, row.t),
        )
    }

    /// The cosine-weighted averages over μ of E, E_s and E_s (1 − E) / E at GGX α `alpha`
    /// (linear in √α).
    pub fn averages(&self, alpha: f32) -> [f32; 3] {
        self.averages_in(AlbedoRowLanes::new(alpha))
    }

    /// [`AlbedoTable::averages`] in roughness row `row`.
    #[inline]
    pub fn averages_in(&self, row: AlbedoRowLanes<f32>) -> [f32; 3] {
        self.averages_in_lanes(row)
    }

    /// [`AlbedoTable::averages_in`] at any width.
    #[inline(always)]
    pub fn averages_in_lanes<R: Real>(&self, row: AlbedoRowLanes<R>) -> [R; 3] {
        let three = R::Bits::splat(3);
        let (lo, hi, t) = (
            row.lo.wrapping_mul(three),
            row.hi.wrapping_mul(three),
            row.t,
        );
        let mut out = [R::ZERO; 3];
        for (c, out) in out.iter_mut().enumerate() {
            let c = R::Bits::splat(c as u32);
            let (low, high) = (
                R::gather(&self.averages, lo.wrapping_add(c)),
                R::gather(&self.averages, hi.wrapping_add(c)),
            );
            *out = low * (R::ONE - t) + high * t;
        }
        out
    }
}

/// Table `t` read bilinearly per lane: its entries at `corners` (row and column indices
/// (lo, x0), (lo, x1), (hi, x0), (hi, x1)) weighted by `fx` along the row and `fy` across.
#[inline(always)]
fn bilinear<R: Real>(t: &[f32; 1024], corners: [R::Bits; 4], fx: R, fy: R) -> R {
    let (a, b) = (R::gather(t, corners[0]), R::gather(t, corners[1]));
    let (c, d) = (R::gather(t, corners[2]), R::gather(t, corners[3]));
    let low = a * (R::ONE - fx) + b * fx;
    let high = c * (R::ONE - fx) + d * fx;
    low * (R::ONE - fy) + high * fy
}

/// Where a GGX α falls between the table's roughness rows (√α on a uniform grid), per lane:
/// found once per material point rather than per lookup.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlbedoRowLanes<R: Real> {
    lo: R::Bits,
    hi: R::Bits,
    t: R,
}

impl<R: Real> AlbedoRowLanes<R> {
    /// Lane `i`'s rows and weight from `lane(i)`.
    pub fn from_fn(mut lane: impl FnMut(usize) -> AlbedoRowLanes<f32>) -> Self {
        let rows: [AlbedoRowLanes<f32>; 8] =
            std::array::from_fn(|i| lane(if i < R::LANES { i } else { 0 }));
        AlbedoRowLanes {
            lo: R::Bits::from_fn(|i| rows[i].lo),
            hi: R::Bits::from_fn(|i| rows[i].hi),
            t: R::from_fn(|i| rows[i].t),
        }
    }

    /// The rows around √α on the table's grid, and the weight of the upper one.
    #[inline(always)]
    pub fn new(alpha: R) -> Self {
        let n = AlbedoTable::N as u32;
        let last = (n - 1) as f32;
        let y = (alpha.max(R::ZERO).sqrt().min(R::ONE) * last).min(R::splat(last));
        let lo = y.trunc_i32();
        let hi = R::Bits::select(
            lo.lt(R::Bits::splat(n - 1)),
            lo.wrapping_add(R::Bits::splat(1)),
            lo,
        );
        AlbedoRowLanes {
            lo,
            hi,
            t: y - R::from_i32(lo),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Inputs for the width tests: random directions of both hemispheres (wo above), points
    /// of the square, and roughnesses from near-smooth to rough, with the corners (grazing
    /// and pole directions, u = 0) among them.
    fn microfacet_inputs() -> Vec<[f32; 10]> {
        let mut next = crate::sampling::hash::uniform_sequence(45);
        let mut inputs: Vec<[f32; 10]> = (0..20_000)
            .map(|_| {
                let mut r = [0.0; 10];
                for (k, r) in r.iter_mut().enumerate() {
                    *r = match k {
                        0 | 1 | 3 | 4 | 5 => next() * 2.0 - 1.0,
                        8 | 9 => (next() * next()).max(2e-3),
                        _ => next(),
                    };
                }
                r
            })
            .collect();
        inputs.extend([
            [0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.5],
            [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.5, 0.5, 0.1, 0.9],
            [
                0.3,
                -0.2,
                0.5,
                0.3,
                0.2,
                -0.5,
                1.0 - f32::EPSILON,
                0.999,
                1.0,
                1e-3,
            ],
        ]);
        inputs
    }

    /// The albedo table's lookups (E, E_s and the averages, bilinear between rows and
    /// cosines): eight lanes give the bits of eight single lanes, over the whole range of
    /// both and the grid's corners.
    #[test]
    fn albedo_lookups_have_the_same_bits_at_every_width() {
        #[inline(always)]
        fn kernel<R: Real>([mu, alpha]: [R; 2]) -> [R; 5] {
            let table = AlbedoTable::get();
            let row = AlbedoRowLanes::new(alpha);
            let (e, e_s) = table.e_and_e_s_lanes(mu, row);
            let [a, b, c] = table.averages_in_lanes(row);
            [e, e_s, a, b, c]
        }
        let mut next = crate::sampling::hash::uniform_sequence(52);
        let mut inputs: Vec<[f32; 2]> = (0..20_000)
            .map(|_| [next() * 1.2 - 0.1, next() * 1.1 - 0.05])
            .collect();
        for (mu, alpha) in [(0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0), (0.5, 1e-6)] {
            inputs.push([mu, alpha]);
        }
        crate::lanes::assert_same_bits_at_every_width!(kernel: [2] -> [5], inputs);
    }

    /// Every term of both distributions and the visible-normal sampling: eight lanes give
    /// the bits of eight single lanes.
    #[test]
    fn microfacet_terms_have_the_same_bits_at_every_width() {
        #[inline(always)]
        fn kernel<R: Real>(x: [R; 10]) -> [R; 11] {
            let wo = Vec3L::new(x[0], x[1], x[2]).normalize();
            let wi = Vec3L::new(x[3], x[4], x[5]).normalize();
            let (ax, ay) = (x[8], x[9]);
            let h = visible_normal(ax, ay, wo, Vec2L::new(x[6], x[7]));
            [
                ggx_d(ax, h),
                ggx_g1(ax, wo),
                ggx_v(ax, wo, wi),
                anisotropic_d(ax, ay, h),
                anisotropic_g1(ax, ay, wi),
                anisotropic_v(ax, ay, wo, wi),
                h.x,
                h.y,
                h.z,
                visible_normal(ax, ax, wo, Vec2L::new(x[7], x[6])).x,
                ggx_d(ax, wi),
            ]
        }
        crate::lanes::assert_same_bits_at_every_width!(kernel: [10] -> [11], microfacet_inputs());
    }

    /// ∫ D(h) (n·h) dh = 1 over the hemisphere: the projected microfacet area is the
    /// macro-surface's (Heitz 2014, eq. 4), integrated in (cos θ, φ) by the midpoint rule.
    #[test]
    fn the_projected_microfacet_area_is_one() {
        for alpha in [0.05f32, 0.2, 0.5, 1.0] {
            let ggx = Ggx::new(alpha);
            let n = 20_000;
            let mut sum = 0.0f64;
            for i in 0..n {
                // Substitute μ = cos θ; dω = dμ dφ, and D depends on μ alone.
                let mu = (i as f64 + 0.5) / n as f64;
                let h = Vec3::new((1.0 - mu * mu).sqrt() as f32, 0.0, mu as f32);
                sum += ggx.d(h) as f64 * mu * 2.0 * std::f64::consts::PI / n as f64;
            }
            assert!((sum - 1.0).abs() < 2e-3, "α {alpha}: ∫D cos = {sum}");
        }
    }

    /// Every normal the sampler draws is a unit vector facing both the macro-normal and the
    /// viewer, from normal incidence to grazing; its density is checked through the
    /// reflected directions' pdf by the χ² tests in tests/sampling.rs.
    #[test]
    fn visible_normals_face_the_viewer() {
        for (alpha, alpha_y) in [(0.01f32, 0.01f32), (0.3, 0.3), (1.0, 1.0), (0.6, 0.05)] {
            let ggx = AnisotropicGgx::new(alpha, alpha_y);
            for theta in [0.0f32, 0.7, 1.4, 1.55] {
                let wo = Vec3::new(theta.sin() * 0.8, theta.sin() * 0.6, theta.cos());
                for i in 0..32 {
                    for j in 0..32 {
                        let u = Vec2::new((i as f32 + 0.5) / 32.0, (j as f32 + 0.5) / 32.0);
                        let h = ggx.sample_visible_normal(wo, u);
                        assert!((h.length() - 1.0).abs() < 1e-4, "{h}");
                        assert!(h.z >= 0.0 && h.dot(wo) >= -1e-4, "α {alpha} θ {theta}: {h}");
                    }
                }
            }
        }
    }

    /// G1 and V against their textbook forms: G1(w) = 1 / (1 + Λ(w)), and V·4 (n·wo)(n·wi)
    /// = 1 / (1 + Λo + Λi), Λ = (√(1 + α² tan²θ) − 1) / 2, in f64.
    #[test]
    fn masking_and_visibility_follow_smith() {
        let lambda = |alpha: f64, c: f64| {
            let tan2 = (1.0 - c * c) / (c * c);
            ((1.0 + alpha * alpha * tan2).sqrt() - 1.0) / 2.0
        };
        for alpha in [0.1f32, 0.4, 1.0] {
            let ggx = Ggx::new(alpha);
            for (co, ci) in [(0.9f32, 0.3f32), (0.2, 0.8), (0.5, 0.5), (0.05, 0.99)] {
                let wo = Vec3::new((1.0 - co * co).sqrt(), 0.0, co);
                let wi = Vec3::new(0.0, (1.0 - ci * ci).sqrt(), ci);
                let a = alpha as f64;
                let g1 = 1.0 / (1.0 + lambda(a, co as f64));
                assert!(
                    (ggx.g1(wo) as f64 - g1).abs() < 1e-5,
                    "G1 α {alpha} cos {co}"
                );
                let g2 = 1.0 / (1.0 + lambda(a, co as f64) + lambda(a, ci as f64));
                let v = g2 / (4.0 * co as f64 * ci as f64);
                let got = ggx.v(wo, wi) as f64;
                assert!(
                    (got - v).abs() < 1e-5 * v.max(1.0),
                    "V α {alpha}: {got} against {v}"
                );
            }
        }
    }

    /// The anisotropic D, V and G1 against KHR_materials_anisotropy's own forms in f64:
    /// D = a² w² w² / π with a² = αt αb, w² = a² / |(αb h·t, αt h·b, a² h·n)|², and
    /// V = 0.5 / (n·wi |(αt wo·t, αb wo·b, n·wo)| + n·wo |(αt wi·t, αb wi·b, n·wi)|); G1 as
    /// 1 / (1 + Λ) with Λ's roughness of the azimuth, α(φ)² = cos²φ αx² + sin²φ αy².
    #[test]
    fn anisotropic_terms_follow_the_extension() {
        let unit = |theta: f64, phi: f64| {
            Vec3::new(
                (theta.sin() * phi.cos()) as f32,
                (theta.sin() * phi.sin()) as f32,
                theta.cos() as f32,
            )
        };
        for (at, ab) in [(0.5f32, 0.1f32), (0.05, 0.6), (1.0, 0.2)] {
            let ggx = AnisotropicGgx::new(at, ab);
            let (at64, ab64) = (at as f64, ab as f64);
            for (theta_o, phi_o, theta_i, phi_i) in [
                (0.3, 0.2, 0.9, 2.5),
                (1.2, 1.0, 0.4, -0.7),
                (0.05, 3.0, 1.45, 0.4),
                (0.8, -1.4, 0.8, 1.7),
            ] {
                let (wo, wi) = (unit(theta_o, phi_o), unit(theta_i, phi_i));
                let h = (wo + wi).normalize();
                let (hx, hy, hz) = (h.x as f64, h.y as f64, h.z as f64);
                let a2 = at64 * ab64;
                let f = [ab64 * hx, at64 * hy, a2 * hz];
                let w2 = a2 / (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
                let d = a2 * w2 * w2 / std::f64::consts::PI;
                let got = ggx.d(h) as f64;
                assert!(
                    (got - d).abs() < 2e-5 * d.max(1.0),
                    "D ({at}, {ab}): {got} against {d}"
                );
                let length = |w: Vec3| {
                    let (x, y, z) = (at64 * w.x as f64, ab64 * w.y as f64, w.z as f64);
                    (x * x + y * y + z * z).sqrt()
                };
                let v = 0.5 / (wi.z as f64 * length(wo) + wo.z as f64 * length(wi));
                let got = ggx.v(wo, wi) as f64;
                assert!(
                    (got - v).abs() < 2e-5 * v.max(1.0),
                    "V ({at}, {ab}): {got} against {v}"
                );
                let alpha2 = phi_o.cos().powi(2) * at64 * at64 + phi_o.sin().powi(2) * ab64 * ab64;
                let tan2 = theta_o.tan().powi(2);
                let lambda = ((1.0 + alpha2 * tan2).sqrt() - 1.0) / 2.0;
                let got = ggx.g1(wo) as f64;
                assert!(
                    (got - 1.0 / (1.0 + lambda)).abs() < 2e-5,
                    "G1 ({at}, {ab}) θ {theta_o}: {got}"
                );
            }
        }
    }

    /// ∫ D(h) (n·h) dh = 1 for anisotropic distributions too, by a midpoint rule in
    /// (cos θ, φ) fine enough for the narrow axis; and the general forms at αx = αy agree
    /// with the isotropic ones.
    #[test]
    fn anisotropic_projected_area_is_one() {
        for (ax, ay) in [(0.3f32, 0.08f32), (0.05, 0.5), (1.0, 0.25)] {
            let ggx = AnisotropicGgx::new(ax, ay);
            let (nt, np) = (4000, 2000);
            let mut sum = 0.0f64;
            for i in 0..nt {
                // μ = cos θ packed toward the pole, where the narrow lobe's mass is: μ = 1 − s².
                let s = (i as f64 + 0.5) / nt as f64;
                let mu = 1.0 - s * s;
                let dmu = 2.0 * s / nt as f64;
                let sin = (1.0 - mu * mu).max(0.0).sqrt();
                for j in 0..np {
                    let phi = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                    let h = Vec3::new(
                        (sin * phi.cos()) as f32,
                        (sin * phi.sin()) as f32,
                        mu as f32,
                    );
                    sum += ggx.d(h) as f64 * mu * dmu * std::f64::consts::TAU / np as f64;
                }
            }
            assert!((sum - 1.0).abs() < 3e-3, "α ({ax}, {ay}): ∫D cos = {sum}");
        }
        // The general forms at αx = αy against the isotropic ones.
        let (iso, near) = (Ggx::new(0.3), AnisotropicGgx::new(0.3, 0.3));
        let (wo, wi) = (Vec3::new(0.6, 0.0, 0.8), Vec3::new(-0.36, 0.48, 0.8));
        let h = (wo + wi).normalize();
        for (a, b) in [
            (iso.d(h), Microfacet::d(&near, h)),
            (iso.v(wo, wi), Microfacet::v(&near, wo, wi)),
            (iso.g1(wo), Microfacet::g1(&near, wo)),
        ] {
            assert!((a - b).abs() < 1e-4 * a, "{a} against {b}");
        }
    }

    /// The tables against quadrature of ∫ D V cos dωi and ∫ (1 − |wo·h|)⁵ D V cos dωi (a
    /// 1000 × 600 midpoint rule in (cos θ, φ)), and E → 1 as the surface becomes smooth.
    #[test]
    fn the_albedo_table_matches_quadrature() {
        let table = AlbedoTable::get();
        for (roughness, mu) in [
            (1.0f32, 1.0f32),
            (1.0, 0.5),
            (0.6, 0.8),
            (0.4, 0.3),
            (0.8, 0.15),
        ] {
            let ggx = Ggx::new(roughness * roughness);
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let (nt, np) = (1000, 600);
            let (mut sum, mut sum_s) = (0.0f64, 0.0f64);
            for i in 0..nt {
                let c = (i as f64 + 0.5) / nt as f64;
                for j in 0..np {
                    let phi = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                    let s = (1.0 - c * c).sqrt();
                    let wi = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, c as f32);
                    let h = (wo + wi).normalize();
                    let f = (ggx.d(h) * ggx.v(wo, wi)) as f64 * c;
                    sum += f;
                    sum_s += f * (1.0 - wo.dot(h).abs() as f64).powi(5);
                }
            }
            let quadrature = sum * std::f64::consts::TAU / (nt * np) as f64;
            let tabulated = table.e(mu, ggx.alpha) as f64;
            assert!(
                (tabulated - quadrature).abs() < 0.01,
                "roughness {roughness} μ {mu}: table {tabulated}, quadrature {quadrature}"
            );
            let quadrature_s = sum_s * std::f64::consts::TAU / (nt * np) as f64;
            let tabulated_s = table.e_s(mu, ggx.alpha) as f64;
            assert!(
                (tabulated_s - quadrature_s).abs() < 0.005,
                "E_s, roughness {roughness} μ {mu}: table {tabulated_s}, quadrature {quadrature_s}"
            );
        }
        assert!(table.e(0.7, 1e-4) > 0.99);
        // A rough surface loses energy to multiple scattering that single scattering misses:
        // at α = 1 and normal incidence D = 1/π and V = 1/(2(1 + μi)), so E = ∫₀¹ μ/(1 + μ) dμ
        // = 1 − ln 2 exactly.
        let exact = 1.0 - std::f32::consts::LN_2;
        assert!(
            (table.e(1.0, 1.0) - exact).abs() < 0.005,
            "{}",
            table.e(1.0, 1.0)
        );
    }
}
