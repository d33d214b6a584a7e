//! Ground truth for multiple scattering on a rough metal, and strata's energy compensation
//! measured against it.
//!
//! The truth is a Monte Carlo random walk on the Smith microsurface, as Heitz, Hanika, d'Eon
//! and Dachsbacher define it ("Multiple-Scattering Microfacet BSDFs with the Smith Model",
//! ACM TOG 35(4), SIGGRAPH 2016): the microsurface is a volume-like medium of facets whose
//! heights and normals are uncorrelated. A ray that enters it travels until it meets a facet
//! at a height drawn from the paper's height-space free-path distribution, reflects off a
//! normal drawn from the facets visible to it (the conductor's phase function), carries
//! Fresnel's factor of that one reflection, and continues until it leaves. Its first
//! bounce alone is the Smith single-scattering BRDF with the height-correlated G2 that glTF
//! uses; the rest is what single scattering loses. Everything here is written for this
//! file in f64 and shares no code with strata's BRDF: only strata's results (the BSDF's
//! sample weights and its albedo table) are read.
//!
//! The table of directional albedos that docs/khronos.md quotes comes from
//!
//!     cargo test --release --test multiple_scattering -- --ignored --nocapture
//!
//! (about a minute on one core).

use glam::{DVec3, Vec2, Vec3};
use strata::shading::microfacet::AlbedoTable;
use strata::shading::{Bsdf, GltfBrdf, LocalBsdf};

/// SplitMix64 (Steele, Lea & Flood 2014): a small generator with good equidistribution,
/// enough for a million independent walks.
struct Rng(u64);

impl Rng {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        // 53 random bits in [0, 1).
        (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Schlick's Fresnel of reflectance `f0` at cosine `cos`.
fn schlick(f0: f64, cos: f64) -> f64 {
    f0 + (1.0 - f0) * (1.0 - cos.clamp(0.0, 1.0)).powi(5)
}

/// The GGX microsurface of roughness α (isotropic), seen as the paper's random medium.
#[derive(Clone, Copy)]
struct Microsurface {
    alpha: f64,
}

/// How one walk ended: the number of reflections, the direction it left in, and its weight
/// (the product of each reflection's Fresnel factor) for each reflectance asked for. `order`
/// 0 means the walk was abandoned (it never left within the cap, or a direction was not
/// finite).
struct WalkEnd<const N: usize> {
    order: u32,
    wi: DVec3,
    weight: [f64; N],
}

impl Microsurface {
    /// The longest walk followed; the probability of more reflections is negligible for
    /// metals (it is counted, and the tests require it to be rare).
    const MAX_ORDER: u32 = 256;

    /// Smith's Λ of GGX for a direction `w` with the sign the walk needs: for an upward
    /// direction Λ(w) = (√(1 + α² tan²θ) − 1) / 2; for a downward one −1 − Λ(−w), whose
    /// magnitude 1 + Λ(−w) measures the facets a descending ray meets.
    fn lambda(&self, w: DVec3) -> f64 {
        let c = w.z.abs();
        let tan2 = (1.0 - c * c).max(0.0) / (c * c);
        let up = ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0) / 2.0;
        match w.z >= 0.0 {
            true => up,
            false => -1.0 - up,
        }
    }

    /// The height at which a ray at height `c` travelling in direction `w` meets the
    /// microsurface next, None when it leaves. Heights are uniform on [−1, 1] and held as
    /// their cumulative distribution C1(h) ∈ (0, 1] (the result does not depend on the height
    /// distribution). Going up, the ray escapes with probability G1(w, h) = C1(h)^Λ(w) and
    /// otherwise stops where C1 = C1(h) / (1 − u)^(1/Λ(w)); going down it always stops, at
    /// C1 = C1(h) (1 − u)^(1/(1 + Λ(−w))): the free-path distribution in height of the paper.
    fn next_height(&self, w: DVec3, c: f64, u: f64) -> Option<f64> {
        if w.z.abs() < 1e-12 {
            // A ray along the plane meets a facet at once.
            return Some(c);
        }
        let lambda = self.lambda(w);
        if w.z > 0.0 {
            if lambda <= 0.0 {
                return None;
            }
            let escape = c.powf(lambda);
            if u >= 1.0 - escape {
                return None;
            }
            Some((c / (1.0 - u).powf(1.0 / lambda)).min(1.0))
        } else {
            Some(c * (1.0 - u).powf(-1.0 / lambda))
        }
    }

    /// A microfacet normal drawn from the facets visible from `v` (pointing away from the
    /// surface toward where the ray came from, possibly below the macro-surface's horizon),
    /// with density ⟨v·m⟩ D(m) / (projected area): stretched to α = 1, where the facets are
    /// those of a hemisphere, a normal is the half vector between `v` and a point uniform on
    /// the sphere's cap above height −v.z (Dupuy & Benyoub 2023, "Sampling Visible GGX
    /// Normals with Spherical Caps", which holds for directions below the horizon too); then
    /// unstretched.
    fn visible_normal(&self, v: DVec3, u1: f64, u2: f64) -> DVec3 {
        let a = self.alpha;
        let vs = DVec3::new(a * v.x, a * v.y, v.z).normalize();
        let phi = std::f64::consts::TAU * u1;
        let z = (1.0 - u2) * (1.0 + vs.z) - vs.z;
        let s = (1.0 - z * z).max(0.0).sqrt();
        let h = DVec3::new(s * phi.cos(), s * phi.sin(), z) + vs;
        DVec3::new(a * h.x, a * h.y, h.z.max(0.0)).normalize()
    }

    /// One walk entering from direction `wo` (toward the viewer, above the surface), with
    /// Fresnel weights for each reflectance of `f0`.
    fn walk<const N: usize>(&self, wo: DVec3, f0: [f64; N], rng: &mut Rng) -> WalkEnd<N> {
        let abandoned = WalkEnd {
            order: 0,
            wi: DVec3::ZERO,
            weight: [0.0; N],
        };
        // The ray's direction of travel, and its height (as C1) starting above every facet.
        let mut w = -wo;
        let mut c = 1.0;
        let mut weight = [1.0; N];
        for order in 0..=Self::MAX_ORDER {
            // Find the next facet, or leave.
            match self.next_height(w, c, rng.next_f64()) {
                None => {
                    return WalkEnd {
                        order,
                        wi: w,
                        weight,
                    }
                }
                Some(next) => c = next,
            }
            if order == Self::MAX_ORDER {
                break;
            }
            // Reflect off a visible facet: the conductor's phase function, weighted by F.
            let v = -w;
            let m = self.visible_normal(v, rng.next_f64(), rng.next_f64());
            let cos = v.dot(m);
            for (k, f) in f0.iter().enumerate() {
                weight[k] *= schlick(*f, cos);
            }
            w = 2.0 * cos * m - v;
            if !w.is_finite() || !c.is_finite() || c <= 0.0 {
                return abandoned;
            }
        }
        abandoned
    }
}

/// The direction of cosine `mu` in the x-z plane.
fn direction(mu: f64) -> DVec3 {
    DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

/// The random walk's directional albedo from direction cosine `mu`, for each reflectance of
/// `f0`: its mean, standard error, and the same for the first bounce alone; and the fraction
/// of walks abandoned.
struct WalkAlbedo<const N: usize> {
    total: [f64; N],
    total_se: [f64; N],
    single: [f64; N],
    single_se: [f64; N],
    abandoned: f64,
}

fn walk_albedo<const N: usize>(
    alpha: f64,
    mu: f64,
    f0: [f64; N],
    walks: usize,
    seed: u64,
) -> WalkAlbedo<N> {
    let surface = Microsurface { alpha };
    let mut rng = Rng(seed);
    let (mut sum, mut sum2) = ([0.0; N], [0.0; N]);
    let (mut single, mut single2) = ([0.0; N], [0.0; N]);
    let mut abandoned = 0usize;
    for _ in 0..walks {
        let end = surface.walk(direction(mu), f0, &mut rng);
        if end.order == 0 {
            abandoned += 1;
            continue;
        }
        for k in 0..N {
            let x = end.weight[k];
            sum[k] += x;
            sum2[k] += x * x;
            if end.order == 1 {
                single[k] += x;
                single2[k] += x * x;
            }
        }
    }
    let n = walks as f64;
    let mean_se = |s: f64, s2: f64| (s / n, ((s2 / n - (s / n).powi(2)).max(0.0) / n).sqrt());
    WalkAlbedo {
        total: std::array::from_fn(|k| mean_se(sum[k], sum2[k]).0),
        total_se: std::array::from_fn(|k| mean_se(sum[k], sum2[k]).1),
        single: std::array::from_fn(|k| mean_se(single[k], single2[k]).0),
        single_se: std::array::from_fn(|k| mean_se(single[k], single2[k]).1),
        abandoned: abandoned as f64 / n,
    }
}

/// The directional albedo ∫ f cos dωi of a strata BSDF seen from cosine `mu`: the mean of
/// its sample weights f·cos/pdf over a 256 × 256 stratified grid (as the BSDF's furnace unit
/// tests estimate it).
fn strata_albedo(bsdf: &Bsdf, mu: f64) -> f64 {
    let wo = direction(mu).as_vec3();
    let grid = 256;
    let mut sum = 0.0f64;
    for i in 0..grid {
        for j in 0..grid {
            let u = Vec2::new(
                (i as f32 + 0.5) / grid as f32,
                (j as f32 + 0.5) / grid as f32,
            );
            if let Some(s) = bsdf.sample(wo, 0.0, u) {
                sum += (s.f_cos.x / s.pdf) as f64;
            }
        }
    }
    sum / (grid * grid) as f64
}

/// A grey metal of reflectance `f0`.
fn metal(f0: f32, roughness: f32) -> GltfBrdf {
    GltfBrdf::new(Vec3::splat(f0), 1.0, roughness)
}

/// The grey metals' reflectances, roughnesses and direction cosines the table covers.
const F0: [f64; 4] = [0.2, 0.5, 0.8, 1.0];
const ROUGHNESS: [f64; 4] = [0.25, 0.5, 0.75, 1.0];
const MU: [f64; 3] = [1.0, 0.5, 0.2];

/// Turquin 2019's compensated albedo (eq. 8: the lobe scaled by 1 + f0 (1 − E) / E), from
/// strata's albedo table: E_F(μ) (1 + f0 (1 − E(μ)) / E(μ)), E_F = f0 E + (1 − f0) E_s the
/// single-scattering albedo with Schlick's F.
fn turquin_albedo(f0: f64, alpha: f64, mu: f64) -> f64 {
    let t = AlbedoTable::get();
    let (e, e_s) = (
        t.e(mu as f32, alpha as f32) as f64,
        t.e_s(mu as f32, alpha as f32) as f64,
    );
    (f0 * e + (1.0 - f0) * e_s) * (1.0 + f0 * (1.0 - e) / e)
}

/// Kulla & Conty 2017's compensated albedo (§2.2 of their course notes "Revisiting
/// Physically Based Shading at Imageworks"): E_F(μ) + F_ms (1 − E(μ)), the lobe
/// (1 − E(μo))(1 − E(μi)) / (π (1 − E_avg)) returning 1 − E(μo) and weighted by
/// F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)), F_avg = f0 + (1 − f0)/21 Schlick's
/// cosine-weighted average.
fn kulla_conty_albedo(f0: f64, alpha: f64, mu: f64) -> f64 {
    let t = AlbedoTable::get();
    let (e, e_s) = (
        t.e(mu as f32, alpha as f32) as f64,
        t.e_s(mu as f32, alpha as f32) as f64,
    );
    let e_avg = t.averages(alpha as f32)[0] as f64;
    let f_avg = f0 + (1.0 - f0) / 21.0;
    let f_ms = f_avg * f_avg * e_avg / (1.0 - f_avg * (1.0 - e_avg));
    f0 * e + (1.0 - f0) * e_s + f_ms * (1.0 - e)
}

/// Fdez-Agüera 2019's compensated albedo ("A Multiple-Scattering Microfacet Model for
/// Real-Time Image-based Lighting", JCGT 8(1), the form Blender's EEVEE and three.js use):
/// E_F(μ) + (1 − E(μ)) F_ms, F_ms = E_F(μ) F_avg / (1 − (1 − E(μ)) F_avg), Kulla & Conty's
/// series with the directional E(μ) and E_F(μ) in place of the averages.
fn fdez_aguera_albedo(f0: f64, alpha: f64, mu: f64) -> f64 {
    let t = AlbedoTable::get();
    let (e, e_s) = (
        t.e(mu as f32, alpha as f32) as f64,
        t.e_s(mu as f32, alpha as f32) as f64,
    );
    let e_f = f0 * e + (1.0 - f0) * e_s;
    let f_avg = f0 + (1.0 - f0) / 21.0;
    e_f + (1.0 - e) * e_f * f_avg / (1.0 - (1.0 - e) * f_avg)
}

/// Every walk with facets that reflect everything (f0 = 1) leaves: its albedo is 1 within
/// the noise, and hardly any walk is abandoned at the order cap. And its first bounce alone
/// is strata's single-scattering albedo with Schlick's F (the BSDF's sample weights), for
/// grey metals, within four standard errors plus the stratified estimate's 0.002.
#[test]
fn the_random_walk_conserves_energy_and_its_first_bounce_is_single_scattering() {
    let f0 = [0.2, 0.6, 1.0];
    for roughness in [0.3f64, 0.7, 1.0] {
        let alpha = roughness * roughness;
        for mu in [1.0, 0.4, 0.1] {
            let walk = walk_albedo(alpha, mu, f0, 100_000, 7);
            let what = format!("roughness {roughness} μ {mu}");
            assert!(
                walk.abandoned < 1e-4,
                "{what}: {} abandoned",
                walk.abandoned
            );
            assert!(
                (walk.total[2] - 1.0).abs() < 1e-4,
                "{what}: white albedo {}",
                walk.total[2]
            );
            for (k, f) in f0.iter().enumerate() {
                let single = metal(*f as f32, roughness as f32).single_scattering();
                let strata = strata_albedo(&Bsdf::MetallicRoughness(single), mu);
                let tolerance = 4.0 * walk.single_se[k] + 0.002;
                assert!(
                    (walk.single[k] - strata).abs() < tolerance,
                    "{what} f0 {f}: first bounce {} ± {}, strata {strata}",
                    walk.single[k],
                    walk.single_se[k]
                );
            }
        }
    }
}

/// The visible-normal sampler against its density ⟨v·m⟩ D(m) / A(v) by quadrature, above
/// and below the horizon (where the walk's later bounces see the facets from): the means of
/// m.x, m.z and m.z² agree within 0.003. A(v) = ∫ ⟨v·m⟩ D(m) dm is checked against Smith's
/// (1 + Λ(v)) v.z with the signed Λ of `lambda` (which makes the walk's escape and stop
/// probabilities consistent) to 0.2%.
#[test]
fn visible_normals_follow_their_density_from_above_and_below_the_horizon() {
    for alpha in [0.3f64, 1.0] {
        let surface = Microsurface { alpha };
        let d = |m: DVec3| {
            let a2 = alpha * alpha;
            let t = m.z * m.z * (a2 - 1.0) + 1.0;
            a2 / (std::f64::consts::PI * t * t)
        };
        for mu in [0.9f64, 0.3, -0.3, -0.8] {
            let v = direction(mu);
            // Quadrature over the hemisphere of m in (cos θ, φ), midpoint rule.
            let (nt, np) = (800, 800);
            let (mut area, mut moments) = (0.0, [0.0f64; 3]);
            for i in 0..nt {
                let c = (i as f64 + 0.5) / nt as f64;
                for j in 0..np {
                    let phi = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                    let s = (1.0 - c * c).sqrt();
                    let m = DVec3::new(s * phi.cos(), s * phi.sin(), c);
                    let p = v.dot(m).max(0.0) * d(m);
                    area += p;
                    moments[0] += p * m.x;
                    moments[1] += p * m.z;
                    moments[2] += p * m.z * m.z;
                }
            }
            let cell = std::f64::consts::TAU / (nt * np) as f64;
            area *= cell;
            let smith = (1.0 + surface.lambda(v)) * v.z;
            assert!(
                (area - smith).abs() < 2e-3 * smith,
                "α {alpha} μ {mu}: projected area {area}, Smith {smith}"
            );
            let want = moments.map(|x| x * cell / area);
            let mut rng = Rng(11);
            let n = 400_000;
            let mut got = [0.0f64; 3];
            for _ in 0..n {
                let m = surface.visible_normal(v, rng.next_f64(), rng.next_f64());
                assert!(m.z >= 0.0 && v.dot(m) >= -1e-9, "α {alpha} μ {mu}: {m}");
                got[0] += m.x;
                got[1] += m.z;
                got[2] += m.z * m.z;
            }
            let got = got.map(|x| x / n as f64);
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() < 3e-3,
                    "α {alpha} μ {mu} moment {k}: sampled {}, quadrature {}",
                    got[k],
                    want[k]
                );
            }
        }
    }
}

/// The walk's multiple scattering (its second and later bounces) is reciprocal, as the
/// paper's BSDFs are: f_ms(a, b) = f_ms(b, a), each estimated as the Fresnel-weighted share
/// of walks entering from one direction that leave within a cone of half-angle 0.2 around
/// the other, over μ Ω (Ω the cone's solid angle). This checks the parts the first bounce
/// does not reach: stops while going up, and facets seen from below the horizon. Within
/// four standard errors plus 2% (the cones' averaging of a smooth lobe).
#[test]
fn the_random_walks_multiple_scattering_is_reciprocal() {
    let at = |mu: f64, phi: f64| {
        let s = (1.0 - mu * mu).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), mu)
    };
    let half_angle = 0.2f64;
    let solid_angle = std::f64::consts::TAU * (1.0 - half_angle.cos());
    // f_ms(from, to) with f0 = 0.5, and its standard error.
    let lobe = |surface: Microsurface, from: DVec3, to: DVec3, seed: u64| {
        let mut rng = Rng(seed);
        let n = 1_000_000;
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..n {
            let end = surface.walk(from, [0.5], &mut rng);
            if end.order >= 2 && end.wi.dot(to) >= half_angle.cos() {
                sum += end.weight[0];
                sum2 += end.weight[0] * end.weight[0];
            }
        }
        let (mean, var) = (sum / n as f64, sum2 / n as f64 - (sum / n as f64).powi(2));
        let scale = 1.0 / (to.z * solid_angle);
        (mean * scale, (var / n as f64).sqrt() * scale)
    };
    for alpha in [1.0, 0.5625] {
        let surface = Microsurface { alpha };
        for (k, (a, b)) in [
            (at(0.9, 0.0), at(0.3, std::f64::consts::FRAC_PI_2)),
            (at(0.6, 0.0), at(0.5, std::f64::consts::PI)),
        ]
        .into_iter()
        .enumerate()
        {
            let (ab, se_ab) = lobe(surface, a, b, 31 + k as u64);
            let (ba, se_ba) = lobe(surface, b, a, 57 + k as u64);
            let tolerance = 4.0 * (se_ab * se_ab + se_ba * se_ba).sqrt() + 0.02 * ab.max(ba);
            println!(
                "α {alpha} pair {k}: f_ms {ab:.4} ± {se_ab:.4}, reversed {ba:.4} ± {se_ba:.4}"
            );
            assert!(
                (ab - ba).abs() < tolerance,
                "α {alpha} pair {k}: f_ms(a, b) {ab} ± {se_ab}, f_ms(b, a) {ba} ± {se_ba}"
            );
        }
    }
}

/// The table docs/khronos.md quotes: for each grey metal, roughness and direction cosine,
/// the random walk's albedo (± its standard error), strata's single scattering and
/// compensated model (the BSDF's sample weights), and the closed forms of Turquin's and Kulla
/// & Conty's compensation from strata's albedo table.
#[test]
#[ignore = "prints the table of docs/khronos.md; about a minute"]
fn print_the_albedo_table() {
    println!(
        "| roughness | μo | f0 | walk | ± | single | strata | Turquin | Kulla-Conty | Fdez-Agüera |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for (r, roughness) in ROUGHNESS.into_iter().enumerate() {
        let alpha = roughness * roughness;
        for (m, mu) in MU.into_iter().enumerate() {
            let walk = walk_albedo(alpha, mu, F0, 1_000_000, 1000 + (r * 10 + m) as u64);
            for (k, f0) in F0.into_iter().enumerate() {
                let brdf = metal(f0 as f32, roughness as f32);
                let single = strata_albedo(&Bsdf::MetallicRoughness(brdf.single_scattering()), mu);
                let strata = strata_albedo(&Bsdf::MetallicRoughness(brdf), mu);
                println!(
                    "| {roughness} | {mu} | {f0} | {:.4} | {:.4} | {single:.4} | {strata:.4} | {:.4} | {:.4} | {:.4} |",
                    walk.total[k],
                    walk.total_se[k],
                    turquin_albedo(f0, alpha, mu),
                    kulla_conty_albedo(f0, alpha, mu),
                    fdez_aguera_albedo(f0, alpha, mu),
                );
            }
        }
    }
}

/// The sphere centres' grey metal (MetalRoughSpheresNoTextures' base colour) and the ring of
/// light directions μi ∈ [0.2, 0.32] around the sun's cos 75°.
const SPHERE_F0: f64 = 0.604;
const RING: (f64, f64) = (0.2, 0.32);

/// The BRDF averaged over the ring, ∫ f μ dω / ∫ μ dω, seen along the normal (μo = 1): the
/// walk's (from the share of its walks entering along the normal that leave in the ring, ±
/// its standard error), strata's single scattering and compensated model (quadrature of
/// `eval`), and Turquin's scaling of the single-scattering lobe, 1 + f0 (1 − E(1)) / E(1).
struct Ring {
    walk: f64,
    walk_se: f64,
    single: f64,
    strata: f64,
    turquin: f64,
}

fn ring(roughness: f64, walks: usize) -> Ring {
    let (lo, hi) = RING;
    let ring_cos = std::f64::consts::PI * (hi * hi - lo * lo);
    let alpha = roughness * roughness;
    let surface = Microsurface { alpha };
    let mut rng = Rng(5);
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..walks {
        let end = surface.walk(DVec3::Z, [SPHERE_F0], &mut rng);
        if end.order > 0 && (lo..hi).contains(&end.wi.z) {
            sum += end.weight[0];
            sum2 += end.weight[0] * end.weight[0];
        }
    }
    let mean = sum / walks as f64;
    let se = ((sum2 / walks as f64 - mean * mean) / walks as f64).sqrt();
    // f·μ integrated over the ring by the midpoint rule in μ and φ.
    let integrate = |bsdf: &Bsdf| {
        let (nm, np) = (64, 256);
        let mut total = 0.0;
        for i in 0..nm {
            let mu = lo + (hi - lo) * (i as f64 + 0.5) / nm as f64;
            for j in 0..np {
                let phi = std::f64::consts::TAU * (j as f64 + 0.5) / np as f64;
                let s = (1.0 - mu * mu).sqrt();
                let wi = DVec3::new(s * phi.cos(), s * phi.sin(), mu).as_vec3();
                total += bsdf.eval(Vec3::Z, wi).x as f64;
            }
        }
        total * (hi - lo) * std::f64::consts::TAU / (nm * np) as f64 / ring_cos
    };
    let brdf = metal(SPHERE_F0 as f32, roughness as f32);
    let single = integrate(&Bsdf::MetallicRoughness(brdf.single_scattering()));
    let e1 = AlbedoTable::get().e(1.0, alpha as f32) as f64;
    Ring {
        walk: mean / ring_cos,
        walk_se: se / ring_cos,
        single,
        strata: integrate(&Bsdf::MetallicRoughness(brdf)),
        turquin: single * (1.0 + SPHERE_F0 * (1.0 - e1) / e1),
    }
}

/// The BRDF where the spheres of docs/khronos.md's MetalRoughSpheresNoTextures differ most
/// from Cycles: seen along the normal (the sphere's centre) and lit from near the horizon
/// (the sun 75° high over a sphere seen from the side, μi ≈ 0.26), their grey metal, as
/// [`ring`] measures it.
#[test]
#[ignore = "prints the second table of docs/khronos.md; a few seconds"]
fn print_the_brdf_at_the_sphere_centres() {
    println!("| roughness | walk | ± | single | strata | Turquin |");
    println!("|---|---|---|---|---|---|");
    for roughness in [0.67f64, 0.83, 1.0] {
        let r = ring(roughness, 4_000_000);
        println!(
            "| {roughness} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} |",
            r.walk, r.walk_se, r.single, r.strata, r.turquin
        );
    }
}

/// Where the light leaves: the energy reflected into bands of μi (0–0.2, …, 0.8–1, all
/// azimuths) by the walk, and the relative error of Turquin's scaled single-scattering lobe
/// and of Kulla & Conty's (strata's compensated model), with the RMS of each over every band.
#[test]
#[ignore = "prints the third table of docs/khronos.md; half a minute"]
fn print_the_energy_by_exit_cosine() {
    let t = AlbedoTable::get();
    println!("| roughness | μo | f0 | each band of μi: walk: Turquin, Kulla-Conty |");
    println!("|---|---|---|---|---|---|---|---|");
    let (mut square_turquin, mut square_strata, mut count) = (0.0f64, 0.0f64, 0);
    for roughness in [0.5f64, 0.75, 1.0] {
        let alpha = roughness * roughness;
        let surface = Microsurface { alpha };
        for mu_o in [1.0f64, 0.5, 0.2] {
            let f0 = [0.2, 0.6, 0.9];
            let mut rng = Rng(9);
            let n = 1_000_000;
            let mut bands = [[0.0f64; 5]; 3];
            for _ in 0..n {
                let end = surface.walk(direction(mu_o), f0, &mut rng);
                if end.order > 0 {
                    let b = ((end.wi.z * 5.0) as usize).min(4);
                    for (band, w) in bands.iter_mut().zip(end.weight) {
                        band[b] += w / n as f64;
                    }
                }
            }
            let e_o = t.e(mu_o as f32, alpha as f32) as f64;
            for (k, f0) in f0.into_iter().enumerate() {
                let brdf = metal(f0 as f32, roughness as f32);
                let single = Bsdf::MetallicRoughness(brdf.single_scattering());
                let compensated = Bsdf::MetallicRoughness(brdf);
                let wo = direction(mu_o).as_vec3();
                let mut line = format!("| {roughness} | {mu_o} | {f0} |");
                for (b, walk) in bands[k].iter().enumerate() {
                    // ∫ f μ dω over the band by the midpoint rule in μ and φ.
                    let (nm, np) = (40, 200);
                    let (mut e_single, mut e_strata) = (0.0, 0.0);
                    for i in 0..nm {
                        let mu = 0.2 * (b as f64 + (i as f64 + 0.5) / nm as f64);
                        for j in 0..np {
                            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / np as f64;
                            let s = (1.0 - mu * mu).sqrt();
                            let wi = DVec3::new(s * phi.cos(), s * phi.sin(), mu).as_vec3();
                            e_single += single.eval(wo, wi).x as f64;
                            e_strata += compensated.eval(wo, wi).x as f64;
                        }
                    }
                    let cell = 0.2 * std::f64::consts::TAU / (nm * np) as f64;
                    let turquin = e_single * cell * (1.0 + f0 * (1.0 - e_o) / e_o);
                    let strata = e_strata * cell;
                    let (dt, ds) = (turquin / walk - 1.0, strata / walk - 1.0);
                    line += &format!(" {walk:.4}: {:+.1}%, {:+.1}% |", dt * 100.0, ds * 100.0);
                    square_turquin += dt * dt;
                    square_strata += ds * ds;
                    count += 1;
                }
                println!("{line}");
            }
        }
    }
    println!(
        "RMS relative error: Turquin {:.3}, Kulla-Conty {:.3}",
        (square_turquin / count as f64).sqrt(),
        (square_strata / count as f64).sqrt()
    );
}

/// strata's compensated grey metals against the walk, the pin of its model. The measured
/// agreement (docs/khronos.md, `print_the_albedo_table` and `print_the_brdf_at_the_sphere_centres`):
/// Kulla & Conty's lobe is at most 5.6% below the walk's directional albedo at roughness
/// ≤ 0.75 and 8.3% at roughness 1 (its series of F_avg^k underestimates the energy that
/// leaves after two or three bounces), and 1–2% off the sphere centres' BRDF. The bounds, 7%,
/// 10% and 4%, leave room for the estimates' noise (about 0.3% here) and fail on a model that
/// errs more. Turquin's scaled single-scattering lobe, the model strata had before, fails
/// them: its albedo is 15.8% high at roughness 1, μo = 1, f0 = 0.5, and its sphere-centre BRDF
/// 17% and 54% high at roughness 0.83 and 1 (the negative control, from its closed form).
#[test]
fn the_compensated_metal_follows_the_random_walk() {
    let relative = |model: f64, walk: f64| (model / walk - 1.0).abs();
    let mut turquin_worst = 0.0f64;
    for (r, roughness) in ROUGHNESS.into_iter().enumerate() {
        let alpha = roughness * roughness;
        let bound = if roughness < 1.0 { 0.07 } else { 0.10 };
        for (m, mu) in MU.into_iter().enumerate() {
            let walk = walk_albedo(alpha, mu, F0, 200_000, 2000 + (r * 10 + m) as u64);
            for (k, f0) in F0.into_iter().enumerate() {
                let brdf = Bsdf::MetallicRoughness(metal(f0 as f32, roughness as f32));
                let strata = strata_albedo(&brdf, mu);
                assert!(
                    relative(strata, walk.total[k]) < bound,
                    "roughness {roughness} μo {mu} f0 {f0}: strata {strata}, walk {}",
                    walk.total[k]
                );
                let turquin = turquin_albedo(f0, alpha, mu);
                turquin_worst = turquin_worst.max(relative(turquin, walk.total[k]) / bound);
            }
        }
    }
    assert!(
        turquin_worst > 1.0,
        "Turquin's albedo passes ({turquin_worst} of the bound)"
    );
    for roughness in [0.83, 1.0] {
        let r = ring(roughness, 1_000_000);
        assert!(
            relative(r.strata, r.walk) < 0.04,
            "sphere centre, roughness {roughness}: strata {}, walk {} ± {}",
            r.strata,
            r.walk,
            r.walk_se
        );
        assert!(
            relative(r.turquin, r.walk) > 0.1,
            "sphere centre, roughness {roughness}: Turquin {} passes, walk {}",
            r.turquin,
            r.walk
        );
    }
}
