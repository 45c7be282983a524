//! The components `fipt run` composes, chosen by name in the run config: the built-in ones and
//! those a binary registers (a plug-in crate builds its own `fipt` with
//! `fipt_cli::main_with(Components::builtin().with_extractor(…))`; see
//! `examples/brightest-emitters`).
//!
//! | kind | chosen by | built in |
//! |---|---|---|
//! | emitter extractor (`fipt_core::emitter::EmitterExtractor`) | `[pipeline] extractor` | `mask`: the emission-mask extractor, settings `[emitters]` |
//! | reflectance model (closed set, `fipt_core::reflectance`) | `[model] brdf` | `principled`, `fipt` |
//!
//! A registered extractor's settings are the run config's `[plugins.<name>]` table, passed to
//! its factory as JSON (the factory validates them and names the bad key).
use anyhow::{bail, Result};
use fipt_core::emitter::EmitterExtractor;
use std::collections::BTreeMap;

/// Builds an extractor from its settings.
pub type ExtractorFactory =
    Box<dyn Fn(&serde_json::Value) -> Result<Box<dyn EmitterExtractor>> + Send + Sync>;

struct Entry {
    description: String,
    factory: ExtractorFactory,
}

/// The registry of named components.
pub struct Components {
    extractors: BTreeMap<String, Entry>,
}

/// The built-in emitter extractor's name.
pub const MASK_EXTRACTOR: &str = "mask";

impl Components {
    /// The components of the `fipt` binary.
    pub fn builtin() -> Self {
        Components {
            extractors: BTreeMap::new(),
        }
        .with_extractor(
            MASK_EXTRACTOR,
            "the trained emission mask averaged per triangle, radiance medians, connected lights (settings: [emitters])",
            Box::new(|v| {
                let config: fipt_emitter::MaskExtractorConfig = serde_json::from_value(v.clone())?;
                Ok(Box::new(fipt_emitter::MaskExtractor { config }))
            }),
        )
    }

    /// Registers (or replaces) the emitter extractor `name`.
    pub fn with_extractor(
        mut self,
        name: &str,
        description: &str,
        factory: ExtractorFactory,
    ) -> Self {
        self.extractors.insert(
            name.to_string(),
            Entry {
                description: description.to_string(),
                factory,
            },
        );
        self
    }

    /// The names of the registered extractors.
    pub fn extractor_names(&self) -> Vec<&str> {
        self.extractors.keys().map(|k| k.as_str()).collect()
    }

    /// One line per registered component, for help texts and reports.
    pub fn describe(&self) -> Vec<String> {
        self.extractors
            .iter()
            .map(|(k, e)| format!("extractor `{k}`: {}", e.description))
            .collect()
    }

    /// The extractor `name` built from `settings`; an unknown name lists the registered ones.
    pub fn extractor(
        &self,
        name: &str,
        settings: &serde_json::Value,
    ) -> Result<Box<dyn EmitterExtractor>> {
        let Some(e) = self.extractors.get(name) else {
            bail!(
                "[pipeline] extractor = \"{name}\" is not registered (this binary has: {})",
                self.extractor_names().join(", ")
            );
        };
        (e.factory)(settings)
            .map_err(|err| anyhow::anyhow!("settings of extractor `{name}`: {err:#}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_mask_extractor_and_unknown_names() {
        let c = Components::builtin();
        assert_eq!(c.extractor_names(), ["mask"]);
        let defaults = serde_json::to_value(fipt_emitter::MaskExtractorConfig::default()).unwrap();
        let e = c.extractor("mask", &defaults).unwrap();
        assert_eq!(e.name(), "emission-mask");
        let err = c
            .extractor("brightest", &serde_json::json!({}))
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("brightest") && err.contains("mask"), "{err}");
        let err = format!(
            "{:#}",
            c.extractor("mask", &serde_json::json!({"tresh": 1}))
                .err()
                .unwrap()
        );
        assert!(err.contains("tresh"), "{err}");
    }
}
