//! The stages of a fipt run composed through fipt-core's traits: stage order, caching by
//! inputs and settings, resume, sharding by views, the output contract (maps, emitters,
//! re-renders, `report.json`) and the registry of components ([`Components`]) that a run
//! chooses by name from its tagged config.
//!
//! It sees components only through the traits (`ShadingBaker`, `ShadingRefiner`,
//! `EmitterExtractor`, `MaterialFitter`, `MaterialField`); it prints nothing (what it has to
//! say goes to the [`observe::Observer`] the program installs). The `fipt` binary (fipt-cli)
//! parses arguments into a [`run::RunRequest`], calls [`run::run`] and prints the
//! [`run::RunSummary`]; a program of one's own does the same:
//!
//! ```no_run
//! use fipt_pipeline::run::{run, RunOutcome, RunRequest};
//! let request = RunRequest::new("scenes/room", "out/room", "fast");
//! if let RunOutcome::Finished(s) = run(&request, &fipt_pipeline::Components::builtin())? {
//!     println!("{} lights in {:.0} s", s.lights, s.seconds);
//! }
//! # Ok::<(), anyhow::Error>(())
//! ```
pub mod bake;
pub mod components;
pub mod config;
pub mod eval;
mod eval_parts;
mod fit;
pub mod inspect;
pub mod memory;
pub mod observe;
pub mod outputs;
pub mod recovered;
pub mod refine;
pub mod regions;
pub mod render;
pub mod report;
pub mod rounds;
pub mod run;
pub mod scene;
pub mod search;
pub mod shard;
pub mod train;

pub use components::Components;

/// An error and its causes on one line, each cause said once (an I/O error's message is often
/// part of its context's already).
pub fn describe(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let s = cause.to_string();
        if out.contains(&s) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&s);
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn an_error_chain_says_each_cause_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file or directory");
        let e = anyhow::Error::new(fipt_core::CoreError::io(std::path::Path::new("/x/out"), io))
            .context("creating the output folder");
        assert_eq!(
            super::describe(&e),
            "creating the output folder: /x/out: No such file or directory"
        );
    }
}
