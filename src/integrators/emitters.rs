//! Emitters the camera sees, estimated with rays of their own.
//!
//! Where a light's outline crosses a pixel, the pixel's value is mostly the fraction of it that
//! the light covers, times the light's radiance, which is often a hundred times that of what
//! surrounds it. One camera ray per sample estimates that fraction with a large variance: on
//! the Cornell box, the ten pixels on the light's outline hold 56–72% of the squared error of
//! a path-traced image (BENCHMARKS.md). The term is cheap to estimate apart: it needs the
//! camera ray's closest hit and the emission there, and no path.
//!
//! So in the pixel blocks where an emissive triangle may be seen (a [`BlockMask`] of the
//! emissive triangles' cluster boxes), each sample of `direct` and `path` splits its estimate
//! (splitting, Arvo and Kirk 1990): the path from the sample's camera ray counts everything
//! but the emission that ray meets, and `n` further camera rays through their own points of the
//! pixel estimate that emission. Their points are the sample's n of a pixel-wide set of spp·n
//! ([`PixelSampler::side_2d_set`]), so the light's outline is resolved by spp·n stratified
//! points instead of spp. Both parts keep their expected values, so the pixel's does too; the
//! path's own sampler dimensions are untouched, so only the emission term changes.
//!
//! The blocks of the mask hold the emitters' interiors too, where every ray sees the same
//! radiance and a split only costs rays. Before the render, one camera ray through each
//! corner of the mask's pixels finds them: a pixel whose four corners see the same, non-zero
//! emitted radiance is left to its path, with the emission its own ray meets. Choosing which
//! pixels are split is a choice of estimator, so a pixel the corners misjudge (an occluder
//! or a gap in a light thinner than a pixel, between its corners) keeps its expected value
//! and only its variance changes. Pixels whose corners see no emitter stay split: a light
//! smaller than a pixel may lie between them.

use glam::{Vec2, Vec3, Vec3A};
use rayon::prelude::*;

use super::{Context, Integrator, RayCounts, SampleRecord};
use crate::accel::culling::{BlockMask, BLOCK_H, BLOCK_W};
use crate::accel::{clusters_of, Hit, Ray, PACKET};
use crate::sampling::PixelSampler;
use crate::scene::RayGenerator;
use crate::shading::lights::Emitter;

/// The side stream of [`PixelSampler::side_2d_set`] that places the emitter rays.
const STREAM: u32 = 0x0e31;

/// Where the camera may see an emitter, and how the samples there are split.
pub(crate) struct EmitterView {
    /// Row-major, one per pixel of the image: whether the pixel's samples are split.
    split: Vec<bool>,
    width: u32,
    /// Camera rays traced to find the emitters' interiors (one per pixel corner examined).
    pub corner_rays: u64,
    /// The integrator with `camera_emission` off: what the path estimates in split pixels.
    integrator: Integrator,
    /// Camera rays per sample that estimate the emission seen: `emitter_samples`, or fewer
    /// where emitters' outlines cover much of the image.
    rays: u32,
}

impl EmitterView {
    /// The view for `integrator` (`direct` or `path` with `emitter_samples` > 0) of a
    /// `width × height` image seen through `camera`; None where nothing is split: another
    /// integrator, no emissive triangles, a camera inside one of their boxes (where the
    /// mask cannot be made; splitting is a choice of estimator, so leaving it out is
    /// correct), or emitters' outlines over half of the image's pixels (see below).
    pub fn new(
        ctx: &Context,
        integrator: &Integrator,
        camera: &RayGenerator,
        width: u32,
        height: u32,
    ) -> Option<EmitterView> {
        let (Integrator::Direct(settings) | Integrator::Path(settings)) = *integrator else {
            return None;
        };
        if settings.emitter_samples == 0 || !integrator.traces_rays(ctx) {
            return None;
        }
        // The emissive triangles, as the light set already lists them (in world space).
        let emissive = ctx.lights.emitters.iter().filter_map(|e| match e {
            Emitter::Triangle(t) => Some(t.vertices.map(Vec3A::from)),
            _ => None,
        });
        let boxes = clusters_of(emissive);
        if boxes.is_empty() {
            return None;
        }
        let mask = BlockMask::new(camera, &boxes, width, height)?;
        let (split, corner_rays) = split_pixels(ctx, camera, &mask, width, height);
        // At most one emitter ray per sample over the whole image, on average: where a
        // fraction f of the pixels is split, at most 1/f rays per sample there. A split whose
        // rays would cost more than its paths is left out; one of a single ray gains nothing.
        // (`as` saturates: no split pixel gives u32::MAX, and nothing to split.)
        let fraction = split.iter().filter(|&&s| s).count() as f64 / split.len().max(1) as f64;
        let rays = settings
            .emitter_samples
            .min((1.0 / fraction).floor() as u32);
        if rays < 2 || fraction == 0.0 {
            return None;
        }
        Some(EmitterView {
            split,
            width,
            corner_rays,
            integrator: integrator.without_camera_emission(),
            rays,
        })
    }

    /// Whether the samples of pixel (x, y) are split.
    #[inline]
    fn splits(&self, x: u32, y: u32) -> bool {
        self.split[y as usize * self.width as usize + x as usize]
    }

    /// [`Integrator::li_packet`] where the camera may see emitters: the estimates for the
    /// camera rays of a packet, `rays[k]`, with closest hit `hits[k]`, through pixel
    /// `pixels[k]`, sampled by `samplers[lanes[k]]`, its record into `out[k]`. A split
    /// pixel's estimate is its path's (without the emission its camera ray meets) plus that
    /// of its emitter rays; the others' are `integrator`'s own. The paths of the packet's
    /// split pixels, and those of its other pixels, are each estimated as one packet; the
    /// estimates do not depend on how the packet is divided, since a split's emitter rays
    /// draw from a side stream that does not depend on where the path's draws have got to.
    /// The emitter rays are traced in packets where camera rays are
    /// (`ctx.experiments.camera_packets`), else one by one (the hits, so the estimates, are
    /// the same).
    #[allow(clippy::too_many_arguments)]
    pub fn li_packet(
        &self,
        ctx: &Context,
        integrator: &Integrator,
        camera: &RayGenerator,
        rays: &[Ray],
        hits: &[Option<Hit>],
        pixels: &[(u32, u32)],
        samplers: &mut [PixelSampler],
        lanes: &[usize],
        counts: &mut RayCounts,
        out: &mut [SampleRecord],
    ) {
        let n = rays.len();
        for split in [false, true] {
            let mut which = [0usize; PACKET];
            let mut m = 0;
            for (k, &(x, y)) in pixels.iter().enumerate().take(n) {
                if self.splits(x, y) == split {
                    which[m] = k;
                    m += 1;
                }
            }
            if m == 0 {
                continue;
            }
            let sub_rays: [Ray; PACKET] = std::array::from_fn(|i| rays[which[i.min(m - 1)]]);
            let sub_hits: [Option<Hit>; PACKET] =
                std::array::from_fn(|i| hits[which[i.min(m - 1)]]);
            let sub_lanes: [usize; PACKET] = std::array::from_fn(|i| lanes[which[i.min(m - 1)]]);
            let mut sub_out = [SampleRecord::default(); PACKET];
            let paths = if split { &self.integrator } else { integrator };
            paths.li_packet(
                ctx,
                &sub_rays[..m],
                &sub_hits[..m],
                samplers,
                &sub_lanes[..m],
                counts,
                &mut sub_out[..m],
            );
            for (i, &k) in which[..m].iter().enumerate() {
                out[k] = sub_out[i];
                if split {
                    let sampler = &samplers[lanes[k]];
                    let packets = ctx.experiments.camera_packets;
                    out[k].l += self.estimate(ctx, camera, sampler, pixels[k], packets, counts);
                }
            }
        }
    }

    /// Whether any pixel of the block [x0, x1) × [y0, y1) is split.
    #[inline]
    pub fn splits_any(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> bool {
        (y0..y1).any(|y| {
            let row = y as usize * self.width as usize;
            self.split[row + x0 as usize..row + x1 as usize].contains(&true)
        })
    }

    /// The estimate of the emission the camera sees from pixel (x, y) for the sample that
    /// `sampler` is on: the mean over the sample's rays.
    fn estimate(
        &self,
        ctx: &Context,
        camera: &RayGenerator,
        sampler: &PixelSampler,
        (x, y): (u32, u32),
        packets: bool,
        counts: &mut RayCounts,
    ) -> Vec3A {
        let set = sampler.side_2d_set(STREAM, self.rays);
        let mut sum = Vec3A::ZERO;
        for first in (0..self.rays).step_by(PACKET) {
            let m = (self.rays - first).min(PACKET as u32) as usize;
            let (mut fx, mut fy) = ([0f32; PACKET], [0f32; PACKET]);
            for k in 0..m {
                let u: Vec2 = set.get(first + k as u32);
                (fx[k], fy[k]) = (x as f32 + u.x, y as f32 + u.y);
            }
            for e in &emission_through(ctx, camera, (&fx, &fy), m, packets)[..m] {
                sum += Vec3A::from(*e);
            }
        }
        counts.camera += self.rays as u64;
        sum / self.rays as f32
    }
}

/// The emission that the camera rays through the first `m` film positions of `(fx, fy)` see
/// ([`Integrator::camera_emission`]), traced as one packet or, with `packets` false, one by one
/// (the hits are the same).
#[inline]
fn emission_through(
    ctx: &Context,
    camera: &RayGenerator,
    (fx, fy): (&[f32; PACKET], &[f32; PACKET]),
    m: usize,
    packets: bool,
) -> [Vec3; PACKET] {
    let rays = camera.rays(fx, fy);
    let mut hits = [None; PACKET];
    if packets {
        ctx.accel.intersect_packet(&rays[..m], &mut hits);
    } else {
        for (hit, ray) in hits.iter_mut().zip(&rays[..m]) {
            *hit = ctx.accel.intersect(ray);
        }
    }
    std::array::from_fn(|k| {
        if k < m {
            Integrator::camera_emission(ctx, &rays[k], hits[k])
        } else {
            Vec3::ZERO
        }
    })
}

/// The pixels to split, row-major, and the camera rays traced to choose them: those of
/// `mask`'s blocks, less the pixels whose four corners see the same non-zero emitted radiance
/// (see the module's documentation). Block rows are examined in parallel on the current
/// rayon pool; the answer does not depend on how.
fn split_pixels(
    ctx: &Context,
    camera: &RayGenerator,
    mask: &BlockMask,
    width: u32,
    height: u32,
) -> (Vec<bool>, u64) {
    let rows: Vec<(Vec<bool>, u64)> = (0..height.div_ceil(BLOCK_H))
        .into_par_iter()
        .map(|r| {
            let (y0, y1) = (r * BLOCK_H, ((r + 1) * BLOCK_H).min(height));
            let mut split = vec![false; ((y1 - y0) * width) as usize];
            let mut traced = 0u64;
            for x0 in (0..width).step_by(BLOCK_W as usize) {
                let x1 = (x0 + BLOCK_W).min(width);
                if !mask.sees(x0, y0, x1, y1) {
                    continue;
                }
                // The emission seen through each corner of the block's pixels, row-major:
                // at most (4 + 1) × (2 + 1) corners, two packets.
                const CORNERS: usize = ((BLOCK_W + 1) * (BLOCK_H + 1)) as usize;
                const _: () = assert!(CORNERS <= 2 * PACKET);
                let (cw, ch) = (x1 - x0 + 1, y1 - y0 + 1);
                let count = (cw * ch) as usize;
                let mut seen = [Vec3::ZERO; 2 * PACKET];
                for first in (0..count).step_by(PACKET) {
                    let m = (count - first).min(PACKET);
                    let (mut fx, mut fy) = ([0f32; PACKET], [0f32; PACKET]);
                    for k in 0..m {
                        let c = (first + k) as u32;
                        (fx[k], fy[k]) = ((x0 + c % cw) as f32, (y0 + c / cw) as f32);
                    }
                    let e = emission_through(ctx, camera, (&fx, &fy), m, true);
                    seen[first..first + PACKET].copy_from_slice(&e);
                }
                traced += count as u64;
                for j in 0..y1 - y0 {
                    for i in 0..x1 - x0 {
                        let at = |di: u32, dj: u32| seen[((j + dj) * cw + i + di) as usize];
                        let c = at(0, 0);
                        let interior =
                            c != Vec3::ZERO && at(1, 0) == c && at(0, 1) == c && at(1, 1) == c;
                        split[(j * width + x0 + i) as usize] = !interior;
                    }
                }
            }
            (split, traced)
        })
        .collect();
    let mut split = Vec::with_capacity(width as usize * height as usize);
    let mut traced = 0;
    for (row, n) in rows {
        split.extend(row);
        traced += n;
    }
    (split, traced)
}
