//! glTF animations (`--frame`, `--frames`, `--fps`, `--animation`): a file whose nodes move by
//! linear, step and cubic-spline channels is flattened in the pose of the asked time, checked
//! against transforms computed here by hand; frames are written one EXR each, with the frame
//! number in the name; and a file's animations are never dropped silently.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use glam::Vec3;
use serde_json::json;
use strata::scene::{load, LoadOptions, PoseTime};

/// Little-endian bytes of f32 values.
fn floats(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|f| f.to_le_bytes()).collect()
}

/// A scene of two nodes, each one triangle with corners (1, 0, 0), (0, 1, 0), (0, 0, 1)
/// before its transform, under a camera looking at them, and two animations:
///
/// animation 0: node 0 ("mover") translated LINEAR from (0, 0, 0) at 0 s to (4, 0, 0) at 2 s,
/// rotated LINEAR (slerp) from the identity at 0 s to 90° about +z at 2 s, scaled STEP from
/// 1 at 0 s to 2 at 1 s; node 1 ("easer", rest translation (0, 0, −3)) translated
/// CUBICSPLINE from (0, 0, 0) at 0 s to (0, 3, 0) at 1 s with zero tangents; plus one
/// channel of morph target weights (not rendered).
///
/// animation 1: node 0 translated STEP to (0, 0, 7) from 0 s.
fn animated_scene(dir: &Path) -> PathBuf {
    let s45 = std::f32::consts::FRAC_1_SQRT_2;
    let parts: Vec<Vec<u8>> = vec![
        floats(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]), // 0 positions
        floats(&[0.0, 2.0]),                                    // 1 times 0, 2
        floats(&[0.0, 0.0, 0.0, 4.0, 0.0, 0.0]),                // 2 translations
        floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, s45, s45]),      // 3 rotations (xyzw)
        floats(&[0.0, 1.0]),                                    // 4 times 0, 1
        floats(&[1.0, 1.0, 1.0, 2.0, 2.0, 2.0]),                // 5 scales
        // 6: cubic spline (in-tangent, value, out-tangent) per key frame
        floats(&[
            0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 3.0, 0.0, 0.0, 0.0,
            0.0,
        ]),
        floats(&[0.5, 0.5]),      // 7 morph weights
        floats(&[0.0]),           // 8 time 0
        floats(&[0.0, 0.0, 7.0]), // 9 translation
    ];
    let mut bin = Vec::new();
    let mut views = Vec::new();
    for p in &parts {
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": p.len()}));
        bin.extend_from_slice(p);
    }
    let acc = |view: usize, count: usize, ty: &str| json!({"bufferView": view, "componentType": 5126, "count": count, "type": ty});
    let mut accessors = vec![
        json!({"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
               "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0]}),
        json!({"bufferView": 1, "componentType": 5126, "count": 2, "type": "SCALAR",
               "min": [0.0], "max": [2.0]}),
        acc(2, 2, "VEC3"),
        acc(3, 2, "VEC4"),
        json!({"bufferView": 4, "componentType": 5126, "count": 2, "type": "SCALAR",
               "min": [0.0], "max": [1.0]}),
        acc(5, 2, "VEC3"),
        acc(6, 6, "VEC3"),
        acc(7, 2, "SCALAR"),
        json!({"bufferView": 8, "componentType": 5126, "count": 1, "type": "SCALAR",
               "min": [0.0], "max": [0.0]}),
        acc(9, 1, "VEC3"),
    ];
    accessors.truncate(10);
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"name": "mover", "mesh": 0},
            {"name": "easer", "mesh": 0, "translation": [0.0, 0.0, -3.0]},
            {"camera": 0, "translation": [0.0, 0.0, 10.0]}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.1}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "buffers": [{"byteLength": bin.len(), "uri": data_uri(&bin)}],
        "bufferViews": views,
        "accessors": accessors,
        "animations": [
            {
                "name": "move",
                "samplers": [
                    {"input": 1, "output": 2, "interpolation": "LINEAR"},
                    {"input": 1, "output": 3, "interpolation": "LINEAR"},
                    {"input": 4, "output": 5, "interpolation": "STEP"},
                    {"input": 4, "output": 6, "interpolation": "CUBICSPLINE"},
                    {"input": 4, "output": 7, "interpolation": "LINEAR"}
                ],
                "channels": [
                    {"sampler": 0, "target": {"node": 0, "path": "translation"}},
                    {"sampler": 1, "target": {"node": 0, "path": "rotation"}},
                    {"sampler": 2, "target": {"node": 0, "path": "scale"}},
                    {"sampler": 3, "target": {"node": 1, "path": "translation"}},
                    {"sampler": 4, "target": {"node": 0, "path": "weights"}}
                ]
            },
            {
                "name": "jump",
                "samplers": [{"input": 8, "output": 9, "interpolation": "STEP"}],
                "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]
            }
        ]
    });
    let path = dir.join("animated.gltf");
    std::fs::write(&path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
    path
}

/// The triangle's corners after scale `s`, a rotation by `angle` about +z and translation
/// `t`, computed here from the definitions.
fn corners(s: f32, angle: f32, t: Vec3) -> [Vec3; 3] {
    let rot = |p: Vec3| {
        let (sin, cos) = angle.sin_cos();
        Vec3::new(cos * p.x - sin * p.y, sin * p.x + cos * p.y, p.z)
    };
    [Vec3::X, Vec3::Y, Vec3::Z].map(|p| rot(p * s) + t)
}

/// The corners of the scene's triangles in the pose of `animation` at `seconds`, flattened;
/// checked against the same pose loaded as instances (the two nodes share their mesh).
fn positions_at(scene: &Path, animation: usize, seconds: f64) -> Vec<Vec3> {
    let options = LoadOptions {
        pose: Some(PoseTime { animation, seconds }),
        flatten_instances: true,
        ..Default::default()
    };
    let flat = load(scene, &options).unwrap().positions;
    let instanced = load(
        scene,
        &LoadOptions {
            flatten_instances: false,
            ..options
        },
    )
    .unwrap();
    assert_eq!(instanced.instances.len(), 2);
    let placed: Vec<Vec3> = (0..2)
        .flat_map(|k| instanced.placed_positions(0, k))
        .collect();
    assert_close(&placed, &flat, "the instances");
    flat
}

fn assert_close(got: &[Vec3], want: &[Vec3], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}");
    for (g, w) in got.iter().zip(want) {
        assert!((*g - *w).length() < 1e-5, "{what}: {g} against {w}");
    }
}

#[test]
fn nodes_take_the_pose_of_the_asked_time() {
    let dir = tempfile::tempdir().unwrap();
    let scene = animated_scene(dir.path());
    let deg = std::f32::consts::PI / 180.0;
    // (time, mover's scale, angle, translation; easer's y).
    let cases = [
        // Before the first key frame: the first values.
        (-1.0, 1.0, 0.0, Vec3::ZERO, 0.0),
        (0.0, 1.0, 0.0, Vec3::ZERO, 0.0),
        // Linear translation and slerp a quarter of the way; step still at its first
        // value; the cubic spline with zero tangents at s = 1/2: 3s² − 2s³ = 1/2.
        (0.5, 1.0, 22.5 * deg, Vec3::new(1.0, 0.0, 0.0), 1.5),
        // s = 1/4 of the easer's second: 3/16 − 2/64 = 0.15625 of the way.
        (
            0.25,
            1.0,
            11.25 * deg,
            Vec3::new(0.5, 0.0, 0.0),
            3.0 * 0.15625,
        ),
        // Halfway; the step has switched at 1 s; the spline has arrived.
        (1.5, 2.0, 67.5 * deg, Vec3::new(3.0, 0.0, 0.0), 3.0),
        // After the last key frame: the last values.
        (9.0, 2.0, 90.0 * deg, Vec3::new(4.0, 0.0, 0.0), 3.0),
    ];
    for (t, s, angle, translation, easer_y) in cases {
        let p = positions_at(&scene, 0, t);
        assert_close(
            &p[0..3],
            &corners(s, angle, translation),
            &format!("mover at {t} s"),
        );
        let easer = corners(1.0, 0.0, Vec3::new(0.0, easer_y, 0.0));
        assert_close(&p[3..6], &easer, &format!("easer at {t} s"));
    }
    // Animation 1 moves the mover only; the easer keeps its rest translation (0, 0, −3).
    let p = positions_at(&scene, 1, 0.5);
    assert_close(
        &p[0..3],
        &corners(1.0, 0.0, Vec3::new(0.0, 0.0, 7.0)),
        "jump",
    );
    assert_close(
        &p[3..6],
        &corners(1.0, 0.0, Vec3::new(0.0, 0.0, -3.0)),
        "rest",
    );
    // The rest pose (no time asked): the nodes' own transforms.
    let rest = load(&scene, &LoadOptions::default()).unwrap();
    assert_close(
        &rest.positions[0..3],
        &corners(1.0, 0.0, Vec3::ZERO),
        "rest mover",
    );
    assert!(
        rest.load_warnings
            .iter()
            .any(|w| w.contains("2 animation(s)")
                && w.contains("\"move\"")
                && w.contains("rest pose")),
        "{:?}",
        rest.load_warnings
    );
    let posed = load(
        &scene,
        &LoadOptions {
            pose: Some(PoseTime {
                animation: 0,
                seconds: 0.5,
            }),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(
        posed
            .load_warnings
            .iter()
            .any(|w| w.contains("morph target weights")),
        "{:?}",
        posed.load_warnings
    );
}

#[test]
fn frames_are_written_one_exr_each_with_their_number() {
    let dir = tempfile::tempdir().unwrap();
    let scene = animated_scene(dir.path());
    let out = dir.path().join("shot.exr");
    let common = [
        "--spp",
        "1",
        "--resolution",
        "16x16",
        "--no-png",
        "--integrator",
        "ao",
    ];
    let mut args = vec![s(&scene), "--frames", "0..2", "--fps", "2", "-o", s(&out)];
    args.extend(common);
    render(dir.path(), &args).assert_success();
    let frames: Vec<PathBuf> = (0..3)
        .map(|f| dir.path().join(format!("shot.{f:04}.exr")))
        .collect();
    for f in &frames {
        assert!(
            f.exists(),
            "{} missing; have {:?}",
            f.display(),
            entries(dir.path())
        );
    }
    assert!(!out.exists(), "no unnumbered file");
    // The mover moves: frame 0 and frame 2 (t = 1 s) differ.
    let (_, _, a) = strata::render::output::read_exr_rgb(&frames[0]).unwrap();
    let (_, _, b) = strata::render::output::read_exr_rgb(&frames[2]).unwrap();
    assert_ne!(a, b, "the frames should differ");

    // One frame, named by a #### pattern, and the same image as that frame of --frames.
    let pattern = dir.path().join("one.####.exr");
    let mut args = vec![s(&scene), "--frame", "2", "--fps", "2", "-o", s(&pattern)];
    args.extend(common);
    render(dir.path(), &args).assert_success();
    let (_, _, c) = strata::render::output::read_exr_rgb(&dir.path().join("one.0002.exr")).unwrap();
    assert_eq!(b, c, "--frame 2 and frame 2 of --frames");

    // A time past the animation's end holds its last pose: frame 100 equals frame 4 (2 s).
    for f in ["4", "100"] {
        let mut args = vec![s(&scene), "--frame", f, "--fps", "2", "-o", s(&pattern)];
        args.extend(common);
        render(dir.path(), &args).assert_success();
    }
    let (_, _, d) = strata::render::output::read_exr_rgb(&dir.path().join("one.0004.exr")).unwrap();
    let (_, _, e) = strata::render::output::read_exr_rgb(&dir.path().join("one.0100.exr")).unwrap();
    assert_eq!(d, e);
}

#[test]
fn frames_of_a_missing_animation_are_refused_plainly() {
    let dir = tempfile::tempdir().unwrap();
    let scene = animated_scene(dir.path());
    let out = dir.path().join("x.exr");
    let run = render(
        dir.path(),
        &[s(&scene), "--frame", "1", "--animation", "5", "-o", s(&out)],
    );
    assert!(!run.status.success());
    assert_one_error_line(&run.stderr, &["animated.gltf", "animation 5", "has 2"]);
    let wall = repo_path("scenes/ao-wall.gltf");
    let run = render(dir.path(), &[s(&wall), "--frame", "1", "-o", s(&out)]);
    assert!(!run.status.success());
    assert_one_error_line(&run.stderr, &["ao-wall.gltf", "no animation"]);
    for bad in ["3..1", "x..2", "4"] {
        let run = render(dir.path(), &[s(&scene), "--frames", bad, "-o", s(&out)]);
        assert!(!run.status.success(), "--frames {bad} accepted");
        assert_no_panic(&run.stderr);
    }
    let run = render(
        dir.path(),
        &[s(&scene), "--frame", "1", "--fps", "0", "-o", s(&out)],
    );
    assert!(!run.status.success());
    assert_one_error_line(&run.stderr, &["--fps"]);
}

#[test]
fn frame_paths_put_the_number_where_the_name_asks() {
    use strata::job::frame_path;
    let p = |s: &str, f| frame_path(Path::new(s), f).to_string_lossy().into_owned();
    assert_eq!(p("out/shot.exr", 7), "out/shot.0007.exr");
    assert_eq!(p("shot.####.exr", 12), "shot.0012.exr");
    assert_eq!(p("shot_##.exr", 3), "shot_03.exr");
    assert_eq!(p("shot_##.exr", 123), "shot_123.exr");
    assert_eq!(p("a.b.exr", 1), "a.b.0001.exr");
}
