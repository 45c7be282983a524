//! Progress bars and timing lines on stderr.
use indicatif::{ProgressBar, ProgressStyle};
use std::time::Instant;

/// A progress bar over `total` units, hidden when stderr is not a terminal.
pub fn bar(total: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(total);
    pb.set_style(
        ProgressStyle::with_template(
            "{msg:>10} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta} {per_sec}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
}

/// Prints `label: seconds` for a finished stage.
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
    pub fn done(self) -> f64 {
        let s = self.start.elapsed().as_secs_f64();
        eprintln!("{:<24} {:>8.2} s", self.label, s);
        s
    }
}
