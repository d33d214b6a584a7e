//! The `render` command line's options, as clap parses them: each option's syntax, its
//! help text and the checks of a value on its own. What the options mean together is
//! [`crate::job::Job`]'s.

use std::path::PathBuf;

use crate::accel::{Backend, BuildQuality};
use crate::integrators::{Hemisphere, IntegratorKind, Strategy};
use crate::render::adaptive::ErrorMetric;
use crate::render::passes::Pass;
use crate::render::view::ViewTransform;
use crate::render::DEFAULT_MIN_PASS_SECONDS;
use crate::sampling::SamplerKind;
use crate::shading::lights::TriangleSampling;
use crate::shading::{MapSampling, MaterialModel};

/// The options of `render`, one field each; a field's doc comment is its `--help` text, and
/// `--help` opens with the package's description.
#[derive(clap::Parser, Debug)]
#[command(
    name = "render",
    version,
    about,
    long_about = None,
    after_help = "Denoise a strata EXR after the render: render denoise IN.exr [-o OUT.exr] (render denoise --help)\nMerge the partial EXRs of --shard: render merge PART.exr... -o OUT.exr (render merge --help)"
)]
pub struct Args {
    /// The scene: a .gltf (embedded or external buffers) or .glb file.
    pub scene: PathBuf,

    /// Image size [default: 640 wide, height from the camera's aspect ratio, else 640x480].
    #[arg(help_heading = "Scene and camera", long, value_name = "WxH", value_parser = parse_resolution)]
    pub resolution: Option<(u32, u32)>,

    /// Which camera of the file, in the order the default scene lists them (--list-cameras
    /// prints them).
    #[arg(help_heading = "Scene and camera", long, value_name = "N")]
    pub camera: Option<usize>,

    /// Print the file's cameras (index, name, projection, position) and exit.
    #[arg(help_heading = "Scene and camera", long)]
    pub list_cameras: bool,

    /// Place the camera at X,Y,Z (world units, glTF's +Y up), looking at --look-at (default:
    /// the centre of the scene's bounding box).
    #[arg(help_heading = "Scene and camera", long, value_name = "X,Y,Z", value_parser = parse_point)]
    pub look_from: Option<[f32; 3]>,

    /// Turn the camera to look at X,Y,Z (without --look-from, from where the camera is).
    #[arg(help_heading = "Scene and camera", long, value_name = "X,Y,Z", value_parser = parse_point)]
    pub look_at: Option<[f32; 3]>,

    /// The image's up direction with --look-from or --look-at [default: 0,1,0].
    #[arg(help_heading = "Scene and camera", long, value_name = "X,Y,Z", value_parser = parse_point)]
    pub up: Option<[f32; 3]>,

    /// Vertical field of view in degrees, for the file's perspective camera or the framing
    /// of a file without one [default: the camera's; 45 for the framing].
    #[arg(help_heading = "Scene and camera", long, value_name = "DEGREES", value_parser = parse_fov)]
    pub fov: Option<f32>,

    /// Depth of field: a thin lens of this aperture diameter, in scene units (glTF's metres),
    /// focused at --focus-distance. Perspective cameras only.
    #[arg(help_heading = "Scene and camera", long, value_name = "DIAMETER", value_parser = parse_length, conflicts_with = "f_stop")]
    pub aperture: Option<f32>,

    /// Depth of field: a thin lens of this f-number, its focal length that of the field of
    /// view on a 36 mm sensor across the image's larger side (Blender's default camera), in
    /// a scene of metres; e.g. 2.8. Perspective cameras only.
    #[arg(help_heading = "Scene and camera", long, value_name = "N", value_parser = parse_length)]
    pub f_stop: Option<f32>,

    /// The distance in focus, in scene units, with --aperture or --f-stop [default: the
    /// distance from the camera to --look-at, or to the centre of the scene's bounding box
    /// along the view].
    #[arg(help_heading = "Scene and camera", long, value_name = "DISTANCE", value_parser = parse_length)]
    pub focus_distance: Option<f32>,

    /// Turn the camera by DEGREES about the vertical axis (+Y) through the centre of the
    /// scene's bounding box, counter-clockwise seen from above. With --frames A..B, frame F
    /// turns by DEGREES·(F − A)/(B − A + 1): --orbit 360 makes a turntable that loops.
    #[arg(
        help_heading = "Scene and camera",
        long,
        value_name = "DEGREES",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub orbit: f32,

    /// Render frame F of the file's animation (at time F / --fps seconds), writing the EXR
    /// with the frame number in its name: `####` in -o becomes the zero-padded number,
    /// otherwise `.FFFF` goes before `.exr`.
    #[arg(
        help_heading = "Scene and camera",
        long,
        value_name = "F",
        conflicts_with = "frames"
    )]
    pub frame: Option<u32>,

    /// Render frames A to B (inclusive) of the file's animation, one EXR each, named as for
    /// --frame.
    #[arg(help_heading = "Scene and camera", long, value_name = "A..B", value_parser = parse_frame_range)]
    pub frames: Option<(u32, u32)>,

    /// Frames per second of --frame and --frames.
    #[arg(
        help_heading = "Scene and camera",
        long,
        value_name = "FPS",
        default_value_t = 24.0
    )]
    pub fps: f64,

    /// Which of the file's animations --frame and --frames play (its index).
    #[arg(
        help_heading = "Scene and camera",
        long,
        value_name = "N",
        default_value_t = 0
    )]
    pub animation: usize,

    /// Constant environment radiance, linear RGB [default: black, or a white sky of radiance 1
    /// for a scene that brings no light meant to light it]; with --env, what the camera sees
    /// behind the scene while the map lights it. `transparent`: the camera sees nothing
    /// behind the scene (the lighting is as without --background) and the EXR and PNG get
    /// an alpha channel, the scene's coverage of each pixel.
    #[arg(help_heading = "Lighting", long, value_name = "R,G,B|transparent", value_parser = parse_background)]
    pub background: Option<Background>,

    /// Environment map: an equirectangular (latitude-longitude) Radiance .hdr or OpenEXR .exr
    /// of linear radiance, oriented as Blender orients a world environment texture, and
    /// importance-sampled (direct and path tracing). `none`: no environment, and no default
    /// sky for a scene that brings no light meant to light it (a file named so: ./none).
    #[arg(help_heading = "Lighting", long, value_name = "FILE")]
    pub env: Option<PathBuf>,

    /// Turn the environment map about +Y by DEGREES, counter-clockwise seen from above.
    #[arg(
        help_heading = "Lighting",
        long,
        value_name = "DEGREES",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub env_rotate: f32,

    /// Scale the environment map's radiance by S.
    #[arg(
        help_heading = "Lighting",
        long,
        value_name = "S",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub env_intensity: f32,

    /// What light sampling draws the map's directions in proportion to: its luminance, or its
    /// luminance less the mean (MIS compensation: light samples go to what outshines the
    /// average, BSDF samples find the rest). With --strategy light or bsdf: radiance.
    #[arg(
        help_heading = "Lighting",
        long,
        default_value = "compensated",
        value_name = "radiance|compensated",
        hide_possible_values = true
    )]
    pub env_sampling: MapSampling,

    /// Light transport algorithm: path tracing (the image a user expects), direct lighting,
    /// or ambient occlusion.
    #[arg(
        help_heading = "Quality",
        long,
        default_value = "path",
        value_name = "ao|direct|path",
        hide_possible_values = true
    )]
    pub integrator: IntegratorKind,

    /// Samples per pixel; with --target-error or --time-limit, the most a pixel takes
    /// [default: 64; with --target-error or --time-limit, 65536].
    #[arg(help_heading = "Quality", long)]
    pub spp: Option<u32>,

    /// Adaptive sampling: stop sampling a pixel once the estimated relative standard error of
    /// its value (and of its eight neighbours') is at most this, e.g. 0.01 for 1%.
    #[arg(help_heading = "Quality", long, value_name = "E", value_parser = parse_target_error)]
    pub target_error: Option<f32>,

    /// Adaptive sampling: the samples every pixel takes before its error is judged.
    #[arg(
        help_heading = "Quality",
        long,
        value_name = "N",
        requires = "target_error"
    )]
    pub min_spp: Option<u32>,

    /// Adaptive sampling: --target-error is relative to the pixel's value (what a tone-mapped
    /// image shows), or absolute, in radiance units (what RMSE measures). With --time-limit it
    /// also decides where the samples go: where they lower this error most.
    #[arg(
        help_heading = "Quality",
        long,
        default_value = "relative",
        value_name = "relative|absolute",
        hide_possible_values = true,
        requires = "target_error"
    )]
    pub error_metric: ErrorMetric,

    /// Stop the render after this many seconds of rendering (loading and the BVH build not
    /// counted), keeping every sample taken so far; exits with success. The image then
    /// depends on the machine's speed.
    #[arg(help_heading = "Quality", long, value_name = "SECONDS", value_parser = parse_seconds)]
    pub time_limit: Option<f64>,

    /// Path tracing: the most bounces (1 = direct lighting; Mitsuba's max_depth is this + 1).
    #[arg(
        help_heading = "Quality",
        long,
        default_value_t = 8,
        value_name = "BOUNCES"
    )]
    pub max_depth: u32,

    /// Path tracing: Russian roulette from this bounce on.
    #[arg(
        help_heading = "Quality",
        long,
        default_value_t = 5,
        value_name = "BOUNCES"
    )]
    pub rr_depth: u32,

    /// Direct and path: how direct light is sampled: MIS of light and BSDF sampling, or one alone.
    #[arg(
        help_heading = "Quality",
        long,
        default_value = "mis",
        value_name = "mis|light|bsdf",
        hide_possible_values = true
    )]
    pub strategy: Strategy,

    /// Direct and path: extra camera rays per sample that estimate the emission the camera sees directly, in the pixels where an emitter's outline may be seen (antialiases lights' outlines); fewer where outlines cover much of the image (at most one per sample on average); 0: none.
    #[arg(help_heading = "Quality", long, default_value_t = 16, value_name = "N", value_parser = clap::value_parser!(u32).range(0..=256))]
    pub emitter_samples: u32,

    /// Direct and path: how points on emissive triangles are sampled.
    #[arg(
        help_heading = "Quality",
        long,
        default_value = "area",
        value_name = "area|solid-angle",
        hide_possible_values = true
    )]
    pub triangle_sampling: TriangleSampling,

    /// Sample generator: random, stratified (correlated multi-jitter) or sobol (Owen-scrambled).
    #[arg(
        help_heading = "Quality",
        long,
        default_value = "sobol",
        value_name = "random|stratified|sobol",
        hide_possible_values = true
    )]
    pub sampler: SamplerKind,

    /// Random seed; the same seed, scene and settings give the same image on any thread count.
    #[arg(help_heading = "Quality", long, default_value_t = 0)]
    pub seed: u64,

    /// AO: occluders farther than this distance are ignored [default: unlimited].
    #[arg(help_heading = "Quality", long, value_name = "DISTANCE")]
    pub ao_distance: Option<f32>,

    /// AO: rays per camera hit, averaged (Mitsuba's shading_samples).
    #[arg(help_heading = "Quality", long, default_value_t = 1, value_name = "N")]
    pub ao_samples: u32,

    /// Hemisphere sampling of AO rays and of Lambertian reflection (`--materials lambertian`):
    /// cosine-weighted, or uniform (weighted by cos θ / pdf), for comparisons.
    #[arg(
        help_heading = "Quality",
        long,
        default_value = "cosine",
        value_name = "cosine|uniform",
        hide_possible_values = true
    )]
    pub hemisphere: Hemisphere,

    /// Material model: the glTF metallic-roughness BRDF the file describes, or Lambertian
    /// reflection of the base colour (a clay override for look-dev: metallic, roughness and
    /// their texture ignored).
    #[arg(
        help_heading = "Quality",
        long,
        default_value = "gltf",
        value_name = "gltf|lambertian",
        hide_possible_values = true
    )]
    pub materials: MaterialModel,

    /// Multiple-scattering energy compensation of the glTF BRDF (Kulla & Conty 2017's
    /// multiple-scattering lobe for metals and their layering for the diffuse below the
    /// dielectric's specular layer, Turquin 2019 for that layer): rough metals keep their
    /// brightness. `off` renders the specification's single-scattering model exactly,
    /// as the reference images do.
    #[arg(
        help_heading = "Quality",
        long,
        default_value = "on",
        value_name = "on|off",
        hide_possible_values = true
    )]
    pub energy_compensation: OnOff,

    /// Output file [default: the scene's name with .exr, in the current directory]: an .exr
    /// (linear, with a .png preview beside it), or a .png or .jpg of the image through the view
    /// transform alone.
    #[arg(help_heading = "Output", short, long, value_name = "FILE.exr")]
    pub output: Option<PathBuf>,

    /// Render passes written as layers of the EXR beside the beauty, comma-separated:
    /// albedo (albedo.R/G/B), normal (normal.X/Y/Z), depth (depth.Z), position
    /// (position.X/Y/Z), uv (uv.U/V), each the pixel's mean over its samples of the camera
    /// ray's first hit; object_id, mesh_id, material_id (object_id.ID, ...), the glTF node,
    /// mesh and material indices of its sample 0's hit, exact, -1 where it met nothing
    /// (README, "Render passes").
    #[arg(
        help_heading = "Output",
        long,
        value_name = "LIST",
        value_delimiter = ','
    )]
    pub passes: Vec<Pass>,

    /// Denoise the beauty with Intel Open Image Denoise (loaded at run time; README, "Denoising"):
    /// the EXR's R, G, B are the denoised image, the raw one is kept as the layer `noisy`,
    /// and the albedo and normal passes the denoiser reads are written too.
    #[arg(help_heading = "Output", long)]
    pub denoise: bool,

    /// With --denoise: denoise the albedo and normal passes first and treat them as clean
    /// (on: final-frame quality), or give them to the denoiser as they are (off: faster).
    #[arg(
        help_heading = "Output",
        long,
        value_name = "on|off",
        default_value = "on"
    )]
    pub denoise_prefilter: OnOff,

    #[command(flatten, next_help_heading = "Output")]
    pub preview: PreviewArgs,

    /// Also write each pixel's estimated variance of the mean (sample variance / samples) as
    /// an RGB EXR, for statistical comparisons.
    #[arg(help_heading = "Output", long, value_name = "FILE.exr")]
    pub variance: Option<PathBuf>,

    /// Also write each pixel's number of samples as a grey EXR (useful with --target-error).
    #[arg(help_heading = "Output", long, value_name = "FILE.exr")]
    pub spp_image: Option<PathBuf>,

    /// Write the running image (and the variance image) to the output path(s) at most every
    /// SECONDS during the render, atomically, so a crash or kill loses at most that much.
    #[arg(help_heading = "Output", long, value_name = "SECONDS", value_parser = parse_seconds)]
    pub checkpoint: Option<f64>,

    /// Continue the render saved in FILE (what an interrupted render or a checkpoint wrote) to
    /// --spp: give the options it was rendered with. Each pixel continues from its samples,
    /// so the image equals an uninterrupted render's bit for bit. Fixed-spp renders only.
    #[arg(help_heading = "Output", long, value_name = "FILE.exr")]
    pub resume: Option<PathBuf>,

    /// When stderr is not a terminal (a farm's log, a pipe), print a progress line every
    /// SECONDS instead of the progress bar; 0: none.
    #[arg(help_heading = "Output", long, value_name = "SECONDS", default_value_t = 10.0, value_parser = parse_seconds_or_zero)]
    pub progress_every: f64,

    /// Print the time of each phase and the rays by kind.
    #[arg(help_heading = "Output", long)]
    pub stats: bool,

    /// Refuse a scene with a texture image that is missing or does not decode, naming it and
    /// the problem, instead of warning and rendering those textures as absent (their
    /// factors alone).
    #[arg(help_heading = "Output", long)]
    pub strict: bool,

    /// Render shard I of N (I from 0: a farm's task index, e.g. $SLURM_ARRAY_TASK_ID), the
    /// samples spp·I/N to spp·(I+1)/N of every pixel, as a partial EXR named -o with
    /// `.shard-I-of-N` before `.exr`. `render merge` joins the N partial files into the image
    /// one machine would have rendered, bit for bit. No PNG preview.
    #[arg(help_heading = "Farm", long, value_name = "I/N", value_parser = parse_shard, conflicts_with = "samples")]
    pub shard: Option<(u32, u32)>,

    /// Render the samples of index A to B − 1 of every pixel as a partial EXR named -o with
    /// `.samples-A-B` before `.exr`, as --shard does for its share.
    #[arg(help_heading = "Farm", long, value_name = "A..B", value_parser = parse_sample_range)]
    pub samples: Option<(u32, u32)>,

    /// Worker threads (0: all cores).
    #[arg(help_heading = "Advanced", long, default_value_t = 0)]
    pub threads: usize,

    /// Refuse a scene whose estimated memory (geometry, BVH, decoded textures, environment
    /// map and image, from the file's declared counts and the images' headers, before
    /// loading) exceeds this: bytes, or with a suffix K, M, G, T (powers of 1024), e.g.
    /// 512M, 4G; 'unlimited' for no limit [default: 3/4 of physical memory].
    #[arg(help_heading = "Advanced", long, value_name = "BYTES", value_parser = parse_memory)]
    pub max_memory: Option<MemoryLimit>,

    /// Ray tracing backend: Embree, or the pure-Rust CWBVH of the obvhs crate.
    #[arg(
        help_heading = "Advanced",
        long,
        default_value = "embree",
        value_name = "embree|obvhs",
        hide_possible_values = true
    )]
    pub backend: Backend,

    /// BVH build quality.
    #[arg(
        help_heading = "Advanced",
        long,
        default_value = "medium",
        value_name = "low|medium|high",
        hide_possible_values = true
    )]
    pub bvh_quality: BuildQuality,

    /// Render only this pixel (all its samples) and print its value; the rest of the image is 0.
    #[arg(help_heading = "Advanced", long, value_name = "X,Y", value_parser = parse_pixel)]
    pub pixel: Option<(u32, u32)>,

    /// Render MASK and BLEND materials opaque, ignoring their alpha, as renderers that ignore
    /// glTF alpha coverage do (for comparisons with them).
    #[arg(help_heading = "Advanced", long)]
    pub no_alpha: bool,

    /// Store every placement of a mesh as a world-space copy of its triangles, where a mesh
    /// that several nodes or EXT_mesh_gpu_instancing instances place is otherwise stored
    /// once and placed by BVH instances: memory grows with the placements (for comparisons).
    #[arg(help_heading = "Advanced", long)]
    pub flatten_instances: bool,

    /// Turn off Embree's watertight (robust) traversal, for measurements only.
    #[arg(help_heading = "Advanced", long, hide = true)]
    pub no_robust: bool,

    /// Trace every triangle as a triangle, never pairs of them as quads (Embree), for
    /// measurements only.
    #[arg(help_heading = "Advanced", long, hide = true)]
    pub no_quads: bool,

    /// Trace camera rays one at a time instead of in packets of 4×2 pixels (the image is the
    /// same; for measuring what packets gain)
    #[arg(help_heading = "Advanced", long)]
    pub no_camera_packets: bool,

    /// Adaptive sampling: estimate each pixel's error from its samples' variance alone, not
    /// from the two halves of its samples; for measurements only.
    #[arg(help_heading = "Advanced", long, hide = true)]
    pub sample_variance_error: bool,

    /// Path tracing: draw each bounce's sample point from a Sobol sequence of its own
    /// (padding) instead of stratifying the bounces jointly; for measurements only.
    #[arg(help_heading = "Advanced", long, hide = true)]
    pub padded_bounces: bool,

    /// Tile edge in pixels.
    #[arg(help_heading = "Advanced", long, default_value_t = 16, hide = true)]
    pub tile_size: u32,

    /// Least length of a pass, in seconds, at the rate measured so far (by a probe of a few
    /// tiles, for the first pass; 0: no probe, and passes of 1, 1, 2, 4, … samples per pixel,
    /// for measuring what passes cost).
    #[arg(help_heading = "Advanced", long, default_value_t = DEFAULT_MIN_PASS_SECONDS, hide = true,
          value_parser = parse_seconds_or_zero)]
    pub min_pass_seconds: f64,
}

impl Args {
    /// The constant colour `--background` gives (None: none, or transparent).
    pub fn background_color(&self) -> Option<[f32; 3]> {
        match self.background {
            Some(Background::Color(c)) => Some(c),
            _ => None,
        }
    }
}

fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}': expected WIDTHxHEIGHT, e.g. 640x480"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|&n| (1..=65536).contains(&n))
    };
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!(
            "'{s}': width and height must be integers in 1..=65536"
        )),
    }
}

/// What `--background` asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Background {
    /// A constant environment of this radiance (behind an `--env` map: what the camera sees).
    Color([f32; 3]),
    /// Nothing behind the scene, and an alpha channel.
    Transparent,
}

fn parse_background(s: &str) -> Result<Background, String> {
    match s.trim() {
        "transparent" => Ok(Background::Transparent),
        _ => parse_rgb(s)
            .map(Background::Color)
            .map_err(|e| format!("{e}, or transparent")),
    }
}

fn parse_rgb(s: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}': expected R,G,B"))?;
    match v[..] {
        [r, g, b] if v.iter().all(|c| c.is_finite() && *c >= 0.0) => Ok([r, g, b]),
        [c] if c.is_finite() && c >= 0.0 => Ok([c, c, c]),
        _ => Err(format!("'{s}': expected three non-negative numbers R,G,B")),
    }
}

/// A point or direction X,Y,Z of finite numbers.
fn parse_point(s: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}': expected X,Y,Z"))?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        _ => Err(format!("'{s}': expected three finite numbers X,Y,Z")),
    }
}

/// A vertical field of view in degrees, in (0, 180).
/// A positive, finite length (or f-number).
fn parse_length(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("'{s}': expected a positive number")),
    }
}

fn parse_fov(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(d) if d > 0.0 && d < 180.0 => Ok(d),
        _ => Err(format!(
            "'{s}': expected degrees between 0 and 180, exclusive"
        )),
    }
}

/// A switch given as `on` or `off`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

crate::display_as_value_name!(OnOff);

impl OnOff {
    pub fn is_on(self) -> bool {
        self == OnOff::On
    }
}

/// `--max-memory`: a number of bytes, or no limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryLimit(pub Option<u64>);

fn parse_memory(s: &str) -> Result<MemoryLimit, String> {
    let t = s.trim().to_ascii_lowercase();
    if t == "unlimited" || t == "none" {
        return Ok(MemoryLimit(None));
    }
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, suffix) = t.split_at(split);
    let unit: u64 = match suffix.trim() {
        "" | "b" => 1,
        "k" | "kb" | "kib" => 1 << 10,
        "m" | "mb" | "mib" => 1 << 20,
        "g" | "gb" | "gib" => 1 << 30,
        "t" | "tb" | "tib" => 1 << 40,
        _ => {
            return Err(format!(
                "'{s}': expected bytes with an optional suffix K, M, G or T (e.g. 512M, 4G), or 'unlimited'"
            ))
        }
    };
    let n: f64 = number
        .parse()
        .map_err(|_| format!("'{s}': expected a number of bytes, e.g. 512M, 4G, or 'unlimited'"))?;
    let bytes = n * unit as f64;
    if !(bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!(
            "'{s}': must be at least 1 byte (or 'unlimited' for no limit)"
        ));
    }
    Ok(MemoryLimit(Some(bytes as u64)))
}

fn parse_target_error(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!(
            "'{s}': expected a positive relative error, e.g. 0.01 for 1%"
        )),
    }
}

fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() && v < 1e9 => Ok(v),
        _ => Err(format!("'{s}': expected a positive number of seconds")),
    }
}

/// [`parse_seconds`], but 0 is allowed.
fn parse_seconds_or_zero(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(0.0) => Ok(0.0),
        _ => parse_seconds(s)
            .map_err(|_| format!("'{s}': expected 0 or a positive number of seconds")),
    }
}

fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    let (x, y) = s
        .split_once(',')
        .ok_or_else(|| format!("'{s}': expected X,Y"))?;
    match (x.trim().parse(), y.trim().parse()) {
        (Ok(x), Ok(y)) => Ok((x, y)),
        _ => Err(format!("'{s}': expected two pixel coordinates X,Y")),
    }
}

/// The options of `render denoise`: denoise an EXR that strata wrote (its beauty, guided by
/// its albedo and normal layers), e.g. a farm's merged image. The output keeps every layer
/// and header attribute of the input, with R, G, B denoised and the raw beauty in `noisy`;
/// an input denoised before has its `noisy` layer denoised again.
#[derive(clap::Parser, Debug)]
#[command(name = "render denoise", version, long_about = None)]
pub struct DenoiseArgs {
    /// The EXR to denoise.
    pub input: PathBuf,

    /// The denoised EXR (default: the input's name with `-denoised`; may be the input itself).
    #[arg(short, long, value_name = "FILE.exr")]
    pub output: Option<PathBuf>,

    /// Denoise the albedo and normal layers first and treat them as clean (on: final-frame
    /// quality), or give them to the denoiser as they are (off: faster).
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub denoise_prefilter: OnOff,

    /// Threads the denoiser may use (0: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,

    #[command(flatten)]
    pub preview: PreviewArgs,
}

/// The options of `render merge`: join the partial EXRs of a farm's shards (`render --shard`,
/// `--samples`) into the image one machine would have rendered, bit for bit, with every pass.
/// The parts must be of the same scene (the same file contents), settings and seed, hold
/// disjoint sample ranges, and together hold every sample; denoise after the merge
/// (`render denoise`).
#[derive(clap::Parser, Debug)]
#[command(name = "render merge", version, long_about = None)]
pub struct MergeArgs {
    /// The partial EXRs, in any order.
    #[arg(required = true, value_name = "PART.exr")]
    pub parts: Vec<PathBuf>,

    /// The merged EXR.
    #[arg(
        short,
        long,
        value_name = "FILE.exr",
        required_unless_present = "check"
    )]
    pub output: Option<PathBuf>,

    /// Only check the parts (their headers): list the sample ranges, and the shards, that
    /// are missing for a re-run. Exit status 0 when the parts are complete, 3 when samples
    /// are missing, 1 when the parts do not belong together.
    #[arg(long)]
    pub check: bool,

    /// Merge parts of one contiguous range of samples into a partial file of that range, for
    /// a later merge: the parts of a farm of many nodes then merge as a tree, groups in
    /// parallel, rather than one after another. No PNG.
    #[arg(long, conflicts_with = "check")]
    pub partial: bool,

    #[command(flatten)]
    pub preview: PreviewArgs,
}

/// The PNG preview's options, shared by `render`, `render denoise` and `render merge`.
#[derive(clap::Args, Debug)]
pub struct PreviewArgs {
    /// Do not write the PNG preview beside the EXR.
    #[arg(long)]
    pub no_png: bool,

    /// The PNG preview's view transform: agx (highlights roll off, as Blender 4 shows by
    /// default) or standard (clamped sRGB). The EXR stays linear.
    #[arg(long, value_name = "VIEW", default_value_t = ViewTransform::Agx)]
    pub view: ViewTransform,

    /// Scale the PNG preview's radiance by 2^EV before its view transform.
    #[arg(
        long,
        value_name = "EV",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub exposure: f32,
}

/// Two whole numbers `A<separator>B`; the errors call the form `form` (with an example) and
/// each number `what`.
fn parse_pair(text: &str, separator: &str, form: &str, what: &str) -> Result<(u32, u32), String> {
    let (a, b) = text
        .split_once(separator)
        .ok_or_else(|| format!("'{text}' is not {form}"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("'{v}' in '{text}' is not {what}"))
    };
    Ok((parse(a)?, parse(b)?))
}

/// `I/N` with I < N: shard I (from 0) of N.
fn parse_shard(text: &str) -> Result<(u32, u32), String> {
    let form = "a shard I/N (e.g. 0/4, the first of four)";
    let (i, n) = parse_pair(text, "/", form, "a whole number")?;
    if n == 0 {
        return Err(format!("'{text}': there must be at least one shard"));
    }
    if i >= n {
        return Err(format!(
            "'{text}': the shard index counts from 0 and must be below the number of shards (0/{n} to {}/{n})",
            n - 1
        ));
    }
    Ok((i, n))
}

/// `A..B` with A < B: the sample indices A to B − 1.
fn parse_sample_range(text: &str) -> Result<(u32, u32), String> {
    let form = "a range of samples A..B (e.g. 0..64)";
    let (a, b) = parse_pair(text, "..", form, "a sample index")?;
    if a >= b {
        return Err(format!(
            "the range {text} holds no samples: A..B takes A to B - 1"
        ));
    }
    Ok((a, b))
}

/// `A..B` with A ≤ B: a range of frames, both included.
fn parse_frame_range(text: &str) -> Result<(u32, u32), String> {
    let form = "a range of frames A..B (e.g. 1..48)";
    let (a, b) = parse_pair(text, "..", form, "a frame number")?;
    if a > b {
        return Err(format!(
            "the range {text} is empty: its first frame is after its last"
        ));
    }
    Ok((a, b))
}
