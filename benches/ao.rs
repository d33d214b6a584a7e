//! Criterion benchmarks of the AO path on the bundled flight helmet (95k triangles):
//! closest-hit camera rays, any-hit AO rays, and a whole small AO render, each on one thread
//! so the numbers compare across machines with different core counts; and the cost of one
//! Owen-scrambled Sobol point (the crate's bit loop against our byte tables).
//!
//!     cargo bench --bench ao

use std::path::Path;
use std::sync::atomic::AtomicBool;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec2;
use indicatif::ProgressBar;
use strata::accel::{Accel, AccelOptions, Ray};
use strata::embree::RawRay;
use strata::integrators::{AoSettings, Integrator, Prepared};
use strata::render::{self, RenderSettings};
use strata::sampling::warps::square_to_cosine_hemisphere;
use strata::sampling::{Onb, PixelSampler, SamplerKind};
use strata::scene::{self, LoadOptions, Scene};
use strata::shading::interaction::SurfaceInteraction;

const W: u32 = 320;
const H: u32 = 240;

fn load() -> (Scene, Accel) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/flight-helmet.gltf");
    let scene = scene::load(&path, &LoadOptions::default()).expect("bundled scene");
    let accel = Accel::build(&scene, &AccelOptions::default()).expect("BVH");
    (scene, accel)
}

/// One camera ray per pixel centre, and the AO rays of the pixels whose camera ray hits.
fn ray_batches(scene: &Scene, accel: &Accel) -> (Vec<Ray>, Vec<Ray>) {
    let camera = &scene.cameras[0];
    let mut sampler = PixelSampler::new(SamplerKind::Sobol, 1, 0);
    let mut camera_rays = Vec::new();
    let mut ao_rays = Vec::new();
    for y in 0..H {
        for x in 0..W {
            let ray = camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, W, H);
            camera_rays.push(ray);
            if let Some(hit) = accel.intersect(&ray) {
                let si = SurfaceInteraction::from_hit(scene, &ray, &hit);
                sampler.start(x, y, 0);
                let u: Vec2 = sampler.next_2d();
                let wi = Onb::from_normal(si.ns).to_world(square_to_cosine_hemisphere(u));
                if wi.dot(si.ng) > 0.0 {
                    ao_rays.push(si.spawn_ray(wi, f32::INFINITY));
                }
            }
        }
    }
    (camera_rays, ao_rays)
}

fn bench(c: &mut Criterion) {
    strata::accel::enable_ftz_daz();
    let (scene, accel) = load();
    let (camera_rays, ao_rays) = ray_batches(&scene, &accel);

    let mut g = c.benchmark_group("flight-helmet");
    g.throughput(Throughput::Elements(camera_rays.len() as u64));
    g.bench_function("closest hit, camera rays", |b| {
        b.iter(|| {
            camera_rays
                .iter()
                .filter(|r| accel.intersect(r).is_some())
                .count()
        })
    });
    g.throughput(Throughput::Elements(ao_rays.len() as u64));
    g.bench_function("any hit, AO rays", |b| {
        b.iter(|| ao_rays.iter().filter(|r| accel.occluded(r)).count())
    });
    // The same rays through raw rtcOccluded1 calls in a tight loop: the cost of Accel.
    let raw_rays: Vec<RawRay> = ao_rays
        .iter()
        .map(|r| RawRay::new(r.org.to_array(), r.dir.to_array(), r.t_min, r.t_max))
        .collect();
    let raw_scene = accel.as_embree().expect("Embree backend").raw();
    // The wrapper runs the alpha test of the helmet's masked materials and the raw loop
    // does not, so a few rays through cut-out texels differ (2780 against 2785 of 23 k).
    let raw = raw_scene.occluded_count_raw(&raw_rays);
    let wrapped = ao_rays.iter().filter(|r| accel.occluded(r)).count();
    assert!(
        raw.abs_diff(wrapped) * 100 < ao_rays.len(),
        "raw and Accel paths disagree beyond the alpha-tested rays: {raw} against {wrapped}"
    );
    g.bench_function("any hit, AO rays, raw Embree loop", |b| {
        b.iter(|| raw_scene.occluded_count_raw(&raw_rays))
    });

    let prepared = Prepared::default();
    let ctx = prepared.context(&scene, &accel);
    let pool = render::thread_pool(1).unwrap();
    let settings = RenderSettings {
        camera: scene.cameras[0].clone(),
        crop: None,
        stopping: Default::default(),
        width: W,
        height: H,
        spp: 4,
        seed: 0,
        sampler: SamplerKind::Sobol,
        integrator: Integrator::Ao(AoSettings::default()),
        tile_size: 16,
        sample_range: None,
        min_pass_seconds: strata::render::DEFAULT_MIN_PASS_SECONDS,
    };
    g.throughput(Throughput::Elements((W * H * settings.spp) as u64));
    g.sample_size(10);
    g.bench_function("AO render 320x240 4 spp, 1 thread (samples)", |b| {
        b.iter(|| {
            render::render(
                &ctx,
                &settings,
                &pool,
                &ProgressBar::hidden(),
                &AtomicBool::new(false),
            )
            .stats
            .rays
        })
    });
    g.finish();
}

/// Owen-scrambled Sobol points: `sobol_burley`'s bit loop against strata's byte tables, and
/// strata's 2D points. Every dimension is summed, so that none is optimised away.
fn sobol(c: &mut Criterion) {
    let mut g = c.benchmark_group("sobol point");
    g.throughput(Throughput::Elements(1 << 16));
    let seed = |i: u32| i.wrapping_mul(0x9e37_79b9);
    // One row: the sum of every dimension of the points of indices 0..2^16 (`point` is
    // generic, so each row's point function is inlined as in the renderer).
    fn row<M: criterion::measurement::Measurement, const N: usize>(
        g: &mut criterion::BenchmarkGroup<M>,
        name: &str,
        point: impl Fn(u32) -> [f32; N],
    ) {
        g.bench_function(name, |b| {
            b.iter(|| {
                (0..1u32 << 16)
                    .map(|i| point(i).iter().sum::<f32>())
                    .sum::<f32>()
            })
        });
    }
    row(&mut g, "4D, sobol_burley::sample_4d", |i| {
        sobol_burley::sample_4d(i, 0, seed(i))
    });
    row(&mut g, "4D, strata::sampling::sobol::sample_4d", |i| {
        strata::sampling::sobol::sample_4d(i, seed(i))
    });
    row(&mut g, "2D, strata::sampling::sobol::sample_2d", |i| {
        strata::sampling::sobol::sample_2d(i, seed(i))
    });
    let sequences: Vec<strata::sampling::sobol::Sequence> = (0..1u32 << 16)
        .map(|i| strata::sampling::sobol::Sequence::new(seed(i)))
        .collect();
    g.bench_function("2D, Sequence::sample_2d", |b| {
        b.iter(|| {
            (0..1u32 << 16)
                .map(|i| sequences[i as usize].sample_2d(i).iter().sum::<f32>())
                .sum::<f32>()
        })
    });
    g.bench_function("2D, sample_2d_lanes, 8 lanes", |b| {
        b.iter(|| {
            (0..1u32 << 13)
                .map(|k| {
                    let s: [strata::sampling::sobol::Sequence; 8] =
                        std::array::from_fn(|j| sequences[(8 * k) as usize + j]);
                    let idx: [u32; 8] = std::array::from_fn(|j| 8 * k + j as u32);
                    strata::sampling::sobol::sample_2d_lanes(&s, &idx)
                        .iter()
                        .map(|p| p[0] + p[1])
                        .sum::<f32>()
                })
                .sum::<f32>()
        })
    });
    g.finish();
}

/// The cosine-weighted hemisphere warp of 4096 points, one at a time and eight at a time
/// (the AO rays of a packet of camera hits).
fn warp(c: &mut Criterion) {
    use strata::sampling::warps::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_lanes};
    let mut g = c.benchmark_group("cosine warp");
    let points: Vec<glam::Vec2> = (0..4096u32)
        .map(|i| {
            let [x, y] = strata::sampling::sobol::sample_2d(i, 7);
            glam::Vec2::new(x, y)
        })
        .collect();
    g.throughput(Throughput::Elements(points.len() as u64));
    g.bench_function("one at a time", |b| {
        b.iter(|| {
            points
                .iter()
                .map(|&u| square_to_cosine_hemisphere(u).z)
                .sum::<f32>()
        })
    });
    g.bench_function("eight at a time", |b| {
        b.iter(|| {
            points
                .chunks_exact(8)
                .map(|c| {
                    let u: [glam::Vec2; 8] = c.try_into().expect("eight points");
                    square_to_cosine_hemisphere_lanes(&u)
                        .iter()
                        .map(|v| v.z)
                        .sum::<f32>()
                })
                .sum::<f32>()
        })
    });
    g.finish();
}

criterion_group!(benches, bench, sobol, warp);
criterion_main!(benches);
