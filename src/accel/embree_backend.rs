//! The Embree backend of [`super::Accel`]: one geometry holding every scene triangle, either
//! as triangles (Embree's primitive id is then the scene's triangle index) or as quads.
//!
//! Quads: triangles that share an edge are given to Embree as one quad when the quad's box is
//! not much larger than theirs (two halves of a rectangle, as in most architectural and
//! modelled scenes), and the rest as degenerate quads (v3 = v2) in the same geometry (a
//! second geometry of triangles would make Embree build and traverse a second BVH). Embree
//! intersects a quad's two triangles in one test: on the Cornell box diffuse rays trace
//! 1.17–1.21× as fast (`cargo bench --bench backends -- quads/`), and a path-traced render
//! takes 9% less time (BENCHMARKS.md). Hits are mapped back to the scene's triangle and its own
//! barycentrics ([`QuadTriangles`]). Where few triangles pair (meshes without shared edges),
//! plain triangles are used: a degenerate quad costs a little more than a triangle.
//!
//! Alpha coverage ([`AlphaCoverage`]): the triangles whose hits alpha may reject go into a
//! second geometry, whose Embree filter callbacks ask the coverage about each candidate hit
//! ([`AlphaFilter`]); the other triangles stay in a geometry without a filter, and pay
//! nothing. Both geometries are of one primitive type (quads if the opaque triangles pair
//! well, else triangles), so Embree still builds and traverses one BVH (it builds one per
//! primitive type). A scene without alpha-tested triangles is laid out exactly as before:
//! one geometry, Embree's primitive ids the scene's triangle indices.
//!
//! Instances ([`crate::scene::Instance`]): each prototype's triangles are a scene of their own
//! (triangles or quads by the same rule, alpha-tested ones behind the filter), built once; each instance is an Embree instance
//! geometry of it in the top scene, after the world-space geometries, so that instance k's
//! geometry id is the first instance's + k. Embree reports an instanced hit's primitive in
//! the prototype's scene and its normal in the prototype's space: [`EmbreeAccel`] maps both
//! back (the scene's triangle; the normal by the instance's inverse transpose).

use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;

use glam::{Vec3, Vec3A};

use super::coverage::{ray_key, AlphaCoverage};
use super::{AccelMemory, AccelOptions, BuildQuality, Hit, Ray};
use crate::embree::{
    self, Device, EmbreeError, HitFilter, SceneBuilder, SceneOptions, OCCLUSION_PACKET, PACKET,
};
use crate::scene::{Instance, Scene, NO_INSTANCE};

/// The scene triangles of one Embree quad (v0, v1, v2, v3), whose halves are (v0, v1, v3)
/// and (v2, v3, v1), and where each half's vertices sit in its triangle's order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct QuadTriangles {
    /// The triangle of the first half, whose vertex `first_rot` is v0 (so vertices
    /// first_rot + 1 and + 2, mod 3, are v1 and v3).
    first: u32,
    first_rot: u8,
    /// The triangle of the second half, whose vertex `second_rot` is v3 (so + 1 and + 2 are v1
    /// and v2); `u32::MAX` for a lone triangle (v3 = v2).
    second: u32,
    second_rot: u8,
}

/// Barycentrics (b1, b2) of a triangle's vertices 1 and 2, from the weights (w0, w1, w2) of
/// its vertices rot, rot + 1, rot + 2 (mod 3), where w0 = 1 − w1 − w2 is passed computed.
#[inline(always)]
fn rotate_barycentrics(rot: u8, w0: f32, w1: f32, w2: f32) -> (f32, f32) {
    match rot {
        0 => (w1, w2),
        1 => (w0, w1),
        _ => (w2, w0),
    }
}

impl QuadTriangles {
    /// The scene triangle and its barycentrics (b1, b2) of a hit at Embree's quad
    /// coordinates (u, v) (see [`crate::embree::SceneBuilder::attach_quads`]). A hit on the
    /// shared diagonal (u + v = 1, up to rounding) may be given to either triangle, as a
    /// shared edge of two triangles is.
    #[inline(always)]
    fn hit(&self, u: f32, v: f32) -> (u32, f32, f32) {
        if u + v <= 1.0 || self.second == u32::MAX {
            // First half (v0, v1, v3): weights 1 − u − v, u, v.
            let (b1, b2) = rotate_barycentrics(self.first_rot, 1.0 - u - v, u, v);
            (self.first, b1, b2)
        } else {
            // Second half (v2, v3, v1) at its own barycentrics u' = 1 − u, v' = 1 − v: weights
            // 1 − u' − v' = u + v − 1 for v2, u' for v3 and v' for v1. In the triangle's order
            // from v3: v3, v1, v2.
            let (b1, b2) = rotate_barycentrics(self.second_rot, 1.0 - u, 1.0 - v, (u + v) - 1.0);
            (self.second, b1, b2)
        }
    }
}

/// Pairs the scene's triangles `prims` (ascending indices) into quads where that should trace
/// faster: triangles of the same material that share an edge (by vertex position, so meshes
/// whose vertices are split along seams still pair), taken greedily in triangle order, when
/// the box of the pair has a surface area at most [`PAIR_AREA_RATIO`] × the mean of the two
/// triangles' boxes' (the halves of a rectangle: equal; two thin neighbours of a curved mesh:
/// larger). Returns the quads' vertex indices and triangles (the unpaired ones as degenerate
/// quads), or `None` when under half of the triangles pair, unless `always`.
///
/// Edges are matched by sorting vertices by position and directed edges by their ends (a
/// hash map of them took longer than Embree's whole build on the flight helmet).
fn pair_quads(
    scene: &Scene,
    prims: &[u32],
    always: bool,
) -> Option<(Vec<[u32; 4]>, Vec<QuadTriangles>)> {
    let at = |i: u32| scene.positions[i as usize];
    let box_area = |vs: &[Vec3]| {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &p in vs {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        let d = hi - lo;
        d.x * d.y + d.y * d.z + d.z * d.x
    };
    let triangle = |k: usize| scene.triangles[prims[k] as usize];
    // A first, cheap look (no allocation): could half of the triangles pair? A triangle whose
    // completion to a parallelogram across one of its edges stays within the ratio is a
    // candidate. Curved meshes (the flight helmet) stop here, and skip the sorts below (which
    // cost as much as half of Embree's build there).
    let n = prims.len();
    if !always {
        let candidates = (0..n)
            .filter(|&k| {
                let [a, b, c] = triangle(k).map(at);
                let area = box_area(&[a, b, c]);
                [b + c - a, c + a - b, a + b - c]
                    .iter()
                    .any(|&w| box_area(&[a, b, c, w]) <= PAIR_AREA_RATIO * area)
            })
            .count();
        if 2 * candidates < n {
            return None;
        }
    }
    // Each vertex's canonical index: the first of the vertices at its exact position.
    let position_key = |i: u32| at(i).to_array().map(f32::to_bits);
    let mut order: Vec<u32> = (0..scene.positions.len() as u32).collect();
    order.sort_unstable_by_key(|&i| (position_key(i), i));
    let mut canonical = vec![0u32; scene.positions.len()];
    for run in order.chunk_by(|&a, &b| position_key(a) == position_key(b)) {
        for &i in run {
            canonical[i as usize] = run[0];
        }
    }
    let edge_key =
        |a: u32, b: u32| (canonical[a as usize] as u64) << 32 | canonical[b as usize] as u64;
    // Every directed edge: (key, k × 3 + its first corner) for the k-th triangle of `prims`,
    // sorted by key.
    let mut edges: Vec<(u64, u32)> = Vec::with_capacity(3 * n);
    for k in 0..n {
        let tri = triangle(k);
        for c in 0..3 {
            edges.push((edge_key(tri[c], tri[(c + 1) % 3]), 3 * k as u32 + c as u32));
        }
    }
    edges.sort_unstable();
    let mut paired = vec![false; n];
    let mut quads = Vec::with_capacity(n);
    let mut map = Vec::with_capacity(n);
    for (t, &prim) in prims.iter().enumerate() {
        if paired[t] {
            continue;
        }
        paired[t] = true;
        let tri = triangle(t);
        let material = scene.triangle_materials[prim as usize];
        // t = (x, y, z), rotated by k, pairs with a triangle s holding the edge z → y (t's
        // y → z reversed): that edge is the quad's diagonal v1 → v3, and s's third vertex w
        // is v2.
        let partner = (0..3).find_map(|k| {
            let (x, y, z) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let key = edge_key(z, y);
            let first = edges.partition_point(|e| e.0 < key);
            edges[first..]
                .iter()
                .take_while(|e| e.0 == key)
                .find_map(|&(_, corner)| {
                    let (s, edge) = ((corner / 3) as usize, corner % 3);
                    let other = triangle(s);
                    let w = other[(edge as usize + 2) % 3];
                    let fits = !paired[s]
                        && scene.triangle_materials[prims[s] as usize] == material
                        && canonical[w as usize] != canonical[x as usize]
                        && box_area(&[x, y, z, w].map(at))
                            <= PAIR_AREA_RATIO
                                * 0.5
                                * (box_area(&tri.map(at)) + box_area(&other.map(at)));
                    // In s's order, z is vertex `edge`: v3 of the quad.
                    fits.then_some((k as u8, s, edge as u8, [x, y, w, z]))
                })
        });
        match partner {
            Some((first_rot, s, second_rot, quad)) => {
                paired[s] = true;
                quads.push(quad);
                map.push(QuadTriangles {
                    first: prim,
                    first_rot,
                    second: prims[s],
                    second_rot,
                });
            }
            None => {
                quads.push([tri[0], tri[1], tri[2], tri[2]]);
                map.push(QuadTriangles {
                    first: prim,
                    first_rot: 0,
                    second: u32::MAX,
                    second_rot: 0,
                });
            }
        }
    }
    // Each pair saved one quad: under half of the triangles paired, keep triangles.
    let pairs = n - quads.len();
    (always || 4 * pairs >= n).then_some((quads, map))
}

/// See [`pair_quads`]. On the Cornell box 1.02 pairs 28 of its 36 triangles (the walls' and
/// the blocks' faces, whose halves each span the rectangle's box), as 1.2 does; 1.5 and more
/// also pair triangles across the blocks' edges, and trace slower. At 1.2 the flight helmet
/// pairs 58% of its triangles, neighbours on its curved surfaces, and its AO renders 5%
/// slower; at 1.02 it stays triangles (BENCHMARKS.md).
const PAIR_AREA_RATIO: f32 = 1.02;

/// How an Embree geometry's primitives map back to scene triangles.
#[derive(Debug)]
enum PrimMap {
    /// Primitive i is scene triangle i (every triangle, as triangles).
    Identity,
    /// Primitive i is scene triangle `ids[i]`.
    Triangles(Vec<u32>),
    /// Primitive i is the quad of the triangles `quads[i]`.
    Quads(Vec<QuadTriangles>),
}

impl PrimMap {
    /// The scene triangle and its barycentrics of a hit on primitive `prim` at Embree's
    /// (u, v), a primitive of the geometry ([`PrimMap::has`]).
    #[inline(always)]
    fn hit(&self, prim: u32, u: f32, v: f32) -> (u32, f32, f32) {
        match self {
            PrimMap::Identity => (prim, u, v),
            PrimMap::Triangles(ids) => (ids[prim as usize], u, v),
            PrimMap::Quads(quads) => quads[prim as usize].hit(u, v),
        }
    }

    /// True when the geometry has primitive `prim` (what Embree reports always is; the
    /// filter checks, as it must not panic).
    #[inline(always)]
    fn has(&self, prim: u32) -> bool {
        match self {
            PrimMap::Identity => true,
            PrimMap::Triangles(ids) => (prim as usize) < ids.len(),
            PrimMap::Quads(quads) => (prim as usize) < quads.len(),
        }
    }

    fn is_quads(&self) -> bool {
        matches!(self, PrimMap::Quads(_))
    }
}

/// The hit filter of the alpha-tested triangles' geometry: a hit counts where the scene
/// triangle's alpha covers it ([`AlphaCoverage::covers`]).
struct AlphaFilter {
    map: PrimMap,
    coverage: Arc<AlphaCoverage>,
    /// The top scene's geometry id of instance 0, for a prototype's filter (set once the
    /// instances are attached, before any ray is traced): Embree reports the instance by
    /// its geometry id, BLEND's coin reads the scene's instance index.
    first_instance: AtomicU32,
}

impl AlphaFilter {
    fn new(map: PrimMap, coverage: Arc<AlphaCoverage>) -> AlphaFilter {
        AlphaFilter {
            map,
            coverage,
            first_instance: AtomicU32::new(0),
        }
    }
}

impl HitFilter for AlphaFilter {
    #[inline]
    fn accept(&self, prim: u32, inst: u32, u: f32, v: f32, ray_id: u32) -> bool {
        if !self.map.has(prim) {
            return true;
        }
        let (tri, u, v) = self.map.hit(prim, u, v);
        let inst = match inst == embree::INVALID_GEOMETRY_ID {
            true => NO_INSTANCE,
            false => inst.wrapping_sub(self.first_instance.load(Ordering::Relaxed)),
        };
        // The ray's key travels as its Embree id ([`EmbreeAccel::lane`]).
        self.coverage.covers(tri, inst, u, v, ray_id)
    }
}

/// The vertices that `indices` use, in order of first use, with `indices` renumbered to
/// them: the alpha-tested triangles and the others each get only their own vertices.
fn compact_vertices<const N: usize>(
    positions: &[[f32; 3]],
    indices: &mut [[u32; N]],
) -> Vec<[f32; 3]> {
    let mut renumbered = vec![u32::MAX; positions.len()];
    let mut used = Vec::new();
    for i in indices.iter_mut().flatten() {
        let new = &mut renumbered[*i as usize];
        if *new == u32::MAX {
            *new = used.len() as u32;
            used.push(positions[*i as usize]);
        }
        *i = *new;
    }
    used
}

/// The geometry of scene triangles `prims` (ascending), as quads (`quads`: what
/// [`pair_quads`] made of them) or as triangles: its own vertices, its index buffer, and how
/// its primitives map back.
enum Part {
    Triangles(Vec<[f32; 3]>, Vec<[u32; 3]>, PrimMap),
    Quads(Vec<[f32; 3]>, Vec<[u32; 4]>, PrimMap),
}

impl Part {
    fn new(
        scene: &Scene,
        positions: &[[f32; 3]],
        prims: &[u32],
        quads: Option<(Vec<[u32; 4]>, Vec<QuadTriangles>)>,
    ) -> Part {
        match quads {
            Some((mut indices, map)) => {
                let vertices = compact_vertices(positions, &mut indices);
                Part::Quads(vertices, indices, PrimMap::Quads(map))
            }
            None => {
                let mut indices: Vec<[u32; 3]> =
                    prims.iter().map(|&t| scene.triangles[t as usize]).collect();
                let vertices = compact_vertices(positions, &mut indices);
                Part::Triangles(vertices, indices, PrimMap::Triangles(prims.to_vec()))
            }
        }
    }

    /// Attaches the geometry without a filter; returns its map.
    fn attach(self, builder: &mut SceneBuilder) -> Result<PrimMap, EmbreeError> {
        match self {
            Part::Triangles(v, i, map) => builder.attach_triangles(&v, &i).map(|_| map),
            Part::Quads(v, i, map) => builder.attach_quads(&v, &i).map(|_| map),
        }
    }

    /// Attaches the geometry with [`AlphaFilter`] on its hits; returns its id and the filter.
    fn attach_filtered(
        self,
        builder: &mut SceneBuilder,
        coverage: Arc<AlphaCoverage>,
    ) -> Result<(u32, Arc<AlphaFilter>), EmbreeError> {
        let (id, filter) = match self {
            Part::Triangles(v, i, map) => {
                let filter = Arc::new(AlphaFilter::new(map, coverage));
                (
                    builder.attach_filtered_triangles(&v, &i, filter.clone())?,
                    filter,
                )
            }
            Part::Quads(v, i, map) => {
                let filter = Arc::new(AlphaFilter::new(map, coverage));
                (
                    builder.attach_filtered_quads(&v, &i, filter.clone())?,
                    filter,
                )
            }
        };
        Ok((id, filter))
    }
}

/// The geometries of some of a scene's triangles: how the primitives of the one without a
/// filter map to the scene's triangles, and the alpha-tested ones' geometry id and filter (which
/// holds their map), if any.
type Parts = (PrimMap, Option<(u32, Arc<AlphaFilter>)>);

/// The instances of a scene's prototypes in the top scene.
struct Placed {
    /// Each prototype's geometries in its own scene.
    prototypes: Vec<Parts>,
    /// The scene's instances.
    instances: Arc<Vec<Instance>>,
    /// The geometry id of instance 0 in the top scene.
    first_id: u32,
}

pub struct EmbreeAccel {
    scene: embree::Scene,
    version: String,
    memory: AccelMemory,
    /// The prototypes and their instances, if the scene has any.
    placed: Option<Placed>,
    /// How the primitives of the geometry without a filter map to scene triangles (all of
    /// them when none is alpha-tested).
    opaque: PrimMap,
    /// The geometry of the alpha-tested triangles: its id and its filter (which holds its
    /// map).
    alpha: Option<(u32, Arc<AlphaFilter>)>,
    /// True when rays carry their key for BLEND's coin ([`ray_key`]): some triangle BLENDs.
    keyed: bool,
}

impl EmbreeAccel {
    /// Builds the BVH of `scene`'s triangles, those that `coverage` tests behind a filter.
    pub fn build(
        scene: &Scene,
        options: &AccelOptions,
        coverage: Option<Arc<AlphaCoverage>>,
    ) -> Result<EmbreeAccel, EmbreeError> {
        let config = if options.threads > 0 {
            format!("threads={},verbose=0", options.threads)
        } else {
            "verbose=0".to_string()
        };
        let device = Device::new(&config)?;
        let quality = match options.quality {
            BuildQuality::Low => embree::BuildQuality::Low,
            BuildQuality::Medium => embree::BuildQuality::Medium,
            BuildQuality::High => embree::BuildQuality::High,
        };
        // Robust mode (the default): Embree's fast path may let rays slip through shared edges
        // and vertices of closed meshes; ROBUST keeps the watertight test so AO and shadow
        // rays never leak through a mesh. Its cost is measured in BENCHMARKS.md.
        let mut builder = SceneBuilder::new(
            &device,
            SceneOptions {
                quality,
                robust: options.robust,
                compact: false,
            },
        )?;
        // glam's Vec3 is three packed f32s: the same layout as Embree's FLOAT3 buffer items.
        let positions: Vec<[f32; 3]> = scene.positions.iter().map(|p| p.to_array()).collect();
        let instanced = !scene.prototypes.is_empty();
        // Without prototypes every triangle is in world space (and the layout is the one
        // before instances).
        let all: Vec<u32> = match instanced {
            false => (0..scene.triangles.len() as u32).collect(),
            true => scene.flat_triangles(),
        };
        let (opaque, alpha) = attach_parts(
            &mut builder,
            scene,
            &positions,
            &all,
            coverage.as_ref(),
            options,
            !instanced,
        )?;
        // The vertex and index buffers: the world-space triangles', then each prototype's
        // (whose BVHs are built in `place_instances`).
        let mut geometry = device.memory_in_use();
        let placed = match instanced {
            false => None,
            true => {
                let (placed, buffers) = place_instances(
                    scene,
                    &device,
                    options,
                    &positions,
                    coverage.as_ref(),
                    &mut builder,
                )?;
                geometry += buffers;
                Some(placed)
            }
        };
        let scene = builder.commit()?;
        // What stays allocated after the build (the builder's scratch memory is freed).
        let total = device.memory_in_use();
        let memory = AccelMemory {
            geometry: geometry.max(0) as usize,
            bvh: (total - geometry).max(0) as usize,
            build_peak: Some(device.peak_memory().max(0) as usize),
        };
        let version = scene.device().version();
        Ok(EmbreeAccel {
            scene,
            version,
            memory,
            placed,
            opaque,
            alpha,
            keyed: coverage.as_ref().is_some_and(|c| c.blends()),
        })
    }

    /// How many instances the top scene places.
    pub fn instances(&self) -> usize {
        self.placed.as_ref().map_or(0, |p| p.instances.len())
    }

    /// True when the geometry is made of quads (see the module docs).
    pub fn uses_quads(&self) -> bool {
        self.opaque.is_quads() || self.alpha.as_ref().is_some_and(|(_, f)| f.map.is_quads())
    }

    /// How many triangles are behind the alpha filter.
    pub fn filtered_triangles(&self) -> usize {
        self.alpha
            .as_ref()
            .map_or(0, |(_, f)| f.coverage.tested_triangles())
    }

    /// Embree's answer as a backend-neutral hit: the scene triangle and its barycentrics, and
    /// the unit geometric normal.
    #[inline(always)]
    fn to_hit(&self, h: embree::RawHit) -> Hit {
        if h.inst_id != embree::INVALID_GEOMETRY_ID {
            if let Some(placed) = &self.placed {
                return placed.hit(h);
            }
        }
        let (prim, u, v) = match &self.alpha {
            Some((id, filter)) if h.geom_id == *id => filter.map.hit(h.prim_id, h.u, h.v),
            _ => self.opaque.hit(h.prim_id, h.u, h.v),
        };
        Hit {
            t: h.t,
            prim,
            inst: NO_INSTANCE,
            u,
            v,
            ng: super::unit_normal(Vec3::from_array(h.ng)),
        }
    }

    /// Ray `r` as Embree takes it: with its key for BLEND's coin as its id where some
    /// triangle BLENDs, else id 0 (the key's hash is then not computed).
    #[inline(always)]
    fn lane(&self, r: &Ray) -> embree::Lane {
        let id = match self.keyed {
            true => ray_key(r),
            false => 0,
        };
        (r.org.to_array(), r.dir.to_array(), r.t_min, r.t_max, id)
    }

    #[inline(always)]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let (org, dir, t_min, t_max, id) = self.lane(ray);
        self.scene
            .intersect_id(org, dir, t_min, t_max, id)
            .map(|h| self.to_hit(h))
    }

    /// The closest hits of up to [`PACKET`] coherent rays in one packet query.
    #[inline]
    pub fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<Hit>; PACKET]) {
        hits[rays.len()..].fill(None);
        self.scene.intersect_packet(
            rays,
            |r| self.lane(r),
            |i, h| hits[i] = h.map(|h| self.to_hit(h)),
        );
    }

    /// Any-hit answers for up to [`OCCLUSION_PACKET`] rays in one packet query.
    #[inline]
    pub fn occluded_packet(&self, rays: &[Ray], occluded: &mut [bool; OCCLUSION_PACKET]) {
        self.scene
            .occluded_packet(rays, |r| self.lane(r), |i, o| occluded[i] = o);
    }

    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        let (org, dir, t_min, t_max, id) = self.lane(ray);
        self.scene.occluded_id(org, dir, t_min, t_max, id)
    }

    pub fn memory(&self) -> AccelMemory {
        self.memory
    }

    /// The bounds of the committed scene, as Embree computed them.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let (lo, hi) = self.scene.bounds();
        (Vec3::from_array(lo), Vec3::from_array(hi))
    }

    /// The committed Embree scene (for measurements against raw Embree calls).
    pub fn raw(&self) -> &embree::Scene {
        &self.scene
    }

    pub fn describe(&self) -> String {
        let quad_maps = [Some(&self.opaque), self.alpha.as_ref().map(|(_, f)| &f.map)];
        let (mut quads, mut pairs) = (0, 0);
        for map in quad_maps.into_iter().flatten() {
            if let PrimMap::Quads(q) = map {
                quads += q.len();
                pairs += q.iter().filter(|q| q.second != u32::MAX).count();
            }
        }
        let quads = match quads {
            0 => String::new(),
            _ => format!(", traced as {quads} quads ({pairs} of them pairs of triangles)"),
        };
        let alpha = match self.filtered_triangles() {
            0 => String::new(),
            n => format!(", {n} alpha-tested triangles behind a hit filter"),
        };
        let instances = self.placed.as_ref().map_or(String::new(), |p| {
            super::instances_note(p.instances.len(), p.prototypes.len())
        });
        format!(
            "Embree {} (compiled against {} headers){quads}{alpha}{instances}",
            self.version,
            env!("STRATA_EMBREE_HEADER_VERSION")
        )
    }
}

impl Placed {
    /// A hit inside instance geometry `h.inst_id`: the scene's triangle, placed by its
    /// instance, with the normal carried to world space.
    #[inline(always)]
    fn hit(&self, h: embree::RawHit) -> Hit {
        let k = h.inst_id.wrapping_sub(self.first_id);
        let instance = &self.instances[k as usize];
        let (prim, u, v) = match &self.prototypes[instance.prototype as usize] {
            (_, Some((id, filter))) if h.geom_id == *id => filter.map.hit(h.prim_id, h.u, h.v),
            (opaque, _) => opaque.hit(h.prim_id, h.u, h.v),
        };
        let ng = instance.normal_to_world * Vec3A::from_array(h.ng);
        Hit {
            t: h.t,
            prim,
            inst: k,
            u,
            v,
            ng: super::unit_normal(ng.into()),
        }
    }
}

/// Attaches triangles `prims` (ascending) of `scene` to `builder`: those `coverage` tests
/// behind [`AlphaFilter`], the rest without a filter, both as quads where the untested ones
/// pair well (judged on the tested ones when there are no others), so that Embree keeps one
/// BVH. `whole` says `prims` are all the scene's triangles, none tested: then they are one
/// geometry whose primitive ids are the scene's triangle indices, unless they pair into quads.
fn attach_parts(
    builder: &mut SceneBuilder,
    scene: &Scene,
    positions: &[[f32; 3]],
    prims: &[u32],
    coverage: Option<&Arc<AlphaCoverage>>,
    options: &AccelOptions,
    whole: bool,
) -> Result<Parts, EmbreeError> {
    let pair = |prims: &[u32], always| {
        options
            .quads
            .then(|| pair_quads(scene, prims, always))
            .flatten()
    };
    let (tested, untested): (Vec<u32>, Vec<u32>) = match coverage {
        Some(c) => prims.iter().partition(|&&t| c.tests(t)),
        None => (Vec::new(), prims.to_vec()),
    };
    if tested.is_empty() {
        // Nothing to attach: Embree commits an empty scene, which no ray hits.
        if untested.is_empty() {
            return Ok((PrimMap::Triangles(Vec::new()), None));
        }
        if !whole {
            let part = Part::new(scene, positions, &untested, pair(&untested, false));
            return Ok((part.attach(builder)?, None));
        }
        let map = match pair(&untested, false) {
            Some((indices, map)) => {
                builder.attach_quads(positions, &indices)?;
                PrimMap::Quads(map)
            }
            None => {
                builder.attach_triangles(positions, &scene.triangles)?;
                PrimMap::Identity
            }
        };
        return Ok((map, None));
    }
    let coverage = coverage.expect("tested triangles have a coverage").clone();
    let (opaque, tested_quads) = if untested.is_empty() {
        (PrimMap::Triangles(Vec::new()), pair(&tested, false))
    } else {
        let quads = pair(&untested, false);
        let tested_quads = quads.as_ref().and_then(|_| pair(&tested, true));
        let part = Part::new(scene, positions, &untested, quads);
        (part.attach(builder)?, tested_quads)
    };
    let alpha =
        Part::new(scene, positions, &tested, tested_quads).attach_filtered(builder, coverage)?;
    Ok((opaque, Some(alpha)))
}

/// Builds each of `scene`'s prototypes as a scene of its own and attaches its instances to
/// `top`, in order after the geometries already there (so their ids are consecutive). Returns
/// them and the bytes of the prototypes' vertex and index buffers.
fn place_instances(
    scene: &Scene,
    device: &Device,
    options: &AccelOptions,
    positions: &[[f32; 3]],
    coverage: Option<&Arc<AlphaCoverage>>,
    top: &mut SceneBuilder,
) -> Result<(Placed, i64), EmbreeError> {
    let scene_options = SceneOptions {
        quality: match options.quality {
            BuildQuality::Low => embree::BuildQuality::Low,
            BuildQuality::Medium => embree::BuildQuality::Medium,
            BuildQuality::High => embree::BuildQuality::High,
        },
        robust: options.robust,
        compact: false,
    };
    let mut children = Vec::with_capacity(scene.prototypes.len());
    let mut prototypes = Vec::with_capacity(scene.prototypes.len());
    let mut buffers = 0;
    for p in &scene.prototypes {
        let prims: Vec<u32> = p.triangles.clone().collect();
        let mut builder = SceneBuilder::new(device, scene_options)?;
        let before = device.memory_in_use();
        let parts = attach_parts(
            &mut builder,
            scene,
            positions,
            &prims,
            coverage,
            options,
            false,
        )?;
        buffers += device.memory_in_use() - before;
        prototypes.push(parts);
        children.push(Arc::new(builder.commit()?));
    }
    let mut first_id = None;
    for (k, instance) in scene.instances.iter().enumerate() {
        let m = instance.to_world;
        let cols: [f32; 12] = std::array::from_fn(|i| match i / 3 {
            0 => m.matrix3.x_axis[i % 3],
            1 => m.matrix3.y_axis[i % 3],
            2 => m.matrix3.z_axis[i % 3],
            _ => m.translation[i % 3],
        });
        let id = top.attach_instance(&children[instance.prototype as usize], &cols)?;
        let first = *first_id.get_or_insert(id);
        if id != first + k as u32 {
            return Err(EmbreeError::unknown(format!(
                "Embree gave instance {k} geometry id {id}, not {} (ids must be consecutive)",
                first + k as u32
            )));
        }
    }
    let first_id = first_id.unwrap_or(0);
    for (_, alpha) in &prototypes {
        if let Some((_, filter)) = alpha {
            filter.first_instance.store(first_id, Ordering::Relaxed);
        }
    }
    let placed = Placed {
        prototypes,
        instances: scene.instances.clone(),
        first_id,
    };
    Ok((placed, buffers))
}
