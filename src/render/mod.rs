//! The parallel frontend: the image is cut into tiles that rayon renders in passes of
//! samples; a film accumulates each pixel's samples one by one in sample-index order, so the
//! image is bit-identical whatever the thread count, and whatever the passes.
//!
//! Passes split the samples per pixel into ranges of doubling size, or longer ones that last
//! at least [`RenderSettings::min_pass_seconds`] ([`fixed_pass_end`]). A fixed-spp render
//! whose passes follow the clock first samples one tile in [`PROBE_TILE_STRIDE`] once, to
//! measure its speed, so that its first pass over the whole image can already last that long
//! ([`first_pass_end`]): a short render then sweeps the image once. Between passes (and before
//! each tile) the render checks its cancel flag, so an interrupted render still holds a usable
//! image, with the number of samples each pixel received.
//!
//! With a [`Checkpoint`], each pass renders its tiles in groups and hands the running film to
//! a callback between groups, at most once per period. The groups are merged in tile order,
//! and every pixel still receives its passes in order, so the image is the same bit for bit.
//!
//! [`Stopping`] ends sampling early. With a target error (adaptive sampling), the film is
//! examined between passes and pixels whose estimated relative error has reached the target
//! receive no further samples ([`adaptive`]); the decision reads only the film, which is the
//! same on any thread count, so an adaptive image is bit-identical across thread counts too.
//! A time limit stops the render between tiles; how far it got depends on the machine's
//! speed, so a time-limited image is not reproducible (each pixel's samples still are).
//!
//! [`RenderSettings::sample_range`] renders only the samples of index a..b of every pixel (a
//! farm shard's part). The film's sums are exact integers ([`film`]), so [`Film::merge`] of
//! the films of disjoint ranges is the film of their union, bit for bit.

pub mod adaptive;
pub mod film;
pub mod merge;
pub mod output;
pub mod partial;
pub mod passes;
pub mod resume;
pub mod view;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use glam::{Vec2, Vec3A};
use indicatif::ProgressBar;
use rayon::prelude::*;

use crate::accel::culling::{self, BlockMask};
use crate::accel::{SceneBox, PACKET};
use crate::integrators::emitters::EmitterView;
use crate::integrators::{Context, Integrator, RayCounts, SampleRecord};
pub use crate::record::{first_hit, split_first_hit, FirstHit, NO_HIT};
use crate::sampling::{warps, PixelSampler, SamplerKind};
use crate::scene::{Camera, RayGenerator};
use film::add_features;
pub use film::{
    BadSample, FeatureTotals, Film, FilmRows, MergeError, PixelFeatures, PixelTotals, RoundTotals,
    WideTotals, FEATURE_SLOTS,
};

/// The default of [`RenderSettings::min_pass_seconds`]: passes shorter than this paid a
/// few percent each for sweeping the image again.
pub const DEFAULT_MIN_PASS_SECONDS: f64 = 0.5;

/// A fixed-spp render whose passes follow the clock begins with a probe: one sample per
/// pixel in every `PROBE_TILE_STRIDE`-th tile (in scanline order, so spread over the
/// image's rows), which measures the render's speed before its first full pass.
pub const PROBE_TILE_STRIDE: usize = 16;

/// How many NaN/Inf samples are kept for the report.
pub const BAD_SAMPLES_KEPT: usize = 8;

#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u64,
    pub sampler: SamplerKind,
    pub integrator: Integrator,
    pub tile_size: u32,
    /// Fixed-spp renders: each pass takes at least the samples per pixel that fill this many
    /// seconds at the rate measured so far, the first one at the rate of a probe of one tile
    /// in [`PROBE_TILE_STRIDE`] ([`first_pass_end`], [`fixed_pass_end`]); 0 gives passes of
    /// 1, 1, 2, 4, … samples and no probe. The image does not depend on it.
    pub min_pass_seconds: f64,
    /// Render only pixels x0 ≤ x < x1, y0 ≤ y < y1 (the rest of the film stays empty).
    pub crop: Option<(u32, u32, u32, u32)>,
    /// When to stop before `spp` samples per pixel.
    pub stopping: Stopping,
    /// Take only the samples of index a ≤ i < b of every pixel (a ≤ b ≤ `spp`; None: all
    /// `spp`), into a film that holds just those (its counts are b − a): a farm shard's
    /// part of the image, whose films [`Film::merge`] joins into the film of the whole
    /// range, bit for bit. Fixed-spp renders only (no [`Stopping`]).
    pub sample_range: Option<(u32, u32)>,
}

impl RenderSettings {
    /// The sample indices every pixel takes, [a, b) ([`RenderSettings::sample_range`]).
    pub fn samples(&self) -> (u32, u32) {
        self.sample_range.unwrap_or((0, self.spp))
    }
}

/// Early stopping: adaptive sampling per pixel, and a time limit for the whole render. With
/// neither (the default), every pixel receives exactly `spp` samples. Either way every pixel
/// receives at least one sample (unless the render is cancelled).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stopping {
    /// Adaptive sampling: a pixel stops once its estimated standard error (and that of its
    /// eight neighbours) is at most this ([`adaptive::pixel_error`]).
    pub target_error: Option<f32>,
    /// Adaptive sampling: the samples every pixel takes before its error is judged.
    pub min_spp: u32,
    /// Adaptive sampling: what the target error is measured against.
    pub metric: adaptive::ErrorMetric,
    /// Stop the whole render after this much time (checked between tiles, from the second
    /// round of samples on).
    pub time_limit: Option<Duration>,
}

impl Stopping {
    /// The default `min_spp`: enough samples for a variance estimate that rarely mistakes a
    /// pixel for converged (see [`adaptive`]).
    pub const DEFAULT_MIN_SPP: u32 = 16;

    /// Whether anything can stop a pixel before `spp`.
    pub fn is_progressive(&self) -> bool {
        self.target_error.is_some() || self.time_limit.is_some()
    }
}

impl Default for Stopping {
    fn default() -> Stopping {
        Stopping {
            target_error: None,
            min_spp: Self::DEFAULT_MIN_SPP,
            metric: adaptive::ErrorMetric::Relative,
            time_limit: None,
        }
    }
}

/// What a render did, besides the image.
#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    pub rays: RayCounts,
    pub seconds: f64,
    /// Passes that rendered tiles, the probe of a fixed-spp render included.
    pub passes: u32,
    /// Samples rejected because their value was NaN, infinite or out of the film's range
    /// ([`film::MAX_SAMPLE_VALUE`]).
    pub bad_samples: u64,
    /// The first few of them, in pixel order, for replay.
    pub first_bad: Vec<BadSample>,
}

pub struct RenderResult {
    pub film: Film,
    pub stats: RenderStats,
    /// True when the cancel flag stopped the render early.
    pub interrupted: bool,
    /// True when the time limit stopped the render before every pixel was done.
    pub time_limit_reached: bool,
    /// Adaptive sampling: the pixels (of the rendered window) still sampling at the end,
    /// i.e. those that reached `spp` or the time limit before the target error.
    pub unconverged_pixels: Option<u64>,
}

/// A rayon pool whose workers all run with flush-to-zero and denormals-are-zero, as Embree
/// asks. `threads = 0` uses every core.
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool, rayon::ThreadPoolBuildError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("strata-worker-{i}"))
        .start_handler(|_| crate::accel::enable_ftz_daz())
        .build()
}

#[derive(Clone, Copy, Debug)]
struct Tile {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

impl Tile {
    /// Its number of pixels.
    fn pixels(&self) -> usize {
        ((self.x1 - self.x0) * (self.y1 - self.y0)) as usize
    }
}

/// Tiles covering the window [x0, x1) × [y0, y1), in scanline order.
fn tiles((x0, y0, x1, y1): (u32, u32, u32, u32), size: u32) -> Vec<Tile> {
    let size = size.max(1);
    let mut out = Vec::new();
    for ty in (y0..y1).step_by(size as usize) {
        for tx in (x0..x1).step_by(size as usize) {
            out.push(Tile {
                x0: tx,
                y0: ty,
                x1: (tx + size).min(x1),
                y1: (ty + size).min(y1),
            });
        }
    }
    out
}

/// The end of the pass after `done` samples per pixel, in a render of `spp` that has run
/// for `seconds`: the doubling (passes of 1, 1, 2, 4, … samples end at 1, 2, 4, 8, …), or,
/// when more, the samples that take `min_pass_seconds` at the rate of the passes so far. An
/// interrupted render thus has every pixel sampled after the first pass, and at least half
/// of its samples when it has run for longer than about `min_pass_seconds`.
///
/// Each pass costs a sweep over the whole image, whose rays, BVH nodes and film no longer sit
/// in the caches: at 8 spp the four doubling passes made a one-AO-ray render 1.2× as slow as
/// one pass. The image does not depend on where passes end, since each pixel's totals
/// continue from the film in sample order (`render_tile`), so passes may follow the clock.
pub fn fixed_pass_end(done: u32, spp: u32, seconds: f64, min_pass_seconds: f64) -> u32 {
    let doubling = done.saturating_mul(2).max(1);
    let by_time = if done > 0 && seconds > 0.0 {
        let more = (done as f64 / seconds * min_pass_seconds).ceil();
        (done as f64 + more).min(u32::MAX as f64) as u32
    } else {
        0
    };
    doubling.max(by_time).min(spp)
}

/// The end of the first pass over the whole image of a render of `spp` samples per pixel
/// that takes `seconds_per_sample` per sample per pixel (measured by the probe): the
/// samples that fill `min_pass_seconds`, at least 1 and at most `spp`. A short render thus
/// sweeps the image once, where a first pass of one sample would make it sweep twice (at
/// 8 spp the second sweep cost a one-AO-ray render 4%); a long one still samples every pixel
/// in its first pass within about `min_pass_seconds`.
pub fn first_pass_end(spp: u32, seconds_per_sample: f64, min_pass_seconds: f64) -> u32 {
    let fill = (min_pass_seconds / seconds_per_sample).ceil();
    if fill.is_nan() {
        return 1;
    }
    (fill.min(spp as f64) as u32).clamp(1, spp.max(1))
}

/// The end of the next pass of a pixel that has `count` samples, in a progressive render
/// (adaptive or time-limited): doubling as in [`fixed_pass_end`] up to `min_spp` samples, then
/// growing by about a quarter (a power of two, at least 8, dividing `count`, so passes end
/// on round numbers), so a pixel overshoots the count at which it converged by at most
/// ~25%, and the film is judged about 3 log2(spp) times. Never past `spp`.
pub fn progressive_next(count: u32, min_spp: u32, spp: u32) -> u32 {
    let min_spp = min_spp.clamp(1, spp.max(1));
    let end = if count < min_spp {
        count.saturating_mul(2).max(1).min(min_spp)
    } else {
        let quarter = (count / 4).max(8);
        let grow =
            (1u32 << (31 - quarter.leading_zeros())).min(1u32 << count.trailing_zeros().min(31));
        count.saturating_add(grow.max(1))
    };
    end.min(spp)
}

/// Which samples a round renders: every pixel of the window that the selection (if any)
/// marks takes the samples from its count up to `next(count)`.
struct Round<'a> {
    film: &'a Film,
    /// The index of each pixel's first sample in the film ([`RenderSettings::sample_range`]).
    offset: u32,
    /// Indexed like the film; `None`: every pixel of the window.
    selection: Option<&'a [bool]>,
    /// Every pixel of a tile holds the same count: true but in a resumed render, whose
    /// film may come from another tiling.
    uniform: bool,
    next: &'a (dyn Fn(u32) -> u32 + Sync),
}

impl Round<'_> {
    #[inline]
    fn samples(&self, x: u32, y: u32) -> (u32, u32) {
        let width = self.film.width as usize;
        if self
            .selection
            .is_some_and(|s| !s[y as usize * width + x as usize])
        {
            return (0, 0);
        }
        let c = self.film.count(x, y);
        (self.offset + c, self.offset + (self.next)(c).max(c))
    }

    fn tile_has_work(&self, t: &Tile) -> bool {
        if self.selection.is_none() && self.uniform {
            // Without a selection every pixel of a tile has the same count (a round is only
            // ever cut short between tiles), so the tile's first pixel speaks for all.
            let (a, b) = self.samples(t.x0, t.y0);
            return b > a;
        }
        (t.y0..t.y1).any(|y| {
            (t.x0..t.x1).any(|x| {
                let (a, b) = self.samples(x, y);
                b > a
            })
        })
    }
}

/// Every tile's [`RoundTotals`] of the current round (what the round adds to each pixel), tile
/// after tile in one allocation made once per render, and each tile's list of wide entries
/// for its pixels that overflow them (kept from round to round). Buffers allocated per round
/// came back from the allocator as fresh zero pages, each taking a copy-on-write fault (and a
/// TLB flush of the other threads) on first use; buffers allocated per tile grew the
/// per-thread heaps by some 4 000 `mprotect` calls in the first round.
struct TileSums {
    data: Vec<RoundTotals>,
    /// Per tile, the wide entries of its pixels ([`RoundTotals`]), emptied as the tile starts
    /// a round (its allocation kept).
    wide: Vec<Vec<WideTotals>>,
    /// The same pixels' [`FeatureTotals`], where the film keeps them; empty otherwise.
    features: Vec<FeatureTotals>,
    /// The same pixels' first hits ([`Film::first_hit`]), where the film keeps them; empty
    /// otherwise.
    first_hits: Vec<FirstHit>,
    /// Tile i's sums are `data[offsets[i]..offsets[i + 1]]`.
    offsets: Vec<usize>,
}

/// A tile's part of [`TileSums`]: its pixels' round totals and their wide entries, their
/// feature totals and their first hits (these two empty when the film keeps none).
type TileTotals<'a> = (
    &'a mut [RoundTotals],
    &'a mut Vec<WideTotals>,
    &'a mut [FeatureTotals],
    &'a mut [FirstHit],
);

/// A tile's part of [`TileSums`] to read.
type TileTotalsRef<'a> = (
    &'a [RoundTotals],
    &'a [WideTotals],
    &'a [FeatureTotals],
    &'a [FirstHit],
);

impl TileSums {
    fn new(tiles: &[Tile], features: bool, first_hits: bool) -> TileSums {
        let mut offsets = Vec::with_capacity(tiles.len() + 1);
        offsets.push(0);
        for t in tiles {
            let n = t.pixels();
            offsets.push(offsets.last().copied().unwrap_or(0) + n);
        }
        let n = offsets[tiles.len()];
        TileSums {
            data: vec![RoundTotals::default(); n],
            wide: vec![Vec::new(); tiles.len()],
            features: if features {
                vec![[0; FEATURE_SLOTS]; n]
            } else {
                Vec::new()
            },
            first_hits: if first_hits {
                vec![NO_HIT; n]
            } else {
                Vec::new()
            },
            offsets,
        }
    }

    fn get(&self, tile: usize) -> TileTotalsRef<'_> {
        let range = self.offsets[tile]..self.offsets[tile + 1];
        let features = match self.features.is_empty() {
            true => &[][..],
            false => &self.features[range.clone()],
        };
        let first_hits = match self.first_hits.is_empty() {
            true => &[][..],
            false => &self.first_hits[range.clone()],
        };
        (&self.data[range], &self.wide[tile], features, first_hits)
    }

    /// The sums of tiles `range`, one mutable [`TileTotals`] per tile.
    fn split_mut(&mut self, range: std::ops::Range<usize>) -> Vec<TileTotals<'_>> {
        let all = self.offsets[range.start]..self.offsets[range.end];
        let keep = !self.features.is_empty();
        let keep_hits = !self.first_hits.is_empty();
        let mut rest = &mut self.data[all.clone()];
        let mut rest_f = match keep {
            true => &mut self.features[all.clone()],
            false => &mut [][..],
        };
        let mut rest_h = match keep_hits {
            true => &mut self.first_hits[all],
            false => &mut [][..],
        };
        let mut wide = self.wide[range.clone()].iter_mut();
        let mut out = Vec::with_capacity(range.len());
        for i in range {
            let n = self.offsets[i + 1] - self.offsets[i];
            let (tile, tail) = std::mem::take(&mut rest).split_at_mut(n);
            rest = tail;
            let (features, tail) =
                std::mem::take(&mut rest_f).split_at_mut(if keep { n } else { 0 });
            rest_f = tail;
            let (first_hits, tail) =
                std::mem::take(&mut rest_h).split_at_mut(if keep_hits { n } else { 0 });
            rest_h = tail;
            let wide = wide.next().expect("a wide list per tile");
            out.push((tile, wide, features, first_hits));
        }
        out
    }
}

/// What a tile's round produced besides its [`RoundTotals`].
struct TileResult {
    rays: RayCounts,
    bad: u64,
    first_bad: Vec<BadSample>,
}

/// Renders the round's samples of every pixel of `tile` into `sums` (one entry per pixel, in
/// scanline order, and the tile's wide entries in `wide`; the tile's part of [`TileSums`]):
/// the round's samples of each pixel, added in index order, for the film to add to its
/// totals ([`FilmRows::add_round`]). A pixel's totals are thus the same however its samples
/// were split into rounds (and would be in any order: the sums are exact). Feature totals
/// and first hits are each pixel's in the film, continued by the round.
fn render_tile(
    ctx: &Context,
    settings: &RenderSettings,
    setup: &TileSetup,
    tile: Tile,
    round: &Round,
    (sums, wide, features, first_hits): TileTotals,
) -> TileResult {
    let TileSetup { ref mask, miss, .. } = *setup;
    let pixels = tile.pixels();
    debug_assert_eq!(sums.len(), pixels);
    wide.clear();
    // Feature totals and first hits, where the film keeps them (empty otherwise).
    let keep_features = !features.is_empty();
    let keep_first_hits = !first_hits.is_empty();
    let mut out = TileResult {
        rays: RayCounts::default(),
        bad: 0,
        first_bad: Vec::new(),
    };
    let integrator = &settings.integrator;
    // Camera rays go in packets of a PACKET_W × PACKET_H block's pixels, or one at a time
    // (`--no-camera-packets`, and where nothing is traced because nothing can be lit): then
    // each block is one pixel, its one ray traced alone.
    let traces = integrator.traces_rays(ctx);
    let packets = ctx.experiments.camera_packets && traces;
    let (block_w, block_h) = if packets {
        (PACKET_W, PACKET_H)
    } else {
        (1, 1)
    };
    let mut samplers: [PixelSampler; PACKET] =
        std::array::from_fn(|_| PixelSampler::new(settings.sampler, settings.spp, settings.seed));
    // Pixel (x, y)'s entry in `sums`.
    let at = |x: u32, y: u32| ((y - tile.y0) * (tile.x1 - tile.x0) + x - tile.x0) as usize;

    // The pixels of a block take their samples side by side, the j-th sample of each
    // pixel's range in one packet of camera rays. Each pixel still adds its samples in index
    // order, from the same sampler dimensions, and packet hits equal single-ray hits, so the
    // image is the one of blocks of one pixel (but for a ray that meets an edge shared by
    // two triangles at one distance, where the two traversals may name different triangles:
    // 1 camera ray in 4.9 M on the helmet). A block's totals stay in `acc` until its last
    // sample and are then written to `sums` whole.
    for by in (tile.y0..tile.y1).step_by(block_h as usize) {
        for bx in (tile.x0..tile.x1).step_by(block_w as usize) {
            let (bx1, by1) = ((bx + block_w).min(tile.x1), (by + block_h).min(tile.y1));
            let mut lanes = [(0u32, 0u32, 0u32, 0u32); PACKET];
            let mut n_lanes = 0;
            for y in by..by1 {
                for x in bx..bx1 {
                    let (a, b) = round.samples(x, y);
                    lanes[n_lanes] = (x, y, a, b);
                    n_lanes += 1;
                }
            }
            let lanes = &lanes[..n_lanes];
            let unseen = mask.as_ref().is_some_and(|m| !m.sees(bx, by, bx1, by1));
            // Samples to take per pixel, at most (Round::samples gives b ≥ a).
            let most = match unseen {
                true => 0,
                false => lanes.iter().map(|l| l.3 - l.2).max().unwrap_or(0),
            };
            let mut acc = [RoundTotals::default(); PACKET];
            let mut feature_acc: [FeatureTotals; PACKET] =
                std::array::from_fn(|i| match lanes.get(i) {
                    Some(&(x, y, _, _)) if keep_features => round.film.feature_totals(x, y),
                    _ => [0; FEATURE_SLOTS],
                });
            // Each pixel's first hit: the film's, until its sample 0 is taken. A block that
            // cannot see the scene, and a packet that misses the scene's box, leave it at
            // NO_HIT (their samples meet nothing).
            let mut first_hit_acc = [NO_HIT; PACKET];
            if keep_first_hits {
                for (hit, &(x, y, _, _)) in first_hit_acc.iter_mut().zip(lanes) {
                    *hit = round.film.first_hit_raw(x, y);
                }
            }
            // A block that cannot see the scene (`mask`) takes the estimate of a miss for
            // each of its samples, untraced and unsampled: the sums a traced miss would have
            // added. A zero estimate (AO) adds nothing to the sums.
            if unseen {
                for (acc, &(x, y, a, b)) in acc.iter_mut().zip(lanes) {
                    out.rays.camera += (b - a) as u64;
                    out.rays.culled += (b - a) as u64;
                    if miss != Vec3A::ZERO {
                        for index in a..b {
                            let bad = (&mut out.bad, &mut out.first_bad);
                            accumulate((acc, wide), miss, (x, y, index), bad);
                        }
                    }
                }
            }
            for j in 0..most {
                let mut which = [0usize; PACKET];
                let mut n = 0;
                for (lane, &(x, y, a, b)) in lanes.iter().enumerate() {
                    if a + j < b {
                        samplers[lane].start(x, y, a + j);
                        which[n] = lane;
                        n += 1;
                    }
                }
                let mut records = [SampleRecord::default(); PACKET];
                if traces {
                    let group = Group {
                        lanes,
                        which: &which[..n],
                        block: (bx, by, bx1, by1),
                        packet: packets,
                    };
                    camera_samples(
                        ctx,
                        settings,
                        setup,
                        &group,
                        &mut samplers,
                        &mut out.rays,
                        &mut records,
                    );
                }
                for (k, record) in records[..n].iter().enumerate() {
                    let (l, lane) = (record.l, which[k]);
                    let (x, y, a, _) = lanes[lane];
                    let bad = (&mut out.bad, &mut out.first_bad);
                    accumulate((&mut acc[lane], wide), l, (x, y, a + j), bad);
                    if keep_features {
                        add_features(&mut feature_acc[lane], record.features);
                    }
                    if keep_first_hits && a + j == 0 {
                        first_hit_acc[lane] = record.triangle.unwrap_or(NO_HIT);
                    }
                }
            }
            for (lane, (acc, &(x, y, a, b))) in acc.iter_mut().zip(lanes).enumerate() {
                acc.count = b - a;
                sums[at(x, y)] = *acc;
                if keep_features {
                    features[at(x, y)] = feature_acc[lane];
                }
                if keep_first_hits {
                    first_hits[at(x, y)] = first_hit_acc[lane];
                }
            }
        }
    }
    out
}

/// The camera samples a block takes side by side: `lanes` its pixels (x, y and their sample
/// range), `which` the lanes that take a sample now, `block` its pixels' bounds
/// [x0, x1) × [y0, y1); `packet`: its rays are traced as a packet (else it is one pixel, whose
/// ray is traced alone).
struct Group<'a> {
    lanes: &'a [(u32, u32, u32, u32)],
    which: &'a [usize],
    block: (u32, u32, u32, u32),
    packet: bool,
}

/// The records of one sample of each of `group`'s lanes (`samplers` started on them): their
/// film positions, camera rays (traced as a packet, or alone for a block of one pixel, whose
/// ray meets no box test), and the integrator's estimates, split where an emitter may be seen.
#[inline]
fn camera_samples(
    ctx: &Context,
    settings: &RenderSettings,
    setup: &TileSetup,
    group: &Group,
    samplers: &mut [PixelSampler; PACKET],
    counts: &mut RayCounts,
    records: &mut [SampleRecord; PACKET],
) {
    let Group {
        lanes,
        which,
        block: (bx, by, bx1, by1),
        packet,
    } = *group;
    let n = which.len();
    let (camera, integrator) = (&setup.camera, &settings.integrator);
    // The first slot places the samples on the film.
    let mut film_uv = [Vec2::ZERO; PACKET];
    PixelSampler::next_film_lanes(samplers, which, &mut film_uv[..n]);
    let (mut fx, mut fy) = ([0f32; PACKET], [0f32; PACKET]);
    for k in 0..n {
        let (x, y, _, _) = lanes[which[k]];
        (fx[k], fy[k]) = (x as f32 + film_uv[k].x, y as f32 + film_uv[k].y);
    }
    // A thin lens takes the sample's next slot for its point on the lens (a pinhole takes
    // none, so its images do not change).
    let rays = match camera.has_lens() {
        false => camera.rays(&fx, &fy),
        true => {
            let mut lens = [Vec2::ZERO; PACKET];
            PixelSampler::next_2d_lanes(samplers, which, &mut lens[..n]);
            camera.rays_through_lens(&fx, &fy, &lens.map(warps::square_to_concentric_disk))
        }
    };
    let mut hits = [None; PACKET];
    if !packet {
        hits[0] = ctx.accel.intersect(&rays[0]);
    } else if setup.scene_box.misses_all(&rays[..n]) {
        // A packet whose rays all miss the scene's box needs no traversal.
        counts.culled += n as u64;
    } else {
        ctx.accel.intersect_packet(&rays[..n], &mut hits);
    }
    match setup
        .emitters
        .as_ref()
        .filter(|e| e.splits_any(bx, by, bx1, by1))
    {
        None => integrator.li_packet(
            ctx,
            &rays[..n],
            &hits[..n],
            samplers,
            which,
            counts,
            &mut records[..n],
        ),
        // Where an emitter may be seen, the samples of the pixels that may see one are
        // split ([`EmitterView`]).
        Some(view) => {
            let pixels: [(u32, u32); PACKET] = std::array::from_fn(|k| {
                let (x, y, _, _) = lanes[which[k.min(n - 1)]];
                (x, y)
            });
            view.li_packet(
                ctx,
                integrator,
                camera,
                &rays[..n],
                &hits[..n],
                &pixels[..n],
                samplers,
                which,
                counts,
                &mut records[..n],
            );
        }
    }
}

/// What every tile of a render shares, made once per render.
struct TileSetup {
    /// The camera's rays for the whole image.
    camera: RayGenerator,
    /// The scene's box, against which packets of camera rays are tested.
    scene_box: SceneBox,
    /// The pixel blocks that can see the scene; None: every block is traced.
    mask: Option<BlockMask>,
    /// The estimate of a camera ray that misses (`Integrator::camera_miss`): the same for
    /// every ray wherever blocks are culled.
    miss: Vec3A,
    /// Where the camera may see emitters, whose samples are split ([`emitters`]).
    emitters: Option<EmitterView>,
}

impl TileSetup {
    fn new(ctx: &Context, settings: &RenderSettings) -> TileSetup {
        let camera = settings
            .camera
            .ray_generator(settings.width, settings.height);
        let integrator = &settings.integrator;
        // Culling serves the packet loop only (camera packets on, rays traced at all).
        let packets = ctx.experiments.camera_packets && integrator.traces_rays(ctx);
        let miss = if packets {
            let mut sampler = PixelSampler::new(settings.sampler, settings.spp, settings.seed);
            integrator.camera_miss(ctx, &mut sampler)
        } else {
            None
        };
        // Blocks are culled only where every miss has the one estimate `miss`.
        let mask = (packets && ctx.experiments.cull_blocks && miss.is_some())
            .then(|| {
                BlockMask::new(
                    &camera,
                    ctx.accel.clusters(),
                    settings.width,
                    settings.height,
                )
            })
            .flatten();
        let emitters = EmitterView::new(ctx, integrator, &camera, settings.width, settings.height);
        TileSetup {
            camera,
            scene_box: SceneBox::new(ctx.accel),
            mask,
            miss: miss.unwrap_or(Vec3A::ZERO),
            emitters,
        }
    }
}

/// The pixel block whose camera rays form one packet: 4 × 2 pixels, the blocks of
/// [`BlockMask`].
const PACKET_W: u32 = culling::BLOCK_W;
const PACKET_H: u32 = culling::BLOCK_H;
const _: () = assert!((PACKET_W * PACKET_H) as usize == PACKET);

/// Adds sample value `l` of pixel sample (x, y, index) to the pixel's round totals and their
/// tile's wide entries (exactly, in fixed point: [`film`]), or counts it as bad (NaN,
/// infinite, or beyond the film's range, [`film::MAX_SAMPLE_VALUE`]) and keeps the first few.
#[inline]
fn accumulate(
    (pixel, wide): (&mut RoundTotals, &mut Vec<WideTotals>),
    l: Vec3A,
    (x, y, index): (u32, u32, u32),
    (bad, first_bad): (&mut u64, &mut Vec<BadSample>),
) {
    if film::in_range(l) {
        film::add_sample(pixel, wide, l);
    } else {
        *bad += 1;
        if first_bad.len() < BAD_SAMPLES_KEPT {
            first_bad.push(BadSample {
                x,
                y,
                index,
                value: l.into(),
            });
        }
    }
}

/// Periodic snapshots of a running render (`--checkpoint`).
pub struct Checkpoint<'a> {
    /// Least time between two calls of `save` (measured from the end of the previous one).
    pub every: Duration,
    /// Called on the render's thread between groups of tiles with the film so far and the
    /// statistics so far (`seconds` set); the render continues when it returns.
    pub save: &'a mut dyn FnMut(&Film, &RenderStats),
}

/// Renders the scene of `ctx` as `settings` say, on `pool`. The progress bar counts tile
/// rounds (milliseconds with a time limit; converged pixels with adaptive sampling alone);
/// `cancel` stops the render between tiles.
pub fn render(
    ctx: &Context,
    settings: &RenderSettings,
    pool: &rayon::ThreadPool,
    progress: &ProgressBar,
    cancel: &AtomicBool,
) -> RenderResult {
    render_with_checkpoints(ctx, settings, pool, progress, cancel, None, None)
}

/// [`render`], handing the running film to `checkpoint` (if any) periodically, and starting
/// from the film `resume` (if any: an interrupted render's or a checkpoint's, of these
/// settings, [`resume`]) instead of an empty one. The image is the same, bit for bit, with or
/// without checkpoints and however often the render was resumed, since each pixel continues
/// from its count in sample order.
///
/// The render goes in rounds: each takes every pixel that still samples from its count to the
/// round's end (a pass end of a fixed-spp render, the next count of a progressive one), tile
/// by tile on `pool`, then adds the tiles to the film. Adaptive sampling judges the film
/// before each round; a time limit or `cancel` stops it between tiles.
pub fn render_with_checkpoints(
    ctx: &Context,
    settings: &RenderSettings,
    pool: &rayon::ThreadPool,
    progress: &ProgressBar,
    cancel: &AtomicBool,
    mut checkpoint: Option<Checkpoint>,
    resume: Option<Film>,
) -> RenderResult {
    let mut run = Run::new(ctx, settings, pool, progress, cancel);
    let mut tile_sums = TileSums::new(&run.tiles, ctx.features, ctx.ids);
    let (stopping, spp, window_pixels) = (settings.stopping, run.spp, run.window_pixels);
    // Each round takes every pixel from its count to the next pass end: in a progressive
    // render by the pixel's count, otherwise the same for all (`done` samples so far).
    let progressive = stopping.is_progressive();
    let next_progressive = |c: u32| progressive_next(c, stopping.min_spp, spp);
    let resumed = resume.is_some();
    // A resumed fixed-spp render's passes continue from its least count.
    let (mut film, mut done) = match resume {
        Some(film) => run.resumed_film(film),
        None => (run.new_film(), 0),
    };
    let base = done;
    // Adaptive sampling: which pixels have not converged (all of the window at first), and
    // which of them sample in the current round.
    let mut active: Option<Vec<bool>> = stopping.target_error.map(|_| run.in_window());
    let mut selected: Option<Vec<bool>> = None;
    let mut stats = RenderStats::default();
    stats.rays.probe = run.setup.emitters.as_ref().map_or(0, |e| e.corner_rays);
    let mut stop = Stop::default();
    // Without checkpoints a round is one group of all tiles. With them, groups of at least
    // four tiles per thread (so the barrier between groups costs little), at most 16 per round.
    let group = match checkpoint {
        Some(_) => (pool.current_num_threads() * 4)
            .max(run.tiles.len().div_ceil(16))
            .max(1),
        None => run.tiles.len().max(1),
    };
    let mut last_checkpoint = Instant::now();
    // The probe round (one sample in one tile in PROBE_TILE_STRIDE), and the speed it
    // measured: seconds per sample per pixel of the whole window.
    let mut probing = !progressive
        && !resumed
        && settings.min_pass_seconds > 0.0
        && spp > 1
        && run.tiles.len() > 1;
    let mut probed: Option<f64> = None;

    'rounds: loop {
        // Adaptive sampling: judge the film, and with a time limit pick the pixels whose next
        // samples lower the error most.
        if let (Some(target), Some(mask)) = (stopping.target_error, active.as_mut()) {
            let judged = run.judge(&film, mask, target);
            if run.adaptive_bar {
                progress.set_position(window_pixels.saturating_sub(judged.active as u64));
            }
            if judged.active == 0 {
                break 'rounds;
            }
            if stopping.time_limit.is_some() {
                let s = selected.get_or_insert_with(|| vec![false; mask.len()]);
                let window = run.window;
                pool.install(|| adaptive::select_most_useful(&film, window, mask, &judged, s));
            }
        }
        let round_start = Instant::now();
        let fixed_end = (!progressive).then(|| {
            if probing {
                return 1;
            }
            if let Some(per_sample) = probed.take() {
                return first_pass_end(spp, per_sample, settings.min_pass_seconds);
            }
            // Passes of a resumed render grow from the count it resumed at, at the rate of
            // its own samples.
            let seconds = run.start.elapsed().as_secs_f64();
            base + fixed_pass_end(done - base, spp - base, seconds, settings.min_pass_seconds)
        });
        let next_fixed = |c: u32| fixed_end.map_or(c, |end| end.max(c));
        let round = Round {
            film: &film,
            offset: run.first_sample,
            selection: selected.as_deref().or(active.as_deref()),
            uniform: !resumed,
            next: if progressive {
                &next_progressive
            } else {
                &next_fixed
            },
        };
        let work = run.tiles_with_work(&round, probing);
        if !work.iter().any(|&w| w) {
            break 'rounds;
        }
        // Tiles rendered this round, by index into `tiles` (and `tile_sums`).
        let mut merged: Vec<(usize, TileResult)> = Vec::new();
        let n_groups = run.tiles.len().div_ceil(group);
        for g in 0..n_groups {
            let range = g * group..((g + 1) * group).min(run.tiles.len());
            stop = run.render_group(&round, range, &work, &mut tile_sums, &mut merged);
            if stop.any() {
                break;
            }
            // Checkpoints see the film as of the last full round plus the groups so far.
            if let Some(c) = checkpoint.as_mut() {
                if g + 1 < n_groups && last_checkpoint.elapsed() >= c.every {
                    let mut snapshot = film.clone();
                    for (i, _) in &merged {
                        merge_tile(&mut snapshot, &run.tiles[*i], tile_sums.get(*i));
                    }
                    stats.seconds = run.start.elapsed().as_secs_f64();
                    (c.save)(&snapshot, &stats);
                    last_checkpoint = Instant::now();
                }
            }
        }
        // Each pixel's sum grows round by round in sample order. The bands of tile rows are
        // merged in parallel (a serial merge, first touching a new film's pages, held back
        // short renders on several threads).
        merge_round(&mut film, &run.tiles, &tile_sums, &merged, pool);
        stats.passes += !merged.is_empty() as u32;
        add_tile_results(&mut stats, merged);
        if stop.any() {
            break 'rounds;
        }
        run.first_round = false;
        if probing {
            // The probe's pixels have a sample, the others none: `done` stays 0.
            probing = false;
            let probe_pixels: u64 = (run.tiles.iter().zip(&work))
                .filter(|(_, &w)| w)
                .map(|(t, _)| t.pixels() as u64)
                .sum();
            let seconds = round_start.elapsed().as_secs_f64();
            probed = Some(seconds * window_pixels as f64 / probe_pixels.max(1) as f64);
            continue;
        }
        done = fixed_end.unwrap_or(done);
        if let Some(c) = checkpoint.as_mut() {
            let finished = film.count_range().0 >= spp;
            if !finished && last_checkpoint.elapsed() >= c.every {
                stats.seconds = run.start.elapsed().as_secs_f64();
                (c.save)(&film, &stats);
                last_checkpoint = Instant::now();
            }
        }
    }
    stats.seconds = run.start.elapsed().as_secs_f64();
    // Judge the last round too, so pixels that converged in it are not reported as still
    // sampling (this changes no pixel).
    let unconverged_pixels = match (stopping.target_error, active.as_mut()) {
        (Some(target), Some(mask)) => Some(run.judge(&film, mask, target).active as u64),
        _ => None,
    };
    RenderResult {
        film,
        stats,
        interrupted: stop.interrupted,
        time_limit_reached: stop.time_limit_reached,
        unconverged_pixels,
    }
}

/// Why a round stopped before its last tile: the cancel flag, the time limit, or (where
/// tiles running side by side saw each) both.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Stop {
    interrupted: bool,
    time_limit_reached: bool,
}

impl Stop {
    fn any(self) -> bool {
        self.interrupted || self.time_limit_reached
    }
}

/// What a render keeps from its start to its end but for the film and the stopping rule's
/// state: its inputs, the window's tiles and their sums, and the progress bar's scale.
struct Run<'a> {
    ctx: &'a Context<'a>,
    settings: &'a RenderSettings,
    pool: &'a rayon::ThreadPool,
    progress: &'a ProgressBar,
    cancel: &'a AtomicBool,
    start: Instant,
    /// The pixels rendered: [x0, x1) × [y0, y1), the image or its crop.
    window: (u32, u32, u32, u32),
    window_pixels: u64,
    tiles: Vec<Tile>,
    setup: TileSetup,
    /// The samples each pixel takes, from index `first_sample` on (the film counts them from
    /// 0), `spp` of them.
    first_sample: u32,
    spp: u32,
    /// The progress bar counts converged pixels (an adaptive render without a time limit).
    adaptive_bar: bool,
    bar_length: u64,
    /// True until the first round completes: it always does, so even a time limit shorter
    /// than one sample per pixel gives a whole image rather than a partly black one.
    first_round: bool,
}

impl<'a> Run<'a> {
    fn new(
        ctx: &'a Context<'a>,
        settings: &'a RenderSettings,
        pool: &'a rayon::ThreadPool,
        progress: &'a ProgressBar,
        cancel: &'a AtomicBool,
    ) -> Run<'a> {
        let start = Instant::now();
        let (width, height) = (settings.width, settings.height);
        let window = settings
            .crop
            .map_or((0, 0, width, height), |(x0, y0, x1, y1)| {
                (x0.min(width), y0.min(height), x1.min(width), y1.min(height))
            });
        let tiles = tiles(window, settings.tile_size);
        let stopping = settings.stopping;
        let (first_sample, end_sample) = settings.samples();
        assert!(
            first_sample <= end_sample && end_sample <= settings.spp,
            "sample range {first_sample}..{end_sample} outside 0..{}",
            settings.spp
        );
        assert!(
            settings.sample_range.is_none() || !stopping.is_progressive(),
            "a sample range is for fixed-spp renders"
        );
        let spp = end_sample - first_sample;
        // The progress bar counts milliseconds when a time limit is set, converged pixels in
        // an adaptive render without one (set after each judgement), and pixel samples
        // otherwise.
        let window_pixels = (window.2 - window.0) as u64 * (window.3 - window.1) as u64;
        let adaptive_bar = stopping.time_limit.is_none() && stopping.target_error.is_some();
        let bar_length = match stopping.time_limit {
            Some(t) => t.as_millis().max(1) as u64,
            None if adaptive_bar => window_pixels,
            None => window_pixels * spp as u64,
        };
        // Before the setup's emitter rays, so that the bar never shows an empty length.
        progress.set_length(bar_length);
        // On the pool: its workers' floating-point mode is the one the tiles trace with.
        let setup = pool.install(|| TileSetup::new(ctx, settings));
        Run {
            ctx,
            settings,
            pool,
            progress,
            cancel,
            start,
            window,
            window_pixels,
            tiles,
            setup,
            first_sample,
            spp,
            adaptive_bar,
            bar_length,
            first_round: true,
        }
    }

    /// A film of the image's size that keeps what the context asks for.
    fn new_film(&self) -> Film {
        let mut film = Film::new(self.settings.width, self.settings.height);
        if self.ctx.features {
            film.keep_features();
        }
        if self.ctx.ids {
            film.keep_first_hits();
        }
        if self.settings.stopping.target_error.is_some() && self.ctx.experiments.error_halves {
            film.keep_halves();
        }
        film
    }

    /// The film a resumed render starts from, checked against the render's settings (the
    /// caller has checked it against the job: [`resume`]), and its window's least count; the
    /// progress bar counts its samples as done.
    fn resumed_film(&self, film: Film) -> (Film, u32) {
        let settings = self.settings;
        assert!(
            !settings.stopping.is_progressive(),
            "a resumed render has a fixed number of samples"
        );
        assert_eq!(
            (
                film.width,
                film.height,
                film.keeps_features(),
                film.keeps_first_hits()
            ),
            (
                settings.width,
                settings.height,
                self.ctx.features,
                self.ctx.ids
            ),
            "a resumed film is of the render's size and layers"
        );
        let (x0, y0, x1, y1) = self.window;
        let (mut done, mut least) = (0u64, u32::MAX);
        for (x, y) in (y0..y1).flat_map(|y| (x0..x1).map(move |x| (x, y))) {
            let count = film.count(x, y);
            done += count.min(self.spp) as u64;
            least = least.min(count);
        }
        self.progress.set_position(done);
        (film, if least == u32::MAX { 0 } else { least })
    }

    /// Indexed like the film: true in the window.
    fn in_window(&self) -> Vec<bool> {
        let (width, w) = (self.settings.width as usize, self.window);
        let mut a = vec![false; width * self.settings.height as usize];
        for y in w.1..w.3 {
            let row = y as usize * width;
            a[row + w.0 as usize..row + w.2 as usize].fill(true);
        }
        a
    }

    /// Adaptive sampling's judgement of `film`: `mask` keeps the pixels still above `target`.
    fn judge(&self, film: &Film, mask: &mut [bool], target: f32) -> adaptive::Judgement {
        let stopping = &self.settings.stopping;
        self.pool.install(|| {
            adaptive::judge(
                film,
                self.window,
                mask,
                stopping.metric,
                target,
                stopping.min_spp,
            )
        })
    }

    /// The time limit has passed (never in the first round).
    fn time_is_up(&self) -> bool {
        let deadline = self.settings.stopping.time_limit.map(|t| self.start + t);
        !self.first_round && deadline.is_some_and(|d| Instant::now() >= d)
    }

    /// Moves the progress bar after a tile that took `samples` pixel samples.
    fn tick(&self, samples: u64) {
        match self.settings.stopping.time_limit {
            Some(_) => {
                let ms = self.start.elapsed().as_millis() as u64;
                self.progress.set_position(ms.min(self.bar_length));
            }
            None if self.adaptive_bar => {}
            None => self.progress.inc(samples),
        }
    }

    /// Which tiles have samples to take in `round` (`probing`: only one tile in
    /// [`PROBE_TILE_STRIDE`] may).
    fn tiles_with_work(&self, round: &Round, probing: bool) -> Vec<bool> {
        if probing {
            let probe =
                |(i, t): (usize, &Tile)| i % PROBE_TILE_STRIDE == 0 && round.tile_has_work(t);
            self.tiles.iter().enumerate().map(probe).collect()
        } else if round.selection.is_none() {
            self.tiles.iter().map(|t| round.tile_has_work(t)).collect()
        } else {
            let tiles = &self.tiles;
            self.pool
                .install(|| tiles.par_iter().map(|t| round.tile_has_work(t)).collect())
        }
    }

    /// Renders the tiles of `range` that have `work` in `round` on the pool into their part
    /// of `tile_sums`, and appends their results to `merged`; stops early, saying why, when
    /// cancelled or out of time.
    fn render_group(
        &self,
        round: &Round,
        range: std::ops::Range<usize>,
        work: &[bool],
        tile_sums: &mut TileSums,
        merged: &mut Vec<(usize, TileResult)>,
    ) -> Stop {
        if self.cancel.load(Ordering::Relaxed) {
            return Stop {
                interrupted: true,
                ..Stop::default()
            };
        }
        if self.time_is_up() {
            return Stop {
                time_limit_reached: true,
                ..Stop::default()
            };
        }
        // A fixed-spp round's samples in a tile (for the progress bar): its pixels all have
        // the same count.
        let progressive = self.settings.stopping.is_progressive();
        let tile_samples = |t: &Tile| {
            if progressive {
                return 0;
            }
            let (a, b) = round.samples(t.x0, t.y0);
            t.pixels() as u64 * (b - a) as u64
        };
        let (chunk, chunk_work) = (&self.tiles[range.clone()], &work[range.clone()]);
        let chunk_sums = tile_sums.split_mut(range.clone());
        let this = self;
        let (ctx, settings, setup) = (self.ctx, self.settings, &self.setup);
        let results: Vec<Option<TileResult>> = self.pool.install(|| {
            chunk
                .par_iter()
                .zip(chunk_work)
                .zip(chunk_sums)
                .map(|((&tile, &has_work), sums)| {
                    if !has_work {
                        this.tick(0);
                        return None;
                    }
                    if this.cancel.load(Ordering::Relaxed) || this.time_is_up() {
                        return None;
                    }
                    let r = render_tile(ctx, settings, setup, tile, round, sums);
                    this.tick(tile_samples(&tile));
                    Some(r)
                })
                .collect()
        });
        let mut stop = Stop::default();
        for ((i, &has_work), result) in range.zip(chunk_work).zip(results) {
            match result {
                Some(r) => merged.push((i, r)),
                None if !has_work => {}
                None if self.cancel.load(Ordering::Relaxed) => stop.interrupted = true,
                None => stop.time_limit_reached = true,
            }
        }
        stop
    }
}

/// Adds a round's tile results to the render's statistics.
fn add_tile_results(stats: &mut RenderStats, merged: Vec<(usize, TileResult)>) {
    for (_, r) in merged {
        stats.rays.add(&r.rays);
        stats.bad_samples += r.bad;
        for b in r.first_bad {
            if stats.first_bad.len() < BAD_SAMPLES_KEPT {
                stats.first_bad.push(b);
            }
        }
    }
}

/// Writes a round's tiles (`merged`: indices into `tiles` and `sums`, in scanline order, as
/// [`tiles`] makes them) to the film, one band of tile rows per task.
fn merge_round(
    film: &mut Film,
    tiles: &[Tile],
    sums: &TileSums,
    merged: &[(usize, TileResult)],
    pool: &rayon::ThreadPool,
) {
    let mut bands: Vec<(u32, u32)> = Vec::new();
    let mut groups: Vec<&[(usize, TileResult)]> = Vec::new();
    let mut rest = merged;
    while let Some((first, _)) = rest.first() {
        let y0 = tiles[*first].y0;
        let n = rest.iter().take_while(|(i, _)| tiles[*i].y0 == y0).count();
        let (group, tail) = rest.split_at(n);
        bands.push((y0, tiles[*first].y1));
        groups.push(group);
        rest = tail;
    }
    let rows = film.rows_mut(&bands);
    pool.install(|| {
        rows.into_par_iter()
            .zip(groups)
            .for_each(|(mut rows, group)| {
                for (i, _) in group {
                    write_tile(&mut rows, &tiles[*i], sums.get(*i));
                }
            })
    });
}

/// Writes a tile's round into the film (for a checkpoint's snapshot: one tile at a time).
fn merge_tile(film: &mut Film, tile: &Tile, sums: TileTotalsRef) {
    let mut rows = film.rows_mut(&[(tile.y0, tile.y1)]);
    write_tile(&mut rows[0], tile, sums);
}

/// Adds a tile's round totals to the film rows that hold it (and writes its feature totals
/// and first hits, where kept).
fn write_tile(rows: &mut FilmRows, tile: &Tile, (sums, wide, features, first_hits): TileTotalsRef) {
    let mut pixel = sums.iter();
    let mut pixel_features = features.iter();
    let mut pixel_first_hits = first_hits.iter();
    for y in tile.y0..tile.y1 {
        for x in tile.x0..tile.x1 {
            rows.add_round(x, y, pixel.next().expect("one sum per tile pixel"), wide);
            if let Some(f) = pixel_features.next() {
                rows.set_features(x, y, f);
            }
            if let Some(&h) = pixel_first_hits.next() {
                rows.set_first_hit(x, y, h);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pass ends from `fixed_pass_end`, with the render taking `per_sample` seconds per
    /// sample per pixel.
    fn fixed_passes(spp: u32, per_sample: f64, min_pass: f64) -> Vec<u32> {
        let mut ends = Vec::new();
        let mut done = 0;
        while done < spp {
            let end = fixed_pass_end(done, spp, done as f64 * per_sample, min_pass);
            assert!(done < end && end <= spp, "{done} → {end} of {spp}");
            ends.push(end);
            done = end;
        }
        ends
    }

    #[test]
    fn fixed_passes_double_and_last_at_least_the_minimum() {
        for spp in [1u32, 2, 7, 16, 17, 100, 1024, 100_000, u32::MAX] {
            // Without a minimum: 1, 1, 2, 4, … samples, about log2(spp) + 2 passes.
            let ends = fixed_passes(spp, 1e-3, 0.0);
            let doubling: Vec<u32> = (0..32)
                .map(|k| 1u32 << k)
                .take_while(|&e| e < spp)
                .chain([spp])
                .collect();
            assert_eq!(ends, doubling, "spp {spp}");
            // Unbounded: one sample per pixel first (a whole image soon), then the rest.
            let ends = fixed_passes(spp, 1e-3, f64::INFINITY);
            assert_eq!(ends, if spp == 1 { vec![1] } else { vec![1, spp] });
        }
        // 10 ms per sample per pixel and passes of at least 0.1 s: 1, then 10 more, then
        // doubling once the doubling is longer.
        assert_eq!(fixed_passes(100, 0.01, 0.1), vec![1, 11, 22, 44, 88, 100]);
        // A clock that reads zero after the first pass cannot divide: doubling.
        assert_eq!(fixed_pass_end(1, 100, 0.0, 0.5), 2);
    }

    /// The first full pass takes the samples that fill the minimum at the probe's speed,
    /// between one and all of them.
    #[test]
    fn the_first_pass_fills_the_minimum() {
        // 0.01 s a sample: 0.5 s hold 50 samples, more than an 8-spp render has.
        assert_eq!(first_pass_end(8, 0.01, 0.5), 8);
        assert_eq!(first_pass_end(1000, 0.01, 0.5), 50);
        // 0.3 s a sample: 1.67, so 2; 10 s a sample: still one.
        assert_eq!(first_pass_end(1000, 0.3, 0.5), 2);
        assert_eq!(first_pass_end(1000, 10.0, 0.5), 1);
        // A probe too fast to time, and an unbounded minimum: all samples.
        assert_eq!(first_pass_end(64, 0.0, 0.5), 64);
        assert_eq!(first_pass_end(64, 1.0, f64::INFINITY), 64);
        assert_eq!(first_pass_end(64, 0.0, 0.0), 1);
    }

    #[test]
    fn progressive_passes_double_to_the_minimum_then_grow_by_a_quarter() {
        for (min_spp, spp) in [
            (16u32, 65536u32),
            (16, 100),
            (5, 37),
            (1, 1),
            (64, 64),
            (16, 8),
        ] {
            let mut c = 0;
            let mut ends = Vec::new();
            while c < spp {
                let next = progressive_next(c, min_spp, spp);
                assert!(next > c, "{min_spp}/{spp}: stuck at {c}");
                if c >= min_spp.min(spp) {
                    // At most a quarter more (or 8), a power of two dividing the count.
                    let grow = next - c;
                    assert!(grow <= (c / 4).max(8), "{c} -> {next}");
                    assert!(
                        next == spp || (grow.is_power_of_two() && c % grow == 0),
                        "{c} -> {next}"
                    );
                }
                ends.push(next);
                c = next;
            }
            assert_eq!(c, spp);
            // The minimum is a pass end, so every pixel is judged with exactly min_spp.
            assert!(
                ends.contains(&min_spp.min(spp)),
                "{min_spp}/{spp}: {ends:?}"
            );
            // About 3 log2(spp) judgements at most.
            assert!(
                ends.len() as f64 <= 4.0 * (spp as f64).log2() + 8.0,
                "{}",
                ends.len()
            );
        }
        assert_eq!(progressive_next(0, 16, 65536), 1);
        assert_eq!(progressive_next(16, 16, 65536), 24);
        assert_eq!(progressive_next(1024, 16, 65536), 1280);
    }

    #[test]
    fn tiles_cover_the_image_once() {
        let (w, h) = (37, 21);
        let mut seen = vec![0u32; (w * h) as usize];
        for t in tiles((0, 0, w, h), 8) {
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    seen[(y * w + x) as usize] += 1;
                }
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
    }
}
