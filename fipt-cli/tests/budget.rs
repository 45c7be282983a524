//! The training views' budget (`[render] train_pixels`) bounds the maps as it bounds the
//! re-renders: the same views get both, `maps.json` names them, `fipt eval` scores them, a
//! previous run's maps of the views left out are removed, and without a budget every view is
//! mapped again and the manifest goes.
mod common;
use common::{fipt, json, tiny_resumable_scene, tmp};
use std::path::Path;

fn mapped(dir: &Path, views: usize) -> Vec<usize> {
    (0..views)
        .filter(|k| dir.join(format!("{k:03}_kd.exr")).is_file())
        .collect()
}

#[test]
fn the_training_view_budget_bounds_the_maps_and_eval_scores_what_was_mapped() {
    let (dir, cfg) = tiny_resumable_scene("budget-scene", 300);
    let out = tmp("budget-run");
    let (d, o) = (dir.to_str().unwrap(), out.to_str().unwrap());
    let base = std::fs::read_to_string(&cfg).unwrap();
    let with = |name: &str, pixels: u32| {
        let p = dir.join(name);
        std::fs::write(&p, format!("{base}[render]\ntrain_pixels = {pixels}\n")).unwrap();
        p
    };
    let (all, capped) = (with("all.toml", 0), with("capped.toml", 800));
    let run = |cfg: &Path| {
        let (ok, stdout, err) = fipt(&["run", d, "--out", o, "--config", cfg.to_str().unwrap()]);
        assert!(ok, "{err}");
        format!("{stdout}{err}")
    };
    let train = out.join("views").join("train");
    let errors = out.join("eval").join("train");
    let scored = |split: &str| {
        json(&out.join("metrics.json"))[split]["views"]
            .as_array()
            .map_or(0, |v| v.len())
    };
    let check_all = |said: String| {
        assert!(!said.contains(" of 3 train views"), "{said}");
        assert_eq!(mapped(&train, 3), [0, 1, 2]);
        assert!(!train.join("maps.json").exists());
        assert_eq!(scored("train"), 3);
        assert!(errors.join("002_kd_error_x4.png").is_file());
    };
    // No budget: every view mapped and scored.
    check_all(run(&all));

    // 3 training views of 24 × 16 = 384 pixels: 800 pixels hold two (views 0 and 1). The
    // first run's maps, previews and error map of view 2 are another field's now: removed.
    let said = run(&capped);
    assert!(said.contains("maps: 2 of 3 train views"), "{said}");
    assert_eq!(mapped(&train, 3), [0, 1]);
    let left = |d: &Path| {
        std::fs::read_dir(d)
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with("002_"))
            .count()
    };
    assert_eq!(
        left(&train) + left(&train.join("preview")) + left(&errors),
        0
    );
    let rendered: Vec<usize> = (0..3)
        .filter(|k| train.join(format!("{k:03}_render.exr")).is_file())
        .collect();
    assert_eq!(rendered, [0, 1], "the re-render covers the mapped views");
    let m = json(&train.join("maps.json"));
    assert_eq!(m["views"], serde_json::json!([0, 1]));
    assert_eq!(
        (m["of"].as_u64(), m["train_pixels"].as_u64()),
        (Some(3), Some(800))
    );
    assert_eq!((scored("train"), scored("val")), (2, 1));
    assert!(json(&out.join("metrics.json"))["train"]["mean"]["kd_psnr"]
        .as_f64()
        .is_some());
    // `fipt eval` alone reads the manifest too.
    let (ok, _, err) = fipt(&["eval", d, o]);
    assert!(ok, "{err}");
    assert_eq!(scored("train"), 2);
    assert!(out.join("report.html").is_file());

    // The budget lifted again: every view mapped, the manifest gone.
    check_all(run(&all));
}
