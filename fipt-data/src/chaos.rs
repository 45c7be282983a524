//! Fault injection for the chaos tests: a process that SIGKILLs itself at a chosen moment of a
//! chosen stage, so that "killed anywhere, it resumes to the same outputs" is tested at every
//! stage, deterministically, instead of at moments a timer happens to hit.
//!
//! The moments are the changes a run makes on disk: the start of each stage of the run's
//! report (`fipt_pipeline::observe::begin`; `start` before the first) and, inside it, each atomic write before its temporary is filled,
//! before it is renamed into place, and after. Between two such moments nothing on disk
//! changes, so killing at each of them covers every state a kill can leave.
//!
//! Off unless the environment asks:
//! - `FIPT_CHAOS_LOG=FILE` appends one line per moment, `<stage>#<occurrence> <n>` (the n-th
//!   moment of the occurrence-th stage of that name, from 0 at its start);
//! - `FIPT_CHAOS_KILL=<stage>#<occurrence>:<n>` kills the process at that moment.
use std::collections::HashMap;
use std::io::Write;
use std::sync::{Mutex, OnceLock};

struct Settings {
    log: Option<std::path::PathBuf>,
    kill: Option<(String, u64)>,
}

#[derive(Default)]
struct State {
    /// The stage running, with its occurrence (`train#2`); `start#1` before the first.
    stage: String,
    seen: HashMap<String, u32>,
    moment: u64,
}

fn settings() -> &'static Settings {
    static S: OnceLock<Settings> = OnceLock::new();
    S.get_or_init(|| Settings {
        log: std::env::var_os("FIPT_CHAOS_LOG").map(Into::into),
        kill: std::env::var("FIPT_CHAOS_KILL").ok().and_then(|v| {
            let (stage, n) = v.rsplit_once(':')?;
            Some((stage.to_string(), n.parse().ok()?))
        }),
    })
}

fn state() -> &'static Mutex<State> {
    static S: OnceLock<Mutex<State>> = OnceLock::new();
    S.get_or_init(|| {
        Mutex::new(State {
            stage: "start#1".into(),
            ..Default::default()
        })
    })
}

fn enabled() -> bool {
    let s = settings();
    s.log.is_some() || s.kill.is_some()
}

/// A stage named `label` starts (its moment 0).
pub fn stage_started(label: &str) {
    if !enabled() {
        return;
    }
    {
        let mut st = state().lock().unwrap_or_else(|e| e.into_inner());
        let seen = st.seen.entry(label.to_string()).or_insert(0);
        *seen += 1;
        let occurrence = *seen;
        st.stage = format!("{label}#{occurrence}");
        st.moment = 0;
    }
    moment_now();
}

/// A moment of the running stage (an atomic write's step).
pub fn moment() {
    if !enabled() {
        return;
    }
    state().lock().unwrap_or_else(|e| e.into_inner()).moment += 1;
    moment_now();
}

fn moment_now() {
    let (stage, n) = {
        let st = state().lock().unwrap_or_else(|e| e.into_inner());
        (st.stage.clone(), st.moment)
    };
    let s = settings();
    if let Some(log) = &s.log {
        if let Ok(mut f) = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(log)
        {
            let _ = writeln!(f, "{stage} {n}");
        }
    }
    if s.kill.as_ref().is_some_and(|(k, m)| *k == stage && *m == n) {
        kill_self();
    }
}

/// SIGKILL to this process (no destructor runs, nothing is flushed), as a user's `kill -9`.
fn kill_self() -> ! {
    let pid = std::process::id().to_string();
    let _ = std::process::Command::new("kill")
        .args(["-KILL", &pid])
        .status();
    // The signal is on its way; where `kill` is missing, abort (as abrupt).
    std::thread::sleep(std::time::Duration::from_secs(5));
    std::process::abort()
}
