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
    // 3 training views of 24 × 16 = 384 pixels: 800 pixels hold two of them (views 0 and 1).
    let base = std::fs::read_to_string(&cfg).unwrap();
    let capped = dir.join("capped.toml");
    std::fs::write(&capped, format!("{base}[render]\ntrain_pixels = 800\n")).unwrap();
    let train = out.join("views").join("train");
    // What a run of another field left there: maps of view 2, and a preview.
    std::fs::create_dir_all(train.join("preview")).unwrap();
    std::fs::write(train.join("002_kd.exr"), b"stale").unwrap();
    std::fs::write(train.join("preview").join("002_kd.png"), b"stale").unwrap();
    let (ok, stdout, err) = fipt(&["run", d, "--out", o, "--config", capped.to_str().unwrap()]);
    assert!(ok, "{err}");
    let said = format!("{stdout}{err}");
    assert!(said.contains("maps: 2 of 3 train views"), "{said}");
    assert_eq!(mapped(&train, 3), [0, 1]);
    assert!(!train.join("preview").join("002_kd.png").exists());
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
    let scored = |metrics: &serde_json::Value, split: &str| {
        metrics[split]["views"].as_array().map_or(0, |v| v.len())
    };
    let metrics = json(&out.join("metrics.json"));
    assert_eq!(scored(&metrics, "train"), 2);
    assert_eq!(scored(&metrics, "val"), 1);
    assert!(metrics["train"]["mean"]["kd_psnr"].as_f64().is_some());
    // `fipt eval` alone reads the manifest too.
    let (ok, _, err) = fipt(&["eval", d, o]);
    assert!(ok, "{err}");
    assert_eq!(scored(&json(&out.join("metrics.json")), "train"), 2);
    assert!(out.join("report.html").is_file());

    // No budget: every view mapped, the manifest gone.
    let all = dir.join("all.toml");
    std::fs::write(&all, format!("{base}[render]\ntrain_pixels = 0\n")).unwrap();
    let (ok, stdout, err) = fipt(&["run", d, "--out", o, "--config", all.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(
        !format!("{stdout}{err}").contains(" of 3 train views"),
        "{stdout}{err}"
    );
    assert_eq!(mapped(&train, 3), [0, 1, 2]);
    assert!(!train.join("maps.json").exists());
    assert_eq!(scored(&json(&out.join("metrics.json")), "train"), 3);
}
