//! The BRDF contract shared by every reflectance model.
//!
//! # Conventions
//! * Directions are unit vectors in the **local shading frame** (normal = +z) and both point
//!   **away** from the surface: `wo` towards the viewer, `wi` towards the light.
//! * [`Brdf::eval`] returns **f(ωo, ωi) · cos θi** — the BRDF *times* the foreshortening cosine
//!   of the incident direction (Mitsuba's convention). It is zero when either direction is
//!   below the horizon (z ≤ 0).
//! * [`Brdf::pdf`] is the solid-angle density of [`Brdf::sample`] for `wi`.
//! * [`Brdf::sample`] takes its random numbers as arguments (it owns no RNG) and returns the
//!   sampled direction with `weight = eval / pdf`.
use crate::color::Rgb;
use glam::{Vec2, Vec3};

/// A sampled incident direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrdfSample {
    /// Incident direction (local frame, pointing away from the surface).
    pub wi: Vec3,
    /// Solid-angle density of `wi` under `sample` (the full mixture pdf).
    pub pdf: f32,
    /// `eval(wo, wi) / pdf`.
    pub weight: Rgb,
}

/// A reflectance model. See the module docs for the cosine convention.
pub trait Brdf {
    /// f(ωo, ωi) · max(0, cos θi); zero when `wo.z <= 0` or `wi.z <= 0`.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb;
    /// Solid-angle pdf of sampling `wi` given `wo`.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;
    /// Samples `wi` from `u_lobe` (lobe choice) and `u` (direction), both uniform in [0, 1).
    fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample>;
    /// `(eval, pdf)` at once, bit for bit the two calls' values; a model whose two share work
    /// (the half vector, D) overrides it.
    #[inline]
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        (self.eval(wo, wi), self.pdf(wo, wi))
    }
}

/// An orthonormal frame around a normal (Duff et al. 2017 construction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// A frame whose +z is the unit vector `n`.
    #[inline]
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn frame_is_orthonormal_and_round_trips() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.4, 0.866).normalize(),
            Vec3::new(1e-7, 0.0, -1.0).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            assert!(
                f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5
            );
            assert!((f.s.cross(f.t) - n).length() < 1e-5, "right-handed");
            let v = Vec3::new(0.2, 0.5, -0.7);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }
}
