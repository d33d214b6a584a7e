//! The path tracer of [`super::path`] for a packet of camera hits at once: its paths advance
//! together, one bounce at a time, with the arithmetic of each bounce done four paths at a
//! time in `Vec4` lanes (structure of arrays: the x, y and z of a quantity are three `Vec4`s).
//! Paths that have ended stay in their lanes, masked out.
//!
//! Each lane performs the float operations of [`super::path::li`] in the same order, so the
//! estimates are the scalar ones bit for bit: SSE's element-wise add, sub, mul, div, sqrt,
//! min and max round as the scalar operations do, and glam's scalar `max`/`min` pick their
//! operands as `maxps`/`minps` do. What stays scalar per lane: the rays traced, the vertex
//! and material lookups, the sampler's draws and the light choice.
//!
//! Only the common case is handled (see [`supported`]); the caller falls back to
//! [`super::path::li`] otherwise.
//!
//! On the Cornell box this takes 5% off the instructions and about 10% off the time on one
//! thread (4% on two); Embree's share, about 40%, is untouched, and compacting the live paths
//! across packets could take at most another 3.5% off. BENCHMARKS.md, "Path tracing in SIMD
//! lanes", has the measurements and what was tried.

use std::f32::consts::FRAC_1_PI;
use std::ops::{Add, Div, Mul, Neg, Sub};

use glam::{BVec4A, Vec2, Vec3, Vec3A, Vec4};

use super::{Context, Hemisphere, PathSettings, RayCounts, Strategy};
use crate::accel::{Hit, Ray, OCCLUSION_PACKET, PACKET};
use crate::interaction::{gamma, step_axis, SHADOW_EPSILON};
use crate::sampling::warps::square_to_cosine_hemisphere_x4;
use crate::sampling::PixelSampler;

/// Whether [`li_lanes`] shades this context's packets: the context asks for lanes
/// ([`Context::path_lanes`]), and the settings and lights are the case it handles: MIS with
/// cosine-weighted directions, paired and jointly stratified bounces, offset ray origins,
/// and emissive triangles (sampled by area) as the only emitters.
pub fn supported(ctx: &Context, settings: &PathSettings) -> bool {
    ctx.path_lanes
        && settings.strategy == Strategy::Mis
        && settings.hemisphere == Hemisphere::Cosine
        && settings.paired_bounces
        && settings.joint_bounces
        && ctx.ray_offset
        && ctx.lights.only_area_triangles()
}

/// Three coordinates of four lanes.
#[derive(Clone, Copy, Debug)]
struct V3 {
    x: Vec4,
    y: Vec4,
    z: Vec4,
}

impl V3 {
    const ZERO: V3 = V3 {
        x: Vec4::ZERO,
        y: Vec4::ZERO,
        z: Vec4::ZERO,
    };
    const ONE: V3 = V3 {
        x: Vec4::ONE,
        y: Vec4::ONE,
        z: Vec4::ONE,
    };

    #[inline(always)]
    fn from_lanes(v: &[Vec3; 4]) -> V3 {
        V3 {
            x: Vec4::new(v[0].x, v[1].x, v[2].x, v[3].x),
            y: Vec4::new(v[0].y, v[1].y, v[2].y, v[3].y),
            z: Vec4::new(v[0].z, v[1].z, v[2].z, v[3].z),
        }
    }

    #[inline(always)]
    fn lane(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    /// (x·x' + y·y') + z·z', as glam's `Vec3::dot`.
    #[inline(always)]
    fn dot(self, o: V3) -> Vec4 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline(always)]
    fn abs(self) -> V3 {
        V3 {
            x: self.x.abs(),
            y: self.y.abs(),
            z: self.z.abs(),
        }
    }

    #[inline(always)]
    fn max(self, o: V3) -> V3 {
        V3 {
            x: self.x.max(o.x),
            y: self.y.max(o.y),
            z: self.z.max(o.z),
        }
    }

    /// max(x, max(y, z)), as glam's `Vec3::max_element`.
    #[inline(always)]
    fn max_element(self) -> Vec4 {
        self.x.max(self.y.max(self.z))
    }

    #[inline(always)]
    fn select(mask: BVec4A, a: V3, b: V3) -> V3 {
        V3 {
            x: Vec4::select(mask, a.x, b.x),
            y: Vec4::select(mask, a.y, b.y),
            z: Vec4::select(mask, a.z, b.z),
        }
    }
}

impl Add for V3 {
    type Output = V3;
    #[inline(always)]
    fn add(self, o: V3) -> V3 {
        V3 {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
}

impl Sub for V3 {
    type Output = V3;
    #[inline(always)]
    fn sub(self, o: V3) -> V3 {
        V3 {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
}

impl Mul for V3 {
    type Output = V3;
    #[inline(always)]
    fn mul(self, o: V3) -> V3 {
        V3 {
            x: self.x * o.x,
            y: self.y * o.y,
            z: self.z * o.z,
        }
    }
}

/// Each lane's vector times that lane's scalar (products commute exactly).
impl Mul<Vec4> for V3 {
    type Output = V3;
    #[inline(always)]
    fn mul(self, s: Vec4) -> V3 {
        V3 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}

impl Div<Vec4> for V3 {
    type Output = V3;
    #[inline(always)]
    fn div(self, s: Vec4) -> V3 {
        V3 {
            x: self.x / s,
            y: self.y / s,
            z: self.z / s,
        }
    }
}

impl Neg for V3 {
    type Output = V3;
    #[inline(always)]
    fn neg(self) -> V3 {
        V3 {
            x: -self.x,
            y: -self.y,
            z: -self.z,
        }
    }
}

#[inline(always)]
fn mask(bits: [bool; 4]) -> BVec4A {
    BVec4A::new(bits[0], bits[1], bits[2], bits[3])
}

#[inline(always)]
fn test(m: BVec4A, i: usize) -> bool {
    m.bitmask() & (1 << i) != 0
}

/// The power heuristic of [`super::path`], lane by lane.
#[inline(always)]
fn power_heuristic(pdf_f: Vec4, pdf_g: Vec4) -> Vec4 {
    let (f, g) = (pdf_f * pdf_f, pdf_g * pdf_g);
    let s = f + g;
    Vec4::select(s.cmpeq(Vec4::ZERO), Vec4::ZERO, f / s)
}

/// `crate::interaction::offset_origin`, lane by lane: `p` moved along `n` past `err` to the
/// side of `w`, then by whole ulps (one more toward `back` where that does not move it back).
#[inline(always)]
fn offset_origin(p: V3, err: V3, n: V3, w: V3, back: V3) -> V3 {
    let d = n.abs().dot(err);
    let offset = n * d;
    let offset = V3::select(w.dot(n).cmplt(Vec4::ZERO), -offset, offset);
    let po = p + offset;
    V3 {
        x: step_ulps4(po.x, offset.x, back.x),
        y: step_ulps4(po.y, offset.y, back.y),
        z: step_ulps4(po.z, offset.z, back.z),
    }
}

/// One coordinate of four lanes of `offset_origin`'s last step
/// ([`crate::interaction::step_axis`]), over plain arrays for the compiler to put in integer
/// lanes.
#[inline(always)]
fn step_ulps4(po: Vec4, o: Vec4, back: Vec4) -> Vec4 {
    let (po, o, back) = (po.to_array(), o.to_array(), back.to_array());
    Vec4::from_array(std::array::from_fn(|i| step_axis(po[i], o[i], back[i])))
}

/// Four paths' state between bounces.
struct Group {
    /// Lanes whose path goes on, with the hit its last ray found.
    live: BVec4A,
    hits: [Option<Hit>; 4],
    dir: V3,
    /// Sampler index of each lane (lanes past the packet's end: unused).
    sampler: [usize; 4],
    /// Which `l` entry each lane writes, for the first `n` lanes.
    out: [usize; 4],
    n: usize,
    l: V3,
    beta: V3,
    has_prev: BVec4A,
    prev_pdf: Vec4,
    prev_p: V3,
    u_light: [Vec2; 4],
    /// Lanes whose next-event estimate awaits its shadow ray's answer, and the estimates.
    shade: BVec4A,
    pending: V3,
}

/// The shadow rays of one bounce of the packet's paths, traced together.
struct Shadows {
    rays: [Ray; PACKET],
    n: usize,
}

/// [`super::path::li`] for every camera hit of a packet (`rays[k]` with closest hit
/// `hits[k]`, sampled by `samplers[lanes[k]]`, estimate into `l[k]`). Only for
/// [`supported`] settings; counts the camera rays too.
#[allow(clippy::too_many_arguments)]
pub fn li_lanes(
    ctx: &Context,
    rays: &[Ray],
    hits: &[Option<Hit>],
    samplers: &mut [PixelSampler],
    lanes: &[usize],
    settings: &PathSettings,
    counts: &mut RayCounts,
    l: &mut [Vec3A],
) {
    debug_assert!(supported(ctx, settings));
    counts.camera += rays.len() as u64;
    let mut groups: [Option<Group>; PACKET / 4] = Default::default();
    for (g, group) in groups.iter_mut().enumerate() {
        let k0 = 4 * g;
        if k0 >= rays.len() {
            break;
        }
        let n = (rays.len() - k0).min(4);
        let lane_hits: [Option<Hit>; 4] =
            std::array::from_fn(|i| if i < n { hits[k0 + i] } else { None });
        let dirs: [Vec3; 4] = std::array::from_fn(|i| rays[k0 + i.min(n - 1)].dir);
        *group = Some(Group {
            live: mask(std::array::from_fn(|i| lane_hits[i].is_some())),
            hits: lane_hits,
            dir: V3::from_lanes(&dirs),
            sampler: std::array::from_fn(|i| lanes[k0 + i.min(n - 1)]),
            out: std::array::from_fn(|i| k0 + i.min(n - 1)),
            n,
            l: V3::ZERO,
            beta: V3::ONE,
            has_prev: BVec4A::FALSE,
            prev_pdf: Vec4::ZERO,
            prev_p: V3::ZERO,
            u_light: [Vec2::ZERO; 4],
            shade: BVec4A::FALSE,
            pending: V3::ZERO,
        });
    }
    let mut depth = 0;
    loop {
        let mut any = false;
        let mut shadow = Shadows {
            rays: [Ray::new(Vec3::ZERO, Vec3::Z); PACKET],
            n: 0,
        };
        for group in groups.iter_mut().flatten() {
            group.shade = BVec4A::FALSE;
            if group.live.any() {
                bounce(ctx, group, depth, samplers, settings, counts, &mut shadow);
                any |= group.live.any();
            }
        }
        // The next-event estimates whose shadow rays are unoccluded, added after the
        // emission their vertex found, as `path::li` adds them.
        if shadow.n > 0 {
            counts.shadow += shadow.n as u64;
            let mut occluded = [false; OCCLUSION_PACKET];
            ctx.accel
                .occluded_packet(&shadow.rays[..shadow.n], &mut occluded);
            let mut next = 0;
            for group in groups.iter_mut().flatten() {
                let mut visible = [false; 4];
                for (i, visible) in visible.iter_mut().enumerate() {
                    if test(group.shade, i) {
                        *visible = !occluded[next];
                        next += 1;
                    }
                }
                group.l = V3::select(mask(visible), group.l + group.pending, group.l);
            }
        }
        if !any || depth == settings.max_depth {
            break;
        }
        depth += 1;
    }
    for group in groups.iter().flatten() {
        for (i, &k) in group.out[..group.n].iter().enumerate() {
            l[k] = group.l.lane(i).into();
        }
    }
}

/// Shades the vertices the group's live paths reached (their `depth`-th bounce's hits): the
/// emission found, and for `depth` < `max_depth` the next event (its shadow rays into
/// `shadow`, its estimates left pending in the group) and the next direction, whose hits
/// it leaves in the group.
fn bounce(
    ctx: &Context,
    group: &mut Group,
    depth: u32,
    samplers: &mut [PixelSampler],
    settings: &PathSettings,
    counts: &mut RayCounts,
    shadow: &mut Shadows,
) {
    let (scene, lights, materials) = (ctx.scene, ctx.lights, ctx.materials);
    let live = group.live;
    // Gathers: each live lane's triangle, its vertex normals and hit.
    let mut p = [[Vec3::ZERO; 4]; 3];
    let mut nv = [[Vec3::ZERO; 4]; 3];
    let mut hit_ng = [Vec3::ZERO; 4];
    let (mut bu, mut bv) = ([0f32; 4], [0f32; 4]);
    let mut prim = [0u32; 4];
    for (i, hit) in group.hits.iter().enumerate() {
        let Some(hit) = hit else { continue };
        let [a, b, c] = scene.triangles[hit.prim as usize];
        for (j, v) in [a, b, c].into_iter().enumerate() {
            p[j][i] = scene.positions[v as usize];
            nv[j][i] = scene.normals[v as usize];
        }
        hit_ng[i] = hit.ng;
        (bu[i], bv[i], prim[i]) = (hit.u, hit.v, hit.prim);
    }
    let (p0, p1, p2) = (
        V3::from_lanes(&p[0]),
        V3::from_lanes(&p[1]),
        V3::from_lanes(&p[2]),
    );
    let (b1, b2) = (Vec4::from_array(bu), Vec4::from_array(bv));
    let hit_ng = V3::from_lanes(&hit_ng);
    let dir = group.dir;

    // The surface interaction (`SurfaceInteraction::from_hit`).
    let (e1, e2) = (p1 - p0, p2 - p0);
    let (d1, d2) = (e1 * b1, e2 * b2);
    let pos = p0 + (d1 + d2);
    let extent = (p0 - pos)
        .abs()
        .max((p1 - pos).abs())
        .max((p2 - pos).abs())
        .max_element();
    let g2 = Vec4::splat(gamma(2));
    let g4 = Vec4::splat(gamma(4));
    let g7e = Vec4::splat(gamma(7)) * extent;
    let p_error = pos.abs() * g2
        + (d1.abs() + d2.abs()) * g4
        + V3 {
            x: g7e,
            y: g7e,
            z: g7e,
        };
    let front = hit_ng.dot(dir).cmplt(Vec4::ZERO);
    let ng = V3::select(front, hit_ng, -hit_ng);
    let w0 = Vec4::ONE - b1 - b2;
    let n = V3::from_lanes(&nv[0]) * w0 + V3::from_lanes(&nv[1]) * b1 + V3::from_lanes(&nv[2]) * b2;
    let len2 = n.dot(n);
    let smooth = len2.cmpgt(Vec4::splat(1e-12)) & len2.cmplt(Vec4::INFINITY);
    let n = n / len2.sqrt();
    let n = V3::select(n.dot(dir).cmpgt(Vec4::ZERO), -n, n);
    let ns = V3::select(smooth, n, ng);
    let wo = -(dir * (Vec4::ONE / dir.dot(dir).sqrt()));

    // Emission reached, weighted against light sampling unless the camera sees it.
    let front_bits = front.bitmask();
    let mut le = [Vec3::ZERO; 4];
    let mut uv = [Vec2::ZERO; 4];
    let mut pmf_area = [(0f32, 0f32); 4];
    for i in 0..4 {
        if test(live, i) {
            uv[i] = materials.uv_at(scene, prim[i], bu[i], bv[i]);
            le[i] = materials.emitted_by(scene, prim[i], front_bits & (1 << i) != 0, uv[i]);
            if le[i].max_element() > 0.0 {
                pmf_area[i] = lights.triangle_pmf_area(prim[i]);
            }
        }
    }
    let le = V3::from_lanes(&le);
    let camera = if settings.camera_emission {
        BVec4A::TRUE
    } else {
        BVec4A::FALSE
    };
    let emits = live & le.max_element().cmpgt(Vec4::ZERO) & (group.has_prev | camera);
    if emits.any() {
        let pmf = Vec4::new(pmf_area[0].0, pmf_area[1].0, pmf_area[2].0, pmf_area[3].0);
        let area = Vec4::new(pmf_area[0].1, pmf_area[1].1, pmf_area[2].1, pmf_area[3].1);
        let d = pos - group.prev_p;
        let dist2 = d.dot(d);
        let cos = (hit_ng.dot(d) / dist2.sqrt()).abs();
        let none = cos.cmple(Vec4::ZERO) | area.cmple(Vec4::ZERO);
        let pdf_light = Vec4::select(none, Vec4::ZERO, pmf * dist2 / (cos * area));
        let w = Vec4::select(
            group.has_prev,
            power_heuristic(group.prev_pdf, pdf_light),
            Vec4::ONE,
        );
        group.l = V3::select(emits, group.l + group.beta * le * w, group.l);
    }
    if depth == settings.max_depth {
        group.live = BVec4A::FALSE;
        return;
    }
    let depth = depth + 1;

    // The BSDF: albedo per lane, the frame around the shading normal in lanes.
    let mut albedo = [Vec3::ZERO; 4];
    let mut u_bsdf = [Vec2::splat(0.5); 4];
    let mut u_next = [Vec2::ZERO; 4];
    let mut u_rr = [1f32; 4];
    let mut light = [None; 4];
    for i in 0..4 {
        if !test(live, i) {
            continue;
        }
        albedo[i] = materials.albedo_of(scene, prim[i], uv[i]);
        // The bounce's slots, in the order `path::li` draws them.
        let sampler = &mut samplers[group.sampler[i]];
        if depth == 1 {
            group.u_light[i] = sampler.paired_with_film();
        }
        (u_bsdf[i], u_next[i]) = sampler.next_bounce_2x2d(depth);
        u_rr[i] = if depth >= settings.rr_depth {
            sampler.next_1d()
        } else {
            sampler.skip_slot();
            1.0
        };
        light[i] = lights.choose_triangle(group.u_light[i]);
    }
    let albedo = V3::from_lanes(&albedo);
    let sign = Vec4::ONE.copysign(ns.z);
    let a = Vec4::splat(-1.0) / (sign + ns.z);
    let b = ns.x * ns.y * a;
    let t = V3 {
        x: Vec4::ONE + sign * ns.x * ns.x * a,
        y: sign * b,
        z: -sign * ns.x,
    };
    let bb = V3 {
        x: b,
        y: sign + ns.y * ns.y * a,
        z: -ns.y,
    };
    // f·cos and the pdf of direction `wi` (`Lambertian::f_cos`, `Lambertian::pdf`).
    let f_pdf = |wi: V3| {
        let cos = wi.dot(ns);
        let zero = cos.cmple(Vec4::ZERO) | wi.dot(ng).cmple(Vec4::ZERO);
        let c = cos * Vec4::splat(FRAC_1_PI);
        (
            V3::select(zero, V3::ZERO, albedo * c),
            Vec4::select(zero, Vec4::ZERO, c),
        )
    };

    // Next-event estimation: a point on the chosen triangle, sampled by area.
    let mut tv = [[Vec3::ZERO; 4]; 3];
    let (mut tn, mut terr) = ([Vec3::ZERO; 4], [Vec3::ZERO; 4]);
    let (mut tarea, mut tpmf) = ([0f32; 4], [0f32; 4]);
    let (mut ux, mut uy) = ([0f32; 4], [0f32; 4]);
    let mut chosen = [false; 4];
    for (i, light) in light.iter().enumerate() {
        if let Some((t, pmf, u)) = light {
            [tv[0][i], tv[1][i], tv[2][i]] = t.vertices;
            (tn[i], terr[i]) = (t.normal, t.point_error);
            (tarea[i], tpmf[i]) = (t.area, *pmf);
            (ux[i], uy[i]) = (u.x, u.y);
            chosen[i] = true;
        }
    }
    let (area, pmf) = (Vec4::from_array(tarea), Vec4::from_array(tpmf));
    let (ux, uy) = (Vec4::from_array(ux), Vec4::from_array(uy));
    let s = ux.sqrt();
    let q0 = Vec4::ONE - s;
    let q1 = (uy * s).min(Vec4::ONE - q0);
    let q2 = Vec4::ONE - q0 - q1;
    let q = V3::from_lanes(&tv[0]) * q0 + V3::from_lanes(&tv[1]) * q1 + V3::from_lanes(&tv[2]) * q2;
    let tn = V3::from_lanes(&tn);
    let d = q - pos;
    let dist2 = d.dot(d);
    let dist = dist2.sqrt();
    let wi = d / dist;
    let cos_l = tn.dot(-wi);
    let sampled = live
        & mask(chosen)
        & area.cmpgt(Vec4::ZERO)
        & dist.cmpgt(Vec4::ZERO)
        & cos_l.cmpne(Vec4::ZERO);
    let p_light = offset_origin(q, V3::from_lanes(&terr), tn, -wi, V3::ZERO);
    let ls_pdf = dist2 / (cos_l.abs() * area);
    let cos_front = cos_l.cmpgt(Vec4::ZERO).bitmask();
    let mut li = [Vec3::ZERO; 4];
    for i in 0..4 {
        if test(sampled, i) {
            let prim = light[i].map_or(0, |(t, _, _)| t.prim);
            let bary = Vec2::new(q1[i], q2[i]);
            li[i] = materials.emitted_at(scene, prim, bary, cos_front & (1 << i) != 0);
        }
    }
    let li = V3::from_lanes(&li);
    let (f, pdf_bsdf) = f_pdf(wi);
    let shade = sampled
        & ls_pdf.cmpgt(Vec4::ZERO)
        & li.max_element().cmpgt(Vec4::ZERO)
        & f.max_element().cmpgt(Vec4::ZERO);
    if shade.any() {
        let pdf_light = pmf * ls_pdf;
        let w = power_heuristic(pdf_light, pdf_bsdf);
        // The shadow ray (`SurfaceInteraction::spawn_ray_to_with`).
        let to = p_light - pos;
        let back = V3::select(to.dot(ng).cmpgt(Vec4::ZERO), wo, V3::ZERO);
        let org = offset_origin(pos, p_error, ng, to, back);
        let sdir = p_light - org;
        group.pending = group.beta * f * li * (w / pdf_light);
        group.shade = shade;
        for i in 0..4 {
            if test(shade, i) {
                shadow.rays[shadow.n] = Ray {
                    org: org.lane(i),
                    dir: sdir.lane(i),
                    t_min: 0.0,
                    t_max: 1.0 - SHADOW_EPSILON,
                };
                shadow.n += 1;
            }
        }
    }

    // The BSDF direction: the cosine warp and the frame in lanes.
    let ub_x = Vec4::new(u_bsdf[0].x, u_bsdf[1].x, u_bsdf[2].x, u_bsdf[3].x);
    let ub_y = Vec4::new(u_bsdf[0].y, u_bsdf[1].y, u_bsdf[2].y, u_bsdf[3].y);
    let (lx, ly, lz) = square_to_cosine_hemisphere_x4(ub_x, ub_y);
    let wi = t * lx + bb * ly + ns * lz;
    let (f, pdf) = f_pdf(wi);
    let mut live = live & pdf.cmpgt(Vec4::ZERO);
    let beta = group.beta * (f / pdf);
    live &= !beta.max_element().cmple(Vec4::ZERO);
    let beta = if depth >= settings.rr_depth {
        // Russian roulette.
        let q = beta.max_element().min(Vec4::splat(0.95));
        live &= !Vec4::from_array(u_rr).cmpge(q);
        beta / q
    } else {
        beta
    };
    group.beta = beta;
    group.has_prev = BVec4A::TRUE;
    group.prev_pdf = pdf;
    group.prev_p = pos;
    group.u_light = u_next;
    // The extension rays (`SurfaceInteraction::spawn_ray_with`).
    let back = V3::select(wi.dot(ng).cmpgt(Vec4::ZERO), wo, V3::ZERO);
    let org = offset_origin(pos, p_error, ng, wi, back);
    for i in 0..4 {
        group.hits[i] = None;
        if test(live, i) {
            counts.extension += 1;
            let ray = Ray {
                org: org.lane(i),
                dir: wi.lane(i),
                t_min: 0.0,
                t_max: f32::INFINITY,
            };
            group.hits[i] = ctx.accel.intersect(&ray);
        }
    }
    group.dir = wi;
    group.live = mask(std::array::from_fn(|i| group.hits[i].is_some()));
}
