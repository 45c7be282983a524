//! BRDF models, one per file, and the closed enum used for per-ray dispatch.
//!
//! Every model implements [`fipt_core::brdf::Brdf`]: `eval` returns f·cos θi in the local
//! frame (normal = +z), `sample` returns `weight = eval / pdf`.
pub mod ladder;
mod lambert;
mod microfacet;

pub use fipt_core::reflectance::{ggx_d, schlick_weight};
pub use lambert::Lambert;
pub use microfacet::MicrofacetBrdf;

use fipt_core::brdf::{Brdf, BrdfSample};
use fipt_core::color::Rgb;
use glam::{Vec2, Vec3};

/// Cosine-weighted hemisphere sample (Malley's method via the concentric disk).
#[inline]
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Shirley–Chiu concentric map of [0,1)² to the unit disk.
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (
            o.y,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y),
        )
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// The reflectance models a renderer dispatches over per ray (closed set, no virtual call).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BrdfModel {
    Microfacet(MicrofacetBrdf),
    Lambert(Lambert),
}

impl BrdfModel {
    /// True when the model reflects nothing (emitters).
    pub fn is_black(&self) -> bool {
        match self {
            BrdfModel::Microfacet(b) => b.is_black(),
            BrdfModel::Lambert(l) => l.albedo == Vec3::ZERO,
        }
    }
}

impl Brdf for BrdfModel {
    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        match self {
            BrdfModel::Microfacet(b) => b.eval(wo, wi),
            BrdfModel::Lambert(b) => b.eval(wo, wi),
        }
    }
    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            BrdfModel::Microfacet(b) => b.pdf(wo, wi),
            BrdfModel::Lambert(b) => b.pdf(wo, wi),
        }
    }
    #[inline]
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        match self {
            BrdfModel::Microfacet(b) => b.eval_pdf(wo, wi),
            BrdfModel::Lambert(b) => b.eval_pdf(wo, wi),
        }
    }
    #[inline]
    fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        match self {
            BrdfModel::Microfacet(b) => b.sample(wo, u_lobe, u),
            BrdfModel::Lambert(b) => b.sample(wo, u_lobe, u),
        }
    }
}
