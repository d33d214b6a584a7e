//! The backend-free scene: world-space triangles, materials, lights, cameras and a summary of
//! which features the scene uses, so the renderer can skip work a scene does not need.
//!
//! Every mesh of the glTF file is flattened into one triangle list in world space; a
//! triangle's index is its primitive id in the acceleration structure's hits.

mod camera;
mod gltf_loader;

pub use camera::{Camera, Projection, RayGenerator};
pub use gltf_loader::{
    format_bytes, load, load_from_bytes, percent_decode, LoadError, LoadOptions, MemoryEstimate,
};

use glam::{Vec2, Vec3, Vec4};

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
    /// `metallicRoughnessTexture`: metallic in its blue channel, roughness in its green.
    pub metallic_roughness_texture: Option<TextureRef>,
    pub double_sided: bool,
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
            metallic_roughness_texture: None,
            double_sided: false,
        }
    }
}

impl Material {
    /// True when any part of the surface can emit light.
    pub fn is_emissive(&self) -> bool {
        self.emissive.max_element() > 0.0
    }
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

/// What a scene uses, so the renderer can skip what it does not need.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneSummary {
    pub triangles: usize,
    pub vertices: usize,
    pub textures: usize,
    pub emissive_triangles: usize,
    pub punctual_lights: usize,
    /// Materials whose metallic factor is non-zero (rendered as diffuse until GGX lands).
    pub non_diffuse_materials: usize,
    pub cameras: usize,
}

/// A scene ready to render: all geometry flattened into world space.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    pub positions: Vec<Vec3>,
    /// Unit shading normal per vertex, or zero for vertices of primitives without normals
    /// (glTF asks for flat shading there: the geometric normal is used).
    pub normals: Vec<Vec3>,
    /// TEXCOORD_0 per vertex (zero where absent).
    pub uvs: Vec<Vec2>,
    /// Vertex indices of each triangle, counter-clockwise seen from the front.
    pub triangles: Vec<[u32; 3]>,
    /// Material index of each triangle.
    pub triangle_materials: Vec<u32>,
    pub materials: Vec<Material>,
    pub images: Vec<ImageSource>,
    pub lights: Vec<Light>,
    pub cameras: Vec<Camera>,
    /// World-space bounds of all vertices (min, max).
    pub bounds: (Vec3, Vec3),
    pub summary: SceneSummary,
    /// What the loader skipped or repaired, one line each.
    pub load_warnings: Vec<String>,
    /// The loader's estimate of the memory the scene needs (geometry and BVH), made from the
    /// file's declared counts before loading.
    pub memory_estimate: MemoryEstimate,
}

impl Scene {
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

    /// The shading normal at barycentrics (u, v) of triangle `prim`, or `None` when the
    /// triangle has no usable vertex normals (flat shading).
    #[inline]
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
        self.bounds = (lo, hi);
        let emissive_triangles = self
            .triangle_materials
            .iter()
            .filter(|&&m| self.materials[m as usize].is_emissive())
            .count();
        let textures = self
            .materials
            .iter()
            .map(|m| {
                m.base_color_texture.is_some() as usize + m.emissive_texture.is_some() as usize
            })
            .sum();
        self.summary = SceneSummary {
            triangles: self.triangles.len(),
            vertices: self.positions.len(),
            textures,
            emissive_triangles,
            punctual_lights: self.lights.len(),
            non_diffuse_materials: self.materials.iter().filter(|m| m.metallic > 0.0).count(),
            cameras: self.cameras.len(),
        };
    }
}
