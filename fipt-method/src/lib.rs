//! FIPT (Factorized Inverse Path Tracing, method §4) as a method of a fipt run, registered by
//! name (`fipt`) as any method is ([`register`]): the bake through the run's baker, the
//! material search on its shadings, the first training through the run's trainer, the
//! emitters through the run's extractor, then the refine → search → train rounds the scene
//! needs through the run's refiner. It reads its scene only through
//! [`fipt_core::fit::FitInputs`] (its `scene` included) and its settings only through its
//! factory ([`FIPT_TABLES`] of the run config, typed into [`FiptSettings`]), so it runs under
//! any host that fills them.
//!
//! ```no_run
//! use fipt_pipeline::run::{run, RunOutcome, RunRequest};
//! let builtin = fipt_pipeline::Components::builtin();
//! let components = fipt_eval::register(fipt_method::register(builtin));
//! let request = RunRequest::new("scenes/room", "out/room", "fast");
//! if let RunOutcome::Finished(s) = run(&request, &components)? {
//!     println!("{} lights in {:.0} s", s.lights, s.seconds);
//! }
//! # Ok::<(), fipt_pipeline::RunError>(())
//! ```
pub(crate) mod draw;
pub mod memory;
pub mod method;
pub mod refine;
pub mod regions;
pub mod rounds;
pub mod search;
pub mod settings;
pub mod train;
pub(crate) mod train_set;

pub use method::Fipt;
pub use settings::FiptSettings;

use fipt_capture::scene;
use fipt_eval::eval;
use fipt_pipeline::components::Table;
use fipt_pipeline::names::{Kind, FIPT_METHOD};
use fipt_pipeline::{bake, fit, maps, outputs, run_config, segments, shard, trained};
use fipt_pipeline::{Components, RunError};
use fipt_run::{bail, config, err, error, names, note, observe};

/// FIPT's tables of the run config, handed to its factory as one object: its own `[search]`
/// and `[rounds]`, and what it reads of `[train]` (the training set's share, seed and targets,
/// the steps asked) and `[refine]` (`rough_threshold`) whichever trainer and refiner run.
pub const FIPT_TABLES: &[Table] = &[
    Table::of::<fipt_search::SearchConfig>("search"),
    Table::of::<settings::RoundsConfig>("rounds"),
    fipt_pipeline::components::TRAIN_TABLE,
    fipt_pipeline::components::REFINE_TABLE,
];

/// `components` with FIPT registered as method `fipt`, its settings [`FIPT_TABLES`].
pub fn register(components: Components) -> Components {
    components
        .with_fitter(
            FIPT_METHOD,
            "bake, search, train, emitters, refine rounds (settings: [search], [rounds], [train], [refine]; the baker, refiner, trainer and extractor read their own)",
            Box::new(|v, _preset| {
                let settings: FiptSettings = config::typed(v.clone())?;
                settings.validate()?;
                Ok(Box::new(Fipt::new(settings)))
            }),
        )
        .with_tables(Kind::Method, FIPT_METHOD, FIPT_TABLES)
}
