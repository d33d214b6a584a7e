//! The PNG preview's view transform: linear radiance, scaled by `--exposure`, to display
//! sRGB. The EXR stays linear; only the preview is tone-mapped.
//!
//! - `agx` (the default, as in Blender 4): Troy Sobotka's AgX, in the closed form Wrensch
//!   fitted to it (2023, "Minimal AgX implementation"): the colour is pulled toward the
//!   achromatic axis by AgX's inset matrix, its log2 taken between −12.47 and +4.03 stops
//!   (about 0.00018 to 16.3 times a scene-linear 1), mapped to [0, 1], shaped by a
//!   polynomial fit of AgX's sigmoid, and brought back by the inverse matrix with a
//!   2.2 power; the result is sRGB-encoded. Highlights roll off toward white instead of
//!   clipping, and saturated lights desaturate as they brighten, as film does.
//! - `standard`: each channel clamped to [0, 1] and sRGB-encoded (Blender's "Standard").

use glam::{Mat3, Vec3};

/// How the preview maps linear radiance to display values (`--view`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum ViewTransform {
    /// AgX (Sobotka; Wrensch's fit): highlights roll off, no clipping.
    #[default]
    Agx,
    /// Clamp to [0, 1] and sRGB-encode.
    Standard,
}

crate::display_as_value_name!(ViewTransform);

/// AgX's inset matrix (Wrensch 2023), acting on linear Rec.709 RGB: its rows sum to 1 within
/// 1.4e-4, so greys stay grey.
const AGX_INSET: Mat3 = Mat3::from_cols_array(&[
    0.842_479_06,
    0.042_328_242,
    0.042_375_655,
    0.078_433_6,
    0.878_468_64,
    0.078_433_6,
    0.079_223_745,
    0.079_166_13,
    0.879_143,
]);

/// The stops AgX spans around a scene-linear 1 (Wrensch 2023).
const AGX_MIN_EV: f32 = -12.473_93;
const AGX_MAX_EV: f32 = 4.026_069;

/// Wrensch's seventh-order fit of AgX's default contrast sigmoid on [0, 1].
fn agx_sigmoid(x: f32) -> f32 {
    // Horner's form of −17.86 x⁷ + 78.01 x⁶ − 126.7 x⁵ + 92.06 x⁴ − 28.72 x³ + 4.361 x²
    // − 0.1718 x + 0.002857.
    ((((((-17.86 * x + 78.01) * x - 126.7) * x + 92.06) * x - 28.72) * x + 4.361) * x - 0.1718) * x
        + 0.002857
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value, clamped to [0, 1] first
/// (non-finite values give 0).
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// A prepared view: the transform and the exposure's scale.
#[derive(Clone, Copy, Debug)]
pub struct Display {
    view: ViewTransform,
    scale: f32,
    inset_inverse: Mat3,
}

impl Display {
    /// `view` after scaling linear values by 2^`exposure`.
    pub fn new(view: ViewTransform, exposure: f32) -> Display {
        Display {
            view,
            scale: exposure.exp2(),
            inset_inverse: AGX_INSET.inverse(),
        }
    }

    /// The display-encoded sRGB value in [0, 1] of linear radiance `rgb`.
    pub fn encode(&self, rgb: Vec3) -> Vec3 {
        let rgb = if rgb.is_finite() { rgb } else { Vec3::ZERO };
        let rgb = rgb * self.scale;
        match self.view {
            ViewTransform::Standard => rgb.to_array().map(linear_to_srgb).into(),
            ViewTransform::Agx => {
                let inset = (AGX_INSET * rgb).max(Vec3::splat(1e-10));
                let t = inset.to_array().map(|c| {
                    let stops = c.log2().clamp(AGX_MIN_EV, AGX_MAX_EV);
                    agx_sigmoid((stops - AGX_MIN_EV) / (AGX_MAX_EV - AGX_MIN_EV))
                });
                // Back out of the inset, to linear by the curve's 2.2 power, then to sRGB.
                let out = (self.inset_inverse * Vec3::from(t)).max(Vec3::ZERO);
                out.to_array().map(|c| linear_to_srgb(c.powf(2.2))).into()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(d: &Display, v: f32) -> f32 {
        let e = d.encode(Vec3::splat(v));
        // Greys stay grey (the inset's rows sum to 1 within 1.4e-4).
        assert!(
            (e.x - e.y).abs() < 2e-3 && (e.y - e.z).abs() < 2e-3,
            "{v}: {e}"
        );
        e.y
    }

    /// AgX rolls highlights off: linear 1, 2, 4 and 8 give distinct values below 1, rising,
    /// where the standard view clips them all to 1 (the negative control).
    #[test]
    fn agx_keeps_highlights_apart_where_standard_clips_them() {
        let agx = Display::new(ViewTransform::Agx, 0.0);
        let standard = Display::new(ViewTransform::Standard, 0.0);
        let highs: Vec<f32> = [1.0, 2.0, 4.0, 8.0]
            .iter()
            .map(|&v| grey(&agx, v))
            .collect();
        assert!(highs.windows(2).all(|w| w[1] > w[0] + 0.01), "{highs:?}");
        assert!(highs.iter().all(|&v| v < 1.0), "{highs:?}");
        let clipped: Vec<f32> = [1.0, 2.0, 4.0, 8.0]
            .iter()
            .map(|&v| grey(&standard, v))
            .collect();
        assert!(clipped.iter().all(|&v| v > 0.9999), "{clipped:?}");
    }

    /// AgX is monotonic over the greys a render shows (from 2⁻¹⁰; below, the polynomial fit
    /// dips by less than 2e-5 in its toe), black stays near black, and middle grey (0.18)
    /// lands in the middle of the display range.
    #[test]
    fn agx_is_monotonic_and_puts_middle_grey_mid_range() {
        let agx = Display::new(ViewTransform::Agx, 0.0);
        let mut last = -1.0;
        for i in 0..=200 {
            let v = 2f32.powf(-10.0 + 16.0 * i as f32 / 200.0);
            let e = grey(&agx, v);
            assert!(e >= last, "not monotonic at {v}: {e} < {last}");
            last = e;
        }
        assert!(grey(&agx, 0.0) < 0.02, "black: {}", grey(&agx, 0.0));
        let mid = grey(&agx, 0.18);
        assert!((0.4..0.65).contains(&mid), "middle grey: {mid}");
    }

    /// Exposure scales linear values by 2^EV before the view: +1 EV on 0.1 is 0.2 at 0 EV.
    #[test]
    fn exposure_doubles_per_stop() {
        for view in [ViewTransform::Agx, ViewTransform::Standard] {
            let up = Display::new(view, 1.0).encode(Vec3::new(0.1, 0.05, 0.02));
            let same = Display::new(view, 0.0).encode(Vec3::new(0.2, 0.1, 0.04));
            assert!(
                (up - same).abs().max_element() < 1e-6,
                "{view:?}: {up} {same}"
            );
        }
    }

    /// The standard view is the sRGB encoding of the clamped value; bad values are black.
    #[test]
    fn standard_is_clamped_srgb() {
        let s = Display::new(ViewTransform::Standard, 0.0);
        let e = s.encode(Vec3::new(0.0, 1.0, 2.0));
        assert!(e.x == 0.0 && e.y > 0.9999 && e.y == e.z, "{e}");
        assert!((s.encode(Vec3::splat(0.5)).x - 0.735_356_6).abs() < 1e-5);
        assert_eq!(s.encode(Vec3::new(f32::NAN, 0.5, 0.5)), Vec3::ZERO);
    }
}
