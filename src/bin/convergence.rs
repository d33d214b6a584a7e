//! `convergence`: error against samples per pixel and against time, for one reference image.
//!
//!     cargo build --release
//!     target/release/convergence --reference scenes/references/cornell-box.path.exr --out results/cornell
//!
//! The reference's entry in `manifest.json` (next to it) names its scene and the `render`
//! arguments that match it (integrator, depth, background, resolution). For every
//! combination of the chosen samplers, AO hemisphere warps and direct-light strategies, the
//! tool runs `render` (the binary next to this one) at 1, 2, 4, … spp up to `--max-spp`, or
//! until a render takes longer than `--time-budget`, with `--seeds` seeds per point, and
//! compares each image with the reference (`strata::convergence`). It writes
//!
//! - `convergence.csv`: one row per configuration and spp (errors are means over seeds);
//! - `error_vs_spp.png` and `error_vs_time.png`: log-log plots of RMSE;
//!
//! and prints the fitted slope of log RMSE against log spp for each configuration (−0.5 for
//! independent samples; steeper for stratified and low-discrepancy ones where the integrand
//! allows). The fit uses the points whose MSE is at least 4× the reference's noise floor.
//! The render time is the renderer's own (`--stats`: rendering only, not loading or the BVH).
//!
//! With `--time-limits`, the ladder is one of `render --time-limit` budgets instead of spp
//! (its spp column is then the mean spp the render reached), and `--adaptive` adds adaptive
//! sampling to the configurations: an equal-time comparison of uniform and adaptive sampling.
//!
//! Plot labels need a TrueType font: `$STRATA_FONT`, else DejaVu Sans from Debian's
//! `fonts-dejavu-core` (installed by tools/setup.sh).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{anyhow, bail, Context, Result};
use clap::Parser;
use plotters::prelude::*;
use strata::convergence::{image_error, log_log_fit, spp_ladder, ImageError};
use strata::plot::{float_label, register_font};
use strata::render::output::read_exr_rgb;

#[derive(Parser, Debug)]
#[command(version, about = "Error against spp and time for one reference image")]
struct Cli {
    /// The reference EXR (its manifest entry gives the scene and render arguments).
    #[arg(long, value_name = "FILE.exr")]
    reference: PathBuf,

    /// The manifest [default: manifest.json next to the reference].
    #[arg(long, value_name = "FILE.json")]
    manifest: Option<PathBuf>,

    /// Samplers to compare, comma-separated.
    #[arg(long, default_value = "random,stratified,sobol", value_delimiter = ',')]
    samplers: Vec<String>,

    /// Hemisphere warps to compare, comma-separated [default: cosine,uniform for AO; for
    /// direct and path, the renderer's default (cosine) alone].
    #[arg(long, value_delimiter = ',')]
    hemispheres: Option<Vec<String>>,

    /// Direct and path only: light-sampling strategies to compare, comma-separated.
    #[arg(long, default_value = "mis", value_delimiter = ',')]
    strategies: Vec<String>,

    /// Direct and path only: `render --emitter-samples` counts to compare, comma-separated
    /// [default: the renderer's default alone].
    #[arg(long, value_delimiter = ',', value_name = "N,...")]
    emitter_samples: Vec<u32>,

    /// Path only: how the bounces' sample points are drawn, comma-separated: `joint` (one
    /// Sobol sequence for all bounces, the renderer's default) or `padded` (each bounce its
    /// own, `render --padded-bounces`) [default: the renderer's default alone].
    #[arg(long, value_delimiter = ',', value_name = "joint|padded,...")]
    bounces: Vec<String>,

    /// The last rung of the spp ladder 1, 2, 4, …
    #[arg(long, default_value_t = 1024)]
    max_spp: u32,

    /// A ladder of render time limits (seconds, comma-separated) instead of the spp ladder.
    #[arg(long, value_name = "SECONDS,...", value_delimiter = ',')]
    time_limits: Vec<f64>,

    /// Sampling modes to compare, comma-separated: none (every pixel alike), relative or
    /// absolute (adaptive sampling with that --error-metric and --target-error).
    #[arg(long, default_value = "none", value_delimiter = ',')]
    adaptive: Vec<String>,

    /// The --target-error of the adaptive modes. With --time-limits, a small one lets the
    /// time limit decide (samples then go where they lower the error most).
    #[arg(long, default_value_t = 1e-4)]
    target_error: f64,

    /// Stop a configuration's ladder after a render that took longer than this (seconds).
    #[arg(long, value_name = "SECONDS")]
    time_budget: Option<f64>,

    /// Seeds per point; errors and times are averaged over them.
    #[arg(long, default_value_t = 1)]
    seeds: u32,

    /// Render threads (0: all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,

    /// Output directory for the CSV and the plots.
    #[arg(long, default_value = "convergence")]
    out: PathBuf,

    /// The render binary [default: `render` next to this program].
    #[arg(long, value_name = "PATH")]
    render: Option<PathBuf>,

    /// Redraw the plots from `convergence.csv` in `--out` without rendering.
    #[arg(long)]
    replot: bool,
}

/// One configuration to climb the ladder with.
#[derive(Clone, Debug)]
struct Config {
    sampler: String,
    hemisphere: Option<String>,
    strategy: Option<String>,
    /// Adaptive sampling's error metric; `None`: uniform.
    adaptive: Option<String>,
    /// `--emitter-samples`; `None`: the renderer's default.
    emitter_samples: Option<u32>,
    /// `joint` or `padded` bounces; `None`: the renderer's default.
    bounces: Option<String>,
}

impl Config {
    fn label(&self) -> String {
        let mut s = self.sampler.clone();
        if let Some(h) = &self.hemisphere {
            write!(s, ", {h}").unwrap();
        }
        if let Some(st) = &self.strategy {
            write!(s, ", {st}").unwrap();
        }
        if let Some(m) = &self.adaptive {
            write!(s, ", adaptive {m}").unwrap();
        }
        if let Some(n) = self.emitter_samples {
            write!(s, ", {n} emitter rays").unwrap();
        }
        if let Some(b) = &self.bounces {
            write!(s, ", {b} bounces").unwrap();
        }
        s
    }

    fn args(&self, target_error: f64) -> Vec<String> {
        let mut a = vec!["--sampler".to_string(), self.sampler.clone()];
        if let Some(h) = &self.hemisphere {
            a.extend(["--hemisphere".into(), h.clone()]);
        }
        if let Some(st) = &self.strategy {
            a.extend(["--strategy".into(), st.clone()]);
        }
        if let Some(m) = &self.adaptive {
            a.extend([
                "--target-error".into(),
                target_error.to_string(),
                "--error-metric".into(),
                m.clone(),
            ]);
        }
        if let Some(n) = self.emitter_samples {
            a.extend(["--emitter-samples".into(), n.to_string()]);
        }
        if self.bounces.as_deref() == Some("padded") {
            a.push("--padded-bounces".into());
        }
        a
    }
}

/// One point of a ladder.
struct Point {
    /// Samples per pixel (the mean, for time-limited and adaptive renders).
    spp: f64,
    seconds: f64,
    rays: f64,
    error: ImageError,
}

/// What the reference's manifest entry says.
struct Reference {
    scene: PathBuf,
    integrator: String,
    args: Vec<String>,
    variance: Option<PathBuf>,
}

fn read_manifest(cli: &Cli) -> Result<Reference> {
    let manifest = cli.manifest.clone().unwrap_or_else(|| {
        cli.reference
            .parent()
            .unwrap_or(Path::new("."))
            .join("manifest.json")
    });
    let text = std::fs::read_to_string(&manifest)
        .with_context(|| format!("{}: cannot read the manifest", manifest.display()))?;
    let json: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: not valid JSON", manifest.display()))?;
    let want = cli.reference.file_name().and_then(|n| n.to_str());
    let entry = json["references"]
        .as_array()
        .into_iter()
        .flatten()
        .find(|r| {
            r["reference"]
                .as_str()
                .and_then(|p| Path::new(p).file_name())
                .and_then(|n| n.to_str())
                == want
        })
        .ok_or_else(|| {
            anyhow!(
                "{}: no entry for {}",
                manifest.display(),
                cli.reference.display()
            )
        })?;
    // Paths in the manifest are relative to the repository root: two levels above it.
    let root = manifest
        .parent()
        .and_then(Path::parent)
        .and_then(Path::parent)
        .unwrap_or(Path::new("."));
    let field = |k: &str| entry[k].as_str().map(str::to_string);
    let scene = root.join(field("scene").ok_or_else(|| anyhow!("manifest entry has no scene"))?);
    let args: Vec<String> = entry["strata_args"]
        .as_array()
        .ok_or_else(|| anyhow!("manifest entry has no strata_args"))?
        .iter()
        .filter_map(|v| v.as_str().map(str::to_string))
        .collect();
    let integrator = field("integrator").unwrap_or_else(|| "ao".into());
    Ok(Reference {
        scene,
        integrator,
        args,
        variance: field("variance").map(|v| root.join(v)),
    })
}

/// What one run of `render` reported.
struct Run {
    seconds: f64,
    rays: f64,
    /// Mean samples per pixel.
    spp: f64,
}

/// Runs `render` once.
fn run_render(render: &Path, scene: &Path, args: &[String], output: &Path) -> Result<Run> {
    let out = Command::new(render)
        .arg(scene)
        .args(args)
        .arg("-o")
        .arg(output)
        .args(["--no-png", "--stats"])
        .output()
        .with_context(|| format!("cannot run {}", render.display()))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        bail!(
            "render {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let seconds = stdout
        .lines()
        .find_map(|l| {
            let rest = l.strip_prefix("time:")?;
            let at = rest.find(" render ")?;
            rest[at + 8..].split_whitespace().next()?.parse().ok()
        })
        .ok_or_else(|| anyhow!("no render time in the output of render --stats"))?;
    let rays = stdout
        .lines()
        .find_map(|l| {
            let rest = l.strip_prefix("rays:")?;
            let at = rest.find(" total")?;
            rest[..at].rsplit(' ').next()?.parse().ok()
        })
        .ok_or_else(|| anyhow!("no ray count in the output of render --stats"))?;
    // The first line: "out.exr: WxH, N spp, …" or "…, MIN-MAX (mean M) spp, …".
    let first = stdout.lines().next().unwrap_or_default();
    let spp = first
        .split_once(" (mean ")
        .and_then(|(_, r)| r.split(')').next())
        .or_else(|| first.split(", ").nth(1)?.strip_suffix(" spp"))
        .and_then(|v| v.trim().parse().ok())
        .ok_or_else(|| anyhow!("no spp in the first line of render's output: {first}"))?;
    Ok(Run { seconds, rays, spp })
}

fn configs(cli: &Cli, integrator: &str) -> Vec<Config> {
    let mut out = Vec::new();
    for s in &cli.samplers {
        for a in &cli.adaptive {
            let adaptive = Some(a.clone()).filter(|a| a != "none");
            let hemispheres: Vec<Option<String>> = match (&cli.hemispheres, integrator) {
                (Some(h), _) => h.iter().cloned().map(Some).collect(),
                (None, "ao") => vec![Some("cosine".into()), Some("uniform".into())],
                (None, _) => vec![None],
            };
            let strategies: Vec<Option<String>> = match integrator {
                "ao" => vec![None],
                _ => cli.strategies.iter().cloned().map(Some).collect(),
            };
            let emitter_samples: Vec<Option<u32>> = match integrator {
                "ao" => vec![None],
                _ if cli.emitter_samples.is_empty() => vec![None],
                _ => cli.emitter_samples.iter().copied().map(Some).collect(),
            };
            let bounces: Vec<Option<String>> = match integrator {
                "path" if !cli.bounces.is_empty() => {
                    cli.bounces.iter().cloned().map(Some).collect()
                }
                _ => vec![None],
            };
            for h in &hemispheres {
                for st in &strategies {
                    for &n in &emitter_samples {
                        for b in &bounces {
                            out.push(Config {
                                sampler: s.clone(),
                                hemisphere: h.clone(),
                                strategy: st.clone(),
                                adaptive: adaptive.clone(),
                                emitter_samples: n,
                                bounces: b.clone(),
                            });
                        }
                    }
                }
            }
        }
    }
    out
}

/// A log-log plot of RMSE against `x` (spp or seconds), one line per configuration.
fn plot(
    path: &Path,
    title: &str,
    x_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    floor: f64,
) -> Result<()> {
    let (w, h) = (900u32, 600u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow!("plot: {e}"))?;
        let all = series.iter().flat_map(|(_, p)| p.iter());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in all.filter(|(x, y)| *x > 0.0 && *y > 0.0) {
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
        if floor > 0.0 {
            y0 = y0.min(floor);
        }
        if x0 >= x1 {
            x1 = x0 * 2.0;
        }
        if y0 >= y1 {
            y1 = y0 * 2.0;
        }
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (x0 / 1.3..x1 * 1.3).log_scale(),
                (y0 / 1.3..y1 * 1.3).log_scale(),
            )
            .map_err(|e| anyhow!("plot: {e}"))?;
        chart
            .configure_mesh()
            .x_label_formatter(&|v| float_label(*v))
            .y_label_formatter(&|v| float_label(*v))
            .x_desc(x_label)
            .y_desc("RMSE against the reference")
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| anyhow!("plot: {e}"))?;
        for (i, (name, points)) in series.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            chart
                .draw_series(LineSeries::new(
                    points.iter().copied(),
                    color.stroke_width(2),
                ))
                .map_err(|e| anyhow!("plot: {e}"))?
                .label(name.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
            chart
                .draw_series(points.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(|e| anyhow!("plot: {e}"))?;
        }
        if floor > 0.0 {
            let grey = RGBColor(120, 120, 120);
            chart
                .draw_series(LineSeries::new(
                    [(x0 / 1.3, floor), (x1 * 1.3, floor)],
                    grey.stroke_width(1),
                ))
                .map_err(|e| anyhow!("plot: {e}"))?
                .label("reference noise (√ mean variance)")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], grey));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(|e| anyhow!("plot: {e}"))?;
        root.present().map_err(|e| anyhow!("plot: {e}"))?;
    }
    let image = image::RgbImage::from_raw(w, h, buf).ok_or_else(|| anyhow!("plot buffer size"))?;
    image
        .save(path)
        .with_context(|| format!("{}: cannot write the plot", path.display()))
}

/// Redraws both plots from a CSV this tool wrote.
fn replot(out: &Path) -> Result<()> {
    let path = out.join("convergence.csv");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let col = |name: &str| {
        head.iter()
            .position(|c| *c == name)
            .ok_or_else(|| anyhow!("{}: no column {name}", path.display()))
    };
    let (c_name, c_s, c_h, c_st) = (
        col("reference")?,
        col("sampler")?,
        col("hemisphere")?,
        col("strategy")?,
    );
    let (c_spp, c_sec, c_rmse, c_var) = (
        col("spp")?,
        col("seconds")?,
        col("rmse")?,
        col("reference_variance")?,
    );
    // Absent from CSVs written before adaptive sampling, --emitter-samples and --bounces.
    let c_ad = col("adaptive").ok();
    let c_em = col("emitter_samples").ok();
    let c_b = col("bounces").ok();
    let mut by_spp: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    let mut by_time: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    let (mut name, mut floor) = (String::new(), 0.0f64);
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let num = |c: usize| -> Result<f64> {
            f.get(c)
                .and_then(|v| v.parse().ok())
                .ok_or_else(|| anyhow!("{}: bad row {line}", path.display()))
        };
        let config = Config {
            sampler: f[c_s].to_string(),
            hemisphere: Some(f[c_h]).filter(|v| !v.is_empty()).map(str::to_string),
            strategy: Some(f[c_st]).filter(|v| !v.is_empty()).map(str::to_string),
            adaptive: c_ad
                .and_then(|c| f.get(c))
                .filter(|v| !v.is_empty())
                .map(|v| v.to_string()),
            emitter_samples: c_em.and_then(|c| f.get(c)).and_then(|v| v.parse().ok()),
            bounces: c_b
                .and_then(|c| f.get(c))
                .filter(|v| !v.is_empty())
                .map(|v| v.to_string()),
        };
        let label = config.label();
        if by_spp.last().is_none_or(|(l, _)| *l != label) {
            by_spp.push((label.clone(), Vec::new()));
            by_time.push((label, Vec::new()));
        }
        let (rmse, var) = (num(c_rmse)?, num(c_var)?);
        by_spp.last_mut().unwrap().1.push((num(c_spp)?, rmse));
        by_time
            .last_mut()
            .unwrap()
            .1
            .push((num(c_sec)?.max(1e-4), rmse));
        name = f[c_name].to_string();
        floor = var.sqrt();
    }
    plot_both(out, &name, &by_spp, &by_time, floor)
}

/// Both plots of a run into `out`: RMSE against spp and against render seconds.
fn plot_both(
    out: &Path,
    name: &str,
    by_spp: &[(String, Vec<(f64, f64)>)],
    by_time: &[(String, Vec<(f64, f64)>)],
    floor: f64,
) -> Result<()> {
    plot(
        &out.join("error_vs_spp.png"),
        &format!("{name}: error against samples per pixel"),
        "samples per pixel",
        by_spp,
        floor,
    )?;
    plot(
        &out.join("error_vs_time.png"),
        &format!("{name}: error against render time"),
        "render seconds",
        by_time,
        floor,
    )
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    if cli.replot {
        register_font()?;
        return replot(&cli.out);
    }
    check_options(&cli)?;
    let reference = read_manifest(&cli)?;
    let (rw, rh, ref_pixels) = read_exr_rgb(&cli.reference)
        .with_context(|| format!("{}: cannot read the reference", cli.reference.display()))?;
    let ref_var = match &reference.variance {
        Some(v) if v.exists() => {
            let (vw, vh, px) = read_exr_rgb(v)
                .with_context(|| format!("{}: cannot read the variance image", v.display()))?;
            if (vw, vh) != (rw, rh) {
                bail!("{}: {vw}x{vh}, but the reference is {rw}x{rh}", v.display());
            }
            Some(px)
        }
        _ => None,
    };
    let render = match &cli.render {
        Some(r) => r.clone(),
        None => std::env::current_exe()?.with_file_name("render"),
    };
    register_font()?;
    std::fs::create_dir_all(&cli.out)
        .with_context(|| format!("{}: cannot create the output directory", cli.out.display()))?;
    let scratch = tempfile_dir(&cli.out)?;

    let name = cli
        .reference
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut csv = String::from(
        "reference,integrator,sampler,hemisphere,strategy,spp,seeds,seconds,rays,rmse,rmse_corrected,relmse,mae,reference_variance,adaptive,time_limit,emitter_samples,bounces\n",
    );
    let mut by_spp = Vec::new();
    let mut by_time = Vec::new();
    println!("{name}: {} ({rw}x{rh})", reference.scene.display());
    for config in configs(&cli, &reference.integrator) {
        let mut points: Vec<Point> = Vec::new();
        // Rungs: (spp, time limit); with time limits the spp is the most a pixel may take.
        let rungs: Vec<(Option<u32>, Option<f64>)> = if cli.time_limits.is_empty() {
            spp_ladder(cli.max_spp)
                .into_iter()
                .map(|spp| (Some(spp), None))
                .collect()
        } else {
            cli.time_limits.iter().map(|&t| (None, Some(t))).collect()
        };
        for (spp, time_limit) in rungs {
            let point = measure(
                &cli,
                &render,
                &reference,
                &config,
                (spp, time_limit),
                &scratch,
                (rw, rh, &ref_pixels, ref_var.as_deref()),
            )?;
            let error = point.error;
            csv_row(
                &mut csv, &name, &cli, &reference, &config, &point, time_limit,
            );
            eprintln!(
                "  {:<24} {:>8.1} spp {:>9.3} s  RMSE {:.4e}  relMSE {:.4e}",
                config.label(),
                point.spp,
                point.seconds,
                error.rmse(),
                error.relmse
            );
            let over_budget = cli.time_budget.is_some_and(|b| point.seconds > b);
            points.push(point);
            if over_budget {
                break;
            }
        }
        // Fit where the image's own error dominates the reference's noise.
        let usable: Vec<&Point> = points
            .iter()
            .filter(|p| p.error.mse >= 4.0 * p.error.reference_variance)
            .collect();
        let fit = log_log_fit(
            &usable
                .iter()
                .map(|p| (p.spp, p.error.rmse()))
                .collect::<Vec<_>>(),
        );
        match fit {
            Some((slope, _)) => println!(
                "  {:<24} slope of log RMSE against log spp: {slope:+.3} ({} points)",
                config.label(),
                usable.len()
            ),
            None => println!(
                "  {:<24} too few points above the reference's noise to fit a slope",
                config.label()
            ),
        }
        by_spp.push((
            config.label(),
            points.iter().map(|p| (p.spp, p.error.rmse())).collect(),
        ));
        by_time.push((
            config.label(),
            points
                .iter()
                .map(|p| (p.seconds.max(1e-4), p.error.rmse()))
                .collect(),
        ));
    }
    let floor = ref_var.as_deref().map_or(0.0, |v| {
        image_error(&ref_pixels, &ref_pixels, Some(v))
            .reference_variance
            .sqrt()
    });
    let csv_path = cli.out.join("convergence.csv");
    std::fs::write(&csv_path, csv)
        .with_context(|| format!("{}: cannot write", csv_path.display()))?;
    plot_both(&cli.out, &name, &by_spp, &by_time, floor)?;
    let _ = std::fs::remove_dir_all(&scratch);
    println!(
        "wrote {}, error_vs_spp.png and error_vs_time.png in {}",
        csv_path.display(),
        cli.out.display()
    );
    Ok(())
}

/// Refuses option values the tool cannot use.
fn check_options(cli: &Cli) -> Result<()> {
    if cli.max_spp == 0 || cli.seeds == 0 {
        bail!("--max-spp and --seeds must be at least 1");
    }
    if let Some(t) = cli
        .time_limits
        .iter()
        .find(|t| !(**t > 0.0 && t.is_finite()))
    {
        bail!("--time-limits: {t} is not a positive number of seconds");
    }
    if let Some(a) = cli
        .adaptive
        .iter()
        .find(|a| !["none", "relative", "absolute"].contains(&a.as_str()))
    {
        bail!("--adaptive: '{a}': expected none, relative or absolute");
    }
    if let Some(b) = cli
        .bounces
        .iter()
        .find(|b| !["joint", "padded"].contains(&b.as_str()))
    {
        bail!("--bounces: '{b}': expected joint or padded");
    }
    Ok(())
}

/// One rung of a configuration's ladder (`spp`, `time_limit`), rendered once per seed and
/// measured against the reference (`width × height` `pixels`, with its variance image if
/// any): the mean over the seeds.
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn measure(
    cli: &Cli,
    render: &Path,
    reference: &Reference,
    config: &Config,
    (spp, time_limit): (Option<u32>, Option<f64>),
    scratch: &Path,
    (rw, rh, ref_pixels, ref_var): (usize, usize, &[[f32; 3]], Option<&[[f32; 3]]>),
) -> Result<Point> {
    let (mut seconds, mut rays, mut mean_spp) = (0.0, 0.0, 0.0);
    let mut errors = Vec::new();
    for seed in 0..cli.seeds {
        let mut args = reference.args.clone();
        args.extend(config.args(cli.target_error));
        if let Some(spp) = spp {
            args.extend(["--spp".into(), spp.to_string()]);
        }
        if let Some(t) = time_limit {
            args.extend(["--time-limit".into(), t.to_string()]);
        }
        args.extend([
            "--seed".into(),
            seed.to_string(),
            "--threads".into(),
            cli.threads.to_string(),
        ]);
        let img = scratch.join("image.exr");
        let run = run_render(render, &reference.scene, &args, &img)?;
        let (w, h, px) = read_exr_rgb(&img)?;
        if (w, h) != (rw, rh) {
            bail!("render gave {w}x{h}, the reference is {rw}x{rh}");
        }
        errors.push(image_error(&px, ref_pixels, ref_var));
        seconds += run.seconds;
        rays += run.rays;
        mean_spp += run.spp;
    }
    let k = cli.seeds as f64;
    let error = ImageError::mean(&errors).expect("at least one seed");
    let point = Point {
        spp: mean_spp / k,
        seconds: seconds / k,
        rays: rays / k,
        error,
    };
    Ok(point)
}

/// Appends a rung's row to the CSV.
fn csv_row(
    csv: &mut String,
    name: &str,
    cli: &Cli,
    reference: &Reference,
    config: &Config,
    point: &Point,
    time_limit: Option<f64>,
) {
    let error = point.error;
    writeln!(
        csv,
        "{name},{},{},{},{},{},{},{:.6},{:.0},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{},{},{},{}",
        reference.integrator,
        config.sampler,
        config.hemisphere.as_deref().unwrap_or(""),
        config.strategy.as_deref().unwrap_or(""),
        point.spp,
        cli.seeds,
        point.seconds,
        point.rays,
        error.rmse(),
        error.rmse_corrected(),
        error.relmse,
        error.mae,
        error.reference_variance,
        config.adaptive.as_deref().unwrap_or(""),
        time_limit.map(|t| t.to_string()).unwrap_or_default(),
        config
            .emitter_samples
            .map(|n| n.to_string())
            .unwrap_or_default(),
        config.bounces.as_deref().unwrap_or(""),
    )
    .unwrap();
}

/// A scratch directory inside `out` for the renders' images.
fn tempfile_dir(out: &Path) -> Result<PathBuf> {
    let dir = out.join(format!(".scratch-{}", std::process::id()));
    std::fs::create_dir_all(&dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    Ok(dir)
}

#[cfg(test)]
mod tests {
    use super::float_label;

    #[test]
    fn axis_labels_are_compact() {
        for (v, want) in [
            (1.0, "1"),
            (10.0, "10"),
            (2.0, "2"),
            (0.25, "0.25"),
            (0.0123, "0.0123"),
            (0.05, "0.05"),
            (1024.0, "1024"),
            (1e-4, "1e-4"),
            (3e5, "3e5"),
        ] {
            assert_eq!(float_label(v), want, "{v}");
        }
    }
}
