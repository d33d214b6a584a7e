//! Farm shards and their merge. A shard renders a disjoint range of every pixel's sample
//! indices ([`Share`]) of the same image and writes a partial EXR ([`super::partial`]);
//! `render merge` checks that the parts belong together and hold every sample once
//! ([`check`]), then adds their films exactly ([`merge`]): the result is the film one machine
//! would have rendered, bit for bit, since every sample is a function of (seed, pixel, sample
//! index) alone and the film's sums are exact.
//!
//! What a part's header carries for the checks:
//! - `strata:partial` (1), `strata:samples` (`A..B`, B exclusive), `strata:shard` (`I/N`, for
//!   `--shard`);
//! - `strata:scene_hash`: SHA-256 over the bytes of every file the scene was read from (the
//!   glTF, its external buffers and images) and of the environment map, so parts of an edited
//!   scene are refused whatever the files are called;
//! - `strata:settings_hash`: SHA-256 of every option that can change the image (the job less
//!   its paths, outputs, threads, memory limit, preview and timing options), with strata's
//!   version;
//! - the settings in plain words (`strata:seed`, `strata:spp`, …), which name what differs
//!   when a check fails.
//!
//! The job writes these attributes ([`crate::job::header`]); this module reads them.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use exr::prelude::{read_all_flat_layers_from_file, AttributeValue, FlatSamples};
use sha2::{Digest, Sha256};

use super::output::Attr;
use super::partial::{ExactLayer, EXACT_LAYER};
use super::passes::Pass;
use super::Film;

/// The share of every pixel's samples a farm task renders (`--shard`, `--samples`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Share {
    /// Shard `index` (from 0) of `count` equal shares of `--spp`.
    Shard { index: u32, count: u32 },
    /// The sample indices `begin` to `end` − 1.
    Samples { begin: u32, end: u32 },
}

impl Share {
    /// The sample indices [a, b) the share renders of `spp` samples per pixel: shard I of N
    /// takes ⌊spp·I/N⌋ to ⌊spp·(I+1)/N⌋, so N shards take every sample once.
    pub fn range(self, spp: u32) -> (u32, u32) {
        match self {
            Share::Shard { index, count } => {
                let at = |i: u32| (spp as u64 * i as u64 / count as u64) as u32;
                (at(index), at(index + 1))
            }
            Share::Samples { begin, end } => (begin, end),
        }
    }

    /// The option as the command line spells it.
    pub fn option(self) -> String {
        match self {
            Share::Shard { index, count } => format!("--shard {index}/{count}"),
            Share::Samples { begin, end } => format!("--samples {begin}..{end}"),
        }
    }

    /// The partial file's name for output `path`: `.shard-I-of-N` (I padded with zeros to
    /// the width of N − 1) or `.samples-A-B` before the extension.
    pub fn path(self, path: &Path) -> PathBuf {
        let tag = match self {
            Share::Shard { index, count } => {
                let width = (count - 1).to_string().len();
                format!("shard-{index:0width$}-of-{count}")
            }
            Share::Samples { begin, end } => format!("samples-{begin}-{end}"),
        };
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let renamed = match name.rsplit_once('.') {
            Some((stem, ext)) => format!("{stem}.{tag}.{ext}"),
            None => format!("{name}.{tag}"),
        };
        path.with_file_name(renamed)
    }
}

/// Hex digits of a digest.
pub(crate) fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 over `files` (each its length, then its bytes, in order), naming a file it cannot
/// read.
pub fn files_hash(files: &[PathBuf]) -> Result<String, String> {
    let mut hash = Sha256::new();
    let mut buffer = vec![0u8; 1 << 20];
    for file in files {
        let mut f = std::fs::File::open(file)
            .map_err(|e| format!("{}: cannot read it to hash it: {e}", file.display()))?;
        let len = f.metadata().map(|m| m.len()).unwrap_or(0);
        hash.update(len.to_le_bytes());
        loop {
            let n = f
                .read(&mut buffer)
                .map_err(|e| format!("{}: cannot read it to hash it: {e}", file.display()))?;
            if n == 0 {
                break;
            }
            hash.update(&buffer[..n]);
        }
    }
    Ok(hex(&hash.finalize()))
}

/// Header attributes that differ from part to part of one image, or do not matter to it.
const OWN_ATTRIBUTES: &[&str] = &[
    "strata:samples",
    "strata:shard",
    "strata:render_seconds",
    "strata:spp_min",
    "strata:spp_max",
    "strata:spp_mean",
    "strata:interrupted",
    "strata:checkpoint",
    "strata:merged_parts",
    "strata:preview_view",
    "strata:preview_exposure",
    "strata:scene",
    "strata:environment",
];

/// A partial file's header: what [`check`] needs.
#[derive(Clone, Debug)]
pub struct Part {
    pub path: PathBuf,
    pub width: usize,
    pub height: usize,
    /// Its `strata:` attributes.
    pub attrs: BTreeMap<String, Attr>,
    /// The sample indices it holds, [a, b).
    pub range: (u32, u32),
    /// Its shard I of N, where `--shard` made it.
    pub shard: Option<(u32, u32)>,
    pub spp: u32,
}

fn attr_of(value: &AttributeValue) -> Option<Attr> {
    match value {
        AttributeValue::Text(t) => Some(Attr::Text(t.to_string())),
        AttributeValue::I32(i) => Some(Attr::Int(*i)),
        AttributeValue::F32(f) => Some(Attr::Float(*f)),
        AttributeValue::Matrix4x4(m) => Some(Attr::Matrix(*m)),
        _ => None,
    }
}

impl std::fmt::Display for Attr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Attr::Text(t) => write!(f, "{t}"),
            Attr::Int(i) => write!(f, "{i}"),
            Attr::Float(v) => write!(f, "{v}"),
            Attr::Matrix(m) => {
                let values: Vec<String> = m.iter().map(|v| v.to_string()).collect();
                write!(f, "[{}]", values.join(", "))
            }
        }
    }
}

/// The `strata:` attributes (and the camera's matrix) of the EXR at `path`, and its width and
/// height; the error says why it is no EXR (without the path).
pub(super) fn strata_header(path: &Path) -> Result<(BTreeMap<String, Attr>, usize, usize), String> {
    if !path.is_file() {
        return Err("no such file".into());
    }
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| format!("cannot read it as an EXR: {e}"))?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| "has no image in it".to_string())?;
    let mut attrs: BTreeMap<String, Attr> = (header.own_attributes.other.iter())
        .chain(&header.shared_attributes.other)
        .filter(|(name, _)| name.to_string().starts_with("strata:"))
        .filter_map(|(name, value)| Some((name.to_string(), attr_of(value)?)))
        .collect();
    if let Some(m) = header.own_attributes.world_to_camera {
        attrs.insert(super::output::WORLD_TO_CAMERA.into(), Attr::Matrix(m));
    }
    if let Some(m) = header.own_attributes.world_to_normalized_device {
        attrs.insert(super::output::WORLD_TO_NDC.into(), Attr::Matrix(m));
    }
    let size = header.layer_size;
    Ok((attrs, size.width(), size.height()))
}

/// `I/N` or `A..B` of a header attribute.
pub(super) fn two_numbers(text: &str, separator: &str) -> Option<(u32, u32)> {
    let (a, b) = text.split_once(separator)?;
    Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
}

impl Part {
    /// Reads the header of the partial file `path`; the error names the file and what makes
    /// it no part of a merge.
    pub fn read(path: &Path) -> Result<Part, String> {
        let fail = |m: String| format!("{}: {m}", path.display());
        let (attrs, width, height) = strata_header(path).map_err(fail)?;
        let text = |name: &str| attrs.get(name).map(|a| a.to_string());
        if attrs.get("strata:partial") != Some(&Attr::Int(1)) {
            return Err(fail(
                "is not a partial file of `render --shard` or `--samples` (a finished image holds no exact sums to merge)".into(),
            ));
        }
        let range = text("strata:samples")
            .and_then(|t| two_numbers(&t, ".."))
            .filter(|(a, b)| a < b)
            .ok_or_else(|| fail("its strata:samples attribute is missing or not A..B".into()))?;
        let spp = match attrs.get("strata:spp") {
            Some(Attr::Int(n)) if *n > 0 => *n as u32,
            _ => return Err(fail("its strata:spp attribute is missing".into())),
        };
        for name in ["strata:scene_hash", "strata:settings_hash", "strata:seed"] {
            if !attrs.contains_key(name) {
                return Err(fail(format!("its {name} attribute is missing")));
            }
        }
        if range.1 > spp {
            return Err(fail(format!(
                "its samples {}..{} pass its --spp {spp}",
                range.0, range.1
            )));
        }
        if attrs.get("strata:interrupted") == Some(&Attr::Int(1))
            || attrs.get("strata:checkpoint") == Some(&Attr::Int(1))
        {
            let how = match attrs.get("strata:checkpoint") == Some(&Attr::Int(1)) {
                true => "is a checkpoint written during its render",
                false => "was interrupted",
            };
            return Err(fail(format!(
                "{how}, so it may not hold all its samples {}..{}: finish it with its render command and --resume {}, or render that part again",
                range.0, range.1, path.display()
            )));
        }
        Ok(Part {
            path: path.to_path_buf(),
            width,
            height,
            shard: text("strata:shard").and_then(|t| two_numbers(&t, "/")),
            attrs,
            range,
            spp,
        })
    }

    /// What this part is, for messages: `parts/x.exr (samples 16..32)`.
    fn describe(&self) -> String {
        let (a, b) = self.range;
        format!("{} (samples {a}..{b})", self.path.display())
    }
}

/// Samples no part holds, for a re-run: their range and the shards of the parts' split
/// that render exactly them (empty where the parts are not shards of one split, or where no
/// whole shard matches).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Missing {
    pub range: (u32, u32),
    pub shards: Vec<(u32, u32)>,
}

impl std::fmt::Display for Missing {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (a, b) = self.range;
        match self.shards.as_slice() {
            [] => write!(f, "missing samples {a}..{b}"),
            shards => {
                let list: Vec<String> = shards.iter().map(|(i, n)| format!("{i}/{n}")).collect();
                write!(f, "missing samples {a}..{b}: shard {}", list.join(", "))
            }
        }
    }
}

/// What [`check`] found of parts that belong together.
#[derive(Clone, Debug)]
pub struct Coverage {
    pub spp: u32,
    /// The parts, by their first sample.
    pub parts: Vec<Part>,
    pub missing: Vec<Missing>,
}

impl Coverage {
    pub fn complete(&self) -> bool {
        self.missing.is_empty()
    }
}

/// Checks that `parts` belong together (the same image size, scene files, settings and seed)
/// and hold disjoint sample ranges; returns them ordered, with the samples missing. The error
/// names two parts and what differs between them, or the overlap.
pub fn check(parts: &[Part]) -> Result<Coverage, String> {
    let first = parts.first().ok_or("no parts to merge")?;
    for part in &parts[1..] {
        let two = || format!("{} and {}", first.path.display(), part.path.display());
        if (part.width, part.height) != (first.width, first.height) {
            return Err(format!(
                "{} are images of {}x{} and {}x{} pixels",
                two(),
                first.width,
                first.height,
                part.width,
                part.height
            ));
        }
        let differs = |name: &str| first.attrs.get(name) != part.attrs.get(name);
        let value = |p: &Part, name: &str| {
            p.attrs
                .get(name)
                .map_or("(none)".to_string(), |a| a.to_string())
        };
        if differs("strata:scene_hash") {
            return Err(format!(
                "{} were rendered from different scenes: the bytes of their glTF, buffer, image or environment files differ",
                two()
            ));
        }
        for name in ["strata:seed", "strata:spp"] {
            if differs(name) {
                return Err(format!(
                    "{} were rendered with different {}: {} and {}",
                    two(),
                    name.trim_start_matches("strata:"),
                    value(first, name),
                    value(part, name)
                ));
            }
        }
        // The first setting in words that differs, else the hash of them all.
        let named = (first.attrs.keys().chain(part.attrs.keys()))
            .filter(|n| !OWN_ATTRIBUTES.contains(&n.as_str()) && !n.ends_with("_hash"))
            .find(|n| differs(n));
        if let Some(name) = named {
            return Err(format!(
                "{} were rendered with different settings: {} is {} and {}",
                two(),
                name,
                value(first, name),
                value(part, name)
            ));
        }
        if differs("strata:settings_hash") {
            return Err(format!(
                "{} were rendered with different settings (their settings hashes differ: an option that changes the image, such as --camera, --resolution, --frame or --no-alpha, or another strata version)",
                two()
            ));
        }
    }
    let mut parts = parts.to_vec();
    parts.sort_by_key(|p| p.range);
    for pair in parts.windows(2) {
        if pair[1].range.0 < pair[0].range.1 {
            return Err(format!(
                "{} and {} overlap: a sample would count twice",
                pair[0].describe(),
                pair[1].describe()
            ));
        }
    }
    let spp = first.spp;
    let mut gaps = Vec::new();
    let mut at = 0;
    for p in &parts {
        if p.range.0 > at {
            gaps.push((at, p.range.0));
        }
        at = p.range.1;
    }
    if at < spp {
        gaps.push((at, spp));
    }
    // The shards of one split that render a gap exactly.
    let split = parts[0].shard.map(|(_, n)| n);
    let one_split = split.filter(|&n| parts.iter().all(|p| p.shard.map(|s| s.1) == Some(n)));
    let missing = gaps
        .into_iter()
        .map(|range| {
            let shards = match one_split {
                None => Vec::new(),
                Some(n) => {
                    let of = |i| Share::Shard { index: i, count: n }.range(spp);
                    let inside: Vec<u32> = (0..n)
                        .filter(|&i| of(i).0 >= range.0 && of(i).1 <= range.1 && of(i).0 < of(i).1)
                        .collect();
                    // Only when the shards fill the gap exactly.
                    let filled = inside.first().map(|&i| of(i).0) == Some(range.0)
                        && inside.last().map(|&i| of(i).1) == Some(range.1);
                    match filled {
                        true => inside.into_iter().map(|i| (i, n)).collect(),
                        false => Vec::new(),
                    }
                }
            };
            Missing { range, shards }
        })
        .collect();
    Ok(Coverage {
        spp,
        parts,
        missing,
    })
}

/// The image [`merge`] made of the parts.
pub struct Merged {
    pub film: Film,
    /// The passes the parts hold.
    pub passes: Vec<Pass>,
    /// The ID passes' values, from the part that holds sample 0 (the first part).
    pub ids: Vec<(Pass, Vec<f32>)>,
    /// The parts' common header attributes.
    pub attrs: Vec<(String, Attr)>,
    /// The parts' render seconds, summed.
    pub seconds: f64,
    /// The samples the merged film holds, [a, b).
    pub range: (u32, u32),
}

/// The samples missing from `coverage`, one per line, for an error.
pub fn missing_lines(coverage: &Coverage) -> String {
    let lines: Vec<String> = coverage.missing.iter().map(|m| m.to_string()).collect();
    lines.join("\n")
}

/// The one range of samples the parts of `coverage` hold together, where they hold one
/// without gaps (what a partial merge needs).
pub fn contiguous(coverage: &Coverage) -> Option<(u32, u32)> {
    let parts = &coverage.parts;
    let gap = parts.windows(2).any(|p| p[0].range.1 != p[1].range.0);
    match (parts.first(), parts.last()) {
        (Some(first), Some(last)) if !gap => Some((first.range.0, last.range.1)),
        _ => None,
    }
}

/// Merges the parts of `coverage` into one film: all of the image's samples, or with
/// `partial` one contiguous range of them (for a later merge: many parts merge as a tree,
/// groups in parallel). Reads one part at a time; each must hold its whole sample range in
/// every pixel.
pub fn merge(coverage: &Coverage, partial: bool) -> Result<Merged, String> {
    if partial && contiguous(coverage).is_none() {
        let gaps: Vec<String> = (coverage.parts.windows(2))
            .filter(|p| p[0].range.1 < p[1].range.0)
            .map(|p| format!("missing samples {}..{}", p[0].range.1, p[1].range.0))
            .collect();
        return Err(format!(
            "a partial merge takes parts of one contiguous range of samples; between them:\n{}",
            gaps.join("\n")
        ));
    }
    if !partial && !coverage.complete() {
        return Err(format!(
            "the parts do not hold every sample of --spp {}:\n{}",
            coverage.spp,
            missing_lines(coverage)
        ));
    }
    let first = &coverage.parts[0];
    let passes: Vec<Pass> = match first.attrs.get("strata:passes") {
        None => Vec::new(),
        Some(list) => (list.to_string().split(','))
            .map(|name| {
                <Pass as clap::ValueEnum>::from_str(name, false).map_err(|_| {
                    format!(
                        "{}: unknown pass '{name}' in strata:passes",
                        first.path.display()
                    )
                })
            })
            .collect::<Result<_, _>>()?,
    };
    let (width, height) = (first.width, first.height);
    let n = width * height;
    let mut film: Option<Film> = None;
    let mut ids = Vec::new();
    let mut seconds = 0.0;
    for part in &coverage.parts {
        let fail = |m: String| format!("{}: {m}", part.path.display());
        let image = read_all_flat_layers_from_file(&part.path)
            .map_err(|e| fail(format!("cannot read it as an EXR: {e}")))?;
        let count_name = format!("{EXACT_LAYER}.N");
        let layer = (image.layer_data.iter())
            .find(|l| (l.channel_data.list.iter()).any(|c| c.name.eq(&count_name)))
            .ok_or_else(|| fail("has no exact sums (layer exact) to merge".into()))?;
        let exact = ExactLayer::find(&layer.channel_data, n).map_err(fail)?;
        let want = part.range.1 - part.range.0;
        if let Some(i) = (0..n).find(|&i| exact.count(i) != want) {
            return Err(fail(format!(
                "pixel ({}, {}) holds {} samples, not the {want} of its samples {}..{}: the file is incomplete; render that part again",
                i % width,
                i / width,
                exact.count(i),
                part.range.0,
                part.range.1
            )));
        }
        // Added to the film pixel by pixel from the file's words, without a copy of the part.
        let film = film.get_or_insert_with(|| {
            let mut f = Film::new(width as u32, height as u32);
            if exact.has_features() {
                f.keep_features();
            }
            f
        });
        for i in 0..n {
            let (totals, features) = exact.pixel(i);
            (film.add_pixel_totals(i, totals, features.as_ref()))
                .map_err(|e| fail(e.to_string()))?;
        }
        // The first part's IDs: the sample-0 part's in a whole merge; in a partial one
        // without sample 0, every part's are −1 alike.
        if std::ptr::eq(part, first) {
            for &pass in passes.iter().filter(|p| p.is_id()) {
                let name = pass.channel_name("ID");
                let values = match layer.channel_data.list.iter().find(|c| c.name.eq(&name)) {
                    Some(c) => match &c.sample_data {
                        FlatSamples::F32(v) if v.len() == n => v.clone(),
                        _ => return Err(fail(format!("its {name} channel is not {n} floats"))),
                    },
                    None => return Err(fail(format!("it has no {name} channel"))),
                };
                ids.push((pass, values));
            }
        }
        if let Some(Attr::Float(s)) = part.attrs.get("strata:render_seconds") {
            seconds += *s as f64;
        }
    }
    // The settings and hashes stay; what the merge writes anew (the film's state, the
    // passes, the preview) and what only a part has go.
    let keep = |name: &str| match name {
        // The first part's paths, for the record.
        "strata:scene" | "strata:environment" => true,
        "strata:passes" => false,
        "strata:partial" => partial,
        _ => !OWN_ATTRIBUTES.contains(&name) && !name.starts_with("strata:pass:"),
    };
    let attrs = (first.attrs.iter())
        .filter(|(name, _)| keep(name))
        .map(|(name, value)| (name.clone(), value.clone()))
        .collect();
    Ok(Merged {
        film: film.expect("a complete coverage has parts"),
        passes,
        ids,
        attrs,
        seconds,
        range: contiguous(coverage).expect("checked above"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_take_every_sample_once() {
        for spp in [1, 2, 7, 64, 1000] {
            for n in 1..=spp.min(9) {
                let mut at = 0;
                for i in 0..n {
                    let (a, b) = Share::Shard { index: i, count: n }.range(spp);
                    assert_eq!(a, at, "spp {spp}, shard {i}/{n}");
                    assert!(b > a, "an empty shard {i}/{n} of {spp}");
                    at = b;
                }
                assert_eq!(at, spp);
            }
        }
        assert_eq!(Share::Shard { index: 1, count: 3 }.range(64), (21, 42));
    }

    #[test]
    fn partial_files_are_named_after_their_share() {
        let shard = |index, count| Share::Shard { index, count };
        assert_eq!(
            shard(3, 4).path(Path::new("out/beauty.exr")),
            Path::new("out/beauty.shard-3-of-4.exr")
        );
        assert_eq!(
            shard(7, 16).path(Path::new("b.exr")),
            Path::new("b.shard-07-of-16.exr")
        );
        assert_eq!(
            shard(9, 10).path(Path::new("b.exr")),
            Path::new("b.shard-9-of-10.exr")
        );
        let samples = Share::Samples { begin: 8, end: 24 };
        assert_eq!(
            samples.path(Path::new("b.exr")),
            Path::new("b.samples-8-24.exr")
        );
    }

    fn part(name: &str, range: (u32, u32), shard: Option<(u32, u32)>) -> Part {
        let attrs = [
            ("strata:seed", Attr::Text("0".into())),
            ("strata:spp", Attr::Int(64)),
            ("strata:scene_hash", Attr::Text("s".into())),
            ("strata:settings_hash", Attr::Text("k".into())),
            ("strata:max_depth", Attr::Int(8)),
            ("strata:render_seconds", Attr::Float(1.5)),
        ];
        Part {
            path: PathBuf::from(name),
            width: 4,
            height: 3,
            attrs: attrs.into_iter().map(|(n, v)| (n.to_string(), v)).collect(),
            range,
            shard,
            spp: 64,
        }
    }

    #[test]
    fn the_check_finds_the_missing_shards_and_refuses_overlaps() {
        let shards: Vec<Part> = (0..4)
            .map(|i| part(&format!("s{i}"), (16 * i, 16 * (i + 1)), Some((i, 4))))
            .collect();
        let all = check(&shards).unwrap();
        assert!(all.complete());
        // Any order.
        let reversed: Vec<Part> = shards.iter().rev().cloned().collect();
        assert_eq!(check(&reversed).unwrap().parts[0].path, Path::new("s0"));
        // Shards 1 and 3 missing: two gaps, each named by its shard.
        let some = check(&[shards[0].clone(), shards[2].clone()]).unwrap();
        assert_eq!(
            some.missing,
            [
                Missing {
                    range: (16, 32),
                    shards: vec![(1, 4)]
                },
                Missing {
                    range: (48, 64),
                    shards: vec![(3, 4)]
                }
            ]
        );
        assert_eq!(
            some.missing[1].to_string(),
            "missing samples 48..64: shard 3/4"
        );
        // Two neighbouring shards missing are one gap naming both.
        let gap = check(&[shards[0].clone(), shards[3].clone()]).unwrap();
        assert_eq!(gap.missing[0].shards, [(1, 4), (2, 4)]);
        // A part of explicit samples: the gap is named by its samples only.
        let mixed = check(&[shards[0].clone(), part("x", (16, 40), None)]).unwrap();
        assert_eq!(mixed.missing[0].to_string(), "missing samples 40..64");
        // Overlaps, and a part given twice, are refused.
        let err = check(&[shards[0].clone(), part("x", (8, 20), None)]).unwrap_err();
        assert!(err.contains("overlap"), "{err}");
        assert!(check(&[shards[1].clone(), shards[1].clone()])
            .unwrap_err()
            .contains("overlap"));
    }

    #[test]
    fn parts_of_another_scene_seed_or_setting_are_refused_by_name() {
        let a = part("a", (0, 32), Some((0, 2)));
        let with = |name: &str, value: Attr| {
            let mut b = part("b", (32, 64), Some((1, 2)));
            b.attrs.insert(name.into(), value);
            b
        };
        let refuse = |b: Part| check(&[a.clone(), b]).unwrap_err();
        assert!(
            refuse(with("strata:scene_hash", Attr::Text("t".into()))).contains("different scenes")
        );
        let seed = refuse(with("strata:seed", Attr::Text("7".into())));
        assert!(seed.contains("seed: 0 and 7"), "{seed}");
        let depth = refuse(with("strata:max_depth", Attr::Int(4)));
        assert!(depth.contains("strata:max_depth is 8 and 4"), "{depth}");
        let hidden = refuse(with("strata:settings_hash", Attr::Text("j".into())));
        assert!(hidden.contains("settings hashes differ"), "{hidden}");
        let mut small = part("b", (32, 64), None);
        small.width = 5;
        assert!(refuse(small).contains("4x3 and 5x3"));
        // What differs from part to part is no reason.
        let ok = with("strata:render_seconds", Attr::Float(9.0));
        assert!(check(&[a.clone(), ok]).unwrap().complete());
    }
}
