//! Atomic file writing: nothing a user computed is ever left half-written.
use crate::error::{CoreError, Result};
use std::path::{Path, PathBuf};

/// The temporary sibling a file is written to before it is renamed into place.
pub fn temp_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(format!(".{}.tmp", std::process::id()));
    path.with_file_name(name)
}

/// Deletes, under `dir` (recursively), the temporaries of [`temp_path`] that a killed process
/// left behind. Finished files are only ever renamed into place, so a temporary is never a
/// result; call this before resuming work in `dir`.
pub fn remove_stale_temporaries(dir: &Path) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            remove_stale_temporaries(&p);
        } else if p.to_string_lossy().ends_with(".tmp") {
            let _ = std::fs::remove_file(&p);
        }
    }
}

/// Writes a file atomically: `write` fills a temporary sibling, which is then renamed over
/// `path`. On error the temporary is removed and any previous `path` is left untouched.
pub fn write_atomic<F>(path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&Path) -> Result<()>,
{
    if let Some(parent) = path.parent() {
        if !parent.as_os_str().is_empty() {
            std::fs::create_dir_all(parent).map_err(|e| CoreError::io(parent, e))?;
        }
    }
    let tmp = temp_path(path);
    crate::chaos::moment();
    // The usual permissions of a new file (0666 less the umask), restored after the writer in
    // case it made the file private (safetensors writes 0600).
    let usual = std::fs::File::create(&tmp)
        .and_then(|f| f.metadata())
        .map_err(|e| CoreError::io(&tmp, e))?
        .permissions();
    match write(&tmp) {
        Ok(()) => {
            crate::chaos::moment();
            let done = std::fs::set_permissions(&tmp, usual)
                .and_then(|_| std::fs::rename(&tmp, path))
                .map_err(|e| {
                    let _ = std::fs::remove_file(&tmp);
                    CoreError::io(path, e)
                });
            crate::chaos::moment();
            done
        }
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// Writes bytes atomically.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |tmp| {
        std::fs::write(tmp, bytes).map_err(|e| CoreError::io(tmp, e))
    })
}

/// Serialises `value` as pretty JSON, atomically.
pub fn write_json_atomic<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value).map_err(|e| CoreError::Json {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    write_bytes_atomic(path, text.as_bytes())
}

/// Reads and parses a JSON file, naming the file in every error, and the field where a
/// value has the wrong type (`exposures[2]: invalid type: string "fast", expected f32 …`).
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let text = std::fs::read_to_string(path).map_err(|e| CoreError::io(path, e))?;
    let mut de = serde_json::Deserializer::from_str(&text);
    let value: T = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let at = e.path().to_string();
        CoreError::Json {
            path: path.to_path_buf(),
            message: if at == "." {
                e.inner().to_string()
            } else {
                format!("`{at}`: {}", e.inner())
            },
        }
    })?;
    de.end().map_err(|e| CoreError::Json {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    Ok(value)
}

/// FNV-1a 64, the fingerprint hash of stage inputs.
/// FNV-1a 64, fed piece by piece: `Fnv::new()`, `feed` in order, then `hex` is
/// [`hash_bytes`] of the pieces concatenated (without holding them together).
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Self::new()
    }
}

impl Fnv {
    pub fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    pub fn feed(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01B3);
        }
    }
    /// The hash as 16 hex digits.
    pub fn hex(&self) -> String {
        format!("{:016x}", self.0)
    }
}

/// FNV-1a 64 over the contents (and lengths) of `paths`, in order: a fingerprint of a stage's
/// inputs. Returned as 16 hex digits.
pub fn hash_files(paths: &[std::path::PathBuf]) -> Result<String> {
    use std::io::Read;
    let mut h = Fnv::new();
    let mut buf = vec![0u8; 1 << 16];
    for p in paths {
        let mut f = std::fs::File::open(p).map_err(|e| CoreError::io(p, e))?;
        let mut len = 0u64;
        loop {
            let n = f.read(&mut buf).map_err(|e| CoreError::io(p, e))?;
            if n == 0 {
                break;
            }
            len += n as u64;
            h.feed(&buf[..n]);
        }
        h.feed(&len.to_le_bytes());
    }
    Ok(h.hex())
}

/// FNV-1a 64 of `bytes` as 16 hex digits (fingerprints of settings and upstream results).
pub fn hash_bytes(bytes: &[u8]) -> String {
    let mut h = Fnv::new();
    h.feed(bytes);
    h.hex()
}

/// [`hash_bytes`] of a JSON value in a canonical form: keys sorted, floating-point numbers
/// rounded to f32. Settings are f32 and serde_json's text round trip of their f64 widening is
/// not exact (0.412f32 reads back one f64 ulp off), so hashing the raw value would change after
/// a save and load.
pub fn hash_json(v: &serde_json::Value) -> String {
    fn canon(v: &serde_json::Value, out: &mut String) {
        use serde_json::Value;
        match v {
            Value::Null | Value::Bool(_) | Value::String(_) => out.push_str(&v.to_string()),
            Value::Number(n) => match (n.as_i64(), n.as_u64(), n.as_f64()) {
                (Some(i), _, _) => out.push_str(&i.to_string()),
                (_, Some(u), _) => out.push_str(&u.to_string()),
                (_, _, Some(f)) => out.push_str(&format!("{:?}", f as f32)),
                _ => out.push_str(&n.to_string()),
            },
            Value::Array(a) => {
                out.push('[');
                for x in a {
                    canon(x, out);
                    out.push(',');
                }
                out.push(']');
            }
            Value::Object(o) => {
                let mut keys: Vec<&String> = o.keys().collect();
                keys.sort();
                out.push('{');
                for k in keys {
                    out.push_str(&format!("{k:?}:"));
                    canon(&o[k], out);
                    out.push(',');
                }
                out.push('}');
            }
        }
    }
    let mut s = String::new();
    canon(v, &mut s);
    hash_bytes(s.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_json_error_names_the_file_and_the_field() {
        #[derive(serde::Deserialize, Debug)]
        struct Capture {
            exposures: Vec<f32>,
        }
        let p = std::env::temp_dir().join(format!("fipt-read-json-{}.json", std::process::id()));
        let err = |text: &str| {
            std::fs::write(&p, text).unwrap();
            read_json::<Capture>(&p).unwrap_err().to_string()
        };
        let e = err(r#"{"exposures": [1, "x"]}"#);
        assert!(
            e.contains("fipt-read-json") && e.contains("`exposures[1]`: invalid type"),
            "{e}"
        );
        assert!(err(r#"{"exposures": [1]} x"#).contains("trailing characters"));
        std::fs::write(&p, r#"{"exposures": [1, 2]}"#).unwrap();
        assert_eq!(read_json::<Capture>(&p).unwrap().exposures, [1.0, 2.0]);
        let _ = std::fs::remove_file(&p);
    }

    #[test]
    fn json_hash_survives_a_text_round_trip_of_f32_settings() {
        let v =
            serde_json::json!({ "b": [0.412f32, 0.216f32, 1], "a": { "x": 0.608f32, "s": "t" } });
        let back: serde_json::Value = serde_json::from_str(&v.to_string()).unwrap();
        assert_eq!(hash_json(&v), hash_json(&back));
        let other =
            serde_json::json!({ "b": [0.413f32, 0.216f32, 1], "a": { "x": 0.608f32, "s": "t" } });
        assert_ne!(hash_json(&v), hash_json(&other));
        assert_eq!(hash_bytes(b"abc"), hash_bytes(b"abc"));
        assert_ne!(hash_bytes(b"abc"), hash_bytes(b"abd"));
    }
}
