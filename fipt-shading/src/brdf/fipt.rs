//! FIPT's metallic-workflow BRDF (method §2).
//!
//! f(ωo, ωi) = kd/π + D·G·F / (4 (n·ωi)(n·ωo)) with
//! * D: GGX (Trowbridge–Reitz), α = σ²: D(h) = α² / (π ((n·h)²(α²−1)+1)²);
//! * G: separable Smith with the Schlick-GGX G1(c) = c / (c(1−k)+k), k = (σ+1)²/8;
//! * F: Schlick on ωo·h, F = ks + (1−ks)(1−ωo·h)⁵.
//!
//! The diffuse lobe has no (1−F) factor, so kd + specular albedo can exceed 1 for bright
//! dielectrics (as in the reference). Sampling: 50 % cosine, 50 % GGX half-vector
//! (cos²θh = (1−u)/(u(α²−1)+1), evaluated as tan²θh = α²u/(1−u)), pdf = ½·cosθi/π + ½·D·(n·h)/(4 ωo·h).
//!
//! | parameter | meaning | range |
//! |---|---|---|
//! | `kd` | diffuse albedo | [0, 1]³ |
//! | `ks` | specular reflectance F0 | [0, 1]³ |
//! | `roughness` | σ (GGX α = σ²) | [0.02, 1] (clamped) |
use fipt_core::brdf::{Brdf, BrdfSample};
use fipt_core::color::Rgb;
use fipt_core::materials::MIN_ROUGHNESS;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI, TAU};

/// GGX normal distribution for α = σ² at the local half vector `h` (unit, normal = +z).
///
/// Written as α² / (π (α² cos²θh + sin²θh)²) with sin²θh = hx² + hy², which stays accurate
/// for α² near f32's epsilon (σ = 0.02 gives α² = 1.6e-7), where the textbook form
/// cos²θh(α²−1)+1 cancels catastrophically.
#[inline]
pub fn ggx_d(h: Vec3, alpha: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let s2 = h.x * h.x + h.y * h.y;
    let d = a2 * h.z * h.z + s2;
    if d <= 0.0 {
        return 0.0;
    }
    a2 / (PI * d * d)
}

/// Schlick-GGX masking for one direction with k = (σ+1)²/8.
#[inline]
pub fn smith_g1(cos: f32, roughness: f32) -> f32 {
    let k = (roughness + 1.0) * (roughness + 1.0) / 8.0;
    cos / (cos * (1.0 - k) + k)
}

/// Schlick's Fresnel weight (1 − c)⁵.
#[inline]
pub fn schlick_fresnel(c: f32) -> f32 {
    let m = (1.0 - c).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// The FIPT BRDF at one surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FiptBrdf {
    pub kd: Rgb,
    pub ks: Rgb,
    /// σ, clamped to [0.02, 1] by [`FiptBrdf::new`].
    pub roughness: f32,
}

impl FiptBrdf {
    pub fn new(kd: Rgb, ks: Rgb, roughness: f32) -> Self {
        FiptBrdf {
            kd,
            ks,
            roughness: roughness.clamp(MIN_ROUGHNESS, 1.0),
        }
    }

    /// GGX α = σ².
    #[inline]
    pub fn alpha(&self) -> f32 {
        self.roughness * self.roughness
    }

    /// True when kd = ks = 0 (note: ks = 0 still reflects at grazing angles via Schlick).
    pub fn is_black(&self) -> bool {
        self.kd == Vec3::ZERO && self.ks == Vec3::ZERO
    }

    /// The specular factors (D·G/(4 cos θo), the two Fresnel weights) used by the shading
    /// factorisation: f_spec·cos θi = cos θi · D·G·(ks·(1−m) + m) / (4 cosθi cosθo) with m = (1−ωo·h)⁵.
    #[inline]
    pub fn spec_terms(&self, wo: Vec3, wi: Vec3) -> Option<(f32, f32)> {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return None;
        }
        let h = (wo + wi).normalize();
        let voh = wo.dot(h).max(0.0);
        let d = ggx_d(h, self.alpha());
        let g = smith_g1(wi.z, self.roughness) * smith_g1(wo.z, self.roughness);
        Some((d * g / (4.0 * wo.z), schlick_fresnel(voh)))
    }
}

impl Brdf for FiptBrdf {
    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        match self.spec_terms(wo, wi) {
            None => Vec3::ZERO,
            Some((dg, m)) => {
                let f = self.ks * (1.0 - m) + Vec3::splat(m);
                self.kd * (FRAC_1_PI * wi.z) + f * dg
            }
        }
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        let voh = wo.dot(h);
        let spec = if voh > 0.0 {
            ggx_d(h, self.alpha()) * h.z / (4.0 * voh)
        } else {
            0.0
        };
        0.5 * wi.z * FRAC_1_PI + 0.5 * spec
    }

    #[inline]
    fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < 0.5 {
            super::sample_cosine_hemisphere(u)
        } else {
            // cos²θh = (1−u)/(u(α²−1)+1), in the stable form tan²θh = α²·u/(1−u).
            let a = self.alpha();
            let tan2 = a * a * u.x / (1.0 - u.x).max(f32::MIN_POSITIVE);
            let ct = 1.0 / (1.0 + tan2).sqrt();
            let st = (tan2.sqrt() * ct).min(1.0);
            let phi = TAU * u.y;
            let h = Vec3::new(st * phi.cos(), st * phi.sin(), ct);
            2.0 * wo.dot(h) * h - wo
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0) || !pdf.is_finite() {
            return None;
        }
        let f = self.eval(wo, wi);
        Some(BrdfSample {
            wi,
            pdf,
            weight: f / pdf,
        })
    }
}
