//! The components `fipt run` composes, chosen by name in the run config: the built-in ones and
//! those a binary registers (a plug-in crate builds its own `fipt` with
//! `fipt_cli::main_with(fipt_cli::components().with_extractor(…))`; see
//! `examples/brightest-emitters`). The host registers no method and no evaluator.
//!
//! | kind | chosen by | built in |
//! |---|---|---|
//! | method (`fipt_core::fit::MaterialFitter`) | `[pipeline] method` | none in the host: `fipt` (bake → search → train → emitters → (refine → search → train) × rounds) is registered by crate `fipt-method` (`fipt_method::register`, settings `[search]`, `[rounds]`, `[train]`, `[refine]`, `[model]`), `ipt` by crate `fipt-ipt` (`fipt_ipt::register`), as any method from outside |
//! | shading baker (`fipt_core::shading::ShadingBaker`), in `fipt`'s rounds | `[pipeline] baker` | `slf`: the surface-light-field bake, settings `[bake]` |
//! | shading refiner (`fipt_core::shading::ShadingRefiner`), in `fipt`'s rounds | `[pipeline] refiner` | `path-grown`: the path-grown refinement, settings `[refine]` |
//! | field trainer (`fipt_core::trainer::FieldTrainer`), in `fipt`'s rounds | `[pipeline] trainer` | `hash-grid`: the hash-grid + MLP field (`fipt_neural::HashGridTrainer`), settings `[train]` |
//! | emitter extractor (`fipt_core::emitter::EmitterExtractor`) | `[pipeline] extractor` | `mask`: the emission-mask extractor, settings `[emitters]` |
//! | reflectance model (`fipt_core::reflectance::ReflectanceFormulas`; built-ins a closed enum) | `[model] brdf`, `--brdf` | `principled`, `fipt` |
//!
//! A registered component's settings are the run config's `[plugins.<name>]` table (a
//! built-in's: its own table, `[bake]`, `[refine]`, `[train]` or `[emitters]`; a component
//! registered with `with_tables`: those tables as one object), passed to its
//! factory as JSON (the factory validates them and names the bad key); `settings_of` finds them.
use crate::bail;
use crate::error::Result;
use fipt_core::emitter::EmitterExtractor;
use fipt_core::fit::MaterialFitter;
use fipt_core::reflectance::{ReflectanceFormulas, ReflectanceModel};
use fipt_core::shading::{ShadingBaker, ShadingRefiner};
use fipt_core::trainer::FieldTrainer;
use std::collections::BTreeMap;

/// Builds a shading baker from its settings, for the run's reflectance model.
pub type BakerFactory = Box<
    dyn Fn(&serde_json::Value, ReflectanceModel) -> Result<Box<dyn ShadingBaker>> + Send + Sync,
>;

/// Builds a shading refiner from its settings, for the run's reflectance model.
pub type RefinerFactory = Box<
    dyn Fn(&serde_json::Value, ReflectanceModel) -> Result<Box<dyn ShadingRefiner>> + Send + Sync,
>;

/// Builds a field trainer from its settings (FIPT builds one per round: a round may change
/// them, see `rounds.roughness_prior`).
pub type TrainerFactory =
    Box<dyn Fn(&serde_json::Value) -> Result<Box<dyn FieldTrainer>> + Send + Sync>;

/// Builds an extractor from its settings.
pub type ExtractorFactory =
    Box<dyn Fn(&serde_json::Value) -> Result<Box<dyn EmitterExtractor>> + Send + Sync>;

/// Builds a fitter (a method) from its settings and the run's preset name (`fast`, `balanced`,
/// `paper`, `reference`), which a method may use to choose its own defaults.
pub type FitterFactory =
    Box<dyn Fn(&serde_json::Value, &str) -> Result<Box<dyn MaterialFitter>> + Send + Sync>;

struct Entry<F> {
    description: String,
    factory: F,
}

/// Registers (or replaces) `name` in `map`.
fn insert<F>(map: &mut BTreeMap<String, Entry<F>>, name: &str, description: &str, factory: F) {
    let description = description.to_string();
    map.insert(
        name.to_string(),
        Entry {
            description,
            factory,
        },
    );
}

pub use crate::names::Kind;

/// The registry of named components.
pub struct Components {
    extractors: BTreeMap<String, Entry<ExtractorFactory>>,
    fitters: BTreeMap<String, Entry<FitterFactory>>,
    bakers: BTreeMap<String, Entry<BakerFactory>>,
    refiners: BTreeMap<String, Entry<RefinerFactory>>,
    trainers: BTreeMap<String, Entry<TrainerFactory>>,
    /// The run config's own table holding a component's settings (the built-ins'; kept when
    /// one is registered again); the others read `[plugins.<name>]`.
    sections: BTreeMap<(Kind, String), Tables>,
    /// What scores a finished run against the scene's ground truth (`metrics.json`); None:
    /// no scoring (`fipt_eval::register` adds it).
    evaluator: Option<Evaluator>,
}

/// Scores the outputs in a run folder against the scene's ground truth, the views having been
/// divided by the given exposure scale; writes and returns `metrics.json`.
pub type Evaluator = Box<
    dyn Fn(&fipt_core::dataset::Dataset, &std::path::Path, f32) -> Result<serde_json::Value>
        + Send
        + Sync,
>;

pub use crate::names::{
    FIPT_METHOD, HASH_GRID_TRAINER, MASK_EXTRACTOR, PATH_GROWN_REFINER, SLF_BAKER,
};

/// The run config's tables a component reads: one (its value is the settings) or several (an
/// object of them, by table name).
#[derive(Clone, Copy)]
enum Tables {
    One(&'static str),
    Several(&'static [&'static str]),
}

impl Tables {
    fn names(&self) -> &[&'static str] {
        match self {
            Tables::One(table) => std::slice::from_ref(table),
            Tables::Several(tables) => tables,
        }
    }
}

impl Components {
    /// The host's defaults: the `slf` baker, `path-grown` refiner, `hash-grid` trainer and
    /// `mask` extractor; no method and no evaluator (`fipt_cli::components()` adds them).
    pub fn builtin() -> Self {
        Components {
            extractors: BTreeMap::new(),
            fitters: BTreeMap::new(),
            bakers: BTreeMap::new(),
            refiners: BTreeMap::new(),
            trainers: BTreeMap::new(),
            sections: BTreeMap::new(),
            evaluator: None,
        }
        .with_baker(
            SLF_BAKER,
            "the surface light field of the views and the factorised shadings (settings: [bake])",
            Box::new(|v, model| {
                let config: fipt_bake::bake::BakeConfig = serde_json::from_value(v.clone())?;
                config.validate().map_err(crate::error::RunError::invalid)?;
                Ok(Box::new(
                    fipt_bake::bake::FactorizedBaker::new(config).with_model(model),
                ))
            }),
        )
        .with_refiner(
            PATH_GROWN_REFINER,
            "paths grown through glossy surfaces, the SLF at rough ones, emitter sampling (settings: [refine])",
            Box::new(|v, model| {
                let config: fipt_bake::refine::RefineConfig = serde_json::from_value(v.clone())?;
                config.validate().map_err(crate::error::RunError::invalid)?;
                Ok(Box::new(
                    fipt_bake::refine::PathGrownRefiner::new(config).with_model(model),
                ))
            }),
        )
        .with_trainer(
            HASH_GRID_TRAINER,
            "a multiresolution hash grid and MLPs trained with the factorised image loss, checkpointed and resumed (settings: [train])",
            Box::new(|v| {
                let config: fipt_neural::TrainConfig = serde_json::from_value(v.clone())?;
                Ok(Box::new(fipt_neural::HashGridTrainer::new(config)?))
            }),
        )
        .with_extractor(
            MASK_EXTRACTOR,
            "the trained emission mask averaged per triangle, radiance medians, connected lights (settings: [emitters])",
            Box::new(|v| {
                let config: fipt_emitter::MaskExtractorConfig = serde_json::from_value(v.clone())?;
                config.validate().map_err(crate::error::RunError::invalid)?;
                Ok(Box::new(fipt_emitter::MaskExtractor { config }))
            }),
        )
        .in_section(Kind::Baker, SLF_BAKER, "bake")
        .in_section(Kind::Refiner, PATH_GROWN_REFINER, "refine")
        .in_section(Kind::Trainer, HASH_GRID_TRAINER, "train")
        .in_section(Kind::Extractor, MASK_EXTRACTOR, "emitters")
    }

    /// Gives the registered component `name` of `kind` the run config's table `section` for
    /// its settings (a built-in's own table) instead of `[plugins.<name>]`.
    fn in_section(mut self, kind: Kind, name: &str, section: &'static str) -> Self {
        self.sections
            .insert((kind, name.to_string()), Tables::One(section));
        self
    }

    /// Gives the registered component `name` of `kind` the run config's tables `tables`, as
    /// one object keyed by table, for its settings.
    pub fn with_tables(mut self, kind: Kind, name: &str, tables: &'static [&'static str]) -> Self {
        self.sections
            .insert((kind, name.to_string()), Tables::Several(tables));
        self
    }

    /// The settings of component `name` of `kind` in `cfg`: a built-in's own table (`[bake]`,
    /// `[refine]`, `[train]`, `[emitters]`), anything else's `[plugins.<name>]` (an empty table
    /// when absent).
    pub fn settings_of(
        &self,
        kind: Kind,
        name: &str,
        cfg: &crate::run_config::RunConfig,
    ) -> Result<serde_json::Value> {
        let Some(&tables) = self.sections.get(&(kind, name.to_string())) else {
            return Ok(cfg.plugin_settings(name));
        };
        let names = tables.names();
        if cfg
            .plugin_settings(name)
            .as_object()
            .is_some_and(|o| !o.is_empty())
        {
            let list: Vec<String> = names.iter().map(|t| format!("[{t}]")).collect();
            bail!(
                "[plugins.{name}]: {name}'s settings are the run config's {} tables; move them there",
                list.join(", ")
            );
        }
        let mut found = cfg.sections(names)?;
        Ok(match tables {
            Tables::One(table) => found.remove(table).unwrap_or_default(),
            Tables::Several(_) => serde_json::Value::Object(found),
        })
    }

    /// Registers (or replaces) what scores a finished run against ground truth.
    pub fn with_evaluator(mut self, evaluator: Evaluator) -> Self {
        self.evaluator = Some(evaluator);
        self
    }

    /// What scores a finished run, when one is registered.
    pub fn evaluator(&self) -> Option<&Evaluator> {
        self.evaluator.as_ref()
    }

    /// Registers (or replaces) the emitter extractor `name`.
    pub fn with_extractor(
        mut self,
        name: &str,
        description: &str,
        factory: ExtractorFactory,
    ) -> Self {
        insert(&mut self.extractors, name, description, factory);
        self
    }

    /// Registers (or replaces) the method `name`.
    pub fn with_fitter(mut self, name: &str, description: &str, factory: FitterFactory) -> Self {
        insert(&mut self.fitters, name, description, factory);
        self
    }

    /// The names of the registered methods.
    pub fn method_names(&self) -> Vec<&str> {
        self.fitters.keys().map(|k| k.as_str()).collect()
    }

    /// The fitter of method `name` built from `settings` for `preset`; an unknown name lists
    /// the registered ones.
    pub fn fitter(
        &self,
        name: &str,
        settings: &serde_json::Value,
        preset: &str,
    ) -> Result<Box<dyn MaterialFitter>> {
        let Some(e) = self.fitters.get(name) else {
            let has = match self.method_names() {
                names if names.is_empty() => {
                    "none: a method registers itself, e.g. \
                    `fipt_method::register(Components::builtin())`, or use `fipt_cli::components()`"
                        .to_string()
                }
                names => names.join(", "),
            };
            bail!("[pipeline] method = \"{name}\" is not registered (this binary has: {has})");
        };
        (e.factory)(settings, preset)
            .map_err(|err| crate::err!("settings of method `{name}`: {err:#}"))
    }

    /// Registers (or replaces) the shading baker `name`.
    pub fn with_baker(mut self, name: &str, description: &str, factory: BakerFactory) -> Self {
        insert(&mut self.bakers, name, description, factory);
        self
    }

    /// Registers (or replaces) the shading refiner `name`.
    pub fn with_refiner(mut self, name: &str, description: &str, factory: RefinerFactory) -> Self {
        insert(&mut self.refiners, name, description, factory);
        self
    }

    /// Registers (or replaces) the field trainer `name`.
    pub fn with_trainer(mut self, name: &str, description: &str, factory: TrainerFactory) -> Self {
        insert(&mut self.trainers, name, description, factory);
        self
    }

    /// The trainer `name` built from `settings`; an unknown name lists the registered ones.
    pub fn trainer(
        &self,
        name: &str,
        settings: &serde_json::Value,
    ) -> Result<Box<dyn FieldTrainer>> {
        let Some(e) = self.trainers.get(name) else {
            bail!(
                "[pipeline] trainer = \"{name}\" is not registered (this binary has: {})",
                self.trainers.keys().cloned().collect::<Vec<_>>().join(", ")
            );
        };
        (e.factory)(settings).map_err(|err| crate::err!("settings of trainer `{name}`: {err:#}"))
    }

    /// The baker `name` built from `settings` for `model`.
    pub fn baker(
        &self,
        name: &str,
        settings: &serde_json::Value,
        model: ReflectanceModel,
    ) -> Result<Box<dyn ShadingBaker>> {
        let Some(e) = self.bakers.get(name) else {
            bail!(
                "[pipeline] baker = \"{name}\" is not registered (this binary has: {})",
                self.bakers.keys().cloned().collect::<Vec<_>>().join(", ")
            );
        };
        (e.factory)(settings, model)
            .map_err(|err| crate::err!("settings of baker `{name}`: {err:#}"))
    }

    /// The refiner `name` built from `settings` for `model`.
    pub fn refiner(
        &self,
        name: &str,
        settings: &serde_json::Value,
        model: ReflectanceModel,
    ) -> Result<Box<dyn ShadingRefiner>> {
        let Some(e) = self.refiners.get(name) else {
            bail!(
                "[pipeline] refiner = \"{name}\" is not registered (this binary has: {})",
                self.refiners.keys().cloned().collect::<Vec<_>>().join(", ")
            );
        };
        (e.factory)(settings, model)
            .map_err(|err| crate::err!("settings of refiner `{name}`: {err:#}"))
    }

    /// Registers the external reflectance model `model` (process-wide: `[model] brdf` and
    /// `--brdf` are parsed before a run picks its components). Every baker, refiner and
    /// renderer takes it as they take the built-in models.
    ///
    /// # Panics
    /// If the model's name is a built-in model's, is taken by another object, or is not
    /// lower-case letters, digits, `-` and `_`: a mistake in the binary, not in a user's input.
    pub fn with_reflectance(self, model: &'static dyn ReflectanceFormulas) -> Self {
        if let Err(e) = ReflectanceModel::register(model) {
            panic!("Components::with_reflectance: {e}");
        }
        self
    }

    /// The names of the registered extractors.
    pub fn extractor_names(&self) -> Vec<&str> {
        self.extractors.keys().map(|k| k.as_str()).collect()
    }

    /// One line per registered component, for help texts and reports.
    pub fn describe(&self) -> Vec<String> {
        let methods = self
            .fitters
            .iter()
            .map(|(k, e)| format!("method `{k}`: {}", e.description));
        let extractors = self
            .extractors
            .iter()
            .map(|(k, e)| format!("extractor `{k}`: {}", e.description));
        let bakers = self
            .bakers
            .iter()
            .map(|(k, e)| format!("baker `{k}`: {}", e.description));
        let refiners = self
            .refiners
            .iter()
            .map(|(k, e)| format!("refiner `{k}`: {}", e.description));
        let trainers = self
            .trainers
            .iter()
            .map(|(k, e)| format!("trainer `{k}`: {}", e.description));
        let models = ReflectanceModel::known().into_iter().map(|m| match m {
            ReflectanceModel::External(e) => {
                format!("reflectance model `{m}`: {}", e.formulas().description())
            }
            _ => format!("reflectance model `{m}`: built in"),
        });
        methods
            .chain(bakers)
            .chain(refiners)
            .chain(trainers)
            .chain(extractors)
            .chain(models)
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
        (e.factory)(settings).map_err(|err| crate::err!("settings of extractor `{name}`: {err:#}"))
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

    /// The built-in trainer takes `[train]`'s settings and names a bad key; an unknown trainer
    /// names the registered ones.
    #[test]
    fn builtin_hash_grid_trainer_and_unknown_names() {
        let c = Components::builtin();
        let defaults = serde_json::to_value(fipt_neural::TrainConfig::default()).unwrap();
        assert_eq!(
            c.trainer("hash-grid", &defaults).unwrap().name(),
            "hash-grid"
        );
        let err = format!("{:#}", c.trainer("nerf", &defaults).err().unwrap());
        assert!(err.contains("nerf") && err.contains("hash-grid"), "{err}");
        let mut bad = defaults.clone();
        bad["stepz"] = 3.into();
        let err = format!("{:#}", c.trainer("hash-grid", &bad).err().unwrap());
        assert!(err.contains("stepz"), "{err}");
    }

    /// The host registers no method: asking for one says how to register it.
    #[test]
    fn the_host_knows_no_method() {
        let c = Components::builtin();
        assert!(c.method_names().is_empty());
        let err = c
            .fitter("fipt", &serde_json::json!({}), "fast")
            .err()
            .unwrap();
        assert!(err.to_string().contains("fipt_method::register"), "{err}");
    }
}
