//! Layers over the glTF metallic-roughness BRDF: a sheen of fibres (`KHR_materials_sheen`)
//! and a clear coat (`KHR_materials_clearcoat`), stacked as the extensions define:
//!
//! ```text
//! f = c·Fc · f_coat + (1 − c·Fc) · (f_sheen + s · f_base)
//! ```
//!
//! **Coat** (`KHR_materials_clearcoat`, "Layering"): `fresnel_coat` mixes the material
//! below with a GGX specular lobe of roughness α_c = clearcoatRoughness² around the coat's
//! own normal n_c, by the weight c·Fc with c = clearcoat and Fc = 0.04 + 0.96 (1 − |wo·n_c|)⁵,
//! Schlick's Fresnel of IOR 1.5 at the *view* angle (not wo·h: so that the mix conserves
//! energy with so simple a rule, as the extension's discussion says). The coat lobe is
//! f_coat = D V of GGX around n_c, taken with the cosine to n_c (the coat is a microfacet
//! surface of its own); with energy compensation (the default, as for the base) it is divided
//! by its single-scattering albedo E(wo·n_c) (Turquin 2019 with F = 1), so that the coat
//! reflects exactly c·Fc of the light and the whole stays at most 1. A smooth coat (α_c below
//! [`Ggx::SMOOTH_ALPHA`], the extension's default roughness 0) is a delta lobe: the mirror
//! about n_c with weight c·Fc. Where no `clearcoatNormalTexture` bends it, n_c is the
//! interpolated vertex normal, even under the base's normal map (the extension says so).
//!
//! **Sheen** (`KHR_materials_sheen`, "Implementation Notes"): Conty Estevez & Kulla's
//! "Charlie" microfibre lobe (2017, "Production Friendly Microfacet Sheen BRDF"):
//! f_sheen = sheenColor · D_s(h) / ((1 + Λ(μo) + Λ(μi)) 4 μo μi), with
//! D_s = (2 + 1/r) sin(θh)^(1/r) / 2π, r = sheenRoughness, and their fitted Λ (the paper's
//! Table 1, which the extension reprints). The base below is scaled by the albedo scaling
//! s = min(1 − max(sheenColor) E_s(μo), 1 − max(sheenColor) E_s(μi)), E_s the white lobe's
//! directional albedo ([`SheenTable`]), which keeps the stack from gaining energy and keeps
//! it reciprocal. r is held at [`SHEEN_MIN_ROUGHNESS`] or more.
//!
//! **Sampling.** One of the three lobes is chosen with the lobe number `uc`, in proportion to
//! the light each returns toward wo (c·Fc; (1 − c·Fc) luminance(sheenColor) E_s(μo); and
//! (1 − c·Fc)(1 − max(sheenColor) E_s(μo)) times the base's own rough estimate of its
//! albedo); the coat by its visible normals around n_c, the sheen by the cosine, the base as
//! [`GltfBrdf`] samples itself with `u`. `pdf` is the mixture's density, so MIS sees every
//! lobe.

use std::sync::OnceLock;

use glam::{Vec2, Vec3};

use super::gltf_brdf::{DirectionLanes, GltfBrdf, GltfBrdfLanes, OutgoingLanes};
use super::lobe::{BsdfFlags, BsdfSample, LocalBsdf};
use super::microfacet::{ggx_d, ggx_g1, ggx_v, visible_normal, AlbedoRowLanes, AlbedoTable, Ggx};
use super::spectrum::luminance_lanes;
use crate::lanes::{select_lazy, Bits, Mask, Real, Vec2L, Vec3L};
use crate::math;
use crate::sampling::onb::Frame;
use crate::sampling::warps::cosine_hemisphere;
use std::f32::consts::FRAC_1_PI;

/// The clear coat's reflectance at normal incidence: Schlick's f0 of IOR 1.5.
pub const COAT_F0: f32 = 0.04;

/// The smallest sheen roughness rendered: below it the lobe hugs the horizon more tightly
/// than the albedo table's grid can follow (and than f32 powers of sin θh resolve), and a
/// sheen that thin is invisible anyway.
pub const SHEEN_MIN_ROUGHNESS: f32 = 0.07;

/// A clear coat over the material: its weight c (clearcoatFactor × texture), its GGX α, and
/// its normal in the BSDF's local frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coat {
    pub weight: f32,
    pub alpha: f32,
    /// The coat's normal n_c in the local frame of the base.
    normal: Vec3,
    /// True when n_c is the base's normal (+z): no change of frame.
    upright: bool,
}

impl Coat {
    /// A coat of weight `weight` and perceptual roughness `roughness` around the local normal
    /// `normal` (+z when the coat's normal is the base's).
    pub fn new(weight: f32, roughness: f32, normal: Vec3) -> Coat {
        let upright = normal == Vec3::Z;
        Coat {
            weight: weight.clamp(0.0, 1.0),
            alpha: roughness * roughness,
            normal,
            upright,
        }
    }
}

/// A sheen of fibres: its colour and roughness r.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sheen {
    pub color: Vec3,
    pub roughness: f32,
}

impl Sheen {
    pub fn new(color: Vec3, roughness: f32) -> Sheen {
        Sheen {
            color,
            roughness: roughness.clamp(SHEEN_MIN_ROUGHNESS, 1.0),
        }
    }

    /// The white lobe's f·cos θi for local directions above the surface:
    /// D_s(h) / ((1 + Λ(μo) + Λ(μi)) 4 μo).
    #[inline]
    pub fn white_lobe(&self, wo: Vec3, wi: Vec3) -> f32 {
        white_sheen::<f32>(wo.into(), wi.into(), self.roughness)
    }
}

/// The Charlie distribution D_s(h) = (2 + 1/r) sin(θh)^(1/r) / 2π (Conty Estevez & Kulla
/// 2017, eq. 2), from cos θh.
#[inline(always)]
fn charlie_d<R: Real>(cos_h: R, r: R) -> R {
    let inv_r = r.recip();
    let sin2 = (R::ONE - cos_h * cos_h).max(R::ZERO);
    (inv_r + 2.0) * math::pow(sin2, inv_r * 0.5) * (0.5 * std::f32::consts::FRAC_1_PI)
}

/// a + (b − a) t.
#[inline(always)]
fn mix<R: Real>(t: R, a: f32, b: f32) -> R {
    t * (b - a) + a
}

/// Conty Estevez & Kulla's L(x) = a / (1 + b x^c) + d x + e for coefficients `k`.
#[inline(always)]
fn charlie_l<R: Real>([a, b, c, d, e]: [R; 5], x: R) -> R {
    a / (b * math::pow(x, c) + 1.0) + d * x + e
}

/// Conty Estevez & Kulla's fit of the Charlie lobe's Λ (2017, Table 1 and eq. 3–4, as
/// KHR_materials_sheen reprints it): L(x) = a / (1 + b x^c) + d x + e, its coefficients
/// interpolated in (1 − r)², and Λ(μ) = exp(L(μ)) for μ < ½, exp(2 L(½) − L(1 − μ)) above.
#[inline(always)]
fn charlie_lambda<R: Real>(mu: R, r: R) -> R {
    let t = (R::ONE - r) * (R::ONE - r);
    let k = [
        mix(t, 21.5473, 25.3245),
        mix(t, 3.82987, 3.32435),
        mix(t, 0.19823, 0.16801),
        mix(t, -1.97760, -1.27393),
        mix(t, -4.32054, -4.85967),
    ];
    let low = mu.lt(R::splat(0.5));
    let l = charlie_l(k, R::select(low, mu, R::ONE - mu));
    let high = charlie_l(k, R::splat(0.5)) * 2.0 - l;
    math::exp(R::select(low, l, high))
}

/// The white sheen lobe's f·cos θi, D_s(h) / ((1 + Λ(μo) + Λ(μi)) 4 μo) for sheen roughness
/// `r`; zero unless both directions are above the surface (and where f32 overflows).
#[inline(always)]
fn white_sheen<R: Real>(wo: Vec3L<R>, wi: Vec3L<R>, r: R) -> R {
    let h = (wo + wi).normalize();
    let g = (R::ONE + charlie_lambda(wo.z, r) + charlie_lambda(wi.z, r)).recip();
    let value = charlie_d(h.z, r) * g / (wo.z * 4.0);
    let above = wo.z.gt(R::ZERO) & wi.z.gt(R::ZERO);
    R::select(
        above & value.abs().lt(R::splat(f32::INFINITY)),
        value,
        R::ZERO,
    )
}

/// The white sheen lobe's directional albedo E_s(μ, r) = ∫ f_sheen cos θi dωi, tabulated once
/// per process (the first scene with a sheen) on a grid uniform in √μ (E_s changes fastest
/// at grazing angles) and in r, each entry integrated by the midpoint rule over θi and φi (the
/// lobe is symmetric in φ about wo's plane), looked up bilinearly.
pub struct SheenTable {
    e: Vec<f32>,
}

impl SheenTable {
    /// Grid points in √μ (0 to 1) and in r (from [`SHEEN_MIN_ROUGHNESS`] to 1).
    pub const N_MU: usize = 32;
    pub const N_R: usize = 32;
    /// Midpoint-rule cells per entry in θi and in φi over [0, π].
    const CELLS: usize = 64;

    /// The table, made on first use.
    pub fn get() -> &'static SheenTable {
        static TABLE: OnceLock<SheenTable> = OnceLock::new();
        TABLE.get_or_init(SheenTable::compute)
    }

    fn r_at(j: usize) -> f32 {
        SHEEN_MIN_ROUGHNESS + (1.0 - SHEEN_MIN_ROUGHNESS) * j as f32 / (Self::N_R - 1) as f32
    }

    fn compute() -> SheenTable {
        let (n_mu, n_r, k) = (Self::N_MU, Self::N_R, Self::CELLS);
        let mut e = Vec::with_capacity(n_mu * n_r);
        for j in 0..n_r {
            let r = Self::r_at(j);
            for i in 0..n_mu {
                let x = i as f32 / (n_mu - 1) as f32;
                let mu = (x * x).max(1e-4);
                e.push(directional_albedo(mu, r, k) as f32);
            }
        }
        SheenTable { e }
    }

    /// E_s at direction cosine `mu` and sheen roughness `r`.
    pub fn e(&self, mu: f32, r: f32) -> f32 {
        self.e_lanes(mu, r)
    }

    /// [`SheenTable::e`] at any width: bilinear in √μ and r, the corners gathered per lane.
    #[inline(always)]
    pub fn e_lanes<R: Real>(&self, mu: R, r: R) -> R {
        let (n_mu, n_r) = (Self::N_MU as f32, Self::N_R as f32);
        let x = mu.clamp(R::ZERO, R::ONE).sqrt() * (n_mu - 1.0);
        let y = ((r - SHEEN_MIN_ROUGHNESS) / (1.0 - SHEEN_MIN_ROUGHNESS)).clamp(R::ZERO, R::ONE)
            * (n_r - 1.0);
        let x0 = x.min(R::splat(n_mu - 2.0)).trunc_i32();
        let y0 = y.min(R::splat(n_r - 2.0)).trunc_i32();
        let (fx, fy) = (x - R::from_i32(x0), y - R::from_i32(y0));
        let row = y0
            .wrapping_mul(R::Bits::splat(Self::N_MU as u32))
            .wrapping_add(x0);
        let (one, next_row) = (R::Bits::splat(1), R::Bits::splat(Self::N_MU as u32));
        let next = row.wrapping_add(next_row);
        let (a, b) = (
            R::gather_slice(&self.e, row),
            R::gather_slice(&self.e, row.wrapping_add(one)),
        );
        let (c, d) = (
            R::gather_slice(&self.e, next),
            R::gather_slice(&self.e, next.wrapping_add(one)),
        );
        let low = a * (R::ONE - fx) + b * fx;
        let high = c * (R::ONE - fx) + d * fx;
        low * (R::ONE - fy) + high * fy
    }
}

/// ∫ f_sheen cos θi dωi for the white lobe of roughness `r` seen from direction cosine `mu`,
/// by the midpoint rule on `k` × `k` cells of θi ∈ [0, π/2] and φi ∈ [0, π], doubled.
pub fn directional_albedo(mu: f32, r: f32, k: usize) -> f64 {
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let (d_theta, d_phi) = (
        std::f64::consts::FRAC_PI_2 / k as f64,
        std::f64::consts::PI / k as f64,
    );
    let mut sum = 0.0f64;
    for a in 0..k {
        let theta = (a as f64 + 0.5) * d_theta;
        for b in 0..k {
            let phi = (b as f64 + 0.5) * d_phi;
            let wi = Vec3::new(
                (theta.sin() * phi.cos()) as f32,
                (theta.sin() * phi.sin()) as f32,
                theta.cos() as f32,
            );
            sum += white_sheen::<f32>(wo.into(), wi.into(), r) as f64 * theta.sin();
        }
    }
    2.0 * sum * d_theta * d_phi
}

/// The glTF BRDF with a sheen and a clear coat over it per lane (see the module
/// documentation): the one source of the layers, run at one lane by [`Layered`] and at eight
/// by shading that keeps eight paths together. A lane without a sheen or a coat has its mask
/// false and takes, by select, exactly what the layers without it give.
#[derive(Clone, Copy, Debug)]
pub struct LayeredLanes<R: Real> {
    pub base: GltfBrdfLanes<R>,
    /// Where a lane has a sheen: its colour and roughness r (unread elsewhere).
    pub sheen: R::Mask,
    pub sheen_color: Vec3L<R>,
    pub sheen_roughness: R,
    /// Where a lane has a clear coat: its weight c, its GGX α and its normal n_c in the
    /// base's local frame, and where n_c is +z (no change of frame).
    pub coat: R::Mask,
    pub coat_weight: R,
    pub coat_alpha: R,
    pub coat_normal: Vec3L<R>,
    pub coat_upright: R::Mask,
}

/// What the layers read of wo alone, per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayerTermsLanes<R: Real> {
    /// The base's own terms of wo.
    pub base: OutgoingLanes<R>,
    /// c·Fc(|wo·n_c|): the coat's share.
    pub coat_weight: R,
    /// The coat lobe's scale: 1 / E(wo·n_c) with energy compensation, else 1.
    pub coat_scale: R,
    /// max(sheenColor) E_s(μo): what the sheen takes from the base seen from wo.
    pub sheen_take: R,
    /// The probabilities of sampling the coat and the sheen (the base takes the rest).
    pub p_coat: R,
    pub p_sheen: R,
}

impl<R: Real> LayeredLanes<R> {
    /// True per lane where the coat is a mirror (a delta lobe).
    #[inline(always)]
    fn coat_smooth(&self) -> R::Mask {
        self.coat & self.coat_alpha.lt(R::splat(Ggx::SMOOTH_ALPHA))
    }

    /// A local direction in the coat's frame (built where it is needed: kept, it would more
    /// than double the size of every [`super::Bsdf`]).
    #[inline(always)]
    fn in_coat_frame(&self, w: Vec3L<R>) -> Vec3L<R> {
        select_lazy!(
            self.coat_upright,
            w,
            Frame::from_normal(self.coat_normal).to_local(w),
            Vec3L::select
        )
    }

    #[inline(always)]
    fn out_of_coat_frame(&self, w: Vec3L<R>) -> Vec3L<R> {
        select_lazy!(
            self.coat_upright,
            w,
            Frame::from_normal(self.coat_normal).to_world(w),
            Vec3L::select
        )
    }

    /// The mirror of `wo` about n_c.
    #[inline(always)]
    fn coat_mirror(&self, wo: Vec3L<R>) -> Vec3L<R> {
        self.coat_normal * (wo.dot(self.coat_normal) * 2.0) - wo
    }

    /// The terms of outgoing direction `wo` (see [`LayerTermsLanes`]).
    #[inline(always)]
    pub fn outgoing(&self, wo: Vec3L<R>) -> LayerTermsLanes<R> {
        let (mut coat_weight, mut coat_scale) = (R::ZERO, R::ONE);
        if self.coat.any() {
            let mu = self.in_coat_frame(wo).z;
            let seen = self.coat & mu.gt(R::ZERO);
            let m = R::ONE - mu.min(R::ONE);
            let m2 = m * m;
            let fresnel = (R::splat(1.0 - COAT_F0) * m2 * m2 * m) + COAT_F0;
            coat_weight = R::select(seen, self.coat_weight * fresnel, R::ZERO);
            if self.base.energy_compensation {
                let row = AlbedoRowLanes::new(self.coat_alpha);
                let e = AlbedoTable::get().e_and_e_s_lanes(mu, row).0;
                let rough = seen & !self.coat_smooth();
                coat_scale = R::select(rough, e.max(R::splat(1e-3)).recip(), R::ONE);
            }
        }
        let (mut sheen_take, mut sheen_share) = (R::ZERO, R::ZERO);
        if self.sheen.any() {
            let e = SheenTable::get().e_lanes(wo.z, self.sheen_roughness);
            let seen = self.sheen & wo.z.gt(R::ZERO);
            sheen_take = R::select(seen, self.sheen_color.max_element() * e, R::ZERO);
            sheen_share = R::select(seen, luminance_lanes(self.sheen_color) * e, R::ZERO);
        }
        let below = R::ONE - coat_weight;
        let w_sheen = below * sheen_share;
        let w_base = below * (R::ONE - sheen_take).max(R::ZERO) * self.base.sampling_albedo(wo);
        let total = coat_weight + w_sheen + w_base;
        let some = total.gt(R::ZERO);
        LayerTermsLanes {
            base: self.base.outgoing(wo),
            coat_weight,
            coat_scale,
            sheen_take,
            p_coat: R::select(some, coat_weight / total, R::ZERO),
            p_sheen: R::select(some, w_sheen / total, R::ZERO),
        }
    }

    /// The sheen's albedo scaling of the base between wo (its take `take_o`) and wi: 1 on
    /// lanes without a sheen.
    #[inline(always)]
    fn sheen_scaling(&self, take_o: R, wi: Vec3L<R>) -> R {
        if self.sheen.none() {
            return R::ONE;
        }
        let e = SheenTable::get().e_lanes(wi.z, self.sheen_roughness);
        let take_i = self.sheen_color.max_element() * e;
        R::select(
            self.sheen,
            (R::ONE - take_o.max(take_i)).max(R::ZERO),
            R::ONE,
        )
    }

    /// The rough coat lobe's f·cos (to n_c, scaled) and pdf at local `wo`, `wi`: zero on
    /// lanes without a rough coat, below the coat, or where f32 overflows.
    #[inline(always)]
    fn coat_lobe(&self, t: &LayerTermsLanes<R>, wo: Vec3L<R>, wi: Vec3L<R>) -> (R, R) {
        let rough = self.coat & !self.coat_smooth();
        if rough.none() {
            return (R::ZERO, R::ZERO);
        }
        let (wo_c, wi_c) = (self.in_coat_frame(wo), self.in_coat_frame(wi));
        let alpha = self.coat_alpha;
        let h = (wo_c + wi_c).normalize();
        let d = ggx_d(alpha, h);
        let value = d * ggx_v(alpha, wo_c, wi_c) * wi_c.z * t.coat_scale;
        let pdf = ggx_g1(alpha, wo_c) * d / (wo_c.z * 4.0);
        let inf = R::splat(f32::INFINITY);
        let ok = rough
            & wo_c.z.gt(R::ZERO)
            & wi_c.z.gt(R::ZERO)
            & value.abs().lt(inf)
            & pdf.abs().lt(inf);
        (R::select(ok, value, R::ZERO), R::select(ok, pdf, R::ZERO))
    }

    /// f(wo, wi)·cos θi and the mixture's density of `wi`, the delta lobes left out, given
    /// wo's terms `t`. Zero where wo or wi is below the surface.
    #[inline(always)]
    pub fn eval_pdf(&self, t: &LayerTermsLanes<R>, wo: Vec3L<R>, wi: Vec3L<R>) -> (Vec3L<R>, R) {
        let (f_base, pdf_base) = self.base.eval_pdf(&t.base, wo, wi);
        let mut below = f_base * self.sheen_scaling(t.sheen_take, wi);
        let mut pdf_sheen = R::ZERO;
        if self.sheen.any() {
            let sheen = self.sheen_color * white_sheen(wo, wi, self.sheen_roughness);
            below = Vec3L::select(self.sheen, below + sheen, below);
            pdf_sheen = R::select(self.sheen, wi.z * FRAC_1_PI, R::ZERO);
        }
        let (f_coat, pdf_coat) = self.coat_lobe(t, wo, wi);
        let f = below * (R::ONE - t.coat_weight) + Vec3L::all(t.coat_weight * f_coat);
        let p_base = R::ONE - t.p_coat - t.p_sheen;
        let pdf = t.p_coat * pdf_coat + t.p_sheen * pdf_sheen + p_base * pdf_base;
        let above = wo.z.gt(R::ZERO) & wi.z.gt(R::ZERO);
        (
            Vec3L::select(above, f, Vec3L::all(R::ZERO)),
            R::select(above, pdf, R::ZERO),
        )
    }

    /// A direction and the lobe it comes from: the layer chosen with the lobe number `uc`,
    /// the direction from `u` (the coat's visible normals around n_c or its mirror, the
    /// cosine for the sheen, the base's own sampling). Not valid where wo is below the
    /// surface or the direction falls below it or below the coat.
    #[inline(always)]
    pub fn sample_direction(
        &self,
        t: &LayerTermsLanes<R>,
        wo: Vec3L<R>,
        uc: R,
        u: Vec2L<R>,
    ) -> DirectionLanes<R> {
        let coat = uc.lt(t.p_coat);
        let drawn = select_lazy!(
            coat,
            self.sample_coat(wo, u),
            select_lazy!(
                uc.lt(t.p_coat + t.p_sheen),
                DirectionLanes {
                    wi: cosine_hemisphere(u),
                    flags: R::Bits::splat(BsdfFlags::GLOSSY_REFLECTION.bits()),
                    valid: R::Mask::splat(true),
                },
                self.base.sample_direction(&t.base, wo, u),
                DirectionLanes::select
            ),
            DirectionLanes::select
        );
        DirectionLanes {
            valid: drawn.valid & wo.z.gt(R::ZERO),
            ..drawn
        }
    }

    /// The coat's direction from `u`: its mirror where smooth, else `wo` reflected about a
    /// visible normal in the coat's frame; valid above both the coat and the surface.
    #[inline(always)]
    fn sample_coat(&self, wo: Vec3L<R>, u: Vec2L<R>) -> DirectionLanes<R> {
        let drawn = select_lazy!(
            self.coat_smooth(),
            DirectionLanes {
                wi: self.coat_mirror(wo),
                flags: R::Bits::splat(BsdfFlags::SPECULAR_REFLECTION.bits()),
                valid: R::Mask::splat(true),
            },
            {
                let wo_c = self.in_coat_frame(wo);
                let h = visible_normal(self.coat_alpha, self.coat_alpha, wo_c, u);
                let wi_c = h * (wo_c.dot(h) * 2.0) - wo_c;
                DirectionLanes {
                    wi: self.out_of_coat_frame(wi_c),
                    flags: R::Bits::splat(BsdfFlags::GLOSSY_REFLECTION.bits()),
                    valid: wi_c.z.gt(R::ZERO),
                }
            },
            DirectionLanes::select
        );
        DirectionLanes {
            valid: drawn.valid & drawn.wi.z.gt(R::ZERO) & self.coat,
            ..drawn
        }
    }

    /// The delta lobes' weight and probability in direction `wi`: the smooth coat's mirror
    /// (weight c·Fc, probability of choosing the coat) and the smooth base's (its weight under
    /// the layers, its probability within the base's), summed where both mirror wo to `wi`
    /// (a coat whose normal is the base's). Valid where the probability is positive.
    #[inline(always)]
    pub fn sample_delta(
        &self,
        t: &LayerTermsLanes<R>,
        wo: Vec3L<R>,
        wi: Vec3L<R>,
    ) -> (Vec3L<R>, R, R::Mask) {
        let near = R::splat(1e-12);
        let coat = self.coat_smooth() & (self.coat_mirror(wo) - wi).length_squared().lt(near);
        let f_coat = R::select(coat, t.coat_weight, R::ZERO);
        let pdf_coat = R::select(coat, t.p_coat, R::ZERO);
        let base_mirror = Vec3L::new(-wo.x, -wo.y, wo.z);
        let base = (base_mirror - wi).length_squared().lt(near) & t.base.p_specular.gt(R::ZERO);
        let below = (R::ONE - t.coat_weight) * self.sheen_scaling(t.sheen_take, wi);
        let f_base = self.base.specular_fresnel(wo.z) * below;
        let pdf_base = (R::ONE - t.p_coat - t.p_sheen) * t.base.p_specular;
        let zero = Vec3L::all(R::ZERO);
        let f_cos = Vec3L::all(f_coat) + Vec3L::select(base, f_base, zero);
        let pdf = pdf_coat + R::select(base, pdf_base, R::ZERO);
        (f_cos, pdf, pdf.gt(R::ZERO))
    }

    /// The lobes each lane has ([`BsdfFlags::bits`]).
    #[inline(always)]
    pub fn flags(&self) -> R::Bits {
        let none = R::Bits::splat(0);
        let glossy = R::Bits::splat(BsdfFlags::GLOSSY_REFLECTION.bits());
        let specular = R::Bits::splat(BsdfFlags::SPECULAR_REFLECTION.bits());
        let sheen = R::Bits::select(self.sheen, glossy, none);
        let coat = R::Bits::select(
            self.coat,
            R::Bits::select(self.coat_smooth(), specular, glossy),
            none,
        );
        self.base.flags() | sheen | coat
    }
}

/// The glTF BRDF with a sheen and a clear coat over it (either may be absent): see the module
/// documentation. [`LayeredLanes`] at one lane, with the terms of the one wo a path
/// evaluates it at kept.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layered {
    pub base: GltfBrdf,
    pub sheen: Option<Sheen>,
    pub coat: Option<Coat>,
    /// The terms of wo, for the one they were computed at ([`LocalBsdf::at`]).
    outgoing: Option<(Vec3, LayerTermsLanes<f32>)>,
}

impl Layered {
    pub fn new(base: GltfBrdf, sheen: Option<Sheen>, coat: Option<Coat>) -> Layered {
        Layered {
            base,
            sheen,
            coat,
            outgoing: None,
        }
    }

    /// The layers as lanes of one.
    #[inline(always)]
    pub fn lanes(&self) -> LayeredLanes<f32> {
        let sheen = self.sheen.unwrap_or(Sheen {
            color: Vec3::ZERO,
            roughness: 1.0,
        });
        let coat = self.coat.unwrap_or(Coat {
            weight: 0.0,
            alpha: 1.0,
            normal: Vec3::Z,
            upright: true,
        });
        LayeredLanes {
            base: *self.base.lanes(),
            sheen: self.sheen.is_some(),
            sheen_color: sheen.color.into(),
            sheen_roughness: sheen.roughness,
            coat: self.coat.is_some(),
            coat_weight: coat.weight,
            coat_alpha: coat.alpha,
            coat_normal: coat.normal.into(),
            coat_upright: coat.upright,
        }
    }

    #[inline]
    fn terms(&self, wo: Vec3) -> LayerTermsLanes<f32> {
        match self.outgoing {
            Some((at, t)) if at == wo => t,
            _ => self.lanes().outgoing(wo.into()),
        }
    }
}

impl LocalBsdf for Layered {
    #[inline(always)]
    fn depends_on_cos_theta_only(&self) -> bool {
        false
    }

    #[inline]
    fn at(self, wo: Vec3) -> Layered {
        // The base's terms of wo are among the layers' (`LayerTermsLanes::base`): its own
        // cache would go unread.
        Layered {
            outgoing: Some((wo, self.lanes().outgoing(wo.into()))),
            ..self
        }
    }

    fn flags(&self) -> BsdfFlags {
        BsdfFlags::from_bits(self.lanes().flags())
    }

    #[inline]
    fn albedo(&self) -> Vec3 {
        self.base.base_color()
    }

    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.eval_pdf(wo, wi).0
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_pdf(wo, wi).1
    }

    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let (f, pdf) = self.lanes().eval_pdf(&self.terms(wo), wo.into(), wi.into());
        (f.into(), pdf)
    }

    #[inline(always)]
    fn reads_lobe_number(&self) -> bool {
        true
    }

    fn sample_direction(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<(Vec3, BsdfFlags)> {
        if wo.z <= 0.0 {
            return None;
        }
        let d = self
            .lanes()
            .sample_direction(&self.terms(wo), wo.into(), uc, u.into());
        d.valid
            .then(|| (d.wi.into(), BsdfFlags::from_bits(d.flags)))
    }

    /// The delta lobes' sample in direction `wi` ([`LayeredLanes::sample_delta`]).
    fn sample_delta(&self, wo: Vec3, wi: Vec3, flags: BsdfFlags) -> Option<BsdfSample> {
        let (f_cos, pdf, valid) = self
            .lanes()
            .sample_delta(&self.terms(wo), wo.into(), wi.into());
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

    /// Lane `i`'s layers from the width test's inputs, by the one-lane builders: a base,
    /// a sheen on some lanes, a coat (smooth, rough, tilted or upright) on others.
    fn layers<R: Real>(x: &[R; 22], i: usize) -> LayeredLanes<f32> {
        let v = |k: usize| x[k].lane(i);
        let mut base = GltfBrdf::new(Vec3::new(v(0), v(1), v(2)), v(3), v(4));
        if v(21) >= 0.5 {
            base = base.single_scattering();
        }
        let sheen = (v(5) < 0.5).then(|| Sheen::new(Vec3::new(v(6), v(7), v(8)), v(9)));
        let coat = (v(10) < 0.6).then(|| {
            let tilt = Vec3::new(v(12) - 0.5, v(13) - 0.5, 1.0).normalize();
            let normal = if v(10) < 0.3 { Vec3::Z } else { tilt };
            let roughness = if v(10) < 0.1 { 0.0 } else { v(11) };
            Coat::new(v(14), roughness, normal)
        });
        Layered::new(base, sheen, coat).lanes()
    }

    /// Every value the layers give for lane inputs `x` (see [`layers`], then wo, wi, uc and
    /// u): the terms of wo, f·cos and pdf, the drawn direction, its lobe and validity, the
    /// delta lobes' weight toward it, and the lobes.
    #[inline(always)]
    fn kernel<R: Real>(x: [R; 22]) -> [R; 16] {
        let lanes = [0usize, 1, 2, 3, 4, 5, 6, 7];
        let one: [LayeredLanes<f32>; 8] = lanes.map(|i| layers(&x, i.min(R::LANES - 1)));
        let pick = |f: &dyn Fn(&LayeredLanes<f32>) -> f32| R::from_fn(|i| f(&one[i]));
        let pick3 =
            |f: &dyn Fn(&LayeredLanes<f32>) -> Vec3L<f32>| Vec3L::from_fn(|i| f(&one[i]).into());
        let l = LayeredLanes::<R> {
            base: GltfBrdfLanes::from_fn(|i| one[i].base),
            sheen: R::Mask::from_fn(|i| one[i].sheen),
            sheen_color: pick3(&|b| b.sheen_color),
            sheen_roughness: pick(&|b| b.sheen_roughness),
            coat: R::Mask::from_fn(|i| one[i].coat),
            coat_weight: pick(&|b| b.coat_weight),
            coat_alpha: pick(&|b| b.coat_alpha),
            coat_normal: pick3(&|b| b.coat_normal),
            coat_upright: R::Mask::from_fn(|i| one[i].coat_upright),
        };
        let d = |a: R, b: R| {
            let z = a * 2.0 - 1.0;
            let r = (R::ONE - z * z).safe_sqrt();
            let (s, c) = math::sin_cos(b * std::f32::consts::TAU);
            Vec3L::new(r * c, r * s, z)
        };
        let (wo, wi) = (d(x[15], x[16]), d(x[17], x[18]));
        let t = l.outgoing(wo);
        let (f, pdf) = l.eval_pdf(&t, wo, wi);
        let s = l.sample_direction(&t, wo, x[19], Vec2L::new(x[20], x[16]));
        let wi_s = Vec3L::select(s.valid, s.wi, Vec3L::new(R::ZERO, R::ZERO, R::ONE));
        let (f_d, pdf_d, valid_d) = l.sample_delta(&t, wo, wi_s);
        let flag = |m: R::Mask| R::select(m, R::ONE, R::ZERO);
        [
            t.coat_weight,
            t.coat_scale,
            t.sheen_take,
            t.p_coat,
            t.p_sheen,
            f.x,
            f.z,
            pdf,
            wi_s.x,
            wi_s.z,
            R::from_bits(R::Bits::select(s.valid, s.flags, R::Bits::splat(0))),
            flag(s.valid),
            f_d.y,
            pdf_d,
            flag(valid_d),
            R::from_bits(l.flags()),
        ]
    }

    fn inputs() -> Vec<[f32; 22]> {
        let mut next = crate::sampling::hash::uniform_sequence(4522);
        (0..3000)
            .map(|k| {
                let mut x = [0.0f32; 22];
                for v in x.iter_mut() {
                    *v = next();
                }
                x[3] = [x[3], 0.0, 1.0][k % 3];
                x[4] = [x[4], 0.0, x[4]][k % 3];
                // Energy compensation for eight lanes in a row, then not.
                x[21] = ((k / 8) % 2) as f32;
                x
            })
            .collect()
    }

    /// The layers give the same bits at one lane and eight, in and out of the AVX2 dispatch,
    /// with lanes with and without a sheen and a coat (smooth, rough, tilted) side by side.
    #[test]
    fn the_layers_have_the_same_bits_at_every_width() {
        crate::lanes::assert_same_bits_at_every_width!(kernel: [22] -> [16], inputs(), dispatched only);
        // The inputs reach the branches: each layer on some lanes, and every lobe drawn.
        let mut lobes = std::collections::BTreeSet::new();
        let (mut sheens, mut coats, mut tilted, mut smooth) = (0, 0, 0, 0);
        for x in inputs() {
            let l = layers(&x, 0);
            sheens += l.sheen as usize;
            coats += l.coat as usize;
            tilted += (l.coat && !l.coat_upright) as usize;
            smooth += l.coat_smooth() as usize;
            let out = kernel::<f32>(x);
            if out[11] > 0.0 {
                lobes.insert(out[10].to_bits());
            }
        }
        println!("sheens {sheens}, coats {coats}, tilted {tilted}, smooth {smooth}, {lobes:?}");
        assert!(sheens > 500 && coats > 500 && tilted > 300 && smooth > 100);
        assert_eq!(lobes.len(), 3, "diffuse, glossy and specular drawn");
    }

    /// The sheen table against the same integral on a four-times finer grid, between grid
    /// points and at them: within 1% (0.4% measured; 1e-4 absolute where E_s < 0.01).
    #[test]
    fn the_sheen_table_is_the_integral_it_tabulates() {
        let table = SheenTable::get();
        let mut worst = 0.0f64;
        for &r in &[SHEEN_MIN_ROUGHNESS, 0.1, 0.3, 0.62, 1.0] {
            for &mu in &[0.02f32, 0.05, 0.1, 0.3, 0.7, 1.0] {
                let fine = directional_albedo(mu, r, 256);
                let got = table.e(mu, r) as f64;
                worst = worst.max((got - fine).abs() / fine.max(0.01));
            }
        }
        assert!(worst < 0.01, "the table is {worst} off");
    }

    /// The white sheen lobe returns less than it receives, more at grazing angles and for
    /// rougher fibres (the look of velvet): E_s(μ) ≤ 1, E_s(0.1) > E_s(1), and E_s grows
    /// with r at normal incidence.
    #[test]
    fn the_sheen_lobe_is_brighter_at_grazing_angles_and_never_gains_energy() {
        let table = SheenTable::get();
        for j in 0..SheenTable::N_R {
            let r = SheenTable::r_at(j);
            for i in 0..SheenTable::N_MU {
                let mu = i as f32 / (SheenTable::N_MU - 1) as f32;
                let e = table.e(mu, r);
                assert!((0.0..=1.0).contains(&e), "r {r} μ {mu}: {e}");
            }
            if r > 0.2 {
                assert!(table.e(0.1, r) > table.e(1.0, r), "r {r}");
            }
        }
        assert!(table.e(1.0, 1.0) > table.e(1.0, 0.3));
    }

    /// A smooth coat over a smooth base with the same normal: one mirror direction, whose
    /// weight is the coat's c·Fc plus the base's Fresnel under it.
    #[test]
    fn a_smooth_coat_and_a_smooth_base_share_their_mirror() {
        let base = GltfBrdf::new(Vec3::splat(0.5), 1.0, 0.0);
        let coat = Coat::new(1.0, 0.0, Vec3::Z);
        let b = Layered::new(base, None, Some(coat));
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let mirror = Vec3::new(-0.6, 0.0, 0.8);
        let fc = COAT_F0 + (1.0 - COAT_F0) * 0.2f32.powi(5);
        let f_base = 0.5 + 0.5 * 0.2f32.powi(5);
        let s = b.sample(wo, 0.0, Vec2::splat(0.5)).unwrap();
        assert!((s.wi - mirror).length() < 1e-6);
        assert!(s.flags.is_specular());
        let expected = fc + (1.0 - fc) * f_base;
        assert!(
            (s.f_cos.x - expected).abs() < 1e-5,
            "{s:?} against {expected}"
        );
        // Both lobes were summed: the probability is the whole delta share (1: every lobe here
        // is the mirror).
        assert!((s.pdf - 1.0).abs() < 1e-5, "{s:?}");
    }

    /// A tilted coat normal: the smooth coat mirrors wo about n_c, not about +z.
    #[test]
    fn a_tilted_coat_mirrors_about_its_own_normal() {
        let n = Vec3::new(0.2, 0.0, 1.0).normalize();
        let base = GltfBrdf::new(Vec3::splat(0.5), 0.0, 0.8);
        let b = Layered::new(base, None, Some(Coat::new(1.0, 0.0, n)));
        let wo = Vec3::new(-0.3, 0.1, 0.95).normalize();
        let s = b.sample(wo, 0.0, Vec2::splat(0.5)).unwrap();
        let expected = 2.0 * wo.dot(n) * n - wo;
        assert!(
            (s.wi - expected).length() < 1e-5,
            "{} against {expected}",
            s.wi
        );
        let fc = COAT_F0 + (1.0 - COAT_F0) * (1.0 - wo.dot(n)).powi(5);
        assert!((s.f_cos.x - fc).abs() < 1e-5, "{s:?} against {fc}");
    }
}
