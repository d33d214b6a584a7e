//! The `convergence` tool end to end on a small ladder: it writes one CSV row per
//! configuration and spp with sane values, both plots, and a negative slope for independent
//! samples (whose RMSE must fall as spp grows).

use std::path::Path;
use std::process::Command;

/// Runs the tool on the Cornell box AO reference with `args`, into `out`; returns its stdout
/// and the CSV it wrote.
fn run_tool(out: &Path, args: &[&str]) -> (String, String) {
    let run = Command::new(env!("CARGO_BIN_EXE_convergence"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["--reference", "scenes/references/cornell-box.ao.exr"])
        .args(["--render", env!("CARGO_BIN_EXE_render")])
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout).into_owned();
    assert!(
        run.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let csv = std::fs::read_to_string(out.join("convergence.csv")).unwrap();
    (stdout, csv)
}

/// The header and the rows of a CSV the tool wrote (no quoted fields), split at commas.
fn table(csv: &str) -> (Vec<&str>, Vec<Vec<&str>>) {
    let mut lines = csv.lines().map(|l| l.split(',').collect::<Vec<_>>());
    let head = lines.next().unwrap_or_default();
    (head, lines.collect())
}

#[test]
fn convergence_tool_writes_csv_plots_and_slopes() {
    let out = tempfile::tempdir().unwrap();
    let (stdout, csv) = run_tool(
        out.path(),
        &[
            "--samplers",
            "random,sobol",
            "--hemispheres",
            "cosine",
            "--max-spp",
            "16",
        ],
    );
    let (head, rows) = table(&csv);
    // Two configurations × spp 1, 2, 4, 8, 16.
    assert_eq!(rows.len(), 10, "{csv}");
    let col = |name: &str| head.iter().position(|c| *c == name).unwrap();
    let (spp, rmse, rays) = (col("spp"), col("rmse"), col("rays"));
    let random: Vec<(u32, f64, f64)> = rows
        .iter()
        .filter(|r| r[col("sampler")] == "random")
        .map(|r| {
            (
                r[spp].parse().unwrap(),
                r[rmse].parse().unwrap(),
                r[rays].parse().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        random.iter().map(|r| r.0).collect::<Vec<_>>(),
        [1, 2, 4, 8, 16]
    );
    // Rays grow with spp (AO: one camera ray plus up to one AO ray per sample).
    assert!(random.windows(2).all(|w| w[1].2 > w[0].2), "{random:?}");
    // Independent samples: 16× the samples gives about ¼ the RMSE; allow a wide margin.
    let ratio = random[4].1 / random[0].1;
    assert!(
        (0.15..0.4).contains(&ratio),
        "RMSE ratio 16 spp / 1 spp = {ratio}"
    );

    let slope_line = stdout
        .lines()
        .find(|l| l.contains("random, cosine") && l.contains("slope"))
        .unwrap_or_else(|| panic!("no slope for random:\n{stdout}"));
    let slope: f64 = slope_line
        .split("spp: ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("cannot read the slope: {slope_line}"));
    assert!(
        (-0.7..-0.35).contains(&slope),
        "random sampling slope {slope}"
    );

    for plot in ["error_vs_spp.png", "error_vs_time.png"] {
        let img = image::open(out.path().join(plot)).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (900, 600));
        // Not blank: lines and labels put plenty of non-white pixels on the white page.
        let ink = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        assert!(ink > 5000, "{plot}: only {ink} non-white pixels");
    }
}

#[test]
fn convergence_tool_compares_uniform_and_adaptive_at_equal_time() {
    let out = tempfile::tempdir().unwrap();
    let (_, csv) = run_tool(
        out.path(),
        &[
            "--samplers",
            "sobol",
            "--hemispheres",
            "cosine",
            "--adaptive",
            "none,absolute",
            "--time-limits",
            "0.2,0.6",
        ],
    );
    let (head, rows) = table(&csv);
    let col = |name: &str| head.iter().position(|c| *c == name).unwrap();
    // Two modes × two time limits, in that order.
    let modes: Vec<(&str, &str)> = rows
        .iter()
        .map(|r| (r[col("adaptive")], r[col("time_limit")]))
        .collect();
    assert_eq!(
        modes,
        [
            ("", "0.2"),
            ("", "0.6"),
            ("absolute", "0.2"),
            ("absolute", "0.6")
        ],
        "{csv}"
    );
    for pair in rows.chunks(2) {
        let spp = |r: &Vec<&str>| r[col("spp")].parse::<f64>().unwrap();
        let seconds = |r: &Vec<&str>| r[col("seconds")].parse::<f64>().unwrap();
        // The render stops at its limit (loosely: this is not a timing test) …
        assert!(
            seconds(&pair[0]) >= 0.2 && seconds(&pair[1]) >= 0.6,
            "{csv}"
        );
        assert!(seconds(&pair[1]) < 30.0, "{csv}");
        // … and three times the time buys more samples.
        assert!(spp(&pair[1]) > spp(&pair[0]), "{csv}");
    }
}

/// `--emitter-samples 0,8` adds a configuration per count, recorded in the CSV's
/// `emitter_samples` column and passed to `render`: on the Cornell box's path tracing, 8
/// emitter rays per sample give a lower RMSE at 8 spp than none (the light's outline).
#[test]
fn convergence_tool_compares_emitter_sample_counts() {
    let out = tempfile::tempdir().unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_convergence"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["--reference", "scenes/references/cornell-box.path.exr"])
        .args(["--render", env!("CARGO_BIN_EXE_render")])
        .args([
            "--samplers",
            "sobol",
            "--emitter-samples",
            "0,8",
            "--max-spp",
            "8",
        ])
        .arg("--out")
        .arg(out.path())
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let csv = std::fs::read_to_string(out.path().join("convergence.csv")).unwrap();
    let (head, rows) = table(&csv);
    let col = |name: &str| head.iter().position(|c| *c == name).unwrap();
    let (c_em, c_spp, c_rmse) = (col("emitter_samples"), col("spp"), col("rmse"));
    // Two configurations × spp 1, 2, 4, 8.
    assert_eq!(rows.len(), 8, "{csv}");
    let rmse_at_8 = |n: &str| -> f64 {
        let row = rows
            .iter()
            .find(|r| r[c_em] == n && r[c_spp].parse::<f64>().unwrap() == 8.0)
            .unwrap_or_else(|| panic!("no 8-spp row with {n} emitter rays:\n{csv}"));
        row[c_rmse].parse().unwrap()
    };
    let (without, with) = (rmse_at_8("0"), rmse_at_8("8"));
    assert!(
        with < 0.8 * without,
        "RMSE at 8 spp: {with} with 8 emitter rays, {without} without"
    );
}
