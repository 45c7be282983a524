//! `fipt-search`: FIPT's material search over the factorised shadings (the algorithm; the run's
//! stage around it, with its caches and regions, is `fipt_method::search`). It imports the
//! shadings' types and the primary hits, never the pipeline: per region, the image loss as a function of
//! roughness σ and metallic m, and the (σ, m) it prefers.
//!
//! For a fixed (σ, m) the factorised image is linear in the base colour a:
//! `I ≈ a·b + c` with `b = (1 − m)·Ld(σ) + m·Ls0(σ)` and `c = 0.04·(1 − m)·Ls0(σ) + Ls1(σ)`
//! (kd = a·(1 − m), ks = 0.04·(1 − m) + a·m; Ld(σ) is constant under FIPT's model and a
//! polynomial in σ under `principled`, see [`fipt_core::reflectance`]). So at every candidate (σ, m) the best base colour
//! of each surface cell (the pixels of all views whose primary hit falls in one small voxel) is a
//! weighted least-squares fit in closed form, and what is left is the part of the views that
//! this (σ, m) cannot explain: how the cell's radiance changes with the viewing direction. The
//! search sums that residual over each region (a part, or a patch of the mesh) and keeps the
//! roughest σ and the non-metal answer unless the data prefers another by a stated margin.
//! Nothing here saturates or depends on an initialisation: it is an exhaustive search on a grid.
//!
//! [`profile`] computes the cost curves (also with a given base colour, the diagnostic of how
//! well the shadings explain the views at the true materials); [`choose`] turns a curve into a
//! decision. The residual is the training's: squared difference of sRGB-encoded values (no
//! clamp), averaged over pixels and channels.
use fipt_core::color::{srgb_oetf, Rgb};
use fipt_core::dataset::{Dataset, GtKind, Split};
use fipt_core::image::Image;
use fipt_core::shading::{level_segment, ViewShadings};
use fipt_shading::records::PrimaryHit;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// One training pixel taking part in the search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchPixel {
    pub view: u32,
    pub pixel: u32,
    pub region: u32,
    /// Surface cell (dense, unique across regions).
    pub cell: u32,
    /// The pixel clipped (an LDR view's highlight): its value is a lower bound on the
    /// radiance, so it takes no part in the base colour's fit and costs only where a
    /// candidate predicts less.
    pub clipped: bool,
}

/// The base colour at each candidate: fitted per surface cell, or given per pixel (the
/// diagnostic with ground truth).
pub enum Albedo<'a> {
    Fitted,
    /// Base colour a of each entry of the pixel list.
    Given(&'a [Rgb]),
}

/// The cost of every candidate for one region: `cost[mi][si]` is the mean squared sRGB error
/// at `metallic[mi]`, `sigma[si]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RegionProfile {
    pub region: u32,
    pub pixels: usize,
    pub cells: usize,
    pub sigma: Vec<f32>,
    pub metallic: Vec<f32>,
    pub cost: Vec<Vec<f64>>,
    /// With a given base colour only: `gain[mi][si]`, the linear least-squares scale of the
    /// views against the model, Σ I·P / Σ P·P over the region's pixels (1: the shadings carry
    /// the right amount of light; 1.1: they miss a tenth of it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gain: Vec<Vec<f64>>,
    /// The dielectric row (m = 0) with one base colour for the whole region instead of one
    /// per surface cell, where the search computed it (`one_colour_below` above 0; empty
    /// elsewhere).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub one_colour: Vec<f64>,
}

/// What the search decided for a region, with the evidence. None: no target (too few pixels,
/// or no σ evidence beyond the tolerance).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RegionChoice {
    pub region: u32,
    pub pixels: usize,
    pub roughness: Option<f32>,
    pub metallic: Option<f32>,
    /// The minimum over σ for each metallic candidate, and where it is.
    pub best_cost: Vec<f64>,
    pub argmin_sigma: Vec<f32>,
    /// Cost at (σ = 1, m = 0), the default answer.
    pub default_cost: f64,
    /// Where each half of the views (even, odd) puts its minimum over σ at the chosen
    /// metallic, when the search profiled the halves: how firmly the views pin σ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub halves_sigma: Option<[f32; 2]>,
}

/// The base colour a of the metallic workflow from a material's kd, ks and metallic as the
/// ground-truth maps store them: kd for a dielectric, ks (= a) for a metal.
pub fn base_colour(kd: Rgb, ks: Rgb, metallic: f32) -> Rgb {
    if metallic > 0.5 {
        ks
    } else {
        kd
    }
}

/// The true base colour ([`base_colour`]) at each of `pixels`, from `split`'s ground-truth
/// DiffCol, Specular and Metallic maps; None when the split lacks one of them.
pub fn true_base_colours(
    ds: &Dataset,
    split: &Split,
    pixels: &[SearchPixel],
) -> fipt_core::Result<Option<Vec<Rgb>>> {
    let kinds = [GtKind::DiffCol, GtKind::Specular, GtKind::Metallic];
    if !kinds.iter().all(|&k| split.has_gt(k)) {
        return Ok(None);
    }
    let mut maps = Vec::with_capacity(split.views.len());
    for v in &split.views {
        let mut m = [vec![], vec![], vec![]];
        for (slot, &kind) in m.iter_mut().zip(&kinds) {
            *slot = ds
                .load_gt(split, kind, v.index)?
                .map(|i| i.data)
                .unwrap_or_default();
        }
        maps.push(m);
    }
    Ok(Some(
        pixels
            .iter()
            .map(|p| {
                let [kd, ks, m] = &maps[p.view as usize];
                let i = p.pixel as usize;
                base_colour(kd[i], ks[i], m[i].x)
            })
            .collect(),
    ))
}

/// The σ candidates: `steps` values evenly spaced over `[lo, hi]`.
pub fn sigma_grid(lo: f32, hi: f32, steps: usize) -> Vec<f32> {
    let n = steps.max(2);
    (0..n)
        .map(|i| lo + (hi - lo) * i as f32 / (n - 1) as f32)
        .collect()
}

/// The surface cell (voxel of edge 1/`inv`) holding `p`.
#[inline]
/// The surface cell (voxel of edge `cell`) a point falls in.
pub fn voxel(p: Vec3, cell: f32) -> [i32; 3] {
    cell_of(p, 1.0 / cell.max(1e-9))
}

fn cell_of(p: Vec3, inv: f32) -> [i32; 3] {
    let q = (p * inv).floor();
    [q.x as i32, q.y as i32, q.z as i32]
}

/// Dense cell ids for `points` (with their region): voxels of edge `cell` per region.
pub fn cell_ids(points: &[(Vec3, u32)], cell: f32) -> Vec<u32> {
    cell_ids_keyed(points, cell).0
}

/// [`cell_ids`] and the voxel of each cell id.
pub fn cell_ids_keyed(points: &[(Vec3, u32)], cell: f32) -> (Vec<u32>, Vec<[i32; 3]>) {
    let inv = 1.0 / cell.max(1e-9);
    let mut map: HashMap<(u32, [i32; 3]), u32> = HashMap::new();
    let mut voxels = vec![];
    let ids = points
        .iter()
        .map(|&(p, r)| {
            let v = cell_of(p, inv);
            *map.entry((r, v)).or_insert_with(|| {
                voxels.push(v);
                voxels.len() as u32 - 1
            })
        })
        .collect();
    (ids, voxels)
}

/// How many training pixels fall in each surface cell: where the views observed a surface
/// (`{k:03}_observed.exr`), so users know where to trust the maps.
#[derive(Clone)]
pub struct CellCounts {
    inv: f32,
    counts: HashMap<[i32; 3], u32>,
}

impl CellCounts {
    /// Counts of `points` in voxels of edge `cell`.
    pub fn new(points: impl IntoIterator<Item = Vec3>, cell: f32) -> Self {
        let inv = 1.0 / cell.max(1e-9);
        let mut counts: HashMap<[i32; 3], u32> = HashMap::new();
        for p in points {
            *counts.entry(cell_of(p, inv)).or_default() += 1;
        }
        CellCounts { inv, counts }
    }

    /// Training pixels in the cell of `p` (0: never observed).
    pub fn count(&self, p: Vec3) -> u32 {
        self.counts.get(&cell_of(p, self.inv)).copied().unwrap_or(0)
    }

    /// The cell of `p`.
    pub fn cell(&self, p: Vec3) -> [i32; 3] {
        cell_of(p, self.inv)
    }
}

/// A search pixel before its surface cell is known: (view, pixel, region, point).
pub type KeyedPixel = (u32, u32, u32, Vec3);

/// The search's pixels of the training views: every valid pixel whose `region_of` is `Some`,
/// with cells of edge `cell`.
pub fn gather_pixels<R: PrimaryHit>(
    records: &[Vec<Option<R>>],
    shadings: &[ViewShadings],
    cell: f32,
    region_of: &dyn Fn(usize, usize, &R) -> Option<u32>,
) -> Vec<SearchPixel> {
    gather_pixels_keyed(records, shadings, cell, region_of).0
}

/// [`gather_pixels`] and the voxel of each surface cell.
pub fn gather_pixels_keyed<R: PrimaryHit>(
    records: &[Vec<Option<R>>],
    shadings: &[ViewShadings],
    cell: f32,
    region_of: &dyn Fn(usize, usize, &R) -> Option<u32>,
) -> (Vec<SearchPixel>, Vec<[i32; 3]>) {
    let mut keyed = vec![];
    for (v, (recs, sh)) in records.iter().zip(shadings).enumerate() {
        keyed.extend(view_pixels(v, recs, &sh.valid, region_of));
    }
    with_cells_keyed(&keyed, cell)
}

/// View `v`'s search pixels: every pixel with a hit, `valid` shadings and a region from
/// `region_of`, in pixel order.
pub fn view_pixels<R: PrimaryHit>(
    v: usize,
    recs: &[Option<R>],
    valid: &[bool],
    region_of: &dyn Fn(usize, usize, &R) -> Option<u32>,
) -> Vec<KeyedPixel> {
    let mut keyed = vec![];
    for (i, r) in recs.iter().enumerate() {
        let Some(r) = r else { continue };
        if !valid.get(i).copied().unwrap_or(false) {
            continue;
        }
        if let Some(region) = region_of(v, i, r) {
            keyed.push((v as u32, i as u32, region, r.point()));
        }
    }
    keyed
}

/// The search pixels of `keyed` with their surface cells (edge `cell`).
pub fn with_cells(keyed: &[KeyedPixel], cell: f32) -> Vec<SearchPixel> {
    with_cells_keyed(keyed, cell).0
}

/// [`with_cells`] and the voxel of each cell ([`voxel`]).
pub fn with_cells_keyed(keyed: &[KeyedPixel], cell: f32) -> (Vec<SearchPixel>, Vec<[i32; 3]>) {
    let pts: Vec<(Vec3, u32)> = keyed.iter().map(|k| (k.3, k.2)).collect();
    let (cells, voxels) = cell_ids_keyed(&pts, cell);
    let pixels = keyed
        .iter()
        .zip(cells)
        .map(|(&(view, pixel, region, _), cell)| SearchPixel {
            view,
            pixel,
            region,
            cell,
            clipped: false,
        })
        .collect();
    (pixels, voxels)
}

/// Per region, from its [`outline_shares`]: whether its outline is at most `share` of its
/// pixels over all views, so that leaving all of the outline out keeps most of it. A camera's
/// pixel on a silhouette mixes the object with what lies behind it. False for every region
/// when `share` is 0, and for a region without pixels.
pub fn small_outlines(shares: &[Option<f64>], share: f32) -> Vec<bool> {
    (shares.iter())
        .map(|s| share > 0.0 && s.is_some_and(|s| s <= f64::from(share)))
        .collect()
}

/// Per region of `n` (ids per view and pixel, `widths` of the views, `none` for no region):
/// the share of its pixels over all views that lie on its outline ([`on_region_edge`] with
/// every neighbour counting: one of the 8 in another region or in none); None for a region
/// without pixels.
pub fn outline_shares(ids: &[Vec<u32>], widths: &[usize], n: usize, none: u32) -> Vec<Option<f64>> {
    let outline = |v: usize, i: usize| on_region_edge(&ids[v], widths[v], i, &|_| true);
    region_shares(ids, n, none, &outline)
}

/// Per region of `n` (ids per view and pixel, `none` for no region): the share of its pixels
/// over all views for which `on(view, pixel)` holds; None for a region without pixels.
pub fn region_shares(
    ids: &[Vec<u32>],
    n: usize,
    none: u32,
    on: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Vec<Option<f64>> {
    use rayon::prelude::*;
    let add = |mut a: Vec<[u64; 2]>, b: Vec<[u64; 2]>| {
        a.iter_mut().zip(b).for_each(|(x, y)| {
            x[0] += y[0];
            x[1] += y[1];
        });
        a
    };
    let counts = (ids.par_iter().enumerate())
        .map(|(v, ids)| {
            let mut c = vec![[0u64; 2]; n];
            for (i, &r) in ids.iter().enumerate() {
                if let Some(c) = c.get_mut(r as usize).filter(|_| r != none) {
                    c[0] += 1;
                    c[1] += on(v, i) as u64;
                }
            }
            c
        })
        .reduce(|| vec![[0u64; 2]; n], add);
    (counts.iter())
        .map(|&[all, on]| (all > 0).then(|| on as f64 / all as f64))
        .collect()
}

/// Whether pixel `i` of a view (`width` pixels a row, region `ids` per pixel) has a neighbour
/// among the 8 around it whose region differs from its own (no region, None or a sentinel
/// id, counts as a region of its own; neighbours off the image do not count) and that `counts` (e.g. one much brighter).
pub fn on_region_edge<T: PartialEq>(
    ids: &[T],
    width: usize,
    i: usize,
    counts: &dyn Fn(usize) -> bool,
) -> bool {
    if width == 0 {
        return false;
    }
    let (x, y) = ((i % width) as isize, (i / width) as isize);
    let height = (ids.len() / width) as isize;
    for dy in -1..=1isize {
        for dx in -1..=1isize {
            let (nx, ny) = (x + dx, y + dy);
            if (dx, dy) == (0, 0) || nx < 0 || ny < 0 || nx >= width as isize || ny >= height {
                continue;
            }
            let j = ny as usize * width + nx as usize;
            if ids[j] != ids[i] && counts(j) {
                return true;
            }
        }
    }
    false
}

/// Whether pixel `i` of a view (ids and hits per pixel, `width` wide, seen from `eye`) lies
/// on a silhouette: a neighbour (of the 8) in another region, or in none, that `counts` (e.g.
/// one of another brightness) has no hit or a hit farther from pixel i's than `gap` × pixel
/// i's distance to the camera. Across an occlusion a pixel's footprint mixes two surfaces at
/// different depths; where two regions meet at one depth (a crease) the neighbours' hits are
/// close and this is false.
pub fn on_silhouette<T: PartialEq, R: PrimaryHit>(
    ids: &[T],
    hits: &[Option<R>],
    width: usize,
    i: usize,
    eye: Vec3,
    gap: f32,
    counts: &dyn Fn(usize) -> bool,
) -> bool {
    let Some(p) = hits[i].as_ref().map(PrimaryHit::point) else {
        return false;
    };
    let far = gap * p.distance(eye);
    let apart = |j: usize| hits[j].as_ref().is_none_or(|q| q.point().distance(p) > far);
    on_region_edge(ids, width, i, &|j| apart(j) && counts(j))
}

#[inline]
fn oetf_grad(x: f32) -> f32 {
    fipt_core::color::srgb_oetf_grad(x.max(1e-3))
}

/// (b, c) of the linear model `a·b + c` at (σ, m) for one pixel.
#[inline]
pub(crate) fn linear_terms(sh: &ViewShadings, i: usize, sigma: f32, m: f32) -> (Rgb, Rgb) {
    let (k, t) = level_segment(&sh.levels, sigma);
    let s0 = sh.ls0[i][k] * (1.0 - t) + sh.ls0[i][k + 1] * t;
    let s1 = sh.ls1[i][k] * (1.0 - t) + sh.ls1[i][k + 1] * t;
    fipt_core::reflectance::image_linear_in_base_color(sh.diffuse(i, sigma), s0, s1, m)
}

/// The weighted least-squares base colour of `a·b + c` over a set of pixels at one (σ, m):
/// each channel's squared sRGB error linearised at the pixel's value (weight: the sRGB slope
/// squared). Shared by the search's profiles and the colour split.
#[derive(Clone, Copy, Default)]
pub(crate) struct AlbedoFit {
    sbb: Vec3,
    sbr: Vec3,
}

impl AlbedoFit {
    /// Adds search pixel `p` (of `shadings` and `images`) at (σ, m).
    #[inline]
    pub(crate) fn add(
        &mut self,
        shadings: &[ViewShadings],
        images: &[Image],
        p: &SearchPixel,
        sigma: f32,
        m: f32,
    ) {
        let (b, c) = linear_terms(&shadings[p.view as usize], p.pixel as usize, sigma, m);
        self.add_terms(&Observed::of_pixel(p, images), b, c);
    }

    /// Adds a pixel whose linear terms at the candidate are `(b, c)`.
    #[inline]
    pub(crate) fn add_terms(&mut self, o: &Observed, b: Rgb, c: Rgb) {
        self.sbb += o.w * b * b;
        self.sbr += o.w * b * (o.g - c);
    }

    /// The fitted base colour (0 in a channel without evidence), unclamped.
    pub(crate) fn albedo(&self) -> Rgb {
        Vec3::select(
            self.sbb.cmpgt(Vec3::splat(1e-20)),
            self.sbr / self.sbb,
            Vec3::ZERO,
        )
    }
}

/// What the search's losses read of one pixel whatever the candidate (σ, m): its value, the
/// value's sRGB encoding and the squared sRGB slope there (its weight in the base-colour fit).
/// Computed once per pixel rather than once per candidate: the same numbers, a third of the
/// `powf` calls.
#[derive(Clone, Copy)]
pub(crate) struct Observed {
    g: Rgb,
    enc: Rgb,
    /// The weight in the base-colour fit: 0 for a clipped pixel (a lower bound), above 0
    /// for every other.
    w: Rgb,
}

/// A colour's sRGB encoding, channel by channel.
#[inline]
pub(crate) fn srgb_encoded(c: Rgb) -> Rgb {
    Vec3::new(srgb_oetf(c.x), srgb_oetf(c.y), srgb_oetf(c.z))
}

impl Observed {
    #[inline]
    pub(crate) fn of(g: Rgb) -> Self {
        let w = Vec3::new(oetf_grad(g.x), oetf_grad(g.y), oetf_grad(g.z));
        Observed {
            g,
            enc: srgb_encoded(g),
            w: w * w,
        }
    }

    /// Search pixel `p` of `images`.
    #[inline]
    pub(crate) fn of_pixel(p: &SearchPixel, images: &[Image]) -> Self {
        let o = Observed::of(images[p.view as usize].data[p.pixel as usize]);
        if p.clipped {
            Observed { w: Vec3::ZERO, ..o }
        } else {
            o
        }
    }

    /// The pixels `at` of `pixels`, in that order.
    pub(crate) fn of_pixels(at: &[usize], pixels: &[SearchPixel], images: &[Image]) -> Vec<Self> {
        (at.par_iter())
            .map(|&j| Observed::of_pixel(&pixels[j], images))
            .collect()
    }

    /// The pixel's value, sRGB-encoded.
    #[inline]
    pub(crate) fn encoded(&self) -> Rgb {
        self.enc
    }

    /// The squared sRGB error of `pred` against the pixel's value, summed over the channels;
    /// for a clipped pixel only where `pred` lies below it.
    #[inline]
    pub(crate) fn sq_err(&self, pred: Rgb) -> f64 {
        let lower = self.w == Vec3::ZERO;
        let e = |p: f32, enc: f32| {
            let d = srgb_oetf(p) - enc;
            if lower && d > 0.0 {
                0.0
            } else {
                (d * d) as f64
            }
        };
        e(pred.x, self.enc.x) + e(pred.y, self.enc.y) + e(pred.z, self.enc.z)
    }
}

/// The pixels' indices grouped by region, then by cell, and each region's cells as ranges of
/// that order.
#[allow(clippy::type_complexity)]
fn cell_spans(
    pixels: &[SearchPixel],
    regions: usize,
) -> (Vec<usize>, Vec<Vec<std::ops::Range<usize>>>) {
    let mut order: Vec<usize> = (0..pixels.len()).collect();
    order.sort_unstable_by_key(|&j| (pixels[j].region, pixels[j].cell, j));
    let mut spans: Vec<Vec<std::ops::Range<usize>>> = vec![vec![]; regions];
    let mut s = 0;
    while s < order.len() {
        let p = pixels[order[s]];
        let mut e = s + 1;
        while e < order.len() && pixels[order[e]].cell == p.cell {
            e += 1;
        }
        if (p.region as usize) < regions {
            spans[p.region as usize].push(s..e);
        }
        s = e;
    }
    (order, spans)
}

/// σ candidates per task of [`profile`]: a cell's pixels are read once for this many.
const SIGMA_RUN: usize = 10;

/// The cost curves of every region over the candidates `sigma` × `metallic`. Regions are
/// `0..regions`; a region without pixels gets an empty profile (`pixels` 0, costs NaN).
pub fn profile(
    pixels: &[SearchPixel],
    shadings: &[ViewShadings],
    images: &[Image],
    regions: usize,
    sigma: &[f32],
    metallic: &[f32],
    albedo: Albedo,
) -> Vec<RegionProfile> {
    let (order, spans) = cell_spans(pixels, regions);
    // In `order`'s order, so that a cell's pixels are read one after another.
    let observed = Observed::of_pixels(&order, pixels, images);
    // A task takes one region, one metallic and a run of σ candidates, and reads each cell's
    // pixels once for all of its candidates (they stay in cache), rather than once per
    // candidate. Each candidate's sums still add the pixels in the same order.
    let tasks: Vec<(usize, usize, std::ops::Range<usize>)> = (0..regions)
        .flat_map(|r| {
            (0..metallic.len()).flat_map(move |mi| {
                (0..sigma.len())
                    .step_by(SIGMA_RUN)
                    .map(move |s| (r, mi, s..(s + SIGMA_RUN).min(sigma.len())))
            })
        })
        .collect();
    let costs: Vec<(f64, f64)> = tasks
        .par_iter()
        .flat_map_iter(|(r, mi, run)| {
            let m = metallic[*mi];
            // Per candidate of the run: squared error, values, Σ pred·g, Σ pred·pred.
            let mut sums = vec![(0.0f64, 0usize, 0.0f64, 0.0f64); run.len()];
            // The cell's linear terms at a candidate, computed once for the fit and the cost.
            let mut terms: Vec<(Rgb, Rgb)> = vec![];
            for span in &spans[*r] {
                let (idx, obs) = (&order[span.clone()], &observed[span.clone()]);
                for (sum, &sg) in sums.iter_mut().zip(&sigma[run.clone()]) {
                    terms.clear();
                    terms.extend(idx.iter().map(|&j| {
                        let p = pixels[j];
                        linear_terms(&shadings[p.view as usize], p.pixel as usize, sg, m)
                    }));
                    let fitted = match albedo {
                        Albedo::Fitted => {
                            let mut fit = AlbedoFit::default();
                            for (o, &(b, c)) in obs.iter().zip(&terms) {
                                fit.add_terms(o, b, c);
                            }
                            Some(fit.albedo().clamp(Vec3::ZERO, Vec3::ONE))
                        }
                        Albedo::Given(_) => None,
                    };
                    let (total, count, ip, pp) = sum;
                    for ((&j, o), &(b, c)) in idx.iter().zip(obs).zip(&terms) {
                        let a = match (&albedo, fitted) {
                            (_, Some(a)) => a,
                            (Albedo::Given(given), None) => given[j],
                            (Albedo::Fitted, None) => unreachable!(),
                        };
                        let pred = a * b + c;
                        *total += o.sq_err(pred);
                        *count += 3;
                        *ip += pred.dot(o.g) as f64;
                        *pp += pred.dot(pred) as f64;
                    }
                }
            }
            sums.into_iter().map(|(total, count, ip, pp)| {
                if count == 0 {
                    (f64::NAN, f64::NAN)
                } else {
                    (total / count as f64, ip / pp)
                }
            })
        })
        .collect();
    let per_region = metallic.len() * sigma.len();
    (0..regions)
        .map(|r| RegionProfile {
            region: r as u32,
            pixels: spans[r].iter().map(|s| s.len()).sum(),
            cells: spans[r].len(),
            sigma: sigma.to_vec(),
            metallic: metallic.to_vec(),
            cost: costs[r * per_region..(r + 1) * per_region]
                .chunks(sigma.len())
                .map(|c| c.iter().map(|x| x.0).collect())
                .collect(),
            gain: match albedo {
                Albedo::Fitted => vec![],
                Albedo::Given(_) => costs[r * per_region..(r + 1) * per_region]
                    .chunks(sigma.len())
                    .map(|c| c.iter().map(|x| x.1).collect())
                    .collect(),
            },
            one_colour: vec![],
        })
        .collect()
}

mod config;
pub use config::{DielectricRule, RegionSource, SearchConfig};

mod choice;
pub use choice::choose;
use choice::{argmin, excess};

mod one_colour;
pub use one_colour::{one_cell_per_region, with_one_colour};

pub mod divided;
pub mod gloss;
mod mincut;
pub mod split;

#[cfg(test)]
mod minimum_rule_tests;
#[cfg(test)]
mod tests;
