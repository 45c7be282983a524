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
    match write(&tmp) {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            CoreError::io(path, e)
        }),
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

/// Reads and parses a JSON file, naming the file in every error.
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let text = std::fs::read_to_string(path).map_err(|e| CoreError::io(path, e))?;
    serde_json::from_str(&text).map_err(|e| CoreError::Json {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// FNV-1a 64 over the contents (and lengths) of `paths`, in order: a fingerprint of a stage's
/// inputs. Returned as 16 hex digits.
pub fn hash_files(paths: &[std::path::PathBuf]) -> Result<String> {
    use std::io::Read;
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut feed = |bytes: &[u8]| {
        for &b in bytes {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01B3);
        }
    };
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
            feed(&buf[..n]);
        }
        feed(&len.to_le_bytes());
    }
    Ok(format!("{h:016x}"))
}
