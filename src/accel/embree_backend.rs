//! The Embree backend of [`super::Accel`]: one triangle geometry holding every scene triangle,
//! so Embree's primitive id is the scene's triangle index.

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

/// Embree's answer as a backend-neutral hit (unit geometric normal).
#[inline(always)]
fn to_hit(h: embree::RawHit) -> Hit {
    Hit {
        t: h.t,
        prim: h.prim_id,
        u: h.u,
        v: h.v,
        ng: super::unit_normal(Vec3::from_array(h.ng)),
    }
}

pub struct EmbreeAccel {
    scene: embree::Scene,
    version: String,
    memory: AccelMemory,
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
        builder.attach_triangles(&positions, &scene.triangles)?;
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
        })
    }

    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let (org, dir, t_min, t_max) = lane(ray);
        self.scene.intersect(org, dir, t_min, t_max).map(to_hit)
    }

    /// The closest hits of up to [`PACKET`] coherent rays in one packet query.
    #[inline]
    pub fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<Hit>; PACKET]) {
        hits[rays.len()..].fill(None);
        self.scene
            .intersect_packet(rays, lane, |i, h| hits[i] = h.map(to_hit));
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
        format!(
            "Embree {} (compiled against {} headers)",
            self.version,
            env!("STRATA_EMBREE_HEADER_VERSION")
        )
    }
}
