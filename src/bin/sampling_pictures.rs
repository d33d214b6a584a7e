//! `sampling-pictures`: strata's sampling routines drawn beside the densities they claim, for a
//! reader to see what the χ² tests check.
//!
//!     cargo build --release
//!     target/release/sampling-pictures --out docs/sampling
//!
//! For each warp from the unit square to directions, it draws `--samples` directions from
//! independent uniform points (SplitMix64, seeded by `--seed`: the same pictures every run) and
//! writes one PNG of three panels: the histogram of cos θ beside the pdf of cos θ the warp
//! claims; the sampled density over the (φ, cos θ) square, an equal-area map of the hemisphere;
//! and the claimed pdf over the same square, on the same colour scale. The caption gives
//! Pearson's χ² of the (φ, cos θ) histogram against the pdf (`strata::sampling::chi2`, the
//! statistics of `tests/sampling.rs`) and its p-value. `summary.csv` lists every picture's
//! statistic, degrees of freedom and p-value; `tests/sampling_pictures.rs` runs the tool on
//! fewer samples and checks them, and `--control` adds a picture that must fail (cosine
//! samples against the uniform pdf).
//!
//! The same two maps (sampled beside claimed, Mitsuba's `ChiSquareTest` layout) for the glTF
//! BSDF's sampling (`Bsdf::sample` against `Bsdf::pdf`, integrated over each cell by
//! Simpson's rule) at a few roughnesses and angles, grazing included, and for the
//! environment map's sampler on the bundled studio HDRI (its texels' probabilities, exact).
//!
//! `points.png` shows the first samples of one pixel from each sampler (`random`,
//! `stratified`, `sobol`): the film position (the sample's first slot) and a later slot's 2D
//! point, with the strata each claims drawn: the correlated multi-jittered cells, rows and
//! columns; the elementary intervals of a (0, m, 2)-net for Owen-scrambled Sobol.
//! `points.csv` gives, per sampler and pair, the least fraction of cells over the claimed
//! strata that hold what is claimed (1 where the claim holds), and the same for the claim of
//! a (0, 6, 2)-net, which only Sobol's dimensions 0–1 make.
//!
//! Labels need a TrueType font: `$STRATA_FONT`, else DejaVu Sans (`fonts-dejavu-core`).

use std::f64::consts::TAU;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use clap::Parser;
use glam::{Vec2, Vec3};
use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;
use strata::plot::{float_label, register_font};
use strata::sampling::chi2::{chi2_test, Chi2Outcome};
use strata::sampling::warps;
use strata::sampling::{PixelSampler, SamplerKind};
use strata::shading::{Bsdf, EnvMap, GltfBrdf, LocalBsdf, MapSampling};

#[derive(Parser, Debug)]
#[command(
    version,
    about = "Pictures of strata's sampling distributions beside their pdfs"
)]
struct Cli {
    /// Where the PNGs and summary.csv go.
    #[arg(long, default_value = "docs/sampling")]
    out: PathBuf,

    /// Directions drawn per picture.
    #[arg(long, default_value_t = 1_000_000)]
    samples: usize,

    /// Seed of the uniform points fed to the warps.
    #[arg(long, default_value_t = 1)]
    seed: u64,

    /// Also draw a negative control: cosine-weighted samples against the uniform pdf.
    #[arg(long)]
    control: bool,
}

/// Bins of the (φ, cos θ) histogram, and of the cos θ histogram.
const PHI_BINS: usize = 64;
const COS_BINS: usize = 32;
const HIST_BINS: usize = 40;

/// SplitMix64 (Steele, Lea & Flood, "Fast splittable pseudorandom number generators", 2014):
/// independent uniform points, so the pictures show the warps and not a sampler's pattern.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) on the 2^-24 grid.
    fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
}

/// A warp to the upper hemisphere and the density it claims.
struct Warp {
    /// File name (without .png) and summary name.
    name: &'static str,
    title: &'static str,
    sample: fn(Vec2) -> Vec3,
    /// The claimed probability of the cell φ ∈ [φ0, φ1), cos θ ∈ [c0, c1) (exact).
    cell: fn(f64, f64, f64, f64) -> f64,
    /// The claimed density of cos θ.
    cos_density: fn(f64) -> f64,
}

fn uniform_cell(p0: f64, p1: f64, c0: f64, c1: f64) -> f64 {
    // pdf 1/(2π) per steradian; dω = dφ d(cos θ).
    (p1 - p0) * (c1 - c0) / TAU
}

fn cosine_cell(p0: f64, p1: f64, c0: f64, c1: f64) -> f64 {
    // pdf cos θ / π: ∫ c dc dφ / π = Δφ (c1² − c0²) / (2π).
    (p1 - p0) * (c1 * c1 - c0 * c0) / TAU
}

fn warps(control: bool) -> Vec<Warp> {
    let mut list = vec![
        Warp {
            name: "hemisphere-uniform",
            title: "Uniform hemisphere",
            sample: warps::square_to_uniform_hemisphere,
            cell: uniform_cell,
            cos_density: |_| 1.0,
        },
        Warp {
            name: "hemisphere-cosine",
            title: "Cosine-weighted hemisphere",
            sample: warps::square_to_cosine_hemisphere,
            cell: cosine_cell,
            cos_density: |c| 2.0 * c,
        },
    ];
    if control {
        list.push(Warp {
            name: "control-cosine-as-uniform",
            title: "Negative control: cosine samples against the uniform pdf",
            sample: warps::square_to_cosine_hemisphere,
            cell: uniform_cell,
            cos_density: |_| 1.0,
        });
    }
    list
}

/// A grid of `nx` × `ny` cells over a rectangle of two coordinates, row-major by y.
#[derive(Clone, Copy)]
struct Grid {
    nx: usize,
    ny: usize,
    x: (f64, f64, &'static str),
    y: (f64, f64, &'static str),
}

/// The (φ, cos θ) grid of the upper hemisphere, an equal-area map (dω = dφ d cos θ).
const HEMISPHERE: Grid = Grid {
    nx: PHI_BINS,
    ny: COS_BINS,
    x: (0.0, TAU, "φ"),
    y: (0.0, 1.0, "cos θ"),
};

/// A warp's counts of cos θ and the density of cos θ it claims.
type CosHistogram = (Vec<f64>, fn(f64) -> f64);

/// What one picture measured.
struct Measured {
    grid: Grid,
    /// Counts per cell; the last entry counts the samples outside the grid's domain (or
    /// declined, or of a delta lobe).
    counts: Vec<f64>,
    /// Expected counts, the same layout.
    expected: Vec<f64>,
    /// Each cell's measure (its solid angle, or its area in the map's (u, v) square), and
    /// what the densities are per.
    measure: Vec<f64>,
    per: &'static str,
    /// Warps: counts of cos θ in [`HIST_BINS`] bins, and the density of cos θ claimed.
    hist: Option<CosHistogram>,
    /// Colours on a log scale (maps whose density spans decades).
    log_colour: bool,
    outcome: std::result::Result<Chi2Outcome, String>,
}

impl Measured {
    fn new(grid: Grid, counts: Vec<f64>, expected: Vec<f64>, solid_angle: Vec<f64>) -> Measured {
        let outcome = chi2_test(&counts, &expected);
        Measured {
            grid,
            counts,
            expected,
            measure: solid_angle,
            per: "per sr",
            hist: None,
            log_colour: false,
            outcome,
        }
    }
}

/// The cell of the hemisphere grid of direction `v` (z up), or None below the horizon or
/// for a direction that is not finite.
fn hemisphere_cell(v: Vec3) -> Option<usize> {
    let c = v.z as f64;
    if !v.is_finite() || !(0.0..=1.0).contains(&c) {
        return None;
    }
    let mut phi = (v.y as f64).atan2(v.x as f64);
    if phi < 0.0 {
        phi += TAU;
    }
    let ip = ((phi / TAU * PHI_BINS as f64) as usize).min(PHI_BINS - 1);
    let ic = ((c * COS_BINS as f64) as usize).min(COS_BINS - 1);
    Some(ic * PHI_BINS + ip)
}

/// The bounds (φ0, φ1, c0, c1) of hemisphere cell `i`.
fn hemisphere_bounds(i: usize) -> (f64, f64, f64, f64) {
    let (ic, ip) = (i / PHI_BINS, i % PHI_BINS);
    let dphi = TAU / PHI_BINS as f64;
    let dc = 1.0 / COS_BINS as f64;
    (
        ip as f64 * dphi,
        (ip + 1) as f64 * dphi,
        ic as f64 * dc,
        (ic + 1) as f64 * dc,
    )
}

fn uniform_points(samples: usize, seed: u64) -> impl Iterator<Item = Vec2> {
    let mut rng = SplitMix64(seed);
    (0..samples).map(move |_| Vec2::new(rng.next_f32(), rng.next_f32()))
}

fn measure(warp: &Warp, samples: usize, seed: u64) -> Measured {
    let cells = PHI_BINS * COS_BINS;
    let mut counts = vec![0.0; cells + 1];
    let mut hist = vec![0.0; HIST_BINS];
    for u in uniform_points(samples, seed) {
        let v = (warp.sample)(u);
        match hemisphere_cell(v) {
            Some(i) => {
                counts[i] += 1.0;
                hist[((v.z as f64 * HIST_BINS as f64) as usize).min(HIST_BINS - 1)] += 1.0;
            }
            None => counts[cells] += 1.0,
        }
    }
    let mut expected: Vec<f64> = (0..cells)
        .map(|i| {
            let (p0, p1, c0, c1) = hemisphere_bounds(i);
            (warp.cell)(p0, p1, c0, c1) * samples as f64
        })
        .collect();
    // Outside the hemisphere the pdf is 0: any sample there fails the test.
    expected.push(0.0);
    let solid_angle = vec![TAU / cells as f64; cells];
    let mut m = Measured::new(HEMISPHERE, counts, expected, solid_angle);
    m.hist = Some((hist, warp.cos_density));
    m
}

/// A glTF BSDF seen from `theta_o` (radians from the normal), for the BSDF pictures.
struct BsdfCase {
    name: &'static str,
    title: &'static str,
    base: [f32; 3],
    metallic: f32,
    roughness: f32,
    /// KHR_materials_anisotropy's strength, the stretch along the frame's x axis (0: none).
    anisotropy: f32,
    theta_o: f32,
}

const BSDF_CASES: [BsdfCase; 5] = [
    BsdfCase {
        name: "bsdf-metal-0.3",
        title: "Metal, roughness 0.3 (GGX visible normals), θo = 34°",
        base: [0.9, 0.9, 0.9],
        metallic: 1.0,
        roughness: 0.3,
        anisotropy: 0.0,
        theta_o: 0.6,
    },
    BsdfCase {
        name: "bsdf-metal-0.3-grazing",
        title: "Metal, roughness 0.3, grazing: θo = 80°",
        base: [0.9, 0.9, 0.9],
        metallic: 1.0,
        roughness: 0.3,
        anisotropy: 0.0,
        theta_o: 1.4,
    },
    BsdfCase {
        name: "bsdf-metal-0.8",
        title: "Metal, roughness 0.8, θo = 69°",
        base: [0.9, 0.6, 0.3],
        metallic: 1.0,
        roughness: 0.8,
        anisotropy: 0.0,
        theta_o: 1.2,
    },
    BsdfCase {
        name: "bsdf-plastic-0.5",
        title: "Plastic, roughness 0.5 (specular + diffuse), θo = 34°",
        base: [0.8, 0.5, 0.2],
        metallic: 0.0,
        roughness: 0.5,
        anisotropy: 0.0,
        theta_o: 0.6,
    },
    BsdfCase {
        name: "bsdf-metal-0.3-anisotropic",
        title: "Metal 0.3, anisotropy 0.7 along x, θo = 34°",
        base: [0.9, 0.9, 0.9],
        metallic: 1.0,
        roughness: 0.3,
        anisotropy: 0.7,
        theta_o: 0.6,
    },
];

/// ∫ f over the rectangle `x` × `y` by the composite Simpson rule, `n` (even) panels per axis.
fn simpson_2d(f: &dyn Fn(f64, f64) -> f64, x: (f64, f64), y: (f64, f64), n: usize) -> f64 {
    let (hx, hy) = ((x.1 - x.0) / n as f64, (y.1 - y.0) / n as f64);
    let weight = |i: usize| match i {
        0 => 1.0,
        i if i == n => 1.0,
        i if i % 2 == 1 => 4.0,
        _ => 2.0,
    };
    let mut sum = 0.0;
    for i in 0..=n {
        for j in 0..=n {
            sum += weight(i) * weight(j) * f(x.0 + i as f64 * hx, y.0 + j as f64 * hy);
        }
    }
    sum * hx * hy / 9.0
}

/// The BSDF's sampled directions against its pdf over the hemisphere grid; samples it
/// declines and those of a delta lobe land in the outside cell, expected to hold what the
/// pdf leaves outside the hemisphere.
fn measure_bsdf(case: &BsdfCase, samples: usize, seed: u64) -> Measured {
    let bsdf = Bsdf::MetallicRoughness(
        GltfBrdf::new(Vec3::from_array(case.base), case.metallic, case.roughness)
            .with_anisotropy(case.anisotropy, Vec3::X),
    );
    let wo = Vec3::new(case.theta_o.sin(), 0.0, case.theta_o.cos());
    let cells = PHI_BINS * COS_BINS;
    let mut counts = vec![0.0; cells + 1];
    for u in uniform_points(samples, seed) {
        // The glTF BRDF reads no lobe number (it remaps u.x).
        let cell = match bsdf.sample(wo, 0.0, u) {
            Some(s) if !s.flags.is_specular() => hemisphere_cell(s.wi),
            _ => None,
        };
        counts[cell.unwrap_or(cells)] += 1.0;
    }
    // pdf per steradian over (φ, cos θ), where dω = dφ d cos θ.
    let pdf = |phi: f64, c: f64| {
        let s = (1.0 - c * c).max(0.0).sqrt();
        let wi = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, c as f32);
        bsdf.pdf(wo, wi) as f64
    };
    let mut expected: Vec<f64> = (0..cells)
        .map(|i| {
            let (p0, p1, c0, c1) = hemisphere_bounds(i);
            simpson_2d(&pdf, (p0, p1), (c0, c1), 16) * samples as f64
        })
        .collect();
    let inside: f64 = expected.iter().sum::<f64>() / samples as f64;
    expected.push((1.0 - inside).max(0.0) * samples as f64);
    let solid_angle = vec![TAU / cells as f64; cells];
    Measured::new(HEMISPHERE, counts, expected, solid_angle)
}

/// The bundled studio HDRI.
const STUDIO: &str = "scenes/env/studio_small_05_1k/studio_small_05_1k.hdr";

/// The map coordinates (u, v) in [0, 1)² of direction `d` (rotation 0), in DESIGN.md's
/// convention (Blender's): u = 0.5 + atan2(d.z, d.x)/2π, v = acos(d.y)/π.
fn env_uv(d: Vec3) -> (f64, f64) {
    let d = d.as_dvec3().normalize();
    let u = (0.5 + d.z.atan2(d.x) / TAU).rem_euclid(1.0);
    (u, d.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI)
}

/// The environment map's samples against its pdf over its own (u, v) grid: the density over
/// (u, v) (pdf times 2π² sin θ) is bilinear over each quarter of a texel, which the midpoint
/// rule integrates exactly, so a cell's probability is the sum over its texels of the mean
/// density at their quarters' centres times a texel's area.
fn measure_env(map: &EnvMap, samples: usize, seed: u64) -> Measured {
    use std::f64::consts::PI;
    let grid = Grid {
        nx: 64,
        ny: 32,
        x: (0.0, 1.0, "u (longitude)"),
        y: (0.0, 1.0, "1 − v (up)"),
    };
    let cells = grid.nx * grid.ny;
    // Cell of map coordinates (u, v), rows from the bottom (v = 1) up.
    let cell_of = |u: f64, v: f64| {
        let ix = ((u * grid.nx as f64) as usize).min(grid.nx - 1);
        let iy = (((1.0 - v) * grid.ny as f64) as usize).min(grid.ny - 1);
        iy * grid.nx + ix
    };
    let (w, h) = map.size();
    let mut probability = vec![0.0; cells];
    let area = 1.0 / (w * h) as f64;
    for y in 0..h {
        for x in 0..w {
            let mut density = 0.0;
            for (qx, qy) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                let (u, v) = ((x as f64 + qx) / w as f64, (y as f64 + qy) / h as f64);
                let (phi, theta) = (TAU * (u - 0.5), PI * v);
                let d = Vec3::new(
                    (theta.sin() * phi.cos()) as f32,
                    theta.cos() as f32,
                    (theta.sin() * phi.sin()) as f32,
                );
                density += 0.25 * map.pdf(d) as f64 * 2.0 * PI * PI * theta.sin();
            }
            let i = cell_of((x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64);
            probability[i] += density * area;
        }
    }
    // A point that lands exactly on a pole (u.y = 0 or 1, 2^-24 of the points) gets pdf 0:
    // the sampler's documented degenerate case, which the renderer skips as weightless, so
    // it is left out here too. A direction that is not finite counts outside the map.
    let mut counts = vec![0.0; cells + 1];
    let mut used = 0usize;
    for u in uniform_points(samples, seed) {
        let (d, _, p) = map.sample(u);
        if p == 0.0 {
            continue;
        }
        used += 1;
        match d.is_finite() && p > 0.0 {
            true => {
                let (u, v) = env_uv(d);
                counts[cell_of(u, v)] += 1.0;
            }
            false => counts[cells] += 1.0,
        }
    }
    let mut expected: Vec<f64> = probability.iter().map(|p| p * used as f64).collect();
    expected.push(0.0);
    // Densities over the (u, v) square, where the claimed pdf is the texels' luminance
    // times sin θ (per steradian it would be the luminance alone).
    let mut m = Measured::new(grid, counts, expected, vec![1.0 / cells as f64; cells]);
    m.per = "per unit (u, v) area";
    m.log_colour = true;
    m
}

fn caption(samples: usize, outcome: &std::result::Result<Chi2Outcome, String>) -> String {
    match outcome {
        Ok(o) => format!(
            "{samples} samples; χ² over the grid = {:.1} with {} dof, p = {}",
            o.statistic,
            o.dof,
            float_label(o.p_value)
        ),
        Err(e) => format!("{samples} samples; χ² test refused: {e}"),
    }
}

fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("plot: {e}")
}

/// The picture: for a warp, the cos θ histogram beside its claimed density; then the
/// sampled and the claimed densities per steradian over the grid, on one colour scale.
fn draw(path: &Path, title: &str, samples: usize, m: &Measured) -> Result<()> {
    let panes = if m.hist.is_some() { 3 } else { 2 };
    let (w, h) = (500 * panes as u32, 520u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let root = root
            .titled(
                &format!("{title} — {}", caption(samples, &m.outcome)),
                ("sans-serif", 18),
            )
            .map_err(plot_err)?;
        let panels = root.split_evenly((1, panes));

        if let Some((hist, cos_density)) = &m.hist {
            let density: Vec<f64> = hist
                .iter()
                .map(|c| c / samples as f64 * HIST_BINS as f64)
                .collect();
            let top = density
                .iter()
                .copied()
                .chain((0..=HIST_BINS).map(|i| cos_density(i as f64 / HIST_BINS as f64)))
                .fold(0.0, f64::max)
                * 1.1;
            let mut chart = ChartBuilder::on(&panels[0])
                .caption(
                    "cos θ: histogram (bars) and claimed density (line)",
                    ("sans-serif", 15),
                )
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(50)
                .build_cartesian_2d(0.0..1.0, 0.0..top.max(1e-9))
                .map_err(plot_err)?;
            chart
                .configure_mesh()
                .x_desc("cos θ")
                .y_desc("density")
                .x_label_formatter(&|v| float_label(*v))
                .y_label_formatter(&|v| float_label(*v))
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(plot_err)?;
            let bar = RGBColor(120, 160, 220);
            chart
                .draw_series(density.iter().enumerate().map(|(i, &d)| {
                    let (x0, x1) = (
                        i as f64 / HIST_BINS as f64,
                        (i + 1) as f64 / HIST_BINS as f64,
                    );
                    Rectangle::new([(x0, 0.0), (x1, d)], bar.filled())
                }))
                .map_err(plot_err)?;
            chart
                .draw_series(LineSeries::new(
                    (0..=200).map(|i| {
                        let c = i as f64 / 200.0;
                        (c, cos_density(c))
                    }),
                    BLACK.stroke_width(2),
                ))
                .map_err(plot_err)?;
        }

        let g = m.grid;
        let cells = g.nx * g.ny;
        let per_sr = |counts: &[f64]| -> Vec<f64> {
            counts[..cells]
                .iter()
                .zip(&m.measure)
                .map(|(c, sr)| c / samples as f64 / sr)
                .collect()
        };
        let (sampled, claimed) = (per_sr(&m.counts), per_sr(&m.expected));
        let max = sampled
            .iter()
            .chain(&claimed)
            .copied()
            .fold(0.0, f64::max)
            .max(1e-9);
        // A log scale spans four decades below the maximum.
        let level = |v: f64| match m.log_colour {
            false => v / max,
            true => ((v / max).max(1e-4).log10() + 4.0) / 4.0,
        };
        let scale = match m.log_colour {
            false => format!("0 to {}", float_label(max)),
            true => format!("log, {} to {}", float_label(max * 1e-4), float_label(max)),
        };
        let first = panes - 2;
        for (panel, values, what) in [
            (
                &panels[first],
                &sampled,
                format!("sampled density ({})", m.per),
            ),
            (
                &panels[first + 1],
                &claimed,
                format!("claimed pdf ({})", m.per),
            ),
        ] {
            let title = format!("{what}; colours {scale}");
            let mut chart = ChartBuilder::on(panel)
                .caption(title, ("sans-serif", 15))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(50)
                .build_cartesian_2d(g.x.0..g.x.1, g.y.0..g.y.1)
                .map_err(plot_err)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc(g.x.2)
                .y_desc(g.y.2)
                .x_label_formatter(&|v| float_label(*v))
                .y_label_formatter(&|v| float_label(*v))
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(plot_err)?;
            let (dx, dy) = ((g.x.1 - g.x.0) / g.nx as f64, (g.y.1 - g.y.0) / g.ny as f64);
            chart
                .draw_series(values.iter().enumerate().map(|(i, &v)| {
                    let (iy, ix) = (i / g.nx, i % g.nx);
                    let (x0, y0) = (g.x.0 + ix as f64 * dx, g.y.0 + iy as f64 * dy);
                    let colour = ViridisRGB::get_color(level(v).clamp(0.0, 1.0));
                    Rectangle::new([(x0, y0), (x0 + dx, y0 + dy)], colour.filled())
                }))
                .map_err(plot_err)?;
        }
        root.present().map_err(plot_err)?;
    }
    let image = image::RgbImage::from_raw(w, h, buf).ok_or_else(|| anyhow!("plot buffer size"))?;
    image
        .save(path)
        .with_context(|| format!("{}: cannot write the picture", path.display()))
}

/// Samples of one pixel in the point-set picture (a power of two, a square, and the CMJ grid
/// 8 × 8).
const POINTS: u32 = 64;
const POINTS_LOG2: u32 = 6;

/// The pairs drawn: the film position, and the 2D point of the sample's fourth slot.
const PAIRS: [(&str, &str); 3] = [
    ("first", "dims 0–1"),
    ("film", "film position"),
    ("slot3", "slot 3"),
];

/// `POINTS` samples of pixel (3, 5) from `kind`: the sample's first two dimensions (the
/// value drawn with the film position: its slot's dimensions 0–1), the film position (with
/// `sobol`, dimensions 2–3 of that slot's 4D point) and slot 3's point.
fn pixel_points(kind: SamplerKind, seed: u64) -> [Vec<Vec2>; 3] {
    let mut sampler = PixelSampler::new(kind, POINTS, seed);
    let (mut first, mut film, mut later) = (Vec::new(), Vec::new(), Vec::new());
    for index in 0..POINTS {
        sampler.start(3, 5, index);
        film.push(sampler.next_film());
        first.push(sampler.paired_with_film());
        sampler.next_2d();
        sampler.next_2d();
        later.push(sampler.next_2d());
    }
    [first, film, later]
}

/// The fraction of the 2^kx × 2^ky cells of the unit square holding exactly `per_cell` of
/// `points`.
fn cells_holding(points: &[Vec2], (kx, ky): (u32, u32), per_cell: u32) -> f64 {
    let (nx, ny) = (1usize << kx, 1usize << ky);
    let mut count = vec![0u32; nx * ny];
    for p in points {
        let ix = ((p.x as f64 * nx as f64) as usize).min(nx - 1);
        let iy = ((p.y as f64 * ny as f64) as usize).min(ny - 1);
        count[iy * nx + ix] += 1;
    }
    count.iter().filter(|&&c| c == per_cell).count() as f64 / count.len() as f64
}

/// What a sampler claims of a pair's points: the cell shapes (log2 columns, log2 rows) that
/// each hold `per_cell` points, and the claim in words.
struct Claim {
    shapes: Vec<(u32, u32)>,
    per_cell: u32,
    words: &'static str,
}

/// The shapes of the elementary intervals of area 2^-k.
fn intervals(k: u32) -> Vec<(u32, u32)> {
    (0..=k).map(|i| (i, k - i)).collect()
}

fn claim(kind: SamplerKind, pair: usize) -> Claim {
    let half = POINTS_LOG2 / 2;
    match (kind, pair) {
        // No claim; judged by the cells of a jittered grid.
        (SamplerKind::Random, _) => Claim {
            shapes: vec![(half, half)],
            per_cell: 1,
            words: "no strata (8 × 8 cells drawn)",
        },
        // Correlated multi-jittered: its grid's cells, and n-rooks columns and rows.
        (SamplerKind::Stratified, _) => Claim {
            shapes: vec![(half, half), (POINTS_LOG2, 0), (0, POINTS_LOG2)],
            per_cell: 1,
            words: "8 × 8 cells, rows, columns",
        },
        // The film position is dimensions 2–3 of the slot's 4D Sobol point, a (1, m, 2)-net:
        // every elementary interval of area 2^(1-m) holds two points (the sampler keeps
        // dimensions 0–1, a (0, m, 2)-net, for the value paired with it, pair 0).
        (SamplerKind::Sobol, 1) => Claim {
            shapes: intervals(POINTS_LOG2 - 1),
            per_cell: 2,
            words: "(1, 6, 2)-net",
        },
        // Dimensions 0–1: a (0, m, 2)-net, every elementary interval of area 2^-m.
        (SamplerKind::Sobol, _) => Claim {
            shapes: intervals(POINTS_LOG2),
            per_cell: 1,
            words: "(0, 6, 2)-net",
        },
    }
}

/// The least fraction over `claim`'s shapes of cells holding what it claims.
fn worst(points: &[Vec2], claim: &Claim) -> f64 {
    claim
        .shapes
        .iter()
        .map(|&shape| cells_holding(points, shape, claim.per_cell))
        .fold(1.0, f64::min)
}

/// Draws `points.png` and returns the rows of `points.csv`.
fn draw_points(path: &Path, seed: u64) -> Result<String> {
    let kinds = [
        SamplerKind::Random,
        SamplerKind::Stratified,
        SamplerKind::Sobol,
    ];
    let net = Claim {
        shapes: intervals(POINTS_LOG2),
        per_cell: 1,
        words: "",
    };
    let mut csv = String::new();
    let (w, h) = (1350u32, 1380u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let root = root
            .titled(
                &format!("{POINTS} samples of one pixel: the strata each sampler claims, and the share of cells that hold them"),
                ("sans-serif", 18),
            )
            .map_err(plot_err)?;
        let panels = root.split_evenly((3, 3));
        for (row, &kind) in kinds.iter().enumerate() {
            for (col, points) in pixel_points(kind, seed).iter().enumerate() {
                let claim = claim(kind, col);
                let held = worst(points, &claim);
                let as_net = worst(points, &net);
                writeln!(csv, "{kind},{},{held},{as_net}", PAIRS[col].0)?;
                let caption = format!(
                    "{kind}, {}: {}, held in {:.0}%",
                    PAIRS[col].1,
                    claim.words,
                    held * 100.0
                );
                let mut chart = ChartBuilder::on(&panels[row * 3 + col])
                    .caption(caption, ("sans-serif", 14))
                    .margin(10)
                    .x_label_area_size(25)
                    .y_label_area_size(35)
                    .build_cartesian_2d(0.0f64..1.0, 0.0f64..1.0)
                    .map_err(plot_err)?;
                chart
                    .configure_mesh()
                    .disable_mesh()
                    .x_labels(3)
                    .y_labels(3)
                    .label_style(("sans-serif", 12))
                    .draw()
                    .map_err(plot_err)?;
                // The claimed strata: lines at their cells' edges, lightest for the finest.
                // The claimed strata: the squarest shapes darker (CMJ's rows and columns, and a
                // net's thin intervals, would hide the points).
                for &(kx, ky) in claim
                    .shapes
                    .iter()
                    .filter(|&&(kx, ky)| kx.abs_diff(ky) <= 1 || kind == SamplerKind::Stratified)
                {
                    let grey = match kx.abs_diff(ky) <= 1 {
                        true => RGBColor(150, 150, 150),
                        false => RGBColor(225, 225, 225),
                    };
                    let lines = (1..(1u32 << kx))
                        .map(|i| {
                            let x = i as f64 / (1u32 << kx) as f64;
                            vec![(x, 0.0), (x, 1.0)]
                        })
                        .chain((1..(1u32 << ky)).map(|i| {
                            let y = i as f64 / (1u32 << ky) as f64;
                            vec![(0.0, y), (1.0, y)]
                        }));
                    for l in lines {
                        chart
                            .draw_series(LineSeries::new(l, grey.stroke_width(1)))
                            .map_err(plot_err)?;
                    }
                }
                chart
                    .draw_series(
                        points
                            .iter()
                            .map(|p| Circle::new((p.x as f64, p.y as f64), 4, RED.filled())),
                    )
                    .map_err(plot_err)?;
            }
        }
        root.present().map_err(plot_err)?;
    }
    let image = image::RgbImage::from_raw(w, h, buf).ok_or_else(|| anyhow!("plot buffer size"))?;
    image
        .save(path)
        .with_context(|| format!("{}: cannot write the picture", path.display()))?;
    Ok(csv)
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    if cli.samples < 1000 {
        bail!("--samples must be at least 1000 (a χ² test needs counts)");
    }
    std::fs::create_dir_all(&cli.out)
        .with_context(|| format!("{}: cannot create the directory", cli.out.display()))?;
    register_font()?;
    let mut summary = String::from("name,samples,statistic,dof,p_value\n");
    let mut record = |name: &str, title: &str, m: &Measured| -> Result<()> {
        let path = cli.out.join(format!("{name}.png"));
        draw(&path, title, cli.samples, m)?;
        let (statistic, dof, p) = match &m.outcome {
            Ok(o) => (o.statistic, o.dof, o.p_value),
            Err(_) => (f64::INFINITY, 0, 0.0),
        };
        writeln!(summary, "{name},{},{statistic},{dof},{p:e}", cli.samples)?;
        println!("{}: {}", path.display(), caption(cli.samples, &m.outcome));
        Ok(())
    };
    // Each picture its own stream of points.
    let seed = |k: u64| cli.seed.wrapping_add(k * 0x1000);
    for (k, warp) in warps(cli.control).iter().enumerate() {
        let m = measure(warp, cli.samples, seed(k as u64));
        record(warp.name, warp.title, &m)?;
    }
    for (k, case) in BSDF_CASES.iter().enumerate() {
        let m = measure_bsdf(case, cli.samples, seed(100 + k as u64));
        record(case.name, case.title, &m)?;
    }
    let studio = Path::new(env!("CARGO_MANIFEST_DIR")).join(STUDIO);
    for (k, (sampling, name, title)) in [
        (
            MapSampling::Radiance,
            "environment-studio",
            "Environment map, studio_small_05",
        ),
        (
            MapSampling::Compensated,
            "environment-studio-compensated",
            "Environment map, studio_small_05, compensated",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let map = EnvMap::load(&studio, 0.0, 1.0, sampling)
            .map_err(|e| anyhow!("{}: {e}", studio.display()))?;
        let m = measure_env(&map, cli.samples, seed(200 + k as u64));
        record(name, title, &m)?;
    }
    let csv = cli.out.join("summary.csv");
    std::fs::write(&csv, summary).with_context(|| format!("{}: cannot write", csv.display()))?;
    let path = cli.out.join("points.png");
    let rows = draw_points(&path, cli.seed)?;
    let csv = cli.out.join("points.csv");
    let text = format!("sampler,pair,claim_holds,zero_m_2_net_holds\n{rows}");
    std::fs::write(&csv, text).with_context(|| format!("{}: cannot write", csv.display()))?;
    println!(
        "{}: the point sets of one pixel ({})",
        path.display(),
        csv.display()
    );
    Ok(())
}
