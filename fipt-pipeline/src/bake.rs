//! The bake stage: cached by inputs, baker and settings; sharded by views; `fipt bake` alone.
use crate::error::Result;
use crate::names::Kind;
use crate::observe::{bar, Stage};
use crate::run_config::RunConfig;
use crate::scene::SceneRef;
use fipt_bake::bake::BakeStats;
use fipt_bake::bake_store::{
    begin, finish, load_if_current, mismatch, shard_done, write_view, BakeManifest, StoredShadings,
    FORMAT_VERSION,
};
use fipt_core::image::BadPixelPolicy;
use fipt_core::image::Image;
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::shading::{PixelDraw, Scope, ShadingBaker, Shard};
use std::path::{Path, PathBuf};

/// `fipt bake`: the bake alone, into `out/bake/`.
pub struct BakeRequest {
    /// Scene folder.
    pub scene: PathBuf,
    /// Output folder; the shadings go to OUT/bake/.
    pub out: PathBuf,
    /// Settings preset.
    pub preset: String,
    /// A TOML or JSON file of bake settings laid over the preset.
    pub config: Option<PathBuf>,
    pub bad_pixels: BadPixelPolicy,
    /// Bake again even if a finished bake with the same inputs and settings exists.
    pub force: bool,
    /// The reflectance model whose shadings are baked.
    pub brdf: ReflectanceModel,
    /// Bake only these views (a task of a job array).
    pub shard: Shard,
}

/// What `fipt bake` did.
pub enum BakeOutcome {
    /// The bake is in this folder.
    Wrote(PathBuf),
    /// A shard's views are written; the message says what remains.
    Stopped(String),
}

/// The baker `fipt bake` uses and its settings, as `fipt run` would choose them: from a run
/// config (a file with a `[pipeline]` table), its `baker` with that baker's settings;
/// otherwise the default baker with the file's settings (a plain config of that baker, or a
/// run config's table of it, `[bake]` for `slf`) over the preset's.
pub fn chosen_baker(
    preset: &str,
    file: Option<&Path>,
    components: &crate::Components,
) -> Result<(String, serde_json::Value)> {
    let mut cfg = crate::config::load_preset(preset, RunConfig::preset, None)?;
    if let Some(path) = file {
        let value = crate::config::read_value(path)?;
        if value.get("pipeline").is_some_and(|t| t.is_object()) {
            cfg = crate::check::load(preset, Some(path), components)?;
        } else if let Some(table) = components.table_of(Kind::Baker, &cfg.pipeline.baker) {
            let own = value.get(table).filter(|t| t.is_object());
            let settings = own.cloned().unwrap_or(value);
            cfg.tables.insert(table.to_string(), settings);
        }
    }
    let name = cfg.pipeline.baker.clone();
    let settings = components.settings_of(Kind::Baker, &name, &cfg, preset)?;
    Ok((name, settings))
}

/// The bake alone (`fipt bake`), with the baker a run would use ([`chosen_baker`]).
pub fn bake_only(a: BakeRequest, components: &crate::Components) -> Result<BakeOutcome> {
    let (name, settings) = chosen_baker(&a.preset, a.config.as_deref(), components)?;
    let baker = components
        .baker(&name, &settings, a.brdf)
        .map_err(crate::check::in_file(a.config.as_deref()))?;
    fipt_core::lock::refuse_nested_run(&a.out)?;
    let _lock = crate::request::lock(&a.out, a.shard, "fipt bake")?;
    let scene = crate::scene::load(&a.scene, a.bad_pixels, &Default::default())?;
    let dir = a.out.join("bake");
    let scope = a.shard.into();
    match stage(
        &SceneRef::loaded(&scene),
        baker.as_ref(),
        &settings,
        &dir,
        a.force,
        scope,
    ) {
        Err(e) if e.is_stopped() => Ok(BakeOutcome::Stopped(e.to_string())),
        Err(e) => Err(e),
        Ok(_) => Ok(BakeOutcome::Wrote(dir)),
    }
}

/// The bake stage with `baker` (built from `settings`): reuses a finished bake of the same
/// inputs, baker and settings in `dir` that holds the pixels `scope` draws, unless `force`
/// (merging finished shards first); otherwise bakes, saves (manifest last) and writes
/// previews of Ld. With a shard other than all, bakes and saves that shard's views and
/// returns [`RunError::Stopped`].
pub fn stage(
    scene: &SceneRef,
    baker: &dyn ShadingBaker,
    settings: &serde_json::Value,
    dir: &Path,
    force: bool,
    scope: Scope,
) -> Result<(BakeManifest, StoredShadings)> {
    let (name, shard, draw) = (baker.name().to_string(), scope.shard, scope.pixels);
    let check = |m: &BakeManifest| {
        mismatch(m, &scene.cache_key, settings, &name).or_else(|| uncovered(&m.pixels, &draw))
    };
    let current = || -> Result<std::result::Result<_, String>> {
        Ok(load_if_current(dir, &scene.cache_key, settings, &name)?
            .and_then(|done| uncovered(&done.0.pixels, &draw).map_or(Ok(done), Err)))
    };
    if !force {
        // A finished bake is reused as it is; shard manifests beside it are stale.
        if let Ok(done) = current()? {
            fipt_bake::bake_store::clear_shard_manifests(dir);
            return Ok(reusing(dir, done));
        }
        let mut part = |k: Shard| {
            let one = Scope { shard: k, ..scope };
            stage(scene, baker, settings, dir, false, one).map(|_| ())
        };
        crate::shard::merge(dir, "bake", shard, check, Some(&mut part))?;
        match current()? {
            Ok(done) => return Ok(reusing(dir, done)),
            Err(why) => crate::note!("baking: {why}"),
        }
    }
    if !shard.is_all() && !force && shard_done(dir, shard, &check) {
        return Err(crate::shard::done(dir, "bake", shard, check).into());
    }
    let split = scene.ds.train();
    if !draw.is_all() {
        crate::note!("baking {draw} of the hit pixels: what the training set and the search will read (train.set_cap, search.max_pixels)");
    }
    let pb = bar(1, "bake");
    let st = Stage::start("bake");
    // Each view is written (with its preview of Ld) as soon as it is baked, and let go.
    begin(dir, shard)?;
    let mut written = 0;
    let report = baker.bake_into(
        scene.geometry,
        &split.views,
        &scene.images,
        scope,
        &|d, t| {
            pb.set_length(t as u64);
            pb.set_position(d as u64);
        },
        &mut |k, s| {
            write_view(dir, &split.name, k, &s)?;
            written += 1;
            let img = Image {
                width: s.width,
                height: s.height,
                data: s.ld,
            };
            img.write_png(&dir.join("preview").join(format!("{k:03}_ld.png")), 1.0)
        },
    )?;
    pb.finish_and_clear();
    let secs = st.done();
    crate::shard::check_handed_over("baker", &name, written, split.views.len(), shard)?;
    let manifest = BakeManifest {
        hashes: Default::default(),
        version: FORMAT_VERSION,
        baker: name.clone(),
        inputs_hash: scene.cache_key.to_string(),
        config: settings.clone(),
        split: split.name.clone(),
        views: split.views.len(),
        width: scene.ds.width,
        height: scene.ds.height,
        stats: report.clone(),
        seconds_total: secs,
        pixels: draw,
    };
    finish(dir, &manifest, shard)?;
    if !shard.is_all() {
        return Err(crate::shard::done(dir, "bake", shard, check).into());
    }
    let stored = StoredShadings::of(dir, &manifest);
    note_stats(&manifest.baker, report, secs);
    Ok((manifest, stored))
}

/// Why shadings computed for the pixels `stored` draws cannot serve a stage that reads those
/// `wanted` draws (None when they can).
pub fn uncovered(stored: &PixelDraw, wanted: &PixelDraw) -> Option<String> {
    (!stored.covers(wanted))
        .then(|| format!("it holds {stored} of the hit pixels; this run reads {wanted}"))
}

/// A finished bake, reused (and said so).
fn reusing(dir: &Path, done: (BakeManifest, StoredShadings)) -> (BakeManifest, StoredShadings) {
    crate::note!(
        "reusing the bake in {} ({} views, baked in {:.1} s); --force to redo it",
        dir.display(),
        done.0.views,
        done.0.seconds_total
    );
    crate::observe::reused(Some(done.0.seconds_total));
    done
}

/// The built-in baker's figures in words; any other baker's report as it is.
fn note_stats(baker: &str, report: serde_json::Value, secs: f64) {
    let Ok(stats) = serde_json::from_value::<BakeStats>(report.clone()) else {
        crate::note!("{baker}: {report}");
        return;
    };
    let rays = stats.rays_diffuse + stats.rays_specular;
    crate::note!(
        "primary {:.2} s, SLF {:.2} s ({} voxels, {:.1} MiB), diffuse {:.2} s ({} cache entries for {} pixels), specular {:.2} s",
        stats.seconds_primary,
        stats.seconds_slf,
        stats.slf_occupied_voxels,
        stats.slf_memory_bytes as f64 / (1 << 20) as f64,
        stats.seconds_diffuse,
        stats.cache_entries,
        stats.valid_pixels,
        stats.seconds_specular
    );
    crate::note!(
        "{:.0} pixels/s, {:.2} Mrays/s",
        stats.valid_pixels as f64 / secs,
        rays as f64 / secs / 1e6
    );
}
