//! A child `fipt run` of `fipt sweep` ends when its parent is gone.

/// The environment variable naming the process a `fipt run` ends with.
pub const PARENT_ENV: &str = "FIPT_PARENT_PID";

/// When [`PARENT_ENV`] names this process's parent, watches it from a thread and ends this
/// process (as a kill would: finished stages stay, the rest resumes) once the parent is gone.
pub fn die_with_parent() {
    #[cfg(unix)]
    {
        let Some(parent) = std::env::var(PARENT_ENV)
            .ok()
            .and_then(|p| p.parse::<u32>().ok())
        else {
            return;
        };
        if std::os::unix::process::parent_id() != parent {
            std::process::exit(137);
        }
        std::thread::spawn(move || loop {
            std::thread::sleep(std::time::Duration::from_millis(200));
            if std::os::unix::process::parent_id() != parent {
                crate::note!("the parent process {parent} is gone: stopping");
                std::process::exit(137);
            }
        });
    }
}
