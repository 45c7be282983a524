//! The checks a scene folder's files get when it is opened: the mesh found (or the meshes it
//! holds under other names named), every view's image present (or a name that differs in
//! letter case only named) and of one size with the camera that declares it.
use crate::dataset::{Split, IMAGE_EXTENSIONS, MESH_NAMES};
use crate::error::{CoreError, Result};
use std::path::{Path, PathBuf};

/// Size of a view's image (EXR, PNG or JPEG) from its header alone.
pub fn image_size(path: &Path) -> Result<(usize, usize)> {
    if crate::capture::is_ldr_file(path) {
        crate::capture::ldr_size(path)
    } else {
        exr_size(path)
    }
}

/// Size of an EXR image from its header alone.
pub fn exr_size(path: &Path) -> Result<(usize, usize)> {
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| match e {
        exr::error::Error::Io(io) => CoreError::io(path, io),
        other => CoreError::Exr {
            path: path.to_path_buf(),
            message: other.to_string(),
        },
    })?;
    let h = meta.headers.first().ok_or_else(|| CoreError::Exr {
        path: path.to_path_buf(),
        message: "no layer".into(),
    })?;
    Ok((h.layer_size.width(), h.layer_size.height()))
}

/// The scene's mesh at `root` ([`MESH_NAMES`]); the error names the meshes the folder holds
/// under other names.
pub(crate) fn find_mesh(root: &Path) -> Result<PathBuf> {
    MESH_NAMES
        .iter()
        .map(|n| root.join(n))
        .find(|p| p.is_file())
        .ok_or_else(|| {
            let others: Vec<String> = std::fs::read_dir(root)
                .into_iter()
                .flatten()
                .filter_map(|e| e.ok()?.file_name().into_string().ok())
                .filter(|n| {
                    let n = n.to_lowercase();
                    (MESH_NAMES.iter()).any(|m| {
                        m.rsplit_once('.')
                            .is_some_and(|(_, e)| n.ends_with(&format!(".{e}")))
                    })
                })
                .collect();
            let hint = if others.is_empty() {
                String::new()
            } else {
                format!(
                    "; found {}: rename the scene's mesh (or link it) to one of those names",
                    others.join(", ")
                )
            };
            CoreError::invalid(
                root,
                format!("no mesh found: expected one of {MESH_NAMES:?}{hint}"),
            )
        })
}

/// A file beside `path` whose name differs from its name in letter case only.
fn same_name_but_case(path: &Path) -> Option<PathBuf> {
    let name = path.file_name()?.to_str()?.to_lowercase();
    std::fs::read_dir(path.parent()?)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.to_lowercase() == name)
        })
}

/// The views' common size; an error naming the missing images (and how each kind of layout
/// names them, `reference`: FIPT's two), or two views of different sizes.
pub(crate) fn check_image_sizes(splits: &[Split], reference: bool) -> Result<(usize, usize)> {
    let mut missing = Vec::new();
    for s in splits {
        for v in &s.views {
            if !v.image.is_file() {
                missing.push(v.image.clone());
            }
        }
    }
    if !missing.is_empty() {
        let list: Vec<String> = missing
            .iter()
            .take(5)
            .map(|p| p.display().to_string())
            .collect();
        let how = match same_name_but_case(&missing[0]) {
            Some(f) => format!(
                "{} is there: file names are case-sensitive, so rename the photos or the names in the camera file",
                f.display()
            ),
            None if reference => format!(
                "in FIPT's layouts `Image/NNN_0001` may be any of {}; put the photographs in place, or remove their views from the cameras file",
                IMAGE_EXTENSIONS.map(|e| format!(".{e}")).join(", ")
            ),
            None => "the camera file names them; put the photographs in place, or remove their views from the camera file".into(),
        };
        return Err(CoreError::invalid(
            &missing[0],
            format!(
                "{} input image(s) missing: {}{} ({how})",
                missing.len(),
                list.join(", "),
                if missing.len() > 5 { ", …" } else { "" },
            ),
        ));
    }
    let first = &splits[0]
        .views
        .first()
        .ok_or_else(|| CoreError::invalid(&splits[0].cameras_file, "no views"))?
        .image;
    let (w, h) = image_size(first)?;
    for s in splits {
        for v in &s.views {
            let (vw, vh) = image_size(&v.image)?;
            if (vw, vh) != (w, h) {
                return Err(CoreError::SizeMismatch {
                    path: v.image.clone(),
                    got_w: vw,
                    got_h: vh,
                    expected_w: w,
                    expected_h: h,
                    hint: if (v.camera.width, v.camera.height) == (vw, vh) {
                        // The camera model agrees with the photo: another camera, a portrait.
                        format!(
                            "{} is {w}x{h}; views of different sizes (a second camera, portrait photos) cannot share one scene: leave this view out of the camera file, or bring every photo and its camera to one size",
                            first.display()
                        )
                    } else {
                        format!(
                            "{} is {w}x{h}{}; all views must have one size: resize this photo to {w}x{h}, or leave its view out of the camera file",
                            first.display(),
                            if (v.camera.width, v.camera.height) == (w, h) {
                                ", as the camera model declares for this view"
                            } else {
                                ""
                            }
                        )
                    },
                });
            }
            if (v.camera.width, v.camera.height) != (w, h) {
                return Err(CoreError::SizeMismatch {
                    path: v.image.clone(),
                    got_w: vw,
                    got_h: vh,
                    expected_w: v.camera.width,
                    expected_h: v.camera.height,
                    hint: format!(
                        "the size declared in {}: export the camera model for the photos as they are",
                        s.cameras_file.display()
                    ),
                });
            }
        }
    }
    Ok((w, h))
}
