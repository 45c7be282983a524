//! # fipt-shading
//!
//! The renderer of fipt-rs: BRDFs, scenes, the path tracer, lights and edits.
//! * [`brdf`]: the metallic-workflow microfacet BRDF of each [`fipt_core::reflectance::ReflectanceModel`] and a Lambertian one, one per file, behind the
//!   [`fipt_core::brdf::Brdf`] contract (eval includes cos θi), dispatched per ray through the
//!   closed enum [`brdf::BrdfModel`];
//! * [`scene`]: a renderable scene (mesh, BVH, [`scene::SurfaceModel`], emitter sampling);
//! * [`render`]: the forward path tracer (NEE + MIS, Russian roulette, reproducible streams)
//!   and ground-truth AOVs;
//! * [`incident`]: the incident-light contract the shading estimators and the tracer share;
//! * [`records`]: the views' primary hits (what each training pixel sees);
//! * [`field_surfaces`]: a material field cached on a voxel grid of the observed surface, as a
//!   [`scene::SurfaceModel`] (re-renders, the refinement);
//! * [`lights`] and [`edit`]: lights added for relighting (`lights.json`: spheres, quads,
//!   meshes, point and spot lights) and edits of a scene's surfaces and emitters;
//! * [`denoise`]: the re-renders' denoiser.
//!
//! The bake and the refinement are in `fipt-bake`, the procedural scenes in `fipt-synth`. This
//! crate must never import those (outside its tests, which render `fipt-synth`'s scenes), the
//! pipeline, the neural field or the search.
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
pub mod brdf;
pub mod denoise;
pub mod edit;
pub mod error;
pub mod field_surfaces;
pub mod incident;
pub mod lights;
mod material_table;
pub mod records;
pub mod relight;
pub mod render;
pub mod scene;
pub mod scene_edits;

pub use error::{Result, ShadingError};
