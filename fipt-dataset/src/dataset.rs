//! Reading the scene folders users already have, with validation that names the file.
//!
//! FIPT's two layouts (method §5), and the capture layouts users have
//! ([`crate::capture_layout`]: a COLMAP model, a nerfstudio / instant-ngp `transforms.json`):
//! * **synthetic**: `scene.obj`, `train/transforms.json`, `val/transforms.json`,
//!   `<split>/Image/{k:03d}_0001.exr` and optional ground-truth folders ([`GtKind`]);
//! * **real**: `scene.obj`, `Image/{k:03d}_0001.exr`, `cam.txt`, `K_list.txt`, optional
//!   `segmentation/`.
//!
//! [`Dataset::open`] parses cameras and checks that every image exists and has the same size
//! (reading only EXR headers); [`Dataset::load_image`] reads pixels and applies the
//! [`BadPixelPolicy`].
use crate::camera::Camera;
use crate::color::Rgb;
use crate::error::{CoreError, Result};
use crate::image::{BadPixelCount, BadPixelPolicy, Image};
use glam::Mat4;
use serde::Serialize;
use std::path::{Path, PathBuf};

use crate::inputs::{check_image_sizes, find_mesh};
pub use crate::inputs::{exr_size, image_size};

pub use crate::camera_files::{read_cam_list, write_cam_list, write_transforms};

/// Which of the two reference layouts a scene folder follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Layout {
    Synthetic,
    Real,
    /// A COLMAP sparse model (`sparse/0/`) with `images/`.
    Colmap,
    /// A nerfstudio / instant-ngp `transforms.json` at the folder's root.
    Nerfstudio,
}

/// Ground-truth map folders of the synthetic layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum GtKind {
    /// kd.
    DiffCol,
    /// σ (channel 0).
    Roughness,
    /// Emitted radiance (emitter where > 0).
    Emit,
    /// a′ = kd + specular reflectance.
    Albedo,
    /// Part (object) id.
    IndexMA,
    /// Semantic id.
    Segmentation,
    /// Metallic.
    Metallic,
    /// ks (Fresnel F0).
    Specular,
}

impl GtKind {
    pub const ALL: [GtKind; 8] = [
        GtKind::DiffCol,
        GtKind::Roughness,
        GtKind::Emit,
        GtKind::Albedo,
        GtKind::IndexMA,
        GtKind::Segmentation,
        GtKind::Metallic,
        GtKind::Specular,
    ];

    /// Folder name inside a split.
    pub fn folder(self) -> &'static str {
        match self {
            GtKind::DiffCol => "DiffCol",
            GtKind::Roughness => "Roughness",
            GtKind::Emit => "Emit",
            GtKind::Albedo => "albedo",
            GtKind::IndexMA => "IndexMA",
            GtKind::Segmentation => "segmentation",
            GtKind::Metallic => "Metallic",
            GtKind::Specular => "Specular",
        }
    }

    /// File name of view `k`.
    pub fn file_name(self, k: usize) -> String {
        match self {
            GtKind::Albedo | GtKind::Segmentation => format!("{k:03}.exr"),
            _ => format!("{k:03}_0001.exr"),
        }
    }
}

/// File name of the HDR input image of view `k`.
pub fn image_file_name(k: usize) -> String {
    format!("{k:03}_0001.exr")
}

/// Extensions a view's image may have, in the order they are looked for: EXR (linear HDR),
/// then 8/16-bit PNG and JPEG (through the response curve of `capture.json`).
pub const IMAGE_EXTENSIONS: [&str; 4] = ["exr", "png", "jpg", "jpeg"];

/// The image of view `k` in `dir`: `{k:03}_0001` with the first extension of
/// [`IMAGE_EXTENSIONS`] present, in lower or upper case (the EXR name when none is, for the
/// error that names it).
pub fn find_image(dir: &Path, k: usize) -> PathBuf {
    let exr = dir.join(image_file_name(k));
    (IMAGE_EXTENSIONS.iter())
        .flat_map(|e| [e.to_string(), e.to_uppercase()])
        .map(|e| exr.with_extension(e))
        .find(|p| p.is_file())
        .unwrap_or(exr)
}

/// One posed view.
#[derive(Clone, Debug)]
pub struct View {
    pub index: usize,
    pub camera: Camera,
    pub image: PathBuf,
    /// A mask of pixels to leave out (0 = leave out), at the image's stored size.
    pub mask: Option<PathBuf>,
}

/// A set of views (`train`, `val`, or the real layout's single set).
#[derive(Clone, Debug)]
pub struct Split {
    pub name: String,
    /// Folder holding `Image/` and the ground-truth folders.
    pub dir: PathBuf,
    pub views: Vec<View>,
    /// Ground-truth folders present with a file for every view.
    pub gt: Vec<GtKind>,
    /// The file the cameras came from.
    pub cameras_file: PathBuf,
}

impl Split {
    /// Path of a ground-truth map of view `k`.
    pub fn gt_path(&self, kind: GtKind, k: usize) -> PathBuf {
        self.dir.join(kind.folder()).join(kind.file_name(k))
    }
    pub fn has_gt(&self, kind: GtKind) -> bool {
        self.gt.contains(&kind)
    }
}

/// A scene folder, opened and checked.
#[derive(Clone, Debug)]
pub struct Dataset {
    pub root: PathBuf,
    pub layout: Layout,
    pub mesh: PathBuf,
    pub splits: Vec<Split>,
    pub width: usize,
    pub height: usize,
    /// Problems that do not stop a run (shown by `fipt info`).
    pub warnings: Vec<String>,
    /// `capture.json`: the response curve of 8/16-bit views and known exposures.
    pub capture: crate::capture::CaptureInfo,
    /// Views, masks and ground truth are shrunk by this factor on read (1: as stored); the
    /// cameras, `width` and `height` are the shrunk ones.
    pub downscale: usize,
    /// The views' size as stored (before the downscale).
    pub stored_size: (usize, usize),
    /// What the camera files are and which convention they state (capture layouts), and
    /// which convention a FIPT `transforms.json` was taken in and why.
    pub cameras_description: Option<String>,
    /// The files the cameras came from (the inputs' fingerprint hashes them).
    pub camera_files: Vec<PathBuf>,
    /// What each training view's EXIF says of its exposure (8/16-bit files; empty for EXR
    /// views).
    pub exif: Vec<Option<crate::exif::ExifExposure>>,
    /// The training views' relative exposures from their EXIF (median 1), used when
    /// `capture.json` gives none and every view has an exposure time.
    pub exif_exposures: Option<Vec<f32>>,
}

/// Mesh file names looked for in a scene folder, in order.
pub const MESH_NAMES: [&str; 4] = ["scene.obj", "scene.ply", "scene.glb", "scene.gltf"];

impl Dataset {
    /// Opens a scene folder of any layout, as stored.
    pub fn open(root: &Path) -> Result<Dataset> {
        Dataset::open_with(root, crate::capture_layout::OpenOptions::default())
    }

    /// Opens a scene folder of any layout with `opts` (a downscale).
    pub fn open_with(root: &Path, opts: crate::capture_layout::OpenOptions) -> Result<Dataset> {
        if !root.exists() {
            return Err(CoreError::invalid(root, "no such folder: check the path (a scene folder holds scene.obj and train/transforms.json, cam.txt + K_list.txt, a COLMAP model in sparse/0/, or a nerfstudio transforms.json)"));
        }
        if !root.is_dir() {
            return Err(CoreError::invalid(root, "not a folder (expected a scene folder with scene.obj and train/transforms.json, cam.txt + K_list.txt, a COLMAP model in sparse/0/, or a nerfstudio transforms.json)"));
        }
        let mesh = find_mesh(root)?;
        let mut warnings = Vec::new();
        let mut description = None;
        let mut camera_files = Vec::new();
        let (layout, splits) = if root.join("train/transforms.json").is_file() {
            description = Some(crate::capture_layout::check_fipt_transforms(root)?);
            let mut splits = vec![read_synthetic_split(root, "train", &mut warnings)?];
            if root.join("val/transforms.json").is_file() {
                splits.push(read_synthetic_split(root, "val", &mut warnings)?);
            } else {
                warnings.push(
                    "no val/transforms.json: no held-out views for novel-view evaluation".into(),
                );
            }
            (Layout::Synthetic, splits)
        } else if root.join("cam.txt").is_file() {
            (Layout::Real, vec![read_real_split(root, &mut warnings)?])
        } else if let Some((layout, cams)) = crate::capture_layout::read_capture_layout(root)? {
            warnings.extend(cams.notes.iter().cloned());
            description = Some(cams.description.clone());
            camera_files = cams.files.clone();
            (
                layout,
                vec![crate::capture_layout::capture_split(root, &cams)?],
            )
        } else {
            return Err(CoreError::invalid(
                root,
                "no cameras found: expected train/transforms.json (FIPT's synthetic layout), cam.txt + K_list.txt (FIPT's real layout), \
                 a COLMAP model (sparse/0/cameras.bin or .txt with images/) or a nerfstudio / instant-ngp transforms.json",
            ));
        };
        let (width, height) =
            check_image_sizes(&splits, matches!(layout, Layout::Synthetic | Layout::Real))?;
        let stored_size = (width, height);
        let (splits, width, height) =
            crate::capture_layout::downscaled(splits, width, height, opts.downscale, root)?;
        warnings.extend(crate::capture_layout::downscale_notes(
            stored_size,
            (width, height),
            opts.downscale,
        ));
        let capture = crate::capture::CaptureInfo::read(root)?;
        if let Some(e) = &capture.exposures {
            let n = splits[0].views.len();
            if e.len() != n {
                return Err(CoreError::invalid(
                    root.join(crate::capture::CAPTURE_FILE),
                    format!(
                        "{} exposures for {n} training views: give one per view",
                        e.len()
                    ),
                ));
            }
        }
        let exif: Vec<Option<crate::exif::ExifExposure>> = if splits[0]
            .views
            .iter()
            .any(|v| crate::capture::is_ldr_file(&v.image))
        {
            splits[0]
                .views
                .iter()
                .map(|v| crate::exif::read(&v.image).ok().flatten())
                .collect()
        } else {
            vec![]
        };
        let exif_exposures = if capture.exposures.is_none() && !exif.is_empty() {
            crate::exif::relative_exposures(&exif).ok()
        } else {
            None
        };
        Ok(Dataset {
            root: root.to_path_buf(),
            layout,
            mesh,
            splits,
            width,
            height,
            warnings,
            capture,
            downscale: opts.downscale.max(1),
            stored_size,
            cameras_description: description,
            camera_files,
            exif,
            exif_exposures,
        })
    }

    pub fn split(&self, name: &str) -> Option<&Split> {
        self.splits.iter().find(|s| s.name == name)
    }

    /// The training views (`train`, or the real layout's views).
    pub fn train(&self) -> &Split {
        &self.splits[0]
    }

    /// Reads a view's image as linear radiance (8/16-bit files through the response curve),
    /// checks its size and applies `policy` to bad pixels. Known exposures (`capture.json`)
    /// are not applied here: see [`Dataset::view_exposure`].
    pub fn load_image(
        &self,
        view: &View,
        policy: BadPixelPolicy,
    ) -> Result<(Image, BadPixelCount)> {
        let c = &self.capture;
        if crate::capture::is_ldr_file(&view.image) || c.exr_response {
            let img = if crate::capture::is_ldr_file(&view.image) {
                crate::capture::read_ldr(&view.image, &c.response)?
            } else {
                let mut img = Image::read_exr(&view.image)?;
                for p in &mut img.data {
                    *p = Rgb::from_array(p.to_array().map(|v| c.response.to_linear(v)));
                }
                img
            };
            let img = self.shrunk(img);
            check_size(&img, &view.image, self.width, self.height)?;
            let bad = img_sanitize(img, policy, &view.image)?;
            return Ok(bad);
        }
        if self.downscale > 1 {
            let img = self.shrunk(Image::read_exr(&view.image)?);
            check_size(&img, &view.image, self.width, self.height)?;
            return img_sanitize(img, policy, &view.image);
        }
        load_checked(&view.image, self.width, self.height, policy)
    }

    /// An image as the run sees it: shrunk by [`Dataset::downscale`].
    fn shrunk(&self, img: Image) -> Image {
        if self.downscale > 1 {
            crate::capture_layout::downscale_image(&img, self.downscale)
        } else {
            img
        }
    }

    /// The pixels of view `view` to keep (`true`), from its mask, at the run's size; None
    /// when it has no mask.
    pub fn load_mask(&self, view: &View) -> Result<Option<Vec<bool>>> {
        let Some(path) = &view.mask else {
            return Ok(None);
        };
        let f = self.downscale.max(1);
        let (w, h) = self.stored_size;
        crate::capture_layout::read_mask(path, w, h, f).map(Some)
    }

    /// The relative exposure known for training view `k`: `capture.json`'s, else its EXIF's
    /// (1 without either).
    pub fn view_exposure(&self, k: usize) -> f32 {
        self.known_exposures()
            .and_then(|(e, _)| e.get(k).copied())
            .unwrap_or(1.0)
    }

    /// The training views' known relative exposures and where they came from
    /// (`capture.json`, else EXIF).
    pub fn known_exposures(&self) -> Option<(&[f32], &'static str)> {
        if let Some(e) = &self.capture.exposures {
            return Some((e, crate::capture::CAPTURE_FILE));
        }
        self.exif_exposures.as_deref().map(|e| (e, "EXIF"))
    }

    /// Whether any view is an 8/16-bit file (PNG, JPEG).
    pub fn has_ldr_files(&self) -> bool {
        self.splits
            .iter()
            .flat_map(|s| &s.views)
            .any(|v| crate::capture::is_ldr_file(&v.image))
    }

    /// Reads a ground-truth map of view `k` of `split` (None when the folder is absent).
    pub fn load_gt(&self, split: &Split, kind: GtKind, k: usize) -> Result<Option<Image>> {
        if !split.has_gt(kind) {
            return Ok(None);
        }
        let p = split.gt_path(kind, k);
        if self.downscale > 1 {
            let img = self.shrunk(Image::read_exr(&p)?);
            check_size(&img, &p, self.width, self.height)?;
            return img_sanitize(img, BadPixelPolicy::Reject, &p).map(|(i, _)| Some(i));
        }
        load_checked(&p, self.width, self.height, BadPixelPolicy::Reject).map(|(i, _)| Some(i))
    }

    /// The per-pixel ids of an id map (`IndexMA/` parts or `segmentation/` classes) of view `k`,
    /// from its first channel: non-negative whole numbers are ids; negative, fractional or
    /// non-finite values mean "no id" (−1). `None` when the split has no such folder.
    pub fn load_ids(&self, split: &Split, kind: GtKind, k: usize) -> Result<Option<Vec<i64>>> {
        if !split.has_gt(kind) {
            return Ok(None);
        }
        let f = self.downscale.max(1);
        let img = read_sized(
            &split.gt_path(kind, k),
            self.stored_size.0,
            self.stored_size.1,
            "an id map must have the size of its view",
        )?;
        let ids: Vec<i64> = img
            .data
            .iter()
            .map(|v| {
                let x = v.x;
                if x.is_finite() && x >= 0.0 && x.fract() == 0.0 && x < 1e15 {
                    x as i64
                } else {
                    -1
                }
            })
            .collect();
        Ok(Some(crate::capture_layout::downscale_ids(
            &ids, img.width, img.height, f,
        )))
    }
}

fn img_sanitize(
    mut img: Image,
    policy: BadPixelPolicy,
    path: &Path,
) -> Result<(Image, BadPixelCount)> {
    let bad = img.sanitize(policy, path)?;
    Ok((img, bad))
}

/// Reads an EXR of `w`×`h` pixels; another size is an error naming the file, with `hint`.
fn read_sized(path: &Path, w: usize, h: usize, hint: &str) -> Result<Image> {
    let img = Image::read_exr(path)?;
    check_size_hint(&img, path, w, h, hint)?;
    Ok(img)
}

fn check_size(img: &Image, path: &Path, w: usize, h: usize) -> Result<()> {
    check_size_hint(
        img,
        path,
        w,
        h,
        "all views of a scene must have the same size",
    )
}

fn check_size_hint(img: &Image, path: &Path, w: usize, h: usize, hint: &str) -> Result<()> {
    if (img.width, img.height) != (w, h) {
        return Err(CoreError::SizeMismatch {
            path: path.to_path_buf(),
            got_w: img.width,
            got_h: img.height,
            expected_w: w,
            expected_h: h,
            hint: hint.into(),
        });
    }
    Ok(())
}

fn load_checked(
    path: &Path,
    w: usize,
    h: usize,
    policy: BadPixelPolicy,
) -> Result<(Image, BadPixelCount)> {
    let mut img = read_sized(path, w, h, "all views of a scene must have the same size")?;
    let bad = img.sanitize(policy, path)?;
    Ok((img, bad))
}

// `!(x < bound)` is meant: it is true for NaN, which must fail the check too.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn check_pose(path: &Path, frame: usize, cam: &Camera) -> Result<()> {
    let (err, det) = cam.rotation_error();
    if !cam.origin.is_finite() || !(err < 1e-3) || !(det > 0.0) {
        let hint = if det < 0.0 && err < 1e-3 {
            "the rotation is a reflection (one axis flipped): the pose is probably in another convention; \
             transforms.json expects camera-to-world with +X left, +Y up, +Z forward (OpenCV poses go in cam.txt)"
        } else {
            "expected a rigid camera-to-world transform (orthonormal rotation, no scale or shear)"
        };
        return Err(CoreError::BadPose {
            path: path.to_path_buf(),
            frame,
            error: err,
            det,
            hint: hint.into(),
        });
    }
    Ok(())
}

#[derive(serde::Deserialize)]
struct TransformsJson {
    camera_angle_x: f32,
    #[serde(default)]
    width: Option<usize>,
    #[serde(default)]
    height: Option<usize>,
    /// The lens of every view (an extension of FIPT's layout; absent: pinholes).
    #[serde(default)]
    distortion: crate::distortion::Distortion,
    frames: Vec<FrameJson>,
}

#[derive(serde::Deserialize)]
struct FrameJson {
    transform_matrix: [[f32; 4]; 4],
}

/// Reads the cameras of a `transforms.json`. The image size comes from its `width`/`height`
/// keys, else from `size` (e.g. the first image's header); poses are validated.
pub fn read_transforms(tf_path: &Path, size: Option<(usize, usize)>) -> Result<Vec<Camera>> {
    let tf: TransformsJson = crate::fsutil::read_json(tf_path)?;
    if !(tf.camera_angle_x > 0.0 && tf.camera_angle_x < std::f32::consts::PI) {
        return Err(CoreError::invalid(
            tf_path,
            format!(
                "camera_angle_x = {} is not a field of view in radians (0, π)",
                tf.camera_angle_x
            ),
        ));
    }
    if tf.frames.is_empty() {
        return Err(CoreError::invalid(tf_path, "no frames"));
    }
    let (w, h) = match (tf.width, tf.height, size) {
        (Some(w), Some(h), _) => (w, h),
        (_, _, Some(s)) => s,
        _ => return Err(CoreError::invalid(tf_path, "no width/height keys and no image to take the size from (add \"width\" and \"height\", or the images)")),
    };
    let mut cams = Vec::with_capacity(tf.frames.len());
    for (k, f) in tf.frames.iter().enumerate() {
        let m = f.transform_matrix;
        // JSON rows → glam columns.
        let c2w = Mat4::from_cols_array_2d(&m).transpose();
        let last = c2w.row(3);
        if (last - glam::Vec4::new(0.0, 0.0, 0.0, 1.0))
            .abs()
            .max_element()
            > 1e-4
        {
            return Err(CoreError::invalid(
                tf_path,
                format!("frame {k}: last row of transform_matrix is {last}, expected [0, 0, 0, 1]"),
            ));
        }
        let mut cam = Camera::from_transform(c2w, tf.camera_angle_x, w, h);
        cam.distortion = tf.distortion;
        check_pose(tf_path, k, &cam)?;
        if let Some(why) = cam.distortion.check(cam.max_normalised_radius()) {
            return Err(CoreError::invalid(tf_path, why));
        }
        cams.push(cam);
    }
    Ok(cams)
}

fn read_synthetic_split(root: &Path, name: &str, warnings: &mut Vec<String>) -> Result<Split> {
    let dir = root.join(name);
    let tf_path = dir.join("transforms.json");
    let img0 = find_image(&dir.join("Image"), 0);
    let size = if img0.is_file() {
        Some(image_size(&img0)?)
    } else {
        None
    };
    let cams = read_transforms(&tf_path, size)?;
    let views: Vec<View> = cams
        .into_iter()
        .enumerate()
        .map(|(k, camera)| View {
            index: k,
            camera,
            image: find_image(&dir.join("Image"), k),
            mask: crate::capture_layout::fipt_mask(&dir, k),
        })
        .collect();
    let gt = present_gt(&dir, views.len(), warnings, name);
    warn_unused_images(
        &dir.join("Image"),
        views.len(),
        name,
        "frames in transforms.json",
        warnings,
    );
    Ok(Split {
        name: name.to_string(),
        dir,
        views,
        gt,
        cameras_file: tf_path,
    })
}

/// Warns when `images` holds EXRs no camera refers to (more images than frames).
fn warn_unused_images(
    images: &Path,
    n: usize,
    split: &str,
    what: &str,
    warnings: &mut Vec<String>,
) {
    let Ok(entries) = std::fs::read_dir(images) else {
        return;
    };
    let named: std::collections::HashSet<String> = (0..n)
        .map(|k| image_file_name(k).trim_end_matches(".exr").to_string())
        .collect();
    let extra: Vec<String> = entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|f| {
            let p = Path::new(f);
            let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
            IMAGE_EXTENSIONS.contains(&ext.to_ascii_lowercase().as_str())
                && !named.contains(p.file_stem().and_then(|s| s.to_str()).unwrap_or(""))
        })
        .collect();
    if !extra.is_empty() {
        warnings.push(format!(
            "{split}: {} images in {} have no camera ({n} {what}; e.g. {}): they are not used",
            extra.len(),
            images.display(),
            extra.iter().min().map_or("", String::as_str)
        ));
    }
}

fn present_gt(dir: &Path, n: usize, warnings: &mut Vec<String>, split: &str) -> Vec<GtKind> {
    let mut gt = Vec::new();
    for kind in GtKind::ALL {
        let folder = dir.join(kind.folder());
        if !folder.is_dir() {
            continue;
        }
        let missing = (0..n)
            .filter(|&k| !folder.join(kind.file_name(k)).is_file())
            .count();
        if missing == 0 {
            gt.push(kind);
        } else {
            warnings.push(format!(
                "{split}/{}: {missing} of {n} files missing; this ground truth is ignored",
                kind.folder()
            ));
        }
    }
    gt
}

fn read_real_split(root: &Path, warnings: &mut Vec<String>) -> Result<Split> {
    let cam_path = root.join("cam.txt");
    let img0 = find_image(&root.join("Image"), 0);
    let k_path = root.join("K_list.txt");
    if !k_path.is_file() {
        return Err(CoreError::invalid(
            &k_path,
            "missing: the real layout needs K_list.txt beside cam.txt",
        ));
    }
    let (w, h) = image_size(&img0)?;
    let views: Vec<View> = read_cam_list(&cam_path, &k_path, w, h)?
        .into_iter()
        .enumerate()
        .map(|(i, camera)| View {
            index: i,
            camera,
            image: find_image(&root.join("Image"), i),
            mask: crate::capture_layout::fipt_mask(root, i),
        })
        .collect();
    let n = views.len();
    let gt = present_gt(root, n, warnings, "real");
    warn_unused_images(
        &root.join("Image"),
        n,
        "real",
        "cameras in cam.txt",
        warnings,
    );
    Ok(Split {
        name: "train".into(),
        dir: root.to_path_buf(),
        views,
        gt,
        cameras_file: cam_path,
    })
}
