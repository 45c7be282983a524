//! Re-renders shown as the camera took the views: at each view's exposure, through the
//! camera's response, clipped where the photo clips. An auto-exposed LDR capture is otherwise
//! compared with renders at one exposure, and the report shows the camera's metering rather
//! than where the model disagrees with the photos.
use fipt_core::capture::Response;
use fipt_core::color::{luminance, srgb_eotf, srgb_oetf};
use fipt_core::image::Image;
use glam::Vec3;
use std::path::Path;

/// What the run knew of its views as photos (`report.json` `capture`).
#[derive(Clone, Debug, Default)]
pub struct PhotoModel {
    /// The views were LDR: renders are shown as photos.
    pub ldr: bool,
    /// The value the files clip at (1 for 8-bit).
    pub clip: f32,
    /// Per training view, the gain the run divided it by (auto-exposure), if any.
    pub train_gains: Option<Vec<f32>>,
    /// The camera's inverse response the run fitted (linear values at stored 0 … 1), if it
    /// used one; the inputs are decoded as sRGB.
    pub response: Option<Response>,
}

/// A render as a photo of one view.
pub struct AsPhoto {
    pub image: Image,
    /// The input's clipped pixels (not scored, shown blue in the error map).
    pub clipped: Vec<bool>,
    /// The exposure the render was shown at (the view's gain × its known exposure).
    pub gain: f32,
}

impl PhotoModel {
    /// Reads `report.json` of run folder `run` (an HDR model when it is absent or HDR).
    pub fn of(run: &Path) -> PhotoModel {
        let Some(r) = std::fs::read_to_string(run.join("report.json"))
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        else {
            return PhotoModel::default();
        };
        let c = &r["capture"];
        let floats = |v: &serde_json::Value| -> Option<Vec<f32>> {
            v.as_array().map(|a| {
                a.iter()
                    .filter_map(|x| x.as_f64())
                    .map(|x| x as f32)
                    .collect()
            })
        };
        PhotoModel {
            ldr: c["ldr"].as_bool().unwrap_or(false),
            clip: c["clip_level"].as_f64().unwrap_or(1.0) as f32,
            train_gains: c["exposures_applied"]
                .as_bool()
                .filter(|a| *a)
                .and_then(|_| floats(&c["exposure_fit"]["gains"])),
            response: c["response"]["applied"]
                .as_bool()
                .filter(|a| *a)
                .and_then(|_| floats(&c["response"]["linear"]))
                .map(Response::Table)
                .filter(|r| r.validate(Path::new("report.json")).is_ok()),
        }
    }

    /// `render` (the run's radiance for the view) as the camera would have stored it,
    /// decoded as the input `input` was (sRGB): at `gain` (the run's, times the known
    /// exposure) or, when None, the gain that fits the input best (the median ratio over
    /// the unclipped pixels), through the fitted response, clipped.
    pub fn as_photo(&self, render: &Image, input: &Image, gain: Option<f32>) -> AsPhoto {
        let clip_at = self.clip * srgb_eotf(250.0 / 255.0);
        let clipped: Vec<bool> = input
            .data
            .iter()
            .map(|p| p.max_element() >= clip_at)
            .collect();
        let gain = gain.unwrap_or_else(|| self.fitted_gain(render, input, &clipped));
        let data = render
            .data
            .iter()
            .map(|p| Vec3::from_array((*p * gain).to_array().map(|x| self.encode(x))))
            .collect();
        AsPhoto {
            image: Image {
                data,
                ..render.clone()
            },
            clipped,
            gain,
        }
    }

    /// A linear value as the camera stores it, decoded back as sRGB.
    fn encode(&self, x: f32) -> f32 {
        let v = (x / self.clip).clamp(0.0, 1.0);
        match &self.response {
            Some(r) => srgb_eotf(r.to_stored(v)) * self.clip,
            None => v * self.clip,
        }
    }

    /// The input pixel's value in the run's linear units (through the fitted response).
    fn decode(&self, x: f32) -> f32 {
        match &self.response {
            Some(r) => r.to_linear(srgb_oetf((x / self.clip).clamp(0.0, 1.0))) * self.clip,
            None => x,
        }
    }

    /// The median of input / render luminance over unclipped pixels both see lit.
    fn fitted_gain(&self, render: &Image, input: &Image, clipped: &[bool]) -> f32 {
        let mut r: Vec<f32> = render
            .data
            .iter()
            .zip(&input.data)
            .zip(clipped)
            .filter(|(_, c)| !**c)
            .filter_map(|((a, b), _)| {
                let (a, b) = (
                    luminance(*a),
                    luminance(Vec3::from_array(b.to_array().map(|x| self.decode(x)))),
                );
                (a > 1e-6 && b > 1e-3 * self.clip).then(|| b / a)
            })
            .collect();
        if r.is_empty() {
            return 1.0;
        }
        fipt_core::image::median(&mut r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(v: &[f32]) -> Image {
        Image {
            width: v.len(),
            height: 1,
            data: v.iter().map(|&x| Vec3::splat(x)).collect(),
        }
    }

    #[test]
    fn an_auto_exposed_view_is_shown_at_its_gain_and_clipped() {
        let m = PhotoModel {
            ldr: true,
            clip: 1.0,
            ..Default::default()
        };
        // The photo: the scene ×4, clipped at 1.
        let scene = [0.01, 0.05, 0.1, 0.2, 0.5];
        let photo: Vec<f32> = scene.iter().map(|x| (x * 4.0f32).min(1.0)).collect();
        let p = m.as_photo(&image(&scene), &image(&photo), None);
        assert!((p.gain - 4.0).abs() < 1e-4, "{}", p.gain);
        assert_eq!(p.clipped, vec![false, false, false, false, true]);
        for (a, b) in p.image.data.iter().zip(&photo) {
            assert!((a.x - b).abs() < 1e-5);
        }
    }

    #[test]
    fn a_fitted_response_round_trips() {
        // A gamma-2 camera, its curve as the run reports it; the input decoded as sRGB.
        let t: Vec<f32> = (0..=32).map(|k| (k as f32 / 32.0).powi(2)).collect();
        let m = PhotoModel {
            ldr: true,
            clip: 1.0,
            response: Some(Response::Table(t)),
            ..Default::default()
        };
        for x in [0.01f32, 0.1, 0.4, 0.9] {
            let stored = x.sqrt();
            let input = srgb_eotf(stored);
            assert!((m.encode(x) - input).abs() < 2e-3, "{x}");
            assert!(
                (m.decode(input) - x).abs() < 5e-3,
                "{x}: {}",
                m.decode(input)
            );
        }
    }
}
