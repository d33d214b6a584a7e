//! Sample generation: per-pixel samplers, warps from the unit square to directions, and the
//! orthonormal basis that carries local directions to world space.

pub mod hash;
pub mod onb;
pub mod sampler;
pub mod sobol;
pub mod warps;

pub use onb::Onb;
pub use sampler::{cmj_grid, PixelSampler, PointSet2d, SamplerKind};
