//! The plug-in runs through `fipt run`: on a generated `cornell`, `[pipeline] extractor =
//! "brightest"` finds the ceiling light (its 2 triangles, radiance (17, 12, 4)) and the report
//! names the component; an unknown setting is an error naming it.
use brightest_emitters::register;
use fipt_cli::run_args;

#[test]
fn the_plugged_extractor_finds_the_light_through_fipt_run() {
    let dir = std::env::temp_dir().join(format!("fipt-plugin-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (scene, out) = (dir.join("scene"), dir.join("out"));
    let c = register(fipt_cli::components());
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    run_args(
        [
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
            "32",
            "--height",
            "24",
            "--spp",
            "16",
        ],
        &c,
    )
    .unwrap();
    let cfg = dir.join("run.toml");
    std::fs::write(
        &cfg,
        "[model]\nbrdf = \"fipt\"\n[pipeline]\nextractor = \"brightest\"\n\
         [plugins.brightest]\nmin_luminance = 5.0\n\
         [bake]\ndiffuse_samples = 16\nspecular_samples = [4, 4, 4, 4, 4, 4]\n\
         [refine]\ndiffuse_samples = 16\nspecular_samples = [4, 4, 4, 4, 4, 4]\nlight_samples = 4\n\
         [train]\nsteps = 200\nbatch = 1024\n[render]\nspp = 2\nval_spp = 2\n",
    )
    .unwrap();
    run_args(
        [
            "fipt",
            "run",
            &s(&scene),
            "--out",
            &s(&out),
            "--preset",
            "fast",
            "--config",
            &s(&cfg),
        ],
        &c,
    )
    .unwrap();
    check_light_and_report(&out);
    // A misspelt plug-in setting fails before any work, naming the key.
    std::fs::write(
        &cfg,
        "[pipeline]\nextractor = \"brightest\"\n[plugins.brightest]\nmin_lum = 5.0\n",
    )
    .unwrap();
    let err = run_args(
        [
            "fipt",
            "run",
            &s(&scene),
            "--out",
            &s(&dir.join("bad")),
            "--config",
            &s(&cfg),
        ],
        &c,
    )
    .unwrap_err();
    assert!(format!("{err:#}").contains("min_lum"), "{err:#}");
    // The stock binary's registry does not know it.
    let err = run_args(
        [
            "fipt",
            "run",
            &s(&scene),
            "--out",
            &s(&dir.join("bad")),
            "--config",
            &s(&cfg),
        ],
        &fipt_cli::components(),
    )
    .unwrap_err();
    assert!(format!("{err:#}").contains("not registered"), "{err:#}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The one light (the ceiling quad's 2 triangles, radiance (17, 12, 4)) and the report's
/// extractor.
fn check_light_and_report(out: &std::path::Path) {
    let e: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("emitters.json")).unwrap()).unwrap();
    let lights = e.as_array().unwrap();
    assert_eq!(lights.len(), 1, "{e}");
    assert_eq!(lights[0]["triangles"].as_array().unwrap().len(), 2, "{e}");
    for (ch, want) in [17.0, 12.0, 4.0].iter().enumerate() {
        let got = lights[0]["mean_radiance"][ch].as_f64().unwrap();
        assert!((got - want).abs() < 0.05 * want, "radiance {got} vs {want}");
    }
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["components"]["extractor"]["name"], "brightest");
    assert_eq!(
        report["components"]["extractor"]["implementation"],
        "brightest-pixels"
    );
}
