//! The BRDF test ladder: checks any [`Brdf`] runs in one call ([`check`]), and the pieces
//! (chi-square of `sample` against `pdf`, directional albedo by sampling and by quadrature)
//! for model-specific tests.
//!
//! [`check`] asserts, for every roughness of a [`Ladder`] and a spread of view angles:
//! 1. **reciprocity**: f(ωo, ωi) = f(ωi, ωo) (eval / cos θi);
//! 2. **sampling consistency**: a sample's pdf is `pdf(ωo, ωi)` and its weight `eval / pdf`;
//! 3. **chi-square**: the distribution of `sample` follows `pdf` (Bonferroni-corrected 1 %);
//! 4. **energy**: the directional albedo (mean sample weight) stays below `max_albedo`, and
//!    agrees with brute-force quadrature of `eval` where the lobe is wide enough for a grid;
//! 5. **extremes**: grazing and below-horizon directions and the random numbers' end points
//!    give finite, non-negative values, zero below the horizon.
//!
//! Each check returns `Err(message)` naming the roughness and angle that failed.
use fipt_core::brdf::Brdf;
use fipt_core::color::Rgb;
use fipt_core::rng::Pcg32;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// What [`check`] runs over.
pub struct Ladder {
    /// Roughness values σ passed to the constructor (GGX α = σ² for the chi-square bins).
    pub roughness: Vec<f32>,
    /// View angles θo in degrees.
    pub theta_o_deg: Vec<f32>,
    /// Samples per chi-square test.
    pub chi_square_samples: usize,
    /// Upper bound of the directional albedo (per channel, plus 4 standard errors).
    pub max_albedo: f32,
}

impl Default for Ladder {
    fn default() -> Self {
        Ladder {
            roughness: vec![0.02, 0.2, 0.5, 1.0],
            theta_o_deg: vec![0.0, 30.0, 60.0, 85.0, 89.0],
            chi_square_samples: 400_000,
            max_albedo: 1.0,
        }
    }
}

/// The unit direction at polar angle `theta` and azimuth `phi` (local frame, normal = +z).
pub fn dir(theta: f32, phi: f32) -> Vec3 {
    Vec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// A direction uniform on the upper hemisphere.
pub fn random_dir(rng: &mut Pcg32) -> Vec3 {
    let z = rng.next_f32();
    let phi = 2.0 * PI * rng.next_f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Runs the whole ladder on the BRDFs `make(σ)`; `name` prefixes the messages.
pub fn check<B: Brdf>(name: &str, ladder: &Ladder, make: impl Fn(f32) -> B) -> Result<(), String> {
    let tests = ladder.roughness.len() * ladder.theta_o_deg.len();
    let threshold = 0.01 / tests.max(1) as f64;
    for (k, &s) in ladder.roughness.iter().enumerate() {
        let b = make(s);
        let at = |what: &str| format!("{name} σ={s}: {what}");
        reciprocity_and_weights(&b).map_err(|e| at(&e))?;
        extremes(&b).map_err(|e| at(&e))?;
        for (m, &th) in ladder.theta_o_deg.iter().enumerate() {
            let wo = dir(th.to_radians(), 0.7);
            let seed = (k * 100 + m) as u64;
            let (chi2, p, dof) =
                chi_square(&b, wo, (s * s) as f64, ladder.chi_square_samples, seed)
                    .map_err(|e| at(&format!("θo={th}: {e}")))?;
            if p <= threshold {
                return Err(at(&format!(
                    "θo={th}: sampling does not follow pdf (χ²={chi2:.1}, dof={dof}, p={p:.2e})"
                )));
            }
            let (a, se) = albedo_mc(&b, wo, 200_000, seed);
            if a.max_element() > ladder.max_albedo + 4.0 * se + 1e-3 {
                return Err(at(&format!(
                    "θo={th}: albedo {a} ± {se} above {}",
                    ladder.max_albedo
                )));
            }
            if s >= 0.2 && th <= 60.0 {
                let q = albedo_quadrature(&b, wo, 400, 400);
                if (a - q).abs().max_element() > 5.0 * se + 2e-3 {
                    return Err(at(&format!("θo={th}: MC albedo {a} vs quadrature {q}")));
                }
            }
        }
    }
    Ok(())
}

/// Reciprocity of eval/cos θi and a sample's pdf and weight against `pdf` and `eval`.
pub fn reciprocity_and_weights(b: &dyn Brdf) -> Result<(), String> {
    let mut rng = Pcg32::new(3, 3);
    for _ in 0..2000 {
        let (wo, wi) = (random_dir(&mut rng), random_dir(&mut rng));
        let fa = b.eval(wo, wi) / wi.z;
        let fb = b.eval(wi, wo) / wo.z;
        if (fa - fb).abs().max_element() > 1e-4 * fa.max_element().max(1.0) {
            return Err(format!("not reciprocal at {wo}, {wi}: {fa} vs {fb}"));
        }
        if let Some(smp) = b.sample(wo, rng.next_f32(), rng.next_2d()) {
            let pdf = b.pdf(wo, smp.wi);
            if (smp.pdf - pdf).abs() > 1e-4 * pdf {
                return Err(format!("sample pdf {} vs pdf() {pdf}", smp.pdf));
            }
            let w = b.eval(wo, smp.wi) / pdf;
            if (smp.weight - w).abs().max_element() > 1e-4 * w.max_element().max(1e-3) {
                return Err(format!("sample weight {} vs eval/pdf {w}", smp.weight));
            }
        }
    }
    Ok(())
}

/// Finite, non-negative values at grazing and below-horizon directions and at the random
/// numbers' end points; zero below the horizon.
pub fn extremes(b: &dyn Brdf) -> Result<(), String> {
    let mut rng = Pcg32::new(8, 8);
    for z in [1.0f32, 1e-2, 1e-4, 1e-7, 0.0, -1e-7, -0.5] {
        let wo = Vec3::new((1.0 - z * z).max(0.0).sqrt(), 0.0, z).normalize();
        for _ in 0..500 {
            let wi = random_dir(&mut rng);
            for wi in [wi, -wi, wo, Vec3::new(-wo.x, 0.0, wo.z)] {
                let (e, p) = (b.eval(wo, wi), b.pdf(wo, wi));
                if !(e.is_finite() && e.min_element() >= 0.0 && p.is_finite() && p >= 0.0) {
                    return Err(format!("wo={wo} wi={wi}: eval {e}, pdf {p}"));
                }
                if (wi.z <= 0.0 || wo.z <= 0.0) && (e != Vec3::ZERO || p != 0.0) {
                    return Err(format!("below the horizon wo={wo} wi={wi}: {e} {p}"));
                }
            }
            if let Some(smp) = b.sample(wo, rng.next_f32(), rng.next_2d()) {
                if !(smp.weight.is_finite() && smp.pdf > 0.0 && smp.wi.z > 0.0) {
                    return Err(format!("wo={wo}: bad sample {smp:?}"));
                }
            }
        }
        for u in [
            Vec2::ZERO,
            Vec2::new(0.99999994, 0.99999994),
            Vec2::new(0.0, 0.99999994),
        ] {
            for lobe in [0.0, 0.99999994] {
                if let Some(smp) = b.sample(wo, lobe, u) {
                    if !(smp.weight.is_finite() && smp.wi.is_finite()) {
                        return Err(format!("wo={wo} u={u} lobe={lobe}: {smp:?}"));
                    }
                }
            }
        }
    }
    Ok(())
}

/// Directional albedo ∫ eval dωi by importance sampling (mean of weights), with the standard
/// error of its largest channel.
pub fn albedo_mc(b: &dyn Brdf, wo: Vec3, n: usize, seed: u64) -> (Rgb, f32) {
    let mut rng = Pcg32::new(seed, 2);
    let (mut sum, mut sum2) = (Vec3::ZERO, Vec3::ZERO);
    for _ in 0..n {
        if let Some(s) = b.sample(wo, rng.next_f32(), rng.next_2d()) {
            sum += s.weight;
            sum2 += s.weight * s.weight;
        }
    }
    let mean = sum / n as f32;
    let var = (sum2 / n as f32 - mean * mean).max(Vec3::ZERO);
    (mean, (var.max_element() / n as f32).sqrt())
}

/// ∫ eval dωi by brute-force midpoint quadrature on an `nt × np` (θ, φ) grid.
pub fn albedo_quadrature(b: &dyn Brdf, wo: Vec3, nt: usize, np: usize) -> Rgb {
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
pub fn chi2_pvalue(x: f64, dof: f64) -> f64 {
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

/// Chi-square goodness of fit of `b.sample` against `b.pdf` at `wo`: (χ², p-value, dof).
/// Bins: a (θ, φ) grid of the local hemisphere, refined geometrically around the mirror
/// direction over a width of `alpha` (the lobe's GGX α) so the narrowest lobe spans many bins;
/// expected counts are the pdf integrated over each bin by 8 × 8 Gauss–Legendre quadrature.
/// Err when samples land where the pdf is zero.
pub fn chi_square(
    b: &dyn Brdf,
    wo: Vec3,
    alpha: f64,
    samples: usize,
    seed: u64,
) -> Result<(f64, f64, usize), String> {
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
        if pool_e == 0.0 && pool_o > 0.0 {
            return Err(format!("{pool_o} samples where the pdf is zero"));
        }
        if pool_e >= 5.0 {
            chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
            dof += 1;
        } else {
            if pool_o >= pool_e + 6.0 * pool_e.sqrt() + 10.0 {
                return Err(format!("{pool_o} samples in cells expecting {pool_e}"));
            }
        }
    }
    let dof = (dof.max(2) - 1) as f64;
    Ok((chi2, chi2_pvalue(chi2, dof), dof as usize))
}
