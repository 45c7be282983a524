//! The decision for one region from its cost profile: metal or not, and which σ (the rules of
//! [`SearchConfig`]: tolerances, the interior rule, held-out halves, the bands).
use super::{DielectricRule, RegionChoice, RegionProfile, SearchConfig};

/// The `deep_median_gain` rule needs this many pixels in the region (a thousand a half): the
/// halves of smaller ones are too noisy to arbitrate. A 616-pixel patch of `studio-mitsuba`'s
/// diffuse box (σ 1) in a capture-like copy, minimum 0.36 with halves at 0.54 and 1.0, took
/// 0.54 where the lifted rules give 0.71.
const MEDIAN_MIN_PIXELS: usize = 2000;

/// Index of the smallest finite value (None when there is none).
pub(super) fn argmin(v: &[f64]) -> Option<usize> {
    v.iter()
        .enumerate()
        .filter(|(_, c)| c.is_finite())
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map(|(i, _)| i)
}

/// How much a cost curve does worse at candidate `other` than at `own`, relative to `own`
/// (0.02: 2 % worse; a cost of 0 at `own` counts as 1e-30).
pub(super) fn excess(row: &[f64], own: usize, other: usize) -> f64 {
    row[other] / row[own].max(1e-30) - 1.0
}

/// Faint gloss (`one_colour_below`) on the region's one-colour curve: the glossiest σ of the
/// run of candidates around its minimum that cost within `interior_gain` of it (a glossier σ is
/// one the curve rejects by the least gain the search counts as evidence), and the roughest
/// within `interior_tolerance` of σ = 1's excess over the minimum (at most `interior_cap`).
/// None without that curve, when its minimum lies under `interior_sigma` (a mirror-end minimum:
/// a diffuse lobe that is not the data's), or when it is not faint itself (a patch of two
/// colours).
fn one_colour_sigma(p: &RegionProfile, cfg: &SearchConfig) -> Option<(f32, f32)> {
    let c = &p.one_colour;
    let n = p.sigma.len();
    if c.len() != n || n == 0 {
        return None;
    }
    let b = argmin(c)?;
    if p.sigma[b] < cfg.interior_sigma {
        return None;
    }
    let gain = c[n - 1] / c[b] - 1.0;
    // Deep gloss on one colour that a colour per cell does not see is the colour's variation
    // (a patch of two materials, a texture), not a lobe.
    if !(gain < cfg.one_colour_below as f64) {
        return None;
    }
    let admitted = c[b] * (1.0 + cfg.interior_gain as f64);
    let mut glossiest = b;
    while glossiest > 0 && c[glossiest - 1] <= admitted {
        glossiest -= 1;
    }
    let limit = c[b] * (1.0 + (gain * cfg.interior_tolerance as f64).min(cfg.interior_cap as f64));
    let roughest = (b..n).rev().find(|&s| c[s] <= limit).unwrap_or(b);
    Some((p.sigma[glossiest], p.sigma[roughest]))
}

/// Whether the σ each half's profile prefers (at metallic candidate `mi`) is an interior one
/// that beats σ = 1 by `interior_gain` on the other half, or (`held_out_band`) both halves
/// prefer interior σ within the band of each other.
fn holds_out(halves: [&RegionProfile; 2], mi: usize, cfg: &SearchConfig) -> bool {
    let best = |h: &RegionProfile| h.cost.get(mi).and_then(|row| argmin(row));
    let beats_default = (0..2).all(|h| {
        let (fit, test) = (halves[h], halves[1 - h]);
        let (Some(b), Some(other)) = (best(fit), test.cost.get(mi)) else {
            return false;
        };
        let n = other.len();
        // A half's minimum must not lie at the mirror end; it may lie below `interior_sigma`
        // (the whole's minimum is held to that): halves are noisier, and a lacquer at σ 0.12
        // has halves at 0.08 and 0.14 (`docs/bedroom-mitsuba.md`).
        b > 0
            && other[b].is_finite()
            && other[b] > 0.0
            && other[n - 1] / other[b] - 1.0 >= cfg.interior_gain as f64
    });
    beats_default || agrees(halves, mi, cfg)
}

/// The `held_out_band` test: both halves' minima interior, more than the band below the
/// roughest candidate (nearer, they are σ = 1 by the same yardstick: the studio's diffuse
/// box, σ 1, has halves at 0.96–0.98), and within the band of each other.
fn agrees(halves: [&RegionProfile; 2], mi: usize, cfg: &SearchConfig) -> bool {
    let band = cfg.held_out_band;
    let interior = |h: &RegionProfile| {
        let row = h.cost.get(mi)?;
        let b = argmin(row)?;
        let roughest = *h.sigma.last()?;
        (b > 0 && h.sigma[b] < roughest - band).then(|| h.sigma[b])
    };
    match (interior(halves[0]), interior(halves[1])) {
        (Some(a), Some(b)) => band > 0.0 && (a - b).abs() <= band + 1e-6,
        _ => false,
    }
}

/// Whether the halves of the views, whose own minima lie at `a` and `b`, bear the whole's minimum
/// `sigma` out (`dielectric_rule = "minimum"`): one half's minimum lies within `band` of it, and
/// neither lies more than `band` glossier. A glossier half is the pull that noise in the
/// shadings puts on a faint curve, reproduced by one set of views and not the other; a rougher
/// half is a set of views that caught no highlight of the surface, which says nothing against
/// the other's for a glossy minimum (a rough one is hedged: [`split_rough`]); two rougher
/// halves leave the whole's minimum reproduced by neither.
/// `bedroom`'s painted wall (σ 0.45): whole 0.48, halves 0.48 and 1.0 (borne out); the CLI
/// test's walls (0.9): wholes 0.52–0.66, a half at 0.14–0.46 (not); `atelier`'s capture copy's
/// back wall (0.9): whole 0.78, halves 1.0 and 0.96 (not).
fn halves_agree([a, b]: [f32; 2], sigma: f32, band: f32) -> bool {
    let near = |s: f32| (s - sigma).abs() <= band + 1e-6;
    let not_glossier = |s: f32| s >= sigma - band - 1e-6;
    (near(a) || near(b)) && not_glossier(a) && not_glossier(b)
}

/// Whether a dielectric's minimum `sigma`, borne out by its halves `[a, b]`, is one that
/// pose error and noise make (`split_halves_above`): rough, with the halves more than
/// `held_out_band` apart.
fn split_rough([a, b]: [f32; 2], sigma: f32, cfg: &SearchConfig) -> bool {
    cfg.split_halves_above > 0.0
        && sigma >= cfg.split_halves_above - 1e-6
        && (a - b).abs() > cfg.held_out_band + 1e-6
}

/// The `dielectric_rule = "minimum"` answer for a dielectric whose minimum is candidate `b`
/// (σ = 1 `gain` above it; `halves_sigma`: the halves' own minima, when `profiled`): the
/// minimum where the halves bear it out (hedged by [`split_rough`]), the median of the three
/// on a deep curve of a large region (`deep_median_gain`, at least `interior_sigma`); None
/// where the lifted rules decide.
fn minimum_rule(
    p: &RegionProfile,
    b: usize,
    gain: f64,
    profiled: bool,
    halves_sigma: Option<[f32; 2]>,
    cfg: &SearchConfig,
) -> Option<f32> {
    let m = p.sigma[b];
    if cfg.dielectric_rule != DielectricRule::Minimum || m < cfg.interior_sigma {
        return None;
    }
    match halves_sigma {
        _ if !profiled => Some(m),
        Some(h) if halves_agree(h, m, cfg.held_out_band) => Some(if split_rough(h, m, cfg) {
            0.5 * (m + h[0].max(h[1]))
        } else {
            m
        }),
        Some([h0, h1])
            if cfg.deep_median_gain > 0.0
                && gain >= cfg.deep_median_gain as f64
                && p.pixels >= MEDIAN_MIN_PIXELS =>
        {
            Some(median_of_three(m, [h0, h1]).max(cfg.interior_sigma))
        }
        _ => None,
    }
}

/// A dielectric the rules above leave without a target although its minimum lies at the
/// mirror end (under `interior_sigma`) of a deep curve (`deep_median_gain`) of a large region
/// (2,000 pixels), with a half of the views finding a lobe (its minimum at or above
/// `interior_sigma`): the median of its minimum and the halves', no lower than
/// `interior_sigma`. Without a target the training reads such a surface rough: `bedroom`'s
/// lamp pole (σ 0.4; minimum 0.02, halves 0.28 and 0.02) read 0.95, `jpg-kitchen`'s counter
/// (0.2; 0.06, halves 0.40 and 0.06) 0.93. Both halves at the mirror end leave it without one.
fn mirror_end_median(
    p: &RegionProfile,
    b: usize,
    gain: f64,
    halves_sigma: Option<[f32; 2]>,
    cfg: &SearchConfig,
) -> Option<f32> {
    let [h0, h1] = halves_sigma?;
    let m = p.sigma[b];
    (cfg.dielectric_rule == DielectricRule::Minimum
        && m < cfg.interior_sigma
        && h0.max(h1) >= cfg.interior_sigma
        && cfg.deep_median_gain > 0.0
        && gain >= cfg.deep_median_gain as f64
        && p.pixels >= MEDIAN_MIN_PIXELS)
        .then(|| median_of_three(m, [h0, h1]).max(cfg.interior_sigma))
}

/// The median of a minimum and its halves' minima.
fn median_of_three(m: f32, [h0, h1]: [f32; 2]) -> f32 {
    m.max(h0.min(h1)).min(h0.max(h1))
}

/// The σ of a half's minimum at metallic candidate `mi`.
fn half_minimum(h: &RegionProfile, mi: usize) -> Option<f32> {
    h.cost
        .get(mi)
        .and_then(|row| argmin(row))
        .map(|b| h.sigma[b])
}

/// The metallic candidate (an index into `p.metallic`): the dielectric one (`dielectric`)
/// unless another's best cost beats it by `metal_margin`; a region the previous search called
/// metal (`was_metal`) starts from the metal one when the dielectric does not beat it by the
/// margin.
fn metallic_candidate(
    p: &RegionProfile,
    best_cost: &[f64],
    dielectric: usize,
    was_metal: bool,
    cfg: &SearchConfig,
) -> usize {
    let keep = 1.0 - cfg.metal_margin as f64;
    let mut mi = dielectric;
    if was_metal {
        if let Some(k) = p.metallic.iter().position(|&m| m == 1.0) {
            if best_cost[k].is_finite() && best_cost[mi] >= best_cost[k] * keep {
                mi = k;
            }
        }
    }
    for (k, &c) in best_cost.iter().enumerate() {
        let base = best_cost[mi];
        if c.is_finite() && (!base.is_finite() || c < base * keep) {
            mi = k;
        }
    }
    mi
}

/// The decision for one region (see [`SearchConfig`]): metal when its best cost beats the best
/// dielectric one by `metal_margin`; then the roughest σ within the tolerance of the minimum
/// for that metallic (none for a dielectric whose answer is the roughest candidate, unless its
/// minimum lies within `rough_band` of it: then the roughest); a
/// dielectric whose minimum is interior, beats σ = 1 by `interior_gain` and holds out takes the
/// `interior_tolerance` rule instead (with `interior_always` off, only when the first rule
/// left it at σ = 1). A faint dielectric (`one_colour_below`) reads no glossier than its
/// one-colour curve admits, and where these rules leave it without a target it takes that
/// curve's. One still without a target whose interior minimum did not hold out takes the
/// midpoint of the interior rule's σ and the roughest (`hedge_disputed`). No target on too
/// few pixels.
///
/// With `dielectric_rule = "minimum"` (the default) a dielectric whose minimum lies at or above
/// `interior_sigma` and whose halves (when given) bear it out (one half's minimum within
/// `held_out_band` of it, neither more than the band glossier) takes that minimum, whatever the
/// rules above would lift it to (the midpoint of it and the rougher half's where it lies at
/// or above `split_halves_above` and the halves lie more than the band apart); otherwise the
/// rules above decide (noise, not the views, placed its minimum), except on a deep curve
/// (`deep_median_gain`) of a region of 2,000 pixels or more, which takes the median of its
/// minimum and the halves' (no lower than `interior_sigma`).
///
/// `was_metal`: the previous search (on earlier shadings) called this region metal; it stays
/// metal unless the dielectric answer beats it by `metal_margin` (hysteresis: the margin is
/// needed to switch either way, so that a small region's decision does not flip on noise).
///
/// `halves`: the same region profiled on each half of the views, for `held_out`.
pub fn choose(
    p: &RegionProfile,
    cfg: &SearchConfig,
    was_metal: bool,
    halves: Option<[&RegionProfile; 2]>,
) -> RegionChoice {
    let best: Vec<Option<usize>> = p.cost.iter().map(|c| argmin(c)).collect();
    let best_cost: Vec<f64> = best
        .iter()
        .zip(&p.cost)
        .map(|(b, c)| b.map_or(f64::NAN, |i| c[i]))
        .collect();
    let argmin_sigma: Vec<f32> = best
        .iter()
        .map(|b| b.map_or(f32::NAN, |i| p.sigma[i]))
        .collect();
    let dielectric = p.metallic.iter().position(|&m| m == 0.0);
    let default_cost = dielectric
        .and_then(|d| p.cost[d].last().copied())
        .unwrap_or(f64::NAN);
    let fallback = RegionChoice {
        region: p.region,
        pixels: p.pixels,
        roughness: None,
        metallic: None,
        best_cost: best_cost.clone(),
        argmin_sigma: argmin_sigma.clone(),
        default_cost,
        halves_sigma: None,
    };
    if p.pixels < cfg.min_pixels || p.sigma.is_empty() {
        return fallback;
    }
    let mi = metallic_candidate(p, &best_cost, dielectric.unwrap_or(0), was_metal, cfg);
    let Some(b) = best[mi] else {
        return fallback;
    };
    let fallback = RegionChoice {
        halves_sigma: halves.and_then(|h| Some([half_minimum(h[0], mi)?, half_minimum(h[1], mi)?])),
        ..fallback
    };
    let metal = p.metallic[mi] > 0.5;
    let tol = if metal {
        cfg.metal_tolerance
    } else {
        cfg.dielectric_tolerance
    };
    let roughest_within = |tol: f64| {
        let limit = p.cost[mi][b] * (1.0 + tol);
        (b..p.sigma.len())
            .rev()
            .find(|&s| p.cost[mi][s] <= limit)
            .unwrap_or(b)
    };
    let n = p.sigma.len();
    let mut si = roughest_within(tol as f64);
    let gain = p.cost[mi][n - 1] / p.cost[mi][b] - 1.0;
    let interior = !metal
        && (si + 1 == n || cfg.interior_always)
        && p.sigma[b] >= cfg.interior_sigma
        && gain >= cfg.interior_gain as f64;
    let interior_si =
        || roughest_within((gain * cfg.interior_tolerance as f64).min(cfg.interior_cap as f64));
    if interior && (!cfg.held_out || halves.is_some_and(|h| holds_out(h, mi, cfg))) {
        si = interior_si();
    }
    if let Some(sigma) = (!metal)
        .then(|| minimum_rule(p, b, gain, halves.is_some(), fallback.halves_sigma, cfg))
        .flatten()
    {
        return RegionChoice {
            roughness: Some(sigma),
            metallic: Some(p.metallic[mi]),
            ..fallback
        };
    }
    let near_roughest = p.sigma[b] >= p.sigma[n - 1] - cfg.rough_band - 1e-6;
    let rough = !metal && si + 1 == n && cfg.rough_band > 0.0 && near_roughest;
    let mut roughness = (metal || si + 1 < n || rough).then_some(p.sigma[si]);
    if !metal && gain < cfg.one_colour_below as f64 {
        if let Some((glossiest, lifted)) = one_colour_sigma(p, cfg) {
            roughness = Some(roughness.map_or(lifted, |s| s.max(glossiest)));
        }
    }
    if roughness.is_none() && interior && cfg.hedge_disputed && !near_roughest {
        roughness = Some(0.5 * (p.sigma[interior_si()] + p.sigma[n - 1]));
    }
    if roughness.is_none() && !metal {
        roughness = mirror_end_median(p, b, gain, fallback.halves_sigma, cfg);
    }
    RegionChoice {
        roughness,
        metallic: Some(p.metallic[mi]),
        ..fallback
    }
}
