//! The external model passes the BRDF ladder as the built-in ones do, its quadratic fits stay
//! within their stated error of Fujii's exact lobe, and a white rough diffuser keeps its energy.
use fipt_core::reflectance::{ReflectanceFormulas, ReflectanceModel};
use fipt_shading::brdf::ladder::{self, albedo_quadrature, dir, Ladder};
use fipt_shading::brdf::{BrdfModel, MicrofacetBrdf};
use glam::Vec3;
use oren_nayar::{fujii_a, s_over_t, A_FIT, MODEL, SIGMA_A_FIT};
use std::f32::consts::PI;

fn model() -> ReflectanceModel {
    ReflectanceModel::register(&MODEL).unwrap()
}

fn brdf(kd: Vec3, ks: Vec3) -> impl Fn(f32) -> BrdfModel {
    let m = model();
    move |s| BrdfModel::Microfacet(MicrofacetBrdf::with_model(m, kd, ks, s))
}

/// Reciprocity, sampling against pdf (chi-square), energy and extremes, as a mixed material
/// and a white metal (the white furnace); the diffuse lobe's own energy is checked below.
#[test]
fn oren_nayar_passes_the_ladder() {
    let any = Ladder {
        max_albedo: 2.0,
        ..Default::default()
    };
    let mixed = brdf(Vec3::new(0.5, 0.3, 0.1), Vec3::new(0.04, 0.6, 0.9));
    ladder::check("oren-nayar mixed", &any, mixed).unwrap();
    let furnace = Ladder::default();
    ladder::check(
        "oren-nayar white metal",
        &furnace,
        brdf(Vec3::ZERO, Vec3::ONE),
    )
    .unwrap();
}

/// The fits against A(σ) and σ·A(σ), and the diffuse factor against Fujii's exact lobe.
#[test]
fn the_quadratic_fits_follow_fujii_within_their_stated_error() {
    let poly = |c: [f32; 3], s: f32| c[0] + c[1] * s + c[2] * s * s;
    let (mut ea, mut eb) = (0f32, 0f32);
    for k in 0..=980 {
        let s = 0.02 + k as f32 * 0.001;
        ea = ea.max((poly(A_FIT, s) - fujii_a(s)).abs());
        eb = eb.max((poly(SIGMA_A_FIT, s) - s * fujii_a(s)).abs());
    }
    assert!(ea < 0.011 && eb < 0.012, "fit errors {ea}, {eb}");
    for (o, i) in [(0.3f32, 1.1f32), (1.2, 1.2), (0.0, 0.7)] {
        for phi in [0.0f32, 1.0, 3.1] {
            let (wo, wi) = (dir(o, 0.0), dir(i, phi));
            let b = MODEL.diffuse_basis(wo.z, wi.z, wo.dot(wi));
            for s in [0.02f32, 0.4, 1.0] {
                let got = b[0] + s * b[1] + s * s * b[2];
                let g = s_over_t(wo.z, wi.z, wo.dot(wi));
                let want = fujii_a(s) * (1.0 + s * g);
                assert!(
                    (got - want).abs() <= 0.012 * (1.0 + g.abs()),
                    "{got} vs {want}"
                );
            }
        }
    }
    // The diffuse lobe alone keeps its energy: ∫ B cos θi/π dωi ≤ 1 at every view angle.
    for theta_o in [0.0f32, 30.0, 60.0, 80.0, 89.0] {
        let wo = dir(theta_o.to_radians(), 0.0);
        for s in [0.02f32, 0.3, 0.7, 1.0] {
            let (nt, np) = (128, 256);
            let (dt, dp) = (0.5 * PI / nt as f32, 2.0 * PI / np as f32);
            let mut albedo = 0.0;
            for a in 0..nt {
                for b in 0..np {
                    let wi = dir((a as f32 + 0.5) * dt, (b as f32 + 0.5) * dp);
                    let k = MODEL.diffuse_basis(wo.z.max(1e-4), wi.z, wo.dot(wi));
                    let f = (k[0] + s * k[1] + s * s * k[2]) / PI;
                    albedo += f * wi.z * (wi.z.max(0.0).acos().sin()) * dt * dp;
                }
            }
            assert!(albedo <= 1.0 + 1e-3, "θo {theta_o}, σ {s}: albedo {albedo}");
        }
    }
    // Reciprocal, and darker than Lambert towards σ = 1 at normal incidence (A(1) = 0.52).
    assert_eq!(
        MODEL.diffuse_basis(0.3, 0.8, 0.5),
        MODEL.diffuse_basis(0.8, 0.3, 0.5)
    );
    let rough = albedo_quadrature(
        &MicrofacetBrdf::with_model(model(), Vec3::ONE, Vec3::ZERO, 1.0),
        Vec3::Z,
        128,
        256,
    );
    assert!((rough.x - 0.53).abs() < 0.03, "albedo at σ = 1: {rough}");
}
