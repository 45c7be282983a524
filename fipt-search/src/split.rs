//! Two finishes in one region. A part can carry two materials whose colours differ (planks of
//! two woods, tiles and their grout, a painted pattern): one σ for the whole part lands between
//! theirs. The search divides such a region in two by the colour of its surface cells when
//! those colours fall in two well-separated groups, profiles each side alone, and keeps the
//! sides' decisions only when they differ; otherwise the region keeps one decision from both
//! sides' pixels together.
//!
//! A cell's colour is its diffuse albedo fitted at σ = 1, m = 0 (the least-squares fit of
//! [`super::profile`]) in log space, so that a dark and a bright finish separate by their
//! ratio. Two groups are "well separated" when 2-means on the cells leaves centres at least
//! `separation` within-group standard deviations apart along the line between them: one
//! Gaussian cloud cut in two gives 2.7, a uniform ramp (a colour gradient the shadings did not
//! explain) 3.5.
use super::{argmin, excess, AlbedoFit, RegionChoice, RegionProfile, SearchPixel};
use fipt_core::image::Image;
use fipt_core::shading::ViewShadings;
use glam::{DVec3, Vec3};
use serde::{Deserialize, Serialize};

/// `[search.split]`: dividing regions by colour, and by gloss (`by_gloss`, [`crate::gloss`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SplitConfig {
    /// Divide regions whose cells fall in two colour groups.
    pub enabled: bool,
    /// Least distance of the two groups' centres in within-group standard deviations (along
    /// the line between them). 3.6 lies above one colour cloud (2.7) and a ramp (3.5); the
    /// planks and the striped wallpaper of `room` measure 3.8–4.0 (their surface cells
    /// straddle the pattern's edges), checkers of two distinct colours 6–8.
    pub separation: f32,
    /// Least share of the region's pixels on each side.
    pub min_share: f32,
    /// The sides keep their own decisions when one is metal and the other is not, or when
    /// their curves' minima lie at least this far apart in σ, on all the views and on each
    /// half of them ([`sides_differ`]).
    pub sigma_gap: f32,
    /// Also divide regions by where the views place their highlights ([`crate::gloss`]): a
    /// change of finish that the colour does not follow (a region the colour leaves whole, or
    /// one whose colour sides are the shallower division).
    pub by_gloss: bool,
    /// The neighbourhood each surface cell reads for the gloss split: the cells within this
    /// many cells of it (a cube of edge `2·r + 1`).
    pub gloss_radius: u32,
    /// Least share of the cells seen in both halves of the views (even, odd) that the cuts
    /// made on each half alone put on the same side. Cuts made by noise agree on about half;
    /// with the edge drawn by a minimum cut, floors of two finishes agree on 60–64 % (`kitchen`,
    /// `bedroom`, 83 % `atelier`) and shading error's cuts on up to 88 %, so the depth decides
    /// (`docs/roughness-rooms.md`, *Finishes outlined by a minimum cut*).
    pub gloss_agreement: f32,
    /// Colour sides keep their own decisions only when each side's profile costs this much
    /// more at the other side's σ than at its own ([`sides_differ`]): `atelier`'s rug, one
    /// finish in two colours, 1.4–1.9 %; floors of two finishes 41–161 %. With
    /// `gloss_view_means` off, a gloss cut's sides are asked it too (the rule before
    /// 2026-12-07 is `gloss_view_means = false`, `gloss_cut_depth = 0.25`: per pixel, floors
    /// measured 15.6–149 % and every other cut at most 17 %).
    pub gloss_depth: f32,
    /// The gloss split's cell curves take each view's pixels of a cell together (the squared
    /// difference of their mean and their mean prediction, times their count) rather than
    /// pixel by pixel: the pixels' own noise, which made most of a floor's cost, averages out,
    /// so a cut's depth says how much the finishes differ, not how noisy the views are
    /// (`kitchen`'s floor measured 25.1 % per pixel and 17.3 % in the same room rendered with
    /// every bounce, whose views are noisier; per view, 257 % and 166 %).
    pub gloss_view_means: bool,
    /// Least relative excess of each side's pooled cell curve at the other side's σ for a
    /// gloss cut to divide its region, and for a colour division to stand against it (on the
    /// curves `gloss_view_means` says). Per view, floors of two finishes measured 143–406 %,
    /// and every other cut of five Mitsuba rooms and a capture copy at most 32 %
    /// (`docs/gloss-cut-noise.md`).
    pub gloss_cut_depth: f32,
    /// The price of the edge between two finishes in the gloss split: each pair of adjacent
    /// cells on different sides costs this many times the median of the region's cells'
    /// preference for one side ([`crate::gloss`]); 0 labels every cell by its own curve.
    pub gloss_smoothness: f32,
}

impl Default for SplitConfig {
    fn default() -> Self {
        SplitConfig {
            enabled: true,
            separation: 3.6,
            min_share: 0.15,
            sigma_gap: 0.1,
            by_gloss: true,
            gloss_radius: 3,
            gloss_agreement: 0.55,
            gloss_depth: 0.25,
            gloss_view_means: true,
            gloss_cut_depth: 0.6,
            gloss_smoothness: 0.5,
        }
    }
}

impl SplitConfig {
    /// Range checks, naming the key.
    pub fn validate(&self) -> Result<(), String> {
        let bad =
            |key: &str, v: f32, range: &str| Err(format!("search.split.{key} = {v} (use {range})"));
        if !(self.separation >= 0.0 && self.separation <= 1e3) {
            return bad("separation", self.separation, "[0, 1000]");
        }
        if !(self.min_share > 0.0 && self.min_share <= 0.5) {
            return bad("min_share", self.min_share, "(0, 0.5]");
        }
        if !(self.sigma_gap >= 0.0 && self.sigma_gap <= 1.0) {
            return bad("sigma_gap", self.sigma_gap, "[0, 1]");
        }
        if self.gloss_radius > 8 {
            return bad("gloss_radius", self.gloss_radius as f32, "0 … 8");
        }
        if !(self.gloss_agreement >= 0.5 && self.gloss_agreement <= 1.0) {
            return bad("gloss_agreement", self.gloss_agreement, "[0.5, 1]");
        }
        if !(self.gloss_depth >= 0.0 && self.gloss_depth <= 10.0) {
            return bad("gloss_depth", self.gloss_depth, "[0, 10]");
        }
        if !(self.gloss_cut_depth >= 0.0 && self.gloss_cut_depth <= 10.0) {
            return bad("gloss_cut_depth", self.gloss_cut_depth, "[0, 10]");
        }
        if !(self.gloss_smoothness >= 0.0 && self.gloss_smoothness <= 100.0) {
            return bad("gloss_smoothness", self.gloss_smoothness, "[0, 100]");
        }
        Ok(())
    }
}

/// How regions divide: `side[cell]` is 0 or 1, and `sub[region]` the id of the region's second
/// side (numbered after the regions), None for a region that stays whole;
/// `deep_per_view[region]` says that its division measured at least
/// [`SplitConfig::gloss_cut_depth`] on the gloss split's cell curves ([`crate::gloss`]; each
/// view's pixels together with `gloss_view_means`, and only then read): a gloss cut that
/// divided, or a colour division that stood against a gloss cut for being that deep (missing:
/// false).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ColourSplit {
    pub sub: Vec<Option<u32>>,
    pub side: Vec<u8>,
    pub deep_per_view: Vec<bool>,
}

impl ColourSplit {
    /// No region divides.
    pub fn none(regions: usize) -> Self {
        ColourSplit {
            sub: vec![None; regions],
            side: vec![],
            deep_per_view: vec![],
        }
    }

    /// How many regions there are with the second sides.
    pub fn regions(&self) -> usize {
        self.sub.len() + self.sub.iter().flatten().count()
    }

    /// The region a pixel of `region` in `cell` belongs to.
    pub fn region_of(&self, region: u32, cell: u32) -> u32 {
        match self.sub.get(region as usize).copied().flatten() {
            Some(s) if self.side.get(cell as usize) == Some(&1) => s,
            _ => region,
        }
    }

    /// `pixels` with their regions divided.
    pub fn apply(&self, pixels: &[SearchPixel]) -> Vec<SearchPixel> {
        pixels
            .iter()
            .map(|p| SearchPixel {
                region: self.region_of(p.region, p.cell),
                ..*p
            })
            .collect()
    }
}

/// Per surface cell: its region, pixel count and log diffuse albedo (σ = 1, m = 0).
fn cell_colours(
    pixels: &[SearchPixel],
    shadings: &[ViewShadings],
    images: &[Image],
) -> Vec<(u32, u32, DVec3)> {
    let cells = pixels
        .iter()
        .map(|p| p.cell as usize + 1)
        .max()
        .unwrap_or(0);
    let mut acc = vec![(u32::MAX, 0u32, AlbedoFit::default()); cells];
    for p in pixels {
        let e = &mut acc[p.cell as usize];
        e.0 = p.region;
        // A clipped pixel (a lower bound) says nothing of the cell's colour.
        e.1 += u32::from(!p.clipped);
        e.2.add(shadings, images, p, 1.0, 0.0);
    }
    acc.into_iter()
        .map(|(r, n, fit)| {
            let a = fit.albedo().clamp(Vec3::splat(1e-3), Vec3::ONE);
            (
                r,
                n,
                DVec3::new(a.x.ln() as f64, a.y.ln() as f64, a.z.ln() as f64),
            )
        })
        .collect()
}

/// Weighted 2-means of `points` (value, weight) started from a cut across their widest
/// direction: each point's side, the two centres' distance in within-group standard
/// deviations along the line between them, and the weight share of side 1.
pub fn two_means(points: &[(DVec3, f64)]) -> Option<(Vec<u8>, f64, f64)> {
    let total: f64 = points.iter().map(|p| p.1).sum();
    if points.len() < 2 || total <= 0.0 {
        return None;
    }
    let mean = points.iter().map(|p| p.0 * p.1).sum::<DVec3>() / total;
    // The widest direction by power iteration on the weighted covariance.
    let mut axis = DVec3::new(1.0, 1.0, 1.0).normalize();
    for _ in 0..30 {
        let next: DVec3 = points
            .iter()
            .map(|&(x, w)| (x - mean) * ((x - mean).dot(axis) * w))
            .sum();
        if next.length_squared() < 1e-30 {
            return None;
        }
        axis = next.normalize();
    }
    let mut side: Vec<u8> = points
        .iter()
        .map(|p| u8::from((p.0 - mean).dot(axis) > 0.0))
        .collect();
    let mut centres = [mean; 2];
    for _ in 0..50 {
        let mut sum = [(DVec3::ZERO, 0.0f64); 2];
        for (p, &s) in points.iter().zip(&side) {
            sum[s as usize].0 += p.0 * p.1;
            sum[s as usize].1 += p.1;
        }
        if sum[0].1 <= 0.0 || sum[1].1 <= 0.0 {
            return None;
        }
        centres = [sum[0].0 / sum[0].1, sum[1].0 / sum[1].1];
        let next: Vec<u8> = points
            .iter()
            .map(|p| u8::from(p.0.distance_squared(centres[1]) < p.0.distance_squared(centres[0])))
            .collect();
        if next == side {
            break;
        }
        side = next;
    }
    let d = centres[1] - centres[0];
    let dist = d.length();
    if dist <= 0.0 {
        return None;
    }
    let u = d / dist;
    let (mut var, mut w1) = (0.0, 0.0);
    for (p, &s) in points.iter().zip(&side) {
        let along = (p.0 - centres[s as usize]).dot(u);
        var += p.1 * along * along;
        w1 += if s == 1 { p.1 } else { 0.0 };
    }
    let sd = (var / total).sqrt();
    let separation = if sd > 0.0 { dist / sd } else { f64::INFINITY };
    Some((side, separation, w1 / total))
}

/// The regions (`0..regions`) whose surface cells fall in two colour groups, each holding at
/// least `cfg.min_share` of the region's pixels and `min_pixels` pixels.
pub fn colour_split(
    pixels: &[SearchPixel],
    shadings: &[ViewShadings],
    images: &[Image],
    regions: usize,
    min_pixels: usize,
    cfg: &SplitConfig,
) -> ColourSplit {
    if !cfg.enabled {
        return ColourSplit::none(regions);
    }
    let cells = cell_colours(pixels, shadings, images);
    let mut by_region: Vec<Vec<usize>> = vec![vec![]; regions];
    for (c, cell) in cells.iter().enumerate() {
        if (cell.0 as usize) < regions && cell.1 > 0 {
            by_region[cell.0 as usize].push(c);
        }
    }
    let mut out = ColourSplit {
        sub: vec![None; regions],
        side: vec![0; cells.len()],
        deep_per_view: vec![],
    };
    let mut next = regions as u32;
    for (r, members) in by_region.iter().enumerate() {
        let points: Vec<(DVec3, f64)> = members
            .iter()
            .map(|&c| (cells[c].2, cells[c].1 as f64))
            .collect();
        let Some((side, separation, share)) = two_means(&points) else {
            continue;
        };
        let n: f64 = points.iter().map(|p| p.1).sum();
        let smaller = share.min(1.0 - share);
        if separation < cfg.separation as f64
            || smaller < cfg.min_share as f64
            || smaller * n < min_pixels as f64
        {
            continue;
        }
        for (&c, &s) in members.iter().zip(&side) {
            out.side[c] = s;
        }
        out.sub[r] = Some(next);
        next += 1;
    }
    out
}

/// The profile of both sides together (`region` keeps `a`'s id): each candidate's mean cost
/// over both sides' pixels. Exact, since every cell lies on one side and fits its own colour.
pub fn merged(a: &RegionProfile, b: &RegionProfile) -> RegionProfile {
    let (na, nb) = (a.pixels as f64, b.pixels as f64);
    let mix = |x: f64, y: f64| match (na > 0.0, nb > 0.0) {
        (true, true) => (na * x + nb * y) / (na + nb),
        (true, false) => x,
        (false, _) => y,
    };
    let rows = |p: &Vec<Vec<f64>>, q: &Vec<Vec<f64>>| -> Vec<Vec<f64>> {
        p.iter()
            .zip(q)
            .map(|(r, s)| r.iter().zip(s).map(|(&x, &y)| mix(x, y)).collect())
            .collect()
    };
    RegionProfile {
        region: a.region,
        pixels: a.pixels + b.pixels,
        cells: a.cells + b.cells,
        sigma: a.sigma.clone(),
        metallic: a.metallic.clone(),
        cost: rows(&a.cost, &b.cost),
        gain: rows(&a.gain, &b.gain),
        one_colour: rows(&vec![a.one_colour.clone()], &vec![b.one_colour.clone()])
            .pop()
            .unwrap_or_default(),
    }
}

/// The cost curve over σ at metallic `m` (None when `m` is not a candidate).
fn cost_row(p: &RegionProfile, m: f32) -> Option<&[f64]> {
    let k = p.metallic.iter().position(|&x| x == m)?;
    p.cost.get(k).map(Vec::as_slice)
}

/// The σ of the lowest cost at metallic `m` (NaN without one).
fn argmin_sigma(p: &RegionProfile, m: f32) -> f32 {
    cost_row(p, m)
        .and_then(argmin)
        .map_or(f32::NAN, |i| p.sigma[i])
}

/// Each side's cost at the other side's minimum (nearest σ candidate, metallic `m`) over its own
/// minimum, minus 1 (0.02: 2 % above): how firmly each side's views reject the other side's σ.
/// None where a side has no finite minimum at `m`.
pub fn crossed(sides: [&RegionProfile; 2], m: f32) -> Option<[f32; 2]> {
    let at = |p: &RegionProfile, s: f32| {
        let row = cost_row(p, m)?;
        let e = excess(row, argmin(row)?, nearest(&p.sigma, s)?) as f32;
        e.is_finite().then_some(e)
    };
    let [a, b] = sides;
    Some([at(a, argmin_sigma(b, m))?, at(b, argmin_sigma(a, m))?])
}

/// The index of the candidate nearest `s` (None for NaN or no candidates).
fn nearest(grid: &[f32], s: f32) -> Option<usize> {
    (0..grid.len())
        .filter(|_| s.is_finite())
        .min_by(|&i, &j| (grid[i] - s).abs().total_cmp(&(grid[j] - s).abs()))
}

/// Whether two sides keep their own decisions `[ca, cb]` (from profiles `[a, b]`): one is metal
/// and the other is not, or their decisions differ and so do their curves' minima, by
/// `sigma_gap`, each side's cost at the other's minimum lies `gloss_depth` above its own
/// ([`crossed`]; not asked of dielectric sides of a division whose depth was measured on
/// each view's pixels together, `depth_measured`: a gloss cut, or a colour division as deep;
/// on the profiles, pixel by pixel, the views' noise decides it),
/// and with `halves` (each side profiled on each half of the views:
/// `halves[side][half]`) the minima differ the same way by half the gap on both halves.
/// Comparing minima, not decisions, keeps a side of weak evidence (whose tolerance rule lands
/// elsewhere) from dividing a region of one finish; the depth keeps a region of one finish and
/// two colours whole, whose sides' minima differ by the colour's bias alone (`atelier`'s rug,
/// σ 0.9: sides at 1.0 and 0.8, each 1.4–1.9 % above its minimum at the other's; floors of
/// two finishes 41–161 %).
pub fn sides_differ(
    sides: [&RegionProfile; 2],
    choices: [&RegionChoice; 2],
    halves: Option<[[&RegionProfile; 2]; 2]>,
    cfg: &SplitConfig,
    depth_measured: bool,
) -> bool {
    let metal = |c: &RegionChoice| c.metallic.is_some_and(|m| m > 0.5);
    if metal(choices[0]) != metal(choices[1]) {
        return true;
    }
    if choices[0].roughness == choices[1].roughness {
        return false;
    }
    let m = choices[0].metallic.unwrap_or(0.0);
    let gap = |a: &RegionProfile, b: &RegionProfile| argmin_sigma(b, m) - argmin_sigma(a, m);
    let whole = gap(sides[0], sides[1]);
    // σ candidates are f32 steps: a gap of exactly `sigma_gap` may come out a rounding below.
    let slack = 1e-4;
    if !(whole.abs() >= cfg.sigma_gap - slack) {
        return false;
    }
    // A division's depth per view was measured at m = 0: metal sides are still asked it here.
    let firm = (depth_measured && m == 0.0)
        || crossed(sides, m).is_some_and(|c| c.iter().all(|&c| c >= cfg.gloss_depth));
    firm && halves.is_none_or(|h| {
        (0..2).all(|k| {
            let g = gap(h[0][k], h[1][k]);
            g * whole.signum() >= 0.5 * cfg.sigma_gap - slack
        })
    })
}

#[cfg(test)]
mod tests {
    use super::super::{choose, profile, Albedo, SearchConfig};
    use super::*;
    use fipt_core::rng::Pcg32;
    use fipt_core::shading::DEFAULT_LEVELS;

    /// One region of two finishes rendered by the factorised model: cells 0–7 a bright base
    /// colour at σ `sigma[0]`, cells 8–15 a dark one at `sigma[1]`.
    fn two_finishes(sigma: [f32; 2]) -> (Vec<SearchPixel>, Vec<ViewShadings>, Vec<Image>) {
        let material = |cell: u32| {
            let side = usize::from(cell >= 8);
            let base = [Vec3::new(0.6, 0.45, 0.3), Vec3::new(0.3, 0.2, 0.12)][side]
                * (1.0 + 0.05 * (cell % 8) as f32 / 8.0);
            (base, sigma[side])
        };
        super::super::tests::rendered(&mut Pcg32::new(5, 9), 0.0, &material)
    }

    #[test]
    fn a_region_of_two_finishes_divides_and_each_side_finds_its_sigma() {
        let grid: Vec<f32> = DEFAULT_LEVELS.to_vec();
        let cfg = SplitConfig::default();
        let search = SearchConfig {
            min_pixels: 1,
            held_out: false,
            ..Default::default()
        };
        for (truth, differ) in [([0.216, 0.804], true), ([0.412, 0.412], false)] {
            let (px, sh, img) = two_finishes(truth);
            let split = colour_split(&px, &sh, &img, 1, 1, &cfg);
            assert_eq!(split.sub, vec![Some(1)], "{truth:?}");
            assert_eq!(split.regions(), 2);
            // The sides are the two finishes, whichever 2-means named first.
            let first = split.side[0];
            assert!(
                (0..16).all(|c| (split.side[c] == first) == (c < 8)),
                "{:?}",
                split.side
            );
            let sides = profile(
                &split.apply(&px),
                &sh,
                &img,
                2,
                &grid,
                &[0.0, 1.0],
                Albedo::Fitted,
            );
            let side_of = |finish: usize| usize::from(split.side[finish * 8] == 1);
            for finish in 0..2 {
                let p = &sides[side_of(finish)];
                assert_eq!(
                    argmin_sigma(p, 0.0),
                    truth[finish],
                    "{truth:?} finish {finish}"
                );
            }
            let choices = [0, 1].map(|k| choose(&sides[k], &search, false, None));
            assert_eq!(
                sides_differ(
                    [&sides[0], &sides[1]],
                    [&choices[0], &choices[1]],
                    None,
                    &cfg,
                    false
                ),
                differ,
                "{truth:?}: {choices:?}"
            );
            // The whole region's curve is the pixel-weighted mean of the sides'.
            let whole = &profile(&px, &sh, &img, 1, &grid, &[0.0, 1.0], Albedo::Fitted)[0];
            let both = merged(&sides[0], &sides[1]);
            for (a, b) in whole.cost.iter().flatten().zip(both.cost.iter().flatten()) {
                assert!((a - b).abs() <= 1e-9 * a.abs().max(1e-12), "{a} vs {b}");
            }
        }
    }

    #[test]
    fn sides_need_the_gap_on_both_halves_of_the_views() {
        let curve = |min_at: usize| RegionProfile {
            region: 0,
            pixels: 1000,
            cells: 10,
            sigma: vec![0.2, 0.4, 0.6, 0.8, 1.0],
            metallic: vec![0.0],
            cost: vec![(0..5)
                .map(|i| 1.0 + (i as f64 - min_at as f64).abs())
                .collect()],
            gain: vec![],
            one_colour: vec![],
        };
        let pick = |s: f32| RegionChoice {
            region: 0,
            pixels: 1000,
            roughness: Some(s),
            metallic: Some(0.0),
            best_cost: vec![],
            argmin_sigma: vec![],
            default_cost: f64::NAN,
            halves_sigma: None,
        };
        let cfg = SplitConfig::default();
        let (a, b) = (curve(1), curve(3));
        let (ca, cb) = (pick(0.4), pick(0.8));
        assert!(sides_differ([&a, &b], [&ca, &cb], None, &cfg, false));
        // Sides that barely reject each other's σ: one decision, unless they are the
        // dielectric sides of a gloss cut whose depth was measured per view; metal sides of
        // one are still asked the depth (the cut measured it at m = 0 only).
        let shallow = |min_at: usize| {
            let row: Vec<f64> = (0..5)
                .map(|i| 1.0 + 0.005 * (i as f64 - min_at as f64).abs())
                .collect();
            RegionProfile {
                metallic: vec![0.0, 1.0],
                cost: vec![row.clone(), row],
                ..curve(min_at)
            }
        };
        let (sa, sb) = (shallow(1), shallow(3));
        assert!(!sides_differ([&sa, &sb], [&ca, &cb], None, &cfg, false));
        assert!(sides_differ([&sa, &sb], [&ca, &cb], None, &cfg, true));
        let metal = |s: f32| RegionChoice {
            metallic: Some(1.0),
            ..pick(s)
        };
        let (ma, mb) = (metal(0.4), metal(0.8));
        assert!(!sides_differ([&sa, &sb], [&ma, &mb], None, &cfg, true));
        // The same on both halves: kept; reversed on one half: not.
        assert!(sides_differ(
            [&a, &b],
            [&ca, &cb],
            Some([[&a, &a], [&b, &b]]),
            &cfg,
            false
        ));
        assert!(!sides_differ(
            [&a, &b],
            [&ca, &cb],
            Some([[&a, &b], [&b, &a]]),
            &cfg,
            false
        ));
        // Minima together, or the same decision: one region.
        assert!(!sides_differ([&a, &a], [&ca, &cb], None, &cfg, false));
        assert!(!sides_differ([&a, &b], [&ca, &ca], None, &cfg, false));
        // A metal side and a dielectric side always keep their own.
        let metal = RegionChoice {
            metallic: Some(1.0),
            ..pick(0.4)
        };
        assert!(sides_differ([&a, &a], [&ca, &metal], None, &cfg, false));
    }

    fn cloud(centre: DVec3, spread: f64, n: usize, seed: u64) -> Vec<(DVec3, f64)> {
        let mut s = seed;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        (0..n)
            .map(|_| {
                // The sum of 4 uniforms: near-Gaussian with sd spread.
                let g = |next: &mut dyn FnMut() -> f64| {
                    (next() + next() + next() + next()) * spread * 3f64.sqrt()
                };
                (
                    centre + DVec3::new(g(&mut next), g(&mut next), g(&mut next)),
                    1.0,
                )
            })
            .collect()
    }

    #[test]
    fn two_groups_separate_and_one_cloud_does_not() {
        // Two finishes 0.35 apart in log albedo with a 0.03 spread: far apart.
        let mut pts = cloud(DVec3::new(-0.6, -1.0, -1.6), 0.03, 300, 1);
        pts.extend(cloud(DVec3::new(-0.9, -1.4, -2.0), 0.03, 200, 2));
        let (side, sep, share) = two_means(&pts).unwrap();
        assert!(sep > 8.0, "separation {sep}");
        assert!(
            (share - 0.4).abs() < 0.01 || (share - 0.6).abs() < 0.01,
            "{share}"
        );
        assert!(side[..300].iter().all(|&s| s == side[0]));
        assert!(side[300..].iter().all(|&s| s != side[0]));
        // One cloud cut in two: about 2.7, below the default 4.
        let one = cloud(DVec3::new(-0.6, -1.0, -1.6), 0.05, 2000, 3);
        let (_, sep, _) = two_means(&one).unwrap();
        assert!((2.0..3.5).contains(&sep), "separation {sep}");
        // A ramp: about 3.5.
        let ramp: Vec<(DVec3, f64)> = (0..1000)
            .map(|i| (DVec3::new(i as f64 / 1000.0, 0.0, 0.0), 1.0))
            .collect();
        let (_, sep, _) = two_means(&ramp).unwrap();
        assert!((3.2..3.8).contains(&sep), "separation {sep}");
        assert!(sep < SplitConfig::default().separation as f64);
        // Identical points never split.
        assert!(two_means(&[(DVec3::ONE, 1.0); 5]).is_none());
    }
}
