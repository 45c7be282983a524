//! The method plug-in runs through `fipt run` and writes the same output contract as FIPT: on a
//! generated `cornell`, the maps, the re-renders, the emitters (found by the built-in extractor
//! on the fitted mask), `report.json` naming the method, and `metrics.json` from the same
//! evaluation.
use fipt_cli::{run_args, Components};
use voxel_lambert::register;

/// A test's folder (emptied), its small generated `cornell` (8 training views and 1 validation
/// view of 48×36), its output folder, its run config (`head` over quick settings) and the
/// components with the plug-ins registered.
struct Setup {
    dir: std::path::PathBuf,
    scene: std::path::PathBuf,
    out: std::path::PathBuf,
    cfg: std::path::PathBuf,
    c: Components,
}

fn setup(name: &str, head: &str) -> Setup {
    let dir = std::env::temp_dir().join(format!("{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (scene, out, cfg) = (dir.join("scene"), dir.join("out"), dir.join("run.toml"));
    let c = register(fipt_cli::components());
    let size = [
        "--views",
        "8",
        "--val-views",
        "1",
        "--width",
        "48",
        "--height",
        "36",
    ];
    let synth = [
        "fipt",
        "synth",
        "cornell",
        "--out",
        scene.to_str().unwrap(),
        "--spp",
        "32",
    ];
    run_args(synth.into_iter().chain(size), &c).unwrap();
    std::fs::write(
        &cfg,
        format!(
            "[model]\nbrdf = \"fipt\"\n{head}[bake]\ndiffuse_samples = 64\nspecular_samples = [4, 4, 4, 4, 4, 4]\n[render]\nspp = 4\nval_spp = 4\n"
        ),
    )
    .unwrap();
    Setup {
        dir,
        scene,
        out,
        cfg,
        c,
    }
}

#[test]
fn the_plugged_method_runs_through_fipt_run_and_is_evaluated() {
    let Setup {
        dir,
        scene,
        out,
        cfg,
        c,
    } = setup(
        "fipt-voxel",
        "[pipeline]\nmethod = \"voxel-lambert\"\n[plugins.voxel-lambert]\ncell_footprints = 3.0\n",
    );
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
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
    check_outputs(&out);
    // An unknown method names the registered ones.
    std::fs::write(&cfg, "[pipeline]\nmethod = \"nerf\"\n").unwrap();
    let err = run_args(
        [
            "fipt",
            "run",
            &s(&scene),
            "--out",
            &s(&dir.join("x")),
            "--config",
            &s(&cfg),
        ],
        &c,
    )
    .unwrap_err();
    assert!(format!("{err:#}").contains("voxel-lambert"), "{err:#}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The run's layout, its report (method, field, stages), the light found from the fitted mask,
/// and the accuracy floors.
fn check_outputs(out: &std::path::Path) {
    for f in [
        "report.json",
        "emitters.json",
        "emitters.obj",
        "metrics.json",
        "views/val/000_kd.exr",
        "views/val/000_render.exr",
        "views/train/000_emission.exr",
    ] {
        assert!(out.join(f).is_file(), "missing {f}");
    }
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["components"]["method"]["name"], "voxel-lambert");
    assert_eq!(
        report["components"]["material_field"],
        "voxel-lambert-table"
    );
    let stages: Vec<&str> = report["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["stage"].as_str().unwrap())
        .collect();
    assert_eq!(
        stages,
        [
            "load",
            "bake",
            "fit",
            "emitters",
            "maps",
            "re-render",
            "eval"
        ]
    );
    // The light is found from the fitted mask by the built-in extractor: the brightest light is
    // the ceiling lamp (its 2 triangles, radiance (17, 12, 4)). The baseline's crude mask also
    // flags a ceiling triangle beside it and a face of the red block (measured: 12 % of the
    // power), which the neural mask does not.
    let e: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("emitters.json")).unwrap()).unwrap();
    let lights = e.as_array().unwrap();
    assert_eq!(lights[0]["triangles"].as_array().unwrap().len(), 2, "{e}");
    for (ch, want) in [17.0, 12.0, 4.0].iter().enumerate() {
        let got = lights[0]["mean_radiance"][ch].as_f64().unwrap();
        assert!((got - want).abs() < 0.05 * want, "radiance {got} vs {want}");
    }
    let power = |l: &serde_json::Value| l["power"][0].as_f64().unwrap();
    let total: f64 = lights.iter().map(power).sum();
    assert!(power(&lights[0]) > 0.8 * total, "{e}");
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    let kd = m["train"]["mean"]["kd_psnr"].as_f64().unwrap();
    let iou = m["train"]["mean"]["emission_iou"].as_f64().unwrap();
    eprintln!("voxel-lambert on cornell: train kd {kd:.2} dB, emitter IoU {iou:.2}");
    // Measured: kd 14.35 dB (FIPT on this scene: ~20), IoU 0.44 (the false ceiling triangle).
    assert!(kd >= 12.0 && iou >= 0.3, "kd {kd:.2} dB, IoU {iou:.2}");
}

/// The table as FIPT's trainer: FIPT's rounds (bake, search, emitters, refinement) run with
/// `[pipeline] trainer = "voxel-table"`; the round's manifest names the trainer, the maps are
/// the table's (σ = 1 everywhere), the emitters are found from its mask, and `fipt export`
/// reloads the field through the trainer, which a binary without it cannot.
#[test]
fn the_plugged_trainer_runs_in_fipts_rounds_and_reloads_its_field() {
    let Setup {
        dir,
        scene,
        out,
        cfg,
        c,
    } = setup(
        "fipt-voxel-trainer",
        "[pipeline]\ntrainer = \"voxel-table\"\n[plugins.voxel-table]\ncell_footprints = 3.0\n",
    );
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let run = [
        "fipt",
        "run",
        &s(&scene),
        "--out",
        &s(&out),
        "--preset",
        "fast",
        "--config",
        &s(&cfg),
    ];
    run_args(run, &c).unwrap();
    let read = |p: std::path::PathBuf| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let report = read(out.join("report.json"));
    assert_eq!(report["components"]["method"]["name"], "fipt");
    assert_eq!(
        report["components"]["material_field"],
        "voxel-lambert-table"
    );
    assert_eq!(report["fit"]["train"]["trainer"], "voxel-table");
    assert!(out.join("train/voxels.json").is_file());
    let sigma =
        fipt_core::image::Image::read_exr(&out.join("views/val/000_roughness.exr")).unwrap();
    assert!(sigma.data.iter().all(|p| p.x == 0.0 || p.x == 1.0));
    let m = read(out.join("metrics.json"));
    let kd = m["train"]["mean"]["kd_psnr"].as_f64().unwrap();
    let iou = m["train"]["mean"]["emission_iou"].as_f64().unwrap();
    eprintln!("voxel-table in FIPT's rounds on cornell: train kd {kd:.2} dB, emitter IoU {iou:.2}");
    // Measured: kd 17.56 dB (the same table as its own method on the bake: 14.35), IoU 0.44.
    assert!(kd >= 12.0 && iou >= 0.3, "kd {kd:.2} dB, IoU {iou:.2}");
    // Re-run: every stage reused. The `[train]` settings that choose the set's pixels are not
    // the trainer's, yet a change of them asks for the training again.
    let manifest = || read(out.join("train/manifest.json"));
    let first = manifest();
    run_args(run, &c).unwrap();
    assert_eq!(manifest()["inputs"], first["inputs"]);
    assert!(
        read(out.join("report.json"))["stages_reused"]
            .as_u64()
            .unwrap()
            >= 5
    );
    let text = std::fs::read_to_string(&cfg).unwrap();
    std::fs::write(&cfg, format!("{text}[train]\nset_cap = 0.5\n")).unwrap();
    run_args(run, &c).unwrap();
    assert_ne!(manifest()["request"], first["request"]);
    let stages = read(out.join("report.json"))["stages"].clone();
    let train = stages
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["stage"] == "train");
    assert_eq!(train.unwrap()["reused"], false, "{stages}");
    // All pixels are kept at either cap: the same set.
    assert_eq!(manifest()["inputs"], first["inputs"]);
    // The field reloads through the trainer its manifest names.
    let glb = dir.join("export");
    let export = [
        "fipt",
        "export",
        &s(&out),
        "--out",
        &s(&glb),
        "--format",
        "glb",
    ];
    run_args(export, &c).unwrap();
    assert!(std::fs::read_dir(&glb).unwrap().count() > 0);
    let err = run_args(export, &fipt_cli::components()).unwrap_err();
    assert!(format!("{err:#}").contains("voxel-table"), "{err:#}");
    // `fipt train` trains with the run config's trainer (on the bake alone: no search
    // targets); the maps come without the hash-grid field's factorised re-render, and `--steps`
    // is refused for a trainer without that setting.
    let train = [
        "fipt",
        "train",
        &s(&scene),
        "--out",
        &s(&out),
        "--config",
        &s(&cfg),
    ];
    run_args(train, &c).unwrap();
    assert_eq!(manifest()["trainer"], "voxel-table");
    assert!(out.join("train/views/train/000_kd.exr").is_file());
    assert!(!out.join("train/views/train/000_render.exr").exists());
    let err = run_args(train.into_iter().chain(["--steps", "5"]), &c).unwrap_err();
    assert!(format!("{err:#}").contains("no `steps` setting"), "{err:#}");
    let _ = std::fs::remove_dir_all(&dir);
}
