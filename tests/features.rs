//! The sample record's first-hit features, summed by the film only when asked for: albedo,
//! shading normal and depth of a known floor seen from above, a sky's empty pixels, and no
//! change to the image when they are kept.

mod common;

use std::path::Path;

use glam::{Vec2, Vec3};
use strata::accel::{Accel, AccelOptions};
use strata::integrators::{AoSettings, Integrator, PathSettings, Prepared};
use strata::render::{Film, RenderSettings};
use strata::sampling::SamplerKind;
use strata::scene::{Camera, Light, Material, Scene};

const FLOOR_COLOUR: Vec3 = Vec3::new(0.2, 0.4, 0.6);

/// A 20 × 20 floor in the plane y = 0 (facing +Y) of base colour FLOOR_COLOUR, under a point
/// light.
fn floor_scene() -> Scene {
    let positions = vec![
        Vec3::new(-10.0, 0.0, -10.0),
        Vec3::new(-10.0, 0.0, 10.0),
        Vec3::new(10.0, 0.0, 10.0),
        Vec3::new(10.0, 0.0, -10.0),
    ];
    let floor = Material {
        base_color: FLOOR_COLOUR.extend(1.0),
        metallic: 0.0,
        ..Default::default()
    };
    let mut s = Scene {
        normals: vec![Vec3::ZERO; 4],
        uvs: vec![Vec2::ZERO; 4],
        positions,
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        triangle_materials: vec![1, 1],
        materials: vec![Material::default(), floor],
        lights: vec![Light::Point {
            position: Vec3::new(0.0, 3.0, 0.0),
            intensity: Vec3::splat(5.0),
            range: None,
        }],
        ..Default::default()
    };
    s.update_summary();
    s
}

fn camera(eye: Vec3, forward: Vec3, up: Vec3, yfov: f32) -> Camera {
    common::camera_looking(eye, forward, up, yfov)
}

fn render_film(scene: &Scene, camera: Camera, integrator: Integrator, features: bool) -> Film {
    let accel = Accel::build(scene, &AccelOptions::default()).unwrap();
    let prepared = Prepared::new(scene, Path::new("test"), &integrator, Vec3::ZERO).unwrap();
    let mut ctx = prepared.context(scene, &accel);
    ctx.features = features;
    let settings = RenderSettings {
        camera,
        crop: None,
        stopping: Default::default(),
        width: 24,
        height: 16,
        spp: 16,
        seed: 3,
        sampler: SamplerKind::Sobol,
        integrator,
        tile_size: 8,
        sample_range: None,
        min_pass_seconds: 0.0,
    };
    let result = common::render_quietly(&ctx, &settings);
    result.film
}

fn integrators() -> [(&'static str, Integrator); 2] {
    [
        ("ao", Integrator::Ao(AoSettings::default())),
        ("path", Integrator::Path(PathSettings::default())),
    ]
}

#[test]
fn a_floor_seen_from_above_has_its_colour_normal_and_distance() {
    let scene = floor_scene();
    // 2 units above the floor, looking straight down; a half-angle of 0.2 rad.
    let h = 2.0f32;
    let yfov = 0.4f32;
    let cam = camera(Vec3::new(0.0, h, 0.0), Vec3::NEG_Y, Vec3::Z, yfov);
    for (name, integrator) in integrators() {
        let film = render_film(&scene, cam.clone(), integrator, true);
        assert!(film.keeps_features());
        // The image's corner is at most this far off the axis (24 × 16 pixels).
        let tan_corner = (yfov / 2.0).tan() * (1.0 + (24.0f32 / 16.0).powi(2)).sqrt();
        let far = h * (1.0 + tan_corner * tan_corner).sqrt();
        for y in 0..film.height {
            for x in 0..film.width {
                let f = film.features(x, y).expect("features kept, pixel sampled");
                let albedo = if name == "ao" {
                    Vec3::ONE
                } else {
                    FLOOR_COLOUR
                };
                assert_eq!(f.albedo, albedo, "{name} ({x}, {y})");
                assert_eq!(f.normal, Vec3::Y, "{name} ({x}, {y})");
                assert_eq!(f.coverage, 1.0, "{name} ({x}, {y})");
                assert!(
                    f.depth >= h * (1.0 - 1e-5) && f.depth <= far * (1.0 + 1e-5),
                    "{name} ({x}, {y}): depth {} outside [{h}, {far}]",
                    f.depth
                );
            }
        }
        // The centre pixels look almost straight down.
        let centre = film.features(12, 8).unwrap();
        assert!((centre.depth - h).abs() < 0.01, "{name}: {}", centre.depth);
    }
}

#[test]
fn pixels_that_see_the_sky_have_no_surface() {
    let scene = floor_scene();
    // Level with the horizon: the top half of the image sees the sky, the bottom the floor.
    let cam = camera(Vec3::new(0.0, 1.0, 9.0), Vec3::NEG_Z, Vec3::Y, 0.5);
    for (name, integrator) in integrators() {
        let film = render_film(&scene, cam.clone(), integrator, true);
        let top = film.features(12, 0).unwrap();
        assert_eq!(top.coverage, 0.0, "{name}");
        assert_eq!(top.depth, f32::INFINITY, "{name}");
        assert_eq!((top.albedo, top.normal), (Vec3::ZERO, Vec3::ZERO), "{name}");
        let bottom = film.features(12, 15).unwrap();
        assert_eq!(bottom.coverage, 1.0, "{name}");
        assert!(bottom.depth.is_finite() && bottom.depth > 1.0, "{name}");
    }
}

#[test]
fn keeping_features_changes_no_pixel_and_costs_nothing_when_off() {
    let scene = floor_scene();
    let cam = camera(
        Vec3::new(0.0, 1.0, 9.0),
        Vec3::new(0.0, -0.3, -1.0),
        Vec3::Y,
        0.7,
    );
    for (name, integrator) in integrators() {
        let with = render_film(&scene, cam.clone(), integrator, true);
        let without = render_film(&scene, cam.clone(), integrator, false);
        assert_eq!(
            common::film_totals(&with),
            common::film_totals(&without),
            "{name}: the image changed when features were kept"
        );
        assert!(!without.keeps_features());
        assert_eq!(without.features(3, 3), None);
        assert!(with.features(3, 3).is_some());
    }
    // The floor's colour is what the path tracer's surfaces reflect: a sanity check that the
    // scene is lit at all.
    let lit = render_film(
        &scene,
        cam,
        Integrator::Path(PathSettings::default()),
        false,
    );
    assert!(lit.pixel(12, 15).max_element() > 0.0);
}
