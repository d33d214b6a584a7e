//! What one camera sample gives the film: the record an integrator fills in and the renderer
//! accumulates. It sits below both, so that neither imports the other for it.

use glam::{Vec3, Vec3A};

/// What one sample of a pixel estimates: the radiance along its camera ray and, when the
/// render keeps feature layers (the integrators' `Context::features`), what the ray's first
/// hit looks like (pbrt-v4's `VisibleSurface`, Mitsuba's AOVs): one record through one entry
/// point, `Integrator::li_packet`, so that passes and a denoiser need no second path.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampleRecord {
    /// The radiance estimate (in 16-byte lanes: a value stored as three floats and loaded
    /// as a pair and a float defeats store-to-load forwarding).
    pub l: Vec3A,
    /// The first hit's features; None for a ray that meets nothing, or when not asked for.
    pub features: Option<Features>,
    /// The camera ray's first hit's triangle and instance ([`FirstHit`]: its index in
    /// `Scene::triangles`, the hit's primitive id, and the hit's instance), which ID passes
    /// name by its glTF node, mesh and material; None for a ray that meets nothing, or when
    /// not asked for (`Context::ids`).
    pub triangle: Option<FirstHit>,
}

/// The first surface a camera ray meets, as feature layers describe it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Features {
    /// The reflectance of its BSDF (ρ for diffuse reflection; 1 for AO).
    pub albedo: Vec3,
    /// The unit shading normal in world space, on the side the camera sees.
    pub normal: Vec3,
    /// The distance from the camera ray's origin to the hit.
    pub depth: f32,
    /// The world-space point hit.
    pub position: Vec3,
    /// Its interpolated TEXCOORD_0 (zero where the scene has none).
    pub uv: glam::Vec2,
}

/// A pixel's first hit where its sample 0 met nothing, or has not been taken.
pub const NO_HIT: FirstHit = u64::MAX;

/// A first hit as the film keeps it: the triangle in the low 32 bits, the instance that placed
/// it (or [`crate::ray::NO_INSTANCE`]) in the high ones ([`first_hit`], [`split_first_hit`]).
pub type FirstHit = u64;

/// Triangle `prim` placed by instance `inst` as a [`FirstHit`].
#[inline]
pub fn first_hit(prim: u32, inst: u32) -> FirstHit {
    (inst as u64) << 32 | prim as u64
}

/// A [`FirstHit`]'s triangle and instance.
#[inline]
pub fn split_first_hit(h: FirstHit) -> (u32, u32) {
    (h as u32, (h >> 32) as u32)
}
