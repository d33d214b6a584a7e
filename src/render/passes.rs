//! Render passes: the first-hit features the film sums beside the beauty
//! ([`Film::keep_features`]), written as layers of the same EXR under OpenEXR's `layer.channel`
//! names, which OpenImageIO, Blender's compositor and Nuke read as layers.
//!
//! | pass     | channels                          | each pixel                                   |
//! |----------|-----------------------------------|----------------------------------------------|
//! | `albedo` | `albedo.R`, `albedo.G`, `albedo.B` | the mean over its samples of the first hit's BSDF reflectance, through perfect mirrors to what they show (a miss adds 0) |
//! | `normal` | `normal.X`, `normal.Y`, `normal.Z` | the mean of the first hit's world-space shading normal, on the side the camera sees (a miss adds 0; not renormalised) |
//! | `depth`  | `depth.Z`                          | the mean distance from the camera to the first hit over the samples that hit; `inf` where none did |
//! | `position` | `position.X`, `position.Y`, `position.Z` | the mean world-space point hit, over the samples that hit; 0 where none did |
//! | `uv`     | `uv.U`, `uv.V`                      | the mean TEXCOORD_0 at the hit, over the samples that hit; 0 where none did (or the scene has none) |
//!
//! Every pass is averaged over the pixel's samples like the beauty, so a pixel on an
//! object's outline holds a blend of both sides (what a denoiser expects of its auxiliary
//! images).

use glam::Vec3;

#[cfg(doc)]
use super::Film;
use super::PixelFeatures;

/// A layer the EXR can hold beside the beauty (`--passes`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, clap::ValueEnum)]
pub enum Pass {
    /// The first hit's BSDF reflectance.
    Albedo,
    /// The first hit's world-space shading normal.
    Normal,
    /// The camera's distance to the first hit.
    Depth,
    /// The world-space point hit.
    Position,
    /// TEXCOORD_0 at the hit.
    Uv,
}

crate::display_as_value_name!(Pass);

impl Pass {
    /// The layer's name in the EXR.
    pub fn layer(self) -> &'static str {
        match self {
            Pass::Albedo => "albedo",
            Pass::Normal => "normal",
            Pass::Depth => "depth",
            Pass::Position => "position",
            Pass::Uv => "uv",
        }
    }

    /// The layer's channels, in the order [`Pass::values`] gives them.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            Pass::Albedo => &["R", "G", "B"],
            Pass::Normal => &["X", "Y", "Z"],
            Pass::Depth => &["Z"],
            Pass::Position => &["X", "Y", "Z"],
            Pass::Uv => &["U", "V"],
        }
    }

    /// What the layer holds, for the header (`strata:pass:<layer>`).
    pub fn description(self) -> &'static str {
        match self {
            Pass::Albedo => {
                "first non-mirror hit's BSDF reflectance (times the mirrors' on the way), linear RGB, mean over the pixel's samples (a miss adds 0)"
            }
            Pass::Normal => {
                "first-hit shading normal, world space, facing the camera, mean over the pixel's samples (a miss adds 0)"
            }
            Pass::Depth => {
                "distance from the camera to the first hit, scene units, mean over the samples that hit; inf where none did"
            }
            Pass::Position => {
                "world-space point of the first hit, scene units, mean over the samples that hit; 0 where none did"
            }
            Pass::Uv => {
                "TEXCOORD_0 at the first hit, mean over the samples that hit; 0 where none did"
            }
        }
    }

    /// The pass's values for a pixel of mean features `f` ([`Film::features`]; None for a
    /// pixel without samples): zeros there (depth `inf`).
    pub fn values(self, f: Option<PixelFeatures>) -> [f32; 3] {
        let v3 = |v: Vec3| v.to_array();
        match (self, f) {
            (Pass::Albedo, Some(f)) => v3(f.albedo),
            (Pass::Normal, Some(f)) => v3(f.normal),
            (Pass::Depth, Some(f)) => [f.depth, 0.0, 0.0],
            (Pass::Position, Some(f)) => v3(f.position),
            (Pass::Uv, Some(f)) => [f.uv.x, f.uv.y, 0.0],
            (Pass::Depth, None) => [f32::INFINITY, 0.0, 0.0],
            (_, None) => [0.0; 3],
        }
    }
}

/// `passes` in a canonical order, each once.
pub fn canonical(passes: &[Pass]) -> Vec<Pass> {
    let mut p = passes.to_vec();
    p.sort();
    p.dedup();
    p
}
