//! Render passes through the binary (`--passes`): one EXR holds the beauty as R, G, B and each
//! pass under OpenEXR's `layer.channel` names, with header attributes saying what each layer
//! is. A plane of known colour seen head-on by an orthographic camera at a known distance:
//! its albedo layer is the base colour, its normal layer the plane's normal, its depth layer
//! the distance, in every pixel; and keeping the passes changes no bit of the beauty.

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

/// Every channel of the EXR's one part, by name, and its text attributes.
fn read_channels(path: &Path) -> (HashMap<String, Vec<f32>>, HashMap<String, String>) {
    use exr::prelude::*;
    let image = read_all_flat_layers_from_file(path).unwrap();
    assert_eq!(image.layer_data.len(), 1, "one part");
    let layer = &image.layer_data[0];
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let values = match &c.sample_data {
                FlatSamples::F32(v) => v.clone(),
                other => panic!("{}: not float32: {other:?}", c.name),
            };
            (c.name.to_string(), values)
        })
        .collect();
    let texts = layer
        .attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    (channels, texts)
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
    render_plane(tmp.path(), &with, Some("depth,albedo,normal,depth"));
    let (channels, texts) = read_channels(&with);
    let mut names: Vec<&str> = channels.keys().map(|k| k.as_str()).collect();
    names.sort();
    assert_eq!(
        names,
        [
            "B", "G", "R", "albedo.B", "albedo.G", "albedo.R", "depth.Z", "normal.X", "normal.Y",
            "normal.Z"
        ]
    );
    assert_eq!(texts["strata:passes"], "albedo,normal,depth");
    for layer in ["albedo", "normal", "depth"] {
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

    // Negative controls: the same render without passes has the beauty alone, bit for bit
    // the same.
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
fn pixels_that_see_nothing_have_zero_albedo_and_infinite_depth() {
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
        "albedo,normal,depth",
    ];
    render_scene(tmp.path(), &sky, &out, 8, 4, &extra);
    let (channels, _) = read_channels(&out);
    assert!(channels["R"].iter().all(|&v| v == 0.5), "the background");
    for c in [
        "albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y", "normal.Z",
    ] {
        assert!(channels[c].iter().all(|&v| v == 0.0), "{c}");
    }
    assert!(channels["depth.Z"]
        .iter()
        .all(|d| d.is_infinite() && *d > 0.0));
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
