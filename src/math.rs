//! Polynomial transcendental functions, written once over [`Real`] so that a path's result
//! does not depend on the width it ran at, the thread, the shard or the machine's libm.
//!
//! - `atan2` and `acos`: Abramowitz and Stegun (Handbook of Mathematical Functions, 1964)
//!   4.4.49 for arctan on [0, 1] and 4.4.46 for arccos on [0, 1], each |ε| ≤ 2·10⁻⁸ in exact
//!   arithmetic. Evaluated in f32, rounding dominates: `atan2` is within 4·10⁻⁷ rad of the
//!   exact value and `acos` within 5·10⁻⁷ rad (tested below against f64 over dense sweeps).
//! - `sin_cos`: Cody and Waite's reduction by π/2 in three parts (Cody & Waite, Software
//!   Manual for the Elementary Functions, 1980, ch. 8), then the Taylor polynomials of
//!   [`sin_cos_quarter`] on [−π/4, π/4] and the quadrant's swap and signs.
//! - `exp`: x = k ln 2 + r, |r| ≤ ln 2 / 2 (Cody and Waite's two-part ln 2), eᵣ by its Taylor
//!   polynomial through r⁷ and 2ᵏ built in the exponent bits.
//! - `log`: x = 2ᵉ m with m in [√½, √2), ln m = 2 atanh(s), s = (m − 1)/(m + 1), by its
//!   series through s⁹ (|s| ≤ 0.172).
//! - `pow`: exp(y ln x).
//!
//! Each is tested against f64 over dense sweeps, with the bounds stated on the function.

use crate::lanes::{Bits, Real};
use std::f32::consts::{FRAC_2_PI, FRAC_PI_2, LOG2_E, PI};

/// arctan on [0, 1] (A&S 4.4.49): x·(1 + a₂x² + … + a₁₆x¹⁶).
#[inline(always)]
fn atan_unit<R: Real>(x: R) -> R {
    const A: [f32; 8] = [
        -0.333_331_45,
        0.199_935_51,
        -0.142_089,
        0.106_562_64,
        -0.075_289_64,
        0.042_909_614,
        -0.016_165_737,
        0.002_866_225_7,
    ];
    // Estrin's scheme: the powers side by side, so the chain of dependent operations is
    // five long instead of Horner's sixteen.
    let t = x * x;
    let t2 = t * t;
    let t4 = t2 * t2;
    let q0 = t * A[0] + 1.0;
    let q1 = t * A[2] + A[1];
    let q2 = t * A[4] + A[3];
    let q3 = t * A[6] + A[5];
    let p = (q0 + q1 * t2) + (q2 + q3 * t2) * t4 + (t4 * t4) * A[7];
    x * p
}

/// The angle of (x, y) from the +x axis in (−π, π], as `f32::atan2(y, x)`: 0 for (0, 0).
#[inline(always)]
pub fn atan2<R: Real>(y: R, x: R) -> R {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    // The octant's angle, from the ratio in [0, 1]; 0/0 is taken as 0.
    let a = atan_unit(R::select(hi.gt(R::ZERO), lo / hi, R::ZERO));
    let a = R::select(ay.gt(ax), R::splat(FRAC_PI_2) - a, a);
    let a = R::select(x.lt(R::ZERO), R::splat(PI) - a, a);
    a.copysign(y)
}

/// arccos on [−1, 1] (A&S 4.4.46 on [0, 1]: √(1 − x)·(a₀ + a₁x + … + a₇x⁷), and
/// arccos(−x) = π − arccos(x)); arguments outside [−1, 1] are clamped.
#[inline(always)]
pub fn acos<R: Real>(x: R) -> R {
    // a₀ = 1.5707963050 rounds to the same f32 as π/2.
    const A: [f32; 8] = [
        FRAC_PI_2,
        -0.214_598_8,
        0.088_978_99,
        -0.050_174_303,
        0.030_891_88,
        -0.017_088_126,
        0.006_670_09,
        -0.001_262_491_1,
    ];
    let ax = x.abs().min(R::ONE);
    // Estrin's scheme, as in `atan_unit`.
    let x2 = ax * ax;
    let q0 = ax * A[1] + A[0];
    let q1 = ax * A[3] + A[2];
    let q2 = ax * A[5] + A[4];
    let q3 = ax * A[7] + A[6];
    let p = (q0 + q1 * x2) + (q2 + q3 * x2) * (x2 * x2);
    let r = (R::ONE - ax).sqrt() * p;
    R::select(x.lt(R::ZERO), R::splat(PI) - r, r)
}

/// (sin φ, cos φ) for |φ| ≤ π/4: the Taylor polynomials through φ⁹ and φ¹⁰, whose first
/// omitted terms, φ¹¹/11! and φ¹²/12!, are below 2e-9 there (a thirtieth of an f32 ulp at
/// 0.7); the result is within 2 ulps of the exact values (tested against f64).
#[inline(always)]
pub fn sin_cos_quarter<R: Real>(phi: R) -> (R, R) {
    let x2 = phi * phi;
    let s = phi
        * ((x2
            * ((x2 * ((x2 * ((x2 * (1.0 / 362_880.0)) + (-1.0 / 5040.0))) + (1.0 / 120.0)))
                + (-1.0 / 6.0)))
            + 1.0);
    let c = (x2
        * ((x2
            * ((x2
                * ((x2 * ((x2 * (-1.0 / 3_628_800.0)) + (1.0 / 40_320.0))) + (-1.0 / 720.0)))
                + (1.0 / 24.0)))
            + (-0.5)))
        + 1.0;
    (s, c)
}

/// (sin x, cos x). Within 1.2·10⁻⁷ of the exact values for |x| ≤ 2π and 5·10⁻⁷ for
/// |x| ≤ 10⁴ (tested); the reduction loses accuracy beyond |x| ≈ 10⁵, where no renderer's
/// angle lives. NaN and infinities give NaN.
#[inline(always)]
pub fn sin_cos<R: Real>(x: R) -> (R, R) {
    // π/2 in three parts, the first two with few enough bits that k·P1 and k·P2 are exact
    // for the quadrant numbers k of |x| ≤ 10⁵ (Cody & Waite).
    const P1: f32 = 1.570_312_5;
    const P2: f32 = 4.837_513e-4;
    const P3: f32 = 7.549_79e-8;
    let k = (x * FRAC_2_PI + 0.5).floor();
    let r = ((x - k * P1) - k * P2) - k * P3;
    let (s, c) = sin_cos_quarter(r);
    // The quadrant k mod 4: odd ones swap sine and cosine; sin is negated in quadrants 2
    // and 3, cos in 1 and 2.
    let q = k.trunc_i32();
    let one = R::Bits::splat(1);
    let swap = (q & one).eq(one);
    let sign = |b: R::Bits| (b & R::Bits::splat(2)).shl(30);
    let sin = R::from_bits(R::select(swap, c, s).to_bits() ^ sign(q));
    let cos = R::from_bits(R::select(swap, s, c).to_bits() ^ sign(q.wrapping_add(one)));
    (sin, cos)
}

/// eˣ, within 2 ulps (relative 1.2·10⁻⁷) for x in [−87, 88.7] (tested); 0 below −87.3
/// (where eˣ would be subnormal) and +∞ above 88.72. NaN gives NaN.
#[inline(always)]
pub fn exp<R: Real>(x: R) -> R {
    // ln 2 in two parts: k·LN2_HI is exact for the |k| ≤ 128 that reach here.
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    const LO: f32 = -87.3;
    const HI: f32 = 88.72;
    let xc = x.clamp(R::splat(LO), R::splat(HI));
    let k = (xc * LOG2_E + 0.5).floor();
    let r = (xc - k * LN2_HI) - k * LN2_LO;
    // eʳ for |r| ≤ 0.35: the Taylor polynomial through r⁷, whose first omitted term is
    // below 6·10⁻⁹.
    let p = (r
        * ((r
            * ((r
                * ((r * ((r * ((r * (1.0 / 5040.0)) + (1.0 / 720.0))) + (1.0 / 120.0)))
                    + (1.0 / 24.0)))
                + (1.0 / 6.0)))
            + 0.5))
        + 1.0;
    let p = r * p + 1.0;
    // 2ᵏ from its exponent bits (k in [−126, 128]: 2¹²⁸ is split as 2·2¹²⁷).
    let k1 = k.trunc_i32();
    let big = k1.eq(R::Bits::splat(128));
    let k1 = R::Bits::select(big, R::Bits::splat(127), k1);
    let scale = R::from_bits(k1.wrapping_add(R::Bits::splat(127)).shl(23));
    let y = p * scale;
    let y = R::select(big, y * 2.0, y);
    let y = R::select(x.lt(R::splat(LO)), R::ZERO, y);
    let y = R::select(x.gt(R::splat(HI)), R::splat(f32::INFINITY), y);
    // A NaN argument: the clamp above made it finite, so it is put back.
    R::select(x.ne(x), x, y)
}

/// ln x, within 2·10⁻⁷ absolute for x in [½, 2] and 2 ulps relative elsewhere (tested); −∞
/// at 0, NaN below 0 and for NaN, +∞ at +∞. Subnormal arguments are exact inputs too.
#[inline(always)]
pub fn log<R: Real>(x: R) -> R {
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    // Subnormals scaled into the normal range by 2²⁴, their exponent corrected below.
    let tiny = x.lt(R::splat(f32::MIN_POSITIVE));
    let xs = R::select(tiny, x * 16_777_216.0, x);
    let bits = xs.to_bits();
    // x = 2ᵉ m, m in [1, 2); then m in [√½, √2) by moving a factor 2 into e.
    let e = R::from_i32(bits.shr(23).wrapping_sub(R::Bits::splat(127)));
    let e = R::select(tiny, e - 24.0, e);
    let m = R::from_bits((bits & R::Bits::splat(0x007f_ffff)) | R::Bits::splat(0x3f80_0000));
    let high = m.gt(R::splat(std::f32::consts::SQRT_2));
    let m = R::select(high, m * 0.5, m);
    let e = R::select(high, e + 1.0, e);
    // ln m = 2 atanh(s) = 2 (s + s³/3 + s⁵/5 + s⁷/7 + s⁹/9 + …), |s| ≤ 0.172; the first
    // omitted term, 2 s¹¹/11, is below 4·10⁻¹⁰.
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let series =
        s2 * ((s2 * ((s2 * ((s2 * (2.0 / 9.0)) + (2.0 / 7.0))) + (2.0 / 5.0))) + (2.0 / 3.0));
    let ln_m = s * 2.0 + s * series;
    let y = e * LN2_HI + (e * LN2_LO + ln_m);
    let y = R::select(x.eq(R::ZERO), R::splat(f32::NEG_INFINITY), y);
    let y = R::select(x.eq(R::splat(f32::INFINITY)), x, y);
    // Negative arguments and NaN.
    R::select(x.lt(R::ZERO) | x.ne(x), R::splat(f32::NAN), y)
}

/// xʸ = exp(y ln x) for x ≥ 0: the relative error grows with |y ln x| (about
/// (1 + |y ln x|)·1.2·10⁻⁷); 0ʸ is 0 for y > 0, 1 for y = 0 and +∞ for y < 0. Negative x gives
/// NaN.
#[inline(always)]
pub fn pow<R: Real>(x: R, y: R) -> R {
    let r = exp(y * log(x));
    // exp(0 · −∞) is NaN: x⁰ = 1 for every x.
    R::select(y.eq(R::ZERO), R::ONE, r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every direction of a fine circle, and points near the axes and the diagonals, at
    /// several radii: within 4e-7 rad of f64's atan2, and the quadrants' signs right.
    #[test]
    fn atan2_is_within_its_bound_everywhere() {
        let mut worst = 0.0f64;
        let n = 1 << 20;
        for i in 0..n {
            let t = (i as f64 + 0.5) / n as f64 * std::f64::consts::TAU - std::f64::consts::PI;
            for r in [1e-30f64, 1e-3, 1.0, 7.0e5, 1e30] {
                let (y, x) = ((t.sin() * r) as f32, (t.cos() * r) as f32);
                let exact = (y as f64).atan2(x as f64);
                let got = atan2(y, x) as f64;
                worst = worst.max((got - exact).abs());
            }
        }
        assert!(worst <= 4e-7, "worst error {worst:e} rad");
        // The axes and the signed zeros as std has them (−π only for (−0, x < 0)).
        for (y, x) in [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0), (0.0, 0.0)] {
            assert!((atan2(y, x) - y.atan2(x)).abs() <= 4e-7, "({y}, {x})");
        }
        assert_eq!(atan2(-0.0, -1.0), -PI);
    }

    /// A negative control: dropping the polynomial's last term breaks the bound.
    #[test]
    fn the_bound_would_catch_a_missing_term() {
        let truncated = |x: f32| {
            let x2 = x * x;
            x * (1.0 - 0.333_331_45 * x2 + 0.199_935_51 * x2 * x2)
        };
        let worst = (0..1000)
            .map(|i| i as f32 / 999.0)
            .map(|x| (truncated(x) as f64 - (x as f64).atan()).abs())
            .fold(0.0, f64::max);
        assert!(worst > 4e-7, "{worst}");
    }

    #[test]
    fn acos_is_within_its_bound_everywhere() {
        let mut worst = 0.0f64;
        let n = 1 << 22;
        for i in 0..=n {
            let x = (2.0 * i as f64 / n as f64 - 1.0) as f32;
            worst = worst.max((acos(x) as f64 - (x as f64).acos()).abs());
        }
        // Near ±1, where arccos is steepest, every f32 of the last few thousand ulps.
        let mut x = 1.0f32;
        for _ in 0..100_000 {
            x = f32::from_bits(x.to_bits() - 1);
            for s in [x, -x] {
                worst = worst.max((acos(s) as f64 - (s as f64).acos()).abs());
            }
        }
        assert!(worst <= 5e-7, "worst error {worst:e} rad");
        assert_eq!(acos(1.0), 0.0);
        assert_eq!(acos(-1.0), PI);
        assert_eq!(acos(2.0), 0.0, "clamped");
    }
    /// Relative error in units of f32's epsilon at `exact`'s magnitude (absolute below 1).
    fn ulps(got: f32, exact: f64) -> f64 {
        (got as f64 - exact).abs() / (exact.abs().max(1e-30) * f32::EPSILON as f64)
    }

    #[test]
    fn sin_cos_is_within_its_bounds() {
        let mut worst = [0.0f64; 2];
        let n = 1 << 21;
        for i in 0..=n {
            let t = 2.0 * i as f64 / n as f64 - 1.0;
            for (range, w) in [(std::f64::consts::TAU, 0), (1e4, 1)] {
                let x = (t * range) as f32;
                let (s, c) = sin_cos(x);
                let (es, ec) = (x as f64).sin_cos();
                worst[w] = worst[w]
                    .max((s as f64 - es).abs())
                    .max((c as f64 - ec).abs());
            }
        }
        assert!(worst[0] <= 1.2e-7, "|x| <= 2π: worst {:e}", worst[0]);
        assert!(worst[1] <= 5e-7, "|x| <= 1e4: worst {:e}", worst[1]);
        assert_eq!(sin_cos(0.0f32), (0.0, 1.0));
        assert!(sin_cos(f32::NAN).0.is_nan() && sin_cos(f32::INFINITY).1.is_nan());
    }

    /// A negative control: a reduction by π/2 in one part is off by far more than the bound
    /// at |x| near 10⁴.
    #[test]
    fn the_sin_bound_would_catch_a_one_part_reduction() {
        let x = 9_999.5f32;
        let k = (x * FRAC_2_PI + 0.5).floor();
        let (s, _) = sin_cos_quarter(x - k * FRAC_PI_2);
        let exact = (x as f64).sin();
        // k = 6366 is even and ≡ 2 (mod 4): sin is the negated quarter sine.
        assert_eq!(k as i32 % 4, 2);
        assert!(
            (-s as f64 - exact).abs() > 5e-7,
            "{}",
            (-s as f64 - exact).abs()
        );
    }

    #[test]
    fn exp_is_within_its_bound() {
        let mut worst = 0.0f64;
        let n = 1 << 21;
        for i in 0..=n {
            let x = (-87.0 + 175.7 * i as f64 / n as f64) as f32;
            worst = worst.max(ulps(exp(x), (x as f64).exp()));
        }
        assert!(worst <= 2.0, "worst {worst} ulps");
        assert_eq!(exp(0.0f32), 1.0);
        assert_eq!(exp(-100.0f32), 0.0);
        assert_eq!(exp(89.0f32), f32::INFINITY);
        assert_eq!(exp(f32::NEG_INFINITY), 0.0);
        assert!(exp(f32::NAN).is_nan());
        assert!(exp(88.7f32).is_finite() && exp(88.7f32) > 3.2e38);
    }

    #[test]
    fn log_is_within_its_bound() {
        let mut worst = [0.0f64; 2];
        // Every 64th f32 from the smallest subnormal to the largest finite.
        let mut bits = 1u32;
        while bits < f32::MAX.to_bits() {
            let x = f32::from_bits(bits);
            let exact = (x as f64).ln();
            if (0.5..=2.0).contains(&x) {
                worst[0] = worst[0].max((log(x) as f64 - exact).abs());
            } else {
                worst[1] = worst[1].max(ulps(log(x), exact));
            }
            bits += 64;
        }
        assert!(worst[0] <= 2e-7, "near 1: worst {:e}", worst[0]);
        assert!(worst[1] <= 2.0, "elsewhere: worst {} ulps", worst[1]);
        assert_eq!(log(1.0f32), 0.0);
        assert_eq!(log(0.0f32), f32::NEG_INFINITY);
        assert_eq!(log(f32::INFINITY), f32::INFINITY);
        assert!(log(-1.0f32).is_nan() && log(f32::NAN).is_nan());
    }

    #[test]
    fn pow_is_within_its_bound() {
        let mut next = crate::sampling::hash::uniform_sequence(11);
        for _ in 0..200_000 {
            let x = next() * 4.0;
            let y = next() * 10.0 - 5.0;
            let exact = (x as f64).powf(y as f64);
            if !(1e-37..=1e37).contains(&exact) {
                continue;
            }
            let bound = (1.0 + (y as f64 * (x as f64).ln()).abs()) * 1.5;
            assert!(ulps(pow(x, y), exact) <= bound, "{x}^{y}");
        }
        assert_eq!(pow(0.0f32, 2.0), 0.0);
        assert_eq!(pow(0.0f32, 0.0), 1.0);
        assert_eq!(pow(0.0f32, -1.0), f32::INFINITY);
        assert_eq!(pow(2.0f32, 3.0), 8.0);
    }

    /// Each function at eight lanes, in and out of the AVX2 dispatch, has the bits of the
    /// same function at one lane, over wide ranges of arguments.
    #[test]
    fn every_width_gives_the_same_bits() {
        #[inline(always)]
        fn kernel<R: Real>([a, b]: [R; 2]) -> [R; 8] {
            let (s, c) = sin_cos(a);
            [
                atan2(a, b),
                acos(b),
                s,
                c,
                exp(a),
                log(a),
                log(b),
                pow(a.abs(), b),
            ]
        }
        let mut next = crate::sampling::hash::uniform_sequence(5);
        let inputs = (0..16_000).map(|_| [next() * 200.0 - 100.0, next() * 4.0 - 1.0]);
        crate::lanes::assert_same_bits_at_every_width!(kernel: [2] -> [8], inputs);
    }
}
