//! The sampling pictures (`sampling-pictures`, docs/sampling/) cannot go stale or wrong
//! silently: the tool run on fewer samples must find every histogram consistent with its pdf
//! by the χ² test it prints in the captions, reject its negative control, and draw the same
//! numbers for the same seed.

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
    let pictures = ["hemisphere-uniform", "hemisphere-cosine"];
    // Bonferroni over the pictures, at 1% overall.
    let alpha = 0.01 / pictures.len() as f64;
    for name in pictures {
        let (statistic, dof, p) = rows[name];
        eprintln!("{name}: χ² {statistic:.1}, {dof} dof, p {p:.3}");
        assert!(p >= alpha, "{name}: p = {p:e} < {alpha}");
        assert!(
            dof > 1000,
            "{name}: the grid should keep its cells ({dof} dof)"
        );
        let png = image::open(dir.path().join(format!("{name}.png"))).unwrap();
        assert_eq!((png.width(), png.height()), (1500, 520));
    }
    let (statistic, _, p) = rows["control-cosine-as-uniform"];
    assert!(
        p < 1e-9,
        "the control should be rejected: χ² {statistic}, p {p:e}"
    );

    // The same seed draws the same numbers.
    let again = run(&dir.path().join("again"), 200_000);
    assert_eq!(again["hemisphere-cosine"], rows["hemisphere-cosine"]);
}
