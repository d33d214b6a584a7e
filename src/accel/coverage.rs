//! Alpha coverage: where a surface exists for rays (glTF 2.0, "Alpha Coverage").
//!
//! A triangle's alpha at a point is `baseColorFactor.a × baseColorTexture.a`, the texture read
//! at the point's TEXCOORD_0 exactly as the base colour is (the texture transform, the
//! sampler's wrap modes, bilinear filtering; [`crate::shading::Materials`]), times the
//! interpolated `COLOR_0` alpha where the scene has vertex colours. By the material's
//! `alphaMode`:
//!
//! | mode            | the surface stops a ray                                          |
//! |-----------------|------------------------------------------------------------------|
//! | `OPAQUE`        | always: alpha is ignored                                         |
//! | `MASK` (cutoff) | where alpha ≥ cutoff; elsewhere it is a hole                     |
//! | `BLEND`         | with probability alpha (stochastic coverage, Enderton et al. 2010) |
//!
//! BLEND's coin is a hash of the triangle, the instance it was reached through, and the
//! ray's key ([`ray_key`]: a 32-bit hash of the world-space origin and direction bits), not a
//! random number drawn in the integrator: the answer is a pure function of the ray, so a
//! render does not depend on the thread count or the schedule, both backends answer alike,
//! a ray asked twice (Embree may run a filter more than once on one hit) gets one answer, and
//! camera, shadow and AO rays all meet the same partial surface in the mean. The ray's extent
//! does not enter: a shadow ray toward a light and an unbounded ray along the same line meet
//! the same surface. Two rays that differ in any bit of their origin or direction flip
//! independent coins (but for key collisions, one pair in 2³²), and so do two instances of a
//! mesh. The key is computed once from the ray the caller traces and travels with it (in
//! Embree's ray id), because inside an instance the backends see the ray in the mesh's own
//! space, whose bits differ.
//!
//! Why here, beside the backends and not in `shading`: whether a hit exists is the
//! acceleration structure's answer, which both backends must give alike (Embree through its
//! filter callbacks, obvhs inside its traversal), and which no integrator must ever see a hole
//! in. It borrows only the texture lookup from [`crate::texture`].
//!
//! [`AlphaCoverage::build`] decodes only the base colour images of the MASK and BLEND
//! materials that some triangle uses, keeps their alpha channel alone, and builds nothing for
//! a scene without such materials ([`crate::scene::SceneSummary::alpha_tested_triangles`]).

use std::path::Path;

use glam::Vec2;

use super::Ray;
use crate::sampling::hash::{hash_words, unit_f32};
use crate::scene::{AlphaMode, Encoding, MissingTexture, Scene, TextureRef};
use crate::texture::{transform_uv, Image};

/// `slot` of a triangle that is not alpha-tested.
const NOT_TESTED: u32 = u32::MAX;

/// Salt of BLEND's coverage hash, so that it shares no values with the samplers' hashes.
const BLEND_SALT: u64 = 0x616c_7068_615f_626c; // "alpha_bl"
const RAY_KEY_SALT: u64 = 0x7261_795f_6b65_7921; // "ray_key!"

/// Which surfaces of a scene let rays through where, by alpha.
#[derive(Clone, Debug)]
pub struct AlphaCoverage {
    /// For each scene triangle, its index into `tested`, or [`NOT_TESTED`].
    slot: Vec<u32>,
    tested: Vec<TestedTriangle>,
    /// The coverage rules of the alpha-tested materials.
    rules: Vec<Rule>,
    /// The alpha channels of the decoded base colour images.
    images: Vec<Image<f32>>,
    /// True when some rule BLENDs ([`AlphaCoverage::blends`]).
    blends: bool,
}

/// What an alpha-tested triangle needs to look its alpha up.
#[derive(Clone, Copy, Debug)]
struct TestedTriangle {
    /// Index into `AlphaCoverage::rules`.
    rule: u32,
    /// TEXCOORD_0 of its three vertices.
    uv: [Vec2; 3],
    /// `COLOR_0` alpha of its three vertices (1 without vertex colours).
    vertex_alpha: [f32; 3],
}

impl TestedTriangle {
    /// Alpha at barycentrics (u, v): the rule's factor × texture, times the interpolated
    /// `COLOR_0` alpha.
    #[inline]
    fn alpha(&self, rule: &Rule, images: &[Image<f32>], u: f32, v: f32) -> f32 {
        let w = 1.0 - u - v;
        let uv = w * self.uv[0] + u * self.uv[1] + v * self.uv[2];
        let vertex = w * self.vertex_alpha[0] + u * self.vertex_alpha[1] + v * self.vertex_alpha[2];
        rule.alpha(images, uv) * vertex
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Cut {
    /// Covered where alpha ≥ the cutoff.
    Mask(f32),
    /// Covered with probability alpha.
    Blend,
}

/// The coverage of one material.
#[derive(Clone, Debug)]
struct Rule {
    cut: Cut,
    /// `baseColorFactor.a`.
    factor: f32,
    /// The base colour texture, its `image` an index into `AlphaCoverage::images`.
    texture: Option<TextureRef>,
}

impl Rule {
    /// Alpha at texture coordinates `uv`.
    #[inline]
    fn alpha(&self, images: &[Image<f32>], uv: Vec2) -> f32 {
        // COLOR_0's alpha, the third factor, multiplies in per triangle (`AlphaCoverage::alpha`).
        match &self.texture {
            Some(t) => {
                self.factor * images[t.image].bilinear(transform_uv(t, uv), t.wrap_s, t.wrap_t)
            }
            None => self.factor,
        }
    }

    /// True when the rule covers every point whatever the texture, which is the case when
    /// the texture's alpha is 1 at every texel (`texture_alpha_is_one`): bilinear filtering
    /// of ones gives exactly 1 ((1 − f) + f rounds to 1 for f in [0, 1]), so alpha is the
    /// factor everywhere.
    fn always_covers(&self, texture_alpha_is_one: bool) -> bool {
        if self.texture.is_some() && !texture_alpha_is_one {
            return false;
        }
        match self.cut {
            Cut::Mask(cutoff) => self.factor >= cutoff,
            Cut::Blend => self.factor >= 1.0,
        }
    }
}

/// The key of `ray` for BLEND's coin: a hash of its origin and direction bits (world space,
/// as the caller traces it).
#[inline]
pub fn ray_key(ray: &Ray) -> u32 {
    let bits = |a: f32, b: f32| u64::from(a.to_bits()) | u64::from(b.to_bits()) << 32;
    let (o, d) = (ray.org, ray.dir);
    hash_words(&[RAY_KEY_SALT, bits(o.x, o.y), bits(o.z, d.x), bits(d.y, d.z)]) as u32
}

/// A uniform number in (0, 1) for BLEND's coin at triangle `prim` of instance `inst`
/// ([`crate::scene::NO_INSTANCE`] outside instances) along the ray of key `key` ([`ray_key`]).
#[inline]
fn blend_coin(prim: u32, inst: u32, key: u32) -> f32 {
    unit_f32(hash_words(&[
        BLEND_SALT ^ u64::from(prim),
        u64::from(inst) | u64::from(key) << 32,
    ]))
}

impl AlphaCoverage {
    /// The alpha coverage of `scene`'s triangles, or `None` when none is alpha-tested (the
    /// scene's summary counts no [`crate::scene::Material::may_cut_holes`] triangle, or every
    /// texture of such a material turns out to have alpha 1 everywhere and its factor
    /// covers). Decodes the base colour images of the MASK and BLEND materials that
    /// triangles use; `scene_path` names the scene in errors. A base colour image that
    /// cannot be read or decoded counts as no texture (the factor's alpha alone) and is added
    /// to `missing`, as shading binds it ([`crate::shading::Materials::missing_textures`]).
    pub fn build(
        scene: &Scene,
        scene_path: &Path,
        missing: &mut Vec<MissingTexture>,
    ) -> Result<Option<AlphaCoverage>, String> {
        if scene.summary.alpha_tested_triangles == 0 {
            return Ok(None);
        }
        let mut used = vec![false; scene.materials.len()];
        for &m in &scene.triangle_materials {
            used[m as usize] = true;
        }
        let mut images: Vec<Image<f32>> = Vec::new();
        // Each image's alpha channel in `images`: None where not decoded yet, Some(None)
        // where it cannot be.
        let mut image_slot: Vec<Option<Option<usize>>> = vec![None; scene.images.len()];
        // Each material's index into `rules`, or NOT_TESTED.
        let mut material_rule = vec![NOT_TESTED; scene.materials.len()];
        let mut rules = Vec::new();
        // Materials some of whose triangles have a vertex alpha below 1 (under MASK or BLEND).
        let mut vertex_alpha = vec![false; scene.materials.len()];
        for (&m, &tri) in scene.triangle_materials.iter().zip(&scene.triangles) {
            if !vertex_alpha[m as usize] && scene.vertex_alpha_below_one(tri) {
                vertex_alpha[m as usize] = true;
            }
        }
        for (i, m) in scene.materials.iter().enumerate() {
            if !used[i] || !(m.may_cut_holes() || vertex_alpha[i]) {
                continue;
            }
            let cut = match m.alpha_mode {
                AlphaMode::Opaque => continue,
                AlphaMode::Mask(cutoff) => Cut::Mask(cutoff),
                AlphaMode::Blend => Cut::Blend,
            };
            let slot = match &m.base_color_texture {
                None => None,
                Some(t) => {
                    let src = scene.image_source(t.image, scene_path)?;
                    let slot = match image_slot[t.image] {
                        Some(slot) => slot,
                        None => {
                            let slot = match Image::decode_source(src, Encoding::Srgb) {
                                Ok(image) => {
                                    images.push(image.alpha());
                                    Some(images.len() - 1)
                                }
                                Err(problem) => {
                                    missing.push(MissingTexture {
                                        image: t.image,
                                        material: i,
                                        problem,
                                    });
                                    None
                                }
                            };
                            image_slot[t.image] = Some(slot);
                            slot
                        }
                    };
                    if slot.is_none() {
                        if let Some(first) = missing.iter().find(|x| x.image == t.image) {
                            let also = MissingTexture {
                                material: i,
                                ..first.clone()
                            };
                            if !missing.contains(&also) {
                                missing.push(also);
                            }
                        }
                    }
                    slot.map(|slot| (t, slot))
                }
            };
            let (texture, alpha_is_one) = match slot {
                None => (None, true),
                Some((t, slot)) => (
                    Some(TextureRef {
                        image: slot,
                        ..t.clone()
                    }),
                    images[slot].texels.iter().all(|&a| a == 1.0),
                ),
            };
            let rule = Rule {
                cut,
                factor: m.base_color.w,
                texture,
            };
            if rule.always_covers(alpha_is_one) && !vertex_alpha[i] {
                continue;
            }
            material_rule[i] = rules.len() as u32;
            rules.push(rule);
        }
        let mut slot = vec![NOT_TESTED; scene.triangles.len()];
        let mut tested = Vec::new();
        for (t, (&m, tri)) in scene
            .triangle_materials
            .iter()
            .zip(&scene.triangles)
            .enumerate()
        {
            let rule = material_rule[m as usize];
            if rule == NOT_TESTED {
                continue;
            }
            slot[t] = tested.len() as u32;
            tested.push(TestedTriangle {
                rule,
                uv: tri.map(|v| scene.uvs.get(v as usize).copied().unwrap_or(Vec2::ZERO)),
                vertex_alpha: tri.map(|v| scene.colors.get(v as usize).map_or(1.0, |c| c.w)),
            });
        }
        if tested.is_empty() {
            return Ok(None);
        }
        Ok(Some(AlphaCoverage {
            slot,
            tested,
            blends: rules.iter().any(|r| matches!(r.cut, Cut::Blend)),
            rules,
            images,
        }))
    }

    /// True when triangle `prim`'s hits are tested ([`AlphaCoverage::covers`] may say no);
    /// false for the triangles that always stop rays.
    #[inline]
    pub fn tests(&self, prim: u32) -> bool {
        self.slot
            .get(prim as usize)
            .is_some_and(|&s| s != NOT_TESTED)
    }

    /// How many triangles are alpha-tested.
    pub fn tested_triangles(&self) -> usize {
        self.tested.len()
    }

    /// Alpha of triangle `prim` at barycentrics (u, v) (p = (1 − u − v)·p0 + u·p1 + v·p2),
    /// or `None` for a triangle that is not alpha-tested.
    #[inline]
    pub fn alpha(&self, prim: u32, u: f32, v: f32) -> Option<f32> {
        let &slot = self.slot.get(prim as usize)?;
        let t = self.tested.get(slot as usize)?;
        let rule = &self.rules[t.rule as usize];
        Some(t.alpha(rule, &self.images, u, v))
    }

    /// True when the hit of the ray of key `key` ([`ray_key`]) with triangle `prim`, reached
    /// through instance `inst` ([`crate::scene::NO_INSTANCE`] outside instances), at barycentrics (u, v)
    /// stops the ray; false where the surface is a hole for this ray (BLEND's coin, see the
    /// module docs). Never panics (it runs inside Embree's callbacks): a triangle it does not
    /// know is covered.
    #[inline]
    pub fn covers(&self, prim: u32, inst: u32, u: f32, v: f32, key: u32) -> bool {
        let Some(&slot) = self.slot.get(prim as usize) else {
            return true;
        };
        let Some(t) = self.tested.get(slot as usize) else {
            return true;
        };
        let rule = &self.rules[t.rule as usize];
        let alpha = t.alpha(rule, &self.images, u, v);
        match rule.cut {
            Cut::Mask(cutoff) => alpha >= cutoff,
            Cut::Blend => blend_coin(prim, inst, key) < alpha,
        }
    }

    /// True when some tested triangle BLENDs: its coin reads the ray's key ([`ray_key`]).
    #[inline]
    pub fn blends(&self) -> bool {
        self.blends
    }

    /// The probability that a ray meeting triangle `prim` at barycentrics (u, v) stops there
    /// ([`AlphaCoverage::covers`] over rays): 1 where the triangle is not alpha-tested, MASK's
    /// 0 or 1, BLEND's alpha (its coin is uniform in (0, 1)). Light sampling weighs an
    /// alpha-tested emitter's radiance by it, so that it agrees in expectation with the rays
    /// that meet the emitter, whose holes let them through.
    #[inline]
    pub fn stopping_fraction(&self, prim: u32, u: f32, v: f32) -> f32 {
        let Some(&slot) = self.slot.get(prim as usize) else {
            return 1.0;
        };
        let Some(t) = self.tested.get(slot as usize) else {
            return 1.0;
        };
        let rule = &self.rules[t.rule as usize];
        let alpha = t.alpha(rule, &self.images, u, v);
        match rule.cut {
            Cut::Mask(cutoff) => f32::from(u8::from(alpha >= cutoff)),
            Cut::Blend => alpha.clamp(0.0, 1.0),
        }
    }

    /// Bytes the coverage holds (alpha images and per-triangle data).
    pub fn memory(&self) -> usize {
        use std::mem::size_of_val;
        size_of_val(self.slot.as_slice())
            + size_of_val(self.tested.as_slice())
            + self
                .images
                .iter()
                .map(|i| size_of_val(i.texels.as_slice()))
                .sum::<usize>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{ImageSource, Material, Wrap, NO_INSTANCE};
    use glam::{Vec3, Vec4};

    /// A 2×1 RGBA PNG: a left texel of alpha `left`, a right one of alpha 255.
    fn png_2x1(left: u8) -> Vec<u8> {
        let mut png = Vec::new();
        image::ImageEncoder::write_image(
            image::codecs::png::PngEncoder::new(&mut png),
            &[255, 255, 255, left, 255, 255, 255, 255],
            2,
            1,
            image::ExtendedColorType::Rgba8,
        )
        .unwrap();
        png
    }

    /// One triangle per material of `materials`, with UVs (0, 0.5), (1, 0.5), (0.5, 0.5) on
    /// a 2×1 image whose left texel has alpha `left` / 255.
    fn scene(materials: Vec<Material>, left: u8) -> Scene {
        let mut s = Scene::default();
        for (i, m) in materials.into_iter().enumerate() {
            let b = s.positions.len() as u32;
            s.positions
                .extend([Vec3::ZERO, Vec3::X, Vec3::Y].map(|p| p + Vec3::Z * i as f32));
            s.uvs.extend([
                Vec2::new(0.0, 0.5),
                Vec2::new(1.0, 0.5),
                Vec2::new(0.5, 0.5),
            ]);
            s.normals.extend([Vec3::ZERO; 3]);
            s.triangles.push([b, b + 1, b + 2]);
            s.triangle_materials.push(i as u32);
            s.materials.push(m);
        }
        s.images = vec![ImageSource::Bytes {
            data: png_2x1(left).into(),
            mime: Some("image/png".into()),
        }];
        s.update_summary();
        s
    }

    fn textured(alpha_mode: AlphaMode, factor: f32) -> Material {
        Material {
            base_color: Vec4::new(1.0, 1.0, 1.0, factor),
            base_color_texture: Some(TextureRef {
                image: 0,
                tex_coord: 0,
                wrap_s: Wrap::ClampToEdge,
                wrap_t: Wrap::ClampToEdge,
                transform: [Vec2::X, Vec2::Y, Vec2::ZERO],
            }),
            alpha_mode,
            ..Default::default()
        }
    }

    fn plain(alpha_mode: AlphaMode, factor: f32) -> Material {
        Material {
            base_color: Vec4::new(1.0, 1.0, 1.0, factor),
            alpha_mode,
            ..Default::default()
        }
    }

    fn build(s: &Scene) -> Option<AlphaCoverage> {
        let mut missing = Vec::new();
        let c = AlphaCoverage::build(s, Path::new("test.gltf"), &mut missing).unwrap();
        assert_eq!(missing, []);
        c
    }

    /// Alpha is the factor times the texture's alpha, read bilinearly at the point's UV: the
    /// triangle's vertex 0 sits on the left texel's centre line (u = 0 clamps to it), vertex
    /// 1 on the right one's, and halfway between them alpha is their mean.
    #[test]
    fn alpha_is_the_factor_times_the_filtered_texture_alpha() {
        let s = scene(vec![textured(AlphaMode::Mask(0.5), 0.8)], 51);
        let c = build(&s).expect("a MASK material with a texture is tested");
        let left = 51.0 / 255.0;
        let at = |u, v| c.alpha(0, u, v).unwrap();
        assert!((at(0.0, 0.0) - 0.8 * left).abs() < 1e-6);
        assert!((at(1.0, 0.0) - 0.8).abs() < 1e-6);
        // Vertex 2 has UV (0.5, 0.5): the texel boundary, where bilinear gives the mean.
        assert!((at(0.0, 1.0) - 0.8 * 0.5 * (left + 1.0)).abs() < 1e-6);
    }

    /// MASK cuts at the cutoff: covered where alpha ≥ cutoff, a hole below, whatever the ray.
    #[test]
    fn mask_covers_where_alpha_reaches_the_cutoff() {
        let ray = Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z);
        // Alpha 0.8 × 0.2 = 0.16 on the left, 0.8 on the right.
        for (cutoff, left, right) in [(0.5, false, true), (0.16, true, true), (0.81, false, false)]
        {
            let s = scene(vec![textured(AlphaMode::Mask(cutoff), 0.8)], 51);
            let c = build(&s).unwrap();
            let key = ray_key(&ray);
            assert_eq!(
                c.covers(0, NO_INSTANCE, 0.0, 0.0, key),
                left,
                "cutoff {cutoff}, left"
            );
            assert_eq!(
                c.covers(0, NO_INSTANCE, 1.0, 0.0, key),
                right,
                "cutoff {cutoff}, right"
            );
        }
    }

    /// BLEND stops a fraction alpha of rays (here over 40,000 rays, 5 standard errors), the
    /// same answer for the same ray each time, and different rays decide independently; so
    /// do two instances of the triangle along the same ray (their coins agree as often as
    /// independent ones would, α² + (1 − α)²).
    #[test]
    fn blend_stops_a_fraction_alpha_of_rays() {
        let s = scene(vec![plain(AlphaMode::Blend, 0.3)], 255);
        let c = build(&s).unwrap();
        let n = 40_000;
        let rays: Vec<Ray> = (0..n)
            .map(|i| {
                let x = (i % 200) as f32 / 200.0;
                let y = (i / 200) as f32 / 200.0;
                Ray::new(Vec3::new(0.3 * x, 0.3 * y, 1.0), -Vec3::Z)
            })
            .collect();
        let covers = |r: &Ray, inst: u32| c.covers(0, inst, 0.2, 0.2, ray_key(r));
        let stopped = rays.iter().filter(|r| covers(r, NO_INSTANCE)).count();
        let p = stopped as f64 / n as f64;
        let se = (0.3f64 * 0.7 / n as f64).sqrt();
        assert!((p - 0.3).abs() < 5.0 * se, "{p} of rays stopped, not 0.3");
        for r in &rays[..100] {
            let key = ray_key(r);
            assert_eq!(
                covers(r, NO_INSTANCE),
                c.covers(0, NO_INSTANCE, 0.7, 0.1, key)
            );
        }
        let agree = rays.iter().filter(|r| covers(r, 3) == covers(r, 4)).count();
        let q = agree as f64 / n as f64;
        let independent = 0.3f64 * 0.3 + 0.7 * 0.7;
        let se = (independent * (1.0 - independent) / n as f64).sqrt();
        assert!(
            (q - independent).abs() < 5.0 * se,
            "instances agree on {q} of rays"
        );
    }

    /// Materials whose alpha cannot cut (OPAQUE whatever its alpha; MASK or BLEND with a
    /// factor that covers and no texture, or a texture of alpha 1 everywhere) are not tested,
    /// and a scene of only those builds nothing.
    #[test]
    fn surfaces_that_always_cover_are_not_tested() {
        let s = scene(
            vec![
                plain(AlphaMode::Opaque, 0.1),
                plain(AlphaMode::Mask(0.5), 0.5),
                plain(AlphaMode::Blend, 1.0),
                textured(AlphaMode::Blend, 1.0),
                textured(AlphaMode::Mask(0.5), 0.9),
            ],
            255,
        );
        // The summary cannot see inside textures: it counts the two textured triangles.
        assert_eq!(s.summary.alpha_tested_triangles, 2);
        assert!(build(&s).is_none());
        let none = scene(vec![plain(AlphaMode::Opaque, 0.0)], 0);
        assert_eq!(none.summary.alpha_tested_triangles, 0);
        assert!(build(&none).is_none());
        // Negative control: a texture with one transparent texel is tested, and so is a
        // MASK whose factor falls below its cutoff.
        let s = scene(
            vec![
                plain(AlphaMode::Opaque, 1.0),
                textured(AlphaMode::Blend, 1.0),
            ],
            254,
        );
        let c = build(&s).unwrap();
        assert_eq!(
            (c.tests(0), c.tests(1), c.tested_triangles()),
            (false, true, 1)
        );
        let s = scene(vec![plain(AlphaMode::Mask(0.5), 0.49)], 255);
        let key = ray_key(&Ray::new(Vec3::Z, -Vec3::Z));
        assert!(!build(&s).unwrap().covers(0, NO_INSTANCE, 0.1, 0.1, key));
    }

    /// An undecodable base colour image of an alpha-tested material counts as no texture:
    /// the factor's alpha alone (1 here: nothing tested), and the image is listed as missing
    /// for that material with why; the same image on an OPAQUE material is never decoded.
    #[test]
    fn an_undecodable_alpha_texture_counts_as_absent() {
        let mut s = scene(vec![textured(AlphaMode::Mask(0.5), 1.0)], 0);
        s.images = vec![ImageSource::Bytes {
            data: b"not a png".to_vec().into(),
            mime: None,
        }];
        let mut missing = Vec::new();
        let c = AlphaCoverage::build(&s, Path::new("test.gltf"), &mut missing).unwrap();
        assert!(c.is_none());
        assert_eq!(missing.len(), 1, "{missing:?}");
        assert_eq!((missing[0].image, missing[0].material), (0, 0));
        assert!(missing[0].problem.contains("format"), "{missing:?}");
        // Under a factor that cuts, the triangle is tested by the factor alone.
        s.materials[0].base_color.w = 0.25;
        s.update_summary();
        let mut missing = Vec::new();
        let c = AlphaCoverage::build(&s, Path::new("test.gltf"), &mut missing).unwrap();
        assert_eq!(
            c.expect("a cutting factor is tested").alpha(0, 0.3, 0.3),
            Some(0.25)
        );
        s.materials[0].alpha_mode = AlphaMode::Opaque;
        s.update_summary();
        let mut missing = Vec::new();
        assert!(
            AlphaCoverage::build(&s, Path::new("test.gltf"), &mut missing)
                .unwrap()
                .is_none()
        );
        assert_eq!(missing, []);
    }
}
