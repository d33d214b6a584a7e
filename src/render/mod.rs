//! The parallel frontend: the image is cut into tiles that rayon renders in passes of
//! samples; a film accumulates each pixel's samples in sample-index order, so the image is
//! bit-identical whatever the thread count.
//!
//! Passes split the samples per pixel into ranges of doubling size ([`passes`]). Between
//! passes (and before each tile) the render checks its cancel flag, so an interrupted render
//! still holds a usable image, with the number of samples each pixel received.
//!
//! With a [`Checkpoint`], each pass renders its tiles in groups and hands the running film to
//! a callback between groups, at most once per period. The groups are merged in tile order,
//! and every pixel still receives its passes in order, so the image is the same bit for bit.

pub mod film;
pub mod output;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use glam::Vec3;
use indicatif::ProgressBar;
use rayon::prelude::*;

use crate::integrators::{Context, Integrator, RayCounts};
use crate::sampling::{PixelSampler, SamplerKind};
use crate::scene::Camera;
pub use film::{BadSample, Film};

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
    /// Render only pixels x0 ≤ x < x1, y0 ≤ y < y1 (the rest of the film stays empty).
    pub crop: Option<(u32, u32, u32, u32)>,
}

/// What a render did, besides the image.
#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    pub rays: RayCounts,
    pub seconds: f64,
    /// Samples rejected because their value was NaN or infinite.
    pub bad_samples: u64,
    /// The first few of them, in pixel order, for replay.
    pub first_bad: Vec<BadSample>,
}

pub struct RenderResult {
    pub film: Film,
    pub stats: RenderStats,
    /// True when the cancel flag stopped the render early.
    pub interrupted: bool,
}

/// A rayon pool whose workers all run with flush-to-zero and denormals-are-zero, as Embree
/// asks. `threads = 0` uses every core.
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool, rayon::ThreadPoolBuildError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("strata-worker-{i}"))
        .start_handler(|_| crate::embree::enable_ftz_daz())
        .build()
}

#[derive(Clone, Copy, Debug)]
struct Tile {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
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

/// Sample-index ranges of the passes: 1, 1, 2, 4, 8, … samples, doubling until `spp` is
/// covered (the last pass takes the remainder). An interrupted render thus has every pixel
/// sampled after the first pass, and at least half of its samples when stopped in the last.
pub fn passes(spp: u32) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    let mut start = 0u32;
    let mut size = 1u32;
    while start < spp {
        let end = start.saturating_add(size).min(spp);
        out.push((start, end));
        if out.len() > 1 {
            size = size.saturating_mul(2);
        }
        start = end;
    }
    out
}

struct TileResult {
    /// Per pixel: (sum, sum of squares) of the pass's samples.
    sums: Vec<([f64; 3], [f64; 3])>,
    rays: RayCounts,
    bad: u64,
    first_bad: Vec<BadSample>,
}

fn render_tile(
    ctx: &Context,
    settings: &RenderSettings,
    tile: Tile,
    samples: (u32, u32),
) -> TileResult {
    let mut sampler = PixelSampler::new(settings.sampler, settings.spp, settings.seed);
    let camera = settings
        .camera
        .ray_generator(settings.width, settings.height);
    let mut rays = RayCounts::default();
    let mut sums = Vec::with_capacity(((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize);
    let mut bad = 0;
    let mut first_bad = Vec::new();
    for y in tile.y0..tile.y1 {
        for x in tile.x0..tile.x1 {
            let mut sum = [0f64; 3];
            let mut sq = [0f64; 3];
            for index in samples.0..samples.1 {
                sampler.start(x, y, index);
                // The first two dimensions place the sample on the film.
                let film_uv = sampler.next_2d();
                let ray = camera.ray(x as f32 + film_uv.x, y as f32 + film_uv.y);
                let l: Vec3 = settings.integrator.li(ctx, &ray, &mut sampler, &mut rays);
                if l.is_finite() {
                    for (c, v) in l.to_array().into_iter().enumerate() {
                        sum[c] += v as f64;
                        sq[c] += v as f64 * v as f64;
                    }
                } else {
                    bad += 1;
                    if first_bad.len() < BAD_SAMPLES_KEPT {
                        first_bad.push(BadSample {
                            x,
                            y,
                            index,
                            value: l,
                        });
                    }
                }
            }
            sums.push((sum, sq));
        }
    }
    TileResult {
        sums,
        rays,
        bad,
        first_bad,
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
/// passes; `cancel` stops the render between tiles.
pub fn render(
    ctx: &Context,
    settings: &RenderSettings,
    pool: &rayon::ThreadPool,
    progress: &ProgressBar,
    cancel: &AtomicBool,
) -> RenderResult {
    render_with_checkpoints(ctx, settings, pool, progress, cancel, None)
}

/// [`render`], handing the running film to `checkpoint` (if any) periodically. The image is
/// the same, bit for bit, with or without checkpoints.
pub fn render_with_checkpoints(
    ctx: &Context,
    settings: &RenderSettings,
    pool: &rayon::ThreadPool,
    progress: &ProgressBar,
    cancel: &AtomicBool,
    mut checkpoint: Option<Checkpoint>,
) -> RenderResult {
    let start = Instant::now();
    let window = settings.crop.map_or(
        (0, 0, settings.width, settings.height),
        |(x0, y0, x1, y1)| {
            (
                x0.min(settings.width),
                y0.min(settings.height),
                x1.min(settings.width),
                y1.min(settings.height),
            )
        },
    );
    let tiles = tiles(window, settings.tile_size);
    let passes = passes(settings.spp);
    progress.set_length((tiles.len() * passes.len()) as u64);
    let mut film = Film::new(settings.width, settings.height);
    let mut stats = RenderStats::default();
    let mut interrupted = false;
    // Without checkpoints a pass is one group of all tiles. With them, groups of at least
    // four tiles per thread (so the barrier between groups costs little), at most 16 per pass.
    let group = match checkpoint {
        Some(_) => (pool.current_num_threads() * 4)
            .max(tiles.len().div_ceil(16))
            .max(1),
        None => tiles.len().max(1),
    };
    let mut last_checkpoint = Instant::now();

    'passes: for (pass_index, &pass) in passes.iter().enumerate() {
        for (group_index, chunk) in tiles.chunks(group).enumerate() {
            if cancel.load(Ordering::Relaxed) {
                interrupted = true;
                break 'passes;
            }
            let results: Vec<Option<TileResult>> = pool.install(|| {
                chunk
                    .par_iter()
                    .map(|&tile| {
                        if cancel.load(Ordering::Relaxed) {
                            return None;
                        }
                        let r = render_tile(ctx, settings, tile, pass);
                        progress.inc(1);
                        Some(r)
                    })
                    .collect()
            });
            // Merge in tile order: each pixel's sum grows pass by pass in sample order.
            for (tile, result) in chunk.iter().zip(results) {
                let Some(result) = result else {
                    interrupted = true;
                    continue;
                };
                let mut sums = result.sums.into_iter();
                for y in tile.y0..tile.y1 {
                    for x in tile.x0..tile.x1 {
                        let (sum, sq) = sums.next().expect("one sum per tile pixel");
                        film.add(x, y, sum, sq, pass.1 - pass.0);
                    }
                }
                stats.rays.add(&result.rays);
                stats.bad_samples += result.bad;
                for b in result.first_bad {
                    if stats.first_bad.len() < BAD_SAMPLES_KEPT {
                        stats.first_bad.push(b);
                    }
                }
            }
            if interrupted {
                break 'passes;
            }
            let last_group =
                pass_index + 1 == passes.len() && (group_index + 1) * group >= tiles.len();
            if let Some(c) = checkpoint.as_mut() {
                if !last_group && last_checkpoint.elapsed() >= c.every {
                    stats.seconds = start.elapsed().as_secs_f64();
                    (c.save)(&film, &stats);
                    last_checkpoint = Instant::now();
                }
            }
        }
    }
    stats.seconds = start.elapsed().as_secs_f64();
    RenderResult {
        film,
        stats,
        interrupted,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_cover_every_sample_once() {
        for spp in [1u32, 2, 7, 16, 17, 100, 1024, 100_000, u32::MAX] {
            let p = passes(spp);
            // Doubling sizes: about log2(spp) + 2 passes.
            assert!(p.len() as u32 <= 34, "{spp}: {} passes", p.len());
            assert_eq!(p[0], (0, 1));
            assert_eq!(p.first().unwrap().0, 0);
            assert_eq!(p.last().unwrap().1, spp);
            for w in p.windows(2) {
                assert_eq!(w[0].1, w[1].0);
            }
        }
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
