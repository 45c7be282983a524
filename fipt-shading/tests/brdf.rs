//! The BRDF test ladder for every model ([`fipt_shading::brdf::ladder::check`]: reciprocity,
//! sampling weights, chi-square of `sample` against `pdf`, white furnace, Monte Carlo vs
//! quadrature, extremes), then each model's analytic values.
use fipt_core::brdf::Brdf;
use fipt_core::reflectance::ReflectanceModel;
use fipt_shading::brdf::ladder::{self, albedo_mc, albedo_quadrature, chi_square, dir, Ladder};
use fipt_shading::brdf::{BrdfModel, Lambert, MicrofacetBrdf};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

fn model(m: ReflectanceModel, kd: Vec3, ks: Vec3) -> impl Fn(f32) -> BrdfModel {
    move |s| BrdfModel::Microfacet(MicrofacetBrdf::with_model(m, kd, ks, s))
}

/// Every model through the whole ladder, as a mixed material (kd + ks may exceed 1: no albedo
/// bound) and as a white metal (white furnace: albedo ≤ 1).
#[test]
fn every_model_passes_the_ladder() {
    let any = Ladder {
        max_albedo: 2.0,
        ..Default::default()
    };
    let furnace = Ladder::default();
    for m in ReflectanceModel::ALL {
        let mixed = model(m, Vec3::new(0.5, 0.3, 0.1), Vec3::new(0.04, 0.6, 0.9));
        ladder::check(&format!("{m} mixed"), &any, mixed).unwrap();
        ladder::check(
            &format!("{m} white metal"),
            &furnace,
            model(m, Vec3::ZERO, Vec3::ONE),
        )
        .unwrap();
    }
    let lambert = |_| Lambert {
        albedo: Vec3::splat(0.7),
    };
    let l = Ladder {
        roughness: vec![1.0],
        theta_o_deg: vec![0.0, 80.0],
        ..Default::default()
    };
    ladder::check("lambert", &l, lambert).unwrap();
}

#[test]
fn construct_clamps_roughness_to_the_model_range() {
    assert_eq!(
        MicrofacetBrdf::new(Vec3::ONE, Vec3::ONE, 0.0).roughness,
        0.02
    );
    assert_eq!(
        MicrofacetBrdf::new(Vec3::ONE, Vec3::ONE, 3.0).roughness,
        1.0
    );
    assert_eq!(MicrofacetBrdf::new(Vec3::ONE, Vec3::ONE, 0.5).alpha(), 0.25);
}

/// The cosine convention: `eval` = f · cos θi.
#[test]
fn eval_includes_the_incident_cosine_and_matches_hand_values() {
    let l = Lambert {
        albedo: Vec3::new(0.2, 0.5, 0.8),
    };
    let wo = dir(0.3, 0.1);
    for theta in [0.0f32, 0.5, 1.2, 1.5] {
        let wi = dir(theta, 2.0);
        let e = l.eval(wo, wi);
        assert!((e - l.albedo / PI * theta.cos()).abs().max_element() < 1e-6);
    }
    // FIPT at normal incidence, σ = 1: D = 1/π, G = 1, F = ks → f = kd/π + ks/(4π).
    let (kd, ks) = (Vec3::new(0.3, 0.2, 0.1), Vec3::new(0.04, 0.5, 0.9));
    let b = MicrofacetBrdf::new(kd, ks, 1.0);
    let e = b.eval(Vec3::Z, Vec3::Z);
    assert!(
        (e - (kd / PI + ks / (4.0 * PI))).abs().max_element() < 1e-6,
        "{e}"
    );
    // Pure diffuse part halves when cos θi halves.
    let d = MicrofacetBrdf::new(kd, Vec3::ZERO, 1.0);
    let (wo, wi) = (Vec3::Z, dir(60f32.to_radians(), 0.0));
    let diffuse_only =
        d.eval(wo, wi) - MicrofacetBrdf::new(Vec3::ZERO, Vec3::ZERO, 1.0).eval(wo, wi);
    assert!((diffuse_only - kd / PI * 0.5).abs().max_element() < 1e-6);
    // Off-specular hand value: σ = 0.5, α = 0.25, wo = wi at 60°: h = n.
    let b = MicrofacetBrdf::new(Vec3::ZERO, Vec3::ONE, 0.5);
    let w = dir(60f32.to_radians(), 0.0);
    let wi = dir(60f32.to_radians(), PI);
    let a2 = 0.25f32 * 0.25;
    let dval = a2 / (PI * (a2 - 1.0 + 1.0) * (a2 - 1.0 + 1.0)); // cos θh = 1
    let k = 1.5f32 * 1.5 / 8.0;
    let g1 = 0.5 / (0.5 * (1.0 - k) + k);
    let f = 1.0; // ks = 1
    let expected = dval * g1 * g1 * f / (4.0 * 0.5 * 0.5) * 0.5;
    let got = b.eval(w, wi).x;
    assert!(
        (got - expected).abs() < 1e-5 * expected,
        "{got} vs {expected}"
    );
}

/// A sampler and a pdf that disagree (sampling σ = 0.45, pdf of σ = 0.5): the test has power.
#[test]
fn chi_square_rejects_a_mismatched_pdf() {
    struct Pair(MicrofacetBrdf, MicrofacetBrdf);
    impl Brdf for Pair {
        fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
            self.1.eval(wo, wi)
        }
        fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
            self.1.pdf(wo, wi)
        }
        fn sample(&self, wo: Vec3, u: f32, u2: Vec2) -> Option<fipt_core::brdf::BrdfSample> {
            self.0.sample(wo, u, u2)
        }
    }
    let sampler = MicrofacetBrdf::new(Vec3::splat(0.5), Vec3::splat(0.5), 0.45);
    let pdf = MicrofacetBrdf::new(Vec3::splat(0.5), Vec3::splat(0.5), 0.5);
    let (chi2, p, dof) = chi_square(&Pair(sampler, pdf), dir(0.5, 0.3), 0.25, 400_000, 6).unwrap();
    assert!(
        p < 1e-6,
        "a 10 % roughness mismatch went unnoticed: χ²={chi2} dof={dof} p={p}"
    );
}

/// FIPT's model: analytic directional albedos. A white metal at σ = 1 seen from the normal
/// reflects 1 − ln 2; the diffuse lobe integrates to kd exactly.
#[test]
fn fipt_model_analytic_albedos() {
    // Analytic: D = 1/π, G1(wo) = 1, G1(c) = 2c/(1+c) → albedo = 1 − ln 2. (Schlick-GGX
    // masking with k = (σ+1)²/8 loses energy at grazing angles and low roughness: 0.18 at
    // σ = 0.02, θo = 85°, a property of the reference model.)
    let metal = MicrofacetBrdf::new(Vec3::ZERO, Vec3::ONE, 1.0);
    let (a, se) = albedo_mc(&metal, Vec3::Z, 200_000, 7);
    let exact = 1.0 - 2f32.ln();
    assert!(
        (a.x - exact).abs() < 4.0 * se + 1e-4,
        "σ=1 θo=0: {} vs 1 − ln 2 = {exact}",
        a.x
    );
    // The diffuse lobe integrates to kd exactly (the model has no (1−F) factor on it).
    let wo = dir(0.7, 0.0);
    for s in [0.02f32, 0.5, 1.0] {
        let with = albedo_quadrature(
            &MicrofacetBrdf::new(Vec3::splat(0.8), Vec3::splat(0.04), s),
            wo,
            800,
            200,
        );
        let without = albedo_quadrature(
            &MicrofacetBrdf::new(Vec3::ZERO, Vec3::splat(0.04), s),
            wo,
            800,
            200,
        );
        assert!(
            ((with - without).x - 0.8).abs() < 2e-3,
            "σ={s}: diffuse albedo {}",
            (with - without).x
        );
    }
    let (a, _) = albedo_mc(&Lambert { albedo: Vec3::ONE }, wo, 10_000, 1);
    assert!(
        (a - Vec3::ONE).abs().max_element() < 1e-6,
        "cosine sampling of Lambert has weight exactly ρ"
    );
}

/// `principled`: Burley's diffuse albedo seen from the normal is 41/42 + 5σ/84 (F_o = 0,
/// R = σ (1 + cos θi)): darker than Lambert at σ = 0.02, brighter (retro-reflection) at σ = 1;
/// hand values at normal incidence and at a grazing retro-reflection; and the white metal at
/// σ = 1 seen from the normal reflects 1 − ln 2 under exact Smith masking too (G1 = 2c/(1 + c)
/// at α = 1).
#[test]
fn principled_model_analytic_values() {
    let p = ReflectanceModel::Principled;
    for s in [0.02f32, 0.5, 1.0] {
        let with = albedo_quadrature(
            &MicrofacetBrdf::with_model(p, Vec3::ONE, Vec3::ZERO, s),
            Vec3::Z,
            2000,
            16,
        );
        let without = albedo_quadrature(
            &MicrofacetBrdf::with_model(p, Vec3::ZERO, Vec3::ZERO, s),
            Vec3::Z,
            2000,
            16,
        );
        let want = 41.0 / 42.0 + 5.0 * s / 84.0;
        assert!(
            ((with - without).x - want).abs() < 1e-3,
            "σ={s}: Burley albedo {} vs {want}",
            (with - without).x
        );
    }
    // Both directions at normal incidence: F_o = F_i = 0, B = 1: f = kd/π + ks·D·G/4 with
    // D(σ = 1) = 1/π, G = 1.
    let (kd, ks) = (Vec3::new(0.3, 0.2, 0.1), Vec3::new(0.04, 0.5, 0.9));
    let e = MicrofacetBrdf::with_model(p, kd, ks, 1.0).eval(Vec3::Z, Vec3::Z);
    assert!(
        (e - (kd / PI + ks / (4.0 * PI))).abs().max_element() < 1e-6,
        "{e}"
    );
    // Grazing retro-reflection: ωo = ωi at 80°, σ = 1 (h = ωo, so R = 2σ).
    let w = dir(80f32.to_radians(), 0.0);
    let f = (1.0 - 80f32.to_radians().cos()).powi(5);
    let rr = 2.0; // 2σ(h·ωo)² with h = ωo
    let b = (1.0 - 0.5 * f) * (1.0 - 0.5 * f) + rr * (f + f + f * f * (rr - 1.0));
    let d = MicrofacetBrdf::with_model(p, kd, Vec3::ZERO, 1.0).eval(w, w)
        - MicrofacetBrdf::with_model(p, Vec3::ZERO, Vec3::ZERO, 1.0).eval(w, w);
    assert!((d - kd / PI * b * w.z).abs().max_element() < 1e-5, "{d}");
    let (a, se) = albedo_mc(
        &MicrofacetBrdf::with_model(p, Vec3::ZERO, Vec3::ONE, 1.0),
        Vec3::Z,
        200_000,
        7,
    );
    let exact = 1.0 - 2f32.ln();
    assert!((a.x - exact).abs() < 4.0 * se + 1e-4, "{} vs {exact}", a.x);
}

/// `eval_pdf` is, bit for bit, `eval` and `pdf` called apart (the renderer and the refinement
/// rely on it: their outputs did not change when they switched): every model and Lambert, σ
/// from 0.02 to 1, directions from normal to grazing, mirror pairs and pairs below the horizon.
#[test]
fn eval_pdf_is_eval_and_pdf_bit_for_bit() {
    let mut brdfs: Vec<BrdfModel> = vec![BrdfModel::Lambert(Lambert {
        albedo: Vec3::new(0.7, 0.2, 0.05),
    })];
    for m in ReflectanceModel::ALL {
        for s in [0.02f32, 0.1, 0.35, 0.7, 1.0] {
            for (kd, ks) in [
                (Vec3::new(0.5, 0.3, 0.1), Vec3::new(0.04, 0.6, 0.9)),
                (Vec3::ZERO, Vec3::ONE),
                (Vec3::ONE, Vec3::ZERO),
            ] {
                brdfs.push(model(m, kd, ks)(s));
            }
        }
    }
    let thetas = [0.0f32, 0.3, 0.9, 1.3, 1.55, 1.5707, 1.65];
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    for b in &brdfs {
        for &to in &thetas {
            for &ti in &thetas {
                for phi in [0.0f32, 1.1, std::f32::consts::PI] {
                    let (wo, wi) = (dir(to, 0.4), dir(ti, 0.4 + phi));
                    let (f, p) = b.eval_pdf(wo, wi);
                    assert_eq!(bits(f), bits(b.eval(wo, wi)), "{b:?} {wo} {wi}");
                    assert_eq!(p.to_bits(), b.pdf(wo, wi).to_bits(), "{b:?} {wo} {wi}");
                }
            }
        }
    }
}
