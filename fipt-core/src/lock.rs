//! An exclusive lock on an output folder: two runs writing one folder would silently mix or
//! overwrite each other's results.
//!
//! The lock is the file `DIR/.fipt.lock`, created exclusively, holding the holder's pid and
//! host. While it is held, another [`OutputLock::acquire`] is refused with a message naming
//! the holder. A lock left by a process that no longer runs on this host is stale and taken
//! over; a lock from another host cannot be checked and is refused (the message says how to
//! remove it). Dropping the lock removes the file.
use crate::error::{CoreError, Result};
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
    /// the file (e.g. "fipt run"). Refused while a shard of a stage ([`OutputLock::acquire_shard`])
    /// works in the folder.
    pub fn acquire(dir: &Path, what: &str) -> Result<OutputLock> {
        let lock = Self::acquire_named(dir, LOCK_FILE, what)?;
        let shards = std::fs::read_dir(dir).into_iter().flatten().flatten();
        for e in shards {
            let name = e.file_name().to_string_lossy().to_string();
            if name.starts_with(SHARD_LOCK_PREFIX) && name.ends_with(".lock") {
                if let Some(holder) = live_holder(&e.path()) {
                    return Err(in_use(dir, &holder, &e.path()));
                }
            }
        }
        Ok(lock)
    }

    /// The lock of one shard `name` (`.fipt.shard-K-of-N.lock`) of a stage in `dir`: the
    /// tasks of a job array write their views side by side, each under its own lock, but never
    /// beside a plain run of the folder (refused both ways: whoever comes second).
    pub fn acquire_shard(dir: &Path, index: usize, count: usize, what: &str) -> Result<OutputLock> {
        let name = format!("{SHARD_LOCK_PREFIX}{index}-of-{count}.lock");
        let lock = Self::acquire_named(dir, &name, what)?;
        let main = dir.join(LOCK_FILE);
        if let Some(holder) = live_holder(&main) {
            return Err(in_use(dir, &holder, &main));
        }
        Ok(lock)
    }

    /// The same with the lock file `name` in `dir`, alone.
    pub fn acquire_named(dir: &Path, name: &str, what: &str) -> Result<OutputLock> {
        output_folder(dir)?;
        std::fs::create_dir_all(dir).map_err(|e| CoreError::io(dir, e))?;
        let path = dir.join(name);
        let me = format!("pid {}\nhost {}\n{what}\n", std::process::id(), host_name());
        for _ in 0..3 {
            match place(&path, &me) {
                Ok(()) => return Ok(OutputLock { path }),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    if !path.exists() {
                        // Released between our attempt and the look: try again, removing nothing.
                        continue;
                    }
                    if let Some(holder) = live_holder(&path) {
                        return Err(in_use(dir, &holder, &path));
                    }
                    // Its holder is gone: take it over.
                    let _ = std::fs::remove_file(&path);
                }
                // Our temporary swept away by another run's clean-up: try again.
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
                Err(e) => return Err(CoreError::io(&path, e)),
            }
        }
        Err(CoreError::invalid(
            &path,
            "could not take over a stale lock",
        ))
    }
}

/// Creates lock file `path` holding `content`, failing with `AlreadyExists` when it exists.
/// The file appears whole or not at all: written to a temporary of a name of its own, then
/// hard-linked to `path`. On a file system without hard links it is created in place (a
/// process killed then leaves an empty lock, stale once a few seconds old).
fn place(path: &Path, content: &str) -> std::io::Result<()> {
    static SEQ: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(format!(".{}.{n}.lock.tmp", std::process::id()));
    let tmp = path.with_file_name(name);
    let linked = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .and_then(|mut f| std::io::Write::write_all(&mut f, content.as_bytes()))
        .and_then(|()| std::fs::hard_link(&tmp, path));
    let _ = std::fs::remove_file(&tmp);
    match linked {
        Err(e)
            if matches!(
                e.kind(),
                std::io::ErrorKind::Unsupported | std::io::ErrorKind::PermissionDenied
            ) =>
        {
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(path)?;
            std::io::Write::write_all(&mut f, content.as_bytes())
        }
        other => other,
    }
}

/// The prefix of a shard's lock file.
pub const SHARD_LOCK_PREFIX: &str = ".fipt.shard-";

/// The holder of lock file `path` ("pid P, host H") unless the file is absent or its holder
/// is known to be gone (a pid that no longer runs on this host).
fn live_holder(path: &Path) -> Option<String> {
    let held = std::fs::read_to_string(path).ok()?;
    let field = |k: &str| {
        held.lines()
            .find_map(|l| l.strip_prefix(k).map(|v| v.trim().to_string()))
    };
    let (pid, host) = (field("pid "), field("host "));
    let pid_num = pid.as_deref().and_then(|p| p.parse::<u32>().ok());
    // A lock without a holder (its writer killed before it wrote, where the lock could not be
    // linked into place whole, or by an older version) is stale once a few seconds old.
    let old = std::fs::metadata(path)
        .and_then(|m| m.modified())
        .ok()
        .and_then(|t| t.elapsed().ok())
        .is_some_and(|age| age.as_secs_f64() > 5.0);
    let stale = (pid_num.is_none() && old)
        || host.as_deref() == Some(host_name().as_str()) && pid_num.is_some_and(|p| !alive(p));
    (!stale).then(|| {
        format!(
            "pid {}, host {}",
            pid.unwrap_or_else(|| "?".into()),
            host.unwrap_or_else(|| "?".into())
        )
    })
}

fn in_use(dir: &Path, holder: &str, path: &Path) -> CoreError {
    CoreError::invalid(
        dir,
        format!(
            "the folder is in use by another fipt ({holder}): wait for it to finish, use another --out, or delete {} if that process is gone",
            path.display()
        ),
    )
}

/// What a folder holds that other commands must not write into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Owner {
    /// The output of a `fipt run` (its `report.json`, or its lock while it runs).
    Run,
    /// A scene (`train/transforms.json` or `cam.txt`).
    Scene,
}

impl Owner {
    /// What owns `dir`, if anything.
    pub fn of(dir: &Path) -> Option<Owner> {
        if dir.join("report.json").is_file() || dir.join(LOCK_FILE).is_file() {
            Some(Owner::Run)
        } else if dir.join("train/transforms.json").is_file() || dir.join("cam.txt").is_file() {
            Some(Owner::Scene)
        } else {
            None
        }
    }

    fn noun(self) -> &'static str {
        match self {
            Owner::Run => "the output folder of a `fipt run`",
            Owner::Scene => "a scene folder",
        }
    }
}

/// Refuses `what`'s output folder `out` when it is, or lies inside, a folder owned by one of
/// `refused` (only `fipt run` writes inside a run folder; a render or an export written into
/// one would be taken for the run's own files). The path is resolved first (`..`, symlinks of
/// the part that exists).
pub fn refuse_owned_output(out: &Path, what: &str, refused: &[Owner]) -> Result<()> {
    refuse_where(out, what, |owner, _| refused.contains(&owner))
}

/// What an output folder `out` already holds, before a command that does not own it (a render,
/// an export) writes into it: the warning to give, or None when it is new or empty. Files of
/// the same names are replaced; the others stay beside the new ones.
pub fn already_holds(out: &Path, what: &str) -> Option<String> {
    let n = std::fs::read_dir(out).ok()?.filter_map(|e| e.ok()).count();
    (n > 0).then(|| {
        format!(
            "{} already holds {n} entries: the {what}'s files replace those of the same names and the others stay beside them (give a new folder to keep outputs apart)",
            out.display()
        )
    })
}

/// Refuses an output folder `out` that is a file, or lies under one (`afile/sub`): the error
/// names the file and says what to give instead, where creating the folder would end in the
/// system's "File exists" or "Not a directory".
pub fn output_folder(out: &Path) -> Result<()> {
    for dir in out.ancestors().filter(|d| !d.as_os_str().is_empty()) {
        if dir.is_dir() {
            return Ok(());
        }
        if dir.exists() {
            let place = if dir == out {
                String::new()
            } else {
                format!(" (the output folder {} would lie under it)", out.display())
            };
            return Err(CoreError::invalid(
                dir,
                format!(
                    "is a file, not a folder{place}: give as the output a folder that does not exist yet (it is created) or an existing folder"
                ),
            ));
        }
    }
    Ok(())
}

/// The rule for a run's own output folder: it may be a run folder (resumed) but not lie inside
/// another, nor be or lie inside a scene folder.
pub fn refuse_nested_run(out: &Path) -> Result<()> {
    refuse_where(out, "run", |owner, is_self| {
        owner == Owner::Scene || !is_self
    })
}

/// `out` made absolute: `..` taken lexically, the part that exists resolved (symlinks), the
/// rest kept as given (a folder about to be made can be compared with one that exists).
pub fn resolved(out: &Path) -> Result<std::path::PathBuf> {
    let abs = std::path::absolute(out).map_err(|e| CoreError::io(out, e))?;
    // `..` taken lexically first (`nx/../R` is R even where `nx` does not exist).
    let mut lexical = std::path::PathBuf::new();
    for c in abs.components() {
        match c {
            std::path::Component::ParentDir => {
                lexical.pop();
            }
            std::path::Component::CurDir => {}
            other => lexical.push(other),
        }
    }
    let abs = lexical;
    // Resolve the part that exists, keep the rest as given.
    let mut existing = abs.as_path();
    let mut rest = vec![];
    while !existing.exists() {
        let (Some(parent), Some(name)) = (existing.parent(), existing.file_name()) else {
            break;
        };
        rest.push(name.to_os_string());
        existing = parent;
    }
    let mut resolved = existing
        .canonicalize()
        .unwrap_or_else(|_| existing.to_path_buf());
    for name in rest.iter().rev() {
        resolved.push(name);
    }
    Ok(resolved)
}

fn refuse_where(out: &Path, what: &str, refused: impl Fn(Owner, bool) -> bool) -> Result<()> {
    output_folder(out)?;
    let resolved = resolved(out)?;
    for dir in resolved.ancestors() {
        let is_self = dir == resolved;
        let Some(owner) = Owner::of(dir).filter(|o| refused(*o, is_self)) else {
            continue;
        };
        let place = if is_self {
            "is".to_string()
        } else {
            format!("lies inside {}, which is", dir.display())
        };
        let sibling = format!(
            "{}-{}",
            dir.file_name().unwrap_or_default().to_string_lossy(),
            what.replace(' ', "-")
        );
        return Err(CoreError::invalid(
            out,
            format!(
                "the {what} output folder {place} {}: write it to a folder of its own (e.g. {})",
                owner.noun(),
                dir.with_file_name(sibling).display()
            ),
        ));
    }
    Ok(())
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A new or empty output folder says nothing; one holding files says how many and that
    /// the others stay.
    #[test]
    fn an_output_folder_that_already_holds_files_is_named() {
        let d = dir("holds");
        assert_eq!(already_holds(&d, "render"), None);
        std::fs::create_dir_all(&d).unwrap();
        assert_eq!(already_holds(&d, "render"), None);
        std::fs::write(d.join("000_render.exr"), b"old").unwrap();
        let w = already_holds(&d, "render").unwrap();
        assert!(
            w.contains("already holds 1 entries") && w.contains("others stay"),
            "{w}"
        );
        let _ = std::fs::remove_dir_all(&d);
    }

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

    #[test]
    fn a_shard_and_a_plain_run_never_share_a_folder() {
        let d = dir("shards");
        let shard = OutputLock::acquire_shard(&d, 0, 3, "run --shard 0/3").unwrap();
        let other = OutputLock::acquire_shard(&d, 1, 3, "run --shard 1/3").unwrap();
        let err = OutputLock::acquire(&d, "run").unwrap_err().to_string();
        assert!(
            err.contains("in use") && err.contains(".fipt.shard-"),
            "{err}"
        );
        // The refused plain run left no lock behind.
        assert!(!d.join(LOCK_FILE).exists());
        drop((shard, other));
        let plain = OutputLock::acquire(&d, "run").unwrap();
        let err = OutputLock::acquire_shard(&d, 2, 3, "run --shard 2/3")
            .unwrap_err()
            .to_string();
        assert!(err.contains(LOCK_FILE), "{err}");
        assert!(!d.join(".fipt.shard-2-of-3.lock").exists());
        drop(plain);
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn outputs_inside_a_run_or_scene_folder_are_refused() {
        let d = dir("owned");
        let run = d.join("run");
        std::fs::create_dir_all(run.join("views/val")).unwrap();
        std::fs::write(run.join("report.json"), "{}").unwrap();
        let scene = d.join("scene");
        std::fs::create_dir_all(scene.join("train")).unwrap();
        std::fs::write(scene.join("train/transforms.json"), "{}").unwrap();
        let both = [Owner::Run, Owner::Scene];
        for bad in [
            run.clone(),
            run.join("views/val"),
            run.join("new/deeper"),
            d.join("scene/x/../y"),
            d.join("nx/../run/views"),
        ] {
            let err = refuse_owned_output(&bad, "render", &both)
                .unwrap_err()
                .to_string();
            assert!(err.contains("folder of its own"), "{err}");
        }
        // `..` out of the run folder and a sibling are fine; a scene's split when scenes are allowed.
        refuse_owned_output(&run.join("../renders"), "render", &both).unwrap();
        refuse_owned_output(&scene.join("val"), "render", &[Owner::Run]).unwrap();
        // A run resumes in its own folder, never inside another's or a scene's.
        refuse_nested_run(&run).unwrap();
        // A file where the folder should be, or above it: named, never "File exists".
        let file = d.join("afile");
        std::fs::write(&file, "x").unwrap();
        for out in [file.clone(), file.join("sub")] {
            let err = refuse_owned_output(&out, "render", &both)
                .unwrap_err()
                .to_string();
            assert!(
                err.contains("afile") && err.contains("is a file, not a folder"),
                "{err}"
            );
            let err = OutputLock::acquire(&out, "run").unwrap_err().to_string();
            assert!(err.contains("is a file, not a folder"), "{err}");
        }
        output_folder(&d.join("new/deeper")).unwrap();
        assert!(refuse_nested_run(&run.join("sub")).is_err());
        assert!(refuse_nested_run(&scene.join("out")).is_err());
        assert!(refuse_nested_run(&scene).is_err());
        std::fs::remove_dir_all(&d).ok();
    }
}
