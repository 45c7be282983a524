//! What the end-to-end tests share: running the binary, scratch folders, generated scenes.
#![allow(dead_code)]
pub mod recovered;

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

pub fn fipt(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_fipt"))
        .args(args)
        .output()
        .expect("run fipt");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

/// `fipt ARGS` started with its output discarded, for a test to watch, kill or wait for.
pub fn spawn_quiet(args: &[&str]) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_fipt"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("start fipt")
}

/// `fipt run SCENE --out OUT --config CFG`, which must succeed; its stdout.
pub fn run(scene: &std::path::Path, out: &std::path::Path, cfg: &std::path::Path) -> String {
    let (ok, stdout, err) = fipt(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--config",
        cfg.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    stdout
}

/// A scratch folder, emptied when made and removed when dropped, unless the test is failing
/// (then it stays, for a look, and its path is printed).
pub struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::path::Path> for Scratch {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("kept for a look: {}", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// `$TMPDIR/fipt-cli-PID-name`, empty (nothing is there yet).
pub fn tmp(name: &str) -> Scratch {
    let d = std::env::temp_dir().join(format!("fipt-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    Scratch(d)
}

/// The cut-down run config of the e2e runs: `model`, `diffuse` samples in the bake and the
/// refinement, 8 GGX samples a level, 1500 steps of 2048, small networks.
pub fn small_run_config(model: &str, diffuse: u32) -> String {
    format!(
        "[model]\nbrdf = \"{model}\"\n\
         [bake]\ndiffuse_samples = {diffuse}\nspecular_samples = [8, 8, 8, 8, 8, 8]\n\
         [refine]\ndiffuse_samples = {diffuse}\nspecular_samples = [8, 8, 8, 8, 8, 8]\n\
         light_samples = 8\n\
         [train]\nsteps = 1500\nbatch = 2048\n[train.field]\nmlp_width = 16\nmask_width = 32\n\
         [train.field.grid]\nlevels = 8\n"
    )
}

/// A 3-view cornell at 24×16 and a run config small enough to run in seconds, with a
/// checkpoint every 50 of `steps` training steps: for kill-and-resume tests. Returns the scene
/// folder and the config file.
pub fn tiny_resumable_scene(name: &str, steps: u32) -> (Scratch, PathBuf) {
    let dir = tmp(name);
    synth_cornell(dir.to_str().unwrap(), [3, 1, 24, 16, 8]);
    let cfg = dir.join("run.toml");
    std::fs::write(
        &cfg,
        format!(
            "[bake]\ndiffuse_samples = 8\nspecular_samples = [4, 4, 4, 4, 4, 4]\n\
             [refine]\ndiffuse_samples = 8\nspecular_samples = [4, 4, 4, 4, 4, 4]\nlight_samples = 4\n\
             [train]\nsteps = {steps}\nbatch = 512\ncheckpoint_every = 50\n[train.field]\nmlp_width = 16\n\
             mask_width = 16\n[train.field.grid]\nlevels = 4\n"
        ),
    )
    .unwrap();
    (dir, cfg)
}

/// `fipt synth cornell --out dir` with [views, val views, width, height, spp].
pub fn synth_cornell(dir: &str, sizes: [u32; 5]) {
    synth("cornell", dir, sizes, &[]);
}

/// `fipt synth <scene> --out dir` with [views, val views, width, height, spp] and `extra` args.
pub fn synth(scene: &str, dir: &str, [views, val, w, h, spp]: [u32; 5], extra: &[&str]) {
    let args = [views, val, w, h, spp].map(|v| v.to_string());
    let mut all = vec![
        "synth",
        scene,
        "--out",
        dir,
        "--views",
        &args[0],
        "--val-views",
        &args[1],
        "--width",
        &args[2],
        "--height",
        &args[3],
        "--spp",
        &args[4],
    ];
    all.extend(extra);
    let (ok, _, err) = fipt(&all);
    assert!(ok, "{err}");
}

pub fn walk(dir: &std::path::Path) -> Vec<PathBuf> {
    let mut out = vec![];
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

/// The temporaries (`*.tmp`) a run left under `dir`: none, after any run or kill and resume.
pub fn temporaries(dir: &std::path::Path) -> Vec<PathBuf> {
    walk(dir)
        .into_iter()
        .filter(|p| p.to_string_lossy().ends_with(".tmp"))
        .collect()
}

/// A JSON file, read.
pub fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The tiny run config of these tests, without the segment prior (a copy has no parts).
pub const TINY: &str = "[bake]\ndiffuse_samples = 8\nspecular_samples = [4, 4, 4, 4, 4, 4]\n\
     [refine]\ndiffuse_samples = 8\nspecular_samples = [4, 4, 4, 4, 4, 4]\nlight_samples = 4\n\
     [train]\nsteps = 150\nbatch = 512\nsegments = \"none\"\n[train.field]\nmlp_width = 16\n\
     mask_width = 16\n[train.field.grid]\nlevels = 4\n[search]\nregions = \"mesh\"\n\
     [render]\nspp = 2\nval_spp = 2\nmax_bounces = 3\nseed = 0\n";

/// `fipt degrade SRC --out OUT EXTRA…`, which must succeed; its `degrade.json`.
pub fn degrade(src: &Path, out: &Path, extra: &[&str]) -> Value {
    let mut args = vec![
        "degrade",
        src.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    let (ok, _, err) = fipt(&args);
    assert!(ok, "{err}");
    json(&out.join("degrade.json"))
}

/// Rewrites every vertex (`v x y z`) of the OBJ at `path` through `f`: a mesh in other units,
/// or in another frame than the poses.
#[allow(dead_code)]
pub fn move_obj_vertices(path: &Path, f: impl Fn([f64; 3]) -> [f64; 3]) {
    let lines: Vec<String> = std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(xyz) => {
                let v: Vec<f64> = xyz.split_whitespace().map(|x| x.parse().unwrap()).collect();
                let [x, y, z] = f([v[0], v[1], v[2]]);
                format!("v {x} {y} {z}")
            }
            None => l.to_string(),
        })
        .collect();
    std::fs::write(path, lines.join("\n")).unwrap();
}
