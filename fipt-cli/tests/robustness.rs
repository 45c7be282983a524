//! No lost work and no crash on any input (docs/robustness.md, *Probe cases*): on one tiny
//! finished run, every class of bad request is refused with a message naming what to change,
//! nothing in the run folder is overwritten by another command, and every stored artifact
//! changed after it was written is computed again (the outputs come back byte for byte).
mod common;
use common::{fipt, tiny_resumable_scene, tmp, walk};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Every file under `dir` with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    walk(dir)
        .into_iter()
        .map(|p| {
            let b = std::fs::read(&p).unwrap();
            (p, b)
        })
        .collect()
}

/// A refusal: a clean non-zero exit (not a panic) whose message holds every one of `words`.
fn refused(args: &[&str], words: &[&str]) {
    let (ok, _, err) = fipt(args);
    assert!(!ok, "accepted: fipt {}", args.join(" "));
    assert!(
        !err.contains("panicked"),
        "panic: fipt {}\n{err}",
        args.join(" ")
    );
    for w in words {
        assert!(
            err.contains(w),
            "fipt {}: no `{w}` in\n{err}",
            args.join(" ")
        );
    }
}

/// The folder of a run's final field (`train`, `train1`, …: the last round's).
fn final_train(run: &Path) -> String {
    (0..10)
        .map(|r| {
            if r == 0 {
                "train".to_string()
            } else {
                format!("train{r}")
            }
        })
        .take_while(|d| run.join(d).join("field.safetensors").is_file())
        .last()
        .expect("a trained field")
}

struct Fixture {
    scene: common::Scratch,
    cfg: PathBuf,
    run: common::Scratch,
}

impl Fixture {
    fn new(name: &str) -> Fixture {
        let (scene, cfg) = tiny_resumable_scene(&format!("{name}-scene"), 200);
        let run = tmp(&format!("{name}-run"));
        let f = Fixture { scene, cfg, run };
        let (ok, _, err) = f.fipt_run(&f.run, &[]);
        assert!(ok, "{err}");
        f
    }

    fn fipt_run(&self, out: &Path, extra: &[&str]) -> (bool, String, String) {
        let mut args = vec![
            "run",
            self.scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--config",
            self.cfg.to_str().unwrap(),
        ];
        args.extend(extra);
        fipt(&args)
    }

    fn r(&self) -> &str {
        self.run.to_str().unwrap()
    }

    fn cams(&self) -> String {
        self.scene
            .join("val/transforms.json")
            .to_string_lossy()
            .into()
    }
}

#[test]
fn no_command_writes_into_a_run_or_scene_folder_and_options_have_ranges() {
    let f = Fixture::new("rb-folders");
    let (r, cams) = (f.r(), f.cams());
    let before = snapshot(&f.run);
    let val = f.run.join("views/val");
    let in_scene = f.scene.join("renders");
    for out in [
        val.to_str().unwrap(),
        r,
        &format!("{r}/renders"),
        in_scene.to_str().unwrap(),
    ] {
        refused(
            &["render", r, "--cameras", &cams, "--out", out, "--spp", "2"],
            &["folder of its own"],
        );
        refused(
            &["export", r, "--format", "obj", "--out", out],
            &["folder of its own"],
        );
    }
    // A copy never goes inside its source, whether or not the folder exists yet.
    let s = f.scene.to_str().unwrap();
    let nested = f.scene.join("new/copy");
    refused(
        &[
            "degrade",
            s,
            "--out",
            nested.to_str().unwrap(),
            "--ldr",
            "fixed",
        ],
        &["outside the source"],
    );
    assert!(!f.scene.join("new").exists());
    // A file where an output folder should be, or above it: named with the fix, at once.
    let afile = tmp("rb-folders-afile");
    std::fs::write(&afile, "x").unwrap();
    let under = afile.join("sub");
    for o in [afile.to_str().unwrap(), under.to_str().unwrap()] {
        let words = &["rb-folders-afile", "is a file, not a folder"][..];
        refused(
            &["render", r, "--cameras", &cams, "--out", o, "--spp", "2"],
            words,
        );
        refused(&["export", r, "--format", "obj", "--out", o], words);
        refused(&["degrade", s, "--out", o, "--ldr", "fixed"], words);
        refused(&["run", s, "--out", o], words);
        refused(&["synth", "cornell", "--out", o, "--force"], words);
        refused(&["demo", "--dir", o], words);
    }
    let _ = std::fs::remove_file(&afile);
    // A mistyped preset is refused before the demo renders its scene.
    let demo = tmp("rb-folders-demo");
    refused(
        &["demo", "--preset", "fsat", "--dir", demo.to_str().unwrap()],
        &["unknown preset `fsat`"],
    );
    assert!(!demo.exists(), "the demo wrote before refusing its preset");
    // A mistyped scene path leaves no run folder behind.
    let nowhere = tmp("rb-folders-nowhere");
    refused(
        &[
            "run",
            nowhere.join("scene").to_str().unwrap(),
            "--out",
            demo.to_str().unwrap(),
        ],
        &["no such folder"],
    );
    assert!(
        !demo.exists(),
        "a run of a missing scene made its output folder"
    );
    // A run's output never nests in another run's folder or in a scene's.
    let (ok, _, err) = f.fipt_run(&f.run.join("again"), &[]);
    assert!(!ok && err.contains("folder of its own"), "{err}");
    assert_eq!(before, snapshot(&f.run), "the run folder was written to");

    let out = tmp("rb-folders-out");
    let o = out.to_str().unwrap();
    // The bad settings and lights files, in a folder of their own (removed with it).
    let files = tmp("rb-folders-files");
    std::fs::create_dir_all(&files).unwrap();
    options_out_of_range_are_refused(r, &cams, o);
    // Settings out of range: refused by key before the run folder is touched.
    for (toml, key) in [
        (
            "[emitters]\nsamples_per_triangle = 100000000000\n",
            "emitters.samples_per_triangle",
        ),
        ("[render]\nspp = 4000000000\n", "render.spp"),
        ("[train]\nsteps = 0\n", "steps = 0"),
    ] {
        let cfg = files.join("bad.toml");
        std::fs::write(&cfg, toml).unwrap();
        let fresh = tmp("rb-folders-fresh");
        let s = f.scene.to_str().unwrap();
        let c = cfg.to_str().unwrap();
        refused(
            &["run", s, "--out", fresh.to_str().unwrap(), "--config", c],
            &[key],
        );
        assert!(
            !fresh.join("report.json").exists(),
            "{key}: report.json written"
        );
    }
    // Lights that would overflow the tracer or hide the scene.
    for (light, words) in [
        (
            r#"{"type": "point", "position": [0, 1, 0], "intensity": [1e38, 1, 1]}"#,
            &["intensity", "overflows"][..],
        ),
        (
            r#"{"type": "sphere", "center": [0, 1, 0], "radius": 1e30, "radiance": [1, 1, 1]}"#,
            &["radius"][..],
        ),
        (
            r#"{"type": "sphere", "center": [0, 1, 0], "radius": 100, "radiance": [1, 1, 1]}"#,
            &["encloses camera"][..],
        ),
    ] {
        let p = files.join("bad.lights.json");
        std::fs::write(&p, light).unwrap();
        let l = p.to_str().unwrap();
        let args = [
            "render",
            r,
            "--cameras",
            &cams,
            "--out",
            o,
            "--spp",
            "2",
            "--lights",
            l,
        ];
        refused(&args, words);
    }
    for p in [f.scene, f.run, out] {
        let _ = std::fs::remove_dir_all(p);
    }
}

/// `--spp`, `--texel` and `--max-atlas` out of range are refused, naming the option.
fn options_out_of_range_are_refused(r: &str, cams: &str, o: &str) {
    for (spp, key) in [("4000000000", "--spp"), ("0", "--spp")] {
        refused(
            &["render", r, "--cameras", cams, "--out", o, "--spp", spp],
            &[key, "use [1, 65536]"],
        );
    }
    for (opt, v) in [
        ("--texel", "0"),
        ("--texel", "nan"),
        ("--max-atlas", "1000000"),
    ] {
        refused(
            &["export", r, "--format", "obj", "--out", o, opt, v],
            &[opt],
        );
    }
}

#[test]
fn readers_refuse_mismatched_and_truncated_inputs_without_a_panic() {
    let f = Fixture::new("rb-readers");
    let (r, cams, s) = (f.r(), f.cams(), f.scene.to_str().unwrap().to_string());
    let out = tmp("rb-readers-out");
    let o = out.to_str().unwrap();
    // A map of another size: named with both sizes.
    let kd = f.run.join("views/val/000_kd.exr");
    let original = std::fs::read(&kd).unwrap();
    fipt_core::image::Image::new(4, 4)
        .write_exr(&kd, fipt_core::image::ExrPrecision::F32)
        .unwrap();
    refused(&["eval", &s, r], &["000_kd.exr", "4×4"]);
    // A map of NaN: refused with the count, not scored (it scored 20.8 dB before).
    std::fs::write(&kd, &original).unwrap();
    let mut nan = fipt_core::image::Image::read_exr(&kd).unwrap();
    let n = nan.data.len();
    nan.data.iter_mut().for_each(|p| *p = glam::Vec3::NAN);
    nan.write_exr(&kd, fipt_core::image::ExrPrecision::F32)
        .unwrap();
    refused(&["eval", &s, r], &["000_kd.exr", &format!("{} NaN", 3 * n)]);
    std::fs::write(&kd, &original).unwrap();
    // A ground-truth map that cannot be read: named, not a view silently left unscored.
    let gt = f.scene.join("val/DiffCol");
    let gt0 = std::fs::read_dir(&gt)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .min()
        .unwrap();
    let whole = std::fs::read(&gt0).unwrap();
    std::fs::write(&gt0, &whole[..whole.len() / 2]).unwrap();
    refused(&["eval", &s, r], &["ground truth", "DiffCol"]);
    std::fs::write(&gt0, &whole).unwrap();
    let (ok, _, err) = fipt(&["eval", &s, r]);
    assert!(ok, "{err}");
    // Truncated files, one at a time: each consumer refuses cleanly.
    let last = final_train(&f.run);
    let (field, checkpoint) = (
        format!("{last}/field.safetensors"),
        format!("{last}/checkpoint.json"),
    );
    let render = vec!["render", r, "--cameras", &cams, "--out", o, "--spp", "2"];
    let export = vec!["export", r, "--format", "obj", "--out", o];
    let (c, rerun) = (f.cfg.to_str().unwrap(), vec!["run", &s, "--out", r]);
    let rerun = [&rerun[..], &["--config", c]].concat();
    // (file, the command that reads it, whether it still succeeds: a run redoes what it finds
    // damaged).
    let cases: [(&str, Vec<&str>, bool); 7] = [
        ("views/val/000_kd.exr", vec!["eval", &s, r], false),
        ("report.json", vec!["eval", &s, r], false),
        ("emitters.json", render.clone(), false),
        (&field, export.clone(), false),
        (&checkpoint, render, false),
        ("bake/train/000.fsh", rerun.clone(), true),
        ("views/val/000_render.exr", rerun, true),
    ];
    for (file, args, works) in cases {
        let p = f.run.join(file);
        let whole = std::fs::read(&p).unwrap();
        std::fs::write(&p, &whole[..whole.len() / 2]).unwrap();
        let (ok, _, err) = fipt(&args);
        assert!(!err.contains("panicked"), "{file}: {err}");
        assert_eq!(
            ok,
            works,
            "{file} truncated: fipt {}\n{err}",
            args.join(" ")
        );
        if !works {
            std::fs::write(&p, &whole).unwrap();
        } else {
            assert!(
                std::fs::read(&p).unwrap() == whole,
                "{file} not computed again"
            );
        }
    }
    // A run whose report.json is gone cannot be told from another scene's: refused.
    std::fs::remove_file(f.run.join("report.json")).unwrap();
    refused(&["eval", &s, r], &["report.json", "cannot be checked"]);
    for p in [f.scene, f.run, out] {
        let _ = std::fs::remove_dir_all(p);
    }
}

#[test]
fn stored_artifacts_changed_after_they_were_written_are_computed_again() {
    let f = Fixture::new("rb-hash");
    let r = f.r().to_string();
    let field = format!("{}/field.safetensors", final_train(&f.run));
    let compared = [
        "bake/train/001.fsh",
        &field,
        "views/val/000_render.exr",
        "metrics.json",
    ];
    let read = |p: &str| std::fs::read(f.run.join(p)).unwrap();
    let reference: Vec<Vec<u8>> = compared.iter().map(|p| read(p)).collect();
    let same = |what: &str| {
        for (p, b) in compared.iter().zip(&reference) {
            assert!(read(p) == *b, "{p} differs after {what}");
        }
    };
    // A well-formed field with other weights (round 0's over the last round's): render refuses
    // it, the run trains that round again.
    std::fs::copy(f.run.join("train/field.safetensors"), f.run.join(&field)).unwrap();
    let out = tmp("rb-hash-out");
    refused(
        &[
            "render",
            &r,
            "--cameras",
            &f.cams(),
            "--out",
            out.to_str().unwrap(),
        ],
        &["field.safetensors", "changed after"],
    );
    let (ok, _, err) = f.fipt_run(&f.run, &[]);
    assert!(ok && err.contains("training again"), "{err}");
    same("a replaced field");
    // 64 bytes inside a view of the bake.
    let fsh = f.run.join("bake/train/001.fsh");
    let mut b = std::fs::read(&fsh).unwrap();
    let mid = b.len() / 2;
    b[mid..mid + 64].copy_from_slice(&[0x7f; 64]);
    std::fs::write(&fsh, b).unwrap();
    let (ok, _, err) = f.fipt_run(&f.run, &[]);
    assert!(
        ok && err.contains("001.fsh was changed after it was written"),
        "{err}"
    );
    same("a changed .fsh");
    // A re-render replaced by another view's.
    std::fs::copy(
        f.run.join("views/val/000_render.exr"),
        f.run.join("views/train/000_render.exr"),
    )
    .unwrap();
    let (ok, _, err) = f.fipt_run(&f.run, &[]);
    assert!(ok && err.contains("rendering it again"), "{err}");
    same("a replaced re-render");
    // A deleted preview is drawn again by `fipt report`; a deleted map is reported missing.
    let preview = f.run.join("views/val/preview/000_kd.png");
    std::fs::remove_file(&preview).unwrap();
    let (ok, _, err) = fipt(&["report", &r]);
    assert!(ok && preview.is_file(), "{err}");
    std::fs::remove_file(&preview).unwrap();
    std::fs::remove_file(f.run.join("views/val/000_kd.exr")).unwrap();
    let (ok, _, err) = fipt(&["report", &r]);
    assert!(ok, "{err}");
    let html = std::fs::read_to_string(f.run.join("report.html")).unwrap();
    assert!(
        html.contains("map(s) of the run are missing") && html.contains("val/000_kd"),
        "no warning"
    );
    for p in [f.scene, f.run, out] {
        let _ = std::fs::remove_dir_all(p);
    }
}

#[test]
fn a_sweep_checks_its_whole_grid_before_the_first_point() {
    let (scene, _) = tiny_resumable_scene("rb-sweep-scene", 100);
    let out = tmp("rb-sweep");
    let grid = scene.join("grid.toml");
    std::fs::write(
        &grid,
        "presets = [\"fast\"]\nvary = \"one_at_a_time\"\n[axes]\n\"train.steps\" = [50]\n\"train.stepz\" = [5]\n",
    )
    .unwrap();
    let t0 = std::time::Instant::now();
    let s = scene.to_str().unwrap();
    let g = grid.to_str().unwrap();
    refused(
        &["sweep", s, "--out", out.to_str().unwrap(), "--grid", g],
        &["stepz", "grid point", "grid.toml"],
    );
    assert!(t0.elapsed().as_secs_f64() < 20.0, "a point ran first");
    let ran = std::fs::read_dir(&out)
        .map(|d| d.flatten().any(|e| e.path().join("report.json").exists()))
        .unwrap_or(false);
    assert!(!ran, "a point ran before the grid was checked");
    for p in [scene, out] {
        let _ = std::fs::remove_dir_all(p);
    }
}

/// A sweep killed alone (SIGKILL to its process, not its group) leaves no `fipt run` behind:
/// the running point stops within a second and the sweep resumes to the end.
#[test]
fn a_killed_sweep_leaves_no_run_behind_and_resumes() {
    let (scene, _) = tiny_resumable_scene("rb-sweep-kill-scene", 100);
    let out = tmp("rb-sweep-kill");
    let grid = scene.join("grid.toml");
    std::fs::write(
        &grid,
        "presets = [\"fast\"]\n[axes]\n\"train.steps\" = [5000]\n\"train.max_passes\" = [0.0]\n\"train.batch\" = [512]\n\"train.checkpoint_every\" = [100]\n",
    )
    .unwrap();
    let args = [
        "sweep",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--grid",
        grid.to_str().unwrap(),
    ];
    let mut sweep = std::process::Command::new(env!("CARGO_BIN_EXE_fipt"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // The point's run holds its folder's lock: its pid.
    let t0 = std::time::Instant::now();
    let child = loop {
        let lock = std::fs::read_dir(&out)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.path().join(".fipt.lock"))
            .find(|p| p.is_file());
        if let Some(pid) = lock
            .and_then(|p| std::fs::read_to_string(p).ok())
            .and_then(|t| {
                t.lines()
                    .next()?
                    .strip_prefix("pid ")?
                    .trim()
                    .parse::<u32>()
                    .ok()
            })
        {
            break pid;
        }
        assert!(t0.elapsed().as_secs() < 60, "no point started");
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    assert!(
        Path::new(&format!("/proc/{child}")).exists(),
        "the point ended before the kill"
    );
    sweep.kill().unwrap();
    sweep.wait().unwrap();
    let t1 = std::time::Instant::now();
    while Path::new(&format!("/proc/{child}")).exists() && t1.elapsed().as_secs() < 5 {
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    // A zombie (reaped by init later) no longer runs: its state is Z.
    let state = std::fs::read_to_string(format!("/proc/{child}/stat")).unwrap_or_default();
    assert!(
        state.is_empty() || state.contains(") Z"),
        "the point's fipt run ({child}) still runs after its sweep was killed: {state}"
    );
    let (ok, _, err) = fipt(&args);
    assert!(ok, "the resumed sweep failed: {err}");
    assert!(out.join("sweep.csv").is_file());
    for p in [scene, out] {
        let _ = std::fs::remove_dir_all(p);
    }
}
