//! The pure-Rust backend of [`super::Accel`]: a compressed wide BVH (CWBVH, Ylitie et al.
//! 2017) built by the `obvhs` crate (PLOC build, Meister & Bittner 2018), traversed by obvhs
//! with strata's own watertight-enough Möller–Trumbore test per triangle.
//!
//! The triangles are stored in the BVH's leaf order, so traversal reads them contiguously;
//! `ids` maps a leaf slot back to the scene's triangle index.
//!
//! Alpha coverage: where the scene has alpha-tested triangles, the per-triangle test rejects
//! a hit that [`AlphaCoverage::covers`] calls a hole, and the traversal goes on past it, as
//! Embree's filter callbacks make Embree do. Without them the traversal is the plain one.

use std::sync::Arc;
use std::time::Duration;

use glam::{Vec3, Vec3A};
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray as ORay, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use super::coverage::AlphaCoverage;
use super::{AccelMemory, AccelOptions, BuildQuality, Hit, Ray};
use crate::scene::Scene;

pub struct ObvhsAccel {
    bvh: CwBvh,
    /// Triangles in leaf order.
    tris: Vec<Triangle>,
    /// Scene triangle index of each leaf slot.
    ids: Vec<u32>,
    /// The box of the triangles' vertices.
    bounds: (Vec3, Vec3),
    /// The coverage of the alpha-tested triangles, if any.
    coverage: Option<Arc<AlphaCoverage>>,
}

/// Möller & Trumbore (1997): (t, u, v) of the ray's hit with triangle (v0, v1, v2), with
/// p = (1 − u − v)·v0 + u·v1 + v·v2, if the hit lies within [t_min, t_max].
#[inline(always)]
fn intersect_triangle(tri: &Triangle, ray: &ORay) -> Option<(f32, f32, f32)> {
    let e1 = tri.v1 - tri.v0;
    let e2 = tri.v2 - tri.v0;
    let pvec = ray.direction.cross(e2);
    let det = e1.dot(pvec);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let tvec = ray.origin - tri.v0;
    let u = tvec.dot(pvec) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qvec = tvec.cross(e1);
    let v = ray.direction.dot(qvec) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(qvec) * inv;
    (t >= ray.tmin && t <= ray.tmax).then_some((t, u, v))
}

impl ObvhsAccel {
    /// Builds the BVH of `scene`'s triangles, testing hits against `coverage` if given.
    pub fn build(
        scene: &Scene,
        options: &AccelOptions,
        coverage: Option<Arc<AlphaCoverage>>,
    ) -> ObvhsAccel {
        let tris: Vec<Triangle> = scene
            .triangles
            .iter()
            .map(|&[a, b, c]| Triangle {
                v0: Vec3A::from(scene.positions[a as usize]),
                v1: Vec3A::from(scene.positions[b as usize]),
                v2: Vec3A::from(scene.positions[c as usize]),
            })
            .collect();
        // obvhs's presets, by the trade-off its documentation gives them.
        let params = match options.quality {
            BuildQuality::Low => BvhBuildParams::fast_build(),
            BuildQuality::Medium => BvhBuildParams::medium_build(),
            BuildQuality::High => BvhBuildParams::slow_build(),
        };
        // No triangles: an empty hierarchy, which the queries below never traverse.
        let bvh = match tris.is_empty() {
            true => CwBvh::default(),
            false => build_cwbvh_from_tris(&tris, params, &mut Duration::default()),
        };
        let ids: Vec<u32> = bvh.primitive_indices.clone();
        let tris: Vec<Triangle> = ids.iter().map(|&i| tris[i as usize]).collect();
        let bounds = tris
            .iter()
            .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), t| {
                (
                    lo.min(t.v0).min(t.v1).min(t.v2),
                    hi.max(t.v0).max(t.v1).max(t.v2),
                )
            });
        ObvhsAccel {
            bvh,
            tris,
            ids,
            bounds: (bounds.0.into(), bounds.1.into()),
            coverage,
        }
    }

    /// The distance of the hit of `r` (the caller's `ray`, as obvhs takes it) with the
    /// triangle in leaf slot `slot`, or infinity for a miss or a hole.
    #[inline(always)]
    fn hit_distance(&self, slot: usize, r: &ORay, ray: &Ray, coverage: &AlphaCoverage) -> f32 {
        match intersect_triangle(&self.tris[slot], r) {
            // BLEND's coin reads the caller's ray (not obvhs's, whose −0 became +0), as
            // Embree's filter does.
            Some((t, u, v)) if coverage.covers(self.ids[slot], u, v, ray) => t,
            _ => f32::INFINITY,
        }
    }

    /// The box of the triangles' vertices.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    #[inline]
    fn ray(ray: &Ray) -> ORay {
        // −0 + +0 = +0: obvhs 0.4 picks a ray's octant by `d < 0` (so −0 counts as positive)
        // but inverts −0 to a large negative number, and the mismatch makes the traversal
        // miss everything along an axis-aligned ray with a −0 component (a top-down
        // orthographic camera, a transformed axis). Turning −0 into +0 keeps them agreeing.
        ORay::new(
            Vec3A::from(ray.org),
            Vec3A::from(ray.dir) + Vec3A::ZERO,
            ray.t_min,
            ray.t_max,
        )
    }

    // Out of line: inlined into `Accel`'s dispatch, the traversal stack would make every
    // Embree query pay for a large stack frame (docs/journal/benchmarks-2026-11.md, "The cost of
    // strata's own layers").
    #[inline(never)]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if self.tris.is_empty() {
            return None;
        }
        let r = Self::ray(ray);
        let mut hit = RayHit::none();
        let tris = &self.tris;
        let found = match &self.coverage {
            None => self.bvh.ray_traverse(r, &mut hit, |r, slot| {
                intersect_triangle(&tris[slot], r).map_or(f32::INFINITY, |(t, _, _)| t)
            }),
            Some(c) => self
                .bvh
                .ray_traverse(r, &mut hit, |r, slot| self.hit_distance(slot, r, ray, c)),
        };
        if !found {
            return None;
        }
        let slot = hit.primitive_id as usize;
        let tri = &self.tris[slot];
        // Barycentrics of the closest hit (one more triangle test, on the winner only).
        let mut exact = r;
        exact.tmax = hit.t;
        let (t, u, v) = intersect_triangle(tri, &exact).unwrap_or((hit.t, 0.0, 0.0));
        let ng = super::unit_normal(Vec3::from((tri.v1 - tri.v0).cross(tri.v2 - tri.v0)));
        Some(Hit {
            t,
            prim: self.ids[slot],
            u,
            v,
            ng,
        })
    }

    #[inline(never)]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if self.tris.is_empty() {
            return false;
        }
        let tris = &self.tris;
        !match &self.coverage {
            None => self.bvh.ray_traverse_miss(Self::ray(ray), |r, slot| {
                intersect_triangle(&tris[slot], r).map_or(f32::INFINITY, |(t, _, _)| t)
            }),
            Some(c) => self
                .bvh
                .ray_traverse_miss(Self::ray(ray), |r, slot| self.hit_distance(slot, r, ray, c)),
        }
    }

    pub fn memory(&self) -> AccelMemory {
        use std::mem::size_of_val;
        AccelMemory {
            geometry: size_of_val(self.tris.as_slice()) + size_of_val(self.ids.as_slice()),
            bvh: size_of_val(self.bvh.nodes.as_slice())
                + size_of_val(self.bvh.primitive_indices.as_slice()),
            build_peak: None,
        }
    }

    pub fn describe(&self) -> String {
        let alpha = match self.coverage.as_ref().map_or(0, |c| c.tested_triangles()) {
            0 => String::new(),
            n => format!(", {n} alpha-tested triangles"),
        };
        format!(
            "obvhs {} CWBVH ({} nodes){alpha}",
            "0.4",
            self.bvh.nodes.len()
        )
    }
}
