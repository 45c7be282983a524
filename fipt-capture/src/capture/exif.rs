//! The photos' EXIF exposures (time × ISO / N²) checked against the exposures the views'
//! shared surfaces give: `report.json`'s `capture.exif` and `fipt info`'s line.
use super::GainFit;
use fipt_core::dataset::Dataset;
use serde::Serialize;

/// After the EXIF exposures are divided out, fitted gains spreading more than this say the
/// EXIF does not describe the pixels (a phone's own tone mapping, an edited photo).
pub const EXIF_DISAGREE_SPREAD: f32 = 1.25;

/// `report.json`'s `capture.exif`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ExifReport {
    /// Training views whose files carry an EXIF exposure time.
    pub views_with_exposure: usize,
    pub views: usize,
    /// The EXIF exposures were applied as the views' relative exposures.
    pub used: bool,
    /// Their spread (largest / smallest).
    pub spread: Option<f32>,
    /// The camera's make and model, as EXIF gives them.
    pub camera: Option<String>,
    /// The spread of the gains fitted on the views after the EXIF exposures were divided
    /// out (1: the EXIF explains the views exactly).
    pub fitted_spread_after: Option<f32>,
    #[serde(skip)]
    pub warning: Option<String>,
}

impl ExifReport {
    pub fn is_empty(&self) -> bool {
        self.views_with_exposure == 0
    }

    /// What `ds`'s EXIF said, checked against `fit` (the gains fitted after its exposures).
    pub fn of(ds: &Dataset, fit: Option<&GainFit>) -> ExifReport {
        let with: Vec<&fipt_core::exif::ExifExposure> = ds.exif.iter().flatten().collect();
        let n = with.iter().filter(|e| e.exposure_time.is_some()).count();
        if n == 0 {
            return ExifReport::default();
        }
        let mut r = ExifReport {
            views_with_exposure: n,
            views: ds.train().views.len(),
            used: ds.exif_exposures.is_some() && ds.capture.exposures.is_none(),
            camera: with.iter().find_map(|e| e.camera.clone()),
            ..Default::default()
        };
        if let Some(e) = &ds.exif_exposures {
            let lo = e.iter().cloned().fold(f32::INFINITY, f32::min);
            let hi = e.iter().cloned().fold(0.0f32, f32::max);
            r.spread = Some(hi / lo.max(1e-30));
        }
        if r.used {
            r.fitted_spread_after = fit.map(|f| f.spread);
            if let Some(s) = r.fitted_spread_after.filter(|&s| s > EXIF_DISAGREE_SPREAD) {
                r.warning = Some(format!(
                    "train: the EXIF exposures (×{:.2} across the views) do not explain the views: after dividing by them the gains fitted on the surfaces the views share still spread ×{s:.2}; the camera's processing (or an edit) changed the exposure",
                    r.spread.unwrap_or(1.0)
                ));
            }
        } else if n < r.views && ds.capture.exposures.is_none() {
            r.warning = Some(format!(
                "train: only {n} of {} views carry an EXIF exposure time: EXIF exposures are not used; the exposures are fitted on the views",
                r.views
            ));
        }
        r
    }
}
