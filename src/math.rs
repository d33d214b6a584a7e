//! Polynomial inverse trigonometry for lookups that run once per ray: the same code on every
//! thread, shard and machine, so a result never depends on which libm the binary met.
//!
//! The polynomials are Abramowitz and Stegun's (Handbook of Mathematical Functions, 1964):
//! 4.4.49 for arctan on [0, 1] and 4.4.46 for arccos on [0, 1], each |ε| ≤ 2·10⁻⁸ in exact
//! arithmetic. Evaluated in f32, rounding dominates: `atan2` is within 4·10⁻⁷ rad of the
//! exact value and `acos` within 5·10⁻⁷ rad (tested below against f64 over dense sweeps).

use std::f32::consts::{FRAC_PI_2, PI};

/// arctan on [0, 1] (A&S 4.4.49): x·(1 + a₂x² + … + a₁₆x¹⁶).
#[inline]
fn atan_unit(x: f32) -> f32 {
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
    let q0 = A[0] * t + 1.0;
    let q1 = A[2] * t + A[1];
    let q2 = A[4] * t + A[3];
    let q3 = A[6] * t + A[5];
    let p = (q0 + q1 * t2) + (q2 + q3 * t2) * t4 + A[7] * (t4 * t4);
    x * p
}

/// The angle of (x, y) from the +x axis in (−π, π], as `f32::atan2(y, x)`: 0 for (0, 0).
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    // The octant's angle, from the ratio in [0, 1]; 0/0 is taken as 0.
    let a = atan_unit(if hi > 0.0 { lo / hi } else { 0.0 });
    let a = if ay > ax { FRAC_PI_2 - a } else { a };
    let a = if x < 0.0 { PI - a } else { a };
    a.copysign(y)
}

/// arccos on [−1, 1] (A&S 4.4.46 on [0, 1]: √(1 − x)·(a₀ + a₁x + … + a₇x⁷), and
/// arccos(−x) = π − arccos(x)); arguments outside [−1, 1] are clamped.
#[inline]
pub fn acos(x: f32) -> f32 {
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
    let ax = x.abs().min(1.0);
    // Estrin's scheme, as in `atan_unit`.
    let x2 = ax * ax;
    let q0 = A[1] * ax + A[0];
    let q1 = A[3] * ax + A[2];
    let q2 = A[5] * ax + A[4];
    let q3 = A[7] * ax + A[6];
    let p = (q0 + q1 * x2) + (q2 + q3 * x2) * (x2 * x2);
    let r = (1.0 - ax).sqrt() * p;
    if x < 0.0 {
        PI - r
    } else {
        r
    }
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
}
