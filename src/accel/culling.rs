//! Which blocks of pixels can see the scene at all.
//!
//! A [`BlockMask`] divides the image into blocks of [`BLOCK_W`] × [`BLOCK_H`] pixels from its
//! top-left corner (the camera packets' shape) and marks those whose film area meets the
//! image of one of the scene's cluster boxes ([`crate::accel::Accel::clusters`], each
//! projected by [`RayGenerator::film_bounds`]). A ray from a film position in an unmarked
//! block meets no cluster box, so no triangle: the renderer gives such blocks' samples the
//! estimate of a miss without sampling or tracing them.

use glam::Vec3;

use crate::scene::RayGenerator;

/// Width of a block, in pixels.
pub const BLOCK_W: u32 = 4;
/// Height of a block, in pixels.
pub const BLOCK_H: u32 = 2;

/// The blocks of an image that can see some cluster box (see the module's documentation).
#[derive(Clone, Debug)]
pub struct BlockMask {
    cols: usize,
    rows: usize,
    /// Row-major, one per block.
    seen: Vec<bool>,
}

impl BlockMask {
    /// The mask of a `width × height` image seen through `camera`, for the boxes `clusters`;
    /// None where some box has no film rectangle (a perspective camera inside it), which
    /// leaves every block to be traced.
    pub fn new(
        camera: &RayGenerator,
        clusters: &[(Vec3, Vec3)],
        width: u32,
        height: u32,
    ) -> Option<BlockMask> {
        let cols = width.div_ceil(BLOCK_W) as usize;
        let rows = height.div_ceil(BLOCK_H) as usize;
        // Each rectangle adds 1 over the blocks it overlaps, as four corner entries of a
        // difference table; running sums then count the rectangles over each block.
        let stride = cols + 1;
        let mut diff = vec![0i32; stride * (rows + 1)];
        for &(lo, hi) in clusters {
            let [x0, y0, x1, y1] = camera.film_bounds(lo, hi, width, height)?;
            // Block i covers film positions [w·i, w·(i + 1)]: it overlaps [x0, x1] when
            // w·i ≤ x1 and w·(i + 1) ≥ x0.
            let span = |a: f32, b: f32, w: u32, n: usize| -> Option<(usize, usize)> {
                let w = w as f32;
                let first = ((a - w) / w).ceil().max(0.0);
                let last = (b / w).floor().min(n as f32 - 1.0);
                (first <= last).then_some((first as usize, last as usize))
            };
            let (Some((c0, c1)), Some((r0, r1))) =
                (span(x0, x1, BLOCK_W, cols), span(y0, y1, BLOCK_H, rows))
            else {
                continue;
            };
            diff[r0 * stride + c0] += 1;
            diff[r0 * stride + c1 + 1] -= 1;
            diff[(r1 + 1) * stride + c0] -= 1;
            diff[(r1 + 1) * stride + c1 + 1] += 1;
        }
        for r in 0..=rows {
            for c in 1..=cols {
                diff[r * stride + c] += diff[r * stride + c - 1];
            }
        }
        for r in 1..=rows {
            for c in 0..=cols {
                diff[r * stride + c] += diff[(r - 1) * stride + c];
            }
        }
        let seen = (0..rows)
            .flat_map(|r| (0..cols).map(move |c| (r, c)))
            .map(|(r, c)| diff[r * stride + c] > 0)
            .collect();
        Some(BlockMask { cols, rows, seen })
    }

    /// True when some pixel of `[x0, x1) × [y0, y1)` (a non-empty range inside the image) lies
    /// in a block that can see a cluster box.
    #[inline]
    pub fn sees(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> bool {
        let (c0, c1) = ((x0 / BLOCK_W) as usize, ((x1 - 1) / BLOCK_W) as usize);
        let (r0, r1) = ((y0 / BLOCK_H) as usize, ((y1 - 1) / BLOCK_H) as usize);
        debug_assert!(c1 < self.cols && r1 < self.rows);
        (r0..=r1).any(|r| self.seen[r * self.cols + c0..=r * self.cols + c1].contains(&true))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Camera, Projection};
    use glam::Mat4;

    /// The mask marks exactly the blocks whose film area meets a cluster's rectangle, checked
    /// block by block against the rectangles themselves for random boxes, and `sees` answers
    /// for pixel ranges that straddle blocks.
    #[test]
    fn marked_blocks_are_those_a_rectangle_overlaps() {
        let camera = Camera {
            name: None,
            projection: Projection::Perspective { yfov: 0.9 },
            to_world: Mat4::from_translation(Vec3::new(0.0, 0.0, 12.0)),
            aspect_ratio: None,
            lens: None,
        };
        let (width, height) = (61u32, 37u32);
        let g = camera.ray_generator(width, height);
        let mut next = crate::sampling::hash::uniform_sequence(3);
        for _ in 0..200 {
            let clusters: Vec<(Vec3, Vec3)> = (0..3)
                .map(|_| {
                    let c = Vec3::new(next() * 14.0 - 7.0, next() * 10.0 - 5.0, next() * 4.0 - 2.0);
                    let h = Vec3::new(next(), next(), next()) * 0.8;
                    (c - h, c + h)
                })
                .collect();
            let rects: Vec<[f32; 4]> = clusters
                .iter()
                .map(|&(lo, hi)| g.film_bounds(lo, hi, width, height).unwrap())
                .collect();
            let mask = BlockMask::new(&g, &clusters, width, height).unwrap();
            for r in 0..mask.rows {
                for c in 0..mask.cols {
                    let (bx, by) = ((c as u32 * BLOCK_W) as f32, (r as u32 * BLOCK_H) as f32);
                    let (bw, bh) = (BLOCK_W as f32, BLOCK_H as f32);
                    let want = rects.iter().any(|&[x0, y0, x1, y1]| {
                        x0 <= bx + bw && x1 >= bx && y0 <= by + bh && y1 >= by
                    });
                    assert_eq!(
                        mask.seen[r * mask.cols + c],
                        want,
                        "block ({c}, {r}) of {rects:?}"
                    );
                }
            }
            // A range is seen when any block it touches is.
            for _ in 0..50 {
                let x0 = (next() * width as f32) as u32 % width;
                let y0 = (next() * height as f32) as u32 % height;
                let x1 = (x0 + 1 + (next() * 6.0) as u32).min(width);
                let y1 = (y0 + 1 + (next() * 3.0) as u32).min(height);
                let want = (y0..y1).any(|y| {
                    (x0..x1).any(|x| {
                        let (c, r) = ((x / BLOCK_W) as usize, (y / BLOCK_H) as usize);
                        mask.seen[r * mask.cols + c]
                    })
                });
                assert_eq!(mask.sees(x0, y0, x1, y1), want);
            }
        }
    }

    /// No mask when a box has no rectangle (here, one around the camera).
    #[test]
    fn no_mask_when_a_box_surrounds_the_camera() {
        let camera = Camera {
            name: None,
            projection: Projection::Perspective { yfov: 0.9 },
            to_world: Mat4::IDENTITY,
            aspect_ratio: None,
            lens: None,
        };
        let g = camera.ray_generator(32, 32);
        let far = (Vec3::new(-1.0, -1.0, -9.0), Vec3::new(1.0, 1.0, -8.0));
        let around = (Vec3::splat(-1.0), Vec3::splat(1.0));
        assert!(BlockMask::new(&g, &[far], 32, 32).is_some());
        assert!(BlockMask::new(&g, &[far, around], 32, 32).is_none());
    }
}
