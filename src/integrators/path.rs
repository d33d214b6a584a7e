//! Unidirectional path tracing with next-event estimation and multiple importance sampling;
//! with `max_depth = 1` it is the `direct` integrator.
//!
//! At every surface vertex one light is sampled (next-event estimation) and one direction is
//! drawn from the BSDF; an emitter reached by the BSDF direction is weighted against the
//! light-sampling pdf with the power heuristic (Veach 1995, §9.2), and delta lights are
//! reached by light sampling only, delta BSDF lobes by BSDF sampling only. Emitters seen
//! directly by the camera count in full. Surfaces scatter through
//! [`crate::shading::SurfaceBsdf`], lights and the environment come from
//! [`crate::shading::LightSet`]: the estimator is the same whatever the BSDFs and emitters.
//!
//! | parameter   | default | meaning                                                           |
//! |-------------|---------|-------------------------------------------------------------------|
//! | `max_depth` | 8       | bounces: 1 is direct lighting (Mitsuba `max_depth` = this + 1)    |
//! | `rr_depth`  | 5       | Russian roulette on the path throughput from this bounce on       |
//! | `strategy`  | mis     | `mis`, `light` (NEE only) or `bsdf` (BSDF sampling only, delta     |
//! |             |         | lights still by NEE): all three are unbiased; for comparisons     |
//!
//! Sample dimensions: the first surface vertex takes its light point from the film
//! position's slot (dimensions 0–1 of the 4D point whose dimensions 2–3 placed the sample in
//! the pixel, [`PixelSampler::paired_with_film`]); then each bounce draws one 4D slot, the BSDF
//! direction (its first two dimensions) and the light point of the vertex that direction
//! reaches (its last two), and one slot for Russian roulette (skipped, not computed,
//! before `rr_depth`) whose second dimension is the lobe number of a BSDF that reads one
//! (glass: [`crate::shading::LocalBsdf::reads_lobe_number`]; the slot is then computed at
//! every bounce). The light is chosen with the point's first dimension, which is then
//! reused for the point. All slots are drawn whether used or not, so a pixel's dimensions do
//! not shift between strategies. A path that meets a dispersive interface
//! (`KHR_materials_dispersion`) draws its wavelength there from one more dimension.
//!
//! Each light point is thus stratified jointly with what its light depends on most: the
//! first with where in the pixel the sample lies (an edge or a penumbra in the pixel: 66%
//! less direct-lighting variance on the Cornell box's edges), the others with the direction
//! that reached their vertex, the pair the one-bounce indirect light depends on (most of a
//! diffuse scene's noise: 7% less variance on the Cornell box at 256 spp, 11% at 1024). See
//! docs/journal/benchmarks-2026-11.md, "Sample layout". `Experiments::paired_bounces` =
//! false pairs each vertex's own direction and light point instead, the layout before, for
//! comparisons.
//!
//! With `sobol`, the bounces' 4D points are not padded apart (each from a sequence of its
//! own, Burley 2020) but are dimensions of one Sobol sequence, bounce k taking dimensions
//! 4(k − 1) to 4k − 1 ([`PixelSampler::next_bounce_2x2d`], up to 8 bounces): the two-bounce
//! light, which depends on two bounces' points at once, is then stratified too. On the
//! Cornell box this takes 7% off the squared error at 256 spp and 16% at 1024
//! (docs/journal/benchmarks-2026-11.md, "Bounces stratified jointly"). The film position's slot stays apart: joined to the
//! bounces, it would push the first bounce off dimensions 0–1, the best-stratified pair.
//! `Experiments::joint_bounces` = false pads them, for comparisons.

use glam::{Vec2, Vec3};

use super::{Context, RayCounts};
use crate::accel::{Hit, Ray};
use crate::sampling::PixelSampler;
use crate::shading::spectrum::Response;
use crate::shading::{Bsdf, Lambertian, ShadeAs, SurfaceInteraction};

/// Which sampling techniques contribute direct light.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Strategy {
    #[default]
    Mis,
    Light,
    Bsdf,
}

crate::display_as_value_name!(Strategy);

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSettings {
    pub max_depth: u32,
    pub rr_depth: u32,
    pub strategy: Strategy,
    /// Camera rays per sample that estimate the emission the camera sees directly, in the
    /// pixel blocks where an emitter may be seen (the renderer traces them, see
    /// [`crate::render`]); 0: the path's own camera ray alone, as elsewhere.
    pub emitter_samples: u32,
    /// Whether [`li`] adds the emission its camera ray meets (true, except where the renderer
    /// estimates that term apart with `emitter_samples` rays).
    pub camera_emission: bool,
}

impl Default for PathSettings {
    fn default() -> Self {
        PathSettings {
            max_depth: 8,
            rr_depth: 5,
            strategy: Strategy::Mis,
            emitter_samples: 16,
            camera_emission: true,
        }
    }
}

/// The power heuristic with β = 2 (Veach 1995).
#[inline]
fn power_heuristic(pdf_f: f32, pdf_g: f32) -> f32 {
    let (f, g) = (pdf_f * pdf_f, pdf_g * pdf_g);
    if f + g == 0.0 {
        0.0
    } else {
        f / (f + g)
    }
}

/// One estimate of the radiance along the camera ray, whose closest hit is `camera_hit`.
#[inline]
pub fn li(
    ctx: &Context,
    ray: &Ray,
    camera_hit: Option<Hit>,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    rays: &mut RayCounts,
) -> Vec3 {
    match ctx.materials.lambertian() {
        true => li_as::<Lambertian>(ctx, ray, camera_hit, sampler, settings, rays),
        false => li_as::<Bsdf>(ctx, ray, camera_hit, sampler, settings, rays),
    }
}

/// [`li`] compiled for the BSDF type `B` that materials give ([`ShadeAs`]): one source, an
/// instance per material model.
fn li_as<B: ShadeAs>(
    ctx: &Context,
    ray: &Ray,
    camera_hit: Option<Hit>,
    sampler: &mut PixelSampler,
    settings: &PathSettings,
    rays: &mut RayCounts,
) -> Vec3 {
    let (scene, lights, materials) = (ctx.scene, ctx.lights, ctx.materials);
    // What light sampling needs to see the holes of alpha-tested emitters.
    let coverage = ctx
        .accel
        .coverage()
        .filter(|_| lights.has_alpha_tested_emitters());
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let mut ray = *ray;
    // The previous vertex's BSDF pdf and position, for MIS of emitters the path reaches; None
    // for the camera vertex. After a delta lobe (`specular`), which light sampling cannot
    // follow, an emitter reached counts in full, as one the camera sees.
    let mut prev: Option<(f32, Vec3)> = None;
    let mut specular = false;
    let mut depth = 0;
    let mut next_hit = camera_hit;
    // The light point of the current vertex (when bounces are paired, drawn by the bounce
    // that reached it).
    let mut u_light = Vec2::ZERO;
    // The path's wavelength in nm, once it has met a dispersive interface.
    let mut wavelength: Option<f32> = None;
    loop {
        let Some(hit) = next_hit else {
            // Possibly add the environment, weighted against sampling it as a light (the
            // camera's own view of it may be a background of its own).
            // Radiance and weight from one lookup of the environment.
            let (le, w) = match (prev, settings.strategy) {
                (None, _) => (lights.camera_miss_radiance(ray.dir), 1.0),
                (Some(_), Strategy::Light) if !specular => (Vec3::ZERO, 0.0),
                (Some((pdf_bsdf, _)), Strategy::Mis) if !specular => {
                    let (le, pdf_light) = lights.environment_radiance_pdf(ray.dir);
                    (le, power_heuristic(pdf_bsdf, pdf_light))
                }
                // After a specular bounce, or under BSDF sampling alone: the whole radiance.
                (Some(_), _) => (lights.environment().radiance(ray.dir), 1.0),
            };
            if le.max_element() > 0.0 {
                l += beta * le * w;
            }
            break;
        };
        let si = SurfaceInteraction::from_hit(scene, &ray, &hit);
        // Beer–Lambert (KHR_materials_volume): a segment that ends on the inside of an
        // absorbing volume's boundary travelled through the medium, and keeps
        // exp(−σ_a t) of its light (the ray's direction has unit length, so t is the
        // distance).
        if materials.absorbing && !si.front_face {
            if let Some(sigma) = materials.absorption(scene, si.prim) {
                let t = hit.t;
                beta *= Vec3::new(
                    (-sigma.x * t).exp(),
                    (-sigma.y * t).exp(),
                    (-sigma.z * t).exp(),
                );
            }
        }
        let uv = materials.uv(scene, &si);

        // Emission of the surface the path reached, MIS-weighted unless the camera sees it
        // (and left to the caller if it estimates the camera's view of emitters apart).
        let le = materials.emitted(scene, &si, uv);
        if le.max_element() > 0.0 && (prev.is_some() || settings.camera_emission) {
            let w = match prev {
                None => 1.0,
                Some(_) if specular => 1.0,
                Some((pdf_bsdf, p_prev)) => match settings.strategy {
                    Strategy::Mis => {
                        let pdf_light = lights.triangle_pdf(si.prim, si.inst, p_prev, si.p, hit.ng);
                        power_heuristic(pdf_bsdf, pdf_light)
                    }
                    Strategy::Bsdf => 1.0,
                    Strategy::Light => 0.0,
                },
            };
            l += beta * le * w;
        }
        if depth == settings.max_depth {
            break;
        }
        depth += 1;

        let bsdf = materials.bsdf_as::<B>(scene, &si, uv);
        // The slots of the bounce (see the module docs).
        let (u_bsdf, u_light_next) = if ctx.experiments.paired_bounces {
            if depth == 1 {
                u_light = sampler.paired_with_film();
            }
            bounce_2x2d(sampler, depth, ctx.experiments.joint_bounces)
        } else {
            let (u_bsdf, u_own) = bounce_2x2d(sampler, depth, ctx.experiments.joint_bounces);
            u_light = u_own;
            (u_bsdf, Vec2::ZERO)
        };
        // The roulette's slot is computed only where the roulette runs or the BSDF reads a
        // lobe number, which is then the slot's second dimension.
        let (u_rr, u_lobe) = match (depth >= settings.rr_depth, bsdf.reads_lobe_number()) {
            (_, true) => {
                let u = sampler.next_2d();
                (u.x, u.y)
            }
            (true, false) => (sampler.next_1d(), 0.0),
            (false, false) => {
                sampler.skip_slot();
                (1.0, 0.0)
            }
        };
        // Dispersion: the path's wavelength, drawn at its first dispersive interface (one
        // more dimension, after this bounce's slots), weights its throughput by the channels'
        // responses over its density ([`Response::sample`]) and holds from then on.
        let bsdf = match bsdf.disperses() {
            false => bsdf,
            true => {
                let lambda = *wavelength.get_or_insert_with(|| {
                    let (lambda, weight) = Response::get().sample(sampler.next_1d());
                    beta *= weight;
                    lambda
                });
                bsdf.at_wavelength(lambda)
            }
        };

        // Next-event estimation: sample a light, test visibility, weight against the BSDF
        // (not through delta lobes, which no light sample can hit).
        // BSDF sampling alone leaves to itself every emitter a ray can reach, and samples
        // only the delta lights it cannot.
        let deltas_only = settings.strategy == Strategy::Bsdf;
        let light = match bsdf.flags().has_non_specular() {
            true => lights.sample(scene, materials, coverage, &si, u_light, deltas_only),
            false => None,
        };
        if let Some((ls, pmf)) = light {
            // MIS weighs an area light's sample by the BSDF's pdf too: both at once.
            let mis = !ls.is_delta && settings.strategy == Strategy::Mis;
            let (f, pdf_bsdf) = match mis {
                true => bsdf.eval_pdf(ls.wi),
                false => (bsdf.eval(ls.wi), 0.0),
            };
            if ls.pdf > 0.0 && ls.li.max_element() > 0.0 && f.max_element() > 0.0 {
                let pdf_light = pmf * ls.pdf;
                let w = match mis {
                    true => power_heuristic(pdf_light, pdf_bsdf),
                    false => 1.0,
                };
                let shadow = if ls.infinite {
                    si.spawn_ray_with(ls.wi, f32::INFINITY, ctx.experiments.ray_offset)
                } else {
                    si.spawn_ray_to_with(ls.p_light, ctx.experiments.ray_offset)
                };
                rays.shadow += 1;
                if !ctx.accel.occluded(&shadow) {
                    l += beta * f * ls.li * (w / pdf_light);
                }
            }
        }

        // After the last bounce the extension ray only serves to find emitters by BSDF
        // sampling: skip it when only delta lights exist.
        if depth == settings.max_depth && !lights.has_reachable_emitters() {
            break;
        }

        // Sample the BSDF for the next direction.
        let Some(bs) = bsdf.sample(u_lobe, u_bsdf) else {
            break;
        };
        beta *= bs.f_cos / bs.pdf;
        if beta.max_element() <= 0.0 {
            break;
        }
        // Possibly terminate the path with Russian roulette.
        if depth >= settings.rr_depth {
            let q = beta.max_element().min(0.95);
            if u_rr >= q {
                break;
            }
            beta /= q;
        }
        specular = bs.flags.is_specular();
        prev = Some((bs.pdf, si.p));
        u_light = u_light_next;
        ray = si.spawn_ray_with(bs.wi, f32::INFINITY, ctx.experiments.ray_offset);
        rays.extension += 1;
        next_hit = ctx.accel.intersect(&ray);
    }
    l
}

/// Bounce `depth`'s 4D slot: jointly stratified with the other bounces', or padded.
#[inline]
fn bounce_2x2d(sampler: &mut PixelSampler, depth: u32, joint: bool) -> (Vec2, Vec2) {
    if joint {
        sampler.next_bounce_2x2d(depth)
    } else {
        sampler.next_2x2d()
    }
}

/// The emission that camera ray `ray`, whose closest hit is `hit`, sees: the term [`li`]
/// adds first (and leaves out when `camera_emission` is false), the same value without the
/// surface interaction that [`li`] builds.
#[inline]
pub fn camera_emission(ctx: &Context, ray: &Ray, hit: Option<Hit>) -> Vec3 {
    match hit {
        Some(h) if ctx.materials.is_emissive_triangle(ctx.scene, h.prim) => {
            let front = h.ng.dot(ray.dir) < 0.0;
            ctx.materials
                .emitted_at(ctx.scene, h.prim, glam::Vec2::new(h.u, h.v), front)
        }
        _ => Vec3::ZERO,
    }
}
