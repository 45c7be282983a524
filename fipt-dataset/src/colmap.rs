//! COLMAP sparse models, text and binary: the cameras and posed images of a structure-from-
//! motion reconstruction, read as [`CaptureCameras`] (and written, for tests and test copies).
//!
//! COLMAP stores world-to-camera poses (unit quaternion qw qx qy qz, translation t) in the
//! OpenCV axes (+X right, +Y down, +Z forward): the camera-to-world rotation is Rᵀ and the
//! centre −Rᵀt. Its pixel coordinates put the top-left pixel's centre at (0.5, 0.5), as ours
//! do, so principal points are taken as they are. The lens models [`Distortion`] expresses
//! are read; the others are refused with the fix.
use crate::camera::{Camera, PoseConvention};
use crate::capture_layout::{CaptureCameras, CaptureView};
use crate::distortion::Distortion;
use crate::error::{CoreError, Result};
use glam::{DMat3, DQuat, DVec3, Mat3, Vec3};
use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

/// COLMAP's camera models, indexed by model id: name and number of parameters.
const MODELS: [(&str, usize); 12] = [
    ("SIMPLE_PINHOLE", 3),
    ("PINHOLE", 4),
    ("SIMPLE_RADIAL", 4),
    ("RADIAL", 5),
    ("OPENCV", 8),
    ("OPENCV_FISHEYE", 8),
    ("FULL_OPENCV", 12),
    ("FOV", 5),
    ("SIMPLE_RADIAL_FISHEYE", 4),
    ("RADIAL_FISHEYE", 5),
    ("THIN_PRISM_FISHEYE", 12),
    ("RAD_TAN_THIN_PRISM_FISHEYE", 16),
];
/// The parameters of the models read (ids below this), in COLMAP's order.
const PARAMS: [&str; 6] = [
    "f, cx, cy",
    "fx, fy, cx, cy",
    "f, cx, cy, k",
    "f, cx, cy, k1, k2",
    "fx, fy, cx, cy, k1, k2, p1, p2",
    "fx, fy, cx, cy, k1, k2, k3, k4",
];
const PINHOLE: usize = 1;
const SIMPLE_RADIAL: usize = 2;
const OPENCV: usize = 4;
const OPENCV_FISHEYE: usize = 5;
/// Folders of a scene looked in for a model, in order.
const MODEL_DIRS: [&str; 3] = ["sparse/0", "sparse", "colmap/sparse/0"];

/// A camera of a model: its model id and the camera it gives (pose left at the identity).
type Cameras = BTreeMap<u32, (usize, Camera)>;

/// An image of a model, as stored.
struct ModelImage {
    id: u32,
    /// qw, qx, qy, qz.
    q: [f64; 4],
    t: [f64; 3],
    camera: u32,
    name: String,
}

/// Where a scene folder keeps its COLMAP model, if it has one: `sparse/0/`, `sparse/`, or
/// `colmap/sparse/0/` (the first holding cameras.{bin,txt} and images.{bin,txt}).
pub fn find_model(root: &Path) -> Option<PathBuf> {
    MODEL_DIRS
        .iter()
        .map(|d| root.join(d))
        .find(|d| is_model(d))
}

/// Whether `dir` itself holds a COLMAP model: cameras.{bin,txt} and images.{bin,txt}.
pub fn is_model(dir: &Path) -> bool {
    ["cameras", "images"].iter().all(|stem| {
        ["bin", "txt"]
            .iter()
            .any(|e| dir.join(format!("{stem}.{e}")).is_file())
    })
}

/// Reads the model in `model_dir` (the binary files preferred when both `.bin` and `.txt`
/// exist; `description` says which were read), the images under `root/images/`, masks under
/// `root/masks/` (COLMAP's convention: the mask of `NAME` is `masks/NAME.png`; also
/// `masks/<NAME with its extension replaced by .png>`, then `masks/NAME`); a view's mask is
/// None when none of these files exists. Views are sorted by image name, their cameras in
/// [`PoseConvention::OpenCv`].
pub fn read_model(root: &Path, model_dir: &Path) -> Result<CaptureCameras> {
    let file = |n: &str| model_dir.join(n);
    let pair = |ext: &str| {
        ["cameras", "images"]
            .iter()
            .all(|s| file(&format!("{s}.{ext}")).is_file())
    };
    let any_bin = file("cameras.bin").is_file() || file("images.bin").is_file();
    // A half binary model beside a whole text one reads the text; else the error names the
    // missing binary file.
    let bin = pair("bin") || (any_bin && !pair("txt"));
    let ext = if bin { "bin" } else { "txt" };
    let (cams_path, imgs_path) = (
        file(&format!("cameras.{ext}")),
        file(&format!("images.{ext}")),
    );
    for p in [&cams_path, &imgs_path] {
        if !p.is_file() {
            return Err(CoreError::invalid(
                p,
                "missing: a COLMAP model needs cameras and images files of one kind \
                 (cameras.bin + images.bin, or cameras.txt + images.txt); \
                 export the model again with COLMAP",
            ));
        }
    }
    let read = |p: &Path| std::fs::read(p).map_err(|e| CoreError::io(p, e));
    let (cams, images) = if bin {
        (
            read_cameras_bin(&cams_path, &read(&cams_path)?)?,
            read_images_bin(&imgs_path, &read(&imgs_path)?)?,
        )
    } else {
        let text = |p: &Path| {
            String::from_utf8(read(p)?).map_err(|_| CoreError::invalid(p, "not UTF-8 text"))
        };
        (
            read_cameras_text(&cams_path, &text(&cams_path)?)?,
            read_images_text(&imgs_path, &text(&imgs_path)?)?,
        )
    };
    let mut notes = Vec::new();
    if bin && pair("txt") {
        notes.push(format!(
            "{} holds both binary and text files: \
             the binary ones (cameras.bin, images.bin) were read",
            model_dir.display()
        ));
    }
    let used: HashSet<u32> = images.iter().map(|im| im.camera).collect();
    let views = views(root, &cams_path, &imgs_path, &cams, images)?;
    notes.extend(mask_note(root, &views));
    let rel = model_dir.strip_prefix(root).unwrap_or(model_dir);
    let description = format!(
        "COLMAP {} model in {} (OpenCV axes, world-to-camera poses): {} image{}, {}",
        if bin { "binary" } else { "text" },
        rel.display(),
        views.len(),
        if views.len() == 1 { "" } else { "s" },
        camera_summary(&cams, &used)
    );
    Ok(CaptureCameras {
        views,
        cameras_file: imgs_path.clone(),
        files: vec![cams_path, imgs_path],
        description,
        notes,
    })
}

/// The views of a model's images, sorted by name, each with its camera, pose and mask.
fn views(
    root: &Path,
    cams_path: &Path,
    imgs_path: &Path,
    cams: &Cameras,
    mut images: Vec<ModelImage>,
) -> Result<Vec<CaptureView>> {
    if images.is_empty() {
        return Err(CoreError::invalid(
            imgs_path,
            "no images: the model registered none; run COLMAP's mapper again or check the export",
        ));
    }
    let mut ids = HashSet::new();
    for im in &images {
        if !ids.insert(im.id) {
            return Err(CoreError::invalid(
                imgs_path,
                format!(
                    "image id {} appears twice (the second is {}): each image needs its own id",
                    im.id, im.name
                ),
            ));
        }
    }
    images.sort_by(|a, b| a.name.cmp(&b.name));
    let cams_name = cams_path.file_name().unwrap_or_default().to_string_lossy();
    images
        .iter()
        .map(|im| {
            let (_, base) = cams.get(&im.camera).ok_or_else(|| {
                CoreError::invalid(
                    imgs_path,
                    format!(
                        "image {} ({}) uses camera {}, which {cams_name} does not define: \
                         export the model again",
                        im.id, im.name, im.camera
                    ),
                )
            })?;
            let (rotation, origin) = pose(imgs_path, im)?;
            Ok(CaptureView {
                camera: Camera {
                    rotation,
                    origin,
                    ..base.clone()
                },
                image: root.join("images").join(&im.name),
                mask: find_mask(root, &im.name),
                name: im.name.clone(),
            })
        })
        .collect()
}

/// What to know of the masks: a few views without one, or a masks/ folder none matched.
fn mask_note(root: &Path, views: &[CaptureView]) -> Option<String> {
    let (with_mask, n) = (
        views.iter().filter(|v| v.mask.is_some()).count(),
        views.len(),
    );
    if with_mask == 0 && root.join("masks").is_dir() {
        Some(
            "masks/ holds no mask named after the images (masks/NAME.png, masks/<NAME as .png> \
             or masks/NAME): no view is masked"
                .into(),
        )
    } else if with_mask > 0 && with_mask < n {
        Some(format!(
            "masks/ has masks for {with_mask} of {n} images: the others keep all their pixels"
        ))
    } else {
        None
    }
}

/// The mask of image `name`: `masks/NAME.png` (COLMAP's convention), else
/// `masks/<NAME as .png>`, else `masks/NAME` (a mask named as its image).
fn find_mask(root: &Path, name: &str) -> Option<PathBuf> {
    let dir = root.join("masks");
    let colmap = dir.join(format!("{name}.png"));
    let replaced = dir.join(name).with_extension("png");
    [colmap, replaced, dir.join(name)]
        .into_iter()
        .find(|p| p.is_file())
}

/// The camera-to-world rotation (OpenCV axes) and centre of an image's world-to-camera pose.
fn pose(path: &Path, im: &ModelImage) -> Result<(Mat3, Vec3)> {
    let [w, x, y, z] = im.q;
    let n = (w * w + x * x + y * y + z * z).sqrt();
    if !(n.is_finite() && n > 0.0 && im.t.iter().all(|v| v.is_finite())) {
        return Err(CoreError::invalid(
            path,
            format!(
                "image {} ({}): the pose (q = {:?}, t = {:?}) is not a rotation and a translation: \
                 the quaternion must be finite and non-zero",
                im.id, im.name, im.q, im.t
            ),
        ));
    }
    let r = DMat3::from_quat(DQuat::from_xyzw(x / n, y / n, z / n, w / n));
    let c2w = r.transpose();
    let origin = -(c2w * DVec3::from_array(im.t));
    Ok((c2w.as_mat3(), origin.as_vec3()))
}

/// "1 camera (OPENCV, k1 = -0.120)", or "3 cameras (2 OPENCV, 1 PINHOLE)": the cameras the
/// images use.
fn camera_summary(cams: &Cameras, used: &HashSet<u32>) -> String {
    let used: Vec<&(usize, Camera)> = cams
        .iter()
        .filter(|(id, _)| used.contains(id))
        .map(|(_, c)| c)
        .collect();
    if let [(m, c)] = used.as_slice() {
        return format!(
            "1 camera ({}{})",
            MODELS[*m].0,
            c.distortion.nonzero_summary(", ")
        );
    }
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for (m, _) in &used {
        *counts.entry(MODELS[*m].0).or_default() += 1;
    }
    let list: Vec<String> = counts.iter().map(|(m, n)| format!("{n} {m}")).collect();
    format!("{} cameras ({})", used.len(), list.join(", "))
}

/// The id of a model COLMAP names `shown` (`model`: its id when known), or the error for
/// one FIPT does not read.
fn supported_model(path: &Path, cam: u32, model: Option<usize>, shown: &str) -> Result<usize> {
    const FIX: &str = "undistort the images with `colmap image_undistorter` (its output is a \
                       PINHOLE model) or re-run COLMAP with camera model OPENCV";
    match model {
        Some(m) if m < PARAMS.len() => Ok(m),
        Some(m) => Err(CoreError::invalid(
            path,
            format!(
                "camera {cam} uses the camera model {}, which FIPT does not read: {FIX}",
                MODELS[m].0
            ),
        )),
        None => Err(CoreError::invalid(
            path,
            format!("camera {cam} has an unknown camera model `{shown}`: {FIX}"),
        )),
    }
}

/// The camera (pose at the identity) of camera `id` of model `m`, checked.
fn model_camera(path: &Path, id: u32, m: usize, size: (u64, u64), p: &[f64]) -> Result<Camera> {
    let name = MODELS[m].0;
    let bad = |msg: String| CoreError::invalid(path, format!("camera {id} ({name}): {msg}"));
    if p.len() != MODELS[m].1 {
        let (n, want, list) = (p.len(), MODELS[m].1, PARAMS[m]);
        return Err(bad(format!(
            "{n} parameters, but {name} takes {want} ({list}): export the model again"
        )));
    }
    // SIMPLE_PINHOLE, SIMPLE_RADIAL and RADIAL share one focal length.
    let (fx, fy, cx, cy, k) = match m {
        0 | 2 | 3 => (p[0], p[0], p[1], p[2], &p[3..]),
        _ => (p[0], p[1], p[2], p[3], &p[4..]),
    };
    let k = |i: usize| k.get(i).map_or(0.0, |&v| v as f32);
    let distortion = match m {
        0 | 1 => Distortion::None,
        OPENCV_FISHEYE => Distortion::Fisheye {
            k1: k(0),
            k2: k(1),
            k3: k(2),
            k4: k(3),
        },
        // SIMPLE_RADIAL: k; RADIAL: k1, k2; OPENCV: k1, k2, p1, p2.
        _ => Distortion::Opencv {
            k1: k(0),
            k2: k(1),
            k3: 0.0,
            p1: k(2),
            p2: k(3),
        },
    };
    if !(fx > 0.0 && fy > 0.0 && fx.is_finite() && fy.is_finite()) {
        return Err(bad(format!(
            "the focal length (fx = {fx}, fy = {fy}) must be positive and finite"
        )));
    }
    if !(cx.is_finite() && cy.is_finite()) || size.0 == 0 || size.1 == 0 {
        let (w, h) = size;
        return Err(bad(format!(
            "the principal point ({cx}, {cy}) or the size {w}x{h} is not valid"
        )));
    }
    let cam = Camera {
        width: size.0 as usize,
        height: size.1 as usize,
        fx: fx as f32,
        fy: fy as f32,
        cx: cx as f32,
        cy: cy as f32,
        convention: PoseConvention::OpenCv,
        rotation: Mat3::IDENTITY,
        origin: Vec3::ZERO,
        distortion,
    };
    match cam.distortion.check(cam.max_normalised_radius()) {
        Some(why) => Err(bad(why)),
        None => Ok(cam),
    }
}

/// Adds camera `id`, refusing a second camera with that id.
fn insert_camera(path: &Path, cams: &mut Cameras, id: u32, m: usize, cam: Camera) -> Result<()> {
    if cams.insert(id, (m, cam)).is_some() {
        return Err(CoreError::invalid(
            path,
            format!("camera id {id} is defined twice: each camera needs its own id"),
        ));
    }
    Ok(())
}

/// Parses token `tok` of line `line`.
fn num<T: std::str::FromStr>(path: &Path, line: usize, tok: &str, what: &str) -> Result<T> {
    tok.parse().map_err(|_| {
        CoreError::invalid(
            path,
            format!("line {line}: {what} `{tok}` is not a valid number"),
        )
    })
}

/// Reads cameras.txt: `CAMERA_ID MODEL WIDTH HEIGHT PARAMS...` per line, `#` comments.
fn read_cameras_text(path: &Path, text: &str) -> Result<Cameras> {
    let mut cams = Cameras::new();
    for (i, line) in text.lines().enumerate() {
        let (line, n) = (line.trim(), i + 1);
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let tok: Vec<&str> = line.split_whitespace().collect();
        if tok.len() < 4 {
            return Err(CoreError::invalid(
                path,
                format!("line {n}: expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS..., got `{line}`"),
            ));
        }
        let id: u32 = num(path, n, tok[0], "the camera id")?;
        let known = MODELS.iter().position(|(name, _)| *name == tok[1]);
        let m = supported_model(path, id, known, tok[1])?;
        let size = (
            num(path, n, tok[2], "the width")?,
            num(path, n, tok[3], "the height")?,
        );
        let params = tok[4..]
            .iter()
            .map(|t| num(path, n, t, "a parameter"))
            .collect::<Result<Vec<f64>>>()?;
        let cam = model_camera(path, id, m, size, &params)?;
        insert_camera(path, &mut cams, id, m, cam)?;
    }
    Ok(cams)
}

/// Reads images.txt: per image, `IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME`, then its
/// POINTS2D line (always the next line, even when blank); blank and `#` lines between images.
fn read_images_text(path: &Path, text: &str) -> Result<Vec<ModelImage>> {
    let mut images = Vec::new();
    let mut lines = text.lines().enumerate();
    while let Some((i, line)) = lines.next() {
        let (line, n) = (line.trim(), i + 1);
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut rest = line;
        let mut f = Vec::with_capacity(9);
        while f.len() < 9 && !rest.is_empty() {
            let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
            f.push(&rest[..end]);
            rest = rest[end..].trim_start();
        }
        if f.len() < 9 || rest.is_empty() {
            return Err(CoreError::invalid(
                path,
                format!(
                    "line {n}: expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, got `{line}`"
                ),
            ));
        }
        let v = |k: usize| num::<f64>(path, n, f[k], "a pose value");
        let im = ModelImage {
            id: num(path, n, f[0], "the image id")?,
            q: [v(1)?, v(2)?, v(3)?, v(4)?],
            t: [v(5)?, v(6)?, v(7)?],
            camera: num(path, n, f[8], "the camera id")?,
            name: rest.to_string(),
        };
        if let Some((j, points)) = lines.next() {
            if points.split_whitespace().count() % 3 != 0 {
                return Err(CoreError::invalid(
                    path,
                    format!(
                        "line {}: expected the POINTS2D line of image {} \
                         (X Y POINT3D_ID triples, or blank): \
                         each image takes two lines, the second possibly blank",
                        j + 1,
                        im.id
                    ),
                ));
            }
        }
        images.push(im);
    }
    Ok(images)
}

/// Little-endian reading of a binary model file, naming where it ends early.
struct Bytes<'a> {
    path: &'a Path,
    data: &'a [u8],
    pos: usize,
}

impl<'a> Bytes<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        if self.data.len() - self.pos < n {
            return Err(CoreError::invalid(
                self.path,
                format!(
                    "truncated at byte {} (the file has {} bytes) while reading {what}: \
                     the model is incomplete; export it again with COLMAP",
                    self.pos,
                    self.data.len()
                ),
            ));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N]> {
        Ok(self.take(N, what)?.try_into().expect("N bytes"))
    }
    fn u64(&mut self, what: &str) -> Result<u64> {
        self.array(what).map(u64::from_le_bytes)
    }
    fn u32(&mut self, what: &str) -> Result<u32> {
        self.array(what).map(u32::from_le_bytes)
    }
    fn i32(&mut self, what: &str) -> Result<i32> {
        self.array(what).map(i32::from_le_bytes)
    }
    fn f64(&mut self, what: &str) -> Result<f64> {
        self.array(what).map(f64::from_le_bytes)
    }
}

/// Reads cameras.bin.
fn read_cameras_bin(path: &Path, data: &[u8]) -> Result<Cameras> {
    let mut r = Bytes { path, data, pos: 0 };
    let mut cams = Cameras::new();
    for _ in 0..r.u64("the number of cameras")? {
        let id = r.u32("a camera id")?;
        let model = r.i32("a camera model id")?;
        let known = usize::try_from(model).ok().filter(|&m| m < MODELS.len());
        let m = supported_model(path, id, known, &format!("id {model}"))?;
        let size = (r.u64("a camera width")?, r.u64("a camera height")?);
        let params = (0..MODELS[m].1)
            .map(|_| r.f64("a camera parameter"))
            .collect::<Result<Vec<f64>>>()?;
        let cam = model_camera(path, id, m, size, &params)?;
        insert_camera(path, &mut cams, id, m, cam)?;
    }
    Ok(cams)
}

/// Reads images.bin (the 2D points are skipped).
fn read_images_bin(path: &Path, data: &[u8]) -> Result<Vec<ModelImage>> {
    let mut r = Bytes { path, data, pos: 0 };
    let mut images = Vec::new();
    for _ in 0..r.u64("the number of images")? {
        let id = r.u32("an image id")?;
        let mut v = [0.0; 7];
        for x in &mut v {
            *x = r.f64("an image pose")?;
        }
        let camera = r.u32("an image's camera id")?;
        let len = data[r.pos..]
            .iter()
            .position(|&b| b == 0)
            .unwrap_or(data.len() - r.pos + 1);
        let name = r.take(len + 1, "an image name")?;
        let name = String::from_utf8(name[..len].to_vec()).map_err(|_| {
            CoreError::invalid(
                path,
                format!(
                    "image {id}: its name is not UTF-8 (byte {})",
                    r.pos - len - 1
                ),
            )
        })?;
        let points = r.u64("an image's number of 2D points")?;
        let bytes = usize::try_from(points)
            .ok()
            .and_then(|p| p.checked_mul(24))
            .unwrap_or(usize::MAX);
        r.take(bytes, "an image's 2D points")?;
        images.push(ModelImage {
            id,
            q: [v[0], v[1], v[2], v[3]],
            t: [v[4], v[5], v[6]],
            camera,
            name,
        });
    }
    Ok(images)
}

/// Writes a model: `text = true` → cameras.txt, images.txt (and an empty points3D.txt);
/// false → cameras.bin, images.bin, points3D.bin (zero points). Each (name, camera) pair
/// becomes one image and one camera (camera_id = image_id = index + 1), posed in OpenCV
/// axes whatever the camera's convention. The model comes from the lens: none → PINHOLE;
/// Brown–Conrady with only k1 and fx == fy → SIMPLE_RADIAL; other Brown–Conrady → OPENCV
/// (k3 must be 0: FULL_OPENCV is not written); fisheye → OPENCV_FISHEYE. Each file is
/// written atomically; files of the other kind already in `dir` are left alone.
pub fn write_model(dir: &Path, views: &[(String, Camera)], text: bool) -> Result<()> {
    let ext = if text { "txt" } else { "bin" };
    let paths = ["cameras", "images", "points3D"].map(|s| dir.join(format!("{s}.{ext}")));
    let mut cams = Vec::new();
    let mut images = Vec::new();
    for (k, (name, cam)) in views.iter().enumerate() {
        let (m, params) = model_params(&paths[0], name, cam)?;
        cams.push((m, params, cam.width, cam.height));
        images.push(model_image(&paths[1], k, name, cam)?);
    }
    let files = if text {
        text_files(&cams, &images)
    } else {
        binary_files(&cams, &images)
    };
    for (path, bytes) in paths.iter().zip(files) {
        crate::fsutil::write_bytes_atomic(path, &bytes)?;
    }
    Ok(())
}

/// A camera as written: model id, parameters, width, height.
type WrittenCamera = (usize, Vec<f32>, usize, usize);

/// The image record of view `k`: its world-to-camera pose in OpenCV axes, camera k + 1.
fn model_image(path: &Path, k: usize, name: &str, cam: &Camera) -> Result<ModelImage> {
    if name.is_empty() || name.contains(['\0', '\n', '\r']) {
        return Err(CoreError::invalid(
            path,
            format!("view {k}: the image name {name:?} cannot be stored"),
        ));
    }
    let (err, det) = cam.rotation_error();
    if !(err < 1e-3 && det > 0.0 && cam.origin.is_finite()) {
        return Err(CoreError::invalid(
            path,
            format!(
                "view {name}: the pose is not rigid (max |RᵀR − I| = {err:.2e}, det = {det:.4})"
            ),
        ));
    }
    let r = cam.rotation.as_dmat3();
    let c2w = match cam.convention {
        PoseConvention::OpenCv => r,
        PoseConvention::Mitsuba => DMat3::from_cols(-r.x_axis, -r.y_axis, r.z_axis),
    };
    let w2c = c2w.transpose();
    let q = DQuat::from_mat3(&w2c).normalize();
    let t = -(w2c * cam.origin.as_dvec3());
    let id = k as u32 + 1;
    let (q, t, name) = ([q.w, q.x, q.y, q.z], t.to_array(), name.to_string());
    Ok(ModelImage {
        id,
        q,
        t,
        camera: id,
        name,
    })
}

/// cameras.txt, images.txt and points3D.txt, with COLMAP's header comments.
fn text_files(cams: &[WrittenCamera], images: &[ModelImage]) -> [Vec<u8>; 3] {
    let mut c = format!(
        "# Camera list with one line of data per camera:\n\
         #   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n# Number of cameras: {}\n",
        cams.len()
    );
    for (k, (m, p, w, h)) in cams.iter().enumerate() {
        let p: Vec<String> = p.iter().map(|v| v.to_string()).collect();
        c += &format!("{} {} {w} {h} {}\n", k + 1, MODELS[*m].0, p.join(" "));
    }
    let mut i = format!(
        "# Image list with two lines of data per image:\n\
         #   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n\
         #   POINTS2D[] as (X, Y, POINT3D_ID)\n\
         # Number of images: {}, mean observations per image: 0\n",
        images.len()
    );
    for im in images {
        let ([qw, qx, qy, qz], [tx, ty, tz]) = (im.q, im.t);
        let (id, cam, name) = (im.id, im.camera, &im.name);
        i += &format!("{id} {qw} {qx} {qy} {qz} {tx} {ty} {tz} {cam} {name}\n\n");
    }
    let p = "# 3D point list with one line of data per point:\n\
             #   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n\
             # Number of points: 0, mean track length: 0\n";
    [c.into_bytes(), i.into_bytes(), p.as_bytes().to_vec()]
}

/// cameras.bin, images.bin and points3D.bin (little endian).
fn binary_files(cams: &[WrittenCamera], images: &[ModelImage]) -> [Vec<u8>; 3] {
    let mut c = (cams.len() as u64).to_le_bytes().to_vec();
    for (k, (m, p, w, h)) in cams.iter().enumerate() {
        c.extend((k as u32 + 1).to_le_bytes());
        c.extend((*m as i32).to_le_bytes());
        c.extend((*w as u64).to_le_bytes());
        c.extend((*h as u64).to_le_bytes());
        p.iter().for_each(|v| c.extend((*v as f64).to_le_bytes()));
    }
    let mut i = (images.len() as u64).to_le_bytes().to_vec();
    for im in images {
        i.extend(im.id.to_le_bytes());
        im.q.iter()
            .chain(&im.t)
            .for_each(|v| i.extend(v.to_le_bytes()));
        i.extend(im.camera.to_le_bytes());
        i.extend(im.name.as_bytes());
        i.push(0);
        i.extend(0u64.to_le_bytes());
    }
    [c, i, 0u64.to_le_bytes().to_vec()]
}

/// The COLMAP model id and parameters of a camera's intrinsics and lens.
fn model_params(path: &Path, name: &str, c: &Camera) -> Result<(usize, Vec<f32>)> {
    let k = [c.fx, c.fy, c.cx, c.cy];
    Ok(match c.distortion {
        Distortion::None => (PINHOLE, k.to_vec()),
        Distortion::Opencv { k1, k2, k3, p1, p2 }
            if c.fx == c.fy && [k2, k3, p1, p2].iter().all(|&v| v == 0.0) =>
        {
            (SIMPLE_RADIAL, vec![c.fx, c.cx, c.cy, k1])
        }
        Distortion::Opencv { k1, k2, k3, p1, p2 } => {
            if k3 != 0.0 {
                return Err(CoreError::invalid(
                    path,
                    format!(
                        "view {name}: k3 = {k3} needs COLMAP's FULL_OPENCV model, \
                         which is not written; set k3 to 0"
                    ),
                ));
            }
            (OPENCV, [&k[..], &[k1, k2, p1, p2]].concat())
        }
        Distortion::Fisheye { k1, k2, k3, k4 } => {
            (OPENCV_FISHEYE, [&k[..], &[k1, k2, k3, k4]].concat())
        }
    })
}

#[cfg(test)]
mod tests;
