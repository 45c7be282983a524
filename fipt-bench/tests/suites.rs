//! The suites write their reports (the figures themselves are measured by `fipt bench`, not
//! asserted here): the rays suite's JSON has its sections and finite, positive throughputs;
//! the bake suite without a scene is refused with what it needs.
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
