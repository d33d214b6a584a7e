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
//! With one AO ray per camera hit (the default) its direction is paired with the film
//! position, the two halves of one 4D point ([`PixelSampler::paired_with_film`]): in a pixel that
//! holds an edge, the samples on each side then have directions stratified among themselves
//! (0.36× the variance on the Cornell box's edges). With several, the `samples` directions of
//! a camera sample come from one dimension slot as one stratified set
//! ([`PixelSampler::next_2d_set`]), not from independent slots. Directions are drawn
//! around the shading normal; one that points below the geometric
//! surface would enter the object, and counts as occluded. Each AO ray is an any-hit query
//! leaving the surface as [`SurfaceInteraction::spawn_ray`] sends it (with several rays per
//! hit, from the origins of [`SurfaceInteraction::front_origins`], computed once per hit).

use glam::{Vec2, Vec3};

use crate::accel::{Hit, Ray, OCCLUSION_PACKET, PACKET};
use crate::integrators::{Context, RayCounts};
use crate::sampling::warps::{
    square_to_cosine_hemisphere, square_to_cosine_hemisphere_lanes, square_to_uniform_hemisphere,
};
use crate::sampling::{Onb, PixelSampler};
use crate::shading::interaction::SurfaceInteraction;

/// How AO directions are sampled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Hemisphere {
    #[default]
    Cosine,
    Uniform,
    /// Uniform directions WITHOUT the cos θ/pdf weight: a deliberately wrong estimator (it
    /// computes unweighted visibility), kept so reference tests can show they catch it.
    /// Not listed in the CLI's help.
    #[value(hide = true)]
    UniformUnweighted,
}

crate::display_as_value_name!(Hemisphere);

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

/// [`li`] for the camera rays of a packet (`rays[k]` with closest hit `hits[k]`, sampled by
/// `samplers[lanes[k]]`, estimate into `l[k]`). With one AO ray per hit, the packet's AO rays
/// go to Embree as one occlusion packet: they leave neighbouring points, which lets them share
/// traversal (1.03–1.18× the render's rate on seven scenes, BENCHMARKS.md), and Embree answers
/// them as it would one by one, so the estimates are those of [`li`] (tests/ao_rays.rs checks
/// every pixel of such packets against its ray traced alone). With more rays per hit, each
/// hit traces its own packets ([`li`]).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn li_packet(
    ctx: &Context,
    rays: &[Ray],
    hits: &[Option<Hit>],
    samplers: &mut [PixelSampler],
    lanes: &[usize],
    settings: &AoSettings,
    counts: &mut RayCounts,
    l: &mut [f32],
) {
    if settings.samples > 1 {
        for k in 0..rays.len() {
            let sampler = &mut samplers[lanes[k]];
            l[k] = li(ctx, hits[k], &rays[k], sampler, settings, counts);
        }
        return;
    }
    // Sweeps over the hits, each lane's work independent of the others': the surface
    // interactions; the sample points, computed side by side; the directions, warped four
    // at a time without branches when cosine-weighted (the concentric map's wedge test is a
    // coin toss per hit, which a branch per lane would mispredict); then the frames and the
    // rays. Each lane draws from its own sampler in the order `one_ray` does, so the rays
    // are its.
    let mut interactions = [None; PACKET];
    let (mut hit_lanes, mut hit_k) = ([0usize; PACKET], [0usize; PACKET]);
    let mut n_hits = 0;
    for k in 0..rays.len() {
        l[k] = 0.0;
        if let Some(hit) = &hits[k] {
            interactions[n_hits] = Some(SurfaceInteraction::from_hit(ctx.scene, &rays[k], hit));
            (hit_lanes[n_hits], hit_k[n_hits]) = (lanes[k], k);
            n_hits += 1;
        }
    }
    // Each direction is paired with its film position (see `one_ray`). Points past `n_hits`
    // are not used.
    let mut u = [Vec2::splat(0.5); PACKET];
    if ctx.experiments.ao_film_paired {
        for (u, &lane) in u.iter_mut().zip(&hit_lanes[..n_hits]) {
            *u = samplers[lane].paired_with_film();
        }
    } else {
        // A set of one point is the slot's `next_2d` point.
        PixelSampler::next_2d_lanes(samplers, &hit_lanes[..n_hits], &mut u[..n_hits]);
    }
    let directions: [(Vec3, f32); PACKET] = if settings.hemisphere == Hemisphere::Cosine {
        square_to_cosine_hemisphere_lanes(&u).map(|local| (local, 1.0))
    } else {
        u.map(|u| direction(u, settings.hemisphere))
    };
    let mut ao_rays = [Ray::new(Vec3::ZERO, Vec3::Z); PACKET];
    let mut owners = [(0usize, 0f32); PACKET];
    let mut m = 0;
    let interactions = interactions.iter().flatten();
    for ((&k, &(local, weight)), si) in hit_k[..n_hits].iter().zip(&directions).zip(interactions) {
        let onb = Onb::from_normal(si.ns);
        let wi = onb.to_world(local);
        // Written whether or not the direction can see the sky, and kept (m advanced) only
        // if it can: whether it can is a coin toss where shading normals bend, which a
        // branch would mispredict.
        ao_rays[m] = Ray {
            org: si.front_origin(wi, ctx.experiments.ray_offset),
            dir: wi,
            t_min: 0.0,
            t_max: settings.max_distance,
        };
        owners[m] = (k, weight);
        m += sees_sky(si, wi, weight) as usize;
    }
    let mut occluded = [false; OCCLUSION_PACKET];
    ctx.accel.occluded_packet(&ao_rays[..m], &mut occluded);
    counts.shadow += m as u64;
    for (&(k, weight), &o) in owners[..m].iter().zip(&occluded[..m]) {
        if !o {
            l[k] = weight;
        }
    }
}

/// The local direction of point `u` in the shading normal's hemisphere and its weight
/// cos θ / (π·pdf) (1 for cosine-weighted directions).
#[inline]
fn direction(u: Vec2, hemisphere: Hemisphere) -> (Vec3, f32) {
    match hemisphere {
        Hemisphere::Cosine => (square_to_cosine_hemisphere(u), 1.0),
        Hemisphere::Uniform => {
            let w = square_to_uniform_hemisphere(u);
            // (1/π)·cos θ / (1/(2π)) = 2 cos θ.
            (w, 2.0 * w.z)
        }
        Hemisphere::UniformUnweighted => (square_to_uniform_hemisphere(u), 1.0),
    }
}

/// The world direction of local direction `local` (weight `weight`) at the hit `si` with
/// frame `onb`, or None for a direction that cannot see the sky.
#[inline(always)]
fn world_direction(si: &SurfaceInteraction, onb: &Onb, local: Vec3, weight: f32) -> Option<Vec3> {
    let wi = onb.to_world(local);
    sees_sky(si, wi, weight).then_some(wi)
}

/// Whether an AO ray from `si` toward world direction `wi` with weight `weight` can see the
/// sky. A direction below the geometric surface enters the object: occluded. One exactly in
/// the tangent plane (u within 2⁻²⁴ of the square's edge puts cosine samples on the rim) is
/// traced: the offset origin lies above the surface, so on an open plane it escapes, as
/// every other sample does.
#[inline(always)]
fn sees_sky(si: &SurfaceInteraction, wi: Vec3, weight: f32) -> bool {
    !(wi.dot(si.ng) < 0.0 || weight == 0.0)
}

/// The one AO ray of a hit (with `samples` = 1) and its weight, from the dimension slot that
/// [`li`] draws; None where the direction cannot see the sky.
#[inline]
fn one_ray(
    ctx: &Context,
    hit: &Hit,
    ray: &Ray,
    sampler: &mut PixelSampler,
    settings: &AoSettings,
) -> Option<(Ray, f32)> {
    let si = SurfaceInteraction::from_hit(ctx.scene, ray, hit);
    // The direction is paired with the film position (stratified with it, for pixels that
    // hold an edge).
    let u = if ctx.experiments.ao_film_paired {
        sampler.paired_with_film()
    } else {
        sampler.next_2d_set(1).get(0)
    };
    let (local, weight) = direction(u, settings.hemisphere);
    let onb = Onb::from_normal(si.ns);
    let wi = world_direction(&si, &onb, local, weight)?;
    // Its one origin, where [`SurfaceInteraction::front_origins`] prepares both kinds for
    // many rays.
    let ray = si.spawn_ray_with(wi, settings.max_distance, ctx.experiments.ray_offset);
    Some((ray, weight))
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
    let n = settings.samples.max(1);
    if n == 1 {
        // One ray: a single query, and no packet to fill.
        let Some((ray, weight)) = one_ray(ctx, &hit, ray, sampler, settings) else {
            return 0.0;
        };
        rays.shadow += 1;
        return if accel.occluded(&ray) { 0.0 } else { weight };
    }
    let si = SurfaceInteraction::from_hit(scene, ray, &hit);
    let onb = Onb::from_normal(si.ns);
    // The n directions of this camera sample are one stratified set (one dimension slot).
    let set = sampler.next_2d_set(n);
    let origins = si.front_origins(ctx.experiments.ray_offset);
    let toward = |local: Vec3, weight: f32| {
        let wi = world_direction(&si, &onb, local, weight)?;
        Some((origins.ray(wi, settings.max_distance), weight))
    };
    // The rays leave one point, so they share the first nodes of their traversal: Embree's
    // packet queries pay for packets of up to 16 (8-wide 1.1x faster than single rays on 64
    // rays per hit, 16-wide another 1.1x; docs/journal/benchmarks-2026-11.md).
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
    // The directions in groups of a packet's size, with the points they came from;
    // cosine-weighted ones warped lane by lane (bit-identical to `direction`, tested in
    // warps.rs), which lets their arithmetic overlap.
    let group = |k0: u32, m: u32| -> Group {
        // Lanes past m repeat the last point; they are not used.
        let u: [Vec2; OCCLUSION_PACKET] =
            std::array::from_fn(|j| set.get(k0 + (j as u32).min(m - 1)));
        let rays = if settings.hemisphere == Hemisphere::Cosine {
            let local = square_to_cosine_hemisphere_lanes(&u);
            std::array::from_fn(|j| toward(local[j], 1.0))
        } else {
            std::array::from_fn(|j| {
                (j < m as usize)
                    .then(|| {
                        let (local, weight) = direction(u[j], settings.hemisphere);
                        toward(local, weight)
                    })
                    .flatten()
            })
        };
        (u, rays)
    };
    // Quadrants from 32 rays (packets of 8 or more); with 16 rays, four packets of four were
    // 0.94x as fast as one of 16.
    let sum = if n >= 2 * OCCLUSION_PACKET as u32 {
        unoccluded_sum::<4>(n, group, flush, rays)
    } else {
        unoccluded_sum::<1>(n, group, flush, rays)
    };
    sum / n as f32
}

/// Up to a packet's worth of AO directions (points k0..k0 + m of a set): the points, and the
/// rays with their weights (None for a direction that cannot see the sky).
type Group = (
    [Vec2; OCCLUSION_PACKET],
    [Option<(Ray, f32)>; OCCLUSION_PACKET],
);

/// The summed weights of the unoccluded rays among a hit's `n` AO rays, traced in packets
/// that each take the rays of one of `R` regions of the unit square (R = 1: the whole
/// square; R = 4: its quadrants).
///
/// The concentric map, and so the cosine warp, keeps the square's quadrants apart, so a
/// packet's directions then lie within a quarter of the hemisphere's azimuths instead of
/// spreading over all of them: the rays share more of their traversal (BENCHMARKS.md). A
/// Sobol set of 2^m ≥ 4 points is a (0, m, 2)-net, so each quadrant holds exactly 2^(m−2)
/// points. With cosine weights (all 1) the sum counts rays and is exact in any order.
#[inline(always)]
fn unoccluded_sum<const R: usize>(
    n: u32,
    group: impl Fn(u32, u32) -> Group,
    flush: impl Fn(&[Ray], &[f32], &mut RayCounts) -> f32,
    rays: &mut RayCounts,
) -> f32 {
    let mut packets = [[Ray::new(Vec3::ZERO, Vec3::Z); OCCLUSION_PACKET]; R];
    let mut weights = [[0f32; OCCLUSION_PACKET]; R];
    let mut filled = [0usize; R];
    let mut sum = 0.0;
    for k0 in (0..n).step_by(OCCLUSION_PACKET) {
        let m = (n - k0).min(OCCLUSION_PACKET as u32);
        let (u, group) = group(k0, m);
        for (u, ray) in u.iter().zip(&group[..m as usize]) {
            let Some((ray, weight)) = ray else { continue };
            let r = if R == 1 {
                0
            } else {
                (u.x >= 0.5) as usize + 2 * (u.y >= 0.5) as usize
            };
            packets[r][filled[r]] = *ray;
            weights[r][filled[r]] = *weight;
            filled[r] += 1;
            if filled[r] == OCCLUSION_PACKET {
                sum += flush(&packets[r], &weights[r], rays);
                filled[r] = 0;
            }
        }
    }
    for r in 0..R {
        if filled[r] > 0 {
            sum += flush(&packets[r][..filled[r]], &weights[r][..filled[r]], rays);
        }
    }
    sum
}
