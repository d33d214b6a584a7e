//! Error measures of a rendered image against a reference, and the convergence rate of a
//! sequence of them: the arithmetic behind the `convergence` tool (`src/bin/convergence.rs`).
//!
//! A reference is itself a Monte Carlo estimate with its own noise. When its per-pixel
//! variance (of the mean) is known, E[(x − r)²] = E[(x − μ)²] + Var(r) for an image x
//! independent of the reference r, so subtracting the mean reference variance from the MSE
//! removes the reference's share. [`ImageError::mse_corrected`] does that; the raw MSE
//! levels off at the reference's noise floor, the corrected one does not (until its own
//! noise takes over).

/// Error measures of one image against a reference, over all pixels and channels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    /// Mean squared error.
    pub mse: f64,
    /// MSE minus the mean variance of the reference (0 without a variance image); may be
    /// negative when the image is closer to the truth than the reference's noise.
    pub mse_corrected: f64,
    /// Relative MSE: mean of (x − r)² / (r² + ε), ε = [`RELMSE_EPSILON`].
    pub relmse: f64,
    /// Mean absolute error.
    pub mae: f64,
    /// Mean variance of the reference (its noise floor for `mse`).
    pub reference_variance: f64,
}

impl ImageError {
    pub fn rmse(&self) -> f64 {
        self.mse.sqrt()
    }

    /// √max(mse_corrected, 0).
    pub fn rmse_corrected(&self) -> f64 {
        self.mse_corrected.max(0.0).sqrt()
    }

    /// The field-wise mean of `errors` (e.g. over seeds), or `None` for none. The reference
    /// variance is the same for all; the first one's is kept.
    pub fn mean(errors: &[ImageError]) -> Option<ImageError> {
        let first = errors.first()?;
        let k = errors.len() as f64;
        let avg = |f: fn(&ImageError) -> f64| errors.iter().map(f).sum::<f64>() / k;
        Some(ImageError {
            mse: avg(|e| e.mse),
            mse_corrected: avg(|e| e.mse_corrected),
            relmse: avg(|e| e.relmse),
            mae: avg(|e| e.mae),
            reference_variance: first.reference_variance,
        })
    }
}

/// The ε of relative MSE, which keeps dark pixels from dominating (as in Rousselle et al.
/// 2011 and most denoising papers: 10⁻²).
pub const RELMSE_EPSILON: f64 = 1e-2;

/// Compares `image` with `reference` (same size, RGB), using the reference's per-pixel
/// variance of the mean when given. Panics if the sizes differ (callers check first and
/// report which file is wrong).
pub fn image_error(
    image: &[[f32; 3]],
    reference: &[[f32; 3]],
    reference_variance: Option<&[[f32; 3]]>,
) -> ImageError {
    assert_eq!(image.len(), reference.len(), "image and reference sizes");
    let n = (image.len() * 3) as f64;
    let (mut se, mut rel, mut ae) = (0.0, 0.0, 0.0);
    for (x, r) in image.iter().zip(reference) {
        for c in 0..3 {
            let d = x[c] as f64 - r[c] as f64;
            se += d * d;
            rel += d * d / ((r[c] as f64).powi(2) + RELMSE_EPSILON);
            ae += d.abs();
        }
    }
    let var = reference_variance.map_or(0.0, |v| {
        assert_eq!(v.len(), reference.len(), "variance and reference sizes");
        v.iter()
            .flat_map(|p| p.iter())
            .map(|&x| x as f64)
            .sum::<f64>()
            / n
    });
    ImageError {
        mse: se / n,
        mse_corrected: se / n - var,
        relmse: rel / n,
        mae: ae / n,
        reference_variance: var,
    }
}

/// The sample counts of a ladder: 1, 2, 4, … up to and including `max` (a power of two
/// or not: `max` itself ends the ladder).
pub fn spp_ladder(max: u32) -> Vec<u32> {
    let mut out = Vec::new();
    let mut s = 1u32;
    while s < max {
        out.push(s);
        s = s.saturating_mul(2);
    }
    out.push(max.max(1));
    out
}

/// Least-squares slope and intercept of log(y) against log(x), for the points with x > 0 and
/// y > 0; `None` with fewer than two such points or no spread in x.
pub fn log_log_fit(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if logs.len() < 2 {
        return None;
    }
    let n = logs.len() as f64;
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let slope = sxy / sxx;
    Some((slope, my - slope * mx))
}

/// Where a fitted error curve log e = slope·log x + intercept reaches `target`: the x (spp
/// or seconds) at which the error is `target`. `None` for a slope that is not negative.
pub fn reach(slope: f64, intercept: f64, target: f64) -> Option<f64> {
    (slope < 0.0 && target > 0.0).then(|| ((target.ln() - intercept) / slope).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mean_of_errors_averages_every_field() {
        let e = |k: f64| ImageError {
            mse: k,
            mse_corrected: k - 1.0,
            relmse: 2.0 * k,
            mae: 3.0 * k,
            reference_variance: 1.0,
        };
        let m = ImageError::mean(&[e(1.0), e(2.0), e(6.0)]).unwrap();
        assert_eq!(m, e(3.0));
        assert_eq!(ImageError::mean(&[]), None);
    }

    #[test]
    fn errors_of_a_known_difference() {
        let reference = vec![[1.0f32, 0.0, 0.5]; 4];
        let image: Vec<[f32; 3]> = reference
            .iter()
            .map(|p| [p[0] + 0.1, p[1] - 0.2, p[2]])
            .collect();
        let e = image_error(&image, &reference, None);
        // Per pixel: squared errors 0.01, 0.04, 0; absolute 0.1, 0.2, 0.
        assert!((e.mse - 0.05 / 3.0).abs() < 1e-7, "{e:?}");
        assert!((e.mae - 0.3 / 3.0).abs() < 1e-7, "{e:?}");
        let rel = (0.01 / (1.0 + RELMSE_EPSILON) + 0.04 / RELMSE_EPSILON) / 3.0;
        assert!((e.relmse - rel).abs() < 1e-6, "{e:?}");
        assert_eq!(e.mse, e.mse_corrected);
    }

    /// The correction removes the reference's noise: a noise-free image compared with a
    /// noisy reference of known variance has corrected MSE ≈ 0, raw MSE ≈ the variance.
    #[test]
    fn reference_noise_is_subtracted() {
        let n = 200_000;
        let sigma = 0.05f32;
        let mut state = 12345u64;
        let mut gauss = || {
            // Box–Muller from two hashed uniforms.
            let mut u = || {
                state = crate::sampling::hash::mix64(state.wrapping_add(0x9e37_79b9_7f4a_7c15));
                crate::sampling::hash::unit_f32(state) as f64
            };
            let (a, b) = (u(), u());
            ((-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()) as f32
        };
        let truth = vec![[0.5f32; 3]; n];
        let reference: Vec<[f32; 3]> = truth
            .iter()
            .map(|p| {
                [
                    p[0] + sigma * gauss(),
                    p[1] + sigma * gauss(),
                    p[2] + sigma * gauss(),
                ]
            })
            .collect();
        let var = vec![[sigma * sigma; 3]; n];
        let e = image_error(&truth, &reference, Some(&var));
        assert!((e.mse / (sigma * sigma) as f64 - 1.0).abs() < 0.02, "{e:?}");
        assert!(
            e.mse_corrected.abs() < 0.02 * (sigma * sigma) as f64,
            "{e:?}"
        );
    }

    #[test]
    fn ladders_double_and_end_at_the_maximum() {
        assert_eq!(spp_ladder(1), vec![1]);
        assert_eq!(spp_ladder(16), vec![1, 2, 4, 8, 16]);
        assert_eq!(spp_ladder(20), vec![1, 2, 4, 8, 16, 20]);
    }

    #[test]
    fn fits_recover_a_power_law() {
        let pts: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0, 64.0]
            .iter()
            .map(|&x: &f64| (x, 0.3 * x.powf(-0.75)))
            .collect();
        let (slope, intercept) = log_log_fit(&pts).unwrap();
        assert!((slope + 0.75).abs() < 1e-12 && (intercept - 0.3f64.ln()).abs() < 1e-12);
        let x = reach(slope, intercept, 0.3 * 16f64.powf(-0.75)).unwrap();
        assert!((x - 16.0).abs() < 1e-9, "{x}");
        assert_eq!(log_log_fit(&[(1.0, 1.0)]), None);
        assert_eq!(log_log_fit(&[(2.0, 1.0), (2.0, 3.0)]), None);
        assert_eq!(reach(0.5, 0.0, 1.0), None);
    }
}
