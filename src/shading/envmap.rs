//! Equirectangular (latitude-longitude) environment maps: linear radiance by direction, and
//! importance sampling of it.
//!
//! Directions map to image coordinates as Blender maps them (an environment texture in the
//! world, with the glTF importer's +Y up), so a glTF asset and an HDRI look the same in both:
//! u = 0.5 + atan2(d.z, d.x) / 2π, v = acos(d.y) / π, with v = 0 the image's top row: the
//! image's centre lies toward +X, u = 0.25 toward −Z, the top row straight up. `rotation`
//! turns the environment about +Y, counter-clockwise seen from above (the right-hand rule):
//! the radiance seen along d is the unrotated map's along R_y(−rotation)·d. The inverse
//! trigonometry is [`crate::math`]'s polynomials (within 5·10⁻⁷ rad, far below a texel).
//!
//! Radiance is looked up bilinearly between texel centres (u wraps around, v is clamped at
//! the poles). Directions are sampled in proportion to that same interpolation: the texel
//! centres are the vertices of a grid of cells (a row of half-height cells at each pole, where
//! the clamped lookup is constant in v), each vertex weighted by its luminance times sin θ of
//! its row, and the density over (u, v) is the bilinear interpolation of the vertex weights,
//! exactly as the radiance is interpolated. A cell is drawn from a piecewise-constant 2D
//! distribution by its mean weight (rows by their marginal, then a cell within the row,
//! pbrt-v4 §A.5), and the point within it from the bilinear patch of its four corners
//! (pbrt-v4 §A.4.2: v from the patch's linear marginal, then u from the linear conditional),
//! reusing the remainders of the two inversions. So L/pdf does not jump at texel edges, as it
//! does when a piecewise-constant pdf meets a bilinear radiance (Mitsuba's `envmap` warps
//! the same way, by its `Hierarchical2D`).
//!
//! What a lookup costs is kept to a constant's: each texel carries its vertex's sampling
//! density beside its radiance, so radiance and pdf come from one bilinear interpolation of
//! four 16-byte texels; each row holds one extra texel, a copy of its first, so the
//! bilinear lookup never wraps; and the inversion of each cdf starts from a guide table (Chen
//! and Asau's cutpoint method, 1974: entry k names the piece that holds k/n), so it finds
//! its piece in an expected constant number of steps instead of a binary search over the
//! row. The inversion is still the inversion: a stratified point set stays stratified over
//! the map, which an alias table (Walker 1977) would scatter. The cdfs and guides of all
//! rows live in one allocation.

use std::f32::consts::{FRAC_1_PI, PI, TAU};
use std::path::Path;

use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

use super::spectrum::luminance;
use crate::lanes::{Bits, Mask, Real, Vec2L, Vec3L};
use crate::math;

/// What light sampling draws directions of the map in proportion to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum MapSampling {
    /// The luminance of the lookup (the module documentation): every direction that sees
    /// radiance can be drawn. Needed where light sampling is the only strategy.
    Radiance,
    /// MIS compensation (Karlík, Šik, Vévoda, Skřivan and Křivánek, "MIS Compensation",
    /// ACM TOG 38(6), 2019, §5): the luminance less its mean over the sphere, so light
    /// sampling spends its samples on what outshines the average (a sun, softboxes) and
    /// leaves the rest to BSDF sampling, which MIS combines it with. Directions dimmer than
    /// the mean get pdf 0: only for MIS. A map of one colour keeps `Radiance`. The default
    /// under MIS: at equal time it lowers the RMSE on every HDRI-lit scene measured
    /// (BENCHMARKS.md, "Environment maps").
    #[default]
    Compensated,
}

/// One texel as lookups read it: linear RGB radiance in x, y, z, and in w the sampling
/// density of its vertex over the (u, v) square divided by 2π² (the solid-angle pdf of a
/// direction is the bilinear interpolation of w over sin θ).
type Texel = Vec4;

/// Piecewise-constant 1D distributions (pbrt-v4's `PiecewiseConstant1D`), one after another:
/// per entry, `cdf` at the start of a piece (the entry after a distribution's last piece
/// holds 1) and the guide, the piece that holds u = k/n. Two arrays, which lanes gather from.
#[derive(Clone, Debug, Default, PartialEq)]
struct Cells {
    cdf: Vec<f32>,
    guide: Vec<u32>,
}

impl Cells {
    fn new(len: usize) -> Cells {
        Cells {
            cdf: vec![0.0; len],
            guide: vec![0; len],
        }
    }
}

/// Fills `cdf` and `guide` (n + 1 entries each) with the distribution of `func` (n values,
/// at least 0) and returns ∫₀¹ func; with no weight anywhere the distribution is uniform.
fn build_distribution(func: &[f32], cdf: &mut [f32], guide: &mut [u32]) -> f32 {
    let n = func.len();
    debug_assert_eq!(cdf.len(), n + 1);
    debug_assert_eq!(guide.len(), n + 1);
    // The running sum in f64, normalised at the end.
    let integral = func.iter().map(|&f| f as f64).sum::<f64>() / n as f64;
    cdf[0] = 0.0;
    if integral > 0.0 {
        let scale = 1.0 / (integral * n as f64);
        let mut sum = 0.0f64;
        for (c, &f) in cdf[1..].iter_mut().zip(func) {
            sum += f as f64;
            *c = (sum * scale) as f32;
        }
    } else {
        for (i, c) in cdf.iter_mut().enumerate() {
            *c = i as f32 / n as f32;
        }
    }
    // guide[k] = the piece that u = k/n falls in, by the rule `invert_lanes` uses.
    let mut piece = 0;
    for (k, g) in guide.iter_mut().take(n).enumerate() {
        let u = k as f32 / n as f32;
        while piece < n - 1 && cdf[piece + 1] <= u {
            piece += 1;
        }
        *g = piece as u32;
    }
    integral as f32
}

/// The piece that holds `u` ∈ [0, 1) of the distribution of `n` pieces at entry `offset` of
/// `cdf` and `guide`, per lane: the number of pieces whose end is at most u, at most n − 1
/// (pieces of zero weight are never chosen) — what a binary search over the whole cdf finds,
/// found from the guide and a binary search between the guide's two neighbouring entries, an
/// expected constant number of steps (lanes step together until the last one is done).
/// Returns the piece and u's position within it, in [0, 1].
#[inline(always)]
fn invert_lanes<R: Real>(
    cdf: &[f32],
    guide: &[u32],
    offset: R::Bits,
    n: u32,
    u: R,
) -> (R::Bits, R) {
    let nf = n as f32;
    let one = R::Bits::splat(1);
    // The guide's slot k with k/n ≤ u < (k + 1)/n, exactly as the guide computed k/n.
    let k = (u * nf).min(R::splat(nf - 1.0)).max(R::ZERO).trunc_i32();
    let kf = R::from_i32(k);
    let down = (kf / nf).gt(u);
    let up = !down & k.lt(R::Bits::splat(n - 1)) & ((kf + 1.0) / nf).le(u);
    let k = R::Bits::select(down, k.wrapping_sub(one), k);
    let k = R::Bits::select(up, k.wrapping_add(one), k);
    // The answer lies between the pieces holding k/n and (k + 1)/n: the last piece i in
    // [lo, hi] that is lo or starts at most at u.
    let last = R::Bits::splat(n - 1);
    let next = k.wrapping_add(one);
    let mut lo = R::Bits::gather_slice(guide, offset.wrapping_add(k));
    let mut hi = R::Bits::select(
        next.lt(last) | next.eq(last),
        R::Bits::gather_slice(guide, offset.wrapping_add(next)),
        last,
    );
    loop {
        let open = lo.lt(hi);
        if open.none() {
            break;
        }
        let mid = lo.wrapping_add(hi).wrapping_add(one).shr(1);
        let below = R::gather_slice(cdf, offset.wrapping_add(mid)).le(u);
        lo = R::Bits::select(open & below, mid, lo);
        hi = R::Bits::select(open & !below, mid.wrapping_sub(one), hi);
    }
    let (start, end) = (
        R::gather_slice(cdf, offset.wrapping_add(lo)),
        R::gather_slice(cdf, offset.wrapping_add(lo).wrapping_add(one)),
    );
    let width = end - start;
    let du = R::select(
        width.gt(R::ZERO),
        ((u - start) / width).clamp(R::ZERO, R::ONE),
        R::splat(0.5),
    );
    (lo, du)
}

/// [`invert_lanes`] at one lane, for the whole of `cdf` and `guide` (n + 1 entries).
#[cfg(test)]
fn invert(cdf: &[f32], guide: &[u32], u: f32) -> (usize, f32) {
    let (i, du) = invert_lanes::<f32>(cdf, guide, 0, (cdf.len() - 1) as u32, u);
    (i as usize, du)
}

/// The x ∈ [0, 1) that `u` ∈ [0, 1) maps to under the density proportional to
/// (1 − x)·a + x·b (a, b ≥ 0): the inverse of its cdf, in the form that stays accurate when
/// a and b differ by orders of magnitude (pbrt-v4 §A.4.2, `SampleLinear`). Uniform when both
/// are 0.
#[inline(always)]
fn sample_linear<R: Real>(u: R, a: R, b: R) -> R {
    let sum = a + b;
    let x = u * sum / (a + ((R::ONE - u) * a * a + u * b * b).sqrt());
    R::select(
        sum.le(R::ZERO),
        u,
        x.min(R::splat(1.0 - f32::EPSILON / 2.0)),
    )
}

/// The vertex rows above and below cell row `r` of a map `height` texels high: cell row 0 is
/// the half row above the first row of centres and row `height` the half row below the last,
/// where the clamped lookup is constant in v.
#[inline]
fn vertex_rows(r: usize, height: usize) -> (usize, usize) {
    (r.saturating_sub(1), r.min(height - 1))
}

/// An equirectangular environment map (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    width: usize,
    height: usize,
    /// (width + 1) × height texels, row 0 the top (straight up), the last of each row a copy
    /// of its first; as arrays, so that lanes gather their channels from the flat floats.
    texels: Vec<[f32; 4]>,
    /// The marginal distribution over the height + 1 rows of cells (height + 2 entries),
    /// then each cell row's conditional one over its width cells (width + 1 entries each).
    cells: Cells,
    /// ∫ over [0, 1]² of L sin θ, L the lookup's luminance (interpolated as the weights are).
    integral: f32,
    /// sin and cos of the rotation about +Y.
    rotation: (f32, f32),
    /// Radiance scale (`--env-intensity`).
    scale: f32,
}

impl EnvMap {
    /// A map of `width × height` texels (row 0 the top), turned by `rotation` radians about
    /// +Y and scaled by `scale`. Negative and non-finite texels are taken as 0.
    pub fn new(
        width: usize,
        height: usize,
        texels: Vec<Vec3>,
        rotation: f32,
        scale: f32,
    ) -> EnvMap {
        EnvMap::sampled(
            width,
            height,
            texels,
            rotation,
            scale,
            MapSampling::Radiance,
        )
    }

    /// [`EnvMap::new`], light sampling drawing directions as `sampling` says.
    pub fn sampled(
        width: usize,
        height: usize,
        texels: Vec<Vec3>,
        rotation: f32,
        scale: f32,
        sampling: MapSampling,
    ) -> EnvMap {
        assert_eq!(texels.len(), width * height, "texel count");
        assert!(width > 0 && height > 0, "an empty map");
        assert!(
            width < u32::MAX as usize,
            "a map wider than a guide entry counts"
        );
        let texels: Vec<Vec3> = texels
            .par_iter()
            .map(|t| Vec3::select(t.cmpgt(Vec3::ZERO) & t.is_finite_mask(), *t, Vec3::ZERO))
            .collect();
        let luminances: Vec<f32> = texels.par_iter().map(|&t| luminance(t)).collect();
        // ∫ L sin θ du dv over [0, 1]², L sin θ interpolated as the weights are (the mean
        // luminance over the sphere is π/2 times it).
        let by_radiance = vertex_weights(width, height, &luminances, 0.0);
        let integral = grid_integral(width, height, &by_radiance);
        let mean = (integral * std::f64::consts::FRAC_PI_2) as f32;
        let mut weights = match sampling {
            // Nothing brighter than the mean: a map of one colour, sampled by its radiance.
            MapSampling::Compensated if luminances.par_iter().any(|&l| l > mean) => {
                vertex_weights(width, height, &luminances, mean)
            }
            _ => by_radiance,
        };
        drop(luminances);
        let mut total = grid_integral(width, height, &weights);
        if total <= 0.0 {
            // No weight anywhere (a black map): directions uniform over the sphere.
            weights = vertex_weights(width, height, &vec![1.0; width * height], 0.0);
            total = grid_integral(width, height, &weights);
        }
        // Each cell row's distribution over its cells by the sum of their corners, rows in
        // parallel, then the marginal over the rows by their integrals (the half rows at the
        // poles weigh half).
        let (w1, h1) = (width + 1, height + 1);
        let mut cells = Cells::new((h1 + 1) + h1 * w1);
        let (marginal_cdf, rows_cdf) = cells.cdf.split_at_mut(h1 + 1);
        let (marginal_guide, rows_guide) = cells.guide.split_at_mut(h1 + 1);
        let row_weights: Vec<f32> = rows_cdf
            .par_chunks_mut(w1)
            .zip(rows_guide.par_chunks_mut(w1))
            .enumerate()
            .map(|(r, (cdf, guide))| {
                let (a, b) = vertex_rows(r, height);
                let above = &weights[a * width..(a + 1) * width];
                let below = &weights[b * width..(b + 1) * width];
                let func: Vec<f32> = (0..width)
                    .map(|i| {
                        let j = (i + 1) % width;
                        above[i] + above[j] + below[i] + below[j]
                    })
                    .collect();
                let mean = build_distribution(&func, cdf, guide);
                match r == 0 || r == height {
                    true => 0.5 * mean,
                    false => mean,
                }
            })
            .collect();
        build_distribution(&row_weights, marginal_cdf, marginal_guide);
        // The density over the (u, v) square is the interpolated weight over its integral.
        let to_density = (1.0 / (total * 2.0 * std::f64::consts::PI.powi(2))) as f32;
        let mut padded = vec![Texel::ZERO; w1 * height];
        padded
            .par_chunks_mut(w1)
            .zip(texels.par_chunks(width).zip(weights.par_chunks(width)))
            .for_each(|(out, (row, w))| {
                for (o, (t, &w)) in out.iter_mut().zip(row.iter().zip(w)) {
                    *o = t.extend(w * to_density);
                }
                out[width] = out[0];
            });
        EnvMap {
            width,
            height,
            texels: padded.iter().map(Vec4::to_array).collect(),
            cells,
            integral: integral as f32,
            rotation: rotation.sin_cos(),
            scale,
        }
    }

    /// What the map of a `width × height` image takes in memory once made: its texels (a
    /// radiance and a density, 16 bytes, one extra column) and its sampling tables (8 bytes
    /// a cell, (width + 1) × (height + 1) cells and the height + 2 of the marginal).
    pub fn bytes_for(width: u64, height: u64) -> u64 {
        let texels = (width + 1)
            .saturating_mul(height)
            .saturating_mul(std::mem::size_of::<Texel>() as u64);
        let cells = (width + 1)
            .saturating_mul(height + 1)
            .saturating_add(height + 2)
            .saturating_mul((std::mem::size_of::<f32>() + std::mem::size_of::<u32>()) as u64);
        texels.saturating_add(cells)
    }

    /// What the map in the `.hdr` or `.exr` file at `path` will take in memory
    /// ([`EnvMap::bytes_for`]), from the file's header alone; an error where the header
    /// does not read.
    pub fn memory_estimate(path: &Path) -> Result<u64, String> {
        let name = path.display();
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        let (width, height) = match ext.as_str() {
            "hdr" => {
                let (w, h) = image::ImageReader::open(path)
                    .and_then(|r| r.with_guessed_format())
                    .map_err(|e| format!("{name}: {e}"))?
                    .into_dimensions()
                    .map_err(|e| format!("{name}: {e}"))?;
                (w as u64, h as u64)
            }
            "exr" => {
                let meta = exr::meta::MetaData::read_from_file(path, false)
                    .map_err(|e| format!("{name}: {e}"))?;
                // The largest layer: the map is read from the first RGBA one.
                (meta.headers.iter())
                    .map(|h| (h.layer_size.width() as u64, h.layer_size.height() as u64))
                    .max_by_key(|&(w, h)| w.saturating_mul(h))
                    .ok_or_else(|| format!("{name}: the file has no layer"))?
            }
            _ => return Err(format!("{name}: not a .hdr or .exr file")),
        };
        Ok(EnvMap::bytes_for(width, height))
    }

    /// Reads a Radiance `.hdr` or OpenEXR `.exr` file (linear RGB; alpha ignored), light
    /// sampling drawing directions as `sampling` says.
    pub fn load(
        path: &Path,
        rotation: f32,
        scale: f32,
        sampling: MapSampling,
    ) -> Result<EnvMap, String> {
        let name = path.display();
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        let (width, height, texels) = match ext.as_str() {
            "hdr" => {
                let image = image::open(path).map_err(|e| match e {
                    // A short read: what a file cut off in a copy or a download gives.
                    image::ImageError::IoError(io)
                        if io.kind() == std::io::ErrorKind::UnexpectedEof =>
                    {
                        format!("{name}: the file ends before its pixels do (truncated?): {io}")
                    }
                    e => format!("{name}: {e}"),
                })?;
                let rgb = image.to_rgb32f();
                let (w, h) = rgb.dimensions();
                let texels = rgb.pixels().map(|p| Vec3::from_array(p.0)).collect();
                (w as usize, h as usize, texels)
            }
            "exr" => read_exr(path)?,
            _ => {
                return Err(format!(
                    "{name}: not an environment map strata reads (Radiance .hdr or OpenEXR .exr)"
                ))
            }
        };
        if width == 0 || height == 0 {
            return Err(format!("{name}: the image is empty"));
        }
        Ok(EnvMap::sampled(
            width, height, texels, rotation, scale, sampling,
        ))
    }

    /// (width, height) in texels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Bytes held (texels with their densities, and the sampling distributions), for
    /// `--stats`.
    pub fn memory(&self) -> usize {
        self.texels.len() * std::mem::size_of::<[f32; 4]>()
            + self.cells.cdf.len() * (std::mem::size_of::<f32>() + std::mem::size_of::<u32>())
    }

    /// True when no texel holds any radiance.
    pub fn is_black(&self) -> bool {
        self.integral <= 0.0 || self.scale <= 0.0
    }

    /// The mean of the radiance over the sphere, by luminance (for choosing among emitters).
    pub fn mean_luminance(&self) -> f32 {
        // ∫ over [0,1]² of the weights is ∫ L sin θ du dv; the sphere's ∫ L dω = 2π² times
        // that, and the mean divides by 4π.
        self.integral * self.scale * PI / 2.0
    }

    /// The direction's (u, v) in the unrotated map, for a direction of unit length (the
    /// tests' one-lane form of [`EnvMap::uv_lanes`]).
    #[cfg(test)]
    fn uv(&self, d: Vec3) -> Vec2 {
        let (u, v) = self.uv_lanes(d.into());
        Vec2::new(u, v)
    }

    /// The direction's (u, v) in the unrotated map, for a direction of unit length.
    #[inline(always)]
    fn uv_lanes<R: Real>(&self, d: Vec3L<R>) -> (R, R) {
        let (s, c) = self.rotation;
        // R_y(−rotation)·d.
        let x = d.x * c - d.z * s;
        let z = d.x * s + d.z * c;
        let u = math::atan2(z, x) * (0.5 * FRAC_1_PI) + 0.5;
        let v = math::acos(d.y) * FRAC_1_PI;
        (u, v)
    }

    /// The world direction of unrotated (u, v), and sin θ there (the tests' one-lane form
    /// of [`EnvMap::direction_lanes`]).
    #[cfg(test)]
    fn direction(&self, uv: Vec2) -> (Vec3, f32) {
        let (d, sin_theta) = self.direction_lanes(uv.x, uv.y);
        (d.into(), sin_theta)
    }

    /// The world direction of unrotated (u, v), and sin θ there, per lane.
    #[inline(always)]
    fn direction_lanes<R: Real>(&self, u: R, v: R) -> (Vec3L<R>, R) {
        let (sin_t, cos_t) = math::sin_cos(v * PI);
        let (sin_p, cos_p) = math::sin_cos((u - 0.5) * TAU);
        let (x, z) = (sin_t * cos_p, sin_t * sin_p);
        // R_y(rotation)·(x, y, z).
        let (s, c) = (R::splat(self.rotation.0), R::splat(self.rotation.1));
        (Vec3L::new(c * x + s * z, cos_t, -s * x + c * z), sin_t)
    }

    /// The texel at `row`, `col` (col ≤ width: the padding column).
    #[cfg(test)]
    #[inline]
    fn texel(&self, row: usize, col: usize) -> Texel {
        Vec4::from_array(self.texels[row * (self.width + 1) + col])
    }

    /// The unscaled radiance and the density at (u, v) ∈ [0, 1]², bilinear between texel
    /// centres, at any width: the four corners' texels gathered per lane.
    #[inline(always)]
    fn lookup_lanes<R: Real>(&self, u: R, v: R) -> [R; 4] {
        let (w, h) = (self.width as f32, self.height as f32);
        // Texel centres sit at half-integers; left of the first centre, u wraps to the last
        // texel, whose right neighbour is the padding copy of the first.
        let x = u * w - 0.5;
        let x = R::select(x.lt(R::ZERO), x + w, x);
        // The column min(⌊x⌋, width − 1), clamped in floats before the conversion.
        let x0 = x
            .max(R::ZERO)
            .min(R::splat((self.width - 1) as f32))
            .trunc_i32();
        let fx = (x - R::from_i32(x0)).clamp(R::ZERO, R::ONE);
        // v is clamped at the poles.
        let y = (v * h - 0.5).max(R::ZERO);
        let y0 = y.min(R::splat((self.height - 1) as f32)).trunc_i32();
        let last = R::Bits::splat(self.height as u32 - 1);
        let y1 = R::Bits::select(y0.lt(last), y0.wrapping_add(R::Bits::splat(1)), last);
        let fy = (y - R::from_i32(y0)).clamp(R::ZERO, R::ONE);
        let stride = R::Bits::splat(self.width as u32 + 1);
        // The texels at and right of column x0 in rows y0 and y1, their four channels.
        let (top, bottom) = (
            y0.wrapping_mul(stride).wrapping_add(x0),
            y1.wrapping_mul(stride).wrapping_add(x0),
        );
        let one = R::Bits::splat(1);
        let t00 = R::gather4(&self.texels, top);
        let t10 = R::gather4(&self.texels, top.wrapping_add(one));
        let t01 = R::gather4(&self.texels, bottom);
        let t11 = R::gather4(&self.texels, bottom.wrapping_add(one));
        bilinear(t00, t10, t01, t11, fx, fy)
    }

    /// The radiance seen along unit direction `dir` (bilinear between texel centres).
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        self.radiance_lanes(dir.into()).into()
    }

    /// The radiance seen along unit direction `dir` and the solid-angle pdf of
    /// [`EnvMap::sample`] drawing it, from one parametrisation and one interpolation.
    #[inline]
    pub fn radiance_pdf(&self, dir: Vec3) -> (Vec3, f32) {
        let (l, pdf) = self.radiance_pdf_lanes(dir.into());
        (l.into(), pdf)
    }

    /// [`EnvMap::radiance`] at any width.
    #[inline(always)]
    pub fn radiance_lanes<R: Real>(&self, dir: Vec3L<R>) -> Vec3L<R> {
        self.radiance_pdf_parts(dir).0
    }

    /// [`EnvMap::radiance_pdf`] at any width.
    #[inline(always)]
    pub fn radiance_pdf_lanes<R: Real>(&self, dir: Vec3L<R>) -> (Vec3L<R>, R) {
        let (l, density, finite) = self.radiance_pdf_parts(dir);
        let pdf = R::select(finite, solid_angle_pdf(density, dir), R::ZERO);
        (l, pdf)
    }

    /// The scaled radiance along `dir` (zero where its (u, v) is not finite), the density
    /// there, and where (u, v) was finite.
    #[inline(always)]
    fn radiance_pdf_parts<R: Real>(&self, dir: Vec3L<R>) -> (Vec3L<R>, R, R::Mask) {
        let (u, v) = self.uv_lanes(dir);
        let inf = R::splat(f32::INFINITY);
        let finite = u.abs().lt(inf) & v.abs().lt(inf);
        let [r, g, b, density] =
            self.lookup_lanes(R::select(finite, u, R::ZERO), R::select(finite, v, R::ZERO));
        let scale = R::splat(self.scale);
        let l = Vec3L::new(r * scale, g * scale, b * scale);
        (
            Vec3L::select(finite, l, Vec3L::all(R::ZERO)),
            density,
            finite,
        )
    }

    /// A direction drawn with `u`, its radiance and its solid-angle pdf (0 at the poles,
    /// where the map's parametrisation degenerates).
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, Vec3, f32) {
        let (dir, l, pdf) = self.sample_lanes::<f32>(u.into());
        (dir.into(), l.into(), pdf)
    }

    /// [`EnvMap::sample`] at any width: the cell by the guided inversions of the marginal and
    /// the cell row's conditional, then the point within the cell's bilinear patch from the
    /// remainders (pbrt-v4 §A.4.2), its four corners gathered per lane.
    #[inline(always)]
    pub fn sample_lanes<R: Real>(&self, u: Vec2L<R>) -> (Vec3L<R>, Vec3L<R>, R) {
        let (width, height) = (self.width as u32, self.height as u32);
        let (w1, h1) = (width + 1, height + 1);
        let (cdf, guide) = (&self.cells.cdf[..], &self.cells.guide[..]);
        let (r, dv) = invert_lanes(cdf, guide, R::Bits::splat(0), h1, u.y);
        let start = R::Bits::splat(h1 + 1).wrapping_add(r.wrapping_mul(R::Bits::splat(w1)));
        let (i, du) = invert_lanes(cdf, guide, start, width, u.x);
        // The vertex rows above and below cell row r (as `vertex_rows`).
        let one = R::Bits::splat(1);
        let top = r.eq(R::Bits::splat(0));
        let bottom = r.eq(R::Bits::splat(height));
        let a = R::Bits::select(top, r, r.wrapping_sub(one));
        let b = R::Bits::select(bottom, r.wrapping_sub(one), r);
        let (stride, i1) = (R::Bits::splat(w1), i.wrapping_add(one));
        let (a, b) = (a.wrapping_mul(stride), b.wrapping_mul(stride));
        let t00 = R::gather4(&self.texels, a.wrapping_add(i));
        let t10 = R::gather4(&self.texels, a.wrapping_add(i1));
        let t01 = R::gather4(&self.texels, b.wrapping_add(i));
        let t11 = R::gather4(&self.texels, b.wrapping_add(i1));
        let fy = sample_linear(dv, t00[3] + t10[3], t01[3] + t11[3]);
        let fx = sample_linear(
            du,
            t00[3] + (t01[3] - t00[3]) * fy,
            t10[3] + (t11[3] - t10[3]) * fy,
        );
        // Cell column i spans u from (i + ½)/w to (i + 3/2)/w, wrapping past 1; cell row r
        // spans v from (r − ½)/h to (r + ½)/h, clipped to [0, 1] at the poles.
        let (w, h) = (self.width as f32, self.height as f32);
        let uu = (R::from_i32(i) + 0.5 + fx) / w;
        let uu = R::select(uu.ge(R::ONE), uu - 1.0, uu);
        let v_top = fy * 0.5 / h;
        let v_bottom = (R::splat(h - 0.5) + fy * 0.5) / h;
        let v_middle = (R::from_i32(r) - 0.5 + fy) / h;
        let v = R::select(top, v_top, R::select(bottom, v_bottom, v_middle));
        let below_one = R::splat(1.0 - f32::EPSILON / 2.0);
        let (dir, sin_theta) = self.direction_lanes(uu.min(below_one), v.min(below_one));
        let l = bilinear(t00, t10, t01, t11, fx, fy);
        let pdf = R::select(sin_theta.gt(R::ZERO), l[3] / sin_theta, R::ZERO);
        let scale = R::splat(self.scale);
        (
            dir,
            Vec3L::new(l[0] * scale, l[1] * scale, l[2] * scale),
            pdf,
        )
    }

    /// The solid-angle pdf of [`EnvMap::sample`] drawing unit direction `dir`.
    #[inline]
    pub fn pdf(&self, dir: Vec3) -> f32 {
        self.radiance_pdf_lanes(dir.into()).1
    }
}

/// The four channels of texels `t00`, `t10` (a row) and `t01`, `t11` (the next) interpolated
/// by `fx` along the rows and `fy` across, each as glam's lerp: a(1 − t) + bt.
#[inline(always)]
fn bilinear<R: Real>(t00: [R; 4], t10: [R; 4], t01: [R; 4], t11: [R; 4], fx: R, fy: R) -> [R; 4] {
    let mut l = [R::ZERO; 4];
    for (k, l) in l.iter_mut().enumerate() {
        let top = t00[k] * (R::ONE - fx) + t10[k] * fx;
        let bottom = t01[k] * (R::ONE - fx) + t11[k] * fx;
        *l = top * (R::ONE - fy) + bottom * fy;
    }
    l
}

/// The solid-angle pdf of unit direction `dir` whose interpolated density (over (u, v), by
/// 2π²) is `density`: that over sin θ, 0 at the poles where the parametrisation degenerates.
#[inline(always)]
fn solid_angle_pdf<R: Real>(density: R, dir: Vec3L<R>) -> R {
    let sin_theta = (dir.x * dir.x + dir.z * dir.z).sqrt();
    R::select(sin_theta.gt(R::ZERO), density / sin_theta, R::ZERO)
}

/// sin θ at the centre of row `y` of `height`.
fn sin_theta_of_row(y: usize, height: usize) -> f32 {
    (PI * (y as f32 + 0.5) / height as f32).sin()
}

/// Each vertex's (texel centre's) sampling weight over the (u, v) square: its luminance less
/// `minus` (at least 0), times sin θ of its row.
fn vertex_weights(width: usize, height: usize, luminances: &[f32], minus: f32) -> Vec<f32> {
    let mut weights = vec![0f32; width * height];
    weights
        .par_chunks_mut(width)
        .zip(luminances.par_chunks(width))
        .enumerate()
        .for_each(|(y, (out, l))| {
            let sin_theta = sin_theta_of_row(y, height);
            for (o, &l) in out.iter_mut().zip(l) {
                *o = (l - minus).max(0.0) * sin_theta;
            }
        });
    weights
}

/// ∫ over [0, 1]² of the bilinear interpolation of the vertex values `w` (u wraps, v is
/// clamped): along u each vertex row's mean, along v each cell row the mean of its two
/// vertex rows times its height.
fn grid_integral(width: usize, height: usize, w: &[f32]) -> f64 {
    let means: Vec<f64> = w
        .par_chunks(width)
        .map(|row| row.iter().map(|&x| x as f64).sum::<f64>() / width as f64)
        .collect();
    (0..=height)
        .map(|r| {
            let (a, b) = vertex_rows(r, height);
            let half = if r == 0 || r == height { 0.25 } else { 0.5 };
            half * (means[a] + means[b])
        })
        .sum::<f64>()
        / height as f64
}

/// The first RGB(A) layer of an OpenEXR file as linear f32 texels, row 0 at the top; a clear
/// error for what the `exr` crate cannot decode (DWAA/DWAB, used by Blender's studio lights),
/// with the command that converts it.
fn read_exr(path: &Path) -> Result<(usize, usize, Vec<Vec3>), String> {
    use exr::prelude::*;
    let name = path.display();
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| {
            (
                resolution.width(),
                vec![Vec3::ZERO; resolution.width() * resolution.height()],
            )
        },
        |(width, texels): &mut (usize, Vec<Vec3>), position, (r, g, b, _a): (f32, f32, f32, f32)| {
            texels[position.y() * *width + position.x()] = Vec3::new(r, g, b);
        },
    )
    .map_err(|e| {
        let message = e.to_string();
        if message.to_ascii_lowercase().contains("dwa") || matches!(e, Error::NotSupported(_)) {
            format!(
                "{name}: {message}; strata's EXR reader does not decode this compression (DWAA/DWAB are common in Blender's studio lights). Convert it losslessly: oiiotool {name} -d float --compression zip -o converted.exr"
            )
        } else {
            format!("{name}: {message}")
        }
    })?;
    let (width, texels) = image.layer_data.channel_data.pixels;
    let height = texels.len() / width.max(1);
    Ok((width, height, texels))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The radiance and pdf of a turned, scaled, random map at eight lanes have the bits of
    /// one lane, over random directions, the poles and the seam.
    /// Sampling gives the same bits at one lane and eight, on a map with a bright sun and
    /// black texels (pieces of no weight, guide slots far apart), at the poles' half rows
    /// and the seam, with lanes that take different numbers of search steps side by side.
    #[test]
    fn sampling_has_the_same_bits_at_every_width() {
        static MAPS: std::sync::OnceLock<[EnvMap; 2]> = std::sync::OnceLock::new();
        #[inline(always)]
        fn kernel<R: Real>([u, v, which]: [R; 3]) -> [R; 7] {
            let map = &MAPS.get().expect("made below")[(which.lane(0) > 0.5) as usize];
            let (d, l, pdf) = map.sample_lanes(Vec2L::new(u, v));
            [d.x, d.y, d.z, l.x, l.y, l.z, pdf]
        }
        let (w, h) = (41, 23);
        let mut next = crate::sampling::hash::uniform_sequence(52);
        let texels: Vec<Vec3> = (0..w * h)
            .map(|i| match i % 7 {
                0 | 3 => Vec3::ZERO,
                _ => Vec3::new(next(), next(), next()),
            })
            .collect();
        let mut sunny = texels.clone();
        sunny[5 * w + 17] = Vec3::splat(5e4);
        MAPS.get_or_init(|| {
            [
                EnvMap::new(w, h, texels, 0.3, 1.0),
                EnvMap::sampled(w, h, sunny, -1.1, 2.0, MapSampling::Compensated),
            ]
        });
        // Eight lanes in a row on one map, the next eight on the other.
        let inputs = (0..16_000).map(|k| {
            let which = ((k / 8) % 2) as f32;
            let (u, v) = match k % 50 {
                0 => (0.0, 0.0),
                1 => (next(), 0.999_999_94),
                2 => (0.999_999_94, next()),
                _ => (next(), next()),
            };
            [u, v, which]
        });
        crate::lanes::assert_same_bits_at_every_width!(kernel: [3] -> [7], inputs);
    }

    #[test]
    fn lookups_have_the_same_bits_at_every_width() {
        static MAP: std::sync::OnceLock<EnvMap> = std::sync::OnceLock::new();
        #[inline(always)]
        fn kernel<R: Real>([x, y, z]: [R; 3]) -> [R; 4] {
            let map = MAP.get().expect("made below");
            let (l, pdf) = map.radiance_pdf_lanes(Vec3L::new(x, y, z).normalize());
            [l.x, l.y, l.z, pdf]
        }
        let (w, h) = (37, 19);
        let mut next = crate::sampling::hash::uniform_sequence(51);
        let texels = (0..w * h)
            .map(|_| Vec3::new(next(), next(), next()) * 4.0)
            .collect();
        MAP.get_or_init(|| EnvMap::new(w, h, texels, 0.7, 1.5));
        let mut inputs: Vec<[f32; 3]> = (0..20_000)
            .map(|_| [next() * 2.0 - 1.0, next() * 2.0 - 1.0, next() * 2.0 - 1.0])
            .collect();
        inputs.extend([
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [-1.0, 0.0, 1e-9],
            [-1.0, 0.0, -1e-9],
        ]);
        crate::lanes::assert_same_bits_at_every_width!(kernel: [3] -> [4], inputs);
    }

    /// Four quadrants of u (the map's columns) with distinct colours, and a bright top half.
    fn quadrants(width: usize, height: usize) -> Vec<Vec3> {
        let colours = [Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE];
        (0..height)
            .flat_map(|y| {
                (0..width)
                    .map(move |x| colours[4 * x / width] * if y < height / 2 { 4.0 } else { 1.0 })
            })
            .collect()
    }

    /// Blender's convention: +X sees the image's centre (u = 0.5: the third quadrant's first
    /// column), −Z sees u = 0.25 (the second quadrant's), +Z u = 0.75, −X the seam (u = 0);
    /// up is the top row. A rotation of 90° about +Y (counter-clockwise seen from above)
    /// carries what +Z saw to +X.
    #[test]
    fn directions_map_to_the_image_as_blender_maps_them() {
        let (w, h) = (64, 32);
        let map = EnvMap::new(w, h, quadrants(w, h), 0.0, 1.0);
        let near = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-3;
        let level = |d: Vec3| (d - Vec3::new(0.0, 0.2, 0.0)).normalize();
        // Just inside each quadrant, slightly below the horizon (the dim half).
        let angle = |u: f32| {
            let phi = std::f32::consts::TAU * (u - 0.5);
            level(Vec3::new(phi.cos(), 0.0, phi.sin()))
        };
        assert!(near(map.radiance(angle(0.5 + 0.06)), Vec3::Z), "+X side");
        assert!(near(map.radiance(angle(0.25 + 0.06)), Vec3::Y), "−Z side");
        assert!(near(map.radiance(angle(0.75 + 0.06)), Vec3::ONE), "+Z side");
        assert!(near(map.radiance(angle(0.06)), Vec3::X), "−X side");
        // Up sees the top row (four times as bright), where u = 0.5 blends the middle
        // quadrants' colours half and half.
        assert!(near(map.radiance(Vec3::Y), Vec3::new(0.0, 2.0, 2.0)), "up");
        let turned = EnvMap::new(w, h, quadrants(w, h), std::f32::consts::FRAC_PI_2, 1.0);
        assert!(
            near(turned.radiance(angle(0.5 + 0.06)), Vec3::ONE),
            "rotated: +X sees what +Z saw"
        );
        // Round trip of the parametrisation.
        for uv in [
            Vec2::new(0.1, 0.3),
            Vec2::new(0.7, 0.9),
            Vec2::new(0.45, 0.5),
        ] {
            assert!(
                (turned.uv(turned.direction(uv).0) - uv).length() < 1e-4,
                "{uv}"
            );
        }
    }

    /// Sampling: each direction's returned pdf is `pdf`'s, the estimator L/pdf integrates the
    /// map over the sphere as quadrature does (1%), and over the 16 × 8 blocks of the image the
    /// fraction of stratified samples in each equals its pdf mass (to 1% and the points a
    /// block's edges can split).
    #[test]
    fn sampling_follows_the_map_and_integrates_it() {
        let (w, h) = (64, 32);
        let mut texels = quadrants(w, h);
        texels[10 * w + 40] = Vec3::splat(500.0); // a sun
        let map = EnvMap::new(w, h, texels, 0.4, 2.0);
        // ∫ L dω by quadrature over (u, v): 2π² ∫∫ L sin θ du dv.
        let (qn, qm) = (1024, 512);
        let mut quadrature = 0.0f64;
        for j in 0..qm {
            for i in 0..qn {
                let uv = Vec2::new((i as f32 + 0.5) / qn as f32, (j as f32 + 0.5) / qm as f32);
                let sin_t = (std::f32::consts::PI * uv.y).sin() as f64;
                quadrature += luminance(map.radiance(map.direction(uv).0)) as f64 * sin_t;
            }
        }
        quadrature *= 2.0 * std::f64::consts::PI.powi(2) / (qn * qm) as f64;
        let n = 1024;
        let mut estimate = 0.0f64;
        let mut blocks = vec![0.0f64; 16 * 8];
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let (dir, l, pdf) = map.sample(u);
                if pdf <= 0.0 {
                    continue;
                }
                assert!(
                    (pdf - map.pdf(dir)).abs() <= 1e-3 * pdf,
                    "u {u}: {pdf} against {}",
                    map.pdf(dir)
                );
                estimate += luminance(l) as f64 / pdf as f64;
                let uv = map.uv(dir);
                let b = ((uv.y * 8.0) as usize).min(7) * 16
                    + ((uv.x.rem_euclid(1.0) * 16.0) as usize).min(15);
                blocks[b] += 1.0 / (n * n) as f64;
            }
        }
        estimate /= (n * n) as f64;
        assert!(
            (estimate - quadrature).abs() < 0.01 * quadrature,
            "{estimate} against {quadrature}"
        );
        // Each block's pdf mass, by quadrature of pdf over its solid angle.
        for (b, &got) in blocks.iter().enumerate() {
            let (bx, by) = (b % 16, b / 16);
            let mut mass = 0.0f64;
            let k = 32;
            for j in 0..k {
                for i in 0..k {
                    let uv = Vec2::new(
                        (bx as f32 + (i as f32 + 0.5) / k as f32) / 16.0,
                        (by as f32 + (j as f32 + 0.5) / k as f32) / 8.0,
                    );
                    let sin_t = (std::f32::consts::PI * uv.y).sin() as f64;
                    mass += map.pdf(map.direction(uv).0) as f64 * sin_t;
                }
            }
            mass *= 2.0 * std::f64::consts::PI.powi(2) / (16.0 * 8.0 * (k * k) as f64);
            // Within a row, the stratified points miss a block's edges by at most one point on
            // each side: 2 points per value of u.y in the block's rows (4 of 32).
            let edges = 2.0 * (n as f64 * 4.0 / 32.0) / (n * n) as f64;
            assert!(
                (got - mass).abs() < 0.01 * mass + edges,
                "block {b}: {got} against {mass}"
            );
        }
    }

    /// MIS compensation: light samples land only on texels brighter than the mean, the dim
    /// ones get pdf 0, and light sampling combined with uniform sphere sampling by the power
    /// heuristic still integrates the map as quadrature does (1%); light sampling alone then
    /// misses the dim quadrants (the negative control).
    #[test]
    fn compensated_sampling_needs_and_survives_mis() {
        let (w, h) = (64, 32);
        let mut texels = quadrants(w, h);
        texels[10 * w + 40] = Vec3::splat(500.0);
        let map = EnvMap::sampled(w, h, texels.clone(), 0.4, 2.0, MapSampling::Compensated);
        // The mean luminance (light selection's weight) is the map's, not the compensated
        // distribution's.
        let plain = EnvMap::new(w, h, texels, 0.4, 2.0);
        assert_eq!(map.mean_luminance(), plain.mean_luminance());
        let (qn, qm) = (1024, 512);
        let mut quadrature = 0.0f64;
        let mut dim_without_pdf = 0;
        for j in 0..qm {
            for i in 0..qn {
                let uv = Vec2::new((i as f32 + 0.5) / qn as f32, (j as f32 + 0.5) / qm as f32);
                let (d, sin_t) = map.direction(uv);
                let (l, pdf) = map.radiance_pdf(d);
                quadrature += luminance(l) as f64 * sin_t as f64;
                dim_without_pdf += (luminance(l) > 0.0 && pdf == 0.0) as usize;
            }
        }
        quadrature *= 2.0 * std::f64::consts::PI.powi(2) / (qn * qm) as f64;
        assert!(dim_without_pdf > qn * qm / 4, "{dim_without_pdf}");
        let uniform_pdf = 0.25 * FRAC_1_PI;
        let n = 512;
        let (mut mis, mut light_alone) = (0.0f64, 0.0f64);
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let (_, l, pdf) = map.sample(u);
                if pdf > 0.0 {
                    let f = luminance(l) as f64 / pdf as f64;
                    light_alone += f;
                    let w = pdf * pdf / (pdf * pdf + uniform_pdf * uniform_pdf);
                    mis += f * w as f64;
                }
                let d2 = crate::sampling::warps::square_to_uniform_sphere(u);
                let (l2, pdf2) = map.radiance_pdf(d2);
                let w2 = uniform_pdf * uniform_pdf / (pdf2 * pdf2 + uniform_pdf * uniform_pdf);
                mis += luminance(l2) as f64 / uniform_pdf as f64 * w2 as f64;
            }
        }
        let (mis, light_alone) = (mis / (n * n) as f64, light_alone / (n * n) as f64);
        assert!(
            (mis - quadrature).abs() < 0.01 * quadrature,
            "{mis} against {quadrature}"
        );
        assert!(
            light_alone < 0.9 * quadrature,
            "{light_alone} against {quadrature}"
        );
    }

    /// Every direction whose lookup sees radiance can be sampled: a single bright texel's
    /// bilinear footprint spills into its neighbours, whose pdf is positive too.
    #[test]
    fn the_pdf_covers_the_bilinear_footprint() {
        let (w, h) = (16, 8);
        let mut texels = vec![Vec3::ZERO; w * h];
        texels[3 * w + 5] = Vec3::ONE;
        let map = EnvMap::new(w, h, texels, 0.0, 1.0);
        for j in 0..4 * h {
            for i in 0..4 * w {
                let uv = Vec2::new(
                    (i as f32 + 0.5) / (4 * w) as f32,
                    (j as f32 + 0.5) / (4 * h) as f32,
                );
                let d = map.direction(uv).0;
                if map.radiance(d).max_element() > 0.0 {
                    assert!(map.pdf(d) > 0.0, "uv {uv}: radiance without a pdf");
                }
            }
        }
    }

    /// The pdf follows the bilinear lookup within each texel: on a checkerboard of texels 1
    /// and 50 apart, L/pdf (which a pdf constant over each texel makes jump fiftyfold at its
    /// edges) stays within the variation of sin θ across a row (6%) away from the poles, for
    /// looked-up directions and sampled ones alike.
    #[test]
    fn radiance_over_pdf_is_smooth_across_texels() {
        let (w, h) = (256, 128);
        let texels: Vec<Vec3> = (0..w * h)
            .map(|k| Vec3::splat(if (k % w + k / w) % 2 == 0 { 1.0 } else { 50.0 }))
            .collect();
        let map = EnvMap::new(w, h, texels, 0.3, 1.0);
        let mut ratios = Vec::new();
        for j in 0..200 {
            for i in 0..400 {
                let uv = Vec2::new((i as f32 + 0.37) / 400.0, 0.25 + 0.5 * j as f32 / 200.0);
                let d = map.direction(uv).0;
                let (l, pdf) = map.radiance_pdf(d);
                ratios.push(luminance(l) / pdf);
            }
        }
        let n = 256;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let (d, l, pdf) = map.sample(u);
                if (0.25..0.75).contains(&map.uv(d).y) {
                    ratios.push(luminance(l) / pdf);
                }
            }
        }
        let (lo, hi) = ratios
            .iter()
            .fold((f32::MAX, 0f32), |(lo, hi), &r| (lo.min(r), hi.max(r)));
        assert!(hi / lo < 1.06, "L/pdf from {lo} to {hi}");
    }

    /// The guided inversion finds the piece a binary search over the cdf finds, for every u
    /// of a fine grid and at and around every cdf entry, on distributions with pieces of
    /// zero weight, one piece holding almost everything, and none weighing anything.
    #[test]
    fn the_guide_finds_what_a_binary_search_finds() {
        let mut sun = vec![1e-3f32; 1000];
        sun[617] = 1e6;
        let funcs: Vec<Vec<f32>> = vec![
            vec![1.0, 0.0, 0.0, 2.0, 0.0, 5.0, 0.0],
            sun,
            vec![0.0; 5],
            (0..333).map(|i| ((i * 7919) % 13) as f32).collect(),
            vec![3.0],
        ];
        for func in funcs {
            let n = func.len();
            let mut cells = Cells::new(n + 1);
            build_distribution(&func, &mut cells.cdf, &mut cells.guide);
            let binary = |u: f32| cells.cdf.partition_point(|&c| c <= u).clamp(1, n) - 1;
            let mut us: Vec<f32> = (0..10_000).map(|i| i as f32 / 10_000.0).collect();
            for &c in &cells.cdf {
                for u in [c, f32::from_bits(c.to_bits().saturating_sub(1))] {
                    if (0.0..1.0).contains(&u) {
                        us.push(u);
                        us.push(f32::from_bits(u.to_bits() + 1).min(0.999_999_94));
                    }
                }
            }
            for u in us {
                let (i, du) = invert(&cells.cdf, &cells.guide, u);
                assert_eq!(i, binary(u), "n {n}, u {u}");
                assert!((0.0..=1.0).contains(&du));
                if n > 1 && func.iter().any(|&f| f > 0.0) {
                    assert!(func[i] > 0.0, "a piece of no weight chosen at u {u}");
                }
            }
        }
    }

    /// A negative control for the test above: a guide that names the piece after the right
    /// one is caught.
    #[test]
    fn a_wrong_guide_is_caught() {
        let func = vec![1.0f32, 2.0, 3.0, 4.0];
        let mut cells = Cells::new(5);
        build_distribution(&func, &mut cells.cdf, &mut cells.guide);
        let right: Vec<usize> = (0..100)
            .map(|i| invert(&cells.cdf, &cells.guide, i as f32 / 100.0).0)
            .collect();
        cells.guide[1] += 1;
        let wrong: Vec<usize> = (0..100)
            .map(|i| invert(&cells.cdf, &cells.guide, i as f32 / 100.0).0)
            .collect();
        assert_ne!(right, wrong);
    }

    #[test]
    fn negative_and_non_finite_texels_are_zero() {
        let texels = vec![Vec3::new(-1.0, f32::NAN, f32::INFINITY), Vec3::ONE];
        let map = EnvMap::new(2, 1, texels, 0.0, 1.0);
        assert_eq!(map.texel(0, 0).truncate(), Vec3::ZERO);
        assert!(map.radiance(Vec3::X).is_finite());
    }
}
