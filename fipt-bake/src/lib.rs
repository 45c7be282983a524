//! # fipt-bake
//!
//! The shading stages of FIPT (method §3–4): what each training pixel's image is made of, as
//! factorised shadings ([`fipt_core::shading::ViewShadings`]: Ld, and Ls0, Ls1 at the roughness
//! levels), computed from the views themselves.
//! * [`slf`]: the surface light field, a voxel grid of the views' radiance on the surfaces;
//! * [`bake`]: the initial bake under the SLF, behind [`fipt_core::shading::ShadingBaker`]
//!   (`FactorizedBaker`, registered as `slf`);
//! * [`refine`]: the path-grown refinement under the extracted emitters and the fitted field,
//!   behind [`fipt_core::shading::ShadingRefiner`] (`PathGrownRefiner`, `path-grown`);
//! * [`diffuse`] and [`specular`]: the estimators of Ld (with its per-cell cache) and of Ls0,
//!   Ls1 (the specular mixture), for any reflectance model; [`stream`]: their sample streams;
//! * [`bake_store`]: shadings on disk, one file per view, read back view by view;
//! * [`limits`]: the settings' bounds.
//!
//! It owns the shading estimators and their storage. It uses meshes and emitter sampling from
//! `fipt-geom` and the renderer's pieces from `fipt-shading` (BRDFs, the incident-light
//! contract, primary hits, `SurfaceModel` and its emitter sampler, the field cached on a voxel
//! grid) and must never import the pipeline, the neural field, the search or a method:
//! it sees the field only as a [`fipt_core::field::MaterialField`].
pub mod bake;
pub mod bake_store;
pub mod diffuse;
pub mod fsh;
pub mod limits;
mod passes;
pub mod refine;
mod refine_config;
pub mod slf;
pub mod specular;
pub mod stream;
