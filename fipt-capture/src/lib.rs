//! A capture as the stages read it, and what the views say about it, usable without a run:
//!
//! * [`scene::load`]: the dataset, the mesh's BVH, the training images decoded and restored
//!   (exposures, a fitted response, clipped lights), the inputs' fingerprint and the cache key;
//! * [`capture`]: the checks behind it (pose convention, LDR and clipping, exposure gains, the
//!   camera's response, misregistered edges) and their report;
//! * [`contrast`]: the tone curve's contrast from the light transport, where 8-bit views carry no
//!   exposures (the views alone leave it open);
//! * [`light_scale`]: the radiance of lights that clip in every view, bounded by what they light;
//! * [`light_ends`]: the kd map at the ends of a light's range, where the views leave it open;
//! * [`inspect`]: `fipt info`'s summary of a scene folder;
//! * [`degrade`]: capture-like copies of a rendered scene (`fipt degrade`).
//!
//! Errors and notes are the run's own ([`fipt_run::RunError`], [`fipt_run::observe`]).
pub mod capture;
pub mod contrast;
pub mod degrade;
mod degrade_mesh;
pub mod inspect;
pub mod light_ends;
pub mod light_scale;
pub mod placement;
pub mod scene;

use fipt_run::{bail, err, error, note, observe};
