//! Typed configuration files (TOML or JSON) applied on top of a named preset.
use crate::bail;
use crate::error::{Context, Result};
use serde::{de::DeserializeOwned, Serialize};
use std::path::Path;

fn merge(base: &mut serde_json::Value, over: serde_json::Value) {
    match (base, over) {
        (serde_json::Value::Object(b), serde_json::Value::Object(o)) => {
            for (k, v) in o {
                match b.get_mut(&k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (b, o) => *b = o,
    }
}

/// The presets every stage knows: `paper` (the reference's sample counts, sizes and steps with
/// this project's estimators and losses), `balanced`, `fast`, and `reference` (the reference's
/// behaviour as well, for comparison).
pub const PRESETS: &str = "paper, balanced, fast, reference";

/// The preset `name` (found by `lookup`) with the keys of `file` laid over it (see [`load`]).
pub fn load_preset<T: Serialize + DeserializeOwned>(
    name: &str,
    lookup: impl FnOnce(&str) -> Option<T>,
    file: Option<&Path>,
) -> Result<T> {
    let Some(preset) = lookup(name) else {
        bail!("unknown preset `{name}` (use one of {PRESETS})")
    };
    load(preset, file)
}

/// [`load_preset`] for one stage's settings from a file that is either that stage's config or a
/// run config: when the file has a `[section]` table, that table is used (a run config's
/// `[bake]` for `fipt bake`), the other sections ignored.
pub fn load_preset_section<T: Serialize + DeserializeOwned>(
    name: &str,
    lookup: impl FnOnce(&str) -> Option<T>,
    file: Option<&Path>,
    section: &str,
) -> Result<T> {
    let Some(preset) = lookup(name) else {
        bail!("unknown preset `{name}` (use one of {PRESETS})")
    };
    load_with(preset, file, Some(section))
}

/// `preset` with the keys of `file` (TOML, or JSON for `.json`) laid over it. Unknown keys are
/// an error naming the file.
pub fn load<T: Serialize + DeserializeOwned>(preset: T, file: Option<&Path>) -> Result<T> {
    load_with(preset, file, None)
}

/// `preset` with the keys of `over` laid over it (a plug-in's `[plugins.<name>]` table);
/// an unknown or mistyped key is an error naming it.
pub fn lay_over<T: Serialize + DeserializeOwned>(preset: T, over: serde_json::Value) -> Result<T> {
    let mut base = serde_json::to_value(&preset)?;
    merge(&mut base, over);
    serde_path_to_error::deserialize(base).map_err(|e| crate::err!("`{}`: {}", e.path(), e.inner()))
}

fn load_with<T: Serialize + DeserializeOwned>(
    preset: T,
    file: Option<&Path>,
    section: Option<&str>,
) -> Result<T> {
    let Some(path) = file else { return Ok(preset) };
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    load_text(preset, &text, path, section)
}

/// Whether the config `path` (TOML, or JSON for `.json`) has a top-level table `key`.
pub fn has_table(path: &Path, key: &str) -> Result<bool> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    Ok(parse(&text, path)?.get(key).is_some_and(|t| t.is_object()))
}

/// The text of a config as a value (TOML, or JSON for `.json`; `path` names it in errors).
fn parse(text: &str, path: &Path) -> Result<serde_json::Value> {
    Ok(if path.extension().is_some_and(|e| e == "json") {
        serde_json::from_str(text).with_context(|| format!("{}: invalid JSON", path.display()))?
    } else {
        toml::from_str(text).with_context(|| format!("{}: invalid TOML", path.display()))?
    })
}

/// [`load`] from the text of a config (`path` names it in errors and says whether it is JSON).
pub fn load_text<T: Serialize + DeserializeOwned>(
    preset: T,
    text: &str,
    path: &Path,
    section: Option<&str>,
) -> Result<T> {
    let over = parse(text, path)?;
    let over = match section.and_then(|k| over.get(k)) {
        Some(table) if table.is_object() => table.clone(),
        _ => over,
    };
    let mut base = serde_json::to_value(&preset)?;
    merge(&mut base, over);
    serde_path_to_error::deserialize(base).map_err(|e| {
        let key = e.path().to_string();
        crate::err!(
            "{}: {}{} (keys are listed in the README)",
            path.display(),
            if key == "." {
                String::new()
            } else {
                format!("`{key}`: ")
            },
            e.inner()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use fipt_bake::bake::BakeConfig;
    use fipt_core::presets::Presets;

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
        let c: BakeConfig =
            load_preset_section("fast", BakeConfig::preset, Some(&p), "bake").unwrap();
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
        // `fipt train` checks its bake against the same baker, by its implementation's name
        // and these settings; a run config of another method is refused.
        let c = crate::Components::builtin();
        let (imp, same) = crate::bake::run_baker("fast", Some(&p), &c)
            .unwrap()
            .unwrap();
        assert_eq!((imp.as_str(), &same), ("fipt-slf/principled", &settings));
        std::fs::write(&p, "[pipeline]\nmethod = \"ipt\"\n").unwrap();
        let err = crate::bake::run_baker("fast", Some(&p), &c)
            .unwrap_err()
            .to_string();
        assert!(err.contains("trains FIPT's field"), "{err}");
        // A value of the wrong type names its key.
        std::fs::write(&p, "[bake]\ndiffuse_samples = \"many\"\n").unwrap();
        assert!(crate::bake::run_baker("fast", Some(&p), &c)
            .unwrap()
            .is_none());
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
        }
        let err = load_preset("papr", RunConfig::preset, None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("`papr`") && err.contains(PRESETS), "{err}");
        // `paper` departs from `reference` only where this project measured better.
        let (p, r) = (
            RunConfig::preset("paper").unwrap(),
            RunConfig::preset("reference").unwrap(),
        );
        assert_eq!(
            (p.train.steps, p.train.batch, p.train.field.grid.levels),
            (r.train.steps, r.train.batch, r.train.field.grid.levels)
        );
        assert_eq!(
            (p.rounds.refinements, p.rounds.warm_start),
            (r.rounds.refinements, r.rounds.warm_start)
        );
        assert_eq!(p.bake.diffuse_samples, r.bake.diffuse_samples);
        assert_eq!(p.refine.specular_samples, r.refine.specular_samples);
    }
}
