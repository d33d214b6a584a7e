//! Surface appearance at render time: the Lambertian BSDF (f = ρ/π) with base colour =
//! baseColorFactor × baseColorTexture, and emission = emissiveFactor × emissiveTexture ×
//! strength, from the front face only unless the material is double-sided.
//!
//! [`Materials::prepare`] decodes exactly the textures the chosen integrator reads: none for
//! ambient occlusion, and for light transport only those of materials some triangle uses.

use std::path::Path;

use glam::{Vec2, Vec3, Vec4};

use crate::interaction::SurfaceInteraction;
use crate::sampling::warps::{square_to_cosine_hemisphere, square_to_uniform_hemisphere};
use crate::sampling::Onb;
use crate::scene::{Scene, TextureRef};
use crate::texture::{transform_uv, Image};

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

#[derive(Clone, Debug)]
struct Prepared {
    base_color: Vec3,
    base_texture: Option<Binding>,
    emissive: Vec3,
    emissive_texture: Option<Binding>,
    double_sided: bool,
}

/// Materials ready for shading.
#[derive(Clone, Debug, Default)]
pub struct Materials {
    materials: Vec<Prepared>,
    images: Vec<Image>,
    /// True when any used material reads a texture (UVs must be interpolated).
    pub textured: bool,
}

impl Materials {
    /// Prepares the scene's materials, decoding the textures that `need` requires.
    pub fn prepare(scene: &Scene, scene_path: &Path, need: Need) -> Result<Materials, String> {
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
        self.uv_at(scene, si.prim, si.u, si.v)
    }

    /// [`Materials::uv`] at barycentrics (u, v) of triangle `prim`.
    #[inline]
    pub fn uv_at(&self, scene: &Scene, prim: u32, u: f32, v: f32) -> Vec2 {
        if !self.textured {
            return Vec2::ZERO;
        }
        let [a, b, c] = scene.triangles[prim as usize];
        (1.0 - u - v) * scene.uvs[a as usize]
            + u * scene.uvs[b as usize]
            + v * scene.uvs[c as usize]
    }

    /// Diffuse reflectance ρ at the surface point.
    #[inline]
    pub fn albedo(&self, scene: &Scene, si: &SurfaceInteraction, uv: Vec2) -> Vec3 {
        self.albedo_of(scene, si.prim, uv)
    }

    /// [`Materials::albedo`] of triangle `prim`.
    #[inline]
    pub fn albedo_of(&self, scene: &Scene, prim: u32, uv: Vec2) -> Vec3 {
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
        self.emitted_by(scene, si.prim, si.front_face, uv)
    }

    /// [`Materials::emitted`] by triangle `prim`, seen from its front face or not.
    #[inline]
    pub fn emitted_by(&self, scene: &Scene, prim: u32, front_face: bool, uv: Vec2) -> Vec3 {
        let m = &self.materials[scene.triangle_materials[prim as usize] as usize];
        if m.emissive.max_element() <= 0.0 || !(front_face || m.double_sided) {
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

/// The Lambertian BSDF at a surface point, in the frame of the shading normal. It samples
/// directions by the cosine (the default, proportional to f·cos θ) or uniformly over the
/// hemisphere (for comparisons).
#[derive(Clone, Copy, Debug)]
pub struct Lambertian {
    pub albedo: Vec3,
    frame: Onb,
    ng: Vec3,
    uniform: bool,
}

impl Lambertian {
    #[inline]
    pub fn new(albedo: Vec3, si: &SurfaceInteraction) -> Lambertian {
        Lambertian {
            albedo,
            frame: Onb::from_normal(si.ns),
            ng: si.ng,
            uniform: false,
        }
    }

    /// The same BSDF, sampling directions uniformly over the hemisphere (pdf 1/2π).
    #[inline]
    pub fn with_uniform_sampling(self) -> Lambertian {
        Lambertian {
            uniform: true,
            ..self
        }
    }

    /// f(wo, wi)·|cos θi| for a direction `wi` (reflection only: `wi` must leave on the side
    /// of the geometric normal the ray came from).
    #[inline]
    pub fn f_cos(&self, wi: Vec3) -> Vec3 {
        let cos = wi.dot(self.frame.n);
        if cos <= 0.0 || wi.dot(self.ng) <= 0.0 {
            return Vec3::ZERO;
        }
        self.albedo * (cos * std::f32::consts::FRAC_1_PI)
    }

    /// The solid-angle pdf of [`Lambertian::sample`] for `wi`.
    #[inline]
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let cos = wi.dot(self.frame.n);
        if cos <= 0.0 || wi.dot(self.ng) <= 0.0 {
            0.0
        } else if self.uniform {
            0.5 * std::f32::consts::FRAC_1_PI
        } else {
            cos * std::f32::consts::FRAC_1_PI
        }
    }

    /// A direction around the shading normal (cosine-weighted, or uniform), with its pdf;
    /// `None` when it falls below the geometric surface or on the horizon.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let local = if self.uniform {
            square_to_uniform_hemisphere(u)
        } else {
            square_to_cosine_hemisphere(u)
        };
        let wi = self.frame.to_world(local);
        let pdf = self.pdf(wi);
        (pdf > 0.0).then_some((wi, pdf))
    }
}
