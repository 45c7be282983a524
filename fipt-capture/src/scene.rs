//! Loading a scene folder for the stages: dataset, geometry, training images, fingerprint.
use crate::capture::CaptureConfig;
use crate::error::{Context, Result};
use crate::observe::Stage;
use fipt_core::dataset::Dataset;
use fipt_core::fit::FitInputs;
use fipt_core::image::{BadPixelPolicy, Image};
use fipt_core::shading::RayQuery;
use fipt_geom::{Geometry, Mesh};
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

pub struct LoadedScene {
    pub ds: Dataset,
    pub geometry: Geometry,
    pub images: Vec<Image>,
    /// Fingerprint of the mesh, the training cameras and images.
    pub inputs_hash: String,
    /// The views' exposure scale s (`fipt_core::image::exposure_scale`: their median luminance
    /// / 0.18): `images` hold the views / s, and radiance results are multiplied by s where
    /// they are written.
    pub exposure: f32,
    /// What the stages' caches key on: the inputs' fingerprint and the exposure scale (the
    /// stages see images / exposure).
    pub cache_key: String,
    /// The views as a capture: LDR or not, clipped pixels, fitted exposures, warnings.
    pub capture: crate::capture::CaptureReport,
}

/// A loaded scene, borrowed: what FIPT's stages and the run's outputs read, from a
/// [`LoadedScene`] or from a fit's inputs ([`FitInputs::scene`], under any host that fills it).
/// Geometry only through [`RayQuery`] and the mesh's arrays.
#[derive(Clone, Copy)]
pub struct SceneRef<'a> {
    /// Every split, the image size, the ground truth when the scene has it.
    pub ds: &'a Dataset,
    pub geometry: &'a dyn RayQuery,
    /// The mesh's vertex positions and triangles (what triangle ids index).
    pub positions: &'a [Vec3],
    pub triangles: &'a [[u32; 3]],
    /// The training views' images / `exposure`, in the training split's order.
    pub images: &'a [Image],
    /// What the stages' caches key on.
    pub cache_key: &'a str,
    pub exposure: f32,
    /// Per training view and pixel: clipped pixels the material loss leaves out, and pixels
    /// the view's mask leaves out (each empty when there are none).
    pub left_out: &'a [Vec<bool>],
    pub masked: &'a [Vec<bool>],
}

impl<'a> SceneRef<'a> {
    /// The scene of a fit's inputs; None when the host gave no [`FitInputs::scene`].
    pub fn of(inputs: &FitInputs<'a>) -> Option<Self> {
        let s = inputs.scene?;
        Some(SceneRef {
            ds: s.dataset,
            geometry: inputs.geometry,
            positions: inputs.positions,
            triangles: inputs.triangles,
            images: inputs.images,
            cache_key: s.cache_key,
            exposure: s.exposure,
            left_out: s.left_out,
            masked: s.masked,
        })
    }

    /// A loaded scene, borrowed.
    pub fn loaded(s: &'a LoadedScene) -> Self {
        SceneRef {
            ds: &s.ds,
            geometry: &s.geometry,
            positions: &s.geometry.mesh.positions,
            triangles: &s.geometry.mesh.triangles,
            images: &s.images,
            cache_key: &s.cache_key,
            exposure: s.exposure,
            left_out: &s.capture.left_out,
            masked: &s.capture.masked,
        }
    }
}

/// The fingerprint of a scene's inputs: the mesh, the training cameras and images (what every
/// stage's cache and `report.json` key on).
pub fn inputs_hash(ds: &Dataset) -> Result<String> {
    let split = ds.train();
    let mut files = vec![ds.mesh.clone(), split.cameras_file.clone()];
    // A capture layout's other camera files (COLMAP's cameras and images), and the masks.
    files.extend(
        ds.camera_files
            .iter()
            .filter(|f| **f != split.cameras_file)
            .cloned(),
    );
    files.extend(split.views.iter().filter_map(|v| v.mask.clone()));
    // The real layout's intrinsics and the capture's response and exposures shape the inputs.
    for name in ["K_list.txt", fipt_core::capture::CAPTURE_FILE] {
        let f = ds.root.join(name);
        if f.is_file() {
            files.push(f);
        }
    }
    files.extend(split.views.iter().map(|v| v.image.clone()));
    let hash = fipt_core::fsutil::hash_files(&files)?;
    Ok(if ds.downscale > 1 {
        format!("{hash}@downscale:{}", ds.downscale)
    } else {
        hash
    })
}

/// What the stages' caches must also key on when the views were decoded or restored by what
/// the run estimated (a fitted response, clipped lights' radiances): empty otherwise.
fn decoding_tag(c: &crate::capture::CaptureReport) -> String {
    let mut tag = String::new();
    if let Some(r) = c.response.as_ref().filter(|r| r.applied) {
        tag += &format!(
            "@response:{}",
            fipt_core::fsutil::hash_bytes(format!("{:?}", r.linear).as_bytes())
        );
    }
    if let Some(x) = c.contrast.as_ref().filter(|x| x.applied) {
        tag += &format!("@contrast:{:e}", x.gamma);
    }
    if let Some(l) = &c.clipped_lights {
        let radiances: Vec<[f32; 3]> = l.estimates.iter().map(|e| e.radiance).collect();
        tag += &format!(
            "@lights:{}",
            fipt_core::fsutil::hash_bytes(format!("{radiances:?}").as_bytes())
        );
    }
    tag
}

/// Loads the scene at `root` for the stages as `capture` says (`[capture]`: its downscale, and
/// when views are shifted onto the mesh; the stages' caches key on both).
pub fn load(root: &Path, policy: BadPixelPolicy, cfg: &CaptureConfig) -> Result<LoadedScene> {
    let st = Stage::start("load scene");
    let ds = Dataset::open_with(root, cfg.open_options())
        .with_context(|| format!("opening scene {}", root.display()))?;
    let mesh = Mesh::load(&ds.mesh).context("loading the scene mesh")?;
    if mesh.dropped_degenerate > 0 {
        crate::note!(
            "note: {} degenerate triangles dropped from {}",
            mesh.dropped_degenerate,
            ds.mesh.display()
        );
    }
    let geometry = Geometry::new(mesh);
    let split = ds.train();
    let images = split
        .views
        .par_iter()
        .map(|v| ds.load_image(v, policy).map(|(img, _)| img))
        .collect::<Result<Vec<_>, _>>()
        .context("reading the training images")?;
    let mut images = images;
    for (k, img) in images.iter_mut().enumerate() {
        let e = ds.view_exposure(k);
        if e != 1.0 {
            img.data.iter_mut().for_each(|p| *p /= e);
        }
    }
    let convention = crate::capture::check_convention(&geometry, &ds, &images)?;
    let masks = load_masks(&ds)?;
    let mut capture = crate::capture::examine(&geometry, &ds, &mut images, cfg.align_views, &masks);
    let (said, black, coverage) = as_info_says(&ds, &geometry, &images, convention.as_ref());
    capture.warnings.splice(0..0, said);
    capture.coverage = coverage;
    capture.exposures_known = ds.known_exposures().is_some();
    capture.exif = crate::capture::ExifReport::of(&ds, capture.exposure_fit.as_ref());
    capture.warnings.extend(capture.exif.warning.clone());
    capture.convention = convention;
    capture.cameras = ds.cameras_description.clone();
    if let Some(c) = &capture.cameras {
        crate::note!("cameras: {c}");
    }
    if let Some(c) = &capture.convention {
        let scores: Vec<String> = c
            .contrast
            .iter()
            .map(|(k, s)| format!("{k} {s:.2}"))
            .collect();
        crate::note!(
            "cameras: poses read as {}; edge contrast per reading {}",
            c.read_as,
            scores.join(", ")
        );
    }
    if cfg.light_contrast && crate::contrast::asks_for_it(&ds, &capture) {
        crate::contrast::fit_and_apply(&geometry, &split.views, &mut images, &masks, &mut capture);
    }
    crate::capture::restore_clipped_lights(&geometry, &split.views, &mut images, &mut capture);
    crate::capture::leave_out_masked(&mut capture, &masks);
    leave_out_black(&mut capture, &images, &black);
    for w in &capture.warnings {
        crate::note!("warning: {w}");
    }
    let median = fipt_core::image::median_luminance(&images);
    let exposure = fipt_core::image::exposure_scale(median);
    if !(0.5..=2.0).contains(&exposure) {
        crate::note!(
            "note: the views' median luminance is {median:.3e}: working at 1/{exposure:.3e} of their scale (radiance results are scaled back)"
        );
    }
    if exposure != 1.0 {
        for img in &mut images {
            for p in &mut img.data {
                *p /= exposure;
            }
        }
    } else if median == 0.0 {
        crate::note!("warning: the median training pixel is black: most views are dark or black");
    }
    let inputs_hash = inputs_hash(&ds)?;
    let mut cache_key = if exposure == 1.0 {
        inputs_hash.clone()
    } else {
        format!("{inputs_hash}@exposure:{exposure:e}")
    };
    cache_key += &capture.alignment.cache_tag(&capture.edges);
    cache_key += &decoding_tag(&capture);
    st.done();
    Ok(LoadedScene {
        ds,
        geometry,
        images,
        inputs_hash,
        exposure,
        cache_key,
        capture,
    })
}

/// What `fipt info` says of the layout (its notes), the cameras' placement against the mesh
/// and an unclear pose convention, said by the run too; the black views, and each view's
/// coverage.
#[allow(clippy::type_complexity)]
fn as_info_says(
    ds: &Dataset,
    geometry: &Geometry,
    images: &[Image],
    convention: Option<&crate::capture::ConventionCheck>,
) -> (Vec<String>, Vec<usize>, Vec<f32>) {
    let mut said = ds.warnings.clone();
    let b = geometry.mesh.bounds();
    let placed =
        crate::placement::placement(&geometry.bvh, (b.max - b.min).length(), &ds.train().views);
    said.extend(crate::placement::warnings("train", &placed));
    let black: Vec<usize> = (images.iter().enumerate())
        .filter(|(_, img)| img.is_black())
        .map(|(k, _)| k)
        .collect();
    said.extend(convention.and_then(|c| c.unclear(ds.layout)));
    (said, black, placed.coverage)
}

/// Leaves the `black` views out of the materials' fit and the search (as masked): a lens cap,
/// or an exposure far too short, would pull every surface they see towards black.
fn leave_out_black(capture: &mut crate::capture::CaptureReport, images: &[Image], black: &[usize]) {
    if black.is_empty() {
        return;
    }
    capture.left_out.resize(images.len(), vec![]);
    capture.masked.resize(images.len(), vec![]);
    for &k in black {
        capture.left_out[k] = vec![true; images[k].data.len()];
        capture.masked[k] = vec![true; images[k].data.len()];
    }
    capture.warnings.push(format!(
        "train: black views {black:?} (no pixel above 0: a lens cap, or an exposure far too short?) are left out of the materials' fit and the search"
    ));
}

/// The training views' masks (pixels to keep), None for a view without one; empty when no
/// view has one.
fn load_masks(ds: &Dataset) -> Result<Vec<Option<Vec<bool>>>> {
    let views = &ds.train().views;
    if views.iter().all(|v| v.mask.is_none()) {
        return Ok(vec![]);
    }
    views
        .par_iter()
        .map(|v| ds.load_mask(v))
        .collect::<Result<Vec<_>, _>>()
        .context("reading the training views' masks")
}

/// Refuses, before any work, training views none of whose rays hits the mesh (poses in another
/// convention, or another scene's mesh), and warns of single views that see nothing.
pub fn check_coverage(scene: &LoadedScene) -> Result<()> {
    let views = &scene.ds.train().views;
    // Measured by the load (`placement`) where it ran.
    let cover: Vec<f32> = if scene.capture.coverage.len() == views.len() {
        scene.capture.coverage.clone()
    } else {
        (views.par_iter())
            .map(|v| fipt_geom::view_coverage(&scene.geometry.bvh, &v.camera, 8))
            .collect()
    };
    if cover.iter().all(|&c| c == 0.0) {
        crate::bail!(
            "no camera ray of any training view hits the mesh {}: the poses are probably in another convention \
             (transforms.json expects camera-to-world with +X left, +Y up, +Z forward) or the mesh is not the scene's (`fipt info` shows the coverage per view)",
            scene.ds.mesh.display()
        );
    }
    let blind: Vec<usize> = (0..cover.len()).filter(|&k| cover[k] == 0.0).collect();
    if !blind.is_empty() {
        crate::note!("warning: training views {blind:?} see none of the mesh: they are ignored");
    }
    Ok(())
}

/// How the run whose `report.json` is `report` read its scene (`[capture] downscale`).
pub fn open_options_of(report: &serde_json::Value) -> fipt_core::capture_layout::OpenOptions {
    let n = report["settings"]["capture"]["downscale"]
        .as_u64()
        .unwrap_or(1);
    fipt_core::capture_layout::OpenOptions {
        downscale: (n as usize).max(1),
    }
}

/// How the run in `out` read its scene (as stored when its report cannot be read).
pub fn run_open_options(out: &Path) -> fipt_core::capture_layout::OpenOptions {
    fipt_core::fsutil::read_json::<serde_json::Value>(&out.join("report.json"))
        .map(|r| open_options_of(&r))
        .unwrap_or_default()
}
