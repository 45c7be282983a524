//! The pipeline without the CLI, FIPT registered by its crate: a run through `fipt_pipeline::run::run` on a tiny generated
//! scene, heard by an observer of our own; a second run reuses every stage.
use fipt_pipeline::observe::{Observer, ProgressSink};
use fipt_pipeline::run::{run, RunOutcome, RunRequest};
use fipt_pipeline::Components;

mod common;
use std::sync::Mutex;

/// Everything the pipeline said: notes, finished stages, progress indicators opened.
#[derive(Default)]
struct Heard {
    notes: Mutex<Vec<String>>,
    stages: Mutex<Vec<String>>,
    bars: Mutex<Vec<String>>,
}

struct Recorder(&'static Heard);

struct NoBar;

impl ProgressSink for NoBar {
    fn set_length(&self, _: u64) {}
    fn set_position(&self, _: u64) {}
    fn inc(&self, _: u64) {}
    fn set_message(&self, _: &str) {}
    fn finish(&self) {}
}

impl Observer for Recorder {
    fn note(&self, line: &str) {
        self.0.notes.lock().unwrap().push(line.to_string());
    }
    fn stage_done(&self, label: &str, _: f64) {
        self.0.stages.lock().unwrap().push(label.to_string());
    }
    fn progress(&self, what: &str, _: u64) -> Box<dyn ProgressSink> {
        self.0.bars.lock().unwrap().push(what.to_string());
        Box::new(NoBar)
    }
}

fn take(m: &Mutex<Vec<String>>) -> Vec<String> {
    std::mem::take(&mut *m.lock().unwrap())
}

#[test]
fn a_run_through_the_library_is_heard_and_reused() {
    let heard: &'static Heard = Box::leak(Box::default());
    assert!(fipt_pipeline::observe::set_observer(Box::new(Recorder(
        heard
    ))));
    let dir = std::env::temp_dir().join(format!("fipt-pipeline-lib-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (scene, config) = common::tiny_run(&dir, 3, "[train]\nsteps = 100\nbatch = 512\n");
    let mut request = RunRequest::new(&scene, dir.join("out"), "fast");
    request.config = Some(config);

    let RunOutcome::Finished(first) = run(
        &request,
        &fipt_eval::register(fipt_method::register(Components::builtin())),
    )
    .unwrap() else {
        panic!("an unsharded run finishes");
    };
    assert_eq!(first.method, "fipt");
    let emitters: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/emitters.json")).unwrap())
            .unwrap();
    assert!(first.lights >= 1 && first.lights == emitters.len());
    assert!(first.field.as_ref().is_some_and(|f| f.is_file()));
    assert!(first.metrics.is_some(), "the scene has ground truth");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/report.json")).unwrap())
            .unwrap();
    assert_eq!(report["status"], "complete");
    let names: Vec<&str> = first.stages.iter().map(|s| s.stage).collect();
    for stage in [
        "load",
        "bake",
        "train",
        "emitters",
        "maps",
        "re-render",
        "eval",
    ] {
        assert!(names.contains(&stage), "{stage} in {names:?}");
    }
    // What the CLI would print went to the observer.
    let stages = take(&heard.stages);
    assert!(stages.iter().any(|s| s == "bake") && stages.iter().any(|s| s == "train"));
    assert!(take(&heard.bars).iter().any(|b| b == "bake"));
    assert!(take(&heard.notes).iter().any(|n| n.starts_with("light 0:")));

    // Again: the bake and the training are reused, not redone.
    let RunOutcome::Finished(_) = run(
        &request,
        &fipt_eval::register(fipt_method::register(Components::builtin())),
    )
    .unwrap() else {
        panic!("finishes");
    };
    let notes = take(&heard.notes);
    assert!(
        notes.iter().any(|n| n.starts_with("reusing the bake")),
        "{notes:?}"
    );
    assert!(!take(&heard.stages).iter().any(|s| s == "bake"));
    let _ = std::fs::remove_dir_all(&dir);
}
