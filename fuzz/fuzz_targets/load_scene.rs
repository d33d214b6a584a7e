//! Fuzz target: arbitrary bytes through strata's glTF loader into a `Scene`.
//!
//! The first byte chooses how the rest becomes a scene file:
//! - even: the rest is the file as it is (glTF JSON, binary glTF, or anything else);
//! - odd: the rest is `JSON [0x00 BIN]`, wrapped into a well-formed binary glTF container
//!   (header, JSON chunk, optional BIN chunk), so JSON mutations also reach the .glb path.
//!
//! Relative URIs resolve against `fuzz/assets/` (a small buffer and image live there). The
//! loader runs under a 256 MiB memory limit (`LoadOptions::memory_limit`), as the CLI's
//! `--max-memory` would impose. A loaded scene must satisfy the invariants the renderer relies
//! on (indices in range, parallel arrays of equal length, finite positions and bounds).
//!
//! With `STRATA_FUZZ_WRITE=FILE` set, the scene file made from the input is written to FILE
//! first: that is how crashing inputs become the files under tests/data/fuzz/.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use strata::scene::{self, LoadOptions};

fn scene_file(data: &[u8]) -> Vec<u8> {
    let Some((&mode, rest)) = data.split_first() else {
        return Vec::new();
    };
    if mode % 2 == 0 {
        return rest.to_vec();
    }
    let (json, bin) = match rest.iter().position(|&b| b == 0) {
        Some(i) => (&rest[..i], Some(&rest[i + 1..])),
        None => (rest, None),
    };
    let pad = |n: usize| (4 - n % 4) % 4;
    let mut chunks = Vec::new();
    chunks.extend_from_slice(&((json.len() + pad(json.len())) as u32).to_le_bytes());
    chunks.extend_from_slice(b"JSON");
    chunks.extend_from_slice(json);
    chunks.extend(std::iter::repeat_n(b' ', pad(json.len())));
    if let Some(bin) = bin {
        chunks.extend_from_slice(&((bin.len() + pad(bin.len())) as u32).to_le_bytes());
        chunks.extend_from_slice(b"BIN\0");
        chunks.extend_from_slice(bin);
        chunks.extend(std::iter::repeat_n(0u8, pad(bin.len())));
    }
    let mut file = b"glTF".to_vec();
    file.extend_from_slice(&2u32.to_le_bytes());
    file.extend_from_slice(&((12 + chunks.len()) as u32).to_le_bytes());
    file.extend_from_slice(&chunks);
    file
}

fuzz_target!(|data: &[u8]| {
    let file = scene_file(data);
    if let Some(out) = std::env::var_os("STRATA_FUZZ_WRITE") {
        std::fs::write(out, &file).expect("cannot write STRATA_FUZZ_WRITE");
    }
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/scene.gltf"));
    let options = LoadOptions {
        memory_limit: Some(256 << 20),
        ..Default::default()
    };
    let Ok(s) = scene::load_from_bytes(path, &file, &options) else {
        return;
    };
    let n = s.positions.len();
    assert!(n > 0 && !s.triangles.is_empty());
    assert_eq!(s.normals.len(), n);
    assert_eq!(s.uvs.len(), n);
    assert_eq!(s.triangle_materials.len(), s.triangles.len());
    assert!(s.triangles.iter().flatten().all(|&i| (i as usize) < n));
    assert!(s
        .triangle_materials
        .iter()
        .all(|&m| (m as usize) < s.materials.len()));
    assert!(s.positions.iter().all(|p| p.is_finite()));
    assert!(s.normals.iter().all(|v| v.is_finite()));
    assert!(s.bounds.0.is_finite() && s.bounds.1.is_finite());
    for m in &s.materials {
        for t in [&m.base_color_texture, &m.emissive_texture]
            .into_iter()
            .flatten()
        {
            assert!(t.image < s.images.len());
        }
    }
    for c in &s.cameras {
        assert!(c.to_world.is_finite());
    }
});
