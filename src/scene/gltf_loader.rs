//! glTF 2.0 loading (`.gltf` with embedded or external buffers, and `.glb`) into a [`Scene`].
//!
//! Every node of the default scene is visited with its composed transform (TRS or matrix);
//! every triangle primitive (lists, strips and fans) is transformed to world space. Normals
//! go through the inverse transpose; under a transform with negative determinant the winding
//! is flipped so the counter-clockwise front face stays the front face. Primitives without
//! normals are shaded flat, as the glTF specification requires, and so are triangles that use
//! a zero or non-finite vertex normal. Triangles of zero or non-finite area are dropped, and
//! with them their vertices; non-finite texture coordinates become (0, 0); each repair is
//! counted in one warning line. Accessors are
//! range-checked against their buffers before they are read, so a malformed file is an
//! error, not a panic.
//!
//! Images are not decoded here: the scene keeps where their bytes are (and the loader reads
//! their headers, for the memory estimate), and integrators that read textures decode them.
//! An image that cannot be read is kept as [`ImageSource::Unreadable`], with why: its
//! textures render as absent, with a warning, or `--strict` refuses the scene.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Affine3A, DMat3, DMat4, DVec3, Mat4, Vec2, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use super::accessors::{
    assemble_triangles, check_accessor, expect_format, read_floats, view_bytes, QUANTIZED,
    QUANTIZED_UNIT,
};
use super::extensions::{self, Layers};
use super::files::{check_glb_header, load_buffers, read_scene_file, read_uri, resolve_uri};
use super::instancing::{instance_transforms, instanced_mesh};
use super::memory::{estimate_memory, texture_memory, MemoryEstimate};
use super::MAX_NODE_DEPTH;
use super::{
    format_bytes, AlphaMode, ImageSource, Instance, Material, Prototype, Scene, TextureRef, Wrap,
};

/// Options for [`load`].
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Refuse a scene whose estimated memory ([`MemoryEstimate::bytes`] plus `other_memory`
    /// and `environment_memory`) exceeds this many bytes. Checked after the JSON is parsed
    /// and before any buffer is read, and again with the decoded textures once the images'
    /// headers give their sizes, before any geometry is allocated. `None`: no limit.
    pub memory_limit: Option<u64>,
    /// Memory the caller will need besides the scene (e.g. the film), counted against
    /// `memory_limit`.
    pub other_memory: u64,
    /// Memory the environment map will take (`--env`), counted against `memory_limit` and
    /// named in its message.
    pub environment_memory: u64,
    /// Flatten the nodes in this animation's pose at this time; None: their rest pose
    /// (their own transforms).
    pub pose: Option<super::PoseTime>,
    /// Draw every placement of a mesh as a world-space copy, where a mesh that several
    /// nodes (or `EXT_mesh_gpu_instancing` instances) place is otherwise stored once and
    /// instanced ([`super::Prototype`]): for comparisons (`--flatten-instances`).
    pub flatten_instances: bool,
}

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
pub fn load(path: &Path, options: &LoadOptions) -> std::result::Result<Scene, LoadError> {
    let error = |message| LoadError {
        path: path.to_path_buf(),
        message,
    };
    let bytes = read_scene_file(path).map_err(error)?;
    load_from_bytes(path, &bytes, options)
}

/// Loads a scene from `bytes`, the contents of a `.gltf` or `.glb` file, as if read from
/// `path`: errors name `path`, and relative URIs resolve against its directory. (The fuzz
/// target's entry point; [`load`] reads the file and calls this.)
pub fn load_from_bytes(
    path: &Path,
    bytes: &[u8],
    options: &LoadOptions,
) -> std::result::Result<Scene, LoadError> {
    load_inner(path, bytes, options).map_err(|message| LoadError {
        path: path.to_path_buf(),
        message,
    })
}

fn load_inner(path: &Path, bytes: &[u8], options: &LoadOptions) -> Result<Scene> {
    let (mut gltf, extension_warnings) = parse_document(bytes)?;
    let root_scene = gltf
        .document
        .default_scene()
        .or_else(|| gltf.document.scenes().next())
        .ok_or("the file has no scene to render")?;

    // Before reading a buffer or allocating geometry: the node graph must be a forest, and
    // what the scene would need must fit the memory limit.
    let (mut estimate, mesh_uses) =
        estimate_memory(&gltf.document, &root_scene, options.flatten_instances)?;
    estimate.input_bytes = gltf.document.buffers().fold(bytes.len() as u64, |sum, b| {
        sum.saturating_add(b.length() as u64)
    });
    check_memory(&estimate, options)?;

    let base_dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let mut files = vec![path.to_path_buf()];
    let mut buffers = load_buffers(&gltf.document, gltf.blob.as_deref(), &base_dir, &mut files)?;
    // Meshopt and Draco compressed geometry, decoded into buffers accessors read.
    let scene_index = root_scene.index();
    gltf.document = super::compressed::decode_geometry(gltf.document, &mut buffers)?;
    let root_scene =
        (gltf.document.scenes().nth(scene_index)).ok_or("the scene to render vanished")?;

    let (pose, pose_warnings) = pose_of(&gltf.document, &buffers, options)?;
    let mut loader = Loader {
        document: &gltf.document,
        pose,
        skinned: 0,
        morphed: 0,
        buffers: &buffers,
        scene: Scene::default(),
        warnings: Vec::new(),
        dropped_triangles: 0,
        bad_normals: 0,
        flat_triangles: 0,
        bad_uvs: 0,
        skipped_primitives: 0,
        bad_colors: 0,
        mesh_uses,
        flatten_instances: options.flatten_instances,
        prototype_of_mesh: vec![None; gltf.document.meshes().len()],
        instances: Vec::new(),
        singular_placements: 0,
    };
    // The scene's material 0 is glTF's default, which the document does not hold; the
    // file's material k is the scene's k + 1.
    loader.scene.materials.push(Material::default());
    loader.scene.origins.materials.push(None);
    for m in gltf.document.materials() {
        let material = loader.material(&m)?;
        loader.scene.materials.push(material);
        loader
            .scene
            .origins
            .materials
            .push(m.index().map(|i| i as u32));
    }
    // Each image's source and size, from its header: an image that cannot be read (a missing
    // file, a header no decoder knows) is kept as unreadable, and its textures render as if
    // absent, with a warning, when a render binds them (or `--strict` refuses the scene).
    let mut sizes = Vec::with_capacity(gltf.document.images().len());
    for img in gltf.document.images() {
        let source = loader
            .image(&gltf.document, img.index(), &base_dir)
            .unwrap_or_else(ImageSource::Unreadable);
        let source = match super::image_header::dimensions(&source) {
            Ok(size) => {
                sizes.push(Some(size));
                source
            }
            Err(why) => {
                sizes.push(None);
                ImageSource::Unreadable(why)
            }
        };
        loader
            .scene
            .image_labels
            .push(image_label(&gltf.document, &img));
        loader.scene.images.push(source);
    }
    // The decoded textures, now that their sizes are known, before any geometry is read.
    (estimate.textures, estimate.texture_bytes) = texture_memory(&loader.scene.materials, &sizes);
    check_memory(&estimate, options)?;

    for node in root_scene.nodes() {
        loader.visit(&node, DMat4::IDENTITY, &mut Vec::new())?;
    }

    let mut scene = loader.finish(extension_warnings, pose_warnings);
    scene.update_summary();
    scene.memory_estimate = estimate;
    files.extend(scene.images.iter().filter_map(|image| match image {
        ImageSource::File(file) => Some(file.clone()),
        ImageSource::Bytes { .. } | ImageSource::Unreadable(_) => None,
    }));
    scene.files = files;
    Ok(scene)
}

/// The document in `bytes` (glTF JSON or binary glTF), its textures reading their
/// extensions' images, checked: every extension it requires is one strata supports, and
/// every index it holds refers to something. Also the warnings for the extensions it uses
/// that strata ignores.
fn parse_document(bytes: &[u8]) -> Result<(gltf::Gltf, Vec<String>)> {
    if bytes.is_empty() {
        return Err("the file is empty".into());
    }
    let is_glb = bytes.starts_with(b"glTF");
    let first = bytes.iter().find(|b| !b.is_ascii_whitespace()).copied();
    if !is_glb && first != Some(b'{') {
        return Err("not a glTF file (neither glTF JSON nor binary glTF with 'glTF' magic)".into());
    }
    if is_glb {
        check_glb_header(bytes).map_err(|e| format!("invalid binary glTF: {e}"))?;
    }
    let mut gltf = gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| {
        format!(
            "invalid {}: {e}",
            if is_glb { "binary glTF" } else { "glTF" }
        )
    })?;
    // EXT_texture_webp, KHR_texture_basisu: textures read their extension's image.
    gltf.document = super::compressed::prefer_texture_extensions(gltf.document)?;
    for ext in gltf.document.extensions_required() {
        if !extensions::SUPPORTED.contains(&ext) {
            return Err(format!(
                "the file requires the extension {ext}, which strata does not support (supported: {})",
                extensions::SUPPORTED.join(", ")
            ));
        }
    }
    let mut extension_warnings = Vec::new();
    for ext in gltf.document.extensions_used() {
        if !extensions::SUPPORTED.contains(&ext) {
            extension_warnings.push(format!(
                "the file uses {ext}, which strata ignores: {}",
                extensions::ignored_effect(ext)
            ));
        }
    }
    check_before_validation(gltf.document.as_json())?;
    // Validation checks every index reference in the document (accessors, views, nodes...),
    // as the `gltf` crate's own does; its verdict on `extensionsRequired` is left out, since
    // strata checked those above against what it supports (KHR_mesh_quantization, which the
    // crate does not list).
    {
        use gltf::json::validation::{Error as Invalid, Validate};
        let root = gltf.document.as_json();
        let mut errors = Vec::new();
        root.validate(root, gltf::json::Path::new, &mut |path, error| {
            errors.push((path(), error))
        });
        // Accessors a KHR_draco_mesh_compression stream fills have no bufferView by design.
        let draco = super::compressed::draco_accessors(root);
        errors.retain(|(path, error)| match error {
            Invalid::Unsupported => !path.as_str().starts_with("extensionsRequired"),
            Invalid::Missing => !draco.contains(path.as_str()),
            _ => true,
        });
        if !errors.is_empty() {
            let shown: Vec<String> = errors
                .iter()
                .take(3)
                .map(|(path, e)| format!("{path}: {}", e.to_string().to_lowercase()))
                .collect();
            let more = match errors.len() {
                n if n > 3 => format!(" (and {} more)", n - 3),
                _ => String::new(),
            };
            return Err(format!("invalid glTF: {}{more}", shown.join("; ")));
        }
    }
    Ok((gltf, extension_warnings))
}

/// What messages call an image: its index, and its name and URI where it has them.
fn image_label(doc: &gltf::Document, img: &gltf::Image) -> String {
    let json = &doc.as_json().images[img.index()];
    let uri = json.uri.as_deref().filter(|u| !u.starts_with("data:"));
    let mut label = format!("image {}", img.index());
    if let Some(name) = img.name() {
        label += &format!(" '{name}'");
    }
    match uri {
        Some(uri) => label += &format!(" ({uri})"),
        None => label += " (embedded)",
    }
    label
}

/// An error where the scene's memory `estimate`, with the image's and the environment map's,
/// exceeds the limit.
fn check_memory(estimate: &MemoryEstimate, options: &LoadOptions) -> Result<()> {
    if let Some(limit) = options.memory_limit {
        let need = (estimate.bytes())
            .saturating_add(options.other_memory)
            .saturating_add(options.environment_memory);
        if need > limit {
            let mut parts = format!(
                "{} vertices, {} triangles, {} of file and buffers",
                estimate.vertices,
                estimate.triangles,
                format_bytes(estimate.input_bytes),
            );
            if estimate.textures > 0 {
                parts += &format!(
                    ", {} for {} decoded texture(s)",
                    format_bytes(estimate.texture_bytes),
                    estimate.textures
                );
            }
            if options.environment_memory > 0 {
                parts += &format!(
                    ", {} for the environment map",
                    format_bytes(options.environment_memory)
                );
            }
            if options.other_memory > 0 {
                parts += &format!(", {} for the image", format_bytes(options.other_memory));
            }
            return Err(format!(
                "the scene needs an estimated {} of memory ({parts}), more than the limit of {} (--max-memory)",
                format_bytes(need),
                format_bytes(limit)
            ));
        }
    }

    Ok(())
}

/// The nodes' pose at `options.pose` (the rest pose without one), and the warnings about
/// animations not rendered.
fn pose_of(
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    options: &LoadOptions,
) -> Result<(super::animation::Pose, Vec<String>)> {
    let mut pose_warnings = Vec::new();
    let pose = match options.pose {
        Some(at) => super::animation::pose(document, buffers, at)?,
        None => super::animation::Pose::default(),
    };
    let animations = document.animations().len();
    if options.pose.is_none() && animations > 0 {
        let names: Vec<String> = document
            .animations()
            .map(|a| match a.name() {
                Some(n) => format!("{} \"{n}\"", a.index()),
                None => a.index().to_string(),
            })
            .collect();
        pose_warnings.push(format!(
            "the file has {animations} animation(s) ({}); strata renders the nodes' rest pose (--frame F renders frame F of one, --animation N chooses it)",
            names.join(", ")
        ));
    }
    if pose.weight_channels > 0 {
        pose_warnings.push(format!(
            "{} animation channel(s) animate morph target weights, which strata does not render",
            pose.weight_channels
        ));
    }
    Ok((pose, pose_warnings))
}

/// Checks that the `gltf` crate's validation assumes rather than checks (it would panic):
/// a primitive's POSITION accessor index must exist.
fn check_before_validation(root: &gltf::json::Root) -> Result<()> {
    use gltf::json::validation::Checked;
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = primitive
                .attributes
                .get(&Checked::Valid(gltf::json::mesh::Semantic::Positions));
            if let Some(i) = position.filter(|i| i.value() >= root.accessors.len()) {
                return Err(format!(
                    "mesh {m} primitive {p}: POSITION refers to accessor {}, but the file has {} accessor(s)",
                    i.value(),
                    root.accessors.len()
                ));
            }
        }
    }
    Ok(())
}

fn wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    }
}

/// A triangle primitive's accessors, checked ([`Loader::primitive_accessors`]).
struct PrimitiveAccessors<'a> {
    position: gltf::Accessor<'a>,
    normal: Option<gltf::Accessor<'a>>,
    uv: Option<gltf::Accessor<'a>>,
    tangent: Option<gltf::Accessor<'a>>,
    color: Option<gltf::Accessor<'a>>,
}

/// A primitive's attributes as the file holds them ([`Loader::read_primitive`]), one per
/// vertex; `material` is its index in the scene's materials (0: the default), and
/// `normal_mapped` whether that material reads tangent frames.
struct PrimitiveData {
    positions: Vec<[f32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    uvs: Option<Vec<[f32; 2]>>,
    colors: Option<Vec<[f32; 4]>>,
    tangents: Option<Vec<[f32; 4]>>,
    indices: Vec<u32>,
    material: u32,
    normal_mapped: bool,
}

struct Loader<'a> {
    document: &'a gltf::Document,
    /// The animated nodes' transforms (empty for the rest pose).
    pose: super::animation::Pose,
    /// Mesh instances with a skin, and primitives with morph targets (not applied).
    skinned: usize,
    morphed: usize,
    buffers: &'a [Vec<u8>],
    scene: Scene,
    warnings: Vec<String>,
    dropped_triangles: usize,
    /// Vertex normals that were zero or not finite, and the triangles shaded flat for them.
    bad_normals: usize,
    flat_triangles: usize,
    /// Texture coordinates that were not finite (set to (0, 0)).
    bad_uvs: usize,
    skipped_primitives: usize,
    /// `COLOR_0` values that were not finite.
    bad_colors: usize,
    /// How often the scene places each mesh (nodes × `EXT_mesh_gpu_instancing` instances).
    mesh_uses: Vec<u64>,
    flatten_instances: bool,
    /// Each mesh's prototype in the scene, once made.
    prototype_of_mesh: Vec<Option<u32>>,
    instances: Vec<Instance>,
    /// Placements of instanced meshes flattened for a singular transform.
    singular_placements: usize,
}

impl Loader<'_> {
    /// The scene the loader made, with the load's warnings in order: the extensions ignored
    /// (`extension_warnings`), instancing, the animation (`pose_warnings`), skins and morph
    /// targets, the loader's own, and the repairs counted; unused vertices dropped.
    fn finish(self, extension_warnings: Vec<String>, pose_warnings: Vec<String>) -> Scene {
        let mut scene = self.scene;
        scene.instances = Arc::new(self.instances);
        let mut warnings = extension_warnings;
        if self.singular_placements > 0 {
            warnings.push(format!(
                "{} placement(s) of instanced meshes have a singular transform (a scale of 0): drawn as flattened copies",
                self.singular_placements
            ));
        }
        warnings.extend(pose_warnings);
        if self.skinned > 0 {
            warnings.push(format!(
                "{} skinned mesh instance(s) rendered in their bind pose: strata does not apply skins",
                self.skinned
            ));
        }
        if self.morphed > 0 {
            warnings.push(format!(
                "{} primitive(s) with morph targets rendered in their base shape: strata does not apply morph targets",
                self.morphed
            ));
        }
        warnings.extend(self.warnings);
        if self.bad_colors > 0 {
            warnings.push(format!(
                "{} COLOR_0 vertex colour(s) not finite; replaced by white",
                self.bad_colors
            ));
        }
        if self.dropped_triangles > 0 {
            warnings.push(format!(
                "dropped {} degenerate triangle(s) (zero area or non-finite vertices)",
                self.dropped_triangles
            ));
        }
        if self.bad_normals > 0 {
            warnings.push(format!(
                "{} vertex normal(s) zero or not finite; the {} triangle(s) using them are shaded flat",
                self.bad_normals, self.flat_triangles
            ));
        }
        if self.bad_uvs > 0 {
            warnings.push(format!(
                "{} texture coordinate(s) not finite; set to (0, 0)",
                self.bad_uvs
            ));
        }
        if self.dropped_triangles > 0 || scene.positions.iter().any(|p| !p.is_finite()) {
            drop_unused_vertices(&mut scene);
        }
        // A valid file with nothing to hit is a valid scene: it renders the environment or
        // background alone.
        if scene.triangles.is_empty() {
            warnings.push(if self.skipped_primitives > 0 {
                format!(
                    "the scene has no triangles to render ({} primitive(s) of points or lines were skipped): only the environment or background is seen",
                    self.skipped_primitives
                )
            } else {
                "the scene has no triangles to render: only the environment or background is seen"
                    .into()
            });
        }
        scene.load_warnings = warnings;
        scene
    }

    fn texture_ref(&mut self, info: &gltf::texture::Info, what: &str) -> TextureRef {
        let texture = info.texture();
        let sampler = texture.sampler();
        let (transform, tex_coord) = extensions::texture_transform::read(info);
        let tex_coord = tex_coord.unwrap_or(info.tex_coord());
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
        let emissive =
            Vec3::from_array(m.emissive_factor()) * extensions::emissive_strength::read(m);
        if !base_color.is_finite() || !emissive.is_finite() {
            return Err(format!("{label} has a non-finite colour factor"));
        }
        let base_color_texture = pbr
            .base_color_texture()
            .map(|info| self.texture_ref(&info, &format!("{label} base colour texture")));
        let metallic_roughness_texture = pbr
            .metallic_roughness_texture()
            .map(|info| self.texture_ref(&info, &format!("{label} metallic-roughness texture")));
        let emissive_texture = m
            .emissive_texture()
            .map(|info| self.texture_ref(&info, &format!("{label} emissive texture")));
        let plain_ref = |texture: gltf::Texture, tex_coord: u32| TextureRef {
            image: texture.source().index(),
            tex_coord,
            wrap_s: wrap(texture.sampler().wrap_s()),
            wrap_t: wrap(texture.sampler().wrap_t()),
            transform: [Vec2::X, Vec2::Y, Vec2::ZERO],
        };
        let normal = m.normal_texture();
        let normal_scale = normal.as_ref().map_or(1.0, |n| n.scale());
        let normal_texture = normal.map(|n| plain_ref(n.texture(), n.tex_coord()));
        let occlusion_texture = m
            .occlusion_texture()
            .map(|o| plain_ref(o.texture(), o.tex_coord()));
        // The material extensions, each read by its own file (scene::extensions), in this
        // order (their warnings and errors come in it).
        let ior = extensions::ior::read(m, self, &label);
        let transmission = extensions::transmission::read(m, self, &label)?;
        let layers = Layers::read(m, self, &label)?;
        let glass = transmission.factor > 0.0;
        if glass && layers.iridescence.is_some() {
            self.warnings.push(format!(
                "{label}: its glass (KHR_materials_transmission) renders without its thin film (KHR_materials_iridescence), which only the opaque part shows"
            ));
        }
        let refracts = glass && transmission.volume.is_some();
        let dispersion = extensions::dispersion::read(m, self, &label, refracts)?;
        if glass && layers.anisotropy.is_some() {
            self.warnings.push(format!(
                "{label}: its glass (KHR_materials_transmission) renders isotropic; its anisotropy (KHR_materials_anisotropy) stretches only the opaque part's reflection"
            ));
        }
        if glass && (layers.clearcoat.is_some() || layers.sheen.is_some()) {
            self.warnings.push(format!(
                "{label}: its glass (KHR_materials_transmission) renders without its clear coat and sheen, which only the opaque part shows"
            ));
        }
        let alpha_mode = match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask(m.alpha_cutoff().unwrap_or(0.5)),
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        };
        let material = Material {
            name: m.name().map(str::to_string),
            base_color,
            base_color_texture,
            emissive,
            emissive_texture,
            metallic: pbr.metallic_factor(),
            roughness: pbr.roughness_factor(),
            ior,
            transmission,
            dispersion,
            layers,
            metallic_roughness_texture,
            normal_texture,
            normal_scale,
            occlusion_texture,
            alpha_mode,
            ignored_extensions: m
                .extensions()
                .into_iter()
                .flat_map(|map| map.keys())
                .filter(|k| !extensions::RENDERED.contains(&k.as_str()))
                .cloned()
                .collect(),
            double_sided: m.double_sided(),
        };
        Ok(material)
    }

    /// Where image `i`'s bytes are, or why they cannot be had (an error that does not name
    /// the image: the caller's label does). Read from the JSON rather than through
    /// `gltf::Image::source`, which panics on an image with neither `uri` nor `bufferView`, or
    /// with a `bufferView` but no `mimeType` (found by fuzzing). A missing `mimeType` is
    /// tolerated: the decoder recognises PNG and JPEG by their bytes.
    fn image(&self, doc: &gltf::Document, i: usize, base_dir: &Path) -> Result<ImageSource> {
        let json = &doc.as_json().images[i];
        let mime = json.mime_type.as_ref().map(|m| m.0.clone());
        if let Some(v) = &json.buffer_view {
            let view = doc
                .views()
                .nth(v.value())
                .ok_or_else(|| format!("its bufferView {} does not exist", v.value()))?;
            let bytes = view_bytes(self.buffers, &view)?;
            return Ok(ImageSource::Bytes {
                data: Arc::from(bytes),
                mime,
            });
        }
        let Some(uri) = json.uri.as_deref() else {
            return Err("it has neither a uri nor a bufferView".into());
        };
        if uri.starts_with("data:") {
            let data = read_uri(uri, base_dir)?;
            return Ok(ImageSource::Bytes {
                data: Arc::from(data),
                mime,
            });
        }
        let file = resolve_uri(uri, base_dir)?;
        if !file.exists() {
            return Err(format!("the file '{}' does not exist", file.display()));
        }
        if !file.is_file() {
            return Err(format!("'{}' is not a regular file", file.display()));
        }
        Ok(ImageSource::File(file))
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
        // An animated node's transform is the pose's; the others keep their own matrix.
        let local = match self.pose.animates(index) {
            true => self.pose.local(node),
            false => Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4(),
        };
        if !local.is_finite() {
            return Err(format!("node {index} has a non-finite transform"));
        }
        let world = parent * local;
        if !world.is_finite() {
            return Err(format!(
                "node {index}: its transform composed with its ancestors' is not finite"
            ));
        }

        if let Some(mesh) = node.mesh() {
            self.skinned += node.skin().is_some() as usize;
            // EXT_mesh_gpu_instancing: the mesh once per instance, each placed by the
            // instance's transform under the node's.
            let placements = match instance_transforms(self.document, node, self.buffers)? {
                Some(instances) => instances.iter().map(|m| world * *m).collect(),
                None => vec![world],
            };
            let instanced = instanced_mesh(self.mesh_uses[mesh.index()], self.flatten_instances);
            for (k, placed) in placements.iter().enumerate() {
                if !placed.is_finite() {
                    return Err(format!(
                        "node {index}: instance {k}'s transform is not finite"
                    ));
                }
                if instanced {
                    // Stored once in its own space, placed here by an instance; a placement
                    // that cannot be inverted (a zero scale) is flattened instead.
                    let to_world = Affine3A::from_mat4(placed.as_mat4());
                    let det = to_world.matrix3.determinant();
                    if det.is_normal() && to_world.inverse().is_finite() {
                        let prototype = self.prototype(&mesh, index)?;
                        let instance = Instance::new(prototype, to_world, Some(index as u32));
                        self.instances.push(instance);
                        continue;
                    }
                    self.singular_placements += 1;
                }
                for primitive in mesh.primitives() {
                    if k == 0 {
                        self.morphed += (primitive.morph_targets().len() > 0) as usize;
                    }
                    // The primitive's triangles are appended from here on (ID passes).
                    let first = u32::try_from(self.scene.triangles.len()).unwrap_or(u32::MAX);
                    (self.scene.origins).start(first, index as u32, mesh.index() as u32);
                    let label = format!("mesh {} primitive {}", mesh.index(), primitive.index());
                    self.primitive(&primitive, placed, &label)?;
                }
            }
        }
        if let Some(camera) = node.camera() {
            let camera = super::camera::from_gltf(&camera, &world)?;
            self.scene.cameras.push(camera);
        }
        if let Some(light) = node.light() {
            let light = super::light_from_gltf(&light, &world)?;
            self.scene.lights.push(light);
        }
        path.push(index);
        for child in node.children() {
            self.visit(&child, world, path)?;
        }
        path.pop();
        Ok(())
    }

    /// Mesh `mesh`'s prototype, its primitives loaded in its own space the first time a node
    /// (`node`, which ID passes name for the prototype's triangles until an instance names its
    /// own) places it.
    fn prototype(&mut self, mesh: &gltf::Mesh, node: usize) -> Result<u32> {
        if let Some(p) = self.prototype_of_mesh[mesh.index()] {
            return Ok(p);
        }
        let first = self.scene.triangles.len();
        for primitive in mesh.primitives() {
            self.morphed += (primitive.morph_targets().len() > 0) as usize;
            let at = u32::try_from(self.scene.triangles.len()).unwrap_or(u32::MAX);
            (self.scene.origins).start(at, node as u32, mesh.index() as u32);
            let label = format!("mesh {} primitive {}", mesh.index(), primitive.index());
            self.primitive(&primitive, &DMat4::IDENTITY, &label)?;
        }
        let end = self.scene.triangles.len();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for t in &self.scene.triangles[first..end] {
            for &v in t {
                let p = self.scene.positions[v as usize];
                (lo, hi) = (lo.min(p), hi.max(p));
            }
        }
        if first == end {
            (lo, hi) = (Vec3::ZERO, Vec3::ZERO);
        }
        let index = self.scene.prototypes.len() as u32;
        self.scene.prototypes.push(Prototype {
            triangles: first as u32..end as u32,
            bounds: (lo, hi),
            mesh: Some(mesh.index() as u32),
        });
        self.prototype_of_mesh[mesh.index()] = Some(index);
        Ok(index)
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
        let Some(accessors) = self.primitive_accessors(primitive, label)? else {
            return Ok(());
        };
        let data = self.read_primitive(primitive, &accessors, label)?;
        // Transform to world space: points by the matrix, normals by its inverse transpose.
        let linear = DMat3::from_mat4(*world);
        let flip = linear.determinant() < 0.0;
        let base = self.add_vertices(&data, world, &linear, label)?;
        let first_triangle = self.scene.triangles.len();
        let corners = self.add_triangles(&data, mode, base, flip, label)?;
        let file_tangents = data.tangents.as_deref().map(|t| (base, t));
        super::tangents::add_frames(
            &mut self.scene,
            first_triangle,
            &corners,
            file_tangents,
            &linear,
            flip,
        );
        Ok(())
    }

    /// A triangle primitive's accessors, each checked against its buffer and the formats glTF
    /// allows it, and against POSITION's count; None (with a warning) without POSITION.
    fn primitive_accessors<'p>(
        &mut self,
        primitive: &gltf::Primitive<'p>,
        label: &str,
    ) -> Result<Option<PrimitiveAccessors<'p>>> {
        let Some(pos_acc) = primitive.get(&gltf::Semantic::Positions) else {
            self.warnings
                .push(format!("{label}: no POSITION attribute, skipped"));
            self.skipped_primitives += 1;
            return Ok(None);
        };
        // KHR_mesh_quantization: positions, normals, tangents and texture coordinates may be
        // (normalized) integers; the node transforms carry any dequantization.
        expect_format(&pos_acc, Dimensions::Vec3, QUANTIZED, label, "POSITION")?;
        check_accessor(self.buffers, &pos_acc).map_err(|e| format!("{label} POSITION: {e}"))?;
        // Before reading: a sparse accessor without a bufferView is bounded by no buffer.
        let before = self.scene.positions.len() as u64;
        if before.saturating_add(pos_acc.count() as u64) > u32::MAX as u64 {
            return Err(format!(
                "{label}: POSITION accessor {} has {} vertices, which with the {before} before it is more than strata's 32-bit vertex indices allow ({})",
                pos_acc.index(),
                pos_acc.count(),
                u32::MAX
            ));
        }
        let normal_acc = primitive.get(&gltf::Semantic::Normals);
        if let Some(acc) = &normal_acc {
            expect_format(acc, Dimensions::Vec3, QUANTIZED_UNIT, label, "NORMAL")?;
            check_accessor(self.buffers, acc).map_err(|e| format!("{label} NORMAL: {e}"))?;
        }
        let uv_acc = primitive.get(&gltf::Semantic::TexCoords(0));
        if let Some(acc) = &uv_acc {
            expect_format(acc, Dimensions::Vec2, QUANTIZED, label, "TEXCOORD_0")?;
            check_accessor(self.buffers, acc).map_err(|e| format!("{label} TEXCOORD_0: {e}"))?;
        }
        let tangent_acc = primitive.get(&gltf::Semantic::Tangents);
        if let Some(acc) = &tangent_acc {
            expect_format(acc, Dimensions::Vec4, QUANTIZED_UNIT, label, "TANGENT")?;
            check_accessor(self.buffers, acc).map_err(|e| format!("{label} TANGENT: {e}"))?;
        }
        let color_acc = primitive.get(&gltf::Semantic::Colors(0));
        if let Some(acc) = &color_acc {
            // glTF 2.0 §3.7.2.1: VEC3 or VEC4 of float, or normalized unsigned byte or short.
            if !matches!(acc.dimensions(), Dimensions::Vec3 | Dimensions::Vec4) {
                return Err(format!(
                    "{label}: COLOR_0 accessor {} is {:?}; glTF allows VEC3 or VEC4",
                    acc.index(),
                    acc.dimensions()
                ));
            }
            expect_format(
                acc,
                acc.dimensions(),
                &[DataType::F32, DataType::U8, DataType::U16],
                label,
                "COLOR_0",
            )?;
            check_accessor(self.buffers, acc).map_err(|e| format!("{label} COLOR_0: {e}"))?;
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
        for (what, acc) in [
            ("NORMAL", &normal_acc),
            ("TEXCOORD_0", &uv_acc),
            ("COLOR_0", &color_acc),
            ("TANGENT", &tangent_acc),
        ] {
            if let Some(acc) = acc.as_ref().filter(|a| a.count() != pos_acc.count()) {
                return Err(format!(
                    "{label}: the {what} accessor has {} elements, the POSITION accessor {}",
                    acc.count(),
                    pos_acc.count()
                ));
            }
        }

        Ok(Some(PrimitiveAccessors {
            position: pos_acc,
            normal: normal_acc,
            uv: uv_acc,
            tangent: tangent_acc,
            color: color_acc,
        }))
    }

    /// A primitive's attributes and indices read (tangents only where its material reads
    /// them), in the file's space.
    fn read_primitive(
        &mut self,
        primitive: &gltf::Primitive,
        accessors: &PrimitiveAccessors,
        label: &str,
    ) -> Result<PrimitiveData> {
        let PrimitiveAccessors {
            position: pos_acc,
            normal: normal_acc,
            uv: uv_acc,
            tangent: tangent_acc,
            color: color_acc,
        } = accessors;
        let buffers = self.buffers;
        let reader = primitive.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let unreadable =
            |what: &str| format!("{label}: the {what} accessor cannot be read from its buffer");
        let positions: Vec<[f32; 3]> =
            read_floats(pos_acc, buffers).ok_or_else(|| unreadable("POSITION"))?;
        let n = positions.len();
        let normals: Option<Vec<[f32; 3]>> = match &normal_acc {
            Some(acc) => Some(read_floats(acc, buffers).ok_or_else(|| unreadable("NORMAL"))?),
            None => None,
        };
        let uvs: Option<Vec<[f32; 2]>> = match &uv_acc {
            Some(acc) => Some(read_floats(acc, buffers).ok_or_else(|| unreadable("TEXCOORD_0"))?),
            None => None,
        };
        let colors: Option<Vec<[f32; 4]>> = match color_acc {
            Some(_) => Some(
                reader
                    .read_colors(0)
                    .ok_or_else(|| unreadable("COLOR_0"))?
                    .into_rgba_f32()
                    .collect(),
            ),
            None => None,
        };
        let material = primitive.material().index().map_or(0, |i| i as u32 + 1);
        // Tangents matter only to normal maps and anisotropy.
        let normal_mapped = self.scene.materials[material as usize].needs_tangents();
        let tangents: Option<Vec<[f32; 4]>> = match &tangent_acc {
            Some(acc) if normal_mapped => {
                Some(read_floats(acc, buffers).ok_or_else(|| unreadable("TANGENT"))?)
            }
            _ => None,
        };
        if normal_mapped && tangents.is_none() && uvs.is_none() {
            // MikkTSpace makes tangents from texture coordinates: without either, the frames
            // are degenerate and shading falls back to the vertex normal, isotropic.
            self.warnings.push(format!(
                "{label}: its material needs tangents (normal map or anisotropy) but it has neither TANGENT nor TEXCOORD_0; it renders without its normal map and anisotropy"
            ));
        }
        if normals.as_ref().is_some_and(|v| v.len() != n)
            || uvs.as_ref().is_some_and(|v| v.len() != n)
            || colors.as_ref().is_some_and(|v| v.len() != n)
            || tangents.as_ref().is_some_and(|v| v.len() != n)
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
        Ok(PrimitiveData {
            positions,
            normals,
            uvs,
            colors,
            tangents,
            indices,
            material,
            normal_mapped,
        })
    }

    /// Adds a primitive's vertices to the scene in world space (`world`, whose linear part is
    /// `linear`), repairing what is not finite; returns the first one's index.
    fn add_vertices(
        &mut self,
        data: &PrimitiveData,
        world: &DMat4,
        linear: &DMat3,
        label: &str,
    ) -> Result<usize> {
        let PrimitiveData {
            positions,
            normals,
            uvs,
            colors,
            ..
        } = data;
        let n = positions.len();
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
            Some(ts) => {
                let mut bad = 0;
                self.scene.uvs.extend(ts.iter().map(|t| {
                    let t = Vec2::from_array(*t);
                    if t.is_finite() {
                        t
                    } else {
                        bad += 1;
                        Vec2::ZERO
                    }
                }));
                self.bad_uvs += bad;
            }
            None => self.scene.uvs.extend(std::iter::repeat_n(Vec2::ZERO, n)),
        }
        // Vertex colours stay an empty list until a primitive brings them; from then on
        // every vertex has one (white where its primitive has none).
        if colors.is_some() && self.scene.colors.is_empty() {
            self.scene.colors = vec![Vec4::ONE; base];
        }
        match &colors {
            Some(cs) => {
                let mut bad = 0;
                self.scene.colors.extend(cs.iter().map(|c| {
                    let c = Vec4::from_array(*c);
                    if c.is_finite() {
                        c
                    } else {
                        bad += 1;
                        Vec4::ONE
                    }
                }));
                self.bad_colors += bad;
            }
            None if !self.scene.colors.is_empty() => {
                self.scene.colors.extend(std::iter::repeat_n(Vec4::ONE, n))
            }
            None => {}
        }
        Ok(base)
    }

    /// Adds a primitive's triangles (of `mode`, its vertices from `base` on; `flip`: turned
    /// to keep their front under a mirroring transform), dropping degenerate ones and shading
    /// flat those with a bad normal; returns the kept triangles' vertices as the file numbers
    /// them, where the material reads tangent frames.
    fn add_triangles(
        &mut self,
        data: &PrimitiveData,
        mode: Mode,
        base: usize,
        flip: bool,
        label: &str,
    ) -> Result<Vec<[u32; 3]>> {
        let triangles = assemble_triangles(mode, &data.indices);
        if mode == Mode::Triangles && !data.indices.len().is_multiple_of(3) {
            self.warnings.push(format!(
                "{label}: {} indices is not a multiple of 3; the last {} ignored",
                data.indices.len(),
                data.indices.len() % 3
            ));
        }
        let (normals, material, normal_mapped) = (&data.normals, data.material, data.normal_mapped);
        // The vertices of each triangle kept, as the file numbers them (before flat-shaded
        // triangles get copies), for its tangent frame.
        let mut corners: Vec<[u32; 3]> = Vec::new();
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
            if normal_mapped {
                corners.push(if flip { [a, c, b] } else { [a, b, c] });
            }
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
                    if !self.scene.colors.is_empty() {
                        let c = self.scene.colors[i as usize];
                        self.scene.colors.push(c);
                    }
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
        Ok(corners)
    }
}

/// The loader's side of reading a material extension.
impl extensions::Reader for Loader<'_> {
    fn texture_info(&mut self, info: &gltf::texture::Info, what: &str) -> TextureRef {
        self.texture_ref(info, what)
    }

    /// The texture an extension's JSON binds under `key` (a textureInfo: `index`,
    /// `texCoord`, `KHR_texture_transform`), read as the core material's are.
    fn texture(
        &mut self,
        ext: &gltf::json::Value,
        key: &str,
        what: &str,
    ) -> Result<Option<TextureRef>> {
        let Some(info) = ext.get(key) else {
            return Ok(None);
        };
        let index = (info.get("index").and_then(|i| i.as_u64()))
            .ok_or_else(|| format!("{what}: {key} has no texture index"))?;
        let texture = (self.document.textures().nth(index as usize))
            .ok_or_else(|| format!("{what}: {key} names texture {index}, which does not exist"))?;
        let sampler = texture.sampler();
        let (transform, tex_coord_override) = extensions::texture_transform::read_json(info);
        let tex_coord = tex_coord_override
            .unwrap_or(info.get("texCoord").and_then(|t| t.as_u64()).unwrap_or(0) as u32);
        if tex_coord != 0 {
            self.warnings.push(format!(
                "{what} {key} uses TEXCOORD_{tex_coord}; strata reads TEXCOORD_0 only"
            ));
        }
        Ok(Some(TextureRef {
            image: texture.source().index(),
            tex_coord,
            wrap_s: wrap(sampler.wrap_s()),
            wrap_t: wrap(sampler.wrap_t()),
            transform,
        }))
    }

    fn warn(&mut self, message: String) {
        self.warnings.push(message);
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
        if !scene.colors.is_empty() {
            scene.colors[kept] = scene.colors[old];
        }
        kept += 1;
    }
    scene.positions.truncate(kept);
    scene.normals.truncate(kept);
    scene.uvs.truncate(kept);
    if !scene.colors.is_empty() {
        scene.colors.truncate(kept);
    }
    for t in &mut scene.triangles {
        *t = t.map(|i| new_index[i as usize]);
    }
}
