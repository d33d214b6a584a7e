//! The film: per-pixel sums of sample values and sample counts, box-filtered (a sample
//! contributes to its own pixel only, like Mitsuba's `box` reconstruction filter); where
//! passes ask, sums of the samples' first-hit features, and the triangle each pixel's sample 0
//! met (for the exact ID passes).

use glam::{Vec2, Vec3};

/// A sample whose value was NaN or infinite, kept out of the film and reported.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BadSample {
    pub x: u32,
    pub y: u32,
    pub index: u32,
    pub value: Vec3,
}

#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Sum of sample values per pixel, row 0 at the top; f64 so long renders do not lose
    /// precision.
    sums: Vec<[f64; 3]>,
    /// Sum of squared sample values per pixel, for the variance estimate.
    sq_sums: Vec<[f64; 3]>,
    /// Samples taken per pixel (rejected NaN/Inf samples count as taken).
    counts: Vec<u32>,
    /// For adaptive sampling ([`Film::keep_halves`]): per pixel, the sums of sample values
    /// when its count last reached a power of two p and when it reached p/2, from which
    /// [`Film::halves_variance_of_mean`] compares the first and second halves of its first p
    /// samples.
    halves: Option<Vec<Halves>>,
    /// For feature layers ([`Film::keep_features`]): per pixel, the sums of its samples'
    /// first-hit features.
    features: Option<Vec<FeatureTotals>>,
    /// For ID passes ([`Film::keep_first_hits`]): per pixel, the triangle that its sample 0's
    /// camera ray met ([`NO_HIT`] where it met nothing or was not taken).
    first_hits: Option<Vec<u32>>,
}

/// A pixel's first hit where its sample 0 met nothing, or has not been taken.
pub const NO_HIT: u32 = u32::MAX;

/// The slots of [`FeatureTotals`].
pub const FEATURE_SLOTS: usize = 13;

/// A pixel's sums of its samples' first-hit features: albedo (0–2), shading normal (3–5),
/// depth (6), position (8–10) and texture coordinates (11–12) over the samples whose camera
/// ray met a surface, and their number (7). Albedo and normal are averaged over all of the
/// pixel's samples (a miss adds zero), depth, position and UV over the samples that hit.
pub type FeatureTotals = [f64; FEATURE_SLOTS];

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
pub fn add_features(totals: &mut FeatureTotals, features: Option<crate::integrators::Features>) {
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
            *t += v as f64;
        }
    }
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
    sums: &'a mut [[f64; 3]],
    sq_sums: &'a mut [[f64; 3]],
    counts: &'a mut [u32],
    halves: Option<&'a mut [Halves]>,
    features: Option<&'a mut [FeatureTotals]>,
    first_hits: Option<&'a mut [u32]>,
}

impl FilmRows<'_> {
    /// Replaces pixel (x, y)'s sums and count (the running totals a round continued from
    /// [`Film::totals`]).
    #[inline]
    pub fn set(&mut self, x: u32, y: u32, (sum, sq_sum, count): PixelTotals) {
        let i = (y - self.y0) as usize * self.width as usize + x as usize;
        if let Some(h) = self.halves.as_deref_mut() {
            record_halves(&mut h[i], self.counts[i], count, sum);
        }
        self.sums[i] = sum;
        self.sq_sums[i] = sq_sum;
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
    pub fn set_first_hit(&mut self, x: u32, y: u32, triangle: u32) {
        let i = (y - self.y0) as usize * self.width as usize + x as usize;
        if let Some(h) = self.first_hits.as_deref_mut() {
            h[i] = triangle;
        }
    }
}

/// A pixel's sum of sample values, sum of their squares, and number of samples.
pub type PixelTotals = ([f64; 3], [f64; 3], u32);

impl Film {
    /// Memory a render needs per pixel: the film's sums, squares and count (52 bytes), a
    /// round's tile results collected before they are merged (sums, squares and count: 52
    /// bytes), and the float32 RGB image made for output (12 bytes). Adaptive sampling and
    /// checkpoints need more ([`Film::ADAPTIVE_BYTES_PER_PIXEL`],
    /// [`Film::CHECKPOINT_BYTES_PER_PIXEL`]).
    pub const BYTES_PER_PIXEL: u64 = 52 + 52 + 12;

    /// Adaptive sampling's extra memory per pixel: the active and selected masks (2 bytes),
    /// the judgement's three f64 error images (own, row maximum, neighbourhood maximum)
    /// plus the selection's gains (32 bytes), and the film's sums of the two halves (48 bytes,
    /// [`Film::keep_halves`]).
    pub const ADAPTIVE_BYTES_PER_PIXEL: u64 = 2 + 32 + Self::HALVES_BYTES_PER_PIXEL;

    /// The sums of the two halves that adaptive sampling keeps per pixel
    /// ([`Film::keep_halves`]).
    pub const HALVES_BYTES_PER_PIXEL: u64 = 48;

    /// A checkpoint's extra memory per pixel: the snapshot of the film it writes (52 bytes).
    pub const CHECKPOINT_BYTES_PER_PIXEL: u64 = 52;

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

    /// The memory [`Film::keep_features`] adds, per pixel: the film's feature totals and a
    /// round's copy of them for its tiles ([`FEATURE_SLOTS`] f64 each).
    pub const FEATURES_BYTES_PER_PIXEL: u64 = 2 * 8 * FEATURE_SLOTS as u64;

    /// Keeps, from now on, each pixel's first-hit feature totals ([`Film::features`]). Call
    /// on a new film.
    pub fn keep_features(&mut self) {
        self.features = Some(zeroed_by_writing(self.counts.len()));
    }

    /// True when the film keeps feature totals.
    pub fn keeps_features(&self) -> bool {
        self.features.is_some()
    }

    /// The memory [`Film::keep_first_hits`] adds, per pixel: the film's triangle and a
    /// round's copy of it for its tiles.
    pub const FIRST_HITS_BYTES_PER_PIXEL: u64 = 8;

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
    pub fn first_hit(&self, x: u32, y: u32) -> Option<u32> {
        let t = self.first_hits.as_ref()?[self.index(x, y)];
        (t != NO_HIT).then_some(t)
    }

    /// Pixel (x, y)'s first hit as the film stores it ([`NO_HIT`] where it keeps none).
    #[inline]
    pub fn first_hit_raw(&self, x: u32, y: u32) -> u32 {
        self.first_hits
            .as_ref()
            .map_or(NO_HIT, |h| h[self.index(x, y)])
    }

    /// Pixel (x, y)'s feature totals (zero where the film keeps none).
    #[inline]
    pub fn feature_totals(&self, x: u32, y: u32) -> FeatureTotals {
        self.features
            .as_ref()
            .map_or([0.0; FEATURE_SLOTS], |f| f[self.index(x, y)])
    }

    /// Pixel (x, y)'s mean first-hit features; None where the film keeps none or the pixel
    /// has no samples.
    pub fn features(&self, x: u32, y: u32) -> Option<PixelFeatures> {
        let f = self.features.as_ref()?[self.index(x, y)];
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

    /// Adds `count` samples whose values sum to `sum` (and whose squares sum to `sq_sum`) to
    /// pixel (x, y).
    #[inline]
    pub fn add(&mut self, x: u32, y: u32, sum: [f64; 3], sq_sum: [f64; 3], count: u32) {
        let i = self.index(x, y);
        for c in 0..3 {
            self.sums[i][c] += sum[c];
            self.sq_sums[i][c] += sq_sum[c];
        }
        let old = self.counts[i];
        self.counts[i] += count;
        if let Some(h) = self.halves.as_mut() {
            record_halves(&mut h[i], old, old + count, self.sums[i]);
        }
    }

    /// The estimated variance of pixel (x, y)'s mean: the unbiased sample variance of its
    /// samples divided by their number (0 with fewer than two samples).
    pub fn variance_of_mean(&self, x: u32, y: u32) -> Vec3 {
        let i = self.index(x, y);
        let n = self.counts[i] as f64;
        if n < 2.0 {
            return Vec3::ZERO;
        }
        let v = |c: usize| {
            let mean = self.sums[i][c] / n;
            (((self.sq_sums[i][c] - mean * self.sums[i][c]) / (n - 1.0)).max(0.0) / n) as f32
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
        let s = self.sums[i];
        let inv = 1.0 / n as f64;
        Vec3::new(
            (s[0] * inv) as f32,
            (s[1] * inv) as f32,
            (s[2] * inv) as f32,
        )
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
        let samples: Vec<f64> = (0..70).map(|i| ((i * 37 % 11) as f64).sqrt()).collect();
        // One sample at a time through `add`.
        let mut film = Film::new(1, 1);
        film.keep_halves();
        for (k, &v) in samples.iter().enumerate() {
            film.add(0, 0, [v; 3], [v * v; 3], 1);
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
            let s: f64 = samples[..n].iter().sum();
            let q: f64 = samples[..n].iter().map(|v| v * v).sum();
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
            let s: f64 = long[..n].iter().sum();
            ([s; 3], [0.0; 3], n as u32)
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
    fn variance_of_the_mean_matches_the_textbook_formula() {
        let samples = [0.0f64, 1.0, 1.0, 3.0, 5.0];
        let mut film = Film::new(1, 1);
        // Added in two parts.
        for part in [&samples[..2], &samples[2..]] {
            let sum = part.iter().sum::<f64>();
            let sq = part.iter().map(|v| v * v).sum::<f64>();
            film.add(0, 0, [sum; 3], [sq; 3], part.len() as u32);
        }
        let n = samples.len() as f64;
        let mean = samples.iter().sum::<f64>() / n;
        let var = samples.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        assert!((film.pixel(0, 0).x as f64 - mean).abs() < 1e-6);
        assert!((film.variance_of_mean(0, 0).x as f64 - var / n).abs() < 1e-6);
        assert_eq!(Film::new(1, 1).variance_of_mean(0, 0), Vec3::ZERO);
    }
}
