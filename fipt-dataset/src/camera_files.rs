//! FIPT's real layout's camera files (`cam.txt`, `K_list.txt`) read and written, and its
//! synthetic layout's `transforms.json` written (read by [`crate::dataset::read_transforms`]).
use crate::camera::Camera;
use crate::dataset::{check_pose, image_file_name};
use crate::error::{CoreError, Result};
use glam::Vec3;
use std::path::Path;

fn numbers(path: &Path) -> Result<Vec<f32>> {
    let text = std::fs::read_to_string(path).map_err(|e| CoreError::io(path, e))?;
    text.split_whitespace()
        .map(|t| {
            t.parse::<f32>()
                .map_err(|_| CoreError::invalid(path, format!("`{t}` is not a number")))
        })
        .collect()
}

/// Reads cameras of the real layout: `cam.txt` (N, then origin, look-at and up per camera)
/// and `K_list.txt` (N, then a 3×3 intrinsic matrix per camera), for images of `w`×`h`.
pub fn read_cam_list(cam_path: &Path, k_path: &Path, w: usize, h: usize) -> Result<Vec<Camera>> {
    let c = numbers(cam_path)?;
    let k = numbers(k_path)?;
    let n = c.first().copied().unwrap_or(0.0) as usize;
    if c.len() != 1 + 9 * n {
        return Err(CoreError::invalid(cam_path, format!("expected N then 3 lines of 3 numbers per camera (origin, look-at, up): {} numbers for N = {n}", c.len())));
    }
    let nk = k.first().copied().unwrap_or(0.0) as usize;
    if nk != n || k.len() != 1 + 9 * n {
        return Err(CoreError::invalid(
            k_path,
            format!(
                "expected {n} 3x3 matrices (N = {n} in cam.txt), found N = {nk} and {} numbers",
                k.len()
            ),
        ));
    }
    let mut cams = Vec::with_capacity(n);
    for i in 0..n {
        let v = |j: usize| {
            Vec3::new(
                c[1 + 9 * i + 3 * j],
                c[2 + 9 * i + 3 * j],
                c[3 + 9 * i + 3 * j],
            )
        };
        let (o, t, up) = (v(0), v(1), v(2));
        if (t - o).length() < 1e-9 {
            return Err(CoreError::invalid(
                cam_path,
                format!("camera {i}: look-at point equals the origin"),
            ));
        }
        if up.length() < 1e-9 || (t - o).normalize().cross(up.normalize()).length() < 1e-3 {
            return Err(CoreError::invalid(
                cam_path,
                format!("camera {i}: the up vector {up} is zero or along the view direction (look-at − origin = {}), so the image's orientation is undefined: give a direction across the view (the world's up for a level camera)", t - o),
            ));
        }
        let km = &k[1 + 9 * i..1 + 9 * (i + 1)];
        let kk = [
            [km[0], km[1], km[2]],
            [km[3], km[4], km[5]],
            [km[6], km[7], km[8]],
        ];
        if !(kk[0][0] > 0.0 && kk[1][1] > 0.0) || (kk[2][2] - 1.0).abs() > 1e-4 {
            return Err(CoreError::invalid(
                k_path,
                format!(
                    "camera {i}: K = {kk:?} is not an intrinsic matrix (fx, fy > 0, K[2][2] = 1)"
                ),
            ));
        }
        let cam = Camera::from_opencv(o, t, up, kk, w, h);
        check_pose(cam_path, i, &cam)?;
        cams.push(cam);
    }
    Ok(cams)
}

/// Writes a `transforms.json` for `cameras` (Mitsuba convention), atomically.
pub fn write_transforms(path: &Path, cameras: &[Camera]) -> Result<()> {
    let first = cameras
        .first()
        .ok_or_else(|| CoreError::invalid(path, "no cameras to write"))?;
    let frames: Vec<serde_json::Value> = cameras
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let m = c.to_mitsuba_matrix().transpose().to_cols_array_2d();
            serde_json::json!({ "file_path": format!("Image/{}", image_file_name(k)), "transform_matrix": m })
        })
        .collect();
    let mut v = serde_json::json!({
        "camera_angle_x": first.fov_x(),
        "width": first.width,
        "height": first.height,
        "camera_convention": "Mitsuba camera-to-world: +X = image left, +Y = up, +Z = forward",
        "frames": frames,
    });
    if !first.distortion.is_none() {
        if cameras.iter().any(|c| c.distortion != first.distortion) {
            return Err(CoreError::invalid(
                path,
                "transforms.json holds one lens for all views: these cameras have several",
            ));
        }
        v["distortion"] = serde_json::to_value(first.distortion)
            .map_err(|e| CoreError::invalid(path, e.to_string()))?;
    }
    crate::fsutil::write_json_atomic(path, &v)
}

/// Writes the real layout's `cam.txt` (N, then origin, look-at and up per camera) and
/// `K_list.txt` (N, then K per camera) for `cameras`, atomically.
pub fn write_cam_list(cam_path: &Path, k_path: &Path, cameras: &[Camera]) -> Result<()> {
    let mut cam = format!("{}\n", cameras.len());
    let mut ks = cam.clone();
    let row = |v: Vec3| format!("{} {} {}\n", v.x, v.y, v.z);
    for c in cameras {
        let (o, t, up, k) = c.to_opencv_lookat();
        cam += &(row(o) + &row(t) + &row(up));
        for r in k {
            ks += &row(Vec3::from_array(r));
        }
    }
    crate::fsutil::write_bytes_atomic(cam_path, cam.as_bytes())?;
    crate::fsutil::write_bytes_atomic(k_path, ks.as_bytes())
}
