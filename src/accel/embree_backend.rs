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

use glam::Vec3;

use super::{AccelMemory, AccelOptions, BuildQuality, Hit, Ray};
use crate::embree::{
    self, Device, EmbreeError, SceneBuilder, SceneOptions, OCCLUSION_PACKET, PACKET,
};
use crate::scene::Scene;

/// A ray as the Embree module takes it: (origin, direction, t_min, t_max).
#[inline(always)]
fn lane(r: &Ray) -> ([f32; 3], [f32; 3], f32, f32) {
    (r.org.to_array(), r.dir.to_array(), r.t_min, r.t_max)
}

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

/// Pairs the scene's triangles into quads where that should trace faster: triangles of the
/// same material that share an edge (by vertex position, so meshes whose vertices are split
/// along seams still pair), taken greedily in triangle order, when the box of the pair has a
/// surface area at most [`PAIR_AREA_RATIO`] × the mean of the two triangles' boxes' (the
/// halves of a rectangle: equal; two thin neighbours of a curved mesh: larger). Returns the
/// quads' vertex indices and triangles, or `None` when under half of the triangles pair.
///
/// Edges are matched by sorting vertices by position and directed edges by their ends (a
/// hash map of them took longer than Embree's whole build on the flight helmet).
fn pair_quads(scene: &Scene) -> Option<(Vec<[u32; 4]>, Vec<QuadTriangles>)> {
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
    // A first, cheap look (no allocation): could half of the triangles pair? A triangle whose
    // completion to a parallelogram across one of its edges stays within the ratio is a
    // candidate. Curved meshes (the flight helmet) stop here, and skip the sorts below (which
    // cost as much as half of Embree's build there).
    let n = scene.triangles.len();
    let candidates = scene
        .triangles
        .iter()
        .filter(|tri| {
            let [a, b, c] = tri.map(at);
            let area = box_area(&[a, b, c]);
            [b + c - a, c + a - b, a + b - c]
                .iter()
                .any(|&w| box_area(&[a, b, c, w]) <= PAIR_AREA_RATIO * area)
        })
        .count();
    if 2 * candidates < n {
        return None;
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
    // Every directed edge: (key, triangle × 3 + its first corner), sorted by key.
    let triangles = &scene.triangles;
    let mut edges: Vec<(u64, u32)> = Vec::with_capacity(3 * triangles.len());
    for (t, tri) in triangles.iter().enumerate() {
        for k in 0..3 {
            edges.push((edge_key(tri[k], tri[(k + 1) % 3]), 3 * t as u32 + k as u32));
        }
    }
    edges.sort_unstable();
    let mut paired = vec![false; n];
    let mut quads = Vec::with_capacity(n);
    let mut map = Vec::with_capacity(n);
    for (t, &tri) in triangles.iter().enumerate() {
        if paired[t] {
            continue;
        }
        paired[t] = true;
        let material = scene.triangle_materials[t];
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
                    let other = triangles[s];
                    let w = other[(edge as usize + 2) % 3];
                    let fits = !paired[s]
                        && scene.triangle_materials[s] == material
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
                    first: t as u32,
                    first_rot,
                    second: s as u32,
                    second_rot,
                });
            }
            None => {
                quads.push([tri[0], tri[1], tri[2], tri[2]]);
                map.push(QuadTriangles {
                    first: t as u32,
                    first_rot: 0,
                    second: u32::MAX,
                    second_rot: 0,
                });
            }
        }
    }
    // Each pair saved one quad: under half of the triangles paired, keep triangles.
    let pairs = n - quads.len();
    (4 * pairs >= n).then_some((quads, map))
}

/// See [`pair_quads`]. On the Cornell box 1.02 pairs 28 of its 36 triangles (the walls' and
/// the blocks' faces, whose halves each span the rectangle's box), as 1.2 does; 1.5 and more
/// also pair triangles across the blocks' edges, and trace slower. At 1.2 the flight helmet
/// pairs 58% of its triangles, neighbours on its curved surfaces, and its AO renders 5%
/// slower; at 1.02 it stays triangles (BENCHMARKS.md).
const PAIR_AREA_RATIO: f32 = 1.02;

pub struct EmbreeAccel {
    scene: embree::Scene,
    version: String,
    memory: AccelMemory,
    /// The triangles of each quad, when the geometry is made of quads.
    quads: Option<Vec<QuadTriangles>>,
}

impl EmbreeAccel {
    pub fn build(scene: &Scene, options: &AccelOptions) -> Result<EmbreeAccel, EmbreeError> {
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
        let quads = match options.quads.then(|| pair_quads(scene)).flatten() {
            Some((indices, map)) => {
                builder.attach_quads(&positions, &indices)?;
                Some(map)
            }
            None => {
                builder.attach_triangles(&positions, &scene.triangles)?;
                None
            }
        };
        let geometry = device.memory_in_use();
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
            quads,
        })
    }

    /// True when the geometry is made of quads (see the module docs).
    pub fn uses_quads(&self) -> bool {
        self.quads.is_some()
    }

    /// Embree's answer as a backend-neutral hit: the scene triangle and its barycentrics, and
    /// the unit geometric normal.
    #[inline(always)]
    fn to_hit(&self, h: embree::RawHit) -> Hit {
        let (prim, u, v) = match &self.quads {
            Some(quads) => quads[h.prim_id as usize].hit(h.u, h.v),
            None => (h.prim_id, h.u, h.v),
        };
        Hit {
            t: h.t,
            prim,
            u,
            v,
            ng: super::unit_normal(Vec3::from_array(h.ng)),
        }
    }

    #[inline(always)]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let (org, dir, t_min, t_max) = lane(ray);
        self.scene
            .intersect(org, dir, t_min, t_max)
            .map(|h| self.to_hit(h))
    }

    /// The closest hits of up to [`PACKET`] coherent rays in one packet query.
    #[inline]
    pub fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<Hit>; PACKET]) {
        hits[rays.len()..].fill(None);
        self.scene
            .intersect_packet(rays, lane, |i, h| hits[i] = h.map(|h| self.to_hit(h)));
    }

    /// Any-hit answers for up to [`OCCLUSION_PACKET`] rays in one packet query.
    #[inline]
    pub fn occluded_packet(&self, rays: &[Ray], occluded: &mut [bool; OCCLUSION_PACKET]) {
        self.scene
            .occluded_packet(rays, lane, |i, o| occluded[i] = o);
    }

    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        let (org, dir, t_min, t_max) = lane(ray);
        self.scene.occluded(org, dir, t_min, t_max)
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
        let quads = match &self.quads {
            Some(map) => format!(
                ", traced as {} quads ({} of them pairs of triangles)",
                map.len(),
                map.iter().filter(|q| q.second != u32::MAX).count()
            ),
            None => String::new(),
        };
        format!(
            "Embree {} (compiled against {} headers){quads}",
            self.version,
            env!("STRATA_EMBREE_HEADER_VERSION")
        )
    }
}
