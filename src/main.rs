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
use strata::report::{self, Phases, Run};
use strata::scene;
use strata::shading::Need;

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
    let mut job = Job::from_args(&args)?;
    for w in &job.warnings {
        eprintln!("warning: {w}");
    }
    let cancel = install_interrupt_handler(job.temporaries());

    // Load.
    let t_load = Instant::now();
    let scene = scene::load(&job.scene, &job.load_options())?;
    let load_time = t_load.elapsed();
    render::passes::check_exact(&job.passes, &scene.origins)
        .map_err(|e| anyhow!("{}: {e}", job.scene.display()))?;
    for w in &scene.load_warnings {
        eprintln!("warning: {}: {w}", job.scene.display());
    }
    if job.integrator.material_need() == Need::Shading {
        for w in scene.material_warnings() {
            eprintln!("warning: {}: {w}", job.scene.display());
        }
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
    if job.light_a_scene_without_lights(&scene) {
        eprintln!(
            "note: {} has no light source (no punctual light, no emissive surface): it is lit by a uniform white sky of radiance {} (--background R,G,B or --env FILE to choose another)",
            job.scene.display(),
            strata::job::DEFAULT_SKY
        );
    }
    if job.integrator.needs_lights() {
        job.load_environment()?;
    } else if job.env.is_some() {
        eprintln!("warning: --env lights direct and path tracing; ambient occlusion ignores it");
    }
    let prepared = Prepared::with_options(&scene, &job.scene, &job.integrator, &job.shading)
        .map_err(|e| anyhow!(e))?;
    if job.integrator.needs_lights() && prepared.lights.is_empty() {
        eprintln!(
            "warning: {} has no light source (no punctual light, no emissive surface) and the background is black: the image is black. --background R,G,B adds a constant environment.",
            job.scene.display()
        );
    }
    let prepare_time = t_prepare.elapsed();

    // Render, writing checkpoints on the way when asked to.
    let ctx = strata::integrators::Context {
        experiments: job.experiments,
        // The film sums the first hit's features, and keeps sample 0's triangle, only for
        // passes that are asked for.
        features: job.passes.iter().any(|p| !p.is_id()),
        ids: job.passes.iter().any(|p| p.is_id()),
        ..prepared.context(&scene, &accel)
    };
    let settings = job.render_settings(&view);
    let progress = progress_bar(&job);
    let header = output::header_attributes(&job, &accel.describe());
    let write_images = |film: &Film, state: Vec<(String, Attr)>| -> Result<()> {
        let attrs = [header.clone(), state].concat();
        output::write_exr(&job.output, film, &job.passes, &scene, &attrs)?;
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
        let display = strata::render::view::Display::new(job.view, job.exposure);
        output::write_png(&job.output.with_extension("png"), &result.film, &display)?;
    }
    let write_time = t_write.elapsed();

    // Report.
    eprint!("{}", report::bad_samples(&result.stats));
    let run = Run {
        job: &job,
        view: &view,
        scene: &scene,
        accel: &accel,
        prepared: &prepared,
        threads,
        result: &result,
        phases: Phases {
            load: load_time,
            build: build_time,
            prepare: prepare_time,
            write: write_time,
        },
        checkpoints,
        checkpoint_seconds,
    };
    print!("{}", report::summary(&run));
    if job.stats {
        print!("{}", report::stats(&run));
    }
    if let Some((x, y)) = job.pixel {
        print!("{}", report::pixel(&run, x, y));
    }
    Ok(if result.interrupted {
        let (spp_min, spp_max) = result.film.count_range();
        eprintln!("saved the image rendered so far ({spp_min}-{spp_max} samples per pixel)");
        Outcome::Interrupted
    } else {
        Outcome::Finished
    })
}
