//! `fipt run --method ipt`: the inverse-path-tracing baseline runs through the same pipeline
//! and writes the same output contract as FIPT (maps, re-renders, its own emitters,
//! `report.json`, `metrics.json`); a finished fit is reused, `--force` redoes it.
use fipt_cli::run_args;

fn read_json(p: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

#[test]
fn ipt_runs_through_fipt_run_and_is_evaluated() {
    let dir = std::env::temp_dir().join(format!("fipt-ipt-run-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (scene, out) = (dir.join("scene"), dir.join("out"));
    let c = fipt_cli::components();
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let synth = [
        "fipt",
        "synth",
        "cornell",
        "--out",
        &s(&scene),
        "--views",
        "6",
        "--val-views",
        "1",
        "--width",
        "40",
        "--height",
        "30",
        "--spp",
        "16",
    ];
    run_args(synth, &c).unwrap();
    let cfg = dir.join("run.toml");
    std::fs::write(
        &cfg,
        "[model]\nbrdf = \"fipt\"\n[plugins.ipt]\niterations = 300\nbatch = 2048\n\
         checkpoint_every = 20\n[render]\nspp = 4\nval_spp = 4\n",
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec![
            "fipt".to_string(),
            "run".into(),
            s(&scene),
            "--out".into(),
            s(&out),
            "--method".into(),
            "ipt".into(),
            "--preset".into(),
            "fast".into(),
            "--config".into(),
            s(&cfg),
        ];
        args.extend(extra.iter().map(|a| a.to_string()));
        run_args(args, &c)
    };
    run(&[]).unwrap();
    check_ipt_outputs(&out);
    // Run again: the finished fit is reused; --force starts it afresh.
    run(&[]).unwrap();
    assert_eq!(
        read_json(&out.join("report.json"))["fit"]["resumed_at_step"],
        300
    );
    run(&["--force"]).unwrap();
    assert_eq!(
        read_json(&out.join("report.json"))["fit"]["resumed_at_step"],
        0
    );
    // A misspelt method names the registered ones.
    let other = dir.join("other");
    let misspelt = [
        "fipt",
        "run",
        &s(&scene),
        "--out",
        &s(&other),
        "--method",
        "ipr",
    ];
    let err = format!("{:#}", run_args(misspelt, &c).unwrap_err());
    assert!(err.contains("ipr") && err.contains("ipt"), "{err}");
    // A bad setting names its key.
    std::fs::write(&cfg, "[plugins.ipt]\niterations = 0\n").unwrap();
    let err = format!("{:#}", run(&["--force"]).unwrap_err());
    assert!(err.contains("iterations"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The run's layout, the report's method, field and fit, the emitters the method found, and
/// the metrics.
fn check_ipt_outputs(out: &std::path::Path) {
    for f in [
        "report.json",
        "emitters.json",
        "emitters.obj",
        "metrics.json",
        "fit/ipt-state.bin",
        "views/val/000_kd.exr",
        "views/val/000_roughness.exr",
        "views/val/000_render.exr",
        "views/train/000_emission.exr",
    ] {
        assert!(out.join(f).is_file(), "missing {f}");
    }
    let report = read_json(&out.join("report.json"));
    assert_eq!(report["components"]["method"]["name"], "ipt");
    assert_eq!(report["components"]["material_field"], "ipt-table");
    assert_eq!(report["fit"]["steps"], 300);
    assert_eq!(report["fit"]["resumed_at_step"], 0);
    assert_eq!(
        report["fit"]["unknowns"]["groups_are"],
        "parts of the scene's id maps"
    );
    // The method estimates its own emitters: the light is found.
    let emitters = read_json(&out.join("emitters.json"));
    assert!(!emitters.as_array().unwrap().is_empty(), "{emitters}");
    let metrics = read_json(&out.join("metrics.json"));
    assert!(
        metrics["val"]["mean"]["kd_psnr"].as_f64().is_some(),
        "{metrics}"
    );
}
