//! Tests of [`crate::colmap`].
use super::*;

use crate::test_temp::Temp;

fn expect(e: &str, parts: &[&str]) {
    for p in parts {
        assert!(e.contains(p), "`{p}` not in: {e}");
    }
}

fn brown(k1: f32, k2: f32, k3: f32, p1: f32, p2: f32) -> Distortion {
    Distortion::Opencv { k1, k2, k3, p1, p2 }
}

/// One camera of each model kind, in both conventions, listed out of name order.
fn cameras() -> Vec<(String, Camera)> {
    let cam = |o: [f32; 3], t: [f32; 3], d: Distortion| {
        let (o, t) = (Vec3::from_array(o), Vec3::from_array(t));
        let mut c = Camera::look_at(o, t, Vec3::Y, 60f32.to_radians(), 64, 48);
        c.distortion = d;
        c
    };
    let mut opencv = cam(
        [-1.0, 0.5, 2.0],
        [0.3, 0.1, -1.0],
        brown(0.08, -0.02, 0.0, 0.001, -0.0015),
    );
    opencv.fy *= 1.05;
    opencv.cx += 1.25;
    let fisheye = Distortion::Fisheye {
        k1: 0.02,
        k2: -0.01,
        k3: 0.001,
        k4: 0.0,
    };
    let (o, t, up, k) = cam([0.0, 2.0, 0.0], [0.1, 0.0, 0.2], Distortion::None).to_opencv_lookat();
    vec![
        (
            "d.png".into(),
            cam([0.3, 1.2, -0.5], [1.0, 0.8, 2.0], Distortion::None),
        ),
        (
            "b.jpg".into(),
            cam([2.0, 1.0, 1.0], [0.0; 3], brown(-0.12, 0.0, 0.0, 0.0, 0.0)),
        ),
        ("c.png".into(), opencv),
        (
            "sub/a.jpg".into(),
            cam([0.5, -0.3, 0.7], [0.0, 0.0, 3.0], fisheye),
        ),
        ("e.png".into(), Camera::from_opencv(o, t, up, k, 64, 48)),
    ]
}

fn assert_same_rays(a: &Camera, b: &Camera, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}");
    let (oa, ob) = (a.origin, b.origin);
    assert!((oa - ob).length() < 1e-5, "{what}: {oa} vs {ob}");
    for (i, j) in [(0, 0), (63, 0), (10, 47), (32, 24), (63, 47)] {
        let ((_, da), (_, db)) = (a.pixel_center_ray(i, j), b.pixel_center_ray(i, j));
        assert!(
            (da - db).length() < 1e-5,
            "{what} pixel ({i},{j}): {da} vs {db}"
        );
    }
}

#[test]
fn write_then_read_round_trips_text_and_binary() {
    let views = cameras();
    for (text, ext, kind) in [(true, "txt", "text"), (false, "bin", "binary")] {
        let tmp = Temp::new();
        let dir = tmp.0.join("sparse/0");
        write_model(&dir, &views, text).unwrap();
        std::fs::create_dir_all(tmp.0.join("masks/sub")).unwrap();
        std::fs::write(tmp.0.join("masks/b.jpg.png"), b"").unwrap();
        std::fs::write(tmp.0.join("masks/sub/a.jpg"), b"").unwrap();
        std::fs::write(tmp.0.join("masks/e.png"), b"").unwrap();
        assert_eq!(find_model(&tmp.0), Some(dir.clone()));
        let read = read_model(&tmp.0, &dir).unwrap();
        let names: Vec<&str> = read.views.iter().map(|v| v.name.as_str()).collect();
        assert_eq!(names, ["b.jpg", "c.png", "d.png", "e.png", "sub/a.jpg"]);
        for v in &read.views {
            let (_, orig) = views.iter().find(|(n, _)| *n == v.name).unwrap();
            assert_same_rays(orig, &v.camera, &format!("{} ({kind})", v.name));
            assert_eq!(v.camera.convention, PoseConvention::OpenCv);
            assert_eq!(v.camera.distortion, orig.distortion);
            assert_eq!(v.image, tmp.0.join("images").join(&v.name));
        }
        assert_eq!(read.views[0].mask, Some(tmp.0.join("masks/b.jpg.png")));
        assert_eq!(read.views[4].mask, Some(tmp.0.join("masks/sub/a.jpg")));
        assert_eq!(read.views[3].mask, Some(tmp.0.join("masks/e.png")));
        assert_eq!(read.views[1].mask, None);
        let summary =
            "5 images, 5 cameras (1 OPENCV, 1 OPENCV_FISHEYE, 2 PINHOLE, 1 SIMPLE_RADIAL)";
        expect(
            &read.description,
            &[&format!("COLMAP {kind} model in sparse/0 ("), summary],
        );
        let file = |s: &str| dir.join(format!("{s}.{ext}"));
        assert_eq!(read.files, [file("cameras"), file("images")]);
        assert_eq!(read.cameras_file, file("images"));
        assert!(file("points3D").is_file());
        expect(&read.notes.join("\n"), &["masks for 3 of 5 images"]);
    }
}

#[test]
fn binary_is_preferred_and_a_single_camera_is_described() {
    let tmp = Temp::new();
    let dir = tmp.0.join("sparse");
    let views = cameras()[1..2].to_vec();
    write_model(&dir, &views, true).unwrap();
    write_model(&dir, &views, false).unwrap();
    assert_eq!(find_model(&tmp.0), Some(dir.clone()));
    let read = read_model(&tmp.0, &dir).unwrap();
    let d = &read.description;
    let want = "binary model in sparse (OpenCV axes, world-to-camera poses): \
                1 image, 1 camera (SIMPLE_RADIAL, k1 = -0.120)";
    assert!(d.ends_with(want), "{d}");
    expect(&read.notes.join("\n"), &["the binary ones"]);
    let mut k3 = views[0].1.clone();
    k3.distortion = brown(0.1, 0.0, 0.01, 0.0, 0.0);
    let e = write_model(&dir, &[("x.png".into(), k3)], false).unwrap_err();
    expect(&e.to_string(), &["cameras.bin", "FULL_OPENCV"]);
}

const CAMERAS: &str = "# Camera list with one line of data per camera:\n\
    #   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n\n\
    1 SIMPLE_PINHOLE 100 80 100 50 40\n  2 PINHOLE 100 80 90 95 49.5 40.5  \n";

fn write_text(root: &Path, cameras: &str, images: &str) -> PathBuf {
    let dir = root.join("sparse/0");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("cameras.txt"), cameras).unwrap();
    std::fs::write(dir.join("images.txt"), images).unwrap();
    dir
}

#[test]
fn hand_written_text_model_with_blank_points_lines() {
    let tmp = Temp::new();
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let images = format!(
        "# Image list with two lines of data per image:\n\
         #   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n\
         2 {s} 0 {s} 0 0 0 5 2 b.jpg\n\n\
         # a comment between images\n\
         7 1 0 0 0 1 2 3 1 a.jpg\n10.5 20.5 -1 30 40 7\n"
    );
    let dir = write_text(&tmp.0, CAMERAS, &images);
    let read = read_model(&tmp.0, &dir).unwrap();
    assert_eq!(read.views.len(), 2);
    let (a, b) = (&read.views[0].camera, &read.views[1].camera);
    assert_eq!(read.views[0].name, "a.jpg");
    assert_eq!((a.fx, a.fy, a.cx, a.cy), (100.0, 100.0, 50.0, 40.0));
    assert_eq!(
        (a.width, a.height, a.distortion),
        (100, 80, Distortion::None)
    );
    assert!((a.origin - Vec3::new(-1.0, -2.0, -3.0)).length() < 1e-6);
    assert!((a.ray(50.0, 40.0).1 - Vec3::Z).length() < 1e-6);
    assert_eq!((b.fx, b.fy, b.cx, b.cy), (90.0, 95.0, 49.5, 40.5));
    // Turned 90° about +Y, the world origin 5 ahead: at (5, 0, 0) looking along −X.
    assert!(
        (b.origin - Vec3::new(5.0, 0.0, 0.0)).length() < 1e-5,
        "{}",
        b.origin
    );
    assert!((b.ray(49.5, 40.5).1 - Vec3::NEG_X).length() < 1e-5);
    expect(
        &read.description,
        &["2 images, 2 cameras (1 PINHOLE, 1 SIMPLE_PINHOLE)"],
    );
    assert!(read.notes.is_empty(), "{:?}", read.notes);
    std::fs::create_dir_all(tmp.0.join("masks")).unwrap();
    let notes = read_model(&tmp.0, &dir).unwrap().notes.join("\n");
    expect(&notes, &["masks/ holds no mask named after the images"]);
    // An image without its POINTS2D line would shift the pairing: refused, not misread.
    let two = "1 1 0 0 0 0 0 0 1 a.jpg\n2 1 0 0 0 0 0 0 1 b.jpg\n\n";
    let dir = write_text(&tmp.0, CAMERAS, two);
    let e = read_model(&tmp.0, &dir).unwrap_err().to_string();
    expect(&e, &["images.txt", "line 2", "POINTS2D"]);
}

#[test]
fn bad_text_models_are_refused_naming_the_file() {
    const ONE: &str = "1 1 0 0 0 0 0 0 1 a.jpg\n\n";
    const TWICE: &str = "1 1 0 0 0 0 0 0 1 a.jpg\n\n1 1 0 0 0 0 0 0 1 b.jpg\n\n";
    const FULL: &str = "1 FULL_OPENCV 10 10 1 1 5 5 0 0 0 0 0 0 0 0\n";
    let error = |cameras: &str, images: &str| {
        let tmp = Temp::new();
        let dir = write_text(&tmp.0, cameras, images);
        read_model(&tmp.0, &dir).unwrap_err().to_string()
    };
    let e = error(FULL, ONE);
    expect(
        &e,
        &[
            "cameras.txt",
            "camera 1",
            "FULL_OPENCV",
            "image_undistorter",
            "OPENCV",
        ],
    );
    let e = error("1 WEIRD 10 10 1 5 5\n", ONE);
    expect(&e, &["cameras.txt", "unknown camera model `WEIRD`"]);
    let e = error(CAMERAS, "1 1 0 0 0 0 0 0 3 a.jpg\n\n");
    expect(
        &e,
        &["images.txt", "camera 3", "cameras.txt does not define"],
    );
    let e = error("1 PINHOLE 10 10 5 5 5\n", ONE);
    expect(
        &e,
        &[
            "cameras.txt",
            "camera 1 (PINHOLE)",
            "3 parameters",
            "takes 4",
        ],
    );
    let e = error("1 PINHOLE 10 10 0 5 5 5\n", ONE);
    expect(&e, &["cameras.txt", "camera 1 (PINHOLE)", "focal length"]);
    let e = error("1 SIMPLE_RADIAL 100 100 50 50 50 nan\n", ONE);
    expect(&e, &["cameras.txt", "not all finite"]);
    let e = error("1 PINHOLE 9 9 5 5 5 5\n1 PINHOLE 9 9 5 5 5 5\n", ONE);
    expect(&e, &["cameras.txt", "camera id 1 is defined twice"]);
    let e = error(CAMERAS, TWICE);
    expect(&e, &["images.txt", "image id 1 appears twice"]);
    expect(&error(CAMERAS, "# nothing\n"), &["images.txt", "no images"]);
    let e = error(CAMERAS, "1 0 0 0 0 0 0 0 1 a.jpg\n\n");
    expect(&e, &["images.txt", "image 1 (a.jpg)", "quaternion"]);
    let e = error(CAMERAS, "1 1 0 0 x 0 0 0 1 a.jpg\n\n");
    expect(&e, &["images.txt", "line 1", "`x`"]);
    let tmp = Temp::new();
    let dir = tmp.0.join("sparse/0");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("cameras.txt"), CAMERAS).unwrap();
    assert_eq!(find_model(&tmp.0), None);
    expect(
        &read_model(&tmp.0, &dir).unwrap_err().to_string(),
        &["images.txt", "missing"],
    );
}

#[test]
fn truncated_and_unsupported_binary_models_are_refused() {
    let tmp = Temp::new();
    let dir = tmp.0.join("sparse/0");
    write_model(&dir, &cameras()[..2], false).unwrap();
    let (cams, imgs) = (dir.join("cameras.bin"), dir.join("images.bin"));
    let error = || read_model(&tmp.0, &dir).unwrap_err().to_string();
    let good_imgs = std::fs::read(&imgs).unwrap();
    let n = good_imgs.len();
    std::fs::write(&imgs, &good_imgs[..n - 5]).unwrap();
    expect(
        &error(),
        &["images.bin", &format!("truncated at byte {}", n - 8)],
    );
    // The second image's name without its NUL.
    std::fs::write(&imgs, &good_imgs[..n - 9]).unwrap();
    expect(
        &error(),
        &["images.bin", "truncated at byte", "an image name"],
    );
    std::fs::write(&imgs, &good_imgs).unwrap();
    let good_cams = std::fs::read(&cams).unwrap();
    let mut bad = good_cams.clone();
    bad[12..16].copy_from_slice(&9i32.to_le_bytes());
    std::fs::write(&cams, &bad).unwrap();
    expect(
        &error(),
        &[
            "cameras.bin",
            "camera 1",
            "RADIAL_FISHEYE",
            "image_undistorter",
        ],
    );
    std::fs::write(&cams, &good_cams[..20]).unwrap();
    expect(&error(), &["cameras.bin", "truncated at byte 16"]);
}
