//! The named presets every stage's settings come in (`paper`, `reference`, `balanced`, `fast`),
//! and their lookup by name, written once: a stage's config implements the constructors. The
//! pipeline's messages list them (`fipt_pipeline::config::PRESETS`).

/// Settings with the named presets.
pub trait Presets: Sized {
    /// The paper's sizes.
    fn paper() -> Self;
    /// The default trade.
    fn balanced() -> Self;
    /// The quickest.
    fn fast() -> Self;
    /// The reference implementation's own settings; `paper` unless the stage has its own.
    fn reference() -> Self {
        Self::paper()
    }
    /// The preset `name` (`default` is `balanced`); None for a name that is none of them.
    fn preset(name: &str) -> Option<Self> {
        match name {
            "paper" => Some(Self::paper()),
            "reference" => Some(Self::reference()),
            "balanced" | "default" => Some(Self::balanced()),
            "fast" => Some(Self::fast()),
            _ => None,
        }
    }
}

/// Whether `name` is a preset every stage knows (`paper`, `reference`, `balanced` or its alias
/// `default`, `fast`).
pub fn is_known(name: &str) -> bool {
    matches!(
        name,
        "paper" | "reference" | "balanced" | "default" | "fast"
    )
}
