//! `render`: the strata command line. Parse the options into a [`Job`], then load, build,
//! render, write and report.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context, Result};
use clap::Parser;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use strata::accel::Accel;
use strata::cli::{Args, DenoiseArgs, MergeArgs};
use strata::integrators::Prepared;
use strata::job::{header, DefaultLight, Job};
use strata::render::merge::{self, Part};
use strata::render::output::{self, Attr, Ids};
use strata::render::{self, Checkpoint, Film, RenderStats};
use strata::report::{self, Phases, Run};
use strata::scene;
use strata::shading::Need;

/// How a successful run ended.
enum Outcome {
    Finished,
    Interrupted,
    /// `render merge --check` found samples missing.
    Incomplete,
}

fn main() -> ExitCode {
    // `render denoise …` and `render merge …` are the subcommands; anything else is a scene
    // to render.
    let rest = || std::env::args_os().skip(2);
    let result = match std::env::args_os().nth(1) {
        Some(a) if a == "denoise" => denoise_file(DenoiseArgs::parse_from(
            std::iter::once("render denoise".into()).chain(rest()),
        )),
        Some(a) if a == "merge" => merge_files(MergeArgs::parse_from(
            std::iter::once("render merge".into()).chain(rest()),
        )),
        _ => run(Args::parse()),
    };
    match result {
        Ok(Outcome::Finished) => ExitCode::SUCCESS,
        Ok(Outcome::Interrupted) => ExitCode::from(130),
        Ok(Outcome::Incomplete) => ExitCode::from(3),
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// `render denoise`: denoises an EXR strata wrote ([`strata::denoise::denoise_exr`]).
fn denoise_file(args: DenoiseArgs) -> Result<Outcome> {
    strata::denoise::check()?;
    let output = args.output.clone().unwrap_or_else(|| {
        let stem = args.input.file_stem().unwrap_or_default().to_string_lossy();
        args.input.with_file_name(format!("{stem}-denoised.exr"))
    });
    output::check_output_path(&output)?;
    if !args.preview.exposure.is_finite() {
        return Err(anyhow!("--exposure must be a finite number of stops"));
    }
    if !args.input.is_file() {
        return Err(anyhow!("{}: no such file", args.input.display()));
    }
    let options = strata::denoise::Options {
        threads: args.threads,
        prefilter: args.denoise_prefilter.is_on(),
    };
    let report = strata::denoise::denoise_exr(&args.input, &output, &options)?;
    for w in &report.warnings {
        eprintln!("warning: {}: {w}", args.input.display());
    }
    let preview = &args.preview;
    if !preview.no_png {
        let display = strata::render::view::Display::new(preview.view, preview.exposure);
        let (w, h) = (report.width as u32, report.height as u32);
        // A transparent render's preview keeps its alpha.
        output::write_png_rgba(
            &output.with_extension("png"),
            w,
            h,
            &report.denoised,
            report.alpha.as_deref(),
            &display,
        )?;
    }
    println!(
        "{}: {}×{} denoised{} in {:.3} s{}",
        output.display(),
        report.width,
        report.height,
        if report.aux {
            " with its albedo and normal"
        } else {
            ""
        },
        report.seconds,
        if report.again {
            " (the input was denoised before: its noisy layer was denoised again)"
        } else {
            ""
        }
    );
    Ok(Outcome::Finished)
}

/// `render merge`: checks the partial files of a farm's shards and merges them
/// ([`strata::render::merge`]); with `--check`, only lists what is missing.
fn merge_files(args: MergeArgs) -> Result<Outcome> {
    let parts: Vec<Part> = args
        .parts
        .iter()
        .map(|p| Part::read(p))
        .collect::<Result<_, _>>()
        .map_err(|e| anyhow!(e))?;
    let coverage = merge::check(&parts).map_err(|e| anyhow!(e))?;
    if args.check {
        let held: u32 = coverage.parts.iter().map(|p| p.range.1 - p.range.0).sum();
        println!(
            "{} part(s) hold {held} of the {} samples per pixel",
            coverage.parts.len(),
            coverage.spp
        );
        for m in &coverage.missing {
            println!("{m}");
        }
        return Ok(match coverage.complete() {
            true => Outcome::Finished,
            false => Outcome::Incomplete,
        });
    }
    let output = args
        .output
        .clone()
        .expect("clap requires -o without --check");
    output::check_output_path(&output)?;
    if !args.preview.exposure.is_finite() {
        return Err(anyhow!("--exposure must be a finite number of stops"));
    }
    let t = Instant::now();
    let merged = merge::merge(&coverage, args.partial).map_err(|e| anyhow!(e))?;
    let film = &merged.film;
    let mut attrs = merged.attrs.clone();
    attrs.extend(output::film_attributes(film, merged.seconds, false, false));
    // The shards merged, through earlier partial merges too.
    let shards: i32 = (coverage.parts.iter())
        .map(|p| match p.attrs.get("strata:merged_parts") {
            Some(Attr::Int(n)) => *n,
            _ => 1,
        })
        .sum();
    attrs.push(("strata:merged_parts".into(), Attr::Int(shards)));
    let preview = &args.preview;
    attrs.push((
        "strata:preview_view".into(),
        Attr::Text(preview.view.to_string()),
    ));
    attrs.push((
        "strata:preview_exposure".into(),
        Attr::Float(preview.exposure),
    ));
    if args.partial {
        let (a, b) = merged.range;
        attrs.push(("strata:samples".into(), Attr::Text(format!("{a}..{b}"))));
    }
    let ids = Ids::Given(&merged.ids);
    output::write_exr(
        &output,
        film,
        &merged.passes,
        ids,
        None,
        &attrs,
        args.partial,
    )?;
    if !args.preview.no_png && !args.partial {
        let display = strata::render::view::Display::new(args.preview.view, args.preview.exposure);
        // A transparent background's preview carries the alpha the merged EXR holds.
        let transparent = (merged.attrs.iter())
            .any(|(k, v)| k == "strata:background" && v.to_string() == "transparent");
        let alpha = transparent.then(|| output::alpha_of(film));
        let (w, h) = (film.width, film.height);
        let png = output.with_extension("png");
        output::write_png_rgba(&png, w, h, &film.pixels(), alpha.as_deref(), &display)?;
    }
    let (a, b) = merged.range;
    println!(
        "{}: {}×{}, {} merged from {} parts in {:.3} s",
        output.display(),
        film.width,
        film.height,
        match args.partial {
            true => format!("samples {a}..{b} of {}", coverage.spp),
            false => format!("{} samples per pixel", coverage.spp),
        },
        coverage.parts.len(),
        t.elapsed().as_secs_f64()
    );
    Ok(Outcome::Finished)
}

/// Signals closer together than this are one (`timeout -s INT` and a shell may each deliver
/// the same interrupt).
const SIGNAL_ECHO: Duration = Duration::from_millis(500);

/// What interrupts (Ctrl-C, SIGTERM, SIGHUP) have asked for so far.
struct Interrupts {
    /// Stop the render after the tiles in flight and save the image.
    cancel: Arc<AtomicBool>,
    /// Save at once: no denoising, no preview.
    hurry: Arc<AtomicBool>,
}

/// SIGINT (Ctrl-C), SIGTERM (what Slurm and Kubernetes send on pre-emption) and SIGHUP, alike:
/// the first stops the render after the tiles in flight and saves the image; the second
/// hurries the save (no denoising, no preview); the third exits at once, removing the
/// temporary files of a write in progress (`temporaries`) so nothing half-written is left (a
/// file already in place stays). Signals within [`SIGNAL_ECHO`] of the last counted one
/// count as that one.
fn install_interrupt_handler(temporaries: Vec<PathBuf>) -> Interrupts {
    let interrupts = Interrupts {
        cancel: Arc::new(AtomicBool::new(false)),
        hurry: Arc::new(AtomicBool::new(false)),
    };
    let (cancel, hurry) = (interrupts.cancel.clone(), interrupts.hurry.clone());
    let mut last: Option<Instant> = None;
    let mut count = 0u32;
    let installed = ctrlc::set_handler(move || {
        let now = Instant::now();
        if last.is_some_and(|t| now.duration_since(t) < SIGNAL_ECHO) {
            return;
        }
        last = Some(now);
        count += 1;
        match count {
            1 => {
                cancel.store(true, Ordering::SeqCst);
                eprintln!("\ninterrupted: finishing the tiles in flight and saving the image (interrupt again to save without denoising or preview, a third time to quit without saving)");
            }
            2 => {
                hurry.store(true, Ordering::SeqCst);
                eprintln!("\ninterrupted again: saving the image without denoising or preview (a third time to quit without saving)");
            }
            _ => {
                for t in &temporaries {
                    let _ = std::fs::remove_file(t);
                }
                eprintln!("\ninterrupted three times: exiting without saving");
                std::process::exit(130);
            }
        }
    });
    if let Err(e) = installed {
        eprintln!("warning: cannot install the interrupt handler ({e}); an interrupted render will not be saved");
    }
    interrupts
}

/// The progress bar on stderr when it is a terminal, counting what the render reports
/// (render::render_with_checkpoints): the time limit, converged pixels, or tile rounds.
fn progress_bar(job: &Job) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        let bar = ProgressBar::hidden();
        if job.progress_every > 0.0 {
            progress_lines(job, bar.clone());
        }
        return bar;
    }
    // No length until the render sets one: a length of 0 shows as 100% done.
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    let template = match (job.time_limit, job.target_error) {
        (Some(_), _) => "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% of the time limit",
        (None, Some(_)) => "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} pixels converged",
        (None, None) => "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% eta {eta}",
    };
    bar.set_style(ProgressStyle::with_template(template).expect("valid progress template"));
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

/// Where stderr is not a terminal: a line every `--progress-every` seconds of what `bar`
/// (hidden) counts, until it is finished. A farm's log thus shows how far each task is.
fn progress_lines(job: &Job, bar: ProgressBar) {
    let every = Duration::from_secs_f64(job.progress_every);
    let name = job.output.display().to_string();
    let unit = match (job.time_limit, job.target_error) {
        (Some(_), _) => "of the time limit",
        (None, Some(_)) => "of the pixels converged",
        (None, None) => "of the samples",
    };
    std::thread::spawn(move || {
        let start = Instant::now();
        let mut next = every;
        while !bar.is_finished() {
            std::thread::sleep(every.min(Duration::from_millis(50)));
            let elapsed = start.elapsed();
            if elapsed < next {
                continue;
            }
            next += every;
            let (done, total) = (bar.position(), bar.length().unwrap_or(0));
            if total == 0 || bar.is_finished() {
                continue;
            }
            let fraction = done as f64 / total as f64;
            let seconds = elapsed.as_secs_f64();
            let eta = match fraction > 0.0 {
                true => format!(
                    ", about {:.0} s left",
                    seconds * (1.0 - fraction) / fraction
                ),
                false => String::new(),
            };
            eprintln!(
                "{name}: {:.0}% {unit} after {seconds:.0} s{eta}",
                100.0 * fraction
            );
        }
    });
}

fn run(args: Args) -> Result<Outcome> {
    let job = Job::from_args(&args)?;
    if args.list_cameras {
        let scene = scene::load(&job.scene, &job.load_options())?;
        let cameras = strata::job::camera_list(&scene);
        if cameras.is_empty() {
            println!(
                "{} has no camera: it is framed from +Z ({}° vertical field of view unless --fov)",
                job.scene.display(),
                strata::scene::Camera::FRAMING_YFOV_DEGREES
            );
        }
        for line in cameras {
            println!("{line}");
        }
        return Ok(Outcome::Finished);
    }
    for w in &job.warnings {
        eprintln!("warning: {w}");
    }
    // One job per animation frame asked for (--frames), or the job itself.
    let jobs = job.frame_jobs();
    let interrupts = install_interrupt_handler(jobs.iter().flat_map(|j| j.temporaries()).collect());
    for job in jobs {
        if let Outcome::Interrupted = run_job(job, &interrupts)? {
            return Ok(Outcome::Interrupted);
        }
    }
    Ok(Outcome::Finished)
}

/// Loads, builds, renders and writes one job (one frame).
fn run_job(mut job: Job, interrupts: &Interrupts) -> Result<Outcome> {
    // The settings that a shard's part and an unfinished render's file carry, from the
    // options alone (before the scene changes the job).
    let settings_hash = header::settings_hash(&job);
    let (scene, load_time) = load_scene(&job)?;

    // Camera and resolution.
    let view = job.view(&scene)?;
    if view.framed {
        eprintln!(
            "note: {} has no camera; framing the scene's bounding box from +Z with a {:.0}° vertical field of view (--look-from, --look-at, --fov and --orbit move it)",
            job.scene.display(),
            match view.camera.projection {
                strata::scene::Projection::Perspective { yfov } => yfov.to_degrees(),
                strata::scene::Projection::Orthographic { .. } => 0.0,
            }
        );
    }

    if let Some(a) = view.camera.aspect_ratio {
        let image = view.width as f32 / view.height as f32;
        if (image - a).abs() > 0.01 * a {
            eprintln!(
                "note: the image's aspect ratio, {}x{} = {image:.3}, is not the camera's {a:.3}: its vertical field of view is kept, so the image shows {} at the sides than the camera's frame",
                view.width,
                view.height,
                if image > a { "more" } else { "less" }
            );
        }
    }

    // Acceleration structure.
    let pool = render::thread_pool(job.threads).context("cannot start the worker threads")?;
    let threads = pool.current_num_threads();
    let t_build = Instant::now();
    let accel = Accel::build(&scene, &job.accel_options(threads))
        .with_context(|| format!("{}: building the {} BVH", job.scene.display(), job.backend))?;
    let build_time = t_build.elapsed();

    // Materials and lights: only what the integrator reads.
    let (prepared, prepare_time) = prepare(&mut job, &scene)?;
    // The textures whose images did not decode, read as absent by alpha coverage and by
    // shading: one warning per image, or under --strict the refusal, before anything is
    // rendered or written.
    let missing: Vec<_> = (accel.missing_textures().iter())
        .chain(prepared.materials.missing_textures())
        .cloned()
        .collect();
    if let (true, Some(m)) = (job.strict, missing.first()) {
        return Err(strict_refusal(&job, &scene, m.image, &m.problem));
    }
    for w in scene.missing_texture_warnings(&missing) {
        eprintln!("warning: {}: {w}", job.scene.display());
    }

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
    let mut header = header::header_attributes(&job, &accel.describe());
    header.extend(header::camera_attributes(&view));
    if let Some(share) = job.share {
        header.extend(
            header::partial_attributes(&job, share, &scene.files, &settings_hash)
                .map_err(|e| anyhow!(e))?,
        );
    }
    // What an unfinished render's file carries besides its sums, for `--resume`: a shard's
    // part has it already. The scene's hash reads its files again: once, when first needed.
    let scene_hash = std::cell::OnceCell::new();
    let scene_hash = || -> Result<String> {
        let hash = scene_hash.get_or_init(|| header::scene_hash(&job, &scene.files));
        hash.clone().map_err(|e| anyhow!(e))
    };
    let resume_attributes = || -> Result<Vec<(String, Attr)>> {
        Ok(match job.share {
            Some(_) => Vec::new(),
            None => vec![
                (
                    "strata:settings_hash".into(),
                    Attr::Text(settings_hash.clone()),
                ),
                ("strata:scene_hash".into(), Attr::Text(scene_hash()?)),
            ],
        })
    };
    let resumed = match &job.resume {
        None => None,
        Some(path) => {
            let (a, b) = settings.samples();
            let expected = render::resume::Expected {
                width: settings.width,
                height: settings.height,
                samples: (a, b),
                settings_hash: &settings_hash,
                scene_hash: &scene_hash()?,
                header: &header,
                features: ctx.features,
                first_hits: ctx.ids,
            };
            let resumed = render::resume::read(path, &expected).map_err(|e| anyhow!(e))?;
            let (lo, hi) = resumed.film.count_range();
            eprintln!(
                "resuming {}: {lo}-{hi} of {} samples per pixel, {:.1} s rendered",
                path.display(),
                b - a,
                resumed.seconds
            );
            Some(resumed)
        }
    };
    let prior_seconds = resumed.as_ref().map_or(0.0, |r| r.seconds);
    let display = strata::render::view::Display::new(job.view, job.exposure);
    // The image at `path` (with the variance and samples-per-pixel images when `extras`).
    // An `unfinished` image (a checkpoint, an interrupted render) holds the film's exact sums
    // too, as a shard's part does, so that `--resume` can continue it.
    let write_images = |path: &Path,
                        extras: bool,
                        film: &Film,
                        denoised: Option<&[glam::Vec3]>,
                        state: Vec<(String, Attr)>,
                        unfinished: bool|
     -> Result<()> {
        let mut attrs = [header.clone(), state].concat();
        if unfinished {
            attrs.extend(resume_attributes()?);
        }
        let (ids, exact) = (Ids::Scene(&scene), job.share.is_some() || unfinished);
        match output::ImageFormat::of(path) {
            Some(output::ImageFormat::Exr) | None => {
                output::write_exr(path, film, &job.passes, ids, denoised, &attrs, exact)?
            }
            // `-o NAME.png` or `.jpg`: the image through the view transform alone.
            Some(_) => {
                let pixels = denoised.map_or_else(|| film.pixels(), <[glam::Vec3]>::to_vec);
                let alpha = job.transparent.then(|| output::alpha_of(film));
                let (w, h) = (film.width, film.height);
                output::write_png_rgba(path, w, h, &pixels, alpha.as_deref(), &display)?
            }
        }
        if let Some(v) = job.variance.as_ref().filter(|_| extras) {
            output::write_rgb_exr(v, film.width, film.height, &film.variances(), &attrs)?;
        }
        if let Some(p) = job.spp_image.as_ref().filter(|_| extras) {
            output::write_rgb_exr(p, film.width, film.height, &film.count_image(), &attrs)?;
        }
        Ok(())
    };
    // Where an unfinished image (a checkpoint, an interrupted render) goes: the output, unless
    // that holds a better image; then NAME.incomplete.exr beside it, the EXR alone.
    let incomplete = output::incomplete_path(&job.output);
    // Set once a checkpoint of this render is at the output: later images replace it.
    let wrote_output = std::cell::Cell::new(false);
    let unfinished_target = |film: &Film| -> (PathBuf, Option<String>) {
        let (lo, _) = film.count_range();
        match wrote_output.get() {
            true => (job.output.clone(), None),
            false => match output::may_replace(&job.output, lo, film.count_mean()) {
                Ok(()) => (job.output.clone(), None),
                Err(why) => (incomplete.clone(), Some(why)),
            },
        }
    };
    let mut checkpoints = 0u32;
    let mut checkpoint_seconds = 0.0;
    let mut kept_said = false;
    let mut save_checkpoint = |film: &Film, stats: &RenderStats| {
        let t = Instant::now();
        let (path, kept) = unfinished_target(film);
        if let Some(why) = kept.filter(|_| !kept_said) {
            kept_said = true;
            eprintln!(
                "note: {} is kept ({why}): checkpoints go to {} until they hold more",
                job.output.display(),
                path.display()
            );
        }
        // Checkpoints are not denoised: they hold the raw beauty.
        let state = output::film_attributes(film, prior_seconds + stats.seconds, false, true);
        match write_images(&path, path == job.output, film, None, state, true) {
            Ok(()) => {
                checkpoints += 1;
                wrote_output.set(wrote_output.get() || path == job.output);
            }
            Err(e) => eprintln!("warning: checkpoint not written: {e:#}"),
        }
        checkpoint_seconds += t.elapsed().as_secs_f64();
    };
    let checkpoint = job.checkpoint.map(|secs| Checkpoint {
        every: Duration::from_secs_f64(secs),
        save: &mut save_checkpoint,
    });
    let result = render::render_with_checkpoints(
        &ctx,
        &settings,
        &pool,
        &progress,
        &interrupts.cancel,
        checkpoint,
        resumed.map(|r| r.film),
    );
    progress.finish_and_clear();

    // An interrupted render never replaces a better image, and with no sample at all
    // saves nothing.
    let (target, kept) = match result.interrupted {
        true => unfinished_target(&result.film),
        false => (job.output.clone(), None),
    };
    let sampled = result.film.count_range().1 > 0;
    if let Some(why) = &kept {
        match sampled {
            true => eprintln!(
                "note: {} is kept ({why}): the image rendered so far goes to {}",
                job.output.display(),
                target.display()
            ),
            false => eprintln!("note: {} is kept ({why})", job.output.display()),
        }
    }
    let write = !result.interrupted || sampled;
    let hurry = interrupts.hurry.load(Ordering::SeqCst);

    // Denoise (not when hurried). If the denoiser fails, the raw image is still written
    // before the error.
    let t_denoise = Instant::now();
    let mut attrs = header::result_attributes(&job, &result, prior_seconds);
    let (denoised, denoise_error, denoise_time) = match write && !hurry {
        true => denoise(&job, &result.film, threads, &mut attrs, t_denoise),
        false => (None, None, Duration::ZERO),
    };

    // Write.
    let t_write = Instant::now();
    if write {
        let extras = kept.is_none();
        let unfinished = result.interrupted;
        write_images(
            &target,
            extras,
            &result.film,
            denoised.as_deref(),
            attrs,
            unfinished,
        )?;
        let resumed_incomplete = job.resume.as_deref() == Some(incomplete.as_path());
        if (kept_said || resumed_incomplete) && kept.is_none() && target != incomplete {
            // The checkpoints this render (or the one it resumed) put beside a better image
            // are outdone.
            let _ = std::fs::remove_file(&incomplete);
        }
    }
    if write && kept.is_none() && !hurry && job.png {
        let pixels = denoised.unwrap_or_else(|| result.film.pixels());
        let (w, h) = (result.film.width, result.film.height);
        let alpha = job.transparent.then(|| output::alpha_of(&result.film));
        let png = job.output.with_extension("png");
        output::write_png_rgba(&png, w, h, &pixels, alpha.as_deref(), &display)?;
    }
    let write_time = t_write.elapsed();
    if let Some(e) = denoise_error {
        return Err(anyhow!(e)).with_context(|| {
            format!(
                "{}: written without denoising, because denoising failed",
                job.output.display()
            )
        });
    }

    let phases = Phases {
        load: load_time,
        build: build_time,
        prepare: prepare_time,
        denoise: denoise_time,
        write: write_time,
    };
    let run = Run {
        job: &job,
        view: &view,
        scene: &scene,
        accel: &accel,
        prepared: &prepared,
        threads,
        result: &result,
        phases,
        checkpoints,
        checkpoint_seconds,
    };
    print_report(&run);
    Ok(if result.interrupted {
        let (spp_min, spp_max) = result.film.count_range();
        match write {
            true => eprintln!(
                "saved the image rendered so far to {} ({spp_min}-{spp_max} samples per pixel); the same command with --resume {} continues it",
                target.display(),
                target.display()
            ),
            false => eprintln!("interrupted before any sample: nothing saved"),
        }
        Outcome::Interrupted
    } else {
        Outcome::Finished
    })
}

/// The error `--strict` gives for a scene whose image `image` cannot be had, for `problem`.
fn strict_refusal(job: &Job, scene: &scene::Scene, image: usize, problem: &str) -> anyhow::Error {
    anyhow!(
        "{}: {}: {problem} (--strict refuses a scene with a texture image that is missing or does not decode; without it, the textures that use the image render as absent, with a warning)",
        job.scene.display(),
        scene.image_label(image)
    )
}

/// Loads the job's scene and prints its warnings; the time it took.
fn load_scene(job: &Job) -> Result<(scene::Scene, Duration)> {
    let t_load = Instant::now();
    let scene = scene::load(&job.scene, &job.load_options())?;
    let load_time = t_load.elapsed();
    render::passes::check_exact(&job.passes, scene.largest_origin())
        .map_err(|e| anyhow!("{}: {e}", job.scene.display()))?;
    for w in &scene.load_warnings {
        eprintln!("warning: {}: {w}", job.scene.display());
    }
    if job.strict {
        // Before anything is built: an image the loader could not read at all.
        if let Some((i, problem)) = scene.unreadable_images().next() {
            return Err(strict_refusal(job, &scene, i, problem));
        }
    }
    if job.integrator.material_need() == Need::Shading {
        for w in scene.material_warnings() {
            eprintln!("warning: {}: {w}", job.scene.display());
        }
    }

    Ok((scene, load_time))
}

/// Loads the environment map, prepares the materials and lights the integrator reads, and
/// lights a scene that brings no light meant to light it with the default sky; the time it
/// took.
fn prepare(job: &mut Job, scene: &scene::Scene) -> Result<(Prepared, Duration)> {
    let t_prepare = Instant::now();
    if job.integrator.needs_lights() {
        job.load_environment()?;
    } else if job.env.is_some() {
        eprintln!("warning: --env lights direct and path tracing; ambient occlusion ignores it");
    }
    let mut prepared = Prepared::with_options(scene, &job.scene, &job.integrator, &job.shading)
        .map_err(|e| anyhow!(e))?;
    if let Some(why) = job.default_light(scene, &prepared.lights) {
        job.use_default_sky();
        prepared.relight(&job.integrator, &job.shading);
        let name = job.scene.display();
        let sky = strata::job::DEFAULT_SKY;
        match why {
            DefaultLight::NoLight => eprintln!(
                "note: {name} has no light source (no punctual light, no emissive surface): it is lit by a uniform white sky of radiance {sky} (--env FILE or --background R,G,B to choose another)"
            ),
            DefaultLight::FaintEmitters(share) => eprintln!(
                "note: {name}'s emissive surfaces (radiance at most 1) give {} of the light a white sky would: taken as glowing details, not its light, so it is lit by a uniform white sky of radiance {sky} as well (--env FILE or --background R,G,B to choose another light, --env none for the emitters alone)",
                percent(share)
            ),
        }
    }
    if job.integrator.needs_lights() && prepared.lights.is_empty() {
        eprintln!(
            "warning: {} has no light source (no punctual light, no emissive surface) and the background is black: the image is black. --background R,G,B adds a constant environment.",
            job.scene.display()
        );
    }
    let prepare_time = t_prepare.elapsed();

    Ok((prepared, prepare_time))
}

/// A share as a percentage to two significant digits ("2.7%", "0.0021%").
fn percent(share: f64) -> String {
    let pct = 100.0 * share;
    if pct <= 0.0 || !pct.is_finite() {
        return format!("{pct}%");
    }
    let decimals = (1.0 - pct.log10().floor()).max(0.0) as usize;
    format!("{pct:.decimals$}%")
}

/// The denoised beauty of `film` where the job asks for it, or the denoiser's error (the raw
/// image is written either way), with its attributes added to `attrs`; the time since
/// `t_denoise`.
#[allow(clippy::type_complexity)]
fn denoise(
    job: &Job,
    film: &Film,
    threads: usize,
    attrs: &mut Vec<(String, Attr)>,
    t_denoise: Instant,
) -> (
    Option<Vec<glam::Vec3>>,
    Option<strata::denoise::DenoiseError>,
    Duration,
) {
    let denoised = job.denoise.map(|options| {
        let options = strata::denoise::Options { threads, ..options };
        let denoised = strata::denoise::denoise_film(film, &options);
        if denoised.is_ok() {
            let about = strata::denoise::describe(&options, film.keeps_features());
            attrs.push(("strata:denoiser".into(), Attr::Text(about)));
            let seconds = t_denoise.elapsed().as_secs_f32();
            attrs.push(("strata:denoise_seconds".into(), Attr::Float(seconds)));
        }
        denoised
    });
    let denoise_time = t_denoise.elapsed();
    let (denoised, denoise_error) = match denoised {
        Some(Err(e)) => (None, Some(e)),
        Some(Ok(d)) => (Some(d), None),
        None => (None, None),
    };

    (denoised, denoise_error, denoise_time)
}

/// Prints what the render did: bad samples, the summary, and `--stats` and `--pixel` where
/// asked for.
fn print_report(run: &Run) {
    eprint!("{}", report::bad_samples(&run.result.stats));
    print!("{}", report::summary(run));
    if run.job.stats {
        print!("{}", report::stats(run));
    }
    if let Some((x, y)) = run.job.pixel {
        print!("{}", report::pixel(run, x, y));
    }
}
