//! Shading: what happens where a ray meets a surface or leaves the scene. It sits below the
//! integrators and above the acceleration structures, the textures ([`crate::texture`]) and
//! the scene, and the integrators reach surfaces and light through it only.
//!
//! | module          | what it holds                                                        |
//! |-----------------|----------------------------------------------------------------------|
//! | [`interaction`] | the surface point a ray hits, and the one way secondary rays leave it |
//! | [`lobe`]        | [`LocalBsdf`], the interface every lobe implements; flags, samples    |
//! | [`bsdf`]        | [`Bsdf`]: the closed set of scattering models, in the shading frame   |
//! | [`dielectric`]  | dielectric interfaces (glass): refractive and thin-walled, rough or  |
//! |                 | smooth, with exact Fresnel                                           |
//! | [`fresnel`]     | Schlick's and the exact dielectric Fresnel reflectance, at any width  |
//! | [`gltf_brdf`]   | the glTF 2.0 metallic-roughness BRDF (Appendix B)                     |
//! | [`layers`]      | sheen and clear coat over it (`KHR_materials_sheen`, `_clearcoat`)    |
//! | [`material`]    | glTF materials prepared for rendering; the BSDF at a surface point    |
//! | [`microfacet`]  | the GGX distribution: D, masking, visible-normal sampling             |
//! | [`spectrum`]    | luminance; wavelengths for dispersion: responses, Cauchy's index      |
//! | [`thin_film`]   | thin-film interference: iridescent Fresnel (Belcour & Barla 2017)     |
//! | [`lights`]      | punctual lights, emissive triangles and the environment, as one set   |
//! |                 | sampled by power                                                      |
//! | [`environment`] | the radiance rays that leave the scene see, by direction              |
//! | [`envmap`]      | equirectangular HDR maps: lookup and importance sampling             |

pub mod bsdf;
pub mod dielectric;
pub mod environment;
pub mod envmap;
pub mod fresnel;
pub mod gltf_brdf;
pub mod interaction;
pub mod layers;
pub mod lights;
pub mod lobe;
pub mod material;
pub mod microfacet;
pub mod spectrum;
pub mod thin_film;

pub use bsdf::{Bsdf, BsdfFlags, BsdfSample, Lambertian, LocalBsdf, SurfaceBsdf};
pub use dielectric::{fresnel_dielectric, refract, Dielectric, ThinDielectric};
pub use environment::Environment;
pub use envmap::{EnvMap, MapSampling};
pub use gltf_brdf::GltfBrdf;
pub use interaction::SurfaceInteraction;
pub use layers::{Coat, Layered, Sheen};
pub use lights::{BackgroundSampling, LightSet, SceneEmitters, TriangleSampling};
pub use material::{DiffuseSampling, MaterialModel, MaterialOptions, Materials, Need, ShadeAs};
