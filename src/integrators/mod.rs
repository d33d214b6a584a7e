//! Integrators: estimators of the radiance arriving along a camera ray.
//!
//! A closed set dispatched by `match`. Each takes the primary ray and the pixel sample's
//! [`PixelSampler`], draws its dimensions in a fixed order, and returns one estimate.

pub mod ao;
pub mod path;
pub mod path_lanes;

use glam::{Vec3, Vec3A};

use crate::accel::{Accel, Hit, Ray, PACKET};
use crate::lights::{BackgroundSampling, LightSet};
use crate::material::{Materials, Need};
use crate::sampling::PixelSampler;
use crate::scene::Scene;

pub use ao::{AoSettings, Hemisphere};
pub use path::{PathSettings, Strategy};

/// Everything an integrator reads: geometry, its acceleration structure, the prepared
/// materials and the light set.
#[derive(Clone, Copy)]
pub struct Context<'a> {
    pub scene: &'a Scene,
    pub accel: &'a Accel,
    pub materials: &'a Materials,
    pub lights: &'a LightSet,
    /// Secondary rays leave surfaces past the hit point's error bound (true, the default and
    /// the only correct setting). False spawns them from the hit point itself: a negative
    /// control for tests/stress_numerics.rs, which must then see self-intersection (acne).
    pub ray_offset: bool,
    /// Trace camera rays of neighbouring pixels in packets ([`Accel::intersect_packet`]):
    /// the default. The hits, and so the image, are the same either way (tested), but for a
    /// ray that meets an edge shared by two triangles at one distance, where packet and
    /// single-ray traversal may report different triangles (1 camera ray in 4.9 M on the
    /// helmet, BENCHMARKS.md); false is for measuring what packets gain.
    pub camera_packets: bool,
    /// Leave untraced the pixel blocks that cannot see the scene
    /// ([`crate::render::culling::BlockMask`]), giving their samples the estimate of a
    /// camera ray that misses (the default; the image is the same either way, tested).
    /// False is for measuring the cost of strata's layers per traced ray.
    pub cull_blocks: bool,
    /// Path-trace a camera packet's paths together in SIMD lanes ([`path_lanes`]) where the
    /// scene and settings allow it: the default. The image is the same bit for bit (tested);
    /// false shades them one path at a time, for measuring what the lanes gain.
    pub path_lanes: bool,
}

/// The materials and lights an integrator needs, prepared once per render: nothing for AO;
/// decoded textures and the light set for direct lighting and path tracing.
#[derive(Clone, Debug, Default)]
pub struct Prepared {
    pub materials: Materials,
    pub lights: LightSet,
}

impl Prepared {
    /// Prepares what `integrator` reads of `scene` (loaded from `scene_path`, for messages),
    /// with a constant `background` radiance.
    pub fn new(
        scene: &Scene,
        scene_path: &std::path::Path,
        integrator: &Integrator,
        background: Vec3,
    ) -> Result<Prepared, String> {
        let materials = Materials::prepare(scene, scene_path, integrator.material_need())?;
        let lights = if integrator.needs_lights() {
            LightSet::build(
                scene,
                &materials,
                background,
                integrator.background_sampling(),
            )
        } else {
            LightSet::default()
        };
        Ok(Prepared { materials, lights })
    }

    /// The integrator context for `scene` traced through `accel`.
    pub fn context<'a>(&'a self, scene: &'a Scene, accel: &'a Accel) -> Context<'a> {
        Context {
            scene,
            accel,
            materials: &self.materials,
            lights: &self.lights,
            ray_offset: true,
            camera_packets: true,
            cull_blocks: true,
            path_lanes: true,
        }
    }
}

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    pub camera: u64,
    /// Closest-hit rays that continue a path after a bounce.
    pub extension: u64,
    /// Any-hit rays: shadow rays toward lights, and ambient-occlusion rays.
    pub shadow: u64,
    /// Camera rays, counted in `camera`, that the renderer found to miss the scene without
    /// traversal: those of pixel blocks that cannot see it ([`crate::render::culling`]), and
    /// of packets whose rays all miss the scene's box. They were not traced.
    pub culled: u64,
    /// Camera rays traced before the render, through pixel corners, to find the pixels
    /// that see an emitter whole (the renderer's `emitters` module).
    pub probe: u64,
}

impl RayCounts {
    /// Rays of every kind, the culled camera rays included.
    pub fn total(&self) -> u64 {
        self.camera + self.extension + self.shadow + self.probe
    }

    /// Rays that went to the BVH: [`RayCounts::total`] without the culled camera rays.
    pub fn traced(&self) -> u64 {
        self.total() - self.culled
    }

    pub fn add(&mut self, other: &RayCounts) {
        self.camera += other.camera;
        self.extension += other.extension;
        self.shadow += other.shadow;
        self.culled += other.culled;
        self.probe += other.probe;
    }
}

/// Which integrator renders the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum IntegratorKind {
    #[default]
    Ao,
    Direct,
    Path,
}

crate::display_as_value_name!(IntegratorKind);

/// An integrator with its settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Integrator {
    Ao(AoSettings),
    /// Direct lighting: the path tracer stopped after one bounce.
    Direct(PathSettings),
    Path(PathSettings),
}

impl Integrator {
    pub fn kind(&self) -> IntegratorKind {
        match self {
            Integrator::Ao(_) => IntegratorKind::Ao,
            Integrator::Direct(_) => IntegratorKind::Direct,
            Integrator::Path(_) => IntegratorKind::Path,
        }
    }

    /// What the integrator reads from materials (AO reads none).
    pub fn material_need(&self) -> Need {
        match self {
            Integrator::Ao(_) => Need::Nothing,
            Integrator::Direct(_) | Integrator::Path(_) => Need::Shading,
        }
    }

    /// How light sampling treats the constant background: only `--strategy light` needs
    /// light samples of it; otherwise BSDF samples find it at less cost (see [`crate::lights`]).
    pub fn background_sampling(&self) -> BackgroundSampling {
        match self {
            Integrator::Direct(s) | Integrator::Path(s) if s.strategy == Strategy::Light => {
                BackgroundSampling::Lights
            }
            _ => BackgroundSampling::BsdfOnly,
        }
    }

    /// True when the integrator needs light sources to produce anything but black.
    pub fn needs_lights(&self) -> bool {
        !matches!(self, Integrator::Ao(_))
    }

    /// False when the image is black whatever the rays find (direct or path tracing without
    /// any emitter): then no ray is traced at all.
    #[inline]
    pub fn traces_rays(&self, ctx: &Context) -> bool {
        !(self.needs_lights() && ctx.lights.is_empty())
    }

    /// One estimate of the radiance along the camera ray `ray`.
    #[inline]
    pub fn li(
        &self,
        ctx: &Context,
        ray: &Ray,
        sampler: &mut PixelSampler,
        rays: &mut RayCounts,
    ) -> Vec3 {
        if !self.traces_rays(ctx) {
            return Vec3::ZERO;
        }
        self.li_from_camera_hit(ctx, ray, ctx.accel.intersect(ray), sampler, rays)
    }

    /// [`Integrator::li_from_camera_hit`] for the camera rays of a packet: `rays[k]`, with
    /// closest hit `hits[k]`, sampled by `samplers[lanes[k]]`, its estimate into `l[k]`
    /// (see [`ao::li_packet`]). The estimates are those of one ray at a time.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn li_packet_from_camera_hits(
        &self,
        ctx: &Context,
        rays: &[Ray],
        hits: &[Option<Hit>],
        samplers: &mut [PixelSampler],
        lanes: &[usize],
        counts: &mut RayCounts,
        l: &mut [Vec3A],
    ) {
        match self {
            Integrator::Ao(settings) => {
                counts.camera += rays.len() as u64;
                let mut ao = [0f32; PACKET];
                let ao = &mut ao[..rays.len()];
                ao::li_packet(ctx, rays, hits, samplers, lanes, settings, counts, ao);
                for (l, a) in l.iter_mut().zip(ao.iter()) {
                    *l = Vec3A::splat(*a);
                }
            }
            Integrator::Direct(settings) | Integrator::Path(settings)
                if path_lanes::supported(ctx, settings) =>
            {
                path_lanes::li_lanes(ctx, rays, hits, samplers, lanes, settings, counts, l);
            }
            _ => {
                for k in 0..rays.len() {
                    let sampler = &mut samplers[lanes[k]];
                    l[k] = self
                        .li_from_camera_hit(ctx, &rays[k], hits[k], sampler, counts)
                        .into();
                }
            }
        }
    }

    /// The estimate of a camera ray that meets nothing. It is the same for every ray, since
    /// misses see a constant (AO's 0, or the constant background), which lets the renderer
    /// give it to samples it leaves untraced. Direct lighting and path tracing compute it as
    /// they do for such a ray (`sampler` is drawn from as it would be); AO's is its
    /// documented 0, written out so that `ao::li` keeps its one caller in the render loop
    /// (a second one changed how it was inlined, and cost a 64-ray AO render 3–5%). The
    /// render tests compare culled and traced misses bit for bit. Only called when
    /// [`Integrator::traces_rays`].
    pub fn camera_miss(&self, ctx: &Context, sampler: &mut PixelSampler) -> Vec3A {
        match self {
            Integrator::Ao(_) => Vec3A::ZERO,
            Integrator::Direct(settings) | Integrator::Path(settings) => {
                let ray = Ray::new(glam::Vec3::ZERO, glam::Vec3::NEG_Z);
                path::li(
                    ctx,
                    &ray,
                    None,
                    sampler,
                    settings,
                    &mut RayCounts::default(),
                )
                .into()
            }
        }
    }

    /// [`Integrator::li`] given the camera ray's closest hit, found by the caller (for
    /// camera rays traced in packets). Only called when [`Integrator::traces_rays`].
    #[inline]
    pub fn li_from_camera_hit(
        &self,
        ctx: &Context,
        ray: &Ray,
        hit: Option<Hit>,
        sampler: &mut PixelSampler,
        rays: &mut RayCounts,
    ) -> Vec3 {
        rays.camera += 1;
        match self {
            Integrator::Ao(settings) => Vec3::splat(ao::li(ctx, hit, ray, sampler, settings, rays)),
            Integrator::Direct(settings) | Integrator::Path(settings) => {
                path::li(ctx, ray, hit, sampler, settings, rays)
            }
        }
    }
}
