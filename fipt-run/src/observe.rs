//! What a running pipeline tells its user, without printing: notes (decisions, warnings, a
//! stage's figures), stage timings and progress go to the process's [`Observer`]. The library
//! prints nothing; the `fipt` binary installs one that writes to the terminal, a program that
//! embeds the pipeline installs its own (or none: then everything is dropped).
use std::sync::OnceLock;
use std::time::Instant;

/// Receives what the pipeline has to say while it runs. Called from worker threads.
pub trait Observer: Send + Sync {
    /// A line for the user: a decision and its reason, a warning, a stage's figures.
    fn note(&self, line: &str);
    /// A stage (`label`) finished after `seconds`.
    fn stage_done(&self, label: &str, seconds: f64);
    /// A progress indicator over `total` units of the work named `what`.
    fn progress(&self, what: &str, total: u64) -> Box<dyn ProgressSink>;
}

/// One progress indicator, as [`Observer::progress`] made it.
pub trait ProgressSink: Send + Sync {
    fn set_length(&self, total: u64);
    fn set_position(&self, done: u64);
    fn inc(&self, by: u64);
    fn set_message(&self, what: &str);
    /// The work is over: the indicator goes away.
    fn finish(&self);
}

static OBSERVER: OnceLock<Box<dyn Observer>> = OnceLock::new();

/// Installs the process's observer; false (and `observer` dropped) when one already is.
pub fn set_observer(observer: Box<dyn Observer>) -> bool {
    OBSERVER.set(observer).is_ok()
}

/// Tells the observer, if any, a line.
pub fn note(line: impl AsRef<str>) {
    if let Some(o) = OBSERVER.get() {
        o.note(line.as_ref());
    }
}

/// `note!("{} views", n)`: [`note`] with `format!` arguments.
#[macro_export]
macro_rules! note {
    ($($arg:tt)*) => { $crate::observe::note(format!($($arg)*)) };
}

/// A progress indicator (dropped quietly without an observer).
pub struct Progress(Option<Box<dyn ProgressSink>>);

impl Progress {
    pub fn set_length(&self, total: u64) {
        self.0.iter().for_each(|p| p.set_length(total));
    }
    pub fn set_position(&self, done: u64) {
        self.0.iter().for_each(|p| p.set_position(done));
    }
    pub fn inc(&self, by: u64) {
        self.0.iter().for_each(|p| p.inc(by));
    }
    pub fn set_message(&self, what: &str) {
        self.0.iter().for_each(|p| p.set_message(what));
    }
    pub fn finish_and_clear(&self) {
        self.0.iter().for_each(|p| p.finish());
    }
}

/// A progress indicator over `total` units of `what`.
pub fn bar(total: u64, what: &str) -> Progress {
    Progress(OBSERVER.get().map(|o| o.progress(what, total)))
}

/// The start of a stage of a run's report (`load`, `bake`, `train`, …): its clock, and the
/// moment fault injection counts the stage's moments from ([`fipt_core::chaos`]).
pub fn begin(stage: &str) -> Instant {
    fipt_core::chaos::stage_started(stage);
    REUSED.with(|r| r.set(None));
    Instant::now()
}

thread_local! {
    /// What the stage begun last on this thread reused: the seconds its result took to compute
    /// (NaN when not known).
    static REUSED: std::cell::Cell<Option<f64>> = const { std::cell::Cell::new(None) };
}

/// The stage under way reuses a finished result, which took `computed_seconds` to compute;
/// its record in `report.json` says so and keeps that time.
pub fn reused(computed_seconds: Option<f64>) {
    REUSED.with(|r| r.set(Some(computed_seconds.unwrap_or(f64::NAN))));
}

/// What [`reused`] said since the stage began (and forgets it).
pub fn take_reused() -> Option<f64> {
    REUSED.with(|r| r.take())
}

/// Times a stage and tells the observer when it is done.
pub struct Stage {
    label: String,
    start: Instant,
}

impl Stage {
    pub fn start(label: &str) -> Self {
        Stage {
            label: label.to_string(),
            start: Instant::now(),
        }
    }
    /// The stage's seconds, told to the observer.
    pub fn done(self) -> f64 {
        let s = self.start.elapsed().as_secs_f64();
        if let Some(o) = OBSERVER.get() {
            o.stage_done(&self.label, s);
        }
        s
    }
}
