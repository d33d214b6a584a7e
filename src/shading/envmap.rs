//! Equirectangular (latitude-longitude) environment maps: linear radiance by direction, and
//! importance sampling of it.
//!
//! Directions map to image coordinates as Blender maps them (an environment texture in the
//! world, with the glTF importer's +Y up), so a glTF asset and an HDRI look the same in both:
//! u = 0.5 + atan2(d.z, d.x) / 2π, v = acos(d.y) / π, with v = 0 the image's top row: the
//! image's centre lies toward +X, u = 0.25 toward −Z, the top row straight up. `rotation`
//! turns the environment about +Y, counter-clockwise seen from above (the right-hand rule):
//! the radiance seen along d is the unrotated map's along R_y(−rotation)·d.
//!
//! Radiance is looked up bilinearly between texel centres (u wraps around, v is clamped at
//! the poles). Directions are sampled from a piecewise-constant distribution over the image
//! (pbrt-v4 §A.5's 2D distribution: rows by their marginal, then a column within the row),
//! each texel weighted by the mean of the bilinear lookup over its area (the texels
//! weighted 1/8, 3/4, 1/8 along each axis) times sin θ of its row. The mean is positive
//! wherever the lookup is, so every direction that sees radiance can be sampled, and the
//! weight follows the luminance the lookup returns (pbrt-v4 §12.5).

use std::path::Path;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::spectrum::luminance;
use crate::scene::Wrap;
use crate::texture::Image;

/// A piecewise-constant density on [0, 1) (pbrt-v4's `PiecewiseConstant1D`).
#[derive(Clone, Debug, PartialEq)]
struct Distribution1D {
    func: Vec<f32>,
    /// cdf[i] = ∫₀^{i/n} of the normalised density; n + 1 entries, the last exactly 1.
    cdf: Vec<f32>,
    /// ∫₀¹ func.
    integral: f32,
}

impl Distribution1D {
    fn new(func: Vec<f32>) -> Distribution1D {
        let n = func.len();
        // The running sum in f64, normalised at the end.
        let integral = func.iter().map(|&f| f as f64).sum::<f64>() / n as f64;
        let cdf = if integral > 0.0 {
            let scale = 1.0 / (integral * n as f64);
            let mut sum = 0.0f64;
            std::iter::once(0.0)
                .chain(func.iter().map(|&f| {
                    sum += f as f64;
                    (sum * scale) as f32
                }))
                .collect()
        } else {
            // No weight anywhere: uniform, so that sampling stays defined.
            (0..=n).map(|i| i as f32 / n as f32).collect()
        };
        Distribution1D {
            func,
            cdf,
            integral: integral as f32,
        }
    }

    /// A point drawn with `u`, its density, and the index of its piece.
    fn sample(&self, u: f32) -> (f32, f32, usize) {
        let n = self.func.len();
        // The last cdf entry at most u.
        let i = self.cdf.partition_point(|&c| c <= u).clamp(1, n) - 1;
        let width = self.cdf[i + 1] - self.cdf[i];
        let du = if width > 0.0 {
            (u - self.cdf[i]) / width
        } else {
            0.5
        };
        let x = ((i as f32 + du.clamp(0.0, 1.0)) / n as f32).min(1.0 - f32::EPSILON / 2.0);
        (x, self.density(i), i)
    }

    /// The density of piece `i`.
    fn density(&self, i: usize) -> f32 {
        if self.integral > 0.0 {
            self.func[i] / self.integral
        } else {
            1.0
        }
    }
}

/// An equirectangular environment map (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    /// Linear RGB radiance (alpha 1), row 0 the top (straight up), looked up as textures
    /// are ([`Image::bilinear`]: u repeats, v clamps at the poles).
    image: Image,
    /// sin and cos of the rotation about +Y.
    rotation: (f32, f32),
    /// Radiance scale (`--env-intensity`).
    scale: f32,
    /// The rows' marginal and each row's conditional distribution.
    marginal: Distribution1D,
    conditional: Vec<Distribution1D>,
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
        assert_eq!(texels.len(), width * height, "texel count");
        assert!(width > 0 && height > 0, "an empty map");
        // RGBA texels as textures hold them, negative and non-finite values zeroed.
        let texels: Vec<glam::Vec4> = texels
            .par_iter()
            .map(|t| Vec3::select(t.cmpgt(Vec3::ZERO) & t.is_finite_mask(), *t, Vec3::ZERO))
            .map(|t| t.extend(1.0))
            .collect();
        // Each texel's weight: the mean of the bilinear lookup over its area, times sin θ.
        // The mean's kernel (1/8, 3/4, 1/8 along each axis; u wraps, v is clamped) is
        // separable: a pass along the rows, then one along the columns, rows in parallel.
        let (k0, k1) = (0.125f32, 0.75f32);
        let mut along_rows = vec![0f32; width * height];
        along_rows
            .par_chunks_mut(width)
            .zip(texels.par_chunks(width))
            .for_each(|(out, row)| {
                let lum = |x: usize| luminance(row[x].truncate());
                for (x, o) in out.iter_mut().enumerate() {
                    let (left, right) = ((x + width - 1) % width, (x + 1) % width);
                    *o = k0 * lum(left) + k1 * lum(x) + k0 * lum(right);
                }
            });
        let conditional: Vec<Distribution1D> = (0..height)
            .into_par_iter()
            .map(|y| {
                let sin_theta = (std::f32::consts::PI * (y as f32 + 0.5) / height as f32).sin();
                let (up, down) = (y.saturating_sub(1), (y + 1).min(height - 1));
                let row = |r: usize| &along_rows[r * width..(r + 1) * width];
                let (a, b, c) = (row(up), row(y), row(down));
                let func = (0..width)
                    .map(|x| (k0 * a[x] + k1 * b[x] + k0 * c[x]) * sin_theta)
                    .collect();
                Distribution1D::new(func)
            })
            .collect();
        let row_integrals = conditional.iter().map(|row| row.integral).collect();
        EnvMap {
            image: Image {
                width: width as u32,
                height: height as u32,
                texels,
            },
            rotation: rotation.sin_cos(),
            scale,
            marginal: Distribution1D::new(row_integrals),
            conditional,
        }
    }

    /// Reads a Radiance `.hdr` or OpenEXR `.exr` file (linear RGB; alpha ignored).
    pub fn load(path: &Path, rotation: f32, scale: f32) -> Result<EnvMap, String> {
        let name = path.display();
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        let (width, height, texels) = match ext.as_str() {
            "hdr" => {
                let image = image::open(path).map_err(|e| format!("{name}: {e}"))?;
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
        Ok(EnvMap::new(width, height, texels, rotation, scale))
    }

    /// (width, height) in texels.
    pub fn size(&self) -> (usize, usize) {
        (self.image.width as usize, self.image.height as usize)
    }

    /// Bytes held (texels and the sampling distributions), for `--stats`.
    pub fn memory(&self) -> usize {
        let (texels, rows) = (self.image.texels.len(), self.conditional.len());
        texels * std::mem::size_of::<glam::Vec4>() + 2 * 4 * (texels + rows)
    }

    /// True when no texel holds any radiance.
    pub fn is_black(&self) -> bool {
        self.marginal.integral <= 0.0 || self.scale <= 0.0
    }

    /// The mean of the radiance over the sphere, by luminance (for choosing among emitters).
    pub fn mean_luminance(&self) -> f32 {
        // ∫ over [0,1]² of the weights is ∫ L sin θ du dv; the sphere's ∫ L dω = 2π² times
        // that, and the mean divides by 4π.
        self.marginal.integral * self.scale * std::f32::consts::PI / 2.0
    }

    /// The direction's (u, v) in the unrotated map.
    #[inline]
    fn uv(&self, dir: Vec3) -> Vec2 {
        let d = dir.normalize();
        let (s, c) = self.rotation;
        // R_y(−rotation)·d.
        let x = c * d.x - s * d.z;
        let z = s * d.x + c * d.z;
        let u = 0.5 + z.atan2(x) * (0.5 * std::f32::consts::FRAC_1_PI);
        let v = d.y.clamp(-1.0, 1.0).acos() * std::f32::consts::FRAC_1_PI;
        Vec2::new(u, v)
    }

    /// The world direction of unrotated (u, v).
    #[inline]
    fn direction(&self, uv: Vec2) -> Vec3 {
        let phi = std::f32::consts::TAU * (uv.x - 0.5);
        let theta = std::f32::consts::PI * uv.y;
        let (sin_t, cos_t) = theta.sin_cos();
        let (sin_p, cos_p) = phi.sin_cos();
        let (x, z) = (sin_t * cos_p, sin_t * sin_p);
        // R_y(rotation)·(x, y, z).
        let (s, c) = self.rotation;
        Vec3::new(c * x + s * z, cos_t, -s * x + c * z)
    }

    /// The radiance seen along `dir` (bilinear between texel centres).
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let uv = self.uv(dir);
        let texel = self.image.bilinear(uv, Wrap::Repeat, Wrap::ClampToEdge);
        texel.truncate() * self.scale
    }

    /// A direction drawn with `u`, its radiance and its solid-angle pdf (0 at the poles,
    /// where the map's parametrisation degenerates).
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, Vec3, f32) {
        let (v, pdf_v, row) = self.marginal.sample(u.y);
        let (uu, pdf_u, _) = self.conditional[row].sample(u.x);
        let dir = self.direction(Vec2::new(uu, v));
        let sin_theta = (std::f32::consts::PI * v).sin();
        let pdf = if sin_theta > 0.0 {
            pdf_u * pdf_v / (2.0 * std::f32::consts::PI * std::f32::consts::PI * sin_theta)
        } else {
            0.0
        };
        (dir, self.radiance(dir), pdf)
    }

    /// The solid-angle pdf of [`EnvMap::sample`] drawing `dir`.
    #[inline]
    pub fn pdf(&self, dir: Vec3) -> f32 {
        let uv = self.uv(dir);
        let sin_theta = (std::f32::consts::PI * uv.y).sin();
        if sin_theta <= 0.0 {
            return 0.0;
        }
        let (width, height) = self.size();
        let row = ((uv.y * height as f32) as usize).min(height - 1);
        let col = ((uv.x.rem_euclid(1.0) * width as f32) as usize).min(width - 1);
        let p = self.marginal.density(row) * self.conditional[row].density(col);
        p / (2.0 * std::f32::consts::PI * std::f32::consts::PI * sin_theta)
    }
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
                (turned.uv(turned.direction(uv)) - uv).length() < 1e-4,
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
                quadrature += luminance(map.radiance(map.direction(uv))) as f64 * sin_t;
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
                    mass += map.pdf(map.direction(uv)) as f64 * sin_t;
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
                let d = map.direction(uv);
                if map.radiance(d).max_element() > 0.0 {
                    assert!(map.pdf(d) > 0.0, "uv {uv}: radiance without a pdf");
                }
            }
        }
    }

    #[test]
    fn negative_and_non_finite_texels_are_zero() {
        let texels = vec![Vec3::new(-1.0, f32::NAN, f32::INFINITY), Vec3::ONE];
        let map = EnvMap::new(2, 1, texels, 0.0, 1.0);
        assert_eq!(map.image.texels[0].truncate(), Vec3::ZERO);
        assert!(map.radiance(Vec3::X).is_finite());
    }
}
