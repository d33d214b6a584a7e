//! `render`: the strata command line. Parse, load, build, render, write, report.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use clap::Parser;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use strata::accel::{Accel, AccelOptions, Backend, BuildQuality};
use strata::integrators::{
    AoSettings, Hemisphere, Integrator, IntegratorKind, PathSettings, Prepared, Strategy,
};
use strata::lights::TriangleSampling;
use strata::render::adaptive::ErrorMetric;
use strata::render::output::{self, Attr};
use strata::render::{self, Checkpoint, Film, RenderSettings, RenderStats, Stopping};
use strata::sampling::sampler::SOBOL_MAX_SPP;
use strata::sampling::SamplerKind;
use strata::scene::{self, format_bytes, Camera, LoadOptions};

/// Render a glTF 2.0 scene to a linear float32 EXR (and an sRGB PNG preview).
#[derive(Parser, Debug)]
#[command(name = "render", version, about, long_about = None)]
struct Cli {
    /// The scene: a .gltf (embedded or external buffers) or .glb file.
    scene: PathBuf,

    /// Output EXR file [default: the scene's name with .exr, in the current directory].
    #[arg(short, long, value_name = "FILE.exr")]
    output: Option<PathBuf>,

    /// Ray tracing backend: Embree, or the pure-Rust CWBVH of the obvhs crate.
    #[arg(
        long,
        default_value = "embree",
        value_name = "embree|obvhs",
        hide_possible_values = true
    )]
    backend: Backend,

    /// Light transport algorithm: ambient occlusion, direct lighting, or path tracing.
    #[arg(
        long,
        default_value = "ao",
        value_name = "ao|direct|path",
        hide_possible_values = true
    )]
    integrator: IntegratorKind,

    /// Path tracing: the most bounces (1 = direct lighting; Mitsuba's max_depth is this + 1).
    #[arg(long, default_value_t = 8, value_name = "BOUNCES")]
    max_depth: u32,

    /// Direct and path: how direct light is sampled: MIS of light and BSDF sampling, or one alone.
    #[arg(
        long,
        default_value = "mis",
        value_name = "mis|light|bsdf",
        hide_possible_values = true
    )]
    strategy: Strategy,

    /// Path tracing: Russian roulette from this bounce on.
    #[arg(long, default_value_t = 5, value_name = "BOUNCES")]
    rr_depth: u32,

    /// Direct and path: how points on emissive triangles are sampled.
    #[arg(
        long,
        default_value = "area",
        value_name = "area|solid-angle",
        hide_possible_values = true
    )]
    triangle_sampling: TriangleSampling,

    /// Direct and path: extra camera rays per sample that estimate the emission the camera sees directly, in the pixels where an emitter's outline may be seen (antialiases lights' outlines); fewer where outlines cover much of the image (at most one per sample on average); 0: none.
    #[arg(long, default_value_t = 16, value_name = "N", value_parser = clap::value_parser!(u32).range(0..=256))]
    emitter_samples: u32,

    /// Constant environment radiance, linear RGB [default: black].
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb)]
    background: Option<[f32; 3]>,

    /// Render only this pixel (all its samples) and print its value; the rest of the image is 0.
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel)]
    pixel: Option<(u32, u32)>,

    /// Sample generator: random, stratified (correlated multi-jitter) or sobol (Owen-scrambled).
    #[arg(
        long,
        default_value = "sobol",
        value_name = "random|stratified|sobol",
        hide_possible_values = true
    )]
    sampler: SamplerKind,

    /// Samples per pixel; with --target-error or --time-limit, the most a pixel takes
    /// [default: 64; with --target-error or --time-limit, 65536].
    #[arg(long)]
    spp: Option<u32>,

    /// Adaptive sampling: stop sampling a pixel once the estimated relative standard error of
    /// its value (and of its eight neighbours') is at most this, e.g. 0.01 for 1%.
    #[arg(long, value_name = "E", value_parser = parse_target_error)]
    target_error: Option<f32>,

    /// Adaptive sampling: the samples every pixel takes before its error is judged.
    #[arg(long, value_name = "N", requires = "target_error")]
    min_spp: Option<u32>,

    /// Adaptive sampling: --target-error is relative to the pixel's value (what a tone-mapped
    /// image shows), or absolute, in radiance units (what RMSE measures). With --time-limit it
    /// also decides where the samples go: where they lower this error most.
    #[arg(
        long,
        default_value = "relative",
        value_name = "relative|absolute",
        hide_possible_values = true,
        requires = "target_error"
    )]
    error_metric: ErrorMetric,

    /// Stop the render after this many seconds of rendering (loading and the BVH build not
    /// counted), keeping every sample taken so far; exits with success. The image then
    /// depends on the machine's speed.
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    time_limit: Option<f64>,

    /// Random seed; the same seed, scene and settings give the same image on any thread count.
    #[arg(long, default_value_t = 0)]
    seed: u64,

    /// Worker threads (0: all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,

    /// Image size [default: 640 wide, height from the camera's aspect ratio, else 640x480].
    #[arg(long, value_name = "WxH", value_parser = parse_resolution)]
    resolution: Option<(u32, u32)>,

    /// Which camera of the file, in the order the default scene lists them.
    #[arg(long, value_name = "N")]
    camera: Option<usize>,

    /// AO: occluders farther than this distance are ignored [default: unlimited].
    #[arg(long, value_name = "DISTANCE")]
    ao_distance: Option<f32>,

    /// Hemisphere sampling of AO rays and of the path tracer's diffuse BSDF: cosine-weighted,
    /// or uniform (weighted by cos θ / pdf), for comparisons.
    #[arg(
        long,
        default_value = "cosine",
        value_name = "cosine|uniform",
        hide_possible_values = true
    )]
    hemisphere: Hemisphere,

    /// AO: rays per camera hit, averaged (Mitsuba's shading_samples).
    #[arg(long, default_value_t = 1, value_name = "N")]
    ao_samples: u32,

    /// BVH build quality.
    #[arg(
        long,
        default_value = "medium",
        value_name = "low|medium|high",
        hide_possible_values = true
    )]
    bvh_quality: BuildQuality,

    /// Adaptive sampling: estimate each pixel's error from its samples' variance alone, not
    /// from the two halves of its samples; for measurements only.
    #[arg(long, hide = true)]
    sample_variance_error: bool,

    /// Path tracing: draw each bounce's sample point from a Sobol sequence of its own
    /// (padding) instead of stratifying the bounces jointly; for measurements only.
    #[arg(long, hide = true)]
    padded_bounces: bool,

    /// Turn off Embree's watertight (robust) traversal, for measurements only.
    #[arg(long, hide = true)]
    no_robust: bool,

    /// Trace every triangle as a triangle, never pairs of them as quads (Embree), for
    /// measurements only.
    #[arg(long, hide = true)]
    no_quads: bool,

    /// Also write each pixel's estimated variance of the mean (sample variance / samples) as
    /// an RGB EXR, for statistical comparisons.
    #[arg(long, value_name = "FILE.exr")]
    variance: Option<PathBuf>,

    /// Also write each pixel's number of samples as a grey EXR (useful with --target-error).
    #[arg(long, value_name = "FILE.exr")]
    spp_image: Option<PathBuf>,

    /// Do not write the PNG preview beside the EXR.
    #[arg(long)]
    no_png: bool,

    /// Trace camera rays one at a time instead of in packets of 4×2 pixels (the image is the
    /// same; for measuring what packets gain)
    #[arg(long)]
    no_camera_packets: bool,

    /// Print the time of each phase and the rays by kind.
    #[arg(long)]
    stats: bool,

    /// Refuse a scene whose estimated memory (geometry, BVH and image, from the file's
    /// declared counts, before loading) exceeds this: bytes, or with a suffix K, M, G, T
    /// (powers of 1024), e.g. 512M, 4G; 'unlimited' for no limit [default: 3/4 of physical
    /// memory].
    #[arg(long, value_name = "BYTES", value_parser = parse_memory)]
    max_memory: Option<MemoryLimit>,

    /// Write the running image (and the variance image) to the output path(s) at most every
    /// SECONDS during the render, atomically, so a crash or kill loses at most that much.
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    checkpoint: Option<f64>,

    /// Tile edge in pixels.
    #[arg(long, default_value_t = 16, hide = true)]
    tile_size: u32,

    /// Least length of a pass, in seconds, at the rate measured so far (by a probe of a few
    /// tiles, for the first pass; 0: no probe, and passes of 1, 1, 2, 4, … samples per pixel,
    /// for measuring what passes cost).
    #[arg(long, default_value_t = render::DEFAULT_MIN_PASS_SECONDS, hide = true,
          value_parser = parse_seconds_or_zero)]
    min_pass_seconds: f64,
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

/// The default `--spp` of an adaptive or time-limited render: as many as the Sobol sampler
/// has, so the target error or the time limit is what stops it.
const PROGRESSIVE_MAX_SPP: u32 = SOBOL_MAX_SPP;

/// `--max-memory`: a number of bytes, or no limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct MemoryLimit(Option<u64>);

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

/// The default `--max-memory`: 3/4 of physical memory (`MemTotal` in /proc/meminfo, or the
/// cgroup v2 `memory.max` of a container when that is lower).
fn default_memory_limit() -> Result<u64, String> {
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

fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    let (x, y) = s
        .split_once(',')
        .ok_or_else(|| format!("'{s}': expected X,Y"))?;
    match (x.trim().parse(), y.trim().parse()) {
        (Ok(x), Ok(y)) => Ok((x, y)),
        _ => Err(format!("'{s}': expected two pixel coordinates X,Y")),
    }
}

/// How a successful run ended.
enum Outcome {
    Finished,
    Interrupted,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(Outcome::Finished) => ExitCode::SUCCESS,
        Ok(Outcome::Interrupted) => ExitCode::from(130),
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Ctrl-C: the first stops the render after the tiles in flight and saves the image; the
/// second exits at once, removing the temporary files of a write in progress (`temporaries`)
/// so nothing half-written is left; a file already in place (a checkpoint) stays.
fn install_interrupt_handler(temporaries: Vec<PathBuf>) -> Arc<AtomicBool> {
    let cancel = Arc::new(AtomicBool::new(false));
    let flag = cancel.clone();
    let installed = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            for t in &temporaries {
                let _ = std::fs::remove_file(t);
            }
            eprintln!("\ninterrupted twice: exiting without saving");
            std::process::exit(130);
        }
        eprintln!("\ninterrupted: finishing the tiles in flight and saving the image (Ctrl-C again to quit at once)");
    });
    if let Err(e) = installed {
        eprintln!("warning: cannot install the Ctrl-C handler ({e}); an interrupted render will not be saved");
    }
    cancel
}

fn default_output(scene: &Path) -> PathBuf {
    let stem = scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "render".into());
    PathBuf::from(format!("{stem}.exr"))
}

fn run(cli: Cli) -> Result<Outcome> {
    let output = cli
        .output
        .clone()
        .unwrap_or_else(|| default_output(&cli.scene));
    output::check_output_path(&output)?;
    for extra in [&cli.variance, &cli.spp_image].into_iter().flatten() {
        output::check_output_path(extra)?;
    }
    let progressive = cli.target_error.is_some() || cli.time_limit.is_some();
    let spp = cli
        .spp
        .unwrap_or(if progressive { PROGRESSIVE_MAX_SPP } else { 64 });
    if spp == 0 {
        bail!("--spp must be at least 1");
    }
    if cli.sampler == SamplerKind::Sobol && spp > SOBOL_MAX_SPP {
        bail!(
            "--sampler sobol supports at most {SOBOL_MAX_SPP} samples per pixel (asked for {spp})"
        );
    }
    if progressive && cli.sampler == SamplerKind::Stratified {
        eprintln!(
            "warning: --sampler stratified lays its strata out for all --spp {spp} samples; a render that stops early (--target-error, --time-limit) keeps little of its stratification. --sampler sobol (the default) is progressive: any prefix of its samples is well spread"
        );
    }
    let min_spp = cli.min_spp.unwrap_or(Stopping::DEFAULT_MIN_SPP.min(spp));
    if min_spp == 0 || min_spp > spp {
        bail!("--min-spp must be between 1 and --spp ({spp}), got {min_spp}");
    }
    if cli.target_error.is_some() && spp < 2 {
        bail!("--target-error needs --spp of at least 2: a pixel's error is estimated from its samples' variance (got --spp {spp})");
    }
    if cli.target_error.is_some() && min_spp < 2 {
        bail!(
            "--min-spp must be at least 2: a pixel's error is estimated from its samples' variance"
        );
    }
    if cli.ao_samples == 0 {
        bail!("--ao-samples must be at least 1");
    }
    let ao_distance = match cli.ao_distance {
        None => f32::INFINITY,
        Some(d) if d > 0.0 => d,
        Some(d) => bail!("--ao-distance must be positive (got {d})"),
    };
    let memory_limit = match cli.max_memory {
        Some(MemoryLimit(limit)) => limit,
        None => match default_memory_limit() {
            Ok(limit) => Some(limit),
            Err(e) => {
                eprintln!("warning: {e}; no memory limit (set one with --max-memory)");
                None
            }
        },
    };
    let mut temporaries = vec![
        output::temp_path(&output),
        output::temp_path(&output.with_extension("png")),
    ];
    temporaries.extend(cli.variance.as_deref().map(output::temp_path));
    temporaries.extend(cli.spp_image.as_deref().map(output::temp_path));
    let cancel = install_interrupt_handler(temporaries);

    // Load.
    let t_load = Instant::now();
    // The film, plus the variance image (float32 RGB) when one is written.
    let image_memory = |(w, h): (u32, u32)| {
        let mut extra = 12 * (cli.variance.is_some() as u64 + cli.spp_image.is_some() as u64);
        if cli.target_error.is_some() {
            extra += Film::ADAPTIVE_BYTES_PER_PIXEL;
        }
        if cli.checkpoint.is_some() {
            extra += Film::CHECKPOINT_BYTES_PER_PIXEL;
            if cli.target_error.is_some() && !cli.sample_variance_error {
                // The snapshot copies the film's halves too.
                extra += Film::HALVES_BYTES_PER_PIXEL;
            }
        }
        Film::memory_estimate(w, h) + w as u64 * h as u64 * extra
    };
    let load_options = LoadOptions {
        memory_limit,
        other_memory: cli.resolution.map_or(0, image_memory),
    };
    let scene = scene::load(&cli.scene, &load_options)?;
    let load_time = t_load.elapsed();
    for w in &scene.load_warnings {
        eprintln!("warning: {}: {w}", cli.scene.display());
    }

    // Camera and resolution.
    let chosen = match cli.camera {
        Some(i) => Some(scene.cameras.get(i).ok_or_else(|| {
            anyhow!(
                "{}: --camera {i}, but the file has {} camera(s)",
                cli.scene.display(),
                scene.cameras.len()
            )
        })?),
        None => scene.cameras.first(),
    };
    let (width, height) =
        cli.resolution
            .unwrap_or_else(|| match chosen.and_then(|c| c.aspect_ratio) {
                Some(a) => (640, ((640.0 / a).round() as u32).clamp(1, 65536)),
                None => (640, 480),
            });
    let scene_memory = scene.memory_estimate.bytes();
    let memory_needed = scene_memory.saturating_add(image_memory((width, height)));
    if let Some(limit) = memory_limit.filter(|&l| memory_needed > l) {
        bail!(
            "{}: rendering needs an estimated {} of memory (scene and BVH {}, {width}x{height} image {}), more than the limit of {} (--max-memory)",
            cli.scene.display(),
            format_bytes(memory_needed),
            format_bytes(scene_memory),
            format_bytes(image_memory((width, height))),
            format_bytes(limit)
        );
    }
    let camera = match chosen {
        Some(c) => c.clone(),
        None => {
            eprintln!(
                "note: {} has no camera; framing the scene's bounding box from +Z with a 45° vertical field of view",
                cli.scene.display()
            );
            Camera::framing(scene.bounds.0, scene.bounds.1, width as f32 / height as f32)
        }
    };

    // Acceleration structure.
    let pool = render::thread_pool(cli.threads).context("cannot start the worker threads")?;
    let threads = pool.current_num_threads();
    let t_build = Instant::now();
    let accel = Accel::build(
        &scene,
        &AccelOptions {
            backend: cli.backend,
            quality: cli.bvh_quality,
            threads,
            robust: !cli.no_robust,
            quads: !cli.no_quads,
        },
    )
    .with_context(|| format!("{}: building the {} BVH", cli.scene.display(), cli.backend))?;
    let build_time = t_build.elapsed();

    // Materials and lights: only what the integrator reads.
    if cli.hemisphere == Hemisphere::UniformUnweighted && cli.integrator != IntegratorKind::Ao {
        bail!("--hemisphere uniform-unweighted is an AO test estimator; direct and path take cosine or uniform");
    }
    let path_settings = PathSettings {
        max_depth: cli.max_depth,
        rr_depth: cli.rr_depth,
        strategy: cli.strategy,
        hemisphere: cli.hemisphere,
        emitter_samples: cli.emitter_samples,
        camera_emission: true,
        paired_bounces: true,
        joint_bounces: !cli.padded_bounces,
    };
    let integrator = match cli.integrator {
        IntegratorKind::Ao => Integrator::Ao(AoSettings {
            max_distance: ao_distance,
            hemisphere: cli.hemisphere,
            samples: cli.ao_samples,
            film_paired: true,
        }),
        IntegratorKind::Direct => Integrator::Direct(PathSettings {
            max_depth: 1,
            ..path_settings
        }),
        IntegratorKind::Path => Integrator::Path(path_settings),
    };
    let t_prepare = Instant::now();
    let background = glam::Vec3::from_array(cli.background.unwrap_or([0.0; 3]));
    let mut prepared =
        Prepared::new(&scene, &cli.scene, &integrator, background).map_err(|e| anyhow!(e))?;
    prepared.lights.triangle_sampling = cli.triangle_sampling;
    if integrator.needs_lights() && prepared.lights.is_empty() {
        eprintln!(
            "warning: {} has no light source (no punctual light, no emissive surface) and the background is black: the image is black. --background R,G,B adds a constant environment.",
            cli.scene.display()
        );
    }
    let prepare_time = t_prepare.elapsed();
    if let Some((x, y)) = cli.pixel {
        if x >= width || y >= height {
            bail!("--pixel {x},{y} lies outside the {width}x{height} image");
        }
    }

    // Render.
    let ctx = strata::integrators::Context {
        camera_packets: !cli.no_camera_packets,
        ..prepared.context(&scene, &accel)
    };
    let settings = RenderSettings {
        camera,
        crop: cli.pixel.map(|(x, y)| (x, y, x + 1, y + 1)),
        width,
        height,
        spp,
        seed: cli.seed,
        sampler: cli.sampler,
        integrator,
        tile_size: cli.tile_size,
        min_pass_seconds: cli.min_pass_seconds,
        stopping: Stopping {
            target_error: cli.target_error,
            min_spp,
            metric: cli.error_metric,
            time_limit: cli.time_limit.map(Duration::from_secs_f64),
            halves: !cli.sample_variance_error,
        },
    };
    let progress = if std::io::stderr().is_terminal() {
        let bar = ProgressBar::with_draw_target(Some(0), ProgressDrawTarget::stderr());
        // What the bar counts (render::render_with_checkpoints): the time limit, converged
        // pixels, or tile rounds.
        let template = match (cli.time_limit, cli.target_error) {
            (Some(_), _) => {
                "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% of the time limit"
            }
            (None, Some(_)) => {
                "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} pixels converged"
            }
            (None, None) => "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% eta {eta}",
        };
        bar.set_style(ProgressStyle::with_template(template).expect("valid progress template"));
        bar.enable_steady_tick(Duration::from_millis(200));
        bar
    } else {
        ProgressBar::hidden()
    };
    // The header attributes that do not change during the render.
    let mut attrs = vec![
        (
            "strata:scene".to_string(),
            Attr::Text(cli.scene.display().to_string()),
        ),
        (
            "strata:integrator".into(),
            Attr::Text(integrator.kind().to_string()),
        ),
        ("strata:sampler".into(), Attr::Text(cli.sampler.to_string())),
        ("strata:spp".into(), Attr::Int(spp as i32)),
        ("strata:seed".into(), Attr::Text(cli.seed.to_string())),
        ("strata:backend".into(), Attr::Text(accel.describe())),
    ];
    if let Some(e) = cli.target_error {
        attrs.push(("strata:target_error".into(), Attr::Float(e)));
        attrs.push(("strata:min_spp".into(), Attr::Int(min_spp as i32)));
        attrs.push((
            "strata:error_metric".into(),
            Attr::Text(cli.error_metric.to_string()),
        ));
    }
    if let Some(t) = cli.time_limit {
        attrs.push(("strata:time_limit".into(), Attr::Float(t as f32)));
    }
    match integrator {
        Integrator::Ao(ao) => {
            attrs.push((
                "strata:hemisphere".into(),
                Attr::Text(ao.hemisphere.to_string()),
            ));
            attrs.push(("strata:ao_distance".into(), Attr::Float(ao.max_distance)));
            attrs.push(("strata:ao_samples".into(), Attr::Int(ao.samples as i32)));
        }
        Integrator::Direct(p) | Integrator::Path(p) => {
            attrs.push(("strata:max_depth".into(), Attr::Int(p.max_depth as i32)));
            attrs.push(("strata:rr_depth".into(), Attr::Int(p.rr_depth as i32)));
            attrs.push((
                "strata:emitter_samples".into(),
                Attr::Int(p.emitter_samples as i32),
            ));
            attrs.push(("strata:strategy".into(), Attr::Text(p.strategy.to_string())));
            attrs.push((
                "strata:hemisphere".into(),
                Attr::Text(p.hemisphere.to_string()),
            ));
            attrs.push((
                "strata:triangle_sampling".into(),
                Attr::Text(prepared.lights.triangle_sampling.to_string()),
            ));
            attrs.push((
                "strata:background".into(),
                Attr::Text(format!(
                    "{},{},{}",
                    background.x, background.y, background.z
                )),
            ));
        }
    }
    // Plus the ones that do: samples per pixel so far, time, and how the image ended.
    let header = |film: &Film, seconds: f64, interrupted: bool, checkpoint: bool| {
        let (spp_min, spp_max) = film.count_range();
        let mut all = attrs.clone();
        all.extend([
            ("strata:spp_min".to_string(), Attr::Int(spp_min as i32)),
            ("strata:spp_max".into(), Attr::Int(spp_max as i32)),
            (
                "strata:spp_mean".into(),
                Attr::Float(film.count_mean() as f32),
            ),
            ("strata:render_seconds".into(), Attr::Float(seconds as f32)),
            ("strata:interrupted".into(), Attr::Int(interrupted as i32)),
            ("strata:checkpoint".into(), Attr::Int(checkpoint as i32)),
        ]);
        all
    };
    let write_images = |film: &Film, attrs: &[(String, Attr)]| -> Result<()> {
        output::write_exr(&output, film, attrs)?;
        if let Some(v) = &cli.variance {
            output::write_rgb_exr(v, film.width, film.height, &film.variances(), attrs)?;
        }
        if let Some(p) = &cli.spp_image {
            output::write_rgb_exr(p, film.width, film.height, &film.count_image(), attrs)?;
        }
        Ok(())
    };

    let mut checkpoints = 0u32;
    let mut checkpoint_seconds = 0.0;
    let mut save_checkpoint = |film: &Film, stats: &RenderStats| {
        let t = Instant::now();
        match write_images(film, &header(film, stats.seconds, false, true)) {
            Ok(()) => checkpoints += 1,
            Err(e) => eprintln!("warning: checkpoint not written: {e:#}"),
        }
        checkpoint_seconds += t.elapsed().as_secs_f64();
    };
    let checkpoint = cli.checkpoint.map(|secs| Checkpoint {
        every: Duration::from_secs_f64(secs),
        save: &mut save_checkpoint,
    });
    let result =
        render::render_with_checkpoints(&ctx, &settings, &pool, &progress, &cancel, checkpoint);
    progress.finish_and_clear();

    // Write.
    let t_write = Instant::now();
    let (spp_min, spp_max) = result.film.count_range();
    let mut final_attrs = header(
        &result.film,
        result.stats.seconds,
        result.interrupted,
        false,
    );
    if cli.time_limit.is_some() {
        final_attrs.push((
            "strata:time_limit_reached".into(),
            Attr::Int(result.time_limit_reached as i32),
        ));
    }
    if let Some(u) = result.unconverged_pixels {
        final_attrs.push((
            "strata:unconverged_pixels".into(),
            Attr::Int(u.min(i32::MAX as u64) as i32),
        ));
    }
    write_images(&result.film, &final_attrs)?;
    if !cli.no_png {
        output::write_png(&output.with_extension("png"), &result.film)?;
    }
    let write_time = t_write.elapsed();

    // Report.
    let stats = &result.stats;
    if stats.bad_samples > 0 {
        eprintln!(
            "warning: {} sample(s) were NaN or infinite and left out of the image; first:",
            stats.bad_samples
        );
        for b in &stats.first_bad {
            eprintln!("  pixel ({}, {}) sample {}: {}", b.x, b.y, b.index, b.value);
        }
    }
    // Rays that went to the BVH: camera rays culled as unable to meet the scene are not.
    let rays = stats.rays.traced();
    let rays_per_s = rays as f64 / stats.seconds.max(1e-9);
    println!(
        "{}: {width}x{height}, {} spp, {:.2} s, {:.2} Mrays, {:.2} Mrays/s{}",
        output.display(),
        if spp_min == spp_max {
            spp_max.to_string()
        } else {
            format!("{spp_min}-{spp_max} (mean {:.1})", result.film.count_mean())
        },
        stats.seconds,
        rays as f64 * 1e-6,
        rays_per_s * 1e-6,
        if result.interrupted {
            " (interrupted)"
        } else if result.time_limit_reached {
            " (time limit reached)"
        } else {
            ""
        }
    );
    if let (Some(e), Some(u)) = (cli.target_error, result.unconverged_pixels) {
        let (x0, y0, x1, y1) = settings.crop.unwrap_or((0, 0, width, height));
        let rendered = (x1 - x0) as u64 * (y1 - y0) as u64;
        let reached = rendered.saturating_sub(u);
        let why = if result.time_limit_reached || result.interrupted {
            "stopped early".to_string()
        } else {
            format!("took the most, {spp} spp (--spp)")
        };
        println!(
            "adaptive: {reached} of {rendered} pixels reached the {} target error {e} ({:.1}%){}",
            cli.error_metric,
            100.0 * reached as f64 / rendered.max(1) as f64,
            if u > 0 {
                format!("; {u} {why}")
            } else {
                String::new()
            }
        );
    }
    if cli.stats {
        let s = &scene.summary;
        println!(
            "scene: {} triangles, {} vertices, {} materials, {} textures, {} emissive triangles, {} lights, {} cameras",
            s.triangles,
            s.vertices,
            scene.materials.len(),
            s.textures,
            s.emissive_triangles,
            s.punctual_lights,
            s.cameras
        );
        println!("backend: {}, {threads} threads", accel.describe());
        let mem = accel.memory();
        let mib = |b: usize| b as f64 / (1024.0 * 1024.0);
        println!(
            "memory: BVH {:.1} MiB ({:.1} bytes/triangle), backend geometry {:.1} MiB{}",
            mib(mem.bvh),
            mem.bvh as f64 / s.triangles.max(1) as f64,
            mib(mem.geometry),
            mem.build_peak
                .map(|p| format!(", build peak {:.1} MiB", mib(p)))
                .unwrap_or_default()
        );
        println!(
            "time: load {:.3} s, BVH build {:.3} s, materials and lights {:.3} s, render {:.6} s ({} passes), write {:.3} s",
            load_time.as_secs_f64(),
            build_time.as_secs_f64(),
            prepare_time.as_secs_f64(),
            stats.seconds,
            stats.passes,
            write_time.as_secs_f64()
        );
        println!(
            "memory estimate: {} (scene and BVH {}, image {}), limit {}",
            format_bytes(memory_needed),
            format_bytes(scene_memory),
            format_bytes(image_memory((width, height))),
            memory_limit.map_or("none".to_string(), format_bytes)
        );
        if cli.checkpoint.is_some() {
            println!(
                "checkpoints: {checkpoints} written, {checkpoint_seconds:.3} s (within the render time)"
            );
        }
        println!(
            "shading: {} textures decoded, {} emitters",
            prepared.materials.decoded_images(),
            prepared.lights.emitters.len()
        );
        println!(
            "rays: {} camera, {} extension, {} shadow, {} total, {} traced ({} camera rays \
             culled: they could not meet the scene; {} through pixel corners, to find \
             emitters' interiors), {:.3} Mrays/s traced",
            stats.rays.camera,
            stats.rays.extension,
            stats.rays.shadow,
            stats.rays.total(),
            rays,
            stats.rays.culled,
            stats.rays.probe,
            rays_per_s * 1e-6
        );
    }
    if let Some((x, y)) = cli.pixel {
        let v = result.film.pixel(x, y);
        println!(
            "pixel ({x}, {y}): {} {} {} ({} samples)",
            v.x,
            v.y,
            v.z,
            result.film.count(x, y)
        );
    }
    Ok(if result.interrupted {
        eprintln!("saved the image rendered so far ({spp_min}-{spp_max} samples per pixel)");
        Outcome::Interrupted
    } else {
        Outcome::Finished
    })
}
