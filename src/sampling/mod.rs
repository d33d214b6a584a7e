//! Sample generation: per-pixel samplers, warps from the unit square to directions, and the
//! orthonormal basis that carries local directions to world space; and the χ² test that
//! checks samplers against their pdfs ([`chi2`]).

pub mod chi2;
pub mod hash;
pub mod onb;
pub mod sampler;
pub mod sobol;
pub mod warps;

pub use onb::Onb;
pub use sampler::{cmj_grid, PixelSampler, PointSet2d, SamplerKind};
