//! Surface points and the one way secondary rays leave them.
//!
//! The hit point is rebuilt from the triangle's vertices and barycentrics as
//! p₀ + b₁·(p₁ − p₀) + b₂·(p₂ − p₀), together with a conservative bound on its floating-point
//! error (γ₂·|p| + γ₄·(|b₁·(p₁ − p₀)| + |b₂·(p₂ − p₀)|); pbrt-v4 §6.8.5 interpolates
//! Σbᵢ·pᵢ, exact only to γ₇·Σ|bᵢ·pᵢ|). [`SurfaceInteraction::spawn_ray`] moves the origin along the
//! geometric normal just past that error bound, on the side the new ray leaves, and rounds
//! away from the surface (pbrt-v4 §6.8.6 `OffsetRayOrigin`). No epsilon in scene units: the
//! offset scales with the coordinates' magnitude, so a scene 10⁵ units from the origin shows
//! no acne and a small one loses no contact shadows.

use glam::Vec3;

use crate::accel::{Hit, Ray};
use crate::scene::Scene;

/// γₙ = n·ε / (1 − n·ε), ε = 2⁻²⁴ (pbrt-v4 eq. 6.34): the relative error bound of n
/// rounded float operations.
#[inline]
pub const fn gamma(n: i32) -> f32 {
    let e = n as f32 * (f32::EPSILON * 0.5);
    e / (1.0 - e)
}

/// A point on a surface seen along a ray.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceInteraction {
    pub p: Vec3,
    /// Per-axis absolute error bound of `p`, widened by the intersector's error (see
    /// [`SurfaceInteraction::from_hit`]).
    pub p_error: Vec3,
    /// Unit geometric normal, flipped to the side the ray came from.
    pub ng: Vec3,
    /// Unit shading normal (interpolated vertex normal, or `ng` for flat triangles), facing
    /// the side the ray came from (`ns · wo ≥ 0`).
    pub ns: Vec3,
    /// Unit direction back toward the ray's origin.
    pub wo: Vec3,
    /// True when the ray hit the counter-clockwise (front) face.
    pub front_face: bool,
    pub prim: u32,
    /// The instance that placed the triangle (`Hit::inst`).
    pub inst: u32,
    pub u: f32,
    pub v: f32,
}

impl SurfaceInteraction {
    /// Always inlined: called, it returns its 80 bytes through memory written a field at a
    /// time, and a caller that moves them on (the AO packet's array of hits) reads them back
    /// 16 bytes at a time, which store-to-load forwarding cannot serve (perf: a stall of
    /// 1.7% of a one-ray AO render).
    #[inline(always)]
    pub fn from_hit(scene: &Scene, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        // The corners as stored, placed by the hit's instance if it has one.
        let stored = scene.triangle_positions(hit.prim);
        let instance = scene.instances.get(hit.inst as usize);
        let [p0, p1, p2] = match instance {
            None => stored,
            Some(i) => stored.map(|q| i.to_world.transform_point3(q)),
        };
        let (b1, b2) = (hit.u, hit.v);
        // p = p0 + b1·(p1 − p0) + b2·(p2 − p0): the edge terms are small next to p0 when the
        // triangle is far from the origin, so p is within about half an ulp of |p| of the
        // exact point (the pbrt form b0·p0 + b1·p1 + b2·p2 rounds three terms of size |p|:
        // up to γ₇·|p|, several ulps). A floor point a hair right of a wall standing at a
        // representable x then never rounds to the wall's left (tests/stress_numerics.rs:
        // the light leak at a wall's foot 10³–10⁵ units from the origin).
        let (e1, e2) = (p1 - p0, p2 - p0);
        let (d1, d2) = (b1 * e1, b2 * e2);
        let p = p0 + (d1 + d2);
        // Its error: the final sum's rounding, γ₁·|p| (γ₂ for margin), and the edge terms'
        // (subtraction, product, sum: γ₃, γ₄ for margin). Embree's ray–triangle test computes
        // t from vertex-minus-origin differences, whose rounding grows with the triangle's
        // extent around p: a second, isotropic term keeps the spawned origin beyond that
        // error too (without it a ray leaving a large triangle can report a hit on it at
        // t ≈ 0).
        let extent = (p0 - p)
            .abs()
            .max((p1 - p).abs())
            .max((p2 - p).abs())
            .max_element();
        let mut p_error =
            gamma(2) * p.abs() + gamma(4) * (d1.abs() + d2.abs()) + Vec3::splat(gamma(7) * extent);
        // An instance's vertices were placed by its affine map M·q + t: three products and
        // three sums per coordinate, off by at most γ₃·(|M|·|q| + |t|) each (γ₄ for margin).
        if let Some(i) = instance {
            let q = stored.iter().fold(Vec3::ZERO, |m, q| m.max(q.abs()));
            let m = &i.to_world;
            let abs = glam::Mat3::from_cols(
                m.matrix3.x_axis.abs().into(),
                m.matrix3.y_axis.abs().into(),
                m.matrix3.z_axis.abs().into(),
            );
            p_error += gamma(4) * (abs * q + Vec3::from(m.translation.abs()));
        }
        let front_face = hit.ng.dot(ray.dir) < 0.0;
        let ng = if front_face { hit.ng } else { -hit.ng };
        // Two-sided shading: the shading normal faces the side the ray arrives from. Where
        // an interpolated normal disagrees with the geometry (grazing views of smooth
        // silhouettes) it may then point below the geometric surface; directions sampled
        // around it enter the object, as in Mitsuba's `twosided` BSDF.
        let ns = match scene.placed_shading_normal(hit.prim, hit.inst, b1, b2) {
            Some(n) if n.dot(ray.dir) > 0.0 => -n,
            Some(n) => n,
            None => ng,
        };
        SurfaceInteraction {
            p,
            p_error,
            ng,
            ns,
            wo: -ray.dir.normalize(),
            front_face,
            prim: hit.prim,
            inst: hit.inst,
            u: b1,
            v: b2,
        }
    }

    /// A shadow ray from the surface toward the point `target` (already offset off its own
    /// surface, if it has one): `dir` spans the whole segment, `t_max` stops just short.
    #[inline]
    pub fn spawn_ray_to(&self, target: Vec3) -> Ray {
        self.spawn_ray_to_with(target, true)
    }

    /// A ray leaving the surface in direction `dir`, reaching up to `t_max`.
    #[inline]
    pub fn spawn_ray(&self, dir: Vec3, t_max: f32) -> Ray {
        self.spawn_ray_with(dir, t_max, true)
    }

    /// [`Self::spawn_ray_to`], or with `ray_offset = false` the same ray from the hit point
    /// itself (no error-bound offset): a deliberately wrong mode that shows self-intersection
    /// ("acne"), kept so tests can prove they detect it (see `experiments::Experiments::ray_offset`).
    #[inline(always)]
    pub fn spawn_ray_to_with(&self, target: Vec3, ray_offset: bool) -> Ray {
        let org = self.origin(target - self.p, ray_offset);
        Ray {
            org,
            dir: target - org,
            t_min: 0.0,
            t_max: 1.0 - SHADOW_EPSILON,
        }
    }

    /// [`Self::spawn_ray`], or with `ray_offset = false` from the hit point itself (see
    /// [`Self::spawn_ray_to_with`]).
    #[inline]
    pub fn spawn_ray_with(&self, dir: Vec3, t_max: f32, ray_offset: bool) -> Ray {
        Ray {
            org: self.origin(dir, ray_offset),
            dir,
            t_min: 0.0,
            t_max,
        }
    }

    /// The origins of rays leaving into the hemisphere around `ng` (the side the ray came
    /// from), computed once for many rays from this point, such as the AO rays of a hit:
    /// [`FrontOrigins::ray`] gives [`Self::spawn_ray_with`]'s ray for each such direction.
    #[inline]
    pub fn front_origins(&self, ray_offset: bool) -> FrontOrigins {
        FrontOrigins {
            // `origin` for a direction with w·ng > 0 (any such w gives the same point) ...
            above: self.origin(self.ng, ray_offset),
            // ... and for one in the tangent plane, which takes no step back along wo.
            tangent: if ray_offset {
                offset_origin(self.p, self.p_error, self.ng, self.ng, Vec3::ZERO)
            } else {
                self.p
            },
            ng: self.ng,
        }
    }

    /// [`Self::spawn_ray_with`]'s origin for a direction `w` with w·ng ≥ 0 (leaving on the side
    /// the ray came from), without branches on `w`: for rays whose directions are a coin toss
    /// and are checked apart, such as the AO rays of a packet of camera hits. For w·ng < 0
    /// the point is not that origin, and the caller must discard the ray.
    #[inline(always)]
    pub fn front_origin(&self, w: Vec3, ray_offset: bool) -> Vec3 {
        if !ray_offset {
            return self.p;
        }
        // `wo` for w·ng > 0, and a zero (of either sign, which `offset_origin` reads alike) in
        // the tangent plane; the offset goes along +ng for both, as `origin` sends it.
        let back = self.wo * (w.dot(self.ng) > 0.0) as u8 as f32;
        offset_origin(self.p, self.p_error, self.ng, self.ng, back)
    }

    /// The origin of a ray leaving toward `w`: past the error bound, or `p` itself when
    /// `ray_offset` is false (one predictable branch; the default path always takes the first).
    ///
    /// A ray leaving on the side it arrived from is also moved one ulp back along `wo` on the
    /// axes where that does not move it toward the surface (see [`offset_origin`]). A hit
    /// point can round exactly onto a second surface (a floor point at the foot of a wall far
    /// from the origin lands in the wall's plane); the offset along this surface's normal
    /// leaves it in that plane, and a ray from there can cross the wall at t = 0 and see the
    /// wall's other side. The incoming segment is free of surfaces, so a point toward it is on
    /// the correct side of both.
    #[inline(always)]
    fn origin(&self, w: Vec3, ray_offset: bool) -> Vec3 {
        if ray_offset {
            let back = if w.dot(self.ng) > 0.0 {
                self.wo
            } else {
                Vec3::ZERO
            };
            offset_origin(self.p, self.p_error, self.ng, w, back)
        } else {
            self.p
        }
    }
}

/// Ray origins for directions in the hemisphere around a surface point's `ng` (see
/// [`SurfaceInteraction::front_origins`]).
#[derive(Clone, Copy, Debug)]
pub struct FrontOrigins {
    above: Vec3,
    tangent: Vec3,
    ng: Vec3,
}

impl FrontOrigins {
    /// The ray leaving toward `dir`, which must satisfy dir·ng ≥ 0, reaching up to `t_max`.
    #[inline]
    pub fn ray(&self, dir: Vec3, t_max: f32) -> Ray {
        debug_assert!(dir.dot(self.ng) >= 0.0, "{dir} leaves below the surface");
        Ray {
            org: if dir.dot(self.ng) > 0.0 {
                self.above
            } else {
                self.tangent
            },
            dir,
            t_min: 0.0,
            t_max,
        }
    }
}

/// Shadow rays toward a point stop this fraction short of it (pbrt-v4's `ShadowEpsilon`),
/// relative to the ray's length, so the target surface itself is not reported.
pub const SHADOW_EPSILON: f32 = 1e-4;

/// Moves `p` along `n` past its error bound, to the side of `w`, and rounds the result away
/// from `p` so the offset survives rounding (pbrt-v4 §6.8.6).
#[inline]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    offset_origin(p, p_error, n, w, Vec3::ZERO)
}

/// [`offset_ray_origin`], then one more ulp toward `back` on every axis where `back` has a
/// component and the normal offset either has none or has the same sign, so the extra step
/// never moves the point back toward the surface (`back = 0`: none). Each coordinate moves
/// by a whole number of ulps in one step.
///
/// Branch-free integer arithmetic on each axis: this runs three times per path vertex (the
/// shadow ray, the light point, the extension ray).
#[inline(always)]
pub fn offset_origin(p: Vec3, p_error: Vec3, n: Vec3, w: Vec3, back: Vec3) -> Vec3 {
    let d = n.abs().dot(p_error);
    let mut offset = d * n;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let po = p + offset;
    let (po, offset, back) = (po.to_array(), offset.to_array(), back.to_array());
    Vec3::from_array(std::array::from_fn(|i| {
        step_axis(po[i], offset[i], back[i])
    }))
}

/// The last step of [`offset_origin`] on one axis: `po` (the point already offset by
/// `offset`) moved one ulp along the offset, and one toward `back` where the offset is zero
/// or agrees with it. Branch-free, so that a loop of it over lanes becomes SIMD code.
#[inline(always)]
pub fn step_axis(po: f32, offset: f32, back: f32) -> f32 {
    let (so, sb) = (sign(offset), sign(back));
    let toward_back = (so == 0) | (so == sb);
    step_ulps(po, so + sb * toward_back as i32)
}

/// −1, 0 or 1 (0 for ±0 and NaN).
#[inline(always)]
fn sign(v: f32) -> i32 {
    (v > 0.0) as i32 - (v < 0.0) as i32
}

/// Moves a finite `v` by `k` ulps, toward +∞ for k > 0 (crossing zero through the
/// denormals), without branches: floats are mapped to integers in the same order, with ±0
/// both at 0.
#[inline(always)]
fn step_ulps(v: f32, k: i32) -> f32 {
    const MAG: i32 = 0x7fff_ffff;
    // Sign-magnitude to two's complement: s is −1 for a set sign bit, 0 otherwise, and
    // (i ^ (s & MAG)) − s is −magnitude for negative floats and i for the others.
    let i = v.to_bits() as i32;
    let s = i >> 31;
    let moved = (i ^ (s & MAG)).wrapping_sub(s).wrapping_add(k);
    // And back: for moved < 0 (t = −1), (moved − 1) ^ MAG sets the sign bit over −moved.
    let t = moved >> 31;
    f32::from_bits((moved.wrapping_add(t) ^ (t & MAG)) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_ulps_matches_next_up_and_next_down() {
        let values = [
            0.0f32,
            -0.0,
            f32::from_bits(1),
            -f32::from_bits(1),
            1.0,
            -1.0,
            1e-38,
            -3.5e7,
            123_456.79,
            f32::MIN_POSITIVE,
        ];
        for v in values {
            assert_eq!(step_ulps(v, 0), v, "{v}");
            assert_eq!(step_ulps(v, 1), v.next_up(), "{v} up");
            assert_eq!(step_ulps(v, -1), v.next_down(), "{v} down");
            assert_eq!(step_ulps(v, 2), v.next_up().next_up(), "{v} up 2");
            assert_eq!(step_ulps(v, -2), v.next_down().next_down(), "{v} down 2");
        }
    }

    /// The lane-wise offset against the same rule written axis by axis with branches and
    /// `next_up`/`next_down`, on random points, normals, directions and `back` vectors, with
    /// components that are exactly ±0 mixed in.
    #[test]
    fn offset_origin_matches_the_rule_axis_by_axis() {
        fn by_hand(p: Vec3, p_error: Vec3, n: Vec3, w: Vec3, back: Vec3) -> Vec3 {
            let d = n.abs().dot(p_error);
            let offset = if w.dot(n) < 0.0 { -(d * n) } else { d * n };
            let po = p + offset;
            let mut out = po;
            for i in 0..3 {
                let mut k = 0;
                for (c, agrees) in [
                    (offset[i], true),
                    (
                        back[i],
                        offset[i] == 0.0 || (offset[i] > 0.0) == (back[i] > 0.0),
                    ),
                ] {
                    if c > 0.0 && agrees {
                        k += 1;
                    } else if c < 0.0 && agrees {
                        k -= 1;
                    }
                }
                if out[i] == 0.0 {
                    out[i] = 0.0; // ±0 both map to the integer 0, and come back as +0
                }
                for _ in 0..k.max(0) {
                    out[i] = out[i].next_up();
                }
                for _ in 0..(-k).max(0) {
                    out[i] = out[i].next_down();
                }
            }
            out
        }
        let mut uniform = crate::sampling::hash::uniform_sequence(29);
        let mut next = |zeros: bool| {
            let u = uniform();
            if zeros && u < 0.15 {
                if u < 0.075 {
                    0.0
                } else {
                    -0.0
                }
            } else {
                2.0 * uniform() - 1.0
            }
        };
        let mut moved_back = 0;
        for _ in 0..50_000 {
            let scale = [1e-30f32, 1e-3, 1.0, 1e4, 1e7][(next(false).abs() * 4.99) as usize];
            let p = Vec3::new(next(true), next(true), next(true)) * scale;
            let p_error = Vec3::new(next(false), next(false), next(false)).abs() * scale * 1e-6;
            let n = Vec3::new(next(true), next(true), next(true));
            let w = Vec3::new(next(false), next(false), next(false));
            let back = Vec3::new(next(true), next(true), next(true));
            let got = offset_origin(p, p_error, n, w, back);
            let want = by_hand(p, p_error, n, w, back);
            assert_eq!(
                got.to_array().map(f32::to_bits),
                want.to_array().map(f32::to_bits),
                "p {p:?} err {p_error:?} n {n:?} w {w:?} back {back:?}"
            );
            moved_back += (got != offset_ray_origin(p, p_error, n, w)) as u32;
        }
        assert!(
            moved_back > 10_000,
            "{moved_back} points took the step toward back"
        );
    }

    /// FrontOrigins gives spawn_ray_with's rays bit for bit, for directions above the
    /// surface and exactly in its tangent plane, with and without the offset.
    #[test]
    fn front_origins_give_the_rays_of_spawn_ray() {
        let mut uniform = crate::sampling::hash::uniform_sequence(11);
        let mut next = || 2.0 * uniform() - 1.0;
        let mut tangent_rays = 0;
        for _ in 0..20_000 {
            let ng = Vec3::new(next(), next(), next()).normalize();
            let wo = (ng + 0.9 * Vec3::new(next(), next(), next())).normalize();
            let si = SurfaceInteraction {
                p: Vec3::new(next(), next(), next()) * 1e4,
                p_error: Vec3::new(next(), next(), next()).abs() * 1e-3,
                ng,
                ns: ng,
                wo,
                front_face: true,
                prim: 0,
                inst: crate::ray::NO_INSTANCE,
                u: 0.0,
                v: 0.0,
            };
            let mut w = Vec3::new(next(), next(), next()).normalize();
            if w.dot(ng) < 0.0 {
                w = -w;
            }
            // A direction exactly in the tangent plane: ng's components permuted so the dot
            // product is exactly zero.
            let tangent = Vec3::new(ng.y, -ng.x, 0.0);
            for offset in [true, false] {
                let origins = si.front_origins(offset);
                for (dir, t_max) in [(w, f32::INFINITY), (tangent, 3.5)] {
                    if dir.dot(ng) == 0.0 {
                        tangent_rays += 1;
                    }
                    let want = si.spawn_ray_with(dir, t_max, offset);
                    assert_eq!(
                        si.front_origin(dir, offset).to_array(),
                        want.org.to_array(),
                        "ng {ng} dir {dir} offset {offset}"
                    );
                    let got = origins.ray(dir, t_max);
                    assert_eq!(
                        (got.org.to_array(), got.dir, got.t_min, got.t_max),
                        (want.org.to_array(), want.dir, want.t_min, want.t_max),
                        "ng {ng} dir {dir} offset {offset}"
                    );
                }
            }
        }
        assert!(tangent_rays > 10_000, "{tangent_rays} tangent rays tested");
    }

    #[test]
    fn the_step_back_along_wo_never_moves_toward_the_surface() {
        // A tilted plane through p: the origin must be at least as far from it as the plain
        // offset is, for any incoming direction on the same side.
        let p = Vec3::new(1000.0, 20.0, -300.0);
        let n = Vec3::new(0.6, 0.8, 0.0);
        let err = gamma(7) * p.abs() * 3.0;
        let w = Vec3::new(0.1, 0.9, 0.3).normalize();
        let plain = offset_ray_origin(p, err, n, w);
        for back in [
            Vec3::new(-0.99, 0.1, 0.0),
            Vec3::new(0.5, 0.5, -0.7),
            Vec3::new(-0.3, 0.2, 0.9),
            Vec3::new(0.0, 1.0, 0.0),
        ] {
            let back = back.normalize();
            let o = offset_origin(p, err, n, w, back);
            let dist = |q: Vec3| (q.as_dvec3() - p.as_dvec3()).dot(n.as_dvec3());
            assert!(
                dist(o) >= dist(plain),
                "back {back}: {} < {}",
                dist(o),
                dist(plain)
            );
            // And every axis moved by at most one ulp more than the plain offset.
            for i in 0..3 {
                let (a, b) = (plain[i].to_bits() as i64, o[i].to_bits() as i64);
                assert!((a - b).abs() <= 1, "axis {i}: {} vs {}", plain[i], o[i]);
            }
        }
        // An axis the normal offset leaves alone moves toward back.
        let floor = offset_origin(p, err, Vec3::Y, w, Vec3::new(-0.5, 0.5, 0.7));
        assert_eq!(floor.x, p.x.next_down());
        assert_eq!(floor.z, p.z.next_up());
    }

    #[test]
    fn offset_points_leave_the_plane_on_the_requested_side() {
        // Points on the plane y = c of a unit-sized triangle at many magnitudes: the offset
        // origin must be strictly on the side of w, and within a few thousand ulps of the
        // coordinates (plus the triangle-extent term of from_hit).
        for c in [0.0f32, 1e-3, 1.0, 1e3, 1e5, 1e6] {
            let p = Vec3::new(c, c, c);
            let extent = 1.0;
            let err = gamma(7) * (p.abs() * 3.0 + Vec3::splat(extent));
            let n = Vec3::Y;
            let up = offset_ray_origin(p, err, n, Vec3::new(0.3, 0.9, 0.1));
            let down = offset_ray_origin(p, err, n, Vec3::new(0.3, -0.9, 0.1));
            assert!(up.y > c && down.y < c, "c={c}: {up} {down}");
            assert_eq!((up.x, up.z), (c, c), "only the normal's axis moves");
            let scale = c.abs() + extent;
            assert!(
                (up.y - c) / scale < 1e-5,
                "offset too large at {c}: {}",
                up.y - c
            );
        }
    }
}
