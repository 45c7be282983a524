//! Checks on the recovered scene of a finished run: relighting, novel views, edits, exports,
//! bad input to `fipt render`, and the report in a browser.
use super::{fipt, tmp};
use std::process::Command;

/// `report.html` of a run: headless Chromium loads it from disk with no script or load error
/// and every image decoded (the page records both on `<body>` when it loads).
pub fn report_opens_in_a_browser(run: &std::path::Path) {
    let html = run.join("report.html");
    assert!(html.is_file() && run.join("report/sheet_val.png").is_file());
    let Some(browser) = ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|b| {
            Command::new(b)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        })
    else {
        eprintln!("skipping the browser check of report.html: no chromium (scripts/install-chromium.sh installs it)");
        return;
    };
    let out = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--virtual-time-budget=5000",
            "--dump-dom",
        ])
        .arg(&html)
        .output()
        .expect("run chromium");
    let dom = String::from_utf8_lossy(&out.stdout);
    let body = dom
        .split("<body")
        .nth(1)
        .and_then(|b| b.split('>').next())
        .unwrap_or_default()
        .to_string();
    let attr = |name: &str| -> Option<usize> {
        body.split(&format!("{name}=\""))
            .nth(1)?
            .split('"')
            .next()?
            .parse()
            .ok()
    };
    let (images, bad, errors) = (
        attr("data-images"),
        attr("data-images-bad"),
        attr("data-errors"),
    );
    assert!(
        images.is_some_and(|n| n >= 8) && bad == Some(0) && errors == Some(0),
        "report.html in {browser}: body{body}"
    );
}

/// The recovered scene of a finished run, relit (its emitters off, a sphere light on) and seen
/// from a camera no view had, against the true scene under the same edit; and what bad input
/// to `fipt render` gets.
pub fn relight_and_novel_views(scene: &std::path::Path, run: &std::path::Path) {
    let d = scene.to_str().unwrap();
    let lights = scene.join("lights.json");
    std::fs::write(
        &lights,
        r#"{"lights": [{"type": "sphere", "center": [0.3, 1.4, 0.2], "radius": 0.12,
                        "radiance": [40, 36, 30], "subdivisions": 2}],
            "emitters": "off"}"#,
    )
    .unwrap();
    let l = lights.to_str().unwrap();
    let cams = scene.join("val/transforms.json");
    let c = cams.to_str().unwrap();
    let truth = tmp("relight-truth");
    let gt = scene.join("scene_gt.json");
    let (ok, _, err) = fipt(&[
        "render",
        d,
        "--materials",
        gt.to_str().unwrap(),
        "--cameras",
        c,
        "--lights",
        l,
        "--out",
        truth.to_str().unwrap(),
        "--spp",
        "256",
    ]);
    assert!(ok, "{err}");
    let rec = tmp("relight-recovered");
    let (ok, stdout, err) = fipt(&[
        "render",
        run.to_str().unwrap(),
        "--cameras",
        c,
        "--lights",
        l,
        "--out",
        rec.to_str().unwrap(),
        "--spp",
        "256",
        "--reference",
        truth.to_str().unwrap(),
    ]);
    assert!(ok, "{stdout}{err}");
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(rec.join("metrics.json")).unwrap()).unwrap();
    let p = m["render_psnr"]["mean"].as_f64().unwrap();
    eprintln!("relit recovered scene vs relit truth: {p:.2} dB");
    assert!(p >= 20.0, "relit recovered scene vs relit truth: {p:.2} dB");
    // A camera no view had: the first val camera moved 0.2 m sideways and turned.
    let mut tf: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&cams).unwrap()).unwrap();
    let frame = tf["frames"][0].clone();
    let mut m4 = frame["transform_matrix"].clone();
    m4[0][3] = serde_json::json!(m4[0][3].as_f64().unwrap() - 0.2);
    m4[2][3] = serde_json::json!(m4[2][3].as_f64().unwrap() + 0.2);
    tf["frames"] = serde_json::json!([{"file_path": "Image/000_0001.exr", "transform_matrix": m4}]);
    let novel = scene.join("novel.json");
    std::fs::write(&novel, tf.to_string()).unwrap();
    let nv = tmp("novel");
    let (ok, _, err) = fipt(&[
        "render",
        run.to_str().unwrap(),
        "--cameras",
        novel.to_str().unwrap(),
        "--out",
        nv.to_str().unwrap(),
        "--spp",
        "16",
    ]);
    assert!(ok, "{err}");
    let img = fipt_core::image::Image::read_exr(&nv.join("000_render.exr")).unwrap();
    assert!(img.data.iter().all(|p| p.is_finite()));
    let dark = img.data.iter().filter(|p| p.max_element() <= 0.0).count();
    assert!(
        dark * 50 <= img.data.len(),
        "{dark} black pixels of {}",
        img.data.len()
    );
    for p in [truth, rec, nv] {
        let _ = std::fs::remove_dir_all(p);
    }
    bad_render_input(scene, run);
    edit_at_a_pixel(scene, run);
    exports(scene, run);
}

/// Bad input to `fipt render`: a clear error naming the thing, and nothing written.
fn bad_render_input(scene: &std::path::Path, run: &std::path::Path) {
    let cams = scene.join("val/transforms.json");
    let c = cams.to_str().unwrap();
    let bad = |name: &str, text: &str, want: &str| {
        let f = scene.join(name);
        std::fs::write(&f, text).unwrap();
        let o = tmp("bad-render");
        let (ok, _, err) = fipt(&[
            "render",
            run.to_str().unwrap(),
            "--cameras",
            c,
            "--lights",
            f.to_str().unwrap(),
            "--out",
            o.to_str().unwrap(),
            "--spp",
            "1",
        ]);
        assert!(
            !ok && err.contains(want) && err.contains(name),
            "{name}: {err}"
        );
        assert!(!o.exists(), "{name}: output written");
    };
    bad(
        "laser.json",
        r#"{"type": "laser", "position": [0, 1, 0]}"#,
        "laser",
    );
    bad(
        "wall.json",
        r#"{"type": "sphere", "center": [1.0, 1.0, 0.0], "radius": 0.2, "radiance": [1, 1, 1]}"#,
        "cuts through",
    );
    bad(
        "missing.json",
        r#"{"type": "mesh", "file": "no-such.obj", "radiance": [1, 1, 1]}"#,
        "not found",
    );
    let (ok, _, err) = fipt(&[
        "render",
        run.to_str().unwrap(),
        "--cameras",
        c,
        "--out",
        run.to_str().unwrap(),
    ]);
    assert!(
        !ok && err.contains("output folder of a `fipt run`"),
        "{err}"
    );
}

/// A material edit on the surface a pixel sees: its kd map reads the set value there.
fn edit_at_a_pixel(scene: &std::path::Path, run: &std::path::Path) {
    let cams = scene.join("val/transforms.json");
    let c = cams.to_str().unwrap();
    let edits = scene.join("edits.json");
    std::fs::write(
        &edits,
        r#"{"materials": [{"select": {"at": {"view": 0, "x": 24, "y": 18}},
                           "edit": {"albedo": {"set": [0.9, 0.1, 0.1]}, "metallic": {"set": 0}}}]}"#,
    )
    .unwrap();
    let ed = tmp("edited");
    let (ok, _, err) = fipt(&[
        "render",
        run.to_str().unwrap(),
        "--cameras",
        c,
        "--edits",
        edits.to_str().unwrap(),
        "--out",
        ed.to_str().unwrap(),
        "--spp",
        "1",
        "--views",
        "0",
    ]);
    assert!(ok && err.contains("1 material edits"), "{err}");
    let kd = fipt_core::image::Image::read_exr(&ed.join("000_kd.exr")).unwrap();
    let px = kd.data[18 * kd.width + 24];
    assert!(
        (px - glam::Vec3::new(0.9, 0.1, 0.1)).length() < 2e-3,
        "kd {px}"
    );
    let _ = std::fs::remove_dir_all(ed);
}

/// Exports of the recovered scene: the glb reloads with every triangle.
fn exports(scene: &std::path::Path, run: &std::path::Path) {
    let d = scene.to_str().unwrap();
    let ex = tmp("export");
    for (format, file) in [
        ("glb", "scene.glb"),
        ("mitsuba", "scene.xml"),
        ("obj", "scene.obj"),
    ] {
        let o = ex.join(format);
        let (ok, stdout, err) = fipt(&[
            "export",
            run.to_str().unwrap(),
            "--format",
            format,
            "--out",
            o.to_str().unwrap(),
        ]);
        assert!(ok && stdout.contains("atlas"), "{format}: {stdout}{err}");
        assert!(o.join(file).is_file(), "{format}: no {file}");
    }
    let glb = fipt_geom::Mesh::load(&ex.join("glb/scene.glb")).unwrap();
    let obj = fipt_geom::Mesh::load(&scene.join("scene.obj")).unwrap();
    assert_eq!(glb.triangles.len(), obj.triangles.len());
    let (ok, _, err) = fipt(&[
        "export",
        d,
        "--format",
        "glb",
        "--out",
        ex.to_str().unwrap(),
    ]);
    assert!(
        !ok && err.contains("not a finished `fipt run` output folder"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(ex);
}
