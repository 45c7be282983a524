//! Per-part scores of `fipt eval`: for every object of the scene's part ids (`IndexMA/`), the
//! mean predicted σ and metallic beside the true ones, and the kd and σ PSNR over its pixels.
//! A split's mean σ PSNR can hide a map that is constant; this table shows which surfaces carry
//! the error. Parts are named from the scene's material table (`scene_gt.json` or
//! `scene_parts.json`, whose material index is the part id) when it has one.
use fipt_core::materials::SceneMaterials;
use glam::Vec3;
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Default, Clone, Copy)]
struct Acc {
    /// Valid (non-emitter surface) pixels.
    n: usize,
    /// Of them GT-diffuse (kd is scored there).
    n_kd: usize,
    kd_se: f64,
    /// Sums of the mean over channels of predicted and true kd (bias beside the error).
    kd_pred: f64,
    kd_true: f64,
    sigma_se: f64,
    sigma_pred: f64,
    sigma_true: f64,
    /// Pixels with a metallic map, and the sums of predicted and true metallic over them.
    n_m: usize,
    m_pred: f64,
    m_true: f64,
}

/// One view's maps, as `fipt eval` prepared them: σ already clamped to [0.2, 1], ground truth
/// quantised to 8 bits.
pub struct ViewMaps<'a> {
    pub ids: &'a [i64],
    pub valid: &'a [bool],
    pub diffuse: &'a [bool],
    pub kd: &'a [Vec3],
    pub kd_gt: &'a [Vec3],
    pub sigma: &'a [Vec3],
    pub sigma_gt: &'a [Vec3],
    /// Predicted and true metallic, when the scene has `Metallic/`.
    pub metallic: Option<(&'a [Vec3], &'a [Vec3])>,
}

/// The accumulated per-part sums of a split.
#[derive(Default)]
pub struct PartScores {
    parts: BTreeMap<i64, Acc>,
}

impl PartScores {
    pub fn add(&mut self, v: &ViewMaps) {
        for (i, &id) in v.ids.iter().enumerate() {
            if id < 0 || !v.valid[i] {
                continue;
            }
            let a = self.parts.entry(id).or_default();
            a.n += 1;
            let (s, t) = (f64::from(v.sigma[i].x), f64::from(v.sigma_gt[i].x));
            a.sigma_pred += s;
            a.sigma_true += t;
            a.sigma_se += (s - t) * (s - t);
            if v.diffuse[i] {
                a.n_kd += 1;
                let d = (v.kd[i] - v.kd_gt[i]).as_dvec3();
                a.kd_se += d.length_squared() / 3.0;
                a.kd_pred += f64::from(v.kd[i].element_sum()) / 3.0;
                a.kd_true += f64::from(v.kd_gt[i].element_sum()) / 3.0;
            }
            if let Some((m, mg)) = v.metallic {
                a.n_m += 1;
                a.m_pred += f64::from(m[i].x);
                a.m_true += f64::from(mg[i].x);
            }
        }
    }

    pub fn is_empty(&self) -> bool {
        self.parts.is_empty()
    }

    /// One row per part: id, name, share of the split's scored pixels, kd and σ PSNR, mean σ
    /// and metallic predicted and true.
    pub fn to_json(&self, names: &[String]) -> serde_json::Value {
        let total: usize = self.parts.values().map(|a| a.n).sum();
        let db = |se: f64, n: usize| {
            (n > 0).then(|| {
                let mse = (se / n as f64).max(1e-10);
                -10.0 * mse.log10()
            })
        };
        let rows: Vec<serde_json::Value> = self
            .parts
            .iter()
            .map(|(&id, a)| {
                let n = a.n as f64;
                let m = (a.n_m > 0).then(|| (a.m_pred / a.n_m as f64, a.m_true / a.n_m as f64));
                serde_json::json!({
                    "id": id,
                    "name": usize::try_from(id).ok().and_then(|i| names.get(i)),
                    "pixels": a.n,
                    "share": a.n as f64 / total.max(1) as f64,
                    "kd_psnr": db(a.kd_se, a.n_kd),
                    "kd_mean": (a.n_kd > 0).then(|| a.kd_pred / a.n_kd as f64),
                    "kd_true": (a.n_kd > 0).then(|| a.kd_true / a.n_kd as f64),
                    "roughness_psnr": db(a.sigma_se, a.n),
                    "roughness_mean": a.sigma_pred / n,
                    "roughness_true": a.sigma_true / n,
                    "metallic_mean": m.map(|m| m.0),
                    "metallic_true": m.map(|m| m.1),
                })
            })
            .collect();
        serde_json::Value::Array(rows)
    }
}

/// The part names of the scene's material table, by part id; empty when it has none (or it
/// does not parse: names are a convenience, the scores stand without them).
pub fn part_names(scene: &Path) -> Vec<String> {
    SceneMaterials::file_in(scene)
        .and_then(|p| SceneMaterials::read_any(&p).ok())
        .map(|t| t.materials.iter().map(|m| m.name().to_string()).collect())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_are_scored_apart_and_emitters_and_unlabelled_pixels_are_skipped() {
        let ids = [0, 0, 1, 1, -1];
        let valid = [true, true, true, false, true];
        let diffuse = [true, true, false, false, true];
        let kd = [
            Vec3::splat(0.5),
            Vec3::splat(0.5),
            Vec3::ZERO,
            Vec3::ZERO,
            Vec3::ONE,
        ];
        let kd_gt = [
            Vec3::splat(0.5),
            Vec3::splat(0.6),
            Vec3::ZERO,
            Vec3::ONE,
            Vec3::ZERO,
        ];
        let sigma = [Vec3::ONE, Vec3::ONE, Vec3::splat(0.3), Vec3::ONE, Vec3::ONE];
        let sigma_gt = [
            Vec3::splat(0.9),
            Vec3::splat(0.9),
            Vec3::splat(0.3),
            Vec3::splat(0.2),
            Vec3::splat(0.2),
        ];
        let m = [Vec3::ZERO, Vec3::ZERO, Vec3::ONE, Vec3::ZERO, Vec3::ZERO];
        let mut p = PartScores::default();
        p.add(&ViewMaps {
            ids: &ids,
            valid: &valid,
            diffuse: &diffuse,
            kd: &kd,
            kd_gt: &kd_gt,
            sigma: &sigma,
            sigma_gt: &sigma_gt,
            metallic: Some((&m, &m)),
        });
        let rows = p.to_json(&["wall".into()]);
        let rows = rows.as_array().unwrap();
        assert_eq!(rows.len(), 2);
        let (w, b) = (&rows[0], &rows[1]);
        assert_eq!(w["name"], "wall");
        assert!(b["name"].is_null());
        assert_eq!(w["pixels"], 2);
        assert_eq!(b["pixels"], 1);
        // kd: errors 0 and 0.1 → MSE 0.005 → 23.01 dB; σ: 0.1 everywhere → 20 dB.
        assert!((w["kd_psnr"].as_f64().unwrap() - 23.0103).abs() < 1e-3);
        assert!((w["roughness_psnr"].as_f64().unwrap() - 20.0).abs() < 1e-3);
        assert!((w["roughness_mean"].as_f64().unwrap() - 1.0).abs() < 1e-9);
        assert!((w["roughness_true"].as_f64().unwrap() - 0.9).abs() < 1e-6);
        // The metal part has no diffuse pixel: no kd score; σ exact.
        assert!(b["kd_psnr"].is_null());
        assert_eq!(b["metallic_mean"], 1.0);
        assert!(b["roughness_psnr"].as_f64().unwrap() > 90.0);
    }
}
