//! Path-grown refinement (method §4.5): once a training round has produced a material field
//! and emitters have been extracted, the shadings are re-computed by path tracing.
//!
//! At a secondary hit, an emitter triangle returns its radiance and stops; a rough surface
//! (σ above `rough_threshold`) whose SLF voxel holds radiance returns the SLF and stops (the
//! SLF is a good radiance cache for view-independent reflection); a glossy surface continues
//! the path, with next-event estimation to the emitters and MIS, for up to `max_bounces` more
//! vertices (where the budget runs out, the vertex returns its SLF value).
//!
//! Beyond the reference:
//! * **Next-event estimation at the shading point.** Ld and Ls0/Ls1 also sample points on the
//!   emitters (`light_samples`), combined with the cosine / GGX-mixture samples by the power
//!   heuristic. A small bright lamp seen through a cosine-sampled hemisphere is the largest
//!   source of noise in the initial bake; light samples remove most of it.
//! * The diffuse cache, stratified samples and the specular mixture estimator of the initial
//!   bake ([`crate::bake`]).
//! * The field is not evaluated per path vertex: [`FieldSurfaces`] caches it on a voxel grid of
//!   the observed surface.
use crate::bake::{
    check_counts, diffuse_direct, diffuse_moments, diffuse_per_pixel, empty_view_shadings,
    moments_express, primary_records, slf_and_cells, specular_mixture_view, CellShading,
    DiffuseCells, DiffuseMoments, HitsSummary, PixelRecord, SampleStream, SpecularSettings,
};
use crate::slf::{SlfBuilder, SurfaceLightField};
use fipt_core::brdf::{Brdf, Frame};
use fipt_core::color::Rgb;
use fipt_core::dataset::View;
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::rng::Pcg32;
use fipt_core::shading::{
    Progress, RayQuery, RefineInputs, Reported, Scope, ShadingRefiner, Shard, SurfaceHit,
    ViewShadings, ViewSink,
};
use fipt_core::CoreError;
use fipt_geom::{Mesh, TriangleSampler};
use fipt_shading::brdf::MicrofacetBrdf;
use fipt_shading::field_surfaces::FieldSurfaces;
use fipt_shading::incident::{power_heuristic, IncidentLight, Incoming, LightSample, Pending};
use fipt_shading::scene::SurfaceModel;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::Instant;

pub use crate::refine_config::RefineConfig;

/// What the secondary rays of a refinement met, and where the time went.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct RefineStats {
    pub pixels: usize,
    pub cache_entries: usize,
    /// Secondary rays by outcome: left the scene, hit an emitter, stopped at a rough surface
    /// with the SLF, grew a path through a glossy surface, grew a path through a rough surface
    /// the SLF has no radiance for.
    pub secondary_miss: u64,
    pub secondary_emitter: u64,
    pub secondary_slf: u64,
    pub secondary_grown: u64,
    pub secondary_unobserved: u64,
    /// Grown paths that reached `max_bounces` and returned the SLF there.
    pub paths_truncated: u64,
    /// Rays cast (secondary, continuation and shadow rays).
    pub rays: u64,
    /// Emitter triangles sampled for next-event estimation.
    pub emitter_triangles: usize,
    /// Material-cache voxels.
    pub material_voxels: usize,
    /// The diffuse cache's cell edge, in pixel footprints ([`RefineConfig::cache_cell_for`]).
    #[serde(default)]
    pub cache_cell_footprints: f32,
    /// Hit pixels off the emitters left out of the SLF beside them (`slf_light_margin`).
    #[serde(default)]
    pub slf_margin_pixels: usize,
    pub seconds_setup: f64,
    pub seconds_diffuse: f64,
    pub seconds_specular: f64,
}

/// Outcome counts, one cache-line-aligned set per worker thread (shared counters would bounce
/// a cache line between cores on every secondary ray).
#[derive(Default)]
#[repr(align(128))]
struct Counters {
    miss: AtomicU64,
    emitter: AtomicU64,
    slf: AtomicU64,
    grown: AtomicU64,
    unobserved: AtomicU64,
    truncated: AtomicU64,
    rays: AtomicU64,
}

struct ThreadCounters(Vec<Counters>);

impl ThreadCounters {
    fn new() -> Self {
        ThreadCounters(
            (0..rayon::current_num_threads() + 1)
                .map(|_| Counters::default())
                .collect(),
        )
    }
    #[inline]
    fn get(&self) -> &Counters {
        let i = rayon::current_thread_index().map_or(0, |i| i + 1);
        &self.0[i % self.0.len()]
    }
    fn total(&self, f: impl Fn(&Counters) -> &AtomicU64) -> u64 {
        self.0.iter().map(|c| f(c).load(Ordering::Relaxed)).sum()
    }
}

impl RefineStats {
    /// Copies the secondary rays' outcomes counted by the threads.
    fn take_counters(&mut self, c: &ThreadCounters) {
        self.secondary_miss = c.total(|c| &c.miss);
        self.secondary_emitter = c.total(|c| &c.emitter);
        self.secondary_slf = c.total(|c| &c.slf);
        self.secondary_grown = c.total(|c| &c.grown);
        self.secondary_unobserved = c.total(|c| &c.unobserved);
        self.paths_truncated = c.total(|c| &c.truncated);
        self.rays = c.total(|c| &c.rays);
    }
}

/// The light of the refinement: emitters, the SLF at rough surfaces, paths through glossy ones.
pub struct GrownLight<'a> {
    pub geometry: &'a dyn RayQuery,
    pub slf: &'a SurfaceLightField,
    pub surfaces: &'a FieldSurfaces,
    /// Mesh for emitter sampling.
    pub mesh: &'a Mesh,
    pub lights: Option<TriangleSampler>,
    /// Area density of emitter samples on each triangle (0 off the emitters).
    pub light_pdf_area: Vec<f32>,
    pub rough_threshold: f32,
    pub max_bounces: u32,
    counters: ThreadCounters,
}

impl<'a> GrownLight<'a> {
    pub fn new(
        geometry: &'a dyn RayQuery,
        slf: &'a SurfaceLightField,
        surfaces: &'a FieldSurfaces,
        mesh: &'a Mesh,
        rough_threshold: f32,
        max_bounces: u32,
    ) -> Self {
        let (lights, light_pdf_area) =
            fipt_shading::scene::emitter_sampler(mesh, |t| surfaces.emission(t));
        GrownLight {
            geometry,
            slf,
            surfaces,
            mesh,
            lights,
            light_pdf_area,
            rough_threshold,
            max_bounces,
            counters: ThreadCounters::new(),
        }
    }

    /// Solid-angle density of emitter sampling for a ray that hits emitter triangle `tri` at
    /// distance `t` with |cos| `cos` at the emitter.
    #[inline]
    fn light_pdf(&self, tri: u32, t: f32, cos: f32) -> f32 {
        if cos > 0.0 {
            self.light_pdf_area[tri as usize] * t * t / cos
        } else {
            0.0
        }
    }

    /// Radiance leaving the non-emitter hit `hit` towards `-dir`: the SLF at a rough surface,
    /// else a path grown through the glossy surface (NEE + MIS at each vertex).
    fn outgoing(&self, mut hit: SurfaceHit, mut dir: Vec3, rng: &mut Pcg32) -> Rgb {
        let mut l = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut bounce = 0;
        loop {
            let sp = self.surfaces.surface(hit.tri, hit.p);
            let cached = self.slf.lookup(hit.p);
            if sp.roughness > self.rough_threshold && cached != Vec3::ZERO {
                if bounce == 0 {
                    self.counters.get().slf.fetch_add(1, Ordering::Relaxed);
                }
                return l + beta * cached;
            }
            if bounce == 0 {
                let c = self.counters.get();
                if sp.roughness > self.rough_threshold {
                    c.unobserved.fetch_add(1, Ordering::Relaxed);
                } else {
                    c.grown.fetch_add(1, Ordering::Relaxed);
                }
            }
            if bounce >= self.max_bounces {
                self.counters
                    .get()
                    .truncated
                    .fetch_add(1, Ordering::Relaxed);
                return l + beta * cached;
            }
            let wo_w = -dir;
            let ng = if hit.ng.dot(wo_w) < 0.0 {
                -hit.ng
            } else {
                hit.ng
            };
            let ns = if hit.ns.dot(ng) < 0.0 {
                -hit.ns
            } else {
                hit.ns
            };
            let frame = Frame::from_normal(ns);
            let wo = frame.to_local(wo_w);
            if wo.z <= 0.0 {
                return l;
            }
            let brdf =
                MicrofacetBrdf::with_model(self.surfaces.model(), sp.kd, sp.ks, sp.roughness);
            let origin = self.geometry.offset(hit.p, ng);
            if let Some(ls) = self.sample_emitter(origin, rng) {
                let wi = frame.to_local(ls.wi);
                if wi.z > 0.0 && ls.wi.dot(ng) > 0.0 {
                    let (f, brdf_pdf) = brdf.eval_pdf(wo, wi);
                    let w = power_heuristic(ls.pdf, brdf_pdf);
                    l += beta * f * ls.le * (w / ls.pdf);
                }
            }
            let Some(s) = brdf.sample(wo, rng.next_f32(), rng.next_2d()) else {
                return l;
            };
            let wi_w = frame.to_world(s.wi);
            if wi_w.dot(ng) <= 0.0 {
                return l;
            }
            beta *= s.weight;
            self.counters.get().rays.fetch_add(1, Ordering::Relaxed);
            let Some(next) = self.geometry.intersect(origin, wi_w) else {
                return l;
            };
            let le = self.surfaces.emission(next.tri);
            if le != Vec3::ZERO
                && !self
                    .surfaces
                    .emit_side(next.tri)
                    .emits_towards(next.ng, -wi_w)
            {
                return l;
            }
            if le != Vec3::ZERO {
                let lp = self.light_pdf(next.tri, next.t, next.ng.dot(wi_w).abs());
                return l + beta * le * power_heuristic(s.pdf, lp);
            }
            hit = next;
            dir = wi_w;
            bounce += 1;
        }
    }
}

impl IncidentLight for GrownLight<'_> {
    fn incoming(&self, origin: Vec3, dir: Vec3, rng: &mut Pcg32) -> Incoming {
        self.finish(self.begin(origin, dir, rng), rng)
    }

    /// The first hit, an emitter's answer at once; at a surface, its material's and its SLF
    /// voxel's memory requested for `finish`, which grows the path (and draws from `rng`).
    #[inline]
    fn begin(&self, origin: Vec3, dir: Vec3, _rng: &mut Pcg32) -> Pending {
        self.counters.get().rays.fetch_add(1, Ordering::Relaxed);
        let Some(hit) = self.geometry.intersect(origin, dir) else {
            self.counters.get().miss.fetch_add(1, Ordering::Relaxed);
            return Pending::Ready(Incoming::Miss);
        };
        let le = self.surfaces.emission(hit.tri);
        if le != Vec3::ZERO && !self.surfaces.emit_side(hit.tri).emits_towards(hit.ng, -dir) {
            // A light's dark side: black, and it reflects nothing.
            return Pending::Ready(Incoming::Radiance(Vec3::ZERO));
        }
        if le != Vec3::ZERO {
            self.counters.get().emitter.fetch_add(1, Ordering::Relaxed);
            return Pending::Ready(Incoming::Emitter {
                le,
                light_pdf: self.light_pdf(hit.tri, hit.t, hit.ng.dot(dir).abs()),
            });
        }
        self.surfaces.prefetch(hit.tri, hit.p);
        self.slf.prefetch(hit.p);
        Pending::Hit { hit, dir }
    }

    #[inline]
    fn finish(&self, pending: Pending, rng: &mut Pcg32) -> Incoming {
        match pending {
            Pending::Ready(i) => i,
            Pending::Hit { hit, dir } => Incoming::Radiance(self.outgoing(hit, dir, rng)),
        }
    }

    fn has_emitters(&self) -> bool {
        self.lights.is_some()
    }

    fn sample_emitter(&self, origin: Vec3, rng: &mut Pcg32) -> Option<LightSample> {
        let lights = self.lights.as_ref()?;
        let s = lights.sample(self.mesh, rng.next_f32(), rng.next_2d());
        let d = s.p - origin;
        let dist2 = d.length_squared();
        let dist = dist2.sqrt();
        if !(dist > 0.0) {
            return None;
        }
        let wi = d / dist;
        if !self.surfaces.emit_side(s.tri).emits_towards(s.n, -wi) {
            return None;
        }
        let cos = s.n.dot(wi).abs();
        if !(cos > 0.0) {
            return None;
        }
        self.counters.get().rays.fetch_add(1, Ordering::Relaxed);
        if self.geometry.occluded(origin, wi, dist * (1.0 - 1e-4)) {
            return None;
        }
        Some(LightSample {
            wi,
            dist,
            le: self.surfaces.emission(s.tri),
            pdf: s.pdf_area * dist2 / cos,
        })
    }
}

/// Whether each of `n` mesh triangles belongs to one of the `emitters`.
fn emitting_triangles(n: usize, emitters: &[fipt_core::emitter::Emitter]) -> Vec<bool> {
    let mut emitting = vec![false; n];
    for &t in emitters.iter().flat_map(|e| &e.triangles) {
        if let Some(e) = emitting.get_mut(t as usize) {
            *e = true;
        }
    }
    emitting
}

/// The FIPT path-grown refiner, with the switches of [`RefineConfig`], for the shadings (and
/// the paths) of a [`ReflectanceModel`].
#[derive(Clone, Debug, Default)]
pub struct PathGrownRefiner {
    pub config: RefineConfig,
    pub model: ReflectanceModel,
}

impl PathGrownRefiner {
    /// A refiner of FIPT-model shadings.
    pub fn new(config: RefineConfig) -> Self {
        PathGrownRefiner {
            config,
            model: ReflectanceModel::Fipt,
        }
    }

    /// The same refiner for `model`.
    pub fn with_model(mut self, model: ReflectanceModel) -> Self {
        self.model = model;
        self
    }

    /// Refines and reports what the secondary rays met and where the time went.
    pub fn refine_detailed(
        &self,
        inputs: &RefineInputs,
        progress: Progress,
    ) -> fipt_core::Result<(Vec<ViewShadings>, RefineStats)> {
        self.refine_views(inputs, Shard::ALL, progress)
    }

    /// [`PathGrownRefiner::refine_detailed`] of `shard`'s views only, bit-identical to the
    /// unsharded refinement there (the SLF, the material cache and the diffuse cache's cells
    /// come from every view; only the cells of the shard's pixels are integrated; sample
    /// streams are keyed by global indices). The other views' shadings are 0 × 0; the stats
    /// count the shard's work.
    pub fn refine_views(
        &self,
        inputs: &RefineInputs,
        shard: Shard,
        progress: Progress,
    ) -> fipt_core::Result<(Vec<ViewShadings>, RefineStats)> {
        let poly = self.model.diffuse_depends_on_roughness();
        let mut out: Vec<ViewShadings> = (inputs.views.iter())
            .map(|_| ViewShadings::zeros_for(0, 0, self.config.levels, poly))
            .collect();
        let stats = self.refine_streamed(inputs, shard.into(), progress, &mut |k, s| {
            out[k] = s;
            Ok(())
        })?;
        Ok((out, stats))
    }

    /// The refinement of `shard`'s views, each view handed to `sink` as soon as it is done (in
    /// view order) and dropped: it holds one view's hits and shadings at a time beside the SLF,
    /// the material cache and the diffuse cache (all bounded by the surface area, not by the
    /// number of views). The primary hits are traced again per pass instead of held. Of each
    /// view's hit pixels it shades those `scope.pixels` draws (the others read as misses),
    /// each exactly as a refinement of every pixel would: the SLF, the material cache and the
    /// diffuse cache's cells come from every pixel.
    pub fn refine_streamed(
        &self,
        inputs: &RefineInputs,
        scope: Scope,
        progress: Progress,
        sink: ViewSink,
    ) -> fipt_core::Result<RefineStats> {
        let cfg = &self.config;
        let RefineInputs {
            geometry,
            views,
            images,
            ..
        } = *inputs;
        check_counts("refine", views, images)?;
        let t = Instant::now();
        let mut stats = RefineStats::default();
        let mesh = Mesh::from_triangles(inputs.positions.to_vec(), None, inputs.triangles.to_vec());
        if mesh.triangles.len() != inputs.triangles.len() {
            return Err(CoreError::invalid(
                "refine",
                "the mesh holds degenerate triangles: pass the mesh as loaded (degenerate triangles dropped)",
            ));
        }
        let selected = scope.shard.mask(views.len());
        let model = self.model;
        let summary = HitsSummary::of(geometry, views, 1.1);
        let Some(cube) = summary.cube else {
            for (k, v) in views.iter().enumerate().filter(|(k, _)| selected[*k]) {
                let r = primary_records(geometry, v);
                sink(k, empty_view_shadings(v, &r, cfg.levels, model))?;
            }
            return Ok(stats);
        };
        let footprint = summary.footprint.unwrap_or(1e-3).max(1e-9);
        // The SLF from the pixels off the emitters: a voxel straddling a light's outline
        // would otherwise lend the light's radiance to the surface beside it, which the
        // emitters' own sampling already counts. The diffuse cache's cells beside it.
        let emitting = emitting_triangles(mesh.triangles.len(), inputs.emitters);
        // The cache holds moments, which express the built-in lobes only.
        let use_cache = cfg.diffuse_cache && moments_express(model);
        stats.cache_cell_footprints = cfg.cache_cell_for(&scope.pixels);
        let (slf, cells, _, hit, bled) = slf_and_cells(
            geometry,
            views,
            images,
            SlfBuilder::with_fallback(cube, cfg.slf_resolution, cfg.slf_fallback_levels),
            DiffuseCells::new(cube.min, footprint * stats.cache_cell_footprints),
            use_cache,
            scope,
            |r| !emitting[r.hit.tri as usize],
            cfg.slf_light_margin as usize,
        );
        stats.pixels = hit;
        stats.slf_margin_pixels = bled;
        let surfaces = material_surfaces(inputs, &mesh, footprint * cfg.material_cell_scale)?
            .with_model(model);
        stats.material_voxels = surfaces.voxels();
        let light = GrownLight::new(
            geometry,
            &slf,
            &surfaces,
            &mesh,
            cfg.rough_threshold,
            cfg.max_bounces,
        );
        stats.emitter_triangles = light.lights.as_ref().map_or(0, |l| l.len());
        stats.seconds_setup = t.elapsed().as_secs_f64();
        let pass = ViewPass {
            cfg,
            model,
            geometry,
            light: &light,
            surfaces: &surfaces,
        };
        // Ld: per cache cell, or per pixel.
        let t = Instant::now();
        let cached = use_cache.then(|| pass.cache(&cells, &mut stats));
        stats.seconds_diffuse = t.elapsed().as_secs_f64();
        let total = stats.pixels * 2;
        let cached = cached.as_ref().map(|c| (&cells, c));
        pass.shade_views(views, scope, cached, total, &mut stats, progress, sink)?;
        stats.take_counters(&light.counters);
        Ok(stats)
    }
}

/// The field's materials per surface cell of `cell` metres around every view's primary hits.
fn material_surfaces(
    inputs: &RefineInputs,
    mesh: &Mesh,
    cell: f32,
) -> fipt_core::Result<FieldSurfaces> {
    let (geometry, views) = (inputs.geometry, inputs.views);
    let hits = |f: &mut fipt_shading::field_surfaces::PointSink| {
        for v in views {
            let r = primary_records(geometry, v);
            let pts: Vec<(Vec3, u32)> = r.iter().flatten().map(|r| (r.hit.p, r.hit.tri)).collect();
            f(&pts);
        }
    };
    FieldSurfaces::build_from(inputs.field, mesh, inputs.emitters, &hits, cell)
}

/// What the refinement's per-pixel passes share once its light is set up.
struct ViewPass<'a> {
    cfg: &'a RefineConfig,
    model: ReflectanceModel,
    geometry: &'a dyn RayQuery,
    light: &'a GrownLight<'a>,
    surfaces: &'a FieldSurfaces,
}

impl ViewPass<'_> {
    /// The diffuse moments at a point, its sample streams keyed by `key`.
    fn moments(&self, key: &[u64], p: Vec3, ng: Vec3, ns: Vec3) -> DiffuseMoments {
        let cfg = self.cfg;
        let mut st = SampleStream::new(cfg.sampler, key);
        let mut rng = Pcg32::from_keys(&[key, &[0x9A7]].concat());
        diffuse_moments(
            self.light,
            self.geometry,
            p,
            ng,
            ns,
            cfg.diffuse_samples,
            cfg.light_samples,
            &mut st,
            &mut rng,
            self.model.diffuse_depends_on_roughness(),
        )
    }

    /// (Ld0, [Ld1, Ld2]) at one pixel, its sample streams keyed by `key`: from the moments
    /// where they express the model, else by the model's basis for the pixel's ωo.
    fn pixel_ld(&self, key: &[u64], rec: &PixelRecord) -> (Rgb, [Rgb; 2]) {
        let model = self.model;
        if moments_express(model) {
            return self
                .moments(key, rec.hit.p, rec.ng, rec.ns)
                .shading(model, rec.wo, rec.ns);
        }
        let cfg = self.cfg;
        let mut st = SampleStream::new(cfg.sampler, key);
        let mut rng = Pcg32::from_keys(&[key, &[0x9A7]].concat());
        let at = (rec.hit.p, rec.ng, rec.ns);
        let (n, n_light) = (cfg.diffuse_samples, cfg.light_samples);
        diffuse_direct(
            self.light,
            self.geometry,
            at,
            rec.wo,
            model,
            n,
            n_light,
            &mut st,
            &mut rng,
        )
    }

    /// Ld of every diffuse cache cell a view uses (emitting cells keep 0).
    fn cache(&self, cells: &DiffuseCells, stats: &mut RefineStats) -> CellShading {
        let needed = cells.used();
        stats.cache_entries = needed.iter().filter(|&&n| n).count();
        let seed = self.cfg.seed;
        cells.integrate(self.model, |k, c| {
            if !needed[k] || self.surfaces.emission(c.tri) != Vec3::ZERO {
                return DiffuseMoments::default();
            }
            self.moments(&[seed, 0xD1FF, c.tri as u64, k as u64], c.p, c.ng, c.ns)
        })
    }

    /// Each selected view's shadings, handed to `sink` in view order: Ld from the cache's
    /// cells (or per pixel without it), Ls0/Ls1 per pixel (emitter pixels keep 0: the mask
    /// explains them).
    #[allow(clippy::too_many_arguments)]
    fn shade_views(
        &self,
        views: &[View],
        scope: Scope,
        cached: Option<(&DiffuseCells, &CellShading)>,
        total: usize,
        stats: &mut RefineStats,
        progress: Progress,
        sink: ViewSink,
    ) -> fipt_core::Result<()> {
        let (cfg, model, seed) = (self.cfg, self.model, self.cfg.seed);
        let is_emitter = |r: &PixelRecord| self.surfaces.emission(r.hit.tri) != Vec3::ZERO;
        let done = AtomicUsize::new(0);
        let tick = |n: usize| progress(done.fetch_add(n, Ordering::Relaxed) + n, total);
        let set = SpecularSettings {
            levels: &cfg.levels,
            counts: &cfg.specular_samples,
            n_light: cfg.light_samples,
            sampler: cfg.sampler,
            seed,
            model,
        };
        for (vi, v) in views
            .iter()
            .enumerate()
            .filter(|(k, _)| scope.shard.contains(*k))
        {
            let mut r = primary_records(self.geometry, v);
            scope.pixels.clear_undrawn(vi, &mut r);
            let hit = r.iter().flatten().count();
            let mut s = empty_view_shadings(v, &r, cfg.levels, model);
            let t = Instant::now();
            match cached {
                Some((cells, shading)) => cells.scatter_view(shading, model, &r, &mut s),
                None => diffuse_per_pixel(&r, &mut s, is_emitter, |i, rec| {
                    self.pixel_ld(&[seed, 0xD1FF, vi as u64, i as u64], rec)
                }),
            }
            tick(hit);
            stats.seconds_diffuse += t.elapsed().as_secs_f64();
            let t = Instant::now();
            specular_mixture_view(self.light, self.geometry, &set, vi, &r, &mut s, &is_emitter);
            tick(hit);
            stats.seconds_specular += t.elapsed().as_secs_f64();
            sink(vi, s)?;
        }
        Ok(())
    }
}

impl ShadingRefiner for PathGrownRefiner {
    fn name(&self) -> &str {
        self.model.component_name("fipt-path-grown")
    }
    fn caveats(&self) -> Vec<String> {
        crate::diffuse::diffuse_cache_caveat(self.model)
    }
    fn refine(
        &self,
        inputs: &RefineInputs,
        progress: Progress,
    ) -> fipt_core::Result<Reported<Vec<ViewShadings>>> {
        self.refine_shard(inputs, Shard::ALL, progress)
    }
    fn refine_shard(
        &self,
        inputs: &RefineInputs,
        shard: Shard,
        progress: Progress,
    ) -> fipt_core::Result<Reported<Vec<ViewShadings>>> {
        let (output, stats) = self.refine_views(inputs, shard, progress)?;
        Ok(Reported {
            output,
            report: serde_json::to_value(stats).unwrap_or_default(),
        })
    }
    fn refine_into(
        &self,
        inputs: &RefineInputs,
        scope: Scope,
        progress: Progress,
        sink: ViewSink,
    ) -> fipt_core::Result<serde_json::Value> {
        let stats = self.refine_streamed(inputs, scope, progress, sink)?;
        Ok(serde_json::to_value(stats).unwrap_or_default())
    }
}

impl fipt_core::presets::Presets for RefineConfig {
    fn paper() -> Self {
        RefineConfig::paper()
    }
    fn reference() -> Self {
        RefineConfig::reference()
    }
    fn balanced() -> Self {
        RefineConfig::balanced()
    }
    fn fast() -> Self {
        RefineConfig::fast()
    }
}
