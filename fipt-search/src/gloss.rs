//! Two finishes of one colour in one region. Tiles of two glazes under one wood pattern, a
//! varnished path worn into a floor: the colour split ([`crate::split`]) cannot see a change of
//! finish that the colour does not follow, yet the views do, in where the highlights fall.
//!
//! Each surface cell's own cost curve over σ (its base colour fitted at every candidate, at
//! m = 0) says which σ its pixels prefer; alone it is noisy, so each cell reads the curves of
//! its neighbours in the same region (a cube of `2·gloss_radius + 1` cells) summed with its own.
//! The cells' preferred σ are cut in two (the weighted 1-D 2-means, exact), each side's pooled
//! curve gives its σ, and the cells are reassigned to the side whose σ their neighbourhood
//! prefers until nothing moves. The cells are then labelled again at the least energy
//! ([`crate::mincut`]): each pays its own curve at its side's σ, and each pair of adjacent
//! cells on two sides pays `gloss_smoothness` times the median of the cells' preferences, so a
//! cell whose own evidence is weak (no view saw a highlight on it) follows its neighbours and
//! the edge between finishes is short; the sides' σ are taken again until neither moves.
//!
//! A cell's curve takes each view's pixels of it together (`gloss_view_means`): the squared
//! difference of their mean and their mean prediction, times their count. Neighbouring pixels
//! see nearly the same light, so what σ changes in them survives the mean while their own
//! noise averages out; pixel by pixel, the noise made most of a floor's cost, and a cut's
//! depth said as much about the views' noise as about the finishes.
//!
//! A region divides when the two sides' σ lie `sigma_gap` apart, the same cut made on each
//! half of the views alone (even, odd) puts at least `gloss_agreement` of the cells both
//! halves saw on the same side (a cut made by noise: about half), and each side's pooled curve
//! costs `gloss_cut_depth` more at the other side's σ than at its own: light the shadings get
//! wrong near a lamp also makes a reproducible cut, but a shallow one. The sides then go
//! through the same guard as a colour split ([`crate::split::sides_differ`]), less the depth
//! on their profiles (made pixel by pixel) when the curves were taken per view and the sides
//! are dielectric. A region the colour divided keeps that division when it is
//! `gloss_cut_depth` deep itself on the same curves (finishes that follow the colour), and
//! otherwise takes the gloss cut when that is the deeper division (a wood checker over tiles
//! of two finishes). A colour division that deep is as firm as a gloss cut: its dielectric
//! sides are not asked the profiles' depth either (`ColourSplit::deep_per_view`).
use super::{argmin, excess, srgb_encoded, AlbedoFit, Observed, SearchPixel};
use crate::split::{ColourSplit, SplitConfig};
use fipt_core::image::Image;
use fipt_core::shading::ViewShadings;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;

/// Which pixels a set of curves reads: all, or one half of the views.
#[derive(Clone, Copy, PartialEq)]
enum Views {
    All,
    Parity(u32),
}

impl Views {
    fn reads(self, p: &SearchPixel) -> bool {
        match self {
            Views::All => true,
            Views::Parity(k) => p.view % 2 == k,
        }
    }
}

/// Per cell (dense id), its cost curve at m = 0 over `grid` (the squared sRGB error of its
/// pixels that `views` reads, summed pixel by pixel or, with `view_means`, view by view as in
/// [`ViewGroups::cost`]; its base colour fitted at each σ), None without such a pixel or where
/// `wanted` says no.
fn cell_curves(
    by_cell: &[Vec<usize>],
    wanted: &[bool],
    pixels: &[SearchPixel],
    shadings: &[ViewShadings],
    images: &[Image],
    grid: &[f32],
    views: Views,
    view_means: bool,
) -> Vec<Option<Vec<f32>>> {
    (by_cell.par_iter().zip(wanted))
        .map(|(members, &wanted)| {
            if !wanted {
                return None;
            }
            let mine: Vec<usize> = (members.iter().copied())
                .filter(|&j| views.reads(&pixels[j]))
                .collect();
            if mine.is_empty() {
                return None;
            }
            let observed: Vec<Observed> = (mine.iter())
                .map(|&j| Observed::of_pixel(&pixels[j], images))
                .collect();
            let mut terms: Vec<(Vec3, Vec3)> = Vec::with_capacity(mine.len());
            // Which view's group each pixel joins does not depend on σ: found once a cell.
            let mut groups = view_means.then(|| ViewGroups::of(&mine, pixels));
            let curve = grid.iter().map(|&sigma| {
                terms.clear();
                terms.extend(mine.iter().map(|&j| {
                    let (v, i) = (pixels[j].view as usize, pixels[j].pixel as usize);
                    super::linear_terms(&shadings[v], i, sigma, 0.0)
                }));
                let mut fit = AlbedoFit::default();
                for (o, &(b, c)) in observed.iter().zip(&terms) {
                    fit.add_terms(o, b, c);
                }
                let a = fit.albedo().clamp(Vec3::ZERO, Vec3::ONE);
                if let Some(g) = groups.as_mut() {
                    return g.cost(&observed, &terms, a) as f32;
                }
                let cost: f64 = (observed.iter().zip(&terms))
                    .map(|(o, &(b, c))| o.sq_err(a * b + c))
                    .sum();
                cost as f32
            });
            Some(curve.collect())
        })
        .collect()
}

/// A cell's pixels grouped by view for [`ViewGroups::cost`]: each unclipped pixel's group
/// (numbered in order of first appearance), None for a clipped one, and each group's count.
struct ViewGroups {
    of: Vec<Option<usize>>,
    count: Vec<f64>,
    /// Per group, the sums of the pixels' sRGB values and of their predictions (reused).
    sums: Vec<(glam::DVec3, glam::DVec3)>,
}

impl ViewGroups {
    fn of(mine: &[usize], pixels: &[SearchPixel]) -> Self {
        let mut views: Vec<u32> = vec![];
        let mut count: Vec<f64> = vec![];
        let of = (mine.iter())
            .map(|&j| {
                let p = &pixels[j];
                if p.clipped {
                    return None;
                }
                let g = match views.iter().rposition(|&v| v == p.view) {
                    Some(g) => g,
                    None => {
                        views.push(p.view);
                        count.push(0.0);
                        views.len() - 1
                    }
                };
                count[g] += 1.0;
                Some(g)
            })
            .collect();
        let sums = vec![Default::default(); count.len()];
        ViewGroups { of, count, sums }
    }

    /// The cost of the cell's pixels with each view's unclipped pixels taken together: the
    /// squared difference of their mean sRGB value and their mean predicted one, times their
    /// count (clipped pixels alone, as lower bounds); `a`: the base colour.
    fn cost(&mut self, observed: &[Observed], terms: &[(Vec3, Vec3)], a: Vec3) -> f64 {
        self.sums.fill(Default::default());
        let mut cost = 0.0;
        for ((g, o), &(b, c)) in self.of.iter().zip(observed).zip(terms) {
            let pred = a * b + c;
            match *g {
                None => cost += o.sq_err(pred),
                Some(g) => {
                    let s = &mut self.sums[g];
                    s.0 += o.encoded().as_dvec3();
                    s.1 += srgb_encoded(pred).as_dvec3();
                }
            }
        }
        for (&n, (so, sp)) in self.count.iter().zip(&self.sums) {
            let d = (*so - *sp) / n;
            cost += n * d.length_squared();
        }
        cost
    }
}

/// One region's cells: their ids, voxels and pixel counts, and the neighbours of each (the
/// cells of the region within `radius` voxels, itself included).
struct RegionCells {
    ids: Vec<usize>,
    weight: Vec<f64>,
    neighbours: Vec<Vec<usize>>,
    /// The neighbours within one cell: the edge between two finishes is drawn with these.
    adjacent: Vec<Vec<usize>>,
}

impl RegionCells {
    fn new(ids: Vec<usize>, voxels: &[[i32; 3]], by_cell: &[Vec<usize>], radius: i32) -> Self {
        let at: HashMap<[i32; 3], usize> = (ids.iter().enumerate())
            .map(|(k, &c)| (voxels[c], k))
            .collect();
        let neighbours = (ids.iter())
            .map(|&c| {
                let [x, y, z] = voxels[c];
                let mut near = vec![];
                for dx in -radius..=radius {
                    for dy in -radius..=radius {
                        for dz in -radius..=radius {
                            if let Some(&k) = at.get(&[x + dx, y + dy, z + dz]) {
                                near.push(k);
                            }
                        }
                    }
                }
                near
            })
            .collect();
        let weight = ids.iter().map(|&c| by_cell[c].len() as f64).collect();
        let adjacent = (ids.iter().zip(&neighbours))
            .map(|(&c, near): (&usize, &Vec<usize>)| {
                let at = voxels[c];
                (near.iter().copied())
                    .filter(|&k| (0..3).all(|d| (voxels[ids[k]][d] - at[d]).abs() <= 1))
                    .collect()
            })
            .collect();
        RegionCells {
            ids,
            weight,
            neighbours,
            adjacent,
        }
    }
}

/// A cut of one region's cells into a glossier side (0) and a rougher one (1): each cell's
/// side (None: no curve), and each side's σ index.
struct Cut {
    side: Vec<Option<u8>>,
    sigma: [usize; 2],
    /// How much worse each side's pooled curve does at the other side's σ than at its own
    /// (relative), the smaller of the two.
    depth: f64,
}

/// The weighted 1-D 2-means threshold of `values` (value, weight): the cut between two
/// distinct values with the largest between-side variance; None when all are equal.
fn threshold(values: &mut [(usize, f64)]) -> Option<usize> {
    values.sort_unstable_by_key(|v| v.0);
    let total: f64 = values.iter().map(|v| v.1).sum();
    let sum: f64 = values.iter().map(|v| v.0 as f64 * v.1).sum();
    let (mut w0, mut s0, mut best) = (0.0, 0.0, None::<(f64, usize)>);
    for k in 0..values.len().saturating_sub(1) {
        w0 += values[k].1;
        s0 += values[k].0 as f64 * values[k].1;
        if values[k].0 == values[k + 1].0 || w0 <= 0.0 || total - w0 <= 0.0 {
            continue;
        }
        let (m0, m1) = (s0 / w0, (sum - s0) / (total - w0));
        let between = w0 * (total - w0) * (m1 - m0) * (m1 - m0);
        if best.is_none_or(|b| between > b.0) {
            best = Some((between, values[k].0));
        }
    }
    best.map(|b| b.1)
}

/// The cut of a region's cells from one set of curves (see the module).
fn cut(cells: &RegionCells, curves: &[Option<Vec<f32>>], smoothness: f32) -> Option<Cut> {
    let smoothed = smooth(cells, curves, &cells.neighbours);
    let own = |k: usize| curves[cells.ids[k]].as_ref();
    // Each cell's preferred σ (None without a curve of its own).
    let preferred: Vec<Option<usize>> = (0..cells.ids.len())
        .map(|k| {
            own(k)?;
            argmin(smoothed[k].as_ref()?)
        })
        .collect();
    let mut local: Vec<(usize, f64)> = (preferred.iter().zip(&cells.weight))
        .filter_map(|(p, &w)| Some(((*p)?, w)))
        .collect();
    let t = threshold(&mut local)?;
    let mut side: Vec<Option<u8>> = preferred
        .iter()
        .map(|p| Some(u8::from((*p)? > t)))
        .collect();
    let mut sigma = [0usize; 2];
    for _ in 0..8 {
        let next = [0, 1].map(|k| pooled(cells, curves, &side, k).as_deref().and_then(argmin));
        let [Some(a), Some(b)] = next else {
            return None;
        };
        if a >= b {
            return None;
        }
        let moved: Vec<Option<u8>> = (0..side.len())
            .map(|k| {
                own(k)?;
                let s = smoothed[k].as_ref()?;
                Some(u8::from(s[b] < s[a]))
            })
            .collect();
        let stable = moved == side && [a, b] == sigma;
        (side, sigma) = (moved, [a, b]);
        if stable {
            break;
        }
    }
    // The neighbourhoods found the two finishes; the cells are then labelled by their own
    // curves with a price on the outline (a minimum cut), and each side's σ taken again from
    // its pooled curve, until neither moves.
    for _ in 0..8 {
        let labelled = outlined(cells, curves, sigma, smoothness);
        let next = [0, 1].map(|k| {
            pooled(cells, curves, &labelled, k)
                .as_deref()
                .and_then(argmin)
        });
        let [Some(a), Some(b)] = next else {
            return None;
        };
        if a >= b {
            return None;
        }
        // The labels follow from σ alone: an unchanged σ would label the cells the same.
        let stable = [a, b] == sigma;
        (side, sigma) = (labelled, [a, b]);
        if stable {
            break;
        }
    }
    let depth = depth(cells, curves, &side)?;
    Some(Cut { side, sigma, depth })
}

/// Each cell's side at the two σ (indices) by a minimum cut: a cell pays its own curve at its
/// side's σ, and each pair of adjacent cells on different sides pays `smoothness` times the
/// median of the cells' preferences (|curve at one σ − at the other|), so that a cell whose
/// own evidence is weak follows its neighbours and the edge between finishes is short.
fn outlined(
    cells: &RegionCells,
    curves: &[Option<Vec<f32>>],
    [a, b]: [usize; 2],
    smoothness: f32,
) -> Vec<Option<u8>> {
    let (nodes, cost): (Vec<usize>, Vec<[f64; 2]>) = (0..cells.ids.len())
        .filter_map(|k| {
            let c = curves[cells.ids[k]].as_ref()?;
            Some((k, [c[a] as f64, c[b] as f64]))
        })
        .unzip();
    let mut node = vec![usize::MAX; cells.ids.len()];
    for (i, &k) in nodes.iter().enumerate() {
        node[k] = i;
    }
    let mut preference: Vec<f64> = cost.iter().map(|c| (c[0] - c[1]).abs()).collect();
    let weight = smoothness as f64 * median(&mut preference);
    let mut edges = vec![];
    for (i, &k) in nodes.iter().enumerate() {
        for &n in &cells.adjacent[k] {
            if node[n] != usize::MAX && node[n] > i {
                edges.push((i, node[n], weight));
            }
        }
    }
    let labels = crate::mincut::two_labels(&cost, &edges);
    let mut side = vec![None; cells.ids.len()];
    for (&k, &l) in nodes.iter().zip(&labels) {
        side[k] = Some(u8::from(l));
    }
    side
}

/// The median of `values` (reordered; 0 when empty).
fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mid = values.len() / 2;
    *values.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// The sum of the curves of `cells` (indices into the region's cells); None without one.
fn summed(
    region: &RegionCells,
    curves: &[Option<Vec<f32>>],
    cells: impl Iterator<Item = usize>,
) -> Option<Vec<f64>> {
    let mut acc: Option<Vec<f64>> = None;
    for k in cells {
        let Some(c) = &curves[region.ids[k]] else {
            continue;
        };
        let a = acc.get_or_insert_with(|| vec![0.0; c.len()]);
        for (x, &y) in a.iter_mut().zip(c) {
            *x += y as f64;
        }
    }
    acc
}

/// Each cell's curve summed with those of its `near` cells.
fn smooth(
    cells: &RegionCells,
    curves: &[Option<Vec<f32>>],
    near: &[Vec<usize>],
) -> Vec<Option<Vec<f64>>> {
    (near.iter())
        .map(|near| summed(cells, curves, near.iter().copied()))
        .collect()
}

/// The sum of the curves of the cells on side `s`.
fn pooled(
    cells: &RegionCells,
    curves: &[Option<Vec<f32>>],
    side: &[Option<u8>],
    s: u8,
) -> Option<Vec<f64>> {
    summed(
        cells,
        curves,
        (0..side.len()).filter(|&k| side[k] == Some(s)),
    )
}

/// The depth of a division: how much worse each side's pooled curve does at the other side's
/// σ (its minimum) than at its own (relative; the smaller of the two, 0 when both sides prefer
/// the same σ).
fn depth(cells: &RegionCells, curves: &[Option<Vec<f32>>], side: &[Option<u8>]) -> Option<f64> {
    let [Some(p0), Some(p1)] = [0, 1].map(|s| pooled(cells, curves, side, s)) else {
        return None;
    };
    let (a, b) = (argmin(&p0)?, argmin(&p1)?);
    Some(excess(&p0, a, b).min(excess(&p1, b, a)))
}

/// The weighted share of the cells both cuts saw that they put on the same side.
fn agreement(cells: &RegionCells, a: &Cut, b: &Cut) -> f64 {
    let (mut same, mut both) = (0.0, 0.0);
    for k in 0..cells.ids.len() {
        if let (Some(x), Some(y)) = (a.side[k], b.side[k]) {
            both += cells.weight[k];
            if x == y {
                same += cells.weight[k];
            }
        }
    }
    if both > 0.0 {
        same / both
    } else {
        0.0
    }
}

/// What the gloss split measured on one region (for `fipt profile` and the logs).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GlossCut {
    pub region: u32,
    /// Each side's σ (glossier first), its share of the region's pixels, and the share of
    /// cells the two halves' cuts agree on.
    pub sigma: [f32; 2],
    pub share: f64,
    pub agreement: f64,
    /// How much worse each side's curve does at the other side's σ (relative; the smaller).
    pub depth: f64,
    /// Whether the region divided.
    pub divided: bool,
    /// Whether the region's colour division stood against the cut (`gloss_cut_depth` deep
    /// itself, or deeper than the cut): the region stays divided by colour.
    #[serde(default)]
    pub colour_stands: bool,
}

/// `base` (the colour split) with regions divided by gloss where the views say their finish
/// changes (see the module): a region the colour leaves whole, or one whose colour sides are
/// a shallower division than the gloss cut (a wood checker over tiles of two finishes); also
/// what was measured on each region that could be cut.
#[allow(clippy::too_many_arguments)]
pub fn gloss_split(
    base: ColourSplit,
    pixels: &[SearchPixel],
    voxels: &[[i32; 3]],
    shadings: &[ViewShadings],
    images: &[Image],
    grid: &[f32],
    min_pixels: usize,
    cfg: &SplitConfig,
) -> (ColourSplit, Vec<GlossCut>) {
    let regions = base.sub.len();
    if !cfg.by_gloss || grid.len() < 2 || voxels.is_empty() {
        return (base, vec![]);
    }
    let mut by_cell: Vec<Vec<usize>> = vec![vec![]; voxels.len()];
    let mut region_of = vec![u32::MAX; voxels.len()];
    for (j, p) in pixels.iter().enumerate() {
        by_cell[p.cell as usize].push(j);
        region_of[p.cell as usize] = p.region;
    }
    let mut members: Vec<Vec<usize>> = vec![vec![]; regions];
    for (c, &r) in region_of.iter().enumerate() {
        if (r as usize) < regions && !by_cell[c].is_empty() {
            members[r as usize].push(c);
        }
    }
    // Regions too small to hold two sides are not cut: their cells need no curves.
    let cuttable: Vec<bool> = (members.iter())
        .map(|ids| {
            let n: usize = ids.iter().map(|&c| by_cell[c].len()).sum();
            ids.len() >= 2 && n >= 2 * min_pixels.max(1)
        })
        .collect();
    let wanted: Vec<bool> = (region_of.iter())
        .map(|&r| cuttable.get(r as usize) == Some(&true))
        .collect();
    let sets = [Views::All, Views::Parity(0), Views::Parity(1)].map(|v| {
        let means = cfg.gloss_view_means;
        cell_curves(&by_cell, &wanted, pixels, shadings, images, grid, v, means)
    });
    let mut out = base;
    out.side.resize(voxels.len().max(out.side.len()), 0);
    let mut measured = vec![];
    for (r, ids) in members.into_iter().enumerate() {
        if !cuttable[r] {
            continue;
        }
        let cells = RegionCells::new(ids, voxels, &by_cell, cfg.gloss_radius as i32);
        let Some(found) = measure(&cells, &sets, grid, min_pixels, cfg) else {
            continue;
        };
        let (mut cut, all) = found;
        // A colour division stands when it is deep itself (two finishes that follow the
        // colour), and otherwise unless the gloss cut is the deeper one.
        let by_colour = out.sub[r].map(|_| {
            let side: Vec<Option<u8>> = cells.ids.iter().map(|&c| Some(out.side[c])).collect();
            depth(&cells, &sets[0], &side).unwrap_or(0.0)
        });
        let gate = cfg.gloss_cut_depth as f64;
        let deep_colour = by_colour.is_some_and(|d| d >= gate);
        cut.colour_stands = by_colour.is_some_and(|d| !(d < gate && all.depth > d));
        cut.divided &= !cut.colour_stands;
        cut.region = r as u32;
        if cut.divided {
            for (k, &c) in cells.ids.iter().enumerate() {
                out.side[c] = all.side[k].unwrap_or(0);
            }
            out.sub[r] = Some(u32::MAX);
        }
        // A division as deep on the curves as a gloss cut must be is as firm as one: its
        // dielectric sides are not asked the profiles' depth again (`split::sides_differ`,
        // with `gloss_view_means`: otherwise these curves are per pixel too).
        if cut.divided || deep_colour {
            out.deep_per_view.resize(regions, false);
            out.deep_per_view[r] = true;
        }
        measured.push(cut);
    }
    // Second sides numbered after the regions, in region order.
    for (next, s) in (regions as u32..).zip(out.sub.iter_mut().flatten()) {
        *s = next;
    }
    (out, measured)
}

/// The gloss cut of one region on all the views and on each half, and whether it divides
/// the region (`region` is left for the caller).
fn measure(
    cells: &RegionCells,
    sets: &[Vec<Option<Vec<f32>>>; 3],
    grid: &[f32],
    min_pixels: usize,
    cfg: &SplitConfig,
) -> Option<(GlossCut, Cut)> {
    let smooth = cfg.gloss_smoothness;
    let all = cut(cells, &sets[0], smooth)?;
    let agree = match [cut(cells, &sets[1], smooth), cut(cells, &sets[2], smooth)] {
        [Some(a), Some(b)] => agreement(cells, &a, &b),
        _ => 0.0,
    };
    let on = |s: u8| -> f64 {
        (0..cells.ids.len())
            .filter(|&k| all.side[k] == Some(s))
            .map(|k| cells.weight[k])
            .sum()
    };
    let (w0, w1) = (on(0), on(1));
    let share = w1 / (w0 + w1).max(1e-12);
    let sigma = all.sigma.map(|k| grid[k]);
    let divided = agree >= cfg.gloss_agreement as f64
        && all.depth >= cfg.gloss_cut_depth as f64
        && share.min(1.0 - share) >= cfg.min_share as f64
        && w0.min(w1) >= min_pixels as f64
        && sigma[1] - sigma[0] >= cfg.sigma_gap - 1e-4;
    let found = GlossCut {
        region: 0,
        sigma,
        share,
        agreement: agree,
        depth: all.depth,
        divided,
        colour_stands: false,
    };
    Some((found, all))
}

#[cfg(test)]
mod tests;
