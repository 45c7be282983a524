//! A worked example of a method plug-in: the simplest baseline of the ablations, a table of
//! Lambertian albedos on a voxel grid fitted to the initial bake in closed form, in place of
//! FIPT's neural field and its rounds.
//!
//! Per voxel (edge: `cell_footprints` pixel footprints), with I the observed radiance and Ld the
//! baked diffuse shading at σ = 1 of the pixels whose primary hit falls in it:
//! kd = Σ I·Ld / Σ Ld² (least squares, per channel, clamped to [0, 1]), σ = 1, m = 0; the emission
//! mask is the share of the voxel's pixels whose luminance exceeds `emit_ratio` times the most
//! they could reflect (Ld + max Ls0 + max Ls1, a white surface), so the run's emitter extractor
//! finds the lights. It implements `fipt_core::fit::MaterialFitter`, registered as `voxel-lambert`
//! ([`register`]):
//!
//! ```toml
//! [pipeline]
//! method = "voxel-lambert"
//! [plugins.voxel-lambert]
//! cell_footprints = 4.0
//! ```
use fipt_core::color::{luminance, Rgb};
use fipt_core::field::{Material, MaterialField};
use fipt_core::fit::{FitInputs, Fitted, MaterialFitter};
use fipt_core::shading::{Progress, NUM_LEVELS};
use fipt_pipeline::Components;
use glam::Vec3;
use serde::Deserialize;
use std::collections::HashMap;

/// `[plugins.voxel-lambert]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VoxelLambertConfig {
    /// Voxel edge in median pixel footprints.
    pub cell_footprints: f32,
    /// A pixel counts as emitting when its luminance exceeds this many times what it could
    /// reflect.
    pub emit_ratio: f32,
}

impl Default for VoxelLambertConfig {
    fn default() -> Self {
        VoxelLambertConfig {
            cell_footprints: 4.0,
            emit_ratio: 2.0,
        }
    }
}

/// The fitter.
pub struct VoxelLambert {
    pub config: VoxelLambertConfig,
}

type Key = (i32, i32, i32);

/// The fitted field: a voxel table, the mean albedo off the table.
pub struct VoxelField {
    cell: f32,
    voxels: HashMap<Key, (Rgb, f32)>,
    fallback: Rgb,
}

impl VoxelField {
    fn key(&self, p: Vec3) -> Key {
        let q = (p / self.cell).floor();
        (q.x as i32, q.y as i32, q.z as i32)
    }
}

impl MaterialField for VoxelField {
    fn name(&self) -> &str {
        "voxel-lambert-table"
    }
    fn materials(&self, points: &[Vec3]) -> fipt_core::Result<Vec<Material>> {
        Ok(points
            .iter()
            .map(|&p| Material {
                albedo: self.voxels.get(&self.key(p)).map_or(self.fallback, |v| v.0),
                roughness: 1.0,
                metallic: 0.0,
            })
            .collect())
    }
    fn emission_mask(&self, points: &[Vec3]) -> fipt_core::Result<Vec<f32>> {
        Ok(points
            .iter()
            .map(|&p| self.voxels.get(&self.key(p)).map_or(0.0, |v| v.1))
            .collect())
    }
}

#[derive(Default)]
struct Sums {
    il: Rgb,
    ll: Rgb,
    emitting: u32,
    n: u32,
}

impl MaterialFitter for VoxelLambert {
    fn name(&self) -> &str {
        "voxel-lambert"
    }
    fn needs_shadings(&self) -> bool {
        true
    }
    fn fit(&self, inp: &FitInputs, progress: Progress) -> fipt_core::Result<Fitted> {
        let t = std::time::Instant::now();
        let shadings = inp.shadings.ok_or_else(|| {
            fipt_core::CoreError::invalid("voxel-lambert", "needs the initial bake's shadings")
        })?;
        // Primary hits of the pixels with shadings, and the median footprint.
        let mut hits = Vec::new();
        let mut foot = Vec::new();
        for (v, (view, sh)) in inp.views.iter().zip(shadings).enumerate() {
            let cam = &view.camera;
            for i in (0..cam.width * cam.height).filter(|&i| sh.valid[i]) {
                let (o, d) = cam.pixel_center_ray(i % cam.width, i / cam.width);
                if let Some(h) = inp.geometry.intersect(o, d) {
                    foot.push(h.t / cam.fx);
                    hits.push((v, i, h.p));
                }
            }
        }
        foot.sort_by(|a, b| a.total_cmp(b));
        let cell = foot.get(foot.len() / 2).copied().unwrap_or(0.01).max(1e-6)
            * self.config.cell_footprints;
        let mut field = VoxelField {
            cell,
            voxels: HashMap::new(),
            fallback: Vec3::splat(0.5),
        };
        let mut sums: HashMap<Key, Sums> = HashMap::new();
        for (k, &(v, i, p)) in hits.iter().enumerate() {
            let sh = &shadings[v];
            let img = inp.images[v].data[i];
            let ld = sh.diffuse(i, 1.0);
            let max = |x: &[Rgb; NUM_LEVELS]| x.iter().fold(Vec3::ZERO, |a, b| a.max(*b));
            let s = sums.entry(field.key(p)).or_default();
            s.il += img * ld;
            s.ll += ld * ld;
            let reflectable = luminance(ld + max(&sh.ls0[i]) + max(&sh.ls1[i]));
            s.emitting += u32::from(luminance(img) > self.config.emit_ratio * reflectable);
            s.n += 1;
            if k % 65_536 == 0 {
                progress(k, hits.len());
            }
        }
        let mut mean = Vec3::ZERO;
        for (key, s) in &sums {
            let kd = (s.il / s.ll.max(Vec3::splat(1e-12))).clamp(Vec3::ZERO, Vec3::ONE);
            field
                .voxels
                .insert(*key, (kd, s.emitting as f32 / s.n as f32));
            mean += kd;
        }
        if !sums.is_empty() {
            field.fallback = mean / sums.len() as f32;
        }
        progress(hits.len(), hits.len());
        let report = serde_json::json!({
            "voxels": field.voxels.len(),
            "cell": cell,
            "pixels": hits.len(),
            "seconds": t.elapsed().as_secs_f64(),
        });
        Ok(Fitted::new(Box::new(field), None, report))
    }
}

/// `components` with the `voxel-lambert` method registered.
pub fn register(components: Components) -> Components {
    components.with_fitter(
        "voxel-lambert",
        "Lambertian albedo per voxel by least squares on the bake (a baseline; settings: [plugins.voxel-lambert])",
        Box::new(|v, _preset| {
            let config: VoxelLambertConfig = serde_json::from_value(v.clone())?;
            Ok(Box::new(VoxelLambert { config }))
        }),
    )
}
