//! The config loader's tests on the stages' own settings (moved with the loader to fipt-run, which knows no stage).
#![cfg(test)]
use fipt_bake::bake::BakeConfig;
use fipt_core::presets::Presets;
use fipt_run::config::*;

#[test]
fn file_keys_override_the_preset_and_unknown_keys_fail() {
    let dir = std::env::temp_dir().join(format!("fipt-cfg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("bake.toml");
    std::fs::write(&p, "diffuse_samples = 32\nsampler = \"independent\"\n").unwrap();
    let c = load(BakeConfig::fast(), Some(&p)).unwrap();
    assert_eq!(c.diffuse_samples, 32);
    assert_eq!(
        c.specular_samples,
        BakeConfig::fast().specular_samples,
        "preset kept for absent keys"
    );
    assert_eq!(c.sampler, fipt_bake::bake::SamplerKind::Independent);
    // A run config's [bake] section serves `fipt bake` too.
    std::fs::write(
        &p,
        "[model]\nbrdf = \"fipt\"\n[bake]\ndiffuse_samples = 48\n",
    )
    .unwrap();
    let c: BakeConfig = load_preset_section("fast", BakeConfig::preset, Some(&p), "bake").unwrap();
    assert_eq!(c.diffuse_samples, 48);
    // `fipt bake` chooses the baker as `fipt run` does: `slf` with `[bake]` without a
    // `[pipeline]` table, else the table's baker with its own section.
    let (name, settings) =
        crate::bake::chosen_baker("fast", Some(&p), &crate::Components::builtin()).unwrap();
    assert_eq!(
        (name.as_str(), settings["diffuse_samples"].as_u64()),
        ("slf", Some(48))
    );
    std::fs::write(
        &p,
        "[pipeline]\nbaker = \"mine\"\n[plugins.mine]\nrays = 3\n[bake]\ndiffuse_samples = 48\n",
    )
    .unwrap();
    let (name, settings) =
        crate::bake::chosen_baker("fast", Some(&p), &crate::Components::builtin()).unwrap();
    assert_eq!(
        (name.as_str(), &settings),
        ("mine", &serde_json::json!({"rays": 3}))
    );
    let err = crate::Components::builtin()
        .baker(&name, &settings, Default::default())
        .err()
        .unwrap();
    assert!(
        err.to_string()
            .contains("baker = \"mine\" is not registered"),
        "{err}"
    );
    // A run config's table that no component reads is refused, the file named.
    std::fs::write(
        &p,
        "[pipeline]\nbaker = \"slf\"\n[bkae]\ndiffuse_samples = 40\n",
    )
    .unwrap();
    let err = crate::bake::chosen_baker("fast", Some(&p), &crate::Components::builtin())
        .unwrap_err()
        .to_string();
    assert!(err.contains("bake.toml") && err.contains("`bkae`"), "{err}");
    std::fs::write(
        &p,
        "[pipeline]\nbaker = \"slf\"\n[bake]\ndiffuse_samples = 40\n",
    )
    .unwrap();
    let (name, settings) =
        crate::bake::chosen_baker("fast", Some(&p), &crate::Components::builtin()).unwrap();
    assert_eq!(
        (name.as_str(), settings["diffuse_samples"].as_u64()),
        ("slf", Some(40))
    );
    assert_eq!(
        settings["specular_samples"],
        serde_json::json!(BakeConfig::fast().specular_samples),
        "the preset's bake settings under the file's"
    );
    // A value of the wrong type names its key.
    std::fs::write(&p, "[bake]\ndiffuse_samples = \"many\"\n").unwrap();
    let err = format!(
        "{:#}",
        load_preset_section("fast", BakeConfig::preset, Some(&p), "bake").unwrap_err()
    );
    assert!(
        err.contains("`diffuse_samples`") && err.contains("many"),
        "{err}"
    );
    std::fs::write(&p, "difuse_samples = 32\n").unwrap();
    let err = format!("{:#}", load(BakeConfig::default(), Some(&p)).unwrap_err());
    assert!(
        err.contains("bake.toml") && err.contains("difuse_samples"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Every stage knows every preset name, and an unknown one names the valid ones.
#[test]
fn every_stage_knows_every_preset() {
    use crate::run_config::RunConfig;
    use fipt_bake::refine::RefineConfig;
    use fipt_neural::TrainConfig;
    use fipt_search::SearchConfig;
    for name in PRESETS.split(", ") {
        assert!(BakeConfig::preset(name).is_some(), "bake: {name}");
        assert_eq!(
            BakeConfig::preset(name).unwrap().validate(),
            Ok(()),
            "{name}"
        );
        assert_eq!(
            RefineConfig::preset(name).unwrap().validate(),
            Ok(()),
            "{name}"
        );
        assert!(TrainConfig::preset(name).is_some(), "train: {name}");
        assert!(RefineConfig::preset(name).is_some(), "refine: {name}");
        assert!(RunConfig::preset(name).is_some(), "run: {name}");
        assert_eq!(SearchConfig::preset(name).unwrap().validate(), Ok(()));
    }
    let err = load_preset("papr", RunConfig::preset, None)
        .unwrap_err()
        .to_string();
    assert!(err.contains("`papr`") && err.contains(PRESETS), "{err}");
    // `paper` departs from `reference` only where this project measured better.
    let (p, r) = (TrainConfig::paper(), TrainConfig::reference());
    assert_eq!(
        (p.steps, p.batch, p.field.grid.levels),
        (r.steps, r.batch, r.field.grid.levels)
    );
    assert_eq!(
        BakeConfig::paper().diffuse_samples,
        BakeConfig::reference().diffuse_samples
    );
    assert_eq!(
        RefineConfig::paper().specular_samples,
        RefineConfig::reference().specular_samples
    );
}

/// The host types its own sections only: a component's table is kept as written and reaches
/// its factory over the preset's values; a table that no component reads is refused by name.
#[test]
fn component_tables_reach_their_factories_and_unknown_ones_fail() {
    use crate::names::Kind;
    use crate::run_config::RunConfig;
    let c = crate::Components::builtin();
    let mut cfg = RunConfig::preset("fast").unwrap();
    cfg.tables
        .insert("bake".into(), serde_json::json!({"diffuse_samples": 40}));
    let bake = c.settings_of(Kind::Baker, "slf", &cfg, "fast").unwrap();
    assert_eq!(bake["diffuse_samples"], 40);
    assert_eq!(
        bake["specular_samples"],
        serde_json::json!(BakeConfig::fast().specular_samples)
    );
    // The preset decides the values the file leaves out.
    let paper = c.settings_of(Kind::Baker, "slf", &cfg, "paper").unwrap();
    assert_eq!(
        paper["specular_samples"],
        serde_json::json!(BakeConfig::paper().specular_samples)
    );
    // Every component but the method (the host registers none) builds from them.
    let err = crate::run::check(&cfg, "fast", &c)
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("method = \"fipt\" is not registered"), "{err}");
    // A misspelt key of a table is named by the factory that reads it.
    cfg.tables
        .insert("bake".into(), serde_json::json!({"difuse_samples": 40}));
    let err = format!("{:#}", crate::run::check(&cfg, "fast", &c).err().unwrap());
    assert!(
        err.contains("difuse_samples") && err.contains("[bake]"),
        "{err}"
    );
    // A table no registered component reads names those that are read.
    cfg.tables.remove("bake");
    cfg.tables.insert("bkae".into(), serde_json::json!({}));
    let err = crate::run::check(&cfg, "fast", &c)
        .err()
        .unwrap()
        .to_string();
    assert!(
        err.contains("`bkae`") && err.contains("[bake]") && err.contains("[render]"),
        "{err}"
    );
}
