//! EXT_mesh_gpu_instancing: a node draws its mesh once per instance, each placed by the
//! instance's translation × rotation × scale under the node's own transform (flattened
//! today: every instance is a copy, counted by the memory estimate), and inconsistent
//! instance attributes are refused by name.

mod common;

use common::*;
use glam::Vec3;
use serde_json::json;
use strata::scene::{load, LoadOptions};

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
    let mut bin = Vec::new();
    let mut views = Vec::new();
    for p in &parts {
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": p.len()}));
        bin.extend(p);
    }
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
    let scene = load(&instanced(dir.path(), 3), &LoadOptions::default()).unwrap();
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
    assert!(
        !scene
            .load_warnings
            .iter()
            .any(|w| w.contains("EXT_mesh_gpu_instancing")),
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
