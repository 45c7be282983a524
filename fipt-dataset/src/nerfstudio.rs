//! nerfstudio / instant-ngp `transforms.json`, read as [`CaptureCameras`] (and written).
//!
//! Poses are 4×4 camera-to-world matrices in the OpenGL camera axes (+X right, +Y up, +Z
//! backward: the camera looks along −Z); they are read into the OpenCV axes,
//! R_cv = R_gl · diag(1, −1, −1), as [`PoseConvention::OpenCv`] cameras. Intrinsics (`fl_x`,
//! `fl_y`, `cx`, `cy`, `w`, `h`, the lens coefficients, `camera_model`) may be given for the
//! whole file and per frame; a frame's own keys override the file's, key by key.
//! instant-ngp's `camera_angle_x` (and `camera_angle_y`) stand in for a missing `fl_x`, and
//! the first image's size for missing `w` / `h`. Principal points are in our pixel
//! convention (the top-left pixel's centre at (0.5, 0.5)) and taken as they are.
//!
//! This is not FIPT's own `transforms.json` (Mitsuba axes, `camera_angle_x`, `width`,
//! `height`: [`crate::dataset::read_transforms`]); [`looks_like_nerfstudio`] tells them apart.
use crate::camera::{rotation_error, Camera, PoseConvention};
use crate::capture_layout::{CaptureCameras, CaptureView};
use crate::dataset::IMAGE_EXTENSIONS;
use crate::distortion::Distortion;
use crate::error::{CoreError, Result};
use glam::{Mat3, Mat4, Vec3, Vec4};
use serde_json::{Map, Value};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// OpenGL camera axes ↔ OpenCV ones: R_cv = R_gl · diag(1, −1, −1) (its own inverse).
const GL_TO_CV: Mat3 = Mat3::from_cols(Vec3::X, Vec3::NEG_Y, Vec3::NEG_Z);
/// Mitsuba camera axes → OpenCV ones: R_cv = R_mi · diag(−1, −1, 1).
const MI_TO_CV: Mat3 = Mat3::from_cols(Vec3::NEG_X, Vec3::NEG_Y, Vec3::Z);
/// The keys a camera is read from, at the top level or in a frame.
#[rustfmt::skip]
const INTRINSIC_KEYS: [&str; 16] = [
    "camera_model", "fl_x", "fl_y", "cx", "cy", "w", "h", "k1", "k2", "k3", "k4", "p1", "p2",
    "camera_angle_x", "camera_angle_y", "is_fisheye",
];
/// The other keys read at the top level and in frames.
const TOP_KEYS: [&str; 2] = ["frames", "applied_transform"];
const FRAME_KEYS: [&str; 3] = ["file_path", "transform_matrix", "mask_path"];
/// Top-level keys a nerfstudio / instant-ngp file has and FIPT's does not.
#[rustfmt::skip]
const MARKERS: [&str; 8] =
    ["fl_x", "fl_y", "camera_model", "w", "h", "k1", "applied_transform", "aabb_scale"];
const OPENGL: &str = "OpenGL camera-to-world: +X right, +Y up, looking along −Z";

/// Whether the `transforms.json` at `path` is a nerfstudio / instant-ngp file (it has any of
/// fl_x, fl_y, camera_model, w, h, k1, applied_transform, aabb_scale, or frames with their
/// own fl_x) rather than FIPT's Mitsuba-convention one (camera_angle_x, width / height,
/// frames with transform_matrix only): the reason, for messages ("it has fl_x, w, h"), or
/// None. Errors only when the file is not readable JSON.
pub fn looks_like_nerfstudio(path: &Path) -> Result<Option<String>> {
    let json: Value = crate::fsutil::read_json(path)?;
    let Some(top) = json.as_object() else {
        return Ok(None);
    };
    let mut found: Vec<String> = MARKERS
        .iter()
        .filter(|k| top.contains_key(**k))
        .map(|k| k.to_string())
        .collect();
    let frames = top.get("frames").and_then(Value::as_array);
    if frames.is_some_and(|f| f.iter().any(|f| f.get("fl_x").is_some())) {
        found.push("frames with their own fl_x".into());
    }
    Ok((!found.is_empty()).then(|| format!("it has {}", found.join(", "))))
}

/// Reads a nerfstudio / instant-ngp `transforms.json`: one view per frame, in the listed
/// order, cameras in [`PoseConvention::OpenCv`]; images (`file_path`; when no file has that
/// name, as with instant-ngp's bare "./train/r_0", the first of [`IMAGE_EXTENSIONS`] added
/// that exists) and masks (`mask_path`: 0 = leave out) relative to the file's folder.
/// Errors name the file, the frame and the fix.
pub fn read(path: &Path) -> Result<CaptureCameras> {
    let json: Value = crate::fsutil::read_json(path)?;
    let top = json.as_object().ok_or_else(|| {
        CoreError::invalid(path, "not a JSON object: expected {\"frames\": [...], ...}")
    })?;
    let frames = match top.get("frames") {
        Some(Value::Array(f)) if !f.is_empty() => f,
        _ => {
            return Err(CoreError::invalid(
                path,
                "no frames: a transforms.json needs a non-empty \"frames\" list \
                 (each with file_path and transform_matrix)",
            ))
        }
    };
    let mut ctx = Ctx {
        path,
        dir: path.parent().unwrap_or(Path::new("")).to_path_buf(),
        top,
        first_image: None,
        first_size: None,
        notes: BTreeSet::new(),
    };
    let mut views = Vec::with_capacity(frames.len());
    let mut models = Vec::with_capacity(frames.len());
    for (k, frame) in frames.iter().enumerate() {
        let (view, model) = ctx.frame(k, frame)?;
        views.push(view);
        models.push(model);
    }
    let mut notes: Vec<String> = std::mem::take(&mut ctx.notes).into_iter().collect();
    if top.contains_key("applied_transform") {
        notes.push(
            "applied_transform is present: poses are in the frame after applied_transform: \
             the mesh must be in that frame too"
                .into(),
        );
    }
    let masks = views.iter().filter(|v| v.mask.is_some()).count();
    if masks > 0 && masks < views.len() {
        notes.push(format!(
            "mask_path is given for {masks} of {} frames: the others keep all their pixels",
            views.len()
        ));
    }
    notes.extend(ignored_keys(top, frames));
    Ok(CaptureCameras {
        description: describe(top, &views, &models, masks),
        views,
        cameras_file: path.to_path_buf(),
        files: vec![path.to_path_buf()],
        notes,
    })
}

/// Writes a nerfstudio `transforms.json` atomically: `camera_model` from the lenses
/// (PINHOLE when none has one, OPENCV_FISHEYE when all are fisheyes, else OPENCV), the
/// intrinsics at the top level when every camera shares them, else in each frame; frames
/// with `file_path` = the given name, `mask_path` when given, and `transform_matrix` the
/// OpenGL camera-to-world pose. Cameras may be in either convention.
pub fn write(path: &Path, views: &[(String, Camera, Option<String>)]) -> Result<()> {
    let Some((_, first, _)) = views.first() else {
        return Err(CoreError::invalid(path, "no views to write"));
    };
    let fisheyes = views
        .iter()
        .filter(|(_, c, _)| matches!(c.distortion, Distortion::Fisheye { .. }))
        .count();
    let camera_model = if fisheyes == views.len() {
        "OPENCV_FISHEYE"
    } else if fisheyes > 0 {
        return Err(CoreError::invalid(
            path,
            format!(
                "{fisheyes} of {} cameras are fisheyes and the others not: one transforms.json \
                 has one camera_model; write them to separate files",
                views.len()
            ),
        ));
    } else if views.iter().all(|(_, c, _)| c.distortion.is_none()) {
        "PINHOLE"
    } else {
        "OPENCV"
    };
    let shared = views.iter().all(|(_, c, _)| same_intrinsics(c, first));
    let file = FileOut {
        camera_model,
        intrinsics: shared.then(|| IntrinsicsOut::of(first)),
        frames: views
            .iter()
            .map(|(name, cam, mask)| FrameOut {
                file_path: name.clone(),
                mask_path: mask.clone(),
                intrinsics: (!shared).then(|| IntrinsicsOut::of(cam)),
                transform_matrix: gl_matrix(cam),
            })
            .collect(),
    };
    crate::fsutil::write_json_atomic(path, &file)
}

/// What reading a file keeps between frames.
struct Ctx<'a> {
    path: &'a Path,
    /// The folder images and masks are relative to.
    dir: PathBuf,
    top: &'a Map<String, Value>,
    /// The first frame's image, whose size stands in for missing `w` / `h`.
    first_image: Option<PathBuf>,
    first_size: Option<(usize, usize)>,
    /// Notes on how the lenses were read (one each, however many frames).
    notes: BTreeSet<String>,
}

impl Ctx<'_> {
    /// Frame `k`'s view and the camera model it was read as.
    fn frame(&mut self, k: usize, frame: &Value) -> Result<(CaptureView, &'static str)> {
        let f = frame.as_object().ok_or_else(|| {
            CoreError::invalid(self.path, format!("frame {k} is not a JSON object"))
        })?;
        let name = match f.get("file_path") {
            Some(Value::String(s)) => s.clone(),
            _ => {
                return Err(CoreError::invalid(
                    self.path,
                    format!(
                        "frame {k} has no file_path: give each frame its image, \
                         relative to the folder of this file"
                    ),
                ))
            }
        };
        let image = image_path(&self.dir, &name);
        if k == 0 {
            self.first_image = Some(image.clone());
        }
        let keys = Keys {
            frame: f,
            top: self.top,
            path: self.path,
            k,
            name: &name,
        };
        let (rotation, origin) = pose(&keys)?;
        let (width, height) = self.size(&keys)?;
        let [fx, fy, cx, cy] = focal(&keys, width, height)?;
        let (model, distortion) = lens(&keys, &mut self.notes)?;
        let camera = Camera {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            convention: PoseConvention::OpenCv,
            rotation,
            origin,
            distortion,
        };
        if let Some(why) = camera.distortion.check(camera.max_normalised_radius()) {
            return Err(keys.frame_err(why));
        }
        let mask = match f.get("mask_path") {
            None | Some(Value::Null) => None,
            Some(Value::String(m)) => Some(self.dir.join(m.strip_prefix("./").unwrap_or(m))),
            Some(v) => return Err(keys.frame_err(format!("mask_path = {v} is not a path"))),
        };
        let view = CaptureView {
            camera,
            image,
            mask,
            name,
        };
        Ok((view, model))
    }

    /// The frame's `w` and `h`; those missing from the first image's header.
    fn size(&mut self, keys: &Keys) -> Result<(usize, usize)> {
        let (w, h) = (keys.pixels("w")?, keys.pixels("h")?);
        if let (Some(w), Some(h)) = (w, h) {
            return Ok((w, h));
        }
        let (iw, ih) = match self.first_size {
            Some(s) => s,
            None => {
                let img = self.first_image.clone().unwrap_or_default();
                if !img.is_file() {
                    return Err(keys.frame_err(format!(
                        "no w and h keys, and the first image {} (to take the size from) is \
                         missing: add \"w\" and \"h\" (pixels) to the file, or put the images \
                         where file_path says",
                        img.display()
                    )));
                }
                let s = crate::dataset::image_size(&img)?;
                self.first_size = Some(s);
                s
            }
        };
        Ok((w.unwrap_or(iw), h.unwrap_or(ih)))
    }
}

/// One frame's keys: its own first, then the file's.
struct Keys<'a> {
    frame: &'a Map<String, Value>,
    top: &'a Map<String, Value>,
    path: &'a Path,
    k: usize,
    name: &'a str,
}

impl Keys<'_> {
    fn get(&self, key: &str) -> Option<&Value> {
        self.frame
            .get(key)
            .or_else(|| self.top.get(key))
            .filter(|v| !v.is_null())
    }

    /// An error naming the file and the frame.
    fn frame_err(&self, msg: impl std::fmt::Display) -> CoreError {
        CoreError::invalid(
            self.path,
            format!("frame {} ({}): {msg}", self.k, self.name),
        )
    }

    /// An error about `key`: naming the frame when the frame gave it, else the file only.
    fn key_err(&self, key: &str, msg: impl std::fmt::Display) -> CoreError {
        if self.frame.contains_key(key) {
            self.frame_err(msg)
        } else {
            CoreError::invalid(self.path, msg.to_string())
        }
    }

    /// A finite number, when the key is given.
    fn num(&self, key: &str) -> Result<Option<f64>> {
        match self.get(key) {
            None => Ok(None),
            Some(v) => v
                .as_f64()
                .filter(|x| x.is_finite())
                .map(Some)
                .ok_or_else(|| self.key_err(key, format!("{key} = {v} is not a number"))),
        }
    }

    /// A size in pixels (a positive whole number; instant-ngp writes 640.0).
    fn pixels(&self, key: &str) -> Result<Option<usize>> {
        match self.num(key)? {
            None => Ok(None),
            Some(v) if v >= 1.0 && (v - v.round()).abs() < 1e-6 => Ok(Some(v.round() as usize)),
            Some(v) => Err(self.key_err(
                key,
                format!("{key} = {v} is not a size in pixels (a positive whole number)"),
            )),
        }
    }

    /// A field of view in radians in (0, π), when given.
    fn angle(&self, key: &str) -> Result<Option<f64>> {
        match self.num(key)? {
            Some(a) if !(a > 0.0 && a < std::f64::consts::PI) => Err(self.key_err(
                key,
                format!("{key} = {a} is not a field of view in radians (0, π)"),
            )),
            a => Ok(a),
        }
    }
}

/// fx, fy, cx, cy of a `width`×`height` frame: `fl_x` (`fl_y` defaulting to it), else
/// instant-ngp's `camera_angle_x` (and `camera_angle_y`); the principal point defaulting
/// to the image centre.
fn focal(keys: &Keys, width: usize, height: usize) -> Result<[f32; 4]> {
    let from_angle = |a: f64, size: usize| 0.5 * size as f64 / (0.5 * a).tan();
    let (fx, fy) = match (keys.num("fl_x")?, keys.angle("camera_angle_x")?) {
        (Some(fx), _) => (fx, keys.num("fl_y")?.unwrap_or(fx)),
        (None, Some(ax)) => {
            let fx = from_angle(ax, width);
            let fy = match (keys.num("fl_y")?, keys.angle("camera_angle_y")?) {
                (Some(fy), _) => fy,
                (None, Some(ay)) => from_angle(ay, height),
                (None, None) => fx,
            };
            (fx, fy)
        }
        (None, None) => {
            return Err(keys.frame_err(
                "no focal length: add fl_x (and fl_y) in pixels, or camera_angle_x in radians",
            ))
        }
    };
    if !(fx > 0.0 && fy > 0.0) {
        return Err(keys.frame_err(format!(
            "the focal length (fl_x = {fx}, fl_y = {fy}) must be positive"
        )));
    }
    let cx = keys.num("cx")?.unwrap_or(0.5 * width as f64);
    let cy = keys.num("cy")?.unwrap_or(0.5 * height as f64);
    Ok([fx as f32, fy as f32, cx as f32, cy as f32])
}

/// The camera model a frame is read as and its lens: `camera_model` OPENCV (k1, k2, p1, p2,
/// k3), OPENCV_FISHEYE (k1..k4), PINHOLE; without one, instant-ngp's reading (`is_fisheye`,
/// else OPENCV when coefficients are given). Other models are refused with the fix.
fn lens(keys: &Keys, notes: &mut BTreeSet<String>) -> Result<(&'static str, Distortion)> {
    let mut c = [0f32; 6];
    for (v, key) in c.iter_mut().zip(["k1", "k2", "k3", "k4", "p1", "p2"]) {
        *v = keys.num(key)?.unwrap_or(0.0) as f32;
    }
    let [k1, k2, k3, k4, p1, p2] = c;
    let brown = || -> Result<(&'static str, Distortion)> {
        if k4 != 0.0 {
            return Err(keys.key_err(
                "k4",
                format!(
                    "k4 = {k4} is not part of the OPENCV model (k1, k2, p1, p2, k3): set it to 0, \
                     or set camera_model to OPENCV_FISHEYE if the lens is a fisheye"
                ),
            ));
        }
        let d = if [k1, k2, k3, p1, p2].iter().all(|v| *v == 0.0) {
            Distortion::None
        } else {
            Distortion::Opencv { k1, k2, k3, p1, p2 }
        };
        Ok(("OPENCV", d))
    };
    let fisheye = || -> Result<(&'static str, Distortion)> {
        if p1 != 0.0 || p2 != 0.0 {
            return Err(keys.frame_err(format!(
                "p1 = {p1}, p2 = {p2}: OPENCV_FISHEYE has no tangential terms; set them to 0"
            )));
        }
        Ok(("OPENCV_FISHEYE", Distortion::Fisheye { k1, k2, k3, k4 }))
    };
    let any = c.iter().any(|v| *v != 0.0);
    let model = match keys.get("camera_model") {
        None => None,
        Some(Value::String(m)) => Some(m.as_str()),
        Some(v) => {
            let msg = format!("camera_model = {v} is not a string");
            return Err(keys.key_err("camera_model", msg));
        }
    };
    let fisheye_flag = keys.get("is_fisheye").and_then(Value::as_bool) == Some(true);
    let note = |notes: &mut BTreeSet<String>, s: &str| notes.insert(s.to_string());
    match model {
        Some("OPENCV") => brown(),
        Some("OPENCV_FISHEYE") => fisheye(),
        Some("PINHOLE" | "SIMPLE_PINHOLE") if !any => Ok(("PINHOLE", Distortion::None)),
        Some(m @ ("PINHOLE" | "SIMPLE_PINHOLE")) => {
            note(notes, &format!("camera_model is {m} but distortion coefficients are given: read as OPENCV, as nerfstudio does"));
            brown()
        }
        None if fisheye_flag => {
            note(notes, "no camera_model and is_fisheye = true: read as OPENCV_FISHEYE (k1..k4), as instant-ngp does");
            fisheye()
        }
        None if any => {
            note(notes, "no camera_model but distortion coefficients are given: read as OPENCV (k1, k2, p1, p2, k3), as instant-ngp does");
            brown()
        }
        None => Ok(("PINHOLE", Distortion::None)),
        Some(other) => Err(unsupported_model(keys, other)),
    }
}

/// The error for a `camera_model` not read, with the fix.
fn unsupported_model(keys: &Keys, model: &str) -> CoreError {
    let msg = if model == "EQUIRECTANGULAR" {
        "camera_model EQUIRECTANGULAR (360° panoramas) is not read: FIPT needs perspective or \
         fisheye views; cut the panoramas into perspective ones (e.g. `ns-process-data images \
         --camera-type equirectangular --images-per-equirect 14`) and read that transforms.json"
            .to_string()
    } else {
        format!(
            "camera_model {model} is not read: FIPT reads PINHOLE, OPENCV and OPENCV_FISHEYE; \
             undistort the images to PINHOLE, or process the capture again with camera model \
             OPENCV (`ns-process-data --camera-type perspective`)"
        )
    };
    keys.key_err("camera_model", msg)
}

/// A frame's camera-to-world rotation (OpenCV axes) and centre, validated.
fn pose(keys: &Keys) -> Result<(Mat3, Vec3)> {
    let bad = || {
        keys.frame_err(
            "transform_matrix must be 4 rows of 4 finite numbers \
             (camera-to-world, OpenGL camera axes)",
        )
    };
    let rows = keys.frame.get("transform_matrix").and_then(Value::as_array);
    let rows = rows.filter(|r| r.len() == 4).ok_or_else(bad)?;
    let mut m = [[0f32; 4]; 4];
    for (i, row) in rows.iter().enumerate() {
        let row = row.as_array().filter(|r| r.len() == 4).ok_or_else(bad)?;
        for (j, v) in row.iter().enumerate() {
            m[i][j] = v.as_f64().filter(|x| x.is_finite()).ok_or_else(bad)? as f32;
        }
    }
    // JSON rows → glam columns.
    let c2w = Mat4::from_cols_array_2d(&m).transpose();
    let last = c2w.row(3);
    if (last - Vec4::W).abs().max_element() > 1e-4 {
        return Err(keys.frame_err(format!(
            "the last row of transform_matrix is {last}, expected [0, 0, 0, 1]: \
             give the camera-to-world pose as a 4×4 affine matrix"
        )));
    }
    let r_gl = Mat3::from_mat4(c2w);
    let (error, det) = rotation_error(r_gl);
    let orthonormal = error < 1e-3;
    if !(orthonormal && det > 0.0) {
        let why = if det < 0.0 && orthonormal {
            "the rotation is a reflection (one axis flipped): nerfstudio's transform_matrix is \
             camera-to-world in the OpenGL camera axes (+X right, +Y up, +Z backward); a pose \
             from another convention with one axis flipped gives this: convert it properly \
             (OpenCV → OpenGL flips both Y and Z)"
        } else {
            "expected a rigid camera-to-world transform (orthonormal rotation, no scale or \
             shear): scale a scene through the translations only"
        };
        return Err(CoreError::BadPose {
            path: keys.path.to_path_buf(),
            frame: keys.k,
            error,
            det,
            hint: format!("file_path {}: {why}", keys.name),
        });
    }
    Ok((r_gl * GL_TO_CV, c2w.w_axis.truncate()))
}

/// The image a `file_path` names, relative to `dir`; without an extension (instant-ngp,
/// NeRF-synthetic: "./train/r_0") the first of [`IMAGE_EXTENSIONS`] that exists.
fn image_path(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name.strip_prefix("./").unwrap_or(name));
    if p.is_file() {
        return p;
    }
    IMAGE_EXTENSIONS
        .iter()
        .map(|e| {
            let mut s = p.clone().into_os_string();
            s.push(format!(".{e}"));
            PathBuf::from(s)
        })
        .find(|c| c.is_file())
        .unwrap_or(p)
}

/// One note listing the keys not read, if any ("frames[].sharpness" for a frame's).
fn ignored_keys(top: &Map<String, Value>, frames: &[Value]) -> Option<String> {
    let known = |k: &str, own: &[&str]| own.contains(&k) || INTRINSIC_KEYS.contains(&k);
    let mut out: BTreeSet<String> = top
        .keys()
        .filter(|k| !known(k, &TOP_KEYS))
        .cloned()
        .collect();
    for f in frames.iter().filter_map(Value::as_object) {
        for k in f.keys().filter(|k| !known(k, &FRAME_KEYS)) {
            out.insert(format!("frames[].{k}"));
        }
    }
    let list: Vec<String> = out.into_iter().collect();
    (!list.is_empty()).then(|| format!("keys not read (ignored): {}", list.join(", ")))
}

/// "nerfstudio transforms.json (OpenGL …): 40 frames, OPENCV k1 = -0.120, masks for 12".
fn describe(
    top: &Map<String, Value>,
    views: &[CaptureView],
    models: &[&str],
    masks: usize,
) -> String {
    let kind = if top.contains_key("camera_model") || top.contains_key("applied_transform") {
        "nerfstudio"
    } else {
        "instant-ngp"
    };
    let first = &views[0].camera;
    let cameras = if views.iter().all(|v| same_intrinsics(&v.camera, first)) {
        format!("{}{}", models[0], first.distortion.nonzero_summary(" "))
    } else {
        let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
        for m in models {
            *counts.entry(m).or_default() += 1;
        }
        let list: Vec<String> = counts.iter().map(|(m, n)| format!("{n} {m}")).collect();
        format!("per-frame intrinsics ({})", list.join(", "))
    };
    let n = views.len();
    format!(
        "{kind} transforms.json ({OPENGL}): {n} frame{}, {cameras}{}",
        if n == 1 { "" } else { "s" },
        if masks > 0 {
            format!(", masks for {masks}")
        } else {
            String::new()
        }
    )
}

/// Whether two cameras have the same size, intrinsics and lens.
fn same_intrinsics(a: &Camera, b: &Camera) -> bool {
    (a.width, a.height, a.fx, a.fy, a.cx, a.cy, a.distortion)
        == (b.width, b.height, b.fx, b.fy, b.cx, b.cy, b.distortion)
}

/// A camera's pose as nerfstudio's `transform_matrix`: rows of the OpenGL camera-to-world.
fn gl_matrix(cam: &Camera) -> [[f32; 4]; 4] {
    let r_cv = match cam.convention {
        PoseConvention::OpenCv => cam.rotation,
        PoseConvention::Mitsuba => cam.rotation * MI_TO_CV,
    };
    let mut m = Mat4::from_mat3(r_cv * GL_TO_CV);
    m.w_axis = cam.origin.extend(1.0);
    m.transpose().to_cols_array_2d()
}

#[derive(serde::Serialize)]
struct FileOut {
    camera_model: &'static str,
    #[serde(flatten)]
    intrinsics: Option<IntrinsicsOut>,
    frames: Vec<FrameOut>,
}

#[derive(serde::Serialize)]
struct FrameOut {
    file_path: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    mask_path: Option<String>,
    #[serde(flatten)]
    intrinsics: Option<IntrinsicsOut>,
    transform_matrix: [[f32; 4]; 4],
}

/// A camera's intrinsics as nerfstudio's keys (lens coefficients only for a lens).
#[derive(serde::Serialize)]
struct IntrinsicsOut {
    fl_x: f32,
    fl_y: f32,
    cx: f32,
    cy: f32,
    w: usize,
    h: usize,
    #[serde(flatten)]
    lens: BTreeMap<&'static str, f32>,
}

impl IntrinsicsOut {
    fn of(c: &Camera) -> Self {
        let lens = match c.distortion {
            Distortion::None => BTreeMap::new(),
            Distortion::Opencv { k1, k2, k3, p1, p2 } => {
                let mut m = BTreeMap::from([("k1", k1), ("k2", k2), ("p1", p1), ("p2", p2)]);
                if k3 != 0.0 {
                    m.insert("k3", k3);
                }
                m
            }
            Distortion::Fisheye { k1, k2, k3, k4 } => {
                BTreeMap::from([("k1", k1), ("k2", k2), ("k3", k3), ("k4", k4)])
            }
        };
        IntrinsicsOut {
            fl_x: c.fx,
            fl_y: c.fy,
            cx: c.cx,
            cy: c.cy,
            w: c.width,
            h: c.height,
            lens,
        }
    }
}

#[cfg(test)]
mod tests;
