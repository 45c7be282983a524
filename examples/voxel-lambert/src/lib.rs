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
//!
//! The same table is also a field trainer (`fipt_core::trainer::FieldTrainer`), registered as
//! `voxel-table` ([`trainer::VoxelTrainer`]): FIPT's rounds then bake, search, refine and
//! extract as usual, and fit this table where they would train the neural field.
use fipt_core::color::{luminance, Rgb};
use fipt_core::field::{Material, MaterialField};
use fipt_core::fit::{FitInputs, Fitted, MaterialFitter};
use fipt_core::shading::{Progress, NUM_LEVELS};
use fipt_pipeline::Components;
use glam::Vec3;
use serde::Deserialize;
use std::collections::HashMap;

pub mod trainer;

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
#[derive(serde::Serialize, Deserialize)]
pub struct VoxelField {
    /// The voxels' edge, in world units, or in the unit cube of `frame` when it is given.
    cell: f32,
    /// The cube whose unit coordinates the voxels are laid in (the trainer's: the training
    /// set's positions are unit-cube ones); None: world coordinates.
    frame: Option<fipt_core::cube::Cube>,
    #[serde(with = "voxel_list")]
    voxels: HashMap<Key, (Rgb, f32)>,
    fallback: Rgb,
}

/// The voxel table as a list of (key, albedo, mask) in JSON.
mod voxel_list {
    use super::{Key, Rgb};
    use serde::{Deserialize, Deserializer, Serialize, Serializer};
    use std::collections::HashMap;
    pub fn serialize<S: Serializer>(v: &HashMap<Key, (Rgb, f32)>, s: S) -> Result<S::Ok, S::Error> {
        let mut list: Vec<_> = v.iter().map(|(k, (a, m))| (*k, a.to_array(), *m)).collect();
        list.sort_by_key(|e| e.0);
        list.serialize(s)
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<HashMap<Key, (Rgb, f32)>, D::Error> {
        let list: Vec<(Key, [f32; 3], f32)> = Vec::deserialize(d)?;
        Ok(list
            .into_iter()
            .map(|(k, a, m)| (k, (Rgb::from(a), m)))
            .collect())
    }
}

fn key_of(q: Vec3, cell: f32) -> Key {
    let q = (q / cell).floor();
    (q.x as i32, q.y as i32, q.z as i32)
}

impl VoxelField {
    fn key(&self, p: Vec3) -> Key {
        match &self.frame {
            Some(c) => key_of(Vec3::from(c.unit(p)), self.cell),
            None => key_of(p, self.cell),
        }
    }

    /// The table of the voxels' sums (the fallback: their mean albedo).
    fn from_sums(
        cell: f32,
        frame: Option<fipt_core::cube::Cube>,
        sums: &HashMap<Key, Sums>,
    ) -> Self {
        let mut field = VoxelField {
            cell,
            frame,
            voxels: HashMap::new(),
            fallback: Vec3::splat(0.5),
        };
        let mut mean = Vec3::ZERO;
        for (key, s) in sums {
            let kd = (s.il / s.ll.max(Vec3::splat(1e-12))).clamp(Vec3::ZERO, Vec3::ONE);
            field
                .voxels
                .insert(*key, (kd, s.emitting as f32 / s.n as f32));
            mean += kd;
        }
        if !sums.is_empty() {
            field.fallback = mean / sums.len() as f32;
        }
        field
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

impl Sums {
    /// One pixel: its radiance `img`, its diffuse shading at σ = 1 `ld`, and the luminance of the
    /// most a white surface could reflect there.
    fn add(&mut self, img: Rgb, ld: Rgb, reflectable: f32, emit_ratio: f32) {
        self.il += img * ld;
        self.ll += ld * ld;
        self.emitting += u32::from(luminance(img) > emit_ratio * reflectable);
        self.n += 1;
    }
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
        let mut sums: HashMap<Key, Sums> = HashMap::new();
        for (k, &(v, i, p)) in hits.iter().enumerate() {
            let sh = &shadings[v];
            let img = inp.images[v].data[i];
            let ld = sh.diffuse(i, 1.0);
            let max = |x: &[Rgb; NUM_LEVELS]| x.iter().fold(Vec3::ZERO, |a, b| a.max(*b));
            let reflectable = luminance(ld + max(&sh.ls0[i]) + max(&sh.ls1[i]));
            let s = sums.entry(key_of(p, cell)).or_default();
            s.add(img, ld, reflectable, self.config.emit_ratio);
            if k % 65_536 == 0 {
                progress(k, hits.len());
            }
        }
        let field = VoxelField::from_sums(cell, None, &sums);
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

/// `components` with the `voxel-lambert` method and the `voxel-table` trainer registered.
pub fn register(components: Components) -> Components {
    components
        .with_fitter(
            "voxel-lambert",
            "Lambertian albedo per voxel by least squares on the bake (a baseline; settings: [plugins.voxel-lambert])",
            Box::new(|v, _preset| {
                let config: VoxelLambertConfig = serde_json::from_value(v.clone())?;
                Ok(Box::new(VoxelLambert { config }))
            }),
        )
        .with_trainer(
            trainer::NAME,
            "the voxel-lambert table fitted in FIPT's rounds in place of the neural field (settings: [plugins.voxel-table])",
            Box::new(|v| {
                let config: VoxelLambertConfig = serde_json::from_value(v.clone())?;
                Ok(Box::new(trainer::VoxelTrainer { config }))
            }),
        )
}
