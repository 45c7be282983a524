//! What every part of a fipt run shares, below the crates that hold its stages (the capture
//! analysis, FIPT's method, the evaluation) and the host that orders them (`fipt-pipeline`):
//!
//! * [`error::RunError`]: the one error enum, with the context each failure happened in, and
//!   the `err!`/`bail!` macros;
//! * [`observe`]: notes, stage timings and progress, told to the process's observer (the
//!   library prints nothing);
//! * [`config`]: typed settings from TOML or JSON laid over a named preset;
//! * [`names`]: the built-in components' names and the kinds of components.
pub mod config;
pub mod error;
pub mod names;
pub mod observe;

pub use error::{describe, Context, Result, RunError};
