//! `render --resume FILE.exr`: a render continued from the image an interrupted render or a
//! checkpoint saved. Such a file holds, besides its image, the film's exact sums
//! ([`super::partial`]: each pixel's sums, squares, count, feature sums and first hit) and
//! the hashes a farm part carries (`strata:settings_hash`, `strata:scene_hash`). The resumed
//! render starts from that film and takes each pixel's samples from its count on, so it
//! ends with the film, and the image, of a render never interrupted, bit for bit: every
//! sample is a function of (seed, pixel, sample index) alone and the sums are exact.
//!
//! Only a fixed-spp render can be resumed. Adaptive sampling decides which pixels sample from
//! the film at the end of each round, and a time limit from the clock; neither decision can
//! be replayed from a film saved part way through a round.

use std::collections::BTreeMap;
use std::path::Path;

use exr::prelude::read_all_flat_layers_from_file;

use super::merge::{strata_header, two_numbers};
use super::output::Attr;
use super::partial::{ExactLayer, EXACT_LAYER};
use super::Film;

/// What the render being resumed is, for checking the file against it.
#[derive(Clone, Debug)]
pub struct Expected<'a> {
    pub width: u32,
    pub height: u32,
    /// The sample indices every pixel takes, [a, b) (a farm share's, or 0..spp).
    pub samples: (u32, u32),
    /// [`crate::job::header::settings_hash`] of the job.
    pub settings_hash: &'a str,
    /// [`super::merge::files_hash`] of the scene's files and the environment map.
    pub scene_hash: &'a str,
    /// The job's header attributes in plain words (`strata:seed`, …), to name what differs
    /// when the settings hash does.
    pub header: &'a [(String, Attr)],
    /// Whether the render keeps feature sums and first hits.
    pub features: bool,
    pub first_hits: bool,
}

/// An unfinished render read back.
#[derive(Debug)]
pub struct Resumed {
    pub film: Film,
    /// The seconds it had rendered (`strata:render_seconds`).
    pub seconds: f64,
}

/// Reads the unfinished render at `path` and checks that it is one of `expected`'s; the
/// error names the file and what keeps it from being resumed.
pub fn read(path: &Path, expected: &Expected) -> Result<Resumed, String> {
    let fail = |m: String| format!("{}: {m}", path.display());
    let (attrs, width, height) = strata_header(path).map_err(fail)?;
    if !attrs.contains_key("strata:settings_hash") || !attrs.contains_key("strata:scene_hash") {
        return Err(fail(
            "holds no sums to resume from: only the image of an interrupted render or a checkpoint (--checkpoint) can be resumed".into(),
        ));
    }
    if attrs.contains_key("strata:target_error") || attrs.contains_key("strata:time_limit") {
        return Err(fail(
            "was rendered with --target-error or --time-limit, whose pixels cannot be continued exactly; only fixed-spp renders resume".into(),
        ));
    }
    if (width, height) != (expected.width as usize, expected.height as usize) {
        return Err(fail(format!(
            "is {width}x{height}, not this render's --resolution {}x{}",
            expected.width, expected.height
        )));
    }
    let text = |name: &str| attrs.get(name).map(|a| a.to_string());
    if text("strata:settings_hash").as_deref() != Some(expected.settings_hash) {
        return Err(fail(format!(
            "was rendered with other settings than this render's{}; resume it with the options it was rendered with",
            differences(&attrs, expected.header)
        )));
    }
    // Another build may take other samples for the same settings (a change to the code),
    // as a merge of its parts would refuse.
    let ours = (expected.header.iter()).find(|(k, _)| k == "strata:commit");
    if let (Some(there), Some((_, here))) = (text("strata:commit"), ours) {
        if there != here.to_string() {
            return Err(fail(format!(
                "was rendered by another build of strata (commit {there}; this one is {here}), whose samples may differ: resume it with that build"
            )));
        }
    }
    if text("strata:scene_hash").as_deref() != Some(expected.scene_hash) {
        return Err(fail(
            "was rendered from other files: the scene (or its buffers, images or environment map) changed since".into(),
        ));
    }
    let (a, b) = expected.samples;
    let range = text("strata:samples").and_then(|t| two_numbers(&t, ".."));
    match range {
        Some(r) if r != (a, b) => {
            return Err(fail(format!(
                "holds samples {}..{} of every pixel, not this render's {a}..{b}",
                r.0, r.1
            )))
        }
        None if (a, b) != (0, b) || text("strata:partial").is_some() => {
            return Err(fail(format!(
                "holds no sample range, where this render takes samples {a}..{b}"
            )))
        }
        _ => {}
    }

    let n = width * height;
    let image =
        read_all_flat_layers_from_file(path).map_err(|e| fail(format!("cannot read it: {e}")))?;
    let count_name = format!("{EXACT_LAYER}.N");
    let layer = (image.layer_data.iter())
        .find(|l| (l.channel_data.list.iter()).any(|c| c.name.eq(&count_name)))
        .ok_or_else(|| fail("has no exact sums (layer exact) to resume from".into()))?;
    let exact = ExactLayer::find(&layer.channel_data, n).map_err(fail)?;
    if (exact.has_features(), exact.has_first_hits()) != (expected.features, expected.first_hits) {
        return Err(fail(
            "its exact sums do not hold the features and first hits its passes need".into(),
        ));
    }
    if let Some(i) = (0..n).find(|&i| exact.count(i) > b - a) {
        return Err(fail(format!(
            "pixel ({}, {}) holds {} samples, more than the {} this render takes",
            i % width,
            i / width,
            exact.count(i),
            b - a
        )));
    }
    let film = exact
        .to_film(expected.width, expected.height)
        .map_err(fail)?;
    let seconds = match attrs.get("strata:render_seconds") {
        Some(Attr::Float(s)) => *s as f64,
        _ => 0.0,
    };
    Ok(Resumed { film, seconds })
}

/// The plain-words settings in which the file's header and this render's differ, as
/// ` (strata:spp 64 there, 128 here; …)`, or nothing where none of them does.
fn differences(file: &BTreeMap<String, Attr>, here: &[(String, Attr)]) -> String {
    // Attributes that describe the file rather than the settings.
    const NOT_SETTINGS: [&str; 4] = [
        "strata:scene",
        "strata:environment",
        "strata:backend",
        "strata:commit",
    ];
    let here: BTreeMap<&str, &Attr> = here.iter().map(|(k, v)| (k.as_str(), v)).collect();
    let mut names: Vec<&str> = (file.keys().map(String::as_str))
        .chain(here.keys().copied())
        .filter(|k| !NOT_SETTINGS.contains(k) && !k.starts_with("strata:preview"))
        .filter(|k| here.contains_key(k) || is_setting(k))
        .collect();
    names.sort_unstable();
    names.dedup();
    let said: Vec<String> = names
        .into_iter()
        .filter_map(|k| {
            let there = file.get(k).map(|a| a.to_string());
            let ours = here.get(k).map(|a| a.to_string());
            (there != ours).then(|| {
                let show = |v: Option<String>| v.unwrap_or_else(|| "none".into());
                format!("{k} {} there, {} here", show(there), show(ours))
            })
        })
        .collect();
    match said.is_empty() {
        true => String::new(),
        false => format!(" ({})", said.join("; ")),
    }
}

/// Whether a header attribute the file has but this render lacks is a setting (rather than
/// the state of the film or the render, which only the file has).
fn is_setting(name: &str) -> bool {
    !matches!(
        name,
        "strata:spp_min"
            | "strata:spp_max"
            | "strata:spp_mean"
            | "strata:render_seconds"
            | "strata:interrupted"
            | "strata:checkpoint"
            | "strata:settings_hash"
            | "strata:scene_hash"
            | "strata:samples"
            | "strata:partial"
            | "strata:shard"
            | "strata:projection"
            | "strata:denoiser"
            | "strata:passes"
            | "strata:time_limit_reached"
            | "strata:unconverged_pixels"
    ) && !name.starts_with("strata:pass:")
}
