//! Incident light as the shading estimators see it: what arrives at a point from a direction,
//! and (when the scene has known emitters) points sampled on them for next-event estimation.
//!
//! The initial bake's light is the SLF alone (`fipt_bake::bake::SlfLight`: no emitters, so no
//! light samples); the path-grown refinement's light (`fipt_bake::refine::GrownLight`) knows
//! the extracted emitters, stops at rough surfaces with the SLF and grows paths through glossy
//! ones. The bake's estimators combine BRDF samples and light samples by multiple importance
//! sampling (power heuristic), so one code path serves both. They ask in two halves
//! ([`IncidentLight::begin`], [`IncidentLight::finish`]) with one sample in flight, so that a
//! sample's memory fetch overlaps the next sample's ray.
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
    /// is `incoming(…)`, bit for bit. Every call draws from `rng` in the same half (the
    /// refinement's light in `finish`, where its paths grow; or never), and an estimator draws
    /// nothing itself between a `begin` and its `finish`: then one that begins the next sample
    /// before it finishes this one draws the same numbers in the same order as one that does
    /// not.
    ///
    /// By default `begin` does all the work through `incoming`. A light that overrides `begin`
    /// to return [`Pending::Hit`] must override `finish` too; only such a light may write its
    /// `incoming` as `finish(begin(…))` (with the defaults that recurses without end).
    fn begin(&self, origin: Vec3, dir: Vec3, rng: &mut Pcg32) -> Pending {
        Pending::Ready(self.incoming(origin, dir, rng))
    }
    /// The second half of [`IncidentLight::begin`]. The default knows only
    /// [`Pending::Ready`]: a hit reaching it is a light that overrode `begin` and not `finish`,
    /// a bug that stops the program with the light's type named.
    fn finish(&self, pending: Pending, _rng: &mut Pcg32) -> Incoming {
        match pending {
            Pending::Ready(i) => i,
            Pending::Hit { .. } => panic!(
                "{} returns Pending::Hit from IncidentLight::begin but does not override finish",
                std::any::type_name::<Self>()
            ),
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

    /// A light that answers in `begin` (the default halves).
    struct Constant;
    impl IncidentLight for Constant {
        fn incoming(&self, _: Vec3, _: Vec3, _: &mut Pcg32) -> Incoming {
            Incoming::Radiance(Vec3::new(1.0, 2.0, 3.0))
        }
    }

    /// A light that overrides `begin` to leave a hit and forgets `finish`.
    struct Forgetful;
    impl IncidentLight for Forgetful {
        fn incoming(&self, _: Vec3, _: Vec3, _: &mut Pcg32) -> Incoming {
            Incoming::Miss
        }
        fn begin(&self, origin: Vec3, dir: Vec3, _: &mut Pcg32) -> Pending {
            let hit = SurfaceHit {
                t: 1.0,
                tri: 0,
                p: origin + dir,
                ng: -dir,
                ns: -dir,
            };
            Pending::Hit { hit, dir }
        }
    }

    #[test]
    fn the_default_halves_give_incoming() {
        let mut rng = Pcg32::new(1, 1);
        let p = Constant.begin(Vec3::ZERO, Vec3::Z, &mut rng);
        assert_eq!(
            p,
            Pending::Ready(Constant.incoming(Vec3::ZERO, Vec3::Z, &mut rng))
        );
        assert_eq!(
            Constant.finish(p, &mut rng),
            Incoming::Radiance(Vec3::new(1.0, 2.0, 3.0))
        );
    }

    #[test]
    #[should_panic(expected = "Forgetful returns Pending::Hit from IncidentLight::begin")]
    fn a_hit_left_to_the_default_finish_names_the_light() {
        let mut rng = Pcg32::new(1, 1);
        let p = Forgetful.begin(Vec3::ZERO, Vec3::Z, &mut rng);
        Forgetful.finish(p, &mut rng);
    }

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
