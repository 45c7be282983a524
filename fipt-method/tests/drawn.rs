//! A run whose training set and search read a share of the pixels (their caps bind) bakes and
//! refines only the pixels they read, and its results are those of the same run over a bake of
//! every pixel (`fipt bake`, reused): metrics, emitters, maps and re-renders bit for bit.
use fipt_core::image::BadPixelPolicy;
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::shading::Shard;
use fipt_pipeline::bake::{bake_only, BakeRequest};
use fipt_pipeline::run::{run, RunOutcome, RunRequest};
use fipt_pipeline::Components;

mod common;
use std::path::Path;

fn read(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn manifest(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&read(&dir.join("manifest.json"))).unwrap()
}

#[test]
fn a_run_bakes_what_it_reads_and_gets_what_a_whole_bake_gives() {
    let dir = std::env::temp_dir().join(format!("fipt-pipeline-drawn-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // 1,536 pixels: the set keeps 512 (0.01 × 100 × 512), the search 300.
    let extra = "[search]\nmax_pixels = 300\n[train]\nsteps = 100\nbatch = 512\nset_cap = 0.01\n";
    let (scene, config) = common::tiny_run(&dir, 4, extra);
    let components = fipt_eval::register(fipt_method::register(Components::builtin()));
    let finish = |out: &Path| {
        let mut request = RunRequest::new(&scene, out, "fast");
        request.config = Some(config.clone());
        let RunOutcome::Finished(s) = run(&request, &components).unwrap() else {
            panic!("an unsharded run finishes");
        };
        s
    };
    let drawn = dir.join("drawn");
    finish(&drawn);
    // The bake and the refinement hold the drawn share only.
    for stage in ["bake", "refine1"] {
        let m = manifest(&drawn.join(stage));
        let share = m["pixels"]["share"].as_f64().unwrap_or(1.0);
        assert!(share > 0.2 && share < 0.6, "{stage}: {m}");
    }
    // The same run over a bake of every pixel, made first by `fipt bake`.
    let whole = dir.join("whole");
    let request = BakeRequest {
        scene: scene.clone(),
        out: whole.clone(),
        preset: "fast".into(),
        config: Some(config.clone()),
        bad_pixels: BadPixelPolicy::Reject,
        force: false,
        brdf: ReflectanceModel::Principled,
        shard: Shard::ALL,
    };
    bake_only(request, &components).unwrap();
    assert!(manifest(&whole.join("bake")).get("pixels").is_none());
    finish(&whole);
    assert!(
        manifest(&whole.join("bake")).get("pixels").is_none(),
        "the whole bake was reused"
    );
    // Every map and re-render, the metrics and the emitters (the fields' files differ only in
    // the provenance they record: the shadings' fingerprints).
    let mut files = vec!["metrics.json".to_string(), "emitters.json".to_string()];
    for split in ["train", "val"] {
        for e in std::fs::read_dir(drawn.join("views").join(split)).unwrap() {
            let e = e.unwrap();
            if e.path().is_file() {
                files.push(format!("views/{split}/{}", e.file_name().to_string_lossy()));
            }
        }
    }
    assert!(files.len() > 10, "{files:?}");
    for file in &files {
        assert!(
            read(&drawn.join(file)) == read(&whole.join(file)),
            "{file} differs between the drawn and the whole bake"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
