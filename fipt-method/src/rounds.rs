//! FIPT's refine → search → train rounds after the first training round (method §4.5): the
//! plan (whether they run and why), the loop, and the extra round that lets small scenes
//! settle.
use crate::error::Result;
pub use crate::settings::RoundsConfig;

use crate::shard::Sharding;
use fipt_core::emitter::Emitter;
use fipt_core::shading::ShadingRefiner;
use fipt_shading::records::HitPoint;
use glam::Vec3;

use std::path::Path;

pub use crate::trained::train_dir;

/// The share of a refinement's secondary rays that met surfaces whose light the field's
/// materials decide (grown through glossy or unobserved rough surfaces), from its report
/// (summed over `shards` for a merged sharded refinement); None when the refiner does not
/// report these counts.
pub(crate) fn field_lit_share(stats: &serde_json::Value) -> Option<f64> {
    let n = |k: &str| -> Option<f64> {
        match stats.get("shards").and_then(|s| s.as_array()) {
            Some(shards) => shards.iter().map(|s| s.get(k)?.as_f64()).sum(),
            None => stats.get(k)?.as_f64(),
        }
    };
    let lit = n("secondary_grown")? + n("secondary_unobserved")?;
    let all = lit + n("secondary_slf")? + n("secondary_emitter")? + n("secondary_miss")?;
    (all > 0.0).then(|| lit / all)
}

/// Whether the refinement rounds run (Ok: what they do) or why not (Err).
pub(crate) fn refine_plan(
    cfg: &crate::settings::FiptSettings,
    emitters: &[Emitter],
    glossy: f64,
) -> Result<String, String> {
    if cfg.rounds.refinements == 0 {
        Err("skipped: rounds.refinements = 0".to_string())
    } else if emitters.is_empty() && glossy < 1e-3 {
        Err(format!(
            "skipped: no emitter was found and no observed surface is glossier than σ = {} (path growing and emitter sampling would change nothing)",
            cfg.refine.rough_threshold
        ))
    } else {
        Ok(format!(
            "{} round(s), {}; {} emitter triangles sampled, {:.1} % of the observed surface glossier than σ = {}",
            cfg.rounds.refinements,
            if cfg.rounds.warm_start { "each training round warm-started from the previous" } else { "each training round from fresh networks (as the reference)" },
            emitters.iter().map(|e| e.triangles.len()).sum::<usize>(),
            glossy * 100.0,
            cfg.refine.rough_threshold
        ))
    }
}

/// What the refinement rounds read.
pub(crate) struct RoundsContext<'a> {
    pub(crate) scene: &'a crate::scene::SceneRef<'a>,
    pub(crate) cfg: &'a crate::settings::FiptSettings,
    pub(crate) out: &'a Path,
    pub(crate) force: bool,
    pub(crate) records: &'a [Vec<Option<HitPoint>>],
    pub(crate) footprint: f32,
    pub(crate) emitters: &'a [Emitter],
    /// The hit pixels the run reads of its shadings ([`crate::draw`]).
    pub(crate) draw: fipt_core::shading::PixelDraw,
    pub(crate) has_gt: bool,
    pub(crate) refiner: &'a dyn ShadingRefiner,
    pub(crate) refine_settings: &'a serde_json::Value,
    pub(crate) trainer: fipt_core::fit::MakeTrainer<'a>,
    pub(crate) train_settings: &'a serde_json::Value,
    pub(crate) sharding: Sharding,
}

/// What the refinement rounds update: the field and its manifest, the search's last answer, and
/// the report's lists.
pub(crate) struct Rounds<'a> {
    pub(crate) field: Box<dyn fipt_core::field::MaterialField>,
    pub(crate) train: crate::train::TrainManifest,
    pub(crate) searched: Option<crate::search::Searched>,
    pub(crate) searches: &'a mut Vec<serde_json::Value>,
    pub(crate) closure: &'a mut Vec<serde_json::Value>,
    pub(crate) reports: &'a mut Vec<serde_json::Value>,
}

/// The rounds the scene needs (`refine_plan`: why none, when none) and, when there are any,
/// the rounds run; the plan and the number of rounds done.
pub(crate) fn planned_rounds(
    ctx: &RoundsContext,
    st: &mut Rounds,
    mark: &mut dyn FnMut(&'static str, std::time::Instant),
) -> Result<(std::result::Result<String, String>, u32)> {
    let glossy = glossy_fraction(
        ctx.records,
        st.field.as_ref(),
        ctx.cfg.refine.rough_threshold,
    )?;
    let plan = refine_plan(ctx.cfg, ctx.emitters, glossy);
    let done = match &plan {
        Ok(p) => {
            crate::note!("refinement: {p}");
            refinement_rounds(ctx, st, mark)?
        }
        Err(why) => {
            crate::note!("refinement {why}");
            0
        }
    };
    Ok((plan, done))
}

/// FIPT's refine → search → train rounds (method §4.5).
pub(crate) fn refinement_rounds(
    ctx: &RoundsContext,
    st: &mut Rounds,
    mark: &mut dyn FnMut(&'static str, std::time::Instant),
) -> Result<u32> {
    let cfg = ctx.cfg;
    let mut last = cfg.rounds.refinements;
    let mut r = 0;
    while r < last {
        r += 1;
        let t = crate::observe::begin("refine");
        let refined = crate::refine::stage(
            ctx.scene,
            st.field.as_ref(),
            &st.train.fingerprint(),
            ctx.emitters,
            ctx.refiner,
            ctx.refine_settings,
            &ctx.out.join(format!("refine{r}")),
            ctx.force,
            ctx.sharding,
            ctx.draw,
        )?;
        mark("refine", t);
        if ctx.has_gt {
            st.closure.push(serde_json::json!({
                "shadings": format!("refine{r}"),
                "psnr_db": crate::eval::closure_psnr(ctx.scene, &refined.shadings, &ctx.draw)?,
            }));
        }
        let t = crate::observe::begin("search");
        let when = if r <= cfg.rounds.refinements {
            crate::search::When::Refined
        } else {
            crate::search::When::Settling
        };
        let on = crate::search::SearchOn {
            shadings: &refined.shadings,
            id: &refined.key,
            force: ctx.force,
            seed: cfg.train.seed,
        };
        // The next search reads the previous one's decisions only: its per-pixel targets
        // (4 bytes a pixel of every view) go before the new ones are made.
        if let Some(s) = st.searched.as_mut() {
            s.targets = Default::default();
            s.second_sides = vec![];
        }
        st.searched = crate::search::stage(
            ctx.scene,
            ctx.records,
            on,
            &cfg.search,
            ctx.footprint,
            st.searched.as_ref(),
            when,
        )?;
        if st.searched.is_some() {
            mark("search", t);
        }
        let t = crate::observe::begin("train");
        let prev_id = st.train.fingerprint();
        let settings = round_settings(ctx, st.searched.is_some());
        let trainer = (ctx.trainer)(&settings)?;
        let on = crate::train::TrainOn {
            scene: ctx.scene,
            shadings: &refined.shadings,
            shadings_id: &refined.key,
            set: &cfg.train,
            trainer: trainer.as_ref(),
            settings: &settings,
            search: st.searched.as_ref(),
        };
        let warm = (cfg.rounds.warm_start).then_some((st.field.as_ref(), prev_id.as_str()));
        let must_reuse = !ctx.sharding.shard.is_all();
        let (f, m, _) =
            crate::train::stage(&on, &train_dir(ctx.out, r), ctx.force, warm, must_reuse)?;
        mark("train", t);
        st.searches
            .push(serde_json::json!({ "shadings": format!("refine{r}"), "search": &st.searched }));
        let settle = settle(&cfg.rounds, &refined.stats, r, &mut last);
        st.reports.push(serde_json::json!({
            "round": r,
            "refine": { "seconds": refined.seconds, "stats": refined.stats },
            "train": m,
            "settle": settle,
        }));
        st.field = f;
        st.train = m;
    }
    Ok(r)
}

/// The trainer's settings for a round after a refinement. Without search targets, the regions
/// without a σ target keep the σ pull: the search found no gloss there, and a free σ drifts
/// towards the targets' values through the shared network (on `cornell-metal` without segments
/// the walls went to σ ≈ 0.4). So `rounds.roughness_prior` replaces the trainer's
/// `roughness_prior` setting then (a trainer without that setting keeps its own).
fn round_settings(ctx: &RoundsContext, searched: bool) -> serde_json::Value {
    let mut settings = ctx.train_settings.clone();
    if let (Some(p), false) = (ctx.cfg.rounds.roughness_prior, searched) {
        if let Some(o) = settings.as_object_mut() {
            if o.contains_key("roughness_prior") {
                o.insert("roughness_prior".into(), serde_json::json!(p));
            }
        }
    }
    settings
}

/// After round `r`: whether one more round runs (`last` raised), and why, for the report.
fn settle(
    cfg: &RoundsConfig,
    stats: &serde_json::Value,
    r: u32,
    last: &mut u32,
) -> serde_json::Value {
    let share = field_lit_share(stats);
    let more = r == *last
        && r < cfg.refinements + cfg.settle_rounds
        && share.is_some_and(|s| s > cfg.settle_share as f64);
    if more {
        *last += 1;
        crate::note!(
            "settle: {:.1} % of the refinement's secondary rays met surfaces lit through the field's materials (over rounds.settle_share = {:.0} %): one more round",
            share.unwrap_or(0.0) * 100.0,
            cfg.settle_share * 100.0
        );
    }
    serde_json::json!({ "field_lit_share": share, "another_round": more })
}

/// Fraction of the observed surface (every 7th primary hit of the training views) whose
/// trained roughness is at most `threshold`.
pub(crate) fn glossy_fraction(
    records: &[Vec<Option<HitPoint>>],
    field: &dyn fipt_core::field::MaterialField,
    threshold: f32,
) -> Result<f64> {
    let pts: Vec<Vec3> = records
        .iter()
        .flatten()
        .flatten()
        .step_by(7)
        .map(|r| r.p)
        .collect();
    if pts.is_empty() {
        return Ok(0.0);
    }
    let mats = field.materials(&pts)?;
    Ok(mats.iter().filter(|m| m.roughness <= threshold).count() as f64 / mats.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The share from a refiner's report, from a merged sharded one, and none without counts.
    #[test]
    fn field_lit_share_reads_plain_and_sharded_reports() {
        let one = serde_json::json!({"secondary_grown": 10, "secondary_unobserved": 30,
            "secondary_slf": 50, "secondary_emitter": 10, "secondary_miss": 0});
        assert_eq!(field_lit_share(&one), Some(0.4));
        let merged = serde_json::json!({"shards": [one, one]});
        assert_eq!(field_lit_share(&merged), Some(0.4));
        assert_eq!(field_lit_share(&serde_json::json!({"rays": 3})), None);
    }
}
