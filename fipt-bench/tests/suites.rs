//! The suites write their reports (the figures themselves are measured by `fipt bench`, not
//! asserted here): the rays suite's JSON has its sections and finite, positive throughputs;
//! the bake suite without a scene is refused with what it needs; the render suite measures a
//! finished run and refuses a folder that is not one.
use fipt_bench::{bench, BenchError, BenchRequest, Suite};

fn request(suite: Suite, out: std::path::PathBuf) -> BenchRequest {
    BenchRequest {
        suite,
        out,
        quick: true,
        reps: 1,
        scene: None,
        views: None,
    }
}

#[test]
fn the_rays_suite_writes_its_sections() {
    let dir = std::env::temp_dir().join(format!("fipt-bench-rays-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("bench.json");
    bench(&request(Suite::Rays, out.clone())).unwrap();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    for key in [
        "/room/coherent_mrays_s",
        "/room/incoherent_mrays_s",
        "/mesh_1m/incoherent_bare_mrays_s",
        "/path_tracer/mrays_s",
        "/peak_rss_mib",
    ] {
        let x = v.pointer(key).and_then(|x| x.as_f64());
        assert!(x.is_some_and(|x| x.is_finite() && x > 0.0), "{key}: {x:?}");
    }
    assert!(v["mesh_1m"]["triangles"].as_u64().unwrap() > v["room"]["triangles"].as_u64().unwrap());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_bake_suite_asks_for_a_scene() {
    let out = std::env::temp_dir().join("fipt-bench-never-written.json");
    let e = bench(&request(Suite::Bake, out.clone())).unwrap_err();
    assert!(matches!(e, BenchError::Invalid(_)), "{e}");
    assert!(e.to_string().contains("--scene"), "{e}");
    assert!(!out.exists());
}

#[test]
fn the_render_suite_measures_a_finished_run_and_refuses_other_folders() {
    let dir = std::env::temp_dir().join(format!("fipt-bench-render-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = dir.join("bench.json");
    let e = bench(&request(Suite::Render, out.clone())).unwrap_err();
    assert!(
        matches!(e, BenchError::Invalid(_)) && e.to_string().contains("--scene"),
        "{e}"
    );
    // A scene folder is not a run.
    let scene = dir.join("scene");
    let mut opts = fipt_synth::SynthOptions::defaults("cornell");
    (opts.train_views, opts.val_views, opts.width, opts.height) = (3, 1, 24, 16);
    opts.render.spp = 4;
    fipt_synth::write_dataset(
        fipt_synth::build("cornell").unwrap(),
        &scene,
        &opts,
        &|_, _| {},
    )
    .unwrap();
    let mut r = request(Suite::Render, out.clone());
    r.scene = Some(scene.clone());
    let e = bench(&r).unwrap_err();
    assert!(e.to_string().contains(&scene.display().to_string()), "{e}");
    assert!(!out.exists());
    // A finished run: both rates measured, the ratio theirs.
    let config = dir.join("run.toml");
    std::fs::write(
        &config,
        "[bake]\ndiffuse_samples = 4\nspecular_samples = [2, 2, 2, 2, 2, 2]\n\
         [refine]\ndiffuse_samples = 4\nspecular_samples = [2, 2, 2, 2, 2, 2]\nlight_samples = 2\n\
         [train]\nsteps = 50\n[train.field]\nmlp_width = 16\nmask_width = 16\n\
         [train.field.grid]\nlevels = 4\n[render]\nspp = 1\nval_spp = 1\n",
    )
    .unwrap();
    let run_dir = dir.join("run");
    let components = fipt_method::register(fipt_pipeline::Components::builtin());
    let mut rr = fipt_pipeline::run::RunRequest::new(&scene, &run_dir, "fast");
    rr.config = Some(config);
    fipt_pipeline::run::run(&rr, &components).unwrap();
    r.scene = Some(run_dir);
    bench(&r).unwrap();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let f = |k: &str| v[k].as_f64().unwrap_or(f64::NAN);
    for k in [
        "render_mrays_s",
        "raw_incoherent_mrays_s",
        "ratio",
        "rays_per_path",
    ] {
        assert!(f(k).is_finite() && f(k) > 0.0, "{k}: {v}");
    }
    assert!((f("ratio") - f("raw_incoherent_mrays_s") / f("render_mrays_s")).abs() < 1e-9);
    assert_eq!(v["views"], 1);
    assert_eq!(v["reps"].as_array().map(|r| r.len()), Some(1));
    // Every pixel of the val view gives 4 bounce rays (the quick suite's samples) at most.
    assert!(v["raw_incoherent_rays"].as_u64().unwrap() <= 4 * 24 * 16);
    std::fs::remove_dir_all(&dir).ok();
}
