//! The bad-input table of ROBUSTNESS.md: broken scene files through the `render` binary.
//!
//! Every case writes its files into a fresh temporary directory (also the working directory)
//! and asserts: a non-zero exit, exactly one line on stderr, `error: <scene file>: <problem>`
//! naming the file and the problem, no panic, and no output (the directory holds exactly the
//! input files afterwards: no EXR, no PNG, no temporary file). Cases that already live in
//! tests/cli.rs (missing file, not glTF, truncated JSON in a .glb, missing external buffer,
//! unsupported required extension, no triangles) are not repeated here. The cases are the
//! rows of [`refusals`], checked by one test, which names every failing case.
//!
//! Also here: the resource limit (`--max-memory`), and absurd counts under a 1 GiB
//! address-space limit (`ulimit -v`), which shows they are refused before allocating.
//!
//! `cargo test --release --test bad_input -- --nocapture` prints each error line.

mod common;

use common::*;
use serde_json::{json, Value};

const SMALL: [&str; 4] = ["--resolution", "32x32", "--spp", "4"];

/// A 1 GiB address-space limit: an allocation for 10^9 or 10^12 vertices would fail (and
/// abort the process, which the one-line-error check would catch).
const ULIMIT_1GIB: &str = "ulimit -v 1048576";

/// A scene `render` must refuse: its files are written into a fresh temporary directory (also
/// the working directory) and it is rendered as `<scene> -o out.exr <options>`. The render
/// must exit with status 1 and print exactly one line, `error: ...`, naming the scene and
/// every word of `words` (case-insensitively) and of `line_has` (as written), without a
/// panic, and leave the directory holding its files alone.
struct Refusal {
    name: &'static str,
    /// The scene's path; `{tmp}` stands for the temporary directory.
    scene: String,
    /// The files written first, by name.
    files: Vec<(&'static str, Vec<u8>)>,
    options: Vec<&'static str>,
    words: &'static [&'static str],
    line_has: &'static [&'static str],
    /// Run under [`ULIMIT_1GIB`], and refused within 5 s.
    under_1gib: bool,
}

impl Refusal {
    /// The scene at `scene` (nothing written), rendered small.
    fn at(name: &'static str, scene: &str, words: &'static [&'static str]) -> Refusal {
        Refusal {
            name,
            scene: scene.to_string(),
            files: Vec::new(),
            options: SMALL.to_vec(),
            words,
            line_has: &[],
            under_1gib: false,
        }
    }

    /// The scene `file`, written with `bytes`, rendered small.
    fn file(
        name: &'static str,
        file: &'static str,
        bytes: Vec<u8>,
        words: &'static [&'static str],
    ) -> Refusal {
        Refusal {
            files: vec![(file, bytes)],
            ..Refusal::at(name, &format!("{{tmp}}/{file}"), words)
        }
    }

    /// ao-wall with `edit` applied, as scene.gltf.
    fn json(
        name: &'static str,
        edit: impl FnOnce(&mut Value),
        words: &'static [&'static str],
    ) -> Refusal {
        let mut doc = ao_wall_json();
        edit(&mut doc);
        Refusal::file(name, "scene.gltf", json_bytes(&doc), words)
    }

    /// `bytes` as huge.gltf, under [`ULIMIT_1GIB`].
    fn huge(name: &'static str, bytes: Vec<u8>, words: &'static [&'static str]) -> Refusal {
        Refusal {
            under_1gib: true,
            ..Refusal::file(name, "huge.gltf", bytes, words)
        }
    }

    /// With `extra` options after the small image's.
    fn with(mut self, extra: &[&'static str]) -> Refusal {
        self.options.extend_from_slice(extra);
        self
    }

    /// With `options` instead of the small image's.
    fn options(self, options: &[&'static str]) -> Refusal {
        Refusal {
            options: options.to_vec(),
            ..self
        }
    }

    /// The error line must also contain each of `words` as written.
    fn line_has(self, line_has: &'static [&'static str]) -> Refusal {
        Refusal { line_has, ..self }
    }
}

fn json_bytes(doc: &Value) -> Vec<u8> {
    serde_json::to_vec_pretty(doc).unwrap()
}

/// The refusals, by kind.
fn refusals() -> Vec<Refusal> {
    let mut cases = Vec::new();

    // Binary glTF containers.
    let wall = ao_wall_glb();
    cases.push(Refusal::file(
        "glb_truncated_in_the_binary_chunk",
        "scene.glb",
        wall[..wall.len() - 100].to_vec(),
        &["invalid binary glTF", "truncated", "declares"],
    ));
    cases.push(Refusal::file(
        "glb_shorter_than_its_header",
        "scene.glb",
        wall[..10].to_vec(),
        &["truncated", "12-byte header"],
    ));
    // The header's total length is right, but the JSON chunk claims more than there is.
    let mut long_chunk = wall.clone();
    long_chunk[12..16].copy_from_slice(&1_000_000u32.to_le_bytes());
    cases.push(Refusal::file(
        "glb_chunk_longer_than_the_file",
        "scene.glb",
        long_chunk,
        &["chunk 0", "1000000 bytes", "past the end"],
    ));
    let mut wrong_magic = wall.clone();
    wrong_magic[..4].copy_from_slice(b"glTX");
    cases.push(Refusal::file(
        "glb_wrong_magic",
        "scene.glb",
        wrong_magic,
        &["not a glTF file", "magic"],
    ));
    let mut version_1 = wall;
    version_1[4..8].copy_from_slice(&1u32.to_le_bytes());
    cases.push(Refusal::file(
        "glb_version_1",
        "scene.glb",
        version_1,
        &["binary glTF", "version 1"],
    ));
    cases.push(Refusal::file(
        "empty_file",
        "scene.gltf",
        Vec::new(),
        &["empty"],
    ));

    // JSON.
    let text = json_bytes(&ao_wall_json());
    cases.push(Refusal::file(
        "json_syntax_error",
        "scene.gltf",
        text[..text.len() / 2].to_vec(),
        &["invalid glTF", "line", "column"],
    ));
    cases.push(Refusal::json(
        "json_wrong_type",
        |d| d["accessors"] = json!(5),
        &["invalid glTF", "invalid type", "line"],
    ));
    cases.push(Refusal::json(
        "json_missing_required_field",
        |d| {
            d.as_object_mut().unwrap().remove("asset");
        },
        &["invalid glTF", "missing field `asset`"],
    ));
    // JSON has no NaN: the parser stops at it (the position names where).
    let text = String::from_utf8(text).unwrap().replacen(
        "\"name\": \"floor\",",
        "\"name\": \"floor\", \"matrix\": [NaN, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1],",
        1,
    );
    assert!(text.contains("NaN"));
    cases.push(Refusal::file(
        "json_nan_is_not_json",
        "scene.gltf",
        text.into_bytes(),
        &["invalid glTF", "expected value", "line"],
    ));

    // Accessors, indices, buffer views, buffers.
    cases.push(Refusal::json(
        "accessor_past_its_buffer_view",
        |d| d["accessors"][0]["count"] = json!(5),
        &["accessor 0", "5 elements", "past the end of bufferView 0"],
    ));
    // Was a panic inside the gltf crate's validation (it indexes the POSITION accessor
    // unchecked); now checked first.
    cases.push(Refusal::json(
        "accessor_index_out_of_range",
        |d| d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(99),
        &["POSITION refers to accessor 99", "6 accessor"],
    ));
    // Every other dangling index is caught by the gltf crate's validation.
    cases.push(Refusal::json(
        "other_reference_out_of_range",
        |d| d["meshes"][0]["primitives"][0]["indices"] = json!(42),
        &["invalid glTF", "indices", "index out of bounds"],
    ));
    let mut bin = ao_wall_buffer();
    // The floor's index list is bufferView 2 at byte 96: make its first index 7 (4 vertices).
    bin[96..100].copy_from_slice(&7u32.to_le_bytes());
    cases.push(Refusal::json(
        "vertex_index_out_of_range",
        |d| d["buffers"][0]["uri"] = json!(data_uri(&bin)),
        &["vertex index 7 out of range", "4 vertices"],
    ));
    cases.push(Refusal::json(
        "buffer_view_past_its_buffer",
        |d| d["bufferViews"][5]["byteLength"] = json!(4000),
        &["bufferView 5", "past the end of buffer 0", "240 bytes"],
    ));
    cases.push(Refusal::json(
        "buffer_shorter_than_its_byte_length",
        |d| d["buffers"][0]["byteLength"] = json!(100_000),
        &["buffer 0", "byteLength 100000"],
    ));
    cases.push(Refusal::json(
        "data_uri_with_invalid_base64",
        |d| d["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@not base64!"),
        &["buffer 0", "not valid base64"],
    ));
    cases.push(Refusal::json(
        "data_uri_not_base64_encoded",
        |d| d["buffers"][0]["uri"] = json!("data:application/octet-stream,hello"),
        &["buffer 0", "not base64-encoded"],
    ));
    // Under --strict (without it they warn and render: textures_that_cannot_be_had_*).
    cases.push(
        Refusal::json(
            "missing_external_image",
            with_missing_texture,
            &["image 0", "nothere.png", "does not exist", "--strict"],
        )
        .with(&["--strict"]),
    );
    // /dev/zero never ends: reading it whole would exhaust memory.
    cases.push(Refusal::json(
        "buffer_that_is_not_a_regular_file",
        |d| d["buffers"][0]["uri"] = json!("/dev/zero"),
        &["buffer 0", "/dev/zero", "not a regular file"],
    ));
    cases.push(Refusal::at(
        "scene_that_is_not_a_regular_file: /dev/zero",
        "/dev/zero",
        &["not a regular file"],
    ));
    cases.push(Refusal::at(
        "scene_that_is_not_a_regular_file: a directory",
        "{tmp}",
        &["is a directory"],
    ));

    // Absurd counts and the memory limit.
    // Refused by the memory estimate made from the declared counts (58 TiB is more than the
    // default limit, 3/4 of physical memory, on any machine) ...
    cases.push(Refusal::huge(
        "absurd_count_10_to_the_12_is_refused_before_allocating: by the estimate",
        ao_wall_with_count(1_000_000_000_000),
        &[
            "needs an estimated",
            "1000000000004 vertices",
            "--max-memory",
        ],
    ));
    // ... and without a limit, by the range check of the accessor against its buffer view.
    cases.push(
        Refusal::huge(
            "absurd_count_10_to_the_12_is_refused_before_allocating: without a limit",
            ao_wall_with_count(1_000_000_000_000),
            &[
                "accessor 0",
                "1000000000000 elements",
                "past the end of bufferView 0",
            ],
        )
        .with(&["--max-memory", "unlimited"]),
    );
    cases.push(
        Refusal::huge(
            "absurd_count_10_to_the_9_is_refused_by_the_memory_estimate",
            ao_wall_with_count(1_000_000_000),
            &[
                "needs an estimated",
                "1000000004 vertices",
                "1.0 GiB",
                "--max-memory",
            ],
        )
        .with(&["--max-memory", "1G"]),
    );
    cases.push(Refusal::huge(
        "sparse_accessor_without_a_buffer_view_with_10_to_the_10_elements: by the estimate",
        ao_wall_with_sparse_count(10_000_000_000),
        &["needs an estimated", "10000000004 vertices"],
    ));
    // Without a limit no buffer bounds the count: the 32-bit vertex index check refuses it
    // before reading.
    cases.push(
        Refusal::huge(
            "sparse_accessor_without_a_buffer_view_with_10_to_the_10_elements: 32-bit",
            ao_wall_with_sparse_count(10_000_000_000),
            &["POSITION accessor 0", "10000000000 vertices", "32-bit"],
        )
        .with(&["--max-memory", "unlimited"]),
    );
    // 10^8 fits in 32 bits, but the NORMAL accessor beside it has 4 elements: refused from
    // the counts before 1.2 GB of zeros are decoded.
    cases.push(
        Refusal::huge(
            "sparse_accessor_without_a_buffer_view_with_10_to_the_10_elements: 10^8",
            ao_wall_with_sparse_count(100_000_000),
            &[
                "NORMAL accessor has 4 elements",
                "POSITION accessor 100000000",
            ],
        )
        .with(&["--max-memory", "unlimited"]),
    );
    // The file and geometry fit in 64 KiB; with the 32x32 image's 116 KiB they do not.
    cases.push(
        Refusal::file(
            "normal_scene_under_a_tiny_memory_limit_is_refused",
            "scene.gltf",
            json_bytes(&ao_wall_json()),
            &[
                "needs an estimated",
                "for the image",
                "64.0 KiB",
                "--max-memory",
            ],
        )
        .with(&["--max-memory", "64K"])
        .line_has(&["8 vertices, 4 triangles"]),
    );
    // The file, geometry and image fit in 512 KiB; with the 256x256 texture decoded (1 MiB
    // of RGBA in f32) they do not: refused once the image's header gives its size.
    let mut doc = ao_wall_json();
    doc["images"] = json!([{"uri": "big.png"}]);
    doc["textures"] = json!([{"source": 0}]);
    doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    cases.push(Refusal {
        files: vec![("scene.gltf", json_bytes(&doc)), ("big.png", png(256, 256))],
        ..Refusal::at(
            "textured_scene_under_a_limit_its_texture_passes_is_refused",
            "{tmp}/scene.gltf",
            &[
                "needs an estimated",
                "1.0 MiB for 1 decoded texture",
                "--max-memory",
            ],
        )
        .with(&["--max-memory", "512K"])
    });
    // Without --resolution the image size comes from the file's camera (640 wide): the
    // check runs after loading, before the BVH and the film are allocated.
    cases.push(
        Refusal::at(
            "image_too_large_for_the_memory_limit_is_refused_after_the_camera_sets_it",
            s(&repo_path("scenes/ao-wall.gltf")),
            &["640x640 image", "10.0 MiB", "--max-memory"],
        )
        .options(&["--spp", "1", "--max-memory", "10M"]),
    );

    // Extensions, textures, cameras, nodes.
    // tests/cli.rs covers EXT_texture_avif in a .gltf; this is another one, in a .glb.
    let mut doc = ao_wall_json();
    let bin = ao_wall_buffer();
    doc["buffers"][0] = json!({ "byteLength": bin.len() });
    doc["extensionsUsed"] = json!(["KHR_gaussian_splatting"]);
    doc["extensionsRequired"] = json!(["KHR_gaussian_splatting"]);
    cases.push(Refusal::file(
        "unsupported_required_extension_in_a_glb",
        "scene.glb",
        glb(&doc, &bin),
        &[
            "requires the extension KHR_gaussian_splatting",
            "not support",
        ],
    ));
    // `direct` reads base colour textures, so it decodes them (before rendering); the
    // header passes, the data does not.
    cases.push(
        Refusal::json(
            "texture_that_does_not_decode",
            with_broken_texture,
            &["image 0 (embedded)", "--strict"],
        )
        .with(&["--integrator", "direct", "--background", "1", "--strict"]),
    );
    cases.push(Refusal::json(
        "camera_with_zero_yfov",
        |d| d["cameras"][0]["perspective"]["yfov"] = json!(0.0),
        &["camera 0", "yfov 0"],
    ));
    cases.push(Refusal::json(
        "camera_with_zero_aspect_ratio",
        |d| d["cameras"][0]["perspective"]["aspectRatio"] = json!(0.0),
        &["camera 0", "aspectRatio 0"],
    ));
    cases.push(Refusal::json(
        "orthographic_camera_with_zero_magnification",
        |d| {
            d["cameras"][0] = json!({"type": "orthographic",
                "orthographic": {"xmag": 0.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0}})
        },
        &["camera 0", "xmag 0"],
    ));
    // JSON cannot hold NaN (see json_nan_is_not_json), but 1e39 overflows f32 to infinity.
    cases.push(Refusal::json(
        "node_matrix_that_overflows_to_infinity",
        |d| d["nodes"][0]["matrix"] = json!([1e39, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]),
        &["node 0", "non-finite transform"],
    ));
    // Each matrix is finite, their product (1e60 in f64) is not representable in f32.
    cases.push(Refusal::json(
        "camera_whose_composed_transform_overflows",
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
        &["camera 0", "overflows single precision"],
    ));
    cases.push(Refusal::json(
        "cyclic_node_graph",
        |d| {
            d["nodes"][0]["children"] = json!([1]);
            d["nodes"][1]["children"] = json!([0]);
            d["scenes"][0]["nodes"] = json!([0, 2]);
        },
        &["node 0", "cycle"],
    ));
    // Without this check, 60 nodes each listing the next twice would be flattened 2^60 times.
    // Depth first: the first node reached twice is the chain's last (3 + 59).
    cases.push(
        Refusal::json(
            "node_with_two_parents",
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
            &["more than one parent"],
        )
        .line_has(&["node 62 "]),
    );
    cases
}

/// Every case of [`refusals`]; a failure names each failing case.
#[test]
fn broken_scenes_are_refused() {
    check_every_case(&refusals(), |case| case.name, check_refusal);
}

fn check_refusal(case: &Refusal) {
    let tmp = tempfile::tempdir().unwrap();
    for (name, bytes) in &case.files {
        std::fs::write(tmp.path().join(name), bytes).unwrap();
    }
    let scene = case.scene.replace("{tmp}", s(tmp.path()));
    let out = tmp.path().join("out.exr");
    let mut args = vec![scene.as_str(), "-o", s(&out)];
    args.extend_from_slice(&case.options);
    let run = if case.under_1gib {
        render_under_shell(tmp.path(), ULIMIT_1GIB, &args)
    } else {
        render(tmp.path(), &args)
    };
    assert!(
        !run.status.success(),
        "render should refuse {scene}; stdout:\n{}\nstderr:\n{}",
        run.stdout,
        run.stderr
    );
    assert_eq!(run.status.code(), Some(1), "exit status: {}", run.status);
    let mut all = vec![scene.as_str()];
    all.extend_from_slice(case.words);
    let line = assert_one_error_line(&run.stderr, &all);
    for word in case.line_has {
        assert!(
            line.contains(word),
            "the error should contain {word:?}: {line}"
        );
    }
    if case.under_1gib {
        assert!(
            run.elapsed.as_secs_f64() < 5.0,
            "refusing took {:?}",
            run.elapsed
        );
    }
    let names: Vec<&str> = case.files.iter().map(|(n, _)| *n).collect();
    assert_entries(tmp.path(), &names);
    let line = line.replace(&format!("{}/", s(tmp.path())), "");
    if case.under_1gib {
        eprintln!("{line} ({:.3} s)", run.elapsed.as_secs_f64());
    } else {
        eprintln!("{line}");
    }
}

// ---------------------------------------------------------------------------------------
// The controls (what renders), --max-memory values, and the helpers of the cases above.

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

/// ao-wall with accessor 0 (the floor's positions) claiming `count` vertices.
fn ao_wall_with_count(count: u64) -> Vec<u8> {
    let mut doc = ao_wall_json();
    doc["accessors"][0]["count"] = json!(count);
    json_bytes(&doc)
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

/// A grey PNG of `width × height` pixels.
fn png(width: u32, height: u32) -> Vec<u8> {
    let mut png = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut png),
        &vec![128; (width * height * 4) as usize],
        width,
        height,
        image::ExtendedColorType::Rgba8,
    )
    .unwrap();
    png
}

/// ao-wall with a base colour texture whose image file does not exist.
fn with_missing_texture(d: &mut Value) {
    d["images"] = json!([{"uri": "nothere.png"}]);
    d["textures"] = json!([{"source": 0}]);
    d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
}

/// Without `--strict`, a texture whose image is missing or does not decode (a file that is
/// not there, a PNG cut after its signature, a file in no format strata reads, an embedded
/// image cut short) renders without it, and one warning line names the scene, the image and
/// the problem: the image is the one without the texture, pixel for pixel.
#[test]
fn textures_that_cannot_be_had_warn_and_render_with_their_factors() {
    let tmp = tempfile::tempdir().unwrap();
    let render_one = |name: &str, doc: &Value| {
        let scene = tmp.path().join(format!("{name}.gltf"));
        std::fs::write(&scene, json_bytes(doc)).unwrap();
        let out = tmp.path().join(format!("{name}.exr"));
        let mut args = vec![s(&scene), "-o", s(&out), "--no-png", "--integrator", "path"];
        args.extend_from_slice(&SMALL);
        let run = render(tmp.path(), &args);
        run.assert_success();
        let pixels = strata::render::output::read_exr_rgb(&out).unwrap().2;
        (run.stderr, pixels)
    };
    let (_, plain) = render_one("plain", &ao_wall_json());
    let good = png(4, 4);
    std::fs::write(tmp.path().join("cut.png"), &good[..good.len() - 20]).unwrap();
    std::fs::write(tmp.path().join("notes.png"), b"plain text, not an image").unwrap();
    let cases: [(&str, Value, &[&str]); 4] = [
        (
            "missing",
            json!({"uri": "nothere.png", "name": "albedo"}),
            &["image 0 'albedo' (nothere.png)", "does not exist"],
        ),
        ("cut", json!({"uri": "cut.png"}), &["image 0 (cut.png)"]),
        (
            "not_an_image",
            json!({"uri": "notes.png"}),
            &["image 0 (notes.png)", "format", "PNG, JPEG"],
        ),
        (
            "embedded_cut",
            json!({"uri": data_uri(&good[..30]).replace("application/octet-stream", "image/png")}),
            &["image 0 (embedded)"],
        ),
    ];
    for (name, image, words) in cases {
        let mut doc = ao_wall_json();
        with_missing_texture(&mut doc);
        doc["images"] = json!([image]);
        let (stderr, pixels) = render_one(name, &doc);
        let lines: Vec<&str> = (stderr.lines())
            .filter(|l| l.contains("as if absent"))
            .collect();
        assert_eq!(lines.len(), 1, "{name}: {stderr}");
        let line = lines[0];
        assert!(
            line.starts_with("warning: ") && line.contains(&format!("{name}.gltf")),
            "{line}"
        );
        for word in words.iter().chain(&["factors alone", "in material 0"]) {
            assert!(line.contains(word), "{name}: '{word}' not in {line}");
        }
        assert!(
            pixels == plain,
            "{name}: the image differs from the untextured one"
        );
    }
}

/// Every texture slot strata renders, core and extension (`KHR_materials_*`), each bound to
/// an image that does not exist, renders as the same material without that texture, pixel
/// for pixel, with the warning for that image; so do the slots strata does not read
/// (occlusion, the volume's thickness), without it. A slot that kept its texture with no
/// image, or filled it with anything, would fail the comparison or the render.
#[test]
fn every_texture_slot_with_a_missing_image_renders_as_without_it() {
    let tmp = tempfile::tempdir().unwrap();
    let tex = json!({"index": 0});
    // (name, the material with the texture at `slot`, a JSON pointer; whether strata reads it)
    let base = json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.5, 0.3, 1.0],
        "metallicFactor": 0.3, "roughnessFactor": 0.5}});
    let with_ext = |ext: &str, body: Value| {
        let mut m = base.clone();
        m["extensions"] = json!({ ext: body });
        m
    };
    let mut emissive = base.clone();
    emissive["emissiveFactor"] = json!([0.5, 0.2, 0.1]);
    let slots: Vec<(&str, Value, &str, bool)> = vec![
        (
            "base colour",
            base.clone(),
            "/pbrMetallicRoughness/baseColorTexture",
            true,
        ),
        (
            "metallic-roughness",
            base.clone(),
            "/pbrMetallicRoughness/metallicRoughnessTexture",
            true,
        ),
        ("normal", base.clone(), "/normalTexture", true),
        ("occlusion", base.clone(), "/occlusionTexture", false),
        ("emissive", emissive, "/emissiveTexture", true),
        (
            "transmission",
            with_ext(
                "KHR_materials_transmission",
                json!({"transmissionFactor": 0.5}),
            ),
            "/extensions/KHR_materials_transmission/transmissionTexture",
            true,
        ),
        (
            "volume thickness",
            {
                let mut m = with_ext(
                    "KHR_materials_transmission",
                    json!({"transmissionFactor": 0.5}),
                );
                m["extensions"]["KHR_materials_volume"] = json!({"thicknessFactor": 0.2});
                m
            },
            "/extensions/KHR_materials_volume/thicknessTexture",
            false,
        ),
        (
            "specular",
            with_ext("KHR_materials_specular", json!({"specularFactor": 0.7})),
            "/extensions/KHR_materials_specular/specularTexture",
            true,
        ),
        (
            "specular colour",
            with_ext(
                "KHR_materials_specular",
                json!({"specularColorFactor": [0.9, 0.8, 0.7]}),
            ),
            "/extensions/KHR_materials_specular/specularColorTexture",
            true,
        ),
        (
            "clearcoat",
            with_ext("KHR_materials_clearcoat", json!({"clearcoatFactor": 0.8})),
            "/extensions/KHR_materials_clearcoat/clearcoatTexture",
            true,
        ),
        (
            "clearcoat roughness",
            with_ext(
                "KHR_materials_clearcoat",
                json!({"clearcoatFactor": 0.8, "clearcoatRoughnessFactor": 0.4}),
            ),
            "/extensions/KHR_materials_clearcoat/clearcoatRoughnessTexture",
            true,
        ),
        (
            "clearcoat normal",
            with_ext("KHR_materials_clearcoat", json!({"clearcoatFactor": 0.8})),
            "/extensions/KHR_materials_clearcoat/clearcoatNormalTexture",
            true,
        ),
        (
            "sheen colour",
            with_ext(
                "KHR_materials_sheen",
                json!({"sheenColorFactor": [0.6, 0.6, 0.6], "sheenRoughnessFactor": 0.5}),
            ),
            "/extensions/KHR_materials_sheen/sheenColorTexture",
            true,
        ),
        (
            "sheen roughness",
            with_ext(
                "KHR_materials_sheen",
                json!({"sheenColorFactor": [0.6, 0.6, 0.6], "sheenRoughnessFactor": 0.5}),
            ),
            "/extensions/KHR_materials_sheen/sheenRoughnessTexture",
            true,
        ),
        (
            "anisotropy",
            with_ext(
                "KHR_materials_anisotropy",
                json!({"anisotropyStrength": 0.6}),
            ),
            "/extensions/KHR_materials_anisotropy/anisotropyTexture",
            true,
        ),
        (
            "iridescence",
            with_ext(
                "KHR_materials_iridescence",
                json!({"iridescenceFactor": 1.0}),
            ),
            "/extensions/KHR_materials_iridescence/iridescenceTexture",
            true,
        ),
        (
            "iridescence thickness",
            with_ext(
                "KHR_materials_iridescence",
                json!({"iridescenceFactor": 1.0}),
            ),
            "/extensions/KHR_materials_iridescence/iridescenceThicknessTexture",
            true,
        ),
    ];
    // ao-wall with texture coordinates (the quads' corners at the unit square's), so that
    // normal maps and anisotropy have tangent frames and every texture could show.
    let mut wall = ao_wall_json();
    let mut bin = ao_wall_buffer();
    let uv_offset = bin.len();
    for v in [0f32, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    wall["buffers"][0] = json!({"uri": data_uri(&bin), "byteLength": bin.len()});
    let views = wall["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 0, "byteOffset": uv_offset, "byteLength": 32}));
    let view = views.len() - 1;
    let accessors = wall["accessors"].as_array_mut().unwrap();
    accessors.push(json!({"bufferView": view, "componentType": 5126, "count": 4, "type": "VEC2"}));
    let uv = accessors.len() - 1;
    for mesh in wall["meshes"].as_array_mut().unwrap() {
        mesh["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv);
    }
    let render_one = |name: String, material: &Value, textured: bool| {
        let mut doc = wall.clone();
        for m in doc["materials"].as_array_mut().unwrap() {
            *m = material.clone();
        }
        if let Some(e) = material.get("extensions").and_then(Value::as_object) {
            doc["extensionsUsed"] = e.keys().cloned().collect();
        }
        if textured {
            doc["images"] = json!([{"uri": "lost.png", "name": "lost"}]);
            doc["textures"] = json!([{"source": 0}]);
        }
        let scene = tmp.path().join(format!("{name}.gltf"));
        std::fs::write(&scene, json_bytes(&doc)).unwrap();
        let out = tmp.path().join(format!("{name}.exr"));
        let mut args = vec![s(&scene), "-o", s(&out), "--no-png", "--integrator", "path"];
        args.extend_from_slice(&["--resolution", "12x12", "--spp", "2"]);
        let run = render(tmp.path(), &args);
        run.assert_success();
        let pixels = strata::render::output::read_exr_rgb(&out).unwrap().2;
        (run.stderr, pixels)
    };
    let mut failures = Vec::new();
    for (i, (name, material, slot, read)) in slots.iter().enumerate() {
        let mut textured = material.clone();
        let (parent, key) = slot.rsplit_once('/').unwrap();
        textured
            .pointer_mut(parent)
            .unwrap_or_else(|| panic!("{name}: {parent}"))[key] = tex.clone();
        let (stderr, with) = render_one(format!("{i}-with"), &textured, true);
        let (_, without) = render_one(format!("{i}-without"), material, false);
        let warned = (stderr.lines())
            .filter(|l| l.contains("image 0 'lost' (lost.png)") && l.contains("as if absent"))
            .count();
        if warned != usize::from(*read) {
            failures.push(format!(
                "{name}: {warned} warning(s) for the missing image:
{stderr}"
            ));
        }
        if with != without {
            failures.push(format!(
                "{name}: the image differs from the material's without the texture"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// ao-wall with a base colour texture whose PNG is broken.
fn with_broken_texture(d: &mut Value) {
    let png = b"\x89PNG\r\n\x1a\nthis is not a PNG after all";
    d["images"] = json!([{"uri": data_uri(png).replace("application/octet-stream", "image/png")}]);
    d["textures"] = json!([{"source": 0}]);
    d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
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
