//! A farm's shards through the command line: `render --shard I/N` on any thread count, then
//! `render merge`, gives the one-machine image bit for bit, every pass included; `merge`
//! refuses parts that do not belong together and names what is missing.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use common::{idiff_identical, render, repo_path, s};
use exr::prelude::{read_all_flat_layers_from_file, FlatSamples};

/// Every channel of an EXR's first layer as raw bits, by name.
fn channels(path: &Path) -> BTreeMap<String, Vec<u32>> {
    let image =
        read_all_flat_layers_from_file(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let layer = &image.layer_data[0];
    (layer.channel_data.list.iter())
        .map(|c| {
            let bits = match &c.sample_data {
                FlatSamples::F32(v) => v.iter().map(|f| f.to_bits()).collect(),
                FlatSamples::U32(v) => v.clone(),
                FlatSamples::F16(v) => v.iter().map(|h| h.to_bits() as u32).collect(),
            };
            (c.name.to_string(), bits)
        })
        .collect()
}

/// Renders `args` whole, then in `n` shards on 1, 2, 1, … threads, merges them, and checks
/// the merged image equals the whole one, channel for channel and bit for bit.
fn shards_merge_to_the_whole(dir: &Path, name: &str, args: &[&str], counts: &[u32]) {
    let whole = dir.join(format!("{name}.exr"));
    let mut all = args.to_vec();
    all.extend(["-o", s(&whole), "--no-png", "--threads", "2"]);
    render(dir, &all).assert_success();
    let want = channels(&whole);
    for &n in counts {
        let parts = dir.join(format!("{name}-{n}"));
        std::fs::create_dir(&parts).unwrap();
        let out = parts.join("part.exr");
        for i in 0..n {
            let shard = format!("{i}/{n}");
            let threads = (1 + i % 2).to_string();
            let mut all = args.to_vec();
            all.extend(["-o", s(&out), "--shard", &shard, "--threads", &threads]);
            let run = render(dir, &all);
            run.assert_success();
            // The README's split: shard I of N takes samples ⌊spp·I/N⌋ to ⌊spp·(I+1)/N⌋ − 1.
            let spp: u32 = args_spp(args).parse().unwrap();
            let (a, b) = (spp * i / n, spp * (i + 1) / n);
            assert!(
                run.stdout
                    .contains(&format!("samples {a}..{b} of {spp} spp,")),
                "{}",
                run.stdout
            );
        }
        let mut files: Vec<PathBuf> = std::fs::read_dir(&parts)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        files.sort();
        assert_eq!(
            files.len(),
            n as usize,
            "one partial file per shard, no PNG"
        );
        let merged = dir.join(format!("{name}-{n}.exr"));
        let mut merge = vec!["merge", "-o", s(&merged), "--no-png"];
        // Any order.
        merge.extend(files.iter().rev().map(|f| s(f)));
        render(dir, &merge).assert_success();
        let got = channels(&merged);
        assert_eq!(
            got.keys().collect::<Vec<_>>(),
            want.keys().collect::<Vec<_>>(),
            "{name}, {n} shards: the same channels"
        );
        for (channel, bits) in &want {
            let differ = (bits.iter().zip(&got[channel]))
                .filter(|(a, b)| a != b)
                .count();
            assert_eq!(
                differ, 0,
                "{name}, {n} shards: {channel} differs in {differ} pixels"
            );
        }
        idiff_identical(&whole, &merged);
        if n == 7 {
            // Controls: each part holds an image of its own samples, not the whole one; and
            // averaging the parts' beauties by their sample counts in float (a merge by
            // weighted mean, as renderers offer) misses the whole image's bits.
            let spp: f64 = args_spp(args).parse().unwrap();
            let parts: Vec<_> = files.iter().map(|f| channels(f)).collect();
            let counts: Vec<f64> = (parts.iter()).map(|p| p["exact.N"][0] as f64).collect();
            assert_eq!(counts.iter().sum::<f64>(), spp);
            let mut own = 0;
            let mut averaged_differ = 0;
            for c in ["R", "G", "B"] {
                let whole = &want[c];
                own += (parts[0][c].iter().zip(whole))
                    .filter(|(a, b)| a != b)
                    .count();
                for (i, &w) in whole.iter().enumerate() {
                    let mean: f32 = (parts.iter().zip(&counts))
                        .map(|(p, &k)| f32::from_bits(p[c][i]) * (k / spp) as f32)
                        .sum();
                    averaged_differ += (mean.to_bits() != w) as usize;
                }
            }
            assert!(own > 0, "{name}: a part's beauty equals the whole image's");
            assert!(
                averaged_differ > 0,
                "{name}: a weighted float average of the parts matched the whole image too"
            );
            eprintln!("{name}, 7 shards: a weighted float average of the parts' beauties differs from the whole image in {averaged_differ} pixel channels; the merge in none");
        }
    }
}

fn args_spp<'a>(args: &[&'a str]) -> &'a str {
    let i = args.iter().position(|a| *a == "--spp").unwrap();
    args[i + 1]
}

#[test]
fn ao_shards_merge_to_the_one_machine_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo_path("scenes/flight-helmet.gltf");
    let args = [
        s(&scene),
        "--integrator",
        "ao",
        "--spp",
        "13",
        "--resolution",
        "48x40",
    ];
    shards_merge_to_the_whole(dir.path(), "ao", &args, &[1, 2, 3, 7]);
}

#[test]
fn path_shards_under_an_environment_map_merge_to_the_one_machine_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo_path("scenes/suzanne.gltf");
    let env = repo_path("scenes/env/studio_small_05_1k/studio_small_05_1k.hdr");
    let args = [
        s(&scene),
        "--env",
        s(&env),
        "--env-rotate",
        "30",
        "--integrator",
        "path",
        "--spp",
        "11",
        "--resolution",
        "40x30",
    ];
    shards_merge_to_the_whole(dir.path(), "path", &args, &[1, 2, 3, 7]);
}

#[test]
fn shards_with_every_pass_merge_to_the_one_machine_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo_path("scenes/cornell-box.gltf");
    let args = [
        s(&scene),
        "--spp",
        "10",
        "--resolution",
        "40x40",
        "--seed",
        "5",
        "--passes",
        "albedo,normal,depth,position,uv,object_id,mesh_id,material_id",
        "--background",
        "transparent",
    ];
    shards_merge_to_the_whole(dir.path(), "passes", &args, &[1, 2, 3, 7]);
}

/// Renders shard `shard` of the Cornell box at 24×24 into `dir/parts/NAME`, with `extra`
/// options.
fn shard(dir: &Path, name: &str, shard: &str, extra: &[&str]) -> PathBuf {
    shard_of(
        dir,
        &repo_path("scenes/cornell-box.gltf"),
        name,
        shard,
        extra,
    )
}

/// [`shard`] of the scene `scene`; returns the partial file's path.
fn shard_of(dir: &Path, scene: &Path, name: &str, shard: &str, extra: &[&str]) -> PathBuf {
    let out = dir.join("parts").join(name);
    let mut args = vec![
        s(scene),
        "--spp",
        "12",
        "--resolution",
        "24x24",
        "--shard",
        shard,
        "-o",
        s(&out),
    ];
    args.extend(extra);
    render(dir, &args).assert_success();
    let (i, n) = shard.split_once('/').unwrap();
    out.with_file_name(format!(
        "{}.shard-{i:0>w$}-of-{n}.exr",
        out.file_stem().unwrap().to_string_lossy(),
        w = (n.parse::<u32>().unwrap() - 1).to_string().len()
    ))
}

/// A copy of the Cornell box (its glTF and buffer) in `dir`, with the first byte of its
/// buffer flipped when `edit`.
fn copy_cornell_box(dir: &Path, edit: bool) -> PathBuf {
    std::fs::create_dir_all(dir.join("cornell_box")).unwrap();
    std::fs::copy(
        repo_path("scenes/cornell-box.gltf"),
        dir.join("cornell-box.gltf"),
    )
    .unwrap();
    let mut bin = std::fs::read(repo_path("scenes/cornell_box/CornellBox.bin")).unwrap();
    if edit {
        bin[0] ^= 1;
    }
    std::fs::write(dir.join("cornell_box/CornellBox.bin"), &bin).unwrap();
    dir.join("cornell-box.gltf")
}

fn merge(dir: &Path, parts: &[&Path], extra: &[&str]) -> common::Run {
    let merged = dir.join("merged.exr");
    let mut args = vec!["merge", "-o", s(&merged), "--no-png"];
    args.extend(extra);
    args.extend(parts.iter().map(|p| s(p)));
    render(dir, &args)
}

#[test]
fn merge_names_missing_shards_and_refuses_parts_that_do_not_belong() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    std::fs::create_dir(dir.join("parts")).unwrap();
    let s0 = shard(dir, "a.exr", "0/3", &[]);
    let s2 = shard(dir, "a.exr", "2/3", &[]);
    assert!(s0.is_file() && s2.is_file(), "{}", s0.display());

    // A missing shard: --check lists it and exits 3; the merge refuses, listing it too.
    let check = render(dir, &["merge", "--check", s(&s0), s(&s2)]);
    assert_eq!(check.status.code(), Some(3), "{}", check.stderr);
    assert!(
        check
            .stdout
            .contains("2 part(s) hold 8 of the 12 samples per pixel")
            && check.stdout.contains("missing samples 4..8: shard 1/3"),
        "{}",
        check.stdout
    );
    let refused = merge(dir, &[&s0, &s2], &[]);
    assert_eq!(refused.status.code(), Some(1));
    assert!(
        refused.stderr.contains("missing samples 4..8: shard 1/3"),
        "{}",
        refused.stderr
    );
    assert!(!dir.join("merged.exr").exists(), "nothing written");

    // Complete: --check exits 0.
    let s1 = shard(dir, "a.exr", "1/3", &[]);
    let check = render(dir, &["merge", "--check", s(&s1), s(&s0), s(&s2)]);
    assert_eq!(check.status.code(), Some(0), "{}", check.stdout);
    merge(dir, &[&s0, &s1, &s2], &[]).assert_success();

    // Overlapping parts: shard 0/2 holds samples 0..6, which 0/3 and 1/3 hold too.
    let half = shard(dir, "b.exr", "0/2", &[]);
    let err = merge(dir, &[&s0, &half, &s1, &s2], &[]).stderr;
    assert!(
        err.contains("overlap") && err.contains("samples 0..6"),
        "{err}"
    );

    // Another seed, another setting named in the header, one that is not, another scene.
    let refused = |name: &str, extra: &[&str], words: &[&str]| {
        let other = shard(dir, name, "1/3", extra);
        let err = merge(dir, &[&s0, &other, &s2], &[]).stderr;
        for w in words {
            assert!(err.contains(w), "{name}: {err}");
        }
        assert!(err.contains(s(&other)), "the error names the part: {err}");
    };
    refused("seed.exr", &["--seed", "9"], &["different seed: 0 and 9"]);
    refused(
        "depth.exr",
        &["--max-depth", "3"],
        &["different settings", "strata:max_depth is 8 and 3"],
    );
    refused("alpha.exr", &["--no-alpha"], &["settings hashes differ"]);
    // The same document with one byte of its buffer (a vertex position) edited.
    let edited = copy_cornell_box(&dir.join("edited"), true);
    let other = shard_of(dir, &edited, "edited.exr", "1/3", &[]);
    let err = merge(dir, &[&s0, &other, &s2], &[]).stderr;
    assert!(err.contains("different scenes"), "{err}");
    // Moving the scene changes nothing: its bytes are the same.
    let moved = copy_cornell_box(&dir.join("moved"), false);
    let moved_part = shard_of(dir, &moved, "moved.exr", "1/3", &["--threads", "1"]);
    merge(dir, &[&s0, &moved_part, &s2], &[]).assert_success();

    // A finished image is no part.
    let whole = dir.join("whole.exr");
    let scene = repo_path("scenes/cornell-box.gltf");
    render(
        dir,
        &[
            s(&scene),
            "--spp",
            "12",
            "--resolution",
            "24x24",
            "-o",
            s(&whole),
            "--no-png",
        ],
    )
    .assert_success();
    let err = merge(dir, &[&whole, &s1], &[]).stderr;
    assert!(err.contains("is not a partial file"), "{err}");
}

#[test]
fn options_that_cannot_be_split_by_samples_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo_path("scenes/cornell-box.gltf");
    let out = dir.path().join("o.exr");
    let base = [s(&scene), "-o", s(&out), "--spp", "16"];
    let refused = |extra: &[&str], words: &[&str]| {
        let mut args = base.to_vec();
        args.extend(extra);
        let run = render(dir.path(), &args);
        assert!(!run.status.success(), "{extra:?} was accepted");
        for w in words {
            assert!(run.stderr.contains(w), "{extra:?}: {}", run.stderr);
        }
    };
    refused(
        &["--shard", "0/2", "--target-error", "0.1"],
        &["--shard 0/2", "--target-error"],
    );
    refused(&["--shard", "1/2", "--time-limit", "5"], &["--time-limit"]);
    refused(
        &["--samples", "0..8", "--checkpoint", "5"],
        &["--samples 0..8", "--checkpoint"],
    );
    refused(&["--shard", "0/17"], &["17 shards", "at most 16"]);
    refused(&["--shard", "4/4"], &["below the number of shards"]);
    refused(&["--samples", "8..20"], &["passes --spp 16"]);
    refused(&["--samples", "8..8"], &["holds no samples"]);
    refused(
        &["--shard", "0/2", "--samples", "0..8"],
        &["cannot be used with"],
    );
    assert!(!dir.path().join("o.shard-0-of-2.exr").exists());
}

#[test]
fn a_killed_shard_leaves_no_part_and_check_names_it() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    std::fs::create_dir(dir.join("parts")).unwrap();
    let s1 = shard(dir, "k.exr", "1/2", &[]);
    let scene = repo_path("scenes/cornell-box.gltf");
    let out = dir.join("parts/k.exr");
    // Shard 0 of a render far too long to finish, killed mid-render.
    let mut child = Command::new(common::render_bin())
        .args([
            s(&scene),
            "--spp",
            "12",
            "--resolution",
            "2000x2000",
            "--shard",
            "0/2",
        ])
        .args(["-o", s(&out), "--threads", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    child.kill().unwrap();
    child.wait().unwrap();
    let names = common::entries(&dir.join("parts"));
    assert!(
        !names.iter().any(|n| n.starts_with("k.shard-0")),
        "a killed shard left a part: {names:?}"
    );
    let check = render(dir, &["merge", "--check", s(&s1)]);
    assert_eq!(check.status.code(), Some(3));
    assert!(
        check.stdout.contains("missing samples 0..6: shard 0/2"),
        "{}",
        check.stdout
    );
}

#[test]
fn partial_merges_form_a_tree_that_merges_to_the_one_machine_image() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    std::fs::create_dir(dir.join("parts")).unwrap();
    let passes = ["--passes", "albedo,depth,object_id,material_id"];
    let shards: Vec<PathBuf> = (0..7)
        .map(|i| shard(dir, "t.exr", &format!("{i}/7"), &passes))
        .collect();
    let whole = dir.join("whole.exr");
    let scene = repo_path("scenes/cornell-box.gltf");
    let mut args = vec![s(&scene), "--spp", "12", "--resolution", "24x24"];
    args.extend(["-o", s(&whole), "--no-png"]);
    args.extend(passes);
    render(dir, &args).assert_success();
    // Two groups merged on their own, the second without sample 0, then the groups.
    let group = |name: &str, parts: &[PathBuf]| {
        let out = dir.join(name);
        let mut args = vec!["merge", "--partial", "-o", s(&out)];
        args.extend(parts.iter().map(|p| s(p)));
        let run = render(dir, &args);
        run.assert_success();
        out
    };
    let a = group("a.exr", &shards[..3]);
    let b = group("b.exr", &shards[3..]);
    assert!(
        !dir.join("a.png").exists(),
        "a partial merge writes no preview"
    );
    let check = render(dir, &["merge", "--check", s(&b)]);
    assert!(
        check.stdout.contains("missing samples 0..5"),
        "{}",
        check.stdout
    );
    let tree = dir.join("tree.exr");
    render(dir, &["merge", "-o", s(&tree), "--no-png", s(&b), s(&a)]).assert_success();
    let (want, got) = (channels(&whole), channels(&tree));
    assert_eq!(
        got.keys().collect::<Vec<_>>(),
        want.keys().collect::<Vec<_>>()
    );
    for (channel, bits) in &want {
        assert!(
            bits == &got[channel],
            "{channel} differs after a tree of merges"
        );
    }
    idiff_identical(&whole, &tree);
    let ints = common::int_attrs(&tree);
    assert_eq!(
        common::attr(&ints, "strata:merged_parts"),
        7,
        "the shards behind the tree"
    );
    // A partial merge of parts with a gap between them is refused, naming the gap.
    let out = dir.join("gap.exr");
    let run = render(
        dir,
        &[
            "merge",
            "--partial",
            "-o",
            s(&out),
            s(&shards[0]),
            s(&shards[2]),
        ],
    );
    assert!(!run.status.success());
    assert!(
        run.stderr.contains("missing samples 1..3"),
        "{}",
        run.stderr
    );
}
