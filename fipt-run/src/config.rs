//! Typed configuration files (TOML or JSON) applied on top of a named preset.
use crate::bail;
use crate::error::{Context, Result};
use serde::{de::DeserializeOwned, Serialize};
use std::path::Path;

/// Lays the keys of `over` onto `base`, table by table (a key of `over` replaces `base`'s,
/// a table is laid over the table of the same name).
pub fn merge(base: &mut serde_json::Value, over: serde_json::Value) {
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
    typed(base)
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

/// `value` typed as `T`; an unknown or mistyped key is an error naming its path
/// (`search.roughness_steps`: …).
pub fn typed<T: DeserializeOwned>(value: serde_json::Value) -> Result<T> {
    serde_path_to_error::deserialize(value)
        .map_err(|e| crate::err!("`{}`: {}", e.path(), e.inner()))
}

/// The config `path` (TOML, or JSON for `.json`) as a value.
pub fn read_value(path: &Path) -> Result<serde_json::Value> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse(&text, path)
}

/// Whether the config `path` (TOML, or JSON for `.json`) has a top-level table `key`.
pub fn has_table(path: &Path, key: &str) -> Result<bool> {
    Ok(read_value(path)?.get(key).is_some_and(|t| t.is_object()))
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
            "{}: {}{} (every key is listed in docs/settings.md)",
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
