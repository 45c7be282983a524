//! The `fipt` binary as a user runs it.
use std::path::PathBuf;
use std::process::Command;

fn fipt(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_fipt")).args(args).output().expect("run fipt");
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fipt-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn synth_info_render_round_trip() {
    let dir = tmp("scene");
    let d = dir.to_str().unwrap();
    let (ok, _, err) = fipt(&["synth", "cornell", "--out", d, "--views", "3", "--val-views", "1", "--width", "24", "--height", "16", "--spp", "4"]);
    assert!(ok, "{err}");
    // A second synth into the same folder refuses to overwrite.
    let (ok, _, err) = fipt(&["synth", "cornell", "--out", d]);
    assert!(!ok && err.contains("not empty") && err.contains("--force"), "{err}");
    let (ok, out, err) = fipt(&["info", d, "--json"]);
    assert!(ok, "{err}");
    assert!(out.contains("3 views at 24x16") && out.contains("DiffCol") && out.contains("warnings     none"), "{out}");
    // Re-render view 1 with the scene's own table and cameras: same GT maps, bit for bit.
    let out_dir = tmp("render");
    let o = out_dir.to_str().unwrap();
    let (ok, _, err) = fipt(&[
        "render", d, "--materials", &format!("{d}/scene_gt.json"), "--cameras", &format!("{d}/train/transforms.json"), "--out", o, "--spp", "4", "--views", "1",
    ]);
    assert!(ok, "{err}");
    for f in ["DiffCol/001_0001.exr", "Roughness/001_0001.exr", "Emit/001_0001.exr", "IndexMA/001_0001.exr"] {
        let a = fipt_core::image::Image::read_exr(&dir.join("train").join(f)).unwrap();
        let b = fipt_core::image::Image::read_exr(&out_dir.join(f)).unwrap();
        assert_eq!(a, b, "{f}");
    }
    assert!(out_dir.join("Image/001_0001.exr").is_file() && out_dir.join("preview/001.png").is_file());
    // Bad input: a missing image is named.
    std::fs::remove_file(dir.join("train/Image/002_0001.exr")).unwrap();
    let (ok, _, err) = fipt(&["info", d]);
    assert!(!ok && err.contains("002_0001.exr"), "{err}");
    let (ok, _, err) = fipt(&["synth", "kitchen", "--out", o]);
    assert!(!ok && err.contains("unknown scene") && err.contains("room"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
    std::fs::remove_dir_all(&out_dir).ok();
}
