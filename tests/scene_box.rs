//! `SceneBox::misses`, the test that lets camera packets outside the scene skip traversal:
//! it must never call a ray a miss that the BVH would hit, and it must call misses the rays
//! that plainly miss. And `RayGenerator::film_bounds`, the rectangle of film positions
//! outside which the renderer culls whole pixel blocks: no film position whose ray hits the
//! box may lie outside it.
//!
//! The scene is a box's own surface (twelve triangles on its six faces), so every hit lies on
//! the face of the box being tested: the hardest case for its rounding. Rays are aimed at
//! points on the faces, edges and corners, from near and far, at boxes near and far from the
//! origin, and checked against both backends.

mod common;

use glam::{Mat4, Quat, Vec2, Vec3};
use proptest::prelude::*;
use proptest::test_runner::Config;
use strata::accel::{Accel, AccelOptions, Backend, Ray, SceneBox};
use strata::scene::{Camera, Projection, Scene};

/// The surface of the box [lo, hi] as twelve triangles.
fn box_scene(lo: Vec3, hi: Vec3) -> Scene {
    let corner = |i: u32| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    let positions: Vec<Vec3> = (0..8).map(corner).collect();
    // Each face as two triangles over its four corners (winding does not matter here).
    let faces = [
        [0, 2, 6, 4],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 5, 7, 6],
    ];
    let triangles: Vec<[u32; 3]> = faces
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    let mut s = Scene {
        normals: vec![Vec3::ZERO; positions.len()],
        uvs: vec![Vec2::ZERO; positions.len()],
        positions,
        triangle_materials: vec![0; triangles.len()],
        triangles,
        materials: vec![Default::default()],
        ..Default::default()
    };
    s.update_summary();
    s
}

fn accels(scene: &Scene) -> [Accel; 2] {
    [Backend::Embree, Backend::Obvhs].map(|backend| {
        Accel::build(
            scene,
            &AccelOptions {
                backend,
                ..Default::default()
            },
        )
        .expect("BVH")
    })
}

/// A point on the box's surface: `which` picks a face, an edge or a corner, `s` and `t` place
/// it on the face.
fn surface_point(lo: Vec3, hi: Vec3, which: u32, s: f32, t: f32) -> Vec3 {
    let pick = |axis: usize, bit: u32| if which & bit == 0 { lo[axis] } else { hi[axis] };
    let axis = (which % 3) as usize;
    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut p = Vec3::ZERO;
    p[axis] = pick(axis, 8);
    p[a] = lo[a] + s * (hi[a] - lo[a]);
    p[b] = lo[b] + t * (hi[b] - lo[b]);
    match (which / 3) % 3 {
        0 => {}
        1 => p[a] = pick(a, 16),
        _ => (p[a], p[b]) = (pick(a, 16), pick(b, 32)),
    }
    p
}

fn unit_vector() -> impl Strategy<Value = Vec3> {
    (-1f32..1.0, 0f32..std::f32::consts::TAU).prop_map(|(z, phi)| {
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    })
}

proptest! {
    #![proptest_config(Config { cases: 2000, ..Config::default() })]

    /// Rays aimed exactly at the surface, and nudged a hair either side of its points: none
    /// that a backend hits may be called a miss.
    #[test]
    fn no_ray_that_hits_is_called_a_miss(
        centre_exp in -3i32..6,
        size in 0.01f32..100.0,
        aspect in (0.001f32..1.0, 0.001f32..1.0),
        which in 0u32..64,
        st in (0f32..=1.0, 0f32..=1.0),
        from in unit_vector(),
        distance in prop::sample::select(vec![0.01f32, 1.0, 30.0, 1e4]),
        nudges in prop::collection::vec(unit_vector(), 8),
    ) {
        let centre = Vec3::new(1.0, -0.7, 0.4) * 10f32.powi(centre_exp);
        let half = Vec3::new(size, size * aspect.0, size * aspect.1) * 0.5;
        let (lo, hi) = (centre - half, centre + half);
        let scene = box_scene(lo, hi);
        let target = surface_point(lo, hi, which, st.0, st.1);
        let ulp = target.abs().max_element() * f32::EPSILON;
        // At least 1000 ulps away: nearer, far from the origin, the origin rounds onto the
        // target and the direction is 0/0, a ray Embree's assertions abort on.
        let org = target + from * (distance * size).max(1000.0 * ulp);
        for accel in accels(&scene) {
            let scene_box = SceneBox::new(&accel);
            for nudge in std::iter::once(Vec3::ZERO).chain(nudges.iter().map(|&n| n * 4.0 * ulp)) {
                let dir = (target + nudge - org).normalize();
                assert!(dir.is_finite(), "a degenerate test ray: {org} toward {target}");
                let ray = Ray::new(org, dir);
                if let Some(hit) = accel.intersect(&ray) {
                    prop_assert!(
                        !scene_box.misses(&ray),
                        "{ray:?} hits triangle {} at t = {}, but the box test calls it a miss",
                        hit.prim,
                        hit.t
                    );
                }
            }
        }
    }
}

#[test]
fn rays_that_plainly_miss_are_called_misses() {
    for centre in [Vec3::ZERO, Vec3::new(3e3, -2e3, 5e2)] {
        let (lo, hi) = (centre - Vec3::ONE, centre + Vec3::ONE);
        let scene_box = SceneBox::new(&accels(&box_scene(lo, hi))[0]);
        let org = centre + Vec3::new(0.0, 0.0, 10.0);
        // Pointing away, and passing 1% of the box's size outside an edge and a corner.
        let away = Ray::new(org, Vec3::Z);
        let past_edge = Ray::new(org, (centre + Vec3::new(1.02, 0.0, 1.0) - org).normalize());
        let past_corner = Ray::new(org, (centre + Vec3::new(1.02, 1.02, 1.0) - org).normalize());
        for ray in [away, past_edge, past_corner] {
            assert!(
                scene_box.misses(&ray),
                "{ray:?} should miss the box at {centre}"
            );
        }
        // Through the box, and stopping short of it.
        let through = Ray::new(org, -Vec3::Z);
        assert!(!scene_box.misses(&through));
        // A packet misses only if all its rays do.
        assert!(scene_box.misses_all(&[away, past_edge, past_corner]));
        assert!(!scene_box.misses_all(&[away, through, past_corner]));
        let short = Ray {
            t_max: 8.0,
            ..through
        };
        assert!(
            scene_box.misses(&short),
            "t_max = 8 ends 1 short of the box"
        );
    }
}

#[test]
fn rays_in_a_face_plane_are_traced_and_parallel_rays_outside_culled() {
    let scene_box = SceneBox::new(&accels(&box_scene(Vec3::ZERO, Vec3::ONE))[0]);
    // In the plane of the face x = 0, crossing it: traced (the slab's direction component is
    // 0, so its distances are infinite).
    let in_plane = Ray::new(Vec3::new(0.0, -1.0, 0.5), Vec3::Y);
    assert!(!scene_box.misses(&in_plane));
    // Parallel to the x slabs, outside them: a miss.
    let outside = Ray::new(Vec3::new(2.0, -1.0, 0.5), Vec3::Y);
    assert!(scene_box.misses(&outside));
    // A NaN direction makes NaN distances: traced, never culled.
    let nan = Ray::new(Vec3::new(0.5, 0.5, 5.0), Vec3::new(f32::NAN, 0.0, -1.0));
    assert!(!scene_box.misses(&nan));
}

#[test]
fn the_box_is_the_bvh_s_own_not_the_scene_s_field() {
    // A scene whose `bounds` were never computed (a library caller that skipped
    // `update_summary`) still gets a box around its triangles: the BVH's.
    let mut scene = box_scene(Vec3::splat(5.0), Vec3::splat(6.0));
    scene.bounds = (Vec3::ZERO, Vec3::ZERO);
    let toward = Ray::new(Vec3::new(5.3, 5.6, 20.0), -Vec3::Z);
    for accel in accels(&scene) {
        let (lo, hi) = accel.bounds();
        assert!(
            lo.cmple(Vec3::splat(5.0)).all() && hi.cmpge(Vec3::splat(6.0)).all(),
            "{}: bounds {lo} {hi}",
            accel.describe()
        );
        assert!(accel.intersect(&toward).is_some());
        assert!(
            !SceneBox::new(&accel).misses(&toward),
            "{}",
            accel.describe()
        );
    }
}

/// The camera-to-world transform of a camera at `eye` looking at `target` (its −Z toward
/// it), +Y up as far as it can be.
fn looking_at(eye: Vec3, target: Vec3) -> Mat4 {
    let z = (eye - target).normalize();
    let x = Vec3::Y.cross(z).try_normalize().unwrap_or(Vec3::X);
    let y = z.cross(x);
    Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), eye.extend(1.0))
}

/// Film position (in pixels of a `width × height` image) of world point `q` seen by `camera`,
/// from the glTF projection itself (camera space, then normalised device coordinates): not
/// from `RayGenerator`, whose inverse `film_bounds` computes. None behind the camera.
fn project(camera: &Camera, q: Vec3, (width, height): (u32, u32)) -> Option<(f32, f32)> {
    let (w, h) = (width as f64, height as f64);
    let p = camera
        .to_world
        .as_dmat4()
        .inverse()
        .transform_point3(q.as_dvec3());
    // Both projections look down −z: an orthographic camera's rays start on its z = 0 plane.
    if p.z >= 0.0 {
        return None;
    }
    let (x, y) = match camera.projection {
        Projection::Perspective { yfov } => {
            let t = (0.5 * yfov as f64).tan();
            (p.x / -p.z / (t * w / h), p.y / -p.z / t)
        }
        Projection::Orthographic { ymag } => {
            let m = ymag as f64;
            (p.x / (m * w / h), p.y / m)
        }
    };
    Some((((x + 1.0) * 0.5 * w) as f32, ((1.0 - y) * 0.5 * h) as f32))
}

proptest! {
    #![proptest_config(Config { cases: 2000, ..Config::default() })]

    /// Cameras of both projections, turned, scaled and placed near, far from or inside boxes
    /// near and far from the origin, at image sizes from 8 to 2000 pixels. Rays aimed at
    /// points on the box's faces, edges and corners (through their film positions, nudged a
    /// thousandth of a pixel), and rays through random film positions, all in the image (the
    /// rectangle speaks for those): every one that a backend hits must start from inside the
    /// rectangle. Cameras near a box see it cross their centre's plane, which the rectangle
    /// clips.
    #[test]
    fn no_film_position_whose_ray_hits_the_box_is_culled(
        centre_exp in -3i32..6,
        size in 0.01f32..100.0,
        aspect in (0.001f32..1.0, 0.001f32..1.0),
        perspective in any::<bool>(),
        fov in 0.1f32..2.8,
        turn in (0f32..6.3, -1.5f32..1.5, 0f32..6.3),
        scale in 0.5f32..4.0,
        from in unit_vector(),
        distance in prop::sample::select(vec![0.3f32, 1.0, 30.0, 1e4]),
        image in (8u32..2000, 8u32..2000),
        targets in prop::collection::vec((0u32..64, 0f32..=1.0, 0f32..=1.0), 16),
        film in prop::collection::vec((0f32..=1.0, 0f32..=1.0), 16),
    ) {
        let centre = Vec3::new(1.0, -0.7, 0.4) * 10f32.powi(centre_exp);
        let half = Vec3::new(size, size * aspect.0, size * aspect.1) * 0.5;
        let (lo, hi) = (centre - half, centre + half);
        let camera = Camera {
            name: None,
            projection: if perspective {
                Projection::Perspective { yfov: fov }
            } else {
                Projection::Orthographic { ymag: size * fov }
            },
            // Looking at the box's centre from `from`, turned about its own axes.
            to_world: looking_at(centre + from * distance * size, centre)
                * Mat4::from_scale_rotation_translation(
                    Vec3::splat(scale),
                    Quat::from_euler(glam::EulerRot::XYZ, 0.3 * turn.0, 0.3 * turn.1, 0.3 * turn.2),
                    Vec3::ZERO,
                ),
            aspect_ratio: None,
            lens: None,
        };
        prop_assume!(camera.to_world.is_finite());
        let gen = camera.ray_generator(image.0, image.1);
        let rect = gen.film_bounds(lo, hi, image.0, image.1);
        let inside = |(fx, fy): (f32, f32)| {
            rect.is_none_or(|[x0, y0, x1, y1]| (x0..=x1).contains(&fx) && (y0..=y1).contains(&fy))
        };
        let (w, h) = (image.0 as f32, image.1 as f32);
        // The rectangle speaks for film positions in the image only.
        let in_image = |(fx, fy): (f32, f32)| (0.0..=w).contains(&fx) && (0.0..=h).contains(&fy);
        let mut positions = Vec::new();
        for &(which, s, t) in &targets {
            let q = surface_point(lo, hi, which, s, t);
            let Some((fx, fy)) = project(&camera, q, image).filter(|&f| in_image(f)) else {
                continue;
            };
            // The projection is right: the ray through (fx, fy) passes through q, but for
            // rounding, of the arithmetic and of (fx, fy) to f32 (a few ulps of them, times
            // a pixel's footprint at q: large for big orthographic pixels).
            let off = |fx: f32, fy: f32| {
                let ray = gen.ray(fx, fy);
                let (o, d, q) = (ray.org.as_dvec3(), ray.dir.as_dvec3(), q.as_dvec3());
                let v = q - o;
                let scale = v.length() + q.abs().max_element() + o.abs().max_element();
                ((v - d * v.dot(d)).length(), scale)
            };
            let (miss, scale) = off(fx, fy);
            let footprint = off(fx + 1.0, fy).0 + off(fx, fy + 1.0).0;
            let tolerance = 1e-4 * scale + 1e-6 * (1.0 + fx.abs() + fy.abs()) as f64 * footprint;
            prop_assert!(miss <= tolerance, "the ray through {:?} passes {miss} from {q}", (fx, fy));
            for (dx, dy) in [(0.0, 0.0), (1e-3, 0.0), (-1e-3, 0.0), (0.0, 1e-3), (0.0, -1e-3)] {
                positions.push((fx + dx, fy + dy));
            }
        }
        positions.extend(film.iter().map(|&(u, v)| (u * w, v * h)));
        positions.retain(|&f| in_image(f));
        let scene = box_scene(lo, hi);
        for accel in accels(&scene) {
            for &f in &positions {
                let ray = gen.ray(f.0, f.1);
                prop_assume!(ray.dir.is_finite() && ray.org.is_finite());
                if let Some(hit) = accel.intersect(&ray) {
                    prop_assert!(
                        inside(f),
                        "film position {f:?} of a {}x{} image hits triangle {} at t = {}, outside {rect:?}",
                        image.0, image.1, hit.prim, hit.t
                    );
                }
            }
        }
    }
}

/// The rectangle is the box's image and a pixel more, not the whole film: a box in the middle
/// of the view culls what lies around it.
#[test]
fn the_film_rectangle_is_the_box_s_image_and_a_pixel() {
    let (lo, hi) = (Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0));
    let image = (400, 300);
    for projection in [
        Projection::Perspective { yfov: 0.8 },
        Projection::Orthographic { ymag: 5.0 },
    ] {
        let camera = Camera {
            name: None,
            projection,
            to_world: Mat4::from_translation(Vec3::new(0.3, -0.2, 10.0)),
            aspect_ratio: None,
            lens: None,
        };
        let [x0, y0, x1, y1] = camera
            .ray_generator(image.0, image.1)
            .film_bounds(lo, hi, image.0, image.1)
            .expect("a box in front of the camera has a rectangle");
        let corners: Vec<(f32, f32)> = (0..8)
            .map(|i| {
                let q = Vec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                );
                project(&camera, q, image).unwrap()
            })
            .collect();
        let min_x = corners.iter().map(|c| c.0).fold(f32::MAX, f32::min);
        let max_x = corners.iter().map(|c| c.0).fold(f32::MIN, f32::max);
        let min_y = corners.iter().map(|c| c.1).fold(f32::MAX, f32::min);
        let max_y = corners.iter().map(|c| c.1).fold(f32::MIN, f32::max);
        for (got, want) in [
            (x0, min_x - 1.0),
            (y0, min_y - 1.0),
            (x1, max_x + 1.0),
            (y1, max_y + 1.0),
        ] {
            assert!(
                (got - want).abs() < 0.01,
                "{projection:?}: rectangle {:?}, corners' images span {:?}",
                [x0, y0, x1, y1],
                [min_x, min_y, max_x, max_y]
            );
        }
        assert!((x1 - x0) * (y1 - y0) < 0.5 * (image.0 * image.1) as f32);
    }
}

/// No rectangle where a perspective camera stands inside the box (a ray from the centre meets
/// it at once, in any direction), or the camera cannot be inverted; an empty one for a box
/// behind the camera.
#[test]
fn no_rectangle_for_a_box_around_the_camera() {
    let (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
    let camera = |to_world| Camera {
        name: None,
        projection: Projection::Perspective { yfov: 0.8 },
        to_world,
        aspect_ratio: None,
        lens: None,
    };
    for to_world in [
        Mat4::IDENTITY,
        Mat4::from_translation(Vec3::new(0.0, 0.0, 0.5)),
        Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0)),
    ] {
        let rect = camera(to_world)
            .ray_generator(64, 64)
            .film_bounds(lo, hi, 64, 64);
        assert!(rect.is_none(), "{to_world:?}: {rect:?}");
    }
    // Wholly behind: an empty rectangle (no film position sees it).
    let behind = camera(Mat4::from_translation(Vec3::new(0.0, 0.0, -5.0)));
    let [x0, y0, x1, y1] = behind
        .ray_generator(64, 64)
        .film_bounds(lo, hi, 64, 64)
        .unwrap();
    assert!(x0 > x1 && y0 > y1, "{:?}", [x0, y0, x1, y1]);
}

/// Renders with block culling on and off give the same film, bit for bit, on scenes of large
/// triangles (each spanning many of the cluster grid's cells, so a cluster box that bounded
/// less than its triangles' vertices would cull visible pixels): two boxes' surfaces far
/// apart, and a long sliver between them, seen from several cameras (one between the boxes,
/// where cluster boxes cross its centre's plane, and one inside a cluster box, which turns
/// culling off), AO at 4 spp; each of the others culls some blocks.
#[test]
fn culling_by_cluster_boxes_leaves_the_image_unchanged() {
    use strata::integrators::{AoSettings, Integrator, Prepared};
    use strata::render::{self, RenderSettings};
    use strata::sampling::SamplerKind;

    let mut scene = box_scene(Vec3::new(-6.0, -1.0, -1.0), Vec3::new(-4.0, 1.0, 1.0));
    let other = box_scene(Vec3::new(4.0, 0.5, -2.0), Vec3::new(5.0, 2.5, 0.0));
    let base = scene.positions.len() as u32;
    scene.positions.extend(&other.positions);
    scene
        .triangles
        .extend(other.triangles.iter().map(|t| t.map(|i| i + base)));
    // The sliver: from one box to the other, a tenth of a unit wide.
    let base = scene.positions.len() as u32;
    scene.positions.extend([
        Vec3::new(-4.0, 0.0, 0.0),
        Vec3::new(4.0, 1.0, -1.0),
        Vec3::new(4.0, 1.1, -1.0),
    ]);
    scene.triangles.push([base, base + 1, base + 2]);
    let n = scene.positions.len();
    scene.normals = vec![Vec3::ZERO; n];
    scene.uvs = vec![Vec2::ZERO; n];
    scene.triangle_materials = vec![0; scene.triangles.len()];
    scene.update_summary();

    let accel = Accel::build(&scene, &AccelOptions::default()).expect("BVH");
    let prepared = Prepared::default();
    let middle = Vec3::new(0.0, 0.5, -0.5);
    for (eye, target, projection) in [
        (
            Vec3::new(0.0, 0.0, 30.0),
            middle,
            Projection::Perspective { yfov: 0.6 },
        ),
        (
            Vec3::new(3.0, 9.0, 14.0),
            middle,
            Projection::Perspective { yfov: 1.2 },
        ),
        (
            Vec3::new(-2.0, 1.0, 20.0),
            middle,
            Projection::Orthographic { ymag: 4.0 },
        ),
        // Inside the scene's box, between the two boxes, looking at the first: the second
        // box lies behind the camera's plane, and the sliver's box crosses it (clipped).
        (
            Vec3::new(1.0, 2.0, 1.0),
            Vec3::new(-5.0, 0.0, 0.0),
            Projection::Perspective { yfov: 1.0 },
        ),
        // Inside the sliver's cluster box: no mask, nothing culled (the sliver is seen from
        // within its own box, in directions no rectangle bounds).
        (
            Vec3::new(0.0, 0.5, -0.2),
            Vec3::new(-5.0, 0.0, 0.0),
            Projection::Perspective { yfov: 1.0 },
        ),
    ] {
        let camera = Camera {
            name: None,
            projection,
            to_world: looking_at(eye, target),
            aspect_ratio: None,
            lens: None,
        };
        let [on, off] = [true, false].map(|cull_blocks| {
            let ctx = strata::integrators::Context {
                experiments: strata::experiments::Experiments {
                    cull_blocks,
                    ..Default::default()
                },
                ..prepared.context(&scene, &accel)
            };
            let settings = RenderSettings {
                camera: camera.clone(),
                width: 150,
                height: 90,
                spp: 4,
                seed: 1,
                sampler: SamplerKind::Sobol,
                integrator: Integrator::Ao(AoSettings::default()),
                tile_size: 16,
                sample_range: None,
                min_pass_seconds: 0.0,
                crop: None,
                stopping: Default::default(),
            };
            common::render_quietly(&ctx, &settings)
        });
        let sums = |r: &render::RenderResult| -> Vec<[i128; 3]> {
            (0..r.film.height)
                .flat_map(|y| (0..r.film.width).map(move |x| (x, y)))
                .map(|(x, y)| r.film.totals(x, y).0)
                .collect()
        };
        let (a, b) = (sums(&on), sums(&off));
        let differing = a.iter().zip(&b).filter(|(p, q)| p != q).count();
        assert_eq!(differing, 0, "{eye}: {differing} pixels differ");
        assert!(a.iter().any(|p| p[0] != 0), "{eye}: nothing in view");
        let inside_a_cluster = accel
            .clusters()
            .iter()
            .any(|&(lo, hi)| eye.cmpge(lo).all() && eye.cmple(hi).all());
        assert_eq!(
            on.stats.rays.culled > off.stats.rays.culled,
            !inside_a_cluster,
            "{eye}: blocks culled, or not, inside a cluster: {inside_a_cluster}"
        );
    }
}
