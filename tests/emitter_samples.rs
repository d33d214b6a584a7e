//! Emitters the camera sees, estimated with camera rays of their own (`--emitter-samples`,
//! `strata::render`'s `emitters` module): the split lowers the error of a light's outline,
//! changes no pixel that cannot see an emitter, and gives the same film whether camera rays
//! are traced in packets or one by one, and on any thread count. That the split keeps the
//! image's expected value is shown by the reference comparisons (`tests/references.rs`: the
//! Cornell box and the emissive-strength scene, direct and path, render with the default of
//! 16 rays).

mod common;

use std::path::Path;

use common::*;
use glam::Vec3;
use serde_json::Value;
use strata::accel::{Accel, AccelOptions};
use strata::integrators::{Integrator, PathSettings, Prepared, ShadingOptions};
use strata::render::output::read_exr_rgb;
use strata::render::{Film, RenderResult, RenderSettings, Stopping};
use strata::sampling::SamplerKind;
use strata::scene::{self, LoadOptions};
use strata::shading::MaterialOptions;

/// How [`cornell`] renders.
#[derive(Clone, Copy)]
struct Setup {
    emitter_samples: u32,
    size: (u32, u32),
    spp: u32,
    seed: u64,
    /// Camera rays in packets, or one by one.
    packets: bool,
    stopping: Stopping,
    sampler: SamplerKind,
    threads: usize,
    /// The references' model by default (the specification's single scattering).
    materials: MaterialOptions,
}

impl Default for Setup {
    fn default() -> Setup {
        Setup {
            emitter_samples: 8,
            size: (64, 64),
            spp: 8,
            seed: 1,
            packets: true,
            stopping: Stopping::default(),
            sampler: SamplerKind::Sobol,
            threads: 2,
            materials: MaterialOptions {
                energy_compensation: false,
                ..Default::default()
            },
        }
    }
}

/// The Cornell box through the library as `render` would, path traced as `setup` says.
fn cornell(setup: Setup) -> RenderResult {
    let Setup {
        emitter_samples,
        size: (width, height),
        spp,
        seed,
        packets,
        stopping,
        sampler,
        threads,
        materials,
    } = setup;
    let path = repo_path("scenes/cornell-box.gltf");
    let scene = scene::load(&path, &LoadOptions::default()).unwrap();
    let accel = Accel::build(&scene, &AccelOptions::default()).unwrap();
    let integrator = Integrator::Path(PathSettings {
        emitter_samples,
        ..Default::default()
    });
    let options = ShadingOptions {
        materials,
        ..Default::default()
    };
    let prepared = Prepared::with_options(&scene, &path, &integrator, &options).unwrap();
    let ctx = strata::integrators::Context {
        experiments: strata::experiments::Experiments {
            camera_packets: packets,
            ..Default::default()
        },
        ..prepared.context(&scene, &accel)
    };
    let settings = RenderSettings {
        camera: scene.cameras[0].clone(),
        width,
        height,
        spp,
        seed,
        sampler,
        integrator,
        tile_size: 16,
        sample_range: None,
        min_pass_seconds: 0.0,
        crop: None,
        stopping,
    };
    render_quietly_on(threads, &ctx, &settings)
}

/// [`cornell`] without the split and with it (`setup`'s emitter rays), in that order.
fn without_and_with_split(setup: Setup) -> [RenderResult; 2] {
    [0, setup.emitter_samples].map(|emitter_samples| {
        cornell(Setup {
            emitter_samples,
            ..setup
        })
    })
}

fn pixels(film: &Film) -> Vec<Vec3> {
    film.pixels()
}

/// On the Cornell box at the reference's size, the squared error against the Mitsuba
/// reference falls by more than half with 8 emitter rays per sample, at equal spp, with each
/// sampler: the light's outline, which holds most of the error with one camera ray, is
/// resolved by 8× as many points. (Measured with Sobol: 0.24× at 64 spp.) With the split
/// disabled, or its rays all placed at one point, this fails.
#[test]
fn emitter_rays_lower_the_error_of_the_light_s_outline() {
    let (_, _, reference) =
        read_exr_rgb(&repo_path("scenes/references/cornell-box.path.exr")).unwrap();
    let mse = |img: &[Vec3]| -> f64 {
        img.iter()
            .zip(&reference)
            .map(|(p, r)| {
                (0..3)
                    .map(|c| (p[c] as f64 - r[c] as f64).powi(2))
                    .sum::<f64>()
            })
            .sum::<f64>()
            / (3 * img.len()) as f64
    };
    for sampler in [
        SamplerKind::Sobol,
        SamplerKind::Stratified,
        SamplerKind::Random,
    ] {
        let mut ratios = Vec::new();
        for seed in [1, 2] {
            let [off, on] = without_and_with_split(Setup {
                size: (160, 160),
                spp: 32,
                seed,
                sampler,
                ..Setup::default()
            })
            .map(|r| mse(&pixels(&r.film)));
            ratios.push(on / off);
        }
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        assert!(
            mean < 0.5,
            "{sampler}: squared error with 8 emitter rays / without, per seed: {ratios:?}"
        );
    }
}

/// With the split, the image is still bit-identical on one thread and on two.
#[test]
fn split_images_do_not_depend_on_the_thread_count() {
    let [one, two] = [1, 2].map(|threads| {
        cornell(Setup {
            size: (64, 48),
            spp: 16,
            seed: 9,
            threads,
            ..Setup::default()
        })
    });
    let (a, b) = (film_totals(&one.film), film_totals(&two.film));
    let differing = a.iter().zip(&b).filter(|(p, q)| p != q).count();
    assert_eq!(
        differing, 0,
        "{differing} pixels differ between 1 and 2 threads"
    );
    assert!(one.stats.rays.camera > 64 * 48 * 16, "no emitter rays");
}

/// The split leaves the path's own sampler dimensions alone: every pixel away from the
/// light is bit-identical with and without it, and the pixels that change are near the
/// light (inside its image grown by the mask's blocks and margins).
#[test]
fn only_pixels_that_may_see_an_emitter_change() {
    let size = (64, 64);
    let [off, on] = without_and_with_split(Setup {
        size,
        seed: 3,
        ..Setup::default()
    });
    let (a, b) = (film_totals(&off.film), film_totals(&on.film));
    let img = pixels(&off.film);
    // The light: pixels far brighter than any lit wall.
    let light: Vec<(i64, i64)> = (0..size.1 as i64)
        .flat_map(|y| (0..size.0 as i64).map(move |x| (x, y)))
        .filter(|&(x, y)| img[(y * size.0 as i64 + x) as usize].max_element() > 20.0)
        .collect();
    assert!(!light.is_empty(), "no light in view");
    let (x0, x1) = (
        light.iter().map(|p| p.0).min().unwrap(),
        light.iter().map(|p| p.0).max().unwrap(),
    );
    let (y0, y1) = (
        light.iter().map(|p| p.1).min().unwrap(),
        light.iter().map(|p| p.1).max().unwrap(),
    );
    let mut changed = 0;
    for y in 0..size.1 as i64 {
        for x in 0..size.0 as i64 {
            let i = (y * size.0 as i64 + x) as usize;
            if a[i] != b[i] {
                changed += 1;
                assert!(
                    (x0 - 8..=x1 + 8).contains(&x) && (y0 - 8..=y1 + 8).contains(&y),
                    "pixel ({x}, {y}) changed, far from the light ({x0}..{x1}, {y0}..{y1})"
                );
            }
        }
    }
    assert!(changed > 0, "no pixel changed");
    // The extra rays are camera rays, 8 per sample of each split pixel.
    let extra = on.stats.rays.camera - off.stats.rays.camera;
    assert!(extra > 0 && extra % 8 == 0, "{extra} extra camera rays");
    assert!(
        extra <= 8 * 8 * (size.0 * size.1) as u64 / 4,
        "{extra} extra camera rays: more than a quarter of the image split"
    );
}

/// Packets and single camera rays give the same film, bit for bit, with the split: fixed spp
/// on a size that leaves part-filled blocks, and adaptive rounds where the pixels of a
/// packet take different numbers of samples. Lambertian: a ray that meets an edge shared by
/// two triangles may hit either in a packet or alone (README, `--no-camera-packets`), which
/// Lambertian reflection off a flat wall does not see and the glTF BRDF does, in the last
/// bits (one pixel of the adaptive render here, by two ulps of one sample).
#[test]
fn packets_and_single_rays_split_alike() {
    let adaptive = Stopping {
        target_error: Some(0.05),
        ..Default::default()
    };
    for (spp, stopping) in [(4, Stopping::default()), (64, adaptive)] {
        let [packets, single] = [true, false].map(|packets| {
            cornell(Setup {
                size: (61, 45),
                spp,
                seed: 5,
                packets,
                stopping,
                materials: MaterialOptions::lambertian(),
                ..Setup::default()
            })
        });
        let (a, b) = (film_totals(&packets.film), film_totals(&single.film));
        let differing = a.iter().zip(&b).filter(|(p, q)| p != q).count();
        assert_eq!(differing, 0, "spp {spp}: {differing} pixels differ");
        let samples: u64 = a.iter().map(|p| p.2 as u64).sum();
        assert!(
            single.stats.rays.camera > samples,
            "spp {spp}: no emitter rays ({} camera rays, {samples} samples)",
            single.stats.rays.camera
        );
    }
}

/// The command line: `--emitter-samples N` reaches the render and its EXR header, 0 traces
/// no emitter rays (the camera rays are one per sample), and a count over 256 is refused
/// with an error naming the option, without writing anything.
#[test]
fn the_option_reaches_the_render_and_bad_counts_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo_path("scenes/cornell-box.gltf");
    let mut camera_rays = Vec::new();
    for n in ["0", "4"] {
        let out = dir.path().join(format!("cb{n}.exr"));
        let run = render(
            dir.path(),
            &[
                s(&scene),
                "-o",
                s(&out),
                "--integrator",
                "path",
                "--resolution",
                "32x32",
                "--spp",
                "4",
                "--emitter-samples",
                n,
                "--no-png",
                "--stats",
            ],
        );
        run.assert_success();
        assert_eq!(
            attr(&int_attrs(&out), "strata:emitter_samples"),
            n.parse::<i32>().unwrap()
        );
        camera_rays.push(camera_rays_of(&run));
    }
    assert_eq!(
        camera_rays[0],
        32 * 32 * 4,
        "one camera ray per sample with 0"
    );
    assert!(camera_rays[1] > camera_rays[0], "no emitter rays with 4");

    let out = dir.path().join("bad.exr");
    let run = render(
        dir.path(),
        &[s(&scene), "-o", s(&out), "--emitter-samples", "1000"],
    );
    assert!(!run.status.success(), "1000 emitter rays accepted");
    assert!(run.stderr.contains("--emitter-samples"), "{}", run.stderr);
    assert_no_panic(&run.stderr);
    assert!(!out.exists(), "an image was written");
}

/// The camera rays of `render --stats` for `scene`: (camera rays, samples).
fn camera_rays_and_samples(dir: &Path, scene: &Path, size: u32, spp: u32) -> (u64, u64) {
    let out = dir.join("out.exr");
    let res = format!("{size}x{size}");
    let spp_s = spp.to_string();
    let run = render(
        dir,
        &[
            s(scene),
            "-o",
            s(&out),
            "--integrator",
            "direct",
            "--resolution",
            &res,
            "--spp",
            &spp_s,
            "--no-png",
            "--stats",
        ],
    );
    run.assert_success();
    (camera_rays_of(&run), (size * size * spp) as u64)
}

/// The camera rays of a `render --stats` run (the first figure of its "rays:" line).
fn camera_rays_of(run: &Run) -> u64 {
    let line = run
        .stdout
        .lines()
        .chain(run.stderr.lines())
        .find(|l| l.starts_with("rays:"))
        .unwrap_or_else(|| panic!("no rays line:\n{}\n{}", run.stdout, run.stderr));
    line.trim_start_matches("rays: ")
        .split(' ')
        .next()
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no camera rays in {line}"))
}

/// Inside an emitter's image every ray sees the same radiance, so splitting there only
/// costs rays: the pixels inside the Cornell box's light are left to their paths, bit for
/// bit as without the split, while those on its outline are split. Without the corner rays
/// that find the interior, the pixels inside would change too.
#[test]
fn the_light_s_interior_is_not_split_and_its_outline_is() {
    let size = (160, 160);
    let [off, on] = without_and_with_split(Setup {
        size,
        spp: 4,
        seed: 5,
        ..Setup::default()
    });
    let (a, b) = (film_totals(&off.film), film_totals(&on.film));
    let (_, _, reference) =
        read_exr_rgb(&repo_path("scenes/references/cornell-box.path.exr")).unwrap();
    let at = |x: i64, y: i64| {
        let p = reference[(y * size.0 as i64 + x) as usize];
        p[0].min(p[1]).min(p[2])
    };
    let (mut inside, mut outline) = (0, 0);
    for y in 1..size.1 as i64 - 1 {
        for x in 1..size.0 as i64 - 1 {
            let i = (y * size.0 as i64 + x) as usize;
            // Covered whole, with its neighbours: the light's radiance is about 100.
            let whole = (-1..=1).all(|dy| (-1..=1).all(|dx| at(x + dx, y + dy) > 90.0));
            if whole {
                inside += 1;
                assert_eq!(a[i], b[i], "pixel ({x}, {y}) inside the light was split");
            } else if (10.0..80.0).contains(&at(x, y)) {
                outline += 1;
                assert_ne!(
                    a[i], b[i],
                    "pixel ({x}, {y}) on the light's outline was not split"
                );
            }
        }
    }
    assert!(
        inside > 50 && outline > 20,
        "{inside} inside, {outline} on the outline"
    );
    assert!(on.stats.rays.probe > 0, "no corner rays counted");
    assert_eq!(off.stats.rays.probe, 0, "corner rays without a split");
}

/// Emitter rays cost about a tenth of a path each: where emitters' outlines cover most of
/// the image, the split would slow the render for little, so the renderer keeps the extra
/// rays under one per sample over the image. A floor of emissive squares smaller than a
/// pixel gets none; an emissive floor that fills the view is all interior and gets none
/// either; a small light in view (the Cornell box) gets all 16, the default. Without the
/// cap, the squares
/// would be split.
#[test]
fn emitter_outlines_over_most_of_the_view_are_not_split() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = ao_wall_json();
    doc["buffers"][0]["uri"] = Value::String(data_uri(&ao_wall_buffer()));
    doc["materials"][0]["emissiveFactor"] = serde_json::json!([1.0, 1.0, 1.0]);
    let glowing = dir.path().join("glowing-wall.gltf");
    std::fs::write(&glowing, serde_json::to_vec(&doc).unwrap()).unwrap();
    let (camera, samples) = camera_rays_and_samples(dir.path(), &glowing, 32, 4);
    assert_eq!(
        camera, samples,
        "an emissive floor filling the view was split"
    );

    let squares = dir.path().join("glowing-squares.gltf");
    std::fs::write(&squares, serde_json::to_vec(&glowing_squares()).unwrap()).unwrap();
    let (camera, samples) = camera_rays_and_samples(dir.path(), &squares, 32, 4);
    assert_eq!(
        camera, samples,
        "emissive squares smaller than a pixel, all over the view, were split"
    );

    let (camera, samples) =
        camera_rays_and_samples(dir.path(), &repo_path("scenes/cornell-box.gltf"), 32, 4);
    assert!(camera > samples, "the Cornell box's light was not split");
    assert_eq!(
        (camera - samples) % 16,
        0,
        "{} emitter rays: not 16 per sample of the split pixels",
        camera - samples
    );
}

/// ao-wall with, 0.01 above its floor, a grid of emissive squares of 0.6 of a pixel at
/// 32 × 32 (pitch 1.2 pixels) over the whole view: nearly every pixel has an emitter's
/// outline in it.
fn glowing_squares() -> Value {
    let mut doc = ao_wall_json();
    let mut buffer = ao_wall_buffer();
    while !buffer.len().is_multiple_of(4) {
        buffer.push(0);
    }
    // The camera at (1, 1, 0) looks down at the floor with a 0.5 rad field of view: about
    // 0.51 across, 0.016 a pixel at 32 pixels.
    let (n, pitch, side) = (40, 0.6 / 40.0, 0.3 / 40.0);
    let mut positions = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x, z) = (0.7 + i as f32 * pitch, -0.3 + j as f32 * pitch);
            let v = positions.len() as u32 / 3;
            for (dx, dz) in [(0.0, 0.0), (side, 0.0), (side, side), (0.0, side)] {
                positions.extend([x + dx, 0.01, z + dz]);
            }
            indices.extend([v, v + 2, v + 1, v, v + 3, v + 2]);
        }
    }
    let offset = buffer.len();
    buffer.extend(positions.iter().flat_map(|f| f.to_le_bytes()));
    let index_offset = buffer.len();
    buffer.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let views = doc["bufferViews"].as_array().unwrap().len();
    let accessors = doc["accessors"].as_array().unwrap().len();
    doc["bufferViews"].as_array_mut().unwrap().extend([
        serde_json::json!({"buffer": 0, "byteOffset": offset, "byteLength": index_offset - offset}),
        serde_json::json!({"buffer": 0, "byteOffset": index_offset, "byteLength": buffer.len() - index_offset}),
    ]);
    doc["accessors"].as_array_mut().unwrap().extend([
        serde_json::json!({"bufferView": views, "componentType": 5126, "count": positions.len() / 3,
            "type": "VEC3", "min": [0.7, 0.01, -0.3], "max": [1.3, 0.01, 0.3]}),
        serde_json::json!({"bufferView": views + 1, "componentType": 5125, "count": indices.len(),
            "type": "SCALAR"}),
    ]);
    doc["buffers"][0]["byteLength"] = buffer.len().into();
    doc["buffers"][0]["uri"] = Value::String(data_uri(&buffer));
    let materials = doc["materials"].as_array().unwrap().len();
    doc["materials"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({
            "name": "glow", "emissiveFactor": [1.0, 1.0, 1.0]
        }));
    let meshes = doc["meshes"].as_array().unwrap().len();
    doc["meshes"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({
            "name": "squares",
            "primitives": [{"attributes": {"POSITION": accessors}, "indices": accessors + 1,
                "material": materials}]
        }));
    let nodes = doc["nodes"].as_array().unwrap().len();
    doc["nodes"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"name": "squares", "mesh": meshes}));
    doc["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(nodes.into());
    doc
}
