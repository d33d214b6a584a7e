//! Ray–scene intersection, independent of the BVH library behind it.
//!
//! [`Accel`] is the only type the renderer traces rays through. It answers two queries:
//! [`Accel::intersect`] (closest hit: distance, primitive, barycentrics, geometric normal) and
//! [`Accel::occluded`] (is there any hit within the ray's extent). Primitive ids are indices
//! into [`crate::scene::Scene::triangles`], and a hit on a prototype's triangle names the
//! instance that placed it (`Hit::inst`); barycentrics follow p = (1 − u − v)·p0 + u·p1 + v·p2;
//! the geometric normal is normalize((p1 − p0) × (p2 − p0)), the front side of a
//! counter-clockwise triangle, carried to world space by an instance's inverse transpose
//! (which keeps a mirrored instance's front where glTF puts it). Integrators never see
//! backend types.
//!
//! Alpha coverage ([`AlphaCoverage`], glTF's MASK and BLEND): a hit where a triangle's alpha
//! makes a hole is no hit, for every query of both backends; [`Accel::build`] builds the
//! coverage itself, and nothing for a scene without alpha-tested materials.
//!
//! Backends form a closed set, dispatched by `match` (no virtual calls in the ray loop).
//! [`culling`] finds, from the scene's cluster boxes, the pixel blocks whose camera rays can
//! meet no triangle, so that the renderer need not trace them.

mod coverage;
pub mod culling;
mod embree_backend;
mod obvhs_backend;

use std::path::Path;
use std::sync::Arc;

use glam::{Vec3, Vec3A};

use crate::scene::{MissingTexture, Scene};

pub use crate::embree::{enable_ftz_daz, ftz_daz_enabled};
pub use crate::ray::{Hit, Ray, OCCLUSION_PACKET, PACKET};
pub use coverage::AlphaCoverage;
pub use embree_backend::EmbreeAccel;
pub use obvhs_backend::ObvhsAccel;

/// A box around all of a scene's triangles, for telling cheaply that a ray cannot hit any
/// of them: camera rays that miss the scene's bounds then need no traversal.
#[derive(Clone, Copy, Debug)]
pub struct SceneBox {
    lo: Vec3A,
    hi: Vec3A,
    /// The box's largest coordinate magnitude.
    scale: f32,
}

impl SceneBox {
    /// The box of the triangles in `accel` ([`Accel::bounds`]).
    pub fn new(accel: &Accel) -> SceneBox {
        let (lo, hi) = accel.bounds();
        let (lo, hi) = (Vec3A::from(lo), Vec3A::from(hi));
        SceneBox {
            lo,
            hi,
            scale: lo.abs().max(hi.abs()).max_element(),
        }
    }

    /// True only when `ray` meets no point of the box within [t_min, t_max]: a slab test
    /// (Kay and Kajiya 1986) against the box widened by 32 ulps of the largest coordinate
    /// magnitude among the box and the ray's origin. The test's own rounding moves the
    /// points it compares by a few of those ulps, so a ray that grazes a triangle on the
    /// box's faces, edges or corners is never called a miss (tests/scene_box.rs). A NaN
    /// anywhere (an origin on a widened slab's plane with a direction parallel to it, a
    /// non-finite ray) answers false: the ray is traced.
    #[inline]
    pub fn misses(&self, ray: &Ray) -> bool {
        let org = Vec3A::from(ray.org);
        let margin = Vec3A::splat(32.0 * f32::EPSILON * self.scale.max(org.abs().max_element()));
        let inv = Vec3A::ONE / Vec3A::from(ray.dir);
        let t0 = (self.lo - margin - org) * inv;
        let t1 = (self.hi + margin - org) * inv;
        if (t0.is_nan_mask() | t1.is_nan_mask()).any() {
            return false;
        }
        let near = t0.min(t1).max_element().max(ray.t_min);
        let far = t0.max(t1).min_element().min(ray.t_max);
        near > far
    }

    /// True when every ray of `rays` [`misses`](SceneBox::misses) the box: a packet that
    /// needs no traversal.
    #[inline]
    pub fn misses_all(&self, rays: &[Ray]) -> bool {
        rays.iter().all(|r| self.misses(r))
    }
}

/// `n / |n|`, or zero for a zero (or non-finite) `n`. |n|² overflows f32 for a cross product
/// above 1.8e19 (triangles with edges of ~4e9 units) and flushes to zero below 1.1e-19 under
/// FTZ/DAZ (edges of ~3e-10): outside a safe range of |n|², `n` is scaled by its largest
/// component first. Inside it, one square root and one division (a normal per hit: the
/// scaling's three divisions were 5% of a Cornell box render).
#[inline]
pub(crate) fn unit_normal(n: Vec3) -> Vec3 {
    let len2 = n.length_squared();
    if (1e-30..=1e30).contains(&len2) {
        n * (1.0 / len2.sqrt())
    } else {
        (n / n.abs().max_element()).normalize_or_zero()
    }
}

/// The backends' description of their instances ([`Accel::describe`]).
fn instances_note(instances: usize, prototypes: usize) -> String {
    format!(", {instances} instances of {prototypes} prototypes")
}

/// Which BVH library traces the rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    Embree,
    /// The pure-Rust CWBVH of the `obvhs` crate.
    Obvhs,
}

crate::display_as_value_name!(Backend);

/// BVH build quality, shared by every backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum BuildQuality {
    Low,
    #[default]
    Medium,
    High,
}

crate::display_as_value_name!(BuildQuality);

/// Options for building an [`Accel`].
#[derive(Clone, Copy, Debug)]
pub struct AccelOptions {
    pub backend: Backend,
    pub quality: BuildQuality,
    /// Worker threads for the BVH build (0: all cores).
    pub threads: usize,
    /// Watertight traversal (Embree's `RTC_SCENE_FLAG_ROBUST`); on by default.
    pub robust: bool,
    /// Embree: triangles that share an edge traced as quads where that pays (see
    /// `embree_backend`); on by default, off for comparisons.
    pub quads: bool,
    /// Alpha coverage of MASK and BLEND materials ([`AlphaCoverage`]); on by default, off to
    /// render every surface opaque, as renderers that ignore glTF alpha do (`--no-alpha`).
    pub alpha: bool,
}

impl Default for AccelOptions {
    fn default() -> Self {
        AccelOptions {
            backend: Backend::Embree,
            quality: BuildQuality::default(),
            threads: 0,
            robust: true,
            quads: true,
            alpha: true,
        }
    }
}

/// Memory an [`Accel`] holds after its build, in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AccelMemory {
    /// The backend's copy of the triangles (Embree's vertex and index buffers; obvhs's
    /// leaf-ordered triangles and their ids).
    pub geometry: usize,
    /// The hierarchy itself: nodes and leaves (Embree's leaves hold their own copies of the
    /// vertices), as the backend reports it.
    pub bvh: usize,
    /// The most the backend held at once during the build, scratch memory included, where
    /// it reports it (Embree's memory monitor; obvhs does not).
    pub build_peak: Option<usize>,
}

/// An error while building the acceleration structure.
#[derive(Debug, thiserror::Error)]
pub enum AccelError {
    #[error(transparent)]
    Embree(#[from] crate::embree::EmbreeError),
    /// A base colour texture that alpha coverage needs could not be read.
    #[error("{0}")]
    Coverage(String),
}

/// The acceleration structure of a scene: the backend's BVH, and the boxes of
/// [`Accel::clusters`].
pub struct Accel {
    bvh: Bvh,
    clusters: Vec<(Vec3, Vec3)>,
    /// The alpha coverage the backend tests hits against, if any triangle is alpha-tested.
    coverage: Option<Arc<AlphaCoverage>>,
    /// The base colour textures alpha coverage read as absent (their images cannot be had).
    missing_textures: Vec<MissingTexture>,
}

enum Bvh {
    Embree(EmbreeAccel),
    Obvhs(ObvhsAccel),
}

impl Accel {
    /// Builds the acceleration structure over every triangle of `scene`, with the alpha
    /// coverage of its MASK and BLEND materials unless `options.alpha` is off
    /// ([`AlphaCoverage::build`]: their base colour textures are decoded here; one whose
    /// image cannot be had counts as absent, listed in [`Accel::missing_textures`]).
    pub fn build(scene: &Scene, options: &AccelOptions) -> Result<Accel, AccelError> {
        // The caller names the scene in its errors (main adds the path).
        let mut missing_textures = Vec::new();
        let coverage = match options.alpha {
            true => AlphaCoverage::build(scene, Path::new("alpha coverage"), &mut missing_textures)
                .map_err(AccelError::Coverage)?
                .map(Arc::new),
            false => None,
        };
        let bvh = match options.backend {
            Backend::Embree => Bvh::Embree(EmbreeAccel::build(scene, options, coverage.clone())?),
            Backend::Obvhs => Bvh::Obvhs(ObvhsAccel::build(scene, options, coverage.clone())),
        };
        Ok(Accel {
            bvh,
            clusters: scene_cluster_boxes(scene),
            coverage,
            missing_textures,
        })
    }

    /// The base colour textures alpha coverage read as absent, because their images cannot
    /// be read or decoded ([`Scene::missing_texture_warnings`] words them).
    pub fn missing_textures(&self) -> &[MissingTexture] {
        &self.missing_textures
    }

    /// The alpha coverage hits are tested against; `None` when no triangle is alpha-tested.
    pub fn coverage(&self) -> Option<&AlphaCoverage> {
        self.coverage.as_deref()
    }

    /// How many triangles are alpha-tested (their hits may be holes).
    pub fn alpha_tested_triangles(&self) -> usize {
        self.coverage.as_ref().map_or(0, |c| c.tested_triangles())
    }

    /// Boxes around groups of nearby triangles, every triangle of the structure inside one
    /// of them: the triangles binned by centroid into a grid of [`CLUSTER_GRID`]³ cells over
    /// their bounds, each non-empty cell's box the bounds of its triangles' vertices. The
    /// renderer culls camera rays against them at a finer grain than the scene's one box
    /// (an object's silhouette, the gaps between objects).
    pub fn clusters(&self) -> &[(Vec3, Vec3)] {
        &self.clusters
    }

    /// The closest hit along the ray within `[t_min, t_max]`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        match &self.bvh {
            Bvh::Embree(a) => a.intersect(ray),
            Bvh::Obvhs(a) => a.intersect(ray),
        }
    }

    /// The closest hits of up to [`PACKET`] rays (`hits[i]` for `rays[i]`; the rest `None`):
    /// one packet query with Embree, which pays on coherent rays such as the camera rays of
    /// neighbouring pixels; one query per ray with obvhs. The answers are those of
    /// [`Accel::intersect`] ray by ray, but at exact ties (a ray meeting an edge shared by two
    /// triangles), where either triangle may be reported.
    #[inline]
    pub fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<Hit>; PACKET]) {
        match &self.bvh {
            Bvh::Embree(a) => a.intersect_packet(rays, hits),
            Bvh::Obvhs(a) => {
                for (i, hit) in hits.iter_mut().enumerate() {
                    *hit = rays.get(i).and_then(|r| a.intersect(r));
                }
            }
        }
    }

    /// Any-hit answers for up to [`OCCLUSION_PACKET`] rays (`occluded[i]` for `rays[i]`): one
    /// query with Embree (a single-ray one for one ray, else a packet), one query per ray with
    /// obvhs.
    #[inline]
    pub fn occluded_packet(&self, rays: &[Ray], occluded: &mut [bool; OCCLUSION_PACKET]) {
        match &self.bvh {
            Bvh::Embree(a) => a.occluded_packet(rays, occluded),
            Bvh::Obvhs(a) => {
                for (o, r) in occluded.iter_mut().zip(rays) {
                    *o = a.occluded(r);
                }
            }
        }
    }

    /// True when any surface lies along the ray within `[t_min, t_max]`.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        match &self.bvh {
            Bvh::Embree(a) => a.occluded(ray),
            Bvh::Obvhs(a) => a.occluded(ray),
        }
    }

    /// The Embree backend, if this is one.
    pub fn as_embree(&self) -> Option<&EmbreeAccel> {
        match &self.bvh {
            Bvh::Embree(a) => Some(a),
            _ => None,
        }
    }

    /// A box around every triangle the structure holds (the BVH's own, so it is right even
    /// when a scene's `bounds` were not brought up to date).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match &self.bvh {
            Bvh::Embree(a) => a.bounds(),
            Bvh::Obvhs(a) => a.bounds(),
        }
    }

    /// The memory the structure holds.
    pub fn memory(&self) -> AccelMemory {
        match &self.bvh {
            Bvh::Embree(a) => a.memory(),
            Bvh::Obvhs(a) => a.memory(),
        }
    }

    /// A one-line description of the backend (library and version).
    pub fn describe(&self) -> String {
        match &self.bvh {
            Bvh::Embree(a) => a.describe(),
            Bvh::Obvhs(a) => a.describe(),
        }
    }
}

/// Cells per axis of the grid that [`Accel::clusters`] bins triangles into.
pub const CLUSTER_GRID: usize = 8;

/// [`Accel::clusters`] of triangles `prims` of `scene`, as their vertices are stored.
pub fn cluster_boxes(scene: &Scene, prims: impl Iterator<Item = u32> + Clone) -> Vec<(Vec3, Vec3)> {
    clusters_of(prims.map(|prim| scene.triangle_positions(prim).map(Vec3A::from)))
}

/// [`Accel::clusters`] of everything in `scene`: its world-space triangles, and its instances
/// each as its world box (binned by the box's centre, as a triangle with the box's corners
/// and centre for vertices).
pub fn scene_cluster_boxes(scene: &Scene) -> Vec<(Vec3, Vec3)> {
    if scene.prototypes.is_empty() {
        return cluster_boxes(scene, 0..scene.triangles.len() as u32);
    }
    let flat = scene.flat_triangles();
    let triangles = flat
        .iter()
        .map(|&prim| scene.triangle_positions(prim).map(Vec3A::from));
    let instances = scene.instances.iter().map(|i| {
        let (lo, hi) = i.world_box(scene.prototypes[i.prototype as usize].bounds);
        let (lo, hi) = (Vec3A::from(lo), Vec3A::from(hi));
        [lo, hi, (lo + hi) * 0.5]
    });
    clusters_of(triangles.chain(instances))
}

/// The cluster boxes of triangles given by their corners (see [`Accel::clusters`]).
pub fn clusters_of(triangles: impl Iterator<Item = [Vec3A; 3]> + Clone) -> Vec<(Vec3, Vec3)> {
    // Triangles with a non-finite vertex are left out: one NaN in a box's running minimum
    // would make it forget the triangles before it. The loader refuses such vertices, so
    // only a scene built by hand can have them, and nothing about hitting them is promised.
    let finite = triangles.filter(|p| p.iter().all(|v| v.is_finite()));
    let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    for t in finite.clone() {
        for p in t {
            (lo, hi) = (lo.min(p), hi.max(p));
        }
    }
    let g = CLUSTER_GRID;
    // Cells per unit length along each axis (0 along an axis of no extent).
    let extent = hi - lo;
    let scale = Vec3A::select(
        extent.cmpgt(Vec3A::ZERO),
        Vec3A::splat(g as f32) / extent,
        Vec3A::ZERO,
    );
    let mut boxes = vec![(Vec3A::INFINITY, Vec3A::NEG_INFINITY); g * g * g];
    for [a, b, c] in finite {
        let centroid = (a + b + c) * (1.0 / 3.0);
        // Any cell will do for the bound to hold; clamping keeps rounding (and NaN, which
        // the loader refuses anyway) inside the grid.
        let cell = ((centroid - lo) * scale)
            .to_array()
            .map(|v| (v as usize).min(g - 1));
        let bounds = &mut boxes[(cell[2] * g + cell[1]) * g + cell[0]];
        *bounds = (bounds.0.min(a).min(b).min(c), bounds.1.max(a).max(b).max(c));
    }
    boxes
        .into_iter()
        .filter(|(lo, hi)| lo.cmple(*hi).all())
        .map(|(lo, hi)| (lo.into(), hi.into()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every triangle lies whole inside one cluster box, so a ray that misses every box
    /// misses it: random triangles from slivers to ones spanning the scene, a flat scene (no
    /// extent along one axis), far from the origin, a single triangle, and triangles with
    /// non-finite vertices among the rest (left out). And the grid does split a spread-out
    /// scene.
    #[test]
    fn every_triangle_lies_inside_a_cluster_box() {
        let mut next = crate::sampling::hash::uniform_sequence(11);
        let mut v = |scale: f32| Vec3::new(next(), next(), next()) * scale;
        for (n, flat, offset) in [
            (2000, false, Vec3::ZERO),
            (2000, true, Vec3::ZERO),
            (500, false, Vec3::splat(3e4)),
            (1, false, Vec3::ZERO),
            (300, false, Vec3::ZERO),
        ] {
            let mut scene = Scene::default();
            for i in 0..n {
                let a = v(100.0);
                let size = [0.001, 1.0, 60.0][i % 3];
                let mut tri = [a, a + v(size), a + v(size)];
                if flat {
                    tri = tri.map(|p| Vec3::new(p.x, p.y, 5.0));
                }
                let base = scene.positions.len() as u32;
                scene.positions.extend(tri.map(|p| p + offset));
                scene.triangles.push([base, base + 1, base + 2]);
            }
            if n == 300 {
                // A triangle with a NaN vertex and one with an infinite one among the rest:
                // left out, and the others still covered.
                for bad in [f32::NAN, f32::INFINITY] {
                    let base = scene.positions.len() as u32;
                    scene
                        .positions
                        .extend([Vec3::ONE, Vec3::new(bad, 2.0, 1.0), Vec3::Y]);
                    scene.triangles.insert(100, [base, base + 1, base + 2]);
                }
            }
            let boxes = cluster_boxes(&scene, 0..scene.triangles.len() as u32);
            assert!(boxes
                .iter()
                .all(|(lo, hi)| lo.is_finite() && hi.is_finite()));
            assert!(!boxes.is_empty() && boxes.len() <= CLUSTER_GRID.pow(3));
            if n > 1 {
                assert!(boxes.len() > 16, "{n} triangles in {} boxes", boxes.len());
            }
            for t in &scene.triangles {
                let p = t.map(|i| scene.positions[i as usize]);
                if !p.iter().all(|q| q.is_finite()) {
                    continue;
                }
                let inside = boxes
                    .iter()
                    .any(|(lo, hi)| p.iter().all(|q| q.cmpge(*lo).all() && q.cmple(*hi).all()));
                assert!(inside, "triangle {p:?} lies in no cluster box");
            }
        }
    }

    /// Unit length and the right direction for normals of every magnitude a scene can give
    /// (cross products of edges from 1e-12 to 1e12 units, both sides of the fast path's
    /// range), and zero for degenerate or non-finite ones.
    #[test]
    fn unit_normals_of_any_magnitude() {
        for dir in [
            Vec3::new(0.3, -0.5, 0.8),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(-2e-3, 7.0, 1e-4),
        ] {
            let want = dir.as_dvec3().normalize();
            for e in (-24..=24).step_by(3) {
                let n = dir * 10f32.powi(e);
                let u = unit_normal(n);
                let err = (u.as_dvec3() - want).length();
                assert!(err < 1e-6, "{n:?}: {u:?} is {err} from {want:?}");
            }
        }
        assert_eq!(unit_normal(Vec3::ZERO), Vec3::ZERO);
        assert_eq!(unit_normal(Vec3::new(f32::NAN, 1.0, 0.0)), Vec3::ZERO);
        assert_eq!(unit_normal(Vec3::new(f32::INFINITY, 1.0, 0.0)), Vec3::ZERO);
    }
}
