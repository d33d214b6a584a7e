//! strata: a CPU renderer for glTF 2.0 scenes. Embree traces the rays (through strata's own
//! FFI layer in [`embree`]); the light transport is Rust.
//!
//! Data flow: [`scene::load`] → [`scene::Scene`] → [`accel::Accel::build`] →
//! [`render::render`] (tiles on rayon, [`integrators`], [`sampling`]) → [`render::Film`] →
//! [`render::output`].

pub mod accel;
pub mod convergence;
pub mod embree;
pub mod integrators;
pub mod ray;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod shading;
