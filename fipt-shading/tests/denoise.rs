//! The denoiser against a converged render of a generated room (checkered floor, a bright
//! lamp, glossy and metal objects): the denoised 16-spp view gains a stated PSNR over the raw
//! one, keeps the view's mean radiance, and keeps the floor's checker edges, which a plain blur
//! of the same reach does not.
use fipt_core::camera::Camera;
use fipt_core::image::Image;
use fipt_core::metrics::srgb_psnr;
use fipt_shading::denoise::{denoise, render_guides, DenoiseConfig};
use fipt_shading::render::{render_aovs, trace_variance, RenderConfig};
use fipt_shading::scene::{Scene, TableSurfaces};
use glam::Vec3;

fn room(n: usize) -> (Scene<TableSurfaces>, Vec<Camera>) {
    let s = fipt_synth::build("room").unwrap();
    let bvh = fipt_geom::Bvh::build(&s.mesh, fipt_geom::BuildQuality::Medium);
    let cams = s.cameras(n, 3, 64, 48, &bvh);
    let surfaces = TableSurfaces::new(s.materials, &s.mesh, std::path::Path::new("room")).unwrap();
    (Scene::with_bvh(s.mesh, bvh, surfaces), cams)
}

fn rc(spp: u32, seed: u64) -> RenderConfig {
    RenderConfig {
        spp,
        seed,
        ..Default::default()
    }
}

fn mean(img: &Image) -> f64 {
    img.data.iter().map(|p| p.element_sum() as f64).sum::<f64>() / img.data.len() as f64
}

/// A normalised 5-pass à-trous blur with no edge stops (the filter's reach, nothing else).
fn blur(img: &Image) -> Image {
    let cfg = DenoiseConfig {
        sigma_normal: 0.0,
        sigma_plane: 1e4,
        sigma_luminance: 1e4,
        ..Default::default()
    };
    let n = img.data.len();
    let flat = fipt_shading::denoise::Guides {
        width: img.width,
        height: img.height,
        albedo: vec![Vec3::ONE; n],
        normal: vec![Vec3::Z; n],
        position: vec![Vec3::ZERO; n],
        depth: vec![1.0; n],
        filtered: vec![true; n],
        roughness: vec![1.0; n],
    };
    let cam = Camera::look_at(Vec3::Z, Vec3::ZERO, Vec3::Y, 1.0, img.width, img.height);
    denoise(img, &vec![1.0; n], &flat, &cam, &cfg)
}

/// Mean |ΔL| across the pixel pairs where the true kd changes by more than 0.1 on one surface
/// (the checker's edges), of `img`.
fn edge_contrast(img: &Image, kd: &Image, normal: &Image, depth: &Image) -> f64 {
    let (w, h) = (img.width, img.height);
    let (mut sum, mut n) = (0.0, 0);
    for y in 0..h {
        for x in 0..w - 1 {
            let (p, q) = (y * w + x, y * w + x + 1);
            let same_surface = normal.data[p].dot(normal.data[q]) > 0.99
                && (depth.data[p].x - depth.data[q].x).abs() < 0.05 * depth.data[p].x;
            if same_surface && (kd.data[p] - kd.data[q]).abs().max_element() > 0.1 {
                let l = |i: usize| fipt_core::color::luminance(img.data[i]) as f64;
                sum += (l(p) - l(q)).abs();
                n += 1;
            }
        }
    }
    assert!(n > 20, "only {n} checker edge pairs in view");
    sum / n as f64
}

#[test]
fn denoised_16_spp_gains_psnr_keeps_energy_and_keeps_checker_edges() {
    let (scene, cams) = room(4);
    let cfg = DenoiseConfig::default();
    let (mut gain_sum, mut views) = (0.0, 0);
    for (k, cam) in cams.iter().enumerate() {
        let (reference, _, _) = trace_variance(&scene, cam, &rc(2048, 99), k as u64, &|_| {});
        let (raw, var, _) = trace_variance(&scene, cam, &rc(16, 1), k as u64, &|_| {});
        let guides = render_guides(&scene, cam, cfg.guide_spp, 1, k as u64);
        let den = denoise(&raw, &var, &guides, cam, &cfg);
        let p_raw = srgb_psnr(&raw.data, &reference.data, None).unwrap();
        let p_den = srgb_psnr(&den.data, &reference.data, None).unwrap();
        let (m_raw, m_den) = (mean(&raw), mean(&den));
        println!(
            "view {k}: raw {p_raw:.2} dB, denoised {p_den:.2} dB, mean {m_raw:.4} → {m_den:.4}"
        );
        assert!(
            (m_den - m_raw).abs() <= 0.01 * m_raw,
            "view {k}: mean radiance {m_raw} → {m_den} (more than 1 %)"
        );
        gain_sum += p_den - p_raw;
        views += 1;
        // The checker's edges, where the view shows them.
        let aovs = render_aovs(&scene, cam);
        let has_edges = (0..raw.data.len() - 1)
            .filter(|&i| (aovs.kd.data[i] - aovs.kd.data[i + 1]).abs().max_element() > 0.1)
            .count()
            > 40;
        if has_edges {
            let e = |img: &Image| edge_contrast(img, &aovs.kd, &aovs.normal, &aovs.depth);
            let (truth, kept, blurred) = (e(&reference), e(&den), e(&blur(&raw)));
            println!("view {k}: edge contrast truth {truth:.4}, denoised {kept:.4}, blurred {blurred:.4}");
            assert!(kept >= 0.8 * truth, "view {k}: edges {kept} of {truth}");
            assert!(
                blurred < 0.8 * truth,
                "view {k}: a blur keeps the edges too ({blurred} of {truth}): the test cannot fail"
            );
        }
    }
    let gain = gain_sum / views as f64;
    assert!(
        gain >= 7.0,
        "the denoised 16-spp views gain {gain:.2} dB (want ≥ 7; 9.6 measured)"
    );
}
