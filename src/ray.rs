//! Rays and hits: what the scene's cameras make, what [`crate::accel::Accel`] traces and
//! answers, and the widths of the packets rays travel in. A leaf module, so that the scene
//! and the acceleration structure both use these types without knowing each other.

use glam::Vec3;

/// Camera rays per packet of [`crate::accel::Accel::intersect_packet`]: the 4 × 2 pixel
/// blocks of the renderer. Embree traces them with its 8-wide packet query.
pub const PACKET: usize = 8;

/// The most rays per call of [`crate::accel::Accel::occluded_packet`]. Embree's 16-wide
/// query traces the 16 AO rays of one point in 0.91× the time of two 8-wide ones
/// (BENCHMARKS.md), which are themselves faster than single rays; camera rays gain nothing
/// from 16 (measured).
pub const OCCLUSION_PACKET: usize = 16;

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

/// [`Hit::inst`] of a hit on a triangle that no instance places (one in world space).
pub const NO_INSTANCE: u32 = u32::MAX;

/// The closest intersection of a ray with the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Index of the triangle in the scene.
    pub prim: u32,
    /// The instance that placed the triangle ([`crate::scene::Instance`], an index into
    /// [`crate::scene::Scene::instances`]), or [`NO_INSTANCE`] for a triangle in world space.
    pub inst: u32,
    /// Barycentric coordinates of the hit point.
    pub u: f32,
    pub v: f32,
    /// Unit geometric normal on the counter-clockwise (front) side, in world space.
    pub ng: Vec3,
}
