//! What a job writes into its images' headers: how the image was rendered
//! ([`header_attributes`], [`result_attributes`]), and for a farm's partial files the hashes
//! that let `render merge` refuse parts of another scene or other settings
//! ([`settings_hash`], [`partial_attributes`]). Beside the job they describe, so that the
//! writers in [`crate::render`] take plain attribute lists and never the job.

use std::path::PathBuf;

use sha2::{Digest, Sha256};

use super::Job;
use crate::integrators::Integrator;
use crate::render::merge::{files_hash, hex, Share};
use crate::render::output::{film_attributes, Attr};
use crate::render::RenderResult;
use crate::scene::Projection;

/// The camera of `view` for compositors: OpenEXR's `worldToCamera`
/// ([`crate::render::output::WORLD_TO_CAMERA`]) and, as text, its projection.
pub fn camera_attributes(view: &crate::job::View) -> Vec<(String, Attr)> {
    // Imath's row-vector convention: M_row = M_colᵀ, whose rows are M_col's columns.
    let to_camera = view.camera.to_world.inverse();
    let world_to_camera = to_camera.to_cols_array();
    let aspect = view.width as f32 / view.height as f32;
    // Camera space (looking down −Z, +Y up) to OpenEXR's NDC, x right and y down over [0, 1]:
    // perspective x_ndc = ½ + ½·x / (−z·tan(fov/2)·aspect), y_ndc = ½ − ½·y / (−z·tan(fov/2)),
    // with w = −z (and z_ndc = 1/−z, the inverse depth); orthographic without the division.
    let (sx, sy, perspective) = match view.camera.projection {
        Projection::Perspective { yfov } => {
            let t = (0.5 * yfov).tan();
            (t * aspect, t, true)
        }
        Projection::Orthographic { ymag } => (ymag * aspect, ymag, false),
    };
    let to_ndc = match perspective {
        true => glam::Mat4::from_cols(
            glam::Vec4::new(0.5 / sx, 0.0, 0.0, 0.0),
            glam::Vec4::new(0.0, -0.5 / sy, 0.0, 0.0),
            glam::Vec4::new(-0.5, -0.5, 0.0, -1.0),
            glam::Vec4::new(0.0, 0.0, 1.0, 0.0),
        ),
        false => glam::Mat4::from_cols(
            glam::Vec4::new(0.5 / sx, 0.0, 0.0, 0.0),
            glam::Vec4::new(0.0, -0.5 / sy, 0.0, 0.0),
            glam::Vec4::new(0.0, 0.0, -1.0, 0.0),
            glam::Vec4::new(0.5, 0.5, 0.0, 1.0),
        ),
    };
    let world_to_ndc = (to_ndc * to_camera).to_cols_array();
    let projection = match view.camera.projection {
        Projection::Perspective { yfov } => format!(
            "perspective, vertical field of view {} rad ({:.4}°), aspect ratio {aspect}",
            yfov,
            yfov.to_degrees()
        ),
        Projection::Orthographic { ymag } => {
            format!("orthographic, half-height {ymag}, aspect ratio {aspect}")
        }
    };
    vec![
        (
            crate::render::output::WORLD_TO_CAMERA.to_string(),
            Attr::Matrix(world_to_camera),
        ),
        (
            crate::render::output::WORLD_TO_NDC.to_string(),
            Attr::Matrix(world_to_ndc),
        ),
        ("strata:projection".into(), Attr::Text(projection)),
    ]
}

/// The header attributes that record how an image was rendered: the scene, the integrator
/// and its settings, the sampler, the samples per pixel, the seed, the backend (`backend`:
/// [`crate::accel::Accel::describe`]) and the stopping rule. They are the same for every
/// image a job writes; [`film_attributes`] and [`result_attributes`] add the film's state.
pub fn header_attributes(job: &Job, backend: &str) -> Vec<(String, Attr)> {
    let mut attrs = vec![
        (
            "strata:scene".to_string(),
            Attr::Text(job.scene.display().to_string()),
        ),
        (
            "strata:integrator".into(),
            Attr::Text(job.integrator.kind().to_string()),
        ),
        ("strata:sampler".into(), Attr::Text(job.sampler.to_string())),
        ("strata:spp".into(), Attr::Int(job.spp as i32)),
        ("strata:seed".into(), Attr::Text(job.seed.to_string())),
        ("strata:backend".into(), Attr::Text(backend.to_string())),
        (
            "strata:commit".into(),
            Attr::Text(env!("STRATA_COMMIT").into()),
        ),
        // What the PNG preview beside the EXR shows (the EXR itself stays linear).
        (
            "strata:preview_view".into(),
            Attr::Text(job.view.to_string()),
        ),
        ("strata:preview_exposure".into(), Attr::Float(job.exposure)),
    ];
    if let Some(e) = job.target_error {
        attrs.push(("strata:target_error".into(), Attr::Float(e)));
        attrs.push(("strata:min_spp".into(), Attr::Int(job.min_spp as i32)));
        attrs.push((
            "strata:error_metric".into(),
            Attr::Text(job.error_metric.to_string()),
        ));
    }
    if let Some(t) = job.time_limit {
        attrs.push(("strata:time_limit".into(), Attr::Float(t as f32)));
    }
    match job.integrator {
        Integrator::Ao(ao) => {
            attrs.push((
                "strata:hemisphere".into(),
                Attr::Text(ao.hemisphere.to_string()),
            ));
            attrs.push(("strata:ao_distance".into(), Attr::Float(ao.max_distance)));
            attrs.push(("strata:ao_samples".into(), Attr::Int(ao.samples as i32)));
        }
        Integrator::Direct(p) | Integrator::Path(p) => {
            attrs.push(("strata:max_depth".into(), Attr::Int(p.max_depth as i32)));
            attrs.push(("strata:rr_depth".into(), Attr::Int(p.rr_depth as i32)));
            attrs.push((
                "strata:emitter_samples".into(),
                Attr::Int(p.emitter_samples as i32),
            ));
            attrs.push(("strata:strategy".into(), Attr::Text(p.strategy.to_string())));
            let materials = job.shading.materials;
            attrs.push((
                "strata:materials".into(),
                Attr::Text(materials.model.to_string()),
            ));
            let compensation = match materials.energy_compensation {
                true => "on",
                false => "off",
            };
            attrs.push((
                "strata:energy_compensation".into(),
                Attr::Text(compensation.into()),
            ));
            attrs.push((
                "strata:hemisphere".into(),
                Attr::Text(job.hemisphere.to_string()),
            ));
            attrs.push((
                "strata:triangle_sampling".into(),
                Attr::Text(job.shading.triangle_sampling.to_string()),
            ));
            let b = (job.shading.camera_background)
                .or(job.shading.environment.constant())
                .unwrap_or_default();
            let background = match job.transparent {
                true => "transparent".to_string(),
                false => format!("{},{},{}", b.x, b.y, b.z),
            };
            attrs.push(("strata:background".into(), Attr::Text(background)));
            if let Some((path, degrees, scale)) = &job.env {
                let text = format!("{}", path.display());
                attrs.push(("strata:environment".into(), Attr::Text(text)));
                attrs.push(("strata:env_rotate".into(), Attr::Float(*degrees)));
                attrs.push(("strata:env_intensity".into(), Attr::Float(*scale)));
            }
        }
    }
    attrs
}

/// The header attributes of a finished render's image: [`film_attributes`], then whether
/// the time limit stopped it (with `--time-limit`) and how many pixels did not reach the
/// target error (with `--target-error`).
pub fn result_attributes(
    job: &Job,
    result: &RenderResult,
    prior_seconds: f64,
) -> Vec<(String, Attr)> {
    let mut attrs = film_attributes(
        &result.film,
        prior_seconds + result.stats.seconds,
        result.interrupted,
        false,
    );
    if job.time_limit.is_some() {
        attrs.push((
            "strata:time_limit_reached".into(),
            Attr::Int(result.time_limit_reached as i32),
        ));
    }
    if let Some(u) = result.unconverged_pixels {
        attrs.push((
            "strata:unconverged_pixels".into(),
            Attr::Int(u.min(i32::MAX as u64) as i32),
        ));
    }
    attrs
}

/// The settings of `job` that can change its image, as text ([`settings_hash`]): the job's
/// own description, less the options that cannot (where files go, the threads, the memory
/// limit, `--strict`, the preview, the pass timing, the report) and less the paths of the scene and the
/// environment map (whose contents [`files_hash`] covers), with strata's version. Call it on
/// the job as the options made it, before the scene lights it.
pub fn settings_key(job: &Job) -> String {
    let mut j = job.clone();
    j.scene = PathBuf::new();
    j.output = PathBuf::new();
    j.png = false;
    j.view = Default::default();
    j.exposure = 0.0;
    j.frames = None;
    j.variance = None;
    j.spp_image = None;
    j.threads = 0;
    j.min_pass_seconds = 0.0;
    j.memory_limit = None;
    j.strict = false;
    j.checkpoint = None;
    j.resume = None;
    j.progress_every = 0.0;
    j.stats = false;
    j.warnings.clear();
    j.share = None;
    if let Some((path, _, _)) = &mut j.env {
        *path = PathBuf::new();
    }
    format!("strata {} {j:?}", env!("CARGO_PKG_VERSION"))
}

/// SHA-256 of [`settings_key`].
pub fn settings_hash(job: &Job) -> String {
    hex(&Sha256::digest(settings_key(job).as_bytes()))
}

/// SHA-256 over the scene's `files` and the job's environment map ([`files_hash`]): what a
/// shard's part and an unfinished render's file carry, so that a merge or a resume refuses
/// files of an edited scene.
pub fn scene_hash(job: &Job, files: &[PathBuf]) -> Result<String, String> {
    let mut all = files.to_vec();
    all.extend(job.env.as_ref().map(|(p, _, _)| p.clone()));
    files_hash(&all)
}

/// The header attributes of a partial file of `share`: the sample range, the shard, and the
/// hashes of the scene's files (`files`, with the environment map's) and of the settings
/// (`settings_hash`, taken from the job before the scene changed it).
pub fn partial_attributes(
    job: &Job,
    share: Share,
    files: &[PathBuf],
    settings_hash: &str,
) -> Result<Vec<(String, Attr)>, String> {
    let (a, b) = share.range(job.spp);
    let mut attrs = vec![
        ("strata:partial".to_string(), Attr::Int(1)),
        ("strata:samples".into(), Attr::Text(format!("{a}..{b}"))),
        (
            "strata:scene_hash".into(),
            Attr::Text(scene_hash(job, files)?),
        ),
        (
            "strata:settings_hash".into(),
            Attr::Text(settings_hash.to_string()),
        ),
    ];
    if let Share::Shard { index, count } = share {
        attrs.push((
            "strata:shard".into(),
            Attr::Text(format!("{index}/{count}")),
        ));
    }
    Ok(attrs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::Args;
    use clap::Parser;
    use std::path::Path;

    fn job(dir: &Path, extra: &[&str]) -> Job {
        let out = dir.join("out.exr");
        let mut all = vec!["render", "scene.gltf", "-o", out.to_str().unwrap()];
        all.extend_from_slice(extra);
        let args = <crate::cli::Args as clap::Parser>::try_parse_from(all).unwrap();
        Job::from_args(&args).unwrap()
    }

    #[test]
    fn the_settings_hash_covers_what_changes_the_image_and_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let base = settings_hash(&job(dir.path(), &["--shard", "0/2"]));
        // Where files go, the threads, the memory limit, the preview, the pass timing and
        // the share itself do not change a pixel.
        let sub = dir.path().join("sub");
        std::fs::create_dir(&sub).unwrap();
        for same in [
            &["--shard", "1/2", "--threads", "3"][..],
            &[
                "--shard",
                "0/2",
                "--max-memory",
                "1G",
                "--min-pass-seconds",
                "0",
                "--strict",
            ],
            &[
                "--shard",
                "0/2",
                "--view",
                "standard",
                "--exposure",
                "2",
                "--stats",
            ],
            &["--samples", "3..9"],
            &["--shard", "0/2", "--resume", "out.shard-0-of-2.exr"],
            &[],
        ] {
            assert_eq!(settings_hash(&job(dir.path(), same)), base, "{same:?}");
        }
        let moved = job(&sub, &["--shard", "0/2"]);
        assert_eq!(settings_hash(&moved), base, "another output directory");
        // Options that do.
        for other in [
            &["--shard", "0/2", "--seed", "1"][..],
            &["--shard", "0/2", "--spp", "32"],
            &["--shard", "0/2", "--camera", "1"],
            &["--shard", "0/2", "--resolution", "64x48"],
            &["--shard", "0/2", "--frame", "3"],
            &["--shard", "0/2", "--no-alpha"],
            &["--shard", "0/2", "--max-depth", "3"],
            &["--shard", "0/2", "--passes", "albedo"],
            &["--shard", "0/2", "--backend", "obvhs"],
        ] {
            assert_ne!(settings_hash(&job(dir.path(), other)), base, "{other:?}");
        }
        // A frame's shard carries its share before the frame number.
        let framed = job(dir.path(), &["--shard", "1/4", "--frame", "12"]);
        assert_eq!(framed.output, dir.path().join("out.shard-1-of-4.0012.exr"));
        let frames = job(dir.path(), &["--shard", "1/4", "--frames", "3..4"]);
        assert_eq!(
            frames.frame_jobs()[1].output,
            dir.path().join("out.shard-1-of-4.0004.exr")
        );
        assert!(!framed.png, "a shard writes no preview");
    }

    fn names(extra: &[&str]) -> Vec<String> {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.exr");
        let mut all = vec!["render", "scene.gltf", "-o", out.to_str().unwrap()];
        all.extend_from_slice(extra);
        let job = Job::from_args(&Args::try_parse_from(all).unwrap()).unwrap();
        header_attributes(&job, "backend")
            .into_iter()
            .map(|(name, _)| name)
            .collect()
    }

    #[test]
    fn the_header_records_the_settings_the_integrator_reads() {
        let common = [
            "strata:scene",
            "strata:integrator",
            "strata:sampler",
            "strata:spp",
            "strata:seed",
            "strata:backend",
            "strata:commit",
            "strata:preview_view",
            "strata:preview_exposure",
        ];
        let ao = names(&["--integrator", "ao"]);
        assert_eq!(ao[..9], common);
        assert_eq!(
            ao[9..],
            [
                "strata:hemisphere",
                "strata:ao_distance",
                "strata:ao_samples"
            ]
        );
        let path = names(&[
            "--integrator",
            "path",
            "--target-error",
            "0.1",
            "--time-limit",
            "9",
        ]);
        assert_eq!(
            path[9..],
            [
                "strata:target_error",
                "strata:min_spp",
                "strata:error_metric",
                "strata:time_limit",
                "strata:max_depth",
                "strata:rr_depth",
                "strata:emitter_samples",
                "strata:strategy",
                "strata:materials",
                "strata:energy_compensation",
                "strata:hemisphere",
                "strata:triangle_sampling",
                "strata:background",
            ]
        );
    }

    #[test]
    fn settings_are_named_as_the_command_line_spells_them() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.exr");
        let args = Args::try_parse_from([
            "render",
            "scene.gltf",
            "-o",
            out.to_str().unwrap(),
            "--integrator",
            "direct",
            "--triangle-sampling",
            "solid-angle",
            "--background",
            "0.25,0.5,1",
        ])
        .unwrap();
        let attrs = header_attributes(&Job::from_args(&args).unwrap(), "backend");
        let text = |name: &str| {
            attrs
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, v)| v.clone())
                .unwrap()
        };
        assert_eq!(text("strata:integrator"), Attr::Text("direct".into()));
        assert_eq!(text("strata:max_depth"), Attr::Int(1));
        assert_eq!(
            text("strata:triangle_sampling"),
            Attr::Text("solid-angle".into())
        );
        assert_eq!(text("strata:background"), Attr::Text("0.25,0.5,1".into()));
    }
}
