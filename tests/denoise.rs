//! Denoising with Intel Open Image Denoise (`--denoise`, `render denoise`), in a build with
//! the `denoise` feature (CI's `denoise` leg: `OIDN_DIR=$(tools/oidn-prefix.sh) cargo test
//! --release --features denoise --test denoise`). Without the feature, the one test here
//! checks that both commands say plainly what the build lacks.

mod common;

use common::*;

#[cfg(not(feature = "denoise"))]
#[test]
fn without_the_feature_denoising_is_refused_plainly() {
    eprintln!(
        "NOTE: built without the `denoise` feature: the denoiser's own tests are not compiled; CI runs them in its `denoise` leg (OIDN_DIR=$(tools/oidn-prefix.sh) cargo test --release --features denoise --test denoise)"
    );
    let dir = tempfile::tempdir().unwrap();
    let scene = repo_path("scenes/cornell-box.gltf");
    let out = dir.path().join("out.exr");
    let run = render(
        dir.path(),
        &[s(&scene), "--spp", "1", "--denoise", "-o", s(&out)],
    );
    assert!(!run.status.success());
    assert_one_error_line(
        &run.stderr,
        &["--denoise", "no denoiser", "--features denoise"],
    );
    assert!(
        !out.exists(),
        "nothing is rendered when the denoiser is missing"
    );

    let run = render(dir.path(), &["denoise", s(&out)]);
    assert!(!run.status.success());
    assert_one_error_line(&run.stderr, &["no denoiser", "--features denoise"]);
}

#[cfg(feature = "denoise")]
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
}
