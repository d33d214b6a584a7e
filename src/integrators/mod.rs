//! Integrators: estimators of the radiance arriving along a camera ray.
//!
//! A closed set dispatched by `match`. Each takes the primary ray and the pixel sample's
//! [`PixelSampler`], draws its dimensions in a fixed order, and returns one estimate.

pub mod ao;
pub(crate) mod emitters;
pub mod path;

use glam::{Vec3, Vec3A};

use crate::accel::{Accel, Hit, Ray, PACKET};
use crate::experiments::Experiments;
use crate::sampling::PixelSampler;
use crate::scene::Scene;
use crate::shading::{
    BackgroundSampling, Environment, LightSet, MaterialOptions, Materials, Need, SceneEmitters,
    TriangleSampling,
};
use crate::shading::{LocalBsdf, SurfaceInteraction};

pub use crate::record::{Features, SampleRecord};
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
    /// Switches for measurements and tests ([`Experiments`]); the defaults render.
    pub experiments: Experiments,
    /// Fill in each sample's first-hit [`Features`] (for feature layers and denoising);
    /// false, the default, skips their cost.
    pub features: bool,
    /// Name each sample's first-hit triangle ([`SampleRecord::triangle`], for ID passes);
    /// false, the default, leaves it None.
    pub ids: bool,
}

/// How the scene is shaded, beyond what its file says: the choices a render makes for
/// materials and lights.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShadingOptions {
    /// What rays that leave the scene see (`--background`).
    pub environment: Environment,
    /// How materials are rendered (`--materials`, `--energy-compensation`, `--hemisphere`).
    pub materials: MaterialOptions,
    /// How points on emissive triangles are sampled (`--triangle-sampling`).
    pub triangle_sampling: TriangleSampling,
    /// What camera rays that miss see instead of the environment (`--background` in front of
    /// an `--env` map); None: the environment.
    pub camera_background: Option<Vec3>,
}

/// The materials and lights an integrator needs, prepared once per render: nothing for AO;
/// decoded textures and the light set for direct lighting and path tracing.
#[derive(Clone, Debug, Default)]
pub struct Prepared {
    pub materials: Materials,
    pub lights: LightSet,
    /// The scene's emitters, collected once for [`Prepared::relight`] (empty where the
    /// integrator needs no lights).
    emitters: SceneEmitters,
}

impl Prepared {
    /// Prepares what `integrator` reads of `scene` (loaded from `scene_path`, for messages),
    /// with a constant `background` radiance and the other options at their defaults.
    pub fn new(
        scene: &Scene,
        scene_path: &std::path::Path,
        integrator: &Integrator,
        background: Vec3,
    ) -> Result<Prepared, String> {
        let options = ShadingOptions {
            environment: Environment::Constant(background),
            ..Default::default()
        };
        Prepared::with_options(scene, scene_path, integrator, &options)
    }

    /// Prepares what `integrator` reads of `scene` (loaded from `scene_path`, for messages)
    /// as `options` say.
    pub fn with_options(
        scene: &Scene,
        scene_path: &std::path::Path,
        integrator: &Integrator,
        options: &ShadingOptions,
    ) -> Result<Prepared, String> {
        let materials = Materials::prepare(
            scene,
            scene_path,
            integrator.material_need(),
            &options.materials,
        )?;
        let emitters = match integrator.needs_lights() {
            true => SceneEmitters::collect(scene, &materials),
            false => SceneEmitters::default(),
        };
        let mut prepared = Prepared {
            materials,
            lights: LightSet::default(),
            emitters,
        };
        prepared.relight(integrator, options);
        Ok(prepared)
    }

    /// Completes the lights as `options` say (another environment), keeping the materials and
    /// the scene's emitters.
    pub fn relight(&mut self, integrator: &Integrator, options: &ShadingOptions) {
        let mut lights = if integrator.needs_lights() {
            LightSet::with_environment(
                &self.emitters,
                options.environment.clone(),
                match options.environment.constant() {
                    // An environment that varies is found by light sampling (importance
                    // sampling of the map), always.
                    None => BackgroundSampling::Lights,
                    Some(_) => integrator.background_sampling(&self.materials),
                },
            )
        } else {
            LightSet::default()
        };
        lights.triangle_sampling = options.triangle_sampling;
        lights.camera_background = options.camera_background;
        self.lights = lights;
    }

    /// The integrator context for `scene` traced through `accel`.
    pub fn context<'a>(&'a self, scene: &'a Scene, accel: &'a Accel) -> Context<'a> {
        Context {
            scene,
            accel,
            materials: &self.materials,
            lights: &self.lights,
            experiments: Experiments::default(),
            features: false,
            ids: false,
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
    /// traversal: those of pixel blocks that cannot see it ([`crate::accel::culling`]), and
    /// of packets whose rays all miss the scene's box. They were not traced.
    pub culled: u64,
    /// Camera rays traced before the render, through pixel corners, to find the pixels
    /// that see an emitter whole ([`emitters`]).
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
    Ao,
    Direct,
    #[default]
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

    /// How light sampling treats the environment: BSDF samples alone find a constant one at
    /// less cost where every surface is diffuse (see [`crate::shading::lights`]); with
    /// `--strategy light`, or glossy and specular surfaces, light samples must find it too.
    pub fn background_sampling(&self, materials: &Materials) -> BackgroundSampling {
        match self {
            Integrator::Direct(s) | Integrator::Path(s) if s.strategy == Strategy::Light => {
                BackgroundSampling::Lights
            }
            _ if !materials.all_diffuse() => BackgroundSampling::Lights,
            _ => BackgroundSampling::BsdfOnly,
        }
    }

    /// True when the integrator needs light sources to produce anything but black.
    pub fn needs_lights(&self) -> bool {
        !matches!(self, Integrator::Ao(_))
    }

    /// False when the image is black whatever the rays find (direct or path tracing without
    /// any emitter) and no pass asks what the camera rays meet: then no ray is traced at all.
    #[inline]
    pub fn traces_rays(&self, ctx: &Context) -> bool {
        !(self.needs_lights() && ctx.lights.is_empty()) || ctx.features || ctx.ids
    }

    /// The same integrator leaving out the emission its camera ray meets, where the caller
    /// estimates that term apart (the renderer's emitter rays); AO, which sees no emission,
    /// is returned as it is.
    pub fn without_camera_emission(&self) -> Integrator {
        match *self {
            Integrator::Direct(s) => Integrator::Direct(PathSettings {
                camera_emission: false,
                ..s
            }),
            Integrator::Path(s) => Integrator::Path(PathSettings {
                camera_emission: false,
                ..s
            }),
            ao @ Integrator::Ao(_) => ao,
        }
    }

    /// The emission that camera ray `ray`, whose closest hit is `hit`, sees: the term the
    /// light-transport integrators add first for a camera ray, and leave out
    /// [`Integrator::without_camera_emission`].
    #[inline]
    pub fn camera_emission(ctx: &Context, ray: &Ray, hit: Option<Hit>) -> Vec3 {
        path::camera_emission(ctx, ray, hit)
    }

    /// Estimates for the camera rays of a packet, the one way every sample reaches an
    /// integrator: `rays[k]`, with closest hit `hits[k]` (traced by the caller, as a packet
    /// or alone), drawn from `samplers[lanes[k]]`, its record into `out[k]`. Each estimate is
    /// the one its ray would get alone (see [`ao::li_packet`]); the first hit's features and
    /// triangle are filled in only where `ctx.features` and `ctx.ids` ask for them. Only called when
    /// [`Integrator::traces_rays`].
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn li_packet(
        &self,
        ctx: &Context,
        rays: &[Ray],
        hits: &[Option<Hit>],
        samplers: &mut [PixelSampler],
        lanes: &[usize],
        counts: &mut RayCounts,
        out: &mut [SampleRecord],
    ) {
        counts.camera += rays.len() as u64;
        match self {
            Integrator::Ao(settings) => {
                let mut ao = [0f32; PACKET];
                let ao = &mut ao[..rays.len()];
                ao::li_packet(ctx, rays, hits, samplers, lanes, settings, counts, ao);
                for (out, a) in out.iter_mut().zip(ao.iter()) {
                    out.l = Vec3A::splat(*a);
                }
            }
            Integrator::Direct(settings) | Integrator::Path(settings) => {
                for k in 0..rays.len() {
                    let sampler = &mut samplers[lanes[k]];
                    out[k].l = path::li(ctx, &rays[k], hits[k], sampler, settings, counts).into();
                }
            }
        }
        if ctx.features {
            for k in 0..rays.len() {
                out[k].features = hits[k].map(|hit| self.features(ctx, &rays[k], &hit));
            }
        }
        if ctx.ids {
            for k in 0..rays.len() {
                out[k].triangle = hits[k].map(|hit| crate::record::first_hit(hit.prim, hit.inst));
            }
        }
    }

    /// The features of a camera ray's first hit: the albedo a denoiser takes
    /// ([`denoising_albedo`]; white for AO, which shades every surface so), the shading
    /// normal facing the camera, and the distance along the ray.
    fn features(&self, ctx: &Context, ray: &Ray, hit: &Hit) -> Features {
        let si = SurfaceInteraction::from_hit(ctx.scene, ray, hit);
        let albedo = match self {
            Integrator::Ao(_) => Vec3::ONE,
            _ => denoising_albedo(ctx, &si),
        };
        Features {
            albedo,
            normal: si.ns,
            depth: hit.t * ray.dir.length(),
            position: si.p,
            // TEXCOORD_0 whether or not a material reads a texture (Materials::uv skips it
            // then).
            uv: ctx.scene.texcoord(hit.prim, hit.u, hit.v),
        }
    }

    /// The estimate of a camera ray that meets nothing, where it is the same for every ray
    /// (AO's 0, or a constant environment): the renderer then gives it to samples it leaves
    /// untraced. None where the environment varies with direction: such rays are traced.
    /// Direct lighting and path tracing compute it as they do for such a ray (`sampler` is
    /// drawn from as it would be); AO's is its documented 0, written out rather than asked of
    /// `ao::li`, whose inlining a second caller changed (a 64-ray AO render was 3–5% slower).
    /// The render tests compare culled and traced misses bit for bit. Only called when
    /// [`Integrator::traces_rays`].
    pub fn camera_miss(&self, ctx: &Context, sampler: &mut PixelSampler) -> Option<Vec3A> {
        Some(match self {
            Integrator::Ao(_) => Vec3A::ZERO,
            Integrator::Direct(_) | Integrator::Path(_)
                if ctx.lights.constant_camera_miss().is_none() =>
            {
                return None
            }
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
        })
    }
}

/// Perfect mirrors followed by [`denoising_albedo`] before it gives up and takes the
/// mirror's own reflectance.
const MIRROR_BOUNCES: u32 = 4;

/// The albedo a denoiser takes for the surface point `si` a camera ray met (Open Image
/// Denoise asks for the first non-specular hit's): its BSDF's reflectance, except where the
/// BSDF is a perfect mirror (delta lobes only), which shows what it reflects: there, the
/// mirror's weight times the albedo of the surface it shows, through up to
/// [`MIRROR_BOUNCES`] mirrors; a reflection that leaves the scene counts as white.
fn denoising_albedo(ctx: &Context, si: &SurfaceInteraction) -> Vec3 {
    let mut weight = Vec3::ONE;
    let mut si = *si;
    for bounce in 0..=MIRROR_BOUNCES {
        let uv = ctx.materials.uv(ctx.scene, &si);
        let bsdf = ctx.materials.bsdf(ctx.scene, &si, uv);
        let flags = bsdf.flags();
        if flags.has_non_specular() || bounce == MIRROR_BOUNCES {
            return weight * bsdf.bsdf.albedo();
        }
        // A delta lobe's direction does not depend on the 2D point; the lobe number chooses
        // between a smooth glass's mirror and refraction: the likelier one.
        let Some(s) = bsdf.sample(0.5, glam::Vec2::splat(0.5)) else {
            return weight * bsdf.bsdf.albedo();
        };
        weight *= s.f_cos / s.pdf;
        let ray = si.spawn_ray_with(s.wi, f32::INFINITY, ctx.experiments.ray_offset);
        match ctx.accel.intersect(&ray) {
            Some(hit) => si = SurfaceInteraction::from_hit(ctx.scene, &ray, &hit),
            None => return weight,
        }
    }
    weight
}
