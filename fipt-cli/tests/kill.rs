//! A run killed at a random moment of any stage resumes to the outputs of an uninterrupted
//! run, byte for byte, and leaves no temporary file behind. The moments are spread over the
//! run's measured length (one per eighth, at a seeded random point inside it), so every stage
//! is hit: load, bake, search, training, emitters, refinement, maps, re-render, report.
mod common;
use common::{fipt, spawn_quiet, tiny_resumable_scene, tmp, walk};
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
    // The measured length is the machine's speed at the start; a run that ends before its
    // moment (the machine got faster: another job ended) shortens it and is tried again.
    let mut length = length;
    for (k, u) in uniforms(seed, slots).into_iter().enumerate() {
        let out = tmp(&format!("killr-{k}"));
        let mut retries = 2;
        let (at, status) = loop {
            let at = length * (k as f64 + u) / slots as f64;
            let (status, ran) = run_until(d, &out, c, at);
            if status.success() && ran < at && retries > 0 {
                retries -= 1;
                length = length.min(ran);
                let _ = std::fs::remove_dir_all(&out);
                continue;
            }
            break (at, status);
        };
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
        let leftovers = common::temporaries(&out);
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

/// `fipt run` of scene `d` into `out` with config `c`, killed `at` seconds after its start
/// unless it has ended by then: its exit status and how long it ran.
fn run_until(d: &str, out: &std::path::Path, c: &str, at: f64) -> (std::process::ExitStatus, f64) {
    let mut child = spawn_quiet(&["run", d, "--out", out.to_str().unwrap(), "--config", c]);
    let t = Instant::now();
    while t.elapsed().as_secs_f64() < at {
        if let Some(status) = child.try_wait().unwrap() {
            return (status, t.elapsed().as_secs_f64());
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let _ = child.kill();
    (child.wait().unwrap(), t.elapsed().as_secs_f64())
}

/// The files of a run that do not record times: every shading, field, map and re-render, the
/// lights and the scores.
fn results(dir: &std::path::Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    walk(dir)
        .into_iter()
        .filter(|p| {
            let name = p.to_string_lossy();
            ["fsh", "safetensors", "exr"]
                .iter()
                .any(|e| p.extension().is_some_and(|x| x == *e))
                || name.ends_with("emitters.json")
                || name.ends_with("metrics.json")
        })
        .map(|p| {
            let rel = p.strip_prefix(dir).unwrap().to_string_lossy().into_owned();
            (rel, std::fs::read(&p).unwrap())
        })
        .collect()
}

/// The chaos test: the run SIGKILLs itself (`FIPT_CHAOS_KILL`, fipt-core's `chaos`) at two
/// seeded moments of every stage of its report, each stage's moments counted in an
/// uninterrupted run (its start, and each atomic write's three steps); every killed run
/// resumes to the uninterrupted run's results byte for byte, with no temporary left.
#[test]
fn a_run_killed_at_seeded_moments_of_every_stage_resumes_to_the_same_results() {
    let (dir, cfg) = tiny_resumable_scene("chaos-scene", 200);
    let d = dir.to_str().unwrap();
    let c = cfg.to_str().unwrap();
    let full = tmp("chaos-full");
    let log = dir.join("moments.txt");
    let out = Command::new(env!("CARGO_BIN_EXE_fipt"))
        .args(["run", d, "--out", full.to_str().unwrap(), "--config", c])
        .env("FIPT_CHAOS_LOG", &log)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let reference = results(&full);
    let stages = stage_moments(&log);
    let names: Vec<&str> = stages
        .iter()
        .map(|s| s.0.split('#').next().unwrap())
        .collect();
    for expected in [
        "load",
        "bake",
        "search",
        "train",
        "emitters",
        "refine",
        "maps",
        "re-render",
        "eval",
    ] {
        assert!(
            names.contains(&expected),
            "no moment of stage {expected}: {stages:?}"
        );
    }
    let seed = std::env::var("FIPT_KILL_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0xC4A05_u64);
    let u = uniforms(seed, 2 * stages.len());
    let mut cases = 0;
    for (i, (stage, seen)) in stages.iter().enumerate() {
        let pick = |j: usize| seen[(u[2 * i + j] * seen.len() as f64) as usize];
        // FIPT_CHAOS_ALL=1: every moment of every stage (minutes; for a local check).
        let mut moments = match std::env::var_os("FIPT_CHAOS_ALL") {
            Some(_) => seen.clone(),
            None => vec![pick(0), pick(1)],
        };
        moments.sort();
        moments.dedup();
        for n in moments {
            let at = format!("{stage}:{n}");
            let out = tmp(&format!("chaos-{i}-{n}"));
            let o = out.to_str().unwrap();
            let status = Command::new(env!("CARGO_BIN_EXE_fipt"))
                .args(["run", d, "--out", o, "--config", c])
                .env("FIPT_CHAOS_KILL", &at)
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .status()
                .unwrap();
            assert!(!status.success(), "not killed at {at} (seed {seed})");
            let (ok, _, err) = fipt(&["run", d, "--out", o, "--config", c]);
            assert!(ok, "killed at {at} (seed {seed}), the resume failed: {err}");
            let got = results(&out);
            assert_eq!(
                got.keys().collect::<Vec<_>>(),
                reference.keys().collect::<Vec<_>>(),
                "killed at {at}: other files"
            );
            for (f, b) in &reference {
                assert!(
                    got[f] == *b,
                    "{f} differs after a kill at {at} (seed {seed})"
                );
            }
            let leftovers = common::temporaries(&out);
            assert!(leftovers.is_empty(), "kill at {at}: {leftovers:?}");
            let _ = std::fs::remove_dir_all(&out);
            cases += 1;
        }
    }
    assert!(
        cases >= stages.len(),
        "{cases} kills for {} stages",
        stages.len()
    );
    for p in [dir, full] {
        let _ = std::fs::remove_dir_all(p);
    }
}

/// The moments of each stage occurrence in the chaos log `log`, in run order.
fn stage_moments(log: &std::path::Path) -> Vec<(String, Vec<u64>)> {
    let mut stages: Vec<(String, Vec<u64>)> = vec![];
    for line in std::fs::read_to_string(log).unwrap().lines() {
        let (stage, n) = line.rsplit_once(' ').unwrap();
        let n: u64 = n.parse().unwrap();
        match stages.last_mut() {
            Some((s, seen)) if s == stage => seen.push(n),
            _ => stages.push((stage.to_string(), vec![n])),
        }
    }
    stages
}
