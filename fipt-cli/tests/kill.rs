//! A run killed at a random moment of any stage resumes to the outputs of an uninterrupted
//! run, byte for byte, and leaves no temporary file behind. The moments are spread over the
//! run's measured length (one per eighth, at a seeded random point inside it), so every stage
//! is hit: load, bake, search, training, emitters, refinement, maps, re-render, report.
mod common;
use common::{fipt, tiny_resumable_scene, tmp, walk};
use std::process::Command;
use std::time::{Duration, Instant};

/// A small xorshift: reproducible kill moments without a dependency (`FIPT_KILL_SEED`).
fn uniforms(seed: u64, n: usize) -> Vec<f64> {
    let mut x = seed.max(1);
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        })
        .collect()
}

const COMPARED: [&str; 8] = [
    "bake/train/000.fsh",
    "train/field.safetensors",
    "emitters.json",
    "refine1/train/001.fsh",
    "train1/field.safetensors",
    "views/val/000_kd.exr",
    "views/val/000_render.exr",
    "metrics.json",
];

#[test]
fn a_run_killed_at_random_moments_of_every_stage_resumes_to_the_same_outputs() {
    let (dir, cfg) = tiny_resumable_scene("killr-scene", 600);
    let d = dir.to_str().unwrap();
    let c = cfg.to_str().unwrap();
    let full = tmp("killr-full");
    let t0 = Instant::now();
    let (ok, _, err) = fipt(&["run", d, "--out", full.to_str().unwrap(), "--config", c]);
    assert!(ok, "{err}");
    let length = t0.elapsed().as_secs_f64();

    let seed = std::env::var("FIPT_KILL_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5EED_u64);
    let slots = 8;
    let mut killed = 0;
    for (k, u) in uniforms(seed, slots).into_iter().enumerate() {
        let at = length * (k as f64 + u) / slots as f64;
        let out = tmp(&format!("killr-{k}"));
        let mut child = Command::new(env!("CARGO_BIN_EXE_fipt"))
            .args(["run", d, "--out", out.to_str().unwrap(), "--config", c])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_secs_f64(at));
        let _ = child.kill();
        let status = child.wait().unwrap();
        killed += usize::from(!status.success());
        let (ok, _, err) = fipt(&["run", d, "--out", out.to_str().unwrap(), "--config", c]);
        assert!(
            ok,
            "killed at {at:.2} s of {length:.2} (seed {seed}), the re-run failed: {err}"
        );
        for f in COMPARED {
            let (a, b) = (
                std::fs::read(full.join(f)).unwrap(),
                std::fs::read(out.join(f)).unwrap_or_default(),
            );
            assert!(
                a == b,
                "{f} differs after a kill at {at:.2} s of {length:.2} (seed {seed})"
            );
        }
        let leftovers: Vec<_> = walk(&out)
            .into_iter()
            .filter(|p| p.to_string_lossy().ends_with(".tmp"))
            .collect();
        assert!(leftovers.is_empty(), "kill at {at:.2} s: {leftovers:?}");
        let _ = std::fs::remove_dir_all(&out);
    }
    // Most moments fall inside the run (the last slot may land after it has finished).
    assert!(
        killed >= slots - 2,
        "only {killed} of {slots} runs were killed mid-way"
    );
    for p in [dir, full] {
        let _ = std::fs::remove_dir_all(p);
    }
}
