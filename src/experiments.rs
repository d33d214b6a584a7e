//! Switches that exist for measurements and tests only, gathered in one place.
//!
//! Each default is the renderer's one production setting; the other value keeps an earlier
//! or a deliberately wrong design alive so that a benchmark can measure what the default
//! gains, or a test can prove that it detects the wrong one. No switch here changes what a
//! render means, only how (or how well) it is estimated, except `ray_offset`, a negative
//! control. A switch goes when its measurement is recorded and nothing replays it.
//!
//! | field            | default | the other value, and who uses it                            |
//! |------------------|---------|-------------------------------------------------------------|
//! | `ray_offset`     | true    | rays leave from the hit point itself: acne, for             |
//! |                  |         | tests/stress_numerics.rs                                    |
//! | `camera_packets` | true    | camera rays traced one at a time (`--no-camera-packets`)    |
//! | `cull_blocks`    | true    | pixel blocks that cannot see the scene traced anyway: the    |
//! |                  |         | per-ray cost of strata's layers (benches/overhead.rs)       |
//! | `paired_bounces` | true    | each vertex's light point paired with its own BSDF direction |
//! |                  |         | instead of the film position or the previous direction      |
//! | `joint_bounces`  | true    | each bounce's 4D point padded instead of one Sobol sequence |
//! |                  |         | over the bounces (`--padded-bounces`)                       |
//! | `ao_film_paired` | true    | AO's one direction per hit not paired with the film position |
//! | `error_halves`   | true    | adaptive sampling's error from σ²/n alone, not the two      |
//! |                  |         | halves of a pixel's samples (`--sample-variance-error`)     |
//!
//! BENCHMARKS.md records what each default gains.

/// The measurement and test switches (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Experiments {
    /// Secondary rays leave surfaces past the hit point's error bound (the only correct
    /// setting); false spawns them from the hit point itself, which must show acne.
    pub ray_offset: bool,
    /// Trace camera rays of neighbouring pixels in packets; the hits, so the image, are the
    /// same either way but for a ray that meets an edge shared by two triangles at one
    /// distance, where packet and single-ray traversal may name different triangles (1
    /// camera ray in 4.9 M on the helmet, docs/journal/benchmarks-2026-11.md, "Packets").
    pub camera_packets: bool,
    /// Leave untraced the pixel blocks that cannot see the scene
    /// ([`crate::accel::culling::BlockMask`]); the image is the same either way (tested).
    pub cull_blocks: bool,
    /// Path tracing: the first light point comes with the film position, and a bounce's
    /// BSDF direction with the light point of the next vertex ([`crate::integrators::path`]).
    pub paired_bounces: bool,
    /// Path tracing with `sobol`: the bounces' 4D points are dimensions of one sequence.
    pub joint_bounces: bool,
    /// AO with one ray per hit: its direction is paired with the film position.
    pub ao_film_paired: bool,
    /// Adaptive sampling: a pixel's error from the two halves of its samples.
    pub error_halves: bool,
}

impl Default for Experiments {
    fn default() -> Experiments {
        Experiments {
            ray_offset: true,
            camera_packets: true,
            cull_blocks: true,
            paired_bounces: true,
            joint_bounces: true,
            ao_film_paired: true,
            error_halves: true,
        }
    }
}
