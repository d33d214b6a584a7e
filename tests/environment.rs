//! Environment maps end to end: a map of one colour lights a scene as the same constant
//! background does (the map's importance sampling against the constant's BSDF sampling, both
//! unbiased); .hdr and .exr files load with their orientation; bad input is refused with the
//! file named.

mod common;

use std::sync::Arc;

use glam::Vec3;
use strata::accel::{Accel, AccelOptions};
use strata::integrators::{Integrator, PathSettings, Prepared, ShadingOptions};
use strata::render::RenderSettings;
use strata::sampling::SamplerKind;
use strata::scene::{self, LoadOptions};
use strata::shading::{EnvMap, Environment};

/// The Suzanne scene path-traced at 32 × 24, 64 spp, under `environment`, with the camera
/// seeing `camera_background` behind it where given.
fn render_under(
    environment: Environment,
    camera_background: Option<Vec3>,
    seed: u64,
) -> strata::render::Film {
    let path = common::repo_path("scenes/suzanne.gltf");
    let scene = scene::load(&path, &LoadOptions::default()).unwrap();
    let accel = Accel::build(&scene, &AccelOptions::default()).unwrap();
    let integrator = Integrator::Path(PathSettings::default());
    let options = ShadingOptions {
        environment,
        camera_background,
        ..Default::default()
    };
    let prepared = Prepared::with_options(&scene, &path, &integrator, &options).unwrap();
    let ctx = prepared.context(&scene, &accel);
    let settings = RenderSettings {
        camera: scene.cameras[0].clone(),
        crop: None,
        stopping: Default::default(),
        width: 32,
        height: 24,
        spp: 64,
        seed,
        sampler: SamplerKind::Sobol,
        integrator,
        tile_size: 8,
        min_pass_seconds: 0.0,
    };
    let result = common::render_quietly(&ctx, &settings);
    assert_eq!(result.stats.bad_samples, 0);
    result.film
}

/// The mean of [`render_under`]'s image (red channel).
fn mean_under(environment: Environment, seed: u64) -> f64 {
    let pixels = render_under(environment, None, seed).pixels();
    pixels.iter().map(|p| p.x as f64).sum::<f64>() / pixels.len() as f64
}

/// With `--background` in front of an `--env` map, the camera sees the background where its
/// rays leave the scene, and the surfaces are lit by the map as without it.
#[test]
fn the_camera_sees_the_background_in_front_of_the_map() {
    let map = Arc::new(EnvMap::new(16, 8, vec![Vec3::splat(0.5); 16 * 8], 0.0, 1.0));
    let behind = Vec3::new(0.2, 0.4, 0.6);
    let with = render_under(Environment::Map(map.clone()), Some(behind), 1);
    let without = render_under(Environment::Map(map), None, 1);
    // The image's corner misses the head: exactly the background, where the map gave 0.5.
    assert_eq!(with.pixel(0, 0), behind);
    assert!((without.pixel(0, 0) - Vec3::splat(0.5)).abs().max_element() < 1e-6);
    // Pixels that see the head are the same estimates either way.
    let (a, b) = (with.pixel(16, 12), without.pixel(16, 12));
    assert!(a.max_element() > 0.0 && a != behind);
    assert_eq!(a, b);
}

#[test]
fn a_map_of_one_colour_lights_as_the_constant_background_does() {
    let l = Vec3::new(0.5, 0.5, 0.5);
    let map = EnvMap::new(16, 8, vec![l; 16 * 8], 0.7, 1.0);
    let (mut constant, mut mapped) = (0.0, 0.0);
    for seed in 0..4 {
        constant += mean_under(Environment::Constant(l), seed) / 4.0;
        mapped += mean_under(Environment::Map(Arc::new(map.clone())), seed) / 4.0;
    }
    assert!(constant > 0.05, "the scene is lit: {constant}");
    assert!(
        (constant - mapped).abs() < 0.01 * constant,
        "constant {constant}, map {mapped}"
    );
    // And twice the radiance, twice the image.
    let doubled = EnvMap::new(16, 8, vec![l; 16 * 8], 0.7, 2.0);
    let twice = mean_under(Environment::Map(Arc::new(doubled)), 0);
    let once = mean_under(Environment::Map(Arc::new(map)), 0);
    assert!(
        (twice - 2.0 * once).abs() < 1e-4 * twice,
        "{twice} against 2 × {once}"
    );
}

/// A 4 × 2 map with a distinct colour per texel, written as .hdr and as .exr: both load
/// with row 0 at the top (up) and the image's centre toward +X.
#[test]
fn hdr_and_exr_files_load_with_their_orientation() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (4usize, 2usize);
    let texel = |x: usize, y: usize| Vec3::new(1.0 + x as f32, 0.5 * (1 + y) as f32, 0.25);
    let hdr = dir.path().join("map.hdr");
    let mut buffer = image::Rgb32FImage::new(w as u32, h as u32);
    for (x, y, p) in buffer.enumerate_pixels_mut() {
        *p = image::Rgb(texel(x as usize, y as usize).to_array());
    }
    image::DynamicImage::ImageRgb32F(buffer).save(&hdr).unwrap();
    let exr_path = dir.path().join("map.exr");
    exr::prelude::write_rgb_file(&exr_path, w, h, |x, y| {
        let t = texel(x, y);
        (t.x, t.y, t.z)
    })
    .unwrap();
    for path in [&hdr, &exr_path] {
        let map = EnvMap::load(path, 0.0, 1.0).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(map.size(), (w, h));
        // Straight up and straight down see the top and bottom rows; +X looks at u = 0.5,
        // between columns 1 and 2, on the boundary of the rows (θ = 90°).
        let up = map.radiance(Vec3::Y);
        let down = map.radiance(Vec3::NEG_Y);
        assert!((up.y - 0.5).abs() < 0.02, "{}: up {up}", path.display());
        assert!(
            (down.y - 1.0).abs() < 0.02,
            "{}: down {down}",
            path.display()
        );
        let x = map.radiance(Vec3::X);
        assert!((x.x - 2.5).abs() < 0.05, "{}: +X {x}", path.display());
    }
}

#[test]
fn bad_environment_options_are_refused_naming_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::repo_path("scenes/suzanne.gltf");
    let out = dir.path().join("o.exr");
    let missing = dir.path().join("missing.hdr");
    let not_a_map = dir.path().join("map.txt");
    std::fs::write(&not_a_map, "not an image").unwrap();
    let broken = dir.path().join("broken.exr");
    std::fs::write(&broken, "not an exr").unwrap();
    let base = [
        common::s(&scene),
        "--integrator",
        "path",
        "-o",
        common::s(&out),
    ];
    for (extra, words) in [
        (
            vec!["--env", common::s(&missing)],
            vec!["missing.hdr", "no such"],
        ),
        (
            vec!["--env", common::s(&not_a_map)],
            vec!["map.txt", ".hdr"],
        ),
        (vec!["--env", common::s(&broken)], vec!["broken.exr"]),
        (vec!["--env-intensity", "-1"], vec!["--env-intensity"]),
    ] {
        let args: Vec<&str> = base.iter().copied().chain(extra.iter().copied()).collect();
        let run = common::render(dir.path(), &args);
        assert!(!run.status.success(), "{extra:?} succeeded");
        common::assert_no_panic(&run.stderr);
        for w in &words {
            assert!(
                run.stderr.contains(w),
                "{extra:?}: {w:?} not in {}",
                run.stderr
            );
        }
        assert!(!out.exists(), "{extra:?} wrote an image");
    }
}
