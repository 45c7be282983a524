//! Sharded stages: the shards of the bake and of the refinement, run one after another on one
//! machine in any order, give the unsharded run's shadings bit for bit, and the run's maps.
mod common;
use common::{fipt, small_run_config, synth_cornell, tmp};
use std::path::Path;

fn fsh_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .flatten()
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

fn status(out: &Path) -> String {
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    r["status"].as_str().unwrap_or("").to_string()
}

#[test]
fn shards_run_one_after_another_give_the_unsharded_shadings_bit_for_bit() {
    let root = tmp("shard");
    let scene = root.join("scene");
    let scene_s = scene.to_str().unwrap();
    synth_cornell(scene_s, [6, 1, 32, 24, 8]);
    let cfg = root.join("run.toml");
    std::fs::write(
        &cfg,
        small_run_config("principled", 16).replace("steps = 1500", "steps = 150"),
    )
    .unwrap();
    let cfg_s = cfg.to_str().unwrap();
    let run = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "run",
            scene_s,
            "--out",
            out.to_str().unwrap(),
            "--preset",
            "fast",
        ];
        args.extend(["--config", cfg_s]);
        args.extend(extra);
        fipt(&args)
    };

    let whole = root.join("whole");
    let (ok, _, err) = run(&whole, &[]);
    assert!(ok, "{err}");

    let sharded = root.join("sharded");
    // A set of another count left behind (an abandoned job array of 2).
    let (ok, _, err) = run(&sharded, &["--shard", "0/2"]);
    assert!(ok, "{err}");
    // The bake's shards, out of order.
    for k in ["2/3", "0/3"] {
        let (ok, out, err) = run(&sharded, &["--shard", k]);
        assert!(ok, "{err}");
        assert!(out.contains(&format!("shard {k} of the bake")), "{out}");
        // Shard tasks share the folder: they leave report.json to the plain runs.
        assert!(!sharded.join("report.json").exists());
    }
    // A finished shard is not computed again.
    let (ok, out, err) = run(&sharded, &["--shard", "2/3"]);
    assert!(
        ok && out.contains("waiting for shards 1/3"),
        "{out}
{err}"
    );
    assert!(
        !err.lines().any(|l| l.starts_with("bake ")),
        "baked again: {err}"
    );
    a_plain_run_waits_for_a_live_shard(&sharded, &run);
    // A plain run computes the missing shard itself (the two done are kept), merges, and
    // clears the stale set of 2; it trains round 1 and stops before the refinement.
    let (ok, out, err) = run(&sharded, &["--stop-before", "refine"]);
    assert!(
        ok && out.contains("stopped before the refinement"),
        "{out}\n{err}"
    );
    assert!(
        err.contains("shards 1/3 are not done: computing them here"),
        "{err}"
    );
    assert!(sharded.join("bake/manifest.json").is_file());
    let left: Vec<_> = std::fs::read_dir(sharded.join("bake"))
        .unwrap()
        .flatten()
        .filter(|e| {
            e.file_name()
                .to_string_lossy()
                .starts_with("manifest.shard-")
        })
        .collect();
    assert!(left.is_empty(), "stale shard manifests left: {left:?}");

    a_stopped_run_keeps_its_stages(&sharded);
    // The refinement's shards; the last one merges.
    for k in ["1/3", "2/3", "0/3"] {
        let (ok, out, err) = run(&sharded, &["--shard", k]);
        assert!(
            ok && out.contains(&format!("shard {k} of the refinement")),
            "{out}\n{err}"
        );
    }
    // Past the sharded stages, a shard run has nothing to compute: it says so and fails.
    let (ok, _, err) = run(&sharded, &["--shard", "0/3"]);
    assert!(!ok && err.contains("does not train"), "{err}");
    let (ok, _, err) = run(&sharded, &[]);
    assert!(ok, "{err}");
    assert_eq!(status(&sharded), "complete");

    assert_same_outputs(&whole, &sharded);
    let _ = std::fs::remove_dir_all(&root);
}

/// A run stopped before the refinement: its report keeps the stages it went through, with their
/// peak memory.
fn a_stopped_run_keeps_its_stages(out: &Path) {
    assert_eq!(status(out), "stopped");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let stages: Vec<&str> = r["stages"]
        .as_array()
        .map(|a| a.iter().filter_map(|s| s["stage"].as_str()).collect())
        .unwrap_or_default();
    assert_eq!(
        stages,
        ["load", "bake", "search", "train", "emitters"],
        "{r}"
    );
    assert!(r["stages"][0]["peak_rss_mib"].as_f64().is_some(), "{r}");
    // The run's peak is the largest of its stages'.
    let most = r["stages"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|s| s["peak_rss_mib"].as_f64())
        .fold(0.0, f64::max);
    assert_eq!(r["peak_rss_mib"].as_f64(), Some(most), "{r}");
}

/// While a shard works in the folder (its lock held by a live process: this test), a plain run
/// is refused before it touches anything.
fn a_plain_run_waits_for_a_live_shard(
    sharded: &Path,
    run: &dyn Fn(&Path, &[&str]) -> (bool, String, String),
) {
    let shard_lock = sharded.join(".fipt.shard-1-of-3.lock");
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap_or_default();
    let me = format!(
        "pid {}\nhost {}\nfipt run --shard 1/3\n",
        std::process::id(),
        host.trim()
    );
    std::fs::write(&shard_lock, me).unwrap();
    let (ok, _, err) = run(sharded, &[]);
    assert!(
        !ok && err.contains("in use") && err.contains(".fipt.shard-1-of-3.lock"),
        "{err}"
    );
    assert!(!sharded.join("report.json").exists() && !sharded.join(".fipt.lock").exists());
    std::fs::remove_file(&shard_lock).unwrap();
}

/// The sharded run's shadings, maps and emitters are the unsharded run's, bit for bit.
fn assert_same_outputs(whole: &Path, sharded: &Path) {
    for stage in ["bake/train", "refine1/train"] {
        let (a, b) = (
            fsh_files(&whole.join(stage)),
            fsh_files(&sharded.join(stage)),
        );
        assert_eq!(a.len(), 6, "{stage}");
        assert!(
            a == b,
            "{stage}: the sharded shadings differ from the unsharded ones"
        );
    }
    // Same shadings, same training: the same maps.
    for f in [
        "views/val/000_kd.exr",
        "views/val/000_roughness.exr",
        "emitters.json",
    ] {
        assert!(
            std::fs::read(whole.join(f)).unwrap() == std::fs::read(sharded.join(f)).unwrap(),
            "{f} differs"
        );
    }
}

/// A stand-in for `sbatch` that runs each job at once (an array's tasks last first), logs
/// the job names and dependencies, and fails when the job fails.
const FAKE_SBATCH: &str = r#"#!/usr/bin/env bash
set -u
name= array= wrap= dep=
for a in "$@"; do
  case $a in
    --job-name=*) name=${a#--job-name=} ;;
    --array=*) array=${a#--array=} ;;
    --wrap=*) wrap=${a#--wrap=} ;;
    --dependency=*) dep=${a#--dependency=} ;;
  esac
done
id=$(( $(cat "$FAKE_LOG.n" 2>/dev/null || echo 100) + 1 ))
echo $id > "$FAKE_LOG.n"
echo "$id $name ${array:-single} ${dep:-none}" >> "$FAKE_LOG"
if [[ -n $array ]]; then
  for ((k = ${array#*-}; k >= ${array%-*}; k--)); do
    SLURM_ARRAY_TASK_ID=$k bash -c "$wrap" > /dev/null 2>&1 || exit 1
  done
else
  bash -c "$wrap" > /dev/null 2>&1 || exit 1
fi
echo "$id;cluster"
"#;

#[test]
fn the_slurm_script_chains_the_arrays_and_the_run_completes() {
    let root = tmp("slurm");
    let scene = root.join("scene");
    synth_cornell(scene.to_str().unwrap(), [6, 1, 32, 24, 8]);
    let cfg = root.join("run.toml");
    std::fs::write(
        &cfg,
        small_run_config("principled", 16).replace("steps = 1500", "steps = 150"),
    )
    .unwrap();
    let sbatch = root.join("sbatch");
    std::fs::write(&sbatch, FAKE_SBATCH).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&sbatch, std::fs::Permissions::from_mode(0o755)).unwrap();
    let log = root.join("jobs.log");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scripts/slurm/fipt-sharded.sh");
    let out_dir = root.join("out");
    let res = std::process::Command::new("bash")
        .arg(&script)
        .args([scene.as_os_str(), out_dir.as_os_str()])
        .args(["3", "1", "--", "--preset", "fast", "--config"])
        .arg(&cfg)
        .env("FIPT", env!("CARGO_BIN_EXE_fipt"))
        .env("SBATCH", &sbatch)
        .env("FAKE_LOG", &log)
        .output()
        .expect("bash");
    let (stdout, stderr) = (
        String::from_utf8_lossy(&res.stdout),
        String::from_utf8_lossy(&res.stderr),
    );
    assert!(res.status.success(), "{stdout}\n{stderr}");
    let jobs = std::fs::read_to_string(&log).unwrap();
    let lines: Vec<&str> = jobs.lines().collect();
    assert_eq!(
        lines,
        [
            "101 fipt-bake 0-2 none",
            "102 fipt-train single afterok:101",
            "103 fipt-refine1 0-2 afterok:102",
            "104 fipt-train1 single afterok:103",
        ],
        "{jobs}"
    );
    assert_eq!(stdout.trim(), "104");
    assert_eq!(status(&out_dir), "complete");
    assert!(out_dir.join("views/val/000_kd.exr").is_file());
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn a_bad_shard_is_refused_with_the_form_it_takes() {
    let (ok, _, err) = fipt(&["run", "nowhere", "--out", "x", "--shard", "3/3"]);
    assert!(!ok && err.contains("use K/N with 0 ≤ K < N"), "{err}");
}
