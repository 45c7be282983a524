//! Which convention a file's poses are in, tested on the views' edges: a layout states its
//! convention, and a file in another one (a NeRF-style `transforms.json` fed as FIPT's, an
//! OpenCV one fed as nerfstudio's) would look the wrong way from every camera. The views'
//! edges line up with the mesh's from the true poses only; [`check_convention`] refuses a
//! reading that another fits far better, naming the fix.
use super::edges::edge_contrast;
use fipt_core::camera::PoseConvention;
use fipt_core::dataset::{Dataset, Layout, View};
use fipt_core::image::Image;
use fipt_geom::Geometry;
use glam::{Mat3, Vec3};
use serde::Serialize;

/// Camera-to-world conventions a pose file may be in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FileConvention {
    /// +X left, +Y up, +Z forward (Mitsuba; FIPT's synthetic layout).
    Mitsuba,
    /// +X right, +Y down, +Z forward (OpenCV, COLMAP).
    OpenCv,
    /// +X right, +Y up, looking along −Z (OpenGL; nerfstudio, instant-ngp, NeRF).
    OpenGl,
}

impl std::fmt::Display for FileConvention {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FileConvention::Mitsuba => "Mitsuba",
            FileConvention::OpenCv => "OpenCV",
            FileConvention::OpenGl => "OpenGL",
        })
    }
}

impl FileConvention {
    const ALL: [FileConvention; 3] = [
        FileConvention::Mitsuba,
        FileConvention::OpenCv,
        FileConvention::OpenGl,
    ];

    /// S with R_opencv = M · S for a camera-to-world rotation M in this convention.
    fn to_opencv(self) -> Mat3 {
        match self {
            FileConvention::OpenCv => Mat3::IDENTITY,
            FileConvention::OpenGl => Mat3::from_diagonal(Vec3::new(1.0, -1.0, -1.0)),
            FileConvention::Mitsuba => Mat3::from_diagonal(Vec3::new(-1.0, -1.0, 1.0)),
        }
    }
}

/// `report.json`'s `capture.convention`: the poses' convention as read and the edge contrast
/// (median over the views tested) of each reading.
#[derive(Clone, Debug, Serialize)]
pub struct ConventionCheck {
    pub read_as: FileConvention,
    pub contrast: Vec<(FileConvention, f32)>,
    pub views_tested: usize,
}

/// A reading is refused when another's edge contrast exceeds its own by this factor.
const REFUSE_RATIO: f32 = 1.5;
/// The layout's reading is unclear (a warning) when it does not beat every other by this
/// factor: a capture whose poses and mesh agree measured 1.24 (5 mm pose noise) and 1.55 over
/// the next reading; a mesh turned 90° out of the poses' frame 0.96.
const CLEAR_RATIO: f32 = 1.05;

impl ConventionCheck {
    /// A warning when no reading of the poses lines the views' edges up with the mesh's
    /// better than the others: the mesh and the poses are likely in different frames. Only for
    /// a capture's nerfstudio file and [`VIEWS_TESTED`] views: FIPT's synthetic layout is a
    /// render of its own mesh, whose other readings turn the image (a box nearly matches
    /// itself: 1.29 against 1.32 on a 24×16 `cornell` of 3 views).
    pub fn unclear(&self, layout: Layout) -> Option<String> {
        if layout != Layout::Nerfstudio || self.views_tested < VIEWS_TESTED {
            return None;
        }
        let own = self.contrast.iter().find(|c| c.0 == self.read_as)?.1;
        let (other, c) = (self.contrast.iter())
            .filter(|c| c.0 != self.read_as)
            .max_by(|a, b| a.1.total_cmp(&b.1))?;
        // Another reading far better is the refusal's case, not this one.
        (own < CLEAR_RATIO * c && *c <= REFUSE_RATIO * own).then(|| {
            format!(
                "train: no reading of the poses lines the views' edges up with the mesh's: edge contrast {own:.2} as {}, the layout's, against {c:.2} as {other} (median of {} views; poses and mesh that agree score about 1.25–1.6 times the next reading): the mesh is probably in another frame than the poses (a scan not aligned to the structure-from-motion model, an applied_transform, another scale), or the poses are far off",
                self.read_as, self.views_tested
            )
        })
    }
}
/// Views tested (evenly spaced over the training views).
const VIEWS_TESTED: usize = 8;

/// The convention a layout reads its pose file in, when the file could be in another (FIPT's
/// synthetic `transforms.json`, nerfstudio's); None for layouts whose files cannot be
/// confused (COLMAP's world-to-camera model, the real layout's look-at list).
pub fn read_as(layout: Layout) -> Option<FileConvention> {
    match layout {
        Layout::Synthetic => Some(FileConvention::Mitsuba),
        Layout::Nerfstudio => Some(FileConvention::OpenGl),
        Layout::Real | Layout::Colmap => None,
    }
}

/// Tests the training views' poses read as their layout says against the other conventions;
/// an error naming the file and the fix when another fits the edges far better.
pub fn check_convention(
    geometry: &Geometry,
    ds: &Dataset,
    images: &[Image],
) -> crate::error::Result<Option<ConventionCheck>> {
    match test_convention(geometry, ds, images) {
        (_, Some(refusal)) => crate::bail!("{refusal}"),
        (check, None) => Ok(check),
    }
}

/// The convention test of [`check_convention`]: what each reading scored, and the refusal's
/// message when another reading fits far better.
pub fn test_convention(
    geometry: &Geometry,
    ds: &Dataset,
    images: &[Image],
) -> (Option<ConventionCheck>, Option<String>) {
    let Some(read) = read_as(ds.layout) else {
        return (None, None);
    };
    let split = ds.train();
    let n = split.views.len();
    let picks: Vec<usize> = (0..VIEWS_TESTED.min(n))
        .map(|i| i * n / VIEWS_TESTED.min(n))
        .collect();
    let imgs: Vec<Image> = picks.iter().map(|&k| images[k].clone()).collect();
    let mut contrast = vec![];
    for conv in FileConvention::ALL {
        let views: Vec<View> = picks
            .iter()
            .map(|&k| reread(&split.views[k], read, conv))
            .collect();
        let mut c: Vec<f32> = edge_contrast(geometry, &views, &imgs)
            .into_iter()
            .flatten()
            .collect();
        let median = if c.is_empty() {
            0.0
        } else {
            fipt_core::image::median(&mut c)
        };
        contrast.push((conv, median));
    }
    let own = contrast.iter().find(|c| c.0 == read).map_or(0.0, |c| c.1);
    let best = contrast
        .iter()
        .copied()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .filter(|b| b.0 != read && b.1 > REFUSE_RATIO * own);
    let refusal = best.map(|(conv, c)| {
        format!(
            "{}: the poses fit the mesh's edges far better read as {conv} camera-to-world than as {read}, the layout's \
             (edge contrast {c:.2} against {own:.2}, median of {} views): every camera would look the wrong way. {}",
            split.cameras_file.display(),
            picks.len(),
            fix(ds.layout, conv)
        )
    });
    let check = ConventionCheck {
        read_as: read,
        contrast,
        views_tested: picks.len(),
    };
    (Some(check), refusal)
}

/// The view with its pose file's matrix re-read in convention `conv` instead of `read`.
fn reread(view: &View, read: FileConvention, conv: FileConvention) -> View {
    let mut v = view.clone();
    let cam = &mut v.camera;
    // The camera's rotation in OpenCV axes, and back to the camera's own storage.
    let stored_to_cv = match cam.convention {
        PoseConvention::OpenCv => Mat3::IDENTITY,
        PoseConvention::Mitsuba => FileConvention::Mitsuba.to_opencv(),
    };
    let r_cv = cam.rotation * stored_to_cv;
    let r_cv = r_cv * read.to_opencv() * conv.to_opencv();
    cam.rotation = r_cv * stored_to_cv;
    v
}

fn fix(layout: Layout, conv: FileConvention) -> String {
    match (layout, conv) {
        (Layout::Synthetic, FileConvention::OpenGl) => "This looks like a NeRF / instant-ngp transforms.json: put it at the scene's root as \
             transforms.json (read as nerfstudio, OpenGL), or multiply each transform_matrix on the right by diag(-1, 1, -1, 1) \
             to make it Mitsuba's".into(),
        (Layout::Synthetic, _) => "Write OpenCV poses as the real layout (cam.txt + K_list.txt), or multiply each transform_matrix \
             on the right by diag(-1, -1, 1, 1) to make it Mitsuba's".into(),
        (_, FileConvention::OpenCv) => "These look like OpenCV camera-to-world poses: multiply each transform_matrix on the right \
             by diag(1, -1, -1, 1) to make them OpenGL's, as nerfstudio expects".into(),
        _ => "These look like Mitsuba camera-to-world poses (FIPT's synthetic layout): put the file in train/ \
             with its images in train/Image/, or multiply each transform_matrix on the right by diag(-1, 1, -1, 1) \
             to make them OpenGL's".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fipt_core::camera::Camera;

    #[test]
    fn rereading_in_the_same_convention_changes_nothing_and_the_others_turn_the_camera() {
        let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 1.0, 8, 6);
        let view = View {
            index: 0,
            camera: cam.clone(),
            image: "x".into(),
            mask: None,
        };
        let same = reread(&view, FileConvention::Mitsuba, FileConvention::Mitsuba);
        assert!((same.camera.rotation - cam.rotation).abs_diff_eq(Mat3::ZERO, 1e-7));
        // Read as OpenGL, a Mitsuba matrix looks backwards.
        let gl = reread(&view, FileConvention::Mitsuba, FileConvention::OpenGl);
        assert!((gl.camera.forward() + cam.forward()).length() < 1e-6);
        // Read as OpenCV, it looks the same way, upside down.
        let cv = reread(&view, FileConvention::Mitsuba, FileConvention::OpenCv);
        assert!((cv.camera.forward() - cam.forward()).length() < 1e-6);
        let (_, up) = cam.pixel_center_ray(4, 0);
        let (_, down) = cv.camera.pixel_center_ray(4, 0);
        assert!(up.y > 0.0 && down.y < 0.0);
    }
}
