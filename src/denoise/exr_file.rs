//! `render denoise`: denoising an EXR that strata wrote, after the render (a farm denoises
//! the merged image; a user tries the other prefilter setting without rendering again).
//!
//! The input's beauty is its `noisy` layer when it has one (it was denoised before: the raw
//! image is kept there) and its `R`, `G`, `B` otherwise; its `albedo.R/G/B` and
//! `normal.X/Y/Z` layers guide the filter when present. The output is the input with `R`,
//! `G`, `B` replaced by the denoised image and the raw one in `noisy`; every other channel
//! and header attribute is kept.

use std::path::Path;

use exr::prelude::{
    read_all_flat_layers_from_file, AnyChannel, AnyChannels, AttributeValue, FlatSamples, Text,
    WritableImage,
};

use super::{denoise, describe, DenoiseError, Inputs, Options};
use crate::render::output::{write_atomically, NOISY_LAYER};

/// What [`denoise_exr`] did.
#[derive(Clone, Debug)]
pub struct Report {
    pub width: usize,
    pub height: usize,
    /// The denoised beauty, row-major from the top row (for the PNG preview).
    pub denoised: Vec<glam::Vec3>,
    /// The input had been denoised before: its `noisy` layer was denoised again.
    pub again: bool,
    /// Albedo and normal layers guided the filter.
    pub aux: bool,
    /// What the input lacks that denoising would use, one line each.
    pub warnings: Vec<String>,
    /// Seconds the filter took.
    pub seconds: f64,
    /// The input's alpha `A` where its background is transparent, for the preview.
    pub alpha: Option<Vec<f32>>,
}

fn fail(path: &Path, message: impl std::fmt::Display) -> DenoiseError {
    DenoiseError(format!("{}: {message}", path.display()))
}

/// A channel's samples as f32, whatever their type.
fn samples(channel: &AnyChannel<FlatSamples>) -> Vec<f32> {
    match &channel.sample_data {
        FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
        FlatSamples::F32(v) => v.clone(),
        FlatSamples::U32(v) => v.iter().map(|&u| u as f32).collect(),
    }
}

/// Denoises the EXR `input` into `output` (which may be the same file: it is replaced
/// atomically).
pub fn denoise_exr(input: &Path, output: &Path, options: &Options) -> Result<Report, DenoiseError> {
    let mut image = read_all_flat_layers_from_file(input)
        .map_err(|e| fail(input, format_args!("cannot read it as an EXR: {e}")))?;
    let has = |layer: &exr::image::Layer<AnyChannels<FlatSamples>>, name: &str| {
        layer.channel_data.list.iter().any(|c| c.name.eq(name))
    };
    let index = image
        .layer_data
        .iter()
        .position(|l| ["R", "G", "B"].iter().all(|c| has(l, c)))
        .ok_or_else(|| {
            let names: Vec<String> = image
                .layer_data
                .iter()
                .flat_map(|l| l.channel_data.list.iter().map(|c| c.name.to_string()))
                .collect();
            fail(
                input,
                format_args!(
                    "has no R, G, B channels to denoise (its channels: {})",
                    names.join(", ")
                ),
            )
        })?;
    let layer = &mut image.layer_data[index];
    let (width, height) = (layer.size.width(), layer.size.height());
    // Three channels interleaved, or None if any is missing.
    let rgb = |layer: &exr::image::Layer<AnyChannels<FlatSamples>>, names: [&str; 3]| {
        let found: Vec<Vec<f32>> = names
            .iter()
            .filter_map(|n| layer.channel_data.list.iter().find(|c| c.name.eq(n)))
            .map(samples)
            .collect();
        (found.len() == 3).then(|| {
            (0..width * height)
                .flat_map(|i| [found[0][i], found[1][i], found[2][i]])
                .collect::<Vec<f32>>()
        })
    };
    let noisy_names = ["R", "G", "B"].map(|c| format!("{NOISY_LAYER}.{c}"));
    let noisy = rgb(layer, noisy_names.each_ref().map(|s| s.as_str()));
    let again = noisy.is_some();
    let color = match noisy {
        Some(c) => c,
        None => rgb(layer, ["R", "G", "B"]).expect("the layer was chosen for its R, G, B"),
    };
    // The alpha of a transparent background (not the coverage of `--passes alpha` against a
    // visible one) goes into the preview.
    let transparent = (layer.attributes.other)
        .get(&Text::from("strata:background"))
        .is_some_and(|v| matches!(v, AttributeValue::Text(t) if t.eq("transparent")));
    let alpha = (layer.channel_data.list.iter())
        .find(|c| transparent && c.name.eq("A"))
        .map(samples);
    let mut warnings = Vec::new();
    let mut albedo = rgb(layer, ["albedo.R", "albedo.G", "albedo.B"]);
    let mut normal = rgb(layer, ["normal.X", "normal.Y", "normal.Z"]);
    match (&albedo, &normal) {
        (None, Some(_)) => {
            warnings.push("it has a normal layer but no albedo layer, and the denoiser takes normals only with an albedo: denoising the beauty alone (render with --passes albedo,normal)".to_string());
            normal = None;
        }
        (None, None) => warnings.push("it has no albedo and normal layers: denoising the beauty alone, which blurs texture and edges (render with --passes albedo,normal)".to_string()),
        (Some(_), None) => warnings.push("it has no normal layer: denoising with the albedo alone (render with --passes albedo,normal)".to_string()),
        (Some(_), Some(_)) => {}
    }
    let finite = |v: &mut Vec<f32>| {
        v.iter_mut()
            .for_each(|x| *x = if x.is_finite() { *x } else { 0.0 })
    };
    for aux in [&mut albedo, &mut normal].into_iter().flatten() {
        finite(aux);
    }

    let t = std::time::Instant::now();
    let denoised = denoise(
        &Inputs {
            width,
            height,
            color: &color,
            albedo: albedo.as_deref(),
            normal: normal.as_deref(),
        },
        options,
    )
    .map_err(|e| fail(input, e))?;
    let seconds = t.elapsed().as_secs_f64();

    // R, G, B become the denoised image; the raw one goes to (or stays in) `noisy`.
    let mut list = std::mem::take(&mut layer.channel_data.list).into_vec();
    if !again {
        // Copies of R, G, B only (not of every layer), renamed.
        let raw: Vec<_> = list
            .iter()
            .filter(|c| ["R", "G", "B"].iter().any(|n| c.name.eq(n)))
            .map(|c| {
                let mut raw = c.clone();
                raw.name = Text::new_or_panic(format!("{NOISY_LAYER}.{}", c.name));
                raw
            })
            .collect();
        list.extend(raw);
    }
    for c in list.iter_mut() {
        if let Some(k) = ["R", "G", "B"].iter().position(|n| c.name.eq(n)) {
            c.sample_data = FlatSamples::F32(denoised.iter().skip(k).step_by(3).copied().collect());
        }
    }
    layer.channel_data = AnyChannels::sort(list.into());
    layer.attributes.software_name =
        Text::new_or_none(format!("strata {}", env!("CARGO_PKG_VERSION")));
    let aux = albedo.is_some();
    let text = |s: String| {
        AttributeValue::Text(
            Text::new_or_none(s).unwrap_or_else(|| Text::new_or_panic("(non-ASCII)")),
        )
    };
    let attrs = [
        ("strata:denoiser", text(describe(options, aux))),
        (
            "strata:denoise_seconds",
            AttributeValue::F32(seconds as f32),
        ),
        ("strata:denoised_from", text(input.display().to_string())),
    ];
    for (key, value) in attrs {
        layer
            .attributes
            .other
            .insert(Text::new_or_panic(key), value);
    }
    for key in [
        "strata:denoiser",
        "strata:denoise_seconds",
        "strata:denoised_from",
    ] {
        image.attributes.other.remove(&Text::new_or_panic(key));
    }
    write_atomically(output, |tmp| {
        image
            .write()
            .to_file(tmp)
            .map_err(|e| format!("cannot write the EXR: {e}"))
    })
    .map_err(|e| DenoiseError(e.to_string()))?;
    Ok(Report {
        width,
        height,
        denoised: denoised
            .chunks_exact(3)
            .map(|c| glam::Vec3::new(c[0], c[1], c[2]))
            .collect(),
        again,
        aux,
        warnings,
        seconds,
        alpha,
    })
}
