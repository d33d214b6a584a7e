//! glTF loading: a hand-made node hierarchy lands where hand computation says
//! (tests/data/hierarchy.expected.json, derived by tools/scenes/make_analytic.py without any
//! renderer code), the same file as .glb and with external buffers, and the parts of the
//! Scene later integrators use (lights, materials, cameras).

use std::path::{Path, PathBuf};

use base64::Engine;
use glam::Vec3;
use serde_json::{json, Value};
use strata::scene::{self, LoadOptions, Projection, Scene};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn load(path: &Path) -> Scene {
    scene::load(path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// The scene with every placement of a mesh flattened into world space.
fn load_flat(path: &Path) -> Scene {
    let options = LoadOptions {
        flatten_instances: true,
        ..Default::default()
    };
    scene::load(path, &options).unwrap_or_else(|e| panic!("{e}"))
}

fn vec3(v: &Value) -> Vec3 {
    let a = v.as_array().expect("[x, y, z]");
    Vec3::new(
        a[0].as_f64().unwrap() as f32,
        a[1].as_f64().unwrap() as f32,
        a[2].as_f64().unwrap() as f32,
    )
}

fn near(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol
}

/// True when `got` is `want` up to a cyclic rotation (same winding), never a swap.
fn same_triangle(got: [Vec3; 3], want: [Vec3; 3], tol: f32) -> bool {
    (0..3).any(|r| (0..3).all(|i| near(got[(i + r) % 3], want[i], tol)))
}

/// What hierarchy.expected.json says, per triangle in emission order.
struct Expected {
    triangles: Vec<[Vec3; 3]>,
    /// Per-vertex normals, for triangles of primitives that have them.
    normals: Vec<Option<[Vec3; 3]>>,
    geometric_normals: Vec<Vec3>,
    /// The node (`node_index`) and mesh that hold each triangle.
    origins: Vec<(u32, u32)>,
    tolerance: f32,
}

fn expected() -> Expected {
    let text = std::fs::read_to_string(data("hierarchy.expected.json")).unwrap();
    let e: Value = serde_json::from_str(&text).unwrap();
    let tol = e["tolerance"].as_f64().unwrap() as f32;
    let (mut tris, mut normals, mut ngs) = (Vec::new(), Vec::new(), Vec::new());
    let mut origins = Vec::new();
    for name in e["emission_order"].as_array().unwrap() {
        let node = &e["nodes"][name.as_str().unwrap()];
        for (k, t) in node["triangles"].as_array().unwrap().iter().enumerate() {
            let t = t.as_array().unwrap();
            tris.push([vec3(&t[0]), vec3(&t[1]), vec3(&t[2])]);
            normals.push(node.get("vertex_normals").map(|vn| {
                let vn = vn[k].as_array().unwrap();
                [vec3(&vn[0]), vec3(&vn[1]), vec3(&vn[2])]
            }));
            ngs.push(vec3(&node["geometric_normals"][k]));
            let index = |key: &str| node[key].as_u64().unwrap() as u32;
            origins.push((index("node_index"), index("mesh")));
        }
    }
    assert_eq!(tris.len() as u64, e["total_triangles"].as_u64().unwrap());
    Expected {
        triangles: tris,
        normals,
        geometric_normals: ngs,
        origins,
        tolerance: tol,
    }
}

fn check_hierarchy(scene: &Scene) {
    let Expected {
        triangles: tris,
        normals,
        geometric_normals: ngs,
        origins,
        tolerance: tol,
    } = expected();
    assert_eq!(scene.triangles.len(), tris.len(), "triangle count");
    for (i, want) in tris.iter().enumerate() {
        let prim = i as u32;
        let got = scene.triangle_positions(prim);
        assert!(
            same_triangle(got, *want, tol),
            "triangle {i}: got {got:?}, want {want:?}"
        );
        // The document's node and mesh (A and B share mesh 0); both primitives name
        // material 0.
        let origin = scene.origin(prim, strata::ray::NO_INSTANCE);
        let (node, mesh) = origins[i];
        assert_eq!(
            (origin.node, origin.mesh, origin.material),
            (Some(node), Some(mesh), Some(0)),
            "triangle {i}'s origin"
        );
        let ng = (got[1] - got[0]).cross(got[2] - got[0]).normalize();
        assert!(
            near(ng, ngs[i], tol),
            "triangle {i}: geometric normal {ng} vs {}",
            ngs[i]
        );
        match normals[i] {
            Some(vn) => {
                // Shading normals, matched to the rotation the positions matched.
                let idx = scene.triangles[i];
                for (k, &v) in idx.iter().enumerate() {
                    let n = scene.normals[v as usize];
                    let want = vn
                        .iter()
                        .zip(want)
                        .find(|(_, p)| near(got[k], **p, tol))
                        .unwrap()
                        .0;
                    assert!(
                        near(n, *want, tol),
                        "triangle {i} vertex {k}: normal {n} vs {want}"
                    );
                }
            }
            None => {
                // No NORMAL attribute: shaded flat with the geometric normal.
                assert_eq!(
                    scene.shading_normal(prim, 0.3, 0.3),
                    None,
                    "triangle {i} should be flat"
                );
            }
        }
    }
    assert_eq!(scene.cameras.len(), 1);
    let cam = &scene.cameras[0];
    assert!(near(
        cam.to_world.transform_point3(Vec3::ZERO),
        Vec3::new(1.5, 7.0, 30.0),
        1e-6
    ));
    assert!(
        matches!(cam.projection, Projection::Perspective { yfov } if (yfov - 0.8).abs() < 1e-6)
    );
}

/// The hierarchy loaded with its shared mesh instanced: every expected triangle is one
/// placed by its own node (an instance's, or a flat one), with its node, mesh and front
/// normal. An instance keeps its mesh's winding where a mirroring node's flattened copy is
/// rewound, so positions match up to winding; the front is the normal's, carried by the
/// instance's inverse transpose.
fn check_instanced_hierarchy(scene: &Scene) {
    let e = expected();
    assert!(!scene.instances.is_empty(), "no instances");
    let front = |p: [Vec3; 3]| (p[1] - p[0]).cross(p[2] - p[0]);
    let mut world = Vec::new();
    for t in scene.flat_triangles() {
        let p = scene.triangle_positions(t);
        let o = scene.origin(t, strata::ray::NO_INSTANCE);
        world.push((p, o.node, o.mesh, front(p).normalize()));
    }
    for (k, instance) in scene.instances.iter().enumerate() {
        let k = k as u32;
        for t in scene.prototypes[instance.prototype as usize]
            .triangles
            .clone()
        {
            let n = scene.normal_to_world(k, front(scene.triangle_positions(t)));
            let o = scene.origin(t, k);
            world.push((scene.placed_positions(t, k), o.node, o.mesh, n));
        }
    }
    assert_eq!(world.len(), e.triangles.len(), "triangles placed");
    for (i, want) in e.triangles.iter().enumerate() {
        let (node, mesh) = e.origins[i];
        let found = world.iter().any(|&(p, n, m, ng)| {
            (n, m) == (Some(node), Some(mesh))
                && (same_triangle(p, *want, e.tolerance)
                    || same_triangle([p[0], p[2], p[1]], *want, e.tolerance))
                && near(ng, e.geometric_normals[i], e.tolerance)
        });
        assert!(
            found,
            "triangle {i} of node {node}: {want:?} is placed nowhere"
        );
    }
}

#[test]
fn node_hierarchy_lands_where_hand_computation_says() {
    check_hierarchy(&load_flat(&data("hierarchy.gltf")));
    check_instanced_hierarchy(&load(&data("hierarchy.gltf")));
}

/// The hierarchy file's JSON and its embedded buffer.
fn hierarchy_parts() -> (Value, Vec<u8>) {
    let doc: Value =
        serde_json::from_str(&std::fs::read_to_string(data("hierarchy.gltf")).unwrap()).unwrap();
    let uri = doc["buffers"][0]["uri"].as_str().unwrap();
    let payload = uri.split_once(";base64,").unwrap().1;
    let bin = base64::engine::general_purpose::STANDARD
        .decode(payload)
        .unwrap();
    (doc, bin)
}

#[test]
fn binary_gltf_gives_the_same_scene() {
    let (mut doc, mut bin) = hierarchy_parts();
    doc["buffers"][0].as_object_mut().unwrap().remove("uri");
    let mut json = serde_json::to_vec(&doc).unwrap();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    // GLB (glTF 2.0 §4.4): header, JSON chunk, BIN chunk, little-endian.
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut glb = Vec::new();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(&json);
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hierarchy.glb");
    std::fs::write(&path, glb).unwrap();
    check_hierarchy(&load_flat(&path));
}

#[test]
fn external_buffers_are_found_beside_the_file() {
    let (mut doc, bin) = hierarchy_parts();
    // A space in the name, percent-encoded in the URI as RFC 3986 asks.
    doc["buffers"][0]["uri"] = json!("hierarchy%20data.bin");
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("hierarchy data.bin"), bin).unwrap();
    let path = dir.path().join("hierarchy.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    check_hierarchy(&load_flat(&path));

    std::fs::remove_file(dir.path().join("hierarchy data.bin")).unwrap();
    let err = scene::load(&path, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("hierarchy.gltf") && err.contains("hierarchy data.bin"),
        "{err}"
    );
}

#[test]
fn lights_materials_and_cameras_reach_the_scene() {
    let (mut doc, bin) = hierarchy_parts();
    let dir = tempfile::tempdir().unwrap();
    // A real PNG: the loader reads its header (for the memory estimate), not its pixels.
    std::fs::write(dir.path().join("tex.png"), png(1, 1)).unwrap();
    doc["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_materials_emissive_strength"]);
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 4.0, "range": 10.0},
        {"type": "spot", "intensity": 2.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
        {"type": "directional", "color": [0.0, 1.0, 0.0], "intensity": 3.0}
    ]}});
    // Light nodes: a point at (1, 2, 3) under R's transform is moved by it; a spot and a
    // directional light pointing down −Y (rotated −90° about X).
    let q = std::f64::consts::FRAC_1_SQRT_2;
    let nodes = doc["nodes"].as_array_mut().unwrap();
    nodes.push(json!({"name": "point", "translation": [0.0, 1.0, 0.0], "extensions": {"KHR_lights_punctual": {"light": 0}}}));
    nodes.push(json!({"name": "spot", "translation": [0.0, 4.0, 0.0], "rotation": [-q, 0.0, 0.0, q], "extensions": {"KHR_lights_punctual": {"light": 1}}}));
    nodes.push(json!({"name": "sun", "rotation": [-q, 0.0, 0.0, q], "extensions": {"KHR_lights_punctual": {"light": 2}}}));
    doc["scenes"][0]["nodes"] = json!([0, 3, 4, 5, 6, 7]);
    doc["materials"][0] = json!({
        "name": "glow",
        "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 1.0, 1.0], "baseColorTexture": {"index": 0}, "metallicFactor": 0.0},
        "emissiveFactor": [1.0, 0.5, 0.0],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 8.0}},
        "doubleSided": true
    });
    doc["textures"] = json!([{"source": 0, "sampler": 0}]);
    doc["samplers"] = json!([{"wrapS": 33071, "wrapT": 33648}]);
    doc["images"] = json!([{"uri": "tex.png"}]);
    let path = dir.path().join("lit.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    std::fs::write(dir.path().join("unused.bin"), &bin).unwrap();
    let s = load(&path);

    assert_eq!(s.lights.len(), 3);
    match &s.lights[0] {
        scene::Light::Point {
            position,
            intensity,
            range,
        } => {
            assert!(
                near(*position, Vec3::new(0.0, 1.0, 0.0), 1e-6),
                "{position}"
            );
            assert!(
                near(*intensity, Vec3::new(4.0, 2.0, 1.0), 1e-6),
                "colour × intensity: {intensity}"
            );
            assert_eq!(*range, Some(10.0));
        }
        other => panic!("expected a point light, got {other:?}"),
    }
    match &s.lights[1] {
        scene::Light::Spot {
            position,
            direction,
            inner_cone_angle,
            outer_cone_angle,
            ..
        } => {
            assert!(near(*position, Vec3::new(0.0, 4.0, 0.0), 1e-6));
            assert!(
                near(*direction, Vec3::NEG_Y, 1e-6),
                "spot points down its −Z: {direction}"
            );
            assert_eq!((*inner_cone_angle, *outer_cone_angle), (0.2, 0.5));
        }
        other => panic!("expected a spot light, got {other:?}"),
    }
    match &s.lights[2] {
        scene::Light::Directional {
            direction,
            irradiance,
        } => {
            assert!(near(*direction, Vec3::NEG_Y, 1e-6));
            assert!(near(*irradiance, Vec3::new(0.0, 3.0, 0.0), 1e-6));
        }
        other => panic!("expected a directional light, got {other:?}"),
    }
    // Material 0 of the file is scene material 1 (0 is glTF's default material).
    let m = &s.materials[1];
    assert_eq!(m.name.as_deref(), Some("glow"));
    assert!(
        near(m.emissive, Vec3::new(8.0, 4.0, 0.0), 1e-6),
        "emissive × strength: {}",
        m.emissive
    );
    assert!(m.double_sided);
    let tex = m.base_color_texture.as_ref().expect("base colour texture");
    assert_eq!(
        (tex.wrap_s, tex.wrap_t),
        (scene::Wrap::ClampToEdge, scene::Wrap::MirroredRepeat)
    );
    assert_eq!(
        s.images,
        vec![scene::ImageSource::File(dir.path().join("tex.png"))]
    );
    assert!(s.triangle_materials.iter().all(|&m| m == 1));
    assert_eq!(s.summary.emissive_triangles, s.triangles.len());
    assert_eq!(s.summary.punctual_lights, 3);
    assert_eq!(s.summary.textures, 1);
}

#[test]
fn bad_files_name_the_file_and_the_problem() {
    let cases = [
        ("not_gltf.gltf", "not a glTF"),
        ("required_extension.gltf", "EXT_texture_avif"),
        ("truncated.glb", "binary glTF"),
        ("missing_buffer.gltf", "does-not-exist.bin"),
    ];
    for (file, words) in cases {
        let path = data("bad").join(file);
        let err = scene::load(&path, &LoadOptions::default())
            .expect_err(file)
            .to_string();
        assert!(err.contains(file) && err.contains(words), "{file}: {err}");
        assert!(!err.contains('\n'), "one line: {err}");
    }
}

/// A file whose meshes hold no triangles (points here) loads as an empty scene, with one
/// warning that says so.
#[test]
fn a_file_without_triangles_loads_empty_with_a_warning() {
    let path = data("bad").join("no_triangles.gltf");
    let s = scene::load(&path, &LoadOptions::default()).unwrap();
    assert!(s.triangles.is_empty());
    assert_eq!(s.bounds, (glam::Vec3::ZERO, glam::Vec3::ZERO));
    let warned: Vec<_> = s
        .load_warnings
        .iter()
        .filter(|w| w.contains("no triangles") && w.contains("points or lines"))
        .collect();
    assert_eq!(warned.len(), 1, "{:?}", s.load_warnings);
}

#[test]
fn accessor_past_its_buffer_is_an_error_not_a_panic() {
    let (mut doc, _) = hierarchy_parts();
    doc["accessors"][0]["count"] = json!(1_000_000_000_000u64);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let err = scene::load(&path, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("accessor 0") && err.contains("past the end"),
        "{err}"
    );

    let (mut doc, _) = hierarchy_parts();
    doc["bufferViews"][2]["byteOffset"] = json!(4000);
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let err = scene::load(&path, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("bufferView 2"), "{err}");
}

#[test]
fn cyclic_node_graph_is_refused() {
    let (mut doc, _) = hierarchy_parts();
    doc["nodes"][1]["children"] = json!([0]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cycle.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let err = scene::load(&path, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("cycle"), "{err}");
}

/// What a file asks for that strata does not render is said, once, with what it looks like
/// instead: extensions it uses (file-level), each material's dropped inputs (for the
/// integrators that shade materials), COLOR_0; and `--stats` counts textures by role. A
/// material that renders as written, and an extension strata honours, say nothing.
#[test]
fn what_is_not_rendered_gets_one_warning_each() {
    let (mut doc, bin) = hierarchy_parts();
    let dir = tempfile::tempdir().unwrap();
    doc["extensionsUsed"] = json!([
        "KHR_materials_emissive_strength",
        "KHR_materials_diffuse_transmission",
        "KHR_materials_variants"
    ]);
    doc["materials"][0] = json!({
        "name": "coated",
        "pbrMetallicRoughness": {
            "metallicFactor": 0.5, "roughnessFactor": 0.25,
            "metallicRoughnessTexture": {"index": 0}
        },
        "normalTexture": {"index": 0, "scale": 0.5},
        "occlusionTexture": {"index": 0},
        "alphaMode": "MASK", "alphaCutoff": 0.3,
        "extensions": {
            "KHR_materials_diffuse_transmission": {"diffuseTransmissionFactor": 0.5},
            "KHR_materials_emissive_strength": {"emissiveStrength": 2.0}
        }
    });
    doc["materials"]
        .as_array_mut()
        .unwrap()
        .push(json!({"name": "plain", "pbrMetallicRoughness": {"metallicFactor": 0.0}}));
    // The first primitive takes the second material too, so that both are in use.
    let meshes = doc["meshes"].as_array_mut().unwrap();
    meshes[0]["primitives"][0]["material"] = json!(1);
    doc["textures"] = json!([{"source": 0}]);
    doc["images"] = json!([{"uri": "tex.png"}]);
    std::fs::write(dir.path().join("tex.png"), b"not decoded at load").unwrap();
    let path = dir.path().join("unrendered.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    std::fs::write(dir.path().join("unused.bin"), &bin).unwrap();
    let s = load(&path);

    let file_level: Vec<&String> = s.load_warnings.iter().collect();
    let says = |w: &[&String], words: &[&str]| {
        w.iter()
            .filter(|l| words.iter().all(|word| l.contains(word)))
            .count()
    };
    assert_eq!(
        says(
            &file_level,
            &["KHR_materials_diffuse_transmission", "ignores"]
        ),
        1,
        "{file_level:?}"
    );
    assert_eq!(
        says(&file_level, &["KHR_materials_variants", "default material"]),
        1,
        "{file_level:?}"
    );
    assert_eq!(
        says(&file_level, &["emissive_strength"]),
        0,
        "{file_level:?}"
    );

    let materials = s.material_warnings();
    let refs: Vec<&String> = materials.iter().collect();
    let coated: Vec<&String> = refs
        .iter()
        .copied()
        .filter(|l| l.contains("'coated'"))
        .collect();
    // One line per kind of input, each naming the material.
    assert_eq!(coated.len(), 2, "a line per kind: {materials:?}");
    for words in [
        &["0 'coated'", "occlusion texture"][..],
        &["0 'coated'", "KHR_materials_diffuse_transmission"],
    ] {
        assert_eq!(says(&coated, words), 1, "{words:?} in {coated:?}");
    }
    assert!(
        coated.iter().all(|l| !l.contains("emissive_strength")),
        "{coated:?}"
    );
    // Metallic, roughness and the normal map are rendered: nothing is said about them.
    assert!(!coated[0].contains("metallic"), "{coated:?}");
    assert!(!coated[0].contains("normal"), "{coated:?}");
    // `plain` (metallic 0, roughness 1 by default) renders as written.
    assert!(
        !materials.iter().any(|l| l.contains("'plain'")),
        "{materials:?}"
    );

    let m = &s.materials[1];
    assert_eq!(m.normal_scale, 0.5);
    assert_eq!(m.alpha_mode, scene::AlphaMode::Mask(0.3));
    // MASK and BLEND are rendered (alpha coverage): no warning speaks of alpha.
    assert!(!coated[0].contains("alpha"), "{coated:?}");
    let roles = s.summary.texture_roles;
    assert_eq!(
        (
            roles.base_color,
            roles.metallic_roughness,
            roles.normal,
            roles.occlusion
        ),
        (0, 1, 1, 1)
    );
}

/// KHR_materials_ior: read, honoured when required, silent when used; an index below 1 is
/// replaced by glTF's 1.5 with a warning naming the material.
#[test]
fn the_index_of_refraction_is_read() {
    let (mut doc, _) = hierarchy_parts();
    let dir = tempfile::tempdir().unwrap();
    doc["extensionsUsed"] = json!(["KHR_materials_ior"]);
    doc["extensionsRequired"] = json!(["KHR_materials_ior"]);
    doc["materials"][0] = json!({
        "name": "water",
        "extensions": {"KHR_materials_ior": {"ior": 1.33}}
    });
    doc["materials"]
        .as_array_mut()
        .unwrap()
        .push(json!({"name": "odd", "extensions": {"KHR_materials_ior": {"ior": 0.5}}}));
    let meshes = doc["meshes"].as_array_mut().unwrap();
    meshes[0]["primitives"][0]["material"] = json!(1);
    let path = dir.path().join("ior.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let s = load(&path);
    let named = |n: &str| {
        s.materials
            .iter()
            .find(|m| m.name.as_deref() == Some(n))
            .unwrap()
    };
    assert_eq!(named("water").ior, 1.33);
    assert_eq!(named("odd").ior, 1.5);
    let odd: Vec<&String> = (s.load_warnings.iter())
        .filter(|w| w.contains("'odd'") && w.contains("0.5"))
        .collect();
    assert_eq!(odd.len(), 1, "{:?}", s.load_warnings);
    assert!(
        !s.load_warnings.iter().any(|w| w.contains("ignores")),
        "{:?}",
        s.load_warnings
    );
    assert!(s.material_warnings().iter().all(|w| !w.contains("ior")));
}

/// Loads `doc` with `material` (named 'bad') as its only material from `dir/bad.gltf`, and
/// checks that it is refused with one message naming the file, the material, `extension` and
/// `words`.
fn assert_material_refused(
    dir: &Path,
    doc: &mut Value,
    material: Value,
    extension: &str,
    words: &str,
) {
    doc["materials"] = json!([material]);
    let path = dir.join("bad.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let err = scene::load(&path, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    for w in ["bad.gltf", "'bad'", extension, words] {
        assert!(err.contains(w), "{w:?} missing from: {err}");
    }
}

/// KHR_materials_anisotropy: strength, rotation and texture read, honoured when required,
/// silent when rendered; a strength of 0 is no anisotropy; bad values are refused naming the
/// file, the material and the property; glass with anisotropy says its glass renders
/// isotropic.
#[test]
fn the_anisotropy_is_read() {
    let (mut doc, _) = hierarchy_parts();
    let dir = tempfile::tempdir().unwrap();
    doc["extensionsUsed"] = json!(["KHR_materials_anisotropy", "KHR_materials_transmission"]);
    doc["extensionsRequired"] = json!(["KHR_materials_anisotropy"]);
    let aniso = |name: &str, ext: Value| json!({"name": name, "extensions": {"KHR_materials_anisotropy": ext}});
    doc["materials"] = json!([
        aniso(
            "brushed",
            json!({"anisotropyStrength": 0.6, "anisotropyRotation": 1.57, "anisotropyTexture": {"index": 0}})
        ),
        aniso("none", json!({"anisotropyRotation": 0.5})),
        {"name": "glass", "extensions": {
            "KHR_materials_anisotropy": {"anisotropyStrength": 1.0},
            "KHR_materials_transmission": {"transmissionFactor": 1.0}}},
    ]);
    doc["textures"] = json!([{"source": 0}]);
    doc["images"] = json!([{"uri": "tex.png"}]);
    std::fs::write(dir.path().join("tex.png"), b"not decoded at load").unwrap();
    let path = dir.path().join("aniso.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let s = load(&path);
    let named = |n: &str| {
        s.materials
            .iter()
            .find(|m| m.name.as_deref() == Some(n))
            .unwrap()
    };
    let brushed = named("brushed")
        .layers
        .anisotropy
        .clone()
        .expect("anisotropy");
    assert_eq!((brushed.strength, brushed.rotation), (0.6, 1.57));
    assert_eq!(brushed.texture.expect("a texture").image, 0);
    assert!(named("brushed").needs_tangents());
    assert_eq!(named("none").layers.anisotropy, None);
    assert!(!named("none").needs_tangents());
    assert!(
        !s.load_warnings.iter().any(|w| w.contains("ignores")),
        "{:?}",
        s.load_warnings
    );
    assert!(s
        .material_warnings()
        .iter()
        .all(|w| !w.contains("anisotropy")));
    let glass: Vec<&String> = (s.load_warnings.iter())
        .filter(|w| w.contains("'glass'") && w.contains("isotropic"))
        .collect();
    assert_eq!(glass.len(), 1, "{:?}", s.load_warnings);

    for (ext, words) in [
        (json!({"anisotropyStrength": 1.5}), "anisotropyStrength 1.5"),
        (
            json!({"anisotropyStrength": 0.5, "anisotropyRotation": "up"}),
            "anisotropyRotation",
        ),
        (
            json!({"anisotropyStrength": 0.5, "anisotropyTexture": {"index": 7}}),
            "texture 7",
        ),
    ] {
        let bad = aniso("bad", ext);
        assert_material_refused(dir.path(), &mut doc, bad, "KHR_materials_anisotropy", words);
    }
}

/// KHR_materials_dispersion: read, honoured when required, silent on a refracting volume;
/// on a material without one it warns that there is nothing to disperse; a negative value is
/// refused naming the file and the material.
#[test]
fn the_dispersion_is_read() {
    let (mut doc, _) = hierarchy_parts();
    let dir = tempfile::tempdir().unwrap();
    doc["extensionsUsed"] = json!([
        "KHR_materials_dispersion",
        "KHR_materials_transmission",
        "KHR_materials_volume"
    ]);
    doc["extensionsRequired"] = json!(["KHR_materials_dispersion"]);
    let material = |name: &str, dispersion: Value, volume: bool| {
        let mut ext = json!({"KHR_materials_dispersion": {"dispersion": dispersion}});
        if volume {
            ext["KHR_materials_transmission"] = json!({"transmissionFactor": 1.0});
            ext["KHR_materials_volume"] = json!({"thicknessFactor": 1.0});
        }
        json!({"name": name, "extensions": ext})
    };
    doc["materials"] = json!([
        material("prism", json!(0.6), true),
        material("painted", json!(0.6), false),
    ]);
    let path = dir.path().join("dispersion.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let s = load(&path);
    let named = |n: &str| {
        s.materials
            .iter()
            .find(|m| m.name.as_deref() == Some(n))
            .unwrap()
    };
    assert_eq!(named("prism").dispersion, 0.6);
    let said = |n: &str| {
        (s.load_warnings.iter())
            .filter(|w| w.contains(n) && w.contains("KHR_materials_dispersion"))
            .count()
    };
    assert_eq!(
        (said("'prism'"), said("'painted'")),
        (0, 1),
        "{:?}",
        s.load_warnings
    );
    assert!(!s.load_warnings.iter().any(|w| w.contains("ignores")));

    let bad = material("bad", json!(-0.5), true);
    assert_material_refused(
        dir.path(),
        &mut doc,
        bad,
        "KHR_materials_dispersion",
        "-0.5",
    );
}

/// KHR_materials_iridescence: factor, film index, thickness range and textures read with the
/// extension's defaults (index 1.3, 100–400 nm), honoured when required, silent when
/// rendered; a factor of 0 is no film; bad values are refused naming the file, the material
/// and the property; glass with a film says its glass renders without it.
#[test]
fn the_iridescence_is_read() {
    let (mut doc, _) = hierarchy_parts();
    let dir = tempfile::tempdir().unwrap();
    doc["extensionsUsed"] = json!(["KHR_materials_iridescence", "KHR_materials_transmission"]);
    doc["extensionsRequired"] = json!(["KHR_materials_iridescence"]);
    let film = |name: &str, ext: Value| json!({"name": name, "extensions": {"KHR_materials_iridescence": ext}});
    doc["materials"] = json!([
        film(
            "bubble",
            json!({"iridescenceFactor": 0.8, "iridescenceIor": 1.33,
                   "iridescenceThicknessMinimum": 250.0, "iridescenceThicknessMaximum": 900.0,
                   "iridescenceTexture": {"index": 0}, "iridescenceThicknessTexture": {"index": 0}})
        ),
        film("plain", json!({"iridescenceFactor": 1.0})),
        film("off", json!({"iridescenceIor": 1.8})),
        {"name": "glass", "extensions": {
            "KHR_materials_iridescence": {"iridescenceFactor": 1.0},
            "KHR_materials_transmission": {"transmissionFactor": 1.0}}},
    ]);
    doc["textures"] = json!([{"source": 0}]);
    doc["images"] = json!([{"uri": "tex.png"}]);
    std::fs::write(dir.path().join("tex.png"), b"not decoded at load").unwrap();
    let path = dir.path().join("film.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let s = load(&path);
    let named = |n: &str| {
        s.materials
            .iter()
            .find(|m| m.name.as_deref() == Some(n))
            .unwrap()
    };
    let bubble = named("bubble").layers.iridescence.clone().expect("a film");
    assert_eq!(
        (
            bubble.factor,
            bubble.ior,
            bubble.thickness_min,
            bubble.thickness_max
        ),
        (0.8, 1.33, 250.0, 900.0)
    );
    assert!(bubble.texture.is_some() && bubble.thickness_texture.is_some());
    let plain = named("plain").layers.iridescence.clone().expect("a film");
    assert_eq!(
        (plain.ior, plain.thickness_min, plain.thickness_max),
        (1.3, 100.0, 400.0)
    );
    assert_eq!(named("off").layers.iridescence, None);
    assert!(
        !s.load_warnings.iter().any(|w| w.contains("ignores")),
        "{:?}",
        s.load_warnings
    );
    assert!(s
        .material_warnings()
        .iter()
        .all(|w| !w.contains("iridescence")));
    let glass: Vec<&String> = (s.load_warnings.iter())
        .filter(|w| w.contains("'glass'") && w.contains("thin film"))
        .collect();
    assert_eq!(glass.len(), 1, "{:?}", s.load_warnings);

    for (ext, words) in [
        (json!({"iridescenceFactor": 2.0}), "iridescenceFactor 2.0"),
        (
            json!({"iridescenceFactor": 1.0, "iridescenceIor": 0.5}),
            "iridescenceIor 0.5",
        ),
        (
            json!({"iridescenceFactor": 1.0, "iridescenceThicknessMaximum": -3.0}),
            "iridescenceThicknessMaximum -3.0",
        ),
    ] {
        let bad = film("bad", ext);
        assert_material_refused(
            dir.path(),
            &mut doc,
            bad,
            "KHR_materials_iridescence",
            words,
        );
    }
}

/// KHR_materials_transmission and KHR_materials_volume: read, rendered (no warning); a volume
/// of thickness 0 is a thin wall; a volume without transmission is nothing; bad values are
/// refused naming the material.
#[test]
fn transmission_and_volume_are_read() {
    let (mut doc, _) = hierarchy_parts();
    let dir = tempfile::tempdir().unwrap();
    doc["extensionsUsed"] = json!(["KHR_materials_transmission", "KHR_materials_volume"]);
    doc["extensionsRequired"] = json!(["KHR_materials_transmission"]);
    let glass = |name: &str, transmission: Option<f32>, volume: Value| {
        let mut ext = json!({"KHR_materials_volume": volume});
        if let Some(t) = transmission {
            ext["KHR_materials_transmission"] = json!({"transmissionFactor": t});
        }
        json!({"name": name, "extensions": ext})
    };
    doc["materials"] = json!([
        glass(
            "tinted",
            Some(0.75),
            json!({"thicknessFactor": 0.5, "attenuationColor": [0.5, 0.25, 1.0], "attenuationDistance": 2.0})
        ),
        glass("wall", Some(1.0), json!({"thicknessFactor": 0.0})),
        glass("opaque", None, json!({"thicknessFactor": 1.0})),
    ]);
    let path = dir.path().join("glass.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let s = load(&path);
    let named = |n: &str| {
        s.materials
            .iter()
            .find(|m| m.name.as_deref() == Some(n))
            .unwrap()
    };
    let tinted = named("tinted");
    assert_eq!(tinted.transmission.factor, 0.75);
    let volume = tinted.transmission.volume.expect("a volume");
    assert_eq!(volume.attenuation_distance, 2.0);
    // σ_a = −ln(colour) / distance: ln 2 / 2, ln 4 / 2, 0.
    let sigma = volume.absorption();
    let want = [2f32.ln() / 2.0, 4f32.ln() / 2.0, 0.0];
    for c in 0..3 {
        assert!(
            (sigma[c] - want[c]).abs() < 1e-6,
            "{sigma} against {want:?}"
        );
    }
    assert_eq!(
        (
            named("wall").transmission.factor,
            named("wall").transmission.volume
        ),
        (1.0, None)
    );
    assert_eq!(
        (
            named("opaque").transmission.factor,
            named("opaque").transmission.volume
        ),
        (0.0, None)
    );
    assert!(
        !s.load_warnings.iter().any(|w| w.contains("ignores")),
        "{:?}",
        s.load_warnings
    );
    // A factor past 1 is refused, naming the material.
    doc["materials"][0]["extensions"]["KHR_materials_transmission"]["transmissionFactor"] =
        json!(1.5);
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let err = scene::load(&path, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("'tinted'") && err.contains("transmissionFactor 1.5"),
        "{err}"
    );
}

/// The memory estimate counts each decoded texture as strata keeps it: RGBA in f32, 16 bytes
/// a texel, once for each colour encoding its textures read it with (sRGB for base colour,
/// emission, sheen and specular colour; linear for the others), and the base colour of a
/// MASK or BLEND material once more as its alpha channel (f32, 4 bytes a texel). An image
/// that cannot be read counts nothing.
#[test]
fn the_memory_estimate_counts_decoded_textures() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tex.png"), png(37, 23)).unwrap();
    let wall: Value = serde_json::from_slice(
        &std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/ao-wall.gltf")).unwrap(),
    )
    .unwrap();
    let estimate = |name: &str, edit: &dyn Fn(&mut Value)| {
        let mut doc = wall.clone();
        doc["images"] = json!([{"uri": "tex.png"}, {"uri": "absent.png"}]);
        doc["textures"] = json!([{"source": 0}, {"source": 1}]);
        edit(&mut doc);
        let path = dir.path().join(format!("{name}.gltf"));
        std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
        load(&path).memory_estimate
    };
    let plain = estimate("plain", &|_| {});
    assert_eq!((plain.textures, plain.texture_bytes), (0, 0));
    let texels: u64 = 37 * 23;
    let pbr = "/materials/0/pbrMetallicRoughness";
    type Edit = Box<dyn Fn(&mut Value)>;
    let cases: Vec<(&str, Edit, u64, u64)> = vec![
        (
            "base_colour",
            Box::new(move |d| {
                d.pointer_mut(pbr).unwrap()["baseColorTexture"] = json!({"index": 0})
            }),
            1,
            texels * 16,
        ),
        (
            "base_colour_and_emission_one_srgb_decode",
            Box::new(move |d| {
                d.pointer_mut(pbr).unwrap()["baseColorTexture"] = json!({"index": 0});
                d["materials"][0]["emissiveTexture"] = json!({"index": 0});
            }),
            1,
            texels * 16,
        ),
        (
            "base_colour_and_metallic_roughness_srgb_and_linear",
            Box::new(move |d| {
                d.pointer_mut(pbr).unwrap()["baseColorTexture"] = json!({"index": 0});
                d.pointer_mut(pbr).unwrap()["metallicRoughnessTexture"] = json!({"index": 0});
            }),
            2,
            texels * 32,
        ),
        (
            "mask_base_colour_and_its_alpha",
            Box::new(move |d| {
                d.pointer_mut(pbr).unwrap()["baseColorTexture"] = json!({"index": 0});
                d["materials"][0]["alphaMode"] = json!("MASK");
            }),
            1,
            texels * 16 + texels * 4,
        ),
        (
            "clearcoat_extension",
            Box::new(|d| {
                d["materials"][0]["extensions"] = json!({"KHR_materials_clearcoat":
                    {"clearcoatFactor": 1.0, "clearcoatTexture": {"index": 0}}});
            }),
            1,
            texels * 16,
        ),
        (
            "missing_image",
            Box::new(move |d| {
                d.pointer_mut(pbr).unwrap()["baseColorTexture"] = json!({"index": 1})
            }),
            0,
            0,
        ),
    ];
    let without_input = |e: &scene::MemoryEstimate| e.bytes() - e.input_bytes;
    for (name, edit, textures, bytes) in cases {
        let e = estimate(name, &*edit);
        assert_eq!((e.textures, e.texture_bytes), (textures, bytes), "{name}");
        // The file's own size changes with the edit; the rest grows by the textures alone.
        assert_eq!(without_input(&e), without_input(&plain) + bytes, "{name}");
    }
}

/// A grey RGB PNG of `width × height` pixels.
fn png(width: u32, height: u32) -> Vec<u8> {
    let mut png = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut png),
        &vec![200; (width * height * 3) as usize],
        width,
        height,
        image::ExtendedColorType::Rgb8,
    )
    .unwrap();
    png
}
