//! The initial bake (method §3–4): for every training pixel, the diffuse shading Ld (cosine
//! sampling) and the specular shadings Ls0/Ls1 at the roughness levels (GGX half-vector
//! sampling; one set of directions serves both), with the SLF as incident light.
//!
//! Beyond the reference:
//! * **Diffuse cache** (`diffuse_cache`): Ld(x) does not depend on the view, so it is integrated
//!   once per surface cell (triangle × side × a cell about one pixel footprint wide) and shared by
//!   every pixel of every view that sees the cell, instead of once per pixel.
//! * **Low-discrepancy sampling** (`sampler = "stratified"`): a rank-1 lattice (R2 sequence)
//!   with a random shift per pixel and term, instead of independent random numbers.
pub use crate::diffuse::{
    diffuse_direct, diffuse_moments, diffuse_shading, moments_express, CellShading, DiffuseCell,
    DiffuseCells, DiffuseMoments,
};
pub(crate) use crate::passes::{
    check_counts, diffuse_per_pixel, slf_and_cells, specular_mixture_view, SpecularSettings,
};
use crate::slf::{Cube, SlfBuilder, SurfaceLightField};
pub use crate::specular::specular_shading_mixture;
use crate::specular::{reflect_about, sample_ggx_h};
pub use crate::stream::{SampleStream, SamplerKind};
use fipt_core::brdf::Frame;
use fipt_core::color::Rgb;
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_core::reflectance::{schlick_weight, ReflectanceModel};
use fipt_core::rng::Pcg32;
use fipt_core::shading::{
    Progress, RayQuery, Reported, Scope, ShadingBaker, Shard, ViewShadings, ViewSink,
    DEFAULT_LEVELS, NUM_LEVELS,
};
use fipt_shading::incident::{IncidentLight, Incoming, Pending};
pub use fipt_shading::records::{
    empty_shadings, empty_shadings_of, empty_view_shadings, median_footprint, primary_records,
    HitsSummary, PixelRecord,
};
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// How the specular shadings at the roughness levels are estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpecularEstimator {
    /// Each level integrates with its own GGX samples only (the reference).
    PerLevel,
    /// Every level reuses every sample of every level through the balance heuristic
    /// (multi-sample MIS over the mixture of the level lobes): the same rays, lower variance.
    Mixture,
}

/// Settings of the initial bake.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BakeConfig {
    /// SLF voxels per axis of the scene cube. Default 256.
    pub slf_resolution: u32,
    /// Coarser SLF grids an empty voxel falls back to (0 = the reference's strict lookup). Default 3.
    pub slf_fallback_levels: u32,
    /// Cosine samples for Ld. Default 256.
    pub diffuse_samples: u32,
    /// GGX samples for Ls0/Ls1 at each level. Default [64, 128, 128, 128, 128, 128].
    pub specular_samples: [u32; NUM_LEVELS],
    /// Roughness levels (increasing, in [0.02, 1]). Default linspace(0.02, 1, 6).
    pub levels: [f32; NUM_LEVELS],
    /// Integrate Ld once per surface cell and share it across pixels and views. Default true.
    pub diffuse_cache: bool,
    /// Cache cell edge as a multiple of the median pixel footprint. Default 1.0.
    pub cache_cell_scale: f32,
    /// Sample directions: "independent" or "stratified". Default stratified.
    pub sampler: SamplerKind,
    /// Specular estimator: "per_level" or "mixture". Default mixture.
    pub specular_estimator: SpecularEstimator,
    /// Seed of all random streams. Default 0.
    pub seed: u64,
}

impl Default for BakeConfig {
    fn default() -> Self {
        BakeConfig {
            slf_resolution: 256,
            slf_fallback_levels: 3,
            diffuse_samples: 256,
            specular_samples: [64, 128, 128, 128, 128, 128],
            levels: DEFAULT_LEVELS,
            diffuse_cache: true,
            cache_cell_scale: 1.0,
            sampler: SamplerKind::Stratified,
            specular_estimator: SpecularEstimator::Mixture,
            seed: 0,
        }
    }
}

impl BakeConfig {
    /// The reference's sample counts with this crate's estimators: the same as `balanced`,
    /// whose counts are the reference's already.
    pub fn paper() -> Self {
        Self::default()
    }
    /// The reference implementation's estimators too: per-pixel Ld, independent samples,
    /// one estimate per roughness level, strict SLF.
    pub fn reference() -> Self {
        BakeConfig {
            diffuse_cache: false,
            sampler: SamplerKind::Independent,
            slf_fallback_levels: 0,
            specular_estimator: SpecularEstimator::PerLevel,
            ..Default::default()
        }
    }
    /// A quarter of the samples.
    pub fn fast() -> Self {
        BakeConfig {
            diffuse_samples: 64,
            specular_samples: [16, 32, 32, 32, 32, 32],
            ..Default::default()
        }
    }

    /// Refuses settings that would exhaust the machine or mean nothing, naming the key.
    pub fn validate(&self) -> Result<(), String> {
        crate::limits::check_shading(
            "bake",
            self.slf_resolution,
            self.slf_fallback_levels,
            self.diffuse_samples,
            &self.specular_samples,
            &self.levels,
            self.cache_cell_scale,
        )
    }
}

/// Where the time and rays of a bake went.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct BakeStats {
    pub pixels: usize,
    pub valid_pixels: usize,
    pub slf_occupied_voxels: usize,
    pub slf_memory_bytes: usize,
    pub cache_entries: usize,
    pub cache_cell: f32,
    pub rays_diffuse: u64,
    pub rays_specular: u64,
    pub seconds_primary: f64,
    pub seconds_slf: f64,
    pub seconds_diffuse: f64,
    pub seconds_specular: f64,
}

/// Builds the SLF from primary records and the matching HDR images, from the pixels whose
/// record `keep` accepts (the cube spans every record either way).
pub fn build_slf(
    records: &[Vec<Option<PixelRecord>>],
    images: &[Image],
    resolution: u32,
    fallback_levels: u32,
    keep: impl Fn(&PixelRecord) -> bool,
) -> Option<SurfaceLightField> {
    let cube = Cube::around(records.iter().flatten().flatten().map(|r| r.hit.p), 1.1)?;
    let mut b = SlfBuilder::with_fallback(cube, resolution, fallback_levels);
    for (recs, img) in records.iter().zip(images) {
        let kept: Vec<(Vec3, Rgb)> = (recs.iter().zip(&img.data))
            .filter_map(|(r, l)| r.as_ref().filter(|r| keep(r)).map(|r| (r.hit.p, *l)))
            .collect();
        b.add_all(&kept);
    }
    Some(b.finish())
}

/// Incident radiance from the SLF: the voxel radiance at the closest hit, 0 on a miss.
#[derive(Clone, Copy)]
pub struct SlfLight<'a> {
    pub geometry: &'a dyn RayQuery,
    pub slf: &'a SurfaceLightField,
}

impl SlfLight<'_> {
    /// The SLF radiance at the closest hit along `origin + t·dir` (None on a miss).
    #[inline]
    fn at_hit(&self, origin: Vec3, dir: Vec3) -> Option<Rgb> {
        self.geometry
            .intersect(origin, dir)
            .map(|h| self.slf.lookup(h.p))
    }
    /// The radiance arriving at `origin` from `dir` (0 on a miss).
    #[inline]
    pub fn li(&self, origin: Vec3, dir: Vec3) -> Rgb {
        self.at_hit(origin, dir).unwrap_or(Vec3::ZERO)
    }
}

impl IncidentLight for SlfLight<'_> {
    #[inline]
    fn incoming(&self, origin: Vec3, dir: Vec3, rng: &mut Pcg32) -> Incoming {
        self.finish(self.begin(origin, dir, rng), rng)
    }
    /// The hit, with its voxel's cache lines requested; `finish` reads them.
    #[inline]
    fn begin(&self, origin: Vec3, dir: Vec3, _rng: &mut Pcg32) -> Pending {
        match self.geometry.intersect(origin, dir) {
            Some(hit) => {
                self.slf.prefetch(hit.p);
                Pending::Hit { hit, dir }
            }
            None => Pending::Ready(Incoming::Miss),
        }
    }
    #[inline]
    fn finish(&self, pending: Pending, _rng: &mut Pcg32) -> Incoming {
        match pending {
            Pending::Ready(i) => i,
            Pending::Hit { hit, .. } => Incoming::Radiance(self.slf.lookup(hit.p)),
        }
    }
}

/// Ls0 and Ls1 at roughness `sigma` by GGX half-vector sampling:
/// weight = Li·F_k·G·(ωo·h)/((n·h)(n·ωo)), F0 = 1 − (1−ωo·h)⁵, F1 = (1−ωo·h)⁵.
#[allow(clippy::too_many_arguments)]
pub fn specular_shading(
    light: &SlfLight,
    p: Vec3,
    ng: Vec3,
    ns: Vec3,
    wo_world: Vec3,
    sigma: f32,
    n: u32,
    stream: &mut SampleStream,
    model: ReflectanceModel,
) -> (Rgb, Rgb) {
    if n == 0 {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let frame = Frame::from_normal(ns);
    let mut wo = frame.to_local(wo_world);
    if wo.z < 1e-4 {
        // Shading normal turned away from the viewer: graze instead.
        wo = Vec3::new(wo.x, wo.y, 1e-4).normalize();
    }
    let origin = light.geometry.offset(p, ng);
    let alpha = sigma * sigma;
    let g1o = model.g1(wo.z, sigma);
    let (mut s0, mut s1) = (Vec3::ZERO, Vec3::ZERO);
    for _ in 0..n {
        let h = sample_ggx_h(alpha, stream.next());
        let Some((wi, voh, li)) = reflected_li(light, &frame, origin, ng, wo, h) else {
            continue;
        };
        let g = model.g1(wi.z, sigma) * g1o;
        let w = g * voh / (h.z * wo.z);
        let m = schlick_weight(voh);
        s0 += li * (w * (1.0 - m));
        s1 += li * (w * m);
    }
    (s0 / n as f32, s1 / n as f32)
}

/// Reflects `wo` about the half vector `h` (local frame) and looks up the incident light:
/// (local ωi, ωo·h, Li), or None when ωi leaves below the shading or geometric surface or
/// no light arrives.
#[inline]
fn reflected_li(
    light: &SlfLight,
    frame: &Frame,
    origin: Vec3,
    ng: Vec3,
    wo: Vec3,
    h: Vec3,
) -> Option<(Vec3, f32, Rgb)> {
    let (wi, voh, wi_w) = reflect_about(frame, ng, wo, h)?;
    let li = light.li(origin, wi_w);
    (li != Vec3::ZERO).then_some((wi, voh, li))
}

/// The FIPT initial baker (SLF incident light), with the switches of [`BakeConfig`], for the
/// shadings of a [`ReflectanceModel`].
#[derive(Clone, Debug, Default)]
pub struct FactorizedBaker {
    pub config: BakeConfig,
    pub model: ReflectanceModel,
}

impl FactorizedBaker {
    /// A baker of FIPT-model shadings.
    pub fn new(config: BakeConfig) -> Self {
        FactorizedBaker {
            config,
            model: ReflectanceModel::Fipt,
        }
    }

    /// The same baker for `model`'s shadings.
    pub fn with_model(mut self, model: ReflectanceModel) -> Self {
        self.model = model;
        self
    }

    /// Bakes and reports where the time went.
    pub fn bake_detailed(
        &self,
        geometry: &dyn RayQuery,
        views: &[View],
        images: &[Image],
        progress: Progress,
    ) -> (Vec<ViewShadings>, BakeStats, Option<SurfaceLightField>) {
        self.bake_views(geometry, views, images, Shard::ALL, progress)
    }

    /// [`FactorizedBaker::bake_detailed`] of `shard`'s views only: the SLF and the diffuse
    /// cache's cells come from every view's primary hits (cheap), only the cells that the
    /// shard's pixels fall in are integrated, and every sample stream is keyed by the global
    /// view and cell indices, so the shard's shadings are bit-identical to an unsharded bake's.
    /// The other views' shadings are 0 × 0; the counts in the stats are the shard's work.
    pub fn bake_views(
        &self,
        geometry: &dyn RayQuery,
        views: &[View],
        images: &[Image],
        shard: Shard,
        progress: Progress,
    ) -> (Vec<ViewShadings>, BakeStats, Option<SurfaceLightField>) {
        let poly = self.model.diffuse_depends_on_roughness();
        let levels = self.config.levels;
        let mut out: Vec<ViewShadings> = views
            .iter()
            .map(|_| ViewShadings::zeros_for(0, 0, levels, poly))
            .collect();
        let (stats, slf) = self
            .bake_streamed(
                geometry,
                views,
                images,
                shard.into(),
                progress,
                &mut |k, s| {
                    out[k] = s;
                    Ok(())
                },
            )
            .expect("collecting views does not fail");
        (out, stats, slf)
    }

    /// The bake of `shard`'s views, each view handed to `sink` as soon as it is done (in view
    /// order) and dropped: the bake holds one view's hits and shadings at a time, beside the
    /// SLF and the diffuse cache (one entry per surface cell, bounded by the surface area, not
    /// by the number of views). The primary hits are traced again in each of three passes
    /// (the cube and footprint, the SLF and the cells, the shadings); they are a small part of
    /// the bake's rays. Results are those of a bake that holds every view. Of each view's hit
    /// pixels it shades those `scope.pixels` draws (the others read as misses), each exactly
    /// as a bake of every pixel would: the SLF and the cache's cells come from every pixel.
    pub fn bake_streamed(
        &self,
        geometry: &dyn RayQuery,
        views: &[View],
        images: &[Image],
        scope: Scope,
        progress: Progress,
        sink: ViewSink,
    ) -> fipt_core::Result<(BakeStats, Option<SurfaceLightField>)> {
        let cfg = &self.config;
        // The cache holds moments, which express the built-in lobes only.
        let use_cache = cfg.diffuse_cache && moments_express(self.model);
        let mut stats = BakeStats::default();
        let t = Instant::now();
        let summary = HitsSummary::of(geometry, views, 1.1);
        stats.seconds_primary = t.elapsed().as_secs_f64();
        let selected = scope.shard.mask(views.len());
        let model = self.model;
        let Some(cube) = summary.cube else {
            for (k, v) in views.iter().enumerate().filter(|(k, _)| selected[*k]) {
                let cam = &v.camera;
                let poly = model.diffuse_depends_on_roughness();
                sink(
                    k,
                    ViewShadings::zeros_for(cam.width, cam.height, cfg.levels, poly),
                )?;
            }
            return Ok((stats, None));
        };
        // The SLF and the diffuse cache's cells, one view at a time.
        let t = Instant::now();
        let cell = summary.footprint.unwrap_or(1e-3).max(1e-9) * cfg.cache_cell_scale.max(1e-3);
        let slf;
        let cells;
        (slf, cells, stats.pixels, stats.valid_pixels, _) = slf_and_cells(
            geometry,
            views,
            images,
            SlfBuilder::with_fallback(cube, cfg.slf_resolution, cfg.slf_fallback_levels),
            DiffuseCells::new(cube.min, cell),
            use_cache,
            scope,
            |_| true,
            0,
        );
        stats.seconds_slf = t.elapsed().as_secs_f64();
        stats.slf_occupied_voxels = slf.occupied();
        stats.slf_memory_bytes = slf.memory_bytes();
        let light = SlfLight {
            geometry,
            slf: &slf,
        };
        let t = Instant::now();
        let cached = use_cache.then(|| {
            stats.cache_cell = cell;
            self.diffuse_cache(&light, &cells, &mut stats)
        });
        if !use_cache {
            stats.rays_diffuse = stats.valid_pixels as u64 * cfg.diffuse_samples as u64;
        }
        stats.seconds_diffuse = t.elapsed().as_secs_f64();
        let spec_per_pixel: u32 = cfg.specular_samples.iter().sum();
        stats.rays_specular = stats.valid_pixels as u64 * spec_per_pixel as u64;
        let cached = cached.as_ref().map(|c| (&cells, c));
        let pass = (views, scope, cached);
        self.shade_views(&light, pass, &mut stats, progress, sink)?;
        Ok((stats, Some(slf)))
    }

    /// The diffuse moments at a point under the SLF, the sample stream keyed by `key`.
    fn diffuse_at(
        &self,
        light: &SlfLight,
        key: &[u64],
        p: Vec3,
        ng: Vec3,
        ns: Vec3,
    ) -> DiffuseMoments {
        let cfg = &self.config;
        let mut st = SampleStream::new(cfg.sampler, key);
        let mut rng = Pcg32::new(0, 0);
        let full = self.model.diffuse_depends_on_roughness();
        let n = cfg.diffuse_samples;
        diffuse_moments(
            light,
            light.geometry,
            p,
            ng,
            ns,
            n,
            0,
            &mut st,
            &mut rng,
            full,
        )
    }

    /// (Ld0, [Ld1, Ld2]) at one pixel under the SLF, the sample stream keyed by `key`: from the
    /// moments where they express the model, else by the model's basis for the pixel's ωo.
    fn pixel_ld(&self, light: &SlfLight, key: &[u64], rec: &PixelRecord) -> (Rgb, [Rgb; 2]) {
        let model = self.model;
        if moments_express(model) {
            return self
                .diffuse_at(light, key, rec.hit.p, rec.ng, rec.ns)
                .shading(model, rec.wo, rec.ns);
        }
        let cfg = &self.config;
        let mut st = SampleStream::new(cfg.sampler, key);
        let mut rng = Pcg32::new(0, 0);
        let at = (rec.hit.p, rec.ng, rec.ns);
        let n = cfg.diffuse_samples;
        diffuse_direct(
            light,
            light.geometry,
            at,
            rec.wo,
            model,
            n,
            0,
            &mut st,
            &mut rng,
        )
    }

    /// Ld of every diffuse cache cell a view uses.
    fn diffuse_cache(
        &self,
        light: &SlfLight,
        cells: &DiffuseCells,
        stats: &mut BakeStats,
    ) -> CellShading {
        let cfg = &self.config;
        let needed = cells.used();
        stats.cache_entries = needed.iter().filter(|&&n| n).count();
        stats.rays_diffuse = stats.cache_entries as u64 * cfg.diffuse_samples as u64;
        cells.integrate(self.model, |k, c| {
            if !needed[k] {
                return DiffuseMoments::default();
            }
            let key = [cfg.seed, 0xD1FF, c.tri as u64, k as u64];
            self.diffuse_at(light, &key, c.p, c.ng, c.ns)
        })
    }

    /// The shadings of the selected `views` (`pass`: the views, which views and pixels are
    /// computed, the cache's cells and their Ld if cached), one view at a time, each handed to
    /// `sink`.
    fn shade_views(
        &self,
        light: &SlfLight,
        pass: (&[View], Scope, Option<(&DiffuseCells, &CellShading)>),
        stats: &mut BakeStats,
        progress: Progress,
        sink: ViewSink,
    ) -> fipt_core::Result<()> {
        let (views, scope, cached) = pass;
        let (cfg, model, geometry) = (&self.config, self.model, light.geometry);
        let total_work = stats.valid_pixels * 2;
        let done = AtomicUsize::new(0);
        let tick = |n: usize| {
            let d = done.fetch_add(n, Ordering::Relaxed) + n;
            progress(d, total_work);
        };
        for (vi, v) in views
            .iter()
            .enumerate()
            .filter(|(k, _)| scope.shard.contains(*k))
        {
            let mut r = primary_records(geometry, v);
            scope.pixels.clear_undrawn(vi, &mut r);
            let hit = r.iter().flatten().count();
            let mut s = empty_view_shadings(v, &r, cfg.levels, model);
            let t = Instant::now();
            match cached {
                Some((cells, shading)) => cells.scatter_view(shading, model, &r, &mut s),
                None => diffuse_per_pixel(
                    &r,
                    &mut s,
                    |_| false,
                    |i, rec| self.pixel_ld(light, &[cfg.seed, 0xD1FF, vi as u64, i as u64], rec),
                ),
            }
            tick(hit);
            stats.seconds_diffuse += t.elapsed().as_secs_f64();
            let t = Instant::now();
            self.specular_view(light, geometry, vi, &r, &mut s);
            tick(hit);
            stats.seconds_specular += t.elapsed().as_secs_f64();
            sink(vi, s)?;
        }
        Ok(())
    }

    /// Ls0 and Ls1 of one view's pixels, each pixel's sample streams keyed by its view and
    /// pixel index.
    fn specular_view(
        &self,
        light: &SlfLight,
        geometry: &dyn RayQuery,
        vi: usize,
        r: &[Option<PixelRecord>],
        s: &mut ViewShadings,
    ) {
        let cfg = &self.config;
        if cfg.specular_estimator == SpecularEstimator::Mixture {
            let set = SpecularSettings {
                levels: &cfg.levels,
                counts: &cfg.specular_samples,
                n_light: 0,
                sampler: cfg.sampler,
                seed: cfg.seed,
                model: self.model,
            };
            return specular_mixture_view(light, geometry, &set, vi, r, s, &|_| false);
        }
        let seed = cfg.seed;
        let ViewShadings { ls0, ls1, .. } = s;
        ls0.par_iter_mut()
            .zip(ls1.par_iter_mut())
            .zip(r.par_iter())
            .enumerate()
            .with_min_len(64)
            .for_each(|(i, ((l0, l1), rec))| {
                let Some(rec) = rec else { return };
                for l in 0..NUM_LEVELS {
                    let mut st = SampleStream::new(
                        cfg.sampler,
                        &[seed, 0x5BEC, vi as u64, i as u64, l as u64],
                    );
                    (l0[l], l1[l]) = specular_shading(
                        light,
                        rec.hit.p,
                        rec.ng,
                        rec.ns,
                        rec.wo,
                        cfg.levels[l],
                        cfg.specular_samples[l],
                        &mut st,
                        self.model,
                    );
                }
            });
    }
}

impl ShadingBaker for FactorizedBaker {
    fn name(&self) -> &str {
        self.model.component_name("fipt-slf")
    }
    fn caveats(&self) -> Vec<String> {
        crate::diffuse::diffuse_cache_caveat(self.model)
    }
    fn bake(
        &self,
        geometry: &dyn RayQuery,
        views: &[View],
        images: &[Image],
        progress: Progress,
    ) -> fipt_core::Result<Reported<Vec<ViewShadings>>> {
        self.bake_shard(geometry, views, images, Shard::ALL, progress)
    }

    fn bake_shard(
        &self,
        geometry: &dyn RayQuery,
        views: &[View],
        images: &[Image],
        shard: Shard,
        progress: Progress,
    ) -> fipt_core::Result<Reported<Vec<ViewShadings>>> {
        check_counts("bake", views, images)?;
        let (output, stats, _) = self.bake_views(geometry, views, images, shard, progress);
        Ok(Reported {
            output,
            report: serde_json::to_value(stats).unwrap_or_default(),
        })
    }

    fn bake_into(
        &self,
        geometry: &dyn RayQuery,
        views: &[View],
        images: &[Image],
        scope: Scope,
        progress: Progress,
        sink: ViewSink,
    ) -> fipt_core::Result<serde_json::Value> {
        check_counts("bake", views, images)?;
        let (stats, _) = self.bake_streamed(geometry, views, images, scope, progress, sink)?;
        Ok(serde_json::to_value(stats).unwrap_or_default())
    }
}

impl fipt_core::presets::Presets for BakeConfig {
    fn paper() -> Self {
        BakeConfig::paper()
    }
    fn reference() -> Self {
        BakeConfig::reference()
    }
    fn balanced() -> Self {
        BakeConfig::default()
    }
    fn fast() -> Self {
        BakeConfig::fast()
    }
}
