//! Laying each view back over the mesh by the image shift its edges ask for (`[capture]
//! align_views`): a first-order pose refinement for views from structure from motion.
use super::edges::{edge_alignment, EdgeCheck};
use fipt_core::dataset::View;
use fipt_core::image::{shifted, shifted_mask, Image};
use fipt_geom::Geometry;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// When the views are shifted onto the mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AlignViews {
    /// When the edge check warns (a median shift of 0.5 px, or a quarter of the views 0.75 px
    /// off): each view whose shift is [`MIN_SHIFT_PX`] or more.
    Auto,
    /// Never.
    #[default]
    Off,
    /// Every view whose shift is [`MIN_SHIFT_PX`] or more, warned or not.
    Always,
}

/// `[capture]`: what a run does with views that are captures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CaptureConfig {
    pub align_views: AlignViews,
    /// Shrink every view (and its mask and intrinsics) by this factor on read: photos larger
    /// than the method needs (`fipt run --downscale N`). 1 reads them as stored.
    #[serde(skip_serializing_if = "is_one")]
    pub downscale: usize,
    /// Where 8-bit views carry no known exposures and no stated response, look for the tone
    /// curve's contrast in the light transport and decode with it where it is clear
    /// ([`crate::contrast`]); false leaves the views as the response fit decoded them.
    #[serde(skip_serializing_if = "is_true")]
    pub light_contrast: bool,
}

impl Default for CaptureConfig {
    fn default() -> Self {
        CaptureConfig {
            align_views: AlignViews::default(),
            downscale: 1,
            light_contrast: true,
        }
    }
}

fn is_true(b: &bool) -> bool {
    *b
}

fn is_one(n: &usize) -> bool {
    *n == 1
}

impl CaptureConfig {
    /// How the scene folder is opened under these settings.
    pub fn open_options(&self) -> fipt_core::capture_layout::OpenOptions {
        fipt_core::capture_layout::OpenOptions {
            downscale: self.downscale.max(1),
        }
    }
}

/// Shifts under this many pixels are left alone: on exact poses and mesh the check reads
/// about 0.1 px, and a bilinear shift blurs.
pub const MIN_SHIFT_PX: f32 = 0.25;

/// What the alignment did (`report.json` `capture.alignment`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct Alignment {
    pub mode: Option<AlignViews>,
    /// The views shifted (their shifts are the edge check's).
    pub views_shifted: Vec<usize>,
    /// The edge check on the shifted views.
    pub after: Option<EdgeCheck>,
}

impl Alignment {
    /// A key of the shifts for the stages' caches ("" when nothing moved).
    pub fn cache_tag(&self, edges: &EdgeCheck) -> String {
        if self.views_shifted.is_empty() {
            return String::new();
        }
        let text: Vec<String> = self
            .views_shifted
            .iter()
            .map(|&k| {
                let s = edges.shifts[k].unwrap_or_default();
                format!("{k}:{:.4},{:.4}", s[0], s[1])
            })
            .collect();
        format!(
            "@aligned:{}",
            fipt_core::fsutil::hash_bytes(text.join(";").as_bytes())
        )
    }
}

/// Shifts the views `mode` asks for by their edge check's shifts (and their clipped masks
/// with them), then checks the edges again.
pub fn align(
    mode: AlignViews,
    warned: bool,
    geometry: &Geometry,
    views: &[View],
    images: &mut [Image],
    clipped: &mut [Vec<bool>],
    edges: &EdgeCheck,
) -> Alignment {
    let on = match mode {
        AlignViews::Off => false,
        AlignViews::Auto => warned,
        AlignViews::Always => true,
    };
    let mut a = Alignment {
        mode: Some(mode),
        ..Default::default()
    };
    if !on {
        return a;
    }
    a.views_shifted = edges
        .shifts
        .iter()
        .enumerate()
        .filter_map(|(k, s)| {
            let s = (*s)?;
            ((s[0] * s[0] + s[1] * s[1]).sqrt() >= MIN_SHIFT_PX).then_some(k)
        })
        .collect();
    let moved: Vec<(usize, Image)> = a
        .views_shifted
        .par_iter()
        .map(|&k| {
            let s = edges.shifts[k].unwrap_or_default();
            (k, shifted(&images[k], s[0], s[1]))
        })
        .collect();
    for (k, img) in moved {
        let s = edges.shifts[k].unwrap_or_default();
        if let Some(m) = clipped.get_mut(k) {
            if !m.is_empty() {
                *m = shifted_mask(m, img.width, img.height, s[0], s[1]);
            }
        }
        images[k] = img;
    }
    if !a.views_shifted.is_empty() {
        a.after = Some(edge_alignment(geometry, views, images));
    }
    a
}
