//! Ambient occlusion.
//!
//! AO(x) = (1/π) ∫_{H²(n_s)} V(x, ω) cos θ dω, with V = 1 when the ray from x in direction ω
//! meets nothing within `max_distance` (default: unlimited). A camera ray that misses gives 0.
//! The Mitsuba equivalent is a white (ρ = 1) Lambertian world under a constant environment of
//! radiance 1, lit directly only.
//!
//! | parameter      | default  | meaning                                                        |
//! |----------------|----------|----------------------------------------------------------------|
//! | `max_distance` | ∞        | occluders farther than this are ignored (`--ao-distance`)      |
//! | `hemisphere`   | cosine   | `cosine`: directions with pdf cos θ/π, estimate V;             |
//! |                |          | `uniform`: pdf 1/(2π), estimate 2·V·cos θ (same mean, more var) |
//! | `samples`      | 1        | AO rays per camera hit, averaged (`--ao-samples`; Mitsuba's     |
//! |                |          | `shading_samples`)                                             |
//!
//! The `samples` directions of a camera sample come from one dimension slot as one stratified
//! set ([`PixelSampler::next_2d_set`]), not from independent slots. Directions are drawn
//! around the shading normal; one that points below the geometric
//! surface would enter the object, and counts as occluded. Each AO ray is an any-hit query
//! leaving the surface as [`SurfaceInteraction::spawn_ray`] would send it (from the origins
//! of [`SurfaceInteraction::front_origins`], computed once per hit).

use std::fmt;
use std::str::FromStr;

use glam::{Vec2, Vec3};

use crate::accel::{Hit, Ray, OCCLUSION_PACKET};
use crate::integrators::{Context, RayCounts};
use crate::interaction::SurfaceInteraction;
use crate::sampling::warps::{
    square_to_cosine_hemisphere, square_to_cosine_hemisphere_lanes, square_to_uniform_hemisphere,
};
use crate::sampling::{Onb, PixelSampler};

/// How AO directions are sampled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Hemisphere {
    #[default]
    Cosine,
    Uniform,
    /// Uniform directions WITHOUT the cos θ/pdf weight: a deliberately wrong estimator (it
    /// computes unweighted visibility), kept so reference tests can show they catch it.
    /// Not listed in the CLI's help.
    UniformUnweighted,
}

impl FromStr for Hemisphere {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "cosine" => Ok(Hemisphere::Cosine),
            "uniform" => Ok(Hemisphere::Uniform),
            "uniform-unweighted" => Ok(Hemisphere::UniformUnweighted),
            other => Err(format!(
                "unknown hemisphere sampling '{other}' (cosine, uniform)"
            )),
        }
    }
}

impl fmt::Display for Hemisphere {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Hemisphere::Cosine => "cosine",
            Hemisphere::Uniform => "uniform",
            Hemisphere::UniformUnweighted => "uniform-unweighted",
        })
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoSettings {
    pub max_distance: f32,
    pub hemisphere: Hemisphere,
    /// AO rays per camera hit (at least 1).
    pub samples: u32,
}

impl Default for AoSettings {
    fn default() -> Self {
        AoSettings {
            max_distance: f32::INFINITY,
            hemisphere: Hemisphere::Cosine,
            samples: 1,
        }
    }
}

/// One AO estimate along the camera ray.
#[inline]
pub fn li(
    ctx: &Context,
    camera_hit: Option<Hit>,
    ray: &Ray,
    sampler: &mut PixelSampler,
    settings: &AoSettings,
    rays: &mut RayCounts,
) -> f32 {
    let (scene, accel) = (ctx.scene, ctx.accel);
    let Some(hit) = camera_hit else {
        return 0.0;
    };
    let si = SurfaceInteraction::from_hit(scene, ray, &hit);
    let onb = Onb::from_normal(si.ns);
    let n = settings.samples.max(1);
    // The n directions of this camera sample are one stratified set (one dimension slot).
    let set = sampler.next_2d_set(n);
    let origins = si.front_origins(ctx.ray_offset);
    // The ray toward local direction `local` with its weight, or None for a direction that
    // cannot see the sky.
    let ray_toward = |local: Vec3, weight: f32| -> Option<(Ray, f32)> {
        let wi = onb.to_world(local);
        // A direction below the geometric surface enters the object: occluded. One exactly in
        // the tangent plane (u within 2⁻²⁴ of the square's edge puts cosine samples on the rim)
        // is traced: the offset origin lies above the surface, so on an open plane it escapes,
        // as every other sample does.
        if wi.dot(si.ng) < 0.0 || weight == 0.0 {
            return None;
        }
        Some((origins.ray(wi, settings.max_distance), weight))
    };
    // Direction k, sampled in the shading normal's hemisphere and weighted by
    // cos θ / (π·pdf).
    let sample = |k: u32| -> Option<(Ray, f32)> {
        let u = set.get(k);
        let (local, weight) = match settings.hemisphere {
            Hemisphere::Cosine => (square_to_cosine_hemisphere(u), 1.0),
            Hemisphere::Uniform => {
                let w = square_to_uniform_hemisphere(u);
                // (1/π)·cos θ / (1/(2π)) = 2 cos θ.
                (w, 2.0 * w.z)
            }
            Hemisphere::UniformUnweighted => (square_to_uniform_hemisphere(u), 1.0),
        };
        ray_toward(local, weight)
    };
    if n == 1 {
        // One ray: a single query, and no packet to fill.
        let Some((ray, weight)) = sample(0) else {
            return 0.0;
        };
        rays.shadow += 1;
        return if accel.occluded(&ray) { 0.0 } else { weight };
    }
    // The rays leave one point, so they share the first nodes of their traversal: Embree's
    // packet queries pay for packets of up to 16 (8-wide 1.1x faster than single rays on 64
    // rays per hit, 16-wide another 1.1x; BENCHMARKS.md).
    let flush = |packet: &[Ray], weights: &[f32], rays: &mut RayCounts| {
        let mut occluded = [false; OCCLUSION_PACKET];
        accel.occluded_packet(packet, &mut occluded);
        rays.shadow += packet.len() as u64;
        let mut s = 0.0;
        for (w, o) in weights.iter().zip(occluded) {
            if !o {
                s += w;
            }
        }
        s
    };
    let mut sum = 0.0;
    let mut packet = [Ray::new(Vec3::ZERO, Vec3::Z); OCCLUSION_PACKET];
    let mut weights = [0f32; OCCLUSION_PACKET];
    let mut filled = 0;
    // The directions in groups of a packet's size; cosine-weighted ones warped lane by lane
    // (bit-identical to `sample`, tested in warps.rs), which lets their arithmetic overlap.
    for k0 in (0..n).step_by(OCCLUSION_PACKET) {
        let m = (n - k0).min(OCCLUSION_PACKET as u32);
        let group: [Option<(Ray, f32)>; OCCLUSION_PACKET] =
            if settings.hemisphere == Hemisphere::Cosine {
                // Lanes past m repeat the last point; their directions are not used.
                let u: [Vec2; OCCLUSION_PACKET] =
                    std::array::from_fn(|j| set.get(k0 + (j as u32).min(m - 1)));
                let local = square_to_cosine_hemisphere_lanes(&u);
                std::array::from_fn(|j| ray_toward(local[j], 1.0))
            } else {
                std::array::from_fn(|j| (j < m as usize).then(|| sample(k0 + j as u32)).flatten())
            };
        for (ray, weight) in group[..m as usize].iter().flatten() {
            packet[filled] = *ray;
            weights[filled] = *weight;
            filled += 1;
            if filled == OCCLUSION_PACKET {
                sum += flush(&packet, &weights, rays);
                filled = 0;
            }
        }
    }
    if filled > 0 {
        sum += flush(&packet[..filled], &weights[..filled], rays);
    }
    sum / n as f32
}
