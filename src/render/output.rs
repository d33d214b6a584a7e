//! Image output: linear float32 EXR (R, G, B, with the render settings as header attributes)
//! and an sRGB PNG preview. Files are written to a temporary name beside the target and
//! renamed into place, so a reader never sees a half-written image.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use exr::prelude::{AttributeValue, Encoding, Image, SpecificChannels, Text};

use super::Film;

/// A header attribute value.
#[derive(Clone, Debug, PartialEq)]
pub enum Attr {
    Text(String),
    Int(i32),
    Float(f32),
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
fn write_atomically(
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

/// Checks, before rendering, that `path` can be written: an `.exr` name in an existing,
/// writable directory, and not a directory itself.
pub fn check_output_path(path: &Path) -> Result<(), OutputError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if ext.as_deref() != Some("exr") {
        return Err(err(path, "the output must be an .exr file"));
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

/// Writes the film as a float32 RGB EXR (ZIP compression) with `attrs` in the header.
pub fn write_exr(path: &Path, film: &Film, attrs: &[(String, Attr)]) -> Result<(), OutputError> {
    write_rgb_exr(path, film.width, film.height, &film.pixels(), attrs)
}

/// Writes row-major RGB `pixels` (top row first) as a float32 EXR with `attrs` in the header.
pub fn write_rgb_exr(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[glam::Vec3],
    attrs: &[(String, Attr)],
) -> Result<(), OutputError> {
    let row = width as usize;
    let channels = SpecificChannels::rgb(|pos: exr::math::Vec2<usize>| {
        let p = pixels[pos.y() * row + pos.x()];
        (p.x, p.y, p.z)
    });
    let mut image = Image::from_encoded_channels(
        (width as usize, height as usize),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    image.layer_data.attributes.software_name =
        Text::new_or_none(format!("strata {}", env!("CARGO_PKG_VERSION")));
    for (name, value) in attrs {
        let key = Text::new_or_none(name)
            .ok_or_else(|| err(path, format!("attribute name {name:?} is not ASCII")))?;
        let value = match value {
            Attr::Text(s) => AttributeValue::Text(
                Text::new_or_none(s).unwrap_or_else(|| Text::new_or_panic("(non-ASCII)")),
            ),
            Attr::Int(i) => AttributeValue::I32(*i),
            Attr::Float(f) => AttributeValue::F32(*f),
        };
        image.attributes.other.insert(key, value);
    }
    write_atomically(path, |tmp| {
        use exr::prelude::WritableImage;
        image
            .write()
            .to_file(tmp)
            .map_err(|e| format!("cannot write the EXR: {e}"))
    })
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value clamped to [0, 1].
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Writes an 8-bit sRGB preview of the film (clamped, no tone mapping).
pub fn write_png(path: &Path, film: &Film) -> Result<(), OutputError> {
    let data: Vec<u8> = film
        .pixels()
        .iter()
        .flat_map(|p| p.to_array())
        .map(|v| (linear_to_srgb(v) * 255.0 + 0.5) as u8)
        .collect();
    write_atomically(path, |tmp| {
        image::save_buffer_with_format(
            tmp,
            &data,
            film.width,
            film.height,
            image::ColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| format!("cannot write the PNG: {e}"))
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
