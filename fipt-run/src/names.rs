//! The names of the built-in components, as `[pipeline]` chooses them, and the kinds of
//! components (a leaf module: the run config's defaults, the stages and the registry read it).

/// The built-in shading baker's name.
pub const SLF_BAKER: &str = "slf";

/// The built-in shading refiner's name.
pub const PATH_GROWN_REFINER: &str = "path-grown";

/// The built-in emitter extractor's name.
pub const MASK_EXTRACTOR: &str = "mask";

/// FIPT's method's name (`fipt_method::Fipt`, registered by `fipt_method::register`;
/// `Components::builtin()` has no method), the default `[pipeline] method`.
pub const FIPT_METHOD: &str = "fipt";

/// The built-in field trainer's name (`fipt_neural::HashGridTrainer`).
pub const HASH_GRID_TRAINER: &str = "hash-grid";

/// The kinds of components the registry holds (`crate::Components`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    Method,
    Baker,
    Refiner,
    Trainer,
    Extractor,
}
