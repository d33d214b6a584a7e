//! `SceneBox::misses`, the test that lets camera packets outside the scene skip traversal:
//! it must never call a ray a miss that the BVH would hit, and it must call misses the rays
//! that plainly miss.
//!
//! The scene is a box's own surface (twelve triangles on its six faces), so every hit lies on
//! the face of the box being tested: the hardest case for its rounding. Rays are aimed at
//! points on the faces, edges and corners, from near and far, at boxes near and far from the
//! origin, and checked against both backends.

use glam::{Vec2, Vec3};
use proptest::prelude::*;
use proptest::test_runner::Config;
use strata::accel::{Accel, AccelOptions, Backend, Ray, SceneBox};
use strata::scene::Scene;

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
