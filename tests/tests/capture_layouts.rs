//! Captures as users store them: one generated scene written in FIPT's real layout, a COLMAP
//! model (text and binary) and a nerfstudio `transforms.json` reads back as the same cameras
//! and pixels; views rendered through a lens trace back through it; a downscale averages
//! blocks and scales the intrinsics exactly; masks are read at the run's size.
use fipt_core::camera::Camera;
use fipt_core::capture_layout::OpenOptions;
use fipt_core::dataset::{write_cam_list, Dataset, Layout};
use fipt_core::distortion::Distortion;
use fipt_core::image::BadPixelPolicy;
use fipt_geom::{BuildQuality, Bvh, Mesh};
use fipt_shading::render::RenderConfig;
use fipt_synth::{build, write_dataset, SynthOptions};
use fipt_tests::temp_dir;
use std::path::Path;

fn tiny_cornell(dir: &Path, lens: Distortion, (w, h): (usize, usize)) {
    let opts = SynthOptions {
        train_views: 4,
        val_views: 1,
        width: w,
        height: h,
        render: RenderConfig {
            spp: 4,
            ..Default::default()
        },
        model: Default::default(),
        lens,
    };
    write_dataset(build("cornell").unwrap(), dir, &opts, &|_, _| {}).unwrap();
}

/// Copies the synthetic scene's training views into `dst/images/` (for the capture layouts)
/// or `dst/Image/` (the real layout) and its mesh; returns the views' cameras and names.
fn copy_views(src: &Dataset, dst: &Path, folder: &str) -> Vec<(String, Camera)> {
    std::fs::create_dir_all(dst.join(folder)).unwrap();
    std::fs::copy(&src.mesh, dst.join("scene.obj")).unwrap();
    src.train()
        .views
        .iter()
        .map(|v| {
            let name = v.image.file_name().unwrap().to_string_lossy().into_owned();
            std::fs::copy(&v.image, dst.join(folder).join(&name)).unwrap();
            (name, v.camera.clone())
        })
        .collect()
}

fn assert_same_views(a: &Dataset, b: &Dataset, what: &str) {
    assert_eq!(a.train().views.len(), b.train().views.len(), "{what}");
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}");
    for (va, vb) in a.train().views.iter().zip(&b.train().views) {
        for (i, j) in [
            (0, 0),
            (a.width - 1, a.height - 1),
            (a.width / 2, 3),
            (5, a.height - 2),
        ] {
            let (oa, da) = va.camera.pixel_center_ray(i, j);
            let (ob, db) = vb.camera.pixel_center_ray(i, j);
            assert!(
                (oa - ob).length() < 1e-5 && (da - db).length() < 1e-5,
                "{what}: view {} pixel ({i},{j}): {oa} {da} vs {ob} {db}",
                va.index
            );
        }
        let ia = a.load_image(va, BadPixelPolicy::Reject).unwrap().0;
        let ib = b.load_image(vb, BadPixelPolicy::Reject).unwrap().0;
        assert_eq!(ia.data, ib.data, "{what}: view {}", va.index);
    }
}

#[test]
fn one_capture_in_four_layouts_reads_as_the_same_cameras_and_pixels() {
    let dir = temp_dir("layouts");
    let src_dir = dir.join("src");
    tiny_cornell(&src_dir, Distortion::None, (24, 18));
    let src = Dataset::open(&src_dir).unwrap();

    let real = dir.join("real");
    let views = copy_views(&src, &real, "Image");
    let cams: Vec<Camera> = views.iter().map(|v| v.1.clone()).collect();
    write_cam_list(&real.join("cam.txt"), &real.join("K_list.txt"), &cams).unwrap();
    let real_ds = Dataset::open(&real).unwrap();
    assert_eq!(real_ds.layout, Layout::Real);
    assert_same_views(&src, &real_ds, "real");

    for text in [true, false] {
        let d = dir.join(if text { "colmap-text" } else { "colmap-bin" });
        let views = copy_views(&src, &d, "images");
        std::fs::create_dir_all(d.join("sparse/0")).unwrap();
        fipt_core::colmap::write_model(&d.join("sparse/0"), &views, text).unwrap();
        let ds = Dataset::open(&d).unwrap();
        assert_eq!(ds.layout, Layout::Colmap);
        assert!(ds
            .cameras_description
            .as_deref()
            .unwrap()
            .contains("COLMAP"));
        assert_same_views(
            &src,
            &ds,
            if text { "COLMAP text" } else { "COLMAP binary" },
        );
    }

    let ns = dir.join("nerfstudio");
    let views = copy_views(&src, &ns, "images");
    let frames: Vec<(String, Camera, Option<String>)> = views
        .into_iter()
        .map(|(n, c)| (format!("images/{n}"), c, None))
        .collect();
    fipt_core::nerfstudio::write(&ns.join("transforms.json"), &frames).unwrap();
    let ds = Dataset::open(&ns).unwrap();
    assert_eq!(ds.layout, Layout::Nerfstudio);
    assert_same_views(&src, &ds, "nerfstudio");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_nerfstudio_file_in_fipts_place_is_refused_with_the_fix() {
    let dir = temp_dir("ns-in-fipt");
    tiny_cornell(&dir, Distortion::None, (16, 12));
    let ds = Dataset::open(&dir).unwrap();
    let frames: Vec<(String, Camera, Option<String>)> = ds
        .train()
        .views
        .iter()
        .map(|v| {
            (
                format!("Image/{:03}_0001.exr", v.index),
                v.camera.clone(),
                None,
            )
        })
        .collect();
    fipt_core::nerfstudio::write(&dir.join("train/transforms.json"), &frames).unwrap();
    let err = Dataset::open(&dir).unwrap_err().to_string();
    assert!(
        err.contains("train/transforms.json") && err.contains("nerfstudio"),
        "{err}"
    );
    assert!(err.contains("scene's root"), "the fix: {err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every pixel of a view rendered through `lens` sees the surface point that projects back
/// through the lens onto its centre, and sees what the pinhole view of the same pose sees at
/// that point (ground-truth kd, no noise).
fn lensed_render_round_trips(lens: Distortion, name: &str) {
    let dir = temp_dir(name);
    let (lensed, pinhole) = (dir.join("lensed"), dir.join("pinhole"));
    tiny_cornell(&lensed, lens, (48, 36));
    tiny_cornell(&pinhole, Distortion::None, (48, 36));
    let (a, b) = (
        Dataset::open(&lensed).unwrap(),
        Dataset::open(&pinhole).unwrap(),
    );
    let mesh = Mesh::load(&a.mesh).unwrap();
    let bvh = Bvh::build(&mesh, BuildQuality::Medium);
    let (mut agree, mut total) = (0usize, 0usize);
    for (va, vb) in a.train().views.iter().zip(&b.train().views) {
        assert_eq!(va.camera.distortion, lens);
        let ka = a
            .load_gt(a.train(), fipt_core::dataset::GtKind::DiffCol, va.index)
            .unwrap()
            .unwrap();
        let kb = b
            .load_gt(b.train(), fipt_core::dataset::GtKind::DiffCol, vb.index)
            .unwrap()
            .unwrap();
        for j in 0..a.height {
            for i in 0..a.width {
                let (o, d) = va.camera.pixel_center_ray(i, j);
                let Some(hit) = bvh.closest_hit(o, d, 0.0, f32::INFINITY) else {
                    continue;
                };
                let p = va.camera.project(o + d * hit.t).unwrap();
                let centre = glam::Vec2::new(i as f32 + 0.5, j as f32 + 0.5);
                assert!(
                    (p - centre).length() < 2e-3,
                    "{name}: pixel ({i},{j}) projects to {p}"
                );
                // The pinhole view of the same pose sees the point at q.
                let Some(q) = vb.camera.project(o + d * hit.t) else {
                    continue;
                };
                let (x, y) = (q.x.floor() as i64, q.y.floor() as i64);
                if x < 0 || y < 0 || x >= b.width as i64 || y >= b.height as i64 {
                    continue;
                }
                total += 1;
                let (ca, cb) = (ka.get(i, j), kb.get(x as usize, y as usize));
                if (ca - cb).abs().max_element() < 1e-3 {
                    agree += 1;
                }
            }
        }
    }
    // Pixels on material edges may fall on the other side in the other view.
    assert!(
        total > 1000 && agree as f64 > 0.9 * total as f64,
        "{name}: {agree} of {total} pixels agree"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn views_rendered_through_a_brown_conrady_lens_trace_back_through_it() {
    lensed_render_round_trips(
        Distortion::Opencv {
            k1: -0.12,
            k2: 0.0,
            k3: 0.0,
            p1: 0.0,
            p2: 0.0,
        },
        "lens-opencv",
    );
}

#[test]
fn views_rendered_through_a_fisheye_trace_back_through_it() {
    lensed_render_round_trips(
        Distortion::Fisheye {
            k1: 0.05,
            k2: -0.01,
            k3: 0.0,
            k4: 0.0,
        },
        "lens-fisheye",
    );
}

#[test]
fn a_downscale_averages_blocks_and_scales_the_intrinsics_exactly() {
    let dir = temp_dir("downscale");
    tiny_cornell(&dir, Distortion::None, (26, 18));
    let full = Dataset::open(&dir).unwrap();
    let half = Dataset::open_with(&dir, OpenOptions { downscale: 2 }).unwrap();
    assert_eq!((half.width, half.height, half.downscale), (13, 9, 2));
    for (vf, vh) in full.train().views.iter().zip(&half.train().views) {
        // Pixel (i, j) of the half view is the 2×2 block whose corner is (2i, 2j): its centre
        // ray is the full view's ray through (2i + 1, 2j + 1).
        for (i, j) in [(0, 0), (12, 8), (6, 4)] {
            let (_, dh) = vh.camera.pixel_center_ray(i, j);
            let (_, df) = vf.camera.ray(2.0 * i as f32 + 1.0, 2.0 * j as f32 + 1.0);
            assert!((dh - df).length() < 1e-6);
        }
        let f = full.load_image(vf, BadPixelPolicy::Reject).unwrap().0;
        let h = half.load_image(vh, BadPixelPolicy::Reject).unwrap().0;
        let block = (f.get(10, 6) + f.get(11, 6) + f.get(10, 7) + f.get(11, 7)) / 4.0;
        assert!((h.get(5, 3) - block).abs().max_element() < 1e-6);
        // Ground truth shrinks with the views: part ids are taken, not averaged.
        let ids = half
            .load_ids(half.train(), fipt_core::dataset::GtKind::IndexMA, vh.index)
            .unwrap()
            .unwrap();
        assert_eq!(ids.len(), 13 * 9);
    }
    let err = Dataset::open_with(&dir, OpenOptions { downscale: 5 })
        .unwrap_err()
        .to_string();
    assert!(err.contains("downscale of 5"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_views_mask_is_read_at_the_runs_size_and_a_wrong_size_named() {
    let dir = temp_dir("masks");
    tiny_cornell(&dir, Distortion::None, (16, 12));
    std::fs::create_dir_all(dir.join("train/Mask")).unwrap();
    // View 1: its left half left out.
    let mask = image::GrayImage::from_fn(16, 12, |x, _| image::Luma([if x < 8 { 0 } else { 255 }]));
    mask.save(dir.join("train/Mask/001_0001.png")).unwrap();
    let ds = Dataset::open(&dir).unwrap();
    let v = &ds.train().views;
    assert!(v[0].mask.is_none() && v[1].mask.is_some());
    let keep = ds.load_mask(&v[1]).unwrap().unwrap();
    assert_eq!(keep.iter().filter(|k| !**k).count(), 8 * 12);
    let half = Dataset::open_with(&dir, OpenOptions { downscale: 2 }).unwrap();
    let keep = half.load_mask(&half.train().views[1]).unwrap().unwrap();
    assert_eq!(
        (keep.len(), keep.iter().filter(|k| !**k).count()),
        (48, 4 * 6)
    );
    // A size the factor does not divide: the remainder is cropped, the mask still read.
    let fifth = Dataset::open_with(&dir, OpenOptions { downscale: 3 }).unwrap();
    let keep = fifth.load_mask(&fifth.train().views[1]).unwrap().unwrap();
    assert_eq!(keep.len(), 5 * 4);
    image::GrayImage::new(8, 8)
        .save(dir.join("train/Mask/001_0001.png"))
        .unwrap();
    let err = ds.load_mask(&v[1]).unwrap_err().to_string();
    assert!(
        err.contains("001_0001.png") && err.contains("size of its view"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_truncated_jpeg_is_named_as_a_damaged_image_not_an_exr() {
    let dir = temp_dir("truncated-jpeg");
    let p = dir.join("view.jpg");
    image::RgbImage::from_fn(64, 48, |x, y| {
        image::Rgb([(x * 4) as u8, (y * 5) as u8, 90])
    })
    .save(&p)
    .unwrap();
    let bytes = std::fs::read(&p).unwrap();
    std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    let err = fipt_core::capture::read_ldr(&p, &Default::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("view.jpg") && err.contains("cannot read the image"),
        "{err}"
    );
    assert!(!err.contains("EXR:"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn fipts_own_transforms_json_at_the_root_is_refused_with_the_fix() {
    let dir = temp_dir("fipt-at-root");
    tiny_cornell(&dir, Distortion::None, (16, 12));
    let ds = Dataset::open(&dir).unwrap();
    let root = dir.join("moved");
    let views = copy_views(&ds, &root, "Image");
    let cams: Vec<Camera> = views.into_iter().map(|v| v.1).collect();
    fipt_core::dataset::write_transforms(&root.join("transforms.json"), &cams).unwrap();
    let err = Dataset::open(&root).unwrap_err().to_string();
    assert!(
        err.contains("FIPT's synthetic-layout") && err.contains("put it in train/"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
