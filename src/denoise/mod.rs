//! Denoising with Intel Open Image Denoise (OIDN 2.x). Its `ffi` submodule is strata's
//! second FFI module: with [`crate::embree`], the only places with `unsafe`.
//!
//! OIDN's `RT` filter takes the noisy beauty (HDR, linear) and, for edges and textures it
//! must keep, the first-hit albedo and shading normal ([`crate::render::passes`]). Those two
//! are themselves averages of a few samples and so slightly noisy at edges, in depth of
//! field and behind glossy reflections: for final frames OIDN's documentation recommends
//! denoising each of them first with the same filter ("prefiltering") and then telling the
//! beauty's filter they are clean (`cleanAux`), which [`Options::prefilter`] does (the
//! default). The filter runs on the CPU device with the thread count strata renders with.
//!
//! The library is loaded at run time (`libloading`), so every build has `--denoise`: from
//! `$OIDN_DIR/lib`, then the prefix `tools/oidn-prefix.sh` makes by default
//! (`~/.cache/strata/oidn-2.5.1`, the libraries of PyPI's `pyoidn` wheel), then the dynamic
//! loader's own search path (`ffi.rs`). Where none is found, [`check`] says where it looked
//! and how to get one. The filter is driven through OIDN's C API rather than a wrapper
//! because prefiltering needs a filter with no colour image, and shared host images save
//! three copies of each image.

/// What the beauty's filter is given, row-major from the top row, three floats per pixel.
#[derive(Clone, Copy, Debug)]
pub struct Inputs<'a> {
    pub width: usize,
    pub height: usize,
    /// Linear HDR radiance.
    pub color: &'a [f32],
    /// First-hit albedo in [0, 1].
    pub albedo: Option<&'a [f32]>,
    /// First-hit shading normal in [-1, 1] (world space; needs the albedo).
    pub normal: Option<&'a [f32]>,
}

/// How to denoise.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Options {
    /// Threads OIDN may use (0: all).
    pub threads: usize,
    /// Denoise albedo and normal first and mark them clean (final-frame quality).
    pub prefilter: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            threads: 0,
            prefilter: true,
        }
    }
}

/// A denoising error: the library's own message, or why there is no library.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct DenoiseError(pub String);

/// Whether Open Image Denoise can be loaded here (it is looked for once per process).
pub fn available() -> bool {
    ffi::library().is_ok()
}

/// Ok where Open Image Denoise can be loaded; otherwise the one message `--denoise` and
/// `render denoise` give: where the library was looked for and how to get it, or what is
/// wrong with the one found.
pub fn check() -> Result<(), DenoiseError> {
    ffi::library().map(|_| ())
}

/// Denoises `inputs.color`, returning the denoised image in the same layout.
pub fn denoise(inputs: &Inputs, options: &Options) -> Result<Vec<f32>, DenoiseError> {
    let n = inputs.width * inputs.height * 3;
    let check = |name: &str, len: usize| {
        if len == n {
            Ok(())
        } else {
            Err(DenoiseError(format!(
                "the {name} image holds {len} floats, not the {n} of {}×{} RGB",
                inputs.width, inputs.height
            )))
        }
    };
    check("colour", inputs.color.len())?;
    if let Some(a) = inputs.albedo {
        check("albedo", a.len())?;
    }
    if let Some(nm) = inputs.normal {
        check("normal", nm.len())?;
        if inputs.albedo.is_none() {
            return Err(DenoiseError(
                "OIDN takes a normal image only together with an albedo image".into(),
            ));
        }
    }
    if n == 0 {
        return Ok(Vec::new());
    }
    ffi::denoise(inputs, options)
}

/// Denoises a film's beauty with its albedo and normal passes (the values the EXR's
/// `albedo` and `normal` layers hold), as the render's `--denoise` does.
pub fn denoise_film(
    film: &crate::render::Film,
    options: &Options,
) -> Result<Vec<glam::Vec3>, DenoiseError> {
    use crate::render::passes::Pass;
    let flat = |v: &[glam::Vec3]| v.iter().flat_map(|p| p.to_array()).collect::<Vec<f32>>();
    let color = flat(&film.pixels());
    let (albedo, normal) = match film.keeps_features() {
        true => {
            let features: Vec<_> = (0..film.height)
                .flat_map(|y| (0..film.width).map(move |x| film.features(x, y)))
                .collect();
            let pass = |p: Pass| -> Vec<f32> {
                features.iter().flat_map(|&f| p.values(f, None)).collect()
            };
            (Some(pass(Pass::Albedo)), Some(pass(Pass::Normal)))
        }
        false => (None, None),
    };
    let out = denoise(
        &Inputs {
            width: film.width as usize,
            height: film.height as usize,
            color: &color,
            albedo: albedo.as_deref(),
            normal: normal.as_deref(),
        },
        options,
    )?;
    Ok(out
        .chunks_exact(3)
        .map(|c| glam::Vec3::new(c[0], c[1], c[2]))
        .collect())
}

/// What the EXR header says of a denoised image (`strata:denoiser`).
pub fn describe(options: &Options, aux: bool) -> String {
    let version = version().unwrap_or_else(|| "?".into());
    let aux = match (aux, options.prefilter) {
        (false, _) => "beauty only",
        (true, true) => "albedo and normal passes, prefiltered (cleanAux)",
        (true, false) => "albedo and normal passes as rendered",
    };
    format!("Intel Open Image Denoise {version}, RT filter, HDR, quality high, with the {aux}; the raw beauty is the layer noisy")
}

/// The library's version ("2.5.1"), or None where it cannot be loaded.
pub fn version() -> Option<String> {
    ffi::library().ok().map(|oidn| oidn.version.clone())
}

mod exr_file;
pub use exr_file::{denoise_exr, Report};

mod ffi;
