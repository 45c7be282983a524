//! The initial bake: known incident light, and the closure test on a generated scene.
use fipt_bake::bake::{
    diffuse_direct, diffuse_moments, diffuse_shading, moments_express, specular_shading,
    specular_shading_mixture, BakeConfig, FactorizedBaker, SampleStream, SamplerKind, SlfLight,
};
use fipt_bake::slf::{Cube, SlfBuilder};
use fipt_core::brdf::Brdf;
use fipt_core::dataset::{Dataset, GtKind};
use fipt_core::image::BadPixelPolicy;
use fipt_core::metrics::srgb_psnr;
use fipt_core::reflectance::{PrincipledViaTrait, ReflectanceModel};
use fipt_core::rng::Pcg32;
use fipt_core::shading::{RayQuery, DEFAULT_LEVELS};
use fipt_geom::{Geometry, Mesh, TriangleSampler};
use fipt_shading::brdf::ladder::albedo_quadrature as quadrature;
use fipt_shading::brdf::MicrofacetBrdf;
use fipt_shading::render::RenderConfig;
use fipt_synth::{build, icosphere_mesh, write_dataset, SynthOptions};
use glam::Vec3;

/// Inside a closed sphere whose every SLF voxel holds L, for both reflectance models: Ld = L
/// under FIPT's model, and under `principled` Ld0 + σ·Ld1 + σ²·Ld2 is L times Burley's
/// directional albedo at every σ and view (from one set of view-independent moments); Ls0 + Ls1
/// at each level is L times the GGX directional albedo with F ≡ 1 (Ls1 alone: F = (1−ωo·h)⁵),
/// with the model's masking. All checked against brute-force quadrature of the BRDF, for both
/// specular estimators (per level: 4096 stratified samples; mixture: 700 per level shared by
/// all levels); tolerance 2 % of L (or 0.003 L absolute).
///
/// The same for `principled` registered as an external model (`PrincipledViaTrait`), whose Ld is
/// summed per view direction from the model's basis (`diffuse_direct`) instead of the moments:
/// with the same samples it agrees with the moments to 1e-5 of L.
#[test]
fn uniform_incident_light_gives_known_shadings() {
    static VIA: PrincipledViaTrait = PrincipledViaTrait;
    let via = ReflectanceModel::register(&VIA).unwrap();
    for model in ReflectanceModel::ALL.into_iter().chain([via]) {
        uniform_light_case(model);
    }
}

fn uniform_light_case(model: ReflectanceModel) {
    let brdf = |kd: Vec3, ks: Vec3, s: f32| MicrofacetBrdf::with_model(model, kd, ks, s);
    let mesh = icosphere_mesh(Vec3::ZERO, 1.0, 3);
    let all: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
    let sampler = TriangleSampler::uniform_area(&mesh, &all).unwrap();
    let l = Vec3::new(0.5, 1.0, 2.0);
    let cube = Cube::around(mesh.positions.iter().copied(), 1.1).unwrap();
    let mut b = SlfBuilder::new(cube, 32);
    let mut rng = Pcg32::new(1, 1);
    for _ in 0..400_000 {
        b.add(sampler.sample(&mesh, rng.next_f32(), rng.next_2d()).p, l);
    }
    let slf = b.finish();
    let geo = Geometry::new(mesh);
    let light = SlfLight {
        geometry: &geo,
        slf: &slf,
    };
    let hit = geo
        .intersect(Vec3::ZERO, Vec3::new(0.3, -0.9, 0.2).normalize())
        .unwrap();
    let n = -hit.ng; // facing the centre
    let frame = fipt_core::brdf::Frame::from_normal(n);
    let mut st = SampleStream::new(SamplerKind::Stratified, &[1]);
    let ld = diffuse_shading(&light, &geo, hit.p, n, n, 4096, 0, &mut st, &mut rng);
    // Exact but for cosine samples that graze the surface (z ≈ 0) and are dropped.
    assert!(
        (ld - l).abs().max_element() < 1e-3 * l.max_element(),
        "Ld = {ld}, L = {l}"
    );
    let mut st = SampleStream::new(SamplerKind::Stratified, &[1]);
    let moments = diffuse_moments(&light, &geo, hit.p, n, n, 4096, 0, &mut st, &mut rng, true);
    for theta_deg in [0.0f32, 45.0, 80.0] {
        let th = theta_deg.to_radians();
        let wo_local = Vec3::new(th.sin(), 0.0, th.cos());
        let wo = frame.to_world(wo_local);
        let (l0, [l1, l2]) = if moments_express(model) {
            moments.shading(model, wo, n)
        } else {
            direct_as_moments(&light, &geo, (hit.p, n), wo, model, &moments, l)
        };
        for sigma in [0.02f32, 0.5, 1.0] {
            let got = (l0 + l1 * sigma + l2 * sigma * sigma) / l;
            let want = quadrature(&brdf(Vec3::ONE, Vec3::ZERO, sigma), wo_local, 600, 300)
                - quadrature(&brdf(Vec3::ZERO, Vec3::ZERO, sigma), wo_local, 600, 300);
            assert!(
                (got - want).abs().max_element() < 0.01 * want.x,
                "{model} σ={sigma} θo={theta_deg}: Ld(σ) = {got} L, albedo {want}"
            );
        }
    }
    for theta_deg in [0.0f32, 45.0, 75.0, 85.0] {
        let th = theta_deg.to_radians();
        let wo_local = Vec3::new(th.sin(), 0.0, th.cos());
        let wo = frame.to_world(wo_local);
        let mut streams = std::array::from_fn(|k| {
            SampleStream::new(SamplerKind::Stratified, &[3, k as u64, theta_deg as u64])
        });
        let (m0, m1) = specular_shading_mixture(
            &light,
            &geo,
            hit.p,
            n,
            n,
            wo,
            &DEFAULT_LEVELS,
            &[700; 6],
            0,
            &mut streams,
            &mut rng,
            model,
        );
        for (k, &sigma) in DEFAULT_LEVELS.iter().enumerate() {
            let mut st =
                SampleStream::new(SamplerKind::Stratified, &[2, k as u64, theta_deg as u64]);
            let (p0, p1) = specular_shading(&light, hit.p, n, n, wo, sigma, 4096, &mut st, model);
            for (s0, s1, est) in [(p0, p1, "per-level"), (m0[k], m1[k], "mixture")] {
                // F ≡ 1: ks = 1 gives F = 1·(1−m) + m.
                let exact = sigma >= 0.2 && theta_deg <= 75.0;
                let both = specular_albedo(&brdf(Vec3::ZERO, Vec3::ONE, sigma), wo_local, exact, k);
                let tol = (0.02 * both).max(0.003);
                let got = (s0 + s1) / l;
                assert!(
                    (got - Vec3::splat(both)).abs().max_element() < tol,
                    "{model} {est} σ={sigma} θo={theta_deg}: Ls0+Ls1 = {got} L, albedo {both}"
                );
                if sigma >= 0.2 && theta_deg <= 75.0 {
                    let only1 =
                        quadrature(&brdf(Vec3::ZERO, Vec3::ZERO, sigma), wo_local, 600, 300).x;
                    let got1 = s1 / l;
                    assert!(
                        (got1 - Vec3::splat(only1)).abs().max_element() < (0.03 * only1).max(0.003),
                        "{est} σ={sigma} θo={theta_deg}: Ls1 = {got1} L vs {only1}"
                    );
                }
                assert!(s0.is_finite() && s1.is_finite());
            }
        }
    }
}

/// The directional albedo of a specular-only BRDF (ks = 1) at `wo`: by quadrature where
/// `exact`, else (narrow or grazing lobes) by the BRDF's own importance sampler, chi-square
/// tested, its stream keyed by `k`.
fn specular_albedo(b: &MicrofacetBrdf, wo_local: Vec3, exact: bool, k: usize) -> f32 {
    if exact {
        return quadrature(b, wo_local, 600, 300).x;
    }
    let mut r = Pcg32::new(9, k as u64);
    let n = 400_000;
    // u_lobe ≥ 0.5 picks the GGX lobe.
    (0..n)
        .filter_map(|_| b.sample(wo_local, 0.99, r.next_2d()))
        .map(|s| spec_only_weight(b, wo_local, s.wi))
        .sum::<f32>()
        / n as f32
}

/// Importance weight of the specular lobe alone for a sample drawn by GGX half-vector
/// sampling: f_spec·cos / pdf_spec.
fn spec_only_weight(b: &MicrofacetBrdf, wo: Vec3, wi: Vec3) -> f32 {
    let h = (wo + wi).normalize();
    let pdf_spec = fipt_shading::brdf::ggx_d(h, b.alpha()) * h.z / (4.0 * wo.dot(h));
    let f = b.eval(wo, wi).x; // kd = 0: specular only
    if pdf_spec > 0.0 {
        f / pdf_spec
    } else {
        0.0
    }
}

/// Closure (24 views of 64×48 of `cornell`): kd·Ld + ks·lerp(Ls0, σ) + lerp(Ls1, σ) + Le from the baked shadings and the
/// *ground-truth* materials reproduces the input views. Limited by the SLF's view-independent
/// radiance and Monte Carlo noise; the figure is printed and a floor asserted.
#[test]
fn closure_with_ground_truth_materials_reproduces_the_views() {
    let dir = std::env::temp_dir().join(format!("fipt-bake-closure-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let opts = SynthOptions {
        train_views: 24,
        val_views: 1,
        width: 64,
        height: 48,
        render: RenderConfig {
            spp: 256,
            ..Default::default()
        },
        model: Default::default(),
        lens: Default::default(),
    };
    write_dataset(build("cornell").unwrap(), &dir, &opts, &|_, _| {}).unwrap();
    let ds = Dataset::open(&dir).unwrap();
    let geo = Geometry::new(Mesh::load(&ds.mesh).unwrap());
    let split = ds.train();
    let images: Vec<_> = split
        .views
        .iter()
        .map(|v| ds.load_image(v, BadPixelPolicy::Reject).unwrap().0)
        .collect();
    let mut report = Vec::new();
    for (name, cfg) in [
        (
            "default (cached Ld, stratified, SLF fallback)",
            BakeConfig::default(),
        ),
        (
            "reference (per-pixel Ld, independent, strict SLF)",
            BakeConfig::reference(),
        ),
    ] {
        let (sh, stats, _) =
            FactorizedBaker::new(cfg).bake_detailed(&geo, &split.views, &images, &|_, _| {});
        let mut ps = Vec::new();
        for (v, s) in split.views.iter().zip(&sh) {
            let kd = ds
                .load_gt(split, GtKind::DiffCol, v.index)
                .unwrap()
                .unwrap();
            let ks = ds
                .load_gt(split, GtKind::Specular, v.index)
                .unwrap()
                .unwrap();
            let ro = ds
                .load_gt(split, GtKind::Roughness, v.index)
                .unwrap()
                .unwrap();
            let le = ds.load_gt(split, GtKind::Emit, v.index).unwrap().unwrap();
            let pred: Vec<Vec3> = (0..kd.data.len())
                .map(|i| le.data[i] + s.reflected(i, kd.data[i], ks.data[i], ro.data[i].x))
                .collect();
            assert!(pred.iter().all(|p| p.is_finite()));
            ps.push(srgb_psnr(&pred, &images[v.index].data, None).unwrap());
            if std::env::var("FIPT_DEBUG").is_ok() {
                let m =
                    |x: &[Vec3]| x.iter().map(|p| p.x + p.y + p.z).sum::<f32>() / x.len() as f32;
                let ld: Vec<Vec3> = (0..kd.data.len()).map(|i| kd.data[i] * s.ld[i]).collect();
                let sp: Vec<Vec3> = (0..kd.data.len())
                    .map(|i| s.reflected(i, Vec3::ZERO, ks.data[i], ro.data[i].x))
                    .collect();
                eprintln!(
                    "view {}: pred {} img {} le {} kd*ld {} spec {}",
                    v.index,
                    m(&pred),
                    m(&images[v.index].data),
                    m(&le.data),
                    m(&ld),
                    m(&sp)
                );
            }
        }
        let mean = ps.iter().sum::<f64>() / ps.len() as f64;
        report.push((
            mean,
            format!(
                "{name}: closure PSNR {mean:.2} dB (min {:.2}), cache entries {} for {} pixels",
                ps.iter().cloned().fold(f64::INFINITY, f64::min),
                stats.cache_entries,
                stats.valid_pixels
            ),
        ));
    }
    for (_, line) in &report {
        eprintln!("{line}");
    }
    // Measured: 25.5 dB (default) vs 16.3 dB (reference) with 24 views of 64×48: the strict SLF
    // loses the direct light of the small emitter, seen in few pixels.
    assert!(report[0].0 >= 24.0, "{}", report[0].1);
    assert!(
        report[0].0 >= report[1].0 + 3.0,
        "the default bake should beat the reference's: {} vs {}",
        report[0].1,
        report[1].1
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// An external model's Ld summed from its basis at `wo`, checked against the moments of
/// `principled` (the same samples: the model must be `principled` through the trait).
fn direct_as_moments(
    light: &SlfLight,
    geo: &Geometry,
    (p, n): (Vec3, Vec3),
    wo: Vec3,
    model: ReflectanceModel,
    moments: &fipt_bake::diffuse::DiffuseMoments,
    l: Vec3,
) -> (Vec3, [Vec3; 2]) {
    let mut st = SampleStream::new(SamplerKind::Stratified, &[1]);
    let mut rng = Pcg32::new(1, 1);
    let direct = diffuse_direct(light, geo, (p, n, n), wo, model, 4096, 0, &mut st, &mut rng);
    let (m0, [m1, m2]) = moments.shading(ReflectanceModel::Principled, wo, n);
    for (d, m) in [direct.0, direct.1[0], direct.1[1]]
        .into_iter()
        .zip([m0, m1, m2])
    {
        assert!(
            (d - m).abs().max_element() < 1e-5 * l.max_element(),
            "{d} vs {m}"
        );
    }
    direct
}
