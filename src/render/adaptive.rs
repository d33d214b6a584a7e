//! Adaptive sampling: which pixels have converged.
//!
//! A pixel's error is estimated from its own samples: the standard error of its mean per
//! channel. The sample variance over the sample count (σ²/n, [`Film::variance_of_mean`])
//! assumes independent samples; a pixel's Sobol points are not, and their mean's true error
//! is far lower (on the Cornell box at 256 spp, σ²/n is 8× the true squared error, and 20×
//! on the light's outline, where the split emitter samples are stratified too). So the
//! estimate compares the two halves of the pixel's samples instead, each a stratified set of
//! its own (Rousselle et al. 2012 compare two half buffers the same way): for the first p
//! samples, p the count's last power of two, with half means a and b, (a − b)²/4 estimates
//! the variance of their mean whatever the correlation within a half, and p/n scales it to
//! the pixel's n samples ([`Film::halves_variance_of_mean`]). It overstates the true squared
//! error by a near-constant 1.4–1.7× on the Cornell box (BENCHMARKS.md). Being the square of
//! one difference per channel, it is noisy, so it is never taken below a sixteenth of σ²/n
//! ([`HALVES_FLOOR`]), and the neighbourhood rule below needs nine of them under the target.
//! `Experiments::error_halves` = false takes σ²/n alone, the estimate before, for comparisons.
//!
//! For RGB the error is the sum of the channels' standard errors, which bounds the standard
//! error of the channel sum whatever the channels' correlation (Cauchy–Schwarz). By default
//! ([`ErrorMetric::Relative`]) it is taken relative to the sum of the channel means:
//!
//! ```text
//! e = (σ_R + σ_G + σ_B) / (μ_R + μ_G + μ_B + floor),   floor = 10⁻² · mean over the image of (μ_R + μ_G + μ_B)
//! ```
//!
//! The floor keeps nearly black pixels from demanding samples without end: their error is
//! measured relative to 1% of the image's mean instead of their own tiny value.
//! [`ErrorMetric::Absolute`] drops the denominator: e = σ_R + σ_G + σ_B, in radiance units
//! (σ_c the channel's standard error as estimated above).
//!
//! **With a time limit**, each round's samples go to the half of the unconverged pixels
//! where one more sample lowers the squared error most ([`select_most_useful`]). Over many
//! rounds this gives each pixel samples in proportion to its per-sample deviation, which
//! minimises the image's summed squared error (relative or absolute, by the metric) for the
//! samples the time allows.
//!
//! The stopping rule is made safe against the estimate's own noise in three ways:
//!
//! - **A minimum of samples** (`min_spp`, 16 by default) before any pixel is judged. With
//!   fewer, a pixel whose few samples happen to agree (all zero, all missing a small light)
//!   looks converged although it is not.
//! - **Neighbourhoods.** A pixel stops only when its error and that of its eight neighbours
//!   are all at or under the target. Features are rarely one pixel wide, so a pixel that has
//!   not yet seen an event its neighbours have seen keeps sampling, and the boundary of a
//!   noisy region keeps sampling with it (no seam between converged and unconverged areas).
//! - **Stopped for good.** A stopped pixel is never judged again, so its samples are a prefix
//!   of its sample sequence and all active pixels take the same sample indices.
//!
//! Stopping on the samples' own variance biases a pixel slightly (one whose early samples
//! happen to agree stops sooner, with a value nearer to those samples); the minimum and the
//! neighbourhood keep this small, and the tests measure it against the references.

use rayon::prelude::*;

use super::film::Film;

/// What a pixel's error is measured against (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum ErrorMetric {
    /// The standard error relative to the pixel's value (with a floor): the noise one sees
    /// once the image is tone-mapped; dark regions get their share of samples.
    #[default]
    Relative,
    /// The standard error in radiance units: what the image's RMSE measures; bright and
    /// high-contrast regions (light edges, caustics) get the samples.
    Absolute,
}

crate::display_as_value_name!(ErrorMetric);

/// How far below the sample variance over n the two-halves estimate may put a pixel's
/// variance ([`pixel_error`]): a sixteenth (a quarter of the error).
pub const HALVES_FLOOR: f64 = 16.0;

/// The floor of the denominator, as a fraction of the image's mean channel sum.
pub const FLOOR_FRACTION: f64 = 1e-2;

/// The estimated standard error of pixel (x, y)'s value in `metric` (module docs), or +∞
/// for a pixel with fewer than `min_spp` (or two) samples.
pub fn pixel_error(
    film: &Film,
    x: u32,
    y: u32,
    metric: ErrorMetric,
    floor: f64,
    min_spp: u32,
) -> f64 {
    if film.count(x, y) < min_spp.max(2) {
        return f64::INFINITY;
    }
    let sample = film.variance_of_mean(x, y).to_array();
    let sigma: f64 = match film.halves_variance_of_mean(x, y) {
        Some(halves) => (halves.to_array().iter().zip(sample))
            .map(|(&h, s)| (h as f64).max(s as f64 / HALVES_FLOOR).sqrt())
            .sum(),
        None => sample.iter().map(|&v| (v as f64).sqrt()).sum(),
    };
    if sigma == 0.0 {
        return 0.0;
    }
    match metric {
        ErrorMetric::Absolute => sigma,
        ErrorMetric::Relative => {
            let mean = film.pixel(x, y);
            sigma / ((mean.x + mean.y + mean.z) as f64 + floor)
        }
    }
}

/// The denominator's floor for the pixels of `window` ([`FLOOR_FRACTION`] of their mean
/// channel sum).
pub fn error_floor(film: &Film, window: (u32, u32, u32, u32)) -> f64 {
    let (x0, y0, x1, y1) = window;
    let n = (x1.saturating_sub(x0) as u64 * y1.saturating_sub(y0) as u64).max(1);
    let sum: f64 = (y0..y1)
        .into_par_iter()
        .map(|y| {
            (x0..x1)
                .map(|x| {
                    let p = film.pixel(x, y);
                    (p.x + p.y + p.z) as f64
                })
                .sum::<f64>()
        })
        .sum();
    FLOOR_FRACTION * sum / n as f64
}

/// The outcome of [`judge`].
pub struct Judgement {
    /// Pixels still active.
    pub active: usize,
    /// Each window pixel's error for the stopping rule: the largest [`pixel_error`] in its
    /// 3 × 3 neighbourhood (clipped to the window), row-major within the window.
    pub errors: Vec<f64>,
}

/// Judges the active pixels of `window` (`active` is indexed like the film): a pixel stays
/// active unless it and its neighbours within the window all have a [`pixel_error`] of at
/// most `target`. Pixels with fewer than `min_spp` samples count as unconverged. Runs on the
/// current rayon pool.
pub fn judge(
    film: &Film,
    window: (u32, u32, u32, u32),
    active: &mut [bool],
    metric: ErrorMetric,
    target: f32,
    min_spp: u32,
) -> Judgement {
    let (x0, y0, x1, y1) = window;
    // The floor only enters relative errors: no pass over the film for absolute ones.
    let floor = match metric {
        ErrorMetric::Relative => error_floor(film, window),
        ErrorMetric::Absolute => 0.0,
    };
    if x0 >= x1 || y0 >= y1 {
        return Judgement {
            active: 0,
            errors: Vec::new(),
        };
    }
    let (w, h) = ((x1 - x0) as usize, (y1 - y0) as usize);
    let own: Vec<f64> = (y0..y1)
        .into_par_iter()
        .flat_map_iter(|y| (x0..x1).map(move |x| pixel_error(film, x, y, metric, floor, min_spp)))
        .collect();
    // The 3 × 3 maximum, separably: along rows, then along columns.
    let max3 = |v: &[f64], i: usize, n: usize, stride: usize| {
        let mut m = v[i * stride];
        if i > 0 {
            m = m.max(v[(i - 1) * stride]);
        }
        if i + 1 < n {
            m = m.max(v[(i + 1) * stride]);
        }
        m
    };
    let rows: Vec<f64> = own
        .par_chunks(w)
        .flat_map_iter(|r| (0..w).map(move |x| max3(r, x, w, 1)))
        .collect();
    let errors: Vec<f64> = (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let rows = &rows;
            (0..w).map(move |x| max3(&rows[x..], y, h, w))
        })
        .collect();
    let target = target as f64;
    let width = film.width as usize;
    let still = active
        .par_chunks_mut(width)
        .enumerate()
        .skip(y0 as usize)
        .take(h)
        .map(|(y, row)| {
            let e = &errors[(y - y0 as usize) * w..][..w];
            let mut still = 0;
            for (a, &e) in row[x0 as usize..x1 as usize].iter_mut().zip(e) {
                if *a && e <= target {
                    *a = false;
                }
                still += *a as usize;
            }
            still
        })
        .sum();
    Judgement {
        active: still,
        errors,
    }
}

/// With a time limit, the samples of a round go where they lower the error most. One more
/// sample lowers a pixel's squared error e² = r²/n by about r²/n² = e²/n (r: the per-sample
/// deviation), so the active pixels whose e²/n is at least the median of theirs are
/// selected. Repeated, this gives each pixel samples in proportion to r, the allocation that
/// minimises the sum of r²/n for a given total Σn (Lagrange multipliers: r²/n² equal for
/// all pixels). Stopping at equal error (n ∝ r²) would only match uniform sampling's sum.
/// Pixels not yet judged (under the minimum of samples) are always selected.
pub fn select_most_useful(
    film: &Film,
    window: (u32, u32, u32, u32),
    active: &[bool],
    judged: &Judgement,
    selected: &mut [bool],
) {
    let (x0, y0, x1, y1) = window;
    let w = x1.saturating_sub(x0) as usize;
    let width = film.width as usize;
    let gain = |x: u32, y: u32| {
        let e = judged.errors[(y - y0) as usize * w + (x - x0) as usize];
        if e == f64::INFINITY {
            // Not yet judged (under the minimum of samples): first in line.
            return f64::INFINITY;
        }
        e * e / film.count(x, y).max(1) as f64
    };
    let mut gains: Vec<f64> = (y0..y1)
        .into_par_iter()
        .flat_map_iter(|y| {
            (x0..x1)
                .filter(move |&x| active[y as usize * width + x as usize])
                .map(move |x| gain(x, y))
        })
        .collect();
    selected.fill(false);
    if gains.is_empty() {
        return;
    }
    let mid = gains.len() / 2;
    let (_, &mut median, _) = gains.select_nth_unstable_by(mid, f64::total_cmp);
    selected
        .par_chunks_mut(width)
        .enumerate()
        .skip(y0 as usize)
        .take((y1 - y0) as usize)
        .for_each(|(y, row)| {
            for x in x0..x1 {
                let i = x as usize;
                row[i] = active[y * width + i] && gain(x, y as u32) >= median;
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A film whose pixels hold `n` samples alternating between `a` and `b` (grey).
    fn film_with(w: u32, h: u32, f: impl Fn(u32, u32) -> (f64, f64, u32)) -> Film {
        let mut film = Film::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let (a, b, n) = f(x, y);
                for i in 0..n {
                    let v = if i % 2 == 0 { a } else { b };
                    film.add_sample(x, y, Vec3::splat(v as f32));
                }
            }
        }
        film
    }

    /// With halves kept, the error is the two-halves estimate, floored at a quarter of σ/√n
    /// (a sixteenth of its variance). Pixel 0: 32 samples, 0 in the first 16 and 1 in the
    /// second, halves far apart; pixel 1: 32 samples alternating 0 and 1, both halves with
    /// mean ½, whose estimate is 0 and takes the floor.
    #[test]
    fn the_error_comes_from_the_two_halves_above_a_floor() {
        let mut film = Film::new(2, 1);
        film.keep_halves();
        for i in 0..32u32 {
            let first = if i < 16 { 0.0 } else { 1.0 };
            let alternating = (i % 2) as f32;
            film.add_sample(0, 0, Vec3::splat(first));
            film.add_sample(1, 0, Vec3::splat(alternating));
        }
        let e = |x| pixel_error(&film, x, 0, ErrorMetric::Absolute, 0.0, 16);
        // Pixel 0: ((0 − 1)/2)² = ¼ per channel, a standard error of ½; three channels.
        assert!((e(0) - 1.5).abs() < 1e-6, "{}", e(0));
        // Pixel 1: σ² = 32/31 · ¼ over n = 32; a quarter of σ/√n per channel.
        let sigma = (32.0 / 31.0 * 0.25 / 32.0f64).sqrt();
        assert!(
            (e(1) - 3.0 * sigma / 4.0).abs() < 1e-6,
            "{} against {}",
            e(1),
            0.75 * sigma
        );
        // Without halves: σ/√n for both.
        let mut plain = Film::new(1, 1);
        for i in 0..32u32 {
            let v = (i % 2) as f32;
            plain.add_sample(0, 0, Vec3::splat(v));
        }
        let e = pixel_error(&plain, 0, 0, ErrorMetric::Absolute, 0.0, 16);
        assert!((e - 3.0 * sigma).abs() < 1e-6, "{e}");
    }

    #[test]
    fn the_error_is_the_standard_error_over_the_mean() {
        // Samples 1 and 3 alternating, 16 of them: mean 2, sample variance 16/15, so the
        // standard error is sqrt(16/15/16) per channel; three channels over three means.
        let film = film_with(1, 1, |_, _| (1.0, 3.0, 16));
        let expected = (16.0f64 / 15.0 / 16.0).sqrt() * 3.0 / 6.0;
        let e = pixel_error(&film, 0, 0, ErrorMetric::Relative, 0.0, 16);
        assert!((e - expected).abs() < 1e-6, "{e} vs {expected}");
        // The floor joins the denominator.
        let e = pixel_error(&film, 0, 0, ErrorMetric::Relative, 6.0, 16);
        assert!((e - expected / 2.0).abs() < 1e-6, "{e}");
        // In radiance units: the summed standard errors.
        let e = pixel_error(&film, 0, 0, ErrorMetric::Absolute, 6.0, 16);
        assert!((e - expected * 6.0).abs() < 1e-6, "{e}");
        // Too few samples: not judged.
        assert_eq!(
            pixel_error(&film, 0, 0, ErrorMetric::Relative, 0.0, 17),
            f64::INFINITY
        );
        // Constant samples (black included): no error.
        let film = film_with(2, 1, |x, _| (x as f64, x as f64, 16));
        assert_eq!(
            pixel_error(&film, 0, 0, ErrorMetric::Relative, 0.0, 16),
            0.0
        );
        assert_eq!(
            pixel_error(&film, 1, 0, ErrorMetric::Relative, 0.0, 16),
            0.0
        );
    }

    #[test]
    fn a_noisy_pixel_keeps_its_neighbours_sampling() {
        // 7 × 5, all constant except a noisy pixel at (3, 2).
        let film = film_with(7, 5, |x, y| {
            if (x, y) == (3, 2) {
                (0.0, 2.0, 16)
            } else {
                (1.0, 1.0, 16)
            }
        });
        let mut active = vec![true; 35];
        let still = judge(
            &film,
            (0, 0, 7, 5),
            &mut active,
            ErrorMetric::Relative,
            0.01,
            16,
        )
        .active;
        assert_eq!(still, 9);
        for y in 0..5usize {
            for x in 0..7usize {
                let near = x.abs_diff(3) <= 1 && y.abs_diff(2) <= 1;
                assert_eq!(active[y * 7 + x], near, "pixel ({x}, {y})");
            }
        }
        // A loose target stops them all.
        assert_eq!(
            judge(
                &film,
                (0, 0, 7, 5),
                &mut active,
                ErrorMetric::Relative,
                10.0,
                16
            )
            .active,
            0
        );
        assert!(active.iter().all(|&a| !a));
    }

    #[test]
    fn stopped_pixels_stay_stopped_and_the_window_bounds_the_judgement() {
        let film = film_with(4, 4, |_, _| (0.0, 2.0, 16));
        // Only the window (1, 1)–(3, 3) is active; a converged pixel outside it is ignored.
        let mut active = vec![false; 16];
        for (x, y) in [(1, 1), (2, 1), (1, 2), (2, 2)] {
            active[y * 4 + x] = true;
        }
        let still = judge(
            &film,
            (1, 1, 3, 3),
            &mut active,
            ErrorMetric::Relative,
            0.01,
            16,
        )
        .active;
        assert_eq!(still, 4);
        assert_eq!(active.iter().filter(|&&a| a).count(), 4);
        // Pixels under the minimum count stay active whatever the target.
        let mut active = vec![true; 16];
        assert_eq!(
            judge(
                &film,
                (0, 0, 4, 4),
                &mut active,
                ErrorMetric::Relative,
                1e9,
                32
            )
            .active,
            16
        );
    }

    #[test]
    fn the_time_limited_selection_takes_the_largest_gains() {
        // One row: pixel x has 16 samples 1 ± x/10, except pixel 0, which has only 4 (under
        // the minimum of 16, so its error is +∞ and it is always selected).
        let film = film_with(9, 1, |x, _| {
            let d = x as f64 / 10.0;
            (1.0 - d, 1.0 + d, if x == 0 { 4 } else { 16 })
        });
        let mut active = vec![true; 9];
        let judged = judge(
            &film,
            (0, 0, 9, 1),
            &mut active,
            ErrorMetric::Absolute,
            1e-9,
            16,
        );
        assert_eq!(judged.active, 9);
        let mut selected = vec![false; 9];
        select_most_useful(&film, (0, 0, 9, 1), &active, &judged, &mut selected);
        // Dilated errors: pixel 1 sees pixel 0's +∞; pixels 2..=7 see their right neighbour's
        // e(x + 1); pixel 8 its own. The gains e²/16 in order: e3 … e8, e8, ∞, ∞; the median
        // (the 5th of 9) is e7², so pixels 6, 7, 8 and the two infinite ones are selected.
        let picked: Vec<usize> = (0..9).filter(|&i| selected[i]).collect();
        assert_eq!(picked, vec![0, 1, 6, 7, 8]);
        // Inactive pixels are never selected.
        active[8] = false;
        select_most_useful(&film, (0, 0, 9, 1), &active, &judged, &mut selected);
        assert!(!selected[8]);
        assert!(selected[0] && selected[7] && !selected[5]);
    }

    #[test]
    fn the_floor_is_a_fraction_of_the_mean() {
        let film = film_with(2, 1, |x, _| (x as f64 * 2.0, x as f64 * 2.0, 4));
        // Channel sums 0 and 6: mean 3.
        assert!((error_floor(&film, (0, 0, 2, 1)) - 3.0 * FLOOR_FRACTION).abs() < 1e-12);
        assert!((error_floor(&film, (1, 0, 2, 1)) - 6.0 * FLOOR_FRACTION).abs() < 1e-12);
    }
}
