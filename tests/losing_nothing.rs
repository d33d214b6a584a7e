//! Losing nothing: interrupts, checkpoints and failed writes through the `render` binary.
//!
//! - Interrupts (Ctrl-C, SIGTERM): the first saves the image (tests/cli.rs::
//!   interrupt_saves_the_image; its header is checked here), SIGTERM alike; an echo within
//!   0.5 s counts once; the second hurries the save; the third exits at once, without saving
//!   and without leaving a temporary file; an interrupted render never replaces a better
//!   image.
//! - `--checkpoint`: a valid image is at the output path while the render runs, replaced
//!   atomically by later checkpoints and by the final image; checkpoints do not change the
//!   image.
//! - A write that fails (file size limit, full disk) leaves no partial file, keeps an older
//!   file at the output path intact, and reports one clear error.

mod common;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::*;
use strata::render::output::read_exr_rgb;

/// A render child whose stderr lines are collected by a thread as they arrive.
struct Running {
    child: Child,
    stderr: Arc<Mutex<Vec<String>>>,
}

impl Running {
    fn start(cwd: &Path, args: &[&str]) -> Running {
        let mut child = Command::new(render_bin())
            .args(args)
            .current_dir(cwd)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("cannot start the render binary");
        let pipe = child.stderr.take().unwrap();
        let stderr = Arc::new(Mutex::new(Vec::new()));
        let lines = stderr.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(pipe).lines() {
                match line {
                    Ok(l) => lines.lock().unwrap().push(l),
                    Err(_) => break,
                }
            }
        });
        Running { child, stderr }
    }

    fn sigint(&self) {
        self.signal("INT");
    }

    /// Sends signal `name` (`INT`, `TERM`) with kill(1).
    fn signal(&self, name: &str) {
        let ok = Command::new("kill")
            .args([&format!("-{name}"), &self.child.id().to_string()])
            .status()
            .expect("cannot run kill")
            .success();
        assert!(ok, "kill -{name} failed");
    }

    fn stderr_text(&self) -> String {
        self.stderr.lock().unwrap().join("\n")
    }

    /// Waits until a line of stderr contains `needle`.
    fn wait_for_stderr(&mut self, needle: &str, limit: Duration) {
        let t0 = Instant::now();
        while !self.stderr_text().contains(needle) {
            if let Some(status) = self.child.try_wait().unwrap() {
                panic!(
                    "the render exited ({status}) before printing {needle:?}:\n{}",
                    self.stderr_text()
                );
            }
            assert!(
                t0.elapsed() < limit,
                "no {needle:?} on stderr after {limit:?}:\n{}",
                self.stderr_text()
            );
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    fn is_running(&mut self) -> bool {
        self.child.try_wait().unwrap().is_none()
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn ao_wall() -> std::path::PathBuf {
    repo_path("scenes/ao-wall.gltf")
}

// ---------------------------------------------------------------------------------------
// Ctrl-C.

/// A render of ao-wall far too long to finish (a million random samples per pixel) at
/// `resolution`, passes not grown to last half a second (`--min-pass-seconds 0`), then
/// `extra`.
fn long_args<'a>(
    wall: &'a Path,
    out: &'a Path,
    resolution: &'a str,
    extra: &[&'a str],
) -> Vec<&'a str> {
    let mut args = vec![
        s(wall),
        "-o",
        s(out),
        "--spp",
        "1000000",
        "--resolution",
        resolution,
        "--sampler",
        "random",
        "--min-pass-seconds",
        "0",
    ];
    args.extend_from_slice(extra);
    args
}

/// A render of ao-wall that cannot finish in the test's time: one thread, one 128 × 128 tile
/// whose first pass is sized to last 30 s (`--min-pass-seconds`), so that after the first
/// interrupt the tile in flight keeps rendering for many seconds.
fn long_single_tile_args<'a>(wall: &'a Path, out: &'a Path) -> Vec<&'a str> {
    vec![
        s(wall),
        "-o",
        s(out),
        "--spp",
        "1000000",
        "--resolution",
        "128x128",
        "--tile-size",
        "128",
        "--threads",
        "1",
        "--sampler",
        "random",
        "--min-pass-seconds",
        "30",
    ]
}

#[test]
fn third_interrupt_exits_at_once_without_saving() {
    // The first SIGINT lets the tile in flight finish (tens of seconds here), the second
    // (more than SIGNAL_ECHO, 0.5 s, later) only hurries the save, the third exits.
    let tmp = tempfile::tempdir().unwrap();
    let (out, wall) = (tmp.path().join("long.exr"), ao_wall());
    let mut run = Running::start(tmp.path(), &long_single_tile_args(&wall, &out));
    std::thread::sleep(Duration::from_millis(1500));
    assert!(run.is_running(), "the render ended before the interrupt");
    run.sigint();
    run.wait_for_stderr("interrupted:", Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(700));
    run.sigint();
    run.wait_for_stderr("interrupted again", Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(700));
    assert!(run.is_running(), "the tile in flight ended early");
    run.sigint();
    let t0 = Instant::now();
    let status = wait_with_limit(&mut run.child, Duration::from_secs(10), "third SIGINT");
    let exit_time = t0.elapsed();
    std::thread::sleep(Duration::from_millis(100)); // let the reader thread drain
    let stderr = run.stderr_text();
    assert_no_panic(&stderr);
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("interrupted three times"), "{stderr}");
    assert!(
        exit_time < Duration::from_secs(2),
        "exit took {exit_time:?} after the third SIGINT"
    );
    // Nothing written, nothing half-written.
    assert_entries(tmp.path(), &[]);
}

/// Two SIGINTs 50 ms apart (`timeout -s INT` and a shell can each deliver one) are one
/// interrupt: the render saves its image instead of quitting or hurrying.
#[test]
fn an_echoed_interrupt_counts_once() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("long.exr");
    let wall = ao_wall();
    let mut run = Running::start(tmp.path(), &long_args(&wall, &out, "32x32", &["--no-png"]));
    std::thread::sleep(Duration::from_millis(1000));
    assert!(run.is_running());
    run.sigint();
    std::thread::sleep(Duration::from_millis(50));
    run.sigint();
    let status = wait_with_limit(&mut run.child, Duration::from_secs(60), "after SIGINT");
    std::thread::sleep(Duration::from_millis(100));
    let stderr = run.stderr_text();
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(!stderr.contains("interrupted again"), "{stderr}");
    assert!(stderr.contains("saved the image"), "{stderr}");
    assert_eq!(attr(&int_attrs(&out), "strata:interrupted"), 1);
}

/// SIGTERM (what Slurm and Kubernetes send on pre-emption) saves like the first Ctrl-C: a
/// valid EXR of what was rendered, marked interrupted.
#[test]
fn sigterm_saves_the_image_like_ctrl_c() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("long.exr");
    let wall = ao_wall();
    let mut run = Running::start(tmp.path(), &long_args(&wall, &out, "32x32", &[]));
    std::thread::sleep(Duration::from_millis(1000));
    assert!(run.is_running());
    run.signal("TERM");
    let status = wait_with_limit(&mut run.child, Duration::from_secs(60), "after SIGTERM");
    std::thread::sleep(Duration::from_millis(100));
    let stderr = run.stderr_text();
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("saved the image"), "{stderr}");
    let a = int_attrs(&out);
    assert_eq!(attr(&a, "strata:interrupted"), 1);
    assert!(attr(&a, "strata:spp_min") >= 1);
    let (_, _, px) = read_exr_rgb(&out).unwrap();
    assert!(px.iter().flatten().any(|&v| v > 0.0));
    assert_entries(tmp.path(), &["long.exr", "long.png"]);
}

/// An interrupt never replaces a better image: interrupted in its first pass (most pixels
/// without a sample), a render leaves the finished image and preview at its output byte for
/// byte and puts what it has beside them as NAME.incomplete.exr. Interrupted with more
/// samples per pixel than the file there holds, it replaces it.
#[test]
fn an_interrupt_never_replaces_a_better_image() {
    let tmp = tempfile::tempdir().unwrap();
    let (out, wall) = (tmp.path().join("long.exr"), ao_wall());
    let png = out.with_extension("png");
    let finished = render(
        tmp.path(),
        &[
            s(&wall),
            "-o",
            s(&out),
            "--spp",
            "4",
            "--resolution",
            "128x128",
        ],
    );
    finished.assert_success();
    let (exr_before, png_before) = (std::fs::read(&out).unwrap(), std::fs::read(&png).unwrap());

    // One thread, many tiles, a first pass sized to 30 s: interrupted after 1.5 s, the tiles
    // in flight finish and most of the image has no sample.
    let mut args = long_single_tile_args(&wall, &out);
    let tile = args.iter().position(|&a| a == "--tile-size").unwrap();
    args[tile + 1] = "16";
    let mut run = Running::start(tmp.path(), &args);
    std::thread::sleep(Duration::from_millis(1500));
    assert!(run.is_running());
    run.sigint();
    let status = wait_with_limit(&mut run.child, Duration::from_secs(60), "after SIGINT");
    std::thread::sleep(Duration::from_millis(100));
    let stderr = run.stderr_text();
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("is kept"), "{stderr}");
    assert_eq!(
        std::fs::read(&out).unwrap(),
        exr_before,
        "the finished EXR changed"
    );
    assert_eq!(
        std::fs::read(&png).unwrap(),
        png_before,
        "the preview changed"
    );
    let incomplete = tmp.path().join("long.incomplete.exr");
    let a = int_attrs(&incomplete);
    assert_eq!(attr(&a, "strata:interrupted"), 1);
    assert_eq!(attr(&a, "strata:spp_min"), 0);
    assert_entries(tmp.path(), &["long.exr", "long.incomplete.exr", "long.png"]);

    // Interrupted after passes of 1, 2, 4, … samples everywhere: more than the file's 4.
    std::fs::remove_file(&incomplete).unwrap();
    let mut run = Running::start(tmp.path(), &long_args(&wall, &out, "128x128", &[]));
    std::thread::sleep(Duration::from_millis(1500));
    assert!(run.is_running());
    run.sigint();
    let status = wait_with_limit(&mut run.child, Duration::from_secs(60), "after SIGINT");
    std::thread::sleep(Duration::from_millis(100));
    assert_eq!(status.code(), Some(130), "{}", run.stderr_text());
    let a = int_attrs(&out);
    assert_eq!(attr(&a, "strata:interrupted"), 1);
    assert!(attr(&a, "strata:spp_min") > 4, "{a:?}");
    assert_entries(tmp.path(), &["long.exr", "long.png"]);
}

#[test]
fn interrupted_image_records_its_samples_per_pixel() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("long.exr");
    let wall = ao_wall();
    let mut run = Running::start(
        tmp.path(),
        &[
            s(&wall),
            "-o",
            s(&out),
            "--spp",
            "1000000",
            "--resolution",
            "64x64",
            "--sampler",
            "random",
            "--no-png",
            // Passes of 1, 1, 2, 4, … samples, not grown to last half a second, so that the
            // counts below are known.
            "--min-pass-seconds",
            "0",
        ],
    );
    std::thread::sleep(Duration::from_millis(1000));
    assert!(run.is_running());
    run.sigint();
    let status = wait_with_limit(&mut run.child, Duration::from_secs(60), "after SIGINT");
    assert_eq!(status.code(), Some(130), "{}", run.stderr_text());
    let a = int_attrs(&out);
    let (lo, hi) = (attr(&a, "strata:spp_min"), attr(&a, "strata:spp_max"));
    assert_eq!(attr(&a, "strata:interrupted"), 1);
    assert_eq!(attr(&a, "strata:checkpoint"), 0);
    assert_eq!(attr(&a, "strata:spp"), 1_000_000, "the requested spp");
    assert!(1 <= lo && lo <= hi && hi < 1_000_000, "spp {lo}..{hi}");
    // Passes double in size: a pixel has the samples of all finished passes, or those plus
    // the interrupted pass, so the two counts are powers of two.
    assert!((lo as u32).is_power_of_two() && (hi as u32).is_power_of_two());
    let text = run.stderr_text();
    assert!(
        text.contains(&format!("({lo}-{hi} samples per pixel)")),
        "{text}"
    );
    assert_entries(tmp.path(), &["long.exr"]);
}

// ---------------------------------------------------------------------------------------
// --checkpoint.

#[test]
fn checkpoints_leave_a_valid_image_during_the_render() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.exr");
    let var = tmp.path().join("var.exr");
    let wall = ao_wall();
    let mut run = Running::start(
        tmp.path(),
        &[
            s(&wall),
            "-o",
            s(&out),
            "--variance",
            s(&var),
            "--spp",
            "1000000",
            "--resolution",
            "64x64",
            "--sampler",
            "random",
            "--checkpoint",
            "0.2",
        ],
    );
    // Poll the output path: every read must find a whole image (written to a temporary name
    // and renamed), and the samples per pixel must grow from checkpoint to checkpoint.
    let t0 = Instant::now();
    let mut seen: Vec<(i32, i32)> = Vec::new();
    while seen.len() < 3 || seen.last().unwrap().0 <= seen[0].1 {
        assert!(run.is_running(), "the render ended: {}", run.stderr_text());
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "checkpoints seen in 60 s: {seen:?}"
        );
        if out.exists() {
            let (w, h, px) = read_exr_rgb(&out).expect("a checkpoint is a whole EXR");
            assert_eq!((w, h), (64, 64));
            assert!(px.iter().flatten().all(|v| v.is_finite()));
            let a = int_attrs(&out);
            assert_eq!(attr(&a, "strata:checkpoint"), 1);
            assert_eq!(attr(&a, "strata:interrupted"), 0);
            let spp = (attr(&a, "strata:spp_min"), attr(&a, "strata:spp_max"));
            // A checkpoint taken between groups of tiles in the first round (or in the speed
            // probe's round, which samples one tile in several) shows tiles not sampled yet:
            // spp_min may be 0 then, never spp_max.
            assert!(0 <= spp.0 && spp.0 <= spp.1 && 1 <= spp.1, "{spp:?}");
            assert!(spp.1 < 1_000_000, "{spp:?}");
            // The variance image is written right after the main one: on the first
            // checkpoint it may not exist yet, so wait for it before counting this one.
            if seen.last() != Some(&spp) && var.exists() {
                assert!(
                    seen.last().is_none_or(|last| spp.0 >= last.0),
                    "the samples went down: {seen:?} then {spp:?}"
                );
                seen.push(spp);
                // The variance image is checkpointed with it.
                let (vw, vh, _) = read_exr_rgb(&var).expect("the variance checkpoint");
                assert_eq!((vw, vh), (64, 64));
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    // Stop it: the final image replaces the last checkpoint.
    run.sigint();
    let status = wait_with_limit(&mut run.child, Duration::from_secs(60), "after SIGINT");
    assert_eq!(status.code(), Some(130), "{}", run.stderr_text());
    let a = int_attrs(&out);
    assert_eq!(attr(&a, "strata:checkpoint"), 0);
    assert_eq!(attr(&a, "strata:interrupted"), 1);
    assert!(attr(&a, "strata:spp_min") >= seen.last().unwrap().0);
    assert_no_panic(&run.stderr_text());
    assert!(!run.stderr_text().contains("checkpoint not written"));
    assert_entries(tmp.path(), &["out.exr", "out.png", "var.exr"]);
    eprintln!("checkpoints seen (spp min, max): {seen:?}");
}

#[test]
fn checkpoints_do_not_change_the_image() {
    let tmp = tempfile::tempdir().unwrap();
    let wall = ao_wall();
    let render_to = |name: &str, extra: &[&str]| {
        let out = tmp.path().join(name);
        let mut args = vec![
            s(&wall),
            "-o",
            s(&out),
            "--resolution",
            "48x40",
            "--spp",
            "256",
            "--threads",
            "2",
            "--stats",
            "--no-png",
        ];
        args.extend_from_slice(extra);
        let run = render(tmp.path(), &args);
        assert!(run.status.success(), "{}", run.stderr);
        assert_no_panic(&run.stderr);
        (read_exr_rgb(&out).unwrap().2, run.stdout)
    };
    let (plain, _) = render_to("plain.exr", &[]);
    let bits =
        |px: &[[f32; 3]]| -> Vec<[u32; 3]> { px.iter().map(|p| p.map(f32::to_bits)).collect() };
    // With the default passes this short render makes a probe and one pass, which may give
    // a single checkpoint; with doubling passes (1, 1, 2, 4, ...) it gives several.
    for (name, passes, at_least) in [
        ("checked.exr", &[][..], 1),
        ("doubling.exr", &["--min-pass-seconds", "0"][..], 2),
    ] {
        let mut extra = vec!["--checkpoint", "0.0001"];
        extra.extend_from_slice(passes);
        let (checked, stdout) = render_to(name, &extra);
        let written: u32 = stdout
            .lines()
            .find_map(|l| l.strip_prefix("checkpoints: "))
            .and_then(|l| l.split_whitespace().next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("no checkpoint count in:\n{stdout}"));
        assert!(written >= at_least, "{name}: {stdout}");
        assert_eq!(
            bits(&plain),
            bits(&checked),
            "{name}: the checkpointed render differs"
        );
        let a = int_attrs(&tmp.path().join(name));
        assert_eq!(attr(&a, "strata:checkpoint"), 0);
        assert_eq!(
            (attr(&a, "strata:spp_min"), attr(&a, "strata:spp_max")),
            (256, 256)
        );
    }
    assert_entries(tmp.path(), &["checked.exr", "doubling.exr", "plain.exr"]);
}

#[test]
fn checkpoint_values_are_checked() {
    let tmp = tempfile::tempdir().unwrap();
    let wall = ao_wall();
    let out = tmp.path().join("out.exr");
    for bad in ["0", "-1", "soon", "inf", "NaN"] {
        let option = format!("--checkpoint={bad}");
        let run = render(tmp.path(), &[s(&wall), "-o", s(&out), &option]);
        assert!(!run.status.success(), "--checkpoint {bad} accepted");
        assert_no_panic(&run.stderr);
        assert!(run.stderr.contains("--checkpoint"), "{}", run.stderr);
    }
    assert_entries(tmp.path(), &[]);
}

// ---------------------------------------------------------------------------------------
// --resume.

/// Every float channel of an EXR as bits, by name, and whether it has the exact layer.
fn float_bits(path: &Path) -> (std::collections::BTreeMap<String, Vec<u32>>, bool) {
    use exr::prelude::*;
    let image = read_all_flat_layers_from_file(path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let mut floats = std::collections::BTreeMap::new();
    let mut exact = false;
    for c in &image.layer_data[0].channel_data.list {
        match &c.sample_data {
            FlatSamples::F32(v) => {
                floats.insert(c.name.to_string(), v.iter().map(|f| f.to_bits()).collect());
            }
            _ => exact |= c.name.to_string().starts_with("exact."),
        }
    }
    (floats, exact)
}

/// The path-traced Cornell box with passes of features and IDs, 512 samples per pixel in
/// doubling passes, so that a render stopped part way has pixels at several counts.
fn resumable_args<'a>(scene: &'a Path, out: &'a Path, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        s(scene),
        "-o",
        s(out),
        "--resolution",
        "24x24",
        "--spp",
        "512",
        "--passes",
        "albedo,normal,object_id",
        "--min-pass-seconds",
        "0",
        "--no-png",
    ];
    args.extend_from_slice(extra);
    args
}

/// A render stopped by SIGTERM part way, and one killed (SIGKILL) after a checkpoint, each
/// resumed with `--resume`, equal the uninterrupted render in every channel, bit for bit
/// (beauty, albedo, normal and object IDs), and the finished file holds no sums.
#[test]
fn a_resumed_render_equals_the_uninterrupted_one() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = repo_path("scenes/cornell-box.gltf");
    let full = tmp.path().join("full.exr");
    let run = render(tmp.path(), &resumable_args(&scene, &full, &[]));
    run.assert_success();
    let (want, exact) = float_bits(&full);
    assert!(!exact, "a finished render holds no exact sums");
    assert!(want.contains_key("object_id.ID") && want.contains_key("albedo.R"));

    // SIGTERM after the first progress line; then SIGKILL after the first checkpoint.
    let stopped = tmp.path().join("stopped.exr");
    let mut run = Running::start(
        tmp.path(),
        &resumable_args(&scene, &stopped, &["--progress-every", "0.05"]),
    );
    run.wait_for_stderr("of the samples after", Duration::from_secs(60));
    run.signal("TERM");
    let status = wait_with_limit(&mut run.child, Duration::from_secs(60), "after SIGTERM");
    assert_eq!(status.code(), Some(130), "{}", run.stderr_text());
    let killed = tmp.path().join("killed.exr");
    let mut crashed = Running::start(
        tmp.path(),
        &resumable_args(&scene, &killed, &["--checkpoint", "0.05"]),
    );
    let t0 = Instant::now();
    while !killed.exists() {
        assert!(crashed.is_running(), "finished before its first checkpoint");
        assert!(t0.elapsed() < Duration::from_secs(60), "no checkpoint");
        std::thread::sleep(Duration::from_millis(5));
    }
    crashed.signal("KILL");
    wait_with_limit(&mut crashed.child, Duration::from_secs(10), "after SIGKILL");

    for (path, flag) in [
        (&stopped, "strata:interrupted"),
        (&killed, "strata:checkpoint"),
    ] {
        let a = int_attrs(path);
        assert_eq!(attr(&a, flag), 1, "{}", path.display());
        assert!(
            attr(&a, "strata:spp_min") < 512,
            "{}: already finished; nothing left to resume",
            path.display()
        );
        assert!(float_bits(path).1, "{}: no exact sums", path.display());
        let resume = path.to_str().unwrap();
        let run = render(
            tmp.path(),
            &resumable_args(&scene, path, &["--resume", resume]),
        );
        run.assert_success();
        assert!(run.stderr.contains("resuming"), "{}", run.stderr);
        let (got, exact) = float_bits(path);
        assert!(
            !exact,
            "{}: the finished file keeps its sums",
            path.display()
        );
        assert_eq!(
            got.keys().collect::<Vec<_>>(),
            want.keys().collect::<Vec<_>>()
        );
        for (name, values) in &want {
            let differ = (values.iter().zip(&got[name]))
                .filter(|(a, b)| a != b)
                .count();
            assert_eq!(
                differ,
                0,
                "{}: {name} differs in {differ} pixels",
                path.display()
            );
        }
        idiff_identical(&full, path);
        let a = int_attrs(path);
        assert_eq!(
            (attr(&a, "strata:interrupted"), attr(&a, "strata:spp_min")),
            (0, 512)
        );
    }
}

/// `--resume` refuses, naming the file and the reason: a finished image (no sums), a render
/// of other settings (naming the setting), of an edited scene, options whose pixels cannot
/// be continued, and a file that is not there.
#[test]
fn resume_refuses_what_it_cannot_continue() {
    let tmp = tempfile::tempdir().unwrap();
    let mut doc = ao_wall_json();
    let scene = tmp.path().join("wall.gltf");
    std::fs::write(&scene, serde_json::to_vec(&doc).unwrap()).unwrap();
    let refused = |args: &[&str], words: &[&str]| {
        assert_refused(&render(tmp.path(), args), &format!("{args:?}"), words);
    };
    // A finished image.
    let finished = tmp.path().join("finished.exr");
    let short = [
        s(&scene),
        "-o",
        s(&finished),
        "--resolution",
        "16x16",
        "--spp",
        "4",
    ];
    render(tmp.path(), &short).assert_success();
    let fin = s(&finished);
    for (extra, words) in [
        (
            &["--resume", fin][..],
            &["finished.exr", "no sums to resume from"][..],
        ),
        (
            &["--resume", "nothing.exr"],
            &["nothing.exr", "no such file"],
        ),
        (
            &["--resume", fin, "--target-error", "0.1"],
            &["--resume", "--target-error"],
        ),
        (
            &["--resume", fin, "--time-limit", "5"],
            &["--resume", "--time-limit"],
        ),
    ] {
        refused(&[&short[..], extra].concat(), words);
    }
    // An unfinished one: a render far too long to finish, interrupted.
    let part = tmp.path().join("part.exr");
    let long = long_args(&scene, &part, "16x16", &["--progress-every", "0.05"]);
    let mut run = Running::start(tmp.path(), &long);
    run.wait_for_stderr("of the samples after", Duration::from_secs(60));
    run.sigint();
    wait_with_limit(&mut run.child, Duration::from_secs(60), "after SIGINT");
    assert_eq!(attr(&int_attrs(&part), "strata:interrupted"), 1);
    let resume = [&long[..], &["--resume", s(&part)]].concat();
    refused(
        &[&resume[..], &["--seed", "7"]].concat(),
        &["part.exr", "other settings", "strata:seed"],
    );
    // The same settings on an edited scene.
    doc["materials"] =
        serde_json::json!([{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}}]);
    std::fs::write(&scene, serde_json::to_vec(&doc).unwrap()).unwrap();
    refused(&resume, &["part.exr", "other files"]);
}

// ---------------------------------------------------------------------------------------
// Failed writes.

/// Render arguments whose EXR (256x256 noisy float RGB, about 90 KB; the PNG 55 KB) cannot
/// fit in the limits below.
fn noisy_args<'a>(scene: &'a str, out: &'a str, spp: &'a str) -> Vec<&'a str> {
    vec![
        scene,
        "-o",
        out,
        "--integrator",
        "ao",
        "--resolution",
        "256x256",
        "--spp",
        spp,
        "--sampler",
        "random",
    ]
}

const OLD: &[u8] = b"an older image that must survive a failed write";

#[test]
fn write_past_the_file_size_limit_leaves_no_partial_file() {
    // `ulimit -f 20`: at most 10 KiB (dash counts 512-byte blocks, bash 1 KiB). The kernel
    // then sends SIGXFSZ, which would kill the process; `trap '' XFSZ` ignores it, and an
    // ignored signal stays ignored across exec, so the write fails with EFBIG instead.
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.exr");
    std::fs::write(&out, OLD).unwrap();
    let wall = ao_wall();
    let run = render_under_shell(
        tmp.path(),
        "trap '' XFSZ; ulimit -f 20",
        &noisy_args(s(&wall), s(&out), "2"),
    );
    assert_eq!(run.status.code(), Some(1), "{}", run.stderr);
    let line = assert_one_error_line(
        &run.stderr,
        &[s(&out), "cannot write the EXR", "file too large"],
    );
    eprintln!("{line}");
    assert_eq!(std::fs::read(&out).unwrap(), OLD, "the older file changed");
    assert_entries(tmp.path(), &["out.exr"]);

    // With checkpoints: each failed checkpoint is a warning (the render goes on), the final
    // write is the error, and nothing partial is left either. Early checkpoints, with most
    // pixels still black, compress below the limit and are written: such a file is a whole
    // image, the last checkpoint that fitted.
    std::fs::remove_file(&out).unwrap();
    let mut args = noisy_args(s(&wall), s(&out), "64");
    args.extend_from_slice(&["--checkpoint", "0.0001"]);
    let run = render_under_shell(tmp.path(), "trap '' XFSZ; ulimit -f 20", &args);
    assert_eq!(run.status.code(), Some(1), "{}", run.stderr);
    assert_no_panic(&run.stderr);
    let lines: Vec<&str> = run.stderr.lines().collect();
    assert!(
        lines.len() >= 2
            && lines[..lines.len() - 1]
                .iter()
                .all(|l| l.starts_with("warning: checkpoint not written")),
        "{}",
        run.stderr
    );
    assert!(
        lines.last().unwrap().starts_with("error:"),
        "{}",
        run.stderr
    );
    if out.exists() {
        let (w, h, _) = read_exr_rgb(&out).expect("a checkpoint left behind is a whole EXR");
        assert_eq!((w, h), (256, 256));
        assert_eq!(attr(&int_attrs(&out), "strata:checkpoint"), 1);
        assert_entries(tmp.path(), &["out.exr"]);
    } else {
        assert_entries(tmp.path(), &[]);
    }
}

/// A tmpfs mounted for the test, unmounted on drop.
struct Tmpfs {
    dir: tempfile::TempDir,
}

impl Tmpfs {
    fn mount(size: &str) -> Result<Tmpfs, String> {
        let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
        let out = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(dir.path())
            .output()
            .map_err(|e| format!("cannot run mount: {e}"))?;
        if !out.status.success() {
            return Err(String::from_utf8_lossy(&out.stderr).trim().to_string());
        }
        Ok(Tmpfs { dir })
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(self.dir.path()).status();
    }
}

#[test]
fn write_to_a_full_disk_leaves_no_partial_file() {
    let fs = match Tmpfs::mount("64k") {
        Ok(fs) => fs,
        Err(e) => {
            if std::env::var_os("STRATA_REQUIRE_TMPFS").is_some() {
                panic!("cannot mount a tmpfs ({e}) and STRATA_REQUIRE_TMPFS is set");
            }
            eprintln!(
                "\n*** SKIPPED: write_to_a_full_disk_leaves_no_partial_file: cannot mount a tmpfs ({e}); needs root ***\n"
            );
            return;
        }
    };
    let out = fs.dir.path().join("out.exr");
    std::fs::write(&out, OLD).unwrap();
    let wall = ao_wall();
    let run = render(fs.dir.path(), &noisy_args(s(&wall), s(&out), "2"));
    assert_eq!(run.status.code(), Some(1), "{}", run.stderr);
    let line = assert_one_error_line(
        &run.stderr,
        &[s(&out), "cannot write the EXR", "no space left on device"],
    );
    eprintln!("{line}");
    assert_eq!(std::fs::read(&out).unwrap(), OLD, "the older file changed");
    assert_entries(fs.dir.path(), &["out.exr"]);
}

// ---------------------------------------------------------------------------------------
// Progress where stderr is not a terminal.

/// A farm's log (stderr a pipe) gets a progress line every `--progress-every` seconds, with
/// the share done rising; `--progress-every 0` prints none.
#[test]
fn progress_lines_go_to_a_log() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("long.exr");
    let wall = ao_wall();
    let long = |every: &'static str| {
        let extra = ["--no-png", "--time-limit", "1.6", "--progress-every", every];
        Running::start(tmp.path(), &long_args(&wall, &out, "64x64", &extra))
    };
    let mut run = long("0.25");
    let status = wait_with_limit(&mut run.child, Duration::from_secs(60), "a timed render");
    std::thread::sleep(Duration::from_millis(100));
    assert!(status.success(), "{}", run.stderr_text());
    let text = run.stderr_text();
    let percents: Vec<f64> = text
        .lines()
        .filter(|l| l.contains("% of the time limit after"))
        .map(|l| {
            let p = l
                .split("long.exr: ")
                .nth(1)
                .unwrap()
                .split('%')
                .next()
                .unwrap();
            p.parse().unwrap()
        })
        .collect();
    assert!(percents.len() >= 3, "{text}");
    assert!(percents.windows(2).all(|w| w[0] <= w[1]), "{percents:?}");
    assert!(percents.last().unwrap() > &50.0, "{percents:?}");

    let mut quiet = long("0");
    let status = wait_with_limit(&mut quiet.child, Duration::from_secs(60), "a quiet render");
    std::thread::sleep(Duration::from_millis(100));
    assert!(status.success());
    assert!(
        !quiet.stderr_text().contains("% of"),
        "{}",
        quiet.stderr_text()
    );
}
