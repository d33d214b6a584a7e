//! Integrators: estimators of the radiance arriving along a camera ray.
//!
//! A closed set dispatched by `match`. Each takes the primary ray and the pixel sample's
//! [`PixelSampler`], draws its dimensions in a fixed order, and returns one estimate.

pub mod ao;

use glam::Vec3;
use std::fmt;
use std::str::FromStr;

use crate::accel::{Accel, Ray};
use crate::sampling::PixelSampler;
use crate::scene::Scene;

pub use ao::{AoSettings, Hemisphere};

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    pub camera: u64,
    /// Shadow and ambient-occlusion rays (any-hit queries).
    pub occlusion: u64,
}

impl RayCounts {
    pub fn total(&self) -> u64 {
        self.camera + self.occlusion
    }

    pub fn add(&mut self, other: &RayCounts) {
        self.camera += other.camera;
        self.occlusion += other.occlusion;
    }
}

/// Which integrator renders the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum IntegratorKind {
    #[default]
    Ao,
}

impl FromStr for IntegratorKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "ao" => Ok(IntegratorKind::Ao),
            "direct" | "path" => Err(format!(
                "integrator '{s}' is not implemented yet (available: ao)"
            )),
            other => Err(format!("unknown integrator '{other}' (available: ao)")),
        }
    }
}

impl fmt::Display for IntegratorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            IntegratorKind::Ao => "ao",
        })
    }
}

/// An integrator with its settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Integrator {
    Ao(AoSettings),
}

impl Integrator {
    pub fn kind(&self) -> IntegratorKind {
        match self {
            Integrator::Ao(_) => IntegratorKind::Ao,
        }
    }

    /// One estimate of the radiance along the camera ray `ray`.
    #[inline]
    pub fn li(
        &self,
        scene: &Scene,
        accel: &Accel,
        ray: &Ray,
        sampler: &mut PixelSampler,
        rays: &mut RayCounts,
    ) -> Vec3 {
        match self {
            Integrator::Ao(settings) => {
                Vec3::splat(ao::li(scene, accel, ray, sampler, settings, rays))
            }
        }
    }
}
