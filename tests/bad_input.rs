//! The bad-input table of ROBUSTNESS.md: broken scene files through the `render` binary.
//!
//! Every case writes its files into a fresh temporary directory (also the working directory)
//! and asserts: a non-zero exit, exactly one line on stderr, `error: <scene file>: <problem>`
//! naming the file and the problem, no panic, and no output (the directory holds exactly the
//! input files afterwards: no EXR, no PNG, no temporary file). Cases that already live in
//! tests/cli.rs (missing file, not glTF, truncated JSON in a .glb, missing external buffer,
//! unsupported required extension, no triangles) are not repeated here.
//!
//! Also here: the resource limit (`--max-memory`), and absurd counts under a 1 GiB
//! address-space limit (`ulimit -v`), which shows they are refused before allocating.
//!
//! `cargo test --release --test bad_input -- --nocapture` prints each error line.

mod common;

use common::*;
use serde_json::{json, Value};

const SMALL: [&str; 4] = ["--resolution", "32x32", "--spp", "4"];

/// Writes `files` (name, bytes) into a fresh directory, renders `scene` (one of them) with
/// `extra` options, and asserts the refusal described in the module comment. Returns the
/// error line.
fn expect_refused(
    scene: &str,
    files: &[(&str, Vec<u8>)],
    extra: &[&str],
    words: &[&str],
) -> String {
    let tmp = tempfile::tempdir().unwrap();
    for (name, bytes) in files {
        std::fs::write(tmp.path().join(name), bytes).unwrap();
    }
    let scene_path = tmp.path().join(scene);
    let out = tmp.path().join("out.exr");
    let mut args = vec![s(&scene_path), "-o", s(&out)];
    args.extend_from_slice(&SMALL);
    args.extend_from_slice(extra);
    let run = render(tmp.path(), &args);
    assert!(
        !run.status.success(),
        "render should refuse {scene}; stdout:\n{}\nstderr:\n{}",
        run.stdout,
        run.stderr
    );
    assert_eq!(run.status.code(), Some(1), "exit status: {}", run.status);
    let mut all = vec![s(&scene_path)];
    all.extend_from_slice(words);
    let line = assert_one_error_line(&run.stderr, &all);
    let names: Vec<&str> = files.iter().map(|(n, _)| *n).collect();
    assert_entries(tmp.path(), &names);
    eprintln!("{}", line.replace(&format!("{}/", s(tmp.path())), ""));
    line
}

fn json_bytes(doc: &Value) -> Vec<u8> {
    serde_json::to_vec_pretty(doc).unwrap()
}

/// ao-wall with `edit` applied, refused with `words`.
fn expect_json_refused(edit: impl FnOnce(&mut Value), extra: &[&str], words: &[&str]) -> String {
    let mut doc = ao_wall_json();
    edit(&mut doc);
    expect_refused(
        "scene.gltf",
        &[("scene.gltf", json_bytes(&doc))],
        extra,
        words,
    )
}

// ---------------------------------------------------------------------------------------
// Binary glTF containers.

#[test]
fn glb_valid_control_renders() {
    // The control for the .glb cases: the same container, unbroken, renders.
    let tmp = tempfile::tempdir().unwrap();
    let scene = tmp.path().join("scene.glb");
    std::fs::write(&scene, ao_wall_glb()).unwrap();
    let out = tmp.path().join("out.exr");
    let mut args = vec![s(&scene), "-o", s(&out), "--no-png"];
    args.extend_from_slice(&SMALL);
    let run = render(tmp.path(), &args);
    assert!(run.status.success(), "{}", run.stderr);
    assert_entries(tmp.path(), &["out.exr", "scene.glb"]);
}

#[test]
fn glb_truncated_in_the_binary_chunk() {
    let glb = ao_wall_glb();
    let cut = glb[..glb.len() - 100].to_vec();
    expect_refused(
        "scene.glb",
        &[("scene.glb", cut)],
        &[],
        &["invalid binary glTF", "truncated", "declares"],
    );
}

#[test]
fn glb_shorter_than_its_header() {
    expect_refused(
        "scene.glb",
        &[("scene.glb", ao_wall_glb()[..10].to_vec())],
        &[],
        &["truncated", "12-byte header"],
    );
}

#[test]
fn glb_chunk_longer_than_the_file() {
    // The header's total length is right, but the JSON chunk claims more than there is.
    let mut glb = ao_wall_glb();
    glb[12..16].copy_from_slice(&1_000_000u32.to_le_bytes());
    expect_refused(
        "scene.glb",
        &[("scene.glb", glb)],
        &[],
        &["chunk 0", "1000000 bytes", "past the end"],
    );
}

#[test]
fn glb_wrong_magic() {
    let mut glb = ao_wall_glb();
    glb[..4].copy_from_slice(b"glTX");
    expect_refused(
        "scene.glb",
        &[("scene.glb", glb)],
        &[],
        &["not a glTF file", "magic"],
    );
}

#[test]
fn glb_version_1() {
    let mut glb = ao_wall_glb();
    glb[4..8].copy_from_slice(&1u32.to_le_bytes());
    expect_refused(
        "scene.glb",
        &[("scene.glb", glb)],
        &[],
        &["binary glTF", "version 1"],
    );
}

#[test]
fn empty_file() {
    expect_refused("scene.gltf", &[("scene.gltf", Vec::new())], &[], &["empty"]);
}

// ---------------------------------------------------------------------------------------
// JSON.

#[test]
fn json_syntax_error() {
    let text = json_bytes(&ao_wall_json());
    let cut = text[..text.len() / 2].to_vec();
    expect_refused(
        "scene.gltf",
        &[("scene.gltf", cut)],
        &[],
        &["invalid glTF", "line", "column"],
    );
}

#[test]
fn json_wrong_type() {
    expect_json_refused(
        |d| d["accessors"] = json!(5),
        &[],
        &["invalid glTF", "invalid type", "line"],
    );
}

#[test]
fn json_missing_required_field() {
    expect_json_refused(
        |d| {
            d.as_object_mut().unwrap().remove("asset");
        },
        &[],
        &["invalid glTF", "missing field `asset`"],
    );
}

#[test]
fn json_nan_is_not_json() {
    // JSON has no NaN: the parser stops at it (the position names where).
    let text = String::from_utf8(json_bytes(&ao_wall_json())).unwrap();
    let text = text.replacen(
        "\"name\": \"floor\",",
        "\"name\": \"floor\", \"matrix\": [NaN, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1],",
        1,
    );
    assert!(text.contains("NaN"));
    expect_refused(
        "scene.gltf",
        &[("scene.gltf", text.into_bytes())],
        &[],
        &["invalid glTF", "expected value", "line"],
    );
}

// ---------------------------------------------------------------------------------------
// Accessors, indices, buffer views, buffers.

#[test]
fn accessor_past_its_buffer_view() {
    expect_json_refused(
        |d| d["accessors"][0]["count"] = json!(5),
        &[],
        &["accessor 0", "5 elements", "past the end of bufferView 0"],
    );
}

#[test]
fn accessor_index_out_of_range() {
    // Was a panic inside the gltf crate's validation (it indexes the POSITION accessor
    // unchecked); now checked first.
    expect_json_refused(
        |d| d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(99),
        &[],
        &["POSITION refers to accessor 99", "6 accessor"],
    );
}

#[test]
fn other_reference_out_of_range() {
    // Every other dangling index is caught by the gltf crate's validation.
    expect_json_refused(
        |d| d["meshes"][0]["primitives"][0]["indices"] = json!(42),
        &[],
        &["invalid glTF", "indices", "index out of bounds"],
    );
}

#[test]
fn vertex_index_out_of_range() {
    let mut bin = ao_wall_buffer();
    // The floor's index list is bufferView 2 at byte 96: make its first index 7 (4 vertices).
    bin[96..100].copy_from_slice(&7u32.to_le_bytes());
    expect_json_refused(
        |d| d["buffers"][0]["uri"] = json!(data_uri(&bin)),
        &[],
        &["vertex index 7 out of range", "4 vertices"],
    );
}

#[test]
fn buffer_view_past_its_buffer() {
    expect_json_refused(
        |d| d["bufferViews"][5]["byteLength"] = json!(4000),
        &[],
        &["bufferView 5", "past the end of buffer 0", "240 bytes"],
    );
}

#[test]
fn buffer_shorter_than_its_byte_length() {
    expect_json_refused(
        |d| d["buffers"][0]["byteLength"] = json!(100_000),
        &[],
        &["buffer 0", "byteLength 100000"],
    );
}

#[test]
fn data_uri_with_invalid_base64() {
    expect_json_refused(
        |d| d["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@not base64!"),
        &[],
        &["buffer 0", "not valid base64"],
    );
}

#[test]
fn data_uri_not_base64_encoded() {
    expect_json_refused(
        |d| d["buffers"][0]["uri"] = json!("data:application/octet-stream,hello"),
        &[],
        &["buffer 0", "not base64-encoded"],
    );
}

#[test]
fn missing_external_image() {
    expect_json_refused(
        |d| {
            d["images"] = json!([{"uri": "nothere.png"}]);
            d["textures"] = json!([{"source": 0}]);
            d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
        },
        &[],
        &["image 0", "nothere.png", "does not exist"],
    );
}

#[test]
fn buffer_that_is_not_a_regular_file() {
    // /dev/zero never ends: reading it whole would exhaust memory.
    expect_json_refused(
        |d| d["buffers"][0]["uri"] = json!("/dev/zero"),
        &[],
        &["buffer 0", "/dev/zero", "not a regular file"],
    );
}

#[test]
fn scene_that_is_not_a_regular_file() {
    let tmp = tempfile::tempdir().unwrap();
    for (scene, words) in [
        ("/dev/zero", &["not a regular file"][..]),
        (s(tmp.path()), &["is a directory"][..]),
    ] {
        let out = tmp.path().join("out.exr");
        let mut args = vec![scene, "-o", s(&out)];
        args.extend_from_slice(&SMALL);
        let run = render(tmp.path(), &args);
        assert_eq!(run.status.code(), Some(1), "{}", run.stderr);
        let mut all = vec![scene];
        all.extend_from_slice(words);
        assert_one_error_line(&run.stderr, &all);
        assert_entries(tmp.path(), &[]);
    }
}

// ---------------------------------------------------------------------------------------
// Absurd counts and the memory limit.

/// ao-wall with accessor 0 (the floor's positions) claiming `count` vertices.
fn ao_wall_with_count(count: u64) -> Vec<u8> {
    let mut doc = ao_wall_json();
    doc["accessors"][0]["count"] = json!(count);
    json_bytes(&doc)
}

/// A 1 GiB address-space limit: an allocation for 10^9 or 10^12 vertices would fail (and
/// abort the process, which the one-line-error check would catch).
const ULIMIT_1GIB: &str = "ulimit -v 1048576";

fn expect_refused_under_ulimit(scene_bytes: Vec<u8>, extra: &[&str], words: &[&str]) -> String {
    let tmp = tempfile::tempdir().unwrap();
    let scene = tmp.path().join("huge.gltf");
    std::fs::write(&scene, scene_bytes).unwrap();
    let out = tmp.path().join("out.exr");
    let mut args = vec![s(&scene), "-o", s(&out)];
    args.extend_from_slice(&SMALL);
    args.extend_from_slice(extra);
    let run = render_under_shell(tmp.path(), ULIMIT_1GIB, &args);
    assert_eq!(run.status.code(), Some(1), "{}", run.stderr);
    let mut all = vec![s(&scene)];
    all.extend_from_slice(words);
    let line = assert_one_error_line(&run.stderr, &all);
    assert!(
        run.elapsed.as_secs_f64() < 5.0,
        "refusing took {:?}",
        run.elapsed
    );
    assert_entries(tmp.path(), &["huge.gltf"]);
    eprintln!("{line} ({:.3} s)", run.elapsed.as_secs_f64());
    line
}

#[test]
fn ulimit_control_a_normal_scene_renders_under_1_gib() {
    // The control: under the same address-space limit a normal render works, so the
    // refusals below are the loader's, not the limit's.
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.exr");
    let wall = repo_path("scenes/ao-wall.gltf");
    let mut args = vec![s(&wall), "-o", s(&out), "--no-png"];
    args.extend_from_slice(&SMALL);
    let run = render_under_shell(tmp.path(), ULIMIT_1GIB, &args);
    assert!(run.status.success(), "{}", run.stderr);
    assert_entries(tmp.path(), &["out.exr"]);
}

#[test]
fn absurd_count_10_to_the_12_is_refused_before_allocating() {
    // Refused by the memory estimate made from the declared counts (58 TiB is more than the
    // default limit, 3/4 of physical memory, on any machine) ...
    expect_refused_under_ulimit(
        ao_wall_with_count(1_000_000_000_000),
        &[],
        &[
            "needs an estimated",
            "1000000000004 vertices",
            "--max-memory",
        ],
    );
    // ... and without a limit, by the range check of the accessor against its buffer view.
    expect_refused_under_ulimit(
        ao_wall_with_count(1_000_000_000_000),
        &["--max-memory", "unlimited"],
        &[
            "accessor 0",
            "1000000000000 elements",
            "past the end of bufferView 0",
        ],
    );
}

#[test]
fn absurd_count_10_to_the_9_is_refused_by_the_memory_estimate() {
    expect_refused_under_ulimit(
        ao_wall_with_count(1_000_000_000),
        &["--max-memory", "1G"],
        &[
            "needs an estimated",
            "1000000004 vertices",
            "1.0 GiB",
            "--max-memory",
        ],
    );
}

/// ao-wall whose accessor 0 has no bufferView (zeros), one sparse substitution, and `count`
/// elements: no buffer bounds its count.
fn ao_wall_with_sparse_count(count: u64) -> Vec<u8> {
    let mut doc = ao_wall_json();
    let mut bin = ao_wall_buffer();
    let n = bin.len();
    bin.extend_from_slice(&1u32.to_le_bytes());
    for v in [1f32, 2.0, 3.0] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    doc["buffers"][0] = json!({"uri": data_uri(&bin), "byteLength": bin.len()});
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 0, "byteOffset": n, "byteLength": 4}));
    views.push(json!({"buffer": 0, "byteOffset": n + 4, "byteLength": 12}));
    let (iv, vv) = (views.len() - 2, views.len() - 1);
    let acc = doc["accessors"][0].as_object_mut().unwrap();
    acc.remove("bufferView");
    acc.remove("byteOffset");
    acc.insert("count".into(), json!(count));
    acc.insert(
        "sparse".into(),
        json!({"count": 1, "indices": {"bufferView": iv, "componentType": 5125},
               "values": {"bufferView": vv}}),
    );
    json_bytes(&doc)
}

#[test]
fn sparse_accessor_without_a_buffer_view_with_10_to_the_10_elements() {
    expect_refused_under_ulimit(
        ao_wall_with_sparse_count(10_000_000_000),
        &[],
        &["needs an estimated", "10000000004 vertices"],
    );
    // Without a limit no buffer bounds the count: the 32-bit vertex index check refuses it
    // before reading.
    expect_refused_under_ulimit(
        ao_wall_with_sparse_count(10_000_000_000),
        &["--max-memory", "unlimited"],
        &["POSITION accessor 0", "10000000000 vertices", "32-bit"],
    );
    // 10^8 fits in 32 bits, but the NORMAL accessor beside it has 4 elements: refused from
    // the counts before 1.2 GB of zeros are decoded.
    expect_refused_under_ulimit(
        ao_wall_with_sparse_count(100_000_000),
        &["--max-memory", "unlimited"],
        &[
            "NORMAL accessor has 4 elements",
            "POSITION accessor 100000000",
        ],
    );
}

#[test]
fn normal_scene_under_a_tiny_memory_limit_is_refused() {
    // The file and geometry fit in 64 KiB; with the 32x32 image's 116 KiB they do not.
    let line = expect_refused(
        "scene.gltf",
        &[("scene.gltf", json_bytes(&ao_wall_json()))],
        &["--max-memory", "64K"],
        &[
            "needs an estimated",
            "for the image",
            "64.0 KiB",
            "--max-memory",
        ],
    );
    assert!(line.contains("8 vertices, 4 triangles"), "{line}");
}

#[test]
fn image_too_large_for_the_memory_limit_is_refused_after_the_camera_sets_it() {
    // Without --resolution the image size comes from the file's camera (640 wide): the
    // check runs after loading, before the BVH and the film are allocated.
    let tmp = tempfile::tempdir().unwrap();
    let wall = repo_path("scenes/ao-wall.gltf");
    let out = tmp.path().join("out.exr");
    let run = render(
        tmp.path(),
        &[s(&wall), "-o", s(&out), "--spp", "1", "--max-memory", "10M"],
    );
    assert_eq!(run.status.code(), Some(1), "{}", run.stderr);
    let line = assert_one_error_line(
        &run.stderr,
        &[s(&wall), "640x640 image", "10.0 MiB", "--max-memory"],
    );
    eprintln!("{line}");
    assert_entries(tmp.path(), &[]);
}

#[test]
fn normal_scene_under_the_default_limit_renders() {
    let tmp = tempfile::tempdir().unwrap();
    let wall = repo_path("scenes/ao-wall.gltf");
    let out = tmp.path().join("out.exr");
    let mut args = vec![s(&wall), "-o", s(&out), "--no-png", "--stats"];
    args.extend_from_slice(&SMALL);
    let run = render(tmp.path(), &args);
    assert!(run.status.success(), "{}", run.stderr);
    assert_no_panic(&run.stderr);
    // The default limit is 3/4 of physical memory, reported by --stats.
    let line = run
        .stdout
        .lines()
        .find(|l| l.starts_with("memory estimate:"))
        .unwrap_or_else(|| panic!("no memory estimate line:\n{}", run.stdout));
    assert!(!line.ends_with("limit none"), "{line}");
    assert_entries(tmp.path(), &["out.exr"]);
}

#[test]
fn max_memory_values_are_checked() {
    let tmp = tempfile::tempdir().unwrap();
    let wall = repo_path("scenes/ao-wall.gltf");
    let out = tmp.path().join("out.exr");
    for bad in ["0", "-5", "12Q", "lots"] {
        let option = format!("--max-memory={bad}");
        let run = render(tmp.path(), &[s(&wall), "-o", s(&out), &option]);
        assert!(!run.status.success(), "--max-memory {bad} accepted");
        assert_no_panic(&run.stderr);
        assert!(run.stderr.contains("--max-memory"), "{}", run.stderr);
        assert_entries(tmp.path(), &[]);
    }
    for good in ["4G", "512M", "1.5g", "100000000", "2GiB", "unlimited"] {
        let mut args = vec![s(&wall), "-o", s(&out), "--no-png", "--max-memory", good];
        args.extend_from_slice(&SMALL);
        let run = render(tmp.path(), &args);
        assert!(run.status.success(), "--max-memory {good}: {}", run.stderr);
    }
}

// ---------------------------------------------------------------------------------------
// Extensions, textures, cameras, nodes.

#[test]
fn unsupported_required_extension_in_a_glb() {
    // tests/cli.rs covers EXT_texture_avif in a .gltf; this is another one, in a .glb.
    let mut doc = ao_wall_json();
    let bin = ao_wall_buffer();
    doc["buffers"][0] = json!({ "byteLength": bin.len() });
    doc["extensionsUsed"] = json!(["KHR_gaussian_splatting"]);
    doc["extensionsRequired"] = json!(["KHR_gaussian_splatting"]);
    expect_refused(
        "scene.glb",
        &[("scene.glb", glb(&doc, &bin))],
        &[],
        &[
            "requires the extension KHR_gaussian_splatting",
            "not support",
        ],
    );
}

/// ao-wall with a base colour texture whose PNG is broken.
fn with_broken_texture(d: &mut Value) {
    let png = b"\x89PNG\r\n\x1a\nthis is not a PNG after all";
    d["images"] = json!([{"uri": data_uri(png).replace("application/octet-stream", "image/png")}]);
    d["textures"] = json!([{"source": 0}]);
    d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
}

#[test]
fn texture_that_does_not_decode() {
    // `direct` reads base colour textures, so it decodes them (before rendering).
    expect_json_refused(
        with_broken_texture,
        &["--integrator", "direct", "--background", "1"],
        &["cannot decode embedded image 0"],
    );
}

#[test]
fn texture_that_does_not_decode_is_not_read_by_ao() {
    // The control: AO reads no texture, so the same file renders.
    let mut doc = ao_wall_json();
    with_broken_texture(&mut doc);
    let tmp = tempfile::tempdir().unwrap();
    let scene = tmp.path().join("scene.gltf");
    std::fs::write(&scene, json_bytes(&doc)).unwrap();
    let out = tmp.path().join("out.exr");
    let mut args = vec![s(&scene), "-o", s(&out), "--no-png", "--integrator", "ao"];
    args.extend_from_slice(&SMALL);
    let run = render(tmp.path(), &args);
    assert!(run.status.success(), "{}", run.stderr);
}

#[test]
fn camera_with_zero_yfov() {
    expect_json_refused(
        |d| d["cameras"][0]["perspective"]["yfov"] = json!(0.0),
        &[],
        &["camera 0", "yfov 0"],
    );
}

#[test]
fn camera_with_zero_aspect_ratio() {
    expect_json_refused(
        |d| d["cameras"][0]["perspective"]["aspectRatio"] = json!(0.0),
        &[],
        &["camera 0", "aspectRatio 0"],
    );
}

#[test]
fn orthographic_camera_with_zero_magnification() {
    expect_json_refused(
        |d| {
            d["cameras"][0] = json!({"type": "orthographic",
                "orthographic": {"xmag": 0.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0}})
        },
        &[],
        &["camera 0", "xmag 0"],
    );
}

#[test]
fn node_matrix_that_overflows_to_infinity() {
    // JSON cannot hold NaN (see json_nan_is_not_json), but 1e39 overflows f32 to infinity.
    expect_json_refused(
        |d| d["nodes"][0]["matrix"] = json!([1e39, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]),
        &[],
        &["node 0", "non-finite transform"],
    );
}

#[test]
fn camera_whose_composed_transform_overflows() {
    // Each matrix is finite, their product (1e60 in f64) is not representable in f32.
    expect_json_refused(
        |d| {
            let big = json!([1e30, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
            d["nodes"][2]["matrix"] = big.clone();
            d["nodes"][2].as_object_mut().unwrap().remove("translation");
            d["nodes"][2].as_object_mut().unwrap().remove("rotation");
            d["nodes"]
                .as_array_mut()
                .unwrap()
                .push(json!({"matrix": big, "children": [2]}));
            d["scenes"][0]["nodes"] = json!([0, 1, 3]);
        },
        &[],
        &["camera 0", "overflows single precision"],
    );
}

#[test]
fn cyclic_node_graph() {
    expect_json_refused(
        |d| {
            d["nodes"][0]["children"] = json!([1]);
            d["nodes"][1]["children"] = json!([0]);
            d["scenes"][0]["nodes"] = json!([0, 2]);
        },
        &[],
        &["node 0", "cycle"],
    );
}

#[test]
fn node_with_two_parents() {
    // Without this check, 60 nodes each listing the next twice would be flattened 2^60 times.
    let line = expect_json_refused(
        |d| {
            let nodes = d["nodes"].as_array_mut().unwrap();
            let first = nodes.len();
            for i in 0..60 {
                nodes.push(if i < 59 {
                    json!({"children": [first + i + 1, first + i + 1]})
                } else {
                    json!({"mesh": 0})
                });
            }
            d["scenes"][0]["nodes"] = json!([first, 2]);
        },
        &[],
        &["more than one parent"],
    );
    // Depth first: the first node reached twice is the chain's last (3 + 59).
    assert!(line.contains("node 62 "), "{line}");
}
