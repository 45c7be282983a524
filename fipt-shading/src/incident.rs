//! Incident light as the shading estimators see it: what arrives at a point from a direction,
//! and (when the scene has known emitters) points sampled on them for next-event estimation.
//!
//! The initial bake's light is the SLF alone ([`crate::bake::SlfLight`]: no emitters, so no
//! light samples); the path-grown refinement's light ([`crate::refine`]) knows the extracted
//! emitters, stops at rough surfaces with the SLF and grows paths through glossy ones. The
//! estimators in [`crate::bake`] combine BRDF samples and light samples by multiple
//! importance sampling (power heuristic), so one code path serves both.
use fipt_core::color::Rgb;
use fipt_core::rng::Pcg32;
use fipt_core::shading::SurfaceHit;
use glam::Vec3;

/// What arrives along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Incoming {
    /// Nothing (the ray left the scene).
    Miss,
    /// An emitter's radiance `le`, which light sampling could also have produced with
    /// solid-angle density `light_pdf` (for the MIS weight of the BRDF sample).
    Emitter { le: Rgb, light_pdf: f32 },
    /// Radiance that light sampling cannot produce (reflected light).
    Radiance(Rgb),
}

/// What [`IncidentLight::begin`] leaves for [`IncidentLight::finish`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pending {
    /// The answer, already known.
    Ready(Incoming),
    /// The ray's first surface hit and its direction: the memory the answer reads there is
    /// being fetched.
    Hit { hit: SurfaceHit, dir: Vec3 },
}

/// A point sampled on an emitter, seen from a shading point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shading point to the emitter point.
    pub wi: Vec3,
    /// Distance to the emitter point.
    pub dist: f32,
    /// Emitted radiance towards the shading point.
    pub le: Rgb,
    /// Solid-angle density of the sample.
    pub pdf: f32,
}

/// The incident light of a shading stage.
pub trait IncidentLight: Sync {
    /// What arrives at `origin` (already offset off the surface) from the unit direction `dir`.
    /// `rng` drives any path continuation.
    fn incoming(&self, origin: Vec3, dir: Vec3, rng: &mut Pcg32) -> Incoming;
    /// [`IncidentLight::incoming`] in two halves, for an estimator with other work to do in
    /// between (the next sample's ray) while the answer's memory is fetched. `finish(begin(…))`
    /// is `incoming(…)`, bit for bit. A light draws from `rng` in one half only (the refinement's
    /// in `finish`, where its paths grow), so that an estimator that begins the next sample
    /// before it finishes this one draws the same numbers in the same order as one that does
    /// not. By default `begin` does all the work.
    fn begin(&self, origin: Vec3, dir: Vec3, rng: &mut Pcg32) -> Pending {
        Pending::Ready(self.incoming(origin, dir, rng))
    }
    /// The second half of [`IncidentLight::begin`]. A light whose `begin` returns
    /// [`Pending::Hit`] overrides it; the default knows only [`Pending::Ready`] (and reads a
    /// hit as a miss).
    fn finish(&self, pending: Pending, _rng: &mut Pcg32) -> Incoming {
        match pending {
            Pending::Ready(i) => i,
            Pending::Hit { .. } => {
                debug_assert!(
                    false,
                    "a light that begins with Pending::Hit must finish it"
                );
                Incoming::Miss
            }
        }
    }
    /// Whether the light has emitters to sample.
    fn has_emitters(&self) -> bool {
        false
    }
    /// A point on an emitter for the shading point at `origin`, visible from it (None when
    /// there are no emitters, the point faces away or is occluded).
    fn sample_emitter(&self, _origin: Vec3, _rng: &mut Pcg32) -> Option<LightSample> {
        None
    }
}

/// The power heuristic (β = 2) weight of a technique with `n·pdf` = `a` against one with `b`.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && a2.is_finite() {
        a2 / (a2 + b2)
    } else if a2.is_finite() {
        0.0
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_heuristic_weights_sum_to_one_and_handle_extremes() {
        for (a, b) in [(1.0f32, 1.0f32), (0.3, 7.0), (1e-20, 1e20), (5.0, 0.0)] {
            let s = power_heuristic(a, b) + power_heuristic(b, a);
            assert!((s - 1.0).abs() < 1e-6, "{a} {b}: {s}");
        }
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert_eq!(power_heuristic(1.0, f32::INFINITY), 0.0);
        assert_eq!(power_heuristic(2.0, 0.0), 1.0);
    }
}
