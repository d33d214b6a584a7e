//! The AO integrator traces a hit's rays in packets, filled by region of the unit square when
//! there are many (`integrators::ao`): its estimate must still count each ray of the hit's set
//! exactly once, with the answer of that ray. Here every estimate is recomputed from the
//! set's points, each ray traced alone (`Accel::occluded`) from `SurfaceInteraction::spawn_ray`,
//! on the flight helmet, whose hits see partial occlusion.

use std::path::Path;

use glam::Vec3;
use strata::accel::{Accel, AccelOptions};
use strata::integrators::{ao, AoSettings, Hemisphere, Integrator, Prepared, RayCounts};
use strata::interaction::SurfaceInteraction;
use strata::sampling::warps::{square_to_cosine_hemisphere, square_to_uniform_hemisphere};
use strata::sampling::{Onb, PixelSampler, SamplerKind};
use strata::scene::{self, LoadOptions};

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

#[test]
fn each_ao_ray_of_a_hit_is_counted_once_with_its_own_answer() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/flight-helmet.gltf");
    let scene = scene::load(&path, &LoadOptions::default()).unwrap();
    let accel = Accel::build(&scene, &AccelOptions::default()).unwrap();
    let integrator = Integrator::Ao(AoSettings::default());
    let prepared = Prepared::new(&scene, &path, &integrator, Vec3::ZERO).unwrap();
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
