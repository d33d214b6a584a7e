//! Criterion benchmarks of the BVH backends (Embree, obvhs) on real meshes: BVH build time on
//! one thread and on all threads, and closest-hit / any-hit throughput for coherent camera
//! rays and incoherent diffuse rays, on one thread and on all threads.
//!
//!     tools/bench/prepare_meshes.sh            # converts the large meshes once (OBJ/PLY → GLB)
//!     cargo bench --bench backends
//!
//! For Embree, the `packets/` group compares its packet API (`rtcIntersect4/8/16`, coherent
//! hint) with one `rtcIntersect1` call per ray on the same camera rays, ordered in 4×4 pixel
//! blocks so each packet holds neighbouring rays; both include packing rays into Embree's
//! layout. It also traces the incoherent diffuse rays both ways, eight consecutive ones per
//! packet.
//!
//! The `quads/` group traces the bundled Cornell box and `emissive-strength` with Embree's
//! geometry as quads (the default) and as triangles (`cargo bench --bench backends -- quads/`).
//!
//! Meshes: the bundled flight helmet, plus every `*.glb`/`*.gltf` in `$STRATA_BENCH_MESHES`
//! (default `~/.cache/strata/meshes`, filled by the script above). Throughput is in rays.

use std::path::{Path, PathBuf};
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::Vec2;
use rayon::prelude::*;
use strata::accel::{Accel, AccelOptions, Backend, Ray};
use strata::embree::RawRay;
use strata::sampling::hash::{hash_words, unit_f32};
use strata::sampling::warps::square_to_cosine_hemisphere;
use strata::sampling::Onb;
use strata::scene::{self, Camera, LoadOptions, Scene};
use strata::shading::interaction::SurfaceInteraction;

const W: u32 = 320;
const H: u32 = 240;

fn meshes() -> Vec<PathBuf> {
    let mut out = vec![Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/flight-helmet.gltf")];
    let dir = std::env::var_os("STRATA_BENCH_MESHES")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| Path::new(&h).join(".cache/strata/meshes")));
    if let Some(dir) = dir {
        if let Ok(entries) = std::fs::read_dir(&dir) {
            let mut found: Vec<PathBuf> = entries
                .flatten()
                .map(|e| e.path())
                .filter(|p| matches!(p.extension().and_then(|e| e.to_str()), Some("glb" | "gltf")))
                .collect();
            found.sort();
            out.extend(found);
        } else {
            eprintln!("note: {} not found: only the bundled mesh is benchmarked (run tools/bench/prepare_meshes.sh)", dir.display());
        }
    }
    out
}

fn build(scene: &Scene, backend: Backend, threads: usize) -> Accel {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        Accel::build(
            scene,
            &AccelOptions {
                backend,
                threads,
                ..Default::default()
            },
        )
        .unwrap()
    })
}

/// Camera rays through pixel centres (coherent), and one cosine-distributed ray from each
/// camera hit (incoherent), as AO or a diffuse bounce would trace them.
fn ray_sets(scene: &Scene, accel: &Accel) -> (Vec<Ray>, Vec<Ray>) {
    let camera =
        scene.cameras.first().cloned().unwrap_or_else(|| {
            Camera::framing(scene.bounds.0, scene.bounds.1, W as f32 / H as f32)
        });
    let mut coherent = Vec::new();
    let mut incoherent = Vec::new();
    for y in 0..H {
        for x in 0..W {
            let ray = camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, W, H);
            coherent.push(ray);
            if let Some(hit) = accel.intersect(&ray) {
                let si = SurfaceInteraction::from_hit(scene, &ray, &hit);
                let k = (y * W + x) as u64;
                let u = Vec2::new(unit_f32(hash_words(&[k, 0])), unit_f32(hash_words(&[k, 1])));
                let wi = Onb::from_normal(si.ns).to_world(square_to_cosine_hemisphere(u));
                incoherent
                    .push(si.spawn_ray(if wi.dot(si.ng) > 0.0 { wi } else { -wi }, f32::INFINITY));
            }
        }
    }
    (coherent, incoherent)
}

/// The camera rays (scanline order, W×H) reordered in 4×4 pixel blocks, in Embree's layout.
fn block_ordered(coherent: &[Ray]) -> Vec<RawRay> {
    let mut out = Vec::with_capacity(coherent.len());
    for by in (0..H).step_by(4) {
        for bx in (0..W).step_by(4) {
            for y in by..(by + 4).min(H) {
                for x in bx..(bx + 4).min(W) {
                    let r = &coherent[(y * W + x) as usize];
                    out.push(RawRay::new(
                        r.org.to_array(),
                        r.dir.to_array(),
                        r.t_min,
                        r.t_max,
                    ));
                }
            }
        }
    }
    out
}

fn bench(c: &mut Criterion) {
    strata::accel::enable_ftz_daz();
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let pool = strata::render::thread_pool(all).unwrap();
    for path in meshes() {
        let scene = match scene::load(&path, &LoadOptions::default()) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("skipping {}: {e}", path.display());
                continue;
            }
        };
        let name = format!(
            "{} ({}k tris)",
            path.file_stem().unwrap().to_string_lossy(),
            scene.triangles.len() / 1000
        );

        let mut g = c.benchmark_group(format!("build/{name}"));
        g.sample_size(10).measurement_time(Duration::from_secs(4));
        for backend in [Backend::Embree, Backend::Obvhs] {
            for threads in [1, all] {
                g.bench_with_input(
                    BenchmarkId::new(backend.to_string(), format!("{threads} threads")),
                    &threads,
                    |b, &t| b.iter(|| build(&scene, backend, t)),
                );
            }
        }
        g.finish();

        let reference = build(&scene, Backend::Embree, all);
        let (coherent, incoherent) = ray_sets(&scene, &reference);

        let blocks = block_ordered(&coherent);
        let raw = reference.as_embree().expect("Embree").raw();
        let hits = raw.intersect_count_raw(&blocks);
        assert_eq!(
            raw.intersect8_count_raw(&blocks, true),
            hits,
            "packets disagree"
        );
        let mut g = c.benchmark_group(format!("packets/{name}"));
        g.sample_size(10).measurement_time(Duration::from_secs(3));
        g.throughput(Throughput::Elements(blocks.len() as u64));
        g.bench_function("rtcIntersect1, 1 thread", |b| {
            b.iter(|| raw.intersect_count_raw(&blocks))
        });
        g.bench_function("rtcIntersect4, 1 thread", |b| {
            b.iter(|| raw.intersect4_count_raw(&blocks, true))
        });
        g.bench_function("rtcIntersect8, 1 thread", |b| {
            b.iter(|| raw.intersect8_count_raw(&blocks, true))
        });
        g.bench_function("rtcIntersect16, 1 thread", |b| {
            b.iter(|| raw.intersect16_count_raw(&blocks, true))
        });
        // The diffuse rays, consecutive ones (from neighbouring camera hits) in a packet:
        // what packets of a path tracer's secondary rays would meet.
        let scattered: Vec<RawRay> = incoherent
            .iter()
            .map(|r| RawRay::new(r.org.to_array(), r.dir.to_array(), r.t_min, r.t_max))
            .collect();
        g.throughput(Throughput::Elements(scattered.len() as u64));
        g.bench_function("incoherent, rtcIntersect1, 1 thread", |b| {
            b.iter(|| raw.intersect_count_raw(&scattered))
        });
        // With the coherent hint (packet traversal throughout) and with the default one
        // (Embree 3's hybrid traversal: one ray at a time once the rays part).
        g.bench_function("incoherent, rtcIntersect8 coherent hint, 1 thread", |b| {
            b.iter(|| raw.intersect8_count_raw(&scattered, true))
        });
        g.bench_function("incoherent, rtcIntersect8 incoherent hint, 1 thread", |b| {
            b.iter(|| raw.intersect8_count_raw(&scattered, false))
        });
        g.bench_function(
            "incoherent, rtcIntersect16 incoherent hint, 1 thread",
            |b| b.iter(|| raw.intersect16_count_raw(&scattered, false)),
        );
        g.finish();
        let mut g = c.benchmark_group(format!("trace/{name}"));
        g.sample_size(10).measurement_time(Duration::from_secs(3));
        for backend in [Backend::Embree, Backend::Obvhs] {
            let accel = build(&scene, backend, all);
            for (kind, rays) in [("coherent", &coherent), ("incoherent", &incoherent)] {
                g.throughput(Throughput::Elements(rays.len() as u64));
                let id = |q: &str, t: &str| {
                    BenchmarkId::new(format!("{backend} {q}"), format!("{kind}, {t}"))
                };
                g.bench_function(id("closest", "1 thread"), |b| {
                    b.iter(|| rays.iter().filter(|r| accel.intersect(r).is_some()).count())
                });
                g.bench_function(id("any", "1 thread"), |b| {
                    b.iter(|| rays.iter().filter(|r| accel.occluded(r)).count())
                });
                g.bench_function(id("closest", "all threads"), |b| {
                    b.iter(|| {
                        pool.install(|| {
                            rays.par_chunks(256)
                                .map(|c| c.iter().filter(|r| accel.intersect(r).is_some()).count())
                                .sum::<usize>()
                        })
                    })
                });
                g.bench_function(id("any", "all threads"), |b| {
                    b.iter(|| {
                        pool.install(|| {
                            rays.par_chunks(256)
                                .map(|c| c.iter().filter(|r| accel.occluded(r)).count())
                                .sum::<usize>()
                        })
                    })
                });
            }
        }
        g.finish();
    }
}

/// Embree's geometry as quads (pairs of triangles, the default where they pay) against plain
/// triangles, on the bundled scenes whose triangles pair (`quads/`): one thread, the same
/// ray sets as `trace/`.
fn bench_quads(c: &mut Criterion) {
    strata::accel::enable_ftz_daz();
    for file in ["cornell-box.gltf", "emissive-strength.gltf"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(file);
        let scene = scene::load(&path, &LoadOptions::default()).unwrap();
        let accel = |quads: bool| {
            Accel::build(
                &scene,
                &AccelOptions {
                    quads,
                    threads: 1,
                    ..Default::default()
                },
            )
            .unwrap()
        };
        let (plain, quads) = (accel(false), accel(true));
        assert!(
            quads.as_embree().unwrap().uses_quads(),
            "{file} pairs no triangles"
        );
        let (coherent, incoherent) = ray_sets(&scene, &plain);
        let mut g = c.benchmark_group(format!("quads/{}", file.trim_end_matches(".gltf")));
        g.sample_size(20).measurement_time(Duration::from_secs(3));
        for (kind, rays) in [("coherent", &coherent), ("incoherent", &incoherent)] {
            g.throughput(Throughput::Elements(rays.len() as u64));
            for (geometry, accel) in [("triangles", &plain), ("quads", &quads)] {
                g.bench_function(
                    BenchmarkId::new(format!("closest, {geometry}"), kind),
                    |b| b.iter(|| rays.iter().filter(|r| accel.intersect(r).is_some()).count()),
                );
                g.bench_function(BenchmarkId::new(format!("any, {geometry}"), kind), |b| {
                    b.iter(|| rays.iter().filter(|r| accel.occluded(r)).count())
                });
            }
        }
        g.finish();
    }
}

criterion_group!(benches, bench, bench_quads);
criterion_main!(benches);
