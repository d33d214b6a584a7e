//! The cost of strata's own layers over raw Embree calls, as ratios measured in one run.
//!
//!     cargo bench --bench overhead
//!
//! The rays are exactly those of an AO render of the bundled flight helmet (320×240, 8 spp,
//! one thread), once with one AO ray per camera hit and once with 16 (`--ao-samples 16`):
//! every camera ray, and the AO rays of every camera hit, made with the renderer's own
//! sampler, camera and offsets, in the renderer's order (round, 16×16 tile, 4×2-pixel block,
//! sample, pixel). Five ways of tracing them then alternate for `ROUNDS` rounds:
//!
//! - **raw, single rays**: `rtcIntersect1` / `rtcOccluded1` in tight loops over rays already
//!   in Embree's layout, one intersection context per batch: the most any renderer could get
//!   from Embree one ray at a time;
//! - **raw, packets**: the camera rays as the render groups them, one `rtcIntersect8` per
//!   packet (packing included), and the AO rays as the render traces them (with one ray per
//!   hit, those of a camera packet's hits in one `rtcOccluded8`; with more, each hit's in
//!   `rtcOccluded8` or `rtcOccluded16` per group of up to 16, `rtcOccluded1` for a lone
//!   ray): the raw counterpart of the render;
//! - **accel**: the same packets and rays through [`Accel::intersect_packet`],
//!   [`Accel::occluded`] and [`Accel::occluded_packet`], the calls the render makes;
//! - **render**: the whole AO render of the same image (sampling, camera, shading, film),
//!   which traces the same rays but for those it culls: pixel blocks that cannot see the
//!   scene (outside the images of its cluster boxes) take a miss's estimate untraced, and
//!   packets whose rays all miss the scene's box are not handed to the BVH;
//! - **render, no block culling**: the same with every block's camera rays made and tested
//!   against the box (`Experiments::cull_blocks` off): the per-ray cost of strata's layers,
//!   which the first render's ratio hides where much of the image sees nothing.
//!
//! `STRATA_OVERHEAD_SPP=N` renders N samples per pixel instead of 8 (the rays are held in
//! memory: about 0.4 GB per 8 spp on the helmet). Each pass of the render sweeps the whole
//! image; the bench renders with passes of at least [`MIN_PASS_SECONDS`] (the probe's one
//! sample in one tile in 16, then one pass to the end: what the default half second gives
//! these short renders) and its rays follow the same passes.
//!
//! `STRATA_OVERHEAD_AO_RAYS=1` (a comma-separated list) measures only those AO rays per hit
//! (default: 1,16).
//!
//! `STRATA_OVERHEAD_SCENE=FILE.gltf` measures another scene (its first camera, or without
//! one the framing `render` makes). The fewer camera rays hit, the harder the render/raw
//! ratio: a miss is a cheap ray, but its sample costs the render as much as a hit's (film
//! point, camera ray, film sums). The helmet covers a fifth of its image.
//!
//! All five run on the render's one-thread pool, and alternating rounds and taking the median
//! of per-round ratios cancels most of the drift of a shared machine. Printed: each way's
//! median Mrays/s, and the median ratios accel/raw packets (target ≥ 0.97: our layer costs
//! under 3%) and render/raw, against both raw ways (target ≥ 0.85).

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use indicatif::ProgressBar;
use strata::accel::{Accel, AccelOptions, Ray, SceneBox, OCCLUSION_PACKET, PACKET};
use strata::embree::RawRay;
use strata::integrators::{AoSettings, Integrator, Prepared};
use strata::render::{self, RenderSettings};
use strata::sampling::warps::square_to_cosine_hemisphere;
use strata::sampling::{Onb, PixelSampler, SamplerKind};
use strata::scene::{self, Camera, LoadOptions, Scene};
use strata::shading::interaction::SurfaceInteraction;

const W: u32 = 320;
const H: u32 = 240;
const TILE: u32 = 16;
const ROUNDS: usize = 15;
/// The render's `min_pass_seconds`: unbounded, so that its passes do not depend on the
/// machine's speed and the rays below can follow them.
const MIN_PASS_SECONDS: f64 = f64::INFINITY;

/// The samples that tile `tile` (scanline index) takes in each of the render's rounds, with
/// passes of at least [`MIN_PASS_SECONDS`]: one sample in the probe's tiles (every
/// [`render::PROBE_TILE_STRIDE`]-th), then all of them in one pass (`first_pass_end` of an
/// unbounded minimum is `spp`). Without a probe (1 spp), the one pass.
fn rounds(tile: usize, spp: u32) -> [Option<(u32, u32)>; 2] {
    assert_eq!(render::first_pass_end(spp, 1.0, MIN_PASS_SECONDS), spp);
    if spp == 1 {
        return [Some((0, 1)), None];
    }
    let probed = tile.is_multiple_of(render::PROBE_TILE_STRIDE);
    [probed.then_some((0, 1)), Some((probed as u32, spp))]
}

/// The rays of one AO render: camera rays grouped by packet (the block's pixels at one
/// sample index), and the AO rays in the groups the integrator traces together (with one ray
/// per hit, those of a camera packet's hits; with more, each hit's in packets of up to
/// [`OCCLUSION_PACKET`]; one query for a lone ray).
struct Rays {
    packets: Vec<Vec<Ray>>,
    ao_groups: Vec<Vec<Ray>>,
}

/// The scene's first camera; without one, the framing of its bounds that `render` makes.
fn camera(scene: &Scene) -> Camera {
    scene
        .cameras
        .first()
        .cloned()
        .unwrap_or_else(|| Camera::framing(scene.bounds.0, scene.bounds.1, W as f32 / H as f32))
}

/// The rays of an AO render with `n` rays per hit, generated as `render::render` and the AO
/// integrator do, in the render's order: round, 16×16 tile, 4×2-pixel block, sample, pixel.
fn render_rays(scene: &Scene, accel: &Accel, n: u32, spp: u32) -> Rays {
    let camera = camera(scene).ray_generator(W, H);
    let mut sampler = PixelSampler::new(SamplerKind::Sobol, spp, 0);
    let (mut packets, mut ao_groups) = (Vec::new(), Vec::new());
    for round in 0..2 {
        let mut tile = 0;
        for ty in (0..H).step_by(TILE as usize) {
            for tx in (0..W).step_by(TILE as usize) {
                tile += 1;
                let Some((s0, s1)) = rounds(tile - 1, spp)[round] else {
                    continue;
                };
                for by in (ty..(ty + TILE).min(H)).step_by(2) {
                    for bx in (tx..(tx + TILE).min(W)).step_by(4) {
                        for index in s0..s1 {
                            let mut packet = Vec::new();
                            for y in by..(by + 2).min(ty + TILE).min(H) {
                                for x in bx..(bx + 4).min(tx + TILE).min(W) {
                                    sampler.start(x, y, index);
                                    let film = sampler.next_2d();
                                    let ray = camera.ray(x as f32 + film.x, y as f32 + film.y);
                                    packet.push((ray, sampler.clone()));
                                }
                            }
                            // The hits as the render finds them: from one packet query
                            // (at an edge shared by two triangles, packet and single-ray
                            // traversal may name different ones; 1 ray in 4.9 M here).
                            let mut hits = [None; PACKET];
                            let camera_rays: Vec<Ray> = packet.iter().map(|(r, _)| *r).collect();
                            accel.intersect_packet(&camera_rays, &mut hits);
                            // With one ray per hit the packet's AO rays form one group.
                            let mut one_each = Vec::new();
                            for ((ray, mut sampler), hit) in packet.iter().cloned().zip(hits) {
                                let Some(hit) = hit else {
                                    continue;
                                };
                                let si = SurfaceInteraction::from_hit(scene, &ray, &hit);
                                let onb = Onb::from_normal(si.ns);
                                let set = sampler.next_2d_set(n);
                                let rays: Vec<Ray> = (0..n)
                                    .map(|k| onb.to_world(square_to_cosine_hemisphere(set.get(k))))
                                    .filter(|wi| wi.dot(si.ng) >= 0.0)
                                    .map(|wi| si.spawn_ray(wi, f32::INFINITY))
                                    .collect();
                                if n == 1 {
                                    one_each.extend(rays);
                                } else {
                                    ao_groups
                                        .extend(rays.chunks(OCCLUSION_PACKET).map(|c| c.to_vec()));
                                }
                            }
                            if !one_each.is_empty() {
                                ao_groups.push(one_each);
                            }
                            packets.push(camera_rays);
                        }
                    }
                }
            }
        }
    }
    Rays { packets, ao_groups }
}

fn raw(rays: &[Ray]) -> Vec<RawRay> {
    rays.iter()
        .map(|r| RawRay::new(r.org.to_array(), r.dir.to_array(), r.t_min, r.t_max))
        .collect()
}

/// A ray as the packet calls of the Embree module take it.
fn lanes(r: &Ray) -> strata::embree::Lane {
    (r.org.to_array(), r.dir.to_array(), r.t_min, r.t_max, 0)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    // `cargo bench` passes --bench; `cargo test --benches` runs this once as a smoke test.
    let quick = !std::env::args().any(|a| a == "--bench");
    strata::accel::enable_ftz_daz();
    let spp: u32 = std::env::var("STRATA_OVERHEAD_SPP").map_or(8, |s| {
        s.parse()
            .ok()
            .filter(|&n| n > 0)
            .expect("STRATA_OVERHEAD_SPP: a positive number of samples per pixel")
    });
    let path = std::env::var_os("STRATA_OVERHEAD_SCENE").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/flight-helmet.gltf"),
        Into::into,
    );
    let scene = scene::load(&path, &LoadOptions::default()).expect("scene");
    let accel = Accel::build(&scene, &AccelOptions::default()).expect("BVH");
    let pool = render::thread_pool(1).expect("thread pool");
    println!(
        "{} ({} triangles), AO {W}x{H} {spp} spp, 1 thread, {} rounds",
        path.file_name().unwrap_or_default().to_string_lossy(),
        scene.triangles.len(),
        if quick { 1 } else { ROUNDS }
    );
    let ao_rays: Vec<u32> = std::env::var("STRATA_OVERHEAD_AO_RAYS").map_or(vec![1, 16], |s| {
        s.split(',')
            .map(|n| n.trim().parse().ok().filter(|&n| n > 0))
            .collect::<Option<_>>()
            .expect("STRATA_OVERHEAD_AO_RAYS: AO rays per hit, a comma-separated list")
    });
    for n in ao_rays {
        pool.install(|| measure(&scene, &accel, &pool, n, spp, quick));
    }
}

/// Measures the five ways on the rays of an AO render with `n` rays per hit, and prints.
fn measure(scene: &Scene, accel: &Accel, pool: &rayon::ThreadPool, n: u32, spp: u32, quick: bool) {
    let embree = accel.as_embree().expect("Embree backend").raw();
    let Rays { packets, ao_groups } = render_rays(scene, accel, n, spp);
    // Copied in order, so that each way reads its rays from consecutive allocations: made
    // while the render's other allocations came and went, the packets lay scattered over the
    // heap, and the cache and TLB misses of reading them cost the `Accel` way a fifth of its
    // camera-ray time, against raw packets copied like this (measured).
    let packets: Vec<Vec<Ray>> = packets.iter().map(|p| p.to_vec()).collect();
    let ao_groups: Vec<Vec<Ray>> = ao_groups.iter().map(|g| g.to_vec()).collect();
    let camera_rays: Vec<Ray> = packets.iter().flatten().copied().collect();
    let ao_rays: Vec<Ray> = ao_groups.iter().flatten().copied().collect();
    let (raw_camera, raw_ao) = (raw(&camera_rays), raw(&ao_rays));
    let raw_packets: Vec<Vec<RawRay>> = packets.iter().map(|p| raw(p)).collect();
    let total = (camera_rays.len() + ao_rays.len()) as f64;
    let accel_camera_hits = || {
        let mut hits = [None; PACKET];
        packets
            .iter()
            .map(|p| {
                accel.intersect_packet(p, &mut hits);
                hits.iter().filter(|h| h.is_some()).count()
            })
            .sum::<usize>()
    };
    let accel_occluded = || {
        let mut occluded = [false; OCCLUSION_PACKET];
        ao_groups
            .iter()
            .map(|g| {
                accel.occluded_packet(g, &mut occluded);
                occluded[..g.len()].iter().filter(|&&o| o).count()
            })
            .sum::<usize>()
    };
    let raw_packet_hits = || {
        raw_packets
            .iter()
            .map(|p| embree.intersect8_count_raw(p, true))
            .sum::<usize>()
    };
    let raw_occluded_groups = || {
        let mut count = 0;
        for g in &ao_groups {
            embree.occluded_packet(g, lanes, |_, o| count += o as usize);
        }
        count
    };

    let prepared = Prepared::default();
    let ctx = prepared.context(scene, accel);
    let settings = RenderSettings {
        camera: camera(scene),
        crop: None,
        stopping: Default::default(),
        width: W,
        height: H,
        spp,
        seed: 0,
        sampler: SamplerKind::Sobol,
        integrator: Integrator::Ao(AoSettings {
            samples: n,
            ..AoSettings::default()
        }),
        tile_size: TILE,
        sample_range: None,
        min_pass_seconds: MIN_PASS_SECONDS,
    };
    // The render as it runs, and with every pixel block's camera rays generated and tested
    // against the box (no block culling): the per-ray cost of strata's layers.
    let ctx_all_blocks = strata::integrators::Context {
        experiments: strata::experiments::Experiments {
            cull_blocks: false,
            ..ctx.experiments
        },
        ..ctx
    };
    let render_with = |ctx| {
        render::render(
            ctx,
            &settings,
            pool,
            &ProgressBar::hidden(),
            &AtomicBool::new(false),
        )
    };
    let render_once = || render_with(&ctx);

    // The four ways must trace the same rays with the same answers.
    let hits_raw = embree.intersect_count_raw(&raw_camera);
    assert_eq!(hits_raw, raw_packet_hits(), "packet hits differ");
    assert_eq!(hits_raw, accel_camera_hits(), "Accel hits differ");
    let occluded_raw = embree.occluded_count_raw(&raw_ao);
    assert_eq!(occluded_raw, raw_occluded_groups(), "AO packets differ");
    assert_eq!(occluded_raw, accel_occluded(), "AO occlusion differs");
    let rendered = render_once().stats.rays;
    assert_eq!(
        (rendered.camera as usize, rendered.shadow as usize),
        (camera_rays.len(), ao_rays.len()),
        "the render traces other rays than the batches"
    );

    let rounds = if quick { 1 } else { ROUNDS };
    let mut t: [Vec<f64>; 5] = Default::default();
    for _ in 0..rounds {
        let start = Instant::now();
        let hits = embree.intersect_count_raw(&raw_camera) + embree.occluded_count_raw(&raw_ao);
        t[0].push(start.elapsed().as_secs_f64());
        std::hint::black_box(hits);

        let start = Instant::now();
        let hits = raw_packet_hits() + raw_occluded_groups();
        t[1].push(start.elapsed().as_secs_f64());
        std::hint::black_box(hits);

        let start = Instant::now();
        let hits = accel_camera_hits() + accel_occluded();
        t[2].push(start.elapsed().as_secs_f64());
        std::hint::black_box(hits);

        // The render's own timer.
        t[3].push(render_once().stats.seconds);
        t[4].push(render_with(&ctx_all_blocks).stats.seconds);
    }
    let ratio = |a: &[f64], b: &[f64]| median(a.iter().zip(b).map(|(x, y)| y / x).collect());
    let mrays = |t: &[f64]| total / median(t.to_vec()) / 1e6;
    println!(
        "{n} AO ray(s) per hit: {} camera rays ({} packets) + {} AO rays ({} groups)",
        camera_rays.len(),
        packets.len(),
        ao_rays.len(),
        ao_groups.len()
    );
    // The render hands no packet to the BVH whose rays all miss the scene's box; the raw
    // and `Accel` ways trace every packet.
    let scene_box = SceneBox::new(accel);
    let culled = packets.iter().filter(|p| scene_box.misses_all(p)).count();
    println!(
        "  camera packets outside the scene's box (not traced by the render): {culled} ({:.1}%)",
        100.0 * culled as f64 / packets.len() as f64
    );
    let culled_rays = render_once().stats.rays.culled;
    println!(
        "  camera rays the render culls (blocks that cannot see the scene, packets outside its box): {culled_rays} ({:.1}%)",
        100.0 * culled_rays as f64 / camera_rays.len() as f64
    );
    let [single, packet, through, whole, all_blocks] = &t;
    println!("  raw Embree, single rays   {:6.2} Mrays/s", mrays(single));
    println!("  raw Embree, packets       {:6.2} Mrays/s", mrays(packet));
    println!("  through Accel (packets)   {:6.2} Mrays/s", mrays(through));
    println!("  full AO render            {:6.2} Mrays/s", mrays(whole));
    println!(
        "  same, no block culling    {:6.2} Mrays/s",
        mrays(all_blocks)
    );
    println!(
        "  Accel / raw packets {:.3}; render / raw single {:.3}, render / raw packets {:.3} (medians of per-round ratios)",
        ratio(through, packet),
        ratio(whole, single),
        ratio(whole, packet)
    );
    println!(
        "  no block culling: render / raw single {:.3}, render / raw packets {:.3}",
        ratio(all_blocks, single),
        ratio(all_blocks, packet)
    );
}
