//! One source at two widths: the glossy lobe's sampling step (a GGX visible normal, the
//! reflected direction, D·V·cos and the pdf), the glTF BRDF's step (its terms of wo, a
//! drawn direction with its value and pdf, and a light direction's for MIS, on materials
//! that differ lane by lane: dielectrics, metals and blends, energy-compensated), the cosine
//! warp, the environment map's radiance and pdf lookup (the bundled 1k studio map, the
//! directions incoherent as bounce rays are) and its sampling (a cell by the guided
//! inversions, a point of its bilinear patch, the direction), for 8192 random states one
//! lane at a time (`f32`), eight at a time in AVX2 (`F8` inside `lanes::dispatch`) and eight
//! at a time in baseline SSE (`F8` outside it). The three give the same bits (the width tests
//! in `src/`); this measures what the width buys.
//!
//!     cargo bench --bench lanes

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use strata::lanes::{dispatch, Kernel, Real, Vec2L, Vec3L, F8};
use strata::sampling::warps::cosine_hemisphere;
use strata::shading::gltf_brdf::GltfBrdfLanes;
use strata::shading::microfacet::{ggx_d, ggx_g1, ggx_v, visible_normal};
use strata::shading::{EnvMap, GltfBrdf};

const N: usize = 8192;

/// The glossy sampling step: (value·cos, pdf) of the direction reflected about a visible
/// normal drawn from `u`, summed so that nothing is optimised away.
#[inline(always)]
fn ggx_step<R: Real>(alpha: R, wo: Vec3L<R>, u: Vec2L<R>) -> R {
    let h = visible_normal(alpha, alpha, wo, u);
    let wi = h * (wo.dot(h) * 2.0) - wo;
    let d = ggx_d(alpha, h);
    let f_cos = d * ggx_v(alpha, wo, wi) * wi.z.max(R::ZERO);
    let pdf = ggx_g1(alpha, wo) * d / (wo.z * 4.0);
    f_cos + pdf
}

/// The glTF BRDF's step at a path vertex: wo's terms, a direction drawn from `u` with its
/// f·cos and pdf, and the f·cos and pdf of light direction `wl`, summed.
#[inline(always)]
fn brdf_step<R: Real>(brdf: &GltfBrdfLanes<R>, wo: Vec3L<R>, u: Vec2L<R>, wl: Vec3L<R>) -> R {
    let o = brdf.outgoing(wo);
    let d = brdf.sample_direction(&o, wo, u);
    let (f, pdf) = brdf.eval_pdf(&o, wo, d.wi);
    let (fl, pdfl) = brdf.eval_pdf(&o, wo, wl);
    R::select(d.valid, f.x + pdf, R::ZERO) + fl.y + pdfl
}

#[inline(always)]
fn cosine_step<R: Real>(u: Vec2L<R>) -> R {
    let d = cosine_hemisphere(u);
    d.x + d.y + d.z
}

/// The states in structure-of-arrays groups of eight, as a wavefront integrator keeps its
/// paths.
struct States {
    alpha: Vec<F8>,
    wo: Vec<Vec3L<F8>>,
    u: Vec<Vec2L<F8>>,
    /// Eight materials per group, and each alone.
    brdf: Vec<GltfBrdfLanes<F8>>,
    one_brdf: Vec<GltfBrdfLanes<f32>>,
    /// Light directions, above the surface or (a fifth) below it.
    wl: Vec<Vec3L<F8>>,
}

fn states() -> States {
    let mut x = 0x2545_f491u32;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        (x >> 8) as f32 / (1 << 24) as f32
    };
    let mut s = States {
        alpha: vec![],
        wo: vec![],
        u: vec![],
        brdf: vec![],
        one_brdf: vec![],
        wl: vec![],
    };
    for _ in 0..N / 8 {
        s.alpha.push(F8::from_fn(|_| 0.05 + next() * 0.6));
        s.wo.push(Vec3L::from_fn(|_| {
            let z = 0.05 + 0.95 * next();
            let phi = std::f32::consts::TAU * next();
            let r = (1.0 - z * z).sqrt();
            glam::Vec3::new(r * phi.cos(), r * phi.sin(), z)
        }));
        s.u.push(Vec2L::from_fn(|_| glam::Vec2::new(next(), next())));
        let group: Vec<GltfBrdfLanes<f32>> = (0..8)
            .map(|_| {
                let base = glam::Vec3::new(next(), next(), next());
                let metallic = [0.0, 1.0, next()][(next() * 3.0) as usize % 3];
                *GltfBrdf::new(base, metallic, 0.2 + 0.7 * next()).lanes()
            })
            .collect();
        s.brdf.push(GltfBrdfLanes::from_fn(|i| group[i]));
        s.one_brdf.extend(group);
        s.wl.push(Vec3L::from_fn(|_| {
            let z = next() * 1.25 - 0.25;
            let phi = std::f32::consts::TAU * next();
            let r = (1.0 - z * z).sqrt();
            glam::Vec3::new(r * phi.cos(), r * phi.sin(), z)
        }));
    }
    s
}

#[inline(always)]
fn one(s: &States) -> f32 {
    let mut sum = 0.0;
    for ((a, wo), u) in s.alpha.iter().zip(&s.wo).zip(&s.u) {
        for i in 0..8 {
            sum += ggx_step(a.lane(i), wo.lane(i).into(), u.lane(i).into());
        }
    }
    sum
}

#[inline(always)]
fn eight(s: &States) -> f32 {
    let mut sum = F8::ZERO;
    for ((a, wo), u) in s.alpha.iter().zip(&s.wo).zip(&s.u) {
        sum += ggx_step(*a, *wo, *u);
    }
    (0..8).map(|i| sum.lane(i)).sum()
}

#[inline(always)]
fn one_brdf(s: &States) -> f32 {
    let mut sum = 0.0;
    for (k, ((wo, u), wl)) in s.wo.iter().zip(&s.u).zip(&s.wl).enumerate() {
        for i in 0..8 {
            let brdf = &s.one_brdf[8 * k + i];
            sum += brdf_step(brdf, wo.lane(i).into(), u.lane(i).into(), wl.lane(i).into());
        }
    }
    sum
}

#[inline(always)]
fn eight_brdf(s: &States) -> f32 {
    let mut sum = F8::ZERO;
    for (((brdf, wo), u), wl) in s.brdf.iter().zip(&s.wo).zip(&s.u).zip(&s.wl) {
        sum += brdf_step(brdf, *wo, *u, *wl);
    }
    (0..8).map(|i| sum.lane(i)).sum()
}

struct Brdf<'a>(&'a States);
impl Kernel for Brdf<'_> {
    type Output = f32;
    #[inline(always)]
    fn run(self) -> f32 {
        eight_brdf(self.0)
    }
}

#[inline(always)]
fn one_cosine(s: &States) -> f32 {
    let mut sum = 0.0;
    for u in &s.u {
        for i in 0..8 {
            sum += cosine_step::<f32>(u.lane(i).into());
        }
    }
    sum
}

#[inline(always)]
fn eight_cosine(s: &States) -> f32 {
    let mut sum = F8::ZERO;
    for u in &s.u {
        sum += cosine_step(*u);
    }
    (0..8).map(|i| sum.lane(i)).sum()
}

#[inline(always)]
fn one_map(s: &States, map: &EnvMap) -> f32 {
    let mut sum = 0.0;
    for wo in &s.wo {
        for i in 0..8 {
            let (l, pdf) = map.radiance_pdf_lanes::<f32>(wo.lane(i).into());
            sum += l.x + pdf;
        }
    }
    sum
}

#[inline(always)]
fn eight_map(s: &States, map: &EnvMap) -> f32 {
    let mut sum = F8::ZERO;
    for wo in &s.wo {
        let (l, pdf) = map.radiance_pdf_lanes(*wo);
        sum += l.x + pdf;
    }
    (0..8).map(|i| sum.lane(i)).sum()
}

#[inline(always)]
fn one_map_sample(s: &States, map: &EnvMap) -> f32 {
    let mut sum = 0.0;
    for u in &s.u {
        for i in 0..8 {
            let (d, l, pdf) = map.sample_lanes::<f32>(u.lane(i).into());
            sum += d.x + l.y + pdf;
        }
    }
    sum
}

#[inline(always)]
fn eight_map_sample(s: &States, map: &EnvMap) -> f32 {
    let mut sum = F8::ZERO;
    for u in &s.u {
        let (d, l, pdf) = map.sample_lanes(*u);
        sum += d.x + l.y + pdf;
    }
    (0..8).map(|i| sum.lane(i)).sum()
}

struct MapSample<'a>(&'a States, &'a EnvMap);
impl Kernel for MapSample<'_> {
    type Output = f32;
    #[inline(always)]
    fn run(self) -> f32 {
        eight_map_sample(self.0, self.1)
    }
}

struct Map<'a>(&'a States, &'a EnvMap);
impl Kernel for Map<'_> {
    type Output = f32;
    #[inline(always)]
    fn run(self) -> f32 {
        eight_map(self.0, self.1)
    }
}

struct Ggx<'a>(&'a States);
impl Kernel for Ggx<'_> {
    type Output = f32;
    #[inline(always)]
    fn run(self) -> f32 {
        eight(self.0)
    }
}

struct Cosine<'a>(&'a States);
impl Kernel for Cosine<'_> {
    type Output = f32;
    #[inline(always)]
    fn run(self) -> f32 {
        eight_cosine(self.0)
    }
}

fn bench(c: &mut Criterion) {
    let s = states();
    let mut g = c.benchmark_group("ggx sampling step");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("one lane", |b| b.iter(|| one(black_box(&s))));
    g.bench_function("eight lanes, AVX2 dispatch", |b| {
        b.iter(|| dispatch(Ggx(black_box(&s))))
    });
    g.bench_function("eight lanes, baseline", |b| b.iter(|| eight(black_box(&s))));
    g.finish();

    let mut g = c.benchmark_group("gltf brdf step");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("one lane", |b| b.iter(|| one_brdf(black_box(&s))));
    g.bench_function("eight lanes, AVX2 dispatch", |b| {
        b.iter(|| dispatch(Brdf(black_box(&s))))
    });
    g.bench_function("eight lanes, baseline", |b| {
        b.iter(|| eight_brdf(black_box(&s)))
    });
    g.finish();

    let mut g = c.benchmark_group("cosine warp step");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("one lane", |b| b.iter(|| one_cosine(black_box(&s))));
    g.bench_function("eight lanes, AVX2 dispatch", |b| {
        b.iter(|| dispatch(Cosine(black_box(&s))))
    });
    g.bench_function("eight lanes, baseline", |b| {
        b.iter(|| eight_cosine(black_box(&s)))
    });
    g.finish();

    // Directions over the whole sphere: the states' directions (z up) turned a quarter
    // about x, (x, y, z) → (x, ∓z, y), every other group toward the map's top (+y) and the
    // rest toward its bottom.
    let mut sphere = states();
    for (k, wo) in sphere.wo.iter_mut().enumerate() {
        let (y, z) = (wo.y, wo.z);
        wo.y = if k % 2 == 0 { z } else { -z };
        wo.z = y;
    }
    let repo = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let map = EnvMap::load(
        &repo.join("scenes/env/studio_small_05_1k/studio_small_05_1k.hdr"),
        0.5,
        1.0,
        Default::default(),
    )
    .expect("the bundled map");
    let mut g = c.benchmark_group("environment radiance and pdf");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("one lane", |b| b.iter(|| one_map(black_box(&sphere), &map)));
    g.bench_function("eight lanes, AVX2 dispatch", |b| {
        b.iter(|| dispatch(Map(black_box(&sphere), &map)))
    });
    g.bench_function("eight lanes, baseline", |b| {
        b.iter(|| eight_map(black_box(&sphere), &map))
    });
    g.finish();

    let mut g = c.benchmark_group("environment sampling");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("one lane", |b| {
        b.iter(|| one_map_sample(black_box(&s), &map))
    });
    g.bench_function("eight lanes, AVX2 dispatch", |b| {
        b.iter(|| dispatch(MapSample(black_box(&s), &map)))
    });
    g.bench_function("eight lanes, baseline", |b| {
        b.iter(|| eight_map_sample(black_box(&s), &map))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
