//! The film: per-pixel sums of sample values and sample counts, box-filtered (a sample
//! contributes to its own pixel only, like Mitsuba's `box` reconstruction filter); where
//! passes ask, sums of the samples' first-hit features, and the triangle each pixel's sample 0
//! met (for the exact ID passes).
//!
//! # Exact sums
//!
//! Every sum is an integer in fixed point, so adding is associative and exact: a pixel's sums
//! are the same bits whatever order or grouping its samples were added in — one sample at a
//! time, in rounds of passes over the image, or as films of disjoint sample ranges rendered
//! apart and joined by [`Film::merge`] (a farm's shards). Floating-point sums are not: f64
//! addition rounds, so partial sums added together differ in the last bits from the
//! sequential sum.
//!
//! - **Values** (a sample's f32 channel): `q = trunc(v · 2^40)` ([`VALUE_FRACTION_BITS`]),
//!   summed in `i128`. Truncation (toward zero) is the only rounding, and only for
//!   |v| < 2^−17 (≈ 7.6·10⁻⁶): every f32 of at least that magnitude is a multiple of 2^−40,
//!   so it converts exactly; smaller ones lose less than 2^−40 ≈ 9.1·10⁻¹³ each. A sample
//!   must have |v| < 2^55 ≈ 3.6·10¹⁶ in every channel ([`MAX_SAMPLE_VALUE`]); one that does
//!   not is rejected like a NaN and reported ([`BadSample`]). Then |q| ≤ 2^95 and a pixel of
//!   at most 2^32 − 1 samples (its count is a `u32`) sums to less than 2^127 in magnitude: a
//!   sum cannot leave the range of `i128`. (The additions are checked all the same: they
//!   would panic, never wrap.)
//! - **Squares** (for the variance): `trunc(v² · 2^48)` ([`SQUARE_FRACTION_BITS`]), v² taken
//!   exactly in f64 and truncated by less than 2^−48 ≈ 3.6·10⁻¹⁵ (not at all where v is a
//!   multiple of 2^−24, e.g. every |v| ≥ 0.5), summed in `u128` with saturating addition,
//!   which is still associative for addends that are never negative. A pixel whose squares
//!   reach 2^80 ≈ 1.2·10²⁴ (e.g. two samples of 10¹²) saturates at `u128::MAX` and reports
//!   an infinite variance.
//! - **A render round** sums its samples of each pixel at the same scales in `i64`/`u64`
//!   ([`RoundTotals`]: half the bytes, one addition each), spilling into a wide entry where
//!   they would overflow, and the film adds them to its own sums: the same integers.
//! - **Features** (albedo, normal, depth, position, UV, and the number of hits, 13 slots):
//!   as values, in `i128` at 2^−40, each clamped to ±2^55 first (a depth or position
//!   farther than that is clamped; a NaN counts as 0), so they cannot overflow either.
//! - **Output**: a mean is the exact sum converted to f64 and divided by the count (times
//!   the scale), rounded to f32: a deterministic function of the exact integers.
//! - **Halves** (adaptive sampling only, which a farm shard cannot use) stay f64, copied
//!   from the exact sums when a pixel's count lands on a power of two.

use glam::{Vec2, Vec3};

use crate::record::{Features, FirstHit, NO_HIT};

/// A sample whose value was NaN, infinite or out of the film's range ([`MAX_SAMPLE_VALUE`]),
/// kept out of the film and reported.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BadSample {
    pub x: u32,
    pub y: u32,
    pub index: u32,
    pub value: Vec3,
}

/// Fractional bits of a sample value's (and a feature's) fixed-point form.
pub const VALUE_FRACTION_BITS: u32 = 40;

/// Fractional bits of a squared sample value's fixed-point form.
pub const SQUARE_FRACTION_BITS: u32 = 48;

/// Sample values must be smaller than this in magnitude (2^55) to reach the film, so that
/// the sums of 2^32 of them fit an `i128` ([`fixed_value`]).
pub const MAX_SAMPLE_VALUE: f32 = (1u64 << 55) as f32;

/// 2^[`VALUE_FRACTION_BITS`].
const VALUE_SCALE: f64 = (1u64 << VALUE_FRACTION_BITS) as f64;

/// 2^[`SQUARE_FRACTION_BITS`].
const SQUARE_SCALE: f64 = (1u64 << SQUARE_FRACTION_BITS) as f64;

/// 2^63: below this in magnitude an f64 converts to an integer in one instruction (through
/// i64) rather than through the slower 128-bit conversion.
const TWO_TO_63: f64 = 9_223_372_036_854_775_808.0;

/// A value's fixed-point form, `trunc(v · 2^40)` (NaN gives 0; beyond the range of `i128`
/// saturates, which [`MAX_SAMPLE_VALUE`] keeps sample values from reaching). The product is
/// exact (f32 to f64, times a power of two).
#[inline]
pub fn fixed_value(v: f32) -> i128 {
    let x = v as f64 * VALUE_SCALE;
    if x.abs() < TWO_TO_63 {
        x as i64 as i128
    } else {
        x as i128
    }
}

/// A value's square in fixed point, `trunc(v² · 2^48)`, saturating at `u128::MAX`. v² is
/// exact in f64 (two 24-bit significands make at most 48 bits).
#[inline]
pub fn fixed_square(v: f32) -> u128 {
    let x = v as f64 * v as f64 * SQUARE_SCALE;
    if x < TWO_TO_63 {
        x as i64 as u128
    } else {
        x as u128
    }
}

/// A feature's fixed-point form: [`fixed_value`] of it clamped to ±[`MAX_SAMPLE_VALUE`].
#[inline]
fn fixed_feature(v: f32) -> i128 {
    fixed_value(v.clamp(-MAX_SAMPLE_VALUE, MAX_SAMPLE_VALUE))
}

/// A fixed-point value back in f64 (rounded to nearest once).
#[inline]
pub fn value_of(q: i128) -> f64 {
    q as f64 / VALUE_SCALE
}

/// A fixed-point square back in f64; infinite where the sum saturated.
#[inline]
pub fn square_of(q: u128) -> f64 {
    match q {
        u128::MAX => f64::INFINITY,
        q => q as f64 / SQUARE_SCALE,
    }
}

#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Sum of sample values per pixel in fixed point ([`fixed_value`]), row 0 at the top.
    sums: Vec<[i128; 3]>,
    /// Sum of squared sample values per pixel in fixed point ([`fixed_square`]), for the
    /// variance estimate.
    sq_sums: Vec<[u128; 3]>,
    /// Samples taken per pixel (rejected samples count as taken).
    counts: Vec<u32>,
    /// For adaptive sampling ([`Film::keep_halves`]): per pixel, the sums of sample values
    /// when its count last reached a power of two p and when it reached p/2, from which
    /// [`Film::halves_variance_of_mean`] compares the first and second halves of its first p
    /// samples (f64, from the exact sums).
    halves: Option<Vec<Halves>>,
    /// For feature layers ([`Film::keep_features`]): per pixel, the sums of its samples'
    /// first-hit features.
    features: Option<Vec<FeatureTotals>>,
    /// For ID passes ([`Film::keep_first_hits`]): per pixel, the triangle that its sample 0's
    /// camera ray met ([`NO_HIT`] where it met nothing or was not taken).
    first_hits: Option<Vec<FirstHit>>,
}

/// The slots of [`FeatureTotals`].
pub const FEATURE_SLOTS: usize = 13;

/// A pixel's sums of its samples' first-hit features, in fixed point like the values
/// ([`fixed_value`]): albedo (0–2), shading normal (3–5), depth (6), position (8–10) and
/// texture coordinates (11–12) over the samples whose camera ray met a surface, and their
/// number (7, as 1.0 each). Albedo and normal are averaged over all of the pixel's samples (a
/// miss adds zero), depth, position and UV over the samples that hit.
pub type FeatureTotals = [i128; FEATURE_SLOTS];

/// A pixel's mean first-hit features ([`Film::features`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelFeatures {
    pub albedo: Vec3,
    pub normal: Vec3,
    /// The mean distance to the surfaces its samples met; infinite where none met one.
    pub depth: f32,
    /// The fraction of its samples whose camera ray met a surface.
    pub coverage: f32,
    /// The mean world-space point its samples met (zero where none met one).
    pub position: Vec3,
    /// The mean TEXCOORD_0 there (zero where none met a surface, or the scene has none).
    pub uv: Vec2,
}

/// Adds a sample's first-hit features (None: its ray met nothing) to a pixel's totals.
#[inline]
pub fn add_features(totals: &mut FeatureTotals, features: Option<Features>) {
    if let Some(f) = features {
        let values = [
            f.albedo.x,
            f.albedo.y,
            f.albedo.z,
            f.normal.x,
            f.normal.y,
            f.normal.z,
            f.depth,
            1.0,
            f.position.x,
            f.position.y,
            f.position.z,
            f.uv.x,
            f.uv.y,
        ];
        for (t, v) in totals.iter_mut().zip(values) {
            *t = add_sum(*t, fixed_feature(v));
        }
    }
}

/// Below this in magnitude (2^7), a value's fixed-point form and its square's both fit an
/// i64: |v| · 2^40 < 2^47 and v² · 2^48 < 2^62.
const SMALL_VALUE: f32 = 128.0;

/// `a + b` for sums of values or features, which cannot overflow: each addend is below 2^95
/// in magnitude ([`MAX_SAMPLE_VALUE`], and features are clamped to it) and a pixel takes
/// fewer than 2^32 samples (module docs). Checked all the same: an overflow would panic,
/// never wrap.
#[inline]
fn add_sum(a: i128, b: i128) -> i128 {
    a.checked_add(b)
        .expect("a film sum stays below 2^127 for fewer than 2^32 samples below 2^55")
}

/// A round's additions to one pixel (its part of a render round's tile results, carried into
/// the film by [`FilmRows::add_round`]): the sums and squares of the round's samples at the
/// film's scales ([`fixed_value`], [`fixed_square`]) in `i64`/`u64`, half the bytes of the
/// film's `i128`/`u128` and one addition each instead of two. A sample that would overflow
/// them (or whose value is too large for them, |v| ≥ 128) goes to the pixel's wide entry, a
/// [`WideTotals`] in its tile's side list, where the narrow sums are spilled first. The film
/// then adds both: integer sums are associative, and so is saturating addition of squares
/// that are never negative (the result is min(total, `u128::MAX`) in any grouping), so the
/// film holds the same bits as if every sample had been added to it one by one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RoundTotals {
    sum: [i64; 3],
    sq_sum: [u64; 3],
    /// Samples the round took (rejected ones included).
    pub count: u32,
    /// 1 + the index of this pixel's wide entry in its tile's list; 0: none.
    wide: u32,
}

/// Pinned by [`Film::BYTES_PER_PIXEL`].
const _: () = assert!(std::mem::size_of::<RoundTotals>() == 56);

/// A pixel's wide sums and squares within a round, for the samples that overflow its
/// [`RoundTotals`] (rare: values of 128 and above, or some 2^23 of value summed in a round).
pub type WideTotals = ([i128; 3], [u128; 3]);

/// Adds sample value `l` (every channel finite and below [`MAX_SAMPLE_VALUE`] in magnitude:
/// [`in_range`]) to a pixel's round totals, or to its wide entry in `wide` (its tile's list)
/// where the narrow sums would overflow; the count is the caller's.
#[inline]
pub fn add_sample(pixel: &mut RoundTotals, wide: &mut Vec<WideTotals>, l: glam::Vec3A) {
    if l.abs().cmplt(glam::Vec3A::splat(SMALL_VALUE)).all() {
        // The common case, one test for the three channels: both conversions through i64
        // (one instruction each), the same integers as `fixed_value` and `fixed_square`.
        let (mut sum, mut sq_sum, mut over) = (pixel.sum, pixel.sq_sum, false);
        for (c, v) in l.to_array().into_iter().enumerate() {
            let v = v as f64;
            let (s, o) = sum[c].overflowing_add((v * VALUE_SCALE) as i64);
            let (q, p) = sq_sum[c].overflowing_add((v * v * SQUARE_SCALE) as i64 as u64);
            (sum[c], sq_sum[c], over) = (s, q, over | o | p);
        }
        if !over {
            (pixel.sum, pixel.sq_sum) = (sum, sq_sum);
            return;
        }
    }
    add_sample_wide(pixel, wide, l);
}

/// [`add_sample`]'s rare path: spills the pixel's narrow sums into its wide entry (made
/// here if it has none) and adds `l` there.
#[cold]
fn add_sample_wide(pixel: &mut RoundTotals, wide: &mut Vec<WideTotals>, l: glam::Vec3A) {
    if pixel.wide == 0 {
        wide.push(([0; 3], [0; 3]));
        pixel.wide = u32::try_from(wide.len()).expect("fewer wide entries than pixels");
    }
    let (sum, sq_sum) = &mut wide[pixel.wide as usize - 1];
    for (c, v) in l.to_array().into_iter().enumerate() {
        sum[c] = add_sum(add_sum(sum[c], pixel.sum[c] as i128), fixed_value(v));
        sq_sum[c] =
            (sq_sum[c].saturating_add(pixel.sq_sum[c] as u128)).saturating_add(fixed_square(v));
    }
    (pixel.sum, pixel.sq_sum) = ([0; 3], [0; 3]);
}

/// Whether a sample value can reach the film: every channel finite and smaller than
/// [`MAX_SAMPLE_VALUE`] in magnitude (NaN is not).
#[inline]
pub fn in_range(l: glam::Vec3A) -> bool {
    l.abs().cmplt(glam::Vec3A::splat(MAX_SAMPLE_VALUE)).all()
}

/// Why [`Film::merge`] refused a film.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MergeError {
    #[error("films of {0}x{1} and {2}x{3} pixels cannot be merged")]
    Size(u32, u32, u32, u32),
    #[error("the films keep different layers (features, first hits)")]
    Layers,
    #[error("a film of adaptive sampling (with halves) cannot be merged")]
    Halves,
    #[error("pixel ({0}, {1}) would hold more than 2^32 - 1 samples")]
    TooManySamples(u32, u32),
    #[error("pixel ({0}, {1}) has its sample 0 in both films: their sample ranges overlap")]
    BothHaveSampleZero(u32, u32),
}

/// The largest power of two at most `n` (> 0).
#[inline]
fn last_power_of_two(n: u32) -> u32 {
    1 << (31 - n.leading_zeros())
}

/// A pixel's sums at the count p/2 and at p, p its count's last power of two.
type Halves = [[f64; 3]; 2];

/// Keeps `halves` current when a pixel's count goes from `old` to `new` with sums `sum`:
/// landing on a power of two p from at least p/2, the sums at p/2 become the first half's;
/// passing over a power of two (or landing on one from below p/2) leaves no halves (NaN)
/// until the pixel lands on the next two in a row.
#[inline]
fn record_halves(halves: &mut Halves, old: u32, new: u32, sum: [f64; 3]) {
    if new <= old {
        return;
    }
    let p = last_power_of_two(new);
    if p <= old {
        return;
    }
    *halves = if new == p && old >= p / 2 {
        [halves[1], sum]
    } else {
        [[f64::NAN; 3]; 2]
    };
}

/// `n` zeros, written one by one rather than allocated already zero. `vec![0; n]` gets
/// zero pages from the kernel that the first read maps to one shared page; the film is read
/// (counts, `+=`) before it is written, so each page then took a copy-on-write fault whose
/// TLB flush interrupts every other render thread: on two threads, 26 000 of them cost a
/// 1024² path render a tenth of its time.
fn zeroed_by_writing<T: Default + Clone>(n: usize) -> Vec<T> {
    filled_by_writing(n, T::default())
}

/// `n` copies of `value`, written one by one ([`zeroed_by_writing`]).
fn filled_by_writing<T: Clone>(n: usize, value: T) -> Vec<T> {
    let mut v = Vec::with_capacity(n);
    v.resize(n, value);
    v
}

/// Some whole rows of a [`Film`], borrowed mutably ([`Film::rows_mut`]).
pub struct FilmRows<'a> {
    y0: u32,
    width: u32,
    sums: &'a mut [[i128; 3]],
    sq_sums: &'a mut [[u128; 3]],
    counts: &'a mut [u32],
    halves: Option<&'a mut [Halves]>,
    features: Option<&'a mut [FeatureTotals]>,
    first_hits: Option<&'a mut [FirstHit]>,
}

impl FilmRows<'_> {
    /// Adds a round's totals of pixel (x, y) to its sums and count: `round`, and its wide
    /// entry in `wide` (its tile's list) where it has one ([`RoundTotals`]). Always inlined
    /// (into `write_tile`'s loop): 1.8 M fewer instructions of 785 M on the helmet's AO.
    #[inline(always)]
    pub fn add_round(&mut self, x: u32, y: u32, round: &RoundTotals, wide: &[WideTotals]) {
        let i = (y - self.y0) as usize * self.width as usize + x as usize;
        let (sum, sq_sum) = (&mut self.sums[i], &mut self.sq_sums[i]);
        if round.wide != 0 {
            let (w, q) = &wide[round.wide as usize - 1];
            for c in 0..3 {
                sum[c] = add_sum(sum[c], w[c]);
                sq_sum[c] = sq_sum[c].saturating_add(q[c]);
            }
        }
        for c in 0..3 {
            sum[c] = add_sum(sum[c], round.sum[c] as i128);
            sq_sum[c] = sq_sum[c].saturating_add(round.sq_sum[c] as u128);
        }
        self.set_count(i, self.counts[i] + round.count);
    }

    /// Replaces pixel (x, y)'s sums and count.
    #[inline]
    pub fn set(&mut self, x: u32, y: u32, (sum, sq_sum, count): PixelTotals) {
        let i = (y - self.y0) as usize * self.width as usize + x as usize;
        self.sums[i] = sum;
        self.sq_sums[i] = sq_sum;
        self.set_count(i, count);
    }

    /// Replaces pixel `i`'s count (its sums already the new count's), keeping its halves.
    #[inline]
    fn set_count(&mut self, i: usize, count: u32) {
        if let Some(h) = self.halves.as_deref_mut() {
            record_halves(&mut h[i], self.counts[i], count, self.sums[i].map(value_of));
        }
        self.counts[i] = count;
    }

    /// Replaces pixel (x, y)'s feature totals, where the film keeps them.
    #[inline]
    pub fn set_features(&mut self, x: u32, y: u32, totals: &FeatureTotals) {
        let i = (y - self.y0) as usize * self.width as usize + x as usize;
        if let Some(f) = self.features.as_deref_mut() {
            f[i] = *totals;
        }
    }

    /// Replaces pixel (x, y)'s first hit, where the film keeps them.
    #[inline]
    pub fn set_first_hit(&mut self, x: u32, y: u32, triangle: FirstHit) {
        let i = (y - self.y0) as usize * self.width as usize + x as usize;
        if let Some(h) = self.first_hits.as_deref_mut() {
            h[i] = triangle;
        }
    }
}

/// A pixel's sum of sample values, sum of their squares (both in fixed point:
/// [`fixed_value`], [`fixed_square`]), and number of samples.
pub type PixelTotals = ([i128; 3], [u128; 3], u32);

impl Film {
    /// Memory a render needs per pixel: the film's sums, squares (three 16-byte integers
    /// each) and count (100 bytes), a round's tile results collected before they are merged
    /// ([`RoundTotals`]: three 8-byte sums and squares, the count and a wide entry's index,
    /// 56 bytes; the wide entries of the rare pixels that overflow them are not counted), and
    /// the float32 RGB image made for output (12 bytes), and the 32-bit words of the exact
    /// sums an interrupted render saves for `--resume` (100 bytes, [`super::partial`]).
    /// Adaptive sampling and checkpoints need more ([`Film::ADAPTIVE_BYTES_PER_PIXEL`],
    /// [`Film::CHECKPOINT_BYTES_PER_PIXEL`]).
    pub const BYTES_PER_PIXEL: u64 = 100 + 56 + 12 + 100;

    /// Adaptive sampling's extra memory per pixel: the active and selected masks (2 bytes),
    /// the judgement's three f64 error images (own, row maximum, neighbourhood maximum)
    /// plus the selection's gains (32 bytes), and the film's sums of the two halves (48 bytes,
    /// [`Film::keep_halves`]).
    pub const ADAPTIVE_BYTES_PER_PIXEL: u64 = 2 + 32 + Self::HALVES_BYTES_PER_PIXEL;

    /// The sums of the two halves that adaptive sampling keeps per pixel
    /// ([`Film::keep_halves`]).
    pub const HALVES_BYTES_PER_PIXEL: u64 = 48;

    /// A checkpoint's extra memory per pixel: the snapshot of the film it writes (100 bytes;
    /// its exact sums' words are counted in [`Film::BYTES_PER_PIXEL`]).
    pub const CHECKPOINT_BYTES_PER_PIXEL: u64 = 100;

    /// The memory a `width` × `height` render needs for its image ([`Film::BYTES_PER_PIXEL`]
    /// per pixel), for checks before anything is allocated.
    pub fn memory_estimate(width: u32, height: u32) -> u64 {
        width as u64 * height as u64 * Self::BYTES_PER_PIXEL
    }

    pub fn new(width: u32, height: u32) -> Film {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            sums: zeroed_by_writing(n),
            sq_sums: zeroed_by_writing(n),
            counts: zeroed_by_writing(n),
            halves: None,
            features: None,
            first_hits: None,
        }
    }

    /// The memory [`Film::keep_features`] adds, per pixel: the film's feature totals, a
    /// round's copy of them for its tiles and their words in an unfinished render's saved
    /// sums ([`FEATURE_SLOTS`] 16-byte integers each).
    pub const FEATURES_BYTES_PER_PIXEL: u64 = 3 * 16 * FEATURE_SLOTS as u64;

    /// Keeps, from now on, each pixel's first-hit feature totals ([`Film::features`]). Call
    /// on a new film.
    pub fn keep_features(&mut self) {
        self.features = Some(zeroed_by_writing(self.counts.len()));
    }

    /// True when the film keeps feature totals.
    pub fn keeps_features(&self) -> bool {
        self.features.is_some()
    }

    /// The memory [`Film::keep_first_hits`] adds, per pixel: the film's triangle, a round's
    /// copy of it for its tiles and its words in an unfinished render's saved sums.
    pub const FIRST_HITS_BYTES_PER_PIXEL: u64 = 24;

    /// Keeps, from now on, the triangle each pixel's sample 0 meets ([`Film::first_hit`]), for
    /// ID passes: exact, where an average of IDs over the samples would name no object at
    /// an outline, and the same whatever the thread count, rounds or stopping, since every
    /// pixel takes its sample 0 first. Call on a new film.
    pub fn keep_first_hits(&mut self) {
        self.first_hits = Some(filled_by_writing(self.counts.len(), NO_HIT));
    }

    /// True when the film keeps first hits.
    pub fn keeps_first_hits(&self) -> bool {
        self.first_hits.is_some()
    }

    /// The triangle pixel (x, y)'s sample 0 met: None where it met nothing, has not been
    /// taken, or the film keeps no first hits.
    pub fn first_hit(&self, x: u32, y: u32) -> Option<FirstHit> {
        let t = self.first_hits.as_ref()?[self.index(x, y)];
        (t != NO_HIT).then_some(t)
    }

    /// Pixel (x, y)'s first hit as the film stores it ([`NO_HIT`] where it keeps none).
    #[inline]
    pub fn first_hit_raw(&self, x: u32, y: u32) -> FirstHit {
        self.first_hits
            .as_ref()
            .map_or(NO_HIT, |h| h[self.index(x, y)])
    }

    /// Pixel (x, y)'s feature totals (zero where the film keeps none).
    #[inline]
    pub fn feature_totals(&self, x: u32, y: u32) -> FeatureTotals {
        self.features
            .as_ref()
            .map_or([0; FEATURE_SLOTS], |f| f[self.index(x, y)])
    }

    /// Pixel (x, y)'s mean first-hit features; None where the film keeps none or the pixel
    /// has no samples.
    pub fn features(&self, x: u32, y: u32) -> Option<PixelFeatures> {
        let f = self.features.as_ref()?[self.index(x, y)].map(value_of);
        let n = self.counts[self.index(x, y)] as f64;
        if n == 0.0 {
            return None;
        }
        let v = |i: usize| (f[i] / n) as f32;
        let hit = |i: usize| (f[i] / f[7]) as f32;
        Some(PixelFeatures {
            albedo: Vec3::new(v(0), v(1), v(2)),
            normal: Vec3::new(v(3), v(4), v(5)),
            depth: if f[7] > 0.0 {
                (f[6] / f[7]) as f32
            } else {
                f32::INFINITY
            },
            coverage: (f[7] / n) as f32,
            position: match f[7] > 0.0 {
                true => Vec3::new(hit(8), hit(9), hit(10)),
                false => Vec3::ZERO,
            },
            uv: match f[7] > 0.0 {
                true => Vec2::new(hit(11), hit(12)),
                false => Vec2::ZERO,
            },
        })
    }

    /// Keeps, from now on, each pixel's sums at its last two power-of-two counts, for
    /// [`Film::halves_variance_of_mean`] (adaptive sampling). They follow counts that land on
    /// every power of two, as the progressive passes of adaptive renders do
    /// ([`crate::render::progressive_next`]); a pixel that jumps over one has no halves until
    /// it lands on the next. Call on a new film.
    pub fn keep_halves(&mut self) {
        self.halves = Some(zeroed_by_writing(self.counts.len()));
    }

    /// Disjoint mutable views of the rows `ranges` ([y0, y1) each, sorted and not
    /// overlapping), for merging different bands of rows on different threads.
    pub fn rows_mut(&mut self, ranges: &[(u32, u32)]) -> Vec<FilmRows<'_>> {
        let w = self.width as usize;
        let (mut sums, mut sq_sums, mut counts) = (
            &mut self.sums[..],
            &mut self.sq_sums[..],
            &mut self.counts[..],
        );
        let mut halves = self.halves.as_deref_mut();
        let mut features = self.features.as_deref_mut();
        let mut first_hits = self.first_hits.as_deref_mut();
        let mut at = 0u32;
        let mut out = Vec::with_capacity(ranges.len());
        for &(y0, y1) in ranges {
            assert!(at <= y0 && y0 <= y1 && y1 <= self.height, "bad row range");
            let skip = (y0 - at) as usize * w;
            let take = (y1 - y0) as usize * w;
            let (s, rest) = std::mem::take(&mut sums)[skip..].split_at_mut(take);
            sums = rest;
            let (q, rest) = std::mem::take(&mut sq_sums)[skip..].split_at_mut(take);
            sq_sums = rest;
            let (c, rest) = std::mem::take(&mut counts)[skip..].split_at_mut(take);
            counts = rest;
            let h = halves.take().map(|all| {
                let (h, rest) = all[skip..].split_at_mut(take);
                halves = Some(rest);
                h
            });
            let f = features.take().map(|all| {
                let (f, rest) = all[skip..].split_at_mut(take);
                features = Some(rest);
                f
            });
            let first = first_hits.take().map(|all| {
                let (h, rest) = all[skip..].split_at_mut(take);
                first_hits = Some(rest);
                h
            });
            out.push(FilmRows {
                y0,
                width: self.width,
                sums: s,
                sq_sums: q,
                counts: c,
                halves: h,
                features: f,
                first_hits: first,
            });
            at = y1;
        }
        out
    }

    #[inline]
    fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// Adds one sample of value `l` to pixel (x, y) (a sample out of range, [`in_range`],
    /// counts without adding to the sums, as a render rejects it).
    pub fn add_sample(&mut self, x: u32, y: u32, l: Vec3) {
        let (mut round, mut wide) = (RoundTotals::default(), Vec::new());
        if in_range(l.into()) {
            add_sample(&mut round, &mut wide, l.into());
        }
        round.count = 1;
        self.rows_mut(&[(y, y + 1)])[0].add_round(x, y, &round, &wide);
    }

    /// Adds the samples of `other`, a film of the same size and layers, to this one: sums,
    /// squares, counts and features add (exactly: the result is the film that would have
    /// taken both films' samples), and each pixel's first hit is the one that is set, since
    /// only the film that took sample 0 sets it. The films should hold disjoint sample
    /// ranges; a pixel whose first hit both set is refused as an overlap, as is a pixel whose
    /// count would pass `u32::MAX`. On error the film is unchanged. Films of adaptive
    /// sampling (which keep halves) are refused.
    pub fn merge(&mut self, other: &Film) -> Result<(), MergeError> {
        if (self.width, self.height) != (other.width, other.height) {
            return Err(MergeError::Size(
                self.width,
                self.height,
                other.width,
                other.height,
            ));
        }
        if self.keeps_features() != other.keeps_features()
            || self.keeps_first_hits() != other.keeps_first_hits()
        {
            return Err(MergeError::Layers);
        }
        if self.halves.is_some() || other.halves.is_some() {
            return Err(MergeError::Halves);
        }
        // Check every pixel before changing any.
        let at = |i: usize| (i % self.width as usize) as u32;
        let row = |i: usize| (i / self.width as usize) as u32;
        for (i, (a, b)) in self.counts.iter().zip(&other.counts).enumerate() {
            if a.checked_add(*b).is_none() {
                return Err(MergeError::TooManySamples(at(i), row(i)));
            }
        }
        if let (Some(a), Some(b)) = (&self.first_hits, &other.first_hits) {
            if let Some(i) = (a.iter().zip(b)).position(|(&a, &b)| a != NO_HIT && b != NO_HIT) {
                return Err(MergeError::BothHaveSampleZero(at(i), row(i)));
            }
        }
        // Checked above: no pixel can fail.
        for i in 0..self.counts.len() {
            let features = other.features.as_ref().map(|f| &f[i]);
            let totals = (other.sums[i], other.sq_sums[i], other.counts[i]);
            self.add_pixel_totals(i, totals, features)?;
        }
        if let (Some(a), Some(b)) = (&mut self.first_hits, &other.first_hits) {
            for (a, &b) in a.iter_mut().zip(b) {
                if b != NO_HIT {
                    *a = b;
                }
            }
        }
        Ok(())
    }

    /// Adds pixel `i`'s totals from a film of disjoint samples (a shard's partial file, read
    /// back: [`super::partial::ExactLayer`]; [`Film::merge`] adds whole films through it):
    /// its sums, squares and count, and its feature sums where both keep features (`features`
    /// must be given exactly when this film keeps them). Sums stay below 2^127 in magnitude
    /// for counts below 2^32 ([`add_sum`]); squares saturate by design. Refuses a count past
    /// `u32::MAX`; the pixel is then unchanged.
    pub fn add_pixel_totals(
        &mut self,
        i: usize,
        (sum, sq_sum, count): PixelTotals,
        features: Option<&FeatureTotals>,
    ) -> Result<(), MergeError> {
        if self.halves.is_some() {
            return Err(MergeError::Halves);
        }
        let total = (self.counts[i].checked_add(count)).ok_or_else(|| {
            let w = self.width as usize;
            MergeError::TooManySamples((i % w) as u32, (i / w) as u32)
        })?;
        match (&mut self.features, features) {
            (Some(all), Some(f)) => {
                for (a, b) in all[i].iter_mut().zip(f) {
                    *a = add_sum(*a, *b);
                }
            }
            (None, None) => {}
            _ => return Err(MergeError::Layers),
        }
        for c in 0..3 {
            self.sums[i][c] = add_sum(self.sums[i][c], sum[c]);
            self.sq_sums[i][c] = self.sq_sums[i][c].saturating_add(sq_sum[c]);
        }
        self.counts[i] = total;
        Ok(())
    }

    /// The estimated variance of pixel (x, y)'s mean: the unbiased sample variance of its
    /// samples divided by their number (0 with fewer than two samples; infinite where the
    /// sum of squares saturated), computed in f64 from the exact sums.
    pub fn variance_of_mean(&self, x: u32, y: u32) -> Vec3 {
        let i = self.index(x, y);
        let n = self.counts[i] as f64;
        if n < 2.0 {
            return Vec3::ZERO;
        }
        let v = |c: usize| {
            let (sum, sq_sum) = (value_of(self.sums[i][c]), square_of(self.sq_sums[i][c]));
            let mean = sum / n;
            (((sq_sum - mean * sum) / (n - 1.0)).max(0.0) / n) as f32
        };
        Vec3::new(v(0), v(1), v(2))
    }

    /// The variance of pixel (x, y)'s mean estimated from the two halves of its first p
    /// samples, p its count's last power of two (at least 2): (a − b)²/4 per channel for the
    /// halves' means a and b, which estimates the variance of the mean of p samples whatever
    /// their correlation within a half (for Sobol points, far below the sample variance over
    /// p), scaled by p/n to the pixel's n samples. `None` without halves
    /// ([`Film::keep_halves`]) or under two samples.
    pub fn halves_variance_of_mean(&self, x: u32, y: u32) -> Option<Vec3> {
        let i = self.index(x, y);
        let n = self.counts[i];
        if n < 2 {
            return None;
        }
        let [first, upto_p] = self.halves.as_ref()?[i];
        if first[0].is_nan() || upto_p[0].is_nan() {
            return None;
        }
        let p = last_power_of_two(n);
        let half = (p / 2) as f64;
        let v = |c: usize| {
            let (a, b) = (first[c] / half, (upto_p[c] - first[c]) / half);
            ((a - b) * (a - b) / 4.0 * p as f64 / n as f64) as f32
        };
        Some(Vec3::new(v(0), v(1), v(2)))
    }

    /// [`Film::variance_of_mean`] of every pixel, row-major from the top row.
    pub fn variances(&self) -> Vec<Vec3> {
        (0..self.height)
            .flat_map(|y| (0..self.width).map(move |x| (x, y)))
            .map(|(x, y)| self.variance_of_mean(x, y))
            .collect()
    }

    /// Pixel (x, y)'s sums and count so far.
    #[inline]
    pub fn totals(&self, x: u32, y: u32) -> PixelTotals {
        let i = self.index(x, y);
        (self.sums[i], self.sq_sums[i], self.counts[i])
    }

    /// Samples taken by pixel (x, y).
    pub fn count(&self, x: u32, y: u32) -> u32 {
        self.counts[self.index(x, y)]
    }

    /// The smallest and largest sample counts over all pixels.
    pub fn count_range(&self) -> (u32, u32) {
        let min = self.counts.iter().copied().min().unwrap_or(0);
        let max = self.counts.iter().copied().max().unwrap_or(0);
        (min, max)
    }

    /// The mean number of samples per pixel over the whole film.
    pub fn count_mean(&self) -> f64 {
        self.counts.iter().map(|&c| c as f64).sum::<f64>() / self.counts.len().max(1) as f64
    }

    /// Every pixel's sample count as a grey value, row-major from the top row.
    pub fn count_image(&self) -> Vec<Vec3> {
        self.counts.iter().map(|&c| Vec3::splat(c as f32)).collect()
    }

    /// The pixel's estimate: the mean of its samples (0 for a pixel with none).
    pub fn pixel(&self, x: u32, y: u32) -> Vec3 {
        let i = self.index(x, y);
        let n = self.counts[i];
        if n == 0 {
            return Vec3::ZERO;
        }
        // One conversion of the exact sum to f64, one division (by the count times the
        // scale, itself exact: a count times a power of two).
        let scale = n as f64 * VALUE_SCALE;
        let mean = |c: usize| (self.sums[i][c] as f64 / scale) as f32;
        Vec3::new(mean(0), mean(1), mean(2))
    }

    /// All pixel estimates, row-major from the top row.
    pub fn pixels(&self) -> Vec<Vec3> {
        (0..self.height)
            .flat_map(|y| (0..self.width).map(move |x| (x, y)))
            .map(|(x, y)| self.pixel(x, y))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The two-halves estimate from first principles: p the count's last power of two, the
    /// first and second halves of the first p samples, ((a − b)/2)² · p/n.
    fn halves_by_hand(samples: &[f64]) -> f64 {
        let n = samples.len();
        let p = 1usize << (usize::BITS - 1 - n.leading_zeros());
        let mean = |s: &[f64]| s.iter().sum::<f64>() / s.len() as f64;
        let (a, b) = (mean(&samples[..p / 2]), mean(&samples[p / 2..p]));
        (a - b).powi(2) / 4.0 * p as f64 / n as f64
    }

    #[test]
    fn the_halves_follow_the_power_of_two_counts() {
        // Values that f32 holds exactly, as the film takes them.
        let samples: Vec<f64> = (0..70)
            .map(|i| ((i * 37 % 11) as f32).sqrt() as f64)
            .collect();
        // One sample at a time through `add`.
        let mut film = Film::new(1, 1);
        film.keep_halves();
        for (k, &v) in samples.iter().enumerate() {
            film.add_sample(0, 0, Vec3::splat(v as f32));
            let got = film.halves_variance_of_mean(0, 0);
            if k == 0 {
                assert_eq!(got, None, "one sample");
                continue;
            }
            let want = halves_by_hand(&samples[..=k]);
            let got = got.expect("halves").x as f64;
            assert!(
                (got - want).abs() <= 1e-6 * want.max(1e-6),
                "n={}: {got} against {want}",
                k + 1
            );
        }
        // Rounds as a progressive render writes them (FilmRows::set with the totals), from
        // 16 to 24, 32, 40: the same estimate.
        let totals = |n: usize| -> PixelTotals {
            let s: i128 = samples[..n].iter().map(|&v| fixed_value(v as f32)).sum();
            let q: u128 = samples[..n].iter().map(|&v| fixed_square(v as f32)).sum();
            ([s; 3], [q; 3], n as u32)
        };
        let mut film = Film::new(1, 1);
        film.keep_halves();
        for n in [1, 2, 4, 8, 16, 24, 32, 40] {
            film.rows_mut(&[(0, 1)])[0].set(0, 0, totals(n));
        }
        let got = film.halves_variance_of_mean(0, 0).unwrap().x as f64;
        let want = halves_by_hand(&samples[..40]);
        assert!((got - want).abs() <= 1e-6 * want, "{got} against {want}");
        // A round that passes over a power of two (24 → 40, over 32) leaves no halves;
        // landing on 64 then gives the sums at 64 but no first half; from 128, whose first
        // half is the sums at 64, there are halves again.
        let mut film = Film::new(1, 1);
        film.keep_halves();
        let long: Vec<f64> = (0..128).map(|i| (i % 7) as f64).collect();
        let totals = |n: usize| -> PixelTotals {
            let s: i128 = long[..n].iter().map(|&v| fixed_value(v as f32)).sum();
            ([s; 3], [0; 3], n as u32)
        };
        for n in [1, 2, 4, 8, 16, 24] {
            film.rows_mut(&[(0, 1)])[0].set(0, 0, totals(n));
        }
        assert!(film.halves_variance_of_mean(0, 0).is_some());
        film.rows_mut(&[(0, 1)])[0].set(0, 0, totals(40));
        assert_eq!(film.halves_variance_of_mean(0, 0), None, "passed over 32");
        film.rows_mut(&[(0, 1)])[0].set(0, 0, totals(64));
        assert_eq!(
            film.halves_variance_of_mean(0, 0),
            None,
            "landed on 64 from 40"
        );
        film.rows_mut(&[(0, 1)])[0].set(0, 0, totals(128));
        let got = film.halves_variance_of_mean(0, 0).unwrap().x as f64;
        let want = halves_by_hand(&long[..128]);
        assert!(
            (got - want).abs() <= 1e-6 * want.max(1e-6),
            "{got} against {want}"
        );
        // Without keep_halves there is no estimate.
        assert_eq!(Film::new(1, 1).halves_variance_of_mean(0, 0), None);
    }

    #[test]
    fn fixed_point_is_exact_above_its_resolution_and_truncates_below() {
        // Every f32 of magnitude at least 2^-17 converts exactly.
        for v in [1.0f32, -1.0, 0.1, 3.0e-5, 2f32.powi(-17), 1.0e16, -2.5e7] {
            assert_eq!(value_of(fixed_value(v)), v as f64, "{v}");
        }
        // Below, toward zero, by less than 2^-40.
        let tiny = 1.0e-7f32;
        let q = fixed_value(tiny);
        assert!(value_of(q) <= tiny as f64 && tiny as f64 - value_of(q) < 2f64.powi(-40));
        assert_eq!(fixed_value(-tiny), -q);
        assert_eq!(fixed_value(f32::NAN), 0);
        // The largest admitted value, 2^55 less an ulp, times 2^32 - 1 samples, fits i128.
        let largest = fixed_value(MAX_SAMPLE_VALUE.next_down());
        assert!(largest.checked_mul(u32::MAX as i128).is_some());
        assert!(!in_range(glam::Vec3A::new(0.0, MAX_SAMPLE_VALUE, 0.0)));
        assert!(!in_range(glam::Vec3A::new(f32::NAN, 0.0, 0.0)));
        assert!(in_range(glam::Vec3A::splat(-MAX_SAMPLE_VALUE.next_down())));
        // Squares exactly where v is a multiple of 2^-24 (every |v| ≥ 0.5), otherwise
        // truncated by less than 2^-48.
        assert_eq!(square_of(fixed_square(3.0)), 9.0);
        assert_eq!(square_of(fixed_square(-0.75)), 0.5625);
        let (exact, q) = (0.1f32 as f64 * 0.1f32 as f64, square_of(fixed_square(0.1)));
        assert!(q <= exact && exact - q < 2f64.powi(-48));
        assert_eq!(fixed_square(f32::MAX), u128::MAX);
        // `add_sample`'s paths (narrow for small values, wide for the others) give the same
        // integers.
        for v in [0.1f32, -127.9, 1.0e-7, 3.0, 127.99, 128.0, -1.0e9] {
            let mut film = Film::new(1, 1);
            film.add_sample(0, 0, Vec3::new(v, 0.5, -v));
            let t = film.totals(0, 0);
            assert_eq!((t.0[0], t.1[0]), (fixed_value(v), fixed_square(v)), "{v}");
            assert_eq!((t.0[2], t.1[2]), (fixed_value(-v), fixed_square(v)), "{v}");
        }
    }

    /// A round's narrow totals that overflow spill into the wide entry: the film gets the
    /// same sums and squares (saturated ones included) as from the samples one by one.
    #[test]
    fn round_totals_that_overflow_give_the_film_the_same_bits() {
        // Squares of 127.99 (about 2^62 in fixed point) overflow a u64 every few samples,
        // their values' sums (2^47 each) an i64 after 2^16 of them; 1e12 and 200 go wide
        // at once, 1e12 twice saturates the squares; one pixel of three takes none.
        let mut values: Vec<Vec3> = vec![Vec3::new(127.99, -127.99, 0.25); 70_000];
        values.insert(10, Vec3::new(200.0, 1.0e12, -3.0));
        values.insert(5_000, Vec3::new(-127.0, 1.0e12, 0.5));
        for k in 0..3u32 {
            // Pixel 0 takes every sample, pixel 1 the first 20, pixel 2 none.
            let n = [values.len(), 20, 0][k as usize];
            let samples = &values[..n];
            let mut one_by_one = Film::new(1, 1);
            for &l in samples {
                one_by_one.add_sample(0, 0, l);
            }
            // One round: narrow totals and a wide list shared with two other pixels.
            let (mut round, mut wide) = (RoundTotals::default(), vec![([7; 3], [7; 3]); 2]);
            for &l in samples {
                add_sample(&mut round, &mut wide, l.into());
            }
            round.count = n as u32;
            // On top of a film that already holds a sample.
            let mut film = Film::new(1, 1);
            film.add_sample(0, 0, Vec3::new(1.0, 2.0, 3.0));
            film.rows_mut(&[(0, 1)])[0].add_round(0, 0, &round, &wide);
            one_by_one.add_sample(0, 0, Vec3::new(1.0, 2.0, 3.0));
            // By hand: exact sums, squares saturating.
            let mut want: PixelTotals = ([0; 3], [0; 3], n as u32 + 1);
            for &l in samples.iter().chain([&Vec3::new(1.0, 2.0, 3.0)]) {
                for c in 0..3 {
                    want.0[c] += fixed_value(l[c]);
                    want.1[c] = want.1[c].saturating_add(fixed_square(l[c]));
                }
            }
            assert_eq!(film.totals(0, 0), want, "pixel {k}");
            assert_eq!(one_by_one.totals(0, 0), want, "pixel {k}");
            assert_eq!(
                wide.len(),
                2 + (n > 0) as usize,
                "pixel {k}: one wide entry"
            );
        }
    }

    #[test]
    fn saturated_squares_report_an_infinite_variance() {
        let mut film = Film::new(1, 1);
        film.add_sample(0, 0, Vec3::new(1.0, 1.0e12, 2.0));
        film.add_sample(0, 0, Vec3::new(3.0, 1.0e12, 2.0));
        let v = film.variance_of_mean(0, 0);
        assert_eq!(v.y, f32::INFINITY);
        assert_eq!((v.x, v.z), (1.0, 0.0));
        assert_eq!(film.pixel(0, 0), Vec3::new(2.0, 1.0e12, 2.0));
    }

    #[test]
    fn merged_films_hold_the_sums_of_all_their_samples_in_any_grouping() {
        // Values whose f64 sums depend on the grouping: ((a + b) + c) ≠ (a + (b + c)).
        let values = [1.0e8f32, 1.0e-3, 3.3e-3, -1.0e8, 0.7, 1.9e-6];
        let film_of = |range: std::ops::Range<usize>| {
            let mut f = Film::new(2, 1);
            f.keep_features();
            for &v in &values[range] {
                f.add_sample(1, 0, Vec3::splat(v));
            }
            f
        };
        let whole = film_of(0..6);
        let mut merged = film_of(4..6);
        merged.merge(&film_of(0..1)).unwrap();
        merged.merge(&film_of(1..4)).unwrap();
        for x in 0..2 {
            assert_eq!(merged.totals(x, 0), whole.totals(x, 0));
            assert_eq!(merged.pixel(x, 0), whole.pixel(x, 0));
        }
        // A film of adaptive sampling is refused, and so is a count past u32::MAX.
        let mut halves = Film::new(2, 1);
        halves.keep_features();
        halves.keep_halves();
        assert_eq!(merged.clone().merge(&halves), Err(MergeError::Halves));
        let mut full = Film::new(2, 1);
        full.counts[1] = u32::MAX;
        assert_eq!(
            Film::new(2, 1).merge(&full),
            Ok(()),
            "an empty film takes any count"
        );
        assert_eq!(
            film_of(0..1).merge(&full),
            Err(MergeError::Layers),
            "features in one only"
        );
        let mut one = Film::new(2, 1);
        one.add_sample(1, 0, Vec3::ONE);
        assert_eq!(one.merge(&full), Err(MergeError::TooManySamples(1, 0)));
    }

    #[test]
    fn variance_of_the_mean_matches_the_textbook_formula() {
        let samples = [0.0f64, 1.0, 1.0, 3.0, 5.0];
        // Added in two films, merged.
        let mut film = Film::new(1, 1);
        let mut rest = Film::new(1, 1);
        for (k, &v) in samples.iter().enumerate() {
            let part = if k < 2 { &mut film } else { &mut rest };
            part.add_sample(0, 0, Vec3::splat(v as f32));
        }
        film.merge(&rest).unwrap();
        let n = samples.len() as f64;
        let mean = samples.iter().sum::<f64>() / n;
        let var = samples.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        assert!((film.pixel(0, 0).x as f64 - mean).abs() < 1e-6);
        assert!((film.variance_of_mean(0, 0).x as f64 - var / n).abs() < 1e-6);
        assert_eq!(Film::new(1, 1).variance_of_mean(0, 0), Vec3::ZERO);
    }
}
