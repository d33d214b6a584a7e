//! A χ² goodness-of-fit test of sampled directions over the whole sphere (reflection and
//! transmission), for the BSDF tests (`dielectric.rs`, `layers.rs`): directions binned on a
//! (θ, φ) grid, each cell's expected probability integrated from the claimed pdf by adaptive
//! Simpson, and Pearson's test from `strata::sampling::chi2`.

use std::f64::consts::{PI, TAU};

use glam::Vec3;
use strata::sampling::chi2::{chi2_test, Chi2Outcome};
use strata::shading::BsdfSample;

use super::Pcg32;

pub const SAMPLES: usize = 1_000_000;
pub const THETA_BINS: usize = 40;
pub const PHI_BINS: usize = 40;
pub const CELLS: usize = THETA_BINS * PHI_BINS;

/// The cell of the (θ, φ) grid over the whole sphere, θ ∈ [0, π] in `THETA_BINS` (the equator
/// a cell boundary), φ ∈ [0, 2π) in `PHI_BINS`.
pub fn cell_of(v: Vec3) -> Option<usize> {
    if !v.is_finite() || v.length_squared() == 0.0 {
        return None;
    }
    let (x, y, z) = (v.x as f64, v.y as f64, v.z as f64);
    let theta = x.hypot(y).atan2(z);
    let mut phi = y.atan2(x);
    if phi < 0.0 {
        phi += TAU;
    }
    let it = ((theta / PI * THETA_BINS as f64) as usize).min(THETA_BINS - 1);
    let ip = ((phi / TAU * PHI_BINS as f64) as usize).min(PHI_BINS - 1);
    Some(it * PHI_BINS + ip)
}

pub fn direction(theta: f64, phi: f64) -> Vec3 {
    Vec3::new(
        (theta.sin() * phi.cos()) as f32,
        (theta.sin() * phi.sin()) as f32,
        theta.cos() as f32,
    )
}

/// ∫cell pdf dω over the cell of polar range [t0, t0 + dt] and azimuths [p0, p0 + dp] by
/// the composite Simpson rule in (θ, φ) with the sin θ Jacobian, `panels` (even) per axis.
pub fn simpson_cell(
    pdf: &dyn Fn(Vec3) -> f64,
    (t0, dt): (f64, f64),
    (p0, dp): (f64, f64),
    panels: usize,
) -> f64 {
    let weight = |i: usize| match i {
        0 => 1.0,
        i if i == panels => 1.0,
        i if i % 2 == 1 => 4.0,
        _ => 2.0,
    };
    let (ht, hp) = (dt / panels as f64, dp / panels as f64);
    let mut sum = 0.0;
    for i in 0..=panels {
        let theta = t0 + i as f64 * ht;
        let sin = theta.sin();
        for j in 0..=panels {
            let phi = p0 + j as f64 * hp;
            sum += weight(i) * weight(j) * pdf(direction(theta, phi)) * sin;
        }
    }
    sum * ht * hp / 9.0
}

/// ∫cell pdf dω for every cell, by [`simpson_cell`] starting from `panels` panels and
/// doubling them (up to `MAX_PANELS`) while two successive estimates differ by more than 1e-4 of the
/// cell's probability (and 1e-9 absolute): the pdf of a rough interface jumps inside cells
/// (GGX's D does not vanish at the horizon, so the transmitted density steps where the
/// half vector reaches it), where a fixed rule would be too coarse.
pub fn cell_probabilities(pdf: &dyn Fn(Vec3) -> f64, panels: usize) -> Vec<f64> {
    const MAX_PANELS: usize = 256;
    let (dt, dp) = (PI / THETA_BINS as f64, TAU / PHI_BINS as f64);
    let mut out = Vec::with_capacity(CELLS);
    for it in 0..THETA_BINS {
        for ip in 0..PHI_BINS {
            let cell = ((it as f64 * dt, dt), (ip as f64 * dp, dp));
            let mut n = panels;
            let mut estimate = simpson_cell(pdf, cell.0, cell.1, n);
            while n < MAX_PANELS {
                let finer = simpson_cell(pdf, cell.0, cell.1, 2 * n);
                let settled = (finer - estimate).abs() <= 1e-4 * finer.abs() + 1e-9;
                (estimate, n) = (finer, 2 * n);
                if settled {
                    break;
                }
            }
            out.push(estimate);
        }
    }
    out
}

/// Draws `SAMPLES` directions with `sample` (its inputs from PCG32 seeded with `seed`), bins
/// them over the sphere, and runs the χ² test against `pdf`. Samples declined (None) and those
/// of delta lobes land in an extra cell, expected to hold what `pdf` leaves of 1.
pub fn sphere_chi2(
    sample: &dyn Fn(&mut Pcg32) -> Option<BsdfSample>,
    pdf: &dyn Fn(Vec3) -> f64,
    panels: usize,
    seed: u64,
) -> Result<Chi2Outcome, String> {
    let mut observed = vec![0.0; CELLS + 1];
    let mut rng = Pcg32::new(seed, 0x91a5);
    for _ in 0..SAMPLES {
        match sample(&mut rng) {
            Some(s) if !s.flags.is_specular() => match cell_of(s.wi) {
                Some(cell) => observed[cell] += 1.0,
                None => return Err(format!("a sample of no direction: {s:?}")),
            },
            _ => observed[CELLS] += 1.0,
        }
    }
    let probabilities = cell_probabilities(pdf, panels);
    let inside: f64 = probabilities.iter().sum();
    if inside > 1.0 + 1e-3 {
        return Err(format!("the pdf integrates to {inside} over the sphere"));
    }
    let mut expected: Vec<f64> = probabilities.iter().map(|p| p * SAMPLES as f64).collect();
    expected.push((1.0 - inside).max(0.0) * SAMPLES as f64);
    chi2_test(&observed, &expected)
}
