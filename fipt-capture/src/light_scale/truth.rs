//! The model of the room's light the estimate measures against, read at given radiances:
//! what the example `lights_against_truth` scores against a scene's true kd (and a render of
//! its direct light alone).
use super::{view_hits, STRIDE};
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_geom::Geometry;
use glam::Vec3;

/// What the model says at one sample ([`shading_at_radiances`]).
pub struct SampleShading {
    /// The pixel: index into the views, x, y.
    pub at: (usize, usize, usize),
    /// The pixel's radiance, the light from the rest of the room A, and the lights' direct
    /// shading Σ L_e D_e at the radiances asked.
    pub seen: Vec3,
    pub room: Vec3,
    pub direct: Vec3,
}

/// The model of the room's light at each sample with the lights at `radiance` (one RGB per
/// light): kd = seen / (room + direct). Against a scene's true kd (and a render of its direct
/// light alone) this measures the model itself (the example `lights_against_truth`).
pub fn shading_at_radiances(
    geometry: &Geometry,
    views: &[View],
    images: &[Image],
    lights: &[Vec<u32>],
    skip: &[Vec<bool>],
    radiance: &[Vec3],
) -> Vec<SampleShading> {
    let hits = view_hits(geometry, views);
    let Some((samples, _)) =
        super::samples_and_model(geometry, views, images, &hits, lights, skip, STRIDE)
    else {
        return vec![];
    };
    samples
        .iter()
        .map(|s| SampleShading {
            at: s.at,
            seen: s.i,
            room: s.a,
            direct: s.d.iter().zip(radiance).map(|(d, l)| *l * *d).sum(),
        })
        .collect()
}
