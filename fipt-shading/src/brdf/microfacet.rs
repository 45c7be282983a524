//! The metallic-workflow microfacet BRDF of a [`ReflectanceModel`] (FIPT's or `principled`).
//!
//! f(ωo, ωi) = kd/π·B(σ) + D·G·F / (4 (n·ωi)(n·ωo)) with
//! * B: the model's diffuse factor (1 for FIPT, Burley with retro-reflection for `principled`);
//! * D: GGX (Trowbridge–Reitz), α = σ²: D(h) = α² / (π ((n·h)²(α²−1)+1)²);
//! * G: separable Smith with the model's G1 (Schlick-GGX k = (σ+1)²/8, or exact GGX);
//! * F: Schlick on ωo·h, F = ks + (1−ks)(1−ωo·h)⁵.
//!
//! Every formula comes from [`fipt_core::reflectance`]. The diffuse lobe has no (1−F) factor,
//! so kd + specular albedo can exceed 1 for bright dielectrics (as in the reference and in
//! Mitsuba's `principled`). Sampling: 50 % cosine, 50 % GGX half-vector
//! (cos²θh = (1−u)/(u(α²−1)+1), evaluated as tan²θh = α²u/(1−u)), pdf = ½·cosθi/π + ½·D·(n·h)/(4 ωo·h).
//!
//! | parameter | meaning | range |
//! |---|---|---|
//! | `kd` | diffuse albedo | [0, 1]³ |
//! | `ks` | specular reflectance F0 | [0, 1]³ |
//! | `roughness` | σ (GGX α = σ²) | [0.02, 1] (clamped) |
use fipt_core::brdf::{Brdf, BrdfSample};
use fipt_core::color::Rgb;
use fipt_core::reflectance::{clamp_roughness, ggx_d, schlick_weight, ReflectanceModel};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, TAU};

/// The BRDF of a [`ReflectanceModel`] at one surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MicrofacetBrdf {
    pub model: ReflectanceModel,
    pub kd: Rgb,
    pub ks: Rgb,
    /// σ, clamped to [0.02, 1] by the constructors.
    pub roughness: f32,
}

impl MicrofacetBrdf {
    /// FIPT's model.
    pub fn new(kd: Rgb, ks: Rgb, roughness: f32) -> Self {
        Self::with_model(ReflectanceModel::Fipt, kd, ks, roughness)
    }

    /// The BRDF of `model`.
    pub fn with_model(model: ReflectanceModel, kd: Rgb, ks: Rgb, roughness: f32) -> Self {
        MicrofacetBrdf {
            model,
            kd,
            ks,
            roughness: clamp_roughness(roughness),
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

    /// The half vector, ωo·h and D(h) at (ωo, ωi), both above the horizon: what `eval` and
    /// `pdf` share.
    #[inline]
    fn half(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32, f32) {
        let h = (wo + wi).normalize();
        (h, wo.dot(h), ggx_d(h, self.alpha()))
    }

    /// The specular factors (D·G/(4 cos θo), the two Fresnel weights) used by the shading
    /// factorisation: f_spec·cos θi = cos θi · D·G·(ks·(1−m) + m) / (4 cosθi cosθo) with m = (1−ωo·h)⁵.
    #[inline]
    pub fn spec_terms(&self, wo: Vec3, wi: Vec3) -> Option<(f32, f32)> {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return None;
        }
        let (_, voh, d) = self.half(wo, wi);
        Some(self.spec_of(wo, wi, voh, d))
    }

    #[inline]
    fn spec_of(&self, wo: Vec3, wi: Vec3, voh: f32, d: f32) -> (f32, f32) {
        let g = self.model.g1(wi.z, self.roughness) * self.model.g1(wo.z, self.roughness);
        (d * g / (4.0 * wo.z), schlick_weight(voh.max(0.0)))
    }

    /// The three scalar lobes [d, s0, s1] of f·cos θi = kd·d + ks·s0 + s1 at (ωo, ωi): the
    /// BRDF is linear in kd and ks for a fixed σ (what a differentiable tracer needs); zero
    /// below the horizon.
    #[inline]
    pub fn lobes(&self, wo: Vec3, wi: Vec3) -> [f32; 3] {
        match self.spec_terms(wo, wi) {
            None => [0.0; 3],
            Some(spec) => self.lobes_of(wo, wi, spec),
        }
    }

    #[inline]
    fn lobes_of(&self, wo: Vec3, wi: Vec3, (dg, m): (f32, f32)) -> [f32; 3] {
        let [b0, b1, b2] = self.model.diffuse_basis(wo.z, wi.z, wo.dot(wi));
        let s = self.roughness;
        let b = b0 + s * (b1 + s * b2);
        [FRAC_1_PI * wi.z * b, dg * (1.0 - m), dg * m]
    }

    #[inline]
    fn combine(&self, [d, s0, s1]: [f32; 3]) -> Rgb {
        self.kd * d + self.ks * s0 + Vec3::splat(s1)
    }

    /// The sampling pdf from the shared terms: ½ cosine + ½ GGX half vector.
    #[inline]
    fn pdf_of(wi: Vec3, h: Vec3, voh: f32, d: f32) -> f32 {
        let spec = if voh > 0.0 {
            d * h.z / (4.0 * voh)
        } else {
            0.0
        };
        0.5 * wi.z * FRAC_1_PI + 0.5 * spec
    }
}

impl Brdf for MicrofacetBrdf {
    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        self.combine(self.lobes(wo, wi))
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let (h, voh, d) = self.half(wo, wi);
        Self::pdf_of(wi, h, voh, d)
    }

    #[inline]
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (self.combine([0.0; 3]), 0.0);
        }
        let (h, voh, d) = self.half(wo, wi);
        let lobes = self.lobes_of(wo, wi, self.spec_of(wo, wi, voh, d));
        (self.combine(lobes), Self::pdf_of(wi, h, voh, d))
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
        let (f, pdf) = self.eval_pdf(wo, wi);
        if !(pdf > 0.0) || !pdf.is_finite() {
            return None;
        }
        Some(BrdfSample {
            wi,
            pdf,
            weight: f / pdf,
        })
    }
}
