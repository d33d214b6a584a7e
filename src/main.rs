//! `render`: the strata command line. Parse the options into a [`Job`], then load, build,
//! render, write and report.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context, Result};
use clap::Parser;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use strata::accel::Accel;
use strata::cli::Args;
use strata::integrators::Prepared;
use strata::job::Job;
use strata::render::output::{self, Attr};
use strata::render::{self, Checkpoint, Film, RenderStats};
use strata::scene::{self, format_bytes};

/// How a successful run ended.
enum Outcome {
    Finished,
    Interrupted,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
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

/// The progress bar on stderr when it is a terminal, counting what the render reports
/// (render::render_with_checkpoints): the time limit, converged pixels, or tile rounds.
fn progress_bar(job: &Job) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(0), ProgressDrawTarget::stderr());
    let template = match (job.time_limit, job.target_error) {
        (Some(_), _) => "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% of the time limit",
        (None, Some(_)) => "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} pixels converged",
        (None, None) => "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% eta {eta}",
    };
    bar.set_style(ProgressStyle::with_template(template).expect("valid progress template"));
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

fn run(args: Args) -> Result<Outcome> {
    let job = Job::from_args(&args)?;
    for w in &job.warnings {
        eprintln!("warning: {w}");
    }
    let cancel = install_interrupt_handler(job.temporaries());

    // Load.
    let t_load = Instant::now();
    let scene = scene::load(&job.scene, &job.load_options())?;
    let load_time = t_load.elapsed();
    for w in &scene.load_warnings {
        eprintln!("warning: {}: {w}", job.scene.display());
    }

    // Camera and resolution.
    let view = job.view(&scene)?;
    if view.framed {
        eprintln!(
            "note: {} has no camera; framing the scene's bounding box from +Z with a 45° vertical field of view",
            job.scene.display()
        );
    }

    // Acceleration structure.
    let pool = render::thread_pool(job.threads).context("cannot start the worker threads")?;
    let threads = pool.current_num_threads();
    let t_build = Instant::now();
    let accel = Accel::build(&scene, &job.accel_options(threads))
        .with_context(|| format!("{}: building the {} BVH", job.scene.display(), job.backend))?;
    let build_time = t_build.elapsed();

    // Materials and lights: only what the integrator reads.
    let t_prepare = Instant::now();
    let mut prepared = Prepared::new(&scene, &job.scene, &job.integrator, job.background)
        .map_err(|e| anyhow!(e))?;
    prepared.lights.triangle_sampling = job.triangle_sampling;
    if job.integrator.needs_lights() && prepared.lights.is_empty() {
        eprintln!(
            "warning: {} has no light source (no punctual light, no emissive surface) and the background is black: the image is black. --background R,G,B adds a constant environment.",
            job.scene.display()
        );
    }
    let prepare_time = t_prepare.elapsed();

    // Render, writing checkpoints on the way when asked to.
    let ctx = strata::integrators::Context {
        camera_packets: job.camera_packets,
        ..prepared.context(&scene, &accel)
    };
    let settings = job.render_settings(&view);
    let progress = progress_bar(&job);
    let header = output::header_attributes(&job, &accel.describe());
    let write_images = |film: &Film, state: Vec<(String, Attr)>| -> Result<()> {
        let attrs = [header.clone(), state].concat();
        output::write_exr(&job.output, film, &attrs)?;
        if let Some(v) = &job.variance {
            output::write_rgb_exr(v, film.width, film.height, &film.variances(), &attrs)?;
        }
        if let Some(p) = &job.spp_image {
            output::write_rgb_exr(p, film.width, film.height, &film.count_image(), &attrs)?;
        }
        Ok(())
    };
    let mut checkpoints = 0u32;
    let mut checkpoint_seconds = 0.0;
    let mut save_checkpoint = |film: &Film, stats: &RenderStats| {
        let t = Instant::now();
        match write_images(
            film,
            output::film_attributes(film, stats.seconds, false, true),
        ) {
            Ok(()) => checkpoints += 1,
            Err(e) => eprintln!("warning: checkpoint not written: {e:#}"),
        }
        checkpoint_seconds += t.elapsed().as_secs_f64();
    };
    let checkpoint = job.checkpoint.map(|secs| Checkpoint {
        every: Duration::from_secs_f64(secs),
        save: &mut save_checkpoint,
    });
    let result =
        render::render_with_checkpoints(&ctx, &settings, &pool, &progress, &cancel, checkpoint);
    progress.finish_and_clear();

    // Write.
    let t_write = Instant::now();
    write_images(&result.film, output::result_attributes(&job, &result))?;
    if job.png {
        output::write_png(&job.output.with_extension("png"), &result.film)?;
    }
    let write_time = t_write.elapsed();

    // What the report reads.
    let (width, height, spp, output) = (view.width, view.height, job.spp, &job.output);
    let (spp_min, spp_max) = result.film.count_range();
    let scene_memory = scene.memory_estimate.bytes();
    let memory_needed = scene_memory.saturating_add(job.image_memory(width, height));

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
    if let (Some(e), Some(u)) = (job.target_error, result.unconverged_pixels) {
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
            job.error_metric,
            100.0 * reached as f64 / rendered.max(1) as f64,
            if u > 0 {
                format!("; {u} {why}")
            } else {
                String::new()
            }
        );
    }
    if job.stats {
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
            format_bytes(job.image_memory(width, height)),
            job.memory_limit.map_or("none".to_string(), format_bytes)
        );
        if job.checkpoint.is_some() {
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
    if let Some((x, y)) = job.pixel {
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
