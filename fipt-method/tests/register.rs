//! FIPT registered from its own crate: its factory reads its four tables of the run config as
//! one object (the preset's values with the file's laid over them), typed once; a
//! `[plugins.fipt]` table is refused with their names; a run of another method neither reads
//! nor reports them.
use fipt_method::{FiptSettings, FIPT_TABLES};
use fipt_pipeline::names::Kind;
use fipt_pipeline::run_config::RunConfig;
use fipt_pipeline::Components;

#[test]
fn fipt_reads_its_tables_and_refuses_a_plugin_table() {
    let c = fipt_method::register(Components::builtin());
    assert_eq!(c.method_names(), ["fipt"]);
    let mut cfg = RunConfig::preset("fast").unwrap();
    let steps = FiptSettings::preset("fast").unwrap().search.roughness_steps + 1;
    cfg.tables.insert(
        "search".into(),
        serde_json::json!({ "roughness_steps": steps }),
    );
    let settings = c.settings_of(Kind::Method, "fipt", &cfg, "fast").unwrap();
    let keys: Vec<&str> = settings
        .as_object()
        .unwrap()
        .keys()
        .map(|k| k.as_str())
        .collect();
    let mut want: Vec<&str> = FIPT_TABLES.iter().map(|t| t.name).collect();
    want.sort();
    assert_eq!(keys, want);
    // The file's key over the preset's values, the others the preset's.
    let typed: FiptSettings = serde_json::from_value(settings.clone()).unwrap();
    let mut expected = FiptSettings::preset("fast").unwrap();
    expected.search.roughness_steps = steps;
    assert_eq!(typed, expected);
    // The preset decides what the file leaves out: `reference` keeps the search off.
    let reference = c
        .settings_of(Kind::Method, "fipt", &cfg, "reference")
        .unwrap();
    assert_eq!(reference["search"]["enabled"], false);
    assert_eq!(reference["search"]["roughness_steps"], steps);
    assert!(c.fitter("fipt", &settings, "fast").is_ok());
    assert!(fipt_pipeline::run::check(&cfg, "fast", &c).is_ok());
    // A key FIPT does not know is refused by its factory, naming it with its table.
    let mut bad = settings.clone();
    bad["rounds"]["refinemnts"] = 1.into();
    let err = format!("{:#}", c.fitter("fipt", &bad, "fast").err().unwrap());
    assert!(err.contains("rounds.refinemnts"), "{err}");
    // So is a value out of range.
    let mut bad = settings.clone();
    bad["rounds"]["settle_share"] = 2.0.into();
    let err = format!("{:#}", c.fitter("fipt", &bad, "fast").err().unwrap());
    assert!(err.contains("rounds.settle_share"), "{err}");
    // Its settings are those tables, never `[plugins.fipt]`.
    cfg.plugins
        .insert("fipt".into(), serde_json::json!({"steps": 3}));
    let err = c
        .settings_of(Kind::Method, "fipt", &cfg, "fast")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("[plugins.fipt]") && err.contains("[search], [rounds], [train]"),
        "{err}"
    );
}

/// The preset's rounds as the run config gave them before the tables moved to FIPT.
#[test]
fn the_presets_rounds() {
    let rounds = |p: &str| {
        let r = FiptSettings::preset(p).unwrap().rounds;
        (
            r.refinements,
            r.warm_start,
            r.roughness_prior,
            r.settle_rounds,
        )
    };
    assert_eq!(rounds("paper"), (2, false, Some(0.0), 0));
    assert_eq!(rounds("reference"), (2, false, None, 0));
    assert_eq!(rounds("balanced"), (1, true, Some(0.0), 1));
    assert_eq!(rounds("fast"), (1, true, Some(0.0), 1));
    assert!(FiptSettings::preset("papr").is_none());
    for p in ["paper", "reference", "balanced", "fast"] {
        assert!(FiptSettings::preset(p).unwrap().validate().is_ok(), "{p}");
    }
}
