//! Tests of [`crate::nerfstudio`].
use super::*;
use serde_json::json;

const EYE: [[f32; 4]; 4] = [
    [1., 0., 0., 0.],
    [0., 1., 0., 0.],
    [0., 0., 1., 0.],
    [0., 0., 0., 1.],
];

use crate::test_temp::Temp;

/// Writes `top` with `frames` (name, transform_matrix) added, as `tmp`'s transforms.json.
fn write_file(tmp: &Temp, mut top: Value, frames: &[(&str, [[f32; 4]; 4])]) -> PathBuf {
    if top.get("frames").is_none() {
        let f: Vec<Value> = frames
            .iter()
            .map(|(n, m)| json!({"file_path": n, "transform_matrix": m}))
            .collect();
        top["frames"] = Value::Array(f);
    }
    let p = tmp.0.join("transforms.json");
    std::fs::write(&p, serde_json::to_string_pretty(&top).unwrap()).unwrap();
    p
}

/// A lens from the CLI's `--lens` syntax.
fn lens(s: &str) -> Distortion {
    s.parse().unwrap()
}

fn expect(e: &str, parts: &[&str]) {
    for p in parts {
        assert!(e.contains(p), "`{p}` not in: {e}");
    }
}

/// Mitsuba-convention cameras around a room, all with lens `d`.
fn cameras(d: Distortion) -> Vec<Camera> {
    let poses = [
        ([0.3, 1.2, -0.5], [1.0, 0.8, 2.0]),
        ([2.0, 1.0, 1.0], [0.0, 0.0, 0.0]),
        ([0.0, 2.0, 0.0], [0.1, 0.0, 0.2]),
    ];
    let cam = |(o, t): &([f32; 3], [f32; 3])| {
        let (o, t) = (Vec3::from_array(*o), Vec3::from_array(*t));
        let mut c = Camera::look_at(o, t, Vec3::Y, 60f32.to_radians(), 64, 48);
        c.distortion = d;
        c
    };
    poses.iter().map(cam).collect()
}

fn assert_same_rays(a: &Camera, b: &Camera, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}");
    assert!((a.origin - b.origin).length() < 1e-5, "{what}");
    for (i, j) in [(0, 0), (63, 0), (10, 47), (32, 24), (63, 47)] {
        let ((_, da), (_, db)) = (a.pixel_center_ray(i, j), b.pixel_center_ray(i, j));
        assert!(
            (da - db).length() < 1e-5,
            "{what} pixel ({i},{j}): {da} vs {db}"
        );
    }
}

/// Writes `cams` (view 1 with a mask), reads them back, checks the rays; the read
/// cameras and the JSON written.
fn round_trip(cams: &[Camera], what: &str) -> (CaptureCameras, Value) {
    let tmp = Temp::new();
    let path = tmp.0.join("transforms.json");
    let views: Vec<(String, Camera, Option<String>)> = (0..cams.len())
        .map(|k| {
            (
                format!("images/{k}.jpg"),
                cams[k].clone(),
                (k == 1).then(|| "m/1.png".into()),
            )
        })
        .collect();
    write(&path, &views).unwrap();
    assert!(looks_like_nerfstudio(&path).unwrap().is_some());
    let got = read(&path).unwrap();
    assert_eq!(got.views.len(), cams.len());
    for (k, (v, orig)) in got.views.iter().zip(cams).enumerate() {
        assert_same_rays(orig, &v.camera, &format!("{what} view {k}"));
        assert_eq!(v.camera.convention, PoseConvention::OpenCv);
        assert_eq!(v.name, format!("images/{k}.jpg"));
        assert_eq!(v.image, tmp.0.join(&v.name));
        assert_eq!(v.mask, (k == 1).then(|| tmp.0.join("m/1.png")));
    }
    assert_eq!(
        (&got.cameras_file, &got.files),
        (&path, &vec![path.clone()])
    );
    let json: Value = crate::fsutil::read_json(&path).unwrap();
    (got, json)
}

#[test]
fn write_then_read_round_trips_each_camera_model() {
    let brown = lens("opencv:-0.12");
    let fisheye = lens("fisheye:0.02,-0.01,0.001");
    for (d, model, lens) in [
        (Distortion::None, "PINHOLE", "frames, PINHOLE,"),
        (brown, "OPENCV", "OPENCV k1 = -0.120,"),
        (
            fisheye,
            "OPENCV_FISHEYE",
            "OPENCV_FISHEYE k1 = 0.020, k2 = -0.010, k3 = 0.001,",
        ),
    ] {
        let (got, json) = round_trip(&cameras(d), model);
        assert_eq!(json["camera_model"], model);
        assert!(json["fl_x"].is_number() && json["frames"][0].get("fl_x").is_none());
        assert!(
            got.views.iter().all(|v| v.camera.distortion == d),
            "{model}"
        );
        let parts = [
            "nerfstudio transforms.json",
            "OpenGL",
            "3 frames",
            lens,
            "masks for 1",
        ];
        expect(&got.description, &parts);
        expect(
            &got.notes.join("\n"),
            &["mask_path is given for 1 of 3 frames"],
        );
    }
}

#[test]
fn per_frame_intrinsics_are_written_and_read_per_frame() {
    let mut cams = cameras(Distortion::None);
    cams[1].fx *= 1.1;
    cams[1].cx += 1.25;
    cams[2].distortion = lens("opencv:0.05,-0.01,0.001,-0.0015,0.002");
    let k = [[50.0, 0.0, 31.0], [0.0, 52.0, 25.5], [0.0, 0.0, 1.0]];
    let (o, t) = (Vec3::new(0.5, -0.3, 0.7), Vec3::new(0.0, 0.0, 3.0));
    cams.push(Camera::from_opencv(o, t, Vec3::Y, k, 64, 48));
    let (got, json) = round_trip(&cams, "per frame");
    assert_eq!(json["camera_model"], "OPENCV");
    assert!(json.get("fl_x").is_none() && json["frames"][1]["fl_x"].is_number());
    assert_eq!(got.views[0].camera.distortion, Distortion::None);
    assert_eq!(got.views[2].camera.distortion, cams[2].distortion);
    expect(
        &got.description,
        &["4 frames", "per-frame intrinsics (4 OPENCV)"],
    );

    // Hand-written: the file's intrinsics, overridden by a frame key by key.
    let tmp = Temp::new();
    let top = json!({
        "camera_model": "OPENCV", "fl_x": 100.0, "fl_y": 101.0, "cx": 40.0, "cy": 30.0,
        "w": 80, "h": 60.0, "k1": -0.1, "k2": 0.0, "p1": 0.0, "p2": 0.0,
        "frames": [
            {"file_path": "a.png", "transform_matrix": EYE},
            {"file_path": "b.png", "transform_matrix": EYE, "fl_x": 120.0, "w": 96, "k1": 0.0},
        ]
    });
    let got = read(&write_file(&tmp, top, &[])).unwrap();
    let (a, b) = (&got.views[0].camera, &got.views[1].camera);
    assert_eq!(
        (a.fx, a.fy, a.cx, a.cy, a.width, a.height),
        (100.0, 101.0, 40.0, 30.0, 80, 60)
    );
    assert_eq!(
        (b.fx, b.fy, b.cx, b.width, b.height),
        (120.0, 101.0, 40.0, 96, 60)
    );
    assert!(matches!(a.distortion, Distortion::Opencv { k1, .. } if k1 == -0.1));
    assert_eq!(b.distortion, Distortion::None);
    expect(&got.description, &["per-frame intrinsics (2 OPENCV)"]);
}

#[test]
fn instant_ngp_files_with_a_field_of_view_and_bare_names_are_read() {
    let tmp = Temp::new();
    std::fs::create_dir_all(tmp.0.join("train")).unwrap();
    for k in 0..2 {
        let p = tmp.0.join(format!("train/r_{k}.png"));
        image::RgbImage::new(8, 6).save(p).unwrap();
    }
    // Frame 1 turned 90° about +Y (it looks along world −X), at (1, 2, 3).
    let turned = [
        [0., 0., 1., 1.],
        [0., 1., 0., 2.],
        [-1., 0., 0., 3.],
        [0., 0., 0., 1.],
    ];
    let ax = 0.6911112070083618_f64;
    let top = json!({"camera_angle_x": ax, "aabb_scale": 16, "scale": 0.33});
    let path = write_file(&tmp, top, &[("./train/r_0", EYE), ("./train/r_1", turned)]);
    expect(
        &looks_like_nerfstudio(&path).unwrap().unwrap(),
        &["it has aabb_scale"],
    );
    let got = read(&path).unwrap();
    let c = &got.views[0].camera;
    assert_eq!((c.width, c.height, c.cx, c.cy), (8, 6, 4.0, 3.0));
    let f = (0.5 * 8.0 / (0.5 * ax).tan()) as f32;
    assert!((c.fx - f).abs() < 1e-5 && c.fy == c.fx, "{c:?}");
    assert_eq!(got.views[1].image, tmp.0.join("train/r_1.png"));
    assert_eq!(got.views[1].name, "./train/r_1");
    // The identity pose looks along −Z, +Y up: the top-left pixel sees up (+Y), left (−X).
    let (_, d) = c.ray(4.0, 3.0);
    assert!((d - Vec3::NEG_Z).length() < 1e-6, "{d}");
    let (_, d) = c.pixel_center_ray(0, 0);
    assert!(d.x < 0.0 && d.y > 0.0 && d.z < 0.0, "{d}");
    let c1 = &got.views[1].camera;
    assert!((c1.forward() - Vec3::NEG_X).length() < 1e-6);
    assert_eq!(c1.origin, Vec3::new(1.0, 2.0, 3.0));
    expect(
        &got.description,
        &["instant-ngp transforms.json", "2 frames, PINHOLE"],
    );
    expect(
        &got.notes.join("\n"),
        &["keys not read (ignored): aabb_scale, scale"],
    );
    // Without the images (and no w, h), the size is nowhere: the error says so.
    std::fs::remove_dir_all(tmp.0.join("train")).unwrap();
    let e = read(&path).unwrap_err().to_string();
    expect(&e, &["transforms.json", "frame 0", "no w and h", "r_0"]);
}

#[test]
fn applied_transform_and_distortion_without_a_model_are_noted() {
    let tmp = Temp::new();
    let top = json!({
        "fl_x": 50.0, "w": 64, "h": 48, "k1": -0.05, "p1": 0.001,
        "applied_transform": [[1., 0., 0., 0.], [0., 0., 1., 0.], [0., -1., 0., 0.]],
        "frames": [{"file_path": "a.jpg", "transform_matrix": EYE, "mask_path": "m/a.png",
                    "sharpness": 31.5}]
    });
    let got = read(&write_file(&tmp, top, &[])).unwrap();
    let c = &got.views[0].camera;
    assert_eq!((c.fy, c.cx, c.cy), (50.0, 32.0, 24.0));
    let brown = lens("opencv:-0.05,0,0.001");
    assert_eq!(c.distortion, brown);
    assert_eq!(got.views[0].mask, Some(tmp.0.join("m/a.png")));
    let notes = got.notes.join("\n");
    let parts = [
        "the mesh must be in that frame too",
        "as instant-ngp does",
        "frames[].sharpness",
    ];
    expect(&notes, &parts);
    let parts = [
        "nerfstudio",
        "1 frame,",
        "OPENCV k1 = -0.050, p1 = 0.001",
        "masks for 1",
    ];
    expect(&got.description, &parts);
}

#[test]
fn bad_poses_are_refused_naming_the_file_and_frame() {
    let tmp = Temp::new();
    let mirrored = [
        [1., 0., 0., 0.],
        [0., 1., 0., 0.],
        [0., 0., -1., 0.],
        [0., 0., 0., 1.],
    ];
    let last_row = [
        [1., 0., 0., 0.],
        [0., 1., 0., 0.],
        [0., 0., 1., 0.],
        [0., 0., 1., 1.],
    ];
    let scaled = [
        [2., 0., 0., 0.],
        [0., 2., 0., 0.],
        [0., 0., 2., 0.],
        [0., 0., 0., 1.],
    ];
    for (bad, parts) in [
        (
            mirrored,
            ["frame 1", "file_path b.png", "reflection", "OpenGL"],
        ),
        (
            last_row,
            ["frame 1 (b.png)", "last row", "[0, 0, 0, 1]", "4×4"],
        ),
        (scaled, ["frame 1", "det", "rigid", "translations"]),
    ] {
        let top = json!({"fl_x": 50.0, "w": 64, "h": 48});
        let path = write_file(&tmp, top, &[("a.png", EYE), ("b.png", bad)]);
        let e = read(&path).unwrap_err().to_string();
        expect(&e, &parts);
        expect(&e, &[path.to_str().unwrap()]);
    }
    let top = json!({"fl_x": 50.0, "w": 64, "h": 48,
                     "frames": [{"file_path": "a.png", "transform_matrix": [[1.0, 0.0]]}]});
    let e = read(&write_file(&tmp, top, &[])).unwrap_err().to_string();
    expect(&e, &["frame 0 (a.png)", "4 rows of 4"]);
}

#[test]
fn unsupported_models_and_bad_intrinsics_are_refused_with_the_fix() {
    let tmp = Temp::new();
    let cases = [
        (
            json!({"camera_model": "EQUIRECTANGULAR", "fl_x": 50.0, "w": 64, "h": 32}),
            vec![
                "EQUIRECTANGULAR",
                "--camera-type equirectangular",
                "perspective",
            ],
        ),
        (
            json!({"camera_model": "FISHEYE624", "fl_x": 50.0, "w": 64, "h": 48}),
            vec!["FISHEYE624", "PINHOLE, OPENCV and OPENCV_FISHEYE"],
        ),
        (
            json!({"w": 64, "h": 48}),
            vec!["frame 0", "no focal length", "camera_angle_x"],
        ),
        (
            json!({"fl_x": -5.0, "w": 64, "h": 48}),
            vec!["frame 0", "must be positive"],
        ),
        (
            json!({"camera_model": "OPENCV", "fl_x": 50.0, "w": 64, "h": 48, "k4": 0.1}),
            vec!["k4 = 0.1", "OPENCV_FISHEYE"],
        ),
        (
            json!({"fl_x": 50.0, "w": 64.5, "h": 48}),
            vec!["w = 64.5", "whole number"],
        ),
        (
            json!({"camera_model": "OPENCV", "fl_x": 30.0, "w": 64, "h": 48, "k1": -0.9}),
            vec!["frame 0", "cannot be inverted"],
        ),
        (
            json!({"fl_x": 50.0, "w": 64, "h": 48, "frames": []}),
            vec!["no frames"],
        ),
    ];
    for (top, parts) in cases {
        let e = read(&write_file(&tmp, top, &[("a.png", EYE)]))
            .unwrap_err()
            .to_string();
        expect(&e, &parts);
        expect(&e, &["transforms.json"]);
    }
}

#[test]
fn fipt_files_are_told_apart_and_mixed_lenses_are_not_written() {
    let tmp = Temp::new();
    let fipt = json!({"camera_angle_x": 0.8, "width": 64, "height": 48,
                      "frames": [{"file_path": "./train/r_0", "transform_matrix": EYE}]});
    let path = write_file(&tmp, fipt, &[]);
    assert_eq!(looks_like_nerfstudio(&path).unwrap(), None);
    let own = json!({"camera_angle_x": 0.8,
                     "frames": [{"fl_x": 40.0, "transform_matrix": EYE}]});
    let path = write_file(&tmp, own, &[]);
    expect(
        &looks_like_nerfstudio(&path).unwrap().unwrap(),
        &["frames with their own fl_x"],
    );
    std::fs::write(&path, "{ not json").unwrap();
    assert!(looks_like_nerfstudio(&path).is_err());

    let mut cams = cameras(Distortion::None);
    cams[0].distortion = lens("fisheye:0");
    let views: Vec<_> = cams
        .into_iter()
        .map(|c| ("x.png".to_string(), c, None))
        .collect();
    let e = write(&path, &views).unwrap_err().to_string();
    expect(&e, &["1 of 3 cameras are fisheyes"]);
    assert!(write(&path, &[]).is_err());
}
