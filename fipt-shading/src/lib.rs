//! # fipt-shading
//!
//! Light transport for fipt-rs:
//! * [`brdf`]: the metallic-workflow microfacet BRDF of each [`fipt_core::reflectance::ReflectanceModel`] and a Lambertian one, one per file, behind the
//!   [`fipt_core::brdf::Brdf`] contract (eval includes cos θi), dispatched per ray through the
//!   closed enum [`brdf::BrdfModel`];
//! * [`scene`]: a renderable scene (mesh, BVH, [`scene::SurfaceModel`], emitter sampling);
//! * [`render`]: the forward path tracer (NEE + MIS, Russian roulette, reproducible streams)
//!   and ground-truth AOVs;
//! * [`diffuse`]: the diffuse shading of either model and its per-cell cache;
//! * [`slf`] and [`bake`]: the surface light field and the initial factorised bake
//!   (Ld, Ls0, Ls1 per training pixel), behind [`fipt_core::shading::ShadingBaker`];
//! * [`refine`]: the path-grown refinement behind [`fipt_core::shading::ShadingRefiner`];
//! * [`lights`] and [`edit`]: lights added for relighting (`lights.json`: spheres, quads,
//!   meshes, point and spot lights) and edits of a scene's surfaces and emitters;
//!
//! ```
//! use fipt_core::brdf::Brdf;
//! use fipt_shading::brdf::MicrofacetBrdf;
//! use glam::Vec3;
//! let b = MicrofacetBrdf::new(Vec3::splat(0.5), Vec3::splat(0.04), 0.3);
//! let (wo, wi) = (Vec3::new(0.0, 0.6, 0.8), Vec3::new(0.0, -0.6, 0.8));
//! // eval includes cos θi, and the BRDF is reciprocal:
//! assert!((b.eval(wo, wi) / wi.z - b.eval(wi, wo) / wo.z).length() < 1e-5);
//! ```
pub mod bake;
pub mod bake_store;
pub mod brdf;
pub mod denoise;
pub mod diffuse;
pub mod edit;
pub mod error;
pub mod field_surfaces;
pub mod incident;
pub mod lights;
pub mod limits;
mod passes;
pub mod records;
pub mod refine;
pub mod relight;
pub mod render;
pub mod scene;
pub mod scene_edits;
pub mod slf;
pub mod specular;
pub mod stream;

pub use error::{Result, ShadingError};
