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
//!
//! Instances ([`crate::scene::Instance`]): each prototype has a BVH of its own triangles
//! ([`Blas`], the same as the world-space triangles', alpha coverage included: BLEND's coin
//! reads the world ray's key and the instance, as Embree's filter gets them), and a
//! top-level BVH over the instances' world boxes leads a ray to them; inside an instance the ray is carried into the
//! prototype's space by the inverse of its placement (an affine map leaves the ray's
//! parameter t unchanged, so distances compare across instances).

use std::sync::Arc;
use std::time::Duration;

use glam::{Affine3A, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::builder::{build_cwbvh, build_cwbvh_from_tris};
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray as ORay, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use super::coverage::{ray_key, AlphaCoverage};
use super::{AccelMemory, AccelOptions, BuildQuality, Hit, Ray};
use crate::scene::{Instance, Scene, NO_INSTANCE};

/// A BVH over some of a scene's triangles: the world-space ones, or one prototype's.
struct Blas {
    bvh: CwBvh,
    /// Triangles in leaf order.
    tris: Vec<Triangle>,
    /// Scene triangle index of each leaf slot.
    ids: Vec<u32>,
    /// The box of the triangles' vertices.
    bounds: (Vec3A, Vec3A),
}

impl Blas {
    /// The BVH of triangles `prims` of `scene`, as their vertices are stored.
    fn build(scene: &Scene, prims: &[u32], params: BvhBuildParams) -> Blas {
        let tris: Vec<Triangle> = prims
            .iter()
            .map(|&t| {
                let [a, b, c] = scene.triangles[t as usize];
                Triangle {
                    v0: Vec3A::from(scene.positions[a as usize]),
                    v1: Vec3A::from(scene.positions[b as usize]),
                    v2: Vec3A::from(scene.positions[c as usize]),
                }
            })
            .collect();
        // No triangles: an empty hierarchy, which the queries never traverse.
        let bvh = match tris.is_empty() {
            true => CwBvh::default(),
            false => build_cwbvh_from_tris(&tris, params, &mut Duration::default()),
        };
        let ids: Vec<u32> = bvh
            .primitive_indices
            .iter()
            .map(|&i| prims[i as usize])
            .collect();
        let tris: Vec<Triangle> = bvh
            .primitive_indices
            .iter()
            .map(|&i| tris[i as usize])
            .collect();
        let bounds = tris
            .iter()
            .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), t| {
                (
                    lo.min(t.v0).min(t.v1).min(t.v2),
                    hi.max(t.v0).max(t.v1).max(t.v2),
                )
            });
        Blas {
            bvh,
            tris,
            ids,
            bounds,
        }
    }

    /// The closest hit of `r` within its extent (alpha coverage tested against the caller's
    /// `ray`, where given): its leaf slot and distance.
    #[inline(always)]
    fn closest(&self, r: ORay, coverage: Option<Probe>) -> Option<(usize, f32)> {
        if self.tris.is_empty() {
            return None;
        }
        let mut hit = RayHit::none();
        let tris = &self.tris;
        let found = match coverage {
            None => self.bvh.ray_traverse(r, &mut hit, |r, slot| {
                intersect_triangle(&tris[slot], r).map_or(f32::INFINITY, |(t, _, _)| t)
            }),
            Some(probe) => self
                .bvh
                .ray_traverse(r, &mut hit, |r, slot| self.hit_distance(slot, r, probe)),
        };
        found.then_some((hit.primitive_id as usize, hit.t))
    }

    /// True when `r` meets a triangle within its extent (as [`Blas::closest`]).
    #[inline(always)]
    fn any(&self, r: ORay, coverage: Option<Probe>) -> bool {
        if self.tris.is_empty() {
            return false;
        }
        let tris = &self.tris;
        !match coverage {
            None => self.bvh.ray_traverse_miss(r, |r, slot| {
                intersect_triangle(&tris[slot], r).map_or(f32::INFINITY, |(t, _, _)| t)
            }),
            Some(probe) => self
                .bvh
                .ray_traverse_miss(r, |r, slot| self.hit_distance(slot, r, probe)),
        }
    }

    /// The distance of the hit of `r` with the triangle in leaf slot `slot`, or infinity for
    /// a miss or a hole (`probe`'s coverage at its ray key and instance).
    #[inline(always)]
    fn hit_distance(&self, slot: usize, r: &ORay, probe: Probe) -> f32 {
        match intersect_triangle(&self.tris[slot], r) {
            Some((t, u, v))
                if probe
                    .coverage
                    .covers(self.ids[slot], probe.inst, u, v, probe.key) =>
            {
                t
            }
            _ => f32::INFINITY,
        }
    }

    /// The hit of `r` with the triangle in `slot`, found at distance `t` by the traversal:
    /// its barycentrics (one more triangle test, on the winner only) and the unnormalized
    /// normal of the triangle as stored.
    #[inline(always)]
    fn hit(&self, slot: usize, t: f32, r: ORay) -> (f32, u32, f32, f32, Vec3A) {
        let tri = &self.tris[slot];
        let mut exact = r;
        exact.tmax = t;
        let (t, u, v) = intersect_triangle(tri, &exact).unwrap_or((t, 0.0, 0.0));
        (
            t,
            self.ids[slot],
            u,
            v,
            (tri.v1 - tri.v0).cross(tri.v2 - tri.v0),
        )
    }

    fn memory(&self) -> (usize, usize) {
        use std::mem::size_of_val;
        (
            size_of_val(self.tris.as_slice()) + size_of_val(self.ids.as_slice()),
            size_of_val(self.bvh.nodes.as_slice())
                + size_of_val(self.bvh.primitive_indices.as_slice()),
        )
    }
}

/// The instances of a scene's prototypes: a BVH over their world boxes (its leaf slot s holds
/// instance `primitive_indices[s]`), and each prototype's own BVH.
struct Tlas {
    bvh: CwBvh,
    prototypes: Vec<Blas>,
    instances: Arc<Vec<Instance>>,
    /// Each instance's map from world space to its prototype's.
    to_object: Vec<Affine3A>,
}

impl Tlas {
    fn build(scene: &Scene, params: BvhBuildParams) -> Tlas {
        let prototypes: Vec<Blas> = scene
            .prototypes
            .iter()
            .map(|p| {
                let prims: Vec<u32> = p.triangles.clone().collect();
                Blas::build(scene, &prims, params)
            })
            .collect();
        let boxes: Vec<Aabb> = scene
            .instances
            .iter()
            .map(|i| {
                let (lo, hi) = prototypes[i.prototype as usize].bounds;
                let (lo, hi) = i.world_box((lo.into(), hi.into()));
                Aabb::new(lo.into(), hi.into())
            })
            .collect();
        let bvh = match boxes.is_empty() {
            true => CwBvh::default(),
            false => build_cwbvh(&boxes, params, &mut Duration::default()),
        };
        Tlas {
            bvh,
            prototypes,
            instances: scene.instances.clone(),
            to_object: scene
                .instances
                .iter()
                .map(|i| i.to_world.inverse())
                .collect(),
        }
    }

    /// `r` in instance `k`'s prototype's space.
    #[inline(always)]
    fn local(&self, k: usize, r: &ORay) -> ORay {
        let m = &self.to_object[k];
        // −0 + +0 = +0, as in `ObvhsAccel::ray`.
        ORay::new(
            m.transform_point3a(r.origin),
            m.transform_vector3a(r.direction) + Vec3A::ZERO,
            r.tmin,
            r.tmax,
        )
    }

    #[inline(always)]
    fn blas(&self, k: usize) -> &Blas {
        &self.prototypes[self.instances[k].prototype as usize]
    }

    /// The closest hit of `r` on an instance (alpha coverage tested as [`Blas::closest`]
    /// says).
    fn intersect(&self, r: ORay, coverage: Option<Probe>) -> Option<Hit> {
        if self.instances.is_empty() {
            return None;
        }
        let mut hit = RayHit::none();
        // The instance and leaf slot of the closest hit so far: every distance the closure
        // returns is below the ray's current extent, so the traversal takes each one.
        let mut best = (0, 0);
        let found = self.bvh.ray_traverse(r, &mut hit, |r, slot| {
            let k = self.bvh.primitive_indices[slot] as usize;
            let coverage = coverage.map(|p| p.inside(k));
            match self.blas(k).closest(self.local(k, r), coverage) {
                Some((slot, t)) => {
                    best = (k, slot);
                    t
                }
                None => f32::INFINITY,
            }
        });
        if !found {
            return None;
        }
        let (k, slot) = best;
        let (t, prim, u, v, n) = self.blas(k).hit(slot, hit.t, self.local(k, &r));
        let ng = self.instances[k].normal_to_world * n;
        Some(Hit {
            t,
            prim,
            inst: k as u32,
            u,
            v,
            ng: super::unit_normal(ng.into()),
        })
    }

    /// True when `r` meets an instance.
    fn occluded(&self, r: ORay, coverage: Option<Probe>) -> bool {
        if self.instances.is_empty() {
            return false;
        }
        !self.bvh.ray_traverse_miss(r, |r, slot| {
            let k = self.bvh.primitive_indices[slot] as usize;
            let coverage = coverage.map(|p| p.inside(k));
            match self.blas(k).any(self.local(k, r), coverage) {
                true => f32::NEG_INFINITY,
                false => f32::INFINITY,
            }
        })
    }
}

/// What the alpha test of a hit reads beside the triangle: the coverage, the key of the
/// caller's ray (world space: not obvhs's copy, whose −0 became +0, nor an instance's local
/// ray), and the instance the triangle was reached through, as Embree's filter gets them.
#[derive(Clone, Copy)]
struct Probe<'a> {
    coverage: &'a AlphaCoverage,
    key: u32,
    inst: u32,
}

impl<'a> Probe<'a> {
    fn new(coverage: &'a AlphaCoverage, ray: &Ray) -> Probe<'a> {
        Probe {
            coverage,
            key: match coverage.blends() {
                true => ray_key(ray),
                false => 0,
            },
            inst: NO_INSTANCE,
        }
    }

    /// The probe for triangles of instance `k`.
    fn inside(self, k: usize) -> Probe<'a> {
        Probe {
            inst: k as u32,
            ..self
        }
    }
}

pub struct ObvhsAccel {
    /// The world-space triangles.
    flat: Blas,
    /// The prototypes and their instances, if the scene has any.
    placed: Option<Tlas>,
    /// The box of the triangles' vertices, instances' included.
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
        // obvhs's presets, by the trade-off its documentation gives them.
        let params = match options.quality {
            BuildQuality::Low => BvhBuildParams::fast_build(),
            BuildQuality::Medium => BvhBuildParams::medium_build(),
            BuildQuality::High => BvhBuildParams::slow_build(),
        };
        let prims: Vec<u32> = match scene.prototypes.is_empty() {
            true => (0..scene.triangles.len() as u32).collect(),
            false => scene.flat_triangles(),
        };
        let flat = Blas::build(scene, &prims, params);
        let placed = (!scene.prototypes.is_empty()).then(|| Tlas::build(scene, params));
        let (mut lo, mut hi) = flat.bounds;
        for (i, p) in placed
            .iter()
            .flat_map(|t| t.instances.iter().map(move |i| (i, t)))
        {
            let (a, b) = p.prototypes[i.prototype as usize].bounds;
            let (a, b) = i.world_box((a.into(), b.into()));
            (lo, hi) = (lo.min(a.into()), hi.max(b.into()));
        }
        ObvhsAccel {
            flat,
            placed,
            bounds: (lo.into(), hi.into()),
            coverage,
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
        let mut r = Self::ray(ray);
        let coverage = self.coverage.as_deref().map(|c| Probe::new(c, ray));
        let flat = self.flat.closest(r, coverage).map(|(slot, t)| {
            let (t, prim, u, v, n) = self.flat.hit(slot, t, r);
            Hit {
                t,
                prim,
                inst: NO_INSTANCE,
                u,
                v,
                ng: super::unit_normal(n.into()),
            }
        });
        let Some(placed) = &self.placed else {
            return flat;
        };
        if let Some(h) = &flat {
            r.tmax = h.t;
        }
        placed.intersect(r, coverage).or(flat)
    }

    #[inline(never)]
    pub fn occluded(&self, ray: &Ray) -> bool {
        let r = Self::ray(ray);
        let coverage = self.coverage.as_deref().map(|c| Probe::new(c, ray));
        self.flat.any(r, coverage)
            || self
                .placed
                .as_ref()
                .is_some_and(|p| p.occluded(r, coverage))
    }

    pub fn memory(&self) -> AccelMemory {
        let (mut geometry, mut bvh) = self.flat.memory();
        if let Some(p) = &self.placed {
            for b in &p.prototypes {
                let (g, n) = b.memory();
                (geometry, bvh) = (geometry + g, bvh + n);
            }
            geometry += std::mem::size_of_val(p.to_object.as_slice());
            bvh += std::mem::size_of_val(p.bvh.nodes.as_slice())
                + std::mem::size_of_val(p.bvh.primitive_indices.as_slice());
        }
        AccelMemory {
            geometry,
            bvh,
            build_peak: None,
        }
    }

    pub fn describe(&self) -> String {
        let alpha = match self.coverage.as_ref().map_or(0, |c| c.tested_triangles()) {
            0 => String::new(),
            n => format!(", {n} alpha-tested triangles"),
        };
        let instances = self.placed.as_ref().map_or(String::new(), |p| {
            super::instances_note(p.instances.len(), p.prototypes.len())
        });
        format!(
            "obvhs {} CWBVH ({} nodes){alpha}{instances}",
            "0.4",
            self.flat.bvh.nodes.len()
        )
    }
}
