//! What an environment map costs a path-traced render beside a constant background, as
//! ratios measured in one run.
//!
//!     cargo bench --bench environment
//!
//! The bundled Suzanne (the glTF model, textured, mostly metal; `STRATA_ENV_SCENE` for
//! another scene, `STRATA_ENV_MAP` for another map) path-traced at 160×120, 16 spp
//! (`STRATA_ENV_SPP`), 8 bounces, one thread, every pixel block's camera rays traced (no
//! block culling, which would spare a constant background the camera rays that miss and so
//! compare different rays). Four renders alternate for `ROUNDS` rounds:
//!
//! - **map, BSDF sampling alone** (`--strategy bsdf`) and **constant, BSDF sampling alone**:
//!   the same rays (checked), so their ratio is the cost of the map's lookups alone. Issue
//!   43's target: at most 1.15.
//! - **map, MIS** (the default) and **constant, MIS**: the map adds its light samples'
//!   shadow rays (a constant background is found by BSDF sampling alone); the ratio of the
//!   times per traced ray says what the map costs beyond those rays (target: about 1).
//!
//! Printed: each render's median seconds and rays, and the median per-round ratios.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use indicatif::ProgressBar;
use strata::accel::{Accel, AccelOptions};
use strata::integrators::{Integrator, PathSettings, Prepared, ShadingOptions, Strategy};
use strata::render::{self, RenderSettings};
use strata::sampling::SamplerKind;
use strata::scene::{self, Camera, LoadOptions};
use strata::shading::{EnvMap, Environment};

const W: u32 = 160;
const H: u32 = 120;
const ROUNDS: usize = 7;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Nanoseconds per call of the map's lookups, over a million directions drawn uniformly on
/// the sphere (incoherent, as bounce rays are) and a million points of the unit square.
fn kernels(map: &EnvMap, quick: bool) {
    let n = if quick { 1 << 12 } else { 1 << 20 };
    let points: Vec<glam::Vec2> = (0..n as u64)
        .map(|i| {
            let h = strata::sampling::hash::mix64(i.wrapping_mul(0x9e37_79b9_7f4a_7c15));
            glam::Vec2::new(
                (h >> 40) as f32 / (1u64 << 24) as f32,
                ((h >> 16) & 0xff_ffff) as f32 / (1u64 << 24) as f32,
            )
        })
        .collect();
    let dirs: Vec<Vec3> = points
        .iter()
        .map(|&u| strata::sampling::warps::square_to_uniform_sphere(u))
        .collect();
    let time = |name: &str, f: &dyn Fn() -> f32| {
        let rounds = if quick { 1 } else { 5 };
        let t = median(
            (0..rounds)
                .map(|_| {
                    let start = Instant::now();
                    std::hint::black_box(f());
                    start.elapsed().as_secs_f64() * 1e9 / n as f64
                })
                .collect(),
        );
        println!("  {name:<26} {t:.1} ns");
    };
    time("radiance", &|| {
        dirs.iter().map(|&d| map.radiance(d).x).sum()
    });
    time("radiance and pdf", &|| {
        dirs.iter()
            .map(|&d| {
                let (l, p) = map.radiance_pdf(d);
                l.x + p
            })
            .sum()
    });
    time("sample", &|| {
        points
            .iter()
            .map(|&u| {
                let (d, l, p) = map.sample(u);
                d.x + l.x + p
            })
            .sum()
    });
}

fn main() {
    // `cargo bench` passes --bench; `cargo test --benches` runs this once as a smoke test.
    let quick = !std::env::args().any(|a| a == "--bench");
    strata::accel::enable_ftz_daz();
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene_path = std::env::var_os("STRATA_ENV_SCENE")
        .map_or_else(|| repo.join("scenes/suzanne.gltf"), Into::into);
    let map_path = std::env::var_os("STRATA_ENV_MAP").map_or_else(
        || repo.join("scenes/env/studio_small_05_1k/studio_small_05_1k.hdr"),
        Into::into,
    );
    let spp: u32 = std::env::var("STRATA_ENV_SPP").map_or(if quick { 2 } else { 16 }, |s| {
        s.parse()
            .ok()
            .filter(|&n| n > 0)
            .expect("STRATA_ENV_SPP: a positive number of samples per pixel")
    });
    let scene = scene::load(&scene_path, &LoadOptions::default()).expect("scene");
    let accel = Accel::build(&scene, &AccelOptions::default()).expect("BVH");
    let map =
        Arc::new(EnvMap::load(&map_path, 0.5, 1.0, Default::default()).expect("environment map"));
    let pool = render::thread_pool(1).expect("thread pool");
    let camera =
        scene.cameras.first().cloned().unwrap_or_else(|| {
            Camera::framing(scene.bounds.0, scene.bounds.1, W as f32 / H as f32)
        });
    println!(
        "{} ({} triangles) under {} ({}×{}), path {W}x{H} {spp} spp, 1 thread, {} rounds",
        scene_path.file_name().unwrap_or_default().to_string_lossy(),
        scene.triangles.len(),
        map_path.file_name().unwrap_or_default().to_string_lossy(),
        map.size().0,
        map.size().1,
        if quick { 1 } else { ROUNDS }
    );

    kernels(&map, quick);

    // The four set-ups: (name, environment, strategy).
    let constant = Environment::Constant(Vec3::splat(map.mean_luminance()));
    let setups = [
        (
            "map, BSDF sampling",
            Environment::Map(map.clone()),
            Strategy::Bsdf,
        ),
        ("constant, BSDF sampling", constant.clone(), Strategy::Bsdf),
        ("map, MIS", Environment::Map(map), Strategy::Mis),
        ("constant, MIS", constant, Strategy::Mis),
    ];
    let prepared: Vec<(Integrator, Prepared)> = setups
        .iter()
        .map(|(_, environment, strategy)| {
            let integrator = Integrator::Path(PathSettings {
                strategy: *strategy,
                ..PathSettings::default()
            });
            let options = ShadingOptions {
                environment: environment.clone(),
                ..Default::default()
            };
            let prepared = Prepared::with_options(&scene, &scene_path, &integrator, &options)
                .expect("materials and lights");
            (integrator, prepared)
        })
        .collect();
    let render_one = |k: usize| {
        let (integrator, prepared) = &prepared[k];
        let mut ctx = prepared.context(&scene, &accel);
        ctx.experiments.cull_blocks = false;
        let settings = RenderSettings {
            camera: camera.clone(),
            crop: None,
            stopping: Default::default(),
            width: W,
            height: H,
            spp,
            seed: 0,
            sampler: SamplerKind::Sobol,
            integrator: *integrator,
            tile_size: 16,
            sample_range: None,
            min_pass_seconds: f64::INFINITY,
        };
        let start = Instant::now();
        let result = pool.install(|| {
            render::render(
                &ctx,
                &settings,
                &pool,
                &ProgressBar::hidden(),
                &AtomicBool::new(false),
            )
        });
        (start.elapsed().as_secs_f64(), result.stats.rays)
    };

    let rounds = if quick { 1 } else { ROUNDS };
    let mut seconds: [Vec<f64>; 4] = Default::default();
    let mut rays = [0u64; 4];
    for _ in 0..rounds {
        for (k, s) in seconds.iter_mut().enumerate() {
            let (t, r) = render_one(k);
            s.push(t);
            rays[k] = r.camera + r.extension + r.shadow;
        }
    }
    assert_eq!(
        rays[0], rays[1],
        "BSDF sampling under the map and under the constant traced different rays"
    );
    for (k, (name, _, _)) in setups.iter().enumerate() {
        println!(
            "  {name:<26} {:.3} s, {:.2} M rays",
            median(seconds[k].clone()),
            rays[k] as f64 / 1e6
        );
    }
    let ratio = |a: usize, b: usize| {
        median(
            seconds[a]
                .iter()
                .zip(&seconds[b])
                .map(|(x, y)| x / y)
                .collect(),
        )
    };
    let per_ray = ratio(2, 3) * rays[3] as f64 / rays[2] as f64;
    println!(
        "  map ÷ constant, BSDF sampling: {:.3} (target ≤ 1.15)",
        ratio(0, 1)
    );
    println!(
        "  map ÷ constant, MIS: {:.3} in time, {:.3} per traced ray",
        ratio(2, 3),
        per_ray
    );
}
