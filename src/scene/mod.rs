//! The backend-free scene: world-space triangles, materials, lights, cameras and a summary of
//! which features the scene uses, so the renderer can skip work a scene does not need.
//!
//! The meshes of the glTF file are flattened into one triangle list in world space, but for
//! those that several nodes draw (or `EXT_mesh_gpu_instancing` instances): their triangles
//! are stored once, in the mesh's own space ([`Prototype`]), and placed by an [`Instance`]
//! each, so that memory grows with the unique geometry. A triangle's index is its primitive
//! id in the acceleration structure's hits, which also name the instance (`Hit::inst`).

mod accessors;
pub mod animation;
mod camera;
mod compressed;
mod draco;
pub mod extensions;
mod files;
mod gltf_loader;
pub mod image_header;
mod instancing;
mod memory;
mod meshopt;
mod origins;
mod tangents;

pub use animation::PoseTime;
pub use camera::{Camera, Lens, Projection, RayGenerator};
pub use extensions::transmission::Transmission;
pub use extensions::{
    AnisotropyLayer, ClearcoatLayer, IridescenceLayer, Layers, SheenLayer, SpecularLayer, Volume,
};
pub use files::percent_decode;
pub use gltf_loader::{load, load_from_bytes, LoadError, LoadOptions};
pub use memory::MemoryEstimate;
pub use origins::{OriginRun, Origins, TriangleOrigin};

use glam::{Affine3A, DMat4, DVec3, Mat3A, Vec2, Vec3, Vec3A, Vec4};

pub use crate::ray::NO_INSTANCE;

/// Deepest node hierarchy accepted (deeper ones are almost certainly cyclic or hostile).
pub(crate) const MAX_NODE_DEPTH: usize = 256;

/// `bytes` for people: "1.5 GiB", "512.0 KiB", "100 bytes".
pub fn format_bytes(bytes: u64) -> String {
    const UNITS: [&str; 6] = ["KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    if bytes < 1024 {
        return format!("{bytes} bytes");
    }
    let mut v = bytes as f64 / 1024.0;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    format!("{v:.1} {}", UNITS[unit])
}

/// How a texture is addressed outside `[0, 1]` (glTF sampler wrap modes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

/// Where an image's encoded bytes live. Images are decoded only when an integrator needs them.
#[derive(Clone, Debug, PartialEq)]
pub enum ImageSource {
    /// A file next to the scene (already resolved to a path).
    File(std::path::PathBuf),
    /// Encoded bytes from a buffer view or a data URI.
    Bytes {
        data: std::sync::Arc<[u8]>,
        mime: Option<String>,
    },
    /// An image the loader could not read (a missing file, a URI it cannot follow, a header
    /// no decoder recognises), and why: its textures render as if the material had none
    /// (the factors alone), with a warning, or `--strict` refuses the scene.
    Unreadable(String),
}

/// A texture that renders as absent, because its image could not be read or decoded: where
/// it was bound, and why. The textures that use it render as if the material had none (the
/// factors alone); [`Scene::missing_texture_warnings`] says so, one line per image.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MissingTexture {
    /// Index into [`Scene::images`].
    pub image: usize,
    /// Index into [`Scene::materials`] of the material that binds it.
    pub material: usize,
    /// Why the image cannot be had.
    pub problem: String,
}

/// How an image's colour channels are encoded: glTF's colour textures (base colour,
/// emission) are sRGB, its data textures (metallic-roughness, normal, occlusion) linear
/// (glTF 2.0, "Textures" and the material properties' descriptions).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Encoding {
    Srgb,
    Linear,
}

/// A texture binding of a material.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into [`Scene::images`].
    pub image: usize,
    /// Which TEXCOORD_n set the texture reads.
    pub tex_coord: u32,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    /// `KHR_texture_transform` as a 3×2 affine map (columns), identity if absent.
    pub transform: [Vec2; 3],
}

/// glTF 2.0's index of refraction of dielectrics (reflectance 0.04 at normal incidence),
/// which `KHR_materials_ior` changes.
pub const DEFAULT_IOR: f32 = 1.5;

/// A glTF material, reduced to what strata's integrators use.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: Option<String>,
    /// Linear RGBA base colour factor.
    pub base_color: Vec4,
    pub base_color_texture: Option<TextureRef>,
    /// Emitted radiance factor: `emissiveFactor × KHR_materials_emissive_strength`.
    pub emissive: Vec3,
    pub emissive_texture: Option<TextureRef>,
    pub metallic: f32,
    pub roughness: f32,
    /// Index of refraction of the dielectric part (`KHR_materials_ior`; glTF's 1.5 without):
    /// its specular reflectance at normal incidence is ((ior − 1) / (ior + 1))².
    pub ior: f32,
    /// `KHR_materials_transmission` and `_volume` ([`extensions::transmission`]): the share of
    /// the dielectric part's light that passes through the surface (factor 0 without), its
    /// texture, and the volume the surface bounds (None: a thin wall).
    pub transmission: Transmission,
    /// `KHR_materials_dispersion`'s 20 / Abbe number of the volume's index (0: none).
    pub dispersion: f32,
    /// The layers over the metallic-roughness BRDF: `KHR_materials_specular`, `_clearcoat`,
    /// `_sheen`, `_anisotropy`, `_iridescence` ([`extensions`]).
    pub layers: Layers,
    /// `metallicRoughnessTexture`: metallic in its blue channel, roughness in its green.
    pub metallic_roughness_texture: Option<TextureRef>,
    /// `normalTexture` and its `scale`.
    pub normal_texture: Option<TextureRef>,
    pub normal_scale: f32,
    /// `occlusionTexture` (precomputed ambient occlusion: light transport computes its own).
    pub occlusion_texture: Option<TextureRef>,
    pub alpha_mode: AlphaMode,
    /// The material's `KHR_materials_*` extensions that strata does not render.
    pub ignored_extensions: Vec<String>,
    pub double_sided: bool,
}

/// A normal-mapped primitive whose tangent frames MikkTSpace is to make.
#[derive(Clone, Debug, PartialEq)]
pub struct PendingTangents {
    /// Its first triangle in [`Scene::triangles`]; its triangles follow in order.
    pub first_triangle: usize,
    /// Each triangle's vertices as the file numbers them (flat-shaded triangles' copies
    /// replaced by the originals, so that MikkTSpace welds them with their neighbours).
    pub corners: Vec<[u32; 3]>,
}

/// How a material's alpha covers its surface (glTF `alphaMode`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum AlphaMode {
    /// Alpha is ignored: the surface is opaque.
    #[default]
    Opaque,
    /// Covered where alpha ≥ the cutoff (`alphaCutoff`, 0.5 by default), else a hole.
    Mask(f32),
    /// Alpha is the fraction of light the surface stops.
    Blend,
}

impl Default for Material {
    /// glTF's default material: white, fully rough dielectric, no emission.
    fn default() -> Self {
        Material {
            name: None,
            base_color: Vec4::ONE,
            base_color_texture: None,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            metallic: 1.0,
            roughness: 1.0,
            ior: DEFAULT_IOR,
            transmission: Transmission::default(),
            dispersion: 0.0,
            layers: Layers::default(),
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            occlusion_texture: None,
            alpha_mode: AlphaMode::Opaque,
            ignored_extensions: Vec::new(),
            double_sided: false,
        }
    }
}

impl Material {
    /// True when any part of the surface can emit light.
    pub fn is_emissive(&self) -> bool {
        self.emissive.max_element() > 0.0
    }

    /// True when shading reads the surface's tangent frames: for its normal map, its clear
    /// coat's normal map, or its anisotropy's direction.
    pub fn needs_tangents(&self) -> bool {
        self.normal_texture.is_some() || self.layers.needs_tangents()
    }

    /// Every texture the material binds, as (its image, how the image's colours are
    /// encoded): the core material's (the occlusion texture's too, though it is not
    /// rendered), the transmission's and each layer's.
    pub fn texture_images(&self) -> Vec<(usize, Encoding)> {
        let core = [
            (&self.base_color_texture, Encoding::Srgb),
            (&self.emissive_texture, Encoding::Srgb),
            (&self.metallic_roughness_texture, Encoding::Linear),
            (&self.normal_texture, Encoding::Linear),
            (&self.occlusion_texture, Encoding::Linear),
        ];
        let mut out: Vec<(usize, Encoding)> = (core.iter())
            .filter_map(|(t, e)| t.as_ref().map(|t| (t.image, *e)))
            .collect();
        // The extensions' textures, through the binding every renderer's texture goes
        // through, so that none is left out.
        let mut note =
            |t: &TextureRef, e: Encoding| -> Result<Option<()>, std::convert::Infallible> {
                out.push((t.image, e));
                Ok(Some(()))
            };
        let Ok(_) = self.transmission.bind(&mut note);
        let Ok(_) = self.layers.bind(&mut note);
        out
    }

    /// True when alpha may leave holes in the surface (glTF 2.0, "Alpha Coverage"): a MASK
    /// or BLEND material with a base colour texture (whose alpha is only known once decoded,
    /// see `accel::AlphaCoverage`), or whose factor's alpha alone is below what covers
    /// everywhere (the cutoff for MASK, 1 for BLEND). OPAQUE ignores alpha.
    ///
    /// COLOR_0: the loader keeps no vertex colours yet; when it does, a primitive whose
    /// COLOR_0 has alpha makes its MASK or BLEND triangles alpha-tested too.
    pub fn may_cut_holes(&self) -> bool {
        let alpha = self.base_color.w;
        let covers = match self.alpha_mode {
            AlphaMode::Opaque => return false,
            AlphaMode::Mask(cutoff) => alpha >= cutoff,
            AlphaMode::Blend => alpha >= 1.0,
        };
        self.base_color_texture.is_some() || !covers
    }

    /// What the material asks for that strata does not render yet, each with what it looks
    /// like instead; empty when it renders as written.
    pub fn unrendered_inputs(&self) -> Vec<String> {
        let mut dropped = Vec::new();
        if self.occlusion_texture.is_some() {
            dropped.push(
                "an occlusion texture is not rendered (light transport computes occlusion)"
                    .to_string(),
            );
        }
        for ext in &self.ignored_extensions {
            dropped.push(format!("{ext} is ignored"));
        }
        dropped
    }
}

/// One line per kind of (kind, material name) pair, in the order the kinds first come,
/// naming its materials (the first four, and how many more).
fn group_by_kind(pairs: impl IntoIterator<Item = (String, String)>) -> Vec<String> {
    let mut kinds: Vec<(String, Vec<String>)> = Vec::new();
    for (kind, name) in pairs {
        match kinds.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, names)) => names.push(name),
            None => kinds.push((kind, vec![name])),
        }
    }
    kinds
        .into_iter()
        .map(|(kind, names)| {
            const SHOWN: usize = 4;
            let mut list = names
                .iter()
                .take(SHOWN)
                .cloned()
                .collect::<Vec<_>>()
                .join(", ");
            if names.len() > SHOWN {
                list += &format!(" and {} more", names.len() - SHOWN);
            }
            match names.len() {
                1 => format!("{kind}, in material {list}"),
                n => format!("{kind}, in {n} materials: {list}"),
            }
        })
        .collect()
}

/// A `KHR_lights_punctual` light in world space. `intensity` is `color × intensity`:
/// radiant intensity for point and spot lights, irradiance for directional lights.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    Point {
        position: Vec3,
        intensity: Vec3,
        range: Option<f32>,
    },
    Spot {
        position: Vec3,
        /// Unit direction the spot points to (the node's −Z).
        direction: Vec3,
        intensity: Vec3,
        range: Option<f32>,
        inner_cone_angle: f32,
        outer_cone_angle: f32,
    },
    Directional {
        /// Unit direction the light travels in (the node's −Z).
        direction: Vec3,
        irradiance: Vec3,
    },
}

/// The `KHR_lights_punctual` light a glTF node places with its world transform `world`, in
/// world space; an error for a colour or placement that is not finite.
pub(super) fn light_from_gltf(
    light: &gltf::khr_lights_punctual::Light,
    world: &DMat4,
) -> Result<Light, String> {
    let color = Vec3::from_array(light.color()) * light.intensity();
    if !color.is_finite() || color.min_element() < 0.0 {
        return Err(format!(
            "light {}: colour × intensity must be finite and non-negative",
            light.index()
        ));
    }
    let position = world.transform_point3(DVec3::ZERO).as_vec3();
    let direction = world
        .transform_vector3(DVec3::NEG_Z)
        .normalize_or_zero()
        .as_vec3();
    if !position.is_finite() {
        return Err(format!(
            "light {}: its world position overflows single precision",
            light.index()
        ));
    }
    let range = light.range().filter(|r| *r > 0.0);
    let l = match light.kind() {
        gltf::khr_lights_punctual::Kind::Point => Light::Point {
            position,
            intensity: color,
            range,
        },
        gltf::khr_lights_punctual::Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => Light::Spot {
            position,
            direction,
            intensity: color,
            range,
            inner_cone_angle,
            outer_cone_angle,
        },
        gltf::khr_lights_punctual::Kind::Directional => Light::Directional {
            direction,
            irradiance: color,
        },
    };
    Ok(l)
}

/// A mesh drawn in several places: its triangles, stored once in [`Scene::triangles`] in the
/// mesh's own space, which each [`Instance`] places: every mesh placed more than once, unless
/// `--flatten-instances`. Alpha coverage (MASK, and BLEND, whose coin reads the instance and
/// the world ray's key) is tested inside instances; an emitting prototype's triangles are
/// lights once per instance.
#[derive(Clone, Debug, PartialEq)]
pub struct Prototype {
    /// Its triangles, `triangles.start..triangles.end` of [`Scene::triangles`].
    pub triangles: std::ops::Range<u32>,
    /// The box of its triangles' vertices, in its own space.
    pub bounds: (Vec3, Vec3),
    /// The glTF mesh it is (ID passes); None for one built in code.
    pub mesh: Option<u32>,
}

/// One placement of a [`Prototype`]: its triangles seen through an affine map to world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Index into [`Scene::prototypes`].
    pub prototype: u32,
    /// The prototype's space to world space.
    pub to_world: Affine3A,
    /// The inverse transpose of `to_world`'s linear part, which carries normals to world
    /// space (unnormalized).
    pub normal_to_world: Mat3A,
    /// The glTF node that draws it (ID passes); None for one built in code.
    pub node: Option<u32>,
}

impl Instance {
    /// Prototype `prototype` placed by `to_world` (invertible: the loader refuses singular
    /// placements).
    pub fn new(prototype: u32, to_world: Affine3A, node: Option<u32>) -> Instance {
        Instance {
            prototype,
            to_world,
            normal_to_world: to_world.matrix3.inverse().transpose(),
            node,
        }
    }

    /// The world-space box of a box `bounds` in the prototype's space: the box of its eight
    /// corners placed.
    pub fn world_box(&self, (lo, hi): (Vec3, Vec3)) -> (Vec3, Vec3) {
        let (mut a, mut b) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        for k in 0..8 {
            let corner = Vec3A::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            let p = self.to_world.transform_point3a(corner);
            (a, b) = (a.min(p), b.max(p));
        }
        (a.into(), b.into())
    }
}

/// How many textures the scene's materials reference in each role.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextureRoles {
    pub base_color: usize,
    pub emissive: usize,
    pub metallic_roughness: usize,
    pub normal: usize,
    pub occlusion: usize,
}

impl TextureRoles {
    /// The textures light transport reads (base colour, emission, metallic-roughness,
    /// normal).
    pub fn rendered(&self) -> usize {
        self.base_color + self.emissive + self.metallic_roughness + self.normal
    }
}

/// What a scene uses, so the renderer can skip what it does not need.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneSummary {
    pub triangles: usize,
    pub vertices: usize,
    pub textures: usize,
    /// The textures materials reference, by what they are for.
    pub texture_roles: TextureRoles,
    pub emissive_triangles: usize,
    /// Triangles whose material may cut holes by alpha ([`Material::may_cut_holes`]): zero,
    /// and the acceleration structure decodes nothing and filters no hit.
    pub alpha_tested_triangles: usize,
    pub punctual_lights: usize,
    pub cameras: usize,
    /// Instances of meshes drawn in several places ([`Scene::instances`]), and the triangles
    /// they place (each instance's prototype's, counted once per instance); `triangles` counts
    /// the triangles stored.
    pub instances: usize,
    pub instanced_triangles: usize,
}

/// A scene ready to render: geometry in world space, but for the [`Prototype`]s that
/// [`Instance`]s place.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    pub positions: Vec<Vec3>,
    /// Unit shading normal per vertex, or zero for vertices of primitives without normals
    /// (glTF asks for flat shading there: the geometric normal is used).
    pub normals: Vec<Vec3>,
    /// TEXCOORD_0 per vertex (zero where absent).
    pub uvs: Vec<Vec2>,
    /// Linear `COLOR_0` per vertex (RGBA; white for vertices of primitives without one), or
    /// empty when no primitive has vertex colours.
    pub colors: Vec<Vec4>,
    /// The tangent frame of each triangle's corners for its material's normal map (xyz the
    /// tangent, w the bitangent's sign) from the file's `TANGENT`, zero where it has none
    /// (yet); empty when no triangle has one. [`Scene::tangent_frames`] adds MikkTSpace's.
    pub tangents: Vec<[Vec4; 3]>,
    /// The normal-mapped primitives without `TANGENT`, whose frames MikkTSpace makes when a
    /// render needs them.
    pub pending_tangents: Vec<PendingTangents>,
    /// Vertex indices of each triangle, counter-clockwise seen from the front.
    pub triangles: Vec<[u32; 3]>,
    /// Material index of each triangle.
    pub triangle_materials: Vec<u32>,
    pub materials: Vec<Material>,
    /// Each triangle's node, mesh and material as the glTF document numbers them, for ID
    /// passes ([`Scene::origin`]); empty for a scene built in code.
    pub origins: Origins,
    pub images: Vec<ImageSource>,
    /// What messages call each image ([`Scene::image_label`]); empty for a scene built in
    /// code.
    pub image_labels: Vec<String>,
    pub lights: Vec<Light>,
    pub cameras: Vec<Camera>,
    /// Meshes drawn in several places, their triangles in their own space.
    pub prototypes: Vec<Prototype>,
    /// Where the prototypes are drawn (shared with the acceleration structure).
    pub instances: std::sync::Arc<Vec<Instance>>,
    /// World-space bounds of all triangles, instances' included (min, max).
    pub bounds: (Vec3, Vec3),
    pub summary: SceneSummary,
    /// What the loader skipped or repaired, one line each.
    pub load_warnings: Vec<String>,
    /// The loader's estimate of the memory the scene needs (geometry and BVH), made from the
    /// file's declared counts before loading.
    pub memory_estimate: MemoryEstimate,
    /// The files the scene was read from: the glTF file, then its external buffers and
    /// images in the document's order (a farm's shards check they rendered the same bytes:
    /// [`crate::render::merge`]). Empty for a scene built in code.
    pub files: Vec<std::path::PathBuf>,
}

impl Scene {
    /// One line per kind of input that materials some triangle uses ask for and strata does
    /// not render yet, saying what it looks like instead and naming the materials (the first
    /// four, and how many more): for the integrators that shade materials (AO shades every
    /// surface alike).
    pub fn material_warnings(&self) -> Vec<String> {
        let mut used = vec![false; self.materials.len()];
        for &m in &self.triangle_materials {
            used[m as usize] = true;
        }
        // One line per kind of input, naming the materials that ask for it.
        let mut kinds = Vec::new();
        for (i, (m, _)) in (self.materials.iter().zip(&used).enumerate()).filter(|(_, (_, &u))| u) {
            for kind in m.unrendered_inputs() {
                kinds.push((kind, self.material_name(i)));
            }
        }
        group_by_kind(kinds)
    }

    /// Every triangle's tangent frames: the file's, with MikkTSpace's for the primitives that
    /// have none (the work normal maps need; ambient occlusion never asks); empty when no
    /// triangle has a normal map.
    pub fn tangent_frames(&self) -> Vec<[Vec4; 3]> {
        let mut frames = self.tangents.clone();
        for p in &self.pending_tangents {
            let made = tangents::mikktspace(self, &p.corners);
            frames[p.first_triangle..p.first_triangle + made.len()].copy_from_slice(&made);
        }
        frames
    }

    /// What messages call image `index`: its index in the glTF file, its name and its URI
    /// where it has them ("image 2 'wood' (textures/wood.png)").
    pub fn image_label(&self, index: usize) -> String {
        match self.image_labels.get(index) {
            Some(label) => label.clone(),
            None => format!("image {index}"),
        }
    }

    /// Every image the loader could not read, with why ([`ImageSource::Unreadable`]), in
    /// the file's order.
    pub fn unreadable_images(&self) -> impl Iterator<Item = (usize, &str)> {
        self.images.iter().enumerate().filter_map(|(i, s)| match s {
            ImageSource::Unreadable(why) => Some((i, why.as_str())),
            _ => None,
        })
    }

    /// The warnings for `missing` textures, grouped as [`Scene::material_warnings`] groups
    /// its kinds: one line per image that cannot be had, saying why and naming the
    /// materials whose textures render without it (each once, however many of their
    /// textures use it).
    pub fn missing_texture_warnings(&self, missing: &[MissingTexture]) -> Vec<String> {
        let mut missing = missing.to_vec();
        missing.sort_by_key(|t| (t.image, t.material));
        let mut seen = std::collections::HashSet::new();
        let kinds = missing
            .iter()
            .filter(|t| seen.insert((t.image, t.material)))
            .map(|t| {
                let kind = format!(
                    "{}: {}; the textures that use it render as if absent (their factors alone)",
                    self.image_label(t.image),
                    t.problem
                );
                (kind, self.material_name(t.material))
            });
        group_by_kind(kinds)
    }

    /// What messages call the scene's material `i`: the file's index (the scene's less one)
    /// and its name.
    fn material_name(&self, i: usize) -> String {
        // Index 0 is glTF's default material; the file's material k is index k + 1.
        match (i, self.materials.get(i).and_then(|m| m.name.as_ref())) {
            (0, _) => "the default material (of primitives that name none)".to_string(),
            (i, Some(n)) => format!("{} '{n}'", i - 1),
            (i, None) => format!("{}", i - 1),
        }
    }

    /// Image `index`'s source, or an error naming the scene file (loaded from `scene_path`)
    /// when a texture points at an image the file does not have.
    pub fn image_source(
        &self,
        index: usize,
        scene_path: &std::path::Path,
    ) -> Result<&ImageSource, String> {
        self.images.get(index).ok_or_else(|| {
            format!(
                "{}: texture image {index} does not exist",
                scene_path.display()
            )
        })
    }

    /// True when triangle `t`'s alpha may leave holes: its material's factor or texture may
    /// ([`Material::may_cut_holes`]), or, under MASK or BLEND, a vertex's `COLOR_0` alpha is
    /// below 1 (alpha = factor × texture × COLOR_0).
    pub fn may_cut_holes(&self, t: usize) -> bool {
        let m = &self.materials[self.triangle_materials[t] as usize];
        m.may_cut_holes()
            || (m.alpha_mode != AlphaMode::Opaque && self.vertex_alpha_below_one(self.triangles[t]))
    }

    /// True when a vertex of `tri` has a `COLOR_0` alpha below 1.
    pub fn vertex_alpha_below_one(&self, tri: [u32; 3]) -> bool {
        !self.colors.is_empty() && tri.iter().any(|&v| self.colors[v as usize].w < 1.0)
    }

    /// Triangle `prim`'s node, mesh and material in the glTF document it was loaded from, as
    /// instance `inst` places it (None each for a scene built in code, and the material of a
    /// primitive that names none).
    pub fn origin(&self, prim: u32, inst: u32) -> TriangleOrigin {
        let mut origin = self
            .origins
            .of(prim, self.triangle_materials[prim as usize]);
        // A prototype's triangle is the node's that placed it.
        if let Some(i) = self.instances.get(inst as usize) {
            origin.node = i.node;
            origin.mesh = self.prototypes[i.prototype as usize].mesh;
        }
        origin
    }

    /// The triangles in world space (all but the prototypes'), ascending.
    pub fn flat_triangles(&self) -> Vec<u32> {
        let mut inside = vec![false; self.triangles.len()];
        for p in &self.prototypes {
            inside[p.triangles.start as usize..p.triangles.end as usize].fill(true);
        }
        (0..self.triangles.len() as u32)
            .filter(|&t| !inside[t as usize])
            .collect()
    }

    /// Positions of the three vertices of triangle `prim` placed by instance `inst` (or as
    /// stored, for [`NO_INSTANCE`]).
    #[inline(always)]
    pub fn placed_positions(&self, prim: u32, inst: u32) -> [Vec3; 3] {
        let p = self.triangle_positions(prim);
        match self.instances.get(inst as usize) {
            None => p,
            Some(i) => p.map(|q| i.to_world.transform_point3(q)),
        }
    }

    /// The shading normal at barycentrics (u, v) of triangle `prim` placed by instance
    /// `inst`, in world space ([`Scene::shading_normal`] carried by
    /// [`Scene::normal_to_world`]).
    #[inline(always)]
    pub fn placed_shading_normal(&self, prim: u32, inst: u32, u: f32, v: f32) -> Option<Vec3> {
        let n = self.shading_normal(prim, u, v)?;
        Some(self.normal_to_world(inst, n))
    }

    /// A normal `n` of instance `inst`'s prototype in world space, unit length (`n` as it is
    /// for [`NO_INSTANCE`]).
    #[inline(always)]
    pub fn normal_to_world(&self, inst: u32, n: Vec3) -> Vec3 {
        match self.instances.get(inst as usize) {
            None => n,
            Some(i) => (i.normal_to_world * Vec3A::from(n))
                .normalize_or_zero()
                .into(),
        }
    }

    /// True when instance `inst` mirrors its prototype (its placement's determinant is
    /// negative), which turns the handedness of tangent frames; false for [`NO_INSTANCE`].
    #[inline]
    pub fn mirrors(&self, inst: u32) -> bool {
        self.instances
            .get(inst as usize)
            .is_some_and(|i| i.to_world.matrix3.determinant() < 0.0)
    }

    /// A tangent direction `v` of instance `inst`'s prototype in world space (not
    /// normalized; `v` for [`NO_INSTANCE`]).
    #[inline(always)]
    pub fn vector_to_world(&self, inst: u32, v: Vec3) -> Vec3 {
        match self.instances.get(inst as usize) {
            None => v,
            Some(i) => i.to_world.transform_vector3(v),
        }
    }

    /// The largest node, mesh and material index any triangle's origin may name
    /// ([`Scene::origin`]; None where none names one).
    pub fn largest_origin(&self) -> TriangleOrigin {
        let mut largest = self.origins.largest();
        let nodes = self.instances.iter().filter_map(|i| i.node);
        largest.node = largest.node.into_iter().chain(nodes).max();
        let meshes = self.prototypes.iter().filter_map(|p| p.mesh);
        largest.mesh = largest.mesh.into_iter().chain(meshes).max();
        largest
    }

    /// Positions of the three vertices of triangle `prim`.
    #[inline]
    pub fn triangle_positions(&self, prim: u32) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[prim as usize];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// TEXCOORD_0 at barycentrics (u, v) of triangle `prim` (zero where the file gives none).
    #[inline]
    pub fn texcoord(&self, prim: u32, u: f32, v: f32) -> Vec2 {
        let [a, b, c] = self.triangles[prim as usize];
        (1.0 - u - v) * self.uvs[a as usize] + u * self.uvs[b as usize] + v * self.uvs[c as usize]
    }

    /// The shading normal at barycentrics (u, v) of triangle `prim`, or `None` when the
    /// triangle has no usable vertex normals (flat shading).
    #[inline(always)]
    pub fn shading_normal(&self, prim: u32, u: f32, v: f32) -> Option<Vec3> {
        let [a, b, c] = self.triangles[prim as usize];
        let n = (1.0 - u - v) * self.normals[a as usize]
            + u * self.normals[b as usize]
            + v * self.normals[c as usize];
        let len2 = n.length_squared();
        (len2 > 1e-12 && len2.is_finite()).then(|| n / len2.sqrt())
    }

    /// Recomputes `bounds` and `summary` from the scene's contents.
    pub fn update_summary(&mut self) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in &self.positions {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if !self.prototypes.is_empty() {
            // The flat triangles' vertices and the instances' boxes (the prototypes' vertices
            // are in their own space).
            (lo, hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for t in self.flat_triangles() {
                for p in self.triangle_positions(t) {
                    (lo, hi) = (lo.min(p), hi.max(p));
                }
            }
            for i in self.instances.iter() {
                let (a, b) = i.world_box(self.prototypes[i.prototype as usize].bounds);
                (lo, hi) = (lo.min(a), hi.max(b));
            }
        }
        // Nothing to bound (a scene with no triangles): a point at the origin, which the
        // framing camera looks at from +Z.
        self.bounds = match self.positions.is_empty() || lo.x > hi.x {
            true => (Vec3::ZERO, Vec3::ZERO),
            false => (lo, hi),
        };
        let emissive_triangles = self
            .triangle_materials
            .iter()
            .filter(|&&m| self.materials[m as usize].is_emissive())
            .count();
        let count =
            |role: fn(&Material) -> bool| self.materials.iter().filter(|&m| role(m)).count();
        let texture_roles = TextureRoles {
            base_color: count(|m| m.base_color_texture.is_some()),
            emissive: count(|m| m.emissive_texture.is_some()),
            metallic_roughness: count(|m| m.metallic_roughness_texture.is_some()),
            normal: count(|m| m.normal_texture.is_some()),
            occlusion: count(|m| m.occlusion_texture.is_some()),
        };
        let textures = texture_roles.rendered();
        let alpha_tested_triangles = (0..self.triangles.len())
            .filter(|&t| self.may_cut_holes(t))
            .count();
        self.summary = SceneSummary {
            triangles: self.triangles.len(),
            vertices: self.positions.len(),
            textures,
            texture_roles,
            emissive_triangles,
            alpha_tested_triangles,
            punctual_lights: self.lights.len(),
            cameras: self.cameras.len(),
            instances: self.instances.len(),
            instanced_triangles: self
                .instances
                .iter()
                .map(|i| self.prototypes[i.prototype as usize].triangles.len())
                .sum(),
        };
    }
}
