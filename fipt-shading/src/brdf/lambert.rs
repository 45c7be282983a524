//! Lambertian reflection: f = ρ/π.
//!
//! | parameter | meaning | range |
//! |---|---|---|
//! | `albedo` | ρ, per channel | [0, 1] |
use fipt_core::brdf::{Brdf, BrdfSample};
use fipt_core::color::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Lambertian BRDF; sampled by cosine-weighted directions (weight = ρ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert {
    pub albedo: Rgb,
}

impl Brdf for Lambert {
    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        self.albedo * (FRAC_1_PI * wi.z)
    }
    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        wi.z * FRAC_1_PI
    }
    #[inline]
    fn sample(&self, wo: Vec3, _u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = super::sample_cosine_hemisphere(u);
        if wi.z <= 0.0 {
            return None;
        }
        Some(BrdfSample {
            wi,
            pdf: wi.z * FRAC_1_PI,
            weight: self.albedo,
        })
    }
}
