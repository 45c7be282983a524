//! `fipt bench --suite rays`: BVH build time, closest-hit throughput (coherent camera rays and incoherent
//! bounce rays, our wrapper side by side with obvhs's bare traversal of the same rays),
//! path-tracing speed, thread scaling and peak memory; written as JSON.
use crate::Result;
use fipt_core::brdf::Frame;
use fipt_core::memory::peak_rss_mib;
use fipt_core::rng::Pcg32;
use fipt_geom::{hit_point, shading_normal, BuildQuality, Bvh, Mesh};
use fipt_shading::brdf::sample_cosine_hemisphere;
use fipt_shading::render::{render, RenderConfig};
use fipt_shading::scene::{Scene, TableSurfaces};
use fipt_synth::icosphere_mesh;
use glam::Vec3;
use rayon::prelude::*;
use serde_json::json;
use std::time::Instant;

pub type Rays = Vec<(Vec3, Vec3)>;

/// Camera rays of `views` views and bounce rays from their hits (cosine about the facing
/// normal), the bounces drawn from random stream `stream`.
pub fn make_rays(
    mesh: &Mesh,
    bvh: &Bvh,
    cams: &[fipt_core::camera::Camera],
    stream: u64,
) -> (Rays, Rays) {
    let mut coherent = Vec::new();
    for c in cams {
        for j in 0..c.height {
            for i in 0..c.width {
                coherent.push(c.pixel_center_ray(i, j));
            }
        }
    }
    let incoherent: Rays = coherent
        .par_iter()
        .enumerate()
        .filter_map(|(k, &(o, d))| {
            let h = bvh.closest_hit(o, d, 0.0, f32::INFINITY)?;
            let p = hit_point(mesh, &h);
            let n = if h.ng.dot(d) > 0.0 { -h.ng } else { h.ng };
            let mut rng = Pcg32::new(k as u64, 3 + stream);
            let w = Frame::from_normal(n).to_world(sample_cosine_hemisphere(rng.next_2d()));
            Some((bvh.offset(p, n), w))
        })
        .collect();
    (coherent, incoherent)
}

/// Best-of-`reps` throughput in Mrays/s of `f` over `rays` (rayon, chunks of 256).
pub fn throughput<F: Fn(Vec3, Vec3) -> f32 + Sync>(rays: &Rays, reps: usize, f: F) -> (f64, f64) {
    let mut best = f64::INFINITY;
    let mut checksum = 0.0;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        checksum = rays
            .par_chunks(256)
            .map(|c| {
                c.iter()
                    .map(|&(o, d)| f(o, d) as f64)
                    .filter(|x| x.is_finite())
                    .sum::<f64>()
            })
            .sum::<f64>();
        best = best.min(t.elapsed().as_secs_f64());
    }
    (rays.len() as f64 / best / 1e6, checksum)
}

fn wrapper(mesh: &Mesh, bvh: &Bvh, o: Vec3, d: Vec3) -> f32 {
    match bvh.closest_hit(o, d, 0.0, f32::INFINITY) {
        Some(h) => {
            let p = hit_point(mesh, &h);
            let n = shading_normal(mesh, &h);
            let q = bvh.offset(p, if n.dot(d) > 0.0 { -n } else { n });
            h.t + q.x * 1e-9
        }
        None => f32::INFINITY,
    }
}

fn rays_section(
    name: &str,
    mesh: &Mesh,
    cams: &[fipt_core::camera::Camera],
    reps: usize,
) -> serde_json::Value {
    let mut build = f64::INFINITY;
    let mut bvh = None;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        bvh = Some(Bvh::build(mesh, BuildQuality::Medium));
        build = build.min(t.elapsed().as_secs_f64());
    }
    let bvh = bvh.expect("built");
    let (coh, inc) = make_rays(mesh, &bvh, cams, 0);
    let (coh_w, c1) = throughput(&coh, reps, |o, d| wrapper(mesh, &bvh, o, d));
    let (coh_b, c2) = throughput(&coh, reps, |o, d| bvh.bare_traverse(o, d));
    let (inc_w, c3) = throughput(&inc, reps, |o, d| wrapper(mesh, &bvh, o, d));
    let (inc_b, c4) = throughput(&inc, reps, |o, d| bvh.bare_traverse(o, d));
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let (inc_1t, _) = one.install(|| throughput(&inc, reps, |o, d| wrapper(mesh, &bvh, o, d)));
    let _ = (c1, c2, c3, c4);
    fipt_pipeline::note!(
        "{name:<8} {:>9} tris  build {:.3} s  coherent {:.2} Mrays/s (bare {:.2}, overhead {:+.1} %)  incoherent {:.2} Mrays/s (bare {:.2}, overhead {:+.1} %)  1→{} threads ×{:.2}",
        mesh.triangles.len(),
        build,
        coh_w,
        coh_b,
        100.0 * (coh_b / coh_w - 1.0),
        inc_w,
        inc_b,
        100.0 * (inc_b / inc_w - 1.0),
        rayon::current_num_threads(),
        inc_w / inc_1t
    );
    json!({
        "triangles": mesh.triangles.len(),
        "bvh_build_s": build,
        "coherent_rays": coh.len(),
        "incoherent_rays": inc.len(),
        "coherent_mrays_s": coh_w,
        "coherent_bare_mrays_s": coh_b,
        "coherent_wrapper_overhead": coh_b / coh_w - 1.0,
        "incoherent_mrays_s": inc_w,
        "incoherent_bare_mrays_s": inc_b,
        "incoherent_wrapper_overhead": inc_b / inc_w - 1.0,
        "incoherent_1thread_mrays_s": inc_1t,
        "thread_scaling": inc_w / inc_1t,
    })
}

/// The rays suite: the room and a ~1M-triangle mesh, then the path tracer on the room.
pub fn run(quick: bool, reps: usize, out: &std::path::Path) -> Result<()> {
    let (w, h, nviews) = if quick { (120, 80, 2) } else { (480, 320, 8) };
    let room = fipt_synth::room();
    let bvh = Bvh::build(&room.mesh, BuildQuality::Medium);
    let cams = room.cameras(nviews, 1, w, h, &bvh);
    let room_json = rays_section("room", &room.mesh, &cams, reps);
    // ~1M triangles: the room plus three icospheres of 327,680 triangles (fewer with --quick).
    let mut big = room.mesh.clone();
    let subdiv = if quick { 5 } else { 7 };
    for c in [
        Vec3::new(-1.2, 0.6, 0.8),
        Vec3::new(1.2, 1.0, -0.8),
        Vec3::new(0.0, 1.8, 0.6),
    ] {
        big.append(&icosphere_mesh(c, 0.45, subdiv));
    }
    let big_json = rays_section("1M", &big, &cams, reps);
    // Path tracing the room.
    let table = std::path::Path::new("scene_gt.json");
    let surfaces = TableSurfaces::new(room.materials.clone(), &room.mesh, table)?;
    let scene = Scene::with_bvh(room.mesh.clone(), bvh, surfaces);
    let cfg = RenderConfig {
        spp: if quick { 4 } else { 16 },
        ..Default::default()
    };
    let (pw, ph) = (240, 160);
    let pcams = room.cameras(2, 2, pw, ph, &scene.bvh);
    let t = Instant::now();
    let mut rays = 0u64;
    let mut paths = 0u64;
    for (k, c) in pcams.iter().enumerate() {
        let (_, st) = render(&scene, c, &cfg, k as u64, &|_| {});
        rays += st.rays;
        paths += st.paths;
    }
    let secs = t.elapsed().as_secs_f64();
    fipt_pipeline::note!(
        "path tracer: {} views {pw}x{ph} at {} spp in {:.2} s: {:.3} Msamples/s, {:.2} Mrays/s, {:.2} rays/path",
        pcams.len(),
        cfg.spp,
        secs,
        paths as f64 / secs / 1e6,
        rays as f64 / secs / 1e6,
        rays as f64 / paths as f64
    );
    let report = json!({
        "threads": rayon::current_num_threads(),
        "quick": quick,
        "room": room_json,
        "mesh_1m": big_json,
        "path_tracer": {
            "width": pw, "height": ph, "views": pcams.len(), "spp": cfg.spp, "seconds": secs,
            "msamples_s": paths as f64 / secs / 1e6, "mrays_s": rays as f64 / secs / 1e6,
            "rays_per_path": rays as f64 / paths as f64, "max_bounces": cfg.max_bounces,
        },
        "peak_rss_mib": peak_rss_mib(),
    });
    fipt_core::fsutil::write_json_atomic(out, &report)?;
    Ok(())
}
