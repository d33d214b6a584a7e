//! Image output: linear float32 EXR (R, G, B, with the header attributes the caller gives:
//! the job's settings, [`crate::job::header`], and the film's state, [`film_attributes`]) and
//! an sRGB PNG preview. Files are written to a temporary name
//! beside the target and renamed into place, so a reader never sees a half-written image.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Compression, Encoding, FlatSamples, Image,
    ImageAttributes, LayerAttributes, SmallVec, Text, WritableImage,
};

use super::passes::Pass;
use super::view::Display;
use super::{split_first_hit, Film};
use crate::scene::Scene;

/// OpenEXR's standard attribute for the camera that rendered the image: world to camera
/// space (the camera looking down −Z, +Y up), as Imath's row-vector `M44f` (a point p maps
/// to p·M), so the 16 values are the column-vector matrix's columns one after another.
pub const WORLD_TO_CAMERA: &str = "worldToCamera";

/// OpenEXR's standard attribute for the camera's projection: world to normalised device
/// coordinates, x from 0 at the image's left edge to 1 at its right, y from 0 at its top to 1
/// at its bottom (after dividing by w), as the exr crate's `world_to_normalized_device`.
pub const WORLD_TO_NDC: &str = "worldToNDC";

/// A header attribute value.
#[derive(Clone, Debug, PartialEq)]
pub enum Attr {
    Text(String),
    Int(i32),
    Float(f32),
    /// A 4×4 matrix (EXR's `m44f`), its 16 values in the file's order.
    Matrix([f32; 16]),
}

/// An output error, naming the file.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct OutputError {
    pub path: PathBuf,
    pub message: String,
}

fn err(path: &Path, message: impl Into<String>) -> OutputError {
    OutputError {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// The temporary file an output is written to before it is renamed to `path`.
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

/// Writes through `write` into a temporary file, then renames it to `path`; on any error the
/// temporary file is removed and `path` is untouched.
pub(crate) fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<(), OutputError> {
    let tmp = temp_path(path);
    let result = write(&tmp).and_then(|()| {
        // Make the data durable before the rename publishes it.
        fs::File::open(&tmp)
            .and_then(|f| f.sync_all())
            .map_err(|e| e.to_string())?;
        fs::rename(&tmp, path)
            .map_err(|e| format!("cannot rename the finished file into place: {e}"))
    });
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result.map_err(|m| err(path, m))
}

/// Where an interrupted render's image goes when the output path holds a better one
/// ([`may_replace`]): `NAME.incomplete.exr` beside `NAME.exr`.
pub fn incomplete_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!("{stem}.incomplete.exr"))
}

/// Whether an unfinished render's image (a checkpoint, or what an interrupt saves), whose
/// pixels hold at least `spp_min` samples and `spp_mean` on average, may replace what is at
/// `path`: yes when nothing is there, or an image strata wrote that holds fewer samples per
/// pixel on average and has no pixel with more samples where this one has a pixel without
/// any. Otherwise the error says why the file there is kept: this image leaves pixels
/// without a sample where that one has none, or that one holds as many samples or more, or
/// strata cannot tell how many it holds (not an EXR strata wrote). A finished render
/// replaces its output always.
pub fn may_replace(path: &Path, spp_min: u32, spp_mean: f64) -> Result<(), String> {
    if !path.exists() {
        return Ok(());
    }
    let held = exr::meta::MetaData::read_from_file(path, false)
        .ok()
        .and_then(|meta| {
            let header = meta.headers.into_iter().next()?;
            let get = |name: &str| {
                let key = Text::from(name);
                (header.own_attributes.other.get(&key))
                    .or_else(|| header.shared_attributes.other.get(&key))
                    .cloned()
            };
            match (get("strata:spp_min")?, get("strata:spp_mean")?) {
                (AttributeValue::I32(min), AttributeValue::F32(mean)) => Some((min, mean as f64)),
                _ => None,
            }
        });
    match held {
        None => Err("it holds an image whose samples per pixel strata cannot tell".into()),
        Some((min, _)) if min > 0 && spp_min == 0 => {
            Err("it holds a whole image, and this one leaves pixels without a sample".into())
        }
        Some((_, mean)) if mean >= spp_mean => Err(format!(
            "it holds as many samples per pixel or more ({mean:.1} on average, this image {spp_mean:.1})"
        )),
        Some(_) => Ok(()),
    }
}

/// What an output file holds, by its extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// `.exr`: linear radiance (float32), passes as layers, the header's attributes.
    Exr,
    /// `.png`: 8-bit sRGB through the view transform and exposure.
    Png,
    /// `.jpg` or `.jpeg`: the same, JPEG at quality 95.
    Jpeg,
}

impl ImageFormat {
    /// The format `path`'s extension names (case-insensitive), if strata writes it.
    pub fn of(path: &Path) -> Option<ImageFormat> {
        let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
        match ext.as_str() {
            "exr" => Some(ImageFormat::Exr),
            "png" => Some(ImageFormat::Png),
            "jpg" | "jpeg" => Some(ImageFormat::Jpeg),
            _ => None,
        }
    }
}

/// Checks, before rendering, that `path` can be written: an `.exr` (or `.png`, `.jpg`) name in an existing,
/// writable directory, and not a directory itself.
pub fn check_output_path(path: &Path) -> Result<(), OutputError> {
    if ImageFormat::of(path).is_none() {
        return Err(err(
            path,
            "the output must be an .exr file (or .png or .jpg: the image through the view transform alone)",
        ));
    }
    if path.is_dir() {
        return Err(err(path, "is a directory"));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(err(
            path,
            format!("the directory '{}' does not exist", dir.display()),
        ));
    }
    // Probe with the same temporary name the writer will use.
    let probe = temp_path(path);
    match fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = fs::remove_file(&probe);
            Ok(())
        }
        Err(e) if e.kind() == io::ErrorKind::AlreadyExists => Ok(()),
        Err(e) => Err(err(
            path,
            format!("cannot write in '{}': {e}", dir.display()),
        )),
    }
}

/// Where the ID passes' values come from.
#[derive(Clone, Copy)]
pub enum Ids<'a> {
    /// The film's first hits, whose document indices `Scene` (the scene rendered) gives.
    Scene(&'a Scene),
    /// Each pass's values, row-major (a merge's, from the part that holds sample 0).
    Given(&'a [(Pass, Vec<f32>)]),
}

/// Writes the film as a float32 RGB EXR (ZIP compression) with `attrs` in the header, and
/// `passes` as layers beside the beauty ([`super::passes`]; the film must keep features when
/// a feature pass is asked for, and first hits when an ID pass is whose values `ids` takes
/// from the scene). With a `denoised` beauty, that is R, G, B and the film's own is the layer
/// `noisy` (Cycles' "Noisy Image"). A `partial` file (a farm shard's) also holds the film's
/// exact sums ([`super::partial`]).
pub fn write_exr(
    path: &Path,
    film: &Film,
    passes: &[Pass],
    ids: Ids,
    denoised: Option<&[glam::Vec3]>,
    attrs: &[(String, Attr)],
    partial: bool,
) -> Result<(), OutputError> {
    let mut channels = match denoised {
        None => rgb_channels(&film.pixels()),
        Some(d) => {
            let mut c = rgb_channels(d);
            c.extend(rgb_channels_named(&film.pixels(), NOISY_LAYER));
            c
        }
    };
    if partial {
        channels.extend(super::partial::exact_channels(film));
    }
    if passes.is_empty() {
        return write_channels(path, film.width, film.height, channels, attrs, partial);
    }
    let with_ids = passes.iter().any(|p| p.is_id());
    if passes.iter().any(|p| !p.is_id()) && !film.keeps_features() {
        return Err(err(
            path,
            "passes asked for, but the render kept no features",
        ));
    }
    if with_ids && matches!(ids, Ids::Scene(_)) && !film.keeps_first_hits() {
        return Err(err(
            path,
            "ID passes asked for, but the render kept no first hits",
        ));
    }
    // Each pixel's mean features and its first hit's origin once, row-major like the beauty.
    let pixels = || (0..film.height).flat_map(|y| (0..film.width).map(move |x| (x, y)));
    let features: Vec<_> = pixels().map(|(x, y)| film.features(x, y)).collect();
    let origins: Vec<_> = match ids {
        Ids::Scene(scene) if with_ids => pixels()
            .map(|(x, y)| {
                film.first_hit(x, y).map(|h| {
                    let (prim, inst) = split_first_hit(h);
                    scene.origin(prim, inst)
                })
            })
            .collect(),
        _ => vec![None; features.len()],
    };
    let mut attrs = attrs.to_vec();
    for &pass in passes {
        let given = match ids {
            Ids::Given(given) if pass.is_id() => {
                let values = given.iter().find(|(p, _)| *p == pass).map(|(_, v)| v);
                match values {
                    Some(v) if v.len() == features.len() => Some(v),
                    _ => return Err(err(path, format!("no values for the {pass} pass"))),
                }
            }
            _ => None,
        };
        for (i, c) in pass.channels().iter().enumerate() {
            let values = match given {
                Some(v) => v.clone(),
                None => (features.iter().zip(&origins))
                    .map(|(&f, &o)| pass.values(f, o)[i])
                    .collect(),
            };
            let name = pass.channel_name(c);
            channels.push(AnyChannel::new(name.as_str(), FlatSamples::F32(values)));
        }
        attrs.push((
            format!("strata:pass:{}", pass.layer()),
            Attr::Text(pass.description().into()),
        ));
    }
    let names: Vec<&str> = passes.iter().map(|p| p.layer()).collect();
    attrs.push(("strata:passes".into(), Attr::Text(names.join(","))));
    write_channels(path, film.width, film.height, channels, &attrs, partial)
}

/// Writes row-major RGB `pixels` (top row first) as a float32 EXR with `attrs` in the header.
pub fn write_rgb_exr(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[glam::Vec3],
    attrs: &[(String, Attr)],
) -> Result<(), OutputError> {
    write_channels(path, width, height, rgb_channels(pixels), attrs, false)
}

/// The layer that keeps the raw beauty of a denoised image.
pub const NOISY_LAYER: &str = "noisy";

/// The R, G and B channels of row-major `pixels`.
fn rgb_channels(pixels: &[glam::Vec3]) -> Vec<AnyChannel<FlatSamples>> {
    rgb_channels_named(pixels, "")
}

/// The R, G and B channels of row-major `pixels` in `layer` (`layer.R`, …; "": the beauty's).
fn rgb_channels_named(pixels: &[glam::Vec3], layer: &str) -> Vec<AnyChannel<FlatSamples>> {
    ["R", "G", "B"]
        .into_iter()
        .enumerate()
        .map(|(i, c)| {
            let values = pixels.iter().map(|p| p[i]).collect();
            let name = match layer {
                "" => c.to_string(),
                l => format!("{l}.{c}"),
            };
            AnyChannel::new(name.as_str(), FlatSamples::F32(values))
        })
        .collect()
}

/// Writes `channels` (each `width × height` row-major floats) as one part of a ZIP-compressed
/// EXR, with strata's software name and `attrs` in its header, atomically. A `partial` file
/// (a shard's, mostly 32-bit integer words) is compressed one scanline per block rather than
/// sixteen: the same size, and half the time to write and to read at 4K
/// (BENCHMARKS.md, "Farm shards").
fn write_channels(
    path: &Path,
    width: u32,
    height: u32,
    channels: Vec<AnyChannel<FlatSamples>>,
    attrs: &[(String, Attr)],
    partial: bool,
) -> Result<(), OutputError> {
    let encoding = match partial {
        false => Encoding::SMALL_LOSSLESS,
        true => Encoding {
            compression: Compression::ZIP1,
            ..Encoding::SMALL_LOSSLESS
        },
    };
    let mut image = Image::from_encoded_channels(
        (width as usize, height as usize),
        encoding,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    set_attributes(
        path,
        &mut image.layer_data.attributes,
        &mut image.attributes,
        attrs,
    )?;
    write_atomically(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .map_err(|e| format!("cannot write the EXR: {e}"))
    })
}

/// Puts strata's software name and `attrs` in an image's header.
fn set_attributes(
    path: &Path,
    layer: &mut LayerAttributes,
    image: &mut ImageAttributes,
    attrs: &[(String, Attr)],
) -> Result<(), OutputError> {
    layer.software_name = Text::new_or_none(format!("strata {}", env!("CARGO_PKG_VERSION")));
    for (name, value) in attrs {
        let key = Text::new_or_none(name)
            .ok_or_else(|| err(path, format!("attribute name {name:?} is not ASCII")))?;
        // Standard attributes the exr crate keeps in fields of their own.
        match (name.as_str(), value) {
            (WORLD_TO_CAMERA, Attr::Matrix(m)) => {
                layer.world_to_camera = Some(*m);
                continue;
            }
            (WORLD_TO_NDC, Attr::Matrix(m)) => {
                layer.world_to_normalized_device = Some(*m);
                continue;
            }
            _ => {}
        }
        let value = match value {
            Attr::Text(s) => AttributeValue::Text(
                Text::new_or_none(s).unwrap_or_else(|| Text::new_or_panic("(non-ASCII)")),
            ),
            Attr::Int(i) => AttributeValue::I32(*i),
            Attr::Float(f) => AttributeValue::F32(*f),
            Attr::Matrix(m) => AttributeValue::Matrix4x4(*m),
        };
        image.other.insert(key, value);
    }
    Ok(())
}

/// The header attributes of the film as it stands: its samples per pixel so far, the
/// render's seconds so far, whether the render was interrupted, and whether the image is a
/// checkpoint (written during the render) rather than the final image.
pub fn film_attributes(
    film: &Film,
    seconds: f64,
    interrupted: bool,
    checkpoint: bool,
) -> Vec<(String, Attr)> {
    let (spp_min, spp_max) = film.count_range();
    vec![
        ("strata:spp_min".to_string(), Attr::Int(spp_min as i32)),
        ("strata:spp_max".into(), Attr::Int(spp_max as i32)),
        (
            "strata:spp_mean".into(),
            Attr::Float(film.count_mean() as f32),
        ),
        ("strata:render_seconds".into(), Attr::Float(seconds as f32)),
        ("strata:interrupted".into(), Attr::Int(interrupted as i32)),
        ("strata:checkpoint".into(), Attr::Int(checkpoint as i32)),
    ]
}

/// Writes the film's preview PNG (8-bit sRGB) through `display` (the view transform and
/// exposure, [`super::view`]).
pub fn write_png(path: &Path, film: &Film, display: &Display) -> Result<(), OutputError> {
    write_png_pixels(path, film.width, film.height, &film.pixels(), display)
}

/// Each pixel's alpha, the fraction of its samples that met the scene ([`Pass::Alpha`]; 0
/// where the film keeps no features or the pixel has no samples), row-major from the top.
pub fn alpha_of(film: &Film) -> Vec<f32> {
    (0..film.height)
        .flat_map(|y| (0..film.width).map(move |x| (x, y)))
        .map(|(x, y)| Pass::Alpha.values(film.features(x, y), None)[0])
        .collect()
}

/// Writes row-major linear `pixels` through `display` as an 8-bit sRGB image: the PNG
/// preview ([`write_png`]), or the output itself when `-o` names a `.png` or `.jpg` (JPEG at
/// quality 95 for `.jpg` and `.jpeg`).
pub fn write_png_pixels(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[glam::Vec3],
    display: &Display,
) -> Result<(), OutputError> {
    write_png_rgba(path, width, height, pixels, None, display)
}

/// [`write_png_pixels`], with an alpha channel where `alpha` is given (a transparent
/// background's coverage, one value per pixel) and the format is PNG. The pixels are
/// premultiplied, as the EXR holds them; PNG's alpha is not, so each is divided by its alpha
/// before the view transform. A JPEG, which has no alpha, gets the premultiplied image: the
/// scene over black.
pub fn write_png_rgba(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[glam::Vec3],
    alpha: Option<&[f32]>,
    display: &Display,
) -> Result<(), OutputError> {
    let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    let png = ImageFormat::of(path) != Some(ImageFormat::Jpeg);
    let (data, color) = match alpha.filter(|_| png) {
        None => (
            (pixels.iter())
                .flat_map(|&p| display.encode(p).to_array())
                .map(byte)
                .collect::<Vec<u8>>(),
            image::ColorType::Rgb8,
        ),
        Some(alpha) => (
            (pixels.iter().zip(alpha))
                .flat_map(|(&p, &a)| {
                    let straight = if a > 0.0 { p / a } else { glam::Vec3::ZERO };
                    let [r, g, b] = display.encode(straight).to_array();
                    [r, g, b, a].map(byte)
                })
                .collect(),
            image::ColorType::Rgba8,
        ),
    };
    write_atomically(path, |tmp| match ImageFormat::of(path) {
        Some(ImageFormat::Jpeg) => {
            let file = fs::File::create(tmp).map_err(|e| e.to_string())?;
            let mut out = io::BufWriter::new(file);
            image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, 95)
                .encode(&data, width, height, image::ExtendedColorType::Rgb8)
                .map_err(|e| format!("cannot write the JPEG: {e}"))?;
            io::Write::flush(&mut out).map_err(|e| format!("cannot write the JPEG: {e}"))
        }
        _ => image::save_buffer_with_format(
            tmp,
            &data,
            width,
            height,
            color,
            image::ImageFormat::Png,
        )
        .map_err(|e| format!("cannot write the PNG: {e}")),
    })
}

/// Reads the RGB channels of an EXR written by [`write_exr`] (or any RGB EXR) as
/// (width, height, row-major pixels from the top row).
pub fn read_exr_rgb(path: &Path) -> Result<(usize, usize, Vec<[f32; 3]>), OutputError> {
    use exr::prelude::read_first_rgba_layer_from_file;
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| {
            let (w, h) = (resolution.width(), resolution.height());
            (w, h, vec![[0f32; 3]; w * h])
        },
        |(w, _h, px): &mut (usize, usize, Vec<[f32; 3]>),
         pos,
         (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b];
        },
    )
    .map_err(|e| err(path, format!("cannot read the EXR: {e}")))?;
    let (w, h, px) = image.layer_data.channel_data.pixels;
    Ok((w, h, px))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `may_replace` on a finished image of 4 samples per pixel, a file strata did not write,
    /// and no file at all.
    #[test]
    fn an_unfinished_image_replaces_only_a_worse_one() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.exr");
        assert!(may_replace(&path, 0, 0.0).is_ok(), "no file there");
        let mut film = Film::new(2, 2);
        for _ in 0..4 {
            for (x, y) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                film.add_sample(x, y, glam::Vec3::ONE);
            }
        }
        let attrs = film_attributes(&film, 1.0, false, false);
        write_exr(&path, &film, &[], Ids::Given(&[]), None, &attrs, false).unwrap();
        assert!(
            may_replace(&path, 5, 5.0).is_ok(),
            "more samples everywhere"
        );
        assert!(
            may_replace(&path, 2, 8.0).is_ok(),
            "more on average, some everywhere"
        );
        let fewer = may_replace(&path, 4, 4.0).unwrap_err();
        assert!(fewer.contains("as many samples"), "{fewer}");
        let holes = may_replace(&path, 0, 100.0).unwrap_err();
        assert!(holes.contains("without a sample"), "{holes}");
        fs::write(&path, b"not an image").unwrap();
        let unknown = may_replace(&path, 100, 100.0).unwrap_err();
        assert!(unknown.contains("cannot tell"), "{unknown}");
    }
}
