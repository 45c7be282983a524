//! The components `fipt run` composes, chosen by name in the run config: the built-in ones and
//! those a binary registers (a plug-in crate builds its own `fipt` with
//! `fipt_cli::main_with(fipt_cli::components().with_extractor(…))`; see
//! `examples/brightest-emitters`). The host registers no method and no evaluator.
//!
//! | kind | chosen by | built in |
//! |---|---|---|
//! | method (`fipt_core::fit::MaterialFitter`) | `[pipeline] method` | none in the host: `fipt` (bake → search → train → emitters → (refine → search → train) × rounds) is registered by crate `fipt-method` (`fipt_method::register`, settings `[search]`, `[rounds]`, `[train]`, `[refine]`), `ipt` by crate `fipt-ipt` (`fipt_ipt::register`), as any method from outside |
//! | shading baker (`fipt_core::shading::ShadingBaker`), in `fipt`'s rounds | `[pipeline] baker` | `slf`: the surface-light-field bake, settings `[bake]` |
//! | shading refiner (`fipt_core::shading::ShadingRefiner`), in `fipt`'s rounds | `[pipeline] refiner` | `path-grown`: the path-grown refinement, settings `[refine]` |
//! | field trainer (`fipt_core::trainer::FieldTrainer`), in `fipt`'s rounds | `[pipeline] trainer` | `hash-grid`: the hash-grid + MLP field (`fipt_neural::HashGridTrainer`), settings `[train]` |
//! | emitter extractor (`fipt_core::emitter::EmitterExtractor`) | `[pipeline] extractor` | `mask`: the emission-mask extractor, settings `[emitters]` |
//! | reflectance model (`fipt_core::reflectance::ReflectanceFormulas`; built-ins a closed enum) | `[model] brdf`, `--brdf` | `principled`, `fipt` |
//!
//! A registered component's settings are the run config's `[plugins.<name>]` table as written
//! (a method's factory also gets the preset's name), or, for one registered with
//! `with_table` / `with_tables` (the built-ins: `[bake]`, `[refine]`, `[train]`,
//! `[emitters]`; FIPT: four tables as one object), the preset's values of its tables
//! ([`Table`]) with the run config's laid over them. `settings_of` finds them; the factory
//! types them, once, and names a bad key.
use crate::bail;
use crate::error::Result;
use fipt_core::emitter::EmitterExtractor;
use fipt_core::fit::MaterialFitter;
use fipt_core::presets::Presets;
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

/// `[bake]`: the `slf` baker's settings.
pub const BAKE_TABLE: Table = Table::of::<fipt_bake::bake::BakeConfig>("bake");
/// `[refine]`: the `path-grown` refiner's settings (FIPT reads its `rough_threshold` too).
pub const REFINE_TABLE: Table = Table::of::<fipt_bake::refine::RefineConfig>("refine");
/// `[train]`: the `hash-grid` trainer's settings (FIPT reads its training set's share, seed
/// and targets too).
pub const TRAIN_TABLE: Table = Table::of::<fipt_neural::TrainConfig>("train");
/// `[emitters]`: the `mask` extractor's settings.
pub const EMITTERS_TABLE: Table = Table::of::<fipt_emitter::MaskExtractorConfig>("emitters");

/// A table of the run config that a component reads (`[bake]`, `[search]`, …): its name and
/// its values in each preset. The host keeps what a file writes there as written; the
/// component's factory gets the preset's values with the file's laid over them and types them,
/// once.
#[derive(Clone, Copy)]
pub struct Table {
    pub name: &'static str,
    defaults: fn(&str) -> Option<serde_json::Value>,
}

impl Table {
    /// Table `name`, holding settings of type `T` (its presets are `T`'s).
    pub const fn of<T: Presets + serde::Serialize>(name: &'static str) -> Table {
        Table {
            name,
            defaults: preset_value::<T>,
        }
    }

    /// The table's values in preset `preset` with `over` (what the run config wrote) laid
    /// over them.
    fn value(&self, preset: &str, over: Option<&serde_json::Value>) -> Result<serde_json::Value> {
        let Some(mut v) = (self.defaults)(preset) else {
            bail!(
                "unknown preset `{preset}` (use one of {})",
                fipt_run::config::PRESETS
            );
        };
        if let Some(over) = over {
            fipt_run::config::merge(&mut v, over.clone());
        }
        Ok(v)
    }
}

/// Table names as a config writes them: `[bake], [search]`.
pub(crate) fn bracketed<'a>(names: impl IntoIterator<Item = &'a str>) -> String {
    let names: Vec<String> = names.into_iter().map(|t| format!("[{t}]")).collect();
    names.join(", ")
}

fn preset_value<T: Presets + serde::Serialize>(preset: &str) -> Option<serde_json::Value> {
    T::preset(preset).and_then(|t| serde_json::to_value(t).ok())
}

/// The run config's tables a component reads: one (its value is the settings) or several (an
/// object of them, by table name).
#[derive(Clone, Copy)]
enum Tables {
    One(Table),
    Several(&'static [Table]),
}

impl Tables {
    fn list(&self) -> &[Table] {
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
                let config: fipt_bake::bake::BakeConfig = fipt_run::config::typed(v.clone())?;
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
                let config: fipt_bake::refine::RefineConfig = fipt_run::config::typed(v.clone())?;
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
                let config: fipt_neural::TrainConfig = fipt_run::config::typed(v.clone())?;
                Ok(Box::new(fipt_neural::HashGridTrainer::new(config)?))
            }),
        )
        .with_extractor(
            MASK_EXTRACTOR,
            "the trained emission mask averaged per triangle, radiance medians, connected lights (settings: [emitters])",
            Box::new(|v| {
                let config: fipt_emitter::MaskExtractorConfig = fipt_run::config::typed(v.clone())?;
                config.validate().map_err(crate::error::RunError::invalid)?;
                Ok(Box::new(fipt_emitter::MaskExtractor::new(config)))
            }),
        )
        .with_table(Kind::Baker, SLF_BAKER, BAKE_TABLE)
        .with_table(Kind::Refiner, PATH_GROWN_REFINER, REFINE_TABLE)
        .with_table(Kind::Trainer, HASH_GRID_TRAINER, TRAIN_TABLE)
        .with_table(Kind::Extractor, MASK_EXTRACTOR, EMITTERS_TABLE)
    }

    /// Gives the registered component `name` of `kind` the run config's table `table` for
    /// its settings (the table's value) instead of `[plugins.<name>]`.
    pub fn with_table(mut self, kind: Kind, name: &str, table: Table) -> Self {
        self.sections
            .insert((kind, name.to_string()), Tables::One(table));
        self
    }

    /// Gives the registered component `name` of `kind` the run config's tables `tables`, as
    /// one object keyed by table, for its settings.
    pub fn with_tables(mut self, kind: Kind, name: &str, tables: &'static [Table]) -> Self {
        self.sections
            .insert((kind, name.to_string()), Tables::Several(tables));
        self
    }

    /// The one table component `name` of `kind` reads its settings from (`[bake]` for the `slf`
    /// baker); None for a component with several or with `[plugins.<name>]`.
    pub fn table_of(&self, kind: Kind, name: &str) -> Option<&'static str> {
        match self.sections.get(&(kind, name.to_string())) {
            Some(Tables::One(t)) => Some(t.name),
            _ => None,
        }
    }

    /// Where component `name` of `kind` reads its settings: `[bake]`, `[search], [rounds]`,
    /// `[plugins.<name>]`.
    fn where_from(&self, kind: Kind, name: &str) -> String {
        match self.sections.get(&(kind, name.to_string())) {
            Some(t) => bracketed(t.list().iter().map(|t| t.name)),
            None => format!("[plugins.{name}]"),
        }
    }

    /// The names of the tables some registered component reads.
    pub fn table_names(&self) -> std::collections::BTreeSet<&'static str> {
        let tables = self.sections.values().flat_map(|t| t.list().iter());
        tables.map(|t| t.name).collect()
    }

    /// The settings of component `name` of `kind` in `cfg` under `preset`: the preset's values
    /// of its tables with `cfg`'s laid over them (one table's value, or an object of its
    /// tables), or, for a component without tables, `[plugins.<name>]` (an empty table when
    /// absent; its factory lays it over its own defaults).
    pub fn settings_of(
        &self,
        kind: Kind,
        name: &str,
        cfg: &crate::run_config::RunConfig,
        preset: &str,
    ) -> Result<serde_json::Value> {
        let Some(&tables) = self.sections.get(&(kind, name.to_string())) else {
            return Ok(cfg.plugin_settings(name));
        };
        if cfg
            .plugin_settings(name)
            .as_object()
            .is_some_and(|o| !o.is_empty())
        {
            bail!(
                "[plugins.{name}]: {name}'s settings are the run config's {} tables; move them there",
                self.where_from(kind, name)
            );
        }
        let value = |t: &Table| t.value(preset, cfg.tables.get(t.name));
        Ok(match tables {
            Tables::One(table) => value(&table)?,
            Tables::Several(list) => serde_json::Value::Object(
                list.iter()
                    .map(|t| Ok((t.name.to_string(), value(t)?)))
                    .collect::<Result<_>>()?,
            ),
        })
    }

    /// Puts the `settings` of component `name` of `kind` ([`Self::settings_of`]) into
    /// `report`, `report.json`'s `settings`: each of its tables by name, a plug-in's under
    /// `plugins.<name>`.
    pub fn report_settings(
        &self,
        kind: Kind,
        name: &str,
        settings: &serde_json::Value,
        report: &mut serde_json::Map<String, serde_json::Value>,
    ) {
        match self.sections.get(&(kind, name.to_string())) {
            Some(Tables::One(t)) => {
                report.insert(t.name.to_string(), settings.clone());
            }
            Some(Tables::Several(list)) => {
                for t in list.iter() {
                    report.insert(t.name.to_string(), settings[t.name].clone());
                }
            }
            None => {
                let plugins = report
                    .entry("plugins")
                    .or_insert_with(|| serde_json::json!({}));
                plugins[name] = settings.clone();
            }
        }
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
        (e.factory)(settings, preset).map_err(|err| {
            crate::err!(
                "settings of method `{name}` ({}): {err:#}",
                self.where_from(Kind::Method, name)
            )
        })
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
        (e.factory)(settings).map_err(|err| {
            crate::err!(
                "settings of trainer `{name}` ({}): {err:#}",
                self.where_from(Kind::Trainer, name)
            )
        })
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
        (e.factory)(settings, model).map_err(|err| {
            crate::err!(
                "settings of baker `{name}` ({}): {err:#}",
                self.where_from(Kind::Baker, name)
            )
        })
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
        (e.factory)(settings, model).map_err(|err| {
            crate::err!(
                "settings of refiner `{name}` ({}): {err:#}",
                self.where_from(Kind::Refiner, name)
            )
        })
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
        (e.factory)(settings).map_err(|err| {
            crate::err!(
                "settings of extractor `{name}` ({}): {err:#}",
                self.where_from(Kind::Extractor, name)
            )
        })
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
