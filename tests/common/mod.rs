//! Helpers shared by the tests: for the CLI tests (`cli.rs`, `bad_input.rs`,
//! `losing_nothing.rs`), run the `render` binary, check its one-line errors, run a table of
//! cases reporting every failing one (`check_every_case`), and build broken variants of a
//! small scene; for the light-transport and numerics tests, a closed sphere; for
//! the render tests, the render loop without a progress bar or a way to cancel
//! (`render_quietly`, `render_quietly_on`) and a film's sums as bits.
#![allow(dead_code)]

pub mod sphere_chi2;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

/// A finished run of the binary.
pub struct Run {
    pub status: ExitStatus,
    pub stdout: String,
    pub stderr: String,
    pub elapsed: Duration,
}

impl Run {
    pub fn assert_success(&self) {
        assert!(
            self.status.success(),
            "render failed ({}):\nstdout:\n{}\nstderr:\n{}",
            self.status,
            self.stdout,
            self.stderr
        );
        assert_no_panic(&self.stderr);
    }
}

pub fn repo_path(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

pub fn render_bin() -> &'static str {
    env!("CARGO_BIN_EXE_render")
}

pub fn s(p: &Path) -> &str {
    p.to_str().expect("test paths are UTF-8")
}

/// Runs `render` with `args` in `cwd`.
pub fn render(cwd: &Path, args: &[&str]) -> Run {
    run_command(Command::new(render_bin()).args(args), cwd)
}

/// Runs `render` with `args` in `cwd` through `sh -c '<shell_prefix>; exec render "$@"'`, e.g.
/// with a `ulimit` in force.
pub fn render_under_shell(cwd: &Path, shell_prefix: &str, args: &[&str]) -> Run {
    let script = format!("{shell_prefix}; exec \"$0\" \"$@\"");
    run_command(
        Command::new("sh")
            .arg("-c")
            .arg(script)
            .arg(render_bin())
            .args(args),
        cwd,
    )
}

fn run_command(cmd: &mut Command, cwd: &Path) -> Run {
    let t0 = Instant::now();
    let out = cmd
        .current_dir(cwd)
        .stdin(Stdio::null())
        .output()
        .expect("cannot start the render binary");
    Run {
        status: out.status,
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        elapsed: t0.elapsed(),
    }
}

/// The names in `dir`, hidden ones included, sorted.
pub fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

pub fn assert_entries(dir: &Path, expected: &[&str]) {
    let mut want: Vec<String> = expected.iter().map(|s| s.to_string()).collect();
    want.sort();
    assert_eq!(
        entries(dir),
        want,
        "unexpected contents of {} (an output or a leftover temporary file?)",
        dir.display()
    );
}

pub fn assert_no_panic(stderr: &str) {
    assert!(
        !stderr.contains("panicked"),
        "the binary panicked:\n{stderr}"
    );
}

/// Asserts that `run` (of `what`, for the message) failed without a panic and that its stderr
/// names every word of `words` (clap's usage errors take several lines, so not
/// [`assert_one_error_line`]).
pub fn assert_refused(run: &Run, what: &str, words: &[&str]) {
    assert!(!run.status.success(), "{what} accepted:\n{}", run.stderr);
    assert_no_panic(&run.stderr);
    for w in words {
        assert!(
            run.stderr.contains(w),
            "{what}: no {w:?} in:\n{}",
            run.stderr
        );
    }
}

/// Asserts that stderr is exactly one line, `error: ...`, mentioning every word of `words`
/// (case-insensitively); returns that line.
pub fn assert_one_error_line(stderr: &str, words: &[&str]) -> String {
    assert_no_panic(stderr);
    let text = stderr.strip_suffix('\n').unwrap_or(stderr);
    assert!(
        !text.is_empty() && !text.contains('\n'),
        "stderr should be exactly one line, got:\n{stderr}"
    );
    assert!(
        text.starts_with("error:"),
        "stderr should start with 'error:', got:\n{stderr}"
    );
    let lower = text.to_lowercase();
    for w in words {
        assert!(
            lower.contains(&w.to_lowercase()),
            "stderr should mention {w:?}, got:\n{stderr}"
        );
    }
    text.to_string()
}

/// Runs `check` on every case of a table, catching each case's panic, then fails naming
/// every case that failed, with its message: one failing case does not hide the others.
/// Names must be unique.
pub fn check_every_case<T>(cases: &[T], name: impl Fn(&T) -> &str, check: impl Fn(&T)) {
    assert!(!cases.is_empty(), "an empty table");
    let mut names: Vec<&str> = cases.iter().map(&name).collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
        panic!("two cases are named {:?}", w[0]);
    }
    let mut failures = Vec::new();
    for case in cases {
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check(case)));
        if let Err(payload) = outcome {
            let message = payload
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| payload.downcast_ref::<&str>().copied())
                .unwrap_or("(a panic without a message)");
            failures.push(format!("--- {}:\n{message}", name(case)));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
    eprintln!("all {} cases passed", cases.len());
}

/// ao-wall.gltf (two quads, one camera, one embedded 240-byte buffer) as JSON.
pub fn ao_wall_json() -> Value {
    serde_json::from_slice(&std::fs::read(repo_path("scenes/ao-wall.gltf")).unwrap()).unwrap()
}

/// The decoded bytes of ao-wall's embedded buffer.
pub fn ao_wall_buffer() -> Vec<u8> {
    use base64::Engine;
    let doc = ao_wall_json();
    let uri = doc["buffers"][0]["uri"].as_str().unwrap();
    let payload = uri.split_once(";base64,").unwrap().1;
    base64::engine::general_purpose::STANDARD
        .decode(payload)
        .unwrap()
}

pub fn data_uri(bytes: &[u8]) -> String {
    use base64::Engine;
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// A binary glTF container: header, the JSON chunk (space-padded) and a BIN chunk
/// (zero-padded). `doc`'s buffer 0 should have no `uri`.
pub fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).unwrap();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// ao-wall as a valid .glb.
pub fn ao_wall_glb() -> Vec<u8> {
    let mut doc = ao_wall_json();
    let bin = ao_wall_buffer();
    doc["buffers"][0] = serde_json::json!({ "byteLength": bin.len() });
    glb(&doc, &bin)
}

/// Waits up to `limit` for `child` to exit; kills it and panics if it does not.
pub fn wait_with_limit(child: &mut std::process::Child, limit: Duration, what: &str) -> ExitStatus {
    let t0 = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what}: still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The `strata:*` integer attributes of an EXR header.
pub fn int_attrs(path: &Path) -> std::collections::HashMap<String, i32> {
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .unwrap_or_else(|e| panic!("cannot read the header of {}: {e}", path.display()));
    meta.headers[0]
        .own_attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            exr::meta::attribute::AttributeValue::I32(i) => Some((k.to_string(), *i)),
            _ => None,
        })
        .collect()
}

pub fn attr(attrs: &std::collections::HashMap<String, i32>, name: &str) -> i32 {
    *attrs
        .get(name)
        .unwrap_or_else(|| panic!("no {name} in the EXR header: {attrs:?}"))
}

/// A geodesic sphere of radius 1 about the origin: an octahedron whose triangles are split in
/// four `subdivisions` times, new vertices pushed onto the sphere (in f64). Vertices are
/// shared exactly, so the mesh is watertight, and every triangle is wound so that its front
/// face points into the sphere (a furnace). Returns the unit-sphere points and the triangles;
/// callers scale and place the points.
pub fn inward_geodesic_sphere(subdivisions: u32) -> (Vec<glam::DVec3>, Vec<[u32; 3]>) {
    use glam::DVec3;
    let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
    let mut tris: Vec<[DVec3; 3]> = vec![
        [x, y, z],
        [y, -x, z],
        [-x, -y, z],
        [-y, x, z],
        [y, x, -z],
        [-x, y, -z],
        [-y, -x, -z],
        [x, -y, -z],
    ];
    for _ in 0..subdivisions {
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let (ab, bc, ca) = (
                (a + b).normalize(),
                (b + c).normalize(),
                (c + a).normalize(),
            );
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        tris = next;
    }
    let mut points = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut triangles = Vec::with_capacity(tris.len());
    for t in tris {
        let [a, b, c] = t.map(|p| {
            *index
                .entry(p.to_array().map(f64::to_bits))
                .or_insert_with(|| {
                    points.push(p);
                    points.len() as u32 - 1
                })
        });
        let outward = (t[1] - t[0]).cross(t[2] - t[0]).dot(t[0]) > 0.0;
        triangles.push(if outward { [a, c, b] } else { [a, b, c] });
    }
    (points, triangles)
}

/// A film's exact (fixed-point) sums and sample counts: for comparing renders bit for bit.
pub fn film_totals(film: &strata::render::Film) -> Vec<strata::render::PixelTotals> {
    (0..film.height)
        .flat_map(|y| (0..film.width).map(move |x| (x, y)))
        .map(|(x, y)| film.totals(x, y))
        .collect()
}

/// A perspective camera at `eye` looking along `forward`, `up` roughly up (not parallel to
/// `forward`), with vertical field of view `yfov`: its to-world columns are right, up, back
/// (a glTF camera looks down its −Z) and the position.
pub fn camera_looking(
    eye: glam::Vec3,
    forward: glam::Vec3,
    up: glam::Vec3,
    yfov: f32,
) -> strata::scene::Camera {
    let back = -forward.normalize();
    let right = up.cross(back).normalize();
    let true_up = back.cross(right);
    strata::scene::Camera {
        name: None,
        projection: strata::scene::Projection::Perspective { yfov },
        to_world: glam::Mat4::from_cols(
            right.extend(0.0),
            true_up.extend(0.0),
            back.extend(0.0),
            eye.extend(1.0),
        ),
        aspect_ratio: None,
        lens: None,
    }
}

/// Renders `settings` through `ctx` on two worker threads, without a progress bar or a way to
/// cancel: the render loop as the library tests drive it.
pub fn render_quietly(
    ctx: &strata::integrators::Context,
    settings: &strata::render::RenderSettings,
) -> strata::render::RenderResult {
    render_quietly_on(2, ctx, settings)
}

/// [`render_quietly`] on `threads` worker threads (0: rayon's default, one per core), for the
/// tests that render on a given number of threads or on every core.
pub fn render_quietly_on(
    threads: usize,
    ctx: &strata::integrators::Context,
    settings: &strata::render::RenderSettings,
) -> strata::render::RenderResult {
    let pool = strata::render::thread_pool(threads).unwrap();
    strata::render::render(
        ctx,
        settings,
        &pool,
        &indicatif::ProgressBar::hidden(),
        &std::sync::atomic::AtomicBool::new(false),
    )
}

/// Every channel of the EXR's one part, by name, and its text attributes.
pub fn read_channels(
    path: &Path,
) -> (
    std::collections::HashMap<String, Vec<f32>>,
    std::collections::HashMap<String, String>,
) {
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

/// A test-local PRNG: PCG32 (XSH-RR 64/32), M. E. O'Neill, "PCG: A Family of Simple Fast
/// Space-Efficient Statistically Good Algorithms for Random Number Generation" (2014).
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    pub fn new(seed: u64, stream: u64) -> Pcg32 {
        let mut rng = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in [0, 1) on the 2^-24 grid (exactly representable in f32).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    pub fn next_vec2(&mut self) -> glam::Vec2 {
        let x = self.next_f32();
        glam::Vec2::new(x, self.next_f32())
    }

    /// Uniform in [0, n).
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.next_u32() as u64 * n as u64) >> 32) as u32
    }
}

/// Writes a glTF of one mesh (`positions`, `triangles`) with `material`, seen by `camera`
/// (a glTF camera object) from `eye` looking down −Z, to `dir/name`.
pub fn write_mesh_scene(
    dir: &Path,
    name: &str,
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    material: Value,
    camera: Value,
    eye: [f32; 3],
) -> PathBuf {
    let mut bin = Vec::new();
    for p in positions {
        for v in p {
            bin.extend_from_slice(&v.to_le_bytes());
        }
    }
    let index_offset = bin.len();
    for t in triangles {
        for i in t {
            bin.extend_from_slice(&i.to_le_bytes());
        }
    }
    let (lo, hi) = positions
        .iter()
        .fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1]), lo[2].min(p[2])],
                [hi[0].max(p[0]), hi[1].max(p[1]), hi[2].max(p[2])],
            )
        });
    // The material's extensions, declared as used.
    let extensions: Vec<String> = (material.get("extensions").and_then(|e| e.as_object()))
        .map(|e| e.keys().cloned().collect())
        .unwrap_or_default();
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": extensions,
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": eye}],
        "cameras": [camera],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "materials": [material],
        "buffers": [{"byteLength": bin.len(), "uri": data_uri(&bin)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": index_offset},
            {"buffer": 0, "byteOffset": index_offset, "byteLength": bin.len() - index_offset}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": positions.len(), "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": 1, "componentType": 5125, "count": triangles.len() * 3, "type": "SCALAR"}
        ]
    });
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// Renders `scene` under a white sky by path tracing up to 5000 bounces, without Russian
/// roulette, with `extra` options; the pixels.
pub fn render_under_white_sky(
    dir: &Path,
    scene: &Path,
    spp: u32,
    size: &str,
    extra: &[&str],
) -> Vec<[f32; 3]> {
    let out = dir.join(format!(
        "{}.exr",
        scene.file_stem().unwrap().to_string_lossy()
    ));
    let spp = spp.to_string();
    let mut args = vec![
        s(scene),
        "--background",
        "1,1,1",
        "--integrator",
        "path",
        "--max-depth",
        "5000",
        "--rr-depth",
        "1000",
        "--spp",
        &spp,
        "--resolution",
        size,
        "-o",
        s(&out),
        "--no-png",
    ];
    args.extend_from_slice(extra);
    let run = render(dir, &args);
    run.assert_success();
    strata::render::output::read_exr_rgb(&out).unwrap().2
}

/// An outward-wound geodesic sphere of radius 1 at the origin.
pub fn outward_sphere() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let (points, triangles) = inward_geodesic_sphere(4);
    let positions = points.iter().map(|p| p.as_vec3().to_array()).collect();
    (
        positions,
        triangles.iter().map(|&[a, b, c]| [a, c, b]).collect(),
    )
}

pub fn perspective_camera() -> Value {
    json!({"type": "perspective", "perspective": {"yfov": 0.6, "znear": 0.01}})
}

/// `idiff -fail 0` of two images over all their channels (required under CI; skipped loudly
/// without it, when the bitwise comparison still runs).
pub fn idiff_identical(a: &Path, b: &Path) {
    match std::process::Command::new("idiff")
        .arg("--version")
        .output()
    {
        Ok(o) if o.status.success() => {}
        _ => {
            assert!(
                std::env::var_os("CI").is_none(),
                "idiff (Debian: openimageio-tools) is required under CI"
            );
            eprintln!("\n*** SKIPPED idiff: not found (install openimageio-tools); the bitwise comparison still runs ***\n");
            return;
        }
    }
    let out = std::process::Command::new("idiff")
        .args(["-fail", "0", "-warn", "0"])
        .args([a, b])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "idiff -fail 0 {} {}:\n{}",
        a.display(),
        b.display(),
        String::from_utf8_lossy(&out.stdout)
    );
}
