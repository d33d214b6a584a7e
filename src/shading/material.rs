//! Materials at render time: each glTF material prepared into what its [`Bsdf`] and its
//! emission need, and looked up per surface point.
//!
//! | property   | from                                                    | used by          |
//! |------------|---------------------------------------------------------|------------------|
//! | base colour| baseColorFactor × baseColorTexture (sRGB-decoded)       | the BSDF (ρ)     |
//! | metallic,  | metallicFactor, roughnessFactor, metallicRoughness-     | kept, not shaded |
//! | roughness  | Texture (B = metallic, G = roughness; not decoded yet)  | yet (diffuse)    |
//! | emission   | emissiveFactor × emissiveTexture × emissive strength;   | lights, paths    |
//! |            | the front face only unless the material is double-sided|                  |
//!
//! Every material is shaded as Lambertian reflection (f = ρ/π) until the glTF
//! metallic-roughness BSDF joins [`Bsdf`]; [`Materials::bsdf`] is the one place that chooses
//! a surface point's BSDF. [`Materials::prepare`] decodes exactly the textures the chosen
//! integrator reads: none for ambient occlusion, and for light transport only those of
//! materials some triangle uses.

use std::path::Path;

use glam::{Vec2, Vec3, Vec4};

use super::bsdf::{Bsdf, BsdfFlags, SurfaceBsdf};
use super::interaction::SurfaceInteraction;
use super::texture::{transform_uv, Image};
use crate::scene::{Scene, TextureRef};

/// What the integrator needs to read from materials.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Need {
    /// Geometry only (AO): no material, no texture.
    Nothing,
    /// Base colour and emission, with their textures.
    Shading,
}

#[derive(Clone, Debug)]
struct Binding {
    texture: TextureRef,
    /// Index into `Materials::images`.
    image: usize,
}

/// How diffuse reflection draws its directions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum DiffuseSampling {
    /// Cosine-weighted: the pdf follows f·cos θ ([`Bsdf::Diffuse`]).
    #[default]
    Cosine,
    /// Uniform over the hemisphere ([`Bsdf::DiffuseUniform`]), for comparisons.
    Uniform,
}

#[derive(Clone, Debug)]
struct Prepared {
    base_color: Vec3,
    base_texture: Option<Binding>,
    /// The metallic-roughness model's factors and texture (B = metallic, G = roughness),
    /// read from the file and kept for the glTF BSDF; not decoded while every material is
    /// shaded as diffuse.
    #[allow(dead_code)]
    metallic: f32,
    #[allow(dead_code)]
    roughness: f32,
    #[allow(dead_code)]
    metallic_roughness_texture: Option<TextureRef>,
    emissive: Vec3,
    emissive_texture: Option<Binding>,
    double_sided: bool,
}

/// Materials ready for shading.
#[derive(Clone, Debug, Default)]
pub struct Materials {
    materials: Vec<Prepared>,
    images: Vec<Image>,
    diffuse_sampling: DiffuseSampling,
    /// True when any used material reads a texture (UVs must be interpolated).
    pub textured: bool,
}

impl Materials {
    /// Prepares the scene's materials, decoding the textures that `need` requires; diffuse
    /// reflection draws its directions as `diffuse_sampling` says.
    pub fn prepare(
        scene: &Scene,
        scene_path: &Path,
        need: Need,
        diffuse_sampling: DiffuseSampling,
    ) -> Result<Materials, String> {
        if need == Need::Nothing {
            return Ok(Materials::default());
        }
        let mut used = vec![false; scene.materials.len()];
        for &m in &scene.triangle_materials {
            used[m as usize] = true;
        }
        let mut image_slot: Vec<Option<usize>> = vec![None; scene.images.len()];
        let mut images = Vec::new();
        let mut bind =
            |t: &Option<TextureRef>, images: &mut Vec<Image>| -> Result<Option<Binding>, String> {
                let Some(t) = t else { return Ok(None) };
                let src = scene.images.get(t.image).ok_or_else(|| {
                    format!(
                        "{}: texture image {} does not exist",
                        scene_path.display(),
                        t.image
                    )
                })?;
                let slot = match image_slot[t.image] {
                    Some(s) => s,
                    None => {
                        images.push(Image::decode(src, t.image, scene_path)?);
                        image_slot[t.image] = Some(images.len() - 1);
                        images.len() - 1
                    }
                };
                Ok(Some(Binding {
                    texture: t.clone(),
                    image: slot,
                }))
            };
        let mut materials = Vec::with_capacity(scene.materials.len());
        for (m, &is_used) in scene.materials.iter().zip(&used) {
            let (base_texture, emissive_texture) = if is_used {
                let base = bind(&m.base_color_texture, &mut images)?;
                // An emissive texture only matters when the emissive factor is non-zero.
                let emissive = if m.is_emissive() {
                    bind(&m.emissive_texture, &mut images)?
                } else {
                    None
                };
                (base, emissive)
            } else {
                (None, None)
            };
            materials.push(Prepared {
                base_color: m.base_color.truncate(),
                base_texture,
                metallic: m.metallic,
                roughness: m.roughness,
                metallic_roughness_texture: m.metallic_roughness_texture.clone(),
                emissive: m.emissive,
                emissive_texture,
                double_sided: m.double_sided,
            });
        }
        let textured = materials
            .iter()
            .any(|m| m.base_texture.is_some() || m.emissive_texture.is_some());
        Ok(Materials {
            materials,
            images,
            diffuse_sampling,
            textured,
        })
    }

    /// Number of decoded images.
    pub fn decoded_images(&self) -> usize {
        self.images.len()
    }

    #[inline]
    fn lookup(&self, b: &Binding, uv: Vec2) -> Vec4 {
        let t = &b.texture;
        self.images[b.image].bilinear(transform_uv(t, uv), t.wrap_s, t.wrap_t)
    }

    /// The interpolated TEXCOORD_0 at a surface point (zero when no material is textured).
    #[inline]
    pub fn uv(&self, scene: &Scene, si: &SurfaceInteraction) -> Vec2 {
        if !self.textured {
            return Vec2::ZERO;
        }
        let (u, v) = (si.u, si.v);
        let [a, b, c] = scene.triangles[si.prim as usize];
        (1.0 - u - v) * scene.uvs[a as usize]
            + u * scene.uvs[b as usize]
            + v * scene.uvs[c as usize]
    }

    /// The BSDF at the surface point (`uv`: its texture coordinates, [`Materials::uv`]).
    #[inline]
    pub fn bsdf(&self, scene: &Scene, si: &SurfaceInteraction, uv: Vec2) -> SurfaceBsdf {
        let albedo = self.base_color(scene, si.prim, uv);
        SurfaceBsdf::new(self.bsdf_with(albedo), si)
    }

    /// The BSDF of a material whose base colour is `albedo`: the one place that chooses a
    /// variant.
    #[inline]
    fn bsdf_with(&self, albedo: Vec3) -> Bsdf {
        match self.diffuse_sampling {
            DiffuseSampling::Cosine => Bsdf::Diffuse { albedo },
            DiffuseSampling::Uniform => Bsdf::DiffuseUniform { albedo },
        }
    }

    /// True when every BSDF [`Materials::bsdf`] makes is diffuse (no glossy or specular
    /// lobe): what leaving a constant environment to BSDF sampling relies on.
    pub fn all_diffuse(&self) -> bool {
        let glossy_or_specular = BsdfFlags::GLOSSY.union(BsdfFlags::SPECULAR);
        self.materials.iter().all(|m| {
            let flags = self.bsdf_with(m.base_color).flags();
            !flags.intersects(glossy_or_specular)
        })
    }

    /// The base colour of triangle `prim` at texture coordinates `uv`.
    #[inline]
    fn base_color(&self, scene: &Scene, prim: u32, uv: Vec2) -> Vec3 {
        let m = &self.materials[scene.triangle_materials[prim as usize] as usize];
        match &m.base_texture {
            Some(b) => m.base_color * self.lookup(b, uv).truncate(),
            None => m.base_color,
        }
    }

    /// True when the triangle's material emits (on some side).
    #[inline]
    pub fn is_emissive_triangle(&self, scene: &Scene, prim: u32) -> bool {
        self.materials[scene.triangle_materials[prim as usize] as usize]
            .emissive
            .max_element()
            > 0.0
    }

    /// Emitted radiance leaving the surface toward `si.wo` (zero from a back face of a
    /// one-sided emitter).
    #[inline]
    pub fn emitted(&self, scene: &Scene, si: &SurfaceInteraction, uv: Vec2) -> Vec3 {
        let m = &self.materials[scene.triangle_materials[si.prim as usize] as usize];
        if m.emissive.max_element() <= 0.0 || !(si.front_face || m.double_sided) {
            return Vec3::ZERO;
        }
        match &m.emissive_texture {
            Some(b) => m.emissive * self.lookup(b, uv).truncate(),
            None => m.emissive,
        }
    }

    /// Emitted radiance of triangle `prim` at barycentrics (u, v), seen from its front
    /// (`front = true`) or back, for light sampling.
    #[inline]
    pub fn emitted_at(&self, scene: &Scene, prim: u32, bary: Vec2, front: bool) -> Vec3 {
        let m = &self.materials[scene.triangle_materials[prim as usize] as usize];
        if !(front || m.double_sided) {
            return Vec3::ZERO;
        }
        match &m.emissive_texture {
            Some(b) => {
                let [i0, i1, i2] = scene.triangles[prim as usize];
                let uv = (1.0 - bary.x - bary.y) * scene.uvs[i0 as usize]
                    + bary.x * scene.uvs[i1 as usize]
                    + bary.y * scene.uvs[i2 as usize];
                m.emissive * self.lookup(b, uv).truncate()
            }
            None => m.emissive,
        }
    }

    /// (Emitted radiance scale used for light power, two-sided?) of a material: the factor
    /// times the texture's mean.
    pub fn emission_power_factor(&self, material: u32) -> (Vec3, bool) {
        let m = &self.materials[material as usize];
        let scale = match &m.emissive_texture {
            Some(b) => self.images[b.image].average().truncate(),
            None => Vec3::ONE,
        };
        (m.emissive * scale, m.double_sided)
    }
}
