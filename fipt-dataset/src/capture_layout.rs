//! Camera files users store captures in, beside FIPT's two layouts: a COLMAP sparse model
//! ([`crate::colmap`]) and a nerfstudio / instant-ngp `transforms.json`
//! ([`crate::nerfstudio`]). Each reader states its convention (never guesses it) and returns
//! the same [`CaptureCameras`]; [`crate::dataset::Dataset::open`] turns them into a split.
use crate::camera::Camera;
use std::path::PathBuf;

/// One posed photograph read from a capture's camera files.
#[derive(Clone, Debug)]
pub struct CaptureView {
    /// The camera (intrinsics, lens model, pose), in the convention the layout states.
    pub camera: Camera,
    /// The image file (absolute, or relative to the current folder as joined from the root).
    pub image: PathBuf,
    /// A mask of pixels to leave out (0 = leave out, anything else = keep), when given.
    pub mask: Option<PathBuf>,
    /// The name the camera file gives the view (COLMAP's image name, nerfstudio's file_path).
    pub name: String,
}

/// What a capture layout's reader found.
#[derive(Clone, Debug)]
pub struct CaptureCameras {
    /// The views, in a deterministic order (COLMAP: by image name; nerfstudio: as listed).
    pub views: Vec<CaptureView>,
    /// The file the poses came from (named by errors and `fipt info`).
    pub cameras_file: PathBuf,
    /// Every file the cameras came from (the inputs' fingerprint hashes them).
    pub files: Vec<PathBuf>,
    /// One line on what was read: the layout, its convention, the camera models and lenses.
    pub description: String,
    /// What a user should know (ignored keys, assumptions taken), shown by `fipt info`.
    pub notes: Vec<String>,
}

use crate::dataset::{Layout, Split, View};
use crate::error::{CoreError, Result};
use crate::image::Image;
use std::path::Path;

/// How a scene folder is read: options that change what the stages see.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OpenOptions {
    /// Each view (and its mask and ground truth) shrunk by this factor on read, the
    /// intrinsics with it (1: as stored). Photos larger than the method needs.
    pub downscale: usize,
}

impl Default for OpenOptions {
    fn default() -> Self {
        OpenOptions { downscale: 1 }
    }
}

/// The capture layout a scene folder holds, if any (after FIPT's own two): a nerfstudio /
/// instant-ngp `transforms.json` at its root, or a COLMAP model.
pub fn read_capture_layout(root: &Path) -> Result<Option<(Layout, CaptureCameras)>> {
    let tf = root.join("transforms.json");
    if tf.is_file() {
        let v: serde_json::Value = crate::fsutil::read_json(&tf)?;
        if let Some(c) = v["camera_convention"]
            .as_str()
            .filter(|c| c.contains("Mitsuba"))
        {
            return Err(CoreError::invalid(
                &tf,
                format!(
                    "this is FIPT's synthetic-layout transforms.json (camera_convention: {c}), not a nerfstudio one \
                     (OpenGL): put it in train/ (with its images in train/Image/) to read it as FIPT's"
                ),
            ));
        }
        let mut cams = crate::nerfstudio::read(&tf)?;
        // `ns-process-data` leaves the COLMAP model it solved beside its transforms.json: said
        // where the cameras are described (`fipt info`, the run's log), not as a warning.
        if let Some(model) = crate::colmap::find_model(root) {
            cams.description += &format!(
                "; the COLMAP model beside it ({}) is not read: the mesh must be in transforms.json's frame (after its applied_transform, if any)",
                model.display()
            );
        }
        return Ok(Some((Layout::Nerfstudio, cams)));
    }
    if let Some(model) = crate::colmap::find_model(root) {
        return Ok(Some((
            Layout::Colmap,
            crate::colmap::read_model(root, &model)?,
        )));
    }
    Ok(None)
}

/// The one split of a capture layout.
pub fn capture_split(root: &Path, cams: &CaptureCameras) -> Result<Split> {
    if cams.views.is_empty() {
        return Err(CoreError::invalid(&cams.cameras_file, "no views"));
    }
    let views = cams
        .views
        .iter()
        .enumerate()
        .map(|(k, v)| View {
            index: k,
            camera: v.camera.clone(),
            image: v.image.clone(),
            mask: v.mask.clone(),
        })
        .collect();
    Ok(Split {
        name: "train".into(),
        dir: root.to_path_buf(),
        views,
        gt: vec![],
        cameras_file: cams.cameras_file.clone(),
    })
}

/// `img` shrunk by `factor`: each output pixel the mean of a `factor`×`factor` block of
/// linear values (summed in f64: a block of equal values gives that value exactly), the
/// remainder cropped at the right and bottom.
pub fn downscale_image(img: &Image, factor: usize) -> Image {
    if factor <= 1 {
        return img.clone();
    }
    let (w, h) = (img.width / factor, img.height / factor);
    let mut out = Image::new(w, h);
    let n = (factor * factor) as f64;
    for y in 0..h {
        for x in 0..w {
            let mut s = glam::DVec3::ZERO;
            for dy in 0..factor {
                let row = (y * factor + dy) * img.width + x * factor;
                for p in &img.data[row..row + factor] {
                    s += p.as_dvec3();
                }
            }
            out.data[y * w + x] = (s / n).as_vec3();
        }
    }
    out
}

/// An id map shrunk by `factor`: each block takes the id at its centre (ids are not averaged).
pub fn downscale_ids(ids: &[i64], width: usize, height: usize, factor: usize) -> Vec<i64> {
    if factor <= 1 {
        return ids.to_vec();
    }
    let (w, h) = (width / factor, height / factor);
    let c = factor / 2;
    (0..w * h)
        .map(|i| ids[(i / w * factor + c) * width + (i % w) * factor + c])
        .collect()
}

/// Reads a view's mask of pixels to keep (`true`) at its stored size: any channel of a PNG,
/// JPEG or EXR that is 0 leaves the pixel out. Shrunk by `factor`, a block is kept only when
/// all its pixels are.
pub fn read_mask(path: &Path, width: usize, height: usize, factor: usize) -> Result<Vec<bool>> {
    let keep: Vec<bool> = if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
    {
        let img = Image::read_exr(path)?;
        check_mask_size(path, img.width, img.height, width, height)?;
        img.data.iter().map(|p| p.x > 0.0).collect()
    } else {
        let img = image::open(path)
            .map_err(|e| CoreError::invalid(path, format!("cannot read the mask: {e}")))?
            .into_luma8();
        check_mask_size(
            path,
            img.width() as usize,
            img.height() as usize,
            width,
            height,
        )?;
        img.pixels().map(|p| p.0[0] > 0).collect()
    };
    if factor <= 1 {
        return Ok(keep);
    }
    let (w, h) = (width / factor, height / factor);
    Ok((0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            (0..factor).all(|dy| {
                let row = (y * factor + dy) * width + x * factor;
                keep[row..row + factor].iter().all(|&k| k)
            })
        })
        .collect())
}

fn check_mask_size(path: &Path, w: usize, h: usize, ew: usize, eh: usize) -> Result<()> {
    if (w, h) != (ew, eh) {
        return Err(CoreError::SizeMismatch {
            path: path.to_path_buf(),
            got_w: w,
            got_h: h,
            expected_w: ew,
            expected_h: eh,
            hint: "a mask must have the size of its view's image".into(),
        });
    }
    Ok(())
}

/// The mask of view `k` of FIPT's layouts, when there is one: `Mask/{k:03}_0001.{png,jpg,exr}`
/// beside `Image/`.
pub fn fipt_mask(split_dir: &Path, k: usize) -> Option<PathBuf> {
    let base = split_dir
        .join("Mask")
        .join(crate::dataset::image_file_name(k));
    ["png", "jpg", "jpeg", "exr"]
        .iter()
        .map(|e| base.with_extension(e))
        .find(|p| p.is_file())
}

/// The convention FIPT's synthetic layout's `train/transforms.json` is taken in, and why; an
/// error when the file is a nerfstudio / instant-ngp one (OpenGL poses) put in its place.
pub fn check_fipt_transforms(root: &Path) -> Result<String> {
    let path = root.join("train/transforms.json");
    if let Some(why) = crate::nerfstudio::looks_like_nerfstudio(&path)? {
        return Err(CoreError::invalid(
            &path,
            format!(
                "this is a nerfstudio / instant-ngp transforms.json ({why}): its poses are OpenGL camera-to-world \
                 (+X right, +Y up, looking along −Z), not the Mitsuba convention of FIPT's synthetic layout. \
                 Put it at the scene's root as transforms.json (with the images where its file_path says) to read it as nerfstudio"
            ),
        ));
    }
    let v: serde_json::Value = crate::fsutil::read_json(&path)?;
    Ok(match v.get("camera_convention").and_then(|c| c.as_str()) {
        Some(c) => format!("FIPT synthetic layout; train/transforms.json states its convention: {c}"),
        None => "FIPT synthetic layout; train/transforms.json states no convention: taken as the layout's, \
                 Mitsuba camera-to-world (+X left, +Y up, +Z forward)"
            .into(),
    })
}

/// Whether a FIPT `transforms.json` left its convention unsaid (see
/// [`check_fipt_transforms`]): then a run tests the other reading on the views' edges.
pub fn convention_unstated(description: Option<&str>) -> bool {
    description.is_some_and(|d| d.contains("states no convention"))
}

/// Views smaller than this many pixels after `--downscale` are named: few pixels a surface.
pub const SMALL_VIEW_PIXELS: usize = 128 * 96;

/// What a user should know of views read at 1/`factor` of their `stored` size, `read` (their
/// size after it): the rows and columns a factor that does not divide the size leaves out, and
/// views so small that surfaces get few pixels.
pub fn downscale_notes(stored: (usize, usize), read: (usize, usize), factor: usize) -> Vec<String> {
    let mut notes = vec![];
    if factor <= 1 {
        return notes;
    }
    let (cut_w, cut_h) = (stored.0 % factor, stored.1 % factor);
    if cut_w > 0 || cut_h > 0 {
        notes.push(format!(
            "--downscale {factor}: the {}x{} photos are not a multiple of {factor}: their last {cut_w} column(s) and {cut_h} row(s) are left out (the views are read at {}x{})",
            stored.0, stored.1, read.0, read.1
        ));
    }
    if read.0 * read.1 < SMALL_VIEW_PIXELS {
        notes.push(format!(
            "--downscale {factor} leaves views of {}x{} pixels: few pixels a surface for its material, and a small light may vanish; a smaller factor keeps more",
            read.0, read.1
        ));
    }
    notes
}

/// The splits as a run sees them after a downscale by `factor`: cameras shrunk, the size
/// divided (an error when a view would be under 4 pixels on a side).
pub fn downscaled(
    splits: Vec<Split>,
    width: usize,
    height: usize,
    factor: usize,
    root: &Path,
) -> Result<(Vec<Split>, usize, usize)> {
    if factor <= 1 {
        return Ok((splits, width, height));
    }
    let (w, h) = (width / factor, height / factor);
    if w < 4 || h < 4 {
        return Err(CoreError::invalid(
            root,
            format!("a downscale of {factor} makes the {width}x{height} views {w}x{h}: choose a smaller factor"),
        ));
    }
    let splits = splits
        .into_iter()
        .map(|mut s| {
            for v in &mut s.views {
                v.camera = v.camera.downscaled(factor);
            }
            s
        })
        .collect();
    Ok((splits, w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_downscale_names_what_it_cuts_and_views_left_small() {
        assert!(downscale_notes((640, 480), (640, 480), 1).is_empty());
        assert!(downscale_notes((4032, 3024), (504, 378), 8).is_empty());
        let n = downscale_notes((160, 120), (22, 17), 7);
        assert_eq!(n.len(), 2, "{n:?}");
        assert!(
            n[0].contains("last 6 column(s) and 1 row(s)") && n[1].contains("22x17"),
            "{n:?}"
        );
        let n = downscale_notes((160, 120), (20, 15), 8);
        assert!(n.len() == 1 && n[0].contains("20x15"), "{n:?}");
    }
}
