//! `fipt bench --suite bake --scene DIR`: bake throughput against the BVH's raw incoherent
//! throughput on the same scene, wall time per term, and the ablations (diffuse cache,
//! sampler, specular estimator, SLF fallback) with their accuracy.
use crate::rays::{make_rays, throughput};
use crate::{BenchError, Result};
use fipt_bake::bake::{BakeConfig, BakeStats, FactorizedBaker, SamplerKind, SpecularEstimator};
use fipt_core::image::BadPixelPolicy;
use fipt_core::memory::peak_rss_mib;
use fipt_core::metrics::{psnr, srgb_psnr};
use fipt_core::reflectance::{PrincipledViaTrait, ReflectanceModel};
use fipt_core::shading::ViewShadings;
use glam::Vec3;
use serde_json::json;
use std::path::Path;
use std::time::Instant;

/// PSNR between two bakes' Ld (and specular at level 3) on valid pixels, in the sRGB space of
/// the loss.
fn agreement(a: &[ViewShadings], b: &[ViewShadings]) -> (f64, f64) {
    let (mut ld, mut sp, mut n) = (0.0, 0.0, 0);
    for (x, y) in a.iter().zip(b) {
        let m: Vec<bool> = x.valid.clone();
        ld += srgb_psnr(&x.ld, &y.ld, Some(&m)).unwrap_or(100.0);
        let s = |v: &ViewShadings| -> Vec<Vec3> {
            v.ls0.iter().zip(&v.ls1).map(|(p, q)| p[3] + q[3]).collect()
        };
        sp += psnr(&s(x), &s(y), Some(&m), 1.0).unwrap_or(100.0);
        n += 1;
    }
    (ld / n as f64, sp / n as f64)
}

pub fn run(scene_dir: Option<&Path>, views: Option<usize>, out: &Path) -> Result<()> {
    let Some(dir) = scene_dir else {
        return Err(BenchError::Invalid(
            "--suite bake needs --scene DIR (e.g. the output of `fipt synth room`)".into(),
        ));
    };
    let mut scene = fipt_capture::scene::load(dir, BadPixelPolicy::Reject, &Default::default())?;
    let n = views.unwrap_or(scene.images.len()).min(scene.images.len());
    scene.images.truncate(n);
    scene.ds.splits[0].views.truncate(n);
    let split = scene.ds.train().clone();
    // Raw incoherent throughput on this scene: bounce rays from the views' primary hits.
    let cams: Vec<_> = split.views.iter().map(|v| v.camera.clone()).collect();
    let (_, inc) = make_rays(&scene.geometry.mesh, &scene.geometry.bvh, &cams, 0);
    let bvh = &scene.geometry.bvh;
    let (raw, _) = throughput(&inc, 2, |o, d| bvh.bare_traverse(o, d));
    fipt_pipeline::note!(
        "raw incoherent closest-hit on this scene: {raw:.2} Mrays/s ({} rays)",
        inc.len()
    );
    let configs = bench_configs();
    let mut rows = Vec::new();
    let mut results: Vec<(String, Vec<ViewShadings>, BakeStats, f64)> = Vec::new();
    for (name, cfg, model) in configs {
        let t = Instant::now();
        let baker = FactorizedBaker::new(cfg.clone()).with_model(model);
        let (sh, stats, _) =
            baker.bake_detailed(&scene.geometry, &split.views, &scene.images, &|_, _| {});
        let secs = t.elapsed().as_secs_f64();
        let rays = (stats.rays_diffuse + stats.rays_specular) as f64;
        let closure = fipt_eval::eval::closure_psnr(
            &fipt_capture::scene::SceneRef::loaded(&scene),
            &sh,
            &fipt_core::shading::PixelDraw::ALL,
        )?;
        fipt_pipeline::note!(
            "{name:<20} {secs:>7.1} s  diffuse {:>6.1} s  specular {:>6.1} s  {:>8.0} px/s  {:>5.2} Mrays/s ({:.0} % of raw)  closure {}",
            stats.seconds_diffuse,
            stats.seconds_specular,
            stats.valid_pixels as f64 / secs,
            rays / secs / 1e6,
            100.0 * rays / secs / 1e6 / raw,
            closure.map(|c| format!("{c:.2} dB")).unwrap_or("n/a".into())
        );
        rows.push(json!({
            "name": name, "model": model, "config": cfg, "seconds": secs, "stats": stats,
            "pixels_per_s": stats.valid_pixels as f64 / secs, "mrays_s": rays / secs / 1e6,
            "fraction_of_raw": rays / secs / 1e6 / raw, "closure_psnr_db": closure,
        }));
        results.push((name.to_string(), sh, stats, secs));
    }
    let find = |n: &str| results.iter().find(|r| r.0 == n).expect("config");
    let (ld_cache_vs_pp, _) = agreement(&find("default").1, &find("per_pixel_ld").1);
    let (ld_noise, _) = agreement(&find("per_pixel_ld").1, &find("per_pixel_ld_seed1").1);
    let speedup = find("per_pixel_ld").2.seconds_diffuse / find("default").2.seconds_diffuse;
    fipt_pipeline::note!(
        "diffuse cache: Ld {speedup:.2}× faster; cached vs per-pixel Ld {ld_cache_vs_pp:.2} dB, per-pixel vs per-pixel (another seed) {ld_noise:.2} dB (the Monte Carlo noise floor)"
    );
    let external = external_model_cost(&results);
    let report = json!({
        "scene": dir, "views": n, "width": scene.ds.width, "height": scene.ds.height,
        "raw_incoherent_mrays_s": raw, "threads": rayon::current_num_threads(),
        "configs": rows,
        "external_model": external,
        "diffuse_cache": { "speedup_diffuse_term": speedup, "ld_psnr_cached_vs_per_pixel_db": ld_cache_vs_pp, "ld_psnr_per_pixel_two_seeds_db": ld_noise },
        "peak_rss_mib": peak_rss_mib(),
    });
    fipt_core::fsutil::write_json_atomic(out, &report)?;
    Ok(())
}

/// What a reflectance model from outside costs against the same model in the enum: `principled`
/// baked per pixel through the enum and through the trait (`principled-via-trait`, which also
/// has to integrate Ld per pixel): the specular term's time (the same samples and bits, so the
/// ratio is the dispatch's cost), the diffuse term's (moments vs the basis summed directly), how
/// closely the two agree, and the whole bake against the enum's default (with the cache).
fn external_model_cost(
    results: &[(String, Vec<ViewShadings>, BakeStats, f64)],
) -> serde_json::Value {
    let find = |n: &str| results.iter().find(|r| r.0 == n).expect("config");
    let (cached, enum_pp, via) = (
        find("principled"),
        find("principled_per_pixel"),
        find("principled_via_trait"),
    );
    let (ld_db, spec_db) = agreement(&enum_pp.1, &via.1);
    let spec_identical = enum_pp
        .1
        .iter()
        .zip(&via.1)
        .all(|(a, b)| a.ls0 == b.ls0 && a.ls1 == b.ls1);
    let mrays = |r: &(String, Vec<ViewShadings>, BakeStats, f64)| {
        (r.2.rays_diffuse + r.2.rays_specular) as f64 / r.3 / 1e6
    };
    let v = json!({
        "specular_seconds_enum": enum_pp.2.seconds_specular,
        "specular_seconds_trait": via.2.seconds_specular,
        "specular_identical": spec_identical,
        "diffuse_seconds_enum_per_pixel": enum_pp.2.seconds_diffuse,
        "diffuse_seconds_trait": via.2.seconds_diffuse,
        "ld_psnr_trait_vs_enum_db": ld_db, "specular_psnr_trait_vs_enum_db": spec_db,
        "mrays_s_enum_per_pixel": mrays(enum_pp), "mrays_s_trait": mrays(via),
        "seconds_enum_with_cache": cached.3, "seconds_trait": via.3,
    });
    fipt_pipeline::note!(
        "external model: specular {:.2} s through the trait vs {:.2} s through the enum ({}); Ld per pixel {:.2} s vs {:.2} s ({ld_db:.1} dB apart); whole bake {:.1} s vs {:.1} s with the cache",
        via.2.seconds_specular, enum_pp.2.seconds_specular,
        if spec_identical { "identical" } else { "DIFFERENT" },
        via.2.seconds_diffuse, enum_pp.2.seconds_diffuse, via.3, cached.3
    );
    v
}

/// The bake settings the benchmark compares: the default, one switch off at a time, the
/// `reference` and `fast` presets, and `principled` through the enum and through the
/// external-model trait.
fn bench_configs() -> Vec<(&'static str, BakeConfig, ReflectanceModel)> {
    static VIA: PrincipledViaTrait = PrincipledViaTrait;
    let via = ReflectanceModel::register(&VIA).expect("principled-via-trait registers");
    let base = BakeConfig::default();
    let per_pixel = BakeConfig {
        diffuse_cache: false,
        ..base.clone()
    };
    let fipt = ReflectanceModel::Fipt;
    let principled = ReflectanceModel::Principled;
    let mut v: Vec<_> = ablations(base.clone())
        .into_iter()
        .map(|(n, c)| (n, c, fipt))
        .collect();
    v.push(("principled", base, principled));
    v.push(("principled_per_pixel", per_pixel.clone(), principled));
    v.push(("principled_via_trait", per_pixel, via));
    v
}

/// The bake's ablations under FIPT's model.
fn ablations(base: BakeConfig) -> Vec<(&'static str, BakeConfig)> {
    vec![
        ("default", base.clone()),
        (
            "per_pixel_ld",
            BakeConfig {
                diffuse_cache: false,
                ..base.clone()
            },
        ),
        (
            "per_pixel_ld_seed1",
            BakeConfig {
                diffuse_cache: false,
                seed: 1,
                ..base.clone()
            },
        ),
        (
            "independent_sampler",
            BakeConfig {
                sampler: SamplerKind::Independent,
                ..base.clone()
            },
        ),
        (
            "per_level_specular",
            BakeConfig {
                specular_estimator: SpecularEstimator::PerLevel,
                ..base.clone()
            },
        ),
        (
            "strict_slf",
            BakeConfig {
                slf_fallback_levels: 0,
                ..base.clone()
            },
        ),
        ("reference", BakeConfig::reference()),
        ("fast", BakeConfig::fast()),
    ]
}
