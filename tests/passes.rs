//! Render passes through the binary (`--passes`): one EXR holds the beauty as R, G, B and each
//! pass under OpenEXR's `layer.channel` names, with header attributes saying what each layer
//! is. A plane of known colour seen head-on by an orthographic camera at a known distance:
//! its albedo layer is the base colour, its normal layer the plane's normal, its depth layer
//! the distance, in every pixel; and keeping the passes changes no bit of the beauty. The ID
//! passes give back the glTF indices of a scene of squares (nodes sharing a mesh, a mesh of
//! two materials, a primitive without one) exactly, from each pixel's sample 0, on both
//! backends and whatever the threads, rounds or stopping.

mod common;

use std::collections::HashMap;
use std::path::Path;

use common::*;
use serde_json::json;

const BASE: [f32; 3] = [0.2, 0.4, 0.6];
/// The camera's height above the plane.
const HEIGHT: f32 = 2.5;

/// A square of half-width `half` in the plane z = `z`, facing +z (`up`) or −z, of material
/// `material`.
struct Square {
    z: f32,
    half: f32,
    up: bool,
    material: u32,
}

/// A glTF of `squares` with `materials` and an orthographic camera at z = [`HEIGHT`]
/// looking down −z whose view is x and y in [−1, 1], written to `dir/name`.
fn squares_scene(
    dir: &Path,
    name: &str,
    squares: &[Square],
    materials: Vec<serde_json::Value>,
) -> std::path::PathBuf {
    let mut bin: Vec<u8> = Vec::new();
    let (mut accessors, mut views, mut meshes, mut nodes) = (vec![], vec![], vec![], vec![]);
    for (i, sq) in squares.iter().enumerate() {
        let (h, z) = (sq.half, sq.z);
        let positions = [[-h, h, z], [-h, -h, z], [h, -h, z], [h, h, z]];
        // TEXCOORD_0: (0, 0) at the top-left corner, u along +x, v along −y.
        let uvs = [[0.0f32, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]];
        // Counter-clockwise seen from the side the square faces.
        let indices: [u32; 6] = match sq.up {
            true => [0, 1, 2, 0, 2, 3],
            false => [0, 2, 1, 0, 3, 2],
        };
        let floats = |v: &[[f32; 3]]| -> Vec<u8> {
            v.iter().flatten().flat_map(|f| f.to_le_bytes()).collect()
        };
        let uv_bytes: Vec<u8> = uvs.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
        let index_bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        for bytes in [floats(&positions), index_bytes, uv_bytes] {
            views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
            bin.extend(bytes);
        }
        let v = 3 * i;
        accessors.push(json!({"bufferView": v, "componentType": 5126, "count": 4,
            "type": "VEC3", "min": [-h, -h, z], "max": [h, h, z]}));
        accessors.push(
            json!({"bufferView": v + 1, "componentType": 5125, "count": 6,
            "type": "SCALAR"}),
        );
        accessors.push(
            json!({"bufferView": v + 2, "componentType": 5126, "count": 4,
            "type": "VEC2"}),
        );
        meshes.push(
            json!({"primitives": [{"attributes": {"POSITION": v, "TEXCOORD_0": v + 2},
            "indices": v + 1, "material": sq.material}]}),
        );
        nodes.push(json!({"mesh": i}));
    }
    nodes.push(json!({"camera": 0, "translation": [0.0, 0.0, HEIGHT]}));
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "cameras": [{"type": "orthographic",
            "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.01, "zfar": 100.0}}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len(), "uri": data_uri(&bin)}],
    });
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
    path
}

fn material(base: [f32; 3], metallic: f32, roughness: f32) -> serde_json::Value {
    json!({"pbrMetallicRoughness": {"baseColorFactor": [base[0], base[1], base[2], 1.0],
        "metallicFactor": metallic, "roughnessFactor": roughness}})
}

/// A 4 × 4 square in the plane z = 0 facing +z, of base colour [`BASE`] (metallic 0), which
/// the camera's view fills.
fn plane_scene(dir: &Path) -> std::path::PathBuf {
    let plane = Square {
        z: 0.0,
        half: 2.0,
        up: true,
        material: 0,
    };
    squares_scene(dir, "plane.gltf", &[plane], vec![material(BASE, 0.0, 1.0)])
}

/// Renders `scene` to `out` (no PNG) at `size` × `size` pixels and `spp` samples, with
/// `extra` options.
fn render_scene(dir: &Path, scene: &Path, out: &Path, size: u32, spp: u32, extra: &[&str]) {
    let (resolution, spp) = (format!("{size}x{size}"), spp.to_string());
    let mut args = vec![
        s(scene),
        "-o",
        s(out),
        "--no-png",
        "--resolution",
        &resolution,
    ];
    args.extend(["--spp", &spp]);
    args.extend_from_slice(extra);
    render(dir, &args).assert_success();
}

/// The plane scene at 16 × 16, 8 spp, under a white background, with `passes` if any.
fn render_plane(dir: &Path, out: &Path, passes: Option<&str>) {
    let scene = plane_scene(dir);
    let mut extra = vec!["--background", "1,1,1"];
    if let Some(p) = passes {
        extra.extend(["--passes", p]);
    }
    render_scene(dir, &scene, out, 16, 8, &extra);
}

#[test]
fn passes_are_layers_of_the_exr_with_the_planes_colour_normal_and_distance() {
    let tmp = tempfile::tempdir().unwrap();
    let with = tmp.path().join("with.exr");
    // Asked out of order and twice: written once each, in a fixed order.
    render_plane(
        tmp.path(),
        &with,
        Some("object_id,depth,albedo,normal,depth,material_id"),
    );
    let (channels, texts) = read_channels(&with);
    let mut names: Vec<&str> = channels.keys().map(|k| k.as_str()).collect();
    names.sort();
    assert_eq!(
        names,
        [
            "B",
            "G",
            "R",
            "albedo.B",
            "albedo.G",
            "albedo.R",
            "depth.Z",
            "material_id.ID",
            "normal.X",
            "normal.Y",
            "normal.Z",
            "object_id.ID"
        ]
    );
    assert_eq!(
        texts["strata:passes"],
        "albedo,normal,depth,object_id,material_id"
    );
    for layer in ["albedo", "normal", "depth", "object_id", "material_id"] {
        assert!(
            texts.contains_key(&format!("strata:pass:{layer}")),
            "no description of {layer}"
        );
    }
    let pixels = 16 * 16;
    for (i, c) in ["albedo.R", "albedo.G", "albedo.B"].into_iter().enumerate() {
        assert_eq!(channels[c].len(), pixels);
        assert!(
            channels[c].iter().all(|&v| v == BASE[i]),
            "{c}: {:?}",
            &channels[c][..4]
        );
    }
    for (c, n) in [("normal.X", 0.0), ("normal.Y", 0.0), ("normal.Z", 1.0)] {
        assert!(
            channels[c].iter().all(|&v| (v - n).abs() < 1e-6),
            "{c}: {:?}",
            &channels[c][..4]
        );
    }
    assert!(
        channels["depth.Z"]
            .iter()
            .all(|&d| (d - HEIGHT).abs() < 1e-5),
        "depth: {:?}",
        &channels["depth.Z"][..4]
    );
    // The plane is node 0's mesh, of material 0.
    for c in ["object_id.ID", "material_id.ID"] {
        assert!(channels[c].iter().all(|&v| v == 0.0), "{c}");
    }

    // Negative controls: the same render without passes has the beauty alone, bit for bit
    // the same (keeping features and first hits changes no sample).
    let without = tmp.path().join("without.exr");
    render_plane(tmp.path(), &without, None);
    let (plain, plain_texts) = read_channels(&without);
    let mut plain_names: Vec<&str> = plain.keys().map(|k| k.as_str()).collect();
    plain_names.sort();
    assert_eq!(plain_names, ["B", "G", "R"]);
    assert!(!plain_texts.contains_key("strata:passes"));
    for c in ["R", "G", "B"] {
        assert_eq!(plain[c], channels[c], "{c} changed by keeping the passes");
    }
    // The plane is lit (the white background): the beauty is not its albedo.
    assert!(plain["R"].iter().any(|&v| v != BASE[0]));
}

#[test]
fn pixels_that_see_nothing_have_zero_albedo_far_depth_and_no_ids() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = plane_scene(tmp.path());
    let out = tmp.path().join("sky.exr");
    // The camera turned half a turn about x: it looks up +z, away from the plane, and every
    // camera ray meets nothing.
    let mut doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&scene).unwrap()).unwrap();
    doc["nodes"][1]["rotation"] = json!([1.0, 0.0, 0.0, 0.0]);
    let sky = tmp.path().join("sky.gltf");
    std::fs::write(&sky, serde_json::to_vec(&doc).unwrap()).unwrap();
    let extra = [
        "--background",
        "0.5,0.5,0.5",
        "--passes",
        "albedo,normal,depth,object_id,mesh_id,material_id",
    ];
    render_scene(tmp.path(), &sky, &out, 8, 4, &extra);
    let (channels, _) = read_channels(&out);
    assert!(channels["R"].iter().all(|&v| v == 0.5), "the background");
    for c in [
        "albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y", "normal.Z",
    ] {
        assert!(channels[c].iter().all(|&v| v == 0.0), "{c}");
    }
    // Far and finite, as Cycles writes it (a compositor normalising depth meets no inf).
    assert!(channels["depth.Z"].iter().all(|&d| d == 1e10));
    for c in ["object_id.ID", "mesh_id.ID", "material_id.ID"] {
        assert!(channels[c].iter().all(|&v| v == -1.0), "{c}");
    }
}

#[test]
fn a_scene_that_renders_black_still_gets_its_passes() {
    // No light and a black background: the beauty is black without tracing for it, but
    // the passes ask what the camera rays meet, so those are traced.
    let tmp = tempfile::tempdir().unwrap();
    let scene = plane_scene(tmp.path());
    let out = tmp.path().join("black.exr");
    let passes = [
        "--background",
        "0,0,0",
        "--passes",
        "albedo,depth,object_id",
    ];
    for integrator in ["path", "direct"] {
        let mut extra = vec!["--integrator", integrator];
        extra.extend(passes);
        render_scene(tmp.path(), &scene, &out, 8, 2, &extra);
        let (c, _) = read_channels(&out);
        assert!(
            c["R"].iter().chain(&c["G"]).all(|&v| v == 0.0),
            "{integrator}: black"
        );
        for (i, v) in c["albedo.R"].iter().enumerate() {
            assert!(
                (v - BASE[0]).abs() < 1e-6,
                "{integrator}: albedo {v} at {i}"
            );
        }
        assert!(c["depth.Z"].iter().all(|&d| (d - HEIGHT).abs() < 1e-4));
        assert!(c["object_id.ID"].iter().all(|&id| id == 0.0));
    }
}

#[test]
fn an_unknown_pass_is_refused_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = plane_scene(tmp.path());
    let out = tmp.path().join("x.exr");
    let run = render(
        tmp.path(),
        &[s(&scene), "-o", s(&out), "--passes", "albedo,cryptomatte"],
    );
    assert!(!run.status.success());
    assert!(run.stderr.contains("cryptomatte"), "{}", run.stderr);
    assert!(!out.exists());
}

/// The albedo pass follows perfect mirrors to what they show, as Open Image Denoise asks: a
/// white mirror (metallic 1, roughness 0) facing the camera shows the red wall behind the
/// camera, and its albedo is the wall's colour, while its normal and depth stay the mirror's.
/// A rough mirror (roughness 0.3, not a delta lobe) keeps its own albedo: the negative control.
#[test]
fn the_albedo_pass_sees_through_perfect_mirrors() {
    let tmp = tempfile::tempdir().unwrap();
    let red = [0.8, 0.1, 0.1];
    for (roughness, want) in [(0.0, red), (0.3, [1.0, 1.0, 1.0])] {
        let mirror = Square {
            z: 0.0,
            half: 2.0,
            up: true,
            material: 0,
        };
        let wall = Square {
            z: 2.0 * HEIGHT,
            half: 4.0,
            up: false,
            material: 1,
        };
        let name = format!("mirror-{roughness}.gltf");
        let materials = vec![material([1.0; 3], 1.0, roughness), material(red, 0.0, 1.0)];
        let scene = squares_scene(tmp.path(), &name, &[mirror, wall], materials);
        let out = tmp.path().join(format!("mirror-{roughness}.exr"));
        render_scene(
            tmp.path(),
            &scene,
            &out,
            8,
            4,
            &["--passes", "albedo,normal,depth"],
        );
        let (channels, _) = read_channels(&out);
        for (i, c) in ["albedo.R", "albedo.G", "albedo.B"].into_iter().enumerate() {
            assert!(
                channels[c].iter().all(|&v| (v - want[i]).abs() < 1e-5),
                "roughness {roughness}: {c} {:?}, want {}",
                &channels[c][..4],
                want[i]
            );
        }
        assert!(channels["normal.Z"].iter().all(|&v| (v - 1.0).abs() < 1e-6));
        assert!(channels["depth.Z"]
            .iter()
            .all(|&d| (d - HEIGHT).abs() < 1e-5));
    }
}

/// The position and UV passes of the plane: at each pixel, the point its samples meet (z = 0,
/// x and y the pixel centre's, within the samples' spread) and the plane's TEXCOORD_0 there
/// (u = (x + 2)/4, v = (2 − y)/4). Position z = 0, not the camera's height: not the depth.
#[test]
fn position_and_uv_passes_follow_the_plane() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("pos.exr");
    render_plane(tmp.path(), &out, Some("position,uv"));
    let (channels, texts) = read_channels(&out);
    assert_eq!(texts["strata:passes"], "position,uv");
    let size = 16;
    for py in 0..size {
        for px in 0..size {
            let i = (py * size + px) as usize;
            // The orthographic view spans x, y in [−1, 1].
            let x = -1.0 + 2.0 * (px as f32 + 0.5) / size as f32;
            let y = 1.0 - 2.0 * (py as f32 + 0.5) / size as f32;
            let got = [
                channels["position.X"][i],
                channels["position.Y"][i],
                channels["position.Z"][i],
            ];
            assert!(
                (got[0] - x).abs() < 0.03 && (got[1] - y).abs() < 0.03 && got[2].abs() < 1e-6,
                "pixel ({px}, {py}): position {got:?}, centre ({x}, {y}, 0)"
            );
            let (u, v) = (channels["uv.U"][i], channels["uv.V"][i]);
            assert!(
                (u - (x + 2.0) / 4.0).abs() < 0.01 && (v - (2.0 - y) / 4.0).abs() < 0.01,
                "pixel ({px}, {py}): uv ({u}, {v})"
            );
        }
    }
}

/// The ID scene's image size, and the pixel centres of its four squares (top-left, top-right,
/// bottom-left, bottom-right: x = ±0.5 and y = ±0.5 of the orthographic view's [−1, 1]).
const ID_SIZE: u32 = 32;
const ID_CENTRES: [(u32, u32); 4] = [(8, 8), (24, 8), (8, 24), (24, 24)];

/// A glTF whose indices the ID passes must give back, written to `dir/ids.gltf`; seen by an
/// orthographic camera at z = [`HEIGHT`] looking down −z over x and y in [−1, 1]. Squares of
/// half-width 0.3 in the plane z = 0 facing +z, one in each quadrant (pixels 3.2 to 12.8 and
/// 19.2 to 28.8 of 32, each way), with background between:
///
/// | node | parent | mesh                | material             | where        |
/// |------|--------|---------------------|----------------------|--------------|
/// | 0    |        | (the camera)        |                      |              |
/// | 1    |        | (none: a group)     |                      | (0, 0.5)     |
/// | 2    | 1      | 0 "square"          | 1 (red)              | (−0.5, 0.5)  |
/// | 3    | 1      | 0 "square"          | 1 (red)              | (0.5, 0.5)   |
/// | 4    |        | 1 "bare square"     | none: −1             | (−0.5, −0.5) |
/// | 5    |        | 2 "two halves"      | 2 (green) for local x < 0.05, 0 (grey) beyond | (0.5, −0.5) |
///
/// The halves of mesh 2 meet at x = 0.55, inside pixel column 24.8.
fn ids_scene(dir: &Path) -> std::path::PathBuf {
    let h = 0.3f32;
    let mut bin: Vec<u8> = Vec::new();
    let (mut accessors, mut views) = (vec![], vec![]);
    // One accessor of positions per rectangle [x0, x1] × [−h, h], and one of indices.
    let mut add = |bytes: Vec<u8>, accessor: serde_json::Value| {
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend(bytes);
        let mut a = accessor;
        a["bufferView"] = json!(views.len() - 1);
        accessors.push(a);
        accessors.len() - 1
    };
    let indices: Vec<u8> = [0u32, 1, 2, 0, 2, 3]
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let index = add(
        indices,
        json!({"componentType": 5125, "count": 6, "type": "SCALAR"}),
    );
    let mut rectangle = |x0: f32, x1: f32| {
        let positions = [[x0, h, 0.0], [x0, -h, 0.0], [x1, -h, 0.0], [x1, h, 0.0f32]];
        let bytes = positions.iter().flatten().flat_map(|f| f.to_le_bytes());
        add(
            bytes.collect(),
            json!({"componentType": 5126, "count": 4, "type": "VEC3",
                "min": [x0, -h, 0.0], "max": [x1, h, 0.0]}),
        )
    };
    let (full, left, right) = (rectangle(-h, h), rectangle(-h, 0.05), rectangle(0.05, h));
    let primitive = |position: usize, material: Option<u32>| {
        let mut p = json!({"attributes": {"POSITION": position}, "indices": index});
        if let Some(m) = material {
            p["material"] = json!(m);
        }
        p
    };
    let colour = |c: [f32; 3]| material(c, 0.0, 1.0);
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 4, 5]}],
        "nodes": [
            {"camera": 0, "translation": [0.0, 0.0, HEIGHT]},
            {"name": "pair", "children": [2, 3], "translation": [0.0, 0.5, 0.0]},
            {"mesh": 0, "translation": [-0.5, 0.0, 0.0]},
            {"mesh": 0, "translation": [0.5, 0.0, 0.0]},
            {"mesh": 1, "translation": [-0.5, -0.5, 0.0]},
            {"mesh": 2, "translation": [0.5, -0.5, 0.0]},
        ],
        "meshes": [
            {"name": "square", "primitives": [primitive(full, Some(1))]},
            {"name": "bare square", "primitives": [primitive(full, None)]},
            {"name": "two halves",
                "primitives": [primitive(left, Some(2)), primitive(right, Some(0))]},
        ],
        "materials": [colour([0.5, 0.5, 0.5]), colour([0.8, 0.1, 0.1]), colour([0.1, 0.8, 0.1])],
        "cameras": [{"type": "orthographic",
            "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.01, "zfar": 100.0}}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len(), "uri": data_uri(&bin)}],
    });
    let path = dir.join("ids.gltf");
    std::fs::write(&path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
    path
}

/// The ID passes' layers, and the normal's Z (for the ID scene, whose squares all face the
/// camera: the fraction of the pixel's samples that met a square).
const ID_CHANNELS: [&str; 3] = ["object_id.ID", "mesh_id.ID", "material_id.ID"];

/// Renders the ID scene (at [`ID_SIZE`]², `spp` samples, a white background) with the ID
/// passes, the normal and the albedo, and `extra` options; returns its channels.
fn render_ids(dir: &Path, name: &str, spp: u32, extra: &[&str]) -> HashMap<String, Vec<f32>> {
    let scene = ids_scene(dir);
    let out = dir.join(name);
    let mut args = vec![
        "--background",
        "1,1,1",
        "--passes",
        "object_id,mesh_id,material_id,normal,albedo",
    ];
    args.extend_from_slice(extra);
    render_scene(dir, &scene, &out, ID_SIZE, spp, &args);
    read_channels(&out).0
}

/// The (object, mesh, material) IDs inside the square of quadrant `(px, py)`, from the table
/// of [`ids_scene`]: the bottom-right square's material by the half.
fn expected_ids(px: u32, py: u32) -> [f32; 3] {
    match (px < 16, py < 16) {
        (true, true) => [2.0, 0.0, 1.0],
        (false, true) => [3.0, 0.0, 1.0],
        (true, false) => [4.0, 1.0, -1.0],
        (false, false) => [5.0, 2.0, if px < 24 { 2.0 } else { 0.0 }],
    }
}

/// True for a pixel whose square [px, px+1] × [py, py+1] meets no square of the ID scene.
fn background(px: u32, py: u32) -> bool {
    let off = |p: u32| !(3..=12).contains(&p) && !(19..=28).contains(&p);
    off(px) || off(py)
}

/// Checks the ID layers of an ID-scene render: the glTF indices well inside each square
/// (two nodes of one mesh: two objects, one mesh; a primitive without a material: −1; two
/// primitives of one node: two materials, one object), −1 on the background, and nothing but
/// those integers anywhere, outlines included.
fn check_ids(channels: &HashMap<String, Vec<f32>>, what: &str) {
    let at = |c: &str, px: u32, py: u32| channels[c][(py * ID_SIZE + px) as usize];
    for &(cx, cy) in &ID_CENTRES {
        for py in cy - 3..cy + 3 {
            for px in cx - 3..cx + 3 {
                // The seam of the two halves, at x = 24.8: a pixel clear of it.
                if cx == 24 && cy == 24 && (px == 24 || px == 23) {
                    continue;
                }
                let got = ID_CHANNELS.map(|c| at(c, px, py));
                assert_eq!(got, expected_ids(px, py), "{what}: pixel ({px}, {py})");
            }
        }
    }
    for py in 0..ID_SIZE {
        for px in 0..ID_SIZE {
            let got = ID_CHANNELS.map(|c| at(c, px, py));
            if background(px, py) {
                assert_eq!(got, [-1.0; 3], "{what}: background pixel ({px}, {py})");
                continue;
            }
            // An outline pixel names its square or nothing: never a blend.
            let square = expected_ids(px, py);
            let materials = match square[0] == 5.0 {
                true => vec![2.0, 0.0],
                false => vec![square[2]],
            };
            let ok = got == [-1.0; 3]
                || (got[0] == square[0] && got[1] == square[1] && materials.contains(&got[2]));
            assert!(ok, "{what}: pixel ({px}, {py}) holds {got:?}");
        }
    }
}

/// The ID passes hold the glTF document's indices of the hit of each pixel's sample 0, not
/// averages, on both backends; the feature layers of the same render show the outline pixels
/// where an average of IDs would be a fraction (the negative control).
#[test]
fn id_passes_hold_the_documents_indices_exactly_on_both_backends() {
    let tmp = tempfile::tempdir().unwrap();
    let embree = render_ids(tmp.path(), "embree.exr", 8, &["--backend", "embree"]);
    let obvhs = render_ids(tmp.path(), "obvhs.exr", 8, &["--backend", "obvhs"]);
    check_ids(&embree, "embree");
    check_ids(&obvhs, "obvhs");
    for c in ID_CHANNELS {
        assert_eq!(embree[c], obvhs[c], "{c} differs between the backends");
    }

    // Negative control: outline pixels, where some samples met a square and some did not
    // (the normal's Z, which a miss adds as 0, is the fraction that met one), and a naive
    // mean of the object IDs over the samples (a miss as −1) would be a fraction.
    let (mut outline, mut fractional) = (0, 0);
    for py in 0..ID_SIZE {
        for px in 0..ID_SIZE {
            let i = (py * ID_SIZE + px) as usize;
            let coverage = embree["normal.Z"][i];
            if coverage <= 0.0 || coverage >= 1.0 || background(px, py) {
                continue;
            }
            outline += 1;
            let object = expected_ids(px, py)[0];
            let mean = coverage * object - (1.0 - coverage);
            fractional += (mean.fract().abs() > 1e-3) as u32;
            let id = embree["object_id.ID"][i];
            assert!(id == -1.0 || id == object, "({px}, {py}): {id}");
        }
    }
    assert!(outline >= 16, "only {outline} outline pixels");
    assert!(fractional >= 8, "only {fractional} fractional means");
    // The seam of mesh 2's halves (pixel column 24, x 24.8): every sample met the square, some
    // green material 2 and some grey material 0 (the albedo's green is between the two), and
    // a mean material ID would lie between 0 and 2; the pass holds one of them.
    let mut mixed = 0;
    for py in 21..28 {
        let i = (py * ID_SIZE + 24) as usize;
        let green = embree["albedo.G"][i];
        if embree["normal.Z"][i] == 1.0 && green > 0.5 + 1e-3 && green < 0.8 - 1e-3 {
            mixed += 1;
            let m = embree["material_id.ID"][i];
            assert!(m == 2.0 || m == 0.0, "seam ({py}): material {m}");
        }
    }
    assert!(mixed >= 4, "only {mixed} pixels mix the two materials");
}

/// The ID layers are those of each pixel's sample 0: the same at 1 spp as at 8 (sample 0 is
/// the same sample; the 1-spp image's outline pixels are −1 exactly where their one sample met
/// nothing), and bit for bit the same on one thread and two, through the one-ray loop as
/// through packets, with adaptive sampling, a time limit, or checkpoints between small
/// tiles. An implementation that kept the last sample's hit, or the first to finish, would
/// differ at the outlines.
#[test]
fn id_passes_are_sample_zeros_whatever_the_threads_rounds_or_stopping() {
    let tmp = tempfile::tempdir().unwrap();
    let reference = render_ids(tmp.path(), "one-thread.exr", 8, &["--threads", "1"]);
    check_ids(&reference, "one thread");
    let one = render_ids(tmp.path(), "one-spp.exr", 1, &["--threads", "1"]);
    for (i, &z) in one["normal.Z"].iter().enumerate() {
        assert_eq!(
            one["object_id.ID"][i] == -1.0,
            z == 0.0,
            "pixel {i}: coverage {z}"
        );
    }
    let variants: [(&str, &[&str]); 5] = [
        ("two threads", &["--threads", "2"]),
        (
            "one ray at a time",
            &["--threads", "2", "--no-camera-packets"],
        ),
        (
            "adaptive",
            &["--threads", "2", "--target-error", "0.5", "--min-spp", "2"],
        ),
        ("time limit", &["--threads", "2", "--time-limit", "0.001"]),
        (
            "checkpoints",
            &[
                "--threads",
                "2",
                "--checkpoint",
                "0.001",
                "--min-pass-seconds",
                "0",
                "--tile-size",
                "4",
            ],
        ),
    ];
    let mut renders = vec![("1 spp", one)];
    for (i, (what, extra)) in variants.iter().enumerate() {
        let name = format!("variant-{i}.exr");
        renders.push((what, render_ids(tmp.path(), &name, 8, extra)));
    }
    for (what, channels) in &renders {
        for c in ID_CHANNELS {
            let differ = (channels[c].iter().zip(&reference[c]))
                .filter(|(a, b)| a.to_bits() != b.to_bits())
                .count();
            assert_eq!(differ, 0, "{what}: {differ} pixels of {c} differ");
        }
    }
    // The variants did change how the samples were taken: the beauty of the adaptive render
    // is not the fixed one's.
    assert!(
        renders[3].1["R"] != reference["R"],
        "adaptive sampling stopped no pixel"
    );
}
