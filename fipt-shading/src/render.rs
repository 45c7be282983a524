//! The forward path tracer: next-event estimation with MIS (power heuristic), Russian
//! roulette, reproducible per-pixel random streams, rayon over tiles, and ground-truth AOVs.
use crate::incident::power_heuristic;
use crate::scene::{Scene, SurfaceModel};
use fipt_core::brdf::{Brdf, Frame};
use fipt_core::camera::Camera;
use fipt_core::color::{is_finite, Rgb};
use fipt_core::image::Image;
use fipt_core::rng::Pcg32;
use fipt_geom::{hit_point, shading_normal};
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Path-tracer settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderConfig {
    /// Samples per pixel (box filter over the pixel square). Default 64.
    pub spp: u32,
    /// Maximum number of reflections along a path (1 = direct light only). Default 7.
    pub max_bounces: u32,
    /// Reflections before Russian roulette starts. Default 1: from the first reflection on,
    /// ×1.16–1.18 the efficiency (1 / (variance × time)) of 3 on `studio-mitsuba`'s recovered
    /// scene, ×1.03–1.06 on `room`'s (`docs/denoise.md`, *Sample efficiency*); ground-truth
    /// renders keep 3 ([`RenderConfig::ground_truth`]).
    pub rr_start: u32,
    /// Seed of all random streams. Default 0.
    pub seed: u64,
    /// Tile edge in pixels for parallel work. Default 16.
    pub tile: usize,
}

impl Default for RenderConfig {
    fn default() -> Self {
        RenderConfig {
            spp: 64,
            max_bounces: 7,
            rr_start: 1,
            seed: 0,
            tile: 16,
        }
    }
}

impl RenderConfig {
    /// Few samples, for previews and tests.
    pub fn preview() -> Self {
        RenderConfig {
            spp: 8,
            ..Default::default()
        }
    }
    /// High quality ground truth.
    pub fn reference() -> Self {
        RenderConfig {
            spp: 512,
            max_bounces: 10,
            ..Self::ground_truth(512)
        }
    }
    /// The renders of a generated scene's views: `spp` samples, roulette after the third
    /// reflection (less variance per sample than the default, more time).
    pub fn ground_truth(spp: u32) -> Self {
        RenderConfig {
            spp,
            rr_start: 3,
            ..Default::default()
        }
    }
}

/// Statistics of a render.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct RenderStats {
    /// Camera paths traced.
    pub paths: u64,
    /// Rays cast (closest-hit and shadow).
    pub rays: u64,
    /// Samples dropped because they were not finite (should be 0).
    pub nonfinite: u64,
    /// Wall time of the path tracing (not of denoising or writing), seconds.
    pub seconds: f64,
}

/// Radiance along one camera ray; returns (radiance, rays cast).
pub fn trace_path<S: SurfaceModel>(
    scene: &Scene<S>,
    cfg: &RenderConfig,
    mut origin: Vec3,
    mut dir: Vec3,
    rng: &mut Pcg32,
) -> (Rgb, u32) {
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let mut rays = 0u32;
    let mut prev_pdf = 0.0f32; // BRDF pdf of the last sampled direction (0 = camera ray)
    let mut bounce = 0u32;
    loop {
        rays += 1;
        let Some(hit) = scene.bvh.closest_hit(origin, dir, 0.0, f32::INFINITY) else {
            break;
        };
        let tri = hit.tri;
        let le = scene.surfaces.emission(tri);
        let wo_w = -dir;
        let cos_ng = hit.ng.dot(wo_w);
        if le != Vec3::ZERO && scene.surfaces.emit_side(tri).emits_towards(hit.ng, wo_w) {
            if prev_pdf == 0.0 {
                l += beta * le;
            } else if cos_ng.abs() > 0.0 {
                let light_pdf = scene.light_pdf_area[tri as usize] * hit.t * hit.t / cos_ng.abs();
                l += beta * le * power_heuristic(prev_pdf, light_pdf);
            }
        }
        if bounce >= cfg.max_bounces {
            break;
        }
        let p = hit_point(&scene.mesh, &hit);
        // The material lookup is a random memory access: start it, make the frame meanwhile.
        // (Both break tests below end the path before any random number is drawn, so their
        // order changes no output.)
        scene.surfaces.prefetch(tri, p);
        // Two-sided: orient both normals towards the viewer.
        let ng = if cos_ng < 0.0 { -hit.ng } else { hit.ng };
        let mut ns = shading_normal(&scene.mesh, &hit);
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        let frame = Frame::from_normal(ns);
        let wo = frame.to_local(wo_w);
        if wo.z <= 0.0 {
            break;
        }
        let p_out = scene.bvh.offset(p, ng);
        let sp = scene.surfaces.surface(tri, p);
        let brdf = scene.surfaces.brdf(&sp);
        if brdf.is_black() {
            break;
        }
        // Next-event estimation: the emitting triangles (MIS with the BRDF), the point lights.
        let at = ShadingPoint {
            brdf: &brdf,
            frame: &frame,
            p_out,
            ng,
            wo,
        };
        rays += next_event(scene, &at, beta, rng, &mut l);
        // Continue the path by sampling the BRDF.
        let Some(s) = brdf.sample(wo, rng.next_f32(), rng.next_2d()) else {
            break;
        };
        let wi_w = frame.to_world(s.wi);
        if wi_w.dot(ng) <= 0.0 {
            break;
        }
        beta *= s.weight;
        prev_pdf = s.pdf;
        bounce += 1;
        if bounce > cfg.rr_start {
            let q = beta.max_element().min(0.95);
            if rng.next_f32() >= q {
                break;
            }
            beta /= q;
        }
        origin = scene.bvh.offset(p, ng);
        dir = wi_w;
    }
    (l, rays)
}

/// A path vertex as next-event estimation sees it.
struct ShadingPoint<'a> {
    brdf: &'a crate::brdf::BrdfModel,
    frame: &'a Frame,
    /// The point, offset off the surface.
    p_out: Vec3,
    /// The geometric normal towards the viewer.
    ng: Vec3,
    /// The direction to the viewer, local frame.
    wo: Vec3,
}

/// Adds to `l` the light arriving at `at` straight from the lights, times `beta`: one sample
/// of the emitting triangles weighted by the power heuristic against the BRDF, and every point
/// light; returns the shadow rays traced.
#[inline]
fn next_event<S: SurfaceModel>(
    scene: &Scene<S>,
    at: &ShadingPoint,
    beta: Rgb,
    rng: &mut Pcg32,
    l: &mut Rgb,
) -> u32 {
    let ShadingPoint {
        brdf,
        frame,
        p_out,
        ng,
        wo,
    } = *at;
    let mut rays = 0u32;
    if let Some(lights) = &scene.lights {
        let ls = lights.sample(&scene.mesh, rng.next_f32(), rng.next_2d());
        let d = ls.p - p_out;
        let dist2 = d.length_squared();
        let dist = dist2.sqrt();
        if dist > 0.0 {
            let wi_w = d / dist;
            let cos_l = ls.n.dot(wi_w).abs();
            let wi = frame.to_local(wi_w);
            let faces = scene.surfaces.emit_side(ls.tri).emits_towards(ls.n, -wi_w);
            if cos_l > 0.0 && faces && wi.z > 0.0 && wi_w.dot(ng) > 0.0 {
                let (f, brdf_pdf) = brdf.eval_pdf(wo, wi);
                if f != Vec3::ZERO {
                    rays += 1;
                    if !scene.bvh.occluded(p_out, wi_w, dist * (1.0 - 1e-4)) {
                        let light_pdf = ls.pdf_area * dist2 / cos_l;
                        let w = power_heuristic(light_pdf, brdf_pdf);
                        *l += beta * f * scene.surfaces.emission(ls.tri) * (w / light_pdf);
                    }
                }
            }
        }
    }
    for dl in &scene.delta_lights {
        let d = dl.position - p_out;
        let dist2 = d.length_squared();
        if dist2 <= 0.0 {
            continue;
        }
        let dist = dist2.sqrt();
        let wi_w = d / dist;
        let wi = frame.to_local(wi_w);
        let i = dl.intensity_towards(-wi_w);
        if wi.z > 0.0 && wi_w.dot(ng) > 0.0 && i != Vec3::ZERO {
            let f = brdf.eval(wo, wi);
            if f != Vec3::ZERO {
                rays += 1;
                if !scene.bvh.occluded(p_out, wi_w, dist * (1.0 - 1e-4)) {
                    *l += beta * f * i / dist2;
                }
            }
        }
    }
    rays
}

/// Tiles of an image, row-major.
fn tiles(w: usize, h: usize, t: usize) -> Vec<(usize, usize, usize, usize)> {
    let t = t.max(1);
    let mut out = Vec::new();
    for y in (0..h).step_by(t) {
        for x in (0..w).step_by(t) {
            out.push((x, y, (x + t).min(w), (y + t).min(h)));
        }
    }
    out
}

/// Renders one view. `view_key` separates the random streams of different views;
/// `progress(done_pixels)` is called as tiles finish.
pub fn render<S: SurfaceModel>(
    scene: &Scene<S>,
    camera: &Camera,
    cfg: &RenderConfig,
    view_key: u64,
    progress: &(dyn Fn(usize) + Sync),
) -> (Image, RenderStats) {
    let (img, _, stats) = trace_variance(scene, camera, cfg, view_key, progress);
    (img, stats)
}

/// [`render`] with the variance of each pixel's mean luminance (the samples' variance over
/// their number; what the denoiser's luminance weights are scaled by).
pub fn trace_variance<S: SurfaceModel>(
    scene: &Scene<S>,
    camera: &Camera,
    cfg: &RenderConfig,
    view_key: u64,
    progress: &(dyn Fn(usize) + Sync),
) -> (Image, Vec<f32>, RenderStats) {
    let t = std::time::Instant::now();
    let (w, h) = (camera.width, camera.height);
    let rays = AtomicUsize::new(0);
    let nonfinite = AtomicUsize::new(0);
    let tile_list = tiles(w, h, cfg.tile);
    let results: Vec<Vec<(Rgb, f32)>> = tile_list
        .par_iter()
        .map(|&(x0, y0, x1, y1)| {
            let mut out = Vec::with_capacity((x1 - x0) * (y1 - y0));
            let mut nrays = 0usize;
            let mut bad = 0usize;
            for y in y0..y1 {
                for x in x0..x1 {
                    let mut rng = Pcg32::from_keys(&[cfg.seed, view_key, (y * w + x) as u64]);
                    let mut sum = Vec3::ZERO;
                    let mut sq = 0.0f64;
                    for _ in 0..cfg.spp {
                        let jitter = rng.next_2d();
                        let (o, d) = camera.ray(x as f32 + jitter.x, y as f32 + jitter.y);
                        let (li, r) = trace_path(scene, cfg, o, d, &mut rng);
                        nrays += r as usize;
                        if is_finite(li) {
                            sum += li;
                            sq += (fipt_core::color::luminance(li) as f64).powi(2);
                        } else {
                            bad += 1;
                        }
                    }
                    let n = cfg.spp.max(1) as f32;
                    let mean = sum / n;
                    let l = fipt_core::color::luminance(mean) as f64;
                    let var = ((sq / n as f64 - l * l).max(0.0) / n as f64) as f32;
                    out.push((mean, var));
                }
            }
            rays.fetch_add(nrays, Ordering::Relaxed);
            nonfinite.fetch_add(bad, Ordering::Relaxed);
            progress((x1 - x0) * (y1 - y0));
            out
        })
        .collect();
    let mut img = Image::new(w, h);
    let mut variance = vec![0f32; w * h];
    for (&(x0, y0, x1, y1), px) in tile_list.iter().zip(results) {
        let mut it = px.into_iter();
        for y in y0..y1 {
            for x in x0..x1 {
                let (c, v) = it.next().unwrap_or_default();
                img.set(x, y, c);
                variance[y * w + x] = v;
            }
        }
    }
    let stats = RenderStats {
        paths: (w * h) as u64 * cfg.spp as u64,
        rays: rays.into_inner() as u64,
        nonfinite: nonfinite.into_inner() as u64,
        seconds: t.elapsed().as_secs_f64(),
    };
    (img, variance, stats)
}

/// Per-pixel ground truth at the pixel-centre ray (not anti-aliased). On emitter pixels
/// kd = ks = metallic = 0, roughness = 1 and emission = Le; misses are 0 (`tri` = u32::MAX).
#[derive(Clone, Debug)]
pub struct Aovs {
    pub kd: Image,
    pub ks: Image,
    pub roughness: Image,
    pub metallic: Image,
    pub emission: Image,
    /// Shading normal, facing the camera.
    pub normal: Image,
    pub position: Image,
    /// Distance along the ray (R = G = B).
    pub depth: Image,
    /// Mesh file face id (u32::MAX on a miss).
    pub face: Vec<u32>,
    /// Part (material) index (u32::MAX on a miss).
    pub part: Vec<u32>,
}

impl Aovs {
    /// a′ = kd + ks.
    pub fn albedo(&self) -> Image {
        let mut a = self.kd.clone();
        for (p, s) in a.data.iter_mut().zip(&self.ks.data) {
            *p += *s;
        }
        a
    }
    /// An id map as an image (R = G = B = id; misses get `miss`).
    pub fn id_image(ids: &[u32], w: usize, h: usize, miss: f32) -> Image {
        Image {
            width: w,
            height: h,
            data: ids
                .iter()
                .map(|&i| Vec3::splat(if i == u32::MAX { miss } else { i as f32 }))
                .collect(),
        }
    }
}

/// Computes the AOVs of a view.
pub fn render_aovs<S: SurfaceModel>(scene: &Scene<S>, camera: &Camera) -> Aovs {
    let (w, h) = (camera.width, camera.height);
    let px: Vec<_> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (o, d) = camera.pixel_center_ray(i % w, i / w);
            scene.bvh.closest_hit(o, d, 0.0, f32::INFINITY).map(|hit| {
                let p = hit_point(&scene.mesh, &hit);
                let sp = scene.surfaces.surface(hit.tri, p);
                let mut n = shading_normal(&scene.mesh, &hit);
                if n.dot(d) > 0.0 {
                    n = -n;
                }
                (hit, p, sp, n)
            })
        })
        .collect();
    let img = |f: &dyn Fn(
        &(
            fipt_geom::Hit,
            Vec3,
            fipt_core::materials::SurfacePoint,
            Vec3,
        ),
    ) -> Vec3| Image {
        width: w,
        height: h,
        data: px
            .iter()
            .map(|x| x.as_ref().map(f).unwrap_or(Vec3::ZERO))
            .collect(),
    };
    Aovs {
        kd: img(&|x| x.2.kd),
        ks: img(&|x| x.2.ks),
        roughness: img(&|x| Vec3::splat(x.2.roughness)),
        metallic: img(&|x| Vec3::splat(x.2.metallic)),
        emission: img(&|x| scene.surfaces.emission(x.0.tri)),
        normal: img(&|x| x.3),
        position: img(&|x| x.1),
        depth: img(&|x| Vec3::splat(x.0.t)),
        face: px
            .iter()
            .map(|x| {
                x.as_ref()
                    .map(|x| scene.mesh.face_ids[x.0.tri as usize])
                    .unwrap_or(u32::MAX)
            })
            .collect(),
        part: px
            .iter()
            .map(|x| {
                x.as_ref()
                    .map(|x| scene.surfaces.part(x.0.tri))
                    .unwrap_or(u32::MAX)
            })
            .collect(),
    }
}
