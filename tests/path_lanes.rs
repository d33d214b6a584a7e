//! The path tracer's lane-parallel form (`strata::integrators::path_lanes`), which shades the
//! paths of a camera packet together in SIMD lanes, against the path tracer one path at a
//! time (`Context::path_lanes` = false): the films are equal bit for bit, and so are the ray
//! counts, on the scenes and settings the lanes handle; the lanes did run there, and stand
//! aside where they do not apply.

mod common;

use std::sync::atomic::AtomicBool;

use common::*;
use glam::Vec3;
use indicatif::ProgressBar;
use strata::accel::{Accel, AccelOptions};
use strata::integrators::{path_lanes, Integrator, PathSettings, Prepared, RayCounts};
use strata::render::{self, RenderSettings, Stopping};
use strata::sampling::SamplerKind;
use strata::scene::{self, LoadOptions};

/// A film's totals per pixel ([`film_totals`]).
type Totals = Vec<([u64; 3], [u64; 3], u32)>;

/// One render of `scene` through the library, as `render` makes it; returns the film's
/// totals, the ray counts, and whether the lanes apply to it.
fn render_with(
    scene: &str,
    integrator: Integrator,
    sampler: SamplerKind,
    spp: u32,
    lanes: bool,
    stopping: Stopping,
) -> (Totals, RayCounts, bool) {
    let path = repo_path(scene);
    let scene = scene::load(&path, &LoadOptions::default()).unwrap();
    let accel = Accel::build(&scene, &AccelOptions::default()).unwrap();
    let prepared = Prepared::new(&scene, &path, &integrator, Vec3::ZERO).unwrap();
    let ctx = strata::integrators::Context {
        path_lanes: lanes,
        ..prepared.context(&scene, &accel)
    };
    let applies = match &integrator {
        Integrator::Path(p) | Integrator::Direct(p) => path_lanes::supported(&ctx, p),
        Integrator::Ao(_) => false,
    };
    // An odd size leaves part-filled packets at the right and bottom edges.
    let settings = RenderSettings {
        camera: scene.cameras[0].clone(),
        width: 45,
        height: 37,
        spp,
        seed: 3,
        sampler,
        integrator,
        tile_size: 16,
        min_pass_seconds: 0.0,
        crop: None,
        stopping,
    };
    let pool = render::thread_pool(2).unwrap();
    let result = render::render(
        &ctx,
        &settings,
        &pool,
        &ProgressBar::hidden(),
        &AtomicBool::new(false),
    );
    (film_totals(&result.film), result.stats.rays, applies)
}

/// Renders `scene` with and without lanes and requires equal films and ray counts; returns
/// whether the lanes applied.
fn assert_lanes_match(
    what: &str,
    scene: &str,
    integrator: Integrator,
    sampler: SamplerKind,
    spp: u32,
    stopping: Stopping,
) -> bool {
    let (a, rays_a, applies) = render_with(scene, integrator, sampler, spp, true, stopping);
    let (b, rays_b, _) = render_with(scene, integrator, sampler, spp, false, stopping);
    let differing = a.iter().zip(&b).filter(|(p, q)| p != q).count();
    assert_eq!(
        differing,
        0,
        "{what}: {differing} of {} pixels differ",
        a.len()
    );
    assert_eq!(rays_a, rays_b, "{what}: ray counts differ");
    assert!(
        rays_a.extension + rays_a.shadow > 0,
        "{what}: nothing traced"
    );
    applies
}

fn path(settings: PathSettings) -> Integrator {
    Integrator::Path(settings)
}

/// The Cornell box, its emitters seen by the camera with and without the split, with each
/// sampler, with roulette from the first bounce and deep paths, as direct lighting, and
/// with adaptive rounds (pixels of one packet taking different numbers of samples); and the
/// emissive-strength scene, whose emitters differ in power and colour.
#[test]
fn lanes_give_the_one_path_at_a_time_film_bit_for_bit() {
    let cornell = "scenes/cornell-box.gltf";
    let fixed = Stopping::default();
    let cases: Vec<(&str, &str, Integrator, SamplerKind, u32, Stopping)> = vec![
        (
            "default",
            cornell,
            path(PathSettings::default()),
            SamplerKind::Sobol,
            8,
            fixed,
        ),
        (
            "no emitter split",
            cornell,
            path(PathSettings {
                emitter_samples: 0,
                ..Default::default()
            }),
            SamplerKind::Sobol,
            8,
            fixed,
        ),
        (
            "roulette from bounce 1, depth 12",
            cornell,
            path(PathSettings {
                max_depth: 12,
                rr_depth: 1,
                ..Default::default()
            }),
            SamplerKind::Sobol,
            8,
            fixed,
        ),
        (
            "random",
            cornell,
            path(PathSettings::default()),
            SamplerKind::Random,
            4,
            fixed,
        ),
        (
            "stratified",
            cornell,
            path(PathSettings::default()),
            SamplerKind::Stratified,
            4,
            fixed,
        ),
        (
            "direct",
            cornell,
            Integrator::Direct(PathSettings {
                max_depth: 1,
                ..Default::default()
            }),
            SamplerKind::Sobol,
            8,
            fixed,
        ),
        (
            "adaptive",
            cornell,
            path(PathSettings::default()),
            SamplerKind::Sobol,
            64,
            Stopping {
                target_error: Some(0.1),
                ..Default::default()
            },
        ),
        (
            "emissive-strength",
            "scenes/emissive-strength.gltf",
            path(PathSettings::default()),
            SamplerKind::Sobol,
            8,
            fixed,
        ),
    ];
    for (what, scene, integrator, sampler, spp, stopping) in cases {
        let applies = assert_lanes_match(what, scene, integrator, sampler, spp, stopping);
        assert!(
            applies,
            "{what}: the lanes did not run, the test compares nothing"
        );
    }
}

/// Where the lanes do not apply (point lights; BSDF sampling alone), the renderer takes the
/// one-path form, with the same film.
#[test]
fn scenes_and_settings_the_lanes_do_not_handle_fall_back() {
    let fixed = Stopping::default();
    let point = assert_lanes_match(
        "point lights",
        "scenes/point-lights.gltf",
        path(PathSettings::default()),
        SamplerKind::Sobol,
        4,
        fixed,
    );
    assert!(!point, "the lanes claim point lights");
    let bsdf = assert_lanes_match(
        "BSDF sampling",
        "scenes/cornell-box.gltf",
        path(PathSettings {
            strategy: strata::integrators::path::Strategy::Bsdf,
            ..Default::default()
        }),
        SamplerKind::Sobol,
        4,
        fixed,
    );
    assert!(!bsdf, "the lanes claim BSDF-only sampling");
}
