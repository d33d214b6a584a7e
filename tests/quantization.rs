//! KHR_mesh_quantization: positions, normals and texture coordinates stored as (normalized)
//! integers load as the floats they stand for, a file that requires the extension is
//! accepted, and component types the extension does not allow are refused by name.

mod common;

use common::*;
use glam::Vec3;
use serde_json::json;
use strata::scene::{load, LoadOptions};

/// A quad (two triangles) with POSITION, NORMAL and TEXCOORD_0 in the given component types
/// (5126 float, 5122 short, 5120 byte, 5123 unsigned short, 5121 unsigned byte), `normalized`
/// as given, the node scaled by `scale` (how quantized files undo their integer range).
fn quad_file(
    dir: &std::path::Path,
    name: &str,
    (pos_type, pos_norm): (u32, bool),
    (nrm_type, uv_type): (u32, u32),
    scale: f32,
) -> std::path::PathBuf {
    // The quad in the unit square of z = 0, facing +z; uv from (0, 0) to (1, 1).
    let corners = [
        [-1.0f32, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ];
    let uvs = [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let encode = |v: f32, ty: u32, normalized: bool| -> Vec<u8> {
        match (ty, normalized) {
            (5126, _) => v.to_le_bytes().to_vec(),
            (5122, true) => ((v * 32767.0).round() as i16).to_le_bytes().to_vec(),
            (5122, false) => (v.round() as i16).to_le_bytes().to_vec(),
            (5120, true) => vec![(v * 127.0).round() as i8 as u8],
            (5120, false) => vec![v.round() as i8 as u8],
            (5123, true) => ((v * 65535.0).round() as u16).to_le_bytes().to_vec(),
            (5121, true) => vec![(v * 255.0).round() as u8],
            _ => unreachable!(),
        }
    };
    // Each element padded to 4 bytes (glTF's alignment for vertex attributes).
    let attribute = |values: &[Vec<f32>], ty: u32, normalized: bool| -> (Vec<u8>, usize) {
        let mut bytes = Vec::new();
        let mut stride = 0;
        for v in values {
            let mut e: Vec<u8> = v.iter().flat_map(|&c| encode(c, ty, normalized)).collect();
            while !e.len().is_multiple_of(4) {
                e.push(0);
            }
            stride = e.len();
            bytes.extend(e);
        }
        (bytes, stride)
    };
    // Positions are stored divided by `scale`, which the node multiplies back.
    let pos: Vec<Vec<f32>> = corners
        .iter()
        .map(|c| c.iter().map(|v| v / scale).collect())
        .collect();
    let nrm: Vec<Vec<f32>> = vec![vec![0.0, 0.0, 1.0]; 4];
    let uv: Vec<Vec<f32>> = uvs.iter().map(|u| u.to_vec()).collect();
    let parts = [
        attribute(&pos, pos_type, pos_norm),
        attribute(&nrm, nrm_type, nrm_type != 5126),
        attribute(&uv, uv_type, uv_type != 5126),
        (
            [0u16, 1, 2, 0, 2, 3]
                .iter()
                .flat_map(|i| i.to_le_bytes())
                .collect(),
            0,
        ),
    ];
    let mut bin = Vec::new();
    let mut views = Vec::new();
    for (bytes, stride) in &parts {
        let mut view = json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()});
        if *stride > 0 {
            view["byteStride"] = json!(stride);
            view["target"] = json!(34962);
        }
        views.push(view);
        bin.extend(bytes);
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
    }
    let lo: Vec<f32> = (0..3)
        .map(|k| pos.iter().map(|p| p[k]).fold(f32::MAX, f32::min))
        .collect();
    let hi: Vec<f32> = (0..3)
        .map(|k| pos.iter().map(|p| p[k]).fold(f32::MIN, f32::max))
        .collect();
    let (lo, hi): (Vec<f32>, Vec<f32>) = match (pos_type, pos_norm) {
        (5126, _) => (lo, hi),
        (_, true) => (lo, hi),
        _ => (
            lo.iter().map(|v| v.round()).collect(),
            hi.iter().map(|v| v.round()).collect(),
        ),
    };
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_mesh_quantization"],
        "extensionsRequired": ["KHR_mesh_quantization"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "scale": [scale, scale, scale]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3}]}],
        "buffers": [{"byteLength": bin.len(), "uri": data_uri(&bin)}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": pos_type, "normalized": pos_norm && pos_type != 5126,
             "count": 4, "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": 1, "componentType": nrm_type, "normalized": nrm_type != 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": uv_type, "normalized": uv_type != 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ]
    });
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

#[test]
fn quantized_attributes_load_as_the_floats_they_encode() {
    let dir = tempfile::tempdir().unwrap();
    let float = quad_file(dir.path(), "float.gltf", (5126, false), (5126, 5126), 1.0);
    let reference = load(&float, &LoadOptions::default()).unwrap();
    // (name, position type and normalization, normal type, uv type, node scale, tolerance:
    // half a quantization step on each axis, times √3, times the node's scale).
    let cases = [
        ("short-normalized", (5122, true), (5122, 5123), 2.0, 1e-4),
        ("byte-normalized", (5120, true), (5120, 5121), 2.0, 2e-2),
        (
            "short-integers",
            (5122, false),
            (5122, 5123),
            1.0 / 1024.0,
            1e-6,
        ),
        (
            "byte-integers",
            (5120, false),
            (5120, 5121),
            1.0 / 64.0,
            1e-6,
        ),
    ];
    for (name, pos, (nrm, uv), scale, tol) in cases {
        let path = quad_file(dir.path(), &format!("{name}.gltf"), pos, (nrm, uv), scale);
        let scene = load(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(scene.positions.len(), 4, "{name}");
        for (i, (p, q)) in scene.positions.iter().zip(&reference.positions).enumerate() {
            assert!(
                (*p - *q).length() < tol,
                "{name}: vertex {i} at {p}, not {q}"
            );
        }
        for n in &scene.normals {
            assert!((*n - Vec3::Z).length() < 1e-2, "{name}: normal {n}");
        }
        for (u, v) in scene.uvs.iter().zip(&reference.uvs) {
            assert!((*u - *v).length() < 1e-2, "{name}: uv {u} against {v}");
        }
        assert!(
            !scene
                .load_warnings
                .iter()
                .any(|w| w.contains("KHR_mesh_quantization")),
            "{name}: {:?}",
            scene.load_warnings
        );
    }
    // The same image from the float and the short-normalized file.
    let short = dir.path().join("short-normalized.gltf");
    let run = |scene: &std::path::Path, out: &str| {
        let out = dir.path().join(out);
        render(
            dir.path(),
            &[
                s(scene),
                "--spp",
                "4",
                "--resolution",
                "24x24",
                "--integrator",
                "ao",
                "--no-png",
                "-o",
                s(&out),
            ],
        )
        .assert_success();
        strata::render::output::read_exr_rgb(&out).unwrap().2
    };
    let (a, b) = (run(&float, "float.exr"), run(&short, "short.exr"));
    let worst = a
        .iter()
        .zip(&b)
        .flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs()))
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-3, "largest pixel difference {worst}");
}

#[test]
fn types_the_extension_does_not_allow_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    // Unsigned bytes for a normal: the extension allows only signed normalized ones.
    let path = quad_file(dir.path(), "bad.gltf", (5126, false), (5121, 5126), 1.0);
    let err = load(&path, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("NORMAL") && err.contains("U8"), "{err}");
}
