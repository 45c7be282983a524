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
//! by their paint). The filter is normalised, so it moves no energy from one surface to another;
//! each weight depends only on the two pixels, so the result does not depend on threads.
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
}

impl Default for DenoiseConfig {
    fn default() -> Self {
        DenoiseConfig {
            passes: 5,
            sigma_normal: 64.0,
            sigma_plane: 1.0,
            sigma_luminance: 4.0,
            guide_spp: 8,
        }
    }
}

impl DenoiseConfig {
    /// Range checks, naming the key.
    pub fn validate(&self) -> Result<(), String> {
        use fipt_core::range::check;
        check("denoise.passes", self.passes, 0, 10)?;
        check("denoise.sigma_normal", self.sigma_normal, 0.0, 1e4)?;
        check("denoise.sigma_plane", self.sigma_plane, 1e-3, 1e4)?;
        check("denoise.sigma_luminance", self.sigma_luminance, 1e-3, 1e4)?;
        check("denoise.guide_spp", self.guide_spp, 1, 1024)
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
    let px: Vec<(Vec3, Vec3, Vec3, f32, bool)> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let mut rng = Pcg32::from_keys(&[seed, view_key, i as u64, 0xDE_0015E]);
            let (mut a, mut nrm, mut p, mut t) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0.0);
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
                nrm += s;
                p += x;
                t += hit.t;
            }
            let k = n as f32;
            let a = a / k;
            ok &= luminance(a) > 1e-3;
            (a, nrm.normalize_or_zero(), p / k, t / k, ok)
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
    }
}

/// The B3-spline taps of one à-trous pass.
const TAPS: [f32; 5] = [1.0 / 16.0, 1.0 / 4.0, 3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0];

/// One à-trous pass over the demodulated light `irr` with its variance `var` at hole `step`:
/// the filtered light and variance.
fn pass(
    irr: &[Vec3],
    var: &[f32],
    g: &Guides,
    footprint: &[f32],
    cfg: &DenoiseConfig,
    step: usize,
) -> (Vec<Vec3>, Vec<f32>) {
    let (w, h) = (g.width as isize, g.height as isize);
    // The noise's standard deviation around each pixel (3×3 Gaussian of the variance).
    let sd: Vec<f32> = (0..irr.len())
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i as isize) % w, (i as isize) / w);
            let (mut s, mut ws) = (0.0, 0.0);
            for dy in -1..=1isize {
                for dx in -1..=1isize {
                    let (qx, qy) = (x + dx, y + dy);
                    if qx < 0 || qy < 0 || qx >= w || qy >= h {
                        continue;
                    }
                    let q = (qy * w + qx) as usize;
                    if g.filtered[q] {
                        let k = TAPS[(dx + 2) as usize] * TAPS[(dy + 2) as usize];
                        s += k * var[q];
                        ws += k;
                    }
                }
            }
            (s / ws.max(1e-12)).max(0.0).sqrt()
        })
        .collect();
    (0..irr.len())
        .into_par_iter()
        .map(|i| {
            if !g.filtered[i] {
                return (irr[i], var[i]);
            }
            let (x, y) = ((i as isize) % w, (i as isize) / w);
            let (np, pp, lp) = (g.normal[i], g.position[i], luminance(irr[i]));
            let lum_scale = cfg.sigma_luminance * sd[i] + 1e-6;
            let (mut sum, mut vsum, mut wsum) = (Vec3::ZERO, 0.0f32, 0.0f32);
            for (ty, ky) in TAPS.iter().enumerate() {
                for (tx, kx) in TAPS.iter().enumerate() {
                    let (dx, dy) = ((tx as isize - 2) * step as isize, (ty as isize - 2) * step as isize);
                    let (qx, qy) = (x + dx, y + dy);
                    if qx < 0 || qy < 0 || qx >= w || qy >= h {
                        continue;
                    }
                    let q = (qy * w + qx) as usize;
                    if !g.filtered[q] {
                        continue;
                    }
                    let wn = np.dot(g.normal[q]).max(0.0).powf(cfg.sigma_normal);
                    let sep = ((dx * dx + dy * dy) as f32).sqrt().max(1.0);
                    let plane = np.dot(g.position[q] - pp).abs();
                    let wp = (-plane / (cfg.sigma_plane * footprint[i] * sep + 1e-9)).exp();
                    let wl = (-(luminance(irr[q]) - lp).abs() / lum_scale).exp();
                    let k = kx * ky * wn * wp * wl;
                    sum += k * irr[q];
                    vsum += k * k * var[q];
                    wsum += k;
                }
            }
            // The pixel itself always weighs kx·ky > 0.
            (sum / wsum, vsum / (wsum * wsum))
        })
        .unzip()
}

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
    let demod = |c: Vec3, a: Vec3| Vec3::select(a.cmpgt(Vec3::splat(1e-4)), c / a, c);
    let mut irr: Vec<Vec3> = (0..n)
        .map(|i| demod(color.data[i], guides.albedo[i]))
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
                irr[i] * Vec3::select(guides.albedo[i].cmpgt(Vec3::splat(1e-4)), guides.albedo[i], Vec3::ONE)
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
