//! The film: per-pixel sums of sample values and sample counts, box-filtered (a sample
//! contributes to its own pixel only, like Mitsuba's `box` reconstruction filter).

use glam::Vec3;

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
    /// Samples taken per pixel (rejected NaN/Inf samples count as taken).
    counts: Vec<u32>,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Film {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            sums: vec![[0.0; 3]; n],
            counts: vec![0; n],
        }
    }

    #[inline]
    fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// Adds `count` samples whose values sum to `sum` to pixel (x, y).
    #[inline]
    pub fn add(&mut self, x: u32, y: u32, sum: [f64; 3], count: u32) {
        let i = self.index(x, y);
        for (acc, s) in self.sums[i].iter_mut().zip(sum) {
            *acc += s;
        }
        self.counts[i] += count;
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
