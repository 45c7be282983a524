//! An edge-aware denoiser for path-traced views: the image is divided by the first-hit albedo
//! (so that a texture's edges never blur: the filter sees the light, not the paint), filtered
//! by an à-trous wavelet (5×5 B3-spline taps, holes 1, 2, 4, …) whose weights stop at
//! creases (normals), at depth steps (distance to the pixel's tangent plane, in pixel
//! footprints) and at changes of light larger than the Monte Carlo noise (the per-pixel
//! variance, filtered along), then multiplied by the albedo again.
//!
//! The guides are anti-aliased like the image: [`render_guides`] averages jittered primary
//! hits per pixel. Pixels that see an emitter, miss the scene, or whose albedo is black are
//! left as rendered and take no part in their neighbours' sums (their light cannot be divided
//! by their paint). Light flows between two pixels in proportion to a weight that is the same
//! both ways, so the view's radiance is kept exactly (a filter that averages each pixel's
//! neighbours would drop the fireflies' energy: 3.6 % of a 16-spp view of `room`); each
//! weight depends only on the two pixels, so the result does not depend on threads.
use crate::render::trace_variance;
use crate::scene::{Scene, SurfaceModel};
use fipt_core::camera::Camera;
use fipt_core::color::luminance;
use fipt_core::image::Image;
use fipt_core::rng::Pcg32;
use fipt_geom::{hit_point, shading_normal};
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The denoiser's settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DenoiseConfig {
    /// À-trous passes (the kernel spans 4·2^passes − 3 pixels: 125 at 5). 0: off.
    pub passes: u32,
    /// Exponent of the normal weight (n_p · n_q)^k.
    pub sigma_normal: f32,
    /// Distance to the pixel's tangent plane at which the weight is 1/e, in pixel footprints
    /// per pixel of separation.
    pub sigma_plane: f32,
    /// Luminance difference at which the weight is 1/e, in standard deviations of the noise.
    pub sigma_luminance: f32,
    /// Jittered primary rays per pixel for the guides (albedo, normal, position).
    pub guide_spp: u32,
    /// The largest hole (pixels) a pass may span between two pixels of roughness σ is
    /// `gloss_reach`·σ² (at least 1): a glossy surface's light changes as fast as the scene it
    /// reflects, so it is averaged over few pixels; a rough one over the whole kernel.
    pub gloss_reach: f32,
}

impl Default for DenoiseConfig {
    fn default() -> Self {
        DenoiseConfig {
            passes: 5,
            sigma_normal: 64.0,
            sigma_plane: 1.0,
            sigma_luminance: 4.0,
            guide_spp: 8,
            gloss_reach: 16.0,
        }
    }
}

/// What the denoiser is guided by, per pixel, averaged over jittered primary rays.
#[derive(Clone, Debug)]
pub struct Guides {
    pub width: usize,
    pub height: usize,
    /// First-hit albedo kd + ks.
    pub albedo: Vec<Vec3>,
    /// First-hit shading normal facing the camera (averaged, renormalised).
    pub normal: Vec<Vec3>,
    /// First-hit position (averaged).
    pub position: Vec<Vec3>,
    /// Distance to the camera of the first hit (averaged).
    pub depth: Vec<f32>,
    /// First-hit roughness σ (averaged).
    pub roughness: Vec<f32>,
    /// Whether the pixel is filtered: every ray hit a non-emitting surface of non-black albedo.
    pub filtered: Vec<bool>,
}

/// The guides of `camera`'s view of `scene`: `spp` jittered primary rays per pixel (their own
/// random stream, keyed by `seed` and `view_key`).
pub fn render_guides<S: SurfaceModel>(
    scene: &Scene<S>,
    camera: &Camera,
    spp: u32,
    seed: u64,
    view_key: u64,
) -> Guides {
    let (w, h) = (camera.width, camera.height);
    let n = spp.max(1);
    let px: Vec<(Vec3, Vec3, Vec3, f32, bool, f32)> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let mut rng = Pcg32::from_keys(&[seed, view_key, i as u64, 0xDE_0015E]);
            let (mut a, mut nrm, mut p, mut t) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0.0);
            let mut r = 0.0;
            let mut ok = true;
            for _ in 0..n {
                let j = rng.next_2d();
                let (o, d) = camera.ray((i % w) as f32 + j.x, (i / w) as f32 + j.y);
                let Some(hit) = scene.bvh.closest_hit(o, d, 0.0, f32::INFINITY) else {
                    ok = false;
                    continue;
                };
                let x = hit_point(&scene.mesh, &hit);
                let sp = scene.surfaces.surface(hit.tri, x);
                let mut s = shading_normal(&scene.mesh, &hit);
                if s.dot(d) > 0.0 {
                    s = -s;
                }
                ok &= scene.surfaces.emission(hit.tri).max_element() <= 0.0;
                a += sp.kd + sp.ks;
                r += sp.roughness;
                nrm += s;
                p += x;
                t += hit.t;
            }
            let k = n as f32;
            let a = a / k;
            ok &= luminance(a) > 1e-3;
            (a, nrm.normalize_or_zero(), p / k, t / k, ok, r / k)
        })
        .collect();
    Guides {
        width: w,
        height: h,
        albedo: px.iter().map(|x| x.0).collect(),
        normal: px.iter().map(|x| x.1).collect(),
        position: px.iter().map(|x| x.2).collect(),
        depth: px.iter().map(|x| x.3).collect(),
        filtered: px.iter().map(|x| x.4).collect(),
        roughness: px.iter().map(|x| x.5).collect(),
    }
}

/// The B3-spline taps of one à-trous pass.
const TAPS: [f32; 5] = [1.0 / 16.0, 1.0 / 4.0, 3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0];

/// The symmetric weight of pixels `p` and `q` (tap product `k`, `sep` pixels apart): their
/// normals, each one's distance to the other's tangent plane (in their mean footprint), and
/// their lights' difference against both noises (`sd`).
#[allow(clippy::too_many_arguments)]
fn weight(
    g: &Guides,
    irr: &[Vec3],
    sd: &[f32],
    footprint: &[f32],
    cfg: &DenoiseConfig,
    (p, q): (usize, usize),
    k: f32,
    sep: f32,
    step: usize,
) -> f32 {
    let r = g.roughness[p].min(g.roughness[q]);
    if step > 1 && step as f32 > cfg.gloss_reach * r * r {
        return 0.0;
    }
    let (np, nq) = (g.normal[p], g.normal[q]);
    let wn = np.dot(nq).max(0.0).powf(cfg.sigma_normal);
    let d = g.position[q] - g.position[p];
    let plane = 0.5 * (np.dot(d).abs() + nq.dot(d).abs());
    let foot = 0.5 * (footprint[p] + footprint[q]);
    let wp = (-plane / (cfg.sigma_plane * foot * sep + 1e-9)).exp();
    let noise = (sd[p] * sd[p] + sd[q] * sd[q]).sqrt();
    let dl = (luminance(irr[q]) - luminance(irr[p])).abs();
    let wl = (-dl / (cfg.sigma_luminance * noise + 1e-6)).exp();
    k * wn * wp * wl
}

/// The neighbours of pixel `i` at hole `step` inside the image: (index, tap product,
/// separation in pixels), itself excluded.
fn taps(i: usize, w: usize, h: usize, step: usize) -> impl Iterator<Item = (usize, f32, f32)> {
    let (x, y) = ((i % w) as isize, (i / w) as isize);
    (0..25).filter_map(move |t| {
        let (tx, ty) = (t % 5, t / 5);
        let (dx, dy) = (
            (tx as isize - 2) * step as isize,
            (ty as isize - 2) * step as isize,
        );
        let (qx, qy) = (x + dx, y + dy);
        let inside = qx >= 0 && qy >= 0 && qx < w as isize && qy < h as isize;
        (inside && (dx, dy) != (0, 0)).then(|| {
            let sep = ((dx * dx + dy * dy) as f32).sqrt();
            ((qy as usize) * w + qx as usize, TAPS[tx] * TAPS[ty], sep)
        })
    })
}

/// One à-trous pass at hole `step` over the demodulated light `irr` (variance `var`) of the
/// pixels with albedo `a`: light flows between each pair of filtered pixels in proportion to
/// their symmetric weight and the smaller albedo, so that Σ albedo · light (the view's
/// radiance) is kept exactly while the noise is averaged out.
fn pass(
    irr: &[Vec3],
    var: &[f32],
    g: &Guides,
    footprint: &[f32],
    cfg: &DenoiseConfig,
    step: usize,
) -> (Vec<Vec3>, Vec<f32>) {
    let (w, h) = (g.width, g.height);
    let n = irr.len();
    // The noise's standard deviation around each pixel (3×3 B3 average of the variance).
    let sd: Vec<f32> = (0..n)
        .into_par_iter()
        .map(|i| {
            let near = taps(i, w, h, 1).filter(|(q, _, sep)| *sep < 2.0 && g.filtered[*q]);
            let (mut s, mut ws) = (TAPS[2] * TAPS[2] * var[i], TAPS[2] * TAPS[2]);
            for (q, k, _) in near {
                s += k * var[q];
                ws += k;
            }
            (s / ws).max(0.0).sqrt()
        })
        .collect();
    let self_tap = TAPS[2] * TAPS[2];
    // Each pixel's total weight (itself included).
    let total: Vec<f32> = (0..n)
        .into_par_iter()
        .map(|p| {
            if !g.filtered[p] {
                return 1.0;
            }
            self_tap
                + taps(p, w, h, step)
                    .filter(|(q, _, _)| g.filtered[*q])
                    .map(|(q, k, sep)| weight(g, irr, &sd, footprint, cfg, (p, q), k, sep, step))
                    .sum::<f32>()
        })
        .collect();
    let floor = Vec3::splat(ALBEDO_FLOOR);
    (0..n)
        .into_par_iter()
        .map(|p| {
            if !g.filtered[p] {
                return (irr[p], var[p]);
            }
            let ap = g.albedo[p].max(floor);
            let (mut flow, mut keep, mut v) = (Vec3::ZERO, Vec3::ONE, 0.0f32);
            for (q, k, sep) in taps(p, w, h, step).filter(|(q, _, _)| g.filtered[*q]) {
                let wpq = weight(g, irr, &sd, footprint, cfg, (p, q), k, sep, step);
                let c = wpq / total[p].max(total[q]) * g.albedo[q].max(floor).min(ap) / ap;
                flow += c * irr[q];
                keep -= c;
                let cl = luminance(c);
                v += cl * cl * var[q];
            }
            let kl = luminance(keep);
            (keep * irr[p] + flow, kl * kl * var[p] + v)
        })
        .unzip()
}

/// Albedo below which a channel is not divided out.
const ALBEDO_FLOOR: f32 = 1e-4;

/// `color` (a path-traced view, the variance of each pixel's mean luminance in `variance`)
/// denoised with `guides`; `camera` gives the pixel footprint.
pub fn denoise(
    color: &Image,
    variance: &[f32],
    guides: &Guides,
    camera: &Camera,
    cfg: &DenoiseConfig,
) -> Image {
    let n = color.data.len();
    assert_eq!(n, guides.albedo.len(), "denoise: guides of another size");
    assert_eq!(n, variance.len(), "denoise: variance of another size");
    if cfg.passes == 0 {
        return color.clone();
    }
    let focal = camera.fx.max(camera.fy).max(1e-6);
    let footprint: Vec<f32> = guides.depth.iter().map(|t| t / focal).collect();
    let floor = Vec3::splat(ALBEDO_FLOOR);
    let mut irr: Vec<Vec3> = (0..n)
        .map(|i| color.data[i] / guides.albedo[i].max(floor))
        .collect();
    let mut var: Vec<f32> = (0..n)
        .map(|i| variance[i] / luminance(guides.albedo[i]).max(1e-4).powi(2))
        .collect();
    for k in 0..cfg.passes {
        let (a, b) = pass(&irr, &var, guides, &footprint, cfg, 1 << k);
        irr = a;
        var = b;
    }
    let data = (0..n)
        .map(|i| {
            if guides.filtered[i] {
                irr[i] * guides.albedo[i].max(floor)
            } else {
                color.data[i]
            }
        })
        .collect();
    Image {
        width: color.width,
        height: color.height,
        data,
    }
}

/// A view path-traced and denoised: (denoised, raw, stats).
pub fn render_denoised<S: SurfaceModel>(
    scene: &Scene<S>,
    camera: &Camera,
    rc: &crate::render::RenderConfig,
    view_key: u64,
    cfg: &DenoiseConfig,
    progress: &(dyn Fn(usize) + Sync),
) -> (Image, Image, crate::render::RenderStats) {
    let (raw, variance, stats) = trace_variance(scene, camera, rc, view_key, progress);
    if cfg.passes == 0 {
        return (raw.clone(), raw, stats);
    }
    let guides = render_guides(scene, camera, cfg.guide_spp, rc.seed, view_key);
    (denoise(&raw, &variance, &guides, camera, cfg), raw, stats)
}
