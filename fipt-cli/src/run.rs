//! `fipt run <scene> --out OUT`: bake → train → extract emitters → per-view maps → report
//! (→ eval when ground truth exists). Every stage writes its results atomically and a manifest
//! last; re-running skips finished stages and resumes an interrupted training.
use crate::info::Policy;
use crate::progress::Stage;
use anyhow::{bail, Result};
use fipt_core::emitter::{Emitter, EmitterExtractor, EmitterInputs, PixelHit};
use fipt_core::fsutil::{write_bytes_atomic, write_json_atomic};
use fipt_core::image::ExrPrecision;
use fipt_emitter::{MaskExtractor, MaskExtractorConfig};
use fipt_neural::TrainConfig;
use fipt_shading::bake::{primary_records, BakeConfig};
use fipt_shading::field_surfaces::FieldSurfaces;
use fipt_shading::render::RenderConfig;
use fipt_shading::scene::Scene as RenderScene;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Scene folder (either layout).
    pub scene: PathBuf,
    /// Output folder (created; finished stages inside are reused).
    #[arg(long)]
    pub out: PathBuf,
    /// Settings preset: paper (the reference's sample counts, sizes and steps), balanced, fast.
    #[arg(long, default_value = "balanced")]
    pub preset: String,
    /// A TOML or JSON file with `[bake]`, `[train]` and `[emitters]` sections laid over the
    /// preset.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// What to do with NaN/Inf/negative pixels.
    #[arg(long, value_enum, default_value = "reject")]
    pub bad_pixels: Policy,
    /// Redo every stage.
    #[arg(long)]
    pub force: bool,
}

/// All settings of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    pub bake: BakeConfig,
    pub train: TrainConfig,
    pub emitters: MaskExtractorConfig,
    pub render: ReRenderConfig,
}

/// Path-traced re-renders of every view from the recovered scene (`_render.exr`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReRenderConfig {
    /// 0 disables the stage.
    pub spp: u32,
    pub max_bounces: u32,
    pub seed: u64,
}

impl RunConfig {
    pub fn preset(name: &str) -> Option<Self> {
        Some(RunConfig {
            bake: BakeConfig::preset(name)?,
            train: TrainConfig::preset(name)?,
            emitters: MaskExtractorConfig::default(),
            render: ReRenderConfig {
                spp: match name {
                    "paper" => 64,
                    "fast" => 8,
                    _ => 32,
                },
                max_bounces: 7,
                seed: 0,
            },
        })
    }
}

#[derive(Serialize)]
struct StageReport {
    stage: &'static str,
    seconds: f64,
    peak_rss_mib: Option<f64>,
}

pub fn run(a: Args) -> Result<()> {
    let Some(preset) = RunConfig::preset(&a.preset) else {
        bail!("unknown preset `{}` (paper, balanced, fast)", a.preset)
    };
    let cfg: RunConfig = crate::config::load(preset, a.config.as_deref())?;
    cfg.train.validate()?;
    let t_all = std::time::Instant::now();
    let mut stages = vec![];
    let mut mark = |stage: &'static str, t: std::time::Instant| {
        stages.push(StageReport {
            stage,
            seconds: t.elapsed().as_secs_f64(),
            peak_rss_mib: crate::bench::peak_rss_mib(),
        })
    };
    fipt_core::fsutil::remove_stale_temporaries(&a.out);
    let t = std::time::Instant::now();
    let scene = crate::scene::load(&a.scene, a.bad_pixels.into())?;
    mark("load", t);
    let t = std::time::Instant::now();
    let (bake, shadings) = crate::bake::stage(&scene, &cfg.bake, &a.out.join("bake"), a.force)?;
    mark("bake", t);
    let t = std::time::Instant::now();
    let (field, train, _) = crate::train::stage(
        &scene,
        &bake,
        &shadings,
        &cfg.train,
        &a.out.join("train"),
        a.force,
    )?;
    mark("train", t);

    let t = std::time::Instant::now();
    let st = Stage::start("emitters");
    let split = scene.ds.train();
    let mut hits = Vec::new();
    for ((v, img), sh) in split.views.iter().zip(&scene.images).zip(&shadings) {
        for (i, (r, l)) in primary_records(&scene.geometry, v)
            .iter()
            .zip(&img.data)
            .enumerate()
        {
            if let Some(r) = r {
                let max_reflected = sh.valid[i].then(|| {
                    let m = |x: &[Vec3; fipt_core::shading::NUM_LEVELS]| {
                        x.iter().fold(Vec3::ZERO, |a, b| a.max(*b))
                    };
                    sh.ld[i] + m(&sh.ls0[i]) + m(&sh.ls1[i])
                });
                hits.push(PixelHit {
                    triangle: r.hit.tri,
                    radiance: *l,
                    max_reflected,
                });
            }
        }
    }
    let mesh = &scene.geometry.mesh;
    let extractor = MaskExtractor {
        config: cfg.emitters.clone(),
    };
    let emitters = extractor.extract(&EmitterInputs {
        positions: &mesh.positions,
        triangles: &mesh.triangles,
        field: &field,
        pixel_hits: &hits,
    })?;
    write_json_atomic(&a.out.join("emitters.json"), &emitters)?;
    write_emitters_obj(&a.out.join("emitters.obj"), mesh, &emitters)?;
    st.done();
    for (i, e) in emitters.iter().enumerate() {
        eprintln!(
            "light {i}: {} triangles, area {:.4} m², radiance {:.2?}, power {:.1?} W, {} pixels",
            e.triangles.len(),
            e.area,
            e.mean_radiance,
            e.power,
            e.pixels
        );
    }
    mark("emitters", t);

    let t = std::time::Instant::now();
    let st = Stage::start("maps");
    let mut emission_of: HashMap<u32, Vec3> = HashMap::new();
    for e in &emitters {
        for (t, l) in e.triangles.iter().zip(&e.radiance) {
            emission_of.insert(*t, Vec3::from(*l));
        }
    }
    for s in &scene.ds.splits {
        crate::train::export_views(
            &field,
            &scene.geometry,
            &s.views,
            None,
            None,
            Some(&emission_of),
            &a.out.join("views").join(&s.name),
        )?;
    }
    st.done();
    mark("maps", t);

    if cfg.render.spp > 0 {
        let t = std::time::Instant::now();
        let st = Stage::start("re-render");
        let (all_pts, footprint) = {
            let views: Vec<_> = scene
                .ds
                .splits
                .iter()
                .flat_map(|s| s.views.clone())
                .collect();
            let (p, f) = crate::train::view_points(&scene.geometry, &views);
            (p.into_iter().flatten().flatten().collect::<Vec<_>>(), f)
        };
        let surfaces = FieldSurfaces::build(
            &field,
            mesh,
            &emitters,
            all_pts,
            footprint.unwrap_or(0.01) * 2.0,
        )?;
        let rscene = RenderScene::new(mesh.clone(), surfaces);
        let rc = RenderConfig {
            spp: cfg.render.spp,
            max_bounces: cfg.render.max_bounces,
            seed: cfg.render.seed,
            ..Default::default()
        };
        let total: usize = scene.ds.splits.iter().map(|s| s.views.len()).sum();
        let pb = crate::progress::bar(total as u64, "re-render");
        for (si, s) in scene.ds.splits.iter().enumerate() {
            let dir = a.out.join("views").join(&s.name);
            for v in &s.views {
                let key = ((si as u64) << 32) + v.index as u64;
                let (img, _) = fipt_shading::render::render(&rscene, &v.camera, &rc, key, &|_| {});
                let k = v.index;
                img.write_exr(&dir.join(format!("{k:03}_render.exr")), ExrPrecision::F32)?;
                img.write_png(&dir.join("preview").join(format!("{k:03}_render.png")), 1.0)?;
                pb.inc(1);
            }
        }
        pb.finish_and_clear();
        st.done();
        mark("re-render", t);
    }

    let has_gt = scene
        .ds
        .splits
        .iter()
        .any(|s| s.has_gt(fipt_core::dataset::GtKind::DiffCol));
    let metrics = if has_gt {
        let t = std::time::Instant::now();
        let m = crate::eval::evaluate(&scene.ds, &a.out)?;
        mark("eval", t);
        Some(m)
    } else {
        None
    };
    let report = serde_json::json!({
        "fipt_version": env!("CARGO_PKG_VERSION"),
        "scene": a.scene,
        "inputs_hash": scene.inputs_hash,
        "preset": a.preset,
        "settings": cfg,
        "inputs": {
            "train_views": split.views.len(),
            "width": scene.ds.width,
            "height": scene.ds.height,
            "triangles": mesh.triangles.len(),
        },
        "stages": stages,
        "seconds_total": t_all.elapsed().as_secs_f64(),
        "bake": { "stats": bake.stats, "seconds": bake.seconds_total },
        "train": train,
        "emitters": emitters.iter().map(|e| serde_json::json!({
            "triangles": e.triangles.len(), "area": e.area, "mean_radiance": e.mean_radiance,
            "power": e.power, "centroid": e.centroid, "pixels": e.pixels,
        })).collect::<Vec<_>>(),
        "modeled": {
            "material_field": true,
            "emission_mask": true,
            "emitters": emitters.len(),
            "path_grown_refinement": "not implemented yet: the shadings are the initial one-bounce bake",
            "re_render": if cfg.render.spp > 0 { format!("path traced at {} spp from the field (voxel cache) and the extracted emitters", cfg.render.spp) } else { "skipped (render.spp = 0)".to_string() },
            "hash_table_log2": train.config.field.grid.log2_table,
        },
        "metrics": metrics,
    });
    write_json_atomic(&a.out.join("report.json"), &report)?;
    println!(
        "\nfipt run finished in {:.1} s",
        t_all.elapsed().as_secs_f64()
    );
    println!("  maps:     {}", a.out.join("views").display());
    println!(
        "  emitters: {} ({} lights)",
        a.out.join("emitters.json").display(),
        emitters.len()
    );
    println!(
        "  field:    {}",
        a.out.join("train/field.safetensors").display()
    );
    println!("  report:   {}", a.out.join("report.json").display());
    Ok(())
}

/// Writes the emitter triangles as OBJ, one group per light.
fn write_emitters_obj(path: &Path, mesh: &fipt_geom::Mesh, emitters: &[Emitter]) -> Result<()> {
    let mut s = String::from("# fipt emitters: one group per light, world space\n");
    let mut n = 0;
    for (i, e) in emitters.iter().enumerate() {
        s.push_str(&format!(
            "g light_{i}\n# mean radiance {:?}\n",
            e.mean_radiance
        ));
        for &t in &e.triangles {
            for v in mesh.triangles[t as usize] {
                let p = mesh.positions[v as usize];
                s.push_str(&format!("v {} {} {}\n", p.x, p.y, p.z));
            }
            s.push_str(&format!("f {} {} {}\n", n + 1, n + 2, n + 3));
            n += 3;
        }
    }
    write_bytes_atomic(path, s.as_bytes())?;
    Ok(())
}
