//! Alpha coverage (glTF `alphaMode` MASK and BLEND) end to end, on both backends:
//! - MASK: a checkerboard cut-out in front of an emitter shows the emitter exactly through
//!   its holes and its own emission exactly on its squares; the same file with OPAQUE shows
//!   no emitter; a factor below the cutoff makes the whole quad a hole;
//! - BLEND: a quad of alpha 0.25 in front of an emitter lets 0.75 of the emitter through in
//!   the mean, and the render is bit-identical on one and two threads;
//! - shadow and AO rays (any-hit queries, single and in packets) see the same holes as
//!   closest-hit queries;
//! - the Embree and obvhs backends agree on a scene of MASK and BLEND surfaces.
//!
//! The scenes are glTF files written here: quads with TEXCOORD_0, an embedded PNG made with
//! the `image` crate, an orthographic camera that frames the cut-out quad exactly.

mod common;

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde_json::{json, Value};
use strata::accel::{Accel, AccelOptions, Backend, Ray, OCCLUSION_PACKET, PACKET};
use strata::integrators::{Integrator, PathSettings, Prepared, ShadingOptions, Strategy};
use strata::render::{self, RenderSettings};
use strata::sampling::hash::{hash_words, unit_f32};
use strata::sampling::SamplerKind;
use strata::scene::{self, AlphaMode, LoadOptions, Scene};
use strata::shading::Environment;

const BACKENDS: [Backend; 2] = [Backend::Embree, Backend::Obvhs];

/// Emitted radiance of the emitter behind the cut-out.
const EMITTER: Vec3 = Vec3::new(1.0, 0.5, 0.25);
/// Emitted radiance of the cut-out's front face: its own shading, since nothing lights it
/// (the emitter is behind it and the background is black).
const CUTOUT: Vec3 = Vec3::new(0.0, 0.0, 1.0);

/// Checker texels of the 4 × 4 alpha texture: texel (x, y) (row 0 at the top) is opaque
/// when x + y is even, fully transparent otherwise.
const CHECKER: u32 = 4;

fn opaque_texel(x: u32, y: u32) -> bool {
    (x + y).is_multiple_of(2)
}

/// A white RGBA PNG of `CHECKER` × `CHECKER` texels with the checker's alpha.
fn checker_png() -> Vec<u8> {
    let mut rgba = Vec::new();
    for y in 0..CHECKER {
        for x in 0..CHECKER {
            let a = if opaque_texel(x, y) { 255 } else { 0 };
            rgba.extend_from_slice(&[255, 255, 255, a]);
        }
    }
    let mut png = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut png),
        &rgba,
        CHECKER,
        CHECKER,
        image::ExtendedColorType::Rgba8,
    )
    .unwrap();
    png
}

/// A square in the plane z = `z`, x and y in [−`half`, `half`], facing +z, with TEXCOORD_0
/// (0, 0) at its top-left corner (−half, half) and (1, 1) at its bottom-right.
struct Square {
    z: f32,
    half: f32,
    material: u32,
}

/// A glTF document of `squares` with `materials`, the checker PNG as image 0 (clamped, as a
/// data URI), and an orthographic camera at z = 2 looking down −z whose view is the square
/// x, y in [−1, 1].
fn gltf(squares: &[Square], materials: Vec<Value>) -> Value {
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut meshes, mut nodes) = (vec![], vec![], vec![], vec![]);
    for (i, sq) in squares.iter().enumerate() {
        let h = sq.half;
        let positions = [[-h, h, sq.z], [-h, -h, sq.z], [h, -h, sq.z], [h, h, sq.z]];
        let uvs = [[0.0f32, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]];
        let indices: [u32; 6] = [0, 1, 2, 0, 2, 3];
        let mut view = |bytes: Vec<u8>| {
            views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
            bin.extend(bytes);
            views.len() - 1
        };
        let p = view(
            positions
                .iter()
                .flatten()
                .flat_map(|f| f.to_le_bytes())
                .collect(),
        );
        let t = view(uvs.iter().flatten().flat_map(|f| f.to_le_bytes()).collect());
        let x = view(indices.iter().flat_map(|i| i.to_le_bytes()).collect());
        let base = accessors.len();
        accessors.push(
            json!({"bufferView": p, "componentType": 5126, "count": 4, "type": "VEC3",
            "min": [-h, -h, sq.z], "max": [h, h, sq.z]}),
        );
        accessors.push(json!({"bufferView": t, "componentType": 5126, "count": 4, "type": "VEC2"}));
        accessors
            .push(json!({"bufferView": x, "componentType": 5125, "count": 6, "type": "SCALAR"}));
        meshes.push(json!({"primitives": [{
            "attributes": {"POSITION": base, "TEXCOORD_0": base + 1},
            "indices": base + 2, "material": sq.material}]}));
        nodes.push(json!({"mesh": i}));
    }
    nodes.push(json!({"camera": 0, "translation": [0.0, 0.0, 2.0]}));
    use base64::Engine;
    let png = base64::engine::general_purpose::STANDARD.encode(checker_png());
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "cameras": [{"type": "orthographic",
            "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.01, "zfar": 100.0}}],
        "materials": materials,
        "textures": [{"sampler": 0, "source": 0}],
        "samplers": [{"wrapS": 33071, "wrapT": 33071, "magFilter": 9729, "minFilter": 9729}],
        "images": [{"uri": format!("data:image/png;base64,{png}")}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len(), "uri": common::data_uri(&bin)}],
    })
}

/// The cut-out's material: black, emitting [`CUTOUT`] from its front, with `alpha` as the
/// base colour factor's alpha, the checker as its base colour texture if `textured`, and the
/// given `alphaMode` (and `alphaCutoff`, if any).
fn cutout_material(mode: &str, cutoff: Option<f32>, alpha: f32, textured: bool) -> Value {
    let mut pbr = json!({"baseColorFactor": [0.0, 0.0, 0.0, alpha], "metallicFactor": 0.0});
    if textured {
        pbr["baseColorTexture"] = json!({"index": 0});
    }
    let mut m = json!({"name": "cutout", "pbrMetallicRoughness": pbr,
        "emissiveFactor": CUTOUT.to_array(), "alphaMode": mode});
    if let Some(c) = cutoff {
        m["alphaCutoff"] = json!(c);
    }
    m
}

fn emitter_material() -> Value {
    json!({"name": "emitter",
        "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0},
        "emissiveFactor": EMITTER.to_array()})
}

/// The cut-out (triangles 0 and 1, mesh 0) at z = 0 filling the camera's view, and the
/// emitter (triangles 2 and 3) at z = −1, three times as wide, behind it.
fn cutout_doc(cutout: Value) -> Value {
    gltf(
        &[
            Square {
                z: 0.0,
                half: 1.0,
                material: 0,
            },
            Square {
                z: -1.0,
                half: 3.0,
                material: 1,
            },
        ],
        vec![cutout, emitter_material()],
    )
}

/// [`cutout_doc`] written to `dir/name`.
fn cutout_scene(dir: &Path, name: &str, cutout: Value) -> PathBuf {
    let doc = cutout_doc(cutout);
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
    path
}

fn load(path: &Path) -> Scene {
    scene::load(path, &LoadOptions::default()).unwrap()
}

fn build(scene: &Scene, backend: Backend) -> Accel {
    Accel::build(
        scene,
        &AccelOptions {
            backend,
            ..Default::default()
        },
    )
    .unwrap()
}

/// Direct lighting (one bounce) from the file's camera at `size` × `size`, black
/// background, rendered on a pool of `threads` workers.
fn render_film(
    path: &Path,
    backend: Backend,
    size: u32,
    spp: u32,
    seed: u64,
    threads: usize,
) -> render::Film {
    render_film_with(path, backend, size, spp, seed, threads, Strategy::Mis)
}

/// [`render_film`] with the direct integrator's sampling `strategy`.
fn render_film_with(
    path: &Path,
    backend: Backend,
    size: u32,
    spp: u32,
    seed: u64,
    threads: usize,
    strategy: Strategy,
) -> render::Film {
    let scene = load(path);
    let accel = build(&scene, backend);
    let integrator = Integrator::Direct(PathSettings {
        max_depth: 1,
        strategy,
        ..Default::default()
    });
    let options = ShadingOptions {
        environment: Environment::Constant(Vec3::ZERO),
        ..Default::default()
    };
    let prepared = Prepared::with_options(&scene, path, &integrator, &options).unwrap();
    let settings = RenderSettings {
        camera: scene.cameras[0].clone(),
        crop: None,
        stopping: Default::default(),
        width: size,
        height: size,
        spp,
        seed,
        sampler: SamplerKind::Sobol,
        integrator,
        tile_size: 8,
        sample_range: None,
        min_pass_seconds: 0.0,
    };
    let result = common::render_quietly_on(threads, &prepared.context(&scene, &accel), &settings);
    assert_eq!(result.stats.bad_samples, 0);
    result.film
}

/// Image size of the MASK renders: 8 × 8 pixels per texel of the checker.
const SIZE: u32 = 8 * CHECKER;

/// The pixels whose every sample falls inside one texel's constant region: texel (x, y)'s
/// pixels but those on its border (bilinear filtering with clamping blends alpha across the
/// texel boundary, where it is 0.5, and a border pixel's footprint touches the boundary).
fn interior_pixels() -> impl Iterator<Item = (u32, u32, bool)> {
    (0..SIZE).flat_map(|py| {
        (0..SIZE).filter_map(move |px| {
            let inner = |p: u32| !p.is_multiple_of(8) && p % 8 != 7;
            (inner(px) && inner(py)).then(|| (px, py, opaque_texel(px / 8, py / 8)))
        })
    })
}

#[test]
fn mask_shows_the_emitter_exactly_through_its_holes() {
    let dir = tempfile::tempdir().unwrap();
    let mask = cutout_scene(
        dir.path(),
        "mask.gltf",
        cutout_material("MASK", None, 1.0, true),
    );
    let opaque = cutout_scene(
        dir.path(),
        "opaque.gltf",
        cutout_material("OPAQUE", None, 1.0, true),
    );
    assert_eq!(load(&mask).materials[1].alpha_mode, AlphaMode::Mask(0.5));
    for backend in BACKENDS {
        let film = render_film(&mask, backend, SIZE, 16, 1, 2);
        let (mut holes, mut squares) = (0, 0);
        for (x, y, covered) in interior_pixels() {
            let (want, what) = match covered {
                true => (CUTOUT, "the cut-out's own emission"),
                false => (EMITTER, "the emitter"),
            };
            assert_eq!(
                film.pixel(x, y),
                want,
                "{backend:?}: pixel ({x}, {y}) should show {what}"
            );
            *(if covered { &mut squares } else { &mut holes }) += 1;
        }
        assert_eq!((holes, squares), (288, 288));

        // Negative control: OPAQUE ignores the texture's alpha; the emitter shows nowhere.
        let film = render_film(&opaque, backend, SIZE, 16, 1, 2);
        for y in 0..SIZE {
            for x in 0..SIZE {
                assert_eq!(
                    film.pixel(x, y),
                    CUTOUT,
                    "{backend:?}: OPAQUE pixel ({x}, {y})"
                );
            }
        }
    }
}

/// Alpha is the factor times the texture: a factor of 0.45 keeps every texel below the
/// default cutoff of 0.5, and the whole cut-out is a hole; a cutoff of 0.2 brings the
/// squares back (checked at the texels' centres: the squares' edges move where
/// 0.45 × alpha crosses 0.2).
#[test]
fn mask_cuts_the_factor_times_the_texture_at_the_cutoff() {
    let dir = tempfile::tempdir().unwrap();
    let below = cutout_scene(
        dir.path(),
        "below.gltf",
        cutout_material("MASK", None, 0.45, true),
    );
    let lowered = cutout_scene(
        dir.path(),
        "lowered.gltf",
        cutout_material("MASK", Some(0.2), 0.45, true),
    );
    for backend in BACKENDS {
        let film = render_film(&below, backend, SIZE, 4, 1, 2);
        for y in 0..SIZE {
            for x in 0..SIZE {
                assert_eq!(film.pixel(x, y), EMITTER, "{backend:?}: pixel ({x}, {y})");
            }
        }
        let film = render_film(&lowered, backend, SIZE, 4, 1, 2);
        // Texel centres: the squares are back, the holes stay.
        for ty in 0..CHECKER {
            for tx in 0..CHECKER {
                let want = if opaque_texel(tx, ty) {
                    CUTOUT
                } else {
                    EMITTER
                };
                assert_eq!(film.pixel(8 * tx + 4, 8 * ty + 4), want, "{backend:?}");
            }
        }
    }
}

/// BLEND at alpha 0.25 (the factor alone) stops a quarter of the camera rays: the image's
/// mean is 0.75 × the emitter + 0.25 × the cut-out's own emission. Each camera ray sees one
/// or the other, so the red channel's mean over N samples has a standard error of at most
/// √(0.25 · 0.75 / N) × the emitter's red (less where a sample averages the emission of
/// several camera rays, `integrators::emitters`); the test allows 5 of them. The render is the
/// same bit for bit on one and two threads, and changes with the seed.
#[test]
fn blend_lets_one_minus_alpha_of_the_light_through() {
    let dir = tempfile::tempdir().unwrap();
    let blend = cutout_scene(
        dir.path(),
        "blend.gltf",
        cutout_material("BLEND", None, 0.25, false),
    );
    let (size, spp) = (32u32, 16u32);
    for backend in BACKENDS {
        let film = render_film(&blend, backend, size, spp, 7, 2);
        let pixels = film.pixels();
        let mean = pixels.iter().map(|p| p.as_dvec3()).sum::<glam::DVec3>() / pixels.len() as f64;
        let n = (size * size * spp) as f64;
        let tolerance = 5.0 * (0.25f64 * 0.75 / n).sqrt();
        let expected = 0.75 * EMITTER.as_dvec3() + 0.25 * CUTOUT.as_dvec3();
        assert!(
            (mean.x / EMITTER.x as f64 - 0.75).abs() < tolerance,
            "{backend:?}: mean {mean}, expected {expected} (tolerance {tolerance} of the emitter)"
        );
        // Blue: 0.25 × 1 + 0.75 × 0.25, with the same coin per sample.
        assert!(
            (mean.z - expected.z).abs() < tolerance * (1.0 - EMITTER.z as f64),
            "{backend:?}: mean {mean}, expected {expected}"
        );
        // Partial pixels: the coin is drawn per ray, not per pixel.
        let partial = pixels
            .iter()
            .filter(|p| p.x > 0.0 && p.x < EMITTER.x)
            .count();
        assert!(partial > pixels.len() / 2, "{partial} pixels mix the two");

        let one = render_film(&blend, backend, size, spp, 7, 1);
        assert_eq!(
            common::film_totals(&film),
            common::film_totals(&one),
            "{backend:?}: one and two threads differ"
        );
        let other_seed = render_film(&blend, backend, size, spp, 8, 2);
        assert_ne!(common::film_totals(&film), common::film_totals(&other_seed));
    }
}

/// The centre of checker texel (tx, ty) on the cut-out (z = 0).
fn texel_centre(tx: u32, ty: u32) -> Vec3 {
    let step = 2.0 / CHECKER as f32;
    Vec3::new(
        -1.0 + step * (tx as f32 + 0.5),
        1.0 - step * (ty as f32 + 0.5),
        0.0,
    )
}

/// Shadow rays (any hit within a bounded extent) and closest hits see the holes the camera
/// sees, one ray at a time and in packets (Embree's 8- and 16-wide queries run the filter on
/// packets), on a scene with the emitter and on the cut-out alone (every triangle
/// alpha-tested), with Embree's quads and without.
#[test]
fn shadow_rays_and_packets_honour_mask_coverage() {
    let dir = tempfile::tempdir().unwrap();
    let with_emitter = cutout_scene(
        dir.path(),
        "mask.gltf",
        cutout_material("MASK", None, 1.0, true),
    );
    let alone = {
        let doc = gltf(
            &[Square {
                z: 0.0,
                half: 1.0,
                material: 0,
            }],
            vec![cutout_material("MASK", None, 1.0, true)],
        );
        let path = dir.path().join("alone.gltf");
        std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
        path
    };
    for path in [&with_emitter, &alone] {
        let scene = load(path);
        let emitter = scene.triangles.len() > 2;
        for (backend, quads) in [
            (Backend::Embree, true),
            (Backend::Embree, false),
            (Backend::Obvhs, true),
        ] {
            let accel = Accel::build(
                &scene,
                &AccelOptions {
                    backend,
                    quads,
                    ..Default::default()
                },
            )
            .unwrap();
            assert_eq!(accel.alpha_tested_triangles(), 2);
            if let Some(e) = accel.as_embree() {
                // The cut-out's two triangles pair into one quad behind the filter.
                assert_eq!(e.uses_quads(), quads, "{}", e.describe());
            }
            let what = format!("{backend:?}, quads {quads}, {}", path.display());
            let mut rays = Vec::new();
            let mut covered = Vec::new();
            for ty in 0..CHECKER {
                for tx in 0..CHECKER {
                    let p = texel_centre(tx, ty);
                    // A shadow ray from above the cut-out to a point between it and the
                    // emitter: blocked only by a square.
                    let mut shadow = Ray::new(p + Vec3::Z * 0.5, -Vec3::Z);
                    shadow.t_max = 1.0;
                    let opaque = opaque_texel(tx, ty);
                    assert_eq!(
                        accel.occluded(&shadow),
                        opaque,
                        "{what}: texel ({tx}, {ty})"
                    );
                    // Unbounded, it meets the emitter behind a hole.
                    let hit = accel.intersect(&Ray::new(p + Vec3::Z * 0.5, -Vec3::Z));
                    match (opaque, emitter) {
                        (true, _) => {
                            let h = hit.expect("a square stops the ray");
                            assert!(h.prim < 2 && (h.t - 0.5).abs() < 1e-6, "{what}: {h:?}");
                        }
                        (false, true) => {
                            let h = hit.expect("the emitter is behind the hole");
                            assert!(h.prim >= 2 && (h.t - 1.5).abs() < 1e-6, "{what}: {h:?}");
                        }
                        (false, false) => assert_eq!(hit, None, "{what}"),
                    }
                    rays.push(shadow);
                    covered.push(opaque);
                }
            }
            // The same rays in packets of 16 (any hit) and 8 (closest hit).
            for (chunk, want) in rays
                .chunks(OCCLUSION_PACKET)
                .zip(covered.chunks(OCCLUSION_PACKET))
            {
                let mut occluded = [false; OCCLUSION_PACKET];
                accel.occluded_packet(chunk, &mut occluded);
                assert_eq!(&occluded[..chunk.len()], want, "{what}: 16-wide any-hit");
                for (sub, want) in chunk.chunks(PACKET).zip(want.chunks(PACKET)) {
                    let mut occluded = [false; OCCLUSION_PACKET];
                    accel.occluded_packet(sub, &mut occluded);
                    assert_eq!(&occluded[..sub.len()], want, "{what}: 8-wide any-hit");
                    let mut hits = [None; PACKET];
                    let unbounded: Vec<Ray> = sub.iter().map(|r| Ray::new(r.org, r.dir)).collect();
                    accel.intersect_packet(&unbounded, &mut hits);
                    for (i, r) in unbounded.iter().enumerate() {
                        assert_eq!(hits[i], accel.intersect(r), "{what}: packet lane {i}");
                    }
                }
            }
        }
    }
}

/// Rays spread over the cut-out: random origins above it, directions down and slanted, all
/// of them meeting the emitter if nothing stops them.
fn rays_through_the_cutout(n: usize, seed: u64) -> Vec<Ray> {
    (0..n as u64)
        .map(|i| {
            let u = |k: u64| unit_f32(hash_words(&[seed, i, k]));
            let org = Vec3::new(2.0 * u(0) - 1.0, 2.0 * u(1) - 1.0, 1.0 + u(2));
            let target = Vec3::new(1.8 * u(3) - 0.9, 1.8 * u(4) - 0.9, 0.0);
            Ray::new(org, (target - org).normalize())
        })
        .collect()
}

/// BLEND's any-hit and closest-hit queries stop a fraction alpha of the rays (5 standard
/// errors), give one answer per ray however they are asked (alone, or in 8- and 16-wide
/// packets, as AO asks), and the same answer on both backends (the coin is a function of
/// the ray and the triangle).
#[test]
fn blend_coverage_is_one_answer_per_ray_for_every_query() {
    let dir = tempfile::tempdir().unwrap();
    let blend = cutout_scene(
        dir.path(),
        "blend.gltf",
        cutout_material("BLEND", None, 0.25, false),
    );
    let scene = load(&blend);
    let rays: Vec<Ray> = rays_through_the_cutout(20_000, 3)
        .into_iter()
        .map(|mut r| {
            r.t_max = r.org.z / -r.dir.z + 0.5; // past the cut-out, short of the emitter
            r
        })
        .collect();
    let mut answers = Vec::new();
    for backend in BACKENDS {
        let accel = build(&scene, backend);
        let single: Vec<bool> = rays.iter().map(|r| accel.occluded(r)).collect();
        let p = single.iter().filter(|&&o| o).count() as f64 / rays.len() as f64;
        let se = (0.25f64 * 0.75 / rays.len() as f64).sqrt();
        assert!(
            (p - 0.25).abs() < 5.0 * se,
            "{backend:?}: {p} of the rays occluded"
        );
        for width in [OCCLUSION_PACKET, PACKET] {
            for (chunk, want) in rays.chunks(width).zip(single.chunks(width)) {
                let mut occluded = [false; OCCLUSION_PACKET];
                accel.occluded_packet(chunk, &mut occluded);
                assert_eq!(&occluded[..chunk.len()], want, "{backend:?}, {width}-wide");
            }
        }
        // Closest hits: the cut-out where the ray was occluded, else the emitter.
        for (chunk, want) in rays.chunks(PACKET).zip(single.chunks(PACKET)) {
            let unbounded: Vec<Ray> = chunk.iter().map(|r| Ray::new(r.org, r.dir)).collect();
            let mut hits = [None; PACKET];
            accel.intersect_packet(&unbounded, &mut hits);
            for (i, r) in unbounded.iter().enumerate() {
                let single = accel.intersect(r);
                assert_eq!(
                    hits[i].map(|h| h.prim),
                    single.map(|h| h.prim),
                    "{backend:?}"
                );
                let on_cutout = single.expect("the emitter is behind").prim < 2;
                assert_eq!(on_cutout, want[i], "{backend:?}: ray {r:?}");
            }
        }
        answers.push(single);
    }
    assert_eq!(answers[0], answers[1], "the backends differ");
}

/// Both backends return the same hits (hit or miss, triangle, distance) and any-hit answers
/// on random rays through a scene of a MASK checker, a BLEND square with the checker's alpha and factor 0.6
/// (coverage 0.6 on its opaque texels) in front of an opaque emitter; and alpha changes many
/// of the answers (else the test would not mean much). A ray within rounding of a MASK
/// boundary may be answered differently (the backends' barycentrics differ in the last
/// bits): at most 1 in 10,000.
#[test]
fn backends_agree_on_an_alpha_scene() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, mask: &str, blend: &str| {
        let doc = gltf(
            &[
                Square {
                    z: 0.0,
                    half: 1.0,
                    material: 0,
                },
                Square {
                    z: -0.5,
                    half: 0.8,
                    material: 1,
                },
                Square {
                    z: -1.0,
                    half: 3.0,
                    material: 2,
                },
            ],
            vec![
                cutout_material(mask, None, 1.0, true),
                cutout_material(blend, None, 0.6, true),
                emitter_material(),
            ],
        );
        let path = dir.path().join(name);
        std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
        load(&path)
    };
    let scene = write("alpha.gltf", "MASK", "BLEND");
    let opaque = write("opaque.gltf", "OPAQUE", "OPAQUE");
    let rays = rays_through_the_cutout(50_000, 9);
    let accels: Vec<Accel> = [
        (Backend::Embree, true),
        (Backend::Embree, false),
        (Backend::Obvhs, true),
    ]
    .into_iter()
    .map(|(backend, quads)| {
        Accel::build(
            &scene,
            &AccelOptions {
                backend,
                quads,
                ..Default::default()
            },
        )
        .unwrap()
    })
    .collect();
    let reference = build(&opaque, Backend::Embree);
    let (mut mismatches, mut changed) = (0, 0);
    for ray in &rays {
        let hits: Vec<_> = accels.iter().map(|a| a.intersect(ray)).collect();
        let agree = hits.iter().all(|h| match (h, &hits[0]) {
            (Some(a), Some(b)) => a.prim == b.prim && (a.t - b.t).abs() <= 1e-5 * b.t,
            (None, None) => true,
            _ => false,
        });
        // Any hit short of the emitter (z = −1): occluded unless the closest hit is the
        // emitter; and unbounded: occluded when anything is hit.
        let mut shadow = *ray;
        shadow.t_max = (ray.org.z + 0.75) / -ray.dir.z;
        let any: Vec<bool> = accels.iter().map(|a| a.occluded(&shadow)).collect();
        let unbounded: Vec<bool> = accels.iter().map(|a| a.occluded(ray)).collect();
        let on_emitter = hits[0].is_some_and(|h| h.prim >= 4);
        if !agree || any.contains(&on_emitter) || unbounded.iter().any(|&o| o != hits[0].is_some())
        {
            if mismatches < 4 {
                eprintln!("{ray:?}: {hits:?} {any:?}");
            }
            mismatches += 1;
        }
        if reference.intersect(ray).map(|h| h.prim) != hits[0].map(|h| h.prim) {
            changed += 1;
        }
    }
    eprintln!(
        "{mismatches} mismatches, alpha changed {changed} of {} answers",
        rays.len()
    );
    assert!(mismatches * 10_000 <= rays.len(), "{mismatches} mismatches");
    assert!(
        changed * 4 > rays.len(),
        "alpha changed only {changed} answers"
    );
}

/// A scene without MASK or BLEND materials builds no coverage (nothing is decoded, no
/// filter is attached), and one whose BLEND texture is opaque everywhere neither.
#[test]
fn scenes_without_alpha_build_no_coverage() {
    let scene = load(&common::repo_path("scenes/cornell-box.gltf"));
    assert_eq!(scene.summary.alpha_tested_triangles, 0);
    for backend in BACKENDS {
        let accel = build(&scene, backend);
        assert!(accel.coverage().is_none() && accel.alpha_tested_triangles() == 0);
        assert!(!accel.describe().contains("alpha"), "{}", accel.describe());
    }
    // The flight helmet's lenses are BLEND, with alpha below 1 in their texture.
    let helmet = load(&common::repo_path("scenes/flight-helmet.gltf"));
    let lenses = helmet
        .triangle_materials
        .iter()
        .filter(|&&m| helmet.materials[m as usize].alpha_mode == AlphaMode::Blend)
        .count();
    assert!(lenses > 0);
    let accel = build(&helmet, Backend::Embree);
    assert_eq!(accel.alpha_tested_triangles(), lenses);
    assert!(
        accel.describe().contains("alpha-tested"),
        "{}",
        accel.describe()
    );
}

/// `doc` with `COLOR_0` (VEC4 float, alpha `alpha`, white) added to mesh `mesh`'s four
/// vertices.
fn with_vertex_alpha(mut doc: Value, mesh: usize, alpha: f32) -> Value {
    use base64::Engine;
    let engine = base64::engine::general_purpose::STANDARD;
    let uri = doc["buffers"][0]["uri"].as_str().unwrap().to_string();
    let mut bin = engine
        .decode(uri.split_once(";base64,").unwrap().1)
        .unwrap();
    let offset = bin.len();
    for _ in 0..4 {
        for c in [1.0f32, 1.0, 1.0, alpha] {
            bin.extend(c.to_le_bytes());
        }
    }
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": 64}));
    let view = views.len() - 1;
    let accessors = doc["accessors"].as_array_mut().unwrap();
    accessors.push(json!({"bufferView": view, "componentType": 5126, "count": 4, "type": "VEC4"}));
    let accessor = accessors.len() - 1;
    doc["meshes"][mesh]["primitives"][0]["attributes"]["COLOR_0"] = json!(accessor);
    doc["buffers"][0] = json!({"byteLength": bin.len(), "uri": common::data_uri(&bin)});
    doc
}

/// `COLOR_0`'s alpha is alpha's third factor: a BLEND cut-out whose factor is 1 and whose
/// vertices carry alpha 0.25 lets 0.75 of the emitter through, as a factor of 0.25 does; a
/// MASK one at cutoff 0.5 becomes a hole everywhere (0.4 < 0.5), and stays whole at cutoff
/// 0.3; without vertex colours the same files are opaque.
#[test]
fn vertex_color_alpha_multiplies_in() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, cutout: Value, alpha: Option<f32>| {
        let doc = cutout_doc(cutout);
        let doc = match alpha {
            Some(a) => with_vertex_alpha(doc, 0, a),
            None => doc,
        };
        let path = dir.path().join(name);
        std::fs::write(&path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
        path
    };
    let (size, spp) = (32u32, 16u32);
    let mean_red = |path: &Path, backend| {
        let film = render_film(path, backend, size, spp, 7, 2);
        let px = film.pixels();
        px.iter().map(|p| p.x as f64).sum::<f64>() / px.len() as f64 / EMITTER.x as f64
    };
    let blend = write(
        "blend.gltf",
        cutout_material("BLEND", None, 1.0, false),
        Some(0.25),
    );
    let opaque = write(
        "plain.gltf",
        cutout_material("BLEND", None, 1.0, false),
        None,
    );
    let mask_hole = write(
        "mask.gltf",
        cutout_material("MASK", Some(0.5), 1.0, false),
        Some(0.4),
    );
    let mask_whole = write(
        "mask3.gltf",
        cutout_material("MASK", Some(0.3), 1.0, false),
        Some(0.4),
    );
    let tolerance = 5.0 * (0.25f64 * 0.75 / (size * size * spp) as f64).sqrt();
    for backend in BACKENDS {
        let through = mean_red(&blend, backend);
        assert!((through - 0.75).abs() < tolerance, "{backend:?}: {through}");
        assert_eq!(mean_red(&opaque, backend), 0.0, "{backend:?}");
        assert_eq!(mean_red(&mask_hole, backend), 1.0, "{backend:?}");
        assert_eq!(mean_red(&mask_whole, backend), 0.0, "{backend:?}");
    }
    let scene = load(&blend);
    assert_eq!(scene.summary.alpha_tested_triangles, 2);
    assert_eq!(load(&opaque).summary.alpha_tested_triangles, 0);
}

/// A double-sided emitter of radiance 1 cut by alpha (`mode`, the checker texture if
/// `textured`, factor alpha `alpha`) at z = 0 filling the view, over a white diffuse floor at
/// z = −0.5 that its back face lights, rendered by direct lighting with `strategy` (one
/// bounce, black background) on `backend`; the mean radiance over the pixels that see the
/// floor through a hole of the checker (all interior pixels when untextured).
fn floor_under_cut_emitter(
    dir: &Path,
    mode: &str,
    alpha: f32,
    textured: bool,
    strategy: Strategy,
    backend: Backend,
) -> f64 {
    let cutoff = (mode == "MASK").then_some(0.5);
    let mut emitter = cutout_material(mode, cutoff, alpha, textured);
    emitter["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    emitter["doubleSided"] = json!(true);
    let floor = json!({"name": "floor", "pbrMetallicRoughness":
        {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}});
    let doc = gltf(
        &[
            Square {
                z: 0.0,
                half: 1.0,
                material: 0,
            },
            Square {
                z: -0.5,
                half: 3.0,
                material: 1,
            },
        ],
        vec![emitter, floor],
    );
    let path = dir.join(format!("cut-emitter-{mode}-{textured}.gltf"));
    std::fs::write(&path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
    let film = render_film_with(&path, backend, SIZE, 64, 5, 2, strategy);
    let pixels = film.pixels();
    let floor: Vec<f64> = interior_pixels()
        .filter(|&(_, _, opaque)| !textured || !opaque)
        .map(|(px, py, _)| f64::from(pixels[(py * SIZE + px) as usize].x))
        .collect();
    floor.iter().sum::<f64>() / floor.len() as f64
}

/// Light sampling sees an alpha-tested emitter's holes as the rays that meet it do: the floor
/// under a MASK checker emitter, and under a BLEND emitter of alpha 0.5, receives the same
/// light whether it is found by sampling the emitter or by sampling the floor's BSDF (whose
/// rays pass through the holes, or through half of a BLEND surface), and under MIS. Light
/// sampling that ignored the holes (the rule before) gave the floor about twice its light.
#[test]
fn light_sampling_sees_the_holes_of_alpha_tested_emitters() {
    let dir = tempfile::tempdir().unwrap();
    for (mode, alpha, textured) in [("MASK", 1.0, true), ("BLEND", 0.5, false)] {
        for backend in BACKENDS {
            let by_bsdf =
                floor_under_cut_emitter(dir.path(), mode, alpha, textured, Strategy::Bsdf, backend);
            assert!(
                by_bsdf > 0.05,
                "{mode} {backend:?}: the floor is dark ({by_bsdf})"
            );
            for strategy in [Strategy::Light, Strategy::Mis] {
                let other =
                    floor_under_cut_emitter(dir.path(), mode, alpha, textured, strategy, backend);
                // 64 spp over hundreds of pixels: BSDF sampling's mean is within about 1%.
                assert!(
                    (other / by_bsdf - 1.0).abs() < 0.04,
                    "{mode} {backend:?} {strategy:?}: floor {other}, by BSDF sampling {by_bsdf}"
                );
            }
        }
    }
}
