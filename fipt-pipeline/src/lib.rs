//! The stages of a fipt run composed through fipt-core's traits: stage order, caching by
//! inputs and settings, resume, sharding by views, the output contract (maps, emitters,
//! re-renders, `report.json`) and the registry of components ([`Components`]) that a run
//! chooses by name from its tagged config.
//!
//! It sees components only through the traits (`ShadingBaker`, `ShadingRefiner`,
//! `EmitterExtractor`, `FieldTrainer`, `MaterialFitter`, `MaterialField`); it prints nothing (what it has to
//! say goes to the [`observe::Observer`] the program installs). The `fipt` binary (fipt-cli)
//! parses arguments into a [`run::RunRequest`], calls [`run::run`] and prints the
//! [`run::RunSummary`]. The host knows no method: `Components::builtin()` holds the default
//! baker, refiner, trainer and extractor, and a method registers itself as a plug-in does
//! (FIPT's `fipt_method::register`, IPT's `fipt_ipt::register`; the `fipt` binary's
//! `fipt_cli::components()` has both). A program of one's own does the same as the binary
//! (see `fipt_method`'s example).
pub mod bake;
pub mod check;
use fipt_capture::capture;
pub mod components;
pub use fipt_run::config;
#[cfg(test)]
mod config_tests;
pub use fipt_run::error;
pub mod fit;
pub mod light_ends;
pub mod maps;
pub mod memory;
pub mod seen;
pub mod segments;
pub mod trained;
pub use fipt_run::names;
pub use fipt_run::observe;
pub mod outputs;
pub mod parent;
pub mod recovered;
pub mod render;
pub mod report;
pub mod request;
pub mod run;
pub mod run_config;
use fipt_capture::scene;
pub mod shard;

pub use components::Components;
pub use fipt_run::{bail, err, note};
pub use fipt_run::{describe, Context, Result, RunError};
