//! Materials at render time: each glTF material prepared into what its [`Bsdf`] and its
//! emission need, and looked up per surface point.
//!
//! | property   | from                                                       | used by       |
//! |------------|------------------------------------------------------------|---------------|
//! | base colour| baseColorFactor × baseColorTexture (sRGB-decoded) × COLOR_0 | the BSDF      |
//! | metallic   | metallicFactor × metallicRoughnessTexture.B (linear)       | the BSDF      |
//! | roughness  | roughnessFactor × metallicRoughnessTexture.G (linear)      | the BSDF      |
//! | iridescence| iridescenceFactor × texture R; film thickness: maximum, or| the BSDF      |
//! |            | mix(minimum, maximum, thickness texture G); film IOR       |               |
//! | anisotropy | anisotropyStrength × texture B; direction: the tangent, or | the BSDF      |
//! |            | the texture's RG, turned by anisotropyRotation             |               |
//! | emission   | emissiveFactor × emissiveTexture × emissive strength;      | lights, paths |
//! |            | the front face only unless the material is double-sided    |               |
//!
//! [`Materials::bsdf`] is the one place that chooses a surface point's BSDF: the glTF
//! metallic-roughness BRDF ([`GltfBrdf`], energy-compensated unless
//! [`MaterialOptions::energy_compensation`] is off), or, under [`MaterialModel::Lambertian`],
//! Lambertian reflection of the base colour (f = ρ/π: the clay look-dev override, and the
//! surface closed-form tests need). [`Materials::prepare`] decodes exactly the textures the
//! chosen integrator and model read: none for ambient occlusion, and for light transport only
//! those of materials some triangle uses.

use std::path::Path;

use std::collections::HashMap;

use glam::{Vec2, Vec3, Vec4};

pub use super::bsdf::DiffuseSampling;
use super::bsdf::{Bsdf, BsdfFlags, Lambertian, LocalBsdf, SurfaceBsdf};
use super::dielectric::{Dielectric, DielectricAlbedoTable, ThinDielectric};
use super::gltf_brdf::GltfBrdf;
use super::interaction::SurfaceInteraction;
use super::layers::{Coat, Layered, Sheen, SheenTable};
use super::microfacet::AlbedoTable;
use crate::sampling::Onb;
use crate::scene::extensions::bind_texture;
use crate::scene::{AnisotropyLayer, Layers, MissingTexture, Scene, TextureRef};
use crate::texture::{transform_uv, Encoding, Image};

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

/// The scattering model every material is rendered with (`--materials`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum MaterialModel {
    /// The glTF 2.0 metallic-roughness BRDF, as the file's materials say.
    #[default]
    Gltf,
    /// Lambertian reflection of the base colour, metallic and roughness ignored: a clay
    /// override for look-dev, and the surface of closed-form tests.
    Lambertian,
}

crate::display_as_value_name!(MaterialModel);

/// How materials are rendered: the choices a render makes beyond what the file says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaterialOptions {
    pub model: MaterialModel,
    /// Compensate the energy single-scattering GGX loses (`--energy-compensation`; see
    /// [`GltfBrdf`]); off renders the specification's model exactly.
    pub energy_compensation: bool,
    /// How Lambertian reflection draws its directions (`--hemisphere`).
    pub diffuse_sampling: DiffuseSampling,
}

impl Default for MaterialOptions {
    fn default() -> Self {
        MaterialOptions {
            model: MaterialModel::Gltf,
            energy_compensation: true,
            diffuse_sampling: DiffuseSampling::Cosine,
        }
    }
}

impl MaterialOptions {
    /// Lambertian reflection, cosine-sampled.
    pub fn lambertian() -> MaterialOptions {
        MaterialOptions {
            model: MaterialModel::Lambertian,
            ..Default::default()
        }
    }
}

#[derive(Clone, Debug)]
struct Prepared {
    base_color: Vec3,
    base_texture: Option<Binding>,
    metallic: f32,
    roughness: f32,
    /// The dielectric part's index of refraction (`KHR_materials_ior`).
    ior: f32,
    /// `KHR_materials_transmission`'s factor and texture (R); 0 and None without.
    transmission: f32,
    transmission_texture: Option<Binding>,
    /// The absorption coefficient inside a transmissive volume (`KHR_materials_volume`);
    /// None for a thin wall, or an opaque material.
    volume: Option<Vec3>,
    /// `KHR_materials_dispersion` of the volume (0: none).
    dispersion: f32,
    /// The layers over the BRDF, their textures bound (glTF model only; none otherwise).
    layers: Layers<Binding>,
    /// B = metallic, G = roughness (bound under the glTF model only).
    metallic_roughness_texture: Option<Binding>,
    /// The tangent-space normal map and its `scale` (both models).
    normal_texture: Option<Binding>,
    normal_scale: f32,
    emissive: Vec3,
    emissive_texture: Option<Binding>,
    double_sided: bool,
}

/// A BSDF type that [`Materials`] can give a surface point as ([`Materials::bsdf_as`]): an
/// integrator generic over it is compiled once per material model from one source, and the
/// instance for [`Lambertian`] holds no other lobe's code (the Lambertian model's path
/// tracer as it was before the glTF BRDF; BENCHMARKS.md, "glTF materials").
pub trait ShadeAs: LocalBsdf {
    /// The BSDF at the surface point.
    fn shade(
        materials: &Materials,
        scene: &Scene,
        si: &SurfaceInteraction,
        uv: Vec2,
    ) -> SurfaceBsdf<Self>;
}

impl ShadeAs for Bsdf {
    #[inline(always)]
    fn shade(
        materials: &Materials,
        scene: &Scene,
        si: &SurfaceInteraction,
        uv: Vec2,
    ) -> SurfaceBsdf<Bsdf> {
        materials.bsdf(scene, si, uv)
    }
}

impl ShadeAs for Lambertian {
    /// Only for a render whose materials are all Lambertian ([`Materials::lambertian`]).
    #[inline(always)]
    fn shade(
        materials: &Materials,
        scene: &Scene,
        si: &SurfaceInteraction,
        uv: Vec2,
    ) -> SurfaceBsdf<Lambertian> {
        debug_assert!(materials.lambertian());
        materials.surface(scene, si, uv, |_, base, _| materials.lambertian_of(base))
    }
}

/// Materials ready for shading.
#[derive(Clone, Debug, Default)]
pub struct Materials {
    materials: Vec<Prepared>,
    images: Vec<Image>,
    options: MaterialOptions,
    /// True when any used material reads a texture (UVs must be interpolated).
    pub textured: bool,
    /// True when the scene has vertex colours (`COLOR_0`), which scale the base colour.
    vertex_colors: bool,
    /// True when some material bounds an absorbing volume ([`Materials::absorption`]).
    pub absorbing: bool,
    /// Each triangle's tangent frames for its normal map ([`Scene::tangent_frames`]); empty
    /// when no material some triangle uses has one.
    tangents: Vec<[Vec4; 3]>,
    /// The textures bound as absent because their images cannot be had.
    missing: Vec<MissingTexture>,
}

impl Materials {
    /// Prepares the scene's materials as `options` say, decoding the textures that `need`
    /// requires. A texture whose image cannot be read or decoded is bound as no texture (the
    /// material renders with its factors alone) and listed in [`Materials::missing_textures`];
    /// an error is only for a texture naming an image the scene does not have.
    pub fn prepare(
        scene: &Scene,
        scene_path: &Path,
        need: Need,
        options: &MaterialOptions,
    ) -> Result<Materials, String> {
        if need == Need::Nothing {
            return Ok(Materials::default());
        }
        let mut used = vec![false; scene.materials.len()];
        for &m in &scene.triangle_materials {
            used[m as usize] = true;
        }
        // One decoded image per (glTF image, encoding): an image bound both as colour and as
        // data is decoded twice. None: the image cannot be had (unreadable, or it does not
        // decode), so every texture that uses it is bound as no texture at all.
        let mut image_slot: HashMap<(usize, Encoding), Option<usize>> = HashMap::new();
        let mut images = Vec::new();
        let mut missing: Vec<MissingTexture> = Vec::new();
        // Binds material `material`'s texture `t`: every texture of every material, the
        // extensions' included, is bound here ([`bind_texture`]).
        let mut bind_one = |material: usize,
                            t: &TextureRef,
                            encoding: Encoding|
         -> Result<Option<Binding>, String> {
            let src = scene.image_source(t.image, scene_path)?;
            let slot = match image_slot.get(&(t.image, encoding)) {
                Some(&slot) => slot,
                None => {
                    let slot = match Image::decode_source(src, encoding) {
                        Ok(image) => {
                            images.push(image);
                            Some(images.len() - 1)
                        }
                        Err(problem) => {
                            missing.push(MissingTexture {
                                image: t.image,
                                material,
                                problem,
                            });
                            None
                        }
                    };
                    image_slot.insert((t.image, encoding), slot);
                    slot
                }
            };
            if slot.is_none() {
                if let Some(first) = missing.iter().find(|m| m.image == t.image) {
                    let also = MissingTexture {
                        material,
                        ..first.clone()
                    };
                    if !missing.contains(&also) {
                        missing.push(also);
                    }
                }
            }
            Ok(slot.map(|image| Binding {
                texture: t.clone(),
                image,
            }))
        };
        let gltf = options.model == MaterialModel::Gltf;
        let mut materials = Vec::with_capacity(scene.materials.len());
        for (i, (m, &is_used)) in scene.materials.iter().zip(&used).enumerate() {
            let mut bind_one = |t: &TextureRef, encoding| bind_one(i, t, encoding);
            let normal_texture = match is_used {
                true => bind_texture(&m.normal_texture, Encoding::Linear, &mut bind_one)?,
                false => None,
            };
            let transmission = &m.transmission;
            let transmission_texture = match is_used && gltf && transmission.factor > 0.0 {
                true => bind_texture(&transmission.texture, Encoding::Linear, &mut bind_one)?,
                false => None,
            };
            let layers = match is_used && gltf {
                true => m.layers.bind(&mut bind_one)?,
                false => Layers::default(),
            };
            let (base_texture, metallic_roughness_texture, emissive_texture) = if is_used {
                let base = bind_texture(&m.base_color_texture, Encoding::Srgb, &mut bind_one)?;
                let metallic_roughness = match gltf {
                    true => bind_texture(
                        &m.metallic_roughness_texture,
                        Encoding::Linear,
                        &mut bind_one,
                    )?,
                    false => None,
                };
                // An emissive texture only matters when the emissive factor is non-zero.
                let emissive = if m.is_emissive() {
                    bind_texture(&m.emissive_texture, Encoding::Srgb, &mut bind_one)?
                } else {
                    None
                };
                (base, metallic_roughness, emissive)
            } else {
                (None, None, None)
            };
            materials.push(Prepared {
                base_color: m.base_color.truncate(),
                base_texture,
                metallic: m.metallic.clamp(0.0, 1.0),
                roughness: m.roughness.clamp(0.0, 1.0),
                ior: m.ior,
                transmission: transmission.factor,
                transmission_texture,
                volume: (transmission.volume)
                    .filter(|_| transmission.factor > 0.0)
                    .map(|v| v.absorption()),
                dispersion: m.dispersion,
                layers,
                metallic_roughness_texture,
                normal_texture,
                normal_scale: m.normal_scale,
                emissive: m.emissive,
                emissive_texture,
                double_sided: m.double_sided,
            });
        }
        if gltf && options.energy_compensation {
            // The compensation's albedo table, made now rather than by the first shading
            // point inside the render (and its timing).
            AlbedoTable::get();
        }
        if materials.iter().any(|m| m.layers.sheen.is_some()) {
            SheenTable::get();
        }
        if gltf && options.energy_compensation && materials.iter().any(|m| m.volume.is_some()) {
            // Rough glass's compensation table (about 0.2 s), likewise before the render.
            DielectricAlbedoTable::get();
        }
        let textured = materials.iter().any(|m| {
            m.base_texture.is_some()
                || m.emissive_texture.is_some()
                || m.metallic_roughness_texture.is_some()
                || m.normal_texture.is_some()
                || m.transmission_texture.is_some()
                || m.layers.textured()
        });
        let tangents = match materials
            .iter()
            .any(|m| m.normal_texture.is_some() || m.layers.needs_tangents())
        {
            true => scene.tangent_frames(),
            false => Vec::new(),
        };
        Ok(Materials {
            images,
            options: *options,
            textured,
            vertex_colors: !scene.colors.is_empty(),
            absorbing: gltf
                && (materials.iter())
                    .any(|m: &Prepared| m.volume.is_some_and(|a| a.max_element() > 0.0)),
            materials,
            tangents,
            missing,
        })
    }

    /// The textures that render as absent (their materials' factors alone) because their
    /// images cannot be read or decoded ([`Scene::missing_texture_warnings`] words them).
    pub fn missing_textures(&self) -> &[MissingTexture] {
        &self.missing
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
        scene.texcoord(si.prim, si.u, si.v)
    }

    /// True when every material renders as Lambertian reflection ([`MaterialModel::Lambertian`]).
    #[inline]
    pub fn lambertian(&self) -> bool {
        self.options.model == MaterialModel::Lambertian
    }

    /// The BSDF at the surface point (`uv`: its texture coordinates, [`Materials::uv`]).
    #[inline]
    pub fn bsdf(&self, scene: &Scene, si: &SurfaceInteraction, uv: Vec2) -> SurfaceBsdf {
        self.surface(scene, si, uv, |m, base, shaded| match self.options.model {
            MaterialModel::Lambertian => Bsdf::Diffuse(self.lambertian_of(base)),
            MaterialModel::Gltf => self.gltf_bsdf(scene, m, base, uv, si, shaded),
        })
    }

    /// The BSDF at the surface point as type `B`: [`Bsdf`] ([`Materials::bsdf`]) under any
    /// model, or [`Lambertian`] when every material is ([`Materials::lambertian`]), for a
    /// caller compiled for that model alone ([`ShadeAs`]).
    #[inline(always)]
    pub fn bsdf_as<B: ShadeAs>(
        &self,
        scene: &Scene,
        si: &SurfaceInteraction,
        uv: Vec2,
    ) -> SurfaceBsdf<B> {
        B::shade(self, scene, si, uv)
    }

    /// The Lambertian model's reflection of base colour `base`.
    #[inline(always)]
    fn lambertian_of(&self, base: Vec3) -> Lambertian {
        Lambertian {
            albedo: base,
            sampling: self.options.diffuse_sampling,
        }
    }

    /// The BSDF that `local` makes of the material at the surface point and its base colour
    /// (factor × texture × COLOR_0), placed in the frame of its shading normal, bent by the
    /// material's normal map if it has one.
    #[inline(always)]
    fn surface<B: LocalBsdf>(
        &self,
        scene: &Scene,
        si: &SurfaceInteraction,
        uv: Vec2,
        local: impl FnOnce(&Prepared, Vec3, &SurfaceInteraction) -> B,
    ) -> SurfaceBsdf<B> {
        let m = &self.materials[scene.triangle_materials[si.prim as usize] as usize];
        let mut base = m.base_color;
        if let Some(b) = &m.base_texture {
            base *= self.lookup(b, uv).truncate();
        }
        if self.vertex_colors {
            base *= vertex_color(scene, si.prim, si.u, si.v).truncate();
        }
        let mapped;
        let shaded = match &m.normal_texture {
            None => si,
            Some(b) => {
                mapped = self.normal_mapped(scene, si, b, m.normal_scale, uv);
                &mapped
            }
        };
        SurfaceBsdf::new(local(m, base, shaded), shaded)
    }

    /// The tangent frame [T, B, N] at surface point `si` in world space (glTF 2.0, "Meshes":
    /// the interpolated vertex normal N, the tangent T made orthogonal to it, B = cross(N, T)
    /// × the tangent's w), N on the surface's front side; None where the triangle has no
    /// tangent frame or it is degenerate.
    fn tangent_frame(&self, scene: &Scene, si: &SurfaceInteraction) -> Option<[Vec3; 3]> {
        let corners = self.tangents.get(si.prim as usize)?;
        let (u, v) = (si.u, si.v);
        let t4 = (1.0 - u - v) * corners[0] + u * corners[1] + v * corners[2];
        // The surface's own normal, before the two-sided rule turned it toward the ray.
        let front_ng = if si.front_face { si.ng } else { -si.ng };
        // The frame in world space: an instance carries the normal by its inverse transpose
        // and the tangent by its linear map, and a mirroring one turns the frame's handedness.
        let n = scene
            .placed_shading_normal(si.prim, si.inst, u, v)
            .unwrap_or(front_ng);
        let tangent = scene.vector_to_world(si.inst, t4.truncate());
        let t = tangent - n * n.dot(tangent);
        if t.length_squared() < 1e-12 || !t.is_finite() {
            return None;
        }
        let t = t.normalize();
        let left_handed = (t4.w < 0.0) != scene.mirrors(si.inst);
        let b = n.cross(t) * if left_handed { -1.0 } else { 1.0 };
        Some([t, b, n])
    }

    /// The direction of `anisotropy`'s stretch at surface point `si`, in the shading frame of
    /// `shaded` (KHR_materials_anisotropy: the texture's RG mapped to [−1, 1]² or else the
    /// tangent, turned by the rotation, in the tangent frame), and its strength (× the
    /// texture's B); None without a tangent frame.
    fn anisotropy_at(
        &self,
        scene: &Scene,
        anisotropy: &AnisotropyLayer<Binding>,
        si: &SurfaceInteraction,
        shaded: &SurfaceInteraction,
        uv: Vec2,
    ) -> Option<(f32, Vec3)> {
        let [t, b, _] = self.tangent_frame(scene, si)?;
        let (strength, turned) = anisotropy.at(|binding| self.lookup(binding, uv));
        let world = t * turned.x + b * turned.y;
        Some((strength, Onb::from_normal(shaded.ns).to_local(world)))
    }

    /// The surface point with its shading normal bent by normal map `map` at `uv` (glTF 2.0,
    /// "normalTexture": n = normalize(T x + B y + N z) with (x, y, z) = (2 texel − 1) ×
    /// (scale, scale, 1), B = cross(N, T) w), on the side the ray arrived from. A strongly
    /// bent normal mirrors wo below the geometric surface (or turns away from it), where
    /// `SurfaceBsdf` gives nothing: smooth surfaces would show black rims. So the normal is
    /// turned toward the geometric normal just enough that wo's mirror direction stays
    /// above the surface ([`valid_reflection_normal`], the rule Cycles applies to shading
    /// normals). Light still never passes through the surface: `SurfaceBsdf` gives nothing
    /// to directions below the geometric surface, whatever the shading normal.
    fn normal_mapped(
        &self,
        scene: &Scene,
        si: &SurfaceInteraction,
        map: &Binding,
        scale: f32,
        uv: Vec2,
    ) -> SurfaceInteraction {
        let Some([t, b, n]) = self.tangent_frame(scene, si) else {
            return *si;
        };
        let texel = self.lookup(map, uv);
        let m = Vec3::new(
            (2.0 * texel.x - 1.0) * scale,
            (2.0 * texel.y - 1.0) * scale,
            2.0 * texel.z - 1.0,
        );
        let mut bent = (t * m.x + b * m.y + n * m.z).normalize_or_zero();
        if bent == Vec3::ZERO {
            return *si;
        }
        if si.ns.dot(n) < 0.0 {
            bent = -bent;
        }
        SurfaceInteraction {
            ns: valid_reflection_normal(si.ng, si.wo, bent),
            ..*si
        }
    }

    /// The glTF model's BSDF of material `m` at `uv` of surface point `si`, of base colour
    /// `base`: kept out of line, so that the Lambertian model's path stays as short as it was
    /// before the glTF BRDF.
    ///
    /// A transmissive material (`KHR_materials_transmission`) is, by the extension's model,
    /// mix(metallic-roughness BRDF, dielectric interface, w) with w = transmission ×
    /// (1 − metallic): the interface takes the share of the dielectric's diffuse lobe that
    /// transmission gives it. Where 0 < w < 1, the surface point takes one of the two with
    /// probability w (pbrt-v4's MixMaterial; the choice a hash of the point, so the same for
    /// every query of it), the BRDF's metallic raised to metallic / (1 − w) so that the mix
    /// keeps the metal's share. The interface refracts where the material bounds a volume
    /// (`KHR_materials_volume`): relative IOR `ior` entering at the front face, 1 / `ior`
    /// leaving; otherwise it is a thin wall. Its tint is the base colour.
    ///
    /// A sheen and a clear coat (`KHR_materials_sheen`, `KHR_materials_clearcoat`) layer the
    /// BRDF ([`Layered`]); not the glass, which renders without them. The coat's normal is its
    /// own normal map's, else the vertex normal `si.ns` (not the base's map, which bent
    /// `shaded`), in the frame of `shaded`.
    #[inline(never)]
    fn gltf_bsdf(
        &self,
        scene: &Scene,
        m: &Prepared,
        base: Vec3,
        uv: Vec2,
        si: &SurfaceInteraction,
        shaded: &SurfaceInteraction,
    ) -> Bsdf {
        let (mut metallic, mut roughness) = (m.metallic, m.roughness);
        if let Some(b) = &m.metallic_roughness_texture {
            let t = self.lookup(b, uv);
            metallic *= t.z;
            roughness *= t.y;
        }
        if m.transmission > 0.0 {
            let mut transmission = m.transmission;
            if let Some(b) = &m.transmission_texture {
                transmission *= self.lookup(b, uv).x;
            }
            let w = transmission * (1.0 - metallic);
            if w > 0.0 && (w >= 1.0 || point_choice(si) < w) {
                let alpha = roughness * roughness;
                let compensated = self.options.energy_compensation;
                return match m.volume {
                    Some(_) => {
                        let eta = if si.front_face { m.ior } else { 1.0 / m.ior };
                        let glass = Dielectric::new(eta, alpha, base).with_dispersion(m.dispersion);
                        Bsdf::Glass(match compensated {
                            true => glass.with_energy_compensation(),
                            false => glass,
                        })
                    }
                    None => {
                        let thin = ThinDielectric::new(m.ior, alpha, base);
                        Bsdf::ThinGlass(match compensated {
                            true => thin.with_energy_compensation(),
                            false => thin,
                        })
                    }
                };
            }
            if w > 0.0 {
                metallic = (metallic / (1.0 - w)).min(1.0);
            }
        }
        let brdf = self.bsdf_with(base, metallic, roughness, m.ior);
        if m.layers.is_empty() {
            return brdf;
        }
        let Bsdf::MetallicRoughness(mut brdf) = brdf else {
            return brdf;
        };
        // Each layer at this point, its textures read by `lookup` (scene::extensions).
        let lookup = |b: &Binding| self.lookup(b, uv);
        let Layers {
            specular,
            clearcoat,
            sheen,
            anisotropy,
            iridescence,
        } = &m.layers;
        if let Some(a) = anisotropy {
            if let Some((strength, direction)) = self.anisotropy_at(scene, a, si, shaded, uv) {
                brdf = brdf.with_anisotropy(strength, direction);
            }
        }
        if let Some(i) = iridescence {
            let (factor, thickness) = i.at(lookup);
            // Under a clear coat the film's outside is the coat (KHR_materials_iridescence,
            // "Clearcoat": index 1.5).
            let outside = if clearcoat.is_some() { 1.5 } else { 1.0 };
            brdf = brdf.with_iridescence(factor, i.ior, thickness, outside);
        }
        if specular.is_none() && clearcoat.is_none() && sheen.is_none() {
            return Bsdf::MetallicRoughness(brdf);
        }
        if let Some(sp) = specular {
            let (weight, color) = sp.at(lookup);
            brdf = brdf.with_specular(weight, color);
            if clearcoat.is_none() && sheen.is_none() {
                return Bsdf::MetallicRoughness(brdf);
            }
        }
        let sheen = sheen.as_ref().map(|s| {
            let (color, roughness) = s.at(lookup);
            Sheen::new(color, roughness)
        });
        let coat = clearcoat.as_ref().map(|c| {
            let (weight, roughness) = c.at(lookup);
            let normal = match &c.normal_texture {
                Some(b) => self.normal_mapped(scene, si, b, c.normal_scale, uv).ns,
                None => si.ns,
            };
            let local = match normal == shaded.ns {
                true => Vec3::Z,
                false => Onb::from_normal(shaded.ns).to_local(normal).normalize(),
            };
            Coat::new(weight, roughness, local)
        });
        Bsdf::Layered(Layered::new(brdf, sheen, coat))
    }

    /// The absorption coefficient of the medium inside triangle `prim`'s material, where it
    /// bounds a transmissive volume (`KHR_materials_volume`) that absorbs.
    #[inline]
    pub fn absorption(&self, scene: &Scene, prim: u32) -> Option<Vec3> {
        let m = &self.materials[scene.triangle_materials[prim as usize] as usize];
        m.volume.filter(|a| a.max_element() > 0.0)
    }

    /// The BSDF of base colour `base`, `metallic`, `roughness` and index of refraction `ior`:
    /// the one place that chooses a variant.
    #[inline]
    fn bsdf_with(&self, base: Vec3, metallic: f32, roughness: f32, ior: f32) -> Bsdf {
        match self.options.model {
            MaterialModel::Lambertian => Bsdf::Diffuse(self.lambertian_of(base)),
            MaterialModel::Gltf => {
                // glTF's own IOR keeps the constant 0.04 (f32's (0.5/2.5)² differs in its
                // last bit), so that files without the extension render as before.
                let brdf = match ior == crate::scene::DEFAULT_IOR {
                    true => GltfBrdf::new(base, metallic, roughness),
                    false => GltfBrdf::new(base, metallic, roughness).with_ior(ior),
                };
                Bsdf::MetallicRoughness(match self.options.energy_compensation {
                    true => brdf,
                    false => brdf.single_scattering(),
                })
            }
        }
    }

    /// True when every BSDF [`Materials::bsdf`] makes is diffuse (no glossy or specular
    /// lobe): what leaving a constant environment to BSDF sampling relies on.
    pub fn all_diffuse(&self) -> bool {
        let glossy_or_specular = BsdfFlags::GLOSSY.union(BsdfFlags::SPECULAR);
        self.materials.iter().all(|m| {
            // A texture scales metallic and roughness by [0, 1]: the flags at the factors and
            // at the texture's extremes cover every point.
            [
                (m.metallic, m.roughness),
                (0.0, 0.0),
                (m.metallic, 0.0),
                (0.0, m.roughness),
            ]
            .iter()
            .all(|&(metallic, roughness)| {
                let flags = (self.bsdf_with(m.base_color, metallic, roughness, m.ior)).flags();
                !flags.intersects(glossy_or_specular)
            })
        })
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

/// Shading normal `n`, turned toward geometric normal `ng` (both on `wo`'s side) just enough
/// that wo's mirror direction r = 2 (n·wo) n − wo rises at least t = min(0.9 wo·ng, 0.01)
/// above the surface: unchanged where it already does.
///
/// In the frame z = ng, x = n's part across ng, the new normal is (√(1 − z²), 0, √z²) with
/// r·ng = 2 (n·wo) n_z − wo_z = t. Writing s = n_z², n·wo = √(1 − s) wo_x + √s wo_z; squared,
/// 4 s (1 − s) wo_x² = (t + wo_z − 2 s wo_z)², the quadratic
/// 4 (wo_x² + wo_z²) s² − 4 (wo_x² + wo_z² + t wo_z) s + (t + wo_z)² = 0,
/// whose root is the one that satisfies the equation before squaring (the sign of wo_x).
pub fn valid_reflection_normal(ng: Vec3, wo: Vec3, n: Vec3) -> Vec3 {
    let wo_z = wo.dot(ng);
    let t = (0.9 * wo_z).min(0.01);
    if wo_z <= 0.0 || (2.0 * n.dot(wo) * n - wo).dot(ng) >= t {
        return n;
    }
    let x = n - n.dot(ng) * ng;
    let x = match x.length_squared() > 1e-12 {
        true => x.normalize(),
        // n along ng: its reflection is wo's own, which is above: not reached.
        false => return n,
    };
    let wo_x = wo.dot(x);
    let a = wo_x * wo_x + wo_z * wo_z;
    let b = a + t * wo_z;
    let c = (t + wo_z) * (t + wo_z);
    let root = (b * b - a * c).max(0.0).sqrt();
    let residual = |s: f32| {
        let (nx, nz) = ((1.0 - s).max(0.0).sqrt(), s.max(0.0).sqrt());
        (2.0 * (nx * wo_x + nz * wo_z) * nz - wo_z - t).abs()
    };
    let (s1, s2) = ((b + root) / (2.0 * a), (b - root) / (2.0 * a));
    let s = match residual(s1) <= residual(s2) {
        true => s1,
        false => s2,
    }
    .clamp(0.0, 1.0);
    ((1.0 - s).sqrt() * x + s.sqrt() * ng).normalize()
}

/// The interpolated `COLOR_0` of triangle `prim` at barycentrics (u, v).
#[inline]
fn vertex_color(scene: &Scene, prim: u32, u: f32, v: f32) -> Vec4 {
    let [a, b, c] = scene.triangles[prim as usize];
    (1.0 - u - v) * scene.colors[a as usize]
        + u * scene.colors[b as usize]
        + v * scene.colors[c as usize]
}

/// A number in [0, 1) of a surface point alone (its position's bits and its triangle):
/// which of two mixed materials the point takes ([`Materials::gltf_bsdf`]), the same for every
/// query of the point and every thread.
#[inline]
fn point_choice(si: &SurfaceInteraction) -> f32 {
    let mut h = si.prim as u64 ^ 0x9e37_79b9_7f4a_7c15;
    for v in si.p.to_array() {
        // SplitMix64's finaliser over each coordinate's bits.
        h = (h ^ v.to_bits() as u64).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 31)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^= h >> 29;
    }
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Over many normals, views and surfaces: a normal whose mirror direction of wo already
    /// rises t = min(0.9 wo·ng, 0.01) above the surface is kept bit for bit; any other comes
    /// back a unit vector whose mirror direction rises exactly t (to rounding), between the
    /// normal and ng.
    #[test]
    fn valid_reflection_normals_keep_the_mirror_direction_above_the_surface() {
        let mut state = 0x9e37_79b9_u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        let sphere = |next: &mut dyn FnMut() -> f32| {
            let z = 2.0 * next() - 1.0;
            let phi = std::f32::consts::TAU * next();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        };
        let (mut kept, mut turned) = (0, 0);
        for _ in 0..20_000 {
            let ng = sphere(&mut next);
            let mut wo = sphere(&mut next);
            if wo.dot(ng) < 0.0 {
                wo = -wo;
            }
            let mut n = sphere(&mut next);
            if n.dot(ng) < 0.0 {
                n = -n;
            }
            let t = (0.9 * wo.dot(ng)).min(0.01);
            let rises = |n: Vec3| (2.0 * n.dot(wo) * n - wo).dot(ng);
            let out = valid_reflection_normal(ng, wo, n);
            if rises(n) >= t {
                assert_eq!(out, n);
                kept += 1;
                continue;
            }
            turned += 1;
            assert!((out.length() - 1.0).abs() < 1e-4, "{out}");
            assert!((rises(out) - t).abs() < 2e-3, "rises {} t {t}", rises(out));
            assert!(out.dot(ng) >= n.dot(ng) - 1e-5, "turned away from ng");
            assert!(out.dot(wo) > 0.0);
        }
        assert!(kept > 1000 && turned > 1000, "kept {kept}, turned {turned}");
    }
}
