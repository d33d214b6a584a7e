//! Denoising with Intel Open Image Denoise (`--denoise`, `render denoise`), which strata
//! loads at run time. The refusal and the search order are checked in every run, in an
//! environment the test makes (OIDN_DIR, HOME and LD_LIBRARY_PATH set or removed). The
//! denoiser's own tests run where the library loads for this process (OIDN_DIR,
//! ~/.cache/strata/oidn-2.5.1 or the loader's path; `tools/oidn-prefix.sh` fetches it) and
//! otherwise print a SKIPPED line, unless STRATA_REQUIRE_OIDN=1, where they fail: CI's
//! `denoise` leg sets it (`OIDN_DIR=$(tools/oidn-prefix.sh) STRATA_REQUIRE_OIDN=1 cargo test
//! --release --test denoise`), so it never skips them.

mod common;

use std::path::{Path, PathBuf};

use common::*;

/// Says that `test` did not run, on stderr itself: the test harness captures `eprintln!`
/// of a passing test, and a skip must not pass unseen.
fn skipped(test: &str, why: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "\n*** SKIPPED {test}: {why} ***\n");
}

/// Whether the denoiser's tests can run here; false (after a loud line) where the library
/// cannot be loaded, a failure instead where STRATA_REQUIRE_OIDN=1.
fn oidn_here(test: &str) -> bool {
    let Err(e) = strata::denoise::check() else {
        return true;
    };
    if std::env::var_os("STRATA_REQUIRE_OIDN").is_some_and(|v| v == "1") {
        panic!("STRATA_REQUIRE_OIDN=1 and Open Image Denoise cannot be loaded: {e}");
    }
    skipped(
        test,
        &format!("Open Image Denoise cannot be loaded here, so this test did not run ({e}). Run tools/oidn-prefix.sh to have it; STRATA_REQUIRE_OIDN=1 makes this a failure"),
    );
    false
}

/// Whether the system's loader cache lists Open Image Denoise (then no environment can hide it).
fn oidn_on_the_system() -> bool {
    ["/sbin/ldconfig", "/usr/sbin/ldconfig", "ldconfig"]
        .iter()
        .find_map(|l| std::process::Command::new(l).arg("-p").output().ok())
        .is_some_and(|o| String::from_utf8_lossy(&o.stdout).contains("libOpenImageDenoise.so"))
}

/// Runs `render` with OIDN_DIR and HOME set as given and LD_LIBRARY_PATH removed.
fn render_with(dir: &Path, oidn_dir: &Path, home: &Path, args: &[&str]) -> Run {
    let quote = |p: &Path| format!("'{}'", s(p).replace('\'', r"'\''"));
    let prefix = format!(
        "export OIDN_DIR={} HOME={}; unset LD_LIBRARY_PATH",
        quote(oidn_dir),
        quote(home)
    );
    render_under_shell(dir, &prefix, args)
}

#[test]
fn without_the_library_denoising_is_refused_plainly() {
    if oidn_on_the_system() {
        skipped(
            "without_the_library_denoising_is_refused_plainly",
            "Open Image Denoise is installed system-wide (ldconfig -p), where no environment hides it",
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // An OIDN_DIR that exists but holds no library, and a HOME without the default prefix.
    let bogus = dir.path().join("bogus-oidn");
    let home = dir.path().join("home");
    std::fs::create_dir_all(&bogus).unwrap();
    std::fs::create_dir_all(&home).unwrap();
    let scene = repo_path("scenes/cornell-box.gltf");
    let out = dir.path().join("out.exr");
    let run = render_with(
        dir.path(),
        &bogus,
        &home,
        &[s(&scene), "--spp", "1", "--denoise", "-o", s(&out)],
    );
    assert!(!run.status.success());
    // What was looked for, where, and the command that gets it.
    let bogus_lib = bogus.join("lib/libOpenImageDenoise.so.2");
    let home_lib = home.join(".cache/strata/oidn-2.5.1/lib/libOpenImageDenoise.so.2");
    let words = [
        "Open Image Denoise 2",
        s(&bogus_lib),
        s(&home_lib),
        "loader's search path",
        "tools/oidn-prefix.sh",
        "OIDN_DIR",
    ];
    let line = assert_one_error_line(&run.stderr, &words);
    assert!(line.starts_with("error: --denoise:"), "{line}");
    assert!(
        !out.exists(),
        "nothing is rendered when the denoiser is missing"
    );

    // `render denoise` says the same, before looking at its input.
    let run = render_with(dir.path(), &bogus, &home, &["denoise", s(&out)]);
    assert!(!run.status.success());
    let same = assert_one_error_line(&run.stderr, &words);
    assert_eq!(
        same.strip_prefix("error: "),
        line.strip_prefix("error: --denoise: "),
        "one message for both commands"
    );
}

#[test]
fn a_broken_library_in_oidn_dir_is_named_not_passed_over() {
    let dir = tempfile::tempdir().unwrap();
    let bogus = dir.path().join("broken-oidn");
    std::fs::create_dir_all(bogus.join("lib")).unwrap();
    let lib = bogus.join("lib/libOpenImageDenoise.so.2");
    std::fs::write(&lib, b"this is not a shared library\n").unwrap();
    // The default prefix, where there is one, comes after OIDN_DIR and must not be used.
    let home = PathBuf::from(std::env::var_os("HOME").unwrap_or_default());
    let scene = repo_path("scenes/cornell-box.gltf");
    let out = dir.path().join("out.exr");
    let run = render_with(
        dir.path(),
        &bogus,
        &home,
        &[s(&scene), "--spp", "1", "--denoise", "-o", s(&out)],
    );
    assert!(!run.status.success(), "{}", run.stdout);
    assert_one_error_line(
        &run.stderr,
        &[
            s(&lib),
            "OIDN_DIR",
            "cannot be loaded",
            "tools/oidn-prefix.sh",
        ],
    );
    assert!(!out.exists());
}

#[test]
fn an_oidn_dir_without_the_library_passes_to_the_default_prefix() {
    if !oidn_here("an_oidn_dir_without_the_library_passes_to_the_default_prefix") {
        return;
    }
    // A prefix holding the library, as OIDN_DIR or the default prefix names it here.
    let home = std::env::var_os("HOME").map(PathBuf::from);
    let prefix = [
        std::env::var_os("OIDN_DIR").map(PathBuf::from),
        home.map(|h| h.join(".cache/strata/oidn-2.5.1")),
    ]
    .into_iter()
    .flatten()
    .find(|p| p.join("lib/libOpenImageDenoise.so.2").exists());
    let Some(prefix) = prefix else {
        if std::env::var_os("STRATA_REQUIRE_OIDN").is_some_and(|v| v == "1") {
            panic!("STRATA_REQUIRE_OIDN=1 and neither OIDN_DIR nor ~/.cache/strata/oidn-2.5.1 holds lib/libOpenImageDenoise.so.2");
        }
        skipped(
            "an_oidn_dir_without_the_library_passes_to_the_default_prefix",
            "the library loads from the loader's path, not from a prefix this test can point at",
        );
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let bogus = dir.path().join("empty-oidn");
    std::fs::create_dir_all(&bogus).unwrap();
    // A HOME whose default prefix is the real one.
    let home = dir.path().join("home");
    std::fs::create_dir_all(home.join(".cache/strata")).unwrap();
    std::os::unix::fs::symlink(&prefix, home.join(".cache/strata/oidn-2.5.1")).unwrap();
    let scene = repo_path("scenes/cornell-box.gltf");
    let out = dir.path().join("out.exr");
    let args = [
        s(&scene),
        "--spp",
        "2",
        "--resolution",
        "64x64",
        "--denoise",
        "--no-png",
        "-o",
        s(&out),
    ];
    let run = render_with(dir.path(), &bogus, &home, &args);
    run.assert_success();
    let (c, attrs) = read_channels(&out);
    assert!(c.contains_key("noisy.R"), "the image was denoised");
    let about = &attrs["strata:denoiser"];
    assert!(about.contains("Open Image Denoise 2."), "{about}");
    // Control: the same render with that HOME's prefix gone is refused (where the system has
    // no OIDN of its own), so the success above came from the default prefix.
    if !oidn_on_the_system() {
        std::fs::remove_file(home.join(".cache/strata/oidn-2.5.1")).unwrap();
        let run = render_with(dir.path(), &bogus, &home, &args);
        assert!(!run.status.success());
        assert_one_error_line(&run.stderr, &["tools/oidn-prefix.sh"]);
    }
}

mod with_oidn {
    use std::collections::HashMap;
    use std::path::Path;

    use super::*;

    /// The Cornell box as its Mitsuba reference was rendered, at `spp`.
    fn cornell(dir: &Path, name: &str, spp: u32, extra: &[&str]) -> std::path::PathBuf {
        let scene = repo_path("scenes/cornell-box.gltf");
        let out = dir.join(name);
        let spp = spp.to_string();
        let mut args = vec![
            s(&scene),
            "--integrator",
            "path",
            "--max-depth",
            "8",
            "--energy-compensation",
            "off",
            "--resolution",
            "160x160",
            "--spp",
            &spp,
            "--no-png",
            "-o",
            s(&out),
        ];
        args.extend_from_slice(extra);
        render(dir, &args).assert_success();
        out
    }

    /// The three channels `names` of `c`, interleaved.
    fn rgb(c: &HashMap<String, Vec<f32>>, names: [&str; 3]) -> Vec<f32> {
        let ch: Vec<&Vec<f32>> = names
            .iter()
            .map(|n| c.get(*n).unwrap_or_else(|| panic!("no channel {n}")))
            .collect();
        (0..ch[0].len())
            .flat_map(|i| [ch[0][i], ch[1][i], ch[2][i]])
            .collect()
    }

    fn reference() -> Vec<f32> {
        let (c, _) = read_channels(&repo_path("scenes/references/cornell-box.path.exr"));
        rgb(&c, ["R", "G", "B"])
    }

    /// RMSE against `reference` over the pixels whose reference is below 2 in every channel
    /// (the surfaces: the light's radiance is about 100), and the ratio of means there.
    fn surface_error(image: &[f32], reference: &[f32]) -> (f64, f64) {
        let (mut se, mut n, mut sum, mut sum_ref) = (0.0, 0usize, 0.0, 0.0);
        for (p, r) in image.chunks(3).zip(reference.chunks(3)) {
            if r.iter().all(|&v| v < 2.0) {
                for k in 0..3 {
                    se += (p[k] as f64 - r[k] as f64).powi(2);
                    sum += p[k] as f64;
                    sum_ref += r[k] as f64;
                }
                n += 3;
            }
        }
        ((se / n as f64).sqrt(), sum / sum_ref)
    }

    /// `image` (160 × 160 RGB) moved one pixel to the right, the first column repeated.
    fn shifted(image: &[f32]) -> Vec<f32> {
        let w = 160;
        let mut out = image.to_vec();
        for y in 0..w {
            for x in (1..w).rev() {
                for k in 0..3 {
                    out[(y * w + x) * 3 + k] = image[(y * w + x - 1) * 3 + k];
                }
            }
        }
        out
    }

    #[test]
    fn the_denoised_cornell_box_is_closer_to_its_reference() {
        if !oidn_here("the_denoised_cornell_box_is_closer_to_its_reference") {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let out = cornell(dir.path(), "cb.exr", 16, &["--denoise"]);
        let (c, attrs) = read_channels(&out);
        let reference = reference();
        let denoised = rgb(&c, ["R", "G", "B"]);
        let noisy = rgb(&c, ["noisy.R", "noisy.G", "noisy.B"]);
        let (e_noisy, m_noisy) = surface_error(&noisy, &reference);
        let (e_denoised, m_denoised) = surface_error(&denoised, &reference);
        eprintln!(
            "surfaces at 16 spp: RMSE noisy {e_noisy:.5}, denoised {e_denoised:.5} ({:.2}×); mean ratio noisy {m_noisy:.4}, denoised {m_denoised:.4}",
            e_denoised / e_noisy
        );
        // Measured: 0.0423 → 0.0180 (0.43×); the mean within 0.4%.
        assert!(
            e_denoised < 0.6 * e_noisy,
            "denoising should cut the surfaces' RMSE by 40% or more"
        );
        assert!(
            (m_denoised - 1.0).abs() < 0.01,
            "denoising moved the mean by {m_denoised}"
        );
        // Negative controls: the same image one pixel off fails the RMSE bound, and 3%
        // darker the mean's.
        let (e_shifted, _) = surface_error(&shifted(&denoised), &reference);
        let darker: Vec<f32> = denoised.iter().map(|v| v * 0.97).collect();
        let (_, m_darker) = surface_error(&darker, &reference);
        eprintln!("negative controls: shifted one pixel RMSE {e_shifted:.5}; 3% darker mean ratio {m_darker:.4}");
        assert!(e_shifted > 0.6 * e_noisy);
        assert!((m_darker - 1.0).abs() > 0.01);
        // The light's own pixels keep their mean (OIDN rings at its edge; BENCHMARKS.md).
        let light = |img: &[f32]| -> f64 {
            let v: Vec<f64> = img
                .chunks(3)
                .zip(reference.chunks(3))
                .filter(|(_, r)| r.iter().all(|&v| v >= 2.0))
                .map(|(p, _)| p.iter().map(|&x| x as f64).sum::<f64>())
                .collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        let ratio = light(&denoised) / light(&reference);
        assert!(
            (ratio - 1.0).abs() < 0.02,
            "the light's mean moved: {ratio}"
        );
        let about = &attrs["strata:denoiser"];
        assert!(about.contains("Open Image Denoise 2."), "{about}");
        assert!(about.contains("prefiltered"), "{about}");
    }

    #[test]
    fn the_noisy_layer_is_the_render_without_denoising() {
        if !oidn_here("the_noisy_layer_is_the_render_without_denoising") {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let denoised = cornell(dir.path(), "dn.exr", 4, &["--denoise"]);
        let plain = cornell(dir.path(), "raw.exr", 4, &["--passes", "albedo,normal"]);
        let (d, d_attrs) = read_channels(&denoised);
        let (p, _) = read_channels(&plain);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for k in ["R", "G", "B"] {
            assert_eq!(bits(&d[&format!("noisy.{k}")]), bits(&p[k]), "noisy.{k}");
            assert_ne!(bits(&d[k]), bits(&p[k]), "{k} should be denoised");
        }
        for k in [
            "albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y", "normal.Z",
        ] {
            assert_eq!(bits(&d[k]), bits(&p[k]), "{k}");
        }
        assert_eq!(d_attrs["strata:passes"], "albedo,normal");
    }

    #[test]
    fn denoising_gives_the_same_bits_on_any_thread_count() {
        if !oidn_here("denoising_gives_the_same_bits_on_any_thread_count") {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let one = cornell(dir.path(), "t1.exr", 4, &["--denoise", "--threads", "1"]);
        let two = cornell(dir.path(), "t2.exr", 4, &["--denoise", "--threads", "2"]);
        let (a, _) = read_channels(&one);
        let (b, _) = read_channels(&two);
        for k in ["R", "G", "B"] {
            let same = a[k]
                .iter()
                .zip(&b[k])
                .all(|(x, y)| x.to_bits() == y.to_bits());
            assert!(same, "{k} differs between 1 and 2 threads");
        }
    }

    #[test]
    fn the_denoise_subcommand_redoes_what_the_render_did() {
        if !oidn_here("the_denoise_subcommand_redoes_what_the_render_did") {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let denoised = cornell(dir.path(), "dn.exr", 4, &["--denoise"]);
        let plain = cornell(dir.path(), "raw.exr", 4, &["--passes", "albedo,normal"]);
        let after = dir.path().join("after.exr");
        let run = render(dir.path(), &["denoise", s(&plain), "-o", s(&after)]);
        run.assert_success();
        assert!(run.stderr.is_empty(), "no warnings: {}", run.stderr);
        assert!(
            dir.path().join("after.png").exists(),
            "the preview is written"
        );
        let (a, a_attrs) = read_channels(&after);
        let (d, _) = read_channels(&denoised);
        let (_, p_attrs) = read_channels(&plain);
        let mut names: Vec<_> = a.keys().collect();
        names.sort();
        let mut expected: Vec<_> = d.keys().collect();
        expected.sort();
        assert_eq!(names, expected, "the same layers as --denoise writes");
        for k in ["R", "G", "B", "noisy.R", "albedo.G", "normal.Z"] {
            let same = a[k]
                .iter()
                .zip(&d[k])
                .all(|(x, y)| x.to_bits() == y.to_bits());
            assert!(same, "{k}: render denoise differs from --denoise");
        }
        // The input's header is kept, and the denoising is recorded.
        assert_eq!(a_attrs["strata:scene"], p_attrs["strata:scene"]);
        assert!(a_attrs["strata:denoiser"].contains("Open Image Denoise"));
        assert_eq!(a_attrs["strata:denoised_from"], s(&plain));

        // An image denoised before is denoised again from its noisy layer: the same bits.
        let again = dir.path().join("again.exr");
        let run = render(
            dir.path(),
            &["denoise", s(&after), "-o", s(&again), "--no-png"],
        );
        run.assert_success();
        assert!(run.stdout.contains("denoised again"), "{}", run.stdout);
        let (g, _) = read_channels(&again);
        for k in ["R", "G", "B", "noisy.R", "noisy.G", "noisy.B"] {
            let same = g[k]
                .iter()
                .zip(&a[k])
                .all(|(x, y)| x.to_bits() == y.to_bits());
            assert!(same, "{k}: denoising twice should change nothing");
        }
        assert!(!g.contains_key("noisy.noisy.R"));

        // Without the prefilter the result differs (the aux images go in as rendered).
        let fast = dir.path().join("fast.exr");
        let run = render(
            dir.path(),
            &[
                "denoise",
                s(&plain),
                "-o",
                s(&fast),
                "--denoise-prefilter",
                "off",
                "--no-png",
            ],
        );
        run.assert_success();
        let (f, f_attrs) = read_channels(&fast);
        assert_ne!(f["R"], a["R"]);
        assert!(f_attrs["strata:denoiser"].contains("as rendered"));
    }

    #[test]
    fn the_denoise_subcommand_says_what_an_input_lacks() {
        if !oidn_here("the_denoise_subcommand_says_what_an_input_lacks") {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        // A beauty without albedo and normal: denoised alone, with a warning.
        let bare = cornell(dir.path(), "bare.exr", 4, &[]);
        let out = dir.path().join("out.exr");
        let run = render(
            dir.path(),
            &["denoise", s(&bare), "-o", s(&out), "--no-png"],
        );
        run.assert_success();
        assert!(
            run.stderr.contains("no albedo and normal layers"),
            "{}",
            run.stderr
        );
        let (c, attrs) = read_channels(&out);
        assert!(c.contains_key("noisy.R"));
        assert!(attrs["strata:denoiser"].contains("beauty only"));

        // Not an EXR: one error line naming the file.
        let scene = repo_path("scenes/cornell-box.gltf");
        let run = render(dir.path(), &["denoise", s(&scene), "-o", s(&out)]);
        assert!(!run.status.success());
        assert_one_error_line(&run.stderr, &["cornell-box.gltf", "EXR"]);

        // An EXR without R, G, B: one error line listing what it has.
        let depth_only = dir.path().join("depth.exr");
        {
            use exr::prelude::*;
            let channel = AnyChannel::new("depth.Z", FlatSamples::F32(vec![1.0; 4]));
            let image =
                Image::from_channels((2, 2), AnyChannels::sort(SmallVec::from_vec(vec![channel])));
            image.write().to_file(&depth_only).unwrap();
        }
        let run = render(dir.path(), &["denoise", s(&depth_only), "-o", s(&out)]);
        assert!(!run.status.success());
        assert_one_error_line(&run.stderr, &["depth.exr", "no R, G, B", "depth.Z"]);
    }

    /// A transparent render denoised keeps its alpha: `--denoise` writes the EXR's `A` and
    /// an RGBA preview, and `render denoise` of it does too, its `A` unchanged.
    #[test]
    fn denoising_a_transparent_render_keeps_its_alpha() {
        if !oidn_here("denoising_a_transparent_render_keeps_its_alpha") {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let scene = repo_path("scenes/suzanne.gltf");
        let out = dir.path().join("t.exr");
        let args = [
            s(&scene),
            "-o",
            s(&out),
            "--resolution",
            "32x32",
            "--spp",
            "8",
            "--background",
            "transparent",
            "--denoise",
        ];
        render(dir.path(), &args).assert_success();
        let (c, _) = read_channels(&out);
        let alpha = c["A"].clone();
        assert!(alpha.contains(&0.0) && alpha.contains(&1.0));
        let png = image::open(out.with_extension("png")).unwrap();
        assert!(png.color().has_alpha(), "{:?}", png.color());
        let again = dir.path().join("again.exr");
        let run = render(dir.path(), &["denoise", s(&out), "-o", s(&again)]);
        run.assert_success();
        let (c2, _) = read_channels(&again);
        assert_eq!(c2["A"], alpha, "the alpha passes through unchanged");
        let preview = image::open(again.with_extension("png")).unwrap().to_rgba8();
        let corner = preview.get_pixel(0, 0)[3];
        assert_eq!(
            corner,
            (alpha[0] * 255.0 + 0.5) as u8,
            "the preview's alpha"
        );
        assert!(preview.pixels().any(|p| p[3] == 255) && preview.pixels().any(|p| p[3] == 0));
    }
}
