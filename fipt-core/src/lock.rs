//! An exclusive lock on an output folder: two runs writing one folder would silently mix or
//! overwrite each other's results.
//!
//! The lock is the file `DIR/.fipt.lock`, created exclusively, holding the holder's pid and
//! host. While it is held, another [`OutputLock::acquire`] is refused with a message naming
//! the holder. A lock left by a process that no longer runs on this host is stale and taken
//! over; a lock from another host cannot be checked and is refused (the message says how to
//! remove it). Dropping the lock removes the file.
use crate::error::{CoreError, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The lock file's name inside the locked folder.
pub const LOCK_FILE: &str = ".fipt.lock";

/// A held lock; released on drop.
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
}

/// This machine's host name (`/proc/sys/kernel/hostname`, else `HOSTNAME`, else "unknown").
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "unknown".to_string())
}

/// Whether process `pid` runs on this machine (Linux: `/proc/<pid>` exists; elsewhere assumed).
fn alive(pid: u32) -> bool {
    if Path::new("/proc/self").exists() {
        Path::new(&format!("/proc/{pid}")).exists()
    } else {
        true
    }
}

impl OutputLock {
    /// Takes the lock on `dir` (created if absent) for this process, `what` naming the work in
    /// the file (e.g. "fipt run").
    pub fn acquire(dir: &Path, what: &str) -> Result<OutputLock> {
        Self::acquire_named(dir, LOCK_FILE, what)
    }

    /// The same with the lock file `name` in `dir`: work that may share a folder with other
    /// work (a shard of a stage: one lock per shard) takes its own.
    pub fn acquire_named(dir: &Path, name: &str, what: &str) -> Result<OutputLock> {
        std::fs::create_dir_all(dir).map_err(|e| CoreError::io(dir, e))?;
        let path = dir.join(name);
        let me = format!("pid {}\nhost {}\n{what}\n", std::process::id(), host_name());
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut f) => {
                    f.write_all(me.as_bytes())
                        .map_err(|e| CoreError::io(&path, e))?;
                    return Ok(OutputLock { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let held = std::fs::read_to_string(&path).unwrap_or_default();
                    let field = |k: &str| {
                        held.lines()
                            .find_map(|l| l.strip_prefix(k).map(|v| v.trim().to_string()))
                    };
                    let (pid, host) = (field("pid "), field("host "));
                    let pid_num = pid.as_deref().and_then(|p| p.parse::<u32>().ok());
                    let stale = host.as_deref() == Some(host_name().as_str())
                        && pid_num.is_some_and(|p| !alive(p));
                    if stale {
                        // Its holder is gone: take it over.
                        let _ = std::fs::remove_file(&path);
                        continue;
                    }
                    return Err(CoreError::invalid(
                        dir,
                        format!(
                            "the folder is in use by another fipt (pid {}, host {}): wait for it to finish, use another --out, or delete {} if that process is gone",
                            pid.unwrap_or_else(|| "?".into()),
                            host.unwrap_or_else(|| "?".into()),
                            path.display()
                        ),
                    ));
                }
                Err(e) => return Err(CoreError::io(&path, e)),
            }
        }
        Err(CoreError::invalid(
            &path,
            "could not take over a stale lock",
        ))
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("fipt-lock-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn held_locks_are_refused_stale_ones_taken_over_and_drop_releases() {
        let d = dir("a");
        let lock = OutputLock::acquire(&d, "test").unwrap();
        let err = OutputLock::acquire(&d, "test").unwrap_err().to_string();
        assert!(
            err.contains(&format!("pid {}", std::process::id())) && err.contains(LOCK_FILE),
            "{err}"
        );
        drop(lock);
        assert!(!d.join(LOCK_FILE).exists());
        // A lock of a process that is gone (pid beyond the kernel's maximum) is taken over.
        std::fs::write(
            d.join(LOCK_FILE),
            format!("pid 4294967295\nhost {}\nfipt run\n", host_name()),
        )
        .unwrap();
        let lock = OutputLock::acquire(&d, "test").unwrap();
        let held = std::fs::read_to_string(d.join(LOCK_FILE)).unwrap();
        assert!(
            held.contains(&format!("pid {}", std::process::id())),
            "{held}"
        );
        drop(lock);
        // Another host's lock cannot be checked: refused.
        std::fs::write(d.join(LOCK_FILE), "pid 1\nhost elsewhere\nfipt run\n").unwrap();
        let err = OutputLock::acquire(&d, "test").unwrap_err().to_string();
        assert!(err.contains("host elsewhere"), "{err}");
        std::fs::remove_dir_all(&d).ok();
    }
}
