//! Triangles traced as Embree quads (`accel::embree_backend`): Embree's quad parametrisation
//! as documented, the mapping of a quad hit back to the scene's triangle and its own
//! barycentrics for every vertex order of the two triangles, the pairing rule, and agreement
//! with plain triangles on real meshes.

use std::path::Path;

use glam::{Vec2, Vec3};
use strata::accel::{Accel, AccelOptions, Hit, Ray};
use strata::embree::{BuildQuality, Device, SceneBuilder, SceneOptions};
use strata::sampling::hash::{hash_words, unit_f32};
use strata::sampling::warps::square_to_uniform_sphere;
use strata::scene::{self, LoadOptions, Scene};

fn scene_of(positions: &[Vec3], triangles: &[[u32; 3]], materials: &[u32]) -> Scene {
    let mut s = Scene {
        positions: positions.to_vec(),
        normals: vec![Vec3::ZERO; positions.len()],
        uvs: vec![Vec2::ZERO; positions.len()],
        triangles: triangles.to_vec(),
        triangle_materials: materials.to_vec(),
        materials: vec![Default::default(); 2],
        ..Default::default()
    };
    s.update_summary();
    s
}

fn build(scene: &Scene, quads: bool) -> Accel {
    Accel::build(
        scene,
        &AccelOptions {
            quads,
            ..Default::default()
        },
    )
    .unwrap()
}

fn uses_quads(accel: &Accel) -> bool {
    accel.as_embree().unwrap().uses_quads()
}

/// The point a hit's triangle and barycentrics name.
fn hit_point(scene: &Scene, hit: &Hit) -> Vec3 {
    let [a, b, c] = scene.triangle_positions(hit.prim);
    (1.0 - hit.u - hit.v) * a + hit.u * b + hit.v * c
}

fn rotate(t: [u32; 3], k: usize) -> [u32; 3] {
    [t[k % 3], t[(k + 1) % 3], t[(k + 2) % 3]]
}

/// A ray onto the point `p` from `from`.
fn ray_onto(p: Vec3, from: Vec3) -> Ray {
    Ray::new(from, (p - from).normalize())
}

/// Embree's quad as `SceneBuilder::attach_quads` documents it: (v0, v1, v3) reports its
/// barycentrics, (v2, v3, v1) one minus its own, so u runs along v0 → v1 and v → v3 on the
/// first half, and u + v > 1 on the second.
#[test]
fn embree_quads_report_the_documented_coordinates() {
    // A unit square in z = 0, v0 at the origin, v1 on +x, v2 at (1, 1), v3 on +y.
    let positions = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let device = Device::new("verbose=0").unwrap();
    let mut builder = SceneBuilder::new(
        &device,
        SceneOptions {
            quality: BuildQuality::Medium,
            robust: true,
            compact: false,
        },
    )
    .unwrap();
    builder.attach_quads(&positions, &[[0, 1, 2, 3]]).unwrap();
    let scene = builder.commit().unwrap();
    for (x, y) in [
        (0.2f32, 0.3f32),
        (0.7, 0.1),
        (0.3, 0.9),
        (0.8, 0.6),
        (0.95, 0.9),
    ] {
        let hit = scene
            .intersect([x, y, 1.0], [0.0, 0.0, -1.0], 0.0, f32::INFINITY)
            .unwrap_or_else(|| panic!("({x}, {y}) missed"));
        assert_eq!(hit.prim_id, 0);
        assert!(
            (hit.u - x).abs() < 1e-6 && (hit.v - y).abs() < 1e-6,
            "({x}, {y}): u, v = {}, {}",
            hit.u,
            hit.v
        );
        // Counter-clockwise seen from +z on both halves: the normal points up.
        assert!(hit.ng[2] > 0.0, "({x}, {y}): normal {:?}", hit.ng);
    }
}

/// Two triangles of a tilted rectangle, in every vertex order of each (nine pairs), with
/// shared or duplicated corner vertices: each becomes one quad, and hits on either half come
/// back as the right triangle with its own barycentrics, and the same hit as without quads.
#[test]
fn hits_on_a_quad_come_back_as_their_triangles_in_every_vertex_order() {
    // Corners of a rectangle in a vertical plane at an angle to the axes (each triangle's
    // box is the rectangle's, so the pair qualifies; no coordinate is trivially zero).
    let (o, e1, e2) = (
        Vec3::new(0.3, -0.2, 0.1),
        Vec3::new(1.7, 0.4, 0.0),
        Vec3::new(0.0, 0.0, 1.3),
    );
    let corners = [o, o + e1, o + e1 + e2, o + e2];
    for shared in [true, false] {
        // Triangles (0, 1, 2) and (0, 2, 3): their shared edge is the diagonal 0–2.
        let (positions, first, second) = if shared {
            (corners.to_vec(), [0, 1, 2], [0, 2, 3])
        } else {
            // Split vertices (a seam): the second triangle has copies of 0 and 2.
            let mut p = corners.to_vec();
            p.extend([corners[0], corners[2]]);
            (p, [0, 1, 2], [4, 5, 3])
        };
        for (k1, k2) in (0..3).flat_map(|a| (0..3).map(move |b| (a, b))) {
            let triangles = [rotate(first, k1), rotate(second, k2)];
            let scene = scene_of(&positions, &triangles, &[0, 0]);
            let (quads, plain) = (build(&scene, true), build(&scene, false));
            assert!(uses_quads(&quads), "shared {shared}, rotations {k1} {k2}");
            assert!(!uses_quads(&plain));
            for i in 0..10 {
                for j in 0..10 {
                    // Grid points, kept off the diagonal (where either triangle may answer).
                    let (s, t) = ((i as f32 + 0.5) / 10.0, (j as f32 + 0.37) / 10.0);
                    let p = o + s * e1 + t * e2;
                    // From in front of the rectangle (on the side of e1 × e2).
                    let ray = ray_onto(p, o + 0.5 * (e1 + e2) + 3.0 * e1.cross(e2).normalize());
                    let (a, b) = (quads.intersect(&ray), plain.intersect(&ray));
                    let (Some(a), Some(b)) = (a, b) else {
                        panic!("({s}, {t}) missed: {a:?} {b:?}");
                    };
                    // Below the diagonal 0–2 (t < s) lies triangle (0, 1, 2).
                    let expected = if t < s { 0 } else { 1 };
                    assert_eq!(
                        a.prim, expected,
                        "shared {shared}, rotations {k1} {k2}, ({s}, {t})"
                    );
                    assert_eq!(a.prim, b.prim);
                    let at = hit_point(&scene, &a);
                    assert!(
                        (at - ray.at(a.t)).length() < 1e-5,
                        "shared {shared}, rotations {k1} {k2}, ({s}, {t}): {at} vs {}",
                        ray.at(a.t)
                    );
                    assert!(
                        (a.u - b.u).abs() < 1e-5 && (a.v - b.v).abs() < 1e-5,
                        "barycentrics {} {} vs {} {}",
                        a.u,
                        a.v,
                        b.u,
                        b.v
                    );
                    assert!((a.t - b.t).abs() < 1e-5 * a.t);
                    assert!(a.ng.dot(b.ng) > 0.99999, "normals {} vs {}", a.ng, b.ng);
                }
            }
        }
    }
}

/// What is not paired: triangles of different materials, a pair whose box would be much
/// larger than theirs (a fold), and meshes where under half of the triangles pair stay
/// triangles.
#[test]
fn triangles_pair_only_where_a_quad_should_pay() {
    let square = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let halves = [[0, 1, 2], [0, 2, 3]];
    assert!(uses_quads(&build(
        &scene_of(&square, &halves, &[0, 0]),
        true
    )));
    assert!(
        !uses_quads(&build(&scene_of(&square, &halves, &[0, 1]), true)),
        "materials"
    );
    // Two long thin triangles folded at a right angle along their shared long edge: the
    // pair's box is a cube's worth of area, each triangle's a flat slab's.
    let fold = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 10.0),
        Vec3::new(1.0, 0.0, 5.0),
        Vec3::new(0.0, 1.0, 5.0),
    ];
    let fold_tris = [[0, 2, 1], [0, 1, 3]];
    assert!(
        !uses_quads(&build(&scene_of(&fold, &fold_tris, &[0, 0]), true)),
        "fold"
    );
    // One pair among four triangles: half of them pair, enough; among six, not.
    let mut soup = square.to_vec();
    let mut tris = halves.to_vec();
    for k in 0..4u32 {
        let base = soup.len() as u32;
        let shift = Vec3::new(3.0 + 2.0 * k as f32, 0.0, 0.0);
        soup.extend([shift, shift + Vec3::X, shift + Vec3::Y]);
        tris.push([base, base + 1, base + 2]);
        let materials = vec![0; tris.len()];
        let paired = uses_quads(&build(&scene_of(&soup, &tris, &materials), true));
        assert_eq!(
            paired,
            tris.len() <= 4,
            "{} triangles, one pair",
            tris.len()
        );
    }
}

fn load(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    scene::load(&path, &LoadOptions::default()).unwrap()
}

/// On the bundled meshes, quads and triangles give the same answers to 100 000 random rays:
/// hit or miss, distance, triangle (but where two triangles meet the ray at the same
/// distance), and the hit point the triangle's barycentrics name.
#[test]
fn quads_and_triangles_agree_on_random_rays() {
    let mut paired = 0;
    for name in [
        "cornell-box.gltf",
        "emissive-strength.gltf",
        "flight-helmet.gltf",
        "suzanne.gltf",
    ] {
        let scene = load(name);
        let (quads, plain) = (build(&scene, true), build(&scene, false));
        paired += uses_quads(&quads) as u32;
        let (lo, hi) = scene.bounds;
        let diagonal = (hi - lo).length();
        let (mut hits, mut other_triangle, mut any_mismatch) = (0, 0, 0);
        for i in 0..100_000u64 {
            let u = |k: u64| unit_f32(hash_words(&[i, k, 7]));
            let org = lo - 0.1 * (hi - lo) + 1.2 * (hi - lo) * Vec3::new(u(0), u(1), u(2));
            let ray = Ray::new(org, square_to_uniform_sphere(Vec2::new(u(3), u(4))));
            let (a, b) = (quads.intersect(&ray), plain.intersect(&ray));
            assert_eq!(a.is_some(), b.is_some(), "{name}: {ray:?}: {a:?} vs {b:?}");
            if let (Some(a), Some(b)) = (a, b) {
                hits += 1;
                assert!(
                    (a.t - b.t).abs() <= 1e-5 * a.t + 1e-6 * diagonal,
                    "{name}: {ray:?}: {a:?} vs {b:?}"
                );
                let err = (hit_point(&scene, &a) - ray.at(a.t)).length();
                assert!(err <= 1e-5 * diagonal, "{name}: {ray:?}: {a:?}: {err}");
                other_triangle += (a.prim != b.prim) as u32;
            }
            let segment = Ray {
                t_max: 0.5 * diagonal,
                ..ray
            };
            any_mismatch += (quads.occluded(&segment) != plain.occluded(&segment)) as u32;
        }
        eprintln!("{name}: quads {}, {hits} hits, {other_triangle} on another triangle at the same distance, {any_mismatch} any-hit mismatches", uses_quads(&quads));
        assert!(hits > 10_000, "{name}: {hits} hits");
        assert!(
            other_triangle * 1000 <= hits,
            "{name}: {other_triangle} of {hits}"
        );
        assert!(
            any_mismatch <= 10,
            "{name}: {any_mismatch} any-hit mismatches"
        );
    }
    assert!(paired >= 1, "no bundled mesh was traced as quads");
}
