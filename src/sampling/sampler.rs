//! Per-pixel samplers, addressed by (pixel, sample index, dimension).
//!
//! A renderer calls [`PixelSampler::start`] for one sample of one pixel and then draws
//! [`PixelSampler::next_1d`] / [`PixelSampler::next_2d`] / [`PixelSampler::next_2x2d`] /
//! [`PixelSampler::next_2d_set`] in a fixed order; the i-th call is the sample's i-th
//! *dimension slot*. Every value is a pure function of (seed, pixel, sample index, slot), so
//! the image is the same whatever thread renders which pixel.
//!
//! | kind         | what it is                                                               |
//! |--------------|--------------------------------------------------------------------------|
//! | `random`     | independent uniform numbers from a counter-based hash (SplitMix64)       |
//! | `stratified` | correlated multi-jittered sampling (Kensler 2013) in each 2D slot: one   |
//! |              | sample per cell of an m×n grid, m·n ≥ spp, and one per 1/spp column and  |
//! |              | row when spp = m·n; 1D slots are jittered 1/spp strata. Any spp works.   |
//! |              | Each slot permutes its strata with its own key, so slots are decorrelated|
//! | `sobol`      | Owen-scrambled Sobol (Burley 2020; [`super::sobol`]): every slot         |
//! |              | uses the first two Sobol dimensions, a (0,2)-sequence, with its own      |
//! |              | scramble and index shuffle (Burley's padding); at most 65 536 spp.       |

use glam::Vec2;

use super::hash::{hash_words, mix64, permute, u32_to_unit_f32, unit_f32};
use super::sobol;

/// The most samples per pixel the `sobol` sampler supports (16-bit indices).
pub const SOBOL_MAX_SPP: u32 = sobol::MAX_INDEX;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum SamplerKind {
    Random,
    #[default]
    Stratified,
    Sobol,
}

crate::display_as_value_name!(SamplerKind);

/// The sample generator of one thread; cheap to create and to restart per pixel sample.
#[derive(Clone, Debug)]
pub struct PixelSampler {
    kind: SamplerKind,
    seed: u64,
    spp: u32,
    /// Grid of the 2D stratified pattern: m columns × n rows, m·n ≥ spp.
    grid_m: u32,
    grid_n: u32,
    /// The pixel of the current sample, its key, and the keys of its first dimension slots
    /// (the same for every sample of the pixel, so computed once per pixel).
    pixel: (u32, u32),
    pixel_key: u64,
    slot_keys: [u64; CACHED_SLOTS],
    /// With `sobol`, each cached slot's sequence, its scramble keys hashed.
    slot_sequences: [sobol::Sequence; CACHED_SLOTS],
    cached_slots: u32,
    index: u32,
    slot: u32,
    /// The value drawn with the current sample's film position ([`PixelSampler::next_film`]).
    film_pair: Option<Vec2>,
    /// With `sobol`, the sequence of the current sample's first bounce slot, whose index
    /// shuffle the later bounces share ([`PixelSampler::next_bounce_2x2d`]).
    first_bounce: Option<sobol::Sequence>,
}

/// The m × n grid of the correlated multi-jittered pattern for `spp` samples.
///
/// An exact factorisation spp = m·n with m ≤ n ≤ 2m when there is one (512 = 16 × 32,
/// 500 = 20 × 25), so every cell holds a sample. Otherwise Kensler's (2013) grid for a
/// square pixel, m = ⌊√spp⌋ and n = ⌈spp/m⌉, with m·n − spp cells left empty at random:
/// the empty cells cost stratification (measured on a disk-indicator integrand, 512 samples
/// in Kensler's 22 × 24 grid gave 1.5× the RMSE of 484 in 22 × 22), so they are the
/// fallback, for sample counts such as primes.
pub fn cmj_grid(spp: u32) -> (u32, u32) {
    let spp = spp.max(1);
    let root = ((spp as f64).sqrt().floor() as u32).max(1);
    let low = ((spp as f64 / 2.0).sqrt().ceil() as u32).max(1);
    if let Some(m) = (low..=root).rev().find(|&m| spp.is_multiple_of(m)) {
        return (m, spp / m);
    }
    (root, spp.div_ceil(root))
}

/// Dimension-slot keys kept per pixel: enough for path tracing to depth 7.
const CACHED_SLOTS: usize = 16;

/// Samplers whose points [`PixelSampler::next_2d_lanes`] computes side by side.
const LANES: usize = 8;

impl PixelSampler {
    /// A sampler for `spp` samples per pixel.
    pub fn new(kind: SamplerKind, spp: u32, seed: u64) -> PixelSampler {
        let spp = spp.max(1);
        let (m, n) = cmj_grid(spp);
        PixelSampler {
            kind,
            seed,
            spp,
            grid_m: m,
            grid_n: n,
            pixel: (u32::MAX, u32::MAX),
            pixel_key: 0,
            slot_keys: [0; CACHED_SLOTS],
            slot_sequences: [sobol::Sequence::default(); CACHED_SLOTS],
            cached_slots: 0,
            index: 0,
            slot: 0,
            film_pair: None,
            first_bounce: None,
        }
    }

    pub fn kind(&self) -> SamplerKind {
        self.kind
    }

    /// Begins sample `index` of pixel (x, y).
    #[inline]
    pub fn start(&mut self, x: u32, y: u32, index: u32) {
        if (x, y) != self.pixel {
            self.pixel = (x, y);
            self.pixel_key = hash_words(&[self.seed, ((y as u64) << 32) | x as u64]);
            self.cached_slots = 0;
        }
        self.index = index;
        self.slot = 0;
        self.film_pair = None;
        self.first_bounce = None;
    }

    /// The key of the current dimension slot and, with `sobol`, its sequence (the default
    /// otherwise); advance to the next slot.
    #[inline]
    fn next_slot(&mut self) -> (u64, sobol::Sequence) {
        let slot = self.slot;
        self.slot += 1;
        if slot < self.cached_slots {
            return (
                self.slot_keys[slot as usize],
                self.slot_sequences[slot as usize],
            );
        }
        let key = hash_words(&[self.pixel_key, slot as u64]);
        let sequence = self.slot_sequence(key);
        if slot == self.cached_slots && (slot as usize) < CACHED_SLOTS {
            self.slot_keys[slot as usize] = key;
            self.slot_sequences[slot as usize] = sequence;
            self.cached_slots += 1;
        }
        (key, sequence)
    }

    /// Passes over the next dimension slot without computing its value, for a value the
    /// caller does not need (the roulette's before its first bounce): the slots after it
    /// keep their dimensions, as if it had been drawn.
    #[inline]
    pub fn skip_slot(&mut self) {
        if self.slot < self.cached_slots || self.slot as usize >= CACHED_SLOTS {
            self.slot += 1;
        } else {
            // The first sample of the pixel to reach this slot: cache its key as a draw does,
            // or the slots after it would not be cached.
            self.next_slot();
        }
    }

    #[inline(always)]
    pub fn next_1d(&mut self) -> f32 {
        let (key, sequence) = self.next_slot();
        match self.kind {
            SamplerKind::Random => unit_f32(hash_words(&[key, self.index as u64])),
            SamplerKind::Stratified => {
                if self.index >= self.spp {
                    return unit_f32(hash_words(&[key, self.index as u64]));
                }
                let stratum = permute(self.index, self.spp, key as u32);
                let jitter = unit_f32(hash_words(&[key ^ 0x5851_f42d, self.index as u64]));
                in_stratum(stratum, jitter, self.spp)
            }
            SamplerKind::Sobol => sequence.sample_1d(self.index) + SOBOL_HALF_CELL,
        }
    }

    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let (key, sequence) = self.next_slot();
        match self.kind {
            SamplerKind::Random => random_2d(key, self.index as u64),
            SamplerKind::Stratified => self.cmj_2d(key),
            SamplerKind::Sobol => sobol_2d(&sequence, self.index),
        }
    }

    /// [`PixelSampler::next_2d`] of several samplers: `out[k]` from `samplers[which[k]]`, the
    /// same values in the same slots. With `sobol` the points are computed side by side,
    /// eight at a time, so that their chains of multiplies and lookups overlap (1.35× as fast
    /// as one after another, `cargo bench --bench ao -- sobol`).
    pub fn next_2d_lanes(samplers: &mut [PixelSampler], which: &[usize], out: &mut [Vec2]) {
        debug_assert_eq!(which.len(), out.len());
        for (which, out) in which.chunks(LANES).zip(out.chunks_mut(LANES)) {
            if samplers[which[0]].kind != SamplerKind::Sobol {
                for (&s, out) in which.iter().zip(out) {
                    *out = samplers[s].next_2d();
                }
                continue;
            }
            let (sequences, indices) = Self::slot_lanes(samplers, which);
            let points = sobol::sample_2d_lanes(&sequences, &indices);
            for (out, point) in out.iter_mut().zip(points) {
                *out = sobol_open_2d(point);
            }
        }
    }

    /// [`PixelSampler::next_film`] of several samplers, side by side as in
    /// [`PixelSampler::next_2d_lanes`].
    pub fn next_film_lanes(samplers: &mut [PixelSampler], which: &[usize], out: &mut [Vec2]) {
        debug_assert_eq!(which.len(), out.len());
        for (which, out) in which.chunks(LANES).zip(out.chunks_mut(LANES)) {
            if samplers[which[0]].kind != SamplerKind::Sobol {
                for (&s, out) in which.iter().zip(out) {
                    *out = samplers[s].next_film();
                }
                continue;
            }
            let (sequences, indices) = Self::slot_lanes(samplers, which);
            let points = sobol::sample_4d_lanes(&sequences, &indices);
            for ((out, &s), [a, b, c, d]) in out.iter_mut().zip(which).zip(points) {
                *out = sobol_open_2d([c, d]);
                samplers[s].film_pair = Some(sobol_open_2d([a, b]));
            }
        }
    }

    /// Advances `samplers[which[k]]` (`sobol`, at most [`LANES`]) past their next slot and
    /// returns each slot's sequence and sample index, for points computed side by side;
    /// lanes past `which.len()` repeat the first, and are not used.
    #[inline]
    fn slot_lanes(
        samplers: &mut [PixelSampler],
        which: &[usize],
    ) -> ([sobol::Sequence; LANES], [u32; LANES]) {
        let mut sequences = [sobol::Sequence::default(); LANES];
        let mut indices = [0u32; LANES];
        for (k, &s) in which.iter().enumerate() {
            let sampler = &mut samplers[s];
            debug_assert_eq!(sampler.kind, SamplerKind::Sobol);
            sequences[k] = sampler.next_slot().1;
            indices[k] = sampler.index;
        }
        for k in which.len()..LANES {
            (sequences[k], indices[k]) = (sequences[0], indices[0]);
        }
        (sequences, indices)
    }

    /// Two 2D values from one dimension slot. `sobol` evaluates one 4D point (dimensions 0–3
    /// of the Sobol sequence, one index shuffle for the four: a little less than two
    /// [`PixelSampler::next_2d`], and one slot key); `stratified` gives two independently
    /// permuted CMJ patterns; `random` two independent pairs. For consumers that draw several
    /// values per bounce.
    #[inline]
    pub fn next_2x2d(&mut self) -> (Vec2, Vec2) {
        // The second value's key, for the kinds that key each value.
        const SECOND: u64 = 0x6a09_e667_f3bc_c908;
        let (key, sequence) = self.next_slot();
        match self.kind {
            SamplerKind::Random => {
                let index = self.index as u64;
                (random_2d(key, index), random_2d(key ^ SECOND, index))
            }
            SamplerKind::Stratified => (self.cmj_2d(key), self.cmj_2d(mix64(key ^ SECOND))),
            SamplerKind::Sobol => {
                let [a, b, c, d] = sequence.sample_4d(self.index);
                (sobol_open_2d([a, b]), sobol_open_2d([c, d]))
            }
        }
    }

    /// [`PixelSampler::next_2x2d`] for bounce `bounce` (1, 2, …) of a path, drawn from a slot
    /// of its own as that is. With `sobol`, the bounces share one Sobol sequence: bounce k
    /// takes dimensions 4(k − 1) to 4k − 1 under the first bounce's index shuffle (each
    /// dimension scrambled with its own slot's keys), so the bounces' points are stratified
    /// jointly, not only each bounce's four dimensions among themselves. Up to
    /// [`sobol::DIMENSION_SETS`] bounces; later ones, and a bounce drawn without the first,
    /// are padded as [`PixelSampler::next_2x2d`] pads. The first bounce keeps dimensions
    /// 0–3, whose 2D projections are the best stratified: it carries most of the indirect
    /// light. The other kinds draw [`PixelSampler::next_2x2d`].
    #[inline]
    pub fn next_bounce_2x2d(&mut self, bounce: u32) -> (Vec2, Vec2) {
        if self.kind != SamplerKind::Sobol {
            return self.next_2x2d();
        }
        let (_, sequence) = self.next_slot();
        let [a, b, c, d] = match (bounce, self.first_bounce) {
            (1, _) => {
                self.first_bounce = Some(sequence);
                sequence.sample_4d(self.index)
            }
            (2..=sobol::DIMENSION_SETS, Some(first)) => sequence
                .with_shuffle_of(&first)
                .sample_4d_of_set(self.index, bounce - 1),
            _ => sequence.sample_4d(self.index),
        };
        (sobol_open_2d([a, b]), sobol_open_2d([c, d]))
    }

    /// The sample's position in the pixel, from its first slot: the second value of
    /// [`PixelSampler::next_2x2d`] there (with `sobol`, dimensions 2–3 of the slot's 4D
    /// point). The first is kept for [`PixelSampler::paired_with_film`]: dimensions 0–1
    /// project to the better-stratified 2D set, and the film position needs it least, since
    /// it matters only where the pixel holds an edge, the value paired with it everywhere.
    #[inline]
    pub fn next_film(&mut self) -> Vec2 {
        debug_assert_eq!(self.slot, 0, "the film position is the sample's first slot");
        let (pair, film) = self.next_2x2d();
        self.film_pair = Some(pair);
        film
    }

    /// The value drawn with the film position ([`PixelSampler::next_film`]), stratified
    /// together with it, which suits a value whose effect depends on where in the pixel the
    /// sample lies, such as the light point or the AO direction of the camera ray's hit (an
    /// edge or a penumbra crossing the pixel). A sampler that has not drawn its film
    /// position draws a slot of its own instead (`next_2d`).
    #[inline]
    pub fn paired_with_film(&mut self) -> Vec2 {
        match self.film_pair {
            Some(pair) => pair,
            None => self.next_2d(),
        }
    }

    /// The value drawn with the film position, as [`PixelSampler::paired_with_film`] gives
    /// it; None until the film position is drawn.
    pub fn film_pair(&self) -> Option<Vec2> {
        self.film_pair
    }

    #[inline]
    fn cmj_2d(&self, key: u64) -> Vec2 {
        cmj_point(self.index, self.spp, (self.grid_m, self.grid_n), key)
    }

    /// One dimension slot holding `n` 2D points that are used together for the current
    /// sample, such as the `--ao-samples` directions of one camera hit. Point k of sample i
    /// is point i·n + k of a sequence of spp·n points in that slot, so a pixel's spp·n points
    /// are stratified as a whole (and, with `sobol` and a power-of-two n, the n points of
    /// each sample too: Burley's index shuffle maps the aligned block [i·n, i·n + n) of
    /// indices to an aligned block, a (0, log₂n, 2)-net). Drawing the n points from n slots
    /// instead would make them independent within the sample, and cost a slot key each.
    /// With n = 1 the point is the one [`PixelSampler::next_2d`] gives.
    #[inline]
    pub fn next_2d_set(&mut self, n: u32) -> PointSet2d {
        let (key, sequence) = self.next_slot();
        self.point_set(key, sequence, n)
    }

    /// [`PixelSampler::next_2d_set`] from a slot of its own, named by `stream`, outside the
    /// sequence of slots the `next_*` calls draw from: the next call still gets the slot it
    /// would have had. For estimates the renderer adds beside an integrator's own (the
    /// emitters the camera sees, [`crate::render`]), which must not shift the integrator's
    /// dimensions. Every sample of a pixel takes its points from the same spp·n-point set.
    #[inline]
    pub fn side_2d_set(&self, stream: u32, n: u32) -> PointSet2d {
        // Ordinary slots hash (pixel key, slot number), slot numbers being small; a side
        // stream sets the top bit, so the two never share a key.
        let key = hash_words(&[self.pixel_key, (1 << 63) | stream as u64]);
        self.point_set(key, self.slot_sequence(key), n)
    }

    /// With `sobol`, the Owen-scrambled sequence of the slot whose key is `key` (its seed:
    /// the key's top half); unused by the other kinds.
    #[inline]
    fn slot_sequence(&self, key: u64) -> sobol::Sequence {
        if self.kind == SamplerKind::Sobol {
            sobol::Sequence::new((key >> 32) as u32)
        } else {
            sobol::Sequence::default()
        }
    }

    /// The current sample's `n` points of the spp·n-point set of a slot.
    #[inline]
    fn point_set(&self, key: u64, sequence: sobol::Sequence, n: u32) -> PointSet2d {
        let n = n.max(1) as u64;
        let count = self.spp as u64 * n;
        PointSet2d {
            kind: self.kind,
            key,
            sequence,
            first: self.index as u64 * n,
            count,
            grid: if self.kind == SamplerKind::Stratified && count <= u32::MAX as u64 {
                cmj_grid(count as u32)
            } else {
                (0, 0)
            },
        }
    }
}

/// The points of one [`PixelSampler::next_2d_set`] slot.
#[derive(Clone, Copy, Debug)]
pub struct PointSet2d {
    kind: SamplerKind,
    key: u64,
    /// With `sobol`, the sequence of the slot's first 2^16 points.
    sequence: sobol::Sequence,
    /// Sequence index of the set's first point, and the sequence's length (spp·n).
    first: u64,
    count: u64,
    /// The CMJ grid of `count` points (`stratified` only).
    grid: (u32, u32),
}

impl PointSet2d {
    /// Point `k` of the set (k < n).
    #[inline]
    pub fn get(&self, k: u32) -> Vec2 {
        let index = self.first + k as u64;
        match self.kind {
            SamplerKind::Random => random_2d(self.key, index),
            SamplerKind::Stratified => {
                if self.count > u32::MAX as u64 {
                    random_2d(self.key, index)
                } else {
                    cmj_point(index as u32, self.count as u32, self.grid, self.key)
                }
            }
            SamplerKind::Sobol => {
                // Sequences hold 2^16 points: each further block of 2^16 indices takes its
                // own scramble (an aligned power-of-two set never straddles two blocks).
                let block = index >> 16;
                let sequence = if block == 0 {
                    self.sequence
                } else {
                    let seed = mix64(self.key ^ block.wrapping_mul(0x9e37_79b9_7f4a_7c15)) as u32;
                    sobol::Sequence::new(seed)
                };
                sobol_2d(&sequence, (index & 0xffff) as u32)
            }
        }
    }
}

/// Dimensions 0 and 1 of point `index` of an Owen-scrambled Sobol sequence, moved to the
/// centre of their 2^-23 cells.
#[inline]
fn sobol_2d(sequence: &sobol::Sequence, index: u32) -> Vec2 {
    sobol_open_2d(sequence.sample_2d(index))
}

/// A 2D Sobol point moved to the centre of its 2^-23 cell (see [`SOBOL_HALF_CELL`]).
#[inline]
fn sobol_open_2d([x, y]: [f32; 2]) -> Vec2 {
    Vec2::new(x, y) + Vec2::splat(SOBOL_HALF_CELL)
}

/// An independent uniform 2D point from a key and an index.
#[inline]
fn random_2d(key: u64, index: u64) -> Vec2 {
    let h = hash_words(&[key, index]);
    Vec2::new(u32_to_unit_f32(h as u32), u32_to_unit_f32((h >> 32) as u32))
}

/// Point `index` of a correlated multi-jittered pattern of `spp` points in the grid `(m, n)`
/// (Kensler 2013, §4–5), keyed by `key`; past `spp`, independent points. The sample's cell
/// in the m×n grid is a permutation of its index; within the cell, the sub-column and
/// sub-row come from permutations shared by each row and column, which gives the n-rooks
/// property over spp = m·n columns and rows.
///
/// When spp < m·n, the spp cells are drawn from all m·n by the (keyed) permutation of the
/// whole grid. Taking always the first spp cells, as a permutation of [0, spp) does, leaves
/// the same cells of the last row empty in every pixel: the top strip of the square is then
/// under-sampled (6 samples instead of 21 at spp = 512), a bias that more samples do not
/// remove. For spp = m·n both are the same permutation.
#[inline]
fn cmj_point(index: u32, spp: u32, (m, n): (u32, u32), key: u64) -> Vec2 {
    if index >= spp {
        return random_2d(key, index as u64);
    }
    let k = key as u32;
    let k2 = (key >> 32) as u32;
    let s = permute(index, m * n, k);
    let (col, row) = (s % m, s / m);
    let sub_x = permute(row, n, k2 ^ 0x68bc_21eb);
    let sub_y = permute(col, m, k2 ^ 0x02e5_be93);
    let h = hash_words(&[key ^ 0x967a_889b, s as u64]);
    let (jx, jy) = (u32_to_unit_f32(h as u32), u32_to_unit_f32((h >> 32) as u32));
    // (col + (sub_x + jx)/n)/m = (col·n + sub_x + jx)/(m·n): the fine column is an integer.
    let x = in_stratum(col * n + sub_x, jx, m * n);
    let y = in_stratum(row * m + sub_y, jy, m * n);
    Vec2::new(x, y)
}

/// (k + jitter)/count as an f32 that lies in stratum k, [k/count, (k+1)/count): computed in
/// f64 and nudged by one ulp where rounding to f32 would cross a stratum edge.
#[inline]
fn in_stratum(k: u32, jitter: f32, count: u32) -> f32 {
    let count = count as f64;
    let v = ((k as f64 + jitter as f64) / count) as f32;
    if v as f64 >= (k as f64 + 1.0) / count {
        v.next_down()
    } else if (v as f64) < k as f64 / count {
        v.next_up()
    } else {
        v
    }
}

/// Sobol values are multiples of 2^-23 in [0, 1); moving each to the centre of its 2^-23 cell
/// keeps every elementary interval (all are coarser) and excludes 0 exactly, as the other
/// samplers do.
const SOBOL_HALF_CELL: f32 = 0.5 / (1u32 << 23) as f32;
