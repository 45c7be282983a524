//! `fipt train <scene> --out OUT`: fit the material field to the bake in OUT/bake, write the
//! checkpoint to OUT/train/ and per-view maps to OUT/train/views/<split>/.
use crate::bail;
use crate::error::Result;
pub use crate::maps::export_views;
use crate::observe::{bar, Stage};
use crate::scene::SceneRef;
use crate::search::Searched;
use crate::train_set::{build_set, second_sides, segment_ids, BuiltSet};
pub use crate::trained::{field_changed, TrainManifest, FIELD_FILE};
use fipt_bake::bake_store::{fingerprint, load_for_inputs, load_if_current, StoredShadings};
use fipt_core::field::MaterialField;
use fipt_core::fsutil::{read_json, write_json_atomic};
use fipt_core::image::BadPixelPolicy;
use fipt_core::presets::Presets;
use fipt_core::trainer::{FieldTrainer, TrainRound};
use fipt_neural::{NeuralField, TrainConfig};
pub use fipt_shading::records::view_points;
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

/// The fingerprint of a training of `inputs` by `trainer` with `settings`.
fn fingerprint_of(inputs: &str, trainer: &str, settings: &serde_json::Value) -> String {
    let cfg = fipt_core::fsutil::hash_bytes(settings.to_string().as_bytes());
    fipt_core::fsutil::hash_bytes(format!("{inputs}|{trainer}|{cfg}").as_bytes())
}

/// The trainer `fipt train` uses, with its settings: `[pipeline] trainer` when the config file
/// has a `[pipeline]` table (its settings as `fipt run` takes them), else the built-in one with
/// `set`'s settings. `steps` overrides the trainer's `steps` setting.
fn chosen_trainer(
    a: &TrainRequest,
    set: &TrainConfig,
    components: &crate::Components,
) -> Result<(Box<dyn FieldTrainer>, serde_json::Value)> {
    let file = a.config.as_deref();
    let with_pipeline = file.filter(|p| crate::config::has_table(p, "pipeline").unwrap_or(false));
    let (name, mut settings) = match with_pipeline {
        Some(path) => {
            let cfg = fipt_pipeline::check::load(&a.preset, Some(path), components)?;
            let name = cfg.pipeline.trainer.clone();
            let settings =
                components.settings_of(crate::names::Kind::Trainer, &name, &cfg, &a.preset)?;
            (name, settings)
        }
        None => (
            crate::run_config::PipelineConfig::default().trainer,
            serde_json::to_value(set)?,
        ),
    };
    if let Some(steps) = a.steps {
        match settings.as_object_mut().filter(|o| o.contains_key("steps")) {
            Some(o) => {
                o.insert("steps".into(), steps.into());
            }
            None => bail!(
                "--steps: trainer `{name}` has no `steps` setting; set its own in [plugins.{name}]"
            ),
        }
    }
    Ok((components.trainer(&name, &settings)?, settings))
}

/// The training alone (`fipt train`); returns the folder written. With a run config, the bake
/// must be the one its `[pipeline] baker` and settings make ([`run_baker`]), and
/// the trainer is its `[pipeline] trainer`.
pub fn train_only(a: TrainRequest, components: &crate::Components) -> Result<PathBuf> {
    let wanted = run_baker(&a.preset, a.config.as_deref(), components)?;
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
    let (trainer, settings) = chosen_trainer(&a, &cfg, components)?;
    let scene = crate::scene::load(&a.scene, a.bad_pixels, &Default::default())?;
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
    let on = TrainOn {
        scene: &SceneRef::loaded(&scene),
        shadings: &stored,
        shadings_id: &fingerprint(&bake),
        set: &cfg,
        trainer: trainer.as_ref(),
        settings: &settings,
        search: None,
    };
    let (field, _, fresh) = stage(&on, &dir, a.force, None, false)?;
    if fresh || !dir.join("views").is_dir() {
        export_train_views(&scene, field.as_ref(), &stored, &dir)?;
    }
    Ok(dir)
}

/// `fipt train`'s per-view maps; on the training views also the field's factorised re-render
/// when the field is the hash-grid trainer's (it reads the shadings).
fn export_train_views(
    scene: &crate::scene::LoadedScene,
    field: &dyn MaterialField,
    stored: &StoredShadings,
    dir: &Path,
) -> Result<()> {
    let neural = field.as_any().and_then(|f| f.downcast_ref::<NeuralField>());
    let shadings = match neural {
        Some(_) => stored.load_all()?,
        None => {
            crate::note!(
                "no factorised re-renders (_render.exr): the field is not the hash-grid trainer's"
            );
            vec![]
        }
    };
    let st = Stage::start("export maps");
    let split = scene.ds.train();
    for s in &scene.ds.splits {
        let train = s.name == split.name;
        export_views(
            field,
            &scene.geometry,
            &s.views,
            neural
                .filter(|_| train)
                .map(|f| (f, &shadings[..], &scene.images[..])),
            None,
            None,
            scene.exposure,
            &dir.join("views").join(&s.name),
        )?;
    }
    st.done();
    Ok(())
}

/// What a training round is given.
pub(crate) struct TrainOn<'a> {
    pub(crate) scene: &'a SceneRef<'a>,
    /// The shadings, and their fingerprint.
    pub(crate) shadings: &'a StoredShadings,
    pub(crate) shadings_id: &'a str,
    /// `[train]`: which pixels, segments and targets the training set holds.
    pub(crate) set: &'a TrainConfig,
    /// The trainer, and the settings it was built from.
    pub(crate) trainer: &'a dyn FieldTrainer,
    pub(crate) settings: &'a serde_json::Value,
    /// The search's answer, whose targets the set carries.
    pub(crate) search: Option<&'a Searched>,
}

/// The `[train]` settings that decide which pixels the set holds (whichever trainer runs).
fn set_settings_id(set: &TrainConfig) -> String {
    fipt_core::fsutil::hash_json(&serde_json::json!({
        "bleed_radius": set.bleed_radius,
        "bleed_contrast": set.bleed_contrast,
        "seed": set.seed,
        "set_limit": set.set_limit(),
    }))
}

/// Which pixels the set holds (its (view, pixel) list, hashed): part of the set's inputs, so
/// that a checkpoint is resumed only on the same pixels.
fn pixels_id(set: &fipt_core::training_set::TrainingSet) -> String {
    let mut h = fipt_core::fsutil::Fnv::new();
    for chunk in set.origin.chunks(65_536) {
        let bytes: Vec<u8> = (chunk.iter())
            .flat_map(|&(v, i)| [v, i])
            .flat_map(u32::to_le_bytes)
            .collect();
        h.feed(&bytes);
    }
    h.hex()
}

/// What decides a training before its set is built: the inputs, the shadings, the warm start,
/// the trainer's settings as given, the search's targets, the segment ids and the settings that
/// choose the set's pixels; and the same key as written before 2026-11-28 (without the last,
/// then part of the trainer's settings). A finished training of the same trainer with either key
/// is reused without building the training set (a resumed run skips it).
fn request_key(
    on: &TrainOn,
    warm: Option<&str>,
    segments: Option<&(crate::train_set::SegmentKind, String)>,
) -> (String, String) {
    let search = on.search;
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
    let legacy = format!(
        "{}|{}|{}|{}|{}|{}",
        on.scene.cache_key,
        on.shadings_id,
        warm.unwrap_or("none"),
        fipt_core::fsutil::hash_json(on.settings),
        targets.as_deref().unwrap_or("none"),
        segments.as_deref().unwrap_or("none")
    );
    (format!("{legacy}|set:{}", set_settings_id(on.set)), legacy)
}

/// What [`finished`] found in a round's folder.
enum Found {
    /// A finished training that fits, with its field.
    Done(Box<dyn MaterialField>, TrainManifest),
    /// None that fits: train, resuming a checkpoint if the trainer has one.
    Train,
    /// A finished training whose field was changed since: train afresh.
    Afresh,
}

/// A finished training of `trainer` in `dir` whose manifest `fits`, with its field (loaded by
/// `trainer`).
fn finished(
    dir: &Path,
    trainer: &dyn FieldTrainer,
    fits: impl Fn(&TrainManifest) -> bool,
) -> Found {
    let Ok(m) = read_json::<TrainManifest>(&dir.join("manifest.json")) else {
        return Found::Train;
    };
    if !fits(&m) || m.trainer != trainer.name() {
        return Found::Train;
    }
    if let Some(why) = field_changed(dir) {
        // Its checkpoint may be the same file: the trainer starts afresh.
        crate::note!("warning: {why}: training again");
        let _ = std::fs::remove_file(dir.join("manifest.json"));
        return Found::Afresh;
    }
    let field = match trainer.load(dir) {
        Ok(f) => f,
        Err(e) => {
            crate::note!(
                "training again: the finished field in {} does not load ({e})",
                dir.display()
            );
            return Found::Train;
        }
    };
    let steps = m
        .config
        .get("steps")
        .map_or(String::new(), |s| format!("{s} steps in "));
    crate::note!(
        "reusing the trained field in {} ({steps}{:.1} s); --force to redo it",
        dir.display(),
        m.seconds
    );
    crate::observe::reused(Some(m.seconds));
    Found::Done(field, m)
}

/// The training stage: reuses a finished run in `dir` (same inputs and settings) unless
/// `force`, or has the trainer train (resuming an interrupted training, or from `warm`'s field,
/// identified by its fingerprint, when given). The shadings are freed once the training set
/// holds them (they do not stay beside it through the training). Returns the field, the
/// manifest and whether training ran now.
pub(crate) fn stage(
    on: &TrainOn,
    dir: &Path,
    force: bool,
    warm: Option<(&dyn MaterialField, &str)>,
    must_reuse: bool,
) -> Result<(Box<dyn MaterialField>, TrainManifest, bool)> {
    let scene = on.scene;
    let segments = segment_ids(scene, on.set.segments)?;
    let warm_id = warm.map(|w| w.1);
    let (request, legacy) = request_key(on, warm_id, segments.as_ref());
    let mut resume = !force;
    if !force {
        match finished(dir, on.trainer, |m| {
            m.request == request || m.request == legacy
        }) {
            Found::Done(field, m) => return Ok((field, m, false)),
            Found::Afresh => resume = false,
            Found::Train => {}
        }
    }
    if must_reuse {
        bail!(
            "{}: this training round is not done, and a shard run (--shard) does not train (training runs on one machine): run `fipt run` without --shard (with --stop-before refine) once the shards before it are done",
            dir.display()
        );
    }
    let st = Stage::start("training set");
    let set = build_set(scene, on.shadings, on.set, segments.as_ref(), on.search)?;
    let mut inputs = format!(
        "{}+shadings:{}+warm:{}+pixels:{}",
        scene.cache_key,
        on.shadings_id,
        warm_id.unwrap_or("none"),
        pixels_id(&set.data)
    );
    if let Some((_, id)) = &segments {
        inputs += &format!("+segments:{id}");
    }
    if let Some(id) = &set.targets_id {
        inputs += &format!("+targets:{id}");
    }
    st.done();
    let round = (inputs, request, resume);
    let (field, manifest) = train_and_record(on, &set, round, dir, warm)?;
    Ok((field, manifest, true))
}

/// Has the trainer train on the set (checkpoints in `dir`) and writes the round's manifest.
/// `round` is the set's inputs, the request key and whether a checkpoint may be resumed.
fn train_and_record(
    on: &TrainOn,
    set: &BuiltSet,
    round: (String, String, bool),
    dir: &Path,
    warm: Option<(&dyn MaterialField, &str)>,
) -> Result<(Box<dyn MaterialField>, TrainManifest)> {
    let (inputs, request, resume) = round;
    std::fs::create_dir_all(dir).map_err(|e| fipt_core::CoreError::io(dir, e))?;
    let note = |s: &str| crate::note!("{s}");
    let round = TrainRound {
        dir,
        inputs: &inputs,
        resume,
        warm: warm.map(|w| w.0),
        note: &note,
    };
    let mut pb = None;
    let st = Stage::start("train");
    let trained = on
        .trainer
        .train(&set.data, &round, &mut |step, steps, loss| {
            let pb = pb.get_or_insert_with(|| bar(steps as u64, "train"));
            pb.set_position(step as u64);
            if step % 10 == 0 {
                pb.set_message(&format!("loss {loss:.4}"));
            }
        })?;
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    let secs = st.done();
    let name = on.trainer.name();
    let bad = |f: &PathBuf| {
        !f.is_relative() || f.components().any(|c| c == std::path::Component::ParentDir)
    };
    if trained.files.is_empty() || trained.files.iter().any(bad) {
        bail!(
            "trainer `{name}` named {:?} as its field's files: it must name at least one, each relative to the round's folder {}",
            trained.files,
            dir.display()
        );
    }
    let files: Vec<PathBuf> = trained.files.iter().map(|f| dir.join(f)).collect();
    let manifest = TrainManifest {
        fingerprint: fingerprint_of(&inputs, name, &trained.settings),
        inputs,
        request,
        trainer: name.to_string(),
        config: trained.settings,
        pixels: set.data.len(),
        pixels_left_out: set.left_out,
        pixels_lights: set.lights,
        seconds: secs,
        report: trained.report,
        field_files: (trained.files.iter())
            .map(|f| f.to_string_lossy().into_owned())
            .collect(),
        field_hash: fipt_core::fsutil::hash_files(&files)?,
    };
    write_json_atomic(&dir.join("manifest.json"), &manifest)?;
    Ok((trained.field, manifest))
}

/// What `fipt train` checks its bake against: with a run config (a file with a `[pipeline]`
/// table), the name and settings of the baker `fipt run` would use (its bake is reused only if
/// it is that one); None otherwise (any finished bake of the inputs). A run config whose method
/// is not FIPT's is refused: `fipt train` trains FIPT's field.
fn run_baker(
    preset: &str,
    file: Option<&Path>,
    components: &crate::Components,
) -> Result<Option<(String, serde_json::Value)>> {
    let Some(path) = file.filter(|p| crate::config::has_table(p, "pipeline").unwrap_or(false))
    else {
        return Ok(None);
    };
    let cfg = fipt_pipeline::check::load(preset, Some(path), components)?;
    let method = &cfg.pipeline.method;
    if method != crate::names::FIPT_METHOD {
        crate::bail!(
            "{}: [pipeline] method = \"{method}\": `fipt train` trains FIPT's field; run the method with `fipt run --config {}`",
            path.display(),
            path.display()
        );
    }
    let name = &cfg.pipeline.baker;
    let settings = components.settings_of(crate::names::Kind::Baker, name, &cfg, preset)?;
    let baker = components.baker(name, &settings, cfg.model.brdf)?;
    Ok(Some((baker.name().to_string(), settings)))
}

#[cfg(test)]
mod run_baker_tests {
    use super::run_baker;
    use fipt_pipeline::Components;

    /// `fipt train` checks its bake against the baker a run would use, by its
    /// implementation's name and settings; a run config of another method is refused, and a
    /// plain bake config checks nothing.
    #[test]
    fn fipt_train_checks_its_bake_against_the_runs_baker() {
        let dir = std::env::temp_dir().join(format!("fipt-run-baker-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("run.toml");
        std::fs::write(
            &p,
            "[pipeline]\nbaker = \"slf\"\n[bake]\ndiffuse_samples = 40\n",
        )
        .unwrap();
        let c = Components::builtin();
        let (_, settings) = fipt_pipeline::bake::chosen_baker("fast", Some(&p), &c).unwrap();
        let (imp, same) = run_baker("fast", Some(&p), &c).unwrap().unwrap();
        assert_eq!((imp.as_str(), &same), ("fipt-slf/principled", &settings));
        std::fs::write(&p, "[pipeline]\nmethod = \"ipt\"\n").unwrap();
        let err = run_baker("fast", Some(&p), &c).unwrap_err().to_string();
        assert!(err.contains("trains FIPT's field"), "{err}");
        std::fs::write(&p, "[bake]\ndiffuse_samples = \"many\"\n").unwrap();
        assert!(run_baker("fast", Some(&p), &c).unwrap().is_none());
        std::fs::remove_dir_all(&dir).ok();
    }
}
