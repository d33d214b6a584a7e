//! glTF extensions: the material extensions, one file each, and which extensions strata
//! honours in a file ([`SUPPORTED`]) or ignores with a warning ([`ignored_effect`]).
//!
//! Each file opens with the extension's parameter table (its glTF properties, defaults and
//! ranges) and holds the whole of what strata does with it but the physics of its lobe:
//! reading it from a material's JSON (through [`Reader`], the loader's side), the validated
//! parameters the [`super::Material`] keeps, and, for those with textures, the parameters
//! at a surface point. The parameters are generic over how a texture is bound (`T`): a
//! [`TextureRef`] as the file names it, or the renderer's decoded image once prepared, so
//! that one type serves both.
//!
//! | file                   | extension                                   | gives the BSDF      |
//! |------------------------|---------------------------------------------|---------------------|
//! | [`emissive_strength`]  | `KHR_materials_emissive_strength`           | emission scale      |
//! | [`ior`]                | `KHR_materials_ior`                         | the dielectric's f0 |
//! | [`transmission`]       | `KHR_materials_transmission`, `_volume`     | glass, its medium   |
//! | [`dispersion`]         | `KHR_materials_dispersion`                  | the glass's Abbe no.|
//! | [`specular`]           | `KHR_materials_specular`                    | f0's weight, colour |
//! | [`clearcoat`]          | `KHR_materials_clearcoat`                   | a coat lobe         |
//! | [`sheen`]              | `KHR_materials_sheen`                       | a sheen lobe        |
//! | [`anisotropy`]         | `KHR_materials_anisotropy`                  | stretched GGX       |
//! | [`iridescence`]        | `KHR_materials_iridescence`                 | thin-film Fresnel   |
//! | [`texture_transform`]  | `KHR_texture_transform`                     | every texture's uv  |
//!
//! Adding one: docs/adding-a-material-extension.md.

pub mod dispersion;
pub mod emissive_strength;
pub mod ior;
pub mod texture_transform;
pub mod transmission;

pub use super::Encoding;
use super::TextureRef;

pub use anisotropy::AnisotropyLayer;
pub use clearcoat::ClearcoatLayer;
pub use iridescence::IridescenceLayer;
pub use sheen::SheenLayer;
pub use specular::SpecularLayer;
pub use transmission::Volume;

/// Extensions strata honours when a file lists them in `extensionsRequired`.
pub const SUPPORTED: &[&str] = &[
    "EXT_mesh_gpu_instancing",
    "EXT_meshopt_compression",
    "EXT_texture_webp",
    "KHR_draco_mesh_compression",
    "KHR_lights_punctual",
    "KHR_meshopt_compression",
    "KHR_mesh_quantization",
    "KHR_materials_anisotropy",
    "KHR_materials_clearcoat",
    "KHR_materials_dispersion",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_iridescence",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_texture_basisu",
    "KHR_texture_transform",
];

/// What strata renders instead of what an extension it ignores asks for, for the warning
/// about a file that uses it.
pub fn ignored_effect(ext: &str) -> &'static str {
    match ext {
        "KHR_materials_unlit" => "unlit materials are shaded as lit ones",
        "KHR_materials_variants" => "each mesh renders its default material",
        "EXT_texture_avif" => {
            "textures in that format are not decoded; their fallback images, if any, are used"
        }
        "EXT_mesh_gpu_instancing" => "each instanced mesh renders once, at its node",
        "KHR_materials_pbrSpecularGlossiness" => {
            "materials render from their core metallic-roughness values"
        }
        "KHR_animation_pointer" | "KHR_xmp_json_ld" | "KHR_xmp" => "nothing it changes is rendered",
        _ => "strata renders the file as if it were absent",
    }
}

/// A loader's error message.
pub type Result<T> = std::result::Result<T, String>;

/// What reading an extension asks of the loader: its textures, resolved as the core
/// material's are (the texture's image and sampler, `texCoord`, [`texture_transform`]), and
/// a place for warnings.
pub trait Reader {
    /// The texture a textureInfo of the glTF crate binds.
    fn texture_info(&mut self, info: &gltf::texture::Info, what: &str) -> TextureRef;
    /// The texture the extension's JSON `ext` binds under `key` (a textureInfo), None where
    /// it binds none; an error naming `what` where the binding is broken.
    fn texture(
        &mut self,
        ext: &gltf::json::Value,
        key: &str,
        what: &str,
    ) -> Result<Option<TextureRef>>;
    fn warn(&mut self, message: String);
}

/// Declares the layers over the metallic-roughness BRDF: each `field: module::Type` line is
/// one extension's file and its parameters (generic over the texture binding, with the
/// functions `module::read` and the methods `bind`, `textured` and `needs_tangents`). The
/// list is the one place a layer is registered: it makes the [`Layers`] struct, reads the
/// layers in its order, binds their textures, and names the extensions in [`RENDERED`].
macro_rules! layers {
    ($($field:ident: $module:ident::$layer:ident),* $(,)?) => {
        $(pub mod $module;)*

        /// The layers over the metallic-roughness BRDF, each None where the material has
        /// none: what [`super::Material`] keeps of them, and the renderer once their
        /// textures are bound. Code that applies the layers destructures this struct whole,
        /// so that a layer added to the list and forgotten there does not compile.
        #[derive(Clone, Debug, PartialEq)]
        pub struct Layers<T = TextureRef> {
            $(pub $field: Option<$module::$layer<T>>,)*
        }

        impl<T> Default for Layers<T> {
            fn default() -> Self {
                Layers { $($field: None,)* }
            }
        }

        impl Layers {
            /// Reads every layer of glTF material `m` (`label` names it in messages), in the
            /// list's order.
            pub fn read(m: &gltf::Material, r: &mut dyn Reader, label: &str) -> Result<Layers> {
                Ok(Layers { $($field: $module::read(m, r, label)?,)* })
            }
        }

        impl<T> Layers<T> {
            /// True where the material has no layer: the plain metallic-roughness BRDF.
            pub fn is_empty(&self) -> bool {
                true $(&& self.$field.is_none())*
            }

            /// The layers with each texture bound by `bind` (given the texture and how its
            /// image is encoded; None where the image cannot be had, which leaves the layer
            /// without that texture: [`bind_texture`]), in the list's order.
            pub fn bind<U, E>(
                &self,
                bind: &mut impl FnMut(&T, Encoding) -> std::result::Result<Option<U>, E>,
            ) -> std::result::Result<Layers<U>, E> {
                Ok(Layers {
                    $($field: self.$field.as_ref().map(|l| l.bind(bind)).transpose()?,)*
                })
            }

            /// True when some layer reads a texture.
            pub fn textured(&self) -> bool {
                false $(|| self.$field.as_ref().is_some_and(|l| l.textured()))*
            }

            /// True when some layer reads the surface's tangent frame.
            pub fn needs_tangents(&self) -> bool {
                false $(|| self.$field.as_ref().is_some_and(|l| l.needs_tangents()))*
            }
        }

        /// The material extensions strata renders (a material's other `KHR_materials_*` are
        /// named in a warning).
        pub const RENDERED: &[&str] = &[
            $($module::NAME,)*
            dispersion::NAME,
            emissive_strength::NAME,
            ior::NAME,
            transmission::NAME,
            transmission::VOLUME,
        ];
    };
}

layers! {
    specular: specular::SpecularLayer,
    clearcoat: clearcoat::ClearcoatLayer,
    sheen: sheen::SheenLayer,
    anisotropy: anisotropy::AnisotropyLayer,
    iridescence: iridescence::IridescenceLayer,
}

/// Binds an optional texture (`bind` as [`Layers::bind`] takes it). `bind` answers None for
/// a texture whose image cannot be had: the binding is then no texture at all, so the layer
/// renders with its factors alone. Every texture of every layer is bound here, and a layer's
/// `bind` that mapped a texture otherwise would not type-check (it would hold an
/// `Option<Option<U>>`), so none can keep a texture whose image is absent.
pub(crate) fn bind_texture<T, U, E>(
    texture: &Option<T>,
    encoding: Encoding,
    bind: &mut impl FnMut(&T, Encoding) -> std::result::Result<Option<U>, E>,
) -> std::result::Result<Option<U>, E> {
    Ok(texture
        .as_ref()
        .map(|t| bind(t, encoding))
        .transpose()?
        .flatten())
}

/// The number under `key` of an extension's JSON, `default` where it is absent; an error
/// naming `what` where it is not a number between 0 and 1.
pub(crate) fn unit_number(
    ext: &gltf::json::Value,
    key: &str,
    default: f32,
    what: &str,
) -> Result<f32> {
    match ext.get(key) {
        None => Ok(default),
        Some(v) => match v.as_f64() {
            Some(x) if (0.0..=1.0).contains(&x) => Ok(x as f32),
            _ => Err(format!("{what}: {key} {v} is not a number between 0 and 1")),
        },
    }
}

/// The number at `key` of an extension's JSON, `default` where absent; an error naming `what`
/// where it is not a finite number of at least `least`.
pub(crate) fn number_at_least(
    ext: &gltf::json::Value,
    key: &str,
    default: f32,
    least: f64,
    what: &str,
) -> Result<f32> {
    match ext.get(key) {
        None => Ok(default),
        Some(v) => (v.as_f64())
            .filter(|x| x.is_finite() && *x >= least)
            .map(|x| x as f32)
            .ok_or_else(|| format!("{what}: {key} {v} is not a number of at least {least}")),
    }
}
