//! Ray–scene intersection, independent of the BVH library behind it.
//!
//! [`Accel`] is the only type the renderer traces rays through. It answers two queries:
//! [`Accel::intersect`] (closest hit: distance, primitive, barycentrics, geometric normal) and
//! [`Accel::occluded`] (is there any hit within the ray's extent). Primitive ids are indices
//! into [`crate::scene::Scene::triangles`]; barycentrics follow p = (1 − u − v)·p0 + u·p1 + v·p2;
//! the geometric normal is normalize((p1 − p0) × (p2 − p0)), the front side of a
//! counter-clockwise triangle. Integrators never see backend types.
//!
//! Backends form a closed set, dispatched by `match` (no virtual calls in the ray loop).

mod embree_backend;
mod obvhs_backend;

use glam::{Vec3, Vec3A};
use std::fmt;
use std::str::FromStr;

use crate::scene::Scene;

pub use crate::embree::{OCCLUSION_PACKET, PACKET};
pub use embree_backend::EmbreeAccel;
pub use obvhs_backend::ObvhsAccel;

/// A ray segment `org + t·dir`, t in `[t_min, t_max]`.
///
/// The field order matches Embree's `RTCRay` in 16-byte groups (origin and t_min, then
/// direction), so building an `RTCRay` from it is two whole-vector copies: Embree reads the
/// ray with 16-byte loads, and a load that straddles several smaller stores stalls.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct Ray {
    pub org: Vec3,
    pub t_min: f32,
    pub dir: Vec3,
    pub t_max: f32,
}

impl Ray {
    pub fn new(org: Vec3, dir: Vec3) -> Ray {
        Ray {
            org,
            dir,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.org + t * self.dir
    }
}

/// A box around all of a scene's triangles, for telling cheaply that a ray cannot hit any
/// of them: camera rays that miss the scene's bounds then need no traversal.
#[derive(Clone, Copy, Debug)]
pub struct SceneBox {
    lo: Vec3A,
    hi: Vec3A,
    /// The box's largest coordinate magnitude.
    scale: f32,
}

impl SceneBox {
    /// The box of the triangles in `accel` ([`Accel::bounds`]).
    pub fn new(accel: &Accel) -> SceneBox {
        let (lo, hi) = accel.bounds();
        let (lo, hi) = (Vec3A::from(lo), Vec3A::from(hi));
        SceneBox {
            lo,
            hi,
            scale: lo.abs().max(hi.abs()).max_element(),
        }
    }

    /// True only when `ray` meets no point of the box within [t_min, t_max]: a slab test
    /// (Kay and Kajiya 1986) against the box widened by 32 ulps of the largest coordinate
    /// magnitude among the box and the ray's origin. The test's own rounding moves the
    /// points it compares by a few of those ulps, so a ray that grazes a triangle on the
    /// box's faces, edges or corners is never called a miss (tests/scene_box.rs). A NaN
    /// anywhere (an origin on a widened slab's plane with a direction parallel to it, a
    /// non-finite ray) answers false: the ray is traced.
    #[inline]
    pub fn misses(&self, ray: &Ray) -> bool {
        let org = Vec3A::from(ray.org);
        let margin = Vec3A::splat(32.0 * f32::EPSILON * self.scale.max(org.abs().max_element()));
        let inv = Vec3A::ONE / Vec3A::from(ray.dir);
        let t0 = (self.lo - margin - org) * inv;
        let t1 = (self.hi + margin - org) * inv;
        if (t0.is_nan_mask() | t1.is_nan_mask()).any() {
            return false;
        }
        let near = t0.min(t1).max_element().max(ray.t_min);
        let far = t0.max(t1).min_element().min(ray.t_max);
        near > far
    }

    /// The box's corners, as [`Accel::bounds`] gave them (not widened).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.lo.into(), self.hi.into())
    }

    /// True when every ray of `rays` [`misses`](SceneBox::misses) the box: a packet that
    /// needs no traversal.
    #[inline]
    pub fn misses_all(&self, rays: &[Ray]) -> bool {
        rays.iter().all(|r| self.misses(r))
    }
}

/// The closest intersection of a ray with the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Index of the triangle in the scene.
    pub prim: u32,
    /// Barycentric coordinates of the hit point.
    pub u: f32,
    pub v: f32,
    /// Unit geometric normal on the counter-clockwise (front) side.
    pub ng: Vec3,
}

/// `n / |n|`, or zero for a zero (or non-finite) `n`. |n|² overflows f32 for a cross product
/// above 1.8e19 (triangles with edges of ~4e9 units) and flushes to zero below 1.1e-19 under
/// FTZ/DAZ (edges of ~3e-10): outside a safe range of |n|², `n` is scaled by its largest
/// component first. Inside it, one square root and one division (a normal per hit: the
/// scaling's three divisions were 5% of a Cornell box render).
#[inline]
pub(crate) fn unit_normal(n: Vec3) -> Vec3 {
    let len2 = n.length_squared();
    if (1e-30..=1e30).contains(&len2) {
        n * (1.0 / len2.sqrt())
    } else {
        (n / n.abs().max_element()).normalize_or_zero()
    }
}

/// Which BVH library traces the rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    Embree,
    /// The pure-Rust CWBVH of the `obvhs` crate.
    Obvhs,
}

impl FromStr for Backend {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "embree" => Ok(Backend::Embree),
            "obvhs" => Ok(Backend::Obvhs),
            other => Err(format!(
                "unknown backend '{other}' (available: embree, obvhs)"
            )),
        }
    }
}

impl fmt::Display for Backend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Backend::Embree => "embree",
            Backend::Obvhs => "obvhs",
        })
    }
}

/// BVH build quality, shared by every backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BuildQuality {
    Low,
    #[default]
    Medium,
    High,
}

impl FromStr for BuildQuality {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "low" => Ok(BuildQuality::Low),
            "medium" => Ok(BuildQuality::Medium),
            "high" => Ok(BuildQuality::High),
            other => Err(format!("unknown BVH quality '{other}' (low, medium, high)")),
        }
    }
}

/// Options for building an [`Accel`].
#[derive(Clone, Copy, Debug)]
pub struct AccelOptions {
    pub backend: Backend,
    pub quality: BuildQuality,
    /// Worker threads for the BVH build (0: all cores).
    pub threads: usize,
    /// Watertight traversal (Embree's `RTC_SCENE_FLAG_ROBUST`); on by default.
    pub robust: bool,
}

impl Default for AccelOptions {
    fn default() -> Self {
        AccelOptions {
            backend: Backend::Embree,
            quality: BuildQuality::default(),
            threads: 0,
            robust: true,
        }
    }
}

/// Memory an [`Accel`] holds after its build, in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AccelMemory {
    /// The backend's copy of the triangles (Embree's vertex and index buffers; obvhs's
    /// leaf-ordered triangles and their ids).
    pub geometry: usize,
    /// The hierarchy itself: nodes and leaves (Embree's leaves hold their own copies of the
    /// vertices), as the backend reports it.
    pub bvh: usize,
    /// The most the backend held at once during the build, scratch memory included, where
    /// it reports it (Embree's memory monitor; obvhs does not).
    pub build_peak: Option<usize>,
}

/// An error while building the acceleration structure.
#[derive(Debug, thiserror::Error)]
pub enum AccelError {
    #[error("the scene has no triangles to build a BVH over")]
    Empty,
    #[error(transparent)]
    Embree(#[from] crate::embree::EmbreeError),
}

/// The acceleration structure of a scene.
pub enum Accel {
    Embree(EmbreeAccel),
    Obvhs(ObvhsAccel),
}

impl Accel {
    /// Builds the acceleration structure over every triangle of `scene`.
    pub fn build(scene: &Scene, options: &AccelOptions) -> Result<Accel, AccelError> {
        if scene.triangles.is_empty() {
            return Err(AccelError::Empty);
        }
        match options.backend {
            Backend::Embree => Ok(Accel::Embree(EmbreeAccel::build(scene, options)?)),
            Backend::Obvhs => Ok(Accel::Obvhs(ObvhsAccel::build(scene, options))),
        }
    }

    /// The closest hit along the ray within `[t_min, t_max]`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        match self {
            Accel::Embree(a) => a.intersect(ray),
            Accel::Obvhs(a) => a.intersect(ray),
        }
    }

    /// The closest hits of up to [`PACKET`] rays (`hits[i]` for `rays[i]`; the rest `None`):
    /// one packet query with Embree, which pays on coherent rays such as the camera rays of
    /// neighbouring pixels; one query per ray with obvhs. The answers are those of
    /// [`Accel::intersect`] ray by ray, but at exact ties (a ray meeting an edge shared by two
    /// triangles), where either triangle may be reported.
    #[inline]
    pub fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<Hit>; PACKET]) {
        match self {
            Accel::Embree(a) => a.intersect_packet(rays, hits),
            Accel::Obvhs(a) => {
                for (i, hit) in hits.iter_mut().enumerate() {
                    *hit = rays.get(i).and_then(|r| a.intersect(r));
                }
            }
        }
    }

    /// Any-hit answers for up to [`OCCLUSION_PACKET`] rays (`occluded[i]` for `rays[i]`): one
    /// query with Embree (a single-ray one for one ray, else a packet), one query per ray with
    /// obvhs.
    #[inline]
    pub fn occluded_packet(&self, rays: &[Ray], occluded: &mut [bool; OCCLUSION_PACKET]) {
        match self {
            Accel::Embree(a) => a.occluded_packet(rays, occluded),
            Accel::Obvhs(a) => {
                for (o, r) in occluded.iter_mut().zip(rays) {
                    *o = a.occluded(r);
                }
            }
        }
    }

    /// True when any surface lies along the ray within `[t_min, t_max]`.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        match self {
            Accel::Embree(a) => a.occluded(ray),
            Accel::Obvhs(a) => a.occluded(ray),
        }
    }

    /// The Embree backend, if this is one.
    pub fn as_embree(&self) -> Option<&EmbreeAccel> {
        match self {
            Accel::Embree(a) => Some(a),
            _ => None,
        }
    }

    /// A box around every triangle the structure holds (the BVH's own, so it is right even
    /// when a scene's `bounds` were not brought up to date).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match self {
            Accel::Embree(a) => a.bounds(),
            Accel::Obvhs(a) => a.bounds(),
        }
    }

    /// The memory the structure holds.
    pub fn memory(&self) -> AccelMemory {
        match self {
            Accel::Embree(a) => a.memory(),
            Accel::Obvhs(a) => a.memory(),
        }
    }

    /// A one-line description of the backend (library and version).
    pub fn describe(&self) -> String {
        match self {
            Accel::Embree(a) => a.describe(),
            Accel::Obvhs(a) => a.describe(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unit length and the right direction for normals of every magnitude a scene can give
    /// (cross products of edges from 1e-12 to 1e12 units, both sides of the fast path's
    /// range), and zero for degenerate or non-finite ones.
    #[test]
    fn unit_normals_of_any_magnitude() {
        for dir in [
            Vec3::new(0.3, -0.5, 0.8),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(-2e-3, 7.0, 1e-4),
        ] {
            let want = dir.as_dvec3().normalize();
            for e in (-24..=24).step_by(3) {
                let n = dir * 10f32.powi(e);
                let u = unit_normal(n);
                let err = (u.as_dvec3() - want).length();
                assert!(err < 1e-6, "{n:?}: {u:?} is {err} from {want:?}");
            }
        }
        assert_eq!(unit_normal(Vec3::ZERO), Vec3::ZERO);
        assert_eq!(unit_normal(Vec3::new(f32::NAN, 1.0, 0.0)), Vec3::ZERO);
        assert_eq!(unit_normal(Vec3::new(f32::INFINITY, 1.0, 0.0)), Vec3::ZERO);
    }
}
