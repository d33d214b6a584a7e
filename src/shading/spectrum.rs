//! Colour: the luminance by which every module weighs an RGB value ([`luminance`]), and
//! wavelengths for dispersion (`KHR_materials_dispersion`): strata renders in linear sRGB, and
//! a path that meets a dispersive interface carries one wavelength from then on, drawn at its
//! first such interface, its throughput weighted so that each RGB channel's expectation is the
//! light the channel sees.
//!
//! - The channels' responses: the CIE 1931 colour-matching functions by the multi-lobe
//!   piecewise Gaussian fit of Wyman, Sloan & Shirley 2013 ("Simple Analytic Approximations to
//!   the CIE XYZ Color Matching Functions", JCGT 2(2), eq. 2), taken to linear sRGB by the
//!   XYZ → sRGB (D65) matrix of IEC 61966-2-1, negative lobes clipped, each channel then scaled
//!   to unit integral over 380–780 nm: r(λ), g(λ), b(λ).
//! - The wavelength is drawn with pdf p(λ) = (r + g + b)(λ) / 3, piecewise constant over 1 nm
//!   bins, and the path's throughput multiplied by (r, g, b)(λ) / p(λ), whose expectation is
//!   (1, 1, 1): white light stays white, and each channel integrates its own response.
//! - The index of refraction at λ (KHR_materials_dispersion, Cauchy's two terms):
//!   n(λ) = max(n_d + (n_d − 1) / V_d (523655 / λ² − 1.5168), 1), V_d = 20 / dispersion the
//!   Abbe number and n_d the material's `ior` (at 587.6 nm).

use crate::lanes::{Real, Vec3L};
use glam::Vec3;

/// Relative luminance of linear Rec.709 RGB.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    luminance_lanes(c.into())
}

/// [`luminance`] at any width.
#[inline(always)]
pub fn luminance_lanes<R: Real>(c: Vec3L<R>) -> R {
    c.x * 0.2126 + c.y * 0.7152 + c.z * 0.0722
}

/// The range of wavelengths drawn, in nm.
pub const LAMBDA_MIN: f32 = 380.0;
pub const LAMBDA_MAX: f32 = 780.0;
const BINS: usize = (LAMBDA_MAX - LAMBDA_MIN) as usize;

/// A piecewise Gaussian: exp(−t²/2) with t = (λ − μ) × (1/σ below μ, 1/σ' above).
#[inline]
fn lobe(lambda: f64, mu: f64, inv_below: f64, inv_above: f64) -> f64 {
    let t = (lambda - mu) * if lambda < mu { inv_below } else { inv_above };
    (-0.5 * t * t).exp()
}

/// The CIE 1931 2° colour-matching functions (x̄, ȳ, z̄) at `lambda` nm, by Wyman, Sloan &
/// Shirley's multi-lobe fit (JCGT 2013, eq. 2).
pub fn cie_1931(lambda: f64) -> [f64; 3] {
    let x = 0.362 * lobe(lambda, 442.0, 0.0624, 0.0374)
        + 1.056 * lobe(lambda, 599.8, 0.0264, 0.0323)
        - 0.065 * lobe(lambda, 501.1, 0.0490, 0.0382);
    let y =
        0.821 * lobe(lambda, 568.8, 0.0213, 0.0247) + 0.286 * lobe(lambda, 530.9, 0.0613, 0.0322);
    let z =
        1.217 * lobe(lambda, 437.0, 0.0845, 0.0278) + 0.681 * lobe(lambda, 459.0, 0.0385, 0.0725);
    [x, y, z]
}

/// The linear sRGB channels' responses, tabulated per 1 nm bin with the sampling
/// distribution over the bins (see the module documentation).
pub struct Response {
    /// (r, g, b) at each bin's centre, each channel of unit integral over the range.
    rgb: Vec<Vec3>,
    /// The pdf in each bin, (r + g + b) / 3, per nm.
    pdf: Vec<f32>,
    /// The cumulative distribution at each bin's upper edge.
    cdf: Vec<f32>,
}

impl Response {
    /// The process's table (made on first use, microseconds).
    pub fn get() -> &'static Response {
        static TABLE: std::sync::OnceLock<Response> = std::sync::OnceLock::new();
        TABLE.get_or_init(Response::compute)
    }

    fn compute() -> Response {
        // XYZ to linear sRGB, D65 (IEC 61966-2-1).
        const M: [[f64; 3]; 3] = [
            [3.2406, -1.5372, -0.4986],
            [-0.9689, 1.8758, 0.0415],
            [0.0557, -0.2040, 1.0570],
        ];
        let raw: Vec<[f64; 3]> = (0..BINS)
            .map(|i| {
                let xyz = cie_1931(LAMBDA_MIN as f64 + i as f64 + 0.5);
                M.map(|row| (row[0] * xyz[0] + row[1] * xyz[1] + row[2] * xyz[2]).max(0.0))
            })
            .collect();
        // Each channel to unit integral (bins are 1 nm wide).
        let totals: [f64; 3] = std::array::from_fn(|c| raw.iter().map(|v| v[c]).sum::<f64>());
        let rgb: Vec<[f64; 3]> = raw
            .iter()
            .map(|v| std::array::from_fn(|c| v[c] / totals[c]))
            .collect();
        let pdf: Vec<f64> = rgb.iter().map(|v| (v[0] + v[1] + v[2]) / 3.0).collect();
        let mut cdf = Vec::with_capacity(BINS);
        let mut sum = 0.0f64;
        for p in &pdf {
            sum += p;
            cdf.push(sum as f32);
        }
        Response {
            rgb: rgb
                .iter()
                .map(|v| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32))
                .collect(),
            pdf: pdf.iter().map(|&p| p as f32).collect(),
            cdf,
        }
    }

    /// The channels' responses (r, g, b) at `lambda` nm (per nm; zero outside the range).
    pub fn rgb(&self, lambda: f32) -> Vec3 {
        match self.bin(lambda) {
            Some(i) => self.rgb[i],
            None => Vec3::ZERO,
        }
    }

    /// The density of the wavelengths [`Response::sample`] draws, per nm.
    pub fn pdf(&self, lambda: f32) -> f32 {
        match self.bin(lambda) {
            Some(i) => self.pdf[i],
            None => 0.0,
        }
    }

    fn bin(&self, lambda: f32) -> Option<usize> {
        let x = lambda - LAMBDA_MIN;
        (x >= 0.0 && lambda < LAMBDA_MAX).then(|| (x as usize).min(BINS - 1))
    }

    /// A wavelength drawn from `u` in [0, 1) with density [`Response::pdf`], and the weight
    /// (r, g, b)(λ) / p(λ) a path's throughput takes for it.
    pub fn sample(&self, u: f32) -> (f32, Vec3) {
        let total = self.cdf[BINS - 1];
        let target = u.clamp(0.0, 1.0) * total;
        // The first bin whose upper edge reaches the target.
        let i = self.cdf.partition_point(|&c| c < target).min(BINS - 1);
        let below = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let width = self.cdf[i] - below;
        let within = match width > 0.0 {
            true => ((target - below) / width).clamp(0.0, 1.0 - f32::EPSILON),
            false => 0.5,
        };
        let lambda = LAMBDA_MIN + i as f32 + within;
        (lambda, self.rgb[i] / (self.pdf[i] / total))
    }
}

/// The index of refraction at `lambda` nm of a material of index `n_d` (at 587.6 nm) and
/// `KHR_materials_dispersion`'s `dispersion` (20 / Abbe number; 0 gives `n_d` everywhere).
#[inline]
pub fn dispersed_ior(n_d: f32, dispersion: f32, lambda: f32) -> f32 {
    if dispersion <= 0.0 {
        return n_d;
    }
    let abbe = 20.0 / dispersion;
    (n_d + (n_d - 1.0) / abbe * (523_655.0 / (lambda * lambda) - 1.5168)).max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Luminance weighs Rec.709's primaries (white is 1, green the largest share), and eight
    /// lanes give the bits of one.
    #[test]
    fn luminance_weighs_the_primaries_at_every_width() {
        assert!((luminance(Vec3::ONE) - 1.0).abs() < 1e-6);
        assert_eq!(luminance(Vec3::Y), 0.7152);
        #[inline(always)]
        fn kernel<R: Real>([r, g, b]: [R; 3]) -> [R; 1] {
            [luminance_lanes(Vec3L::new(r, g, b))]
        }
        let mut next = crate::sampling::hash::uniform_sequence(53);
        let inputs = (0..4096).map(|_| [next() * 8.0, next(), next() * 0.5]);
        crate::lanes::assert_same_bits_at_every_width!(kernel: [3] -> [1], inputs);
    }

    /// The fit against the CIE 1931 2° table at a few wavelengths (values from CIE 15:2004's
    /// table, to the fit's stated accuracy of a few hundredths).
    #[test]
    fn the_fit_follows_the_cie_table() {
        let table = [
            (450.0, [0.3362, 0.0380, 1.7721]),
            (500.0, [0.0049, 0.3230, 0.2720]),
            (550.0, [0.4334, 0.9950, 0.0087]),
            (600.0, [1.0622, 0.6310, 0.0008]),
            (650.0, [0.2835, 0.1070, 0.0000]),
        ];
        for (lambda, want) in table {
            let got = cie_1931(lambda);
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < 0.05 * want[c].max(0.5),
                    "{lambda} nm, channel {c}: {} against {}",
                    got[c],
                    want[c]
                );
            }
        }
    }

    /// Each channel's response integrates to 1, red peaks in the reds and blue in the blues,
    /// and the weights average to white: the mean of (r, g, b)(λ)/p(λ) over stratified
    /// draws is (1, 1, 1).
    #[test]
    fn the_weights_keep_white_white() {
        let r = Response::get();
        let mut integral = Vec3::ZERO;
        for i in 0..BINS {
            integral += r.rgb(LAMBDA_MIN + i as f32 + 0.5);
        }
        assert!(
            (integral - Vec3::ONE).abs().max_element() < 1e-4,
            "{integral}"
        );
        let peak = |c: usize| {
            (0..BINS)
                .max_by(|&a, &b| r.rgb[a][c].total_cmp(&r.rgb[b][c]))
                .unwrap() as f32
                + LAMBDA_MIN
        };
        assert!(
            (590.0..630.0).contains(&peak(0)),
            "red peaks at {}",
            peak(0)
        );
        assert!(
            (520.0..560.0).contains(&peak(1)),
            "green peaks at {}",
            peak(1)
        );
        assert!(
            (430.0..470.0).contains(&peak(2)),
            "blue peaks at {}",
            peak(2)
        );
        let n = 100_000;
        let mut mean = Vec3::ZERO;
        for k in 0..n {
            let (lambda, w) = r.sample((k as f32 + 0.5) / n as f32);
            assert!((LAMBDA_MIN..LAMBDA_MAX).contains(&lambda));
            mean += w / n as f32;
        }
        assert!((mean - Vec3::ONE).abs().max_element() < 1e-3, "{mean}");
    }

    /// The sampled wavelengths follow the pdf: χ² over 40 bins of 10 nm.
    #[test]
    fn sampled_wavelengths_follow_the_pdf() {
        let r = Response::get();
        let n = 200_000usize;
        let mut observed = vec![0.0f64; 40];
        // A low-discrepancy-free stream: a 64-bit LCG's top bits.
        let mut state = 0x853c_49e6_748f_ea9bu64;
        for _ in 0..n {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (state >> 40) as f32 / (1u64 << 24) as f32;
            let (lambda, _) = r.sample(u);
            observed[((lambda - LAMBDA_MIN) / 10.0) as usize] += 1.0;
        }
        let expected: Vec<f64> = (0..40)
            .map(|b| {
                (0..10)
                    .map(|i| r.pdf(LAMBDA_MIN + (b * 10 + i) as f32 + 0.5) as f64)
                    .sum::<f64>()
                    * n as f64
            })
            .collect();
        let outcome = crate::sampling::chi2::chi2_test(&observed, &expected).unwrap();
        assert!(outcome.p_value > 0.01, "{outcome:?}");
        // Control: the same samples against a uniform pdf.
        let uniform = vec![n as f64 / 40.0; 40];
        let control = crate::sampling::chi2::chi2_test(&observed, &uniform).unwrap();
        assert!(control.p_value < 1e-6, "{control:?}");
    }

    /// Cauchy's law as the extension writes it: n(587.6 nm) is the material's index, and
    /// (n_d − 1) / (n_F − n_C) is the Abbe number 20 / dispersion.
    #[test]
    fn the_index_has_the_abbe_number_it_is_given() {
        for (n_d, dispersion) in [(1.5f32, 0.33f32), (2.42, 0.36), (1.33, 1.0), (1.6, 2.04)] {
            let at = |lambda: f32| dispersed_ior(n_d, dispersion, lambda) as f64;
            assert!(
                (at(587.6) - n_d as f64).abs() < 2e-4,
                "n_d {n_d}: {}",
                at(587.6)
            );
            let abbe = (n_d as f64 - 1.0) / (at(486.1) - at(656.3));
            let want = 20.0 / dispersion as f64;
            assert!(
                (abbe - want).abs() < 2e-3 * want,
                "V_d {abbe} against {want}"
            );
        }
        assert_eq!(dispersed_ior(1.5, 0.0, 400.0), 1.5);
        assert!(dispersed_ior(1.01, 50.0, 780.0) >= 1.0);
    }
}
