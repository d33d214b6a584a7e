//! Warps from the unit square [0, 1)² to directions and points, each with its pdf and, where
//! it exists, its inverse. Local frames have z along the normal.
//!
//! References: Shirley & Chiu, "A Low Distortion Map Between Disk and Square" (1997) for the
//! concentric disk; Malley's method (cosine hemisphere = disk lifted to the hemisphere);
//! pbrt-v4 §A.5 for the pdfs.

use crate::lanes::{self, Kernel, Real, Vec2L, Vec3L, F8};
use crate::math;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI, TAU};

/// Uniform direction on the hemisphere z ≥ 0; pdf 1/(2π) per steradian.
#[inline(always)]
pub fn uniform_hemisphere<R: Real>(u: Vec2L<R>) -> Vec3L<R> {
    let z = u.x;
    let r = (R::ONE - z * z).safe_sqrt();
    let (s, c) = math::sin_cos(u.y * TAU);
    Vec3L::new(r * c, r * s, z)
}

/// [`uniform_hemisphere`] of one point.
#[inline]
pub fn square_to_uniform_hemisphere(u: Vec2) -> Vec3 {
    uniform_hemisphere(u.into()).into()
}

#[inline]
pub fn uniform_hemisphere_pdf(v: Vec3) -> f32 {
    if v.z >= 0.0 {
        0.5 * FRAC_1_PI
    } else {
        0.0
    }
}

pub fn uniform_hemisphere_to_square(v: Vec3) -> Vec2 {
    Vec2::new(v.z, azimuth_fraction(v))
}

/// Concentric map of the square onto the unit disk (Shirley & Chiu 1997).
///
/// Within a wedge the angle is θ = φ (right and left wedges) or θ = π/2 − φ (top and
/// bottom), with φ = π/4 · (minor/major coordinate) in [−π/4, π/4]; so sin and cos of φ alone
/// give the point, and over that range short polynomials ([`math::sin_cos_quarter`]) reach
/// f32 precision without the range reduction of a general `sin_cos`. The wedge and the
/// centre are chosen by masks, so no branch depends on the coin toss of which wedge a point
/// falls in.
#[inline(always)]
pub fn concentric_disk<R: Real>(u: Vec2L<R>) -> Vec2L<R> {
    let ox = u.x * 2.0 - 1.0;
    let oy = u.y * 2.0 - 1.0;
    // The wedge: `major` is the coordinate the concentric map divides by.
    let right = ox.abs().gt(oy.abs());
    let major = R::select(right, ox, oy);
    let minor = R::select(right, oy, ox);
    let (sin, cos) = math::sin_cos_quarter((minor / major) * FRAC_PI_4);
    // d = major·(cos, sin) in the right and left wedges, major·(sin, cos) in the top and
    // bottom ones, and 0 at the centre (where the division gave NaN).
    let centre = ox.eq(R::ZERO) & oy.eq(R::ZERO);
    Vec2L::new(
        R::select(centre, R::ZERO, major * R::select(right, cos, sin)),
        R::select(centre, R::ZERO, major * R::select(right, sin, cos)),
    )
}

/// [`concentric_disk`] of one point.
#[inline]
pub fn square_to_concentric_disk(u: Vec2) -> Vec2 {
    concentric_disk(u.into()).into()
}

/// Inverse of [`square_to_concentric_disk`].
pub fn concentric_disk_to_square(p: Vec2) -> Vec2 {
    let r = p.length();
    if r == 0.0 {
        return Vec2::splat(0.5);
    }
    // φ in (−π/4, 7π/4]: the four wedges of the forward map.
    let mut phi = p.y.atan2(p.x);
    if phi < -FRAC_PI_4 {
        phi += TAU;
    }
    let (a, b) = if phi < FRAC_PI_4 {
        // Right wedge: o = (r, r·φ/(π/4)).
        (r, r * phi / FRAC_PI_4)
    } else if phi < 3.0 * FRAC_PI_4 {
        // Top wedge: o.y = r, o.x = r·(π/2 − φ)/(π/4).
        (r * (FRAC_PI_2 - phi) / FRAC_PI_4, r)
    } else if phi < 5.0 * FRAC_PI_4 {
        // Left wedge: o.x = −r, θ = φ − π.
        (-r, -r * (phi - PI) / FRAC_PI_4)
    } else {
        // Bottom wedge: o.y = −r, θ = φ − π.
        (-r * (FRAC_PI_2 - (phi - PI)) / FRAC_PI_4, -r)
    };
    // A point on the rim may lie a rounding error outside the disk (the (x, y) part of a
    // normalised direction with z = 0), which would put the result just outside [0, 1]².
    ((Vec2::new(a, b) + Vec2::ONE) * 0.5).clamp(Vec2::ZERO, Vec2::ONE)
}

/// Cosine-weighted direction on the hemisphere z ≥ 0 (Malley's method on the concentric
/// disk); pdf cos θ / π.
#[inline(always)]
pub fn cosine_hemisphere<R: Real>(u: Vec2L<R>) -> Vec3L<R> {
    let d = concentric_disk(u);
    // safe_sqrt keeps rounding from making the radicand negative.
    let z = (R::ONE - (d.x * d.x + d.y * d.y)).safe_sqrt();
    Vec3L::new(d.x, d.y, z)
}

/// [`cosine_hemisphere`] of one point.
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    cosine_hemisphere(u.into()).into()
}

/// [`cosine_hemisphere`] of `N` points, eight at a time in [`F8`] lanes (AVX2 where the
/// processor has it): bit for bit the one-point warp, the lanes' arithmetic side by side.
#[inline]
pub fn square_to_cosine_hemisphere_lanes<const N: usize>(u: &[Vec2; N]) -> [Vec3; N] {
    struct Warp<'a, const N: usize>(&'a [Vec2; N]);
    impl<const N: usize> Kernel for Warp<'_, N> {
        type Output = [Vec3; N];
        #[inline(always)]
        fn run(self) -> [Vec3; N] {
            let mut out = [Vec3::ZERO; N];
            for (u, out) in self.0.chunks(8).zip(out.chunks_mut(8)) {
                // Lanes past the chunk's end warp the centre; they are not used.
                let points =
                    Vec2L::<F8>::from_fn(|i| u.get(i).copied().unwrap_or(Vec2::splat(0.5)));
                let d = cosine_hemisphere(points);
                for (i, out) in out.iter_mut().enumerate() {
                    *out = d.lane(i);
                }
            }
            out
        }
    }
    lanes::dispatch(Warp(u))
}

#[inline]
pub fn cosine_hemisphere_pdf(v: Vec3) -> f32 {
    v.z.max(0.0) * FRAC_1_PI
}

pub fn cosine_hemisphere_to_square(v: Vec3) -> Vec2 {
    concentric_disk_to_square(Vec2::new(v.x, v.y))
}

/// Uniform direction on the unit sphere; pdf 1/(4π).
#[inline(always)]
pub fn uniform_sphere<R: Real>(u: Vec2L<R>) -> Vec3L<R> {
    let z = R::ONE - u.x * 2.0;
    let r = (R::ONE - z * z).safe_sqrt();
    let (s, c) = math::sin_cos(u.y * TAU);
    Vec3L::new(r * c, r * s, z)
}

/// [`uniform_sphere`] of one point.
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    uniform_sphere(u.into()).into()
}

#[inline]
pub fn uniform_sphere_pdf() -> f32 {
    0.25 * FRAC_1_PI
}

pub fn uniform_sphere_to_square(v: Vec3) -> Vec2 {
    Vec2::new((1.0 - v.z) * 0.5, azimuth_fraction(v))
}

/// Uniform direction in the cone of half-angle θmax around +z; pdf 1/(2π(1 − cos θmax)).
#[inline(always)]
pub fn uniform_cone<R: Real>(u: Vec2L<R>, cos_theta_max: R) -> Vec3L<R> {
    // Rounding of 1 − u·(1 − cos θmax) can land just below cos θmax (u.x = 1, cos θmax =
    // −0.9304151 gives −0.93041515), outside the cone where the pdf is 0: clamp.
    let z = (R::ONE - u.x * (R::ONE - cos_theta_max)).max(cos_theta_max);
    let r = (R::ONE - z * z).safe_sqrt();
    let (s, c) = math::sin_cos(u.y * TAU);
    Vec3L::new(r * c, r * s, z)
}

/// [`uniform_cone`] of one point.
#[inline]
pub fn square_to_uniform_cone(u: Vec2, cos_theta_max: f32) -> Vec3 {
    uniform_cone(u.into(), cos_theta_max).into()
}

#[inline]
pub fn uniform_cone_pdf(v: Vec3, cos_theta_max: f32) -> f32 {
    if v.z >= cos_theta_max {
        1.0 / (TAU * (1.0 - cos_theta_max))
    } else {
        0.0
    }
}

pub fn uniform_cone_to_square(v: Vec3, cos_theta_max: f32) -> Vec2 {
    Vec2::new((1.0 - v.z) / (1.0 - cos_theta_max), azimuth_fraction(v))
}

/// Uniform barycentrics (b0, b1) on a triangle, b2 = 1 − b0 − b1 (pbrt-v4 §A.5.5's
/// square-root mapping); the pdf with respect to area is 1/area.
#[inline(always)]
pub fn uniform_triangle<R: Real>(u: Vec2L<R>) -> Vec2L<R> {
    let s = u.x.sqrt();
    let b0 = R::ONE - s;
    // Bound b1 by 1 − b0 as rounded, so that b2 = 1 − b0 − b1 is never negative (without
    // it, u.x = 1e-45 rounds b0 to 1 while b1 = u.y·s stays positive).
    Vec2L::new(b0, (u.y * s).min(R::ONE - b0))
}

/// [`uniform_triangle`] of one point.
#[inline]
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    uniform_triangle(u.into()).into()
}

pub fn uniform_triangle_to_square(b: Vec2) -> Vec2 {
    let s = 1.0 - b.x;
    Vec2::new(s * s, if s > 0.0 { b.y / s } else { 0.0 })
}

/// φ/(2π) in [0, 1) of a direction's azimuth.
fn azimuth_fraction(v: Vec3) -> f32 {
    let mut phi = v.y.atan2(v.x);
    if phi < 0.0 {
        phi += TAU;
    }
    (phi / TAU).min(1.0 - f32::EPSILON / 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every forward warp: eight lanes give the bits of eight single lanes, over random
    /// points, the square's centre, corners and edges and its diagonals (where the concentric
    /// map's wedge changes).
    #[test]
    fn warps_have_the_same_bits_at_every_width() {
        #[inline(always)]
        fn kernel<R: Real>([ux, uy, c]: [R; 3]) -> [R; 15] {
            let u = Vec2L::new(ux, uy);
            let (d, h, s) = (
                concentric_disk(u),
                cosine_hemisphere(u),
                uniform_hemisphere(u),
            );
            let (sphere, cone, tri) = (
                uniform_sphere(u),
                uniform_cone(u, c * 2.0 - 1.0),
                uniform_triangle(u),
            );
            [
                d.x, d.y, h.x, h.y, h.z, s.x, s.z, sphere.x, sphere.y, sphere.z, cone.x, cone.y,
                cone.z, tri.x, tri.y,
            ]
        }
        let mut next = crate::sampling::hash::uniform_sequence(47);
        let mut inputs: Vec<[f32; 3]> = (0..20_000).map(|_| [next(), next(), next()]).collect();
        for k in 0..=64 {
            let t = k as f32 / 64.0;
            let edge = t.min(1.0 - f32::EPSILON / 2.0);
            for (x, y) in [
                (t, t),
                (t, 1.0 - t),
                (0.0, edge),
                (edge, 0.0),
                (0.5, 0.5),
                (0.5, t),
            ] {
                inputs.push([x, y, t]);
            }
        }
        crate::lanes::assert_same_bits_at_every_width!(kernel: [3] -> [15], inputs);
    }

    fn grid() -> impl Iterator<Item = Vec2> {
        (1..40).flat_map(|i| (1..40).map(move |j| Vec2::new(i as f32 / 40.0, j as f32 / 40.0)))
    }

    #[test]
    fn warps_round_trip_through_their_inverses() {
        for u in grid() {
            let checks = [
                (
                    "uniform hemisphere",
                    uniform_hemisphere_to_square(square_to_uniform_hemisphere(u)),
                ),
                (
                    "cosine hemisphere",
                    cosine_hemisphere_to_square(square_to_cosine_hemisphere(u)),
                ),
                (
                    "uniform sphere",
                    uniform_sphere_to_square(square_to_uniform_sphere(u)),
                ),
                (
                    "uniform cone",
                    uniform_cone_to_square(square_to_uniform_cone(u, 0.3), 0.3),
                ),
                (
                    "uniform triangle",
                    uniform_triangle_to_square(square_to_uniform_triangle(u)),
                ),
            ];
            for (name, back) in checks {
                assert!(
                    (back - u).abs().max_element() < 2e-4,
                    "{name}: {u} -> {back}"
                );
            }
        }
    }

    #[test]
    fn directions_are_unit_and_in_their_domain() {
        for u in grid().chain([
            Vec2::ZERO,
            Vec2::ONE,
            Vec2::new(1.0, 0.0),
            Vec2::new(0.0, 1.0),
        ]) {
            for (name, v, pdf) in [
                (
                    "uniform hemisphere",
                    square_to_uniform_hemisphere(u),
                    uniform_hemisphere_pdf(square_to_uniform_hemisphere(u)),
                ),
                ("cosine hemisphere", square_to_cosine_hemisphere(u), 1.0),
                (
                    "uniform sphere",
                    square_to_uniform_sphere(u),
                    uniform_sphere_pdf(),
                ),
            ] {
                assert!((v.length() - 1.0).abs() < 1e-5, "{name}({u}) = {v}");
                assert!(v.is_finite() && pdf.is_finite() && pdf > 0.0, "{name}({u})");
            }
            assert!(square_to_uniform_hemisphere(u).z >= 0.0);
            assert!(square_to_cosine_hemisphere(u).z >= 0.0);
            let d = square_to_concentric_disk(u);
            assert!(d.length() <= 1.0 + 1e-6);
        }
    }

    /// The lane-parallel cosine warp equals the scalar one bit for bit, over random points,
    /// the square's centre, its edges and its diagonals (where the wedge changes).
    #[test]
    fn cosine_warp_lanes_equal_the_scalar_warp() {
        let mut next = crate::sampling::hash::uniform_sequence(5);
        let mut points = Vec::new();
        for k in 0..=64 {
            let t = k as f32 / 64.0;
            let edge = t.min(1.0 - f32::EPSILON / 2.0);
            points.extend([
                Vec2::new(t, t),
                Vec2::new(t, 1.0 - t),
                Vec2::new(0.0, edge),
                Vec2::new(edge, 0.0),
                Vec2::splat(0.5),
                Vec2::new(0.5, t),
            ]);
        }
        points.extend((0..100_000).map(|_| Vec2::new(next(), next())));
        fn check<const N: usize>(points: &[Vec2]) {
            for chunk in points.chunks_exact(N) {
                let u: [Vec2; N] = chunk.try_into().unwrap();
                let lanes = square_to_cosine_hemisphere_lanes(&u);
                for (p, got) in u.iter().zip(lanes) {
                    let want = square_to_cosine_hemisphere(*p);
                    assert_eq!(
                        got.to_array().map(f32::to_bits),
                        want.to_array().map(f32::to_bits),
                        "{p}, {N} lanes"
                    );
                }
            }
        }
        // The packet sizes, and one that leaves a part-filled group of four.
        check::<16>(&points);
        check::<8>(&points);
        check::<7>(&points);
    }

    /// The quarter-range polynomials are within 2 ulps of f64's sin and cos over [−π/4, π/4]
    /// (every 2^-20 of the range), and the disk points they give lie within 3e-7 of the
    /// exact concentric map's.
    #[test]
    fn quarter_range_sin_cos_is_accurate() {
        let steps = 1 << 20;
        let mut worst = 0f64;
        for k in -steps..=steps {
            let phi = (FRAC_PI_4 as f64 * k as f64 / steps as f64) as f32;
            let (s, c) = math::sin_cos_quarter(phi);
            let (es, ec) = (phi as f64).sin_cos();
            for (got, exact) in [(s, es), (c, ec)] {
                let ulp = (exact.abs() as f32).next_up() - exact.abs() as f32;
                let err = (got as f64 - exact).abs() / ulp as f64;
                worst = worst.max(err);
            }
        }
        assert!(worst <= 2.0, "worst error {worst} ulps");
        let mut next = crate::sampling::hash::uniform_sequence(3);
        for _ in 0..100_000 {
            let u = Vec2::new(next(), next());
            let d = square_to_concentric_disk(u);
            // The exact map, in f64.
            let (ox, oy) = (2.0 * u.x as f64 - 1.0, 2.0 * u.y as f64 - 1.0);
            let (r, theta) = if ox.abs() > oy.abs() {
                (ox, std::f64::consts::FRAC_PI_4 * (oy / ox))
            } else {
                (
                    oy,
                    std::f64::consts::FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (ox / oy),
                )
            };
            let (x, y) = (r * theta.cos(), r * theta.sin());
            let err = (d.x as f64 - x).abs().max((d.y as f64 - y).abs());
            assert!(err < 3e-7, "{u}: {d} against ({x}, {y})");
        }
    }
}

/// Solid angle subtended by the spherical triangle of unit vectors `a`, `b`, `c`
/// (Van Oosterom & Strackee 1983): Ω = 2·atan2(|a·(b×c)|, 1 + a·b + b·c + c·a).
#[inline]
pub fn spherical_triangle_area(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

/// A direction distributed uniformly (pdf 1/Ω) over the spherical triangle of unit vectors
/// `a`, `b`, `c`, with the two stages of Arvo, "Stratified Sampling of Spherical Triangles"
/// (SIGGRAPH 1995): `u.x` picks the sub-triangle (a, b, Ĉ) of area u.x·Ω, which fixes the
/// point Ĉ on arc AC; `u.y` picks the point on arc BĈ, uniform in solid angle. Returns `None`
/// for a degenerate triangle.
///
/// Ĉ is not found with Arvo's closed form, which goes through the vertex angle α and
/// loses most of its digits in f32 on thin triangles (samples landed up to 9e-3 rad outside
/// them, tests/stress_warps.rs). Instead, with Ĉ = cos φ·a + sin φ·c⊥, the
/// Van Oosterom–Strackee formula for the sub-triangle's area h = Â/2 solves to
/// tan(φ/2) = (1 + a·b)·sin h / (K·cos h − (b·c⊥)·sin h), K = |(a × b)·c⊥|; and 1 ∓ cos of
/// the arc from b to Ĉ are taken as |Ĉ ∓ b|²/2, accurate where 1 ∓ Ĉ·b cancel.
pub fn square_to_spherical_triangle(a: Vec3, b: Vec3, c: Vec3, u: Vec2) -> Option<Vec3> {
    let area = spherical_triangle_area(a, b, c);
    if !(area > 0.0 && area.is_finite()) {
        return None;
    }
    // c⊥: the unit tangent at a of the great circle toward c; θ_ac the arc length a → c.
    let c_off = c - c.dot(a) * a;
    let c_perp = c_off.try_normalize()?;
    let theta_ac = c_off.length().atan2(c.dot(a));

    // Ĉ on arc AC such that the triangle (a, b, Ĉ) has area u.x·Ω.
    let k = a.cross(b).dot(c_perp).abs();
    let (sin_h, cos_h) = (0.5 * u.x * area).sin_cos();
    let half_phi = ((1.0 + a.dot(b)) * sin_h).atan2(k * cos_h - b.dot(c_perp) * sin_h);
    let (sin_phi, cos_phi) = (2.0 * half_phi).min(theta_ac).sin_cos();
    let c_hat = cos_phi * a + sin_phi * c_perp;

    // Uniform in solid angle along the arc from b to Ĉ: 1 − cos θ = u.y·(1 − Ĉ·b), and
    // 1 + cos θ = 2(1 − u.y) + u.y·(1 + Ĉ·b), each without cancellation.
    let one_minus_z = u.y * 0.5 * (c_hat - b).length_squared();
    let one_plus_z = 2.0 * (1.0 - u.y) + u.y * 0.5 * (c_hat + b).length_squared();
    let Some(perp) = (c_hat - c_hat.dot(b) * b).try_normalize() else {
        return Some(b);
    };
    let sin_theta = (one_minus_z * one_plus_z).max(0.0).sqrt();
    Some(((1.0 - one_minus_z) * b + sin_theta * perp).normalize())
}

#[cfg(test)]
mod spherical_tests {
    use super::*;

    /// Splits (a, b, c) into four spherical sub-triangles at the edge midpoints.
    fn subdivide(a: Vec3, b: Vec3, c: Vec3) -> [[Vec3; 3]; 4] {
        let (ab, bc, ca) = (
            (a + b).normalize(),
            (b + c).normalize(),
            (c + a).normalize(),
        );
        [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
    }

    fn inside(p: Vec3, [a, b, c]: [Vec3; 3]) -> bool {
        let s = a.dot(b.cross(c)).signum();
        p.dot(a.cross(b)) * s >= -1e-6
            && p.dot(b.cross(c)) * s >= -1e-6
            && p.dot(c.cross(a)) * s >= -1e-6
    }

    #[test]
    fn spherical_triangle_samples_are_uniform_over_the_triangle() {
        let cases = [
            [Vec3::X, Vec3::Y, Vec3::Z],
            [
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(0.3, 0.0, 1.0).normalize(),
                Vec3::new(0.0, 0.2, 1.0).normalize(),
            ],
            [
                Vec3::new(-0.9, 0.1, 0.2).normalize(),
                Vec3::new(0.8, 0.3, 0.1).normalize(),
                Vec3::new(0.1, -0.2, 1.0).normalize(),
            ],
        ];
        let n = 64;
        for tri in cases {
            let [a, b, c] = tri;
            let total = spherical_triangle_area(a, b, c);
            let parts = subdivide(a, b, c);
            let mut counts = [0usize; 4];
            for i in 0..n {
                for j in 0..n {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    let w = square_to_spherical_triangle(a, b, c, u).unwrap();
                    assert!(
                        (w.length() - 1.0).abs() < 1e-4 && inside(w, tri),
                        "{w} outside {tri:?}"
                    );
                    let k = parts.iter().position(|p| inside(w, *p)).unwrap();
                    counts[k] += 1;
                }
            }
            // Each sub-triangle receives its share of the solid angle (a stratified grid of
            // samples: the error is far below 2% of the total).
            for (k, p) in parts.iter().enumerate() {
                let want = spherical_triangle_area(p[0], p[1], p[2]) / total;
                let got = counts[k] as f32 / (n * n) as f32;
                assert!(
                    (got - want).abs() < 0.02,
                    "{tri:?} part {k}: {got} vs {want}"
                );
            }
        }
        // The octant's solid angle is 4π/8.
        let octant = spherical_triangle_area(Vec3::X, Vec3::Y, Vec3::Z);
        assert!((octant - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    }
}
