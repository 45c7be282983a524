//! A worked example of a plug-in: an emitter extractor that needs no emission mask. A triangle
//! emits when the median luminance of the training pixels that see it reaches `min_luminance`
//! and exceeds the most it could reflect under its baked incident light; triangles sharing a
//! vertex form one light.
//!
//! It implements `fipt_core::emitter::EmitterExtractor` and is registered under the name
//! `brightest` ([`register`]); `src/main.rs` builds a `fipt` binary with it, and a run config
//! chooses it:
//!
//! ```toml
//! [pipeline]
//! extractor = "brightest"
//! [plugins.brightest]
//! min_luminance = 5.0
//! ```
//!
//! Nothing in the fipt crates was edited to add it.
use fipt_core::color::luminance;
use fipt_core::disjoint::DisjointSets;
use fipt_core::emitter::{Emitter, EmitterExtractor, EmitterInputs};
use fipt_pipeline::Components;
use glam::Vec3;
use serde::Deserialize;
use std::collections::HashMap;

/// `[plugins.brightest]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BrightestConfig {
    /// Median luminance a triangle's pixels must reach to emit.
    pub min_luminance: f32,
}

impl Default for BrightestConfig {
    fn default() -> Self {
        BrightestConfig { min_luminance: 5.0 }
    }
}

/// The extractor.
pub struct BrightestExtractor {
    pub config: BrightestConfig,
}

fn median(v: &mut [f32]) -> f32 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

impl EmitterExtractor for BrightestExtractor {
    fn name(&self) -> &str {
        "brightest-pixels"
    }

    fn extract(&self, inp: &EmitterInputs) -> fipt_core::Result<Vec<Emitter>> {
        // Observations per triangle; a pixel that could be reflected light does not count.
        let mut obs: HashMap<u32, Vec<Vec3>> = HashMap::new();
        inp.pixel_hits.visit(&mut |h| {
            let reflectable = h
                .max_reflected
                .is_some_and(|m| luminance(h.radiance) <= luminance(m));
            if !reflectable {
                obs.entry(h.triangle).or_default().push(h.radiance);
            }
        })?;
        let mut lit: Vec<(u32, Vec3, usize)> = obs
            .into_iter()
            .filter_map(|(t, ls)| {
                let mut ch: [Vec<f32>; 3] =
                    std::array::from_fn(|c| ls.iter().map(|l| l[c]).collect());
                let l = Vec3::new(median(&mut ch[0]), median(&mut ch[1]), median(&mut ch[2]));
                (luminance(l) >= self.config.min_luminance).then_some((t, l, ls.len()))
            })
            .collect();
        lit.sort_by_key(|e| e.0);
        // Lights: triangles sharing a vertex index, grouped by a union-find over the lit ones.
        let mut sets = DisjointSets::new(lit.len());
        let mut owner: HashMap<u32, usize> = HashMap::new();
        for (k, (t, _, _)) in lit.iter().enumerate() {
            for v in inp.triangles[*t as usize] {
                if let Some(&j) = owner.get(&v) {
                    sets.union(k, j);
                } else {
                    owner.insert(v, k);
                }
            }
        }
        let mut groups: HashMap<usize, Vec<usize>> = HashMap::new();
        for k in 0..lit.len() {
            groups.entry(sets.find(k)).or_default().push(k);
        }
        let mut roots: Vec<_> = groups.into_iter().collect();
        roots.sort_by_key(|g| g.0);
        Ok(roots
            .into_iter()
            .filter_map(|(_, ks)| {
                Emitter::from_triangles(
                    inp.positions,
                    inp.triangles,
                    ks.iter().map(|&k| lit[k].0).collect(),
                    ks.iter().map(|&k| lit[k].1).collect(),
                    ks.iter().map(|&k| lit[k].2).sum(),
                )
            })
            .collect())
    }
}

/// `components` with the `brightest` extractor registered.
pub fn register(components: Components) -> Components {
    components.with_extractor(
        "brightest",
        "triangles whose pixels' median luminance reaches min_luminance and cannot be reflected light (settings: [plugins.brightest])",
        Box::new(|v| {
            let config: BrightestConfig = serde_json::from_value(v.clone())?;
            Ok(Box::new(BrightestExtractor { config }))
        }),
    )
}
