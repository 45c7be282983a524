//! `fipt-ipt`: inverse path tracing (IPT, Azinović et al. 2019) as a method of `fipt run`, the
//! baseline FIPT replaces: the materials and the emission of a scene optimised jointly by
//! gradient descent through a differentiable Monte Carlo path tracer.
//!
//! * **Unknowns** ([`params`]): base colour, roughness and metallic per material group — a
//!   scene part (`IndexMA/`, else a class of `segmentation/`) when the scene has them and
//!   `segments = "auto"`, else a triangle — and emitted radiance per triangle, every triangle
//!   starting dim (nothing says which surfaces emit).
//! * **Gradients** ([`tracer`]): path replay — each path is traced with next-event estimation
//!   to the current emitters and MIS, and differentiated with its sampled directions held
//!   fixed. A residual path and an independent gradient path per pixel keep the squared
//!   loss's gradient unbiased.
//! * **Optimiser** ([`optimise`]): Adam on the relative squared error, an exponentially decaying
//!   rate, an L1 prior on emission, the emitter sampler rebuilt from the current power,
//!   checkpoints to resume from.
//! * **Output** ([`Ipt`] implements `fipt_core::fit::MaterialFitter`): the fitted table as a
//!   `MaterialField` and the emitters (seen triangles whose fitted emission makes up at least
//!   `emitter_share` of the radiance observed on them, grouped by shared edges, in groups that
//!   outshine the views' median `emitter_contrast` times), so the run's maps, re-renders,
//!   report and evaluation are those of every method.
//!
//! It plugs into `fipt run` as any method from outside does: [`register`] adds it to a
//! `Components` (the `fipt` binary's are `fipt_cli::components()`).
pub mod config;
pub mod field;
pub mod lights;
pub mod optimise;
pub mod params;
pub mod tracer;

/// The method's name in `[pipeline] method` (and `fipt run --method`).
pub const NAME: &str = "ipt";

/// `components` with the `ipt` method registered; its settings are `[plugins.ipt]`, laid over
/// the preset's ([`IptConfig::preset`]).
pub fn register(components: fipt_pipeline::Components) -> fipt_pipeline::Components {
    use fipt_pipeline::error::RunError;
    components.with_fitter(
        NAME,
        "inverse path tracing: materials per part (or triangle) and emission per triangle optimised jointly through a differentiable path tracer (settings: [plugins.ipt], defaults per preset)",
        Box::new(|v, preset| {
            let base = IptConfig::preset(preset).ok_or_else(|| {
                RunError::invalid(format!(
                    "unknown preset `{preset}` (use one of {})",
                    fipt_pipeline::config::PRESETS
                ))
            })?;
            let config: IptConfig = fipt_pipeline::config::lay_over(base, v.clone())?;
            config.validate().map_err(RunError::invalid)?;
            Ok(Box::new(Ipt { config }))
        }),
    )
}

pub use config::{IptConfig, Segments};
use fipt_core::color::{luminance, Rgb};
use fipt_core::emitter::{EmitSide, Emitter};
use fipt_core::field::Material;
use fipt_core::fit::{FitInputs, Fitted, MaterialFitter};
use fipt_core::presets::Presets;
use fipt_core::shading::Progress;
use fipt_core::CoreError;
use fipt_geom::Mesh;
use glam::Vec3;
use optimise::{Problem, State};
use rayon::prelude::*;
use std::collections::BTreeMap;

/// The IPT method.
pub struct Ipt {
    pub config: IptConfig,
}

/// What the fit prepares from its inputs before optimising.
pub struct Prepared {
    pub mesh: Mesh,
    pub tri_group: Vec<u32>,
    pub groups: usize,
    /// Where the groups came from.
    pub segments: &'static str,
    /// Per emission slot (a side of a triangle, [`params::slot`]): training pixels whose
    /// centre ray sees it, and their summed radiance.
    pub seen: Vec<(u32, Rgb)>,
    /// Per slot: the brightest radiance observed on its pixels, per channel.
    pub observed_max: Vec<Rgb>,
    /// Per slot: whether a training pixel sees it, and the mean radiance seen.
    pub may_emit: Vec<bool>,
    pub observed: Vec<Rgb>,
    /// Per view and pixel: the slot its centre ray sees (u32::MAX: none).
    pub pixel_slots: Vec<Vec<u32>>,
    pub mean_radiance: f32,
    /// Median luminance of the training pixels.
    pub median_luminance: f32,
}

impl Prepared {
    /// What the optimisation loop works on.
    pub fn problem<'a>(&'a self, inp: &'a FitInputs) -> Problem<'a> {
        Problem {
            geometry: inp.geometry,
            mesh: &self.mesh,
            views: inp.views,
            images: inp.images,
            tri_group: &self.tri_group,
            may_emit: &self.may_emit,
            observed: &self.observed,
            pixel_slots: &self.pixel_slots,
            observed_max: &self.observed_max,
            groups: self.groups,
            model: inp.model,
            mean_radiance: self.mean_radiance,
        }
    }
}

impl Ipt {
    /// Groups, observations per triangle and the radiance scale.
    pub fn prepare(&self, inp: &FitInputs) -> fipt_core::Result<Prepared> {
        let mesh = Mesh::from_triangles(inp.positions.to_vec(), None, inp.triangles.to_vec());
        if mesh.triangles.len() != inp.triangles.len() {
            return Err(CoreError::invalid(
                "ipt",
                "the mesh has degenerate triangles (load it through fipt, which drops them)",
            ));
        }
        let nt = mesh.triangles.len();
        // Primary hit of every training pixel's centre: triangle and emission slot.
        let two_sided = self.config.two_sided_emission;
        let hits: Vec<Vec<Option<(u32, u32)>>> = inp
            .views
            .par_iter()
            .map(|v| {
                let c = &v.camera;
                (0..c.width * c.height)
                    .map(|i| {
                        let (o, d) = c.pixel_center_ray(i % c.width, i / c.width);
                        inp.geometry
                            .intersect(o, d)
                            .map(|h| (h.tri, params::slot(h.tri, h.ng.dot(d) < 0.0, two_sided)))
                    })
                    .collect()
            })
            .collect();
        let mut seen = vec![(0u32, Vec3::ZERO); 2 * nt];
        let mut observed_max = vec![Vec3::ZERO; 2 * nt];
        let (mut sum, mut count) = (0f64, 0usize);
        let mut votes: Vec<BTreeMap<i64, u32>> = vec![BTreeMap::new(); nt];
        let ids = inp
            .segments
            .filter(|_| self.config.segments == Segments::Auto);
        for (v, view_hits) in hits.iter().enumerate() {
            let img = &inp.images[v].data;
            let view_ids = ids.and_then(|s| s.get(v)).filter(|s| s.len() == img.len());
            for (i, h) in view_hits.iter().enumerate() {
                sum += luminance(img[i]) as f64;
                count += 1;
                let Some((t, slot)) = *h else { continue };
                let s = &mut seen[slot as usize];
                s.0 += 1;
                s.1 += img[i];
                observed_max[slot as usize] = observed_max[slot as usize].max(img[i]);
                if let Some(&id) = view_ids.and_then(|s| s.get(i)).filter(|&&id| id >= 0) {
                    *votes[t as usize].entry(id).or_default() += 1;
                }
            }
        }
        let (tri_group, groups, segments) = if ids.is_some() {
            // The majority id of each triangle's pixels; unseen triangles share one group.
            let labels: Vec<Option<i64>> = votes
                .iter()
                .map(|m| {
                    m.iter()
                        .max_by_key(|(id, n)| (**n, -**id))
                        .map(|(id, _)| *id)
                })
                .collect();
            let mut index: BTreeMap<i64, u32> = BTreeMap::new();
            for l in labels.iter().flatten() {
                let n = index.len() as u32;
                index.entry(*l).or_insert(n);
            }
            let unseen = index.len() as u32;
            let g = labels
                .iter()
                .map(|l| l.map_or(unseen, |l| index[&l]))
                .collect();
            (g, unseen as usize + 1, "parts of the scene's id maps")
        } else {
            ((0..nt as u32).collect(), nt, "triangles")
        };
        let pixel_slots = hits
            .iter()
            .map(|h| h.iter().map(|t| t.map_or(u32::MAX, |t| t.1)).collect())
            .collect();
        let may_emit = seen.iter().map(|s| s.0 > 0).collect();
        let observed = seen
            .iter()
            .map(|&(n, sum)| if n > 0 { sum / n as f32 } else { Vec3::ZERO })
            .collect();
        Ok(Prepared {
            may_emit,
            observed,
            pixel_slots,
            observed_max,
            mesh,
            tri_group,
            groups,
            segments,
            seen,
            mean_radiance: (sum / count.max(1) as f64) as f32,
            median_luminance: fipt_core::image::median_luminance(inp.images),
        })
    }

    /// The settings key a checkpoint must match.
    fn key(&self, prep: &Prepared, inp: &FitInputs) -> String {
        // What only the emitter extraction reads does not change the fit: a rerun with another
        // `emitter_share` or `emitter_contrast` reuses it.
        let mut config = serde_json::to_value(&self.config).unwrap_or_default();
        if let Some(c) = config.as_object_mut() {
            c.remove("emitter_share");
            c.remove("emitter_contrast");
        }
        let v = serde_json::json!({
            "config": config, "model": inp.model, "views": inp.views.len(),
            "groups": prep.groups, "triangles": prep.mesh.triangles.len(),
        });
        fipt_core::fsutil::hash_json(&v)
    }

    /// Optimises up to step `until` (resuming from the checkpoint in `inp.dir` when it is
    /// this fit's); returns the state and the step it resumed at.
    pub fn optimise(
        &self,
        inp: &FitInputs,
        prep: &Prepared,
        until: u32,
        progress: Progress,
    ) -> fipt_core::Result<(State, u32)> {
        self.config
            .validate()
            .map_err(|e| CoreError::invalid("ipt", e))?;
        let problem = prep.problem(inp);
        let key = self.key(prep, inp);
        let fresh = State::initial(&problem, &self.config);
        let mut state = State::load(inp.dir, &key, &fresh)?.unwrap_or(fresh);
        let start = state.iteration;
        optimise::run(
            &problem,
            &self.config,
            &mut state,
            until,
            inp.dir,
            &key,
            progress,
        )?;
        Ok((state, start))
    }

    /// The emitted radiance of triangle `t`: its brighter side's.
    pub fn triangle_emission(state: &State, t: u32) -> Rgb {
        let (a, b) = (
            state.params.emission(2 * t),
            state.params.emission(2 * t + 1),
        );
        if luminance(a) >= luminance(b) {
            a
        } else {
            b
        }
    }

    /// The emitters of a fitted state: triangles with a seen side whose emission is at least
    /// `emitter_share` of the radiance observed on it, grouped by shared edges; a group is a
    /// light when the radiance observed on it is `emitter_contrast` times the views' median
    /// luminance. The radiance of each triangle is its brighter side's; with one radiance per
    /// side, a triangle emits on the sides that pass the share (both when neither alone does).
    pub fn emitters(&self, prep: &Prepared, state: &State) -> (Vec<bool>, Vec<Emitter>) {
        let nt = prep.mesh.triangles.len();
        let slot_emits = |s: usize| {
            let (n, sum) = prep.seen[s];
            let le = luminance(state.params.emission(s as u32));
            n > 0 && le >= self.config.emitter_share * luminance(sum / n as f32) && le > 0.0
        };
        let mut emitting: Vec<bool> = (0..nt)
            .map(|t| slot_emits(2 * t) || slot_emits(2 * t + 1))
            .collect();
        let neighbours = prep.mesh.edge_neighbours();
        let mut done = vec![false; nt];
        let mut lights = vec![];
        for start in 0..nt {
            if !emitting[start] || done[start] {
                continue;
            }
            let (mut stack, mut tris) = (vec![start as u32], vec![]);
            done[start] = true;
            while let Some(t) = stack.pop() {
                tris.push(t);
                for &u in &neighbours[t as usize] {
                    if emitting[u as usize] && !done[u as usize] {
                        done[u as usize] = true;
                        stack.push(u);
                    }
                }
            }
            tris.sort_unstable();
            if !self.bright_enough(prep, &tris) {
                tris.iter().for_each(|&t| emitting[t as usize] = false);
                continue;
            }
            let radiance = tris
                .iter()
                .map(|&t| Self::triangle_emission(state, t))
                .collect();
            let pixels = tris
                .iter()
                .map(|&t| (prep.seen[2 * t as usize].0 + prep.seen[2 * t as usize + 1].0) as usize)
                .sum();
            let sides = tris
                .iter()
                .map(|&t| {
                    let emits = |s: usize| usize::from(slot_emits(s));
                    if self.config.two_sided_emission {
                        EmitSide::Both
                    } else {
                        EmitSide::from_counts(emits(2 * t as usize), emits(2 * t as usize + 1))
                    }
                })
                .collect();
            let m = &prep.mesh;
            if let Some(e) =
                Emitter::from_triangles(&m.positions, &m.triangles, tris, radiance, pixels)
            {
                lights.push(e.with_sides(&m.positions, &m.triangles, sides));
            }
        }
        (emitting, lights)
    }
}

impl Ipt {
    /// Whether the mean radiance observed on `tris` (both sides, per pixel) is at least
    /// `emitter_contrast` times the training views' median luminance.
    fn bright_enough(&self, prep: &Prepared, tris: &[u32]) -> bool {
        let (n, sum) = tris
            .iter()
            .flat_map(|&t| [prep.seen[2 * t as usize], prep.seen[2 * t as usize + 1]])
            .fold((0u64, Vec3::ZERO), |(n, s), (k, x)| (n + k as u64, s + x));
        n > 0 && luminance(sum / n as f32) >= self.config.emitter_contrast * prep.median_luminance
    }
}

impl MaterialFitter for Ipt {
    fn name(&self) -> &str {
        "ipt"
    }
    fn needs_shadings(&self) -> bool {
        false
    }
    fn wants_segments(&self) -> bool {
        self.config.segments == Segments::Auto
    }
    fn fit(&self, inp: &FitInputs, progress: Progress) -> fipt_core::Result<Fitted> {
        let t0 = std::time::Instant::now();
        let prep = self.prepare(inp)?;
        let t_prep = t0.elapsed().as_secs_f64();
        let t1 = std::time::Instant::now();
        let (state, start) = self.optimise(inp, &prep, self.config.iterations, progress)?;
        let secs = t1.elapsed().as_secs_f64();
        let (emitting, emitters) = self.emitters(&prep, &state);
        let p = &state.params;
        let group_materials = (0..prep.groups as u32)
            .map(|g| Material {
                albedo: p.albedo(g),
                roughness: p.roughness(g),
                metallic: p.metallic(g),
            })
            .collect();
        let steps = state.iteration.saturating_sub(start);
        let report = serde_json::json!({
            "method": "ipt",
            "config": self.config,
            "unknowns": { "material_groups": prep.groups, "groups_are": prep.segments,
                          "emitting_triangles": prep.mesh.triangles.len(), "parameters": p.len() },
            "resumed_at_step": start,
            "steps": state.iteration,
            "seconds_prepare": t_prep,
            "seconds_optimise": secs,
            "steps_per_second": if secs > 0.0 { steps as f64 / secs } else { 0.0 },
            "paths_per_second": if secs > 0.0 { 2.0 * steps as f64 * self.config.batch as f64 / secs } else { 0.0 },
            "loss": state.losses,
            "emitter_triangles": emitting.iter().filter(|&&e| e).count(),
        });
        let field = field::IptField {
            locator: field::TriangleLocator::new(&prep.mesh),
            tri_group: prep.tri_group,
            group_materials,
            emitting,
        };
        Ok(Fitted::new(Box::new(field), Some(emitters), report))
    }
}
