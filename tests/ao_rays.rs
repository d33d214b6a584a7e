//! The AO integrator traces a hit's rays in packets, filled by region of the unit square when
//! there are many (`integrators::ao`): its estimate must still count each ray of the hit's set
//! exactly once, with the answer of that ray. Here every estimate is recomputed from the
//! set's points, each ray traced alone (`Accel::occluded`) from `SurfaceInteraction::spawn_ray`,
//! on the flight helmet, whose hits see partial occlusion.

use std::path::Path;

use glam::Vec3;
use strata::accel::{Accel, AccelOptions};
use strata::integrators::{ao, AoSettings, Hemisphere, Integrator, Prepared, RayCounts};
use strata::sampling::warps::{square_to_cosine_hemisphere, square_to_uniform_hemisphere};
use strata::sampling::{Onb, PixelSampler, SamplerKind};
use strata::scene::{self, LoadOptions, Scene};
use strata::shading::interaction::SurfaceInteraction;

const SIZE: u32 = 48;
const SPP: u32 = 2;

/// The estimate of `n` rays per hit from single-ray queries, and the number of rays traced.
fn single_ray_estimate(
    accel: &Accel,
    si: &SurfaceInteraction,
    sampler: &mut PixelSampler,
    n: u32,
    hemisphere: Hemisphere,
) -> (f32, u64) {
    let onb = Onb::from_normal(si.ns);
    let set = sampler.next_2d_set(n);
    let (mut sum, mut traced) = (0.0f32, 0u64);
    for k in 0..n {
        let u = set.get(k);
        let (local, weight) = match hemisphere {
            Hemisphere::Cosine => (square_to_cosine_hemisphere(u), 1.0),
            _ => {
                let w = square_to_uniform_hemisphere(u);
                (w, 2.0 * w.z)
            }
        };
        let wi = onb.to_world(local);
        if wi.dot(si.ng) < 0.0 || weight == 0.0 {
            continue;
        }
        traced += 1;
        if !accel.occluded(&si.spawn_ray(wi, f32::INFINITY)) {
            sum += weight;
        }
    }
    (sum / n as f32, traced)
}

/// The flight helmet, whose hits see partial occlusion, with its BVH and what the AO
/// integrator prepares.
fn helmet() -> (Scene, Accel, Prepared) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/flight-helmet.gltf");
    let scene = scene::load(&path, &LoadOptions::default()).unwrap();
    let accel = Accel::build(&scene, &AccelOptions::default()).unwrap();
    let integrator = Integrator::Ao(AoSettings::default());
    let prepared = Prepared::new(&scene, &path, &integrator, Vec3::ZERO).unwrap();
    (scene, accel, prepared)
}

#[test]
fn each_ao_ray_of_a_hit_is_counted_once_with_its_own_answer() {
    let (scene, accel, prepared) = helmet();
    let ctx = prepared.context(&scene, &accel);
    let camera = &scene.cameras[0];
    // Counts below 16, 16 itself, the first counts with quadrant packets (32, 33), full
    // quadrants (64, 128) and a count that fills no packet evenly (100).
    let counts = [1, 2, 16, 31, 32, 33, 64, 100, 128];
    let mut failures = Vec::new();
    let mut partial = 0;
    for sampler_kind in [
        SamplerKind::Sobol,
        SamplerKind::Stratified,
        SamplerKind::Random,
    ] {
        for hemisphere in [Hemisphere::Cosine, Hemisphere::Uniform] {
            for n in counts {
                let settings = AoSettings {
                    hemisphere,
                    samples: n,
                    ..AoSettings::default()
                };
                let mut ours = PixelSampler::new(sampler_kind, SPP, 5);
                let mut theirs = PixelSampler::new(sampler_kind, SPP, 5);
                for y in 0..SIZE {
                    for x in 0..SIZE {
                        let ray = camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, SIZE, SIZE);
                        let Some(hit) = accel.intersect(&ray) else {
                            continue;
                        };
                        let si = SurfaceInteraction::from_hit(&scene, &ray, &hit);
                        for i in 0..SPP {
                            ours.start(x, y, i);
                            theirs.start(x, y, i);
                            let mut rays = RayCounts::default();
                            let got =
                                ao::li(&ctx, Some(hit), &ray, &mut ours, &settings, &mut rays);
                            let (want, traced) =
                                single_ray_estimate(&accel, &si, &mut theirs, n, hemisphere);
                            // Cosine estimates count rays: exact in any order. Uniform ones sum
                            // weights, whose rounding depends on the order of the packets.
                            let close = match hemisphere {
                                Hemisphere::Cosine => got == want,
                                _ => (got - want).abs() <= 1e-6 * want.abs().max(1.0),
                            };
                            if !close || rays.shadow != traced {
                                failures.push(format!(
                                    "{sampler_kind} {hemisphere} n={n} pixel ({x}, {y}) sample {i}: \
                                     {got} from {} rays, single rays give {want} from {traced}",
                                    rays.shadow
                                ));
                            }
                            if want > 0.0 && want < 1.0 {
                                partial += 1;
                            }
                        }
                    }
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} estimates differ, first: {}",
        failures.len(),
        failures[..failures.len().min(5)].join("\n")
    );
    // The comparison has teeth only where rays disagree among themselves.
    assert!(
        partial > 10_000,
        "only {partial} partially occluded estimates"
    );
}

/// With one AO ray per hit, the render traces the AO rays of a camera packet's hits (up to
/// eight neighbouring pixels) as one occlusion packet (`ao::li_packet`): each pixel's estimate
/// must still be its own ray's answer. Blocks of 4×2 pixels, part-filled at the image's edges
/// and with some lanes left out (as adaptive rounds leave them), camera rays that miss, three
/// samplers and both hemispheres; with two rays per hit it falls back to `ao::li` per hit.
#[test]
fn packets_of_neighbouring_hits_keep_each_pixels_answer() {
    use strata::accel::PACKET;
    let (scene, accel, prepared) = helmet();
    let default_ctx = prepared.context(&scene, &accel);
    let camera = &scene.cameras[0];
    let (w, h) = (SIZE - 2, SIZE - 3);
    let (mut failures, mut partial, mut packets) = (Vec::new(), 0, 0);
    for sampler_kind in [
        SamplerKind::Sobol,
        SamplerKind::Stratified,
        SamplerKind::Random,
    ] {
        for hemisphere in [Hemisphere::Cosine, Hemisphere::Uniform] {
            // One ray per hit with its direction paired with the film position (the default)
            // or from a slot of its own, and two rays per hit.
            for (n, film_paired) in [(1, true), (1, false), (2, true)] {
                let settings = AoSettings {
                    hemisphere,
                    samples: n,
                    ..AoSettings::default()
                };
                let ctx = strata::integrators::Context {
                    experiments: strata::experiments::Experiments {
                        ao_film_paired: film_paired,
                        ..Default::default()
                    },
                    ..default_ctx
                };
                let mut samplers: [PixelSampler; PACKET] =
                    std::array::from_fn(|_| PixelSampler::new(sampler_kind, SPP, 5));
                let mut theirs = PixelSampler::new(sampler_kind, SPP, 5);
                for (b, (by, bx)) in (0..h)
                    .step_by(2)
                    .flat_map(|by| (0..w).step_by(4).map(move |bx| (by, bx)))
                    .enumerate()
                {
                    let pixels: Vec<(u32, u32)> = (by..(by + 2).min(h))
                        .flat_map(|y| (bx..(bx + 4).min(w)).map(move |x| (x, y)))
                        .collect();
                    // Every third block leaves lane 2 out.
                    let lanes: Vec<usize> = (0..pixels.len())
                        .filter(|&k| !(b % 3 == 0 && k == 2))
                        .collect();
                    for i in 0..SPP {
                        let rays: Vec<_> = lanes
                            .iter()
                            .map(|&k| {
                                let (x, y) = pixels[k];
                                camera.generate_ray(x as f32 + 0.3, y as f32 + 0.7, w, h)
                            })
                            .collect();
                        let hits: Vec<_> = rays.iter().map(|r| accel.intersect(r)).collect();
                        for &k in &lanes {
                            let (x, y) = pixels[k];
                            samplers[k].start(x, y, i);
                        }
                        let mut counts = RayCounts::default();
                        let mut got = vec![f32::NAN; lanes.len()];
                        ao::li_packet(
                            &ctx,
                            &rays,
                            &hits,
                            &mut samplers,
                            &lanes,
                            &settings,
                            &mut counts,
                            &mut got,
                        );
                        packets += 1;
                        let mut traced_all = 0;
                        for (j, &k) in lanes.iter().enumerate() {
                            let (x, y) = pixels[k];
                            theirs.start(x, y, i);
                            let (want, traced) = match hits[j] {
                                Some(hit) => {
                                    let si = SurfaceInteraction::from_hit(&scene, &rays[j], &hit);
                                    single_ray_estimate(&accel, &si, &mut theirs, n, hemisphere)
                                }
                                None => (0.0, 0),
                            };
                            traced_all += traced;
                            let close = match hemisphere {
                                Hemisphere::Cosine => got[j] == want,
                                _ => (got[j] - want).abs() <= 1e-6 * want.abs().max(1.0),
                            };
                            if !close {
                                failures.push(format!(
                                    "{sampler_kind} {hemisphere} n={n} paired={film_paired} pixel ({x}, {y}) sample \
                                     {i}: {} in the packet, {want} from single rays",
                                    got[j]
                                ));
                            }
                            partial += (want > 0.0 && want < 1.0) as usize;
                        }
                        if counts.shadow != traced_all {
                            failures.push(format!(
                                "{sampler_kind} {hemisphere} n={n} paired={film_paired} block at ({bx}, {by}) \
                                 sample {i}: {} rays traced, single rays trace {traced_all}",
                                counts.shadow
                            ));
                        }
                    }
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} estimates differ, first: {}",
        failures.len(),
        failures[..failures.len().min(5)].join("\n")
    );
    assert!(packets > 1000, "{packets} packets");
    // Cosine estimates of one ray are 0 or 1: the comparison needs hits that disagree among
    // themselves, which the uniform and two-ray estimates give.
    assert!(
        partial > 1000,
        "only {partial} partially occluded estimates"
    );
}
