//! Typed configuration files (TOML or JSON) applied on top of a named preset.
use anyhow::{Context, Result};
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

/// `preset` with the keys of `file` (TOML, or JSON for `.json`) laid over it. Unknown keys are
/// an error naming the file.
pub fn load<T: Serialize + DeserializeOwned>(preset: T, file: Option<&Path>) -> Result<T> {
    let Some(path) = file else { return Ok(preset) };
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let over: serde_json::Value = if path.extension().is_some_and(|e| e == "json") {
        serde_json::from_str(&text).with_context(|| format!("{}: invalid JSON", path.display()))?
    } else {
        toml::from_str(&text).with_context(|| format!("{}: invalid TOML", path.display()))?
    };
    let mut base = serde_json::to_value(&preset)?;
    merge(&mut base, over);
    serde_json::from_value(base).with_context(|| {
        format!(
            "{}: invalid settings (keys are listed in the README)",
            path.display()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use fipt_shading::bake::BakeConfig;

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
        assert_eq!(c.sampler, fipt_shading::bake::SamplerKind::Independent);
        std::fs::write(&p, "difuse_samples = 32\n").unwrap();
        let err = format!("{:#}", load(BakeConfig::default(), Some(&p)).unwrap_err());
        assert!(
            err.contains("bake.toml") && err.contains("difuse_samples"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
