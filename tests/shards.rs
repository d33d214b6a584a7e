//! Films of disjoint sample ranges ([`RenderSettings::sample_range`], a farm's shards) merged
//! with [`Film::merge`] equal the film of the whole range bit for bit: sums, squares, counts,
//! feature totals and first hits, and so the image, its variances and its passes. The film's
//! fixed-point sums make this so; the negative control shows that the f64 sums the film kept
//! before (added sample by sample, per shard, then the shards' sums added) do not.

mod common;

use std::path::Path;

use common::{render_quietly_on, repo_path};
use glam::Vec3;
use strata::accel::{Accel, AccelOptions};
use strata::integrators::{Context, Integrator, PathSettings, Prepared};
use strata::render::film::value_of;
use strata::render::passes::Pass;
use strata::render::{self, Film, MergeError, RenderSettings};
use strata::sampling::SamplerKind;
use strata::scene::{self, LoadOptions, Scene};

const SPP: u32 = 24;
/// Uneven shard boundaries: [0, 5), [5, 13), [13, 24).
const SHARDS: [(u32, u32); 3] = [(0, 5), (5, 13), (13, SPP)];
const PASSES: [Pass; 4] = [Pass::Albedo, Pass::Normal, Pass::Depth, Pass::ObjectId];

fn render_range(
    ctx: &Context,
    scene: &Scene,
    range: Option<(u32, u32)>,
    threads: usize,
    spp: u32,
) -> Film {
    let settings = RenderSettings {
        camera: scene.cameras[0].clone(),
        width: 40,
        height: 30,
        spp,
        seed: 11,
        sampler: SamplerKind::Sobol,
        integrator: Integrator::Path(PathSettings::default()),
        // Tiles that do not divide the image; passes of 1, 1, 2, 4, … samples, which split
        // the whole range and each shard's range into rounds differently.
        tile_size: 16,
        sample_range: range,
        min_pass_seconds: 0.0,
        crop: None,
        stopping: Default::default(),
    };
    let result = render_quietly_on(threads, ctx, &settings);
    assert_eq!(result.stats.bad_samples, 0);
    result.film
}

/// Every pixel's exact totals, feature totals and first hit.
#[allow(clippy::type_complexity)]
fn raw(film: &Film) -> Vec<(render::PixelTotals, render::FeatureTotals, u64)> {
    pixels(film)
        .map(|(x, y)| {
            (
                film.totals(x, y),
                film.feature_totals(x, y),
                film.first_hit_raw(x, y),
            )
        })
        .collect()
}

fn pixels(film: &Film) -> impl Iterator<Item = (u32, u32)> {
    let (w, h) = (film.width, film.height);
    (0..h).flat_map(move |y| (0..w).map(move |x| (x, y)))
}

/// What the film writes: the beauty, its variances and the passes, as bits.
fn output(film: &Film, scene: &Scene) -> Vec<u32> {
    let mut out: Vec<u32> = Vec::new();
    for (x, y) in pixels(film) {
        out.extend(film.pixel(x, y).to_array().map(f32::to_bits));
        out.extend(film.variance_of_mean(x, y).to_array().map(f32::to_bits));
        let origin = film.first_hit(x, y).map(|h| {
            let (prim, inst) = render::split_first_hit(h);
            scene.origin(prim, inst)
        });
        for pass in PASSES {
            out.extend(pass.values(film.features(x, y), origin).map(f32::to_bits));
        }
    }
    out
}

/// The cornell box, path traced, with feature and ID passes kept.
fn with_cornell_box(f: impl FnOnce(&Context, &Scene)) {
    let path = repo_path("scenes/cornell-box.gltf");
    let scene = scene::load(&path, &LoadOptions::default()).unwrap();
    let accel = Accel::build(&scene, &AccelOptions::default()).unwrap();
    let integrator = Integrator::Path(PathSettings::default());
    let prepared = Prepared::new(&scene, Path::new("test"), &integrator, Vec3::ZERO).unwrap();
    let mut ctx = prepared.context(&scene, &accel);
    (ctx.features, ctx.ids) = (true, true);
    f(&ctx, &scene)
}

#[test]
fn shards_of_uneven_sample_ranges_merge_to_the_whole_render_bit_for_bit() {
    with_cornell_box(|ctx, scene| {
        let whole = render_range(ctx, scene, None, 2, SPP);
        // The shards on different thread counts.
        let shards: Vec<Film> = (SHARDS.iter().zip([1, 2, 1]))
            .map(|(&r, threads)| render_range(ctx, scene, Some(r), threads, SPP))
            .collect();
        for (shard, (a, b)) in shards.iter().zip(SHARDS) {
            assert_eq!(shard.count_range(), (b - a, b - a));
        }
        // Only the shard holding sample 0 has first hits.
        assert!(pixels(&shards[0]).any(|(x, y)| shards[0].first_hit(x, y).is_some()));
        assert!(pixels(&shards[1]).all(|(x, y)| shards[1].first_hit(x, y).is_none()));
        let want = (raw(&whole), output(&whole, scene));
        // Merged in order, and in another order.
        for order in [[0, 1, 2], [2, 0, 1]] {
            let mut merged = shards[order[0]].clone();
            for &i in &order[1..] {
                merged.merge(&shards[i]).unwrap();
            }
            let got = (raw(&merged), output(&merged, scene));
            let differing = (want.0.iter().zip(&got.0)).filter(|(a, b)| a != b).count();
            assert_eq!(
                differing, 0,
                "order {order:?}: {differing} pixels' totals differ"
            );
            assert!(want.1 == got.1, "order {order:?}: the output differs");
        }
    });
}

/// The film's sums as they were before they became exact: f64, added sample by sample. Each
/// sample's value comes from a film of that one sample (whose fixed-point sum converts back
/// to the f32 value exactly, values under 2^-17 but for less than 2^-40). The sums of squares
/// of the shards added together differ from the sequential sums on some pixels (the plain
/// sums of f32 values in f64 rarely round at this spp: counted, not asserted); the
/// fixed-point sums of the same films do not.
#[test]
fn f64_sums_of_the_same_shards_do_not_merge_bit_for_bit() {
    with_cornell_box(|ctx, scene| {
        let (spp, shards) = (SPP, SHARDS);
        let samples: Vec<Film> = (0..spp)
            .map(|k| render_range(ctx, scene, Some((k, k + 1)), 2, spp))
            .collect();
        let whole = render_range(ctx, scene, None, 2, spp);
        let (mut exact_differ, mut f64_differ, mut f64_sq_differ, mut channels) = (0, 0, 0, 0);
        for (x, y) in pixels(&whole) {
            for c in 0..3 {
                channels += 1;
                let v: Vec<f64> = (samples.iter())
                    .map(|f| value_of(f.totals(x, y).0[c]))
                    .collect();
                // Old: one f64 sum in sample order, against the shards' f64 sums added.
                let sequential = v.iter().fold(0.0, |s, v| s + v);
                let sharded = (shards.iter())
                    .map(|(a, b)| v[*a as usize..*b as usize].iter().fold(0.0, |s, v| s + v))
                    .fold(0.0, |s, p| s + p);
                f64_differ += (sequential.to_bits() != sharded.to_bits()) as u32;
                let sequential_sq = v.iter().fold(0.0, |s, v| s + v * v);
                let sharded_sq = (shards.iter())
                    .map(|(a, b)| (v[*a as usize..*b as usize].iter()).fold(0.0, |s, v| s + v * v))
                    .fold(0.0, |s, p| s + p);
                f64_sq_differ += (sequential_sq.to_bits() != sharded_sq.to_bits()) as u32;
                // New: the one-sample films' fixed-point sums, added, are the whole film's.
                let exact: i128 = samples.iter().map(|f| f.totals(x, y).0[c]).sum();
                exact_differ += (exact != whole.totals(x, y).0[c]) as u32;
            }
        }
        eprintln!(
            "f64 partial sums differ from the sequential sum in {f64_differ} of {channels} \
             pixel channels (squares: {f64_sq_differ}); fixed-point sums in {exact_differ}"
        );
        assert_eq!(exact_differ, 0);
        assert!(f64_sq_differ > 0, "the control should differ");
    });
}

#[test]
fn merge_refuses_films_that_do_not_belong_together() {
    with_cornell_box(|ctx, scene| {
        let first = render_range(ctx, scene, Some((0, 2)), 2, 4);
        // Both hold sample 0: overlapping ranges.
        let mut again = first.clone();
        assert!(matches!(
            again.merge(&first),
            Err(MergeError::BothHaveSampleZero(..))
        ));
        // Unchanged by the refusal.
        assert_eq!(raw(&again), raw(&first));
        let mut other_size = Film::new(40, 31);
        other_size.keep_features();
        other_size.keep_first_hits();
        assert_eq!(
            again.merge(&other_size),
            Err(MergeError::Size(40, 30, 40, 31))
        );
        assert_eq!(
            again.merge(&Film::new(40, 30)),
            Err(MergeError::Layers),
            "a film without passes"
        );
    });
}
