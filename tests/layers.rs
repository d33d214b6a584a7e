//! The layers over the glTF BRDF, `KHR_materials_clearcoat` and `KHR_materials_sheen`
//! (`strata::shading::layers`):
//!
//! 1. χ² goodness of fit of the sampled directions against `pdf` over the sphere: coats rough
//!    and smooth, tilted by their own normal, sheens rough and at the smallest roughness,
//!    both together, at normal and grazing views; Bonferroni-corrected at 1%; with negative
//!    controls the same test must reject (the base's pdf alone, the coat's normal untilted,
//!    the coat's roughness wrong);
//! 2. values against the extensions' formulas written again here in f64 (GGX and Smith for
//!    the coat, Conty Estevez & Kulla's Charlie lobe and Λ fit for the sheen);
//! 3. energy: the albedo a sampled estimate gives, a white base under a coat returning all
//!    the light with energy compensation, a sheen never adding any;
//! 4. through the renderer: a coated white sphere in a white furnace, and a negative control
//!    without energy compensation;
//! 5. loading: the extensions' values and textures read, bad values refused naming the
//!    material, no warning that they are ignored.

mod common;

use std::f64::consts::PI;

use common::sphere_chi2::{direction, sphere_chi2};
use common::{outward_sphere, perspective_camera, render_under_white_sky, write_mesh_scene, Pcg32};
use glam::{DVec3, Vec2, Vec3};
use serde_json::json;
use strata::sampling::chi2::Chi2Outcome;
use strata::scene::{load, LoadOptions};
use strata::shading::layers::{directional_albedo, SheenTable};
use strata::shading::{BsdfSample, Coat, GltfBrdf, Layered, LocalBsdf, Sheen};

/// The χ² tests of correct sampling below.
const CHI2_RUNS: usize = 6;
const CHI2_ALPHA: f64 = 0.01 / CHI2_RUNS as f64;

fn wo_at(theta: f64) -> Vec3 {
    direction(theta, 0.4)
}

/// The cases: a name, the BSDF and the polar angle of wo.
fn cases() -> Vec<(&'static str, Layered, f64)> {
    let tilted = Vec3::new(0.3, 0.1, 1.0).normalize();
    vec![
        (
            "rough coat over a rough dielectric",
            Layered::new(
                GltfBrdf::new(Vec3::new(0.6, 0.3, 0.2), 0.0, 0.5),
                None,
                Some(Coat::new(1.0, 0.3, Vec3::Z)),
            ),
            0.4,
        ),
        (
            "tilted rough coat over a metal",
            Layered::new(
                GltfBrdf::new(Vec3::new(0.9, 0.6, 0.3), 1.0, 0.4),
                None,
                Some(Coat::new(1.0, 0.45, tilted)),
            ),
            0.9,
        ),
        (
            "sheen over a rough dielectric",
            Layered::new(
                GltfBrdf::new(Vec3::new(0.2, 0.2, 0.6), 0.0, 0.8),
                Some(Sheen::new(Vec3::new(0.9, 0.7, 0.5), 0.4)),
                None,
            ),
            0.3,
        ),
        (
            "sheen and a rough half coat, grazing",
            Layered::new(
                GltfBrdf::new(Vec3::new(0.5, 0.5, 0.5), 0.3, 0.6),
                Some(Sheen::new(Vec3::new(1.0, 1.0, 1.0), 0.9)),
                Some(Coat::new(0.5, 0.4, Vec3::Z)),
            ),
            1.3,
        ),
        (
            "smooth coat over a rough dielectric",
            Layered::new(
                GltfBrdf::new(Vec3::new(0.8, 0.8, 0.8), 0.0, 0.7),
                None,
                Some(Coat::new(0.8, 0.0, Vec3::Z)),
            ),
            0.6,
        ),
        (
            "the thinnest sheen",
            Layered::new(
                GltfBrdf::new(Vec3::new(0.3, 0.3, 0.3), 0.0, 1.0),
                Some(Sheen::new(Vec3::new(0.8, 0.8, 0.8), 0.0)),
                None,
            ),
            1.0,
        ),
    ]
}

fn sampler(b: Layered, wo: Vec3) -> impl Fn(&mut Pcg32) -> Option<BsdfSample> {
    move |rng: &mut Pcg32| {
        let uc = rng.next_f32();
        b.sample(wo, uc, rng.next_vec2())
    }
}

fn accepted(name: &str, r: &Result<Chi2Outcome, String>) -> bool {
    println!("{name}: {r:?}");
    matches!(r, Ok(o) if o.p_value >= CHI2_ALPHA)
}

#[test]
fn chi2_layered_sampling_matches_its_pdf() {
    let cases = cases();
    assert_eq!(cases.len(), CHI2_RUNS);
    for (k, (name, b, theta)) in cases.into_iter().enumerate() {
        let wo = wo_at(theta);
        let pdf = |wi: Vec3| b.pdf(wo, wi) as f64;
        let r = sphere_chi2(&sampler(b, wo), &pdf, 8, 500 + k as u64);
        assert!(accepted(name, &r), "{name}: {r:?}");
    }
}

#[test]
fn chi2_rejects_layered_samples_against_wrong_pdfs() {
    let cases = cases();
    let (_, coated, theta) = cases[0];
    let wo = wo_at(theta);
    // The base's pdf alone: the coat's lobe forgotten.
    let base_only = |wi: Vec3| coated.base.pdf(wo, wi) as f64;
    // The coat's roughness 0.4 for 0.3.
    let rougher = Layered::new(coated.base, None, Some(Coat::new(1.0, 0.4, Vec3::Z)));
    let wrong_alpha = |wi: Vec3| rougher.pdf(wo, wi) as f64;
    let (_, tilted, theta_t) = cases[1];
    let wo_t = wo_at(theta_t);
    // The tilted coat's pdf with its normal along the base's.
    let upright = Layered::new(tilted.base, None, Some(Coat::new(1.0, 0.45, Vec3::Z)));
    let untilted = |wi: Vec3| upright.pdf(wo_t, wi) as f64;
    type Control<'a> = (&'a str, &'a dyn Fn(Vec3) -> f64, Layered, Vec3);
    let controls: [Control; 3] = [
        ("the base's pdf alone", &base_only, coated, wo),
        ("the coat's roughness 0.4 for 0.3", &wrong_alpha, coated, wo),
        ("the coat's normal untilted", &untilted, tilted, wo_t),
    ];
    for (k, (name, pdf, b, wo)) in controls.into_iter().enumerate() {
        let r = sphere_chi2(&sampler(b, wo), pdf, 8, 600 + k as u64);
        assert!(!accepted(name, &r), "{name} accepted: {r:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// The extensions' formulas again, in f64.
// ---------------------------------------------------------------------------------------------

fn ggx_d(alpha: f64, cos_h: f64) -> f64 {
    let a2 = alpha * alpha;
    let d = cos_h * cos_h * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d)
}

/// Smith's height-correlated visibility G2 / (4 μo μi) (glTF 2.0 Appendix B).
fn smith_v(alpha: f64, mu_o: f64, mu_i: f64) -> f64 {
    let a2 = alpha * alpha;
    let lambda = |mu: f64| ((1.0 + a2 * (1.0 - mu * mu) / (mu * mu)).sqrt() - 1.0) / 2.0;
    1.0 / (1.0 + lambda(mu_o) + lambda(mu_i)) / (4.0 * mu_o * mu_i)
}

/// KHR_materials_sheen's "Sheen distribution" and "Sheen visibility" (the Charlie terms).
fn charlie_f(r: f64, mu_o: f64, mu_i: f64, cos_h: f64) -> f64 {
    let d = (2.0 + 1.0 / r) * (1.0 - cos_h * cos_h).powf(0.5 / r) / (2.0 * PI);
    let t = (1.0 - r) * (1.0 - r);
    let mix = |a: f64, b: f64| a * (1.0 - t) + b * t;
    let l = |x: f64| {
        mix(21.5473, 25.3245) / (1.0 + mix(3.82987, 3.32435) * x.powf(mix(0.19823, 0.16801)))
            + mix(-1.97760, -1.27393) * x
            + mix(-4.32054, -4.85967)
    };
    let lambda = |mu: f64| match mu < 0.5 {
        true => l(mu).exp(),
        false => (2.0 * l(0.5) - l(1.0 - mu)).exp(),
    };
    d / ((1.0 + lambda(mu_o) + lambda(mu_i)) * 4.0 * mu_o * mu_i)
}

/// A coat (weight 0.7, roughness 0.4, tilted) and a sheen over an uncompensated base: f·cos
/// at several pairs of directions against mix(base with its sheen, coat, c·Fc(wo·n_c)),
/// written from the extensions.
#[test]
fn layered_values_follow_the_extensions_formulas() {
    let n_c = Vec3::new(0.2, -0.1, 1.0).normalize();
    let base = GltfBrdf::new(Vec3::new(0.7, 0.4, 0.2), 0.2, 0.6).single_scattering();
    let (c, rc) = (0.7f64, 0.4f64);
    let (sheen_color, rs) = (DVec3::new(0.6, 0.8, 0.3), 0.5f64);
    let b = Layered::new(
        base,
        Some(Sheen::new(sheen_color.as_vec3(), rs as f32)),
        Some(Coat::new(c as f32, rc as f32, n_c)),
    );
    let table = SheenTable::get();
    let mut checked = 0;
    let pairs = [
        (0.3, 0.5, 2.5),
        (1.0, 0.2, 0.3),
        (0.1, 1.3, 3.0),
        (1.4, 1.45, 3.1),
        (1.2, 1.0, 0.1),
    ];
    let mut below_coat = 0;
    for (to, ti, dphi) in pairs {
        let (wo, wi) = (direction(to, 0.0), direction(ti, dphi));
        let (o, i, n) = (wo.as_dvec3(), wi.as_dvec3(), n_c.as_dvec3());
        // The coat: Schlick's Fresnel of IOR 1.5 at the view angle; GGX around n_c.
        let fc = 0.04 + 0.96 * (1.0 - o.dot(n)).powi(5);
        let h = (o + i).normalize();
        let alpha = rc * rc;
        // The coat is a microfacet surface above its own plane: nothing reaches a wi below it.
        below_coat += (i.dot(n) <= 0.0) as usize;
        let coat = match i.dot(n) > 0.0 {
            true => ggx_d(alpha, h.dot(n)) * smith_v(alpha, o.dot(n), i.dot(n)) * i.dot(n),
            false => 0.0,
        };
        // The sheen and the base it scales.
        let m = sheen_color.max_element();
        let scaling = (1.0 - m * table.e(wo.z, rs as f32) as f64)
            .min(1.0 - m * table.e(wi.z, rs as f32) as f64);
        let sheen = sheen_color * charlie_f(rs, o.z, i.z, h.z) * i.z;
        let below = sheen + base.eval(wo, wi).as_dvec3() * scaling;
        let expected = below * (1.0 - c * fc) + DVec3::splat(c * fc * coat);
        let got = b.eval(wo, wi).as_dvec3();
        let error = ((got - expected).abs() / expected.max(DVec3::splat(1e-6))).max_element();
        println!("θo {to} θi {ti}: {got} against {expected} ({error:.1e})");
        assert!(error < 2e-4, "θo {to} θi {ti}: {got} against {expected}");
        checked += 1;
    }
    assert_eq!((checked, below_coat), (5, 1));
}

// ---------------------------------------------------------------------------------------------
// Energy.
// ---------------------------------------------------------------------------------------------

/// ∫ f cos dωi seen from `wo`, by `n` samples.
fn sampled_albedo(b: &Layered, wo: Vec3, n: usize) -> DVec3 {
    let mut rng = Pcg32::new(3, 0x1a7e);
    let mut sum = DVec3::ZERO;
    for _ in 0..n {
        let uc = rng.next_f32();
        if let Some(s) = b.sample(wo, uc, rng.next_vec2()) {
            sum += (s.f_cos / s.pdf).as_dvec3();
        }
    }
    sum / n as f64
}

/// A white dielectric base (energy-compensated, so that it returns all the light) under a
/// coat of any roughness returns all of it too (the coat's Fresnel share c·Fc, the rest the
/// base); without compensation a rough coat loses some. A white sheen on it never adds
/// energy and takes from the base what it returns itself.
#[test]
fn a_coat_keeps_the_energy_of_a_white_base_and_a_sheen_adds_none() {
    let white = GltfBrdf::new(Vec3::ONE, 0.0, 0.5);
    for theta in [0.0, 0.6, 1.2, 1.45] {
        let wo = wo_at(theta);
        let plain = sampled_albedo(&Layered::new(white, None, None), wo, 200_000).x;
        for roughness in [0.0f32, 0.3, 0.8] {
            let coated = Layered::new(white, None, Some(Coat::new(1.0, roughness, Vec3::Z)));
            let a = sampled_albedo(&coated, wo, 200_000).x;
            println!("θ {theta} coat roughness {roughness}: {a:.4} (base alone {plain:.4})");
            assert!(
                (a - plain).abs() < 0.01,
                "θ {theta} roughness {roughness}: {a} against {plain}"
            );
            assert!(
                (a - 1.0).abs() < 0.02,
                "θ {theta} roughness {roughness}: {a}"
            );
        }
        // Control: without compensation the rough coat (and base) lose energy.
        let lossy = Layered::new(
            white.single_scattering(),
            None,
            Some(Coat::new(1.0, 0.8, Vec3::Z)),
        );
        let a = sampled_albedo(&lossy, wo, 200_000).x;
        assert!(a < 0.99, "θ {theta}: uncompensated {a}");
        for r in [0.1f32, 0.5, 1.0] {
            let sheen = Layered::new(white, Some(Sheen::new(Vec3::ONE, r)), None);
            let a = sampled_albedo(&sheen, wo, 200_000).x;
            let own = directional_albedo(wo.z.max(1e-3), r.max(0.07), 128);
            println!("θ {theta} sheen r {r}: {a:.4} (the sheen's own {own:.4})");
            assert!(a <= 1.0 + 0.01, "θ {theta} sheen {r}: {a}");
            assert!(
                a >= own - 0.01,
                "θ {theta} sheen {r}: {a} below the sheen's own {own}"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Through the renderer.
// ---------------------------------------------------------------------------------------------

fn coated_white(roughness: f32) -> serde_json::Value {
    json!({
        "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5},
        "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": roughness}}
    })
}

/// A white sphere under a coat in a white furnace returns the sky everywhere (the mean within
/// noise of 1), smooth or rough coat; without energy compensation the rough one is darker.
#[test]
fn a_coated_white_sphere_in_a_white_furnace_disappears() {
    let dir = tempfile::tempdir().unwrap();
    let (positions, triangles) = outward_sphere();
    for (name, roughness) in [("smooth.gltf", 0.0f32), ("rough.gltf", 0.6)] {
        let scene = write_mesh_scene(
            dir.path(),
            name,
            &positions,
            &triangles,
            coated_white(roughness),
            perspective_camera(),
            [0.0, 0.0, 4.0],
        );
        let px = render_under_white_sky(dir.path(), &scene, 64, "32x32", &[]);
        let mean = px.iter().flatten().map(|&v| v as f64).sum::<f64>() / (px.len() * 3) as f64;
        println!("{name}: mean {mean}");
        assert!((mean - 1.0).abs() < 5e-3, "{name}: mean {mean}");
        if roughness > 0.0 {
            let px = render_under_white_sky(
                dir.path(),
                &scene,
                64,
                "32x32",
                &["--energy-compensation", "off"],
            );
            let lossy = px.iter().flatten().map(|&v| v as f64).sum::<f64>() / (px.len() * 3) as f64;
            println!("{name} without compensation: mean {lossy}");
            // The single-scattering coat and base lose half a percent here (the base's
            // Fresnel-weighted diffuse lobe gains some of it back at grazing angles); the
            // means' noise is a few 1e-4.
            assert!(lossy < mean - 0.003, "{name}: {lossy} against {mean}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Loading.
// ---------------------------------------------------------------------------------------------

#[test]
fn the_loader_reads_clearcoat_and_sheen_and_refuses_bad_values() {
    let dir = tempfile::tempdir().unwrap();
    let (positions, triangles) = outward_sphere();
    let material = json!({
        "name": "velvet car",
        "extensions": {
            "KHR_materials_clearcoat": {"clearcoatFactor": 0.8, "clearcoatRoughnessFactor": 0.25},
            "KHR_materials_sheen": {"sheenColorFactor": [0.5, 0.25, 1.0], "sheenRoughnessFactor": 0.3}
        }
    });
    let scene = write_mesh_scene(
        dir.path(),
        "layers.gltf",
        &positions,
        &triangles,
        material,
        perspective_camera(),
        [0.0, 0.0, 4.0],
    );
    let loaded = load(&scene, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let m = (loaded.materials.iter())
        .find(|m| m.name.as_deref() == Some("velvet car"))
        .expect("the file's material");
    let coat = m.layers.clearcoat.as_ref().expect("a clear coat");
    assert_eq!((coat.factor, coat.roughness), (0.8, 0.25));
    let sheen = m.layers.sheen.as_ref().expect("a sheen");
    assert_eq!(
        (sheen.color, sheen.roughness),
        (Vec3::new(0.5, 0.25, 1.0), 0.3)
    );
    assert!(
        m.ignored_extensions.is_empty(),
        "{:?}",
        m.ignored_extensions
    );
    let warnings = [loaded.load_warnings.clone(), loaded.material_warnings()].concat();
    assert!(
        !warnings
            .iter()
            .any(|w| w.contains("clearcoat") || w.contains("sheen")),
        "{warnings:?}"
    );

    for (ext, bad, words) in [
        (
            "KHR_materials_clearcoat",
            json!({"clearcoatFactor": 1.5}),
            "clearcoatFactor 1.5 is not a number between 0 and 1",
        ),
        (
            "KHR_materials_clearcoat",
            json!({"clearcoatFactor": 1.0, "clearcoatTexture": {"index": 7}}),
            "clearcoatTexture names texture 7, which does not exist",
        ),
        (
            "KHR_materials_sheen",
            json!({"sheenColorFactor": [0.5, 2.0, 0.1]}),
            "sheenColorFactor [0.5,2.0,0.1] is not three numbers between 0 and 1",
        ),
    ] {
        let material = json!({"name": "bad", "extensions": {ext: bad}});
        let scene = write_mesh_scene(
            dir.path(),
            "bad.gltf",
            &positions,
            &triangles,
            material,
            perspective_camera(),
            [0.0, 0.0, 4.0],
        );
        let err = load(&scene, &LoadOptions::default())
            .expect_err("refused")
            .to_string();
        assert!(
            err.contains("material 0 'bad'") && err.contains(words),
            "{err}"
        );
    }
}

#[test]
fn directions_below_the_surface_get_nothing() {
    let b = cases()[3].1;
    let wo = wo_at(0.5);
    let below = Vec3::new(0.3, 0.2, -0.5).normalize();
    assert_eq!(b.eval_pdf(wo, below), (Vec3::ZERO, 0.0));
    assert_eq!(b.eval_pdf(-wo, wo), (Vec3::ZERO, 0.0));
    assert!(b.sample(-wo, 0.5, Vec2::splat(0.5)).is_none());
}

// ---------------------------------------------------------------------------------------------
// KHR_materials_specular (the dielectric layer's weight and colour, in `GltfBrdf`).
// ---------------------------------------------------------------------------------------------

/// Weight 1 and a white specular colour leave the BRDF as it was, bit for bit, compensated
/// or not, at IOR 1.5 and 1.8.
#[test]
fn a_neutral_specular_layer_changes_nothing() {
    let mut rng = Pcg32::new(5, 77);
    for ior in [1.5f32, 1.8] {
        for compensated in [true, false] {
            let mut plain = GltfBrdf::new(Vec3::new(0.7, 0.5, 0.3), 0.3, 0.45).with_ior(ior);
            if !compensated {
                plain = plain.single_scattering();
            }
            let neutral = plain.with_specular(1.0, Vec3::ONE);
            for _ in 0..200 {
                let wo = direction((rng.next_f32() * 1.5) as f64, 0.0);
                let wi = direction((rng.next_f32() * 1.5) as f64, (rng.next_f32() * 6.0) as f64);
                assert_eq!(plain.eval_pdf(wo, wi), neutral.eval_pdf(wo, wi));
                let u = rng.next_vec2();
                assert_eq!(
                    plain.sample_direction(wo, u),
                    neutral.sample_direction(wo, u)
                );
            }
        }
    }
}

/// The extension's fresnel_mix written again in f64, uncompensated: f = (1 − w max(F_c))
/// c_diff/π + w F_c D V at metallic 0, mixed with the metal's Schlick lobe by metallic.
#[test]
fn specular_values_follow_the_extensions_formula() {
    let (w, color, ior) = (0.6f64, DVec3::new(1.0, 0.5, 2.0), 1.6f64);
    let base = DVec3::new(0.4, 0.6, 0.2);
    for metallic in [0.0f64, 0.4] {
        let roughness = 0.5f64;
        let brdf = GltfBrdf::new(base.as_vec3(), metallic as f32, roughness as f32)
            .with_ior(ior as f32)
            .single_scattering()
            .with_specular(w as f32, color.as_vec3());
        for (to, ti, dphi) in [(0.2, 0.7, 2.0), (1.1, 0.4, 0.5), (0.6, 1.3, 3.0)] {
            let (wo, wi) = (direction(to, 0.0), direction(ti, dphi));
            let (o, i) = (wo.as_dvec3(), wi.as_dvec3());
            let h = (o + i).normalize();
            let m = (1.0 - o.dot(h)).powi(5);
            let f0 = (((ior - 1.0) / (ior + 1.0)).powi(2) * color).min(DVec3::ONE);
            let f_c = f0 + (DVec3::ONE - f0) * m;
            let alpha = roughness * roughness;
            let dv = ggx_d(alpha, h.z) * smith_v(alpha, o.z, i.z);
            let dielectric = (1.0 - w * f_c.max_element()) * base / PI + w * f_c * dv;
            let metal = (base + (DVec3::ONE - base) * m) * dv;
            let expected = (dielectric * (1.0 - metallic) + metal * metallic) * i.z;
            let got = brdf.eval(wo, wi).as_dvec3();
            let error = ((got - expected).abs() / expected).max_element();
            assert!(
                error < 2e-4,
                "metallic {metallic} θo {to}: {got} against {expected}"
            );
        }
    }
}

/// Energy with a coloured and weighted layer: never above 1 for a white compensated base;
/// weight 0 leaves the Lambertian lobe alone, whose albedo is the base colour.
#[test]
fn a_specular_layer_never_adds_energy() {
    for theta in [0.0, 0.7, 1.3] {
        let wo = wo_at(theta);
        for (w, color) in [(1.0f32, Vec3::splat(3.0)), (0.5, Vec3::new(2.0, 1.0, 0.2))] {
            // Compensated only: the specification's own single-scattering model gains
            // energy at grazing angles whatever the layer (1.075 here at θ 1.3; the
            // GltfBrdf documentation).
            let brdf = GltfBrdf::new(Vec3::ONE, 0.0, 0.4);
            let b = Layered::new(brdf.with_specular(w, color), None, None);
            let a = sampled_albedo(&b, wo, 200_000);
            println!("θ {theta} w {w} colour {color}: {a}");
            assert!(a.max_element() <= 1.0 + 0.005, "θ {theta} w {w}: {a}");
        }
        let matte = GltfBrdf::new(Vec3::new(0.5, 0.25, 0.75), 0.0, 0.7)
            .single_scattering()
            .with_specular(0.0, Vec3::ONE);
        let a = sampled_albedo(&Layered::new(matte, None, None), wo, 200_000);
        assert!(
            (a - DVec3::new(0.5, 0.25, 0.75)).abs().max_element() < 5e-3,
            "{a}"
        );
    }
}

#[test]
fn chi2_a_specular_layer_samples_its_pdf() {
    let brdf = GltfBrdf::new(Vec3::new(0.3, 0.5, 0.7), 0.2, 0.35)
        .with_specular(0.7, Vec3::new(2.5, 1.0, 0.5));
    let b = Layered::new(brdf, None, None);
    let wo = wo_at(0.8);
    let pdf = |wi: Vec3| b.pdf(wo, wi) as f64;
    let r = sphere_chi2(&sampler(b, wo), &pdf, 8, 700);
    assert!(matches!(r, Ok(o) if o.p_value >= 0.01), "{r:?}");
}

#[test]
fn the_loader_reads_specular_and_refuses_bad_values() {
    let dir = tempfile::tempdir().unwrap();
    let (positions, triangles) = outward_sphere();
    let write = |material| {
        write_mesh_scene(
            dir.path(),
            "specular.gltf",
            &positions,
            &triangles,
            material,
            perspective_camera(),
            [0.0, 0.0, 4.0],
        )
    };
    let scene = write(json!({
        "name": "satin",
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.3, "specularColorFactor": [1.0, 2.0, 0.5]}}
    }));
    let loaded = load(&scene, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let m = (loaded.materials.iter())
        .find(|m| m.name.as_deref() == Some("satin"))
        .expect("the file's material");
    let sp = m.layers.specular.as_ref().expect("a specular layer");
    assert_eq!((sp.factor, sp.color), (0.3, Vec3::new(1.0, 2.0, 0.5)));
    assert!(
        m.ignored_extensions.is_empty(),
        "{:?}",
        m.ignored_extensions
    );
    let scene = write(json!({
        "name": "bad",
        "extensions": {"KHR_materials_specular": {"specularFactor": -1.0}}
    }));
    let err = load(&scene, &LoadOptions::default())
        .expect_err("refused")
        .to_string();
    assert!(
        err.contains("material 0 'bad'") && err.contains("specularFactor -1"),
        "{err}"
    );
}
