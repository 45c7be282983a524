//! The loader on generated scenes: both layouts, round trips of every file, and every kind of
//! bad input named with its file.
use fipt_core::camera::Camera;
use fipt_core::dataset::{read_transforms, write_transforms, Dataset, GtKind, Layout};
use fipt_core::image::{BadPixelPolicy, ExrPrecision, Image};
use fipt_core::materials::SceneMaterials;
use fipt_geom::Mesh;
use fipt_shading::render::RenderConfig;
use fipt_synth::{build, write_dataset, SynthOptions};
use fipt_tests::temp_dir;
use glam::Vec3;
use std::path::Path;

fn tiny_cornell(dir: &Path) {
    let opts = SynthOptions {
        train_views: 4,
        val_views: 2,
        width: 16,
        height: 12,
        render: RenderConfig {
            spp: 4,
            ..Default::default()
        },
        model: Default::default(),
        lens: Default::default(),
    };
    write_dataset(build("cornell").unwrap(), dir, &opts, &|_, _| {}).unwrap();
}

#[test]
fn generated_scene_opens_with_all_ground_truth_and_round_trips() {
    let dir = temp_dir("gen");
    tiny_cornell(&dir);
    let ds = Dataset::open(&dir).unwrap();
    assert_eq!(ds.layout, Layout::Synthetic);
    assert_eq!((ds.width, ds.height), (16, 12));
    assert_eq!(ds.train().views.len(), 4);
    assert_eq!(ds.split("val").unwrap().views.len(), 2);
    for kind in GtKind::ALL {
        assert!(ds.train().has_gt(kind), "{kind:?} missing");
    }
    assert!(ds.warnings.is_empty(), "{:?}", ds.warnings);
    // transforms.json round trip: the cameras we wrote are the cameras we read.
    let cams: Vec<Camera> = ds.train().views.iter().map(|v| v.camera.clone()).collect();
    let p = dir.join("rt/transforms.json");
    write_transforms(&p, &cams).unwrap();
    let back = read_transforms(&p, None).unwrap();
    for (a, b) in cams.iter().zip(&back) {
        for (i, j) in [(0, 0), (15, 11), (7, 5)] {
            let (oa, da) = a.pixel_center_ray(i, j);
            let (ob, db) = b.pixel_center_ray(i, j);
            assert!((oa - ob).length() < 1e-6 && (da - db).length() < 1e-6);
        }
    }
    // scene_gt.json and scene.obj agree: every face has a material, the emitter is found.
    let mesh = Mesh::load(&ds.mesh).unwrap();
    let mats = SceneMaterials::read(&dir.join("scene_gt.json")).unwrap();
    let table = mats.face_table(mesh.num_file_faces, &dir).unwrap();
    assert!(table
        .iter()
        .any(|&m| mats.materials[m as usize].is_emitter()));
    // Emit GT is positive exactly where the part is an emitter.
    let split = ds.train();
    for v in &split.views {
        let emit = ds.load_gt(split, GtKind::Emit, v.index).unwrap().unwrap();
        let part = ds
            .load_gt(split, GtKind::IndexMA, v.index)
            .unwrap()
            .unwrap();
        for (e, p) in emit.data.iter().zip(&part.data) {
            let is_emitter = p.x >= 0.0 && mats.materials[p.x as usize].is_emitter();
            assert_eq!(e.max_element() > 0.0, is_emitter);
        }
        let (img, bad) = ds.load_image(v, BadPixelPolicy::Reject).unwrap();
        assert_eq!(bad.total(), 0);
        assert!(img
            .data
            .iter()
            .all(|p| p.is_finite() && p.min_element() >= 0.0));
    }
    std::fs::remove_dir_all(&dir).ok();
}

fn expect_err(dir: &Path, needles: &[&str]) {
    let err = match Dataset::open(dir) {
        Ok(ds) => {
            // Pixel problems surface when images are read.
            let v = &ds.train().views[0];
            ds.load_image(v, BadPixelPolicy::Reject)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        }
        Err(e) => e.to_string(),
    };
    for n in needles {
        assert!(err.contains(n), "error `{err}` should mention `{n}`");
    }
}

#[test]
fn bad_inputs_are_named_with_their_file_and_fix() {
    let base = temp_dir("bad");
    tiny_cornell(&base);
    let fresh = |name: &str| {
        let d = base.with_file_name(format!(
            "{}-{name}",
            base.file_name().unwrap().to_string_lossy()
        ));
        let _ = std::fs::remove_dir_all(&d);
        copy_dir(&base, &d);
        d
    };
    // Missing image.
    let d = fresh("missing");
    std::fs::remove_file(d.join("train/Image/002_0001.exr")).unwrap();
    expect_err(&d, &["002_0001.exr", "missing"]);
    // An upper-case extension is read; a name in other letter case otherwise is named.
    let d = fresh("case");
    let image = |e: &str| d.join(format!("train/Image/002_0001.{e}"));
    std::fs::rename(image("exr"), image("EXR")).unwrap();
    assert!(Dataset::open(&d).is_ok());
    std::fs::rename(image("EXR"), image("Exr")).unwrap();
    // (On a file system that ignores case the view is simply found.)
    if !image("exr").is_file() {
        expect_err(
            &d,
            &["002_0001.exr", "002_0001.Exr is there", "case-sensitive"],
        );
    }
    // Size mismatch between views.
    let d = fresh("size");
    Image::new(8, 8)
        .write_exr(&d.join("train/Image/001_0001.exr"), ExrPrecision::F32)
        .unwrap();
    expect_err(&d, &["001_0001.exr", "8x8", "16x12", "resize this photo"]);
    // NaN / Inf / negative pixels: rejected by default, clamped on request.
    let d = fresh("nan");
    let p = d.join("train/Image/000_0001.exr");
    let mut img = Image::read_exr(&p).unwrap();
    img.set(3, 2, Vec3::new(f32::NAN, -1.0, f32::INFINITY));
    img.write_exr(&p, ExrPrecision::F32).unwrap();
    expect_err(
        &d,
        &[
            "000_0001.exr",
            "1 NaN",
            "1 infinite",
            "1 negative",
            "(3, 2)",
            "clamp",
        ],
    );
    let ds = Dataset::open(&d).unwrap();
    let (img, bad) = ds
        .load_image(&ds.train().views[0], BadPixelPolicy::Clamp)
        .unwrap();
    assert_eq!(bad.total(), 3);
    assert!(img
        .data
        .iter()
        .all(|p| p.is_finite() && p.min_element() >= 0.0));
    non_rigid_poses_are_refused(&fresh);
    // No mesh, or not a scene at all.
    let d = fresh("nomesh");
    std::fs::remove_file(d.join("scene.obj")).unwrap();
    expect_err(&d, &["no mesh found", "scene.obj"]);
    // A mesh under another name is named.
    std::fs::write(d.join("room.OBJ"), "v 0 0 0\n").unwrap();
    expect_err(&d, &["no mesh found", "found room.OBJ", "rename"]);
    // Unknown keys in the material table.
    let d = fresh("keys");
    let p = d.join("scene_gt.json");
    let text = std::fs::read_to_string(&p).unwrap().replacen(
        "\"version\": 1",
        "\"version\": 1, \"colour_space\": \"srgb\"",
        1,
    );
    std::fs::write(&p, text).unwrap();
    let err = SceneMaterials::read(&p).unwrap_err().to_string();
    assert!(
        err.contains("scene_gt.json") && err.contains("colour_space"),
        "{err}"
    );
    // More images than frames: opened, with a warning naming the unused images.
    let d = fresh("extra");
    std::fs::copy(
        d.join("train/Image/000_0001.exr"),
        d.join("train/Image/099_0001.exr"),
    )
    .unwrap();
    let ds = fipt_core::dataset::Dataset::open(&d).unwrap();
    assert!(
        ds.warnings
            .iter()
            .any(|w| w.contains("1 images") && w.contains("099_0001.exr")),
        "{:?}",
        ds.warnings
    );
    for name in [
        "missing", "case", "size", "nan", "shear", "flip", "nomesh", "keys", "extra",
    ] {
        std::fs::remove_dir_all(base.with_file_name(format!(
            "{}-{name}",
            base.file_name().unwrap().to_string_lossy()
        )))
        .ok();
    }
    std::fs::remove_dir_all(&base).ok();
}

/// A pose that is not a rotation, and one that is a reflection (another convention), are
/// refused naming the frame.
fn non_rigid_poses_are_refused(fresh: &dyn Fn(&str) -> std::path::PathBuf) {
    for (name, scale, needle) in [
        ("shear", [1.3f32, 1.0, 1.0], "rigid"),
        ("flip", [-1.0, 1.0, 1.0], "reflection"),
    ] {
        let d = fresh(name);
        let tf = d.join("train/transforms.json");
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&tf).unwrap()).unwrap();
        for r in 0..3 {
            for c in 0..3 {
                let x = v["frames"][1]["transform_matrix"][r][c].as_f64().unwrap();
                v["frames"][1]["transform_matrix"][r][c] = serde_json::json!(x * scale[c] as f64);
            }
        }
        std::fs::write(&tf, serde_json::to_string(&v).unwrap()).unwrap();
        expect_err(&d, &["transforms.json", "frame 1", needle]);
    }
}

/// The real layout (cam.txt + K_list.txt, OpenCV convention) of the same physical cameras
/// gives the same rays as the synthetic layout.
#[test]
fn real_layout_matches_synthetic_layout() {
    let syn = temp_dir("syn");
    tiny_cornell(&syn);
    let ds = Dataset::open(&syn).unwrap();
    let real = temp_dir("real");
    std::fs::copy(syn.join("scene.obj"), real.join("scene.obj")).unwrap();
    std::fs::create_dir_all(real.join("Image")).unwrap();
    let views = &ds.train().views;
    let mut cam_txt = format!("{}\n", views.len());
    let mut k_txt = format!("{}\n", views.len());
    for v in views {
        let c = &v.camera;
        let target = c.origin + c.forward();
        let up = c.rotation.y_axis; // Mitsuba +Y is up
        cam_txt += &format!(
            "{} {} {}\n{} {} {}\n{} {} {}\n",
            c.origin.x, c.origin.y, c.origin.z, target.x, target.y, target.z, up.x, up.y, up.z
        );
        k_txt += &format!("{} 0 {}\n0 {} {}\n0 0 1\n", c.fx, c.cx, c.fy, c.cy);
        std::fs::copy(
            &v.image,
            real.join("Image").join(v.image.file_name().unwrap()),
        )
        .unwrap();
    }
    std::fs::write(real.join("cam.txt"), &cam_txt).unwrap();
    std::fs::write(real.join("K_list.txt"), &k_txt).unwrap();
    let rd = Dataset::open(&real).unwrap();
    assert_eq!(rd.layout, Layout::Real);
    for (a, b) in views.iter().zip(&rd.train().views) {
        for (i, j) in [(0, 0), (15, 11), (3, 9)] {
            let (_, da) = a.camera.pixel_center_ray(i, j);
            let (_, db) = b.camera.pixel_center_ray(i, j);
            assert!((da - db).length() < 1e-4, "{da} vs {db}");
        }
    }
    // An up vector along the view direction is named, not given an arbitrary roll.
    let mut lines: Vec<String> = std::fs::read_to_string(real.join("cam.txt"))
        .unwrap()
        .lines()
        .map(String::from)
        .collect();
    let c = &views[0].camera;
    let f = c.forward() * 2.0;
    lines[3] = format!("{} {} {}", f.x, f.y, f.z);
    std::fs::write(real.join("cam.txt"), lines.join("\n")).unwrap();
    let err = Dataset::open(&real).unwrap_err().to_string();
    assert!(
        err.contains("cam.txt") && err.contains("camera 0: the up vector"),
        "{err}"
    );
    // A missing image is named with the extensions looked for.
    std::fs::write(real.join("cam.txt"), cam_txt).unwrap();
    let img1 = rd.train().views[1].image.clone();
    std::fs::remove_file(&img1).unwrap();
    let err = Dataset::open(&real).unwrap_err().to_string();
    assert!(
        err.contains("001_0001") && err.contains(".exr, .png, .jpg, .jpeg"),
        "{err}"
    );
    // A K_list with the wrong count is named.
    std::fs::write(real.join("K_list.txt"), "1\n1 0 0 0 1 0 0 0 1\n").unwrap();
    let err = Dataset::open(&real).unwrap_err().to_string();
    assert!(err.contains("K_list.txt"), "{err}");
    std::fs::remove_dir_all(&syn).ok();
    std::fs::remove_dir_all(&real).ok();
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let t = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &t);
        } else {
            std::fs::copy(e.path(), t).unwrap();
        }
    }
}
