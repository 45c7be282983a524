//! Training mechanics: determinism, exact resume from a checkpoint, config validation.
use fipt_core::field::MaterialField;
use fipt_core::image::Image;
use fipt_core::rng::Pcg32;
use fipt_core::shading::{ViewShadings, DEFAULT_LEVELS, NUM_LEVELS};
use fipt_neural::hashgrid::HashGridConfig;
use fipt_neural::{Bounds, FieldConfig, LrDecay, TrainConfig, Trainer, TrainingSet};
use glam::Vec3;

/// One 32×32 "view" of random points with random positive shadings and images.
fn data() -> (TrainingSet, Bounds) {
    let (w, h) = (32, 32);
    let mut r = Pcg32::new(3, 4);
    let mut sh = ViewShadings::zeros(w, h, DEFAULT_LEVELS);
    let mut img = Image::new(w, h);
    let mut pts = vec![];
    for i in 0..w * h {
        sh.valid[i] = i % 7 != 0;
        sh.ld[i] = Vec3::splat(r.next_f32() + 0.1);
        sh.ls0[i] = [Vec3::splat(r.next_f32()); NUM_LEVELS];
        sh.ls1[i] = [Vec3::splat(0.05); NUM_LEVELS];
        img.data[i] = Vec3::new(r.next_f32(), r.next_f32(), r.next_f32());
        pts.push((i % 11 != 0).then(|| Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()) * 3.0));
    }
    let bounds = Bounds::around(pts.iter().flatten().copied(), 1.1).unwrap();
    let set = TrainingSet::new(&[pts], &[sh], &[img], &bounds).unwrap();
    (set, bounds)
}

fn config() -> TrainConfig {
    TrainConfig {
        field: FieldConfig {
            grid: HashGridConfig {
                levels: 4,
                log2_table: 12,
                ..HashGridConfig::default()
            },
            mlp_width: 16,
            mask_width: 16,
            mask_frequencies: 4,
            ..FieldConfig::default()
        },
        steps: 40,
        batch: 256,
        checkpoint_every: 5,
        ..TrainConfig::default()
    }
}

fn query(t: &Trainer) -> Vec<f32> {
    let pts: Vec<Vec3> = (0..50).map(|i| Vec3::splat(i as f32 * 0.06)).collect();
    let m = t.field.materials(&pts).unwrap();
    let a = t.field.emission_mask(&pts).unwrap();
    m.iter()
        .flat_map(|m| [m.albedo.x, m.albedo.y, m.albedo.z, m.roughness, m.metallic])
        .chain(a)
        .collect()
}

#[test]
fn training_set_skips_misses_and_invalid_pixels() {
    let (set, _) = data();
    let expected = (0..1024).filter(|i| i % 7 != 0 && i % 11 != 0).count();
    assert_eq!(set.len(), expected);
}

#[test]
fn same_seed_same_field_and_resume_is_exact() {
    let (set, bounds) = data();
    let cfg = config();
    let mut a = Trainer::new(cfg.clone(), bounds, set.levels).unwrap();
    a.run(&set, None, &mut |_| {}).unwrap();
    let qa = query(&a);
    assert!(qa.iter().all(|v| v.is_finite()));

    let mut b = Trainer::new(cfg.clone(), bounds, set.levels).unwrap();
    b.run(&set, None, &mut |_| {}).unwrap();
    assert_eq!(qa, query(&b), "same seed, different field");

    // Interrupted at step 15 (checkpoint), resumed from disk, finished.
    let dir = std::env::temp_dir().join(format!("fipt-neural-resume-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut c = Trainer::new(cfg.clone(), bounds, set.levels).unwrap();
    c.run_until(&set, 15, Some(&dir), &mut |_| {}).unwrap();
    drop(c);
    let mut d = Trainer::resume(&cfg, bounds, set.levels, "", &dir)
        .unwrap()
        .expect("checkpoint accepted");
    assert_eq!(d.step_count(), 15);
    d.run(&set, Some(&dir), &mut |_| {}).unwrap();
    assert_eq!(
        qa,
        query(&d),
        "resumed run differs from the uninterrupted one"
    );
    // The finished checkpoint loads for queries alone.
    let (field, meta) = fipt_neural::train::load_field(&dir).unwrap();
    // The checkpoint is readable like every other output (safetensors alone writes 0600).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = |f: &str| std::fs::metadata(dir.join(f)).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode("field.safetensors"), mode("checkpoint.json"));
    }
    assert_eq!(meta.step, 40);
    let pts: Vec<Vec3> = (0..50).map(|i| Vec3::splat(i as f32 * 0.06)).collect();
    assert_eq!(
        field.materials(&pts).unwrap(),
        d.field.materials(&pts).unwrap()
    );
    assert!(
        Trainer::resume(&cfg, bounds, set.levels, "other scene", &dir)
            .unwrap()
            .is_err()
    );
    // Changed settings are refused with a reason, not silently mixed.
    let mut other = cfg.clone();
    other.field.mlp_width = 32;
    assert!(Trainer::resume(&other, bounds, set.levels, "", &dir)
        .unwrap()
        .is_err());
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A process killed after writing a checkpoint's tensors but before its `checkpoint.json`
/// leaves the tensors one checkpoint ahead of the JSON. Resuming must follow the tensors'
/// own metadata: mixing step 15's JSON with step 20's tensors gave another field (found by
/// `fipt-cli/tests/kill.rs` with FIPT_KILL_SEED=5).
#[test]
fn a_kill_between_the_checkpoint_files_still_resumes_exactly() {
    let (set, bounds) = data();
    let cfg = config();
    let mut a = Trainer::new(cfg.clone(), bounds, set.levels).unwrap();
    a.run(&set, None, &mut |_| {}).unwrap();
    let qa = query(&a);

    let dir = std::env::temp_dir().join(format!("fipt-neural-kill-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut c = Trainer::new(cfg.clone(), bounds, set.levels).unwrap();
    c.run_until(&set, 15, Some(&dir), &mut |_| {}).unwrap();
    let old_json = std::fs::read(dir.join("checkpoint.json")).unwrap();
    c.run_until(&set, 20, Some(&dir), &mut |_| {}).unwrap();
    drop(c);
    // The kill: step 20's tensors, step 15's JSON.
    std::fs::write(dir.join("checkpoint.json"), old_json).unwrap();
    let mut d = Trainer::resume(&cfg, bounds, set.levels, "", &dir)
        .unwrap()
        .expect("checkpoint accepted");
    assert_eq!(d.step_count(), 20, "resumed at the tensors' step");
    d.run(&set, Some(&dir), &mut |_| {}).unwrap();
    assert_eq!(
        qa,
        query(&d),
        "resumed run differs from the uninterrupted one"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_settings_are_rejected_with_the_key() {
    let mut cfg = config();
    cfg.field.grid.log2_table = 40;
    let (set, bounds) = data();
    let e = Trainer::new(cfg, bounds, set.levels)
        .err()
        .expect("rejected")
        .to_string();
    assert!(e.contains("log2_table"), "{e}");
    let bad: Result<TrainConfig, _> = serde_json::from_str(r#"{"steps": 10, "bogus": 1}"#);
    assert!(bad.is_err());
    for (key, set_bad) in [
        (
            "roughness_gain",
            (|c: &mut TrainConfig| c.field.roughness_gain = 0.0) as fn(&mut TrainConfig),
        ),
        ("roughness_init", |c| c.field.roughness_init = 1.5),
        ("segment_weight", |c| c.segment_weight = f32::NAN),
        ("roughness_prior", |c| c.roughness_prior = -1.0),
        ("lr_decay", |c| c.lr_decay.factor = 0.0),
        ("lr_decay", |c| c.lr_decay.start = 1.5),
    ] {
        let mut c = config();
        set_bad(&mut c);
        let e = Trainer::new(c, bounds, set.levels)
            .err()
            .expect("rejected")
            .to_string();
        assert!(e.contains(key), "{key}: {e}");
    }
}

/// The decay keeps the rate until `start`, ends at `factor` on the last step, and is geometric
/// in between; the defaults (and the reference) keep it constant.
#[test]
fn learning_rate_decay_follows_its_schedule() {
    let d = LrDecay {
        start: 0.5,
        factor: 0.1,
    };
    let steps = 101;
    assert_eq!(d.scale(0, steps), 1.0);
    assert_eq!(d.scale(50, steps), 1.0);
    assert!((d.scale(75, steps) - 0.1f32.sqrt()).abs() < 1e-6);
    assert!((d.scale(100, steps) - 0.1).abs() < 1e-6);
    let mut prev = 1.0;
    for s in 0..steps {
        let v = d.scale(s, steps);
        assert!(v <= prev && v >= 0.1 - 1e-6, "step {s}: {v}");
        prev = v;
    }
    for s in [0, 500, 999] {
        assert_eq!(LrDecay::default().scale(s, 1000), 1.0);
        assert_eq!(TrainConfig::reference().lr_decay.scale(s, 1000), 1.0);
    }
    // A decayed run ends elsewhere than a constant-rate one (the schedule reaches Adam).
    let (set, bounds) = data();
    let mut runs = vec![];
    for decay in [LrDecay::default(), d] {
        let mut cfg = config();
        cfg.lr_decay = decay;
        let mut t = Trainer::new(cfg, bounds, set.levels).unwrap();
        t.run(&set, None, &mut |_| {}).unwrap();
        runs.push(query(&t));
    }
    assert_ne!(runs[0], runs[1]);
}

/// A fresh field starts at σ = `roughness_init` whatever the gain (hash features start near 0,
/// so σ's output is its bias, up to the hidden layers' small random biases times the gain).
#[test]
fn roughness_starts_at_its_setting() {
    let (_, bounds) = data();
    let pts: Vec<Vec3> = (0..20).map(|i| Vec3::splat(0.2 + i as f32 * 0.1)).collect();
    for (gain, init) in [(1.0, 0.51), (10.0, 0.98), (4.0, 0.3), (10.0, 0.02)] {
        let mut cfg = config();
        cfg.field.roughness_gain = gain;
        cfg.field.roughness_init = init;
        let t = Trainer::new(cfg, bounds, DEFAULT_LEVELS).unwrap();
        for m in t.field.materials(&pts).unwrap() {
            assert!(
                (m.roughness - init).abs() < 0.02,
                "gain {gain}: σ {} for init {init}",
                m.roughness
            );
        }
    }
}

#[test]
fn segment_ids_are_renumbered_densely_and_must_cover_every_pixel() {
    let (set, _) = data();
    // Ids 1000 and 7 alternate, negative ids mean none.
    let ids: Vec<i64> = (0..1024)
        .map(|i| match i % 3 {
            0 => 1000,
            1 => 7,
            _ => -1,
        })
        .collect();
    let origin = set.origin.clone();
    let seg = set.with_segments(&[ids]).unwrap();
    assert_eq!(seg.segments, 2);
    let first = |r: usize| {
        origin
            .iter()
            .position(|&(_, i)| i as usize % 3 == r)
            .map(|j| seg.segment[j])
            .unwrap()
    };
    let (a, b) = (first(0), first(1));
    assert!(a != b && a < 2 && b < 2);
    for (j, &(_, i)) in origin.iter().enumerate() {
        let want = match i % 3 {
            0 => a,
            1 => b,
            _ => fipt_neural::ops::NO_SEGMENT,
        };
        assert_eq!(seg.segment[j], want, "pixel {i}");
    }
    // Too few ids for the view: an error, not a silent default.
    let (set, _) = data();
    assert!(set.with_segments(&[vec![0; 100]]).is_err());
}

/// A warm start copies the trained weights exactly (same queries before any step), continues
/// from there (its first loss is the trained field's, not a fresh field's), and refuses a
/// field of other sizes.
#[test]
fn warm_start_continues_from_the_previous_field() {
    let (set, bounds) = data();
    let cfg = config();
    let mut a = Trainer::new(cfg.clone(), bounds, set.levels).unwrap();
    a.run(&set, None, &mut |_| {}).unwrap();
    let trained_loss = a.last.image;

    let mut w = Trainer::new(cfg.clone(), bounds, set.levels).unwrap();
    let fresh = query(&w);
    w.warm_start(&a.field).unwrap();
    assert_eq!(query(&w), query(&a), "warm start must copy the field");
    assert_ne!(fresh, query(&a));
    assert_eq!(w.step_count(), 0);
    let first = w.step(&set).unwrap().image;
    let mut f = Trainer::new(cfg.clone(), bounds, set.levels).unwrap();
    let fresh_first = f.step(&set).unwrap().image;
    assert!(
        (first - trained_loss).abs() < 0.25 * trained_loss
            && (first - fresh_first).abs() > 0.25 * trained_loss,
        "warm first loss {first}, fresh {fresh_first}, trained {trained_loss}"
    );

    let mut other = cfg.clone();
    other.field.mlp_width = 32;
    let mut o = Trainer::new(other, bounds, set.levels).unwrap();
    assert!(o.warm_start(&a.field).is_err());
}

/// The hash-grid trainer through the `FieldTrainer` contract: a training equals the
/// `Trainer`'s of the same settings, the field reloads from the round's folder with the same
/// answers, a second call resumes the finished checkpoint without a step, and a warm start
/// from a field of another kind is refused with its name.
#[test]
fn hash_grid_trainer_keeps_the_contract() {
    use fipt_core::trainer::{FieldTrainer, TrainRound};
    use fipt_neural::HashGridTrainer;
    let (set, bounds) = data();
    let dir = std::env::temp_dir().join(format!("fipt-hash-grid-trainer-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let trainer = HashGridTrainer::new(config()).unwrap();
    let notes = std::sync::Mutex::new(Vec::<String>::new());
    let note = |s: &str| notes.lock().unwrap().push(s.to_string());
    let round = TrainRound {
        dir: &dir,
        inputs: "set-1",
        resume: true,
        warm: None,
        note: &note,
    };
    let mut steps = vec![];
    let trained = trainer
        .train(&set, &round, &mut |k, n, _| steps.push((k, n)))
        .unwrap();
    assert_eq!(steps.first(), Some(&(1, 40)));
    assert_eq!(steps.last(), Some(&(40, 40)));
    let pts: Vec<Vec3> = (0..50).map(|i| Vec3::splat(i as f32 * 0.06)).collect();
    let answers = |f: &dyn MaterialField| {
        let m = f.materials(&pts).unwrap();
        (m, f.emission_mask(&pts).unwrap())
    };
    let mut direct = Trainer::new(config(), bounds, set.levels).unwrap();
    direct.run(&set, None, &mut |_| {}).unwrap();
    assert_eq!(answers(trained.field.as_ref()), answers(&direct.field));
    assert_eq!(
        trained.files,
        [std::path::PathBuf::from("field.safetensors")]
    );
    assert_eq!(trained.settings["steps"], 40);
    let loaded = trainer.load(&dir).unwrap();
    assert_eq!(answers(loaded.as_ref()), answers(&direct.field));
    let mut again = 0;
    let resumed = trainer
        .train(&set, &round, &mut |_, _, _| again += 1)
        .unwrap();
    assert_eq!(again, 0, "a finished checkpoint resumes with no step left");
    assert_eq!(answers(resumed.field.as_ref()), answers(&direct.field));
    assert!(notes
        .lock()
        .unwrap()
        .iter()
        .any(|n| n.starts_with("resuming from step 40")));

    struct Grey;
    impl MaterialField for Grey {
        fn name(&self) -> &str {
            "grey"
        }
        fn materials(&self, p: &[Vec3]) -> fipt_core::Result<Vec<fipt_core::field::Material>> {
            let m = fipt_core::field::Material {
                albedo: Vec3::splat(0.5),
                roughness: 1.0,
                metallic: 0.0,
            };
            Ok(vec![m; p.len()])
        }
        fn emission_mask(&self, p: &[Vec3]) -> fipt_core::Result<Vec<f32>> {
            Ok(vec![0.0; p.len()])
        }
    }
    let warm = TrainRound {
        resume: false,
        warm: Some(&Grey),
        ..round
    };
    let err = trainer.train(&set, &warm, &mut |_, _, _| {}).err().unwrap();
    assert!(err.to_string().contains("`grey`"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
