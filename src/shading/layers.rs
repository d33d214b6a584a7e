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

use super::gltf_brdf::GltfBrdf;
use super::lobe::{BsdfFlags, BsdfSample, LocalBsdf};
use super::microfacet::{AlbedoTable, Ggx};
use super::spectrum::luminance;
use crate::sampling::warps::square_to_cosine_hemisphere;
use crate::sampling::Onb;

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

    fn ggx(&self) -> Ggx {
        Ggx::new(self.alpha)
    }

    /// A local direction in the coat's frame (built where it is needed: kept, it would more
    /// than double the size of every [`super::Bsdf`]).
    #[inline]
    fn in_coat_frame(&self, w: Vec3) -> Vec3 {
        match self.upright {
            true => w,
            false => Onb::from_normal(self.normal).to_local(w),
        }
    }

    #[inline]
    fn out_of_coat_frame(&self, w: Vec3) -> Vec3 {
        match self.upright {
            true => w,
            false => Onb::from_normal(self.normal).to_world(w),
        }
    }

    /// The mirror of `wo` about n_c.
    #[inline]
    fn mirror(&self, wo: Vec3) -> Vec3 {
        2.0 * wo.dot(self.normal) * self.normal - wo
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
        white_sheen(wo, wi, self.roughness)
    }
}

/// The Charlie distribution D_s(h) = (2 + 1/r) sin(θh)^(1/r) / 2π (Conty Estevez & Kulla
/// 2017, eq. 2), from cos θh.
#[inline]
fn charlie_d(cos_h: f32, r: f32) -> f32 {
    let inv_r = 1.0 / r;
    let sin2 = (1.0 - cos_h * cos_h).max(0.0);
    (2.0 + inv_r) * sin2.powf(0.5 * inv_r) * (0.5 * std::f32::consts::FRAC_1_PI)
}

/// Conty Estevez & Kulla's fit of the Charlie lobe's Λ (2017, Table 1 and eq. 3–4, as
/// KHR_materials_sheen reprints it): L(x) = a / (1 + b x^c) + d x + e, its coefficients
/// interpolated in (1 − r)², and Λ(μ) = exp(L(μ)) for μ < ½, exp(2 L(½) − L(1 − μ)) above.
#[inline]
fn charlie_lambda(mu: f32, r: f32) -> f32 {
    let t = (1.0 - r) * (1.0 - r);
    let lerp = |a: f32, b: f32| a + (b - a) * t;
    let (a, b, c) = (
        lerp(21.5473, 25.3245),
        lerp(3.82987, 3.32435),
        lerp(0.19823, 0.16801),
    );
    let (d, e) = (lerp(-1.97760, -1.27393), lerp(-4.32054, -4.85967));
    let l = |x: f32| a / (1.0 + b * x.powf(c)) + d * x + e;
    match mu < 0.5 {
        true => l(mu).exp(),
        false => (2.0 * l(0.5) - l(1.0 - mu)).exp(),
    }
}

/// The white sheen lobe's f·cos θi (see [`Sheen::white_lobe`]); zero unless both directions
/// are above the surface.
#[inline]
fn white_sheen(wo: Vec3, wi: Vec3, r: f32) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let h = (wo + wi).normalize();
    let g = 1.0 / (1.0 + charlie_lambda(wo.z, r) + charlie_lambda(wi.z, r));
    let value = charlie_d(h.z, r) * g / (4.0 * wo.z);
    match value.is_finite() {
        true => value,
        false => 0.0,
    }
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
        let (n_mu, n_r) = (Self::N_MU, Self::N_R);
        let x = mu.clamp(0.0, 1.0).sqrt() * (n_mu - 1) as f32;
        let y = ((r - SHEEN_MIN_ROUGHNESS) / (1.0 - SHEEN_MIN_ROUGHNESS)).clamp(0.0, 1.0)
            * (n_r - 1) as f32;
        let (x0, y0) = ((x as usize).min(n_mu - 2), (y as usize).min(n_r - 2));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let at = |i: usize, j: usize| self.e[j * n_mu + i];
        let low = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
        let high = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
        low * (1.0 - fy) + high * fy
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
            sum += white_sheen(wo, wi, r) as f64 * theta.sin();
        }
    }
    2.0 * sum * d_theta * d_phi
}

/// The glTF BRDF with a sheen and a clear coat over it (either may be absent): see the module
/// documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layered {
    pub base: GltfBrdf,
    pub sheen: Option<Sheen>,
    pub coat: Option<Coat>,
    /// The terms of wo, for the one they were computed at ([`LocalBsdf::at`]).
    outgoing: Option<LayerTerms>,
}

/// What the layers read of wo alone.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LayerTerms {
    wo: Vec3,
    /// c·Fc(|wo·n_c|): the coat's share.
    coat_weight: f32,
    /// The coat lobe's scale: 1 / E(wo·n_c) with energy compensation, else 1.
    coat_scale: f32,
    /// max(sheenColor) E_s(μo): what the sheen takes from the base seen from wo.
    sheen_take: f32,
    /// The probabilities of sampling the coat and the sheen (the base takes the rest).
    p_coat: f32,
    p_sheen: f32,
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

    #[inline]
    fn terms(&self, wo: Vec3) -> LayerTerms {
        match self.outgoing {
            Some(t) if t.wo == wo => t,
            _ => self.outgoing_terms(wo),
        }
    }

    fn outgoing_terms(&self, wo: Vec3) -> LayerTerms {
        let (mut coat_weight, mut coat_scale) = (0.0, 1.0);
        if let Some(coat) = &self.coat {
            let mu = coat.in_coat_frame(wo).z;
            if mu > 0.0 {
                let m = 1.0 - mu.min(1.0);
                let m2 = m * m;
                coat_weight = coat.weight * (COAT_F0 + (1.0 - COAT_F0) * m2 * m2 * m);
                if self.base.lanes().energy_compensation && !coat.ggx().is_smooth() {
                    coat_scale = 1.0 / AlbedoTable::get().e(mu, coat.alpha).max(1e-3);
                }
            }
        }
        let (sheen_take, sheen_share) = match &self.sheen {
            Some(s) if wo.z > 0.0 => {
                let e = SheenTable::get().e(wo.z, s.roughness);
                (s.color.max_element() * e, luminance(s.color) * e)
            }
            _ => (0.0, 0.0),
        };
        let below = 1.0 - coat_weight;
        let w_sheen = below * sheen_share;
        let w_base = below * (1.0 - sheen_take).max(0.0) * self.base.sampling_albedo(wo);
        let total = coat_weight + w_sheen + w_base;
        let (p_coat, p_sheen) = match total > 0.0 {
            true => (coat_weight / total, w_sheen / total),
            false => (0.0, 0.0),
        };
        LayerTerms {
            wo,
            coat_weight,
            coat_scale,
            sheen_take,
            p_coat,
            p_sheen,
        }
    }

    /// The sheen's albedo scaling of the base between wo (its take `take_o`) and wi.
    #[inline]
    fn sheen_scaling(&self, take_o: f32, wi: Vec3) -> f32 {
        match &self.sheen {
            None => 1.0,
            Some(s) => {
                let take_i = s.color.max_element() * SheenTable::get().e(wi.z, s.roughness);
                (1.0 - take_o.max(take_i)).max(0.0)
            }
        }
    }

    /// The rough coat lobe's f·cos (to n_c, scaled) and pdf at local `wo`, `wi`.
    #[inline]
    fn coat_lobe(&self, coat: &Coat, t: &LayerTerms, wo: Vec3, wi: Vec3) -> (f32, f32) {
        let ggx = coat.ggx();
        if ggx.is_smooth() {
            return (0.0, 0.0);
        }
        let (wo_c, wi_c) = (coat.in_coat_frame(wo), coat.in_coat_frame(wi));
        if wo_c.z <= 0.0 || wi_c.z <= 0.0 {
            return (0.0, 0.0);
        }
        let h = (wo_c + wi_c).normalize();
        let d = ggx.d(h);
        let value = d * ggx.v(wo_c, wi_c) * wi_c.z * t.coat_scale;
        let pdf = ggx.reflection_pdf(wo_c, d);
        match value.is_finite() && pdf.is_finite() {
            true => (value, pdf),
            false => (0.0, 0.0),
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
        Layered {
            base: self.base.at(wo),
            outgoing: Some(self.outgoing_terms(wo)),
            ..self
        }
    }

    fn flags(&self) -> BsdfFlags {
        let mut flags = self.base.flags();
        if self.sheen.is_some() {
            flags = flags.union(BsdfFlags::GLOSSY_REFLECTION);
        }
        if let Some(coat) = &self.coat {
            flags = flags.union(match coat.ggx().is_smooth() {
                true => BsdfFlags::SPECULAR_REFLECTION,
                false => BsdfFlags::GLOSSY_REFLECTION,
            });
        }
        flags
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
        let t = self.terms(wo);
        let (f_base, pdf_base) = self.base.eval_pdf(wo, wi);
        let mut below = f_base * self.sheen_scaling(t.sheen_take, wi);
        let mut pdf_sheen = 0.0;
        if let Some(s) = &self.sheen {
            below += s.color * s.white_lobe(wo, wi);
            pdf_sheen = wi.z * std::f32::consts::FRAC_1_PI;
        }
        let (f_coat, pdf_coat) = match &self.coat {
            Some(coat) => self.coat_lobe(coat, &t, wo, wi),
            None => (0.0, 0.0),
        };
        let f = below * (1.0 - t.coat_weight) + Vec3::splat(t.coat_weight * f_coat);
        let p_base = 1.0 - t.p_coat - t.p_sheen;
        let pdf = t.p_coat * pdf_coat + t.p_sheen * pdf_sheen + p_base * pdf_base;
        (f, pdf)
    }

    #[inline(always)]
    fn reads_lobe_number(&self) -> bool {
        true
    }

    fn sample_direction(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<(Vec3, BsdfFlags)> {
        if wo.z <= 0.0 {
            return None;
        }
        let t = self.terms(wo);
        if uc < t.p_coat {
            let coat = self.coat.as_ref()?;
            let ggx = coat.ggx();
            let (wi, flags) = match ggx.is_smooth() {
                true => (coat.mirror(wo), BsdfFlags::SPECULAR_REFLECTION),
                false => {
                    let wo_c = coat.in_coat_frame(wo);
                    let h = ggx.sample_visible_normal(wo_c, u);
                    let wi_c = 2.0 * wo_c.dot(h) * h - wo_c;
                    if wi_c.z <= 0.0 {
                        return None;
                    }
                    (coat.out_of_coat_frame(wi_c), BsdfFlags::GLOSSY_REFLECTION)
                }
            };
            return (wi.z > 0.0).then_some((wi, flags));
        }
        if uc < t.p_coat + t.p_sheen {
            let wi = square_to_cosine_hemisphere(u);
            return Some((wi, BsdfFlags::GLOSSY_REFLECTION));
        }
        self.base.sample_direction(wo, u)
    }

    /// The delta lobes' sample in direction `wi`: the smooth coat's mirror (weight c·Fc,
    /// probability of choosing the coat) and the smooth base's (its weight under the layers,
    /// its probability within the base's), summed where both mirror wo to `wi` (a coat whose
    /// normal is the base's).
    fn sample_delta(&self, wo: Vec3, wi: Vec3, flags: BsdfFlags) -> Option<BsdfSample> {
        let t = self.terms(wo);
        let (mut f_cos, mut pdf) = (Vec3::ZERO, 0.0);
        if let Some(coat) = &self.coat {
            if coat.ggx().is_smooth() && (coat.mirror(wo) - wi).length_squared() < 1e-12 {
                f_cos += Vec3::splat(t.coat_weight);
                pdf += t.p_coat;
            }
        }
        let base_mirror = Vec3::new(-wo.x, -wo.y, wo.z);
        if (base_mirror - wi).length_squared() < 1e-12 {
            if let Some(b) = self.base.sample_delta(wo, wi, flags) {
                let below = (1.0 - t.coat_weight) * self.sheen_scaling(t.sheen_take, wi);
                f_cos += b.f_cos * below;
                pdf += (1.0 - t.p_coat - t.p_sheen) * b.pdf;
            }
        }
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
