//! The optimisation loop: batches of training pixels, a residual path and a gradient path per
//! pixel, the relative squared loss, Adam at a decaying rate, the emitter sampler refreshed
//! from the current emission, and a checkpoint to resume from.
use crate::config::IptConfig;
use crate::lights::LightSampler;
use crate::params::{Adam, Params};
use crate::tracer::{accumulate_gradient, trace, TraceScene, Vertex};
use fipt_core::color::{luminance, Rgb};
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::rng::Pcg32;
use fipt_core::shading::{Progress, RayQuery};
use fipt_core::CoreError;
use fipt_geom::Mesh;
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

/// What the loop works on (prepared once per fit).
pub struct Problem<'a> {
    pub geometry: &'a dyn RayQuery,
    pub mesh: &'a Mesh,
    pub views: &'a [View],
    pub images: &'a [Image],
    pub tri_group: &'a [u32],
    /// Per emission slot ([`crate::params::slot`]): whether it may emit (a training pixel
    /// sees it; a light no view sees cannot be told from the surfaces it lights, so the
    /// others stay black).
    pub may_emit: &'a [bool],
    /// Per slot, the mean observed radiance of its pixels (0 unseen).
    pub observed: &'a [Rgb],
    /// Per slot, the brightest radiance observed on its pixels, per channel: no surface
    /// emits more than leaves it.
    pub observed_max: &'a [Rgb],
    /// The slot each training pixel's centre ray sees (u32::MAX: none), per view.
    pub pixel_slots: &'a [Vec<u32>],
    pub groups: usize,
    pub model: ReflectanceModel,
    /// Mean observed luminance of the training pixels (the loss's and the prior's scale).
    pub mean_radiance: f32,
}

/// The optimiser's state: what a checkpoint holds.
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    pub params: Params,
    pub adam: Adam,
    /// Steps done.
    pub iteration: u32,
    /// (step, mean relative squared residual of the batch) every 10 steps.
    pub losses: Vec<(u32, f32)>,
}

/// Slack of the emission bound over the brightest observed pixel (image noise).
const EMISSION_BOUND_SLACK: f32 = 1.25;

const CHECKPOINT: &str = "ipt-state.bin";
const MAGIC: &str = "fipt-ipt-state-1";

impl State {
    pub fn initial(p: &Problem, cfg: &IptConfig) -> State {
        // Every seen side of a triangle starts emitting `init_emission` times the radiance
        // observed on it (nothing says which surfaces emit); the others stay black.
        let mut params = Params::new(
            p.groups,
            p.mesh.triangles.len(),
            cfg.init_albedo,
            cfg.init_roughness,
            1.0,
            cfg.two_sided_emission,
        );
        for (t, &o) in p.observed.iter().enumerate() {
            let i = params.emission_index(t as u32);
            for c in 0..3 {
                params.x[i + c] = if p.may_emit[t] {
                    (cfg.init_emission * o[c]).ln()
                } else {
                    f32::NEG_INFINITY
                };
            }
        }
        params.log_emission_bound = p
            .observed_max
            .iter()
            .flat_map(|m| {
                (*m * EMISSION_BOUND_SLACK)
                    .max(Vec3::splat(1e-30))
                    .to_array()
                    .map(f32::ln)
            })
            .collect();
        params.project();
        let adam = Adam::new(params.len());
        State {
            params,
            adam,
            iteration: 0,
            losses: vec![],
        }
    }

    /// Writes the state into `dir` (one file, written whole then renamed: a kill leaves the
    /// previous checkpoint).
    pub fn save(&self, dir: &Path, key: &str) -> fipt_core::Result<()> {
        let header = serde_json::json!({
            "magic": MAGIC, "key": key, "iteration": self.iteration, "adam_steps": self.adam.t,
            "groups": self.params.groups, "slots": self.params.slots,
            "losses": self.losses,
        });
        let mut bytes = serde_json::to_vec(&header).expect("a JSON value serialises");
        bytes.push(b'\n');
        for v in [&self.params.x, &self.adam.m, &self.adam.v] {
            for x in v.iter() {
                bytes.extend(x.to_le_bytes());
            }
        }
        fipt_core::fsutil::write_bytes_atomic(&dir.join(CHECKPOINT), &bytes)
    }

    /// The checkpoint in `dir` when it was written for `key` and `fresh`'s sizes; None when
    /// there is none or it belongs to other settings (then the fit starts afresh).
    pub fn load(dir: &Path, key: &str, fresh: &State) -> fipt_core::Result<Option<State>> {
        let path = dir.join(CHECKPOINT);
        let Ok(bytes) = std::fs::read(&path) else {
            return Ok(None);
        };
        let corrupt = |why: &str| {
            CoreError::invalid(&path, format!("{why}; delete it to start the fit afresh"))
        };
        let nl = bytes
            .iter()
            .position(|&b| b == b'\n')
            .ok_or_else(|| corrupt("no header"))?;
        let h: serde_json::Value =
            serde_json::from_slice(&bytes[..nl]).map_err(|_| corrupt("unreadable header"))?;
        let n = fresh.params.len();
        let same = h["magic"] == MAGIC
            && h["key"] == key
            && h["groups"] == fresh.params.groups
            && h["slots"] == fresh.params.slots;
        if !same {
            return Ok(None);
        }
        let body = &bytes[nl + 1..];
        if body.len() != 3 * n * 4 {
            return Err(corrupt("truncated"));
        }
        let floats: Vec<f32> = body
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let mut s = fresh.clone();
        s.params.x.copy_from_slice(&floats[..n]);
        s.adam.m.copy_from_slice(&floats[n..2 * n]);
        s.adam.v.copy_from_slice(&floats[2 * n..]);
        s.adam.t = h["adam_steps"]
            .as_u64()
            .ok_or_else(|| corrupt("no adam_steps"))? as u32;
        s.iteration = h["iteration"]
            .as_u64()
            .ok_or_else(|| corrupt("no iteration"))? as u32;
        s.losses = serde_json::from_value(h["losses"].clone()).unwrap_or_default();
        Ok(Some(s))
    }
}

/// The pixel of a flat index over all training views.
struct Pixels {
    /// Start of each view's pixels.
    offsets: Vec<usize>,
}

impl Pixels {
    fn new(views: &[View]) -> Self {
        let mut offsets = vec![0];
        for v in views {
            offsets.push(offsets.last().unwrap() + v.camera.width * v.camera.height);
        }
        Pixels { offsets }
    }
    fn total(&self) -> usize {
        *self.offsets.last().unwrap()
    }
    fn locate(&self, k: usize) -> (usize, usize) {
        let v = self.offsets.partition_point(|&o| o <= k) - 1;
        (v, k - self.offsets[v])
    }
}

/// Each material group's share of the training pixels (their centre rays' triangles).
fn group_shares(p: &Problem) -> Vec<f32> {
    let mut n = vec![0u64; p.groups];
    for &slot in p.pixel_slots.iter().flatten() {
        let group = p.tri_group.get(slot as usize / 2);
        if let Some(c) = group.and_then(|&g| n.get_mut(g as usize)) {
            *c += 1;
        }
    }
    let total = n.iter().sum::<u64>().max(1) as f32;
    n.iter().map(|&k| k as f32 / total).collect()
}

/// Runs steps `state.iteration..until` (saving a checkpoint every `checkpoint_every` steps
/// and at the last); `progress(step, cfg.iterations)`.
pub fn run(
    p: &Problem,
    cfg: &IptConfig,
    state: &mut State,
    until: u32,
    dir: &Path,
    key: &str,
    progress: Progress,
) -> fipt_core::Result<()> {
    let pixels = Pixels::new(p.views);
    if pixels.total() == 0 {
        return Err(CoreError::invalid("ipt", "no training pixels"));
    }
    let eps = 0.05 * p.mean_radiance.max(1e-12);
    let max_rel = cfg.max_relative_residual;
    let batch = cfg.batch as usize;
    let until = until.min(cfg.iterations);
    let share = group_shares(p);
    let mut lights = LightSampler::new(p.mesh, &state.params);
    while state.iteration < until {
        let it = state.iteration;
        if it % cfg.light_update_every == 0 {
            lights = LightSampler::new(p.mesh, &state.params);
        }
        let scene = TraceScene {
            geometry: p.geometry,
            tri_group: p.tri_group,
            model: p.model,
            lights: &lights,
            max_bounces: cfg.max_bounces,
            rr_start: cfg.rr_start,
        };
        let params = &state.params;
        let chunks: Vec<(Vec<(u32, f32)>, f64)> = (0..batch)
            .collect::<Vec<_>>()
            .par_chunks(256)
            .map(|js| {
                let mut grad = Vec::with_capacity(js.len() * 24);
                let mut path: Vec<Vertex> = Vec::with_capacity(8);
                let mut loss = 0f64;
                for &j in js {
                    let keys = |pass: u64| [cfg.seed, it as u64, j as u64, pass];
                    let mut rng = Pcg32::from_keys(&keys(0));
                    let k = ((rng.next_u32() as u64 * pixels.total() as u64) >> 32) as usize;
                    let (v, i) = pixels.locate(k);
                    let cam = &p.views[v].camera;
                    let (x, y) = ((i % cam.width) as f32, (i / cam.width) as f32);
                    let jitter = rng.next_2d();
                    let (o, d) = cam.ray(x + jitter.x, y + jitter.y);
                    let observed = p.images[v].data[i];
                    let l = trace(&scene, params, o, d, &mut rng, &mut path);
                    // The gradient path is independent of the residual's, its point in the
                    // pixel included: a shared point correlates the two at every edge (a
                    // light's edge pixels would pull its radiance down).
                    let mut rng_g = Pcg32::from_keys(&keys(1));
                    let jitter = rng_g.next_2d();
                    let (o, d) = cam.ray(x + jitter.x, y + jitter.y);
                    trace(&scene, params, o, d, &mut rng_g, &mut path);
                    // The relative residual, clamped (one firefly of the residual path must
                    // not steer a step), scaled by the mean radiance observed on the pixel's
                    // triangle side rather than by the pixel's own noisy value.
                    let slot = p.pixel_slots[v][i];
                    let typical = p.observed.get(slot as usize).map_or(0.0, |&o| luminance(o));
                    let scale = 1.0 / (typical + eps);
                    let r: Rgb =
                        ((l - observed) * scale).clamp(Vec3::splat(-max_rel), Vec3::splat(max_rel));
                    if !r.is_finite() {
                        continue;
                    }
                    loss += r.length_squared() as f64;
                    let delta = r * (2.0 * scale / batch as f32);
                    accumulate_gradient(&scene, params, &path, delta, &mut grad);
                }
                (grad, loss)
            })
            .collect();
        let (mut g, loss) = sum_chunks(chunks, state.params.len());
        add_priors(p, cfg, &state.params, &share, eps, &mut g);
        let frac = it as f32 / cfg.iterations.max(1) as f32;
        let lr = cfg.learning_rate * cfg.final_rate_ratio.powf(frac);
        state
            .adam
            .step(&mut state.params, &g, lr, lr * cfg.emission_rate_scale);
        state.iteration += 1;
        if it % 10 == 0 {
            state.losses.push((it, (loss / batch as f64) as f32));
        }
        // Checkpoints fall on steps that rebuild the emitter sampler, so a resumed fit rebuilds
        // the same one.
        if state.iteration % cfg.checkpoint_every == 0 || state.iteration == cfg.iterations {
            state.save(dir, key)?;
        }
        progress(state.iteration as usize, cfg.iterations as usize);
    }
    Ok(())
}

/// The gradient over `n` parameters and the loss, summed over the batch's chunks in order.
fn sum_chunks(chunks: Vec<(Vec<(u32, f32)>, f64)>, n: usize) -> (Vec<f32>, f64) {
    let mut g = vec![0f32; n];
    let mut loss = 0f64;
    for (pairs, l) in chunks {
        loss += l;
        for (i, v) in pairs {
            g[i as usize] += v;
        }
    }
    (g, loss)
}

/// Adds the priors' gradients to `g` and zeroes the emission of slots that may not emit.
fn add_priors(
    p: &Problem,
    cfg: &IptConfig,
    params: &Params,
    share: &[f32],
    eps: f32,
    g: &mut [f32],
) {
    let total_area: f32 = (0..p.mesh.triangles.len()).map(|t| p.mesh.area(t)).sum();
    let lum_w = [Vec3::X, Vec3::Y, Vec3::Z].map(luminance);
    for (t, _) in p.may_emit.iter().enumerate().filter(|(_, &e)| !e) {
        let i = params.emission_index(t as u32);
        g[i..i + 3].fill(0.0);
    }
    // The L1 prior on emission, relative to what each slot shows:
    // λ Σ_s (A_s/A) lum(Le_s) / (observed_s + ε).
    if cfg.emission_prior > 0.0 {
        let s = cfg.emission_prior / total_area.max(1e-20);
        for slot in 0..params.slots as u32 {
            if !p.may_emit[slot as usize] {
                continue;
            }
            let le = params.emission(slot);
            let i = params.emission_index(slot);
            let area = p.mesh.area(slot as usize / 2);
            let a = area * s / (luminance(p.observed[slot as usize]) + eps);
            for c in 0..3 {
                g[i + c] += a * lum_w[c] * le[c];
            }
        }
    }
    // The L1 prior on metallic: λ Σ_g share_g m_g (m ≥ 0).
    if cfg.metallic_prior > 0.0 {
        for (group, &sh) in share.iter().enumerate() {
            g[Params::metallic_index(group as u32)] += cfg.metallic_prior * sh;
        }
    }
}
