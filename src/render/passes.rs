//! Render passes: the first-hit features the film sums beside the beauty
//! ([`Film::keep_features`]), written as layers of the same EXR under OpenEXR's `layer.channel`
//! names, which OpenImageIO, Blender's compositor and Nuke read as layers.
//!
//! | pass     | channels                          | each pixel                                   |
//! |----------|-----------------------------------|----------------------------------------------|
//! | `albedo` | `albedo.R`, `albedo.G`, `albedo.B` | the mean over its samples of the first hit's BSDF reflectance, through perfect mirrors to what they show (a miss adds 0) |
//! | `normal` | `normal.X`, `normal.Y`, `normal.Z` | the mean of the first hit's world-space shading normal, on the side the camera sees (a miss adds 0; not renormalised) |
//! | `depth`  | `depth.Z`                          | the mean distance from the camera to the first hit over the samples that hit; [`BACKGROUND_DEPTH`] (10¹⁰) where none did |
//! | `position` | `position.X`, `position.Y`, `position.Z` | the mean world-space point hit, over the samples that hit; 0 where none did |
//! | `uv`     | `uv.U`, `uv.V`                      | the mean TEXCOORD_0 at the hit, over the samples that hit; 0 where none did (or the scene has none) |
//! | `object_id` | `object_id.ID`                   | the glTF node (index into the document's `nodes`) whose mesh sample 0 hit; −1 where it met nothing |
//! | `mesh_id` | `mesh_id.ID`                       | the glTF mesh (index into `meshes`) sample 0 hit; −1 where it met nothing |
//! | `material_id` | `material_id.ID`               | the glTF material (index into `materials`) of the triangle sample 0 hit; −1 where it met nothing or its primitive names none |
//! | `alpha`  | `A`                                | the fraction of its samples whose camera ray met the scene (its coverage), OpenEXR's alpha beside `R`, `G`, `B`; `--background transparent` adds it |
//!
//! The feature passes are averaged over the pixel's samples like the beauty, so a pixel on an
//! object's outline holds a blend of both sides (what a denoiser expects of its auxiliary
//! images).
//!
//! The ID passes are exact instead: an average of IDs names no object (the mean of objects 2
//! and 4 is not object 3), so each pixel holds the IDs of one hit, its first sample's
//! (sample index 0), which the film keeps apart ([`Film::keep_first_hits`]). Every pixel takes
//! sample 0 first, whatever the thread count, the tiles' order, adaptive sampling, a time
//! limit or checkpoints, so the IDs are too; a farm shard holding sample 0 holds the IDs. They
//! are float32 channels holding integers (as Cycles' `IndexOB` pass, which compositors read),
//! exact up to 2^24 ([`check_exact`] refuses a scene whose indices pass it). A triangle of a
//! scene built in code rather than loaded from glTF has no document indices: −1.

use glam::Vec3;

#[cfg(doc)]
use super::Film;
use super::PixelFeatures;
use crate::scene::TriangleOrigin;

/// The largest integer a float32 channel holds exactly, with every integer below it: 2^24.
pub const MAX_EXACT_ID: u32 = 1 << 24;

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
    /// The glTF node whose mesh sample 0 hit.
    #[value(name = "object_id")]
    ObjectId,
    /// The glTF mesh sample 0 hit.
    #[value(name = "mesh_id")]
    MeshId,
    /// The glTF material of the triangle sample 0 hit.
    #[value(name = "material_id")]
    MaterialId,
    /// The fraction of the samples whose camera ray met the scene.
    Alpha,
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
            Pass::ObjectId => "object_id",
            Pass::MeshId => "mesh_id",
            Pass::MaterialId => "material_id",
            Pass::Alpha => "alpha",
        }
    }

    /// The EXR's name of the layer's channel `c` (one of [`Pass::channels`]): `layer.c`, but
    /// the alpha pass is OpenEXR's own `A`, the beauty's alpha.
    pub fn channel_name(self, c: &str) -> String {
        match self {
            Pass::Alpha => c.to_string(),
            _ => format!("{}.{c}", self.layer()),
        }
    }

    /// True for the ID passes, which the film's first hits give ([`Film::keep_first_hits`]);
    /// false for the feature passes, averaged over the samples ([`Film::keep_features`]).
    pub fn is_id(self) -> bool {
        matches!(self, Pass::ObjectId | Pass::MeshId | Pass::MaterialId)
    }

    /// An ID pass's index in `origin` (None for a feature pass).
    pub fn id_of(self, origin: TriangleOrigin) -> Option<u32> {
        match self {
            Pass::ObjectId => origin.node,
            Pass::MeshId => origin.mesh,
            Pass::MaterialId => origin.material,
            _ => None,
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
            Pass::ObjectId | Pass::MeshId | Pass::MaterialId => &["ID"],
            Pass::Alpha => &["A"],
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
                "distance from the camera to the first hit, scene units, mean over the samples that hit; 1e10 where none did"
            }
            Pass::Position => {
                "world-space point of the first hit, scene units, mean over the samples that hit; 0 where none did"
            }
            Pass::Uv => {
                "TEXCOORD_0 at the first hit, mean over the samples that hit; 0 where none did"
            }
            Pass::ObjectId => {
                "index into the glTF document's nodes of the node whose mesh the pixel's sample 0 (its first) hit, exact (not averaged); -1 where it met nothing"
            }
            Pass::MeshId => {
                "index into the glTF document's meshes of the mesh the pixel's sample 0 (its first) hit, exact (not averaged); -1 where it met nothing"
            }
            Pass::Alpha => {
                "fraction of the pixel's samples whose camera ray met the scene (its coverage); the beauty is premultiplied by it where the background is transparent"
            }
            Pass::MaterialId => {
                "index into the glTF document's materials of the material of the triangle the pixel's sample 0 (its first) hit, exact (not averaged); -1 where it met nothing or its primitive names no material"
            }
        }
    }

    /// The pass's values for a pixel of mean features `f` ([`Film::features`]; None for a
    /// pixel without samples, or for an ID pass): zeros there (depth [`BACKGROUND_DEPTH`]). An ID pass's
    /// is its index in `origin`, the document's indices of the triangle the pixel's sample 0
    /// hit (None where it met nothing), or −1.
    pub fn values(self, f: Option<PixelFeatures>, origin: Option<TriangleOrigin>) -> [f32; 3] {
        let v3 = |v: Vec3| v.to_array();
        match (self, f) {
            (Pass::ObjectId | Pass::MeshId | Pass::MaterialId, _) => {
                let id = origin.and_then(|o| self.id_of(o));
                [id.map_or(-1.0, |i| i as f32), 0.0, 0.0]
            }
            (Pass::Albedo, Some(f)) => v3(f.albedo),
            (Pass::Normal, Some(f)) => v3(f.normal),
            (Pass::Depth, Some(f)) if f.depth.is_finite() => [f.depth, 0.0, 0.0],
            (Pass::Position, Some(f)) => v3(f.position),
            (Pass::Uv, Some(f)) => [f.uv.x, f.uv.y, 0.0],
            (Pass::Alpha, Some(f)) => [f.coverage, 0.0, 0.0],
            (Pass::Depth, _) => [BACKGROUND_DEPTH, 0.0, 0.0],
            (_, None) => [0.0; 3],
        }
    }
}

/// The depth of a pixel whose samples all met nothing: far, finite (Cycles writes the same),
/// so that a compositor normalising the depth pass meets no infinity.
pub const BACKGROUND_DEPTH: f32 = 1e10;

/// Refuses ID passes whose indices (`largest`: the largest of each a scene's triangles may
/// name, [`crate::scene::Scene::largest_origin`]) a float32 channel cannot hold exactly (past
/// [`MAX_EXACT_ID`]), naming the pass, rather than writing wrong IDs.
pub fn check_exact(passes: &[Pass], largest: TriangleOrigin) -> Result<(), String> {
    for &pass in passes {
        if let Some(i) = pass.id_of(largest).filter(|&i| i > MAX_EXACT_ID) {
            return Err(format!(
                "--passes {pass}: the scene's indices reach {i}, past 2^24 = {MAX_EXACT_ID}, the largest a float32 channel holds exactly; leave out {pass}"
            ));
        }
    }
    Ok(())
}

/// `passes` in a canonical order, each once.
pub fn canonical(passes: &[Pass]) -> Vec<Pass> {
    let mut p = passes.to_vec();
    p.sort();
    p.dedup();
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{OriginRun, Origins};

    #[test]
    fn id_passes_past_two_to_the_24_are_refused_and_up_to_it_are_exact() {
        let origins = |node: u32, material: u32| Origins {
            runs: vec![OriginRun {
                first_triangle: 0,
                node,
                mesh: 0,
            }],
            materials: vec![None, Some(material)],
        };
        let all = [Pass::ObjectId, Pass::MeshId, Pass::MaterialId, Pass::Depth];
        assert_eq!(
            check_exact(&all, origins(MAX_EXACT_ID, MAX_EXACT_ID).largest()),
            Ok(())
        );
        // 2^24 is the last integer of a run that float32 holds: 2^24 + 1 rounds to 2^24.
        assert_eq!(MAX_EXACT_ID as f32 as u32, MAX_EXACT_ID);
        assert_ne!((MAX_EXACT_ID + 1) as f32 as u32, MAX_EXACT_ID + 1);
        let err = check_exact(&all, origins(MAX_EXACT_ID + 1, 3).largest()).unwrap_err();
        assert!(
            err.contains("object_id") && err.contains("16777217"),
            "{err}"
        );
        // Only the pass whose indices are too large is refused.
        let big_material = origins(7, MAX_EXACT_ID + 1);
        assert_eq!(
            check_exact(&[Pass::ObjectId, Pass::MeshId], big_material.largest()),
            Ok(())
        );
        assert!(check_exact(&[Pass::MaterialId], big_material.largest())
            .unwrap_err()
            .contains("material_id"));
    }

    #[test]
    fn an_id_pass_holds_the_documents_index_or_minus_one() {
        let origin = TriangleOrigin {
            node: Some(4),
            mesh: Some(1),
            material: None,
        };
        assert_eq!(Pass::ObjectId.values(None, Some(origin))[0], 4.0);
        assert_eq!(Pass::MeshId.values(None, Some(origin))[0], 1.0);
        assert_eq!(Pass::MaterialId.values(None, Some(origin))[0], -1.0);
        assert_eq!(Pass::ObjectId.values(None, None)[0], -1.0);
        assert_eq!(Pass::ObjectId.to_string(), "object_id");
        assert!(Pass::MaterialId.is_id() && !Pass::Uv.is_id());
    }
}
