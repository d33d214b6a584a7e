//! Instancing: a mesh that several nodes or EXT_mesh_gpu_instancing instances place is stored
//! once, in its own space, and each placement is an instance (translation × rotation × scale
//! under the node's own transform), traced by Embree's instances or obvhs's two-level BVH; it
//! renders as its flattened copies do (`--flatten-instances`), normal maps, mirrors and ID
//! passes included, and a scene whose flattened copy could never fit in memory renders.
//! Inconsistent instance attributes are refused by name.

mod common;

use common::*;
use glam::Vec3;
use serde_json::json;
use strata::scene::{load, LoadOptions};

/// `parts` laid end to end in one buffer, and a buffer view of each.
fn buffer_views(parts: &[Vec<u8>]) -> (Vec<u8>, Vec<serde_json::Value>) {
    let mut bin = Vec::new();
    let mut views = Vec::new();
    for p in parts {
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": p.len()}));
        bin.extend(p);
    }
    (bin, views)
}

/// A triangle with corners (1, 0, 0), (0, 1, 0), (0, 0, 1) on a node translated by
/// (0, 0, −5), instanced three times: translations (0,0,0), (10,0,0), (0,10,0); rotations
/// identity, 90° about +z (as normalized shorts), identity; scales 1, 1, 2. `rotation_count`
/// lets a test give the ROTATION accessor a wrong count.
fn instanced(dir: &std::path::Path, rotation_count: usize) -> std::path::PathBuf {
    let f = |v: &[f32]| -> Vec<u8> { v.iter().flat_map(|x| x.to_le_bytes()).collect() };
    let q = 23170i16; // round(32767 · sin 45°)
    let rotations: Vec<u8> = [0i16, 0, 0, 32767, 0, 0, q, q, 0, 0, 0, 32767]
        .iter()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    let parts = [
        f(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]),
        f(&[0.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 10.0, 0.0]),
        rotations,
        f(&[1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0]),
    ];
    let (bin, views) = buffer_views(&parts);
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["EXT_mesh_gpu_instancing"],
        "extensionsRequired": ["EXT_mesh_gpu_instancing"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{
            "mesh": 0,
            "translation": [0.0, 0.0, -5.0],
            "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {
                "TRANSLATION": 1, "ROTATION": 2, "SCALE": 3, "_ID": 1
            }}}
        }],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "buffers": [{"byteLength": bin.len(), "uri": data_uri(&bin)}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5122, "normalized": true,
             "count": rotation_count, "type": "VEC4"},
            {"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC3"}
        ]
    });
    let path = dir.join("instanced.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

#[test]
fn every_instance_is_drawn_where_its_transform_puts_it() {
    let dir = tempfile::tempdir().unwrap();
    let flattened = LoadOptions {
        flatten_instances: true,
        ..Default::default()
    };
    let scene = load(&instanced(dir.path(), 3), &flattened).unwrap();
    let node = Vec3::new(0.0, 0.0, -5.0);
    // Computed here: corner p of instance k at node + t_k + R_k (s_k p).
    let rot90 = |p: Vec3| Vec3::new(-p.y, p.x, p.z);
    let corners = [Vec3::X, Vec3::Y, Vec3::Z];
    let want: Vec<Vec3> = corners
        .iter()
        .map(|&p| node + p)
        .chain(
            corners
                .iter()
                .map(|&p| node + Vec3::new(10.0, 0.0, 0.0) + rot90(p)),
        )
        .chain(
            corners
                .iter()
                .map(|&p| node + Vec3::new(0.0, 10.0, 0.0) + 2.0 * p),
        )
        .collect();
    assert_eq!(scene.positions.len(), 9);
    for (i, (got, want)) in scene.positions.iter().zip(&want).enumerate() {
        assert!(
            (*got - *want).length() < 1e-4,
            "vertex {i}: {got} against {want}"
        );
    }
    assert_eq!(scene.triangles.len(), 3);
    // The estimate counts every copy.
    assert_eq!(scene.memory_estimate.triangles, 3);
    assert_eq!(scene.memory_estimate.vertices, 9);
    assert_eq!(scene.memory_estimate.instances, 0);

    // Instanced: the triangle stored once, in the mesh's own space, and three instances that
    // place it at the same corners.
    let scene = load(&instanced(dir.path(), 3), &LoadOptions::default()).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    assert_eq!(scene.positions, corners.to_vec());
    assert_eq!(scene.prototypes.len(), 1);
    assert_eq!(scene.instances.len(), 3);
    assert!(scene.flat_triangles().is_empty());
    for (k, want) in want.chunks(3).enumerate() {
        let got = scene.placed_positions(0, k as u32);
        for (got, want) in got.iter().zip(want) {
            assert!(
                (*got - *want).length() < 1e-4,
                "instance {k}: {got} against {want}"
            );
        }
        assert_eq!(scene.origin(0, k as u32).node, Some(0));
    }
    assert_eq!(
        (
            scene.memory_estimate.triangles,
            scene.memory_estimate.vertices
        ),
        (1, 3)
    );
    assert_eq!(scene.memory_estimate.instances, 3);
    assert_eq!(
        (scene.summary.instances, scene.summary.instanced_triangles),
        (3, 3)
    );
    // The bounds hold every instance's corners.
    for p in &want {
        assert!(p.cmpge(scene.bounds.0 - 1e-4).all() && p.cmple(scene.bounds.1 + 1e-4).all());
    }
    assert!(
        !scene
            .load_warnings
            .iter()
            .any(|w| w.contains("EXT_mesh_gpu_instancing")),
        "{:?}",
        scene.load_warnings
    );
}

/// A placement that cannot be inverted (a scale of 0 along x: the triangle flattened onto the
/// yz plane, still a triangle) cannot be an instance: it is drawn as a flattened copy, with a
/// warning, beside the mesh's other placement, which stays an instance.
#[test]
fn a_singular_placement_is_drawn_as_a_copy_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let corners: Vec<u8> = [1.0f32, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0, "translation": [0.0, 0.0, -5.0]},
            {"mesh": 0, "translation": [3.0, 0.0, -5.0], "scale": [0.0, 1.0, 1.0]}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "buffers": [{"byteLength": corners.len(), "uri": data_uri(&corners)}],
        "bufferViews": [{"buffer": 0, "byteLength": corners.len()}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0]}]
    });
    let path = dir.path().join("singular.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let scene = load(&path, &LoadOptions::default()).unwrap();
    assert_eq!((scene.prototypes.len(), scene.instances.len()), (1, 1));
    assert_eq!(scene.triangles.len(), 2, "the prototype's and the copy's");
    let flat = scene.flat_triangles();
    assert_eq!(flat.len(), 1);
    let copy = scene.triangle_positions(flat[0]);
    let want = [
        Vec3::new(3.0, 0.0, -5.0),
        Vec3::new(3.0, 1.0, -5.0),
        Vec3::new(3.0, 0.0, -4.0),
    ];
    assert_eq!(copy, want);
    assert_eq!(
        scene.origin(flat[0], strata::ray::NO_INSTANCE).node,
        Some(1)
    );
    assert_eq!(scene.origin(0, 0).node, Some(0));
    assert!(
        scene
            .load_warnings
            .iter()
            .any(|w| w.contains("1 placement(s)") && w.contains("singular transform")),
        "{:?}",
        scene.load_warnings
    );
}

#[test]
fn instance_attributes_of_different_counts_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let err = load(&instanced(dir.path(), 2), &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("EXT_mesh_gpu_instancing")
            && err.contains("ROTATION")
            && err.contains("node 0"),
        "{err}"
    );
}

/// A scene of one normal-mapped sphere mesh placed five times: by three nodes (one turned and
/// squashed, one mirrored, as `mirror` says, and turned) and by a node with two
/// EXT_mesh_gpu_instancing instances, over a floor placed once, under a sun. The normal map
/// (no TANGENT: MikkTSpace's frames) is lopsided, so that a frame of the wrong handedness
/// shows. With `alpha` ("MASK" or "BLEND"), the spheres' material takes that alpha mode with
/// a texture of bands that cut holes (under BLEND, the rest half covered: factor alpha 0.5).
fn shared_spheres(
    dir: &std::path::Path,
    name: &str,
    mirror: bool,
    alpha: Option<&str>,
) -> std::path::PathBuf {
    let (sphere, sphere_tris) = outward_sphere();
    let uvs: Vec<[f32; 2]> = sphere
        .iter()
        .map(|p| {
            let u = 0.5 + p[2].atan2(p[0]) / std::f32::consts::TAU;
            let v = p[1].clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
            [u, v]
        })
        .collect();
    let floor = [
        [-6.0, -1.2, 4.0],
        [6.0, -1.2, 4.0],
        [6.0, -1.2, -8.0],
        [-6.0, -1.2, -8.0],
    ];
    let floor_tris = [[0u32, 1, 2], [0, 2, 3]];
    let map = image::RgbImage::from_fn(64, 64, |x, y| {
        let (u, v) = (x as f32 / 64.0, y as f32 / 64.0);
        let nx = 0.6 * (std::f32::consts::TAU * 6.0 * u).sin() + 0.3;
        let ny = 0.5 * (std::f32::consts::TAU * 5.0 * v).cos();
        let nz = (1.0 - nx * nx - ny * ny).max(0.0).sqrt();
        let c = |n: f32| ((n * 0.5 + 0.5) * 255.0).round() as u8;
        image::Rgb([c(nx), c(ny), c(nz)])
    });
    let mut png = Vec::new();
    map.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let bands = image::RgbaImage::from_fn(32, 32, |x, _| {
        image::Rgba([230, 160, 100, if (x / 4) % 2 == 0 { 255 } else { 0 }])
    });
    let mut bands_png = Vec::new();
    bands
        .write_to(
            &mut std::io::Cursor::new(&mut bands_png),
            image::ImageFormat::Png,
        )
        .unwrap();

    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut push = |bytes: Vec<u8>, bin: &mut Vec<u8>| {
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend(bytes);
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.len() - 1
    };
    let floats = |v: &[f32]| -> Vec<u8> { v.iter().flat_map(|x| x.to_le_bytes()).collect() };
    let ints = |v: &[u32]| -> Vec<u8> { v.iter().flat_map(|x| x.to_le_bytes()).collect() };
    let flat3 = |v: &[[f32; 3]]| -> Vec<f32> { v.iter().flatten().copied().collect() };
    let bounds = |v: &[[f32; 3]]| {
        let lo: Vec<f32> = (0..3)
            .map(|a| v.iter().map(|p| p[a]).fold(f32::MAX, f32::min))
            .collect();
        let hi: Vec<f32> = (0..3)
            .map(|a| v.iter().map(|p| p[a]).fold(f32::MIN, f32::max))
            .collect();
        (lo, hi)
    };
    let (slo, shi) = bounds(&sphere);
    let (flo, fhi) = bounds(&floor);
    let sphere_pos = push(floats(&flat3(&sphere)), &mut bin);
    let sphere_uv = push(
        floats(&uvs.iter().flatten().copied().collect::<Vec<_>>()),
        &mut bin,
    );
    let sphere_idx = push(
        ints(&sphere_tris.iter().flatten().copied().collect::<Vec<_>>()),
        &mut bin,
    );
    let floor_pos = push(floats(&flat3(&floor)), &mut bin);
    let floor_idx = push(
        ints(&floor_tris.iter().flatten().copied().collect::<Vec<_>>()),
        &mut bin,
    );
    let image_view = push(png, &mut bin);
    let bands_view = push(bands_png, &mut bin);
    let instance_t = push(floats(&[-1.1, 0.0, -2.5, 1.1, 0.0, -2.5]), &mut bin);
    // Quaternions (x, y, z, w) of a turn by `deg` degrees about a unit axis.
    let turn = |axis: [f32; 3], deg: f32| {
        let (s, c) = (deg.to_radians() / 2.0).sin_cos();
        json!([axis[0] * s, axis[1] * s, axis[2] * s, c])
    };
    let mut sphere_material = json!(
        {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.5, 0.3, 1.0],
                                  "metallicFactor": 0.0, "roughnessFactor": 0.3},
         "normalTexture": {"index": 0}});
    if let Some(mode) = alpha {
        sphere_material["alphaMode"] = json!(mode);
        sphere_material["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 1});
        if mode == "BLEND" {
            sphere_material["pbrMetallicRoughness"]["baseColorFactor"][3] = json!(0.5);
        }
    }
    let mirrored_scale = if mirror {
        json!([-1.0, 1.0, 1.0])
    } else {
        json!([1.0, 1.0, 1.0])
    };
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["EXT_mesh_gpu_instancing", "KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "directional", "color": [1.0, 0.95, 0.9], "intensity": 3.0}
        ]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3, 4, 5, 6]}],
        "nodes": [
            {"mesh": 0, "translation": [-2.2, 0.0, 0.0]},
            {"mesh": 0, "rotation": turn([0.0, 1.0, 0.0], 40.0), "scale": [1.0, 0.7, 1.2]},
            {"mesh": 0, "translation": [2.2, 0.0, 0.0], "rotation": turn([1.0, 0.0, 0.0], 20.0),
             "scale": mirrored_scale},
            {"mesh": 0, "translation": [0.0, 0.3, 0.0],
             "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 5}}}},
            {"mesh": 1},
            {"camera": 0, "translation": [0.0, 1.5, 7.0], "rotation": turn([1.0, 0.0, 0.0], -12.0)},
            {"rotation": turn([0.6, 0.8, 0.0], -50.0),
             "extensions": {"KHR_lights_punctual": {"light": 0}}}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.01}}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 0, "TEXCOORD_0": 1},
                             "indices": 2, "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": 3}, "indices": 4, "material": 1}]}
        ],
        "materials": [
            sphere_material,
            {"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1.0],
                                      "metallicFactor": 0.0, "roughnessFactor": 0.8}}
        ],
        "textures": [{"source": 0}, {"source": 1}],
        "images": [{"bufferView": image_view, "mimeType": "image/png"},
                   {"bufferView": bands_view, "mimeType": "image/png"}],
        "buffers": [{"byteLength": bin.len(), "uri": data_uri(&bin)}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": sphere_pos, "componentType": 5126, "count": sphere.len(), "type": "VEC3",
             "min": slo, "max": shi},
            {"bufferView": sphere_uv, "componentType": 5126, "count": uvs.len(), "type": "VEC2"},
            {"bufferView": sphere_idx, "componentType": 5125, "count": sphere_tris.len() * 3,
             "type": "SCALAR"},
            {"bufferView": floor_pos, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": flo, "max": fhi},
            {"bufferView": floor_idx, "componentType": 5125, "count": 6, "type": "SCALAR"},
            {"bufferView": instance_t, "componentType": 5126, "count": 2, "type": "VEC3"}
        ]
    });
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// Renders `scene` to `dir/out` by the path tracer with Owen-scrambled Sobol samples, `spp`
/// per pixel at `size`, with `extra` options; the EXR's path.
fn render_path(
    dir: &std::path::Path,
    scene: &std::path::Path,
    out: &str,
    (spp, size): (&str, &str),
    extra: &[&str],
) -> std::path::PathBuf {
    let out = dir.join(out);
    let mut args = vec![
        s(scene),
        "--integrator",
        "path",
        "--sampler",
        "sobol",
        "--spp",
        spp,
        "--resolution",
        size,
        "-o",
        s(&out),
        "--no-png",
    ];
    args.extend_from_slice(extra);
    render(dir, &args).assert_success();
    out
}

/// The spheres' render (8 spp, 120 × 72, under a blue-grey background and the sun) with
/// `extra` options: its pixels and its object ID pass.
fn render_spheres(
    dir: &std::path::Path,
    scene: &std::path::Path,
    out: &str,
    extra: &[&str],
) -> (Vec<[f32; 3]>, Vec<f32>) {
    let mut args = vec!["--background", "0.4,0.5,0.7", "--passes", "object_id"];
    args.extend_from_slice(extra);
    let out = render_path(dir, scene, out, ("8", "120x72"), &args);
    let pixels = strata::render::output::read_exr_rgb(&out).unwrap().2;
    let (channels, _) = read_channels(&out);
    (pixels, channels["object_id.ID"].clone())
}

/// The mean absolute difference of two images over the mean of the first, in percent.
fn relative_difference(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let (mut diff, mut sum) = (0.0f64, 0.0f64);
    for (p, q) in a.iter().zip(b) {
        for c in 0..3 {
            diff += (p[c] as f64 - q[c] as f64).abs();
            sum += p[c] as f64;
        }
    }
    100.0 * diff / sum
}

/// The same render whether the spheres are instances (Embree's, obvhs's) or flattened copies:
/// the same samples meet the same surfaces, so the images differ only where a placement's
/// rounding moves a hit across an edge (within 0.5% on average; a mirrored sphere drawn
/// unmirrored, whose normal map then bends the other way, differs by several times that).
/// The scene stores the sphere once, and the ID pass names each instance's own node.
#[test]
fn instances_render_as_their_flattened_copies() {
    let dir = tempfile::tempdir().unwrap();
    let scene = shared_spheres(dir.path(), "spheres.gltf", true, None);
    let loaded = load(&scene, &LoadOptions::default()).unwrap();
    let flat = load(
        &scene,
        &LoadOptions {
            flatten_instances: true,
            ..Default::default()
        },
    )
    .unwrap();
    let sphere = outward_sphere().1.len();
    assert_eq!(loaded.prototypes.len(), 1);
    assert_eq!(loaded.instances.len(), 5);
    assert_eq!(loaded.triangles.len(), sphere + 2);
    assert_eq!(flat.triangles.len(), 5 * sphere + 2);
    assert!(flat.prototypes.is_empty() && flat.instances.is_empty());
    // The instances' bounds are their prototype's box placed: around the flattened copies'
    // exact ones, and not far off.
    let (lo, hi) = (loaded.bounds.0, loaded.bounds.1);
    let (want_lo, want_hi) = (flat.bounds.0, flat.bounds.1);
    assert!(
        lo.cmple(want_lo + 1e-4).all() && hi.cmpge(want_hi - 1e-4).all(),
        "bounds {lo}..{hi} do not hold {want_lo}..{want_hi}"
    );
    assert!(
        (lo - want_lo).abs().max(hi - want_hi).max_element() < 0.2,
        "bounds {lo}..{hi} against {want_lo}..{want_hi}"
    );

    let (instanced, ids) = render_spheres(dir.path(), &scene, "instanced.exr", &[]);
    let (copies, flat_ids) =
        render_spheres(dir.path(), &scene, "flat.exr", &["--flatten-instances"]);
    let (obvhs, obvhs_ids) =
        render_spheres(dir.path(), &scene, "obvhs.exr", &["--backend", "obvhs"]);
    let unmirrored = shared_spheres(dir.path(), "unmirrored.gltf", false, None);
    let (control, _) = render_spheres(
        dir.path(),
        &unmirrored,
        "control.exr",
        &["--flatten-instances"],
    );
    let differences = [
        ("Embree instances", relative_difference(&copies, &instanced)),
        ("obvhs instances", relative_difference(&copies, &obvhs)),
        (
            "unmirrored (control)",
            relative_difference(&copies, &control),
        ),
    ];
    eprintln!("differences from the flattened copies, %: {differences:?}");
    assert!(differences[0].1 < 0.5, "{differences:?}");
    assert!(differences[1].1 < 0.5, "{differences:?}");
    assert!(differences[2].1 > 1.5, "{differences:?}");
    // ID passes: each sphere is its own node's (nodes 0 to 3, the two instances of node 3
    // both node 3), the floor node 4's, the sky −1; and the same pixel by pixel but where a
    // hit moved across a silhouette.
    for ids in [&ids, &obvhs_ids] {
        let same = ids.iter().zip(&flat_ids).filter(|(a, b)| a == b).count();
        assert!(
            same as f64 >= 0.995 * ids.len() as f64,
            "{same} of {} ID pixels agree",
            ids.len()
        );
    }
    let mut seen: Vec<i32> = ids.iter().map(|&i| i as i32).collect();
    seen.sort();
    seen.dedup();
    assert_eq!(seen, vec![-1, 0, 1, 2, 3, 4]);
}

/// 100 000 EXT_mesh_gpu_instancing instances of a 32 768-triangle sphere: 3.3·10⁹ triangles
/// placed, whose flattened copy would need about 400 GB. Stored once and instanced, the scene
/// loads, builds and renders within a 1 GiB limit (`--max-memory`, and the process's peak
/// resident memory as `--stats` reports it), the image shows the spheres (ambient occlusion
/// varies over it), and the same scene flattened is refused by the same limit before
/// anything is allocated.
#[test]
fn a_hundred_thousand_instances_render_within_the_memory_of_one() {
    let dir = tempfile::tempdir().unwrap();
    let (points, tris) = inward_geodesic_sphere(6);
    assert_eq!(tris.len(), 32_768);
    let sphere: Vec<f32> = points.iter().flat_map(|p| p.as_vec3().to_array()).collect();
    let indices: Vec<u32> = tris.iter().flat_map(|&[a, b, c]| [a, c, b]).collect();
    let (cols, rows) = (400usize, 250usize);
    let translations: Vec<f32> = (0..rows)
        .flat_map(|r| (0..cols).map(move |c| (c, r)))
        .flat_map(|(c, r)| [2.5 * c as f32 - 500.0, 0.0, -2.5 * r as f32])
        .collect();
    let (bin, views) = buffer_views(&[
        sphere.iter().flat_map(|x| x.to_le_bytes()).collect(),
        indices.iter().flat_map(|x| x.to_le_bytes()).collect(),
        translations.iter().flat_map(|x| x.to_le_bytes()).collect(),
    ]);
    std::fs::write(dir.path().join("spheres.bin"), &bin).unwrap();
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["EXT_mesh_gpu_instancing"],
        "extensionsRequired": ["EXT_mesh_gpu_instancing"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 2}}}},
            {"camera": 0, "translation": [0.0, 12.0, 8.0],
             "rotation": [-0.2588, 0.0, 0.0, 0.9659]}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": bin.len(), "uri": "spheres.bin"}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": points.len(), "type": "VEC3",
             "min": [-1.0, -1.0, -1.0], "max": [1.0, 1.0, 1.0]},
            {"bufferView": 1, "componentType": 5125, "count": indices.len(), "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5126, "count": cols * rows, "type": "VEC3"}
        ]
    });
    let scene = dir.path().join("spheres.gltf");
    std::fs::write(&scene, serde_json::to_vec(&doc).unwrap()).unwrap();
    let out = dir.path().join("spheres.exr");
    let args = [
        s(&scene),
        "--integrator",
        "ao",
        "--spp",
        "4",
        "--resolution",
        "80x48",
        "--max-memory",
        "1GiB",
        "--stats",
        "-o",
        s(&out),
        "--no-png",
    ];
    let run = render(dir.path(), &args);
    assert!(run.status.success(), "{}", run.stderr);
    assert!(
        run.stdout
            .contains("instances: 100000 of 1 meshes stored once, placing 3276800000 triangles"),
        "{}",
        run.stdout
    );
    let peak = run
        .stdout
        .lines()
        .find_map(|l| l.strip_prefix("peak resident memory: "))
        .unwrap_or_else(|| panic!("no peak memory line:\n{}", run.stdout));
    eprintln!("peak resident memory: {peak}");
    let mib: f64 = match peak.split_once(' ') {
        Some((v, "MiB")) => v.parse().unwrap(),
        Some((v, "KiB")) => v.parse::<f64>().unwrap() / 1024.0,
        _ => panic!("peak resident memory of {peak}: more than 1 GiB"),
    };
    assert!(mib < 1024.0, "{peak}");
    let pixels = strata::render::output::read_exr_rgb(&out).unwrap().2;
    let values: Vec<f32> = pixels.iter().map(|p| p[0]).collect();
    let (lo, hi) = values
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(lo < 0.5 && hi > 0.9, "ambient occlusion from {lo} to {hi}");

    let mut flat_args = args.to_vec();
    flat_args.push("--flatten-instances");
    let run = render(dir.path(), &flat_args);
    assert!(!run.status.success(), "the flattened copy was not refused");
    assert_no_panic(&run.stderr);
    assert!(
        run.stderr.contains("--max-memory") && run.stderr.contains("3276800000 triangles"),
        "{}",
        run.stderr
    );
}

/// Alpha MASK inside instances: the banded spheres, stored once with their triangles behind
/// the backends' alpha tests, render as their flattened copies on both backends (within 0.5%),
/// where the same spheres with their alpha ignored (`--no-alpha`) differ by much more.
#[test]
fn masked_instances_render_as_their_flattened_copies() {
    let dir = tempfile::tempdir().unwrap();
    let scene = shared_spheres(dir.path(), "masked.gltf", true, Some("MASK"));
    let loaded = load(&scene, &LoadOptions::default()).unwrap();
    assert_eq!((loaded.prototypes.len(), loaded.instances.len()), (1, 5));
    assert_eq!(
        loaded.summary.alpha_tested_triangles,
        outward_sphere().1.len(),
        "the sphere's triangles, stored once, are alpha-tested"
    );
    let (copies, _) = render_spheres(dir.path(), &scene, "flat.exr", &["--flatten-instances"]);
    let (instanced, _) = render_spheres(dir.path(), &scene, "instanced.exr", &[]);
    let (obvhs, _) = render_spheres(dir.path(), &scene, "obvhs.exr", &["--backend", "obvhs"]);
    let (opaque, _) = render_spheres(dir.path(), &scene, "opaque.exr", &["--no-alpha"]);
    let differences = [
        ("Embree instances", relative_difference(&copies, &instanced)),
        ("obvhs instances", relative_difference(&copies, &obvhs)),
        (
            "alpha ignored (control)",
            relative_difference(&copies, &opaque),
        ),
    ];
    eprintln!("differences from the flattened copies, %: {differences:?}");
    assert!(differences[0].1 < 0.5, "{differences:?}");
    assert!(differences[1].1 < 0.5, "{differences:?}");
    assert!(differences[2].1 > 5.0, "{differences:?}");
}

/// Alpha BLEND inside instances: the banded spheres, half covered, stored once. BLEND's coin
/// reads the world ray's key and the instance, so the instanced spheres flip other coins than
/// their flattened copies (each copy its own triangles): the images agree in the mean over
/// every pixel (within 0.5% per channel); Embree's instances and obvhs's disagree pixel by
/// pixel no more than the two backends do on the flattened copies (1.3% on 28 Nov: where
/// their hits differ in the last bits, a path's later rays differ and flip other coins);
/// and the spheres with their alpha ignored are much brighter or darker (the control).
#[test]
fn blended_instances_render_as_their_flattened_copies() {
    let dir = tempfile::tempdir().unwrap();
    let scene = shared_spheres(dir.path(), "blended.gltf", true, Some("BLEND"));
    let loaded = load(&scene, &LoadOptions::default()).unwrap();
    assert_eq!((loaded.prototypes.len(), loaded.instances.len()), (1, 5));
    let render = |out: &str, extra: &[&str]| {
        let mut args = vec!["--background", "0.4,0.5,0.7"];
        args.extend_from_slice(extra);
        let out = render_path(dir.path(), &scene, out, ("64", "120x72"), &args);
        strata::render::output::read_exr_rgb(&out).unwrap().2
    };
    let copies = render("flat.exr", &["--flatten-instances"]);
    let instanced = render("instanced.exr", &[]);
    let obvhs = render("obvhs.exr", &["--backend", "obvhs"]);
    let obvhs_copies = render(
        "obvhs-flat.exr",
        &["--backend", "obvhs", "--flatten-instances"],
    );
    let opaque = render("opaque.exr", &["--no-alpha"]);
    let mean = |px: &[[f32; 3]]| -> [f64; 3] {
        std::array::from_fn(|c| px.iter().map(|p| p[c] as f64).sum::<f64>() / px.len() as f64)
    };
    let off = |a: &[[f32; 3]], b: &[[f32; 3]]| {
        let (ma, mb) = (mean(a), mean(b));
        (0..3)
            .map(|c| 100.0 * (ma[c] - mb[c]).abs() / mb[c])
            .fold(0.0, f64::max)
    };
    let means = [
        ("Embree instances", off(&instanced, &copies)),
        ("obvhs instances", off(&obvhs, &copies)),
        ("alpha ignored (control)", off(&opaque, &copies)),
    ];
    let backends = relative_difference(&instanced, &obvhs);
    let backends_flat = relative_difference(&copies, &obvhs_copies);
    eprintln!(
        "image means off the flattened copies', %: {means:?}; Embree against obvhs, pixel by \
         pixel: {backends}% (on the copies: {backends_flat}%)"
    );
    assert!(means[0].1 < 0.5, "{means:?}");
    assert!(means[1].1 < 0.5, "{means:?}");
    assert!(means[2].1 > 3.0, "{means:?}");
    assert!(
        backends < 1.5 * backends_flat.max(0.1),
        "the backends disagree on instances by {backends}%, on copies by {backends_flat}%"
    );
}

/// Four glowing spheres, one mesh placed by four nodes (one mirrored, one scaled down; the
/// first `bulbs` of them), over a floor with a matte sphere on it, in the dark: the bulbs are
/// the only light.
fn glowing_bulbs(dir: &std::path::Path, name: &str, bulbs: usize) -> std::path::PathBuf {
    let (sphere, sphere_tris) = outward_sphere();
    let floor = [
        [-4.0, 0.0, 3.0],
        [4.0, 0.0, 3.0],
        [4.0, 0.0, -5.0],
        [-4.0, 0.0, -5.0],
    ];
    let f =
        |v: &[[f32; 3]]| -> Vec<u8> { v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect() };
    let i =
        |v: &[[u32; 3]]| -> Vec<u8> { v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect() };
    let parts = [
        f(&sphere),
        i(&sphere_tris),
        f(&floor),
        i(&[[0, 1, 2], [0, 2, 3]]),
    ];
    let (bin, views) = buffer_views(&parts);
    let placements = [
        json!({"mesh": 0, "translation": [-1.5, 1.2, 0.0], "scale": [0.25, 0.25, 0.25]}),
        json!({"mesh": 0, "translation": [1.5, 1.0, -0.5], "scale": [-0.3, 0.3, 0.3]}),
        json!({"mesh": 0, "translation": [0.0, 2.0, -2.0], "scale": [0.15, 0.15, 0.15]}),
        json!({"mesh": 0, "translation": [0.5, 0.4, 1.2], "scale": [0.2, 0.2, 0.2]}),
    ];
    let mut nodes: Vec<_> = placements[..bulbs].to_vec();
    nodes.push(json!({"mesh": 1}));
    nodes.push(json!({"mesh": 2, "translation": [0.0, 0.7, -0.8], "scale": [0.7, 0.7, 0.7]}));
    nodes.push(json!({"camera": 0, "translation": [0.0, 2.2, 5.5],
                      "rotation": [-0.17, 0.0, 0.0, 0.985]}));
    let roots: Vec<usize> = (0..nodes.len()).collect();
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": roots}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 0}, "indices": 1, "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": 2}, "indices": 3, "material": 1}]},
            {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 0}, "indices": 1, "material": 1}]}
        ],
        "materials": [
            {"emissiveFactor": [1.0, 0.8, 0.6],
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 6.0}},
             "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]}},
            {"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1.0],
                                      "metallicFactor": 0.0, "roughnessFactor": 0.9}}
        ],
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "buffers": [{"byteLength": bin.len(), "uri": data_uri(&bin)}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": sphere.len(), "type": "VEC3",
             "min": [-1.0, -1.0, -1.0], "max": [1.0, 1.0, 1.0]},
            {"bufferView": 1, "componentType": 5125, "count": sphere_tris.len() * 3, "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-4.0, 0.0, -5.0], "max": [4.0, 0.0, 3.0]},
            {"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"}
        ]
    });
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// The bulbs' render (16 spp, 100 × 60, no light but theirs) with `extra` options.
fn render_bulbs(
    dir: &std::path::Path,
    scene: &std::path::Path,
    out: &str,
    extra: &[&str],
) -> Vec<[f32; 3]> {
    let mut args = vec!["--env", "none"];
    args.extend_from_slice(extra);
    let out = render_path(dir, scene, out, ("16", "100x60"), &args);
    strata::render::output::read_exr_rgb(&out).unwrap().2
}

/// Emitting instances: the bulb mesh is stored once, and each instance's triangles are lights
/// of their own, sampled and weighed by MIS as the flattened copies' are. The renders agree
/// within 0.5% on both backends, with MIS and with light sampling alone (where a bulb missing
/// from the light set would be black); the same scene with one bulb fewer differs by much
/// more.
#[test]
fn emitting_instances_light_the_scene_as_their_copies() {
    let dir = tempfile::tempdir().unwrap();
    let scene = glowing_bulbs(dir.path(), "bulbs.gltf", 4);
    let loaded = load(&scene, &LoadOptions::default()).unwrap();
    let sphere = outward_sphere().1.len();
    assert_eq!((loaded.prototypes.len(), loaded.instances.len()), (1, 4));
    assert_eq!(loaded.summary.emissive_triangles, sphere);
    let flat = ["--flatten-instances"];
    let copies = render_bulbs(dir.path(), &scene, "flat.exr", &flat);
    let instanced = render_bulbs(dir.path(), &scene, "instanced.exr", &[]);
    let obvhs = render_bulbs(dir.path(), &scene, "obvhs.exr", &["--backend", "obvhs"]);
    let light = ["--strategy", "light"];
    let copies_light = render_bulbs(
        dir.path(),
        &scene,
        "flat-light.exr",
        &["--strategy", "light", "--flatten-instances"],
    );
    let instanced_light = render_bulbs(dir.path(), &scene, "light.exr", &light);
    let three = glowing_bulbs(dir.path(), "three.gltf", 3);
    let control = render_bulbs(dir.path(), &three, "three.exr", &flat);
    let differences = [
        ("Embree instances", relative_difference(&copies, &instanced)),
        ("obvhs instances", relative_difference(&copies, &obvhs)),
        (
            "light sampling alone",
            relative_difference(&copies_light, &instanced_light),
        ),
        (
            "one bulb fewer (control)",
            relative_difference(&copies, &control),
        ),
    ];
    eprintln!("differences from the flattened copies, %: {differences:?}");
    for d in &differences[..3] {
        assert!(d.1 < 0.5, "{differences:?}");
    }
    assert!(differences[3].1 > 3.0, "{differences:?}");
}
