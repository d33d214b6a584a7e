//! Embree through strata's FFI layer: known rays against known triangles, both through the
//! raw wrapper (`strata::embree`) and the backend-neutral `Accel`.

use glam::{Vec2, Vec3};
use strata::accel::{Accel, AccelOptions, Backend, Ray};
use strata::embree::{self, BuildQuality, Device, SceneBuilder, SceneOptions};
use strata::scene::Scene;

/// Triangle 0: (0,0,0) (1,0,0) (0,1,0), counter-clockwise seen from +z.
/// Triangle 1: (0,0,−1) (2,0,−1) (0,2,−1), below it and larger.
fn two_triangles() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    (
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, -1.0],
            [2.0, 0.0, -1.0],
            [0.0, 2.0, -1.0],
        ],
        vec![[0, 1, 2], [3, 4, 5]],
    )
}

fn raw_scene(robust: bool) -> embree::Scene {
    let device = Device::new("verbose=0").expect("Embree device");
    let mut builder = SceneBuilder::new(
        &device,
        SceneOptions {
            quality: BuildQuality::Medium,
            robust,
            compact: false,
        },
    )
    .expect("scene");
    let (p, i) = two_triangles();
    let id = builder.attach_triangles(&p, &i).expect("attach");
    assert_eq!(id, 0);
    builder.commit().expect("commit")
}

fn scene_of(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Scene {
    let mut s = Scene {
        positions: positions.iter().map(|p| Vec3::from_array(*p)).collect(),
        normals: vec![Vec3::ZERO; positions.len()],
        uvs: vec![Vec2::ZERO; positions.len()],
        triangles: triangles.to_vec(),
        triangle_materials: vec![0; triangles.len()],
        materials: vec![Default::default()],
        ..Default::default()
    };
    s.update_summary();
    s
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-6 * (1.0 + b.abs())
}

#[test]
fn closest_hits_report_t_primitive_barycentrics_and_normal() {
    for robust in [false, true] {
        let scene = raw_scene(robust);
        let down = [0.0, 0.0, -1.0];

        let h = scene
            .intersect([0.25, 0.25, 1.0], down, 0.0, f32::INFINITY)
            .expect("hits triangle 0");
        assert_eq!((h.geom_id, h.prim_id), (0, 0));
        assert!(
            close(h.t, 1.0) && close(h.u, 0.25) && close(h.v, 0.25),
            "{h:?}"
        );
        // Counter-clockwise from +z: the geometric normal points to +z.
        assert!(
            h.ng[2] > 0.0 && h.ng[0].abs() < 1e-6 && h.ng[1].abs() < 1e-6,
            "{h:?}"
        );

        // Outside triangle 0 (u + v > 1) but inside triangle 1: p = u·(2,0) + v·(0,2).
        let h = scene
            .intersect([0.8, 0.8, 1.0], down, 0.0, f32::INFINITY)
            .expect("hits triangle 1");
        assert_eq!(h.prim_id, 1);
        assert!(
            close(h.t, 2.0) && close(h.u, 0.4) && close(h.v, 0.4),
            "{h:?}"
        );

        // From below, the normal still names the front side.
        let h = scene
            .intersect([0.25, 0.25, -0.5], [0.0, 0.0, 1.0], 0.0, f32::INFINITY)
            .expect("hits triangle 0 from below");
        assert_eq!(h.prim_id, 0);
        assert!(close(h.t, 0.5) && h.ng[2] > 0.0, "{h:?}");

        // Misses: beside both triangles, and pointing away.
        assert!(scene
            .intersect([5.0, 5.0, 1.0], down, 0.0, f32::INFINITY)
            .is_none());
        assert!(scene
            .intersect([0.25, 0.25, 1.0], [0.0, 0.0, 1.0], 0.0, f32::INFINITY)
            .is_none());
        // t_min skips triangle 0 and finds triangle 1.
        let h = scene
            .intersect([0.25, 0.25, 1.0], down, 1.5, f32::INFINITY)
            .expect("skips the first");
        assert_eq!(h.prim_id, 1);
        // t_max stops short of both.
        assert!(scene
            .intersect([0.25, 0.25, 1.0], down, 0.0, 0.99)
            .is_none());
    }
}

#[test]
fn any_hit_respects_t_max_and_t_min() {
    let scene = raw_scene(true);
    let org = [0.25, 0.25, 1.0];
    let down = [0.0, 0.0, -1.0];
    assert!(
        !scene.occluded(org, down, 0.0, 0.99),
        "triangle 0 lies at t = 1"
    );
    assert!(scene.occluded(org, down, 0.0, 1.01));
    assert!(scene.occluded(org, down, 1.5, 2.5), "triangle 1 at t = 2");
    assert!(!scene.occluded(org, down, 1.5, 1.9));
    assert!(!scene.occluded([5.0, 5.0, 1.0], down, 0.0, f32::INFINITY));
}

#[test]
fn accel_follows_the_backend_neutral_contract() {
    let (p, i) = two_triangles();
    let scene = scene_of(&p, &i);
    let accel = Accel::build(&scene, &AccelOptions::default()).expect("accel");
    let ray = Ray::new(Vec3::new(0.2, 0.3, 2.0), Vec3::NEG_Z);
    let h = accel.intersect(&ray).expect("hit");
    assert_eq!(h.prim, 0);
    assert!(
        close(h.t, 2.0) && close(h.u, 0.2) && close(h.v, 0.3),
        "{h:?}"
    );
    assert!((h.ng - Vec3::Z).length() < 1e-6, "unit front normal: {h:?}");
    // The hit point rebuilt from barycentrics equals org + t·dir.
    let [a, b, c] = scene.triangle_positions(h.prim);
    let p = (1.0 - h.u - h.v) * a + h.u * b + h.v * c;
    assert!((p - ray.at(h.t)).length() < 1e-6);

    let mut shadow = Ray::new(Vec3::new(0.2, 0.3, 2.0), Vec3::NEG_Z);
    shadow.t_max = 1.9;
    assert!(!accel.occluded(&shadow));
    shadow.t_max = 2.1;
    assert!(accel.occluded(&shadow));
}

#[test]
fn many_threads_see_the_same_hits() {
    let scene = raw_scene(true);
    let expected: Vec<_> = (0..200)
        .map(|k| {
            let x = (k % 20) as f32 * 0.1;
            let y = (k / 20) as f32 * 0.2;
            scene.intersect([x, y, 1.0], [0.0, 0.0, -1.0], 0.0, f32::INFINITY)
        })
        .collect();
    assert!(expected.iter().any(Option::is_some) && expected.iter().any(Option::is_none));
    std::thread::scope(|s| {
        for _ in 0..4 {
            s.spawn(|| {
                for (k, e) in expected.iter().enumerate() {
                    let x = (k % 20) as f32 * 0.1;
                    let y = (k / 20) as f32 * 0.2;
                    let h = scene.intersect([x, y, 1.0], [0.0, 0.0, -1.0], 0.0, f32::INFINITY);
                    assert_eq!(&h, e);
                }
            });
        }
    });
}

#[test]
fn device_errors_become_rust_errors() {
    let err = Device::new("threads=not-a-number,no_such_option=1");
    assert!(err.is_err(), "an invalid configuration must fail");
    let message = err.err().unwrap().to_string();
    assert!(message.contains("Embree error"), "{message}");

    let device = Device::new("verbose=0").unwrap();
    let mut builder = SceneBuilder::new(
        &device,
        SceneOptions {
            quality: BuildQuality::Low,
            robust: false,
            compact: false,
        },
    )
    .unwrap();
    assert!(
        builder
            .attach_triangles(&[[0.0; 3]; 3], &[[0, 1, 3]])
            .is_err(),
        "index out of range"
    );
    assert!(builder.attach_triangles(&[], &[]).is_err(), "empty mesh");
    assert!(device.check().is_ok(), "no error left pending");
}

/// A scene with no triangles is a valid scene (it renders its environment alone): both
/// backends build it, and no ray hits it or is blocked by it.
#[test]
fn an_empty_scene_builds_and_nothing_hits_it() {
    let scene = scene_of(&[], &[]);
    for backend in [Backend::Embree, Backend::Obvhs] {
        let accel = Accel::build(
            &scene,
            &AccelOptions {
                backend,
                ..Default::default()
            },
        )
        .unwrap();
        let ray = Ray::new(Vec3::new(0.0, 0.0, 1.0), Vec3::NEG_Z);
        assert!(accel.intersect(&ray).is_none(), "{backend:?}");
        assert!(!accel.occluded(&ray), "{backend:?}");
        assert!(accel.clusters().is_empty(), "{backend:?}");
    }
}

#[test]
fn runtime_library_matches_the_compiled_major_version() {
    let device = Device::new("verbose=0").unwrap();
    let version = device.version();
    assert!(
        version.starts_with(&format!("{}.", embree::MAJOR)),
        "compiled for Embree {}, loaded {version}",
        embree::MAJOR
    );
    eprintln!(
        "Embree runtime {version}, headers {}",
        env!("STRATA_EMBREE_HEADER_VERSION")
    );
}

#[test]
fn render_workers_flush_denormals() {
    let pool = strata::render::thread_pool(2).unwrap();
    let flags: Vec<bool> = pool.broadcast(|_| embree::ftz_daz_enabled());
    assert_eq!(flags, vec![true, true]);
}

/// The memory each backend reports follows from what it must store: Embree copies the
/// vertex and index buffers (12 bytes per vertex and per triangle, or 16 per quad, at least)
/// and builds a non-empty BVH, and its build peak covers what it keeps; obvhs stores one 48-byte
/// triangle and a 4-byte id per triangle. A grid of 2·n² triangles makes the sizes clear.
#[test]
fn backends_report_the_memory_they_hold() {
    let n = 64u32;
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for y in 0..=n {
        for x in 0..=n {
            positions.push([x as f32, y as f32, 0.0]);
        }
    }
    let at = |x: u32, y: u32| y * (n + 1) + x;
    for y in 0..n {
        for x in 0..n {
            triangles.push([at(x, y), at(x + 1, y), at(x + 1, y + 1)]);
            triangles.push([at(x, y), at(x + 1, y + 1), at(x, y + 1)]);
        }
    }
    let scene = scene_of(&positions, &triangles);
    let t = triangles.len();

    // As triangles, and as quads (the grid's squares pair: 16 bytes per quad).
    for (quads, primitives, index_bytes) in [(false, t, 12), (true, t / 2, 16)] {
        let accel = Accel::build(
            &scene,
            &AccelOptions {
                quads,
                ..AccelOptions::default()
            },
        )
        .unwrap();
        assert_eq!(accel.as_embree().unwrap().uses_quads(), quads);
        let embree = accel.memory();
        assert!(
            embree.geometry >= 12 * positions.len() + index_bytes * primitives,
            "Embree geometry {} B for {} vertices and {primitives} primitives",
            embree.geometry,
            positions.len()
        );
        assert!(
            embree.bvh >= 8 * primitives,
            "Embree BVH {} B for {primitives} primitives",
            embree.bvh
        );
        let peak = embree.build_peak.expect("Embree reports its peak");
        assert!(
            peak >= embree.geometry + embree.bvh,
            "peak {peak} B, {embree:?}"
        );
    }

    let options = AccelOptions {
        backend: strata::accel::Backend::Obvhs,
        ..AccelOptions::default()
    };
    let obvhs = Accel::build(&scene, &options).unwrap().memory();
    assert_eq!(obvhs.geometry, 52 * t, "{obvhs:?}");
    assert!(obvhs.bvh >= 4 * t, "{obvhs:?}");
}

/// Embree's packet API (4, 8 and 16 rays per call) finds exactly the hits of single-ray
/// tracing, also for a ray count that leaves the last packet part-filled (masked lanes).
#[test]
fn packets_agree_with_single_rays() {
    let (positions, triangles) = two_triangles();
    let scene = scene_of(&positions, &triangles);
    let accel = Accel::build(&scene, &AccelOptions::default()).unwrap();
    let raw = accel.as_embree().unwrap().raw();
    // A fan of 1001 rays from above, some over the quad and some past it.
    let rays: Vec<embree::RawRay> = (0..1001)
        .map(|i| {
            let (x, y) = ((i % 37) as f32 / 12.0 - 0.5, (i / 37) as f32 / 9.0 - 0.5);
            embree::RawRay::new([x, y, 1.0], [0.0, 0.0, -1.0], 0.0, f32::INFINITY)
        })
        .collect();
    let single = raw.intersect_count_raw(&rays);
    assert!(
        single > 100 && single < rays.len(),
        "{single} hits: pick rays that both hit and miss"
    );
    for coherent in [true, false] {
        assert_eq!(raw.intersect4_count_raw(&rays, coherent), single);
        assert_eq!(raw.intersect8_count_raw(&rays, coherent), single);
        assert_eq!(raw.intersect16_count_raw(&rays, coherent), single);
    }
}

/// The scene's acceleration structure from each backend.
fn both_backends(scene: &Scene) -> Vec<(strata::accel::Backend, Accel)> {
    use strata::accel::Backend;
    [Backend::Embree, Backend::Obvhs]
        .into_iter()
        .map(|backend| {
            let options = AccelOptions {
                backend,
                ..Default::default()
            };
            (backend, Accel::build(scene, &options).unwrap())
        })
        .collect()
}

/// `Accel::intersect_packet` gives, lane by lane, exactly the hit (t, triangle, barycentrics,
/// normal) that `Accel::intersect` gives: the camera rays of a real scene in 4×2 pixel
/// blocks, part-filled packets included, for both backends. Renders trace camera rays either
/// way, so this equality is what keeps their images identical.
#[test]
fn packet_queries_equal_single_ray_queries_on_camera_rays() {
    use strata::accel::PACKET;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/suzanne.gltf");
    let scene = strata::scene::load(&path, &Default::default()).unwrap();
    let (w, h) = (61u32, 45u32);
    let camera = scene.cameras[0].ray_generator(w, h);
    let mut rays = Vec::new();
    for by in (0..h).step_by(2) {
        for bx in (0..w).step_by(4) {
            let block: Vec<Ray> = (by..(by + 2).min(h))
                .flat_map(|y| (bx..(bx + 4).min(w)).map(move |x| (x, y)))
                .map(|(x, y)| camera.ray(x as f32 + 0.37, y as f32 + 0.61))
                .collect();
            rays.push(block);
        }
    }
    for (backend, accel) in both_backends(&scene) {
        let (mut hits, mut partial) = (0, 0);
        for block in &rays {
            let mut packet = [None; PACKET];
            accel.intersect_packet(block, &mut packet);
            partial += (block.len() < PACKET) as usize;
            for (i, hit) in packet.iter().enumerate() {
                let single = block.get(i).and_then(|r| accel.intersect(r));
                assert_eq!(*hit, single, "{backend:?}: lane {i} of {block:?}");
                hits += hit.is_some() as usize;
            }
        }
        let total: usize = rays.iter().map(Vec::len).sum();
        assert!(
            hits > total / 10 && hits < total,
            "{backend:?}: {hits} of {total} hit"
        );
        assert!(partial > 0, "no part-filled packet");
    }
}

/// `Accel::occluded_packet` answers, lane by lane, as `Accel::occluded` does: AO-like rays
/// leaving points of a real mesh (Suzanne seen by its camera) in all directions, in packets
/// of 1 to 16 rays from one point (Embree's 8- and 16-wide queries), for both backends.
#[test]
fn occlusion_packets_equal_single_ray_queries() {
    use strata::accel::OCCLUSION_PACKET as PACKET;
    use strata::shading::interaction::SurfaceInteraction;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/suzanne.gltf");
    let scene = strata::scene::load(&path, &Default::default()).unwrap();
    let camera = scene.cameras[0].ray_generator(40, 30);
    for (backend, accel) in both_backends(&scene) {
        let (mut rays_traced, mut occluded_count) = (0, 0);
        for p in 0..40 * 30u32 {
            let ray = camera.ray((p % 40) as f32 + 0.5, (p / 40) as f32 + 0.5);
            let Some(hit) = accel.intersect(&ray) else {
                continue;
            };
            let si = SurfaceInteraction::from_hit(&scene, &ray, &hit);
            let n = 1 + p as usize % PACKET;
            let packet: Vec<Ray> = (0..n)
                .map(|k| {
                    let a = (p as f32 * 0.37 + k as f32 * 2.4).sin_cos();
                    let z = (k as f32 + 0.5) / n as f32 * 2.0 - 1.0;
                    let r = (1.0 - z * z).sqrt();
                    si.spawn_ray(Vec3::new(r * a.0, r * a.1, z), f32::INFINITY)
                })
                .collect();
            let mut occluded = [false; PACKET];
            accel.occluded_packet(&packet, &mut occluded);
            for (k, r) in packet.iter().enumerate() {
                assert_eq!(
                    occluded[k],
                    accel.occluded(r),
                    "{backend:?}: pixel {p} ray {k}"
                );
                occluded_count += occluded[k] as usize;
            }
            rays_traced += n;
        }
        assert!(
            occluded_count > rays_traced / 10 && occluded_count < rays_traced,
            "{backend:?}: {occluded_count} of {rays_traced} occluded"
        );
    }
}

/// Instances through the raw wrapper: the two triangles as a scene of their own, placed twice
/// (moved up by 3; turned a quarter about +z, scaled by 2 and moved to x = −5), beside a
/// triangle of the top scene. A hit inside an instance reports the instance's geometry id,
/// the child's geometry and primitive, the child's barycentrics and normal (in the child's
/// space) and the world ray's t (an affine map keeps a ray's parameter); a hit on the top
/// scene's own triangle reports no instance; a packet answers as single rays do; a
/// placement that is not finite is refused.
#[test]
fn instances_report_their_geometry_id_and_the_child_primitive() {
    let device = Device::new("verbose=0").expect("Embree device");
    let options = SceneOptions {
        quality: BuildQuality::Medium,
        robust: true,
        compact: false,
    };
    let mut child = SceneBuilder::new(&device, options).expect("scene");
    let (p, i) = two_triangles();
    child.attach_triangles(&p, &i).expect("attach");
    let child = std::sync::Arc::new(child.commit().expect("commit"));
    let mut top = SceneBuilder::new(&device, options).expect("scene");
    let world = top
        .attach_triangles(
            &[[10.0, 0.0, 0.0], [11.0, 0.0, 0.0], [10.0, 1.0, 0.0]],
            &[[0, 1, 2]],
        )
        .expect("attach");
    // Column-major: the images of x, y and z, then the translation.
    let up = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 3.0];
    // (x, y, z) → (−2y − 5, 2x, 2z).
    let turned = [0.0, 2.0, 0.0, -2.0, 0.0, 0.0, 0.0, 0.0, 2.0, -5.0, 0.0, 0.0];
    let a = top.attach_instance(&child, &up).expect("instance");
    let b = top.attach_instance(&child, &turned).expect("instance");
    assert_eq!((world, a, b), (0, 1, 2));
    let mut bad = up;
    bad[9] = f32::NAN;
    let err = top.attach_instance(&child, &bad).unwrap_err();
    assert!(err.to_string().contains("not finite"), "{err}");
    let scene = top.commit().expect("commit");

    let down = [0.0, 0.0, -1.0];
    let rays = [
        // Child triangle 0 at (0.25, 0.25, 0), moved up to z = 3.
        ([0.25, 0.25, 10.0], down, (a, 0, 0), 7.0, [0.25, 0.25]),
        // The same point of instance b: (−5.5, 0.5, 0).
        ([-5.5, 0.5, 10.0], down, (b, 0, 0), 10.0, [0.25, 0.25]),
        // Child triangle 1 at (0.8, 0.8, −1) (barycentrics 0.4, 0.4) in b: (−6.6, 1.6, −2).
        ([-6.6, 1.6, 10.0], down, (b, 0, 1), 12.0, [0.4, 0.4]),
        // The top scene's own triangle.
        (
            [10.25, 0.25, 10.0],
            down,
            (embree::INVALID_GEOMETRY_ID, world, 0),
            10.0,
            [0.25, 0.25],
        ),
    ];
    let mut singles = Vec::new();
    for &(org, dir, ids, t, [u, v]) in &rays {
        let h = scene
            .intersect(org, dir, 0.0, f32::INFINITY)
            .unwrap_or_else(|| panic!("the ray from {org:?} misses"));
        assert_eq!((h.inst_id, h.geom_id, h.prim_id), ids, "{h:?}");
        assert!(
            (h.t - t).abs() < 1e-4 && close(h.u, u) && close(h.v, v),
            "{h:?}"
        );
        // The child's normal, in its own space (+z, whatever the placement's scale).
        assert!(
            h.ng[2] > 0.0 && h.ng[0].abs() < 1e-6 && h.ng[1].abs() < 1e-6,
            "{h:?}"
        );
        singles.push(h);
    }
    let mut packed = vec![None; rays.len()];
    scene.intersect_packet(
        &rays,
        |r| (r.0, r.1, 0.0, f32::INFINITY, 0),
        |i, h| packed[i] = h,
    );
    for (single, packed) in singles.iter().zip(&packed) {
        assert_eq!(Some(*single), *packed);
    }
    // Below everything: no hit, no instance.
    assert!(scene
        .intersect([0.25, 0.25, -10.0], down, 0.0, f32::INFINITY)
        .is_none());
}

/// A hit filter inside an instance hears of the instance and of the ray's id: a filter on the
/// child's geometry records (instance, primitive, ray id) of every candidate hit and lets
/// only primitive 1 through. Traced with ids through two instances, single rays and
/// packets, each record names the instance the ray went through and the id it was traced
/// with (Embree hands the filter the ray in the instance's space: the id is what survives
/// the change of space), and the filter's answer decides the hit.
#[test]
fn hit_filters_hear_the_instance_and_the_ray_id() {
    use std::sync::{Arc, Mutex};
    struct Recorder(Mutex<Vec<(u32, u32, u32)>>);
    impl embree::HitFilter for Recorder {
        fn accept(&self, prim: u32, inst: u32, _u: f32, _v: f32, ray_id: u32) -> bool {
            self.0.lock().unwrap().push((inst, prim, ray_id));
            prim == 1
        }
    }
    let device = Device::new("verbose=0").expect("Embree device");
    let options = SceneOptions {
        quality: BuildQuality::Medium,
        robust: true,
        compact: false,
    };
    let recorder = Arc::new(Recorder(Mutex::new(Vec::new())));
    let mut child = SceneBuilder::new(&device, options).expect("scene");
    let (p, i) = two_triangles();
    child
        .attach_filtered_triangles(&p, &i, recorder.clone())
        .expect("attach");
    let child = Arc::new(child.commit().expect("commit"));
    let mut top = SceneBuilder::new(&device, options).expect("scene");
    let up = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 3.0];
    let aside = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 20.0, 0.0, 0.0];
    let a = top.attach_instance(&child, &up).expect("instance");
    let b = top.attach_instance(&child, &aside).expect("instance");
    let scene = top.commit().expect("commit");
    let down = [0.0, 0.0, -1.0];
    // Through instance a at child (0.25, 0.25): triangle 0 (rejected) above triangle 1.
    let h = scene
        .intersect_id([0.25, 0.25, 10.0], down, 0.0, f32::INFINITY, 0xabcd_1234)
        .expect("a hit on triangle 1");
    assert_eq!((h.inst_id, h.prim_id), (a, 1));
    assert!((h.t - 8.0).abs() < 1e-4, "{h:?}");
    let heard = std::mem::take(&mut *recorder.0.lock().unwrap());
    assert!(heard.contains(&(a, 0, 0xabcd_1234)), "{heard:?}");
    assert!(
        heard
            .iter()
            .all(|&(inst, _, id)| inst == a && id == 0xabcd_1234),
        "{heard:?}"
    );
    // Occlusion through instance b with another id.
    assert!(scene.occluded_id([20.25, 0.25, 10.0], down, 0.0, f32::INFINITY, 77));
    let heard = std::mem::take(&mut *recorder.0.lock().unwrap());
    assert!(
        !heard.is_empty() && heard.iter().all(|&(inst, _, id)| inst == b && id == 77),
        "{heard:?}"
    );
    // A packet: each lane's id reaches the filter with its own instance.
    let rays = [
        ([0.25f32, 0.25, 10.0], 5u32),
        ([20.25, 0.25, 10.0], 6),
        ([0.3, 0.3, 10.0], 7),
    ];
    scene.intersect_packet(
        &rays,
        |r| (r.0, down, 0.0, f32::INFINITY, r.1),
        |_, h| {
            assert_eq!(h.map(|h| h.prim_id), Some(1));
        },
    );
    let heard = std::mem::take(&mut *recorder.0.lock().unwrap());
    for (inst, id) in [(a, 5), (b, 6), (a, 7)] {
        assert!(
            heard.iter().any(|&(i, _, r)| i == inst && r == id),
            "{inst} {id}: {heard:?}"
        );
    }
    assert!(
        heard.iter().all(|&(i, _, r)| (i == b) == (r == 6)),
        "{heard:?}"
    );
}

/// Both backends on a scene built in code with instances (the two triangles placed three
/// times: moved, turned and scaled, mirrored) beside a world-space triangle: for a grid of
/// rays from above, some oblique, the closest hit (triangle, instance, t, barycentrics,
/// normal) and the any-hit answer equal those on the flattened copy, whose triangles
/// 2k + 1 and 2k + 2 are instance k's placed corners (a mirror's copy keeps the corners'
/// order, so its e1 × e2 normal is the instance's front turned over).
#[test]
fn instanced_scenes_answer_as_their_flattened_copies() {
    use glam::{Affine3A, Quat};
    use strata::scene::{Instance, Prototype, NO_INSTANCE};
    let (p, t) = two_triangles();
    let world_tri = [[3.0, -3.0, 0.5], [4.0, -3.0, 0.5], [3.0, -2.0, 0.5]];
    let placements = [
        Affine3A::from_translation(Vec3::new(-2.0, 1.0, 0.5)),
        Affine3A::from_scale_rotation_translation(
            Vec3::new(1.5, 0.5, 1.0),
            Quat::from_rotation_z(0.7),
            Vec3::new(1.0, -1.0, 0.0),
        ),
        Affine3A::from_scale_rotation_translation(
            Vec3::new(-1.0, 1.0, 1.0),
            Quat::from_rotation_x(0.3),
            Vec3::new(-1.0, -2.5, -0.5),
        ),
    ];
    // Instanced: the world triangle (0), then the prototype (1, 2).
    let mut positions = world_tri.to_vec();
    positions.extend(&p);
    let mut triangles = vec![[0, 1, 2]];
    triangles.extend(t.iter().map(|tri| tri.map(|i| i + 3)));
    let mut instanced = scene_of(&positions, &triangles);
    instanced.prototypes = vec![Prototype {
        triangles: 1..3,
        bounds: (Vec3::new(0.0, 0.0, -1.0), Vec3::new(2.0, 2.0, 0.0)),
        mesh: None,
    }];
    instanced.instances = std::sync::Arc::new(
        placements
            .iter()
            .map(|m| Instance::new(0, *m, None))
            .collect(),
    );
    instanced.update_summary();
    // Flattened: the world triangle, then each instance's two triangles placed.
    let mut flat_positions = world_tri.to_vec();
    for m in &placements {
        flat_positions.extend(
            p.iter()
                .map(|q| m.transform_point3(Vec3::from(*q)).to_array()),
        );
    }
    let flat_triangles: Vec<[u32; 3]> = (0..7u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
    let flat = scene_of(&flat_positions, &flat_triangles);

    let mut rays = Vec::new();
    for i in 0..40 {
        for j in 0..40 {
            // Off the grid of the corners' coordinates: a ray through an edge may be given to
            // either side by rounding, which a placement changes.
            let org = Vec3::new(-3.9863 + 0.2 * i as f32, -4.9709 + 0.2 * j as f32, 5.0);
            rays.push(Ray::new(org, Vec3::new(0.0, 0.0, -1.0)));
            rays.push(Ray::new(org, Vec3::new(0.3, -0.2, -1.0)));
        }
    }
    let mut hits = 0;
    for ((backend, inst_accel), (_, flat_accel)) in both_backends(&instanced)
        .into_iter()
        .zip(both_backends(&flat))
    {
        for ray in &rays {
            let (got, want) = (inst_accel.intersect(ray), flat_accel.intersect(ray));
            assert_eq!(
                inst_accel.occluded(ray),
                flat_accel.occluded(ray),
                "{backend:?}: {ray:?}"
            );
            let (got, want) = match (got, want) {
                (None, None) => continue,
                (Some(g), Some(w)) => (g, w),
                other => panic!("{backend:?}: {ray:?}: {other:?}"),
            };
            hits += 1;
            let (prim, mirrored) = match got.inst {
                NO_INSTANCE => (got.prim, false),
                k => (2 * k + got.prim, k == 2),
            };
            assert_eq!(prim, want.prim, "{backend:?}: {ray:?}: {got:?} {want:?}");
            let ng = if mirrored { -want.ng } else { want.ng };
            assert!(
                (got.t - want.t).abs() < 1e-4
                    && (got.u - want.u).abs() < 1e-4
                    && (got.v - want.v).abs() < 1e-4
                    && (got.ng - ng).length() < 1e-4,
                "{backend:?}: {ray:?}: {got:?} against {want:?}"
            );
        }
    }
    assert!(hits > 500, "{hits} hits");
}
