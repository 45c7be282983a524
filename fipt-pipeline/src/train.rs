//! `fipt train <scene> --out OUT`: fit the material field to the bake in OUT/bake, write the
//! checkpoint to OUT/train/ and per-view maps to OUT/train/views/<split>/.
use crate::bail;
use crate::error::{Context, Result};
use crate::observe::{bar, Stage};
use crate::scene::LoadedScene;
use crate::search::Searched;
use crate::train_set::{build_set, second_sides, segment_ids, BuiltSet};
use fipt_bake::bake::primary_records;
use fipt_bake::bake_store::{fingerprint, load_for_inputs, load_if_current, StoredShadings};
use fipt_core::dataset::View;
use fipt_core::fsutil::{read_json, write_json_atomic};
use fipt_core::image::{BadPixelPolicy, ExrPrecision, Image};
use fipt_core::presets::Presets;
use fipt_core::shading::ViewShadings;
use fipt_geom::Geometry;
use fipt_neural::train::{render_factorized, StepLosses, TrainTimings};
use fipt_neural::{NeuralField, TrainConfig, Trainer};
pub use fipt_shading::records::view_points;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// `fipt train`: the training alone, on the bake in `out/bake/`.
pub struct TrainRequest {
    /// Scene folder.
    pub scene: PathBuf,
    /// Output folder holding OUT/bake/; results go to OUT/train/.
    pub out: PathBuf,
    /// Settings preset.
    pub preset: String,
    /// A TOML or JSON file of training settings laid over the preset.
    pub config: Option<PathBuf>,
    /// Override the number of steps.
    pub steps: Option<usize>,
    pub bad_pixels: BadPixelPolicy,
    /// Train afresh even if a finished or resumable run exists.
    pub force: bool,
}

/// What a finished training stage wrote, read back by later runs (written last).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainManifest {
    pub inputs: String,
    /// [`request_key`]: what decided this training before its set was built (empty in
    /// manifests written before it existed).
    #[serde(default)]
    pub request: String,
    pub config: TrainConfig,
    pub pixels: usize,
    /// Hit pixels that `train.set_cap` left out of the training set.
    #[serde(default)]
    pub pixels_left_out: usize,
    /// Training pixels over [`fipt_neural::ops::UNREFLECTABLE`]× brighter than any reflection
    /// their shadings allow (a light's); with `emitter_material = false` they train the
    /// emission mask only.
    #[serde(default)]
    pub pixels_lights: usize,
    pub params_grid: usize,
    pub params_mlp: usize,
    pub seconds: f64,
    pub steps_per_second: f64,
    pub timings: TrainTimings,
    pub last: StepLosses,
    /// `field.safetensors`' content hash when the training finished, checked before the field
    /// is reused or rendered (empty in manifests written before it existed: not checked).
    #[serde(default)]
    pub field_hash: String,
}

/// Why the field in `dir` is not the one its training wrote (None when it is, or when its
/// manifest records no hash).
pub fn field_changed(dir: &Path) -> Option<String> {
    let m = read_json::<TrainManifest>(&dir.join("manifest.json")).ok()?;
    let path = dir.join(FIELD_FILE);
    let now = fipt_core::fsutil::hash_files(&[path.clone()]).unwrap_or_else(|e| e.to_string());
    (!m.field_hash.is_empty() && now != m.field_hash).then(|| {
        format!(
            "{} was changed after its training wrote it (content hash {now}, recorded {})",
            path.display(),
            m.field_hash
        )
    })
}

/// The trained field's file in a training folder.
pub const FIELD_FILE: &str = "field.safetensors";

impl TrainManifest {
    /// What the trained field is a function of: its inputs and settings (training is
    /// deterministic). Later stages key on it.
    pub fn fingerprint(&self) -> String {
        let cfg = serde_json::to_string(&self.config).unwrap_or_default();
        fipt_core::fsutil::hash_bytes(format!("{}|{cfg}", self.inputs).as_bytes())
    }
}

/// The training alone (`fipt train`); returns the folder written. With a run config, the bake
/// must be the one its `[pipeline] baker` and settings make ([`crate::bake::run_baker`]).
pub fn train_only(a: TrainRequest, components: &crate::Components) -> Result<PathBuf> {
    let wanted = crate::bake::run_baker(&a.preset, a.config.as_deref(), components)?;
    let mut cfg: TrainConfig = crate::config::load_preset_section(
        &a.preset,
        TrainConfig::preset,
        a.config.as_deref(),
        "train",
    )?;
    if let Some(s) = a.steps {
        cfg.steps = s;
    }
    cfg.validate()?;
    let scene = crate::scene::load(&a.scene, a.bad_pixels, Default::default())?;
    let bake_dir = a.out.join("bake");
    fipt_core::lock::refuse_nested_run(&a.out)?;
    let _lock = if a.out.is_dir() {
        Some(fipt_core::lock::OutputLock::acquire(&a.out, "fipt train")?)
    } else {
        None // no bake there: the error below says what to run first
    };
    let loaded = match &wanted {
        Some((name, settings)) => load_if_current(&bake_dir, &scene.cache_key, settings, name)?,
        None => load_for_inputs(&bake_dir, &scene.cache_key)?,
    };
    let (bake, stored) = match loaded {
        Ok(x) => x,
        Err(why) => bail!(
            "{}: {why}; run `fipt bake {} --out {}{}` first",
            bake_dir.display(),
            a.scene.display(),
            a.out.display(),
            a.config
                .as_ref()
                .map_or(String::new(), |c| format!(" --config {}", c.display()))
        ),
    };
    let dir = a.out.join("train");
    let (field, m, fresh) = stage(
        &scene,
        &fingerprint(&bake),
        &stored,
        &cfg,
        &dir,
        a.force,
        None,
        None,
        false,
    )?;
    if fresh || !dir.join("views").is_dir() {
        // The maps' predicted renders read the shadings.
        let shadings = stored.load_all()?;
        let st = Stage::start("export maps");
        let split = scene.ds.train();
        for s in &scene.ds.splits {
            let train = s.name == split.name;
            export_views(
                &field,
                &scene.geometry,
                &s.views,
                train.then_some((&field, &shadings[..], &scene.images[..])),
                None,
                None,
                scene.exposure,
                &dir.join("views").join(&s.name),
            )?;
        }
        st.done();
    }
    let _ = m;
    Ok(dir)
}

/// What decides a training before its set is built: the inputs, the shadings, the warm start,
/// the settings as given, the search's targets and the segment ids. A finished training with
/// the same key is reused without building the training set (a resumed run skips it).
fn request_key(
    scene: &LoadedScene,
    shadings_id: &str,
    cfg: &TrainConfig,
    warm: Option<&str>,
    search: Option<&Searched>,
    segments: Option<&(crate::train_set::SegmentKind, String)>,
) -> Result<String> {
    let segments = segments.map(|s| match second_sides(search, s.0) {
        Some(sides) => {
            let bytes: Vec<u8> = (sides.iter())
                .flat_map(|&(v, i, k)| [v, i, k])
                .flat_map(u32::to_le_bytes)
                .collect();
            format!("{}+divided:{}", s.1, fipt_core::fsutil::hash_bytes(&bytes))
        }
        None => s.1.clone(),
    });
    // Every pixel's target, hashed view by view (all of them at once took 12 bytes a pixel).
    let targets = search.map(|s| &s.targets).map(|t| {
        let mut h = fipt_core::fsutil::Fnv::new();
        for (v, view) in t.index.iter().enumerate() {
            let bytes: Vec<u8> = (0..view.len())
                .flat_map(|i| match t.get(v, i).flatten() {
                    Some([a, b]) => [1u32, a.to_bits(), b.to_bits()],
                    None => [0, 0, 0],
                })
                .flat_map(u32::to_le_bytes)
                .collect();
            h.feed(&bytes);
        }
        h.hex()
    });
    Ok(format!(
        "{}|{shadings_id}|{}|{}|{}|{}",
        scene.cache_key,
        warm.unwrap_or("none"),
        fipt_core::fsutil::hash_json(&serde_json::to_value(cfg)?),
        targets.as_deref().unwrap_or("none"),
        segments.as_deref().unwrap_or("none")
    ))
}

/// A finished training in `dir` whose manifest `fits`, with its field.
fn finished(
    dir: &Path,
    fits: impl Fn(&TrainManifest) -> bool,
) -> Option<(NeuralField, TrainManifest)> {
    let m = read_json::<TrainManifest>(&dir.join("manifest.json")).ok()?;
    if !fits(&m) {
        return None;
    }
    if let Some(why) = field_changed(dir) {
        // Its checkpoint is the same file: training resumes from nothing.
        crate::note!("warning: {why}: training again");
        let _ = std::fs::remove_file(dir.join("checkpoint.json"));
        let _ = std::fs::remove_file(dir.join("manifest.json"));
        return None;
    }
    let (field, _) = fipt_neural::train::load_field(dir).ok()?;
    crate::note!(
        "reusing the trained field in {} ({} steps in {:.1} s); --force to redo it",
        dir.display(),
        m.config.steps,
        m.seconds
    );
    crate::observe::reused(Some(m.seconds));
    Some((field, m))
}

/// Per-step timings and the final losses of a training, printed.
fn note_training(t: &TrainTimings, l: &StepLosses, done: usize, sps: f64) {
    let ms = |x: f64| x / done as f64 * 1e3;
    crate::note!(
        "{sps:.1} steps/s; per step: batch {:.1} ms, forward {:.1} ms (hash grid {:.1}), backward {:.1} ms (hash grid {:.1}, with its Adam update {:.1}), MLP optimiser {:.1} ms",
        ms(t.batch),
        ms(t.forward),
        ms(t.grid_forward),
        ms(t.backward),
        ms(t.grid_backward + t.grid_optimizer),
        ms(t.grid_optimizer),
        ms(t.optimizer),
    );
    crate::note!(
        "final losses: total {:.5}, image {:.5}, mask {:.5}, prior {:.5}",
        l.total,
        l.image,
        l.mask,
        l.prior
    );
}

/// The training stage: reuses a finished run in `dir` (same inputs and settings) unless
/// `force`, resumes an interrupted one, or trains afresh (from `warm`'s field, identified by
/// its fingerprint, when given). `shadings_id` fingerprints the shadings, which are freed
/// once the training set holds them (they do not stay beside it through the training). Returns the
/// field, the manifest and whether training ran now.
pub fn stage(
    scene: &LoadedScene,
    shadings_id: &str,
    shadings: &StoredShadings,
    cfg: &TrainConfig,
    dir: &Path,
    force: bool,
    warm: Option<(&NeuralField, &str)>,
    search: Option<&Searched>,
    must_reuse: bool,
) -> Result<(NeuralField, TrainManifest, bool)> {
    let segments = segment_ids(scene, cfg.segments)?;
    let warm_id = warm.map(|w| w.1);
    let request = request_key(scene, shadings_id, cfg, warm_id, search, segments.as_ref())?;
    if !force {
        if let Some((field, m)) = finished(dir, |m| m.request == request) {
            return Ok((field, m, false));
        }
    }
    let st = Stage::start("training set");
    let set = build_set(scene, shadings, cfg, segments.as_ref(), search)?;
    let cfg = sized_config(cfg, &set, warm.is_some());
    let mut inputs = format!(
        "{}+shadings:{shadings_id}+warm:{}",
        scene.cache_key,
        warm_id.unwrap_or("none")
    );
    if let Some((_, id)) = &segments {
        inputs += &format!("+segments:{id}");
    }
    if let Some(id) = &set.targets_id {
        inputs += &format!("+targets:{id}");
    }
    st.done();
    // A training finished before manifests held the request key: reused, and its manifest
    // given the key so that the next run skips the training set.
    if !force {
        if let Some((field, mut m)) = finished(dir, |m| m.inputs == inputs && m.config == cfg) {
            m.request = request;
            write_json_atomic(&dir.join("manifest.json"), &m)?;
            return Ok((field, m, false));
        }
    }
    if must_reuse {
        bail!(
            "{}: this training round is not done, and a shard run (--shard) does not train (training runs on one machine): run `fipt run` without --shard (with --stop-before refine) once the shards before it are done",
            dir.display()
        );
    }
    let trainer = trainer_for(&cfg, &set, &inputs, dir, force, warm)?;
    let (field, manifest) = train_and_record(scene, trainer, &set, cfg, inputs, request, dir)?;
    Ok((field, manifest, true))
}

/// The round's settings sized for its set (the grid's finest level from the footprint, the
/// steps capped for a warm start).
fn sized_config(cfg: &TrainConfig, set: &BuiltSet, warm: bool) -> TrainConfig {
    let n = set.data.len();
    let mut sized = cfg.sized_for(n, set.footprint, &set.bounds);
    sized.steps = cfg.capped_steps(n, warm);
    if sized.steps < cfg.steps {
        crate::note!(
            "training for {} steps instead of {}: at most {} passes over {} pixels from the previous round's field, at least {} steps (train.max_passes, min_steps)",
            sized.steps,
            cfg.steps,
            cfg.max_passes,
            n,
            cfg.min_steps
        );
    }
    sized
}

/// The trainer of a round: resumed from its checkpoint, or new (warm-started from the
/// previous round's field when there is one).
fn trainer_for(
    cfg: &TrainConfig,
    set: &BuiltSet,
    inputs: &str,
    dir: &Path,
    force: bool,
    warm: Option<(&NeuralField, &str)>,
) -> Result<Trainer> {
    if !force {
        match Trainer::resume(cfg, set.bounds, set.data.levels, inputs, dir)? {
            Ok(t) => {
                crate::note!("resuming from step {} in {}", t.step_count(), dir.display());
                return Ok(t);
            }
            Err(why) if why != "no checkpoint" => crate::note!("training afresh: {why}"),
            Err(_) => {}
        }
    }
    let mut t = Trainer::new(cfg.clone(), set.bounds, set.data.levels)?;
    t.inputs = inputs.to_string();
    if let Some((field, _)) = warm {
        t.warm_start(field)?;
        crate::note!("warm start from the previous round's field");
    }
    Ok(t)
}

/// Trains to the end (checkpoints in `dir`) and writes the round's manifest.
fn train_and_record(
    scene: &LoadedScene,
    mut trainer: Trainer,
    set: &BuiltSet,
    cfg: TrainConfig,
    inputs: String,
    request: String,
    dir: &Path,
) -> Result<(NeuralField, TrainManifest)> {
    let data = &set.data;
    let (pg, pm) = trainer.field.num_params();
    crate::note!(
        "training on {} pixels of {} views: {} hash-table + {} MLP parameters, {} steps of {}",
        data.len(),
        scene.ds.train().views.len(),
        pg,
        pm,
        cfg.steps,
        cfg.batch
    );
    let pb = bar(cfg.steps as u64, "train");
    pb.set_position(trainer.step_count() as u64);
    let st = Stage::start("train");
    let first = trainer.step_count();
    trainer.run(data, Some(dir), &mut |l| {
        pb.set_position(l.step as u64);
        if l.step % 10 == 0 {
            pb.set_message(&format!("loss {:.4}", l.total));
        }
    })?;
    pb.finish_and_clear();
    let secs = st.done();
    let t = trainer.timings;
    let done = (trainer.step_count() - first).max(1);
    let sps = done as f64 / secs.max(1e-9);
    note_training(&t, &trainer.last, done, sps);
    let manifest = TrainManifest {
        inputs,
        request,
        config: cfg,
        pixels: data.len(),
        pixels_left_out: set.left_out,
        pixels_lights: set.lights,
        params_grid: pg,
        params_mlp: pm,
        seconds: secs,
        steps_per_second: sps,
        timings: t,
        last: trainer.last,
        field_hash: fipt_core::fsutil::hash_files(&[dir.join(FIELD_FILE)])?,
    };
    write_json_atomic(&dir.join("manifest.json"), &manifest)?;
    Ok((trainer.field, manifest))
}

/// Writes `{k:03}_kd|ks|roughness|metallic|emission_mask.exr` (+ PNG previews) per view,
/// `_emission.exr` (emitted radiance of the given emitter triangles) when `emission` is given, and
/// `_render.exr` where shadings exist: the trained model's prediction
/// (1 − α)·(kd·Ld + ks·Ls0(σ) + Ls1(σ)) + α·GT.
pub fn export_views(
    field: &dyn fipt_core::field::MaterialField,
    geometry: &Geometry,
    views: &[View],
    factorized: Option<(&NeuralField, &[ViewShadings], &[Image])>,
    emission: Option<&HashMap<u32, Vec3>>,
    observed: Option<&fipt_search::CellCounts>,
    radiance_scale: f32,
    dir: &Path,
) -> Result<()> {
    for (vi, v) in views.iter().enumerate() {
        let (w, h) = (v.camera.width, v.camera.height);
        let recs = primary_records(geometry, v);
        let hit: Vec<usize> = (0..w * h).filter(|&i| recs[i].is_some()).collect();
        let pts: Vec<Vec3> = hit.iter().map(|&i| recs[i].unwrap().hit.p).collect();
        let mats = field.materials(&pts).context("querying the field")?;
        let alpha = field.emission_mask(&pts).context("querying the field")?;
        let mut maps: Vec<(&str, Image)> = ["kd", "ks", "roughness", "metallic", "emission_mask"]
            .iter()
            .map(|n| (*n, Image::new(w, h)))
            .collect();
        for (j, &i) in hit.iter().enumerate() {
            let m = &mats[j];
            maps[0].1.data[i] = m.kd();
            maps[1].1.data[i] = m.ks();
            maps[2].1.data[i] = Vec3::splat(m.roughness);
            maps[3].1.data[i] = Vec3::splat(m.metallic);
            maps[4].1.data[i] = Vec3::splat(alpha[j]);
        }
        if let Some(em) = emission {
            let mut img = Image::new(w, h);
            for &i in &hit {
                if let Some(l) = em.get(&recs[i].unwrap().hit.tri) {
                    img.data[i] = *l;
                }
            }
            maps.push(("emission", img));
        }
        if let Some(counts) = observed {
            let mut img = Image::new(w, h);
            for &i in &hit {
                img.data[i] = Vec3::splat(counts.count(recs[i].unwrap().hit.p) as f32);
            }
            maps.push(("observed", img));
        }
        if let Some((field, sh, imgs)) = factorized {
            let s = &sh[vi];
            let idx: Vec<usize> = hit.iter().copied().filter(|&i| s.valid[i]).collect();
            let unit = field.to_unit(
                &idx.iter()
                    .map(|&i| recs[i].unwrap().hit.p)
                    .collect::<Vec<_>>(),
            );
            let (render, al) = render_factorized(field, &unit, s, &idx)?;
            let mut img = Image::new(w, h);
            for (j, &i) in idx.iter().enumerate() {
                let r = Vec3::from(render[j]);
                img.data[i] = r * (1.0 - al[j]) + imgs[vi].data[i] * al[j];
            }
            maps.push(("render", img));
        }
        for (name, img) in &mut maps {
            let k = v.index;
            let radiance = matches!(*name, "emission" | "render");
            if radiance && radiance_scale != 1.0 {
                for p in &mut img.data {
                    *p *= radiance_scale;
                }
            }
            img.write_exr(&dir.join(format!("{k:03}_{name}.exr")), ExrPrecision::F32)?;
            // Counts: white at 64 training pixels a cell; radiance at the working exposure.
            let exposure = match *name {
                "observed" => 1.0 / 64.0,
                _ if radiance => 1.0 / radiance_scale,
                _ => 1.0,
            };
            img.write_png(
                &dir.join("preview").join(format!("{k:03}_{name}.png")),
                exposure,
            )?;
        }
    }
    Ok(())
}
