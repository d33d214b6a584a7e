//! End-to-end tests of the `render` command line: bad input, determinism across thread
//! counts, the files and reports a render produces, scenes without a camera, and Ctrl-C.
//!
//! Every test runs the real binary in its own temporary directory (also its working
//! directory, so a file written anywhere unexpected shows up in the directory listings).

use std::io::Read;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::*;

use strata::render::output::read_exr_rgb;

fn ao_wall() -> PathBuf {
    repo_path("scenes/ao-wall.gltf")
}

fn bad(name: &str) -> PathBuf {
    repo_path("tests/data/bad").join(name)
}

const SMALL: [&str; 4] = ["--resolution", "32x32", "--spp", "4"];

fn with_small<'a>(args: &[&'a str]) -> Vec<&'a str> {
    let mut v = args.to_vec();
    v.extend_from_slice(&SMALL);
    v
}

// ---------------------------------------------------------------------------------------
// 1. Bad input.

/// What a refused command line must print on stderr, besides no panic.
enum Says {
    /// Exactly one line, `error: ...`, mentioning every word of `words` (case-insensitively)
    /// and, unless `one_of` is empty, at least one word of `one_of`.
    OneErrorLine {
        words: &'static [&'static str],
        one_of: &'static [&'static str],
    },
    /// Every word as written, in any number of lines.
    Mentions(&'static [&'static str]),
}

const fn one_error_line(words: &'static [&'static str]) -> Says {
    Says::OneErrorLine { words, one_of: &[] }
}

/// A command line `render` must refuse, run in a fresh temporary directory (also the working
/// directory): it fails, says what `says` says, and writes nothing.
struct Refusal {
    name: &'static str,
    /// Directories made in the temporary directory before the run; afterwards it must hold
    /// exactly these, still empty.
    dirs: &'static [&'static str],
    /// The arguments, split at whitespace. Here and in `says`, `{tmp}` stands for the
    /// temporary directory and `{repo}` for the repository.
    args: &'static str,
    says: Says,
}

const REFUSALS: &[Refusal] = &[
    Refusal {
        name: "error_missing_scene_file",
        dirs: &[],
        args: "{tmp}/missing.gltf -o {tmp}/out.exr --resolution 32x32 --spp 4",
        says: one_error_line(&["{tmp}/missing.gltf", "no such file"]),
    },
    // Bad scene files from tests/data/bad: the error names the file and says what is wrong.
    Refusal {
        name: "error_not_gltf",
        dirs: &[],
        args: "{repo}/tests/data/bad/not_gltf.gltf -o {tmp}/out.exr --resolution 32x32 --spp 4",
        says: one_error_line(&["{repo}/tests/data/bad/not_gltf.gltf", "not a glTF"]),
    },
    Refusal {
        name: "error_required_extension",
        dirs: &[],
        args: "{repo}/tests/data/bad/required_extension.gltf -o {tmp}/out.exr \
               --resolution 32x32 --spp 4",
        says: one_error_line(&[
            "{repo}/tests/data/bad/required_extension.gltf",
            "requires the extension EXT_texture_avif",
            "not support",
        ]),
    },
    Refusal {
        name: "error_truncated_glb",
        dirs: &[],
        args: "{repo}/tests/data/bad/truncated.glb -o {tmp}/out.exr --resolution 32x32 --spp 4",
        says: one_error_line(&["{repo}/tests/data/bad/truncated.glb", "invalid", "glTF"]),
    },
    // The message names the scene, the buffer and the file that could not be read.
    Refusal {
        name: "error_missing_buffer",
        dirs: &[],
        args: "{repo}/tests/data/bad/missing_buffer.gltf -o {tmp}/out.exr \
               --resolution 32x32 --spp 4",
        says: one_error_line(&[
            "{repo}/tests/data/bad/missing_buffer.gltf",
            "buffer 0",
            "does-not-exist.bin",
            "no such file",
        ]),
    },
    Refusal {
        name: "error_output_directory_missing",
        dirs: &[],
        args: "{repo}/scenes/ao-wall.gltf -o {tmp}/no/such/dir/out.exr --resolution 32x32 --spp 4",
        says: one_error_line(&["{tmp}/no/such/dir/out.exr", "does not exist"]),
    },
    Refusal {
        name: "error_output_is_existing_directory",
        dirs: &["out.exr"],
        args: "{repo}/scenes/ao-wall.gltf -o {tmp}/out.exr --resolution 32x32 --spp 4",
        says: one_error_line(&["{tmp}/out.exr", "directory"]),
    },
    // Either reason (not .exr, or a directory) is right; it must name the path.
    Refusal {
        name: "error_output_is_existing_directory_without_extension",
        dirs: &["images"],
        args: "{repo}/scenes/ao-wall.gltf -o {tmp}/images --resolution 32x32 --spp 4",
        says: Says::OneErrorLine {
            words: &["{tmp}/images"],
            one_of: &[".exr", "directory"],
        },
    },
    Refusal {
        name: "error_output_wrong_extension",
        dirs: &[],
        args: "{repo}/scenes/ao-wall.gltf -o {tmp}/out.tiff --resolution 32x32 --spp 4",
        says: one_error_line(&["{tmp}/out.tiff", ".exr"]),
    },
    Refusal {
        name: "error_spp_zero",
        dirs: &[],
        args: "{repo}/scenes/ao-wall.gltf -o {tmp}/out.exr --resolution 32x32 --spp 0",
        says: one_error_line(&["--spp", "at least 1"]),
    },
    // The rest need only name the option (and the value).
    Refusal {
        name: "error_camera_out_of_range",
        dirs: &[],
        args: "{repo}/scenes/ao-wall.gltf -o {tmp}/out.exr --camera 5 --resolution 32x32 --spp 4",
        says: Says::Mentions(&["--camera"]),
    },
    Refusal {
        name: "error_resolution_zero",
        dirs: &[],
        args: "{repo}/scenes/ao-wall.gltf -o {tmp}/out.exr --resolution 0x10 --spp 4",
        says: Says::Mentions(&["--resolution"]),
    },
    // error_min_pass_seconds_negative_or_not_a_number, one case per value.
    Refusal {
        name: "error_min_pass_seconds -1",
        dirs: &[],
        args: "{repo}/scenes/ao-wall.gltf -o {tmp}/out.exr --min-pass-seconds=-1",
        says: Says::Mentions(&["--min-pass-seconds", "-1"]),
    },
    Refusal {
        name: "error_min_pass_seconds nan",
        dirs: &[],
        args: "{repo}/scenes/ao-wall.gltf -o {tmp}/out.exr --min-pass-seconds=nan",
        says: Says::Mentions(&["--min-pass-seconds", "nan"]),
    },
    Refusal {
        name: "error_min_pass_seconds inf",
        dirs: &[],
        args: "{repo}/scenes/ao-wall.gltf -o {tmp}/out.exr --min-pass-seconds=inf",
        says: Says::Mentions(&["--min-pass-seconds", "inf"]),
    },
    Refusal {
        name: "error_min_pass_seconds soon",
        dirs: &[],
        args: "{repo}/scenes/ao-wall.gltf -o {tmp}/out.exr --min-pass-seconds=soon",
        says: Says::Mentions(&["--min-pass-seconds", "soon"]),
    },
];

/// Every case of [`REFUSALS`]; a failure names each failing case.
#[test]
fn refused_command_lines() {
    check_every_case(REFUSALS, |case| case.name, check_refusal);
}

fn check_refusal(case: &Refusal) {
    let tmp = tempfile::tempdir().unwrap();
    let expand = |text: &str| {
        text.replace("{tmp}", s(tmp.path()))
            .replace("{repo}", env!("CARGO_MANIFEST_DIR"))
    };
    for dir in case.dirs {
        std::fs::create_dir(tmp.path().join(dir)).unwrap();
    }
    let args: Vec<String> = case.args.split_whitespace().map(expand).collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let run = render(tmp.path(), &args);
    assert!(
        !run.status.success(),
        "render should fail for {args:?}; stdout:\n{}\nstderr:\n{}",
        run.stdout,
        run.stderr
    );
    match case.says {
        Says::OneErrorLine { words, one_of } => {
            let words: Vec<String> = words.iter().map(|w| expand(w)).collect();
            let words: Vec<&str> = words.iter().map(String::as_str).collect();
            assert_one_error_line(&run.stderr, &words);
            let lower = run.stderr.to_lowercase();
            assert!(
                one_of.is_empty() || one_of.iter().any(|w| lower.contains(&w.to_lowercase())),
                "stderr should mention one of {one_of:?}, got:\n{}",
                run.stderr
            );
        }
        Says::Mentions(words) => {
            assert_no_panic(&run.stderr);
            for word in words {
                let word = expand(word);
                assert!(
                    run.stderr.contains(&word),
                    "stderr should mention {word:?}, got:\n{}",
                    run.stderr
                );
            }
        }
    }
    assert_entries(tmp.path(), case.dirs);
    for dir in case.dirs {
        assert_entries(&tmp.path().join(dir), &[]);
    }
}

/// A valid file with nothing to hit (tests/data/bad/no_triangles.gltf: one mesh of points) is
/// a valid scene: it renders the background alone, on either backend, with a warning.
#[test]
fn a_scene_without_triangles_renders_the_background_with_a_warning() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = bad("no_triangles.gltf");
    for backend in ["embree", "obvhs"] {
        let out = tmp.path().join(format!("{backend}.exr"));
        let run = render(
            tmp.path(),
            &with_small(&[
                s(&scene),
                "-o",
                s(&out),
                "--background",
                "0.25,0.5,0.75",
                "--backend",
                backend,
            ]),
        );
        run.assert_success();
        assert!(
            run.stderr.contains("no triangles") && run.stderr.contains("background"),
            "{}",
            run.stderr
        );
        let (_, _, px) = strata::render::output::read_exr_rgb(&out).unwrap();
        assert!(
            px.iter().all(|p| *p == [0.25, 0.5, 0.75]),
            "{backend}: not the background everywhere"
        );
    }
}

// ---------------------------------------------------------------------------------------
// 2. Determinism.

/// Renders ao-wall at 48x40, 16 spp, and returns the EXR pixels as bit patterns.
fn render_bits(sampler: &str, threads: u32, seed: u64) -> Vec<[u32; 3]> {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.exr");
    let threads = threads.to_string();
    let seed = seed.to_string();
    let run = render(
        tmp.path(),
        &[
            s(&ao_wall()),
            "-o",
            s(&out),
            "--no-png",
            "--resolution",
            "48x40",
            "--spp",
            "16",
            "--sampler",
            sampler,
            "--threads",
            &threads,
            "--seed",
            &seed,
        ],
    );
    run.assert_success();
    let (w, h, px) = read_exr_rgb(&out).unwrap();
    assert_eq!((w, h), (48, 40));
    assert!(
        px.iter().flatten().any(|&v| v != 0.0),
        "the {sampler} render is all black"
    );
    px.iter()
        .map(|p| [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()])
        .collect()
}

#[test]
fn same_seed_same_image_on_any_thread_count() {
    for sampler in ["random", "stratified", "sobol"] {
        let one = render_bits(sampler, 1, 3);
        for threads in [2, 3] {
            let other = render_bits(sampler, threads, 3);
            let differing = one.iter().zip(&other).filter(|(a, b)| a != b).count();
            assert_eq!(
                differing, 0,
                "{sampler}: --threads 1 and --threads {threads} differ in {differing} pixel(s)"
            );
        }
    }
}

#[test]
fn different_seed_different_image() {
    let a = render_bits("random", 2, 1);
    let b = render_bits("random", 2, 2);
    let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    assert!(
        differing > a.len() / 10,
        "seeds 1 and 2 differ in only {differing} of {} pixels",
        a.len()
    );
}

// ---------------------------------------------------------------------------------------
// 3. Output files and reports.

#[test]
fn writes_exr_and_png_and_reports() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.exr");
    let run = render(
        tmp.path(),
        &[
            s(&ao_wall()),
            "-o",
            s(&out),
            "--resolution",
            "48x40",
            "--spp",
            "16",
        ],
    );
    run.assert_success();
    assert_entries(tmp.path(), &["out.exr", "out.png"]);

    let (w, h, px) = read_exr_rgb(&out).unwrap();
    assert_eq!((w, h), (48, 40), "EXR size");
    assert!(px.iter().flatten().all(|v| v.is_finite()));
    assert!(px.iter().flatten().any(|&v| v > 0.0), "EXR is all black");

    let png = tmp.path().join("out.png");
    let img = image::open(&png).expect("the PNG decodes");
    assert_eq!((img.width(), img.height()), (48, 40), "PNG size");
    // And the IHDR, read by hand: width and height are the first two big-endian u32s.
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap());
    assert_eq!((be(16), be(20)), (48, 40), "PNG IHDR size");

    let summary = run.stdout.lines().next().unwrap_or_default();
    for want in ["48x40", "16 spp", "Mrays/s"] {
        assert!(
            summary.contains(want),
            "summary line should contain {want:?}: {summary:?}"
        );
    }
}

#[test]
fn no_png_writes_only_the_exr() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.exr");
    let run = render(
        tmp.path(),
        &with_small(&[s(&ao_wall()), "-o", s(&out), "--no-png"]),
    );
    run.assert_success();
    assert_entries(tmp.path(), &["out.exr"]);
    let (w, h, _) = read_exr_rgb(&out).unwrap();
    assert_eq!((w, h), (32, 32));
}

#[test]
fn stats_report_phases_and_rays() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.exr");
    let (w, h, spp) = (40u64, 24u64, 8u64);
    let res = format!("{w}x{h}");
    let spp_s = spp.to_string();
    let run = render(
        tmp.path(),
        &[
            s(&ao_wall()),
            "-o",
            s(&out),
            "--resolution",
            &res,
            "--spp",
            &spp_s,
            "--stats",
        ],
    );
    run.assert_success();
    assert_entries(tmp.path(), &["out.exr", "out.png"]);
    // Each phase is reported as "<phase> <seconds> s".
    for phase in ["load", "BVH build", "render", "write"] {
        let reported = run.stdout.lines().any(|l| {
            l.match_indices(phase).any(|(i, _)| {
                let mut rest = l[i + phase.len()..].split_whitespace();
                let secs = rest.next().and_then(|v| v.parse::<f64>().ok());
                secs.is_some_and(|v| v >= 0.0)
                    && rest.next().map(|u| u.trim_end_matches(',')) == Some("s")
            })
        });
        assert!(
            reported,
            "--stats should report the {phase} time:\n{}",
            run.stdout
        );
    }
    // A number immediately followed by "camera": the camera ray count, one per sample.
    let camera_rays = run
        .stdout
        .lines()
        .find_map(|l| {
            let words: Vec<&str> = l.split(|c: char| c.is_whitespace() || c == ',').collect();
            words
                .windows(2)
                .find(|p| p[1] == "camera")
                .and_then(|p| p[0].parse::<u64>().ok())
        })
        .unwrap_or_else(|| panic!("no camera ray count in:\n{}", run.stdout));
    assert_eq!(
        camera_rays,
        w * h * spp,
        "one camera ray per sample:\n{}",
        run.stdout
    );
}

#[test]
fn exr_header_holds_settings() {
    let has_oiiotool = Command::new("oiiotool")
        .arg("--help")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok();
    if !has_oiiotool {
        if std::env::var_os("CI").is_some() {
            panic!("oiiotool not found on PATH, and CI is set");
        }
        eprintln!("\n*** SKIPPED: oiiotool not found; exr_header_holds_settings not checked ***\n");
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.exr");
    let run = render(
        tmp.path(),
        &with_small(&[
            s(&ao_wall()),
            "-o",
            s(&out),
            "--sampler",
            "stratified",
            "--seed",
            "12345",
        ]),
    );
    run.assert_success();
    let info = Command::new("oiiotool")
        .args(["--info", "-v", s(&out)])
        .output()
        .expect("oiiotool runs");
    assert!(info.status.success(), "oiiotool failed: {info:?}");
    let text = String::from_utf8_lossy(&info.stdout);
    let attr = |name: &str| -> String {
        text.lines()
            .find_map(|l| {
                l.trim()
                    .strip_prefix(name)
                    .and_then(|rest| rest.strip_prefix(':'))
            })
            .unwrap_or_else(|| panic!("no {name} in the EXR header:\n{text}"))
            .trim()
            .trim_matches('"')
            .to_string()
    };
    // Path tracing is the default integrator.
    assert_eq!(attr("strata:integrator"), "path");
    assert_eq!(attr("strata:sampler"), "stratified");
    assert_eq!(attr("strata:spp"), "4");
    assert_eq!(attr("strata:seed"), "12345");
    assert_entries(tmp.path(), &["out.exr", "out.png"]);
}

// ---------------------------------------------------------------------------------------
// 4. A scene without a camera.

/// Removes the top-level `"cameras": [...]` array (with its trailing comma) from pretty JSON.
fn remove_cameras_array(json: &str) -> String {
    let key = "\"cameras\"";
    let start = json.find(key).expect("the scene has a cameras array");
    let open = start + json[start..].find('[').unwrap();
    let mut depth = 0;
    let mut end = None;
    for (i, c) in json[open..].char_indices() {
        match c {
            '[' => depth += 1,
            ']' => {
                depth -= 1;
                if depth == 0 {
                    end = Some(open + i + 1);
                    break;
                }
            }
            _ => {}
        }
    }
    let mut end = end.expect("the cameras array is closed");
    // Swallow the comma that separated it from the next member.
    let after = &json[end..];
    let trimmed = after.trim_start();
    if trimmed.starts_with(',') {
        end += after.len() - trimmed.len() + 1;
    }
    format!("{}{}", &json[..start], &json[end..])
}

#[test]
fn scene_without_camera_is_framed() {
    let tmp = tempfile::tempdir().unwrap();
    let original = std::fs::read_to_string(ao_wall()).unwrap();
    let node_camera = "\"camera\": 0,";
    assert_eq!(
        original.matches(node_camera).count(),
        1,
        "expected one node with a camera in ao-wall.gltf"
    );
    let edited = remove_cameras_array(&original.replacen(node_camera, "", 1));
    assert!(
        !edited.contains("\"cameras\"") && !edited.contains("\"camera\":"),
        "the edit left a camera in:\n{edited}"
    );
    let scenes = tmp.path().join("scenes");
    std::fs::create_dir(&scenes).unwrap();
    let scene = scenes.join("nocam.gltf");
    std::fs::write(&scene, edited).unwrap();
    let outdir = tmp.path().join("out");
    std::fs::create_dir(&outdir).unwrap();
    let out = outdir.join("nocam.exr");

    let run = render(tmp.path(), &with_small(&[s(&scene), "-o", s(&out)]));
    run.assert_success();
    let stderr = run.stderr.to_lowercase();
    assert!(
        stderr.contains("no camera") && stderr.contains("framing"),
        "expected a note about framing the scene:\n{}",
        run.stderr
    );
    assert!(stderr.contains("nocam.gltf"), "{}", run.stderr);
    assert!(!stderr.contains("error"), "{}", run.stderr);
    let (w, h, px) = read_exr_rgb(&out).unwrap();
    assert_eq!((w, h), (32, 32));
    let lit = px.iter().filter(|p| p.iter().any(|&v| v > 0.0)).count();
    assert!(lit > 0, "the framed render is all black");
    assert_entries(&outdir, &["nocam.exr", "nocam.png"]);
}

// ---------------------------------------------------------------------------------------
// 5. Ctrl-C.

#[test]
fn interrupt_saves_the_image() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("long.exr");
    let mut child = Command::new(env!("CARGO_BIN_EXE_render"))
        .args([
            s(&ao_wall()),
            "-o",
            s(&out),
            "--spp",
            "100000",
            "--resolution",
            "128x128",
            "--sampler",
            "random",
        ])
        .current_dir(tmp.path())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot start the render binary");

    std::thread::sleep(Duration::from_millis(1500));
    assert!(
        child.try_wait().unwrap().is_none(),
        "the long render ended before it was interrupted"
    );
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("cannot run kill");
    assert!(kill.success(), "kill -INT failed");

    let t0 = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if t0.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("the render was still running 60 s after SIGINT");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut stdout = String::new();
    let mut stderr = String::new();
    child
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut stdout)
        .unwrap();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut stderr)
        .unwrap();

    assert_eq!(
        status.code(),
        Some(130),
        "exit status after SIGINT: {status}\nstdout:\n{stdout}\nstderr:\n{stderr}"
    );
    assert_no_panic(&stderr);
    assert!(
        stderr.to_lowercase().contains("saved"),
        "stderr should say the image was saved:\n{stderr}"
    );
    assert!(
        stdout.contains("interrupted"),
        "the summary should say the render was interrupted:\n{stdout}"
    );
    let (w, h, px) = read_exr_rgb(&out).expect("the interrupted EXR is readable");
    assert_eq!((w, h), (128, 128));
    assert!(px.iter().flatten().all(|v| v.is_finite()));
    assert!(
        px.iter().flatten().any(|&v| v != 0.0),
        "the interrupted image is all zero"
    );
    assert_entries(tmp.path(), &["long.exr", "long.png"]);
}

// ---------------------------------------------------------------------------------------
// 6. Light transport options.

#[test]
fn pixel_replay_renders_one_pixel_and_prints_it() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("one.exr");
    let run = render(
        tmp.path(),
        &[
            s(&ao_wall()),
            "-o",
            s(&out),
            "--resolution",
            "16x16",
            "--spp",
            "8",
            "--pixel",
            "5,9",
        ],
    );
    run.assert_success();
    assert!(run.stdout.contains("pixel (5, 9)"), "{}", run.stdout);
    assert!(run.stdout.contains("(8 samples)"), "{}", run.stdout);
    let (w, _, px) = strata::render::output::read_exr_rgb(&out).unwrap();
    for (i, p) in px.iter().enumerate() {
        let (x, y) = (i % w, i / w);
        if (x, y) == (5, 9) {
            assert!(p[0] > 0.0, "the replayed pixel was rendered");
        } else {
            assert_eq!(*p, [0.0; 3], "pixel ({x}, {y}) should not be rendered");
        }
    }
    // The same pixel of a full render, same seed: bit-identical.
    let full = tmp.path().join("full.exr");
    render(
        tmp.path(),
        &[
            s(&ao_wall()),
            "-o",
            s(&full),
            "--resolution",
            "16x16",
            "--spp",
            "8",
        ],
    )
    .assert_success();
    let (_, _, all) = strata::render::output::read_exr_rgb(&full).unwrap();
    assert_eq!(all[9 * w + 5], px[9 * w + 5]);

    let bad = render(
        tmp.path(),
        &[
            s(&ao_wall()),
            "-o",
            s(&out),
            "--resolution",
            "16x16",
            "--pixel",
            "16,0",
        ],
    );
    assert!(!bad.status.success());
    assert_one_error_line(&bad.stderr, &["--pixel", "outside"]);
}

#[test]
fn path_tracing_without_lights_warns_and_background_lights_the_scene() {
    let tmp = tempfile::tempdir().unwrap();
    // Without --background or --env, a scene with no light is lit by the default white sky,
    // and says so: the floor beside the wall is not black.
    let sky = tmp.path().join("sky.exr");
    let run = render(
        tmp.path(),
        &[
            s(&ao_wall()),
            "-o",
            s(&sky),
            "--integrator",
            "path",
            "--resolution",
            "16x16",
            "--spp",
            "16",
        ],
    );
    run.assert_success();
    assert!(
        run.stderr.contains("no light source") && run.stderr.contains("white sky"),
        "{}",
        run.stderr
    );
    let (_, _, px) = strata::render::output::read_exr_rgb(&sky).unwrap();
    let mean = px.iter().map(|p| p[0] as f64).sum::<f64>() / px.len() as f64;
    assert!(mean > 0.1, "the default sky lights the scene: mean {mean}");

    // An explicit black background keeps the scene dark: black, without tracing a ray.
    let out = tmp.path().join("dark.exr");
    let wall = ao_wall();
    let args = [
        s(&wall),
        "-o",
        s(&out),
        "--integrator",
        "path",
        "--background",
        "0,0,0",
        "--resolution",
        "16x16",
        "--spp",
        "4",
        "--stats",
    ];
    let run = render(tmp.path(), &args);
    run.assert_success();
    assert!(run.stderr.contains("no light source"), "{}", run.stderr);
    assert!(
        run.stdout.contains("rays: 0 camera, 0 extension, 0 shadow"),
        "{}",
        run.stdout
    );
    let (_, _, px) = strata::render::output::read_exr_rgb(&out).unwrap();
    assert!(px.iter().all(|p| *p == [0.0; 3]));

    // `--env none` asks for no environment and no default sky: black again.
    let none = tmp.path().join("none.exr");
    let run = render(
        tmp.path(),
        &[
            s(&wall),
            "-o",
            s(&none),
            "--integrator",
            "path",
            "--env",
            "none",
            "--resolution",
            "16x16",
            "--spp",
            "4",
        ],
    );
    run.assert_success();
    assert!(!run.stderr.contains("white sky"), "{}", run.stderr);
    let (_, _, px) = strata::render::output::read_exr_rgb(&none).unwrap();
    assert!(
        px.iter().all(|p| *p == [0.0; 3]),
        "--env none lit the scene"
    );

    // Under a white background of radiance 1, the floor beside the wall sees half the sky
    // directly: with one bounce, radiance ρ·(1/2)·1 for the white (ρ = 1) floor.
    let lit = tmp.path().join("lit.exr");
    let run = render(
        tmp.path(),
        &[
            s(&ao_wall()),
            "-o",
            s(&lit),
            "--integrator",
            "direct",
            "--background",
            "1,1,1",
            "--resolution",
            "16x16",
            "--spp",
            "256",
        ],
    );
    run.assert_success();
    assert!(!run.stderr.contains("no light source"), "{}", run.stderr);
    let (_, _, px) = strata::render::output::read_exr_rgb(&lit).unwrap();
    let mean = px.iter().map(|p| p[0] as f64).sum::<f64>() / px.len() as f64;
    assert!(
        (mean - 0.5).abs() < 0.01,
        "direct light under a white sky beside a wall: {mean}"
    );
}

/// The PNG preview is the EXR's linear radiance through the view transform (`--view`,
/// `--exposure`). The standard view's bytes are checked against the sRGB formula written out
/// here; AgX's against `Display` (whose curve the unit tests in `render::view` check), which
/// tests that `--view` and `--exposure` reach the preview; and the two views differ.
#[test]
fn the_png_preview_is_the_exr_through_its_view() {
    use strata::render::view::{Display, ViewTransform};
    let tmp = tempfile::tempdir().unwrap();
    let scene = repo_path("scenes/cornell-box.gltf");
    let mut pngs = Vec::new();
    for (view, exposure) in [("standard", "0"), ("agx", "0"), ("agx", "1.5")] {
        let out = tmp.path().join(format!("{view}-{exposure}.exr"));
        let run = render(
            tmp.path(),
            &[
                s(&scene),
                "-o",
                s(&out),
                "--resolution",
                "24x24",
                "--spp",
                "8",
                "--view",
                view,
                "--exposure",
                exposure,
            ],
        );
        run.assert_success();
        let (_, _, px) = read_exr_rgb(&out).unwrap();
        let png = image::open(out.with_extension("png")).unwrap().to_rgb8();
        let transform = match view {
            "standard" => ViewTransform::Standard,
            _ => ViewTransform::Agx,
        };
        let display = Display::new(transform, exposure.parse().unwrap());
        // IEC 61966-2-1's transfer function of the clamped value.
        let srgb = |v: f32| match v.clamp(0.0, 1.0) {
            v if v <= 0.003_130_8 => 12.92 * v,
            v => 1.055 * v.powf(1.0 / 2.4) - 0.055,
        };
        for (p, q) in px.iter().zip(png.pixels()) {
            let want = match transform {
                ViewTransform::Standard => p.map(srgb),
                ViewTransform::Agx => display.encode(glam::Vec3::from_array(*p)).to_array(),
            };
            for (w, got) in want.iter().zip(q.0) {
                assert!(
                    (w * 255.0 + 0.5) as u8 == got,
                    "{view} {exposure}: pixel {p:?} gave {q:?}, want {want:?}"
                );
            }
        }
        pngs.push(png);
    }
    assert_ne!(pngs[0], pngs[1], "the views differ");
    assert_ne!(pngs[1], pngs[2], "the exposure changes the preview");
    let bad = render(
        tmp.path(),
        &[
            s(&scene),
            "-o",
            s(&tmp.path().join("x.exr")),
            "--exposure",
            "inf",
        ],
    );
    assert!(!bad.status.success());
    assert_one_error_line(&bad.stderr, &["--exposure"]);
}

/// A white floor 4 × 4 with a small emissive tile 0.5 above it (radiance `emissive`, as
/// `emissiveFactor` × `strength`), seen from above, written to `dir/name`.
fn floor_with_emissive_tile(
    dir: &std::path::Path,
    name: &str,
    emissive: [f32; 3],
    strength: Option<f32>,
) -> PathBuf {
    let positions: [[f32; 3]; 8] = [
        [-2.0, 0.0, -2.0],
        [2.0, 0.0, -2.0],
        [2.0, 0.0, 2.0],
        [-2.0, 0.0, 2.0],
        [-0.1, 0.5, -0.1],
        [0.1, 0.5, -0.1],
        [0.1, 0.5, 0.1],
        [-0.1, 0.5, 0.1],
    ];
    let mut bin: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let indices = [0u32, 2, 1, 0, 3, 2, 4, 6, 5, 4, 7, 6];
    bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let mut tile = serde_json::json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0},
        "emissiveFactor": emissive,
        "doubleSided": true
    });
    let mut used = vec![];
    if let Some(strength) = strength {
        tile["extensions"] =
            serde_json::json!({"KHR_materials_emissive_strength": {"emissiveStrength": strength}});
        used.push("KHR_materials_emissive_strength");
    }
    // Looking down: a quarter turn about +X.
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let doc = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": used,
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0},
            {"camera": 0, "translation": [0.0, 3.0, 0.0], "rotation": [-h, 0.0, 0.0, h]}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01, "aspectRatio": 1.0}}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": 0}, "indices": 1, "material": 0},
            {"attributes": {"POSITION": 0}, "indices": 2, "material": 1}
        ]}],
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0}, "doubleSided": true},
            tile
        ],
        "buffers": [{"byteLength": bin.len(), "uri": data_uri(&bin)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 96},
            {"buffer": 0, "byteOffset": 96, "byteLength": 24},
            {"buffer": 0, "byteOffset": 120, "byteLength": 24}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
             "min": [-2.0, 0.0, -2.0], "max": [2.0, 0.5, 2.0]},
            {"bufferView": 1, "componentType": 5125, "count": 6, "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR"}
        ]
    });
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// Renders `scene` by path tracing at 24 × 24, 8 spp, with `extra` options; the run and the
/// EXR's pixels.
fn render_small(
    dir: &std::path::Path,
    scene: &std::path::Path,
    out: &str,
    extra: &[&str],
) -> (Run, Vec<[f32; 3]>) {
    let out = dir.join(out);
    let mut args = vec![
        s(scene),
        "-o",
        s(&out),
        "--no-png",
        "--integrator",
        "path",
        "--resolution",
        "24x24",
        "--spp",
        "8",
    ];
    args.extend_from_slice(extra);
    let run = render(dir, &args);
    run.assert_success();
    let pixels = read_exr_rgb(&out).unwrap().2;
    (run, pixels)
}

fn mean_of(pixels: &[[f32; 3]]) -> f64 {
    pixels
        .iter()
        .map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0)
        .sum::<f64>()
        / pixels.len() as f64
}

/// Light by default (docs/lights.md, "Light by default"): emissive surfaces no brighter than
/// glTF's core allows that give a sliver of a white sky's power are glowing details, and the
/// scene is lit by the sky as well, with a note; `--env none` keeps them alone. Emitters meant
/// to light (a tile with emissive strength, the bundled Cornell box and emissive-strength
/// scenes) render exactly as with `--env none`.
#[test]
fn faint_emitters_get_the_default_sky_and_lights_do_not() {
    let tmp = tempfile::tempdir().unwrap();
    let faint = floor_with_emissive_tile(tmp.path(), "faint.gltf", [1.0, 0.6, 0.2], None);
    let (run, lit) = render_small(tmp.path(), &faint, "faint.exr", &[]);
    assert!(
        run.stderr.contains("glowing details") && run.stderr.contains("white sky"),
        "{}",
        run.stderr
    );
    let (run, alone) = render_small(tmp.path(), &faint, "faint-none.exr", &["--env", "none"]);
    assert!(!run.stderr.contains("white sky"), "{}", run.stderr);
    // The 0.8-grey floor under the sky is about 0.8 bright; the tile alone lights it dimly.
    let (lit, alone) = (mean_of(&lit), mean_of(&alone));
    assert!(lit > 0.5, "the sky lights the floor: mean {lit}");
    assert!(alone < 0.1, "the tile alone: mean {alone}");

    // The same tile at radiance 4 (emissive strength): a light, and nothing is added.
    let light = floor_with_emissive_tile(tmp.path(), "light.gltf", [1.0, 0.6, 0.2], Some(4.0));
    let (run, default) = render_small(tmp.path(), &light, "light.exr", &[]);
    assert!(!run.stderr.contains("white sky"), "{}", run.stderr);
    let (_, alone) = render_small(tmp.path(), &light, "light-none.exr", &["--env", "none"]);
    assert_eq!(default, alone, "a light by intent got the sky");
    assert!(mean_of(&default) > 0.0);

    for scene in ["scenes/cornell-box.gltf", "scenes/emissive-strength.gltf"] {
        let path = repo_path(scene);
        let (run, default) = render_small(tmp.path(), &path, "scene.exr", &[]);
        assert!(!run.stderr.contains("white sky"), "{scene}: {}", run.stderr);
        let (_, alone) = render_small(tmp.path(), &path, "scene-none.exr", &["--env", "none"]);
        assert_eq!(
            default, alone,
            "{scene}: the default differs from --env none"
        );
    }
}

/// The Khronos sample models whose emissive textures are details (DamagedHelmet, WaterBottle,
/// BoomBox, ToyCar, ClearCoatTest, TransmissionTest) render lit by default, not black. They
/// are not in the repository: the test reads them from `STRATA_KHRONOS_DIR` or
/// `../shared/scenes/khronos` and says loudly when it cannot.
#[test]
fn khronos_models_with_emissive_details_are_lit_by_default() {
    let dir = std::env::var_os("STRATA_KHRONOS_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo_path("../shared/scenes/khronos"));
    if !dir.is_dir() {
        eprintln!(
            "SKIPPED khronos_models_with_emissive_details_are_lit_by_default: no Khronos models at {} (set STRATA_KHRONOS_DIR)",
            dir.display()
        );
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    for name in [
        "DamagedHelmet",
        "WaterBottle",
        "BoomBox",
        "ToyCar",
        "ClearCoatTest",
        "TransmissionTest",
    ] {
        let binary = dir
            .join(name)
            .join("glTF-Binary")
            .join(format!("{name}.glb"));
        let text = dir.join(name).join("glTF").join(format!("{name}.gltf"));
        let scene = if binary.is_file() { binary } else { text };
        let (run, pixels) = render_small(tmp.path(), &scene, &format!("{name}.exr"), &[]);
        assert!(
            run.stderr.contains("glowing details"),
            "{name}: {}",
            run.stderr
        );
        // Under --env none these average 0 to 0.09; lit, 0.34 to 0.86 (the models fill part
        // of the frame against a background of radiance 1).
        let mean = mean_of(&pixels);
        assert!(mean > 0.2, "{name}: mean {mean}");
    }
}

/// The README's first command renders: its `render` arguments (after `cargo run --release
/// --`), at a small size and one sample per pixel, write the EXR and PNG it promises.
#[test]
fn the_readmes_first_command_renders() {
    let readme = std::fs::read_to_string(repo_path("README.md")).unwrap();
    let line = readme
        .lines()
        .find(|l| l.contains("tools/setup.sh && cargo run --release --"))
        .expect("the README's first command");
    let args: Vec<&str> = line
        .split("cargo run --release --")
        .nth(1)
        .unwrap()
        .split_whitespace()
        .collect();
    let tmp = tempfile::tempdir().unwrap();
    let repo = repo_path(".");
    let mut full: Vec<String> = args
        .iter()
        .map(|a| match repo.join(a).exists() {
            true => repo.join(a).to_string_lossy().into_owned(),
            false => a.to_string(),
        })
        .collect();
    full.extend(["--spp", "1", "--resolution", "32x24"].map(String::from));
    let full: Vec<&str> = full.iter().map(String::as_str).collect();
    let run = render(tmp.path(), &full);
    run.assert_success();
    assert!(!run.stderr.contains("warning: --env"), "{}", run.stderr);
    let exr = args[args.iter().position(|&a| a == "-o").unwrap() + 1];
    assert_entries(tmp.path(), &[exr, &exr.replace(".exr", ".png")]);
}

/// The mean of the four pixels at the centre of a square image of even `size`.
fn centre(pixels: &[[f32; 3]], size: usize) -> f32 {
    let h = size / 2;
    let four = [(h - 1, h - 1), (h, h - 1), (h - 1, h), (h, h)];
    four.iter()
        .map(|&(x, y)| pixels[y * size + x].iter().sum::<f32>() / 3.0)
        .sum::<f32>()
        / 4.0
}

/// `--background transparent`: the EXR's alpha `A` is 1 where the scene covers a pixel, 0
/// where only the background is seen and between 0 and 1 on the outline, the beauty there
/// is 0 (premultiplied) while the default sky still lights the floor, and the PNG preview's
/// alpha follows. Without it the EXR has no alpha and the PNG none.
#[test]
fn a_transparent_background_gives_the_scenes_coverage_as_alpha() {
    let tmp = tempfile::tempdir().unwrap();
    // A 4 × 4 floor seen from 10 above with a 40° field of view: the floor covers the middle
    // 2/3.64 of the frame's width and height, the corners see past it.
    let scene = floor_with_emissive_tile(tmp.path(), "floor.gltf", [0.01; 3], None);
    let view = [
        "--look-from",
        "0,10,0",
        "--look-at",
        "0,0,0",
        "--up",
        "0,0,-1",
        "--fov",
        "40",
    ];
    let out = tmp.path().join("t.exr");
    let mut args = vec![
        s(&scene),
        "-o",
        s(&out),
        "--resolution",
        "24x24",
        "--spp",
        "64",
    ];
    args.extend(view);
    let mut transparent = args.clone();
    transparent.extend(["--background", "transparent"]);
    render(tmp.path(), &transparent).assert_success();
    let (channels, texts) = read_channels(&out);
    assert_eq!(texts["strata:background"], "transparent");
    let (a, r) = (&channels["A"], &channels["R"]);
    let at = |x: usize, y: usize| y * 24 + x;
    for (x, y) in [(9, 14), (8, 8), (15, 15)] {
        assert_eq!(a[at(x, y)], 1.0, "({x}, {y}) is on the floor");
        assert!(
            r[at(x, y)] > 0.3,
            "the sky lights the floor: {}",
            r[at(x, y)]
        );
    }
    for (x, y) in [(0, 0), (23, 0), (0, 23), (23, 23), (1, 12)] {
        assert_eq!(a[at(x, y)], 0.0, "({x}, {y}) sees past the floor");
        assert_eq!(r[at(x, y)], 0.0, "({x}, {y}): nothing behind the scene");
    }
    // The floor's edge, 2/3.64 of the way from the centre to the frame's edge: pixel 5.4
    // from the left, so pixel 5 is partly covered.
    assert!(
        a[at(5, 12)] > 0.0 && a[at(5, 12)] < 1.0,
        "edge: {}",
        a[at(5, 12)]
    );
    let png = image::open(out.with_extension("png")).unwrap();
    assert!(png.color().has_alpha(), "{:?}", png.color());
    let png = png.to_rgba8();
    assert_eq!((png.get_pixel(12, 12)[3], png.get_pixel(0, 0)[3]), (255, 0));
    // `-o NAME.png` alone carries the same alpha.
    let alone = tmp.path().join("alone.png");
    let mut png_args = transparent.clone();
    png_args[2] = s(&alone);
    render(tmp.path(), &png_args).assert_success();
    assert_eq!(image::open(&alone).unwrap().to_rgba8(), png);

    // Without it: the sky behind the floor, no alpha anywhere.
    render(tmp.path(), &args).assert_success();
    let (channels, texts) = read_channels(&out);
    assert!(!channels.contains_key("A"));
    assert_ne!(texts["strata:background"], "transparent");
    assert!(
        channels["R"][at(0, 0)] > 0.5,
        "the sky is seen past the floor"
    );
    assert!(!image::open(out.with_extension("png"))
        .unwrap()
        .color()
        .has_alpha());
}

/// Depth of field: a bright tile (radiance 4, 0.2 wide) seen from 3.5 above with a 20° field
/// of view covers the middle 3.9 of 24 pixels. A lens 0.5 across focused on it (the default
/// focus, the --look-at distance) leaves it as sharp as the pinhole shows it. Focused at 2
/// instead, each of its points spreads over a disk of radius R·|z − f|/z = 0.25 · 1.5 / 3.5
/// on the plane of focus, 3.65 pixels there (a pixel spans 2 · 2 tan 10° / 24): the tile's
/// centre falls to about 4 · 3.9² / (π · 3.65²) = 1.45 above the floor, and light reaches
/// pixels 4.5 from the centre, outside its sharp image. `--f-stop` and the refusals.
#[test]
fn a_thin_lens_blurs_what_is_out_of_focus_and_not_what_is_in_it() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = floor_with_emissive_tile(tmp.path(), "tile.gltf", [1.0, 1.0, 1.0], Some(4.0));
    let view = [
        "--env",
        "none",
        "--look-from",
        "0,4,0",
        "--look-at",
        "0,0.5,0",
        "--up",
        "0,0,-1",
        "--fov",
        "20",
        "--spp",
        "256",
        "--sampler",
        "sobol",
        "--resolution",
        "24x24",
        "--no-png",
    ];
    let shoot = |name: &str, extra: &[&str]| {
        let out = tmp.path().join(name);
        let mut args = vec![s(&scene), "-o", s(&out)];
        args.extend_from_slice(&view);
        args.extend_from_slice(extra);
        render(tmp.path(), &args).assert_success();
        read_exr_rgb(&out).unwrap().2
    };
    let at = |px: &[[f32; 3]], x: usize, y: usize| px[y * 24 + x][1];
    let pinhole = shoot("pinhole.exr", &[]);
    let sharp = shoot("sharp.exr", &["--aperture", "0.5"]);
    let blurred = shoot(
        "blurred.exr",
        &["--aperture", "0.5", "--focus-distance", "2"],
    );
    for (x, y) in [(11, 11), (12, 12)] {
        let (p, s) = (at(&pinhole, x, y), at(&sharp, x, y));
        assert!((p - 4.0).abs() < 0.1, "the tile's centre: {p}");
        assert!(
            (s - p).abs() < 0.05,
            "in focus, ({x}, {y}): {s} against {p}"
        );
    }
    let (p, b) = (at(&pinhole, 12, 12), at(&blurred, 12, 12));
    assert!(
        b > 1.1 && b < 2.2,
        "out of focus, the centre: {b} (pinhole {p})"
    );
    let (p, b) = (at(&pinhole, 16, 11), at(&blurred, 16, 11));
    assert!(p < 0.3, "the floor beside the sharp tile: {p}");
    assert!(
        b > p + 0.1,
        "the blurred tile reaches 4.5 pixels out: {b} against {p}"
    );
    // At 20° on a 36 mm sensor the focal length is 18 mm / tan 10° = 102.1 mm: f/0.2 is a
    // lens 510 mm across, which blurs as --aperture 0.51 does (and unlike 0.5's half).
    let stopped = shoot("f.exr", &["--f-stop", "0.2", "--focus-distance", "2"]);
    let same = shoot("same.exr", &["--aperture", "0.51", "--focus-distance", "2"]);
    let half = shoot("half.exr", &["--aperture", "0.25", "--focus-distance", "2"]);
    let (f, w, h) = (at(&stopped, 12, 12), at(&same, 12, 12), at(&half, 12, 12));
    assert!((f - w).abs() < 0.05, "f/0.2 {f}, 510 mm {w}");
    assert!(
        h > f + 0.5,
        "a lens half as wide blurs less: {h} against {f}"
    );
    // Refusals.
    let refused = |extra: &[&str], words: &[&str]| {
        let mut args = vec![s(&scene), "-o", "x.exr", "--resolution", "8x8"];
        args.extend_from_slice(extra);
        assert_refused(&render(tmp.path(), &args), &format!("{extra:?}"), words);
    };
    refused(
        &["--focus-distance", "2"],
        &["--focus-distance", "--aperture"],
    );
    refused(&["--aperture", "0"], &["--aperture", "positive"]);
    refused(
        &["--aperture", "1", "--f-stop", "2"],
        &["--aperture", "--f-stop"],
    );
}

/// `--look-from`/`--look-at` put the point looked at in the image's centre; `--orbit` turns
/// the camera about +Y through the scene's centre, as placing it there by hand does;
/// `--list-cameras` lists and renders nothing; the camera options' errors name the problem.
#[test]
fn camera_options_aim_the_camera() {
    let tmp = tempfile::tempdir().unwrap();
    // A bright tile (radiance 4, 0.2 wide) 0.5 above the floor's centre, lit by itself alone.
    let scene = floor_with_emissive_tile(tmp.path(), "tile.gltf", [1.0, 1.0, 1.0], Some(4.0));
    let aim = |name: &str, extra: &[&str]| {
        let mut args = vec!["--env", "none"];
        args.extend_from_slice(extra);
        render_small(tmp.path(), &scene, name, &args).1
    };
    let on = aim(
        "on.exr",
        &["--look-from", "1,4,1", "--look-at", "0,0.5,0", "--fov", "5"],
    );
    assert!(
        centre(&on, 24) > 3.0,
        "the tile at the centre: {}",
        centre(&on, 24)
    );
    let off = aim(
        "off.exr",
        &["--look-from", "1,4,1", "--look-at", "1.5,0,0", "--fov", "5"],
    );
    assert!(
        centre(&off, 24) < 1.0,
        "the floor at the centre: {}",
        centre(&off, 24)
    );

    // The scene's centre is (0, 0.25, 0); an eighth of a turn counter-clockwise seen from
    // above carries (3, 1, 0) to (3/√2, 1, −3/√2), from which the square floor shows a
    // corner instead of a side.
    let orbited = aim(
        "orbit.exr",
        &[
            "--look-from",
            "3,1,0",
            "--look-at",
            "0,0.25,0",
            "--orbit",
            "45",
        ],
    );
    let placed = aim(
        "placed.exr",
        &[
            "--look-from",
            "2.1213203,1,-2.1213203",
            "--look-at",
            "0,0.25,0",
        ],
    );
    let unturned = aim(
        "unturned.exr",
        &["--look-from", "3,1,0", "--look-at", "0,0.25,0"],
    );
    let diff = |a: &[[f32; 3]], b: &[[f32; 3]]| {
        a.iter()
            .zip(b)
            .map(|(p, q)| (0..3).map(|c| (p[c] - q[c]).abs() as f64).sum::<f64>())
            .sum::<f64>()
            / a.len() as f64
    };
    let (turned, control) = (diff(&orbited, &placed), diff(&unturned, &placed));
    assert!(
        turned < 0.2 * control,
        "orbited {turned}, unturned {control}"
    );

    // --list-cameras prints the file's one camera and writes nothing.
    let listed = tmp.path().join("listed");
    std::fs::create_dir(&listed).unwrap();
    let run = render(&listed, &[s(&scene), "--list-cameras"]);
    run.assert_success();
    assert!(
        run.stdout
            .starts_with("0: perspective, 45.8° vertical field of view, at (0, 3, 0)"),
        "{}",
        run.stdout
    );
    assert_entries(&listed, &[]);

    for (args, words) in [
        (
            &["--camera", "2"][..],
            &["--camera 2: no such camera", "it has 0: perspective"][..],
        ),
        (
            &["--look-from", "1,1,1", "--look-at", "1,1,1"],
            &["two different points"],
        ),
        (
            &["--look-from", "0,3,0", "--look-at", "0,0,0"],
            &["up direction"],
        ),
        (&["--up", "0,0,1"], &["--up", "--look-from"]),
        (&["--fov", "200"], &["--fov", "between 0 and 180"]),
    ] {
        let mut all = vec![s(&scene), "-o", "x.exr"];
        all.extend_from_slice(args);
        let run = render(tmp.path(), &all);
        assert!(!run.status.success(), "{args:?}");
        assert!(
            words.iter().all(|w| run.stderr.contains(w)),
            "{args:?}: {}",
            run.stderr
        );
    }
}

/// `-o` by extension: a `.png` or `.jpg` is the image through the view transform alone (no
/// EXR beside it), the same pixels as the EXR run's preview; what needs an EXR is refused.
#[test]
fn the_output_format_follows_the_extension() {
    let tmp = tempfile::tempdir().unwrap();
    let wall = ao_wall();
    let base = [s(&wall), "--resolution", "24x16", "--spp", "4"];
    let run_to = |name: &str, extra: &[&str]| {
        let mut args = base.to_vec();
        args.extend_from_slice(&["-o", name]);
        args.extend_from_slice(extra);
        render(tmp.path(), &args)
    };
    run_to("a.exr", &[]).assert_success();
    run_to("b.png", &[]).assert_success();
    run_to("c.jpg", &[]).assert_success();
    assert_entries(tmp.path(), &["a.exr", "a.png", "b.png", "c.jpg"]);
    // The PNG output is the EXR run's preview, byte for byte (same seed, same view).
    assert_eq!(
        std::fs::read(tmp.path().join("a.png")).unwrap(),
        std::fs::read(tmp.path().join("b.png")).unwrap()
    );
    let jpeg = std::fs::read(tmp.path().join("c.jpg")).unwrap();
    assert_eq!(
        &jpeg[..3],
        &[0xFF, 0xD8, 0xFF],
        "a JPEG's start-of-image marker"
    );
    let decoded = image::load_from_memory(&jpeg).unwrap();
    assert_eq!((decoded.width(), decoded.height()), (24, 16));

    for (name, extra, words) in [
        ("d.tif", &[][..], &["d.tif", ".exr", ".png", ".jpg"][..]),
        (
            "e.png",
            &["--passes", "depth"],
            &["e.png", "--passes", ".exr"],
        ),
        (
            "f.png",
            &["--shard", "0/2"],
            &["f.png", "farm part", ".exr"],
        ),
    ] {
        let run = run_to(name, extra);
        assert!(!run.status.success(), "{name}");
        assert_one_error_line(&run.stderr, words);
    }
    assert_entries(tmp.path(), &["a.exr", "a.png", "b.png", "c.jpg"]);
}

/// A resolution whose aspect ratio is not the camera's gets a note saying what changes; the
/// camera's own aspect ratio gets none.
#[test]
fn a_resolution_unlike_the_cameras_aspect_is_noted() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = repo_path("scenes/cornell-box.gltf");
    let run_at = |size: &str| {
        let out = tmp.path().join(format!("{size}.exr"));
        let run = render(
            tmp.path(),
            &[s(&scene), "-o", s(&out), "--resolution", size, "--spp", "1"],
        );
        run.assert_success();
        run.stderr
    };
    let wide = run_at("32x16");
    assert!(
        wide.contains("aspect ratio") && wide.contains("shows more at the sides"),
        "{wide}"
    );
    assert!(!run_at("16x16").contains("aspect ratio"));
}

/// The EXR header carries OpenEXR's `worldToCamera` (Imath's row-vector convention, p·M) and
/// the projection: ao-wall's camera stands at (1, 1, 0) looking straight down, so it maps
/// to the origin and the point one unit below it to (0, 0, −1), one unit ahead.
#[test]
fn the_header_records_the_camera() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("wall.exr");
    let run = render(
        tmp.path(),
        &[
            s(&ao_wall()),
            "-o",
            s(&out),
            "--resolution",
            "8x8",
            "--spp",
            "1",
        ],
    );
    run.assert_success();
    let meta = exr::meta::MetaData::read_from_file(&out, false).unwrap();
    let header = &meta.headers[0];
    let find = |name: &str| {
        let key = exr::meta::attribute::Text::from(name);
        (header.own_attributes.other.get(&key))
            .or_else(|| header.shared_attributes.other.get(&key))
            .cloned()
    };
    let m = header
        .own_attributes
        .world_to_camera
        .expect("worldToCamera in the header");
    let map = |p: [f32; 3]| -> [f32; 3] {
        let v = [p[0], p[1], p[2], 1.0];
        [0, 1, 2].map(|j| (0..4).map(|i| v[i] * m[i * 4 + j]).sum::<f32>())
    };
    let near = |a: [f32; 3], b: [f32; 3]| (0..3).all(|k| (a[k] - b[k]).abs() < 1e-5);
    assert!(
        near(map([1.0, 1.0, 0.0]), [0.0, 0.0, 0.0]),
        "{:?}",
        map([1.0, 1.0, 0.0])
    );
    assert!(
        near(map([1.0, 0.0, 0.0]), [0.0, 0.0, -1.0]),
        "{:?}",
        map([1.0, 0.0, 0.0])
    );
    match find("strata:projection") {
        Some(exr::meta::attribute::AttributeValue::Text(t)) => {
            assert!(t.to_string().starts_with("perspective"), "{t}")
        }
        other => panic!("strata:projection: {other:?}"),
    }
    // worldToNDC, with ao-wall's 8x8 image and --fov 90 (tan 45° = 1, aspect 1): a point c
    // in camera space lands at x = ½ + ½·c.x/(−c.z), y = ½ − ½·c.y/(−c.z).
    let out = tmp.path().join("ndc.exr");
    let wall = ao_wall();
    let args = [
        s(&wall),
        "-o",
        s(&out),
        "--resolution",
        "8x8",
        "--spp",
        "1",
        "--fov",
        "90",
    ];
    render(tmp.path(), &args).assert_success();
    let header = exr::meta::MetaData::read_from_file(&out, false)
        .unwrap()
        .headers[0]
        .clone();
    let n = (header.own_attributes)
        .world_to_normalized_device
        .expect("worldToNDC in the header");
    let ndc = |p: [f32; 3]| -> [f32; 2] {
        let v = [p[0], p[1], p[2], 1.0];
        let q = [0, 1, 3].map(|j| (0..4).map(|i| v[i] * n[i * 4 + j]).sum::<f32>());
        [q[0] / q[2], q[1] / q[2]]
    };
    for p in [[1.0, 0.0, 0.0], [1.3, -0.5, 0.2], [0.2, 0.4, -0.7]] {
        let c = map(p);
        let want = [0.5 + 0.5 * c[0] / -c[2], 0.5 - 0.5 * c[1] / -c[2]];
        let got = ndc(p);
        assert!(
            (got[0] - want[0]).abs() < 1e-5 && (got[1] - want[1]).abs() < 1e-5,
            "{p:?}: {got:?} against {want:?}"
        );
    }
    assert!(
        (ndc([1.0, 0.0, 0.0])[0] - 0.5).abs() < 1e-6,
        "straight ahead: the centre"
    );
}
