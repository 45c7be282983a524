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
/// that exists) and masks
/// (`mask_path`: 0 = leave out) relative to the file's folder. Errors name the file, the
/// frame and the fix.
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
        format!("{}{}", models[0], lens_summary(&first.distortion))
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

/// " k1 = -0.120, p1 = 0.001": a lens's non-zero coefficients.
fn lens_summary(d: &Distortion) -> String {
    let coeffs = match *d {
        Distortion::None => vec![],
        Distortion::Opencv { k1, k2, k3, p1, p2 } => {
            vec![("k1", k1), ("k2", k2), ("k3", k3), ("p1", p1), ("p2", p2)]
        }
        Distortion::Fisheye { k1, k2, k3, k4 } => {
            vec![("k1", k1), ("k2", k2), ("k3", k3), ("k4", k4)]
        }
    };
    let list: Vec<String> = coeffs
        .into_iter()
        .filter(|(_, v)| *v != 0.0)
        .map(|(n, v)| format!("{n} = {v:.3}"))
        .collect();
    if list.is_empty() {
        String::new()
    } else {
        format!(" {}", list.join(", "))
    }
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
mod tests {
    use super::*;
    use serde_json::json;

    const EYE: [[f32; 4]; 4] = [
        [1., 0., 0., 0.],
        [0., 1., 0., 0.],
        [0., 0., 1., 0.],
        [0., 0., 0., 1.],
    ];

    /// A temporary folder, removed when dropped.
    struct Temp(PathBuf);
    impl Temp {
        fn new() -> Temp {
            static N: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
            let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let t = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap();
            let name = format!(
                "fipt-nerfstudio-{}-{n}-{}",
                std::process::id(),
                t.as_nanos()
            );
            let p = std::env::temp_dir().join(name);
            std::fs::create_dir_all(&p).unwrap();
            Temp(p)
        }
        /// Writes `top` with `frames` (name, transform_matrix) added, as transforms.json.
        fn file(&self, mut top: Value, frames: &[(&str, [[f32; 4]; 4])]) -> PathBuf {
            if top.get("frames").is_none() {
                let f: Vec<Value> = frames
                    .iter()
                    .map(|(n, m)| json!({"file_path": n, "transform_matrix": m}))
                    .collect();
                top["frames"] = Value::Array(f);
            }
            let p = self.0.join("transforms.json");
            std::fs::write(&p, serde_json::to_string_pretty(&top).unwrap()).unwrap();
            p
        }
    }
    impl Drop for Temp {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
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
        let got = read(&tmp.file(top, &[])).unwrap();
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
        let path = tmp.file(top, &[("./train/r_0", EYE), ("./train/r_1", turned)]);
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
        let got = read(&tmp.file(top, &[])).unwrap();
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
            let path = tmp.file(top, &[("a.png", EYE), ("b.png", bad)]);
            let e = read(&path).unwrap_err().to_string();
            expect(&e, &parts);
            expect(&e, &[path.to_str().unwrap()]);
        }
        let top = json!({"fl_x": 50.0, "w": 64, "h": 48,
                         "frames": [{"file_path": "a.png", "transform_matrix": [[1.0, 0.0]]}]});
        let e = read(&tmp.file(top, &[])).unwrap_err().to_string();
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
            let e = read(&tmp.file(top, &[("a.png", EYE)]))
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
        let path = tmp.file(fipt, &[]);
        assert_eq!(looks_like_nerfstudio(&path).unwrap(), None);
        let own = json!({"camera_angle_x": 0.8,
                         "frames": [{"fl_x": 40.0, "transform_matrix": EYE}]});
        let path = tmp.file(own, &[]);
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
}
