//! The environment: the radiance a ray that leaves the scene sees, as a function of its
//! direction, and how light sampling draws directions toward it.
//!
//! A constant (`--background R,G,B`, black by default) or an equirectangular HDR map
//! (`--env FILE`, [`EnvMap`]). Callers ask by direction only, so nothing outside this module
//! assumes a constant: the renderer's shortcuts for camera rays that miss (block culling,
//! [`crate::integrators::Integrator::camera_miss`]) ask [`Environment::constant`] first and
//! trace where it answers None.

use std::sync::Arc;

use glam::{Vec2, Vec3};

use super::envmap::EnvMap;
use super::spectrum::luminance;
use crate::sampling::warps::square_to_uniform_sphere;

/// Radiance arriving from infinitely far away, by direction.
#[derive(Clone, Debug, PartialEq)]
pub enum Environment {
    /// The same radiance from every direction (black: no environment).
    Constant(Vec3),
    /// An equirectangular map, importance-sampled.
    Map(Arc<EnvMap>),
}

impl Default for Environment {
    fn default() -> Environment {
        Environment::Constant(Vec3::ZERO)
    }
}

impl Environment {
    /// The radiance seen along unit direction `dir` (from the scene toward the environment).
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        match self {
            Environment::Constant(l) => *l,
            Environment::Map(map) => map.radiance(dir),
        }
    }

    /// The radiance, where it is the same in every direction.
    #[inline]
    pub fn constant(&self) -> Option<Vec3> {
        match self {
            Environment::Constant(l) => Some(*l),
            Environment::Map(_) => None,
        }
    }

    /// True when no direction sees any radiance.
    #[inline]
    pub fn is_black(&self) -> bool {
        match self {
            Environment::Constant(l) => l.max_element() <= 0.0,
            Environment::Map(map) => map.is_black(),
        }
    }

    /// A direction toward the environment drawn with 2D point `u`, its radiance and its
    /// solid-angle pdf: uniform over the sphere for a constant.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, Vec3, f32) {
        match self {
            Environment::Constant(l) => (square_to_uniform_sphere(u), *l, UNIFORM_SPHERE_PDF),
            Environment::Map(map) => map.sample(u),
        }
    }

    /// The radiance along unit direction `dir` and the solid-angle pdf with which
    /// [`Environment::sample`] draws it, from one lookup.
    #[inline]
    pub fn radiance_pdf(&self, dir: Vec3) -> (Vec3, f32) {
        match self {
            Environment::Constant(l) => (*l, UNIFORM_SPHERE_PDF),
            Environment::Map(map) => map.radiance_pdf(dir),
        }
    }

    /// The solid-angle pdf with which [`Environment::sample`] draws `dir`.
    #[inline]
    pub fn pdf(&self, dir: Vec3) -> f32 {
        match self {
            Environment::Constant(_) => UNIFORM_SPHERE_PDF,
            Environment::Map(map) => map.pdf(dir),
        }
    }

    /// The power it sends into a scene bounded by a sphere of `radius`, by luminance, for
    /// choosing among emitters: π·L·(area of the sphere's disc, πr²) from every direction of
    /// the sphere, 4π·π·r²·L (at least a tiny positive value, so that it can be chosen).
    pub fn power(&self, radius: f32) -> f64 {
        let pi = std::f64::consts::PI;
        let mean = match self {
            Environment::Constant(l) => luminance(*l),
            Environment::Map(map) => map.mean_luminance(),
        };
        4.0 * pi * pi * (radius.max(1e-3) as f64).powi(2) * mean.max(1e-6) as f64
    }
}

/// 1/(4π): the density of directions uniform over the sphere.
const UNIFORM_SPHERE_PDF: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_environment_is_the_same_everywhere_and_sampled_uniformly() {
        let env = Environment::Constant(Vec3::new(0.5, 1.0, 2.0));
        assert_eq!(env.constant(), Some(Vec3::new(0.5, 1.0, 2.0)));
        assert!(!env.is_black() && Environment::default().is_black());
        let mut seen_up = false;
        for i in 0..64 {
            let u = Vec2::new((i % 8) as f32 / 8.0 + 0.06, (i / 8) as f32 / 8.0 + 0.06);
            let (dir, l, pdf) = env.sample(u);
            assert!((dir.length() - 1.0).abs() < 1e-5);
            assert_eq!(l, env.radiance(dir));
            assert_eq!(pdf, env.pdf(dir));
            assert!((pdf * 4.0 * std::f32::consts::PI - 1.0).abs() < 1e-6);
            seen_up |= dir.y > 0.5;
        }
        assert!(seen_up);
    }
}
