//! Captures, not renders: `fipt degrade` copies of generated scenes, and what `fipt info` and
//! `fipt run` make of them (LDR evidence, exposures, clipped lights, the no-light warning).
mod common;
use common::{degrade, fipt, json, move_obj_vertices, run, synth, tmp, TINY};
use serde_json::Value;
use std::path::Path;

/// An 8-view cornell at 64×48 (2 val views): every view shares walls with the others.
fn cornell(dir: &Path) -> std::path::PathBuf {
    let scene = dir.join("scene");
    synth("cornell", scene.to_str().unwrap(), [8, 2, 64, 48, 32], &[]);
    scene
}

#[test]
fn a_copy_without_noise_runs_as_its_source_through_the_real_layout() {
    let dir = tmp("degrade-exact");
    let src = dir.join("scene");
    synth("cornell", src.to_str().unwrap(), [4, 2, 32, 24, 16], &[]);
    let copy = dir.join("copy");
    let rec = degrade(&src, &copy, &["--layout", "real"]);
    assert_eq!(
        rec["views"].as_array().unwrap().len(),
        4,
        "the training views only"
    );
    assert!(copy.join("cam.txt").is_file() && copy.join("K_list.txt").is_file());
    assert!(
        !copy.join("train").exists(),
        "no ground truth in the real layout"
    );
    let cfg = dir.join("run.toml");
    std::fs::write(&cfg, TINY).unwrap();
    let mut scores = vec![];
    for (scene, out) in [(&src, dir.join("out-src")), (&copy, dir.join("out-copy"))] {
        run(scene, &out, &cfg);
        let (ok, stdout, err) = fipt(&[
            "eval",
            src.to_str().unwrap(),
            out.to_str().unwrap(),
            "--cameras-from",
            src.to_str().unwrap(),
            "--spp",
            "4",
        ]);
        assert!(ok, "{err}");
        assert!(stdout.contains("val"), "{stdout}");
        let m = json(&out.join("eval/cameras-from/metrics.json"));
        scores.push(m["val"]["mean"].clone());
    }
    for key in ["kd_psnr", "roughness_psnr", "render_psnr"] {
        let (a, b) = (
            scores[0][key].as_f64().unwrap(),
            scores[1][key].as_f64().unwrap(),
        );
        assert!(
            (a - b).abs() < 0.3,
            "{key}: source run {a:.2} dB, copy run {b:.2} dB"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn ldr_views_are_recognised_and_a_run_without_a_light_says_so() {
    let dir = tmp("degrade-ldr");
    let src = cornell(&dir);
    let (ok, out, _) = fipt(&["info", src.to_str().unwrap()]);
    assert!(
        ok && out.contains("HDR") && !out.contains("LOW DYNAMIC RANGE"),
        "{out}"
    );
    for (name, format) in [("png", "png"), ("exr", "exr")] {
        let copy = dir.join(name);
        degrade(
            &src,
            &copy,
            &["--ldr", "fixed", "--format", format, "--layout", "real"],
        );
        let (ok, out, err) = fipt(&["info", copy.to_str().unwrap()]);
        assert!(ok, "{err}");
        assert!(
            out.contains("LDR") && out.contains("LOW DYNAMIC RANGE"),
            "{name}: {out}"
        );
        assert!(
            out.contains("8-bit sRGB steps") && out.contains("views clip"),
            "{name}: {out}"
        );
    }
    // A run whose extractor finds nothing (no mask value reaches 2) while the views clip.
    let cfg = dir.join("run.toml");
    std::fs::write(&cfg, format!("{TINY}[emitters]\nthreshold = 2.0\n")).unwrap();
    let out = dir.join("out");
    let stdout = run(&dir.join("png"), &out, &cfg);
    assert!(stdout.contains("NO LIGHT FOUND"), "{stdout}");
    let report = json(&out.join("report.json"));
    assert_eq!(report["capture"]["ldr"], true);
    let warnings = report["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.as_str().unwrap().starts_with("NO LIGHT FOUND")),
        "{warnings:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn auto_exposed_views_get_their_gains_back() {
    let dir = tmp("degrade-auto");
    let src = cornell(&dir);
    let copy = dir.join("auto");
    let rec = degrade(
        &src,
        &copy,
        &[
            "--ldr", "auto", "--format", "png", "--layout", "real", "--seed", "3",
        ],
    );
    let (ok, out, err) = fipt(&["info", copy.to_str().unwrap(), "--json"]);
    assert!(ok, "{err}");
    let fit = &serde_json::from_str::<Value>(&out).unwrap()["exposure_fit"];
    let gains: Vec<f64> = fit["gains"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g.as_f64().unwrap())
        .collect();
    let unfitted: Vec<usize> = fit["unfitted"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() as usize)
        .collect();
    let truth: Vec<f64> = rec["views"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["gain"].as_f64().unwrap())
        .collect();
    // Views that see little but the light clip almost whole: they are named, not fitted.
    let fitted: Vec<usize> = (0..truth.len()).filter(|k| !unfitted.contains(k)).collect();
    assert!(fitted.len() >= 6, "unfitted {unfitted:?}");
    let mean = |f: &dyn Fn(usize) -> f64| {
        fitted.iter().map(|&k| f(k).ln()).sum::<f64>() / fitted.len() as f64
    };
    let (gm_fit, gm_true) = (mean(&|k| gains[k]).exp(), mean(&|k| truth[k]).exp());
    let spread =
        truth.iter().cloned().fold(0.0, f64::max) / truth.iter().cloned().fold(f64::MAX, f64::min);
    assert!(spread > 1.5, "the copy's exposures differ (×{spread:.2})");
    for &k in &fitted {
        let err = (gains[k] / gm_fit) / (truth[k] / gm_true) - 1.0;
        assert!(
            err.abs() < 0.06,
            "view {k}: gain off by {:.1} %",
            100.0 * err
        );
    }
    // A mask on one view only (a person in one photo): its top rows are left out of the
    // gains, the response and the lights' estimate, and the views without one keep all their
    // pixels (this panicked on 8-bit views until 2026-12-07).
    std::fs::create_dir_all(copy.join("Mask")).unwrap();
    let mask = image::GrayImage::from_fn(64, 48, |_, y| image::Luma([if y < 8 { 0 } else { 255 }]));
    mask.save(copy.join("Mask/000_0001.png")).unwrap();
    let (ok, info, err) = fipt(&["info", copy.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(info.contains("1 training views have a mask"), "{info}");
    let cfg = dir.join("run.toml");
    std::fs::write(&cfg, TINY).unwrap();
    let out = dir.join("out");
    run(&copy, &out, &cfg);
    let report = json(&out.join("report.json"));
    assert_eq!(report["status"], "complete", "{}", report["status"]);
    assert_eq!(report["capture"]["masked_pixels"], 64 * 8);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_clipped_light_gets_its_radiance_back_from_the_surfaces_it_lights() {
    let dir = tmp("degrade-clipped");
    let src = cornell(&dir);
    let copy = dir.join("ldr");
    let rec = degrade(
        &src,
        &copy,
        &["--ldr", "fixed", "--format", "png", "--layout", "real"],
    );
    let gain = rec["views"][0]["gain"].as_f64().unwrap();
    let gt = json(&src.join("scene_gt.json"));
    let light = gt["materials"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["type"] == "emitter")
        .unwrap();
    let truth: Vec<f64> = light["radiance"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap() * gain)
        .collect();
    assert!(truth.iter().all(|&t| t > 3.0), "the light clips: {truth:?}");
    let cfg = dir.join("run.toml");
    std::fs::write(&cfg, TINY).unwrap();
    let out = dir.join("out");
    let stdout = run(&copy, &out, &cfg);
    assert!(!stdout.contains("NO LIGHT FOUND"), "{stdout}");
    let report = json(&out.join("report.json"));
    let est = &report["capture"]["clipped_lights"]["estimates"];
    let biggest = est
        .as_array()
        .unwrap()
        .iter()
        .max_by_key(|e| e["triangles"].as_u64())
        .unwrap();
    assert_eq!(biggest["pinned"], true, "{est}");
    // Measured 2026-11-27: RGB (25.1, 14.1, 5.6) for (18.2, 12.9, 4.3), luminance 15.8 for
    // 13.4 (the clip level is 1): luminance within 25 %, each channel within 45 %.
    let lum = |v: &[f64]| 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
    let got: Vec<f64> = (0..3)
        .map(|c| biggest["radiance"][c].as_f64().unwrap())
        .collect();
    assert!(
        (lum(&got) / lum(&truth) - 1.0).abs() < 0.25,
        "{got:?} for {truth:?}"
    );
    for c in 0..3 {
        assert!(
            (got[c] / truth[c] - 1.0).abs() < 0.45,
            "channel {c}: {got:?} for {truth:?}"
        );
    }
    assert!(
        report["emitters"].as_array().is_some_and(|e| !e.is_empty()),
        "{}",
        report["emitters"]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn views_off_their_poses_are_shifted_back_onto_the_mesh() {
    let dir = tmp("degrade-align");
    let src = cornell(&dir);
    let copy = dir.join("turned");
    degrade(
        &src,
        &copy,
        &["--layout", "real", "--pose-noise", "0,1.5", "--seed", "5"],
    );
    let cfg = dir.join("run.toml");
    let mut reports = vec![];
    for mode in ["off", "auto"] {
        std::fs::write(&cfg, format!("{TINY}[capture]\nalign_views = \"{mode}\"\n")).unwrap();
        let out = dir.join(format!("out-{mode}"));
        run(&copy, &out, &cfg);
        reports.push(json(&out.join("report.json"))["capture"].clone());
    }
    let before = reports[0]["edges"]["median_px"].as_f64().unwrap();
    assert!(
        before > 0.75,
        "the turned copy's edges are off: {before:.2} px"
    );
    assert_eq!(
        reports[0]["alignment"]["views_shifted"],
        serde_json::json!([])
    );
    let a = &reports[1]["alignment"];
    assert!(!a["views_shifted"].as_array().unwrap().is_empty(), "{a}");
    let after = a["after"]["median_px"].as_f64().unwrap();
    assert!(
        after < 0.5 * before,
        "shifted views line up: {before:.2} px before, {after:.2} px after"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `fipt eval --ceiling`: the true materials on a scan copy's mesh. On the same surface split
/// finer they score as the ground truth; on a warped one less; a mesh that is no copy of the
/// scene is refused, naming it.
#[test]
fn the_ceiling_of_a_scan_is_exact_on_the_same_surface_and_lower_on_a_warped_one() {
    let dir = tmp("ceiling");
    let src = dir.join("scene");
    synth("cornell", src.to_str().unwrap(), [4, 2, 48, 36, 4], &[]);
    let mut kd = vec![];
    // A ripple of a micrometre refines the mesh (edges of 5 cm) and leaves the surface.
    let copies = [
        ("fine", ["--subdivide", "1", "--mesh-warp", "0"]),
        ("warped", ["--subdivide", "1", "--mesh-warp", "40"]),
        ("refined", ["--mesh-ripple", "0.001,30", "--mesh-warp", "0"]),
    ];
    for (name, how) in copies {
        let copy = dir.join(name);
        degrade(&src, &copy, &[&["--layout", "real"][..], &how[..]].concat());
        let out = dir.join(format!("ceil-{name}"));
        let (ok, stdout, err) = fipt(&[
            "eval",
            src.to_str().unwrap(),
            out.to_str().unwrap(),
            "--ceiling",
            copy.to_str().unwrap(),
            "--spp",
            "2",
        ]);
        assert!(ok, "{err}");
        assert!(stdout.contains("true materials on"), "{stdout}");
        let m = json(&out.join("metrics.json"));
        let per_face = &m["val"]["ceiling"]["faces_per_source_face"];
        if name == "refined" {
            assert!(per_face.as_f64().unwrap() > 4.0, "{per_face}");
        } else {
            assert_eq!(*per_face, 4);
        }
        kd.push(m["val"]["mean"]["kd_psnr"].as_f64().unwrap());
    }
    assert!(
        kd[2] >= 40.0,
        "the same surface, refined through degrade.json's face map: kd {:.2} dB",
        kd[2]
    );
    assert!(
        kd[0] >= 40.0,
        "the same surface, split finer: kd {:.2} dB",
        kd[0]
    );
    assert!(
        kd[1] < kd[0] - 3.0,
        "warped by 40 mm: kd {:.2} dB, unwarped {:.2}",
        kd[1],
        kd[0]
    );
    let other = dir.join("other");
    synth("room", other.to_str().unwrap(), [2, 1, 16, 12, 1], &[]);
    let out = dir.join("ceil-other");
    let (ok, _, err) = fipt(&[
        "eval",
        src.to_str().unwrap(),
        out.to_str().unwrap(),
        "--ceiling",
        other.to_str().unwrap(),
    ]);
    assert!(!ok, "a mesh of another scene is refused");
    assert!(err.contains("other") && err.contains("power of 4"), "{err}");
    let (ok, _, err) = fipt(&[
        "eval",
        src.to_str().unwrap(),
        dir.join("fine").to_str().unwrap(),
        "--ceiling",
        dir.join("fine").to_str().unwrap(),
    ]);
    assert!(!ok, "a scene folder is not written into: {err}");
}

/// A mesh in millimetres with poses in metres, and a black photo: `fipt info` names both, and
/// `fipt run` says the same in its report (it said neither before 2026-12-07) and leaves the
/// black view out of the materials' fit.
#[test]
fn a_mesh_in_other_units_and_a_black_view_are_named_by_info_and_run() {
    let dir = tmp("units");
    let src = dir.join("scene");
    synth("cornell", src.to_str().unwrap(), [6, 1, 32, 24, 4], &[]);
    let copy = dir.join("mm");
    degrade(&src, &copy, &["--layout", "real"]);
    move_obj_vertices(&copy.join("scene.obj"), |v| v.map(|x| 1000.0 * x));
    let black = copy.join("Image/001_0001.exr");
    let size = fipt_core::image::Image::read_exr(&black).unwrap();
    fipt_core::image::Image::new(size.width, size.height)
        .write_exr(&black, fipt_core::image::ExrPrecision::F16)
        .unwrap();
    let (ok, info, err) = fipt(&["info", copy.to_str().unwrap()]);
    assert!(ok, "{err}");
    let units = "poses and mesh in different units";
    assert!(
        info.contains(units) && info.contains("black views [1]"),
        "{info}"
    );
    let (ok, info, _) = fipt(&["info", src.to_str().unwrap()]);
    assert!(ok && !info.contains(units), "{info}");
    let cfg = dir.join("run.toml");
    std::fs::write(&cfg, TINY).unwrap();
    let out = dir.join("out");
    run(&copy, &out, &cfg);
    let warnings = json(&out.join("report.json"))["warnings"].to_string();
    assert!(
        warnings.contains(units)
            && warnings.contains("black views [1] (no pixel above 0")
            && warnings.contains("are left out of the materials' fit and the search"),
        "{warnings}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
