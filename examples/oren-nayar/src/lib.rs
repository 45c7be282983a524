//! A reflectance model from a crate of its own: Oren–Nayar's rough diffuse lobe (in Fujii's
//! form) under the GGX specular lobe of `principled`. Registering it
//! ([`register`]) is all it takes for `[model] brdf = "oren-nayar"` to drive the bake, the
//! refinement, the training, the re-renders and `fipt synth --brdf oren-nayar`.
//!
//! # The diffuse lobe
//! Fujii's Oren–Nayar ("A tiny improvement of Oren–Nayar reflectance model", 2012):
//! f_d = kd/π · A(σ)·(1 + σ·s/t), with s = ωi·ωo − cos θi cos θo (the azimuthal term),
//! t = max(cos θi, cos θo) where s > 0 and 1 elsewhere, and A(σ) = 1 / (1 + (π/2 − 2/3)·σ). It
//! is Lambert at σ = 0 and darkens and flattens towards σ = 1 (retro-reflective, as a rough
//! plaster or cloth).
//!
//! fipt's factorised image needs the diffuse factor as a polynomial of degree 2 in σ (the
//! shadings carry Ld0, Ld1, Ld2), so A(σ) and σ·A(σ) are replaced by their least-squares
//! quadratics on [0.02, 1] ([`A_FIT`], [`SIGMA_A_FIT`]; largest error 0.011 and 0.012, checked
//! by a test). Here σ is both lobes' roughness, as in `principled` (GGX α = σ²).
//!
//! # The specular lobe
//! `principled`'s: GGX with Smith's separable masking, called from fipt-core so that formula
//! stays in one place.
use fipt_core::reflectance::{ReflectanceFormulas, ReflectanceModel};
use fipt_pipeline::components::Components;

/// The config name.
pub const NAME: &str = "oren-nayar";

/// A(σ) ≈ a0 + a1·σ + a2·σ² on [0.02, 1].
pub const A_FIT: [f32; 3] = [0.986_612, -0.738_706, 0.284_462];
/// σ·A(σ) ≈ b0 + b1·σ + b2·σ² on [0.02, 1].
pub const SIGMA_A_FIT: [f32; 3] = [0.014_808, 0.817_035, -0.314_625];

/// Fujii's A(σ), exact (the fits' target).
pub fn fujii_a(sigma: f32) -> f32 {
    1.0 / (1.0 + (std::f32::consts::FRAC_PI_2 - 2.0 / 3.0) * sigma)
}

/// The azimuthal factor s/t of the diffuse lobe.
#[inline]
pub fn s_over_t(cos_o: f32, cos_i: f32, io: f32) -> f32 {
    let s = io - cos_o * cos_i;
    if s > 0.0 {
        s / cos_o.max(cos_i)
    } else {
        s
    }
}

/// The model: Oren–Nayar (Fujii) diffuse, GGX with Smith masking.
pub struct OrenNayar;

impl ReflectanceFormulas for OrenNayar {
    fn name(&self) -> &'static str {
        NAME
    }
    fn description(&self) -> &'static str {
        "Oren–Nayar diffuse (Fujii's form, quadratic in σ) with principled's GGX lobe (crate oren-nayar)"
    }
    fn diffuse_depends_on_roughness(&self) -> bool {
        true
    }
    #[inline]
    fn g1(&self, cos: f32, sigma: f32) -> f32 {
        ReflectanceModel::Principled.g1(cos, sigma)
    }
    #[inline]
    fn diffuse_basis(&self, cos_o: f32, cos_i: f32, io: f32) -> [f32; 3] {
        let g = s_over_t(cos_o, cos_i, io);
        std::array::from_fn(|k| A_FIT[k] + SIGMA_A_FIT[k] * g)
    }
}

/// The one instance the registry points to.
pub static MODEL: OrenNayar = OrenNayar;

/// `components` with the `oren-nayar` reflectance model registered.
pub fn register(components: Components) -> Components {
    components.with_reflectance(&MODEL)
}
