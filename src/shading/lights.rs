//! Light sources at render time and their sampling.
//!
//! | emitter        | from                                   | sampled by                         |
//! |----------------|----------------------------------------|------------------------------------|
//! | point          | `KHR_lights_punctual` point            | delta: its position; I/d²          |
//! | spot           | `KHR_lights_punctual` spot             | delta; the extension's cone falloff |
//! | directional    | `KHR_lights_punctual` directional      | delta: its direction; irradiance E |
//! | triangle       | each triangle of an emissive material  | uniform area (default) or uniform  |
//! |                |                                        | solid angle (Arvo 1995)            |
//! | environment    | [`Environment`] (`--background R,G,B`)  | BSDF sampling only; its own pdf    |
//! |                |                                        | when light sampling must find it   |
//!
//! One emitter is chosen per sample in proportion to its power through an alias table
//! (Walker 1977, Vose 1991). Punctual `range` is ignored (it is optional in the extension
//! and has no physical counterpart).
//!
//! A constant environment is left out of light selection unless only light sampling can
//! reach it, or the scene's BSDFs are not all diffuse ([`BackgroundSampling`]).
//! Cosine-weighted BSDF sampling of a diffuse surface already has a pdf proportional to the
//! integrand cos θ·L for constant L, so light samples of the environment (uniform over the
//! sphere, half of them below the surface) add shadow rays
//! without lowering the variance; with them gone, a BSDF direction that escapes takes the
//! full weight (its MIS partner's pdf is 0). pbrt-v4 does the same for its uniform infinite
//! light ("allowIncompletePDF", Pharr et al. 2023, §13.4).

use glam::{Vec2, Vec3};

use super::environment::Environment;
use super::interaction::{gamma, SurfaceInteraction};
use super::material::Materials;
use crate::accel::AlphaCoverage;
use crate::sampling::warps::{
    spherical_triangle_area, square_to_spherical_triangle, square_to_uniform_triangle,
};
use crate::scene::{Light, Scene, NO_INSTANCE};

pub use super::spectrum::luminance;

#[derive(Clone, Debug, PartialEq)]
pub enum Emitter {
    Point {
        position: Vec3,
        intensity: Vec3,
    },
    Spot {
        position: Vec3,
        direction: Vec3,
        intensity: Vec3,
        cos_inner: f32,
        cos_outer: f32,
    },
    Directional {
        /// Direction the light travels in.
        direction: Vec3,
        irradiance: Vec3,
    },
    Triangle(TriangleLight),
    /// The light set's [`Environment`], where light sampling may choose it.
    Environment,
}

impl Emitter {
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Emitter::Point { .. } | Emitter::Spot { .. } | Emitter::Directional { .. }
        )
    }
}

/// An emissive triangle as a light: what every light sample on it needs, computed once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleLight {
    pub prim: u32,
    /// The instance that places it ([`crate::scene::Instance`]), or
    /// [`crate::scene::NO_INSTANCE`] for a world-space triangle.
    pub inst: u32,
    /// The triangle's area and unit geometric normal on its front (along e1 × e2, but for a
    /// mirroring instance's triangle, whose placed corners wind the other way): each costs a
    /// square root or a division.
    pub area: f32,
    pub normal: Vec3,
    /// Its vertices in world space (placed by its instance), copied here so that a light
    /// sample reads them without going through the scene's index buffer.
    pub vertices: [Vec3; 3],
    /// A per-axis bound on the rounding error of any point b₀·a + b₁·b + b₂·c computed on the
    /// triangle, and on the error of a ray–triangle test near it: γ₇·(max |vᵢ| + the
    /// triangle's largest extent). A point's own bound (γ₇·Σ|bᵢ·vᵢ| plus γ₇ times its distance
    /// to the farthest vertex) is never larger, as bᵢ ≥ 0 sum to 1.
    pub point_error: Vec3,
}

/// Angular attenuation of a `KHR_lights_punctual` spot light for `cos_angle` between the
/// spot axis and the direction to the lit point: the extension's smooth falloff,
/// clamp((cos − cos_outer)/(cos_inner − cos_outer), 0, 1)².
#[inline]
pub fn spot_falloff(cos_angle: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let scale = 1.0 / (cos_inner - cos_outer).max(0.001);
    let t = ((cos_angle - cos_outer) * scale).clamp(0.0, 1.0);
    t * t
}

/// A sampled light direction as seen from a surface point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the surface toward the light.
    pub wi: Vec3,
    /// Radiance (area lights, environment) or the delta light's incident irradiance term
    /// (I/d² or E), to be multiplied by f·|cos| and divided by `pdf`.
    pub li: Vec3,
    /// Solid-angle pdf of `wi` (1 for delta lights), not including the selection pmf.
    pub pdf: f32,
    pub is_delta: bool,
    /// The point on the light, offset off its surface (ignored when `infinite`).
    pub p_light: Vec3,
    /// True for directions to infinity (directional light, environment).
    pub infinite: bool,
}

/// Walker's alias method (Vose's construction): O(1) sampling of a discrete distribution.
#[derive(Clone, Debug, Default)]
pub struct AliasTable {
    prob: Vec<f32>,
    alias: Vec<u32>,
    pmf: Vec<f32>,
}

impl AliasTable {
    /// A table over `weights` (non-negative, not all zero).
    pub fn new(weights: &[f64]) -> AliasTable {
        let n = weights.len();
        let total: f64 = weights.iter().sum();
        let pmf: Vec<f32> = weights.iter().map(|w| (w / total) as f32).collect();
        let mut scaled: Vec<f64> = weights.iter().map(|w| w / total * n as f64).collect();
        let mut prob = vec![1.0f32; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
            prob[s] = scaled[s] as f32;
            alias[s] = l as u32;
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // Leftovers (from rounding) keep probability 1.
        AliasTable { prob, alias, pmf }
    }

    /// An index drawn with probability `pmf(index)` from one uniform number `u` in [0, 1),
    /// its pmf, and `u` remapped to a new uniform number in [0, 1), independent
    /// of the index drawn: the stretch of [0, 1) that chose the index, scaled to the whole
    /// (sample reuse, as pbrt-v4's alias table does). Each index owns one or two intervals of
    /// `u`, mapped linearly, so points that were stratified stay stratified within each
    /// index's share: a light can be chosen with one dimension of its own 2D point.
    #[inline]
    pub fn sample_remapped(&self, u: f32) -> (usize, f32, f32) {
        const BELOW_ONE: f32 = 1.0 - f32::EPSILON / 2.0;
        let n = self.prob.len();
        let x = u * n as f32;
        let i = (x as usize).min(n - 1);
        let coin = (x - i as f32).min(BELOW_ONE);
        let p = self.prob[i];
        let (k, remapped) = if coin < p {
            (i, coin / p)
        } else {
            (self.alias[i] as usize, (coin - p) / (1.0 - p))
        };
        (k, self.pmf[k], remapped.min(BELOW_ONE))
    }

    /// The probability of drawing `i`; 0 past the end (and in the empty table).
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf.get(i).copied().unwrap_or(0.0)
    }

    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }
}

/// How points on emissive triangles are sampled for next-event estimation.
///
/// Measured (docs/journal/benchmarks-2026-11.md, "Emissive triangles"): under a large emitter close to the surface, solid-angle
/// sampling halves the RMSE at equal spp; on the Cornell box it lowers RMSE by about 1% but
/// makes the render 57% slower (spherical trigonometry per light sample and per MIS pdf).
/// Area sampling is the default; choose solid angle for scenes lit by large, near emitters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum TriangleSampling {
    /// Uniform over the triangle's area (pdf converted to solid angle: d²/(cos·A)).
    #[default]
    Area,
    /// Uniform over the solid angle the triangle subtends (Arvo 1995), falling back to area
    /// sampling for very small or very large solid angles.
    SolidAngle,
}

crate::display_as_value_name!(TriangleSampling);

/// Whether next-event estimation samples the environment.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BackgroundSampling {
    /// Only BSDF sampling reaches the environment: it is never selected as a light, and its
    /// light pdf is 0 in MIS weights. Unbiased whenever BSDF samples count (MIS, BSDF only),
    /// and the better choice for a constant environment over diffuse surfaces, whose
    /// cosine-weighted directions already follow the integrand (see the module docs).
    #[default]
    BsdfOnly,
    /// The environment is selected like any emitter and sampled by its own pdf: needed when
    /// light samples alone must find it (`--strategy light`), and where BSDF sampling does
    /// not follow the environment's light.
    Lights,
}

/// All emitters of a scene, with power-proportional selection.
#[derive(Clone, Debug, Default)]
pub struct LightSet {
    pub triangle_sampling: TriangleSampling,
    pub emitters: Vec<Emitter>,
    table: AliasTable,
    /// Emitter index of each world-space triangle, and for a prototype's triangle its index
    /// among the prototype's emitting triangles, or `u32::MAX`; empty when no triangle emits.
    triangle_light: Vec<u32>,
    /// Each instance's first emitter (its prototype's emitting triangles follow in order), or
    /// `u32::MAX` for an instance of a prototype that emits nothing; empty when none does.
    instance_lights: Vec<u32>,
    environment: Environment,
    /// What camera rays that miss the scene see instead of the environment (`--background`
    /// in front of an `--env` map); None: the environment.
    pub camera_background: Option<Vec3>,
    /// The environment's index in `emitters` (its selection probability, 0 when light
    /// sampling leaves it to BSDF sampling); None for a black environment.
    environment_light: Option<usize>,
    /// True when some emissive triangle may cut holes by alpha
    /// ([`Scene::may_cut_holes`]): light sampling then reads the alpha coverage.
    alpha_tested_emitters: bool,
    /// The power of the punctual lights and emissive triangles, by luminance (the
    /// environment's left out).
    emitted_power: f64,
}

/// A scene's punctual lights and emissive triangles with their selection weights: the part of
/// a [`LightSet`] that does not depend on the environment, collected once (the emissive
/// textures' means are the costly part) and completed by [`LightSet::with_environment`], as
/// often as the environment changes.
#[derive(Clone, Debug, Default)]
pub struct SceneEmitters {
    emitters: Vec<Emitter>,
    weights: Vec<f64>,
    triangle_light: Vec<u32>,
    instance_lights: Vec<u32>,
    alpha_tested_emitters: bool,
    /// The radius of the scene's bounding sphere, which the environment's power is taken
    /// over.
    radius: f32,
}

impl SceneEmitters {
    /// Collects the scene's punctual lights and emissive triangles.
    pub fn collect(scene: &Scene, materials: &Materials) -> SceneEmitters {
        let (lo, hi) = scene.bounds;
        let radius = 0.5 * (hi - lo).length();
        let (mut emitters, mut weights) = punctual_emitters(scene, radius);
        let (triangle_light, instance_lights, alpha_tested_emitters) =
            triangle_emitters(scene, materials, &mut emitters, &mut weights);
        SceneEmitters {
            emitters,
            weights,
            triangle_light,
            instance_lights,
            alpha_tested_emitters,
            radius,
        }
    }

    /// The power they emit, by luminance ([`LightSet::emitted_power`]).
    pub fn emitted_power(&self) -> f64 {
        self.weights.iter().sum()
    }
}

impl LightSet {
    /// Collects the scene's punctual lights, emissive triangles and the environment;
    /// `background_sampling` says whether light sampling selects the environment.
    pub fn build(
        scene: &Scene,
        materials: &Materials,
        environment: Environment,
        background_sampling: BackgroundSampling,
    ) -> LightSet {
        let emitters = SceneEmitters::collect(scene, materials);
        LightSet::with_environment(&emitters, environment, background_sampling)
    }

    /// The lights of `scene_emitters` and `environment`; `background_sampling` says whether
    /// light sampling selects the environment.
    pub fn with_environment(
        scene_emitters: &SceneEmitters,
        environment: Environment,
        background_sampling: BackgroundSampling,
    ) -> LightSet {
        let emitted_power = scene_emitters.emitted_power();
        let SceneEmitters {
            mut emitters,
            mut weights,
            triangle_light,
            instance_lights,
            alpha_tested_emitters,
            radius,
        } = scene_emitters.clone();
        let mut environment_light = None;
        if !environment.is_black() {
            environment_light = Some(emitters.len());
            emitters.push(Emitter::Environment);
            // Weight 0: the alias table never draws it, and its pmf (so its MIS pdf) is 0.
            weights.push(match background_sampling {
                BackgroundSampling::Lights => environment.power(radius),
                BackgroundSampling::BsdfOnly => 0.0,
            });
        }
        let table = if weights.iter().all(|&w| w <= 0.0) {
            AliasTable::default()
        } else {
            AliasTable::new(&weights)
        };
        LightSet {
            triangle_sampling: TriangleSampling::default(),
            emitters,
            table,
            triangle_light,
            instance_lights,
            environment,
            camera_background: None,
            environment_light,
            alpha_tested_emitters,
            emitted_power,
        }
    }

    /// The power the scene's punctual lights and emissive triangles emit, by luminance (the
    /// weights light selection draws them by; the environment's left out).
    pub fn emitted_power(&self) -> f64 {
        self.emitted_power
    }

    /// True when some emissive triangle may cut holes by alpha: light sampling must then be
    /// given the alpha coverage ([`LightSet::sample`]).
    #[inline]
    pub fn has_alpha_tested_emitters(&self) -> bool {
        self.alpha_tested_emitters
    }

    pub fn is_empty(&self) -> bool {
        self.emitters.is_empty()
    }

    /// True when some emitter can be reached by a ray (emissive triangles, the environment):
    /// otherwise BSDF-sampled directions never find light and the last bounce's extension
    /// ray can be skipped.
    pub fn has_reachable_emitters(&self) -> bool {
        !self.triangle_light.is_empty() || self.environment_light.is_some()
    }

    /// What rays that leave the scene see.
    #[inline]
    pub fn environment(&self) -> &Environment {
        &self.environment
    }

    /// The radiance a camera ray that leaves the scene in direction `dir` sees: the camera
    /// background where one is set, else the environment.
    #[inline]
    pub fn camera_miss_radiance(&self, dir: Vec3) -> Vec3 {
        match self.camera_background {
            Some(l) => l,
            None => self.environment.radiance(dir),
        }
    }

    /// The camera miss radiance where it is the same in every direction.
    #[inline]
    pub fn constant_camera_miss(&self) -> Option<Vec3> {
        self.camera_background
            .or_else(|| self.environment.constant())
    }

    /// The environment's radiance along unit direction `dir`, and the selection probability ×
    /// solid-angle pdf with which light sampling would have drawn `dir` toward it (0 when
    /// light sampling leaves the environment to BSDF sampling), from one lookup.
    #[inline]
    pub fn environment_radiance_pdf(&self, dir: Vec3) -> (Vec3, f32) {
        match self.environment_light {
            Some(i) => {
                let (l, pdf) = self.environment.radiance_pdf(dir);
                (l, self.table.pmf(i) * pdf)
            }
            None => (self.environment.radiance(dir), 0.0),
        }
    }

    /// Selection probability × solid-angle pdf with which light sampling from `p_ref` would
    /// have produced the point `p` on emissive triangle `prim` placed by instance `inst`
    /// (unit normal `n`).
    #[inline]
    pub fn triangle_pdf(&self, prim: u32, inst: u32, p_ref: Vec3, p: Vec3, n: Vec3) -> f32 {
        let Some((pmf, light)) = self.light_of_triangle(prim, inst) else {
            return 0.0;
        };
        if self.triangle_sampling == TriangleSampling::SolidAngle {
            let [a, b, c] = light.vertices;
            if let Some(omega) = self.spherical_area(a, b, c, p_ref) {
                return pmf / omega;
            }
        }
        let area = light.area;
        let d = p - p_ref;
        let dist2 = d.length_squared();
        let cos = (n.dot(d) / dist2.sqrt()).abs();
        if cos <= 0.0 || area <= 0.0 {
            return 0.0;
        }
        pmf * dist2 / (cos * area)
    }

    /// The emitter of triangle `prim` placed by instance `inst` and its selection
    /// probability; None for a triangle that emits nothing.
    #[inline]
    fn light_of_triangle(&self, prim: u32, inst: u32) -> Option<(f32, &TriangleLight)> {
        let &i = self.triangle_light.get(prim as usize)?;
        if i == u32::MAX {
            return None;
        }
        // A prototype's triangle: its index among the prototype's emitters, after the
        // instance's first.
        let i = match self.instance_lights.get(inst as usize) {
            None => i,
            Some(&u32::MAX) => return None,
            Some(&first) => first + i,
        };
        match &self.emitters[i as usize] {
            Emitter::Triangle(t) => Some((self.table.pmf(i as usize), t)),
            _ => {
                debug_assert!(false, "triangle_light indexes triangle emitters");
                None
            }
        }
    }

    /// The emitter chosen with `u.x`, its selection probability, and `u` with its first
    /// dimension remapped for sampling the emitter ([`AliasTable::sample_remapped`]); None
    /// when no emitter can be chosen.
    #[inline]
    fn choose(&self, u: Vec2) -> Option<(&Emitter, f32, Vec2)> {
        if self.table.is_empty() {
            return None;
        }
        let (i, pmf, ux) = self.table.sample_remapped(u.x);
        Some((&self.emitters[i], pmf, Vec2::new(ux, u.y)))
    }

    /// The solid angle of triangle (a, b, c) seen from `p` when it is sampled by solid angle
    /// from there; `None` when it is sampled by area (the option says so, or the solid angle
    /// is too small or too large for spherical sampling to be accurate in f32: pbrt-v4's
    /// bounds, 3e-4 and 6.22 sr).
    #[inline]
    fn spherical_area(&self, a: Vec3, b: Vec3, c: Vec3, p: Vec3) -> Option<f32> {
        if self.triangle_sampling != TriangleSampling::SolidAngle {
            return None;
        }
        let (da, db, dc) = (
            (a - p).try_normalize()?,
            (b - p).try_normalize()?,
            (c - p).try_normalize()?,
        );
        let omega = spherical_triangle_area(da, db, dc);
        (3e-4..=6.22).contains(&omega).then_some(omega)
    }

    /// A point on emissive triangle `prim` as seen from `p`: uniform in solid angle (Arvo
    /// 1995) or uniform in area, with its solid-angle pdf.
    fn sample_triangle(
        &self,
        scene: &Scene,
        materials: &Materials,
        triangle: &TriangleLight,
        p: Vec3,
        u: Vec2,
    ) -> Option<LightSample> {
        self.triangle_point(scene, materials, triangle, p, u)
            .map(|(ls, _)| ls)
    }

    /// [`LightSet::sample_triangle`] of an alpha-tested emitter: its radiance weighed by
    /// `coverage`'s stopping fraction at the point. An alpha-tested emitter shines where it
    /// stops rays: through its holes a ray that meets it goes on, so its light reaches no one
    /// from there. (Apart, so that emitters without alpha pay nothing.)
    fn sample_cut_triangle(
        &self,
        scene: &Scene,
        materials: &Materials,
        coverage: &AlphaCoverage,
        triangle: &TriangleLight,
        p: Vec3,
        u: Vec2,
    ) -> Option<LightSample> {
        let (mut ls, bary) = self.triangle_point(scene, materials, triangle, p, u)?;
        ls.li *= coverage.stopping_fraction(triangle.prim, bary.x, bary.y);
        Some(ls)
    }

    /// The work of [`LightSet::sample_triangle`], with the point's barycentrics.
    #[inline(always)]
    fn triangle_point(
        &self,
        scene: &Scene,
        materials: &Materials,
        triangle: &TriangleLight,
        p: Vec3,
        u: Vec2,
    ) -> Option<(LightSample, Vec2)> {
        let &TriangleLight {
            prim,
            inst: _,
            area,
            normal: n,
            vertices: [a, b, c],
            point_error,
        } = triangle;
        if area.is_nan() || area <= 0.0 {
            return None;
        }
        let (q, bary, pdf_solid_angle) = match self.spherical_area(a, b, c, p) {
            Some(omega) => {
                let da = (a - p).normalize();
                let w =
                    square_to_spherical_triangle(da, (b - p).normalize(), (c - p).normalize(), u)?;
                // Where the direction meets the triangle's plane, and its barycentrics.
                let t = (a - p).dot(n) / w.dot(n);
                if !(t > 0.0 && t.is_finite()) {
                    return None;
                }
                let q = p + t * w;
                let (e1, e2) = (b - a, c - a);
                let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
                let v = q - a;
                let (d20, d21) = (v.dot(e1), v.dot(e2));
                let den = d00 * d11 - d01 * d01;
                let b1 = ((d11 * d20 - d01 * d21) / den).clamp(0.0, 1.0);
                let b2 = ((d00 * d21 - d01 * d20) / den).clamp(0.0, 1.0 - b1);
                (q, Vec2::new(b1, b2), Some(1.0 / omega))
            }
            None => {
                let bary = square_to_uniform_triangle(u);
                let (b0, b1) = (bary.x, bary.y);
                let b2 = 1.0 - b0 - b1;
                (b0 * a + b1 * b + b2 * c, Vec2::new(b1, b2), None)
            }
        };
        let d = q - p;
        let dist2 = d.length_squared();
        let dist = dist2.sqrt();
        if dist.is_nan() || dist <= 0.0 {
            return None;
        }
        let wi = d / dist;
        let cos_l = n.dot(-wi);
        if cos_l == 0.0 {
            return None;
        }
        let li = materials.emitted_at(scene, prim, bary, cos_l > 0.0);
        // Offset the light point off its triangle toward the receiver, past the triangle's
        // error bound.
        let p_light = crate::shading::interaction::offset_ray_origin(q, point_error, n, -wi);
        let sample = LightSample {
            wi,
            li,
            pdf: pdf_solid_angle.unwrap_or(dist2 / (cos_l.abs() * area)),
            is_delta: false,
            p_light,
            infinite: false,
        };
        Some((sample, bary))
    }

    /// Chooses an emitter with `u.x` and samples a direction to it from `si` with `u`, its
    /// first dimension reused ([`AliasTable::sample_remapped`]): a stratified set of `u` then
    /// gives stratified points on each emitter, where a separate choice would scatter the
    /// points of an emitter made of several triangles (a quad light's two halves) at random
    /// between them. An alpha-tested emitter's radiance is weighed by `coverage` (the
    /// acceleration structure's, [`AlphaCoverage::stopping_fraction`]). With `deltas_only`
    /// (BSDF sampling alone, which finds every other emitter by itself), a chosen emitter
    /// that is not a delta light gives None without being sampled. Returns the sample and
    /// the selection probability.
    #[inline(always)]
    pub fn sample(
        &self,
        scene: &Scene,
        materials: &Materials,
        coverage: Option<&AlphaCoverage>,
        si: &SurfaceInteraction,
        u: Vec2,
        deltas_only: bool,
    ) -> Option<(LightSample, f32)> {
        let (emitter, pmf, u) = self.choose(u)?;
        if deltas_only && matches!(emitter, Emitter::Triangle(_) | Emitter::Environment) {
            return None;
        }
        let p = si.p;
        let s = match emitter {
            &Emitter::Point {
                position,
                intensity,
            } => {
                let d = position - p;
                let dist2 = d.length_squared();
                LightSample {
                    wi: d / dist2.sqrt(),
                    li: intensity / dist2,
                    pdf: 1.0,
                    is_delta: true,
                    p_light: position,
                    infinite: false,
                }
            }
            &Emitter::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
            } => {
                let d = position - p;
                let dist2 = d.length_squared();
                let wi = d / dist2.sqrt();
                let falloff = spot_falloff(direction.dot(-wi), cos_inner, cos_outer);
                LightSample {
                    wi,
                    li: intensity * (falloff / dist2),
                    pdf: 1.0,
                    is_delta: true,
                    p_light: position,
                    infinite: false,
                }
            }
            &Emitter::Directional {
                direction,
                irradiance,
            } => LightSample {
                wi: -direction,
                li: irradiance,
                pdf: 1.0,
                is_delta: true,
                p_light: Vec3::ZERO,
                infinite: true,
            },
            Emitter::Environment => {
                let (wi, li, pdf) = self.environment.sample(u);
                LightSample {
                    wi,
                    li,
                    pdf,
                    is_delta: false,
                    p_light: Vec3::ZERO,
                    infinite: true,
                }
            }
            Emitter::Triangle(triangle) => match coverage {
                None => self.sample_triangle(scene, materials, triangle, p, u)?,
                Some(c) => self.sample_cut_triangle(scene, materials, c, triangle, p, u)?,
            },
        };
        Some((s, pmf))
    }
}

/// The scene's punctual lights as emitters, each with its power (in luminance) for light
/// selection; those of no power left out. `radius`: the scene's bounding sphere's, over which
/// a directional light's power is taken.
fn punctual_emitters(scene: &Scene, radius: f32) -> (Vec<Emitter>, Vec<f64>) {
    let mut emitters = Vec::new();
    let mut weights = Vec::new();
    let pi = std::f64::consts::PI;
    for light in &scene.lights {
        let (e, power) = match *light {
            Light::Point {
                position,
                intensity,
                ..
            } => (
                Emitter::Point {
                    position,
                    intensity,
                },
                4.0 * pi * luminance(intensity) as f64,
            ),
            Light::Spot {
                position,
                direction,
                intensity,
                inner_cone_angle,
                outer_cone_angle,
                ..
            } => {
                let (ci, co) = (inner_cone_angle.cos(), outer_cone_angle.cos());
                (
                    Emitter::Spot {
                        position,
                        direction,
                        intensity,
                        cos_inner: ci,
                        cos_outer: co,
                    },
                    2.0 * pi * luminance(intensity) as f64 * (1.0 - 0.5 * (ci + co) as f64),
                )
            }
            Light::Directional {
                direction,
                irradiance,
            } => (
                Emitter::Directional {
                    direction,
                    irradiance,
                },
                pi * (radius as f64).powi(2) * luminance(irradiance) as f64,
            ),
        };
        if power > 0.0 {
            emitters.push(e);
            weights.push(power);
        }
    }
    (emitters, weights)
}

/// Adds the scene's emissive triangles of positive power to `emitters` and `weights`: those
/// in world space once, a prototype's once per instance. Returns the light of each triangle
/// (`u32::MAX`: none; a prototype's triangle: its number among the prototype's emitting
/// ones), each instance's first light (`u32::MAX`: none), and whether any emitter may cut
/// holes by alpha.
fn triangle_emitters(
    scene: &Scene,
    materials: &Materials,
    emitters: &mut Vec<Emitter>,
    weights: &mut Vec<f64>,
) -> (Vec<u32>, Vec<u32>, bool) {
    let pi = std::f64::consts::PI;
    let mut triangle_light = Vec::new();
    let mut instance_lights = Vec::new();
    let mut alpha_tested_emitters = false;
    if scene.summary.emissive_triangles > 0 {
        triangle_light = vec![u32::MAX; scene.triangles.len()];
        // Each material's mean emission (a texture's mean reads every texel), once.
        let mut emission: Vec<Option<(Vec3, bool)>> = vec![None; scene.materials.len()];
        let mut power_of = |prim: u32, [a, b, c]: [Vec3; 3]| {
            let m = scene.triangle_materials[prim as usize];
            let (le, two_sided) =
                *emission[m as usize].get_or_insert_with(|| materials.emission_power_factor(m));
            let area = 0.5 * (b - a).cross(c - a).length() as f64;
            pi * area * luminance(le) as f64 * if two_sided { 2.0 } else { 1.0 }
        };
        let light = |prim: u32, inst: u32, [a, b, c]: [Vec3; 3]| {
            let cross = (b - a).cross(c - a);
            let area = 0.5 * cross.length();
            let extent = (a.max(b).max(c) - a.min(b).min(c)).max_element();
            let point_error = gamma(7) * (a.abs().max(b.abs()).max(c.abs()) + Vec3::splat(extent));
            Emitter::Triangle(TriangleLight {
                prim,
                inst,
                area,
                normal: cross / (2.0 * area),
                vertices: [a, b, c],
                point_error,
            })
        };
        let world = match scene.prototypes.is_empty() {
            true => (0..scene.triangles.len() as u32).collect(),
            false => scene.flat_triangles(),
        };
        for prim in world {
            if !materials.is_emissive_triangle(scene, prim) {
                continue;
            }
            let corners = scene.triangle_positions(prim);
            let power = power_of(prim, corners);
            if power > 0.0 {
                triangle_light[prim as usize] = emitters.len() as u32;
                alpha_tested_emitters |= scene.may_cut_holes(prim as usize);
                emitters.push(light(prim, NO_INSTANCE, corners));
                weights.push(power);
            }
        }
        // A prototype's emitting triangles (those of positive power in its own space,
        // which an invertible placement keeps positive), a light each per instance.
        let emitting: Vec<Vec<u32>> = scene
            .prototypes
            .iter()
            .map(|p| {
                let prims = p.triangles.clone().filter(|&prim| {
                    materials.is_emissive_triangle(scene, prim)
                        && power_of(prim, scene.triangle_positions(prim)) > 0.0
                });
                prims.collect()
            })
            .collect();
        if emitting.iter().any(|e| !e.is_empty()) {
            for prims in &emitting {
                for (k, &prim) in prims.iter().enumerate() {
                    triangle_light[prim as usize] = k as u32;
                }
            }
            for (k, instance) in scene.instances.iter().enumerate() {
                let prims = &emitting[instance.prototype as usize];
                instance_lights.push(match prims.is_empty() {
                    true => u32::MAX,
                    false => emitters.len() as u32,
                });
                for &prim in prims {
                    let corners = scene.placed_positions(prim, k as u32);
                    alpha_tested_emitters |= scene.may_cut_holes(prim as usize);
                    // The front is where the prototype's normal points once carried to
                    // world space, as for a hit on it (a mirroring placement winds the
                    // placed corners the other way).
                    let [a, b, c] = scene.triangle_positions(prim);
                    let front = scene.normal_to_world(k as u32, (b - a).cross(c - a));
                    let mut emitter = light(prim, k as u32, corners);
                    if let Emitter::Triangle(t) = &mut emitter {
                        t.normal = front;
                    }
                    emitters.push(emitter);
                    weights.push(power_of(prim, corners));
                }
            }
        }
    }
    (triangle_light, instance_lights, alpha_tested_emitters)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alias_table_reproduces_its_weights() {
        let weights = [1.0, 0.0, 3.0, 6.0, 0.5];
        let table = AliasTable::new(&weights);
        let total: f64 = weights.iter().sum();
        let n = 200_000;
        let mut counts = [0usize; 5];
        for k in 0..n {
            let u = (k as f32 + 0.5) / n as f32;
            let (i, pmf, _) = table.sample_remapped(u);
            counts[i] += 1;
            assert!((pmf as f64 - weights[i] / total).abs() < 1e-6);
        }
        for i in 0..5 {
            let p = counts[i] as f64 / n as f64;
            assert!((p - weights[i] / total).abs() < 1e-3, "{i}: {p}");
        }
        assert_eq!(counts[1], 0, "zero weight never drawn");
    }

    /// The remapped number is uniform in [0, 1) whatever index it came with: over evenly
    /// spaced `u`, each index's remapped values fill ten bins equally (up to one value per
    /// interval of `u` that the index owns, at the bins' edges).
    #[test]
    fn alias_table_remaps_uniformly_within_each_index() {
        let weights = [1.0, 0.0, 3.0, 6.0, 0.5];
        let table = AliasTable::new(&weights);
        let n = 100_000;
        let mut bins = [[0i64; 10]; 5];
        for k in 0..n {
            let u = (k as f32 + 0.5) / n as f32;
            let (i, _, r) = table.sample_remapped(u);
            assert!((0.0..1.0).contains(&r), "u {u}: remapped {r}");
            bins[i][(r * 10.0) as usize] += 1;
        }
        assert_eq!(bins[1], [0; 10], "zero weight never drawn");
        for (i, b) in bins.iter().enumerate().filter(|(i, _)| *i != 1) {
            let total: i64 = b.iter().sum();
            for &c in b {
                assert!(
                    (c * 10 - total).abs() <= 10 * 5,
                    "index {i}: remapped values per tenth {b:?}"
                );
            }
        }
    }

    #[test]
    fn spot_falloff_follows_the_extension() {
        let (ci, co) = (0.9f32, 0.5f32);
        assert_eq!(spot_falloff(0.95, ci, co), 1.0);
        assert_eq!(spot_falloff(0.4, ci, co), 0.0);
        // Halfway in cosine: (0.5)² = 0.25.
        assert!((spot_falloff(0.7, ci, co) - 0.25).abs() < 1e-6);
    }
}
