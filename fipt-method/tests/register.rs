//! FIPT registered from its own crate: its factory reads its five tables of the run config as
//! one object, typed once, and a `[plugins.fipt]` table is refused with their names.
use fipt_method::{FiptSettings, FIPT_TABLES};
use fipt_pipeline::names::Kind;
use fipt_pipeline::run_config::RunConfig;
use fipt_pipeline::Components;

#[test]
fn fipt_reads_its_tables_and_refuses_a_plugin_table() {
    let c = fipt_method::register(Components::builtin());
    assert_eq!(c.method_names(), ["fipt"]);
    let mut cfg = RunConfig::preset("fast").unwrap();
    cfg.search.roughness_steps += 1;
    let settings = c.settings_of(Kind::Method, "fipt", &cfg).unwrap();
    let keys: Vec<&str> = settings
        .as_object()
        .unwrap()
        .keys()
        .map(|k| k.as_str())
        .collect();
    let mut want = FIPT_TABLES.to_vec();
    want.sort();
    assert_eq!(keys, want);
    let typed: FiptSettings = serde_json::from_value(settings.clone()).unwrap();
    assert_eq!(typed, FiptSettings::of(&cfg));
    assert!(c.fitter("fipt", &settings, "fast").is_ok());
    // A key FIPT does not know is refused by its factory, naming it.
    let mut bad = settings.clone();
    bad["rounds"]["refinemnts"] = 1.into();
    let err = format!("{:#}", c.fitter("fipt", &bad, "fast").err().unwrap());
    assert!(err.contains("refinemnts"), "{err}");
    // Its settings are those tables, never `[plugins.fipt]`.
    cfg.plugins
        .insert("fipt".into(), serde_json::json!({"steps": 3}));
    let err = c
        .settings_of(Kind::Method, "fipt", &cfg)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("[plugins.fipt]") && err.contains("[search], [rounds], [train]"),
        "{err}"
    );
}
