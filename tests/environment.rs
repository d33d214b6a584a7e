//! Environment maps end to end: a map of one colour lights a scene as the same constant
//! background does (the map's importance sampling against the constant's BSDF sampling, both
//! unbiased); under a map that is 1 above the horizon and 0 below, a white Lambertian floor
//! reads 1 and a white wall 1/2 (closed forms); .hdr and .exr files load with their
//! orientation; bad input is refused with the file named.

mod common;

use std::sync::Arc;

use glam::{Vec2, Vec3, Vec4};
use strata::accel::{Accel, AccelOptions};
use strata::integrators::{Integrator, PathSettings, Prepared, ShadingOptions};
use strata::render::RenderSettings;
use strata::sampling::SamplerKind;
use strata::scene::{self, LoadOptions, Material, Scene};
use strata::shading::{EnvMap, Environment, MapSampling, MaterialOptions};

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
        sample_range: None,
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

/// The memory a map will take, from its file's header alone, .hdr and .exr alike: a 40 × 20
/// map keeps 41 texels a row (the first repeated at the end) of 16 bytes (RGB radiance and
/// the sampling density, f32 each), 41 × 20 × 16 = 13 120 bytes, and 8 bytes (a cdf value
/// and a guide index) for each of its 41 × 21 cells and the 22 entries of the marginal over
/// the cell rows, (861 + 22) × 8 = 7 064: 20 184 in all.
#[test]
fn an_environment_maps_memory_is_estimated_from_its_header() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (40usize, 20usize);
    let hdr = dir.path().join("map.hdr");
    image::DynamicImage::ImageRgb32F(image::Rgb32FImage::new(w as u32, h as u32))
        .save(&hdr)
        .unwrap();
    let exr_path = dir.path().join("map.exr");
    exr::prelude::write_rgb_file(&exr_path, w, h, |_, _| (0.5f32, 0.5f32, 0.5f32)).unwrap();
    for path in [&hdr, &exr_path] {
        assert_eq!(
            EnvMap::memory_estimate(path),
            Ok(20_184),
            "{}",
            path.display()
        );
    }
    let e = EnvMap::memory_estimate(&dir.path().join("absent.hdr")).unwrap_err();
    assert!(e.contains("absent.hdr"), "{e}");
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
        let map =
            EnvMap::load(path, 0.0, 1.0, Default::default()).unwrap_or_else(|e| panic!("{e}"));
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
    // The bundled studio map cut off after its header and a few rows.
    let truncated = dir.path().join("truncated.hdr");
    let studio = std::fs::read(common::repo_path(
        "scenes/env/studio_small_05_1k/studio_small_05_1k.hdr",
    ))
    .unwrap();
    std::fs::write(&truncated, &studio[..30_000]).unwrap();
    let folder = dir.path().join("maps");
    std::fs::create_dir(&folder).unwrap();
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
        (
            vec!["--env", common::s(&truncated)],
            vec!["truncated.hdr", "truncated?"],
        ),
        (
            vec!["--env", common::s(&folder)],
            vec!["maps", "a directory"],
        ),
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

// ---------------------------------------------------------------------------------------------
// The sky of radiance 1 above the horizon and 0 below: closed forms.
//
// A white Lambertian surface (ρ = 1, f = 1/π) that nothing occludes reflects L_o = E/π, E the
// irradiance. A floor (normal +Y) sees the whole upper hemisphere lit: E = π, L_o = 1. A
// vertical wall sees a hemisphere that the horizon cuts in half, symmetric in elevation, so
// the lit half carries half the cosine-weighted solid angle: E = π/2, L_o = 1/2.
//
// The map is looked up bilinearly, so within half a texel row of the horizon (δ/2, δ = π/H)
// the radiance ramps from 0 to 1. For the wall the ramp is odd about the horizon and the
// cosine even: no error. The floor misses 2π∫₀^{δ/2} (1/2 − e/δ)·e de = πδ²/24 of its
// irradiance: L_o = 1 − δ²/24, 1.0e-4 for H = 64 rows, allowed for beside the noise.
// ---------------------------------------------------------------------------------------------

/// Rows of the sky maps: an even count, so the horizon falls between two rows.
const SKY_ROWS: usize = 64;

/// Writes a 2H × H .hdr map whose rows above `horizon_row` are 1 and the rest 0 (or the
/// reverse when `upside_down`), into `dir`.
fn write_sky(
    dir: &std::path::Path,
    name: &str,
    horizon_row: usize,
    upside_down: bool,
) -> std::path::PathBuf {
    let (w, h) = (2 * SKY_ROWS as u32, SKY_ROWS as u32);
    let mut buffer = image::Rgb32FImage::new(w, h);
    for (_, y, p) in buffer.enumerate_pixels_mut() {
        let lit = ((y as usize) < horizon_row) != upside_down;
        *p = image::Rgb([if lit { 1.0 } else { 0.0 }; 3]);
    }
    let path = dir.join(name);
    image::DynamicImage::ImageRgb32F(buffer)
        .save(&path)
        .unwrap();
    path
}

/// A 200 × 200 white square centred at the origin, facing `normal` (+Y or +X), alone.
fn white_square(normal: Vec3) -> Scene {
    let s = 100.0;
    let (a, b) = if normal == Vec3::Y {
        (Vec3::Z, Vec3::X)
    } else {
        (Vec3::Y, Vec3::Z)
    };
    let positions = vec![(-a - b) * s, (a - b) * s, (a + b) * s, (-a + b) * s];
    let mut scene = Scene {
        normals: vec![Vec3::ZERO; 4],
        uvs: vec![Vec2::ZERO; 4],
        positions,
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        triangle_materials: vec![1; 2],
        materials: vec![
            Material::default(),
            Material {
                base_color: Vec4::ONE,
                metallic: 0.0,
                ..Default::default()
            },
        ],
        ..Default::default()
    };
    scene.update_summary();
    scene
}

/// The mean of the pixels of `scene` seen from `eye` (looking at the origin) under the map
/// at `map`, and its standard error, rendered with independent random samples (so pixels are
/// independent estimates), Lambertian materials.
fn mean_radiance(
    scene: &Scene,
    eye: Vec3,
    map: &std::path::Path,
    (integrator, sampling): (Integrator, MapSampling),
) -> (f64, f64) {
    let accel = Accel::build(scene, &AccelOptions::default()).unwrap();
    let environment = Environment::Map(Arc::new(EnvMap::load(map, 0.0, 1.0, sampling).unwrap()));
    let options = ShadingOptions {
        environment,
        materials: MaterialOptions::lambertian(),
        ..Default::default()
    };
    let prepared = Prepared::with_options(
        scene,
        std::path::Path::new("white square"),
        &integrator,
        &options,
    )
    .unwrap();
    let ctx = prepared.context(scene, &accel);
    let settings = RenderSettings {
        camera: common::camera_looking(eye, -eye, Vec3::Y, 0.5),
        crop: None,
        stopping: Default::default(),
        width: 16,
        height: 16,
        spp: 64,
        seed: 7,
        sampler: SamplerKind::Random,
        integrator,
        tile_size: 8,
        sample_range: None,
        min_pass_seconds: 0.0,
    };
    let result = common::render_quietly(&ctx, &settings);
    assert_eq!(result.stats.bad_samples, 0);
    let v: Vec<f64> = result.film.pixels().iter().map(|p| p.x as f64).collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// Whether `mean ± sem` agrees with `expected`: within 5 standard errors plus the map's
/// interpolation bias bound (see above).
fn agrees(mean: f64, sem: f64, expected: f64) -> bool {
    let bias = (std::f64::consts::PI / SKY_ROWS as f64).powi(2) / 24.0;
    (mean - expected).abs() < 5.0 * sem + bias
}

/// Direct lighting and path tracing, under each way of sampling the map.
fn direct_and_path() -> [(&'static str, (Integrator, MapSampling)); 4] {
    let path = Integrator::Path(PathSettings::default());
    let direct = Integrator::Direct(PathSettings {
        max_depth: 1,
        ..Default::default()
    });
    let (radiance, compensated) = (MapSampling::Radiance, MapSampling::Compensated);
    [
        ("direct", (direct, radiance)),
        ("direct, compensated", (direct, compensated)),
        ("path", (path, radiance)),
        ("path, compensated", (path, compensated)),
    ]
}

#[test]
fn under_a_sky_lit_above_the_horizon_a_floor_reads_1_and_a_wall_one_half() {
    let dir = tempfile::tempdir().unwrap();
    let sky = write_sky(dir.path(), "sky.hdr", SKY_ROWS / 2, false);
    let floor = white_square(Vec3::Y);
    let wall = white_square(Vec3::X);
    for (name, integrator) in direct_and_path() {
        let (mean, sem) = mean_radiance(&floor, Vec3::new(0.0, 3.0, 0.5), &sky, integrator);
        eprintln!("{name}: floor {mean} ± {sem}");
        assert!(sem > 0.0 && sem < 0.01, "{name}: floor noise {sem}");
        assert!(
            agrees(mean, sem, 1.0),
            "{name}: floor {mean} ± {sem}, expected 1"
        );
        let (mean, sem) = mean_radiance(&wall, Vec3::new(3.0, 0.5, 0.2), &sky, integrator);
        eprintln!("{name}: wall {mean} ± {sem}");
        assert!(sem < 0.01, "{name}: wall noise {sem}");
        assert!(
            agrees(mean, sem, 0.5),
            "{name}: wall {mean} ± {sem}, expected 1/2"
        );
    }
}

/// Negative controls: the same checks reject the map upside down (the floor then reads 0)
/// and a horizon two rows too low (α = 5.6° below it lit: the wall then reads
/// 1/2 + (α + sin 2α / 2)/π = 0.562).
#[test]
fn the_floor_and_wall_checks_reject_a_wrong_sky() {
    let dir = tempfile::tempdir().unwrap();
    let flipped = write_sky(dir.path(), "flipped.hdr", SKY_ROWS / 2, true);
    let low = write_sky(dir.path(), "low.hdr", SKY_ROWS / 2 + 2, false);
    for (name, integrator) in direct_and_path() {
        let (mean, sem) = mean_radiance(
            &white_square(Vec3::Y),
            Vec3::new(0.0, 3.0, 0.5),
            &flipped,
            integrator,
        );
        eprintln!("{name}: floor under the flipped map {mean} ± {sem}");
        assert!(
            !agrees(mean, sem, 1.0),
            "{name}: the flipped map passed: {mean} ± {sem}"
        );
        let (mean, sem) = mean_radiance(
            &white_square(Vec3::X),
            Vec3::new(3.0, 0.5, 0.2),
            &low,
            integrator,
        );
        eprintln!("{name}: wall under the low horizon {mean} ± {sem}");
        assert!(
            !agrees(mean, sem, 0.5),
            "{name}: the low horizon passed: {mean} ± {sem}"
        );
    }
}
