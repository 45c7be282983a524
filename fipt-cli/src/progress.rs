//! The terminal's [`Observer`]: notes and stage timings on stderr, progress bars (hidden when
//! stderr is not a terminal).
pub use fipt_pipeline::observe::{bar, Stage};
use fipt_pipeline::observe::{Observer, ProgressSink};
use indicatif::{ProgressBar, ProgressStyle};

/// Writes what the pipeline says to stderr.
pub struct Terminal;

impl Observer for Terminal {
    fn note(&self, line: &str) {
        eprintln!("{line}");
    }
    fn stage_done(&self, label: &str, seconds: f64) {
        eprintln!("{label:<24} {seconds:>8.2} s");
    }
    fn progress(&self, what: &str, total: u64) -> Box<dyn ProgressSink> {
        let pb = ProgressBar::new(total);
        pb.set_style(
            ProgressStyle::with_template(
                "{msg:>10} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta} {per_sec}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        pb.set_message(what.to_string());
        Box::new(Bar(pb))
    }
}

struct Bar(ProgressBar);

impl ProgressSink for Bar {
    fn set_length(&self, total: u64) {
        self.0.set_length(total);
    }
    fn set_position(&self, done: u64) {
        self.0.set_position(done);
    }
    fn inc(&self, by: u64) {
        self.0.inc(by);
    }
    fn set_message(&self, what: &str) {
        self.0.set_message(what.to_string());
    }
    fn finish(&self) {
        self.0.finish_and_clear();
    }
}
