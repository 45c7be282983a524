//! Numerical extremes end to end: `fipt run --preset fast` on tiny generated scenes.
mod common;

use common::*;
use fipt_core::image::{ExrPrecision, Image};
use std::path::Path;

/// Copies scene `src` to `dst` with every view (and the emission ground truth) × `k`.
fn scaled_copy(src: &Path, dst: &Path, k: f32) {
    for e in walk(src) {
        let rel = e.strip_prefix(src).unwrap();
        let to = dst.join(rel);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        let s = rel.to_string_lossy();
        if s.ends_with(".exr") && (s.contains("/Image/") || s.contains("/Emit/")) {
            let mut img = Image::read_exr(&e).unwrap();
            for p in &mut img.data {
                *p *= k;
            }
            img.write_exr(&to, ExrPrecision::F32).unwrap();
        } else {
            std::fs::copy(&e, &to).unwrap();
        }
    }
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// Exposure is arbitrary: the same scene at ×1e5 and ×1e-6 gives the same lights (their
/// radiance scaled), the same materials, and scored re-renders.
#[test]
fn image_scale_does_not_change_the_answer() {
    let base = tmp("scale-scene");
    synth_cornell(base.to_str().unwrap(), [12, 2, 48, 36, 64]);
    let cfg = base.join("run.toml");
    std::fs::write(&cfg, small_run_config("fipt", 32)).unwrap();
    let mut results = Vec::new();
    for k in [1.0f32, 1e5, 1e-6] {
        let scene = if k == 1.0 {
            base.clone()
        } else {
            tmp(&format!("scale-{k:e}"))
        };
        if k != 1.0 {
            scaled_copy(&base, &scene, k);
        }
        let out = tmp(&format!("scale-out-{k:e}"));
        let (ok, stdout, err) = fipt(&[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--config",
            cfg.to_str().unwrap(),
            "--preset",
            "fast",
        ]);
        assert!(ok, "×{k}: {stdout}{err}");
        let e = json(&out.join("emitters.json"));
        let m = json(&out.join("metrics.json"));
        let r = json(&out.join("report.json"));
        let lights = e.as_array().unwrap().len();
        let le = e[0]["mean_radiance"][0].as_f64().unwrap() / k as f64;
        let kd = m["train"]["mean"]["kd_psnr"].as_f64().unwrap();
        let render = m["val"]["mean"]["render_psnr"].as_f64().unwrap();
        eprintln!(
            "×{k:e}: exposure {}, {lights} lights, Le/k {le:.2}, kd {kd:.2} dB, re-render {render:.2} dB",
            r["exposure_scale"]
        );
        results.push((lights, le, kd, render));
        if k != 1.0 {
            let _ = std::fs::remove_dir_all(&scene);
        }
        let _ = std::fs::remove_dir_all(&out);
    }
    let (l0, le0, kd0, r0) = results[0];
    assert_eq!(l0, 1);
    for &(l, le, kd, r) in &results[1..] {
        assert_eq!(l, l0, "lights");
        assert!((le / le0 - 1.0).abs() < 0.05, "radiance {le} vs {le0}");
        assert!((kd - kd0).abs() < 1.0, "kd {kd} vs {kd0}");
        assert!(r < 60.0 && (r - r0).abs() < 1.0, "re-render {r} vs {r0}");
    }
    let _ = std::fs::remove_dir_all(&base);
}
