//! A scene folder summarised and checked before any work (`fipt info`): the layout, the mesh,
//! per split the views' HDR range and how much of each view the mesh covers, the ground truth
//! present, and warnings (degenerate triangles, views that see nothing, bad pixels, black or
//! saturated views). A scene no camera ray hits is an error.
use crate::bail;
pub use crate::capture::ldr_warnings;
use crate::error::{Context, Result};
use fipt_core::dataset::{Dataset, Layout};
use fipt_core::image::BadPixelPolicy;
use fipt_core::view_stats::{hdr_stats, HdrStats};
use fipt_geom::{BuildQuality, Bvh, Mesh};
use glam::Vec3;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// One split of a scene.
#[derive(Clone, Debug, Serialize)]
pub struct SplitSummary {
    pub name: String,
    pub views: usize,
    /// Horizontal field of view of the first view, degrees.
    pub fov_x_deg: f32,
    pub hdr: HdrStats,
    /// Share of pixel-centre rays that hit the mesh: mean over views, lowest and its view.
    pub coverage_mean: f32,
    pub coverage_min: f32,
    pub coverage_min_view: usize,
    /// The ground-truth folders present.
    pub ground_truth: Vec<&'static str>,
}

/// A scene folder, summarised.
#[derive(Clone, Debug, Serialize)]
pub struct SceneSummary {
    pub scene: PathBuf,
    pub layout: Layout,
    pub mesh: PathBuf,
    pub triangles: usize,
    pub vertices: usize,
    pub vertex_normals: bool,
    pub degenerate_dropped: usize,
    pub bounds: [[f32; 3]; 2],
    pub width: usize,
    pub height: usize,
    /// The camera files: what they are and the convention they state.
    pub cameras: Option<String>,
    /// The views' lens models, with how many views have each.
    pub lenses: Vec<(String, usize)>,
    /// Views shrunk by this factor on read (`--downscale`).
    pub downscale: usize,
    /// Training views with a mask of pixels to leave out.
    pub masked_views: usize,
    /// The poses' convention tested on the edges, and the reading refused (if any).
    pub convention: Option<crate::capture::ConventionCheck>,
    /// What the photos' EXIF says of their exposures.
    pub exif: crate::capture::ExifReport,
    /// The camera's response estimated from the views (8-bit views, no stated response).
    pub response: Option<crate::capture::ResponseFit>,
    pub splits: Vec<SplitSummary>,
    /// The training views' exposures fitted on the surfaces they share.
    pub exposure_fit: Option<crate::capture::GainFit>,
    /// How well the mesh's edges line up with the training views'.
    pub edges: crate::capture::EdgeCheck,
    pub warnings: Vec<String>,
}

impl SceneSummary {
    /// The bounds' diagonal.
    pub fn extent(&self) -> f32 {
        (Vec3::from(self.bounds[1]) - Vec3::from(self.bounds[0])).length()
    }
}

/// Opens `scene`, reads every image (bad pixels as `policy` says) and checks the views
/// against the mesh.
pub fn inspect(
    scene: &Path,
    policy: BadPixelPolicy,
    opts: fipt_core::capture_layout::OpenOptions,
) -> Result<SceneSummary> {
    let ds = Dataset::open_with(scene, opts)
        .with_context(|| format!("opening scene {}", scene.display()))?;
    let mut warnings = ds.warnings.clone();
    let mesh = Mesh::load(&ds.mesh).with_context(|| "loading the scene mesh")?;
    if mesh.dropped_degenerate > 0 {
        warnings.push(format!(
            "{}: {} degenerate triangles dropped (zero area, repeated or invalid vertices)",
            ds.mesh.display(),
            mesh.dropped_degenerate
        ));
    }
    let bvh = Bvh::build(&mesh, BuildQuality::Medium);
    let mut splits = Vec::new();
    for s in &ds.splits {
        let hdr =
            hdr_stats(&ds, s, policy).with_context(|| format!("reading the {} images", s.name))?;
        let placed = crate::placement::placement(
            &bvh,
            (mesh.bounds().max - mesh.bounds().min).length(),
            &s.views,
        );
        let cover = &placed.coverage;
        let (coverage_min, coverage_min_view) = cover.iter().enumerate().fold(
            (1.0f32, 0usize),
            |acc, (k, &c)| if c < acc.0 { (c, k) } else { acc },
        );
        warnings.extend(crate::placement::warnings(&s.name, &placed));
        warnings.extend(image_warnings(&s.name, &hdr));
        splits.push(SplitSummary {
            name: s.name.clone(),
            views: s.views.len(),
            fov_x_deg: s.views[0].camera.fov_x().to_degrees(),
            hdr,
            coverage_mean: cover.iter().sum::<f32>() / cover.len().max(1) as f32,
            coverage_min,
            coverage_min_view,
            ground_truth: s.gt.iter().map(|g| g.folder()).collect(),
        });
    }
    if !splits.iter().any(|s| s.coverage_mean > 0.0) {
        bail!(
            "no camera ray of any view hits the mesh {}: the poses are probably in another convention \
             (transforms.json expects camera-to-world with +X left, +Y up, +Z forward) or the mesh is not the scene's",
            ds.mesh.display()
        );
    }
    let (capture, convention) = exposures(&ds, &mesh, policy, &mut warnings)?;
    warnings.extend(convention.as_ref().and_then(|c| c.unclear(ds.layout)));
    warnings.extend(capture.response_warning());
    if crate::contrast::asks_for_it(&ds, &capture) {
        warnings.push(
            "train: no exposure is known and no response stated, so the views fix the tone curve only up to a power: `fipt run` also looks for its contrast in the light transport (`[capture] light_contrast`, a few seconds), which `fipt info` does not; the run's report says what it found".into(),
        );
    }
    let (exposure_fit, edges, ldr) = (capture.exposure_fit, capture.edges, capture.check.ldr);
    let exif = crate::capture::ExifReport::of(&ds, exposure_fit.as_ref());
    warnings.extend(exif.warning.clone());
    warnings.extend(crate::capture::edge_warning(&edges));
    if let Some(f) = exposure_fit
        .as_ref()
        .filter(|f| f.spread > crate::capture::gain_spread_limit(ldr))
    {
        warnings.push(format!(
            "train: the views' exposures disagree on the surfaces they share: fitted gains spread ×{:.2} over {} surface cells (auto-exposure? `fipt run` divides LDR views by them)",
            f.spread, f.cells
        ));
    }
    let b = mesh.bounds();
    Ok(SceneSummary {
        scene: ds.root.clone(),
        layout: ds.layout,
        mesh: ds.mesh.clone(),
        triangles: mesh.triangles.len(),
        vertices: mesh.positions.len(),
        vertex_normals: mesh.normals.is_some(),
        degenerate_dropped: mesh.dropped_degenerate,
        bounds: [b.min.to_array(), b.max.to_array()],
        width: ds.width,
        height: ds.height,
        cameras: ds.cameras_description.clone(),
        lenses: lenses(&ds),
        downscale: ds.downscale,
        masked_views: ds.train().views.iter().filter(|v| v.mask.is_some()).count(),
        convention,
        exif,
        response: capture.response,
        splits,
        exposure_fit,
        edges,
        warnings,
    })
}

/// The training views examined as `fipt run` examines them (the response, the exposures with
/// the clipped pixels left out, how their edges line up with the mesh's), and the poses'
/// convention.
fn exposures(
    ds: &Dataset,
    mesh: &Mesh,
    policy: BadPixelPolicy,
    warnings: &mut Vec<String>,
) -> Result<(
    crate::capture::CaptureReport,
    Option<crate::capture::ConventionCheck>,
)> {
    let split = ds.train();
    let mut images = vec![];
    for (k, v) in split.views.iter().enumerate() {
        let mut img = ds.load_image(v, policy)?.0;
        let e = ds.view_exposure(k);
        if e != 1.0 {
            img.data.iter_mut().for_each(|p| *p /= e);
        }
        images.push(img);
    }
    let geometry = fipt_geom::Geometry::new(mesh.clone());
    let (convention, refused) = crate::capture::test_convention(&geometry, ds, &images);
    warnings.extend(refused);
    let masks = split
        .views
        .iter()
        .map(|v| ds.load_mask(v))
        .collect::<Result<Vec<_>, _>>()?;
    let report = crate::capture::examine(
        &geometry,
        ds,
        &mut images,
        crate::capture::AlignViews::Off,
        &masks,
    );
    Ok((report, convention))
}

/// The views' lens models ("pinhole", "opencv k1 -0.120 …"), with how many views have each.
fn lenses(ds: &Dataset) -> Vec<(String, usize)> {
    let mut out: Vec<(String, usize)> = vec![];
    for v in ds.splits.iter().flat_map(|s| &s.views) {
        let name = fipt_core::distortion::describe(&v.camera.distortion);
        match out.iter_mut().find(|(n, _)| *n == name) {
            Some(e) => e.1 += 1,
            None => out.push((name, 1)),
        }
    }
    out
}

/// What a split's images say that a user should know: clamped values, black and saturated
/// views.
fn image_warnings(split: &str, stats: &HdrStats) -> Vec<String> {
    let mut w = vec![];
    if stats.bad > 0 {
        w.push(format!(
            "{split}: {} bad pixel values clamped in views {:?}",
            stats.bad, stats.bad_views
        ));
    }
    w.extend(black_views_warning(split, &stats.black_views));
    w.extend(ldr_warnings(split, &stats.ldr));
    if !stats.saturated_views.is_empty() {
        w.push(format!(
            "{split}: views {:?} have ≥ 99 % of their pixels at their maximum (clipped exposure?)",
            stats.saturated_views
        ));
    }
    w
}

/// The warning on a split's views whose every pixel is 0 (none when there are none).
pub fn black_views_warning(split: &str, black: &[usize]) -> Option<String> {
    (!black.is_empty()).then(|| {
        format!("{split}: black views {black:?} (no pixel above 0): they constrain nothing but emitters' absence (a lens cap, or an exposure far too short?)")
    })
}
