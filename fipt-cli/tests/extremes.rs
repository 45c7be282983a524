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
        let scaled = (k != 1.0).then(|| tmp(&format!("scale-{k:e}")));
        let scene: &std::path::Path = scaled.as_deref().unwrap_or(&base);
        if k != 1.0 {
            scaled_copy(&base, scene, k);
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
        // emitters.obj states each light's radiance at the same scale as emitters.json.
        let obj = std::fs::read_to_string(out.join("emitters.obj")).unwrap();
        let said: Vec<f64> = obj
            .lines()
            .find_map(|l| l.strip_prefix("# mean radiance "))
            .expect("emitters.obj states the radiance")
            .trim_matches(['[', ']'])
            .split(',')
            .map(|x| x.trim().parse().unwrap())
            .collect();
        let json_le: Vec<f64> = (0..3)
            .map(|c| e[0]["mean_radiance"][c].as_f64().unwrap())
            .collect();
        for (o, j) in said.iter().zip(&json_le) {
            assert!(
                (o / j - 1.0).abs() < 1e-4,
                "×{k}: emitters.obj {said:?} vs .json {json_le:?}"
            );
        }
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

/// One generated extreme: a cornell whose materials, mesh and cameras `edit` changes, its
/// views rendered again from the edited truth (train and val, 10 + 2 views of 40×30).
fn extreme_scene(
    name: &str,
    edit: impl Fn(&mut serde_json::Value, &mut fipt_geom::Mesh, &mut Vec<fipt_core::camera::Camera>),
) -> common::Scratch {
    let dir = tmp(&format!("extreme-{name}"));
    let d = dir.to_str().unwrap();
    synth_cornell(d, [10, 2, 40, 30, 4]);
    let gt_path = dir.join("scene_gt.json");
    let mut gt = json(&gt_path);
    let mut mesh = fipt_geom::Mesh::load(&dir.join("scene.obj")).unwrap();
    let tf = dir.join("train/transforms.json");
    let mut cams = fipt_core::dataset::read_transforms(&tf, None).unwrap();
    edit(&mut gt, &mut mesh, &mut cams);
    std::fs::write(&gt_path, gt.to_string()).unwrap();
    mesh.write_obj(&dir.join("scene.obj"), "edited cornell")
        .unwrap();
    fipt_core::dataset::write_transforms(&tf, &cams).unwrap();
    for split in ["train", "val"] {
        let (ok, _, err) = fipt(&[
            "render",
            d,
            "--materials",
            gt_path.to_str().unwrap(),
            "--cameras",
            dir.join(split).join("transforms.json").to_str().unwrap(),
            "--out",
            dir.join(split).to_str().unwrap(),
            "--spp",
            "32",
            "--brdf",
            "principled",
        ]);
        assert!(ok, "{name}: {err}");
    }
    dir
}

fn material<'a>(gt: &'a mut serde_json::Value, name: &str) -> &'a mut serde_json::Value {
    gt["materials"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .find(|m| m["name"] == name)
        .unwrap()
}

/// Runs `fast` on `scene`; every EXR it wrote is finite, every JSON parses, and report.json
/// says what was modelled. Returns the report.
fn run_clean(name: &str, scene: &Path) -> serde_json::Value {
    let out = tmp(&format!("extreme-{name}-out"));
    let cfg = scene.join("run.toml");
    std::fs::write(&cfg, small_run_config("principled", 16)).unwrap();
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
    assert!(ok, "{name}: {stdout}{err}");
    assert!(!err.contains("panicked"), "{name}: {err}");
    for f in walk(&out) {
        let s = f.to_string_lossy();
        if s.ends_with(".exr") {
            let img = Image::read_exr(&f).unwrap();
            assert!(
                img.data.iter().all(|p| p.is_finite()),
                "{name}: non-finite values in {s}"
            );
        } else if s.ends_with(".json") {
            let text = std::fs::read_to_string(&f).unwrap();
            assert!(
                !text.contains("NaN") && !text.contains("inf"),
                "{name}: {s}"
            );
            serde_json::from_str::<serde_json::Value>(&text).unwrap();
        }
    }
    let report = json(&out.join("report.json"));
    assert!(
        report["modeled"].is_object(),
        "{name}: {}",
        report["modeled"]
    );
    eprintln!("{name}: modeled {}", report["modeled"]);
    let _ = std::fs::remove_dir_all(&out);
    report
}

#[test]
fn extremes_run_clean_and_say_what_they_modelled() {
    use fipt_core::camera::Camera;
    use glam::Vec3;
    // A near-mirror floor next to a fully rough block.
    let s = extreme_scene("mirror", |gt, _, _| {
        material(gt, "floor")["roughness"] = serde_json::json!(0.02);
        material(gt, "tall_block")["roughness"] = serde_json::json!(1.0);
    });
    let r = run_clean("mirror", &s);
    assert_eq!(
        r["modeled"]["emitters_doubtful"].as_array().map(Vec::len),
        Some(0),
        "mirror: the ceiling light is bright"
    );
    let _ = std::fs::remove_dir_all(&s);
    // A light at 1e5 over 1e-3 shadows, shrunk to a few pixels.
    let s = extreme_scene("tiny-bright", |gt, mesh, _| {
        material(gt, "ceiling_light")["radiance"] = serde_json::json!([1e5, 8e4, 5e4]);
        let light: Vec<usize> = (0..mesh.triangles.len())
            .filter(|&t| (12..14).contains(&mesh.face_ids[t]))
            .collect();
        let mut vs: Vec<u32> = light.iter().flat_map(|&t| mesh.triangles[t]).collect();
        vs.sort_unstable();
        vs.dedup();
        let c = vs.iter().map(|&v| mesh.positions[v as usize]).sum::<Vec3>() / vs.len() as f32;
        for v in vs {
            let p = &mut mesh.positions[v as usize];
            *p = c + (*p - c) * 0.08;
        }
    });
    let r = run_clean("tiny-bright", &s);
    assert!(r["emitters"].as_array().is_some());
    let _ = std::fs::remove_dir_all(&s);
    // Grazing views along the floor, and a black view among the others.
    let s = extreme_scene("grazing-black", |_, _, cams| {
        for (k, cam) in cams.iter_mut().enumerate().take(3) {
            let x = 0.8 - 0.5 * k as f32;
            *cam = Camera::look_at(
                Vec3::new(x, 0.03, 0.9),
                Vec3::new(-x, 0.0, -0.9),
                Vec3::Y,
                1.0,
                40,
                30,
            );
        }
    });
    let black = Image::new(40, 30);
    black
        .write_exr(&s.join("train/Image/005_0001.exr"), ExrPrecision::F32)
        .unwrap();
    let r = run_clean("grazing-black", &s);
    assert_eq!(
        r["modeled"]["emitters_doubtful"].as_array().map(Vec::len),
        Some(0),
        "grazing-black: the ceiling light is bright"
    );
    let _ = std::fs::remove_dir_all(&s);
    // No emitter in any view: every camera looks down at the floor.
    let s = extreme_scene("no-emitter-in-view", |_, _, cams| {
        for (k, cam) in cams.iter_mut().enumerate() {
            let a = k as f32 * 0.6;
            let o = Vec3::new(0.6 * a.cos(), 1.0, 0.6 * a.sin());
            *cam = Camera::look_at(
                o,
                Vec3::new(-0.2 * a.cos(), 0.0, -0.2 * a.sin()),
                Vec3::Y,
                0.7,
                40,
                30,
            );
        }
    });
    // What explains the light is a lit surface, and the report says so.
    let r = run_clean("no-emitter-in-view", &s);
    let n = r["emitters"].as_array().map_or(0, Vec::len);
    let doubtful = r["modeled"]["emitters_doubtful"]
        .as_array()
        .map_or(0, Vec::len);
    assert_eq!(doubtful, n, "{}", r["modeled"]);
    let _ = std::fs::remove_dir_all(&s);
    // Everything rough and dielectric.
    let s = extreme_scene("all-diffuse", |gt, _, _| {
        for m in gt["materials"].as_array_mut().unwrap() {
            if m["type"] == "principled" {
                m["roughness"] = serde_json::json!(1.0);
                m["metallic"] = serde_json::json!(0.0);
            }
        }
    });
    let r = run_clean("all-diffuse", &s);
    assert_eq!(
        r["modeled"]["emitters_doubtful"].as_array().map(Vec::len),
        Some(0),
        "all-diffuse: the ceiling light is bright"
    );
    let _ = std::fs::remove_dir_all(&s);
}

/// A configuration that cannot fit is refused before any work, with the figures.
#[test]
fn a_run_too_large_for_the_machine_is_refused_up_front() {
    let dir = tmp("huge-scene");
    let d = dir.to_str().unwrap();
    synth_cornell(d, [2, 1, 16, 12, 4]);
    // 64 levels × 2^24 entries × 8 features × 4 bytes × 3: 96 GiB of hash tables.
    let cfg = dir.join("huge.toml");
    std::fs::write(
        &cfg,
        "[train.field.grid]\nlevels = 64\nlog2_table = 24\nfeatures = 8\n",
    )
    .unwrap();
    let out = tmp("huge-out");
    let (ok, _, err) = fipt(&[
        "run",
        d,
        "--out",
        out.to_str().unwrap(),
        "--config",
        cfg.to_str().unwrap(),
        "--preset",
        "fast",
    ]);
    assert!(
        !ok && err.contains("needs at least") && err.contains("hash tables 96.00 GiB"),
        "{err}"
    );
    assert!(!out.join("bake").exists());
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&out);
}

/// `fipt sweep --quick`: every point run, the CSV and the plot written; a second sweep keeps
/// the finished points.
#[test]
fn a_quick_sweep_measures_its_points_and_resumes() {
    let dir = tmp("sweep-scene");
    let d = dir.to_str().unwrap();
    synth_cornell(d, [4, 1, 24, 18, 16]);
    let out = tmp("sweep-out");
    let o = out.to_str().unwrap();
    let (ok, stdout, err) = fipt(&["sweep", d, "--out", o, "--quick"]);
    assert!(ok, "{stdout}{err}");
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3, "{csv}");
    assert!(lines[0].starts_with("point,preset,settings,seconds,peak_mib,kd_db"));
    for l in &lines[1..] {
        let kd: f64 = l.split(',').nth(6).unwrap().parse().unwrap();
        assert!(kd.is_finite() && kd > 5.0, "{l}");
    }
    let svg = std::fs::read_to_string(out.join("sweep.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("fast_steps=300"));
    let (ok, _, err) = fipt(&["sweep", d, "--out", o, "--quick"]);
    assert!(
        ok && err.matches("finished before, kept").count() == 2,
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&out);
}
