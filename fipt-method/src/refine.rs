//! The path-grown refinement stage of `fipt run`: re-computes the shadings of the training
//! views from the last round's field and the extracted emitters, stored like a bake in
//! `OUT/refine<k>/` (manifest last), keyed by the settings and the upstream fingerprints.
use crate::error::{Result, RunError};
use crate::observe::{bar, Stage};
use crate::scene::SceneRef;
use crate::shard::Sharding;
use fipt_bake::bake_store::{
    begin, finish, keyed_mismatch, load_keyed, shard_done, write_view, BakeManifest,
    StoredShadings, FORMAT_VERSION,
};
use fipt_bake::refine::RefineStats;
use fipt_core::emitter::Emitter;
use fipt_core::field::MaterialField;
use fipt_core::fsutil::{hash_bytes, read_json, write_json_atomic};
use fipt_core::shading::{PixelDraw, RefineInputs, Scope, ShadingRefiner, Shard};
use std::path::Path;

/// A finished refinement: its shadings (on disk), their fingerprint and what the rays met.
pub struct Refined {
    pub shadings: StoredShadings,
    pub key: String,
    /// The refiner's report (`ShadingRefiner::refine`).
    pub stats: serde_json::Value,
    pub seconds: f64,
}

/// Runs (or reuses) the refinement of the field fingerprinted `field_id` with `emitters`.
pub fn stage(
    scene: &SceneRef,
    field: &dyn MaterialField,
    field_id: &str,
    emitters: &[Emitter],
    refiner: &dyn ShadingRefiner,
    settings: &serde_json::Value,
    dir: &Path,
    force: bool,
    sharding: Sharding,
    draw: PixelDraw,
) -> Result<Refined> {
    let name = refiner.name().to_string();
    let shard = sharding.shard;
    let key = format!(
        "{}|{field_id}|{}{}",
        serde_json::to_string(settings)?,
        serde_json::to_string(emitters)?,
        draw.key_tag()
    );
    let key = hash_bytes(key.as_bytes());
    let stats_path = dir.join("refine_stats.json");
    let check = |m: &BakeManifest| keyed_mismatch(m, &scene.cache_key, &name, &key);
    let reused = |m: BakeManifest, shadings| -> Refined {
        crate::note!(
            "reusing the refined shadings in {} (computed in {:.1} s); --force to redo them",
            dir.display(),
            m.seconds_total
        );
        crate::observe::reused(Some(m.seconds_total));
        Refined {
            shadings,
            key: key.clone(),
            stats: read_json(&stats_path).unwrap_or_default(),
            seconds: m.seconds_total,
        }
    };
    if !force {
        // A finished refinement is reused as it is; shard manifests beside it are stale.
        if let Ok((m, shadings)) = load_keyed(dir, &scene.cache_key, &name, &key)? {
            fipt_bake::bake_store::clear_shard_manifests(dir);
            if stats_path.is_file() {
                return Ok(reused(m, shadings));
            }
        }
        let mut part = |k: Shard| {
            let one = Sharding {
                shard: k,
                stop_before_refine: false,
            };
            let args = (field, field_id, emitters, refiner, settings);
            stage(
                scene, args.0, args.1, args.2, args.3, args.4, dir, false, one, draw,
            )
            .map(|_| ())
        };
        let compute = (!sharding.stop_before_refine)
            .then_some(&mut part as &mut dyn FnMut(Shard) -> Result<()>);
        crate::shard::merge(dir, "refinement", shard, check, compute)?;
        if !stats_path.is_file() {
            // Merged shards: the reports of the shards, as the merged manifest holds them.
            if let Ok(m) = read_json::<BakeManifest>(&dir.join("manifest.json")) {
                if check(&m).is_none() {
                    write_json_atomic(&stats_path, &m.stats)?;
                }
            }
        }
        match load_keyed(dir, &scene.cache_key, &name, &key)? {
            Ok((m, shadings)) => return Ok(reused(m, shadings)),
            Err(why) if why != "no finished bake found" => crate::note!("refining: {why}"),
            Err(_) => {}
        }
    }
    if sharding.stop_before_refine && shard.is_all() {
        return Err(RunError::Stopped(format!(
            "stopped before the refinement in {} (--stop-before refine): run `fipt run … --shard K/N` for every K, then `fipt run` again",
            dir.display()
        ))
        .into());
    }
    if !shard.is_all() && !force && shard_done(dir, shard, &check) {
        return Err(crate::shard::done(dir, "refinement", shard, check).into());
    }
    let job = Job {
        scene,
        field,
        field_id,
        emitters,
        refiner,
        settings,
        dir,
    };
    let scope = Scope {
        shard,
        pixels: draw,
    };
    compute(&job, &name, key, scope)
}

/// What one refinement computes from.
struct Job<'a> {
    scene: &'a SceneRef<'a>,
    field: &'a dyn MaterialField,
    field_id: &'a str,
    emitters: &'a [Emitter],
    refiner: &'a dyn ShadingRefiner,
    settings: &'a serde_json::Value,
    dir: &'a Path,
}

/// Refines `shard`'s views, each written as soon as it is done, then the manifest (a shard's
/// ends the process's work on the stage with `shard::done`).
fn compute(job: &Job, name: &str, key: String, scope: Scope) -> Result<Refined> {
    let shard = scope.shard;
    let (scene, refiner, dir) = (job.scene, job.refiner, job.dir);
    let stats_path = dir.join("refine_stats.json");
    let check = |m: &BakeManifest| keyed_mismatch(m, &scene.cache_key, name, &key);
    let split = scene.ds.train();
    let inputs = RefineInputs {
        geometry: scene.geometry,
        positions: scene.positions,
        triangles: scene.triangles,
        views: &split.views,
        images: &scene.images,
        field: job.field,
        emitters: job.emitters,
    };
    let pb = bar(1, "refine");
    let st = Stage::start("refine");
    // Each view is written as soon as it is refined, and let go.
    begin(dir, shard)?;
    let mut written = 0;
    let stats = refiner.refine_into(
        &inputs,
        scope,
        &|d, t| {
            pb.set_length(t as u64);
            pb.set_position(d as u64);
        },
        &mut |k, s| {
            written += 1;
            write_view(dir, &split.name, k, &s)
        },
    )?;
    pb.finish_and_clear();
    let secs = st.done();
    crate::shard::check_handed_over("refiner", name, written, split.views.len(), shard)?;
    print_stats(name, &stats, secs);
    let manifest = BakeManifest {
        hashes: Default::default(),
        version: FORMAT_VERSION,
        baker: name.to_string(),
        inputs_hash: scene.cache_key.to_string(),
        config: serde_json::json!({ "key": key, "settings": job.settings, "field": job.field_id }),
        split: split.name.clone(),
        views: split.views.len(),
        width: scene.ds.width,
        height: scene.ds.height,
        stats: Default::default(),
        seconds_total: secs,
        pixels: scope.pixels,
    };
    if !shard.is_all() {
        let manifest = BakeManifest {
            hashes: Default::default(),
            stats: stats.clone(),
            ..manifest
        };
        if stats_path.exists() {
            std::fs::remove_file(&stats_path)?;
        }
        finish(dir, &manifest, shard)?;
        return Err(crate::shard::done(dir, "refinement", shard, check).into());
    }
    write_json_atomic(&stats_path, &stats)?;
    finish(dir, &manifest, shard)?;
    Ok(Refined {
        shadings: StoredShadings::of(dir, &manifest),
        key,
        stats,
        seconds: secs,
    })
}

/// The built-in refiner's figures in words; any other refiner's report as it is.
fn print_stats(name: &str, report: &serde_json::Value, secs: f64) {
    let Ok(stats) = serde_json::from_value::<RefineStats>(report.clone()) else {
        crate::note!("{name}: {report}");
        return;
    };
    crate::note!(
        "refine: {:.0} pixels/s, {:.2} Mrays/s ({} rays)",
        stats.pixels as f64 / secs.max(1e-9),
        stats.rays as f64 / secs.max(1e-9) / 1e6,
        stats.rays
    );
    crate::note!(
        "refine: setup {:.1} s, diffuse {:.1} s ({} cells{}), specular {:.1} s; secondary rays: {} to emitters, {} SLF at rough surfaces, {} grown through glossy ones, {} through unobserved rough ones, {} left the scene",
        stats.seconds_setup,
        stats.seconds_diffuse,
        stats.cache_entries,
        if stats.cache_cell_footprints > 0.0 {
            format!(" of {:.2} pixel footprints", stats.cache_cell_footprints)
        } else {
            String::new()
        },
        stats.seconds_specular,
        stats.secondary_emitter,
        stats.secondary_slf,
        stats.secondary_grown,
        stats.secondary_unobserved,
        stats.secondary_miss
    );
    if stats.slf_margin_pixels > 0 {
        crate::note!(
            "refine: {} pixels beside the lights left out of the SLF (refine.slf_light_margin)",
            stats.slf_margin_pixels
        );
    }
}
