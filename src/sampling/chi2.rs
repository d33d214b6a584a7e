//! Pearson's χ² goodness-of-fit test, as strata's sampling tests and the sampling pictures
//! (`sampling-pictures`) use it: observed against expected counts per cell, cells expected to
//! hold fewer than [`MIN_EXPECTED`] samples pooled (the method of Mitsuba 3's `ChiSquareTest`
//! and pbrt's `sampling_test`), and the p-value from the χ² distribution.
//!
//! The distribution is the regularized upper incomplete gamma function Q(a, x) = Γ(a, x)/Γ(a),
//! after Numerical Recipes (Press, Teukolsky, Vetterling & Flannery, 3rd ed., §6.2): the series
//! for P(a, x) when x < a + 1, the continued fraction for Q(a, x) evaluated with the modified
//! Lentz method otherwise. ln Γ uses the Lanczos approximation (g = 7, n = 9, Godfrey's
//! coefficients; NR §6.1 describes the method).

use std::f64::consts::PI;

/// Cells expected to hold fewer samples than this are pooled.
pub const MIN_EXPECTED: f64 = 5.0;

/// ln Γ(x) for x ≥ 0.5 (a smaller x panics: nothing here needs one).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const COEF: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    assert!(
        x >= 0.5,
        "ln_gamma is only needed (and only valid here) for x ≥ 0.5"
    );
    let x = x - 1.0;
    let mut a = COEF[0];
    for (i, c) in COEF.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    let t = x + G + 0.5;
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

const GAMMA_EPS: f64 = 1e-15;
const GAMMA_MAX_ITER: usize = 100_000;

/// P(a, x) by its series (NR `gser`); converges quickly for x < a + 1.
fn gamma_p_series(a: f64, x: f64) -> f64 {
    let mut ap = a;
    let mut del = 1.0 / a;
    let mut sum = del;
    for _ in 0..GAMMA_MAX_ITER {
        ap += 1.0;
        del *= x / ap;
        sum += del;
        if del.abs() < sum.abs() * GAMMA_EPS {
            return sum * (-x + a * x.ln() - ln_gamma(a)).exp();
        }
    }
    panic!("gamma_p_series({a}, {x}) did not converge");
}

/// Q(a, x) by its continued fraction, modified Lentz (NR `gcf`); for x ≥ a + 1.
fn gamma_q_continued_fraction(a: f64, x: f64) -> f64 {
    const FPMIN: f64 = 1e-300;
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / FPMIN;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..GAMMA_MAX_ITER {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < FPMIN {
            d = FPMIN;
        }
        c = b + an / c;
        if c.abs() < FPMIN {
            c = FPMIN;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < GAMMA_EPS {
            return (-x + a * x.ln() - ln_gamma(a)).exp() * h;
        }
    }
    panic!("gamma_q_continued_fraction({a}, {x}) did not converge");
}

/// The regularized upper incomplete gamma function Q(a, x), for a > 0 and x ≥ 0 (others
/// panic).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    assert!(a > 0.0 && x >= 0.0, "gamma_q({a}, {x})");
    if x == 0.0 {
        1.0
    } else if x < a + 1.0 {
        1.0 - gamma_p_series(a, x)
    } else {
        gamma_q_continued_fraction(a, x)
    }
}

/// P(X ≥ x) for X ~ χ²(dof).
pub fn chi2_survival(x: f64, dof: usize) -> f64 {
    gamma_q(dof as f64 / 2.0, x / 2.0)
}

/// The outcome of [`chi2_test`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chi2Outcome {
    /// Pearson's statistic Σ (observed − expected)² / expected.
    pub statistic: f64,
    /// Degrees of freedom: the cells after pooling, less one.
    pub dof: usize,
    /// P(χ²(dof) ≥ statistic): small when the samples do not follow the pdf.
    pub p_value: f64,
}

/// Pearson's χ² test of observed against expected counts. Cells with expected count below
/// [`MIN_EXPECTED`] are pooled (smallest first, as Mitsuba 3 does) until the pool reaches
/// it. A sample in a cell of expected count 0 is an error: the pdf says it cannot happen.
pub fn chi2_test(observed: &[f64], expected: &[f64]) -> Result<Chi2Outcome, String> {
    assert_eq!(observed.len(), expected.len());
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pooled_obs, mut pooled_exp, mut pooled_cells) = (0.0, 0.0, 0usize);
    let (mut statistic, mut cells) = (0.0, 0usize);
    for &i in &order {
        let (obs, exp) = (observed[i], expected[i]);
        if exp == 0.0 {
            if obs > 0.0 {
                return Err(format!(
                    "{obs} samples in cell {i}, whose expected count is 0"
                ));
            }
            continue;
        }
        if exp < MIN_EXPECTED || (pooled_cells > 0 && pooled_exp < MIN_EXPECTED) {
            pooled_obs += obs;
            pooled_exp += exp;
            pooled_cells += 1;
        } else {
            statistic += (obs - exp) * (obs - exp) / exp;
            cells += 1;
        }
    }
    if pooled_cells > 0 {
        statistic += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
        cells += 1;
    }
    if cells < 2 {
        return Err("fewer than two cells: no degrees of freedom".into());
    }
    let dof = cells - 1;
    Ok(Chi2Outcome {
        statistic,
        dof,
        p_value: chi2_survival(statistic, dof),
    })
}
