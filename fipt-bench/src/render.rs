//! `fipt bench --suite render --scene RUN`: the re-render of a finished run's recovered scene
//! (the scene `fipt run`'s re-render stage path-traces) beside the BVH's raw incoherent
//! closest-hit throughput on the same mesh and cameras, in interleaved repetitions so that a
//! machine whose speed drifts shows in both; written as JSON.
use crate::rays::{make_rays, throughput};
use crate::{BenchError, Result};
use fipt_core::memory::peak_rss_mib;
use fipt_pipeline::recovered::RunOutput;
use fipt_pipeline::run_config::ReRenderConfig;
use fipt_pipeline::Components;
use fipt_shading::render::{trace_variance, RenderConfig};
use fipt_shading::scene::Scene;
use serde_json::json;
use std::path::Path;

/// What the render suite measures.
pub struct RenderBench<'a> {
    /// A finished `fipt run` output folder.
    pub run: Option<&'a Path>,
    /// Val views rendered (the first N; default 2).
    pub views: Option<usize>,
    /// Interleaved repetitions; the best of each is reported.
    pub reps: usize,
    /// 4 samples a pixel instead of 16.
    pub quick: bool,
}

pub fn run(b: &RenderBench, out: &Path) -> Result<()> {
    let Some(dir) = b.run else {
        return Err(BenchError::Invalid(
            "--suite render needs --scene RUN, a finished `fipt run` output folder".into(),
        ));
    };
    let run = RunOutput::open(dir, None)?;
    let (ds, geometry) = run.open_scene()?;
    let field = run.field(&Components::builtin())?;
    let all: Vec<_> = ds.splits.iter().flat_map(|s| s.views.clone()).collect();
    let surfaces = fipt_pipeline::recovered::surfaces(
        &geometry,
        &all,
        field.as_ref(),
        &run.emitters,
        run.model,
    )?;
    let split = ds
        .splits
        .iter()
        .find(|s| s.name == "val")
        .unwrap_or(ds.train());
    let n = b.views.unwrap_or(2).clamp(1, split.views.len().max(1));
    let cams: Vec<_> = split
        .views
        .iter()
        .take(n)
        .map(|v| v.camera.clone())
        .collect();
    // Bounce rays from every pixel's primary hit, as many a pixel as the render's samples,
    // so that both measurements last long enough for the machine's noise to average out.
    let spp = if b.quick { 4 } else { 16 };
    let inc: Vec<_> = (0..spp)
        .flat_map(|s| make_rays(&geometry.mesh, &geometry.bvh, &cams, s as u64).1)
        .collect();
    let scene = Scene::new(geometry.mesh.clone(), surfaces);
    // The re-render stage's own bounces and seed (`report.json`'s settings), at `spp`.
    let stage: Option<ReRenderConfig> =
        serde_json::from_value(run.report["settings"]["render"].clone()).ok();
    let d = RenderConfig::default();
    let cfg = RenderConfig {
        spp,
        max_bounces: stage.as_ref().map_or(d.max_bounces, |r| r.max_bounces),
        seed: stage.as_ref().map_or(d.seed, |r| r.seed),
        ..d
    };
    let bvh = &scene.bvh;
    let (mut raw, mut traced, mut reps) = (0f64, 0f64, Vec::new());
    let (mut rays, mut paths) = (0u64, 0u64);
    for _ in 0..b.reps.max(1) {
        let (r, _) = throughput(&inc, 1, |o, d| bvh.bare_traverse(o, d));
        let (mut secs, mut nr, mut np) = (0f64, 0u64, 0u64);
        for (k, c) in cams.iter().enumerate() {
            let (_, _, st) = trace_variance(&scene, c, &cfg, k as u64, &|_| {});
            (secs, nr, np) = (secs + st.seconds, nr + st.rays, np + st.paths);
        }
        let t = nr as f64 / secs.max(1e-9) / 1e6;
        reps.push(json!({ "raw_incoherent_mrays_s": r, "render_mrays_s": t }));
        raw = raw.max(r);
        if t > traced {
            (traced, rays, paths) = (t, nr, np);
        }
    }
    let ratio = raw / traced.max(1e-9);
    fipt_pipeline::note!(
        "re-render of {}: {traced:.2} Mrays/s traced ({:.2} rays a path, {} views at {} spp); the BVH's raw incoherent closest-hit rate on the same mesh and cameras {raw:.2} Mrays/s ({} rays): {ratio:.2}× below it",
        dir.display(),
        rays as f64 / paths.max(1) as f64,
        cams.len(),
        cfg.spp,
        inc.len()
    );
    let report = json!({
        "run": dir.display().to_string(),
        "threads": rayon::current_num_threads(),
        "views": cams.len(),
        "width": cams[0].width, "height": cams[0].height,
        "spp": cfg.spp,
        "triangles": scene.mesh.triangles.len(),
        "raw_incoherent_rays": inc.len(),
        "raw_incoherent_mrays_s": raw,
        "render_mrays_s": traced,
        "render_rays": rays,
        "rays_per_path": rays as f64 / paths.max(1) as f64,
        "ratio": ratio,
        "reps": reps,
        "peak_rss_mib": peak_rss_mib(),
    });
    fipt_core::fsutil::write_json_atomic(out, &report)?;
    Ok(())
}
