//! strata: a CPU renderer for glTF 2.0 scenes. Embree traces the rays (through strata's own
//! FFI layer in [`embree`]); the light transport is Rust.
//!
//! Data flow: [`scene::load`] → [`scene::Scene`] → [`accel::Accel::build`] →
//! [`render::render`] (tiles on rayon, [`integrators`], [`sampling`]) → [`render::Film`] →
//! [`render::output`].

/// `Display` for an option enum that derives `clap::ValueEnum`: a value prints as the name
/// the command line takes for it (`TriangleSampling::SolidAngle` as `solid-angle`), so the
/// EXR headers, the reports and the tools name settings the way the command line spells them.
macro_rules! display_as_value_name {
    ($t:ty) => {
        impl std::fmt::Display for $t {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                match clap::ValueEnum::to_possible_value(self) {
                    Some(value) => f.write_str(value.get_name()),
                    None => write!(f, "{self:?}"),
                }
            }
        }
    };
}
pub(crate) use display_as_value_name;

pub mod accel;
pub mod cli;
pub mod convergence;
pub mod denoise;
pub mod embree;
pub mod experiments;
pub mod integrators;
pub mod job;
pub mod lanes;
pub mod math;
pub mod plot;
pub mod ray;
pub mod record;
pub mod render;
pub mod report;
pub mod sampling;
pub mod scene;
pub mod shading;
pub mod texture;
