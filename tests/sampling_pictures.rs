//! The sampling pictures (`sampling-pictures`, docs/sampling/) cannot go stale or wrong
//! silently: the tool run on fewer samples must find every histogram consistent with its pdf
//! by the χ² test it prints in the captions, reject its negative control, and draw the same
//! numbers for the same seed; and the pixel samplers' point sets must keep the strata they
//! claim.

use std::collections::HashMap;
use std::process::Command;

/// The tool's summary.csv rows by name: (statistic, dof, p-value).
fn run(out: &std::path::Path, samples: usize) -> HashMap<String, (f64, usize, f64)> {
    let status = Command::new(env!("CARGO_BIN_EXE_sampling-pictures"))
        .args(["--out", out.to_str().unwrap(), "--control"])
        .args(["--samples", &samples.to_string()])
        .status()
        .unwrap();
    assert!(status.success(), "sampling-pictures failed");
    let text = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("name,samples,statistic,dof,p_value"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f[1], samples.to_string());
            (
                f[0].to_string(),
                (
                    f[2].parse().unwrap(),
                    f[3].parse().unwrap(),
                    f[4].parse().unwrap(),
                ),
            )
        })
        .collect()
}

#[test]
fn every_picture_agrees_with_its_pdf_and_the_control_does_not() {
    let dir = tempfile::tempdir().unwrap();
    let rows = run(dir.path(), 200_000);
    let pictures = [
        "hemisphere-uniform",
        "hemisphere-cosine",
        "bsdf-metal-0.3",
        "bsdf-metal-0.3-grazing",
        "bsdf-metal-0.8",
        "bsdf-plastic-0.5",
        "bsdf-metal-0.3-anisotropic",
        "environment-studio",
        "environment-studio-compensated",
    ];
    assert_eq!(
        rows.len(),
        pictures.len() + 1,
        "every picture and the control"
    );
    // Bonferroni over the pictures, at 1% overall.
    let alpha = 0.01 / pictures.len() as f64;
    for name in pictures {
        let (statistic, dof, p) = rows[name];
        eprintln!("{name}: χ² {statistic:.1}, {dof} dof, p {p:.3}");
        assert!(p >= alpha, "{name}: p = {p:e} < {alpha}");
        // The compensated map's pdf is 0 outside its two softboxes: about a hundred cells.
        let min_dof = if name.ends_with("compensated") {
            50
        } else {
            500
        };
        assert!(
            dof > min_dof,
            "{name}: the grid should keep its cells ({dof} dof)"
        );
        let png = image::open(dir.path().join(format!("{name}.png"))).unwrap();
        // Warps have the cos θ histogram as a third panel.
        let width = if name.starts_with("hemisphere") {
            1500
        } else {
            1000
        };
        assert_eq!((png.width(), png.height()), (width, 520));
    }
    let (statistic, _, p) = rows["control-cosine-as-uniform"];
    assert!(
        p < 1e-9,
        "the control should be rejected: χ² {statistic}, p {p:e}"
    );

    // The point sets: each sampler's claimed strata hold in every cell; independent random
    // points, judged by the same 8 × 8 cells, do not (the control).
    let points = std::fs::read_to_string(dir.path().join("points.csv")).unwrap();
    let mut lines = points.lines();
    assert_eq!(
        lines.next(),
        Some("sampler,pair,claim_holds,zero_m_2_net_holds")
    );
    let sets: HashMap<(String, String), (f64, f64)> = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let key = (f[0].to_string(), f[1].to_string());
            (key, (f[2].parse().unwrap(), f[3].parse().unwrap()))
        })
        .collect();
    let get = |s: &str, p: &str| sets[&(s.to_string(), p.to_string())];
    for pair in ["first", "film", "slot3"] {
        assert_eq!(get("stratified", pair).0, 1.0, "stratified {pair}");
        assert_eq!(get("sobol", pair).0, 1.0, "sobol {pair}");
        assert!(
            get("random", pair).0 < 0.9,
            "random {pair}: {:?}",
            get("random", pair)
        );
    }
    // Sobol's dimensions 0–1 (the first pair, slot 3) are (0, 6, 2)-nets; the film
    // position's 2–3 are not.
    assert_eq!(get("sobol", "first").1, 1.0);
    assert_eq!(get("sobol", "slot3").1, 1.0);
    assert!(get("sobol", "film").1 < 1.0);
    let png = image::open(dir.path().join("points.png")).unwrap();
    assert_eq!((png.width(), png.height()), (1350, 1380));

    // The same seed draws the same numbers.
    let again = run(&dir.path().join("again"), 200_000);
    assert_eq!(again["hemisphere-cosine"], rows["hemisphere-cosine"]);
}
