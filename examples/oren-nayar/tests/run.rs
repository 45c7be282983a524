//! The external reflectance model runs through `fipt run`: on a `cornell` rendered with it
//! (`fipt synth --brdf oren-nayar`), a run whose `[model] brdf` names it bakes, trains, refines
//! and re-renders under it, reports it, and recovers the diffuse albedo that a run under the
//! built-in `principled` model (Burley's lobe, brighter at σ ≈ 1) cannot.
use fipt_cli::{run_args, Components};
use oren_nayar::register;
use std::path::Path;

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// Runs `fipt run` on `scene` under `brdf`; returns (train kd PSNR, report.json).
fn run(c: &Components, dir: &Path, scene: &Path, brdf: &str) -> (f64, serde_json::Value) {
    let (cfg, out) = (dir.join(format!("{brdf}.toml")), dir.join(brdf));
    std::fs::write(
        &cfg,
        format!(
            "[model]\nbrdf = \"{brdf}\"\n[bake]\ndiffuse_samples = 64\n\
             specular_samples = [4, 4, 4, 4, 4, 4]\n[render]\nspp = 4\nval_spp = 4\n"
        ),
    )
    .unwrap();
    let args = [
        "fipt",
        "run",
        &s(scene),
        "--out",
        &s(&out),
        "--preset",
        "fast",
    ];
    run_args(args.into_iter().chain(["--config", &s(&cfg)]), c).unwrap();
    let m = json(&out.join("metrics.json"));
    (
        m["train"]["mean"]["kd_psnr"].as_f64().unwrap(),
        json(&out.join("report.json")),
    )
}

#[test]
fn the_external_model_runs_through_fipt_run_and_recovers_its_albedo() {
    let dir = std::env::temp_dir().join(format!("fipt-oren-nayar-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let scene = dir.join("scene");
    let c = register(fipt_cli::components());
    let synth = [
        "fipt",
        "synth",
        "cornell",
        "--brdf",
        "oren-nayar",
        "--views",
        "8",
        "--val-views",
        "1",
        "--width",
        "48",
        "--height",
        "36",
        "--spp",
        "32",
    ];
    run_args(synth.into_iter().chain(["--out", &s(&scene)]), &c).unwrap();
    let (kd_on, report) = run(&c, &dir, &scene, "oren-nayar");
    assert_eq!(report["components"]["reflectance_model"], "oren-nayar");
    assert_eq!(report["modeled"]["reflectance_model"], "oren-nayar");
    let cache = report["modeled"]["diffuse_cache"]
        .as_str()
        .unwrap_or_default();
    assert!(cache.starts_with("diffuse cache off"), "{report}");
    let registered = report["components"]["registered"].to_string();
    assert!(
        registered.contains("reflectance model `oren-nayar`"),
        "{registered}"
    );
    let (kd_principled, _) = run(&c, &dir, &scene, "principled");
    eprintln!("cornell rendered with oren-nayar: train kd {kd_on:.2} dB under oren-nayar, {kd_principled:.2} dB under principled");
    assert!(kd_on >= 18.0, "kd {kd_on:.2} dB under its own model");
    assert!(
        kd_on >= kd_principled + 4.0,
        "{kd_on:.2} vs {kd_principled:.2} dB"
    );
    // An unknown model names the registered ones, the external one included.
    std::fs::write(dir.join("bad.toml"), "[model]\nbrdf = \"ward\"\n").unwrap();
    let bad = [
        "fipt",
        "run",
        &s(&scene),
        "--out",
        &s(&dir.join("x")),
        "--config",
        &s(&dir.join("bad.toml")),
    ];
    let err = format!("{:#}", run_args(bad, &c).unwrap_err());
    assert!(err.contains("ward") && err.contains("oren-nayar"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
