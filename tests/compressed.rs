//! Compressed and modern-format glTF (scenes/compressed/, made by gltfpack, glTF Transform,
//! cwebp and basisu: its SOURCE.md): every variant loads; its geometry is the plain model's
//! within the quantization its tool documents (positions within half a quantization step,
//! normals within the octahedral encoding's angular error, texture coordinates within a
//! step, the same triangles with the same winding); its render matches the plain model's
//! within a tolerance derived from that quantization or the texture codec's loss; decoded
//! WebP and KTX2 textures match the PNG originals within the codec's loss (PSNR); negative
//! controls (a dropped filter, a dropped attribute, swapped textures) fail those checks; and
//! corrupt or inconsistent streams are errors naming the file, never a panic.

mod common;

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use serde_json::Value;
use strata::accel::{Accel, AccelOptions};
use strata::integrators::{Integrator, PathSettings, Prepared};
use strata::render::RenderSettings;
use strata::sampling::SamplerKind;
use strata::scene::{self, ImageSource, Light, LoadOptions, Scene};
use strata::texture::{transform_uv, Encoding, Image};

fn asset(name: &str) -> PathBuf {
    common::repo_path("scenes/compressed").join(name)
}

fn load(path: &Path) -> Scene {
    scene::load(path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// Loads `bytes` as if read from `name` in scenes/compressed/ (so relative URIs resolve
/// there).
fn load_bytes(name: &str, bytes: &[u8]) -> Result<Scene, String> {
    scene::load_from_bytes(&asset(name), bytes, &LoadOptions::default()).map_err(|e| e.to_string())
}

/// A binary glTF's JSON and binary chunk.
fn split_glb(bytes: &[u8]) -> (Value, Vec<u8>) {
    let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap()) as usize;
    let json_len = word(12);
    let json: Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin_at = 20 + json_len;
    let bin = match bin_at + 8 <= bytes.len() {
        true => bytes[bin_at + 8..bin_at + 8 + word(bin_at)].to_vec(),
        false => Vec::new(),
    };
    (json, bin)
}

// ---------------------------------------------------------------------------------------
// Geometry: the same triangles, within the quantization's error.

/// Quantization of a variant, as its tool's documentation and command line say
/// (SOURCE.md): bits of positions, normals (octahedral) and texture coordinates, and
/// whether positions are floats through meshopt's EXPONENTIAL filter.
#[derive(Clone, Copy, Debug)]
struct Quantization {
    position_bits: u32,
    normal_bits: u32,
    uv_bits: u32,
    exponential_positions: bool,
}

/// gltfpack's defaults: -vp 14, -vn 8, -vt 12.
const GLTFPACK: Quantization = Quantization {
    position_bits: 14,
    normal_bits: 8,
    uv_bits: 12,
    exponential_positions: false,
};

/// glTF Transform's `draco` defaults: --quantize-position 14, --quantize-normal 10,
/// --quantize-texcoord 12.
const GLTF_TRANSFORM_DRACO: Quantization = Quantization {
    position_bits: 14,
    normal_bits: 10,
    uv_bits: 12,
    exponential_positions: false,
};

impl Quantization {
    /// The largest error of a position coordinate, for a model whose largest extent is
    /// `extent` and largest absolute coordinate `max_abs`. Integer quantization over the
    /// extent rounds to steps of extent / (2ᵇ − 1): half a step. The exponential filter
    /// stores each value as m · 2ᵉ with a b-bit signed mantissa, its exponent the smallest
    /// that holds the value: half of that 2ᵉ.
    fn position_error(&self, extent: f32, max_abs: f32) -> f32 {
        let b = self.position_bits;
        let half_step = match self.exponential_positions {
            false => 0.5 * extent / ((1u32 << b) - 1) as f32,
            true => {
                let e = (max_abs / ((1u32 << (b - 1)) - 1) as f32).log2().ceil();
                0.5 * 2f32.powf(e)
            }
        };
        // f32 rounding of the world transform (node scale × value + translation).
        half_step + 4.0 * f32::EPSILON * max_abs
    }

    /// The largest angle between a unit normal and its octahedral encoding with b-bit signed
    /// components: a component error of at most h = 1 / (2^(b−1) − 1) (one step: rounding is
    /// half of it, the margin covers the encoders' different grids) moves the unnormalized
    /// point (u, v, 1 − |u| − |v|) by at most h√6, whose length is at least 1/√3: the angle
    /// is at most 3√2 · h.
    fn normal_error(&self) -> f32 {
        let h = 1.0 / ((1u32 << (self.normal_bits - 1)) - 1) as f32;
        3.0 * std::f32::consts::SQRT_2 * h
    }

    /// The largest error of a texture coordinate over a range of `extent`: one step.
    fn uv_error(&self, extent: f32) -> f32 {
        extent / ((1u32 << self.uv_bits) - 1) as f32 + 1e-6
    }
}

/// How far a variant's geometry is from the plain model's.
#[derive(Debug, Default)]
struct Distance {
    triangles: usize,
    unmatched: usize,
    position: f32,
    normal_angle: f32,
    uv: f32,
}

/// Matches every triangle of `variant` to one of `plain` whose corners are within
/// `tolerance` per coordinate, in the same cyclic order (winding), and measures the largest
/// position, normal (angle) and base-colour texture coordinate (after the material's
/// texture transform) differences over matched corners.
fn distance(plain: &Scene, variant: &Scene, tolerance: f32) -> Distance {
    // Plain triangles by the grid cell of their centroid.
    let cell = 0.02;
    let key = |p: Vec3| (p / cell).floor().as_ivec3();
    let mut grid: std::collections::HashMap<glam::IVec3, Vec<usize>> = Default::default();
    for t in 0..plain.triangles.len() {
        let c = plain.triangle_positions(t as u32).iter().sum::<Vec3>() / 3.0;
        grid.entry(key(c)).or_default().push(t);
    }
    let uv_of = |s: &Scene, t: usize, v: u32| {
        let m = &s.materials[s.triangle_materials[t] as usize];
        let uv = s.uvs[v as usize];
        m.base_color_texture
            .as_ref()
            .map_or(uv, |r| transform_uv(r, uv))
    };
    let mut used = vec![false; plain.triangles.len()];
    let mut d = Distance {
        triangles: variant.triangles.len(),
        ..Default::default()
    };
    for t in 0..variant.triangles.len() {
        let corners = variant.triangle_positions(t as u32);
        let c = corners.iter().sum::<Vec3>() / 3.0;
        let k = key(c);
        let mut found = None;
        'search: for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let Some(list) = grid.get(&(k + glam::IVec3::new(dx, dy, dz))) else {
                        continue;
                    };
                    for &p in list {
                        if used[p] {
                            continue;
                        }
                        let pc = plain.triangle_positions(p as u32);
                        for r in 0..3 {
                            let err = (0..3)
                                .map(|i| (corners[i] - pc[(i + r) % 3]).abs().max_element())
                                .fold(0.0f32, f32::max);
                            if err <= tolerance {
                                found = Some((p, r, err));
                                break 'search;
                            }
                        }
                    }
                }
            }
        }
        let Some((p, r, err)) = found else {
            d.unmatched += 1;
            continue;
        };
        used[p] = true;
        d.position = d.position.max(err);
        for i in 0..3 {
            let vv = variant.triangles[t][i];
            let pv = plain.triangles[p][(i + r) % 3];
            let (nv, np) = (variant.normals[vv as usize], plain.normals[pv as usize]);
            let angle = nv.normalize().dot(np.normalize()).clamp(-1.0, 1.0).acos();
            d.normal_angle = d.normal_angle.max(angle);
            let duv = (uv_of(variant, t, vv) - uv_of(plain, p, pv))
                .abs()
                .max_element();
            d.uv = d.uv.max(duv);
        }
    }
    d
}

fn extent(s: &Scene) -> (f32, f32) {
    let (lo, hi) = s.bounds;
    (
        (hi - lo).max_element(),
        lo.abs().max(hi.abs()).max_element(),
    )
}

fn uv_extent(s: &Scene) -> f32 {
    let (lo, hi) = s.uvs.iter().fold((Vec2::MAX, Vec2::MIN), |(lo, hi), &u| {
        (lo.min(u), hi.max(u))
    });
    (hi - lo).max_element()
}

/// Asserts `variant` is `plain`'s geometry within `q`'s errors.
fn assert_same_geometry(name: &str, plain: &Scene, variant: &Scene, q: Quantization) {
    let (ext, max_abs) = extent(plain);
    let tol = q.position_error(ext, max_abs);
    let d = distance(plain, variant, tol);
    eprintln!(
        "{name}: {d:?} (position tolerance {tol:e}, normal {:e} rad, uv {:e})",
        q.normal_error(),
        q.uv_error(uv_extent(plain))
    );
    assert_eq!(d.triangles, plain.triangles.len(), "{name}: triangle count");
    assert_eq!(
        d.unmatched, 0,
        "{name}: triangles without a match within {tol:e}: {d:?}"
    );
    assert!(
        d.normal_angle <= q.normal_error(),
        "{name}: normals off by {} rad",
        d.normal_angle
    );
    let uv_tol = q.uv_error(uv_extent(plain));
    assert!(
        d.uv <= uv_tol,
        "{name}: texture coordinates off by {} > {uv_tol}",
        d.uv
    );
}

fn plain() -> Scene {
    load(&asset("suzanne.gltf"))
}

#[test]
fn meshopt_variants_are_the_plain_geometry_within_gltfpacks_quantization() {
    let plain = plain();
    for name in ["suzanne-meshopt.glb", "suzanne-meshopt-fallback.glb"] {
        assert_same_geometry(name, &plain, &load(&asset(name)), GLTFPACK);
    }
    let float = Quantization {
        exponential_positions: true,
        ..GLTFPACK
    };
    let name = "suzanne-meshopt-float.glb";
    assert_same_geometry(name, &plain, &load(&asset(name)), float);
}

#[test]
fn draco_variants_are_the_plain_geometry_within_gltf_transforms_quantization() {
    let plain = plain();
    for name in ["suzanne-draco.gltf", "suzanne-draco-sequential.gltf"] {
        assert_same_geometry(name, &plain, &load(&asset(name)), GLTF_TRANSFORM_DRACO);
    }
}

#[test]
fn compressed_variants_load_without_warnings_and_with_their_images() {
    for name in [
        "suzanne-meshopt.glb",
        "suzanne-meshopt-float.glb",
        "suzanne-meshopt-fallback.glb",
        "suzanne-draco.gltf",
        "suzanne-draco-sequential.gltf",
        "suzanne-webp.glb",
        "suzanne-etc1s.gltf",
        "suzanne-uastc.gltf",
        "animated-box-meshopt.glb",
    ] {
        let s = load(&asset(name));
        let unexpected: Vec<&String> = (s.load_warnings.iter())
            .filter(|w| !w.contains("animation"))
            .collect();
        assert!(unexpected.is_empty(), "{name}: {unexpected:?}");
    }
    // The textures read the extensions' images, not the PNG fallbacks.
    let etc1s = load(&asset("suzanne-etc1s.gltf"));
    let base = etc1s.materials[1].base_color_texture.as_ref().unwrap();
    assert_eq!(
        etc1s.images[base.image],
        ImageSource::File(asset("suzanne-textures/Suzanne_BaseColor_etc1s.ktx2"))
    );
    let webp = load(&asset("suzanne-webp.glb"));
    let base = webp.materials[1].base_color_texture.as_ref().unwrap();
    assert!(
        matches!(&webp.images[base.image], ImageSource::Bytes { data, mime } if data.starts_with(b"RIFF") && mime.as_deref() == Some("image/webp")),
        "{:?}",
        webp.images[base.image]
    );
}

/// A negative control of the geometry check: without the OCTAHEDRAL filter the normal view
/// is read as its raw encoding, and the normals check fails.
#[test]
fn a_dropped_octahedral_filter_fails_the_geometry_check() {
    let bytes = std::fs::read(asset("suzanne-meshopt.glb")).unwrap();
    let (mut doc, bin) = split_glb(&bytes);
    let mut dropped = 0;
    for view in doc["bufferViews"].as_array_mut().unwrap() {
        let ext = &mut view["extensions"]["EXT_meshopt_compression"];
        if ext.get("filter").and_then(Value::as_str) == Some("OCTAHEDRAL") {
            ext.as_object_mut().unwrap().remove("filter");
            dropped += 1;
        }
    }
    assert_eq!(dropped, 1);
    let variant = load_bytes("wrong-filter.glb", &common::glb(&doc, &bin)).unwrap();
    let plain = plain();
    let (ext, max_abs) = extent(&plain);
    let d = distance(&plain, &variant, GLTFPACK.position_error(ext, max_abs));
    assert_eq!(d.unmatched, 0, "positions are untouched: {d:?}");
    assert!(d.normal_angle > GLTFPACK.normal_error(), "{d:?}");
}

// ---------------------------------------------------------------------------------------
// Renders: each variant's image is the plain model's within what its quantization allows.

const WIDTH: u32 = 96;
const HEIGHT: u32 = 72;
const SPP: u32 = 32;

/// Irradiance of the directional light the renders add, and their sky's radiance.
const SUN: f32 = 3.0;
const SKY: f32 = 0.2;

/// The scene path traced from its own camera, 96 × 72 at 32 samples per pixel, lit by a
/// directional light from the upper left front (irradiance [`SUN`]) and a dim constant sky
/// ([`SKY`]): a light whose shading follows the normals (under a uniform sky alone, an
/// unoccluded diffuse surface looks the same whatever its normal).
fn render(scene: &Scene, path: &Path, seed: u64) -> Vec<Vec3> {
    let mut scene = scene.clone();
    scene.lights.push(Light::Directional {
        direction: Vec3::new(0.5, -0.6, -1.0).normalize(),
        irradiance: Vec3::splat(SUN),
    });
    scene.update_summary();
    let scene = &scene;
    let accel = Accel::build(scene, &AccelOptions::default()).unwrap();
    let integrator = Integrator::Path(PathSettings::default());
    let prepared = Prepared::new(scene, path, &integrator, Vec3::splat(SKY)).unwrap();
    let ctx = prepared.context(scene, &accel);
    let settings = RenderSettings {
        camera: scene.cameras[0].clone(),
        crop: None,
        stopping: Default::default(),
        width: WIDTH,
        height: HEIGHT,
        spp: SPP,
        seed,
        sampler: SamplerKind::Sobol,
        integrator,
        tile_size: 8,
        sample_range: None,
        min_pass_seconds: 0.0,
    };
    common::render_quietly(&ctx, &settings).film.pixels()
}

fn rmse(a: &[Vec3], b: &[Vec3]) -> f32 {
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).length_squared() as f64 / 3.0)
        .sum();
    (sum / a.len() as f64).sqrt() as f32
}

/// The plain model's render (seed 1), and the RMSE between two independent renders of it
/// (seeds 1 and 2): the Monte Carlo noise at this sample count.
struct Reference {
    image: Vec<Vec3>,
    noise: f32,
}

fn reference() -> Reference {
    let path = asset("suzanne.gltf");
    let s = load(&path);
    let image = render(&s, &path, 1);
    let other = render(&s, &path, 2);
    Reference {
        noise: rmse(&image, &other),
        image,
    }
}

/// The largest RMSE a variant's render may differ from the plain one by: `q` times the
/// radiance scale E/π + sky of a white diffuse surface facing the light, plus a quarter of
/// the noise between two independent renders (renders with one seed decorrelate where their
/// paths differ). `q` is the normals' angular error for geometry (cos θ moves by at most
/// the angle's change: |Δ(E cos θ / π)| ≤ E/π · Δθ) and the textures' relative RMS error for
/// textures (radiance is linear in the base colour).
fn tolerance(r: &Reference, q: f32) -> f32 {
    q * (SUN / std::f32::consts::PI + SKY) + 0.25 * r.noise
}

/// The relative RMS error of a texture codec whose PSNR is at least `psnr` dB.
fn texture_error(psnr: f64) -> f32 {
    10f64.powf(-psnr / 20.0) as f32
}

fn render_error(name: &str, r: &Reference, path: &Path, scene: &Scene) -> f32 {
    let e = rmse(&render(scene, path, 1), &r.image);
    eprintln!("{name}: render RMSE {e:e} (noise {:e})", r.noise);
    e
}

#[test]
fn compressed_renders_match_the_plain_render_and_negative_controls_do_not() {
    let r = reference();
    let geometry = [
        ("suzanne-meshopt.glb", GLTFPACK.normal_error()),
        ("suzanne-meshopt-float.glb", GLTFPACK.normal_error()),
        ("suzanne-meshopt-fallback.glb", GLTFPACK.normal_error()),
        ("suzanne-draco.gltf", GLTF_TRANSFORM_DRACO.normal_error()),
        (
            "suzanne-draco-sequential.gltf",
            GLTF_TRANSFORM_DRACO.normal_error(),
        ),
    ];
    let textures = [
        ("suzanne-webp.glb", texture_error(WEBP_PSNR)),
        ("suzanne-etc1s.gltf", texture_error(ETC1S_PSNR)),
        ("suzanne-uastc.gltf", texture_error(UASTC_PSNR)),
    ];
    for (name, q) in geometry.into_iter().chain(textures) {
        let path = asset(name);
        let e = render_error(name, &r, &path, &load(&path));
        let tol = tolerance(&r, q);
        assert!(e <= tol, "{name}: render RMSE {e} > {tol}");
    }

    // Negative controls, each against the tightest tolerance above it must beat.
    // 1. The meshopt normals without their OCTAHEDRAL filter.
    let bytes = std::fs::read(asset("suzanne-meshopt.glb")).unwrap();
    let (mut doc, bin) = split_glb(&bytes);
    for view in doc["bufferViews"].as_array_mut().unwrap() {
        if let Some(ext) = view["extensions"]["EXT_meshopt_compression"].as_object_mut() {
            ext.remove("filter");
        }
    }
    let s = load_bytes("wrong-filter.glb", &common::glb(&doc, &bin)).unwrap();
    let e = render_error("without the filter", &r, &asset("wrong-filter.glb"), &s);
    assert!(e > tolerance(&r, GLTFPACK.normal_error()), "{e}");

    // 2. The Draco primitive without its NORMAL attribute (shaded flat).
    let mut doc: Value =
        serde_json::from_slice(&std::fs::read(asset("suzanne-draco.gltf")).unwrap()).unwrap();
    let primitive = &mut doc["meshes"][0]["primitives"][0];
    primitive["attributes"]
        .as_object_mut()
        .unwrap()
        .remove("NORMAL");
    (primitive["extensions"]["KHR_draco_mesh_compression"]["attributes"].as_object_mut())
        .unwrap()
        .remove("NORMAL");
    // The NORMAL accessor, now used by nothing, still needs a bufferView for the gltf crate's
    // validation.
    doc["accessors"][1]["bufferView"] = 0.into();
    let s = load_bytes("no-normal.gltf", &serde_json::to_vec(&doc).unwrap()).unwrap();
    let e = render_error("without NORMAL", &r, &asset("no-normal.gltf"), &s);
    assert!(
        e > tolerance(&r, GLTF_TRANSFORM_DRACO.normal_error()),
        "{e}"
    );

    // 3. The UASTC textures swapped (base colour ↔ metallic-roughness).
    let mut doc: Value =
        serde_json::from_slice(&std::fs::read(asset("suzanne-uastc.gltf")).unwrap()).unwrap();
    let textures = doc["textures"].as_array_mut().unwrap();
    textures.swap(0, 1);
    let s = load_bytes("swapped.gltf", &serde_json::to_vec(&doc).unwrap()).unwrap();
    let e = render_error("swapped textures", &r, &asset("swapped.gltf"), &s);
    assert!(e > tolerance(&r, texture_error(ETC1S_PSNR)), "{e}");
}

/// The animated box's meshopt variant (QUATERNION rotations, EXPONENTIAL translations and
/// scales, 12-bit rotations by gltfpack's default -ar 12) poses the box where the plain file
/// does at a frame between key frames: every vertex within the rotation's quantization
/// (a 12-bit component moves a unit quaternion by at most 2 / (2¹¹ − 1), a rotation by
/// twice that, times the box's 1-unit reach) plus the positions' 14-bit step.
#[test]
fn the_meshopt_animation_poses_the_box_as_the_plain_file_does() {
    // Frame 13 at 24 frames per second, between key frames.
    let at = Some(scene::PoseTime {
        animation: 0,
        seconds: 13.0 / 24.0,
    });
    let options = LoadOptions {
        pose: at,
        ..Default::default()
    };
    let plain = scene::load(&common::repo_path("scenes/animated-box.gltf"), &options).unwrap();
    let packed = scene::load(&asset("animated-box-meshopt.glb"), &options).unwrap();
    let rest = scene::load(&asset("animated-box-meshopt.glb"), &LoadOptions::default()).unwrap();
    let (ext, max_abs) = extent(&plain);
    let rotation = 2.0 * 2.0 / ((1u32 << 11) - 1) as f32 * max_abs;
    let tol = rotation + GLTFPACK.position_error(ext, max_abs);
    let d = distance(&plain, &packed, tol);
    eprintln!("animated box: {d:?}, tolerance {tol:e}");
    assert_eq!(d.triangles, plain.triangles.len());
    assert_eq!(d.unmatched, 0, "{d:?}");
    // Negative control: the rest pose is not frame 13's.
    assert!(distance(&plain, &rest, tol).unmatched > 0);
}

// ---------------------------------------------------------------------------------------
// Textures: decoded WebP and KTX2 images are the PNGs within their codec's loss.

/// Lowest PSNR (dB, 8-bit RGB) each codec is held to on Suzanne's textures: lossy WebP at
/// quality 90, ETC1S at basisu's default quality (128), UASTC (no RDO). Typical values
/// for these codecs and settings; each is below what the files give and far above a wrong
/// image's (the negative control).
const WEBP_PSNR: f64 = 35.0;
const ETC1S_PSNR: f64 = 33.0;
const UASTC_PSNR: f64 = 45.0;

/// PSNR (dB) of `decoded` (linear encoding: the stored values) against the PNG at `png`
/// decoded by the `image` crate, over the RGB channels on the 8-bit scale.
fn psnr(decoded: &Image, png: &Path) -> f64 {
    let original = image::open(png).unwrap().to_rgba8();
    assert_eq!((decoded.width, decoded.height), original.dimensions());
    let mut sum = 0.0f64;
    for (t, p) in decoded.texels.iter().zip(original.pixels()) {
        for c in 0..3 {
            let d = (t[c] * 255.0) as f64 - p[c] as f64;
            sum += d * d;
        }
    }
    let mse = sum / (3 * decoded.texels.len()) as f64;
    10.0 * (255.0 * 255.0 / mse).log10()
}

fn decoded_textures(name: &str) -> [Image; 2] {
    let path = asset(name);
    let s = load(&path);
    let m = &s.materials[1];
    [
        m.base_color_texture.as_ref().unwrap(),
        m.metallic_roughness_texture.as_ref().unwrap(),
    ]
    .map(|t| Image::decode_as(&s.images[t.image], t.image, &path, Encoding::Linear).unwrap())
}

#[test]
fn decoded_textures_are_the_pngs_within_the_codecs_loss() {
    let pngs = [
        common::repo_path("scenes/suzanne/Suzanne_BaseColor.png"),
        common::repo_path("scenes/suzanne/Suzanne_MetallicRoughness.png"),
    ];
    for (name, least) in [
        ("suzanne-webp.glb", WEBP_PSNR),
        ("suzanne-etc1s.gltf", ETC1S_PSNR),
        ("suzanne-uastc.gltf", UASTC_PSNR),
    ] {
        let [base, mr] = decoded_textures(name);
        let (pb, pm) = (psnr(&base, &pngs[0]), psnr(&mr, &pngs[1]));
        eprintln!("{name}: base colour {pb:.2} dB, metallic-roughness {pm:.2} dB");
        assert!(
            pb >= least && pm >= least,
            "{name}: {pb:.2}, {pm:.2} dB < {least}"
        );
        // Negative control: against the other texture, far below.
        let crossed = psnr(&base, &pngs[1]);
        assert!(crossed < least - 10.0, "{name}: crossed {crossed:.2} dB");
    }
}

/// The same texture decoded upside down (a KTX2 transcoder that ignored orientation, say)
/// would fail the PSNR check: the check can tell.
#[test]
fn a_flipped_texture_fails_the_psnr_check() {
    let [base, _] = decoded_textures("suzanne-uastc.gltf");
    let (w, h) = (base.width as usize, base.height as usize);
    let flipped = Image {
        texels: (0..h)
            .flat_map(|y| base.texels[(h - 1 - y) * w..(h - y) * w].to_vec())
            .collect(),
        ..base.clone()
    };
    let png = common::repo_path("scenes/suzanne/Suzanne_BaseColor.png");
    assert!(psnr(&base, &png) >= UASTC_PSNR);
    // Below even the loosest codec's threshold.
    let flipped = psnr(&flipped, &png);
    assert!(flipped < ETC1S_PSNR.min(WEBP_PSNR) - 3.0, "{flipped:.2} dB");
}

// ---------------------------------------------------------------------------------------
// Corrupt and inconsistent streams: one-line errors naming the file, never a panic.

/// Asserts loading `bytes` as `name` fails with one line naming the file and every word.
fn assert_refused(name: &str, bytes: &[u8], words: &[&str]) {
    let err = match load_bytes(name, bytes) {
        Ok(_) => panic!("{name}: loaded, but should be refused for {words:?}"),
        Err(e) => e,
    };
    assert!(
        err.contains(name),
        "{name}: the error does not name the file: {err}"
    );
    assert!(!err.contains('\n'), "{name}: more than one line: {err}");
    for w in words {
        assert!(err.contains(w), "{name}: the error should say {w:?}: {err}");
    }
}

/// suzanne-meshopt.glb's JSON and binary chunk, edited by `edit`, as a .glb again.
fn edited_meshopt(edit: impl Fn(&mut Value, &mut Vec<u8>)) -> Vec<u8> {
    let (mut doc, mut bin) = split_glb(&std::fs::read(asset("suzanne-meshopt.glb")).unwrap());
    edit(&mut doc, &mut bin);
    common::glb(&doc, &bin)
}

fn meshopt_ext(doc: &mut Value, view: usize) -> &mut Value {
    &mut doc["bufferViews"][view]["extensions"]["EXT_meshopt_compression"]
}

/// The view of suzanne-meshopt.glb with the given mode and filter.
fn meshopt_view(mode: &str, filter: Option<&str>) -> usize {
    let (doc, _) = split_glb(&std::fs::read(asset("suzanne-meshopt.glb")).unwrap());
    (doc["bufferViews"].as_array().unwrap().iter())
        .position(|v| {
            let e = &v["extensions"]["EXT_meshopt_compression"];
            e["mode"] == mode && e.get("filter").and_then(Value::as_str) == filter
        })
        .unwrap()
}

#[test]
fn corrupt_or_inconsistent_meshopt_views_are_errors_naming_the_file_and_the_view() {
    let positions = meshopt_view("ATTRIBUTES", None);
    let normals = meshopt_view("ATTRIBUTES", Some("OCTAHEDRAL"));
    let indices = meshopt_view("TRIANGLES", None);
    let at = |doc: &Value, view: usize| {
        doc["bufferViews"][view]["extensions"]["EXT_meshopt_compression"]["byteOffset"]
            .as_u64()
            .unwrap() as usize
    };
    let p = format!("bufferView {positions} EXT_meshopt_compression");
    let i = format!("bufferView {indices} EXT_meshopt_compression");
    let n = format!("bufferView {normals} EXT_meshopt_compression");
    let cases: Vec<(&str, Vec<u8>, Vec<&str>)> = vec![
        (
            "truncated-stream.glb",
            edited_meshopt(|d, _| {
                let len = meshopt_ext(d, positions)["byteLength"].as_u64().unwrap();
                meshopt_ext(d, positions)["byteLength"] = (len / 2).into();
            }),
            vec![&p, "corrupt"],
        ),
        (
            "truncated-indices.glb",
            edited_meshopt(|d, _| {
                let len = meshopt_ext(d, indices)["byteLength"].as_u64().unwrap();
                meshopt_ext(d, indices)["byteLength"] = (len / 3).into();
            }),
            vec![&i, "corrupt"],
        ),
        (
            "bad-header.glb",
            edited_meshopt(|d, b| b[at(d, positions)] = 0x55),
            vec![&p, "header byte 0x55"],
        ),
        (
            "version-1.glb",
            edited_meshopt(|d, b| b[at(d, positions)] = 0xa1),
            vec![&p, "codec version 1", "does not allow"],
        ),
        (
            "unknown-filter.glb",
            edited_meshopt(|d, _| meshopt_ext(d, normals)["filter"] = "OCTAHEDRON".into()),
            vec![&n, "unknown filter \"OCTAHEDRON\""],
        ),
        (
            "unknown-mode.glb",
            edited_meshopt(|d, _| meshopt_ext(d, indices)["mode"] = "STRIPS".into()),
            vec![&i, "unknown mode \"STRIPS\""],
        ),
        (
            "past-the-buffer.glb",
            edited_meshopt(|d, _| meshopt_ext(d, positions)["byteOffset"] = 1_000_000.into()),
            vec![&p, "runs past the end of buffer 0"],
        ),
        (
            "wrong-count.glb",
            edited_meshopt(|d, _| {
                let c = meshopt_ext(d, positions)["count"].as_u64().unwrap();
                meshopt_ext(d, positions)["count"] = (c + 1).into();
            }),
            vec![&p, "is not the view's byteLength"],
        ),
        (
            "quaternion-stride.glb",
            edited_meshopt(|d, _| meshopt_ext(d, normals)["filter"] = "QUATERNION".into()),
            vec![&n, "the QUATERNION filter needs a byteStride of [8], not 4"],
        ),
        (
            "filtered-indices.glb",
            edited_meshopt(|d, _| meshopt_ext(d, indices)["filter"] = "EXPONENTIAL".into()),
            vec![&i, "allows no filter"],
        ),
        (
            "no-count.glb",
            edited_meshopt(|d, _| {
                meshopt_ext(d, positions)
                    .as_object_mut()
                    .unwrap()
                    .remove("count");
            }),
            vec![&p, "no count"],
        ),
    ];
    for (name, bytes, words) in cases {
        assert_refused(name, &bytes, &words);
    }
}

/// Fuzz-regression style: the meshopt streams with bytes flipped at 400 places spread over
/// the binary chunk, and cut short at 50 lengths, load or are refused, never panic (the
/// decoder may turn garbage into garbage; the loader's range checks catch what matters).
#[test]
fn meshopt_streams_with_flipped_bytes_never_panic() {
    let (doc, bin) = split_glb(&std::fs::read(asset("suzanne-meshopt.glb")).unwrap());
    let mut rng = common::Pcg32::new(7, 1);
    let (mut loaded, mut refused) = (0, 0);
    for _ in 0..400 {
        let mut b = bin.clone();
        let k = rng.below(b.len() as u32) as usize;
        b[k] ^= 1 << rng.below(8);
        match load_bytes("flipped.glb", &common::glb(&doc, &b)) {
            Ok(_) => loaded += 1,
            Err(e) => {
                assert!(e.contains("flipped.glb"), "{e}");
                refused += 1;
            }
        }
    }
    for k in 1..=50 {
        let b = &bin[..bin.len() * k / 51];
        let mut d = doc.clone();
        d["buffers"][0]["byteLength"] = b.len().into();
        assert!(
            load_bytes("cut.glb", &common::glb(&d, b)).is_err(),
            "cut at {}",
            b.len()
        );
    }
    eprintln!("flipped bytes: {loaded} loaded, {refused} refused");
}

/// suzanne-draco.gltf's JSON, with its buffer embedded (a data URI), edited by `edit`.
fn edited_draco(edit: impl Fn(&mut Value, &mut Vec<u8>)) -> Vec<u8> {
    let mut doc: Value =
        serde_json::from_slice(&std::fs::read(asset("suzanne-draco.gltf")).unwrap()).unwrap();
    let mut bin = std::fs::read(asset("suzanne-draco.bin")).unwrap();
    edit(&mut doc, &mut bin);
    doc["buffers"][0]["uri"] = common::data_uri(&bin).into();
    serde_json::to_vec(&doc).unwrap()
}

fn draco_ext(doc: &mut Value) -> &mut Value {
    &mut doc["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]
}

#[test]
fn corrupt_or_inconsistent_draco_streams_are_errors_naming_the_file_and_the_primitive() {
    let stream = |d: &Value| {
        let v = &d["bufferViews"][d["meshes"][0]["primitives"][0]["extensions"]
            ["KHR_draco_mesh_compression"]["bufferView"]
            .as_u64()
            .unwrap() as usize];
        let at = v["byteOffset"].as_u64().unwrap_or(0) as usize;
        (at, v["byteLength"].as_u64().unwrap() as usize)
    };
    let prim = "mesh 0 primitive 0 KHR_draco_mesh_compression";
    let cases: Vec<(&str, Vec<u8>, Vec<&str>)> = vec![
        (
            "truncated.gltf",
            edited_draco(|d, _| {
                let v = draco_ext(d)["bufferView"].as_u64().unwrap() as usize;
                let len = d["bufferViews"][v]["byteLength"].as_u64().unwrap();
                d["bufferViews"][v]["byteLength"] = (len / 2).into();
            }),
            vec![prim, "the Draco stream does not decode"],
        ),
        (
            "zeroed.gltf",
            edited_draco(|d, b| {
                let (at, len) = stream(d);
                b[at..at + len].fill(0);
            }),
            vec![prim, "does not decode"],
        ),
        (
            "missing-id.gltf",
            edited_draco(|d, _| draco_ext(d)["attributes"]["NORMAL"] = 9.into()),
            vec![prim, "NORMAL's Draco attribute id 9 is not in the stream"],
        ),
        (
            "wrong-count.gltf",
            edited_draco(|d, _| {
                let a = d["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
                    .as_u64()
                    .unwrap() as usize;
                d["accessors"][a]["count"] = 100.into();
            }),
            vec![prim, "POSITION", "count 100 is not the"],
        ),
        (
            "wrong-type.gltf",
            edited_draco(|d, _| {
                let a = d["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"]
                    .as_u64()
                    .unwrap() as usize;
                d["accessors"][a]["type"] = "VEC3".into();
            }),
            vec![
                prim,
                "TEXCOORD_0",
                "3 components per element, the stream's attribute 2",
            ],
        ),
        (
            "no-such-view.gltf",
            edited_draco(|d, _| draco_ext(d)["bufferView"] = 99.into()),
            vec![prim, "bufferView 99 does not exist"],
        ),
        (
            "points.gltf",
            edited_draco(|d, _| d["meshes"][0]["primitives"][0]["mode"] = 0.into()),
            vec![prim, "TRIANGLES or TRIANGLE_STRIP"],
        ),
        (
            "undeclared.gltf",
            edited_draco(|d, _| {
                (d["meshes"][0]["primitives"][0]["attributes"].as_object_mut())
                    .unwrap()
                    .remove("TANGENT");
                // The TANGENT accessor, now used by nothing, still needs a bufferView for
                // the gltf crate's validation.
                d["accessors"][3]["bufferView"] = 0.into();
            }),
            vec![
                prim,
                "TANGENT is compressed, but the primitive has no TANGENT",
            ],
        ),
    ];
    for (name, bytes, words) in cases {
        assert_refused(name, &bytes, &words);
    }
}

/// Fuzz-regression style: the Draco stream with bytes flipped at 300 places and cut short at
/// 40 lengths loads or is refused with an error naming the file; Draco never crashes.
#[test]
fn draco_streams_with_flipped_bytes_never_crash() {
    let doc: Value =
        serde_json::from_slice(&std::fs::read(asset("suzanne-draco.gltf")).unwrap()).unwrap();
    let bin = std::fs::read(asset("suzanne-draco.bin")).unwrap();
    let view = &doc["bufferViews"][0];
    let (at, len) = (
        view["byteOffset"].as_u64().unwrap_or(0) as usize,
        view["byteLength"].as_u64().unwrap() as usize,
    );
    let with = |b: &[u8], d: &Value| {
        let mut d = d.clone();
        d["buffers"][0]["uri"] = common::data_uri(b).into();
        serde_json::to_vec(&d).unwrap()
    };
    let mut rng = common::Pcg32::new(11, 3);
    let (mut loaded, mut refused) = (0, 0);
    for _ in 0..300 {
        let mut b = bin.clone();
        let k = at + rng.below(len as u32) as usize;
        b[k] ^= 1 << rng.below(8);
        match load_bytes("flipped.gltf", &with(&b, &doc)) {
            Ok(_) => loaded += 1,
            Err(e) => {
                assert!(e.contains("flipped.gltf"), "{e}");
                refused += 1;
            }
        }
    }
    for k in 1..=40 {
        let mut d = doc.clone();
        d["bufferViews"][0]["byteLength"] = (len * k / 41).into();
        let e = load_bytes("cut.gltf", &with(&bin, &d)).expect_err("a cut stream");
        assert!(e.contains("cut.gltf") && e.contains("Draco"), "{e}");
    }
    eprintln!("flipped bytes: {loaded} loaded, {refused} refused");
}

fn uastc_base_colour() -> Vec<u8> {
    std::fs::read(asset("suzanne-textures/Suzanne_BaseColor_uastc_zstd.ktx2")).unwrap()
}

#[test]
fn corrupt_ktx2_and_webp_images_are_errors_naming_the_scene_and_the_image() {
    let scene = asset("suzanne-uastc.gltf");
    let decode = |data: Vec<u8>| {
        let source = ImageSource::Bytes {
            data: data.into(),
            mime: None,
        };
        Image::decode(&source, 3, &scene)
    };
    let ktx2 = uastc_base_colour();
    for (what, data, words) in [
        ("cut", ktx2[..ktx2.len() / 2].to_vec(), "KTX2"),
        ("header only", ktx2[..80].to_vec(), "KTX2"),
        ("identifier only", ktx2[..12].to_vec(), "KTX2"),
    ] {
        let e = decode(data).expect_err(what);
        assert!(
            e.contains("suzanne-uastc.gltf") && e.contains("embedded image 3") && e.contains(words),
            "{what}: {e}"
        );
    }
    let webp = {
        let (doc, bin) = split_glb(&std::fs::read(asset("suzanne-webp.glb")).unwrap());
        let v = &doc["bufferViews"][doc["images"][0]["bufferView"].as_u64().unwrap() as usize];
        let at = v["byteOffset"].as_u64().unwrap_or(0) as usize;
        bin[at..at + v["byteLength"].as_u64().unwrap() as usize].to_vec()
    };
    assert!(decode(webp.clone()).is_ok());
    let e = decode(webp[..webp.len() / 3].to_vec()).expect_err("a cut WebP");
    assert!(e.contains("embedded image 3"), "{e}");

    // A file: the error names the image file.
    let dir = tempfile::tempdir().unwrap();
    let cut = dir.path().join("cut.ktx2");
    std::fs::write(&cut, &ktx2[..ktx2.len() / 2]).unwrap();
    let e = Image::decode(&ImageSource::File(cut.clone()), 0, &scene).unwrap_err();
    assert!(
        e.contains("suzanne-uastc.gltf") && e.contains(cut.to_str().unwrap()),
        "{e}"
    );
}

/// The command line: a scene whose KTX2 texture is cut short renders without it, with a
/// warning naming the scene and the image; under `--strict` it renders nothing and says, in
/// one line, which scene and which image.
#[test]
fn the_renderer_names_a_corrupt_ktx2_texture_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc: Value =
        serde_json::from_slice(&std::fs::read(asset("suzanne-uastc.gltf")).unwrap()).unwrap();
    // The copy's buffer and images by absolute path; the base colour cut short.
    let buffer = common::repo_path("scenes/suzanne/Suzanne.bin");
    doc["buffers"][0]["uri"] = buffer.to_str().unwrap().into();
    let ktx2 = uastc_base_colour();
    std::fs::write(dir.path().join("cut.ktx2"), &ktx2[..ktx2.len() / 2]).unwrap();
    for image in doc["images"].as_array_mut().unwrap() {
        let uri = image["uri"].as_str().unwrap().to_string();
        image["uri"] = match uri.contains("BaseColor") {
            true => "cut.ktx2".into(),
            false => asset(&uri).to_str().unwrap().into(),
        };
    }
    std::fs::write(
        dir.path().join("scene.gltf"),
        serde_json::to_vec(&doc).unwrap(),
    )
    .unwrap();
    let args = [
        "scene.gltf",
        "--spp",
        "1",
        "--resolution",
        "8x6",
        "--no-png",
    ];
    let run = common::render(dir.path(), &args);
    run.assert_success();
    let warned = (run.stderr.lines()).any(|l| {
        ["warning: scene.gltf", "cut.ktx2", "KTX2", "as if absent"]
            .iter()
            .all(|w| l.contains(w))
    });
    assert!(warned, "{}", run.stderr);
    std::fs::remove_file(dir.path().join("scene.exr")).unwrap();

    let run = common::render(dir.path(), &[&args[..], &["--strict"]].concat());
    assert!(!run.status.success());
    assert!(!dir.path().join("scene.exr").exists());
    // A note on the lighting may come first; the error is one line.
    let stderr: String = (run.stderr.lines())
        .filter(|l| !l.starts_with("note:"))
        .map(|l| format!("{l}\n"))
        .collect();
    common::assert_one_error_line(&stderr, &["scene.gltf", "cut.ktx2", "KTX2"]);
}

/// Fuzz-regression style: KTX2 files (ETC1S and UASTC with Zstandard) with bytes flipped at
/// 120 places each decode or are refused, never crash; cut at 40 lengths, they are refused.
#[test]
fn ktx2_files_with_flipped_bytes_never_crash() {
    let scene = asset("suzanne-etc1s.gltf");
    for file in [
        "suzanne-textures/Suzanne_BaseColor_etc1s.ktx2",
        "suzanne-textures/Suzanne_BaseColor_uastc_zstd.ktx2",
    ] {
        let bytes = std::fs::read(asset(file)).unwrap();
        let decode = |data: Vec<u8>| {
            let source = ImageSource::Bytes {
                data: data.into(),
                mime: None,
            };
            Image::decode(&source, 0, &scene)
        };
        let mut rng = common::Pcg32::new(5, 9);
        let (mut decoded, mut refused) = (0, 0);
        for _ in 0..120 {
            let mut b = bytes.clone();
            // Half in the first 512 bytes (header, level index, descriptors, global data).
            let k = match rng.below(2) {
                0 => rng.below(512) as usize,
                _ => rng.below(b.len() as u32) as usize,
            };
            b[k] ^= 1 << rng.below(8);
            match decode(b) {
                Ok(_) => decoded += 1,
                Err(_) => refused += 1,
            }
        }
        for k in 1..=40 {
            assert!(
                decode(bytes[..bytes.len() * k / 41].to_vec()).is_err(),
                "{file} cut"
            );
        }
        eprintln!("{file}: flipped bytes: {decoded} decoded, {refused} refused");
    }
}

// ---------------------------------------------------------------------------------------
// KHR_meshopt_compression: what gltfpack 1.3 does not write (version 1 of the vertex codec,
// the COLOR filter, INDICES mode), encoded here by meshoptimizer's own encoders.

/// A quad (two triangles) whose positions (floats, vertex codec version 1), colours (RGBA8
/// through the COLOR filter, version 1) and indices (INDICES mode, 16-bit) are compressed
/// under `extension`, in a .glb whose buffer 1 is the URI-less fallback placeholder.
fn khr_meshopt_quad(extension: &str, colours: &[[f32; 4]; 4]) -> Vec<u8> {
    use meshopt::encoding as enc;
    let positions: [[f32; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]];
    let indices: [u32; 6] = [0, 1, 2, 0, 2, 3];
    let pos = enc::encode_vertex_buffer_level(&positions, 2, Some(1)).unwrap();
    let filtered: Vec<[u8; 4]> = enc::encode_filter_color(colours, 8);
    let col = enc::encode_vertex_buffer_level(&filtered, 2, Some(1)).unwrap();
    let idx = enc::encode_index_sequence(&indices, 4).unwrap();
    let mut bin = Vec::new();
    let mut place = |bytes: &[u8]| {
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        bin.extend_from_slice(bytes);
        (bin.len() - bytes.len(), bytes.len())
    };
    let (p, c, i) = (place(&pos), place(&col), place(&idx));
    let view = |offset: usize,
                len: usize,
                (at, n): (usize, usize),
                stride: usize,
                count: usize,
                mode: &str,
                filter: &str| {
        serde_json::json!({
            "buffer": 1, "byteOffset": offset, "byteLength": len,
            "extensions": { extension: {
                "buffer": 0, "byteOffset": at, "byteLength": n, "byteStride": stride,
                "count": count, "mode": mode, "filter": filter,
            }},
        })
    };
    let doc = serde_json::json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": [extension],
        "extensionsRequired": [extension],
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0, "COLOR_0": 1 }, "indices": 2 }] }],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
              "min": [0, 0, 0], "max": [1, 1, 0] },
            { "bufferView": 1, "componentType": 5121, "normalized": true, "count": 4, "type": "VEC4" },
            { "bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR" },
        ],
        "bufferViews": [
            view(0, 48, p, 12, 4, "ATTRIBUTES", "NONE"),
            view(48, 16, c, 4, 4, "ATTRIBUTES", "COLOR"),
            view(64, 12, i, 2, 6, "INDICES", "NONE"),
        ],
        "buffers": [
            { "byteLength": bin.len() },
            { "byteLength": 76, "extensions": { extension: { "fallback": true } } },
        ],
    });
    common::glb(&doc, &bin)
}

const QUAD_COLOURS: [[f32; 4]; 4] = [
    [1.0, 0.0, 0.0, 1.0],
    [0.2, 0.6, 0.1, 0.5],
    [0.9, 0.8, 0.05, 0.25],
    [0.0, 0.3, 1.0, 0.75],
];

#[test]
fn khr_meshopt_decodes_version_1_the_color_filter_and_indices_mode() {
    let s = load_bytes(
        "quad.glb",
        &khr_meshopt_quad("KHR_meshopt_compression", &QUAD_COLOURS),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    // Positions and indices are exact (lossless codecs); the quad's two triangles.
    assert_eq!(s.triangles.len(), 2);
    let mut corners: Vec<[i32; 3]> = (s.triangles.iter().flatten())
        .map(|&v| (s.positions[v as usize]).to_array().map(|c| c as i32))
        .collect();
    corners.sort();
    corners.dedup();
    assert_eq!(corners, vec![[0, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0]]);
    // Colours within the COLOR filter's 8-bit YCoCg quantization (alpha 7 bits): 3/255 and
    // 2/127, against the colours given to the encoder.
    let corner_of = |p: Vec3| match (p.x as i32, p.y as i32) {
        (0, 0) => 0,
        (1, 0) => 1,
        (1, 1) => 2,
        _ => 3,
    };
    for (p, c) in s.positions.iter().zip(&s.colors) {
        let want = glam::Vec4::from_array(QUAD_COLOURS[corner_of(*p)]);
        let d = (*c - want).abs();
        assert!(
            d.x.max(d.y).max(d.z) <= 3.0 / 255.0 && d.w <= 2.0 / 127.0,
            "{c} vs {want}"
        );
    }
    // Negative control: other colours give other results.
    let other = [[0.5; 4]; 4];
    let t = load_bytes(
        "quad.glb",
        &khr_meshopt_quad("KHR_meshopt_compression", &other),
    )
    .unwrap();
    assert!(t
        .colors
        .iter()
        .all(|c| (*c - glam::Vec4::splat(0.5)).abs().max_element() <= 3.0 / 255.0));

    // EXT_meshopt_compression allows neither version 1 nor COLOR.
    let e = load_bytes(
        "ext.glb",
        &khr_meshopt_quad("EXT_meshopt_compression", &QUAD_COLOURS),
    )
    .unwrap_err();
    assert!(
        e.contains("ext.glb") && e.contains("EXT_meshopt_compression"),
        "{e}"
    );
    assert!(
        e.contains("codec version 1") || e.contains("unknown filter \"COLOR\""),
        "{e}"
    );
}

/// gltfpack's EXT_ file with the extension renamed KHR_ (the same bitstream, which KHR_
/// allows) loads to the same geometry.
#[test]
fn a_meshopt_file_under_khr_meshopt_compression_loads_as_under_ext() {
    let bytes = std::fs::read(asset("suzanne-meshopt.glb")).unwrap();
    let (doc, bin) = split_glb(&bytes);
    let text = serde_json::to_string(&doc)
        .unwrap()
        .replace("EXT_meshopt_compression", "KHR_meshopt_compression");
    let khr = load_bytes(
        "khr.glb",
        &common::glb(&serde_json::from_str(&text).unwrap(), &bin),
    )
    .unwrap();
    let ext = load(&asset("suzanne-meshopt.glb"));
    assert_eq!(
        (khr.positions, khr.normals, khr.triangles),
        (ext.positions, ext.normals, ext.triangles)
    );
}

// ---------------------------------------------------------------------------------------
// Which image a texture reads.

#[test]
fn a_texture_reads_webp_before_ktx2_before_its_fallback_and_bad_sources_are_refused() {
    let doc: Value =
        serde_json::from_slice(&std::fs::read(asset("suzanne-etc1s.gltf")).unwrap()).unwrap();
    let edited = |edit: &dyn Fn(&mut Value)| {
        let mut d = doc.clone();
        edit(&mut d);
        serde_json::to_vec(&d).unwrap()
    };
    // Both extensions on texture 0: the WebP image (suzanne-webp.glb's, as a data URI).
    let webp_bytes = {
        let (d, bin) = split_glb(&std::fs::read(asset("suzanne-webp.glb")).unwrap());
        let v = &d["bufferViews"][d["images"][0]["bufferView"].as_u64().unwrap() as usize];
        let at = v["byteOffset"].as_u64().unwrap_or(0) as usize;
        bin[at..at + v["byteLength"].as_u64().unwrap() as usize].to_vec()
    };
    let both = edited(&|d| {
        let webp = d["images"].as_array().unwrap().len();
        let uri = common::data_uri(&webp_bytes);
        (d["images"].as_array_mut().unwrap())
            .push(serde_json::json!({ "uri": uri, "mimeType": "image/webp" }));
        d["textures"][0]["extensions"]["EXT_texture_webp"] = serde_json::json!({ "source": webp });
    });
    let s = load_bytes("both.gltf", &both).unwrap();
    let t = s.materials[1].base_color_texture.as_ref().unwrap();
    assert!(
        matches!(&s.images[t.image], ImageSource::Bytes { data, .. } if data[..] == webp_bytes[..]),
        "{:?}",
        s.images[t.image]
    );
    // Without the extensions: the core source, the PNG fallback.
    let plain = edited(&|d| {
        for t in d["textures"].as_array_mut().unwrap() {
            t.as_object_mut().unwrap().remove("extensions");
        }
    });
    let s = load_bytes("fallback.gltf", &plain).unwrap();
    let t = s.materials[1].base_color_texture.as_ref().unwrap();
    assert_eq!(
        s.images[t.image],
        ImageSource::File(asset("../suzanne/Suzanne_BaseColor.png"))
    );
    // An extension naming an image the file does not have, or none.
    let missing = edited(&|d| {
        d["textures"][1]["extensions"]["KHR_texture_basisu"]["source"] = 9.into();
    });
    assert_refused(
        "missing.gltf",
        &missing,
        &["texture 1: KHR_texture_basisu names image 9, but the file has 4 image(s)"],
    );
    let none = edited(&|d| {
        d["textures"][0]["extensions"]["KHR_texture_basisu"] = serde_json::json!({});
    });
    assert_refused(
        "none.gltf",
        &none,
        &["texture 0: KHR_texture_basisu has no source"],
    );
}
