//! The BRDF test ladder: construction, analytic values and the cosine convention,
//! reciprocity, sampling weights, chi-square of `sample` against `pdf`, white furnace,
//! Monte Carlo vs quadrature, and numerical extremes.
use fipt_core::brdf::Brdf;
use fipt_core::rng::Pcg32;
use fipt_shading::brdf::{BrdfModel, FiptBrdf, Lambert};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

const ROUGHNESS: [f32; 4] = [0.02, 0.2, 0.5, 1.0];
const THETA_O_DEG: [f32; 5] = [0.0, 30.0, 60.0, 85.0, 89.0];

fn dir(theta: f32, phi: f32) -> Vec3 {
    Vec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

fn random_dir(rng: &mut Pcg32) -> Vec3 {
    let z = rng.next_f32();
    let phi = 2.0 * PI * rng.next_f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[test]
fn construct_clamps_roughness_to_the_model_range() {
    assert_eq!(FiptBrdf::new(Vec3::ONE, Vec3::ONE, 0.0).roughness, 0.02);
    assert_eq!(FiptBrdf::new(Vec3::ONE, Vec3::ONE, 3.0).roughness, 1.0);
    assert_eq!(FiptBrdf::new(Vec3::ONE, Vec3::ONE, 0.5).alpha(), 0.25);
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
    let b = FiptBrdf::new(kd, ks, 1.0);
    let e = b.eval(Vec3::Z, Vec3::Z);
    assert!(
        (e - (kd / PI + ks / (4.0 * PI))).abs().max_element() < 1e-6,
        "{e}"
    );
    // Pure diffuse part halves when cos θi halves.
    let d = FiptBrdf::new(kd, Vec3::ZERO, 1.0);
    let (wo, wi) = (Vec3::Z, dir(60f32.to_radians(), 0.0));
    let diffuse_only = d.eval(wo, wi) - FiptBrdf::new(Vec3::ZERO, Vec3::ZERO, 1.0).eval(wo, wi);
    assert!((diffuse_only - kd / PI * 0.5).abs().max_element() < 1e-6);
    // Off-specular hand value: σ = 0.5, α = 0.25, wo = wi at 60°: h = n.
    let b = FiptBrdf::new(Vec3::ZERO, Vec3::ONE, 0.5);
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

#[test]
fn reciprocity_and_sample_weights() {
    let mut rng = Pcg32::new(3, 3);
    for &s in &ROUGHNESS {
        let b = FiptBrdf::new(Vec3::new(0.5, 0.3, 0.1), Vec3::new(0.04, 0.6, 0.9), s);
        for _ in 0..2000 {
            let (wo, wi) = (random_dir(&mut rng), random_dir(&mut rng));
            let fa = b.eval(wo, wi) / wi.z;
            let fb = b.eval(wi, wo) / wo.z;
            assert!(
                (fa - fb).abs().max_element() <= 1e-4 * fa.max_element().max(1.0),
                "σ={s}: {fa} vs {fb}"
            );
            if let Some(smp) = b.sample(wo, rng.next_f32(), rng.next_2d()) {
                let pdf = b.pdf(wo, smp.wi);
                assert!((smp.pdf - pdf).abs() <= 1e-4 * pdf);
                let w = b.eval(wo, smp.wi) / pdf;
                assert!((smp.weight - w).abs().max_element() <= 1e-4 * w.max_element().max(1e-3));
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Chi-square goodness of fit of `sample` against `pdf`.
// Bins: a (θ, φ) grid of the local hemisphere, refined geometrically around the mirror
// direction so that the narrowest lobe (σ = 0.02, α = 4e-4) spans many bins. Expected counts
// are the pdf integrated over each bin by Gauss–Legendre quadrature (8 × 8 nodes).

fn refined_edges(lo: f64, hi: f64, uniform: usize, centre: f64, width: f64) -> Vec<f64> {
    let mut e: Vec<f64> = (0..=uniform)
        .map(|i| lo + (hi - lo) * i as f64 / uniform as f64)
        .collect();
    let mut w = width * 0.25;
    while w < (hi - lo) {
        for x in [centre - w, centre + w] {
            if x > lo && x < hi {
                e.push(x);
            }
        }
        w *= 2.0;
    }
    if centre > lo && centre < hi {
        e.push(centre);
    }
    e.sort_by(|a, b| a.partial_cmp(b).unwrap());
    e.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    e
}

const GL_X: [f64; 8] = [
    -0.9602898564975363,
    -0.7966664774136267,
    -0.5255324099163290,
    -0.1834346424956498,
    0.1834346424956498,
    0.5255324099163290,
    0.7966664774136267,
    0.9602898564975363,
];
const GL_W: [f64; 8] = [
    0.1012285362903763,
    0.2223810344533745,
    0.3137066458778873,
    0.3626837833783620,
    0.3626837833783620,
    0.3137066458778873,
    0.2223810344533745,
    0.1012285362903763,
];

/// Upper tail of the chi-square distribution (Wilson–Hilferty normal approximation).
fn chi2_pvalue(x: f64, dof: f64) -> f64 {
    let z = ((x / dof).powf(1.0 / 3.0) - (1.0 - 2.0 / (9.0 * dof))) / (2.0 / (9.0 * dof)).sqrt();
    0.5 * erfc(z / std::f64::consts::SQRT_2)
}

fn erfc(x: f64) -> f64 {
    // Numerical Recipes' erfcc (fractional error < 1.2e-7).
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.26551223
            + t * (1.00002368
                + t * (0.37409196
                    + t * (0.09678418
                        + t * (-0.18628806
                            + t * (0.27886807
                                + t * (-1.13520398
                                    + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277)))))))))
            .exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

fn chi_square(b: &dyn Brdf, wo: Vec3, alpha: f64, samples: usize, seed: u64) -> (f64, f64, usize) {
    let theta_r = ((wo.x as f64).hypot(wo.y as f64)).atan2(wo.z as f64);
    let phi_r = ((-wo.y as f64).atan2(-wo.x as f64)).rem_euclid(std::f64::consts::TAU);
    let te = refined_edges(0.0, std::f64::consts::FRAC_PI_2, 24, theta_r, alpha);
    let pw = alpha / theta_r.sin().max(0.05);
    // φ grid in [φr − π, φr + π) so the refinement centre is interior.
    let pe: Vec<f64> = refined_edges(
        phi_r - std::f64::consts::PI,
        phi_r + std::f64::consts::PI,
        48,
        phi_r,
        pw,
    );
    let (nt, np) = (te.len() - 1, pe.len() - 1);
    let mut expected = vec![0.0f64; nt * np];
    for i in 0..nt {
        for j in 0..np {
            let (t0, t1, p0, p1) = (te[i], te[i + 1], pe[j], pe[j + 1]);
            let mut acc = 0.0;
            for (xa, wa) in GL_X.iter().zip(GL_W) {
                let t = 0.5 * (t0 + t1) + 0.5 * (t1 - t0) * xa;
                for (xb, wb) in GL_X.iter().zip(GL_W) {
                    let p = 0.5 * (p0 + p1) + 0.5 * (p1 - p0) * xb;
                    let wi = dir(t as f32, p as f32);
                    acc += wa * wb * b.pdf(wo, wi) as f64 * t.sin();
                }
            }
            expected[i * np + j] = acc * 0.25 * (t1 - t0) * (p1 - p0) * samples as f64;
        }
    }
    let mut observed = vec![0.0f64; nt * np];
    let mut rng = Pcg32::new(seed, 17);
    let mut failed = 0usize;
    for _ in 0..samples {
        match b.sample(wo, rng.next_f32(), rng.next_2d()) {
            Some(s) => {
                // atan2, not acos: near the pole z rounds to 1 in f32 while x, y keep precision.
                let (x, y) = (s.wi.x as f64, s.wi.y as f64);
                let t = (x * x + y * y).sqrt().atan2(s.wi.z as f64);
                let mut p = (s.wi.y as f64).atan2(s.wi.x as f64);
                while p < pe[0] {
                    p += std::f64::consts::TAU;
                }
                while p >= pe[np] {
                    p -= std::f64::consts::TAU;
                }
                let i = te.partition_point(|&e| e <= t).clamp(1, nt) - 1;
                let j = pe.partition_point(|&e| e <= p).clamp(1, np) - 1;
                observed[i * np + j] += 1.0;
            }
            None => failed += 1,
        }
    }
    // The failed samples are one more cell: their expected count is what the pdf misses.
    let total_expected: f64 = expected.iter().sum();
    let mut cells: Vec<(f64, f64)> = expected.into_iter().zip(observed).collect();
    cells.push(((samples as f64 - total_expected).max(0.0), failed as f64));
    // Pool cells with expected count < 5, smallest first.
    cells.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
    let mut chi2 = 0.0;
    let mut dof = 0usize;
    let (mut pool_e, mut pool_o) = (0.0, 0.0);
    for (e, o) in cells {
        if e < 5.0 {
            pool_e += e;
            pool_o += o;
            continue;
        }
        chi2 += (o - e) * (o - e) / e;
        dof += 1;
    }
    if pool_e > 0.0 || pool_o > 0.0 {
        assert!(
            pool_e > 0.0 || pool_o == 0.0,
            "samples where the pdf is zero: {pool_o}"
        );
        if pool_e >= 5.0 {
            chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
            dof += 1;
        } else {
            assert!(
                pool_o < pool_e + 6.0 * pool_e.sqrt() + 10.0,
                "{pool_o} samples in cells expecting {pool_e}"
            );
        }
    }
    let dof = (dof.max(2) - 1) as f64;
    (chi2, chi2_pvalue(chi2, dof), dof as usize)
}

#[test]
fn chi_square_sampling_matches_pdf() {
    let tests = ROUGHNESS.len() * THETA_O_DEG.len() + 2;
    let threshold = 0.01 / tests as f64;
    let mut report = Vec::new();
    for (k, &s) in ROUGHNESS.iter().enumerate() {
        for (m, &th) in THETA_O_DEG.iter().enumerate() {
            let b = BrdfModel::Fipt(FiptBrdf::new(Vec3::splat(0.5), Vec3::splat(0.5), s));
            let wo = dir(th.to_radians(), 0.7);
            let (chi2, p, dof) = chi_square(&b, wo, (s * s) as f64, 400_000, (k * 10 + m) as u64);
            report.push(format!("σ={s} θo={th}: χ²={chi2:.1} dof={dof} p={p:.3}"));
            assert!(
                p > threshold,
                "sampling does not follow pdf: {}",
                report.last().unwrap()
            );
        }
    }
    for (i, th) in [0.0f32, 80.0].iter().enumerate() {
        let b = BrdfModel::Lambert(Lambert {
            albedo: Vec3::splat(0.7),
        });
        let (chi2, p, dof) = chi_square(&b, dir(th.to_radians(), 0.0), 1.0, 400_000, 99 + i as u64);
        assert!(p > threshold, "Lambert θo={th}: χ²={chi2} dof={dof} p={p}");
    }
    eprintln!("{}", report.join("\n"));
}

/// A sampler and a pdf that disagree (sampling σ = 0.45, pdf of σ = 0.5): the test has power.
#[test]
fn chi_square_rejects_a_mismatched_pdf() {
    struct Pair(FiptBrdf, FiptBrdf);
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
    let sampler = FiptBrdf::new(Vec3::splat(0.5), Vec3::splat(0.5), 0.45);
    let pdf = FiptBrdf::new(Vec3::splat(0.5), Vec3::splat(0.5), 0.5);
    let (chi2, p, dof) = chi_square(&Pair(sampler, pdf), dir(0.5, 0.3), 0.25, 400_000, 6);
    assert!(
        p < 1e-6,
        "a 10 % roughness mismatch went unnoticed: χ²={chi2} dof={dof} p={p}"
    );
}

/// Directional albedo ∫ eval dωi by importance sampling (mean of weights), with its standard error.
fn albedo_mc(b: &dyn Brdf, wo: Vec3, n: usize, seed: u64) -> (Vec3, f32) {
    let mut rng = Pcg32::new(seed, 2);
    let (mut sum, mut sum2) = (Vec3::ZERO, 0.0f64);
    for _ in 0..n {
        if let Some(s) = b.sample(wo, rng.next_f32(), rng.next_2d()) {
            sum += s.weight;
            sum2 += (s.weight.x as f64).powi(2);
        }
    }
    let mean = sum / n as f32;
    let var = (sum2 / n as f64 - (mean.x as f64).powi(2)).max(0.0);
    (mean, (var / n as f64).sqrt() as f32)
}

/// ∫ eval dωi by brute-force midpoint quadrature on a fine (θ, φ) grid.
fn albedo_quadrature(b: &dyn Brdf, wo: Vec3, nt: usize, np: usize) -> Vec3 {
    let mut acc = Vec3::ZERO;
    let (dt, dp) = (0.5 * PI / nt as f32, 2.0 * PI / np as f32);
    for i in 0..nt {
        let t = (i as f32 + 0.5) * dt;
        for j in 0..np {
            let p = (j as f32 + 0.5) * dp;
            acc += b.eval(wo, dir(t, p)) * (t.sin() * dt * dp);
        }
    }
    acc
}

/// White furnace: with ks = 1 (metal, base colour white) the directional albedo never
/// exceeds 1, for every roughness and view angle, and importance sampling agrees with
/// brute-force quadrature where the lobe is wide enough to integrate on a grid.
#[test]
fn white_furnace_and_monte_carlo_against_quadrature() {
    for s in [0.02f32, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0] {
        let metal = FiptBrdf::new(Vec3::ZERO, Vec3::ONE, s);
        for th in THETA_O_DEG {
            let wo = dir(th.to_radians(), 0.0);
            let (a, se) = albedo_mc(&metal, wo, 200_000, 7);
            assert!(
                a.x <= 1.0 + 4.0 * se + 1e-3,
                "σ={s} θo={th}: albedo {} ± {se}",
                a.x
            );
            // Schlick-GGX masking with k = (σ+1)²/8 loses energy at grazing angles and high
            // roughness (0.18 at σ = 0.02, θo = 85°): a property of the reference model.
            if s == 1.0 && th == 0.0 {
                // Analytic: D = 1/π, G1(wo) = 1, G1(c) = 2c/(1+c) → albedo = 1 − ln 2.
                let exact = 1.0 - 2f32.ln();
                assert!(
                    (a.x - exact).abs() < 4.0 * se + 1e-4,
                    "σ=1 θo=0: {} vs 1 − ln 2 = {exact}",
                    a.x
                );
            }
            if s >= 0.2 && th <= 60.0 {
                let q = albedo_quadrature(&metal, wo, 400, 400);
                assert!(
                    (a.x - q.x).abs() < 5.0 * se + 2e-3,
                    "σ={s} θo={th}: MC {} vs quadrature {}",
                    a.x,
                    q.x
                );
            }
        }
    }
    // The diffuse lobe integrates to kd exactly (the model has no (1−F) factor on it).
    let wo = dir(0.7, 0.0);
    for s in [0.02f32, 0.5, 1.0] {
        let with = albedo_quadrature(
            &FiptBrdf::new(Vec3::splat(0.8), Vec3::splat(0.04), s),
            wo,
            800,
            200,
        );
        let without = albedo_quadrature(
            &FiptBrdf::new(Vec3::ZERO, Vec3::splat(0.04), s),
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

#[test]
fn extremes_give_finite_values() {
    let mut rng = Pcg32::new(8, 8);
    let grazing = [1.0f32, 1e-2, 1e-4, 1e-7, 0.0, -1e-7, -0.5];
    for s in [0.02f32, 1.0] {
        let b = FiptBrdf::new(Vec3::splat(0.5), Vec3::splat(0.9), s);
        for &z in &grazing {
            let wo = Vec3::new((1.0 - z * z).max(0.0).sqrt(), 0.0, z).normalize();
            for _ in 0..500 {
                let wi = random_dir(&mut rng);
                for wi in [wi, -wi, wo, Vec3::new(-wo.x, 0.0, wo.z)] {
                    let e = b.eval(wo, wi);
                    let p = b.pdf(wo, wi);
                    assert!(
                        e.is_finite() && e.min_element() >= 0.0 && p.is_finite() && p >= 0.0,
                        "σ={s} wo={wo} wi={wi}: {e} {p}"
                    );
                    if wi.z <= 0.0 || wo.z <= 0.0 {
                        assert_eq!(e, Vec3::ZERO);
                        assert_eq!(p, 0.0);
                    }
                }
                if let Some(smp) = b.sample(wo, rng.next_f32(), rng.next_2d()) {
                    assert!(
                        smp.weight.is_finite() && smp.pdf > 0.0 && smp.wi.z > 0.0,
                        "σ={s} wo={wo}: {smp:?}"
                    );
                }
            }
            // The random numbers at their extremes.
            for u in [
                Vec2::ZERO,
                Vec2::new(0.99999994, 0.99999994),
                Vec2::new(0.0, 0.99999994),
            ] {
                for lobe in [0.0, 0.99999994] {
                    if let Some(smp) = b.sample(wo, lobe, u) {
                        assert!(smp.weight.is_finite() && smp.wi.is_finite());
                    }
                }
            }
        }
    }
}
