//! glTF 2.0 loading (`.gltf` with embedded or external buffers, and `.glb`) into a [`Scene`].
//!
//! Every node of the default scene is visited with its composed transform (TRS or matrix);
//! every triangle primitive (lists, strips and fans) is transformed to world space. Normals
//! go through the inverse transpose; under a transform with negative determinant the winding
//! is flipped so the counter-clockwise front face stays the front face. Primitives without
//! normals are shaded flat, as the glTF specification requires, and so are triangles that use
//! a zero or non-finite vertex normal. Triangles of zero or non-finite area are dropped, and
//! with them their vertices; both repairs are counted in one warning line each. Accessors are
//! range-checked against their buffers before they are read, so a malformed file is an
//! error, not a panic.
//!
//! Images are not decoded here: the scene keeps where their bytes are, and integrators that
//! read textures decode them.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use base64::Engine;
use glam::{DMat3, DMat4, DVec3, Mat4, Vec2, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use super::{Camera, ImageSource, Light, Material, Projection, Scene, TextureRef, Wrap};

/// Extensions strata honours when a file lists them in `extensionsRequired`.
pub const SUPPORTED_REQUIRED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_texture_transform",
];

/// Deepest node hierarchy accepted (deeper ones are almost certainly cyclic or hostile).
const MAX_NODE_DEPTH: usize = 256;

/// Options for [`load`].
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {}

/// A scene file that cannot be loaded, with the reason.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct LoadError {
    pub path: PathBuf,
    pub message: String,
}

type Result<T> = std::result::Result<T, String>;

/// Loads a `.gltf` or `.glb` file. Warnings (skipped primitives, repaired data) are stored in
/// [`Scene::load_warnings`].
pub fn load(path: &Path, _options: &LoadOptions) -> std::result::Result<Scene, LoadError> {
    load_inner(path).map_err(|message| LoadError {
        path: path.to_path_buf(),
        message,
    })
}

fn load_inner(path: &Path) -> Result<Scene> {
    let bytes = std::fs::read(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".to_string(),
        _ => format!("cannot read the file: {e}"),
    })?;
    if bytes.is_empty() {
        return Err("the file is empty".into());
    }
    let is_glb = bytes.starts_with(b"glTF");
    let first = bytes.iter().find(|b| !b.is_ascii_whitespace()).copied();
    if !is_glb && first != Some(b'{') {
        return Err("not a glTF file (neither glTF JSON nor binary glTF with 'glTF' magic)".into());
    }
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| {
        format!(
            "invalid {}: {e}",
            if is_glb { "binary glTF" } else { "glTF" }
        )
    })?;
    for ext in gltf.document.extensions_required() {
        if !SUPPORTED_REQUIRED_EXTENSIONS.contains(&ext) {
            return Err(format!(
                "the file requires the extension {ext}, which strata does not support (supported: {})",
                SUPPORTED_REQUIRED_EXTENSIONS.join(", ")
            ));
        }
    }
    // Validation checks every index reference in the document (accessors, views, nodes...).
    let gltf = gltf::Gltf::from_slice(&bytes).map_err(|e| format!("invalid glTF: {e}"))?;
    let base_dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let buffers = load_buffers(&gltf.document, gltf.blob.as_deref(), &base_dir)?;

    let mut loader = Loader {
        buffers: &buffers,
        scene: Scene::default(),
        warnings: Vec::new(),
        dropped_triangles: 0,
        bad_normals: 0,
        flat_triangles: 0,
        skipped_primitives: 0,
    };
    loader.scene.materials.push(Material::default());
    for m in gltf.document.materials() {
        let material = loader.material(&m)?;
        loader.scene.materials.push(material);
    }
    for img in gltf.document.images() {
        let source = loader.image(&img, &base_dir)?;
        loader.scene.images.push(source);
    }

    let root_scene = gltf
        .document
        .default_scene()
        .or_else(|| gltf.document.scenes().next())
        .ok_or("the file has no scene to render")?;
    for node in root_scene.nodes() {
        loader.visit(&node, DMat4::IDENTITY, &mut Vec::new())?;
    }

    let mut scene = loader.scene;
    let mut warnings = loader.warnings;
    if loader.dropped_triangles > 0 {
        warnings.push(format!(
            "dropped {} degenerate triangle(s) (zero area or non-finite vertices)",
            loader.dropped_triangles
        ));
    }
    if loader.bad_normals > 0 {
        warnings.push(format!(
            "{} vertex normal(s) zero or not finite; the {} triangle(s) using them are shaded flat",
            loader.bad_normals, loader.flat_triangles
        ));
    }
    if loader.dropped_triangles > 0 || scene.positions.iter().any(|p| !p.is_finite()) {
        drop_unused_vertices(&mut scene);
    }
    if scene.triangles.is_empty() {
        return Err(if loader.skipped_primitives > 0 {
            format!(
                "the scene has no triangles to render ({} primitive(s) of points or lines were skipped)",
                loader.skipped_primitives
            )
        } else {
            "the scene has no triangles to render".into()
        });
    }
    scene.update_summary();
    scene.load_warnings = warnings;
    Ok(scene)
}

fn load_buffers(
    doc: &gltf::Document,
    blob: Option<&[u8]>,
    base_dir: &Path,
) -> Result<Vec<Vec<u8>>> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let i = buffer.index();
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .ok_or_else(|| {
                    format!("buffer {i} refers to the binary chunk, but the file has none")
                })?
                .to_vec(),
            gltf::buffer::Source::Uri(uri) => {
                read_uri(uri, base_dir).map_err(|e| format!("buffer {i}: {e}"))?
            }
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "buffer {i} holds {} bytes but declares byteLength {}",
                data.len(),
                buffer.length()
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// Reads a data URI or a file relative to the scene.
fn read_uri(uri: &str, base_dir: &Path) -> Result<Vec<u8>> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest
            .split_once(";base64,")
            .ok_or("data URI is not base64-encoded (expected ';base64,')")?;
        return base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map_err(|e| format!("data URI is not valid base64: {e}"));
    }
    let file = resolve_uri(uri, base_dir)?;
    std::fs::read(&file).map_err(|e| format!("cannot read '{}': {e}", file.display()))
}

fn resolve_uri(uri: &str, base_dir: &Path) -> Result<PathBuf> {
    if uri.contains("://") {
        return Err(format!(
            "'{uri}': only relative file URIs and data URIs are supported"
        ));
    }
    Ok(base_dir.join(percent_decode(uri)?))
}

/// Decodes %XX escapes of a URI reference (RFC 3986 §2.1).
pub fn percent_decode(uri: &str) -> Result<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("'{uri}': bad percent escape"))?;
            out.push(hex);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("'{uri}': not UTF-8 after percent-decoding"))
}

fn wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    }
}

struct Loader<'a> {
    buffers: &'a [Vec<u8>],
    scene: Scene,
    warnings: Vec<String>,
    dropped_triangles: usize,
    /// Vertex normals that were zero or not finite, and the triangles shaded flat for them.
    bad_normals: usize,
    flat_triangles: usize,
    skipped_primitives: usize,
}

impl Loader<'_> {
    fn texture_ref(&mut self, info: &gltf::texture::Info, what: &str) -> TextureRef {
        let texture = info.texture();
        let sampler = texture.sampler();
        let mut tex_coord = info.tex_coord();
        // KHR_texture_transform: uv' = T · R · S · uv, R = [[cos, sin], [−sin, cos]].
        let mut transform = [Vec2::X, Vec2::Y, Vec2::ZERO];
        if let Some(t) = info.texture_transform() {
            let (s, c) = t.rotation().sin_cos();
            let [sx, sy] = t.scale();
            transform = [
                Vec2::new(c * sx, -s * sx),
                Vec2::new(s * sy, c * sy),
                Vec2::from_array(t.offset()),
            ];
            if let Some(tc) = t.tex_coord() {
                tex_coord = tc;
            }
        }
        if tex_coord != 0 {
            self.warnings.push(format!(
                "{what} uses TEXCOORD_{tex_coord}; strata reads TEXCOORD_0 only"
            ));
        }
        TextureRef {
            image: texture.source().index(),
            tex_coord,
            wrap_s: wrap(sampler.wrap_s()),
            wrap_t: wrap(sampler.wrap_t()),
            transform,
        }
    }

    fn material(&mut self, m: &gltf::Material) -> Result<Material> {
        let label = match (m.index(), m.name()) {
            (Some(i), Some(n)) => format!("material {i} '{n}'"),
            (Some(i), None) => format!("material {i}"),
            _ => "default material".to_string(),
        };
        let pbr = m.pbr_metallic_roughness();
        let base_color = Vec4::from_array(pbr.base_color_factor());
        let emissive = Vec3::from_array(m.emissive_factor()) * m.emissive_strength().unwrap_or(1.0);
        if !base_color.is_finite() || !emissive.is_finite() {
            return Err(format!("{label} has a non-finite colour factor"));
        }
        let base_color_texture = pbr
            .base_color_texture()
            .map(|info| self.texture_ref(&info, &format!("{label} base colour texture")));
        let emissive_texture = m
            .emissive_texture()
            .map(|info| self.texture_ref(&info, &format!("{label} emissive texture")));
        Ok(Material {
            name: m.name().map(str::to_string),
            base_color,
            base_color_texture,
            emissive,
            emissive_texture,
            metallic: pbr.metallic_factor(),
            roughness: pbr.roughness_factor(),
            double_sided: m.double_sided(),
        })
    }

    fn image(&self, img: &gltf::Image, base_dir: &Path) -> Result<ImageSource> {
        let i = img.index();
        match img.source() {
            gltf::image::Source::View { view, mime_type } => {
                let bytes =
                    view_bytes(self.buffers, &view).map_err(|e| format!("image {i}: {e}"))?;
                Ok(ImageSource::Bytes {
                    data: Arc::from(bytes),
                    mime: Some(mime_type.to_string()),
                })
            }
            gltf::image::Source::Uri { uri, mime_type } => {
                if uri.starts_with("data:") {
                    let data = read_uri(uri, base_dir).map_err(|e| format!("image {i}: {e}"))?;
                    Ok(ImageSource::Bytes {
                        data: Arc::from(data),
                        mime: mime_type.map(str::to_string),
                    })
                } else {
                    let file = resolve_uri(uri, base_dir).map_err(|e| format!("image {i}: {e}"))?;
                    if !file.is_file() {
                        return Err(format!(
                            "image {i}: file '{}' does not exist",
                            file.display()
                        ));
                    }
                    Ok(ImageSource::File(file))
                }
            }
        }
    }

    /// Visits `node` and its subtree; `path` holds the indices of the ancestors (cycle check).
    fn visit(&mut self, node: &gltf::Node, parent: DMat4, path: &mut Vec<usize>) -> Result<()> {
        let index = node.index();
        if path.contains(&index) {
            return Err(format!(
                "node {index} is its own ancestor (the node graph has a cycle)"
            ));
        }
        if path.len() >= MAX_NODE_DEPTH {
            return Err(format!(
                "the node hierarchy is deeper than {MAX_NODE_DEPTH} levels"
            ));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4();
        if !local.is_finite() {
            return Err(format!("node {index} has a non-finite transform"));
        }
        let world = parent * local;

        if let Some(mesh) = node.mesh() {
            for primitive in mesh.primitives() {
                let label = format!("mesh {} primitive {}", mesh.index(), primitive.index());
                self.primitive(&primitive, &world, &label)?;
            }
        }
        if let Some(camera) = node.camera() {
            let camera = self.camera(&camera, &world)?;
            self.scene.cameras.push(camera);
        }
        if let Some(light) = node.light() {
            self.light(&light, &world)?;
        }
        path.push(index);
        for child in node.children() {
            self.visit(&child, world, path)?;
        }
        path.pop();
        Ok(())
    }

    fn camera(&self, camera: &gltf::Camera, world: &DMat4) -> Result<Camera> {
        let label = format!("camera {}", camera.index());
        let (projection, aspect_ratio) = match camera.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let yfov = p.yfov();
                if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
                    return Err(format!("{label}: yfov {yfov} is not in (0, π)"));
                }
                let aspect = p.aspect_ratio();
                if let Some(a) = aspect {
                    if !(a > 0.0 && a.is_finite()) {
                        return Err(format!("{label}: aspectRatio {a} is not positive"));
                    }
                }
                (Projection::Perspective { yfov }, aspect)
            }
            gltf::camera::Projection::Orthographic(o) => {
                let (xmag, ymag) = (o.xmag(), o.ymag());
                if !(ymag > 0.0 && ymag.is_finite() && xmag > 0.0 && xmag.is_finite()) {
                    return Err(format!(
                        "{label}: xmag {xmag} and ymag {ymag} must be positive"
                    ));
                }
                (Projection::Orthographic { ymag }, Some(xmag / ymag))
            }
        };
        Ok(Camera {
            name: camera.name().map(str::to_string),
            projection,
            to_world: world.as_mat4(),
            aspect_ratio,
        })
    }

    fn light(&mut self, light: &gltf::khr_lights_punctual::Light, world: &DMat4) -> Result<()> {
        let color = Vec3::from_array(light.color()) * light.intensity();
        if !color.is_finite() || color.min_element() < 0.0 {
            return Err(format!(
                "light {}: colour × intensity must be finite and non-negative",
                light.index()
            ));
        }
        let position = world.transform_point3(DVec3::ZERO).as_vec3();
        let direction = world
            .transform_vector3(DVec3::NEG_Z)
            .normalize_or_zero()
            .as_vec3();
        let range = light.range().filter(|r| *r > 0.0);
        let l = match light.kind() {
            gltf::khr_lights_punctual::Kind::Point => Light::Point {
                position,
                intensity: color,
                range,
            },
            gltf::khr_lights_punctual::Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => Light::Spot {
                position,
                direction,
                intensity: color,
                range,
                inner_cone_angle,
                outer_cone_angle,
            },
            gltf::khr_lights_punctual::Kind::Directional => Light::Directional {
                direction,
                irradiance: color,
            },
        };
        self.scene.lights.push(l);
        Ok(())
    }

    fn primitive(&mut self, primitive: &gltf::Primitive, world: &DMat4, label: &str) -> Result<()> {
        let mode = primitive.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.skipped_primitives += 1;
            self.warnings.push(format!(
                "{label}: {mode:?} skipped (strata renders triangles only)"
            ));
            return Ok(());
        }
        let Some(pos_acc) = primitive.get(&gltf::Semantic::Positions) else {
            self.warnings
                .push(format!("{label}: no POSITION attribute, skipped"));
            self.skipped_primitives += 1;
            return Ok(());
        };
        expect_format(
            &pos_acc,
            Dimensions::Vec3,
            &[DataType::F32],
            label,
            "POSITION",
        )?;
        check_accessor(self.buffers, &pos_acc).map_err(|e| format!("{label} POSITION: {e}"))?;
        let normal_acc = primitive.get(&gltf::Semantic::Normals);
        if let Some(acc) = &normal_acc {
            expect_format(acc, Dimensions::Vec3, &[DataType::F32], label, "NORMAL")?;
            check_accessor(self.buffers, acc).map_err(|e| format!("{label} NORMAL: {e}"))?;
        }
        let uv_acc = primitive.get(&gltf::Semantic::TexCoords(0));
        if let Some(acc) = &uv_acc {
            expect_format(
                acc,
                Dimensions::Vec2,
                &[DataType::F32, DataType::U8, DataType::U16],
                label,
                "TEXCOORD_0",
            )?;
            check_accessor(self.buffers, acc).map_err(|e| format!("{label} TEXCOORD_0: {e}"))?;
        }
        if let Some(acc) = primitive.indices() {
            expect_format(
                &acc,
                Dimensions::Scalar,
                &[DataType::U8, DataType::U16, DataType::U32],
                label,
                "indices",
            )?;
            check_accessor(self.buffers, &acc).map_err(|e| format!("{label} indices: {e}"))?;
        }

        let buffers = self.buffers;
        let reader = primitive.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let unreadable =
            |what: &str| format!("{label}: the {what} accessor cannot be read from its buffer");
        let positions: Vec<[f32; 3]> = reader
            .read_positions()
            .ok_or_else(|| unreadable("POSITION"))?
            .collect();
        let n = positions.len();
        let normals: Option<Vec<[f32; 3]>> = match normal_acc {
            Some(_) => Some(
                reader
                    .read_normals()
                    .ok_or_else(|| unreadable("NORMAL"))?
                    .collect(),
            ),
            None => None,
        };
        let uvs: Option<Vec<[f32; 2]>> = match uv_acc {
            Some(_) => Some(
                reader
                    .read_tex_coords(0)
                    .ok_or_else(|| unreadable("TEXCOORD_0"))?
                    .into_f32()
                    .collect(),
            ),
            None => None,
        };
        if normals.as_ref().is_some_and(|v| v.len() != n)
            || uvs.as_ref().is_some_and(|v| v.len() != n)
        {
            return Err(format!(
                "{label}: attribute counts differ from the POSITION count {n}"
            ));
        }
        let indices: Vec<u32> = match primitive.indices() {
            Some(_) => reader
                .read_indices()
                .ok_or_else(|| unreadable("indices"))?
                .into_u32()
                .collect(),
            None => {
                let n32 = u32::try_from(n).map_err(|_| format!("{label}: too many vertices"))?;
                (0..n32).collect()
            }
        };
        if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
            return Err(format!(
                "{label}: vertex index {bad} out of range ({n} vertices)"
            ));
        }
        let triangles = assemble_triangles(mode, &indices);
        if mode == Mode::Triangles && indices.len() % 3 != 0 {
            self.warnings.push(format!(
                "{label}: {} indices is not a multiple of 3; the last {} ignored",
                indices.len(),
                indices.len() % 3
            ));
        }

        // Transform to world space: points by the matrix, normals by its inverse transpose.
        let linear = DMat3::from_mat4(*world);
        let flip = linear.determinant() < 0.0;
        let normal_matrix = linear.inverse().transpose();
        let base = self.scene.positions.len();
        if base + n > u32::MAX as usize {
            return Err(format!("{label}: the scene has more than 2^32 vertices"));
        }
        self.scene.positions.extend(positions.iter().map(|p| {
            world
                .transform_point3(DVec3::from_array(p.map(f64::from)))
                .as_vec3()
        }));
        match &normals {
            Some(ns) => {
                let mut bad = 0;
                self.scene.normals.extend(ns.iter().map(|nrm| {
                    // Zero for a normal that is zero, not finite, or too short for f64 to
                    // normalise: triangles using it are shaded flat below.
                    let v = (normal_matrix * DVec3::from_array(nrm.map(f64::from)))
                        .normalize_or_zero()
                        .as_vec3();
                    if v.is_finite() && v != Vec3::ZERO {
                        v
                    } else {
                        bad += 1;
                        Vec3::ZERO
                    }
                }));
                self.bad_normals += bad;
            }
            None => self
                .scene
                .normals
                .extend(std::iter::repeat_n(Vec3::ZERO, n)),
        }
        match &uvs {
            Some(ts) => self
                .scene
                .uvs
                .extend(ts.iter().map(|t| Vec2::from_array(*t))),
            None => self.scene.uvs.extend(std::iter::repeat_n(Vec2::ZERO, n)),
        }
        let material = primitive.material().index().map_or(0, |i| i as u32 + 1);
        for [a, b, c] in triangles {
            let [a, b, c] = [a, b, c].map(|i| i + base as u32);
            let [pa, pb, pc] = [a, b, c].map(|i| self.scene.positions[i as usize]);
            let area2 = (pb - pa).cross(pc - pa).length_squared();
            if !(area2 > 0.0 && area2.is_finite()) {
                self.dropped_triangles += 1;
                continue;
            }
            // A triangle that uses a bad vertex normal is shaded flat: it gets its own copies
            // of its vertices, all with the zero normal that means "no normal", so the
            // neighbours sharing its good vertices keep their smooth shading.
            let [a, b, c] = if normals.is_some()
                && [a, b, c]
                    .iter()
                    .any(|&i| self.scene.normals[i as usize] == Vec3::ZERO)
            {
                let first = self.scene.positions.len();
                if first + 3 > u32::MAX as usize {
                    return Err(format!("{label}: the scene has more than 2^32 vertices"));
                }
                for i in [a, b, c] {
                    let (p, t) = (self.scene.positions[i as usize], self.scene.uvs[i as usize]);
                    self.scene.positions.push(p);
                    self.scene.uvs.push(t);
                    self.scene.normals.push(Vec3::ZERO);
                }
                self.flat_triangles += 1;
                let first = first as u32;
                [first, first + 1, first + 2]
            } else {
                [a, b, c]
            };
            self.scene
                .triangles
                .push(if flip { [a, c, b] } else { [a, b, c] });
            self.scene.triangle_materials.push(material);
        }
        Ok(())
    }
}

/// Keeps only the vertices some triangle uses, in their order. Run after triangles were
/// dropped or when a position is not finite: the vertices of dropped triangles (NaN,
/// infinite, or so large that the area overflows) would otherwise reach the scene bounds,
/// which place the default camera and size distant lights, and the BVH's vertex buffer.
fn drop_unused_vertices(scene: &mut Scene) {
    let mut used = vec![false; scene.positions.len()];
    for t in &scene.triangles {
        for &i in t {
            used[i as usize] = true;
        }
    }
    let mut new_index = vec![u32::MAX; used.len()];
    let mut kept = 0;
    for old in (0..used.len()).filter(|&i| used[i]) {
        new_index[old] = kept as u32;
        scene.positions[kept] = scene.positions[old];
        scene.normals[kept] = scene.normals[old];
        scene.uvs[kept] = scene.uvs[old];
        kept += 1;
    }
    scene.positions.truncate(kept);
    scene.normals.truncate(kept);
    scene.uvs.truncate(kept);
    for t in &mut scene.triangles {
        *t = t.map(|i| new_index[i as usize]);
    }
}

/// Turns an index list of the given mode into triangles (glTF 2.0 §3.7.2.1: strips use
/// {v_i, v_{i+1+i%2}, v_{i+2−i%2}}, fans {v_{i+1}, v_{i+2}, v_0}, keeping one winding).
fn assemble_triangles(mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .map(|i| [idx[i], idx[i + 1 + i % 2], idx[i + 2 - i % 2]])
            .collect(),
        Mode::TriangleFan => (0..idx.len().saturating_sub(2))
            .map(|i| [idx[i + 1], idx[i + 2], idx[0]])
            .collect(),
        _ => Vec::new(),
    }
}

fn expect_format(
    acc: &gltf::Accessor,
    dims: Dimensions,
    types: &[DataType],
    label: &str,
    what: &str,
) -> Result<()> {
    if acc.dimensions() != dims || !types.contains(&acc.data_type()) {
        return Err(format!(
            "{label}: {what} accessor {} is {:?} {:?}; expected {dims:?} of {types:?}",
            acc.index(),
            acc.dimensions(),
            acc.data_type()
        ));
    }
    Ok(())
}

/// The bytes of a buffer view, range-checked.
fn view_bytes<'b>(buffers: &'b [Vec<u8>], view: &gltf::buffer::View) -> Result<&'b [u8]> {
    let data = &buffers[view.buffer().index()];
    let end = view
        .offset()
        .checked_add(view.length())
        .filter(|&e| e <= data.len())
        .ok_or_else(|| {
            format!(
                "bufferView {} (offset {}, length {}) runs past the end of buffer {} ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index(),
                data.len()
            )
        })?;
    Ok(&data[view.offset()..end])
}

/// Checks that an accessor's elements (and sparse parts) lie inside their buffer views and
/// buffers, with overflow-checked arithmetic, before anything is read.
fn check_accessor(buffers: &[Vec<u8>], acc: &gltf::Accessor) -> Result<()> {
    let count = acc.count();
    if count == 0 {
        return Err(format!("accessor {} has count 0", acc.index()));
    }
    let elem = acc.size();
    if let Some(view) = acc.view() {
        let bytes = view_bytes(buffers, &view)?;
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(format!(
                "accessor {}: byteStride {stride} is smaller than its element size {elem}",
                acc.index()
            ));
        }
        let needed = stride
            .checked_mul(count - 1)
            .and_then(|x| x.checked_add(elem))
            .and_then(|x| x.checked_add(acc.offset()));
        if needed.is_none_or(|n| n > bytes.len()) {
            return Err(format!(
                "accessor {} ({count} elements of {elem} bytes at offset {}) runs past the end of bufferView {} ({} bytes)",
                acc.index(),
                acc.offset(),
                view.index(),
                bytes.len()
            ));
        }
    }
    if let Some(sparse) = acc.sparse() {
        let sc = sparse.count();
        let idx = sparse.indices();
        let idx_bytes = view_bytes(buffers, &idx.view())?;
        let idx_size = match idx.index_type() {
            gltf::accessor::sparse::IndexType::U8 => 1,
            gltf::accessor::sparse::IndexType::U16 => 2,
            gltf::accessor::sparse::IndexType::U32 => 4,
        };
        let val = sparse.values();
        let val_bytes = view_bytes(buffers, &val.view())?;
        let idx_end = sc
            .checked_mul(idx_size)
            .and_then(|x| x.checked_add(idx.offset()));
        let val_end = sc
            .checked_mul(elem)
            .and_then(|x| x.checked_add(val.offset()));
        if idx_end.is_none_or(|e| e > idx_bytes.len())
            || val_end.is_none_or(|e| e > val_bytes.len())
        {
            return Err(format!(
                "accessor {}: sparse data runs past its bufferView",
                acc.index()
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_one_winding() {
        // A strip over a regular quad row: every triangle must face the same way.
        let p = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
        ];
        let idx: Vec<u32> = (0..6).collect();
        let strip = assemble_triangles(Mode::TriangleStrip, &idx);
        assert_eq!(strip.len(), 4);
        let normal = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|i| p[i as usize]);
            (b - a).cross(c - a).z.signum()
        };
        let first = normal(&strip[0]);
        assert!(strip.iter().all(|t| normal(t) == first), "{strip:?}");

        // A fan around vertex 0 of a convex polygon.
        let fan_pts = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let fan = assemble_triangles(Mode::TriangleFan, &[0, 1, 2, 3]);
        assert_eq!(fan, vec![[1, 2, 0], [2, 3, 0]]);
        for t in &fan {
            let [a, b, c] = t.map(|i| fan_pts[i as usize]);
            assert!((b - a).cross(c - a).z > 0.0);
        }
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin").unwrap(), "a b.bin");
        assert!(percent_decode("bad%2").is_err());
        assert!(percent_decode("bad%zz").is_err());
    }
}
