//! The specular shadings Ls0/Ls1 at every roughness level from one set of GGX samples
//! (multi-sample MIS over the level lobes), and the half-vector helpers the bake shares.
use crate::stream::SampleStream;
use fipt_core::brdf::Frame;
use fipt_core::color::Rgb;
use fipt_core::reflectance::{ggx_d, schlick_weight, ReflectanceModel};
use fipt_core::rng::Pcg32;
use fipt_core::shading::{RayQuery, NUM_LEVELS};
use fipt_shading::incident::{power_heuristic, IncidentLight, Incoming, Pending};
use glam::{Vec2, Vec3};

/// Reflects `wo` about the half vector `h` (local frame): (local ωi, ωo·h, world ωi), or None
/// when ωi leaves below the shading or geometric surface.
#[inline]
pub(crate) fn reflect_about(
    frame: &Frame,
    ng: Vec3,
    wo: Vec3,
    h: Vec3,
) -> Option<(Vec3, f32, Vec3)> {
    let voh = wo.dot(h);
    if voh <= 0.0 {
        return None;
    }
    let wi = 2.0 * voh * h - wo;
    if wi.z <= 0.0 {
        return None;
    }
    let wi_w = frame.to_world(wi);
    (wi_w.dot(ng) > 0.0).then_some((wi, voh, wi_w))
}

/// Sample a GGX half vector (local frame) for α from `u` (stable tan² form).
#[inline]
pub(crate) fn sample_ggx_h(alpha: f32, u: Vec2) -> Vec3 {
    let tan2 = alpha * alpha * u.x / (1.0 - u.x).max(f32::MIN_POSITIVE);
    let ct = 1.0 / (1.0 + tan2).sqrt();
    let st = (tan2.sqrt() * ct).min(1.0);
    let phi = std::f32::consts::TAU * u.y;
    Vec3::new(st * phi.cos(), st * phi.sin(), ct)
}

/// Ls0/Ls1 at every level at once: `counts[k]` samples from level k's GGX lobe, each sample
/// weighted for every level l by the balance heuristic over the level lobes,
/// Li·D_l·G_l·F·(ωo·h) / ((n·ωo)(n·h)·Σ_k counts_k·D_k(h)); with emitters, `n_light` emitter
/// samples more, the two techniques (GGX mixture, emitters) combined by the power heuristic.
#[allow(clippy::too_many_arguments)]
pub fn specular_shading_mixture<L: IncidentLight>(
    light: &L,
    geometry: &dyn RayQuery,
    p: Vec3,
    ng: Vec3,
    ns: Vec3,
    wo_world: Vec3,
    levels: &[f32; NUM_LEVELS],
    counts: &[u32; NUM_LEVELS],
    n_light: u32,
    streams: &mut [SampleStream; NUM_LEVELS],
    rng: &mut Pcg32,
    model: ReflectanceModel,
) -> ([Rgb; NUM_LEVELS], [Rgb; NUM_LEVELS]) {
    let mut s0 = [Vec3::ZERO; NUM_LEVELS];
    let mut s1 = [Vec3::ZERO; NUM_LEVELS];
    let n_light = if light.has_emitters() { n_light } else { 0 };
    let frame = Frame::from_normal(ns);
    let mut wo = frame.to_local(wo_world);
    if wo.z < 1e-4 {
        wo = Vec3::new(wo.x, wo.y, 1e-4).normalize();
    }
    let origin = geometry.offset(p, ng);
    let alphas: [f32; NUM_LEVELS] = std::array::from_fn(|l| levels[l] * levels[l]);
    let g1o = model.g1_levels(wo.z, levels);
    let nl = n_light as f32;
    let n_brdf = counts.iter().sum::<u32>().max(1) as f32;
    // Adds `li`·(the per-level integrand at wi/h)·`scale` where scale = w/(n·pdf) of the
    // technique; `q` = Σ_k counts_k·pdf_k(ωi) is the GGX mixture's n·pdf in solid angle.
    let mut add = |wi: Vec3, voh: f32, d: &[f32; NUM_LEVELS], li: Rgb, scale: f32| {
        let m = schlick_weight(voh);
        let common = scale / (4.0 * wo.z);
        let g1i = model.g1_levels(wi.z, levels);
        for l in 0..NUM_LEVELS {
            let w = d[l] * g1i[l] * g1o[l] * common;
            s0[l] += li * (w * (1.0 - m));
            s1[l] += li * (w * m);
        }
    };
    let mixture_pdf = |h: Vec3, voh: f32| -> ([f32; NUM_LEVELS], f32) {
        let d: [f32; NUM_LEVELS] = std::array::from_fn(|l| ggx_d(h, alphas[l]));
        let q: f32 = (0..NUM_LEVELS)
            .map(|l| counts[l] as f32 * d[l])
            .sum::<f32>()
            * h.z
            / (4.0 * voh);
        (d, q)
    };
    // One sample in flight: its light is begun (the ray traced, its radiance's memory
    // requested) before the previous sample's is finished and added, so the fetch overlaps the
    // next ray. The samples are added in the order they are drawn, as one at a time would.
    let mut in_flight: Option<(Vec3, Vec3, f32, Pending)> = None;
    let mut settle = |(h, wi, voh, pending): (Vec3, Vec3, f32, Pending), rng: &mut Pcg32| {
        let li = match light.finish(pending, rng) {
            Incoming::Miss => return,
            Incoming::Radiance(l) => (l, 0.0),
            Incoming::Emitter { le, light_pdf } => (le, light_pdf),
        };
        if li.0 == Vec3::ZERO {
            return;
        }
        let (d, q) = mixture_pdf(h, voh);
        if !(q > 0.0) {
            return;
        }
        let w = if n_light > 0 && li.1 > 0.0 {
            power_heuristic(q / n_brdf, li.1)
        } else {
            1.0
        };
        add(wi, voh, &d, li.0, w / q);
    };
    for k in 0..NUM_LEVELS {
        for _ in 0..counts[k] {
            let h = sample_ggx_h(alphas[k], streams[k].next());
            let Some((wi, voh, wi_w)) = reflect_about(&frame, ng, wo, h) else {
                continue;
            };
            let begun = (h, wi, voh, light.begin(origin, wi_w, rng));
            if let Some(previous) = in_flight.replace(begun) {
                settle(previous, rng);
            }
        }
    }
    if let Some(last) = in_flight.take() {
        settle(last, rng);
    }
    for _ in 0..n_light {
        let Some(ls) = light.sample_emitter(origin, rng) else {
            continue;
        };
        let wi = frame.to_local(ls.wi);
        if wi.z <= 0.0 || ls.wi.dot(ng) <= 0.0 {
            continue;
        }
        let h = (wi + wo).normalize();
        let voh = wo.dot(h);
        if !(voh > 0.0) || h.z <= 0.0 {
            continue;
        }
        let (d, q) = mixture_pdf(h, voh);
        let w = power_heuristic(ls.pdf, q / n_brdf);
        add(wi, voh, &d, ls.le, w / (nl * ls.pdf));
    }
    (s0, s1)
}
