//! A render job: the command line's options ([`Args`]) checked together and resolved into
//! the settings the renderer takes, with the defaults that depend on other options filled in
//! (the output path, the samples per pixel, the memory limit).
//!
//! [`Job::from_args`] is the one place where options become settings, and makes every check
//! the options allow before anything is loaded. [`Job::view`] makes the checks that need
//! the scene: the camera, the image size and the memory estimate.

pub mod header;

use std::path::{Path, PathBuf};
use std::time::Duration;

use glam::Vec3;

use crate::accel::{AccelOptions, Backend, BuildQuality};
use crate::cli::{Args, Background, MemoryLimit};
use crate::experiments::Experiments;
use crate::integrators::{
    AoSettings, Hemisphere, Integrator, IntegratorKind, PathSettings, ShadingOptions, Strategy,
};
use crate::render::adaptive::ErrorMetric;
use crate::render::merge::Share;
use crate::render::output::{self, ImageFormat, OutputError};
use crate::render::passes::Pass;
use crate::render::view::ViewTransform;
use crate::render::{Film, RenderSettings, Stopping};
use crate::sampling::sampler::SOBOL_MAX_SPP;
use crate::sampling::SamplerKind;
use crate::scene::{format_bytes, Camera, Lens, LoadOptions, Projection, Scene};
use crate::shading::{
    DiffuseSampling, EnvMap, Environment, LightSet, MapSampling, MaterialModel, MaterialOptions,
};

/// The default `--spp` of an adaptive or time-limited render: as many as the Sobol sampler
/// has, so the target error or the time limit is what stops it.
pub const PROGRESSIVE_MAX_SPP: u32 = SOBOL_MAX_SPP;

/// The radiance of the uniform white sky that lights a scene bringing no light of its own,
/// when neither `--background` nor `--env` says what else to use: the light of ambient
/// occlusion, so such a scene renders as AO would, with its materials' colours.
pub const DEFAULT_SKY: f32 = 1.0;

/// The share of [`DEFAULT_SKY`]'s power below which emissive surfaces that are no brighter
/// than glTF's core allows (radiance 1) are taken as glowing details — an emissive texture
/// that is mostly black, lit labels, lamps on a model — rather than as the light the scene is
/// meant to be seen by: such a scene is lit by the sky as well. A sky of radiance L sends
/// 4π²r²L into the bounding sphere of radius r; the emitters' power is by luminance, as light
/// selection weighs them. Measured (docs/lights.md, "Light by default"): the six Khronos
/// models with emissive details give 0.002–2.7% of the sky's power; emitters of radiance 1
/// covering a tenth of the bounding sphere's area give 10%.
pub const FAINT_EMITTERS: f64 = 0.1;

/// Why a scene is lit by [`DEFAULT_SKY`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DefaultLight {
    /// No punctual light and no emissive surface.
    NoLight,
    /// No punctual light, and emissive surfaces of radiance at most 1 whose power is this
    /// share of the sky's, below [`FAINT_EMITTERS`].
    FaintEmitters(f64),
}

/// The default `--spp` of a render that takes every pixel's samples.
pub const DEFAULT_SPP: u32 = 64;

/// Options that cannot be rendered together, or a scene they do not fit; the message names
/// the option.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct JobError(pub String);

impl From<OutputError> for JobError {
    fn from(e: OutputError) -> JobError {
        JobError(e.to_string())
    }
}

/// Returns early with a [`JobError`] made of `format!`'s arguments.
macro_rules! refuse {
    ($($arg:tt)*) => {
        return Err(JobError(format!($($arg)*)))
    };
}

/// A checked render job.
#[derive(Clone, Debug)]
pub struct Job {
    /// The scene file.
    pub scene: PathBuf,
    /// The EXR (the PNG preview goes beside it, with `.png`), or a `.png` or `.jpg` that is
    /// the image through the view transform alone.
    pub output: PathBuf,
    /// What `output` holds, by its extension.
    pub format: ImageFormat,
    /// Write the PNG preview.
    pub png: bool,
    /// The PNG preview's view transform and exposure (`--view`, `--exposure`).
    pub view: ViewTransform,
    pub exposure: f32,
    /// The animation frame this job renders (`--frame`; one of `--frames`), at time
    /// frame / `fps` of animation `animation`; None: the rest pose.
    pub frame: Option<u32>,
    /// `--frames A..B`: the jobs of [`Job::frame_jobs`] render them.
    pub frames: Option<(u32, u32)>,
    pub fps: f64,
    pub animation: usize,
    /// The share of every pixel's samples this farm task renders (`--shard`, `--samples`),
    /// written as a partial file for `render merge`; None: all of them.
    pub share: Option<Share>,
    /// The passes written beside the beauty (`--passes`, and albedo and normal for
    /// `--denoise`), each once, in a fixed order.
    pub passes: Vec<Pass>,
    /// Denoise the beauty (`--denoise`) this way; `threads` 0 here: the render's count.
    pub denoise: Option<crate::denoise::Options>,
    /// Also write each pixel's variance of the mean here.
    pub variance: Option<PathBuf>,
    /// Also write each pixel's sample count here.
    pub spp_image: Option<PathBuf>,

    /// Worker threads (0: all cores).
    pub threads: usize,
    pub backend: Backend,
    pub bvh_quality: BuildQuality,
    /// Embree's watertight traversal (false only for measurements).
    pub robust: bool,
    /// Embree's quads, pairs of triangles traced as one (false only for measurements).
    pub quads: bool,
    /// Alpha coverage of MASK and BLEND materials (`--no-alpha` turns it off).
    pub alpha: bool,
    /// Refuse a scene whose texture images cannot all be had (`--strict`), rather than
    /// render those textures as absent with a warning.
    pub strict: bool,
    /// Every placement of a mesh stored as its own copy (`--flatten-instances`), not
    /// instanced.
    pub flatten_instances: bool,

    pub integrator: Integrator,
    /// How materials and lights are shaded: the environment (`--background`), diffuse
    /// sampling (`--hemisphere`) and emissive triangles' sampling.
    pub shading: ShadingOptions,
    /// `--hemisphere`, as given (AO's estimator and the diffuse BSDF's sampling).
    pub hemisphere: Hemisphere,
    /// Neither `--background` nor `--env` was given: a scene that brings no light of its own
    /// is lit by [`DEFAULT_SKY`] ([`Job::default_light`]).
    pub default_sky: bool,
    /// `--background transparent`: camera rays that miss see nothing, and the outputs carry
    /// the scene's coverage as alpha.
    pub transparent: bool,
    /// The environment map to load (`--env`), its rotation about +Y in degrees and its scale;
    /// [`Job::load_environment`] puts it into `shading`.
    pub env: Option<(PathBuf, f32, f32)>,
    /// What light sampling draws the map's directions in proportion to (`--env-sampling`;
    /// radiance unless light sampling is combined with BSDF sampling by MIS).
    pub env_sampling: MapSampling,
    /// Switches for measurements (`--no-camera-packets`, `--padded-bounces`,
    /// `--sample-variance-error`); the defaults otherwise.
    pub experiments: Experiments,

    /// The camera's index in the file; `None`: the first camera, or a framing of the scene.
    pub camera: Option<usize>,
    /// `--look-from`, `--look-at`, `--up`, `--fov` and `--orbit` (radians, this frame's).
    pub aim: Aim,
    /// The image size; `None`: from the camera's aspect ratio.
    pub resolution: Option<(u32, u32)>,
    /// Render only this pixel.
    pub pixel: Option<(u32, u32)>,

    pub spp: u32,
    pub seed: u64,
    pub sampler: SamplerKind,
    pub target_error: Option<f32>,
    pub min_spp: u32,
    pub error_metric: ErrorMetric,
    /// The time limit in seconds, as given.
    pub time_limit: Option<f64>,
    pub tile_size: u32,
    pub min_pass_seconds: f64,

    /// Refuse a scene whose estimated memory exceeds this many bytes; `None`: no limit.
    pub memory_limit: Option<u64>,
    /// Write the running image at most every this many seconds.
    pub checkpoint: Option<f64>,
    /// Continue the unfinished render saved in this file (`--resume`).
    pub resume: Option<PathBuf>,
    /// Seconds between progress lines when stderr is not a terminal (`--progress-every`).
    pub progress_every: f64,
    /// Print the `--stats` report.
    pub stats: bool,
    /// What the options let through but the user should hear about, one line each.
    pub warnings: Vec<String>,
}

/// How the command line moves the camera ([`Job::view`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Aim {
    pub look_from: Option<Vec3>,
    pub look_at: Option<Vec3>,
    pub up: Option<Vec3>,
    /// Vertical field of view, radians.
    pub fov: Option<f32>,
    /// Turn about +Y through the scene's centre, radians.
    pub orbit: f32,
    /// Depth of field (`--aperture`, `--f-stop`), and the distance in focus.
    pub aperture: Option<Aperture>,
    pub focus_distance: Option<f32>,
}

/// A thin lens's size: its diameter in scene units, or an f-number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Aperture {
    Diameter(f32),
    FStop(f32),
}

/// One line per camera of `scene`: index, name, projection and position (`--list-cameras`,
/// and the error for a camera the file does not have).
pub fn camera_list(scene: &Scene) -> Vec<String> {
    scene
        .cameras
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let name = c
                .name
                .as_deref()
                .map(|n| format!(" '{n}'"))
                .unwrap_or_default();
            let projection = match c.projection {
                Projection::Perspective { yfov } => {
                    format!(
                        "perspective, {:.1}° vertical field of view",
                        yfov.to_degrees()
                    )
                }
                Projection::Orthographic { ymag } => format!("orthographic, half-height {ymag}"),
            };
            let p = c.position();
            format!("{i}{name}: {projection}, at ({}, {}, {})", p.x, p.y, p.z)
        })
        .collect()
}

/// What [`Job::view`] makes of the job and the scene: the camera and the image size.
#[derive(Clone, Debug)]
pub struct View {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    /// The file has no camera: `camera` frames the scene's bounding box.
    pub framed: bool,
}

impl Job {
    /// Checks the options together and resolves them into a job; the error names the
    /// option at fault.
    pub fn from_args(args: &Args) -> Result<Job, JobError> {
        let (output, variance, spp_image, share) = outputs(args)?;
        let format = ImageFormat::of(&output).unwrap_or(ImageFormat::Exr);
        let mut warnings = Vec::new();
        let (spp, min_spp) = samples(args, share, &mut warnings)?;
        if !(args.env_intensity >= 0.0 && args.env_intensity.is_finite()) {
            refuse!(
                "--env-intensity must be a finite number of at least 0 (got {})",
                args.env_intensity
            );
        }
        let (passes, denoise) = denoise_and_passes(args)?;
        if !args.preview.exposure.is_finite() {
            refuse!("--exposure must be a finite number of stops");
        }
        if !args.env_rotate.is_finite() {
            refuse!("--env-rotate must be a finite number of degrees");
        }
        // `--env none`: no environment and no default sky (a file named so: `--env ./none`).
        let no_env = args.env.as_deref() == Some(std::path::Path::new("none"));
        let env_file = args.env.as_ref().filter(|_| !no_env);
        if let Some(env) = env_file {
            if env.is_dir() {
                refuse!(
                    "{}: a directory, not an environment map (name the .hdr or .exr inside it)",
                    env.display()
                );
            }
            if !env.is_file() {
                refuse!("{}: no such environment map", env.display());
            }
        }
        let integrator = integrator(args)?;
        let memory_limit = match args.max_memory {
            Some(MemoryLimit(limit)) => limit,
            None => match default_memory_limit() {
                Ok(limit) => Some(limit),
                Err(e) => {
                    warnings.push(format!("{e}; no memory limit (set one with --max-memory)"));
                    None
                }
            },
        };

        Ok(Job {
            scene: args.scene.clone(),
            output,
            format,
            // A shard's preview would show a fraction of the samples; the merge writes one.
            png: !args.preview.no_png && share.is_none() && format == ImageFormat::Exr,
            view: args.preview.view,
            exposure: args.preview.exposure,
            frame: args.frame,
            frames: args.frames,
            fps: args.fps,
            animation: args.animation,
            share,
            passes: crate::render::passes::canonical(&passes),
            denoise,
            variance,
            spp_image,
            threads: args.threads,
            backend: args.backend,
            bvh_quality: args.bvh_quality,
            robust: !args.no_robust,
            quads: !args.no_quads,
            alpha: !args.no_alpha,
            strict: args.strict,
            flatten_instances: args.flatten_instances,
            integrator,
            shading: shading_options(args, env_file.is_some()),
            hemisphere: args.hemisphere,
            default_sky: args.env.is_none() && args.background_color().is_none(),
            transparent: args.background == Some(Background::Transparent),
            env: env_file
                .cloned()
                .map(|p| (p, args.env_rotate, args.env_intensity)),
            env_sampling: match args.strategy {
                Strategy::Mis => args.env_sampling,
                Strategy::Light | Strategy::Bsdf => MapSampling::Radiance,
            },
            experiments: Experiments {
                camera_packets: !args.no_camera_packets,
                joint_bounces: !args.padded_bounces,
                error_halves: !args.sample_variance_error,
                ..Experiments::default()
            },
            camera: args.camera,
            aim: Aim {
                look_from: args.look_from.map(Vec3::from_array),
                look_at: args.look_at.map(Vec3::from_array),
                up: args.up.map(Vec3::from_array),
                fov: args.fov.map(f32::to_radians),
                orbit: args.orbit.to_radians(),
                aperture: match (args.aperture, args.f_stop) {
                    (Some(d), _) => Some(Aperture::Diameter(d)),
                    (None, Some(n)) => Some(Aperture::FStop(n)),
                    (None, None) => None,
                },
                focus_distance: args.focus_distance,
            },
            resolution: args.resolution,
            pixel: args.pixel,
            spp,
            seed: args.seed,
            sampler: args.sampler,
            target_error: args.target_error,
            min_spp,
            error_metric: args.error_metric,
            time_limit: args.time_limit,
            tile_size: args.tile_size,
            min_pass_seconds: args.min_pass_seconds,
            memory_limit,
            checkpoint: args.checkpoint,
            resume: args.resume.clone(),
            progress_every: args.progress_every,
            stats: args.stats,
            warnings,
        })
    }

    /// The temporary files the job's writes go through (removed if it is killed mid-write).
    pub fn temporaries(&self) -> Vec<PathBuf> {
        let mut temporaries = vec![
            output::temp_path(&self.output),
            output::temp_path(&self.output.with_extension("png")),
            output::temp_path(&output::incomplete_path(&self.output)),
        ];
        temporaries.extend(self.variance.as_deref().map(output::temp_path));
        temporaries.extend(self.spp_image.as_deref().map(output::temp_path));
        temporaries
    }

    /// The memory a `width`×`height` image needs: the film, what adaptive sampling and
    /// checkpoints add to it, and the extra images (float32 RGB) written.
    pub fn image_memory(&self, width: u32, height: u32) -> u64 {
        let mut extra = 12 * (self.variance.is_some() as u64 + self.spp_image.is_some() as u64);
        if self.target_error.is_some() {
            extra += Film::ADAPTIVE_BYTES_PER_PIXEL;
        }
        if self.passes.iter().any(|p| p.is_id()) {
            extra += Film::FIRST_HITS_BYTES_PER_PIXEL;
        }
        if self.passes.iter().any(|p| !p.is_id()) {
            extra += Film::FEATURES_BYTES_PER_PIXEL;
        }
        if self.checkpoint.is_some() {
            extra += Film::CHECKPOINT_BYTES_PER_PIXEL;
            if self.target_error.is_some() && self.experiments.error_halves {
                // The snapshot copies the film's halves too.
                extra += Film::HALVES_BYTES_PER_PIXEL;
            }
        }
        Film::memory_estimate(width, height) + width as u64 * height as u64 * extra
    }

    /// How to load the scene: within the memory limit, less the image's share when its size
    /// is known before the scene is; in the pose of the job's frame, if it renders one.
    pub fn load_options(&self) -> LoadOptions {
        LoadOptions {
            memory_limit: self.memory_limit,
            other_memory: self.resolution.map_or(0, |(w, h)| self.image_memory(w, h)),
            environment_memory: self.environment_memory(),
            pose: self.frame.map(|f| crate::scene::PoseTime {
                animation: self.animation,
                seconds: f as f64 / self.fps,
            }),
            flatten_instances: self.flatten_instances,
        }
    }

    /// The jobs of the frames `--frame` and `--frames` ask for, each writing its own files
    /// ([`frame_path`]); the job itself where none is asked for.
    pub fn frame_jobs(&self) -> Vec<Job> {
        match self.frames {
            None => vec![self.clone()],
            Some((a, b)) => (a..=b)
                .map(|f| Job {
                    frame: Some(f),
                    frames: None,
                    // A turntable: the whole orbit over the frames, the last frame one step
                    // short of the first.
                    aim: Aim {
                        orbit: self.aim.orbit * (f - a) as f32 / (b - a + 1) as f32,
                        ..self.aim
                    },
                    output: frame_path(&self.output, f),
                    variance: self.variance.as_deref().map(|p| frame_path(p, f)),
                    spp_image: self.spp_image.as_deref().map(|p| frame_path(p, f)),
                    ..self.clone()
                })
                .collect(),
        }
    }

    /// The camera and the image size for `scene`, after checking the camera index, the
    /// memory the render needs against the limit, and `--pixel` against the image.
    pub fn view(&self, scene: &Scene) -> Result<View, JobError> {
        let chosen = match self.camera {
            Some(i) => Some(scene.cameras.get(i).ok_or_else(|| {
                let list = match scene.cameras.is_empty() {
                    true => "it has none".to_string(),
                    false => format!("it has {}", camera_list(scene).join("; ")),
                };
                JobError(format!(
                    "{}: --camera {i}: no such camera; {list}",
                    self.scene.display()
                ))
            })?),
            None => scene.cameras.first(),
        };
        let (width, height) =
            self.resolution
                .unwrap_or_else(|| match chosen.and_then(|c| c.aspect_ratio) {
                    Some(a) => (640, ((640.0 / a).round() as u32).clamp(1, 65536)),
                    None => (640, 480),
                });
        let scene_memory = scene.memory_estimate.bytes();
        let image_memory = self.image_memory(width, height);
        let environment_memory = self.environment_memory();
        let needed = (scene_memory)
            .saturating_add(image_memory)
            .saturating_add(environment_memory);
        if let Some(limit) = self.memory_limit.filter(|&l| needed > l) {
            refuse!(
                "{}: rendering needs an estimated {} of memory (scene and BVH {}{}, {width}x{height} image {}), more than the limit of {} (--max-memory)",
                self.scene.display(),
                format_bytes(needed),
                format_bytes(scene_memory),
                match environment_memory {
                    0 => String::new(),
                    n => format!(", environment map {}", format_bytes(n)),
                },
                format_bytes(image_memory),
                format_bytes(limit)
            );
        }
        if let Some((x, y)) = self.pixel {
            if x >= width || y >= height {
                refuse!("--pixel {x},{y} lies outside the {width}x{height} image");
            }
        }
        let aspect = width as f32 / height as f32;
        let (mut camera, framed) = match chosen {
            Some(c) => (c.clone(), false),
            None => {
                let yfov = self
                    .aim
                    .fov
                    .unwrap_or(Camera::FRAMING_YFOV_DEGREES.to_radians());
                let (lo, hi) = scene.bounds;
                (Camera::framing_with(lo, hi, aspect, yfov), true)
            }
        };
        if let Some(fov) = self.aim.fov {
            match &mut camera.projection {
                Projection::Perspective { yfov } => *yfov = fov,
                Projection::Orthographic { .. } => {
                    refuse!("--fov: the camera is orthographic (it has no field of view)")
                }
            }
        }
        let centre = 0.5 * (scene.bounds.0 + scene.bounds.1);
        if self.aim.look_from.is_some() || self.aim.look_at.is_some() {
            let from = self.aim.look_from.unwrap_or(camera.position());
            let at = self.aim.look_at.unwrap_or(centre);
            let up = self.aim.up.unwrap_or(Vec3::Y);
            camera = camera.looking(from, at, up).ok_or_else(|| {
                JobError(format!(
                    "--look-from {from} and --look-at {at} with --up {up}: the camera needs two different points and an up direction that is not along the line between them"
                ))
            })?;
        } else if self.aim.up.is_some() {
            refuse!("--up turns the camera of --look-from or --look-at: give one of them");
        }
        if self.aim.orbit != 0.0 {
            camera = camera.orbited(centre, self.aim.orbit);
        }
        if let Some(aperture) = self.aim.aperture {
            let Projection::Perspective { yfov } = camera.projection else {
                refuse!("--aperture and --f-stop: the camera is orthographic (it has no lens)")
            };
            // In focus by default: what the camera looks at, or the scene's centre along its
            // view (the camera looks down its local −Z).
            let view = camera.to_world.transform_vector3(Vec3::NEG_Z).normalize();
            let focus_distance = match (self.aim.focus_distance, self.aim.look_at) {
                (Some(d), _) => d,
                (None, Some(at)) => (at - camera.position()).length(),
                (None, None) => (centre - camera.position()).dot(view),
            };
            if !(focus_distance > 0.0 && focus_distance.is_finite()) {
                refuse!(
                    "--aperture and --f-stop: the scene's centre is not ahead of the camera, so there is no distance to focus at by default: give --focus-distance"
                );
            }
            camera.lens = Some(match aperture {
                Aperture::Diameter(d) => Lens {
                    radius: 0.5 * d,
                    focus_distance,
                },
                Aperture::FStop(n) => Lens::from_f_stop(n, yfov, aspect, focus_distance),
            });
        } else if self.aim.focus_distance.is_some() {
            refuse!(
                "--focus-distance focuses the lens of --aperture or --f-stop: give one of them"
            );
        }
        Ok(View {
            camera,
            width,
            height,
            framed,
        })
    }

    /// The BVH build's options, for a pool of `threads` worker threads.
    /// Whether `scene`, whose lights without an environment are `lights`, is to be lit by
    /// [`DEFAULT_SKY`], and why: where neither `--background` nor `--env` was given, for the
    /// integrators that need light, a scene with no punctual light and no emissive surface,
    /// or one whose emissive surfaces emit at most radiance 1 (no emissive strength beyond
    /// glTF's core) and give less than [`FAINT_EMITTERS`] of the sky's power. A punctual
    /// light, or a surface brighter than 1, is always meant to light.
    pub fn default_light(&self, scene: &Scene, lights: &LightSet) -> Option<DefaultLight> {
        if !(self.default_sky && self.integrator.needs_lights() && scene.lights.is_empty()) {
            return None;
        }
        if scene.summary.emissive_triangles == 0 {
            return Some(DefaultLight::NoLight);
        }
        // Brighter than a white surface under a unit sky (KHR_materials_emissive_strength):
        // a light by intent.
        let brightest = scene.materials.iter().map(|m| m.emissive.max_element());
        if brightest.fold(0.0, f32::max) > 1.0 {
            return None;
        }
        let (lo, hi) = scene.bounds;
        let sky = Environment::Constant(Vec3::splat(DEFAULT_SKY)).power(0.5 * (hi - lo).length());
        let share = lights.emitted_power() / sky;
        (share < FAINT_EMITTERS).then_some(DefaultLight::FaintEmitters(share))
    }

    /// Lights the scene with [`DEFAULT_SKY`] ([`Job::default_light`] says when).
    pub fn use_default_sky(&mut self) {
        self.shading.environment = Environment::Constant(Vec3::splat(DEFAULT_SKY));
    }

    /// Reads the environment map (`--env`), if any, into the shading options.
    /// What the `--env` map will take in memory ([`EnvMap::memory_estimate`], from its
    /// header); 0 without one, or where its header does not read (loading it says why).
    pub fn environment_memory(&self) -> u64 {
        match &self.env {
            Some((path, _, _)) => EnvMap::memory_estimate(path).unwrap_or(0),
            None => 0,
        }
    }

    pub fn load_environment(&mut self) -> Result<(), JobError> {
        if let Some((path, degrees, scale)) = &self.env {
            let map = EnvMap::load(path, degrees.to_radians(), *scale, self.env_sampling)
                .map_err(JobError)?;
            self.shading.environment = Environment::Map(std::sync::Arc::new(map));
        }
        Ok(())
    }

    pub fn accel_options(&self, threads: usize) -> AccelOptions {
        AccelOptions {
            backend: self.backend,
            quality: self.bvh_quality,
            threads,
            robust: self.robust,
            quads: self.quads,
            alpha: self.alpha,
        }
    }

    /// When the render stops.
    pub fn stopping(&self) -> Stopping {
        Stopping {
            target_error: self.target_error,
            min_spp: self.min_spp,
            metric: self.error_metric,
            time_limit: self.time_limit.map(Duration::from_secs_f64),
        }
    }

    /// The renderer's settings for the image of `view`.
    pub fn render_settings(&self, view: &View) -> RenderSettings {
        RenderSettings {
            camera: view.camera.clone(),
            crop: self.pixel.map(|(x, y)| (x, y, x + 1, y + 1)),
            width: view.width,
            height: view.height,
            spp: self.spp,
            seed: self.seed,
            sampler: self.sampler,
            integrator: self.integrator,
            tile_size: self.tile_size,
            sample_range: self.share.map(|s| s.range(self.spp)),
            min_pass_seconds: self.min_pass_seconds,
            stopping: self.stopping(),
        }
    }
}

/// Where a job's files go (`-o`, `--variance`, `--spp-image`, carrying a shard's share and a
/// frame's number), checked writable, and the share of samples it renders.
#[allow(clippy::type_complexity)]
fn outputs(
    args: &Args,
) -> Result<(PathBuf, Option<PathBuf>, Option<PathBuf>, Option<Share>), JobError> {
    let mut output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.scene));
    output::check_output_path(&output)?;
    for extra in [&args.variance, &args.spp_image].into_iter().flatten() {
        output::check_output_path(extra)?;
        if ImageFormat::of(extra) != Some(ImageFormat::Exr) {
            refuse!(
                "{}: --variance and --spp-image write EXRs: name an .exr",
                extra.display()
            );
        }
    }
    if ImageFormat::of(&output) != Some(ImageFormat::Exr) {
        let name = output.display();
        if args.shard.is_some() || args.samples.is_some() {
            refuse!("{name}: a farm part holds exact sums only an EXR carries: name an .exr");
        }
        if !args.passes.is_empty() {
            refuse!("{name}: --passes are layers of an EXR: name an .exr");
        }
    }
    if !(args.fps > 0.0 && args.fps.is_finite()) {
        refuse!("--fps must be a positive number (got {})", args.fps);
    }
    // One frame's files carry its number ([`frame_path`]); --frames names each frame's
    // in [`Job::frame_jobs`].
    let (mut variance, mut spp_image) = (args.variance.clone(), args.spp_image.clone());
    let share = match (args.shard, args.samples) {
        (Some((index, count)), _) => Some(Share::Shard { index, count }),
        (None, Some((begin, end))) => Some(Share::Samples { begin, end }),
        (None, None) => None,
    };
    // A shard's file carries its share before the frame number.
    if let Some(share) = share {
        output = share.path(&output);
    }
    if let Some(f) = args.frame {
        output = frame_path(&output, f);
        variance = variance.map(|p| frame_path(&p, f));
        spp_image = spp_image.map(|p| frame_path(&p, f));
    }
    Ok((output, variance, spp_image, share))
}

/// The samples per pixel and the adaptive minimum, checked against the sampler, the stopping
/// rule and the farm `share`.
fn samples(
    args: &Args,
    share: Option<Share>,
    warnings: &mut Vec<String>,
) -> Result<(u32, u32), JobError> {
    let progressive = args.target_error.is_some() || args.time_limit.is_some();
    let spp = args.spp.unwrap_or(if progressive {
        PROGRESSIVE_MAX_SPP
    } else {
        DEFAULT_SPP
    });
    if spp == 0 {
        refuse!("--spp must be at least 1");
    }
    if args.sampler == SamplerKind::Sobol && spp > SOBOL_MAX_SPP {
        refuse!(
            "--sampler sobol supports at most {SOBOL_MAX_SPP} samples per pixel (asked for {spp})"
        );
    }
    if progressive && args.sampler == SamplerKind::Stratified {
        warnings.push(format!(
            "--sampler stratified lays its strata out for all --spp {spp} samples; a render that stops early (--target-error, --time-limit) keeps little of its stratification. --sampler sobol (the default) is progressive: any prefix of its samples is well spread"
        ));
    }
    let min_spp = args.min_spp.unwrap_or(Stopping::DEFAULT_MIN_SPP.min(spp));
    if min_spp == 0 || min_spp > spp {
        refuse!("--min-spp must be between 1 and --spp ({spp}), got {min_spp}");
    }
    if let Some(share) = share {
        let option = share.option();
        let refused = [
            (args.target_error.is_some(), "--target-error: adaptive sampling stops each pixel at its own count, so a shard's share of samples is not fixed"),
            (args.time_limit.is_some(), "--time-limit: a time limit stops the render after as many samples as the machine managed, not a fixed share"),
            (args.checkpoint.is_some(), "--checkpoint: a checkpoint of a shard holds only part of its samples, and a merge must not take it for the whole"),
            (args.pixel.is_some(), "--pixel: a shard renders the whole image"),
            (args.denoise, "--denoise: denoise the merged image (render denoise MERGED.exr)"),
            (args.variance.is_some() || args.spp_image.is_some(), "--variance and --spp-image: the shards' files would overwrite each other; the merged image's variance follows from its sums"),
        ];
        if let Some((_, why)) = refused.iter().find(|(given, _)| *given) {
            refuse!("{option} cannot be combined with {why}");
        }
        match share {
            Share::Shard { count, .. } if count > spp => refuse!(
                "{option}: {count} shards of --spp {spp} would leave some without samples; use at most {spp} shards"
            ),
            Share::Samples { end, .. } if end > spp => {
                refuse!("{option} passes --spp {spp}: the last sample index is {}", spp - 1)
            }
            _ => {}
        }
    }
    if args.resume.is_some() {
        let refused = [
            (args.target_error.is_some(), "--target-error: adaptive sampling picks the pixels that sample from the film at the end of each round, which a film saved part way through a round cannot replay"),
            (args.time_limit.is_some(), "--time-limit: a time limit stops the render by the clock, not at a count a resumed render could continue"),
            (args.frames.is_some(), "--frames: a resumed file holds one frame; resume each frame's file with --frame N"),
        ];
        if let Some((_, why)) = refused.iter().find(|(given, _)| *given) {
            refuse!("--resume cannot be combined with {why}");
        }
    }
    if args.target_error.is_some() && spp < 2 {
        refuse!("--target-error needs --spp of at least 2: a pixel's error is estimated from its samples' variance (got --spp {spp})");
    }
    if args.target_error.is_some() && min_spp < 2 {
        refuse!(
            "--min-spp must be at least 2: a pixel's error is estimated from its samples' variance"
        );
    }

    Ok((spp, min_spp))
}

/// The passes written beside the beauty, with the albedo and normal that `--denoise` reads,
/// and the denoiser's options (an error where Open Image Denoise cannot be loaded).
fn denoise_and_passes(
    args: &Args,
) -> Result<(Vec<Pass>, Option<crate::denoise::Options>), JobError> {
    // The denoiser reads the albedo and normal passes; they are written too, so that
    // `render denoise` can denoise the raw image again.
    let mut passes = args.passes.clone();
    // A transparent background's coverage is the alpha pass.
    if args.background == Some(Background::Transparent) {
        passes.push(Pass::Alpha);
    }
    let denoise = match args.denoise {
        false => None,
        true => {
            if let Err(e) = crate::denoise::check() {
                refuse!("--denoise: {e}")
            }
            passes.extend([Pass::Albedo, Pass::Normal]);
            Some(crate::denoise::Options {
                threads: 0,
                prefilter: args.denoise_prefilter.is_on(),
            })
        }
    };
    Ok((passes, denoise))
}

/// The integrator and its settings, checked against the hemisphere sampling asked for.
fn integrator(args: &Args) -> Result<Integrator, JobError> {
    if args.ao_samples == 0 {
        refuse!("--ao-samples must be at least 1");
    }
    let ao_distance = match args.ao_distance {
        None => f32::INFINITY,
        Some(d) if d > 0.0 => d,
        Some(d) => refuse!("--ao-distance must be positive (got {d})"),
    };
    if args.hemisphere == Hemisphere::UniformUnweighted && args.integrator != IntegratorKind::Ao {
        refuse!("--hemisphere uniform-unweighted is an AO test estimator; direct and path take cosine or uniform");
    }
    if args.hemisphere == Hemisphere::Uniform
        && args.integrator != IntegratorKind::Ao
        && args.materials != MaterialModel::Lambertian
    {
        refuse!("--hemisphere uniform samples Lambertian reflection only; add --materials lambertian (the glTF BRDF samples its own lobes)");
    }
    let path_settings = PathSettings {
        max_depth: args.max_depth,
        rr_depth: args.rr_depth,
        strategy: args.strategy,
        emitter_samples: args.emitter_samples,
        camera_emission: true,
    };
    let integrator = match args.integrator {
        IntegratorKind::Ao => Integrator::Ao(AoSettings {
            max_distance: ao_distance,
            hemisphere: args.hemisphere,
            samples: args.ao_samples,
        }),
        IntegratorKind::Direct => Integrator::Direct(PathSettings {
            max_depth: 1,
            ..path_settings
        }),
        IntegratorKind::Path => Integrator::Path(path_settings),
    };

    Ok(integrator)
}

/// How materials and lights are shaded; `env_map`: an environment map is loaded, in front
/// of which `--background` is what the camera sees.
fn shading_options(args: &Args, env_map: bool) -> ShadingOptions {
    ShadingOptions {
        environment: Environment::Constant(Vec3::from_array(
            args.background_color().unwrap_or([0.0; 3]),
        )),
        materials: MaterialOptions {
            model: args.materials,
            energy_compensation: args.energy_compensation.is_on(),
            diffuse_sampling: match args.hemisphere {
                Hemisphere::Cosine => DiffuseSampling::Cosine,
                Hemisphere::Uniform | Hemisphere::UniformUnweighted => DiffuseSampling::Uniform,
            },
        },
        triangle_sampling: args.triangle_sampling,
        // With a map, --background is what the camera sees behind the scene; a transparent
        // one is nothing, in front of any light.
        camera_background: match (args.background, env_map) {
            (Some(Background::Transparent), _) => Some(Vec3::ZERO),
            (Some(Background::Color(c)), true) => Some(Vec3::from_array(c)),
            _ => None,
        },
    }
}

/// The default output: the scene's name with `.exr`, in the current directory.
/// `path` for frame `frame`: a run of `#` in its file name becomes the frame number padded
/// with zeros to the run's length (`shot.####.exr` → `shot.0012.exr`); a name without one
/// gets `.FFFF` before its extension (`shot.exr` → `shot.0012.exr`).
pub fn frame_path(path: &Path, frame: u32) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let renamed = match name.find('#') {
        Some(start) => {
            let width = name[start..].chars().take_while(|&c| c == '#').count();
            let hashes = "#".repeat(width);
            name.replacen(&hashes, &format!("{frame:0width$}"), 1)
        }
        None => match name.rsplit_once('.') {
            Some((stem, ext)) => format!("{stem}.{frame:04}.{ext}"),
            None => format!("{name}.{frame:04}"),
        },
    };
    path.with_file_name(renamed)
}

fn default_output(scene: &Path) -> PathBuf {
    let stem = scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "render".into());
    PathBuf::from(format!("{stem}.exr"))
}

/// The default `--max-memory`: 3/4 of physical memory (`MemTotal` in /proc/meminfo, or the
/// cgroup v2 `memory.max` of a container when that is lower).
pub fn default_memory_limit() -> Result<u64, String> {
    let text = std::fs::read_to_string("/proc/meminfo")
        .map_err(|e| format!("cannot read /proc/meminfo: {e}"))?;
    let kib = text
        .lines()
        .find_map(|l| l.strip_prefix("MemTotal:"))
        .and_then(|v| v.trim().strip_suffix("kB"))
        .and_then(|v| v.trim().parse::<u64>().ok())
        .ok_or("no MemTotal line in /proc/meminfo")?;
    let mut total = kib.saturating_mul(1024);
    if let Ok(max) = std::fs::read_to_string("/sys/fs/cgroup/memory.max") {
        if let Ok(m) = max.trim().parse::<u64>() {
            total = total.min(m);
        }
    }
    Ok(total / 4 * 3)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shading::TriangleSampling;
    use clap::Parser;

    fn ao_wall() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/ao-wall.gltf")
    }

    /// `render ao-wall.gltf -o <dir>/out.exr` and `extra`, parsed.
    fn args(dir: &Path, extra: &[&str]) -> Args {
        let scene = ao_wall();
        let out = dir.join("out.exr");
        let mut all = vec![
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        all.extend_from_slice(extra);
        Args::try_parse_from(all).unwrap()
    }

    fn job(extra: &[&str]) -> Result<Job, JobError> {
        let dir = tempfile::tempdir().unwrap();
        Job::from_args(&args(dir.path(), extra))
    }

    /// `--orbit 360 --frames 10..13`: a turntable of four frames, a quarter turn apart, the
    /// last one short of a whole turn so that the loop does not repeat a frame.
    #[test]
    fn an_orbit_over_frames_is_a_turntable() {
        let frames = job(&["--orbit", "360", "--frames", "10..13"])
            .unwrap()
            .frame_jobs();
        let turns: Vec<f32> = frames.iter().map(|j| j.aim.orbit.to_degrees()).collect();
        assert_eq!(turns.len(), 4);
        for (got, want) in turns.iter().zip([0.0, 90.0, 180.0, 270.0]) {
            assert!((got - want).abs() < 1e-3, "{turns:?}");
        }
        assert_eq!(
            job(&["--orbit", "-30"]).unwrap().aim.orbit,
            (-30f32).to_radians()
        );
    }

    #[test]
    fn defaults_depend_on_the_stopping_rule() {
        let fixed = job(&[]).unwrap();
        assert_eq!(
            (fixed.spp, fixed.min_spp),
            (DEFAULT_SPP, Stopping::DEFAULT_MIN_SPP)
        );
        assert_eq!(fixed.integrator.kind(), IntegratorKind::Path);
        assert!(fixed.png && fixed.robust && fixed.quads);
        assert_eq!(fixed.experiments, Experiments::default());
        assert!(fixed.warnings.iter().all(|w| !w.contains("--sampler")));

        let adaptive = job(&["--target-error", "0.01"]).unwrap();
        assert_eq!(adaptive.spp, PROGRESSIVE_MAX_SPP);
        let timed = job(&["--time-limit", "2", "--spp", "8"]).unwrap();
        assert_eq!((timed.spp, timed.min_spp), (8, 8));
        assert_eq!(timed.stopping().time_limit, Some(Duration::from_secs(2)));
    }

    #[test]
    fn options_become_settings() {
        let j = job(&[
            "--integrator",
            "direct",
            "--max-depth",
            "5",
            "--strategy",
            "light",
            "--triangle-sampling",
            "solid-angle",
            "--padded-bounces",
            "--no-robust",
            "--no-quads",
            "--no-camera-packets",
            "--sample-variance-error",
            "--background",
            "0.5",
        ])
        .unwrap();
        let Integrator::Direct(p) = j.integrator else {
            panic!("not direct: {:?}", j.integrator)
        };
        assert_eq!(p.max_depth, 1, "direct lighting is one bounce");
        assert_eq!(p.strategy, crate::integrators::Strategy::Light);
        assert!(!j.experiments.joint_bounces);
        assert_eq!(j.shading.triangle_sampling, TriangleSampling::SolidAngle);
        assert!(!j.robust && !j.quads);
        assert!(!j.experiments.camera_packets && !j.experiments.error_halves);
        assert_eq!(
            j.shading.environment,
            Environment::Constant(Vec3::splat(0.5))
        );
        let options = j.accel_options(3);
        assert_eq!(
            (options.threads, options.robust, options.quads),
            (3, false, false)
        );

        let ao = job(&[
            "--integrator",
            "ao",
            "--ao-distance",
            "2.5",
            "--ao-samples",
            "4",
        ])
        .unwrap();
        let Integrator::Ao(a) = ao.integrator else {
            panic!("not AO")
        };
        assert_eq!((a.max_distance, a.samples), (2.5, 4));
    }

    #[test]
    fn bad_combinations_are_refused_naming_the_option() {
        let cases: &[(&[&str], &str)] = &[
            (&["--spp", "0"], "--spp must be at least 1"),
            (
                &["--spp", "70000"],
                "--sampler sobol supports at most 65536 samples per pixel (asked for 70000)",
            ),
            (
                &["--target-error", "0.1", "--min-spp", "0"],
                "--min-spp must be between 1 and --spp (65536), got 0",
            ),
            (
                &["--target-error", "0.1", "--min-spp", "1"],
                "--min-spp must be at least 2: a pixel's error is estimated from its samples' variance",
            ),
            (
                &["--target-error", "0.1", "--spp", "1"],
                "--target-error needs --spp of at least 2: a pixel's error is estimated from its samples' variance (got --spp 1)",
            ),
            (&["--ao-samples", "0"], "--ao-samples must be at least 1"),
            (&["--ao-distance=-1"], "--ao-distance must be positive (got -1)"),
            (
                &["--integrator", "path", "--hemisphere", "uniform-unweighted"],
                "--hemisphere uniform-unweighted is an AO test estimator; direct and path take cosine or uniform",
            ),
        ];
        for (extra, message) in cases {
            match job(extra) {
                Ok(_) => panic!("{extra:?} was accepted"),
                Err(e) => assert_eq!(e.to_string(), *message, "{extra:?}"),
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let mut a = args(dir.path(), &[]);
        a.output = Some(dir.path().join("out.tif"));
        let e = Job::from_args(&a).unwrap_err().to_string();
        assert!(e.contains("out.tif") && e.contains(".exr"), "{e}");
    }

    #[test]
    fn early_stopping_with_stratified_samples_is_a_warning() {
        let j = job(&["--sampler", "stratified", "--time-limit", "1"]).unwrap();
        assert!(
            j.warnings[0].starts_with("--sampler stratified lays its strata out"),
            "{:?}",
            j.warnings
        );
    }

    #[test]
    fn the_view_checks_the_options_against_the_scene() {
        let scene = crate::scene::load(&ao_wall(), &LoadOptions::default()).unwrap();
        let view = job(&["--resolution", "40x30"])
            .unwrap()
            .view(&scene)
            .unwrap();
        assert_eq!((view.width, view.height, view.framed), (40, 30, false));

        let e = job(&["--camera", "7"]).unwrap().view(&scene).unwrap_err();
        assert!(
            e.to_string().ends_with(
                ": --camera 7: no such camera; it has 0 'camera': perspective, 28.6° vertical field of view, at (1, 1, 0)"
            ),
            "{e}"
        );
        let e = job(&["--resolution", "10x10", "--pixel", "10,2"]);
        assert_eq!(
            e.unwrap().view(&scene).unwrap_err().to_string(),
            "--pixel 10,2 lies outside the 10x10 image"
        );
        let e = job(&["--max-memory", "1K"])
            .unwrap()
            .view(&scene)
            .unwrap_err();
        assert!(e
            .to_string()
            .contains("more than the limit of 1.0 KiB (--max-memory)"));
    }

    #[test]
    fn adaptive_sampling_and_checkpoints_cost_image_memory() {
        let plain = job(&[]).unwrap().image_memory(100, 100);
        let extra = job(&[
            "--target-error",
            "0.1",
            "--checkpoint",
            "5",
            "--variance",
            "v.exr",
        ])
        .unwrap()
        .image_memory(100, 100);
        let per_pixel = 12
            + Film::ADAPTIVE_BYTES_PER_PIXEL
            + Film::CHECKPOINT_BYTES_PER_PIXEL
            + Film::HALVES_BYTES_PER_PIXEL;
        assert_eq!(extra - plain, 100 * 100 * per_pixel);
    }

    #[test]
    fn passes_cost_image_memory() {
        let plain = job(&[]).unwrap().image_memory(100, 100);
        let with = |passes: &str| job(&["--passes", passes]).unwrap().image_memory(100, 100);
        // Feature totals: 13 16-byte integers in the film, as many in a round's tiles and
        // as many in the words of an interrupted render's saved sums.
        assert_eq!(with("depth") - plain, 100 * 100 * 3 * 13 * 16);
        assert_eq!(with("albedo,normal,uv") - plain, 100 * 100 * 3 * 13 * 16);
        // IDs: one u64 first hit (triangle and instance) in the film, one in a round's
        // tiles, and one in the saved sums.
        assert_eq!(with("object_id") - plain, 100 * 100 * 24);
        assert_eq!(
            with("depth,mesh_id") - plain,
            100 * 100 * (3 * 13 * 16 + 24)
        );
    }
}
