//! A run's settings checked before any work: every table read by a registered component (or
//! the host), every named component built from its settings ([`check`]), and what
//! `report.json` lists of them ([`Checked::report`]).
use crate::components::bracketed;
use crate::error::{Result, RunError};
use crate::names::Kind;
use crate::run_config::RunConfig;

/// A run's components built from its checked settings, and the settings of each.
pub struct Checked {
    pub(crate) extractor: Box<dyn fipt_core::emitter::EmitterExtractor>,
    pub(crate) baker: Box<dyn fipt_core::shading::ShadingBaker>,
    pub(crate) refiner: Box<dyn fipt_core::shading::ShadingRefiner>,
    pub(crate) bake_settings: serde_json::Value,
    pub(crate) refine_settings: serde_json::Value,
    pub(crate) train_settings: serde_json::Value,
    pub(crate) extractor_settings: serde_json::Value,
    pub(crate) method_settings: serde_json::Value,
}

impl Checked {
    /// `report.json`'s `settings`: the host's sections of `cfg` and the settings of the
    /// components the run used (the method's, and each part's that `used` says), as their
    /// factories took them.
    pub(crate) fn report(
        &self,
        cfg: &RunConfig,
        components: &crate::Components,
        used: fipt_core::fit::PartsUsed,
    ) -> serde_json::Value {
        let mut host = cfg.clone();
        host.tables.clear();
        host.plugins.clear();
        let mut out = match serde_json::to_value(&host) {
            Ok(serde_json::Value::Object(o)) => o,
            _ => Default::default(),
        };
        out.insert("plugins".into(), serde_json::json!({}));
        let p = &cfg.pipeline;
        let parts = [
            (used.baker, Kind::Baker, &p.baker, &self.bake_settings),
            (
                used.refiner,
                Kind::Refiner,
                &p.refiner,
                &self.refine_settings,
            ),
            (
                used.trainer,
                Kind::Trainer,
                &p.trainer,
                &self.train_settings,
            ),
            (
                used.extractor,
                Kind::Extractor,
                &p.extractor,
                &self.extractor_settings,
            ),
        ];
        for (_, kind, name, settings) in parts.into_iter().filter(|u| u.0) {
            components.report_settings(kind, name, settings, &mut out);
        }
        components.report_settings(Kind::Method, &p.method, &self.method_settings, &mut out);
        serde_json::Value::Object(out)
    }
}

/// Every setting of `cfg` in its range and every component it names built (a misspelt name or
/// bad plug-in settings fail here, before any work; `fipt sweep` checks each grid point so);
/// a table that no registered component reads is refused, naming the ones they read.
pub fn check(cfg: &RunConfig, preset: &str, components: &crate::Components) -> Result<Checked> {
    cfg.render.validate().map_err(RunError::invalid)?;
    check_tables(cfg, components)?;
    let p = &cfg.pipeline;
    let settings = |kind, name: &str| components.settings_of(kind, name, cfg, preset);
    let extractor_settings = settings(Kind::Extractor, &p.extractor)?;
    let extractor = components.extractor(&p.extractor, &extractor_settings)?;
    let bake_settings = settings(Kind::Baker, &p.baker)?;
    let baker = components.baker(&p.baker, &bake_settings, cfg.model.brdf)?;
    let refine_settings = settings(Kind::Refiner, &p.refiner)?;
    let refiner = components.refiner(&p.refiner, &refine_settings, cfg.model.brdf)?;
    let train_settings = settings(Kind::Trainer, &p.trainer)?;
    components.trainer(&p.trainer, &train_settings)?;
    let method_settings = settings(Kind::Method, &p.method)?;
    components.fitter(&p.method, &method_settings, preset)?;
    Ok(Checked {
        extractor,
        baker,
        refiner,
        bake_settings,
        refine_settings,
        train_settings,
        extractor_settings,
        method_settings,
    })
}

/// The run config of preset `preset` with `file` laid over it, a table that no registered
/// component reads refused with the file named (`fipt run`, and `fipt bake` and `fipt train`
/// given a run config).
pub fn load(
    preset: &str,
    file: Option<&std::path::Path>,
    components: &crate::Components,
) -> Result<RunConfig> {
    let cfg = crate::config::load_preset(preset, RunConfig::preset, file)?;
    check_tables(&cfg, components).map_err(in_file(file))?;
    Ok(cfg)
}

/// An error about the settings of config `file` (None: the preset alone) with the file named.
pub(crate) fn in_file(file: Option<&std::path::Path>) -> impl Fn(RunError) -> RunError + '_ {
    move |e| match file {
        Some(file) => crate::err!("{}: {e:#}", file.display()),
        None => e,
    }
}

/// Refuses a table of `cfg` that neither the host nor any registered component reads.
fn check_tables(cfg: &RunConfig, components: &crate::Components) -> Result<()> {
    let known = components.table_names();
    let Some(unknown) = cfg.tables.keys().find(|k| !known.contains(k.as_str())) else {
        return Ok(());
    };
    let what = if cfg.tables[unknown].is_object() {
        "table"
    } else {
        "key"
    };
    crate::bail!(
        "unknown {what} `{unknown}`: the run reads {}, its components {} (a plug-in's settings go in [plugins.<name>])",
        bracketed(RunConfig::HOST_TABLES.iter().copied()),
        bracketed(known)
    )
}
