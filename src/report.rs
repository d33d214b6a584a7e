//! What `render` prints about a finished render: the summary line, the adaptive sampling
//! line, the `--stats` report, the `--pixel` value, and the samples left out as NaN or
//! infinite. Each is a `String` of whole lines, for the caller to print.
//!
//! Tools read these lines (tools/peers, tests/emitter_samples.rs, tests/losing_nothing.rs):
//! their wording and number formats are an interface.

use std::fmt::Write;
use std::time::Duration;

use crate::accel::Accel;
use crate::integrators::Prepared;
use crate::job::{Job, View};
use crate::render::{RenderResult, RenderStats};
use crate::scene::{format_bytes, Scene};

/// How long each phase of the run took, besides the render itself (in its stats).
#[derive(Clone, Copy, Debug, Default)]
pub struct Phases {
    pub load: Duration,
    pub build: Duration,
    /// Materials and lights.
    pub prepare: Duration,
    /// Denoising (`--denoise`; zero without).
    pub denoise: Duration,
    pub write: Duration,
}

/// A finished run: the job and everything made for it.
pub struct Run<'a> {
    pub job: &'a Job,
    pub view: &'a View,
    pub scene: &'a Scene,
    pub accel: &'a Accel,
    pub prepared: &'a Prepared,
    /// The worker threads of the render.
    pub threads: usize,
    pub result: &'a RenderResult,
    pub phases: Phases,
    /// Checkpoints written during the render.
    pub checkpoints: u32,
    /// The time the checkpoints took (within the render's).
    pub checkpoint_seconds: f64,
}

/// The warning about samples left out of the image as NaN, infinite or too large for the
/// film ([`crate::render::film::MAX_SAMPLE_VALUE`]), with the first few;
/// empty when there were none.
pub fn bad_samples(stats: &RenderStats) -> String {
    let mut s = String::new();
    if stats.bad_samples > 0 {
        let _ = writeln!(
            s,
            "warning: {} sample(s) were NaN, infinite or beyond ±2^55 and left out of the image; first:",
            stats.bad_samples
        );
        for b in &stats.first_bad {
            let _ = writeln!(
                s,
                "  pixel ({}, {}) sample {}: {}",
                b.x, b.y, b.index, b.value
            );
        }
    }
    s
}

/// The line every run prints (output, size, samples per pixel, seconds, rays traced and
/// their rate, how the render ended), and with `--target-error`, how many pixels reached it.
pub fn summary(run: &Run) -> String {
    let (job, result) = (run.job, run.result);
    let (width, height) = (run.view.width, run.view.height);
    let stats = &result.stats;
    let (spp_min, spp_max) = result.film.count_range();
    // Rays that went to the BVH: camera rays culled as unable to meet the scene are not.
    let rays = stats.rays.traced();
    let rays_per_s = rays as f64 / stats.seconds.max(1e-9);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {width}x{height}, {} spp, {:.2} s, {:.2} Mrays, {:.2} Mrays/s{}",
        job.output.display(),
        match (job.share, spp_min == spp_max) {
            (Some(share), _) => {
                let (a, b) = share.range(job.spp);
                format!("samples {a}..{b} of {}", job.spp)
            }
            (None, true) => spp_max.to_string(),
            (None, false) => {
                format!("{spp_min}-{spp_max} (mean {:.1})", result.film.count_mean())
            }
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
        let (x0, y0, x1, y1) = job
            .pixel
            .map_or((0, 0, width, height), |(x, y)| (x, y, x + 1, y + 1));
        let rendered = (x1 - x0) as u64 * (y1 - y0) as u64;
        let reached = rendered.saturating_sub(u);
        let why = if result.time_limit_reached || result.interrupted {
            "stopped early".to_string()
        } else {
            format!("took the most, {} spp (--spp)", job.spp)
        };
        let _ = writeln!(
            s,
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
    s
}

/// The most memory the process has held resident so far (Linux's `VmHWM`), if the system
/// says.
pub fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// The `--stats` report: the scene, the backend and its memory, the time of each phase, the
/// memory estimate, the checkpoints, the shading data and the rays by kind.
pub fn stats(run: &Run) -> String {
    let (job, scene, stats) = (run.job, run.scene, &run.result.stats);
    let summary = &scene.summary;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "scene: {} triangles, {} vertices, {} materials, {} textures, {} emissive triangles, {} alpha-tested triangles, {} lights, {} cameras",
        summary.triangles,
        summary.vertices,
        scene.materials.len(),
        summary.textures,
        summary.emissive_triangles,
        run.accel.alpha_tested_triangles(),
        summary.punctual_lights,
        summary.cameras
    );
    if summary.instances > 0 {
        let _ = writeln!(
            s,
            "instances: {} of {} meshes stored once, placing {} triangles",
            summary.instances,
            scene.prototypes.len(),
            summary.instanced_triangles
        );
    }
    let roles = &summary.texture_roles;
    let _ = writeln!(
        s,
        "textures by role: {} base colour, {} emissive, {} metallic-roughness, {} normal (rendered); {} occlusion (not needed)",
        roles.base_color, roles.emissive, roles.metallic_roughness, roles.normal, roles.occlusion
    );
    let _ = writeln!(
        s,
        "backend: {}, {} threads",
        run.accel.describe(),
        run.threads
    );
    let mem = run.accel.memory();
    let mib = |b: usize| b as f64 / (1024.0 * 1024.0);
    let _ = writeln!(
        s,
        "memory: BVH {:.1} MiB ({:.1} bytes/triangle), backend geometry {:.1} MiB{}",
        mib(mem.bvh),
        mem.bvh as f64 / summary.triangles.max(1) as f64,
        mib(mem.geometry),
        mem.build_peak
            .map(|p| format!(", build peak {:.1} MiB", mib(p)))
            .unwrap_or_default()
    );
    let _ = writeln!(
        s,
        "time: load {:.3} s, BVH build {:.3} s, materials and lights {:.3} s, render {:.6} s ({} passes), {}write {:.3} s",
        run.phases.load.as_secs_f64(),
        run.phases.build.as_secs_f64(),
        run.phases.prepare.as_secs_f64(),
        stats.seconds,
        stats.passes,
        match job.denoise {
            Some(_) => format!("denoise {:.3} s, ", run.phases.denoise.as_secs_f64()),
            None => String::new(),
        },
        run.phases.write.as_secs_f64()
    );
    let estimate = &scene.memory_estimate;
    let scene_memory = estimate.bytes();
    let image_memory = job.image_memory(run.view.width, run.view.height);
    let environment_memory = job.environment_memory();
    let _ = writeln!(
        s,
        "memory estimate: {} (scene and BVH {}{}{}, image {}), limit {}",
        format_bytes(
            (scene_memory)
                .saturating_add(image_memory)
                .saturating_add(environment_memory)
        ),
        format_bytes(scene_memory),
        match estimate.textures {
            0 => String::new(),
            n => format!(
                " with {n} decoded texture(s) {}",
                format_bytes(estimate.texture_bytes)
            ),
        },
        match environment_memory {
            0 => String::new(),
            n => format!(", environment map {}", format_bytes(n)),
        },
        format_bytes(image_memory),
        job.memory_limit.map_or("none".to_string(), format_bytes)
    );
    let _ = writeln!(
        s,
        "peak resident memory: {}",
        peak_resident_bytes().map_or("unknown".to_string(), format_bytes)
    );
    if job.checkpoint.is_some() {
        let _ = writeln!(
            s,
            "checkpoints: {} written, {:.3} s (within the render time)",
            run.checkpoints, run.checkpoint_seconds
        );
    }
    let environment = match run.prepared.lights.environment() {
        crate::shading::Environment::Map(map) => {
            let (w, h) = map.size();
            format!(
                ", environment map {w}x{h} ({})",
                crate::scene::format_bytes(map.memory() as u64)
            )
        }
        crate::shading::Environment::Constant(_) => String::new(),
    };
    let _ = writeln!(
        s,
        "shading: {} textures decoded, {} emitters{environment}",
        run.prepared.materials.decoded_images(),
        run.prepared.lights.emitters.len()
    );
    let rays = stats.rays.traced();
    let _ = writeln!(
        s,
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
        rays as f64 / stats.seconds.max(1e-9) * 1e-6
    );
    s
}

/// The value of the `--pixel` pixel and its sample count.
pub fn pixel(run: &Run, x: u32, y: u32) -> String {
    let film = &run.result.film;
    let v = film.pixel(x, y);
    format!(
        "pixel ({x}, {y}): {} {} {} ({} samples)\n",
        v.x,
        v.y,
        v.z,
        film.count(x, y)
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::Args;
    use clap::Parser;
    use std::path::Path;
    use std::sync::atomic::AtomicBool;

    /// Renders ao-wall at 8×6, 2 spp, with `extra` options, and hands the run to `check`.
    fn with_run(extra: &[&str], check: impl FnOnce(&Run)) {
        let dir = tempfile::tempdir().unwrap();
        let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/ao-wall.gltf");
        let out = dir.path().join("wall.exr");
        let mut all = vec![
            "render",
            scene_path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--resolution",
            "8x6",
            "--spp",
            "2",
            "--max-memory",
            "unlimited",
        ];
        all.extend_from_slice(extra);
        let job = Job::from_args(&Args::try_parse_from(all).unwrap()).unwrap();
        let scene = crate::scene::load(&job.scene, &job.load_options()).unwrap();
        let view = job.view(&scene).unwrap();
        let pool = crate::render::thread_pool(1).unwrap();
        let accel = Accel::build(&scene, &job.accel_options(1)).unwrap();
        let prepared =
            Prepared::with_options(&scene, &job.scene, &job.integrator, &job.shading).unwrap();
        let result = crate::render::render(
            &prepared.context(&scene, &accel),
            &job.render_settings(&view),
            &pool,
            &indicatif::ProgressBar::hidden(),
            &AtomicBool::new(false),
        );
        check(&Run {
            job: &job,
            view: &view,
            scene: &scene,
            accel: &accel,
            prepared: &prepared,
            threads: 1,
            result: &result,
            phases: Phases::default(),
            checkpoints: 0,
            checkpoint_seconds: 0.0,
        });
    }

    #[test]
    fn the_summary_is_one_line() {
        with_run(&[], |run| {
            let s = summary(run);
            assert!(s.starts_with(&format!("{}: 8x6, 2 spp, ", run.job.output.display())));
            assert!(s.ends_with(" Mrays/s\n") && s.lines().count() == 1, "{s}");
        });
    }

    #[test]
    fn the_summary_says_how_many_pixels_reached_the_target() {
        with_run(&["--target-error", "1000", "--min-spp", "2"], |run| {
            let s = summary(run);
            let adaptive = s.lines().nth(1).unwrap_or_else(|| panic!("{s}"));
            assert_eq!(
                adaptive,
                "adaptive: 48 of 48 pixels reached the relative target error 1000 (100.0%)"
            );
        });
    }

    #[test]
    fn stats_report_each_part_on_its_line() {
        with_run(&["--checkpoint", "60"], |run| {
            let s = stats(run);
            let starts: Vec<&str> = s.lines().map(|l| l.split(':').next().unwrap()).collect();
            assert_eq!(
                starts,
                [
                    "scene",
                    "textures by role",
                    "backend",
                    "memory",
                    "time",
                    "memory estimate",
                    "peak resident memory",
                    "checkpoints",
                    "shading",
                    "rays"
                ]
            );
            let rays = &run.result.stats.rays;
            assert!(s.contains(&format!(
                "rays: {} camera, {} extension, {} shadow, {} total",
                rays.camera,
                rays.extension,
                rays.shadow,
                rays.total()
            )));
            assert!(s.contains(", limit none\n"), "{s}");
            assert!(
                s.contains("backend: Embree") && s.contains(", 1 threads\n"),
                "{s}"
            );
        });
    }

    #[test]
    fn the_pixel_line_gives_the_value_and_the_samples() {
        with_run(&["--pixel", "3,2"], |run| {
            let v = run.result.film.pixel(3, 2);
            assert_eq!(
                pixel(run, 3, 2),
                format!("pixel (3, 2): {} {} {} (2 samples)\n", v.x, v.y, v.z)
            );
        });
    }

    #[test]
    fn no_bad_samples_no_warning() {
        assert_eq!(bad_samples(&RenderStats::default()), "");
    }
}
