//! The settings of the path-grown refinement ([`crate::refine`]) and its presets.
use crate::bake::SamplerKind;
use fipt_core::shading::{PixelDraw, DEFAULT_LEVELS, NUM_LEVELS};
use serde::{Deserialize, Serialize};

/// Settings of the path-grown refinement.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RefineConfig {
    /// Cosine samples for Ld (per diffuse-cache cell). Default 512 (the reference: 128 per
    /// pixel). Ld noise limits kd: on `room`, 512 + 64 emitter samples instead of 128 + 16
    /// raised val kd from 26.7 to 27.9 dB for 32 s more.
    pub diffuse_samples: u32,
    /// GGX samples for Ls0/Ls1 at each level. Default 64 each (the reference's refinement).
    pub specular_samples: [u32; NUM_LEVELS],
    /// Emitter samples per Ld and per Ls estimate at the shading point (0 = none, as the
    /// reference). Default 64.
    pub light_samples: u32,
    /// Roughness above which a secondary hit returns the SLF. Default 0.6.
    pub rough_threshold: f32,
    /// Vertices a path may grow through glossy surfaces. Default 5.
    pub max_bounces: u32,
    /// Roughness levels (must equal the bake's). Default linspace(0.02, 1, 6).
    pub levels: [f32; NUM_LEVELS],
    /// SLF voxels per axis and coarser fallback grids (as the bake's). Defaults 256 and 3.
    pub slf_resolution: u32,
    pub slf_fallback_levels: u32,
    /// Integrate Ld once per surface cell of `cache_cell_scale` pixel footprints. Default true.
    pub diffuse_cache: bool,
    pub cache_cell_scale: f32,
    /// The most the cache's cell edge grows by where a run refines a drawn share of the pixels
    /// (`Scope::pixels`): the edge is `cache_cell_scale` × √(1 / share), at most this many
    /// times, so that a cell holds about as many drawn pixels as a cell of a whole refinement
    /// holds pixels and the diffuse integrals follow the pixels read, not the views. 1: cells
    /// of one size whatever the draw. Default 4. Every pixel drawn: no growth.
    pub cache_cell_growth: f32,
    /// Voxel edge of the material cache, in pixel footprints. Default 2.
    pub material_cell_scale: f32,
    /// "independent" or "stratified" sample directions. Default stratified.
    pub sampler: SamplerKind,
    /// Seed of all random streams. Default 1.
    pub seed: u64,
    /// Leave out of the SLF the pixels within this many pixels of one that sees an emitter
    /// (0: only those). A camera's pixel filter and a renderer's anti-aliasing spread a light
    /// over the pixels around its outline, whose centres lie on the surface beside it: the SLF
    /// would return part of the light's radiance from that surface, on top of the emitter
    /// sampling. Default 1 (the reference: 0): `room`'s val kd +0.6 dB, `studio-mitsuba`
    /// unchanged; 2 gained as much on `room` but cost a 48×36 cornell 3 dB of training kd
    /// (`docs/kd-bias.md`).
    pub slf_light_margin: u32,
}

impl Default for RefineConfig {
    fn default() -> Self {
        RefineConfig {
            diffuse_samples: 512,
            specular_samples: [64; NUM_LEVELS],
            light_samples: 64,
            rough_threshold: 0.6,
            max_bounces: 5,
            levels: DEFAULT_LEVELS,
            slf_resolution: 256,
            slf_fallback_levels: 3,
            diffuse_cache: true,
            cache_cell_scale: 1.0,
            cache_cell_growth: 4.0,
            material_cell_scale: 2.0,
            sampler: SamplerKind::Stratified,
            seed: 1,
            slf_light_margin: 1,
        }
    }
}

impl RefineConfig {
    /// The reference's GGX samples ([64; 6]) with this crate's estimators; Ld keeps 512
    /// samples per cache cell (the reference: 128 per pixel, fewer than `balanced`).
    pub fn paper() -> Self {
        Self::default()
    }
    /// The reference's refinement: per-pixel Ld, independent samples, no light samples at the
    /// shading point, strict SLF.
    pub fn reference() -> Self {
        RefineConfig {
            diffuse_samples: 128,
            light_samples: 0,
            diffuse_cache: false,
            sampler: SamplerKind::Independent,
            slf_fallback_levels: 0,
            slf_light_margin: 0,
            ..Default::default()
        }
    }
    /// Half the GGX samples.
    pub fn balanced() -> Self {
        RefineConfig {
            specular_samples: [32; NUM_LEVELS],
            ..Default::default()
        }
    }
    /// Half the Ld samples, a quarter of the GGX samples, `balanced`'s light samples: with 32
    /// of them the walls' σ minima moved glossier and shallower (`loft-mitsuba`'s right wall,
    /// true 0.85, failed its held-out check and read 0.99; val σ 25.1 dB against `balanced`'s
    /// 29.6), with 64 val σ 29.6 / `studio-mitsuba` 31.3 / `room` 20.7 dB (+4.6, +0.1, +0.9) and
    /// kd +0.1 to +0.6 dB for 9–26 s more refinement (docs/speed-accuracy.md). Doubling the GGX
    /// samples instead changed nothing on `loft-mitsuba`.
    pub fn fast() -> Self {
        RefineConfig {
            diffuse_samples: 256,
            specular_samples: [16; NUM_LEVELS],
            light_samples: 64,
            ..Default::default()
        }
    }

    /// Refuses settings that would exhaust the machine or mean nothing, naming the key.
    pub fn validate(&self) -> Result<(), String> {
        crate::limits::check_shading(
            "refine",
            self.slf_resolution,
            self.slf_fallback_levels,
            self.diffuse_samples,
            &self.specular_samples,
            &self.levels,
            self.cache_cell_scale,
        )?;
        if self.light_samples > crate::limits::MAX_SAMPLES || self.max_bounces > 64 {
            return Err(format!(
                "[refine] light_samples = {}, max_bounces = {}: use at most {} and 64",
                self.light_samples,
                self.max_bounces,
                crate::limits::MAX_SAMPLES
            ));
        }
        if !(self.cache_cell_growth >= 1.0 && self.cache_cell_growth <= 100.0) {
            return Err(format!(
                "[refine] cache_cell_growth = {}: use [1, 100] (1: no growth)",
                self.cache_cell_growth
            ));
        }
        if !(self.material_cell_scale > 0.0 && self.material_cell_scale <= 1e3) {
            return Err(format!(
                "[refine] material_cell_scale = {}: use (0, 1000]",
                self.material_cell_scale
            ));
        }
        Ok(())
    }

    /// The diffuse cache's cell edge in pixel footprints for a refinement of `draw`'s pixels
    /// (see [`RefineConfig::cache_cell_growth`]).
    pub fn cache_cell_for(&self, draw: &PixelDraw) -> f32 {
        let scale = self.cache_cell_scale.max(1e-3);
        if draw.is_all() {
            return scale;
        }
        let growth = (1.0 / draw.share.max(1e-12)).sqrt() as f32;
        scale * growth.clamp(1.0, self.cache_cell_growth.max(1.0))
    }
}
