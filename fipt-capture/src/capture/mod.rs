//! What a run knows of its views as a capture: whether they are LDR (and which pixels clip),
//! each view's exposure relative to the others (fitted on the surfaces they share: the mesh
//! gives exact correspondences), and the warnings a user must read. `report.json`'s `capture`.
mod align;
pub(crate) mod clipped;
mod convention;
mod edges;
mod exif;
mod gains;
pub(crate) mod response;

pub use align::{AlignViews, Alignment, CaptureConfig, MIN_SHIFT_PX};
pub use clipped::{restore_clipped_lights, ClippedLights, CLIPPED_LIGHT_LEVELS};
pub use convention::{check_convention, test_convention, ConventionCheck, FileConvention};
pub use edges::{edge_alignment, edge_contrast, edge_warning, EdgeCheck, EDGE_OFF_PX};
pub use exif::ExifReport;
pub use gains::{fit_gains, gain_spread_limit, GainFit, GAIN_SPREAD_WARN, MIN_SHARED_CELLS};
pub use response::{fit_response, ResponseFit, MIN_DEPARTURE};

use fipt_core::capture::{clipped_mask_at, ldr_check, LdrCheck, ViewLdr};
use fipt_core::image::Image;
use fipt_geom::Geometry;
use rayon::prelude::*;
use serde::Serialize;

/// `report.json`'s `capture`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CaptureReport {
    /// The LDR check of the training views.
    #[serde(flatten)]
    pub check: LdrCheck,
    /// The value LDR views clip at (1 for 8-bit files), before any gain.
    pub clip_level: Option<f32>,
    /// Per training view, the value it clips at in the units the stages see (after its known
    /// exposure and its fitted gain; LDR views only).
    #[serde(skip)]
    pub view_clip: Vec<f32>,
    /// The share of a view's clip level at which a pixel counts as clipped (the linear value
    /// of stored 250): what a clipped pixel says of its radiance at least.
    #[serde(skip)]
    pub clip_fraction: f32,
    /// The fitted exposures, and whether the views were divided by them (LDR views only).
    pub exposure_fit: Option<GainFit>,
    pub exposures_applied: bool,
    /// Known exposures from `capture.json`, applied first.
    pub exposures_known: bool,
    /// What the user must know, with numbers (also printed).
    pub warnings: Vec<String>,
    /// Per training view, its clipped pixels (LDR views only).
    #[serde(skip)]
    pub clipped: Vec<Vec<bool>>,
    /// Per training view, the clipped pixels the material loss leaves out (clipped but not on
    /// a light: a highlight or a bright wall whose radiance is only bounded below).
    #[serde(skip)]
    pub left_out: Vec<Vec<bool>>,
    /// The lights seen only clipped, and the convention their radiance was set by.
    pub clipped_lights: Option<ClippedLights>,
    /// How the mesh's edges line up with the views' (before any alignment).
    pub edges: EdgeCheck,
    /// The views shifted onto the mesh (`[capture] align_views`).
    pub alignment: Alignment,
    /// The poses' convention tested on the edges (layouts whose files could be in another).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub convention: Option<ConventionCheck>,
    /// Training pixels the views' masks leave out (`Mask/`, COLMAP's `masks/`, nerfstudio's
    /// `mask_path`).
    #[serde(skip_serializing_if = "is_zero")]
    pub masked_pixels: usize,
    /// Per training view, the share of its traced pixel-centre rays that hit the mesh
    /// (`placement`; empty until the scene's load measures it).
    #[serde(skip)]
    pub coverage: Vec<f32>,
    /// Per training view, the pixels its mask leaves out (empty: no view has a mask; one
    /// view's list empty: that view has none). Read it with [`flagged`].
    #[serde(skip)]
    pub masked: Vec<Vec<bool>>,
    /// What the camera files are and the convention they state (as `fipt info` says).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cameras: Option<String>,
    /// What the photos' EXIF said of their exposures, and whether the views agree.
    #[serde(skip_serializing_if = "ExifReport::is_empty")]
    pub exif: ExifReport,
    /// The camera's response estimated from the views (8-bit views whose `capture.json`
    /// gives none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub response: Option<ResponseFit>,
    /// The tone curve's contrast from the light transport ([`crate::contrast`]), where it was
    /// looked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contrast: Option<crate::contrast::ContrastFit>,
}

impl CaptureReport {
    /// The warning that the views were decoded through a fitted response, if they were.
    pub fn response_warning(&self) -> Option<String> {
        let f = self.response.as_ref().filter(|f| f.applied)?;
        Some(format!(
            "train: the camera's response is NOT sRGB: the curve fitted on the surfaces the views share departs from sRGB by {:.3} RMS (linear, over stored values) and explains the views better (they disagree by {:.2} 8-bit steps RMS against sRGB's {:.2}, gains {}); the views are decoded through it (report.json capture.response; state it in capture.json to skip the fit)",
            f.departure, f.residual_fitted, f.residual_srgb, f.gains
        ))
    }
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// Whether pixel `i` of view `v` is flagged in per-view pixel flags such as
/// [`CaptureReport::masked`] or `clipped`, where a view with no flags holds an empty list
/// (a mask on some views only) and a view past the list's end has none.
#[inline]
pub fn flagged(flags: &[Vec<bool>], v: usize, i: usize) -> bool {
    flags
        .get(v)
        .and_then(|f| f.get(i))
        .copied()
        .unwrap_or(false)
}

/// Per training view (of `sizes` pixels), the pixels that are clipped or masked: neither tells
/// an exposure nor a light's radiance. `r.clipped` itself where no view has a mask.
pub(crate) fn clipped_or_masked(r: &CaptureReport, sizes: &[usize]) -> Vec<Vec<bool>> {
    if r.masked.is_empty() {
        return r.clipped.clone();
    }
    (sizes.iter().enumerate())
        .map(|(k, &n)| {
            (0..n)
                .map(|i| flagged(&r.clipped, k, i) || flagged(&r.masked, k, i))
                .collect()
        })
        .collect()
}

/// Leaves the pixels the views' masks drop out of the material loss and the search (with
/// the clipped ones), and counts them.
pub fn leave_out_masked(r: &mut CaptureReport, masks: &[Option<Vec<bool>>]) {
    if masks.is_empty() {
        return;
    }
    if r.left_out.len() < masks.len() {
        r.left_out.resize(masks.len(), vec![]);
    }
    for (out, keep) in r.left_out.iter_mut().zip(masks) {
        let Some(keep) = keep else { continue };
        if out.is_empty() {
            *out = vec![false; keep.len()];
        }
        for (o, k) in out.iter_mut().zip(keep) {
            if !k {
                r.masked_pixels += 1;
                *o = true;
            }
        }
    }
    let per_view = masks.iter().flatten().map(Vec::len).next().unwrap_or(0);
    if r.masked_pixels > 0 {
        r.warnings.push(format!(
            "train: the views' masks leave out {} pixels ({:.1} % of the training pixels) from the materials' fit",
            r.masked_pixels,
            100.0 * r.masked_pixels as f64 / (masks.len() * per_view).max(1) as f64
        ));
    }
}

/// Checks the training images of `ds` (`images`, divided by their known exposures), estimates
/// the camera's response where the views are 8-bit files and `capture.json` gives none, fits
/// their exposures on shared surfaces and, for LDR views, divides each by its fitted gain, and
/// shifts the views onto the mesh as `mode` asks. Returns what it found.
pub fn examine(
    geometry: &Geometry,
    ds: &fipt_core::dataset::Dataset,
    images: &mut [Image],
    mode: AlignViews,
    masks: &[Option<Vec<bool>>],
) -> CaptureReport {
    let views = &ds.train().views;
    let files_ldr = ds.has_ldr_files();
    let response = response_of(geometry, ds, images, masks);
    let per_view: Vec<(usize, ViewLdr)> = images
        .par_iter()
        .enumerate()
        .map(|(k, img)| (k, ViewLdr::of(img)))
        .collect();
    let check = ldr_check(&per_view, files_ldr);
    let mut r = CaptureReport {
        warnings: ldr_warnings("train", &check),
        masked: masked_pixels(masks),
        ..Default::default()
    };
    r.response = response;
    r.warnings.extend(r.response_warning());
    if check.ldr {
        // The views were divided by their known exposures: their common clip level is the
        // largest value times its view's exposure.
        let known = ds.known_exposures().map(|(e, _)| e.to_vec());
        let level = per_view
            .iter()
            .map(|(k, v)| v.max * known.as_ref().map_or(1.0, |e| e[*k]))
            .fold(0.0f32, f32::max);
        let level = if files_ldr || level <= 1.0 + 1e-3 {
            1.0
        } else {
            level
        };
        r.clip_level = Some(level);
        clip_masks(&mut r, ds, images, level);
    }
    // Masked pixels (people, screens) say nothing of the views' exposures either.
    let sizes: Vec<usize> = images.iter().map(|i| i.data.len()).collect();
    let unused = clipped_or_masked(&r, &sizes);
    let fit = fit_gains(geometry, views, images, &unused, r.clip_level);
    if let Some(f) = &fit {
        if !f.unfitted.is_empty() {
            r.warnings.push(format!(
                "train: views {:?} share fewer than {MIN_SHARED_CELLS} usable surface cells with the others (mostly clipped, black or alone): their exposure is unknown and left as it is",
                f.unfitted
            ));
        }
        if f.spread > gain_spread_limit(check.ldr) {
            r.warnings.push(format!(
                "train: the views' exposures disagree on the surfaces they share: fitted gains {:.3} … {:.3} (×{:.2}) over {} surface cells{}",
                f.gains.iter().cloned().fold(f32::INFINITY, f32::min),
                f.gains.iter().cloned().fold(0.0f32, f32::max),
                f.spread,
                f.cells,
                if check.ldr { "; each view is divided by its gain (auto-exposure)" } else { "; HDR views are used as they are" }
            ));
        }
        if check.ldr && f.spread > GAIN_SPREAD_WARN {
            for ((img, g), clip) in images.iter_mut().zip(&f.gains).zip(&mut r.view_clip) {
                for p in &mut img.data {
                    *p /= *g;
                }
                *clip /= *g;
            }
            r.exposures_applied = true;
        }
    }
    r.exposure_fit = fit;
    r.check = check;
    r.edges = edge_alignment(geometry, views, images);
    let warning = edge_warning(&r.edges);
    r.alignment = align::align(
        mode,
        warning.is_some(),
        geometry,
        views,
        images,
        &mut r.clipped,
        &r.edges,
    );
    r.warnings.extend(warning.map(|w| match &r.alignment.after {
        Some(after) => format!(
            "{w}; {} views shifted onto the mesh by their edges ([capture] align_views): median {:.2} px after",
            r.alignment.views_shifted.len(),
            after.median_px
        ),
        None => w,
    }));
    r
}

/// The camera's response fitted where every training view is an 8-bit file and
/// `capture.json` states none (`images` decoded again through it when it is used).
fn response_of(
    geometry: &Geometry,
    ds: &fipt_core::dataset::Dataset,
    images: &mut [Image],
    masks: &[Option<Vec<bool>>],
) -> Option<ResponseFit> {
    let views = &ds.train().views;
    let estimate = !ds.capture.response_stated
        && views
            .iter()
            .all(|v| fipt_core::capture::is_ldr_file(&v.image));
    estimate.then(|| {
        fit_response(
            geometry,
            views,
            images,
            ds.known_exposures().map(|(e, _)| e),
            &masked_pixels(masks),
        )
    })
}

/// Each view's clip level (`level` over its known exposure: it was divided by it) and its
/// clipped pixels: a stored value of 250 and above clips, whatever the curve decodes it to.
/// Per view, its pixels a mask leaves out (empty: no view has a mask).
fn masked_pixels(masks: &[Option<Vec<bool>>]) -> Vec<Vec<bool>> {
    if masks.iter().all(Option::is_none) {
        return vec![];
    }
    masks
        .iter()
        .map(|m| {
            m.as_ref()
                .map_or(vec![], |keep| keep.iter().map(|k| !k).collect())
        })
        .collect()
}

fn clip_masks(
    r: &mut CaptureReport,
    ds: &fipt_core::dataset::Dataset,
    images: &[Image],
    level: f32,
) {
    let known = ds.known_exposures().map(|(e, _)| e.to_vec());
    r.view_clip = (0..images.len())
        .map(|k| level / known.as_ref().map_or(1.0, |e| e[k]))
        .collect();
    let at = match r.response.as_ref().filter(|f| f.applied) {
        Some(f) => f.clip_linear,
        None => fipt_core::color::srgb_eotf(250.0 / 255.0),
    };
    r.clip_fraction = at;
    r.clipped = images
        .iter()
        .zip(&r.view_clip)
        .map(|(i, l)| clipped_mask_at(i, l * at))
        .collect();
}

/// What a split's LDR evidence means for a run, in words and numbers (empty for HDR views).
pub fn ldr_warnings(split: &str, c: &fipt_core::capture::LdrCheck) -> Vec<String> {
    if !c.ldr {
        return vec![];
    }
    let mut w = vec![format!(
        "{split}: the views are LOW DYNAMIC RANGE ({}): radiance above the clip level is lost",
        c.evidence.join("; ")
    )];
    if !c.clipped_views.is_empty() {
        let worst = c.clipped_views.iter().fold(
            (0usize, 0f64),
            |a, &(k, s)| if s > a.1 { (k, s) } else { a },
        );
        w.push(format!(
            "{split}: {} of the views clip ({:.2} % of all pixels at the clip level; most in view {}: {:.2} %): \
             lights and highlights there are lower bounds, and a light seen only clipped has an unknown radiance",
            c.clipped_views.len(),
            100.0 * c.clipped_share,
            worst.0,
            100.0 * worst.1
        ));
    }
    w
}
