//! The forward path tracer: next-event estimation with MIS (power heuristic), Russian
//! roulette, reproducible per-pixel random streams, rayon over tiles with several pixels'
//! paths in flight on each thread (their material fetches overlap), and ground-truth AOVs.
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
    origin: Vec3,
    dir: Vec3,
    rng: &mut Pcg32,
) -> (Rgb, u32) {
    let mut path = Path::new(origin, dir);
    while let Some(v) = arrive(scene, cfg, &mut path) {
        v.prefetch(scene);
        if !scatter(scene, cfg, &mut path, &v, rng) {
            break;
        }
    }
    (path.l, path.rays)
}

/// A camera path between two vertices: what [`arrive`] and [`scatter`] carry on.
struct Path {
    /// The next ray.
    origin: Vec3,
    dir: Vec3,
    /// Radiance gathered so far.
    l: Rgb,
    /// Throughput.
    beta: Rgb,
    /// BRDF pdf of the last sampled direction (0 = camera ray).
    prev_pdf: f32,
    bounce: u32,
    /// Rays cast so far.
    rays: u32,
}

impl Path {
    fn new(origin: Vec3, dir: Vec3) -> Self {
        Path {
            origin,
            dir,
            l: Vec3::ZERO,
            beta: Vec3::ONE,
            prev_pdf: 0.0,
            bounce: 0,
            rays: 0,
        }
    }
}

/// A surface a path reached and will scatter from.
#[derive(Clone, Copy)]
struct Vertex {
    hit: fipt_geom::Hit,
    p: Vec3,
    /// The geometric normal's cosine with the direction back along the ray.
    cos_ng: f32,
}

impl Vertex {
    /// Starts fetching the vertex's material: the lookup is a random memory access, which
    /// the frame (and in [`trace_tile`] the other paths' fetches) then hide.
    #[inline]
    fn prefetch<S: SurfaceModel>(&self, scene: &Scene<S>) {
        scene.surfaces.prefetch(self.hit.tri, self.p);
    }
}

/// Casts the path's next ray and adds the light it sees emitted there (MIS against the light
/// sample of the vertex before); the vertex to scatter from, or None where the path ends.
/// Draws no random number.
#[inline]
fn arrive<S: SurfaceModel>(
    scene: &Scene<S>,
    cfg: &RenderConfig,
    path: &mut Path,
) -> Option<Vertex> {
    path.rays += 1;
    let hit = scene
        .bvh
        .closest_hit(path.origin, path.dir, 0.0, f32::INFINITY)?;
    let tri = hit.tri;
    let le = scene.surfaces.emission(tri);
    let wo_w = -path.dir;
    let cos_ng = hit.ng.dot(wo_w);
    if le != Vec3::ZERO && scene.surfaces.emit_side(tri).emits_towards(hit.ng, wo_w) {
        if path.prev_pdf == 0.0 {
            path.l += path.beta * le;
        } else if cos_ng.abs() > 0.0 {
            let light_pdf = scene.light_pdf_area[tri as usize] * hit.t * hit.t / cos_ng.abs();
            path.l += path.beta * le * power_heuristic(path.prev_pdf, light_pdf);
        }
    }
    if path.bounce >= cfg.max_bounces {
        return None;
    }
    let p = hit_point(&scene.mesh, &hit);
    Some(Vertex { hit, p, cos_ng })
}

/// Scatters the path at `v`: next-event estimation, then a direction sampled from the BRDF
/// and Russian roulette; false where the path ends.
#[inline]
fn scatter<S: SurfaceModel>(
    scene: &Scene<S>,
    cfg: &RenderConfig,
    path: &mut Path,
    v: &Vertex,
    rng: &mut Pcg32,
) -> bool {
    let (hit, p) = (&v.hit, v.p);
    // Two-sided: orient both normals towards the viewer.
    let ng = if v.cos_ng < 0.0 { -hit.ng } else { hit.ng };
    let mut ns = shading_normal(&scene.mesh, hit);
    if ns.dot(ng) < 0.0 {
        ns = -ns;
    }
    let frame = Frame::from_normal(ns);
    let wo = frame.to_local(-path.dir);
    if wo.z <= 0.0 {
        return false;
    }
    let p_out = scene.bvh.offset(p, ng);
    let sp = scene.surfaces.surface(hit.tri, p);
    let brdf = scene.surfaces.brdf(&sp);
    if brdf.is_black() {
        return false;
    }
    // Next-event estimation: the emitting triangles (MIS with the BRDF), the point lights.
    let at = ShadingPoint {
        brdf: &brdf,
        frame: &frame,
        p_out,
        ng,
        wo,
    };
    path.rays += next_event(scene, &at, path.beta, rng, &mut path.l);
    // Continue the path by sampling the BRDF.
    let Some(s) = brdf.sample(wo, rng.next_f32(), rng.next_2d()) else {
        return false;
    };
    let wi_w = frame.to_world(s.wi);
    if wi_w.dot(ng) <= 0.0 {
        return false;
    }
    path.beta *= s.weight;
    path.prev_pdf = s.pdf;
    path.bounce += 1;
    if path.bounce > cfg.rr_start {
        let q = path.beta.max_element().min(0.95);
        if rng.next_f32() >= q {
            return false;
        }
        path.beta /= q;
    }
    path.origin = p_out;
    path.dir = wi_w;
    true
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
        .map(|&rect| {
            let (out, nrays, bad) = trace_tile(scene, camera, cfg, view_key, rect);
            rays.fetch_add(nrays, Ordering::Relaxed);
            nonfinite.fetch_add(bad, Ordering::Relaxed);
            progress(out.len());
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

/// Paths in flight on a thread. Each lane is a pixel whose samples run one after another,
/// so its random stream is drawn in the order of one path at a time and the image does not
/// depend on the lanes. The lanes take turns: all of them cast their next ray, all their
/// material fetches are requested together, then each scatters, so that a lane's fetch is
/// hidden behind the other fetches and the shading of the lanes before it.
const LANES: usize = 16;

/// A pixel being traced, one sample's path at a time.
struct Lane {
    /// The pixel's index in its tile, and its coordinates.
    at: usize,
    x: usize,
    y: usize,
    rng: Pcg32,
    /// Samples finished (finite or not), and the sum of the finite ones and of their
    /// luminances' squares.
    done: u32,
    sum: Rgb,
    sq: f64,
    path: Path,
    vertex: Option<Vertex>,
}

impl Lane {
    fn new(
        at: usize,
        x: usize,
        y: usize,
        camera: &Camera,
        cfg: &RenderConfig,
        view_key: u64,
    ) -> Self {
        let w = camera.width;
        let rng = Pcg32::from_keys(&[cfg.seed, view_key, (y * w + x) as u64]);
        let mut lane = Lane {
            at,
            x,
            y,
            rng,
            done: 0,
            sum: Vec3::ZERO,
            sq: 0.0,
            path: Path::new(Vec3::ZERO, Vec3::Z),
            vertex: None,
        };
        lane.begin(camera);
        lane
    }

    /// Starts the next sample's camera path (a jittered point of the pixel square).
    fn begin(&mut self, camera: &Camera) {
        let jitter = self.rng.next_2d();
        let (o, d) = camera.ray(self.x as f32 + jitter.x, self.y as f32 + jitter.y);
        self.path = Path::new(o, d);
    }

    /// Ends the current path: its rays are added to `rays`, its radiance to the pixel's (a
    /// radiance that is not finite is dropped and counted in `bad`), and the next sample's
    /// path begins; false when the pixel has all its `spp` samples.
    fn end_path(&mut self, camera: &Camera, spp: u32, rays: &mut usize, bad: &mut usize) -> bool {
        *rays += self.path.rays as usize;
        let li = self.path.l;
        if is_finite(li) {
            self.sum += li;
            self.sq += (fipt_core::color::luminance(li) as f64).powi(2);
        } else {
            *bad += 1;
        }
        self.done += 1;
        if self.done < spp {
            self.begin(camera);
            return true;
        }
        false
    }

    /// The pixel's mean and the variance of its mean luminance.
    fn result(&self, spp: u32) -> (Rgb, f32) {
        let n = spp.max(1) as f32;
        let mean = self.sum / n;
        let l = fipt_core::color::luminance(mean) as f64;
        let var = ((self.sq / n as f64 - l * l).max(0.0) / n as f64) as f32;
        (mean, var)
    }
}

/// One tile's pixels (row-major) as (mean, variance of the mean luminance), with the rays
/// cast and the samples dropped as not finite; at most [`LANES`] pixels in flight.
fn trace_tile<S: SurfaceModel>(
    scene: &Scene<S>,
    camera: &Camera,
    cfg: &RenderConfig,
    view_key: u64,
    (x0, y0, x1, y1): (usize, usize, usize, usize),
) -> (Vec<(Rgb, f32)>, usize, usize) {
    let tw = x1 - x0;
    let n = tw * (y1 - y0);
    let mut out = vec![(Vec3::ZERO, 0.0f32); n];
    if cfg.spp == 0 {
        return (out, 0, 0);
    }
    let (mut nrays, mut bad) = (0usize, 0usize);
    let mut next = 0usize;
    let mut take = || {
        (next < n).then(|| {
            next += 1;
            let at = next - 1;
            Lane::new(at, x0 + at % tw, y0 + at / tw, camera, cfg, view_key)
        })
    };
    let mut lanes: Vec<Lane> = std::iter::from_fn(&mut take).take(LANES).collect();
    while !lanes.is_empty() {
        for lane in lanes.iter_mut() {
            lane.vertex = arrive(scene, cfg, &mut lane.path);
        }
        for v in lanes.iter().filter_map(|l| l.vertex.as_ref()) {
            v.prefetch(scene);
        }
        let mut k = 0;
        while k < lanes.len() {
            let lane = &mut lanes[k];
            let goes_on = match lane.vertex.take() {
                Some(v) => scatter(scene, cfg, &mut lane.path, &v, &mut lane.rng),
                None => false,
            };
            if goes_on || lane.end_path(camera, cfg.spp, &mut nrays, &mut bad) {
                k += 1;
                continue;
            }
            out[lane.at] = lane.result(cfg.spp);
            match take() {
                Some(fresh) => {
                    lanes[k] = fresh;
                    k += 1;
                }
                None => {
                    lanes.swap_remove(k);
                }
            }
        }
    }
    (out, nrays, bad)
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
